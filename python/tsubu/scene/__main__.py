"""``python -m tsubu.scene schema | reference | write-docs DOCS_DIR`` (tsubu.scene.reference.main)."""

import sys

from .reference import main

sys.exit(main())

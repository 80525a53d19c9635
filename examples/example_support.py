"""What the example scripts share: their command line's output options, the headless figure,
and reading back the .npz files they write. (Each example imports it from its own folder.)"""

from __future__ import annotations

import argparse
import json
import os

import numpy as np


def arguments(description: str, name: str) -> argparse.ArgumentParser:
    """A parser with the options every example has: --out, --figure, --no-figure."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--out", default=f"output/{name}", help="output folder")
    parser.add_argument("--figure", default=None, help=f"PNG to write (default: OUT/{name}.png)")
    parser.add_argument("--no-figure", action="store_true", help="write the data only")
    return parser


def figure_path(args: argparse.Namespace, name: str) -> str | None:
    """Where the figure goes, or None for --no-figure."""
    return None if args.no_figure else args.figure or os.path.join(args.out, f"{name}.png")


def pyplot():
    """matplotlib.pyplot drawing off-screen (Agg), or SystemExit saying how to get it."""
    try:
        import matplotlib
    except ImportError:
        raise SystemExit("the figure needs matplotlib: pip install matplotlib "
                         "(or tsubu's bench extra), or pass --no-figure") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save_figure(fig, path: str) -> None:
    """Write the figure as a PNG (its folder made if missing) and free it."""
    import matplotlib.pyplot as plt

    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_json(path: str, summary) -> None:
    """The summary an example prints, as JSON beside its data."""
    with open(path, "w") as f:
        json.dump(summary, f, indent=2)


def read_npz(path) -> dict:
    """The arrays of an .npz file, the file closed again."""
    with np.load(path) as z:
        return {k: z[k] for k in z.files}

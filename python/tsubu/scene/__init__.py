"""Scene files: a whole simulation described in TOML, for ``tsubu run scene.toml``.

A scene file names the materials, the walls (planes and triangle meshes, with motion schedules:
a gate that opens, a drum that spins up), where the spheres come from (a generator, an inserter
or a file), the simulation's options, how long to run and what to write. The format is
defined once, by the declarative spec ``SPEC``: the loader validates with it (every bad or
unknown key is reported with its path in the file and its value), and the JSON Schema
(``docs/scene.schema.json``) and the key reference in ``docs/scene-format.md`` are generated
from it (``python -m tsubu.scene write-docs docs`` rewrites both).

Values that pass the spec are then handed to tsubu's own constructors (:class:`tsubu.Material`,
:class:`tsubu.Simulation`, ``add_plane``, the generators of :mod:`tsubu.fill`, ...); a
ValueError or TypeError they raise is reported at the path of the argument it names.

The public API (``__all__``): :func:`load_scene` (file to a ready :class:`Scene`),
:func:`scene_from_dict`, :func:`read_toml`, :func:`validate` (checks only), :func:`resume` (a
checkpoint written by a scene run back to a :class:`Scene`), :class:`SceneError` and
:data:`MISSING`, :data:`FORMAT_VERSION`, and the format's documents :func:`json_schema` and
:func:`reference_markdown`. The spec's node classes (``Number``, ``Table``, ...) are internal.

The package has one module per job:

* ``tsubu.scene.language``: the schema language (the spec's node classes, :class:`SceneError`);
* ``tsubu.scene.spec``: the format itself, ``SPEC``, written in that language;
* ``tsubu.scene.builder``: reading, validating and building a scene, and :func:`resume`;
* ``tsubu.scene.reference``: the JSON Schema and the key reference generated from ``SPEC``
  (``python -m tsubu.scene``).
"""

from __future__ import annotations

from . import language as _language, spec as _spec
from .builder import Scene, load_scene, read_toml, resume, scene_from_dict, validate
from .language import (_BAD, ArrayOf, Boolean, Field, Integer, MapOf, Node, Number,
                       NumberList, SceneError, String, Table, Tagged, Vector, show)
from .reference import (REFERENCE_BEGIN, REFERENCE_END, json_schema, main, reference_markdown,
                        schema_text, with_reference)
from .spec import SPEC

#: The value of a :class:`SceneError` entry for a key that is missing (or an error about the file
#: as a whole), where there is no value to show.
MISSING = _language.MISSING

#: The version of the scene format (an int), stored in the metadata of the checkpoints that scene
#: runs write; :func:`resume` refuses a newer one.
FORMAT_VERSION = _spec.FORMAT_VERSION

__all__ = ["load_scene", "scene_from_dict", "read_toml", "validate", "resume", "Scene", "SceneError",
           "MISSING", "FORMAT_VERSION", "json_schema", "reference_markdown"]

"""Scene files: a whole simulation described in TOML, for ``tsubu run scene.toml``.

A scene file names the materials, the walls, where the spheres come from (a generator, an
inserter or a file), the simulation's options, how long to run and what to write. The format is
defined once, by the declarative spec ``SPEC`` in this module: the loader validates with it
(every bad or unknown key is reported with its path in the file and its value), and the JSON
Schema (``docs/scene.schema.json``) and the key reference in ``docs/scene-format.md`` are
generated from it (``python -m tsubu.scene write-docs docs`` rewrites both).

Values that pass the spec are then handed to tsubu's own constructors (:class:`tsubu.Material`,
:class:`tsubu.Simulation`, ``add_plane``, the generators of :mod:`tsubu.fill`, ...); a
ValueError or TypeError they raise is reported at the path of the argument it names.

The public API (``__all__``): :func:`load_scene` (file to a ready :class:`Scene`),
:func:`scene_from_dict`, :func:`read_toml`, :func:`validate` (checks only), :func:`resume` (a
checkpoint written by a scene run back to a :class:`Scene`), :class:`SceneError` and
:data:`MISSING`, :data:`FORMAT_VERSION`, and the format's documents :func:`json_schema` and
:func:`reference_markdown`. The spec's node classes (``Number``, ``Table``, ...) are internal.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import numbers
import os
import re
import sys
from typing import Any, Callable

import numpy as np

from . import _core
from .material import Material
from .simulation import Simulation

__all__ = ["load_scene", "scene_from_dict", "read_toml", "validate", "resume", "Scene", "SceneError",
           "MISSING", "FORMAT_VERSION", "json_schema", "reference_markdown"]

#: The version of the scene format (an int), stored in the metadata of the checkpoints that scene
#: runs write; :func:`resume` refuses a newer one.
FORMAT_VERSION = 1


class SceneError(ValueError):
    """A scene that cannot be run: a bad, missing or unknown key, a bad value, or a file that
    cannot be read.

    ``errors`` is a list of ``(path, value, message)``: ``path`` is the key's path in the file
    (``"materials.glass.restitution"``, ``"walls[0].normal"``; "" for the file as a whole),
    ``value`` the value found (or :data:`MISSING`). ``source`` is the file's name (or None).
    ``str()`` gives one line per error: ``<source>: <path> = <value>: <message>``.
    """

    def __init__(self, errors: list, source: str | None = None):
        self.errors = list(errors)
        self.source = source
        super().__init__("\n".join(self.lines()))

    def lines(self) -> list[str]:
        """The errors as lines of text, ``<source>: <path> = <value>: <message>`` each."""
        prefix = f"{self.source}: " if self.source else ""
        return [prefix + _error_line(path, value, message) for path, value, message in self.errors]


class _Missing:
    def __repr__(self) -> str:
        return "MISSING"


#: The value of a :class:`SceneError` entry for a key that is missing (or an error about the file
#: as a whole), where there is no value to show.
MISSING = _Missing()
_BAD = object()  # a value that failed its check (the error is already recorded)


def _error_line(path: str, value, message: str) -> str:
    if not path:
        return message
    if value is MISSING:
        return f"{path}: {message}"
    return f"{path} = {show(value)}: {message}"


def show(value, limit: int = 60) -> str:
    """A value as it would be written in TOML, shortened to about ``limit`` characters."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, str):
        text = json.dumps(value, ensure_ascii=False)
    elif isinstance(value, float):
        text = "nan" if math.isnan(value) else ("inf" if value == math.inf else
                                                  "-inf" if value == -math.inf else repr(value))
    elif isinstance(value, dict):
        text = "{" + ", ".join(f"{_key(k)} = {show(v, limit)}" for k, v in value.items()) + "}"
    elif isinstance(value, (list, tuple)):
        text = "[" + ", ".join(show(v, limit) for v in value) + "]"
    else:
        text = str(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _key(name: str) -> str:
    return name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else json.dumps(name)


def _join(path: str, key) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{_key(key)}" if path else _key(key)


# ---- the spec's node types ---------------------------------------------------------------------
# Each node checks a value (appending (path, value, message) to errors and returning _BAD when it
# is wrong), describes itself as a JSON Schema and as a short type for the reference.


class Node:
    """A node of the scene format's spec (internal: the spec, ``SPEC``, is made of these)."""

    def check(self, value, path: str, errors: list):
        """The checked ``value`` (numbers as floats, ...), or ``_BAD`` after appending
        ``(path, value, message)`` to ``errors``; ``path`` is the value's path in the file."""
        raise NotImplementedError

    def schema(self) -> dict:
        """This node as a JSON Schema."""
        raise NotImplementedError

    def kind(self) -> str:
        """A short type for the key reference ("number", "array of 3 numbers", ...)."""
        raise NotImplementedError


def _is_number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


@dataclasses.dataclass
class Number(Node):
    """A real number (TOML integer or float) with optional bounds."""

    unit: str = ""
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False
    exclusive_maximum: bool = False

    def _bounds(self) -> str:
        lo, hi = self.minimum, self.maximum
        if lo is not None and hi is not None:
            return (("(" if self.exclusive_minimum else "[") + f"{lo:g}, {hi:g}"
                    + (")" if self.exclusive_maximum else "]"))
        if lo is not None:
            return (">" if self.exclusive_minimum else ">=") + f" {lo:g}"
        if hi is not None:
            return ("<" if self.exclusive_maximum else "<=") + f" {hi:g}"
        return ""

    def check(self, value, path, errors):
        if not _is_number(value):
            errors.append((path, value, "must be a number" + (f" [{self.unit}]" if self.unit else "")))
            return _BAD
        v = float(value)
        lo, hi = self.minimum, self.maximum
        ok = (math.isfinite(v)
              and (lo is None or (v > lo if self.exclusive_minimum else v >= lo))
              and (hi is None or (v < hi if self.exclusive_maximum else v <= hi)))
        if not ok:
            bounds = self._bounds()
            if lo is not None and hi is not None:
                message = f"must be in {bounds}"
            elif bounds:
                message = f"must be a finite number {bounds}"
            else:
                message = "must be finite"
            errors.append((path, value, message))
            return _BAD
        return v

    def schema(self):
        s: dict = {"type": "number"}
        if self.minimum is not None:
            s["exclusiveMinimum" if self.exclusive_minimum else "minimum"] = self.minimum
        if self.maximum is not None:
            s["exclusiveMaximum" if self.exclusive_maximum else "maximum"] = self.maximum
        return s

    def kind(self):
        bounds = self._bounds()
        if bounds and self.minimum is not None and self.maximum is not None:
            bounds = "in " + bounds
        return "number" + (f" {bounds}" if bounds else "")


@dataclasses.dataclass
class Integer(Node):
    minimum: int | None = None
    maximum: int | None = None

    def check(self, value, path, errors):
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            errors.append((path, value, "must be an integer"))
            return _BAD
        if self.minimum is not None and value < self.minimum:
            errors.append((path, value, f"must be >= {self.minimum}"))
            return _BAD
        if self.maximum is not None and value > self.maximum:
            errors.append((path, value, f"must be <= {self.maximum}"))
            return _BAD
        return int(value)

    def schema(self):
        s: dict = {"type": "integer"}
        if self.minimum is not None:
            s["minimum"] = self.minimum
        if self.maximum is not None:
            s["maximum"] = self.maximum
        return s

    def kind(self):
        if self.minimum is not None and self.maximum is not None:
            return f"integer in [{self.minimum}, {self.maximum}]"
        if self.minimum is not None:
            return f"integer >= {self.minimum}"
        return "integer"


class Boolean(Node):
    def check(self, value, path, errors):
        if not isinstance(value, bool):
            errors.append((path, value, "must be true or false"))
            return _BAD
        return value

    def schema(self):
        return {"type": "boolean"}

    def kind(self):
        return "boolean"


@dataclasses.dataclass
class String(Node):
    """A string, one of ``choices`` when given."""

    choices: tuple = ()

    def check(self, value, path, errors):
        if not isinstance(value, str):
            errors.append((path, value, "must be a string"))
            return _BAD
        if self.choices and value not in self.choices:
            errors.append((path, value, "must be " + _listing(self.choices) + _closest(value, self.choices)))
            return _BAD
        if not self.choices and not value:
            errors.append((path, value, "must not be empty"))
            return _BAD
        return value

    def schema(self):
        return {"type": "string", "enum": list(self.choices)} if self.choices else {"type": "string", "minLength": 1}

    def kind(self):
        return " \\| ".join(f'`"{c}"`' for c in self.choices) if self.choices else "string"


@dataclasses.dataclass
class Vector(Node):
    """``length`` finite numbers (a TOML array)."""

    length: int = 3
    unit: str = ""
    nonzero: bool = False

    def check(self, value, path, errors):
        if (not isinstance(value, list) or len(value) != self.length
                or not all(_is_number(v) for v in value)):
            errors.append((path, value, f"must be an array of {self.length} numbers"
                           + (f" [{self.unit}]" if self.unit else "")))
            return _BAD
        v = [float(x) for x in value]
        if not all(math.isfinite(x) for x in v):
            errors.append((path, value, "must be finite"))
            return _BAD
        if self.nonzero and not any(v):
            errors.append((path, value, "must not be zero"))
            return _BAD
        return v

    def schema(self):
        s = {"type": "array", "items": {"type": "number"}, "minItems": self.length,
             "maxItems": self.length}
        if self.nonzero:
            s["not"] = {"items": {"const": 0}}
        return s

    def kind(self):
        return f"array of {self.length} numbers" + (", not all 0" if self.nonzero else "")


@dataclasses.dataclass
class NumberList(Node):
    """A non-empty array of numbers within the bounds of ``item``."""

    item: Number = dataclasses.field(default_factory=Number)
    min_items: int = 1

    def check(self, value, path, errors):
        if not isinstance(value, list) or len(value) < self.min_items:
            errors.append((path, value, f"must be an array of at least {self.min_items} numbers"))
            return _BAD
        out = [self.item.check(v, _join(path, k), errors) for k, v in enumerate(value)]
        return _BAD if any(v is _BAD for v in out) else out

    def schema(self):
        return {"type": "array", "items": self.item.schema(), "minItems": self.min_items}

    def kind(self):
        return f"array of numbers ({self.item.kind()})"


@dataclasses.dataclass
class Field:
    """A key of a table: its node, whether it is required, its default (for the reference;
    the value used is the constructor's own default), its unit and meaning."""

    node: Node
    doc: str
    required: bool = False
    default: str | None = None
    unit: str = ""
    example: str | None = None


@dataclasses.dataclass
class Table(Node):
    """A TOML table with known keys. ``exclusive``: groups of keys of which at most one may be
    given; ``one_of``: groups of which exactly one must be."""

    fields: dict
    doc: str = ""
    exclusive: tuple = ()
    one_of: tuple = ()
    name: str = ""  # the reference's heading

    def check(self, value, path, errors, *, skip: tuple = ()):
        if not isinstance(value, dict):
            errors.append((path, value, "must be a table"))
            return _BAD
        out = {}
        bad = False
        for key, item in value.items():
            if key in skip:
                continue
            sub = _join(path, key)
            if key not in self.fields:
                allowed = [k for k in self.fields]
                errors.append((sub, item, "unknown key; allowed: " + ", ".join(allowed)
                               + _closest(key, allowed, quote=False)))
                bad = True
                continue
            v = self.fields[key].node.check(item, sub, errors)
            if v is _BAD:
                bad = True
            else:
                out[key] = v
        for key, f in self.fields.items():
            if f.required and key not in value:
                errors.append((_join(path, key), MISSING, "required key missing"
                               + (f" ({f.doc.split('.')[0]})" if f.doc else "")))
                bad = True
        for group in self.exclusive:
            given = [k for k in group if k in value]
            if len(given) > 1:
                errors.append((path or "(top level)", MISSING, "give only one of " + _listing(given, "and")
                               if len(group) == 2 else "give at most one of " + _listing(group, "and")
                               + f", not {_listing(given, 'and')}"))
                bad = True
        for group in self.one_of:
            given = [k for k in group if k in value]
            if len(given) != 1:
                errors.append((path or "(top level)", MISSING, "give exactly one of " + _listing(group)
                               + (f", not {_listing(given, 'and')}" if given else "")))
                bad = True
        return _BAD if bad else out

    def schema(self):
        s: dict = {"type": "object"}
        if self.doc:
            s["description"] = self.doc
        s["properties"] = {k: _field_schema(f) for k, f in self.fields.items()}
        required = [k for k, f in self.fields.items() if f.required]
        if required:
            s["required"] = required
        s["additionalProperties"] = False
        constraints = [{"not": {"required": list(pair)}} for group in self.exclusive
                       for pair in _pairs(group)]
        constraints += [{"oneOf": [{"required": [k]} for k in group]} for group in self.one_of]
        if constraints:
            s["allOf"] = constraints
        return s

    def kind(self):
        return "table"


def _pairs(group):
    return [(a, b) for i, a in enumerate(group) for b in group[i + 1:]]


def _field_schema(f: Field) -> dict:
    s = dict(f.node.schema())
    text = f.doc + (f" [{f.unit}]" if f.unit else "") + (f" Default: {f.default}." if f.default else "")
    if text:
        s = {"description": text, **s}
    return s


@dataclasses.dataclass
class Tagged(Node):
    """A table whose key ``tag`` picks one of several variants (each a Table without the tag)."""

    tag: str
    variants: dict
    doc: str = ""
    name: str = ""

    def check(self, value, path, errors):
        if not isinstance(value, dict):
            errors.append((path, value, f"must be a table with a key {self.tag}"))
            return _BAD
        if self.tag not in value:
            errors.append((_join(path, self.tag), MISSING, "required key missing: one of "
                           + _listing(list(self.variants))))
            return _BAD
        choice = value[self.tag]
        if not isinstance(choice, str) or choice not in self.variants:
            errors.append((_join(path, self.tag), choice, "must be " + _listing(list(self.variants))
                           + (_closest(choice, list(self.variants)) if isinstance(choice, str) else "")))
            return _BAD
        out = self.variants[choice].check(value, path, errors, skip=(self.tag,))
        if out is _BAD:
            return _BAD
        out[self.tag] = choice
        return out

    def schema(self):
        variants = []
        for name, table in self.variants.items():
            s = table.schema()
            s["properties"] = {self.tag: {"const": name}, **s["properties"]}
            s["required"] = [self.tag] + s.get("required", [])
            variants.append(s)
        out: dict = {"description": self.doc} if self.doc else {}
        out["type"] = "object"
        out["required"] = [self.tag]
        out["properties"] = {self.tag: {"enum": list(self.variants)}}
        out["oneOf"] = variants
        return out

    def kind(self):
        return f"table (by `{self.tag}`)"


@dataclasses.dataclass
class MapOf(Node):
    """A table of named items (``[materials.NAME]``)."""

    item: Node
    doc: str = ""

    def check(self, value, path, errors):
        if not isinstance(value, dict):
            errors.append((path, value, "must be a table of named entries"))
            return _BAD
        out = {k: self.item.check(v, _join(path, k), errors) for k, v in value.items()}
        return _BAD if any(v is _BAD for v in out.values()) else out

    def schema(self):
        s: dict = {"description": self.doc} if self.doc else {}
        return {**s, "type": "object", "additionalProperties": self.item.schema()}

    def kind(self):
        return "table of tables"


@dataclasses.dataclass
class ArrayOf(Node):
    """An array of tables (``[[walls]]``)."""

    item: Node
    doc: str = ""

    def check(self, value, path, errors):
        if not isinstance(value, list):
            errors.append((path, value, "must be an array of tables ([[...]] blocks)"))
            return _BAD
        out = [self.item.check(v, _join(path, k), errors) for k, v in enumerate(value)]
        return _BAD if any(v is _BAD for v in out) else out

    def schema(self):
        s: dict = {"description": self.doc} if self.doc else {}
        return {**s, "type": "array", "items": self.item.schema()}

    def kind(self):
        return "array of tables"


def _listing(options, last: str = "or") -> str:
    names = [f'"{o}"' for o in options]
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + f" {last} " + names[-1]


def _closest(word: str, options, quote: bool = True) -> str:
    match = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    if not match:
        return ""
    return f" (did you mean {json.dumps(match[0]) if quote else match[0]}?)"


class _NameList(Node):
    """Two material names."""

    def check(self, value, path, errors):
        if (not isinstance(value, list) or len(value) != 2
                or not all(isinstance(v, str) and v for v in value)):
            errors.append((path, value, "must be an array of two material names"))
            return _BAD
        return list(value)

    def schema(self):
        return {"type": "array", "items": {"type": "string", "minLength": 1}, "minItems": 2, "maxItems": 2}

    def kind(self):
        return "array of 2 strings"


# ---- the scene format --------------------------------------------------------------------------
# Units, defaults and meanings are those of the Python API (tsubu.Material, tsubu.Simulation,
# tsubu.fill, tsubu.insert, tsubu.output); the ranges are tsubu's own checks (tests/test_scene.py
# checks that Material refuses what the spec refuses).

POSITIVE = dict(minimum=0.0, exclusive_minimum=True)
NON_NEGATIVE = dict(minimum=0.0)
XYZ = "array of 3 numbers"


def _material_table() -> Table:
    def number(doc, unit="", default=None, **bounds):
        return Field(Number(unit=unit, **bounds), doc, default=default, unit=unit)

    return Table({
        "density": number("Mass density.", "kg/m^3", "2500", **POSITIVE),
        "kn": number("Normal spring stiffness of the linear (Kelvin-Voigt) law.", "N/m",
                     "1e3 for a linear material", **POSITIVE),
        "kt": number("Tangential spring stiffness of the linear law.", "N/m", "2/7 kn",
                     **NON_NEGATIVE),
        "youngs_modulus": number("Young's modulus E: makes the material Hertz-Mindlin (then kn, kt "
                                 "must not be given).", "Pa", "none (linear)", **POSITIVE),
        "poisson_ratio": number("Poisson's ratio of a Hertzian material.", "", "0.3 with youngs_modulus",
                                minimum=-1.0, maximum=0.5, exclusive_minimum=True),
        "restitution": number("Normal coefficient of restitution.", "", "0.5",
                              minimum=0.0, maximum=1.0, exclusive_minimum=True),
        "friction": number("Coulomb friction coefficient (0: frictionless).", "", "0.5", **NON_NEGATIVE),
        "rolling_friction": number("Rolling friction coefficient.", "", "0", **NON_NEGATIVE),
        "tangential_damping": number("Tangential dashpot as a fraction of the normal one.", "", "0",
                                     **NON_NEGATIVE),
        "roughness": number("Standard deviation of the roughness scatter angle (docs/roughness.md).",
                            "degrees", "0", minimum=0.0, maximum=90.0, exclusive_maximum=True),
        "roughness_distribution": Field(String(tuple(_core.choices["roughness_distribution"])),
                                        "Distribution of the roughness tilt.", default='"normal"'),
        "shadow": Field(String(tuple(_core.choices["shadow"])),
                        "Shadow effect at walls (docs/roughness.md).", default='"reject"'),
    }, doc="A material: the fields of tsubu.Material (SI units; roughness in degrees). The table's "
           "name (materials.NAME) is how walls, particles and inserters refer to it.",
        exclusive=(("kn", "youngs_modulus"), ("kt", "youngs_modulus")), name="materials.NAME")


def _region() -> Tagged:
    return Tagged("shape", {
        "box": Table({
            "lower": Field(Vector(unit="m"), "Lower corner.", required=True, unit="m"),
            "upper": Field(Vector(unit="m"), "Upper corner (each coordinate above lower's).",
                           required=True, unit="m"),
        }, doc="An axis-aligned box (tsubu.fill.Box)."),
        "cylinder": Table({
            "base": Field(Vector(unit="m"), "Centre of the bottom disc.", required=True, unit="m"),
            "radius": Field(Number("m", **POSITIVE), "Radius.", required=True, unit="m"),
            "height": Field(Number("m", **POSITIVE), "Height along the axis.", required=True, unit="m"),
            "axis": Field(String(("x", "y", "z")), "Axis direction.", default='"z"'),
        }, doc="A circular cylinder (tsubu.fill.Cylinder)."),
    }, doc="A region of space: a box or a cylinder (tsubu.fill).", name="region")


def _radius(doc, required=True, default=None):
    return Field(Number("m", **POSITIVE), doc, required=required, default=default, unit="m")


def _sizes() -> Tagged:
    return Tagged("distribution", {
        "monodisperse": Table({"radius": _radius("The radius.")}, doc="One radius."),
        "uniform": Table({"min_radius": _radius("Smallest radius."),
                          "max_radius": _radius("Largest radius.")},
                         doc="Radii uniform between two bounds."),
        "normal": Table({"mean_radius": _radius("Mean radius."),
                         "std": Field(Number("m", **NON_NEGATIVE), "Standard deviation.", required=True,
                                      unit="m"),
                         "min_radius": _radius("Truncation below.", False, "none"),
                         "max_radius": _radius("Truncation above.", False, "none")},
                        doc="A truncated normal distribution of radii."),
        "lognormal": Table({"median_radius": _radius("Median radius."),
                            "sigma": Field(Number(**NON_NEGATIVE), "Standard deviation of ln r.",
                                           required=True),
                            "min_radius": _radius("Truncation below.", False, "none"),
                            "max_radius": _radius("Truncation above.", False, "none")},
                           doc="A (truncated) log-normal distribution of radii."),
        "tabulated": Table({"radii": Field(NumberList(Number("m", **POSITIVE), 2),
                                           "Radii of the table, increasing.", required=True, unit="m"),
                            "fractions": Field(NumberList(Number(minimum=0.0, maximum=1.0), 2),
                                               "Cumulative fraction finer than each radius, "
                                               "non-decreasing, from 0 to 1.", required=True),
                            "basis": Field(String(("number", "mass")), "Fractions by number or by mass.",
                                           default='"number"')},
                           doc="A tabulated particle-size distribution (cumulative, linear in radius "
                               "between points)."),
    }, doc="A size distribution of radii (tsubu.fill).", name="sizes")


def _motion(what: str) -> dict:
    return {
        "velocity": Field(Vector(unit="m/s"), f"Initial velocity of {what}.", default="[0, 0, 0]",
                          unit="m/s"),
        "angular_velocity": Field(Vector(unit="rad/s"), f"Initial angular velocity of {what}.",
                                  default="[0, 0, 0]", unit="rad/s"),
    }


def _every() -> dict:
    return {
        "every": Field(Integer(minimum=1), "Write every this many steps.", unit="steps"),
        "interval": Field(Number("s", **POSITIVE), "Write every this much simulated time (rounded to "
                                                   "whole steps, at least 1).", unit="s"),
    }


def _writer(name_default: str, doc: str, extra: dict | None = None) -> Table:
    return Table({**_every(),
                  "name": Field(String(), "Base name of the files.", default=f'"{name_default}"'),
                  **(extra or {})}, doc=doc, one_of=(("every", "interval"),))


def _build_spec() -> Table:
    material_name = String()
    simulation = Table({
        "duration": Field(Number("s", **NON_NEGATIVE), "Simulated time to run.", required=True, unit="s"),
        "gravity": Field(Vector(unit="m/s^2"), "Gravitational acceleration.", default="[0, 0, -9.81]",
                         unit="m/s^2"),
        "dt": Field(Number("s", **POSITIVE), "Time step.", default="dt_fraction's", unit="s"),
        "dt_fraction": Field(Number(minimum=0.0, maximum=1.0, exclusive_minimum=True),
                             "Time step as a fraction of the scene's shortest contact duration "
                             "(Simulation.contact_duration(), with the spheres of the particles "
                             "blocks and the smallest spheres of the inserters).",
                             default="0.02 (tsubu's t_c/50)"),
        "seed": Field(Integer(0, 2**64 - 1), "Seed of the roughness draws.", default="0"),
        "threads": Field(Integer(1, 4096), "OpenMP threads (`tsubu run --threads` overrides it).",
                         default="all cores"),
        "parallel_min": Field(Integer(0, 2**31 - 1), "Scenes with fewer spheres run on one thread.",
                              default="2048"),
        "skin": Field(Number("m", **POSITIVE), "Neighbour-list skin.", default="0.2 mean diameter",
                      unit="m"),
        "tangential_history": Field(String(tuple(_core.choices["tangential_history"])),
                                    "How the tangential displacement follows the contact.",
                                    default='"rotate"'),
        "slip_rule": Field(String(tuple(_core.choices["slip_rule"])), "What a slipping contact does.",
                           default='"frozen"'),
        "hertz_force": Field(String(("signed", "repulsive")), "Normal force of Hertzian materials.",
                             default='"signed"'),
        "impact_speed": Field(Number("m/s", **POSITIVE), "Impact speed for a Hertzian scene's contact "
                                                         "duration.", default="measured", unit="m/s"),
        "max_overlap": Field(Number(**POSITIVE), "Overlap (fraction of a radius) that stops a run as "
                                                 "unstable.", default="0.5"),
        "initial_overlap": Field(Number(**NON_NEGATIVE), "Largest initial overlap accepted (fraction of "
                                                         "a radius).", default="0.05"),
        "allow_unstable_dt": Field(Boolean(), "Run with a dt above the stability bound.", default="false"),
        "rebuild_every_step": Field(Boolean(), "Rebuild the neighbour list every step (a testing aid).",
                                    default="false"),
    }, doc="The simulation's options (tsubu.Simulation) and how long to run.",
        exclusive=(("dt", "dt_fraction"),), name="simulation")

    pair = Table({
        "materials": Field(_NameList(), "The two materials' names.",
                           required=True),
        **{k: Field(f.node, f.doc, default="mixed", unit=f.unit) for k, f in _material_table().fields.items()
           if k in ("kn", "kt", "restitution", "friction", "rolling_friction", "tangential_damping",
                    "roughness", "roughness_distribution", "shadow")},
        "effective_modulus": Field(Number("Pa", **POSITIVE), "E* of a pair of Hertzian materials.",
                                   default="mixed", unit="Pa"),
        "effective_shear_modulus": Field(Number("Pa", **NON_NEGATIVE), "G* of a pair of Hertzian "
                                                                       "materials.", default="mixed",
                                         unit="Pa"),
    }, doc="A per-pair override of the mixed contact parameters (Simulation.set_pair).", name="pairs")

    wall = Table({
        "point": Field(Vector(unit="m"), "A point of the plane (and the centre of its rotation).",
                       required=True, unit="m"),
        "normal": Field(Vector(nonzero=True), "Normal, pointing to the side where spheres live.",
                        required=True),
        "material": Field(material_name, "The wall's material (a name from [materials]).", required=True),
        "velocity": Field(Vector(unit="m/s"), "Translation velocity.", default="[0, 0, 0]", unit="m/s"),
        "angular_velocity": Field(Vector(unit="rad/s"), "Angular velocity about point.",
                                  default="[0, 0, 0]", unit="rad/s"),
    }, doc="An infinite plane wall (Simulation.add_plane).", name="walls")

    common = {"material": Field(material_name, "The spheres' material (a name from [materials]).",
                                required=True)}
    particles = Tagged("generator", {
        "lattice": Table({
            **common,
            "region": Field(_region(), "Where the spheres go.", required=True),
            "radius": _radius("The spheres' radius."),
            "spacing": Field(Number("m", **POSITIVE), "Distance between neighbouring centres.",
                             default="2 radius", unit="m"),
            "kind": Field(String(("cubic", "hexagonal")), "Lattice type.", default='"cubic"'),
            "jitter": Field(Number(minimum=0.0, maximum=1.0, exclusive_maximum=True),
                            "Random displacement as a fraction of the gap.", default="0"),
            "seed": Field(Integer(0, 2**64 - 1), "Seed of the jitter.", default="0"),
            **_motion("every sphere"),
        }, doc="Spheres on a lattice filling a region (tsubu.fill.lattice)."),
        "random_packing": Table({
            **common,
            "region": Field(_region(), "Where the spheres go.", required=True),
            "sizes": Field(_sizes(), "The size distribution.", required=True),
            "count": Field(Integer(minimum=1), "Number of spheres."),
            "solid_fraction": Field(Number(minimum=0.0, maximum=1.0, exclusive_minimum=True,
                                           exclusive_maximum=True), "Target solid fraction of the region."),
            "seed": Field(Integer(0, 2**64 - 1), "Seed of the positions and sizes.", default="0"),
            "max_attempts": Field(Integer(minimum=1), "Attempts of random sequential addition.",
                                  default="tsubu.fill's"),
            **_motion("every sphere"),
        }, doc="A random non-overlapping packing (tsubu.fill.random_packing).", one_of=(("count", "solid_fraction"),)),
        "file": Table({
            "material": Field(material_name, "The spheres' material. Without it, each sphere gets "
                                             "the material the file names (an .npz of "
                                             "tsubu.output.save_npz: its material and material_names "
                                             "arrays), which must be one of [materials]."),
            "path": Field(String(), "An .npz or .csv file written by tsubu.output.save_npz / save_csv "
                                    "(relative to the scene file).", required=True),
            "velocities": Field(Boolean(), "Take the velocities and angular velocities from the file "
                                           "(false: at rest).", default="true"),
        }, doc="Spheres read from a file of tsubu.output."),
    }, doc="A block of spheres added before the run.", name="particles")

    inserter = Table({
        "material": Field(material_name, "The inserted spheres' material.", required=True),
        "region": Field(_region(), "Where spheres are inserted.", required=True),
        "rate": Field(Number(**POSITIVE), "Spheres per second (basis \"number\") or kg per second "
                                          "(basis \"mass\").", required=True, unit="1/s or kg/s"),
        "sizes": Field(_sizes(), "The size distribution.", required=True),
        "basis": Field(String(("number", "mass")), "What rate and total count.", default='"number"'),
        **_motion("the inserted spheres"),
        "start": Field(Number("s", **NON_NEGATIVE), "Simulated time of the first insertion.", default="0",
                       unit="s"),
        "stop": Field(Number("s", **NON_NEGATIVE), "Simulated time after which nothing is inserted.",
                      default="never", unit="s"),
        "total": Field(Number(**POSITIVE), "Count (basis \"number\") or mass [kg] after which it stops.",
                       default="unlimited"),
        "interval": Field(Number("s", **POSITIVE), "Time between insertion events.",
                          default="chosen from the region and velocity", unit="s"),
        "seed": Field(Integer(0, 2**64 - 1), "Seed of the positions and sizes.", default="0"),
    }, doc="Pours spheres during the run (Simulation.add_inserter).", name="inserters")

    output = Table({
        "directory": Field(String(), "Where output and checkpoints go (relative to the scene file; "
                                     "`tsubu run --output` overrides it).", default='"output"'),
        "vtk": Field(_writer("particles", "VTK XML files for ParaView (tsubu.output.VTKOutput).", {
            "contacts": Field(Boolean(), "Write the contact network.", default="true"),
            "walls": Field(Boolean(), "Write the walls.", default="true"),
        }), "ParaView output."),
        "npz": Field(_writer("state", "numpy .npz files (tsubu.output.NpzOutput)."), "npz dumps."),
        "csv": Field(_writer("state", "CSV tables (tsubu.output.CSVOutput), with an index "
                                      "NAME_frames.csv of steps and times.", {
            "contacts": Field(Boolean(), "Also write the contact network as NAME_contacts_STEP.csv.",
                              default="true"),
        }), "CSV dumps."),
    }, doc="What to write during the run.", name="output")

    checkpoint = Table({
        "path": Field(String(), "Checkpoint file (relative to the output directory).",
                      default='"checkpoint.tsubu"'),
        **{k: Field(f.node, f.doc.replace("Write", "Checkpoint"), unit=f.unit) for k, f in _every().items()},
        "keep": Field(Integer(minimum=1), "How many periodic checkpoints to keep.", default="3"),
    }, doc="Checkpoints (Simulation.save), for `tsubu resume`. Without every or interval, only "
           "the end of the run and a Ctrl-C write one.", exclusive=(("every", "interval"),),
        name="checkpoint")

    return Table({
        "simulation": Field(simulation, "Options and duration.", required=True),
        "materials": Field(MapOf(_material_table(), "Materials by name."), "Materials by name.",
                           required=True),
        "pairs": Field(ArrayOf(pair, "Pair overrides."), "Pair overrides."),
        "walls": Field(ArrayOf(wall, "Plane walls."), "Plane walls."),
        "particles": Field(ArrayOf(particles, "Blocks of spheres."), "Blocks of spheres."),
        "inserters": Field(ArrayOf(inserter, "Inserters."), "Inserters."),
        "output": Field(output, "Output."),
        "checkpoint": Field(checkpoint, "Checkpoints."),
    }, doc="A tsubu scene file (docs/scene-format.md).", name="scene")


SPEC = _build_spec()


# ---- loading -------------------------------------------------------------------------------------

def read_toml(path) -> dict:
    """The TOML file at ``path`` as a dict; SceneError for a file that is missing, unreadable or
    not TOML (with the line and column of the syntax error)."""
    source = os.fspath(path)
    try:
        import tomllib  # Python 3.11+
    except ModuleNotFoundError:  # pragma: no cover - Python < 3.11
        try:
            import tomli as tomllib
        except ModuleNotFoundError:
            raise SceneError([("", MISSING, "reading scene files on Python < 3.11 needs tomli: "
                               "install it with pip install 'tsubu[scene]' (or pip install tomli)")],
                             source) from None
    try:
        with open(source, "rb") as f:
            return tomllib.load(f)
    except OSError as e:
        raise SceneError([("", MISSING, f"cannot read the scene file: {e.strerror or e}")], source) from None
    except tomllib.TOMLDecodeError as e:
        raise SceneError([("", MISSING, f"not a valid TOML file: {e}")], source) from None


def validate(data, source: str | None = None) -> dict:
    """Check a scene (``data``, the dict of a parsed TOML file) against the format's spec and the
    references between its parts (material names); returns the checked scene (numbers as floats,
    vectors as lists). Raises SceneError listing every bad, missing or unknown key, with
    ``source`` (the file's name, or None) in front of each line."""
    errors: list = []
    checked = SPEC.check(data, "", errors)
    materials = data.get("materials") if isinstance(data, dict) else None
    if isinstance(materials, dict):  # names are checked even where other keys are bad
        names = list(materials)
        for path, name in _material_references(data):
            if name not in materials:
                errors.append((path, name, "no such material; defined: " + (", ".join(names) or "none")
                               + _closest(name, names)))
        errors.sort(key=lambda e: _order(data, e[0]))
    if errors:
        raise SceneError(errors, source)
    return checked


def _material_references(data: dict) -> list:
    """(path, name) of every material name the scene uses (those that are strings)."""
    refs = []
    for part in ("walls", "particles", "inserters"):
        items = data.get(part)
        for k, item in enumerate(items if isinstance(items, list) else []):
            if isinstance(item, dict) and isinstance(item.get("material"), str):
                refs.append((f"{part}[{k}].material", item["material"]))
    pairs = data.get("pairs")
    for k, pair in enumerate(pairs if isinstance(pairs, list) else []):
        names = pair.get("materials") if isinstance(pair, dict) else None
        for j, name in enumerate(names if isinstance(names, list) else []):
            if isinstance(name, str):
                refs.append((f"pairs[{k}].materials[{j}]", name))
    return refs


def _order(data: dict, path: str) -> tuple:
    """Sorts errors in the order of the file's top-level tables, then of their items."""
    top = re.match(r"[^.\[]*", path).group(0)
    keys = list(data)
    index = re.match(r"[^.\[]*\[(\d+)\]", path)
    return (keys.index(top) if top in keys else len(keys), int(index.group(1)) if index else -1)


@dataclasses.dataclass
class Scene:
    """A scene ready to run, as :func:`load_scene`, :func:`scene_from_dict` and :func:`resume`
    make it (not meant to be constructed by hand); :meth:`run` runs it.

    Attributes
    ----------
    simulation : tsubu.Simulation
        The Simulation, with its spheres, walls and inserters.
    end_time : float
        The simulated time [s] at which the run ends.
    output : list
        The hooks that write output (:mod:`tsubu.output` writers).
    checkpoint : dict or None
        The checkpoint settings (``path``, ``every`` in steps or None, ``keep``), or None.
    output_directory : str
        Where output and checkpoints go.
    data : dict
        The scene as read (JSON-able).
    directory : str
        The folder the scene's relative paths start from.
    source : str or None
        The scene file's name.
    """

    simulation: Simulation
    end_time: float
    output: list
    checkpoint: dict | None
    output_directory: str
    data: dict
    directory: str
    source: str | None = None

    def metadata(self) -> dict:
        """What checkpoints carry so that ``tsubu resume`` can go on: the scene, its directory,
        the output directory and the end time."""
        return {"tsubu_scene": FORMAT_VERSION, "scene": self.data, "source": self.source,
                "directory": self.directory, "output_directory": self.output_directory,
                "end_time": self.end_time}

    def run(self, until: float | None = None, progress: bool | None = None) -> Simulation:
        """Run to simulated time ``until`` [s] (default :attr:`end_time`) with the scene's output
        and checkpoints; returns the Simulation. An ``until`` beyond :attr:`end_time` becomes the
        new end time (the one the checkpoints record, which ``tsubu resume`` runs to). A final
        checkpoint is written at the end when the scene has a [checkpoint] table. ``progress``
        is that of :meth:`tsubu.Simulation.run` (None: a bar on an interactive terminal). Raises InstabilityError (the run went unstable) and
        KeyboardInterrupt (Ctrl-C; a checkpoint is written first when the scene has one)."""
        sim = self.simulation
        end = self.end_time if until is None else until
        # a run taken beyond the scene's end moves it (what tsubu resume of its checkpoints reaches)
        self.end_time = max(self.end_time, end)
        remaining = max(0.0, end - sim.time)
        kwargs: dict = {"progress": progress}
        if self.checkpoint is not None:
            os.makedirs(os.path.dirname(self.checkpoint["path"]), exist_ok=True)
        if self.output:
            kwargs["output"] = list(self.output)
        if self.checkpoint is not None and self.checkpoint["every"] is not None:
            _attach_metadata(sim, self.metadata())  # for the run's periodic checkpoints
            kwargs.update(checkpoint=self.checkpoint["path"], checkpoint_every=self.checkpoint["every"],
                          checkpoint_keep=self.checkpoint["keep"])
        try:
            sim.run(time=remaining, **kwargs)
        except KeyboardInterrupt:
            self._save()
            raise
        self._save()
        return sim

    def _save(self) -> None:
        """The checkpoint of the run's end (or of a Ctrl-C), with the scene in its metadata (over
        the one the run may have written without it)."""
        if self.checkpoint is not None:
            self.simulation.save(self.checkpoint["path"], metadata=self.metadata())


def _attach_metadata(sim: Simulation, metadata: dict) -> None:
    """Make the run's own periodic checkpoints carry the scene's metadata, where the Simulation
    saves its ``metadata`` attribute by default."""
    try:
        sim.metadata = metadata
    except AttributeError:  # pragma: no cover - a Simulation without settable metadata
        pass


def load_scene(path, *, threads: int | None = None, output_directory=None) -> Scene:
    """Read, check and build the scene file at ``path`` (TOML; docs/scene-format.md).

    Parameters
    ----------
    path : str or path-like
        The scene file.
    threads : int or None
        Overrides ``simulation.threads``.
    output_directory : path or None
        Overrides ``output.directory`` (relative paths: to the current directory).

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        Naming the path and value of every bad, missing or unknown key.
    """
    source = os.fspath(path)
    data = read_toml(source)
    return scene_from_dict(data, directory=os.path.dirname(os.path.abspath(source)), source=source,
                           threads=threads, output_directory=output_directory)


def scene_from_dict(data: dict, directory=".", *, source: str | None = None, threads: int | None = None,
                    output_directory=None) -> Scene:
    """Build a :class:`Scene` from ``data``, a scene as a dict (a parsed TOML file); relative
    paths start at ``directory``. ``source`` (the file's name, or None) prefixes the errors;
    ``threads``, ``output_directory`` and the errors are as in :func:`load_scene`."""
    checked = validate(data, source)
    directory = os.path.abspath(os.fspath(directory))
    builder = _Builder(checked, directory, source)
    try:
        return builder.build(data, threads, output_directory)
    except SceneError:
        raise
    except (ValueError, TypeError) as e:  # a check this module does not know the path of
        raise SceneError([("", MISSING, str(e))], source) from None


class _Builder:
    """Turns a checked scene into tsubu objects, reporting their errors at the scene's paths."""

    def __init__(self, scene: dict, directory: str, source: str | None):
        self.scene = scene
        self.directory = directory
        self.source = source
        self.materials: dict = {}
        self.batches: list = []  # (positions, radii, material, velocities) of every block, for dt
        self.inserters: list = []
        self.pairs: list = []  # (material_a, material_b, overrides)

    def fail(self, path: str, value, message: str):
        raise SceneError([(path, value, message)], self.source)

    def call(self, path: str, given: dict, function: Callable, *args, **kwargs):
        """``function(*args, **kwargs)``, its ValueError or TypeError reported at ``path`` or,
        when the message starts with the name of one of the keys in ``given``, at that key."""
        try:
            return function(*args, **kwargs)
        except (ValueError, TypeError) as e:
            message = str(e)
            for key in sorted(given, key=len, reverse=True):
                if message.startswith(key + " ") or message.startswith(key + ":"):
                    rest = re.sub(r",? got .*$", "", message[len(key):].lstrip(" :"), flags=re.S)
                    self.fail(_join(path, key), given[key], rest or message)
            self.fail(path, MISSING, message)

    def build(self, data: dict, threads, output_directory) -> Scene:
        s = self.scene
        for name, fields in s["materials"].items():
            self.materials[name] = self.call(_join("materials", name), fields, Material, name=name, **fields)
        sim = self.simulation(s["simulation"], threads)
        for k, pair in enumerate(s.get("pairs", [])):
            overrides = {key: v for key, v in pair.items() if key != "materials"}
            a, b = (self.materials[n] for n in pair["materials"])
            self.call(f"pairs[{k}]", overrides, sim.set_pair, a, b, **overrides)
            self.pairs.append((a, b, overrides))
        for k, wall in enumerate(s.get("walls", [])):
            given = {key: v for key, v in wall.items() if key != "material"}
            self.call(f"walls[{k}]", given, sim.add_plane, material=self.materials[wall["material"]], **given)
        for k, block in enumerate(s.get("particles", [])):
            self.particles(sim, f"particles[{k}]", block)
        for k, spec in enumerate(s.get("inserters", [])):
            self.inserter(sim, f"inserters[{k}]", spec)
        self.time_step(sim, s["simulation"])
        out_dir = self.output_directory(output_directory)
        end_time = sim.time + s["simulation"]["duration"]
        return Scene(simulation=sim, end_time=end_time, output=self.output_hooks(sim, out_dir),
                     checkpoint=self.checkpoint(sim, out_dir), output_directory=out_dir, data=data,
                     directory=self.directory, source=self.source)

    # -- parts --
    def simulation(self, options: dict, threads) -> Simulation:
        given = {k: v for k, v in options.items() if k not in ("duration", "dt_fraction", "dt")}
        if threads is not None:
            given["threads"] = threads
        sim = self.call("simulation", given, Simulation, **given)
        if "dt" in options:
            sim.dt = options["dt"]
        return sim

    def time_step(self, sim: Simulation, options: dict) -> None:
        """Fix dt for the whole run (a default evaluated at each run's start would change as
        inserters add spheres): dt, or dt_fraction of the contact duration of the scene's spheres
        and the smallest spheres its inserters make."""
        if "dt" in options:
            return
        probe = sim if not self.inserters else self.probe(sim)
        if probe.size == 0:
            self.fail("simulation.dt", MISSING, "required when the scene has no particles and no "
                                                "inserters (there is no contact to derive it from)")
        try:
            if "dt_fraction" in options:
                dt = options["dt_fraction"] * probe.contact_duration()
            else:
                dt = probe.default_time_step()
        except (ValueError, RuntimeError) as e:
            self.fail("simulation", MISSING, f"cannot choose the time step: {e}")
        if not (math.isfinite(dt) and dt > 0):
            self.fail("simulation.dt_fraction" if "dt_fraction" in options else "simulation", MISSING,
                      f"the scene's contact duration gives dt = {dt!r}: give simulation.dt")
        sim.dt = dt

    def probe(self, sim: Simulation) -> Simulation:
        """A Simulation with the scene's options, walls and spheres plus, for each inserter, two
        spheres of its smallest radius at its velocity (two: an inserter's spheres meet each
        other, and the lightest pair bounds the contact duration): what the run will have to
        resolve."""
        options = self.scene["simulation"]
        probe = Simulation(**{k: v for k, v in options.items() if k not in ("duration", "dt_fraction", "dt")})
        for a, b, overrides in self.pairs:
            probe.set_pair(a, b, **overrides)
        for k in range(sim.plane_count):
            wall = sim.plane(k)
            probe.add_plane(point=wall["point"], normal=wall["normal"], material=wall["material"])
        for positions, radii, material, velocities in self.batches:
            probe.add_spheres(positions, radii, material, velocities=velocities)
        for spec, sizes in self.inserters:
            for _ in range(2):
                offset = 1e3 * (1 + probe.size) * sizes.max_radius  # apart from everything else
                probe.add_sphere([offset, offset, offset], sizes.min_radius,
                                 self.materials[spec["material"]], velocity=spec.get("velocity"))
        return probe

    def region(self, path: str, spec: dict):
        fill = _fill()
        given = {k: v for k, v in spec.items() if k != "shape"}
        if spec["shape"] == "box":
            return self.call(path, given, fill.Box, **given)
        return self.call(path, given, fill.Cylinder, **given)

    def sizes(self, path: str, spec: dict):
        fill = _fill()
        given = {k: v for k, v in spec.items() if k != "distribution"}
        cls = {"monodisperse": "Monodisperse", "uniform": "Uniform", "normal": "Normal",
               "lognormal": "LogNormal", "tabulated": "Tabulated"}[spec["distribution"]]
        return self.call(path, given, getattr(fill, cls), **given)

    def particles(self, sim: Simulation, path: str, block: dict) -> None:
        generator = block["generator"]
        velocities = angular = None
        if generator == "file":
            positions, radii, velocities, angular, materials = self.read_particles(path, block)
        else:
            fill = _fill()
            region = self.region(_join(path, "region"), block["region"])
            skip = ("generator", "material", "region", "velocity", "angular_velocity")
            given = {k: v for k, v in block.items() if k not in skip}
            if generator == "lattice":
                packing = self.call(path, given, fill.lattice, region, **given)
            else:
                given["sizes"] = self.sizes(_join(path, "sizes"), block["sizes"])
                packing = self.call(path, given, fill.random_packing, region, **given)
            positions, radii = packing.positions, packing.radii
            n = len(radii)
            if n == 0:
                self.fail(path, MISSING, "the generator placed no spheres (is the region smaller "
                                         "than one sphere?)")
            if "velocity" in block:
                velocities = np.tile(block["velocity"], (n, 1))
            if "angular_velocity" in block:
                angular = np.tile(block["angular_velocity"], (n, 1))
            materials = [(0, n, self.materials[block["material"]])]
        for start, stop, material in materials:  # runs of one material, in the file's order
            part = slice(start, stop)
            v = None if velocities is None else velocities[part]
            w = None if angular is None else angular[part]
            self.call(path, {}, sim.add_spheres, positions[part], radii[part], material, velocities=v,
                      angular_velocities=w)
            self.batches.append((positions[part], radii[part], material, v))

    def read_particles(self, path: str, block: dict):
        """Positions, radii, velocities and angular velocities of a file of tsubu.output."""
        file = os.path.join(self.directory, block["path"])
        where = _join(path, "path")
        if not os.path.isfile(file):
            self.fail(where, block["path"], f"no such file ({file})")
        try:
            columns = _read_columns(file)
        except (OSError, ValueError) as e:
            self.fail(where, block["path"], f"cannot read {file}: {e}")
        found = {}
        for name, aliases, width in _PARTICLE_COLUMNS:
            found[name] = _column(columns, aliases, width)
        if found["positions"] is None or found["radii"] is None:
            self.fail(where, block["path"], f"{file} has no positions and radii (found: "
                                            f"{', '.join(sorted(columns)) or 'nothing'})")
        if not block.get("velocities", True):
            found["velocities"] = found["angular_velocities"] = None
        n = len(found["radii"])
        if "material" in block:
            materials = [(0, n, self.materials[block["material"]])]
        else:
            materials = self.file_materials(path, block, columns, n)
        return (found["positions"], found["radii"], found["velocities"], found["angular_velocities"],
                materials)

    def file_materials(self, path: str, block: dict, columns: dict, n: int) -> list:
        """(start, stop, Material) of the runs of spheres of one material that a file names."""
        if "material" not in columns or "material_names" not in columns:
            self.fail(_join(path, "material"), MISSING, f"required: {block['path']} does not name its "
                                                        "spheres' materials (material and material_names "
                                                        "arrays of tsubu.output.save_npz)")
        names = [str(x) for x in np.asarray(columns["material_names"]).reshape(-1)]
        index = np.asarray(columns["material"]).reshape(-1)
        if len(index) != n or not np.all((index >= 0) & (index < len(names))):
            self.fail(_join(path, "path"), block["path"], "its material array does not index its "
                                                          "material_names")
        unknown = sorted({names[k] for k in set(index.tolist())} - set(self.materials))
        if unknown:
            self.fail(_join(path, "path"), block["path"],
                      f"its spheres have materials {', '.join(map(repr, unknown))}, not in [materials] "
                      f"(defined: {', '.join(self.materials)}); name them so, or give {path}.material")
        cuts = [0] + [k for k in range(1, n) if index[k] != index[k - 1]] + [n]
        return [(a, b, self.materials[names[index[a]]]) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]

    def inserter(self, sim: Simulation, path: str, spec: dict) -> None:
        region = self.region(_join(path, "region"), spec["region"])
        sizes = self.sizes(_join(path, "sizes"), spec["sizes"])
        given = {k: v for k, v in spec.items() if k not in ("region", "sizes", "rate", "material")}
        total = given.get("total")
        if given.get("basis", "number") == "number" and total is not None and float(total).is_integer():
            given["total"] = int(total)  # a count (TOML's 600 reaches here as the number 600.0)
        inserter = self.call(path, {"rate": spec["rate"], **given}, sim.add_inserter, region, spec["rate"],
                             sizes, self.materials[spec["material"]], **given)
        self.inserters.append((spec, sizes))
        return inserter

    def output_directory(self, override) -> str:
        if override is not None:
            return os.path.abspath(os.fspath(override))
        return os.path.join(self.directory, self.scene.get("output", {}).get("directory", "output"))

    def steps(self, sim: Simulation, spec: dict) -> int:
        if "every" in spec:
            return spec["every"]
        return max(1, int(round(spec["interval"] / sim.dt)))

    def output_hooks(self, sim: Simulation, directory: str) -> list:
        output = self.scene.get("output", {})
        hooks = []
        writers = [key for key in ("vtk", "npz", "csv") if key in output]
        if not writers:
            return hooks
        out = _output()
        for key in writers:
            spec = output[key]
            options = {k: v for k, v in spec.items() if k not in ("every", "interval")}
            cls = {"vtk": out.VTKOutput, "npz": out.NpzOutput, "csv": out.CSVOutput}[key]
            try:
                hooks.append(self.call(_join("output", key), options, cls, directory, self.steps(sim, spec),
                                       **options))
            except ImportError as e:  # an optional dependency of the writer (pyevtk)
                self.fail(_join("output", key), MISSING, str(e))
        return hooks

    def checkpoint(self, sim: Simulation, directory: str) -> dict | None:
        spec = self.scene.get("checkpoint")
        if spec is None:
            return None
        every = self.steps(sim, spec) if ("every" in spec or "interval" in spec) else None
        return {"path": os.path.join(directory, spec.get("path", "checkpoint.tsubu")), "every": every,
                "keep": spec.get("keep", 3)}


# Names a particle file's columns may have: tsubu.output's first, then common spellings. A
# vector is one (N, 3) array (npz) or three columns NAME_x, NAME_y, NAME_z (CSV).
_PARTICLE_COLUMNS = (
    ("positions", ("positions", "position", ""), 3),
    ("radii", ("radii", "radius", "r"), 1),
    ("velocities", ("velocities", "velocity", "v"), 3),
    ("angular_velocities", ("angular_velocities", "angular_velocity", "omega", "w"), 3),
)


def _read_columns(file: str) -> dict:
    """The arrays of an .npz file, or the columns of a CSV file with a header line (vector
    columns as ``name_x``, ``name_y``, ``name_z`` or ``name[0]``...), by name."""
    if file.endswith(".npz"):
        with np.load(file, allow_pickle=False) as z:
            return {k: np.asarray(z[k]) for k in z.files}
    if file.endswith(".csv"):
        table = np.genfromtxt(file, delimiter=",", names=True, dtype=float, comments="#",
                              encoding="utf-8", ndmin=1)
        if table.dtype.names is None:
            raise ValueError("no header line")
        return {n: np.atleast_1d(table[n]) for n in table.dtype.names}
    raise ValueError("the file must end in .npz or .csv")


def _column(columns: dict, aliases, width: int):
    for name in aliases:
        if width == 1 and name in columns:
            return np.asarray(columns[name], dtype=float).reshape(-1)
        if width == 3 and name in columns and np.ndim(columns[name]) == 2:
            return np.asarray(columns[name], dtype=float).reshape(-1, 3)
        for x, y, z in ((f"{name}_x", f"{name}_y", f"{name}_z"), (f"{name}x", f"{name}y", f"{name}z")):
            if width == 3 and x in columns and y in columns and z in columns:
                return np.stack([columns[x], columns[y], columns[z]], axis=1).astype(float)
    return None


def _fill():
    from . import fill
    return fill


def _output():
    from . import output
    return output


# ---- resume ------------------------------------------------------------------------------------

def resume(checkpoint, *, threads: int | None = None, output_directory=None) -> Scene:
    """The :class:`Scene` of a checkpoint written by a scene run (``tsubu run``): the Simulation as
    saved, with the scene's output and checkpoint settings, and the end time it was to reach.
    ``threads`` and ``output_directory`` override the saved ones, as in :func:`load_scene`.
    Raises SceneError for a ``checkpoint`` that was not written by a scene run (or whose scene no
    longer checks), and whatever ``Simulation.load`` raises for a bad file
    (:class:`tsubu.checkpoint.CheckpointError`)."""
    source = os.fspath(checkpoint)
    sim = Simulation.load(source)
    meta = getattr(sim, "metadata", None) or {}
    if not isinstance(meta, dict) or meta.get("tsubu_scene") is None or "scene" not in meta:
        raise SceneError([("", MISSING, "this checkpoint was not written by a scene run (tsubu run): "
                                        "it has no scene to resume (load it with tsubu.Simulation.load)")],
                         source)
    version = meta["tsubu_scene"]
    if not isinstance(version, int) or not isinstance(meta.get("end_time"), (int, float)):
        raise SceneError([("", MISSING, "this checkpoint's scene metadata is not tsubu's (tsubu_scene "
                                        f"= {version!r}, end_time = {meta.get('end_time')!r})")], source)
    if version > FORMAT_VERSION:
        raise SceneError([("", MISSING, f"this checkpoint's scene has format version {meta['tsubu_scene']}, "
                                        f"newer than this tsubu's ({FORMAT_VERSION}): upgrade tsubu")], source)
    checked = validate(meta["scene"], source)
    builder = _Builder(checked, meta.get("directory", "."), source)
    if threads is not None:
        sim.threads = threads
    out_dir = output_directory if output_directory is not None else meta.get("output_directory")
    out_dir = builder.output_directory(out_dir)
    return Scene(simulation=sim, end_time=float(meta["end_time"]), output=builder.output_hooks(sim, out_dir),
                 checkpoint=builder.checkpoint(sim, out_dir), output_directory=out_dir, data=meta["scene"],
                 directory=builder.directory, source=meta.get("source"))


# ---- the format's documents --------------------------------------------------------------------

def json_schema() -> dict:
    """The scene format as a JSON Schema (draft 2020-12), generated from the format's spec."""
    schema = SPEC.schema()
    return {"$schema": "https://json-schema.org/draft/2020-12/schema",
            "$id": "https://tsubu/scene.schema.json", "title": "tsubu scene file",
            "description": "The TOML scene format of `tsubu run` (docs/scene-format.md); generated by "
                           "`python -m tsubu.scene schema`.", **{k: v for k, v in schema.items()
                                                                   if k != "description"}}


def reference_markdown() -> str:
    """The key reference of docs/scene-format.md (every table and key: type, unit, default,
    meaning), generated from the format's spec."""
    out: list[str] = []

    def table(heading: str, node: Table, note: str = "") -> None:
        out.append(f"### `{heading}`\n")
        if node.doc:
            out.append(node.doc + "\n")
        if note:
            out.append(note + "\n")
        rules = [f"At most one of {_listing(g, 'and')}." for g in node.exclusive]
        rules += [f"Exactly one of {_listing(g)}." for g in node.one_of]
        if rules:
            out.append(" ".join(r.replace('"', "`") for r in rules) + "\n")
        out.append("| key | type | unit | default | meaning |")
        out.append("|---|---|---|---|---|")
        nested = []
        for key, f in node.fields.items():
            node_kind = f.node.kind()
            if isinstance(f.node, (Table, Tagged, MapOf, ArrayOf)):
                nested.append((key, f))
            default = "**required**" if f.required else _code_default(f.default)
            out.append(f"| `{key}` | {node_kind} | {f.unit} | {default} | {f.doc} |")
        out.append("")
        for key, f in nested:
            if isinstance(f.node, Table):
                table(f"[{heading.strip('[]')}.{key}]", f.node)

    for key, f in SPEC.fields.items():
        node = f.node
        item = node.item if isinstance(node, (MapOf, ArrayOf)) else node
        heading = {"materials": "[materials.NAME]"}.get(key, f"[[{key}]]" if isinstance(node, ArrayOf)
                                                          else f"[{key}]")
        if isinstance(item, Tagged):
            for name, variant in item.variants.items():
                table(f"{heading} {item.tag} = \"{name}\"", variant)
        else:
            table(heading, item, "" if not f.required else "This table is required.")
    for name, variant in _region().variants.items():
        table(f"region = {{shape = \"{name}\", ...}}", variant)
    for name, variant in _sizes().variants.items():
        table(f"sizes = {{distribution = \"{name}\", ...}}", variant)
    return "\n".join(out).rstrip() + "\n"


def _code_default(text: str | None) -> str:
    """A default for the reference: literal values as code, descriptions as text."""
    if not text:
        return ""
    literal = re.fullmatch(r'"[^"]*"|\[[^\]]*\]|-?[0-9.e+-]+|true|false', text)
    return f"`{text}`" if literal else text


REFERENCE_BEGIN = "<!-- BEGIN GENERATED REFERENCE (python -m tsubu.scene write-docs docs) -->\n"
REFERENCE_END = "<!-- END GENERATED REFERENCE -->"


def schema_text() -> str:
    """docs/scene.schema.json's expected content."""
    return json.dumps(json_schema(), indent=2) + "\n"


def with_reference(page: str) -> str:
    """``page`` (docs/scene-format.md) with the part between its markers replaced by
    :func:`reference_markdown`."""
    start = page.index(REFERENCE_BEGIN) + len(REFERENCE_BEGIN)
    return page[:start] + "\n" + reference_markdown() + "\n" + page[page.index(REFERENCE_END):]


def main(argv: list[str] | None = None) -> int:
    """``python -m tsubu.scene write-docs DOCS`` rewrites DOCS/scene.schema.json and the
    generated reference in DOCS/scene-format.md; ``schema`` and ``reference`` print them."""
    argv = sys.argv[1:] if argv is None else argv
    if argv == ["schema"]:
        print(schema_text(), end="")
        return 0
    if argv == ["reference"]:
        print(reference_markdown(), end="")
        return 0
    if len(argv) == 2 and argv[0] == "write-docs":
        with open(os.path.join(argv[1], "scene.schema.json"), "w", encoding="utf-8") as f:
            f.write(schema_text())
        page = os.path.join(argv[1], "scene-format.md")
        with open(page, encoding="utf-8") as f:
            text = with_reference(f.read())
        with open(page, "w", encoding="utf-8") as f:
            f.write(text)
        return 0
    print("usage: python -m tsubu.scene schema | reference | write-docs DOCS_DIR", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())

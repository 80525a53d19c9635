"""The scene format's schema language: the nodes a spec is made of (``Number``, ``Table``, ...),
each of which checks a value, describes itself as JSON Schema and as a short type for the
reference, and the errors they report (:class:`SceneError`, with a path and a value each).

Nothing here knows the scene format itself (that is :mod:`tsubu.scene.spec`).
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import numbers
import re

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


# The value of an error entry that has no value to show (documented as tsubu.scene.MISSING).
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
            errors.append((path, value, "must be " + _listing(self.choices) + self.hint(value)))
            return _BAD
        if not self.choices and not value:
            errors.append((path, value, "must not be empty"))
            return _BAD
        return value

    def hint(self, value: str) -> str:
        """What to say after the choices about a ``value`` that is none of them."""
        return _closest(value, self.choices)

    def schema(self):
        return {"type": "string", "enum": list(self.choices)} if self.choices else {"type": "string", "minLength": 1}

    def kind(self):
        return " \\| ".join(f'`"{c}"`' for c in self.choices) if self.choices else "string"


class Letters(String):
    """A set of letters written in one order (``"xz"``, periodic axes): one of ``choices``,
    with a hint that names the choice of the same letters in another order (``"zx"``)."""

    def hint(self, value: str) -> str:
        same = [c for c in self.choices if sorted(c) == sorted(value)]
        if same:
            return f" (the same letters in this order: {json.dumps(same[0])})"
        return _closest(value, self.choices)


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


@dataclasses.dataclass
class ByKey(Node):
    """A table whose variant is picked by which one of several keys it has (``[[meshes]]``: a
    ``file`` or a ``generator``): ``variants`` maps each key to the node (a Table or a Tagged)
    of the tables that have it."""

    variants: dict
    doc: str = ""
    name: str = ""

    def check(self, value, path, errors):
        keys = list(self.variants)
        if not isinstance(value, dict):
            errors.append((path, value, f"must be a table with a key {_listing(keys).replace(chr(34), '')}"))
            return _BAD
        given = [k for k in keys if k in value]
        if len(given) != 1:
            errors.append((path or "(top level)", MISSING, "give exactly one of " + _listing(keys)
                           + (f", not {_listing(given, 'and')}" if given else "")))
            return _BAD
        return self.variants[given[0]].check(value, path, errors)

    def schema(self):
        out: dict = {"description": self.doc} if self.doc else {}
        out["type"] = "object"
        out["oneOf"] = [node.schema() for node in self.variants.values()]
        return out

    def kind(self):
        return "table (by " + " or ".join(f"`{k}`" for k in self.variants) + ")"


class StringList(Node):
    """A non-empty array of non-empty strings (names)."""

    def check(self, value, path, errors):
        if (not isinstance(value, list) or not value
                or not all(isinstance(v, str) and v for v in value)):
            errors.append((path, value, "must be a non-empty array of names (strings)"))
            return _BAD
        return list(value)

    def schema(self):
        return {"type": "array", "items": {"type": "string", "minLength": 1}, "minItems": 1}

    def kind(self):
        return "array of strings"

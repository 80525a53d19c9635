"""The declarations of every option a user sets (the material fields, the per-pair overrides,
the run options): name, unit, range, default, a one-line doc and the docstrings' paragraph,
declared once in the core (cpp/include/tsubu/option_table.hpp) and read here through
``_core.option_table()``.

The Python checks (:func:`check`, used by Material, Simulation and Simulation.set_pair), the
fields of tsubu.Material and the keyword arguments of tsubu.Simulation with their docstrings
(:func:`parameter_entries`, :func:`keyword_function`), and the scene format's spec
(tsubu.scene.spec) are built from these; tests/test_option_declarations.py checks that the core
and Python accept and refuse the same values.
"""

from __future__ import annotations

import __future__
import dataclasses
import json
import linecache
import re
import textwrap

from . import _checks, _core


@dataclasses.dataclass(frozen=True)
class Declaration:
    """One option's declaration (the fields of ``_core.option_table()``'s dicts).

    ``kind`` is "real", "integer", "flag", "choice" or "vector"; ``scopes`` a tuple of
    "material", "pair", "run"; ``minimum``/``maximum`` None where unbounded; ``zero_means``
    what the core's 0 stands for (Python's None), or None; ``scale`` the factor from ``unit`` to
    the core's ``core_unit``; ``default`` a Choice's first choice, a Vector's None;
    ``checked_for`` the materials the core checks the range on ("any", "linear", "hertzian");
    ``needs_hertzian`` why a value > 0 needs a Hertzian material (youngs_modulus), or None;
    ``law_choice`` whether the contact laws read this run choice; ``details`` the paragraph of
    the docstrings' Parameters entry (numpy-style RST, unwrapped), or ""."""

    name: str
    scopes: tuple
    kind: str
    unit: str
    minimum: float | int | None
    maximum: float | int | None
    exclusive_minimum: bool
    exclusive_maximum: bool
    zero_means: str | None
    choices: tuple
    default: object
    default_text: str
    doc: str
    scale: float
    core_unit: str
    checked_for: str
    needs_hertzian: str | None
    law_choice: bool
    details: str


#: Every declared option, by name, in the declaration table's order.
DECLARATIONS: dict[str, Declaration] = {d["name"]: Declaration(**d) for d in _core.option_table()}


def declared(scope: str) -> list[str]:
    """The names of the options of one scope ("material", "pair" or "run"), in table order."""
    return [name for name, d in DECLARATIONS.items() if scope in d.scopes]


def check(name: str, value, label: str | None = None):
    """``value`` checked against the declaration of option ``name`` and converted (a float, an
    int, a bool, a choice's name, a 3-tuple); TypeError or ValueError naming ``label`` (default
    ``name``) and the value, as every check of :mod:`tsubu._checks` does."""
    d = DECLARATIONS[name]
    label = name if label is None else label
    if d.kind == "real":
        return _checks.bounded(label, value, d.minimum, d.maximum, lo_open=d.exclusive_minimum,
                               hi_open=d.exclusive_maximum)
    if d.kind == "integer":
        return _checks.whole(label, value, minimum=d.minimum, maximum=d.maximum)
    if d.kind == "flag":
        if not isinstance(value, bool):
            raise TypeError(f"{label} must be a bool, got {value!r}")
        return value
    if d.kind == "choice":
        return _checks.choice(label, value, d.choices)
    return _checks.vec3(label, value)


# ---- docstrings and signatures from the declarations ----------------------------------------

def python_type(name: str) -> str:
    """The type of option ``name`` as a numpy-style docstring writes it ("float or None",
    '{"rotate", "literal"}', ...)."""
    d = DECLARATIONS[name]
    if d.kind == "choice":
        return "{" + ", ".join(json.dumps(c) for c in d.choices) + "}"
    if d.kind == "vector":
        return "sequence of 3 floats"
    base = {"real": "float", "integer": "int", "flag": "bool"}[d.kind]
    return base + " or None" if d.zero_means is not None else base


def parameter_entries(names, types: dict | None = None, indent: str = "    ",
                      width: int = 96) -> str:
    """The numpy-style Parameters entries ("name : type" and its paragraph, wrapped) of the
    options ``names``, from their declarations; ``types`` replaces the type of some."""
    out = []
    for name in names:
        d = DECLARATIONS[name]
        text = d.details
        if not text:
            unit = f" [{d.unit}]" if d.unit else ""
            text = f"{d.doc[:-1]}{unit}. Default {d.default_text}."
        out.append(f"{indent}{name} : {(types or {}).get(name) or python_type(name)}\n")
        # (an inline literal, ``...``, is kept on one line)
        text = re.sub(r"``.+?``", lambda m: m.group().replace(" ", "\0"), text)
        out.append(textwrap.fill(text, width, initial_indent=indent * 2,
                                 subsequent_indent=indent * 2, break_long_words=False,
                                 break_on_hyphens=False).replace("\0", " ") + "\n")
    return "".join(out)


def with_parameters(doc: str, entries: str) -> str:
    """``doc`` with ``entries`` first in its Parameters section (after the dashes under the
    header)."""
    found = re.search(r"^ *Parameters\n *-+\n", doc, re.M)
    if found is None:
        raise ValueError("the docstring has no Parameters section")
    return doc[:found.end()] + entries + doc[found.end():]


def _literal(value) -> str:
    """``value`` as the source code of a default argument (strings in double quotes)."""
    return json.dumps(value) if isinstance(value, str) else repr(value)


def signature_default(name: str):
    """The default of run option ``name`` in Simulation's signature: None where the core's 0
    means "not given", a tuple for a vector, else the declared default."""
    d = DECLARATIONS[name]
    if d.zero_means is not None:
        return None
    if d.kind == "vector":
        return tuple(float(x) for x in json.loads(d.default_text))
    return d.default


def keyword_function(qualname: str, module: str, names, target):
    """A function ``(self, <each of names>=<its signature_default>)`` that returns
    ``target(self, {name: value, ...})``: a constructor whose keyword arguments, their order and
    defaults are the declarations'. Its source is generated (as dataclasses generate theirs)
    and kept in linecache, so that inspect.getsource and the API reference show it."""
    params = []
    for name in names:
        d = DECLARATIONS[name]
        annotation = ("" if d.zero_means is not None or d.kind == "vector" else
                      ": " + {"real": "float", "integer": "int", "flag": "bool",
                              "choice": "str"}[d.kind])
        params.append(f"{name}{annotation}={_literal(signature_default(name))}")
    *owners, function = qualname.split(".")
    source = (f"def {function}(self, {', '.join(params)}):\n"
              f"    return _target(self, {{{', '.join(f'{n!r}: {n}' for n in names)}}})\n")
    for owner in reversed(owners):  # nested in its class: Python's messages name it so
        source = f"class {owner}:\n" + textwrap.indent(source, "    ")
    filename = f"<tsubu declared options: {module}.{qualname}>"
    code = compile(source, filename, "exec", flags=__future__.annotations.compiler_flag,
                   dont_inherit=True)
    namespace = {"_target": target}
    exec(code, namespace)
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    made = namespace
    for part in qualname.split("."):
        made = made[part] if isinstance(made, dict) else vars(made)[part]
    made.__module__ = module
    return made

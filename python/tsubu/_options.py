"""The declarations of every option a user sets (the material fields, the per-pair overrides,
the run options): name, unit, range, default and a one-line doc, declared once in the core
(cpp/include/tsubu/option_table.hpp) and read here through ``_core.option_table()``.

The Python checks (:func:`check`, used by Material, Simulation and Simulation.set_pair) and the
scene format's spec (tsubu.scene.spec) are built from these; tests/test_option_declarations.py
checks that the core and Python accept and refuse the same values.
"""

from __future__ import annotations

import dataclasses

from . import _checks, _core


@dataclasses.dataclass(frozen=True)
class Declaration:
    """One option's declaration (the fields of ``_core.option_table()``'s dicts).

    ``kind`` is "real", "integer", "flag", "choice" or "vector"; ``scopes`` a tuple of
    "material", "pair", "run"; ``minimum``/``maximum`` None where unbounded; ``zero_means``
    what the core's 0 stands for (Python's None), or None; ``scale`` the factor from ``unit`` to
    the core's ``core_unit``; ``default`` a Choice's first choice, a Vector's None."""

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

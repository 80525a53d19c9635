"""Materials: the contact parameters of spheres and walls."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any

from . import _core, _options
from ._options import DECLARATIONS


# The fields of the two families of materials (linear: kn, kt; Hertzian: youngs_modulus,
# poisson_ratio): None by default, filled in by the family's rules (__post_init__).
_FAMILY = ("kn", "kt", "youngs_modulus", "poisson_ratio")


def _declared_fields(cls):
    """``cls`` with a field per declared material option (cpp/include/tsubu/option_table.hpp), in
    the declarations' order and before the class's own (``name``), each with its declared
    default (None for the family fields) and its Parameters entry in the docstring."""
    names = _options.declared("material")
    annotations = {}
    for name in names:
        annotations[name] = ("float | None" if name in _FAMILY else
                             {"real": "float", "choice": "str"}[DECLARATIONS[name].kind])
        setattr(cls, name, None if name in _FAMILY else DECLARATIONS[name].default)
    cls.__annotations__ = {**annotations, **cls.__dict__.get("__annotations__", {})}
    cls.__doc__ = _options.with_parameters(
        cls.__doc__, _options.parameter_entries(names, {n: "float or None" for n in _FAMILY}))
    return cls


# Material's fields and their Parameters entries come from the declarations (_declared_fields,
# before the dataclass is made); its own field is the name.
@dataclass(frozen=True, eq=False)
@_declared_fields
class Material:
    """Contact and bulk parameters of one material (SI units).

    Every sphere and wall has a material. A Material is immutable (a frozen dataclass: its
    fields are read as attributes, with the defaults below filled in) and compared by identity. A material follows one of two contact laws:

    * **linear** (Kelvin-Voigt, the default): give ``kn`` (and optionally ``kt``);
    * **Hertz-Mindlin**: give ``youngs_modulus`` (and ``poisson_ratio``). The normal force is
      Hertz's ``(4/3) E* sqrt(R*) delta^(3/2)`` with a dashpot that gives the restitution at any
      impact speed, the tangential spring Mindlin's ``k_t = 8 G* sqrt(R* delta)``
      (docs/physics.md). Giving ``kn`` or ``kt`` too is a ValueError; so is a scene whose
      spheres and walls mix the two kinds.

    The parameters of a contact between two materials are mixed once, when a run starts (see
    :meth:`Simulation.set_pair` to override a pair), each by the rule its entry below gives
    (docs/physics.md).

    Parameters
    ----------
    name : str, optional
        A label for printing and error messages. Default None.

    Raises
    ------
    TypeError
        For a parameter that is not a real number (a bool, a string), or a name that is not a
        string.
    ValueError
        For a parameter out of its range (the message names it and gives the range), both
        ``kn``/``kt`` and ``youngs_modulus``, a ``poisson_ratio`` without ``youngs_modulus``, a
        parameter > 0 that its entry says is only for a Hertzian material without
        ``youngs_modulus``, an unknown ``roughness_distribution`` or ``shadow``, or a uniform
        roughness whose range ``sqrt(3) roughness`` reaches 90 degrees.
    """

    name: str | None = field(default=None)

    if TYPE_CHECKING:  # (type checkers see no declared field: any keyword, any attribute)
        def __init__(self, *args: Any, **fields: Any) -> None: ...
        def __getattr__(self, name: str) -> Any: ...

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        hertz = self.youngs_modulus is not None
        if hertz and (self.kn is not None or self.kt is not None):
            raise ValueError(
                "a material is either linear (kn, kt) or Hertzian (youngs_modulus, poisson_ratio), "
                f"got kn={self.kn!r}, kt={self.kt!r} and youngs_modulus={self.youngs_modulus!r}")
        if not hertz and self.poisson_ratio is not None:
            raise ValueError(f"poisson_ratio={self.poisson_ratio!r} needs youngs_modulus (a "
                             "Hertzian material); a linear material takes kn, kt")
        for name in _PARAMETERS:
            value = getattr(self, name)
            if name == "kn" and value is None:
                if hertz:
                    continue
                value = DECLARATIONS["kn"].default
            if name == "kt" and value is None:
                if hertz:
                    continue
                value = 2.0 / 7.0 * self.kn  # (the declared "2/7 kn"; kn comes first, checked)
            if name == "youngs_modulus" and value is None:
                continue
            if name == "poisson_ratio" and value is None:
                if not hertz:
                    continue
                value = DECLARATIONS["poisson_ratio"].default
            set_(self, name, _check_field(name, value))
        for name in _PARAMETERS:  # (a parameter of a law offered on Hertz's law only)
            why = DECLARATIONS[name].needs_hertzian
            if why and not hertz and getattr(self, name) > 0:
                raise ValueError(f"{name}={getattr(self, name)!r} needs youngs_modulus ({why})")
        _check_uniform_range(self.roughness_distribution, self.roughness)
        if self.name is not None and not isinstance(self.name, str):
            raise TypeError(f"name must be a string, got {self.name!r}")

    @property
    def hertzian(self) -> bool:
        """Whether the material follows Hertz-Mindlin (given a Young's modulus)."""
        return self.youngs_modulus is not None

    def _to_core(self) -> "_core.Material":
        """The compiled core's Material (roughness in radians; the other law's fields at the
        core's defaults, unused)."""
        return _to_core(_core.Material, {k: v for k, v in vars(self).items() if v is not None})


# Checks and units of the parameters, shared by Material and Simulation.set_pair. The core's
# classes list their own fields (_core.Material.fields, _core.PairParams.fields); tests/
# test_bindings.py checks they are these.
_PARAMETERS = tuple(f.name for f in fields(Material) if f.name != "name")


def _check_field(name: str, value):
    """One contact or bulk parameter in the Python API's units (roughness in degrees), checked
    against its declaration."""
    return _options.check(name, value)


def _check_uniform_range(distribution: str, roughness: float) -> None:
    if distribution == "uniform" and 3**0.5 * roughness >= 90.0:
        raise ValueError(f"roughness with a uniform distribution must be < 90/sqrt(3) degrees "
                         f"(its range is +-sqrt(3) sigma), got {roughness!r}")


def _to_core(cls, values):
    """``cls`` (_core.Material or _core.PairParams) from a mapping of its fields in the Python
    API's units."""
    return cls(**{n: values[n] * DECLARATIONS[n].scale if DECLARATIONS[n].scale != 1 else values[n]
                  for n in cls.fields if n in values})


def _from_core(params) -> dict:
    """A _core.PairParams (or Material) as a dict of its fields in the Python API's units."""
    p = {n: getattr(params, n) for n in params.fields}
    p["roughness"] = math.degrees(p["roughness"])  # the inverse of its declared scale, exactly
    return p

"""Materials: the contact parameters of spheres and walls."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

from . import _core, _options
from ._options import DECLARATIONS


@dataclass(frozen=True, eq=False)
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
    :meth:`Simulation.set_pair` to override a pair):

    * ``kn``, ``kt``: harmonic mean ``2 a b / (a + b)`` (two half-springs in series; equal
      materials keep their own value);
    * Hertzian: ``1/E* = (1 - nu_a^2)/E_a + (1 - nu_b^2)/E_b`` and
      ``1/G* = (2 - nu_a)/G_a + (2 - nu_b)/G_b``, ``G = E / (2 (1 + nu))`` (a plane wall: the
      wall material's E and nu, with ``R* = r`` and ``m* = m`` of the sphere; a rigid wall is a
      wall material with a much larger E);
    * ``restitution``, ``friction``, ``rolling_friction``, ``tangential_damping``,
      ``work_of_adhesion``: geometric mean (for the work of adhesion, Dupre's
      ``w_ab = gamma_a + gamma_b - gamma_ab`` with Berthelot's rule for the interface).

    Parameters
    ----------
    density : float
        Mass density [kg/m^3], > 0. Default 2500 (glass). Unused for walls.
    kn : float or None
        Normal spring stiffness [N/m], > 0 (linear Kelvin-Voigt law, eq. 1.6). Default 1e3 for a
        linear material; None (unused) for a Hertzian one.
    kt : float or None
        Tangential spring stiffness [N/m], >= 0. Default ``2/7 kn``, which gives the tangential
        oscillation of a rolling sphere the frequency of the normal one. None for a Hertzian
        material.
    youngs_modulus : float or None
        Young's modulus E [Pa], > 0: makes the material Hertzian. Default None (linear).
    poisson_ratio : float or None
        Poisson's ratio nu in (-1, 0.5] of a Hertzian material. Default 0.3 when
        ``youngs_modulus`` is given; giving it without ``youngs_modulus`` is a ValueError.
    restitution : float
        Normal coefficient of restitution e in (0, 1]. Default 0.5. Linear law: the normal dashpot is
        ``eta_n = -2 ln(e) sqrt(m_eff kn / (pi^2 + ln^2 e))`` (eq. B.9) with the reduced mass
        ``m_eff = m_i m_j / (m_i + m_j)`` of the pair (walls: ``m_i``), so every contact
        rebounds with e. The normal force is not clipped at zero (B.9 assumes it). Hertzian:
        ``eta_n = 2 sqrt(5/6) |beta| sqrt(S_n m*)``, ``S_n = 2 E* sqrt(R* delta)``,
        ``beta = ln e / sqrt(ln^2 e + pi^2)`` (or, with ``Simulation(hertz_force="repulsive")``,
        the dashpot that gives e with a force clipped at zero).
    friction : float
        Coulomb friction coefficient mu >= 0 (eqs. 1.17-1.18). Default 0.5. 0 makes contacts frictionless:
        the run then uses a specialisation with no tangential code or history.
    rolling_friction : float
        Rolling friction coefficient mu_r >= 0 (eq. 1.20), dimensionless. Default 0.
    tangential_damping : float
        Tangential dashpot as a fraction of the normal one, ``eta_t = tangential_damping *
        eta_n`` (eq. 1.11), >= 0. Default 0, as in the shared reference scene and LAMMPS's
        ``gran/hooke/history`` with ``gamma_t = 0`` (LAMMPS's NULL default is 0.5).
    roughness : float
        Standard deviation sigma of the roughness scatter angle, in DEGREES, in [0, 90): at
        first touch the contact normal is tilted by a random angle dG (docs/roughness.md).
        0 (default): smooth, and the run uses a specialisation without roughness code. Two
        materials combine as sqrt(sigma_a^2 + sigma_b^2).
    work_of_adhesion : float
        Work of adhesion w [J/m^2] >= 0 of two surfaces of this material (``2 gamma``, gamma its
        surface energy). Default 0 (no adhesion). Only for a Hertzian material: w > 0 makes the
        scene adhesive, with the normal law chosen by ``Simulation(adhesion=...)``: JKR
        (default; the contact is made at zero overlap and holds to the negative overlap
        ``delta_c = -(3/4) (pi^2 w^2 R* / E*^2)^(1/3)``, pull-off force ``(3/2) pi w R*``) or
        DMT (Hertz's force less ``2 pi w R*``, pull-off ``2 pi w R*``), with the Hertzian
        dashpot and Mindlin's spring (docs/physics.md). Two materials mix as
        ``sqrt(w_a w_b)``. Roughness, ``hertz_force="repulsive"`` and
        ``slip_rule="truncate"`` are not offered with adhesion.
    roughness_distribution : {"normal", "uniform"}
        Distribution of dG: zero-mean normal with standard deviation sigma, truncated to
        ``abs(dG) < 90`` degrees (default), or uniform on [-sqrt(3) sigma, sqrt(3) sigma] (same
        standard deviation).
    shadow : {"reject", "weighted", "none"}
        Shadow effect at walls (Sommerfeld & Huber 1999): "reject" (default) redraws tilts the
        sphere could not meet (dG < -gamma in the plane of incidence); "weighted" also weights
        the accepted tilts by sin(gamma + dG); "none" keeps every draw.
    name : str, optional
        A label for printing and error messages. Default None.

    Raises
    ------
    TypeError
        For a parameter that is not a real number (a bool, a string), or a name that is not a
        string.
    ValueError
        For a parameter out of its range (the message names it and gives the range), both
        ``kn``/``kt`` and ``youngs_modulus``, a ``poisson_ratio`` or a ``work_of_adhesion`` > 0
        without ``youngs_modulus``, an
        unknown ``roughness_distribution`` or ``shadow``, or a uniform roughness whose range
        ``sqrt(3) roughness`` reaches 90 degrees.
    """

    # The defaults are the option declarations' (cpp/include/tsubu/option_table.hpp); kn, kt,
    # youngs_modulus and poisson_ratio default to None, filled in by the law (__post_init__).
    density: float = DECLARATIONS["density"].default
    kn: float | None = None
    kt: float | None = None
    youngs_modulus: float | None = None
    poisson_ratio: float | None = None
    restitution: float = DECLARATIONS["restitution"].default
    friction: float = DECLARATIONS["friction"].default
    rolling_friction: float = DECLARATIONS["rolling_friction"].default
    tangential_damping: float = DECLARATIONS["tangential_damping"].default
    roughness: float = DECLARATIONS["roughness"].default
    work_of_adhesion: float = DECLARATIONS["work_of_adhesion"].default
    roughness_distribution: str = DECLARATIONS["roughness_distribution"].default
    shadow: str = DECLARATIONS["shadow"].default
    name: str | None = field(default=None)

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
        if not hertz and self.work_of_adhesion > 0:
            raise ValueError(f"work_of_adhesion={self.work_of_adhesion!r} needs youngs_modulus "
                             "(adhesion is offered on Hertz's law)")
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

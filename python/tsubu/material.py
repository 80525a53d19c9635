"""Materials: the contact parameters of spheres and walls."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from . import _checks, _core


@dataclass(frozen=True, eq=False)
class Material:
    """Contact and bulk parameters of one material (SI units).

    Every sphere and wall has a material. The parameters of a contact between two materials are
    mixed once, when a run starts (see ``Simulation.set_pair`` to override a pair):

    * ``kn``, ``kt``: harmonic mean ``2 a b / (a + b)`` (two half-springs in series; equal
      materials keep their own value);
    * ``restitution``, ``friction``, ``rolling_friction``, ``tangential_damping``: geometric mean.

    Parameters
    ----------
    density : float
        Mass density [kg/m^3], > 0. Unused for walls.
    kn : float
        Normal spring stiffness [N/m], > 0 (linear Kelvin-Voigt law, eq. 1.6).
    kt : float or None
        Tangential spring stiffness [N/m], >= 0. Default ``2/7 kn``, which gives the tangential
        oscillation of a rolling sphere the frequency of the normal one.
    restitution : float
        Normal coefficient of restitution e in (0, 1]. The normal dashpot is
        ``eta_n = -2 ln(e) sqrt(m_eff kn / (pi^2 + ln^2 e))`` (eq. B.9) with the reduced mass
        ``m_eff = m_i m_j / (m_i + m_j)`` of the pair (walls: ``m_i``), so every contact
        rebounds with e. The normal force is not clipped at zero (B.9 assumes it).
    friction : float
        Coulomb friction coefficient mu >= 0 (eqs. 1.17-1.18). 0 makes contacts frictionless:
        the run then uses a specialisation with no tangential code or history.
    rolling_friction : float
        Rolling friction coefficient mu_r >= 0 (eq. 1.20), dimensionless.
    tangential_damping : float
        Tangential dashpot as a fraction of the normal one, ``eta_t = tangential_damping *
        eta_n`` (eq. 1.11), >= 0. Default 0, as in the shared reference scene and LAMMPS's
        ``gran/hooke/history`` with ``gamma_t = 0`` (LAMMPS's NULL default is 0.5).
    roughness : float
        Standard deviation sigma of the roughness scatter angle, in DEGREES, in [0, 90): at
        first touch the contact normal is tilted by a random angle dG (docs/roughness.md).
        0 (default): smooth, and the run uses a specialisation without roughness code. Two
        materials combine as sqrt(sigma_a^2 + sigma_b^2).
    roughness_distribution : {"normal", "uniform"}
        Distribution of dG: zero-mean normal with standard deviation sigma, truncated to
        |dG| < 90 degrees (default), or uniform on [-sqrt(3) sigma, sqrt(3) sigma] (same
        standard deviation).
    shadow : {"reject", "weighted", "none"}
        Shadow effect at walls (Sommerfeld & Huber 1999): "reject" (default) redraws tilts the
        sphere could not meet (dG < -gamma in the plane of incidence); "weighted" also weights
        the accepted tilts by sin(gamma + dG); "none" keeps every draw.
    name : str, optional
        A label for printing.
    """

    density: float = 2500.0
    kn: float = 1.0e3
    kt: float | None = None
    restitution: float = 0.5
    friction: float = 0.5
    rolling_friction: float = 0.0
    tangential_damping: float = 0.0
    roughness: float = 0.0
    roughness_distribution: str = "normal"
    shadow: str = "reject"
    name: str | None = field(default=None)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "density", _checks.positive("density", self.density))
        set_(self, "kn", _checks.positive("kn", self.kn))
        kt = 2.0 / 7.0 * self.kn if self.kt is None else _checks.positive("kt", self.kt, allow_zero=True)
        set_(self, "kt", kt)
        set_(self, "restitution",
             _checks.in_range("restitution", self.restitution, 0.0, 1.0, lo_open=True, hi_open=False))
        set_(self, "friction", _checks.positive("friction", self.friction, allow_zero=True))
        set_(self, "rolling_friction",
             _checks.positive("rolling_friction", self.rolling_friction, allow_zero=True))
        set_(self, "tangential_damping",
             _checks.positive("tangential_damping", self.tangential_damping, allow_zero=True))
        set_(self, "roughness",
             _checks.in_range("roughness", self.roughness, 0.0, 90.0, lo_open=False, hi_open=True))
        _checks.choice("roughness_distribution", self.roughness_distribution,
                       _core.choices["roughness_distribution"])
        if self.roughness_distribution == "uniform" and 3**0.5 * self.roughness >= 90.0:
            raise ValueError(f"roughness with a uniform distribution must be < 90/sqrt(3) degrees "
                             f"(its range is +-sqrt(3) sigma), got {self.roughness!r}")
        _checks.choice("shadow", self.shadow, _core.choices["shadow"])
        if self.name is not None and not isinstance(self.name, str):
            raise TypeError(f"name must be a string, got {self.name!r}")

    def _to_core(self) -> "_core.Material":
        """The compiled core's Material: every field the core binds (``_core.Material.fields``),
        with the roughness in radians."""
        core = _core.Material()
        for name in _core.Material.fields:
            value = getattr(self, name)
            setattr(core, name, math.radians(value) if name == "roughness" else value)
        return core

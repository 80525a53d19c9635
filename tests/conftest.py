"""Shared helpers for the physics tests: the reference material and the closed forms of
appendix B of shared/seeds/dem_basics.md.

Test modules import the plain functions (``from conftest import make_material``); the only
fixtures are prefixed ``ref_`` so they cannot clash with fixtures defined elsewhere.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu

# The reference scene: glass-like spheres of radius 0.5 mm, kn = 1000 N/m, kt = 2/7 kn.
REF_DENSITY = 2500.0  # kg/m^3
REF_KN = 1.0e3  # N/m
REF_RADIUS = 0.5e-3  # m
REF_FRICTION = 0.5


def make_material(**kw) -> tsubu.Material:
    """The reference material (density 2500, kn 1000 N/m, kt = 2/7 kn, friction 0.5,
    restitution 0.5); keywords override any field."""
    args = dict(density=REF_DENSITY, kn=REF_KN, kt=2.0 / 7.0 * REF_KN, restitution=0.5,
                friction=REF_FRICTION)
    args.update(kw)
    return tsubu.Material(**args)


def sphere_mass(radius: float = REF_RADIUS, density: float = REF_DENSITY) -> float:
    """m = density * 4/3 pi r^3."""
    return density * 4.0 / 3.0 * math.pi * radius ** 3


def damping_from_restitution(e: float, m_eff: float, k: float) -> float:
    """eta = -2 ln(e) sqrt(m_eff k / (pi^2 + ln^2 e))   (B.9)."""
    le = math.log(e)
    return -2.0 * le * math.sqrt(m_eff * k / (math.pi ** 2 + le ** 2))


def damped_frequency(k: float, m_eff: float, eta: float) -> float:
    """alpha = sqrt(k/m_eff - (eta / (2 m_eff))^2)   (B.3)."""
    return math.sqrt(k / m_eff - (eta / (2.0 * m_eff)) ** 2)


def contact_time(e: float, m_eff: float, k: float = REF_KN) -> float:
    """t_c = pi / alpha   (B.5), with eta from (B.9)."""
    return math.pi / damped_frequency(k, m_eff, damping_from_restitution(e, m_eff, k))


@pytest.fixture
def ref_material() -> tsubu.Material:
    """The reference material with its default restitution 0.5 and friction 0.5."""
    return make_material()


def momenta(sim: tsubu.Simulation, origin):
    """Linear momentum, angular momentum about `origin` (orbital m x × v + spin I w, I = 2/5 m r^2)
    and the scales sum m|v| and sum |m x × v| + |I w| used for relative errors."""
    x = sim.positions - origin
    v, w, m, r = sim.velocities, sim.angular_velocities, sim.masses, sim.radii
    p = m[:, None] * v
    orbital = np.cross(x, p)
    spin = (0.4 * m * r * r)[:, None] * w
    return (p.sum(0), np.abs(p).sum(), orbital.sum(0) + spin.sum(0),
            np.abs(orbital).sum() + np.abs(spin).sum())

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


def add_cube_walls(sim: tsubu.Simulation, side: float, material: tsubu.Material) -> None:
    """Six planes enclosing the cube [0, side]^3, normals inwards."""
    for ax in range(3):
        n = np.zeros(3)
        n[ax] = 1.0
        sim.add_plane(point=(0.0, 0.0, 0.0), normal=n, material=material)
        sim.add_plane(point=n * side, normal=-n, material=material)


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


def squeezed_pack(kind: str, f: float, cells: int = 3, squeeze_top: bool = False):
    """Spheres of the reference material (e = 0.5, friction 0.5) on a simple-cubic ("sc"),
    body-centred ("bcc") or face-centred ("fcc") lattice, nearest neighbours at 1.98 R (1 %
    overlap); the walls x, y, z = 0 touch the first layer with the same 1 % overlap, the three
    opposite walls either squeeze the outer layer by 1 % too (``squeeze_top``) or stand at
    cells x lattice constant + 0.99 R (a gap, as benchmarks/stability.py); no gravity, random
    velocities of 1 mm/s (seed 1), dt = f 2 sqrt(m/2 / k). Returns (simulation, box side)."""
    r, k, m = REF_RADIUS, REF_KN, sphere_mass()
    d = 1.98 * r
    if kind == "sc":
        a, basis = d, [(0, 0, 0)]
    elif kind == "bcc":
        a, basis = 2 * d / math.sqrt(3), [(0, 0, 0), (0.5, 0.5, 0.5)]
    else:
        a, basis = d * math.sqrt(2), [(0, 0, 0), (0.5, 0.5, 0), (0.5, 0, 0.5), (0, 0.5, 0.5)]
    x = np.array([(np.array([i, j, l]) + b) * a for i in range(cells) for j in range(cells)
                  for l in range(cells) for b in basis]) + 0.99 * r
    side = x.max() + 0.99 * r if squeeze_top else cells * a + 0.99 * r
    mat = make_material(restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=f * 2 * math.sqrt(m / 2 / k), threads=1,
                           allow_unstable_dt=True)
    sim.add_spheres(x, r, mat, velocities=np.random.default_rng(1).normal(0.0, 1e-3, x.shape))
    for axis in range(3):
        n = np.eye(3)[axis]
        sim.add_plane(point=(0.0, 0.0, 0.0), normal=n, material=mat)
        sim.add_plane(point=side * n, normal=-n, material=mat)
    return sim, side


def mechanical(sim: tsubu.Simulation) -> float:
    """Kinetic + elastic energy [J] (no gravity in the squeezed packs)."""
    e = sim.energy()
    return e["kinetic"] + e["elastic"]

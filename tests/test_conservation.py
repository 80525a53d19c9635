"""Momentum conservation in a free frictional cloud (no gravity, no walls).

Every contact force acts on i and -force on j, so sum m v is conserved (A.5, A.9). Every
pair's torques are T_i = -c_i n x F_t and T_j = -c_j n x F_t with c_i + c_j = |x_ij|
(DESIGN.md note 2), so they cancel the moment x_ij x F = |x_ij| n x F_t of its forces, and the
total angular momentum sum(m x × v + I w) is conserved (A.22-A.24, plus the spin). Symplectic
Euler keeps both exactly (x^{n+1} × m v^{n+1} = x^n × m v^{n+1} + dt v^{n+1} × m v^{n+1}), so
the only error is round-off.

Rolling friction (1.20) with unequal radii is not torque-free (docs/physics.md), so the
polydisperse cloud has none; a monodisperse cloud with rolling friction (M_ij = -M_ji there)
is checked as well.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu
from conftest import momenta

RHO = 2500.0
KN = 1.0e3


def cloud(seed: int, n: int, r_min: float, r_max: float, rolling_friction: float = 0.0,
          history: str = "rotate") -> tsubu.Simulation:
    """n spheres on a jittered cubic lattice (spacing 2.2 r_max, so no initial overlap),
    radii uniform in [r_min, r_max], random velocities (0.2 m/s rms per component) and spins."""
    rng = np.random.default_rng(seed)
    side = math.ceil(n ** (1.0 / 3.0))
    spacing = 2.2 * r_max
    grid = np.stack(np.meshgrid(*(np.arange(side),) * 3, indexing="ij"), -1).reshape(-1, 3)[:n]
    radii = rng.uniform(r_min, r_max, n)
    pos = grid * spacing + rng.uniform(-0.09, 0.09, (n, 3)) * r_max
    pos += rng.uniform(-1.0, 1.0, 3) * 1e-3  # the cloud is not centred on the origin
    vel = rng.normal(0.0, 0.2, (n, 3))
    spin = rng.normal(0.0, 200.0, (n, 3))
    mat = tsubu.Material(density=RHO, kn=KN, restitution=0.5, friction=0.5,
                         rolling_friction=rolling_friction)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), threads=1, tangential_history=history)
    sim.add_spheres(pos, radii, mat, velocities=vel, angular_velocities=spin)
    return sim




def check_cloud(sim: tsubu.Simulation, steps: int, chunk: int = 10):
    """Worst relative errors of P and L over the run, the number of distinct pairs seen in
    contact (sampled every `chunk` steps, well below a contact's t_c = 50 dt) and the
    dissipated energy over the initial kinetic energy."""
    m = sim.masses
    com = (m[:, None] * sim.positions).sum(0) / m.sum()
    p0, p_scale, l0, l_scale = momenta(sim, com)
    ke0 = sim.energy()["kinetic"]
    pairs, worst_p, worst_l = set(), 0.0, 0.0
    for _ in range(steps // chunk):
        sim.run(steps=chunk)
        c = sim.contacts()
        pairs.update(zip(c["i"].tolist(), c["j"].tolist()))
        p, _, l, _ = momenta(sim, com)
        worst_p = max(worst_p, np.max(np.abs(p - p0)) / p_scale)
        worst_l = max(worst_l, np.max(np.abs(l - l0)) / l_scale)
    return worst_p, worst_l, len(pairs), sim.energy()["dissipated"] / ke0


@pytest.mark.parametrize("history", ["rotate", "literal"])
@pytest.mark.parametrize("seed", [1, 2])
def test_polydisperse_frictional_cloud_conserves_momenta(seed, history):
    """300 spheres, radii 0.25-0.5 mm, friction 0.5, e = 0.5, 4000 steps:
    |P - P0| <= 1e-12 sum m|v0|, |L - L0| <= 1e-10 (sum |m x × v| + |I w|) about the
    initial centre of mass, with many collisions (> 100 distinct pairs touched, > 5 % of KE dissipated)."""
    sim = cloud(seed, 300, 0.25e-3, 0.5e-3, history=history)
    worst_p, worst_l, pairs, dissipated = check_cloud(sim, 4000)
    assert pairs > 100, pairs
    assert dissipated > 0.05, dissipated
    assert worst_p <= 1e-12, worst_p
    assert worst_l <= 1e-10, worst_l


def test_monodisperse_cloud_with_rolling_friction_conserves_momenta():
    """Equal radii: the rolling torques of a pair are opposite (1.20), so angular momentum is
    still conserved to round-off with rolling friction 0.1."""
    sim = cloud(3, 300, 0.4e-3, 0.4e-3, rolling_friction=0.1)
    assert "rolling" in sim.law
    worst_p, worst_l, pairs, dissipated = check_cloud(sim, 4000)
    assert pairs > 100, pairs
    assert dissipated > 0.05, dissipated
    assert worst_p <= 1e-12, worst_p
    assert worst_l <= 1e-10, worst_l

"""Points of the stability map of benchmarks/stability.py (docs/benchmarks.md, "Stability map"),
pinned: where the time loop must stay bounded, and where it must blow up *and be caught*.

Units: f = dt / (2 sqrt(m_red / k)), the notes' spring-only bound (2.24) for the stiffest, lightest
contact of the scene (m_red = m/2 for two equal spheres).

* Squeezed lattices. A sphere with neighbours on both sides along an axis feels 2k: the highest
  mode of a chain of equal masses and springs has omega_max^2 = 4 k / m, so symplectic Euler is
  stable only for dt < 2 / omega_max = sqrt(m / k), i.e. f < 1/sqrt(2) = 0.71 (the dashpot lowers
  it further, and the tangential springs and the walls add stiffness) -- below the single-contact
  bound that critical_time_step() reports (f = 0.81 at e = 0.5). Measured on these packs: stable
  (the energy only decays) at f = 0.3 for sc and fcc; at f = 0.35-0.6 a burst: the highest mode
  grows until contacts open, and the pack flies apart with 2-7x its energy, no overlap ever near
  the limit -- the energy-balance check must catch it; from f = 0.6-0.7 the overlap passes
  0.5 r within a few steps and that check catches it.
* A small sphere on a large one (mass ratio 1:1000): the bound uses the reduced mass, so
  0.95 critical_time_step() is stable.
* Impacts. The closed-form peak overlap of an elastic wall impact is v sqrt(m/k) (0.072 r per
  m/s here; the dashpot lowers it): from 10 m/s (0.72 r elastic, 0.54 r damped) it passes
  max_overlap = 0.5 r and the run stops with InstabilityError naming the sphere and the wall;
  at 0.3 m/s (0.022 r) the sphere bounces and never crosses the wall.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu
from conftest import (REF_KN, REF_RADIUS, make_material, mechanical, sphere_mass,
                      squeezed_pack)

R = REF_RADIUS
K = REF_KN
M = sphere_mass()


def tight_pack(kind: str, f: float) -> tsubu.Simulation:
    """A 3-cell squeezed pack whose six walls all squeeze the outer layers by 1 %."""
    return squeezed_pack(kind, f, squeeze_top=True)[0]


@pytest.mark.parametrize("kind", ["sc", "fcc"])
def test_squeezed_pack_is_stable_well_inside_the_chain_bound(kind):
    """f = 0.3: the pack's energy only decays (e = 0.5), nothing leaves the box."""
    sim = tight_pack(kind, 0.3)
    sim.run(steps=10)
    start = mechanical(sim)
    sim.run(steps=3000)
    assert mechanical(sim) <= start
    x = sim.positions
    assert np.all(np.isfinite(x)) and np.all(x > 0)


@pytest.mark.parametrize("kind", ["sc", "fcc"])
def test_squeezed_pack_burst_is_caught_by_the_energy_balance(kind):
    """f = 0.5 (0.62 critical_time_step()): no overlap comes near 0.5 r, but energy appears from
    nowhere (walls fixed, no gravity); the run stops once the balance shows it."""
    sim = tight_pack(kind, 0.5)
    with pytest.raises(tsubu.InstabilityError, match=r"energy balance grew by .* too large for this packing"):
        sim.run(steps=5000)
    assert np.all(np.isfinite(sim.positions)) and np.all(np.isfinite(sim.velocities))


@pytest.mark.parametrize("kind", ["sc", "fcc"])
def test_squeezed_pack_beyond_the_chain_bound_is_caught(kind):
    """f = 0.95: inside the single-contact bound but beyond the chain's 1/sqrt(2): the pack's
    highest mode grows; the run must stop with InstabilityError, not turn NaN."""
    sim = tight_pack(kind, 0.95)
    assert sim.dt < 2 * math.sqrt(M / 2 / K)
    with pytest.raises(tsubu.InstabilityError) as info:
        sim.run(steps=20000)
    assert "unstable at step" in str(info.value)
    assert info.value.step > 0 and info.value.particle >= 0
    assert np.all(np.isfinite(sim.positions)) and np.all(np.isfinite(sim.velocities))


def stacked(dt: float | None = None) -> tsubu.Simulation:
    """A sphere of radius 10 R (1000 times the mass) on the floor, a sphere of radius R on top."""
    mat = make_material(restitution=0.5, friction=0.5)
    big = 10 * R
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -9.81), threads=1, dt=dt)
    sim.add_sphere((0.0, 0.0, big), big, mat)
    sim.add_sphere((0.0, 0.0, 2 * big + R - 2e-7), R, mat)
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
    return sim


def test_small_sphere_on_a_large_one_is_stable_at_the_reduced_mass_bound():
    """Mass ratio 1:1000: critical_time_step() uses m_red = m M / (m + M) of the pair, below
    the wall contacts' bounds; at 0.95 of it the stack settles."""
    m_red = M * 1000 * M / (1001 * M)
    bound = stacked().critical_time_step()
    assert bound < 2 * math.sqrt(m_red / K)
    sim = stacked(dt=0.95 * bound)
    sim.run(steps=20000)
    x = sim.positions
    big = 10 * R
    assert np.allclose(x[:, :2], 0.0, atol=1e-9)  # nothing rolled off
    # static overlaps: the floor carries both spheres, the pair the small one (1.6)
    floor = 1001 * M * 9.81 / K
    pair = M * 9.81 / K
    assert x[0, 2] == pytest.approx(big - floor, abs=1e-3 * pair)
    assert x[1, 2] == pytest.approx(x[0, 2] + big + R - pair, abs=1e-3 * pair)
    assert np.linalg.norm(sim.velocities) < 1e-3


def impact(speed: float) -> tsubu.Simulation:
    mat = make_material(restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), threads=1)
    sim.add_sphere((0.0, 0.0, R + 1e-7), R, mat, velocity=(0.3 * speed, 0.0, -speed))
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
    return sim


def test_impact_at_10_m_per_s_passes_max_overlap_and_is_caught():
    sim = impact(10.0)
    assert 10.0 * math.sqrt(M / K) > 0.5 * R  # the elastic closed-form peak passes the limit
    with pytest.raises(tsubu.InstabilityError, match=r"sphere 0 and wall 0 overlap by .*limit 0\.5"):
        sim.run(steps=400)
    assert np.all(np.isfinite(sim.positions))
    assert sim.positions[0, 2] > 0  # the state before the failing step: the centre is above the wall


def test_impact_at_0_3_m_per_s_bounces_and_never_crosses_the_wall():
    sim = impact(0.3)
    lowest = np.inf
    for _ in range(40):
        sim.run(steps=10)
        lowest = min(lowest, sim.positions[0, 2])
    peak = 0.3 * math.sqrt(M / K)  # elastic closed form; the dashpot only lowers it
    assert R - lowest < peak
    assert lowest > 0.5 * R
    assert sim.velocities[0, 2] > 0  # rebounding


# ---- the step correction of the energy check ----------------------------------------------------

@pytest.mark.parametrize("kind, f", [("fcc", 0.5), ("bcc", 0.5), ("sc", 0.7)])
def test_bursts_of_five_cell_packs_are_caught(kind, f):
    """The map's 5-cell packs (far walls at a gap) at the three points where a burst used to pass
    unseen (0.62-0.87 of critical_time_step()): the highest mode of the pack grows within the
    first tens of steps, the kinetic energy peaks at up to 4 times the pack's starting energy and
    is dissipated again. The check, now on the balance with symplectic Euler's step correction
    and a threshold that a burst's own energy cannot raise, stops the run at its first look
    (step 1,000)."""
    sim, _ = squeezed_pack(kind, f, cells=5)
    with pytest.raises(tsubu.InstabilityError, match=r"energy balance grew by .* since step 0"):
        sim.run(steps=5000)
    assert sim.step_count == 1000
    assert np.all(np.isfinite(sim.positions)) and np.all(np.isfinite(sim.velocities))


@pytest.mark.parametrize("fraction", [0.5, 0.85])
def test_undamped_oscillation_keeps_the_corrected_balance_exactly(fraction):
    """One undamped contact (e = 1, frictionless, g = 1000 m/s^2) started at half its static
    overlap, at 0.5 and 0.85 of the bound: kinetic + gravitational + elastic energy swings within
    each oscillation (by up to 1 / (1 - (omega dt / 2)^2) of the oscillation's energy), but with
    the step correction (dt/2) sum v.F -- symplectic Euler's modified energy, exact for a linear
    spring: with v' = v + dt F(x)/m, x' = x + dt v', the form 1/2 m v^2 + 1/2 k x^2 + dt/2 v.F(x)
    is unchanged by a step -- it stays constant to rounding over 20,000 steps, and the energy
    check never fires."""
    mat = make_material(restitution=1.0, friction=0.0)
    g = 1000.0
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -g), threads=1)
    sim.add_sphere((0.0, 0.0, R - 0.5 * M * g / K), R, mat)
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
    sim.dt = fraction * sim.critical_time_step()
    sim.run(steps=1)
    e = sim.energy(at_positions=True)
    start = e["total"] + e["step_correction"]
    swing = 0.0
    for _ in range(200):
        sim.run(steps=100)
        e = sim.energy(at_positions=True)
        assert e["dissipated"] == 0.0
        assert abs(e["total"] + e["step_correction"] - start) <= 1e-9 * abs(start)
        swing = max(swing, abs(e["total"] - start))
    assert swing > 1e-6 * abs(start)  # the plain energy does move: the correction is doing the work

"""Time-step stability: the bound of section 2 of dem_basics.md, its enforcement, and the
detection of runs that go unstable.

Scene: one sphere (reference material, r = 0.5 mm, kn = 1000 N/m) pressed onto a plane wall
z = 0 by a strong gravity g = 1000 m/s^2, so that its equilibrium overlap
delta_eq = m g / kn (1.3e-6 m, 0.26 % of r) is far larger than the oscillation we start: the
contact never opens, and the overlap obeys the linear recurrence of the stability analysis
with m_eff = m (wall contact):

    undamped (2.3)/(2.4):  y^{n+1} = (2 - a) y^n - y^{n-1},  a = k dt^2 / m
    stable iff dt < 2 sqrt(m/k)                                          (2.24)

y = overlap - delta_eq. Started from rest at y^0 = A (y^{-1} = y^0), the recurrence conserves
Q = y_n^2 - (2 - a) y_n y_{n-1} + y_{n-1}^2 = a A^2, whence the closed-form amplitude bound
|y| <= 2 A / sqrt(4 - a) (5.03 A at dt = 0.98 x 2 sqrt(m/k)).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import tsubu
from conftest import (REF_KN, REF_RADIUS, contact_time, damping_from_restitution,
                      make_material, sphere_mass)

R = REF_RADIUS
K = REF_KN
M = sphere_mass()
G_PRESS = 1000.0  # m/s^2
DELTA_EQ = M * G_PRESS / K
PERTURBATION = 0.05  # of delta_eq


def pressed_sphere(e: float = 1.0, allow_unstable_dt: bool = False) -> tsubu.Simulation:
    """A sphere at rest with overlap (1 + 5 %) delta_eq on a wall, under g = 1000 m/s^2."""
    mat = make_material(restitution=e, friction=0.0)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -G_PRESS), threads=1,
                           allow_unstable_dt=allow_unstable_dt)
    sim.add_sphere((0.0, 0.0, R - DELTA_EQ * (1 + PERTURBATION)), R, mat)
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
    return sim


def deviation(sim: tsubu.Simulation) -> float:
    """(overlap - delta_eq) / delta_eq."""
    return (R - sim.positions[0, 2]) / DELTA_EQ - 1.0


# ---- the bound ------------------------------------------------------------------------------

def test_critical_time_step_of_a_wall_contact_is_2_sqrt_m_over_k():
    """One sphere and a wall, e = 1: the only contact is sphere-wall with m_eff = m, so
    critical_time_step() = 2 sqrt(m/k) (2.24) = 7.236e-5 s for the reference sphere."""
    sim = pressed_sphere(e=1.0)
    expected = 2.0 * math.sqrt(M / K)
    assert expected == pytest.approx(7.236012545582676e-05, rel=1e-12)
    assert sim.critical_time_step() == pytest.approx(expected, rel=1e-12)


def test_critical_time_step_of_a_sphere_pair_uses_the_reduced_mass():
    """Two equal spheres (with or without a wall), e = 1: the shortest bound is the pair's,
    2 sqrt(m_eff/k) with m_eff = m/2 (2.24 with the reduced mass)."""
    mat = make_material(restitution=1.0, friction=0.0)
    for with_wall in (False, True):
        sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), threads=1)
        sim.add_spheres([(0.0, 0.0, 2 * R), (0.0, 0.0, 5 * R)], R, mat)
        if with_wall:
            sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
        assert sim.critical_time_step() == pytest.approx(2.0 * math.sqrt(M / 2 / K), rel=1e-12)


def test_default_time_step_is_contact_duration_over_50():
    """dt=None: dt = default_time_step() = contact_duration() / 50, contact_duration() =
    pi/alpha (B.3, B.5, B.9 with m_eff = m for the wall), far below the bound."""
    sim = pressed_sphere(e=0.5)
    tc = contact_time(0.5, M)
    assert sim.contact_duration() == pytest.approx(tc, rel=1e-12)
    assert sim.default_time_step() == pytest.approx(tc / 50, rel=1e-12)
    assert sim.dt == sim.default_time_step()
    sim.run(steps=10)
    assert sim.time == pytest.approx(10 * tc / 50, rel=1e-12)
    assert sim.dt < 0.1 * sim.critical_time_step()


# ---- below the bound: bounded ------------------------------------------------------------------

def test_undamped_run_just_below_the_bound_stays_within_the_closed_form_amplitude():
    """e = 1, dt = 0.98 x critical_time_step(): over 1e5 steps the overlap deviation stays
    within 2 A / sqrt(4 - a) (the conserved quadratic form of (2.4)), and comes within 10 %
    of it (the bound is sharp: the phase sweeps all values); the contact never opens."""
    sim = pressed_sphere(e=1.0)
    sim.dt = 0.98 * sim.critical_time_step()
    a = K * sim.dt ** 2 / M
    bound = 2 * PERTURBATION / math.sqrt(4 - a)
    worst = 0.0
    for _ in range(1000):
        sim.run(steps=100)
        assert len(sim.contacts()["i"]) == 1
        worst = max(worst, abs(deviation(sim)))
    assert sim.step_count == 100_000
    assert np.all(np.isfinite(sim.positions)) and np.all(np.isfinite(sim.velocities))
    assert worst <= bound * (1 + 1e-6), f"deviation {worst:.4f} x delta_eq > bound {bound:.4f}"
    assert worst >= 0.9 * bound


@pytest.mark.parametrize("e", [1.0, 0.5, 0.1])
def test_run_just_below_the_reported_bound_stays_bounded(e):
    """The promise of critical_time_step(): a single persistent wall contact run at 0.98 x the
    reported bound stays bounded (no InstabilityError over 2e4 steps, the overlap deviation
    never above 10 x the initial 5 % perturbation; with damping, it has decayed at the end).

    For e < 1 the scheme is the damped recurrence y^{n+1} = (2 - a - b) y^n - (1 - b) y^{n-1},
    b = eta dt / m (2.2 with the dashpot of (2.26)); it is stable iff a + 2 b < 4, i.e.
    dt < 4 m / (eta + sqrt(eta^2 + 4 k m)). That is below min(2 sqrt(m/k), 2 m/eta) of (2.31)
    whenever eta > 0 (0.81 x for e = 0.5, 0.68 x for e = 0.1): (2.31) treats the spring and the
    dashpot separately (footnote 6 of the notes)."""
    sim = pressed_sphere(e=e)
    sim.dt = 0.98 * sim.critical_time_step()
    eta = 0.0 if e == 1.0 else damping_from_restitution(e, M, K)
    exact = 4 * M / (eta + math.sqrt(eta ** 2 + 4 * K * M))
    worst = 0.0
    try:
        for _ in range(200):
            sim.run(steps=100)
            worst = max(worst, abs(deviation(sim)))
    except tsubu.InstabilityError as err:
        pytest.fail(f"e = {e}: InstabilityError at step {err.step} with dt = "
                    f"{sim.dt:.4e} s = 0.98 x critical_time_step() = {sim.dt / exact:.3f} x the "
                    f"exact bound 4m/(eta + sqrt(eta^2 + 4km)) = {exact:.4e} s: {err}")
    assert worst <= 10 * PERTURBATION
    if e < 1.0:
        assert abs(deviation(sim)) <= 1e-3 * PERTURBATION


# ---- above the bound: refused, or detected -----------------------------------------------------

def test_dt_above_the_bound_is_refused():
    """dt = 1.02 x critical_time_step() is refused with a ValueError naming dt and its value,
    before anything moves (given to the constructor or assigned)."""
    sim = pressed_sphere(e=1.0)
    crit = sim.critical_time_step()
    x0 = sim.positions.copy()
    sim.dt = 1.02 * crit
    with pytest.raises(ValueError, match=r"\bdt\b") as info:
        sim.run(steps=10)
    number = re.search(r"dt\s*=\s*([0-9.]+e[-+]?\d+)", str(info.value))
    assert number is not None, str(info.value)
    assert float(number.group(1)) == pytest.approx(1.02 * crit, rel=1e-5)
    assert sim.step_count == 0 and sim.time == 0.0
    np.testing.assert_array_equal(sim.positions, x0)

    mat = make_material(restitution=1.0, friction=0.0)
    sim2 = tsubu.Simulation(dt=1.02 * crit, threads=1)
    sim2.add_sphere((0.0, 0.0, R), R, mat)
    sim2.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
    with pytest.raises(ValueError, match=r"\bdt\b"):
        sim2.run(time=1e-3)
    # just below is accepted
    sim2.dt = 0.98 * crit
    sim2.run(steps=10)
    assert sim2.step_count == 10


def test_unstable_run_is_detected_and_leaves_a_finite_state():
    """allow_unstable_dt=True at dt = 1.02 x the bound: the eigenvalue of (2.4) is
    |lambda| = 1.49 > 1, the oscillation grows and the run stops with tsubu.InstabilityError
    (a RuntimeError) carrying .step (the failing step, one after the last completed one) and
    .particle (0); positions, velocities and angular velocities stay finite and readable."""
    sim = pressed_sphere(e=1.0, allow_unstable_dt=True)
    sim.dt = 1.02 * sim.critical_time_step()
    a = K * sim.dt ** 2 / M
    lam = abs((2 - a) - math.sqrt((2 - a) ** 2 - 4)) / 2
    assert lam > 1.4  # (2.15): growth per step
    with pytest.raises(tsubu.InstabilityError) as info:
        sim.run(steps=100_000)
    err = info.value
    assert isinstance(err, RuntimeError)
    assert err.particle == 0
    assert isinstance(err.step, int) and 0 < err.step < 100_000
    assert err.step == sim.step_count + 1
    assert re.search(r"sphere 0\b", str(err)) and "unstable" in str(err).lower()
    for arr in (sim.positions, sim.velocities, sim.angular_velocities):
        assert arr.shape == (1, 3) and np.all(np.isfinite(arr))
    assert math.isfinite(sim.energy()["total"])
    # the growth was real: the velocity is far above anything the stable run reaches
    assert np.abs(sim.velocities).max() > 1.0

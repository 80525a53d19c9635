"""Normal restitution and contact duration against appendix B of dem_basics.md.

A head-on collision of two equal spheres (no gravity, no walls, no friction) and of a sphere
on a fixed plane wall (no gravity, wall normal +z). The damped oscillator of the overlap,
m_eff d2x/dt2 + eta dx/dt + k x = 0 (B.1), has

    alpha = sqrt(k/m_eff - (eta / (2 m_eff))^2)                     (B.3)
    contact duration t_c = pi / alpha                                (B.5)
    restitution e = exp(-eta pi / (2 alpha m_eff))                   (B.8)
    eta = -2 ln(e) sqrt(m_eff k / (pi^2 + ln^2 e))                   (B.9)

with m_eff = m/2 for the pair and m_eff = m for the wall.

Each collision starts exactly at touching (surface gap 0) with approach speed 0.1 m/s
(pair: +-0.05 m/s). The contact then starts exactly on a step, so the measured errors are
smooth functions of dt (a small initial gap puts the entry at an arbitrary phase within a step
and makes the sign of the O(dt) restitution error jump from one dt to the next).

Measurements: the overlap is computed every step from ``sim.positions``; the contact duration
is the time between the linearly interpolated zero crossings of the overlap; the restitution
is -v_rel_after / v_rel_before, with v_rel_after read once the overlap is <= 0 (from then on
no force acts, so the velocity is final).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu
from conftest import (REF_KN, REF_RADIUS, contact_time, damped_frequency,
                      damping_from_restitution, make_material, sphere_mass)

R = REF_RADIUS
K = REF_KN
M = sphere_mass()
V_APPROACH = 0.1  # m/s, relative approach speed
RESTITUTIONS = [0.1, 0.5, 0.9, 1.0]
KINDS = ["wall", "pair"]
SWEEP = [25, 50, 100, 200, 400]  # dt = t_c / N


def m_eff(kind: str) -> float:
    """Reduced mass: m_i m_j / (m_i + m_j) = m/2 for two equal spheres, m_i for a wall (B.9)."""
    return M if kind == "wall" else M / 2.0


def build(kind: str, e: float, dt: float) -> tsubu.Simulation:
    mat = make_material(restitution=e, friction=0.0)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=dt, threads=1)
    if kind == "wall":
        sim.add_sphere((0.0, 0.0, R), R, mat, velocity=(0.0, 0.0, -V_APPROACH))
        sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
    else:
        sim.add_spheres([(-R, 0.0, 0.0), (R, 0.0, 0.0)], R, mat,
                        velocities=[(V_APPROACH / 2, 0.0, 0.0), (-V_APPROACH / 2, 0.0, 0.0)])
    return sim


def overlap(kind: str, sim: tsubu.Simulation) -> float:
    p = sim.positions
    if kind == "wall":
        return R - p[0, 2]
    return 2.0 * R - (p[1, 0] - p[0, 0])


def approach_speed(kind: str, sim: tsubu.Simulation) -> float:
    v = sim.velocities
    if kind == "wall":
        return -v[0, 2]
    return v[0, 0] - v[1, 0]


def collide(kind: str, e: float, n_per_contact: float) -> dict:
    """One collision at dt = t_c / n_per_contact; returns the measured restitution, duration,
    the overlap of every step and the simulation."""
    tc = contact_time(e, m_eff(kind))
    dt = tc / n_per_contact
    sim = build(kind, e, dt)
    u0 = approach_speed(kind, sim)
    ov = [overlap(kind, sim)]
    started = False
    for _ in range(int(3 * n_per_contact) + 10):
        sim.run(steps=1)
        ov.append(overlap(kind, sim))
        started = started or ov[-1] > 0
        if started and ov[-1] <= 0:
            break
    else:
        raise AssertionError(f"{kind}, e={e}: the contact did not end within 3 t_c")
    ov = np.array(ov)
    i0 = int(np.argmax(ov > 0))  # first step with overlap
    assert i0 >= 1
    t_in = (i0 - 1 + (0.0 - ov[i0 - 1]) / (ov[i0] - ov[i0 - 1])) * dt
    i1 = len(ov) - 1  # first step without overlap after the contact
    t_out = (i1 - 1 + ov[i1 - 1] / (ov[i1 - 1] - ov[i1])) * dt
    return dict(e=-approach_speed(kind, sim) / u0, duration=t_out - t_in, tc=tc, dt=dt,
                overlap=ov, sim=sim, u0=u0)


def fitted_slope(dts, errors) -> float:
    """Slope of log|error| against log dt (least squares)."""
    return float(np.polyfit(np.log(dts), np.log(np.abs(errors)), 1)[0])


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("e", RESTITUTIONS)
def test_engine_contact_duration_is_pi_over_alpha(kind, e):
    """Simulation.contact_duration() = pi/alpha (B.3, B.5) with eta from (B.9) and
    m_eff = m/2 (pair) or m (wall); the default dt is t_c/50."""
    sim = build(kind, e, None)
    tc = contact_time(e, m_eff(kind))
    assert sim.contact_duration() == pytest.approx(tc, rel=1e-12)
    assert sim.default_time_step() == pytest.approx(tc / 50, rel=1e-12)
    # the undamped limit differs by > 0.3 % for e <= 0.5: the check can tell eta = 0 apart
    if e <= 0.5:
        assert abs(math.pi * math.sqrt(m_eff(kind) / K) / tc - 1) > 3e-3


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("e", RESTITUTIONS)
def test_restitution_and_duration_at_tc_over_100(kind, e):
    """At dt = t_c/100: |e_measured - e| <= 0.005 (<= 0.5 % of e for e >= 0.9), with e the
    restitution of (B.8)/(B.9), and the contact duration within 1 % of pi/alpha (B.3, B.5)."""
    r = collide(kind, e, 100)
    tol_e = 0.005 * e if e >= 0.9 else 0.005
    assert abs(r["e"] - e) <= tol_e, f"measured e = {r['e']:.6f}, expected {e}"
    assert abs(r["duration"] / r["tc"] - 1) <= 0.01, (
        f"measured t_c = {r['duration']:.6e} s, pi/alpha = {r['tc']:.6e} s")
    if kind == "pair":
        # momentum conservation (A.9): no external force, equal and opposite contact forces
        v = r["sim"].velocities
        assert np.all(np.abs(v.sum(axis=0)) <= 1e-12 * V_APPROACH)
        assert np.all(np.isfinite(v))


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("e", [0.1, 0.5, 0.9])
def test_damped_errors_are_first_order_in_dt(kind, e):
    """With e < 1 the explicit dashpot (eta v^n in the symplectic Euler step (2.2), (2.26))
    makes both the restitution error |e_meas - e| and the duration error |t_meas - pi/alpha|
    first order in dt: the slope of log(error) against log(dt) over dt = t_c/N,
    N = 25..400, lies in [0.9, 1.2] (measured 1.00-1.09)."""
    runs = [collide(kind, e, n) for n in SWEEP]
    dts = [r["dt"] for r in runs]
    err_e = [r["e"] - e for r in runs]
    err_t = [r["duration"] / r["tc"] - 1 for r in runs]
    assert min(map(abs, err_e)) > 1e-6 and min(map(abs, err_t)) > 1e-6  # far above round-off
    s_e, s_t = fitted_slope(dts, err_e), fitted_slope(dts, err_t)
    assert 0.9 <= s_e <= 1.2, f"restitution error slope {s_e:.3f}, errors {err_e}"
    assert 0.9 <= s_t <= 1.2, f"duration error slope {s_t:.3f}, errors {err_t}"
    # and the errors do shrink: t_c/400 is at least 10x better than t_c/25
    assert abs(err_e[-1]) < abs(err_e[0]) / 10 and abs(err_t[-1]) < abs(err_t[0]) / 10


@pytest.mark.parametrize("kind", KINDS)
def test_elastic_collision_matches_discrete_closed_form(kind):
    """e = 1 (eta = 0): the errors are not first order but follow the exact solution of the
    undamped symplectic Euler recurrence (2.3)-(2.4). With cos h = 1 - k dt^2 / (2 m_eff)
    (eigenvalues of (2.22), h = omega_d dt) and the contact starting on a step with overlap 0,
    the overlap is x^n = u dt sin(n h) / sin(h) for n <= N, where N = ceil(pi/h) is the first
    step with x^N <= 0. Hence, with theta = N h - pi:

        e_measured = cos(theta - h/2) / cos(h/2)          (~ 1 + pi h^3 / 48: third order)
        t_measured = dt [(N - 1) + s_{N-1} / (s_{N-1} - s_N)],  s_n = sin(n h)
                                                          (~ t_c (1 - h^2/24): second order)

    Both are checked to 1e-9 relative at every dt of the sweep, and the fitted orders are
    asserted: 3 for the restitution error, 2 for the duration error."""
    me = m_eff(kind)
    dts, err_e, err_t = [], [], []
    for n in SWEEP:
        r = collide(kind, 1.0, n)
        dt = r["dt"]
        h = math.acos(1.0 - K * dt * dt / (2.0 * me))
        big_n = math.ceil(math.pi / h)
        theta = big_n * h - math.pi
        e_pred = math.cos(theta - h / 2) / math.cos(h / 2)
        s1, s2 = math.sin((big_n - 1) * h), math.sin(big_n * h)
        t_pred = dt * ((big_n - 1) + s1 / (s1 - s2))
        assert r["e"] == pytest.approx(e_pred, rel=1e-9, abs=0)
        assert r["duration"] == pytest.approx(t_pred, rel=1e-9)
        assert len(r["overlap"]) - 1 == big_n
        dts.append(dt)
        err_e.append(r["e"] - 1.0)
        err_t.append(r["duration"] / r["tc"] - 1.0)
    assert all(x > 1e-12 for x in err_e)  # the smallest, at t_c/400, is ~3e-8
    s_e, s_t = fitted_slope(dts, err_e), fitted_slope(dts, err_t)
    assert 2.8 <= s_e <= 3.2, f"restitution error slope {s_e:.3f}"
    assert 1.9 <= s_t <= 2.1, f"duration error slope {s_t:.3f}"


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("e", [0.5, 1.0])
def test_overlap_history_is_the_symplectic_euler_recurrence(kind, e):
    """The whole overlap history equals the scalar symplectic Euler scheme (2.2)/(2.26)
    applied to (B.1) (a 20-line Python model of the scheme): u^{n+1} = u^n - dt/m_eff (k x^n + eta u^n) while x^n > 0, then
    x^{n+1} = x^n + dt u^{n+1} (velocity first, dashpot on the old velocity), to 1e-9 of the
    peak overlap."""
    me = m_eff(kind)
    eta = damping_from_restitution(e, me, K)
    r = collide(kind, e, 50)
    dt, x, u = r["dt"], 0.0, r["u0"]
    ref = [x]
    for _ in range(len(r["overlap"]) - 1):
        if x > 0:
            u -= dt / me * (K * x + eta * u)
        x += dt * u
        ref.append(x)
    ref = np.array(ref)
    peak = ref.max()
    # the reference itself is the physics: its peak is that of (B.5),
    # x = u/alpha sin(alpha t) exp(-eta t / (2 m_eff)), reached at tan(alpha t) = 2 m_eff alpha / eta
    alpha = damped_frequency(K, me, eta)
    t_peak = math.atan2(alpha, eta / (2 * me)) / alpha
    peak_b5 = V_APPROACH / alpha * math.sin(alpha * t_peak) * math.exp(-eta * t_peak / (2 * me))
    assert peak == pytest.approx(peak_b5, rel=0.02)
    np.testing.assert_allclose(r["overlap"], ref, rtol=0, atol=1e-9 * peak)

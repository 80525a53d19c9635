"""Sliding, rolling and rolling friction of one sphere on a floor, against closed forms.

Geometry: floor z = 0 with normal +z, gravity -g z, the sphere moves along +x. Its lowest
contact point sits at -c z from the centre (c = R - delta/2, the contraction radius the
engine uses as lever arm, DESIGN.md note 2; delta = m g / kn ~ 1e-8 m, so c = R to 3e-5).

Velocity of the contact point:  v_c = v + w x (-c z) = (v_x - c w_y) x.
  * w_y > 0 with v_x > 0 is rolling forward ("topspin"), rolling without slip is v_x = c w_y;
  * w_y < 0 with v_x > 0 is BACKSPIN (the bottom of the sphere moves forward faster than v).

Sliding (Coulomb, eqs. 1.17-1.18 with the slip force mu |f_n| of DESIGN.md note 1): the
friction force is -mu m g sign(v_c) x at the contact point, its torque about the centre is
(-c z) x (F x) = -c F y. With I = 2/5 m R^2 (1.3):

    dv/dt = -mu g s,   dw_y/dt = +mu m g c s / I = +5/2 mu g s / R,   s = sign(v_c)
    d v_c / dt = -7/2 mu g s        ->  slip ends at  t_s = |v0 - R w0| / (7/2 mu g)

Angular momentum about the (fixed) floor line under the sphere, L_y = I w_y + m R v_x, is
conserved (friction acts at the line, normal force and gravity balance), so when rolling
(v = R w) starts:

    v_f = (m R v0 + I w0) / (7/5 m R) = (5 v0 + 2 R w0) / 7          (w0 = 0: v_f = 5/7 v0)

Rolling friction (1.20): M = -mu_r R |f_n| w/|w| opposes the spin. Rolling without slip,
m a = F (friction force on the sphere), I a / R = -R F - mu_r R m g, eliminate F:

    (m + I/R^2) a = -mu_r m g   ->   a = -5/7 mu_r g,    stopping distance v0^2 / (2 |a|).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu

R = 0.5e-3  # m
KN = 1.0e3  # N/m
RHO = 2500.0  # kg/m^3
G = 9.81  # m/s^2
MU = 0.5
M = RHO * 4.0 / 3.0 * math.pi * R ** 3  # 1.309e-6 kg
I = 0.4 * M * R * R  # (1.3)
DT = 0.02 * 2.0 * math.sqrt(M / KN)  # 1.4472e-6 s, the reference step
DELTA = M * G / KN  # static overlap on the floor
C = R - 0.5 * DELTA  # contraction radius = lever arm (DESIGN.md note 2)


def floor_sphere(v0: float, w0: float = 0.0, rolling_friction: float = 0.0,
                 friction: float = MU) -> tsubu.Simulation:
    """One reference sphere resting on the floor at its static overlap, velocity v0 x,
    angular velocity w0 y."""
    mat = tsubu.Material(density=RHO, kn=KN, restitution=0.5, friction=friction,
                         rolling_friction=rolling_friction)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -G), dt=DT, threads=1)
    sim.add_sphere((0.0, 0.0, R - DELTA), R, mat, velocity=(v0, 0.0, 0.0),
                   angular_velocity=(0.0, w0, 0.0))
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
    return sim


def record(sim: tsubu.Simulation, steps: int, every: int = 1):
    """Time, x position, x velocity and y spin, sampled every ``every`` steps."""
    t, x, v, w = [], [], [], []
    for _ in range(steps // every):
        sim.run(steps=every)
        t.append(sim.time)
        x.append(sim.positions[0, 0])
        v.append(sim.velocities[0, 0])
        w.append(sim.angular_velocities[0, 1])
    return np.array(t), np.array(x), np.array(v), np.array(w)


V0 = 0.1  # m/s


@pytest.mark.parametrize("w0_factor", [0.0, -0.5, -5.0, 3.0],
                         ids=["no-spin", "backspin-0.5", "backspin-5", "topspin-3"])
def test_sliding_to_rolling(w0_factor):
    """Slip ends at t_s = |v0 - R w0| / (7/2 mu g); then v_f = (5 v0 + 2 R w0)/7, w_f = v_f/R.

    w0 = w0_factor v0 / R about +y. Negative is backspin (see the module docstring):
    -0.5 gives v_f = 4/7 v0 (still forward, spin reversed to topspin), -5 gives
    v_f = -5/7 v0 (the sphere comes back), +3 (topspin, contact point moving backwards) gives
    v_f = 11/7 v0: friction pushes the sphere forward.
    """
    w0 = w0_factor * V0 / R
    slip0 = V0 - C * w0
    t_slip = abs(slip0) / (3.5 * MU * G)
    v_final = (5.0 * V0 + 2.0 * R * w0) / 7.0
    steps = int(1.3 * t_slip / DT) + int(2e-3 / DT)  # slip phase + 2 ms of rolling
    sim = floor_sphere(V0, w0)
    t, _, v, w = record(sim, steps)
    slip = v - C * w

    # During slip, v(t) = v0 - mu g s t (linear, friction mu m g): check at t_s / 2.
    k_half = np.searchsorted(t, 0.5 * t_slip)
    v_half = V0 - MU * G * math.copysign(1.0, slip0) * t[k_half]
    assert abs(v[k_half] - v_half) < 0.005 * abs(V0 - v_final) + 1e-12, (v[k_half], v_half)

    # Slip ends (v_c changes sign / becomes ~0) at t_s within 1 %.
    ended = np.nonzero(slip * math.copysign(1.0, slip0) <= 1e-3 * V0)[0]
    assert ended.size > 0, "the sphere never stopped slipping"
    t_end = t[ended[0]]
    assert t_end == pytest.approx(t_slip, rel=0.01), (t_end, t_slip)

    # After that it rolls: average over the last 1.5 ms (~6 periods of the tangential spring).
    tail = t > t[-1] - 1.5e-3
    v_mean = v[tail].mean()
    assert v_mean == pytest.approx(v_final, rel=0.01), (v_mean, v_final)
    assert (w[tail].mean() * R) == pytest.approx(v_final, rel=0.01)
    # and keeps rolling: the slip velocity stays small compared with v0
    assert np.max(np.abs(slip[tail])) < 0.01 * V0


def test_rolling_without_slip_keeps_velocity():
    """Without rolling friction, a sphere set rolling (v = c w) keeps v (no torque, no force)."""
    sim = floor_sphere(V0, V0 / C)
    t, x, v, w = record(sim, 5000, every=50)
    assert np.max(np.abs(v - V0)) < 1e-3 * V0
    assert np.max(np.abs(w * C - V0)) < 1e-3 * V0


MU_R = 0.2


def test_rolling_friction_deceleration_and_stop():
    """Rolling friction mu_r: a = -5/7 mu_r g while rolling (fit within 2 %), the sphere stops
    after v0^2/(2|a|) (within 2 %), at t = v0/|a|, and then stays put: it does not roll back.

    After the stop the only motion left is the release of the tangential spring, which held
    the rolling-friction force F = 5/7 mu_r m g: it can move the centre back by at most
    2 F / kt (spring released from stretch F/kt oscillates about zero stretch).
    """
    a = 5.0 / 7.0 * MU_R * G  # 1.40 m/s^2
    t_stop = V0 / a
    s_stop = V0 ** 2 / (2.0 * a)
    sim = floor_sphere(V0, V0 / C, rolling_friction=MU_R)
    steps = int(1.6 * t_stop / DT)
    t, x, v, w = record(sim, steps, every=20)

    # Uniform deceleration while rolling: linear fit between 10 % and 80 % of t_stop.
    sel = (t > 0.1 * t_stop) & (t < 0.8 * t_stop)
    slope, _ = np.polyfit(t[sel], v[sel], 1)
    assert -slope == pytest.approx(a, rel=0.02), (-slope, a)
    # still rolling without slip while it decelerates
    assert np.max(np.abs(v[sel] - C * w[sel])) < 0.01 * V0

    # It stops at t_stop, after s_stop.
    k_stop = np.argmax(v <= 0.0)
    assert v[k_stop] <= 0.0
    assert t[k_stop] == pytest.approx(t_stop, rel=0.02)
    x_stop = x[k_stop]
    assert x_stop == pytest.approx(s_stop, rel=0.02)

    # And stays: no rolling back, no rocking spin.
    after = t > t[k_stop] + 2e-3
    kt = 2.0 / 7.0 * KN
    x_back_max = 2.0 * (5.0 / 7.0 * MU_R * M * G) / kt  # 1.3e-8 m
    assert np.all(x[t >= t[k_stop]] > x_stop - x_back_max)
    assert np.max(np.abs(v[after])) < 1e-3 * V0
    assert np.max(np.abs(w[after] * R)) < 1e-3 * V0
    assert abs(x[-1] - x_stop) < x_back_max
    # kinetic energy left: below 1e-6 of the initial 7/10 m v0^2
    ke = sim.energy()["kinetic"]
    assert ke < 1e-6 * 0.7 * M * V0 ** 2


def test_rolling_friction_does_not_reverse_spin_of_a_spinning_sphere():
    """A sphere spinning in place about z (w_z = 200 rad/s) on the floor: (1.20) with the
    normal force m g decelerates the spin at dw/dt = mu_r R m g / I (no tangential force:
    the contact point does not slide), until w_z = 0 at t = w0 I / (mu_r R m g). Then w_z stays
    0: the capped torque must not flip the spin back and forth beyond one step's worth."""
    w0 = 200.0
    sim = floor_sphere(0.0, 0.0, rolling_friction=MU_R)
    sim.angular_velocities = [[0.0, 0.0, w0]]
    alpha = MU_R * R * M * G / I  # 9810 rad/s^2
    t_stop = w0 / alpha
    ws = []
    ts = []
    for _ in range(int(2.0 * t_stop / DT) // 10):
        sim.run(steps=10)
        ts.append(sim.time)
        ws.append(sim.angular_velocities[0, 2])
    ts, ws = np.array(ts), np.array(ws)
    sel = ts < 0.8 * t_stop
    slope, _ = np.polyfit(ts[sel], ws[sel], 1)
    assert -slope == pytest.approx(alpha, rel=0.02)
    k = np.argmax(ws <= 0.0)
    assert ts[k] == pytest.approx(t_stop, rel=0.02)
    # one step of rolling torque changes w by alpha dt = 0.014 rad/s: never exceeded after stop
    assert np.all(np.abs(ws[k:]) <= alpha * DT * 1.0001)

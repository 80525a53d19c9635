"""Plane walls (section 3 of the notes, eqs. 3.1-3.2): the two ways to give a plane, sliding
and rolling on an incline, a translating floor dragging a sphere, moving walls pushing spheres.

A wall contact uses the sphere's mass as m_eff, lever arm c = R - delta/2 and the wall's own
velocity at the contact point (docs/physics.md, "Walls").
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu

R = 0.5e-3
KN = 1.0e3
RHO = 2500.0
G = 9.81
M = RHO * 4.0 / 3.0 * math.pi * R ** 3
I = 0.4 * M * R * R
DT = 0.02 * 2.0 * math.sqrt(M / KN)  # 1.4472e-6 s


def material(friction=0.5, restitution=0.5):
    return tsubu.Material(density=RHO, kn=KN, restitution=restitution, friction=friction)


def state(sim):
    return sim.positions, sim.velocities, sim.angular_velocities


# ---- point + normal vs coefficients ---------------------------------------------------------

def bouncing(plane_kw, normal, on_plane):
    """A sphere thrown at a plane (with friction and spin) under gravity, from 0.2 mm above
    the point `on_plane`, 4000 steps."""
    mat = material()
    sim = tsubu.Simulation(dt=DT, threads=1)
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    start = np.asarray(on_plane, float) + (R + 0.2e-3) * n
    sim.add_sphere(start, R, mat, velocity=-0.05 * n + [0.03, 0.01, 0.0],
                   angular_velocity=(100.0, -50.0, 20.0))
    sim.add_plane(material=mat, **plane_kw)
    touched = 0
    for _ in range(40):
        sim.run(steps=100)
        touched += len(sim.contacts()["i"])
    assert touched > 0
    return sim


def test_coefficients_equal_point_normal_exactly():
    """z = 1 mm as (0, 0, 1, -1e-3) and as point (0, 0, 1e-3), normal (0, 0, 1): the stored
    plane and the whole run are bit-identical."""
    on = (0.2e-3, -0.1e-3, 1e-3)
    a = bouncing(dict(point=(0.0, 0.0, 1e-3), normal=(0.0, 0.0, 1.0)), (0, 0, 1), on)
    b = bouncing(dict(coefficients=(0.0, 0.0, 1.0, -1e-3)), (0, 0, 1), on)
    pa, pb = a.plane(0), b.plane(0)
    assert np.array_equal(pa["point"], pb["point"]) and np.array_equal(pa["normal"], pb["normal"])
    for x, y in zip(state(a), state(b)):
        assert np.array_equal(x, y)


def test_coefficients_equal_point_normal_tilted():
    """A tilted plane a x + b y + c z + d = 0 with (a, b, c) = 2.5 (0.3, -0.2, 0.9) (not unit)
    through the point q, and the same plane as point q + 1 mm along it, normal (a, b, c):
    same unit normal (to 1e-15), both points on the plane (3.2), and the same trajectory up to
    round-off (positions to 1e-12 m, velocities to 1e-9 m/s)."""
    abc = 2.5 * np.array([0.3, -0.2, 0.9])
    q = np.array([1e-3, 2e-3, -0.5e-3])
    d = -abc @ q
    along = np.cross(abc, [1.0, 0.0, 0.0])
    q2 = q + 1e-3 * along / np.linalg.norm(along)
    a = bouncing(dict(coefficients=tuple(abc) + (d,)), abc, q)
    b = bouncing(dict(point=q2, normal=abc), abc, q)
    pa, pb = a.plane(0), b.plane(0)
    unit = abc / np.linalg.norm(abc)
    assert np.allclose(pa["normal"], unit, rtol=0, atol=1e-15)
    assert np.allclose(pb["normal"], unit, rtol=0, atol=1e-15)
    for p in (pa["point"], pb["point"]):
        assert abs(abc @ p + d) <= 1e-15 * np.linalg.norm(abc)
    assert np.max(np.abs(a.positions - b.positions)) < 1e-12
    assert np.max(np.abs(a.velocities - b.velocities)) < 1e-9
    assert np.max(np.abs(a.angular_velocities - b.angular_velocities)) < 1e-9 / R


# ---- incline ----------------------------------------------------------------------------------

THETA = math.radians(20.0)


def incline(friction):
    """A sphere at rest on the plane through the origin with normal n = (sin t, 0, cos t),
    sitting at its static overlap m g cos(t)/kn. Downslope direction u = (cos t, 0, -sin t)."""
    n = np.array([math.sin(THETA), 0.0, math.cos(THETA)])
    mat = material(friction=friction)
    sim = tsubu.Simulation(dt=DT, threads=1)
    sim.add_sphere((R - M * G * math.cos(THETA) / KN) * n, R, mat)
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=n, material=mat)
    return sim, n, np.array([math.cos(THETA), 0.0, -math.sin(THETA)])


@pytest.mark.parametrize("friction, factor", [(0.0, 1.0), (0.5, 5.0 / 7.0)],
                         ids=["frictionless-slides", "frictional-rolls"])
def test_incline(friction, factor):
    """Frictionless: it slides with a = g sin(theta) and does not spin. With mu = 0.5
    (tan 20 deg = 0.36 < 7/2 mu, so it rolls without slip): a = 5/7 g sin(theta), from
    (m + I/R^2) a = m g sin(theta), and w = v/R. Checked after 20 ms: v = a t and
    s = a t^2 / 2 within 0.5 %, and the sphere stays on the plane."""
    sim, n, u = incline(friction)
    a = factor * G * math.sin(THETA)
    x0 = sim.positions[0].copy()
    sim.run(steps=int(round(0.02 / DT)))
    t = sim.time
    v = sim.velocities[0]
    s = (sim.positions[0] - x0) @ u
    assert v @ u == pytest.approx(a * t, rel=0.005)
    assert s == pytest.approx(0.5 * a * t * t, rel=0.005)
    assert abs(v @ n) < 1e-4 * a * t  # no motion off the plane
    assert abs(sim.positions[0] @ n - (R - M * G * math.cos(THETA) / KN)) < 1e-3 * R
    w = sim.angular_velocities[0]
    if friction == 0.0:
        assert np.all(w == 0.0)
    else:
        # rolling down along u: w = (n x u) v / R, along n x u = +y here, |w| = v/R
        w_expected = np.cross(n, u) * (v @ u) / R
        assert np.allclose(w, w_expected, rtol=0.0, atol=0.005 * np.linalg.norm(w_expected))


# ---- translating floor ------------------------------------------------------------------------

def test_translating_floor_drags_sphere_to_two_sevenths():
    """A sphere at rest on a floor that moves at u = 0.1 m/s along x. Friction (mu m g) at the
    contact point is the only horizontal force; about a fixed line on the floor under the sphere
    its angular momentum L_y = I w_y + m R v_x stays 0 (friction acts on the line, weight and
    normal force cancel), and slip stops when the contact point moves with the floor,
    v_x - R w_y = u. Hence v_x = 2/7 u and w_y = -5/7 u / R (spinning backwards), reached at
    t = u / (7/2 mu g). Checked within 1 %."""
    u = 0.1
    mat = material()
    sim = tsubu.Simulation(dt=DT, threads=1)
    sim.add_sphere((0.0, 0.0, R - M * G / KN), R, mat)
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat,
                  velocity=(u, 0.0, 0.0))
    t_slip = u / (3.5 * 0.5 * G)
    ts, vs, ws = [], [], []
    for _ in range(int((t_slip + 3e-3) / DT) // 10):
        sim.run(steps=10)
        ts.append(sim.time)
        vs.append(sim.velocities[0, 0])
        ws.append(sim.angular_velocities[0, 1])
    ts, vs, ws = map(np.array, (ts, vs, ws))
    slip = vs - (R - 0.5 * M * G / KN) * ws - u
    k = np.argmax(slip >= -1e-3 * u)
    assert ts[k] == pytest.approx(t_slip, rel=0.01)
    tail = ts > ts[-1] - 1.5e-3
    assert vs[tail].mean() == pytest.approx(2.0 / 7.0 * u, rel=0.01)
    assert ws[tail].mean() * R == pytest.approx(-5.0 / 7.0 * u, rel=0.01)
    # the floor moved (its point follows the velocity), the sphere stayed on it
    assert sim.plane(0)["point"][0] == pytest.approx(u * sim.time, rel=1e-9)
    assert sim.positions[0, 2] == pytest.approx(R - M * G / KN, abs=1e-3 * R)


# ---- moving walls push --------------------------------------------------------------------------

def test_moving_wall_hits_sphere():
    """No gravity: a wall x = p(t), normal +x, moving at u = 0.05 m/s hits a sphere at rest.
    In the wall's frame the sphere arrives at -u and leaves at +e u (B.8, m_eff = m), so it
    leaves at (1 + e) u = 0.075 m/s (within 1 %). Its centre never gets behind r/2 of the
    wall."""
    u, e = 0.05, 0.5
    mat = material(restitution=e)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=DT, threads=1)
    sim.add_sphere((R + 0.1e-3, 0.0, 0.0), R, mat)
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(1.0, 0.0, 0.0), material=mat,
                  velocity=(u, 0.0, 0.0))
    touched = False
    for _ in range(600):
        sim.run(steps=10)
        gap = sim.positions[0, 0] - sim.plane(0)["point"][0]
        assert gap > 0.5 * R
        touched = touched or len(sim.contacts()["i"]) > 0
    assert touched and len(sim.contacts()["i"]) == 0
    assert sim.velocities[0, 0] == pytest.approx((1.0 + e) * u, rel=0.01)
    assert np.all(sim.velocities[0, 1:] == 0.0)


def test_bulldozer_wall_pushes_a_pile_without_letting_spheres_through():
    """Gravity, a frictional floor, 36 spheres (radii 0.4-0.5 mm) in 3 layers in front of a
    wall x = p(t) moving at 0.05 m/s. Over 4 mm of travel every sphere stays in front of it:
    n.(x - p) > 0.9 r at every check (the wall overlap stays small), the spheres it touches
    move with it, and the run never goes unstable."""
    rng = np.random.default_rng(3)
    u = 0.05
    mat = material()
    sim = tsubu.Simulation(dt=DT, threads=1)
    grid = np.stack(np.meshgrid(np.arange(4), np.arange(4), np.arange(3), indexing="ij"),
                    -1).reshape(-1, 3).astype(float)
    pos = (grid + 0.5) * 1.02e-3 + [0.3e-3, 0.0, 0.0]
    radii = rng.uniform(0.4e-3, 0.5e-3, len(pos))
    sim.add_spheres(pos, radii, mat)
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
    wall = sim.add_plane(point=(0.0, 0.0, 0.0), normal=(1.0, 0.0, 0.0), material=mat,
                         velocity=(u, 0.0, 0.0))
    sim.run(time=0.01)  # let the pile settle a little before the wall arrives
    travel = 4e-3
    steps = int(travel / u / DT)
    pushed = 0
    for _ in range(40):
        sim.run(steps=steps // 40)
        p = sim.plane(wall)["point"][0]
        gap = sim.positions[:, 0] - p
        assert np.all(gap > 0.9 * sim.radii), gap.min() / R
        c = sim.contacts()
        pushed = max(pushed, np.count_nonzero(c["wall"] == wall))
    assert sim.plane(wall)["point"][0] > 0.99 * (travel + 0.01 * u)
    assert pushed >= 3
    # spheres in contact with the wall move at least at roughly its speed
    touching = np.unique(sim.contacts()["i"][sim.contacts()["wall"] == wall])
    assert touching.size > 0
    assert np.all(sim.velocities[touching, 0] > 0.5 * u)

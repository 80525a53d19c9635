"""The tangential displacement history (1.13-1.16): kept per contact across neighbour-list
rebuilds, reset when a contact opens, and the difference between the default "rotate" rule and
the notes' literal (1.14) (DESIGN.md note 3).

The history must belong to the contact, not to the neighbour list: a run that rebuilds the list
every step (``rebuild_every_step=True``, which re-creates every pair entry each step) must give
bit-identical trajectories. If the history were dropped or mixed up at a rebuild, the sheared
contacts below would lose or change their spring force there and the runs would differ.
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
DT = 0.02 * 2.0 * math.sqrt(M / KN)  # 1.4472e-6 s
DELTA = M * G / KN  # static overlap of one sphere on the floor


def stacked_pair(rebuild_every_step: bool, skin=None, history="rotate") -> tsubu.Simulation:
    """Sphere 0 on the floor moving at 0.05 m/s along x, sphere 1 resting on top of it: the
    pair contact (loaded by the weight of sphere 1) and the floor contact are sheared."""
    mat = tsubu.Material(density=RHO, kn=KN, restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(dt=DT, skin=skin, rebuild_every_step=rebuild_every_step,
                           tangential_history=history, threads=1)
    sim.add_spheres([[0.0, 0.0, R - 2 * DELTA], [0.0, 0.0, 3 * R - 3.5 * DELTA]], R, mat,
                    velocities=[[0.05, 0.0, 0.0], [0.0, 0.0, 0.0]])
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
    return sim


def sheared_pile(rebuild_every_step: bool, skin=None, history="rotate") -> tsubu.Simulation:
    """80 polydisperse spheres (radii 0.3-0.5 mm) falling into a box whose floor slides along x
    at 0.02 m/s: many lasting, sheared sphere-sphere and sphere-wall contacts. Gravity is
    50 m/s^2 so that the pile forms within 12000 steps."""
    rng = np.random.default_rng(7)
    mat = tsubu.Material(density=RHO, kn=KN, restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -50.0), dt=DT, skin=skin,
                           rebuild_every_step=rebuild_every_step, tangential_history=history,
                           threads=1)
    grid = np.stack(np.meshgrid(np.arange(4), np.arange(4), np.arange(5), indexing="ij"),
                    -1).reshape(-1, 3)
    pos = (grid + 0.5) * 1.05e-3 + rng.uniform(-0.02e-3, 0.02e-3, grid.shape)
    sim.add_spheres(pos, rng.uniform(0.3e-3, 0.5e-3, len(pos)), mat,
                    velocities=rng.normal(0.0, 0.02, (len(pos), 3)))
    side = 4 * 1.05e-3
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat,
                  velocity=(0.02, 0.0, 0.0))
    for ax in (0, 1):
        n = np.zeros(3)
        n[ax] = 1.0
        sim.add_plane(point=(0.0, 0.0, 0.0), normal=n, material=mat)
        sim.add_plane(point=n * side, normal=-n, material=mat)
    return sim


def state(sim):
    return sim.positions, sim.velocities, sim.angular_velocities


@pytest.mark.parametrize("skin", [None, 2e-5])
def test_stacked_pair_identical_with_rebuild_every_step(skin):
    """The stacked pair for 8 ms (its contacts stay closed and loaded): bit-identical with and
    without rebuilding every step, although the rebuild counts differ (and the run without
    forced rebuilds does rebuild while the contacts are loaded)."""
    a, b = stacked_pair(False, skin), stacked_pair(True, skin)
    shear_seen = 0.0
    rebuilds_in_contact = 0
    for _ in range(55):
        before = a.rebuild_count
        a.run(steps=100)
        b.run(steps=100)
        c = a.contacts()
        assert len(c["i"]) == 2, "the pair must stay in contact with the floor and each other"
        if np.abs(c["tangential_displacement"]).max() > 0:
            rebuilds_in_contact += a.rebuild_count - before
        shear_seen = max(shear_seen, np.abs(c["tangential_displacement"]).max())
        for x, y in zip(state(a), state(b)):
            assert np.array_equal(x, y)
    assert shear_seen > 1e-9  # m: the springs were really loaded
    assert rebuilds_in_contact >= 1
    assert b.rebuild_count > a.rebuild_count
    ca, cb = a.contacts(), b.contacts()
    for key in ca:
        assert np.array_equal(ca[key], cb[key]), key


@pytest.mark.parametrize("history", ["rotate", "literal"])
def test_sheared_pile_identical_with_rebuild_every_step(history):
    """The sheared pile, 12000 steps, small skin (many rebuilds): bit-identical states and
    contact lists (including tangential displacements) with and without per-step rebuilds."""
    a, b = sheared_pile(False, 5e-5, history), sheared_pile(True, 5e-5, history)
    for _ in range(6):
        a.run(steps=2000)
        b.run(steps=2000)
        for x, y in zip(state(a), state(b)):
            assert np.array_equal(x, y)
    ca, cb = a.contacts(), b.contacts()
    assert len(ca["i"]) > 50
    assert np.count_nonzero(np.linalg.norm(ca["tangential_displacement"], axis=1)) > 50
    for key in ca:
        assert np.array_equal(ca[key], cb[key]), key
    assert 10 < a.rebuild_count < b.rebuild_count
    assert b.rebuild_count >= 12000


def test_history_nonzero_in_contact_and_reset_after_separation():
    """Two spheres collide obliquely (no gravity, e = 0.5, mu = 0.5). During the contact the
    stored tangential displacement is nonzero; after separation there is no contact and no
    elastic energy. Sending them back into each other (v -> -v, w -> -w) opens a NEW contact
    whose history starts from zero: in its first step |xi| <= |v_t| dt (1.13), well below the
    value the old contact held when it opened."""
    mat = tsubu.Material(density=RHO, kn=KN, restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=DT, threads=1)
    d = 2 * R
    b = 0.4 * d
    sim.add_spheres([[-math.sqrt(d * d - b * b) - 1e-6, b, 0.0], [0.0, 0.0, 0.0]], R, mat,
                    velocities=[[0.05, 0.0, 0.0], [-0.05, 0.0, 0.0]])
    xi_in_contact = []
    while True:
        sim.run(steps=1)
        c = sim.contacts()
        if len(c["i"]) == 0 and xi_in_contact:
            break
        if len(c["i"]):
            xi_in_contact.append(np.linalg.norm(c["tangential_displacement"][0]))
        assert sim.step_count < 2000
    xi_in_contact = np.array(xi_in_contact)
    assert len(xi_in_contact) > 20
    assert np.all(xi_in_contact[1:] > 0)
    xi_last = xi_in_contact[-1]
    assert xi_last > 0.1 * xi_in_contact.max() > 0  # the history still held a lot at the end
    sim.run(steps=5)
    assert len(sim.contacts()["i"]) == 0
    assert sim.energy()["elastic"] == 0.0

    sim.velocities = -sim.velocities
    sim.angular_velocities = -sim.angular_velocities
    while True:
        sim.run(steps=1)
        c = sim.contacts()
        if len(c["i"]):
            break
        assert sim.step_count < 4000
    xi_new = np.linalg.norm(c["tangential_displacement"][0])
    v = sim.velocities
    dv = np.linalg.norm(v[0] - v[1])  # bounds |v_t| up to the spin term
    w = np.linalg.norm(sim.angular_velocities, axis=1).sum()
    bound = (dv + R * w) * DT * 1.01
    assert bound < 0.5 * xi_last  # so the check below can tell a fresh history from the old
    assert xi_new <= bound


def floor_bead(history: str, steps: int):
    """A bead at rest height on the floor pushed sideways at 3e-4 m/s, no spin: the friction
    needed to stop its contact point, k_t xi_max = k_t v/omega_t = 3.1e-6 N (omega_t =
    sqrt(7/2 k_t/m) = sqrt(kn/m)), is below mu m g = 6.4e-6 N, so the contact should stick
    and the contact point oscillate (the tangential spring on the rolling sphere)."""
    mat = tsubu.Material(density=RHO, kn=KN, restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(dt=DT, tangential_history=history, threads=1)
    sim.add_sphere((0.0, 0.0, R - DELTA), R, mat, velocity=(3e-4, 0.0, 0.0))
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=mat)
    c_lever = R - DELTA / 2
    xi, vc = [], []
    for _ in range(steps):
        vc.append(sim.velocities[0, 0] - c_lever * sim.angular_velocities[0, 1])
        sim.run(steps=1)
        xi.append(sim.contacts()["tangential_displacement"][0, 0])
    return np.array(xi), np.array(vc)


def test_rotate_rule_unloads_when_tangential_velocity_reverses():
    """"rotate": xi += v_t dt. When v_t reverses (first time after ~pi/(2 omega_t) = 39
    steps) the spring unloads: |xi| falls back through zero. It oscillates smoothly
    (period 2 pi/omega_t = 157 steps, so ~2 sign changes per period, not one per step) and
    the contact keeps sticking: |xi| stays below the slip limit mu m g / k_t."""
    xi, vc = floor_bead("rotate", 800)
    k_rev = np.argmax(vc < 0)
    assert 30 < k_rev < 50
    peak = np.abs(xi[:k_rev + 1]).max()
    assert peak < 0.5 * M * G / (2.0 / 7.0 * KN)  # below the slip limit: sticking
    # after the reversal |xi| decreases (unloads) ...
    assert np.abs(xi[k_rev + 20]) < 0.8 * peak
    assert np.abs(xi[k_rev + 38]) < 0.1 * peak
    assert np.all(np.diff(np.abs(xi[k_rev + 2:k_rev + 36])) < 0)
    # ... and oscillates smoothly: about 2 sign changes per period of 157 steps
    changes = np.count_nonzero(np.diff(np.sign(xi)) != 0)
    assert 8 <= changes <= 12, changes


def test_literal_rule_only_grows_and_chatters():
    """"literal" (1.14): xi = (|xi| + |v_t| dt) v_t/|v_t|. Its magnitude never decreases, and
    once v_t reverses the whole accumulated length is re-aimed: the spring force flips sign
    instead of unloading, and the contact chatters (xi changes sign almost every step)."""
    xi, vc = floor_bead("literal", 800)
    mag = np.abs(xi)
    assert np.all(np.diff(mag) >= 0)
    k_rev = np.argmax(vc < 0)
    assert 30 < k_rev < 50
    assert mag[-1] > mag[k_rev]  # it kept growing after the reversal
    changes = np.count_nonzero(np.diff(np.sign(xi[k_rev:])) != 0)
    assert changes > 0.8 * (len(xi) - k_rev), changes

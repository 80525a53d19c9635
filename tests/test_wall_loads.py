"""Loads on walls (issue 27): ``wall_forces()`` and ``wall_torques()`` of planes and meshes.

A wall's force is the sum over its contacts of the force on the wall (minus the force on the
sphere); its torque is the moment of those forces at their contact points about the wall's
centre (``wall(w)["center"]``). At rest, Newton's third law and statics fix both: a floor carries
the weight of what rests on it, an off-centre sphere's weight has the moment r x F, and a
drum that lifts its grains feels their weight's moment against its rotation.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

import tsubu
from tsubu import mesh

R = 0.5e-3
KN = 1.0e3
RHO = 2500.0
G = 9.81
M = RHO * 4.0 / 3.0 * math.pi * R ** 3
DT = 0.02 * 2.0 * math.sqrt(M / KN)


def material(friction=0.5, restitution=0.5):
    return tsubu.Material(density=RHO, kn=KN, restitution=restitution, friction=friction)


def floor(sim, kind, mat, center=(0.0, 0.0, 0.0)):
    """A floor z = 0 as a plane or a 6 mm square mesh (12 x 12 cells), centred at ``center``."""
    if kind == "plane":
        return sim.add_plane(point=center, normal=(0, 0, 1), material=mat, center=center)
    return sim.add_mesh(*mesh.square(center, 6e-3, (0, 0, 1), 12), material=mat, center=center)


def pack(kind):
    """A small resting pack in a 2 mm square pen: nine spheres touching in a 3 x 3 layer on the
    floor, four nested in the hollows above; the pen's side walls (planes) are frictionless, so
    they carry no vertical load; the grains and the floor are frictional."""
    grain = material(friction=0.5)
    smooth = material(friction=0.0)
    sim = tsubu.Simulation(dt=DT, threads=1)
    i, j = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
    bottom = np.stack([(2 * i.ravel() - 2) * R, (2 * j.ravel() - 2) * R,
                       np.full(9, R)], axis=1)
    i, j = np.meshgrid(np.arange(2), np.arange(2), indexing="ij")
    top = np.stack([(2 * i.ravel() - 1) * R, (2 * j.ravel() - 1) * R,
                    np.full(4, R + math.sqrt(2) * R)], axis=1)
    sim.add_spheres(np.concatenate([bottom, top]), R, grain)
    floor(sim, kind, grain)
    for axis in (0, 1):
        n = np.eye(3)[axis]
        sim.add_plane(point=-3 * R * n, normal=n, material=smooth)
        sim.add_plane(point=3 * R * n, normal=-n, material=smooth)
    sim.set_pair(grain, smooth, friction=0.0)
    return sim


@pytest.mark.parametrize("kind", ["plane", "mesh"])
def test_a_floor_carries_the_weight_of_the_pack_resting_on_it(kind):
    """Once the dashpots have settled the pack (e = 0.5; 15000 steps, 22 ms, about 90 contact
    durations), the floor's force is the 13 spheres' weight, downward (on the wall), to 1e-6:
    what remains is the pack's residual acceleration, which decays exponentially. The
    frictionless side walls take only horizontal forces, which cancel by symmetry (to round-off
    of the weight)."""
    sim = pack(kind)
    sim.run(steps=15000)
    weight = 13 * M * G
    forces = sim.wall_forces()
    assert forces.shape == (5, 3)
    assert forces[0, 2] == pytest.approx(-weight, rel=1e-6, abs=0)
    assert abs(forces[0, 0]) < 1e-6 * weight and abs(forces[0, 1]) < 1e-6 * weight
    assert np.all(np.abs(forces[1:, 2]) == 0.0)  # frictionless side walls: no vertical load
    # The sum over the wall's contacts, with the opposite sign of the forces on the spheres.
    c = sim.contacts()
    on_floor = c["wall"] == 0
    assert on_floor.sum() == 9
    assert np.allclose(forces[0], -c["force"][on_floor].sum(axis=0), rtol=1e-12, atol=0)


@pytest.mark.parametrize("kind", ["plane", "mesh"])
def test_the_torque_of_a_resting_sphere_about_the_floors_centre_is_r_cross_f(kind):
    """A sphere resting at (1.1, -0.7) mm on a floor centred at c = (-0.4, 0.5, 0) mm: its
    contact point is p = (1.1, -0.7, 0) mm (the foot of the sphere; the sphere's weight is
    vertical, so no tangential force), the force on the wall F = (0, 0, -m g), and the torque
    about c is (p - c) x F, to 1e-9."""
    mat = material()
    sim = tsubu.Simulation(dt=DT, threads=1)
    foot = np.array([1.1e-3, -0.7e-3, 0.0])
    sim.add_sphere(foot + [0, 0, R - M * G / KN], R, mat)
    center = np.array([-0.4e-3, 0.5e-3, 0.0])
    floor(sim, kind, mat, center)
    sim.run(steps=3000)
    assert np.array_equal(sim.wall(0)["center"], center)
    F = np.array([0.0, 0.0, -M * G])
    assert np.allclose(sim.wall_forces()[0], F, rtol=0, atol=1e-9 * M * G)
    expected = np.cross(foot - center, F)
    assert np.allclose(sim.wall_torques()[0], expected, rtol=0,
                       atol=1e-9 * M * G * np.linalg.norm(foot - center))
    assert abs(expected[0]) > 0 and abs(expected[1]) > 0


def drum(spin, walls="mesh"):
    """A drum of radius 3 mm about the y axis (24 flat faces; as a mesh, or as 24 planes that
    share its centre and turn as one body), spinning at ``spin`` rad/s about +y, with 8
    frictional spheres inside; gravity along -z."""
    mat = material(friction=0.8)
    sim = tsubu.Simulation(dt=DT, threads=1)
    segments, radius, length = 24, 3e-3, 2e-3
    w = (0.0, spin, 0.0)
    if walls == "mesh":
        sim.add_mesh(*mesh.cylinder(radius, length, segments, axis="y"), material=mat,
                     angular_velocity=w, center=(0, 0, 0))
    else:
        for k in range(segments):
            # Face k between vertices k and k + 1 (at angles 2 pi k / n from z toward x).
            angle = 2 * math.pi * (k + 0.5) / segments
            out = np.array([math.sin(angle), 0.0, math.cos(angle)])
            sim.add_plane(point=radius * math.cos(math.pi / segments) * out, normal=-out,
                          material=mat, angular_velocity=w, center=(0, 0, 0))
    # Side caps: frictionless, still planes at y = -/+ length/2.
    smooth = material(friction=0.0)
    sim.add_plane(point=(0, -length / 2, 0), normal=(0, 1, 0), material=smooth)
    sim.add_plane(point=(0, length / 2, 0), normal=(0, -1, 0), material=smooth)
    sim.set_pair(mat, smooth, friction=0.0)
    x = np.array([[-1.2, 0, -2.1], [-0.4, 0, -2.4], [0.4, 0, -2.4], [1.3, 0, -2.0],
                  [-0.9, 0, -1.2], [0.2, 0, -1.4], [1.3, 0, -1.0], [0.0, 0, -0.3]]) * 1e-3
    sim.add_spheres(x, 0.38e-3, mat)
    return sim


def spin_about_y(sim):
    """The spheres' angular momentum about the y axis through the origin, orbital and spin."""
    m, r = sim.masses, sim.radii
    return float((m * np.cross(sim.positions, sim.velocities)[:, 1]).sum()
                 + (0.4 * m * r * r * sim.angular_velocities[:, 1]).sum())


@functools.lru_cache(maxsize=None)  # (both tests below read the same run)
def drum_torques(walls, spin=10.0, steps=4000):
    """Spin the drum up for 20000 steps (29 ms: the grains pile up against the rising side),
    then run ``steps`` single steps; returns the drum's wall indices, the impulse of the
    driving torque (-wall_torques along y, as reported after each step), the impulse of the
    torque of the wall contacts on the grains about the axis at the positions where the step
    evaluated them (from ``contacts()``), the impulse of gravity's moment (sum m g x), and the
    grains' change of angular momentum about the axis."""
    sim = drum(spin, walls)
    drum_walls = [0] if walls == "mesh" else list(range(24))
    sim.run(steps=20000)
    before = spin_about_y(sim)
    driving = from_contacts = gravity = 0.0
    for _ in range(steps):
        x = sim.positions
        gravity += sim.dt * float((sim.masses * G * x[:, 0]).sum())
        sim.run(steps=1)
        driving += sim.dt * -float(sim.wall_torques()[drum_walls, 1].sum())
        c = sim.contacts()
        w = c["wall"] >= 0
        from_contacts += sim.dt * float((np.cross(x[c["i"][w]], c["force"][w])
                                         + c["torque_i"][w])[:, 1].sum())
    return driving, from_contacts, gravity, spin_about_y(sim) - before


@pytest.mark.parametrize("walls", ["mesh", "planes"])
def test_a_spinning_drum_needs_a_driving_torque_along_its_spin(walls):
    """A drum (mesh, or 24 planes turning about the common centre) spins at +10 rad/s about
    y: at its bottom the wall moves toward -x (w x r = y x -z = -x), so friction carries the
    grains up the -x side, and their weight's moment about the axis (sum m g x, along y) resists
    the spin. The torque the spheres put on the drum is then against the spin: the driving
    torque -wall_torques . y is positive on average (over 5.8 ms), and by the balance of
    angular momentum about the axis (the caps are frictionless planes normal to y, and pair
    contacts cancel) its impulse plus gravity's equals the grains' gain of angular momentum
    (to round-off: the next test; 1 % here)."""
    driving, _, gravity, gained = drum_torques(walls)
    assert driving > 0
    assert gravity < 0  # the grains sit on the -x side
    assert driving + gravity == pytest.approx(gained, rel=1e-2, abs=0)


@pytest.mark.parametrize("walls", ["mesh", "planes"])
def test_a_drums_torque_impulse_balances_the_grains_angular_momentum_to_round_off(walls):
    """The step is symplectic Euler: x_n x (v_{n+1} - v_n) = dt x_n x F_n/m and
    (x_{n+1} - x_n) x v_{n+1} = 0, so the grains' angular momentum about the axis changes by
    exactly dt times the moments of the forces at the positions x_n where they were evaluated.
    The wall contacts' part of it (from contacts(), at x_n) closes the balance to round-off
    (1e-9 here; seen 1e-12, the round-off of the sums of nearly cancelling impulses);
    wall_torques() takes each moment where the force was evaluated (x - dt v) and gives the
    same impulse."""
    driving, from_contacts, gravity, gained = drum_torques(walls)
    assert from_contacts + gravity == pytest.approx(gained, rel=1e-9, abs=0)
    assert driving + gravity == pytest.approx(gained, rel=1e-9, abs=0)


def test_the_torque_on_a_floor_is_the_moment_of_the_force_where_it_was_evaluated():
    """The smallest case of the drum's lag: a sphere sliding at 1 m/s along x on a frictional
    floor (plane through the origin, its centre): after one step, contacts() gives the force F
    (on the sphere) and its torque at the position x_n the step started from; the torque on the
    wall about the origin must be -(x_n x F + torque_i), to 1e-12."""
    mat = material(friction=0.5)
    sim = tsubu.Simulation(dt=DT, threads=1)
    sim.add_sphere((0.0, 0.0, R - M * G / KN), R, mat, velocity=(1.0, 0.0, 0.0))
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=mat)
    sim.run(steps=100)
    x = sim.positions
    sim.run(steps=1)
    c = sim.contacts()
    expected = -(np.cross(x[0], c["force"][0]) + c["torque_i"][0])
    scale = np.linalg.norm(c["force"][0]) * R
    assert np.allclose(sim.wall_torques()[0], expected, rtol=0, atol=1e-12 * scale)

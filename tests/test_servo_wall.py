"""Servo walls (Simulation.set_wall_servo): a wall driven by a target force.

The statics it must reach: a lid pressing a confined pack with force F along -z carries F, and
the floor then carries the pack's weight plus F (Newton's third law and the pack's equilibrium:
F_floor = m g + F_lid).
"""
import numpy as np
import pytest

import tsubu


def confined_pack(threads=1):
    mat = tsubu.Material(density=2500, kn=1e4, restitution=0.3, friction=0.3)
    sim = tsubu.Simulation(gravity=(0, 0, -9.81), threads=threads)
    g = (np.arange(4) + 0.5) * 0.002 - 0.004
    X, Y, Z = np.meshgrid(g, g, 0.0011 + 0.0022 * np.arange(3), indexing="ij")
    sim.add_spheres(np.stack([X.ravel(), Y.ravel(), Z.ravel()], 1), 1e-3, mat)
    floor = sim.add_plane((0, 0, 0), (0, 0, 1), mat)
    for p, n in [((-0.004, 0, 0), (1, 0, 0)), ((0.004, 0, 0), (-1, 0, 0)),
                 ((0, -0.004, 0), (0, 1, 0)), ((0, 0.004, 0), (0, -1, 0))]:
        sim.add_plane(p, n, mat)
    lid = sim.add_plane((0, 0, 0.009), (0, 0, -1), mat)
    return sim, floor, lid


def test_a_servo_lid_settles_at_its_force_and_the_floor_carries_weight_plus_it():
    sim, floor, lid = confined_pack()
    force = 0.5  # N, ~50x the pack's weight
    sim.set_wall_servo(lid, force=force, max_speed=0.05)
    sim.run(time=0.12)
    f = sim.wall_forces()
    weight = sim.masses.sum() * 9.81
    assert f[lid][2] == pytest.approx(force, rel=1e-6, abs=0)             # the spheres push the lid up by F
    assert -f[floor][2] == pytest.approx(weight + force, rel=1e-6, abs=0)  # and the floor down by mg + F
    assert sim.wall(lid)["servo"]["force"] == force
    # Settled: the lid stands still, below where it started.
    assert np.linalg.norm(sim.wall(lid)["velocity"]) < 1e-9
    assert sim.wall(lid)["point"][2] < 0.009


def test_a_servo_wall_is_the_same_for_any_thread_count_and_through_a_checkpoint(tmp_path):
    runs = []
    for threads in (1, 2):
        sim, _, lid = confined_pack(threads)
        sim.set_wall_servo(lid, force=0.2, max_speed=0.05)
        sim.run(steps=3000)
        runs.append(sim)
    a, b = runs
    lid = 5
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.wall(lid)["point"], b.wall(lid)["point"])
    path = a.save(tmp_path / "servo.tsubu")
    c = tsubu.Simulation.load(path)
    a.run(steps=2000)
    c.run(steps=2000)
    assert np.array_equal(a.positions, c.positions)
    assert np.array_equal(a.wall(lid)["point"], c.wall(lid)["point"])
    assert c.wall(lid)["servo"]["force"] == 0.2


def test_clearing_a_servo_stops_the_wall():
    sim, _, lid = confined_pack()
    sim.set_wall_servo(lid, force=0.2, max_speed=0.05)
    sim.run(steps=500)
    sim.clear_wall_servo(lid)
    assert "servo" not in sim.wall(lid)
    z = sim.wall(lid)["point"][2]
    sim.run(steps=500)
    assert sim.wall(lid)["point"][2] == z


@pytest.mark.parametrize("kwargs, match", [
    (dict(force=-1.0, max_speed=0.1), "force"),
    (dict(force=1.0, max_speed=0.0), "max_speed"),
    (dict(force=1.0, max_speed=float("nan")), "max_speed"),
    (dict(force=1.0, max_speed=0.1, gain=-2.0), "gain"),
    (dict(force=1.0, max_speed=0.1, direction=(0, 0, 0)), "direction"),
])
def test_bad_servo_settings_are_refused_by_name(kwargs, match):
    sim, _, lid = confined_pack()
    with pytest.raises(ValueError, match=match):
        sim.set_wall_servo(lid, **kwargs)


def test_a_mesh_servo_needs_a_direction():
    sim, _, _ = confined_pack()
    mat = sim.materials[0]
    lid = sim.add_mesh(*tsubu.mesh.square((0, 0, 0.02), 0.01, (0, 0, -1), 2), material=mat)
    with pytest.raises(ValueError, match="direction"):
        sim.set_wall_servo(lid, force=0.1, max_speed=0.01)
    sim.set_wall_servo(lid, force=0.1, max_speed=0.01, direction=(0, 0, -1))
    assert sim.wall(lid)["servo"]["direction"][2] == -1

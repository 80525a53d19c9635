"""Flat sheets of mesh triangles (docs/geometry.md, "Flat sheets"): a speed aid that must not
show in the bits.

Where the triangles of a mesh near a sphere (within r + skin/10) all lie in one plane and every
edge among them within that reach is shared by two of them, they stand in the near-wall list as
one entry: the triangle that holds the sphere's contact, or that it lies over. The step measures
that triangle alone while the sphere lies over its face, and every triangle of the sheet, as
separate entries would be, when the sphere nears an edge; the contact then moves to the triangle
that holds it. So a run with sheets gives the bits of a run without (``_mesh_sheets = False``,
a testing aid), for any thread count, through removals and checkpoints; ridges, rims and
creases within reach make no sheet, and neither do moving meshes or sticky laws.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu
from tsubu import mesh

from bits import assert_same_bits

R = 0.5e-3
KN = 1.0e3
RHO = 2500.0
G = 9.81
M = RHO * 4.0 / 3.0 * math.pi * R ** 3
DT = 0.02 * 2.0 * math.sqrt(M / KN)  # as tests/test_mesh_walls.py


def material(friction=0.3, restitution=0.2):
    return tsubu.Material(density=RHO, kn=KN, restitution=restitution, friction=friction)


def tilted(vertices, degrees=(12.0, 7.0), shift=(0.4e-3, -0.3e-3, 0.2e-3)):
    """The vertices turned about x, then y, and shifted: a plane whose normal and corners are
    not round numbers, so that which triangle a contact is measured on shows in the last bits."""
    a, b = np.radians(degrees)
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    turn = ry @ rx
    return np.asarray(vertices) @ turn.T + np.asarray(shift), turn @ np.array([0.0, 0.0, 1.0])


def pour_onto(sim, vertices_faces, normal, n_side=3, lift=1.4e-3, seed=11, speed=0.1):
    """n_side^2 x 3 frictional spheres above the mesh, thrown at it with spins."""
    mat = material(friction=0.2)
    sim.add_mesh(*vertices_faces, material=mat)
    g = (np.arange(n_side) - (n_side - 1) / 2) * 1.2e-3
    x = np.stack(np.meshgrid(g, g, np.array([0.0, 1.2e-3, 2.4e-3]) + lift, indexing="ij"), -1).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    v = rng.normal(0, 0.02, x.shape) + [0.3, 0.15, 0.0] - speed * np.asarray(normal)
    sim.add_spheres(x, R, mat, velocities=v, angular_velocities=rng.normal(0, 50, x.shape))
    return sim


def fine_tilted_floor(threads, sheets, gravity=(2.0, 1.0, -G), divisions=50):
    """A tilted square floor 10 mm wide of 2 x divisions^2 triangles (50: legs of a fifth of a
    diameter) with 27 spheres thrown onto it."""
    v, f = mesh.square((0.0, 0.0, 0.0), 10e-3, (0.0, 0.0, 1.0), divisions)
    v, normal = tilted(v)
    sim = tsubu.Simulation(dt=DT, threads=threads, parallel_min=0, gravity=gravity)
    sim._core._mesh_sheets = sheets
    return pour_onto(sim, (v, f), normal)


def run_watching(sim, steps, every=100, per_call=100):
    """Runs ``steps`` in calls of ``per_call``; returns the most sheets seen and the triangles
    that held a contact, sampled every ``every`` steps."""
    most, touched = 0, set()
    for _ in range(steps // per_call):
        sim.run(steps=per_call)
        if sim.step_count % every == 0:
            most = max(most, sim._core._mesh_sheet_count)
            c = sim.contacts()
            touched |= set(c["element"][c["wall"] >= 0].tolist())
    return most, touched


def test_spheres_rolling_over_a_tilted_fine_floor_give_the_bits_of_separate_triangles():
    """27 spheres thrown with spins onto a tilted floor of 2 x 50 x 50 triangles, gravity
    across it: they bounce, slide and roll over many triangles (contacts move from triangle to
    triangle, across edges and corners). With sheets, without, and with sheets on 2 threads:
    the same bits, wall loads included."""
    with_sheets = fine_tilted_floor(1, True)
    most, touched = run_watching(with_sheets, 6000)
    assert most >= 6  # (the lowest layer lies on sheets: the test measures the sheets' path)
    assert len(touched) >= 30  # (contacts crossed many edges: the sheets' whole path too)
    assert_the_bits_of_separate_triangles(with_sheets, fine_tilted_floor, 6000)


def assert_the_bits_of_separate_triangles(with_sheets, build, steps):
    """``with_sheets`` (``build(1, True)`` run ``steps`` steps) has the bits, wall loads included,
    of the same run without sheets and of the run with sheets on 2 threads."""
    without = build(1, False)
    assert run_watching(without, steps)[0] == 0
    assert_same_bits(with_sheets, without)
    assert np.array_equal(with_sheets.wall_forces(), without.wall_forces())
    two = build(2, True)
    run_watching(two, steps)
    assert_same_bits(with_sheets, two)


def test_a_sphere_over_the_middle_of_one_large_triangle_lies_on_a_sheet_of_one():
    """A floor of two large triangles (a tilted square 10 mm wide, one diagonal): a sphere whose
    reach holds no edge of its one near triangle has a sheet of that triangle alone, whose plane
    stands while the sphere stays over the face (a hopper's plates). The lowest layer's spheres
    off the diagonal lie on such sheets; the same bits without sheets and on 2 threads."""
    def coarse(threads, sheets):
        return fine_tilted_floor(threads, sheets, divisions=1)

    with_sheets = coarse(1, True)
    most, touched = run_watching(with_sheets, 4000)
    # (9 spheres in the lowest layer, 3 of them on the diagonal: at least the other 6 on sheets
    # of one triangle, which separate entries of two triangles could not give)
    assert most >= 6
    assert touched == {0, 1}
    assert_the_bits_of_separate_triangles(with_sheets, coarse, 4000)


def test_runs_of_one_step_give_the_bits_of_long_runs_with_sheets():
    """A run start resets what the sheets keep between steps (where the sphere stood over its
    face): 1,000 steps in calls of 1 step, of 100 and in one call give the same bits."""
    runs = []
    for per_call in (1, 100, 1000):
        sim = fine_tilted_floor(1, True)
        run_watching(sim, 1000, every=1000, per_call=per_call)
        runs.append(sim)
    assert_same_bits(runs[0], runs[1])
    assert_same_bits(runs[0], runs[2])


@pytest.mark.parametrize("half_angle", [60.0, 80.0])
def test_a_crease_makes_no_sheet_and_spheres_in_it_press_both_faces(half_angle):
    """Two fine tilted planes meeting in a valley (a V of 2 x 2 x 30 x 8 triangles): a sphere
    whose reach holds the crease gets no sheet and presses each face once, as separate
    triangles do; spheres on either face away from the crease lie on sheets. The same bits with
    and without sheets."""
    def valley(sheets):
        t = math.radians(90.0 - half_angle)
        v, f = [], []
        for side in (-1.0, 1.0):
            u = np.array([side * math.cos(t), 0.0, math.sin(t)])  # up the face, away from the crease
            grid = np.linspace(0.0, 6e-3, 9)
            along = np.linspace(-6e-3, 6e-3, 31)
            base = len(v)
            for a in along:
                for s in grid:
                    v.append(a * np.array([0.0, 1.0, 0.0]) + s * u)
            for i in range(len(along) - 1):
                for j in range(len(grid) - 1):
                    p = base + i * len(grid) + j
                    q = p + len(grid)
                    quad = [(p, q, p + 1), (p + 1, q, q + 1)] if side > 0 else [(p, p + 1, q), (p + 1, q + 1, q)]
                    f.extend(quad)
        sim = tsubu.Simulation(dt=DT, threads=1, parallel_min=0)
        sim._core._mesh_sheets = sheets
        mat = material(friction=0.4, restitution=0.2)
        sim.add_mesh(np.array(v), np.array(f), material=mat)
        lift = R / math.cos(t) + 0.05e-3  # (just clear of a face, measured along z)
        x = np.array([[0.0, y, lift] for y in (-3e-3, 0.0, 3e-3)]
                     + [[side * 3e-3, y, 3e-3 * math.tan(t) + lift] for side in (-1, 1) for y in (-2e-3, 2e-3)])
        sim.add_spheres(x, R, mat)
        sim.run(steps=6000)
        return sim

    a, b = valley(True), valley(False)
    assert a._core._mesh_sheet_count == 4  # (the four on the faces; the three in the crease none)
    assert_same_bits(a, b)
    c = a.contacts()
    in_crease = np.abs(a.positions[:, 0]) < R
    assert in_crease.sum() >= 3
    for i in np.flatnonzero(in_crease):
        walls = (c["i"] == i) & (c["wall"] >= 0)
        assert walls.sum() == 2  # one contact per face


def test_removing_spheres_keeps_the_bits_with_sheets():
    """Spheres removed mid-run (the lists compacted in place, sheets and all) leave the others
    with the bits of a run without sheets."""
    def run(sheets):
        sim = fine_tilted_floor(1, sheets)
        sim.run(steps=1500)
        sim.remove_spheres(sim.ids[::4])
        sim.run(steps=1500)
        return sim

    assert_same_bits(run(True), run(False))


def test_a_checkpoint_on_a_fine_floor_resumes_bit_for_bit(tmp_path):
    """Saved at step 1,500 and loaded, a run with sheets ends with the bits of the unbroken one."""
    whole = fine_tilted_floor(1, True)
    whole.run(steps=3000)
    first = fine_tilted_floor(1, True)
    first.run(steps=1500)
    path = first.save(tmp_path / "floor.tsubu")
    resumed = tsubu.Simulation.load(path)
    resumed.run(steps=1500)
    assert_same_bits(whole, resumed)


def test_a_moving_mesh_has_no_sheets():
    """A mesh that moves (here, slides in its plane) is measured triangle by triangle."""
    sim = fine_tilted_floor(1, True)
    sim.run(steps=4000)
    assert sim._core._mesh_sheet_count > 0
    sim.set_wall_motion(0, velocity=(1e-3, 0.0, 0.0))
    sim.run(steps=500)
    assert sim._core._mesh_sheet_count == 0
    sim.set_wall_motion(0, velocity=(0.0, 0.0, 0.0))
    sim.run(steps=500)
    assert sim._core._mesh_sheet_count > 0


def test_a_sticky_law_has_no_sheets():
    """An adhesive (JKR) contact holds past zero overlap, where a sheet's rule (one face, the
    others clear) need not hold: its triangles stay separate entries."""
    mat = tsubu.Material(youngs_modulus=1e7, poisson_ratio=0.3, density=RHO, restitution=0.3,
                         friction=0.3, work_of_adhesion=0.05)
    sim = tsubu.Simulation(threads=1, parallel_min=0)
    sim.add_mesh(*mesh.square((0.0, 0.0, 0.0), 6e-3, (0.0, 0.0, 1.0), 30), material=mat)
    sim.add_spheres([[0.1e-3, 0.2e-3, R + 0.02e-3]], R, mat)
    sim.run(steps=2000)
    assert (sim.contacts()["wall"] >= 0).sum() == 1  # (it sticks to the floor)
    assert sim._core._mesh_sheet_count == 0


def test_a_mesh_that_overlaps_itself_in_one_plane_makes_no_sheet():
    """Two copies of a fine floor in one mesh, the second shifted by half a triangle in the
    plane: every edge near a sphere is shared by two triangles of its own copy, but the copies
    overlap, and separate entries give a contact per copy. So no sheet forms, and the bits are
    those of separate entries: each sphere resting on the floor presses it twice."""
    def run(sheets):
        v, f = mesh.square((0.0, 0.0, 0.0), 6e-3, (0.0, 0.0, 1.0), 30)
        shifted = v + [0.1e-3, 0.07e-3, 0.0]
        v2, f2 = np.vstack([v, shifted]), np.vstack([f, f + len(v)])
        sim = tsubu.Simulation(dt=DT, threads=1, parallel_min=0)
        sim._core._mesh_sheets = sheets
        mat = material(friction=0.3)
        sim.add_mesh(v2, f2, material=mat)
        sim.add_spheres([[x, y, R + 0.02e-3] for x in (-1.5e-3, 0.3e-3, 1.6e-3) for y in (-1e-3, 1.1e-3)], R, mat)
        sim.run(steps=3000)
        return sim

    a, b = run(True), run(False)
    assert a._core._mesh_sheet_count == 0
    assert_same_bits(a, b)
    c = a.contacts()
    assert ((c["wall"] >= 0).sum()) == 2 * len(a)  # (a contact per copy)


def test_a_fine_mesh_keeps_contact_state_only_for_the_triangles_near_each_sphere(tmp_path):
    """The walls have two levels, as the pairs (docs/architecture.md, "Neighbour lists: two
    levels"): a rebuild lists every triangle within r + skin of a sphere as keys only, and each
    refresh keeps, with its contact state, those within r + skin/10 and every touching one. Under
    a floor whose triangles are a fifth of a diameter, a resting sphere reaches some fifty of
    them, and its state is kept for the few under it; a checkpoint taken mid-run (its wall
    contacts put back through the same refresh) resumes to the same bits."""
    v, f = mesh.square((0.0, 0.0, 0.0), 10e-3, (0.0, 0.0, 1.0), 50)
    v, normal = tilted(v)
    sim = tsubu.Simulation(dt=DT, gravity=tuple(-G * normal))
    mat = material()
    sim.add_mesh(v, f, material=mat)
    g = (np.arange(4) - 1.5) * 2.2 * R
    x = np.stack(np.meshgrid(g, g, [0.0], indexing="ij"), -1).reshape(-1, 3)
    x = np.asarray(tilted(x)[0]) + (R + 1e-6) * normal  # (tilted() shifts points as it shifts the floor)
    sim.add_spheres(x, R, mat)
    sim.run(steps=2000)
    verlet, near, reach, near_walls, busy = sim._core._list_sizes
    touching = int(np.sum(sim.contacts()["wall"] >= 0))
    assert touching == 16  # (every sphere rests on the floor)
    assert reach >= 20 * touching  # (every triangle within r + skin: keys only)
    assert touching <= near_walls <= reach / 4  # (state for those within r + skin/10)
    sim.save(tmp_path / "floor.tsubu")
    resumed = tsubu.Simulation.load(tmp_path / "floor.tsubu")
    for s in (sim, resumed):
        s.run(steps=700)
    assert_same_bits(sim, resumed)

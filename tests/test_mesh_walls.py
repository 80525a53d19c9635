"""Mesh walls (issue 27): the physics of spheres on triangle meshes (docs/geometry.md).

A flat surface made of many triangles is the plane through them: a sphere rolling and sliding
over it follows its trajectory on that plane (bit for bit on a z = 0 square, to round-off on a
tilted one) with one contact at a time. A sphere on a convex edge or vertex gets one contact
along the edge (vertex) normal; in a concave corner one contact per face, with the forces of
statics. A box mesh is the box of six planes; an STL file is its arrays; a turning or sliding
mesh drives a sphere as a turning or sliding plane does. Bad meshes are refused naming the
triangle; runs with meshes are bit-identical for any thread count and through checkpoints.

A wall contact uses the sphere's mass as m_eff (docs/physics.md, "Walls").
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
DT = 0.02 * 2.0 * math.sqrt(M / KN)  # 1.4472e-6 s, as tests/test_walls.py


def material(friction=0.3, restitution=0.5, **kw):
    return tsubu.Material(density=RHO, kn=KN, restitution=restitution, friction=friction, **kw)


def frame(normal):
    """A unit normal n and two in-plane unit vectors u, v (right-handed)."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    u = np.cross(n, [0.0, 1.0, 0.0]) if abs(n[1]) < 0.9 else np.cross(n, [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    return n, u, np.cross(n, u)


def record(sim, samples, every=100):
    """Runs ``samples * every`` steps; returns the (positions, velocities, spins, dissipated
    energy, contacts' tangential springs) at every ``every`` steps and the number of wall
    contacts at each of them."""
    states, contacts = [], []
    for _ in range(samples):
        sim.run(steps=every)
        states.append((sim.positions, sim.velocities, sim.angular_velocities,
                       sim.energy()["dissipated"], sim.contacts()["tangential_displacement"]))
        contacts.append(int((sim.contacts()["wall"] >= 0).sum()))
    return states, contacts


# ---- 1. a flat surface of triangles is the plane through them -------------------------------

def sliding_sphere(surface, normal=(0.0, 0.0, 1.0), center=(0.0, 0.0, 0.0)):
    """A sphere put down on the surface through ``center`` with normal ``normal`` (gravity
    along -normal, the sphere at its equilibrium overlap m g / kn), moving at 0.22 m/s in the
    plane and spinning so that it slips at 0.03 m/s (and 30 rad/s about the normal): friction
    (0.3) stops the slip in about 2000 steps, then it rolls with a loaded tangential spring,
    about 2.3 mm in 8000 steps across the 4 mm square of 2 x 32 x 32 triangles (cells of 0.125 mm), much smaller than
    the sphere. ``surface(sim, mat, n, c)`` adds the wall."""
    n, u, v = frame(normal)
    mat = material()
    sim = tsubu.Simulation(dt=DT, threads=1, gravity=tuple(-G * n))
    start = np.asarray(center) + (R - M * G / KN) * n - 1.5e-3 * u - 1.0e-3 * v
    velocity = 0.2 * u + 0.1 * v
    sim.add_sphere(start, R, mat, velocity=velocity,
                   angular_velocity=np.cross(n, velocity) / R + 60 * u + 30 * n)
    surface(sim, mat, n, np.asarray(center, float))
    return sim


def on_plane(sim, mat, n, c):
    sim.add_plane(point=c, normal=n, material=mat)


def on_square(jitter, divisions=32):
    def add(sim, mat, n, c):
        sim.add_mesh(*mesh.square(c, 4e-3, n, divisions, jitter=jitter), material=mat)
    return add


@pytest.mark.parametrize("jitter", [0.0, 0.4])
def test_a_sphere_slides_and_rolls_over_a_flat_square_as_over_its_plane(jitter):
    """z = 0: the square's vertices lie exactly at z = 0 (docs/geometry.md), every triangle's
    plane is the plane z = 0 to the bit, and the hand-over of the contact's history between
    triangles copies it whole: positions, velocities, spins and dissipated energy every 100
    steps equal the plane's to the bit, and so does the contact's tangential spring, regular
    or irregular tessellation, while the sphere slides, then rolls, across triangle edges
    (about 2.3 mm over 0.125 mm cells)."""
    plane, on_plane_contacts = record(sliding_sphere(on_plane), 80)
    squared, on_square_contacts = record(sliding_sphere(on_square(jitter)), 80)
    assert on_square_contacts == on_plane_contacts == [1] * 80
    assert np.abs(plane[40][4]).max() > 1e-9  # rolling: a loaded spring
    for k, (a, b) in enumerate(zip(plane, squared)):
        for name, x, y in zip(("positions", "velocities", "spins"), a[:3], b[:3]):
            assert np.array_equal(x, y), (k, name)
        assert a[3] == b[3], k
        assert np.array_equal(a[4], b[4]), k  # the spring crossed the edges whole
    travelled = np.linalg.norm(squared[-1][0][0] - squared[0][0][0])
    assert travelled > 2e-3  # crossed several triangles (0.125 mm cells)
    assert plane[-1][3] > 0  # it slid: friction dissipated energy


def test_triangles_that_share_corners_only_by_coordinates_are_joined_too():
    """add_mesh joins vertices at equal coordinates (its docstring): the irregular square with
    each triangle's corners in rows of their own (as an STL file stores them) is the same
    surface, and the sphere's run is the plane's to the bit, its spring included."""
    def unmerged(sim, mat, n, c):
        v, f = mesh.square(c, 4e-3, n, 32, jitter=0.4)
        sim.add_mesh(v[f].reshape(-1, 3), np.arange(3 * len(f)).reshape(-1, 3), material=mat)

    plane, on_plane_contacts = record(sliding_sphere(on_plane), 80)
    loose, loose_contacts = record(sliding_sphere(unmerged), 80)
    assert loose_contacts == on_plane_contacts == [1] * 80
    for a, b in zip(plane, loose):
        for x, y in zip(a, b):
            assert np.array_equal(x, y)


def test_a_sphere_touches_a_flat_square_once_at_every_step():
    """At every one of 3000 steps of the slide (and the start of the roll) over the irregular
    square, exactly one contact, with one of the square's triangles."""
    sim = sliding_sphere(on_square(0.4))
    elements = set()
    for _ in range(3000):
        sim.run(steps=1)
        c = sim.contacts()
        assert c["wall"].tolist() == [0]
        elements.add(int(c["element"][0]))
    assert len(elements) > 5  # it went over several triangles


def test_a_sphere_slides_over_a_tilted_square_as_over_its_plane_to_round_off():
    """A square with normal (0.3, -0.2, 0.9) through (1, 2, -0.5) mm against the plane through
    that point with that normal (gravity along -n). The triangles' vertices are the centre plus
    in-plane offsets, each rounded to about 1e-19 m (half an ulp of a millimetre), so each
    triangle's plane differs from the wall's by about that much, which is 1e-11 of the
    equilibrium overlap m g / kn = 1.3e-8 m: forces, and so the trajectory, differ in their
    11th digit at most. Checked: positions to 1e-15 m (a part in 1e12 of the millimetre), and
    velocities, spins and dissipated energy to 1e-9 of their scale (0.2 m/s, 100 rad/s of the
    450 rad/s, the energy dissipated); the run seen agrees far better (5e-13 relative at most)."""
    normal, center = (0.3, -0.2, 0.9), (1e-3, 2e-3, -0.5e-3)
    plane, on_plane_contacts = record(sliding_sphere(on_plane, normal, center), 80)
    squared, on_square_contacts = record(sliding_sphere(on_square(0.4), normal, center), 80)
    assert on_square_contacts == on_plane_contacts == [1] * 80
    for a, b in zip(plane, squared):
        assert np.allclose(a[0], b[0], rtol=0, atol=1e-15)
        assert np.allclose(a[1], b[1], rtol=0, atol=1e-9 * 0.2)
        assert np.allclose(a[2], b[2], rtol=0, atol=1e-9 * 100)
        assert a[3] == pytest.approx(b[3], rel=1e-9, abs=0)
    assert plane[-1][3] > 0


# ---- 2. convex edges and vertices -----------------------------------------------------------

def roof(slope):
    """A ridge along y at x = 0, z = 0 with two faces falling at ``slope`` (radians) to
    x = -/+ 3 mm: four triangles sharing the ridge's vertices."""
    a, L = 3e-3, 2e-3
    h = -a * math.tan(slope)
    vertices = np.array([[0, -L, 0], [0, L, 0], [-a, -L, h], [-a, L, h], [a, -L, h], [a, L, h]])
    faces = np.array([[2, 0, 1], [2, 1, 3], [0, 4, 5], [0, 5, 1]])
    return vertices, faces


def pyramid(slope):
    """A square pyramid with its apex at the origin, faces falling at ``slope``."""
    a = 3e-3
    h = -a * math.tan(slope)
    base = [[-a, -a, h], [a, -a, h], [a, a, h], [-a, a, h]]
    vertices = np.array([[0.0, 0.0, 0.0]] + base)
    faces = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    return vertices, faces


def settle(sim, steps=6000):
    sim.run(steps=steps)
    return sim.contacts()


@pytest.mark.parametrize("shape", [roof, pyramid], ids=["ridge", "apex"])
@pytest.mark.parametrize("friction", [0.0, 0.5])
def test_a_sphere_on_a_convex_edge_or_vertex_feels_one_vertical_contact(shape, friction):
    """A sphere put on the ridge of a roof (or the apex of a pyramid), faces falling at 20
    degrees: its nearest point on the mesh is the edge (vertex), the contact is along the
    vertical through it (the edge's normal toward the sphere), one contact only, and after
    the dashpot has damped the bounce (e = 0.5: e-folding in 0.17 ms, 6000 steps are 8.7 ms)
    its force is the weight, m g upward, to 1e-9; the symmetric scene keeps the sphere on the
    ridge (x = 0 exactly)."""
    mat = material(friction=friction)
    sim = tsubu.Simulation(dt=DT, threads=1)
    sim.add_mesh(*shape(math.radians(20)), material=mat)
    sim.add_sphere((0.0, 0.0, R + 2e-6), R, mat)
    c = settle(sim)
    assert c["wall"].tolist() == [0]
    f = c["force"][0]
    assert f[2] == pytest.approx(M * G, rel=1e-9, abs=0)
    assert abs(f[0]) <= 1e-12 * M * G and abs(f[1]) <= 1e-12 * M * G
    assert c["overlap"][0] == pytest.approx(M * G / KN, rel=1e-9, abs=0)
    assert sim.positions[0, 0] == 0.0


# ---- 3. concave corners ---------------------------------------------------------------------

def vee(half_angle):
    """A V-groove along y: two faces meeting at the line x = 0, z = 0, each at ``half_angle``
    from the vertical, rising to z = 3 mm."""
    H, L = 3e-3, 2e-3
    a = H * math.tan(half_angle)
    vertices = np.array([[0, -L, 0], [0, L, 0], [-a, -L, H], [-a, L, H], [a, -L, H], [a, L, H]])
    faces = np.array([[0, 1, 3], [0, 3, 2], [0, 4, 5], [0, 5, 1]])
    return vertices, faces


@pytest.mark.parametrize("half_angle", [30.0, 45.0, 60.0])
def test_a_sphere_in_a_v_groove_presses_each_face_with_the_force_of_statics(half_angle):
    """Frictionless faces at half-angle a from the vertical: each face pushes along its normal,
    which makes the angle a with the horizontal, so its vertical part is N sin a; the horizontal
    parts cancel by symmetry and the vertical ones carry the weight: 2 N sin a = m g,
    N = m g / (2 sin a) (the wedge of any statics text, e.g. Meriam & Kraige, Engineering
    Mechanics: Statics, ch. 3). One contact per face (each with a triangle of that face), each
    force N along that face's normal, to 1e-9 once the dashpots have settled the sphere."""
    a = math.radians(half_angle)
    mat = material(friction=0.0)
    sim = tsubu.Simulation(dt=DT, threads=1)
    sim.add_mesh(*vee(a), material=mat)
    sim.add_sphere((0.0, 0.0, R / math.sin(a)), R, mat)
    c = settle(sim, 12000)
    assert c["wall"].tolist() == [0, 0]
    faces = sorted(int(e) // 2 for e in c["element"])
    assert faces == [0, 1]  # triangles 0, 1 are the face at -x, 2, 3 the face at +x
    N = M * G / (2.0 * math.sin(a))
    for f in c["force"]:
        side = -1.0 if f[0] > 0 else 1.0  # the face at -x pushes toward +x
        normal = np.array([-side * math.cos(a), 0.0, math.sin(a)])
        assert np.linalg.norm(f) == pytest.approx(N, rel=1e-9, abs=0)
        assert np.allclose(f / np.linalg.norm(f), normal, rtol=0, atol=1e-9)
    assert sim.forces[0] == pytest.approx(np.zeros(3), abs=1e-9 * M * G)


def test_a_sphere_in_a_box_corner_presses_the_three_faces_with_a_third_each():
    """Gravity along -(1, 1, 1)/sqrt(3) into the corner lo of a cube mesh (frictionless): the
    three faces' normals are x, y, z, and statics along each gives N = m g / sqrt(3) per face,
    one contact per face (the sphere's foot on each face lies on the diagonal that splits it
    into two triangles: still one contact per face), to 1e-9."""
    mat = material(friction=0.0)
    sim = tsubu.Simulation(dt=DT, threads=1, gravity=tuple(-G / math.sqrt(3) * np.ones(3)))
    sim.add_mesh(*mesh.box((0, 0, 0), (4e-3, 4e-3, 4e-3)), material=mat)
    sim.add_sphere((R + 1e-6,) * 3, R, mat)
    c = settle(sim, 12000)
    assert c["wall"].tolist() == [0, 0, 0]
    sides = sorted(int(e) // 2 for e in c["element"])
    assert sides == [0, 2, 4]  # the sides x = lo, y = lo, z = lo (two triangles each)
    forces = c["force"][np.argsort(c["element"])]
    N = M * G / math.sqrt(3)
    assert np.allclose(forces, N * np.eye(3), rtol=0, atol=1e-9 * N)


# ---- 4. a box mesh is the box of six planes -------------------------------------------------

LO, HI = np.array([0.0, 0.0, 0.0]), np.array([4e-3, 3e-3, 5e-3])


def bouncing_in_a_box(walls, threads=1):
    """Five frictional spheres thrown about (0.3 m/s, spinning) inside the box [LO, HI]."""
    mat = material(friction=0.5)
    sim = tsubu.Simulation(dt=DT, threads=threads, parallel_min=0)
    rng = np.random.default_rng(3)
    x = np.array([[1.0, 1.0, 1.0], [3.0, 1.0, 1.5], [1.0, 2.0, 3.0], [3.0, 2.0, 4.0],
                  [2.0, 1.5, 2.5]]) * 1e-3
    sim.add_spheres(x, 0.45e-3, mat, velocities=rng.normal(0, 0.3, x.shape),
                    angular_velocities=rng.normal(0, 300, x.shape))
    walls(sim, mat)
    return sim


def six_planes(sim, mat):
    for axis in range(3):
        n = np.eye(3)[axis]
        sim.add_plane(point=LO, normal=n, material=mat)
        sim.add_plane(point=HI, normal=-n, material=mat)


def box_mesh(sim, mat):
    sim.add_mesh(*mesh.box(LO, HI), material=mat)


def test_a_box_mesh_is_the_box_of_six_planes():
    """The box's triangles have axis-aligned edges, so their normals (cross products of
    differences of coordinates that are equal in all but one axis) are exactly the axes and the
    distance to a side is the one coordinate difference the plane takes: the same contact
    geometry to the bit, so the same trajectories, step after step, while the spheres hit the
    walls and each other (and the same number of wall contacts at every sample)."""
    planes, mesh_box = bouncing_in_a_box(six_planes), bouncing_in_a_box(box_mesh)
    touches = 0
    for _ in range(30):
        planes.run(steps=200)
        mesh_box.run(steps=200)
        for name in ("positions", "velocities", "angular_velocities"):
            assert np.array_equal(getattr(planes, name), getattr(mesh_box, name)), name
        assert planes.energy()["dissipated"] == mesh_box.energy()["dissipated"]
        touches += int((planes.contacts()["wall"] >= 0).sum())
        assert (planes.contacts()["wall"] >= 0).sum() == (mesh_box.contacts()["wall"] >= 0).sum()
    assert touches > 0


# ---- 5. an STL file is its arrays -----------------------------------------------------------

@pytest.mark.parametrize("binary", [False, True])
def test_an_stl_file_and_its_arrays_give_the_same_run(tmp_path, binary):
    """A cone hopper written to STL and read back: ASCII STL keeps every coordinate to the bit;
    binary STL keeps float32, so the cone is first rounded to float32 (exact in both). The
    merged vertices may be numbered differently, but each triangle keeps its corners and its
    place, so the run (spheres poured into the hopper) is the same to the bit."""
    pytest.importorskip("trimesh")
    vertices, faces = mesh.cone(3e-3, 0.4e-3, 3e-3, 12)  # orifice narrower than a sphere
    if binary:
        vertices = vertices.astype(np.float32).astype(np.float64)
    path = mesh.write_stl(tmp_path / "cone.stl", vertices, faces, binary=binary)
    read_vertices, read_faces = tsubu.read_mesh(path)
    assert np.array_equal(read_vertices[read_faces], vertices[faces])

    def pour(v, f):
        mat = material(friction=0.5)
        sim = tsubu.Simulation(dt=DT, threads=1)
        # (The default centre, the mean of the vertices, would depend on their numbering.)
        sim.add_mesh(v, f, material=mat, center=(0, 0, 0))
        x = np.array([[0, 0, 1.2e-3], [1.2e-3, 0.3e-3, 2.0e-3], [-0.9e-3, -0.9e-3, 2.8e-3]])
        sim.add_spheres(x, 0.4e-3, mat)
        return sim

    a, b = pour(vertices, faces), pour(read_vertices, read_faces)
    for _ in range(4):
        a.run(steps=3000)
        b.run(steps=3000)
        assert_same_bits(a, b)
    assert (a.contacts()["wall"] >= 0).sum() >= 3  # all three rest on the cone's faces


# ---- 6. moving meshes drive spheres as moving planes do -------------------------------------

def on_turntable(wall, velocity=(0.0, 0.0, 0.0), angular_velocity=(0.0, 0.0, 0.0)):
    """A sphere at rest on a floor (a plane or a 4 mm square of 20 x 20 jittered triangles,
    centre (0.3, -0.2, 0) mm) 1.2 mm off the centre, the floor moving as given: friction
    drags the sphere along."""
    mat = material(friction=0.5)
    sim = tsubu.Simulation(dt=DT, threads=1)
    sim.add_sphere((1.5e-3, -0.2e-3, R - M * G / KN), R, mat)
    c = (0.3e-3, -0.2e-3, 0.0)
    if wall == "plane":
        sim.add_plane(point=c, normal=(0, 0, 1), material=mat, velocity=velocity,
                      angular_velocity=angular_velocity, center=c)
    else:
        sim.add_mesh(*mesh.square(c, 4e-3, (0, 0, 1), 20, jitter=0.4), material=mat,
                     velocity=velocity, angular_velocity=angular_velocity, center=c)
    return sim


@pytest.mark.parametrize("motion", [dict(angular_velocity=(0.0, 0.0, 40.0)),
                                    dict(velocity=(0.05, 0.03, 0.0)),
                                    dict(velocity=(0.03, 0.0, 0.02))],
                         ids=["turning", "sliding", "lifting"])
def test_a_moving_square_drags_a_sphere_as_the_moving_plane_does(motion):
    """A floor turning at 40 rad/s about the vertical through its centre (the sphere, 1.2 mm
    off-axis, is dragged round at up to 48 mm/s), or sliding at (50, 30, 0) mm/s, or sliding
    and rising at (30, 0, 20) mm/s (carrying the sphere up 0.17 mm): the mesh,
    whose vertices turn (slide) with it, and the plane through the same centre with the same
    motion, whose surface velocity is v + w x (x - c), give the same trajectory. The mesh's
    vertices are moved by its rigid motion each step, so its triangles' planes differ from
    z = 0 by round-off of the rotation (1e-19 m relative to the 1.3e-8 m overlap) and the
    contact point's wall velocity by round-off of the same: positions to 1e-15 m,
    velocities to 1e-9 of the 0.05 m/s scale, spins to 1e-9 of the 100 rad/s scale."""
    plane, mesh_floor = on_turntable("plane", **motion), on_turntable("mesh", **motion)
    start = plane.positions[0].copy()
    touching = 0
    for _ in range(30):
        plane.run(steps=200)
        mesh_floor.run(steps=200)
        count = (mesh_floor.contacts()["wall"] >= 0).sum()
        assert count == (plane.contacts()["wall"] >= 0).sum() <= 1
        touching += count
        assert np.allclose(plane.positions, mesh_floor.positions, rtol=0, atol=1e-15)
        assert np.allclose(plane.velocities, mesh_floor.velocities, rtol=0, atol=1e-9 * 0.05)
        assert np.allclose(plane.angular_velocities, mesh_floor.angular_velocities, rtol=0,
                           atol=1e-9 * 100)
    assert np.linalg.norm(plane.positions[0] - start) > 0.05e-3  # the floor dragged it along
    assert np.linalg.norm(plane.velocities[0]) > 0.01
    assert touching >= 15  # (the rising floor throws the sphere up a little: e = 0.5)


def test_a_turning_mesh_keeps_its_shape_and_turns_about_its_centre():
    """After a quarter turn (40 rad/s for pi/80 s) about z through its centre c, the square's
    vertices are those of the start turned by 90 degrees about c (to round-off, 1e-15 m), and
    ``wall(0)`` reports them."""
    sim = on_turntable("mesh", angular_velocity=(0.0, 0.0, 40.0))
    before = sim.wall(0)["vertices"].copy()
    c = sim.wall(0)["center"]
    steps = round(math.pi / 80 / DT)
    sim.dt = math.pi / 80 / steps
    sim.run(steps=steps)
    turned = c + (before - c) @ np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    assert np.allclose(sim.wall(0)["vertices"], turned, rtol=0, atol=1e-15)
    assert np.array_equal(sim.wall(0)["faces"], mesh.square(c, 4e-3, (0, 0, 1), 20,
                                                            jitter=0.4)[1])


# ---- 8. removing a wall ---------------------------------------------------------------------

def gate_scene(threads=1, gate="plane"):
    """Four frictional spheres resting on a gate at z = 0.2 mm (wall 1: a plane, or a square
    mesh), above a floor at z = 0 (wall 2: a jittered square mesh sliding at 2 mm/s); wall 0
    is a side plane x = -3 mm that they do not touch. Three spheres side by side, a fourth
    nested on them; gravity 40 m/s^2 (it shortens the fall, not the physics)."""
    mat = material(friction=0.5)
    sim = tsubu.Simulation(dt=DT, threads=threads, parallel_min=0, gravity=(0, 0, -40.0))
    sim.add_plane(point=(-3e-3, 0, 0), normal=(1, 0, 0), material=mat)
    if gate == "plane":
        sim.add_plane(point=(0, 0, 0.2e-3), normal=(0, 0, 1), material=mat)
    else:
        sim.add_mesh(*mesh.square((0, 0, 0.2e-3), 6e-3, (0, 0, 1), 6), material=mat)
    sim.add_mesh(*mesh.square((0, 0, 0), 8e-3, (0, 0, 1), 8, jitter=0.3), material=mat,
                 velocity=(0.002, 0.0, 0.0))
    x = np.array([[-0.505, 0.0, 0.7], [0.505, 0.0, 0.7], [0.0, -0.875, 0.7],
                  [0.0, -0.29, 1.53]]) * 1e-3
    sim.add_spheres(x, R, mat, angular_velocities=[[0, 0, 50], [0, 0, -50], [10, 0, 0],
                                                    [0, 10, 0]])
    return sim


def open_gate(sim):
    sim.run(steps=1500)   # settle on the gate
    sim.remove_wall(1)
    sim.run(steps=3000)   # fall 0.2 mm onto the floor (2200 steps) and bounce
    return sim


@pytest.mark.parametrize("gate", ["plane", "mesh"])
def test_spheres_held_by_a_gate_fall_when_it_is_removed(gate):
    """Before removal the spheres rest on the gate (every one of its contacts); after
    ``remove_wall(1)`` they fall through where it was onto the floor (wall 2), the gate is
    still listed (``removed`` true, zero load) and walls 0 and 2 keep their indices."""
    sim = gate_scene(gate=gate)
    sim.run(steps=1500)
    assert set(sim.contacts()["wall"].tolist()) == {-1, 1}
    assert np.all(sim.positions[:, 2] > 0.2e-3 + 0.9 * R)
    assert sim.wall_forces()[1, 2] < 0
    sim.remove_wall(1)
    assert sim.wall_count == 3
    assert sim.wall(1)["removed"] and not sim.wall(0)["removed"] and not sim.wall(2)["removed"]
    assert sim.wall(1)["kind"] == gate and sim.wall(2)["kind"] == "mesh"
    before = sim.positions
    sim.run(steps=6000)
    assert np.all(sim.positions[:, 2] < before[:, 2] - 0.15e-3)  # fell the 0.2 mm
    walls = set(sim.contacts()["wall"].tolist()) - {-1}
    assert walls == {2}
    assert np.array_equal(sim.wall_forces()[1], np.zeros(3))
    assert sim.wall_forces()[2, 2] < 0
    with pytest.raises(ValueError, match="wall 3 does not exist"):
        sim.remove_wall(3)


def test_a_run_with_a_removed_wall_is_bit_identical_for_one_and_two_threads():
    """The gate scene on one thread and on two (parallel_min=0: both really used), from the
    start through the removal and the fall onto the sliding floor: the same bits."""
    one = open_gate(gate_scene(threads=1, gate="mesh"))
    two = open_gate(gate_scene(threads=2, gate="mesh"))
    assert (one.contacts()["wall"] == 2).sum() > 0
    assert_same_bits(one, two)
    assert np.array_equal(one.wall_forces(), two.wall_forces())
    assert np.array_equal(one.wall_torques(), two.wall_torques())


@pytest.mark.parametrize("gate", ["plane", "mesh"])
def test_a_removed_wall_stays_removed_through_a_checkpoint(tmp_path, gate):
    """Saved after the removal, mid-fall, and loaded (with 2 threads): the rest of the run
    gives the bits of the run that never stopped."""
    whole = open_gate(gate_scene(gate=gate))
    part = gate_scene(gate=gate)
    part.run(steps=1500)
    part.remove_wall(1)
    part.run(steps=1800)
    part.save(tmp_path / "gate.tsubu")
    resumed = tsubu.Simulation.load(tmp_path / "gate.tsubu", threads=2)
    assert resumed.wall(1)["removed"]
    assert_same_bits(part, resumed)
    resumed.run(steps=1200)
    assert_same_bits(whole, resumed)
    assert np.array_equal(whole.wall_forces(), resumed.wall_forces())
    assert np.array_equal(whole.wall_torques(), resumed.wall_torques())


def test_a_checkpoint_of_a_turning_sliding_mesh_resumes_bit_for_bit(tmp_path):
    """A sphere on a square that turns (40 rad/s) and slides (set_wall_motion between runs),
    saved mid-run: the mesh's pose, motion and centre come back and the continued run (and
    the mesh's vertices) equal the uninterrupted one's to the bit."""
    def scene():
        sim = on_turntable("mesh", angular_velocity=(0.0, 0.0, 40.0))
        sim.run(steps=1500)
        sim.set_wall_motion(0, velocity=(0.01, 0.0, 0.0), center=(0.2e-3, -0.2e-3, 0.0))
        return sim

    whole = scene().run(steps=3000)
    part = scene().run(steps=1700)
    part.save(tmp_path / "turning.tsubu")
    resumed = tsubu.Simulation.load(tmp_path / "turning.tsubu")
    for key in ("vertices", "center", "velocity", "angular_velocity"):
        assert np.array_equal(part.wall(0)[key], resumed.wall(0)[key]), key
    resumed.run(steps=1300)
    assert_same_bits(whole, resumed)
    assert np.array_equal(whole.wall(0)["vertices"], resumed.wall(0)["vertices"])
    assert np.array_equal(whole.wall_torques(), resumed.wall_torques())


# ---- 9. bad input ---------------------------------------------------------------------------

def test_bad_meshes_are_refused_naming_the_triangle():
    mat = material()
    sim = tsubu.Simulation(dt=DT)
    v, f = mesh.square((0, 0, 0), 1e-3, (0, 0, 1), 2)  # 9 vertices, 8 triangles
    bad = v.copy()
    bad[4, 2] = np.nan
    with pytest.raises(ValueError, match=r"vertices.*vertex 4.*triangle"):
        sim.add_mesh(bad, f, material=mat)
    out = f.copy()
    out[5, 1] = 9
    with pytest.raises(ValueError, match=r"triangle 5.*out of range"):
        sim.add_mesh(v, out, material=mat)
    flat = v.copy()
    flat[[0, 1, 4]] = [[0, 0, 0], [1e-3, 0, 0], [2e-3, 0, 0]]  # corners in a line
    with pytest.raises(ValueError, match=r"triangle 0\b.*degenerate"):
        sim.add_mesh(flat, f, material=mat)
    with pytest.raises(ValueError, match=r"triangle 3.*repeats"):
        sim.add_mesh(v, np.where(np.arange(8)[:, None] == 3, [2, 2, 5], f), material=mat)
    assert sim.wall_count == 0  # nothing added


def test_wall_motion_of_a_missing_wall_and_plane_of_a_mesh_are_refused():
    mat = material()
    sim = tsubu.Simulation(dt=DT)
    sim.add_plane(material=mat)
    sim.add_mesh(*mesh.box((0, 0, 0), (1e-3, 1e-3, 1e-3)), material=mat)
    with pytest.raises(ValueError, match="wall 2 does not exist.*2 walls"):
        sim.set_wall_motion(2, velocity=(0, 0, 1))
    with pytest.raises(ValueError, match=r"wall 1 is a mesh.*wall\(1\)"):
        sim.plane(1)
    with pytest.raises(ValueError, match=r"wall 1 is a mesh"):
        sim.set_plane_motion(1, velocity=(0, 0, 1))
    with pytest.raises(TypeError):
        sim.remove_wall(0.5)
    sim.set_wall_motion(1, angular_velocity=(0, 0, 1))  # a mesh's motion is set through this
    assert np.array_equal(sim.wall(1)["angular_velocity"], [0, 0, 1])


# ---- 10. determinism ------------------------------------------------------------------------

@pytest.mark.parametrize("hopper", ["cone", "wedge"])
def test_a_pour_into_a_hopper_is_bit_identical_for_one_and_two_threads(hopper):
    """8 frictional spheres thrown down (0.3 m/s) with random velocities and spins into a
    conical (48 triangles) or wedge hopper whose orifice (0.6 mm) holds them (0.9 mm): contacts
    with faces, edges and vertices, between spheres, with several triangles at once; 1 and 2
    threads give the same bits (wall loads included)."""
    def pour(threads):
        mat = material(friction=0.5)
        sim = tsubu.Simulation(dt=DT, threads=threads, parallel_min=0)
        if hopper == "cone":
            sim.add_mesh(*mesh.cone(4e-3, 0.3e-3, 4e-3, 24), material=mat)
        else:
            sim.add_mesh(*mesh.wedge_hopper(0.6e-3, 8e-3, 4e-3, 4e-3), material=mat)
        g = np.array([-0.5e-3, 0.5e-3])
        x = np.stack(np.meshgrid(g, g, g + 2.0e-3, indexing="ij"), -1).reshape(-1, 3)
        rng = np.random.default_rng(5)
        sim.add_spheres(x, 0.45e-3, mat, velocities=rng.normal(0, 0.05, x.shape) - [0, 0, 0.3],
                        angular_velocities=rng.normal(0, 100, x.shape))
        touched = set()
        for _ in range(24):
            sim.run(steps=100)
            c = sim.contacts()
            touched |= set(c["i"][c["wall"] >= 0].tolist())
        return sim, touched

    (one, touched), (two, _) = pour(1), pour(2)
    assert len(touched) >= 4  # the lower four hit the hopper (the upper four land on them)
    assert_same_bits(one, two)
    assert np.array_equal(one.wall_forces(), two.wall_forces())
    assert np.array_equal(one.wall_torques(), two.wall_torques())


def test_triangles_found_clear_are_skipped_with_the_bits_of_measuring_every_one():
    """Walls::measure skips a triangle it found clear of a sphere while the sphere stays within
    0.9 of that gap of where it was (no wall moving); the records are reset when a run starts, so
    runs of one step measure every near triangle at every step. 27 frictional spheres thrown
    down with spins onto a floor of 2 x 40 x 40 triangles (a fifth of a diameter across), gravity
    tilted, roll and slide over many of them, with 1 and 2 threads: the same bits both ways."""
    def pour(threads, steps_per_call):
        mat = material(friction=0.2)
        sim = tsubu.Simulation(dt=DT, threads=threads, parallel_min=0,
                               gravity=(2.0, 1.0, -G))
        sim.add_mesh(*mesh.square((0.0, 0.0, 0.0), 8e-3, (0.0, 0.0, 1.0), 40), material=mat)
        g = np.array([-1.2e-3, 0.0, 1.2e-3])
        x = np.stack(np.meshgrid(g, g, g + 1.8e-3, indexing="ij"), -1).reshape(-1, 3)
        rng = np.random.default_rng(11)
        sim.add_spheres(x, R, mat, velocities=rng.normal(0, 0.02, x.shape) + [0.3, 0.15, -0.3],
                        angular_velocities=rng.normal(0, 50, x.shape))
        touched = set()
        for _ in range(4000 // steps_per_call):  # (calls of 100 or of 1 step)
            sim.run(steps=steps_per_call)
            if sim.step_count % 100 == 0:
                c = sim.contacts()
                touched |= set(c["element"][c["wall"] >= 0].tolist())
        return sim, touched

    whole, touched = pour(1, 100)
    assert len(touched) >= 20  # (the spheres crossed many triangles)
    assert_same_bits(whole, pour(1, 1)[0])
    assert_same_bits(whole, pour(2, 100)[0])

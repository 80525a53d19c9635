"""tsubu.mesh (mesh validation, STL/OBJ files, generators) and the mesh walls in the VTK output
(issue 27). The engine's mesh walls are tested with the engine; here the Python side alone."""

import os
import re
import struct
import sys

import numpy as np
import pytest

import tsubu
from tsubu import mesh, output

TRIANGLE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def edge_uses(faces):
    """{sorted edge: how many triangles have it}."""
    uses = {}
    for tri in np.asarray(faces).tolist():
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            key = (min(a, b), max(a, b))
            uses[key] = uses.get(key, 0) + 1
    return uses


def normals_and_centroids(vertices, faces):
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    return np.cross(b - a, c - a), (a + b + c) / 3


# ---- check_mesh ----------------------------------------------------------------------------------

def test_check_mesh_returns_float64_and_int64_copies():
    vertices = np.asfortranarray(TRIANGLE.astype(np.float32))
    faces = np.array([[0, 1, 2]], dtype=np.int32)
    v, f = mesh.check_mesh(vertices, faces)
    assert v.dtype == np.float64 and v.flags.c_contiguous and v.shape == (3, 3)
    assert f.dtype == np.int64 and f.flags.c_contiguous and f.tolist() == [[0, 1, 2]]
    v[0, 0] = 5.0
    f[0, 0] = 1
    assert vertices[0, 0] == 0 and faces[0, 0] == 0  # copies, never views
    v, f = mesh.check_mesh(TRIANGLE.tolist(), [[0, 1, 2]])  # lists too
    assert v.tolist() == TRIANGLE.tolist()


SQUARE_V = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]


@pytest.mark.parametrize("vertices, faces, message", [
    (SQUARE_V, [[0, 1, 2], [0, 2, 4]], r"faces: triangle 1 is \[0, 2, 4\]: vertex index 4 is out of "
                                      r"range: vertices has 4 rows \(valid indices are 0 to 3\)"),
    (SQUARE_V, [[0, 1, 2], [0, -1, 3]], r"faces: triangle 1 is \[0, -1, 3\]: vertex index -1 is negative"),
    (SQUARE_V, [[0, 1, 2], [2, 3, 3]], r"faces: triangle 1 is \[2, 3, 3\], which repeats a vertex index"),
    ([[0, 0, 0], [1, 0, 0], [1, 1, 0], [2, 2, 0]], [[0, 1, 2], [0, 2, 3]],
     r"faces: triangle 1 \(\[0, 2, 3\], corners .*\) is degenerate"),
    ([[0, 0, 0], [1, 0, 0], [1, 1, 0], [1, 1, 0]], [[0, 1, 2], [1, 2, 3]],
     r"faces: triangle 1 \(\[1, 2, 3\], .*\) is degenerate"),  # two corners at one point
    ([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0.5, 1e-13, 0]], [[0, 1, 2], [0, 1, 3]],
     r"faces: triangle 1 .* is degenerate"),  # a needle: area 5e-14 < 1e-12 * 1
    ([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 1, 3], [1, 2, 3]],
     r"vertices must be finite: vertex 2 is \[nan, 1.0, 0.0\], used by triangle\(s\) 0 and 2"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [np.inf, 0, 0]], [[0, 1, 2]],
     r"vertices must be finite: vertex 3 is \[inf, 0.0, 0.0\], used by no triangle"),
    (SQUARE_V, [0, 1, 2], r"faces must have shape \(F, 3\) .*got shape \(3,\)"),
    ([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], r"vertices must have shape \(V, 3\), got shape \(3, 2\)"),
    (np.zeros((0, 3)), [[0, 1, 2]], "vertices is empty"),
    (SQUARE_V, np.zeros((0, 3), dtype=int), "faces is empty"),
    ([[0, 0, 0], [1e308, 0, 0], [-1e308, 1, 0]], [[0, 1, 2]], "triangle 0 .* longer than the largest"),
])
def test_check_mesh_refuses_bad_meshes_naming_the_triangle(vertices, faces, message):
    with pytest.raises(ValueError, match=message):
        mesh.check_mesh(vertices, faces)


def test_check_mesh_names_every_bad_triangle_up_to_a_few():
    v = np.array(SQUARE_V, dtype=float)
    faces = [[0, 1, 2]] + [[0, 1, 9]] * 7
    with pytest.raises(ValueError, match=r"7 triangle\(s\) have bad indices: 1, 2, 3, 4, 5 and 2 more"):
        mesh.check_mesh(v, faces)


@pytest.mark.parametrize("vertices, faces, message", [
    ([[0, 0, 0], [1, 0, 0], [0, True, 0]], [[0, 1, 2]], "vertices must be .* not booleans"),
    (TRIANGLE, [[0, 1, True]], "faces must be .* not booleans"),
    (TRIANGLE, np.array([[0, 1, 2]], dtype=bool), "faces must be .* not booleans|dtype bool"),
    (TRIANGLE, [[0.0, 1.0, 2.0]], r"faces must be an array of shape \(F, 3\) of vertex indices "
                                  r"\(integers\), got an array of dtype float64"),
    ("abc", [[0, 1, 2]], "vertices must be .* real numbers"),
    (TRIANGLE, "012", "faces must be .* vertex indices"),
    (TRIANGLE.astype(complex), [[0, 1, 2]], "vertices must be .*dtype complex"),
    (TRIANGLE, None, "faces must be"),
])
def test_check_mesh_refuses_non_numbers_with_type_error(vertices, faces, message):
    with pytest.raises(TypeError, match=message):
        mesh.check_mesh(vertices, faces)


def test_small_and_large_well_shaped_triangles_are_accepted():
    # The degeneracy test is relative: a micrometre triangle is as good as a kilometre one.
    for scale in (1e-200, 1e-6, 1.0, 1e6, 1e200):
        mesh.check_mesh(TRIANGLE * scale, [[0, 1, 2]])
    # A thin but real sliver (area 1e-9 of its longest edge squared) is a triangle.
    mesh.check_mesh([[0, 0, 0], [1, 0, 0], [0.5, 2e-9, 0]], [[0, 1, 2]])


def test_open_meshes_unused_vertices_and_either_orientation_are_accepted():
    v, f = mesh.check_mesh(SQUARE_V + [[5, 5, 5]], [[0, 1, 2], [0, 3, 2]])
    assert f.shape == (2, 3) and v.shape == (5, 3)


# ---- files -----------------------------------------------------------------------------------------

@pytest.fixture
def needs_trimesh():
    """The file tests need trimesh: CI installs it (``.[test]`` has it), so there they run or
    fail, never skip; elsewhere they are skipped without it."""
    if os.environ.get("CI"):
        import trimesh  # noqa: F401
    else:
        pytest.importorskip("trimesh")


def binary_stl(path, triangles):
    """A binary STL written by hand (independent of the writer under test): an 80-byte header,
    the count, then per triangle a normal, three corners (float32) and a 2-byte attribute."""
    with open(path, "wb") as f:
        f.write(b"hand-written binary STL".ljust(80, b" "))
        f.write(struct.pack("<I", len(triangles)))
        for tri in triangles:
            f.write(struct.pack("<12fH", 0, 0, 0, *np.asarray(tri, dtype=float).reshape(-1), 0))


def ascii_stl(path, triangles):
    lines = ["solid hand"]
    for tri in triangles:
        lines += ["  facet normal 0 0 0", "    outer loop"]
        lines += [f"      vertex {x!r} {y!r} {z!r}" for x, y, z in np.asarray(tri, dtype=float).tolist()]
        lines += ["    endloop", "  endfacet"]
    lines.append("endsolid hand")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


@pytest.mark.parametrize("writer", [binary_stl, ascii_stl])
def test_read_mesh_merges_the_corners_stl_stores_per_triangle_and_keeps_the_face_order(needs_trimesh, tmp_path, writer):
    vertices, faces = mesh.box((0, 0, 0), (1, 2, 3))  # coordinates exact in float32
    triangles = vertices[faces]  # (12, 3, 3): what an STL file holds
    writer(tmp_path / "box.stl", triangles)
    v, f = mesh.read_mesh(tmp_path / "box.stl")
    assert v.shape == (8, 3) and f.shape == (12, 3)  # 36 corners merged into the box's 8
    assert np.array_equal(v[f], triangles)  # triangle k is the file's triangle k, same vertex order
    assert set(edge_uses(f).values()) == {2}  # closed: every edge shared by two triangles
    assert v.dtype == np.float64 and f.dtype == np.int64


def test_ascii_stl_round_trips_to_the_bit_and_binary_to_float32(needs_trimesh, tmp_path):
    rng = np.random.default_rng(1)
    vertices, faces = mesh.square((0.1, 0.2, 0.3), 1 / 3, (1, 2, 3), divisions=3, jitter=0.5, seed=4)
    vertices = vertices + rng.normal(0, 1e-3, vertices.shape)
    mesh.write_stl(tmp_path / "a.stl", vertices, faces, binary=False)
    v, f = mesh.read_mesh(tmp_path / "a.stl")
    assert np.array_equal(v[f], vertices[faces]) and v.shape == vertices.shape
    path = mesh.write_stl(tmp_path / "b.stl", vertices, faces)
    assert path == os.fspath(tmp_path / "b.stl")
    v, f = mesh.read_mesh(path)
    assert np.array_equal(v[f], vertices[faces].astype(np.float32).astype(np.float64))


def test_read_mesh_reads_obj_keeping_its_numbering_and_splitting_quads(needs_trimesh, tmp_path):
    (tmp_path / "m.obj").write_text("# a unit square as a quad, a triangle above it\n"
                                    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\n"
                                    "f 1 2 3 4\nf 1 2 5\n")
    v, f = mesh.read_mesh(tmp_path / "m.obj")
    assert v.tolist() == [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]]
    assert f.shape == (3, 3) and f[-1].tolist() == [0, 1, 4]
    assert sorted(set(f[:2].reshape(-1).tolist())) == [0, 1, 2, 3]


def test_read_mesh_merges_equal_vertices_of_an_obj_file_too(needs_trimesh, tmp_path):
    # Two squares' triangles that repeat the shared corners as rows of their own (and one as
    # -0.0): merged, numbered in the order they first appear, so the squares are neighbours.
    (tmp_path / "split.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\n"
                                        "v 1 0 0\nv 2 0 0\nv 1 1 -0.0\n"
                                        "f 1 2 3\nf 4 5 6\n")
    v, f = mesh.read_mesh(tmp_path / "split.obj")
    assert v.tolist() == [[0, 0, 0], [1, 0, 0], [1, 1, 0], [2, 0, 0]]
    assert f.tolist() == [[0, 1, 2], [1, 3, 2]]
    assert edge_uses(f)[(1, 2)] == 2


def test_read_mesh_scales_the_coordinates(needs_trimesh, tmp_path):
    vertices, faces = mesh.box((0, 0, 0), (10, 20, 30))  # "millimetres"
    mesh.write_stl(tmp_path / "mm.stl", vertices, faces, binary=False)
    v, f = mesh.read_mesh(tmp_path / "mm.stl", scale=1e-3)
    assert np.array_equal(v[f], vertices[faces] * 1e-3)


def test_read_mesh_errors_name_the_path(needs_trimesh, tmp_path):
    with pytest.raises(FileNotFoundError, match=re.escape(repr(str(tmp_path / "none.stl")))):
        mesh.read_mesh(tmp_path / "none.stl")
    (tmp_path / "m.ply").write_text("ply\n")
    with pytest.raises(ValueError, match=r"m\.ply' is neither an STL nor an OBJ file"):
        mesh.read_mesh(tmp_path / "m.ply")
    (tmp_path / "junk.stl").write_text("this is not a mesh\n")
    with pytest.raises(ValueError, match=r"junk\.stl' holds no triangle"):
        mesh.read_mesh(tmp_path / "junk.stl")
    (tmp_path / "empty.obj").write_text("")
    with pytest.raises(ValueError, match=r"empty\.obj' holds no triangle"):
        mesh.read_mesh(tmp_path / "empty.obj")
    (tmp_path / "dir.stl").mkdir()
    with pytest.raises(ValueError, match=r"dir\.stl' is a directory"):
        mesh.read_mesh(tmp_path / "dir.stl")
    # A degenerate triangle (the third of the file): named by the file and its place in it.
    ascii_stl(tmp_path / "flat.stl", [TRIANGLE, TRIANGLE + 1, [[0, 0, 0], [1, 1, 1], [2, 2, 2]]])
    with pytest.raises(ValueError, match=r"flat\.stl' .*faces: triangle 2 .* is degenerate"):
        mesh.read_mesh(tmp_path / "flat.stl")
    # Two corners at one point merge into one vertex: a triangle that repeats it.
    ascii_stl(tmp_path / "pinched.stl", [TRIANGLE, [[0, 0, 5], [0, 0, 5], [1, 0, 5]]])
    with pytest.raises(ValueError, match=r"pinched\.stl' .*triangle 1 .* repeats a vertex index"):
        mesh.read_mesh(tmp_path / "pinched.stl")
    with pytest.raises(ValueError, match="scale must be a finite number > 0"):
        mesh.read_mesh(tmp_path / "m.obj", scale=0)
    with pytest.raises(TypeError, match="scale must be a real number"):
        mesh.read_mesh(tmp_path / "m.obj", scale=True)
    with pytest.raises(TypeError, match="path must be a file path"):
        mesh.read_mesh(3)


def test_without_trimesh_the_error_says_how_to_install_it(tmp_path, monkeypatch):
    ascii_stl(tmp_path / "t.stl", [TRIANGLE])
    monkeypatch.setitem(sys.modules, "trimesh", None)  # makes "import trimesh" raise ImportError
    with pytest.raises(ImportError, match=re.escape("pip install 'tsubu[mesh]'")):
        tsubu.read_mesh(tmp_path / "t.stl")
    with pytest.raises(ImportError, match=re.escape("pip install 'tsubu[mesh]'")):
        mesh.write_stl(tmp_path / "u.stl", TRIANGLE, [[0, 1, 2]])
    assert mesh.box((0, 0, 0), (1, 1, 1))[1].shape == (12, 3)  # the rest needs only numpy


def test_write_stl_checks_the_mesh(tmp_path):
    with pytest.raises(ValueError, match="faces: triangle 0 .* repeats"):
        mesh.write_stl(tmp_path / "x.stl", TRIANGLE, [[0, 1, 1]])
    with pytest.raises(TypeError, match="binary must be True or False"):
        mesh.write_stl(tmp_path / "x.stl", TRIANGLE, [[0, 1, 2]], binary="yes")
    assert not (tmp_path / "x.stl").exists()


# ---- generators ------------------------------------------------------------------------------------

def assert_faces_point_at(vertices, faces, inside):
    """Every triangle's normal (right-hand rule) points toward ``inside(centroid)``."""
    normal, centroid = normals_and_centroids(vertices, faces)
    toward = np.array([inside(c) for c in centroid]) - centroid
    assert np.all(np.einsum("ij,ij->i", normal, toward) > 0)


def test_box_is_closed_and_faces_inward():
    v, f = mesh.box((-1, 0, 2), (1, 3, 5))
    mesh.check_mesh(v, f)
    assert v.shape == (8, 3) and f.shape == (12, 3)
    assert v.min(axis=0).tolist() == [-1, 0, 2] and v.max(axis=0).tolist() == [1, 3, 5]
    assert set(edge_uses(f).values()) == {2}
    assert_faces_point_at(v, f, lambda c: np.array([0.0, 1.5, 3.5]))
    normal, _ = normals_and_centroids(v, f)
    area = 0.5 * np.linalg.norm(normal, axis=1)
    assert np.isclose(area.sum(), 2 * (2 * 3 + 2 * 3 + 3 * 3))
    with pytest.raises(ValueError, match="lo must be below hi"):
        mesh.box((0, 0, 0), (1, 0, 1))


def test_square_is_a_flat_regular_grid_facing_its_normal():
    v, f = mesh.square((1, 2, 3), 2.0, (0, 0, 5), divisions=4)
    mesh.check_mesh(v, f)
    assert v.shape == (25, 3) and f.shape == (32, 3)
    assert np.all(v[:, 2] == 3.0)  # exactly in the plane z = 3
    assert v[:, 0].min() == 0 and v[:, 0].max() == 2 and v[:, 1].min() == 1 and v[:, 1].max() == 3
    normal, _ = normals_and_centroids(v, f)
    assert np.allclose(normal / np.linalg.norm(normal, axis=1)[:, None], (0, 0, 1))
    assert np.isclose(0.5 * np.linalg.norm(normal, axis=1).sum(), 4.0)
    assert v[1].tolist() == [0.5, 1, 3]  # row i + 5 j: grid point (i, j)
    assert [sum(1 for n in edge_uses(f).values() if n == 1)] == [16]  # the outline's 16 edges


def test_square_jitter_makes_an_irregular_tessellation_of_the_same_square():
    regular, faces = mesh.square((0, 0, 0), 1.0, (1, 1, 1), divisions=5)
    v, f = mesh.square((0, 0, 0), 1.0, (1, 1, 1), divisions=5, jitter=0.9, seed=7)
    assert np.array_equal(f, faces)
    moved = np.any(v != regular, axis=1)
    boundary = np.array([i in (0, 5) or j in (0, 5) for j in range(6) for i in range(6)])
    assert moved[~boundary].all() and not moved[boundary].any()  # interior only; outline kept
    n = np.array([1, 1, 1]) / np.sqrt(3)
    assert np.allclose(v @ n, 0, atol=1e-15)  # still in the plane
    normal, _ = normals_and_centroids(v, f)
    h = 1.0 / 5
    assert np.all(normal @ n >= (1 - 0.9) * h * h * (1 - 1e-12))  # oriented, area >= (1-j) h^2/2
    assert np.isclose(0.5 * (normal @ n).sum(), 1.0)  # the same square
    again, _ = mesh.square((0, 0, 0), 1.0, (1, 1, 1), divisions=5, jitter=0.9, seed=7)
    other, _ = mesh.square((0, 0, 0), 1.0, (1, 1, 1), divisions=5, jitter=0.9, seed=8)
    assert np.array_equal(again, v) and not np.array_equal(other, v)


def test_cylinder_is_a_drum_facing_its_axis():
    v, f = mesh.cylinder(0.5, 2.0, 24, axis="x", center=(1, 2, 3))
    mesh.check_mesh(v, f)
    assert v.shape == (48, 3) and f.shape == (48, 3)
    assert np.allclose(np.hypot(v[:, 1] - 2, v[:, 2] - 3), 0.5)
    assert sorted(set(v[:, 0].tolist())) == [0.0, 2.0]
    assert_faces_point_at(v, f, lambda c: np.array([c[0], 2.0, 3.0]))
    assert set(edge_uses(f).values()) == {1, 2}  # open at both ends
    v, f = mesh.cylinder(0.5, 2.0, 24, caps=True)
    mesh.check_mesh(v, f)
    assert v.shape == (50, 3) and f.shape == (96, 3)
    assert set(edge_uses(f).values()) == {2}  # closed
    assert_faces_point_at(v, f, lambda c: np.zeros(3))


def test_cone_is_a_hopper_open_at_both_ends_facing_its_axis():
    v, f = mesh.cone(top_radius=1.0, bottom_radius=0.1, height=1.5, segments=16, bottom=(0, 0, 0.2))
    mesh.check_mesh(v, f)
    assert v.shape == (32, 3) and f.shape == (32, 3)
    assert np.allclose(np.hypot(v[:16, 0], v[:16, 1]), 0.1) and np.all(v[:16, 2] == 0.2)
    assert np.allclose(np.hypot(v[16:, 0], v[16:, 1]), 1.0) and np.allclose(v[16:, 2], 1.7)
    assert_faces_point_at(v, f, lambda c: np.array([0.0, 0.0, c[2]]))
    assert sum(1 for n in edge_uses(f).values() if n == 1) == 32  # two open rims


def test_wedge_hopper_has_its_orifice_and_faces_inward():
    v, f = mesh.wedge_hopper(orifice_width=0.02, top_width=0.2, height=0.15, depth=0.05,
                             bottom=(0, 0, 0.1))
    mesh.check_mesh(v, f)
    assert v.shape == (8, 3) and f.shape == (8, 3)
    low = v[v[:, 2] == 0.1]
    assert np.isclose(np.ptp(low[:, 0]), 0.02) and np.isclose(np.ptp(low[:, 1]), 0.05)
    high = v[np.isclose(v[:, 2], 0.25)]
    assert np.isclose(np.ptp(high[:, 0]), 0.2)
    assert_faces_point_at(v, f, lambda c: np.array([0.0, 0.0, 0.175]))
    plate = v[[0, 4]]  # a plate's lower and upper edge at y = -depth/2
    half_angle = np.degrees(np.arctan2(abs(plate[1, 0] - plate[0, 0]), plate[1, 2] - plate[0, 2]))
    assert np.isclose(half_angle, np.degrees(np.arctan((0.2 - 0.02) / (2 * 0.15))))
    with pytest.raises(ValueError, match="top_width must be >= orifice_width"):
        mesh.wedge_hopper(0.2, 0.1, 0.1, 0.1)


@pytest.mark.parametrize("call, error, message", [
    (lambda: mesh.square((0, 0, 0), 1, (0, 0, 0), 2), ValueError, "normal must not be zero"),
    (lambda: mesh.square((0, 0, 0), 1, (0, 0, 1), 0), ValueError, "divisions must be >= 1"),
    (lambda: mesh.square((0, 0, 0), 1, (0, 0, 1), 2.0), TypeError, "divisions must be an integer"),
    (lambda: mesh.square((0, 0, 0), 1, (0, 0, 1), 2, jitter=1.0), ValueError, r"jitter must be in \[0, 1\)"),
    (lambda: mesh.square((0, 0, 0), -1, (0, 0, 1), 2), ValueError, "size must be a finite number > 0"),
    (lambda: mesh.cylinder(1, 1, 2), ValueError, "segments must be >= 3"),
    (lambda: mesh.cylinder(1, 1, 8, axis="w"), ValueError, "axis must be 'x', 'y' or 'z'"),
    (lambda: mesh.cylinder(1, 1, 8, caps=1), TypeError, "caps must be True or False"),
    (lambda: mesh.cylinder(np.nan, 1, 8), ValueError, "radius must be a finite number > 0"),
    (lambda: mesh.cone(1, 0, 1, 8), ValueError, "bottom_radius must be a finite number > 0"),
    (lambda: mesh.cone(1, 1, 1, True), TypeError, "segments must be an integer"),
    (lambda: mesh.box((0, 0), (1, 1, 1)), ValueError, "lo must have 3 components"),
    (lambda: mesh.wedge_hopper(0.1, 0.2, 0.1, 0.0), ValueError, "depth must be a finite number > 0"),
])
def test_generators_refuse_bad_arguments(call, error, message):
    with pytest.raises(error, match=message):
        call()


# ---- VTK output ------------------------------------------------------------------------------------

class WithMeshWalls:
    """A Simulation seen through the walls API of issue 27 (``wall_count``, ``wall(k)``), with
    mesh walls after its planes that translate with ``velocity`` and turn about z with
    ``angular_velocity`` about ``center`` as ``sim.time`` goes on: a stand-in for
    ``Simulation.add_mesh`` to test the writers against."""

    def __init__(self, sim, meshes):
        self._sim = sim
        self.meshes = meshes  # dicts: vertices, faces, material, velocity, spin (rad/s about z), center

    def __getattr__(self, name):
        return getattr(self._sim, name)

    def run(self, *args, output=None, **kwargs):
        """The Simulation's run, its hooks handed this view instead of the Simulation."""
        hooks = [] if output is None else output if isinstance(output, (list, tuple)) else [output]
        return self._sim.run(*args, output=[_Through(h, self) for h in hooks], **kwargs)

    @property
    def wall_count(self):
        return self._sim.plane_count + len(self.meshes)

    def wall(self, k):
        planes = self._sim.plane_count
        if k < planes:
            return dict(self._sim.plane(k), kind="plane", center=self._sim.plane(k)["point"],
                        removed=False)
        m = self.meshes[k - planes]
        t = self._sim.time
        c, s = np.cos(m["spin"] * t), np.sin(m["spin"] * t)
        turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        center = np.asarray(m["center"], dtype=float) + t * np.asarray(m["velocity"])
        return {"kind": "mesh", "vertices": center + (m["vertices"] - m["center"]) @ turn.T,
                "faces": m["faces"], "material": m["material"], "center": center,
                "velocity": np.asarray(m["velocity"], dtype=float),
                "angular_velocity": np.array([0.0, 0.0, m["spin"]]), "removed": m.get("removed", False)}


class _Through:
    """A run hook called with a given view of the Simulation."""

    def __init__(self, hook, view):
        self.hook, self.view = hook, view

    def next_step(self, sim):
        return self.hook.next_step(self.view)

    def act(self, sim):
        self.hook.act(self.view)

    def close(self, sim):
        self.hook.close(self.view)


def scene_with_meshes():
    sim = tsubu.Simulation(dt=1e-5, gravity=(0, 0, -9.81))
    glass = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, name="glass")
    steel = tsubu.Material(density=7800.0, kn=1e3, restitution=0.5, name="steel")
    sim.add_spheres([(0, 0, 2e-3), (3e-3, 0, 2e-3)], 1e-3, glass)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=steel)
    drum_v, drum_f = mesh.cylinder(0.02, 0.01, 12)  # turning about its axis, z
    box_v, box_f = mesh.box((-0.01, -0.01, 0), (0.01, 0.01, 0.02))
    return WithMeshWalls(sim, [
        {"vertices": drum_v, "faces": drum_f, "material": steel, "velocity": (0, 0, 0),
         "spin": 30.0, "center": (0, 0, 0)},
        {"vertices": box_v, "faces": box_f, "material": glass, "velocity": (0.5, 0, 0),
         "spin": 0.0, "center": (0, 0, 0.01)},
    ])


def vtk_readers():
    pytest.importorskip("pyevtk")
    sys.path.insert(0, os.path.dirname(__file__))
    try:
        from test_output import read_pvd, read_vtk
    finally:
        sys.path.pop(0)
    return read_vtk, read_pvd


def test_mesh_data_gives_each_mesh_wall_where_it_is_now():
    sim = scene_with_meshes()
    sim.run(steps=20)
    data = output.mesh_data(sim)
    assert [d["wall"] for d in data] == [1, 2]  # after the plane (wall 0)
    assert [d["material"] for d in data] == [1, 0]  # steel was added second, by the plane
    for d in data:
        wall = sim.wall(d["wall"])
        assert np.array_equal(d["vertices"], wall["vertices"])
        assert np.array_equal(d["faces"], wall["faces"])
        assert np.allclose(np.linalg.norm(d["normal"], axis=1), 1.0)
        expected = wall["velocity"] + np.cross(wall["angular_velocity"], wall["vertices"] - wall["center"])
        assert np.array_equal(d["vertex_velocity"], expected)
    sim.meshes[0]["removed"] = True
    assert [d["wall"] for d in output.mesh_data(sim)] == [2]


def test_each_mesh_wall_gets_a_vtp_with_its_current_triangles(tmp_path):
    read_vtk, _ = vtk_readers()
    sim = scene_with_meshes()
    sim.run(steps=30)
    written = output.write_vtk(sim, tmp_path, name="f")
    assert set(written) == {"particles", "contacts", "walls", "meshes"}
    assert written["meshes"] == {1: str(tmp_path / "f_mesh1_30.vtp"), 2: str(tmp_path / "f_mesh2_30.vtp")}
    for d in output.mesh_data(sim):
        f = read_vtk(written["meshes"][d["wall"]])
        assert f["kind"] == "PolyData"
        assert np.array_equal(f["points"], d["vertices"])  # to the bit
        assert np.array_equal(f["polys"]["connectivity"].reshape(-1, 3), d["faces"])
        assert f["polys"]["offsets"].tolist() == list(range(3, 3 * len(d["faces"]) + 1, 3))
        assert np.array_equal(f["point"]["velocity"], d["vertex_velocity"])
        assert np.array_equal(f["cell"]["normal"], d["normal"])
        assert set(f["cell"]["wall"].tolist()) == {d["wall"]}
        assert set(f["cell"]["material"].tolist()) == {d["material"]}
        assert f["cell"]["triangle"].tolist() == list(range(len(d["faces"])))
        assert f["field"]["TimeValue"].tolist() == [sim.time] and f["field"]["step"].tolist() == [30]
    # The plane's rectangle covers the meshes too (the drum reaches x = +-2 cm).
    corners = read_vtk(written["walls"])["points"]
    assert corners[:, 0].min() < -0.02 and corners[:, 0].max() > 0.02
    assert output.write_vtk(sim, tmp_path / "no_walls", walls=False).keys() == {"particles", "contacts"}


def test_the_walls_series_lists_the_moving_meshes_and_drops_a_removed_one(tmp_path):
    read_vtk, _ = vtk_readers()
    import xml.etree.ElementTree as ET

    sim = scene_with_meshes()
    hook = output.VTKOutput(tmp_path, every=10, contacts=False)
    sim.run(steps=20, output=hook)  # frames 0, 10, 20
    sim.meshes[1]["removed"] = True
    sim.run(steps=10, output=hook)  # frame 30: the drum only
    entries = [(float(d.get("timestep")), d.get("part"), d.get("file"))
               for d in ET.parse(tmp_path / "particles_walls.pvd").getroot().iter("DataSet")]
    times = sorted({t for t, _, _ in entries})
    assert len(times) == 4
    assert [(p, f) for t, p, f in entries if t == times[2]] == [
        ("0", "particles_walls_20.vtp"), ("2", "particles_mesh1_20.vtp"), ("3", "particles_mesh2_20.vtp")]
    assert [(p, f) for t, p, f in entries if t == times[3]] == [
        ("0", "particles_walls_30.vtp"), ("2", "particles_mesh1_30.vtp")]
    assert not (tmp_path / "particles_mesh2_30.vtp").exists()
    # The drum turns: its vertices differ from frame to frame, each frame where the wall was.
    first, last = (read_vtk(tmp_path / f"particles_mesh1_{s}.vtp")["points"] for s in (0, 30))
    assert not np.allclose(first, last)
    assert np.allclose(np.hypot(last[:, 0], last[:, 1]), 0.02)
    # A hook resumed into the same directory keeps the earlier frames' parts.
    again = output.VTKOutput(tmp_path, every=10, contacts=False)
    sim.run(steps=10, output=again)  # frame 40
    resumed = [(d.get("part"), d.get("file"))
               for d in ET.parse(tmp_path / "particles_walls.pvd").getroot().iter("DataSet")]
    assert len(resumed) == len(entries) + 2
    assert resumed[:len(entries)] == [(p, f) for _, p, f in entries]

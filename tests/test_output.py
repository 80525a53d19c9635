"""tsubu.output: VTK XML files read back and compared with the Simulation bit for bit, the .pvd
series across runs, the walls' rectangles, the contact network, and the npz / CSV dumps."""

import os
import re
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import tsubu
from tsubu import output

pytest.importorskip("pyevtk")


# ---- a reader of VTK XML files with raw appended data (what pyevtk writes) ---------------------

_VTK_TYPES = {"Float64": "f8", "Float32": "f4", "Int64": "i8", "Int32": "i4", "UInt8": "u1",
              "UInt64": "u8", "Int8": "i1", "UInt32": "u4"}


def read_vtk(path):
    """{'kind', 'piece' (attributes), 'points', 'cells' / 'lines' / 'polys' (dicts of arrays),
    'point', 'cell', 'field' (dicts of arrays)} of one VTK XML file, read independently of the
    writer: the XML header with ElementTree, each appended block by its offset and UInt64 size."""
    with open(path, "rb") as f:
        raw = f.read()
    start = raw.index(b"<AppendedData")
    data = raw.index(b"_", start) + 1
    root = ET.fromstring(raw[:start] + b"</VTKFile>")
    assert root.get("header_type") == "UInt64"
    order = "<" if root.get("byte_order") == "LittleEndian" else ">"

    def array(element):
        assert element.get("format") == "appended"
        at = data + int(element.get("offset"))
        size = int(np.frombuffer(raw[at:at + 8], dtype=order + "u8")[0])
        values = np.frombuffer(raw[at + 8:at + 8 + size], dtype=order + _VTK_TYPES[element.get("type")])
        components = int(element.get("NumberOfComponents", "1"))
        return values.reshape(-1, 3) if components == 3 else values

    def arrays(element):
        return {} if element is None else {a.get("Name"): array(a) for a in element.findall("DataArray")}

    grid = root[0]
    piece = grid.find("Piece")
    result = {"kind": root.get("type"), "piece": dict(piece.attrib),
              "field": arrays(grid.find("FieldData")),
              "point": arrays(piece.find("PointData")), "cell": arrays(piece.find("CellData"))}
    result["points"] = arrays(piece.find("Points"))["points"].reshape(-1, 3)
    for element in ("Cells", "Lines", "Polys"):
        if piece.find(element) is not None:
            result[element.lower()] = arrays(piece.find(element))
    return result


def read_pvd(path):
    """[(timestep, file)] of a .pvd collection."""
    return [(float(d.get("timestep")), d.get("file")) for d in ET.parse(path).getroot().iter("DataSet")]


def text(path):
    with open(path) as f:
        return f.read()


def binary(path):
    with open(path, "rb") as f:
        return f.read()


def same(a, b):
    """Equal to the bit (dtype, shape and every value)."""
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


# ---- scenes -------------------------------------------------------------------------------------

SETTLE = 8400  # steps until the spheres lean on all three walls


def settled_scene():
    """Spheres of two materials and two sizes resting on a floor, against a tilted wall and a
    wall moving (and turning) slowly: pair and wall contacts with friction, 40 spheres.
    The first 400 steps have no contact (the spheres start touching and part)."""
    glass = tsubu.Material(density=2500.0, kn=2e3, restitution=0.5, friction=0.4, name="glass")
    steel = tsubu.Material(density=7800.0, kn=2e3, restitution=0.6, friction=0.3, name="steel")
    sim = tsubu.Simulation(gravity=(-3.0, 2.0, -9.81))
    rng = np.random.default_rng(5)
    grid = np.stack(np.meshgrid(np.arange(4), np.arange(5), np.arange(2), indexing="ij"), -1).reshape(-1, 3)
    x = (grid * 1.995e-3 + 0.998e-3) + rng.uniform(-2e-6, 2e-6, grid.shape)  # touching
    r = np.where(np.arange(len(x)) % 3 == 0, 0.9e-3, 1.0e-3)
    sim.add_spheres(x[::2], r[::2], glass, velocities=rng.normal(0, 0.02, (len(x[::2]), 3)))
    sim.add_spheres(x[1::2], r[1::2], steel)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=steel)
    sim.add_plane(point=(-0.2e-3, 0, 0), normal=(1, 0, 0.2), material=glass)
    sim.add_plane(point=(0, 10.5e-3, 0), normal=(0, -1, 0), material=glass,
                  velocity=(0, -1e-4, 0), angular_velocity=(0.01, 0, 0))
    sim.run(steps=SETTLE)
    return sim


@pytest.fixture(scope="module")
def scene():
    return settled_scene()


# ---- particles ---------------------------------------------------------------------------------

def test_particle_file_holds_the_simulation_arrays_to_the_bit(scene, tmp_path):
    written = output.write_vtk(scene, tmp_path)
    assert written["particles"] == os.path.join(tmp_path, f"particles_{scene.step_count}.vtu")
    f = read_vtk(written["particles"])
    n = scene.size
    assert f["kind"] == "UnstructuredGrid" and f["piece"]["NumberOfPoints"] == str(n)
    assert same(f["points"], scene.positions)
    assert same(f["cells"]["types"], np.full(n, 1, np.uint8))  # VTK_VERTEX
    assert same(f["cells"]["connectivity"], np.arange(n)) and same(f["cells"]["offsets"], np.arange(1, n + 1))
    p = f["point"]
    assert same(p["id"], np.arange(n, dtype=np.int64))
    assert same(p["velocity"], scene.velocities)
    assert same(p["angular_velocity"], scene.angular_velocities)
    assert same(p["radius"], scene.radii) and same(p["mass"], scene.masses)
    assert same(p["material"], scene.material_ids)
    assert [scene.materials[k].name for k in p["material"][[0, -1]]] == ["glass", "steel"]
    assert same(p["force"], scene.forces) and same(p["torque"], scene.torques)
    assert same(f["field"]["TimeValue"], np.array([scene.time]))
    assert same(f["field"]["step"], np.array([scene.step_count], dtype=np.int64))


def test_coordination_counts_each_contact_for_both_spheres_and_walls_for_one(scene, tmp_path):
    contacts = scene.contacts()
    pairs, walls = contacts["j"] >= 0, contacts["j"] < 0
    assert pairs.sum() > 10 and walls.sum() > 3  # the scene has both kinds
    expected = np.zeros(scene.size, dtype=np.int64)
    for i, j in zip(contacts["i"], contacts["j"]):
        expected[i] += 1
        if j >= 0:
            expected[j] += 1
    f = read_vtk(output.write_vtk(scene, tmp_path, contacts=False, walls=False)["particles"])
    assert same(f["point"]["coordination"], expected)
    assert expected.max() >= 3


# ---- contact network ---------------------------------------------------------------------------

def test_contact_lines_carry_the_contacts_forces(scene, tmp_path):
    f = read_vtk(output.write_vtk(scene, tmp_path)["contacts"])
    contacts, x = scene.contacts(), scene.positions
    m = len(contacts["i"])
    assert f["kind"] == "PolyData" and f["piece"]["NumberOfLines"] == str(m)
    c = f["cell"]
    for key in ("i", "j", "wall"):
        assert same(c[key], contacts[key].astype(np.int64))
    assert same(c["overlap"], contacts["overlap"]) and same(c["force"], contacts["force"])
    lines = f["points"][f["lines"]["connectivity"]].reshape(m, 2, 3)
    assert same(f["lines"]["offsets"], np.arange(2, 2 * m + 1, 2))
    assert same(lines[:, 0], x[contacts["i"]])
    pairs, walls = contacts["j"] >= 0, contacts["j"] < 0
    assert same(lines[pairs, 1], x[contacts["j"][pairs]])
    n = c["normal"]
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, rtol=0, atol=1e-12)
    scale = np.abs(contacts["force"]).max()
    # F = F_n + F_t with F_t perpendicular to n, F_n along n; compressive contacts push i away.
    assert np.allclose(c["normal_force_vector"] + c["tangential_force"], contacts["force"], rtol=0, atol=1e-12 * scale)
    assert np.allclose(np.einsum("ij,ij->i", c["tangential_force"], n), 0, rtol=0, atol=1e-12 * scale)
    assert np.allclose(np.cross(c["normal_force_vector"], n), 0, rtol=0, atol=1e-12 * scale)
    assert same(c["normal_force"], -np.einsum("ij,ij->i", contacts["force"], n))
    assert np.abs(c["tangential_force"]).max() > 0  # friction is acting somewhere
    assert np.median(c["normal_force"]) > 0
    for k in np.flatnonzero(walls):  # a wall contact ends on its plane, along its normal
        plane = scene.plane(int(contacts["wall"][k]))
        end = lines[k, 1]
        assert abs((end - plane["point"]) @ plane["normal"]) < 1e-15
        assert np.allclose(n[k], -plane["normal"], rtol=0, atol=1e-12)
        # The overlap is that of the last force evaluation, the line's ends the current state:
        # they differ by the step's drift.
        drift = 2 * scene.dt * np.abs(scene.velocities).max()
        assert np.isclose(np.linalg.norm(end - lines[k, 0]), scene.radii[contacts["i"][k]] - contacts["overlap"][k],
                          rtol=0, atol=drift)


def test_centres_at_one_point_give_a_zero_normal_not_nan():
    class Fake:
        positions = np.zeros((2, 3))
        size = 2

        def plane(self, k):
            raise AssertionError

    fake = {"i": np.array([0]), "j": np.array([1]), "wall": np.array([-1]), "overlap": np.array([1e-3]),
            "force": np.array([[0.0, 0.0, 1.0]])}
    data = output.contact_data(Fake(), fake)
    assert same(data["normal"], np.zeros((1, 3))) and same(data["tangential_force"], fake["force"])


# ---- walls -------------------------------------------------------------------------------------

def _in_plane_coordinates(corners, points):
    """(u, v) of points in the rectangle's edge frame, and the rectangle's extent in it."""
    u = corners[1] - corners[0]
    v = corners[3] - corners[0]
    uu, vv = u / np.linalg.norm(u), v / np.linalg.norm(v)
    return (points - corners[0]) @ uu, (points - corners[0]) @ vv, np.linalg.norm(u), np.linalg.norm(v)


def test_wall_rectangles_lie_in_their_planes_and_cover_the_spheres(scene, tmp_path):
    f = read_vtk(output.write_vtk(scene, tmp_path)["walls"])
    count = scene._core.plane_count
    assert f["piece"]["NumberOfPolys"] == str(count)
    assert same(f["polys"]["offsets"], np.arange(4, 4 * count + 1, 4))
    quads = f["points"][f["polys"]["connectivity"]].reshape(count, 4, 3)
    x, r = scene.positions, scene.radii
    size = np.ptp(x, axis=0).max()
    for k in range(count):
        plane, corners = scene.plane(k), quads[k]
        assert np.allclose((corners - plane["point"]) @ plane["normal"], 0, rtol=0, atol=1e-15)
        u, v = corners[1] - corners[0], corners[3] - corners[0]
        assert abs(u @ v) < 1e-12 * size * size  # a rectangle
        assert np.allclose(corners[2], corners[0] + u + v, rtol=0, atol=1e-15)
        assert np.cross(u, v) @ plane["normal"] > 0  # counter-clockwise seen from the spheres' side
        a, b, lu, lv = _in_plane_coordinates(corners, x)
        assert np.all((a >= r) & (a <= lu - r) & (b >= r) & (b <= lv - r))  # every sphere's shadow inside
        assert max(lu, lv) < 10 * size  # clipped to the scene, not a huge sheet
        assert f["cell"]["wall"][k] == k
        assert scene.materials[f["cell"]["material"][k]] is plane["material"]
        for key in ("normal", "point", "velocity", "angular_velocity"):
            assert same(f["cell"][key][k], plane[key])
        expected = plane["velocity"] + np.cross(plane["angular_velocity"], corners - plane["point"])
        assert np.allclose(f["point"]["velocity"][4 * k:4 * k + 4], expected, rtol=1e-12, atol=0)


def test_a_given_extent_sets_an_axis_aligned_walls_rectangle(scene, tmp_path):
    lower, upper = (-0.01, -0.02, -0.03), (0.04, 0.05, 0.06)
    f = read_vtk(output.write_vtk(scene, tmp_path, contacts=False, extent=(lower, upper))["walls"])
    floor = f["points"][:4]
    assert same(floor[:, 2], np.zeros(4))
    assert (floor[:, 0].min(), floor[:, 0].max(), floor[:, 1].min(), floor[:, 1].max()) == (-0.01, 0.04, -0.02, 0.05)
    with pytest.raises(ValueError, match="extent: lower must be <= upper"):
        output.write_vtk(scene, tmp_path, extent=(upper, lower))
    with pytest.raises(ValueError, match="extent must be"):
        output.VTKOutput(tmp_path, 1, extent=((0, 0), (1, 1)))


# ---- the hook and its .pvd series --------------------------------------------------------------

def periodic_cell():
    """Eight spheres in a box periodic along x and y (z: open, its corners only a volume)."""
    glass = tsubu.Material(density=2500.0, kn=2e3, restitution=0.5, friction=0.4, name="glass")
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    x = np.array([[i, j, 1.0] for i in (1.5, 4.5) for j in (1.5, 4.5)] * 2) * 1e-3
    x[4:, 2] = 4e-3
    sim.add_spheres(x, np.full(8, 1e-3), glass, velocities=np.tile([0.5, 0.2, 0.0], (8, 1)))
    sim.set_box((0, 0, 0), (6e-3, 6e-3, 5e-3), periodic="xy")
    return sim


def test_a_periodic_box_is_drawn_as_its_outline(tmp_path):
    sim = periodic_cell()
    hook = output.VTKOutput(tmp_path, every=50)
    sim.run(steps=100, output=[hook])
    assert [f for _, f in read_pvd(tmp_path / "particles_box.pvd")] == [
        f"particles_box_{s}.vtp" for s in (0, 50, 100)]
    outline = read_vtk(tmp_path / "particles_box_100.vtp")
    corners = outline["points"]
    assert sorted(map(tuple, corners.tolist())) == sorted(
        (x, y, z) for x in (0, 6e-3) for y in (0, 6e-3) for z in (0, 5e-3))
    assert same(outline["lines"]["offsets"], np.arange(2, 25, 2, dtype=np.int64))
    ends = corners[outline["lines"]["connectivity"].reshape(12, 2)]
    along = ends[:, 1] - ends[:, 0]
    axis = outline["cell"]["axis"]
    assert sorted(axis.tolist()) == [0] * 4 + [1] * 4 + [2] * 4
    assert np.all(along[np.arange(12), axis] == np.array([6e-3, 6e-3, 5e-3])[axis])  # each edge along its axis
    assert np.count_nonzero(along) == 12
    assert same(outline["cell"]["periodic"], (axis < 2).astype(np.int64))  # x and y periodic, z open
    # without the walls, or in an open scene, no outline
    output.write_vtk(sim, tmp_path / "none", walls=False)
    sim.set_box((0, 0, 0), (6e-3, 6e-3, 5e-3), periodic="")
    assert "box" not in output.write_vtk(sim, tmp_path / "open")
    assert not [f for d in ("none", "open") for f in os.listdir(tmp_path / d) if "_box" in f]


def test_frames_every_k_steps_across_two_runs_none_twice(tmp_path):
    sim = settled_scene()
    hook = output.VTKOutput(tmp_path, every=25)
    acted, act = [], hook.act
    hook.act = lambda s: (acted.append(s.step_count), act(s))
    times = {}
    start = sim.step_count  # 8400
    sim.run(steps=60, output=[hook])
    times.update({sim.step_count: sim.time})
    sim.run(steps=40, output=[hook])  # both runs contain step 8460; no frame there: 8400, 8425, 8450, 8475, 8500
    assert acted == [8400, 8425, 8450, 8475, 8500]
    assert hook.next_step(sim) == 8525
    expected_times = {}
    probe = settled_scene()
    for step in acted:
        probe.run(steps=step - probe.step_count)
        expected_times[step] = probe.time
    for series, ext in (("particles", "vtu"), ("particles_contacts", "vtp"), ("particles_walls", "vtp")):
        entries = read_pvd(tmp_path / f"{series}.pvd")
        assert entries == [(expected_times[s], f"{series}_{s}.{ext}") for s in acted]
        for time, file in entries:
            assert same(read_vtk(tmp_path / file)["field"]["TimeValue"], np.array([time]))
    final = read_vtk(tmp_path / "particles_8500.vtu")
    assert same(final["points"], sim.positions)
    assert not [f for f in os.listdir(tmp_path) if f.startswith(".")]  # no temporary file left
    assert start == 8400


def test_the_pvd_is_valid_after_every_frame(tmp_path):
    sim = settled_scene()
    hook = output.VTKOutput(tmp_path, every=10, contacts=False, walls=False)
    seen = []
    for _ in range(3):
        sim.run(steps=10, output=[hook])
        seen.append(read_pvd(tmp_path / "particles.pvd"))
    assert [len(s) for s in seen] == [2, 3, 4]  # a killed run would leave the frames so far
    assert sorted(os.listdir(tmp_path)) == ["particles.pvd"] + [f"particles_{s}.vtu" for s in (8400, 8410, 8420, 8430)]


def test_a_run_resumed_from_a_checkpoint_continues_the_series(tmp_path):
    sim = settled_scene()
    hook = output.VTKOutput(tmp_path, every=20, walls=False)
    sim.run(steps=20, output=hook)  # 8400, 8420
    sim.save(tmp_path / "run.tsubu")
    sim.run(steps=40, output=hook)  # 8440, 8460
    first = {s: binary(tmp_path / f"particles_{s}.vtu") for s in (8420, 8440)}
    resumed = tsubu.Simulation.load(tmp_path / "run.tsubu")  # as after a crash at step 8460
    resumed.run(steps=20, output=output.VTKOutput(tmp_path, every=20, walls=False))  # 8420, 8440
    for series in ("particles", "particles_contacts"):
        files = [file for _, file in read_pvd(tmp_path / f"{series}.pvd")]
        assert [int(re.findall(r"_(\d+)\.", f)[0]) for f in files] == [8400, 8420, 8440]
    for step, content in first.items():  # the continued run writes the same frames, bit for bit
        assert binary(tmp_path / f"particles_{step}.vtu") == content


def test_a_hook_on_a_simulation_that_went_back_writes_again(tmp_path):
    sim = settled_scene()
    hook = output.VTKOutput(tmp_path, every=10, contacts=False, walls=False)
    sim.run(steps=20, output=[hook])
    earlier = settled_scene()
    assert hook.next_step(earlier) == 8400  # step 8400 of another Simulation: due again
    assert hook.next_step(sim) == 8430


def two_beads() -> tsubu.Simulation:
    sim = tsubu.Simulation(dt=1e-5)
    bead = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5)
    sim.add_spheres([(0, 0, 1e-3), (0, 0, 4e-3)], 1e-3, bead)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=bead)
    return sim


@pytest.mark.parametrize("writer, index", [(output.VTKOutput, "particles.pvd"),
                                           (output.CSVOutput, "state_frames.csv")])
def test_a_second_simulation_does_not_silently_replace_the_first_ones_series(tmp_path, writer, index):
    """Two Simulations of one process writing into one directory under one name: the second,
    whose first frame would replace every frame of the first, is refused before it writes
    anything, with a message naming the directory and what to do (issue 26)."""
    first = two_beads()
    first.run(steps=30, output=writer(tmp_path, every=10))
    files = {f: binary(tmp_path / f) for f in os.listdir(tmp_path)}
    second = two_beads()
    with pytest.raises(FileExistsError, match=re.escape(f"the directory {str(tmp_path)!r} already "
                                                        f"holds a series {index} of 4 frames")) as info:
        second.run(steps=30, output=writer(tmp_path, every=10))
    assert "its own directory or name=" in str(info.value)
    assert info.value.filename == str(tmp_path / index)
    assert second.step_count == 0
    assert {f: binary(tmp_path / f) for f in os.listdir(tmp_path)} == files  # untouched
    second.run(steps=30, output=writer(tmp_path / "second", every=10))  # its own directory: fine
    second.run(steps=10, output=writer(tmp_path, every=10, name="second"))  # its own name: fine
    first.run(steps=10, output=writer(tmp_path, every=10))  # the first goes on with its series
    del first  # even once the first is gone, its frames are not replaced
    with pytest.raises(FileExistsError):
        two_beads().run(steps=10, output=writer(tmp_path, every=10))


def test_bad_arguments_are_refused(tmp_path):
    with pytest.raises(ValueError, match="every must be >= 1"):
        output.VTKOutput(tmp_path, every=0)
    with pytest.raises(TypeError, match="every must be a whole number"):
        output.NpzOutput(tmp_path, every=2.5)
    with pytest.raises(TypeError, match="every must be a whole number"):
        output.CSVOutput(tmp_path, every=True)
    with pytest.raises(ValueError, match="name must be a file-name stem.*'../x'"):
        output.VTKOutput(tmp_path, every=1, name="../x")


def test_without_pyevtk_the_error_says_how_to_install_it(tmp_path, monkeypatch, scene):
    monkeypatch.setitem(sys.modules, "pyevtk", None)  # makes "import pyevtk" raise ImportError
    monkeypatch.delitem(sys.modules, "pyevtk.vtk", raising=False)
    with pytest.raises(ImportError, match=re.escape("pip install 'tsubu[vtk]'")):
        output.VTKOutput(tmp_path, every=1)
    with pytest.raises(ImportError, match=re.escape("pip install 'tsubu[vtk]'")):
        output.write_vtk(scene, tmp_path)
    output.save_npz(scene, tmp_path / "still.npz")  # the dumps need only numpy


def test_an_empty_scene_writes_empty_valid_files(tmp_path):
    sim = tsubu.Simulation()
    written = output.write_vtk(sim, tmp_path)
    assert read_vtk(written["particles"])["points"].shape == (0, 3)
    assert read_vtk(written["contacts"])["cell"]["i"].shape == (0,)
    assert read_vtk(written["walls"])["piece"]["NumberOfPolys"] == "0"


# ---- npz and CSV -------------------------------------------------------------------------------

def test_npz_round_trips_exactly(scene, tmp_path):
    path = output.save_npz(scene, tmp_path / "sub" / "frame.npz")
    with np.load(path) as f:  # allow_pickle stays False: plain arrays only
        data = dict(f)
    particles = output.particle_data(scene)
    for key, value in particles.items():
        assert same(data[key], value), key
    for key, value in output.contact_data(scene).items():
        assert same(data[f"contact_{key}"], value), key
    assert same(data["contact_force"], scene.contacts()["force"])
    assert data["step"] == scene.step_count and same(data["time"], np.array(scene.time))
    assert list(data["material_names"]) == ["glass", "steel"]


def test_csv_round_trips_exactly_at_repr_precision(scene, tmp_path):
    path = output.save_csv(scene, tmp_path / "frame.csv", contacts_path=tmp_path / "contacts.csv")
    header = text(path).splitlines()[0].split(",")
    assert header[:5] == ["id", "position_x", "position_y", "position_z", "velocity_x"]
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    columns = dict(zip(header, table.T))
    particles = output.particle_data(scene)
    for key, value in particles.items():
        if value.ndim == 1:
            assert same(columns[key].astype(value.dtype), value), key
        else:
            assert same(np.stack([columns[f"{key}_{a}"] for a in "xyz"], 1), value), key
    row = text(path).splitlines()[1].split(",")
    assert row[1] == repr(float(scene.positions[0, 0]))  # shortest round-trip text
    contact_header = text(tmp_path / "contacts.csv").splitlines()[0].split(",")
    contact_table = dict(zip(contact_header, np.loadtxt(tmp_path / "contacts.csv", delimiter=",", skiprows=1).T))
    raw = scene.contacts()
    assert same(np.stack([contact_table[f"force_{a}"] for a in "xyz"], 1), raw["force"])
    assert same(contact_table["overlap"], raw["overlap"])
    assert same(contact_table["j"].astype(np.int64), raw["j"].astype(np.int64))


def test_npz_and_csv_hooks_write_their_frames(tmp_path):
    sim = settled_scene()
    npz = output.NpzOutput(tmp_path / "npz", every=30)
    table = output.CSVOutput(tmp_path / "csv", every=45)
    sim.run(steps=50, output=[npz, table])
    sim.run(steps=50, output=[npz, table])
    assert sorted(os.listdir(tmp_path / "npz")) == [f"state_{s}.npz" for s in (8400, 8430, 8460, 8490)]
    with np.load(tmp_path / "npz" / "state_8490.npz") as f:
        assert same(f["position"], settled_scene().run(steps=90).positions)
    index = text(tmp_path / "csv" / "state_frames.csv").splitlines()
    assert index[0] == "step,time,file"
    assert [line.split(",")[0] for line in index[1:]] == ["8415", "8460"]
    assert float(index[-1].split(",")[1]) == settled_scene().run(steps=60).time
    assert sorted(os.listdir(tmp_path / "csv")) == sorted(
        ["state_frames.csv"] + [f"state_{s}.csv" for s in (8415, 8460)]
        + [f"state_contacts_{s}.csv" for s in (8415, 8460)])


def test_the_same_state_gives_the_same_vtk_bytes(scene, tmp_path):
    # No time stamps, names of temporary files or dict orders leak into the files.
    for copy in ("a", "b"):
        output.write_vtk(scene, tmp_path / copy)
    assert sorted(os.listdir(tmp_path / "a")) == sorted(os.listdir(tmp_path / "b"))
    for file in os.listdir(tmp_path / "a"):
        assert binary(tmp_path / "a" / file) == binary(tmp_path / "b" / file), file


def test_vtk_itself_reads_the_files(scene, tmp_path):
    vtk = pytest.importorskip("vtk")
    from vtk.util.numpy_support import vtk_to_numpy

    written = output.write_vtk(scene, tmp_path)
    for kind, reader in (("particles", vtk.vtkXMLUnstructuredGridReader), ("contacts", vtk.vtkXMLPolyDataReader),
                         ("walls", vtk.vtkXMLPolyDataReader)):
        r = reader()
        r.SetFileName(written[kind])
        r.Update()
        data = r.GetOutput()
        mine = read_vtk(written[kind])
        assert same(vtk_to_numpy(data.GetPoints().GetData()), mine["points"])
        assert data.GetNumberOfCells() == len(next(iter(mine["cell"].values()), mine["points"]))
        arrays = data.GetPointData() if kind == "particles" else data.GetCellData()
        for name, values in (mine["point"] if kind == "particles" else mine["cell"]).items():
            assert same(vtk_to_numpy(arrays.GetArray(name)), values), name
        assert vtk_to_numpy(data.GetFieldData().GetArray("TimeValue"))[0] == scene.time

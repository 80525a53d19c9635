"""Scene files' periodic box ([box], [box.shear], [box.pressure]; docs/scene-format.md,
docs/periodic.md): what the table builds (the same bits as the Python API's calls), its errors,
the schema, the example scene, and runs resumed from a checkpoint of a periodic scene."""

import json
import math
import pathlib
import shutil

import numpy as np
import pytest

import tsubu
from tsubu import fill, scene
from tsubu.__main__ import main

from test_scene import changed  # (a deep copy with one key set or removed)

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
EXAMPLE = ROOT / "examples" / "scenes" / "periodic_shear.toml"

L = 0.006  # the lattice's region [m]: 3 x 3 x 3 touching spheres 2 mm across
S = 0.00599  # the cell's side [m]: the spheres overlap their images by 10 um


def cell():
    """A small sheared, pressure-controlled periodic cell: 27 spheres on a touching lattice, in a
    box a little shorter so that they overlap their images across the faces (a squeezed pack
    that the pressure control lets expand), moving along x so that the shear acts at once."""
    return {
        "simulation": {"duration": 0.004, "gravity": [0, 0, 0], "dt_fraction": 0.02, "threads": 1},
        "materials": {"glass": {"density": 2500.0, "kn": 1000.0, "restitution": 0.5, "friction": 0.5}},
        "particles": [{"generator": "lattice", "material": "glass", "radius": 1e-3,
                       "region": {"shape": "box", "lower": [0, 0, 0], "upper": [L, L, L]},
                       "velocity": [0.3, 0, 0]}],
        "box": {"lower": [0, 0, 0], "upper": [S, S, S], "periodic": "xyz",
                "shear": {"rate": 20.0, "flow": "x", "gradient": "z"},
                "pressure": {"pressure": 50.0, "gain": 1e-3, "axis": "z", "max_strain_rate": 5.0}},
    }


def by_hand(data):
    """cell() written with the Python API."""
    glass = tsubu.Material(density=2500.0, kn=1000.0, restitution=0.5, friction=0.5, name="glass")
    sim = tsubu.Simulation(gravity=(0, 0, 0), threads=1)
    block = data["particles"][0]
    packing = fill.lattice(fill.Box(block["region"]["lower"], block["region"]["upper"]),
                                 block["radius"])
    sim.add_spheres(packing.positions, packing.radii, glass,
                    velocities=np.tile(block["velocity"], (len(packing.radii), 1)))
    box = data["box"]
    sim.set_box(box["lower"], box["upper"], periodic=box["periodic"])
    sim.set_shear(**box["shear"])
    sim.set_pressure(**box["pressure"])
    sim.dt = 0.02 * sim.contact_duration()
    return sim


def errors_of(data):
    with pytest.raises(scene.SceneError) as info:
        scene.scene_from_dict(data)
    return info.value.lines()


def same_state(a, b):
    for name in ("positions", "velocities", "angular_velocities", "images", "unwrapped_positions"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert box_fields(a.box) == box_fields(b.box)


def box_fields(box):
    """A Box's fields, comparable with == (the corners as lists of floats)."""
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in vars(box).items()}


# ---- what [box] builds ---------------------------------------------------------------------

def test_the_box_table_builds_what_the_api_calls_build():
    data = cell()
    built = scene.scene_from_dict(data)
    sim, hand = built.simulation, by_hand(data)
    box = sim.box
    assert (box.periodic, box.flow, box.gradient, box.shear_rate) == ("xyz", "x", "z", 20.0)
    assert (box.pressure, box.pressure_axis) == (50.0, "z")
    assert sim.size == hand.size == 27 and sim.dt == hand.dt
    built.run(progress=False)
    hand.run(steps=sim.step_count)
    assert sim.step_count == round(0.004 / sim.dt) > 0
    same_state(sim, hand)
    # the run did what a periodic, sheared, controlled box does
    assert sim.box.upper[2] != S and sim.box.shear_offset != 0 and np.any(sim.images != 0)
    assert len(sim.contacts()["i"]) > 0


def test_defaults_are_the_apis():
    data = cell()
    data["box"] = {"lower": [0, 0, 0], "upper": [L, L, L], "shear": {"rate": -3.0},
                   "pressure": {"pressure": 50.0, "gain": 1e-3}}
    sim = scene.scene_from_dict(data).simulation
    hand = by_hand(cell())
    hand.set_box([0, 0, 0], [L, L, L])
    hand.set_shear(-3.0)
    hand.set_pressure(50.0, 1e-3)  # the cap: 0.01 / the contact duration of the spheres
    assert box_fields(sim.box) == box_fields(hand.box)
    sim.run(steps=50)
    hand.run(steps=50)
    same_state(sim, hand)


def test_a_box_along_some_axes_leaves_the_others_open():
    data = cell()
    data["box"] = {"lower": [0, 0, 0], "upper": [L, L, 0], "periodic": "xy"}  # z: only the volume
    sim = scene.scene_from_dict(data).simulation
    assert sim.box.periodic == "xy" and sim.box.pressure is None and sim.box.flow is None


def test_a_scene_without_a_box_is_open():
    data = cell()
    del data["box"]
    assert scene.scene_from_dict(data).simulation.box is None


# ---- bad values ----------------------------------------------------------------------------

BAD = [
    (("box", "lower"), scene.MISSING, "box.lower: required key missing (Lower corner)"),
    (("box", "upper"), [L, L], "box.upper = [0.006, 0.006]: must be an array of 3 numbers [m]"),
    (("box", "upper"), [L, L, -1.0],
     "box.upper = [0.006, 0.006, -1.0]: must be above lower ([0.0, 0.0, 0.0]) along the periodic axis z"),
    (("box", "periodic"), "zx",
     'box.periodic = "zx": must be "xyz", "xy", "xz", "yz", "x", "y" or "z" (the same letters in this order: "xz")'),
    (("box", "periodic"), "xyy", 'box.periodic = "xyy": must be "xyz", "xy", "xz", "yz", "x", "y" or "z" (did you mean "xy"?)'),
    (("box", "periodic"), "", 'box.periodic = "": must be "xyz", "xy", "xz", "yz", "x", "y" or "z"'),
    (("box", "shear", "gradient"), "x", 'box.shear.gradient = "x": must differ from the flow axis (x)'),
    (("box", "shear", "gradient"), "w", 'box.shear.gradient = "w": must be "x", "y" or "z"'),
    (("box", "shear", "rate"), math.nan, "box.shear.rate = nan: must be finite"),
    (("box", "shear", "rate"), scene.MISSING, "box.shear.rate: required key missing (Shear rate (any sign): "
                                              "the images across the gradient faces slide along the flow at "
                                              "rate times the box's gradient length)"),
    (("box", "shear", "rat"), 1.0, "box.shear.rat = 1.0: unknown key; allowed: rate, flow, gradient "
                                   "(did you mean rate?)"),
    (("box", "pressure", "pressure"), -5.0, "box.pressure.pressure = -5.0: must be a finite number > 0"),
    (("box", "pressure", "gain"), 0, "box.pressure.gain = 0: must be a finite number > 0"),
    (("box", "pressure", "max_strain_rate"), "fast", 'box.pressure.max_strain_rate = "fast": must be a number [1/s]'),
    (("box", "extent"), 1.0, "box.extent = 1.0: unknown key; allowed: lower, upper, periodic, shear, pressure"),
    (("box",), [0, 0, 0], "box = [0, 0, 0]: must be a table"),
]


@pytest.mark.parametrize("path, value, message", BAD, ids=[m.split(":")[0] + f" {i}" for i, (_, _, m) in enumerate(BAD)])
def test_a_bad_box_value_is_reported_with_its_path_and_value(path, value, message):
    assert errors_of(changed(cell(), path, value)) == [message]


def test_the_shear_axes_and_the_pressure_axis_must_be_periodic():
    assert errors_of(changed(cell(), ("box", "periodic"), "xy")) == [
        'box.shear.gradient = "z": the box is not periodic along z (box.periodic = "xy"): name a periodic '
        "axis, or add z to box.periodic",
        'box.pressure.axis = "z": the box is not periodic along z (box.periodic = "xy"): name a periodic '
        "axis, or add z to box.periodic"]
    data = changed(cell(), ("box", "periodic"), "xz")
    data["box"]["pressure"]["axis"] = "y"
    assert errors_of(data) == ['box.pressure.axis = "y": the box is not periodic along y (box.periodic = '
                               '"xz"): name a periodic axis, or add y to box.periodic']
    data = changed(cell(), ("box", "shear"), {"rate": 1.0, "flow": "z"})  # gradient: its default, z
    assert errors_of(data) == ['box.shear.flow = "z": must differ from the gradient axis (z, gradient\'s default)']


def test_the_pressure_caps_default_needs_spheres():
    data = cell()
    del data["particles"], data["box"]["pressure"]["max_strain_rate"]
    data["simulation"]["dt"] = 1e-6
    del data["simulation"]["dt_fraction"]
    assert errors_of(data) == ["box.pressure.max_strain_rate: required when the scene has no particles blocks "
                               "(the default is 0.01 / the contact duration of their spheres)"]
    data["box"]["pressure"]["max_strain_rate"] = 5.0
    assert scene.scene_from_dict(data).simulation.box.pressure == 50.0


def test_a_box_smaller_than_twice_the_reach_cannot_start(tmp_path, capsys):
    path = tmp_path / "small.toml"
    shutil.copy(EXAMPLE, path)
    path.write_text(path.read_text().replace("upper = [0.008, 0.008, 0.008]\nperiodic",
                                             "upper = [0.008, 0.008, 0.002]\nperiodic"))
    assert main(["run", str(path), "--no-progress", "--output", str(tmp_path / "out")]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"tsubu: error: {path}: the scene cannot start: box: the periodic length along z ")


# ---- the schema and the example ------------------------------------------------------------

def test_the_schema_accepts_the_example_and_the_cell_and_refuses_bad_values():
    jsonschema = pytest.importorskip("jsonschema")
    validator = jsonschema.Draft202012Validator(json.loads((DOCS / "scene.schema.json").read_text()))
    example = scene.read_toml(EXAMPLE)
    assert "box" in example and "shear" in example["box"]
    assert list(validator.iter_errors(example)) == []
    assert list(validator.iter_errors(cell())) == []
    for path, value, message in BAD:
        if "periodic along" in message or "must differ" in message or "must be above" in message:
            continue  # rules between keys: the loader's, not the schema's
        if value is not scene.MISSING and isinstance(value, float) and math.isnan(value):
            continue  # JSON has no NaN
        assert not validator.is_valid(changed(cell(), path, value)), message


def test_the_example_runs_a_sheared_periodic_gas(tmp_path):
    built = scene.load_scene(EXAMPLE, output_directory=tmp_path)
    sim = built.simulation
    assert 250 < sim.size < 300 and sim.box.periodic == "xyz" and sim.box.shear_rate == 10.0
    built.run(until=0.01, progress=False)
    assert np.all((sim.positions >= -1e-3) & (sim.positions <= 0.009))  # wrapped into the box
    assert sim.box.shear_offset == pytest.approx(10.0 * 0.008 * sim.time)


# ---- checkpoints and resume ----------------------------------------------------------------

def test_resume_of_a_periodic_scene_continues_bit_for_bit(tmp_path):
    data = cell()
    data["checkpoint"] = {"every": 40}
    whole = scene.scene_from_dict(data, output_directory=tmp_path / "whole")
    whole.run(progress=False)
    half = scene.scene_from_dict(data, output_directory=tmp_path / "half")
    half.run(until=0.002, progress=False)
    resumed = scene.resume(tmp_path / "half" / "checkpoint.tsubu")
    assert box_fields(resumed.simulation.box) == box_fields(half.simulation.box)  # the checkpoint kept the box
    resumed.run(progress=False)
    assert resumed.simulation.step_count == whole.simulation.step_count
    same_state(resumed.simulation, whole.simulation)


def test_tsubu_resume_continues_the_example(tmp_path, capsys):
    path = tmp_path / "periodic_shear.toml"
    shutil.copy(EXAMPLE, path)
    path.write_text(path.read_text().replace("duration = 0.1 ", "duration = 0.004"))
    assert main(["run", str(path), "--no-progress", "--threads", "1"]) == 0
    checkpoint = tmp_path / "output" / "checkpoint.tsubu"
    assert main(["resume", str(checkpoint), "--time", "0.004", "--no-progress"]) == 0
    resumed = tsubu.Simulation.load(checkpoint)
    whole = scene.load_scene(path, threads=1, output_directory=tmp_path / "whole")
    whole.run(until=resumed.time, progress=False)
    assert resumed.step_count == whole.simulation.step_count
    same_state(resumed, whole.simulation)
    assert "tsubu resume" in capsys.readouterr().out


# ---- output --------------------------------------------------------------------------------

def test_npz_frames_hold_the_box_and_the_images(tmp_path):
    data = cell()
    data["output"] = {"npz": {"every": 100}}
    built = scene.scene_from_dict(data, output_directory=tmp_path)
    sim = built.simulation
    sim.dt = 0.004 / 800  # 800 steps: the last frame is the end's
    built.run(progress=False)
    assert sim.step_count == 800
    with np.load(tmp_path / "state_800.npz") as f:
        frame = dict(f)
    box = sim.box
    assert np.array_equal(frame["box_lower"], box.lower) and np.array_equal(frame["box_upper"], box.upper)
    assert str(frame["box_periodic"]) == "xyz" and frame["box_upper"][2] != S  # the controlled height
    assert frame["box_shear_offset"] == box.shear_offset and frame["box_shear_rate"] == 20.0
    assert frame["image"].dtype == np.int64 and np.array_equal(frame["image"], sim.images)
    assert np.any(frame["image"] != 0)
    assert np.array_equal(frame["unwrapped_position"], sim.unwrapped_positions)
    assert np.array_equal(frame["position"], sim.positions)
    del data["box"]
    open_scene = scene.scene_from_dict(data, output_directory=tmp_path / "open")
    open_scene.simulation.dt = 0.004 / 800
    open_scene.run(until=0.0005, progress=False)
    with np.load(tmp_path / "open" / "state_0.npz") as f:
        assert not [k for k in f.files if k.startswith("box_") or k in ("image", "unwrapped_position")]


def test_vtk_output_draws_the_box(tmp_path):
    pytest.importorskip("pyevtk")
    data = cell()
    data["output"] = {"vtk": {"every": 400, "contacts": False}}
    built = scene.scene_from_dict(data, output_directory=tmp_path)
    built.simulation.dt = 0.004 / 800
    built.run(progress=False)
    assert {f for f in (tmp_path).iterdir() if "_box" in f.name} == {
        tmp_path / "particles_box.pvd", *(tmp_path / f"particles_box_{s}.vtp" for s in (0, 400, 800))}


def test_the_box_example_in_the_docs_is_valid():
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    page = (DOCS / "scene-format.md").read_text(encoding="utf-8")
    block = page.split("## Periodic boxes", 1)[1].split("```toml\n", 1)[1].split("```", 1)[0]
    data = {**cell(), **tomllib.loads(block)}
    assert set(data["box"]) == {"lower", "upper", "periodic", "shear", "pressure"}
    scene.validate(data)
    jsonschema = pytest.importorskip("jsonschema")
    assert jsonschema.Draft202012Validator(json.loads((DOCS / "scene.schema.json").read_text())).is_valid(data)

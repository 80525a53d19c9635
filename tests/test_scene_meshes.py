"""Mesh walls and wall motion schedules in scene files (docs/scene-format.md): [[meshes]] from a
generator or an STL file, named walls, [[walls.schedule]] / [[meshes.schedule]] / [[schedule]]
entries (jumps, ramps, removals) that a run applies at whole steps, bit for bit as a Python
script that makes the same changes between runs, through checkpoints, and the errors of bad
meshes and schedules."""

import copy
import textwrap

import numpy as np
import pytest

import tsubu
from tsubu import scene
from tsubu.scene.builder import wall_schedule

DT = 1e-4


def materials():
    return {"grain": {"density": 2500.0, "kn": 2000.0, "restitution": 0.5, "friction": 0.5},
            "steel": {"density": 7800.0, "kn": 2000.0, "restitution": 0.5, "friction": 0.3}}


BLOCK = {"generator": "lattice", "material": "grain", "radius": 2e-3,
         "region": {"shape": "box", "lower": [-0.004, -0.004, -0.0196], "upper": [0.004, 0.004, -0.0116]}}


def drum_scene(duration=0.02, **extra):
    """A capped drum (cylinder mesh along y, radius 2 cm) with 8 grains in its lower half that
    spins up about y by a ramp from rest to 20 rad/s over 0.01 s in 4 segments, then reverses
    at t = 0.015 s."""
    data = {
        "simulation": {"duration": duration, "dt": DT, "gravity": [0, 0, -9.81]},
        "materials": materials(),
        "meshes": [{"generator": "cylinder", "name": "drum", "radius": 0.02, "length": 0.01,
                    "segments": 24, "axis": "y", "caps": True, "material": "steel",
                    "schedule": [{"at": 0.0, "angular_velocity": [0, 20, 0], "ramp": 0.01, "segments": 4},
                                 {"at": 0.015, "angular_velocity": [0, -10, 0]}]}],
        "particles": [copy.deepcopy(BLOCK)],
    }
    data.update(extra)
    return data


def drum_script():
    """The drum scene written as a Python script: the same Simulation, run in pieces with the
    motion changed between them at the steps docs/scene-format.md gives (ramp from step 0 to
    round(0.01 / dt) = 100 in 4 segments of 25 steps, each at the linear ramp's value at its
    middle; the reversal at step 150)."""
    grain, steel = (tsubu.Material(name=n, **m) for n, m in materials().items())
    sim = tsubu.Simulation(gravity=(0, 0, -9.81))
    sim.dt = DT
    drum = sim.add_mesh(*tsubu.mesh.cylinder(0.02, 0.01, 24, axis="y", caps=True), material=steel,
                        center=(0, 0, 0))
    region = BLOCK["region"]
    packing = tsubu.fill.lattice(tsubu.fill.Box(lower=region["lower"], upper=region["upper"]), 2e-3)
    sim.add_spheres(packing.positions, packing.radii, grain)
    for start, stop, omega in ((0, 25, 2.5), (25, 50, 7.5), (50, 75, 12.5), (75, 100, 17.5),
                               (100, 150, 20.0), (150, 200, -10.0)):
        sim.set_wall_motion(drum, angular_velocity=(0, omega, 0))
        sim.run(steps=stop - start)
    return sim


def state(sim):
    return [np.array(a) for a in (sim.positions, sim.velocities, sim.angular_velocities)]


def assert_same_bits(a, b):
    for x, y in zip(state(a), state(b)):
        assert x.tobytes() == y.tobytes()


def test_a_drum_that_spins_up_by_schedule_gives_the_bits_of_the_script(tmp_path):
    run = scene.scene_from_dict(drum_scene(), tmp_path)
    assert run.simulation.wall(0)["kind"] == "mesh"
    sim = run.run(progress=False)
    assert sim.step_count == 200
    assert list(sim.wall(0)["angular_velocity"]) == [0, -10, 0]
    script = drum_script()
    assert_same_bits(sim, script)
    # the drum did drive the grains (they are not at rest where gravity alone leaves them)
    assert np.abs(script.angular_velocities[:, 1]).max() > 1


def test_the_schedule_becomes_whole_steps_and_ramp_segments():
    changes = wall_schedule(scene.validate(drum_scene()), DT)
    assert [(step, wall, change["angular_velocity"][1]) for step, wall, change in changes] == [
        (0, 0, 2.5), (25, 0, 7.5), (50, 0, 12.5), (75, 0, 17.5), (100, 0, 20.0), (150, 0, -10.0)]
    # times round to the nearest step; a ramp shorter than its segments has one per step;
    # a ramp starts from the value before it (the block's own velocity)
    data = drum_scene()
    data["meshes"][0]["velocity"] = [1.0, 0, 0]
    data["meshes"][0]["schedule"] = [{"at": 0.00104, "velocity": [3.0, 0, 0], "ramp": 0.0002},
                                     {"at": 0.00236, "remove": True}]
    changes = wall_schedule(scene.validate(data), DT)
    assert [(step, change) for step, _, change in changes] == [
        (10, {"velocity": (1.5, 0.0, 0.0)}), (11, {"velocity": (2.5, 0.0, 0.0)}),
        (12, {"velocity": (3.0, 0.0, 0.0)}), (24, {"remove": True})]


GATE_TOML = """
    # a column held by a gate at x = 8 mm that a schedule removes at t = 0.005 s (step 50),
    # pressed on it by gravity along x (a steep channel)
    [simulation]
    duration = 0.03
    dt = 1e-4
    gravity = [20, 0, -9.81]

    [materials.grain]
    density = 2500.0
    kn = 2000.0
    restitution = 0.5
    friction = 0.5

    [[walls]]
    point = [0, 0, 0]
    normal = [0, 0, 1]
    material = "grain"

    [[walls]]
    name = "gate"
    point = [0.008, 0, 0]
    normal = [-1, 0, 0]
    material = "grain"

    [[walls.schedule]]
    at = 0.00504
    remove = true

    [[particles]]
    generator = "lattice"
    material = "grain"
    radius = 2e-3
    region = { shape = "box", lower = [0, 0, 0], upper = [0.008, 0.004, 0.016] }
"""


def test_a_gate_removed_by_schedule_opens_at_its_step(tmp_path):
    (tmp_path / "gate.toml").write_text(textwrap.dedent(GATE_TOML))
    run = scene.load_scene(tmp_path / "gate.toml", output_directory=tmp_path / "out")
    sim = run.simulation
    run.run(until=0.0049, progress=False)  # step 49: the grains press on the gate
    assert not sim.wall(1)["removed"] and sim.wall_forces()[1][0] > 0
    run.run(progress=False)
    assert sim.wall(1)["removed"] and sim.step_count == 300
    assert sim.positions[:, 0].max() > 0.008 + 2e-3  # grains went through the gate's place
    # the same as a script that removes the gate between runs at step round(0.00504 / dt) = 50
    data = scene.read_toml(tmp_path / "gate.toml")
    del data["walls"][1]["schedule"]
    script = scene.scene_from_dict(data, tmp_path).simulation
    script.run(steps=50)
    script.remove_wall(1)
    script.run(steps=250)
    assert_same_bits(sim, script)


def test_a_top_level_schedule_moves_named_walls_together():
    data = drum_scene()
    del data["meshes"][0]["schedule"]
    data["walls"] = [{"name": "lid", "point": [0, 0, 0.015], "normal": [0, 0, -1], "material": "steel",
                      "center": [0, 0, 0]}]
    data["schedule"] = [{"walls": ["lid", "drum"], "at": 0.001, "angular_velocity": [0, 3, 0]},
                        {"wall": "lid", "at": 0.002, "remove": True}]
    run = scene.scene_from_dict(data)
    assert [(s, w, c) for s, w, c in run.schedule.changes] == [
        (10, 0, {"angular_velocity": (0.0, 3.0, 0.0)}), (10, 1, {"angular_velocity": (0.0, 3.0, 0.0)}),
        (20, 0, {"remove": True})]
    run.run(until=0.003, progress=False)
    assert run.simulation.wall(0)["removed"] and list(run.simulation.wall(1)["angular_velocity"]) == [0, 3, 0]
    assert list(run.simulation.wall(0)["center"]) == [0, 0, 0]


def test_resuming_mid_schedule_applies_only_the_changes_to_come(tmp_path):
    # checkpoints every 50 steps: steps 50 and 100 are also ramp changes, made before the
    # checkpoint is written there (the resumed run must not make them again, nor miss them)
    data = drum_scene(checkpoint={"every": 50, "keep": 10})
    whole = scene.scene_from_dict(data, tmp_path, output_directory=tmp_path / "a").run(progress=False)
    scene.scene_from_dict(data, tmp_path, output_directory=tmp_path / "b").run(progress=False)
    for step in (50, 100):
        resumed = scene.resume(tmp_path / "b" / f"checkpoint.step{step:012d}.tsubu")
        assert resumed.simulation.step_count == step
        assert all(s > step for s, _, _ in resumed.schedule.changes)
        assert_same_bits(resumed.run(progress=False), whole)


@pytest.fixture
def needs_trimesh():
    pytest.importorskip("trimesh")


def ascii_stl(vertices, faces) -> str:
    lines = ["solid floor"]
    for f in faces:
        lines += ["facet normal 0 0 0", "outer loop"]
        lines += [f"vertex {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in vertices[f]]
        lines += ["endloop", "endfacet"]
    return "\n".join(lines + ["endsolid floor"]) + "\n"


def test_an_stl_mesh_scene_reads_the_file_beside_it_scaled(needs_trimesh, tmp_path):
    # a floor of 8 triangles, drawn in millimetres, under a sphere that falls on it
    vertices, faces = tsubu.mesh.square((0, 0, 0), 40.0, (0, 0, 1), 2)
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "floor.stl").write_text(ascii_stl(vertices, faces))
    data = {"simulation": {"duration": 0.05, "dt": DT, "gravity": [0, 0, -9.81]},
            "materials": materials(),
            "meshes": [{"file": "meshes/floor.stl", "scale": 1e-3, "material": "steel"}],
            "particles": [{"generator": "lattice", "material": "grain", "radius": 2e-3,
                           "region": {"shape": "box", "lower": [-0.002, -0.002, 0.0021],
                                      "upper": [0.002, 0.002, 0.0061]}}]}
    run = scene.scene_from_dict(data, tmp_path)
    wall = run.simulation.wall(0)
    assert np.array_equal(wall["vertices"][wall["faces"]], vertices[faces] * 1e-3)
    sim = run.run(progress=False)
    # the mesh stopped the sphere (it bounces on it): without it, it would fall 12 mm
    assert sim.positions[0, 2] > 0.0019 and sim.velocities[0, 2] != -9.81 * 0.05


def errors(data, directory="."):
    with pytest.raises(scene.SceneError) as info:
        scene.scene_from_dict(data, directory)
    return info.value.lines()


def with_schedule(*entries, top=()):
    data = drum_scene()
    data["meshes"][0]["schedule"] = list(entries)
    if top:
        data["schedule"] = list(top)
    return data


@pytest.mark.parametrize("data, message", [
    (with_schedule(top=[{"at": 0.1, "remove": True}]),
     'schedule[0]: give exactly one of "wall" or "walls"'),
    (with_schedule(top=[{"wall": "drun", "at": 0.1, "remove": True}]),
     'schedule[0].wall = "drun": no such wall; named walls: drum (did you mean "drum"?)'),
    (with_schedule({"at": -0.1, "remove": True}),
     "meshes[0].schedule[0].at = -0.1: must be a finite number >= 0"),
    (with_schedule({"at": 0.1}),
     "meshes[0].schedule[0]: the entry changes nothing: give velocity, angular_velocity, center or "
     "remove = true"),
    (with_schedule({"at": 0.1, "remove": False}),
     "meshes[0].schedule[0].remove = false: remove = false changes nothing: leave it out, or give "
     "remove = true to remove the wall"),
    (with_schedule({"at": 0.1, "remove": True, "velocity": [1, 0, 0]}),
     "meshes[0].schedule[0]: a removal comes alone: remove = true with velocity (a removed wall does "
     "not move): give those in another entry"),
    (with_schedule({"at": 0.1, "center": [0, 0, 0], "ramp": 0.1}),
     "meshes[0].schedule[0].ramp = 0.1: a ramp needs a velocity or angular_velocity to reach"),
    (with_schedule({"at": 0.1, "velocity": [0, 0, 1], "segments": 4}),
     "meshes[0].schedule[0].segments = 4: segments divide a ramp: give ramp too (or leave segments out)"),
    (with_schedule({"at": 0.0, "angular_velocity": [0, 1, 0], "ramp": 0.5},
                   {"at": 0.2, "angular_velocity": [0, 2, 0]}),
     'meshes[0].schedule[1].angular_velocity = [0.0, 2.0, 0.0]: changes meshes[0] ("drum")\'s angular_velocity '
     "at t = 0.2 s, within the ramp of meshes[0].schedule[0] (from t = 0.0 to 0.5 s): start it when "
     "the ramp ends"),
    (with_schedule({"at": 0.1, "remove": True}, {"at": 0.2, "velocity": [1, 0, 0]}),
     'meshes[0].schedule[1].at = 0.2: meshes[0] ("drum") is removed at t = 0.1 s '
     "(meshes[0].schedule[0]): nothing changes it after that"),
    (with_schedule({"at": 0.1, "velocity": [1, 0, 0]}, top=[{"wall": "drum", "at": 0.1, "remove": True}]),
     'schedule[0].at = 0.1: meshes[0] ("drum") already has a schedule entry at t = 0.1 s '
     "(meshes[0].schedule[0]): give one entry per wall and time"),
    (with_schedule({"at": 0.1, "velocity": [3e8, 0, 0]}),
     "meshes[0].schedule[0].velocity = [300000000.0, 0.0, 0.0]: must be at most the speed of light, "
     "2.99792e+08 m/s, in magnitude: no wall of a Newtonian scene moves faster, and far beyond it the "
     "contact forces overflow doubles (check the units)"),
    (drum_scene(walls=[{"name": "drum", "point": [0, 0, -0.03], "normal": [0, 0, 1], "material": "steel"}]),
     'meshes[0].name = "drum": another wall has this name (walls[0]): names must be unique among walls '
     "and meshes"),
])
def test_bad_schedules_are_refused_naming_the_entry(data, message):
    assert errors(data) == [message]


def mesh_scene(mesh):
    return {"simulation": {"duration": 0.01, "dt": DT}, "materials": materials(),
            "meshes": [{"material": "steel", **mesh}]}


@pytest.mark.parametrize("mesh, message", [
    ({"generator": "sphere", "radius": 0.1},
     'meshes[0].generator = "sphere": must be "box", "square", "cylinder", "cone" or "wedge_hopper"'),
    ({"generator": "cylinder", "radius": 0.1, "length": 0.1, "segments": 2},
     "meshes[0].segments = 2: must be >= 3"),
    ({"generator": "cylinder", "radius": 0.1, "length": 0.1},
     "meshes[0].segments: required key missing (Flat faces around)"),
    ({"generator": "cone", "top_radius": 0.1, "bottom_radius": 0.05, "height": 0.1, "segments": 8,
      "radius": 0.1},
     "meshes[0].radius = 0.1: unknown key; allowed: top_radius, bottom_radius, height, segments, axis, "
     "bottom, material, velocity, angular_velocity, center, name, schedule (did you mean top_radius?)"),
    ({"generator": "wedge_hopper", "orifice_width": 0.02, "top_width": 0.01, "height": 0.1, "depth": 0.05},
     "meshes[0].top_width = 0.01: must be >= orifice_width (0.02)"),
    ({"generator": "box", "lo": [0, 0, 0], "hi": [1, 1, 1], "file": "box.stl"},
     'meshes[0]: give exactly one of "file" or "generator", not "file" and "generator"'),
    ({"velocity": [1, 0, 0]}, 'meshes[0]: give exactly one of "file" or "generator"'),
    ({"file": "missing.stl"}, 'meshes[0].file = "missing.stl": no such file'),
    ({"generator": "box", "lo": [0, 0, 0], "hi": [1, 1, 1], "material": "stell"},
     'meshes[0].material = "stell": no such material; defined: grain, steel (did you mean "steel"?)'),
])
def test_bad_meshes_are_refused_naming_the_key(mesh, message, tmp_path):
    lines = errors(mesh_scene(mesh), tmp_path)
    assert len(lines) == 1 and lines[0].startswith(message)


@pytest.mark.parametrize("name, text, message", [
    ("hopper.ply", "ply\n", 'meshes[0].file = "hopper.ply": is neither an STL nor an OBJ file'),
    ("hopper.stl", "garbage\n", 'meshes[0].file = "hopper.stl": holds no triangle'),
])
def test_a_mesh_file_that_is_not_a_mesh_is_refused_at_its_key(name, text, message, tmp_path):
    if name.endswith(".stl"):
        pytest.importorskip("trimesh")
    (tmp_path / name).write_text(text)
    lines = errors(mesh_scene({"file": name}), tmp_path)
    assert len(lines) == 1 and lines[0].startswith(message)

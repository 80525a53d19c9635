"""Scene files (tsubu.scene): the spec's checks and messages, the generated schema and reference,
what a scene builds, and scenes that use tsubu.fill, tsubu.insert, tsubu.output and checkpoints."""

import copy
import inspect
import json
import math
import os
import pathlib
import re
import sys

import numpy as np
import pytest

import tsubu
from tsubu import scene

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCENES = pathlib.Path(__file__).resolve().parent / "scenes"
DOCS = ROOT / "docs"


def read(name):
    with open(SCENES / name, "rb") as f:
        return tomllib.load(f)


def errors_of(data):
    """The error lines (without a source) that validating and building ``data`` gives."""
    with pytest.raises(scene.SceneError) as info:
        scene.scene_from_dict(data, SCENES)
    return info.value.lines()


def changed(data, path, value):
    """A deep copy of ``data`` with the key at ``path`` (a tuple of keys and indices) set to
    ``value`` (or removed, for scene.MISSING)."""
    data = copy.deepcopy(data)
    where = data
    for key in path[:-1]:
        where = where[key]
    if value is scene.MISSING:
        del where[path[-1]]
    else:
        where[path[-1]] = value
    return data


# ---- the generated documents are up to date --------------------------------------------------

def test_schema_file_is_generated_from_the_spec():
    assert (DOCS / "scene.schema.json").read_text(encoding="utf-8") == scene.schema_text(), (
        "docs/scene.schema.json is out of date: run python -m tsubu.scene write-docs docs")


def test_reference_in_the_docs_is_generated_from_the_spec():
    page = (DOCS / "scene-format.md").read_text(encoding="utf-8")
    assert scene.with_reference(page) == page, (
        "docs/scene-format.md's reference is out of date: run python -m tsubu.scene write-docs docs")
    for key in scene.SPEC.fields["simulation"].node.fields:  # every key is documented
        assert f"| `{key}` |" in page


# ---- messages with paths -----------------------------------------------------------------------

BAD_VALUES = [
    (("materials", "glass", "restitution"), 1.5, "materials.glass.restitution = 1.5: must be in (0, 1]"),
    (("materials", "glass", "density"), "heavy", 'materials.glass.density = "heavy": must be a number [kg/m^3]'),
    (("materials", "glass", "friction"), -0.1, "materials.glass.friction = -0.1: must be a finite number >= 0"),
    (("materials", "glass", "roughness"), 90, "materials.glass.roughness = 90: must be in [0, 90)"),
    (("materials", "glass", "shadow"), "rejct",
     'materials.glass.shadow = "rejct": must be "reject", "weighted" or "none" (did you mean "reject"?)'),
    (("materials", "glass", "frition"), 0.3,
     "materials.glass.frition = 0.3: unknown key; allowed: density, kn, kt, youngs_modulus, poisson_ratio, "
     "restitution, friction, rolling_friction, tangential_damping, roughness, work_of_adhesion, "
     "roughness_distribution, shadow (did you mean friction?)"),
    (("simulation", "duration"), scene.MISSING, "simulation.duration: required key missing (Simulated time to run)"),
    (("simulation", "duration"), -1.0, "simulation.duration = -1.0: must be a finite number >= 0"),
    (("simulation", "gravity"), [0, -9.81], "simulation.gravity = [0, -9.81]: must be an array of 3 numbers [m/s^2]"),
    (("simulation", "gravity"), [0, 0, math.inf], "simulation.gravity = [0, 0, inf]: must be finite"),
    (("simulation", "threads"), 0, "simulation.threads = 0: must be >= 1"),
    (("simulation", "threads"), 1.5, "simulation.threads = 1.5: must be an integer"),
    (("simulation", "allow_unstable_dt"), 1, "simulation.allow_unstable_dt = 1: must be true or false"),
    (("simulation", "dt"), 1e-6, 'simulation: give only one of "dt" and "dt_fraction"'),
    (("walls", 0, "normal"), [0, 0, 0], "walls[0].normal = [0, 0, 0]: must not be zero"),
    (("walls", 0, "material"), "glas",
     'walls[0].material = "glas": no such material; defined: glass, steel (did you mean "glass"?)'),
    (("walls", 0, "point"), scene.MISSING, "walls[0].point: required key missing (A point of the plane (and the centre of its rotation))"),
    (("walls", 1), "floor", 'walls[1] = "floor": must be a table'),
    (("pairs", 0, "materials"), ["glass", "rock"],
     'pairs[0].materials[1] = "rock": no such material; defined: glass, steel'),
    (("particles", 0, "generator"), "latice",
     'particles[0].generator = "latice": must be "lattice", "random_packing" or "file" (did you mean "lattice"?)'),
    (("particles", 0, "velocities"), "yes", 'particles[0].velocities = "yes": must be true or false'),
    (("output",), {"vtk": {"every": 10, "interval": 0.1}},
     'output.vtk: give exactly one of "every" or "interval", not "every" and "interval"'),
    (("output",), {"npz": {"every": 0}}, "output.npz.every = 0: must be >= 1"),
    (("checkpoint",), {"keep": 2, "evry": 10},
     "checkpoint.evry = 10: unknown key; allowed: path, every, interval, keep (did you mean every?)"),
    (("extra",), 1, "extra = 1: unknown key; allowed: simulation, materials, pairs, walls, meshes, schedule, box, particles, "
                    "inserters, outlets, output, checkpoint"),
]


@pytest.mark.parametrize("path, value, message", BAD_VALUES, ids=[m.split(":")[0] for _, _, m in BAD_VALUES])
def test_a_bad_value_is_reported_with_its_path_and_value(path, value, message):
    assert errors_of(changed(read("drop.toml"), path, value)) == [message]


def test_every_bad_key_of_a_file_is_reported_in_the_file_order():
    with pytest.raises(scene.SceneError) as info:
        scene.load_scene(SCENES / "bad.toml")
    lines = str(info.value).splitlines()
    source = str(SCENES / "bad.toml")
    assert all(line.startswith(source + ": ") for line in lines)
    paths = [line[len(source) + 2:].split(" ")[0].rstrip(":") for line in lines]
    assert paths == ["simulation.gravty", "simulation.tangential_history", "simulation",
                     "materials.glass.restitution", "materials.glass.density", "materials.steel",
                     "walls[0].normal", "walls[0].material", "particles[0].generator",
                     "particles[1].region.upper", "particles[1].sizes.max_radius", "particles[1]"]
    assert [(p, v) for p, v, _ in info.value.errors][3] == ("materials.glass.restitution", 1.5)


def test_errors_of_tsubus_own_checks_are_reported_at_the_key_they_name():
    data = read("drop.toml")
    # Material: poisson_ratio without youngs_modulus (a rule between keys)
    lines = errors_of(changed(data, ("materials", "glass", "poisson_ratio"), 0.3))
    assert lines == ["materials.glass: poisson_ratio=0.3 needs youngs_modulus (a Hertzian material); "
                     "a linear material takes kn, kt"]
    # Material: a uniform roughness distribution wider than 90 degrees
    mutated = changed(data, ("materials", "steel", "roughness_distribution"), "uniform")
    lines = errors_of(changed(mutated, ("materials", "steel", "roughness"), 60.0))
    assert lines == ["materials.steel.roughness = 60.0: with a uniform distribution must be < 90/sqrt(3) "
                     "degrees (its range is +-sqrt(3) sigma)"]
    # Simulation.set_pair: an effective modulus for a pair of linear materials
    lines = errors_of(changed(data, ("pairs", 0, "effective_modulus"), 1e9))
    assert lines == ["pairs[0].effective_modulus = 1000000000.0: must be > 0 for a pair of Hertzian "
                     "materials and 0 otherwise"]
    # Simulation: slip_rule "truncate" with the literal history
    mutated = changed(data, ("simulation", "slip_rule"), "truncate")
    lines = errors_of(changed(mutated, ("simulation", "tangential_history"), "literal"))
    assert lines == ["simulation: slip_rule='truncate' needs tangential_history='rotate', got 'literal'"]
    # add_spheres: a material that mixes laws with the walls'
    hertz = {"youngs_modulus": 1e9, "density": 2500.0}
    lines = errors_of(changed(data, ("materials", "glass"), hertz))
    assert len(lines) == 1 and lines[0].startswith("particles[0]: material 'glass' is Hertzian")


def test_file_errors_name_the_file():
    with pytest.raises(scene.SceneError, match=r"missing\.toml: cannot read the scene file"):
        scene.load_scene(SCENES / "missing.toml")
    data = changed(read("drop.toml"), ("particles", 0, "path"), "nowhere.npz")
    (line,) = errors_of(data)
    assert line == f'particles[0].path = "nowhere.npz": no such file ({SCENES / "nowhere.npz"})'


def test_a_toml_syntax_error_gives_its_line(tmp_path):
    bad = tmp_path / "syntax.toml"
    bad.write_text("[simulation]\nduration = \n")
    with pytest.raises(scene.SceneError) as info:
        scene.load_scene(bad)
    (line,) = info.value.lines()
    assert line.startswith(f"{bad}: not a valid TOML file: ") and "line 2" in line


@pytest.mark.parametrize("name", sorted(scene.SPEC.fields["materials"].node.item.fields))
def test_the_specs_bounds_are_those_of_tsubu_material(name):
    """Each Material field's bounds in the spec: a value just inside is accepted by Material, one
    just outside refused by both (so the schema and the reference say what tsubu does)."""
    node = scene.SPEC.fields["materials"].node.item.fields[name].node
    if not isinstance(node, scene.Number):
        assert isinstance(node, scene.String) and tuple(node.choices) == tsubu._core.choices[name]
        return
    base = {"youngs_modulus": 1e9} if name == "poisson_ratio" else {}
    for bound, exclusive, step in ((node.minimum, node.exclusive_minimum, -1),
                                   (node.maximum, node.exclusive_maximum, +1)):
        if bound is None:
            continue
        inside = bound if not exclusive else bound - step * 1e-9
        outside = bound + step * 1e-9 if not exclusive else bound
        tsubu.Material(**base, **{name: inside})
        with pytest.raises(ValueError):
            tsubu.Material(**base, **{name: outside})
        assert node.check(outside, name, []) is scene._BAD
        assert node.check(inside, name, []) == inside


# ---- the JSON Schema agrees with the loader ---------------------------------------------------

def test_the_schema_accepts_and_refuses_what_the_loader_does():
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads((DOCS / "scene.schema.json").read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    for name in ("drop.toml", "pour.toml"):
        assert list(validator.iter_errors(read(name))) == [], name
        scene.validate(read(name))
    assert not validator.is_valid(read("bad.toml"))
    for path, value, message in BAD_VALUES:
        if value == [0, 0, math.inf] or "no such material" in message:
            continue  # JSON has no infinity; the schema cannot see which materials are defined
        assert not validator.is_valid(changed(read("drop.toml"), path, value)), path


# ---- what a scene builds -----------------------------------------------------------------------

def drop_by_hand():
    """drop.toml written with the Python API."""
    glass = tsubu.Material(density=2500.0, kn=1.0e3, restitution=0.5, friction=0.5, name="glass")
    steel = tsubu.Material(density=7850.0, kn=2.0e3, restitution=0.8, friction=0.3, roughness=5.0,
                           name="steel")
    sim = tsubu.Simulation(gravity=(0, 0, -9.81), seed=7, threads=1)
    sim.set_pair(glass, steel, friction=0.2)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=steel, velocity=(0.01, 0, 0))
    sim.add_plane(point=(-0.002, 0, 0), normal=(1, 0, 0), material=steel)
    table = np.loadtxt(SCENES / "beads.csv", delimiter=",", skiprows=1)
    sim.add_spheres(table[:, 1:4], table[:, 4], glass, velocities=table[:, 5:8],
                    angular_velocities=table[:, 8:11])
    sim.dt = 0.02 * sim.contact_duration()
    return sim


def test_a_scene_builds_what_the_same_python_code_builds():
    built = scene.load_scene(SCENES / "drop.toml")
    sim = built.simulation
    assert sim.seed == 7 and sim.threads == 1 and sim.size == 3 and sim._core.plane_count == 2
    assert [m.name for m in sim.materials] == ["glass", "steel"]
    assert sim.pair_parameters(*sim.materials)["friction"] == 0.2
    assert built.end_time == 0.002 and built.output == [] and built.checkpoint is None
    hand = drop_by_hand()
    assert sim.dt == hand.dt
    built.run(progress=False)
    hand.run(steps=sim.step_count)
    assert sim.step_count == round(0.002 / sim.dt) > 0
    for name in ("positions", "velocities", "angular_velocities"):
        assert np.array_equal(getattr(sim, name), getattr(hand, name)), name
    assert len(sim.contacts()["i"]) > 0  # the beads reached the floor: the run did something


def test_options_overrides_and_time_step_choices(tmp_path):
    data = read("drop.toml")
    built = scene.scene_from_dict(data, SCENES, threads=2, output_directory=tmp_path / "out")
    assert built.simulation.threads == 2
    assert built.output_directory == str(tmp_path / "out")
    assert scene.scene_from_dict(data, SCENES).output_directory == str(SCENES / "output")
    fixed = changed(changed(data, ("simulation", "dt_fraction"), scene.MISSING), ("simulation", "dt"), 1e-6)
    assert scene.scene_from_dict(fixed, SCENES).simulation.dt == 1e-6
    default = changed(data, ("simulation", "dt_fraction"), scene.MISSING)
    sim = scene.scene_from_dict(default, SCENES).simulation
    assert sim.dt == sim.default_time_step()
    empty = {"simulation": {"duration": 1.0}, "materials": {"glass": {}}}
    assert errors_of(empty) == ["simulation.dt: required when the scene has no particles and no "
                                "inserters (there is no contact to derive it from)"]
    empty["simulation"]["dt"] = 1e-3
    assert scene.scene_from_dict(empty).simulation.dt == 1e-3


def test_particles_from_npz_and_csv_files(tmp_path):
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 0.01, (5, 3)) + [0, 0, 0.002]
    x[:, 0] = np.arange(5) * 3e-3
    r = np.full(5, 1e-3)
    v = rng.normal(size=(5, 3))
    np.savez(tmp_path / "beads.npz", positions=x, radii=r, velocities=v, angular_velocities=v * 2)
    data = read("drop.toml")
    data = changed(data, ("particles", 0, "path"), "beads.npz")
    sim = scene.scene_from_dict(data, tmp_path).simulation
    assert np.array_equal(sim.positions, x) and np.array_equal(sim.velocities, v)
    assert np.array_equal(sim.angular_velocities, 2 * v) and np.array_equal(sim.radii, r)
    sim = scene.scene_from_dict(changed(data, ("particles", 0, "velocities"), False), tmp_path).simulation
    assert not sim.velocities.any() and not sim.angular_velocities.any()
    np.savez(tmp_path / "other.npz", centres=x)
    (line,) = errors_of_in(changed(data, ("particles", 0, "path"), "other.npz"), tmp_path)
    assert line.startswith('particles[0].path = "other.npz": ') and "has no positions and radii (found: centres)" in line
    (tmp_path / "beads.txt").write_text("x y z\n")
    (line,) = errors_of_in(changed(data, ("particles", 0, "path"), "beads.txt"), tmp_path)
    assert line.endswith("the file must end in .npz or .csv")


def test_a_file_can_name_the_spheres_materials(tmp_path):
    """An .npz of tsubu.output.save_npz names each sphere's material: a file block without a
    material gives each sphere the scene's material of that name, in the file's order."""
    x = np.array([[0, 0, 2e-3], [3e-3, 0, 2e-3], [6e-3, 0, 2e-3], [9e-3, 0, 2e-3]])
    np.savez(tmp_path / "mixed.npz", position=x, radius=np.full(4, 1e-3), material=np.array([1, 1, 0, 1]),
             material_names=np.array(["steel", "glass"]))
    data = read("drop.toml")
    data["particles"] = [{"generator": "file", "path": "mixed.npz"}]
    sim = scene.scene_from_dict(data, tmp_path).simulation
    names = [m.name for m in sim.materials]
    assert [names[k] for k in sim.material_ids] == ["glass", "glass", "steel", "glass"]
    assert np.array_equal(sim.positions, x)
    data["materials"]["iron"] = data["materials"].pop("steel")
    for wall in data["walls"]:
        wall["material"] = "iron"
    data["pairs"][0]["materials"] = ["glass", "iron"]
    (line,) = errors_of_in(data, tmp_path)
    assert line == ('particles[0].path = "mixed.npz": its spheres have materials \'steel\', not in '
                    "[materials] (defined: glass, iron); name them so, or give particles[0].material")
    np.savez(tmp_path / "plain.npz", position=x, radius=np.full(4, 1e-3))
    data["particles"][0]["path"] = "plain.npz"
    (line,) = errors_of_in(data, tmp_path)
    assert line.startswith("particles[0].material: required: plain.npz does not name its spheres' materials")


def errors_of_in(data, directory):
    with pytest.raises(scene.SceneError) as info:
        scene.scene_from_dict(data, directory)
    return info.value.lines()


def test_show_writes_values_as_toml():
    assert scene.show(True) == "true" and scene.show("a") == '"a"' and scene.show([1, 2.5]) == "[1, 2.5]"
    assert scene.show({"shape": "box", "lower": [0, 0]}) == '{shape = "box", lower = [0, 0]}'
    assert scene.show(math.nan) == "nan" and scene.show(-math.inf) == "-inf"
    assert len(scene.show(list(range(100)))) == 60


# ---- scenes with the generators, inserters, output and checkpoints ------------------------------

def needs(*modules):
    for m in modules:
        pytest.importorskip(m)


def test_generators_build_as_in_python():
    needs("tsubu.fill")
    from tsubu import fill
    data = read("pour.toml")
    data.pop("output")
    data.pop("checkpoint")
    if not hasattr(tsubu.Simulation, "add_inserter"):
        data.pop("inserters")
    built = scene.scene_from_dict(data, SCENES)
    sim = built.simulation
    lattice = fill.lattice(fill.Box([-0.003, -0.003, 0.0], [0.003, 0.003, 0.002]), 5e-4, spacing=1.1e-3,
                           jitter=0.2, seed=3)
    packing = fill.random_packing(fill.Cylinder([0, 0, 0.003], 0.003, 0.003),
                                  fill.Uniform(3e-4, 5e-4), count=30, seed=4)
    n = len(lattice.radii)
    assert sim.size == n + 30
    assert np.array_equal(sim.positions[:n], lattice.positions)
    assert np.array_equal(sim.positions[n:], packing.positions)
    assert np.array_equal(sim.radii[n:], packing.radii)
    assert sim.dt == sim.default_time_step()  # the smallest spheres are the packing's (0.3 mm)


def test_inserters_pour_and_set_the_time_step():
    needs("tsubu.fill", "tsubu.insert")
    if not hasattr(tsubu.Simulation, "add_inserter"):
        pytest.skip("Simulation.add_inserter not in this build")
    from tsubu import fill
    data = read("pour.toml")
    for key in ("output", "checkpoint", "particles"):
        data.pop(key)
    built = scene.scene_from_dict(data, SCENES)
    sim = built.simulation
    assert sim.size == 0
    # dt: t_c/50 of two spheres of the inserter's (only) radius, 0.4 mm, meeting: a pair's
    # reduced mass is half a sphere's, so its t_c is sqrt(2) shorter than against the wall
    probe = tsubu.Simulation()
    probe.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=sim.materials[0])
    probe.add_sphere((0, 0, 0.01), 4e-4, sim.materials[0])
    against_wall = probe.default_time_step()
    probe.add_sphere((0, 0.01, 0.01), 4e-4, sim.materials[0])
    assert sim.dt == probe.default_time_step() == pytest.approx(against_wall / 2**0.5)
    built.run(progress=False)
    assert sim.size > 0 and np.all(sim.radii == 4e-4)  # the inserter poured spheres


def test_an_inserter_total_is_a_count():
    """TOML's integer total = 3 (a count, basis "number") stops the inserter after 3 spheres."""
    needs("tsubu.fill", "tsubu.insert")
    data = read("pour.toml")
    for key in ("output", "checkpoint", "particles"):
        data.pop(key)
    data["inserters"][0]["total"] = 3
    built = scene.scene_from_dict(data, SCENES)
    built.run(progress=False)
    assert built.simulation.size == 3


def test_a_generator_error_is_reported_at_its_block():
    needs("tsubu.fill")
    data = read("pour.toml")
    block = data["particles"][1]
    del block["count"]
    block["solid_fraction"] = 0.9  # beyond random sequential addition
    lines = errors_of(data)
    assert len(lines) == 1 and lines[0].startswith("particles[1]")


def needs_run_hooks():
    if "output" not in inspect.signature(tsubu.Simulation.run).parameters:
        pytest.skip("Simulation.run(output=...) not in this build")


def test_run_writes_the_output_the_scene_asks_for(tmp_path):
    needs("tsubu.fill", "tsubu.output")
    pytest.importorskip("pyevtk")
    needs_run_hooks()
    data = read("pour.toml")
    del data["checkpoint"], data["inserters"]
    built = scene.scene_from_dict(data, SCENES, output_directory=tmp_path)
    sim = built.run(progress=False)
    steps = sim.step_count
    files = set(os.listdir(tmp_path))
    assert {"particles.pvd", "particles_contacts.pvd", "particles_walls.pvd", "state_frames.csv"} <= files
    assert {f for f in files if f.endswith(".npz")} == {f"state_{k}.npz" for k in range(0, steps + 1, 200)}
    every = round(0.002 / sim.dt)
    assert {f for f in files if re.fullmatch(r"state_\d+\.csv", f)} == {
        f"state_{k}.csv" for k in range(0, steps + 1, every)}
    with np.load(tmp_path / f"state_{steps - steps % 200}.npz") as last:
        if steps % 200 == 0:
            assert np.array_equal(last["position"], sim.positions)


def test_run_writes_output_and_checkpoints_and_resume_continues_bit_for_bit(tmp_path):
    needs("tsubu.fill", "tsubu.insert", "tsubu.output")
    if not hasattr(tsubu.Simulation, "save"):
        pytest.skip("checkpoints (Simulation.save) not in this build")
    data = read("pour.toml")
    whole = scene.scene_from_dict(data, SCENES, output_directory=tmp_path / "whole")
    whole.run(progress=False)
    assert os.path.exists(tmp_path / "whole" / "particles.pvd")
    assert os.path.exists(tmp_path / "whole" / "checkpoint.tsubu")
    # stop half way, resume from the checkpoint
    half = scene.scene_from_dict(data, SCENES, output_directory=tmp_path / "half")
    half.run(until=0.002, progress=False)
    resumed = scene.resume(tmp_path / "half" / "checkpoint.tsubu")
    assert resumed.end_time == whole.end_time
    assert resumed.output_directory == str(tmp_path / "half")
    resumed.run(progress=False)
    a, b = whole.simulation, resumed.simulation
    assert a.step_count == b.step_count and a.size == b.size
    for name in ("positions", "velocities", "angular_velocities"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    # the resumed run went on with the same series of frames and the same periodic checkpoints
    for name in ("particles.pvd", f"state_{a.step_count - a.step_count % 200}.npz"):
        assert (tmp_path / "half" / name).exists()
    pvd = {d: (tmp_path / d / "particles.pvd").read_text() for d in ("whole", "half")}
    assert pvd["half"].replace("/half/", "/whole/") == pvd["whole"]
    for d in ("whole", "half"):
        assert len([f for f in os.listdir(tmp_path / d) if f.startswith("checkpoint.step")]) == 2


def test_the_example_in_the_docs_is_a_valid_scene():
    page = (DOCS / "scene-format.md").read_text(encoding="utf-8")
    example = page.split("```toml\n", 1)[1].split("```", 1)[0]
    data = tomllib.loads(example)
    scene.validate(data)
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads((DOCS / "scene.schema.json").read_text(encoding="utf-8"))
    assert jsonschema.Draft202012Validator(schema).is_valid(data)

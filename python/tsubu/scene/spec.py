"""The scene format: the declarative spec ``SPEC`` of every table and key of a scene file, written
in the schema language of :mod:`tsubu.scene.language`. The loader validates with it, and the JSON
Schema and the key reference are generated from it (:mod:`tsubu.scene.reference`).
"""

from __future__ import annotations

from .._options import DECLARATIONS, declared
from .language import (ArrayOf, Boolean, ByKey, Field, Integer, Letters, MapOf, Node, Number,
                       NumberList, String, StringList, Table, Tagged, Vector, _NameList)


# The version of the scene format (documented as tsubu.scene.FORMAT_VERSION).
FORMAT_VERSION = 1


# ---- the scene format --------------------------------------------------------------------------
# Units, defaults and meanings are those of the Python API (tsubu.Material, tsubu.Simulation,
# tsubu.fill, tsubu.insert, tsubu.output); the materials', pairs' and simulation's options are
# their declarations (_option), the other ranges tsubu's own checks (tests/test_scene.py checks
# that Material refuses what the spec refuses).

POSITIVE = dict(minimum=0.0, exclusive_minimum=True)
NON_NEGATIVE = dict(minimum=0.0)
XYZ = "array of 3 numbers"


def _option(name: str, doc: str | None = None, default: str | None = None) -> Field:
    """The key of option ``name`` as its declaration says it (cpp/include/tsubu/option_table.hpp:
    type, unit, range, default, doc); ``doc`` and ``default`` replace the declared text where a
    scene file says more."""
    d = DECLARATIONS[name]
    if d.kind == "real":
        bounds = {}
        if d.minimum is not None:
            bounds.update(minimum=d.minimum, exclusive_minimum=d.exclusive_minimum)
        if d.maximum is not None:
            bounds.update(maximum=d.maximum, exclusive_maximum=d.exclusive_maximum)
        node: Node = Number(unit=d.unit, **bounds)
    elif d.kind == "integer":
        node = Integer(d.minimum, d.maximum)
    elif d.kind == "flag":
        node = Boolean()
    elif d.kind == "choice":
        node = String(tuple(d.choices))
    else:
        node = Vector(unit=d.unit)
    return Field(node, d.doc if doc is None else doc,
                 default=d.default_text if default is None else default, unit=d.unit)


def _material_table() -> Table:
    return Table({name: _option(name) for name in declared("material")},
                 doc="A material: the fields of tsubu.Material (SI units; roughness in degrees). The "
                     "table's name (materials.NAME) is how walls, particles and inserters refer to it.",
                 exclusive=(("kn", "youngs_modulus"), ("kt", "youngs_modulus")), name="materials.NAME")


def _region() -> Tagged:
    return Tagged("shape", {
        "box": Table({
            "lower": Field(Vector(unit="m"), "Lower corner.", required=True, unit="m"),
            "upper": Field(Vector(unit="m"), "Upper corner (each coordinate above lower's).",
                           required=True, unit="m"),
        }, doc="An axis-aligned box (tsubu.fill.Box)."),
        "cylinder": Table({
            "base": Field(Vector(unit="m"), "Centre of the bottom disc.", required=True, unit="m"),
            "radius": Field(Number("m", **POSITIVE), "Radius.", required=True, unit="m"),
            "height": Field(Number("m", **POSITIVE), "Height along the axis.", required=True, unit="m"),
            "axis": Field(String(("x", "y", "z")), "Axis direction.", default='"z"'),
        }, doc="A circular cylinder (tsubu.fill.Cylinder)."),
    }, doc="A region of space: a box or a cylinder (tsubu.fill).", name="region")


def _radius(doc, required=True, default=None):
    return Field(Number("m", **POSITIVE), doc, required=required, default=default, unit="m")


def _sizes() -> Tagged:
    return Tagged("distribution", {
        "monodisperse": Table({"radius": _radius("The radius.")}, doc="One radius."),
        "uniform": Table({"min_radius": _radius("Smallest radius."),
                          "max_radius": _radius("Largest radius.")},
                         doc="Radii uniform between two bounds."),
        "normal": Table({"mean_radius": _radius("Mean radius."),
                         "std": Field(Number("m", **NON_NEGATIVE), "Standard deviation.", required=True,
                                      unit="m"),
                         "min_radius": _radius("Truncation below.", False, "none"),
                         "max_radius": _radius("Truncation above.", False, "none")},
                        doc="A truncated normal distribution of radii."),
        "lognormal": Table({"median_radius": _radius("Median radius."),
                            "sigma": Field(Number(**NON_NEGATIVE), "Standard deviation of ln r.",
                                           required=True),
                            "min_radius": _radius("Truncation below.", False, "none"),
                            "max_radius": _radius("Truncation above.", False, "none")},
                           doc="A (truncated) log-normal distribution of radii."),
        "tabulated": Table({"radii": Field(NumberList(Number("m", **POSITIVE), 2),
                                           "Radii of the table, increasing.", required=True, unit="m"),
                            "fractions": Field(NumberList(Number(minimum=0.0, maximum=1.0), 2),
                                               "Cumulative fraction finer than each radius, "
                                               "non-decreasing, from 0 to 1.", required=True),
                            "basis": Field(String(("number", "mass")), "Fractions by number or by mass.",
                                           default='"number"')},
                           doc="A tabulated particle-size distribution (cumulative, linear in radius "
                               "between points)."),
    }, doc="A size distribution of radii (tsubu.fill).", name="sizes")


def _motion(what: str) -> dict:
    return {
        "velocity": Field(Vector(unit="m/s"), f"Initial velocity of {what}.", default="[0, 0, 0]",
                          unit="m/s"),
        "angular_velocity": Field(Vector(unit="rad/s"), f"Initial angular velocity of {what}.",
                                  default="[0, 0, 0]", unit="rad/s"),
    }


def _every() -> dict:
    return {
        "every": Field(Integer(minimum=1), "Write every this many steps.", unit="steps"),
        "interval": Field(Number("s", **POSITIVE), "Write every this much simulated time (rounded to "
                                                   "whole steps, at least 1).", unit="s"),
    }


def _writer(name_default: str, doc: str, extra: dict | None = None) -> Table:
    return Table({**_every(),
                  "name": Field(String(), "Base name of the files.", default=f'"{name_default}"'),
                  **(extra or {})}, doc=doc, one_of=(("every", "interval"),))


# ---- a periodic box (docs/periodic.md) --------------------------------------------------------

# The periodic axes a box may name (Simulation.set_box takes them in any order; the scene format
# takes each set once, in x, y, z order, so that the schema can list them).
PERIODIC_AXES = ("xyz", "xy", "xz", "yz", "x", "y", "z")
AXES = ("x", "y", "z")


def _box() -> Table:
    """``[box]``: a periodic box, its Lees-Edwards shear and its pressure control."""
    shear = Table({
        "rate": Field(Number("1/s"), "Shear rate (any sign): the images across the gradient faces "
                                     "slide along the flow at rate times the box's gradient length.",
                      required=True, unit="1/s"),
        "flow": Field(String(AXES), "The flow axis (periodic).", default='"x"'),
        "gradient": Field(String(AXES), "The gradient axis (periodic, not the flow's).", default='"z"'),
    }, doc="Lees-Edwards simple shear of the periodic box (Simulation.set_shear): the mean flow "
           "u = rate (x_gradient - centre) along the flow develops without walls.", name="box.shear")
    pressure = Table({
        "pressure": Field(Number("Pa", **POSITIVE), "Target normal stress along the axis "
                                                    "(compression positive).", required=True, unit="Pa"),
        "gain": Field(Number("1/(Pa s)", **POSITIVE), "d ln L / dt per pascal of pressure error: the box "
                                                      "relaxes with the time constant 1 / (K gain), K ~ "
                                                      "kn / d (docs/periodic.md: how to choose it).",
                      required=True, unit="1/(Pa s)"),
        "axis": Field(String(AXES), "The controlled axis (periodic).", default='"z"'),
        "max_strain_rate": Field(Number("1/s", **POSITIVE), "Cap on abs(d ln L / dt).",
                                 default="0.01 / the contact duration (Simulation.contact_duration()) of the particles blocks' "
                                         "spheres",
                                 unit="1/s"),
    }, doc="Pressure control (Simulation.set_pressure): after every step the box stretches along the "
           "axis about its lower face, the spheres with it, at the strain rate gain (P - pressure), "
           "so that the normal stress P follows the target.", name="box.pressure")
    return Table({
        "lower": Field(Vector(unit="m"), "Lower corner.", required=True, unit="m"),
        "upper": Field(Vector(unit="m"), "Upper corner: above lower along each periodic axis (along "
                                         "the others the corners only set the volume that stresses "
                                         "divide by).", required=True, unit="m"),
        "periodic": Field(Letters(PERIODIC_AXES), "The periodic axes (along the others the scene is "
                                                 "open: walls bound it).", default='"xyz"'),
        "shear": Field(shear, "Lees-Edwards shear."),
        "pressure": Field(pressure, "Pressure control."),
    }, doc="A periodic box (Simulation.set_box; docs/periodic.md): a sphere that leaves through a "
           "face comes back through the opposite one, and spheres near a face touch the images of "
           "those near the other. Each periodic length must be at least twice the neighbour reach, "
           "2 (2 r_max + skin) (checked when the run starts).", name="box")


# ---- walls: meshes and motion schedules ---------------------------------------------------------

# Schedule entries' ramps: piecewise-constant segments by default (docs/scene-format.md).
RAMP_SEGMENTS = 20


def _schedule_entry(top_level: bool = False) -> Table:
    """An entry of a wall's motion schedule (``[[walls.schedule]]``, ``[[meshes.schedule]]``) or,
    with ``top_level``, of ``[[schedule]]`` (which names its walls)."""
    fields = {}
    if top_level:
        fields["wall"] = Field(String(), "The name of the wall the entry changes.")
        fields["walls"] = Field(StringList(), "The names of the walls the entry changes (together: "
                                              "a box of planes that turns as one body).")
    fields.update({
        "at": Field(Number("s", **NON_NEGATIVE), "Simulated time of the change, rounded to the "
                                                 "nearest whole step.", required=True, unit="s"),
        "velocity": Field(Vector(unit="m/s"), "New translation velocity.", default="unchanged",
                          unit="m/s"),
        "angular_velocity": Field(Vector(unit="rad/s"), "New angular velocity about the centre.",
                                  default="unchanged", unit="rad/s"),
        "center": Field(Vector(unit="m"), "New centre of rotation (the wall does not move).",
                        default="unchanged", unit="m"),
        "remove": Field(Boolean(), "Remove the wall (a gate that opens): true, alone.",
                        default="false"),
        "ramp": Field(Number("s", **POSITIVE), "Reach velocity and angular_velocity linearly over this "
                                               "long from their values before the entry, in "
                                               "piecewise-constant segments.", default="none (a jump)",
                      unit="s"),
        "segments": Field(Integer(minimum=1), "Segments of the ramp (at most one per step).",
                          default=str(RAMP_SEGMENTS)),
    })
    doc = ("A change of a wall's motion at a simulated time: new velocity, angular velocity or centre "
           "(the others unchanged), a ramp to them, or the wall's removal.")
    if top_level:
        return Table(fields, doc=doc + " Names its walls (the name keys of [[walls]] and [[meshes]]).",
                     one_of=(("wall", "walls"),), name="schedule")
    return Table(fields, doc=doc, name="schedule")


def _wall_extras(what: str) -> dict:
    return {
        "name": Field(String(), f"A name for the {what}, unique among walls and meshes (for "
                                "[[schedule]]).", default="none"),
        "schedule": Field(ArrayOf(_schedule_entry(), "Motion changes."),
                          "Changes of this wall's motion during the run ([[walls.schedule]] / "
                          "[[meshes.schedule]] blocks after the wall's).", default="none"),
    }


def _mesh_motion(center_doc: str, center_default: str) -> dict:
    return {
        "material": Field(String(), "The mesh's material (a name from [materials]).", required=True),
        "velocity": Field(Vector(unit="m/s"), "Translation velocity.", default="[0, 0, 0]", unit="m/s"),
        "angular_velocity": Field(Vector(unit="rad/s"), "Angular velocity about center.",
                                  default="[0, 0, 0]", unit="rad/s"),
        "center": Field(Vector(unit="m"), center_doc, default=center_default, unit="m"),
        **_wall_extras("mesh"),
    }


def _meshes(material_name: Node) -> ByKey:
    rotation = ("Centre of rotation (and of the wall's torque).", "the mean of the vertices")
    shape_centre = ("The shape's centre (the generator's center), also the centre of rotation "
                    "(and of the wall's torque).", "[0, 0, 0]")

    def length(doc: str, required: bool = True, default=None) -> Field:
        return Field(Number("m", **POSITIVE), doc, required=required, default=default, unit="m")

    def count(doc: str, minimum: int) -> Field:
        return Field(Integer(minimum=minimum), doc, required=True)

    axis = Field(String(("x", "y", "z")), "The axis.", default='"z"')
    bottom = Field(Vector(unit="m"), "Centre of the bottom opening.", default="[0, 0, 0]", unit="m")
    generators = Tagged("generator", {
        "box": Table({
            "lo": Field(Vector(unit="m"), "Lower corner.", required=True, unit="m"),
            "hi": Field(Vector(unit="m"), "Upper corner (above lo in x, y and z).", required=True,
                        unit="m"),
            **_mesh_motion(*rotation),
        }, doc="A closed box of 12 triangles (tsubu.mesh.box)."),
        "square": Table({
            "size": length("Side."),
            "normal": Field(Vector(nonzero=True), "Normal.", required=True),
            "divisions": count("Cells along each side.", 1),
            "jitter": Field(Number(minimum=0.0, maximum=1.0, exclusive_maximum=True),
                            "Irregularity of the interior vertices.", default="0"),
            "seed": Field(Integer(0, 2**64 - 1), "Seed of the jitter.", default="0"),
            **_mesh_motion(*shape_centre),
        }, doc="A flat square of triangles (tsubu.mesh.square)."),
        "cylinder": Table({
            "radius": length("Radius of the vertices' circles."),
            "length": length("Length along the axis."),
            "segments": count("Flat faces around.", 3),
            "axis": axis,
            "caps": Field(Boolean(), "Close both ends.", default="false"),
            **_mesh_motion(*shape_centre),
        }, doc="A drum: the side of a cylinder, optionally with caps (tsubu.mesh.cylinder)."),
        "cone": Table({
            "top_radius": length("Radius of the top circle."),
            "bottom_radius": length("Radius of the bottom circle (the orifice)."),
            "height": length("Height along the axis."),
            "segments": count("Flat faces around.", 3),
            "axis": Field(String(("x", "y", "z")), "The axis, from the bottom to the top.",
                          default='"z"'),
            "bottom": bottom,
            **_mesh_motion(*rotation),
        }, doc="A conical hopper, open at both ends (tsubu.mesh.cone)."),
        "wedge_hopper": Table({
            "orifice_width": length("Width of the slot (along x)."),
            "top_width": length("Width of the top opening (>= orifice_width)."),
            "height": length("Height of the plates."),
            "depth": length("Length of the slot (along y)."),
            "bottom": Field(Vector(unit="m"), "Centre of the slot.", default="[0, 0, 0]", unit="m"),
            **_mesh_motion(*rotation),
        }, doc="A wedge (slot) hopper (tsubu.mesh.wedge_hopper)."),
    }, doc="A mesh made by a generator of tsubu.mesh.", name="meshes")
    from_file = Table({
        "file": Field(String(), "An STL (binary or ASCII) or OBJ file (relative to the scene file; "
                                "tsubu.read_mesh, which needs trimesh: pip install 'tsubu[mesh]').",
                      required=True),
        "scale": Field(Number(**POSITIVE), "Factor on every coordinate (1e-3 for a file in mm).",
                       default="1"),
        **_mesh_motion(*rotation),
    }, doc="A mesh read from a file (tsubu.read_mesh).", name="meshes")
    return ByKey({"file": from_file, "generator": generators},
                 doc="A triangle-mesh wall (Simulation.add_mesh), from a file or a generator.",
                 name="meshes")


def _build_spec() -> Table:
    material_name = String()
    simulation = Table({
        "duration": Field(Number("s", **NON_NEGATIVE), "Simulated time to run.", required=True, unit="s"),
        "gravity": _option("gravity"),
        "dt": _option("dt", default="dt_fraction's"),
        "dt_fraction": Field(Number(minimum=0.0, maximum=1.0, exclusive_minimum=True),
                             "Time step as a fraction of the scene's shortest contact duration "
                             "(Simulation.contact_duration(), with the spheres of the particles "
                             "blocks and the smallest spheres of the inserters).",
                             default="0.02 (tsubu's t_c/50)"),
        "seed": _option("seed"),
        "threads": _option("threads", "OpenMP threads (`tsubu run --threads` overrides it)."),
        "parallel_min": _option("parallel_min"),
        # every other run option, as declared, in the declarations' order
        **{name: _option(name) for name in declared("run")
           if name not in ("gravity", "dt", "seed", "threads", "parallel_min")},
    }, doc="The simulation's options (tsubu.Simulation) and how long to run.",
        exclusive=(("dt", "dt_fraction"),), name="simulation")

    pair = Table({
        "materials": Field(_NameList(), "The two materials' names.",
                           required=True),
        **{name: _option(name, default="mixed") for name in declared("pair")},
    }, doc="A per-pair override of the mixed contact parameters (Simulation.set_pair).", name="pairs")

    wall = Table({
        "point": Field(Vector(unit="m"), "A point of the plane (and the centre of its rotation).",
                       required=True, unit="m"),
        "normal": Field(Vector(nonzero=True), "Normal, pointing to the side where spheres live.",
                        required=True),
        "material": Field(material_name, "The wall's material (a name from [materials]).", required=True),
        "velocity": Field(Vector(unit="m/s"), "Translation velocity.", default="[0, 0, 0]", unit="m/s"),
        "angular_velocity": Field(Vector(unit="rad/s"), "Angular velocity about center.",
                                  default="[0, 0, 0]", unit="rad/s"),
        "center": Field(Vector(unit="m"), "Centre of rotation, instead of point (planes and meshes that share a centre "
                                          "and a motion turn as one body).", default="point", unit="m"),
        **_wall_extras("plane"),
    }, doc="An infinite plane wall (Simulation.add_plane).", name="walls")

    common = {"material": Field(material_name, "The spheres' material (a name from [materials]).",
                                required=True),
              "fixed": Field(Boolean(), "Fix the block's spheres (Simulation.fix_spheres): they "
                                        "move with the block's velocity and spin with its "
                                        "angular_velocity (glued without them), whatever the forces "
                                        "and gravity; a file's spheres are glued.", default="false")}
    particles = Tagged("generator", {
        "lattice": Table({
            **common,
            "region": Field(_region(), "Where the spheres go.", required=True),
            "radius": _radius("The spheres' radius."),
            "spacing": Field(Number("m", **POSITIVE), "Distance between neighbouring centres.",
                             default="2 radius", unit="m"),
            "kind": Field(String(("cubic", "hexagonal")), "Lattice type.", default='"cubic"'),
            "jitter": Field(Number(minimum=0.0, maximum=1.0, exclusive_maximum=True),
                            "Random displacement as a fraction of the gap.", default="0"),
            "seed": Field(Integer(0, 2**64 - 1), "Seed of the jitter.", default="0"),
            **_motion("every sphere"),
        }, doc="Spheres on a lattice filling a region (tsubu.fill.lattice)."),
        "random_packing": Table({
            **common,
            "region": Field(_region(), "Where the spheres go.", required=True),
            "sizes": Field(_sizes(), "The size distribution.", required=True),
            "count": Field(Integer(minimum=1), "Number of spheres."),
            "solid_fraction": Field(Number(minimum=0.0, maximum=1.0, exclusive_minimum=True,
                                           exclusive_maximum=True), "Target solid fraction of the region."),
            "seed": Field(Integer(0, 2**64 - 1), "Seed of the positions and sizes.", default="0"),
            "max_attempts": Field(Integer(minimum=1), "Attempts of random sequential addition.",
                                  default="tsubu.fill's"),
            **_motion("every sphere"),
        }, doc="A random non-overlapping packing (tsubu.fill.random_packing).", one_of=(("count", "solid_fraction"),)),
        "file": Table({
            "fixed": common["fixed"],
            "material": Field(material_name, "The spheres' material. Without it, each sphere gets "
                                             "the material the file names (an .npz of "
                                             "tsubu.output.save_npz: its material and material_names "
                                             "arrays), which must be one of [materials]."),
            "path": Field(String(), "An .npz or .csv file written by tsubu.output.save_npz / save_csv "
                                    "(relative to the scene file).", required=True),
            "velocities": Field(Boolean(), "Take the velocities and angular velocities from the file "
                                           "(false: at rest).", default="true"),
        }, doc="Spheres read from a file of tsubu.output."),
    }, doc="A block of spheres added before the run.", name="particles")

    inserter = Table({
        "material": Field(material_name, "The inserted spheres' material.", required=True),
        "region": Field(_region(), "Where spheres are inserted.", required=True),
        "rate": Field(Number(**POSITIVE), "Spheres per second (basis \"number\") or kg per second "
                                          "(basis \"mass\").", required=True, unit="1/s or kg/s"),
        "sizes": Field(_sizes(), "The size distribution.", required=True),
        "basis": Field(String(("number", "mass")), "What rate and total count.", default='"number"'),
        **_motion("the inserted spheres"),
        "start": Field(Number("s", **NON_NEGATIVE), "Simulated time of the first insertion.", default="0",
                       unit="s"),
        "stop": Field(Number("s", **NON_NEGATIVE), "Simulated time after which nothing is inserted.",
                      default="never", unit="s"),
        "total": Field(Number(**POSITIVE), "Count (basis \"number\") or mass [kg] after which it stops.",
                       default="unlimited"),
        "interval": Field(Number("s", **POSITIVE), "Time between insertion events.",
                          default="chosen from the region and velocity", unit="s"),
        "seed": Field(Integer(0, 2**64 - 1), "Seed of the positions and sizes.", default="0"),
    }, doc="Pours spheres during the run (Simulation.add_inserter).", name="inserters")

    outlet = Tagged("shape", {
        "plane": Table({
            "point": Field(Vector(unit="m"), "A point of the plane.", required=True, unit="m"),
            "normal": Field(Vector(nonzero=True), "Normal, pointing into the scene (as a wall's): a "
                                                  "sphere whose centre is behind the plane is removed.",
                            required=True),
        }, doc="A plane: spheres whose centre crosses it are removed."),
        "box": Table({
            "lo": Field(Vector(unit="m"), "Lower corner.", required=True, unit="m"),
            "hi": Field(Vector(unit="m"), "Upper corner (no coordinate below lo's).", required=True,
                        unit="m"),
            "remove": Field(String(("outside", "inside")), "Which spheres go: those whose centre "
                                                          "is outside the box, or inside it.",
                            default='"outside"'),
        }, doc="A box: spheres whose centre leaves it (or enters it) are removed."),
    }, doc="An outlet (Simulation.add_outlet): spheres it takes are removed at the end of a step "
           "and logged (Simulation.removed()).", name="outlets")

    output = Table({
        "directory": Field(String(), "Where output and checkpoints go (relative to the scene file; "
                                     "`tsubu run --output` overrides it).", default='"output"'),
        "vtk": Field(_writer("particles", "VTK XML files for ParaView (tsubu.output.VTKOutput).", {
            "contacts": Field(Boolean(), "Write the contact network.", default="true"),
            "walls": Field(Boolean(), "Write the walls (and a periodic box's outline).", default="true"),
        }), "ParaView output."),
        "npz": Field(_writer("state", "numpy .npz files (tsubu.output.NpzOutput)."), "npz dumps."),
        "csv": Field(_writer("state", "CSV tables (tsubu.output.CSVOutput), with an index "
                                      "NAME_frames.csv of steps and times.", {
            "contacts": Field(Boolean(), "Also write the contact network as NAME_contacts_STEP.csv.",
                              default="true"),
        }), "CSV dumps."),
    }, doc="What to write during the run.", name="output")

    checkpoint = Table({
        "path": Field(String(), "Checkpoint file (relative to the output directory).",
                      default='"checkpoint.tsubu"'),
        **{k: Field(f.node, f.doc.replace("Write", "Checkpoint"), unit=f.unit) for k, f in _every().items()},
        "keep": Field(Integer(minimum=1), "How many periodic checkpoints to keep.", default="3"),
    }, doc="Checkpoints (Simulation.save), for `tsubu resume`. Without every or interval, only "
           "the end of the run and a Ctrl-C write one.", exclusive=(("every", "interval"),),
        name="checkpoint")

    return Table({
        "simulation": Field(simulation, "Options and duration.", required=True),
        "materials": Field(MapOf(_material_table(), "Materials by name."), "Materials by name.",
                           required=True),
        "pairs": Field(ArrayOf(pair, "Pair overrides."), "Pair overrides."),
        "walls": Field(ArrayOf(wall, "Plane walls."), "Plane walls."),
        "meshes": Field(ArrayOf(_meshes(material_name), "Mesh walls."), "Triangle-mesh walls."),
        "schedule": Field(ArrayOf(_schedule_entry(top_level=True), "Wall motion changes."),
                          "Changes of the named walls' motion during the run (as a wall's own "
                          "schedule, for one or several walls)."),
        "box": Field(_box(), "A periodic box."),
        "particles": Field(ArrayOf(particles, "Blocks of spheres."), "Blocks of spheres."),
        "inserters": Field(ArrayOf(inserter, "Inserters."), "Inserters."),
        "outlets": Field(ArrayOf(outlet, "Outlets."), "Outlets."),
        "output": Field(output, "Output."),
        "checkpoint": Field(checkpoint, "Checkpoints."),
    }, doc="A tsubu scene file (docs/scene-format.md).", name="scene")


SPEC = _build_spec()

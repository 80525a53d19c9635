"""Loading a scene: reading the TOML file, validating it against the spec, and building the tsubu
objects it describes (:class:`Scene`), or a :class:`Scene` from a checkpoint of a scene run
(:func:`resume`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from typing import Callable

import numpy as np

from .. import _checks
from ..material import Material
from ..simulation import Simulation
from .language import _BAD, MISSING, SceneError, _closest, _join, show
from .spec import FORMAT_VERSION, RAMP_SEGMENTS, SPEC


def read_toml(path) -> dict:
    """The TOML file at ``path`` as a dict; SceneError for a file that is missing, unreadable or
    not TOML (with the line and column of the syntax error)."""
    source = os.fspath(path)
    try:
        import tomllib  # Python 3.11+
    except ModuleNotFoundError:  # pragma: no cover - Python < 3.11
        try:
            import tomli as tomllib
        except ModuleNotFoundError:
            raise SceneError([("", MISSING, "reading scene files on Python < 3.11 needs tomli: "
                               "install it with pip install 'tsubu[scene]' (or pip install tomli)")],
                             source) from None
    try:
        with open(source, "rb") as f:
            return tomllib.load(f)
    except OSError as e:
        raise SceneError([("", MISSING, f"cannot read the scene file: {e.strerror or e}")], source) from None
    except tomllib.TOMLDecodeError as e:
        raise SceneError([("", MISSING, f"not a valid TOML file: {e}")], source) from None


def validate(data, source: str | None = None) -> dict:
    """Check a scene (``data``, the dict of a parsed TOML file) against the format's spec and the
    references between its parts (material names); returns the checked scene (numbers as floats,
    vectors as lists). Raises SceneError listing every bad, missing or unknown key, with
    ``source`` (the file's name, or None) in front of each line."""
    errors: list = []
    checked = SPEC.check(data, "", errors)
    materials = data.get("materials") if isinstance(data, dict) else None
    if isinstance(materials, dict):  # names are checked even where other keys are bad
        names = list(materials)
        for path, name in _material_references(data):
            if name not in materials:
                errors.append((path, name, "no such material; defined: " + (", ".join(names) or "none")
                               + _closest(name, names)))
    if checked is not _BAD:  # the walls' names and schedules, once their keys are sound
        _check_walls(checked, errors)
        if "box" in checked:
            _check_box(checked["box"], errors)
    if isinstance(materials, dict) or checked is not _BAD:
        errors.sort(key=lambda e: _order(data, e[0]))
    if errors:
        raise SceneError(errors, source)
    return checked


def _material_references(data: dict) -> list:
    """(path, name) of every material name the scene uses (those that are strings)."""
    refs = []
    for part in ("walls", "meshes", "particles", "inserters"):
        items = data.get(part)
        for k, item in enumerate(items if isinstance(items, list) else []):
            if isinstance(item, dict) and isinstance(item.get("material"), str):
                refs.append((f"{part}[{k}].material", item["material"]))
    pairs = data.get("pairs")
    for k, pair in enumerate(pairs if isinstance(pairs, list) else []):
        names = pair.get("materials") if isinstance(pair, dict) else None
        for j, name in enumerate(names if isinstance(names, list) else []):
            if isinstance(name, str):
                refs.append((f"pairs[{k}].materials[{j}]", name))
    return refs


# ---- walls: names and schedules ----------------------------------------------------------------

def _walls(scene: dict) -> list:
    """(path, table) of every wall of a checked scene in the order of their wall indices: the
    [[walls]] planes, then the [[meshes]]."""
    return ([(f"walls[{k}]", w) for k, w in enumerate(scene.get("walls", []))]
            + [(f"meshes[{k}]", m) for k, m in enumerate(scene.get("meshes", []))])


_MOTION = ("velocity", "angular_velocity")


def _schedule_entries(scene: dict, errors: list | None = None) -> list:
    """Every schedule entry of a checked scene as (wall index, path, entry), the walls' own
    schedules and [[schedule]]'s; names that match no wall are reported in ``errors``."""
    walls = _walls(scene)
    names = {}
    for index, (path, wall) in enumerate(walls):
        if "name" in wall:
            names.setdefault(wall["name"], index)
    out = []
    for index, (path, wall) in enumerate(walls):
        for k, entry in enumerate(wall.get("schedule", [])):
            out.append((index, f"{path}.schedule[{k}]", entry))
    for k, entry in enumerate(scene.get("schedule", [])):
        path = f"schedule[{k}]"
        targets = [("wall", entry["wall"])] if "wall" in entry else [
            (f"walls[{j}]", name) for j, name in enumerate(entry["walls"])]
        for key, name in targets:
            if name in names:
                out.append((names[name], path, entry))
            elif errors is not None:
                known = list(names)
                errors.append((f"{path}.{key}", name, "no such wall; named walls: "
                               + (", ".join(known) if known else "none (give a [[walls]] or "
                                  "[[meshes]] block a name key)") + _closest(name, known)))
    return out


def _check_walls(scene: dict, errors: list) -> None:
    """Unique wall names; schedule entries that change something, once each time, not after the
    wall's removal and not within a ramp of the same motion."""
    seen: dict = {}
    for path, wall in _walls(scene):
        if "name" in wall:
            if wall["name"] in seen:
                errors.append((f"{path}.name", wall["name"], f"another wall has this name "
                               f"({seen[wall['name']]}): names must be unique among walls and meshes"))
            else:
                seen[wall["name"]] = path
    checked_entries = set()
    by_wall: dict = {}
    for index, path, entry in _schedule_entries(scene, errors):
        if path not in checked_entries:
            checked_entries.add(path)
            if not _check_entry(path, entry, errors):
                continue
        by_wall.setdefault(index, []).append((path, entry))
    walls = _walls(scene)
    for index, entries in sorted(by_wall.items()):
        what = walls[index][0] + (f' ("{walls[index][1]["name"]}")' if "name" in walls[index][1] else "")
        entries.sort(key=lambda e: e[1]["at"])  # stable: the file's order at equal times
        removed = None
        ramps: dict = {}  # motion -> (path, start, end) of the last ramp
        previous = None
        for path, entry in entries:
            at = entry["at"]
            if previous is not None and previous[1]["at"] == at:
                errors.append((f"{path}.at", at, f"{what} already has a schedule entry at t = {at!r} s "
                               f"({previous[0]}): give one entry per wall and time"))
            elif removed is not None:
                errors.append((f"{path}.at", at, f"{what} is removed at t = {removed[1]!r} s "
                               f"({removed[0]}): nothing changes it after that"))
            for key in _MOTION:
                ramp = ramps.get(key)
                if key in entry and ramp is not None and at < ramp[2]:
                    errors.append((f"{path}.{key}", entry[key], f"changes {what}'s {key} at t = {at!r} s, "
                                   f"within the ramp of {ramp[0]} (from t = {ramp[1]!r} to {ramp[2]!r} "
                                   "s): start it when the ramp ends"))
                if key in entry and "ramp" in entry:
                    ramps[key] = (path, at, at + entry["ramp"])
            if entry.get("remove"):
                removed = (path, at)
            previous = (path, entry)


def _check_entry(path: str, entry: dict, errors: list) -> bool:
    """One schedule entry on its own: it changes something, a removal alone, a ramp of a motion.
    False (after reporting) when it does not."""
    changes = [k for k in (*_MOTION, "center") if k in entry]
    if entry.get("remove") is False:
        errors.append((f"{path}.remove", False, "remove = false changes nothing: leave it out, or give "
                                                "remove = true to remove the wall"))
        return False
    if entry.get("remove") and (changes or "ramp" in entry or "segments" in entry):
        extra = changes + [k for k in ("ramp", "segments") if k in entry]
        errors.append((path, MISSING, "a removal comes alone: remove = true with "
                       + ", ".join(extra) + " (a removed wall does not move): give those in another entry"))
        return False
    if not changes and not entry.get("remove"):
        errors.append((path, MISSING, "the entry changes nothing: give velocity, angular_velocity, "
                                      "center or remove = true"))
        return False
    if "ramp" in entry and not any(k in entry for k in _MOTION):
        errors.append((f"{path}.ramp", entry["ramp"], "a ramp needs a velocity or angular_velocity to "
                                                      "reach"))
        return False
    if "velocity" in entry:
        from ..simulation import _wall_velocity
        try:
            _wall_velocity("velocity", entry["velocity"])
        except ValueError as e:
            errors.append((f"{path}.velocity", entry["velocity"],
                           re.sub(r",? got .*$", "", str(e)[len("velocity "):], flags=re.S)))
            return False
    if "segments" in entry and "ramp" not in entry:
        errors.append((f"{path}.segments", entry["segments"], "segments divide a ramp: give ramp too "
                                                              "(or leave segments out)"))
        return False
    return True


def _check_box(box: dict, errors: list) -> None:
    """A periodic box's rules between keys: upper above lower along each periodic axis, and the
    shear's and the pressure control's axes periodic (the shear's two different)."""
    periodic = box.get("periodic", "xyz")
    for a in periodic:
        d = "xyz".index(a)
        if not box["upper"][d] > box["lower"][d]:
            errors.append(("box.upper", box["upper"], f"must be above lower ({show(box['lower'])}) along "
                                                      f"the periodic axis {a}"))
            break

    def periodic_axis(path: str, axis: str) -> None:
        if axis not in periodic:
            errors.append((path, axis, f"the box is not periodic along {axis} (box.periodic = "
                                       f"{show(periodic)}): name a periodic axis, or add {axis} to "
                                       "box.periodic"))

    shear = box.get("shear")
    if shear is not None:
        flow, gradient = shear.get("flow", "x"), shear.get("gradient", "z")
        if flow == gradient:  # reported at the key given (the other is its default)
            key, other = ("gradient", "flow") if "gradient" in shear else ("flow", "gradient")
            given = "" if other in shear else f", {other}'s default"
            errors.append((f"box.shear.{key}", shear[key], f"must differ from the {other} axis "
                                                          f"({shear.get(other, flow)}{given})"))
        else:
            periodic_axis("box.shear.flow", flow)
            periodic_axis("box.shear.gradient", gradient)
    pressure = box.get("pressure")
    if pressure is not None:
        periodic_axis("box.pressure.axis", pressure.get("axis", "z"))


def wall_schedule(scene: dict, dt: float) -> list:
    """The motion changes of a checked scene's schedules as whole steps of ``dt``: a list of
    ``(step, wall, changes)`` in the order they apply, ``changes`` a dict of ``velocity``,
    ``angular_velocity``, ``center`` (3-tuples) and ``remove`` (True).

    An entry at time t acts at step ``round(t / dt)`` (the nearest whole step, half to even), as
    the simulation stands after that step: its change holds from that step on. A ramp of an
    entry at t over R seconds goes from step s0 = round(t / dt) to s1 = round((t + R) / dt):
    its n = s1 - s0 steps are cut into m = min(segments, n) segments, segment k from step
    s0 + floor(k n / m) to s0 + floor((k + 1) n / m), each with the linear ramp's mean over it
    (the value at its middle, so that a ramp moves a wall as far as the linear one); at s1 the
    target holds. A ramp shorter than half a step is a jump.
    """
    walls = _walls(scene)
    current = [{k: tuple(w.get(k, (0.0, 0.0, 0.0))) for k in _MOTION} for _, w in walls]
    changes = []  # (step, wall, order, key, value)
    entries = sorted(_schedule_entries(scene), key=lambda e: (e[0], e[2]["at"]))
    order = 0
    for wall, path, entry in entries:
        s0 = round(entry["at"] / dt)
        if entry.get("remove"):
            changes.append((s0, wall, order, "remove", True))
            order += 1
        if "center" in entry:
            changes.append((s0, wall, order, "center", tuple(entry["center"])))
            order += 1
        for key in _MOTION:
            if key not in entry:
                continue
            target = tuple(float(x) for x in entry[key])
            if "ramp" in entry:
                start = current[wall][key]
                s1 = round((entry["at"] + entry["ramp"]) / dt)
                n = s1 - s0
                m = min(entry.get("segments", RAMP_SEGMENTS), n)
                for k in range(m):
                    a, b = s0 + (k * n) // m, s0 + ((k + 1) * n) // m
                    fraction = (a + b - 2 * s0) / (2 * n)
                    value = tuple(x0 + (x1 - x0) * fraction for x0, x1 in zip(start, target))
                    changes.append((a, wall, order, key, value))
                    order += 1
                changes.append((s1, wall, order, key, target))
            else:
                changes.append((s0, wall, order, key, target))
            order += 1
            current[wall][key] = target
    changes.sort(key=lambda c: (c[0], c[1], c[2]))
    out: list = []
    for step, wall, _, key, value in changes:
        if not out or out[-1][0] != step or out[-1][1] != wall:
            out.append((step, wall, {}))
        out[-1][2][key] = value  # a later change of the same key at the same step wins
    return out


class WallSchedule:
    """The run hook that applies a scene's wall schedule (:func:`wall_schedule`): it acts only at
    the steps where a change is due, so the run goes on in the core between them.

    Parameters
    ----------
    changes : list
        ``(step, wall, changes)`` as :func:`wall_schedule` makes them.
    after : int
        Only the changes at steps >= ``after`` are applied (a scene's start), or, with
        ``resumed``, > ``after`` (a checkpoint of step ``after`` holds the changes made there).
    """

    # Over MPI ranks (tsubu.parallel), every rank's part of the scene takes the changes.
    acts_on_every_rank = True

    def __init__(self, changes: list, after: int = 0, resumed: bool = False):
        self.changes = [c for c in changes if c[0] > after or (c[0] == after and not resumed)]
        self.position = 0

    def next_step(self, sim) -> int | None:
        if self.position < len(self.changes):
            return max(self.changes[self.position][0], sim.step_count)
        return None

    def act(self, sim) -> None:
        now = sim.step_count
        while self.position < len(self.changes) and self.changes[self.position][0] <= now:
            _, wall, change = self.changes[self.position]
            if change.get("remove"):
                if not sim.wall(wall)["removed"]:
                    sim.remove_wall(wall)
            else:
                sim.set_wall_motion(wall, velocity=change.get("velocity"),
                                    angular_velocity=change.get("angular_velocity"),
                                    center=change.get("center"))
            self.position += 1

    def close(self, sim) -> None:
        pass

    def __repr__(self) -> str:
        return f"WallSchedule({len(self.changes) - self.position} changes to come)"


def _order(data: dict, path: str) -> tuple:
    """Sorts errors in the order of the file's top-level tables, then of their items."""
    top = re.match(r"[^.\[]*", path).group(0)
    keys = list(data)
    index = re.match(r"[^.\[]*\[(\d+)\]", path)
    return (keys.index(top) if top in keys else len(keys), int(index.group(1)) if index else -1)


@dataclasses.dataclass
class Scene:
    """A scene ready to run, as :func:`load_scene`, :func:`scene_from_dict` and :func:`resume`
    make it (not meant to be constructed by hand); :meth:`run` runs it.

    Attributes
    ----------
    simulation : tsubu.Simulation
        The Simulation, with its spheres, walls and inserters.
    end_time : float
        The simulated time [s] at which the run ends.
    output : list
        The hooks that write output (:mod:`tsubu.output` writers).
    checkpoint : dict or None
        The checkpoint settings (``path``, ``every`` in steps or None, ``keep``), or None.
    output_directory : str
        Where output and checkpoints go.
    data : dict
        The scene as read (JSON-able).
    directory : str
        The folder the scene's relative paths start from.
    source : str or None
        The scene file's name.
    schedule : WallSchedule or None
        The hook that applies the walls' schedules (it runs before the output writers, which
        see the walls as they are from that step on), or None without schedules.
    """

    simulation: Simulation
    end_time: float
    output: list
    checkpoint: dict | None
    output_directory: str
    data: dict
    directory: str
    source: str | None = None
    schedule: "WallSchedule | None" = None

    def metadata(self) -> dict:
        """What checkpoints carry so that ``tsubu resume`` can go on: the scene, its directory,
        the output directory and the end time."""
        return {"tsubu_scene": FORMAT_VERSION, "scene": self.data, "source": self.source,
                "directory": self.directory, "output_directory": self.output_directory,
                "end_time": self.end_time}

    def run(self, until: float | None = None, progress: bool | None = None) -> Simulation:
        """Run to simulated time ``until`` [s] (default :attr:`end_time`) with the scene's output
        and checkpoints; returns the Simulation. An ``until`` beyond :attr:`end_time` becomes the
        new end time (the one the checkpoints record, which ``tsubu resume`` runs to). A final
        checkpoint is written at the end when the scene has a [checkpoint] table. ``progress``
        is that of :meth:`tsubu.Simulation.run` (None: a bar on an interactive terminal). The run
        takes the whole number of steps nearest to ``until`` (none when the simulation is within
        half a step of it). Raises ValueError for an ``until`` more than half a step before the
        simulation's time (a run cannot go back), InstabilityError (the run went unstable) and
        KeyboardInterrupt (Ctrl-C; a checkpoint is written first when the scene has one)."""
        sim = self.simulation
        dt = sim.dt
        half_step = 0.5 * dt if math.isfinite(dt) else 0.0
        if until is not None:
            until = _checks.positive("until", until, allow_zero=True)
            if until < sim.time - half_step:
                raise ValueError(
                    f"until={until!r} s is before the simulation's time t = {sim.time!r} s (step "
                    f"{sim.step_count}): a run cannot go back in time; give an until after "
                    f"{sim.time!r} s, or run for a duration (tsubu resume --time)")
        end = self.end_time if until is None else until
        # a run taken beyond the scene's end moves it (what tsubu resume of its checkpoints reaches)
        self.end_time = max(self.end_time, end)
        remaining = max(0.0, end - sim.time)
        if math.isfinite(dt) and round(remaining / dt) == 0:
            remaining = 0.0  # the end is reached, to within the rounding to whole steps
        kwargs: dict = {"progress": progress}
        if self.checkpoint is not None:
            os.makedirs(os.path.dirname(self.checkpoint["path"]), exist_ok=True)
        hooks = ([self.schedule] if self.schedule is not None else []) + list(self.output)
        if hooks:
            kwargs["output"] = hooks
        if self.checkpoint is not None and self.checkpoint["every"] is not None:
            _attach_metadata(sim, self.metadata())  # for the run's periodic checkpoints
            kwargs.update(checkpoint=self.checkpoint["path"], checkpoint_every=self.checkpoint["every"],
                          checkpoint_keep=self.checkpoint["keep"])
        from .. import parallel
        if parallel.launched_ranks() > 1:
            return self._run_decomposed(remaining, kwargs)
        try:
            sim.run(time=remaining, **kwargs)
        except KeyboardInterrupt:
            self._save()
            raise
        self._save()
        return sim

    def _run_decomposed(self, remaining: float, kwargs: dict) -> Simulation:
        """The run under ``mpiexec`` (docs/parallel.md): the scene cut over the ranks, the wall
        schedule acting on every rank, output and checkpoints written by rank 0 from the whole
        scene gathered there. Afterwards rank 0's :attr:`simulation` is the whole scene (the
        others' hold their parts)."""
        from .. import parallel
        kwargs = dict(kwargs)
        kwargs.pop("progress", None)  # (no bar: the ranks would each draw one)
        part = parallel.decompose(self.simulation)
        part.run(time=remaining, **kwargs)
        whole = part.gather()
        if whole is not None:
            self.simulation = whole
            self._save()
        return self.simulation

    def _save(self) -> None:
        """The checkpoint of the run's end (or of a Ctrl-C), with the scene in its metadata (over
        the one the run may have written without it)."""
        if self.checkpoint is not None:
            self.simulation.save(self.checkpoint["path"], metadata=self.metadata())


def _attach_metadata(sim: Simulation, metadata: dict) -> None:
    """Make the run's own periodic checkpoints carry the scene's metadata, where the Simulation
    saves its ``metadata`` attribute by default."""
    try:
        sim.metadata = metadata
    except AttributeError:  # pragma: no cover - a Simulation without settable metadata
        pass


def load_scene(path, *, threads: int | None = None, output_directory=None) -> Scene:
    """Read, check and build the scene file at ``path`` (TOML; docs/scene-format.md).

    Parameters
    ----------
    path : str or path-like
        The scene file.
    threads : int or None
        Overrides ``simulation.threads``.
    output_directory : path or None
        Overrides ``output.directory`` (relative paths: to the current directory).

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        Naming the path and value of every bad, missing or unknown key.
    """
    source = os.fspath(path)
    data = read_toml(source)
    return scene_from_dict(data, directory=os.path.dirname(os.path.abspath(source)), source=source,
                           threads=threads, output_directory=output_directory)


def scene_from_dict(data: dict, directory=".", *, source: str | None = None, threads: int | None = None,
                    output_directory=None) -> Scene:
    """Build a :class:`Scene` from ``data``, a scene as a dict (a parsed TOML file); relative
    paths start at ``directory``. ``source`` (the file's name, or None) prefixes the errors;
    ``threads``, ``output_directory`` and the errors are as in :func:`load_scene`."""
    checked = validate(data, source)
    directory = os.path.abspath(os.fspath(directory))
    builder = _Builder(checked, directory, source)
    try:
        return builder.build(data, threads, output_directory)
    except SceneError:
        raise
    except (ValueError, TypeError) as e:  # a check this module does not know the path of
        raise SceneError([("", MISSING, str(e))], source) from None


class _Builder:
    """Turns a checked scene into tsubu objects, reporting their errors at the scene's paths."""

    def __init__(self, scene: dict, directory: str, source: str | None):
        self.scene = scene
        self.directory = directory
        self.source = source
        self.materials: dict = {}
        self.batches: list = []  # (positions, radii, material, velocities) of every block, for dt
        self.inserters: list = []
        self.pairs: list = []  # (material_a, material_b, overrides)

    def fail(self, path: str, value, message: str):
        raise SceneError([(path, value, message)], self.source)

    def call(self, path: str, given: dict, function: Callable, *args, **kwargs):
        """``function(*args, **kwargs)``, its ValueError or TypeError reported at ``path`` or,
        when the message starts with the name of one of the keys in ``given``, at that key."""
        try:
            return function(*args, **kwargs)
        except (ValueError, TypeError) as e:
            message = str(e)
            for key in sorted(given, key=len, reverse=True):
                if message.startswith(key + " ") or message.startswith(key + ":"):
                    rest = re.sub(r",? got .*$", "", message[len(key):].lstrip(" :"), flags=re.S)
                    self.fail(_join(path, key), given[key], rest or message)
            self.fail(path, MISSING, message)

    def build(self, data: dict, threads, output_directory) -> Scene:
        s = self.scene
        for name, fields in s["materials"].items():
            self.materials[name] = self.call(_join("materials", name), fields, Material, name=name, **fields)
        sim = self.simulation(s["simulation"], threads)
        for k, pair in enumerate(s.get("pairs", [])):
            overrides = {key: v for key, v in pair.items() if key != "materials"}
            a, b = (self.materials[n] for n in pair["materials"])
            self.call(f"pairs[{k}]", overrides, sim.set_pair, a, b, **overrides)
            self.pairs.append((a, b, overrides))
        for k, wall in enumerate(s.get("walls", [])):
            given = {key: v for key, v in wall.items() if key not in ("material", "name", "schedule")}
            self.call(f"walls[{k}]", given, sim.add_plane, material=self.materials[wall["material"]], **given)
        for k, mesh in enumerate(s.get("meshes", [])):
            self.mesh(sim, f"meshes[{k}]", mesh)
        for k, block in enumerate(s.get("particles", [])):
            self.particles(sim, f"particles[{k}]", block)
        for k, spec in enumerate(s.get("inserters", [])):
            self.inserter(sim, f"inserters[{k}]", spec)
        if "box" in s:
            self.box(sim, s["box"])
        for k, spec in enumerate(s.get("outlets", [])):
            given = {key: v for key, v in spec.items() if key != "shape"}
            self.call(f"outlets[{k}]", given, sim.add_outlet, **given)
        self.time_step(sim, s["simulation"])
        out_dir = self.output_directory(output_directory)
        end_time = sim.time + s["simulation"]["duration"]
        return Scene(simulation=sim, end_time=end_time, output=self.output_hooks(sim, out_dir),
                     checkpoint=self.checkpoint(sim, out_dir), output_directory=out_dir, data=data,
                     directory=self.directory, source=self.source,
                     schedule=self.schedule(sim, resumed=False))

    def schedule(self, sim: Simulation, resumed: bool) -> "WallSchedule | None":
        """The hook of the walls' schedules from the simulation's step on (None without any)."""
        changes = wall_schedule(self.scene, sim.dt)
        return WallSchedule(changes, sim.step_count, resumed) if changes else None

    def mesh(self, sim: Simulation, path: str, spec: dict) -> int:
        """Add the mesh wall of a [[meshes]] block; returns its wall index."""
        from .. import mesh as meshes
        motion = ("material", "velocity", "angular_velocity", "center", "name", "schedule")
        if "file" in spec:
            file = os.path.join(self.directory, spec["file"])
            where = _join(path, "file")
            if not os.path.isfile(file):
                self.fail(where, spec["file"], f"no such file ({file})")
            try:
                vertices, faces = meshes.read_mesh(file, scale=spec.get("scale", 1.0))
            except ImportError as e:
                self.fail(where, spec["file"], str(e))
            except (OSError, ValueError) as e:
                self.fail(where, spec["file"], str(e).replace(f"read_mesh: {file!r} ", "").strip(" :"))
            center = spec.get("center")
        else:
            generator = spec["generator"]
            given = {k: v for k, v in spec.items() if k not in motion and k != "generator"}
            if generator in ("cylinder", "square"):  # the shape's centre is the centre of rotation
                center = spec.get("center", [0.0, 0.0, 0.0])
                given["center"] = center
            else:
                center = spec.get("center")
            vertices, faces = self.call(path, given, getattr(meshes, generator), **given)
        given = {k: spec[k] for k in ("velocity", "angular_velocity") if k in spec}
        if center is not None:
            given["center"] = center
        return self.call(path, given, sim.add_mesh, vertices, faces,
                         material=self.materials[spec["material"]], **given)

    # -- parts --
    def simulation(self, options: dict, threads) -> Simulation:
        given = {k: v for k, v in options.items() if k not in ("duration", "dt_fraction", "dt")}
        if threads is not None:
            given["threads"] = threads
        sim = self.call("simulation", given, Simulation, **given)
        if "dt" in options:
            sim.dt = options["dt"]
        return sim

    def box(self, sim: Simulation, spec: dict) -> None:
        """The periodic box of ``[box]``, its shear and its pressure control, by the Simulation's
        own methods (set_box, set_shear, set_pressure), after the spheres: the pressure
        control's default cap is 0.01 over their contact duration."""
        given = {k: spec[k] for k in ("lower", "upper", "periodic") if k in spec}
        self.call("box", given, sim.set_box, **given)
        if "shear" in spec:
            self.call("box.shear", spec["shear"], sim.set_shear, **spec["shear"])
        if "pressure" in spec:
            pressure = spec["pressure"]
            if "max_strain_rate" not in pressure and sim.size == 0:
                self.fail("box.pressure.max_strain_rate", MISSING,
                          "required when the scene has no particles blocks (the default is 0.01 / "
                          "the contact duration of their spheres)")
            self.call("box.pressure", pressure, sim.set_pressure, **pressure)

    def time_step(self, sim: Simulation, options: dict) -> None:
        """Fix dt for the whole run (a default evaluated at each run's start would change as
        inserters add spheres): dt, or dt_fraction of the contact duration of the scene's spheres
        and the smallest spheres its inserters make."""
        if "dt" in options:
            return
        probe = sim if not self.inserters else self.probe(sim)
        if probe.size == 0:
            self.fail("simulation.dt", MISSING, "required when the scene has no particles and no "
                                                "inserters (there is no contact to derive it from)")
        try:
            if "dt_fraction" in options:
                dt = options["dt_fraction"] * probe.contact_duration()
            else:
                dt = probe.default_time_step()
        except (ValueError, RuntimeError) as e:
            self.fail("simulation", MISSING, f"cannot choose the time step: {e}")
        if not (math.isfinite(dt) and dt > 0):
            self.fail("simulation.dt_fraction" if "dt_fraction" in options else "simulation", MISSING,
                      f"the scene's contact duration gives dt = {dt!r}: give simulation.dt")
        sim.dt = dt

    def probe(self, sim: Simulation) -> Simulation:
        """A Simulation with the scene's options, walls and spheres plus, for each inserter, two
        spheres of its smallest radius at its velocity (two: an inserter's spheres meet each
        other, and the lightest pair bounds the contact duration): what the run will have to
        resolve."""
        options = self.scene["simulation"]
        probe = Simulation(**{k: v for k, v in options.items() if k not in ("duration", "dt_fraction", "dt")})
        for a, b, overrides in self.pairs:
            probe.set_pair(a, b, **overrides)
        for k in range(sim.wall_count):
            wall = sim.wall(k)
            if wall["removed"]:
                continue
            if wall["kind"] == "mesh":
                probe.add_mesh(wall["vertices"], wall["faces"], material=wall["material"])
            else:
                probe.add_plane(point=wall["point"], normal=wall["normal"], material=wall["material"])
        for positions, radii, material, velocities in self.batches:
            probe.add_spheres(positions, radii, material, velocities=velocities)
        for spec, sizes in self.inserters:
            for _ in range(2):
                offset = 1e3 * (1 + probe.size) * sizes.max_radius  # apart from everything else
                probe.add_sphere([offset, offset, offset], sizes.min_radius,
                                 self.materials[spec["material"]], velocity=spec.get("velocity"))
        return probe

    def region(self, path: str, spec: dict):
        fill = _fill()
        given = {k: v for k, v in spec.items() if k != "shape"}
        if spec["shape"] == "box":
            return self.call(path, given, fill.Box, **given)
        return self.call(path, given, fill.Cylinder, **given)

    def sizes(self, path: str, spec: dict):
        fill = _fill()
        given = {k: v for k, v in spec.items() if k != "distribution"}
        cls = {"monodisperse": "Monodisperse", "uniform": "Uniform", "normal": "Normal",
               "lognormal": "LogNormal", "tabulated": "Tabulated"}[spec["distribution"]]
        return self.call(path, given, getattr(fill, cls), **given)

    def particles(self, sim: Simulation, path: str, block: dict) -> None:
        generator = block["generator"]
        velocities = angular = None
        if generator == "file":
            positions, radii, velocities, angular, materials = self.read_particles(path, block)
        else:
            fill = _fill()
            region = self.region(_join(path, "region"), block["region"])
            skip = ("generator", "material", "region", "velocity", "angular_velocity", "fixed")
            given = {k: v for k, v in block.items() if k not in skip}
            if generator == "lattice":
                packing = self.call(path, given, fill.lattice, region, **given)
            else:
                given["sizes"] = self.sizes(_join(path, "sizes"), block["sizes"])
                packing = self.call(path, given, fill.random_packing, region, **given)
            positions, radii = packing.positions, packing.radii
            n = len(radii)
            if n == 0:
                self.fail(path, MISSING, "the generator placed no spheres (is the region smaller "
                                         "than one sphere?)")
            if "velocity" in block:
                velocities = np.tile(block["velocity"], (n, 1))
            if "angular_velocity" in block:
                angular = np.tile(block["angular_velocity"], (n, 1))
            materials = [(0, n, self.materials[block["material"]])]
        for start, stop, material in materials:  # runs of one material, in the file's order
            part = slice(start, stop)
            v = None if velocities is None else velocities[part]
            w = None if angular is None else angular[part]
            ids = self.call(path, {}, sim.add_spheres, positions[part], radii[part], material,
                            velocities=v, angular_velocities=w)
            if block.get("fixed", False):  # the block's motion, prescribed (a file's: glued)
                motion = {k: block[k] for k in ("velocity", "angular_velocity") if k in block}
                self.call(path, motion, sim.fix_spheres, ids, **motion)
            self.batches.append((positions[part], radii[part], material, v))

    def read_particles(self, path: str, block: dict):
        """Positions, radii, velocities and angular velocities of a file of tsubu.output."""
        file = os.path.join(self.directory, block["path"])
        where = _join(path, "path")
        if not os.path.isfile(file):
            self.fail(where, block["path"], f"no such file ({file})")
        try:
            columns = _read_columns(file)
        except (OSError, ValueError) as e:
            self.fail(where, block["path"], f"cannot read {file}: {e}")
        found = {}
        for name, aliases, width in _PARTICLE_COLUMNS:
            found[name] = _column(columns, aliases, width)
        if found["positions"] is None or found["radii"] is None:
            self.fail(where, block["path"], f"{file} has no positions and radii (found: "
                                            f"{', '.join(sorted(columns)) or 'nothing'})")
        if not block.get("velocities", True):
            found["velocities"] = found["angular_velocities"] = None
        n = len(found["radii"])
        if "material" in block:
            materials = [(0, n, self.materials[block["material"]])]
        else:
            materials = self.file_materials(path, block, columns, n)
        return (found["positions"], found["radii"], found["velocities"], found["angular_velocities"],
                materials)

    def file_materials(self, path: str, block: dict, columns: dict, n: int) -> list:
        """(start, stop, Material) of the runs of spheres of one material that a file names."""
        if "material" not in columns or "material_names" not in columns:
            self.fail(_join(path, "material"), MISSING, f"required: {block['path']} does not name its "
                                                        "spheres' materials (material and material_names "
                                                        "arrays of tsubu.output.save_npz)")
        names = [str(x) for x in np.asarray(columns["material_names"]).reshape(-1)]
        index = np.asarray(columns["material"]).reshape(-1)
        if len(index) != n or not np.all((index >= 0) & (index < len(names))):
            self.fail(_join(path, "path"), block["path"], "its material array does not index its "
                                                          "material_names")
        unknown = sorted({names[k] for k in set(index.tolist())} - set(self.materials))
        if unknown:
            self.fail(_join(path, "path"), block["path"],
                      f"its spheres have materials {', '.join(map(repr, unknown))}, not in [materials] "
                      f"(defined: {', '.join(self.materials)}); name them so, or give {path}.material")
        cuts = [0] + [k for k in range(1, n) if index[k] != index[k - 1]] + [n]
        return [(a, b, self.materials[names[index[a]]]) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]

    def inserter(self, sim: Simulation, path: str, spec: dict) -> None:
        region = self.region(_join(path, "region"), spec["region"])
        sizes = self.sizes(_join(path, "sizes"), spec["sizes"])
        given = {k: v for k, v in spec.items() if k not in ("region", "sizes", "rate", "material")}
        total = given.get("total")
        if given.get("basis", "number") == "number" and total is not None and float(total).is_integer():
            given["total"] = int(total)  # a count (TOML's 600 reaches here as the number 600.0)
        inserter = self.call(path, {"rate": spec["rate"], **given}, sim.add_inserter, region, spec["rate"],
                             sizes, self.materials[spec["material"]], **given)
        self.inserters.append((spec, sizes))
        return inserter

    def output_directory(self, override) -> str:
        if override is not None:
            return os.path.abspath(os.fspath(override))
        return os.path.join(self.directory, self.scene.get("output", {}).get("directory", "output"))

    def steps(self, sim: Simulation, spec: dict) -> int:
        if "every" in spec:
            return spec["every"]
        return max(1, int(round(spec["interval"] / sim.dt)))

    def output_hooks(self, sim: Simulation, directory: str) -> list:
        output = self.scene.get("output", {})
        hooks = []
        writers = [key for key in ("vtk", "npz", "csv") if key in output]
        if not writers:
            return hooks
        out = _output()
        for key in writers:
            spec = output[key]
            options = {k: v for k, v in spec.items() if k not in ("every", "interval")}
            cls = {"vtk": out.VTKOutput, "npz": out.NpzOutput, "csv": out.CSVOutput}[key]
            try:
                hooks.append(self.call(_join("output", key), options, cls, directory, self.steps(sim, spec),
                                       **options))
            except ImportError as e:  # an optional dependency of the writer (pyevtk)
                self.fail(_join("output", key), MISSING, str(e))
        return hooks

    def checkpoint(self, sim: Simulation, directory: str) -> dict | None:
        spec = self.scene.get("checkpoint")
        if spec is None:
            return None
        every = self.steps(sim, spec) if ("every" in spec or "interval" in spec) else None
        return {"path": os.path.join(directory, spec.get("path", "checkpoint.tsubu")), "every": every,
                "keep": spec.get("keep", 3)}


# Names a particle file's columns may have: tsubu.output's first, then common spellings. A
# vector is one (N, 3) array (npz) or three columns NAME_x, NAME_y, NAME_z (CSV).
_PARTICLE_COLUMNS = (
    ("positions", ("positions", "position", ""), 3),
    ("radii", ("radii", "radius", "r"), 1),
    ("velocities", ("velocities", "velocity", "v"), 3),
    ("angular_velocities", ("angular_velocities", "angular_velocity", "omega", "w"), 3),
)


def _read_columns(file: str) -> dict:
    """The arrays of an .npz file, or the columns of a CSV file with a header line (vector
    columns as ``name_x``, ``name_y``, ``name_z`` or ``name[0]``...), by name."""
    if file.endswith(".npz"):
        with np.load(file, allow_pickle=False) as z:
            return {k: np.asarray(z[k]) for k in z.files}
    if file.endswith(".csv"):
        table = np.genfromtxt(file, delimiter=",", names=True, dtype=float, comments="#",
                              encoding="utf-8", ndmin=1)
        if table.dtype.names is None:
            raise ValueError("no header line")
        return {n: np.atleast_1d(table[n]) for n in table.dtype.names}
    raise ValueError("the file must end in .npz or .csv")


def _column(columns: dict, aliases, width: int):
    for name in aliases:
        if width == 1 and name in columns:
            return np.asarray(columns[name], dtype=float).reshape(-1)
        if width == 3 and name in columns and np.ndim(columns[name]) == 2:
            return np.asarray(columns[name], dtype=float).reshape(-1, 3)
        for x, y, z in ((f"{name}_x", f"{name}_y", f"{name}_z"), (f"{name}x", f"{name}y", f"{name}z")):
            if width == 3 and x in columns and y in columns and z in columns:
                return np.stack([columns[x], columns[y], columns[z]], axis=1).astype(float)
    return None


def _fill():
    from .. import fill
    return fill


def _output():
    from .. import output
    return output


# ---- resume ------------------------------------------------------------------------------------

def resume(checkpoint, *, threads: int | None = None, output_directory=None) -> Scene:
    """The :class:`Scene` of a checkpoint written by a scene run (``tsubu run``): the Simulation as
    saved, with the scene's output and checkpoint settings, and the end time it was to reach.
    ``threads`` and ``output_directory`` override the saved ones, as in :func:`load_scene`.
    Raises SceneError for a ``checkpoint`` that was not written by a scene run (or whose scene no
    longer checks), and whatever ``Simulation.load`` raises for a bad file
    (:class:`tsubu.checkpoint.CheckpointError`)."""
    source = os.fspath(checkpoint)
    sim = Simulation.load(source)
    meta = getattr(sim, "metadata", None) or {}
    if not isinstance(meta, dict) or meta.get("tsubu_scene") is None or "scene" not in meta:
        raise SceneError([("", MISSING, "this checkpoint was not written by a scene run (tsubu run): "
                                        "it has no scene to resume (load it with tsubu.Simulation.load)")],
                         source)
    version = meta["tsubu_scene"]
    if not isinstance(version, int) or not isinstance(meta.get("end_time"), (int, float)):
        raise SceneError([("", MISSING, "this checkpoint's scene metadata is not tsubu's (tsubu_scene "
                                        f"= {version!r}, end_time = {meta.get('end_time')!r})")], source)
    if version > FORMAT_VERSION:
        raise SceneError([("", MISSING, f"this checkpoint's scene has format version {meta['tsubu_scene']}, "
                                        f"newer than this tsubu's ({FORMAT_VERSION}): upgrade tsubu")], source)
    checked = validate(meta["scene"], source)
    builder = _Builder(checked, meta.get("directory", "."), source)
    if threads is not None:
        sim.threads = threads
    out_dir = output_directory if output_directory is not None else meta.get("output_directory")
    out_dir = builder.output_directory(out_dir)
    return Scene(simulation=sim, end_time=float(meta["end_time"]), output=builder.output_hooks(sim, out_dir),
                 checkpoint=builder.checkpoint(sim, out_dir), output_directory=out_dir, data=meta["scene"],
                 directory=builder.directory, source=meta.get("source"),
                 schedule=builder.schedule(sim, resumed=True))

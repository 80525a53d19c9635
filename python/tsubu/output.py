"""Output of a Simulation's state: VTK XML files for ParaView, and CSV / npz dumps for scripts.

Hooks for ``Simulation.run(..., output=...)`` (the run-loop contract, ``tsubu.hooks``), each
writing a frame every ``every`` steps:

- :class:`VTKOutput`: particles (``.vtu``), the contact network (``.vtp``, one line per
  contact) and the walls (``.vtp``, one rectangle per plane, and one ``.vtp`` per mesh wall
  with its triangles where they are now; in a periodic box, its outline), each with a ``.pvd``
  time series that ParaView opens as one animated data set;
- :class:`NpzOutput`, :class:`CSVOutput`: the same particle (and contact) arrays as numpy
  ``.npz`` archives or CSV tables.

And one frame at a time: :func:`write_vtk`, :func:`save_npz`, :func:`save_csv`. The arrays
themselves, as dicts of numpy arrays, come from :func:`particle_data`, :func:`contact_data`
and :func:`wall_data`, :func:`mesh_data`. ``docs/output.md`` describes every file and array.

The VTK files are written with pyevtk (an optional dependency: ``pip install 'tsubu[vtk]'``);
the CSV and npz dumps need only numpy.
"""

from __future__ import annotations

import csv
import errno
import math
import os
import re
import tempfile
import weakref
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .checkpoint import _folder_error, sync_folder

__all__ = [
    "VTKOutput", "NpzOutput", "CSVOutput", "write_vtk", "save_npz", "save_csv",
    "particle_data", "contact_data", "wall_data", "mesh_data", "scene_extent",
]

_INSTALL_HINT = "install it with: pip install 'tsubu[vtk]'"


def _pyevtk_vtk():
    """pyevtk's low-level writer module, or ImportError saying how to install it."""
    try:
        from pyevtk import vtk
    except ImportError as e:
        raise ImportError(f"tsubu's VTK output needs the package pyevtk: {_INSTALL_HINT}") from e
    return vtk


# ---- the arrays --------------------------------------------------------------------------------

def _ids(sim) -> np.ndarray:
    """Each row's sphere id (``sim.ids``; row = id for an object without them)."""
    ids = getattr(sim, "ids", None)
    return np.arange(sim.size, dtype=np.int64) if ids is None else np.asarray(ids, dtype=np.int64)


def _coordination(ids: np.ndarray, contacts: dict) -> np.ndarray:
    """Contacts per sphere (rows of ``ids``): a pair counts for both spheres, a wall contact for
    its sphere."""
    size = len(ids)
    i, j = np.asarray(contacts["i"], dtype=np.int64), np.asarray(contacts["j"], dtype=np.int64)
    i, j = np.searchsorted(ids, i), np.searchsorted(ids, j[j >= 0])  # ids to rows
    return (np.bincount(i, minlength=size) + np.bincount(j, minlength=size)).astype(np.int64)


def particle_data(sim, contacts: dict | None = None) -> dict:
    """The per-sphere arrays that the writers store, in id order (row k = sphere ``id[k]``;
    row = id until a sphere is removed).

    Keys: ``id`` (N,) int64, ``sim.ids``; ``position`` [m], ``velocity`` [m/s], ``angular_velocity``
    [rad/s], ``force`` [N] and ``torque`` [N m] of the last step, each (N, 3) float64;
    ``radius`` [m] and ``mass`` [kg] (N,) float64; ``material`` (N,) int64, the index into
    ``sim.materials``; ``coordination`` (N,) int64, the number of contacts of each sphere in
    ``sim.contacts()`` (a pair counts for both spheres, a wall contact for its sphere).
    ``contacts``: the dict of ``sim.contacts()`` when already at hand.
    """
    contacts = sim.contacts() if contacts is None else contacts
    ids = np.array(_ids(sim))
    return {
        "id": ids,
        "position": sim.positions,
        "velocity": sim.velocities,
        "angular_velocity": sim.angular_velocities,
        "radius": sim.radii,
        "mass": sim.masses,
        "material": sim.material_ids,
        "force": sim.forces,
        "torque": sim.torques,
        "coordination": _coordination(ids, contacts),
    }


def contact_data(sim, contacts: dict | None = None, positions=None) -> dict:
    """The contact network: one row per touching contact of ``sim.contacts()``, in its order.

    Keys: ``i``, ``j`` (-1 for a wall), ``wall`` (-1 for a pair) (M,) int64; ``overlap`` [m]
    (M,); ``start``, ``end`` [m] (M, 3): the centre of sphere i and that of sphere j (in a
    periodic box, j's image nearest i, outside the box for a contact across a face), or for a
    wall contact the point of the wall nearest the centre of i (a mesh's: of the contact's
    triangle; with ``positions`` given, planes only); ``normal`` (M, 3): the unit
    vector from ``start`` to ``end`` (the centre-to-centre direction; a rough contact's tilted
    normal is not shown separately); ``force`` [N] (M, 3): the contact's force on sphere i;
    ``normal_force`` [N] (M,): -F.n, positive when the contact pushes the spheres apart;
    ``normal_force_vector`` [N] (M, 3): (F.n) n; ``tangential_force`` [N] (M, 3):
    F - (F.n) n.

    The forces are those of the last force evaluation (the start of the last step, see
    ``Simulation.contacts``); ``start``, ``end`` and ``normal`` use the current positions
    (``positions``, when given, instead of ``sim.positions``) and planes.
    """
    contacts = sim.contacts() if contacts is None else contacts
    x = sim.positions if positions is None else positions
    i = np.asarray(contacts["i"], dtype=np.int64)
    j = np.asarray(contacts["j"], dtype=np.int64)
    wall = np.asarray(contacts["wall"], dtype=np.int64)
    force = np.asarray(contacts["force"], dtype=np.float64).reshape(-1, 3)
    ids = _ids(sim)  # contacts name ids; the positions are by row
    start = x[np.searchsorted(ids, i)]
    end = x[np.searchsorted(ids, np.maximum(j, 0))]
    if positions is None and "branch" in contacts:  # j's image nearest i: across a periodic face
        pairs = np.flatnonzero(j >= 0)
        end[pairs] = start[pairs] + np.asarray(contacts["branch"], dtype=np.float64).reshape(-1, 3)[pairs]
    walls = np.flatnonzero(j < 0)
    if walls.size:
        if positions is None and "wall_point" in contacts:  # (a mesh's: its nearest triangle)
            end[walls] = np.asarray(contacts["wall_point"], dtype=np.float64).reshape(-1, 3)[walls]
        else:
            planes = [sim.wall(k) for k in range(sim.wall_count)]
            point = np.array([p.get("point", p["center"]) for p in planes])[wall[walls]]
            normal = np.array([p.get("normal", (0.0, 0.0, 1.0)) for p in planes])[wall[walls]]
            height = np.einsum("ij,ij->i", start[walls] - point, normal)
            end[walls] = start[walls] - height[:, None] * normal
    gap = end - start
    length = np.sqrt(np.einsum("ij,ij->i", gap, gap))
    # Two centres at one point have no direction: their normal is left zero, never NaN.
    with np.errstate(invalid="ignore", divide="ignore"):
        n = np.where(length[:, None] > 0, gap / length[:, None], 0.0)
    f_dot_n = np.einsum("ij,ij->i", force, n)
    normal_vector = f_dot_n[:, None] * n
    return {
        "i": i, "j": j, "wall": wall,
        "overlap": np.asarray(contacts["overlap"], dtype=np.float64),
        "start": start, "end": end, "normal": n, "force": force,
        "normal_force": -f_dot_n,
        "normal_force_vector": normal_vector,
        "tangential_force": force - normal_vector,
    }


def scene_extent(sim, margin: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The box (lower, upper) [m] that the wall rectangles of the Simulation ``sim`` cover: the
    spheres' bounding box (centres +- the largest radius) joined with the planes' points and
    the mesh walls' vertices, widened on every side by ``margin`` [m] (default: a tenth of the
    box's largest side, at least 2 largest radii; 1 m for an empty scene)."""
    points = [np.array(sim.plane(k)["point"]) for k in range(sim.plane_count)]
    points += [p for mesh in _mesh_walls(sim) for p in (mesh["vertices"].min(axis=0),
                                                         mesh["vertices"].max(axis=0))]
    lower = np.full(3, np.inf)
    upper = np.full(3, -np.inf)
    r_max = 0.0
    if sim.size:
        x = sim.positions
        r_max = float(sim.radii.max())
        lower = np.minimum(lower, x.min(axis=0) - r_max)
        upper = np.maximum(upper, x.max(axis=0) + r_max)
    for p in points:
        lower = np.minimum(lower, p)
        upper = np.maximum(upper, p)
    if not np.all(np.isfinite(lower)):
        lower, upper = np.zeros(3), np.zeros(3)
    if margin is None:
        margin = max(0.1 * float(np.max(upper - lower)), 2.0 * r_max)
        if margin == 0.0:
            margin = 1.0
    margin = float(margin)
    if not (math.isfinite(margin) and margin >= 0):
        raise ValueError(f"margin must be a finite number >= 0, got {margin!r}")
    return lower - margin, upper + margin


def _check_extent(extent) -> tuple[np.ndarray, np.ndarray]:
    try:
        lower, upper = (np.asarray(e, dtype=np.float64) for e in extent)
    except (TypeError, ValueError):
        raise TypeError(f"extent must be (lower, upper), two 3-vectors [m], got {extent!r}") from None
    if lower.shape != (3,) or upper.shape != (3,) or not (np.all(np.isfinite(lower))
                                                          and np.all(np.isfinite(upper))):
        raise ValueError(f"extent must be (lower, upper), two finite 3-vectors [m], got {extent!r}")
    if not np.all(lower <= upper):
        raise ValueError(f"extent: lower must be <= upper in x, y and z, got {extent!r}")
    return lower, upper


def _plane_axes(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors u, v in the plane with (u, v, n) right-handed, u as close to a
    coordinate axis as the normal allows (a floor's rectangle has x and y edges)."""
    axis = np.zeros(3)
    axis[int(np.argmin(np.abs(normal)))] = 1.0
    u = axis - (axis @ normal) * normal
    u /= np.sqrt(u @ u)
    return u, np.cross(normal, u)


def wall_data(sim, extent=None) -> dict:
    """Each plane wall as a rectangle in its own plane: the smallest rectangle, with edges along
    the plane axes u, v (``_plane_axes``), that covers the orthogonal projection of the box
    ``extent`` = (lower, upper) [m] (default :func:`scene_extent`), so that every sphere's
    projection onto the wall lies inside it.

    Keys: ``corners`` [m] (W, 4, 3), counter-clockwise seen from the side the normal points to;
    ``wall`` (W,) int64; ``material`` (W,) int64 (index into ``sim.materials``); ``point`` [m],
    ``normal``, ``velocity`` [m/s], ``angular_velocity`` [rad/s] (W, 3): the plane's state;
    ``corner_velocity`` [m/s] (W, 4, 3): the wall's velocity at each corner, v + w x (c - point).
    """
    lower, upper = scene_extent(sim) if extent is None else _check_extent(extent)
    count = sim.plane_count
    box = np.array([[(lower, upper)[a][0], (lower, upper)[b][1], (lower, upper)[c][2]]
                    for a in (0, 1) for b in (0, 1) for c in (0, 1)])
    materials = sim.materials
    data = {k: np.zeros((count, 3)) for k in ("point", "normal", "velocity", "angular_velocity")}
    data["corners"] = np.zeros((count, 4, 3))
    data["corner_velocity"] = np.zeros((count, 4, 3))
    data["wall"] = np.arange(count, dtype=np.int64)
    data["material"] = np.zeros(count, dtype=np.int64)
    for k in range(count):
        plane = sim.plane(k)
        p, n = plane["point"], plane["normal"]
        u, v = _plane_axes(n)
        a, b = (box - p) @ u, (box - p) @ v
        corners = np.array([p + a.min() * u + b.min() * v, p + a.max() * u + b.min() * v,
                            p + a.max() * u + b.max() * v, p + a.min() * u + b.max() * v])
        data["corners"][k] = corners
        data["corner_velocity"][k] = plane["velocity"] + np.cross(plane["angular_velocity"], corners - p)
        for key in ("point", "normal", "velocity", "angular_velocity"):
            data[key][k] = plane[key]
        data["material"][k] = next(m for m, mat in enumerate(materials) if mat is plane["material"])
    return data


def _mesh_walls(sim) -> list[dict]:
    """``sim.wall(k)`` of each mesh wall not removed, with its index as ``"index"``, in index
    order; none for a Simulation without ``wall_count`` (a build before mesh walls)."""
    found = []
    for k in range(getattr(sim, "wall_count", 0)):
        wall = sim.wall(k)
        if wall["kind"] == "mesh" and not wall["removed"]:
            found.append(dict(wall, index=k,
                              vertices=np.asarray(wall["vertices"], dtype=np.float64).reshape(-1, 3)))
    return found


def mesh_data(sim) -> list[dict]:
    """The mesh walls of the Simulation ``sim`` as they are now, one dict per mesh wall that
    has not been removed, in wall-index order.

    Keys: ``wall`` (int), the wall's index (as in ``sim.wall(k)``); ``material`` (int), the
    index into ``sim.materials``; ``vertices`` [m] (V, 3) float64, the current vertices in the
    world frame; ``faces`` (F, 3) int64; ``normal`` (F, 3), each triangle's unit normal
    (right-hand rule of its vertex order); ``vertex_velocity`` [m/s] (V, 3), the wall's
    velocity at each vertex, v + w x (x - center); ``center`` [m], ``velocity`` [m/s],
    ``angular_velocity`` [rad/s] (3,): the wall's motion.
    """
    materials = sim.materials
    found = []
    for wall in _mesh_walls(sim):
        x = wall["vertices"]
        faces = np.asarray(wall["faces"], dtype=np.int64).reshape(-1, 3)
        center, v, w = (np.asarray(wall[key], dtype=np.float64)
                        for key in ("center", "velocity", "angular_velocity"))
        a, b, c = x[faces[:, 0]], x[faces[:, 1]], x[faces[:, 2]]
        normal = np.cross(b - a, c - a)
        length = np.linalg.norm(normal, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            normal = np.where(length[:, None] > 0, normal / length[:, None], 0.0)
        found.append({
            "wall": wall["index"],
            "material": next(m for m, mat in enumerate(materials) if mat is wall["material"]),
            "vertices": x, "faces": faces, "normal": normal,
            "vertex_velocity": v + np.cross(w, x - center),
            "center": center, "velocity": v, "angular_velocity": w,
        })
    return found


def _box_outline(sim) -> dict | None:
    """The periodic box of ``sim`` (``sim.box``) as 12 edges between its 8 corners, or None for
    an open scene: ``corners`` [m] (8, 3), corner k at (lower or upper by bit 0, 1, 2 of k);
    ``edges`` (12, 2) int64, corner indices; per edge ``axis`` (12,) int64, 0, 1, 2 for x, y, z,
    and ``periodic`` (12,) int64, 1 along a periodic axis."""
    box = getattr(sim, "box", None)
    if box is None:
        return None
    lo, hi = np.asarray(box.lower, dtype=np.float64), np.asarray(box.upper, dtype=np.float64)
    corners = np.array([[(hi if k >> a & 1 else lo)[a] for a in range(3)] for k in range(8)])
    edges = [(k, k | 1 << a, a) for k in range(8) for a in range(3) if not k >> a & 1]
    return {"corners": corners,
            "edges": np.array([(i, j) for i, j, _ in edges], dtype=np.int64),
            "axis": np.array([a for _, _, a in edges], dtype=np.int64),
            "periodic": np.array(["xyz"[a] in box.periodic for _, _, a in edges], dtype=np.int64)}


# ---- VTK XML files (pyevtk) ----------------------------------------------------------------------

class _VTKWriter:
    """One VTK XML file with its arrays in pyevtk's raw appended binary section.

    pyevtk writes the XML (elements, array headers and their offsets, byte order, UInt64 block
    sizes); the blocks themselves are written here with numpy's ``tobytes``: pyevtk packs 3-vector
    blocks one value at a time in Python (0.4 s for 1e5 spheres' two vectors), numpy writes the
    same bytes (C order of an (n, 3) array = x0 y0 z0 x1 ...) at memory speed."""

    def __init__(self, vtk, path_without_extension: str, kind):
        self.vtk = vtk
        self.file = vtk.VtkFile(path_without_extension, kind)
        self.blocks: list[np.ndarray] = []

    def header(self, name: str, array: np.ndarray) -> None:
        array = np.ascontiguousarray(array)
        components = 1 if array.ndim == 1 else array.shape[1]
        self.file.addHeader(name, array.dtype.name, array.shape[0], components)
        self.blocks.append(array)

    def field_data(self, arrays: dict) -> None:
        """The data set's FieldData: pyevtk leaves out NumberOfTuples, without which VTK's
        readers (ParaView) read field arrays as empty, so these headers are written here."""
        self.file.openElement("FieldData")
        for name, array in arrays.items():
            vtk_type = self.vtk.np_to_vtk[array.dtype.name]
            self.file.xml.openElement("DataArray").addAttributes(
                Name=name, NumberOfTuples=array.shape[0], NumberOfComponents=1, type=vtk_type.name,
                format="appended", offset=self.file.offset)
            self.file.xml.closeElement()
            self.file.offset += array.nbytes + 8  # the block and its UInt64 size
            self.blocks.append(array)
        self.file.closeElement("FieldData")

    def section(self, element: str, arrays: dict) -> None:
        if not arrays:
            return
        self.file.openElement(element)
        for name, array in arrays.items():
            self.header(name, array)
        self.file.closeElement(element)

    def save(self) -> None:
        from pyevtk.evtk import writeBlockSize

        self.file.openAppendedData()
        stream = self.file.xml.stream
        for block in self.blocks:
            writeBlockSize(stream, block.nbytes)
            stream.write(block.tobytes())
        self.file.save()


def _write_atomically(final_path: str, write) -> None:
    """``write(path_without_extension)`` writes a file there (pyevtk adds the extension); it is
    moved over ``final_path`` only once complete and on disk, so that a reader (or a run killed
    meanwhile) never sees half a file."""
    directory, base = os.path.split(final_path)
    stem, extension = os.path.splitext(base)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{stem}.", suffix=extension, dir=directory or ".")
    except OSError as e:  # said of final_path, not of the temporary file
        raise _folder_error(e, Path(final_path), Path(directory or ".")) from None
    os.close(fd)
    try:
        write(tmp[: -len(extension)])
        _fsync(tmp)
        os.replace(tmp, final_path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    sync_folder(directory or ".")  # the rename itself survives a crash


def _fsync(path: str) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _field_data(sim) -> dict:
    # ParaView shows TimeValue as the data set's time when a file is opened on its own.
    return {"TimeValue": np.array([sim.time], dtype=np.float64),
            "step": np.array([sim.step_count], dtype=np.int64)}


def _write_piece(vtk, path: str, grid, sim, counts: dict, sections: dict, location: str,
                 scalars: str, vectors: str, arrays: dict) -> None:
    """One VTK XML file of one piece: its counts (``npoints``, ``ncells``, ...), its geometry
    sections in order, and the data arrays at ``location`` ("Point" or "Cell")."""
    w = _VTKWriter(vtk, path, grid)
    w.file.openGrid()
    w.field_data(_field_data(sim))
    w.file.openPiece(**{k: str(v) for k, v in counts.items()})  # strings: pyevtk drops a count of 0
    for section, values in sections.items():
        w.section(section, values)
    w.file.openData(location, scalars=scalars, vectors=vectors)
    for key, values in arrays.items():
        w.header(key, values)
    w.file.closeData(location)
    w.file.closePiece()
    w.file.closeGrid()
    w.save()


def _write_particles(vtk, path: str, sim, particles: dict) -> None:
    n = particles["id"].shape[0]
    _write_piece(vtk, path, vtk.VtkUnstructuredGrid, sim, {"npoints": n, "ncells": n}, {
        "Points": {"points": particles["position"]},
        "Cells": {"connectivity": np.arange(n, dtype=np.int64),
                  "offsets": np.arange(1, n + 1, dtype=np.int64),
                  "types": np.full(n, vtk.VtkVertex.tid, dtype=np.uint8)},
    }, "Point", "radius", "velocity", {key: particles[key] for key in (
        "id", "velocity", "angular_velocity", "radius", "mass", "material", "force", "torque",
        "coordination")})


def _write_contacts(vtk, path: str, sim, network: dict) -> None:
    m = network["i"].shape[0]
    _write_piece(vtk, path, vtk.VtkPolyData, sim, {"npoints": 2 * m, "nlines": m}, {
        "Points": {"points": np.stack([network["start"], network["end"]], axis=1).reshape(-1, 3)},
        "Lines": {"connectivity": np.arange(2 * m, dtype=np.int64),
                  "offsets": np.arange(2, 2 * m + 1, 2, dtype=np.int64)},
    }, "Cell", "normal_force", "force", {key: network[key] for key in (
        "normal_force", "normal_force_vector", "tangential_force", "force", "overlap", "normal",
        "i", "j", "wall")})


def _write_walls(vtk, path: str, sim, walls: dict) -> None:
    count = walls["wall"].shape[0]
    _write_piece(vtk, path, vtk.VtkPolyData, sim, {"npoints": 4 * count, "npolys": count}, {
        "Points": {"points": walls["corners"].reshape(-1, 3)},
        "Polys": {"connectivity": np.arange(4 * count, dtype=np.int64),
                  "offsets": np.arange(4, 4 * count + 1, 4, dtype=np.int64)},
        "PointData": {"velocity": walls["corner_velocity"].reshape(-1, 3)},
    }, "Cell", "wall", "normal", {key: walls[key] for key in (
        "wall", "material", "normal", "point", "velocity", "angular_velocity")})


def _write_mesh(vtk, path: str, sim, mesh: dict) -> None:
    count = mesh["faces"].shape[0]
    _write_piece(vtk, path, vtk.VtkPolyData, sim,
                 {"npoints": mesh["vertices"].shape[0], "npolys": count}, {
        "Points": {"points": mesh["vertices"]},
        "Polys": {"connectivity": mesh["faces"].reshape(-1),
                  "offsets": np.arange(3, 3 * count + 1, 3, dtype=np.int64)},
        "PointData": {"velocity": mesh["vertex_velocity"]},
    }, "Cell", "wall", "normal", {
        "wall": np.full(count, mesh["wall"], dtype=np.int64),
        "material": np.full(count, mesh["material"], dtype=np.int64),
        "triangle": np.arange(count, dtype=np.int64),
        "normal": mesh["normal"]})


def _write_box(vtk, path: str, sim, outline: dict) -> None:
    _write_piece(vtk, path, vtk.VtkPolyData, sim, {"npoints": 8, "nlines": 12}, {
        "Points": {"points": outline["corners"]},
        "Lines": {"connectivity": outline["edges"].reshape(-1),
                  "offsets": np.arange(2, 25, 2, dtype=np.int64)},
    }, "Cell", "periodic", None, {key: outline[key] for key in ("axis", "periodic")})


def write_vtk(sim, directory, name: str = "particles", contacts: bool = True, walls: bool = True,
              extent=None) -> dict:
    """Write the Simulation's current state as VTK XML files (one frame), for ParaView.

    Files, in ``directory`` (created if missing), with ``step`` = ``sim.step_count``:
    ``<name>_<step>.vtu`` (the spheres as points, with the arrays of :func:`particle_data` as
    point data), ``<name>_contacts_<step>.vtp`` (one line per contact, the arrays of
    :func:`contact_data` as cell data) if ``contacts``, ``<name>_walls_<step>.vtp`` (one
    rectangle per plane, :func:`wall_data`, clipped to ``extent`` = (lower, upper) [m], default
    :func:`scene_extent`) if ``walls``, and with it ``<name>_mesh<k>_<step>.vtp`` for each
    mesh wall k not removed (its triangles at their current place, :func:`mesh_data`), and in a
    periodic box ``<name>_box_<step>.vtp``, the box's outline (12 lines, cell data ``axis`` and
    ``periodic``). Every
    file carries the field data ``TimeValue`` (the simulated time [s]) and ``step``. Each file
    is written under a temporary name and renamed when complete.

    Returns a dict: the path of each file written, under ``"particles"``, ``"contacts"``,
    ``"walls"``, ``"box"``, and under ``"meshes"`` a dict {wall index: path} of the mesh walls' files
    (absent when none was written). Raises ImportError when pyevtk is not installed
    (``pip install 'tsubu[vtk]'``).
    """
    vtk = _pyevtk_vtk()
    name = _check_name(name)
    if extent is not None:
        extent = _check_extent(extent)
    directory = os.fspath(directory)
    os.makedirs(directory, exist_ok=True)
    step = sim.step_count
    raw_contacts = sim.contacts()
    particles = particle_data(sim, raw_contacts)
    written = {"particles": os.path.join(directory, f"{name}_{step}.vtu")}
    _write_atomically(written["particles"], lambda p: _write_particles(vtk, p, sim, particles))
    if contacts:
        network = contact_data(sim, raw_contacts, particles["position"])
        written["contacts"] = os.path.join(directory, f"{name}_contacts_{step}.vtp")
        _write_atomically(written["contacts"], lambda p: _write_contacts(vtk, p, sim, network))
    if walls:
        wall_arrays = wall_data(sim, extent)
        written["walls"] = os.path.join(directory, f"{name}_walls_{step}.vtp")
        _write_atomically(written["walls"], lambda p: _write_walls(vtk, p, sim, wall_arrays))
        meshes = {}
        for mesh in mesh_data(sim):
            meshes[mesh["wall"]] = os.path.join(directory, f"{name}_mesh{mesh['wall']}_{step}.vtp")
            _write_atomically(meshes[mesh["wall"]],
                              lambda p, mesh=mesh: _write_mesh(vtk, p, sim, mesh))
        outline = _box_outline(sim)
        if outline is not None:
            written["box"] = os.path.join(directory, f"{name}_box_{step}.vtp")
            _write_atomically(written["box"], lambda p: _write_box(vtk, p, sim, outline))
        if meshes:
            written["meshes"] = meshes
    return written


def _check_name(name) -> str:
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", name):
        raise ValueError("name must be a file-name stem of letters, digits, '_', '.' and '-' "
                         f"(starting with a letter or digit), got {name!r}")
    return name


def _check_every(every) -> int:
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)):
        raise TypeError(f"every must be a whole number of steps, got {every!r}")
    if every < 1:
        raise ValueError(f"every must be >= 1 (steps between frames), got {every!r}")
    return int(every)


# ---- .pvd collections ----------------------------------------------------------------------------

# The Simulation (a weak reference) whose frames each index lists, by the index's real path,
# for the indexes written by this process (see _Series.claim).
_INDEX_OWNERS: dict = {}


class _Series:
    """A time series of files listed in a .pvd collection (or a CSV index), rewritten atomically
    after each frame. Frames are kept by step; writing step s drops the frames listed at s and
    after (a run that went back, e.g. resumed from a checkpoint, replaces its old future). A
    frame is one file, or several (the walls: the planes' file and one per mesh wall), each
    listed with its ``part`` number.

    Before each frame a writer claims the index for its Simulation (:meth:`claim`): within one
    process, a Simulation whose first frame would replace every frame that another Simulation
    wrote there is refused."""

    def __init__(self, directory: str, index_name: str, pattern: str):
        self.path = os.path.join(directory, index_name)
        self.pattern = re.compile(pattern)
        # step -> (time, ((part, file name), ...))
        self.frames: dict[int, tuple[float, tuple[tuple[int, str], ...]]] | None = None

    def _load(self) -> dict:
        """The frames an existing index lists (a resumed run continues its series)."""
        frames: dict[int, tuple[float, tuple[tuple[int, str], ...]]] = {}
        if not os.path.exists(self.path):
            return frames
        try:
            for step, time, part, file in self._read():
                frames[step] = (time, frames.get(step, (time, ()))[1] + ((part, file),))
        except (ET.ParseError, ValueError, KeyError, OSError):
            return {}  # not one of ours: replaced by the new series
        return frames

    def _read(self):
        for entry in ET.parse(self.path).getroot().iter("DataSet"):
            file = entry.attrib["file"]
            match = self.pattern.fullmatch(file)
            if match:
                yield (int(match.group(1)), float(entry.attrib["timestep"]),
                       int(entry.attrib.get("part", "0")), file)

    def claim(self, sim, step: int, writer: str) -> None:
        """Refuse (FileExistsError, naming the directory and what to do) to write the frame of
        ``step`` for ``sim`` when the index lists frames that another Simulation of this
        process wrote and that frame would replace them all (a second scene writing into the
        same directory under the same name); otherwise make ``sim`` the index's owner.

        A run resumed from a checkpoint keeps the frames before its first one, and is let
        through; so is a series left by another process (rerunning a script replaces its
        output, as a rerun is meant to)."""
        key = os.path.realpath(self.path)
        owner = _INDEX_OWNERS.get(key)
        if owner is not None and owner() is sim:
            return
        if owner is not None:
            self.frames = self._load()  # as the other Simulation left it
            if self.frames and step <= min(self.frames):
                first, last = min(self.frames), max(self.frames)
                raise FileExistsError(
                    errno.EEXIST,
                    f"{writer}: the directory {os.path.dirname(self.path)!r} already holds a series "
                    f"{os.path.basename(self.path)} of {len(self.frames)} frames (steps {first} to "
                    f"{last}) written by another Simulation of this process, which this run's first "
                    f"frame (step {step}) would replace: give each Simulation its own directory or "
                    "name= (or delete the old files first)", self.path)
        _INDEX_OWNERS[key] = weakref.ref(sim)

    def add(self, step: int, time: float, files) -> None:
        """List the frame of ``step``: ``files`` is a file name, or a sequence of
        (part, file name)."""
        if self.frames is None:
            self.frames = self._load()
        self.frames = {s: f for s, f in self.frames.items() if s < step}
        self.frames[step] = (time, ((0, files),) if isinstance(files, str) else tuple(files))
        _write_atomically(self.path, lambda stem: self._write(stem + os.path.splitext(self.path)[1]))

    def _write(self, path: str) -> None:
        vtk = _pyevtk_vtk()
        group = vtk.VtkGroup(path[: -len(".pvd")])
        for step in sorted(self.frames):
            time, files = self.frames[step]
            for part, file in files:
                group.addFile(os.path.join(os.path.dirname(self.path), file), sim_time=repr(time),
                              part=str(part))
        group.save()


class _CSVSeries(_Series):
    """The frames of a CSV series: ``step,time,file`` rows."""

    def _read(self):
        with open(self.path, newline="") as f:
            rows = csv.DictReader(f)
            for row in rows:
                if self.pattern.fullmatch(row["file"]):
                    yield int(row["step"]), float(row["time"]), 0, row["file"]

    def _write(self, path: str) -> None:
        with open(path, "w", newline="") as f:
            f.write("step,time,file\n")
            for step in sorted(self.frames):
                time, files = self.frames[step]
                for _, file in files:
                    f.write(f"{step},{time!r},{file}\n")


# ---- hooks ---------------------------------------------------------------------------------------

class _EveryK:
    """The run-loop contract for a hook that writes every ``every`` steps: the next multiple of
    ``every`` at or after the current step, but never the step it wrote last (two consecutive
    runs share their boundary step)."""

    def __init__(self, every):
        self.every = _check_every(every)
        self.last_step: int | None = None

    def next_step(self, sim) -> int:
        """The step at which :meth:`act` is next due (run-loop contract)."""
        step = sim.step_count
        due = -(-step // self.every) * self.every
        if due == step and step == self.last_step:
            due += self.every
        return due

    def act(self, sim) -> None:
        """Write the frame of the current step (run-loop contract)."""
        self._write(sim)
        self.last_step = sim.step_count

    def close(self, sim) -> None:
        """Nothing to flush: every frame, and its index, is complete on disk when act returns."""


class VTKOutput(_EveryK):
    """A hook for ``sim.run(..., output=...)`` that writes VTK XML files for ParaView every
    ``every`` steps (at steps 0, every, 2 every, ...; a step is never written twice).

    Parameters
    ----------
    directory : str or path
        Where the files go (created if missing).
    every : int
        Steps between frames (>= 1).
    name : str
        File-name stem. Default ``"particles"``.
    contacts, walls : bool
        Also write the contact network and the walls (planes and mesh walls, and a periodic
        box's outline). Default True.
    extent : (lower, upper) 3-vectors [m] or None
        The box the wall rectangles cover; None: :func:`scene_extent` of each frame.

    Notes
    -----
    Each frame writes the files of :func:`write_vtk`; after it the collections
    ``<name>.pvd``, ``<name>_contacts.pvd``, ``<name>_walls.pvd`` (the frames' simulated times
    and files: open these in ParaView; the walls' collection lists at each time the planes'
    file as part 0 and each mesh wall k's file as part k + 1, a removed wall no more) and, with
    the walls, in a periodic box ``<name>_box.pvd`` (the box's outline) are
    rewritten under a temporary name, flushed to disk and
    renamed, so that a run killed at any moment leaves valid ones. When a collection already
    exists (a run resumed from a checkpoint into the same directory), the frames it lists before
    the first step written are kept and those from that step on are replaced. Within one
    process, a Simulation whose first frame would replace every frame another Simulation wrote
    into the collection is refused (FileExistsError, before any file is written): give each
    its own ``directory`` or ``name`` (a series left by another process, as when a script is
    run again, is replaced).

    Raises
    ------
    ImportError
        When pyevtk is not installed (``pip install 'tsubu[vtk]'``), at construction.
    TypeError, ValueError
        For a bad ``every``, ``name`` or ``extent``.
    FileExistsError
        From a run, at its first frame: the collection holds the frames of another Simulation of
        this process, which that frame would all replace (see Notes).
    """

    def __init__(self, directory, every: int, name: str = "particles", contacts: bool = True,
                 walls: bool = True, extent=None):
        _pyevtk_vtk()
        super().__init__(every)
        self.directory = os.fspath(directory)
        self.name = _check_name(name)
        self.contacts = bool(contacts)
        self.walls = bool(walls)
        self.extent = None if extent is None else _check_extent(extent)
        esc = re.escape(self.name)
        self._series = {"particles": _Series(self.directory, f"{self.name}.pvd", rf"{esc}_(\d+)\.vtu")}
        if self.contacts:
            self._series["contacts"] = _Series(self.directory, f"{self.name}_contacts.pvd",
                                               rf"{esc}_contacts_(\d+)\.vtp")
        if self.walls:
            self._series["walls"] = _Series(self.directory, f"{self.name}_walls.pvd",
                                            rf"{esc}_(?:walls|mesh\d+)_(\d+)\.vtp")

    def _write(self, sim) -> None:
        if self.walls and "box" not in self._series and getattr(sim, "box", None) is not None:
            self._series["box"] = _Series(self.directory, f"{self.name}_box.pvd",
                                          rf"{re.escape(self.name)}_box_(\d+)\.vtp")
        for series in self._series.values():
            series.claim(sim, sim.step_count, f"VTKOutput(name={self.name!r})")
        written = write_vtk(sim, self.directory, self.name, self.contacts, self.walls, self.extent)
        meshes = written.pop("meshes", {})
        for kind, path in written.items():
            files = [(0, os.path.basename(path))]
            if kind == "walls":  # the mesh walls: part k + 1 for wall k, the same in every frame
                files += [(k + 1, os.path.basename(p)) for k, p in sorted(meshes.items())]
            self._series[kind].add(sim.step_count, sim.time, files)


# ---- npz and CSV ---------------------------------------------------------------------------------

def save_npz(sim, path) -> str:
    """Write the Simulation's current state to one ``.npz`` archive (``numpy.load`` reads it,
    no pickle needed) and return its path.

    Arrays: ``step`` and ``time`` [s] (0-d); ``material_names`` (str, one per entry of
    ``sim.materials``, "" when unnamed); the per-sphere arrays of :func:`particle_data`
    (``id``, ``position``, ...); the contacts as ``contact_<key>`` for each key of
    :func:`contact_data` (``contact_i``, ``contact_force``, ...); in a periodic box
    (``sim.box``), the box as ``box_lower``, ``box_upper`` [m], ``box_periodic`` (str),
    ``box_shear_offset`` [m], ``box_shear_rate`` [1/s], and each sphere's ``image`` (N, 3)
    int64 (``sim.images``) and ``unwrapped_position`` [m] (``sim.unwrapped_positions``).
    Written under a temporary name and renamed when complete.
    """
    path = os.fspath(path)
    raw = sim.contacts()
    particles = particle_data(sim, raw)
    arrays = {"step": np.array(sim.step_count, dtype=np.int64),
              "time": np.array(sim.time, dtype=np.float64),
              "material_names": np.array([m.name or "" for m in sim.materials], dtype=str)}
    arrays.update(particles)
    arrays.update({f"contact_{k}": v for k, v in contact_data(sim, raw, particles["position"]).items()})
    arrays.update(_box_arrays(sim))
    if os.path.dirname(path):
        os.makedirs(os.path.dirname(path), exist_ok=True)

    def write(stem):
        with open(stem + os.path.splitext(path)[1], "wb") as f:
            np.savez(f, **arrays)

    _write_atomically(path, write)
    return path


def _box_arrays(sim) -> dict:
    """The periodic box of ``sim`` as npz arrays (none for an open scene): ``box_lower``,
    ``box_upper`` [m] (3,), ``box_periodic`` (the axes, a str), ``box_shear_offset`` [m] and
    ``box_shear_rate`` [1/s] (0-d), ``image`` (N, 3) int64, the images each sphere crossed
    (``Simulation.images``), and ``unwrapped_position`` [m] (N, 3), position + image L plus the
    Lees-Edwards slides taken (``Simulation.unwrapped_positions``), rows as ``position``'s."""
    box = getattr(sim, "box", None)
    if box is None:
        return {}
    return {"box_lower": np.array(box.lower, dtype=np.float64),
            "box_upper": np.array(box.upper, dtype=np.float64),
            "box_periodic": np.array(box.periodic, dtype=str),
            "box_shear_offset": np.array(box.shear_offset, dtype=np.float64),
            "box_shear_rate": np.array(box.shear_rate, dtype=np.float64),
            "image": np.array(sim.images, dtype=np.int64),
            "unwrapped_position": np.array(sim.unwrapped_positions, dtype=np.float64)}


# Column names of the CSV tables: a vector ``force`` is three columns ``force_x, force_y, force_z``.
_CSV_PARTICLES = ("id", "position", "velocity", "angular_velocity", "radius", "mass", "material",
                  "force", "torque", "coordination")
_CSV_CONTACTS = ("i", "j", "wall", "overlap", "normal_force", "force", "normal_force_vector",
                 "tangential_force", "normal", "start", "end")


def _write_table(path: str, arrays: dict, keys) -> None:
    header, columns = [], []
    for key in keys:
        a = arrays[key]
        if a.ndim == 1:
            header.append(key)
            columns.append(a.tolist())
        else:
            for c, axis in enumerate("xyz"):
                header.append(f"{key}_{axis}")
                columns.append(a[:, c].tolist())

    def write(stem):
        with open(stem + os.path.splitext(path)[1], "w", newline="") as f:
            f.write(",".join(header) + "\n")
            # repr: the shortest text that reads back as the same double (ints as ints)
            f.writelines(",".join(map(repr, row)) + "\n" for row in zip(*columns))

    _write_atomically(path, write)


def save_csv(sim, path, contacts_path=None) -> str:
    """Write the current state of the spheres of the Simulation ``sim`` as a CSV table at
    ``path`` (one row per sphere, in id order, a header row of column names) and return its
    path; with ``contacts_path``, also the contact network as a second table there.

    Columns: ``id``, ``position_x``, ``position_y``, ``position_z``, ``velocity_*``,
    ``angular_velocity_*``, ``radius``, ``mass``, ``material``, ``force_*``, ``torque_*``,
    ``coordination`` (units and meaning as :func:`particle_data`); the contact table: ``i``,
    ``j``, ``wall``, ``overlap``, ``normal_force``, ``force_*``, ``normal_force_vector_*``,
    ``tangential_force_*``, ``normal_*``, ``start_*``, ``end_*`` (:func:`contact_data`).
    Floats are written at repr precision (the shortest decimal that reads back as the same
    double), so ``numpy.loadtxt(path, delimiter=",", skiprows=1)`` gives the arrays bit for
    bit. The step and time are not in the table (:class:`CSVOutput` lists them in its index).
    """
    path = os.fspath(path)
    raw = sim.contacts()
    particles = particle_data(sim, raw)
    if os.path.dirname(path):
        os.makedirs(os.path.dirname(path), exist_ok=True)
    _write_table(path, particles, _CSV_PARTICLES)
    if contacts_path is not None:
        _write_table(os.fspath(contacts_path), contact_data(sim, raw, particles["position"]),
                     _CSV_CONTACTS)
    return path


class NpzOutput(_EveryK):
    """A hook for ``sim.run(..., output=...)`` that writes :func:`save_npz` archives
    ``<directory>/<name>_<step>.npz`` every ``every`` steps (a step is never written twice).
    TypeError / ValueError for a bad ``every`` or ``name``."""

    def __init__(self, directory, every: int, name: str = "state"):
        super().__init__(every)
        self.directory = os.fspath(directory)
        self.name = _check_name(name)

    def _write(self, sim) -> None:
        save_npz(sim, os.path.join(self.directory, f"{self.name}_{sim.step_count}.npz"))


class CSVOutput(_EveryK):
    """A hook for ``sim.run(..., output=...)`` that writes :func:`save_csv` tables every
    ``every`` steps (a step is never written twice): ``<directory>/<name>_<step>.csv`` and, if
    ``contacts``, ``<name>_contacts_<step>.csv``; after each frame the index
    ``<name>_frames.csv`` (columns ``step,time,file``) is rewritten atomically. TypeError /
    ValueError for a bad ``every`` or ``name``; FileExistsError from a run whose first frame would
    replace every frame another Simulation of this process listed in the index (as
    :class:`VTKOutput`)."""

    def __init__(self, directory, every: int, name: str = "state", contacts: bool = True):
        super().__init__(every)
        self.directory = os.fspath(directory)
        self.name = _check_name(name)
        self.contacts = bool(contacts)
        self._index = _CSVSeries(self.directory, f"{self.name}_frames.csv",
                                 rf"{re.escape(self.name)}_(\d+)\.csv")

    def _write(self, sim) -> None:
        step = sim.step_count
        self._index.claim(sim, step, f"CSVOutput(name={self.name!r})")
        path = os.path.join(self.directory, f"{self.name}_{step}.csv")
        contacts_path = (os.path.join(self.directory, f"{self.name}_contacts_{step}.csv")
                         if self.contacts else None)
        save_csv(sim, path, contacts_path)
        self._index.add(step, sim.time, os.path.basename(path))

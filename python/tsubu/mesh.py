"""Triangle meshes for mesh walls: validation, files (STL, OBJ) and generators.

A mesh is two numpy arrays: ``vertices`` (V, 3) float64 [m] and ``faces`` (F, 3) int64, each
row of ``faces`` the indices of a triangle's three vertices. Triangles are connected only
through shared vertex indices (two triangles that touch at equal coordinates but through
different vertex rows are not neighbours), so files that store every triangle's corners
separately (STL) are merged on reading. A triangle's orientation is that of its vertex order
(right-hand rule): ``cross(b - a, c - a)`` points to its front. Both sides of a triangle touch
spheres alike; the generators below still orient containers' faces toward the inside, where the
grains are, so that normals drawn in ParaView point at them.

- :func:`check_mesh`: the checks every mesh passes through (``Simulation.add_mesh`` calls it);
- :func:`read_mesh`, :func:`write_stl`: STL (binary and ASCII) and OBJ files, through trimesh
  (an optional dependency: ``pip install 'tsubu[mesh]'``);
- generators, each returning ``(vertices, faces)``: :func:`box`, :func:`square`,
  :func:`cylinder`, :func:`cone`, :func:`wedge_hopper`.

``docs/geometry.md`` describes the meshes, their files and their output.
"""

from __future__ import annotations

import errno
import math
import numbers
import os

import numpy as np

from . import _checks

__all__ = ["check_mesh", "read_mesh", "write_stl", "box", "square", "cylinder", "cone",
           "wedge_hopper"]

_INSTALL_HINT = "install it with: pip install 'tsubu[mesh]'"

# A triangle is degenerate when its area is below this fraction of its longest edge squared
# (a needle or a triangle whose corners are in a line: no normal to speak of).
DEGENERATE_AREA = 1e-12

# File formats read_mesh reads, by file-name suffix (lower case): trimesh's name for each.
_FORMATS = {".stl": "stl", ".obj": "obj"}


# ---- validation ------------------------------------------------------------------------------------

def _listing(indices, limit: int = 5) -> str:
    """'3' / '3, 7 and 9' / '3, 7, 9, 12, 15 and 4 more'."""
    indices = [int(k) for k in indices]
    if len(indices) == 1:
        return str(indices[0])
    if len(indices) <= limit:
        return ", ".join(map(str, indices[:-1])) + " and " + str(indices[-1])
    return ", ".join(map(str, indices[:limit])) + f" and {len(indices) - limit} more"


def _index_array(name: str, value) -> np.ndarray:
    """``value`` as a new C-contiguous int64 array; TypeError for booleans, floats, strings and
    other non-integers, ValueError for an integer beyond int64."""
    shape = getattr(value, "shape", None)
    if isinstance(shape, tuple) and len(shape) >= 1 and all(isinstance(k, int) for k in shape):
        _checks.fits_in_memory(name, shape[0], "rows")
    holder = value if isinstance(value, (bool, np.bool_)) else _checks._bool_inside(value)
    if holder is not None:
        raise TypeError(f"{name} must be an array of shape (F, 3) of vertex indices (integers), "
                        f"not booleans, got {holder!r}")
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of shape (F, 3) of vertex indices (integers), "
                        f"got {type(value).__name__}") from None
    if a.dtype.kind == "O":
        if not all(isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in a.flat):
            raise TypeError(f"{name} must be an array of shape (F, 3) of vertex indices "
                            f"(integers), got {value!r}")
        big = [int(v) for v in a.flat if not -2**63 <= int(v) < 2**63]
        if big:
            raise ValueError(f"{name}: vertex index {big[0]} is out of range")
        return np.array(a.tolist(), dtype=np.int64, order="C").reshape(a.shape)
    if a.dtype.kind == "u" and a.size and int(a.max()) >= 2**63:
        raise ValueError(f"{name}: vertex index {int(a.max())} is out of range")
    if a.dtype.kind not in "iu":
        raise TypeError(f"{name} must be an array of shape (F, 3) of vertex indices (integers), "
                        f"got an array of dtype {a.dtype}")
    return np.array(a, dtype=np.int64, order="C", copy=True)


def check_mesh(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """Check a triangle mesh and return it as the arrays the engine takes.

    Parameters
    ----------
    vertices : array_like, shape (V, 3)
        The vertices' coordinates [m], finite real numbers (not booleans).
    faces : array_like of int, shape (F, 3)
        Each triangle's three vertex indices, each in 0 .. V - 1, three different ones.

    Returns
    -------
    vertices : numpy.ndarray, float64, shape (V, 3), C-contiguous
        A copy (never a view of the caller's array).
    faces : numpy.ndarray, int64, shape (F, 3), C-contiguous
        A copy, in the given order (triangle k is row k).

    Raises
    ------
    TypeError
        Non-numeric input, booleans, or ``faces`` that are not integers (floats included).
    ValueError
        Naming the argument and the triangle (its index, its vertex indices and where needed its
        coordinates): a shape other than (V, 3) / (F, 3); no vertex or no triangle; a NaN or
        infinite coordinate (naming the vertex and the triangles that use it); a vertex index
        that is negative or not below V; a triangle that repeats a vertex index; a degenerate
        triangle, whose area is below 1e-12 of its longest edge squared (its corners in a line,
        or two of them at one point). Unused vertices, open meshes, duplicate or inconsistently
        oriented triangles are accepted.
    """
    v = _checks._float_array("vertices", vertices, "an array of shape (V, 3)")
    f = _index_array("faces", faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices must have shape (V, 3), got shape {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces must have shape (F, 3) (three vertex indices per triangle), "
                         f"got shape {f.shape}")
    if v.shape[0] == 0:
        raise ValueError("vertices is empty: a mesh needs at least 3 vertices")
    if f.shape[0] == 0:
        raise ValueError("faces is empty: a mesh needs at least 1 triangle")
    count = v.shape[0]
    bad = np.flatnonzero(((f < 0) | (f >= count)).any(axis=1))
    if bad.size:
        t = int(bad[0])
        k = int(next(i for i in f[t] if not 0 <= i < count))
        reason = "is negative" if k < 0 else f"is out of range: vertices has {count} rows"
        raise ValueError(f"faces: triangle {t} is {f[t].tolist()}: vertex index {k} {reason} "
                         f"(valid indices are 0 to {count - 1}); {bad.size} triangle(s) "
                         f"have bad indices: {_listing(bad)}")
    nonfinite = np.flatnonzero(~np.isfinite(v).all(axis=1))
    if nonfinite.size:
        k = int(nonfinite[0])
        users = np.flatnonzero((f == k).any(axis=1))
        used = f"used by triangle(s) {_listing(users)}" if users.size else "used by no triangle"
        raise ValueError(f"vertices must be finite: vertex {k} is {v[k].tolist()}, {used}; "
                         f"{nonfinite.size} vertex/vertices are not finite: {_listing(nonfinite)}")
    repeated = np.flatnonzero((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2]))
    if repeated.size:
        t = int(repeated[0])
        raise ValueError(f"faces: triangle {t} is {f[t].tolist()}, which repeats a vertex index "
                         f"(a triangle needs three different vertices); {repeated.size} "
                         f"triangle(s) do: {_listing(repeated)}")
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    with np.errstate(over="ignore", invalid="ignore"):
        edges = np.stack([b - a, c - a, c - b], axis=1)  # (F, 3 edges, 3)
        overflow = np.flatnonzero(~np.isfinite(edges).all(axis=(1, 2)))
    if overflow.size:
        t = int(overflow[0])
        raise ValueError(f"faces: triangle {t} ({f[t].tolist()}, corners {v[f[t]].tolist()}) has "
                         "an edge longer than the largest float64: scale the mesh down")
    # In units of each triangle's largest edge component, so that neither tiny nor huge
    # coordinates underflow or overflow when squared.
    unit = np.abs(edges).max(axis=(1, 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        e = edges / np.where(unit > 0, unit, 1.0)[:, None, None]
    longest2 = np.einsum("fej,fej->fe", e, e).max(axis=1)
    area = 0.5 * np.linalg.norm(np.cross(e[:, 0], e[:, 1]), axis=1)
    degenerate = np.flatnonzero(~(area >= DEGENERATE_AREA * longest2) | (unit == 0))
    if degenerate.size:
        t = int(degenerate[0])
        real_area = float(area[t]) * float(unit[t]) ** 2
        real_longest2 = float(longest2[t]) * float(unit[t]) ** 2
        raise ValueError(
            f"faces: triangle {t} ({f[t].tolist()}, corners {v[f[t]].tolist()}) is degenerate: "
            f"its area {real_area:.3g} m^2 is below {DEGENERATE_AREA:g} of its longest edge "
            f"squared ({real_longest2:.3g} m^2), its corners are (nearly) in a line; remove it "
            f"or merge its vertices ({degenerate.size} triangle(s) are degenerate: "
            f"{_listing(degenerate)})")
    return v, f


# ---- files -----------------------------------------------------------------------------------------

def _trimesh(what: str):
    """The trimesh module, or ImportError saying how to install it."""
    try:
        import trimesh
    except ImportError as e:
        raise ImportError(f"{what} needs the package trimesh: {_INSTALL_HINT}") from e
    return trimesh


def _merge_vertices(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices with exactly equal coordinates made one (the first occurrence's row; the
    others' rows removed), the faces renumbered, their order kept."""
    if vertices.shape[0] == 0:
        return vertices, faces
    # Sorted by coordinates (lexsort is stable: within a group of equal rows, by row number).
    order = np.lexsort((vertices[:, 2], vertices[:, 1], vertices[:, 0]))
    ordered = vertices[order]
    starts = np.ones(order.size, dtype=bool)
    starts[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)  # (-0.0 equals 0.0; NaN no row)
    group = np.cumsum(starts) - 1
    first = order[starts]  # each group's first row in the file
    # Number the groups in the order of their first occurrence (a file without duplicates keeps
    # its numbering).
    rank = np.empty(first.size, dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(first.size)
    new_index = np.empty(order.size, dtype=np.int64)
    new_index[order] = rank[group]
    return (np.ascontiguousarray(vertices[np.sort(first)]),
            np.ascontiguousarray(new_index[faces], dtype=np.int64))


def read_mesh(path, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh from an STL (binary or ASCII) or OBJ file.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its format is told by its suffix, ``.stl`` or ``.obj`` (any case).
    scale : float
        A factor applied to every coordinate (> 0; e.g. 1e-3 for a CAD file drawn in
        millimetres). Default 1.

    Returns
    -------
    vertices : numpy.ndarray, float64, shape (V, 3)
        The coordinates [m] times ``scale``; vertices with exactly equal coordinates merged into
        one (STL stores each triangle's three corners separately; mesh walls see triangles as
        neighbours only through shared vertices), numbered in the order in which they first appear
        in the file (STL: the order of first use by the triangles; an OBJ file without
        duplicate vertices keeps its numbering).
    faces : numpy.ndarray, int64, shape (F, 3)
        The triangles in the file's order (polygons of an OBJ file split into triangles), each
        with the vertex order of the file (its orientation; STL's stored normals are ignored).

    Raises
    ------
    ImportError
        When trimesh is not installed (``pip install 'tsubu[mesh]'``).
    FileNotFoundError
        When there is no file at ``path``.
    ValueError
        Naming the path: an unknown suffix, a directory, a file that is not a readable mesh or
        holds no triangle, or a mesh that :func:`check_mesh` refuses (its message names the
        triangle, numbered in the file's order).
    TypeError
        For a ``path`` that is not a str or os.PathLike, or a ``scale`` that is not a number.

    Notes
    -----
    Binary STL stores coordinates in single precision: the vertices read back are those
    rounded to float32. The files are parsed by trimesh (``docs/geometry.md`` says why).
    """
    file = _checks.path("path", path)
    scale = _checks.positive("scale", scale)
    suffix = file.suffix.lower()
    if suffix not in _FORMATS:
        raise ValueError(f"read_mesh: {str(file)!r} is neither an STL nor an OBJ file (its name "
                         f"must end in .stl or .obj), got the suffix {file.suffix!r}")
    if not file.exists():
        raise FileNotFoundError(errno.ENOENT, f"read_mesh: no mesh file at {str(file)!r}",
                                str(file))
    if file.is_dir():
        raise ValueError(f"read_mesh: {str(file)!r} is a directory, not a mesh file")
    trimesh = _trimesh("tsubu.mesh.read_mesh")
    with open(file, "rb") as stream:  # (an unreadable file: the OSError says why)
        try:
            loaded = trimesh.load_mesh(stream, file_type=_FORMATS[suffix], process=False)
        except Exception as e:  # trimesh's parsers raise whatever their parsing meets
            raise ValueError(f"read_mesh: {str(file)!r} is not a readable "
                             f"{_FORMATS[suffix].upper()} file: {e}") from e
    vertices = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=np.float64)
    faces = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), dtype=np.int64)
    if faces.size == 0 or vertices.size == 0:
        raise ValueError(f"read_mesh: {str(file)!r} holds no triangle (an empty file, or not "
                         f"an {_FORMATS[suffix].upper()} file)")
    vertices, faces = _merge_vertices(vertices.reshape(-1, 3), faces.reshape(-1, 3))
    if scale != 1.0:
        vertices = vertices * scale
    try:
        return check_mesh(vertices, faces)
    except ValueError as e:
        raise ValueError(f"read_mesh: {str(file)!r} (vertices merged, times scale={scale!r}): "
                         f"{e}") from None


def write_stl(path, vertices, faces, binary: bool = True) -> str:
    """Write a triangle mesh to an STL file and return its path.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (replaced if it exists; its folder must exist).
    vertices : array_like, shape (V, 3)
        Coordinates [m].
    faces : array_like of int, shape (F, 3)
        Triangles (vertex indices); each is written with its vertex order and the normal that
        order gives.
    binary : bool
        Binary STL (default; coordinates stored as float32) or ASCII STL (coordinates written
        at repr precision: :func:`read_mesh` gives them back to the bit).

    Raises
    ------
    ImportError
        When trimesh is not installed (``pip install 'tsubu[mesh]'``).
    TypeError, ValueError
        For a mesh that :func:`check_mesh` refuses, or a bad ``path``.
    """
    file = _checks.path("path", path)
    vertices, faces = check_mesh(vertices, faces)
    if not isinstance(binary, (bool, np.bool_)):
        raise TypeError(f"binary must be True or False, got {binary!r}")
    trimesh = _trimesh("tsubu.mesh.write_stl")
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    data = mesh.export(file_type="stl" if binary else "stl_ascii")
    with open(file, "wb") as stream:
        stream.write(data if isinstance(data, bytes) else data.encode("ascii"))
    return os.fspath(file)


# ---- generators ------------------------------------------------------------------------------------

def _axes(axis) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit vectors (a, b, c) of a right-handed frame with c along ``axis`` ('x', 'y' or 'z'):
    a cyclic permutation of x, y, z."""
    axis = _checks.choice("axis", axis, ("x", "y", "z"))
    eye = np.eye(3)
    c = "xyz".index(axis)
    return eye[(c + 1) % 3], eye[(c + 2) % 3], eye[c]


def _count(name: str, value, minimum: int) -> int:
    return _checks.whole(name, value, minimum=minimum, maximum=10**7)


def _ring(centre: np.ndarray, radius: float, count: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``count`` points on a circle, at angles 2 pi k / count from ``a`` toward ``b``."""
    angle = 2.0 * np.pi * np.arange(count) / count
    return centre + radius * (np.cos(angle)[:, None] * a + np.sin(angle)[:, None] * b)


def _band(count: int, first: int, second: int, closed: bool = True) -> np.ndarray:
    """The triangles between two rings (or rows) of ``count`` vertices numbered from ``first``
    and ``second``: quad k is (first+k, first+k+1, second+k+1, second+k), split along
    first+k -- second+k+1 into two triangles with its orientation."""
    k = np.arange(count if closed else count - 1)
    k1 = (k + 1) % count
    p, q, r, s = first + k, first + k1, second + k1, second + k
    return np.concatenate([np.stack([p, q, r], axis=1), np.stack([p, r, s], axis=1)])


def box(lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """A closed box, the boundary of [lo, hi], as 8 vertices and 12 triangles.

    Parameters
    ----------
    lo, hi : 3-vectors [m]
        The opposite corners, ``lo < hi`` in x, y and z.

    Returns
    -------
    vertices : numpy.ndarray, float64, shape (8, 3)
        Corner k has x = hi[0] if k & 1, y = hi[1] if k & 2, z = hi[2] if k & 4 (lo otherwise).
    faces : numpy.ndarray, int64, shape (12, 3)
        Two triangles per side, in the order -x, +x, -y, +y, -z, +z, each oriented with its
        normal pointing into the box (where the grains are).
    """
    lo = np.array(_checks.vec3("lo", lo))
    hi = np.array(_checks.vec3("hi", hi))
    if not np.all(lo < hi):
        raise ValueError(f"lo must be below hi in x, y and z, got lo={lo.tolist()}, "
                         f"hi={hi.tolist()}")
    vertices = np.array([[(lo, hi)[k & 1][0], (lo, hi)[(k >> 1) & 1][1], (lo, hi)[(k >> 2) & 1][2]]
                         for k in range(8)])
    # Each side as a quad (p, q, r, s) counter-clockwise seen from inside the box.
    quads = [(0, 2, 6, 4), (1, 5, 7, 3),   # x = lo, x = hi
             (0, 4, 5, 1), (2, 3, 7, 6),   # y = lo, y = hi
             (0, 1, 3, 2), (4, 6, 7, 5)]   # z = lo, z = hi
    faces = np.array([t for p, q, r, s in quads for t in ((p, q, r), (p, r, s))], dtype=np.int64)
    return vertices, faces


def square(center, size: float, normal, divisions: int, jitter: float = 0.0,
           seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A flat square tessellated into triangles: a regular grid of ``divisions`` x ``divisions``
    cells, each split into two triangles, optionally made irregular.

    Parameters
    ----------
    center : 3-vector [m]
        The square's centre.
    size : float
        Its side [m] (> 0).
    normal : 3-vector
        Its normal (any length > 0); the triangles are oriented with their normals along it.
    divisions : int
        Cells along each side (>= 1): ``(divisions + 1)**2`` vertices, ``2 divisions**2``
        triangles.
    jitter : float
        In [0, 1): each interior vertex is moved within the plane by up to
        ``jitter * h / 4`` along each of the two in-plane axes (h = size / divisions, uniform
        random), which makes an irregular tessellation of the same square; the boundary
        vertices stay, so the square's outline does not change. Any jitter below 1 keeps every
        triangle's orientation and an area of at least ``(1 - jitter) h**2 / 2``. Default 0.
    seed : int
        The seed of the jitter's random numbers (numpy's default generator). Default 0.

    Returns
    -------
    vertices : numpy.ndarray, float64, shape ((divisions + 1)**2, 3)
        Row ``i + (divisions + 1) j`` is the grid point ``center + (i h - size/2) u +
        (j h - size/2) v`` (before the jitter), where the in-plane axes u, v are those of the
        plane walls' rectangles in the VTK output: u along the coordinate axis least aligned
        with the normal, projected into the plane, and v = n x u (for normal (0, 0, 1): u = x,
        v = y, and every vertex lies exactly at the centre's z).
    faces : numpy.ndarray, int64, shape (2 divisions**2, 3)
        Cell (i, j) gives the triangles (p, p+1, p+d+2) and (p, p+d+2, p+d+1) with
        p = i + (d + 1) j, d = divisions: split along the same diagonal everywhere.
    """
    from .output import _plane_axes

    center = np.array(_checks.vec3("center", center))
    size = _checks.positive("size", size)
    n = np.array(_checks.vec3("normal", normal))
    length = math.sqrt(float(n @ n))
    if not length > 0:
        raise ValueError(f"normal must not be zero, got {n.tolist()}")
    n = n / length
    d = _count("divisions", divisions, 1)
    jitter = _checks.in_range("jitter", jitter, 0.0, 1.0, lo_open=False, hi_open=True)
    seed = _checks.whole("seed", seed)
    u, v = _plane_axes(n)
    h = size / d
    i, j = np.meshgrid(np.arange(d + 1), np.arange(d + 1), indexing="xy")
    a = (i.reshape(-1) * h - 0.5 * size).astype(np.float64)
    b = (j.reshape(-1) * h - 0.5 * size).astype(np.float64)
    if jitter > 0:
        rng = np.random.default_rng(seed)
        inner = ((i > 0) & (i < d) & (j > 0) & (j < d)).reshape(-1)
        shift = rng.uniform(-0.25 * jitter * h, 0.25 * jitter * h, size=(int(inner.sum()), 2))
        a[inner] += shift[:, 0]
        b[inner] += shift[:, 1]
    vertices = center + a[:, None] * u + b[:, None] * v
    faces = np.concatenate([_band(d + 1, (d + 1) * row, (d + 1) * (row + 1), closed=False)
                            for row in range(d)]).astype(np.int64)
    return np.ascontiguousarray(vertices), faces


def cylinder(radius: float, length: float, segments: int, axis: str = "z",
             center=(0.0, 0.0, 0.0), caps: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """A drum: the side of a cylinder as a prism of ``segments`` flat faces, closed by two
    flat caps if ``caps``.

    Parameters
    ----------
    radius : float
        The radius of the circles the vertices lie on [m] (> 0). The flat faces are nearer the
        axis, at ``radius * cos(pi / segments)`` at their middle lines.
    length : float
        The length along the axis [m] (> 0).
    segments : int
        Faces around (>= 3), two triangles each.
    axis : {'x', 'y', 'z'}
        The cylinder's axis. Default 'z'.
    center : 3-vector [m]
        The centre of the cylinder (the middle of its axis), a drum's natural centre of
        rotation. Default the origin.
    caps : bool
        Close both ends with a fan of ``segments`` triangles around the end's centre. Default
        False (an open tube).

    Returns
    -------
    vertices : numpy.ndarray, float64
        ``segments`` vertices on the circle at ``center - length/2 * axis``, then ``segments``
        on the circle at ``center + length/2 * axis``, vertex k of each at the angle
        ``2 pi k / segments`` from the first axis after ``axis`` in the cycle x, y, z (for
        axis 'z': from x toward y); with ``caps``, then the two ends' centres. Shape
        (2 segments, 3), or (2 segments + 2, 3) with caps.
    faces : numpy.ndarray, int64
        The side's ``2 segments`` triangles, then with ``caps`` the lower and the upper cap's
        ``segments`` each; all with their normals pointing into the drum.
    """
    radius = _checks.positive("radius", radius)
    length = _checks.positive("length", length)
    n = _count("segments", segments, 3)
    a, b, c = _axes(axis)
    center = np.array(_checks.vec3("center", center))
    if not isinstance(caps, (bool, np.bool_)):
        raise TypeError(f"caps must be True or False, got {caps!r}")
    lower, upper = center - 0.5 * length * c, center + 0.5 * length * c
    vertices = [_ring(lower, radius, n, a, b), _ring(upper, radius, n, a, b)]
    # Upper ring k, k+1 then lower k+1, k: counter-clockwise seen from the axis (inward).
    faces = [_band(n, n, 0)]
    if caps:
        vertices.append(np.stack([lower, upper]))
        k = np.arange(n)
        k1 = (k + 1) % n
        bottom, top = np.full(n, 2 * n), np.full(n, 2 * n + 1)
        faces.append(np.stack([bottom, k, k1], axis=1))            # normal +axis (inward)
        faces.append(np.stack([top, n + k1, n + k], axis=1))       # normal -axis (inward)
    return np.ascontiguousarray(np.concatenate(vertices)), np.concatenate(faces).astype(np.int64)


def cone(top_radius: float, bottom_radius: float, height: float, segments: int,
         axis: str = "z", bottom=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """A conical hopper: the side of a truncated cone as ``segments`` flat faces, open at both
    ends (the bottom opening is the orifice).

    Parameters
    ----------
    top_radius, bottom_radius : float
        The radii of the top and bottom circles the vertices lie on [m] (> 0; equal radii give
        an open cylinder). The hopper's half-angle from the axis is
        ``atan((top_radius - bottom_radius) / height)``; the flat faces' middle lines are at
        ``cos(pi / segments)`` times the radius.
    height : float
        The distance between the two circles along the axis [m] (> 0).
    segments : int
        Faces around (>= 3), two triangles each.
    axis : {'x', 'y', 'z'}
        The cone's axis, pointing from the bottom circle to the top one. Default 'z' (the
        orifice below, for gravity along -z).
    bottom : 3-vector [m]
        The centre of the bottom circle (the orifice). Default the origin.

    Returns
    -------
    vertices : numpy.ndarray, float64, shape (2 segments, 3)
        ``segments`` vertices on the bottom circle, then ``segments`` on the top circle
        (``bottom + height * axis``), vertex k of each at the angle ``2 pi k / segments`` as
        in :func:`cylinder`.
    faces : numpy.ndarray, int64, shape (2 segments, 3)
        Normals pointing into the hopper (toward the axis).
    """
    top_radius = _checks.positive("top_radius", top_radius)
    bottom_radius = _checks.positive("bottom_radius", bottom_radius)
    height = _checks.positive("height", height)
    n = _count("segments", segments, 3)
    a, b, c = _axes(axis)
    bottom = np.array(_checks.vec3("bottom", bottom))
    vertices = np.concatenate([_ring(bottom, bottom_radius, n, a, b),
                               _ring(bottom + height * c, top_radius, n, a, b)])
    # Upper ring k, k+1 then lower k+1, k: counter-clockwise seen from the axis (inward).
    return np.ascontiguousarray(vertices), _band(n, n, 0).astype(np.int64)


def wedge_hopper(orifice_width: float, top_width: float, height: float, depth: float,
                 bottom=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """A wedge (slot) hopper: two inclined plates that leave a slot of width ``orifice_width``
    between their lower edges, and two vertical side walls that close the wedge at both ends of
    the slot; open at the top and at the slot.

    The slot runs along y, the hopper opens upward along +z (gravity along -z): the plates go
    from x = -/+ ``orifice_width``/2 at the bottom to x = -/+ ``top_width``/2 at the top,
    for y in [-depth/2, depth/2]; the side walls are the trapezoids between them at
    y = -/+ depth/2. The plates' angle from the vertical (the hopper half-angle) is
    ``atan((top_width - orifice_width) / (2 height))``; equal widths give a vertical slot
    channel. Rotate the vertices for other orientations.

    Parameters
    ----------
    orifice_width : float
        The slot's width [m] (> 0), along x.
    top_width : float
        The opening's width at the top [m] (>= orifice_width).
    height : float
        The plates' height along z [m] (> 0).
    depth : float
        The slot's length along y [m] (> 0): the distance between the side walls.
    bottom : 3-vector [m]
        The centre of the slot. Default the origin.

    Returns
    -------
    vertices : numpy.ndarray, float64, shape (8, 3)
        The slot's corners (x = -w/2 at y = -depth/2, +depth/2, then x = +w/2 at y = -depth/2,
        +depth/2), then the top's corners in the same order, relative to ``bottom``.
    faces : numpy.ndarray, int64, shape (8, 3)
        The plate at -x, the plate at +x, the side wall at -y, the side wall at +y, two
        triangles each, with normals pointing into the hopper.
    """
    w = _checks.positive("orifice_width", orifice_width)
    top = _checks.positive("top_width", top_width)
    if top < w:
        raise ValueError(f"top_width must be >= orifice_width ({w!r}), got {top_width!r}: the "
                         "plates would lean outward")
    height = _checks.positive("height", height)
    depth = _checks.positive("depth", depth)
    bottom = np.array(_checks.vec3("bottom", bottom))
    y0, y1 = -0.5 * depth, 0.5 * depth
    vertices = bottom + np.array([
        [-0.5 * w, y0, 0.0], [-0.5 * w, y1, 0.0], [0.5 * w, y0, 0.0], [0.5 * w, y1, 0.0],
        [-0.5 * top, y0, height], [-0.5 * top, y1, height], [0.5 * top, y0, height],
        [0.5 * top, y1, height]])
    # Quads (p, q, r, s), counter-clockwise seen from inside the hopper.
    quads = [(0, 1, 5, 4),   # plate at -x: normal toward +x and up
             (2, 6, 7, 3),   # plate at +x: normal toward -x and up
             (0, 4, 6, 2),   # side wall at y = -depth/2: normal +y
             (1, 3, 7, 5)]   # side wall at y = +depth/2: normal -y
    faces = np.array([t for p, q, r, s in quads for t in ((p, q, r), (p, r, s))], dtype=np.int64)
    return np.ascontiguousarray(vertices), faces

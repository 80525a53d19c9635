"""Input checks shared by the public API: every message names the argument and the bad value.

Each check takes the argument's name (as the user wrote it, or a path such as
``materials.glass.restitution``) and the value, and returns the value converted (a float, an
int, a float64 array copied from the input) or raises TypeError (not a number, a bool, a
string where a number is expected) or ValueError (a number out of range, a wrong shape, a
non-finite value).
"""

from __future__ import annotations

import math
import numbers
import os
import reprlib
import sys
import warnings

import numpy as np

from . import _core


def _real(name: str, value) -> float:
    """A real number (not a bool) as a float: TypeError for anything else, ValueError for an
    integer beyond the range of floats. A 0-d numpy array of ints or floats (what indexing an
    ``np.load`` archive gives) counts as its number."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value[()]
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    try:
        return float(value)
    except OverflowError:
        raise ValueError(f"{name} must be a finite number, got {value!r}") from None


def positive(name: str, value, *, allow_zero: bool = False) -> float:
    """A finite real number > 0 (or >= 0 with ``allow_zero``), as a float; TypeError for a
    non-number, ValueError for a number out of range."""
    return bounded(name, value, 0.0, None, lo_open=not allow_zero, hi_open=False)


def in_range(name: str, value, lo: float, hi: float, *, lo_open: bool, hi_open: bool) -> float:
    """A finite real number in the interval from ``lo`` to ``hi`` (each end open or closed), as a
    float; ValueError names the interval, e.g. "restitution must be in (0, 1], got 1.5"."""
    return bounded(name, value, lo, hi, lo_open=lo_open, hi_open=hi_open)


def bounded(name: str, value, lo: float | None, hi: float | None, *, lo_open: bool,
            hi_open: bool) -> float:
    """A finite real number within the bounds (None: unbounded on that side; each end open or
    closed), as a float; TypeError for a non-number, ValueError naming the range: "restitution
    must be in (0, 1], got 1.5", "density must be a finite number > 0, got 0.0"."""
    v = _real(name, value)
    ok = (math.isfinite(v) and (lo is None or (v > lo if lo_open else v >= lo))
          and (hi is None or (v < hi if hi_open else v <= hi)))
    if not ok:
        if lo is not None and hi is not None:
            interval = ("(" if lo_open else "[") + f"{lo:g}, {hi:g}" + (")" if hi_open else "]")
            raise ValueError(f"{name} must be in {interval}, got {value!r}")
        if lo is not None:
            bound = (">" if lo_open else ">=") + f" {lo:g}"
        elif hi is not None:
            bound = ("<" if hi_open else "<=") + f" {hi:g}"
        else:
            raise ValueError(f"{name} must be finite, got {value!r}")
        raise ValueError(f"{name} must be a finite number {bound}, got {value!r}")
    return v


# Bytes one sphere costs at least: the engine's particle arrays (about 140) and the copies the
# checks make of its input (56). Its neighbour lists and contact state come on top (300-1,500
# bytes in dense packs) and are checked when the list is built (neighbor.cpp); refusing here only
# what cannot fit even without them never refuses a scene that would fit.
BYTES_PER_SPHERE = 256


def fits_in_memory(name: str, count: int, what: str = "spheres") -> None:
    """MemoryError, before anything is allocated, when ``count`` spheres (or rows: ``what``)
    cannot fit in the memory the process can still use (BYTES_PER_SPHERE each)."""
    available = _core.available_memory()
    need = count * BYTES_PER_SPHERE
    if need > available:
        raise MemoryError(
            f"{name}: {count} {what} need about {need / 2**30:.3g} GiB ({BYTES_PER_SPHERE} bytes "
            f"each), more than the {available / 2**30:.3g} GiB of memory available")


def _bool_inside(value):
    """The innermost list or tuple of a (nested) list or tuple that holds a bool (Python's or
    numpy's) or a bool array, or None: numpy would turn ``(0, 0, True)`` into the numbers
    (0, 0, 1) without a word."""
    stack = [value]
    while stack:
        v = stack.pop()
        if isinstance(v, (list, tuple)):
            for item in v:
                if isinstance(item, (bool, np.bool_)) or (isinstance(item, np.ndarray)
                                                          and item.dtype.kind == "b"):
                    return v
                if isinstance(item, (list, tuple)):
                    stack.append(item)
    return None


def _float_array(name: str, value, expected: str) -> np.ndarray:
    """``value`` as a new C-contiguous float64 array (never a view of the caller's data); refuses
    booleans (also inside a sequence of numbers), complex numbers, strings and other non-numbers
    with TypeError, and counts that cannot fit in memory (a broadcast view of a billion rows)
    with MemoryError."""
    shape = getattr(value, "shape", None)
    if isinstance(shape, tuple) and len(shape) >= 1 and all(isinstance(k, int) for k in shape):
        fits_in_memory(name, shape[0], "rows")
    holder = value if isinstance(value, (bool, np.bool_)) else _bool_inside(value)
    if holder is not None:
        raise TypeError(f"{name} must be {expected} of real numbers, not booleans, got "
                        f"{reprlib.repr(holder)}")
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be {expected}, got {type(value).__name__}") from None
    if a.dtype.kind == "O":
        if not all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in a.flat):
            raise TypeError(f"{name} must be {expected} of real numbers, got {value!r}")
        try:
            return np.array(a, dtype=float, order="C", copy=True)
        except OverflowError:
            raise ValueError(f"{name} must be finite, got {value!r}") from None
    if a.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be {expected} of real numbers, got an array of dtype {a.dtype}")
    return np.array(a, dtype=float, order="C", copy=True)


def vec3(name: str, value) -> tuple[float, float, float]:
    """A finite 3-vector as a tuple of 3 floats; TypeError for non-numbers, ValueError for
    another shape or a non-finite component."""
    a = _float_array(name, value, "a sequence of 3 numbers")
    if a.shape != (3,):
        raise ValueError(f"{name} must have 3 components, got shape {a.shape}: {value!r}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return (float(a[0]), float(a[1]), float(a[2]))


def points(name: str, value, n: int | None = None) -> np.ndarray:
    """An (n, 3) array of finite floats, copied; a single 3-vector is promoted to shape (1, 3)
    and an empty sequence to shape (0, 3). ``n`` None accepts any number of rows. TypeError for
    non-numbers, ValueError for another shape or a non-finite row (named by its index)."""
    a = _float_array(name, value, "an array of shape (N, 3)")
    if a.ndim == 1 and a.shape == (3,):
        a = a.reshape(1, 3)
    if a.ndim == 1 and a.shape == (0,):
        a = a.reshape(0, 3)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got shape {a.shape}")
    if n is not None and a.shape[0] != n:
        raise ValueError(f"{name} must have shape ({n}, 3), got shape {a.shape}")
    bad = ~np.all(np.isfinite(a), axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"{name} must be finite: row {k} is {a[k].tolist()}")
    return a


def radii(name: str, value, n: int) -> np.ndarray:
    """A scalar or an (n,) array of finite radii > 0, as an (n,) float array (a scalar is
    repeated); ValueError names the first bad entry."""
    a = _float_array(name, value, f"a number or an array of shape ({n},)")
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,):
        raise ValueError(f"{name} must be a number or have shape ({n},), got shape {a.shape}")
    bad = ~(np.isfinite(a) & (a > 0))
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"{name} must be finite and > 0: entry {k} is {a[k]!r}")
    return a


def choice(name: str, value, options) -> str:
    """One of the names in ``options`` (for the string-valued arguments, ``_core.choices``);
    ValueError lists the options."""
    if not isinstance(value, str) or value not in options:  # (an array would compare elementwise)
        names = [f"'{o}'" for o in options]
        listing = ", ".join(names[:-1]) + " or " + names[-1] if len(names) > 1 else names[0]
        raise ValueError(f"{name} must be {listing}, got {value!r}")
    return value


def whole(name: str, value, *, minimum: int = 0, maximum: int = 2**62) -> int:
    """An integer (not a bool) in [minimum, maximum], as an int; TypeError for a non-integer
    (a float too), ValueError out of range."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value!r}")
    if value > maximum:
        raise ValueError(f"{name} must be <= {maximum}, got {value!r}")
    return int(value)


def path(name: str, value) -> "Path":
    """A file path (str or os.PathLike, not empty) as a pathlib.Path."""
    import os
    from pathlib import Path

    if isinstance(value, bytes) or not isinstance(value, (str, os.PathLike)):
        raise TypeError(f"{name} must be a file path (str or os.PathLike), got {value!r}")
    if str(value) == "":
        raise ValueError(f"{name} must be a file path, got an empty string")
    return Path(value)


def warn(message: str, category: type) -> None:
    """warnings.warn pointing at the first caller outside the tsubu package (the user's line)."""
    package = os.path.dirname(os.path.abspath(__file__)) + os.sep

    def ours(filename: str) -> bool:  # (also the constructors _options makes: "<tsubu ...>")
        return filename.startswith("<tsubu ") or os.path.abspath(filename).startswith(package)

    frame, level = sys._getframe(1), 2
    while frame is not None and ours(frame.f_code.co_filename):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)

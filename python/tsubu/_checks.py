"""Input checks shared by the public API: every message names the argument and the bad value."""

from __future__ import annotations

import math
import numbers

import numpy as np


def positive(name: str, value, *, allow_zero: bool = False) -> float:
    """A finite real number > 0 (or >= 0 with ``allow_zero``)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be a finite number {bound}, got {value!r}")
    return v


def in_range(name: str, value, lo: float, hi: float, *, lo_open: bool, hi_open: bool) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    v = float(value)
    ok = math.isfinite(v) and (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    if not ok:
        interval = ("(" if lo_open else "[") + f"{lo:g}, {hi:g}" + (")" if hi_open else "]")
        raise ValueError(f"{name} must be in {interval}, got {value!r}")
    return v


def vec3(name: str, value) -> tuple[float, float, float]:
    """A finite 3-vector."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a sequence of 3 numbers, got {value!r}") from None
    if a.shape != (3,):
        raise ValueError(f"{name} must have 3 components, got shape {a.shape}: {value!r}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return (float(a[0]), float(a[1]), float(a[2]))


def points(name: str, value, n: int | None = None) -> np.ndarray:
    """An (n, 3) array of finite floats; a single 3-vector is promoted to shape (1, 3)."""
    try:
        a = np.array(value, dtype=float, order="C", copy=True)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of shape (N, 3), got {type(value).__name__}") from None
    if a.ndim == 1 and a.shape == (3,):
        a = a.reshape(1, 3)
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
    """A scalar or an (n,) array of finite radii > 0."""
    try:
        a = np.array(value, dtype=float, copy=True)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number or an array of shape ({n},), got {value!r}") from None
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
    """One of the names in ``options`` (for the string-valued arguments, ``_core.choices``)."""
    if value not in options:
        names = [f"'{o}'" for o in options]
        listing = ", ".join(names[:-1]) + " or " + names[-1] if len(names) > 1 else names[0]
        raise ValueError(f"{name} must be {listing}, got {value!r}")
    return value


def whole(name: str, value, *, minimum: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value!r}")
    return int(value)

"""Filling a container: regions, size distributions and packing generators (lengths in metres).

Every generator returns a :class:`Packing` ``(positions (N, 3), radii (N,))`` that plugs into
:meth:`tsubu.Simulation.add_spheres`::

    import tsubu
    from tsubu import fill
    box = fill.Box(lower=(0, 0, 0), upper=(0.02, 0.02, 0.04))
    p = fill.random_packing(box, fill.Uniform(0.4e-3, 0.6e-3), solid_fraction=0.3, seed=1)
    sim.add_spheres(p.positions, p.radii, glass)

Regions (:class:`Box`, :class:`Cylinder`, :class:`Region` for any region given as a function)
say which sphere centres lie inside them; size distributions (:class:`Monodisperse`,
:class:`Uniform`, :class:`Normal`, :class:`LogNormal`, :class:`Tabulated`) draw radii;
:func:`lattice` and :func:`random_packing` place spheres. Everything is numpy-only and
deterministic for a seed. ``docs/filling.md`` has the measured solid fractions and speeds.
"""

from __future__ import annotations

import inspect
import math
import numbers
from typing import NamedTuple

import numpy as np

from . import _checks

__all__ = ["Packing", "Box", "Cylinder", "Region", "region_from_dict", "Monodisperse", "Uniform",
           "Normal", "LogNormal", "Tabulated", "distribution_from_dict", "lattice",
           "random_packing"]


class Packing(NamedTuple):
    """What the generators return: ``positions``, the sphere centres [m], shape (N, 3), and
    ``radii`` [m], shape (N,); ``sim.add_spheres(p.positions, p.radii, material)`` adds them."""

    positions: np.ndarray
    radii: np.ndarray


def _sphere_volume(r):
    return 4.0 / 3.0 * math.pi * r ** 3


def _margin_array(margin, n: int) -> np.ndarray:
    m = np.asarray(margin, dtype=float)
    if m.ndim == 0:
        return np.full(n, float(m))
    if m.shape != (n,):
        raise ValueError(f"margin must be a number or have shape ({n},), got shape {m.shape}")
    return m


def _bool_result(name: str, value, n: int) -> np.ndarray:
    a = np.asarray(value)
    if a.shape != (n,) or a.dtype.kind not in "bui":
        raise ValueError(f"{name} must return a bool array of shape ({n},), got "
                         f"{a.dtype} of shape {a.shape}")
    return a.astype(bool)


# ---- regions ----------------------------------------------------------------------------------
class _RegionBase:
    """What every region offers: ``lower``, ``upper`` (bounding box, (3,) arrays [m]),
    ``volume`` [m^3], ``contains(points, margin=0.0)`` and ``to_dict()``."""

    lower: np.ndarray
    upper: np.ndarray

    @property
    def volume(self) -> float:
        raise NotImplementedError

    def contains(self, points, margin=0.0) -> np.ndarray:
        raise NotImplementedError

    def to_dict(self) -> dict:
        raise NotImplementedError


class Box(_RegionBase):
    """An axis-aligned box between the corners ``lower`` and ``upper`` [m] (each a 3-vector,
    ``lower < upper`` in every component; ValueError otherwise)."""

    def __init__(self, lower, upper):
        lo = np.array(_checks.vec3("lower", lower))
        hi = np.array(_checks.vec3("upper", upper))
        if not np.all(lo < hi):
            raise ValueError(f"lower must be < upper in every component, got lower={lo.tolist()}, "
                             f"upper={hi.tolist()}")
        self.lower, self.upper = lo, hi

    @property
    def volume(self) -> float:
        """[m^3]"""
        return float(np.prod(self.upper - self.lower))

    def contains(self, points, margin=0.0) -> np.ndarray:
        """True for each of the points (M, 3) where a sphere of radius ``margin`` (a number or
        (M,)) centred there lies inside the box (touching its faces counts as inside)."""
        x = np.asarray(points, dtype=float).reshape(-1, 3)
        m = _margin_array(margin, len(x))[:, None]
        return np.all((x - m >= self.lower) & (x + m <= self.upper), axis=1)

    def to_dict(self) -> dict:
        """The box as a JSON/TOML-able dict, ``{"type": "box", "lower": [...], "upper": [...]}``
        (read back by :func:`region_from_dict`)."""
        return {"type": "box", "lower": self.lower.tolist(), "upper": self.upper.tolist()}

    def __repr__(self) -> str:
        return f"Box(lower={self.lower.tolist()}, upper={self.upper.tolist()})"


_AXES = {"x": 0, "y": 1, "z": 2}


class Cylinder(_RegionBase):
    """A solid circular cylinder: ``base`` [m] is the centre of its bottom disc, ``radius`` [m]
    (> 0), ``height`` [m] (> 0) along ``axis`` ("x", "y" or "z", default "z")."""

    def __init__(self, base, radius, height, axis: str = "z"):
        self.base = np.array(_checks.vec3("base", base))
        self.radius = _checks.positive("radius", radius)
        self.height = _checks.positive("height", height)
        self.axis = _checks.choice("axis", axis, tuple(_AXES))
        k = _AXES[axis]
        self.lower = self.base - self.radius
        self.upper = self.base + self.radius
        self.lower[k] = self.base[k]
        self.upper[k] = self.base[k] + self.height

    @property
    def volume(self) -> float:
        """[m^3]"""
        return math.pi * self.radius ** 2 * self.height

    def contains(self, points, margin=0.0) -> np.ndarray:
        """True for each of the points (M, 3) where a sphere of radius ``margin`` (a number or
        (M,)) centred there lies inside the cylinder (touching counts as inside)."""
        x = np.asarray(points, dtype=float).reshape(-1, 3)
        m = _margin_array(margin, len(x))
        k = _AXES[self.axis]
        i, j = [a for a in range(3) if a != k]
        d = x - self.base
        rho2 = d[:, i] ** 2 + d[:, j] ** 2
        room = self.radius - m
        return (room >= 0) & (rho2 <= room * room) & (d[:, k] >= m) & (d[:, k] + m <= self.height)

    def to_dict(self) -> dict:
        """The cylinder as a JSON/TOML-able dict, ``{"type": "cylinder", "base": [...],
        "radius": r, "height": h, "axis": "z"}`` (read back by :func:`region_from_dict`)."""
        return {"type": "cylinder", "base": self.base.tolist(), "radius": self.radius,
                "height": self.height, "axis": self.axis}

    def __repr__(self) -> str:
        return (f"Cylinder(base={self.base.tolist()}, radius={self.radius!r}, "
                f"height={self.height!r}, axis={self.axis!r})")


def _fibonacci_directions(count: int) -> np.ndarray:
    k = np.arange(count) + 0.5
    z = 1.0 - 2.0 * k / count
    phi = math.pi * (3.0 - math.sqrt(5.0)) * k
    s = np.sqrt(1.0 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


# Directions at which a function region without a margin argument is probed around a centre:
# 64 points spaced evenly on the sphere (neighbours about 0.45 rad apart), so a sphere may cross
# a curved boundary by a few percent of its radius between them.
_PROBES = _fibonacci_directions(64)


class Region(_RegionBase):
    """Any region, given as a function, inside the bounding box ``lower``, ``upper`` [m].

    ``contains(points)`` takes centre points (M, 3) and returns a bool array (M,), True inside.
    If it also takes a second argument ``margin`` (a number or an (M,) array of radii [m]), it
    must return True where the whole sphere of that radius is inside, and is then exact.
    Otherwise a sphere counts as inside when its centre and 64 points evenly spread over its
    surface are inside: exact for boxes, within a few percent of the radius for curved
    boundaries (give the margin form when that matters).

    ``volume`` [m^3]: give it when known; otherwise it is estimated from the function on a
    regular grid of 10^6 points in the bounding box (relative error about the boundary's share
    of grid cells, ~1%). Not serialisable: ``to_dict`` raises ValueError.
    """

    def __init__(self, contains, lower, upper, volume=None):
        if not callable(contains):
            raise TypeError(f"contains must be a function of points (M, 3), got {contains!r}")
        box = Box(lower, upper)  # checks lower < upper
        self.lower, self.upper = box.lower, box.upper
        self._function = contains
        self._takes_margin = _takes_margin(contains)
        self._volume = None if volume is None else _checks.positive("volume", volume)

    @property
    def volume(self) -> float:
        """[m^3] (given, or estimated once on a grid)."""
        if self._volume is None:
            n = 100
            axes = [self.lower[a] + (np.arange(n) + 0.5) / n * (self.upper[a] - self.lower[a])
                    for a in range(3)]
            inside = 0
            gx, gy = np.meshgrid(axes[0], axes[1], indexing="ij")
            for z in axes[2]:  # one layer at a time keeps memory small
                layer = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, z)], axis=1)
                inside += int(np.count_nonzero(self._call(layer)))
            self._volume = inside / n ** 3 * float(np.prod(self.upper - self.lower))
            if self._volume == 0:
                raise ValueError("Region: contains() is False at every point of a 100^3 grid in "
                                 "the bounding box: the region is empty (or give volume=)")
        return self._volume

    def _call(self, points, margin=None) -> np.ndarray:
        if margin is None:
            out = self._function(points)
        else:
            out = self._function(points, margin)
        return _bool_result("contains", out, len(points))

    def contains(self, points, margin=0.0) -> np.ndarray:
        """True for each of the points (M, 3) where a sphere of radius ``margin`` (a number or
        (M,)) centred there lies inside the region and its bounding box."""
        x = np.asarray(points, dtype=float).reshape(-1, 3)
        m = _margin_array(margin, len(x))
        ok = Box.contains(self, x, m)
        if not ok.any():
            return ok
        idx = np.flatnonzero(ok)
        if self._takes_margin:
            ok[idx] = self._call(x[idx], m[idx])
            return ok
        inside = self._call(x[idx])
        rounded = idx[inside & (m[idx] > 0)]
        if len(rounded):
            probes = x[rounded, None, :] + m[rounded, None, None] * _PROBES[None, :, :]
            hit = self._call(probes.reshape(-1, 3)).reshape(len(rounded), len(_PROBES))
            inside[np.searchsorted(idx, rounded)] = hit.all(axis=1)
        ok[idx] = inside
        return ok

    def to_dict(self) -> dict:
        """Always raises ValueError: a region given as a function cannot be written to a file."""
        raise ValueError("a Region given as a function cannot be written to a file: use Box or "
                         "Cylinder, or build the region in Python")

    def __repr__(self) -> str:
        return f"Region({self._function!r}, lower={self.lower.tolist()}, upper={self.upper.tolist()})"


def _takes_margin(function) -> bool:
    try:
        params = list(inspect.signature(function).parameters.values())
    except (TypeError, ValueError):
        return False
    if any(p.name == "margin" for p in params):
        return True
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len(positional) >= 2 or any(p.kind == p.VAR_POSITIONAL for p in params)


def _from_dict(kind: str, d, classes: dict):
    if not isinstance(d, dict):
        raise TypeError(f"{kind} must be a dict (a table), got {d!r}")
    if "type" not in d:
        raise ValueError(f"{kind}: missing key 'type' (one of {', '.join(map(repr, classes))})")
    name = d["type"]
    if name not in classes:
        raise ValueError(f"{kind}.type must be one of {', '.join(map(repr, classes))}, got {name!r}")
    cls = classes[name]
    args = {k: v for k, v in d.items() if k != "type"}
    params = inspect.signature(cls.__init__).parameters
    known = [p for p in params if p != "self"]
    for key in args:
        if key not in known:
            raise ValueError(f"{kind}: unknown key {key!r} for type {name!r} (expected "
                             f"{', '.join(map(repr, known))})")
    required = [p for p, v in params.items() if p != "self" and v.default is inspect.Parameter.empty]
    for key in required:
        if key not in args:
            raise ValueError(f"{kind}: missing key {key!r} for type {name!r}")
    return cls(**args)


def region_from_dict(d: dict):
    """The region that ``d``, a :meth:`Box.to_dict` or :meth:`Cylinder.to_dict` dict, describes
    (``{"type": "box", "lower": [...], "upper": [...]}``, ``{"type": "cylinder", "base": [...],
    "radius": r, "height": h, "axis": "z"}``). TypeError when ``d`` is not a dict; ValueError for
    a missing or unknown key or a bad value."""
    return _from_dict("region", d, {"box": Box, "cylinder": Cylinder})


# ---- size distributions -----------------------------------------------------------------------
def _phi(x: float) -> float:
    return math.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi) if math.isfinite(x) else 0.0


def _Phi(x: float) -> float:
    return 0.5 * (1.0 + math.erf(x / math.sqrt(2.0)))


def _truncated_standard_normal(rng, n: int, a: float, b: float, mass: float) -> np.ndarray:
    """n draws of a standard normal restricted to [a, b] (``mass`` = Phi(b) - Phi(a)), by
    rejection in batches sized from the acceptance rate."""
    out = np.empty(n)
    filled = 0
    while filled < n:
        want = n - filled
        draw = rng.standard_normal(int(want / mass * 1.1) + 16)
        keep = draw[(draw >= a) & (draw <= b)][:want]
        out[filled:filled + len(keep)] = keep
        filled += len(keep)
    return out


class _Distribution:
    """What every size distribution offers: ``sample(n, rng)``, ``min_radius``, ``max_radius``,
    ``mean_volume`` and ``to_dict()``."""

    min_radius: float
    max_radius: float

    def sample(self, n: int, rng=None) -> np.ndarray:
        """n radii [m], shape (n,), drawn with ``rng`` (a numpy Generator, or a seed for one)."""
        n = _checks.whole("n", n)
        return self._sample(n, _generator(rng))

    @property
    def mean_volume(self) -> float:
        """Mean volume per sphere, E[4/3 pi r^3] [m^3]."""
        return 4.0 / 3.0 * math.pi * self._mean_cube()

    def __repr__(self) -> str:
        d = self.to_dict()
        kind = type(self).__name__
        return f"{kind}(" + ", ".join(f"{k}={v!r}" for k, v in d.items() if k != "type") + ")"


def _generator(rng) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None:
        return np.random.default_rng(0)
    return np.random.default_rng(_checks.whole("rng", rng))


class Monodisperse(_Distribution):
    """Every sphere of one ``radius`` [m] (> 0)."""

    def __init__(self, radius):
        self.radius = _checks.positive("radius", radius)
        self.min_radius = self.max_radius = self.radius

    def _sample(self, n, rng):
        return np.full(n, self.radius)

    def _mean_cube(self):
        return self.radius ** 3

    def to_dict(self) -> dict:
        """The distribution as a JSON/TOML-able dict, ``{"type": "monodisperse", ...}`` with the
        constructor's arguments as keys (read back by :func:`distribution_from_dict`)."""
        return {"type": "monodisperse", "radius": self.radius}


class Uniform(_Distribution):
    """Radii uniform in [``min_radius``, ``max_radius``] [m] (0 < min < max) by number."""

    def __init__(self, min_radius, max_radius):
        self.min_radius = _checks.positive("min_radius", min_radius)
        self.max_radius = _checks.positive("max_radius", max_radius)
        if not self.min_radius < self.max_radius:
            raise ValueError(f"min_radius must be < max_radius, got min_radius={min_radius!r}, "
                             f"max_radius={max_radius!r} (equal radii: use Monodisperse)")

    def _sample(self, n, rng):
        return self.min_radius + (self.max_radius - self.min_radius) * rng.random(n)

    def _mean_cube(self):
        a, b = self.min_radius, self.max_radius
        return (b ** 4 - a ** 4) / (4.0 * (b - a))

    def to_dict(self) -> dict:
        """The distribution as a JSON/TOML-able dict, ``{"type": "uniform", ...}`` with the
        constructor's arguments as keys (read back by :func:`distribution_from_dict`)."""
        return {"type": "uniform", "min_radius": self.min_radius, "max_radius": self.max_radius}


def _truncation(name_low: str, name_high: str, low, high, centre: float, spread: float,
                positive_low: bool):
    """Bounds of a truncated normal: given, or centre -/+ 3 spread."""
    lo = centre - 3.0 * spread if low is None else _checks._real(name_low, low)
    hi = centre + 3.0 * spread if high is None else _checks._real(name_high, high)
    if positive_low and not lo > 0:
        if low is None:
            raise ValueError(f"{name_low} defaults to mean_radius - 3 std = {lo!r}, which is not "
                             f"> 0: give {name_low} > 0")
        raise ValueError(f"{name_low} must be > 0, got {low!r}")
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"{name_low} must be < {name_high} (both finite), got {lo!r} and {hi!r}")
    a, b = (lo - centre) / spread, (hi - centre) / spread
    mass = _Phi(b) - _Phi(a)
    if not mass >= 1e-4:
        raise ValueError(f"{name_low}={lo!r}, {name_high}={hi!r} keep only {mass:.3g} of the "
                         "distribution (at least 1e-4 is needed): move them towards the centre")
    return lo, hi, a, b, mass


class Normal(_Distribution):
    """Radii normally distributed by number: ``mean_radius`` [m] (> 0), standard deviation
    ``std`` [m] (> 0), truncated to [``min_radius``, ``max_radius``] (default mean -/+ 3 std;
    ``min_radius`` must be > 0: ValueError when the default is not, give it then). The mean and
    spread of the samples are those of the truncated normal, not quite ``mean_radius`` and
    ``std`` when the bounds cut much."""

    def __init__(self, mean_radius, std, min_radius=None, max_radius=None):
        self.mean_radius = _checks.positive("mean_radius", mean_radius)
        self.std = _checks.positive("std", std)
        self.min_radius, self.max_radius, self._a, self._b, self._mass = _truncation(
            "min_radius", "max_radius", min_radius, max_radius, self.mean_radius, self.std, True)

    def _sample(self, n, rng):
        z = _truncated_standard_normal(rng, n, self._a, self._b, self._mass)
        return np.clip(self.mean_radius + self.std * z, self.min_radius, self.max_radius)

    def _mean_cube(self):
        # Moments of the truncated standard normal: m_k = (k-1) m_{k-2} + (a^{k-1} phi(a) -
        # b^{k-1} phi(b)) / Z, then E[(mu + s X)^3] by the binomial expansion.
        a, b, z = self._a, self._b, self._mass
        m = [1.0, (_phi(a) - _phi(b)) / z]
        for k in (2, 3):
            m.append((k - 1) * m[k - 2] + (a ** (k - 1) * _phi(a) - b ** (k - 1) * _phi(b)) / z)
        mu, s = self.mean_radius, self.std
        return mu ** 3 + 3 * mu ** 2 * s * m[1] + 3 * mu * s ** 2 * m[2] + s ** 3 * m[3]

    def to_dict(self) -> dict:
        """The distribution as a JSON/TOML-able dict, ``{"type": "normal", ...}`` with the
        constructor's arguments as keys (read back by :func:`distribution_from_dict`)."""
        return {"type": "normal", "mean_radius": self.mean_radius, "std": self.std,
                "min_radius": self.min_radius, "max_radius": self.max_radius}


class LogNormal(_Distribution):
    """Radii whose logarithm is normal, by number: ``median_radius`` [m] (> 0) and ``sigma``
    (> 0) the standard deviation of ln r, truncated to [``min_radius``, ``max_radius``]
    (default median exp(-/+ 3 sigma))."""

    def __init__(self, median_radius, sigma, min_radius=None, max_radius=None):
        self.median_radius = _checks.positive("median_radius", median_radius)
        self.sigma = _checks.positive("sigma", sigma)
        mu = math.log(self.median_radius)
        low = None if min_radius is None else _checks.positive("min_radius", min_radius)
        high = None if max_radius is None else _checks.positive("max_radius", max_radius)
        if low is not None and high is not None and not low < high:
            raise ValueError(f"min_radius must be < max_radius, got {min_radius!r} and {max_radius!r}")
        _, _, self._a, self._b, self._mass = _truncation(
            "ln(min_radius)", "ln(max_radius)", None if low is None else math.log(low),
            None if high is None else math.log(high), mu, self.sigma, False)
        self.min_radius = low if low is not None else self.median_radius * math.exp(self._a * self.sigma)
        self.max_radius = high if high is not None else self.median_radius * math.exp(self._b * self.sigma)

    def _sample(self, n, rng):
        z = _truncated_standard_normal(rng, n, self._a, self._b, self._mass)
        return np.clip(self.median_radius * np.exp(self.sigma * z), self.min_radius, self.max_radius)

    def _mean_cube(self):
        # E[exp(3 sigma X)] for X truncated to [a, b]: exp(9 sigma^2 / 2) (Phi(b - 3 sigma) -
        # Phi(a - 3 sigma)) / Z.
        s3 = 3.0 * self.sigma
        return (self.median_radius ** 3 * math.exp(0.5 * s3 * s3)
                * (_Phi(self._b - s3) - _Phi(self._a - s3)) / self._mass)

    def to_dict(self) -> dict:
        """The distribution as a JSON/TOML-able dict, ``{"type": "lognormal", ...}`` with the
        constructor's arguments as keys (read back by :func:`distribution_from_dict`)."""
        return {"type": "lognormal", "median_radius": self.median_radius, "sigma": self.sigma,
                "min_radius": self.min_radius, "max_radius": self.max_radius}


class Tabulated(_Distribution):
    """A particle-size distribution from a table: ``fractions[k]`` is the cumulative fraction
    of spheres finer than ``radii[k]`` [m], by number (``basis="number"``) or by mass
    (``basis="mass"``, the sieve analysis form).

    ``radii`` strictly increasing and > 0; ``fractions`` non-decreasing, starting at 0 and
    ending at 1 (as many as radii, at least 2). Between table points the cumulative fraction is
    linear in radius (in the basis given); radii are drawn by inverse transform. By mass, the
    number density in a bin is proportional to r^-3 (a constant mass density), so a large
    sample's mass-weighted cumulative fraction follows the table.
    """

    def __init__(self, radii, fractions, basis: str = "number"):
        r = _checks._float_array("radii", radii, "a sequence of radii")
        f = _checks._float_array("fractions", fractions, "a sequence of fractions")
        self.basis = _checks.choice("basis", basis, ("number", "mass"))
        if r.ndim != 1 or len(r) < 2:
            raise ValueError(f"radii must be a 1-D sequence of at least 2 radii, got shape {r.shape}")
        if f.shape != r.shape:
            raise ValueError(f"fractions must have one value per radius ({len(r)}), got shape {f.shape}")
        bad = ~(np.isfinite(r) & (r > 0))
        if bad.any():
            k = int(np.argmax(bad))
            raise ValueError(f"radii must be finite and > 0: entry {k} is {r[k]!r}")
        if not np.all(np.diff(r) > 0):
            k = int(np.argmax(~(np.diff(r) > 0))) + 1
            raise ValueError(f"radii must be strictly increasing: entry {k} ({r[k]!r}) follows "
                             f"{r[k - 1]!r}")
        if not np.all(np.isfinite(f)):
            raise ValueError(f"fractions must be finite, got {f.tolist()}")
        if not np.all(np.diff(f) >= 0):
            k = int(np.argmax(~(np.diff(f) >= 0))) + 1
            raise ValueError(f"fractions must be non-decreasing (cumulative): entry {k} ({f[k]!r}) "
                             f"is below {f[k - 1]!r}")
        if f[0] != 0 or f[-1] != 1:
            raise ValueError(f"fractions must start at 0 and end at 1 (cumulative fraction finer "
                             f"than each radius), got {f[0]!r} ... {f[-1]!r}")
        self.radii, self.fractions = r, f
        used = np.flatnonzero(np.diff(f) > 0)
        self.min_radius = float(r[used[0]])
        self.max_radius = float(r[used[-1] + 1])
        lo, hi, df = r[:-1], r[1:], np.diff(f)
        if self.basis == "number":
            self._bin_number = df
        else:
            # mass density df/(hi - lo) per unit radius, number density ~ that / r^3
            self._bin_number = df / (hi - lo) * 0.5 * (lo ** -2.0 - hi ** -2.0)
        self._bin_number = self._bin_number / self._bin_number.sum()
        self._bin_cdf = np.concatenate([[0.0], np.cumsum(self._bin_number)])
        self._bin_cdf[-1] = 1.0

    def _sample(self, n, rng):
        u = rng.random(n)
        if self.basis == "number":
            return np.clip(np.interp(u, self.fractions, self.radii), self.min_radius, self.max_radius)
        k = np.clip(np.searchsorted(self._bin_cdf, u, side="right") - 1, 0, len(self._bin_number) - 1)
        k = np.where(self._bin_number[k] > 0, k, _next_used(self._bin_number)[k])
        w = (u - self._bin_cdf[k]) / self._bin_number[k]
        lo, hi = self.radii[k], self.radii[k + 1]
        inv2 = lo ** -2.0 - np.clip(w, 0.0, 1.0) * (lo ** -2.0 - hi ** -2.0)
        return np.clip(inv2 ** -0.5, lo, hi)

    def _mean_cube(self):
        lo, hi = self.radii[:-1], self.radii[1:]
        df = np.diff(self.fractions)
        if self.basis == "number":
            return float(np.sum(df * (hi ** 4 - lo ** 4) / (4.0 * (hi - lo))))
        # E[r^3] = (mass, 1) / (number per unit mass density) = 1 / sum(c_k/2 (lo^-2 - hi^-2))
        return float(1.0 / np.sum(df / (hi - lo) * 0.5 * (lo ** -2.0 - hi ** -2.0)))

    def to_dict(self) -> dict:
        """The distribution as a JSON/TOML-able dict, ``{"type": "tabulated", ...}`` with the
        constructor's arguments as keys (read back by :func:`distribution_from_dict`)."""
        return {"type": "tabulated", "radii": self.radii.tolist(),
                "fractions": self.fractions.tolist(), "basis": self.basis}


def _next_used(weights: np.ndarray) -> np.ndarray:
    """For each bin, the index of the first bin at or after it with weight > 0 (u landing on
    the edge of an empty bin goes to the next bin that has spheres)."""
    used = np.flatnonzero(weights > 0)
    pos = np.minimum(np.searchsorted(used, np.arange(len(weights))), len(used) - 1)
    return used[pos]


_DISTRIBUTIONS = {"monodisperse": Monodisperse, "uniform": Uniform, "normal": Normal,
                  "lognormal": LogNormal, "tabulated": Tabulated}


def distribution_from_dict(d: dict):
    """The size distribution that ``d``, a ``to_dict()`` dict, describes (``{"type": "uniform",
    "min_radius": ..., "max_radius": ...}``; types "monodisperse", "uniform", "normal",
    "lognormal", "tabulated" with their constructor's arguments as keys). TypeError when ``d``
    is not a dict; ValueError for a missing or unknown key or a bad value."""
    return _from_dict("sizes", d, _DISTRIBUTIONS)


def _sizes(sizes):
    """A distribution, or a radius [m] for a monodisperse one."""
    if isinstance(sizes, _Distribution):
        return sizes
    if isinstance(sizes, numbers.Real) and not isinstance(sizes, bool):
        return Monodisperse(sizes)
    raise TypeError(f"sizes must be a size distribution (tsubu.fill.Uniform, ...) or a radius, "
                    f"got {sizes!r}")


def _region(region):
    if not isinstance(region, _RegionBase):
        raise TypeError(f"region must be a tsubu.fill region (Box, Cylinder, Region), got {region!r}")
    return region


# Lattice rows that fit up to this fraction of a spacing are kept (rounding in extent / spacing).
_ROUNDING = 1e-9


# ---- lattice ----------------------------------------------------------------------------------
def lattice(region, radius, spacing=None, kind: str = "cubic", jitter=0.0, seed: int = 0) -> Packing:
    """Spheres of one ``radius`` [m] on a lattice filling ``region``, centred in its bounding box.

    Parameters
    ----------
    region : Box, Cylinder or Region
        Where the spheres go (only sites whose whole sphere lies inside are kept).
    radius : float
        The spheres' radius [m] (> 0).
    spacing : float or None
        Distance between nearest neighbours [m], >= 2 radius (default 2 radius: touching).
    kind : str
        "cubic" (simple cubic, solid fraction pi/6 = 0.524 at the default spacing; the default)
        or "hexagonal" (hexagonal close packing, ABAB layers along z, 0.740).
    jitter : float
        In [0, 1] (default 0): each sphere is moved by a random vector of length up to
        ``jitter`` x (spacing - 2 radius) / 2, so spheres never overlap and stay inside the
        region (a lattice site is kept only when the sphere fits wherever the jitter takes it).
    seed : int
        Seed of the jitter (default 0).

    Returns
    -------
    Packing
        Sites in x-fastest, then y, then z order.

    Raises
    ------
    ValueError
        For bad values (named), including jitter > 0 with no gap (spacing = 2 radius).
    TypeError
        When ``region`` is not a region of this module.
    """
    region = _region(region)
    r = _checks.positive("radius", radius)
    s = 2.0 * r if spacing is None else _checks.positive("spacing", spacing)
    if s < 2.0 * r:
        raise ValueError(f"spacing must be >= 2 radius = {2 * r!r} (spheres would overlap), got {spacing!r}")
    _checks.choice("kind", kind, ("cubic", "hexagonal"))
    j = _checks.in_range("jitter", jitter, 0.0, 1.0, lo_open=False, hi_open=False)
    seed = _checks.whole("seed", seed, maximum=2**64 - 1)
    gap = s - 2.0 * r
    if j > 0 and gap <= 0:
        raise ValueError(f"jitter={jitter!r} needs room to move: give spacing > 2 radius = {2 * r!r}")
    shift = j * gap / 2.0
    reach = r + shift
    extent = region.upper - region.lower
    if kind == "cubic":
        step = np.array([s, s, s])
        counts = np.floor(np.maximum(extent - 2 * reach, -1.0) / step + _ROUNDING).astype(np.int64) + 1
        counts = np.maximum(counts, 0)
        _checks.fits_in_memory("spacing", int(np.prod(counts)), "lattice sites")
        grids = [np.arange(c) * step[a] for a, c in enumerate(counts)]
        gz, gy, gx = np.meshgrid(grids[2], grids[1], grids[0], indexing="ij")
        sites = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)
    else:
        row, layer = s * math.sqrt(3.0) / 2.0, s * math.sqrt(2.0 / 3.0)
        # rows are shifted by s/2 every other row, and B layers by (s/2, s/(2 sqrt 3))
        span = extent - 2 * reach
        counts = np.array([math.floor((span[0] - s / 2) / s + _ROUNDING) + 1 if span[0] >= s / 2 else
                           (1 if span[0] >= 0 else 0),
                           math.floor((span[1] - s / (2 * math.sqrt(3))) / row + _ROUNDING) + 1
                           if span[1] >= 0 else 0,
                           math.floor(span[2] / layer + _ROUNDING) + 1 if span[2] >= 0 else 0])
        counts = np.maximum(counts, 0)
        _checks.fits_in_memory("spacing", int(np.prod(counts)), "lattice sites")
        k, jj, i = np.meshgrid(np.arange(counts[2]), np.arange(counts[1]), np.arange(counts[0]),
                               indexing="ij")
        i, jj, k = i.ravel(), jj.ravel(), k.ravel()
        b = k % 2
        x = i * s + ((jj + b) % 2) * s / 2  # B layers shift rows by s/2 (modulo s)
        y = jj * row + b * s / (2 * math.sqrt(3))
        z = k * layer
        sites = np.stack([x, y, z], axis=1).astype(float)
    if len(sites):
        centre = (region.lower + region.upper) / 2
        sites += centre - (sites.min(axis=0) + sites.max(axis=0)) / 2
        # a lattice that fits exactly (spheres touching the faces) may cross them by rounding
        snapped = np.clip(sites, region.lower + reach, region.upper - reach)
        sites = np.where(np.abs(snapped - sites) <= _ROUNDING * s, snapped, sites)
        sites = sites[region.contains(sites, reach)]
    if shift > 0 and len(sites):
        rng = np.random.default_rng(seed)
        direction = rng.standard_normal(sites.shape)
        norm = np.linalg.norm(direction, axis=1, keepdims=True)
        direction /= np.where(norm > 0, norm, 1.0)
        length = shift * rng.random(len(sites)) ** (1.0 / 3.0)  # uniform in the ball
        sites = sites + direction * length[:, None] * (1.0 - 1e-12)
    return Packing(np.ascontiguousarray(sites, dtype=float), np.full(len(sites), r))


# ---- random sequential addition ----------------------------------------------------------------
# Two spheres count as overlapping unless their centres are this fraction further apart than the
# sum of radii: a margin far above rounding, so a check of d >= r_i + r_j, done any way, passes.
_GAP = 1e-9
# Offsets of the 27 cells around a cell (including itself), in the grid's flat index.
_NEIGHBOURS = np.array([(dx, dy, dz) for dz in (-1, 0, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)])


class _CellGrid:
    """Placed spheres in a linked-cell grid whose cells are at least the largest contact
    distance wide, so overlaps are found in the 27 cells around a point. Each cell keeps its
    spheres' (x, y, z, r) in up to ``capacity`` slots (NaN when empty, which never overlaps), so
    one gather reads a neighbourhood; the capacity grows when a cell fills. A ring of empty
    cells around the box saves bounds checks."""

    def __init__(self, lower, upper, cell: float, expected: int):
        extent = np.maximum(upper - lower, 0.0)
        # keep the cell count near the expected sphere count (a few spheres in a huge box)
        ncell = np.ceil(extent / cell)
        while np.prod(ncell + 2) > 4 * expected + 4096:
            cell *= 1.25
            ncell = np.ceil(extent / cell)
        self.lower, self.cell = lower, cell
        self.dims = (np.maximum(ncell, 1) + 2).astype(np.int64)
        self.stride = np.array([1, self.dims[0], self.dims[0] * self.dims[1]], dtype=np.int64)
        self.offsets = _NEIGHBOURS @ self.stride
        self.slots = np.full((int(np.prod(self.dims)), 2, 4), np.nan)
        self.count = np.zeros(len(self.slots), dtype=np.int64)
        self.fill = 0  # the largest count of any cell
        self.size = 0

    def _cells(self, x):
        c = np.floor((x - self.lower) / self.cell).astype(np.int64) + 1
        c = np.clip(c, 1, self.dims - 2)
        return c @ self.stride

    def add(self, x, r) -> None:
        n = len(x)
        if n == 0:
            return
        cells = self._cells(x)
        order = np.argsort(cells, kind="stable")
        sorted_cells = cells[order]
        first = np.searchsorted(sorted_cells, sorted_cells, side="left")
        slot = self.count[sorted_cells] + np.arange(n) - first
        need = int(slot.max()) + 1
        if need > self.slots.shape[1]:
            wider = np.full((len(self.slots), max(need, self.slots.shape[1] + 2), 4), np.nan)
            wider[:, :self.slots.shape[1]] = self.slots
            self.slots = wider
        self.slots[sorted_cells, slot, :3] = x[order]
        self.slots[sorted_cells, slot, 3] = r[order]
        np.add.at(self.count, cells, 1)
        self.fill = max(self.fill, need)
        self.size += n

    def overlaps(self, x, r) -> np.ndarray:
        """True where a sphere (x, r) would overlap a sphere of the grid."""
        out = np.zeros(len(x), dtype=bool)
        if self.size == 0 or len(x) == 0:
            return out
        width = 27 * self.fill
        chunk = max(1, 200_000 // width)
        cells = self._cells(x)
        for s in range(0, len(x), chunk):
            xs, rs = x[s:s + chunk], r[s:s + chunk]
            near = self.slots[cells[s:s + chunk, None] + self.offsets[None, :], :self.fill]
            near = near.reshape(len(xs), width, 4)
            dx = near[:, :, 0] - xs[:, 0:1]
            dy = near[:, :, 1] - xs[:, 1:2]
            dz = near[:, :, 2] - xs[:, 2:3]
            reach = (near[:, :, 3] + rs[:, None]) * (1.0 + _GAP)
            with np.errstate(invalid="ignore"):
                out[s:s + chunk] = np.any(dx * dx + dy * dy + dz * dz < reach * reach, axis=1)
        return out


def _conflicts(x, r) -> list:
    """For each of the points (in order), the earlier points whose spheres it would overlap."""
    n = len(x)
    found = [None] * n
    chunk = 256
    for s in range(0, n, chunk):
        d = x[s:s + chunk, None, :] - x[None, :, :]
        d2 = np.einsum("ijk,ijk->ij", d, d)
        reach = (r[s:s + chunk, None] + r[None, :]) * (1.0 + _GAP)
        hit = d2 < reach * reach
        hit &= np.arange(n)[None, :] < np.arange(s, min(s + chunk, n))[:, None]
        rows, cols = np.nonzero(hit)
        for k in np.unique(rows):
            found[s + k] = cols[rows == k]
    return found


# Spheres this fraction smaller than the largest unplaced one share its candidate points: a point
# where the larger sphere fits holds a smaller one too, with a bias in where the smaller spheres
# go that this bound keeps negligible.
_SHARED_SPREAD = 0.02


def _sequential_addition(region, radii, rng, grid: _CellGrid, max_attempts: int, batch: int = 1024):
    """Place spheres of ``radii`` (in order, each no larger than the one before unless it waits
    its turn) at uniform random points of ``region`` where they overlap neither ``grid``'s
    spheres nor each other, adding them to ``grid``.

    Each round draws ``batch`` candidate points for the first unplaced sphere's radius and keeps
    those inside the region and clear of the grid; in order, each one that overlaps no point
    accepted before it in the round goes to the next unplaced sphere, as long as that sphere is
    no larger than the first and within 2% of it (a window also bounded by twice the expected
    number of hits, so the spheres of a round stay alike). The result depends only on the
    generator's stream. Stops when every sphere is placed or ``max_attempts`` candidates in a
    row found no room. Returns (positions (n, 3), NaN where not placed; placed mask)."""
    n = len(radii)
    positions = np.full((n, 3), np.nan)
    placed = np.zeros(n, dtype=bool)
    extent = region.upper - region.lower
    head, misses, hit_rate = 0, 0, 1.0
    while head < n:
        largest = float(radii[head])
        ahead = radii[head:min(n, head + batch, head + max(1, math.ceil(2.0 * batch * hit_rate)))]
        alike = (ahead <= largest) & (ahead >= largest * (1.0 - _SHARED_SPREAD))
        window = len(ahead) if alike.all() else max(1, int(np.argmin(alike)))
        count = min(batch, max_attempts - misses)
        x = region.lower + largest + rng.random((count, 3)) * (extent - 2 * largest)
        ok = region.contains(x, largest)
        if ok.any():
            inside = np.flatnonzero(ok)
            ok[inside] = ~grid.overlaps(x[inside], np.full(len(inside), largest))
        valid = np.flatnonzero(ok)
        accepted = []
        if len(valid):
            before = _conflicts(x[valid], np.full(len(valid), largest))
            taken = np.zeros(len(valid), dtype=bool)
            for k in range(len(valid)):
                if before[k] is not None and taken[before[k]].any():
                    continue
                taken[k] = True
                accepted.append(valid[k])
                if len(accepted) == window:
                    break
        hit_rate = max(len(valid), 0.25) / count
        if accepted:
            who = np.arange(head, head + len(accepted))
            positions[who] = x[accepted]
            placed[who] = True
            grid.add(x[accepted], radii[who])
            head += len(accepted)
            misses = 0
        else:
            misses += count
            if misses >= max_attempts:
                break
    return positions, placed


def random_packing(region, sizes, count=None, solid_fraction=None, seed: int = 0,
                   max_attempts: int = 20_000) -> Packing:
    """A random packing of spheres without overlap in ``region``, by random sequential addition.

    Radii are drawn first, then placed largest first, each at a uniformly random point where it
    lies inside the region and overlaps nothing placed before (candidates are tested in batches
    against a cell grid; spheres within 2% of each other's radius share a batch's points).
    Monodisperse random sequential addition jams near a solid fraction of 0.38 (less in a small
    container, whose walls leave gaps); docs/filling.md gives measured limits and speeds.

    Parameters
    ----------
    region : Box, Cylinder or Region
        Where the spheres go.
    sizes : size distribution or float
        A size distribution (:class:`Monodisperse`, :class:`Uniform`, :class:`Normal`,
        :class:`LogNormal`, :class:`Tabulated`), or a radius [m] for a monodisperse packing.
    count : int or None
        The number of spheres. Exactly one of ``count`` and ``solid_fraction``.
    solid_fraction : float or None
        The sphere volume over the region's volume to reach, in (0, 1): radii are drawn until
        their volume reaches it (so the fraction reached exceeds it by less than one sphere's
        volume over the region's).
    seed : int
        The packing is the same for a seed, and another for another seed (default 0).
    max_attempts : int
        Random positions tried in a row without finding room before giving up (>= 1, default
        20000).

    Returns
    -------
    Packing
        Largest sphere first.

    Raises
    ------
    ValueError
        Saying what was reached, when the spheres do not all fit (ask for less, use a larger
        region, or use :func:`lattice` or pour and settle for denser packings), and for bad
        arguments (named).
    TypeError
        When both or neither of ``count`` and ``solid_fraction`` are given, or ``region`` or
        ``sizes`` is of the wrong kind.
    """
    region = _region(region)
    sizes = _sizes(sizes)
    if (count is None) == (solid_fraction is None):
        raise TypeError("random_packing needs exactly one of count= or solid_fraction=")
    seed = _checks.whole("seed", seed, maximum=2**64 - 1)
    max_attempts = _checks.whole("max_attempts", max_attempts, minimum=1)
    volume = region.volume
    size_rng = np.random.default_rng([seed, 0])
    place_rng = np.random.default_rng([seed, 1])
    if count is not None:
        count = _checks.whole("count", count)
        _checks.fits_in_memory("count", count)
        radii = sizes.sample(count, size_rng)
    else:
        target = _checks.in_range("solid_fraction", solid_fraction, 0.0, 1.0, lo_open=True, hi_open=True)
        expected = target * volume / sizes.mean_volume
        _checks.fits_in_memory("solid_fraction", int(min(expected, 2**62)), "spheres")
        chunk = int(expected * 1.05) + 16
        radii = np.empty(0)
        total = 0.0
        while total < target * volume:
            more = sizes.sample(chunk, size_rng)
            radii = np.concatenate([radii, more])
            total += float(np.sum(_sphere_volume(more)))
        cumulative = np.cumsum(_sphere_volume(radii))
        radii = radii[:int(np.searchsorted(cumulative, target * volume)) + 1]
    radii = np.sort(radii)[::-1].copy()
    if len(radii) == 0:
        return Packing(np.zeros((0, 3)), np.zeros(0))
    extent = region.upper - region.lower
    if 2 * radii[0] > extent.min():
        raise ValueError(f"sizes: the largest radius drawn ({radii[0]!r} m) does not fit in the "
                         f"region, whose bounding box is {extent.tolist()} m")
    asked = float(np.sum(_sphere_volume(radii))) / volume
    if asked > 0.7405:
        raise ValueError(f"{'count' if count is not None else 'solid_fraction'}: {len(radii)} "
                         f"spheres fill {asked:.3f} of the region, more than any packing of equal "
                         "spheres (0.7405) and far beyond random sequential addition (~0.38)")
    grid = _CellGrid(region.lower, region.upper, 2.0 * radii[0] * (1.0 + 2 * _GAP), len(radii))
    positions, placed = _sequential_addition(region, radii, place_rng, grid, max_attempts)
    if not placed.all():
        got = int(placed.sum())
        reached = float(np.sum(_sphere_volume(radii[placed]))) / volume
        raise ValueError(
            f"random_packing placed {got} of {len(radii)} spheres (solid fraction {reached:.4f} "
            f"of {asked:.4f} asked): sphere {got} (radius {float(radii[got])!r} m) found no room "
            f"in {max_attempts} attempts. Random sequential addition jams near 0.38 for equal "
            "spheres (less in small containers): ask for fewer spheres or a larger region, raise "
            "max_attempts, or for denser packings use lattice() or pour the spheres and let "
            "them settle")
    return Packing(positions, radii)

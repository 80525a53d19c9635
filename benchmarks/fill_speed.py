"""How fast tsubu.fill.random_packing places spheres, and what solid fractions random sequential
addition reaches before it jams (docs/filling.md quotes the figures this prints).

    python benchmarks/fill_speed.py            # all: speed at 1e4 and 1e5 spheres, jamming limits
    python benchmarks/fill_speed.py --quick    # 1e4 only and smaller jamming runs

Timings are wall-clock seconds of one call on this machine (one core: numpy only).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from tsubu import fill
from tsubu.fill import _CellGrid, _sequential_addition


def cube_for(count: int, radius: float, fraction: float) -> fill.Box:
    side = (count * 4 / 3 * math.pi * radius ** 3 / fraction) ** (1 / 3)
    return fill.Box((0, 0, 0), (side, side, side))


def speed(count: int, fraction: float, sizes, label: str) -> None:
    radius = sizes.max_radius
    box = cube_for(count, (sizes.mean_volume * 3 / (4 * math.pi)) ** (1 / 3), fraction)
    start = time.perf_counter()
    p = fill.random_packing(box, sizes, solid_fraction=fraction, seed=1)
    seconds = time.perf_counter() - start
    reached = float(np.sum(4 / 3 * math.pi * p.radii ** 3)) / box.volume
    print(f"  {label:<26} N = {len(p.radii):>7}  solid fraction {reached:.3f}  "
          f"{seconds:7.2f} s  ({len(p.radii) / seconds:,.0f} spheres/s; box {box.upper[0] / radius:.0f} radii)")


def jamming(side_in_diameters: float, sizes, attempts: int, label: str) -> None:
    """Place spheres (drawn for a solid fraction of 0.6, far beyond what fits) until one has had
    ``attempts`` candidates without finding room; print the fraction reached."""
    diameter = 2 * sizes.max_radius
    box = fill.Box((0, 0, 0), (side_in_diameters * diameter,) * 3)
    rng = np.random.default_rng(1)
    want = int(0.6 * box.volume / sizes.mean_volume)
    radii = np.sort(sizes.sample(want, rng))[::-1].copy()
    grid = _CellGrid(box.lower, box.upper, 2 * radii[0] * (1 + 2e-9), want)
    start = time.perf_counter()
    _, placed = _sequential_addition(box, radii, rng, grid, attempts)
    seconds = time.perf_counter() - start
    reached = float(np.sum(4 / 3 * math.pi * radii[placed] ** 3)) / box.volume
    print(f"  {label:<26} box {side_in_diameters:>3.0f} d  max_attempts {attempts:>7}  "
          f"N = {int(placed.sum()):>6}  solid fraction {reached:.3f}  {seconds:6.1f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    mono = fill.Monodisperse(0.5e-3)
    poly = fill.Uniform(0.25e-3, 0.5e-3)
    counts = [10_000] if args.quick else [10_000, 100_000]
    print("random_packing, time for a solid fraction in a cube:")
    for count in counts:
        for fraction in (0.2, 0.3):
            speed(count, fraction, mono, f"monodisperse, {fraction}")
        speed(count, 0.3, poly, "uniform r in [0.5, 1] r_max")
    print("jamming: the solid fraction reached when a sphere finds no room:")
    sides = [10, 20] if args.quick else [10, 20, 30]
    for side in sides:
        for attempts in (1_000, 20_000):
            jamming(side, mono, attempts, "monodisperse")
    jamming(sides[-1], poly, 20_000, "uniform r in [0.5, 1] r_max")
    start = time.perf_counter()
    p = fill.lattice(fill.Box((0, 0, 0), (0.1, 0.1, 0.1)), 0.5e-3, kind="hexagonal")
    print(f"lattice: {len(p.radii):,} spheres (hexagonal) in {time.perf_counter() - start:.2f} s")


if __name__ == "__main__":
    main()

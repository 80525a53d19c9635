"""Pouring a polydisperse heap: angle of repose and packing fraction against height.

Glass-like beads with log-normal radii (median 1 mm, sigma of ln r 0.2, truncated to
0.7-1.4 mm) are poured from a narrow stream onto a rough floor, in a channel 8 mm wide whose
side walls are frictionless (a quasi-2D heap: its flanks are straight lines a few grains long,
cheap to measure). An inserter (``sim.add_inserter``, a ``tsubu.insert.Inserter``) places them
during the run, without overlap, at 2000 spheres/s, in a box 6 mm long and 17 mm high, 25 mm above the floor,
falling at 0.3 m/s; after the last one the heap settles until no grain moves faster than
5 mm/s. The floor is rough (a pair override: friction 0.8, rolling friction 0.5, restitution
0.2), as the layer of grains glued to the base in experiments. Then:

- the angle of repose: straight lines fitted to the top surface h(x) of each flank between
  20 % and 80 % of the heap's height;
- the packing fraction against height: horizontal slices one mean radius thick, each over the
  part of the heap at least two diameters below its surface (the solid volume of each sphere
  in the slice exactly, as spherical segments; spheres counted by their centre's x).

Run:  python examples/pouring_heap.py [--quick] [--out DIR] [--figure PNG | --no-figure]

Writes DIR/pouring_heap.npz (positions, velocities, radii, the profile and the packing
fractions), DIR/pouring_heap.json (the figures printed at the end) and the figure (matplotlib,
headless).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time

import numpy as np

import tsubu
from tsubu import fill

from example_support import arguments, figure_path, pyplot, read_npz, save_figure, write_json  # beside this script

GRAVITY = 9.81  # m/s^2
SIZES = fill.LogNormal(median_radius=1.0e-3, sigma=0.2, min_radius=0.7e-3, max_radius=1.4e-3)
DENSITY = 2500.0  # kg/m^3
STIFFNESS = 500.0  # N/m: overlaps under a 15-grain heap stay below 0.5 % of a radius
FRICTION = 0.5
ROLLING_FRICTION = 0.1
RESTITUTION = 0.5
FLOOR_FRICTION = 0.8
FLOOR_ROLLING_FRICTION = 0.5
FLOOR_RESTITUTION = 0.2
WIDTH = 8e-3  # m, between the side walls (4 mean diameters)
RATE = 2000.0  # spheres per second
SOURCE_HEIGHT = 25e-3  # m, bottom of the insertion box
SOURCE_HALF_WIDTH = 3e-3  # m, along x
SOURCE_SPEED = 0.3  # m/s, downwards
REST_SPEED = 0.005  # m/s


def mean_diameter() -> float:
    return 2.0 * float(np.mean(SIZES.sample(100_000, np.random.default_rng(0))))


def pour(count: int, seed: int, threads) -> tuple:
    grain = tsubu.Material(density=DENSITY, kn=STIFFNESS, restitution=RESTITUTION,
                           friction=FRICTION, rolling_friction=ROLLING_FRICTION, name="grain")
    smooth = tsubu.Material(density=DENSITY, kn=STIFFNESS, restitution=RESTITUTION, friction=0.0,
                            name="smooth wall")
    # dt from the smallest grains, fixed before any is poured (the default would be evaluated
    # at each run from the grains present so far).
    probe = tsubu.Simulation()
    probe.add_spheres([(0, 0, 0), (1, 0, 0)], SIZES.min_radius, grain)
    sim = tsubu.Simulation(gravity=(0, 0, -GRAVITY), dt=probe.default_time_step(), threads=threads)
    # A rough base, as the grains glued to the base in experiments: without it the first grains
    # roll away along the floor and no heap forms. Modelled by a pair override: more friction,
    # strong rolling resistance and a softer bounce between grains and floor.
    floor = tsubu.Material(density=DENSITY, kn=STIFFNESS, restitution=RESTITUTION,
                           friction=FRICTION, name="rough floor")
    sim.set_pair(grain, floor, friction=FLOOR_FRICTION, rolling_friction=FLOOR_ROLLING_FRICTION,
                 restitution=FLOOR_RESTITUTION)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=floor)
    sim.add_plane(point=(0, 0, 0), normal=(0, 1, 0), material=smooth)
    sim.add_plane(point=(0, WIDTH, 0), normal=(0, -1, 0), material=smooth)
    source = fill.Box((-SOURCE_HALF_WIDTH, 0.0, SOURCE_HEIGHT),
                      (SOURCE_HALF_WIDTH, WIDTH, SOURCE_HEIGHT + 12 * SIZES.max_radius))
    # The inserter acts between the steps of every run: an event every time a sphere takes to
    # cross the source box, each placing what the rate makes due (what finds no room waits).
    inserter = sim.add_inserter(source, RATE, SIZES, grain, velocity=(0, 0, -SOURCE_SPEED),
                                total=count, seed=seed)
    sim.run(time=count / RATE)
    while not inserter.finished:  # spheres still pending: the stream was blocked for a moment
        sim.run(time=0.01)
    poured = sim.time
    # Settle: at least the fall from the source, then until no grain moves.
    sim.run(time=math.sqrt(2 * SOURCE_HEIGHT / GRAVITY))
    while sim.time < poured + 1.0 and np.max(np.linalg.norm(sim.velocities, axis=1)) >= REST_SPEED:
        sim.run(time=0.02)
    return sim, inserter, poured


def surface_profile(x, z, r, bin_width: float):
    """Bin centres and the top of the heap h = max(z + r) per bin of width `bin_width` (0 where
    no grain)."""
    edges = np.arange(np.floor(x.min() / bin_width) * bin_width, x.max() + bin_width, bin_width)
    which = np.clip(np.digitize(x, edges) - 1, 0, len(edges) - 2)
    top = np.zeros(len(edges) - 1)
    np.maximum.at(top, which, z + r)
    return 0.5 * (edges[1:] + edges[:-1]), top


def flank_fits(centres, top):
    """Straight lines h = a + b x fitted to each flank of the heap between 20 % and 80 % of its
    height, walking out from the peak and stopping where the surface first drops below 20 % (so
    that grains that rolled away from the heap do not count). Returns [(angle_deg, a, b,
    x_used), ...] for the left and the right flank."""
    peak = int(np.argmax(top))
    height = top[peak]
    fits = []
    for step in (-1, 1):
        k, used = peak, []
        while 0 <= k < len(top) and top[k] >= 0.2 * height:
            if top[k] <= 0.8 * height:
                used.append(k)
            k += step
        b, a = np.polyfit(centres[used], top[used], 1)
        fits.append((math.degrees(math.atan(abs(b))), a, b, centres[used]))
    return fits


def segment_volume(zc, r, z0: float, z1: float):
    """Volume of each sphere (centre height zc, radius r) between the planes z0 < z1."""
    def below(u):  # volume of the part of a sphere below height zc + u, u in [-r, r], less its half
        return math.pi * (r * r * u - u ** 3 / 3.0)

    lo = np.clip(z0 - zc, -r, r)
    hi = np.clip(z1 - zc, -r, r)
    return below(hi) - below(lo)


def packing_profile(x, z, r, centres, top, slice_height: float, depth: float):
    """Solid fraction in horizontal slices of the heap's interior: at each height, over the
    x-range where the surface is at least `depth` above the slice's top. Returns the slice
    mid-heights and fractions (NaN where the interior is empty at that height)."""
    bin_width = centres[1] - centres[0]
    mids, fractions = [], []
    for z0 in np.arange(0.0, top.max(), slice_height):
        z1 = z0 + slice_height
        inside = top >= z1 + depth
        mids.append(0.5 * (z0 + z1))
        # The contiguous run of bins around the peak that is deep enough, at least 4 wide.
        peak = int(np.argmax(top))
        left = right = peak
        while left > 0 and inside[left - 1]:
            left -= 1
        while right < len(top) - 1 and inside[right + 1]:
            right += 1
        if not inside[peak] or right - left + 1 < 4:
            fractions.append(math.nan)
            continue
        x_lo, x_hi = centres[left] - bin_width / 2, centres[right] + bin_width / 2
        counted = (x >= x_lo) & (x < x_hi)
        solid = float(np.sum(segment_volume(z[counted], r[counted], z0, z1)))
        fractions.append(solid / ((x_hi - x_lo) * WIDTH * slice_height))
    return np.array(mids), np.array(fractions)


def analyse(sim, inserter, poured: float, wall_seconds: float) -> dict:
    x, r = sim.positions, sim.radii
    d = mean_diameter()
    centres, top = surface_profile(x[:, 0], x[:, 2], r, d)
    fits = flank_fits(centres, top)
    mids, phi = packing_profile(x[:, 0], x[:, 2], r, centres, top, d / 2, 2 * d)
    interior = phi[np.isfinite(phi) & (mids > d)]
    return dict(
        grains=sim.size, inserted=inserter.inserted, inserted_mass=inserter.inserted_mass,
        pour_time=poured, settle_time=sim.time - poured, dt=sim.dt, steps=sim.step_count,
        at_rest=bool(np.max(np.linalg.norm(sim.velocities, axis=1)) < REST_SPEED),
        mean_diameter=d, heap_height=float(top.max()),
        angle_left=fits[0][0], angle_right=fits[1][0],
        angle_of_repose=0.5 * (fits[0][0] + fits[1][0]),
        fits=[(a, b) for _, a, b, _ in fits],
        fit_ranges=[(float(u.min()), float(u.max())) for *_, u in fits],
        mean_packing_fraction=float(np.mean(interior)) if len(interior) else math.nan,
        wall_seconds=wall_seconds,
        positions=x, velocities=sim.velocities, radii=r, profile_x=centres, profile_h=top,
        slice_z=mids, packing_fraction=phi)


def write_outputs(result: dict, out: str) -> dict:
    os.makedirs(out, exist_ok=True)
    arrays = ("positions", "velocities", "radii", "profile_x", "profile_h", "slice_z",
              "packing_fraction")
    np.savez(os.path.join(out, "pouring_heap.npz"), **{k: result[k] for k in arrays})
    summary = {k: v for k, v in result.items() if k not in arrays}
    write_json(os.path.join(out, "pouring_heap.json"), summary)
    return summary


def plot(out: str, figure: str) -> None:
    """The figure, from the files in `out` only."""
    plt = pyplot()
    from matplotlib.collections import EllipseCollection

    with open(os.path.join(out, "pouring_heap.json")) as f:
        s = json.load(f)
    data = read_npz(os.path.join(out, "pouring_heap.npz"))
    x, r = data["positions"] * 1e3, data["radii"] * 1e3  # mm
    fig, (ax_view, ax_phi) = plt.subplots(1, 2, figsize=(13, 4.6),
                                          gridspec_kw=dict(width_ratios=(3, 1)))
    order = np.argsort(x[:, 1])  # the side view from -y: nearest drawn last
    circles = EllipseCollection(2 * r[order], 2 * r[order], 0.0, units="xy",
                                offsets=x[order][:, [0, 2]], offset_transform=ax_view.transData,
                                cmap="coolwarm", linewidths=0.2, edgecolors="k")
    circles.set_array(2 * r[order])
    ax_view.add_collection(circles)
    fig.colorbar(circles, ax=ax_view, label="diameter [mm]", shrink=0.8)
    for (a, b), (lo, hi), name in zip(s["fits"], s["fit_ranges"], ("left", "right")):
        xs = np.array([lo, hi]) * 1e3
        ax_view.plot(xs, (a + b * xs / 1e3) * 1e3, "k-", lw=2)
    ax_view.set_xlim(data["profile_x"].min() * 1e3 - 2, data["profile_x"].max() * 1e3 + 2)
    ax_view.set_ylim(0, s["heap_height"] * 1e3 * 1.15)
    ax_view.set_aspect("equal")
    ax_view.set(xlabel="x [mm]", ylabel="z [mm]",
                title=f"{s['grains']} beads poured at {RATE:g}/s: angle of repose "
                      f"{s['angle_left']:.1f}° (left), {s['angle_right']:.1f}° (right)")
    d = s["mean_diameter"]
    ax_phi.plot(data["packing_fraction"], data["slice_z"] / d, "o-", ms=3)
    ax_phi.axvline(s["mean_packing_fraction"], color="grey", ls="--", lw=1,
                   label=f"mean above 1 d: {s['mean_packing_fraction']:.3f}")
    ax_phi.set(xlabel="packing fraction", ylabel="height / mean diameter",
               title="Packing fraction (heap interior)", xlim=(0.3, 0.7))
    ax_phi.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, figure)


def main(argv=None) -> dict:
    parser = arguments(__doc__.split("\n")[0], "pouring_heap")
    parser.add_argument("--quick", action="store_true", help="300 beads: a test of a few seconds")
    parser.add_argument("--count", type=int, default=None, help="beads to pour (default 600)")
    parser.add_argument("--threads", type=int, default=None, help="OpenMP threads (default: all)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the inserter")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    count = args.count or (300 if args.quick else 600)
    sim, inserter, poured = pour(count, args.seed, args.threads)
    summary = write_outputs(analyse(sim, inserter, poured, time.perf_counter() - started), args.out)
    figure = figure_path(args, "pouring_heap")
    if figure:
        plot(args.out, figure)
    print(f"{summary['grains']} beads poured in {summary['pour_time']:.2f} s, settled "
          f"{summary['settle_time']:.2f} s later{'' if summary['at_rest'] else ' (NOT at rest)'}: "
          f"heap {summary['heap_height'] * 1e3:.1f} mm high, angle of repose "
          f"{summary['angle_left']:.1f} / {summary['angle_right']:.1f} deg (left / right), "
          f"packing fraction {summary['mean_packing_fraction']:.3f} in the interior")
    print(f"wrote {args.out} in {time.perf_counter() - started:.1f} s")
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])

"""Discharge of a wedge (slot) hopper: the mass flow rate against Beverloo's law.

A quasi-2D wedge hopper (``tsubu.mesh.wedge_hopper``: two inclined plates 30 degrees from the
vertical leaving a slot of width D between their lower edges) holds about 2,000 glass-like beads
(mean diameter d = 2 mm, radii uniform within +-10 %, linear contacts, friction 0.5, rolling
friction 0.05) between two frictionless side walls L = 5 d apart (planes: the slab behaves as a
slice of a long slot). The hopper with the narrowest slot is filled by random sequential
addition (``tsubu.fill``) and the beads settle on a plane that closes the slot. The hopper with a
wider slot D and the same plates is the narrow one cut where its gap is D: for each D, the beads
below the cut are left out, the rest settle again on a plane closing the slot (a fall of less
than a diameter), the plane is removed (``sim.remove_wall``) and the beads discharge. The
discharged mass M(t) (beads whose centre has fallen below the slot's plane) is recorded every
5 ms; the steady mass flow rate W is the slope of a straight line fitted to M(t) after a
start-up of 50 ms, while more than a third of the beads are still in the hopper.

The rates are compared with Beverloo's law in its slot form,

    W = C rho_b sqrt(g) L (D - k d)^(3/2),

the slot analogue of Beverloo, Leniger & van de Velde (Chem. Eng. Sci. 15 (1961) 260) for
circular orifices, W = C rho_b sqrt(g) (D - k d)^(5/2) with C ~ 0.58 and k ~ 1.5 (C 0.55-0.65
and k 1.2-3 over materials). Both forms come from the same free-fall-arch scaling: beads cross
the orifice at a speed of order sqrt(g D), through its area less an empty band of width of
order d along its edge; for a slot the area is L (D - k d) (the form discussed e.g. by Myers &
Sellers 1978 and Mankoc et al. 2007, which I could not consult here). rho_b is the bulk
density of the settled pack, measured.
C and k are fitted to the measured points: W^(2/3) is linear in D, slope (C rho_b sqrt(g) L)^(2/3)
and root D = k d. docs/examples.md discusses what to compare them with.

Discharged beads fall freely below the slot until an outlet (``sim.add_outlet``), a plane 4 d
below it, removes them inside the run; the discharged mass counts the beads below the slot and
those the outlet removed (``sim.removed()``).

Run:  python examples/hopper.py [--quick] [--widths 4 5 6 7] [--out DIR]
                                [--figure PNG | --no-figure]

Writes DIR/hopper.json (the figures printed at the end), DIR/hopper_D<D/d>.npz (the discharge
curve M(t), the settled pack, a snapshot during discharge) and the figure (matplotlib,
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
from tsubu import fill, mesh

from example_support import arguments, figure_path, pyplot, read_npz, save_figure, write_json  # beside this script

GRAVITY = 9.81  # m/s^2
DIAMETER = 2e-3  # m, mean bead diameter d
RADIUS_SPREAD = 0.1  # radii uniform in (1 +- 0.1) d/2: no crystalline packing
DENSITY = 2500.0  # kg/m^3
STIFFNESS = 500.0  # N/m: overlaps under a 30-bead column stay below 0.3 % of d
FRICTION = 0.5
ROLLING_FRICTION = 0.05
RESTITUTION = 0.5
LENGTH = 5.0  # slot length L between the frictionless side walls, in diameters
HALF_ANGLE = 30.0  # degrees, plates from the vertical
HEIGHT = 36.0  # plates' height, in diameters
FILL_FRACTION = 0.33  # solid fraction of the random sequential addition before settling
SETTLE_SPEED = 0.02  # m/s: settled when no bead is faster
CHUNK = 0.005  # s between measurements
START_UP = 0.05  # s after opening left out of the fit
REMAINING = 1 / 3  # fit while more than this fraction of the beads is in the hopper
OUTLET_BELOW = 4.0  # diameters below the slot: the outlet's plane


def materials():
    grain = tsubu.Material(density=DENSITY, kn=STIFFNESS, restitution=RESTITUTION,
                           friction=FRICTION, rolling_friction=ROLLING_FRICTION, name="grain")
    # Frictionless side walls (the pair's friction is the geometric mean, so zero): the slab is
    # a slice of a long slot. The plates and the gate have the beads' friction.
    smooth = tsubu.Material(density=DENSITY, kn=STIFFNESS, restitution=RESTITUTION, friction=0.0,
                            name="smooth side wall")
    return grain, smooth


def wedge_region(width: float, top: float, height: float, length: float):
    """The inside of the wedge as a fill region (exact for spheres: the margin form)."""
    tan_a = (top - width) / (2 * height)
    cos_a = math.cos(math.atan(tan_a))

    def inside(x, margin=0.0):
        x = np.asarray(x, dtype=float).reshape(-1, 3)
        m = np.broadcast_to(np.asarray(margin, dtype=float), (len(x),))
        half = 0.5 * width + tan_a * x[:, 2]  # the plates' x at the centre's height
        return ((np.abs(x[:, 0]) + m / cos_a <= half) & (x[:, 2] - m >= 0)
                & (x[:, 2] + m <= height) & (np.abs(x[:, 1]) + m <= 0.5 * length))

    return fill.Region(inside, (-0.5 * top, -0.5 * length, 0.0), (0.5 * top, 0.5 * length, height),
                       volume=0.5 * (width + top) * height * length)


def build(width: float, height: float, positions, radii, threads):
    """The hopper with slot width `width` at z = 0 and plates `height` high, holding the
    given beads, closed by a plane at z = 0. Returns (sim, gate index, geometry dict)."""
    length = LENGTH * DIAMETER
    top = width + 2 * height * math.tan(math.radians(HALF_ANGLE))
    grain, smooth = materials()
    vertices, faces = mesh.wedge_hopper(width, top, height, length)
    sim = tsubu.Simulation(gravity=(0, 0, -GRAVITY), threads=threads)
    # The two inclined plates are the mesh (faces 0-3); its own side walls (faces 4-7) are
    # replaced by frictionless planes, which also keep the falling beads in the slab.
    sim.add_mesh(vertices, faces[:4], grain)
    sim.add_plane(point=(0, -0.5 * length, 0), normal=(0, 1, 0), material=smooth)
    sim.add_plane(point=(0, 0.5 * length, 0), normal=(0, -1, 0), material=smooth)
    gate = sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=grain)
    sim.add_spheres(positions, radii, grain)
    return sim, gate, dict(width=width, top=top, height=height, length=length)


def settled_pack(width: float, count: int, seed: int, threads) -> tuple:
    """About `count` beads settled in the hopper of slot width `width`: random sequential
    addition in the wedge, then settling on the closed slot. Returns (positions, radii,
    plates' height)."""
    # The plates' height grows with the bead count so that the fill starts at the same depth.
    height = HEIGHT * DIAMETER * math.sqrt(count / 2000.0)
    top = width + 2 * height * math.tan(math.radians(HALF_ANGLE))
    length = LENGTH * DIAMETER
    sizes = fill.Uniform((1 - RADIUS_SPREAD) * DIAMETER / 2, (1 + RADIUS_SPREAD) * DIAMETER / 2)
    region = wedge_region(width, top, height, length)
    # About `count` beads: the solid fraction that makes them, at this region's volume.
    mean_volume = 4 / 3 * math.pi * sizes._mean_cube()
    fraction = min(FILL_FRACTION, count * mean_volume / region.volume)
    pack = fill.random_packing(region, sizes, solid_fraction=fraction, seed=seed)
    sim, _, _ = build(width, height, pack.positions, pack.radii, threads)
    settle(sim)
    return sim.positions, sim.radii, height


def cut_pack(positions, radii, height: float, narrowest: float, width: float):
    """The pack settled above the narrowest slot, for the slot `width`: the hopper of slot
    `width` with the same plates is the narrow one cut at the height where its gap is `width`.
    Beads below the cut (less a radius) are left out and the rest moved down by the cut's
    height. Returns (positions, radii, plates' height)."""
    cut = (width - narrowest) / (2 * math.tan(math.radians(HALF_ANGLE)))
    keep = positions[:, 2] - radii >= cut
    x = positions[keep] - (0.0, 0.0, cut)
    return x, radii[keep], height - cut


def settle(sim, limit: float = 0.5) -> float:
    """Run until no bead is faster than SETTLE_SPEED (at most `limit` s); returns the time."""
    while sim.time < limit:
        sim.run(time=0.02)
        if np.max(np.linalg.norm(sim.velocities, axis=1)) < SETTLE_SPEED:
            break
    return sim.time


def bulk_density(x, r, geometry) -> float:
    """Mass over volume of the settled pack in the wedge between 3 d above the slot and 3 d
    below the pack's top (away from the slot's edge and the loose surface)."""
    d = DIAMETER
    z0, z1 = 3 * d, np.max(x[:, 2] + r) - 3 * d
    tan_a = (geometry["top"] - geometry["width"]) / (2 * geometry["height"])
    inside = (x[:, 2] >= z0) & (x[:, 2] < z1)
    mass = float(np.sum(DENSITY * 4 / 3 * math.pi * r[inside] ** 3))
    # The wedge's volume between z0 and z1 (its width grows linearly with z).
    volume = geometry["length"] * (geometry["width"] * (z1 - z0) + tan_a * (z1 ** 2 - z0 ** 2))
    return mass / volume


def discharge(sim, gate: int, geometry: dict, duration: float, snapshot_at: float) -> dict:
    """Open the slot and record the discharged mass every CHUNK until `duration` or until the
    hopper holds less than a fifth of its beads: the beads whose centre is below the slot, and
    those the outlet OUTLET_BELOW d below it has removed."""
    mass_of = dict(zip(sim.ids.tolist(), sim.masses.tolist()))  # by id: rows go as beads leave
    total = float(sum(mass_of.values()))
    before = len(sim.removed()["id"])
    sim.add_outlet(point=(0.0, 0.0, -OUTLET_BELOW * DIAMETER), normal=(0.0, 0.0, 1.0))
    sim.remove_wall(gate)
    t0 = sim.time
    times, discharged, snapshot = [0.0], [0.0], None
    while sim.time - t0 < duration - 0.5 * CHUNK:
        sim.run(time=CHUNK)
        x = sim.positions
        out = x[:, 2] < 0
        gone = sim.removed()["id"][before:]
        times.append(sim.time - t0)
        discharged.append(float(sim.masses[out].sum()) + sum(mass_of[int(i)] for i in gone))
        if snapshot is None and sim.time - t0 >= snapshot_at:
            snapshot = dict(positions=x, speeds=np.linalg.norm(sim.velocities, axis=1),
                            radii=sim.radii, time=sim.time - t0, out=out)
        if discharged[-1] > 0.8 * total:
            break
    return dict(times=np.array(times), discharged=np.array(discharged), total_mass=total,
                snapshot=snapshot)


def flow_rate(times, discharged, total: float):
    """Slope [kg/s] and intercept of the line fitted to M(t) after START_UP while the hopper
    holds more than REMAINING of its mass; and the mask of the points used."""
    used = (times >= START_UP) & (discharged <= (1 - REMAINING) * total)
    if used.sum() < 3:
        return math.nan, math.nan, used
    slope, intercept = np.polyfit(times[used], discharged[used], 1)
    return float(slope), float(intercept), used


def fit_beverloo(widths, rates, rho_b: float, length: float):
    """C and k of W = C rho_b sqrt(g) L (D - k d)^(3/2), from the straight line W^(2/3) against
    D (least squares)."""
    slope, intercept = np.polyfit(widths, np.asarray(rates) ** (2 / 3), 1)
    c = slope ** 1.5 / (rho_b * math.sqrt(GRAVITY) * length)
    k = -intercept / slope / DIAMETER
    return float(c), float(k)


def beverloo(width, c: float, k: float, rho_b: float, length: float):
    """The slot form of Beverloo's law [kg/s] (0 below D = k d)."""
    return c * rho_b * math.sqrt(GRAVITY) * length * np.maximum(np.asarray(width) - k * DIAMETER, 0) ** 1.5


def run_width(ratio: float, pack: tuple, narrowest: float, duration: float, threads) -> tuple:
    started = time.process_time()
    width = ratio * DIAMETER
    x, r, height = cut_pack(*pack, narrowest, width)
    sim, gate, geometry = build(width, height, x, r, threads)
    settled_at = settle(sim)  # what the cut loosened (a fall of less than a diameter)
    x0, r0 = sim.positions, sim.radii
    rho_b = bulk_density(x0, r0, geometry)
    record = discharge(sim, gate, geometry, duration, snapshot_at=0.1)
    w, intercept, used = flow_rate(record["times"], record["discharged"], record["total_mass"])
    summary = dict(
        width_ratio=ratio, width=width, beads=sim.size, total_mass=record["total_mass"],
        settle_time=settled_at, bulk_density=rho_b, solid_fraction=rho_b / DENSITY,
        fill_height=float(np.max(x0[:, 2] + r0)), flow_rate=w, fit_intercept=intercept,
        fit_range=[float(record["times"][used].min()), float(record["times"][used].max())]
        if used.any() else [math.nan, math.nan],
        discharged_fraction=float(record["discharged"][-1] / record["total_mass"]),
        steps=sim.step_count, dt=sim.dt, cpu_seconds=time.process_time() - started,
        **{k: v for k, v in geometry.items() if k != "width"})
    snap = record["snapshot"] or {}
    arrays = dict(times=record["times"], discharged=record["discharged"], settled_positions=x0,
                  radii=r0, snapshot_positions=snap.get("positions", np.zeros((0, 3))),
                  snapshot_speeds=snap.get("speeds", np.zeros(0)),
                  snapshot_radii=snap.get("radii", np.zeros(0)),
                  snapshot_time=np.array(snap.get("time", math.nan)))
    return summary, arrays


def write_outputs(results, out: str, pack_cpu: float) -> dict:
    os.makedirs(out, exist_ok=True)
    for s, arrays in results:
        np.savez(os.path.join(out, f"hopper_D{s['width_ratio']:g}.npz"), **arrays)
    runs = [s for s, _ in results]
    ok = [s for s in runs if math.isfinite(s["flow_rate"]) and s["flow_rate"] > 0]
    rho_b = float(np.mean([s["bulk_density"] for s in runs]))
    length = runs[0]["length"]
    summary = dict(runs=runs, bulk_density=rho_b, length=length, diameter=DIAMETER,
                   half_angle=HALF_ANGLE, pack_cpu_seconds=pack_cpu)
    if len(ok) >= 2:
        c, k = fit_beverloo([s["width"] for s in ok], [s["flow_rate"] for s in ok], rho_b, length)
        summary.update(C=c, k=k)
    write_json(os.path.join(out, "hopper.json"), summary)
    return summary


def plot(out: str, figure: str) -> None:
    """The figure, from the files in `out` only."""
    plt = pyplot()
    from matplotlib.collections import EllipseCollection
    from matplotlib.patches import Polygon

    with open(os.path.join(out, "hopper.json")) as f:
        s = json.load(f)
    runs = s["runs"]
    fig, (ax_view, ax_mass, ax_rate) = plt.subplots(
        1, 3, figsize=(15, 5), gridspec_kw=dict(width_ratios=(1.0, 1.2, 1.2)))
    # Side view of the widest slot during discharge, beads coloured by speed.
    run = runs[-1]
    data = read_npz(os.path.join(out, f"hopper_D{run['width_ratio']:g}.npz"))
    x, v = data["snapshot_positions"] * 1e3, data["snapshot_speeds"]
    r = data["snapshot_radii"] * 1e3
    keep = np.ones(len(x), bool)
    order = np.argsort(x[keep][:, 1]) if len(x) else []
    if len(x):
        circles = EllipseCollection(2 * r[keep][order], 2 * r[keep][order], 0.0, units="xy",
                                    offsets=x[keep][order][:, [0, 2]],
                                    offset_transform=ax_view.transData, cmap="viridis",
                                    linewidths=0.1, edgecolors="k")
        circles.set_array(v[keep][order])
        circles.set_clim(0, max(0.05, float(np.percentile(v[keep], 99))))
        ax_view.add_collection(circles)
        fig.colorbar(circles, ax=ax_view, label="speed [m/s]", shrink=0.7)
    w, top, h = run["width"] * 1e3, run["top"] * 1e3, run["height"] * 1e3
    for sign in (-1, 1):
        ax_view.add_patch(Polygon([(sign * w / 2, 0), (sign * top / 2, h)], closed=False,
                                  color="k", lw=2))
    ax_view.set_xlim(-top / 2 - 2, top / 2 + 2)
    ax_view.set_ylim(-8 * DIAMETER * 1e3, h + 2)
    ax_view.set_aspect("equal")
    ax_view.set(xlabel="x [mm]", ylabel="z [mm]",
                title=f"D = {run['width_ratio']:g} d, t = {float(data['snapshot_time']):.2f} s "
                      f"after opening")
    # Discharged mass against time, with the fitted lines.
    for i, run in enumerate(runs):
        data = read_npz(os.path.join(out, f"hopper_D{run['width_ratio']:g}.npz"))
        ax_mass.plot(data["times"], data["discharged"] * 1e3, color=f"C{i}",
                     label=f"D = {run['width_ratio']:g} d: W = {run['flow_rate'] * 1e3:.1f} g/s")
        lo, hi = run["fit_range"]
        if math.isfinite(lo):
            t = np.array([lo, hi])
            ax_mass.plot(t, (run["fit_intercept"] + run["flow_rate"] * t) * 1e3, "k--", lw=1)
    ax_mass.set(xlabel="time after opening [s]", ylabel="discharged mass [g]",
                title="Discharge (dashed: fitted lines)")
    ax_mass.legend(fontsize=8)
    # W against D with the fitted law.
    widths = np.array([run["width_ratio"] for run in runs])
    rates = np.array([run["flow_rate"] for run in runs])
    ax_rate.plot(widths, rates * 1e3, "o", color="C3", label="tsubu")
    if "C" in s:
        grid = np.linspace(0, widths.max() * 1.1, 200)
        ax_rate.plot(grid, beverloo(grid * DIAMETER, s["C"], s["k"], s["bulk_density"],
                                    s["length"]) * 1e3, "k-", lw=1,
                     label=f"fit: C = {s['C']:.2f}, k = {s['k']:.2f}")
    ax_rate.set(xlabel="slot width D / d", ylabel="W [g/s]",
                title="W = C rho_b sqrt(g) L (D - k d)^(3/2)", xlim=(0, None), ylim=(0, None))
    ax_rate.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, figure)


def main(argv=None) -> dict:
    parser = arguments(__doc__.split("\n")[0], "hopper")
    parser.add_argument("--quick", action="store_true",
                        help="about 400 beads, two slot widths: a test of a few seconds")
    parser.add_argument("--widths", type=float, nargs="+", default=None,
                        help="slot widths D in bead diameters (default 4 5 6 7)")
    parser.add_argument("--count", type=int, default=None, help="beads (default 2000)")
    parser.add_argument("--duration", type=float, default=None,
                        help="longest discharge [s] per width (default 0.25)")
    parser.add_argument("--threads", type=int, default=None, help="OpenMP threads (default: all)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the packing")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    widths = args.widths or ([4.0, 6.0] if args.quick else [4.0, 5.0, 6.0, 7.0])
    count = args.count or (400 if args.quick else 2000)
    duration = args.duration or (0.15 if args.quick else 0.25)
    narrowest = min(widths) * DIAMETER
    cpu = time.process_time()
    pack = settled_pack(narrowest, count, args.seed, args.threads)
    pack_cpu = time.process_time() - cpu
    results = [run_width(ratio, pack, narrowest, duration, args.threads) for ratio in widths]
    summary = write_outputs(results, args.out, pack_cpu)
    figure = figure_path(args, "hopper")
    if figure:
        plot(args.out, figure)
    for s in summary["runs"]:
        print(f"D = {s['width_ratio']:g} d ({s['beads']} beads, solid fraction "
              f"{s['solid_fraction']:.3f}): W = {s['flow_rate'] * 1e3:.2f} g/s over "
              f"t = {s['fit_range'][0]:.3f}-{s['fit_range'][1]:.3f} s, {s['cpu_seconds']:.1f} s CPU")
    if "C" in summary:
        print(f"Beverloo (slot form) fitted: C = {summary['C']:.3f}, k = {summary['k']:.2f} "
              f"(rho_b = {summary['bulk_density']:.0f} kg/m^3, L = {LENGTH:g} d)")
    print(f"wrote {args.out} in {time.perf_counter() - started:.1f} s")
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])

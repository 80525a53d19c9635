"""Collapse of a granular column in a narrow channel: final profile and run-out against the
published scaling.

A quasi-2D slab of glass-like beads (mean diameter d = 2 mm, radii uniform within +-10 %,
linear contacts, friction 0.5) is held between a back wall (x = 0) and a gate (x = L0) in a
channel W = 4 d wide whose side walls are frictionless (the smooth glass of the experiments:
the slab behaves as a slice of a wide channel). It is settled, cut to the height H0 = a L0, the
gate is removed and the grains spread along the floor until they stop. The run-out
(L_inf - L0) / L0 is compared with Lube, Huppert, Sparks & Freundt (2005), for a rectangular
channel: 1.2 a for a < 1.8 and 1.9 a^(2/3) for a > 2.8 (docs/examples.md).

Removing the gate: the gate (a plane whose normal points into the column) is moved away along
its normal at 20 sqrt(g H0), much faster than any grain can follow (a collapsing column's front
moves at about sqrt(g H0)), to a place beyond any run-out, and stopped there
(``sim.set_plane_motion``); the example checks that no grain reaches it. (This predates
``sim.remove_wall``, which takes the gate out at once, as examples/scenes/column_collapse.toml
now does; the run-outs in docs/examples.md were measured with the moving gate.)

One settled pack is made for the tallest column and cut at each height, so every aspect ratio
starts from the same packing.

Run:  python examples/column_collapse.py [--quick] [--aspect-ratios 0.5 1 2] [--out DIR]
                                          [--figure PNG | --no-figure]

Writes DIR/column_collapse.json (the figures printed at the end), DIR/column_a<a>.npz (initial
and final positions and radii, the final profile), DIR/column_a<a>_start.npz (the settled column
as a particle file for a scene: examples/scenes/column_collapse.toml) and the figure
(matplotlib, headless).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time

import numpy as np

import tsubu

from example_support import arguments, figure_path, pyplot, read_npz, save_figure, write_json  # beside this script

GRAVITY = 9.81  # m/s^2
DIAMETER = 2e-3  # m, mean grain diameter d
RADIUS_SPREAD = 0.1  # radii uniform in (1 +- 0.1) d/2: no crystalline packing
DENSITY = 2500.0  # kg/m^3
STIFFNESS = 2e3  # N/m: the overlap under a 30-grain column is below 0.1 % of d
FRICTION = 0.5
ROLLING_FRICTION = 0.1
RESTITUTION = 0.5
WIDTH = 4.0  # channel width, in diameters
GATE_SPEED = 20.0  # in units of sqrt(g H0)
REST_SPEED = 0.005  # m/s: at rest when no grain is faster (about 3 % of sqrt(g d))


def materials():
    grain = tsubu.Material(density=DENSITY, kn=STIFFNESS, restitution=RESTITUTION,
                           friction=FRICTION, rolling_friction=ROLLING_FRICTION, name="grain")
    # Smooth side walls and gate: friction 0 makes every contact with them frictionless (the
    # pair's friction is the geometric mean).
    smooth = tsubu.Material(density=DENSITY, kn=STIFFNESS, restitution=RESTITUTION, friction=0.0,
                            name="smooth wall")
    return grain, smooth


def channel(sim, length: float, width: float, gate_at: float, grain, smooth) -> int:
    """Floor (rough), back wall, two smooth side walls and the smooth gate at x = gate_at;
    returns the gate's wall index. x along the channel, y across, z up."""
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=grain)
    sim.add_plane(point=(0, 0, 0), normal=(1, 0, 0), material=grain)
    sim.add_plane(point=(0, 0, 0), normal=(0, 1, 0), material=smooth)
    sim.add_plane(point=(0, width, 0), normal=(0, -1, 0), material=smooth)
    return sim.add_plane(point=(gate_at, 0, 0), normal=(-1, 0, 0), material=smooth)


def settled_pack(length: float, height: float, width: float, seed: int, threads: int):
    """Grains dropped from a jittered lattice into the box [0, length] x [0, width] up to about
    2 x `height` (a loose lattice settles to about 55 % of its height), settled until at rest.
    Returns (positions, radii) of the settled pack."""
    rng = np.random.default_rng(seed)
    r_max = (1 + RADIUS_SPREAD) * DIAMETER / 2
    spacing = 2.2 * r_max
    nx = int(length // spacing)
    ny = int(width // spacing)
    nz = int(math.ceil(2.0 * height / spacing))
    grid = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"),
                    axis=-1).reshape(-1, 3)
    # Centre the lattice across the box; jitter by up to a quarter of the gap between spheres.
    offset = np.array([(length - (nx - 1) * spacing) / 2, (width - (ny - 1) * spacing) / 2,
                       r_max])
    jitter = (spacing - 2 * r_max) / 4
    positions = offset + grid * spacing + rng.uniform(-jitter, jitter, grid.shape)
    radii = DIAMETER / 2 * rng.uniform(1 - RADIUS_SPREAD, 1 + RADIUS_SPREAD, len(grid))
    grain, smooth = materials()
    sim = tsubu.Simulation(gravity=(0, 0, -GRAVITY), threads=threads)
    sim.add_spheres(positions, radii, grain)
    channel(sim, length, width, length, grain, smooth)
    run_until_rest(sim, minimum=math.sqrt(2 * 2.0 * height / GRAVITY), maximum=2.0)
    return sim.positions, sim.radii


def run_until_rest(sim, minimum: float, maximum: float, chunk: float = 0.02) -> float:
    """Run at least `minimum` seconds, then until no grain is faster than REST_SPEED (or
    `maximum` seconds). Returns the time run."""
    start = sim.time
    sim.run(time=minimum)
    while sim.time - start < maximum:
        if np.max(np.linalg.norm(sim.velocities, axis=1)) < REST_SPEED:
            break
        sim.run(time=chunk)
    return sim.time - start


def profile(positions, radii, bin_width: float):
    """The deposit's side profile: bin centres x [m] and the top h(x) = max(z + r) of the grains
    whose centre is in each bin (0 where none)."""
    x = positions[:, 0]
    edges = np.arange(0.0, x.max() + radii.max() + bin_width, bin_width)
    which = np.digitize(x, edges) - 1
    top = np.zeros(len(edges) - 1)
    np.maximum.at(top, which, positions[:, 2] + radii)
    return 0.5 * (edges[1:] + edges[:-1]), top


def front(positions, radii) -> float:
    """Run-out: the front of the continuous deposit, the largest x + r reached by a grain that
    is linked to the back wall by a chain of grains along x with no gap over one diameter (a
    few grains bounced off ahead of the front do not count)."""
    order = np.argsort(positions[:, 0])
    x = positions[order, 0]
    gaps = np.flatnonzero(np.diff(x) > DIAMETER)
    last = gaps[0] if len(gaps) else len(x) - 1
    return float(np.max(x[: last + 1] + radii[order][: last + 1]))


def collapse(pack, length: float, aspect_ratio: float, width: float, threads: int) -> dict:
    """Cut the settled pack at H0 = aspect_ratio x length, release it and run until rest."""
    positions, radii = pack
    height = aspect_ratio * length
    keep = positions[:, 2] + radii <= height
    x0, r = positions[keep], radii[keep]
    grain, smooth = materials()
    sim = tsubu.Simulation(gravity=(0, 0, -GRAVITY), threads=threads)
    sim.add_spheres(x0, r, grain)
    gate = channel(sim, length, width, length, grain, smooth)
    # The copied pack has no contact history: let it find its contacts again behind the gate.
    run_until_rest(sim, minimum=0.02, maximum=0.2)
    start_positions = sim.positions
    initial_height = float(np.max(start_positions[:, 2] + r))  # the cut column, re-settled
    # Remove the gate: move it away fast, beyond any run-out (3 x Lube's, plus 20 d), then stop.
    speed = GATE_SPEED * math.sqrt(GRAVITY * height)
    parked = length * (1 + 3 * max(1.2 * aspect_ratio, 1.9 * aspect_ratio ** (2 / 3))) + 20 * DIAMETER
    travel = parked - length
    released = sim.time
    sim.set_plane_motion(gate, velocity=(speed, 0, 0))
    sim.run(steps=max(1, math.ceil(travel / (speed * sim.dt))))
    sim.set_plane_motion(gate, velocity=(0, 0, 0))
    run_until_rest(sim, minimum=3 * math.sqrt(height / GRAVITY),
                   maximum=40 * math.sqrt(height / GRAVITY))
    settle_time = sim.time - released
    final = sim.positions
    gate_x = float(sim.plane(gate)["point"][0])
    contacts = sim.contacts()
    x_bins, h = profile(final, r, DIAMETER)
    run_out = front(final, r)
    return dict(
        aspect_ratio=initial_height / length, nominal_aspect_ratio=aspect_ratio, length=length,
        height=initial_height, width=width, grains=len(r),
        run_out=run_out, normalised_run_out=(run_out - length) / length,
        final_height=float(h.max()), farthest_grain=float(np.max(final[:, 0] + r)),
        time_to_rest=settle_time, at_rest=bool(np.max(np.linalg.norm(sim.velocities, axis=1)) < REST_SPEED),
        gate_position=gate_x, gate_touched=bool(np.any(contacts["wall"] == gate)),
        release_time=released, dt=sim.dt, steps=sim.step_count,
        initial_positions=start_positions, final_positions=final, radii=r,
        profile_x=x_bins, profile_h=h)


def write_outputs(results: list, out: str) -> dict:
    os.makedirs(out, exist_ok=True)
    arrays = ("initial_positions", "final_positions", "radii", "profile_x", "profile_h")
    summary = []
    for res in results:
        np.savez(os.path.join(out, f"column_a{res['nominal_aspect_ratio']:g}.npz"),
                 **{k: res[k] for k in arrays})
        # The settled column behind the gate, as a particle file for a scene (examples/scenes/).
        np.savez(os.path.join(out, f"column_a{res['nominal_aspect_ratio']:g}_start.npz"),
                 positions=res["initial_positions"], radii=res["radii"])
        summary.append({k: v for k, v in res.items() if k not in arrays})
    write_json(os.path.join(out, "column_collapse.json"), summary)
    return summary


def plot(out: str, figure: str) -> None:
    """The figure, from the files in `out` only."""
    plt = pyplot()
    from matplotlib.collections import EllipseCollection

    with open(os.path.join(out, "column_collapse.json")) as f:
        summary = json.load(f)
    fig = plt.figure(figsize=(12, 7.5))
    grid = fig.add_gridspec(2, 2, height_ratios=(1, 1))
    ax_view = fig.add_subplot(grid[0, :])
    ax_profile = fig.add_subplot(grid[1, 0])
    ax_scaling = fig.add_subplot(grid[1, 1])

    tallest = max(summary, key=lambda s: s["aspect_ratio"])
    data = read_npz(os.path.join(out, f"column_a{tallest['nominal_aspect_ratio']:g}.npz"))
    length = tallest["length"]
    colour = data["initial_positions"][:, 2] / tallest["height"]  # initial height: layers
    for positions, alpha in ((data["initial_positions"], 0.25), (data["final_positions"], 1.0)):
        diameters = 2 * data["radii"] / length
        circles = EllipseCollection(diameters, diameters, 0.0, units="xy",
                                    offsets=positions[:, [0, 2]] / length,
                                    offset_transform=ax_view.transData, cmap="viridis",
                                    alpha=alpha, linewidths=0)
        circles.set_array(colour)
        ax_view.add_collection(circles)
    ax_view.axvline(1.0, color="k", ls=":", lw=1)
    ax_view.axvline(tallest["run_out"] / length, color="C3", ls="--", lw=1)
    ax_view.set_xlim(0, max(tallest["farthest_grain"] / length, tallest["run_out"] / length) + 0.2)
    ax_view.set_ylim(0, tallest["height"] / length * 1.05)
    ax_view.set_aspect("equal")
    ax_view.set(xlabel="x / L0", ylabel="z / L0",
                title=f"a = {tallest['aspect_ratio']:.2f}: the column (faint, coloured by initial "
                      f"height) and the deposit; gate at x = L0 (dotted), run-out (dashed)")

    for s in summary:
        d = read_npz(os.path.join(out, f"column_a{s['nominal_aspect_ratio']:g}.npz"))
        ax_profile.plot(d["profile_x"] / s["length"], d["profile_h"] / s["length"],
                        drawstyle="steps-mid", label=f"a = {s['aspect_ratio']:.2f}")
    ax_profile.set(xlabel="x / L0", ylabel="h / L0", title="Final profiles h(x)")
    ax_profile.legend(fontsize=8)

    a = np.array([s["aspect_ratio"] for s in summary])
    measured = np.array([s["normalised_run_out"] for s in summary])
    grid_a = np.linspace(0, max(4.0, a.max() * 1.1), 200)
    ax_scaling.plot(grid_a, 1.2 * grid_a, "k-", lw=1, label="1.2 a (Lube et al. 2005, a < 1.8)")
    ax_scaling.plot(grid_a, 1.9 * grid_a ** (2 / 3), "k--", lw=1,
                    label="1.9 a^(2/3) (Lube et al. 2005, a > 2.8)")
    ax_scaling.plot(a, measured, "o", color="C3", label="tsubu")
    ax_scaling.set(xlabel="a = H0 / L0", ylabel="(L_inf - L0) / L0", title="Run-out",
                   xlim=(0, grid_a[-1]), ylim=(0, None))
    ax_scaling.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, figure)


def main(argv=None) -> list:
    parser = arguments(__doc__.split("\n")[0], "column_collapse")
    parser.add_argument("--quick", action="store_true",
                        help="a small column (L0 = 6 d, W = 3 d), a = 1 only: a test of a few seconds")
    parser.add_argument("--aspect-ratios", type=float, nargs="+", default=None,
                        help="aspect ratios a = H0/L0 to run (default 0.5 1 2)")
    parser.add_argument("--length", type=float, default=None,
                        help="column length L0 in grain diameters (default 8)")
    parser.add_argument("--threads", type=int, default=None, help="OpenMP threads (default: all)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the packing")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    aspect_ratios = args.aspect_ratios or ([1.0] if args.quick else [0.5, 1.0, 2.0])
    length = (args.length or (6 if args.quick else 8)) * DIAMETER
    width = (3 if args.quick else WIDTH) * DIAMETER
    pack = settled_pack(length, max(aspect_ratios) * length, width, args.seed, args.threads)
    results = [collapse(pack, length, a, width, args.threads) for a in aspect_ratios]
    summary = write_outputs(results, args.out)
    figure = figure_path(args, "column_collapse")
    if figure:
        plot(args.out, figure)
    for s in summary:
        print(f"a = {s['aspect_ratio']:4.2f} ({s['grains']} grains): run-out (L_inf - L0)/L0 = "
              f"{s['normalised_run_out']:5.2f} (Lube et al. 2005: 1.2 a = {1.2 * s['aspect_ratio']:4.2f}, "
              f"1.9 a^(2/3) = {1.9 * s['aspect_ratio'] ** (2 / 3):4.2f}), H_inf/L0 = "
              f"{s['final_height'] / s['length']:4.2f}, at rest {s['time_to_rest']:.2f} s after "
              f"release{'' if s['at_rest'] else ' (NOT at rest)'}"
              f"{', the gate was touched' if s['gate_touched'] else ''}")
    print(f"wrote {args.out} in {time.perf_counter() - started:.1f} s")
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])

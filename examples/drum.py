"""A rotating drum: the dynamic angle of repose and the driving torque against the Froude number.

A drum of radius R = 14 d (``tsubu.mesh.cylinder``, 64 flat faces, axis along y, closed by its
caps) is filled to about 35 % of its volume with about 1,000 glass-like beads (mean diameter
d = 2 mm, radii uniform within +-10 %, linear contacts, friction 0.5, rolling friction 0.05). Its
side is rough (a pair override: friction 1.0, rolling friction 0.3, as a lining of glued beads;
with the beads' own friction the bed slips along the flat faces); its caps (a second mesh from the same generator: the cap
triangles) are frictionless and L = 4 d apart, so that the bed behaves as a slice of a long
drum. The drum turns by itself: its ``angular_velocity`` about its centre (no Python hook
per step). It is spun at Froude numbers Fr = omega^2 R / g of 1e-1, 1e-2 and 1e-3 in turn (the
cascading regime to the rolling one), each after the last in the same run: a spin-up (from rest
for the first: the drum turns the bed up to its angle quickly at the highest speed; each slower
speed then starts from a steeper bed, which relaxes within a few avalanches), then a
measurement over a fixed time, in which:

- the dynamic angle of repose: a straight line fitted to the free surface (the highest
  z + r per bin one diameter wide along x, over the middle 60 % of the chord) every 20 ms,
  averaged; also the angle of the bed's principal axis (the cross-section's second moments:
  a circular segment's long axis lies along its chord), a check that needs no surface;
- the driving torque: minus the component along the axis of ``sim.wall_torques()`` of the
  drum's side and caps (the caps, frictionless, add none), sampled every 2 ms and averaged;
- the bed's rotation rate about its centre of mass (its angular momentum over its moment of
  inertia, about the axis) over the drum's: 1 when it turns as a solid body, above 1 with a
  flowing layer at the surface (which moves the same way), below 1 when it slips on the wall.

The torque is compared with the static estimate T = M g R_c sin(theta), derived here from the
balance of angular momentum about the axis: in a steady state the bed's angular momentum is
constant on average, so the drum's torque on the bed balances the moment of the bed's weight,
M g times the horizontal distance x_c of its centre of mass from the axis (time-averaged, this
holds exactly: it is also measured, as M g x_c; frictionless caps add no torque about the axis).
If the bed is a circular segment tilted rigidly by the angle theta of its surface, its centre of
mass lies at the angle theta from below the axis, so x_c = R_c sin(theta) with R_c its distance
from the axis: the "torque arm" model of the power draw of tumbling mills (P = T omega). Where
the surface curves (cascading, higher Fr) the line's angle is only the mean slope and the
estimate drifts from the balance.

Run:  python examples/drum.py [--quick] [--froude 1e-1 1e-2 1e-3] [--out DIR]
                              [--figure PNG | --no-figure]

Writes DIR/drum.json (the figures printed at the end), DIR/drum_Fr<i>.npz (a snapshot, the
torque samples, the surface fits) and the figure (matplotlib, headless).
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
RADIUS_SPREAD = 0.1
DENSITY = 2500.0  # kg/m^3
STIFFNESS = 300.0  # N/m: overlaps under a 20-bead bed stay below 1 % of d
FRICTION = 0.5
ROLLING_FRICTION = 0.05
RESTITUTION = 0.5
LINING_FRICTION = 1.0  # between the beads and the drum's side (a pair override)
LINING_ROLLING_FRICTION = 0.3
RADIUS = 14.0  # drum radius R, in diameters
LENGTH = 4.0  # between the caps, in diameters
SEGMENTS = 64
FILL = 0.35  # fraction of the drum's volume that the settled bed fills
LOOSE = 0.30  # solid fraction of the random sequential addition before settling
SETTLED = 0.57  # about the settled bed's (between the caps)
SPIN_UP_ANGLE = 0.8  # rad the drum turns from rest before the first measurement
SPIN_UP = 0.25  # s, at least, after each change of speed
SAMPLE = 0.002  # s between torque samples
SNAPSHOT = 0.02  # s between surface fits


def materials():
    grain = tsubu.Material(density=DENSITY, kn=STIFFNESS, restitution=RESTITUTION,
                           friction=FRICTION, rolling_friction=ROLLING_FRICTION, name="grain")
    lining = tsubu.Material(density=DENSITY, kn=STIFFNESS, restitution=RESTITUTION,
                            friction=FRICTION, name="drum lining")
    smooth = tsubu.Material(density=DENSITY, kn=STIFFNESS, restitution=RESTITUTION, friction=0.0,
                            name="smooth cap")
    return grain, lining, smooth


def build(radius: float, length: float, seed: int, threads):
    """The drum (side and caps as two meshes about the same centre, the origin) and the bed,
    settled. Returns (sim, side wall, cap wall)."""
    grain, lining, smooth = materials()
    vertices, faces = mesh.cylinder(radius, length, SEGMENTS, axis="y", caps=True)
    sim = tsubu.Simulation(gravity=(0, 0, -GRAVITY), threads=threads)
    # A rough lining (as a layer of beads glued to the wall, or sandpaper, in experiments): a
    # pair override. With the beads' own friction on the flat faces the bed slips along the
    # wall (it turned at 0.8 of the drum's rate at Fr = 0.1, and its angle swung by 20 degrees
    # in stick-slip cycles).
    sim.set_pair(grain, lining, friction=LINING_FRICTION, rolling_friction=LINING_ROLLING_FRICTION)
    side = sim.add_mesh(vertices, faces[:2 * SEGMENTS], lining, center=(0, 0, 0))
    caps = sim.add_mesh(vertices, faces[2 * SEGMENTS:], smooth, center=(0, 0, 0))
    inner = radius * math.cos(math.pi / SEGMENTS)  # the flat faces' distance from the axis
    # Beads of a random sequential addition (solid fraction LOOSE) in the lower part of the
    # drum, settled to a bed of about SETTLED that fills about FILL of the drum.
    sizes = fill.Uniform((1 - RADIUS_SPREAD) * DIAMETER / 2, (1 + RADIUS_SPREAD) * DIAMETER / 2)
    level = segment_level(inner, FILL * SETTLED / LOOSE)

    def inside(x, margin=0.0):
        x = np.asarray(x, dtype=float).reshape(-1, 3)
        m = np.broadcast_to(np.asarray(margin, dtype=float), (len(x),))
        rho = np.hypot(x[:, 0], x[:, 2])
        return ((rho + m <= inner) & (x[:, 2] + m <= level)
                & (np.abs(x[:, 1]) + m <= 0.5 * length))

    volume = segment_area(inner, level) * length
    region = fill.Region(inside, (-inner, -0.5 * length, -inner), (inner, 0.5 * length, level),
                         volume=volume)
    pack = fill.random_packing(region, sizes, solid_fraction=LOOSE, seed=seed)
    sim.add_spheres(pack.positions, pack.radii, grain)
    while sim.time < 0.5:
        sim.run(time=0.02)
        if np.max(np.linalg.norm(sim.velocities, axis=1)) < 0.02:
            break
    return sim, side, caps


def segment_area(radius: float, level: float) -> float:
    """Area of the part of a disc of `radius` below the height `level` (centre at 0)."""
    h = min(max(level + radius, 0.0), 2 * radius)  # the segment's height
    return radius ** 2 * math.acos((radius - h) / radius) - (radius - h) * math.sqrt(max(2 * radius * h - h * h, 0.0))


def segment_level(radius: float, fraction: float) -> float:
    """The height below which a disc's `fraction` of area lies (bisection)."""
    lo, hi = -radius, radius
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if segment_area(radius, mid) < fraction * math.pi * radius ** 2:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def surface_fit(x, r, inner: float):
    """The free surface's line z = a + b x: the highest z + r per bin one diameter wide along
    x, over the middle 60 % of the bed's chord. Returns (angle in degrees (positive: rising
    toward -x, the side the drum lifts for a positive spin about +y), a, b, bin centres,
    tops)."""
    lo, hi = np.min(x[:, 0]), np.max(x[:, 0])
    middle, half = 0.5 * (lo + hi), 0.3 * (hi - lo)
    edges = np.arange(middle - half, middle + half + 1e-12, DIAMETER)
    which = np.digitize(x[:, 0], edges) - 1
    ok = (which >= 0) & (which < len(edges) - 1)
    tops = np.full(len(edges) - 1, -np.inf)
    np.maximum.at(tops, which[ok], x[ok, 2] + r[ok])
    centres = 0.5 * (edges[1:] + edges[:-1])
    good = np.isfinite(tops)
    b, a = np.polyfit(centres[good], tops[good], 1)
    return math.degrees(math.atan(-b)), float(a), float(b), centres[good], tops[good]


def principal_angle(x, m) -> float:
    """The angle [deg] of the long principal axis of the bed's cross-section (x, z), mass
    weighted, from the horizontal, positive when it rises toward -x."""
    c = np.average(x[:, [0, 2]], axis=0, weights=m)
    dx = x[:, [0, 2]] - c
    cov = (dx * m[:, None]).T @ dx
    values, vectors = np.linalg.eigh(cov)
    u = vectors[:, np.argmax(values)]
    return math.degrees(math.atan(-u[1] / u[0]))


def measure(sim, side: int, caps: int, froude: float, radius: float, spin_up: float,
            duration: float) -> tuple:
    """Spin the drum at `froude`, wait `spin_up`, then sample for `duration`."""
    omega = math.sqrt(froude * GRAVITY / radius)
    for wall in (side, caps):
        sim.set_wall_motion(wall, angular_velocity=(0.0, omega, 0.0))
    sim.run(time=spin_up)
    masses = sim.masses
    total = float(masses.sum())
    inner = radius * math.cos(math.pi / SEGMENTS)
    torques, balance, angles, axes, surfaces, spin = [], [], [], [], [], []
    t0, next_snapshot = sim.time, sim.time
    while sim.time - t0 < duration - 0.5 * SAMPLE:
        sim.run(time=SAMPLE)
        # The drum's load: minus the spheres' torque on the side about the axis (+y).
        torques.append(-float(sim.wall_torques()[side, 1] + sim.wall_torques()[caps, 1]))
        x = sim.positions
        cm = np.average(x, axis=0, weights=masses)
        # The moment of the bed's weight about the axis, along +y: (c x (-M g z)).y = M g c_x;
        # the drum's torque balances it, so its driving torque is -M g c_x (c_x < 0 when the
        # bed is lifted toward -x).
        balance.append(-total * GRAVITY * cm[0])
        v = sim.velocities
        dx = x - cm
        # The bed's mean rotation rate about the axis through its centre of mass (+y):
        # L_y / I_y, from the beads' motion relative to the centre of mass.
        dv = v - np.average(v, axis=0, weights=masses)
        spin.append(float(np.sum(masses * (dx[:, 2] * dv[:, 0] - dx[:, 0] * dv[:, 2]))
                          / np.sum(masses * (dx[:, 0] ** 2 + dx[:, 2] ** 2))))
        if sim.time >= next_snapshot - 0.5 * SAMPLE:
            next_snapshot += SNAPSHOT
            r = sim.radii
            angle, a, b, centres, tops = surface_fit(x, r, inner)
            angles.append(angle)
            axes.append(principal_angle(x, masses))
            surfaces.append((a, b, centres.min(), centres.max()))
    x, r, v = sim.positions, sim.radii, sim.velocities
    cm = np.average(x, axis=0, weights=masses)
    distance = float(np.hypot(cm[0], cm[2]))
    theta = float(np.mean(angles))
    summary = dict(
        froude=froude, omega=omega, beads=sim.size, mass=total, time=sim.time,
        angle=theta, angle_std=float(np.std(angles)), principal_angle=float(np.mean(axes)),
        torque=float(np.mean(torques)), torque_std=float(np.std(torques)),
        torque_balance=float(np.mean(balance)), com_distance=distance,
        torque_estimate=total * GRAVITY * distance * math.sin(math.radians(theta)),
        bed_rotation=float(np.mean(spin)) / omega, last_surface=surfaces[-1], steps=sim.step_count)
    arrays = dict(positions=x, radii=r, speeds=np.linalg.norm(v, axis=1),
                  torques=np.array(torques), balance=np.array(balance), angles=np.array(angles),
                  principal_angles=np.array(axes))
    return summary, arrays


def write_outputs(results, out: str, radius: float, length: float) -> dict:
    os.makedirs(out, exist_ok=True)
    for i, (s, arrays) in enumerate(results):
        np.savez(os.path.join(out, f"drum_Fr{i}.npz"), **arrays)
    summary = dict(runs=[s for s, _ in results], radius=radius, length=length,
                   segments=SEGMENTS, diameter=DIAMETER)
    write_json(os.path.join(out, "drum.json"), summary)
    return summary


def plot(out: str, figure: str) -> None:
    """The figure, from the files in `out` only."""
    plt = pyplot()
    from matplotlib.collections import EllipseCollection
    from matplotlib.patches import Circle

    with open(os.path.join(out, "drum.json")) as f:
        s = json.load(f)
    runs = s["runs"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 5), gridspec_kw=dict(width_ratios=(1, 1, 1)))
    ax_view, ax_angle, ax_torque = axes
    i = len(runs) // 2  # the side view of the middle speed
    run = runs[i]
    data = read_npz(os.path.join(out, f"drum_Fr{i}.npz"))
    x, r, v = data["positions"] * 1e3, data["radii"] * 1e3, data["speeds"]
    order = np.argsort(x[:, 1])
    circles = EllipseCollection(2 * r[order], 2 * r[order], 0.0, units="xy",
                                offsets=x[order][:, [0, 2]], offset_transform=ax_view.transData,
                                cmap="viridis", linewidths=0.1, edgecolors="k")
    circles.set_array(v[order])
    ax_view.add_collection(circles)
    fig.colorbar(circles, ax=ax_view, label="speed [m/s]", shrink=0.7)
    radius = s["radius"] * 1e3
    ax_view.add_patch(Circle((0, 0), radius, fill=False, color="k", lw=2))
    a, b, lo, hi = run["last_surface"]
    xs = np.array([lo, hi])
    ax_view.plot(xs * 1e3, (a + b * xs) * 1e3, "r-", lw=2, label=f"surface fit {run['angle']:.1f}°")
    ax_view.set_xlim(-radius * 1.05, radius * 1.05)
    ax_view.set_ylim(-radius * 1.05, radius * 1.05)
    ax_view.set_aspect("equal")
    ax_view.legend(fontsize=8, loc="upper right")
    ax_view.set(xlabel="x [mm]", ylabel="z [mm]",
                title=f"Fr = {run['froude']:g} (drum turning about +y)")
    fr = np.array([run["froude"] for run in runs])
    ax_angle.errorbar(fr, [run["angle"] for run in runs], yerr=[run["angle_std"] for run in runs],
                      fmt="o-", capsize=3, label="surface line (± std over snapshots)")
    ax_angle.plot(fr, [run["principal_angle"] for run in runs], "s--",
                  label="bed's principal axis")
    ax_angle.set(xscale="log", xlabel="Fr = ω² R / g", ylabel="angle [deg]",
                 title="Dynamic angle of repose")
    ax_angle.legend(fontsize=8)
    ax_torque.errorbar(fr, [run["torque"] * 1e3 for run in runs],
                       yerr=[run["torque_std"] * 1e3 for run in runs], fmt="o-", capsize=3,
                       label="-wall_torques()·axis (± std of samples)")
    ax_torque.plot(fr, [run["torque_balance"] * 1e3 for run in runs], "s--",
                   label="M g |x_c| (moment of the weight)")
    ax_torque.plot(fr, [run["torque_estimate"] * 1e3 for run in runs], "k^:",
                   label="M g R_c sin θ (static estimate)")
    ax_torque.set(xscale="log", xlabel="Fr = ω² R / g", ylabel="driving torque [mN m]",
                  title="Driving torque", ylim=(0, None))
    ax_torque.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, figure)


def main(argv=None) -> dict:
    parser = arguments(__doc__.split("\n")[0], "drum")
    parser.add_argument("--quick", action="store_true",
                        help="a drum of R = 8 d with about 150 beads, two speeds: a test of a few seconds")
    parser.add_argument("--froude", type=float, nargs="+", default=None,
                        help="Froude numbers, run in this order (default 1e-1 1e-2 1e-3)")
    parser.add_argument("--duration", type=float, default=None,
                        help="measurement time per speed [s] (default 0.4)")
    parser.add_argument("--threads", type=int, default=None, help="OpenMP threads (default: all)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the packing")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    froude = args.froude or ([1e-1, 1e-2] if args.quick else [1e-1, 1e-2, 1e-3])
    radius = (8.0 if args.quick else RADIUS) * DIAMETER
    length = (3.0 if args.quick else LENGTH) * DIAMETER
    duration = args.duration or (0.08 if args.quick else 0.4)
    sim, side, caps = build(radius, length, args.seed, args.threads)
    results = []
    for i, fr in enumerate(froude):
        omega = math.sqrt(fr * GRAVITY / radius)
        # From rest the drum must first lift the bed to its angle: SPIN_UP_ANGLE of turn.
        spin_up = max(SPIN_UP, SPIN_UP_ANGLE / omega) if i == 0 else SPIN_UP
        if args.quick:
            spin_up = min(spin_up, 0.15)
        results.append(measure(sim, side, caps, fr, radius, spin_up, duration))
    summary = write_outputs(results, args.out, radius, length)
    figure = figure_path(args, "drum")
    if figure:
        plot(args.out, figure)
    for s in summary["runs"]:
        print(f"Fr = {s['froude']:g} (omega = {s['omega']:.2f} rad/s): angle {s['angle']:.1f} deg "
              f"(principal axis {s['principal_angle']:.1f}), torque {s['torque'] * 1e3:.3f} mN m "
              f"(M g x_c {s['torque_balance'] * 1e3:.3f}, M g R_c sin(theta) "
              f"{s['torque_estimate'] * 1e3:.3f})")
    print(f"{summary['runs'][0]['beads']} beads; wrote {args.out} in "
          f"{time.perf_counter() - started:.1f} s")
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])

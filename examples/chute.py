"""Chute flow: a periodic inclined layer on a rough base, against Bagnold's velocity profile.

The geometry of Silbert, Ertas, Grest, Halsey, Levine & Plimpton, "Granular flow down an
inclined plane: Bagnold scaling and rheology", Phys. Rev. E 64, 051302 (2001): a layer of
monodisperse frictional spheres (diameter d) of height h on a rough base, periodic along the
flow (x) and across it (y) (``sim.set_box(..., periodic="xy")``), with gravity tilted by the
angle theta, g = 9.81 (sin theta, 0, -cos theta) m/s^2. The base is a random monolayer of
spheres of the same size, fixed (``sim.fix_spheres``): random sequential addition of discs in
the periodic rectangle until no disc fits (to a grid of d/20), glued on a flat board (a plane at
z = 0, the centres at d/2). The board is not Silbert's (his base had none): with the springs
used here, 100 times softer than his, a sphere was seen squeezing through the widest gap of a
monolayer without it (a gap of 0.998 d: an overlap of 0.2 % of d lets it through); with the
board it stays in that gap, as on the glued-bead bases of experiments.

**Material.** Silbert's model L2 (as I recall the paper; I could not consult it here): the
linear (Hooke) law, k_t = 2/7 k_n, a normal dashpot giving a restitution e = 0.88, no
tangential dashpot, friction mu = 0.5 with the tangential spring truncated at the Coulomb limit,
no rolling friction. tsubu's linear material is that law: ``tsubu.Material(kn, restitution,
friction)`` has k_t = 2/7 k_n and ``tangential_damping = 0`` by default, and sets the dashpot
from e with each pair's effective mass (a free sphere against a fixed one: its own mass), and
``slip_rule="truncate"`` truncates the spring as Silbert (and LAMMPS's ``gran/hooke/history``)
did, where tsubu's default freezes it. One difference, for speed: k_n = 2e3 m g/d where
Silbert used 2e5 m g/d. The time step (t_c/50, the ratio of Silbert's 1e-4 sqrt(d/g) to his
contact time) is then ten times longer, which is what brings three steady flows into a couple
of minutes of CPU; the stiffness number k_n/(p d) at the base is about 200 (Silbert's h = 40 d
layers: about 5000). Overlaps are 0.5-0.7 % of d on average (3 % at the 99th percentile, 7 % at
most, in the snapshots at the end of each angle).

**Size.** Silbert's main runs had a 20 d x 10 d base and N = 8000 flowing spheres (h about
40 d). This example uses a 10 d x 10 d base and 1,108 flowing spheres, h about 10 d
(``--base``, ``--height``). A thinner layer needs a steeper slope to flow: at h = 10 d the
layer flows unevenly at 22 degrees (tried: its kinetic energy wanders by +-20 % and its
profile is nearly linear, the slow regime Silbert et al. describe near the angle of repose), its
kinetic energy still wanders by a quarter over 40 tau at 23 degrees, and it flows steadily from
24 degrees up; the default angles are 24, 25 and 26 degrees (26 is near Silbert's upper limit
for steady flow). (A layer of h = 15 d at 20 degrees nearly came to rest: a mean speed of
about 0.1 sqrt(g d) after 80 tau.)

**Runs.** The spheres start on a loose lattice above the base and fall onto it at the first
angle; each further angle starts from the flow of the one before. At each angle the run lasts
at least 100 tau (tau = sqrt(d/g)), then goes on in chunks of 10 tau until the kinetic energy
is flat (a straight line fitted to it, sampled every tau over the last 40 tau, changes by less
than 4 % of its mean across them). Then the profiles are averaged over 50 tau (a sample every
tau), in slabs d/2 thick:

- v_x(z): the mean velocity along the flow of the free spheres whose centre is in the slab;
- phi(z): the solid fraction, every sphere's volume in the slab counted exactly (spherical
  segments), over the slab's volume L_x L_y dz.

**Bagnold.** Heights z are measured from the top of the base's spheres (z = d above the
board). The free surface h is where phi falls to half its bulk value (the bulk: 2 d above the
base to 3 d below the surface). Bagnold's profile v(z) = A [h^(3/2) - (h - z)^(3/2)] is fitted
to v_x over 0 <= z <= h (one parameter, least squares); the residual is the rms difference over
those slabs, as a fraction of the surface velocity A h^(3/2). A is also fitted to each half of
the averaging window, as a measure of its noise. The same profile follows from the mu(I)
rheology with a uniform inertial number I (tan theta = mu(I) at every depth, pressure
phi rho g cos theta (h - z)): A = (2/3) I sqrt(phi g cos theta) / d, so the example also
reports I = 3 A d / (2 sqrt(phi g cos theta)) for each angle.

Run:  python examples/chute.py [--quick] [--angles 24 25 26] [--height 10] [--base 10 10]
                               [--out DIR] [--figure PNG | --no-figure]

Writes DIR/chute.json (the figures printed at the end), DIR/chute_theta<angle>.npz (the
kinetic energy against time, the profiles, the final positions and velocities in units of d and
sqrt(g d)) and the figure (matplotlib, headless).
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
DIAMETER = 2e-3  # m
DENSITY = 2500.0  # kg/m^3
MASS = DENSITY * math.pi / 6 * DIAMETER ** 3  # kg, one sphere
TAU = math.sqrt(DIAMETER / GRAVITY)  # s, the time unit sqrt(d/g)
STIFFNESS = 2e3  # k_n in units of m g / d (Silbert: 2e5)
RESTITUTION = 0.88
FRICTION = 0.5
BASE = (10.0, 10.0)  # base's lengths L_x, L_y in diameters
HEIGHT = 10.0  # layer's height in diameters, at solid fraction PHI_GUESS: sets N
PHI_GUESS = 0.58
ANGLES = (24.0, 25.0, 26.0)  # degrees
CHUNK = 10.0  # tau between steadiness checks
STEADY_WINDOW = 40.0  # tau: the kinetic energy's trend is fitted over this
STEADY_TOL = 0.04  # relative change of that trend across the window that counts as flat
MIN_TIME = 100.0  # tau at an angle before testing
MAX_TIME = 400.0  # tau at an angle at most (then averaged anyway, flagged as not steady)
AVERAGE = 50.0  # tau of averaging
SAMPLE = 1.0  # tau between samples
SLAB = 0.5  # slab thickness in diameters


def material() -> tsubu.Material:
    """Silbert's L2 spheres, with the softer k_n (module docstring)."""
    return tsubu.Material(density=DENSITY, kn=STIFFNESS * MASS * GRAVITY / DIAMETER,
                          restitution=RESTITUTION, friction=FRICTION, name="grain")


def gravity(angle: float) -> tuple:
    a = math.radians(angle)
    return (GRAVITY * math.sin(a), 0.0, -GRAVITY * math.cos(a))


def rough_base(lx: float, ly: float, seed: int, attempts: int = 4000) -> np.ndarray:
    """Centres (x, y) of a random monolayer of discs of diameter d in the periodic rectangle
    lx x ly, by random sequential addition until no disc fits: random darts until `attempts`
    in a row miss, then the points of a grid (d/20) that still have room, in random order."""
    d = DIAMETER
    rng = np.random.default_rng(seed)
    size = np.array([lx, ly])
    centres = np.zeros((0, 2))

    def room(points):
        if len(centres) == 0:
            return np.full(len(points), np.inf)
        gap = points[:, None, :] - centres[None]
        gap -= np.round(gap / size) * size
        return np.sqrt((gap ** 2).sum(-1)).min(1)

    def add_free(candidates):
        nonlocal centres
        for p in candidates:
            if room(p[None])[0] >= d:
                centres = np.vstack([centres, p])

    misses = 0
    while misses < attempts:  # darts until `attempts` in a row find no room
        p = rng.uniform((0, 0), size, (1, 2))
        if room(p)[0] >= d:
            centres = np.vstack([centres, p])
            misses = 0
        else:
            misses += 1
    gx, gy = np.meshgrid(np.arange(0, lx, d / 20), np.arange(0, ly, d / 20))
    grid = np.column_stack([gx.ravel(), gy.ravel()])
    grid = grid[room(grid) >= d]
    add_free(grid[rng.permutation(len(grid))])
    return centres


def build(base_size, height: float, angle: float, seed: int, threads=None):
    """The scene: the fixed base on its board, the free spheres on a loose lattice above it,
    gravity at `angle`. Returns (sim, number of base spheres)."""
    d = DIAMETER
    lx, ly = base_size[0] * d, base_size[1] * d
    grain = material()
    sim = tsubu.Simulation(gravity=gravity(angle), slip_rule="truncate", threads=threads)
    base = rough_base(lx, ly, seed)
    ids = sim.add_spheres(np.column_stack([base, np.full(len(base), d / 2)]), d / 2, grain)
    sim.fix_spheres(ids)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=grain)  # the board
    count = int(round(PHI_GUESS * base_size[0] * base_size[1] * height / (math.pi / 6)))
    # A lattice ~1.1 d apart (solid fraction ~0.4), jittered, from 2 d up.
    nx, ny = max(1, int(base_size[0] / 1.1)), max(1, int(base_size[1] / 1.1))
    layers = -(-count // (nx * ny))
    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(layers), indexing="ij")
    x = np.column_stack([(i.ravel() + 0.5) * lx / nx, (j.ravel() + 0.5) * ly / ny,
                         2 * d + 1.1 * d * k.ravel()])[:count]
    rng = np.random.default_rng([seed, 1])
    x[:, :2] += rng.uniform(-0.03 * d, 0.03 * d, (count, 2))
    sim.add_spheres(x, d / 2, grain)
    top = float(x[:, 2].max()) + d
    sim.set_box(lower=(0, 0, 0), upper=(lx, ly, top), periodic="xy")
    return sim, len(base)


def segment_volume(zc, r, z0: float, z1: float):
    """Volume of each sphere (centre height zc, radius r) between the planes z0 < z1."""
    def below(u):
        return math.pi * (r * r * u - u ** 3 / 3.0)

    return below(np.clip(z1 - zc, -r, r)) - below(np.clip(z0 - zc, -r, r))


def profiles(sim, fixed: int, edges: np.ndarray):
    """Per slab between `edges`, at this instant: the sum of v_x over the free spheres whose
    centre is in it, their number, and the solid fraction (all spheres, the base's included)."""
    x, r = sim.positions, sim.radii
    v = sim.velocities[fixed:, 0]
    z = x[fixed:, 2]
    box = sim.box
    area = float((box.upper[0] - box.lower[0]) * (box.upper[1] - box.lower[1]))
    slab = np.digitize(z, edges) - 1
    inside = (slab >= 0) & (slab < len(edges) - 1)
    count = np.bincount(slab[inside], minlength=len(edges) - 1).astype(float)
    vsum = np.bincount(slab[inside], weights=v[inside], minlength=len(edges) - 1)
    phi = np.array([segment_volume(x[:, 2], r, a, b).sum() for a, b in zip(edges[:-1], edges[1:])])
    phi /= area * np.diff(edges)
    return vsum, count, phi


def steady(times, energies) -> tuple:
    """Whether the kinetic energy is flat over the last STEADY_WINDOW tau (the change of a
    straight line fitted to it across the window, relative to its mean), and that change."""
    t, e = np.asarray(times), np.asarray(energies)
    last = t >= t[-1] - STEADY_WINDOW * TAU - 1e-12
    if t[-1] - t[0] < STEADY_WINDOW * TAU or last.sum() < 5:
        return False, math.inf
    slope, _ = np.polyfit(t[last] - t[-1], e[last], 1)
    change = abs(slope) * STEADY_WINDOW * TAU / max(float(np.mean(e[last])), 1e-300)
    return bool(change < STEADY_TOL), float(change)


def bagnold(z, a: float, h: float):
    """Bagnold's profile A [h^(3/2) - (h - z)^(3/2)] (h - z clipped at 0)."""
    return a * (h ** 1.5 - np.clip(h - np.asarray(z), 0, None) ** 1.5)


def fit_bagnold(z, v, h: float) -> tuple:
    """A of the least-squares Bagnold profile over 0 <= z <= h, and the rms residual there
    relative to the surface velocity A h^(3/2)."""
    use = (z >= 0) & (z <= h) & np.isfinite(v)
    shape = bagnold(z[use], 1.0, h)
    a = float(shape @ v[use] / (shape @ shape))
    rms = float(np.sqrt(np.mean((v[use] - a * shape) ** 2)))
    return a, rms / (a * h ** 1.5)


def surface_and_bulk(z, phi) -> tuple:
    """The free surface h (where phi falls to half the bulk value, interpolated) and the bulk
    phi (mean from 2 d above the base to 3 d below h)."""
    d = DIAMETER
    guess = float(np.median(phi[(z > 2 * d) & (phi > 0.3)]))  # the dense part
    for _ in range(3):
        above = np.where((z > d) & (phi < 0.5 * guess))[0]
        k = int(above[0])
        h = float(np.interp(0.5 * guess, [phi[k], phi[k - 1]], [z[k], z[k - 1]]))
        bulk = (z >= 2 * d) & (z <= h - 3 * d)
        if bulk.sum() >= 1:
            guess = float(phi[bulk].mean())
    return h, guess


def run_angle(sim, fixed: int, angle: float, edges: np.ndarray, base_top: float,
              min_time: float = MIN_TIME, max_time: float = MAX_TIME,
              average: float = AVERAGE) -> tuple:
    """Tilt to `angle`, run at least `min_time` and until the kinetic energy is flat (at most
    `max_time`), then average the profiles over `average` (all three in tau)."""
    started = time.process_time()
    sim.gravity = gravity(angle)
    t0, steps0 = sim.time, sim.step_count
    n = sim.size - fixed
    times, energies = [], []

    def advance(duration: float):
        target = sim.time + duration * TAU
        while sim.time < target - 0.5 * sim.dt:
            sim.run(time=SAMPLE * TAU)
            times.append(sim.time - t0)
            energies.append(sim.energy()["kinetic"] / (n * MASS * GRAVITY * DIAMETER))

    advance(min_time)
    flat, change = steady(times, energies)
    while not flat and sim.time - t0 < max_time * TAU - 0.5 * sim.dt:
        advance(CHUNK)
        flat, change = steady(times, energies)
    steady_at = sim.time - t0
    halves = [[np.zeros(len(edges) - 1) for _ in range(3)] for _ in range(2)]  # vsum, count, phi
    samples = [0, 0]
    start = sim.time
    target = start + average * TAU
    while sim.time < target - 0.5 * sim.dt:
        sim.run(time=SAMPLE * TAU)
        times.append(sim.time - t0)
        energies.append(sim.energy()["kinetic"] / (n * MASS * GRAVITY * DIAMETER))
        k = int(sim.time - start > 0.5 * average * TAU + 1e-9 * TAU)
        for total, part in zip(halves[k], profiles(sim, fixed, edges)):
            total += part
        samples[k] += 1
    mid = 0.5 * (edges[:-1] + edges[1:]) - base_top  # height above the base's top
    vsum, count, phi = (a + b for a, b in zip(*halves))
    with np.errstate(invalid="ignore", divide="ignore"):
        vx = vsum / count
        vx_halves = [h[0] / h[1] for h in halves]
    phi /= sum(samples)
    h, phi_bulk = surface_and_bulk(mid, phi)
    a, residual = fit_bagnold(mid, vx, h)
    a_halves = [fit_bagnold(mid, v, h)[0] for v in vx_halves]
    cos = math.cos(math.radians(angle))
    t = np.asarray(times)
    during = t >= steady_at - 1e-12
    e_avg = np.asarray(energies)[during]
    half = len(e_avg) // 2
    x = sim.positions
    summary = dict(
        angle=angle, steady=flat, kinetic_energy_trend=change, steady_after_tau=steady_at / TAU,
        averaged_tau=average, kinetic_energy=float(e_avg.mean()),
        kinetic_energy_drift=float(e_avg[half:].mean() / e_avg[:half].mean() - 1),
        surface_height=h / DIAMETER, phi_bulk=phi_bulk,
        bagnold_A=a, bagnold_A_dimensionless=a * DIAMETER / math.sqrt(GRAVITY),
        bagnold_residual=residual,
        bagnold_A_halves=[x * DIAMETER / math.sqrt(GRAVITY) for x in a_halves],
        surface_velocity=a * h ** 1.5 / math.sqrt(GRAVITY * DIAMETER),
        mean_velocity=float(vsum.sum() / count.sum() / math.sqrt(GRAVITY * DIAMETER)),
        inertial_number=1.5 * a * DIAMETER / math.sqrt(phi_bulk * GRAVITY * cos),
        lowest_free_sphere=float(x[fixed:, 2].min() / DIAMETER),
        steps=sim.step_count - steps0, cpu_seconds=time.process_time() - started)
    arrays = dict(times=t / TAU, kinetic_energy=np.asarray(energies), z=mid / DIAMETER,
                  vx=vx / math.sqrt(GRAVITY * DIAMETER), phi=phi, spheres_per_slab=count / sum(samples),
                  positions=x / DIAMETER, velocities=sim.velocities / math.sqrt(GRAVITY * DIAMETER),
                  fixed=np.arange(sim.size) < fixed)
    return summary, arrays


def main(argv=None) -> dict:
    parser = arguments(__doc__.split("\n")[0], "chute")
    parser.add_argument("--quick", action="store_true",
                        help="a 6 d x 6 d base, h ~ 6 d, two angles, short runs: a test of seconds")
    parser.add_argument("--angles", type=float, nargs="+", default=None,
                        help="inclinations in degrees (default 24 25 26)")
    parser.add_argument("--height", type=float, default=None, help="layer height in d (default 10)")
    parser.add_argument("--base", type=float, nargs=2, default=None,
                        help="base's L_x L_y in d (default 10 10)")
    parser.add_argument("--threads", type=int, default=None, help="OpenMP threads (default: all)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the base and the lattice")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    cpu = time.process_time()
    angles = args.angles or ([24.0, 26.0] if args.quick else list(ANGLES))
    height = args.height or (6.0 if args.quick else HEIGHT)
    base_size = args.base or ((6.0, 6.0) if args.quick else BASE)
    timing = (dict(min_time=10.0, max_time=10.0, average=6.0) if args.quick else
              dict(min_time=MIN_TIME, max_time=MAX_TIME, average=AVERAGE))
    sim, fixed = build(base_size, height, angles[0], args.seed, args.threads)
    base_top = DIAMETER  # the base's centres at d/2 on the board
    edges = np.arange(0.0, sim.box.upper[2] + 2 * DIAMETER, SLAB * DIAMETER)
    results = [run_angle(sim, fixed, angle, edges, base_top, **timing) for angle in angles]
    os.makedirs(args.out, exist_ok=True)
    for s, arrays in results:
        np.savez(os.path.join(args.out, f"chute_theta{s['angle']:g}.npz"), **arrays)
    summary = dict(runs=[s for s, _ in results], base_spheres=fixed, free_spheres=sim.size - fixed,
                   base=list(base_size), diameter=DIAMETER, stiffness_mg_per_d=STIFFNESS,
                   restitution=RESTITUTION, friction=FRICTION, dt_tau=sim.dt / TAU,
                   cpu_seconds=time.process_time() - cpu)
    write_json(os.path.join(args.out, "chute.json"), summary)
    figure = figure_path(args, "chute")
    if figure:
        plot(args.out, figure)
    print(f"{sim.size - fixed} free spheres on a base of {fixed} fixed ones "
          f"({base_size[0]:g} d x {base_size[1]:g} d), dt = {sim.dt / TAU:.2e} tau")
    for s in summary["runs"]:
        print(f"theta = {s['angle']:g} deg: {'steady' if s['steady'] else 'NOT steady'} after "
              f"{s['steady_after_tau']:.0f} tau, h = {s['surface_height']:.2f} d, phi bulk "
              f"{s['phi_bulk']:.3f}, Bagnold A = {s['bagnold_A_dimensionless']:.4f} sqrt(g/d)/d, "
              f"residual {100 * s['bagnold_residual']:.1f} % of v(h) = "
              f"{s['surface_velocity']:.2f} sqrt(gd), I = {s['inertial_number']:.3f}, "
              f"{s['cpu_seconds']:.1f} s CPU")
    print(f"wrote {args.out} in {time.perf_counter() - started:.1f} s "
          f"({summary['cpu_seconds']:.1f} s CPU)")
    return summary


def plot(out: str, figure: str) -> None:
    """The figure, from the files in `out` only."""
    plt = pyplot()
    with open(os.path.join(out, "chute.json")) as f:
        s = json.load(f)
    fig, (ax_e, ax_v, ax_phi) = plt.subplots(1, 3, figsize=(15, 5))
    offset, deepest = 0.0, 0.0
    for i, run in enumerate(s["runs"]):
        data = read_npz(os.path.join(out, f"chute_theta{run['angle']:g}.npz"))
        colour = f"C{i}"
        label = f"{run['angle']:g}°"
        # Kinetic energy against time, the averaging window marked.
        t = data["times"] + offset
        ax_e.plot(t, data["kinetic_energy"], color=colour, label=label)
        ax_e.axvspan(offset + run["steady_after_tau"], t[-1], color=colour, alpha=0.12, lw=0)
        offset = t[-1]
        # v_x(z) with the fitted Bagnold profile.
        z, vx, h = data["z"], data["vx"], run["surface_height"]
        ok = np.isfinite(vx) & (data["spheres_per_slab"] > 0.5)
        ax_v.plot(vx[ok], z[ok], "o", ms=3, color=colour,
                  label=f"{label}: A = {run['bagnold_A_dimensionless']:.3f}, "
                        f"residual {100 * run['bagnold_residual']:.1f} %")
        zz = np.linspace(0, h, 100)
        ax_v.plot(bagnold(zz, run["bagnold_A_dimensionless"], h), zz, "-", color=colour, lw=1)
        # phi against depth below the surface.
        deepest = max(deepest, float(h - z.min()))
        ax_phi.plot(data["phi"], h - z, "-", color=colour,
                    label=f"{label}: bulk {run['phi_bulk']:.3f}, h = {h:.1f} d")
    ax_e.set(xlabel="t / sqrt(d/g) (one angle after the other)",
             ylabel="kinetic energy per sphere / (m g d)",
             title="Kinetic energy (shaded: averaged, steady)")
    ax_e.legend(fontsize=8)
    ax_v.set(xlabel="v_x / sqrt(g d)", ylabel="height above the base z / d",
             title="v_x(z); lines: A [h^(3/2) - (h - z)^(3/2)]", xlim=(0, None), ylim=(0, None))
    ax_v.legend(fontsize=8)
    ax_phi.set(xlabel="solid fraction phi", ylabel="depth below the surface (h - z) / d",
               title="Packing fraction against depth", xlim=(0, 0.75), ylim=(deepest, -2.0))
    ax_phi.axhline(0, color="k", lw=0.5)
    ax_phi.legend(fontsize=8)
    fig.suptitle(f"Chute flow, {s['free_spheres']} spheres on a {s['base'][0]:g} d x "
                 f"{s['base'][1]:g} d periodic rough base (Silbert et al. 2001, k_n = "
                 f"{s['stiffness_mg_per_d']:g} m g/d, e = {s['restitution']:g}, mu = {s['friction']:g})")
    fig.tight_layout()
    save_figure(fig, figure)


if __name__ == "__main__":
    main(sys.argv[1:])

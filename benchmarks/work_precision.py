"""Run time against error (work-precision) of tsubu's symplectic Euler on closed-form cases.

For each case the time step is swept as dt = t_c / k (t_c the contact duration, B.5) and the
error against the closed form is plotted against the wall time of the run. Each case runs
many independent copies of its scene at once (spheres far apart), so that the time measured is
the engine's, not Python's.

    python benchmarks/work_precision.py            # prints the table, writes docs/figures/work_precision.png
    python benchmarks/work_precision.py --quick    # a smoke run (CI size), no plot

Cases (closed forms from shared/seeds/dem_basics.md, appendix B, and rigid-body mechanics):
  restitution  head-on pairs, e = 0.5: |e_measured - e|
  rolling      spheres sliding on a floor, mu = 0.5: |v_final - 5/7 v0| / (5/7 v0) at 2 t_roll
  oblique      gross-slip impacts on a wall (e = 1, mu = 0.5): |w' - 5 mu (1+e) v_n / (2 R)| / that
  energy       elastic (e = 1, mu = 0) spheres bouncing in a box for 0.02 s: max |E - E0| / E0
               over samples taken when nothing touches
"""
from __future__ import annotations

import argparse
import math
import pathlib
import time

import numpy as np

import tsubu

R = 0.5e-3
RHO = 2500.0
KN = 1e3
M = RHO * 4.0 / 3.0 * math.pi * R**3
G = 9.81


def material(**kw) -> tsubu.Material:
    args = dict(density=RHO, kn=KN, restitution=0.5, friction=0.5)
    args.update(kw)
    return tsubu.Material(**args)


def spread(n: int, spacing: float) -> np.ndarray:
    """n points on a square grid in the xy plane, `spacing` apart."""
    side = int(math.ceil(math.sqrt(n)))
    k = np.arange(n)
    return np.stack([(k % side) * spacing, (k // side) * spacing, np.zeros(n)], axis=1)


def timed_run(sim: tsubu.Simulation, steps: int) -> float:
    start = time.perf_counter()
    sim.run(steps=steps)
    return time.perf_counter() - start


def restitution(k: float, copies: int):
    e = 0.5
    mat = material(restitution=e, friction=0.0)
    sim = tsubu.Simulation(gravity=(0, 0, 0), threads=1)
    base = spread(copies, 10 * R)
    left, right = base.copy(), base.copy()
    left[:, 2] = -R
    right[:, 2] = R  # touching: the contact starts at the first step
    v = np.zeros((2 * copies, 3))
    v[:copies, 2], v[copies:, 2] = 0.05, -0.05
    sim.add_spheres(np.vstack([left, right]), R, mat, velocities=v)
    sim.dt = sim.contact_duration() / k
    seconds = timed_run(sim, int(math.ceil(2.0 * k)) + 2)
    u = sim.velocities
    e_measured = (u[copies:, 2] - u[:copies, 2]).mean() / 0.1
    return abs(e_measured - e), seconds


def rolling(k: float, copies: int):
    mu, v0 = 0.5, 0.1
    # a damped tangential spring stops ringing once the sphere rolls; the closed form holds
    # whatever the tangential law (angular momentum about the contact line is conserved)
    mat = material(friction=mu, tangential_damping=1.0)
    sim = tsubu.Simulation(gravity=(0, 0, -G), threads=1)
    x = spread(copies, 10 * R)
    x[:, 2] = R - M * G / KN
    v = np.zeros((copies, 3))
    v[:, 0] = v0
    sim.add_spheres(x, R, mat, velocities=v)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=mat)
    sim.dt = sim.contact_duration() / k
    t_roll = 2 * v0 / (7 * mu * G)
    seconds = timed_run(sim, int(round(2.0 * t_roll / sim.dt)))
    v_final = float(sim.velocities[:, 0].mean())
    return abs(v_final - 5 / 7 * v0) / (5 / 7 * v0), seconds


def oblique(k: float, copies: int):
    mu, e, vn, vt = 0.5, 1.0, 0.02, 0.3
    mat = material(friction=mu, restitution=e)
    sim = tsubu.Simulation(gravity=(0, 0, 0), threads=1)
    x = spread(copies, 10 * R)
    x[:, 2] = R
    v = np.zeros((copies, 3))
    v[:, 0], v[:, 2] = vt, -vn
    sim.add_spheres(x, R, mat, velocities=v)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=mat)
    sim.dt = sim.contact_duration() / k
    seconds = timed_run(sim, int(math.ceil(2.0 * k)) + 2)
    spin = sim.angular_velocities[:, 1].mean()
    expected = 5 * mu * (1 + e) * vn / (2 * R)  # I dw = R mu (1+e) m v_n, I = 2/5 m R^2
    return abs(spin - expected) / expected, seconds


def energy(k: float, copies: int):
    mat = material(restitution=1.0, friction=0.0)
    sim = tsubu.Simulation(gravity=(0, 0, -G), threads=1, seed=1)
    rng = np.random.default_rng(3)
    side = 8e-3
    n = copies
    g = int(math.ceil(n ** (1 / 3)))
    idx = np.arange(n)
    x = (np.stack([idx % g, (idx // g) % g, idx // (g * g)], axis=1) + 0.5) * (side / g)
    x[:, 2] += 2 * R
    sim.add_spheres(x, R * 0.8, mat, velocities=rng.uniform(-0.05, 0.05, (n, 3)))
    for point, normal in [((0, 0, 0), (0, 0, 1)), ((0, 0, 0), (1, 0, 0)), ((side, 0, 0), (-1, 0, 0)),
                          ((0, 0, 0), (0, 1, 0)), ((0, side, 0), (0, -1, 0))]:
        sim.add_plane(point=point, normal=normal, material=mat)
    sim.dt = sim.contact_duration() / k
    e0 = sim.energy()["total"]
    worst, seconds = 0.0, 0.0
    chunk = max(1, int(round(2e-4 / sim.dt)))
    for _ in range(int(round(0.02 / (chunk * sim.dt)))):
        seconds += timed_run(sim, chunk)
        en = sim.energy()
        if en["elastic"] == 0.0:
            worst = max(worst, abs(en["total"] - e0) / abs(e0))
    return worst, seconds


CASES = {"restitution": (restitution, 2000), "rolling": (rolling, 500), "oblique": (oblique, 2000),
         "energy": (energy, 300)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="small copies and two time steps, no plot")
    ap.add_argument("--steps-per-contact", nargs="+", type=float, default=[25, 50, 100, 200, 400],
                    help="the sweep dt = t_c / k (default 25 .. 400; 50 is the default dt)")
    args = ap.parse_args(argv)
    ks = [25, 50] if args.quick else args.steps_per_contact
    results = {}
    print(f"{'case':12s} {'k=t_c/dt':>9s} {'error':>11s} {'seconds':>9s}")
    for name, (fn, copies) in CASES.items():
        copies = max(4, copies // 50) if args.quick else copies
        rows = []
        for k in ks:
            err, sec = fn(k, copies)
            rows.append((k, err, sec))
            print(f"{name:12s} {k:9.1f} {err:11.3e} {sec:9.3f}", flush=True)
        results[name] = rows
        good = [(k, e) for k, e, _ in rows if e > 0]
        if len(good) >= 2:
            slope = np.polyfit(np.log([1 / k for k, _ in good]), np.log([e for _, e in good]), 1)[0]
            print(f"{name:12s} fitted order in dt: {slope:.2f}")
    if args.quick:
        return 0
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, rows in results.items():
        ks_, errs, secs = zip(*rows)
        axes[0].loglog(secs, errs, "o-", label=name)
        axes[1].loglog([1 / k for k in ks_], errs, "o-", label=name)
        i = list(ks_).index(50) if 50 in ks_ else None
        if i is not None:
            axes[0].loglog([secs[i]], [errs[i]], "k*", ms=12)
            axes[1].loglog([1 / 50], [errs[i]], "k*", ms=12)
    axes[0].set_xlabel("wall time of the run [s] (one thread)")
    axes[0].set_ylabel("relative error against the closed form")
    axes[0].set_title("work-precision (★: default dt = t_c/50)", fontsize=10)
    axes[1].set_xlabel("dt / t_c")
    axes[1].set_title("convergence in dt", fontsize=10)
    ref = np.array([1 / 400, 1 / 12.5])
    axes[1].loglog(ref, 0.3 * ref, "k--", lw=0.8, label="first order")
    from matplotlib.ticker import NullFormatter

    for ax in axes:
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    out = pathlib.Path(__file__).resolve().parent.parent / "docs" / "figures" / "work_precision.png"
    fig.savefig(out, dpi=110)
    print("wrote", out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

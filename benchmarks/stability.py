"""Stability stress tests: where does the time loop blow up, against the bound that
critical_time_step() predicts, and does the run-time detection catch every blow-up?

    python benchmarks/stability.py           # prints the maps, writes docs/figures/stability.png
    python benchmarks/stability.py --quick   # a smoke run (CI size), no plot

Every run is forced (allow_unstable_dt=True) at dt = f x 2 sqrt(m/k) (the notes' spring bound,
m the reduced mass of the stiffest, lightest contact) and classified:
  stable    runs its steps (or settles) with finite values and no energy created
  caught    the run stopped with tsubu.InstabilityError (an overlap beyond 0.5 r or a
            non-finite force)
  SILENT    a blow-up was seen (energy created: the balance kinetic + gravitational + elastic +
            step correction + dissipated grew by more than a third of the energy dissipated plus twice
            the starting kinetic + elastic energy, or a quarter of the current one if larger; a
            sphere behind the floor; a NaN) and the run finished without an error (must never
            happen)
Scenes:
  single    one sphere pressed on a wall (m_eff = m), e in {1, 0.5, 0.1}
  mass      a small sphere resting on a large one, mass ratio 1:1 to 1:1000 (reduced mass)
  packs     spheres on simple-cubic (6 neighbours), body-centred (8) and face-centred (12)
            lattices squeezed in a box of walls, e = 0.5: coordination shrinks the safe dt
  impacts   spheres hitting a wall at increasing speed: overlaps beyond 10 % of r must either
            stay stable or be caught, never silent
"""
from __future__ import annotations

import argparse
import math
import pathlib

import numpy as np

import tsubu

R = 0.5e-3
RHO = 2500.0
KN = 1e3
M = RHO * 4 / 3 * math.pi * R**3


def balance(sim: tsubu.Simulation) -> tuple[float, float, float]:
    """(kinetic + gravitational + elastic + step correction + dissipated, dissipated,
    kinetic + elastic) [J]. The step correction (dt/2 sum v.F of the conservative forces) makes
    the mechanical part exactly conserved by symplectic Euler for linear springs, even just below
    the bound where kinetic + elastic alone swings by a large factor within one oscillation."""
    e = sim.energy(at_positions=True)
    return (e["total"] + e["step_correction"] + e["dissipated"], e["dissipated"],
            e["kinetic"] + e["elastic"])


def outcome(sim: tsubu.Simulation, steps: int) -> str:
    """stable / caught / SILENT. With fixed walls nothing supplies energy. A blow-up: a value
    not finite, a centre behind the floor, or energy created -- the balance grew by more than
    a third of the energy dissipated plus twice max(the starting kinetic + elastic energy, a quarter
    of the current one), the criterion of tsubu's own check, looked at 200 times per run
    instead of every 1,000 steps. Caught: tsubu raised InstabilityError at some step of the run
    (a burst seen between its checks counts as caught once the check raises); SILENT: a blow-up
    was seen and the run finished without an error."""
    blown = False
    try:
        sim.run(steps=1)  # contacts evaluated once: the elastic energy is known
        b0, d0, e0 = balance(sim)
        for _ in range(200):
            sim.run(steps=max(steps // 200, 1))
            x = sim.positions
            if not np.all(np.isfinite(x)) or not np.all(np.isfinite(sim.velocities)) or np.any(x[:, 2] < 0):
                blown = True
                break
            b, d, e = balance(sim)
            blown = blown or b - b0 > 0.5 * max(d - d0, 0.0) + 2.0 * max(e0, 0.25 * e)
    except tsubu.InstabilityError:
        return "caught" if np.all(np.isfinite(sim.positions)) else "SILENT"
    return "SILENT" if blown else "stable"


def single(f: float, e: float, steps: int) -> tuple[str, float]:
    mat = tsubu.Material(density=RHO, kn=KN, restitution=e, friction=0.0)
    g = 1000.0
    sim = tsubu.Simulation(gravity=(0, 0, -g), dt=f * 2 * math.sqrt(M / KN), allow_unstable_dt=True)
    sim.add_sphere((0, 0, R - 0.5 * M * g / KN), R, mat)  # half the static overlap: it oscillates
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=mat)
    return outcome(sim, steps), sim.dt / sim.critical_time_step()


def mass_ratio(f: float, ratio: float, steps: int) -> tuple[str, float]:
    mat = tsubu.Material(density=RHO, kn=KN, restitution=0.5, friction=0.5)
    big = R * ratio ** (1 / 3)
    m_small, m_big = M, M * ratio
    m_red = m_small * m_big / (m_small + m_big)
    sim = tsubu.Simulation(gravity=(0, 0, -9.81), dt=f * 2 * math.sqrt(m_red / KN), allow_unstable_dt=True)
    sim.add_sphere((0, 0, big), big, mat)
    sim.add_sphere((0, 0, 2 * big + R - 2e-7), R, mat)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=mat)
    return outcome(sim, steps), sim.dt / sim.critical_time_step()


def lattice(kind: str, cells: int) -> tuple[np.ndarray, float]:
    """Centres of a lattice of spheres of radius R squeezed by 1 % (nearest neighbours at
    1.98 R), and the box side."""
    d = 1.98 * R
    if kind == "sc":
        a, basis = d, [(0, 0, 0)]
    elif kind == "bcc":
        a, basis = 2 * d / math.sqrt(3), [(0, 0, 0), (0.5, 0.5, 0.5)]
    else:
        a, basis = d * math.sqrt(2), [(0, 0, 0), (0.5, 0.5, 0), (0.5, 0, 0.5), (0, 0.5, 0.5)]
    pts = [(np.array([i, j, k]) + b) * a for i in range(cells) for j in range(cells)
           for k in range(cells) for b in basis]
    x = np.array(pts) + 0.99 * R
    return x, cells * a + 0.99 * R


def pack(f: float, kind: str, cells: int, steps: int) -> tuple[str, float]:
    mat = tsubu.Material(density=RHO, kn=KN, restitution=0.5, friction=0.5)
    x, side = lattice(kind, cells)
    sim = tsubu.Simulation(gravity=(0, 0, 0), dt=f * 2 * math.sqrt(M / 2 / KN), allow_unstable_dt=True,
                           initial_overlap=0.05)
    rng = np.random.default_rng(1)
    sim.add_spheres(x, R, mat, velocities=rng.normal(0, 1e-3, x.shape))
    for axis in range(3):
        n = np.eye(3)[axis]
        sim.add_plane(point=(0, 0, 0), normal=n, material=mat)
        sim.add_plane(point=side * n, normal=-n, material=mat)
    return outcome(sim, steps), sim.dt / sim.critical_time_step()


def impact(speed: float) -> tuple[str, float]:
    mat = tsubu.Material(density=RHO, kn=KN, restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    sim.add_sphere((0, 0, R + 1e-7), R, mat, velocity=(0.3 * speed, 0, -speed))
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=mat)
    worst = 0.0
    try:
        for _ in range(400):
            sim.run(steps=1)
            c = sim.contacts()
            if len(c["overlap"]):
                worst = max(worst, float(c["overlap"].max()) / R)
    except tsubu.InstabilityError:
        return "caught", worst
    ok = np.all(np.isfinite(sim.positions)) and sim.positions[0, 2] > 0 and sim.velocities[0, 2] > 0
    return ("stable" if ok else "SILENT"), worst


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    fs = [0.5, 1.1] if args.quick else [0.1, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 1.0, 1.05, 1.1, 1.2]
    steps = 4000 if args.quick else 20000  # packs run a quarter: at least one 1,000-step check
    silent = 0
    rows = []
    print("f = dt / (2 sqrt(m/k)); 'bound' = dt / critical_time_step()")
    for e in (1.0, 0.5, 0.1):
        line = []
        for f in fs:
            res, b = single(f, e, steps)
            silent += res == "SILENT"
            rows.append(("single", f"e={e}", f, res, b))
            line.append(f"{f:.2f}:{res}")
        print(f"single sphere on a wall, e = {e}:  " + "  ".join(line))
    for ratio in ([1, 1000] if args.quick else [1, 10, 100, 1000]):
        line = []
        for f in fs:
            res, b = mass_ratio(f, ratio, steps)
            silent += res == "SILENT"
            rows.append(("mass", f"1:{ratio}", f, res, b))
            line.append(f"{f:.2f}:{res}")
        print(f"small on large sphere, mass ratio 1:{ratio}:  " + "  ".join(line))
    cells = 3 if args.quick else 5
    for kind, z in (("sc", 6), ("bcc", 8), ("fcc", 12)):
        line = []
        for f in fs:
            res, b = pack(f, kind, cells, steps // 4)
            silent += res == "SILENT"
            rows.append(("pack", f"{kind} z={z}", f, res, b))
            line.append(f"{f:.2f}:{res}")
        print(f"squeezed {kind} pack (z = {z}):  " + "  ".join(line))
    for speed in ([1.0, 30.0] if args.quick else [0.1, 1.0, 3.0, 10.0, 30.0, 100.0]):
        res, worst = impact(speed)
        silent += res == "SILENT"
        print(f"impact at {speed:6.1f} m/s: {res}, largest overlap seen {worst:.3f} r")
    print(f"silent blow-ups: {silent} (must be 0)")
    if not args.quick:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        labels = sorted({(kind, lab) for kind, lab, *_ in rows}, key=lambda t: [r[:2] for r in rows].index(t))
        colour = {"stable": "tab:green", "caught": "tab:orange", "SILENT": "tab:red"}
        fig, ax = plt.subplots(figsize=(9, 4.5))
        for y, (kind, lab) in enumerate(labels):
            for k, l2, f, res, b in rows:
                if (k, l2) == (kind, lab):
                    ax.scatter(f, y, c=colour[res], s=60, marker="s")
            bound = [b / f for k, l2, f, _, b in rows if (k, l2) == (kind, lab)][0]
            ax.plot([1 / bound, 1 / bound], [y - 0.4, y + 0.4], "k-", lw=2)
        ax.set_yticks(range(len(labels)))
        ax.set_yticklabels([f"{k}: {l}" for k, l in labels])
        ax.set_xlabel("dt / (2 sqrt(m/k))")
        ax.set_title("green: stable, orange: blow-up caught, red: silent; bar: critical_time_step()", fontsize=9)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        out = pathlib.Path(__file__).resolve().parent.parent / "docs" / "figures" / "stability.png"
        fig.savefig(out, dpi=110)
        print("wrote", out)
    return 1 if silent else 0


if __name__ == "__main__":
    raise SystemExit(main())

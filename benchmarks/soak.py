"""Soak: a settled pack run for a million steps stays bounded.

A pack of glass beads (the reference material: kn = 1000 N/m, e = 0.5, mu = 0.5) is dropped
into a box of five walls and settled; then it runs 1e6 more steps at the same dt, and the script
reports what must not happen in a settled pack: energy creeping up, spheres sinking through
the floor or walls, overlaps growing.

    python benchmarks/soak.py                 # 512 beads, 1e6 steps (a few minutes)
    python benchmarks/soak.py --steps 20000   # a short run
"""
from __future__ import annotations

import argparse
import time

import numpy as np

import tsubu

D = 1e-3
R = D / 2


def settled_pack(nx: int, nz: int, threads: int | None):
    glass = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)
    a = 1.1 * D
    m = 2500.0 * np.pi / 6 * D**3
    sim = tsubu.Simulation(gravity=(0, 0, -9.81), dt=0.02 * 2 * np.sqrt(m / 1e3), threads=threads)
    i, j, k = np.meshgrid(np.arange(nx), np.arange(nx), np.arange(nz), indexing="ij")
    x = (np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1) + 0.5) * a
    sim.add_spheres(x, R, glass, velocities=np.random.default_rng(1).uniform(-0.05, 0.05, x.shape))
    side = nx * a
    walls = [((0, 0, 0), (0, 0, 1)), ((0, 0, 0), (1, 0, 0)), ((side, 0, 0), (-1, 0, 0)),
             ((0, 0, 0), (0, 1, 0)), ((0, side, 0), (0, -1, 0))]
    for point, normal in walls:
        sim.add_plane(point=point, normal=normal, material=glass)
    sim.run(time=0.15)
    return sim, side


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--nx", type=int, default=8)
    ap.add_argument("--nz", type=int, default=8)
    ap.add_argument("--threads", type=int, default=None)
    args = ap.parse_args(argv)
    sim, side = settled_pack(args.nx, args.nz, args.threads)
    e0 = sim.energy()
    base = e0["total"]
    drop = abs(e0["gravitational"])  # scale: the potential energy of the pack above the floor
    print(f"{sim.size} beads settled for {sim.time:.3f} s ({sim.step_count} steps); kinetic energy "
          f"{e0['kinetic']:.3e} J; now {args.steps} more steps of dt = {sim.dt:.4g} s")
    chunk = max(1, args.steps // 50)
    ke_max, creep_max, overlap_max, lowest, outside = 0.0, 0.0, 0.0, np.inf, 0
    start = time.perf_counter()
    done = 0
    while done < args.steps:
        k = min(chunk, args.steps - done)
        sim.run(steps=k)
        done += k
        e = sim.energy()
        x = sim.positions
        ke_max = max(ke_max, e["kinetic"])
        creep_max = max(creep_max, (e["total"] - base) / drop)  # may only fall: dissipation
        c = sim.contacts()
        if len(c["overlap"]):
            overlap_max = max(overlap_max, float(c["overlap"].max()) / R)
        lowest = min(lowest, float(x[:, 2].min()))
        outside += int(np.sum((x[:, 0] < 0) | (x[:, 0] > side) | (x[:, 1] < 0) | (x[:, 1] > side) | (x[:, 2] < 0)))
    wall = time.perf_counter() - start
    e = sim.energy()
    print(f"ran {done} steps ({sim.size * done / wall / 1e6:.1f} M particle-steps/s, {wall:.1f} s)")
    print(f"kinetic energy: start {e0['kinetic']:.3e} J, largest {ke_max:.3e} J, end {e['kinetic']:.3e} J")
    print(f"energy creep: largest rise of the mechanical energy (kinetic + gravitational + elastic) "
          f"over its start, relative to |gravitational energy|: {creep_max:.2e}")
    print(f"largest overlap {overlap_max:.4f} r; lowest centre {lowest / R:.4f} r above the floor; "
          f"centres outside the box at any sample: {outside}")
    ok = outside == 0 and lowest > 0 and overlap_max < 0.05 and creep_max < 1e-6
    print("bounded" if ok else "NOT BOUNDED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())

"""What a mesh wall costs: one settled bed on a floor that is a plane, a mesh of ~1,000
triangles or one of ~100,000 triangles (the same flat square, finer), timed side by side.

The bed (N spheres, radius 1 mm, frictional linear law) is built once on a plane floor inside
four side planes, settled, and saved; each variant starts from those bits with its own floor and
runs the same steps, in rounds (A B C A B C ...), each run in a fresh process-free Simulation
copy. Prints particle-steps per second per variant (median of the rounds) and the ratios: the
issue's target is a 100,000-triangle floor within 20 % of a 1,000-triangle one, and the scenes
without a mesh unchanged (benchmarks/ab_speed.py, benchmarks/state_hashes.py).

    python benchmarks/mesh_cost.py [--n 10000] [--steps 2000] [--rounds 3] [--threads 1]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import tsubu
from bench_common import machine

RADIUS = 1e-3


def material():
    return tsubu.Material(density=2500, kn=1e4, restitution=0.5, friction=0.5)


def side_walls(sim, side: float, mat) -> None:
    """Four planes boxing the square [-side/2, side/2]^2 in."""
    for axis in (0, 1):
        for sign in (-1, 1):
            nrm = np.zeros(3)
            nrm[axis] = -sign
            p = np.zeros(3)
            p[axis] = sign * side / 2
            sim.add_plane(p, nrm, mat)


def bed(n: int, threads: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Positions and velocities of n spheres settled on z = 0 in a square box, and its side."""
    side = 2 * RADIUS * 1.05 * np.ceil(np.sqrt(n / 8))  # ~8 layers
    mat = material()
    sim = tsubu.Simulation(gravity=(0, 0, -9.81), threads=threads)
    k = int(np.ceil(side / (2.2 * RADIUS)))
    g = (np.arange(k) + 0.5) * side / k - side / 2
    layers = int(np.ceil(n / k**2))
    z = RADIUS * 1.1 + 2.2 * RADIUS * np.arange(layers)
    X, Y, Z = np.meshgrid(g, g, z, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel(), Z.ravel()], 1)[:n]
    rng = np.random.default_rng(1)
    pts[:, :2] += rng.uniform(-0.05, 0.05, (n, 2)) * RADIUS
    sim.add_spheres(pts, RADIUS, mat)
    sim.add_plane((0, 0, 0), (0, 0, 1), mat)
    side_walls(sim, side, mat)
    sim.run(time=0.15)
    return sim.positions.copy(), sim.velocities.copy(), side


def scene(floor: str, divisions: int, pts, vel, side, threads):
    mat = material()
    sim = tsubu.Simulation(gravity=(0, 0, -9.81), threads=threads)
    sim.add_spheres(pts, RADIUS, mat, velocities=vel)
    if floor == "plane":
        sim.add_plane((0, 0, 0), (0, 0, 1), mat)
    else:
        v, f = tsubu.mesh.square((0, 0, 0), 1.2 * side, (0, 0, 1), divisions)
        sim.add_mesh(v, f, material=mat)
    side_walls(sim, side, mat)
    return sim


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    print(machine())
    pts, vel, side = bed(a.n, a.threads)
    variants = {"plane": ("plane", 0), "mesh 1e3": ("mesh", 22), "mesh 1e5": ("mesh", 224)}
    rates = {k: [] for k in variants}
    triangles = {}
    for _ in range(a.rounds):
        for name, (floor, div) in variants.items():
            sim = scene(floor, div, pts, vel, side, a.threads)
            if floor == "mesh":
                triangles[name] = len(sim.wall(0)["faces"])
            sim.run(steps=10)  # the lists and the first contacts, outside the timing
            t0 = time.perf_counter()
            sim.run(steps=a.steps)
            rates[name].append(a.n * a.steps / (time.perf_counter() - t0))
    med = {k: statistics.median(v) for k, v in rates.items()}
    for k, v in med.items():
        tri = f" ({triangles[k]} triangles)" if k in triangles else ""
        print(f"{k:10s}{tri:20s} {v / 1e6:7.3f} M particle-steps/s  (runs: "
              + ", ".join(f"{x / 1e6:.3f}" for x in rates[k]) + ")")
    print(f"mesh 1e3 / plane: {med['mesh 1e3'] / med['plane']:.3f}")
    print(f"mesh 1e5 / mesh 1e3: {med['mesh 1e5'] / med['mesh 1e3']:.3f}  (target >= 1/1.2 = 0.833)")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Bit-for-bit fingerprints of end states, for showing that a change to the core leaves the
physics untouched.

Each scene is built, run for a fixed number of steps with 1 and with 2 threads, and its end state
is hashed (SHA-256 of the bytes of positions, velocities, angular velocities, forces, torques,
every current contact's ids, overlap, force, torque and tangential displacement, the energy
terms and the step count). The scenes cover every compiled feature: the reference drop at
N = 1e5 (blocked law, fused pass), the two dense beds (fixed and sliding floor), a rough scene
with rolling friction, a frictionless drop, a scene of two materials (per-pair parameter lanes),
the notes' literal history rule, a scene with a tilting, rising wall, a Lees–Edwards box, a
periodic chute on fixed grains, a drop onto a floor of small triangles and a fast, spinning gas
(contacts whose normal turns far in one step).

Run it on the code before and after a change and compare the printed hashes (or the --json
files): equal hashes mean equal bits. The two thread counts must also agree with each other.
A change to how energy is booked (not to the motion) is shown with ``--skip-energy dissipated``:
the trajectories and every other term keep their bits.

Usage (from the repository root)::

    PYTHONPATH=python python benchmarks/state_hashes.py                  # all scenes, 1 and 2 threads
    PYTHONPATH=python python benchmarks/state_hashes.py --scenes dense-static --threads 1
    PYTHONPATH=python python benchmarks/state_hashes.py --json before.json
    python benchmarks/state_hashes.py --compare before.json after.json
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import reference_scene as ref  # noqa: E402


def _drop(n, **kw):
    def make(threads):
        return ref.build(n, threads=threads, **kw)
    return make


def _dense(floor_velocity=0.0):
    def make(threads):
        return ref.build_dense_bed(threads=threads, floor_velocity=floor_velocity)
    return make


def _two_materials(threads):
    import tsubu
    n = 10_000
    sim = ref.new_simulation(threads, slip_rule="frozen")
    soft = ref.material()
    hard = tsubu.Material(density=ref.RHO * 1.5, kn=2.0 * ref.KN, kt=0.5 * ref.KN, restitution=0.7,
                          friction=0.3, tangential_damping=0.2)
    x, v = ref.initial_state(n)
    sim.add_spheres(x[0::2], ref.R, soft, velocities=v[0::2])
    sim.add_spheres(x[1::2], ref.R, hard, velocities=v[1::2])
    lx, ly = ref.box(n)
    ref.add_walls(sim, lx, ly, hard)
    return sim


def _literal(threads):
    import tsubu
    n = 10_000
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -ref.G), dt=ref.DT, threads=threads, skin=ref.SKIN,
                           tangential_history="literal")
    x, v = ref.initial_state(n)
    sim.add_spheres(x, ref.R, ref.material(), velocities=v)
    lx, ly = ref.box(n)
    ref.add_walls(sim, lx, ly, ref.material())
    return sim


def _tilting_wall(threads):
    sim = ref.build_dense_bed(threads=threads)
    sim.set_plane_motion(0, velocity=(0.02, 0.0, 0.002), angular_velocity=(0.0, 0.3, 0.0))
    return sim


def _lattice(nx, ny, nz, spacing, seed):
    """A simple cubic lattice of nx x ny x nz sites `spacing` apart from the origin plus half a
    spacing, jittered by up to 1 % of a spacing (seeded)."""
    rng = np.random.default_rng(seed)
    g = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"), -1)
    x = (g.reshape(-1, 3) + 0.5) * spacing
    return x + rng.uniform(-0.01, 0.01, x.shape) * spacing


def _lees_edwards(threads):
    """2,000 spheres in a periodic cube, sheared at 200 /s by Lees–Edwards images (ghosts across
    every face, the lists' bound relative to the mean flow), from a jittered lattice at solid
    fraction ~0.45 with random velocities."""
    import tsubu
    n_side, spacing = (10, 10, 20), 2.1 * ref.R
    sim = ref.new_simulation(threads)
    sim.gravity = (0.0, 0.0, 0.0)
    x = _lattice(*n_side, spacing, seed=5)
    v = np.random.default_rng(6).normal(0.0, 0.05, x.shape)
    upper = np.array(n_side) * spacing
    v[:, 0] += 200.0 * (x[:, 2] - 0.5 * upper[2])
    sim.add_spheres(x, ref.R, ref.material(), velocities=v)
    sim.set_box((0.0, 0.0, 0.0), tuple(upper), periodic="xyz")
    sim.set_shear(200.0, flow="x", gradient="z")
    return sim


def _periodic_chute(threads):
    """A chute periodic along x and y, gravity tilted 25 degrees, on a layer of fixed grains:
    periodic ghosts with fixed spheres and gravity along a periodic axis."""
    import math
    n_side, spacing = (12, 8, 12), 2.05 * ref.R
    g = ref.G
    sim = ref.new_simulation(threads)
    sim.gravity = (g * math.sin(math.radians(25)), 0.0, -g * math.cos(math.radians(25)))
    x = _lattice(*n_side, spacing, seed=7)
    ids = sim.add_spheres(x, ref.R, ref.material())
    upper = np.array(n_side) * spacing
    sim.set_box((0.0, 0.0, 0.0), (upper[0], upper[1], 4.0 * upper[2]), periodic="xy")
    sim.fix_spheres(ids[x[:, 2] < spacing])
    return sim


def _mesh_floor(threads):
    """The lattice drop of 2,000 spheres onto a floor of 2 x 24 x 24 triangles (each a third of a
    sphere's diameter across, so a sphere rests on several), inside the four side planes: mesh
    contacts, their hidden edges and hand-overs."""
    n = 2000
    sim = ref.new_simulation(threads)
    x, v = ref.initial_state(n)
    sim.add_spheres(x, ref.R, ref.material(), velocities=v)
    lx, ly = ref.box(n)
    k = 24
    gx, gy = np.meshgrid(np.linspace(0.0, lx, k + 1), np.linspace(0.0, ly, k + 1), indexing="ij")
    vertices = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], 1)
    at = lambda i, j: i * (k + 1) + j  # noqa: E731
    faces = []
    for i in range(k):
        for j in range(k):
            faces += [(at(i, j), at(i + 1, j), at(i + 1, j + 1)), (at(i, j), at(i + 1, j + 1), at(i, j + 1))]
    sim.add_mesh(vertices, np.array(faces), ref.material())
    for p, nrm in (((0, 0, 0), (1, 0, 0)), ((lx, 0, 0), (-1, 0, 0)), ((0, 0, 0), (0, 1, 0)), ((0, ly, 0), (0, -1, 0))):
        sim.add_plane(p, nrm, ref.material())
    return sim


def _fast_gas(threads):
    """About 1,400 spheres flying at ~2 m/s and spinning at ~2,000 rad/s in a closed box without
    gravity, the default (frozen) slip rule: contacts whose normal turns by more than ~1/300 rad
    in one step, the rare lanes that the block evaluates twice (engine/block.hpp, Blocked::evaluate)."""
    import tsubu
    rng = np.random.default_rng(3)
    side = 0.05
    x = rng.uniform(1.5e-3, side - 1.5e-3, size=(2000, 3))
    keep = [0]
    for k in range(1, len(x)):
        if np.min(np.linalg.norm(x[keep] - x[k], axis=1)) > 2.2e-3:
            keep.append(k)
    x = x[keep]
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), threads=threads)
    mat = tsubu.Material(density=2500.0, kn=1e4, restitution=0.5, friction=0.5)
    sim.add_spheres(x, 1e-3, mat, velocities=rng.normal(0.0, 2.0, size=x.shape),
                    angular_velocities=rng.normal(0.0, 2000.0, size=x.shape))
    for k in range(3):
        normal = np.eye(3)[k]
        sim.add_plane(np.zeros(3), normal, mat)
        sim.add_plane(side * normal, -normal, mat)
    return sim


# name: (builder(threads) -> Simulation, steps)
SCENES = {
    "drop-1e5": (_drop(100_000), 2000),
    "dense-static": (_dense(), 20_000),
    "dense-shear": (_dense(0.05), 20_000),
    "rough-rolling": (_drop(10_000, roughness=10.0, rolling_friction=0.1, slip_rule="frozen"), 6000),
    "frictionless": (_drop(10_000, friction=0.0), 6000),
    "two-materials": (_two_materials, 6000),
    "literal-history": (_literal, 6000),
    "tilting-wall": (_tilting_wall, 6000),
    "lees-edwards": (_lees_edwards, 20_000),
    "periodic-chute": (_periodic_chute, 20_000),
    "mesh-floor": (_mesh_floor, 20_000),
    "fast-gas": (_fast_gas, 4000),
}


def fingerprint(sim, skip_energy=()) -> str:
    h = hashlib.sha256()
    for a in (sim.positions, sim.velocities, sim.angular_velocities, sim.forces, sim.torques):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    c = sim.contacts()
    for key in sorted(c):
        if key in ("element", "wall_point", "branch"):  # (derived, added later: hashes stay comparable)
            continue
        h.update(key.encode())
        h.update(np.ascontiguousarray(c[key]).tobytes())
    e = sim.energy()
    for key in sorted(set(e) - set(skip_energy)):
        h.update(f"{key}={float(e[key]).hex()}".encode())
    h.update(str(sim.step_count).encode())
    return h.hexdigest()


def run(scenes, threads_list, skip_energy=()):
    out = {}
    for name in scenes:
        make, steps = SCENES[name]
        for threads in threads_list:
            sim = make(threads)
            t0 = time.perf_counter()
            sim.run(steps=steps)
            seconds = time.perf_counter() - t0
            digest = fingerprint(sim, skip_energy)
            out[f"{name}/t{threads}"] = digest
            print(f"{name:16s} threads={threads}  {digest[:16]}  law={sim.law}  {steps} steps "
                  f"{seconds:6.2f} s  contacts={len(sim.contacts()['i'])}", flush=True)
    for name in scenes:
        digests = {out[f"{name}/t{t}"] for t in threads_list}
        if len(digests) > 1:
            print(f"MISMATCH between thread counts: {name}")
    return out


def compare(before_path, after_path) -> int:
    with open(before_path) as f:
        before = json.load(f)
    with open(after_path) as f:
        after = json.load(f)
    bad = 0
    for key in sorted(set(before) | set(after)):
        a, b = before.get(key), after.get(key)
        same = a == b
        bad += not same
        print(f"{key:24s} {'same' if same else 'DIFFERENT'}  {str(a)[:16]}  {str(b)[:16]}")
    print("all bit-identical" if bad == 0 else f"{bad} differ")
    return 1 if bad else 0


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="+", choices=sorted(SCENES), default=list(SCENES))
    p.add_argument("--threads", nargs="+", type=int, default=[1, 2])
    p.add_argument("--json", help="write the hashes to this file")
    p.add_argument("--skip-energy", nargs="+", default=[], metavar="TERM",
                   help="energy terms left out of the hash (e.g. dissipated, for a change to "
                        "how energy is booked)")
    p.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"),
                   help="compare two --json files instead of running")
    args = p.parse_args()
    if args.compare:
        return compare(*args.compare)
    out = run(args.scenes, args.threads, args.skip_energy)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1, sort_keys=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

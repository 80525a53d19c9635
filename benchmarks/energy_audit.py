#!/usr/bin/env python3
"""The energy audit on settled beds: how well the balance holds through long static holds, for
the matrix of scenes of issue 26 (false alarms on calm frictional beds).

Each scene pours glass beads (radius 1 mm unless stated) from a loose random packing into a
square box of five planes, runs `--settle` seconds, then changes something from outside (stops
every bead, or tilts gravity by 2 degrees) and holds for `--hold` seconds. It prints the drift of
kinetic + potential + elastic + dissipated over the hold (zero for an exact booking), beside the
elastic energy the contacts store and the energy booked as dissipated in the hold, and whether
the run's own audit raised. The audit raises when the balance grows by more than twice the
energy in motion and in the springs plus a third of the dissipation (docs/reliability.md).

Usage (from the repository root)::

    PYTHONPATH=python python benchmarks/energy_audit.py              # the whole matrix, 10 s holds
    PYTHONPATH=python python benchmarks/energy_audit.py --hold 2 --only base hertz
"""
import argparse
import math
import sys
import time

import numpy as np

import tsubu
from tsubu import fill

# name: (material keywords, scene keywords)
SCENES = {
    "base": ({}, {}),
    "rolling": ({"rolling_friction": 0.1}, {}),
    "box-1cm": ({}, {"box": 0.01, "count": 74}),
    "box-3cm": ({}, {"box": 0.03, "count": 1323}),
    "e-0.1": ({"restitution": 0.1}, {}),
    "e-0.9": ({"restitution": 0.9}, {}),
    "radius-0.5mm": ({}, {"radius": 5e-4, "box": 0.01}),
    "seed-1": ({}, {"seed": 1}),
    "seed-2": ({}, {"seed": 2}),
    "threads-2": ({}, {"threads": 2}),
    "tilt-2deg": ({}, {"change": "tilt"}),
    "mu-1.0": ({"friction": 1.0}, {}),
    "hertz": ({"youngs_modulus": 5e6, "poisson_ratio": 0.25}, {}),
    "hertz-rolling": ({"youngs_modulus": 5e6, "poisson_ratio": 0.25, "rolling_friction": 0.1}, {}),
    "frictionless": ({"friction": 0.0}, {}),
    "dt-over-5": ({}, {"dt_factor": 0.2}),
    "truncate": ({}, {"slip_rule": "truncate"}),
}


def balance(sim) -> float:
    e = sim.energy()
    return e["kinetic"] + e["gravitational"] + e["elastic"] + e["dissipated"]


def build(material_kw: dict, box=0.02, count=588, radius=1e-3, seed=0, threads=1,
          slip_rule="frozen", dt_factor=1.0, change="stop"):
    material = tsubu.Material(**material_kw)
    sim = tsubu.Simulation(seed=seed, threads=threads, slip_rule=slip_rule)
    packing = fill.random_packing(fill.Box((0, 0, 0), (box, box, 3 * box)), radius, count=count,
                                  seed=seed)
    sim.add_spheres(packing.positions, packing.radii, material)
    for point, normal in [((0, 0, 0), (0, 0, 1)), ((0, 0, 0), (1, 0, 0)), ((box, 0, 0), (-1, 0, 0)),
                          ((0, 0, 0), (0, 1, 0)), ((0, box, 0), (0, -1, 0))]:
        sim.add_plane(point, normal, material)
    sim.dt = dt_factor * sim.dt  # (the default: contact_duration() / 50)
    return sim, change


def measure(name: str, settle: float, hold: float) -> dict:
    material_kw, scene_kw = SCENES[name]
    sim, change = build(material_kw, **scene_kw)
    sim.run(time=settle)
    if change == "tilt":
        a = math.radians(2.0)
        sim.gravity = (9.81 * math.sin(a), 0.0, -9.81 * math.cos(a))
    else:
        sim.velocities = np.zeros((len(sim), 3))
        sim.angular_velocities = np.zeros((len(sim), 3))
    start, dissipated = balance(sim), sim.energy()["dissipated"]
    t0 = time.perf_counter()
    raised = ""
    try:
        sim.run(time=hold)
    except tsubu.InstabilityError as err:
        raised = f"raised at t = {sim.time:.3f} s"
        del err
    e = sim.energy()
    return {"name": name, "beads": len(sim), "law": sim.law, "drift": balance(sim) - start,
            "elastic": e["elastic"], "booked": e["dissipated"] - dissipated,
            "kinetic": e["kinetic"], "raised": raised, "held": sim.time - settle,
            "seconds": time.perf_counter() - t0}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--settle", type=float, default=0.2, help="seconds of pouring (default 0.2)")
    p.add_argument("--hold", type=float, default=10.0, help="seconds of hold (default 10)")
    p.add_argument("--only", nargs="+", choices=sorted(SCENES), default=list(SCENES))
    args = p.parse_args()
    print(f"tsubu {tsubu.__version__}: settle {args.settle} s, then hold {args.hold} s")
    print(f"{'scene':14s} {'beads':>5s} {'held s':>6s} {'drift J':>10s} {'elastic J':>10s} "
          f"{'drift/el':>9s} {'booked J':>10s} {'kinetic J':>10s}  audit")
    bad = 0
    for name in args.only:
        r = measure(name, args.settle, args.hold)
        bad += bool(r["raised"])
        print(f"{name:14s} {r['beads']:5d} {r['held']:6.2f} {r['drift']:10.2e} {r['elastic']:10.2e} "
              f"{r['drift'] / r['elastic']:9.2e} {r['booked']:10.2e} {r['kinetic']:10.2e}  "
              f"{r['raised'] or 'quiet'}   ({r['law']}, {r['seconds']:.0f} s)", flush=True)
    print("no false alarm" if bad == 0 else f"{bad} scene(s) raised")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

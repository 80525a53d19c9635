#!/usr/bin/env python3
"""Checkpoint cost: seconds to save and load, and bytes per sphere, for the reference drop (few
contacts yet) or the dense bed (about three contacts per sphere, with tangential history).

Usage (from the repository root)::

    python benchmarks/checkpoint_speed.py [--scene drop|dense] [--n 100000] [--steps 2000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

import tsubu
from reference_scene import build, build_dense_bed


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", choices=["drop", "dense"], default="drop")
    p.add_argument("--n", type=int, default=100_000, help="spheres of the drop (default 1e5)")
    p.add_argument("--steps", type=int, default=2000, help="steps run before saving")
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args()
    sim = build(args.n, threads=1) if args.scene == "drop" else build_dense_bed(threads=1)
    sim.run(steps=args.steps)
    contacts = len(sim.contacts()["i"])
    saves, loads = [], []
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "run.tsubu")
        for _ in range(args.repeat):
            start = time.perf_counter()
            sim.save(path)
            saves.append(time.perf_counter() - start)
            start = time.perf_counter()
            back = tsubu.Simulation.load(path)
            loads.append(time.perf_counter() - start)
        size = os.path.getsize(path)
    assert back.step_count == sim.step_count
    print(f"{args.scene}: N = {sim.size}, {contacts} contacts, step {sim.step_count}")
    print(f"file {size / 1e6:.2f} MB = {size / sim.size:.0f} bytes per sphere")
    print(f"save {statistics.median(saves):.3f} s, load {statistics.median(loads):.3f} s "
          f"(medians of {args.repeat}; load includes the neighbour-list rebuild)")


if __name__ == "__main__":
    main()

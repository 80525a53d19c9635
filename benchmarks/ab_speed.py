#!/usr/bin/env python3
"""Two builds of tsubu side by side: is a change to the core as fast as the code before it?

Each round runs every scene once with build A and once with build B, each in a fresh process,
alternating which goes first, and records the ratio B/A of their particle-steps per second. The
figure to quote is the median of the per-round ratios (absolute rates on a shared machine drift
between rounds; ratios taken back to back much less). A build is a Python interpreter that can
import tsubu (a virtual environment's ``bin/python``), optionally with a PYTHONPATH.

Scenes (``reference_scene``): the reference drop at N = 1e5 (2,000 steps, the last 1,900 timed) and
at N = 1e6 (200 steps, the last 150 timed), and the two dense beds (5,000 steps, the last 4,000
timed), on one thread unless ``--threads`` says otherwise; on request (``--scenes tiled-bed``) the
dense bed tiled 4 x 4 with its floor sliding (N = 160,000, 1,000 steps, the last 950 timed; the
scene of ``scaling.py``), the Lees–Edwards cell of ``shear_lammps.py`` (``shear-cell``, N = 10,000,
3,000 steps from its packing, the last 2,500 timed) and the hopper of ``hopper_liggghts.py``
(``hopper``, N = 20,000, 3,000 steps from its packing, the last 2,900 timed, before any grain
leaves); those two take their packings from the scripts' caches, or make them (minutes).

Usage (from the repository root)::

    python benchmarks/ab_speed.py --a /path/to/old/venv/bin/python --b /path/to/new/venv/bin/python
    python benchmarks/ab_speed.py --a OLD_PY --b NEW_PY --b-path python --scenes dense-shear --rounds 7
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))

# name: (builder expression, total steps, untimed warm-up steps)
SCENES = {
    "drop-1e5": ("ref.build(100_000, threads=T)", 2000, 100),
    "drop-1e6": ("ref.build(1_000_000, threads=T)", 200, 50),
    "dense-static": ("ref.build_dense_bed(threads=T)", 5000, 1000),
    "dense-shear": ("ref.build_dense_bed(threads=T, floor_velocity=0.05)", 5000, 1000),
    "tiled-bed": ("ref.build_tiled_bed(4, threads=T)", 1000, 50),
    # (the packings of shear_lammps.py and hopper_liggghts.py, made and cached by those scripts)
    "shear-cell": ("(lambda m: m.build_tsubu(m.packing(10000, _tmp('tsubu-shear-lammps'), log=_quiet), 15.0, T))"
                   "(__import__('shear_lammps'))", 3000, 500),
    "hopper": ("(lambda m: m.build_tsubu(m.packing(20000, _tmp('tsubu-hopper-liggghts'), log=_quiet), T))"
               "(__import__('hopper_liggghts'))", 3000, 100),
}

CHILD = """
import sys, time, json
sys.path.insert(0, {here!r})
import reference_scene as ref
_tmp = lambda name: __import__('os').path.join(__import__('tempfile').gettempdir(), name)
_quiet = lambda *args: None
T = {threads}
sim = {build}
sim.run(steps={warmup})
t0 = time.perf_counter()
sim.run(steps={timed})
dt = time.perf_counter() - t0
print(json.dumps({{"rate": sim.size * {timed} / dt, "law": sim.law}}))
"""


def one_run(python: str, path: str | None, scene: str, threads: int) -> float:
    build, steps, warmup = SCENES[scene]
    code = CHILD.format(here=HERE, threads=threads, build=build, warmup=warmup, timed=steps - warmup)
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    env.pop("PYTHONPATH", None)
    if path:
        env["PYTHONPATH"] = path
    out = subprocess.run([python, "-c", code], env=env, capture_output=True, text=True, cwd="/")
    if out.returncode != 0:
        raise RuntimeError(f"{python} failed on {scene}:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])["rate"]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--a", required=True, help="python of build A (before)")
    p.add_argument("--b", required=True, help="python of build B (after)")
    p.add_argument("--a-path", help="PYTHONPATH for build A")
    p.add_argument("--b-path", help="PYTHONPATH for build B (relative paths: from the current directory)")
    p.add_argument("--scenes", nargs="+", choices=sorted(SCENES),
                   default=["drop-1e5", "dense-static", "dense-shear", "drop-1e6"])
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", help="write every run to this file")
    args = p.parse_args()
    paths = {k: (os.path.abspath(v) if v else None) for k, v in (("a", args.a_path), ("b", args.b_path))}
    runs = {s: {"a": [], "b": [], "ratio": []} for s in args.scenes}
    for r in range(args.rounds):
        for scene in args.scenes:
            order = ("a", "b") if r % 2 == 0 else ("b", "a")
            rate = {}
            for which in order:
                rate[which] = one_run(getattr(args, which), paths[which], scene, args.threads)
            runs[scene]["a"].append(rate["a"])
            runs[scene]["b"].append(rate["b"])
            runs[scene]["ratio"].append(rate["b"] / rate["a"])
            print(f"round {r + 1} {scene:13s} A {rate['a'] / 1e6:7.2f} M  B {rate['b'] / 1e6:7.2f} M"
                  f"  B/A {rate['b'] / rate['a']:.3f}", flush=True)
    print(f"\n{'scene':13s} {'A median':>10s} {'B median':>10s} {'B/A median':>11s} {'range':>15s}"
          f"   ({args.rounds} rounds, {args.threads} thread(s), particle-steps/s)")
    for scene, d in runs.items():
        print(f"{scene:13s} {statistics.median(d['a']) / 1e6:9.2f}M {statistics.median(d['b']) / 1e6:9.2f}M "
              f"{statistics.median(d['ratio']):11.3f} {min(d['ratio']):7.3f}-{max(d['ratio']):.3f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(runs, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

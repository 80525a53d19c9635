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

``--lockstep`` measures another way, for changes of a few per cent on a machine whose speed drifts
from second to second (a shared host): each round starts one process per build, both pinned to
the same core, builds the scene in each and warms it up; then the two take turns, ``--chunk`` steps
at a time (``--turns`` turns each, alternating which goes first), so that both see the same spells
of the host. Each round's figure is B's speed over A's, from their summed times over all turns;
the quartiles of the per-turn ratios show the spread within a round. On the 2-core machines the
dense beds resolve 1 % this way (quartiles within +-1 %), where fresh-process rounds scatter by
+-5 %; a scene whose arrays do not stay in cache (the hopper, the drops) stays noisy either way.

Usage (from the repository root)::

    python benchmarks/ab_speed.py --a /path/to/old/venv/bin/python --b /path/to/new/venv/bin/python
    python benchmarks/ab_speed.py --a OLD_PY --b NEW_PY --b-path python --scenes dense-shear --rounds 7
    python benchmarks/ab_speed.py --a PY --a-path /tmp/base/python --b PY --b-path python \
        --scenes dense-shear dense-static --lockstep --rounds 3
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


# The lockstep child: builds and warms up its scene, then runs the steps it is told, one line a turn.
LOCK_CHILD = """
import os, sys, time
sys.path.insert(0, {here!r})
import reference_scene as ref
_tmp = lambda name: os.path.join(__import__('tempfile').gettempdir(), name)
_quiet = lambda *args: None
os.sched_setaffinity(0, {{{cpu}}})
T = {threads}
sim = {build}
sim.run(steps={warmup})
print("ready", flush=True)
for line in sys.stdin:
    t0 = time.perf_counter()
    sim.run(steps=int(line))
    print(time.perf_counter() - t0, sim.size, flush=True)
"""


def lockstep_round(args, paths, scene: str) -> dict:
    """One lockstep round of `scene`: per-turn times of A and B, particle counts at each turn."""
    build, _, warmup = SCENES[scene]
    cpu = max(os.sched_getaffinity(0))
    code = LOCK_CHILD.format(here=HERE, threads=args.threads, build=build, warmup=warmup, cpu=cpu)
    procs = {}
    times = {"a": [], "b": []}
    try:
        # One child at a time builds the scene: a packing that is not cached yet is made once
        # (two children writing the same cache file at once would race).
        for which in ("a", "b"):
            env = dict(os.environ, OMP_NUM_THREADS=str(args.threads))
            env.pop("PYTHONPATH", None)
            if paths[which]:
                env["PYTHONPATH"] = paths[which]
            procs[which] = subprocess.Popen([getattr(args, which), "-c", code], env=env, cwd="/", text=True,
                                            stdin=subprocess.PIPE, stdout=subprocess.PIPE)
            if procs[which].stdout.readline().strip() != "ready":
                raise RuntimeError(f"a lockstep child failed to build {scene}")
        for turn in range(args.turns):
            for which in (("a", "b") if turn % 2 == 0 else ("b", "a")):
                p = procs[which]
                p.stdin.write(f"{args.chunk}\n")
                p.stdin.flush()
                seconds, size = p.stdout.readline().split()
                times[which].append((float(seconds), int(size)))
    finally:
        for p in procs.values():
            p.stdin.close()
            p.wait()
    rate = {w: sum(n * args.chunk for _, n in t) / sum(s for s, _ in t) for w, t in times.items()}
    turns = [a[0] / b[0] for a, b in zip(times["a"], times["b"])]
    return {"a": rate["a"], "b": rate["b"], "ratio": rate["b"] / rate["a"],
            "turn_quartiles": statistics.quantiles(turns)}


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
    p.add_argument("--lockstep", action="store_true",
                   help="both builds in long-lived processes on one core, taking turns (see above)")
    p.add_argument("--turns", type=int, default=12, help="lockstep: turns per build and round")
    p.add_argument("--chunk", type=int, default=500, help="lockstep: steps per turn")
    args = p.parse_args()
    paths = {k: (os.path.abspath(v) if v else None) for k, v in (("a", args.a_path), ("b", args.b_path))}
    runs = {s: {"a": [], "b": [], "ratio": []} for s in args.scenes}
    for r in range(args.rounds):
        for scene in args.scenes:
            if args.lockstep:
                got = lockstep_round(args, paths, scene)
                for key in ("a", "b", "ratio"):
                    runs[scene][key].append(got[key])
                q1, _, q3 = got["turn_quartiles"]
                print(f"round {r + 1} {scene:13s} A {got['a'] / 1e6:7.2f} M  B {got['b'] / 1e6:7.2f} M"
                      f"  B/A {got['ratio']:.3f}  (turns' quartiles {q1:.3f}-{q3:.3f})", flush=True)
                continue
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
          f"   ({args.rounds} {'lockstep ' if args.lockstep else ''}rounds, {args.threads} thread(s),"
          " particle-steps/s)")
    for scene, d in runs.items():
        print(f"{scene:13s} {statistics.median(d['a']) / 1e6:9.2f}M {statistics.median(d['b']) / 1e6:9.2f}M "
              f"{statistics.median(d['ratio']):11.3f} {min(d['ratio']):7.3f}-{max(d['ratio']):.3f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(runs, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

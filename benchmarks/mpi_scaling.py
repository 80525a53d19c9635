#!/usr/bin/env python3
"""MPI scaling of ``tsubu.parallel`` (issue 30): one scene cut over R ranks, one thread each.

What it measures: for each scene and each rank count R (``--ranks``, default 1 2), the rate of
``Decomposed.run`` in particle-steps/s (N x timed steps / wall seconds), each run a fresh
``mpiexec -n R python mpi_scaling.py --worker ...`` (the ``mpiexec`` beside ``sys.executable``,
OMP_NUM_THREADS=1 and ``threads=1`` on every rank; R = 1 also goes through mpiexec and
``decompose``, so that both sides pay the same per-step exchange callback). Every rank builds the
same scene, calls ``decompose(sim)``, takes ``--warmup`` untimed steps, then rank 0 times
``d.run(steps)`` between two barriers (wall clock). Repetitions alternate the order of R; the
table gives the median rate per R, the ratio rate(R) / rate(first R) of each repetition and its
median (the figure to quote), and, from each run:

* ``redist``: ``d.redistributions`` over warm-up + timed run and the seconds they took inside
  ``run`` (and, separately, the cost of one explicit ``d.redistribute()`` after the timed run,
  outside the timing, so that a redistribution's price is visible even when none was due);
* ``held/owned``: spheres each rank holds (``d.simulation.size``: own + halo copies) and owns
  (``len(d._owned)``) after the timed run, and the halo overhead sum(held) / N - 1;
* ``exch``: seconds each rank spent in the per-step exchange callback (packing, MPI messages,
  the allreduce of the move bound, so also waiting for the slower rank), ``decomp``: seconds of
  ``decompose``;
* ``other``: CPU the rest of the machine used during each timed run (cores, from /proc/stat less
  the ranks' own CPU): on a 2-core machine R = 2 needs it near 0, so compare quiet repetitions;
* ``identical``: rank 0 saves the positions of ``d.gather()`` after the timed run; the parent
  compares them byte for byte over every run of a scene (every R, every repetition).

Scenes (``reference_scene``; SI units, the shared benchmark's linear law of SCENE.md):

* ``drop``: the reference lattice drop (``rs.build``) with ``--n`` spheres (default 1e5), its
  first ``--warmup`` + ``--steps`` steps (free fall: few contacts, so the per-step exchange
  weighs most here);
* ``bed``: the settled dense bed tiled K x K in x and y (``rs.build_tiled_bed``, the scene of
  shared/bench/device/README.md and ``scaling.py``), floor sliding at 0.05 m/s; K = ``--tiles``,
  by default the K whose N = 10,000 K^2 is nearest ``--n`` (1e5: K = 3, N = 90,000; the
  README's 4 x 4 = 160,000 with ``--tiles 4``).

Usage (from the repository root; about 1.5-2 minutes with the defaults on 2 cores)::

    PYTHONPATH=python python benchmarks/mpi_scaling.py                       # N = 1e5, 2,000 steps, 3 repeats
    PYTHONPATH=python python benchmarks/mpi_scaling.py --n 20000 --steps 100 --repeats 1   # quick
    PYTHONPATH=python python benchmarks/mpi_scaling.py --scenes bed --tiles 4 --ranks 1 2 4
    PYTHONPATH=python python benchmarks/mpi_scaling.py --json mpi_scaling.json

Needs mpi4py and an MPI library (``pip install "tsubu[mpi]"``: mpi4py and the mpich wheel).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from bench_common import cpu_seconds, machine, parse_size, run_result, system_busy_s  # noqa: E402


def tiles_for(n: int) -> int:
    """The K of the K x K tiled bed (10,000 K^2 spheres) nearest n."""
    return max(1, int(round(math.sqrt(n / 10000.0))))


def build(scene: str, n: int, tiles: int):
    import reference_scene as rs
    if scene == "bed":
        return rs.build_tiled_bed(tiles, threads=1)
    return rs.build(n, threads=1)


# ---------------------------------------------------------------- one run (every rank)
def worker(args) -> None:
    from mpi4py import MPI
    import numpy as np
    import tsubu.parallel

    comm = MPI.COMM_WORLD
    rank = comm.Get_rank()
    sim = build(args.scene, args.n, args.tiles)
    n = sim.size
    comm.Barrier()
    t = time.perf_counter()
    d = tsubu.parallel.decompose(sim)
    decomp_s = time.perf_counter() - t

    # Time the per-step exchange and the redistributions run() makes (instance attributes: run()
    # looks both up on the object; the wrapped methods are called unchanged).
    spent = {"exch": 0.0, "exch_n": 0, "redist": 0.0}
    exchange, redistribute = d._exchange, d.redistribute

    def timed_exchange(*speeds):
        t0 = time.perf_counter()
        try:
            return exchange(*speeds)
        finally:
            spent["exch"] += time.perf_counter() - t0
            spent["exch_n"] += 1

    def timed_redistribute(balance=False):
        t0 = time.perf_counter()
        try:
            return redistribute(balance)
        finally:
            spent["redist"] += time.perf_counter() - t0

    d._exchange, d.redistribute = timed_exchange, timed_redistribute

    d.run(args.warmup)
    redist_warmup = d.redistributions
    spent.update(exch=0.0, exch_n=0)
    comm.Barrier()
    busy0, cpu0, t0 = system_busy_s(), cpu_seconds(), time.perf_counter()
    d.run(args.steps)
    comm.Barrier()
    t1, cpu1, busy1 = time.perf_counter(), cpu_seconds(), system_busy_s()
    wall = t1 - t0

    mine = {"held": int(d.simulation.size), "owned": int(len(d._owned)), "exch_s": spent["exch"],
            "exch_calls": spent["exch_n"], "redist_s_in_run": spent["redist"], "cpu_s": cpu1 - cpu0,
            "decompose_s": decomp_s}
    per_rank = comm.gather(mine, root=0)
    # The positions after the timed run, in id order: from d.gather(); also straight from the
    # owners (ids and positions of each rank's own spheres), which serves when gather() cannot
    # (a Python package ahead of its compiled extension) and checks gather() when it can.
    core = d.simulation._core
    ids = core.get_ids()
    own = np.isin(ids, d._owned, assume_unique=True)
    parts = comm.gather((ids[own], core.positions()[own]), root=0)
    try:
        whole = d.gather()
        gather_error = None
    except Exception as e:  # noqa: BLE001 - reported, the owners' positions used instead
        whole, gather_error = None, f"{type(e).__name__}: {e}"
    if rank == 0:
        oid = np.concatenate([p[0] for p in parts])
        ox = np.concatenate([p[1] for p in parts]).reshape(-1, 3)[np.argsort(oid, kind="stable")]
        if whole is not None:
            x = np.ascontiguousarray(whole.positions, dtype=np.float64)
            gather_agrees = x.shape == ox.shape and x.tobytes() == ox.tobytes()
            del whole
        else:
            x, gather_agrees = ox, None
        np.save(args.out, x)

    # One explicit redistribution, outside the timing: what one costs.
    d.redistribute = redistribute
    comm.Barrier()
    t = time.perf_counter()
    d.redistribute()
    comm.Barrier()
    explicit_s = time.perf_counter() - t

    if rank == 0:
        cpu_ranks = sum(p["cpu_s"] for p in per_rank)
        out = {"scene": args.scene, "n": n, "ranks": comm.Get_size(), "shape": list(d.shape),
               "steps": args.steps, "warmup": args.warmup, "wall_s": wall, "rate": n * args.steps / wall,
               "redistributions": d.redistributions - 1, "redistributions_warmup": redist_warmup,
               "redistribute_explicit_s": explicit_s, "reach": d.reach, "margin": d.margin,
               "per_rank": per_rank, "gather_error": gather_error, "gather_agrees": gather_agrees,
               "other": None if busy0 is None else max(0.0, (busy1 - busy0) - cpu_ranks) / wall}
        print("RESULT " + json.dumps(out), flush=True)


# ---------------------------------------------------------------- the parent
def mpiexec_path() -> str:
    return os.path.join(os.path.dirname(sys.executable), "mpiexec")


def one_run(args, scene: str, ranks: int, out: str) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS="1")
    cmd = [mpiexec_path(), "-n", str(ranks), sys.executable, os.path.abspath(__file__), "--worker",
           "--scene", scene, "--n", str(args.n), "--tiles", str(args.tiles), "--steps", str(args.steps),
           "--warmup", str(args.warmup), "--out", out]
    return run_result(cmd, env)


def same_bits(a: str, b: str) -> bool:
    import numpy as np
    x, y = np.load(a), np.load(b)
    return x.shape == y.shape and x.tobytes() == y.tobytes()


def report(scene: str, runs: dict, ranks: list, identical: bool, n_runs: int) -> dict:
    base = ranks[0]
    first = runs[base][0]
    print(f"\n== {scene}: N = {first['n']:,}, {first['steps']} timed steps after {first['warmup']} warm-up, "
          f"one thread per rank, reach {first['reach'] * 1e3:.3g} mm (margin {first['margin'] * 1e3:.3g} mm)")
    head = (f"{'R':>2} {'grid':>7} {'median Mp-s/s':>13} {'min-max':>13} {'R/R%d each rep' % base:>18} "
            f"{'median':>6} {'redist':>6} {'redist s':>8} {'1 redist s':>10} {'decomp s':>8} {'other each rep':>14}")
    print(head)
    print("-" * len(head))
    summary = {}
    for r in ranks:
        rates = [x["rate"] for x in runs[r]]
        ratios = [a["rate"] / b["rate"] for a, b in zip(runs[r], runs[base])]
        red = [x["redistributions"] for x in runs[r]]
        red_s = [max(p["redist_s_in_run"] for p in x["per_rank"]) for x in runs[r]]
        expl = [x["redistribute_explicit_s"] for x in runs[r]]
        dec = [max(p["decompose_s"] for p in x["per_rank"]) for x in runs[r]]
        other = [x["other"] for x in runs[r] if x["other"] is not None]
        each = " ".join(f"{q:.3f}" for q in ratios)
        print(f"{r:>2} {'x'.join(map(str, runs[r][0]['shape'])):>7} {statistics.median(rates) / 1e6:>13.2f} "
              f"{min(rates) / 1e6:>6.2f}-{max(rates) / 1e6:<6.2f} {each:>18} {statistics.median(ratios):>6.3f} "
              f"{'/'.join(map(str, sorted(set(red)))):>6} {statistics.median(red_s):>8.3f} "
              f"{statistics.median(expl):>10.3f} {statistics.median(dec):>8.3f} "
              f"{' '.join(f'{o:.2f}' for o in other):>14}")
        summary[r] = {"median_rate": statistics.median(rates), "rates": rates, "ratios": ratios,
                      "median_ratio": statistics.median(ratios)}
    print("per rank (last repetition): held = own + halo copies, owned; exchange callback seconds "
          "(timed run) / share of the timed wall time")
    for r in ranks:
        x = runs[r][-1]
        held = [p["held"] for p in x["per_rank"]]
        owned = [p["owned"] for p in x["per_rank"]]
        exch = [p["exch_s"] for p in x["per_rank"]]
        print(f"  R={r}: held {held}  owned {owned}  halo overhead {sum(held) / x['n'] - 1:+.1%}  "
              f"exch s {[round(e, 4) for e in exch]} in {x['per_rank'][0]['exch_calls']} calls ({max(exch) / x['wall_s']:.1%} of {x['wall_s']:.2f} s)")
    print(f"positions after the timed run bit-identical over all {n_runs} runs (every R, every repetition): "
          f"{'yes' if identical else 'NO'}")
    every = [x for r in ranks for x in runs[r]]
    errors = sorted({x["gather_error"] for x in every if x["gather_error"]})
    agree = [x["gather_agrees"] for x in every if x["gather_agrees"] is not None]
    if agree:
        print(f"d.gather() positions = the owners' positions, bit for bit: {sum(agree)}/{len(agree)} runs")
    if errors:
        print(f"d.gather() failed in {len(every) - len(agree)} runs, the owners' positions compared instead: "
              + "; ".join(errors))
    return {"runs": {str(r): runs[r] for r in ranks}, "summary": {str(r): s for r, s in summary.items()},
            "identical": identical}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["drop", "bed"], choices=["drop", "bed"])
    ap.add_argument("--n", type=parse_size, default=100000, help="drop spheres (default 1e5); also picks the bed's tiles")
    ap.add_argument("--tiles", type=int, default=None, help="bed tiles per side (default: N = 10,000 K^2 nearest --n)")
    ap.add_argument("--steps", type=int, default=2000, help="timed steps (default 2,000)")
    ap.add_argument("--warmup", type=int, default=50, help="untimed steps after decompose (default 50)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--ranks", nargs="+", type=int, default=[1, 2])
    ap.add_argument("--json", default=None, help="write every run's figures here")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--scene", default="drop", help=argparse.SUPPRESS)
    ap.add_argument("--out", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.tiles is None:
        args.tiles = tiles_for(args.n)
    if args.worker:
        worker(args)
        return 0

    if not os.path.exists(mpiexec_path()):
        print(f"no mpiexec beside {sys.executable} ({mpiexec_path()})", file=sys.stderr)
        return 2
    m = machine()
    print(f"machine: {m['cpu']}, {m['usable_cpus']} usable CPUs, load {m['loadavg']}; python {m['python']}")
    print(f"mpiexec: {mpiexec_path()}; ranks {args.ranks}, {args.repeats} repetitions (R order alternating)")
    results, ok = {}, True
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="tsubu-mpi-scaling-") as tmp:
        for scene in args.scenes:
            runs = {r: [] for r in args.ranks}
            files = []
            for rep in range(args.repeats):
                order = args.ranks if rep % 2 == 0 else list(reversed(args.ranks))
                for r in order:
                    out = os.path.join(tmp, f"{scene}_R{r}_{rep}.npy")
                    x = one_run(args, scene, r, out)
                    runs[r].append(x)
                    files.append(out)
                    held = [p["held"] for p in x["per_rank"]]
                    print(f"  {scene} rep {rep + 1} R={r}: {x['rate'] / 1e6:.2f} M particle-steps/s "
                          f"({x['wall_s']:.2f} s), held {held}, redistributions {x['redistributions']}",
                          flush=True)
            identical = all(same_bits(files[0], f) for f in files[1:])
            ok &= identical
            results[scene] = (runs, identical, len(files))
    print(f"\n(total {time.perf_counter() - t_start:.0f} s)")
    out = {"machine": m, "args": {k: v for k, v in vars(args).items() if k not in ("worker", "scene", "out")},
           "scenes": {}}
    for scene, (runs, identical, n_runs) in results.items():
        out["scenes"][scene] = report(scene, runs, args.ranks, identical, n_runs)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

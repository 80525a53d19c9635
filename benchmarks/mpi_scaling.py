#!/usr/bin/env python3
"""MPI scaling of ``tsubu.parallel`` (issue 30): one scene cut over R ranks of T threads each
(one thread unless ``--ranks`` says ``RxT``), optionally side by side with LAMMPS on R x T ranks.

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
    # a 16-core machine: strong and weak scaling against LAMMPS, ranks x threads
    PYTHONPATH=python python benchmarks/mpi_scaling.py --scenes bed --tiles 4 --ranks 1 2 4 8 16 \
        --lammps lmp --mpiexec-args "-bind-to core" --json strong.json
    PYTHONPATH=python python benchmarks/mpi_scaling.py --scenes bed --weak --ranks 1 2 4 8 16 --lammps lmp
    PYTHONPATH=python python benchmarks/mpi_scaling.py --scenes bed --tiles 4 --ranks 16 4x4 2x8 1x16
    # the figure of docs/benchmarks.md from saved runs
    PYTHONPATH=python python benchmarks/mpi_scaling.py --plot out.png --replot "lend 2=benchmarks/results/mpi16_strong.json"

With ``--weak`` the bed holds 10,000 spheres a core (R x T cores: the bed tiled a x b times,
a b = R T) and the efficiency column is the rate a core against the first count's.

Needs mpi4py and an MPI library (``pip install "tsubu[mpi]"``: mpi4py and the mpich wheel).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
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


def tiles_for_cores(cores: int) -> tuple:
    """Weak scaling: the bed tiled a x b times, a b = cores (10,000 spheres a core), as square as
    the count allows (2: 2 x 1, 8: 4 x 2, 16: 4 x 4)."""
    b = max(d for d in range(1, int(math.isqrt(cores)) + 1) if cores % d == 0)
    return (cores // b, b)


def parse_tiles(s: str) -> tuple:
    """'4' -> (4, 4); '4,2' -> (4, 2)."""
    parts = [int(v) for v in str(s).split(",")]
    return (parts[0], parts[0]) if len(parts) == 1 else (parts[0], parts[1])


def parse_config(s: str) -> tuple:
    """A --ranks entry: 'R' (one thread a rank) or 'RxT' (T threads a rank) -> (R, T)."""
    try:
        r, _, t = s.lower().partition("x")
        r, t = int(r), int(t or 1)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--ranks entries are R or RxT (e.g. 4 or 4x2), got {s!r}")
    if r < 1 or t < 1:
        raise argparse.ArgumentTypeError(f"--ranks entries need R, T >= 1, got {s!r}")
    return (r, t)


def label(cfg: tuple) -> str:
    return f"{cfg[0]}x{cfg[1]}" if cfg[1] > 1 else str(cfg[0])


def build(scene: str, n: int, tiles: tuple, threads: int = 1):
    import reference_scene as rs
    if scene == "bed":
        return rs.build_tiled_bed(tiles, threads=threads)
    return rs.build(n, threads=threads)


# ---------------------------------------------------------------- one run (every rank)
def worker(args) -> None:
    from mpi4py import MPI
    import numpy as np
    import tsubu.parallel

    comm = MPI.COMM_WORLD
    rank = comm.Get_rank()
    sim = build(args.scene, args.n, parse_tiles(args.tiles), args.threads)
    n = sim.size
    comm.Barrier()
    t = time.perf_counter()
    d = tsubu.parallel.decompose(sim, margin=args.margin)
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
        out = {"scene": args.scene, "n": n, "ranks": comm.Get_size(), "threads": args.threads,
               "tiles": list(parse_tiles(args.tiles)), "shape": list(d.shape),
               "steps": args.steps, "warmup": args.warmup, "wall_s": wall, "rate": n * args.steps / wall,
               "redistributions": d.redistributions - 1, "redistributions_warmup": redist_warmup,
               "redistribute_explicit_s": explicit_s, "reach": d.reach, "margin": d.margin,
               "per_rank": per_rank, "gather_error": gather_error, "gather_agrees": gather_agrees,
               "other": None if busy0 is None else max(0.0, (busy1 - busy0) - cpu_ranks) / wall}
        print("RESULT " + json.dumps(out), flush=True)


# ---------------------------------------------------------------- the parent
def mpiexec_path() -> str:
    return os.path.join(os.path.dirname(sys.executable), "mpiexec")


def one_run(args, scene: str, cfg: tuple, tiles: tuple, out: str) -> dict:
    ranks, threads = cfg
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    cmd = ([mpiexec_path(), "-n", str(ranks)] + args.mpiexec_args.split()
           + [sys.executable, os.path.abspath(__file__), "--worker", "--threads", str(threads),
              "--scene", scene, "--n", str(args.n), "--tiles", f"{tiles[0]},{tiles[1]}",
              "--steps", str(args.steps), "--warmup", str(args.warmup), "--out", out]
           + ([] if args.margin is None else ["--margin", repr(args.margin)]))
    return run_result(cmd, env)


_LAMMPS_DATA = {}  # tiles -> (data file, N): each bed written once a run of this script


def one_lammps(args, tiles: tuple, cores: int, work: str) -> dict:
    """The same bed in LAMMPS on ``cores`` MPI ranks (scaling.py's deck and log parsing)."""
    import scaling
    if tiles not in _LAMMPS_DATA:
        data = os.path.join(work, f"bed_{tiles[0]}x{tiles[1]}.lmp")
        _LAMMPS_DATA[tiles] = (data, scaling.write_bed_data(tiles, data))
    data, n = _LAMMPS_DATA[tiles]
    walls = scaling.lammps_walls(args.lammps, "auto")
    largs = argparse.Namespace(lammps=args.lammps, bed_steps=args.warmup + args.steps, mpiexec=mpiexec_path(),
                               mpiexec_args=args.mpiexec_args, mpiexec_always=True)
    sub = os.path.join(work, f"lammps_{tiles[0]}x{tiles[1]}_{cores}")
    os.makedirs(sub, exist_ok=True)
    return scaling.run_lammps(largs, data, n, cores, walls, sub)


def same_bits(a: str, b: str) -> bool:
    import numpy as np
    x, y = np.load(a), np.load(b)
    return x.shape == y.shape and x.tobytes() == y.tobytes()


def report(scene: str, runs: dict, configs: list, identical: bool, n_runs: int, lammps: dict, weak: bool) -> dict:
    base = configs[0]
    c0 = base[0] * base[1]
    first = runs[base][0]
    kind = "weak scaling, 10,000 spheres a core" if weak else f"N = {first['n']:,}"
    print(f"\n== {scene}: {kind}, {first['steps']} timed steps after {first['warmup']} warm-up, "
          f"reach {first['reach'] * 1e3:.3g} mm (margin {first['margin'] * 1e3:.3g} mm)")
    print("R x T: ranks x threads a rank; speed-up: rate / rate(first), per repetition, median; "
          "eff.: speed-up x cores(first) / cores" + (" (weak: the rate a core against the first's)" if weak else ""))
    head = (f"{'RxT':>5} {'N':>8} {'grid':>7} {'median Mp-s/s':>13} {'min-max':>13} {'speed-up':>8} {'eff.':>5} "
            f"{'redist':>6} {'redist s':>8} {'decomp s':>8} {'exch %':>6} {'other':>12}")
    if lammps:
        head += f" | {'LAMMPS M':>8} {'L x':>5} {'L eff.':>6} {'tsubu/L':>7}"
    print(head)
    print("-" * len(head))
    summary = {}
    lbase = lammps.get(c0) if lammps else None
    for cfg in configs:
        rr = runs[cfg]
        cores = cfg[0] * cfg[1]
        rates = [x["rate"] for x in rr]
        ratios = [a["rate"] / b["rate"] for a, b in zip(rr, runs[base])]
        sp = statistics.median(ratios)
        red = [x["redistributions"] for x in rr]
        red_s = [max(p["redist_s_in_run"] for p in x["per_rank"]) for x in rr]
        dec = [max(p["decompose_s"] for p in x["per_rank"]) for x in rr]
        exch = [max(p["exch_s"] for p in x["per_rank"]) / x["wall_s"] for x in rr]
        other = [x["other"] for x in rr if x["other"] is not None]
        line = (f"{label(cfg):>5} {rr[0]['n']:>8} {'x'.join(map(str, rr[0]['shape'])):>7} "
                f"{statistics.median(rates) / 1e6:>13.2f} {min(rates) / 1e6:>6.2f}-{max(rates) / 1e6:<6.2f} "
                f"{sp:>7.2f}x {sp * c0 / cores:>5.2f} {'/'.join(map(str, sorted(set(red)))):>6} "
                f"{statistics.median(red_s):>8.3f} {statistics.median(dec):>8.3f} "
                f"{100 * statistics.median(exch):>5.1f}% {' '.join(f'{o:.2f}' for o in other):>12}")
        row = {"ranks": cfg[0], "threads": cfg[1], "n": rr[0]["n"], "median_rate": statistics.median(rates),
               "rates": rates, "ratios": ratios, "median_ratio": sp, "efficiency": sp * c0 / cores,
               "exchange_share": statistics.median(exch)}
        if lammps and cores in lammps:
            lr = lammps[cores]
            lrate = statistics.median([x["rate"] for x in lr])
            lx = statistics.median([a["rate"] / b["rate"] for a, b in zip(lr, lbase)]) if lbase else float("nan")
            vs = statistics.median([a["rate"] / b["rate"] for a, b in zip(rr, lr)])
            line += f" | {lrate / 1e6:>8.2f} {lx:>4.2f}x {lx * c0 / cores:>6.2f} {vs:>6.2f}x"
            row.update(lammps_rate=lrate, lammps_speedup=lx, lammps_rates=[x["rate"] for x in lr], ratio_vs_lammps=vs)
        print(line)
        summary[label(cfg)] = row
    print("per rank (last repetition): held = own + halo copies; owned; exchange callback seconds")
    for cfg in configs:
        x = runs[cfg][-1]
        held = [p["held"] for p in x["per_rank"]]
        owned = [p["owned"] for p in x["per_rank"]]
        exch = [p["exch_s"] for p in x["per_rank"]]
        show = (lambda v: v if len(v) <= 4 else f"{min(v)}..{max(v)}")
        print(f"  {label(cfg)}: held {show(held)}  owned {show(owned)}  halo overhead {sum(held) / x['n'] - 1:+.1%}  "
              f"exch s {show([round(e, 4) for e in exch])} in {x['per_rank'][0]['exch_calls']} calls "
              f"({max(exch) / x['wall_s']:.1%} of {x['wall_s']:.2f} s)")
    print(f"positions after the timed run bit-identical over all {n_runs} runs of the same N "
          f"(every R x T, every repetition): {'yes' if identical else 'NO'}")
    every = [x for c in configs for x in runs[c]]
    errors = sorted({x["gather_error"] for x in every if x["gather_error"]})
    agree = [x["gather_agrees"] for x in every if x["gather_agrees"] is not None]
    if agree:
        print(f"d.gather() positions = the owners' positions, bit for bit: {sum(agree)}/{len(agree)} runs")
    if errors:
        print(f"d.gather() failed in {len(every) - len(agree)} runs, the owners' positions compared instead: "
              + "; ".join(errors))
    return {"weak": weak, "runs": {label(c): runs[c] for c in configs}, "summary": summary,
            "lammps_runs": {str(k): v for k, v in (lammps or {}).items()}, "identical": identical}


def plot(results: list, path: str) -> None:
    """Rates against cores, log-log: strong scaling (the whole scene's particle-steps/s) and weak
    scaling (per core), for tsubu's ranks (each thread count a line) and LAMMPS's, from one or
    more runs (``results``: (label, the JSON this script writes) pairs). Rates, not speed-ups: on
    a shared machine a slow one-core run would bend every speed-up."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import matplotlib.ticker
    except ImportError:
        raise SystemExit('--plot needs matplotlib: pip install "tsubu[bench]"')
    panels = sorted({sc["weak"] for _, res in results for sc in res["scenes"].values()})
    fig, axes = plt.subplots(1, len(panels), figsize=(5.4 * len(panels), 4.3), squeeze=False)
    for ax, weak in zip(axes[0], panels):
        for k, (name, res) in enumerate(results):
            for scene, sc in res["scenes"].items():
                if sc["weak"] != weak:
                    continue
                rows = list(sc["summary"].values())
                per = (lambda c: 1e6 * (c if weak else 1))  # (M particle-steps/s, a core if weak)
                for t in sorted({r["threads"] for r in rows}):
                    pts = [r for r in rows if r["threads"] == t]
                    c = [r["ranks"] * r["threads"] for r in pts]
                    tag = "" if t == 1 else f", {t} threads a rank"
                    ax.plot(c, [r["median_rate"] / per(cc) for r, cc in zip(pts, c)], "o-", color=f"C{k}",
                            alpha=1.0 if t == 1 else 0.5,
                            label=f"tsubu {scene}{tag} ({name})")
                lam = [r for r in rows if "lammps_rate" in r and r["threads"] == 1]
                if lam:
                    c = [r["ranks"] for r in lam]
                    ax.plot(c, [r["lammps_rate"] / per(cc) for r, cc in zip(lam, c)], "s--", color=f"C{k}",
                            label=f"LAMMPS ({name})")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.yaxis.set_minor_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.set_xlabel("cores (MPI ranks x threads)")
        ax.set_ylabel("M particle-steps/s per core (10,000 spheres a core)" if weak
                      else "M particle-steps/s (N = 160,000)")
        ax.set_title("weak scaling" if weak else "strong scaling", fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    m = results[0][1]["machine"]
    fig.suptitle(f"{m['cpu']}, {m['usable_cpus']} cores", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["drop", "bed"], choices=["drop", "bed"])
    ap.add_argument("--n", type=parse_size, default=100000, help="drop spheres (default 1e5); also picks the bed's tiles")
    ap.add_argument("--tiles", default=None, help="bed tiles per side, or 'a,b' (default: N = 10,000 K^2 nearest --n)")
    ap.add_argument("--steps", type=int, default=2000, help="timed steps (default 2,000)")
    ap.add_argument("--warmup", type=int, default=50, help="untimed steps after decompose (default 50)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--ranks", nargs="+", type=parse_config, default=[(1, 1), (2, 1)],
                    help="rank counts, R or RxT for T threads a rank (default: 1 2)")
    ap.add_argument("--weak", action="store_true",
                    help="bed only: 10,000 spheres a core (R x T cores: the bed tiled a x b, a b = R T)")
    ap.add_argument("--lammps", default=None, help="LAMMPS binary: the bed also in LAMMPS on R x T ranks")
    ap.add_argument("--margin", type=float, default=None, help="decompose's margin, m (default: its own)")
    ap.add_argument("--mpiexec-args", default="", help="extra mpiexec arguments, both codes (e.g. '-bind-to core')")
    ap.add_argument("--json", default=None, help="write every run's figures here")
    ap.add_argument("--plot", default=None, help="draw the rates against cores here (matplotlib)")
    ap.add_argument("--replot", nargs="+", default=None, metavar="LABEL=JSON",
                    help="redraw --plot from earlier runs' --json files (each LABEL=path), and exit")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--threads", type=int, default=1, help=argparse.SUPPRESS)
    ap.add_argument("--scene", default="drop", help=argparse.SUPPRESS)
    ap.add_argument("--out", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.tiles is None:
        args.tiles = str(tiles_for(args.n))
    if args.worker:
        worker(args)
        return 0
    if args.replot:
        if not args.plot:
            ap.error("--replot needs --plot (the image to write)")
        runs = []
        for item in args.replot:
            name, _, path = item.rpartition("=")
            with open(path) as f:
                runs.append((name or os.path.basename(path), json.load(f)))
        plot(runs, args.plot)
        return 0
    if args.weak and args.scenes != ["bed"]:
        ap.error("--weak scales the bed only: add --scenes bed")
    if args.lammps and not shutil.which(args.lammps):
        ap.error(f"--lammps {args.lammps!r}: no such program")

    if not os.path.exists(mpiexec_path()):
        print(f"no mpiexec beside {sys.executable} ({mpiexec_path()})", file=sys.stderr)
        return 2
    m = machine()
    configs = args.ranks
    print(f"machine: {m['cpu']}, {m['usable_cpus']} usable CPUs, load {m['loadavg']}; python {m['python']}")
    print(f"mpiexec: {mpiexec_path()} {args.mpiexec_args}; R x T {[label(c) for c in configs]}, "
          f"{args.repeats} repetitions (order alternating)" + (f"; LAMMPS {args.lammps}" if args.lammps else ""))
    results, ok = {}, True
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="tsubu-mpi-scaling-") as tmp:
        for scene in args.scenes:
            runs = {c: [] for c in configs}
            lammps = {} if (args.lammps and scene == "bed") else None
            files = {}
            for rep in range(args.repeats):
                order = configs if rep % 2 == 0 else list(reversed(configs))
                for cfg in order:
                    cores = cfg[0] * cfg[1]
                    tiles = tiles_for_cores(cores) if args.weak else parse_tiles(args.tiles)
                    out = os.path.join(tmp, f"{scene}_{label(cfg)}_{rep}.npy")
                    x = one_run(args, scene, cfg, tiles, out)
                    runs[cfg].append(x)
                    files.setdefault(x["n"], []).append(out)
                    held = [p["held"] for p in x["per_rank"]]
                    print(f"  {scene} rep {rep + 1} {label(cfg)}: N {x['n']}, {x['rate'] / 1e6:.2f} M particle-steps/s "
                          f"({x['wall_s']:.2f} s), held {min(held)}..{max(held)}, redistributions {x['redistributions']}",
                          flush=True)
                    if lammps is not None and len(lammps.setdefault(cores, [])) <= rep:
                        lx = one_lammps(args, tiles, cores, tmp)
                        lammps[cores].append(lx)
                        print(f"  {scene} rep {rep + 1} LAMMPS {cores} ranks: {lx['rate'] / 1e6:.2f} M particle-steps/s",
                              flush=True)
            identical = all(same_bits(f[0], g) for f in files.values() for g in f[1:])
            ok &= identical
            results[scene] = (runs, identical, sum(len(f) for f in files.values()), lammps)
    print(f"\n(total {time.perf_counter() - t_start:.0f} s)")
    out = {"machine": m, "args": {k: (v if k != "ranks" else [label(c) for c in v]) for k, v in vars(args).items()
                                  if k not in ("worker", "scene", "out", "threads")},
           "scenes": {}}
    for scene, (runs, identical, n_runs, lammps) in results.items():
        out["scenes"][scene] = report(scene, runs, configs, identical, n_runs, lammps, args.weak)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
    if args.plot:
        plot([("this run", out)], args.plot)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

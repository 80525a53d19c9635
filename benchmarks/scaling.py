#!/usr/bin/env python3
"""Thread scaling of the step loop (issue 29): the tiled dense bed and the lattice drop at 1e6,
at chosen thread counts, each run in a fresh process, side by side with LAMMPS on as many MPI
ranks.

Scenes (SI units, the shared benchmark's linear law of SCENE.md):

* ``bed``: the settled dense bed of shared/bench/dense tiled ``--tiles`` x ``--tiles`` times in x
  and y (shared/bench/device/README.md; 4 x 4: N = 160,000 in a 0.088 m x 0.088 m box), five walls,
  the floor sliding along +x at 0.05 m/s, ``--bed-steps`` steps (default 1,000). There the
  contact law sets the pace (~2.2 contacts per sphere).
* ``drop``: the reference lattice drop (SCENE.md) with ``--drop-n`` spheres (default 1e6), its
  first ``--drop-steps`` steps (default 2,000, as ``throughput.py`` at 1e6): free fall into a pile,
  where streaming the particle arrays through memory and the neighbour-list rebuilds set the pace.

Each run builds its scene, takes ``--warmup`` untimed steps (the first list build, the threads'
start), then times the rest with ``time.perf_counter``. For every thread count the script prints
the median rate (particle-steps/s), the speed-up over the first thread count (median of the ratios
within each repetition: thread counts of one scene run back to back, their order alternating
between repetitions), and where the time went, per step:

* the loop's phases (``Simulation.phase_seconds``): ``neighbors`` (list checks and rebuilds, with
  their own parallel loops), ``contacts`` and ``integrate``, each with its speed-up;
* inside the step's parallel regions (``Simulation.region_seconds``): ``sync``, what starting,
  joining and synchronising the team cost (region time less the busiest thread's working time);
  ``imbalance`` (the busiest thread's time less the average thread's); and ``inflation``, threads x
  the average thread's working time over the first thread count's: above 1, each thread does the
  same work slower (memory bandwidth, caches shared with the other threads, false sharing);
* ``outside``: the loop's time outside those regions, rebuilds excluded (serial bookkeeping of a
  step: wall motion, the move bound, the energy audit).

With ``--lammps LMP`` the bed also runs in LAMMPS on as many MPI ranks as tsubu has threads
(``mpiexec -n R LMP -in lammps/in.scene ...``, ``--mpiexec``), one OpenMP thread per rank, from
the same state written as a LAMMPS data file; LAMMPS's "Loop time" gives its rate, and the table
gives tsubu / LAMMPS at each count. The wall deck is picked by LAMMPS's version: the 2021 build's
classic ``wall/gran hooke/history`` (``lammps/walls_shear.lmp``), or, for the 2025 wheel (whose
classic wall scales kt by the contact radius), ``lammps/walls_granular_shear.lmp``
(shared/bench/device); ``--lammps-walls`` overrides it.

On a shared machine, compare only runs marked quiet: each run's "other" column is the CPU the
rest of the machine used meanwhile (cores). Threads are pinned (OMP_PROC_BIND=close,
OMP_PLACES=cores) unless ``--no-bind``.

Usage (from the repository root)::

    PYTHONPATH=python python benchmarks/scaling.py                          # bed and drop, 1..cores threads
    PYTHONPATH=python python benchmarks/scaling.py --scenes bed --threads 1 2 4 8 16 --lammps lmp
    PYTHONPATH=python python benchmarks/scaling.py --scenes drop --drop-n 1e6 --repeats 5
    PYTHONPATH=python python benchmarks/scaling.py --quick                  # small smoke run (CI)
    PYTHONPATH=python python benchmarks/scaling.py --json scaling.json --plot scaling.png
    python benchmarks/scaling.py --replot scaling.json --plot scaling.png    # redraw a saved run
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

from bench_common import cpu_seconds, machine, parse_size, run_result, system_busy_s

HERE = os.path.dirname(os.path.abspath(__file__))
LAMMPS_DIR = os.path.join(HERE, "lammps")
PHASES = ("neighbors", "contacts", "integrate")


# ---------------------------------------------------------------- one tsubu run (child process)
def child(args) -> None:
    """--child SCENE THREADS: one run in this fresh process; its figures as JSON on a RESULT line."""
    sys.path.insert(0, HERE)
    import reference_scene as rs
    scene, threads = args.child[0], int(args.child[1])
    if scene == "bed":
        sim = rs.build_tiled_bed(args.tiles, threads=threads)
        steps = args.bed_steps
    else:
        sim = rs.build(args.drop_n, threads=threads)
        steps = args.drop_steps
    n = len(sim)
    warmup = min(args.warmup, steps - 1)
    sim.run(warmup)
    p0, r0 = sim.phase_seconds(), sim.region_seconds()
    busy0, cpu0, t0 = system_busy_s(), cpu_seconds(), time.perf_counter()
    sim.run(steps - warmup)
    t1, cpu1, busy1 = time.perf_counter(), cpu_seconds(), system_busy_s()
    p1, r1 = sim.phase_seconds(), sim.region_seconds()
    timed = steps - warmup
    phases = {k: (p1[k] - p0[k]) / timed for k in PHASES}
    regions = {k: {f: (r1[k][f] - r0[k][f]) / (timed if f != "count" else 1) for f in ("wall", "slowest", "mean", "count")}
               for k in r1}
    out = {"scene": scene, "n": n, "threads": threads, "steps": steps, "timed_steps": timed,
           "loop_s": t1 - t0, "rate": n * timed / (t1 - t0), "phases": phases, "regions": regions,
           "cpu_use": (cpu1 - cpu0) / (t1 - t0),
           "other": None if busy0 is None else max(0.0, (busy1 - busy0) - (cpu1 - cpu0)) / (t1 - t0),
           "rebuilds": sim.rebuild_count, "fused_steps": sim.fused_step_count}
    print("RESULT " + json.dumps(out), flush=True)


def run_tsubu(args, scene: str, threads: int) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    if args.bind:
        env.update(OMP_PROC_BIND="close", OMP_PLACES="cores")
    cmd = [sys.executable, os.path.abspath(__file__), "--child", scene, str(threads),
           "--tiles", str(args.tiles), "--bed-steps", str(args.bed_steps), "--drop-n", str(args.drop_n),
           "--drop-steps", str(args.drop_steps), "--warmup", str(args.warmup)]
    return run_result(cmd, env)


# ---------------------------------------------------------------- LAMMPS side
def lammps_walls(lmp: str, choice: str) -> str:
    from compare_lammps import lmp_info
    if choice == "auto":
        version, _ = lmp_info(lmp)
        choice = "granular" if any(y in version for y in ("2023", "2024", "2025", "2026")) else "classic"
    return os.path.join(LAMMPS_DIR, "walls_shear.lmp" if choice == "classic" else "walls_granular_shear.lmp")


def write_bed_data(tiles, path: str) -> int:
    """The tiled bed (``tiles``: K, or a pair (tiles along x, along y)) as a LAMMPS data file."""
    sys.path.insert(0, HERE)
    import reference_scene as rs
    from compare_lammps import write_lammps_state
    st = rs.tiled_bed_state(tiles)
    tx, ty = (tiles, tiles) if isinstance(tiles, int) else tuple(tiles)
    write_lammps_state(path, "DEM dense bed tiled %d x %d (N=%d)" % (tx, ty, len(st["x"])), None,
                       st["x"], st["v"], st["w"],
                       bounds=(0.0, st["lx"], 0.0, st["ly"], 0.0, rs.DENSE_ZTOP))
    return len(st["x"])


def run_lammps(args, data: str, n: int, ranks: int, walls: str, workdir: str) -> dict:
    from compare_lammps import parse_lammps_log
    log = os.path.join(workdir, f"lammps_{ranks}.log")
    cmd = [args.lammps, "-in", os.path.join(LAMMPS_DIR, "in.scene"), "-var", "walls", walls,
           "-var", "vfloor", "0.05", "-var", "data", data, "-var", "steps", str(args.bed_steps),
           "-var", "out", os.path.join(workdir, f"lammps_{ranks}.dump"), "-log", log, "-screen", "none"]
    if ranks > 1 or args.mpiexec_always:
        cmd = [args.mpiexec, "-n", str(ranks)] + args.mpiexec_args.split() + cmd
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if hasattr(os, "geteuid") and os.geteuid() == 0:  # (Open MPI refuses root without these; MPICH ignores them)
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    busy0, child0, t0 = system_busy_s(), cpu_seconds(resource.RUSAGE_CHILDREN), time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=workdir)
    t1, busy1 = time.perf_counter(), system_busy_s()
    child1 = cpu_seconds(resource.RUSAGE_CHILDREN)
    if p.returncode != 0 or not os.path.exists(log):
        raise RuntimeError(f"LAMMPS failed (exit {p.returncode}): {' '.join(cmd)}\n{p.stdout[-2000:]}{p.stderr[-2000:]}")
    r = parse_lammps_log(log)
    if r["atoms"] != n or r["procs"] != ranks:
        raise RuntimeError(f"unexpected LAMMPS run: {r['procs']} procs, {r['atoms']} atoms")
    r.update(ranks=ranks, rate=n * r["timed_steps"] / r["loop_s"],
             other=None if busy0 is None else max(0.0, (busy1 - busy0) - (child1 - child0)) / (t1 - t0))
    return r


# ---------------------------------------------------------------- tables
def med(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


def report(scene: str, runs: dict, threads: list, lammps: dict | None) -> dict:
    """Prints the scene's table; returns its summary."""
    base = threads[0]
    n = runs[base][0]["n"]
    print(f"\n{scene}: N = {n:,}, {runs[base][0]['steps']} steps ({runs[base][0]['timed_steps']} timed), "
          f"{len(runs[base])} repetition(s); per-step times in ms")
    head = (f"{'threads':>7} {'M p-s/s':>8} {'speed-up':>8} {'eff.':>5} | "
            + " ".join(f"{p[:6]:>7} {'x':>5}" for p in PHASES)
            + f" | {'sync':>6} {'imbal.':>6} {'infl.':>5} {'outside':>7} | {'other':>5}")
    if lammps:
        head += f" | {'LAMMPS':>7} {'x':>5} {'tsubu/L':>7}"
    print(head)
    summary = []
    for t in threads:
        rs = runs[t]
        rate = med([r["rate"] for r in rs])
        ratio = med([a["rate"] / b["rate"] for a, b in zip(rs, runs[base])])
        ph = {p: med([r["phases"][p] for r in rs]) for p in PHASES}
        ph_base = {p: med([r["phases"][p] for r in runs[base]]) for p in PHASES}
        reg = lambda r, f: sum(v[f] for v in r["regions"].values())
        sync = med([reg(r, "wall") - reg(r, "slowest") for r in rs])
        imbalance = med([reg(r, "slowest") - reg(r, "mean") for r in rs])
        inflation = med([t * reg(a, "mean") / (base * reg(b, "mean")) if reg(b, "mean") > 0 else None
                         for a, b in zip(rs, runs[base])])
        outside = med([r["phases"]["contacts"] + r["phases"]["integrate"] - reg(r, "wall") for r in rs])
        other = med([r["other"] for r in rs])
        line = (f"{t:>7} {rate / 1e6:>8.2f} {ratio:>7.2f}x {ratio * base / t:>5.2f} | "
                + " ".join(f"{1e3 * ph[p]:>7.3f} {ph_base[p] / ph[p] if ph[p] else 0:>4.2f}x" for p in PHASES)
                + f" | {1e3 * sync:>6.3f} {1e3 * imbalance:>6.3f} {inflation or 0:>5.2f} {1e3 * outside:>7.3f}"
                + f" | {other if other is not None else float('nan'):>5.2f}")
        row = {"threads": t, "rate": rate, "speedup": ratio, "phases_s": ph, "sync_s": sync,
               "imbalance_s": imbalance, "inflation": inflation, "outside_s": outside, "other": other}
        if lammps and t in lammps:
            lr = med([r["rate"] for r in lammps[t]])
            lx = med([a["rate"] / b["rate"] for a, b in zip(lammps[t], lammps[base])]) if base in lammps else None
            vs = med([a["rate"] / b["rate"] for a, b in zip(rs, lammps[t])])
            line += f" | {lr / 1e6:>7.2f} {lx or 0:>4.2f}x {vs:>6.2f}x"
            row.update(lammps_rate=lr, lammps_speedup=lx, ratio_vs_lammps=vs)
        print(line)
        summary.append(row)
    return {"scene": scene, "n": n, "rows": summary}


def plot(results: dict, path: str) -> None:
    """Speed-up against threads (tsubu) and MPI ranks (LAMMPS), with linear scaling drawn in."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SystemExit('--plot needs matplotlib: pip install "tsubu[bench]"')
    fig, ax = plt.subplots(figsize=(5.5, 4.2))
    most = 1
    for sc in results["scenes"]:
        rows = sc["rows"]
        t = [r["threads"] for r in rows]
        most = max(most, *t)
        ax.plot(t, [r["speedup"] * t[0] for r in rows], "o-", label=f"tsubu, {sc['scene']} (N = {sc['n']:,})")
        if rows and "lammps_speedup" in rows[0]:
            ax.plot(t, [r["lammps_speedup"] * t[0] for r in rows], "s--", label=f"LAMMPS, {sc['scene']} (MPI ranks)")
    ax.plot([1, most], [1, most], ":", color="grey", label="linear")
    ax.set_xlabel("threads (tsubu) / MPI ranks (LAMMPS)")
    ax.set_ylabel("speed-up over one")
    ax.set_title(f"{results['machine']['cpu']}, {results['machine']['usable_cpus']} cores", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


# ---------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["bed", "drop"], choices=["bed", "drop"])
    ap.add_argument("--threads", nargs="+", type=int, default=None,
                    help="thread counts (default: 1, 2, 4, ... up to the usable cores)")
    ap.add_argument("--tiles", type=int, default=4, help="bed tiles per side (4: N = 160,000)")
    ap.add_argument("--bed-steps", type=int, default=1000)
    ap.add_argument("--drop-n", type=parse_size, default=1000000)
    ap.add_argument("--drop-steps", type=int, default=2000)
    ap.add_argument("--warmup", type=int, default=50)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--lammps", default=None, help="LAMMPS binary for the bed (e.g. lmp)")
    ap.add_argument("--lammps-walls", default="auto", choices=["auto", "classic", "granular"])
    ap.add_argument("--mpiexec", default="mpiexec")
    ap.add_argument("--mpiexec-args", default="", help="extra mpiexec arguments (e.g. '--bind-to core')")
    ap.add_argument("--mpiexec-always", action="store_true", help="use mpiexec for 1 rank too")
    ap.add_argument("--no-bind", dest="bind", action="store_false", help="do not pin tsubu's threads")
    ap.add_argument("--quick", action="store_true", help="smoke run: bed 1 x 1 and drop 2e4, 200 steps, 1 repetition")
    ap.add_argument("--json", default=None)
    ap.add_argument("--plot", default=None, help="draw the speed-ups into this image (needs matplotlib)")
    ap.add_argument("--replot", default=None, metavar="JSON",
                    help="only draw --plot from an earlier run's --json file")
    ap.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(args)
        return 0
    if args.replot:
        if not args.plot:
            ap.error("--replot needs --plot FILE")
        with open(args.replot) as f:
            plot(json.load(f), args.plot)
        return 0
    if args.quick:
        args.tiles, args.bed_steps, args.drop_n, args.drop_steps = 1, 200, 20000, 200
        args.warmup, args.repeats = 20, 1
        args.threads = args.threads or [1, 2]
    if args.threads is None:
        try:
            cores = len(os.sched_getaffinity(0))
        except AttributeError:
            cores = os.cpu_count() or 1
        args.threads = sorted({1 << k for k in range(cores.bit_length()) if (1 << k) <= cores} | {cores})
    if any(t < 1 for t in args.threads):
        ap.error(f"--threads must be positive, got {args.threads}")
    if args.lammps and not shutil.which(args.lammps):
        ap.error(f"--lammps {args.lammps!r}: no such program")
    info = machine()
    print(f"machine: {info['cpu']}, {info['usable_cpus']} usable cores, load {info['loadavg']}")
    print(f"threads: {args.threads}; pinned: {args.bind}")
    results = {"machine": info, "args": {k: v for k, v in vars(args).items() if k != "child"}, "scenes": []}
    with tempfile.TemporaryDirectory(prefix="tsubu-scaling-") as work:
        lammps_setup = None
        if args.lammps and "bed" in args.scenes:
            data = os.path.join(work, "bed.lmp")
            lammps_setup = (data, write_bed_data(args.tiles, data), lammps_walls(args.lammps, args.lammps_walls))
            print(f"LAMMPS: {args.lammps}, walls {os.path.basename(lammps_setup[2])}")
        for scene in args.scenes:
            runs = {t: [] for t in args.threads}
            lruns = {t: [] for t in args.threads} if (lammps_setup and scene == "bed") else None
            for rep in range(args.repeats):
                order = args.threads if rep % 2 == 0 else args.threads[::-1]
                for t in order:
                    r = run_tsubu(args, scene, t)
                    runs[t].append(r)
                    print(f"  {scene} rep {rep + 1} threads {t:>3}: {r['rate'] / 1e6:8.2f} M p-s/s"
                          f"  (other {r['other'] if r['other'] is not None else float('nan'):.2f} cores)", flush=True)
                    if lruns is not None:
                        lr = run_lammps(args, lammps_setup[0], lammps_setup[1], t, lammps_setup[2], work)
                        lruns[t].append(lr)
                        print(f"  {scene} rep {rep + 1} LAMMPS {t:>3} ranks: {lr['rate'] / 1e6:8.2f} M p-s/s", flush=True)
            # (paired ratios need the first count's runs in the same order)
            summary = report(scene, runs, args.threads, lruns)
            summary["runs"] = runs
            if lruns is not None:
                summary["lammps_runs"] = lruns
            results["scenes"].append(summary)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1, default=str)
        print(f"\nwrote {args.json}")
    if args.plot:
        plot(results, args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Throughput and memory of tsubu on the shared reference scene (SCENE.md, "lattice drop in a box").

For each size N and each thread count, one fresh child process builds the scene
(``reference_scene.build``), runs ``--warmup`` steps untimed (the first neighbour-list build and
force evaluation, the OpenMP thread start), then times the remaining steps of the standard step
count with ``time.perf_counter``. The warm-up steps are part of the standard count, so the end state
is the state after exactly SCENE.md's number of steps (1e4: 10,000; 1e5: 2,000) and can be compared
with LAMMPS's published end state. Reported:

* particle-steps/s = N * timed steps / loop time; median (and range) over ``--repeats``. Inside each
  repetition the thread counts of one size run back to back (their order alternates between
  repetitions), so that 1 and 2 threads are measured side by side on a noisy machine;
* the speed-up of each thread count over the first one (ratio of medians, and the median of the
  per-repetition ratios);
* peak resident memory: ``ru_maxrss`` of the child at the end of the timed loop (before the
  end-state analysis), minus the child's RSS just after ``import tsubu, numpy``, per particle
  [bytes], and the absolute peak [MiB];
* contention: the CPU time the loop used (cores) and the CPU time other processes of the machine
  took meanwhile (from /proc/stat); a run during which others used more than 0.25 cores is flagged
  CONTENDED and counted in the table's "busy" column. On 2 cores a 2-thread run sharing the machine
  with one busy process can be 10-30x slower than on a quiet machine (each OpenMP fork/join then waits
  for the scheduler), so compare only unflagged runs; ``--wait-quiet SECONDS`` waits for a quiet
  machine before each run;
* the end-state summary of every run (kinetic energy, mean height, contacts, overlaps) and, where
  published (N = 1e4 after 10,000 steps), the relative difference from LAMMPS's end state.

Usage (from the repository root)::

    PYTHONPATH=python python benchmarks/throughput.py                       # N = 1e4, 1e5; 1 and 2 threads; 3 repeats
    PYTHONPATH=python python benchmarks/throughput.py --sizes 1e4 --threads 1 2 --repeats 1
    PYTHONPATH=python python benchmarks/throughput.py --quick               # tiny CI smoke run
    PYTHONPATH=python python benchmarks/throughput.py --json results.json   # also write every run
    PYTHONPATH=python python benchmarks/throughput.py --wait-quiet 300      # wait for a quiet machine before each run
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time

from bench_common import cpu_seconds, machine, parse_size, system_busy_s

HERE = os.path.dirname(os.path.abspath(__file__))


# ---------------------------------------------------------------- helpers
def _rss_now_kib() -> int:
    """Current resident set size [KiB] (VmRSS; falls back to the peak so far)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return _maxrss_kib()


def _maxrss_kib() -> int:
    r = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return r // 1024 if sys.platform == "darwin" else r   # bytes on macOS, KiB on Linux










# ---------------------------------------------------------------- child: one timed run
def child(args) -> None:
    rss0 = _rss_now_kib()                      # after "import tsubu, numpy" (below, before this call)
    maxrss0 = _maxrss_kib()
    sys.path.insert(0, HERE)
    import tsubu
    import reference_scene as rs

    n, threads = args.n, args.threads
    steps = args.steps if args.steps is not None else rs.standard_steps(n)
    warmup = min(args.warmup, max(steps - 1, 0))
    t_build = time.perf_counter()
    sim = rs.build(n, threads=threads, roughness=args.roughness)
    t_build = time.perf_counter() - t_build
    rss_built = _rss_now_kib()
    t_warm = time.perf_counter()
    sim.run(steps=warmup)
    t_warm = time.perf_counter() - t_warm
    rebuilds0, fused0 = sim.rebuild_count, sim.fused_step_count
    timed = steps - warmup
    error = None
    load_before = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    busy0, cpu0 = system_busy_s(), cpu_seconds()
    t0 = time.perf_counter()
    try:
        sim.run(steps=timed)
    except tsubu.InstabilityError as e:
        error = f"InstabilityError at step {e.step}, particle {e.particle}: {e}"
    t1 = time.perf_counter()
    busy1, cpu1 = system_busy_s(), cpu_seconds()
    loop_cpu = cpu1 - cpu0
    # CPU time that other processes took during the loop, in cores (contention on a shared machine)
    other = None if busy0 is None else max(0.0, (busy1 - busy0) - loop_cpu) / (t1 - t0)
    peak = _maxrss_kib()
    out = {
        "n": n, "threads": threads, "steps": steps, "warmup": warmup, "timed_steps": timed,
        "loop_s": t1 - t0, "loop_cpu_s": loop_cpu, "cpu_use": loop_cpu / (t1 - t0),
        "other_load": other, "loadavg_before": load_before, "rate": n * timed / (t1 - t0) if error is None else None,
        "build_s": t_build, "warmup_s": t_warm,
        "rebuilds": sim.rebuild_count, "rebuilds_timed": sim.rebuild_count - rebuilds0,
        "fused_timed": sim.fused_step_count - fused0,
        "rss_after_import_kib": rss0, "maxrss_after_import_kib": maxrss0,
        "rss_after_build_kib": rss_built, "peak_rss_kib": peak,
        "bytes_per_particle": (peak - rss0) * 1024.0 / n,
        "law": sim.law, "dt": sim.dt, "skin": sim.skin, "openmp": tsubu.openmp,
        "error": error,
    }
    s = rs.summary(sim)
    out["summary"] = s
    out["vs_lammps"] = rs.compare_with_lammps(s)
    print("@@RESULT " + json.dumps(out), flush=True)


# ---------------------------------------------------------------- parent
def run_child(n, threads, steps, warmup, roughness=0.0) -> dict:
    cmd = [sys.executable, os.path.abspath(__file__), "--child", "--n", str(n), "--threads", str(threads),
           "--warmup", str(warmup), "--roughness", str(roughness)]
    if steps is not None:
        cmd += ["--steps", str(steps)]
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for line in p.stdout.splitlines():
        if line.startswith("@@RESULT "):
            r = json.loads(line[len("@@RESULT "):])
            r["returncode"] = p.returncode
            return r
    return {"n": n, "threads": threads, "rate": None, "returncode": p.returncode,
            "error": f"child exited with status {p.returncode}: "
                     + (p.stderr.strip().splitlines() or ["(no message)"])[-1],
            "stderr": p.stderr[-4000:]}


CONTENTION = 0.25     # cores used by other processes during a loop above which it is flagged


def _contended(r) -> bool:
    return r.get("other_load") is not None and r["other_load"] > CONTENTION


def wait_quiet(limit_s: float, sample_s: float = 3.0) -> float | None:
    """Wait (at most limit_s) until the other processes of the machine use less than CONTENTION
    cores over a sample_s window; returns the last load measured (cores), None if unknown."""
    deadline = time.monotonic() + limit_s
    while True:
        b0, c0 = system_busy_s(), cpu_seconds()
        if b0 is None:
            return None
        time.sleep(sample_s)
        load = max(0.0, (system_busy_s() - b0) - (cpu_seconds() - c0)) / sample_s
        if load < CONTENTION or time.monotonic() >= deadline:
            return load


def fmt_rate(r):
    return "-" if r is None else f"{r / 1e6:8.2f} M"


def print_run(r) -> None:
    head = f"N={r['n']:<8d} threads={r['threads']}"
    if r.get("rate") is None:
        print(f"{head}  FAILED: {r.get('error')}", flush=True)
        if r.get("stderr"):
            print(r["stderr"], file=sys.stderr)
        return
    s = r["summary"]
    print(f"{head}  {fmt_rate(r['rate'])} particle-steps/s  loop {r['loop_s']:.3f} s "
          f"({r['timed_steps']} steps + {r['warmup']} warm-up; build {r['build_s']:.2f} s, "
          f"warm-up {r['warmup_s']:.3f} s; {r['rebuilds_timed']} rebuilds and "
          f"{r.get('fused_timed', 0)} fused steps in the loop)  "
          f"peak RSS {r['peak_rss_kib'] / 1024:.1f} MiB, {r['bytes_per_particle']:.0f} B/particle "
          f"({(r['rss_after_build_kib'] - r['rss_after_import_kib']) * 1024 / r['n']:.0f} after build, "
          f"+{(r['peak_rss_kib'] - r['rss_after_build_kib']) * 1024 / r['n']:.0f} by the end of the loop)", flush=True)
    other = "?" if r.get("other_load") is None else f"{r['other_load']:.2f}"
    print(f"    CPU use of the loop {r['cpu_use']:.2f} cores; other processes used {other} cores meanwhile"
          f" (load average before: {r.get('loadavg_before') or 0:.2f})"
          + ("  <-- CONTENDED" if _contended(r) else ""), flush=True)
    print(f"    end state after {s['steps']} steps (t = {s['time'] * 1e3:.4f} ms): "
          f"KE {s['ke_total']:.5e} J (trans {s['ke_trans']:.4e}, rot {s['ke_rot']:.4e}), "
          f"mean z {s['mean_z']:.7f} m, {s['pair_contacts']} pair / {s['wall_contacts']} wall contacts, "
          f"max/mean pair overlap {s['max_pair_overlap_over_d']:.4e} / {s['mean_pair_overlap_over_d']:.4e} d, "
          f"max wall overlap {s['max_wall_overlap_over_d']:.4e} d", flush=True)
    if r.get("vs_lammps"):
        d = r["vs_lammps"]
        print("    vs LAMMPS (KE 1.0420e-4 J, mean z 0.0128749 m, 975 pair, 250 wall): "
              + ", ".join(f"{k} {100 * v:+.2f} %" for k, v in d.items()), flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", nargs="+", type=parse_size, default=None,
                    help="particle counts (default 1e4 1e5; other sizes get a near-cubic lattice)")
    ap.add_argument("--threads", nargs="+", type=int, default=None, help="thread counts (default 1 2)")
    ap.add_argument("--repeats", type=int, default=None, help="repetitions (default 3)")
    ap.add_argument("--steps", type=int, default=None,
                    help="steps per run, warm-up included (default: SCENE.md's 10,000 for 1e4, 2,000 for 1e5)")
    ap.add_argument("--warmup", type=int, default=10, help="untimed first steps (default 10)")
    ap.add_argument("--quick", action="store_true",
                    help="tiny smoke run: N=500, 2000 steps, threads 1 2, 1 repeat (unless given)")
    ap.add_argument("--wait-quiet", type=float, default=0.0, metavar="SECONDS",
                    help="before each run, wait up to SECONDS for the other processes of the machine to use "
                         f"less than {CONTENTION} cores (default 0: do not wait)")
    ap.add_argument("--json", metavar="FILE", help="write every run and the table to FILE")
    ap.add_argument("--roughness", type=float, default=0.0, metavar="DEGREES",
                    help="make the walls rough with this scatter sigma (default 0: the smooth "
                         "reference scene); compares the rough specialisation's cost")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args.child:
        args.threads = args.threads[0]
        child(args)
        return 0

    if args.quick:
        sizes = args.sizes or [500]
        steps = args.steps if args.steps is not None else 2000
        repeats = args.repeats or 1
    else:
        sizes = args.sizes or [10000, 100000]
        steps = args.steps
        repeats = args.repeats or 3
    threads = args.threads or [1, 2]
    if any(t < 1 for t in threads) or repeats < 1 or (steps is not None and steps < 1):
        ap.error("threads, repeats and steps must be >= 1")

    sys.path.insert(0, HERE)
    import tsubu
    import reference_scene as rs

    m = machine()
    print(f"machine: {m['cpu']}, {m['logical_cpus']} logical CPUs ({m['usable_cpus']} usable), "
          f"Python {m['python']}, {m['platform']}")
    print(f"tsubu {tsubu.__version__}, openmp={tsubu.openmp}")
    if not tsubu.openmp and any(t > 1 for t in threads):
        print("WARNING: tsubu was built without OpenMP; thread counts > 1 run serially")
    if max(threads) > (m["usable_cpus"] or 1):
        print(f"WARNING: {max(threads)} threads on {m['usable_cpus']} usable CPUs")
    print("self-check of the scene (constants, jitter, tsubu's damping):")
    if not rs.self_check():
        print("WARNING: the scene does not match SCENE.md")
    plan = [(n, steps if steps is not None else rs.standard_steps(n)) for n in sizes]
    print("plan: " + "; ".join(f"N={n} {rs.shape(n)} x {s} steps" for n, s in plan)
          + f"; threads {threads}; {repeats} repeat(s); warm-up {args.warmup} steps; fresh process per run\n",
          flush=True)

    runs = []
    for rep in range(repeats):
        print(f"--- repetition {rep + 1}/{repeats}", flush=True)
        for n in sizes:
            order = threads if rep % 2 == 0 else threads[::-1]
            for t in order:
                if args.wait_quiet > 0:
                    load = wait_quiet(args.wait_quiet)
                    if load is not None and load >= CONTENTION:
                        print(f"(machine still busy after {args.wait_quiet:.0f} s: other processes use "
                              f"{load:.2f} cores; running anyway)", flush=True)
                r = run_child(n, t, steps, args.warmup, roughness=args.roughness)
                r["repeat"] = rep
                runs.append(r)
                print_run(r)

    # ---- table
    print("\n=== summary (medians over repetitions; rates in million particle-steps/s) ===")
    print(f"machine: {m['cpu']}, {m['usable_cpus']} usable CPUs; tsubu openmp={tsubu.openmp}")
    hdr = (f"{'N':>9} {'steps':>6} {'thr':>3} {'runs':>4} {'median':>9} {'min':>8} {'max':>8} "
           f"{'speed-up':>9} {'paired':>7} {'busy':>4} {'B/part':>7} {'peak MiB':>9} {'KE [J]':>11} {'mean z [m]':>11} "
           f"{'pair':>6} {'wall':>5}")
    print(hdr)
    print("-" * len(hdr))
    table = []
    for n, st in plan:
        base = None
        for t in threads:
            rs_ = [r for r in runs if r["n"] == n and r["threads"] == t]
            ok = [r for r in rs_ if r.get("rate") is not None]
            row = {"n": n, "steps": st, "threads": t, "runs": len(ok), "failed": len(rs_) - len(ok),
                   "contended": sum(_contended(r) for r in ok)}
            if ok:
                rates = [r["rate"] for r in ok]
                row.update(median=statistics.median(rates), min=min(rates), max=max(rates),
                           bytes_per_particle=statistics.median(r["bytes_per_particle"] for r in ok),
                           peak_mib=max(r["peak_rss_kib"] for r in ok) / 1024.0,
                           ke=statistics.median(r["summary"]["ke_total"] for r in ok),
                           mean_z=statistics.median(r["summary"]["mean_z"] for r in ok),
                           pair=statistics.median(r["summary"]["pair_contacts"] for r in ok),
                           wall=statistics.median(r["summary"]["wall_contacts"] for r in ok))
                if base is None:
                    base = (t, row["median"], {r["repeat"]: r["rate"] for r in ok})
                row["speedup"] = row["median"] / base[1]
                paired = [r["rate"] / base[2][r["repeat"]] for r in ok if r["repeat"] in base[2]]
                row["speedup_paired"] = statistics.median(paired) if paired else None
            table.append(row)
            if not ok:
                print(f"{n:>9d} {st:>6d} {t:>3d} {0:>4d}  all runs failed")
                continue
            sp = f"{row['speedup']:.2f}x"
            pp = "-" if row["speedup_paired"] is None else f"{row['speedup_paired']:.2f}x"
            print(f"{n:>9d} {st:>6d} {t:>3d} {len(ok):>4d} {row['median'] / 1e6:>9.2f} {row['min'] / 1e6:>8.2f} "
                  f"{row['max'] / 1e6:>8.2f} {sp:>9} {pp:>7} {row['contended']:>4d} {row['bytes_per_particle']:>7.0f} "
                  f"{row['peak_mib']:>9.1f} {row['ke']:>11.4e} {row['mean_z']:>11.7f} {row['pair']:>6.0f} "
                  f"{row['wall']:>5.0f}")
    print(f"speed-up: median rate / median rate at {threads[0]} thread(s); paired: median over repetitions of "
          f"the ratio within one repetition.\nbusy: runs during which other processes used more than "
          f"{CONTENTION} cores (their rates are not representative; rerun on a quiet machine).\nB/part: (peak RSS - RSS after 'import tsubu, numpy') / N, "
          f"peak read at the end of the timed loop; peak MiB: absolute peak RSS of the child.")
    ref = rs.LAMMPS_END_STATE
    cmp_rows = [r for r in runs if r.get("vs_lammps")]
    if cmp_rows:
        print("\nend state vs LAMMPS (N=1e4, 10,000 steps: KE 1.0420e-4 J, mean z 0.0128749 m, 975 pair, "
              "250 wall contacts); relative differences:")
        for r in cmp_rows:
            d = r["vs_lammps"]
            print(f"  threads={r['threads']} rep={r['repeat'] + 1}: " + ", ".join(
                f"{k} {100 * v:+.2f} %" for k, v in d.items()))
    else:
        print("\n(no run matches a published LAMMPS end state: N=1e4 after 10,000 steps)")
    failed = [r for r in runs if r.get("rate") is None]
    if failed:
        print(f"\n{len(failed)} run(s) FAILED:")
        for r in failed:
            print(f"  N={r['n']} threads={r['threads']}: {r.get('error')}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"machine": m, "openmp": tsubu.openmp, "runs": runs, "table": table,
                       "lammps_end_state": {str(k): v for k, v in ref.items()}}, f, indent=1)
        print(f"\nwrote {args.json}")
    return 1 if failed else 0


if __name__ == "__main__":
    if "--child" in sys.argv[1:]:
        import numpy  # noqa: F401  the memory baseline is taken after these two imports
        import tsubu  # noqa: F401
    sys.exit(main())

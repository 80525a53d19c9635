"""Skip what a scene does not use, measured: the reference scene run frictionless, frictional,
with rolling friction and with rough walls, each in its own compiled specialisation.

    python benchmarks/features.py [--n 10000] [--steps 5000] [--repeats 3] [--threads 1]

The variants alternate within each repetition in fresh processes; the script prints each
variant's median particle-steps/s and its ratio to the frictional reference scene measured
side by side (median of the per-repetition ratios).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

VARIANTS = {
    "frictionless": dict(friction=0.0),
    "frictional (reference)": dict(),
    "rolling friction 0.1": dict(rolling_friction=0.1),
    "rough walls 10 deg": dict(roughness=10.0),
}

CHILD = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
import reference_scene as rs
n, steps, threads, kw = int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), json.loads(sys.argv[5])
sim = rs.build(n, threads=threads, **kw)
sim.run(steps=10)
t = time.perf_counter()
sim.run(steps=steps)
dt = time.perf_counter() - t
print(json.dumps({"rate": n * steps / dt / 1e6, "law": sim.law}))
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--steps", type=int, default=5000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args(argv)
    here = os.path.dirname(os.path.abspath(__file__))
    rates = {k: [] for k in VARIANTS}
    laws = {}
    for rep in range(args.repeats):
        order = list(VARIANTS) if rep % 2 == 0 else list(VARIANTS)[::-1]
        for name in order:
            out = subprocess.run([sys.executable, "-c", CHILD, here, str(args.n), str(args.steps),
                                  str(args.threads), json.dumps(VARIANTS[name])],
                                 capture_output=True, text=True, check=True)
            r = json.loads(out.stdout.strip().splitlines()[-1])
            rates[name].append(r["rate"])
            laws[name] = r["law"]
    ref = rates["frictional (reference)"]
    print(f"reference scene, N = {args.n}, {args.steps} steps, {args.threads} thread(s), "
          f"{args.repeats} repetitions")
    print(f"{'variant':24s} {'specialisation':40s} {'median':>8s}  {'ratio to frictional':>20s}")
    for name, v in rates.items():
        ratio = statistics.median(a / b for a, b in zip(v, ref))
        print(f"{name:24s} {laws[name]:40s} {statistics.median(v):8.2f}  {ratio:19.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

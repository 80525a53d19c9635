#!/usr/bin/env python3
"""A long fuzzing campaign: tests/test_fuzz.py under hypothesis's "campaign" profile (random,
not derandomized, many examples per test), through pytest.

Prints, per test and in all, how many generated cases ran and how many failed, and the time.
CI runs the same tests with the small deterministic "ci" profile.

Usage (from the repository root, with the test extra installed)::

    python benchmarks/fuzz_campaign.py                   # 2,000 examples per test
    python benchmarks/fuzz_campaign.py --examples 20000  # longer
    python benchmarks/fuzz_campaign.py -k add_spheres    # one test (pytest's -k)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=2000, help="examples per test (default 2000)")
    parser.add_argument("-k", default=None, help="pytest -k expression selecting tests")
    args = parser.parse_args()
    env = dict(os.environ, TSUBU_FUZZ_PROFILE="campaign", TSUBU_FUZZ_EXAMPLES=str(args.examples))
    cmd = [sys.executable, "-m", "pytest", os.path.join(ROOT, "tests", "test_fuzz.py"), "-q",
           "-p", "no:cacheprovider", "--hypothesis-show-statistics"]
    if args.k:
        cmd += ["-k", args.k]
    start = time.perf_counter()
    proc = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    out = proc.stdout + proc.stderr
    # hypothesis's statistics: "- N passing examples, M failing examples, K invalid examples"
    cases = failures = 0
    test = None
    rows = []
    for line in out.splitlines():
        s = line.strip()
        if s.startswith("tests/test_fuzz.py::") or s.startswith("test_fuzz.py::"):
            test = s.split("::", 1)[1].rstrip(":")
        elif "passing examples" in s and test:
            words = s.lstrip("- ").replace(",", "").split()
            passing, failing = int(words[0]), int(words[3])
            cases += passing + failing
            failures += failing
            rows.append((test, passing, failing))
    for name, passing, failing in rows:
        print(f"{name:45s} {passing + failing:8d} cases {failing:4d} failing")
    print(f"{'all':45s} {cases:8d} cases {failures:4d} failing  in {seconds:.0f} s "
          f"(pytest exit {proc.returncode})")
    if proc.returncode != 0:
        print(out[-6000:])
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main())

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


def _tests(selection: str | None) -> list[str]:
    cmd = [sys.executable, "-m", "pytest", "tests/test_fuzz.py", "--collect-only", "-q",
           "-p", "no:cacheprovider"] + (["-k", selection] if selection else [])
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True).stdout
    return [line.strip() for line in out.splitlines() if "::" in line]


def _statistics(output: str) -> tuple[int, int]:
    """(cases, failing) from hypothesis's statistics: "- 50 passing, 0 failing, and 3 invalid
    test cases" (per phase: generate, shrink, ...)."""
    cases = failing = 0
    for line in output.splitlines():
        words = line.strip().lstrip("- ").replace(",", "").split()
        if len(words) >= 4 and words[1] == "passing" and words[3] == "failing":
            cases += int(words[0]) + int(words[2])
            failing += int(words[2])
    return cases, failing


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=2000, help="examples per test (default 2000)")
    parser.add_argument("-k", default=None, help="pytest -k expression selecting tests")
    args = parser.parse_args()
    env = dict(os.environ, TSUBU_FUZZ_PROFILE="campaign", TSUBU_FUZZ_EXAMPLES=str(args.examples))
    total_cases = total_failing = 0
    failed_tests = []
    start = time.perf_counter()
    for test in _tests(args.k):
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "pytest", test, "-q", "-p", "no:cacheprovider",
                               "--hypothesis-show-statistics"], env=env, cwd=ROOT,
                              capture_output=True, text=True)
        out = proc.stdout + proc.stderr
        cases, failing = _statistics(out)
        if proc.returncode != 0:
            failing = max(failing, 1)  # hypothesis stops at the first (shrunk) failure
            failed_tests.append((test, out))
        total_cases += cases
        total_failing += failing
        print(f"{test.split('::')[1]:40s} {cases:7d} cases {failing:3d} failing "
              f"{time.perf_counter() - t0:7.1f} s", flush=True)
    print(f"{'all':40s} {total_cases:7d} cases {total_failing:3d} failing "
          f"{time.perf_counter() - start:7.1f} s", flush=True)
    for test, out in failed_tests:
        print(f"\n==== {test}\n{out[-4000:]}")
    return 1 if failed_tests else 0


if __name__ == "__main__":
    sys.exit(main())

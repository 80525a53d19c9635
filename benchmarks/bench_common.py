"""Helpers shared by the benchmark scripts: what the machine is, and how busy it is."""
from __future__ import annotations

import argparse
import os
import platform
import resource


def system_busy_s() -> float | None:
    """CPU seconds spent so far by the whole machine (all processes, all CPUs), from /proc/stat."""
    try:
        with open("/proc/stat") as f:
            fields = f.readline().split()
        j = [int(x) for x in fields[1:9]]          # user nice system idle iowait irq softirq steal
        return (j[0] + j[1] + j[2] + j[5] + j[6] + j[7]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None



def cpu_seconds(who=resource.RUSAGE_SELF) -> float:
    """User + system CPU seconds of this process (or of its finished children)."""
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def machine() -> dict:
    """CPU model, core counts, Python, platform and load average."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    return {"cpu": cpu, "logical_cpus": os.cpu_count(), "usable_cpus": usable,
            "python": platform.python_version(), "platform": platform.platform(),
            "loadavg": os.getloadavg() if hasattr(os, "getloadavg") else None}


def parse_size(s: str) -> int:
    """A particle count from the command line: '1e4', '100000'."""
    v = float(s)
    if v < 1 or v != int(v):
        raise argparse.ArgumentTypeError(f"a size must be a positive whole number, got {s!r}")
    return int(v)


def load_state(path: str) -> dict:
    """A cached state (``np.savez``): arrays as arrays, 0-d entries as floats."""
    import numpy as np
    with np.load(path) as z:
        return {k: (z[k] if z[k].ndim else float(z[k])) for k in z.files}


def run_child(script: str, arguments: list[str]) -> dict:
    """Runs ``script`` with ``arguments`` in a fresh one-thread process and returns the JSON it
    printed on its ``RESULT`` line (the paired benchmarks' child runs)."""
    import sys
    return run_result([sys.executable, os.path.abspath(script)] + arguments,
                      dict(os.environ, OMP_NUM_THREADS="1"))


def run_result(cmd: list[str], env: dict) -> dict:
    """Runs ``cmd`` with ``env`` and returns the JSON it printed on its ``RESULT`` line;
    RuntimeError with the end of its output if it failed or printed none."""
    import json
    import subprocess
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    line = next((l for l in p.stdout.splitlines() if l.startswith("RESULT ")), None)
    if p.returncode != 0 or line is None:
        raise RuntimeError(f"{' '.join(cmd)} failed (exit {p.returncode}):\n{p.stdout[-2000:]}{p.stderr[-3000:]}")
    return json.loads(line[len("RESULT "):])

"""Interrupt latency: how long after Ctrl-C (SIGINT) a run raises KeyboardInterrupt, and how
long after request_stop() from another thread it returns.

The reference drop (reference_scene.py) with N spheres (default 36,000, the scene of the issue
that took 89 s to notice Ctrl-C) runs a long call; a timer thread sends SIGINT to the main
thread (or calls request_stop) a random 0.2-0.7 s into it. Reported per kind: the median and
the largest latency over the tries, and the mean step time (a stop waits for the step in
progress; tsubu looks for signals every 20 ms of wall time).

    python benchmarks/interrupt_latency.py                 # 36,000 spheres, 7 tries each
    python benchmarks/interrupt_latency.py --n 1e5 --tries 3 --threads 2
"""
from __future__ import annotations

import argparse
import random
import signal
import statistics
import threading
import time

import bench_common
import reference_scene


def one_try(sim, stop, after: float, steps: int) -> tuple[float, int]:
    """(seconds from stop() to the end of run, steps the call took)."""
    sent = []

    def fire():
        sent.append(time.perf_counter())
        stop()

    before = sim.step_count
    timer = threading.Timer(after, fire)
    timer.start()
    try:
        sim.run(steps=steps)
    except KeyboardInterrupt:
        pass
    ended = time.perf_counter()
    timer.join()
    if not sent or not sim.stopped:
        raise SystemExit("the run ended before the stop: raise --steps")
    return ended - sent[0], sim.step_count - before


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=bench_common.parse_size, default=36_000)
    parser.add_argument("--tries", type=int, default=7)
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--steps", type=int, default=1_000_000, help="steps asked of each call")
    args = parser.parse_args()
    signal.signal(signal.SIGINT, signal.default_int_handler)
    print("machine:", bench_common.machine())
    sim = reference_scene.build(args.n, threads=args.threads)
    start = time.perf_counter()
    sim.run(steps=20)
    print(f"N = {len(sim)}, threads used {sim.threads_used}; first 20 steps "
          f"{time.perf_counter() - start:.2f} s")
    main_thread = threading.main_thread().ident
    kinds = {"SIGINT -> KeyboardInterrupt": lambda: signal.pthread_kill(main_thread, signal.SIGINT),
             "request_stop() from a thread": sim.request_stop}
    rng = random.Random(1)
    for name, stop in kinds.items():
        latencies, step_times = [], []
        for _ in range(args.tries):
            after = rng.uniform(0.2, 0.7)
            t0 = time.perf_counter()
            latency, steps = one_try(sim, stop, after, args.steps)
            latencies.append(latency)
            step_times.append((time.perf_counter() - t0) / max(steps, 1))
        print(f"{name}: latency median {statistics.median(latencies) * 1e3:.1f} ms, "
              f"max {max(latencies) * 1e3:.1f} ms over {args.tries} tries; "
              f"mean step {statistics.mean(step_times) * 1e3:.2f} ms")


if __name__ == "__main__":
    main()

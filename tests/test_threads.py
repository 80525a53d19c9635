"""Simulations and Python threads.

Several Simulations run at once from several threads give the bits of the same runs made one
after the other: runs release the GIL (the test checks that the runs overlapped in time), and
the engine keeps no state shared between Simulations. One Simulation used from two threads at
once refuses the second thread with RuntimeError (every public method and property but
request_stop, running and the progress counters step_count and time), and leaves its state as
the run left it.
"""

from __future__ import annotations

import inspect
import threading
import time

import numpy as np
import pytest

import tsubu

STEPS, CHUNK = 240, 40


def scene(seed: int, threads: int = 1) -> tsubu.Simulation:
    """1,000 frictional spheres (radii 0.4-0.5 mm) on a jittered lattice with random
    velocities and spins, falling onto a floor between two walls; threads=2 really uses two
    (parallel_min=0)."""
    rng = np.random.default_rng(seed)
    grid = np.stack(np.meshgrid(np.arange(10), np.arange(10), np.arange(10), indexing="ij"),
                    -1).reshape(-1, 3)
    pos = (grid + 0.5) * 1.1e-3 + rng.uniform(-0.05e-3, 0.05e-3, grid.shape)
    sim = tsubu.Simulation(dt=2e-6, threads=threads, parallel_min=0 if threads > 1 else 2048)
    mat = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)
    sim.add_spheres(pos, rng.uniform(0.4e-3, 0.5e-3, len(pos)), mat,
                    velocities=rng.normal(0.0, 0.3, pos.shape),
                    angular_velocities=rng.normal(0.0, 100.0, pos.shape))
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=mat)
    sim.add_plane(point=(0, 0, 0), normal=(1, 0, 0), material=mat)
    sim.add_plane(point=(11e-3, 0, 0), normal=(-1, 0, 0), material=mat)
    return sim


def state(sim: tsubu.Simulation) -> dict:
    out = {name: getattr(sim, name) for name in
           ("positions", "velocities", "angular_velocities", "forces", "step_count", "time")}
    out.update({"contact " + k: v for k, v in sim.contacts().items()})
    return out


def assert_same_bits(a: dict, b: dict):
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key]), key


def run_in_chunks(sims, spans=None):
    """Runs each Simulation STEPS steps, CHUNK at a time, taking them in turn; records each
    call's (start, end) wall time in `spans`."""
    for _ in range(STEPS // CHUNK):
        for sim in sims:
            start = time.perf_counter()
            sim.run(steps=CHUNK)
            if spans is not None:
                spans.append((start, time.perf_counter()))


def test_simulations_in_three_threads_give_the_bits_of_sequential_runs():
    """Nine Simulations (different scenes, one or two OpenMP threads: one of each three), three per Python
    thread, run at once in chunks: each ends with the bits it has when the nine run one after
    the other, contacts and tangential histories included; and calls of different threads
    overlapped in time, so the GIL was released."""
    seeds = range(9)
    sequential = [scene(k, threads=2 if k % 3 == 0 else 1) for k in seeds]
    for sim in sequential:
        run_in_chunks([sim])
    concurrent = [scene(k, threads=2 if k % 3 == 0 else 1) for k in seeds]
    spans = [[] for _ in range(3)]
    errors = []
    start = threading.Barrier(3)

    def work(t):
        try:
            start.wait()
            run_in_chunks(concurrent[3 * t:3 * t + 3], spans[t])
        except BaseException as e:  # noqa: BLE001 (re-raised below)
            errors.append(e)

    workers = [threading.Thread(target=work, args=(t,)) for t in range(3)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    if errors:
        raise errors[0]
    for a, b in zip(concurrent, sequential):
        assert a.step_count == STEPS
        assert len(a.contacts()["i"]) > 50
        assert_same_bits(state(a), state(b))
    overlapping = sum(s0 < e1 and s1 < e0 for t in range(3) for u in range(t + 1, 3)
                      for s0, e0 in spans[t] for s1, e1 in spans[u])
    assert overlapping > 0, "no two runs of different threads overlapped: was the GIL held?"


LONG = 200_000  # steps: some 10 s, unless stopped (the test stops it within a second)


def start_long_run(sim: tsubu.Simulation):
    """Starts sim.run(steps=LONG) in a thread; returns (thread, list of what it raised) once
    the run is in progress."""
    errors = []

    def work():
        try:
            sim.run(steps=LONG)
        except BaseException as e:  # noqa: BLE001 (checked by the caller)
            errors.append(e)

    worker = threading.Thread(target=work)
    worker.start()
    deadline = time.monotonic() + 10.0
    while not sim.running and worker.is_alive() and time.monotonic() < deadline:
        time.sleep(0.001)
    assert sim.running
    return worker, errors


def test_a_second_thread_is_refused_while_a_run_is_in_progress():
    """While one thread runs a Simulation, another thread's run, setters, array writes and
    reads, scene changes and even len() raise RuntimeError naming the reason, and change
    nothing; request_stop() then ends the run, whose state is that of a plain run of as many
    steps."""
    sim = scene(1)
    material = tsubu.Material(density=1000.0, kn=1e3, restitution=0.5)
    worker, errors = start_long_run(sim)
    try:
        refused = {
            "run": lambda: sim.run(steps=1),
            "run(time=)": lambda: sim.run(time=1e-5),
            "positions": lambda: sim.positions,
            "set positions": lambda: setattr(sim, "positions", np.zeros((1000, 3))),
            "set velocities": lambda: setattr(sim, "velocities", np.zeros((1000, 3))),
            "gravity": lambda: setattr(sim, "gravity", (0.0, 0.0, 0.0)),
            "dt": lambda: setattr(sim, "dt", 1e-6),
            "add_spheres": lambda: sim.add_spheres([[0.0, 0.0, 0.05]], 0.5e-3, material),
            "add_plane": lambda: sim.add_plane(point=(0, 0, 1), normal=(0, 0, -1),
                                               material=material),
            "set_pair": lambda: sim.set_pair(material, material, friction=0.1),
            "contacts": lambda: sim.contacts(),
            "energy": lambda: sim.energy(),
            "len": lambda: len(sim),
        }
        for what, call in refused.items():
            with pytest.raises(RuntimeError, match="running in another thread"):
                call()
        # Every other public member too (called without arguments: refused before they are
        # looked at), but those meant for other threads.
        for name in dir(tsubu.Simulation):
            if name.startswith("_") or name in ("request_stop", "running", "step_count", "time"):
                continue
            if isinstance(inspect.getattr_static(tsubu.Simulation, name), staticmethod):
                continue  # load: makes a new Simulation, touches none
            member = getattr(tsubu.Simulation, name)
            with pytest.raises(RuntimeError, match="running in another thread"):
                if isinstance(member, property):
                    getattr(sim, name)
                else:
                    getattr(sim, name)()
        assert repr(sim) == "tsubu.Simulation(running)"
        assert sim.running and worker.is_alive()
    finally:
        sim.request_stop()
        worker.join(timeout=60)
    assert not worker.is_alive() and errors == []
    assert sim.stopped and not sim.running
    done = sim.step_count
    assert done < LONG
    assert len(sim) == 1000
    assert np.array_equal(sim.gravity, (0.0, 0.0, -9.81)) and sim.dt == 2e-6
    plain = scene(1)
    plain.run(steps=done)
    assert_same_bits(state(sim), state(plain))
    assert repr(sim).startswith("tsubu.Simulation(1000 spheres, 3 walls")
    sim.run(steps=10)  # usable again
    assert sim.step_count == done + 10 and not sim.stopped


def test_a_monitor_thread_reads_step_count_and_time_during_a_run():
    """While one thread runs, another reads step_count and time (issue 26: they were refused):
    each read is a step completed, never decreasing, and time follows step_count; the run's
    result is that of a run nobody watched."""
    sim = scene(1)
    worker, errors = start_long_run(sim)
    seen = []
    try:
        deadline = time.monotonic() + 30.0
        while len({s for s, _ in seen}) < 3 and time.monotonic() < deadline:
            seen.append((sim.step_count, sim.time))
            time.sleep(0.002)
        assert sim.running
    finally:
        sim.request_stop()
        worker.join(timeout=60)
    assert errors == [] and sim.stopped
    steps, times = [s for s, _ in seen], [t for _, t in seen]
    assert len(set(steps)) >= 3 and steps == sorted(steps) and times == sorted(times)
    assert all(0 <= s < LONG for s in steps) and max(steps) <= sim.step_count
    for s, t in seen:  # (time is read after step_count: at its step or later)
        assert s * 2e-6 * (1 - 1e-9) <= t <= sim.time, (s, t)
    plain = scene(1)
    plain.run(steps=sim.step_count)
    assert_same_bits(state(sim), state(plain))


def test_two_threads_running_one_simulation_one_is_refused():
    """Two threads call run on one Simulation: the second gets RuntimeError, the first runs."""
    sim = scene(2)
    worker, errors = start_long_run(sim)
    try:
        with pytest.raises(RuntimeError, match="running in another thread"):
            sim.run(steps=LONG)
    finally:
        sim.request_stop()
        worker.join(timeout=60)
    # (The stop may come before the first step: a request made as the run starts still counts.)
    assert errors == [] and sim.stopped and sim.step_count < LONG
    sim.run(steps=5)
    assert not sim.stopped

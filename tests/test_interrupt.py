"""Stopping a run: Ctrl-C (SIGINT, sent from a thread) and Simulation.request_stop().

A stopped run ends at a step boundary with the state of its last completed step, and running
the remaining steps gives the bits of a run that never stopped: positions, velocities, spins,
contacts with their tangential history, step count and time. The scene is the fused-pass
scene of test_fused_pass.py (67,600 frictional spheres, fixed walls): most of its steps are
fused with the next step's contact pass, so the stop falls inside a fused stretch, where it
has to end the run the way a run's last step ends.

The run is sized from the machine's speed (about 1 s), and stopped after 0.3 s. The one
timing assertion is the issue's latency bound: KeyboardInterrupt within 0.5 s of the signal
(tsubu checks for signals every 20 ms, so the margin is wide).
"""

from __future__ import annotations

import signal
import threading
import time

import numpy as np
import pytest

from test_fused_pass import FUSED_MIN, lattice_scene

import tsubu

from bits import assert_same_bits

WARMUP = 10  # steps run before the measured call (the first step of a run never fuses)
# The call that gets interrupted is sized to take this long at the speed of the steps right
# after WARMUP; its later steps, with contacts formed, take about three times longer: ~1 s.
RUN_SECONDS = 0.4
STOP_AFTER = 0.3  # s
LATENCY_BOUND = 0.5  # s: the bound


@pytest.fixture(scope="module")
def reference():
    """(steps of the measured call, the scene after WARMUP + that many steps uninterrupted).
    The measured call is sized from this machine's speed (at least 300 steps): the stop must
    come well before its end even if the machine gets faster meanwhile."""
    sim = lattice_scene(1)
    sim.run(steps=WARMUP // 2)  # the first rebuild
    start = time.perf_counter()
    sim.run(steps=WARMUP - WARMUP // 2)
    per_step = (time.perf_counter() - start) / (WARMUP - WARMUP // 2)
    steps = int(min(max(RUN_SECONDS / per_step, 300), 3000))
    fused = sim.fused_step_count
    sim.run(steps=steps)
    assert sim.fused_step_count - fused > steps // 2  # the scene takes the fused pass
    assert len(sim) >= FUSED_MIN
    return steps, sim


def interrupted(sim: tsubu.Simulation, stop, **run):
    """Runs sim.run(**run) while a timer thread calls stop() after STOP_AFTER seconds; returns
    (what run raised or None, seconds from stop() to run's end)."""
    sent = []

    def fire():
        sent.append(time.perf_counter())
        stop()

    timer = threading.Timer(STOP_AFTER, fire)
    timer.start()
    raised = None
    try:
        try:
            sim.run(**run)
        except KeyboardInterrupt as e:
            raised = e
        ended = time.perf_counter()
        timer.join()
        # A signal sent after run returned (a run too short) arrives here, not in pytest.
        time.sleep(0.05)
    except KeyboardInterrupt as e:
        raised, ended = raised or e, time.perf_counter()
    return raised, ended - sent[0] if sent else float("nan")


@pytest.fixture
def sigint_raises_keyboard_interrupt():
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.mark.parametrize("threads", [1, 2])
def test_ctrl_c_stops_the_run_and_running_on_gives_the_same_bits(
        reference, threads, sigint_raises_keyboard_interrupt):
    """SIGINT, sent to the main thread from a timer thread 0.3 s into a run of ~1 s, raises
    KeyboardInterrupt within 0.5 s, leaving the state of a completed step (fewer steps than
    asked, some of them fused); run(steps=remaining) then gives the reference's bits."""
    steps, whole = reference
    sim = lattice_scene(threads)
    sim.run(steps=WARMUP)
    fused = sim.fused_step_count
    main = threading.main_thread().ident
    raised, latency = interrupted(sim, lambda: signal.pthread_kill(main, signal.SIGINT),
                                  steps=steps)
    assert isinstance(raised, KeyboardInterrupt)
    print(f"threads={threads}: KeyboardInterrupt {latency * 1e3:.1f} ms after SIGINT, "
          f"at step {sim.step_count - WARMUP} of {steps}")
    assert latency < LATENCY_BOUND
    done = sim.step_count - WARMUP
    assert 0 < done < steps
    assert sim.fused_step_count > fused
    assert sim.stopped and not sim.running
    assert sim.time == pytest.approx((WARMUP + done) * sim.dt, rel=1e-12)
    # The state is that of a run of exactly that many steps. (The rest runs on one thread,
    # which gives the same bits: two threads on a busy 2-core machine can be ten times slower.)
    sim.threads = 1
    same = lattice_scene(1)
    same.run(steps=WARMUP)
    same.run(steps=done)
    assert_same_bits(sim, same)
    sim.run(steps=steps - done)
    assert not sim.stopped
    assert_same_bits(sim, whole)


def test_request_stop_from_another_thread(reference):
    """request_stop() from a timer thread ends run(time=...) after its current step without an
    exception (``stopped`` says so); running the remaining steps gives the reference's bits."""
    steps, whole = reference
    sim = lattice_scene(1)
    sim.run(steps=WARMUP)
    raised, _ = interrupted(sim, sim.request_stop, time=steps * sim.dt)
    assert raised is None
    done = sim.step_count - WARMUP
    assert 0 < done < steps and sim.stopped
    sim.run(steps=steps - done)
    assert_same_bits(sim, whole)


def small_scene() -> tsubu.Simulation:
    """500 frictional spheres falling onto a floor: a few tens of microseconds a step."""
    rng = np.random.default_rng(3)
    grid = np.stack(np.meshgrid(*[np.arange(8)] * 2, np.arange(8), indexing="ij"), -1).reshape(-1, 3)
    sim = tsubu.Simulation(dt=1e-6, threads=1)
    mat = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)
    sim.add_spheres((grid + 0.5) * 1.05e-3, 0.5e-3, mat,
                    velocities=rng.normal(0.0, 0.2, (len(grid), 3)))
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=mat)
    return sim


def test_request_between_runs_stops_the_next_run_before_its_first_step():
    sim = small_scene()
    sim.run(steps=3)
    sim.request_stop()
    sim.run(steps=100)
    assert sim.stopped and sim.step_count == 3
    sim.run(steps=5)  # the request is gone
    assert not sim.stopped and sim.step_count == 8


def test_a_signal_handler_that_raises_stops_the_run_with_its_exception():
    """Any exception a Python signal handler raises during run stops it the same way; here the
    handler reads the Simulation, which its own run refuses (its state is mid-step)."""
    sim = small_scene()
    seen = []

    def handler(signum, frame):
        seen.append(signum)
        sim.positions  # noqa: B018 (refused: raises)

    previous = signal.signal(signal.SIGINT, handler)
    try:
        main = threading.main_thread().ident
        timer = threading.Timer(0.1, signal.pthread_kill, (main, signal.SIGINT))
        timer.start()
        with pytest.raises(RuntimeError, match="own run"):
            sim.run(steps=2_000_000)
        timer.join()
    finally:
        signal.signal(signal.SIGINT, previous)
    assert seen == [signal.SIGINT]
    assert 0 < sim.step_count < 2_000_000 and sim.stopped
    assert np.all(np.isfinite(sim.positions))


def test_a_run_with_progress_stops_on_request(capsys):
    """run(progress=True) runs in chunks; a stop requested during any of them ends the run."""
    pytest.importorskip("tqdm.auto")  # imported before the timer starts: not inside its 0.1 s
    sim = small_scene()
    timer = threading.Timer(0.1, sim.request_stop)
    timer.start()
    sim.run(steps=2_000_000, progress=True)
    timer.join()
    assert sim.stopped and 0 < sim.step_count < 2_000_000
    assert "tsubu" in capsys.readouterr().err  # the bar (its fields: tests/test_run_hooks.py)

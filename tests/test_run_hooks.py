"""The run loop between steps (issue 19): hooks act at the steps they ask for, a run cut into
stretches by them gives the same bits, and the progress bar shows only where it should."""

from __future__ import annotations

import re
import sys

import numpy as np
import pytest

import tsubu
from tsubu import hooks

from bits import assert_same_bits


def pile(threads: int = 1) -> tsubu.Simulation:
    bead = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5, roughness=3.0)
    sim = tsubu.Simulation(threads=threads, seed=3, parallel_min=0)
    i, j, k = np.meshgrid(np.arange(5), np.arange(5), np.arange(8), indexing="ij")
    x = (np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1) + 0.5) * 1.05e-3
    sim.add_spheres(x, 0.5e-3, bead, velocities=np.random.default_rng(0).uniform(-0.05, 0.05, x.shape))
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=bead, velocity=(0.02, 0, 0))
    return sim


class Every:
    """Acts every k steps, never twice at one step; records what it saw."""

    def __init__(self, k: int):
        self.k, self.steps, self.mean_z, self.closed = k, [], [], 0

    def next_step(self, sim):
        now = sim.step_count
        due = -(-now // self.k) * self.k
        return due + self.k if self.steps and self.steps[-1] == due else due

    def act(self, sim):
        self.steps.append(sim.step_count)
        self.mean_z.append(sim.positions[:, 2].mean())

    def close(self, sim):
        self.closed += 1


def test_hooks_act_at_their_steps_across_runs():
    sim, every = pile(), Every(70)
    sim.run(steps=300, output=every)
    sim.run(steps=200, output=[every])
    assert every.steps == list(range(0, 501, 70))
    assert every.closed == 2


def test_stretches_do_not_change_the_bits():
    """A hook every 7 steps cuts the run into 7-step stretches: the same bits as one run."""
    plain = pile().run(steps=3000)
    cut = pile().run(steps=3000, output=Every(7))
    assert_same_bits(plain, cut)


def test_a_hook_may_change_the_scene():
    """A hook adds a sphere at step 100: the run goes on with it."""
    sim = pile()

    class AddOne(Every):
        def act(self, sim):
            super().act(sim)
            if sim.step_count == 100:
                sim.add_sphere((2e-3, 2e-3, 12e-3), 0.5e-3, sim.materials[0])

    sim.run(steps=200, output=AddOne(100))
    assert sim.size == 201 and sim.positions[200, 2] < 12e-3


def test_a_hook_that_does_not_move_on_is_refused():
    class Stuck(Every):
        def next_step(self, sim):
            return sim.step_count

    with pytest.raises(RuntimeError, match="next_step must move on"):
        pile().run(steps=10, output=Stuck(1))


class Returns(Every):
    """A hook whose next_step returns a fixed value until it has acted, then None."""

    def __init__(self, value):
        super().__init__(1)
        self.value = value

    def next_step(self, sim):
        return None if self.steps else self.value

    def __repr__(self):
        return "Returns()"


@pytest.mark.parametrize("value", [10.5, "10", 10.0, True, np.float64(10.0), [10]])
def test_a_next_step_that_is_not_an_int_is_named(value):
    """next_step must return an int step count or None: anything else gets a TypeError naming the
    hook and the value, not pybind11's message about run()'s arguments (issue 26)."""
    sim = pile()
    hook = Returns(value)
    with pytest.raises(TypeError, match=re.escape(f"run hook Returns(): next_step returned {value!r} "
                                                  f"({type(value).__name__})")):
        sim.run(steps=20, output=hook)
    assert sim.step_count == 0 and hook.closed == 1


@pytest.mark.parametrize("value", [10, np.int64(10), np.uint32(10), None])
def test_a_next_step_may_be_any_integer(value):
    hook = Returns(value)
    sim = pile().run(steps=20, output=hook)
    assert sim.step_count == 20 and hook.steps == ([] if value is None else [10])


def test_close_runs_when_the_run_fails():
    class Boom(Every):
        def act(self, sim):
            super().act(sim)
            if sim.step_count == 20:
                raise ZeroDivisionError("boom")

    boom = Boom(10)
    with pytest.raises(ZeroDivisionError):
        pile().run(steps=100, output=boom)
    assert boom.closed == 1 and boom.steps == [0, 10, 20]


@pytest.mark.parametrize("bad, name", [(object(), "output"), ([Every(3), 5], r"output\[1\]")])
def test_a_non_hook_is_named(bad, name):
    with pytest.raises(TypeError, match=name):
        pile().run(steps=1, output=bad)


def test_run_inside_a_hook_is_refused():
    class Again(Every):
        def act(self, sim):
            sim.run(steps=1)

    with pytest.raises(RuntimeError, match="own run"):
        pile().run(steps=5, output=Again(2))


# ---- progress ------------------------------------------------------------------------------

def test_no_bar_in_a_pipe(capsys):
    pile().run(steps=2000)
    assert capsys.readouterr().err == ""


def test_a_bar_when_asked(capsys):
    pile().run(steps=2000, progress=True)
    err = capsys.readouterr().err
    assert "2000/2000" in err and "particle-steps/s" in err and "t = " in err


def test_the_bar_shows_current_rates_in_one_unit_and_whole_run_means_at_the_end(capsys):
    """During the run, steps/s and particle-steps/s are both current (the second is the sphere
    count times the first), not a current step rate beside a whole-run particle-step average;
    the final line shows both as whole-run means, marked so (issue 26)."""
    pytest.importorskip("tqdm")
    sim = pile()  # 200 spheres
    clock = [0.0]
    bar = hooks.ProgressBar(sim, steps=3000, delay=0.0, clock=lambda: clock[0])
    sim._core.run(100)
    clock[0] = 1.0
    bar.update(100, 0.5)  # 100 steps in 1 s of wall time
    assert bar.bar.postfix == f"t = {sim.time:.4g} s, 200 spheres, 100 step/s, 0.02 M particle-steps/s"
    sim._core.run(300)
    clock[0] = 2.0
    bar.update(300, 0.5)  # 300 steps in 1 s: smoothed, 0.3 * 300 + 0.7 * 100 = 160 steps per second
    assert bar.bar.postfix.endswith(", 200 spheres, 160 step/s, 0.032 M particle-steps/s")
    clock[0] = 4.0
    bar.close()  # 400 steps in 4 s
    last = capsys.readouterr().err.split("\r")[-1]
    assert "400/3000" in last
    assert "200 spheres, mean 100 step/s, 0.02 M particle-steps/s" in last


def test_the_bar_ends_at_the_steps_done_when_ctrl_c_cuts_a_stretch(capsys):
    """Ctrl-C during a stretch: the bar's final count is the steps actually done, those of the
    cut stretch included, not the count of the last update (issue 26)."""
    pytest.importorskip("tqdm")
    sim = pile()
    asked = []

    def advance(steps):  # the third stretch takes 2 steps, then Ctrl-C
        asked.append(steps)
        if len(asked) < 3:
            return sim._core.run(steps)
        sim._core.run(2)
        raise KeyboardInterrupt

    sim._advance = advance
    with pytest.raises(KeyboardInterrupt):
        sim.run(steps=1000, progress=True)
    assert sim.step_count == asked[0] + asked[1] + 2
    last = capsys.readouterr().err.split("\r")[-1]
    assert f"| {sim.step_count}/1000 [" in last and f"t = {sim.time:.4g} s" in last


def test_on_by_default_only_in_an_interactive_terminal(monkeypatch):
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.delenv("TSUBU_NO_PROGRESS", raising=False)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    assert hooks.interactive()
    monkeypatch.setenv("CI", "true")
    assert not hooks.interactive()
    monkeypatch.delenv("CI")
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False, raising=False)
    assert not hooks.interactive()


def test_without_tqdm(monkeypatch):
    monkeypatch.setitem(sys.modules, "tqdm", None)
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)
    with pytest.raises(ImportError, match=r"pip install 'tsubu\[progress\]'"):
        pile().run(steps=10, progress=True)
    monkeypatch.setattr(hooks, "interactive", lambda: True)
    pile().run(steps=10)  # the default quietly shows none


def test_progress_must_be_a_bool():
    with pytest.raises(TypeError, match="progress"):
        pile().run(steps=1, progress="yes")

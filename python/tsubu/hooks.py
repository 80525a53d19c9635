"""What a run calls between its steps: the hook protocol, the progress bar, periodic checkpoints.

A *hook* is any object with three methods; :meth:`tsubu.Simulation.run` takes them in its
``output`` argument, and the inserters of :meth:`tsubu.Simulation.add_inserter` are hooks the
Simulation keeps::

    class Hook:
        def next_step(self, sim) -> int | None:
            '''The step count (>= sim.step_count) at which act() must next be called, or None.'''
        def act(self, sim) -> None:
            '''Called when sim.step_count equals what next_step returned: the state is that of a
            completed step. Afterwards next_step must return a later step, or None.'''
        def close(self, sim) -> None:
            '''Called once when the run returns or raises.'''

A run asks every hook for its next step before each stretch of steps, advances to the earliest
one (or the end of the run), and lets the hooks due there act: inserters first, then output
hooks in the order given, then the periodic checkpoint. Stretches are independent of the
results: a run cut into stretches gives the same bits as one that is not.
"""

from __future__ import annotations

import os
import sys
import time as _time
from pathlib import Path
from typing import Protocol

import numpy as np

# The rest of this module is the run loop's own machinery (progress bar, periodic checkpoints).
__all__ = ["Hook"]


class Hook(Protocol):
    """The protocol of a run hook: any object with these three methods (no need to subclass).

    Each method takes the running :class:`tsubu.Simulation` as its one argument, ``sim``. The
    writers of :mod:`tsubu.output` and :class:`tsubu.insert.Inserter` are hooks. Hooks that only
    read the state leave the run's results unchanged, bit for bit. Example: record the kinetic
    energy every 100 steps::

        class EnergyLog:
            def __init__(self):
                self.energies, self.last = [], None

            def next_step(self, sim):
                due = -(-sim.step_count // 100) * 100  # the next multiple of 100
                return due if due != self.last else due + 100

            def act(self, sim):
                self.energies.append(sim.energy()["kinetic"])
                self.last = sim.step_count

            def close(self, sim):
                pass

        sim.run(time=0.1, output=EnergyLog())
    """

    def next_step(self, sim) -> "int | None":
        """The absolute step count (>= ``sim.step_count``), an int (Python's or numpy's; a
        float, bool or string ends the run with a TypeError naming the hook), at which
        :meth:`act` must next be called, or None for never. Called before every stretch of the run, so the answer may
        change as the run goes on. A hook that writes every k steps returns the next multiple
        of k, the current step included unless it has already acted there (two consecutive
        runs must not act twice at the same step)."""
        ...

    def act(self, sim) -> None:
        """Called when ``sim.step_count`` equals what :meth:`next_step` returned: the state is
        that of a completed step, every array readable. The hook may read the state, write
        files, add spheres or move walls. Afterwards :meth:`next_step` must return a later step
        (or None). An exception raised here ends the run (:meth:`close` is still called)."""
        ...

    def close(self, sim) -> None:
        """Called once when the run returns or raises (Ctrl-C included): flush and close files.
        A hook given to several runs is closed at the end of each."""
        ...


def check_hook(hook, name: str = "output") -> None:
    """TypeError naming ``name`` unless ``hook`` has the three methods of a hook."""
    missing = [m for m in ("next_step", "act", "close") if not callable(getattr(hook, m, None))]
    if missing:
        raise TypeError(f"{name} must be a run hook (an object with next_step, act and close "
                        f"methods, such as tsubu.output.VTKOutput), got {hook!r}: it has no "
                        f"{', '.join(missing)}")


def due_step(hook, sim) -> "int | None":
    """``hook.next_step(sim)``, checked: None, or a step count as an int (Python's or numpy's
    integers; not a bool, a float such as 10.0 or 10.5, or a string). TypeError naming the hook
    and the value otherwise."""
    due = hook.next_step(sim)
    if due is None:
        return None
    if isinstance(due, (bool, np.bool_)) or not isinstance(due, (int, np.integer)):
        raise TypeError(f"run hook {hook!r}: next_step returned {due!r} ({type(due).__name__}); it "
                        "must return a whole step count as an int (the step at which act is due, "
                        ">= sim.step_count) or None")
    return int(due)


def interactive() -> bool:
    """Whether a progress bar belongs on stderr by default: a terminal, not CI, not a notebook."""
    if os.environ.get("CI") or os.environ.get("TSUBU_NO_PROGRESS"):
        return False
    if "ipykernel" in sys.modules:
        return False
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


class ProgressBar:
    """A tqdm bar over the steps of a run: steps done and total, the time elapsed and left, and
    the simulated time, the sphere count, steps/s and particle-steps/s.

    While the run goes on both rates are *current* ones, over the wall time since the previous
    update (smoothed over the last few updates): particle-steps/s is the sphere count times
    steps/s. The final line, when the bar closes, shows both as averages over the whole run,
    marked "mean", and the steps actually done (a run stopped by Ctrl-C, an error or
    ``request_stop`` shows where it stopped).

    ``delay``: seconds before the bar shows (a short run shows none). The run advances in
    stretches of about ``refresh`` seconds of wall time between updates.
    """

    # The weight of the newest update in the current rates (as tqdm's own smoothing).
    SMOOTHING = 0.3

    def __init__(self, sim, steps: int, delay: float, refresh: float = 0.2, clock=_time.perf_counter):
        try:
            from tqdm.auto import tqdm
        except ImportError:
            raise ImportError("progress=True needs tqdm: install it with "
                              "pip install 'tsubu[progress]' (or pip install tqdm)") from None
        self.sim = sim
        self.refresh = refresh
        self.clock = clock
        # tqdm's own rate (an average over its refreshes) is left out: the rates are the
        # postfix's, both measured over the same updates.
        self.bar = tqdm(total=steps, unit="step", delay=delay, dynamic_ncols=True, desc="tsubu",
                        leave=True, file=sys.stderr,
                        bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}<{remaining}{postfix}]")
        self.start = self.last = clock()
        self.first_step = sim.step_count
        self.counted = 0  # steps shown so far
        self.particle_steps = 0  # sum of the sphere count over the steps shown
        self.recent_steps = self.recent_seconds = 0.0  # smoothed steps and seconds per update
        self.stretch = 1  # steps per stretch, grown to about `refresh` seconds each

    def limit(self, now: int) -> int:
        """The last step the next stretch may reach."""
        return now + self.stretch

    def update(self, taken: int, seconds: float) -> None:
        """``taken`` more steps, of which the engine spent ``seconds`` [s] (sizes the next
        stretch); the rates are measured on the wall clock (hooks included)."""
        now = self.clock()
        if taken > 0 and seconds > 0:
            per_step = seconds / taken
            self.stretch = max(1, min(int(self.refresh / per_step), 4 * self.stretch))
        wall = now - self.last
        self.last = now
        if wall > 0:
            a = self.SMOOTHING if self.recent_seconds > 0 else 1.0
            self.recent_steps = a * taken + (1 - a) * self.recent_steps
            self.recent_seconds = a * wall + (1 - a) * self.recent_seconds
        rate = self.recent_steps / self.recent_seconds if self.recent_seconds > 0 else None
        # the postfix first: tqdm's update may redraw the bar, which should show this stretch's
        self.bar.set_postfix_str(self._rates(rate, None if rate is None else rate * self.sim.size),
                                 refresh=False)
        self._count(taken)

    def _count(self, taken: int) -> None:
        self.bar.update(taken)
        self.counted += taken
        self.particle_steps += self.sim.size * taken

    def _rates(self, steps_per_second, particle_steps_per_second, mean: bool = False) -> str:
        text = f"t = {self.sim.time:.4g} s, {self.sim.size} spheres"
        if steps_per_second is not None:
            label = "mean " if mean else ""
            steps = f"{steps_per_second:,.0f}" if steps_per_second >= 100 else f"{steps_per_second:.3g}"
            text += (f", {label}{steps} step/s, "
                     f"{particle_steps_per_second / 1e6:.3g} M particle-steps/s")
        return text

    def close(self) -> None:
        """The final line: the steps actually done (also those of a stretch that Ctrl-C or an
        error cut short) and the whole run's mean rates."""
        done = self.sim.step_count - self.first_step
        if done != self.counted:  # a stretch ended by an exception: its steps never counted
            self.bar.n = done
            self.particle_steps += self.sim.size * (done - self.counted)
            self.counted = done
        elapsed = self.clock() - self.start
        if elapsed > 0 and done > 0:
            self.bar.set_postfix_str(self._rates(done / elapsed, self.particle_steps / elapsed,
                                                 mean=True), refresh=False)
        self.bar.close()


def progress_bar(sim, steps: int, progress) -> "ProgressBar | None":
    """The bar a run shows: ``progress`` None (default) shows one, after 2 s, on an
    interactive terminal when tqdm is installed; True always (after 0.5 s; ImportError without
    tqdm); False never."""
    if progress is None:
        if not interactive():
            return None
        try:
            return ProgressBar(sim, steps, delay=2.0)
        except ImportError:
            return None
    if not isinstance(progress, bool):
        raise TypeError(f"progress must be True, False or None, got {progress!r}")
    return ProgressBar(sim, steps, delay=0.0) if progress else None


def numbered(path: Path, step: int) -> Path:
    """``run.tsubu`` at step 1200 -> ``run.step000000001200.tsubu`` (sorts by step)."""
    return path.with_name(f"{path.stem}.step{step:012d}{path.suffix}")


class PeriodicCheckpoint:
    """A hook that saves a checkpoint every ``every`` steps to numbered files beside ``path``
    (see :func:`numbered`), keeping the newest ``keep``."""

    def __init__(self, path: Path, every: int, keep: int):
        self.path = path
        self.every = every
        self.keep = keep
        self.last = None

    def next_step(self, sim) -> int:
        now = sim.step_count
        due = -(-now // self.every) * self.every
        return due if due != self.last else due + self.every

    def act(self, sim) -> None:
        step = sim.step_count
        sim.save(numbered(self.path, step))
        self.last = step
        stem, suffix = self.path.stem + ".step", self.path.suffix
        old = sorted(p for p in self.path.parent.glob(f"{glob_escape(stem)}*{glob_escape(suffix)}")
                     if p.name[len(stem):len(p.name) - len(suffix)].isdigit())
        for p in old[:-self.keep]:
            p.unlink(missing_ok=True)

    def close(self, sim) -> None:
        pass


def glob_escape(text: str) -> str:
    return "".join(f"[{c}]" if c in "*?[]" else c for c in text)

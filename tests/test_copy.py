"""Copies and pickles of a Simulation (issue 26, item 4): copy.copy used to return an alias
(running the copy advanced the original) and pickle and copy.deepcopy failed ("cannot pickle
'_thread.RLock'"). All three now go through the checkpoint format: an independent Simulation
whose runs continue bit for bit as the original's."""

from __future__ import annotations

import copy
import pickle
import threading
import time

import numpy as np
import pytest

import tsubu
from tsubu import fill

from bits import assert_same_bits


def pile(threads: int = 1) -> tsubu.Simulation:
    """64 rough, frictional beads (rolling friction too) falling into a box whose floor slides
    and whose side wall turns, a pair override between beads and walls: every kind of state a
    checkpoint carries."""
    bead = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5,
                          rolling_friction=0.1, roughness=5.0, name="bead")
    wall = tsubu.Material(density=2500.0, kn=2e3, restitution=0.6, friction=0.3, name="wall")
    sim = tsubu.Simulation(threads=threads, seed=7, parallel_min=0)
    i, j, k = np.meshgrid(np.arange(4), np.arange(4), np.arange(4), indexing="ij")
    x = (np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1) + 0.5) * 1.02e-3
    sim.add_spheres(x, 0.5e-3, bead,
                    velocities=np.random.default_rng(1).uniform(-0.05, 0.05, x.shape))
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=wall, velocity=(0.01, 0, 0))
    sim.add_plane(point=(0, 0, 0), normal=(1, 0, 0), material=wall, angular_velocity=(0, 0.2, 0))
    sim.add_plane(point=(4.08e-3, 0, 0), normal=(-1, 0, 0), material=wall)
    sim.set_pair(bead, wall, friction=0.8)
    sim.metadata = {"scene": "pile", "n": [1, 2.5]}
    return sim


def pickled(sim):
    return pickle.loads(pickle.dumps(sim))


COPIES = {"copy": copy.copy, "deepcopy": copy.deepcopy, "pickle": pickled}


@pytest.mark.parametrize("how", COPIES)
def test_a_copy_continues_bit_for_bit(how):
    """Run A 4000 steps (beads piled on the floor: contacts with history and roughness draws),
    copy it to B, run both 1500 more: the same bits; and A is the run that never was copied."""
    a = pile().run(steps=4000)
    assert len(a.contacts()["i"]) > 20
    b = COPIES[how](a)
    assert b is not a and b._core is not a._core
    assert_same_bits(a, b)
    assert np.array_equal(a.contacts()["tangential_displacement"],
                          b.contacts()["tangential_displacement"])
    a.run(steps=1500)
    b.run(steps=1500)
    assert_same_bits(a, b)
    assert_same_bits(a, pile().run(steps=5500))
    assert b.metadata == a.metadata and b.metadata is not a.metadata
    assert (b.threads, b.seed, b.dt) == (a.threads, a.seed, a.dt)


@pytest.mark.parametrize("how", COPIES)
def test_a_copy_is_independent(how):
    """Running or changing the copy leaves the original as it was (copy.copy was an alias)."""
    a = pile().run(steps=100)
    x, step = a.positions, a.step_count
    b = COPIES[how](a)
    b.run(steps=50)
    b.gravity = (0.0, 0.0, 0.0)
    b.metadata["scene"] = "changed"
    b.add_sphere((0.0, 0.0, 0.02), 0.5e-3, b.materials[0])
    assert a.step_count == step and np.array_equal(a.positions, x)
    assert np.array_equal(a.gravity, (0.0, 0.0, -9.81)) and a.metadata["scene"] == "pile"
    assert len(a) == 64 and len(b) == 65


def test_materials_are_shared_by_copy_and_copied_by_deepcopy_and_pickle():
    """copy.copy shares the (immutable) materials: the original's Material adds spheres of the
    same index and pair override to the copy. deepcopy and pickle copy them, keeping their
    identity within what is copied together."""
    a = pile().run(steps=10)
    bead, wall = a.materials
    b = copy.copy(a)
    assert b.materials[0] is bead and b.materials[1] is wall
    b.add_sphere((0.0, 0.0, 0.02), 0.5e-3, bead)
    assert len(b.materials) == 2 and b.material_ids[-1] == 0
    assert b.pair_parameters(bead, wall)["friction"] == 0.8
    for twin, twin_bead in (copy.deepcopy((a, bead)), pickled((a, bead))):
        assert twin.materials[0] is twin_bead and twin_bead is not bead
        assert twin_bead.name == "bead" and twin_bead.kn == bead.kn
        assert twin.pair_parameters(twin_bead, twin.materials[1])["friction"] == 0.8


def test_inserters_are_copied_with_their_progress():
    """A copy carries its own inserters, at the original's progress: both pour on alike."""
    glass = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)
    a = tsubu.Simulation(seed=3)
    a.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=glass)
    inserter = a.add_inserter(fill.Box((0, 0, 2e-3), (4e-3, 4e-3, 6e-3)), rate=5e3,
                              sizes=fill.Uniform(0.3e-3, 0.5e-3), material=glass,
                              interval=2e-4, total=60, seed=5)
    a.run(steps=2000)
    assert 0 < inserter.inserted < 60
    b = copy.deepcopy(a)
    assert b.inserters[0] is not inserter and b.inserters[0].inserted == inserter.inserted
    before = inserter.inserted
    a.run(steps=3000)
    b.run(steps=3000)
    assert inserter.inserted == b.inserters[0].inserted > before
    assert_same_bits(a, b)


def test_an_overlap_not_yet_checked_is_checked_in_the_copy():
    """A sphere added into another after the first run: the copy's next run refuses it, as the
    original's does."""
    a = pile().run(steps=10)
    a.add_sphere(a.positions[0] + (0.9e-3, 0.0, 0.0), 0.5e-3, a.materials[0])
    for sim in (copy.copy(a), pickled(a), a):
        with pytest.raises(ValueError, match=r"spheres 0 and 64 overlap.*sphere 64 was added"):
            sim.run(steps=1)


def test_metadata_that_is_not_json_able_is_refused():
    a = pile()
    a.metadata = {"when": object()}
    for how in COPIES.values():
        with pytest.raises(TypeError, match=r"metadata must be JSON-able.*copy or pickle"):
            how(a)


class CopyAt:
    """A run hook that deep-copies the Simulation at one step."""

    def __init__(self, step: int):
        self.step, self.copy = step, None

    def next_step(self, sim):
        return self.step if self.copy is None else None

    def act(self, sim):
        self.copy = copy.deepcopy(sim)

    def close(self, sim):
        pass


def test_a_copy_made_by_a_run_hook_continues_bit_for_bit():
    a = pile()
    hook = CopyAt(700)
    a.run(steps=1000, output=hook)
    assert hook.copy.step_count == 700 and not hook.copy.running
    assert_same_bits(a, hook.copy.run(steps=300))


def test_a_running_simulation_is_not_copied():
    """From another thread during a run: RuntimeError naming save/load, the run unharmed."""
    sim = pile()
    errors = []

    def work():
        try:
            sim.run(steps=10_000_000)
        except BaseException as e:  # noqa: BLE001 (checked below)
            errors.append(e)

    worker = threading.Thread(target=work)
    worker.start()
    try:
        deadline = time.monotonic() + 10.0
        while not (sim.running and sim.step_count > 0) and time.monotonic() < deadline:
            time.sleep(0.001)
        for how in COPIES.values():
            with pytest.raises(RuntimeError, match=r"copied or pickled while it runs.*save.*load"):
                how(sim)
        assert sim.running
    finally:
        sim.request_stop()
        worker.join(timeout=60)
    assert errors == [] and sim.stopped
    assert_same_bits(copy.copy(sim), pile().run(steps=sim.step_count))

"""Requests that cannot fit are refused up front (MemoryError or ValueError naming what and why),
and spheres spread over kilometres run in memory proportional to their number. Settings that a
typo makes absurd -- thousands of threads, a skin of kilometres, a wall faster than light, a
run shorter than a step -- are refused or warned about (tsubu.PerformanceWarning)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import tsubu
from tsubu import _checks, _core, simulation


def test_available_memory_is_a_positive_figure():
    assert _core.available_memory() > 0


def test_spheres_beyond_memory_are_refused_before_copying():
    # A broadcast view costs nothing; its copy would need far more than any machine has.
    huge = np.broadcast_to(np.zeros(3), (10**13, 3))
    sim = tsubu.Simulation()
    with pytest.raises(MemoryError, match=r"positions: 10000000000000 rows need about .* GiB"):
        sim.add_spheres(huge, 1e-3, tsubu.Material())
    assert sim.size == 0


def test_reserve_beyond_memory_is_refused():
    sim = tsubu.Simulation()
    with pytest.raises(MemoryError, match=r"count: 1000000000000000 spheres .* more than the .* GiB"):
        sim.reserve(10**15)
    with pytest.raises(ValueError, match=r"count must be <= 2\*\*62|count must be <= 4611686018427387904"):
        sim.reserve(2**70)


def test_memory_estimate_is_a_lower_bound_of_what_a_sphere_costs():
    # BYTES_PER_SPHERE refuses only what cannot fit: it covers the particle arrays and stays below
    # what a sphere of a dense pack costs with its lists.
    sim = tsubu.Simulation(threads=1, dt=1e-6, gravity=(0, 0, 0))
    side = 12
    g = np.arange(side) * 2.02e-3
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    sim.add_spheres(x, 1e-3, tsubu.Material())
    sim.run(steps=1)
    held = sim.memory_bytes()
    assert held["particles"] < _checks.BYTES_PER_SPHERE * sim.size < sum(held.values())


def test_neighbour_list_that_cannot_fit_is_refused_with_the_state_kept():
    # 20,000 spheres 2 mm apart with a 1 km skin: every pair would be in the list, 2e8 pairs of
    # over 100 bytes each, more than the 32-bit indices (and most machines' memory) hold.
    n = 20_000
    x = np.column_stack([np.arange(n) * 2e-3, np.zeros(n), np.zeros(n)])
    sim = tsubu.Simulation(threads=1, dt=1e-6, skin=1e3, gravity=(0, 0, 0))
    sim.add_spheres(x, 0.5e-3, tsubu.Material(), velocities=np.full((n, 3), 1e-3))
    before = sim.positions.copy()
    with pytest.raises(MemoryError, match=r"neighbour list of 20000 spheres would hold over .* pairs"
                                          r".*skin 1000\.0+ m"):
        sim.run(steps=1)
    np.testing.assert_array_equal(sim.positions, before)
    assert sim.step_count == 0
    sim2 = tsubu.Simulation(threads=1, dt=1e-6, skin=1e3)
    sim2.add_spheres(x, 0.5e-3, tsubu.Material())
    with pytest.raises(MemoryError, match="neighbour list"):
        sim2.rebuild_neighbors()


def test_huge_radius_among_small_spheres_runs():
    # One boulder (1 m) above a layer of 2,000 pebbles (0.1 mm): the cells are 2 m wide and every
    # pebble is a candidate of every other, but the list holds only the close pairs and fits.
    n = 2000
    rng = np.random.default_rng(3)
    pebbles = rng.uniform(-0.5, 0.5, (n, 3)) * [1, 1, 0.01]
    sim = tsubu.Simulation(threads=1, dt=1e-6, gravity=(0, 0, 0))
    sim.add_spheres([[0, 0, 1.2]], 1.0, tsubu.Material())
    sim.add_spheres(pebbles[np.argsort(pebbles[:, 0])], 1e-4, tsubu.Material())
    sim.run(steps=2)
    assert np.isfinite(sim.positions).all()
    assert sim.size == n + 1 and sim.memory_bytes()["verlet list"] < 1000 * sim.size


def _kilometres_apart(n_cluster: int, spread: float):
    """A dense cluster of n_cluster spheres (radius 1 mm) and 3 lone spheres ``spread`` m away."""
    side = round(n_cluster ** (1 / 3))
    g = np.arange(side) * 2.1e-3
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    lone = np.array([[spread, 0, 0], [0, spread, 0], [-spread, -spread, spread]])
    sim = tsubu.Simulation(threads=1, dt=1e-6, gravity=(0, 0, 0))
    sim.add_spheres(np.vstack([x, lone]), 1e-3, tsubu.Material(),
                    velocities=np.random.default_rng(1).normal(0, 1e-3, (len(x) + 3, 3)))
    return sim


@pytest.mark.parametrize("spread", [5e3, 1e12, 1e300])
def test_spheres_kilometres_apart_run_in_memory_proportional_to_n(spread):
    sim = _kilometres_apart(1000, spread)
    sim.run(steps=20)
    near = _kilometres_apart(1000, 0.1)
    near.run(steps=20)
    # The same engine arrays as a compact scene, give or take the sparse grid's keys.
    spread_bytes = sum(sim.memory_bytes().values())
    compact_bytes = sum(near.memory_bytes().values())
    assert spread_bytes < 1.5 * compact_bytes + 64 * sim.size
    assert np.isfinite(sim.positions).all()
    # The cluster keeps its neighbours: the sparse grid does not widen the cells.
    assert len(sim.neighbor_pairs()) == len(near.neighbor_pairs())


def test_sparse_grid_finds_the_same_pairs_as_the_dense_one():
    # The same cluster with and without a far sphere (which switches the grid to sparse): the
    # cluster's neighbour pairs and end state agree bit for bit.
    rng = np.random.default_rng(7)
    x = rng.uniform(0, 0.02, (400, 3))
    x = x[np.all(np.linalg.norm(x[:, None] - x[None], axis=-1) + np.eye(len(x)) > 2.2e-3, axis=1)]
    ends = []
    for extra in (None, [[4e3, 0, 0]]):
        sim = tsubu.Simulation(threads=1, dt=1e-6, gravity=(0, 0, -9.81))
        sim.add_spheres(x, 1e-3, tsubu.Material(), velocities=rng.normal(0, 0.05, x.shape) * 0)
        if extra is not None:
            sim.add_spheres(extra, 1e-3, tsubu.Material())
        sim.run(steps=200)
        ends.append((sim.positions[: len(x)], sim.neighbor_pairs()))
    np.testing.assert_array_equal(ends[0][0], ends[1][0])
    np.testing.assert_array_equal(ends[0][1], ends[1][1])


def test_absurd_sizes_are_refused_naming_the_argument():
    sim = tsubu.Simulation()
    with pytest.raises(ValueError, match="threads must be <= 4096"):
        sim.threads = 2**40
    with pytest.raises(ValueError, match="parallel_min must be <="):
        tsubu.Simulation(parallel_min=2**70)
    with pytest.raises(ValueError, match="steps must be <="):
        sim.run(steps=2**70)
    sim.dt = 1e-300
    with pytest.raises(ValueError, match=r"time=1e\+300 s is inf steps"):
        sim.run(time=1e300)


# ---- settings a typo makes absurd ------------------------------------------------------------------

@pytest.fixture
def two_cores(monkeypatch):
    """The machine gives the process 2 hardware threads, whatever it really has."""
    monkeypatch.setattr(simulation, "_hardware_threads", lambda: 2)


def test_threads_far_beyond_the_hardware_warn_naming_the_count(two_cores):
    # 4096 threads on 2 cores ran 2600x slower than 1, with no word.
    with pytest.warns(tsubu.PerformanceWarning, match=r"threads=4096 is more than 2x the 2 hardware "
                                                       r"thread\(s\).*os\.cpu_count\(\) = \d+.*at most 2"):
        sim = tsubu.Simulation(threads=4096)
    assert sim.threads == 4096  # warned, not changed: the results are the same bits anyway
    with pytest.warns(tsubu.PerformanceWarning, match="threads=5 "):
        sim.threads = 5
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.threads = 4  # twice the cores: a few more threads than cores cost little
        sim.threads = None


def test_threads_of_a_loaded_checkpoint_warn_too(two_cores, tmp_path):
    sim = tsubu.Simulation(threads=1)
    sim.add_sphere((0, 0, 0), 1e-3, tsubu.Material())
    sim.save(tmp_path / "a.tsubu")
    with pytest.warns(tsubu.PerformanceWarning, match="threads=64 "):
        tsubu.Simulation.load(tmp_path / "a.tsubu", threads=64)


def test_the_threads_warning_points_at_the_callers_line(two_cores):
    with pytest.warns(tsubu.PerformanceWarning) as record:
        tsubu.Simulation(threads=100)
    assert record[0].filename == __file__


def _scattered(n, skin, seed=0):
    """n spheres of radius 1 mm scattered in a 1 m cube (a dilute gas: few neighbours at a fitting
    skin), no gravity."""
    x = np.random.default_rng(seed).uniform(0, 1, (n, 3))
    sim = tsubu.Simulation(threads=1, dt=1e-6, skin=skin, gravity=(0, 0, 0))
    sim.add_spheres(x, 1e-3, tsubu.Material())
    return sim


def test_a_skin_that_fills_the_neighbour_list_warns_before_the_run_steps():
    # skin = 1e6 m: every pair of 600 spheres is a neighbour (179,700 pairs, 300 per sphere,
    # where the scene built 4.2 GB the same way); the warning comes before the first
    # step, with the list's size.
    sim = _scattered(600, 1e6)
    with pytest.warns(tsubu.PerformanceWarning,
                      match=r"skin=1000000\.0 m is 5e\+08 times the largest diameter \(0\.002 m\): the "
                            r"neighbour list holds 179700 pairs, 300 per sphere.*GiB"):
        sim.run(steps=1)
    assert sim.step_count == 1  # a warning, not a refusal
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(tsubu.PerformanceWarning):
            sim.run(steps=5)  # every run() looks again
    assert sim.step_count == 1  # raised as an error, before stepping


def test_a_large_skin_that_keeps_the_list_small_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _scattered(600, 0.05).run(steps=2)  # 5 cm in a dilute gas: a few pairs per sphere
        _scattered(300, 1e6).run(steps=2)  # every pair, but only 44,850 of them
        _scattered(600, None).run(steps=2)  # the default skin


def test_a_wall_faster_than_light_is_refused_naming_the_velocity():
    # A wall sliding at 1e150 m/s lost its friction: |F_t|^2 overflowed to inf and the slip force
    # became 0, silently.
    sim = tsubu.Simulation()
    mat = tsubu.Material()
    with pytest.raises(ValueError, match=r"velocity must be at most the speed of light, 2\.99792e\+08 m/s, "
                                         r".*got \(1e\+150, 0, 0\) \(1e\+150 m/s\)"):
        sim.add_plane(material=mat, velocity=(1e150, 0, 0))
    wall = sim.add_plane(material=mat, velocity=(299_792_458.0, 0, 0))  # light speed itself: accepted
    with pytest.raises(ValueError, match=r"velocity must be at most the speed of light.*got \(0, 300000000\.0, 0\)"):
        sim.set_plane_motion(wall, velocity=(0, 3e8, 0))
    with pytest.raises(ValueError, match="faster than light"):  # the core refuses it too
        sim._core.set_plane_motion(wall, (0, 3e8, 0), (0, 0, 0))
    assert sim.plane(wall)["velocity"][0] == 299_792_458.0
    # A wall restored as it was saved (as an old checkpoint's may be) is checked when a run starts.
    sim.add_spheres([[0, 0, 1e-3], [0.01, 0, 1e-3]], 1e-3, mat)
    sim._core.set_plane_state(wall, (0, 0, 0), (0, 0, 1), (1e150, 0, 0), (0, 0, 0), 0)
    with pytest.raises(ValueError, match=r"wall 0: a wall's velocity of 1e\+150 m/s is faster than light"):
        sim.run(steps=1)


def test_a_wall_turning_faster_than_light_where_the_spheres_are_is_refused_when_a_run_starts():
    sim = tsubu.Simulation(dt=1e-6)
    mat = tsubu.Material()
    sim.add_sphere((2.0, 0, 1e-3), 1e-3, mat)
    wall = sim.add_plane(material=mat, angular_velocity=(0, 0, 1e9))  # 2e9 m/s at the sphere
    with pytest.raises(ValueError, match=r"wall 0 turns at 1e\+09 rad/s about a point 2 m from the "
                                         r"farthest sphere.*2e\+09 m/s there, faster than light"):
        sim.run(steps=1)
    assert sim.step_count == 0
    sim.set_plane_motion(wall, angular_velocity=(0, 0, 100.0))
    sim.run(steps=1)
    assert sim.step_count == 1


def test_a_run_shorter_than_half_a_step_is_refused_naming_time_and_dt():
    # run(time=0.4 dt) took 0 steps without a word.
    sim = tsubu.Simulation(dt=1e-4)
    sim.add_spheres([[0, 0, 0], [0.01, 0, 0]], 1e-3, tsubu.Material())
    with pytest.raises(ValueError, match=r"time=4e-05 s is shorter than half a step \(dt = 0\.0001 s\)"):
        sim.run(time=0.4e-4)
    sim.run(time=0)  # no step, as asked
    sim.run(time=0.6e-4)  # rounds to one step
    assert sim.step_count == 1

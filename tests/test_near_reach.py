"""The near list's reach (Simulation.near_reach): how far beyond contact the pairs the step
loop reads may lie.

A wider near list is refreshed less often but scanned at every step. At each refresh the
reach is chosen as the fraction f of the skin that makes the two costs least together
(near_list.cpp, NeighborList::choose_near_fraction):

    cost per step ~ c_s (N_0 + k f) + c_r N_verlet / T(f),   T(f) = f skin / (2 u),
    f* = sqrt((c_r / c_s) N_verlet 2 u / (skin k)),  kept within [1/10, 1/2],

with u the growth of the lists' displacement bound per step and k the Verlet pairs per unit f
beyond the last reach. A scene whose spheres barely move keeps skin/10 (the reach a sticky
contact needs); a fast one widens it. The lists' contents and every result are the same for
any reach: only the work changes, which these tests check bit for bit against a run that
rebuilds its lists at every step.
"""

from __future__ import annotations

import numpy as np
import pytest

import tsubu
from conftest import add_cube_walls

R = 0.5e-3
RHO = 2500.0
KN = 1.0e4


def gas_in_a_box(speed: float, rebuild_every_step: bool = False, seed: int = 3) -> tsubu.Simulation:
    """A 6 x 6 x 6 lattice of frictional spheres, 1.1 diameters apart, with random velocities of
    typical size `speed` [m/s], in a closed box of planes; no gravity."""
    rng = np.random.default_rng(seed)
    mat = tsubu.Material(density=RHO, kn=KN, restitution=0.7, friction=0.4)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), rebuild_every_step=rebuild_every_step, threads=1)
    pitch = 2.2 * R
    grid = np.stack(np.meshgrid(*(np.arange(6),) * 3, indexing="ij"), -1).reshape(-1, 3)
    sim.add_spheres((grid + 0.5) * pitch, R, mat, velocities=rng.normal(0.0, speed, (len(grid), 3)))
    add_cube_walls(sim, 6 * pitch, mat)
    return sim


def test_a_scene_that_barely_moves_keeps_a_tenth_of_the_skin():
    sim = gas_in_a_box(speed=0.03)
    sim.run(steps=3000)
    assert sim.near_refresh_count >= 10  # (refreshes chose it)
    assert sim.near_reach == pytest.approx(0.1 * sim.skin, rel=1e-12)


def test_a_fast_scene_widens_the_reach_within_half_the_skin():
    sim = gas_in_a_box(speed=2.0)
    reaches = []
    for _ in range(20):
        sim.run(steps=100)
        reaches.append(sim.near_reach / sim.skin)
    assert sim.near_refresh_count >= 10
    assert min(reaches) >= 0.1 - 1e-12 and max(reaches) <= 0.5 + 1e-12
    assert max(reaches) > 0.15  # (a gas: few near pairs per Verlet pair, many refreshes)


@pytest.mark.parametrize("speed", [0.05, 2.0])
def test_results_do_not_depend_on_the_reach(speed):
    """The adaptive reach against lists rebuilt (and refreshed, at reaches chosen from one step's
    motion) at every step: the same bits."""
    a, b = gas_in_a_box(speed), gas_in_a_box(speed, rebuild_every_step=True)
    a.run(steps=1500)
    b.run(steps=1500)
    assert a.near_refresh_count < b.near_refresh_count
    for name in ("positions", "velocities", "angular_velocities"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)

"""Large scenes take loops of their own, for memory rather than cache: from 65,536 spheres on
(engine/views.hpp, ContactView::kFar) the contact pass scans ahead until its block of contacts is
nearly full and requests the block's data together (engine/contact_pass.hpp, far_pairs), the
particle pass requests the sums' data in stages (ContactSums::prefetch), and steps are fused
(tests/test_fused_pass.py). None of it may change a result.

The check: a cluster of colliding spheres follows the same trajectory, bit for bit, whether it is
alone (2,197 spheres: the loops of a scene that stays in cache) or shares the scene with a
distant lattice that makes the scene large (67,797 spheres: the large-scene loops). The contacts
of a sphere, and the order in which its sums take them (fixed by ids, docs/architecture.md), do
not depend on spheres it never touches; nor do the threads or the neighbour lists' schedule.

Cluster: 13 x 13 x 13 spheres 1.05 mm apart with random velocities of 0.3 m/s (each sphere meets
its neighbours within a few hundred steps: a few hundred contacts at a time among ~4,000 near
entries, sparse as in the 1e6 lattice drop), frictional with tangential history, no gravity, no
walls. Lattice: 40 x 40 x 41 spheres 0.2 m away, at rest but for 1 mm/s of noise.

From 32,768 near pairs on (engine/views.hpp, ParticleView::kAskPairs) the particle pass's flat sums
request their entries' results ahead (ParticlePass::flat_sums). The same check holds: a pressed
cluster, whose sums are flat, moves the same alone and beside a pressed block of 13,500 spheres
(some 39,000 near pairs, fewer than 65,536 spheres).
"""

from __future__ import annotations

import numpy as np
import pytest

import tsubu

LARGE = 65_536  # spheres: ContactView::kFar
SPACING = 1.05e-3  # m
STEPS = 400
DT = 1.0e-6  # s


def lattice(side: tuple[int, int, int], spacing: float, origin) -> np.ndarray:
    grid = np.stack(np.meshgrid(*(np.arange(n) for n in side), indexing="ij"), -1).reshape(-1, 3)
    return (grid + 0.5) * spacing + np.asarray(origin, dtype=float)


def scene(with_lattice: bool, threads: int, polydisperse: bool) -> tsubu.Simulation:
    rng = np.random.default_rng(11)
    grain = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=DT, threads=threads, skin=0.2e-3)
    cluster = lattice((13, 13, 13), SPACING, (0.0, 0.0, 0.0))
    radii = rng.uniform(0.42e-3, 0.5e-3, len(cluster)) if polydisperse else np.full(len(cluster), 0.5e-3)
    sim.add_spheres(cluster, radii, grain, velocities=rng.normal(0.0, 0.3, cluster.shape))
    if with_lattice:  # (its ids come after the cluster's: the cluster's ids are the same)
        far = lattice((40, 40, 41), SPACING, (0.2, 0.0, 0.0))
        sim.add_spheres(far, np.full(len(far), 0.5e-3), grain,
                        velocities=rng.normal(0.0, 1e-3, far.shape))
    return sim


def cluster_state(sim: tsubu.Simulation, n: int) -> dict:
    ids = sim.ids
    rows = np.argsort(ids)[:n]
    assert np.array_equal(ids[rows], np.arange(n))
    return {name: getattr(sim, name)[rows] for name in
            ("positions", "velocities", "angular_velocities", "forces", "torques")}


@pytest.mark.parametrize("polydisperse", [False, True], ids=["alike", "polydisperse"])
@pytest.mark.parametrize("threads", [1, 2])
def test_a_cluster_moves_the_same_alone_and_in_a_large_scene(polydisperse, threads):
    alone = scene(False, 1, polydisperse)
    large = scene(True, threads, polydisperse)
    n = len(alone)
    assert n < LARGE <= len(large)
    alone.run(steps=STEPS)
    large.run(steps=STEPS)
    # The cluster collided throughout, with sliding contacts, and the large scene fused steps.
    contacts = alone.contacts()
    assert len(contacts["i"]) > 300
    assert np.count_nonzero(np.linalg.norm(contacts["tangential_displacement"], axis=1)) > 300
    assert large.fused_step_count > STEPS // 2
    a, b = cluster_state(alone, n), cluster_state(large, n)
    for name in a:
        assert np.array_equal(a[name], b[name]), name
    # the cluster's contacts, with their histories, are the large scene's contacts among ids < n
    cb = large.contacts()
    mine = cb["i"] < n
    assert np.all(cb["j"][mine] < n) and np.all(cb["j"][mine] >= 0)
    key_a = np.lexsort((contacts["j"], contacts["i"]))
    key_b = np.lexsort((cb["j"][mine], cb["i"][mine]))
    for name in ("i", "j", "overlap", "force", "tangential_displacement"):
        assert np.array_equal(np.asarray(contacts[name])[key_a], np.asarray(cb[name])[mine][key_b]), name


ASK_PAIRS = 32_768  # near pairs: ParticleView::kAskPairs


def pressed(side, origin, rng) -> np.ndarray:
    """A lattice of 1 mm spheres 0.99 mm apart: every neighbour pressed 10 um."""
    return lattice(side, 0.99e-3, origin) + rng.normal(0.0, 1e-6, (int(np.prod(side)), 3))


def pressed_scene(with_block: bool, threads: int) -> tsubu.Simulation:
    rng = np.random.default_rng(5)
    grain = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=DT, threads=threads, skin=0.2e-3)
    cluster = pressed((13, 13, 13), (0.0, 0.0, 0.0), rng)
    sim.add_spheres(cluster, np.full(len(cluster), 0.5e-3), grain,
                    velocities=rng.normal(0.0, 0.05, cluster.shape))
    if with_block:
        block = pressed((30, 30, 15), (0.1, 0.0, 0.0), rng)
        sim.add_spheres(block, np.full(len(block), 0.5e-3), grain,
                        velocities=rng.normal(0.0, 0.05, block.shape))
    return sim


@pytest.mark.parametrize("threads", [1, 2])
def test_a_pressed_cluster_sums_the_same_alone_and_beside_a_pressed_block(threads):
    alone = pressed_scene(False, 1)
    big = pressed_scene(True, threads)
    n = len(alone)
    assert len(big) < LARGE
    alone.run(steps=50)  # (half a contact's duration: the pressed spheres are still in contact)
    big.run(steps=50)
    # The cluster is pressed throughout (its sums are flat), and the block makes the scene's near
    # pairs more than ASK_PAIRS: three pressed neighbours per sphere.
    assert len(alone.contacts()["i"]) > 2.5 * n
    assert len(big.contacts()["i"]) - len(alone.contacts()["i"]) > ASK_PAIRS
    a, b = cluster_state(alone, n), cluster_state(big, n)
    for name in a:
        assert np.array_equal(a[name], b[name]), name

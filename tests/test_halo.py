"""A rank's halo at the core (docs/parallel.md): spheres taken out of a scene and put back under
their ids, with their state and their contacts, continue bit for bit as if they had never left;
and the halo's calls refuse bad ids. No MPI here (tests/test_parallel.py runs the ranks)."""
import sys
from pathlib import Path

import numpy as np
import pytest

from tsubu import parallel

sys.path.insert(0, str(Path(__file__).parent / "mpi"))
import scene  # noqa: E402  (tests/mpi/scene.py: a frictional pack on a mesh floor, an outlet)


def _state(sim):
    return [sim.positions, sim.velocities, sim.angular_velocities, sim.forces, sim._core.dissipated()]


def test_spheres_dropped_and_put_back_continue_bit_for_bit():
    steps = 5000
    one = scene.build()
    one.run(steps)
    other = scene.build()
    other.run(steps)
    core = other._core
    ids = other.ids
    rng = np.random.default_rng(7)
    away = np.sort(rng.choice(ids[10:], size=120, replace=False))  # (not the fixed ones)
    rows = other.rows(away)
    keep = [a[rows].copy() for a in (other.positions, other.velocities, other.angular_velocities,
                                     other.radii, core.materials(), core.dissipated())]
    pairs, walls = core.contact_state(False), core.contact_state(True)
    touching = np.isin(pairs["owner"], away) | np.isin(pairs["partner"], away)
    assert touching.any() and np.isin(walls["owner"], away).any()  # contacts leave with them
    core._drop_spheres(away)
    assert other.size == one.size - len(away)
    assert len(other.removed()["id"]) == 0  # (a halo's change is no removal)
    x, v, w, r, m, d = keep
    core._insert_spheres(away, x, r, m, v, w, d)
    core.set_contact_state(parallel._merge([core.contact_state(False), parallel._rows(pairs, touching)], walls=False),
                           parallel._merge([core.contact_state(True), walls], walls=True))
    one.run(steps)
    other.run(steps)
    assert len(one.removed()["id"]) > 0  # (the outlet worked meanwhile, on both)
    for a, b in zip(_state(one), _state(other)):
        assert np.array_equal(a, b)
    for k in ("i", "j", "wall", "element", "tangential_displacement", "force"):
        assert np.array_equal(one.contacts()[k], other.contacts()[k])
    assert np.array_equal(one.removed()["id"], other.removed()["id"])


def test_pack_and_unpack_carry_state_by_id_and_skip_ids_not_held():
    sim = scene.build()
    core = sim._core
    ids = np.array([5, 3, 10_000, 7], dtype=np.int64)  # (10,000 is no sphere: skipped)
    buf = np.zeros(1 + 10 * len(ids))
    # Before any run there is no list to tell who touches whom: every sphere held travels, each
    # with its place in the list (as not all of the list's do).
    assert core._pack_halo(ids, buf) == 1 + 10 * 3
    assert buf[0] == 3
    x, v, w = sim.positions, sim.velocities, sim.angular_velocities
    for k, (place, i) in enumerate([(0, 5), (1, 3), (3, 7)]):
        record = buf[1 + 10 * k:11 + 10 * k]
        assert record[0] == place
        assert np.array_equal(record[1:], np.concatenate([x[i], v[i], w[i]]))
    buf[2:11] = [1, 2, 3, 4, 5, 6, 7, 8, 9]
    assert core._unpack_halo(ids, buf) == max(4 * 4 + 5 * 5 + 6 * 6, *(np.sum(v[[3, 7]] ** 2, axis=1)))
    assert np.array_equal(sim.positions[5], [1, 2, 3]) and np.array_equal(sim.velocities[5], [4, 5, 6])
    with pytest.raises(ValueError, match="1 \\+ 10 values per id"):
        core._pack_halo(ids, np.zeros(3))
    with pytest.raises(ValueError, match="another list"):
        core._unpack_halo(ids[:2], buf)


def test_only_spheres_with_pair_contacts_travel_each_step():
    """A copy with no pair in the near list steps on its rank as on its owner's (the walls,
    gravity and imposed motions are the same everywhere): only the others' state travels."""
    sim = scene.build()
    lone = sim.add_spheres([[0.05, 0.02, 0.06]], 0.001, sim.materials[0])[0]  # far from all
    sim.run(20_000)
    core = sim._core
    c = sim.contacts()
    pair = c["j"] >= 0  # (a wall contact's j is -1)
    touching = np.unique(np.concatenate([c["i"][pair], c["j"][pair]]))
    assert len(touching) > 10 and lone not in touching
    ids = np.concatenate([[lone], touching]).astype(np.int64)
    buf = np.zeros(1 + 10 * len(ids))
    n = core._pack_halo(ids, buf)
    m = int(buf[0])
    # Every sphere in contact travels (with its place: not all do), the lone sphere does not.
    assert m == len(touching) and n == 1 + 10 * m
    places = buf[1::10][:m].astype(int)
    assert 0 not in places and set(range(1, len(ids))) <= set(places)
    # All of a list travel: no places then.
    assert core._pack_halo(touching.astype(np.int64), buf) == 1 + 9 * len(touching)


def test_insert_refuses_ids_in_use_repeated_or_negative():
    sim = scene.build()
    core = sim._core
    one = lambda ids: (np.zeros((len(ids), 3)), np.full(len(ids), 1e-3), np.zeros(len(ids), np.int32),
                       np.zeros((len(ids), 3)), np.zeros((len(ids), 3)), np.zeros(len(ids)))
    for ids, message in (([4], "id 4 is in use"), ([-2], "negative"), ([600, 600], "listed twice")):
        x, r, m, v, w, d = one(ids)
        with pytest.raises(ValueError, match=message):
            core._insert_spheres(np.array(ids), x, r, m, v, w, d)
    with pytest.raises(ValueError, match="no sphere 9999"):
        core._drop_spheres(np.array([9999]))

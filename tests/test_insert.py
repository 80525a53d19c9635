"""tsubu.Inserter: pouring at a number or mass rate, without overlap, inside its region, with its
velocity; deterministic for a seed and a thread count; total, stop, carry-over, and the
_state/_restore round trip the checkpoints use."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import tsubu
from tsubu import fill

from conftest import make_material

REGION = fill.Box((-3e-3, -3e-3, 8e-3), (3e-3, 3e-3, 14e-3))
SIZES = fill.Uniform(0.4e-3, 0.6e-3)


class Checked:
    """An inserter whose every insertion is checked: the new spheres lie inside the region, carry
    the inserter's velocity and spin, and overlap no sphere (new or old)."""

    def __init__(self, inserter):
        self.inserter = inserter
        self.events = 0

    def next_step(self, sim):
        return self.inserter.next_step(sim)

    def act(self, sim):
        before = sim.size
        self.inserter.act(sim)
        self.events += 1
        new = np.arange(before, sim.size)
        if len(new) == 0:
            return
        x, r = sim.positions, sim.radii
        assert self.inserter.region.contains(x[new], r[new]).all()
        assert np.all(sim.velocities[new] == self.inserter.velocity)
        assert np.all(sim.angular_velocities[new] == self.inserter.angular_velocity)
        d = np.sqrt(((x[new][:, None, :] - x[None, :, :]) ** 2).sum(axis=2))
        d[np.arange(len(new)), new] = np.inf
        assert np.all(d >= r[new][:, None] + r[None, :])

    def close(self, sim):
        self.inserter.close(sim)


def pour_scene(threads=None, parallel_min=2048, attach=True, **inserter_args):
    """A box of five walls under an inserter (kept by the Simulation with ``attach``, else to
    be passed to runs as an output hook)."""
    glass = make_material()
    sim = tsubu.Simulation(gravity=(0, 0, -9.81), threads=threads, parallel_min=parallel_min)
    for point, normal in (((0, 0, 0), (0, 0, 1)), ((-4e-3, 0, 0), (1, 0, 0)), ((4e-3, 0, 0), (-1, 0, 0)),
                          ((0, -4e-3, 0), (0, 1, 0)), ((0, 4e-3, 0), (0, -1, 0))):
        sim.add_plane(point=point, normal=normal, material=glass)
    args = dict(region=REGION, rate=4000.0, sizes=SIZES, material=glass, velocity=(0, 0, -0.5),
                angular_velocity=(0, 0, 3.0), seed=1)
    args.update(inserter_args)
    return sim, sim.add_inserter(**args) if attach else tsubu.Inserter(**args)


def test_number_rate_over_time():
    sim, inserter = pour_scene(attach=False)
    checked = Checked(inserter)
    sim.run(steps=20_000, output=checked)
    elapsed = sim.time
    # events at k * interval insert the amount of the interval that begins
    assert checked.events == math.floor(elapsed / inserter.interval) + 1
    assert abs(inserter.inserted - 4000.0 * elapsed) <= 4000.0 * inserter.interval + 1
    assert inserter.inserted == sim.size and inserter.pending == 0
    assert inserter.inserted_mass == pytest.approx(sim.masses.sum(), rel=1e-12)
    assert np.all((sim.radii >= 0.4e-3) & (sim.radii <= 0.6e-3))


def test_mass_rate_over_time():
    sim, inserter = pour_scene(rate=2e-3, basis="mass", sizes=fill.Normal(0.5e-3, 0.05e-3), attach=False)
    sim.run(steps=20_000, output=[Checked(inserter)])
    largest = 2500.0 * 4 / 3 * math.pi * (0.65e-3) ** 3
    due = 2e-3 * (math.floor(sim.time / inserter.interval) + 1) * inserter.interval
    assert abs(inserter.inserted_mass - due) <= 0.5 * largest
    assert inserter.inserted_mass == pytest.approx(sim.masses.sum(), rel=1e-12)


def test_default_interval_crosses_the_region():
    sim, inserter = pour_scene()
    assert inserter.interval is None
    inserter.next_step(sim)
    h, v, g = 6e-3, 0.5, 9.81
    assert inserter.interval == pytest.approx((-v + math.sqrt(v * v + 2 * g * h)) / g, rel=1e-12)
    sim, inserter = pour_scene(velocity=(0, 0, 0))
    inserter.next_step(sim)
    assert inserter.interval == pytest.approx(math.sqrt(2 * h / g), rel=1e-12)
    sim, inserter = pour_scene(velocity=(1.0, 0, 0))
    sim.gravity = (0, 0, 0)
    inserter.next_step(sim)
    assert inserter.interval == pytest.approx(6e-3 / 1.0, rel=1e-12)
    sim, inserter = pour_scene(velocity=(0, 0, 0))
    sim.gravity = (0, 0, 0)
    with pytest.raises(ValueError, match="give interval="):
        sim.run(steps=1)


def final_state(threads=None, seed=1, pieces=(1_000,)):
    # low and fast enough that the spheres reach the floor and each other within the run
    low = fill.Box((-3e-3, -3e-3, 0.45e-3), (3e-3, 3e-3, 2.5e-3))
    sim, inserter = pour_scene(threads=threads, parallel_min=0, seed=seed, region=low, rate=20_000.0,
                               interval=0.25e-3, velocity=(0, 0, -1.0))
    for steps in pieces:
        sim.run(steps=steps)
    return sim, inserter


def test_same_seed_same_pour_any_thread_count():
    one, _ = final_state(threads=1)
    two, _ = final_state(threads=2)
    assert one.size == two.size > 20
    assert len(one.contacts()["i"]) > 0
    assert np.array_equal(one.positions, two.positions)
    assert np.array_equal(one.velocities, two.velocities)
    assert np.array_equal(one.radii, two.radii)
    cut, _ = final_state(threads=1, pieces=(317, 1, 682))  # runs cut anywhere: the same
    assert np.array_equal(one.positions, cut.positions)
    other, _ = final_state(threads=1, seed=2)
    assert not np.array_equal(other.radii[:10], one.radii[:10])


def test_total_and_stop_end_it():
    sim, inserter = pour_scene(total=30)
    sim.run(steps=2_000)
    assert inserter.inserted == 30 == sim.size and inserter.finished
    assert inserter.next_step(sim) is None
    sim, inserter = pour_scene(rate=6000.0, stop=0.005, interval=1e-3)
    sim.run(steps=6_000)
    assert sim.time > 0.006 and inserter.finished and inserter.next_step(sim) is None
    assert inserter.inserted == 30
    sim, inserter = pour_scene(rate=1e-2, basis="mass", total=2e-5, interval=1e-3)
    sim.run(steps=6_000)
    assert inserter.finished
    assert abs(inserter.inserted_mass - 2e-5) <= 0.5 * 2500.0 * 4 / 3 * math.pi * (0.6e-3) ** 3


def test_what_does_not_fit_is_carried_over():
    glass = make_material()
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    small = fill.Box((0, 0, 0), (2.5e-3, 2.5e-3, 2.5e-3))  # room for a few spheres only
    inserter = sim.add_inserter(small, rate=20_000.0, sizes=SIZES, material=glass, interval=1e-3, seed=3)
    sim.run(steps=1)
    first = sim.size
    assert 0 < first < 20 and inserter.pending == 20 - first
    waiting = inserter._queue[:inserter.pending].copy()
    sim.positions = sim.positions + np.array([1.0, 0, 0])  # clear the region
    steps = inserter.next_step(sim) - sim.step_count
    sim.run(steps=steps + 1)
    placed = sim.radii[first:]
    assert 0 < len(placed) < len(waiting)  # the region holds fewer than waited
    # the spheres that waited go first (largest first), and those still waiting stay first in line
    assert set(placed) <= set(waiting)
    still = [r for r in waiting if r not in set(placed)]
    assert np.array_equal(inserter._queue[:len(still)], still)
    assert inserter.inserted + inserter.pending == 40 and inserter.pending == 40 - sim.size


def test_a_rate_the_region_can_never_hold_is_refused_at_the_first_event():
    # 1e7 spheres/s into a 2 cm box: one step spent 6.9 s trying to place 451,012 of them. Now the
    # first event refuses, naming the rate, before placing any (a box of 8e-6 m^3 holds at most
    # 0.7405 x 8e-6 / (4/3 pi (0.4 mm)^3) = 22,097 spheres of the smallest radius).
    glass = make_material()
    sim = tsubu.Simulation(gravity=(0, 0, -9.81), dt=1e-5)
    box = fill.Box((0, 0, 0), (0.02, 0.02, 0.02))
    inserter = sim.add_inserter(box, rate=1e7, sizes=SIZES, material=glass, seed=1)
    with pytest.raises(ValueError, match=r"Inserter: \d+ spheres are due at t = 0 s \(0 of them left "
                                         r"from earlier events\), more than the 22097 that its region.*"
                                         r"rate=10000000\.0 spheres/s.*Lower the rate"):
        sim.run(steps=2)
    assert sim.size == 0 and inserter.inserted == 0 and sim.step_count == 0


def test_a_backlog_beyond_what_the_region_holds_is_refused():
    # No gravity: what is inserted stays in the region, and each event adds 30 to a region of room
    # for at most 43 (2.5 mm cube, 0.4 mm spheres): the second event finds more due, new and left
    # over, than the region could ever take.
    glass = make_material()
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    small = fill.Box((0, 0, 0), (2.5e-3, 2.5e-3, 2.5e-3))
    inserter = sim.add_inserter(small, rate=30_000.0, sizes=SIZES, material=glass, interval=1e-3, seed=3)
    sim.run(steps=1)
    assert 0 < inserter.pending < 30
    with pytest.raises(ValueError, match=rf"Inserter: {inserter.pending + 30} spheres are due at t = "
                                         rf"0\.001\d* s \({inserter.pending} of them left from earlier "
                                         r"events\), more than the 43 "):
        sim.run(time=2e-3)
    assert inserter.inserted == sim.size


def test_state_round_trip_gives_the_same_future():
    sim_a, inserter_a = pour_scene(sizes=fill.LogNormal(0.5e-3, 0.1), interval=2e-3)
    sim_b, inserter_b = pour_scene(sizes=fill.LogNormal(0.5e-3, 0.1), interval=2e-3, attach=False)
    sim_a.run(steps=6_000)
    sim_b.run(steps=6_000, output=inserter_b)
    assert inserter_a.inserted > 0
    config = json.loads(json.dumps(inserter_a._config(sim_a)))
    state = json.loads(json.dumps(inserter_a._state()))
    config["seed"] = 12345  # the restored generators, not the seed, must carry the stream
    restored = tsubu.Inserter._from_config(config, sim_b)
    restored._restore(state)
    assert restored._state() == inserter_a._state()
    sim_a.run(steps=8_000)
    sim_b.run(steps=8_000, output=restored)
    assert restored.inserted == inserter_a.inserted > state["inserted"]
    assert np.array_equal(sim_a.positions, sim_b.positions)
    assert np.array_equal(sim_a.radii, sim_b.radii)


def test_config_names_the_material_by_index():
    sim, inserter = pour_scene()
    config = inserter._config(sim)
    assert sim.materials[config["material"]] is inserter.material
    assert config["region"] == REGION.to_dict() and config["sizes"] == SIZES.to_dict()
    with pytest.raises(ValueError, match="cannot be written"):
        tsubu.Inserter(fill.Region(lambda x: np.ones(len(x), bool), (0, 0, 0), (1, 1, 1)), 1.0,
                       1e-3, make_material())._config(sim)


@pytest.mark.parametrize("args, error, match", [
    (dict(rate=0.0), ValueError, "rate must be a finite number > 0"),
    (dict(basis="volume"), ValueError, "basis must be"),
    (dict(start=0.1, stop=0.05), ValueError, "stop must be > start"),
    (dict(total=0), ValueError, "total must be >= 1"),
    (dict(total=2.5), TypeError, "total must be an integer"),
    (dict(basis="mass", total=-1.0), ValueError, "total must be a finite number > 0"),
    (dict(interval=0.0), ValueError, "interval must be a finite number > 0"),
    (dict(material="glass"), TypeError, "material must be a tsubu.Material"),
    (dict(sizes=4e-3), ValueError, "do not fit in the region"),
    (dict(velocity=(0, 0)), ValueError, "velocity must have 3 components"),
    (dict(region=(0, 0, 0)), TypeError, "region must be a tsubu.fill region"),
    (dict(material=tsubu.Material(youngs_modulus=1e9)), ValueError, "one contact law"),
])
def test_inserter_refuses_bad_input(args, error, match):
    full = dict(region=REGION, rate=100.0, sizes=SIZES, material=make_material())
    full.update(args)
    sim = tsubu.Simulation()
    sim.add_plane(material=make_material())  # a linear scene
    with pytest.raises(error, match=match):
        sim.add_inserter(**full)
    assert sim.inserters == []


def test_a_pour_resumed_from_a_checkpoint_runs_on_bit_for_bit(tmp_path):
    low = fill.Box((-3e-3, -3e-3, 0.45e-3), (3e-3, 3e-3, 2.5e-3))
    args = dict(region=low, rate=20_000.0, interval=0.25e-3, velocity=(0, 0, -1.0),
                sizes=fill.Tabulated([0.3e-3, 0.4e-3, 0.6e-3], [0, 0.3, 1.0], basis="mass"))
    sim, inserter = pour_scene(**args)
    sim.run(steps=700)
    sim.save(tmp_path / "pour.tsubu")
    sim.run(steps=900)
    resumed = tsubu.Simulation.load(tmp_path / "pour.tsubu")
    assert len(resumed.inserters) == 1
    resumed.run(steps=900)
    again = resumed.inserters[0]
    assert again.inserted == inserter.inserted > 0 and again._state() == inserter._state()
    assert np.array_equal(resumed.positions, sim.positions)
    assert np.array_equal(resumed.radii, sim.radii)

"""The fused pass of large scenes (docs/architecture.md, "One step"): from 65,536 spheres on, with
fixed walls, a step's particle pass also evaluates the next step's contacts, in one sweep over
memory, whenever no neighbour list can fall due in between. It must change nothing but the
time: the same bits as the two passes, for any thread count, through near-list refreshes and
rebuilds, and the same error at the same step when a run goes unstable.

The reference is the same run taken one step per call: run(steps=1) never fuses (a step is
fused only with a next step of the same call), so it is the two-pass loop.

Scene: 67,600 polydisperse frictional spheres (radii 0.42-0.50 mm, two materials) on a 26 x 26
x 100 lattice 1.02 mm apart (gaps up to 0.18 mm), random velocities (0.3 m/s) and spins, in a
box of five fixed walls under gravity: within 200 steps some 15,000 contacts form between
spheres and with the walls, the near list is refreshed about 20 times (the Verlet list rebuilt
twice), and about 180 of the steps are fused.
"""

from __future__ import annotations

import numpy as np
import pytest

import tsubu

from bits import assert_same_bits

FUSED_MIN = 65_536  # spheres: step.hpp, kFar
SIDE, LAYERS = 26, 100
SPACING = 1.02e-3  # m
DT = 1.0e-6  # s
STEPS = 200


def lattice_scene(threads: int, dt: float = DT, skin: float = 0.3e-3,
                  **options) -> tsubu.Simulation:
    rng = np.random.default_rng(5)
    grid = np.stack(np.meshgrid(np.arange(SIDE), np.arange(SIDE), np.arange(LAYERS),
                                indexing="ij"), -1).reshape(-1, 3)
    pos = (grid + 0.5) * SPACING
    radii = rng.uniform(0.42e-3, 0.50e-3, len(pos))
    grain = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)
    stiff = tsubu.Material(density=2000.0, kn=2e3, restitution=0.7, friction=0.3)
    velocities = rng.normal(0.0, 0.3, (len(pos), 3))
    spins = rng.normal(0.0, 100.0, (len(pos), 3))
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -9.81), dt=dt, threads=threads, skin=skin,
                           **options)
    # every third sphere (by lattice column) of the stiffer material
    for mat, rows in ((grain, grid[:, 0] % 3 != 0), (stiff, grid[:, 0] % 3 == 0)):
        sim.add_spheres(pos[rows], radii[rows], mat, velocities=velocities[rows],
                        angular_velocities=spins[rows])
    side = SIDE * SPACING
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=stiff)
    for ax in (0, 1):
        n = np.zeros(3)
        n[ax] = 1.0
        sim.add_plane(point=(0.0, 0.0, 0.0), normal=n, material=grain)
        sim.add_plane(point=n * side, normal=-n, material=stiff)
    return sim


_RUNS: dict = {}


def one_call(threads: int) -> tsubu.Simulation:
    if threads not in _RUNS:
        sim = lattice_scene(threads)
        sim.run(steps=STEPS)
        _RUNS[threads] = sim
    return _RUNS[threads]


def one_step_per_call(sim: tsubu.Simulation) -> tsubu.Simulation:
    """STEPS calls of one step each: never fused, the two-pass loop."""
    for _ in range(STEPS):
        sim.run(steps=1)
    assert sim.fused_step_count == 0
    return sim


@pytest.fixture(scope="module")
def two_pass() -> tsubu.Simulation:
    return one_step_per_call(lattice_scene(1))


def test_scene_takes_the_fused_pass_through_refreshes_and_contacts(two_pass):
    """The scene is large enough, most of its steps are fused, the near list is refreshed
    meanwhile, and spheres touch each other and the walls with tangential history."""
    sim = one_call(1)
    assert len(sim) >= FUSED_MIN
    assert STEPS // 2 < sim.fused_step_count < STEPS - 1
    assert sim.near_refresh_count >= 10 and sim.rebuild_count >= 2
    c = sim.contacts()
    assert len(c["i"]) > 10_000
    assert np.count_nonzero(c["j"] < 0) > 500
    assert np.count_nonzero(np.linalg.norm(c["tangential_displacement"], axis=1)) > 10_000


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_fused_steps_give_the_bits_of_two_passes(two_pass, threads):
    """One call of STEPS steps (fused where it can) equals STEPS calls of one step (never
    fused), bit for bit: positions, velocities, spins, forces, torques, contacts with their
    histories, and energies with the dissipated work."""
    assert_same_bits(one_call(threads), two_pass)


@pytest.mark.filterwarnings("ignore::tsubu.PerformanceWarning")  # (more threads than cores)
@pytest.mark.parametrize("threads", [16, 24])
def test_parts_shorter_than_the_reach_give_the_same_bits(two_pass, threads):
    """With 16 or 24 threads a thread's part (4,225 or 2,817 spheres) is shorter than the
    stretch of the array that its owners' pairs span (below + above: over 4,225 places here,
    some three lattice layers of 676 each way): an owner near the bottom of a part then has
    partners in both neighbouring threads' parts, and beyond them.
    Each thread waits for the posts of every thread whose spheres its owners reach, not for
    the whole team (fused_pass.hpp): the bits must not depend on it."""
    assert_same_bits(one_call(threads), two_pass)


def test_unstable_run_stops_at_the_same_step_with_the_same_state():
    """Two spheres in the middle of the pack driven into each other at 10 m/s each: their
    overlap passes max_overlap (0.5 of a radius) at step 20, after 13 fused steps (a skin of
    1 mm keeps the near list valid for several steps at that speed). The fused run stops with
    the same InstabilityError, at the same step, with the same state kept, as the two-pass
    run."""
    errors, sims = [], []
    for per_call in (400, 1):
        sim = lattice_scene(1, skin=1e-3)
        p = sim.positions
        a = int(np.argmin(np.linalg.norm(p - p.mean(axis=0), axis=1)))
        b = int(np.argmin(np.linalg.norm(p - (p[a] + (SPACING, 0.0, 0.0)), axis=1)))
        v = sim.velocities.copy()  # (read-only: a copy to edit)
        v[a], v[b] = (10.0, 0.0, 0.0), (-10.0, 0.0, 0.0)
        sim.velocities = v
        with pytest.raises(tsubu.InstabilityError) as info:
            for _ in range(400 // per_call):
                sim.run(steps=per_call)
        errors.append(info.value)
        sims.append(sim)
    fused, two = errors
    assert sims[0].fused_step_count >= 10 and sims[1].fused_step_count == 0
    assert (fused.step, fused.particle, str(fused)) == (two.step, two.particle, str(two))
    assert "overlap by" in str(fused)
    for name in ("positions", "velocities", "angular_velocities"):
        assert np.array_equal(getattr(sims[0], name), getattr(sims[1], name)), name
    assert sims[0].energy() == sims[1].energy()


def moving_walls_scene(threads: int) -> tsubu.Simulation:
    """The lattice scene with its floor sliding along +x at 0.5 m/s (a shear cell's plate), the
    x = side wall drawing back at 2 m/s (0.4 mm in the run: it alone makes the Verlet list fall
    due, a skin's worth) and the y = 0 wall turning slowly about its point."""
    sim = lattice_scene(threads)
    sim.set_plane_motion(0, velocity=(0.5, 0.0, 0.0))
    sim.set_plane_motion(2, velocity=(2.0, 0.0, 0.0))
    sim.set_plane_motion(3, angular_velocity=(0.0, 0.0, 0.5))
    return sim


@pytest.fixture(scope="module")
def two_pass_moving() -> tsubu.Simulation:
    return one_step_per_call(moving_walls_scene(1))


@pytest.mark.parametrize("threads", [1, 2])
def test_moving_walls_fused_give_the_bits_of_two_passes(two_pass_moving, threads):
    """Walls with a prescribed motion take their step before the particle pass, so a fused pass
    evaluates the next step's wall contacts where the walls then stand: one call of STEPS steps,
    mostly fused, equals STEPS calls of one step, bit for bit, walls included."""
    sim = moving_walls_scene(threads)
    sim.run(steps=STEPS)
    assert STEPS // 2 < sim.fused_step_count < STEPS - 1
    assert np.count_nonzero(sim.contacts()["j"] < 0) > 500
    assert sim.rebuild_count >= 3  # (the fixed walls' run rebuilds twice)
    assert_same_bits(sim, two_pass_moving)
    for w in range(5):
        mine, theirs = sim.plane(w), two_pass_moving.plane(w)
        assert all(np.array_equal(mine[k], theirs[k]) for k in ("point", "normal")), w

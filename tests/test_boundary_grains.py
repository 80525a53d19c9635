"""Grains as boundaries (docs/boundaries.md): fixed and prescribed spheres, removal, outlets.

Fixed spheres have infinite mass to the others (a contact takes the free sphere's mass, as a wall
does), move with their prescribed motion whatever the forces, and still push on the others.
Removal keeps the other spheres' ids and trajectories; outlets remove at the end of a step, count
each sphere once, and give the same bits for any thread count and through a checkpoint.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu
from bits import assert_same_bits

R = 0.01  # m
G = (0.0, 0.0, -9.81)


def material(**kw):
    args = dict(density=2500.0, kn=1e5, restitution=0.5, friction=0.5)
    args.update(kw)
    return tsubu.Material(**args)


# ---- fixed and prescribed spheres -----------------------------------------------------------

def glued_layer_with_a_sphere_on_it(**options):
    m = material()
    sim = tsubu.Simulation(gravity=G, dt=1e-5, **options)
    base = sim.add_spheres([(2 * R * i, 2 * R * j, 0.0) for i in range(3) for j in range(3)], R, m)
    top = sim.add_sphere((2 * R, 2 * R, 2 * R * 0.995), R, m)
    sim.fix_spheres(base)
    return sim, base, top


def test_a_glued_layer_carries_the_weight_of_a_sphere_resting_on_it():
    sim, base, top = glued_layer_with_a_sphere_on_it()
    start = sim.positions[base]
    sim.run(time=0.3)
    assert np.array_equal(sim.positions[base], start)  # glued: not a bit moved
    assert np.all(sim.velocities[base] == 0) and np.all(sim.angular_velocities[base] == 0)
    assert np.linalg.norm(sim.velocities[top]) < 1e-6  # at rest on the layer
    weight = sim.masses[top] * 9.81
    # sim.forces holds contact forces + m g: the contacts on the layer sum to the top's weight
    contact_on_base = (sim.forces[base] - sim.masses[base, None] * np.array(G)).sum(axis=0)
    assert contact_on_base == pytest.approx([0.0, 0.0, -weight], rel=1e-9, abs=1e-12)
    assert sim.fixed.tolist() == [True] * 9 + [False]


def test_free_spheres_fall_again():
    sim, base, top = glued_layer_with_a_sphere_on_it()
    sim.run(steps=100)
    sim.free_spheres(base)
    assert not sim.fixed.any()
    sim.run(steps=1000)
    assert np.all(sim.velocities[base][:, 2] < 0)  # under gravity again


def _head_on(driver: str, e: float, speed: float = 0.5):
    """A free sphere at rest hit head on by a driver moving at `speed` along +x: a fixed sphere,
    a free sphere 1e9 times as dense, or a plane. Returns the free sphere's velocity after the
    contact."""
    m = material(restitution=e, friction=0.0)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=2e-6)
    free = sim.add_sphere((0.0, 0.0, 0.0), R, m)
    gap = 0.2 * R
    if driver == "sphere":
        d = sim.add_sphere((-2 * R - gap, 0.0, 0.0), R, m)
        sim.fix_spheres(d, velocity=(speed, 0.0, 0.0))
    elif driver == "heavy":
        sim.add_sphere((-2 * R - gap, 0.0, 0.0), R, material(restitution=e, friction=0.0, density=2.5e12),
                       velocity=(speed, 0.0, 0.0))
    else:
        sim.add_plane(point=(-R - gap, 0.0, 0.0), normal=(1.0, 0.0, 0.0), material=m,
                      velocity=(speed, 0.0, 0.0))
    sim.run(time=0.02)
    return sim.velocities[free], sim


@pytest.mark.parametrize("e", [0.3, 0.8])
def test_a_moving_fixed_sphere_drives_a_free_one_as_a_moving_wall_does(e):
    v_sphere, sim = _head_on("sphere", e)
    v_plane, _ = _head_on("plane", e)
    v_heavy, _ = _head_on("heavy", e)
    # in the driver's frame the sphere comes in at -U and leaves at e U: v = (1 + e) U, as off a
    # plane moving at U (to the discretisation error of 500 steps per contact)
    assert v_sphere[0] == pytest.approx((1 + e) * 0.5, rel=2e-3)
    assert v_sphere == pytest.approx(v_plane, rel=2e-3, abs=1e-12)
    # infinite mass: as a driver 1e9 times as heavy, to its mass ratio
    assert v_sphere == pytest.approx(v_heavy, rel=1e-8, abs=1e-12)
    # the driver kept its prescribed motion through the impact
    assert sim.velocities[1].tolist() == [0.5, 0.0, 0.0]


def test_fixing_a_sphere_after_a_run_gives_the_contact_a_wall_s_mass():
    """Two spheres of one radius and material share one set of the law's per-pair terms (the
    dashpot's mass m* = m/2) until one is fixed: then the contact takes the free sphere's mass.
    Fixed after the lists are built, the driver gives the bits it gives fixed from the start."""
    e, speed, gap = 0.5, 0.5, 0.2 * R
    m = material(restitution=e, friction=0.0)

    def run(fix_late: bool):
        sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=2e-6)
        free = sim.add_sphere((0.0, 0.0, 0.0), R, m)
        d = sim.add_sphere((-2 * R - gap, 0.0, 0.0), R, m, velocity=(speed, 0.0, 0.0))
        if fix_late:
            sim.run(steps=10)  # the lists are built while every sphere is alike
        sim.fix_spheres(d, velocity=(speed, 0.0, 0.0))
        sim.run(steps=10_000 - sim.step_count)
        return sim.velocities[free]

    late, early = run(True), run(False)
    assert np.array_equal(late, early)
    assert late[0] == pytest.approx((1 + e) * speed, rel=2e-3)  # off a wall moving at `speed`


def test_a_spinning_fixed_sphere_keeps_its_spin_and_drags_a_neighbour():
    m = material(friction=0.5)
    sim = tsubu.Simulation(gravity=G, dt=1e-5)
    wheel = sim.add_sphere((0.0, 0.0, 0.0), R, m)
    rider = sim.add_sphere((0.0, 0.0, 2 * R * 0.999), R, m)
    sim.fix_spheres(wheel, angular_velocity=(0.0, 10.0, 0.0))
    sim.run(steps=2000)
    assert sim.angular_velocities[wheel].tolist() == [0.0, 10.0, 0.0]
    assert sim.positions[wheel].tolist() == [0.0, 0.0, 0.0]
    assert sim.velocities[rider][0] > 0  # its top moves along +x (w x r): friction drags the rider


def test_a_lifting_fixed_raft_keeps_the_energy_audit_quiet():
    # A sphere lifted at constant speed gains m g h with nothing dissipated: without the
    # driver's work booked as a moving wall's, the audit at step 1000 calls that unstable.
    m = material(restitution=0.9)
    sim = tsubu.Simulation(gravity=G, dt=2e-5)
    raft = sim.add_sphere((0.0, 0.0, 0.0), R, m)
    rider = sim.add_sphere((0.0, 0.0, 2 * R * 0.999), R, m)
    sim.fix_spheres(raft, velocity=(0.0, 0.0, 0.5))
    sim.run(steps=3000)  # no InstabilityError
    assert sim.positions[rider][2] > 0.5 * 3000 * 2e-5


def test_fixed_spheres_pay_no_mass_in_the_time_step():
    # a fixed sphere contact uses the free sphere's mass: the damping gives restitution e
    # against a wall (m_eff = m), the bound stays that of the pairs (conservative)
    sim, base, top = glued_layer_with_a_sphere_on_it()
    before = sim.critical_time_step()
    sim.free_spheres(base)
    assert sim.critical_time_step() == before


def test_a_checkpoint_keeps_fixed_spheres_and_their_motion(tmp_path):
    m = material()
    def make():
        sim = tsubu.Simulation(gravity=G, dt=1e-5)
        sim.add_spheres([(2.05 * R * i, 0.0, 0.0) for i in range(4)], R, m)
        sim.add_spheres([(2.05 * R * i + R, 0.0, 1.9 * R) for i in range(3)], R, m)
        sim.fix_spheres([0, 1, 2, 3], velocity=[(0.01 * k, 0.0, 0.0) for k in range(4)],
                        angular_velocity=(0.0, 0.0, 1.0))
        return sim
    a, b = make(), make()
    a.run(steps=500)
    a.run(steps=500)
    b.run(steps=500)
    c = tsubu.Simulation.load(b.save(tmp_path / "fixed.tsubu"))
    assert c.fixed.tolist() == b.fixed.tolist()
    c.run(steps=500)
    assert_same_bits(a, c)


# ---- removal --------------------------------------------------------------------------------

def _cluster(far: bool, threads: int = 1):
    """24 spheres colliding under gravity on a floor, and 6 more: far away (never interacting)."""
    m = material()
    sim = tsubu.Simulation(gravity=G, dt=2e-5, skin=0.2 * R, threads=threads, parallel_min=1)
    rng = np.random.default_rng(3)
    x = np.array([(2.2 * R * i, 2.2 * R * j, R + 2.2 * R * k)
                  for i in range(2) for j in range(3) for k in range(4)], dtype=float)
    x += rng.uniform(-0.05 * R, 0.05 * R, x.shape)
    v = rng.uniform(-0.3, 0.3, x.shape)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=m)
    # the extra spheres sit among the others' ids: ids 0-11, then 6 extras (12-17), then 12 more
    y = np.array([(5.0 + 3 * R * k, 5.0, 5.0) for k in range(6)])
    sim.add_spheres(x[:12], R, m, velocities=v[:12])
    extra = sim.add_spheres(y, R, m)
    sim.add_spheres(x[12:], R, m, velocities=v[12:])
    return sim, extra


def test_removal_keeps_the_others_trajectories_to_the_bit():
    kept, extra = _cluster(far=True)
    cut, _ = _cluster(far=True)
    kept.run(steps=1500)
    cut.run(steps=1500)
    cut.remove_spheres(extra)
    assert cut.size == kept.size - 6
    others = np.setdiff1d(kept.ids, extra)
    assert cut.ids.tolist() == others.tolist()
    kept.run(steps=1500)
    cut.run(steps=1500)
    rows = kept.rows(others)
    for name in ("positions", "velocities", "angular_velocities", "forces", "torques"):
        assert np.array_equal(getattr(cut, name), getattr(kept, name)[rows]), name
    assert len(cut.contacts()["i"]) > 10  # the pile touches: histories were carried


def test_removing_touching_spheres_keeps_ids_and_threads_agree():
    runs = []
    for threads in (1, 2):
        sim, _ = _cluster(far=True, threads=threads)
        sim.run(steps=300)
        sim.remove_spheres([0, 5, 20])  # in the pile
        sim.run(steps=200)
        runs.append(sim)
    assert_same_bits(*runs)
    assert 5 not in runs[0].ids and 6 in runs[0].ids
    log = runs[0].removed()
    assert log["id"].tolist() == [0, 5, 20] and log["outlet"].tolist() == [-1, -1, -1]
    assert log["step"].tolist() == [300] * 3


def test_output_and_contacts_follow_ids_after_a_removal():
    from tsubu import output

    sim, extra = _cluster(far=True)
    sim.run(steps=500)
    sim.remove_spheres([1, 2])
    sim.run(steps=10)
    data = output.particle_data(sim)
    assert data["id"].tolist() == sim.ids.tolist()
    c = output.contact_data(sim)
    pairs = c["j"] >= 0
    # the drawn contact runs between the centres of the spheres it names
    assert np.array_equal(c["start"], sim.positions[sim.rows(c["i"])])
    assert np.array_equal(c["end"][pairs], sim.positions[sim.rows(c["j"][pairs])])
    assert data["coordination"].sum() == len(c["i"]) + pairs.sum()


# ---- outlets ---------------------------------------------------------------------------------

def _discharge(threads: int = 1):
    """288 spheres in a square column over an outlet plane at z = Z_OUT (no floor): they fall
    out."""
    m = material()
    sim = tsubu.Simulation(gravity=G, dt=2e-5, threads=threads, parallel_min=1)
    rng = np.random.default_rng(1)
    s = 2.15 * R
    x = np.array([(1.25 * R + i * s, 1.25 * R + j * s, 2 * R + k * s)
                  for i in range(6) for j in range(6) for k in range(8)])
    sim.add_spheres(x + rng.uniform(-0.03 * R, 0.03 * R, x.shape), R, m)
    side = 2.5 * R + 5 * s
    for p, n in (((0, 0, 0), (1, 0, 0)), ((0, 0, 0), (0, 1, 0)), ((side, 0, 0), (-1, 0, 0)),
                 ((0, side, 0), (0, -1, 0))):
        sim.add_plane(point=p, normal=n, material=m)
    sim.add_outlet(point=(0, 0, Z_OUT), normal=(0, 0, 2))
    return sim


Z_OUT = 1.5 * R


def test_an_outlet_counts_every_sphere_of_a_discharge_once():
    sim = _discharge()
    n = sim.size
    sim.run(time=0.12)
    log = sim.removed()
    assert 0 < len(log["id"]) < n  # mid-discharge
    assert len(np.unique(log["id"])) == len(log["id"])
    assert np.intersect1d(log["id"], sim.ids).size == 0
    assert sorted(log["id"].tolist() + sim.ids.tolist()) == list(range(n))
    assert np.all(log["position"][:, 2] < Z_OUT) and np.all(log["velocity"][:, 2] < 0)
    assert np.all(np.diff(log["time"]) >= 0)
    assert np.allclose(log["time"], log["step"] * 2e-5, rtol=1e-12)
    assert np.all(sim.positions[:, 2] >= Z_OUT)
    sim.run(time=0.2)
    assert sim.size == 0 and len(sim.removed()["id"]) == n


def test_a_discharge_gives_the_same_bits_for_any_thread_count_and_through_a_checkpoint(tmp_path):
    one = _discharge(threads=1)
    one.run(steps=4000)
    two = _discharge(threads=1)
    two.run(steps=2000)
    resumed = tsubu.Simulation.load(two.save(tmp_path / "discharge.tsubu"), threads=2)
    resumed.run(steps=2000)
    assert 0 < len(two.removed()["id"]) < len(one.removed()["id"])  # saved mid-discharge
    assert_same_bits(one, resumed)
    assert resumed.outlets == one.outlets == [{"point": (0.0, 0.0, Z_OUT), "normal": (0.0, 0.0, 1.0)}]
    for key, value in one.removed().items():
        assert np.array_equal(value, resumed.removed()[key]), key


def _chute(rebuild_every_step: bool):
    """180 spheres, packed touching, sliding down a floor tilted 30 degrees between two side
    walls; an outlet removes those whose centre passes x = 0.175 m."""
    m = material()
    sim = tsubu.Simulation(gravity=G, dt=2e-5, threads=1, rebuild_every_step=rebuild_every_step)
    tilt = math.radians(30.0)
    down, up = np.array([math.cos(tilt), 0.0, -math.sin(tilt)]), np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    s = 2.0 * R
    x = np.array([R * 1.05 * up + (2 + i) * s * down + (1.1 * R + j * s) * np.array([0, 1, 0]) + k * s * up
                  for i in range(6) for j in range(6) for k in range(5)])
    sim.add_spheres(x, R, m)
    sim.add_plane(point=(0, 0, 0), normal=tuple(up), material=m)
    sim.add_plane(point=(0, 0, 0), normal=(0, 1, 0), material=m)
    sim.add_plane(point=(0, 0.2 * R + 6 * s, 0), normal=(0, -1, 0), material=m)
    sim.add_outlet(point=(0.175, 0, 0), normal=(-1, 0, 0))
    return sim


def test_removals_between_refreshes_give_the_same_bits_as_lists_rebuilt_every_step():
    """Between rebuilds, a refresh carries each touching contact to its Verlet pair's new entry
    (the pairs kept through each removal's compaction of the lists); a rebuild carries them by
    ids. A chute whose outlet removes spheres as they come must give the same bits with lists
    rebuilt at every step."""
    kept, rebuilt = _chute(False), _chute(True)
    kept.run(steps=6000)
    rebuilt.run(steps=6000)
    assert 0 < len(kept.removed()["id"]) < 180
    assert len(kept.contacts()["overlap"]) > 20
    assert kept.near_refresh_count > kept.rebuild_count + 4
    assert_same_bits(kept, rebuilt)
    for key, value in kept.removed().items():
        assert np.array_equal(value, rebuilt.removed()[key]), key


@pytest.mark.parametrize("remove", ["outside", "inside"])
def test_a_box_outlet_removes_spheres_leaving_or_entering_it(remove):
    m = material()
    sim = tsubu.Simulation(dt=1e-5)
    sim.add_spheres([(0.0, 0.0, 0.0), (0.1, 0.0, 0.0)], R, m, velocities=[(1, 0, 0), (0, 0, 0)])
    sim.add_outlet(lo=(-0.05, -0.05, -0.05), hi=(0.05, 0.05, 0.05), remove=remove)
    sim.run(steps=1)
    # outside: the sphere at x = 0.1 goes at the end of the first step; inside: the other
    assert sim.removed()["id"].tolist() == ([1] if remove == "outside" else [0])
    assert sim.outlets[0]["remove"] == remove


# ---- bad input --------------------------------------------------------------------------------

def test_bad_input_is_refused_naming_the_argument():
    sim, base, top = glued_layer_with_a_sphere_on_it()
    with pytest.raises(ValueError, match="no sphere has id 99"):
        sim.fix_spheres([99])
    with pytest.raises(ValueError, match="sphere 3 is listed twice"):
        sim.fix_spheres([3, 3])
    with pytest.raises(TypeError, match="ids must be sphere ids"):
        sim.fix_spheres([1.5])
    with pytest.raises(TypeError, match="ids must be sphere ids"):
        sim.remove_spheres([True])
    with pytest.raises(ValueError, match="velocity must be finite"):
        sim.fix_spheres([top], velocity=(math.nan, 0, 0))
    with pytest.raises(ValueError, match=r"velocity must have shape \(2, 3\)"):
        sim.fix_spheres([top, 1], velocity=[(0, 0, 0)] * 3)
    with pytest.raises(ValueError, match="faster than light"):
        sim.fix_spheres([top], velocity=(1e9, 0, 0))
    with pytest.raises(ValueError, match="no sphere has id -1"):
        sim.free_spheres(-1)
    with pytest.raises(ValueError, match="no sphere has id 10"):
        sim.remove_spheres([10])
    sim.remove_spheres([top])
    with pytest.raises(ValueError, match="no sphere has id 9 \\(it was removed\\)"):
        sim.remove_spheres([top])
    with pytest.raises(ValueError, match="either point and normal"):
        sim.add_outlet()
    with pytest.raises(ValueError, match="either point and normal"):
        sim.add_outlet(point=(0, 0, 0), normal=(0, 0, 1), lo=(0, 0, 0), hi=(1, 1, 1))
    with pytest.raises(ValueError, match="needs both point and normal"):
        sim.add_outlet(point=(0, 0, 0))
    with pytest.raises(ValueError, match="normal must be a non-zero vector"):
        sim.add_outlet(point=(0, 0, 0), normal=(0, 0, 0))
    with pytest.raises(ValueError, match="lo must be <= hi"):
        sim.add_outlet(lo=(0, 0, 1), hi=(1, 1, 0))
    with pytest.raises(ValueError, match="remove must be 'outside' or 'inside', got 'below'"):
        sim.add_outlet(lo=(0, 0, 0), hi=(1, 1, 1), remove="below")
    with pytest.raises(ValueError, match="point must be finite"):
        sim.add_outlet(point=(math.inf, 0, 0), normal=(0, 0, 1))
    assert sim.outlets == [] and sim.size == 9 and sim.fixed.all()


# ---- scene files ------------------------------------------------------------------------------

def _scene(outlets, fixed_block: dict):
    return {
        "simulation": {"duration": 0.01, "dt": 2e-5},
        "materials": {"m": {"density": 2500.0, "kn": 1e5, "restitution": 0.5}},
        "particles": [
            {"generator": "lattice", "material": "m", "radius": R, "fixed": True,
             "region": {"shape": "box", "lower": [0, 0, 0], "upper": [0.06, 0.06, 0.02]},
             **fixed_block},
            {"generator": "lattice", "material": "m", "radius": R,
             "region": {"shape": "box", "lower": [0, 0, 0.03], "upper": [0.06, 0.06, 0.05]}},
        ],
        "outlets": outlets,
    }


def test_a_scene_file_fixes_a_block_and_adds_outlets(tmp_path):
    from tsubu.scene import scene_from_dict

    scene = scene_from_dict(_scene([{"shape": "plane", "point": [0, 0, -0.5], "normal": [0, 0, 1]},
                                    {"shape": "box", "lo": [1, 1, 1], "hi": [2, 2, 2],
                                     "remove": "inside"}],
                                   {"velocity": [0.1, 0, 0]}), tmp_path, output_directory=tmp_path)
    sim = scene.simulation
    assert sim.fixed.tolist() == [True] * 9 + [False] * 9
    assert np.all(sim.velocities[:9] == [0.1, 0, 0])
    assert sim.outlets == [{"point": (0.0, 0.0, -0.5), "normal": (0.0, 0.0, 1.0)},
                           {"lo": (1.0, 1.0, 1.0), "hi": (2.0, 2.0, 2.0), "remove": "inside"}]
    scene.run()
    assert np.all(sim.velocities[:9] == [0.1, 0, 0])


def test_a_scene_file_reports_a_bad_outlet_at_its_path(tmp_path):
    from tsubu.scene import SceneError, scene_from_dict

    with pytest.raises(SceneError, match=r"outlets\[0\]\.lo = \[0\.0, 0\.0, 1\.0\]: must be <= hi"):
        scene_from_dict(_scene([{"shape": "box", "lo": [0, 0, 1], "hi": [1, 1, 0]}], {}), tmp_path)
    with pytest.raises(SceneError, match=r"outlets\[0\]\.shape"):
        scene_from_dict(_scene([{"shape": "cone", "lo": [0, 0, 0], "hi": [1, 1, 1]}], {}), tmp_path)


def test_a_removal_keeps_the_mesh_triangle_of_each_wall_contact():
    # two spheres slide on the two triangles of a square mesh; removing a third, far away, keeps
    # each contact on its triangle (element) with its history: the same bits as without it
    m = material()
    def make():
        sim = tsubu.Simulation(gravity=G, dt=1e-5)
        sim.add_mesh(np.array([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], float),
                     np.array([(0, 1, 2), (0, 2, 3)]), m)
        sim.add_spheres([(0.3, -0.2, R * 0.999), (-0.3, 0.2, R * 0.999), (0.5, 0.5, 0.5)], R, m,
                        velocities=[(0.1, 0, 0), (0.1, 0, 0), (0, 0, 0)])
        return sim
    kept, cut = make(), make()
    kept.run(steps=500)
    cut.run(steps=500)
    cut.remove_spheres([2])
    assert cut.contacts()["element"].tolist() == [0, 1]
    kept.run(steps=2000)
    cut.run(steps=2000)
    assert np.array_equal(cut.positions, kept.positions[:2])
    assert np.array_equal(cut.angular_velocities, kept.angular_velocities[:2])

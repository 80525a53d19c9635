"""Bad input raises ValueError/TypeError whose message names the argument and the bad value
(DESIGN.md, "Bad input"), and leaves the simulation unchanged."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu
from conftest import REF_RADIUS, make_material

R = REF_RADIUS
NAN, INF = float("nan"), float("inf")


@pytest.fixture
def ref_sim():
    """An empty simulation with a fixed dt (far below any bound of the reference material)."""
    return tsubu.Simulation(gravity=(0.0, 0.0, -9.81), dt=1e-6, threads=1)


# ---- Material --------------------------------------------------------------------------------

@pytest.mark.parametrize("field, value, pattern", [
    ("density", -2500.0, r"density.*-2500"),
    ("density", 0.0, r"density.*0\.0"),
    ("density", NAN, r"density.*nan"),
    ("kn", -1000.0, r"kn.*-1000"),
    ("kn", 0.0, r"kn.*0\.0"),
    ("kn", INF, r"kn.*inf"),
    ("kt", -1.0, r"kt.*-1"),
    ("restitution", 0.0, r"restitution.*\(0, 1\].*0\.0"),
    ("restitution", 1.5, r"restitution.*1\.5"),
    ("restitution", -0.1, r"restitution.*-0\.1"),
    ("restitution", NAN, r"restitution.*nan"),
    ("friction", -0.5, r"friction.*-0\.5"),
    ("rolling_friction", -0.1, r"rolling_friction.*-0\.1"),
    ("tangential_damping", -1.0, r"tangential_damping.*-1"),
])
def test_material_rejects_bad_values(field, value, pattern):
    with pytest.raises(ValueError, match=pattern):
        make_material(**{field: value})


@pytest.mark.parametrize("field, value, pattern", [
    ("youngs_modulus", 0.0, r"youngs_modulus.*0\.0"),
    ("youngs_modulus", -1e9, r"youngs_modulus.*-1"),
    ("youngs_modulus", INF, r"youngs_modulus.*inf"),
    ("youngs_modulus", NAN, r"youngs_modulus.*nan"),
    ("poisson_ratio", -1.0, r"poisson_ratio.*-1\.0"),
    ("poisson_ratio", 0.51, r"poisson_ratio.*0\.51"),
    ("poisson_ratio", NAN, r"poisson_ratio.*nan"),
])
def test_hertzian_material_rejects_bad_values(field, value, pattern):
    kwargs = {"youngs_modulus": 1e9, field: value}
    with pytest.raises(ValueError, match=pattern):
        tsubu.Material(**kwargs)


@pytest.mark.parametrize("field, value", [
    ("density", "2500"), ("kn", "1e3"), ("restitution", True), ("name", 3)])
def test_material_rejects_non_numbers(field, value):
    with pytest.raises(TypeError, match=field):
        make_material(**{field: value})


def test_material_boundaries_are_accepted():
    """restitution = 1 (elastic) and friction = 0 are valid; kt defaults to 2/7 kn."""
    m = make_material(restitution=1.0, friction=0.0, kt=None)
    assert m.restitution == 1.0 and m.friction == 0.0
    assert m.kt == pytest.approx(2.0 / 7.0 * m.kn, rel=1e-15)


# ---- spheres ---------------------------------------------------------------------------------

@pytest.mark.parametrize("radius, pattern", [
    (-1e-3, r"radius.*-0\.001"), (0.0, r"radius.*0\.0"), (NAN, r"radius.*nan")])
def test_add_sphere_rejects_bad_radius(ref_sim, ref_material, radius, pattern):
    with pytest.raises(ValueError, match=pattern):
        ref_sim.add_sphere((0.0, 0.0, 0.0), radius, ref_material)
    assert ref_sim.size == 0


def test_add_spheres_rejects_a_bad_radius_entry(ref_sim, ref_material):
    """The message names the argument, the offending entry and its value."""
    with pytest.raises(ValueError, match=r"radius.*entry 1.*-0\.001"):
        ref_sim.add_spheres([(0.0, 0.0, 0.0), (0.01, 0.0, 0.0)], [R, -1e-3], ref_material)
    with pytest.raises(ValueError, match=r"radius.*\(2,\).*\(3,\)"):
        ref_sim.add_spheres([(0.0, 0.0, 0.0), (0.01, 0.0, 0.0)], [R, R, R], ref_material)
    assert ref_sim.size == 0


@pytest.mark.parametrize("count, error, pattern", [
    (-5, ValueError, r"count.*-5"), (2.5, TypeError, r"count.*2\.5")])
def test_reserve_rejects_a_bad_count(ref_sim, count, error, pattern):
    with pytest.raises(error, match=pattern):
        ref_sim.reserve(count)
    ref_sim.reserve(3)  # room only: adds nothing
    assert ref_sim.size == 0


@pytest.mark.parametrize("bad, pattern", [(NAN, r"positions.*row 1.*nan"),
                                          (INF, r"positions.*row 1.*inf"),
                                          (-INF, r"positions.*row 1.*-inf")])
def test_add_spheres_rejects_non_finite_positions(ref_sim, ref_material, bad, pattern):
    with pytest.raises(ValueError, match=pattern):
        ref_sim.add_spheres([(0.0, 0.0, 0.0), (0.01, bad, 0.0)], R, ref_material)
    with pytest.raises(ValueError, match=r"position.*" + ("nan" if bad != bad else "inf")):
        ref_sim.add_sphere((0.0, 0.0, bad), R, ref_material)
    assert ref_sim.size == 0


def test_add_spheres_rejects_non_finite_velocities(ref_sim, ref_material):
    with pytest.raises(ValueError, match=r"velocities.*nan"):
        ref_sim.add_spheres([(0.0, 0.0, 0.0)], R, ref_material, velocities=[(0.0, NAN, 0.0)])
    with pytest.raises(ValueError, match=r"angular_velocities.*inf"):
        ref_sim.add_spheres([(0.0, 0.0, 0.0)], R, ref_material,
                            angular_velocities=[(0.0, INF, 0.0)])
    assert ref_sim.size == 0


def test_shape_mismatches_are_rejected(ref_sim, ref_material):
    """positions of shape (N, 2), velocities for a different N, scalar positions."""
    with pytest.raises(ValueError, match=r"positions.*\(N, 3\).*\(2, 2\)"):
        ref_sim.add_spheres([(0.0, 0.0), (1.0, 1.0)], R, ref_material)
    with pytest.raises(ValueError, match=r"velocities.*\(2, 3\).*\(1, 3\)"):
        ref_sim.add_spheres([(0.0, 0.0, 0.0), (0.01, 0.0, 0.0)], R, ref_material,
                            velocities=[(0.0, 0.0, 0.0)])
    with pytest.raises(ValueError, match=r"angular_velocities.*\(2, 3\).*\(3, 3\)"):
        ref_sim.add_spheres([(0.0, 0.0, 0.0), (0.01, 0.0, 0.0)], R, ref_material,
                            angular_velocities=np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"positions.*shape"):
        ref_sim.add_spheres(np.zeros((2, 3, 1)), R, ref_material)
    with pytest.raises(ValueError, match=r"position.*3 components"):
        ref_sim.add_sphere((0.0, 0.0), R, ref_material)
    assert ref_sim.size == 0


def test_state_setters_check_shape_and_finiteness(ref_sim, ref_material):
    ref_sim.add_spheres([(0.0, 0.0, 0.01), (0.01, 0.0, 0.01)], R, ref_material)
    x0 = ref_sim.positions.copy()
    with pytest.raises(ValueError, match=r"positions.*\(2, 3\).*\(3, 3\)"):
        ref_sim.positions = np.zeros((3, 3))
    bad = x0.copy()
    bad[1, 2] = NAN
    with pytest.raises(ValueError, match=r"positions.*row 1.*nan"):
        ref_sim.positions = bad
    with pytest.raises(ValueError, match=r"velocities.*\(2, 3\).*\(1, 3\)"):
        ref_sim.velocities = np.zeros((1, 3))
    with pytest.raises(ValueError, match=r"angular_velocities.*inf"):
        ref_sim.angular_velocities = [(0.0, 0.0, 0.0), (INF, 0.0, 0.0)]
    np.testing.assert_array_equal(ref_sim.positions, x0)
    assert np.all(ref_sim.velocities == 0) and np.all(ref_sim.angular_velocities == 0)


@pytest.mark.parametrize("bad", ["glass", None, 2500.0, {"density": 2500.0}])
def test_material_argument_must_be_a_material(ref_sim, bad):
    with pytest.raises(TypeError, match=r"material.*Material"):
        ref_sim.add_spheres([(0.0, 0.0, 0.0)], R, bad)
    with pytest.raises(TypeError, match=r"material"):
        ref_sim.add_sphere((0.0, 0.0, 0.0), R, bad)
    with pytest.raises(TypeError, match=r"material"):
        ref_sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=bad)
    assert ref_sim.size == 0


# ---- initial overlaps (checked at the first run) -----------------------------------------------

def test_overlapping_initial_spheres_are_refused_naming_both_ids(ref_sim, ref_material):
    """Spheres 1 and 2 overlap by 4e-5 m = 0.08 r > initial_overlap = 0.05 r: the first run()
    raises ValueError naming ids 1 and 2, and nothing moves."""
    ref_sim.add_spheres([(0.0, 0.0, 0.0), (5e-3, 0.0, 0.0), (5e-3 + 2 * R - 4e-5, 0.0, 0.0)],
                        R, ref_material)
    x0 = ref_sim.positions.copy()
    with pytest.raises(ValueError, match=r"overlap.*\b1\b.*\b2\b"):
        ref_sim.run(steps=1)
    with pytest.raises(ValueError, match=r"overlap.*\b1\b.*\b2\b"):  # still refused
        ref_sim.run(steps=1)
    assert ref_sim.step_count == 0
    np.testing.assert_array_equal(ref_sim.positions, x0)


def test_overlap_within_the_tolerance_is_accepted(ref_sim, ref_material):
    """An initial overlap of 0.04 r < 0.05 r runs."""
    ref_sim.gravity = (0.0, 0.0, 0.0)
    ref_sim.add_spheres([(0.0, 0.0, 0.0), (2 * R - 0.04 * R, 0.0, 0.0)], R, ref_material)
    ref_sim.run(steps=5)
    assert ref_sim.step_count == 5


def test_sphere_overlapping_a_wall_is_refused(ref_sim, ref_material):
    """Sphere 0 overlaps wall 0 by 0.1 r: refused, naming the sphere and the wall."""
    ref_sim.add_sphere((0.0, 0.0, 0.9 * R), R, ref_material)
    ref_sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=ref_material)
    with pytest.raises(ValueError, match=r"sphere 0.*wall 0"):
        ref_sim.run(steps=1)
    assert ref_sim.step_count == 0


# ---- overlaps made after the first run (checked at the next run) ------------------------------

def two_apart(sim, material):
    """Spheres 0 and 1 on the floor (wall 0), 4 radii apart, after a first run of 10 steps."""
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=material)
    sim.add_spheres([(0.0, 0.0, R), (4 * R, 0.0, R)], R, material)
    sim.run(steps=10)
    return sim


@pytest.mark.parametrize("depth", [0.2, 0.6])
def test_a_sphere_added_after_the_first_run_into_another_is_refused(ref_sim, ref_material, depth):
    """A sphere added after the first run overlapping sphere 0 by 0.2 r (which used to fly off
    at 2.6 m/s) or 0.6 r (which used to raise an InstabilityError blaming the time step): the
    next run raises the first run's ValueError, naming both spheres and the one added, takes
    no step and moves nothing, and runs once the sphere is moved clear."""
    sim = two_apart(ref_sim, ref_material)
    x0 = sim.positions
    sim.add_sphere((-(2 - depth) * R, 0.0, sim.positions[0, 2]), R, ref_material)
    for _ in range(2):  # still refused
        with pytest.raises(ValueError, match=r"initial overlap: spheres 0 and 2 overlap by .* "
                                             rf"\({depth:g} of the smaller radius; tolerance 0\.05\)"
                                             r".*sphere 2 was added since the last run"):
            sim.run(steps=5)
        assert sim.step_count == 10
        np.testing.assert_array_equal(sim.positions[:2], x0)
    sim.positions = np.vstack([x0, [(-3 * R, 0.0, x0[0, 2])]])
    sim.run(steps=5)
    assert sim.step_count == 15 and np.abs(sim.velocities).max() < 1e-2


def test_add_spheres_after_the_first_run_is_checked_against_walls_and_each_other(ref_sim, ref_material):
    sim = two_apart(ref_sim, ref_material)
    sim.add_spheres([(10 * R, 0.0, 0.8 * R)], R, ref_material)  # 0.2 r into the floor
    with pytest.raises(ValueError, match=r"sphere 2 overlaps wall 0 by .*\(0\.2 of its radius.*"
                                         r"sphere 2 was added since the last run"):
        sim.run(steps=1)
    sim.positions = np.vstack([sim.positions[:2], [(10 * R, 0.0, 1.5 * R)]])
    sim.run(steps=1)
    # two new spheres overlapping each other
    sim.add_spheres([(20 * R, 0.0, 3 * R), (21.8 * R, 0.0, 3 * R)], R, ref_material)
    with pytest.raises(ValueError, match=r"spheres 3 and 4 overlap by .*\(0\.2 of the smaller"):
        sim.run(steps=1)


def test_a_sphere_moved_after_the_first_run_into_another_or_a_wall_is_refused(ref_sim, ref_material):
    sim = two_apart(ref_sim, ref_material)
    x = sim.positions.copy()
    x[1, 0] = x[0, 0] + 1.8 * R
    sim.positions = x
    with pytest.raises(ValueError, match=r"spheres 0 and 1 overlap by .*\(0\.2 of the smaller.*"
                                         r"sphere 1 was moved since the last run"):
        sim.run(steps=1)
    x[1] = (4 * R, 0.0, 0.7 * R)
    sim.positions = x
    with pytest.raises(ValueError, match=r"sphere 1 overlaps wall 0 by .*\(0\.3 of its radius.*"
                                         r"sphere 1 was moved since the last run"):
        sim.run(steps=1)
    x[1] = (4 * R, 0.0, R)
    sim.positions = x
    sim.run(steps=1)


def test_a_wall_added_after_the_first_run_through_a_sphere_is_refused(ref_sim, ref_material):
    sim = two_apart(ref_sim, ref_material)
    sim.add_plane(point=(4.9 * R, 0.0, 0.0), normal=(-1.0, 0.0, 0.0), material=ref_material)
    with pytest.raises(ValueError, match=r"sphere 1 overlaps wall 1 by .*\(0\.1 of its radius.*"
                                         r"wall 1 was added since the last run"):
        sim.run(steps=1)


def test_a_pack_moved_as_a_whole_keeps_its_overlaps(ref_material):
    """Two spheres that a run pressed together beyond initial_overlap, moved together (or a
    third sphere moved, or added clear): the next run accepts their overlap, which the change
    did not deepen; pushing one deeper into the other is refused."""
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=1e-6, threads=1)
    v = 2.0  # m/s: a head-on impact that overlaps the pair by about 0.15 r at its deepest
    sim.add_spheres([(-1.01 * R, 0.0, 0.0), (1.01 * R, 0.0, 0.0), (10 * R, 0.0, 0.0)], R,
                    ref_material, velocities=[(v, 0.0, 0.0), (-v, 0.0, 0.0), (0.0, 0.0, 0.0)])
    for _ in range(40):
        sim.run(steps=1)
        if sim.contacts()["overlap"].size and sim.contacts()["overlap"].max() > 0.1 * R:
            break
    assert sim.contacts()["overlap"].max() > 0.1 * R
    x = sim.positions
    sim.positions = x + (1.0, -2.0, 0.5)
    sim.run(steps=1)
    sim.add_sphere((0.0, 10 * R, 0.0), R, ref_material)
    sim.run(steps=1)
    x = sim.positions.copy()
    x[1, 0] -= 0.1 * R
    sim.positions = x
    with pytest.raises(ValueError, match=r"spheres 0 and 1 overlap.*sphere 1 was moved"):
        sim.run(steps=1)


def test_an_unchecked_change_survives_save_and_load(ref_sim, ref_material, tmp_path):
    """A sphere added into another and saved before the run that would refuse it: the loaded
    Simulation refuses it too."""
    sim = two_apart(ref_sim, ref_material)
    sim.add_sphere((-1.8 * R, 0.0, sim.positions[0, 2]), R, ref_material)
    loaded = tsubu.Simulation.load(sim.save(tmp_path / "ck.tsubu"))
    with pytest.raises(ValueError, match=r"spheres 0 and 2 overlap.*sphere 2 was added"):
        loaded.run(steps=1)
    sim = two_apart(tsubu.Simulation(dt=1e-6, threads=1), ref_material)
    sim.add_plane(point=(0.0, 0.0, 0.5 * R), normal=(0.0, 0.0, 1.0), material=ref_material)
    loaded = tsubu.Simulation.load(sim.save(tmp_path / "ck2.tsubu"))
    with pytest.raises(ValueError, match=r"sphere 0 overlaps wall 1.*wall 1 was added"):
        loaded.run(steps=1)


def test_spheres_an_inserter_places_are_not_checked_at_later_runs(ref_material):
    """An inserter whose region reaches 0.3 r into the floor: its spheres go in during the run
    (as before), not refused at the next piece of the run (inserters place their spheres clear
    of the others themselves; walls they leave to the user)."""
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -9.81), dt=1e-6, threads=1)
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=ref_material)
    sim.add_sphere((0.0, 0.0, 20 * R), R, ref_material)
    region = tsubu.fill.Box((-0.2 * R, -10 * R, -0.3 * R), (10 * R, 10 * R, 1.8 * R))
    inserter = sim.add_inserter(region, rate=1e5, sizes=R, material=ref_material, interval=1e-5,
                                total=3, start=2e-5)
    sim.run(steps=60)
    assert inserter.inserted == 3 and sim.size == 4


# ---- time step and run() -----------------------------------------------------------------------

@pytest.mark.parametrize("dt, pattern", [(0.0, r"dt.*0\.0"), (-1e-6, r"dt.*-1e-06"),
                                         (NAN, r"dt.*nan"), (INF, r"dt.*inf")])
def test_non_positive_or_non_finite_dt_is_refused(dt, pattern):
    with pytest.raises(ValueError, match=pattern):
        tsubu.Simulation(dt=dt)
    sim = tsubu.Simulation(dt=1e-6)
    with pytest.raises(ValueError, match=pattern):
        sim.dt = dt
    assert sim.dt == 1e-6


def test_a_number_in_a_0d_array_is_taken_and_other_arrays_are_refused():
    # (a state saved with np.savez gives its dt back as a 0-d array)
    assert tsubu.Simulation(dt=np.array(1e-6)).dt == 1e-6
    for bad in (np.array([1e-6]), np.array(True), np.array("1e-6")):
        with pytest.raises(TypeError, match="dt must be a real number"):
            tsubu.Simulation(dt=bad)


def test_dt_above_the_stability_bound_is_refused(ref_material):
    sim = tsubu.Simulation(threads=1)
    sim.add_sphere((0.0, 0.0, 2 * R), R, ref_material)
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=ref_material)
    sim.dt = 1.5 * sim.critical_time_step()
    with pytest.raises(ValueError, match=r"\bdt\b.*stability"):
        sim.run(steps=1)
    assert sim.step_count == 0


def test_run_needs_exactly_one_of_steps_and_time(ref_sim, ref_material):
    ref_sim.add_sphere((0.0, 0.0, 0.0), R, ref_material)
    with pytest.raises(TypeError, match=r"steps.*time"):
        ref_sim.run()
    with pytest.raises(TypeError, match=r"steps.*time"):
        ref_sim.run(steps=10, time=1e-5)
    with pytest.raises(ValueError, match=r"steps.*-1"):
        ref_sim.run(steps=-1)
    with pytest.raises(TypeError, match=r"steps.*1\.5"):
        ref_sim.run(steps=1.5)
    with pytest.raises(ValueError, match=r"time.*-1"):
        ref_sim.run(time=-1.0)
    assert ref_sim.step_count == 0
    ref_sim.run(time=1e-5)  # = 10 steps of 1e-6 s
    assert ref_sim.step_count == 10


def test_run_on_an_empty_scene_is_clean():
    """No spheres, dt given: the run either advances time (nothing to move) or is refused with
    a ValueError that says what is missing. It must not leak an internal C++ error."""
    for with_wall in (False, True):
        sim = tsubu.Simulation(dt=1e-6, threads=1)
        if with_wall:
            sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=make_material())
        try:
            sim.run(steps=10)
        except ValueError as err:
            assert "sphere" in str(err), f"unclear error for an empty scene: {err}"
        else:
            assert sim.step_count == 10 and sim.time == pytest.approx(1e-5)


def test_no_time_step_without_possible_contacts(ref_material):
    """dt=None and no contact possible (one sphere, no wall): no t_c to derive dt from; the
    run is refused with a ValueError naming dt."""
    sim = tsubu.Simulation(threads=1)
    sim.add_sphere((0.0, 0.0, 0.0), R, ref_material)
    assert math.isinf(sim.contact_duration())
    with pytest.raises(ValueError, match=r"\bdt\b"):
        sim.run(steps=1)


# ---- walls ---------------------------------------------------------------------------------

def test_plane_with_zero_normal_is_refused(ref_sim, ref_material):
    with pytest.raises(ValueError, match=r"normal.*\(0, 0, 0\)"):
        ref_sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0, 0, 0), material=ref_material)
    with pytest.raises(ValueError, match=r"coefficients.*\(0, 0, 0, 1\)"):
        ref_sim.add_plane(coefficients=(0, 0, 0, 1), material=ref_material)
    with pytest.raises(ValueError, match=r"normal.*nan"):
        ref_sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, NAN, 1.0), material=ref_material)
    with pytest.raises(ValueError, match=r"coefficients.*not both|point.*coefficients|coefficients.*point"):
        ref_sim.add_plane(point=(0.0, 0.0, 0.0), coefficients=(0, 0, 1, 0), material=ref_material)
    with pytest.raises(ValueError, match=r"wall.*5"):
        ref_sim.plane(5)


# ---- Simulation options ---------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, exc, pattern", [
    (dict(tangential_history="foo"), ValueError, r"tangential_history.*'foo'"),
    (dict(gravity=(0.0, NAN, 0.0)), ValueError, r"gravity.*nan"),
    (dict(gravity=(0.0, -9.81)), ValueError, r"gravity.*3 components"),
    (dict(threads=0), ValueError, r"threads.*got 0"),
    (dict(threads=1.5), TypeError, r"threads.*1\.5"),
    (dict(seed="x"), TypeError, r"seed.*'x'"),
    (dict(skin=-1e-4), ValueError, r"skin.*-0\.0001"),
    (dict(max_overlap=0.0), ValueError, r"max_overlap.*0\.0"),
    (dict(initial_overlap=-0.1), ValueError, r"initial_overlap.*-0\.1"),
    (dict(allow_unstable_dt="yes"), TypeError, r"allow_unstable_dt.*'yes'"),
    (dict(hertz_force="clipped"), ValueError, r"hertz_force.*'clipped'"),
    (dict(impact_speed=-1.0), ValueError, r"impact_speed.*-1\.0"),
    (dict(impact_speed=NAN), ValueError, r"impact_speed.*nan"),
])
def test_simulation_options_are_checked(kwargs, exc, pattern):
    with pytest.raises(exc, match=pattern):
        tsubu.Simulation(**kwargs)


def test_set_pair_checks_its_parameters(ref_sim, ref_material):
    other = make_material(kn=2000.0)
    with pytest.raises(ValueError, match=r"restitution.*0\.0"):
        ref_sim.set_pair(ref_material, other, restitution=0.0)
    with pytest.raises(ValueError, match=r"kn.*-5"):
        ref_sim.set_pair(ref_material, other, kn=-5.0)
    with pytest.raises(TypeError, match=r"stiffness"):
        ref_sim.set_pair(ref_material, other, stiffness=1.0)
    with pytest.raises(TypeError, match=r"material_b"):
        ref_sim.set_pair(ref_material, "steel", kn=1.0)
    # nothing was overridden: the harmonic mean of kn stays
    assert ref_sim.pair_parameters(ref_material, other)["kn"] == pytest.approx(
        2 * 1000.0 * 2000.0 / 3000.0, rel=1e-12)


# ---- returned arrays are read-only (an edit raises, instead of changing a copy) ---------------

STATE_ARRAYS = ["positions", "velocities", "angular_velocities", "radii", "masses", "forces",
                "torques", "gravity", "material_ids"]


@pytest.mark.parametrize("name", STATE_ARRAYS)
def test_writing_into_a_returned_array_raises(ref_sim, ref_material, name):
    """sim.positions[0, 2] = 99 used to edit a copy silently; now it raises ValueError, and the
    Simulation is as it was (the setter is the way to change it)."""
    ref_sim.add_spheres([(0.0, 0.0, R), (4 * R, 0.0, R)], R, ref_material)
    ref_sim.run(steps=2)
    before = getattr(ref_sim, name).copy()
    array = getattr(ref_sim, name)
    with pytest.raises(ValueError, match="read-only"):
        array[0] = 99
    with pytest.raises(ValueError, match="read-only"):
        array += 1
    np.testing.assert_array_equal(getattr(ref_sim, name), before)
    edited = array.copy()  # (a copy is writable: edit it, then assign it)
    edited[0] = 0


def test_plane_arrays_are_read_only(ref_sim, ref_material):
    wall = ref_sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=ref_material,
                             velocity=(0.1, 0.0, 0.0))
    state = ref_sim.plane(wall)
    for key in ("point", "normal", "velocity", "angular_velocity"):
        with pytest.raises(ValueError, match="read-only"):
            state[key][2] = 99
    np.testing.assert_array_equal(ref_sim.plane(wall)["normal"], (0.0, 0.0, 1.0))
    np.testing.assert_array_equal(ref_sim.plane(wall)["velocity"], (0.1, 0.0, 0.0))


def test_setters_take_the_read_only_arrays(ref_sim, ref_material):
    """A returned array, or one computed from it, is what the setters take."""
    ref_sim.add_spheres([(0.0, 0.0, R), (4 * R, 0.0, R)], R, ref_material)
    ref_sim.positions = ref_sim.positions + (0.0, 0.0, R)
    ref_sim.velocities = ref_sim.velocities
    ref_sim.gravity = ref_sim.gravity
    assert ref_sim.positions[0, 2] == 2 * R


# ---- booleans are not numbers ------------------------------------------------------------------

@pytest.mark.parametrize("call, name", [
    (lambda s, m: s.add_sphere((0.0, 0.0, True), R, m), "position"),
    (lambda s, m: s.add_sphere((0.0, 0.0, 1.0), R, m, velocity=[0, False, 0]), "velocity"),
    (lambda s, m: s.add_sphere((0.0, 0.0, 1.0), R, m, angular_velocity=(np.True_, 0, 0)),
     "angular_velocity"),
    (lambda s, m: s.add_spheres([(0.0, 0.0, 1.0), (0.0, 0.0, True)], R, m), "positions"),
    (lambda s, m: s.add_spheres(np.zeros((1, 3), dtype=bool), R, m), "positions"),
    (lambda s, m: s.add_spheres([(0.0, 0.0, 1.0)], [True], m), "radius"),
    (lambda s, m: s.add_spheres([(0.0, 0.0, 1.0)], True, m), "radius"),
    (lambda s, m: s.add_spheres([(0.0, 0.0, 1.0)], R, m, velocities=[[0, 0, True]]), "velocities"),
    (lambda s, m: s.add_plane(point=(0, 0, True), material=m), "point"),
    (lambda s, m: s.add_plane(normal=(0, 0, True), material=m), "normal"),
    (lambda s, m: s.add_plane(coefficients=(0, 0, 1, False), material=m), "coefficients"),
    (lambda s, m: s.add_plane(material=m, velocity=(True, 0, 0)), "velocity"),
    (lambda s, m: setattr(s, "gravity", (0, 0, True)), "gravity"),
    (lambda s, m: tsubu.Simulation(gravity=[0.0, 0.0, np.True_]), "gravity"),
])
def test_booleans_in_numeric_vectors_are_refused(ref_sim, ref_material, call, name):
    """add_sphere((0, 0, True)) used to put the sphere at z = 1 m: a bool where a number is
    expected is a TypeError naming the argument."""
    with pytest.raises(TypeError, match=rf"^{name} must .*(bool|True|False)"):
        call(ref_sim, ref_material)
    assert ref_sim.size == 0 and ref_sim.plane_count == 0
    np.testing.assert_array_equal(ref_sim.gravity, (0.0, 0.0, -9.81))


def test_booleans_in_state_setters_are_refused(ref_sim, ref_material):
    ref_sim.add_spheres([(0.0, 0.0, R), (4 * R, 0.0, R)], R, ref_material)
    x = ref_sim.positions
    for name in ("positions", "velocities", "angular_velocities"):
        with pytest.raises(TypeError, match=rf"^{name} must .*True"):
            setattr(ref_sim, name, [[0.0, 0.0, 1.0], [0.0, 0.0, True]])
    wall = ref_sim.add_plane(material=ref_material)
    with pytest.raises(TypeError, match=r"^velocity must .*True"):
        ref_sim.set_plane_motion(wall, velocity=(0, 0, True))
    np.testing.assert_array_equal(ref_sim.positions, x)
    np.testing.assert_array_equal(ref_sim.plane(wall)["velocity"], (0.0, 0.0, 0.0))

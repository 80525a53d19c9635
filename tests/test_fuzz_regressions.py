"""Plain regression tests for what fuzzing the public API found (tests/test_fuzz.py;
docs/physics.md, "Bad input"). Each would fail on the code before its fix."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import tsubu

MAT = tsubu.Material()


def _sim(**kw):
    kw.setdefault("threads", 1)
    kw.setdefault("dt", 1e-5)
    return tsubu.Simulation(**kw)


@pytest.mark.parametrize("far", [1e200, 1e300, -1.7e308])
@pytest.mark.parametrize("third", [False, True])
def test_a_sphere_beyond_1e200_m_runs(far, third):
    # Was: the dense cell grid's size overflowed a long ("cannot create std::vector larger than
    # max_size()" for two spheres; undefined behaviour that happened to pass with three).
    sim = _sim()
    sim.add_spheres([[0, 0, 0], [far, 0, 0]] + ([[0, 0, 2.5e-3]] if third else []), 1e-3, MAT)
    sim.run(steps=3)
    assert np.isfinite(sim.positions).all()


@pytest.mark.parametrize("value, dtype", [
    ([[0, 0, 1j]], "complex"), ([[True, False, True]], "bool"), ([["1", "2", "3"]], "<U1"),
    (np.array([[0, 0, None]], dtype=object), "real numbers"),
])
def test_positions_of_non_real_numbers_are_refused(value, dtype):
    # Was: complex values lost their imaginary part (a ComplexWarning), booleans and strings
    # were read as numbers, None became NaN.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(TypeError, match=rf"positions must be .*{dtype}"):
            _sim().add_spheres(value, 1e-3, MAT)


@pytest.mark.parametrize("radius", ["1", 1j, True])
def test_radius_of_non_real_numbers_is_refused(radius):
    with pytest.raises(TypeError, match="radius"):
        _sim().add_spheres([[0, 0, 0]], radius, MAT)


@pytest.mark.parametrize("radius, density", [(1e200, 2500.0), (1e-120, 2500.0), (1.0, 1e308),
                                             (1e-100, 1e-300)])
def test_radius_whose_mass_overflows_or_vanishes_is_refused(radius, density):
    # Was: accepted, then "no time step: the scene has no possible contact" at the first run.
    sim = _sim()
    with pytest.raises(ValueError, match=r"radius: entry 0 .* density .* mass of"):
        sim.add_spheres([[0, 0, 0]], radius, tsubu.Material(density=density))
    assert sim.size == 0


def test_run_time_of_too_many_steps_is_a_value_error():
    # Was: OverflowError (cannot convert float infinity to integer).
    sim = _sim(dt=1e-300)
    with pytest.raises(ValueError, match=r"time=1e\+300 s is inf steps of dt = 1e-300"):
        sim.run(time=1e300)


@pytest.mark.parametrize("call, name", [
    (lambda s: s.run(steps=2**70), "steps"),
    (lambda s: setattr(s, "threads", 2**40), "threads"),
    (lambda s: s.reserve(2**70), "count"),
])
def test_integers_beyond_the_core_types_name_the_argument(call, name):
    # Was: pybind11's "incompatible function arguments" TypeError, naming nothing.
    with pytest.raises(ValueError, match=rf"{name} must be <="):
        call(_sim())


def test_parallel_min_beyond_int_names_the_argument():
    with pytest.raises(ValueError, match="parallel_min must be <="):
        tsubu.Simulation(parallel_min=2**70)


@pytest.mark.parametrize("count", [2**40, 2**62])
def test_reserve_beyond_memory_is_a_memory_error_naming_count(count):
    # Was: a bare std::bad_alloc, or ValueError "vector::reserve".
    with pytest.raises(MemoryError, match=rf"count: {count} spheres need about"):
        _sim().reserve(count)


@pytest.mark.parametrize("normal", [(0, 0, 1e300), (0, 0, 1e-320), (0, 0, 5e-324)])
def test_huge_and_tiny_normals_give_the_unit_normal(normal):
    # Was: |n|^2 overflowed to inf (the normal became zero and a sphere above the floor was
    # reported overlapping it) or underflowed to 0 (refused by the core without naming it).
    sim = _sim()
    sim.add_spheres([[0, 0, 0.01]], 1e-3, MAT)
    wall = sim.add_plane(point=(0, 0, 0), normal=normal, material=MAT)
    np.testing.assert_array_equal(sim.plane(wall)["normal"], [0, 0, 1])
    sim.run(steps=2)


def test_coefficients_of_tiny_normal_are_scaled_not_refused():
    # Was: (a, b, c) = (0, 0, 1e-200) squared to 0: "must not all be zero".
    sim = _sim()
    wall = sim.add_plane(coefficients=(0, 0, 1e-200, -1e-203), material=MAT)
    np.testing.assert_allclose(sim.plane(wall)["point"], [0, 0, 1e-3])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="coefficients put the plane beyond the range of floats"):
            sim.add_plane(coefficients=(0, 0, 1e-300, 1e300), material=MAT)


@pytest.mark.parametrize("material", [tsubu.Material(restitution=1e-300), tsubu.Material(kn=1e300)])
def test_no_contact_duration_says_why(material):
    # Was: "the scene has no possible contact", for a scene that has contacts.
    sim = tsubu.Simulation(threads=1)
    sim.add_spheres([[0, 0, 0], [3e-3, 0, 0]], 1e-3, material)
    with pytest.raises(ValueError, match=r"default dt \(contact duration / 50\) is inf s.*set dt"):
        sim.run(steps=1)


def test_empty_list_adds_no_spheres():
    # Was: ValueError (shape (0,)), while an empty (0, 3) array was accepted.
    sim = _sim()
    assert len(sim.add_spheres([], 1e-3, MAT)) == 0 and sim.size == 0


def test_wall_that_does_not_exist_says_so():
    with pytest.raises(ValueError, match="wall 0 does not exist: the simulation has 0 walls"):
        _sim().set_plane_motion(0, velocity=(1, 0, 0))

"""The compiled module's Material and PairParams, and the one table of names per enum: what the
Python layer relies on when it hands parameters to the core."""

from __future__ import annotations

import math

import pytest

import tsubu
from tsubu import _checks, _core
from tsubu.material import _PARAMETERS


@pytest.mark.parametrize("cls", [_core.Material, _core.PairParams])
def test_keyword_constructor_sets_the_named_fields(cls):
    p = cls(kn=2.0e3, friction=0.25, roughness=0.1, shadow="weighted",
            roughness_distribution="uniform")
    assert (p.kn, p.friction, p.roughness) == (2.0e3, 0.25, 0.1)
    assert (p.shadow, p.roughness_distribution) == ("weighted", "uniform")
    default = cls()
    assert p.restitution == default.restitution and p.kt == default.kt
    assert repr(p).startswith(cls.__name__ + "(") and "shadow='weighted'" in repr(p)


@pytest.mark.parametrize("cls", [_core.Material, _core.PairParams])
def test_keyword_constructor_names_bad_keywords(cls):
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'stiffness'"):
        cls(stiffness=1.0)
    with pytest.raises(TypeError, match=r"'kn'.*'soft'"):
        cls(kn="soft")
    with pytest.raises(ValueError, match=r"shadow must be 'reject', 'weighted' or 'none', got 'x'"):
        cls(shadow="x")


def test_python_material_and_core_fields_agree():
    """A field the core binds must be a field of tsubu.Material, and the other way round."""
    assert set(_core.Material.fields) == set(_PARAMETERS)
    assert set(_core.PairParams.fields) == (set(_PARAMETERS) - {"density", "youngs_modulus", "poisson_ratio"}
                                            | {"effective_modulus", "effective_shear_modulus"})


def test_material_reaches_the_core_in_radians():
    core = tsubu.Material(roughness=10.0, shadow="none")._to_core()
    assert core.roughness == math.radians(10.0) and core.shadow == "none"


def test_set_pair_round_trips_through_pair_params():
    sim = tsubu.Simulation()
    a, b = tsubu.Material(), tsubu.Material(kn=2.0e3)
    sim.set_pair(a, b, roughness=5.0, roughness_distribution="uniform", friction=0.3)
    p = sim.pair_parameters(b, a)
    assert set(p) == set(_core.PairParams.fields)
    assert p["roughness"] == pytest.approx(5.0, rel=1e-15)
    assert (p["roughness_distribution"], p["friction"]) == ("uniform", 0.3)


@pytest.mark.parametrize("argument", sorted(_core.choices))
def test_one_table_per_enum(argument):
    """The bindings and the Python checks reject a bad name with the same message, and every
    name in the table converts both ways."""
    with pytest.raises(ValueError) as from_python:
        _checks.choice(argument, "x", _core.choices[argument])
    assert str(from_python.value).startswith(f"{argument} must be ")
    assert str(from_python.value).endswith(", got 'x'")
    if argument in _core.PairParams.fields:
        obj, attribute = _core.PairParams(), argument
    else:
        obj = _core.Simulation()
        attribute = {"tangential_history": "history_rule", "slip_rule": "slip_rule",
                     "adhesion": "adhesion"}[argument]
    with pytest.raises(ValueError) as from_core:
        setattr(obj, attribute, "x")
    assert str(from_core.value) == str(from_python.value)
    for name in _core.choices[argument]:
        setattr(obj, attribute, name)
        assert getattr(obj, attribute) == name


def test_public_api_names_the_bad_choice():
    with pytest.raises(ValueError, match=r"shadow must be 'reject', 'weighted' or 'none', got 'x'"):
        tsubu.Material(shadow="x")
    with pytest.raises(ValueError, match=r"roughness_distribution must be 'normal' or 'uniform', got 1"):
        tsubu.Simulation().set_pair(tsubu.Material(), tsubu.Material(), roughness_distribution=1)
    with pytest.raises(ValueError, match=r"slip_rule must be 'frozen' or 'truncate', got 'y'"):
        tsubu.Simulation(slip_rule="y")


def test_every_field_of_a_material_reaches_the_core():
    m = tsubu.Material(density=1234.0, kn=2e3, kt=300.0, restitution=0.7, friction=0.3,
                       rolling_friction=0.02, tangential_damping=0.1, roughness=12.0,
                       roughness_distribution="uniform", shadow="weighted")
    core = m._to_core()
    for name in _core.Material.fields:
        want, got = getattr(m, name), getattr(core, name)
        if want is None:  # the other law's field (a linear material's youngs_modulus): unused
            continue
        if name == "roughness":
            assert got == pytest.approx(math.radians(want), rel=1e-15)
        else:
            assert got == want, name


def test_every_field_of_a_pair_override_round_trips():
    m = tsubu.Material()
    sim = tsubu.Simulation()
    sim.set_pair(m, m, kn=5e3, kt=1e3, restitution=0.9, friction=0.1, rolling_friction=0.05,
                 tangential_damping=0.3, roughness=5.0, roughness_distribution="uniform",
                 shadow="none")
    p = sim.pair_parameters(m, m)
    want = {"kn": 5e3, "kt": 1e3, "restitution": 0.9, "friction": 0.1, "rolling_friction": 0.05,
            "tangential_damping": 0.3, "roughness": 5.0}
    assert {k: p[k] for k in want} == pytest.approx(want, rel=1e-14)
    assert (p["roughness_distribution"], p["shadow"]) == ("uniform", "none")

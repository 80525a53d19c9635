"""The Python layer and the compiled core agree on what a material, a pair and the string-valued
options are: the core lists its fields and choices once (``_core.Material.fields``,
``_core.PairParams.fields``, ``_core.choices``) and Python reads them instead of repeating them."""

import dataclasses
import math

import pytest

import tsubu
from tsubu import _core


def test_every_core_material_field_is_a_python_material_field():
    python_fields = {f.name for f in dataclasses.fields(tsubu.Material)}
    assert set(_core.Material.fields) <= python_fields


def test_material_reaches_the_core_whole_with_roughness_in_radians():
    m = tsubu.Material(density=1234.0, kn=2e3, kt=300.0, restitution=0.7, friction=0.3,
                       rolling_friction=0.02, tangential_damping=0.1, roughness=12.0,
                       roughness_distribution="uniform", shadow="weighted")
    core = m._to_core()
    for name in _core.Material.fields:
        want = getattr(m, name)
        got = getattr(core, name)
        if name == "roughness":
            assert got == pytest.approx(math.radians(want), rel=1e-15)
        else:
            assert got == want, name


def test_pair_override_round_trips_every_field():
    m = tsubu.Material()
    sim = tsubu.Simulation()
    sim.set_pair(m, m, kn=5e3, kt=1e3, restitution=0.9, friction=0.1, rolling_friction=0.05,
                 tangential_damping=0.3, roughness=5.0, roughness_distribution="uniform",
                 shadow="none")
    p = sim.pair_parameters(m, m)
    assert set(p) == set(_core.PairParams.fields)
    want = {"kn": 5e3, "kt": 1e3, "restitution": 0.9, "friction": 0.1, "rolling_friction": 0.05,
            "tangential_damping": 0.3, "roughness": 5.0}
    assert {k: p[k] for k in want} == pytest.approx(want, rel=1e-14)
    assert p["roughness_distribution"] == "uniform" and p["shadow"] == "none"


@pytest.mark.parametrize("argument", sorted(_core.choices))
def test_string_options_are_checked_against_the_core_table(argument):
    options = _core.choices[argument]
    assert len(options) >= 2
    with pytest.raises(ValueError, match=f"{argument} must be .*'{options[-1]}', got 'bogus'"):
        if argument in ("roughness_distribution", "shadow"):
            tsubu.Material(**{argument: "bogus"})
        else:
            tsubu.Simulation(**{argument: "bogus"})
    # every listed name is accepted
    for name in options:
        if argument in ("roughness_distribution", "shadow"):
            tsubu.Material(**{argument: name})
        elif not (argument == "tangential_history" and name == "literal"):
            tsubu.Simulation(**{argument: name})

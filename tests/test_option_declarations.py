"""Every option is declared once (cpp/include/tsubu/option_table.hpp, read as _core.option_table()
and tsubu._options.DECLARATIONS): the core's checks, the Python checks, the scene format's JSON
Schema and the defaults of the C++ structs and Python signatures all agree with it."""

import dataclasses
import inspect
import json
import math
import pathlib
import re

import numpy as np
import pytest

import tsubu
from tsubu import _core, _options
from tsubu._options import DECLARATIONS

DOCS = pathlib.Path(__file__).resolve().parents[1] / "docs"

# The Simulation constructor's option -> the _core.Simulation property that stores it (None: not
# stored as is: hertz_force is the bool `repulsive`).
CORE_PROPERTY = {"skin": "skin_option", "tangential_history": "history_rule", "hertz_force": None}
# Options a linear material (or pair) refuses whatever their value: checked on a Hertzian one.
HERTZIAN_ONLY = ("poisson_ratio", "work_of_adhesion")


def _names(scope):
    return set(_options.declared(scope))


def test_every_option_is_declared_and_nothing_else():
    assert _names("material") == set(_core.Material.fields)
    assert _names("pair") == set(_core.PairParams.fields)
    init = set(inspect.signature(tsubu.Simulation).parameters)
    assert _names("run") == init
    assert set(tsubu.material._PARAMETERS) == _names("material")


def test_choices_are_the_cores_names():
    for name, d in DECLARATIONS.items():
        assert (d.kind == "choice") == bool(d.choices), name
        if name in _core.choices:
            assert d.choices == tuple(_core.choices[name])
    assert DECLARATIONS["hertz_force"].choices == ("signed", "repulsive")


def test_every_declaration_is_complete():
    for name, d in DECLARATIONS.items():
        assert d.doc and d.doc[0].isupper() and d.doc.endswith("."), name
        assert d.default_text, name
        assert d.kind in ("real", "integer", "flag", "choice", "vector")
        if d.kind in ("real", "integer") and d.minimum is not None and d.maximum is not None:
            assert d.minimum < d.maximum


def _default_of_python_material(name):
    value = getattr(tsubu.Material(), name)
    if value is None:  # youngs_modulus, poisson_ratio of a linear material
        value = getattr(tsubu.Material(youngs_modulus=1e9), name)
    return value


@pytest.mark.parametrize("name", _options.declared("material"))
def test_material_defaults_are_the_structs(name):
    d = DECLARATIONS[name]
    core = getattr(_core.Material(), name)
    if d.kind == "real":
        assert core == pytest.approx(d.default * d.scale, rel=1e-15), name
        python = _default_of_python_material(name)
        if name != "youngs_modulus":  # 0 in the core: not given (None in Python)
            assert python == pytest.approx(d.default, rel=1e-15)
    else:
        assert core == d.default == getattr(tsubu.Material(), name)


@pytest.mark.parametrize("name", _options.declared("run"))
def test_run_defaults_are_the_structs_and_the_signatures(name):
    d = DECLARATIONS[name]
    signature = inspect.signature(tsubu.Simulation).parameters[name].default
    core = _core.Simulation()
    if d.kind == "vector":
        default = json.loads(d.default_text)
        assert list(core.gravity) == default and list(signature) == default
        return
    prop = CORE_PROPERTY.get(name, name)
    if name == "hertz_force":
        assert core.repulsive is (d.default == "repulsive")
    else:
        assert getattr(core, prop) == d.default, name
    if d.zero_means is not None:
        assert d.default == 0 and signature is None, name  # None in Python, 0 in the core
    else:
        assert signature == d.default and type(signature) is type(d.default), name


def _boundary_values(d):
    """Values on, just inside and just outside each declared bound, and a few non-finite ones, in
    the Python API's units."""
    if d.kind == "integer":
        out = set()
        for b in (d.minimum, d.maximum):
            out.update((b - 1, b, b + 1))
        return sorted(out)
    values = [math.nan, math.inf, -math.inf, 0.0, -1.0, 1.0]
    for b in (d.minimum, d.maximum):
        if b is not None:
            values += [b, np.nextafter(b, -math.inf), np.nextafter(b, math.inf), b - 1e-9, b + 1e-9]
    return [float(v) for v in values]


def _core_accepts(d, value):
    """Whether the core accepts `value` (Python's units) for option d: a material, a pair or a
    Simulation's run options with that one value, through validate_material / validate_pair /
    validate_options. (None: the core's 0 means "not given", which Python spells None.)"""
    core_value = value * d.scale if d.kind == "real" else value
    if d.zero_means is not None and core_value == 0:
        return None
    if core_value == 0 and value != 0:  # a denormal that the unit's scale makes 0: the core
        return None                     # never sees it (Python refuses it in its own units)
    try:
        if "material" in d.scopes:
            base = {"youngs_modulus": 1e9} if d.name in HERTZIAN_ONLY else {}
            m = _core.Material(**base)
            setattr(m, d.name, core_value)
            _core.validate_material(m)
        elif "pair" in d.scopes:
            base = ({"effective_modulus": 1e9}
                    if d.name in ("effective_shear_modulus",) + HERTZIAN_ONLY else {})
            p = _core.PairParams(kn=1e3, kt=2e2, restitution=0.5, friction=0.5, **base)
            setattr(p, d.name, core_value)
            _core.validate_pair(p)
        else:
            s = _core.Simulation()
            setattr(s, CORE_PROPERTY.get(d.name, d.name), core_value)
            _core.validate_options(s)
    except TypeError:  # an integer the core's field cannot hold (seed < 0, parallel_min >= 2^31)
        assert d.kind == "integer"
        return False
    except ValueError as e:
        return str(e)
    return True


def _python_accepts(d, value):
    try:
        _options.check(d.name, value)
    except ValueError as e:
        return str(e)
    return True


def _got(message):
    return float(re.search(r"got (\S+?)(?: degrees)?$", message).group(1))


NUMERIC = [n for n, d in DECLARATIONS.items() if d.kind in ("real", "integer")]


@pytest.mark.parametrize("name", NUMERIC)
def test_the_core_and_python_accept_and_refuse_alike_at_every_bound(name):
    d = DECLARATIONS[name]
    for value in _boundary_values(d):
        core = _core_accepts(d, value)
        python = _python_accepts(d, value)
        if core is None:  # the core's "not given"
            continue
        assert (core is True) == (python is True), (name, value, core, python)
        if python is not True:  # both refuse: both messages name the option and the value
            assert python.startswith(f"{name} must be ") and python.endswith(f"got {value!r}")
            if isinstance(core, str):
                assert re.match(rf"(pair )?{name} must be ", core), core
                got = _got(core)
                expected = value * d.scale
                assert got == expected or (math.isnan(got) and math.isnan(expected)) or (
                    got == pytest.approx(expected, rel=1e-5)), (core, value)
                if d.scale == 1:  # the same words for the range
                    assert python.split(", got")[0].split(" must be ")[1] in core


@pytest.mark.parametrize("name", _options.declared("material"))
def test_material_checks_what_the_declaration_says(name):
    d = DECLARATIONS[name]
    if d.kind != "real":
        return
    base = {"youngs_modulus": 1e9} if name in HERTZIAN_ONLY else {}
    for value in _boundary_values(d):
        declared = _python_accepts(d, value) is True
        try:
            tsubu.Material(**base, **{name: value})
            accepted = True
        except ValueError as e:
            accepted = False
            assert name in str(e)
        assert accepted == declared, (name, value)


def _schema_properties(schema):
    props = schema["properties"]
    return {
        "material": props["materials"]["additionalProperties"]["properties"],
        "pair": props["pairs"]["items"]["properties"],
        "run": props["simulation"]["properties"],
    }


def test_the_schemas_bounds_are_the_declarations():
    schema = json.loads((DOCS / "scene.schema.json").read_text(encoding="utf-8"))
    for scope, props in _schema_properties(schema).items():
        for name in _options.declared(scope):
            d, s = DECLARATIONS[name], props[name]
            if d.kind in ("real", "integer"):
                assert s["type"] == ("number" if d.kind == "real" else "integer")
                lo = s.get("exclusiveMinimum", s.get("minimum"))
                hi = s.get("exclusiveMaximum", s.get("maximum"))
                assert (lo, hi) == (d.minimum, d.maximum), (scope, name)
                assert ("exclusiveMinimum" in s) == (d.minimum is not None and d.exclusive_minimum)
                assert ("exclusiveMaximum" in s) == (d.maximum is not None and d.exclusive_maximum)
            elif d.kind == "choice":
                assert tuple(s["enum"]) == d.choices
            elif d.kind == "flag":
                assert s["type"] == "boolean"
            else:
                assert s["minItems"] == s["maxItems"] == 3
            unit = f" [{d.unit}]" if d.unit else ""
            assert s["description"].startswith(d.doc.rstrip(".")) and unit in s["description"]


def test_the_cores_field_docs_are_the_declarations():
    for cls in (_core.Material, _core.PairParams):
        for name in cls.fields:
            doc = getattr(cls, name).__doc__ or ""
            assert doc.startswith(DECLARATIONS[name].doc), (cls.__name__, name, doc)


def _words(text):
    return " ".join(text.split())


def test_the_python_api_is_made_from_the_declarations():
    """tsubu.Material's fields and tsubu.Simulation's keyword arguments are the declared options,
    in the declarations' order, each with its declared paragraph in the class docstring: a new
    option needs no Python edit."""
    assert [f.name for f in dataclasses.fields(tsubu.Material)] == _options.declared("material") + ["name"]
    assert list(inspect.signature(tsubu.Simulation).parameters) == _options.declared("run")
    for cls, scope in ((tsubu.Material, "material"), (tsubu.Simulation, "run")):
        doc = _words(cls.__doc__)
        for name in _options.declared(scope):
            d = DECLARATIONS[name]
            assert d.details, name
            assert f"{name} : " in doc and _words(d.details) in doc, (cls.__name__, name)


def test_a_value_that_needs_a_hertzian_material_is_refused_on_a_linear_one_alike():
    """The rule is declared (needs_hertzian): the core and Python refuse a value > 0 on a linear
    material with the declared reason, and accept it on a Hertzian one."""
    rules = {n: d.needs_hertzian for n, d in DECLARATIONS.items() if d.needs_hertzian}
    if not rules:
        pytest.skip("no option declares the rule")
    for name, why in rules.items():
        with pytest.raises(ValueError, match=re.escape(f"{name}=0.5 needs youngs_modulus ({why})")):
            tsubu.Material(**{name: 0.5})
        tsubu.Material(youngs_modulus=1e9, **{name: 0.5})
        core = _core.Material(**{name: 0.5})
        with pytest.raises(ValueError, match=re.escape(f"{name} > 0 needs youngs_modulus ({why})")):
            _core.validate_material(core)
        pair = _core.PairParams(kn=1e3, kt=2e2, restitution=0.5, friction=0.5, **{name: 0.5})
        with pytest.raises(ValueError, match=re.escape(f"pair {name} > 0 needs youngs_modulus")):
            _core.validate_pair(pair)


def test_law_choices_are_bound_and_saved_from_their_declarations():
    """A run option the laws read (law_choice) is a property of the core's Simulation under its
    name, listed in _core.choices, checked by its declaration, and kept by the core's
    checkpoints, with no code of its own outside its law."""
    choices = [d for d in DECLARATIONS.values() if d.law_choice]
    if not choices:
        pytest.skip("no law choice is declared")
    for d in choices:
        assert d.kind == "choice" and d.scopes == ("run",)
        assert tuple(_core.choices[d.name]) == d.choices
        for value in d.choices:
            sim = tsubu.Simulation(**{d.name: value})
            assert getattr(sim._core, d.name) == value
            back = _core.Simulation.load_bytes(sim._core.save_bytes())
            assert getattr(back, d.name) == value

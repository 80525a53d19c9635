"""Property-based fuzzing of the public API (hypothesis).

Every call made with generated arguments (shapes, dtypes, NaN/inf, huge and tiny values, empty,
non-contiguous, read-only and aliased arrays, keywords and positions, setters between runs) must
either work and leave a simulation that passes ``check_consistent``, or raise ValueError,
TypeError, MemoryError or tsubu.InstabilityError with a message that names the argument. A crash
of the process, a hang or a silent NaN fails the test.

Profiles: "ci" (the default: derandomized, so CI is deterministic, and small enough that the file
runs in well under a minute) and "campaign" (many random examples; benchmarks/fuzz_campaign.py
selects it with TSUBU_FUZZ_PROFILE=campaign and sets TSUBU_FUZZ_EXAMPLES).
"""

from __future__ import annotations

import math
import numbers
import os
import re

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason="install the test extra: pip install '.[test]'")
from hypothesis import HealthCheck, assume, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import tsubu  # noqa: E402

# Thread counts and skins drawn here may exceed what the machine or the list should take: the
# PerformanceWarning they earn is tests/test_limits.py's subject, not a fuzzing failure.
pytestmark = pytest.mark.filterwarnings("ignore::tsubu.PerformanceWarning")

_QUIET = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much]
settings.register_profile("ci", max_examples=100, deadline=None, derandomize=True, database=None,
                          suppress_health_check=_QUIET, print_blob=True)
settings.register_profile("campaign", max_examples=int(os.environ.get("TSUBU_FUZZ_EXAMPLES", "2000")),
                          deadline=None, derandomize=False, database=None,
                          suppress_health_check=_QUIET, print_blob=True)
fuzz = settings(settings.get_profile(os.environ.get("TSUBU_FUZZ_PROFILE", "ci")))

ACCEPTED = (ValueError, TypeError, MemoryError, tsubu.InstabilityError)
MAX_STEPS = 30  # every run is bounded: no example can hang

# ---- generated values ------------------------------------------------------------------------

SPECIAL = [0.0, -0.0, 5e-324, 1e-300, 1e-120, 1e-9, 1e-3, 0.5, 1.0, 3.0, 1e3, 1e9, 1e120, 1e300,
           -1e-3, -1.0, -1e300, math.inf, -math.inf, math.nan]
reals = st.one_of(st.sampled_from(SPECIAL), st.floats(), st.integers(-10**3, 10**3),
                  st.integers(-2**80, 2**80))
weird = st.one_of(reals, st.booleans(), st.none(), st.complex_numbers(max_magnitude=10),
                  st.text(max_size=2), st.just([1.0, 2.0]), st.just(np.float32(0.25)),
                  st.just(np.int64(3)), st.just(np.array(1.5)), st.just(np.array([1.0, 2.0])))
sane_lengths = st.floats(1e-4, 1e-2)


def _layout(a: np.ndarray, how: str):
    """``a`` handed over as a list, a strided view, a read-only array, a view into a larger
    array, a Fortran-ordered copy, or as another dtype."""
    if how == "list":
        return a.tolist()
    if how == "strided":
        big = np.repeat(a, 2, axis=0) if a.ndim else a
        return big[::2] if a.ndim else big
    if how == "readonly":
        b = a.copy()
        b.flags.writeable = False
        return b
    if how == "view":
        host = np.zeros((a.shape[0] + 2,) + a.shape[1:] if a.ndim else (3,))
        if a.ndim == 0:
            return host[1:2].reshape(())
        host[1:-1] = a
        return host[1:-1]
    if how == "fortran":
        return np.asfortranarray(a)
    if how in ("float32", "int64", "int8", "bool", "complex128", "object"):
        with np.errstate(all="ignore"):
            return a.astype(how)
    return a


layouts = st.sampled_from(["plain", "list", "strided", "readonly", "view", "fortran", "float32",
                           "int64", "int8", "bool", "complex128", "object"])


@st.composite
def arrays(draw, rows: int, cols: int | None = 3, bad: bool = True):
    """A (rows, cols) (or (rows,)) array of sane values, sometimes with a bad entry or shape,
    in one of the layouts."""
    shape = (rows, cols) if cols else (rows,)
    if bad and draw(st.integers(0, 9)) == 0:
        shape = draw(st.sampled_from([(rows,), (rows, 2), (rows + 1, 3), (0,), (rows, 3, 1), ()]))
    a = np.asarray(draw(st.lists(st.floats(-0.05, 0.05), min_size=int(np.prod(shape)),
                                 max_size=int(np.prod(shape))))).reshape(shape)
    if bad and a.size and draw(st.integers(0, 4)) == 0:
        a.flat[draw(st.integers(0, a.size - 1))] = draw(st.sampled_from(SPECIAL))
    return _layout(a, draw(layouts) if bad else "plain")


# ---- the property ------------------------------------------------------------------------------

def names_argument(error: BaseException, names) -> bool:
    """Whether the message names one of ``names`` (an InstabilityError names a step instead)."""
    if isinstance(error, tsubu.InstabilityError):
        return "step" in str(error) or "unstable" in str(error)
    text = str(error)
    return any(re.search(rf"\b{re.escape(n)}\b", text) for n in names)


_LAST_ERROR: list = [None]


def attempt(call, *names):
    """``call()``; an accepted error must name one of ``names`` (then None is returned)."""
    _LAST_ERROR[0] = None
    try:
        return call()
    except ACCEPTED as e:
        assert names_argument(e, names), f"{type(e).__name__} names none of {names}: {e}"
        _LAST_ERROR[0] = e
        return None


def check_consistent(sim: tsubu.Simulation) -> None:
    """Every array finite and of the shape the size says, counters and contacts coherent. Right
    after an InstabilityError the forces, torques and contacts are those of the evaluation that
    failed (what the error reports: they may be non-finite); the state itself must be finite."""
    unstable = isinstance(_LAST_ERROR[0], tsubu.InstabilityError)
    n = sim.size
    assert len(sim) == n >= 0
    for name in ("positions", "velocities", "angular_velocities", "forces", "torques"):
        a = getattr(sim, name)
        assert a.shape == (n, 3) and a.dtype == np.float64, name
        assert (unstable and name in ("forces", "torques")) or np.isfinite(a).all(), \
            f"{name} not finite: {a}"
    for name in ("radii", "masses"):
        a = getattr(sim, name)
        assert a.shape == (n,) and np.isfinite(a).all() and (a > 0).all(), name
    assert sim.step_count >= 0 and math.isfinite(sim.time) and sim.time >= 0
    if sim.step_count == 0:
        assert sim.time == 0
    c = sim.contacts()
    m = len(c["i"])
    walls = sim._core.plane_count
    for key, width in (("j", 0), ("wall", 0), ("overlap", 0), ("force", 3), ("torque_i", 3),
                       ("tangential_displacement", 3)):
        assert c[key].shape == ((m, width) if width else (m,)), key
        assert unstable or np.isfinite(c[key]).all(), key
    assert ((0 <= c["i"]) & (c["i"] < n)).all()
    assert ((-1 <= c["j"]) & (c["j"] < n)).all() and ((-1 <= c["wall"]) & (c["wall"] < walls)).all()
    assert ((c["j"] == -1) == (c["wall"] >= 0)).all()
    assert unstable or (c["overlap"] > 0).all()
    assert (np.diff(c["i"]) >= 0).all()
    pairs = sim.neighbor_pairs()
    assert pairs.ndim == 2 and pairs.shape[1] == 2
    assert ((0 <= pairs) & (pairs < n)).all() and (pairs[:, 0] < pairs[:, 1]).all()
    energies = attempt(sim.energy, "energy")  # refused only if a run drove it past doubles
    for key, value in (energies or {}).items():
        assert math.isfinite(value), f"energy {key} is {value}"
    assert all(v >= 0 for v in sim.memory_bytes().values())


def too_long(sim: tsubu.Simulation, duration) -> bool:
    """Whether run(time=duration) would take more than MAX_STEPS steps (then it is not run)."""
    if isinstance(duration, bool) or not isinstance(duration, numbers.Real):
        return False
    try:
        return float(duration) / sim.dt > MAX_STEPS
    except OverflowError:
        return True


def bounded_run(sim: tsubu.Simulation, steps: int) -> None:
    """Run at most MAX_STEPS steps; accepted errors must name what they are about."""
    attempt(lambda: sim.run(steps=min(steps, MAX_STEPS)), "dt", "steps", "overlap", "time", "initial")


# ---- Material --------------------------------------------------------------------------------

MATERIAL_FIELDS = ["density", "kn", "kt", "youngs_modulus", "poisson_ratio", "restitution",
                   "friction", "rolling_friction", "tangential_damping", "roughness",
                   "roughness_distribution", "shadow", "name"]
choice_values = st.sampled_from(["normal", "uniform", "reject", "weighted", "none", "", "x", 3, None])


@fuzz
@given(st.dictionaries(st.sampled_from(MATERIAL_FIELDS), st.one_of(weird, choice_values), max_size=4))
def test_material(kw):
    material = attempt(lambda: tsubu.Material(**kw), *kw, "poisson_ratio", "kn", "roughness")
    if material is None:
        return
    for f in MATERIAL_FIELDS[:10]:
        v = getattr(material, f)
        assert v is None or (isinstance(v, float) and math.isfinite(v)), (f, v)
    # Such a material in a scene: two spheres and a floor, a few steps.
    sim = tsubu.Simulation(threads=1)
    ok = attempt(lambda: sim.add_spheres([[0, 0, 2e-3], [0, 0, 4.5e-3]], 1e-3, material), "radius")
    attempt(lambda: sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=material), "material")
    if ok is not None:
        bounded_run(sim, 20)
    check_consistent(sim)


# ---- Simulation options ----------------------------------------------------------------------

OPTIONS = {
    "gravity": st.one_of(arrays(1, None), st.just((0.0, 0.0, -9.81)), weird),
    "dt": st.one_of(st.none(), st.sampled_from([1e-6, 1e-5, 1e-300, 1e300]), weird),
    "threads": st.one_of(st.none(), st.integers(-1, 3), st.just(2**40), weird),
    "seed": st.one_of(st.integers(-1, 2**64), weird),
    "skin": st.one_of(st.none(), st.sampled_from([1e-4, 1e-300, 1e300, 1e3]), weird),
    "tangential_history": choice_values | st.sampled_from(["rotate", "literal"]),
    "slip_rule": choice_values | st.sampled_from(["frozen", "truncate"]),
    "hertz_force": choice_values | st.sampled_from(["signed", "repulsive"]),
    "impact_speed": st.one_of(st.none(), weird),
    "max_overlap": weird,
    "initial_overlap": weird,
    "allow_unstable_dt": st.one_of(st.booleans(), weird),
    "rebuild_every_step": st.one_of(st.booleans(), weird),
    "parallel_min": st.one_of(st.integers(-1, 5000), st.just(2**70), weird),
}


@fuzz
@given(st.fixed_dictionaries({}, optional=OPTIONS), st.booleans())
def test_simulation_options(options, hertzian):
    sim = attempt(lambda: tsubu.Simulation(**options), *options, "seed")
    if sim is None:
        return
    material = tsubu.Material(youngs_modulus=1e7) if hertzian else tsubu.Material()
    sim.add_spheres([[0, 0, 1.2e-3], [0, 0, 3.5e-3], [2.1e-3, 0, 1.2e-3]], 1e-3, material,
                    velocities=[[0, 0, -0.1], [0, 0, 0], [0.1, 0, 0]])
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=material)
    attempt(lambda: sim.run(steps=MAX_STEPS), "dt", "tangential_history", "slip_rule", "overlap",
            "step", "skin")
    check_consistent(sim)


@fuzz
@given(st.lists(weird, max_size=5))
def test_simulation_positional_arguments(args):
    attempt(lambda: tsubu.Simulation(*args), "gravity", "dt", "threads", "seed", "skin")


# ---- spheres ---------------------------------------------------------------------------------

def _spaced(n: int) -> np.ndarray:
    """n non-overlapping centres for radius 1e-3."""
    return np.column_stack([np.arange(n) * 2.5e-3, np.zeros(n), np.full(n, 5e-3)])


@st.composite
def sphere_batches(draw):
    n = draw(st.integers(0, 5))
    positions = draw(st.one_of(arrays(n), st.just(_layout(_spaced(n), draw(layouts)))))
    radius = draw(st.one_of(st.floats(1e-4, 1e-3), arrays(n, None), weird))
    velocities = draw(st.one_of(st.none(), arrays(n)))
    spins = draw(st.one_of(st.none(), arrays(n)))
    return positions, radius, velocities, spins


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal dtype, shape and bytes (NaN equals itself; object arrays: the same objects)."""
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _snapshot(value):
    return None if value is None else (np.array(value, dtype=object, copy=True)
                                       if not isinstance(value, np.ndarray) else value.copy())


@fuzz
@given(sphere_batches(), st.booleans(), st.integers(0, MAX_STEPS))
def test_add_spheres(batch, keywords, steps):
    positions, radius, velocities, spins = batch
    before = [_snapshot(v) for v in batch]
    sim = tsubu.Simulation(threads=1, dt=1e-6)
    material = tsubu.Material()
    if keywords:
        call = lambda: sim.add_spheres(velocities=velocities, material=material, radius=radius,  # noqa: E731
                                       angular_velocities=spins, positions=positions)
    else:
        call = lambda: sim.add_spheres(positions, radius, material, velocities, spins)  # noqa: E731
    ids = attempt(call, "positions", "radius", "velocities", "angular_velocities")
    for old, new in zip(before, batch):  # the caller's arrays are never changed
        if isinstance(new, np.ndarray):
            assert same_bits(old, new)
    if ids is None:
        assert sim.size == 0  # a refused batch adds nothing
        return
    assert len(ids) == sim.size
    held = sim.positions.copy()
    if isinstance(positions, np.ndarray) and positions.flags.writeable and positions.size:
        positions[...] = 7.0  # nor do later changes to them reach the simulation
        np.testing.assert_array_equal(sim.positions, held)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=material)
    bounded_run(sim, steps)
    check_consistent(sim)


@fuzz
@given(weird | arrays(1, None), weird, st.one_of(st.none(), weird, arrays(1, None)))
def test_add_sphere(position, radius, velocity):
    sim = tsubu.Simulation(threads=1, dt=1e-6)
    attempt(lambda: sim.add_sphere(position, radius, tsubu.Material(), velocity=velocity),
            "position", "radius", "velocity")
    check_consistent(sim)


# ---- walls -----------------------------------------------------------------------------------

@fuzz
@given(st.one_of(st.none(), weird, arrays(1, None)), st.one_of(st.none(), weird, arrays(1, None)),
       st.one_of(st.none(), weird, arrays(4, None, bad=True)),
       st.one_of(weird, arrays(1, None)), st.integers(-1, 2), st.integers(0, MAX_STEPS))
def test_planes(point, normal, coefficients, motion, wall, steps):
    sim = tsubu.Simulation(threads=1, dt=1e-6)
    material = tsubu.Material()
    sim.add_spheres(_spaced(3), 1e-3, material)
    kw = {"coefficients": coefficients} if coefficients is not None else {}
    index = attempt(lambda: sim.add_plane(point=point, normal=normal, material=material, **kw),
                    "point", "normal", "coefficients")
    if index is not None:
        unit = sim.plane(index)["normal"]
        assert np.isfinite(unit).all() and abs(np.linalg.norm(unit) - 1) < 1e-12
    attempt(lambda: sim.set_plane_motion(wall, velocity=motion), "wall", "velocity")
    attempt(lambda: sim.set_plane_motion(wall, angular_velocity=motion), "wall", "angular_velocity")
    bounded_run(sim, steps)
    check_consistent(sim)


# ---- pair overrides --------------------------------------------------------------------------

PAIR_FIELDS = ["kn", "kt", "restitution", "friction", "rolling_friction", "tangential_damping",
               "roughness", "roughness_distribution", "shadow", "effective_modulus",
               "effective_shear_modulus", "bogus"]


@fuzz
@given(st.dictionaries(st.sampled_from(PAIR_FIELDS), st.one_of(weird, choice_values), max_size=3),
       st.booleans())
def test_set_pair(overrides, hertzian):
    make = (lambda: tsubu.Material(youngs_modulus=1e7)) if hertzian else tsubu.Material
    a, b = make(), make()
    sim = tsubu.Simulation(threads=1)
    sim.add_spheres(_spaced(2) + [0, 0, -3.99e-3], 1e-3, a)
    sim.add_spheres(_spaced(2) + [0, 0, -1.5e-3], 1e-3, b)
    attempt(lambda: sim.set_pair(a, b, **overrides), *overrides, "effective_modulus", "roughness")
    p = sim.pair_parameters(b, a)
    assert all(not isinstance(v, float) or math.isfinite(v) for v in p.values())
    bounded_run(sim, MAX_STEPS)
    check_consistent(sim)


# ---- setters between runs --------------------------------------------------------------------

SETTERS = ["positions", "velocities", "angular_velocities"]


@st.composite
def operations(draw):
    kind = draw(st.sampled_from(["set", "gravity", "dt", "threads", "run", "time", "energy",
                                 "rebuild", "add", "motion", "contacts"]))
    if kind == "set":
        return kind, draw(st.sampled_from(SETTERS)), draw(arrays(3))
    if kind in ("gravity", "dt", "threads"):
        return kind, draw(st.one_of(weird, arrays(1, None)))
    if kind == "run":
        return kind, draw(st.one_of(st.integers(-2, MAX_STEPS), weird))
    if kind == "energy":
        return kind, draw(st.one_of(st.booleans(), weird))
    if kind == "time":
        return kind, draw(st.one_of(st.floats(0, 1e-4), weird))
    if kind == "add":
        return kind, draw(sphere_batches())
    if kind == "motion":
        return kind, draw(st.one_of(weird, arrays(1, None)))
    return kind, draw(st.booleans())


@fuzz
@given(st.lists(operations(), min_size=1, max_size=8))
def test_setters_between_runs(ops):
    material = tsubu.Material(friction=0.3, rolling_friction=0.01)
    sim = tsubu.Simulation(threads=1, dt=1e-6)
    sim.add_spheres(_spaced(3), 1e-3, material)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=material)
    for kind, *args in ops:
        if kind == "set":
            name, value = args
            before = sim.positions, sim.velocities, sim.angular_velocities
            snap = _snapshot(value)
            done = attempt(lambda: setattr(sim, name, value) or True, name)
            if isinstance(value, np.ndarray):
                assert same_bits(snap, value)
            if done is None:  # refused: nothing changed
                for old, new in zip(before, (sim.positions, sim.velocities, sim.angular_velocities)):
                    np.testing.assert_array_equal(old, new)
        elif kind in ("gravity", "dt", "threads"):
            attempt(lambda: setattr(sim, kind, args[0]), kind)
        elif kind == "run":
            attempt(lambda: sim.run(steps=args[0]) if not (isinstance(args[0], int) and args[0] > MAX_STEPS)
                    else None, "steps", "dt", "overlap", "initial")
        elif kind == "time":
            t = args[0]
            if too_long(sim, t):
                continue
            attempt(lambda: sim.run(time=t), "time", "dt", "overlap", "initial")
        elif kind == "add":
            positions, radius, velocities, spins = args[0]
            attempt(lambda: sim.add_spheres(positions, radius, material, velocities, spins),
                    "positions", "radius", "velocities", "angular_velocities")
        elif kind == "motion":
            attempt(lambda: sim.set_plane_motion(0, velocity=args[0]), "velocity")
        elif kind == "energy":
            energies = attempt(lambda: sim.energy(at_positions=args[0]), "energy", "at_positions")
            assert all(math.isfinite(v) for v in (energies or {}).values())
        elif kind == "rebuild":
            attempt(sim.rebuild_neighbors)
        check_consistent(sim)


@fuzz
@given(st.one_of(st.none(), weird, st.integers(-3, 40)), st.one_of(st.none(), weird),
       st.one_of(weird, st.sampled_from([1e-7, 1e-5])))
def test_run_arguments(steps, duration, dt):
    sim = tsubu.Simulation(threads=1)
    attempt(lambda: setattr(sim, "dt", dt), "dt")
    sim.add_spheres(_spaced(2), 1e-3, tsubu.Material())
    if isinstance(steps, int) and not isinstance(steps, bool) and steps > MAX_STEPS:
        return
    if too_long(sim, duration):
        return
    attempt(lambda: sim.run(steps=steps, time=duration), "steps", "time", "dt")
    check_consistent(sim)

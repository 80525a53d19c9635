"""The Simulation: spheres, plane walls and the time loop (SI units throughout)."""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import os
import threading
import time as _time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from . import _checks, _core, _options, hooks
from ._options import DECLARATIONS
from .material import Material, _check_field, _check_uniform_range, _from_core, _to_core


class InstabilityError(RuntimeError):
    """A run went unstable: a non-finite force, an overlap beyond ``max_overlap`` of a radius, or
    a step that moved a sphere too far for the overlap check to see it meet another.

    Raised by :meth:`Simulation.run`. The message says what went wrong (the quantity, the step,
    the sphere, or for a pack that bursts between fixed walls the energy it created). The state
    of the step before (positions, velocities, angular velocities) stays readable.

    Parameters
    ----------
    message : str
        What went unstable, and where.
    step : int
        The step that failed.
    particle : int
        The id of the sphere the message names.

    Attributes
    ----------
    step : int
        The step that failed.
    particle : int
        The id of the sphere the message names.
    """

    def __init__(self, message: str, step: int, particle: int):
        super().__init__(message)
        self.step = step
        self.particle = particle


class PerformanceWarning(UserWarning):
    """A setting that gives the same results but costs far more than it should.

    Issued (:func:`warnings.warn`) for ``threads`` beyond twice the threads the machine gives
    the process, and by a run whose ``skin`` is beyond the largest diameter and fills the
    neighbour list with many times the pairs that can touch. The message names the setting, its
    value and what to use instead. Silence it with ``warnings.simplefilter("ignore",
    tsubu.PerformanceWarning)``.
    """


def _one_thread_at_a_time(*any_thread: str, refused: dict | None = None):
    """Class decorator: every public method and property of the class, but those named, runs
    under the instance's lock; while a run is in progress (``_running``) calls are refused.

    Only ``run`` releases the GIL, so a run is the one call that can overlap another thread's
    use of the engine: calls made meanwhile raise RuntimeError instead of racing with it. A
    call that finds another thread in a short call waits for it (unless that call turns out
    to be a run). ``refused`` maps private members to guard too to the message their refusal
    gives."""
    refused = refused or {}

    def guard(function, message=None):
        @functools.wraps(function)
        def guarded(self, *args, **kwargs):
            lock = self._lock
            if not lock.acquire(blocking=False):
                while True:
                    if self._running:
                        raise RuntimeError(message or
                            "Simulation is running in another thread: a Simulation is used by "
                            "one thread at a time (request_stop() ends the run; wait for run to "
                            "return)")
                    if lock.acquire(timeout=0.005):
                        break
            try:
                if self._running:  # this thread's own run: a signal handler called during it
                    raise RuntimeError(message or
                        f"Simulation.{function.__name__} called during the Simulation's own run "
                        "(from a signal handler or a callback): wait for run to return")
                return function(self, *args, **kwargs)
            finally:
                lock.release()

        return guarded

    def decorate(cls):
        for name, member in list(vars(cls).items()):
            if name in refused:
                setattr(cls, name, guard(member, refused[name]))
                continue
            if (name in any_thread or (name.startswith("_") and name != "__len__")
                    or isinstance(member, (staticmethod, classmethod))):
                continue
            if isinstance(member, property):
                setattr(cls, name, property(guard(member.fget),
                                            None if member.fset is None else guard(member.fset),
                                            doc=member.__doc__))
            elif callable(member):
                setattr(cls, name, guard(member))
        return cls

    return decorate


_COPY_REFUSED = (
    "a Simulation cannot be copied or pickled while it runs: a copy goes through its checkpoint "
    "(save/load), which is taken between runs or from a run hook; copy it after run returns "
    "(request_stop() ends the run), or save() it from a run hook and load() the file")


def _axis(name: str, value) -> int:
    """An axis letter as its index."""
    if not isinstance(value, str) or value not in ("x", "y", "z"):
        raise ValueError(f"{name} must be one of 'x', 'y', 'z', got {value!r}")
    return "xyz".index(value)


def _axes(name: str, value) -> list[int]:
    """A string of distinct axis letters as their indices."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string of axes such as 'xyz' or 'xy', got {value!r}")
    if any(a not in "xyz" for a in value) or len(set(value)) != len(value):
        raise ValueError(f"{name} must list distinct axes among 'x', 'y', 'z', got {value!r}")
    return sorted("xyz".index(a) for a in value)


@dataclasses.dataclass(frozen=True)
class Box:
    """A periodic box (:meth:`Simulation.set_box`), as :attr:`Simulation.box` reports it.

    Attributes
    ----------
    lower, upper : numpy.ndarray, shape (3,)
        The corners [m].
    periodic : str
        The periodic axes, e.g. ``"xyz"``.
    shear_rate : float
        The Lees-Edwards rate [1/s] (0 without shear).
    shear_offset : float
        How far the images across the gradient faces have slid along the flow [m].
    flow, gradient : str or None
        The shear's axes (None without shear).
    pressure : float or None
        The target normal stress of a pressure-controlled box [Pa] (None without control).
    pressure_axis : str or None
        The axis whose length it controls.
    """

    lower: np.ndarray
    upper: np.ndarray
    periodic: str
    shear_rate: float = 0.0
    shear_offset: float = 0.0
    flow: str | None = None
    gradient: str | None = None
    pressure: float | None = None
    pressure_axis: str | None = None

    @property
    def lengths(self) -> np.ndarray:
        """upper - lower [m]."""
        return self.upper - self.lower

    @property
    def volume(self) -> float:
        """The box's volume [m^3]."""
        return float(np.prod(self.upper - self.lower))


def _declared_options(cls):
    """``cls`` with the constructor ``__init__(self, <each run option>)``: its keyword arguments,
    their order and defaults, and their Parameters entries in the class docstring, are the run
    options' declarations (cpp/include/tsubu/option_table.hpp); it calls ``cls._init(self,
    {option: value})``."""
    names = _options.declared("run")
    cls.__init__ = _options.keyword_function(f"{cls.__qualname__}.__init__", cls.__module__,
                                             names, cls._init)
    cls.__doc__ = _options.with_parameters(cls.__doc__, _options.parameter_entries(names))
    return cls


# The constructor's keyword arguments and their Parameters entries come from the run options'
# declarations (_declared_options).
@_one_thread_at_a_time("request_stop", "running", "step_count", "time",
                       refused={"__reduce__": _COPY_REFUSED})
@_declared_options
class Simulation:
    """Rigid spheres with linear (Kelvin-Voigt) or Hertz-Mindlin contacts, plane walls and gravity.

    The contact law follows from the materials (:class:`Material`); the options below are fixed
    at construction, except ``gravity``, ``dt`` and ``threads``, which are also assignable
    properties.

    Parameters
    ----------

    Raises
    ------
    TypeError
        For an option of the wrong type (a string where a number is expected, a float for
        ``threads``, a non-bool flag).
    ValueError
        For a value out of range or an unknown choice; the message names the argument and the
        value.

    Notes
    -----
    **Threads.** Runs release the GIL, so several Simulations can run at once from several threads (with
    the same results as one after the other). One Simulation is used by one thread at a time:
    while it runs, a call from another thread (another run, a setter, reading an array, ...)
    raises RuntimeError("Simulation is running in another thread ..."); only
    :meth:`request_stop`, :attr:`running`, and the progress counters :attr:`step_count` and
    :attr:`time` (those of a step completed) may be used meanwhile, say by a monitor thread.
    Calls that overlap a short call of another thread wait for it.

    **Arrays.** The arrays it returns (:attr:`positions`, :attr:`velocities`, :attr:`radii`,
    :attr:`gravity`, the arrays of :meth:`plane`, ...) are read-only copies: writing into one
    raises ValueError ("assignment destination is read-only") rather than change nothing.
    Assign the property to change the state: ``sim.positions = new`` (``x =
    sim.positions.copy()`` gives an array to edit first).

    **Copies.** ``copy.copy``, ``copy.deepcopy`` and ``pickle`` (so ``multiprocessing`` and
    Dask) give an independent Simulation through the checkpoint format (:meth:`save`,
    :meth:`load`): the same state, inserters with their progress, and ``metadata`` (which
    must be JSON-able), whose runs continue bit for bit as this one's would, for any thread
    count. The materials are shared by ``copy.copy`` (they are immutable), copied by
    ``deepcopy`` and pickling. Not carried: a pending :meth:`request_stop`, the diagnostics
    (:meth:`phase_seconds`, :attr:`rebuild_count`, ...: from zero), and the run hooks passed to
    :meth:`run` (they belong to that run). A Simulation is not copied while it runs
    (RuntimeError): copy it between runs, or from a run hook.
    """

    if TYPE_CHECKING:  # (type checkers do not see the made constructor: any keyword)
        def __init__(self, *args: Any, **options: Any) -> None: ...

    def _init(self, options: dict) -> None:
        """The constructor (``__init__``, made by _declared_options, passes its arguments as
        ``options``)."""
        self._lock = threading.RLock()  # _one_thread_at_a_time
        self._running = False  # True while the engine runs (and the GIL is released)
        self._in_run = False  # True from the start of run to its return (hooks act meanwhile)
        self._core = _core.Simulation()
        self._materials: list[Material] = []
        self._inserters: list = []  # hooks kept across runs (add_inserter)
        #: A JSON-able dict (default empty) saved with checkpoints (:meth:`save`) and restored by
        #: :meth:`load`; scene runs keep their scene there, for ``tsubu resume``.
        self.metadata: dict = {}
        self._material_index: dict[int, int] = {}
        self._scene_materials: list[Material] = []
        # Each option's check follows its declaration (option_table.hpp, tsubu._options), in the
        # declarations' order (but parallel_min's, which comes right after threads').
        for name in sorted(options, key=_RUN_OPTIONS.index):
            self._set_option(name, options[name])

    def _set_option(self, name: str, value) -> None:
        """Check the constructor's run option ``name`` and set it in the core."""
        if name in ("gravity", "dt", "threads"):  # (assignable properties, which check)
            setattr(self, name, value)
            return
        if value is None and DECLARATIONS[name].zero_means is not None:
            return  # the core's 0: its default
        value = _options.check(name, value)
        if name == "slip_rule" and value == "truncate" and self._core.history_rule != "rotate":
            raise ValueError("slip_rule='truncate' needs tangential_history='rotate', got "
                             f"{self._core.history_rule!r}")
        if name == "hertz_force":
            self._core.repulsive = value == "repulsive"
        else:
            setattr(self._core, _CORE_PROPERTY.get(name, name), value)

    # ---- options ---------------------------------------------------------------------------
    @property
    def gravity(self) -> np.ndarray:
        """Gravitational acceleration [m/s^2], shape (3,), a read-only copy. Assignable
        (ValueError for a non-finite vector or one that would give a sphere an energy beyond
        1e300 J)."""
        return _read_only(np.array(self._core.gravity))

    @gravity.setter
    def gravity(self, value) -> None:
        g = _options.check("gravity", value)
        if self.size:
            _energies_fit("gravity", self.masses, self.radii, x=self.positions, g=g)
        self._core.gravity = g

    @property
    def dt(self) -> float:
        """The time step [s] the next run uses (the one set, or :meth:`default_time_step`).
        Assignable: a float > 0, or None for the default."""
        return self._core.time_step()

    @dt.setter
    def dt(self, value) -> None:
        self._core.dt = 0.0 if value is None else _options.check("dt", value)

    @property
    def seed(self) -> int:
        """Seed of the roughness draws (read-only; set in the constructor)."""
        return self._core.seed

    @property
    def threads(self) -> int:
        """OpenMP threads runs may use, 0 for OpenMP's default (all cores).

        Assignable: an integer in [1, 4096], or None for the default. Results are the same bits
        for any count; more than twice the hardware threads (and more than 4) issue a
        :class:`PerformanceWarning`."""
        return self._core.threads

    @threads.setter
    def threads(self, value) -> None:
        threads = 0 if value is None else _options.check("threads", value)
        _warn_threads(threads)
        self._core.threads = threads

    @property
    def parallel_min(self) -> int:
        """Scenes with fewer spheres than this run on one thread (see the constructor;
        read-only)."""
        return self._core.parallel_min

    @property
    def threads_used(self) -> int:
        """Threads a run of this scene uses (read-only).

        1 below :attr:`parallel_min` spheres (or in a build without OpenMP), else
        :attr:`threads` or OpenMP's default."""
        return self._core.threads_used()

    @property
    def skin(self) -> float:
        """Neighbour-list skin [m]."""
        return self._core.skin()

    @property
    def law(self) -> str:
        """Name of the compiled contact-law specialisation the next run uses."""
        return self._core.law_name()

    # ---- materials ---------------------------------------------------------------------------
    def _material(self, material, name: str = "material", scene: bool = False) -> int:
        if not isinstance(material, Material):
            raise TypeError(f"{name} must be a tsubu.Material, got {material!r}")
        if scene and all(m is not material for m in self._scene_materials):
            for other in self._scene_materials:
                if other.hertzian != material.hertzian:
                    kinds = {True: "Hertzian (youngs_modulus)", False: "linear (kn, kt)"}
                    raise ValueError(
                        f"{name} {_label(material)} is {kinds[material.hertzian]} but the scene "
                        f"already has {_label(other)}, which is {kinds[other.hertzian]}: a scene's "
                        "spheres and walls all follow one contact law")
            self._scene_materials.append(material)
        key = id(material)
        if key not in self._material_index:
            self._material_index[key] = self._core.add_material(material._to_core())
            self._materials.append(material)  # keeps id(material) valid
        return self._material_index[key]

    def set_pair(self, material_a: Material, material_b: Material, **overrides) -> None:
        """Override the mixed contact parameters between two materials (either order).

        Parameters
        ----------
        material_a, material_b : Material
            The two materials (equal for the contacts of one material with itself).
        **overrides
            Any parameter of :class:`Material` but ``density``, ``youngs_modulus`` and
            ``poisson_ratio``, with its meaning, units and range (``roughness`` in degrees),
            and, for two Hertzian materials, ``effective_modulus`` (E* [Pa], > 0) and
            ``effective_shear_modulus`` (G* [Pa], >= 0). Those not given keep their mixed value
            (see :meth:`pair_parameters`).

        Raises
        ------
        TypeError
            For an unknown keyword, or a material that is not a :class:`Material`.
        ValueError
            For a value out of its range, or an ``effective_modulus`` given for a pair that is
            not Hertzian.
        """
        a = self._material(material_a, "material_a")
        b = self._material(material_b, "material_b")
        p = self.pair_parameters(material_a, material_b)
        for key, value in overrides.items():
            if key not in p:
                raise TypeError(f"set_pair got an unknown parameter {key!r}; expected one of {sorted(p)}")
            p[key] = _check_field(key, value)
        if (p["effective_modulus"] > 0) != (material_a.hertzian and material_b.hertzian):
            raise ValueError(
                "effective_modulus must be > 0 for a pair of Hertzian materials and 0 otherwise, "
                f"got {p['effective_modulus']!r}")
        _check_uniform_range(p["roughness_distribution"], p["roughness"])
        params = _to_core(_core.PairParams, p)
        self._core.set_pair_parameters(a, b, params)

    def pair_parameters(self, material_a: Material, material_b: Material) -> dict:
        """The contact parameters used between two materials (mixed, or as overridden).

        Parameters
        ----------
        material_a, material_b : Material
            The two materials, in either order.

        Returns
        -------
        dict
            Parameter name to value: the keywords of :meth:`set_pair`, in the units of
            :class:`Material` (roughness in degrees; ``effective_modulus`` 0 for a linear
            pair).

        Raises
        ------
        TypeError
            For an argument that is not a :class:`Material`.
        """
        return _from_core(self._core.pair_parameters(self._material(material_a, "material_a"),
                                                     self._material(material_b, "material_b")))

    # ---- scene -------------------------------------------------------------------------------
    def reserve(self, count: int) -> None:
        """Make room for ``count`` spheres in all before adding them in batches: the engine's
        particle arrays then grow once, which keeps peak memory down.

        Parameters
        ----------
        count : int
            Total number of spheres to make room for, >= 0.

        Raises
        ------
        TypeError
            For a count that is not an integer.
        ValueError
            For a negative count.
        MemoryError
            When ``count`` spheres cannot fit in the memory available.
        """
        count = _checks.whole("count", count)
        _checks.fits_in_memory("count", count)
        self._core.reserve(count)

    def add_spheres(self, positions, radius, material: Material, velocities=None,
                    angular_velocities=None) -> np.ndarray:
        """Add N spheres; returns their ids (consecutive integers, in the order given).

        Mass is density 4/3 pi r^3 and the moment of inertia 2/5 m r^2 (1.3). The arrays are
        copied (later changes to them do not reach the simulation). The result of a
        :mod:`tsubu.fill` generator plugs in: ``add_spheres(p.positions, p.radii, material)``.

        Parameters
        ----------
        positions : array_like, shape (N, 3)
            Centre positions [m]; a single 3-vector counts as N = 1.
        radius : float or array_like, shape (N,)
            Radii [m], > 0: one for all, or one per sphere.
        material : Material
            The spheres' material (one for all; call again for another material).
        velocities : array_like, shape (N, 3), optional
            Initial velocities [m/s]. Default None: at rest.
        angular_velocities : array_like, shape (N, 3), optional
            Initial angular velocities [rad/s]. Default None: not spinning.

        Returns
        -------
        numpy.ndarray of int64, shape (N,)
            The new spheres' ids; their rows in :attr:`positions` and the other arrays too,
            until a sphere is removed (then :meth:`rows`).

        Raises
        ------
        TypeError
            For non-numbers (booleans, complex numbers and strings too) or a material that is
            not a :class:`Material`.
        ValueError
            For wrong shapes, non-finite values, radii <= 0, radii whose mass or moment of
            inertia (or their inverses) overflow or vanish for the material's density, energies
            beyond 1e300 J per sphere, or a material whose contact law (linear or Hertzian)
            differs from the scene's.
        MemoryError
            Before anything is allocated, for more spheres than the available memory holds
            (about 400 bytes each).

        Notes
        -----
        Spheres added after the first run are checked for overlaps when the next run starts, as
        the first run checks all (``initial_overlap``): that run raises ValueError naming the
        spheres (or the wall) and takes no step.
        """
        return self._add_spheres(positions, radius, material, velocities, angular_velocities)

    def _add_spheres(self, positions, radius, material, velocities=None, angular_velocities=None,
                     check_overlaps: bool = True) -> np.ndarray:
        """:meth:`add_spheres`; ``check_overlaps=False`` leaves the spheres out of the next run's
        overlap check (for inserters, which place them clear of the others themselves)."""
        x = _checks.points("positions", positions)
        n = x.shape[0]
        _checks.fits_in_memory("positions", self.size + n)
        r = _checks.radii("radius", radius, n)
        if not isinstance(material, Material):
            raise TypeError(f"material must be a tsubu.Material, got {material!r}")
        mass = _check_mass(r, material)
        mat = self._material(material, scene=True)
        v = None if velocities is None else _checks.points("velocities", velocities, n)
        w = None if angular_velocities is None else _checks.points("angular_velocities", angular_velocities, n)
        _energies_fit("positions", mass, r, x=x, g=self.gravity)
        _energies_fit("velocities", mass, r, v=v)
        _energies_fit("angular_velocities", mass, r, w=w)
        first = self._core.add_spheres(x, r, np.full(n, mat, dtype=np.intc), v, w, check_overlaps)
        return np.arange(first, first + n, dtype=np.int64)

    def add_sphere(self, position, radius: float, material: Material, velocity=None,
                   angular_velocity=None) -> int:
        """Add one sphere; returns its id (an int).

        Parameters
        ----------
        position : array_like, shape (3,)
            Centre [m].
        radius : float
            Radius [m], > 0.
        material : Material
            The sphere's material.
        velocity : array_like, shape (3,), optional
            Initial velocity [m/s]. Default None: at rest.
        angular_velocity : array_like, shape (3,), optional
            Initial angular velocity [rad/s]. Default None: not spinning.

        Raises
        ------
        TypeError
            For non-numbers or a material that is not a :class:`Material`.
        ValueError
            For a radius <= 0, wrong shapes or non-finite values (as :meth:`add_spheres`).
        MemoryError
            When no memory is left for one more sphere.
        """
        ids = self.add_spheres(
            [_checks.vec3("position", position)], _checks.positive("radius", radius), material,
            None if velocity is None else [_checks.vec3("velocity", velocity)],
            None if angular_velocity is None else [_checks.vec3("angular_velocity", angular_velocity)])
        return int(ids[0])

    def add_plane(self, point=None, normal=None, material: Material | None = None,
                  velocity=(0.0, 0.0, 0.0), angular_velocity=(0.0, 0.0, 0.0),
                  coefficients=None, center=None) -> int:
        """Add an infinite plane wall; returns its index (an int, counted from 0).

        Give either ``point`` and ``normal``, or ``coefficients`` = (a, b, c, d) of
        a x + b y + c z + d = 0 (3.2). The normal (or (a, b, c)) points to the side where
        spheres live: a plane is a half-space, and a sphere whose centre crosses it is an
        instability. The wall's velocity at the contact point enters the relative velocity.
        Wall contacts use the particle's mass as m_eff.

        Parameters
        ----------
        point : array_like, shape (3,), optional
            A point of the plane [m], also the centre of its rotation. Default the origin.
        normal : array_like, shape (3,), optional
            The normal, towards the spheres' side; any nonzero length (it is normalised).
            Default ``(0, 0, 1)``.
        material : Material
            The wall's material (required).
        velocity : array_like, shape (3,)
            Translation velocity [m/s], at most the speed of light (299,792,458 m/s)
            in magnitude. Default zero.
        angular_velocity : array_like, shape (3,)
            Angular velocity [rad/s] about ``center``. Default zero. A run refuses (ValueError) a
            rotation that moves the wall faster than light where a sphere is.
        coefficients : array_like, shape (4,), optional
            (a, b, c, d), instead of ``point`` and ``normal``.
        center : array_like, shape (3,), optional
            The centre of the wall's rotation [m]; default its point. Planes (and meshes) that
            share a centre and a motion turn together as one body (a box of planes).

        Raises
        ------
        TypeError
            Without a material, or for arguments that are not numbers.
        ValueError
            For both ``coefficients`` and ``point``/``normal``, a zero normal, non-finite
            values, a velocity faster than light, or a material whose contact law differs from
            the scene's.
        """
        if material is None:
            raise TypeError("add_plane needs a material")
        if coefficients is not None:
            if point is not None or normal is not None:
                raise ValueError("give either coefficients or point and normal, not both")
            c = _checks._float_array("coefficients", coefficients, "4 numbers (a, b, c, d)")
            if c.shape != (4,) or not np.all(np.isfinite(c)):
                raise ValueError(f"coefficients must be 4 finite numbers (a, b, c, d), got {coefficients!r}")
            scale = float(np.max(np.abs(c[:3])))
            if scale == 0:
                raise ValueError(f"coefficients (a, b, c) must not all be zero, got {coefficients!r}")
            with np.errstate(all="ignore"):
                c = c / scale  # (a, b, c) of order 1: |n|^2 neither overflows nor underflows
                normal = c[:3]
                point = -c[3] * c[:3] / float(c[:3] @ c[:3])
            if not np.all(np.isfinite(point)):
                raise ValueError(f"coefficients put the plane beyond the range of floats: {coefficients!r}")
        if point is None:
            point = (0.0, 0.0, 0.0)
        if normal is None:
            normal = (0.0, 0.0, 1.0)
        p = _checks.vec3("point", point)
        nrm = _unit("normal", normal)
        c = p if center is None else _checks.vec3("center", center)
        return self._core.add_plane(p, nrm, self._material(material, scene=True), _wall_velocity("velocity", velocity),
                                    _checks.vec3("angular_velocity", angular_velocity), c)

    def add_mesh(self, vertices, faces, material: Material | None = None, velocity=(0.0, 0.0, 0.0),
                 angular_velocity=(0.0, 0.0, 0.0), center=None) -> int:
        """Add a triangle-mesh wall; returns its wall index (shared with planes).

        Spheres touch a triangle on either side, at its face, an edge or a vertex, whichever
        is nearest; on a smooth surface made of many triangles a sphere has one contact, whose
        tangential history crosses the triangles' edges whole, and in a concave corner one
        contact per face it presses (docs/geometry.md). Triangles are joined through shared
        vertex indices (vertices at equal coordinates are joined too). The mesh need not be
        closed. It moves as a rigid body. Wall contacts use the particle's mass as m_eff.

        Parameters
        ----------
        vertices : array_like, shape (V, 3)
            Vertex coordinates [m], where the mesh is now.
        faces : array_like of int, shape (F, 3)
            Each triangle's three vertex indices (0-based).
        material : Material
            The wall's material (required).
        velocity : array_like, shape (3,)
            Translation velocity [m/s] of the whole mesh. Default zero.
        angular_velocity : array_like, shape (3,)
            Angular velocity [rad/s] about ``center``. Default zero.
        center : array_like, shape (3,), optional
            Centre of rotation [m] (also the point wall torques are taken about). Default the
            mean of the vertices.

        Raises
        ------
        TypeError
            Without a material, or for arguments that are not numbers.
        ValueError
            For arrays of the wrong shape, non-finite coordinates, face indices out of range or
            repeated within a triangle, degenerate (zero-area) triangles (each named), or a
            velocity faster than light.

        Examples
        --------
        >>> import tsubu
        >>> sim = tsubu.Simulation()
        >>> steel = tsubu.Material(density=7800, kn=1e5)
        >>> sim.add_mesh(*tsubu.mesh.box((0, 0, 0), (0.1, 0.1, 0.1)), material=steel)
        0
        """
        if material is None:
            raise TypeError("add_mesh needs a material")
        from .mesh import check_mesh
        v, f = check_mesh(vertices, faces)
        c = tuple(float(x) for x in v.mean(axis=0)) if center is None else _checks.vec3("center", center)
        return self._core.add_mesh(v, f, self._material(material, scene=True), _wall_velocity("velocity", velocity),
                                   _checks.vec3("angular_velocity", angular_velocity), c)

    def set_wall_motion(self, wall: int, velocity=None, angular_velocity=None, center=None) -> None:
        """Change a wall's (plane's or mesh's) motion, from the next step on.

        Parameters
        ----------
        wall : int
            The wall's index (as :meth:`add_plane` or :meth:`add_mesh` returned it).
        velocity : array_like, shape (3,), optional
            New translation velocity [m/s]. Default None: unchanged.
        angular_velocity : array_like, shape (3,), optional
            New angular velocity [rad/s] about the wall's centre. Default None: unchanged.
        center : array_like, shape (3,), optional
            New centre of rotation [m] (the wall does not move when it changes). Default None:
            unchanged.

        Raises
        ------
        TypeError
            For an index that is not an integer, or vectors that are not numbers.
        ValueError
            For a wall that does not exist, non-finite vectors, or a velocity faster than light.
        """
        state = self.wall(wall)
        v = state["velocity"] if velocity is None else _wall_velocity("velocity", velocity)
        w = state["angular_velocity"] if angular_velocity is None else _checks.vec3("angular_velocity", angular_velocity)
        c = None if center is None else _checks.vec3("center", center)
        self._core.set_plane_motion(wall, v, w)
        if c is not None:
            self._core.set_wall_center(wall, c)

    def remove_wall(self, wall: int) -> None:
        """Take a wall out of the scene (a gate that opens): from the next run on it touches
        nothing, and its contacts end (their stored energy leaves with them). The other walls
        keep their indices; the removed one stays listed, with ``removed`` true.

        Raises
        ------
        TypeError
            For an index that is not an integer.
        ValueError
            For a wall that does not exist.
        """
        self.wall(wall)
        self._core.remove_wall(wall)

    def set_wall_servo(self, wall: int, force: float, max_speed: float, direction=None,
                       gain: float | None = None) -> None:
        """Drive a wall by a target force: a servo wall (confined compression at a set load).

        Every step, after the contact forces, the wall's velocity becomes
        ``direction * gain * (force - F)``, at most ``max_speed`` in magnitude, where F is the
        force its contacts put on the spheres along ``direction`` (its push). The wall so moves
        towards the spheres while it pushes less than ``force`` and backs off while it pushes
        more; it does not turn. The control is proportional, on the wall's velocity (the wall
        has no mass): the load settles with the time constant 1 / (gain k), k the stiffness the
        pack offers the wall [N/m]; an explicit step stays stable while gain k dt < 1, which the
        default gain keeps for packs up to k = force / (max_speed dt).

        Parameters
        ----------
        wall : int
            The wall (a plane or a mesh).
        force : float
            The target push [N], >= 0.
        max_speed : float
            The largest speed [m/s] the wall moves at (> 0): its approach speed when free.
        direction : array_like, shape (3,), optional
            The direction it pushes along (any length; normalised). Default a plane's normal
            (towards the spheres); required for a mesh.
        gain : float, optional
            [m/(N s)], > 0. Default ``max_speed / force`` (the wall slows linearly as it
            loads), or 1e-3 max_speed when ``force`` is 0.

        Raises
        ------
        ValueError
            For a wall that does not exist, a mesh without ``direction``, a zero direction, a
            negative force, or a gain or max_speed that is not positive and finite.
        """
        state = self.wall(wall)
        force = _checks.positive("force", force, allow_zero=True)
        max_speed = _checks.positive("max_speed", max_speed)
        if max_speed > MAX_WALL_SPEED:
            raise ValueError(f"max_speed must be at most the speed of light, {MAX_WALL_SPEED:g} m/s, got {max_speed!r}")
        if direction is None:
            if state["kind"] != "plane":
                raise ValueError(f"set_wall_servo: wall {wall} is a mesh: give its direction")
            direction = state["normal"]
        d = _unit("direction", direction)
        if gain is None:
            gain = max_speed / force if force > 0 else 1e-3 * max_speed
        gain = _checks.positive("gain", gain)
        self._core.set_wall_servo(wall, d, force, float(gain), max_speed)

    def clear_wall_servo(self, wall: int) -> None:
        """Stop driving a wall by force (:meth:`set_wall_servo`); it stands still."""
        self.wall(wall)
        self._core.clear_wall_servo(wall)

    def _wall_index(self, wall) -> int:
        """``wall`` checked to be the index of an existing wall (TypeError, ValueError)."""
        wall = _checks.whole("wall", wall)
        if wall >= self._core.plane_count:
            raise ValueError(f"wall {wall} does not exist: the simulation has {self._core.plane_count} "
                             f"walls (wall must be < {self._core.plane_count})")
        return wall

    @property
    def wall_count(self) -> int:
        """Number of walls, planes and meshes (indices 0 to wall_count - 1, removed ones too)."""
        return self._core.plane_count

    def wall(self, wall: int) -> dict:
        """A wall's current state.

        Returns
        -------
        dict
            ``kind`` ("plane" or "mesh"), ``center`` [m], ``velocity`` [m/s],
            ``angular_velocity`` [rad/s], ``material`` (the :class:`Material`), ``removed``
            (bool); a plane also ``point`` [m] and ``normal``; a mesh also ``vertices`` (V, 3)
            [m], where it is now, and ``faces`` (F, 3); a servo wall also ``servo`` (a dict:
            ``direction``, ``force``, ``gain``, ``max_speed``). Arrays are read-only copies.

        Raises
        ------
        TypeError
            For an index that is not an integer.
        ValueError
            For a wall that does not exist.
        """
        wall = self._wall_index(wall)
        d = self._core.wall(wall)
        out = {}
        for k, v in d.items():
            if k == "material":
                out[k] = self._materials_by_index(v)
            elif k in ("kind", "removed", "servo"):
                out[k] = v
            else:
                out[k] = _read_only(np.array(v))
        return out

    def wall_forces(self) -> np.ndarray:
        """The force [N] the spheres put on each wall, as the last step evaluated its contacts.

        Returns
        -------
        numpy.ndarray, shape (wall_count, 3)
            Row w: the sum over wall w's contacts of the force on the wall (minus the force on
            the sphere); zero for a removed wall. A silo wall's load; a resting pack's weight on
            its floor.
        """
        return _read_only(self._core.wall_loads()[0])

    def wall_torques(self) -> np.ndarray:
        """The torque [N m] the spheres put on each wall about its centre (``wall(w)["center"]``),
        as the last step evaluated its contacts: the moment of each contact force at its contact
        point, and the reaction of any rolling-resistance torque. A drum's driving torque is
        minus its component along the axis.

        Returns
        -------
        numpy.ndarray, shape (wall_count, 3)
        """
        return _read_only(self._core.wall_loads()[1])

    # ---- stress (stress.cpp, docs/stress.md) --------------------------------------------------

    def stress(self, volume=None, per_particle: bool = False) -> np.ndarray:
        """The Cauchy stress of the spheres (Love-Weber), as the last step evaluated its contacts.

        sigma = (1/V) sum_i [ -m_i v'_i (x) v'_i + sum_{c of i} (x_c - x_i) (x) f_c ],

        with f_c each contact force on sphere i (:meth:`contacts`: a pair's partner gets -f),
        x_c its contact point (a pair's on the line of centres, splitting it at the levers'
        ratio (r_i - overlap/2) : (r_j - overlap/2); a wall's ``wall_point``), and v' = v - u(x)
        the velocity relative to the mean flow u: in a Lees-Edwards box (:meth:`set_shear`) u =
        rate (x_gradient - centre_gradient) along the flow, else 0. Tension is positive: a
        compressed pack has a negative diagonal (:meth:`pressure` is minus its mean). Periodic
        images count through their source spheres, with the minimum-image branch vector.

        Parameters
        ----------
        volume : float, optional
            The volume V [m^3] the sum is divided by, > 0. Default None: the periodic box's
            (:attr:`box`, ``box.volume``); a scene without a box needs it explicitly (the
            volume the walls enclose).
        per_particle : bool
            If True, return each sphere's bracket instead: sigma_i V [N m] (stress times
            volume, not divided by V), in id order, whose sum over the spheres is
            ``stress(volume) * volume`` to round-off (for coarse-graining). ``volume`` is then
            not needed (validated if given).

        Returns
        -------
        numpy.ndarray
            Shape (3, 3) [Pa], or (N, 3, 3) [N m] with ``per_particle``; a read-only copy. The
            contact part of a static pack without rolling resistance is symmetric to the
            residual of the force balance; the kinetic part always is.

        Raises
        ------
        TypeError
            For a volume that is not a number, or per_particle that is not a bool.
        ValueError
            For a volume that is not finite and positive, or None in a scene without a box.
        """
        if not isinstance(per_particle, (bool, np.bool_)):
            raise TypeError(f"per_particle must be True or False, got {per_particle!r}")
        box = getattr(self, "box", None)
        if volume is not None:
            volume = _checks.positive("volume", volume)
        elif box is not None:
            volume = float(box.volume)
        elif per_particle:
            volume = 1.0  # (the brackets do not depend on it)
        else:
            raise ValueError("stress: volume=None needs a periodic box (set_box); a walled or open "
                             "scene needs an explicit volume [m^3], e.g. the volume its walls enclose")
        rate, flow, gradient, reference = 0.0, 0, 2, 0.0
        if box is not None and box.shear_rate and box.flow is not None:
            flow, gradient = "xyz".index(box.flow), "xyz".index(box.gradient)
            rate = float(box.shear_rate)
            reference = 0.5 * float(box.lower[gradient] + box.upper[gradient])
        sigma, per = self._core.stress(volume, rate, flow, gradient, reference, bool(per_particle))
        return _read_only(per if per_particle else sigma)

    def pressure(self, volume=None) -> float:
        """The mean normal stress [Pa], compression positive: p = -trace(sigma) / 3 with sigma
        :meth:`stress`.

        Parameters
        ----------
        volume : float, optional
            The volume [m^3], > 0, as for :meth:`stress` (default None: the periodic box's).

        Returns
        -------
        float
            The pressure [Pa] (positive in a compressed pack).

        Raises
        ------
        TypeError, ValueError
            As :meth:`stress` for the volume.
        """
        return float(-np.trace(self.stress(volume)) / 3.0)

    def set_plane_motion(self, wall: int, velocity=None, angular_velocity=None) -> None:
        """Change a wall's velocity and/or angular velocity (from the next step on).

        Parameters
        ----------
        wall : int
            The wall's index (as returned by :meth:`add_plane`).
        velocity : array_like, shape (3,), optional
            New translation velocity [m/s], at most the speed of light (299,792,458 m/s)
            in magnitude. Default None: unchanged.
        angular_velocity : array_like, shape (3,), optional
            New angular velocity [rad/s] about the wall's centre (its point unless
            given). Default None: unchanged. (:meth:`set_wall_motion` can also move the centre.) A run refuses (ValueError) a rotation that moves the wall faster than
            light where a sphere is.

        Raises
        ------
        TypeError
            For an index that is not an integer, or vectors that are not numbers.
        ValueError
            For a wall that does not exist, non-finite vectors, or a velocity faster than
            light.
        """
        self.plane(wall)  # (a plane's: a mesh is refused, naming wall())
        self.set_wall_motion(wall, velocity=velocity, angular_velocity=angular_velocity)

    @property
    def plane_count(self) -> int:
        """Number of plane walls (their indices are 0 to plane_count - 1)."""
        return self._core.plane_count

    def plane(self, wall: int) -> dict:
        """A wall's current state.

        Parameters
        ----------
        wall : int
            The wall's index (as returned by :meth:`add_plane`).

        Returns
        -------
        dict
            ``point`` [m], ``normal`` (unit), ``velocity`` [m/s], ``angular_velocity``
            [rad/s], each a read-only numpy array of shape (3,) (a copy: change the motion
            with :meth:`set_plane_motion`), and ``material`` (the :class:`Material`).

        Raises
        ------
        TypeError
            For an index that is not an integer.
        ValueError
            For a wall that does not exist.
        """
        wall = self._wall_index(wall)
        if self._core.wall(wall)["kind"] != "plane":
            raise ValueError(f"wall {wall} is a mesh, not a plane: use wall({wall})")
        d = self._core.plane(wall)
        return {k: (_read_only(np.array(v)) if k != "material" else self._materials_by_index(v))
                for k, v in d.items()}

    # ---- a periodic box and Lees-Edwards shear (docs/periodic.md) ----------------------------

    def set_box(self, lower, upper, periodic: str = "xyz") -> None:
        """Make the scene periodic along some axes: a sphere leaving the box through a face
        comes back through the opposite one, and spheres near a face touch the images of those
        near the other (contacts keep their history across the faces). Spheres outside the box
        are wrapped into it when the next run starts; their images are counted
        (:attr:`images`, :attr:`unwrapped_positions`).

        Parameters
        ----------
        lower, upper : array_like, shape (3,)
            The box's corners [m]. Along the periodic axes they are the cell's faces (each
            length at least twice the neighbour reach, 2 (2 r_max + skin), checked when a run
            starts); along the others they set only the volume :meth:`stress` divides by.
        periodic : str
            The periodic axes, a combination of ``"x"``, ``"y"``, ``"z"`` (default ``"xyz"``);
            ``""`` makes the scene open again. Walls and meshes still bound the other axes.

        Raises
        ------
        TypeError
            For corners that are not numbers or axes that are not a string.
        ValueError
            For non-finite corners, ``upper <= lower`` along a periodic axis, or unknown axes.
        """
        lo = _checks.vec3("lower", lower)
        hi = _checks.vec3("upper", upper)
        axes = _axes("periodic", periodic)
        for d in axes:
            if not hi[d] > lo[d]:
                raise ValueError(f"upper must exceed lower along the periodic axis {'xyz'[d]}: "
                                 f"got lower={lo[d]!r}, upper={hi[d]!r}")
        self._core.set_box(lo, hi, [d in axes for d in range(3)])

    def set_shear(self, rate: float, flow: str = "x", gradient: str = "z") -> None:
        """Lees-Edwards simple shear: the images across the ``gradient`` faces slide along
        ``flow`` at ``rate`` x L_gradient (their offset grows by that speed) and move that much
        faster, so that the mean flow u = rate (x_gradient - centre) along ``flow`` develops
        without walls. The rate may change between runs; 0 stops the slide where it is.

        Parameters
        ----------
        rate : float
            Shear rate [1/s] (any sign).
        flow, gradient : str
            Two different axes, ``"x"``, ``"y"`` or ``"z"``, both periodic (:meth:`set_box`).

        Raises
        ------
        ValueError
            For a non-finite rate, equal or unknown axes, or axes that are not periodic.
        """
        r = _checks.bounded("rate", rate, None, None, lo_open=False, hi_open=False)
        f = _axis("flow", flow)
        g = _axis("gradient", gradient)
        if f == g:
            raise ValueError(f"flow and gradient must be different axes, got {flow!r} for both")
        box = self.box
        if box is None or "xyz"[f] not in box.periodic or "xyz"[g] not in box.periodic:
            raise ValueError(f"set_shear: the box must be periodic along the flow ({flow!r}) and the "
                             f"gradient ({gradient!r}) axes; call set_box first")
        self._core.set_shear(r, f, g)

    def set_pressure(self, pressure: float, gain: float, axis: str = "z",
                     max_strain_rate: float | None = None) -> None:
        """Pressure control: the box's length along ``axis`` follows a target normal stress,
        so that a sheared cell runs at constant pressure (mu(I) rheology). After every step the
        box stretches about its lower face, the spheres with it (affinely), at the strain rate

            d ln L / dt = gain * (P - pressure),  capped at +/- max_strain_rate,

        where P is the normal stress along ``axis`` (compression positive): the spheres'
        kinetic part (velocities less the Lees-Edwards mean flow) plus their contacts' virial,
        over the box volume. A pack answers a strain with a stress change K x strain (K ~ kn / d
        for a linear law of stiffness kn and diameter d): the box then relaxes toward the target
        with the time constant 1 / (K gain). Keep that well above the time a stress wave takes
        to cross the box (~ (L / d) contact durations): gain = d / (kn * 20 * (L / d) * t_c) is
        a safe start (t_c = :meth:`contact_duration`); a larger gain overshoots and oscillates.

        Parameters
        ----------
        pressure : float
            Target normal stress [Pa], > 0.
        gain : float
            [1 / (Pa s)], > 0 (see above).
        axis : str
            The controlled axis, periodic (default ``"z"``, the gradient of a default shear).
        max_strain_rate : float, optional
            Cap on the magnitude of d ln L / dt [1/s]. Default: 0.01 / :meth:`contact_duration`.

        Raises
        ------
        ValueError
            For a non-positive or non-finite value, or an axis that is not periodic.
        """
        p = _checks.positive("pressure", pressure)
        k = _checks.positive("gain", gain)
        a = _axis("axis", axis)
        box = self.box
        if box is None or "xyz"[a] not in box.periodic:
            raise ValueError(f"set_pressure: the box must be periodic along axis {axis!r}; call set_box first")
        if max_strain_rate is None:
            duration = self.contact_duration()
            if not (math.isfinite(duration) and duration > 0):
                raise ValueError("set_pressure: max_strain_rate defaults to 0.01 / contact_duration(), and this "
                                 "scene has no contact duration yet (no spheres, or no stiffness): add the "
                                 "spheres first or give max_strain_rate")
            rate = 0.01 / duration
        else:
            rate = _checks.positive("max_strain_rate", max_strain_rate)
        self._core.set_pressure(p, a, k, rate)

    def clear_pressure(self) -> None:
        """End pressure control: the box keeps the length it has."""
        self._core.clear_pressure()

    def box_pressure(self, axis: str = "z") -> float:
        """The normal stress along ``axis`` [Pa], compression positive, as the pressure control
        measures it (kinetic part less the mean shear flow, plus the contacts' virial, over the
        box volume; the contacts of the last step)."""
        if self.box is None:
            raise ValueError("box_pressure needs a periodic box (set_box)")
        return float(self._core.box_pressure(_axis("axis", axis)))

    @property
    def box(self) -> "Box | None":
        """The periodic box (:class:`tsubu.Box`), or None for an open scene."""
        b = self._core.box()
        axes = "".join(a for a, p in zip("xyz", b["periodic"]) if p)
        if not axes:
            return None
        flow_length = b["upper"][b["flow"]] - b["lower"][b["flow"]]
        return Box(lower=np.array(b["lower"]), upper=np.array(b["upper"]), periodic=axes,
                   shear_rate=b["shear_rate"] if b["sheared"] else 0.0,
                   shear_offset=math.fmod(b["shear_offset"], flow_length) if b["sheared"] else 0.0,
                   flow="xyz"[b["flow"]] if b["sheared"] else None,
                   gradient="xyz"[b["gradient"]] if b["sheared"] else None,
                   pressure=b["pressure"] if b["pressure_on"] else None,
                   pressure_axis="xyz"[b["pressure_axis"]] if b["pressure_on"] else None)

    @property
    def images(self) -> np.ndarray:
        """Images crossed by each sphere along x, y, z since it was added (int64, shape (N, 3)),
        +1 each time it left through the upper face; zero in an open scene."""
        return _read_only(self._core.images())

    @property
    def unwrapped_positions(self) -> np.ndarray:
        """Positions as if no sphere had been wrapped [m], shape (N, 3), ``positions + images *
        L`` plus, across Lees-Edwards faces, the slides taken; their differences over time are
        the spheres' displacements (diffusion)."""
        return _read_only(self._core.unwrapped_positions())

    def _materials_by_index(self, index: int) -> Material:
        for m in self._materials:
            if self._material_index[id(m)] == index:
                return m
        raise KeyError(index)

    def add_inserter(self, *args, **kwargs):
        """Pour spheres into a region during runs; returns the :class:`tsubu.Inserter`.

        The arguments are those of :class:`tsubu.Inserter` (region, rate, sizes, material,
        velocity, ...). The inserter acts in every later run of this Simulation (before the
        output hooks), and checkpoints keep its progress.

        Raises
        ------
        TypeError, ValueError
            A bad argument (named), as :class:`tsubu.Inserter` raises; ValueError also when
            the material's contact law differs from the scene's (Hertz with linear).
        """
        from .insert import Inserter

        inserter = Inserter(*args, **kwargs)
        inserter._attach(self)
        self._inserters.append(inserter)
        return inserter

    @property
    def inserters(self) -> list:
        """The inserters added with :meth:`add_inserter`, in order."""
        return list(self._inserters)

    # ---- time stepping -----------------------------------------------------------------------
    def critical_time_step(self) -> float:
        """The stability bound of the time step for this scene [s].

        (2.31) gives 2 sqrt(m/k) for the spring and 2 m/eta for the dashpot, analysed apart;
        for the two together symplectic Euler (dashpot on the old velocity) is stable only for
        dt < 4 m / (eta + sqrt(eta^2 + 4 k m)), which equals 2 sqrt(m/k) when eta = 0 and is
        below both otherwise (0.81 x 2 sqrt(m/k) at e = 0.5). This is what is returned, taken
        over every kind of contact the scene can have: for each pair of sphere materials the
        reduced mass of their lightest spheres, for walls the lightest sphere's mass, for the
        normal spring (kn, eta_n) and, with friction, the tangential one (kt, eta_t) acting on
        m/3.5 (a sphere that can roll: 1/m + c^2/I = 3.5/m). Dense packs with many contacts
        per sphere are stable only below a fraction of it.
        """
        return self._core.critical_time_step()

    def contact_duration(self) -> float:
        """The shortest contact duration of the scene [s]: t_c = pi/alpha (B.3, B.5) for the
        linear law; for Hertzian materials Hertz's t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5) at the
        impact speed v = ``characteristic_speed()``."""
        return self._core.contact_duration()

    def default_time_step(self) -> float:
        """t_c / 50, and for Hertzian materials at most 0.2 ``rayleigh_time()``: the time step
        used when none is set [s]."""
        return self._core.default_time_step()

    def rayleigh_time(self) -> float:
        """The Rayleigh time ``pi r sqrt(rho/G) / (0.1631 nu + 0.8766)`` [s] of the scene's
        smallest Hertzian sphere (per material), G = E / (2 (1 + nu)): the time a Rayleigh
        wave takes to cross it. Hertzian DEM codes keep dt below 0.1-0.3 of it. ``inf`` for a
        linear scene."""
        return self._core.rayleigh_time()

    def characteristic_speed(self) -> float:
        """The normal impact speed [m/s] a Hertzian scene's contact duration and bounds use:
        ``impact_speed`` if given, else twice the largest sphere speed now, at least 1 m/s."""
        return self._core.characteristic_speed()

    def run(self, steps: int | None = None, time: float | None = None, *, progress=None,
            output=None, checkpoint=None, checkpoint_every: int | None = None,
            checkpoint_keep: int = 3) -> "Simulation":
        """Advance by ``steps`` steps or by ``time`` seconds (rounded to whole steps of the dt
        at the start of the run).

        Parameters
        ----------
        steps : int, optional
            Number of steps (>= 0). Give exactly one of ``steps`` and ``time``.
        time : float, optional
            Simulated time [s] (>= 0), rounded to the nearest whole number of steps. 0 runs no
            step; a time > 0 that rounds to none (below dt/2) raises ValueError rather than run
            nothing.
        progress : bool or None, default None
            Show a progress bar on stderr (tqdm: simulated time, steps/s, particle-steps/s and
            time left). None: only on an interactive terminal (not in pipes, CI or notebooks),
            for runs longer than 2 s, and only if tqdm is installed; True: always (ImportError
            without tqdm); False: never.
        output : hook or list of hooks, optional
            Objects called between steps, such as :class:`tsubu.output.VTKOutput` (see
            :mod:`tsubu.hooks`). The Simulation's inserters (:meth:`add_inserter`) run first.
        checkpoint : str or path, optional
            Where to save a checkpoint (:meth:`save`) when the run ends: when it finishes, on a
            requested stop and on Ctrl-C (then before KeyboardInterrupt propagates); not after
            an InstabilityError.
        checkpoint_every : int, optional
            Also save a checkpoint every this many steps (counted from step 0), to numbered
            files beside ``checkpoint`` (``run.tsubu`` -> ``run.step000000001000.tsubu``).
        checkpoint_keep : int, default 3
            How many of the numbered checkpoints to keep (the newest).

        Returns
        -------
        Simulation
            self.

        Raises
        ------
        InstabilityError
            The run went unstable (the last good state stays readable): an overlap beyond
            ``max_overlap``, a non-finite force or velocity, a step that moved a sphere further
            than the overlap check can follow, or (with fixed walls) an energy balance that grew,
            audited every 1,000th step and when the run ends.
        ValueError
            A dt above the stability bound, initial overlaps, a time shorter than half a step,
            or a bad argument.
        KeyboardInterrupt
            Ctrl-C (SIGINT) during the run.

        Notes
        -----
        A run stops early, at a step boundary, on Ctrl-C or :meth:`request_stop`: Ctrl-C is
        noticed within 20 ms of wall time plus one step and raises KeyboardInterrupt (any
        exception raised by a Python signal handler is raised the same way); a requested stop
        returns normally, with :attr:`stopped` True. Either way the state is that of the last
        completed step (positions, velocities, spins, contact history, ``step_count`` and
        ``time`` agree), and running the remaining steps, ``run(steps=requested - (step_count -
        step_count_before))``, gives the same bits as a run that never stopped. Signals are
        checked only when run is called from the main thread (the only one Python runs signal
        handlers on). While it runs, the Simulation refuses calls from other threads (see the
        class's Threads section). Hooks run in the calling thread with the Simulation usable.
        """
        if (steps is None) == (time is None):
            raise TypeError("run needs exactly one of steps= or time=")
        if time is not None:
            t = _checks.positive("time", time, allow_zero=True)
            steps = _steps_for(t, self.dt)
        steps = _checks.whole("steps", steps)
        outputs = [] if output is None else list(output) if isinstance(output, (list, tuple)) else [output]
        for k, hook in enumerate(outputs):
            hooks.check_hook(hook, "output" if len(outputs) == 1 else f"output[{k}]")
        path = None
        if checkpoint is not None:
            path = _checks.path("checkpoint", checkpoint)
        periodic = []
        if checkpoint_every is not None:
            if path is None:
                raise ValueError("checkpoint_every needs checkpoint= (the path beside which the "
                                 "numbered checkpoints are written)")
            every = _checks.whole("checkpoint_every", checkpoint_every, minimum=1)
            keep = _checks.whole("checkpoint_keep", checkpoint_keep, minimum=1)
            periodic = [hooks.PeriodicCheckpoint(path, every, keep)]
        bar = hooks.progress_bar(self, steps, progress)
        everything = list(self._inserters) + outputs + periodic
        if self._in_run:
            raise RuntimeError("Simulation.run called during the Simulation's own run (from a run "
                               "hook): wait for run to return")
        self._in_run = True
        try:
            start = self._core.step_count
            self._run_hooks(start + steps, everything, bar)
            self._audit_energy(start)
        except KeyboardInterrupt:
            if path is not None:
                self.save(path)
            raise
        finally:
            self._in_run = False
            if bar is not None:
                bar.close()
            for hook in everything:
                hook.close(self)
        if path is not None:
            self.save(path)
        return self

    def _run_hooks(self, end: int, everything: list, bar) -> None:
        """Steps to ``end``, with the hooks acting at the steps they ask for."""
        first = True
        while True:
            now = self._core.step_count
            target = end
            for hook in everything:
                due = hooks.due_step(hook, self)
                if due is not None and due <= now:
                    hook.act(self)
                    due = hooks.due_step(hook, self)
                    if due is not None and due <= now:
                        raise RuntimeError(f"run hook {hook!r} acted at step {now} and asks for step "
                                           f"{due} again: next_step must move on after act")
                if due is not None and due < target:
                    target = due
            if now >= end:
                return
            if first:
                self._check_skin()
                first = False
            if bar is not None:
                target = min(target, bar.limit(now))
            asked = target - now
            started = _time.perf_counter()
            self._running = True
            try:
                taken = self._advance(asked)
            finally:
                self._running = False
            if bar is not None:
                bar.update(taken, _time.perf_counter() - started)
            if taken < asked:  # request_stop()
                return

    def _advance(self, steps: int) -> int:
        # The energy audit runs once when the whole run ends (_audit_energy), not after each
        # stretch between hooks.
        try:
            return self._core.run(steps, False)
        except _core.InstabilityError as e:
            message, step, particle = e.args
            raise InstabilityError(message, step, particle) from None

    def _audit_energy(self, start: int) -> None:
        """The energy audit of the end of a run that started at step ``start`` (with fixed walls,
        if it passed a multiple of 100 steps: InstabilityError if the balance grew;
        docs/physics.md)."""
        try:
            self._core.audit_run_end(start)
        except _core.InstabilityError as e:
            message, step, particle = e.args
            raise InstabilityError(message, step, particle) from None

    def _check_skin(self) -> None:
        """PerformanceWarning before a run's first step when a skin set beyond the largest
        diameter fills the neighbour list with far more pairs than can touch (the lists are
        built now, as the run would build them: a list that cannot fit raises MemoryError)."""
        if self._core.skin_option <= 0 or self.size == 0:
            return  # the default skin is a fraction of the mean diameter
        diameter = 2.0 * float(np.max(self.radii))
        skin = self.skin
        if skin <= diameter:
            return  # (before building the lists: the run builds them, once)
        self._core.prepare_run()
        pairs, n = self._core.neighbor_pair_count, self.size
        if pairs <= max(SKIN_PAIRS_PER_SPHERE * n, SKIN_PAIRS_FLOOR):
            return
        held = self.memory_bytes()
        lists = held["verlet list"] + held["near list"]
        _checks.warn(
            f"skin={skin!r} m is {skin / diameter:.3g} times the largest diameter ({diameter:g} m): the "
            f"neighbour list holds {pairs} pairs, {pairs / n:.0f} per sphere (a sphere among equal ones "
            f"touches at most 12), and the lists take {lists / 2**30:.3g} GiB. A skin of a fraction of "
            "a diameter suffices (None: 0.2 x the mean diameter); a larger one only for spheres "
            "that move far between rebuilds", PerformanceWarning)

    def request_stop(self) -> None:
        """Ask the run in progress (in another thread) to return after its current step, with
        :attr:`stopped` True; the state is then that of that step, and running on continues bit
        for bit (see :meth:`run`). Callable from any thread at any time (it only sets a flag).
        The request stays until a run stops on it: one made while no run is in progress, or too
        late for the run in progress to see it (during its last step), makes the next run
        return before its first step."""
        self._core.request_stop()

    @property
    def running(self) -> bool:
        """Whether a run of this Simulation is in progress (in any thread). Readable at any
        time, from any thread."""
        return self._in_run

    @property
    def stopped(self) -> bool:
        """Whether the last run returned before all its steps because of :meth:`request_stop`
        or a signal (Ctrl-C)."""
        return self._core.stopped

    @property
    def time(self) -> float:
        """Simulated time [s]. Readable from any thread, also during a run (then the time of a
        step completed, published by the run between its steps)."""
        return self._core.time

    @property
    def step_count(self) -> int:
        """Steps taken so far. Readable from any thread, also during a run (then the steps
        completed so far, published by the run between its steps): a monitor thread can follow
        a run's progress."""
        return self._core.step_count

    # ---- checkpoints ---------------------------------------------------------------------------
    def save(self, path, metadata: dict | None = None) -> Path:
        """Write a checkpoint of the complete state to ``path``; returns the path.

        The file holds the spheres (positions, velocities, angular velocities, radii,
        materials, dissipated energy), the walls and their motion, the materials and pair
        overrides, the options, every touching contact's history and roughness state, the
        step counter and time, the energy bookkeeping, the fixed spheres and their motion, the
        outlets and the log of removed spheres (:meth:`removed`), the inserters' progress, and
        ``metadata`` (default :attr:`metadata`; any JSON-able dict). :meth:`load` gives a
        Simulation whose runs continue bit for bit as this one's would.

        The file is written atomically (a temporary file in the same folder, fsync'ed, then
        renamed over ``path``): at every moment ``path`` is the old file or the complete new
        one. It carries a format version and a SHA-256 checksum (:mod:`tsubu.checkpoint`).

        Raises
        ------
        TypeError
            ``path`` is not a path, or ``metadata`` is not a JSON-able dict.
        OSError
            The file cannot be written (the old file, if any, is left as it was); a missing
            directory gives FileNotFoundError naming ``path`` and the directory.
        """
        from . import checkpoint

        target = _checks.path("path", path)
        if metadata is None:
            metadata = self.metadata
        _check_metadata(metadata)
        checkpoint.write_atomically(target, checkpoint.encode(self, metadata))
        return target

    @staticmethod
    def load(path, threads: int | None = None) -> "Simulation":
        """A Simulation restored from the checkpoint file at ``path`` (a str or path), written
        by :meth:`save`.

        ``threads``: the OpenMP threads of the restored Simulation (default: the saved
        setting); results are the same bits for any count. The checkpoint's ``metadata`` is
        in :attr:`metadata`.

        Raises
        ------
        tsubu.checkpoint.CheckpointError
            (a ValueError) The file is truncated, corrupted (checksum), not a tsubu
            checkpoint, or written by a newer tsubu: nothing is built from it.
        FileNotFoundError
            No such file.
        """
        from . import checkpoint

        source = _checks.path("path", path)
        if threads is not None:
            threads = _options.check("threads", threads)
        return checkpoint.load(source, threads)

    # ---- state (read-only copies, in id order) -----------------------------------------------
    @property
    def size(self) -> int:
        """Number of spheres."""
        return self._core.size

    def __len__(self) -> int:
        return self._core.size

    @property
    def positions(self) -> np.ndarray:
        """Centre positions [m], shape (N, 3), row k the sphere ``ids[k]`` (row = id until a
        sphere is removed, :attr:`ids`), a read-only copy. Assigning moves the
        spheres (``sim.positions = x``); spheres moved after the first run are checked for
        overlaps when the next run starts, as the first run checks all (``initial_overlap``)."""
        return _read_only(self._core.positions())

    @positions.setter
    def positions(self, value) -> None:
        x = _checks.points("positions", value, self.size)
        _energies_fit("positions", self.masses, self.radii, x=x, g=self.gravity)
        self._core.set_positions(x)

    @property
    def velocities(self) -> np.ndarray:
        """Velocities [m/s], shape (N, 3), a read-only copy. Assignable."""
        return _read_only(self._core.velocities())

    @velocities.setter
    def velocities(self, value) -> None:
        v = _checks.points("velocities", value, self.size)
        _energies_fit("velocities", self.masses, self.radii, v=v)
        self._core.set_velocities(v)

    @property
    def angular_velocities(self) -> np.ndarray:
        """Angular velocities [rad/s], shape (N, 3), a read-only copy. Assignable."""
        return _read_only(self._core.angular_velocities())

    @angular_velocities.setter
    def angular_velocities(self, value) -> None:
        w = _checks.points("angular_velocities", value, self.size)
        _energies_fit("angular_velocities", self.masses, self.radii, w=w)
        self._core.set_angular_velocities(w)

    @property
    def radii(self) -> np.ndarray:
        """Radii [m], shape (N,), a read-only copy."""
        return _read_only(self._core.radii())

    @property
    def masses(self) -> np.ndarray:
        """Masses [kg], shape (N,), a read-only copy."""
        return _read_only(self._core.masses())

    @property
    def materials(self) -> list:
        """The materials the Simulation knows (of spheres, walls and pair overrides), in the order
        of their indices: ``materials[material_ids[k]]`` is sphere k's."""
        return list(self._materials)

    @property
    def material_ids(self) -> np.ndarray:
        """Each sphere's material as an index into :attr:`materials`, shape (N,), a read-only
        copy."""
        return _read_only(np.array(self._core.materials(), dtype=np.int64))

    @property
    def forces(self) -> np.ndarray:
        """Total force of the last step (contacts + gravity) [N], shape (N, 3), a read-only
        copy."""
        return _read_only(self._core.forces())

    @property
    def torques(self) -> np.ndarray:
        """Total torque of the last step [N m], shape (N, 3), a read-only copy."""
        return _read_only(self._core.torques())

    def contacts(self) -> dict:
        """The contacts of the last force evaluation (the start of the last step).

        Returns
        -------
        dict of numpy arrays
            One row per touching contact (M in all), sorted by ``i``:

            - ``i``: sphere id, int64, shape (M,);
            - ``j``: partner sphere id (-1 for a wall), int64, shape (M,);
            - ``wall``: wall index (-1 for a pair of spheres), int, shape (M,);
            - ``overlap``: overlap [m], shape (M,) (negative for a contact that a sticky
              normal law holds beyond zero overlap, docs/physics.md);
            - ``force``: contact force on i [N], shape (M, 3) (the partner gets -force);
            - ``torque_i``: torque on i from this contact [N m], shape (M, 3);
            - ``tangential_displacement``: the stored tangential history [m], shape (M, 3)
              (zero without friction);
            - ``element``: a wall contact's element (a mesh's triangle, the row of its
              ``faces``; 0 for a plane; -1 for a pair), int, shape (M,);
            - ``wall_point``: a wall contact's point of the wall nearest the centre of i now
              (on the plane, or on the triangle) [m], shape (M, 3) (zero for a pair);
            - ``branch``: a pair's x_j - x_i now [m], shape (M, 3), to the image of j nearest
              i in a periodic box (zero for a wall contact).
        """
        return self._core.contacts()

    def energy(self, at_positions: bool = False) -> dict:
        """The energies of the scene [J].

        With fixed walls, ``total + dissipated`` is conserved up to time-discretisation error.

        Parameters
        ----------
        at_positions : bool
            Default False. True: the normal springs' energy from the current positions instead
            of the last force evaluation (which is one step behind the kinetic and
            gravitational parts), and ``step_correction`` = dt/2 (sum v.F over gravity and the
            normal springs - the same over the tangential springs): ``total +
            step_correction`` is symplectic Euler's modified energy, exactly conserved for
            linear springs however close dt is to the bound; with ``dissipated`` it is the
            balance that tsubu's own instability check uses (docs/physics.md).

        Returns
        -------
        dict of float
            ``translational``, ``rotational``, ``kinetic`` (their sum), ``gravitational``
            (-sum m g.x), ``elastic`` (springs of the last force evaluation: 1/2 kn overlap^2 +
            1/2 kt abs(history)^2 for the linear law, the Hertz-Mindlin potentials otherwise),
            ``total`` (kinetic + gravitational + elastic), ``dissipated`` (work of dashpots,
            slip and rolling friction since the start) and ``step_correction`` (0 without
            ``at_positions``), all in joules.

        Raises
        ------
        TypeError
            For an ``at_positions`` that is not a bool.
        ValueError
            If a part is not finite. Input whose energy would overflow is refused (a sphere's
            kinetic, rotational or gravitational energy above 1e300 J), so only a run that
            drove the state there (an enormous gravity, say) can get there.
        """
        if not isinstance(at_positions, (bool, np.bool_)):
            raise TypeError(f"at_positions must be a bool, got {at_positions!r}")
        energies = self._core.energy(bool(at_positions))
        if not all(math.isfinite(e) for e in energies.values()):
            raise ValueError("energy: the state's energies overflow doubles (" + ", ".join(
                f"{k} {e!r} J" for k, e in energies.items() if not math.isfinite(e)) + "): a run "
                "drove speeds or positions beyond what doubles resolve")
        return energies

    # ---- neighbour list ----------------------------------------------------------------------
    def rebuild_neighbors(self) -> None:
        """Rebuild the neighbour list now (runs do this by themselves)."""
        self._core.rebuild_neighbors()

    def neighbor_pairs(self) -> np.ndarray:
        """Pairs (lower id first) of the current neighbour list: every pair of spheres closer
        than r_i + r_j + skin at the last rebuild; shape (M, 2)."""
        return self._core.neighbor_pairs()

    def phase_seconds(self) -> dict:
        """Wall-clock seconds spent so far in each phase of the time loop: ``neighbors``
        (rebuild checks and rebuilds), ``contacts`` (contact laws of pairs and walls),
        ``integrate`` (summing reactions and advancing the spheres)."""
        return self._core.phase_seconds()

    def region_seconds(self) -> dict:
        """How the time loop's parallel regions used their threads so far, for thread-scaling
        studies (``benchmarks/scaling.py``): for each kind of region, ``contacts`` (the contact
        pass), ``particles`` (the particle pass) and ``fused`` (a particle pass fused with the
        next contact pass), a dict with ``wall`` (seconds inside those regions, as the calling
        thread saw them), ``slowest`` and ``mean`` (the sums over regions of the busiest
        thread's and of the average thread's working time, in seconds, barriers left out) and
        ``count`` (regions timed). ``wall - slowest`` is what starting, joining and
        synchronising the threads cost; ``slowest - mean`` what the imbalance between their
        shares cost. The loop's time outside these regions is the sum of
        :meth:`phase_seconds` less the ``wall`` times."""
        return self._core.region_seconds()

    @property
    def rebuild_count(self) -> int:
        """Verlet-list rebuilds so far."""
        return self._core.rebuild_count

    @property
    def near_refresh_count(self) -> int:
        """Refreshes of the near list (the pairs within r_i + r_j + :attr:`near_reach` that the
        step loop reads; docs/architecture.md) so far, rebuilds included."""
        return self._core.near_refresh_count

    @property
    def near_reach(self) -> float:
        """How far beyond contact the near list reaches now [m], between a tenth and half of the
        skin.

        It is chosen at each refresh so that the list's scans and its refreshes cost least
        together: a fast scene refreshes less often with a wider list, a slow one scans a thinner
        one (docs/architecture.md). Results do not depend on it, only the work does."""
        return self._core.near_reach

    @property
    def fused_step_count(self) -> int:
        """Steps so far whose particle pass also evaluated the next step's contacts, in one
        sweep over memory (scenes of 65,536 spheres or more with fixed walls, whenever no
        neighbour list can fall due in between; docs/architecture.md). The results are the
        same bits as two passes; the time of such a step counts under ``integrate`` in
        :meth:`phase_seconds`."""
        return self._core.fused_step_count

    def memory_bytes(self) -> dict:
        """Bytes held by the engine's arrays, by group (``particles``, ``verlet list``,
        ``near list`` with the contact state, ``walls``, ``scratch`` kept for the next rebuild).
        Capacities, not the process's resident memory (benchmarks/throughput.py reports both)."""
        return self._core.memory_bytes()

    # ---- grains as boundaries (docs/boundaries.md) --------------------------------------------
    @property
    def ids(self) -> np.ndarray:
        """Each row's sphere id, int64, shape (N,), increasing, a read-only copy. Ids are handed
        out in the order of addition and never reused: until a sphere is removed ``ids`` is
        0..N-1 and row = id; after :meth:`remove_spheres` or an outlet, the arrays
        (:attr:`positions`, :attr:`velocities`, ...) hold the spheres left, by increasing id,
        and row k is the sphere ``ids[k]`` (:meth:`rows` maps ids to rows)."""
        return _read_only(self._core.get_ids())

    def rows(self, ids) -> np.ndarray:
        """The rows of the spheres ``ids`` (int or array_like of int) in :attr:`positions` and
        the other per-sphere arrays: int64, shape (M,). ValueError naming an id that is no
        sphere's (never added, or removed)."""
        return np.searchsorted(self._core.get_ids(), self._sphere_ids("ids", ids))

    def _sphere_ids(self, name: str, ids, unique: bool = False) -> np.ndarray:
        """``ids`` as a 1-d int64 array of ids of spheres present; TypeError for non-integers,
        ValueError naming an unknown (or, with ``unique``, repeated) id."""
        a = np.asarray(ids)
        if a.dtype == object or a.dtype.kind not in "iu" or a.dtype == bool:
            if a.size == 0 and a.dtype.kind == "f":
                a = a.astype(np.int64)
            else:
                raise TypeError(f"{name} must be sphere ids (integers), got {ids!r}")
        if a.ndim > 1:
            raise ValueError(f"{name} must be an id or a 1-d sequence of ids, got shape {a.shape}")
        a = a.reshape(-1).astype(np.int64)
        have = self._core.get_ids()
        at = np.searchsorted(have, a)
        bad = (at >= len(have)) | (have[np.minimum(at, max(len(have) - 1, 0))] != a) if len(have) \
            else np.ones(len(a), dtype=bool)
        if bad.any():
            k = int(a[np.argmax(bad)])
            removed = k in set(self._core.removed()["id"].tolist())
            raise ValueError(f"{name}: no sphere has id {k}" + (
                " (it was removed)" if removed else
                f" (ids run from 0 to {self._core.size + len(self._core.removed()['id']) - 1})"))
        if unique and len(np.unique(a)) != len(a):
            u, count = np.unique(a, return_counts=True)
            raise ValueError(f"{name}: sphere {int(u[np.argmax(count > 1)])} is listed twice")
        return a

    def fix_spheres(self, ids, velocity=(0.0, 0.0, 0.0), angular_velocity=(0.0, 0.0, 0.0)) -> None:
        """Fix spheres, or give them a prescribed motion: from now on each moves with constant
        ``velocity`` and spins with constant ``angular_velocity`` (zero: glued in place),
        whatever the forces on it and gravity. The glued base of a chute, the rough plates of a
        shear cell.

        A fixed sphere still exerts contact forces on the others (and :attr:`forces` reports
        those on it, with its weight m g), and has infinite mass to them: a contact between a
        free and a fixed sphere takes the free sphere's mass as its reduced mass, as a wall
        contact does (its restitution is the pair's against a wall). A sphere's velocity and
        spin are set to the prescribed ones at once. Fixing a fixed sphere again sets its
        motion anew. While some fixed sphere moves or spins it works on the scene as a moving
        wall does, and the energy audit is off (docs/boundaries.md).

        Parameters
        ----------
        ids : int or array_like of int, shape (M,)
            The spheres' ids (:attr:`ids`).
        velocity : array_like, shape (3,) or (M, 3)
            Velocity [m/s]: one for all or one per sphere. Default (0, 0, 0).
        angular_velocity : array_like, shape (3,) or (M, 3)
            Angular velocity [rad/s], about each sphere's own centre. Default (0, 0, 0).

        Raises
        ------
        TypeError
            For ids that are not integers, or motions that are not numbers.
        ValueError
            For an unknown or repeated id, motions of another shape or not finite, or a
            velocity faster than light.
        """
        a = self._sphere_ids("ids", ids, unique=True)
        v = self._motions("velocity", velocity, len(a))
        w = self._motions("angular_velocity", angular_velocity, len(a))
        self._core.fix_spheres(a, v, w)

    @staticmethod
    def _motions(name: str, value, n: int) -> np.ndarray:
        """One 3-vector for all n spheres, or an (n, 3) array."""
        if np.ndim(value) == 1:
            return np.tile(np.array(_checks.vec3(name, value)), (n, 1))
        return _checks.points(name, value, n)

    def free_spheres(self, ids) -> None:
        """Release fixed spheres (:meth:`fix_spheres`): they keep the velocity and spin they
        had and move under forces and gravity again. A free sphere listed is left as it is.

        Parameters
        ----------
        ids : int or array_like of int
            The spheres' ids.

        Raises
        ------
        TypeError, ValueError
            For ids that are not integers, or an id that is no sphere's.
        """
        self._core.free_spheres(self._sphere_ids("ids", ids))

    @property
    def fixed(self) -> np.ndarray:
        """Whether each sphere is fixed (:meth:`fix_spheres`), bool, shape (N,), row as in
        :attr:`positions`, a read-only copy."""
        return _read_only(self._core.get_fixed())

    def remove_spheres(self, ids) -> None:
        """Remove spheres from the scene. The others keep their ids, their state and their
        contacts' history (a run continues bit for bit as if the removed spheres had been far
        away); the removed spheres' contacts end and their energy leaves with them. Ids are
        never reused: the per-sphere arrays then hold the spheres left by increasing id
        (:attr:`ids`). Each removal is logged in :meth:`removed` (outlet -1).

        Parameters
        ----------
        ids : int or array_like of int
            The spheres' ids.

        Raises
        ------
        TypeError, ValueError
            For ids that are not integers, or an unknown or repeated id.
        """
        self._core.remove_spheres(self._sphere_ids("ids", ids, unique=True))

    def add_outlet(self, point=None, normal=None, *, lo=None, hi=None,
                   remove: str = "outside") -> int:
        """Add an outlet: spheres whose centre it finds beyond it at the end of a step are
        removed there (inside the run's loop, no Python per step) and logged
        (:meth:`removed`). Returns its index (an int, counted from 0).

        Two forms:

        - a plane, ``point`` and ``normal``: the normal points into the scene, as a wall's
          does; a sphere whose centre is behind the plane, (x - point) . normal < 0, is
          removed (a hopper's outlet below the orifice: ``normal=(0, 0, 1)``);
        - a box, ``lo`` and ``hi`` (its corners): with ``remove="outside"`` (default) a sphere
          whose centre leaves the box is removed; with ``remove="inside"`` one whose centre is
          in it (a sink). The box's faces count as inside.

        A sphere already beyond an outlet when it is added goes at the end of the next step.
        Results stay bit-identical for any thread count, and a checkpoint keeps the outlets and
        the log.

        Parameters
        ----------
        point, normal : array_like, shape (3,)
            The plane form: a point of the plane [m] and its normal (any length > 0).
        lo, hi : array_like, shape (3,)
            The box form: its lower and upper corners [m], lo <= hi along every axis.
        remove : {"outside", "inside"}
            The box form: which side of the box removes spheres.

        Raises
        ------
        TypeError
            For coordinates that are not numbers.
        ValueError
            For neither or both forms, a zero or non-finite normal, a box with lo > hi, or a
            ``remove`` other than "outside" or "inside".
        """
        plane = point is not None or normal is not None
        box = lo is not None or hi is not None
        if plane == box:
            raise ValueError("add_outlet takes either point and normal (a plane) or lo and hi "
                             f"(a box), got point={point!r}, normal={normal!r}, lo={lo!r}, hi={hi!r}")
        if plane:
            if point is None or normal is None:
                raise ValueError(f"a plane outlet needs both point and normal, got point={point!r}, "
                                 f"normal={normal!r}")
            p, n = _checks.vec3("point", point), _checks.vec3("normal", normal)
            if not any(n):
                raise ValueError(f"normal must be a non-zero vector, got {normal!r}")
            return self._core.add_outlet(0, p, n, False)
        if lo is None or hi is None:
            raise ValueError(f"a box outlet needs both lo and hi, got lo={lo!r}, hi={hi!r}")
        a, b = _checks.vec3("lo", lo), _checks.vec3("hi", hi)
        if any(x > y for x, y in zip(a, b)):
            raise ValueError(f"lo must be <= hi along every axis, got lo={lo!r}, hi={hi!r}")
        remove = _checks.choice("remove", remove, ("outside", "inside"))
        return self._core.add_outlet(1, a, b, remove == "inside")

    @property
    def outlets(self) -> list:
        """The outlets (:meth:`add_outlet`), each a dict, in the order added.

        A plane has the keys ``point`` and ``normal`` (a unit vector), a box ``lo``, ``hi`` and
        ``remove``."""
        out = []
        for o in self._core.outlets():
            if o["kind"] == 0:
                out.append({"point": tuple(o["a"]), "normal": tuple(o["b"])})
            else:
                out.append({"lo": tuple(o["a"]), "hi": tuple(o["b"]),
                            "remove": "inside" if o["remove_inside"] else "outside"})
        return out

    def removed(self) -> dict:
        """Every sphere removed so far, in the order of removal (by step, then by id).

        Returns
        -------
        dict of numpy arrays, one row per removed sphere (R in all)
            - ``id``: its id, int64, shape (R,);
            - ``outlet``: the outlet that took it (:meth:`add_outlet`'s index), or -1 for
              :meth:`remove_spheres`, int, shape (R,);
            - ``step``, ``time``: the step count and time [s] when it left (an outlet removes
              at the end of a step: the step just completed), shapes (R,);
            - ``position``, ``velocity``: its centre [m] and velocity [m/s] then, shape (R, 3).
        """
        return self._core.removed()

    def __reduce__(self):
        """Pickling, ``copy.copy`` and ``copy.deepcopy``: through the checkpoint format (see the
        class's Copies section); refused while the Simulation runs."""
        from . import checkpoint

        _check_metadata(self.metadata, "a copy or pickle of a Simulation carries its metadata")
        return _from_checkpoint_bytes, (checkpoint.encode(self, self.metadata), tuple(self._materials))

    def __repr__(self) -> str:
        if self._in_run:  # its state is being written by the run
            return "tsubu.Simulation(running)"
        return (f"tsubu.Simulation({self.size} spheres, {self._core.plane_count} walls, "
                f"t = {self.time:.6g} s, step {self.step_count})")


def _read_only(array: np.ndarray) -> np.ndarray:
    """``array`` (a new copy of the engine's state) marked read-only: writing into it raises
    instead of changing a copy nobody sees."""
    array.flags.writeable = False
    return array


def _check_metadata(metadata, why: str = "") -> None:
    """TypeError unless ``metadata`` is a JSON-able dict (what checkpoints can hold)."""
    where = f" ({why})" if why else ""
    if not isinstance(metadata, dict):
        raise TypeError(f"metadata must be a dict{where}, got {metadata!r}")
    try:
        json.dumps(metadata, allow_nan=True)
    except (TypeError, ValueError) as e:
        raise TypeError(f"metadata must be JSON-able (dicts, lists, strings, numbers){where}: "
                        f"{e}") from None


def _from_checkpoint_bytes(data: bytes, materials: tuple) -> "Simulation":
    """The Simulation a pickle or copy holds: its checkpoint's bytes, with ``materials`` (the
    original's Material objects, or their copies) in place of those the checkpoint describes."""
    from . import checkpoint

    return checkpoint.decode(data, materials)


# Far more than any machine's cores: OpenMP would try to start every thread asked for (the
# declared maximum of threads).
MAX_THREADS = _options.DECLARATIONS["threads"].maximum
# Threads up to this many times the hardware threads (and up to OVERSUBSCRIBED_FLOOR) run
# without a warning: a few threads more than cores cost little (tests run 3 threads on 2 cores),
# each further one waits at every barrier of every step.
OVERSUBSCRIPTION = 2
OVERSUBSCRIBED_FLOOR = 4


def _hardware_threads() -> int:
    """The threads the machine gives this process: its CPU affinity where the OS has one, else
    os.cpu_count()."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


def _warn_threads(threads: int) -> None:
    """PerformanceWarning for ``threads`` beyond OVERSUBSCRIPTION x the hardware threads."""
    hardware = _hardware_threads()
    if threads > max(OVERSUBSCRIPTION * hardware, OVERSUBSCRIBED_FLOOR):
        _checks.warn(
            f"threads={threads} is more than {OVERSUBSCRIPTION}x the {hardware} hardware thread(s) this "
            f"process may use (os.sched_getaffinity; os.cpu_count() = {os.cpu_count()}): every thread "
            "beyond the cores waits at each barrier of each step, and a run can be many times "
            f"slower (the results are the same bits). Use threads=None (all cores) or at most "
            f"{hardware}", PerformanceWarning)


# A run whose skin is beyond the largest diameter warns when its Verlet list holds more than
# this many pairs per sphere (a dense pack of equal spheres at the default skin holds about 6:
# each sphere touches at most 12, and the half list counts a pair once) ...
SKIN_PAIRS_PER_SPHERE = 64
# ... and more than this many in all (a smaller list, some 10 MB, costs little whatever its skin).
SKIN_PAIRS_FLOOR = 100_000

# The _core.Simulation property that stores a run option, where it is not the option's name
# (hertz_force: the bool `repulsive`).
_CORE_PROPERTY = {"skin": "skin_option", "tangential_history": "history_rule"}
# The order in which the constructor checks and sets its options: the declarations', but
# parallel_min's, which comes right after threads' (as it always has).
_RUN_OPTIONS = [name for name in _options.declared("run") if name != "parallel_min"]
_RUN_OPTIONS.insert(_RUN_OPTIONS.index("threads") + 1, "parallel_min")


def _steps_for(duration: float, dt: float) -> int:
    """The whole number of steps of ``dt`` nearest to ``duration`` (ValueError when that is not a
    finite count, or when a duration > 0 rounds to no step at all)."""
    count = duration / dt if math.isfinite(dt) else math.inf
    if not count <= 2**62:
        raise ValueError(f"time={duration!r} s is {count:g} steps of dt = {dt!r} s: more than 2**62 "
                         "steps (or dt is not finite: set dt)")
    steps = int(round(count))
    if steps == 0 and duration > 0:
        raise ValueError(f"time={duration!r} s is shorter than half a step (dt = {dt!r} s): it rounds "
                         "to 0 steps and the run would do nothing. Give a time of at least dt/2 "
                         "(steps=1 for one step), or time=0 for no step")
    return steps


#: The fastest a wall may move [m/s]: the speed of light (the core's Simulation::kMaxWallSpeed).
#: No wall of a Newtonian scene comes near it, and far beyond it a contact's products overflow
#: doubles: a wall sliding at 1e150 m/s lost its friction force without a word.
MAX_WALL_SPEED = 299_792_458.0


def _wall_velocity(name: str, value) -> tuple[float, float, float]:
    """A wall's velocity: a finite 3-vector no faster than MAX_WALL_SPEED (ValueError naming
    ``name``)."""
    v = _checks.vec3(name, value)
    speed = math.hypot(*v)
    if not speed <= MAX_WALL_SPEED:
        raise ValueError(f"{name} must be at most the speed of light, {MAX_WALL_SPEED:g} m/s, in magnitude: "
                         "no wall of a Newtonian scene moves faster, and far beyond it the contact "
                         f"forces overflow doubles (check the units), got {value!r} ({speed:g} m/s)")
    return v


def _unit(name: str, value) -> tuple[float, float, float]:
    """A finite nonzero 3-vector, scaled to unit length without overflow or underflow."""
    v = np.array(_checks.vec3(name, value))
    scale = float(np.max(np.abs(v)))
    if scale == 0:
        raise ValueError(f"{name} must not be zero, got {value!r}")
    v = v / scale
    v = v / math.sqrt(float(v @ v))
    return (float(v[0]), float(v[1]), float(v[2]))


# The largest energy [J] one sphere may have (kinetic, rotational or gravitational): sums over
# many spheres, and products in the energy balance, stay inside the range of doubles.
MAX_SPHERE_ENERGY = 1e300


def _energies_fit(name: str, mass, radius, *, x=None, v=None, w=None, g=None) -> None:
    """ValueError naming ``name`` when a sphere's kinetic, rotational or gravitational energy
    would exceed MAX_SPHERE_ENERGY (or overflow)."""
    with np.errstate(all="ignore"):
        if v is not None:
            e, what = 0.5 * mass * np.einsum("ij,ij->i", v, v), "kinetic"
        elif w is not None:
            e, what = 0.2 * mass * radius * radius * np.einsum("ij,ij->i", w, w), "rotational"
        elif x is not None and g is not None:
            e, what = mass * np.abs(np.asarray(x) @ np.asarray(g)), "gravitational"
        else:
            return
        bad = ~(e <= MAX_SPHERE_ENERGY)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"{name}: sphere {k} would have a {what} energy of {float(e[k]):g} J, beyond "
                         f"{MAX_SPHERE_ENERGY:g} J (sums of such energies overflow doubles)")


def _check_mass(radius: np.ndarray, material: Material) -> np.ndarray:
    """The mass and moment of inertia of every sphere, and their inverses, must be finite and > 0
    in doubles (a radius of 1e-120 m or 1e120 m is not)."""
    with np.errstate(over="ignore", under="ignore", divide="ignore"):
        mass = material.density * 4.0 / 3.0 * math.pi * radius ** 3
        inertia = 0.4 * mass * radius * radius
        ok = (np.isfinite(mass) & (mass > 0) & np.isfinite(1.0 / mass) & np.isfinite(inertia)
              & (inertia > 0) & np.isfinite(1.0 / inertia))
    if not ok.all():
        k = int(np.argmin(ok))
        raise ValueError(
            f"radius: entry {k} ({float(radius[k])!r} m) with density {material.density!r} kg/m^3 "
            f"gives a mass of {float(mass[k])!r} kg and a moment of inertia of {float(inertia[k])!r} "
            "kg m^2; both and "
            "their inverses must be finite and > 0 in double precision")
    return mass


def _label(material: Material) -> str:
    return repr(material.name) if material.name is not None else repr(material)

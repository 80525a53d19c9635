"""Pouring: an inserter adds spheres to a running simulation at a number or mass rate."""

from __future__ import annotations

import math
import numbers

import numpy as np

from . import _checks
from .fill import _CellGrid, _GAP, _region, _sequential_addition, _sizes, distribution_from_dict, \
    region_from_dict
from .material import Material

__all__ = ["Inserter"]

# Random positions tried in a row without room, at one event, before what is left waits for the
# next event.
_ATTEMPTS_PER_EVENT = 2000
# Radii are drawn in chunks of this size, so the stream of sizes does not depend on when events
# fall or how a run is cut into pieces.
_SIZE_CHUNK = 64
# An event is due at the first step whose time is at least its time, less this many steps
# (rounding in sim.time).
_STEP_SLACK = 1e-6
# The densest packing of equal spheres (pi / sqrt(18)): no region holds more than this fraction
# of its volume in spheres, so no event can place more than region volume x this / the smallest
# sphere's volume (Inserter._capacity).
_DENSEST_PACKING = math.pi / math.sqrt(18.0)


class Inserter:
    """Pours spheres into ``region`` during runs, as LIGGGHTS's ``fix insert/stream`` does.

    Usually made with :meth:`tsubu.Simulation.add_inserter` (same arguments), which keeps it
    and runs it in every run. At events every ``interval`` seconds of simulated time from
    ``start``, it adds the amount due for the interval that begins (``rate`` x interval) at
    random points of the region where the spheres overlap neither the spheres already in the
    simulation nor each other, with ``velocity`` and ``angular_velocity``. Spheres that find no
    room (the region is full) are carried over to the next event, first in line. Walls are not
    looked at: put the region where walls are not.

    Parameters
    ----------
    region : tsubu.fill.Box, Cylinder or Region
        Where spheres are placed (each sphere wholly inside).
    rate : float
        Spheres per second (``basis="number"``) or kilograms per second (``basis="mass"``), > 0.
    sizes : a tsubu.fill size distribution, or a radius [m]
        The radii, drawn in order from one stream.
    material : tsubu.Material
    velocity, angular_velocity : (3,) floats
        Of each inserted sphere [m/s], [rad/s]. Default zero.
    basis : "number" or "mass"
        The unit of ``rate`` and ``total``. By mass, spheres from the size stream are inserted
        while the mass inserted stays within half a sphere's mass of ``rate`` x time.
    start : float
        Time of the first event [s] (>= 0; default 0). A simulation without spheres has no
        default time step, so one that waits for a later start needs ``dt`` set.
    stop : float or None
        No amount becomes due after this time [s] (> start). Events go on only to place what is
        still pending. None: no end.
    total : int or float or None
        The most spheres (number basis, an integer >= 1) or kilograms (mass basis, > 0) to
        insert; the inserter ends when they are in. None: no limit.
    interval : float or None
        Seconds between events (> 0). None: the time a sphere inserted with ``velocity`` takes
        to cross the region's extent along it (along gravity when ``velocity`` is zero),
        accelerated by gravity, so that one event's spheres have left the region before the
        next; evaluated at the first event (ValueError if there is neither velocity nor gravity).
    seed : int
        The same seed gives the same spheres, at the same places, whatever the thread count.

    Raises
    ------
    ValueError
        At an event (so from :meth:`tsubu.Simulation.run`) whose spheres due, new and pending
        together, are more than the region could hold at the densest packing of the smallest
        radius: the rate outruns what the region can take, and the backlog would only grow
        (at 1e7 spheres/s one step spent 6.9 s trying to place 451,012 of them).

    Notes
    -----
    Its properties :attr:`inserted` (spheres so far), :attr:`inserted_mass` [kg],
    :attr:`pending` (spheres due but not yet placed), :attr:`interval` (None until resolved)
    and :attr:`finished` tell how far it got.

    It is a run hook (:mod:`tsubu.hooks`): ``next_step(sim)`` gives the step of the next
    event, ``act(sim)`` inserts, ``close(sim)`` does nothing. Its progress is saved in
    checkpoints (:meth:`tsubu.Simulation.save`), so a resumed run pours on where it stopped.
    """

    def __init__(self, region, rate, sizes, material, velocity=(0.0, 0.0, 0.0), basis: str = "number",
                 angular_velocity=(0.0, 0.0, 0.0), start=0.0, stop=None, total=None, interval=None,
                 seed: int = 0):
        self.region = _region(region)
        self.rate = _checks.positive("rate", rate)
        self.sizes = _sizes(sizes)
        if not isinstance(material, Material):
            raise TypeError(f"material must be a tsubu.Material, got {material!r}")
        self.material = material
        self.velocity = np.array(_checks.vec3("velocity", velocity))
        self.basis = _checks.choice("basis", basis, ("number", "mass"))
        self.angular_velocity = np.array(_checks.vec3("angular_velocity", angular_velocity))
        self.start = _checks.positive("start", start, allow_zero=True)
        self.stop = None if stop is None else _checks.positive("stop", stop)
        if self.stop is not None and not self.stop > self.start:
            raise ValueError(f"stop must be > start = {self.start!r} s, got {stop!r}")
        if total is None:
            self.total = None
        elif self.basis == "number":
            self.total = _checks.whole("total", total, minimum=1)
        else:
            self.total = _checks.positive("total", total)
        self._given_interval = None if interval is None else _checks.positive("interval", interval)
        self.seed = _checks.whole("seed", seed, maximum=2**64 - 1)
        extent = self.region.upper - self.region.lower
        if 2 * self.sizes.max_radius > extent.min():
            raise ValueError(f"sizes: spheres of radius up to {self.sizes.max_radius!r} m do not fit "
                             f"in the region, whose bounding box is {extent.tolist()} m")
        self._size_rng = np.random.default_rng([self.seed, 0])
        self._place_rng = np.random.default_rng([self.seed, 1])
        self._queue = np.empty(0)  # radii drawn and not yet inserted, in stream order
        self._interval = self._given_interval
        self._event = 0  # index of the next event: at start + event * interval
        self._inserted = 0
        self._inserted_mass = 0.0
        self._pending = 0

    # ---- properties ----------------------------------------------------------------------------
    @property
    def inserted(self) -> int:
        """Spheres inserted so far."""
        return self._inserted

    @property
    def inserted_mass(self) -> float:
        """Mass inserted so far [kg] (the sum of the simulation's masses of those spheres)."""
        return self._inserted_mass

    @property
    def pending(self) -> int:
        """Spheres that were due at the last event but found no room (placed first at the next)."""
        return self._pending

    @property
    def interval(self):
        """Seconds between events; None while the default is not yet resolved (first event)."""
        return self._interval

    @property
    def finished(self) -> bool:
        """True when nothing more will be inserted (``total`` reached, or past ``stop`` with
        nothing pending)."""
        if self._pending:
            return False
        cap = self._final_target()
        return cap is not None and self._due(cap) == 0

    # ---- amounts ---------------------------------------------------------------------------------
    def _target(self, event: int) -> float:
        """The amount (count or kg) due by the end of the interval that starts at ``event``."""
        span = (event + 1) * self._interval
        if self.stop is not None:
            span = min(span, self.stop - self.start)
        amount = self.rate * span
        return amount if self.total is None else min(amount, self.total)

    def _final_target(self):
        if self.total is not None and self.stop is None:
            return float(self.total)
        if self.stop is None:
            return None
        amount = self.rate * (self.stop - self.start)
        return amount if self.total is None else min(amount, self.total)

    def _masses(self, radii):
        return self.material.density * 4.0 / 3.0 * math.pi * radii ** 3

    def _due(self, target: float) -> int:
        """How many spheres at the head of the queue are due when ``target`` is due (drawing more
        radii as needed)."""
        if self.basis == "number":
            return max(0, int(math.floor(target * (1 + 1e-12))) - self._inserted)
        room = target - self._inserted_mass
        while True:
            mass = self._masses(self._queue)
            cumulative = np.cumsum(mass)
            due = int(np.count_nonzero(cumulative - 0.5 * mass <= room))
            if due < len(self._queue):
                return due
            self._draw()

    def _capacity(self) -> int:
        """The most spheres the region could hold at once: its volume at the densest packing of
        the smallest radius (a bound no event can exceed)."""
        smallest = 4.0 / 3.0 * math.pi * self.sizes.min_radius ** 3
        return int(_DENSEST_PACKING * self.region.volume / smallest)

    def _draw(self) -> None:
        self._queue = np.concatenate([self._queue, self.sizes.sample(_SIZE_CHUNK, self._size_rng)])

    def _head(self, count: int) -> np.ndarray:
        while len(self._queue) < count:
            self._draw()
        return self._queue[:count]

    def _resolve_interval(self, sim) -> float:
        if self._interval is not None:
            return self._interval
        speed = float(np.linalg.norm(self.velocity))
        gravity = np.asarray(sim.gravity, dtype=float)
        if speed > 0:
            direction = self.velocity / speed
        elif np.any(gravity != 0):
            direction = gravity / float(np.linalg.norm(gravity))
        else:
            raise ValueError("Inserter: interval=None needs a velocity or gravity to choose the "
                             "time between events: give interval= (seconds)")
        extent = float(np.abs(direction) @ (self.region.upper - self.region.lower))
        accel = float(gravity @ direction)
        if accel > 0:  # extent = v t + a t^2 / 2
            t = 2.0 * extent / (speed + math.sqrt(speed * speed + 2.0 * accel * extent))
        else:
            t = extent / speed
        self._interval = t
        return t

    # ---- the hook --------------------------------------------------------------------------------
    def next_step(self, sim):
        """The step of the next event (>= sim.step_count), or None when finished."""
        if self.finished:
            return None
        interval = self._resolve_interval(sim)
        when = self.start + self._event * interval
        dt = sim.dt
        if when <= sim.time:
            return sim.step_count
        if not math.isfinite(dt):  # no spheres yet to set the default dt: look again next step
            return sim.step_count + 1
        return sim.step_count + max(0, math.ceil((when - sim.time) / dt - _STEP_SLACK))

    def act(self, sim) -> None:
        """Insert what is due at this event (and what earlier events left pending)."""
        positions, radii, placed, due = self._plan(sim)
        if placed.any():
            # (placed clear of the spheres here: left out of the next run's overlap check, which
            # would otherwise refuse those that the region puts into a wall)
            ids = sim._add_spheres(
                positions[placed], radii[placed], self.material,
                velocities=np.tile(self.velocity, (int(placed.sum()), 1)),
                angular_velocities=np.tile(self.angular_velocity, (int(placed.sum()), 1)),
                check_overlaps=False)
            self._inserted += len(ids)
            self._inserted_mass += float(np.sum(sim.masses[sim.rows(ids)]))
        self._carry(radii, placed, due)

    def _plan(self, sim, existing=None):
        """This event's spheres: (positions, radii, placed, due), the inserter's event counter
        moved on (``act`` adds the placed ones, then ``_carry``). ``existing``: the (positions,
        radii) of every sphere of the scene in id order, where ``sim`` holds only some (a rank of
        a decomposed scene, tsubu.parallel); default ``sim``'s."""
        interval = self._resolve_interval(sim)
        slack = _STEP_SLACK * sim.dt if math.isfinite(sim.dt) else 0.0
        reached = math.floor((sim.time - self.start + slack) / interval)
        event = max(self._event, reached)
        due = self._due(self._target(event))
        capacity = self._capacity()
        if due > capacity:
            unit = "spheres/s" if self.basis == "number" else "kg/s"
            raise ValueError(
                f"Inserter: {due} spheres are due at t = {sim.time:.6g} s ({self._pending} of them "
                f"left from earlier events), more than the {capacity} that its region (volume "
                f"{self.region.volume:.6g} m^3) could hold even packed at the densest "
                f"({_DENSEST_PACKING:.4f}) with its smallest radius {self.sizes.min_radius:g} m: at "
                f"rate={self.rate!r} {unit} and an event every {interval:.6g} s the backlog only "
                "grows. Lower the rate, enlarge the region, or give a shorter interval (fewer "
                "spheres per event)")
        self._event = event + 1
        if due == 0:
            return np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=bool), 0
        radii = self._head(due).copy()
        # spheres carried over go first, then the new ones; largest first within each
        carried = min(self._pending, due)
        order = np.concatenate([np.argsort(-radii[:carried], kind="stable"),
                                carried + np.argsort(-radii[carried:], kind="stable")])
        positions, placed = self._place(sim, radii, order, existing)
        return positions, radii, placed, due

    def _carry(self, radii, placed, due) -> None:
        """What found no room stays at the head of the queue, in stream order."""
        if due == 0:
            self._pending = 0
            return
        self._queue = np.concatenate([radii[~placed], self._queue[due:]])
        self._pending = int(np.count_nonzero(~placed))

    def close(self, sim) -> None:
        """Nothing to flush."""

    def _place(self, sim, radii, order, existing=None):
        """Positions for ``radii`` in the region clear of the simulation's spheres (NaN where no
        room was found) and which were placed, trying them in ``order``."""
        region = self.region
        largest = float(radii.max())
        if existing is not None:
            existing_x, existing_r = existing
        else:
            existing_x = sim.positions if sim.size else np.zeros((0, 3))
            existing_r = sim.radii if sim.size else np.zeros(0)
        reach = largest + (float(existing_r.max()) if len(existing_r) else largest)
        lower, upper = region.lower - reach, region.upper + reach
        near = np.all((existing_x >= lower) & (existing_x <= upper), axis=1)
        grid = _CellGrid(lower, upper, max(2 * largest, reach) * (1 + 2 * _GAP),
                         int(near.sum()) + len(radii))
        grid.add(existing_x[near], existing_r[near])
        x, ok = _sequential_addition(region, radii[order], self._place_rng, grid, _ATTEMPTS_PER_EVENT)
        positions = np.full((len(radii), 3), np.nan)
        placed = np.zeros(len(radii), dtype=bool)
        positions[order], placed[order] = x, ok
        return positions, placed

    def _attach(self, sim) -> None:
        """Called by :meth:`Simulation.add_inserter`: the material joins the scene now, so a
        material of the other contact law is refused at once, not at the first event."""
        sim._material(self.material, "material", scene=True)

    # ---- checkpoints -------------------------------------------------------------------------------
    def _config(self, sim) -> dict:
        """The constructor's arguments as JSON-able values (the material as its index in
        ``sim.materials``, registered there if the simulation did not know it yet)."""
        return {"region": self.region.to_dict(), "rate": self.rate, "sizes": self.sizes.to_dict(),
                "material": _material_index(sim, self.material),
                "velocity": self.velocity.tolist(), "basis": self.basis,
                "angular_velocity": self.angular_velocity.tolist(), "start": self.start,
                "stop": self.stop, "total": self.total, "interval": self._given_interval,
                "seed": self.seed}

    @classmethod
    def _from_config(cls, config: dict, sim) -> "Inserter":
        """The Inserter a ``_config`` dict describes, with its material from ``sim.materials``."""
        args = dict(config)
        args["region"] = region_from_dict(args["region"])
        args["sizes"] = distribution_from_dict(args["sizes"])
        index = args["material"]
        materials = sim.materials
        if not (isinstance(index, numbers.Integral) and 0 <= index < len(materials)):
            raise ValueError(f"inserter material index {index!r} is not one of the simulation's "
                             f"{len(materials)} materials")
        args["material"] = materials[index]
        return cls(**args)

    def _state(self) -> dict:
        """The progress as JSON-able values: counts, next event, drawn radii, the generators."""
        return {"inserted": self._inserted, "inserted_mass": self._inserted_mass,
                "pending": self._pending, "event": self._event, "interval": self._interval,
                "queue": self._queue.tolist(),
                "size_rng": self._size_rng.bit_generator.state,
                "place_rng": self._place_rng.bit_generator.state}

    def _restore(self, state: dict) -> None:
        """Continue from a ``_state()``: the same future insertions as the Inserter it came from."""
        self._inserted = int(state["inserted"])
        self._inserted_mass = float(state["inserted_mass"])
        self._pending = int(state["pending"])
        self._event = int(state["event"])
        self._interval = None if state["interval"] is None else float(state["interval"])
        self._queue = np.array(state["queue"], dtype=float).reshape(-1)
        self._size_rng.bit_generator.state = state["size_rng"]
        self._place_rng.bit_generator.state = state["place_rng"]

    def __repr__(self) -> str:
        return (f"Inserter({self.region!r}, rate={self.rate!r} ({self.basis}), sizes={self.sizes!r}, "
                f"inserted={self._inserted})")


def _material_index(sim, material: Material) -> int:
    for k, m in enumerate(sim.materials):
        if m is material:
            return k
    sim._material(material, scene=True)  # registers it (and refuses a law the scene does not use)
    return next(k for k, m in enumerate(sim.materials) if m is material)

"""A scene cut into sub-domains over MPI ranks, bit-identical to one process (docs/parallel.md).

Every rank builds the same scene (the same script, or :meth:`Simulation.load` of one
checkpoint), then :func:`decompose` cuts space into a regular grid of boxes, one per rank, and
each rank keeps the spheres whose centre lies in its box (its own) and copies of the others'
within reach of it (its halo), each under its global id. A step evaluates every contact of a
rank's own spheres there, as one process would: the same two spheres, the same contact state,
the same sums in id order. So the state after any number of steps is the same, bit for bit, for
any number of ranks and threads. After each step the owners send their spheres' state to the
ranks that hold copies (inside the loop, through mpi4py). Spheres move to another rank's box,
and the cuts move with the load (:meth:`Decomposed.balance`), when the run stops between two
steps for it: the halo's margin bounds how far spheres may move before then.

Needs mpi4py and an MPI library: ``pip install "tsubu[mpi]"`` brings both (mpi4py and the
``mpich`` wheel, with its ``mpiexec``)::

    mpiexec -n 4 python script.py

where ``script.py`` builds the scene, calls ``decompose(sim)`` and runs it.
"""
from __future__ import annotations

import hashlib
import math
import pickle

import numpy as np

from . import _checks

__all__ = ["decompose", "Decomposed", "grid_shape", "launched_ranks", "launched_rank"]

_TAG_HALO = 0x7575
# The automatic margin lets the fastest sphere travel about this many steps between two
# redistributions (one costs some tens of steps: measured in docs/parallel.md).
_MARGIN_STEPS = 1000


def _mpi():
    try:
        from mpi4py import MPI
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError('tsubu.parallel needs mpi4py and an MPI library: pip install "tsubu[mpi]"') from e
    return MPI


def grid_shape(ranks: int, extent, uncut=None) -> tuple[int, int, int]:
    """The grid (nx, ny, nz) of ``ranks`` boxes that cuts a region of lengths ``extent`` (m,
    3 values) into the most cube-like boxes: of all factorisations nx ny nz = ranks, the one
    with the least area between boxes (ties: the most cube-like boxes, then the first axes).
    ``uncut``: an axis (0, 1, 2) or a list of axes not to cut (their counts 1), or None; where
    every factorisation cuts them, the last of them is cut after all."""
    ranks = _checks.whole("ranks", ranks, minimum=1)
    L = np.maximum(np.asarray(extent, dtype=float).reshape(3), 1e-300)
    axes = [] if uncut is None else [uncut] if isinstance(uncut, (int, np.integer)) else list(uncut)
    if any(a not in (0, 1, 2) for a in axes):
        raise ValueError(f"uncut must be an axis 0, 1 or 2, a list of them, or None; got {uncut!r}")
    while True:
        shape = _grid_shape(ranks, L, axes)
        if shape is not None or not axes:
            return shape
        axes = axes[:-1]


def _grid_shape(ranks, L, axes):
    best, shape = None, None
    for nx in range(1, ranks + 1):
        if ranks % nx:
            continue
        for ny in range(1, ranks // nx + 1):
            if (ranks // nx) % ny:
                continue
            n = np.array([nx, ny, ranks // nx // ny], dtype=float)
            if any(n[a] != 1 for a in axes):
                continue
            box = L / n
            # (the faces between boxes, summed: what the halo's volume grows with)
            area = float(np.sum((n - 1) * L[[1, 0, 0]] * L[[2, 2, 1]]))
            cost = (area, -min(box) / max(box))
            if best is None or cost < best:
                best, shape = cost, tuple(int(k) for k in n)
    return shape


class Decomposed:
    """One rank's part of a scene cut over the ranks of ``comm`` (made by :func:`decompose`).

    Attributes
    ----------
    simulation : Simulation
        This rank's spheres (its own and its halo) as a :class:`tsubu.Simulation`. Read it for
        what it holds; do not add or remove spheres, walls or contacts on it directly. Its
        energy and stress count the copies too: the whole scene's are :meth:`energy` and
        :meth:`stress`.
    comm : mpi4py.MPI.Comm
        The ranks.
    shape : tuple of 3 ints
        Boxes along x, y and z (rank r is box r in C order).
    cuts : list of 3 arrays
        The box boundaries along each axis, m (the outer ones at -inf and +inf).
    reach : float
        m: the halo holds every sphere whose centre is within this distance of the box:
        the largest diameter, plus a tenth of the skin (a sticky contact's reach), plus
        ``margin``.
    margin : float
        m: the run stops to move spheres between ranks before any sphere can have moved
        margin / 2 since the last time. Unless :func:`decompose` was given one, it is set again
        from the largest speed at each redistribution.
    redistributions : int
        How many times spheres were moved between ranks.
    imbalance : float or None
        A redistribution also moves the cuts (:meth:`balance`) when the busiest rank owns more
        than this many times the mean; None: only when asked.
    balances : int
        How many times the cuts were moved.
    """

    def __init__(self, simulation, comm, shape, margin, imbalance):
        self.simulation = simulation
        self.imbalance = imbalance
        self.balances = 0
        self.comm = comm
        self.shape = tuple(int(s) for s in shape)
        self._margin_auto = margin is None
        self.margin = 0.0 if margin is None else float(margin)
        self.redistributions = 0
        core = simulation._core
        self._core = core
        self._rank, self._size = comm.Get_rank(), comm.Get_size()
        self._fixed = self._fixed_table()
        box = simulation.box
        self._periodic = [] if box is None else ["xyz".index(a) for a in box.periodic]
        self._lower = None if box is None else np.asarray(box.lower, dtype=float)
        self._upper = None if box is None else np.asarray(box.upper, dtype=float)
        radii = core.radii()
        self._r_max = comm.allreduce(float(radii.max()) if len(radii) else 0.0, op=_mpi().MAX)
        self._set_reach(self._largest_speed2())
        # One past the largest id handed out (ids are never reused): the next added sphere's id.
        removed = core.removed()["id"]
        self._id_bound = int(max([int(core.get_ids().max()) + 1 if core.size else 0] +
                                 [int(removed.max()) + 1 if len(removed) else 0]))
        self._moved = 0.0
        self._due = False
        self._local, self._top = np.zeros(3), np.zeros(3)
        self.cuts = self._balanced_cuts(core.positions(), core.get_ids(), everywhere=True)
        # The removal log: what was removed before (every rank has it: rank 0 tells it), then
        # each rank's own spheres' removals.
        before = core.removed()
        self._removed_seen = len(before["id"])
        self._removed = [dict(before)] if self._rank == 0 and self._removed_seen else []
        # Every rank holds the whole scene now: keep what is this rank's.
        ids, x = core.get_ids(), core.positions()
        owner = self.owner_of(x)
        keep = self._present(x, owner, self._rank)
        pairs, walls = core.contact_state(False), core.contact_state(True)
        held = np.isin(pairs["owner"], ids[keep]) & np.isin(pairs["partner"], ids[keep])
        self._reshape(ids[~keep], None, _rows(pairs, held), _rows(walls, np.isin(walls["owner"], ids[keep])))
        self._set_lists(ids[keep], x[keep], owner[keep])

    # ---- geometry ---------------------------------------------------------------------------
    def _largest_speed2(self, v=None) -> float:
        """The largest squared speed of the spheres held (or of the velocities ``v``) on any
        rank (a collective call)."""
        v = self._core.velocities() if v is None else v
        return self.comm.allreduce(float(np.max(np.einsum("ij,ij->i", v, v))) if len(v) else 0.0,
                                   op=_mpi().MAX)

    def _set_reach(self, v2: float) -> None:
        """The automatic margin for the largest squared speed ``v2`` (every rank finds the same),
        then the reach. Between two redistributions the fastest sphere may travel margin / 2: at
        ``v`` that takes _MARGIN_STEPS steps. The margin stays within [skin, largest diameter]:
        no thinner than the lists' own skin (as LAMMPS's ghost cut-off is the force cut-off plus
        the neighbour skin), no thicker than the halo of a slow scene needs."""
        core = self._core
        if self._margin_auto:
            step = float(core.dt) if core.dt > 0 else float(core.time_step())
            wanted = 2.0 * _MARGIN_STEPS * step * math.sqrt(v2)
            self.margin = max(float(core.skin()), min(2.0 * self._r_max, wanted))
        # (A contact reaches at most r_i + r_j, a sticky one up to the near list's skin / 10
        # further.)
        self.reach = 2.0 * self._r_max + 0.1 * float(core.skin()) + self.margin

    def _balanced_cuts(self, x, ids, everywhere=False):
        """Cuts that give each box about as many spheres: along each axis, at the quantiles of
        the centres (all spheres, each counted once: by its owner, or by every rank when each
        holds the whole scene; gathered to every rank along the axes that are cut)."""
        cuts = []
        for d in range(3):
            n = self.shape[d]
            inner = []
            if n > 1:
                if everywhere:
                    allx = np.sort(x[:, d])
                else:
                    own = np.isin(ids, self._owned, assume_unique=True)
                    allx = np.sort(np.concatenate(self.comm.allgather(x[own, d])))
                if len(allx):
                    inner = [float(allx[min(len(allx) - 1, (k * len(allx)) // n)]) for k in range(1, n)]
                else:
                    inner = [float(self._lower[d]) if d in self._periodic else 0.0] * (n - 1)
            if d in self._periodic:  # (its boxes end at the faces: their images are the far side's)
                cuts.append(np.array([self._lower[d]] + inner + [self._upper[d]]))
            else:
                cuts.append(np.array([-np.inf] + inner + [np.inf]))
        return cuts

    def _box_of(self, rank):
        ix, iy, iz = np.unravel_index(rank, self.shape)
        lo = np.array([self.cuts[0][ix], self.cuts[1][iy], self.cuts[2][iz]])
        hi = np.array([self.cuts[0][ix + 1], self.cuts[1][iy + 1], self.cuts[2][iz + 1]])
        return lo, hi

    def owner_of(self, x) -> np.ndarray:
        """The rank whose box holds each centre (x: (N, 3), m)."""
        x = np.asarray(x, dtype=float).reshape(-1, 3)
        idx = [np.clip(np.searchsorted(self.cuts[d], x[:, d], side="right") - 1, 0, self.shape[d] - 1)
               for d in range(3)]
        return np.ravel_multi_index(idx, self.shape).astype(np.int64)

    def _present(self, x, owner, rank):
        """Whether each sphere (centres x, owners) is held by `rank`: its own, or in its halo."""
        lo, hi = self._box_of(rank)
        gap = np.maximum(np.maximum(lo - x, x - hi), 0.0)
        for d in self._periodic:  # (the nearest image along a periodic axis)
            length = self._upper[d] - self._lower[d]
            for shift in (-length, length):
                xs = x[:, d] + shift
                gap[:, d] = np.minimum(gap[:, d], np.maximum(np.maximum(lo[d] - xs, xs - hi[d]), 0.0))
        return (owner == rank) | (np.sqrt(np.sum(gap * gap, axis=1)) <= self.reach)

    @property
    def owned(self) -> np.ndarray:
        """The ids of this rank's own spheres, sorted."""
        return self._owned[np.isin(self._owned, self._core.get_ids(), assume_unique=True)]

    def _set_lists(self, ids, x, owner):
        """This rank's own spheres, and who sends what to whom each step (ids sorted on both
        sides, so that the buffers line up): ids, x, owner are the spheres held here."""
        me = self._rank
        self._owned = np.sort(ids[owner == me])
        own = owner == me
        self._send, self._recv = {}, {}
        for q in range(self._size):
            if q == me:
                continue
            there = own & self._present(x, owner, q)
            if there.any():
                self._send[q] = np.sort(ids[there])
            mine = owner == q
            if mine.any():
                self._recv[q] = np.sort(ids[mine])
        self._buffers()

    def _buffers(self) -> None:
        # (Its own spheres: what a periodic rank's speeds and every rank's energy share count.)
        self._core._set_own(self._owned)
        # (A message: a count, then 9 values per sphere, or 10 when only some travel:
        # Simulation::pack_halo.)
        self._send_buffers = {q: np.empty(1 + 10 * len(v)) for q, v in self._send.items()}
        self._recv_buffers = {q: np.empty(1 + 10 * len(v)) for q, v in self._recv.items()}
        # The receives are the same every step until the next redistribution: persistent
        # requests, started each step (a few microseconds of Python less than new ones).
        for r in getattr(self, "_receives", ()):
            r.Free()
        self._receives = [self.comm.Recv_init(buf, source=q, tag=_TAG_HALO)
                          for q, buf in self._recv_buffers.items()]
        self._sends = [(q, ids, self._send_buffers[q]) for q, ids in self._send.items()]
        self._unpacks = [(ids, self._recv_buffers[q]) for q, ids in self._recv.items()]

    def _fixed_table(self):
        f = self._core.fixed_motion()
        table = self.comm.allgather((np.asarray(f["ids"]), np.asarray(f["velocities"]),
                                     np.asarray(f["angular_velocities"])))
        ids = np.concatenate([t[0] for t in table]) if table else np.empty(0, np.int64)
        v = np.concatenate([t[1] for t in table]).reshape(-1, 3)
        w = np.concatenate([t[2] for t in table]).reshape(-1, 3)
        ids, first = np.unique(ids, return_index=True)
        return ids, v[first], w[first]

    # ---- the step: the halo follows its owners ------------------------------------------------
    def _exchange(self, vmax2: float, rel2: float):
        MPI = _mpi()
        core, comm = self._core, self.comm
        receives = self._receives
        MPI.Prequest.Startall(receives)
        requests = [comm.Isend(buf[:core._pack_halo(ids, buf)], dest=q, tag=_TAG_HALO)
                    for q, ids, buf in self._sends]
        MPI.Request.Waitall(receives + requests)
        v2 = 0.0
        for ids, buf in self._unpacks:
            v2 = max(v2, core._unpack_halo(ids, buf))
        # The step's largest speeds over every rank: what the lists book. In a periodic box,
        # the largest over the spheres each rank owns, as one process finds them (it wraps
        # spheres at rebuilds, which must fall at the same steps); elsewhere any bound will do.
        local = self._local
        if self._periodic:
            local[:] = core._own_speeds()
        else:
            local[0], local[1], local[2] = max(vmax2, v2), rel2, 0.0
        top = self._top
        comm.Allreduce([local, MPI.DOUBLE], [top, MPI.DOUBLE], op=MPI.MAX)
        # The run stops for a redistribution before any sphere can have moved margin / 2.
        self._moved += self._dt * math.sqrt(top[0])
        if self._moved > 0.5 * self.margin:
            self._due = True
            core.request_stop()
        return float(top[0]), float(top[1]), float(top[2])

    def run(self, steps: int | None = None, time: float | None = None, *, output=None,
            checkpoint=None, checkpoint_every: int | None = None,
            checkpoint_keep: int = 3) -> "Decomposed":
        """Advance every rank by ``steps`` steps or ``time`` seconds (a collective call: every
        rank calls it with the same arguments). The state after it is the same, bit for bit, as
        one process's after the same run.

        Parameters
        ----------
        steps, time : int or float
            As :meth:`tsubu.Simulation.run`: exactly one of them.
        output : hook or list of hooks, optional
            Run hooks (:mod:`tsubu.hooks`), such as :class:`tsubu.output.VTKOutput`. A hook
            with a true attribute ``acts_on_every_rank`` (a scene file's wall schedule) acts on
            every rank's part; any other acts on rank 0 only, on the whole scene gathered there
            (:meth:`gather`) at the steps it asks for.
        checkpoint, checkpoint_every, checkpoint_keep
            As :meth:`tsubu.Simulation.run`: rank 0 saves the gathered scene, a checkpoint that
            loads in one process or on any number of ranks.

        Notes
        -----
        An error on one rank (an unstable run, a hook that raises) is printed there and ends
        every rank (``MPI_Abort``, exit status 1), as LAMMPS's errors do: the others would wait
        for it forever.
        """
        from . import hooks as _hooks

        core, comm = self._core, self.comm
        if (steps is None) == (time is None):
            raise TypeError("run needs exactly one of steps= or time=")
        self._dt = float(core.time_step())
        if time is not None:
            from .simulation import _steps_for
            steps = _steps_for(_checks.positive("time", time, allow_zero=True), self._dt)
        steps = _checks.whole("steps", steps)
        outputs = [] if output is None else list(output) if isinstance(output, (list, tuple)) else [output]
        for k, hook in enumerate(outputs):
            _hooks.check_hook(hook, "output" if len(outputs) == 1 else f"output[{k}]")
        periodic = []
        if checkpoint_every is not None:
            if checkpoint is None:
                raise ValueError("checkpoint_every needs checkpoint= (the path beside which the "
                                 "numbered checkpoints are written)")
            periodic = [_hooks.PeriodicCheckpoint(_checks.path("checkpoint", checkpoint),
                                                  _checks.whole("checkpoint_every", checkpoint_every, minimum=1),
                                                  _checks.whole("checkpoint_keep", checkpoint_keep, minimum=1))]
        # (The scene's inserters first, as Simulation.run runs them: an event on every rank.)
        everywhere = [_InsertEvents(self, i) for i in self.simulation.inserters]
        everywhere += [h for h in outputs if getattr(h, "acts_on_every_rank", False)]
        observers = [h for h in outputs if h not in everywhere] + periodic
        root = self._rank == 0
        end = core.step_count + steps
        whole = None
        core._set_exchange(self._exchange)
        try:
            try:
                while True:
                    now = core.step_count
                    target = end
                    for hook in everywhere:
                        due = _hooks.due_step(hook, self.simulation)
                        if due is not None and due <= now:
                            hook.act(self.simulation)
                            due = _hooks.due_step(hook, self.simulation)
                        if due is not None and due < target:
                            target = due
                    # The observers' answers are rank 0's (they act there only).
                    acting = False
                    if root and observers:
                        for hook in observers:
                            due = _hooks.due_step(hook, self.simulation)
                            acting |= due is not None and due <= now
                    if observers:
                        acting = comm.bcast(acting, root=0)
                    if acting:
                        whole = self.gather()
                        if root:
                            for hook in observers:
                                due = _hooks.due_step(hook, whole)
                                if due is not None and due <= now:
                                    hook.act(whole)
                    if root and observers:
                        for hook in observers:
                            due = _hooks.due_step(hook, self.simulation)
                            if due is not None and due <= now:
                                raise RuntimeError(f"run hook {hook!r} acted at step {now} and asks for "
                                                   f"step {due} again: next_step must move on after act")
                            if due is not None and due < target:
                                target = due
                    if observers:
                        target = comm.bcast(target, root=0)
                    if now >= end:
                        break
                    self._advance(target - now)
            finally:
                if root:
                    for hook in observers:
                        hook.close(whole if whole is not None else self.simulation)
                for hook in everywhere:
                    hook.close(self.simulation)
        except Exception as e:  # noqa: BLE001 - every error ends every rank
            if self._size == 1:
                raise
            import sys
            import traceback
            print(f"tsubu: rank {self._rank} of {self._size}: error at step {core.step_count}: "
                  f"{type(e).__name__}: {e}", file=sys.stderr)
            traceback.print_exc(file=sys.stderr)
            sys.stderr.flush()
            comm.Abort(1)
        finally:
            core._set_exchange(None)
        if checkpoint is not None:
            whole = self.gather()
            if root:
                whole.save(checkpoint, metadata=getattr(self.simulation, "metadata", None))
        return self

    def _advance(self, steps: int) -> None:
        """``steps`` steps, stopping for redistributions on the way."""
        core = self._core
        left = steps
        while left > 0:
            try:
                taken = core.run(left, False)
            except Exception as e:
                from .simulation import InstabilityError, _core
                if isinstance(e, _core.InstabilityError):
                    message, step, particle = e.args
                    raise InstabilityError(message, step, particle) from None
                raise
            left -= taken
            if self._due:
                self._due = False
                core._set_exchange(None)
                self.redistribute()
                core._set_exchange(self._exchange)

    # ---- moving spheres between ranks -----------------------------------------------------------
    def add_spheres(self, positions, radius, material, velocities=None,
                    angular_velocities=None, _check: bool = True) -> np.ndarray:
        """Add spheres to the decomposed scene, each rank its own share (a collective call: every
        rank calls it, with any number of spheres, none included). The spheres go to the ranks
        that hold them; no rank holds the whole scene. The result is that of one process adding
        rank 0's spheres, then rank 1's, and so on, in one call of
        :meth:`tsubu.Simulation.add_spheres`: the same ids, the same bits afterwards.

        Parameters
        ----------
        positions, radius, material, velocities, angular_velocities
            As :meth:`tsubu.Simulation.add_spheres`, this rank's share.

        Returns
        -------
        numpy.ndarray of int64
            The ids of this rank's share (consecutive; rank 0's come first).

        Raises
        ------
        ValueError
            As :meth:`tsubu.Simulation.add_spheres`; and for a scene whose ``dt``, ``skin`` or
            ``impact_speed`` was not set when it was decomposed (their defaults are taken from
            all the spheres, which no rank holds).
        """
        from .material import Material
        from .simulation import _check_mass, _energies_fit

        core, comm, me = self._core, self.comm, self._rank
        missing = [k for k, v in getattr(self, "_given", {}).items() if not v]
        if missing:
            raise ValueError(f"add_spheres over ranks needs the scene's {', '.join(missing)} set before "
                             "decompose (Simulation(dt=..., skin=..., impact_speed=...)): their defaults "
                             "are taken from all the spheres, which no rank holds")
        x = _checks.points("positions", positions)
        n = x.shape[0]
        r = _checks.radii("radius", radius, n)
        if not isinstance(material, Material):
            raise TypeError(f"material must be a tsubu.Material, got {material!r}")
        mass = _check_mass(r, material)
        mat = self.simulation._material(material, scene=True)
        v = np.zeros((n, 3)) if velocities is None else _checks.points("velocities", velocities, n)
        w = np.zeros((n, 3)) if angular_velocities is None else _checks.points("angular_velocities",
                                                                              angular_velocities, n)
        _energies_fit("positions", mass, r, x=x, g=self.simulation.gravity)
        _energies_fit("velocities", mass, r, v=v)
        _energies_fit("angular_velocities", mass, r, w=w)
        counts = comm.allgather(n)
        first = self._id_bound + sum(counts[:me])
        ids = np.arange(first, first + n, dtype=np.int64)
        self._id_bound += sum(counts)
        self._r_max = max(self._r_max, comm.allreduce(float(r.max()) if n else 0.0, op=_mpi().MAX))
        self._set_reach(max(self._largest_speed2(), self._largest_speed2(v)))
        owner = self.owner_of(x)
        outgoing = []
        for q in range(self._size):
            there = self._present(x, owner, q)
            outgoing.append({"ids": ids[there], "x": x[there], "v": v[there], "w": w[there],
                             "radius": r[there], "material": np.full(int(there.sum()), mat, np.int32)})
        got = {k: np.concatenate([m[k] for m in comm.alltoall(outgoing)]) for k in outgoing[0]}
        pairs, walls = core.contact_state(False), core.contact_state(True)
        k = len(got["ids"])
        got.update(dissipated=np.zeros(k), images=np.zeros((k, 3), np.int64), slid=np.zeros(k))
        self._reshape([], got, pairs, walls, fresh=True, check=_check)
        # The new spheres join the lists as the spheres held where they were sent (the lists of
        # the others stay those of the last redistribution), then the cuts move with the load.
        gx = got["x"].reshape(-1, 3)
        gown = self.owner_of(gx)
        self._owned = np.union1d(self._owned, got["ids"][gown == me])
        for q in range(self._size):
            if q == me:
                continue
            mine = (gown == me) & self._present(gx, gown, q)
            if mine.any():
                self._send[q] = np.union1d(self._send.get(q, np.zeros(0, np.int64)), got["ids"][mine])
            theirs = gown == q
            if theirs.any():
                self._recv[q] = np.union1d(self._recv.get(q, np.zeros(0, np.int64)), got["ids"][theirs])
        self._buffers()
        self.redistribute(balance=True)
        return ids

    def _insert(self, inserter) -> None:
        """An event of one of the scene's inserters, on every rank alike: it places its spheres
        against every sphere of the scene (gathered from their owners, in id order), rank 0 adds
        them (ids as one process hands them out) and each rank takes those it holds."""
        core, comm = self._core, self.comm
        ids = core.get_ids()
        own = np.isin(ids, self._owned, assume_unique=True)
        parts = comm.allgather((ids[own], core.positions()[own], core.radii()[own]))
        every = np.concatenate([p[0] for p in parts])
        order = np.argsort(every, kind="stable")
        existing = (np.concatenate([p[1] for p in parts]).reshape(-1, 3)[order],
                    np.concatenate([p[2] for p in parts])[order])
        positions, radii, placed, due = inserter._plan(self.simulation, existing=existing)
        n = int(placed.sum()) if self._rank == 0 else 0
        x = positions[placed] if n else np.zeros((0, 3))
        r = radii[placed] if n else np.zeros(0)
        self.add_spheres(x, r, inserter.material, velocities=np.tile(inserter.velocity, (n, 1)),
                         angular_velocities=np.tile(inserter.angular_velocity, (n, 1)), _check=False)
        if placed.any():
            inserter._inserted += int(placed.sum())
            # (the masses as the core computes them, summed as Simulation.masses would be)
            rp = radii[placed]
            inserter._inserted_mass += float(np.sum(inserter.material.density * 4.0 / 3.0 * np.pi * rp * rp * rp))
        inserter._carry(radii, placed, due)

    def _reshape(self, leaving, arriving, pairs, walls, fresh=False, check=False) -> None:
        _reshape(self._core, self._fixed, bool(self._periodic), leaving, arriving, pairs, walls, fresh, check)

    def redistribute(self, balance: bool = False) -> None:
        """Move spheres to the rank whose box now holds them, refill every halo and carry the
        contacts with them (a collective call). ``balance``: first move the cuts so that the
        boxes hold about as many spheres again (as LAMMPS's ``balance``).

        Only what a rank lacks travels: the spheres new to its halo or box, each from its
        owner, with their contacts there; a sphere that changes owner between two ranks that
        both hold it sends only its dissipated energy (the copies book their own)."""
        core, comm, me = self._core, self.comm, self._rank
        ids = core.get_ids()  # (sorted)
        x = core.positions()
        self._harvest_removed(ids)
        if self._margin_auto:
            self._set_reach(self._largest_speed2())
        counts = comm.allgather(int(np.count_nonzero(np.isin(self._owned, ids, assume_unique=True))))
        mean = sum(counts) / len(counts)
        if balance or (self.imbalance is not None and max(counts) > self.imbalance * max(mean, 1.0)):
            self.cuts = self._balanced_cuts(x, ids)
            self.balances += 1
        owner = self.owner_of(x)  # (every rank finds the same owner for a sphere it holds)
        own = np.isin(ids, self._owned, assume_unique=True)
        pairs, walls = core.contact_state(False), core.contact_state(True)
        p_rows = np.searchsorted(ids, np.asarray(pairs["owner"]))
        q_rows = np.searchsorted(ids, np.asarray(pairs["partner"]))
        w_rows = np.searchsorted(ids, np.asarray(walls["owner"]))
        radius = material = dissipated = None
        outgoing = []
        for q in range(self._size):
            message = {}
            if q != me and own.any():
                there = self._present(x, owner, q)
                had = np.isin(ids, self._send.get(q, ()), assume_unique=True)
                new = own & there & ~had
                handed = own & had & (owner == q)  # (q holds it already: it takes its energy)
                if new.any():
                    if radius is None:
                        radius, material, dissipated = core.radii(), core.materials(), core.dissipated()
                    prow = (new[p_rows] & there[q_rows]) | (new[q_rows] & there[p_rows])
                    message.update(_raw(core, ids[new]), radius=radius[new], material=material[new],
                                   dissipated=dissipated[new], pairs=_rows(pairs, prow),
                                   walls=_rows(walls, new[w_rows]))
                if handed.any():
                    if dissipated is None:
                        dissipated = core.dissipated()
                    message.update(handed=ids[handed], handed_dissipated=dissipated[handed])
            outgoing.append(message)
        incoming = [m for m in comm.alltoall(outgoing) if m]
        # What stays here: this rank's own now and the spheres within its reach.
        stays = self._present(x, owner, me)
        arrivals = [m for m in incoming if "ids" in m]
        handed = [m for m in incoming if "handed" in m]
        if arrivals or not stays.all():
            keep = stays[p_rows] & stays[q_rows] if len(p_rows) else np.zeros(0, bool)
            kept_pairs = _rows(pairs, keep)
            kept_walls = _rows(walls, stays[w_rows] if len(w_rows) else np.zeros(0, bool))
            got = None
            if arrivals:
                got = {k: np.concatenate([m[k] for m in arrivals]) for k in _SPHERE_KEYS if k in arrivals[0]}
            # The contacts kept, and the arrivals' (a pair of two arrivals from two owners comes
            # twice: once is kept).
            self._reshape(ids[~stays], got,
                          _join(kept_pairs, _merge([m["pairs"] for m in arrivals], walls=False) if arrivals else None),
                          _join(kept_walls, _merge([m["walls"] for m in arrivals], walls=True) if arrivals else None))
        if handed:
            hid = np.concatenate([m["handed"] for m in handed])
            held = core.get_ids()
            d = core.dissipated()
            d[np.searchsorted(held, hid)] = np.concatenate([m["handed_dissipated"] for m in handed])
            core.set_dissipated(d)
        held, hx = core.get_ids(), core.positions()
        self._set_lists(held, hx, self.owner_of(hx))
        self._moved = 0.0
        self.redistributions += 1

    def balance(self) -> None:
        """Move the cuts so that every box holds about as many spheres, and the spheres with
        them (a collective call)."""
        self.redistribute(balance=True)

    # ---- the whole scene on one rank ----------------------------------------------------------
    def _harvest_removed(self, ids_now) -> None:
        log = self._core.removed()
        n = len(log["id"])
        fresh = slice(self._removed_seen, n)
        mine = np.isin(log["id"][fresh], self._owned)
        if mine.any():
            self._removed.append({k: np.asarray(a)[fresh][mine] for k, a in log.items()})
        self._removed_seen = n

    def removed(self) -> dict:
        """The spheres outlets removed on every rank so far (as :attr:`Simulation.removed`),
        on every rank (a collective call)."""
        self._harvest_removed(None)
        parts = [p for rank in self.comm.allgather(self._removed) for p in rank]
        keys = ("id", "outlet", "step", "time", "position", "velocity")
        if not parts:
            empty = self._core.removed()
            return {k: np.asarray(empty[k])[:0] for k in keys}
        out = {k: np.concatenate([p[k] for p in parts]) for k in keys}
        order = np.lexsort((out["id"], out["step"]))
        return {k: a[order] for k, a in out.items()}

    def energy(self) -> dict:
        """The whole scene's energies [J], the terms of :meth:`tsubu.Simulation.energy`, on every
        rank (a collective call), without gathering the scene: each rank books its share (its
        own spheres, and the contacts they own: a pair by its lower id's owner, a wall contact by
        its sphere's), and the shares are summed in rank order. Equal to one process's energies
        to round-off (one process sums over all spheres in id order), the same on every rank.

        Returns
        -------
        dict of float
            ``translational``, ``rotational``, ``kinetic``, ``gravitational``, ``elastic``,
            ``total``, ``dissipated`` and ``step_correction`` (0), as ``Simulation.energy()``.
        """
        shares = self.comm.allgather(self._core.energy(False, True))
        return {key: sum(share[key] for share in shares) for key in shares[0]}

    def stress(self, volume=None, per_particle: bool = False) -> np.ndarray:
        """The whole scene's Cauchy stress (Love-Weber, as :meth:`tsubu.Simulation.stress`), on
        every rank (a collective call). A rank's own spheres have all their contacts there, so
        their brackets sigma_i V are one process's, bit for bit; the stress sums them over each
        rank, then over the ranks in rank order: one process's to round-off.

        Parameters
        ----------
        volume : float, optional
            As ``Simulation.stress``: the volume [m^3], > 0; default the periodic box's (a scene
            without a box needs it, unless ``per_particle``).
        per_particle : bool
            If True, every sphere's bracket sigma_i V [N m], shape (N, 3, 3), in id order (the
            whole scene's, on every rank: N x 72 bytes each).

        Returns
        -------
        numpy.ndarray
            (3, 3) [Pa], or (N, 3, 3) [N m]; read-only.
        """
        brackets = self.simulation.stress(volume=volume, per_particle=True)
        box = self.simulation.box
        if not per_particle:
            if volume is None and box is None:
                raise ValueError("stress: volume=None needs a periodic box (set_box); a walled or open "
                                 "scene needs an explicit volume [m^3], e.g. the volume its walls enclose")
            volume = float(box.volume) if volume is None else float(volume)
        ids = self._core.get_ids()
        own = np.isin(ids, self._owned, assume_unique=True)
        if per_particle:
            parts = self.comm.allgather((ids[own], brackets[own]))
            every = np.concatenate([p[0] for p in parts])
            out = np.concatenate([p[1] for p in parts]).reshape(-1, 3, 3)[np.argsort(every, kind="stable")]
        else:
            out = np.zeros((3, 3))
            for share in self.comm.allgather(brackets[own].sum(axis=0)):
                out += share
            out /= volume
        out.flags.writeable = False
        return out

    def gather(self, root: int = 0):
        """The whole scene as one :class:`tsubu.Simulation` on rank ``root`` (None on the
        others): every sphere with its state, every contact, as one process would hold them
        after the same steps (a collective call). Save it, take its energy, write output."""
        core, comm = self._core, self.comm
        ids = core.get_ids()
        own = np.isin(ids, self._owned, assume_unique=True)
        pairs, walls = core.contact_state(False), core.contact_state(True)
        mine_p = np.isin(pairs["owner"], self._owned)  # (the lower id's owner sends a pair)
        mine_w = np.isin(walls["owner"], self._owned)
        part = dict(_raw(core, ids[own]), radius=core.radii()[own], material=core.materials()[own],
                    dissipated=core.dissipated()[own], pairs=_rows(pairs, mine_p), walls=_rows(walls, mine_w))
        log = self.removed()
        parts = comm.gather(part, root=root)
        if comm.Get_rank() != root:
            return None
        whole = pickle.loads(pickle.dumps(self.simulation))
        wc = whole._core
        wc._set_exchange(None)
        got = {k: np.concatenate([p[k] for p in parts]) for k in _SPHERE_KEYS if k in parts[0]}
        order = np.argsort(got["ids"], kind="stable")
        got = {k: a[order] for k, a in got.items()}
        _reshape(wc, self._fixed, bool(self._periodic), wc.get_ids(), got,
                 _merge([p["pairs"] for p in parts], walls=False), _merge([p["walls"] for p in parts], walls=True))
        wc._set_removed(*(log[k] for k in ("id", "outlet", "step", "time", "position", "velocity")))
        return whole


class _InsertEvents:
    """An inserter of a decomposed scene as a run hook acting on every rank."""
    acts_on_every_rank = True

    def __init__(self, part, inserter):
        self.part, self.inserter = part, inserter

    def next_step(self, sim):
        return self.inserter.next_step(sim)

    def act(self, sim) -> None:
        self.part._insert(self.inserter)

    def close(self, sim) -> None:
        pass


def _reshape(core, fixed, periodic, leaving, arriving, pairs, walls, fresh=False, check=False) -> None:
    """Drops the spheres ``leaving`` (ids), inserts ``arriving`` (a dict of arrays, or None; the
    fixed ones among them, by ``fixed``'s table, fixed again; ``check``: checked for overlaps at
    the next run), and sets the contacts ``pairs`` and ``walls`` (contact_state dicts): one
    rebuild of the lists. In a periodic box that rebuild wraps nothing and the lists keep their
    displacement bounds, so that the next rebuild, which wraps, falls where one process's does;
    unless ``fresh``: spheres were added, and one process's next run rebuilds and wraps them all,
    as this rebuild then does."""
    bounds = core._moved_bounds
    core._drop_spheres(np.asarray(leaving, dtype=np.int64), carry=False)
    if arriving is not None and len(arriving["ids"]):
        core._insert_spheres(arriving["ids"], arriving["x"].reshape(-1, 3), arriving["radius"],
                             arriving["material"].astype(np.int32), arriving["v"].reshape(-1, 3),
                             arriving["w"].reshape(-1, 3), arriving["dissipated"], carry=False,
                             images=arriving["images"].reshape(-1, 3) if periodic else None,
                             slid=arriving["slid"] if periodic else None, check=check)
        fixed_ids, fv, fw = fixed
        back = np.isin(fixed_ids, arriving["ids"])
        if back.any():
            core.fix_spheres(fixed_ids[back], fv[back], fw[back])
    core.set_contact_state(pairs, walls, wrap=fresh or not periodic)
    if periodic and not fresh:
        core._moved_bounds = bounds


_SPHERE_KEYS = ("ids", "x", "v", "w", "radius", "material", "dissipated", "images", "slid")


def _raw(core, ids) -> dict:
    """The spheres ``ids`` (all held) as stored: position, velocity, spin and image counters
    (in a periodic box a sphere stays unwrapped until the next rebuild; the positions property
    reports it wrapped, which would wrap it at another step than one process does)."""
    state, images, slid = core._raw_state(np.asarray(ids, dtype=np.int64))
    return {"ids": np.asarray(ids, dtype=np.int64), "x": state[:, 0:3], "v": state[:, 3:6],
            "w": state[:, 6:9], "images": images, "slid": slid}


def launched_ranks() -> int:
    """How many ranks ``mpiexec`` started this process among (MPICH's and Intel MPI's
    ``PMI_SIZE``, Open MPI's ``OMPI_COMM_WORLD_SIZE``), read from the environment without
    starting MPI; 1 when it was not started by mpiexec."""
    return _launched(("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"), 1)


def launched_rank() -> int:
    """This process's rank among those ``mpiexec`` started (0 when it was not)."""
    return _launched(("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"), 0)


def _launched(names, default: int) -> int:
    import os

    for name in names:
        value = os.environ.get(name)
        if value and value.isdigit():
            return int(value)
    return default


def _rows(state: dict, mask) -> dict:
    """The contacts of a contact_state dict where mask is True."""
    out = {"owner": np.asarray(state["owner"])[mask], "partner": np.asarray(state["partner"])[mask],
           "values": [np.asarray(a)[mask] for a in state["values"]], "widths": list(state["widths"])}
    if "element" in state:
        out["element"] = np.asarray(state["element"])[mask]
    return out


def _join(a: dict, b: "dict | None") -> dict:
    """Two contact_state dicts with no contact in common, as one."""
    if b is None or len(b["owner"]) == 0:
        return a
    out = {"owner": np.concatenate([a["owner"], b["owner"]]),
           "partner": np.concatenate([a["partner"], b["partner"]]),
           "values": [np.concatenate([np.asarray(x).reshape(len(a["owner"]), wd),
                                      np.asarray(y).reshape(len(b["owner"]), wd)])
                      for x, y, wd in zip(a["values"], b["values"], a["widths"])],
           "widths": list(a["widths"])}
    if "element" in a:
        out["element"] = np.concatenate([a["element"], b["element"]])
    return out


def _merge(states: list, walls: bool) -> dict:
    """The contacts of several contact_state dicts, each key once (the first one's copy: every
    copy of a contact holds the same bits), ordered by key."""
    owner = np.concatenate([np.asarray(s["owner"], dtype=np.int64) for s in states])
    partner = np.concatenate([np.asarray(s["partner"], dtype=np.int64) for s in states])
    widths = next((list(s["widths"]) for s in states if len(s["owner"])), list(states[0]["widths"]))
    if walls:
        element = np.concatenate([np.asarray(s.get("element", np.zeros(len(s["owner"]), np.int64)),
                                             dtype=np.int64) for s in states])
        keys = np.stack([owner, partner, element], axis=1)
    else:
        keys = np.stack([owner, partner], axis=1)
    if len(keys):
        _, first = np.unique(keys, axis=0, return_index=True)
    else:
        first = np.zeros(0, np.int64)
    values = []
    for k, wd in enumerate(widths):
        cols = [np.asarray(s["values"][k], dtype=float).reshape(len(s["owner"]), wd) for s in states]
        values.append(np.concatenate(cols)[first] if len(first) else np.zeros((0, wd)))
    out = {"owner": owner[first], "partner": partner[first], "values": values, "widths": widths}
    if walls:
        out["element"] = element[first]
    return out


def decompose(simulation, comm=None, shape=None, margin: float | None = None,
              imbalance: float | None = 1.2) -> Decomposed:
    """Cut a scene over MPI ranks (a collective call: every rank calls it with the same scene).

    Parameters
    ----------
    simulation : Simulation
        The whole scene, the same on every rank (built by the same code, or loaded from one
        checkpoint). From now on it holds this rank's part: use the returned object.
    comm : mpi4py.MPI.Comm, optional
        The ranks (default ``MPI.COMM_WORLD``).
    shape : tuple of 3 ints, optional
        Boxes along x, y, z, their product the number of ranks (default: :func:`grid_shape` of
        the spheres' extent, leaving the axis of gravity uncut).
    margin : float, optional
        m, > 0: how much further than the contacts' reach the halo holds spheres. A larger
        margin redistributes less often and holds more copies. Default: automatic, set again at
        each redistribution so that the fastest sphere takes about 1,000 steps to travel
        margin / 2, within [the neighbour lists' skin, the largest diameter].
    imbalance : float or None, default 1.2
        Move the cuts at a redistribution when the busiest rank owns more than this many times
        the mean number of spheres (> 1); None: only on :meth:`Decomposed.balance`.

    Returns
    -------
    Decomposed
        This rank's part; ``run``, ``gather``, ``removed``, ``balance``, ``energy`` and
        ``stress`` are collective.

    Raises
    ------
    ValueError
        A scene that differs between ranks, a bad ``shape`` or ``margin``, or what the
        decomposition does not handle yet: a periodic box, servo walls, inserters.
    ImportError
        Without mpi4py.
    """
    MPI = _mpi()
    if comm is None:
        comm = MPI.COMM_WORLD
    core = simulation._core
    box = simulation.box
    if box is not None and box.pressure is not None:
        raise ValueError("decompose: a pressure-controlled box needs the stress of every rank's "
                         "contacts each step: not cut over ranks yet (docs/parallel.md)")
    for k in range(simulation.wall_count):
        if simulation.wall(k).get("servo") is not None:
            raise ValueError(f"decompose: wall {k} is a servo wall, which needs the force of every "
                             "rank's contacts each step: not supported over ranks yet")
    if core._has_exchange:
        raise ValueError("decompose: this simulation is already decomposed")
    # The same scene everywhere: the same spheres (a digest of their state and ids).
    ids = core.get_ids()
    h = hashlib.sha256()
    for a in (ids, core.positions(), core.velocities(), core.radii(), np.array([core.step_count])):
        h.update(np.ascontiguousarray(a).tobytes())
    digest = h.hexdigest()
    if len(set(comm.allgather(digest))) != 1:
        raise ValueError("decompose: the scene differs between ranks (its spheres, their state or "
                         "its step): every rank must build or load the same scene")
    # What the scene's spheres decide by default (the step, the skin) is fixed now, from the
    # whole scene, so that no rank's part decides it otherwise. (The characteristic impact
    # speed is fixed by the first run, prepare_run, and kept through the halo's changes.)
    given = {"dt": core.dt > 0, "skin": core.skin_option > 0, "impact_speed": core.impact_speed > 0}
    if simulation.inserters:
        missing = [k for k, v in given.items() if not v]
        if missing:
            raise ValueError(f"decompose: a scene with inserters needs {', '.join(missing)} set "
                             "(Simulation(dt=..., skin=..., impact_speed=...)): one process takes their "
                             "defaults again from all the spheres after each insertion")
    if len(ids) == 0:
        missing = [k for k, v in given.items() if not v]
        if missing:
            raise ValueError(f"decompose: a scene without spheres (to be added by parts, "
                             f"Decomposed.add_spheres) needs {', '.join(missing)} set: their defaults are "
                             "taken from all the spheres")
    else:
        core.prepare_run()
        core.dt = float(core.time_step())
        core.skin_option = float(core.skin())
    if shape is None:
        x = core.positions()
        extent = x.max(axis=0) - x.min(axis=0) if len(x) else np.ones(3)
        # Under gravity the packing changes along it (a bed below, grains falling above): boxes
        # cut along it hold as many spheres but not as much work. So it is left uncut.
        g = np.abs(np.asarray(simulation.gravity, dtype=float))
        # (A Lees-Edwards flow axis first: it must stay uncut, gravity's only should.)
        uncut = ["xyz".index(box.flow)] if box is not None and box.flow is not None else []
        uncut += [int(np.argmax(g))] if g.any() else []
        shape = grid_shape(comm.Get_size(), extent, uncut=uncut)
    shape = tuple(_checks.whole(f"shape[{d}]", s, minimum=1) for d, s in enumerate(shape))
    if len(shape) != 3 or int(np.prod(shape)) != comm.Get_size():
        raise ValueError(f"shape must be 3 whole numbers whose product is the number of ranks "
                         f"({comm.Get_size()}), got {shape!r}")
    if box is not None and box.flow is not None and shape["xyz".index(box.flow)] != 1:
        raise ValueError(f"shape {shape!r} cuts the Lees-Edwards flow axis {box.flow!r}, whose images "
                         "slide along it: leave it uncut (1)")
    if margin is not None:
        margin = _checks.positive("margin", margin)
    if imbalance is not None:
        imbalance = _checks.positive("imbalance", imbalance)
        if imbalance <= 1:
            raise ValueError(f"imbalance must be > 1 (or None), got {imbalance!r}")
    part = Decomposed(simulation, comm, shape, margin, imbalance)
    part._given = given
    return part

#!/usr/bin/env python3
"""A wedge (slot) hopper discharging ~20,000 spheres, side by side with LIGGGHTS (issue 27's
speed target: >= 3x LIGGGHTS's particle-steps/s on one core, with a matching discharge rate).

The scene (SI units):

* spheres: radius 1 mm (d = 2 mm), density 2500 kg/m^3, N = 20,000 (``--n``);
* contact law, grain-grain and grain-wall alike: linear spring-dashpot, kn = 1e4 N/m,
  kt = 2/7 kn, restitution 0.5 (tsubu turns it into eta_n with m_eff = m/2 for a pair and m for
  a wall), Coulomb mu = 0.5, no tangential damping, no rolling friction; Coulomb rule
  ``slip_rule="truncate"`` (LIGGGHTS's: the trial spring force rescaled to the cap, the history
  truncated to match); gravity 9.81 m/s^2 along -z;
* the hopper: a wedge whose two plates (30 deg from the vertical) leave a slot 6 d = 12 mm wide
  at z = 0, running along y over the depth 20 d = 40 mm between two vertical end walls, 100 mm
  high (top width 127.5 mm). 8 triangles (two per plate and per end wall), the layout of
  ``tsubu.mesh.wedge_hopper(orifice_width, top_width, height, depth)``; ``--divisions k`` cuts
  every quad into k x k cells (2 k^2 triangles each) for a finer mesh of the same surface;
* time step: tsubu's default (t_c / 50 of the pair contact), neighbour skin 0.2 d in both codes;
* the outlet: a grain whose centre falls below z = -3 d = -6 mm (3 d under the slot) is removed
  (tsubu: ``add_outlet(point=(0, 0, -6 mm), normal=(0, 0, 1))``; LIGGGHTS: the box floor with a
  fixed boundary, lost atoms ignored: a grain below it is dropped at the next neighbour-list
  rebuild, i.e. within a few steps).

The initial packing (the same for both codes): tsubu pours a random packing (``fill.random_packing``,
solid fraction ~0.30, zero velocities) into the hopper closed at the slot and lets it settle under
gravity (planes: the two plates, the end walls and a floor at z = 0; their faces are the mesh's
triangles, so the settled grains touch the mesh exactly as they touched the planes) until the mean
speed is below 5 mm/s; positions, velocities and spins are kept (not the tangential histories: both
codes start with none). The packing is cached in ``--workdir`` (filling takes minutes) and written
for LIGGGHTS as a data file with every coordinate at full precision. At t = 0 the slot opens and both
codes run ``--steps`` steps.

LIGGGHTS (``benchmarks/liggghts/in.hopper``): ``pair_style gran model hooke/stiffness tangential
history`` (F_n = kn delta - gamma_n m_eff v_n with gamma_n [1/s] per type pair: grain-grain
eta_pair / (m/2), grain-mesh eta_wall / m, the dashpots tsubu derives from e = 0.5), kt, mu,
``tangential_damping off``, ``limitForce off``; the mesh through ``fix mesh/surface`` (ASCII STL written
here from the same vertices and triangles at full precision) and ``fix wall/gran`` with the same law;
``fix nve/sphere`` (velocity Verlet; tsubu integrates with symplectic Euler), one process
(``OMP_NUM_THREADS=1``), ``-echo none``. Its speed comes from the "Loop time of X on 1 procs for S
steps" line (the loop excludes reading the data file and the first neighbour list and force
evaluation); tsubu runs ``--warmup`` untimed steps first (the same set-up work) and times the rest with
``time.perf_counter``. Particle-steps: the sum over the timed steps of the grains present (the hopper
empties), from LIGGGHTS's thermo counts (every ``--every`` steps, trapezoid rule) and from tsubu's
removal log (exact).

Reported: particle-steps/s of each run, medians over ``--repeats`` repetitions (each code in a fresh
process, the order alternating), the median of the per-repetition ratios tsubu / LIGGGHTS (the figure
to quote: side by side on a shared machine), and the discharge rate of each code [kg/s]: a linear fit
of the discharged mass against time over the steady part (from ``--fit-from`` seconds after opening to
the end of the run, or to when 2/3 of the grains are out if earlier).

tsubu's side needs the mesh walls and outlets of issue 27 (``Simulation.add_mesh``,
``Simulation.add_outlet``, ``Simulation.removed``); the script says so and runs LIGGGHTS alone without
them (``--only liggghts`` does that on purpose). Without ``liggghts`` on the PATH (Debian:
``apt-get install liggghts``) the script prints why and exits with status 2 (``--only tsubu`` runs tsubu
alone); ``liggghts`` is a benchmark-only tool, never needed by tsubu or its tests.

Usage (from the repository root)::

    PYTHONPATH=python python benchmarks/hopper_liggghts.py                        # both codes, 3 repeats
    PYTHONPATH=python python benchmarks/hopper_liggghts.py --only liggghts --repeats 1
    PYTHONPATH=python python benchmarks/hopper_liggghts.py --steps 20000 --json out.json   # shorter: speed only
    PYTHONPATH=python python benchmarks/hopper_liggghts.py --steps 150000 --fit-from 0.07 --repeats 1
                                           # the discharge rate over 0.15 s of steady flow
    PYTHONPATH=python python benchmarks/hopper_liggghts.py --fill-only            # make (cache) the packing

The flow takes a few hundredths of a second to settle into its steady rate: in LIGGGHTS the first
grain is out at 0.029 s, and the rate is 0.178 kg/s over 0.0375-0.0736 s (the default 50,000 steps'
window), 0.189 kg/s over 0.074-0.147 s and 0.191 kg/s over 0.147-0.221 s. Compare the two codes'
rates over the same window; the longer run gives the steady value.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from bench_common import load_state, machine, run_child, system_busy_s

HERE = os.path.dirname(os.path.abspath(__file__))
DECK = os.path.join(HERE, "liggghts", "in.hopper")

# ---------------------------------------------------------------- the scene (SI)
R = 1.0e-3                       # radius [m]
D = 2.0 * R                      # diameter [m]
RHO = 2500.0                     # density [kg/m^3]
KN = 1.0e4                       # normal stiffness [N/m]
KT = 2.0 / 7.0 * KN              # tangential stiffness [N/m]
E_REST = 0.5                     # restitution, pair and wall
MU = 0.5                         # Coulomb friction, pair and wall
G = 9.81                         # gravity [m/s^2] along -z
SKIN = 0.2 * D                   # neighbour skin [m]
MASS = RHO * 4.0 / 3.0 * math.pi * R ** 3

ORIFICE = 6.0 * D                # slot width [m], along x, at z = 0
HALF_ANGLE = math.radians(30.0)  # the plates' angle from the vertical
HEIGHT = 0.100                   # the plates' height [m]
DEPTH = 20.0 * D                 # the slot's length [m], along y (end walls at y = -/+ DEPTH/2)
TOP = ORIFICE + 2.0 * HEIGHT * math.tan(HALF_ANGLE)   # width at the top [m]
Z_OUT = -3.0 * D                 # grains whose centre falls below this are removed [m]
N_DEFAULT = 20000
STEPS_DEFAULT = 50000              # 0.074 s after opening: ~0.03 s of steady discharge
FIT_DELAY = 0.01                 # the steady part starts this long after the first grain is out [s]
SETTLED_SPEED = 5.0e-3           # filling ends when the mean speed is below this [m/s]


def hopper_mesh(divisions: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The hopper's vertices (V, 3) [m] and triangles (F, 3), normals into the hopper.

    ``divisions`` = 1: the 8 vertices and 8 triangles of ``tsubu.mesh.wedge_hopper(ORIFICE, TOP,
    HEIGHT, DEPTH)`` (same order); k > 1 cuts each of the four quads into k x k cells, two
    triangles each (8 k^2 triangles), the same surface, vertices shared along the quads' edges."""
    y0, y1 = -0.5 * DEPTH, 0.5 * DEPTH
    w, t = 0.5 * ORIFICE, 0.5 * TOP
    corners = np.array([[-w, y0, 0.0], [-w, y1, 0.0], [w, y0, 0.0], [w, y1, 0.0],
                        [-t, y0, HEIGHT], [-t, y1, HEIGHT], [t, y0, HEIGHT], [t, y1, HEIGHT]])
    quads = [(0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]   # counter-clockwise from inside
    if divisions == 1:
        faces = np.array([f for p, q, r, s in quads for f in ((p, q, r), (p, r, s))], dtype=np.int64)
        return corners, faces
    k = int(divisions)
    verts, faces = [], []
    for p, q, r, s in quads:
        P, Q, Rr, S = corners[[p, q, r, s]]
        u = np.linspace(0.0, 1.0, k + 1)
        grid = np.array([[(1 - a) * (1 - b) * P + a * (1 - b) * Q + a * b * Rr + (1 - a) * b * S
                          for a in u] for b in u])           # (k+1, k+1, 3): b rows, a columns
        base = sum(len(v) for v in verts)
        verts.append(grid.reshape(-1, 3))
        idx = lambda i, j: base + i * (k + 1) + j           # noqa: E731  (row i = b, column j = a)
        for i in range(k):
            for j in range(k):
                a0, a1, a2, a3 = idx(i, j), idx(i, j + 1), idx(i + 1, j + 1), idx(i + 1, j)
                faces += [(a0, a1, a2), (a0, a2, a3)]
    # The quads' shared edges: one vertex where two grids meet (within 1 nm), so that neighbouring
    # triangles share their edge across the corners as within a quad.
    verts = np.concatenate(verts)
    _, first, inverse = np.unique(np.round(verts / 1e-9).astype(np.int64), axis=0,
                                  return_index=True, return_inverse=True)
    keep = np.sort(first)
    renumber = np.empty(len(verts), dtype=np.int64)
    renumber[keep] = np.arange(len(keep))
    faces = renumber[first[inverse.ravel()]][np.array(faces, dtype=np.int64)]
    return verts[keep], faces


def hopper_planes() -> list[tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """(point, inward normal) of the planes the mesh's faces lie in, and the floor closing the slot."""
    c, s = math.cos(HALF_ANGLE), math.sin(HALF_ANGLE)
    return [((-0.5 * ORIFICE, 0.0, 0.0), (c, 0.0, s)),      # plate at -x
            ((0.5 * ORIFICE, 0.0, 0.0), (-c, 0.0, s)),      # plate at +x
            ((0.0, -0.5 * DEPTH, 0.0), (0.0, 1.0, 0.0)),    # end wall at -y
            ((0.0, 0.5 * DEPTH, 0.0), (0.0, -1.0, 0.0)),    # end wall at +y
            ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))]             # floor over the slot (filling only)


def eta(m_eff: float, k: float = KN, e: float = E_REST) -> float:
    """Normal dashpot [N s/m] for restitution e (docs/physics.md, (B.9))."""
    le = math.log(e)
    return -2.0 * le * math.sqrt(m_eff * k / (math.pi ** 2 + le * le))


def material():
    import tsubu
    return tsubu.Material(density=RHO, kn=KN, kt=KT, restitution=E_REST, friction=MU,
                          rolling_friction=0.0, tangential_damping=0.0, name="hopper glass")


def new_simulation(threads=None, dt=None):
    import tsubu
    return tsubu.Simulation(gravity=(0.0, 0.0, -G), dt=dt, threads=threads, skin=SKIN,
                            slip_rule="truncate")


# ---------------------------------------------------------------- the initial packing (tsubu)
def _inside(points: np.ndarray, margin) -> np.ndarray:
    """Whole spheres (centres ``points``, radius ``margin``) inside the closed hopper."""
    p = np.asarray(points, dtype=float)
    m = np.broadcast_to(np.asarray(margin, dtype=float), p.shape[:1])
    ok = (p[:, 2] - m >= 0.0) & (p[:, 2] + m <= HEIGHT)
    for point, normal in hopper_planes()[:4]:
        ok &= (p - np.array(point)) @ np.array(normal) >= m
    return ok


def _say(*args) -> None:
    print(*args, flush=True)


def fill_packing(n: int, threads=None, seed: int = 1, log=_say) -> dict:
    """Pour ``n`` spheres into the closed hopper and let them settle; returns x, v, w (N, 3), dt."""
    from tsubu import fill
    h = HEIGHT
    region = fill.Region(_inside, lower=(-0.5 * TOP, -0.5 * DEPTH, 0.0), upper=(0.5 * TOP, 0.5 * DEPTH, h),
                         volume=DEPTH * (ORIFICE * h + math.tan(HALF_ANGLE) * h * h))
    t0 = time.perf_counter()
    p = fill.random_packing(region, R, count=n, seed=seed)
    log(f"  random packing of {n} spheres: {time.perf_counter() - t0:.1f} s")
    sim = new_simulation(threads)
    mat = material()
    sim.add_spheres(p.positions, R, mat)
    for point, normal in hopper_planes():
        sim.add_plane(point=point, normal=normal, material=mat)
    dt = sim.dt
    t0 = time.perf_counter()
    while True:
        sim.run(time=0.02)
        speed = float(np.mean(np.linalg.norm(sim.velocities, axis=1)))
        log(f"  settling: t = {sim.time:.3f} s, mean speed {speed:.2e} m/s, "
            f"top {sim.positions[:, 2].max() * 1e3:.1f} mm ({time.perf_counter() - t0:.0f} s)")
        if (sim.time >= 0.1 and speed < SETTLED_SPEED) or sim.time > 1.0:
            break
    return {"x": np.array(sim.positions), "v": np.array(sim.velocities),
            "w": np.array(sim.angular_velocities), "dt": float(dt), "fill_time": float(sim.time)}


def packing_path(n: int, workdir: str) -> str:
    """The packing's cache file: named by n and a digest of everything the filling depends on."""
    scene = repr((n, R, RHO, KN, KT, E_REST, MU, G, SKIN, ORIFICE, HALF_ANGLE, HEIGHT, DEPTH, SETTLED_SPEED))
    return os.path.join(workdir, f"hopper_packing_n{n}_{hashlib.sha1(scene.encode()).hexdigest()[:12]}.npz")


def packing(n: int, workdir: str, threads=None, log=_say) -> dict:
    """The settled packing of ``n`` spheres, from ``workdir``'s cache or made (and cached) now."""
    path = packing_path(n, workdir)
    if os.path.exists(path):
        return load_state(path)
    log(f"filling the hopper with {n} spheres (cached as {path}) ...")
    state = fill_packing(n, threads=threads, log=log)
    os.makedirs(workdir, exist_ok=True)  # (a caller other than main(): ab_speed.py's children)
    tmp = path + ".tmp.npz"
    np.savez_compressed(tmp, **state)
    os.replace(tmp, path)
    return state


# ---------------------------------------------------------------- LIGGGHTS side
def write_stl(path: str, vertices: np.ndarray, faces: np.ndarray) -> None:
    """ASCII STL at full precision (LIGGGHTS reads ASCII STL; repr keeps every bit)."""
    lines = ["solid hopper"]
    for f in faces:
        a, b, c = vertices[f]
        nrm = np.cross(b - a, c - a)
        nrm = nrm / np.linalg.norm(nrm)
        lines.append("  facet normal " + " ".join(repr(float(x)) for x in nrm))
        lines.append("    outer loop")
        for v in (a, b, c):
            lines.append("      vertex " + " ".join(repr(float(x)) for x in v))
        lines += ["    endloop", "  endfacet"]
    lines.append("endsolid hopper")
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")


def write_data(path: str, state: dict) -> None:
    """LIGGGHTS data file (atom_style granular): type 1 grains, type 2 the mesh; the box is the
    region kept (its floor z = Z_OUT is the outlet)."""
    x, v, w = state["x"], state["v"], state["w"]
    n = len(x)
    margin = 2.0 * D
    with open(path, "w") as fh:
        fh.write(f"LIGGGHTS data file: wedge hopper packing, {n} spheres (benchmarks/hopper_liggghts.py)\n\n")
        fh.write(f"{n} atoms\n2 atom types\n\n")
        fh.write(f"{-0.5 * TOP - margin!r} {0.5 * TOP + margin!r} xlo xhi\n")
        fh.write(f"{-0.5 * DEPTH - margin!r} {0.5 * DEPTH + margin!r} ylo yhi\n")
        fh.write(f"{Z_OUT!r} {HEIGHT + margin!r} zlo zhi\n\nAtoms\n\n")
        ids = np.arange(1, n + 1)
        # %.17g: every double read back to the bit.
        np.savetxt(fh, np.column_stack([ids, np.ones(n), np.full(n, D), np.full(n, RHO), x]),
                   fmt=["%d", "%d"] + ["%.17g"] * 5)
        fh.write("\nVelocities\n\n")
        np.savetxt(fh, np.column_stack([ids, v, w]), fmt=["%d"] + ["%.17g"] * 6)


def liggghts_vars(dt: float, steps: int, every: int, n0: int) -> dict:
    """The deck's -var values: tsubu's law in LIGGGHTS's terms (gamma_n = eta_n / m_eff, 1/s)."""
    return {"kn": repr(KN), "kt": repr(KT), "gnp": repr(eta(MASS / 2) / (MASS / 2)),
            "gnw": repr(eta(MASS) / MASS), "mu": repr(MU), "dt": repr(dt), "skin": repr(SKIN),
            "steps": str(steps), "every": str(every), "n0": str(n0), "mgrain": repr(MASS)}


def liggghts_version(exe: str) -> str:
    p = subprocess.run([exe, "-echo", "none", "-log", "none"], input="", capture_output=True,
                       text=True, timeout=60)
    m = re.search(r"LIGGGHTS \(Version ([^)]*)\)", p.stdout + p.stderr)
    return m.group(1) if m else "unknown"


def run_liggghts(exe: str, workdir: str, data: str, stl: str, dt: float, steps: int, every: int,
                 n0: int) -> dict:
    """One LIGGGHTS run (a fresh process, one core); loop time, particle-steps, discharge curve."""
    log = os.path.join(workdir, "log.liggghts")
    cmd = [exe, "-echo", "none", "-log", log, "-in", DECK,
           "-var", "data", data, "-var", "stl", stl]
    for k, val in liggghts_vars(dt, steps, every, n0).items():
        cmd += ["-var", k, val]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    busy0, t0 = system_busy_s(), time.perf_counter()
    p = subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    busy1 = system_busy_s()
    text = open(log).read() if os.path.exists(log) else ""
    if p.returncode != 0 or "Loop time" not in text:
        raise RuntimeError(f"liggghts failed (exit {p.returncode}):\n{p.stdout[-2000:]}{p.stderr[-2000:]}"
                           f"{text[-3000:]}")
    m = re.search(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", text)
    loop, nsteps = float(m.group(1)), int(m.group(3))
    rows = []
    block = re.split(r"^\s*Step\s+Time\s+Atoms\s+v_mout\s*$", text[:m.start()], flags=re.M)[-1]
    for line in block.splitlines():
        f = line.split()
        if len(f) == 4 and f[0].isdigit():
            rows.append((int(f[0]), float(f[1]), int(f[2]), float(f[3])))
    a = np.array(rows, dtype=float)
    psteps = float(np.sum(0.5 * (a[1:, 2] + a[:-1, 2]) * np.diff(a[:, 0])))
    return {"code": "liggghts", "loop_s": loop, "steps": nsteps, "wall_s": wall,
            "particle_steps": psteps, "rate": psteps / loop, "n0": int(a[0, 2]), "n_end": int(a[-1, 2]),
            "t": a[:, 1].tolist(), "discharged_kg": a[:, 3].tolist(),
            "others_cores": None if busy0 is None else max(0.0, (busy1 - busy0 - wall) / wall)}


# ---------------------------------------------------------------- tsubu side
def tsubu_has_mesh_api() -> str | None:
    """None when this tsubu has the mesh walls and outlets, else what is missing."""
    import tsubu
    missing = [a for a in ("add_mesh", "add_outlet", "removed") if not hasattr(tsubu.Simulation, a)]
    return None if not missing else "tsubu.Simulation lacks " + ", ".join(missing) + " (issue 27)"


def build_tsubu(state: dict, threads: int = 1, divisions: int = 1):
    """The discharge scene in tsubu: the packing, the hopper mesh, the outlet (slot open)."""
    sim = new_simulation(threads, dt=state["dt"])
    mat = material()
    sim.add_spheres(state["x"], R, mat, velocities=state["v"], angular_velocities=state["w"])
    vertices, faces = hopper_mesh(divisions)
    sim.add_mesh(vertices, faces, mat)
    sim.add_outlet(point=(0.0, 0.0, Z_OUT), normal=(0.0, 0.0, 1.0))
    return sim


def run_tsubu(state: dict, steps: int, every: int, warmup: int, threads: int = 1, divisions: int = 1) -> dict:
    """One tsubu run: ``warmup`` untimed steps, then the rest timed in one ``run``."""
    sim = build_tsubu(state, threads, divisions)
    n0 = sim.size
    sim.run(steps=warmup)
    busy0, t0 = system_busy_s(), time.perf_counter()
    sim.run(steps=steps - warmup)
    loop = time.perf_counter() - t0
    busy1 = system_busy_s()
    removed = sim.removed()
    rstep = np.sort(np.asarray(removed["step"], dtype=np.int64))
    # grains present during timed step k (warmup < k <= steps): those not removed at the end of an
    # earlier step; a removal logged at step s ends that step.
    timed = np.arange(warmup + 1, steps + 1)
    present = n0 - np.searchsorted(rstep, timed, side="left")
    psteps = float(np.sum(present))
    sample = np.arange(0, steps + 1, every)
    out_by = np.searchsorted(rstep, sample, side="right")
    return {"code": "tsubu", "loop_s": loop, "steps": steps - warmup, "particle_steps": psteps,
            "rate": psteps / loop, "n0": int(n0), "n_end": int(sim.size), "threads": threads,
            "t": (sample * state["dt"]).tolist(), "discharged_kg": (out_by * MASS).tolist(),
            "others_cores": None if busy0 is None else max(0.0, (busy1 - busy0 - loop) / loop)}


# ---------------------------------------------------------------- analysis
def discharge_rate(t, m, fit_from, n0: int) -> dict:
    """Least-squares slope of the discharged mass [kg] against time [s] over the steady part:
    from ``fit_from`` s (None: FIT_DELAY after the first grain is out) to the end, or to when 2/3
    of the grains are out if earlier."""
    t, m = np.asarray(t, float), np.asarray(m, float)
    if fit_from is None:
        out = np.nonzero(m > 0)[0]
        if len(out) == 0:
            return {"rate_kg_s": float("nan"), "window_s": None, "points": 0}
        fit_from = t[max(out[0] - 1, 0)] + FIT_DELAY
    sel = (t >= fit_from) & (m <= 2.0 / 3.0 * n0 * MASS)
    if sel.sum() < 3:
        return {"rate_kg_s": float("nan"), "window_s": None, "points": int(sel.sum())}
    slope, icpt = np.polyfit(t[sel], m[sel], 1)
    return {"rate_kg_s": float(slope), "window_s": [float(t[sel][0]), float(t[sel][-1])],
            "points": int(sel.sum())}


def _child(args) -> None:
    """--child-tsubu: one tsubu run in this (fresh) process, JSON on stdout."""
    state = load_state(args.child_tsubu)
    r = run_tsubu(state, args.steps, args.every, args.warmup, threads=1, divisions=args.divisions)
    print("RESULT " + json.dumps(r))


def spawn_tsubu(args, cache: str) -> dict:
    return run_child(__file__, ["--child-tsubu", cache, "--steps", str(args.steps), "--every", str(args.every),
                                "--warmup", str(args.warmup), "--divisions", str(args.divisions)])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=N_DEFAULT, help="spheres (default 20000)")
    ap.add_argument("--steps", type=int, default=STEPS_DEFAULT, help="steps after opening (default %(default)s)")
    ap.add_argument("--every", type=int, default=500, help="discharge sampling interval, steps")
    ap.add_argument("--warmup", type=int, default=1, help="tsubu's untimed first steps")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--only", choices=("both", "liggghts", "tsubu"), default="both")
    ap.add_argument("--divisions", type=int, default=1, help="cut each quad of the mesh into k x k cells")
    ap.add_argument("--fit-from", type=float, default=None,
                    help="start of the steady part [s after opening] (default: 0.01 s after the "
                         "first grain is out)")
    ap.add_argument("--fill-threads", type=int, default=1,
                    help="threads for tsubu's filling run (default 1: on a shared 2-core machine two "
                         "threads ran it 8x slower)")
    ap.add_argument("--workdir", default=os.path.join(tempfile.gettempdir(), "tsubu-hopper-liggghts"),
                    help="where the packing is cached and the runs write (default %(default)s)")
    ap.add_argument("--fill-only", action="store_true", help="make (or find) the packing and stop")
    ap.add_argument("--json", help="write every run and the summary to this file")
    ap.add_argument("--child-tsubu", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child_tsubu:
        _child(args)
        return 0
    if args.warmup < 0 or args.warmup >= args.steps:
        ap.error("--warmup must be in [0, --steps)")

    exe = shutil.which("liggghts")
    want_l = args.only in ("both", "liggghts")
    want_t = args.only in ("both", "tsubu")
    if want_l and exe is None and not args.fill_only:
        print("liggghts is not installed (Debian: apt-get install liggghts); nothing to compare "
              "against: skipped (--only tsubu runs tsubu alone).")
        return 2
    missing = tsubu_has_mesh_api()
    if want_t and missing and not args.fill_only:
        if args.only == "tsubu":
            print(f"{missing}: cannot run tsubu's side.")
            return 2
        print(f"{missing}: running LIGGGHTS alone.")
        want_t = False

    os.makedirs(args.workdir, exist_ok=True)
    state = packing(args.n, args.workdir, threads=args.fill_threads)
    n = len(state["x"])
    key = packing_path(args.n, args.workdir)
    print(f"packing: {n} spheres, settled for {state['fill_time']:.3f} s; top at "
          f"{state['x'][:, 2].max() * 1e3:.1f} mm; dt = {state['dt']:.6e} s; mass {n * MASS * 1e3:.1f} g")
    if args.fill_only:
        return 0
    data = os.path.join(args.workdir, f"hopper_{args.n}.data")
    stl = os.path.join(args.workdir, f"hopper_k{args.divisions}.stl")
    if want_l:
        write_data(data, state)
        write_stl(stl, *hopper_mesh(args.divisions))
    info = {"machine": machine(), "n": n, "steps": args.steps, "dt": state["dt"],
            "simulated_s": args.steps * state["dt"], "triangles": len(hopper_mesh(args.divisions)[1]),
            "liggghts": liggghts_version(exe) if exe else None}
    print(f"LIGGGHTS {info['liggghts']}; {args.steps} steps = {info['simulated_s']:.4f} s after "
          f"opening; {info['triangles']} triangles; {info['machine']['cpu']}")
    fit_from = args.fit_from
    runs = []
    for rep in range(args.repeats):
        order = [c for c in ("liggghts", "tsubu") if (c == "liggghts" and want_l) or (c == "tsubu" and want_t)]
        if rep % 2:
            order.reverse()
        for code in order:
            r = (run_liggghts(exe, args.workdir, data, stl, state["dt"], args.steps, args.every, n)
                 if code == "liggghts" else spawn_tsubu(args, key))
            r["repeat"] = rep
            r.update(discharge_rate(r["t"], r["discharged_kg"], fit_from, n))
            runs.append(r)
            busy = "" if r["others_cores"] is None else f", others used {r['others_cores']:.2f} cores"
            print(f"  [{rep}] {code:8s} {r['rate'] / 1e6:7.3f} M particle-steps/s (loop {r['loop_s']:.1f} s, "
                  f"{r['n0'] - r['n_end']} grains out, {r['rate_kg_s']:.4f} kg/s{busy})", flush=True)

    summary = {}
    for code in ("liggghts", "tsubu"):
        rs = [r for r in runs if r["code"] == code]
        if rs:
            summary[code] = {"rate_median": statistics.median(r["rate"] for r in rs),
                             "discharge_kg_s_median": statistics.median(r["rate_kg_s"] for r in rs)}
    ratios = []
    for rep in range(args.repeats):
        pair = {r["code"]: r for r in runs if r["repeat"] == rep}
        if len(pair) == 2:
            ratios.append(pair["tsubu"]["rate"] / pair["liggghts"]["rate"])
    print("\ndischarged mass [g] against time after opening (first run of each code):")
    first = {c: next((r for r in runs if r["code"] == c), None) for c in ("liggghts", "tsubu")}
    first = {c: r for c, r in first.items() if r}
    print("   t [s]  " + "  ".join(f"{c:>9s}" for c in first))
    ref = next(iter(first.values()))
    stride = max(1, len(ref["t"]) // 20)
    for i in range(0, len(ref["t"]), stride):
        cells = []
        for r in first.values():
            j = int(np.argmin(np.abs(np.asarray(r["t"]) - ref["t"][i])))
            cells.append(f"{1e3 * r['discharged_kg'][j]:9.3f}")
        print(f"  {ref['t'][i]:.4f}  " + "  ".join(cells))
    for c, r in first.items():
        print(f"{c}: steady part fitted over {r['window_s']} s ({r['points']} points)")
    for code, s in summary.items():
        print(f"{code:8s}: {s['rate_median'] / 1e6:.3f} M particle-steps/s (median), "
              f"discharge {s['discharge_kg_s_median']:.4f} kg/s")
    if ratios:
        summary["ratio_median"] = statistics.median(ratios)
        summary["ratio_range"] = [min(ratios), max(ratios)]
        dl, dt_ = summary["liggghts"]["discharge_kg_s_median"], summary["tsubu"]["discharge_kg_s_median"]
        summary["discharge_rel_diff"] = (dt_ - dl) / dl
        print(f"tsubu / LIGGGHTS: {summary['ratio_median']:.2f}x (median of paired ratios, "
              f"{min(ratios):.2f}-{max(ratios):.2f}; target >= 3x: {'met' if summary['ratio_median'] >= 3 else 'not met'}); "
              f"discharge rates differ by {100 * summary['discharge_rel_diff']:+.1f} %")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"info": info, "fit_from": fit_from, "runs": runs, "summary": summary}, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

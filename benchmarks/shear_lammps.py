#!/usr/bin/env python3
"""Lees-Edwards simple shear of 10,000 frictional spheres in a periodic cell, side by side with
LAMMPS (issue 28's speed figure for periodic boxes, with the mean stress as the physics check).

The scene (SI units):

* spheres: radius 1 mm (d = 2 mm), density 2500 kg/m^3, N = 10,000 (``--n``), monodisperse;
* contact law: linear spring-dashpot, kn = 1e4 N/m, kt = 2/7 kn, restitution 0.5 (tsubu turns it
  into eta_n with m_eff = m/2), Coulomb mu = 0.5, no tangential damping, no rolling friction;
  Coulomb rule ``slip_rule="truncate"`` (LAMMPS's: the trial spring force rescaled to the cap, the
  history truncated to match); no gravity;
* the cell: a cube of side L = 20.6 d, periodic along x, y and z, solid fraction 0.6 (``--phi``),
  sheared by Lees-Edwards images: flow along x, gradient along z, rate ``RATE`` = 15 /s (``--rate``;
  the images across the z faces slide along x at RATE * L);
* time step: tsubu's default (t_c / 50 of the pair contact), neighbour skin 0.2 d in both codes.

Why that rate: the inertial number I = RATE d / sqrt(p / rho) should be ~1e-2 (the dense,
quasi-static-to-inertial crossover of mu(I), GDR MiDi 2004). The cell starts from an unjammed
packing (frictionless relaxation, below), and at a fixed solid fraction of 0.6, above the jamming
fraction of mu = 0.5 spheres (~0.58-0.59, Chialvo, Sun & Sundaresan 2012), shearing jams it: in one
LAMMPS run at 6 /s the pressure stayed below 100 Pa up to a strain of 0.09, rose from 0.1 to 20 kPa
between strains 0.1 and 0.3 and levelled off near 21 kPa (tau ~ 9 kPa, mu ~ 0.43) at 0.33-0.35. In
that shear-jammed state p is set by the stiffness (kn / (p d) ~ 240), not by the rate, so
I = 6 x 0.002 / sqrt(21000 / 2500) = 4e-3 at 6 /s, and 15 /s gives I ~ 1e-2. The start-up before
jamming (the default 4,000 steps reach a strain of 0.09) is far more inertial (I ~ 0.07 over
steps 2000-4000 at 15 /s); ``--steps 20000`` (strain 0.44) reaches the jammed state.

The initial state (the same for both codes, built once and cached in ``--workdir``):
``tsubu.fill.random_packing`` places the spheres at solid fraction 0.3 in the cube (random
sequential addition jams near 0.38), the coordinates are scaled in steps to 0.4, 0.5, 0.56 and 0.6,
and after each step a frictionless, strongly damped (restitution 0.1) tsubu run in the periodic
cube removes most of the overlaps the scaling made (frictionless spheres at 0.6 are below their
jamming fraction, ~0.64, so they find room). Positions are kept, velocities are set to the linear
shear profile u_x = RATE (z - z_centre) (tsubu's mean flow, centred on the box), spins to zero, and
there are no tangential histories. It is written for LAMMPS as a data file (``atom_style sphere``,
triclinic box of zero tilt) with every coordinate at full precision.

LAMMPS (``benchmarks/lammps/in.shear``): ``boundary p p p``, ``fix deform 1 xz erate RATE remap
v`` (the Lees-Edwards equivalent: the xz tilt grows at RATE * L_z and image velocities across z
differ by RATE * L_z), ``pair_style gran/hooke/history kn kt gamma_n 0 mu 0`` (gamma_n = eta_n /
m_eff with m_eff = m/2, the dashpot tsubu derives from e = 0.5; ``dampflag 0``: no tangential
damping), ``fix nve/sphere`` (velocity Verlet; tsubu integrates with symplectic Euler), one process
(``OMP_NUM_THREADS=1``). Stress: ``compute pressure NULL virial``, the virial part only (the contact
forces: pair gran/hooke/history tallies every pair force into LAMMPS's virial), i.e. the contact
part of the Love-Weber stress; LAMMPS's pressure tensor is P = -sigma, so p = (pxx + pyy + pzz)/3
and tau = sigma_xz = -pxz (> 0 for RATE > 0). Speed from the "Loop time of X on 1 procs for S
steps" line (it excludes reading the data file, the first neighbour list and force evaluation).

tsubu: ``sim.set_box(lower, upper, periodic="xyz")``, ``sim.set_shear(RATE, flow="x",
gradient="z")``, ``--warmup`` untimed steps (the same set-up work as LAMMPS's), then the remaining
steps timed with ``time.perf_counter`` in runs of ``--every`` steps, each followed by
``sim.stress()`` (Cauchy, tension positive, kinetic part with the mean flow removed); its contact
part, sigma + (1/V) sum_i m_i v'_i v'_i with v' = v - RATE (z - z_centre) e_x, is what is compared
with LAMMPS's virial, and the kinetic part is recorded in the JSON too. Without
``Simulation.stress`` the script says so and reports tsubu's speed only. Without
``Simulation.set_box`` (the periodic boxes of issue 28) it says so and runs LAMMPS alone.

Reported: particle-steps/s of each run (N x timed steps / loop time), medians over ``--repeats``
repetitions (each code in a fresh process, the order alternating), the median of the
per-repetition ratios tsubu / LAMMPS (the figure to quote: side by side on a shared machine), and
each code's time-averaged p, tau and mu = tau / p over the last ``--average`` fraction of the run
(default 0.5), sampled every ``--every`` steps; the two codes' means should agree within a few per
cent (same start, same law; the trajectories part slowly: different integrators).

Without ``lmp`` on the PATH (Debian: ``apt-get install lammps``) the script prints why and exits
with status 2 (``--only tsubu`` runs tsubu alone); LAMMPS is a benchmark-only tool.

Usage (from the repository root)::

    PYTHONPATH=python python benchmarks/shear_lammps.py                      # both codes, 3 repeats
    PYTHONPATH=python python benchmarks/shear_lammps.py --only lammps --repeats 1
    PYTHONPATH=python python benchmarks/shear_lammps.py --steps 2000 --json out.json
    PYTHONPATH=python python benchmarks/shear_lammps.py --fill-only          # make (cache) the packing
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
DECK = os.path.join(HERE, "lammps", "in.shear")

# ---------------------------------------------------------------- the scene (SI)
R = 1.0e-3                       # radius [m]
D = 2.0 * R                      # diameter [m]
RHO = 2500.0                     # density [kg/m^3]
KN = 1.0e4                       # normal stiffness [N/m]
KT = 2.0 / 7.0 * KN              # tangential stiffness [N/m]
E_REST = 0.5                     # restitution
MU = 0.5                         # Coulomb friction
SKIN = 0.2 * D                   # neighbour skin [m]
MASS = RHO * 4.0 / 3.0 * math.pi * R ** 3
N_DEFAULT = 10000
PHI = 0.6                        # solid fraction of the cell
RATE = 15.0                      # shear rate [1/s]: I ~ 1e-2 in the shear-jammed state (docstring)
STEPS_DEFAULT = 4000
EVERY_DEFAULT = 50
RSA_PHI = 0.3                    # random sequential addition's solid fraction (it jams near 0.38)
COMPRESSION = (0.4, 0.5, 0.56)   # intermediate solid fractions of the scaling, then ``phi``
RELAX_E = 0.1                    # restitution of the frictionless relaxation runs
RELAX_CHUNK = 500                # relaxation steps between checks
RELAX_MAX = 20                   # at most this many chunks per stage
RELAX_OVERLAP = 2.0e-3           # a stage ends when the largest overlap is below this fraction of d


def side(n: int, phi: float = PHI) -> float:
    """The cube's side [m] holding ``n`` spheres at solid fraction ``phi``."""
    return (n * 4.0 / 3.0 * math.pi * R ** 3 / phi) ** (1.0 / 3.0)


def eta(m_eff: float, k: float = KN, e: float = E_REST) -> float:
    """Normal dashpot [N s/m] for restitution e (docs/physics.md, (B.9))."""
    le = math.log(e)
    return -2.0 * le * math.sqrt(m_eff * k / (math.pi ** 2 + le * le))


def material(restitution: float = E_REST, friction: float = MU):
    import tsubu
    return tsubu.Material(density=RHO, kn=KN, kt=KT, restitution=restitution, friction=friction,
                          rolling_friction=0.0, tangential_damping=0.0, name="shear glass")


def new_simulation(threads=None, dt=None, **options):
    import tsubu
    return tsubu.Simulation(gravity=(0.0, 0.0, 0.0), dt=dt, threads=threads, skin=SKIN,
                            slip_rule="truncate", **options)


def shear_profile(x: np.ndarray, length: float, rate: float) -> np.ndarray:
    """The mean flow (N, 3) [m/s] at ``x``: u_x = rate (z - z_centre) in the cube [0, length]^3
    (tsubu's set_shear flow, centred on the box)."""
    u = np.zeros_like(np.asarray(x, dtype=float))
    u[:, 0] = rate * (x[:, 2] - 0.5 * length)
    return u


def _say(*args) -> None:
    print(*args, flush=True)


# ---------------------------------------------------------------- the initial packing (tsubu)
def make_packing(n: int, phi: float = PHI, threads=None, seed: int = 1, log=_say) -> dict:
    """Spheres at solid fraction ``phi`` in the periodic cube [0, L]^3: random sequential addition
    at RSA_PHI, then scaled in steps with frictionless damped relaxations; returns x (N, 3), L, dt
    (tsubu's default for the frictional law), the largest overlap left [m]."""
    from tsubu import fill
    l0 = side(n, RSA_PHI)
    t0 = time.perf_counter()
    x = np.array(fill.random_packing(fill.Box((0.0, 0.0, 0.0), (l0, l0, l0)), R, count=n, seed=seed).positions)
    log(f"  random packing of {n} spheres at {RSA_PHI}: {time.perf_counter() - t0:.1f} s")
    slippery = material(restitution=RELAX_E, friction=0.0)
    length, worst = l0, 0.0
    for target in [f for f in COMPRESSION if f < phi] + [phi]:
        new = side(n, target)
        x = x * (new / length)
        length = new
        sim = new_simulation(threads, initial_overlap=1.0)
        sim.add_spheres(x, R, slippery)
        sim.set_box((0.0, 0.0, 0.0), (length, length, length), periodic="xyz")
        for chunk in range(RELAX_MAX):
            sim.run(steps=RELAX_CHUNK)
            ov = np.asarray(sim.contacts()["overlap"])
            worst = float(ov.max()) if len(ov) else 0.0
            if worst < RELAX_OVERLAP * D:
                break
        x = np.array(sim.positions)
        log(f"  solid fraction {target}: largest overlap {worst / D:.2e} d after {(chunk + 1) * RELAX_CHUNK} steps, "
            f"mean speed {np.mean(np.linalg.norm(sim.velocities, axis=1)):.2e} m/s")
    sim = new_simulation(threads, initial_overlap=1.0)
    sim.add_spheres(x, R, material())
    return {"x": x, "L": float(length), "dt": float(sim.dt), "overlap": worst}


def packing_path(n: int, workdir: str, phi: float = PHI) -> str:
    """The packing's cache file: named by n and a digest of everything the packing depends on."""
    scene = repr((n, phi, R, RHO, KN, KT, E_REST, MU, SKIN, RSA_PHI, COMPRESSION, RELAX_E, RELAX_CHUNK,
                  RELAX_MAX, RELAX_OVERLAP))
    return os.path.join(workdir, f"shear_packing_n{n}_{hashlib.sha1(scene.encode()).hexdigest()[:12]}.npz")


def packing(n: int, workdir: str, phi: float = PHI, threads=None, log=_say) -> dict:
    """The packing of ``n`` spheres, from ``workdir``'s cache or made (and cached) now."""
    path = packing_path(n, workdir, phi)
    if os.path.exists(path):
        return load_state(path)
    log(f"packing {n} spheres at solid fraction {phi} (cached as {path}) ...")
    state = make_packing(n, phi, threads=threads, log=log)
    os.makedirs(workdir, exist_ok=True)  # (a caller other than main(): ab_speed.py's children)
    tmp = path + ".tmp.npz"
    np.savez_compressed(tmp, **state)
    os.replace(tmp, path)
    return state


# ---------------------------------------------------------------- LAMMPS side
def write_data(path: str, state: dict, rate: float) -> None:
    """LAMMPS data file (atom_style sphere): the periodic cube [0, L]^3 as a triclinic box of zero
    tilt, the packing at full precision, velocities on the shear profile, no spin."""
    x = state["x"]
    length = float(state["L"])
    n = len(x)
    v = shear_profile(x, length, rate)
    with open(path, "w") as fh:
        fh.write(f"LAMMPS data file: periodic shear cell, {n} spheres (benchmarks/shear_lammps.py)\n\n")
        fh.write(f"{n} atoms\n1 atom types\n\n")
        for a in "xyz":
            fh.write(f"0.0 {length!r} {a}lo {a}hi\n")
        fh.write("0.0 0.0 0.0 xy xz yz\n\nAtoms # sphere\n\n")
        ids = np.arange(1, n + 1)
        # %.17g: every double read back to the bit.
        np.savetxt(fh, np.column_stack([ids, np.ones(n), np.full(n, D), np.full(n, RHO), x]),
                   fmt=["%d", "%d"] + ["%.17g"] * 5)
        fh.write("\nVelocities\n\n")
        np.savetxt(fh, np.column_stack([ids, v, np.zeros((n, 3))]), fmt=["%d"] + ["%.17g"] * 6)


def lammps_vars(dt: float, rate: float, steps: int, every: int) -> dict:
    """The deck's -var values: tsubu's law in LAMMPS's terms (gamma_n = eta_n / m_eff, 1/s)."""
    return {"kn": repr(KN), "kt": repr(KT), "gnp": repr(eta(MASS / 2) / (MASS / 2)), "mu": repr(MU),
            "dt": repr(dt), "skin": repr(SKIN), "rate": repr(rate), "steps": str(steps),
            "every": str(every)}


def lammps_version(exe: str) -> str:
    p = subprocess.run([exe, "-h"], capture_output=True, text=True, timeout=60)
    m = re.search(r"Large-scale Atomic/Molecular Massively Parallel Simulator - (.*)", p.stdout)
    return m.group(1).strip() if m else "unknown"


def parse_lammps_log(text: str) -> tuple[dict, np.ndarray]:
    """The loop line and the thermo rows (step, time, p, pxx, pyy, pzz, pxy, pxz, pyz, xz)."""
    m = re.search(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", text)
    if m is None:
        raise ValueError("no 'Loop time' line in the LAMMPS log")
    rows = []
    block = re.split(r"^\s*Step\s+Time\s+c_pv\s", text[:m.start()], flags=re.M)[-1]
    for line in block.splitlines():
        f = line.split()
        if len(f) == 10 and f[0].isdigit():
            rows.append([float(t) for t in f])
    return ({"loop_s": float(m.group(1)), "steps": int(m.group(3)), "atoms": int(m.group(4))},
            np.array(rows, dtype=float))


def run_lammps(exe: str, workdir: str, data: str, dt: float, rate: float, steps: int, every: int) -> dict:
    """One LAMMPS run (a fresh process, one core): loop time, particle-steps, stress samples."""
    log = os.path.join(workdir, "log.shear")
    cmd = [exe, "-echo", "none", "-screen", "none", "-log", log, "-in", DECK, "-var", "data", data]
    for k, val in lammps_vars(dt, rate, steps, every).items():
        cmd += ["-var", k, val]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    busy0, t0 = system_busy_s(), time.perf_counter()
    p = subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    busy1 = system_busy_s()
    text = open(log).read() if os.path.exists(log) else ""
    if p.returncode != 0 or "Loop time" not in text:
        raise RuntimeError(f"lmp failed (exit {p.returncode}):\n{p.stdout[-2000:]}{p.stderr[-2000:]}{text[-3000:]}")
    loop, a = parse_lammps_log(text)
    # P = -sigma: p = trace(P)/3 (compression positive), tau = sigma_xz = -pxz.
    return {"code": "lammps", "loop_s": loop["loop_s"], "steps": loop["steps"], "wall_s": wall,
            "particle_steps": float(loop["atoms"]) * loop["steps"],
            "rate": float(loop["atoms"]) * loop["steps"] / loop["loop_s"],
            "step": a[:, 0].tolist(), "p": a[:, 2].tolist(), "tau": (-a[:, 7]).tolist(),
            "p_kinetic": None, "tau_kinetic": None,
            "others_cores": None if busy0 is None else max(0.0, (busy1 - busy0 - wall) / wall)}


# ---------------------------------------------------------------- tsubu side
def tsubu_missing() -> tuple[str | None, str | None]:
    """(what stops tsubu's side, what stops its stress): None when present."""
    import tsubu
    miss = [a for a in ("set_box", "set_shear") if not hasattr(tsubu.Simulation, a)]
    box = None if not miss else "tsubu.Simulation lacks " + ", ".join(miss) + " (periodic boxes, issue 28)"
    stress = None if hasattr(tsubu.Simulation, "stress") else \
        "tsubu.Simulation lacks stress() (issue 28): tsubu's speed only, no stress"
    return box, stress


def build_tsubu(state: dict, rate: float, threads: int = 1):
    """The shear scene in tsubu: the packing in the periodic cube, Lees-Edwards along x over z."""
    length = float(state["L"])
    sim = new_simulation(threads, dt=state["dt"], initial_overlap=1.0)
    sim.add_spheres(state["x"], R, material(), velocities=shear_profile(state["x"], length, rate))
    sim.set_box((0.0, 0.0, 0.0), (length, length, length), periodic="xyz")
    sim.set_shear(rate, flow="x", gradient="z")
    return sim


def kinetic_stress(sim, length: float, rate: float) -> np.ndarray:
    """-(1/V) sum_i m_i v'_i v'_i [Pa] with v' = v - u(x) (the Cauchy kinetic part tsubu's stress
    includes and LAMMPS's virial pressure leaves out)."""
    x = np.asarray(sim.positions)
    vp = np.asarray(sim.velocities) - shear_profile(x, length, rate)
    m = np.asarray(sim.masses) if hasattr(sim, "masses") else np.full(len(x), MASS)
    return -np.einsum("i,ia,ib->ab", m, vp, vp) / length ** 3


def run_tsubu(state: dict, rate: float, steps: int, every: int, warmup: int, threads: int = 1) -> dict:
    """One tsubu run: ``warmup`` untimed steps, then the rest timed in runs of ``every`` steps,
    each followed by ``sim.stress()`` when tsubu has it (the time includes it, as LAMMPS's loop
    includes its thermo output)."""
    sim = build_tsubu(state, rate, threads)
    length = float(state["L"])
    has_stress = hasattr(sim, "stress")
    n = sim.size
    sim.run(steps=warmup)
    rows = []
    loop = 0.0
    busy0 = system_busy_s()
    done = warmup
    while done < steps:
        k = min(every - done % every, steps - done)
        t0 = time.perf_counter()
        sim.run(steps=k)
        sigma = np.asarray(sim.stress()) if has_stress else None
        loop += time.perf_counter() - t0
        done += k
        if sigma is not None and done % every == 0:
            kin = kinetic_stress(sim, length, rate)
            contact = sigma - kin
            rows.append((done, -np.trace(contact) / 3.0, contact[0, 2], -np.trace(kin) / 3.0, kin[0, 2]))
    busy1 = system_busy_s()
    a = np.array(rows, dtype=float).reshape(-1, 5)
    return {"code": "tsubu", "loop_s": loop, "steps": steps - warmup, "particle_steps": float(n) * (steps - warmup),
            "rate": float(n) * (steps - warmup) / loop, "threads": threads,
            "step": a[:, 0].tolist(), "p": a[:, 1].tolist(), "tau": a[:, 2].tolist(),
            "p_kinetic": a[:, 3].tolist() if has_stress else None,
            "tau_kinetic": a[:, 4].tolist() if has_stress else None,
            "others_cores": None if busy0 is None else max(0.0, (busy1 - busy0 - loop) / loop)}


# ---------------------------------------------------------------- analysis
def mean_stress(step, p, tau, steps: int, average: float) -> dict:
    """Time averages of p and tau [Pa] over the samples in the last ``average`` fraction of the
    run (steps > (1 - average) steps), and mu = <tau> / <p>."""
    step, p, tau = (np.asarray(a, dtype=float) for a in (step, p, tau))
    sel = step > (1.0 - average) * steps
    if not sel.any():
        return {"p_mean": None, "tau_mean": None, "mu": None, "samples": 0}
    pm, tm = float(np.mean(p[sel])), float(np.mean(tau[sel]))
    return {"p_mean": pm, "tau_mean": tm, "mu": tm / pm if pm else None, "samples": int(sel.sum())}


def inertial_number(rate: float, p: float) -> float:
    """I = rate d / sqrt(p / rho)."""
    return abs(rate) * D / math.sqrt(p / RHO)


def _child(args) -> None:
    """--child-tsubu: one tsubu run in this (fresh) process, JSON on stdout."""
    state = load_state(args.child_tsubu)
    r = run_tsubu(state, args.rate, args.steps, args.every, args.warmup, threads=1)
    print("RESULT " + json.dumps(r))


def spawn_tsubu(args, cache: str) -> dict:
    return run_child(__file__, ["--child-tsubu", cache, "--steps", str(args.steps), "--every", str(args.every),
                                "--warmup", str(args.warmup), "--rate", repr(args.rate)])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=N_DEFAULT, help="spheres (default %(default)s)")
    ap.add_argument("--phi", type=float, default=PHI, help="solid fraction (default %(default)s)")
    ap.add_argument("--rate", type=float, default=RATE, help="shear rate [1/s] (default %(default)s)")
    ap.add_argument("--steps", type=int, default=STEPS_DEFAULT, help="steps (default %(default)s)")
    ap.add_argument("--every", type=int, default=EVERY_DEFAULT, help="stress sampling interval, steps")
    ap.add_argument("--average", type=float, default=0.5,
                    help="average the stress over this last fraction of the run (default %(default)s)")
    ap.add_argument("--warmup", type=int, default=1, help="tsubu's untimed first steps")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--only", choices=("both", "lammps", "tsubu"), default="both")
    ap.add_argument("--fill-threads", type=int, default=1, help="threads for making the packing")
    ap.add_argument("--workdir", default=os.path.join(tempfile.gettempdir(), "tsubu-shear-lammps"),
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
    if not 0.0 < args.average <= 1.0:
        ap.error("--average must be in (0, 1]")

    exe = shutil.which("lmp")
    want_l = args.only in ("both", "lammps")
    want_t = args.only in ("both", "tsubu")
    if want_l and exe is None and not args.fill_only:
        print("lmp is not installed (Debian: apt-get install lammps); nothing to compare against: "
              "skipped (--only tsubu runs tsubu alone).")
        return 2
    no_box, no_stress = tsubu_missing()
    if no_box and want_t:
        if args.only == "tsubu":
            print(f"{no_box}: cannot run tsubu's side.")
            return 2
        print(f"{no_box}: running LAMMPS alone.")
        want_t = False
    if no_box and not os.path.exists(packing_path(args.n, args.workdir, args.phi)):
        print(f"{no_box}: cannot make the packing (it relaxes in tsubu's periodic box).")
        return 2
    if want_t and no_stress:
        print(no_stress + ".")

    os.makedirs(args.workdir, exist_ok=True)
    state = packing(args.n, args.workdir, args.phi, threads=args.fill_threads)
    n = len(state["x"])
    key = packing_path(args.n, args.workdir, args.phi)
    print(f"packing: {n} spheres in a periodic cube of side {state['L'] * 1e3:.3f} mm "
          f"({state['L'] / D:.2f} d), solid fraction {args.phi}, largest overlap "
          f"{state['overlap'] / D:.1e} d; dt = {state['dt']:.6e} s")
    if args.fill_only:
        return 0
    data = os.path.join(args.workdir, f"shear_{args.n}.data")
    if want_l:
        write_data(data, state, args.rate)
    info = {"machine": machine(), "n": n, "steps": args.steps, "dt": state["dt"], "rate": args.rate,
            "strain": args.rate * args.steps * state["dt"], "phi": args.phi,
            "lammps": lammps_version(exe) if exe else None}
    print(f"LAMMPS {info['lammps']}; {args.steps} steps, shear rate {args.rate} /s, strain "
          f"{info['strain']:.3f}; {info['machine']['cpu']}")
    runs = []
    for rep in range(args.repeats):
        order = [c for c in ("lammps", "tsubu") if (c == "lammps" and want_l) or (c == "tsubu" and want_t)]
        if rep % 2:
            order.reverse()
        for code in order:
            r = (run_lammps(exe, args.workdir, data, state["dt"], args.rate, args.steps, args.every)
                 if code == "lammps" else spawn_tsubu(args, key))
            r["repeat"] = rep
            r.update(mean_stress(r["step"], r["p"], r["tau"], args.steps, args.average))
            runs.append(r)
            busy = "" if r["others_cores"] is None else f", others used {r['others_cores']:.2f} cores"
            stress = ("no stress" if r["p_mean"] is None else
                      f"p = {r['p_mean']:.4g} Pa, tau = {r['tau_mean']:.4g} Pa, mu = {r['mu']:.4f}, "
                      f"I = {inertial_number(args.rate, r['p_mean']):.2e}")
            print(f"  [{rep}] {code:6s} {r['rate'] / 1e6:7.3f} M particle-steps/s (loop {r['loop_s']:.1f} s; "
                  f"{stress}{busy})", flush=True)

    summary = {}
    for code in ("lammps", "tsubu"):
        rs = [r for r in runs if r["code"] == code]
        if rs:
            s = {"rate_median": statistics.median(r["rate"] for r in rs)}
            if rs[0]["p_mean"] is not None:
                for k in ("p_mean", "tau_mean", "mu"):
                    s[k + "_median"] = statistics.median(r[k] for r in rs)
                s["inertial_number"] = inertial_number(args.rate, s["p_mean_median"])
            summary[code] = s
    ratios = []
    for rep in range(args.repeats):
        pair = {r["code"]: r for r in runs if r["repeat"] == rep}
        if len(pair) == 2:
            ratios.append(pair["tsubu"]["rate"] / pair["lammps"]["rate"])
    print("\nmean stress against step (first run of each code): p [Pa], tau [Pa]")
    first = {c: next((r for r in runs if r["code"] == c and r["p"]), None) for c in ("lammps", "tsubu")}
    first = {c: r for c, r in first.items() if r}
    if first:
        print("   step  " + "  ".join(f"{c + ' p':>12s} {c + ' tau':>12s}" for c in first))
        ref = next(iter(first.values()))
        stride = max(1, len(ref["step"]) // 20)
        for i in range(0, len(ref["step"]), stride):
            cells = []
            for r in first.values():
                j = int(np.argmin(np.abs(np.asarray(r["step"]) - ref["step"][i])))
                cells.append(f"{r['p'][j]:12.5g} {r['tau'][j]:12.5g}")
            print(f"  {int(ref['step'][i]):6d} " + "  ".join(cells))
    for code, s in summary.items():
        stress = ("" if "p_mean_median" not in s else
                  f", p = {s['p_mean_median']:.4g} Pa, tau = {s['tau_mean_median']:.4g} Pa, "
                  f"mu = {s['mu_median']:.4f}, I = {s['inertial_number']:.2e}")
        print(f"{code:6s}: {s['rate_median'] / 1e6:.3f} M particle-steps/s (median){stress}")
    if ratios:
        summary["ratio_median"] = statistics.median(ratios)
        summary["ratio_range"] = [min(ratios), max(ratios)]
        line = (f"tsubu / LAMMPS: {summary['ratio_median']:.2f}x (median of paired ratios, "
                f"{min(ratios):.2f}-{max(ratios):.2f})")
        if "p_mean_median" in summary.get("tsubu", {}) and "p_mean_median" in summary.get("lammps", {}):
            rel = {k: summary["tsubu"][k + "_median"] / summary["lammps"][k + "_median"] - 1.0
                   for k in ("p_mean", "tau_mean", "mu")}
            summary["stress_rel_diff"] = rel
            line += (f"; tsubu - LAMMPS: p {100 * rel['p_mean']:+.1f} %, tau {100 * rel['tau_mean']:+.1f} %, "
                     f"mu {100 * rel['mu']:+.1f} %")
        print(line)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"info": info, "runs": runs, "summary": summary}, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The shared reference DEM scene ("lattice drop in a box", SCENE.md of the DEM benchmark
folder) built for tsubu.

Self-contained: numpy only (scipy's cKDTree is used by :func:`summary` when installed). The
numbers below reproduce ``scene.py`` of the shared benchmark folder, which defines the scene:

* monodisperse spheres, d = 1 mm, density 2500 kg/m^3;
* linear spring-dashpot contacts, kn = 1000 N/m, kt = 2/7 kn, restitution 0.5 for pair *and*
  wall contacts (tsubu turns e into eta_n with m_eff = m/2 for a pair of equal spheres and m for
  a wall: the two eta values of SCENE.md, see :func:`damping_check`), Coulomb mu = 0.5, no
  tangential damping, no rolling resistance;
* five fixed plane walls (floor z = 0, x = 0, x = Lx, y = 0, y = Ly), open top, gravity
  9.81 m/s^2 along -z;
* dt = 0.02 * 2 sqrt(m/kn) = 1.4472025091165352e-06 s, neighbour skin 0.2 d (as the LAMMPS deck);
* simple cubic lattice, spacing 1.1 d, p = i + nx (j + ny k), with the SplitMix64 velocity
  jitter v_c = 0.05 (2 u(3p + c) - 1) m/s.

Usage::

    import reference_scene as rs
    sim = rs.build(10000, threads=1)
    sim.run(steps=rs.standard_steps(10000))
    print(rs.summary(sim))

``python reference_scene.py [N]`` prints the parameters, the self-checks and the initial-state
summary.
"""

from __future__ import annotations

import math
import os

import numpy as np

# ---------------------------------------------------------------- parameters (SI)
D = 1.0e-3                     # diameter [m]
R = 0.5 * D                    # radius [m]
RHO = 2500.0                   # density [kg/m^3]
KN = 1000.0                    # normal stiffness [N/m]
KT = 2.0 / 7.0 * KN            # tangential stiffness [N/m]
E_REST = 0.5                   # restitution, pair and wall
MU = 0.5                       # Coulomb friction, pair and wall
G = 9.81                       # gravity [m/s^2] along -z
SPACING = 1.1 * D              # lattice spacing [m]
VJIT = 0.05                    # jitter amplitude [m/s]
SKIN = 0.2 * D                 # neighbour skin [m], as the LAMMPS deck ("neighbor 0.0002 bin")

MASS = RHO * 4.0 / 3.0 * math.pi * R ** 3          # 1.3089969389957471e-06 kg
INERTIA = 0.4 * MASS * R * R                        # 1.3089969389957474e-13 kg m^2
DT = 0.02 * 2.0 * math.sqrt(MASS / KN)              # 1.4472025091165352e-06 s

# SCENE.md's absolute normal damping coefficients [N s/m] (eta_n = -2 ln e sqrt(m_eff kn/(pi^2+ln^2 e)))
ETA_N_PAIR_REF = 0.011023979447380282   # m_eff = m/2
ETA_N_WALL_REF = 0.015590261245807455   # m_eff = m

SHAPES = {10000: (20, 20, 25), 100000: (50, 50, 40), 1000000: (100, 100, 100)}
STEPS = {10000: 10000, 100000: 2000}

# the published LAMMPS end state (shared bench README.md), N = 1e4 after 10,000 steps
LAMMPS_END_STATE = {10000: {"steps": 10000, "ke_total": 1.0420e-4, "mean_z": 0.0128749,
                            "pair_contacts": 975, "wall_contacts": 250}}

_M64 = np.uint64(0xFFFFFFFFFFFFFFFF)


def eta_from_e(m_eff: float, k: float = KN, e: float = E_REST) -> float:
    """Absolute normal dashpot giving restitution e (SCENE.md, tsubu docs/physics.md)."""
    le = math.log(e)
    return -2.0 * le * math.sqrt(m_eff * k / (math.pi ** 2 + le ** 2))


# ---------------------------------------------------------------- lattice and jitter
def shape(n: int) -> tuple[int, int, int]:
    """(nx, ny, nz) of the lattice for n particles. The two sizes of SCENE.md (and 1e6) are
    tabulated; otherwise nx = ny = round(n^(1/3)), nz = ceil(n / nx^2) as scene.py does (the top
    layer is then partly filled: particles p = 0..n-1 only)."""
    n = int(n)
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    if n in SHAPES:
        return SHAPES[n]
    nx = max(1, int(round(n ** (1.0 / 3.0))))
    nz = int(math.ceil(n / (nx * nx)))
    return nx, nx, nz


def box(n: int) -> tuple[float, float]:
    """(Lx, Ly) of the box for n particles."""
    nx, ny, _ = shape(n)
    return nx * SPACING, ny * SPACING


def standard_steps(n: int) -> int:
    """Steps of SCENE.md's table (1e4: 10,000; 1e5: 2,000). Other sizes: 2,000 steps for
    n >= 1e5, 10,000 below (the same simulated time as the table's nearest size)."""
    n = int(n)
    if n in STEPS:
        return STEPS[n]
    return 2000 if n >= 100000 else 10000


def splitmix64(keys: np.ndarray) -> np.ndarray:
    """Standard SplitMix64 output function of uint64 keys (arithmetic mod 2^64)."""
    with np.errstate(over="ignore"):
        z = keys.astype(np.uint64) + np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return z ^ (z >> np.uint64(31))


def unit(keys: np.ndarray) -> np.ndarray:
    """u(key) = (splitmix64(key) >> 11) * 2^-53, exact in IEEE double."""
    return (splitmix64(keys) >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)


def initial_state(n: int, start: int = 0, stop: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Positions and velocities (arrays (m, 3)) of particles p = start..stop-1 (id = p + 1)."""
    nx, ny, _ = shape(n)
    stop = n if stop is None else min(stop, n)
    p = np.arange(start, stop, dtype=np.int64)
    i = p % nx
    j = (p // nx) % ny
    k = p // (nx * ny)
    x = np.empty((len(p), 3))
    x[:, 0] = (i + 0.5) * SPACING
    x[:, 1] = (j + 0.5) * SPACING
    x[:, 2] = (k + 0.5) * SPACING
    keys = (3 * p[:, None] + np.arange(3, dtype=np.int64)[None, :]).astype(np.uint64)
    v = VJIT * (2.0 * unit(keys) - 1.0)
    return x, v


# ---------------------------------------------------------------- the tsubu scene
def material(friction: float = MU, rolling_friction: float = 0.0, roughness: float = 0.0):
    """The scene's material (spheres and walls share it; ``roughness`` in degrees)."""
    import tsubu
    rough = {"roughness": roughness} if roughness > 0 else {}
    return tsubu.Material(density=RHO, kn=KN, kt=KT, restitution=E_REST, friction=friction,
                          rolling_friction=rolling_friction, tangential_damping=0.0,
                          name="reference glass", **rough)


def build(n, threads=None, friction: float = MU, rolling_friction: float = 0.0, chunk: int = 1 << 16,
          roughness: float = 0.0, slip_rule: str = "truncate"):
    """The reference scene with n particles as a ``tsubu.Simulation`` (not yet run).

    ``threads``: OpenMP threads (None: OpenMP's default). ``friction`` / ``rolling_friction``:
    override mu / mu_r of every contact (the reference scene: 0.5 / 0). ``roughness`` (degrees):
    make the five walls rough (the reference scene: 0, smooth). ``slip_rule``: SCENE.md's
    Coulomb rule scales the trial force to the cap and truncates the history, tsubu's
    "truncate" (the default here; tsubu's own default is the notes' "frozen"). Spheres are added in
    chunks of ``chunk`` so that the Python-side temporaries stay small next to the engine's
    own storage (this matters when peak memory is measured). The scene's dimensions are kept as
    ``sim.reference_scene`` (a dict: n, shape, lx, ly).
    """
    n = int(n)
    nx, ny, nz = shape(n)
    lx, ly = box(n)
    mat = material(friction, rolling_friction)
    wall = material(friction, rolling_friction, roughness) if roughness > 0 else mat
    sim = new_simulation(threads, slip_rule)
    sim.reserve(n)
    for start in range(0, n, chunk):
        x, v = initial_state(n, start, start + chunk)
        sim.add_spheres(x, R, mat, velocities=v)
        del x, v
    add_walls(sim, lx, ly, wall)
    sim.reference_scene = {"n": n, "shape": (nx, ny, nz), "lx": lx, "ly": ly, "walls": 5}
    return sim


def new_simulation(threads=None, slip_rule: str = "truncate"):
    """An empty ``tsubu.Simulation`` with the scene's gravity, dt and skin."""
    import tsubu
    return tsubu.Simulation(gravity=(0.0, 0.0, -G), dt=DT, threads=threads, skin=SKIN,
                            slip_rule=slip_rule)


def add_walls(sim, lx: float, ly: float, wall) -> None:
    """The scene's five walls, in LAMMPS's order: floor z = 0, x = 0, x = Lx, y = 0, y = Ly."""
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=wall)   # floor
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(1.0, 0.0, 0.0), material=wall)   # x = 0
    sim.add_plane(point=(lx, 0.0, 0.0), normal=(-1.0, 0.0, 0.0), material=wall)   # x = Lx
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0), material=wall)   # y = 0
    sim.add_plane(point=(0.0, ly, 0.0), normal=(0.0, -1.0, 0.0), material=wall)   # y = Ly


# ---------------------------------------------------------------- the settled dense bed
# The N = 1e4 drop settled for 0.2 s (shared/bench/dense/bed_10000.txt, gzipped here): 21,812 pair
# contacts, mean z 9.784 mm; box Lx = Ly as the N = 1e4 drop. Its LAMMPS data file's box top:
DENSE_BED = os.path.join(os.path.dirname(os.path.abspath(__file__)), "dense", "bed_10000.txt.gz")
DENSE_ZTOP = 0.021242950938713399


def dense_bed_state(path: str = DENSE_BED) -> dict:
    """The settled bed, id order: x, v, w as (N, 3) arrays [m, m/s, rad/s]."""
    a = np.loadtxt(path, ndmin=2)
    a = a[np.argsort(a[:, 0])]
    return {"x": a[:, 1:4], "v": a[:, 4:7], "w": a[:, 7:10]}


def build_dense_bed(threads=None, floor_velocity: float = 0.0, slip_rule: str = "truncate"):
    """The dense-bed benchmark (shared/bench/README.md) as a ``tsubu.Simulation``: the settled bed,
    five walls, zero tangential history; ``floor_velocity`` > 0: the floor slides along +x at that
    speed [m/s] (dense-shear; it stays at z = 0)."""
    state = dense_bed_state()
    n = len(state["x"])
    lx, ly = box(n)
    mat = material()
    sim = new_simulation(threads, slip_rule)
    sim.add_spheres(state["x"], R, mat, velocities=state["v"], angular_velocities=state["w"])
    add_walls(sim, lx, ly, mat)
    if floor_velocity:
        sim.set_plane_motion(0, velocity=(floor_velocity, 0.0, 0.0))
    sim.reference_scene = {"n": n, "lx": lx, "ly": ly, "walls": 5, "floor_velocity": floor_velocity}
    return sim


def tiled_bed_state(tiles, path: str = DENSE_BED) -> dict:
    """The settled bed tiled ``tiles`` x ``tiles`` times in x and y (shared/bench/device/tile.py:
    copy (a, b) shifted by (a Lx, b Ly), copies in the order a, then b), as x, v, w (N, 3) arrays
    and the box's ``lx``, ``ly``. ``tiles`` may also be a pair (tiles along x, tiles along y), for
    rectangular beds (weak scaling over 2 or 8 ranks)."""
    tx, ty = (tiles, tiles) if np.ndim(tiles) == 0 else tuple(tiles)
    st = dense_bed_state(path)
    lx, ly = box(len(st["x"]))
    shift = np.array([[a * lx, b * ly, 0.0] for a in range(tx) for b in range(ty)])
    x = (st["x"][None, :, :] + shift[:, None, :]).reshape(-1, 3)
    k = tx * ty
    return {"x": x, "v": np.tile(st["v"], (k, 1)), "w": np.tile(st["w"], (k, 1)),
            "lx": tx * lx, "ly": ty * ly}


def build_tiled_bed(tiles, threads=None, floor_velocity: float = 0.05, slip_rule: str = "truncate"):
    """The tiled dense bed of shared/bench/device (issue 29's scaling scene) as a
    ``tsubu.Simulation``: ``tiles`` x ``tiles`` copies of the settled bed (tiles = 4: N = 160,000 in
    a 0.088 m x 0.088 m box; a pair: tiles along x and y), five walls around the whole, the floor
    sliding along +x at ``floor_velocity`` [m/s], zero tangential history."""
    st = tiled_bed_state(tiles)
    mat = material()
    sim = new_simulation(threads, slip_rule)
    sim.add_spheres(st["x"], R, mat, velocities=st["v"], angular_velocities=st["w"])
    add_walls(sim, st["lx"], st["ly"], mat)
    if floor_velocity:
        sim.set_plane_motion(0, velocity=(floor_velocity, 0.0, 0.0))
    sim.reference_scene = {"n": len(st["x"]), "lx": st["lx"], "ly": st["ly"], "walls": 5,
                           "floor_velocity": floor_velocity, "tiles": tiles}
    return sim


# ---------------------------------------------------------------- end-state summary
def _pairs_within(x: np.ndarray, cutoff: float) -> np.ndarray:
    """Index pairs (i < j) with |x_i - x_j| < cutoff: scipy's cKDTree if installed, else a
    numpy cell method (cells of size cutoff, 14 half-stencil offsets)."""
    try:
        from scipy.spatial import cKDTree
    except ImportError:
        cKDTree = None
    if cKDTree is not None:
        pairs = cKDTree(x).query_pairs(cutoff, output_type="ndarray")
        if len(pairs):
            d = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)
            pairs = pairs[d < cutoff]          # query_pairs is <= cutoff; the summary wants <
        return pairs.reshape(-1, 2)
    n = len(x)
    if n < 2:
        return np.zeros((0, 2), dtype=np.int64)
    lo = x.min(axis=0)
    c = np.floor((x - lo) / cutoff).astype(np.int64)
    dims = c.max(axis=0) + 3                         # one empty cell of margin each side
    c += 1
    key = (c[:, 0] * dims[1] + c[:, 1]) * dims[2] + c[:, 2]
    order = np.argsort(key, kind="stable")
    skey = key[order]
    out = []
    offsets = [(0, 0, 0)] + [(a, b, cc) for a in (-1, 0, 1) for b in (-1, 0, 1) for cc in (-1, 0, 1)
                             if (a, b, cc) > (0, 0, 0)]
    for a, b, cc in offsets:
        nkey = key + (a * dims[1] + b) * dims[2] + cc
        first = np.searchsorted(skey, nkey, side="left")
        last = np.searchsorted(skey, nkey, side="right")
        cnt = last - first
        i = np.repeat(np.arange(n), cnt)
        if len(i) == 0:
            continue
        starts = np.repeat(first - np.cumsum(cnt) + cnt, cnt)
        j = order[np.arange(len(i)) + starts]
        if (a, b, cc) == (0, 0, 0):
            keep = i < j
            i, j = i[keep], j[keep]
        d = np.linalg.norm(x[i] - x[j], axis=1)
        keep = d < cutoff
        out.append(np.stack([np.minimum(i[keep], j[keep]), np.maximum(i[keep], j[keep])], axis=1))
    return np.concatenate(out) if out else np.zeros((0, 2), dtype=np.int64)


def summary(sim, use_scipy: bool = True) -> dict:
    """End-state summaries of SCENE.md, computed from positions and velocities as
    ``scene.py analyse`` does: translational / rotational / total kinetic energy [J], mean / min /
    max z [m], pair contacts (centre distance < d), wall contacts (centre closer than R to one of
    the five walls, counted per wall), max and mean pair overlap / d, max wall overlap / d; plus
    the simulated time and step count."""
    x = np.asarray(sim.positions)
    v = np.asarray(sim.velocities)
    w = np.asarray(sim.angular_velocities)
    m = np.asarray(sim.masses)
    r = np.asarray(sim.radii)
    inertia = 0.4 * m * r * r
    ke_t = 0.5 * float(m @ (v * v).sum(axis=1))
    ke_r = 0.5 * float(inertia @ (w * w).sum(axis=1))
    info = getattr(sim, "reference_scene", None)
    if info is not None:
        lx, ly = info["lx"], info["ly"]
    else:
        lx, ly = box(len(x))
    if use_scipy:
        pairs = _pairs_within(x, D)
    else:  # force the numpy path (testing)
        import builtins
        real_import = builtins.__import__

        def no_scipy(name, *args, **kwargs):
            if name.startswith("scipy"):
                raise ImportError(name)
            return real_import(name, *args, **kwargs)
        builtins.__import__ = no_scipy
        try:
            pairs = _pairs_within(x, D)
        finally:
            builtins.__import__ = real_import
    if len(pairs):
        ov = D - np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)
        ov = ov[ov > 0]
    else:
        ov = np.zeros(0)
    wov = np.concatenate([R - x[:, 2], R - x[:, 0], x[:, 0] + R - lx, R - x[:, 1], x[:, 1] + R - ly])
    wov = wov[wov > 0]
    return {
        "n": int(len(x)), "steps": int(sim.step_count), "time": float(sim.time),
        "ke_trans": ke_t, "ke_rot": ke_r, "ke_total": ke_t + ke_r,
        "mean_z": float(x[:, 2].mean()), "min_z": float(x[:, 2].min()), "max_z": float(x[:, 2].max()),
        "pair_contacts": int(len(ov)), "wall_contacts": int(len(wov)),
        "max_pair_overlap_over_d": float(ov.max() / D) if len(ov) else 0.0,
        "mean_pair_overlap_over_d": float(ov.mean() / D) if len(ov) else 0.0,
        "max_wall_overlap_over_d": float(wov.max() / D) if len(wov) else 0.0,
    }


def compare_with_lammps(s: dict) -> dict | None:
    """Relative differences (tsubu - LAMMPS) / LAMMPS of the published end-state figures, or
    None when there are none for this size and step count."""
    ref = LAMMPS_END_STATE.get(s["n"])
    if ref is None or ref["steps"] != s["steps"]:
        return None
    return {k: (s[k] - ref[k]) / ref[k] for k in ("ke_total", "mean_z", "pair_contacts", "wall_contacts")}


# ---------------------------------------------------------------- self-checks
def damping_check() -> dict:
    """Measure the normal dashpot tsubu applies with this material, for a pair and for a wall
    contact, from the force of one step (F_n = kn delta - eta v_n), and compare with SCENE.md's
    eta values. Returns {"pair": (eta_tsubu, eta_ref), "wall": (...)}."""
    import tsubu
    mat = material()
    delta, vn = 1e-6, -0.02          # overlap [m], normal velocity (approaching) [m/s]
    out = {}
    # pair: sphere 0 at origin moving +x, sphere 1 at d - delta moving -x; n (from 1 to 0) = -x
    sim = tsubu.Simulation(gravity=(0, 0, 0), dt=DT)
    sim.add_spheres([[0, 0, 0], [D - delta, 0, 0]], R, mat,
                    velocities=[[-vn / 2, 0, 0], [vn / 2, 0, 0]])
    sim.run(steps=1)
    c = sim.contacts()
    f = np.asarray(c["force"])[0]             # force on sphere c["i"][0]
    i0 = int(np.asarray(c["i"])[0])
    nvec = np.array([-1.0, 0, 0]) if i0 == 0 else np.array([1.0, 0, 0])
    fn = float(f @ nvec)
    out["pair"] = ((KN * delta - fn) / vn, ETA_N_PAIR_REF)
    # wall: sphere above the floor, overlap delta, falling with vn
    sim = tsubu.Simulation(gravity=(0, 0, 0), dt=DT)
    sim.add_sphere((0, 0, R - delta), R, mat, velocity=(0, 0, vn))
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=mat)
    sim.run(steps=1)
    c = sim.contacts()
    fn = float(np.asarray(c["force"])[0][2])
    out["wall"] = ((KN * delta - fn) / vn, ETA_N_WALL_REF)
    return out


def self_check(verbose: bool = True) -> bool:
    """Check the derived constants, the jitter of particle id 2 and the damping against
    SCENE.md. Returns True when all agree."""
    ok = True

    def report(name, got, want, rtol):
        nonlocal ok
        good = abs(got - want) <= rtol * abs(want)
        ok &= good
        if verbose:
            print(f"  {name:<28s} {got!r:<26} SCENE.md {want!r:<26} {'ok' if good else 'MISMATCH'}")

    report("mass", MASS, 1.3089969389957471e-06, 1e-15)
    report("dt", DT, 1.4472025091165352e-06, 0)
    report("eta_n pair (formula)", eta_from_e(MASS / 2), ETA_N_PAIR_REF, 1e-14)
    report("eta_n wall (formula)", eta_from_e(MASS), ETA_N_WALL_REF, 1e-14)
    _, v = initial_state(10000, 1, 2)
    for c, want in enumerate((-0.038654965794284547, -0.0068544182255026237, -0.011323195401606602)):
        report(f"v[id 2][{'xyz'[c]}]", float(v[0, c]), want, 0)
    d = damping_check()
    report("eta_n pair (tsubu, measured)", d["pair"][0], d["pair"][1], 1e-6)
    report("eta_n wall (tsubu, measured)", d["wall"][0], d["wall"][1], 1e-6)
    return ok


if __name__ == "__main__":
    import sys
    n = int(float(sys.argv[1])) if len(sys.argv) > 1 else 10000
    print(f"reference scene N={n}: lattice {shape(n)}, box {box(n)} m, {standard_steps(n)} steps, dt={DT!r}")
    print("self-check:")
    good = self_check()
    sim = build(n)
    print("initial state:", summary(sim))
    sys.exit(0 if good else 1)

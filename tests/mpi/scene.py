"""The scene the MPI tests cut over ranks (tests/test_parallel.py runs this file under mpiexec).

A frictional Hertz-Mindlin pack in a box of planes with a tessellated mesh floor, tilted gravity
pushing it out of its open side into an outlet, a few glued spheres and one driven sphere: every
kind of state a rank's halo must carry (pair and wall contact history, mesh contacts, fixed
spheres, removals).

    python scene.py reference STEPS OUT.npz          one process, no MPI
    mpiexec -n R python scene.py decomposed STEPS OUT.npz [--save PATH] [--load PATH]

--chute: the periodic chute of build_chute instead; --shear [--fixed]: the Lees-Edwards cell
of build_shear; --threads T: T threads on every rank.
"""
import sys

import numpy as np

import tsubu
import tsubu.mesh


def build(n=500, seed=3):
    sim = tsubu.Simulation(gravity=(3.0, 0.0, -9.81), threads=1)
    m = tsubu.Material(density=2500.0, youngs_modulus=5e6, poisson_ratio=0.3, restitution=0.4,
                       friction=0.4)
    rng = np.random.default_rng(seed)
    side = 8
    g = np.stack(np.meshgrid(np.arange(side), np.arange(side), np.arange(n // 64 + 1), indexing="ij"),
                 -1).reshape(-1, 3)[:n]
    x = 0.0026 * g + np.array([0.0015, 0.0015, 0.0015]) + rng.uniform(-1e-4, 1e-4, (n, 3))
    r = rng.uniform(0.0009, 0.0011, n)
    sim.add_spheres(x, r, m, velocities=rng.normal(0.0, 0.05, (n, 3)))
    v, f = tsubu.mesh.square(center=(0.03, 0.01, 0.0), size=0.06, normal=(0, 0, 1), divisions=6,
                             jitter=0.2, seed=5)
    sim.add_mesh(v, f, m)
    sim.add_plane(point=(0, 0, 0), normal=(1, 0, 0), material=m)
    sim.add_plane(point=(0, 0, 0), normal=(0, 1, 0), material=m)
    sim.add_plane(point=(0, 0.024, 0), normal=(0, -1, 0), material=m)
    sim.add_outlet(point=(0.025, 0, 0), normal=(-1, 0, 0))
    sim.fix_spheres([0, 1, 2])
    sim.fix_spheres([9], velocity=(0.01, 0.0, 0.0))
    return sim


def build_chute(seed=4):
    """A chute: a layer periodic along x and y on a base of glued spheres, gravity tilted 24
    degrees along x; spheres cross the periodic faces and keep their contacts across them."""
    angle = np.radians(24.0)
    sim = tsubu.Simulation(gravity=(9.81 * np.sin(angle), 0.0, -9.81 * np.cos(angle)), threads=1)
    m = tsubu.Material(density=2500.0, youngs_modulus=5e6, poisson_ratio=0.3, restitution=0.4,
                       friction=0.4)
    rng = np.random.default_rng(seed)
    L = 0.02
    base = np.stack(np.meshgrid(np.arange(10), np.arange(10), indexing="ij"), -1).reshape(-1, 2)
    xb = np.column_stack([(base + 0.5) * L / 10, np.zeros(len(base))])
    sim.add_spheres(xb, 0.001, m)
    g = np.stack(np.meshgrid(np.arange(8), np.arange(8), np.arange(5), indexing="ij"), -1).reshape(-1, 3)
    x = (g + 0.5) * np.array([L / 8, L / 8, 0.0024]) + np.array([0, 0, 0.0022])
    x += rng.uniform(-1e-4, 1e-4, x.shape)
    sim.add_spheres(x, rng.uniform(0.0009, 0.0011, len(x)), m, velocities=rng.normal(0.0, 0.05, x.shape))
    sim.set_box(lower=(0, 0, -0.001), upper=(L, L, 0.03), periodic="xy")
    sim.fix_spheres(np.arange(len(base)))
    return sim


def build_shear(fixed=False, seed=5):
    """A Lees-Edwards cell: 432 frictional spheres in a box periodic along x, y and z, sheared
    at 20 /s (flow x, gradient z), no gravity; ``fixed``: two spheres glued in it as well (the
    lists then bound the motion after the fixed spheres are placed)."""
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), threads=1)
    m = tsubu.Material(density=2500.0, youngs_modulus=5e6, poisson_ratio=0.3, restitution=0.4,
                       friction=0.4)
    rng = np.random.default_rng(seed)
    n = (6, 6, 12)
    a = 0.00205
    g = np.stack(np.meshgrid(*[np.arange(k) for k in n], indexing="ij"), -1).reshape(-1, 3)
    x = (g + 0.5) * a + rng.uniform(-2.5e-5, 2.5e-5, g.shape)
    sim.add_spheres(x, rng.uniform(0.00095, 0.001, len(x)), m, velocities=rng.normal(0.0, 0.02, x.shape))
    sim.set_box(lower=(0, 0, 0), upper=tuple(np.array(n) * a), periodic="xyz")
    sim.set_shear(20.0, flow="x", gradient="z")
    if fixed:
        sim.fix_spheres([100, 300])
    return sim


def build_parts(rank=0, ranks=1, seed=6):
    """The frictional pack of build() in a box of planes, its spheres given by parts: rank k of
    `ranks` adds the k-th share (one process: all of them at once). dt, skin and impact_speed
    are set: their defaults are taken from all the spheres."""
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -9.81), threads=1, dt=4e-6, skin=4e-4, impact_speed=1.0)
    m = tsubu.Material(density=2500.0, youngs_modulus=5e6, poisson_ratio=0.3, restitution=0.4,
                       friction=0.4)
    for point, normal in (((0, 0, 0), (0, 0, 1)), ((0, 0, 0), (1, 0, 0)), ((0, 0, 0), (0, 1, 0)),
                          ((0.024, 0, 0), (-1, 0, 0)), ((0, 0.024, 0), (0, -1, 0))):
        sim.add_plane(point=point, normal=normal, material=m)
    rng = np.random.default_rng(seed)
    g = np.stack(np.meshgrid(np.arange(8), np.arange(8), np.arange(8), indexing="ij"), -1).reshape(-1, 3)
    x = 0.0026 * g + 0.0015 + rng.uniform(-1e-4, 1e-4, g.shape)
    r = rng.uniform(0.0009, 0.0011, len(x))
    v = rng.normal(0.0, 0.05, x.shape)
    share = np.array_split(np.arange(len(x)), ranks)[rank]
    return sim, (x[share], r[share], m, v[share])


def build_pour():
    """build_parts's box with its first 200 spheres, and an inserter pouring more from above."""
    import tsubu.fill

    sim, (x, r, m, v) = build_parts()
    sim.add_spheres(x[:200], r[:200], m, velocities=v[:200])
    sim.add_inserter(tsubu.fill.Box((0.002, 0.002, 0.03), (0.022, 0.022, 0.038)), rate=20000.0,
                     sizes=0.001, material=m, velocity=(0.0, 0.0, -0.5), seed=3)
    return sim


def record(sim, path):
    c = sim.contacts()
    gone = sim.removed()
    extra = {"images": sim.images} if sim.box is not None else {}
    if sim.inserters:
        extra["inserted"] = [i.inserted for i in sim.inserters]
        extra["inserted_mass"] = [i.inserted_mass for i in sim.inserters]
    np.savez(path, **extra, removed_id=gone["id"], removed_step=gone["step"], removed_x=gone["position"], ids=sim.ids, x=sim.positions, v=sim.velocities, w=sim.angular_velocities,
             forces=sim.forces, dissipated=sim._core.dissipated(), step=sim.step_count,
             ci=c["i"], cj=c["j"], cwall=c["wall"], cxi=c["tangential_displacement"], cf=c["force"])


VOLUME = 0.03 * 0.024 * 0.02  # (a volume for the stress: any will do to compare)


def record_sums(energy, stress, brackets, path):
    np.savez(path, **{"energy_" + k: v for k, v in energy.items()}, stress=stress, brackets=brackets)


def main(argv):
    mode, steps, out = argv[0], int(argv[1]), argv[2]
    rest = argv[3:]
    save = rest[rest.index("--save") + 1] if "--save" in rest else None
    load = rest[rest.index("--load") + 1] if "--load" in rest else None
    if mode == "differ":  # each rank a scene of its own: decompose must refuse it
        from mpi4py import MPI

        from tsubu import parallel

        try:
            parallel.decompose(build(seed=MPI.COMM_WORLD.Get_rank()))
        except ValueError as e:
            print("refused:", e)
        return
    sim = (tsubu.Simulation.load(load) if load else build_chute() if "--chute" in rest
           else build_shear("--fixed" in rest) if "--shear" in rest
           else build_pour() if "--pour" in rest else build())
    if "--threads" in rest:  # (threads per rank; the scene is too small to use them: forced)
        sim._core.threads = int(rest[rest.index("--threads") + 1])
        sim._core.parallel_min = 1
    if "--parts" in rest:  # the spheres added by parts, after decompose (one process: at once)
        rank, ranks = 0, 1
        if mode != "reference":
            from mpi4py import MPI
            rank, ranks = MPI.COMM_WORLD.Get_rank(), MPI.COMM_WORLD.Get_size()
        sim, (x, r, m, v) = build_parts(rank, ranks)
        if mode == "reference":
            sim.add_spheres(x, r, m, velocities=v)
        else:
            from tsubu import parallel

            d = parallel.decompose(sim)
            d.add_spheres(x, r, m, velocities=v)
            d.run(steps)
            whole = d.gather()
            if whole is not None:
                record(whole, out)
                print("redistributions", d.redistributions, "balances", d.balances, "owned",
                      MPI.COMM_WORLD.gather(len(d.owned)))
            else:
                MPI.COMM_WORLD.gather(len(d.owned))
            return
    if mode == "reference":
        sim.run(steps)
        record(sim, out)
        record_sums(sim.energy(), sim.stress(VOLUME), sim.stress(per_particle=True), out + ".sums.npz")
        return
    from mpi4py import MPI

    from tsubu import parallel

    d = parallel.decompose(sim)
    d.run(steps)
    # The reductions, without gathering: the same on every rank.
    sums = (d.energy(), d.stress(VOLUME), d.stress(per_particle=True))
    every = MPI.COMM_WORLD.gather(sums)
    whole = d.gather()
    sizes = MPI.COMM_WORLD.gather(len(d.owned))
    if whole is not None:
        assert sum(sizes) == whole.size, (sizes, whole.size)
        record(whole, out)
        for e, st, b in every[1:]:
            assert e == every[0][0] and np.array_equal(st, every[0][1]) and np.array_equal(b, every[0][2])
        record_sums(*sums, out + ".sums.npz")
        if save:
            whole.save(save)
        print("redistributions", d.redistributions, "balances", d.balances, "owned", sizes)


if __name__ == "__main__":
    main(sys.argv[1:])

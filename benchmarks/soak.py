"""Soak: a settled pack run for a million steps stays bounded, in energy and in memory.

Two scenes (``--scene``):

* ``fixed`` (default): a pack of glass beads (the reference material: kn = 1000 N/m, e = 0.5,
  mu = 0.5) is dropped into a box of five walls and settled; then it runs 1e6 more steps at the
  same dt, and the script reports what must not happen in a settled pack: energy creeping up,
  spheres sinking through the floor or walls, overlaps growing.
* ``moving``: the same box, but the beads have rolling friction and the floor is rough (a
  random tilt of the contact normal) and slides in its own plane, to and fro along x (it
  reverses every ``--reverse`` steps). A moving wall does work, so the mechanical energy is not
  conserved; the closed balance is: the change of (kinetic + gravitational + elastic +
  dissipated) equals the work the floor did, sum over steps of dt F.U (F the force of the floor
  on the beads, U its velocity: a wall sliding in its own plane has the same velocity at every
  point, and exerts no work through its rolling-friction couple because it does not rotate).
  The script steps one step at a time to sum that work exactly, and reports the balance's
  residual against the dissipation booked meanwhile (energy from nowhere would show as a
  residual that grows faster than the dissipation).

Both scenes sample the process's resident memory (/proc/self/statm) and the engine's own arrays
(``Simulation.memory_bytes()``) at 50 points of the run and report first / last / largest: a
leak would show as growth.

    python benchmarks/soak.py                        # 512 beads, 1e6 steps (a few minutes)
    python benchmarks/soak.py --scene moving         # moving rough floor, rolling friction
    python benchmarks/soak.py --steps 20000          # a short run
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

import tsubu

D = 1e-3
R = D / 2


def settled_pack(nx: int, nz: int, threads: int | None, *, rolling_friction: float = 0.0,
                 floor_roughness: float = 0.0):
    glass = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5,
                           rolling_friction=rolling_friction)
    floor = glass
    if floor_roughness > 0:
        floor = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5,
                               rolling_friction=rolling_friction, roughness=floor_roughness)
    a = 1.1 * D
    m = 2500.0 * np.pi / 6 * D**3
    sim = tsubu.Simulation(gravity=(0, 0, -9.81), dt=0.02 * 2 * np.sqrt(m / 1e3), threads=threads)
    i, j, k = np.meshgrid(np.arange(nx), np.arange(nx), np.arange(nz), indexing="ij")
    x = (np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1) + 0.5) * a
    sim.add_spheres(x, R, glass, velocities=np.random.default_rng(1).uniform(-0.05, 0.05, x.shape))
    side = nx * a
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=floor)   # wall 0: the floor
    walls = [((0, 0, 0), (1, 0, 0)), ((side, 0, 0), (-1, 0, 0)),
             ((0, 0, 0), (0, 1, 0)), ((0, side, 0), (0, -1, 0))]
    for point, normal in walls:
        sim.add_plane(point=point, normal=normal, material=glass)
    sim.run(time=0.15)
    return sim, side


_PAGE = os.sysconf("SC_PAGE_SIZE")


def rss_bytes() -> int:
    """The process's resident memory now (second field of /proc/self/statm)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * _PAGE


class MemoryLog:
    """Resident memory and the engine's own bytes at sample points."""

    def __init__(self):
        self.rss: list[int] = []
        self.engine: list[int] = []

    def sample(self, sim) -> None:
        self.rss.append(rss_bytes())
        self.engine.append(sum(sim.memory_bytes().values()))

    def report(self) -> bool:
        mib = 2.0**20
        for name, v in (("process resident memory", self.rss), ("engine arrays (memory_bytes)", self.engine)):
            print(f"{name}: first {v[0] / mib:.2f} MiB, last {v[-1] / mib:.2f} MiB, largest "
                  f"{max(v) / mib:.2f} MiB, last - first {(v[-1] - v[0]) / 1024:+.0f} KiB "
                  f"({len(v)} samples)")
        # Flat: no growth over the second half of the run (the first samples see the allocator
        # and the lists reach their working capacity); a leak grows linearly with the steps.
        mid = len(self.rss) // 2
        print(f"growth over the second half: resident {(self.rss[-1] - self.rss[mid]) / 1024:+.0f} KiB, "
              f"engine arrays {(self.engine[-1] - self.engine[mid]) / 1024:+.0f} KiB")
        return (self.rss[-1] - self.rss[mid] < 2**20
                and max(self.engine[mid:]) <= 1.05 * max(self.engine[:mid + 1]))


def soak_fixed(args) -> bool:
    sim, side = settled_pack(args.nx, args.nz, args.threads)
    e0 = sim.energy()
    base = e0["total"]
    drop = abs(e0["gravitational"])  # scale: the potential energy of the pack above the floor
    print(f"{sim.size} beads settled for {sim.time:.3f} s ({sim.step_count} steps); kinetic energy "
          f"{e0['kinetic']:.3e} J; now {args.steps} more steps of dt = {sim.dt:.4g} s")
    chunk = max(1, args.steps // 50)
    ke_max, creep_max, overlap_max, lowest, outside = 0.0, 0.0, 0.0, np.inf, 0
    memory = MemoryLog()
    memory.sample(sim)
    start = time.perf_counter()
    done = 0
    while done < args.steps:
        k = min(chunk, args.steps - done)
        sim.run(steps=k)
        done += k
        e = sim.energy()
        x = sim.positions
        ke_max = max(ke_max, e["kinetic"])
        creep_max = max(creep_max, (e["total"] - base) / drop)  # may only fall: dissipation
        c = sim.contacts()
        if len(c["overlap"]):
            overlap_max = max(overlap_max, float(c["overlap"].max()) / R)
        lowest = min(lowest, float(x[:, 2].min()))
        outside += int(np.sum((x[:, 0] < 0) | (x[:, 0] > side) | (x[:, 1] < 0) | (x[:, 1] > side) | (x[:, 2] < 0)))
        memory.sample(sim)
    wall = time.perf_counter() - start
    e = sim.energy()
    print(f"ran {done} steps ({sim.size * done / wall / 1e6:.1f} M particle-steps/s, {wall:.1f} s)")
    print(f"kinetic energy: start {e0['kinetic']:.3e} J, largest {ke_max:.3e} J, end {e['kinetic']:.3e} J")
    print(f"energy creep: largest rise of the mechanical energy (kinetic + gravitational + elastic) "
          f"over its start, relative to |gravitational energy|: {creep_max:.2e}")
    print(f"largest overlap {overlap_max:.4f} r; lowest centre {lowest / R:.4f} r above the floor; "
          f"centres outside the box at any sample: {outside}")
    flat = memory.report()
    return outside == 0 and lowest > 0 and overlap_max < 0.05 and creep_max < 1e-6 and flat


def soak_moving(args) -> bool:
    sim, side = settled_pack(args.nx, args.nz, args.threads, rolling_friction=args.rolling_friction,
                             floor_roughness=args.roughness)
    floor = 0
    sim.dt = sim.dt * args.dt_scale
    print(f"{sim.size} beads settled for {sim.time:.3f} s ({sim.step_count} steps), law {sim.law}; "
          f"now {args.steps} more steps of dt = {sim.dt:.4g} s with the floor (roughness "
          f"{args.roughness} deg) sliding at +-{args.speed} m/s along x, reversing every "
          f"{args.reverse} steps; rolling friction {args.rolling_friction}")
    dt = sim.dt
    e0 = sim.energy()
    balance0 = e0["total"] + e0["dissipated"]
    work = 0.0                 # work of the floor on the beads since the start [J]
    samples = []               # (step, work, dissipated since start, residual, kinetic)
    sample_every = max(1, args.steps // 50)
    memory = MemoryLog()
    memory.sample(sim)
    overlap_max, lowest, outside = 0.0, np.inf, 0
    velocity = np.array([args.speed, 0.0, 0.0])
    start = time.perf_counter()
    for step in range(args.steps):
        if step % args.reverse == 0:
            velocity = -velocity if step else velocity
            sim.set_plane_motion(floor, velocity=velocity)
        sim.run(steps=1)
        c = sim.contacts()   # the forces of the force evaluation this step used
        on_floor = c["wall"] == floor
        work += dt * float(c["force"][on_floor].sum(axis=0) @ velocity)
        if (step + 1) % sample_every == 0 or step + 1 == args.steps:
            e = sim.energy()
            residual = e["total"] + e["dissipated"] - balance0 - work
            samples.append((step + 1, work, e["dissipated"] - e0["dissipated"], residual, e["kinetic"]))
            x = sim.positions
            if len(c["overlap"]):
                overlap_max = max(overlap_max, float(c["overlap"].max()) / R)
            lowest = min(lowest, float(x[:, 2].min()))
            outside += int(np.sum((x[:, 0] < 0) | (x[:, 0] > side) | (x[:, 1] < 0) | (x[:, 1] > side) | (x[:, 2] < 0)))
            memory.sample(sim)
    wall = time.perf_counter() - start
    s = np.array(samples)
    steps_s, work_s, diss_s, res_s, ke_s = s.T
    print(f"ran {args.steps} steps one at a time ({wall:.1f} s, {wall / args.steps * 1e6:.0f} us per step "
          f"with the work sum); rebuilds {sim.rebuild_count}")
    print(f"kinetic energy: start {e0['kinetic']:.3e} J, largest {ke_s.max():.3e} J, end {ke_s[-1]:.3e} J")
    print(f"work of the floor {work_s[-1]:.4e} J; dissipated meanwhile {diss_s[-1]:.4e} J; "
          f"change of kinetic + gravitational + elastic {work_s[-1] - diss_s[-1] + res_s[-1]:.3e} J")
    ratio = res_s / np.maximum(diss_s, 1e-300)
    half = len(s) // 2
    print(f"energy balance residual (total + dissipated - start - work): end {res_s[-1]:.3e} J = "
          f"{ratio[-1]:.2e} of the dissipation; largest |residual| / dissipation over the samples "
          f"{np.abs(ratio[1:]).max():.2e}; residual / dissipation in the first half {ratio[half - 1]:.2e}, "
          f"at the end {ratio[-1]:.2e}")
    print(f"largest overlap {overlap_max:.4f} r; lowest centre {lowest / R:.4f} r above the floor; "
          f"centres outside the box at any sample: {outside}")
    flat = memory.report()
    # The stated bound: tsubu's own balance check (docs/physics.md) allows a residual of half the
    # dissipation; a stable run's first-order booking error is a few per cent of it. Creep would
    # be the residual growing faster than the dissipation: its ratio at the end must not exceed
    # twice the ratio at half-way (plus a small margin for a ratio near zero).
    bounded = abs(ratio[-1]) < 0.5 and abs(ratio[-1]) <= 2 * abs(ratio[half - 1]) + 0.01
    return outside == 0 and lowest > 0 and overlap_max < 0.05 and bounded and flat


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", choices=("fixed", "moving"), default="fixed")
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--nx", type=int, default=8)
    ap.add_argument("--nz", type=int, default=8)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--speed", type=float, default=0.02, help="moving: floor speed [m/s]")
    ap.add_argument("--reverse", type=int, default=100_000, help="moving: steps between reversals")
    ap.add_argument("--roughness", type=float, default=10.0, help="moving: floor roughness [deg]")
    ap.add_argument("--rolling-friction", type=float, default=0.05, help="moving: rolling friction")
    ap.add_argument("--dt-scale", type=float, default=1.0,
                    help="moving: dt after settling, relative to the settling dt (the balance "
                         "residual is first order in dt: halving dt halves it)")
    args = ap.parse_args(argv)
    ok = soak_fixed(args) if args.scene == "fixed" else soak_moving(args)
    print("bounded" if ok else "NOT BOUNDED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())

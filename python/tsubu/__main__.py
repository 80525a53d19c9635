"""Command line: ``tsubu run scene.toml`` runs a scene file (docs/scene-format.md);
``tsubu resume CHECKPOINT`` continues a scene run from its checkpoint; ``tsubu demo`` runs a small
embedded scene and prints what it simulated; ``tsubu info`` prints the build's capabilities.

Exit status: 0 on success, 2 for a bad scene file, key or value, or a checkpoint that cannot be
resumed (one line each: ``tsubu: error: <file>: <path> = <value>: <what is wrong>``), 1 for a run
that went unstable, 130 after Ctrl-C."""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from . import __version__, openmp
from .material import Material
from .simulation import Simulation


def lattice_drop(nx: int = 10, nz: int = 20, threads: int | None = None, seed: int = 1) -> Simulation:
    """Glass beads (d = 1 mm) on a jittered cubic lattice in a box of five walls, as the shared
    reference scene: they fall, collide and settle on the floor."""
    d = 1.0e-3
    a = 1.1 * d
    glass = Material(density=2500.0, kn=1.0e3, restitution=0.5, friction=0.5)
    sim = Simulation(gravity=(0.0, 0.0, -9.81), threads=threads, dt=0.02 * 2.0 * np.sqrt(
        2500.0 * np.pi / 6.0 * d**3 / 1.0e3))
    i, j, k = np.meshgrid(np.arange(nx), np.arange(nx), np.arange(nz), indexing="ij")
    pos = (np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1) + 0.5) * a
    rng = np.random.default_rng(seed)
    vel = rng.uniform(-0.05, 0.05, size=pos.shape)
    sim.add_spheres(pos, d / 2, glass, velocities=vel)
    length = nx * a
    for point, normal in [((0, 0, 0), (0, 0, 1)), ((0, 0, 0), (1, 0, 0)), ((length, 0, 0), (-1, 0, 0)),
                          ((0, 0, 0), (0, 1, 0)), ((0, length, 0), (0, -1, 0))]:
        sim.add_plane(point=point, normal=normal, material=glass)
    return sim


def demo(args: argparse.Namespace) -> int:
    sim = lattice_drop(nx=args.nx, nz=args.nz, threads=args.threads)
    n = sim.size
    e0 = sim.energy()
    z0 = sim.positions[:, 2].mean()
    print(f"tsubu {__version__} demo: {n} glass beads (d = 1 mm, e = 0.5, mu = 0.5) dropped "
          f"into a {args.nx * 1.1:.1f} mm square box")
    print(f"  contact law: {sim.law}; dt = {sim.dt:.4g} s = t_c/{sim.contact_duration() / sim.dt:.1f}; "
          f"stability bound {sim.critical_time_step():.4g} s")
    start = time.perf_counter()
    sim.run(time=args.time, progress=args.progress)
    wall = time.perf_counter() - start
    e = sim.energy()
    z = sim.positions[:, 2]
    c = sim.contacts()
    pairs = int(np.sum(c["wall"] < 0))
    walls = int(np.sum(c["wall"] >= 0))
    print(f"  simulated {sim.time * 1e3:.2f} ms in {sim.step_count} steps, {wall:.2f} s wall time "
          f"({n * sim.step_count / wall / 1e6:.1f} M particle-steps/s on {sim.threads_used} thread(s))")
    print(f"  mean height {z.mean() * 1e3:.3f} mm (started at {z0 * 1e3:.3f} mm), "
          f"lowest centre {z.min() * 1e3:.4f} mm")
    print(f"  contacts: {pairs} sphere-sphere, {walls} sphere-wall; max overlap "
          f"{(c['overlap'].max() / 1e-3 if len(c['overlap']) else 0):.2e} d")
    print(f"  energy [J]: kinetic {e['kinetic']:.3e}, elastic {e['elastic']:.3e}, "
          f"dissipated {e['dissipated']:.3e}")
    balance = (e["total"] + e["dissipated"] - e0["total"]) / abs(e0["total"])
    print(f"  energy balance (total + dissipated - initial) / initial = {balance:.2e}")
    return 0


def info(_: argparse.Namespace) -> int:
    print(f"tsubu {__version__}; OpenMP: {'yes' if openmp else 'no (single-threaded)'}; "
          f"python {sys.version.split()[0]}")
    return 0


def _execute(scene, source: str, what: str, until: float | None, progress: bool | None) -> int:
    from .simulation import InstabilityError
    steps_before = scene.simulation.step_count
    start = time.perf_counter()
    try:
        scene.run(until=until, progress=progress)
    except InstabilityError as e:
        print(f"tsubu: error: {source}: the run went unstable: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        sim = scene.simulation
        saved = f"; checkpoint in {scene.checkpoint['path']}" if scene.checkpoint is not None else ""
        print(f"\ntsubu: interrupted at t = {sim.time:.6g} s (step {sim.step_count}){saved}",
              file=sys.stderr)
        return 130
    wall = time.perf_counter() - start
    sim = scene.simulation
    steps = sim.step_count - steps_before
    rate = sim.size * steps / max(wall, 1e-9)
    print(f"tsubu {what} {source}: {sim.size} spheres, t = {sim.time:.6g} s (step {sim.step_count}), "
          f"{steps} steps in {wall:.2f} s ({rate / 1e6:.2f} M particle-steps/s)")
    if scene.output or scene.checkpoint is not None:
        print(f"  output in {scene.output_directory}")
    return 0


def _scene_error(e) -> int:
    for line in e.lines():
        print(f"tsubu: error: {line}", file=sys.stderr)
    return 2


def run(args: argparse.Namespace) -> int:
    from .scene import SceneError, load_scene
    try:
        scene = load_scene(args.scene, threads=args.threads, output_directory=args.output)
    except SceneError as e:
        return _scene_error(e)
    return _execute(scene, args.scene, "run", None, False if args.no_progress else None)


def resume(args: argparse.Namespace) -> int:
    from .scene import SceneError, resume as resume_scene
    try:
        scene = resume_scene(args.checkpoint, threads=args.threads, output_directory=args.output)
    except SceneError as e:
        return _scene_error(e)
    except OSError as e:
        print(f"tsubu: error: {args.checkpoint}: cannot read the checkpoint: {e.strerror or e}",
              file=sys.stderr)
        return 2
    except ValueError as e:  # Simulation.load: a truncated, corrupted, foreign or newer file
        text = str(e)  # CheckpointError's message starts with the path already
        where = "" if text.startswith(f"{args.checkpoint}: ") else f"{args.checkpoint}: "
        print(f"tsubu: error: {where}{text}", file=sys.stderr)
        return 2
    until = None
    if args.time is not None:
        until = scene.simulation.time + args.time
    elif args.until is not None:
        until = args.until
    return _execute(scene, args.checkpoint, "resume", until, False if args.no_progress else None)


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds, got {text!r}") from None
    if not (value >= 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds >= 0, got {text!r}")
    return value


def _threads(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text!r}")
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="tsubu", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("demo", help="drop a few thousand beads into a box and report")
    p.add_argument("--nx", type=int, default=10, help="beads along x and y (default 10)")
    p.add_argument("--nz", type=int, default=20, help="layers (default 20)")
    p.add_argument("--time", type=float, default=0.03, help="simulated time in s (default 0.03)")
    p.add_argument("--threads", type=int, default=None, help="OpenMP threads (default: all)")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="show a progress bar (default: only on an interactive terminal)")
    p.set_defaults(func=demo)
    sub.add_parser("info", help="print version and build capabilities").set_defaults(func=info)
    p = sub.add_parser("run", help="run a scene file (TOML; docs/scene-format.md)")
    p.add_argument("scene", help="the scene file")
    p.add_argument("--threads", type=_threads, default=None,
                   help="OpenMP threads (default: the scene's simulation.threads, else all cores)")
    p.add_argument("--output", default=None, metavar="DIR",
                   help="directory for output and checkpoints (default: the scene's output.directory)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)
    p = sub.add_parser("resume", help="continue a scene run from its checkpoint")
    p.add_argument("checkpoint", help="a checkpoint written by tsubu run")
    when = p.add_mutually_exclusive_group()
    when.add_argument("--time", type=_seconds, default=None, metavar="T",
                      help="run T more seconds of simulated time")
    when.add_argument("--until", type=_seconds, default=None, metavar="T",
                      help="run until simulated time T (default: the scene's end)")
    p.add_argument("--threads", type=_threads, default=None, help="OpenMP threads")
    p.add_argument("--output", default=None, metavar="DIR",
                   help="directory for output and checkpoints (default: the run's)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=resume)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())

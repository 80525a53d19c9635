"""Command line: ``tsubu run scene.toml`` runs a scene file (docs/scene-format.md);
``tsubu resume CHECKPOINT`` continues a scene run from its checkpoint; ``tsubu demo`` runs a small
embedded scene and prints what it simulated; ``tsubu info`` prints the build's capabilities.

Exit status: 0 on success; 2 for a bad command-line option, a bad scene file, key or value, a
scene that tsubu refuses to run (spheres overlapping, a time step above the stability bound), an
output directory or file that cannot be written, or a checkpoint that cannot be resumed (one line
each: ``tsubu: error: <file>: <path> = <value>: <what is wrong>``); 1 for a run that went
unstable; 130 after Ctrl-C."""

from __future__ import annotations

import argparse
import os
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
          f"({n * sim.step_count / wall / 1e6:.1f} M particle-steps/s {_threads_text(sim, args.threads)})")
    print(f"  mean height {z.mean() * 1e3:.3f} mm (started at {z0 * 1e3:.3f} mm), "
          f"lowest centre {z.min() * 1e3:.4f} mm")
    print(f"  contacts: {pairs} sphere-sphere, {walls} sphere-wall; max overlap "
          f"{(c['overlap'].max() / 1e-3 if len(c['overlap']) else 0):.2e} d")
    print(f"  energy [J]: kinetic {e['kinetic']:.3e}, elastic {e['elastic']:.3e}, "
          f"dissipated {e['dissipated']:.3e}")
    balance = (e["total"] + e["dissipated"] - e0["total"]) / abs(e0["total"])
    print(f"  energy balance (total + dissipated - initial) / initial = {balance:.2e}")
    return 0


def _threads_text(sim: Simulation, asked: int | None) -> str:
    """"on N threads", and why a run on one thread used no more than that."""
    used = sim.threads_used
    text = f"on {used} thread" + ("s" if used != 1 else "")
    if used != 1 or asked == 1:
        return text
    if not openmp:
        return text + ": this build has no OpenMP"
    if sim.size < sim.parallel_min:
        return (text + f": {sim.size} beads are below parallel_min = {sim.parallel_min}, under "
                "which a scene runs on one thread (--nx, --nz for more beads)")
    return text


def info(_: argparse.Namespace) -> int:
    print(f"tsubu {__version__}; OpenMP: {'yes' if openmp else 'no (single-threaded)'}; "
          f"python {sys.version.split()[0]}")
    return 0


def _execute(scene, source: str, what: str, until: float | None, progress: bool | None,
             output_option: str) -> int:
    """Run ``scene`` and report; ``output_option`` names where its output directory came from
    (``--output`` or the scene's key), for the message when it cannot be written."""
    from .simulation import InstabilityError
    sim = scene.simulation
    problem = _output_problem(scene)
    if problem is not None:
        print(f"tsubu: error: {source}: {output_option} = {scene.output_directory}: {problem}",
              file=sys.stderr)
        return 2
    steps_before = sim.step_count
    start = time.perf_counter()
    try:
        scene.run(until=until, progress=progress)
    except InstabilityError as e:
        print(f"tsubu: error: {source}: the run went unstable: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        saved = f"; checkpoint in {scene.checkpoint['path']}" if scene.checkpoint is not None else ""
        print(f"\ntsubu: interrupted at t = {sim.time:.6g} s (step {sim.step_count}){saved}",
              file=sys.stderr)
        return 130
    except OSError as e:  # output or a checkpoint that cannot be written
        print(f"tsubu: error: {source}: cannot write the output: {_os_error(e)}", file=sys.stderr)
        return 2
    except (ValueError, TypeError) as e:  # what the library refuses in the scene as built
        when = ("the scene cannot start" if sim.step_count == steps_before
                else f"the run stopped at t = {sim.time:.6g} s (step {sim.step_count})")
        print(f"tsubu: error: {source}: {when}: {_one_line(e)}", file=sys.stderr)
        return 2
    wall = time.perf_counter() - start
    from .parallel import launched_rank, launched_ranks
    if launched_rank() != 0:
        return 0  # (rank 0 reports a run over MPI ranks)
    sim = scene.simulation  # (after a run over ranks, rank 0's is the whole scene gathered)
    ranks = launched_ranks()
    steps = sim.step_count - steps_before
    rate = sim.size * steps / max(wall, 1e-9)
    print(f"tsubu {what} {source}: {sim.size} spheres, t = {sim.time:.6g} s (step {sim.step_count}), "
          f"{steps} steps in {wall:.2f} s ({rate / 1e6:.2f} M particle-steps/s"
          + (f" on {ranks} MPI ranks)" if ranks > 1 else ")"))
    if scene.output or scene.checkpoint is not None:
        print(f"  output in {scene.output_directory}")
    return 0


def _output_problem(scene) -> str | None:
    """Why the output directory of ``scene`` cannot be written, or None (it is created when
    missing, as the run would create it): checked before the run, not at its end."""
    if not scene.output and scene.checkpoint is None:
        return None
    directory = scene.output_directory
    try:
        os.makedirs(directory, exist_ok=True)
    except FileExistsError:
        return "not a directory (a file of that name exists)"
    except OSError as e:
        return f"cannot create the directory: {e.strerror or e}"
    if not os.access(directory, os.W_OK | os.X_OK):
        return "cannot write into the directory (permission denied)"
    return None


def _os_error(e: OSError) -> str:
    """An OSError in one line: the file it names, then what went wrong."""
    text = e.strerror or str(e)
    return f"{e.filename}: {text}" if e.filename else text


def _one_line(e: Exception) -> str:
    return " ".join(str(e).split()) or type(e).__name__


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
    where = "--output" if args.output is not None else "output.directory"
    return _execute(scene, args.scene, "run", None, False if args.no_progress else None, where)


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
    where = "--output" if args.output is not None else "output directory"
    return _execute(scene, args.checkpoint, "resume", until, False if args.no_progress else None, where)


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds, got {text!r}") from None
    if not (value >= 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds >= 0, got {text!r}")
    return value


def _threads(text: str) -> int:
    """--threads: an integer in the range Simulation's ``threads`` accepts (checked here, so that
    a bad value is reported as the option's, not as the scene's ``simulation.threads``)."""
    from ._options import DECLARATIONS
    most = DECLARATIONS["threads"].maximum
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if not 1 <= value <= most:
        raise argparse.ArgumentTypeError(f"must be an integer from 1 to {most}, got {text!r}")
    return value


def _count(text: str) -> int:
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
    p.add_argument("--nx", type=_count, default=10, help="beads along x and y (default 10)")
    p.add_argument("--nz", type=_count, default=20, help="layers (default 20)")
    p.add_argument("--time", type=_seconds, default=0.03, help="simulated time in s (default 0.03)")
    p.add_argument("--threads", type=_threads, default=None,
                   help="OpenMP threads (default: all; a scene below the Simulation's "
                        "parallel_min beads runs on one)")
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

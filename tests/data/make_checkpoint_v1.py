"""Writes tests/data/checkpoint_v1.tsubu and checkpoint_v1.json with the tsubu of format version 1
(commit a5ef837, main before issue 25 item 4). Kept to show how the file was made; later tsubus
must keep loading the file and reproduce the recorded numbers (tests/test_checkpoint.py).

The scene: 60 frictional beads of two linear materials (one rough and rolling), two pair
overrides, a sliding floor and a turning side wall among five walls, and an inserter (12
spheres); saved at step 20000 with 61 contacts touching (19 with walls), then run 2000 more
steps. checkpoint_v1.json records the numbers at the save and after the 2000 steps.

    PYTHONPATH=python python tests/data/make_checkpoint_v1.py
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

import tsubu
from tsubu import fill

HERE = Path(__file__).parent
SAVE_AT, THEN = 20000, 2000


def scene() -> tsubu.Simulation:
    bead = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5,
                          rolling_friction=0.1, roughness=5.0, name="bead")
    heavy = tsubu.Material(density=4000.0, kn=1.5e3, restitution=0.6, friction=0.4, name="heavy")
    wall = tsubu.Material(density=2500.0, kn=2e3, restitution=0.6, friction=0.3, name="wall")
    sim = tsubu.Simulation(threads=1, seed=7, parallel_min=0)
    i, j, k = np.meshgrid(np.arange(4), np.arange(3), np.arange(5), indexing="ij")
    x = (np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1) + 0.5) * 1.02e-3
    rng = np.random.default_rng(1)
    v = rng.uniform(-0.05, 0.05, x.shape)
    half = len(x) // 2
    sim.add_spheres(x[:half], 0.5e-3, bead, velocities=v[:half])
    sim.add_spheres(x[half:], 0.45e-3, heavy, velocities=v[half:])
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=wall, velocity=(0.01, 0, 0))
    sim.add_plane(point=(0, 0, 0), normal=(1, 0, 0), material=wall, angular_velocity=(0, 0.2, 0))
    sim.add_plane(point=(4.08e-3, 0, 0), normal=(-1, 0, 0), material=wall)
    sim.add_plane(point=(0, 0, 0), normal=(0, 1, 0), material=wall)
    sim.add_plane(point=(0, 3.06e-3, 0), normal=(0, -1, 0), material=wall)
    sim.set_pair(bead, wall, friction=0.8)
    sim.set_pair(bead, heavy, restitution=0.3)
    sim.add_inserter(fill.Box((0.5e-3, 0.5e-3, 6e-3), (3.5e-3, 2.5e-3, 8e-3)), rate=300.0,
                     sizes=fill.Uniform(0.4e-3, 0.5e-3), material=bead, seed=3, total=12)
    return sim


def digest(sim: tsubu.Simulation) -> str:
    """SHA-256 over the state's bits: positions, velocities, spins, contacts, energy."""
    h = hashlib.sha256()
    for a in (sim.positions, sim.velocities, sim.angular_velocities, sim.forces, sim.torques):
        h.update(np.ascontiguousarray(a).tobytes())
    c = sim.contacts()
    for key in sorted(c):
        if key in ("element", "wall_point", "branch"):  # (added later, after these files)
            continue
        h.update(key.encode())
        h.update(np.ascontiguousarray(c[key]).tobytes())
    h.update(json.dumps(sim.energy(), sort_keys=True).encode())
    return h.hexdigest()


def numbers(sim: tsubu.Simulation) -> dict:
    return {"step_count": sim.step_count, "time": sim.time, "size": sim.size,
            "contacts": int(len(sim.contacts()["i"])), "digest": digest(sim),
            "energy": sim.energy(), "position_0": [float(v) for v in sim.positions[0]],
            "velocity_last": [float(v) for v in sim.velocities[-1]]}


def main() -> None:
    sim = scene().run(steps=SAVE_AT)
    sim.metadata = {"made_by": "tests/data/make_checkpoint_v1.py"}
    sim.save(HERE / "checkpoint_v1.tsubu")
    saved = numbers(sim)
    sim.run(steps=THEN)
    expected = {"format_version": 1, "run_steps_after_load": THEN, "at_save": saved,
                "after_run": numbers(sim)}
    (HERE / "checkpoint_v1.json").write_text(json.dumps(expected, indent=1, sort_keys=True) + "\n")
    print(json.dumps(expected["after_run"], indent=1))


if __name__ == "__main__":
    main()

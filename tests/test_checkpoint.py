"""Checkpoint and restart (issue 19, item 3): a run continued from a checkpoint gives the same
bits as one that never stopped; files are written atomically and refused whole when damaged."""

from __future__ import annotations

import os
import signal
import struct
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import tsubu
from tsubu.checkpoint import FORMAT_VERSION, MAGIC, CheckpointError

from bits import assert_same_bits


def box_scene(law: str = "rough", threads: int = 1) -> tsubu.Simulation:
    """360 beads falling into a box whose floor slides and whose side wall turns: contacts with
    history, roughness draws and rolling friction at every save point."""
    if law == "hertz":
        bead = tsubu.Material(density=2500.0, youngs_modulus=1e7, poisson_ratio=0.25,
                              restitution=0.5, friction=0.4, rolling_friction=0.05, name="bead")
        options = {}
    else:
        bead = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5,
                              rolling_friction=0.1, roughness=5.0 if law == "rough" else 0.0,
                              name="bead")
        options = {"tangential_history": "literal"} if law == "literal" else {}
    wall = tsubu.Material(density=2500.0, kn=2e3, restitution=0.6, friction=0.3,
                          name="wall") if law != "hertz" else bead
    sim = tsubu.Simulation(threads=threads, seed=7, parallel_min=0, **options)
    i, j, k = np.meshgrid(np.arange(6), np.arange(6), np.arange(10), indexing="ij")
    x = (np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1) + 0.5) * 1.02e-3
    rng = np.random.default_rng(1)
    sim.add_spheres(x, 0.5e-3, bead, velocities=rng.uniform(-0.05, 0.05, x.shape))
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=wall, velocity=(0.01, 0, 0))
    sim.add_plane(point=(0, 0, 0), normal=(1, 0, 0), material=wall, angular_velocity=(0, 0.2, 0))
    sim.add_plane(point=(6.12e-3, 0, 0), normal=(-1, 0, 0), material=wall)
    sim.add_plane(point=(0, 0, 0), normal=(0, 1, 0), material=wall)
    sim.add_plane(point=(0, 6.12e-3, 0), normal=(0, -1, 0), material=wall)
    if law != "hertz":
        sim.set_pair(bead, wall, friction=0.8)
    return sim


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("law", ["rough", "literal", "hertz"])
def test_a_continued_run_is_bit_identical(tmp_path, law, threads):
    """Save at step 14000 (the beads piling on the floor: hundreds of contacts), load, run 6000
    more: the same bits as 20000 steps in one go."""
    whole = box_scene(law, threads).run(steps=20000)
    first = box_scene(law, threads).run(steps=14000)
    assert len(first.contacts()["i"]) > 200
    first.save(tmp_path / "run.tsubu")
    resumed = tsubu.Simulation.load(tmp_path / "run.tsubu")
    assert_same_bits(first, resumed)  # forces, contacts and energy of the last step too
    assert np.array_equal(first.contacts()["tangential_displacement"],
                          resumed.contacts()["tangential_displacement"])
    resumed.run(steps=6000)
    assert_same_bits(whole, resumed)


def test_a_checkpoint_loads_with_another_thread_count(tmp_path):
    whole = box_scene("rough", threads=1).run(steps=16000)
    box_scene("rough", threads=1).run(steps=12000).save(tmp_path / "a.tsubu")
    resumed = tsubu.Simulation.load(tmp_path / "a.tsubu", threads=2)
    assert resumed.threads == 2
    assert_same_bits(whole, resumed.run(steps=4000))


def test_the_scene_comes_back_whole(tmp_path):
    sim = box_scene("rough").run(steps=8000)
    sim.metadata = {"scene": "box", "end_time": 0.5, "nested": [1, 2.5, None]}
    sim.save(tmp_path / "s.tsubu")
    back = tsubu.Simulation.load(tmp_path / "s.tsubu")
    assert back.metadata == sim.metadata
    assert [m.name for m in back.materials] == ["bead", "wall"]
    bead, wall = back.materials
    assert back.pair_parameters(bead, wall) == sim.pair_parameters(*sim.materials)
    assert back.pair_parameters(bead, wall)["friction"] == 0.8
    for w in range(5):
        for key, value in sim.plane(w).items():
            if key == "material":
                assert value.name == back.plane(w)["material"].name
            else:
                assert np.array_equal(value, back.plane(w)[key]), (w, key)
    assert (back.seed, back.skin, back.dt, back.law) == (sim.seed, sim.skin, sim.dt, sim.law)
    assert np.array_equal(back.gravity, sim.gravity)
    assert np.array_equal(back.material_ids, sim.material_ids)
    assert back.energy()["dissipated"] == sim.energy()["dissipated"] > 0


def test_the_last_pair_override_wins_in_either_order(tmp_path):
    sim = box_scene("rough")
    bead, wall = sim.materials
    sim.set_pair(bead, wall, friction=0.1)
    sim.set_pair(wall, bead, friction=0.2)
    sim.set_pair(bead, wall, friction=0.3)
    sim.save(tmp_path / "p.tsubu")
    back = tsubu.Simulation.load(tmp_path / "p.tsubu")
    assert back.pair_parameters(*back.materials)["friction"] == 0.3


def test_a_scene_that_never_ran_round_trips(tmp_path):
    sim = box_scene("rough")
    sim.save(tmp_path / "fresh.tsubu")
    back = tsubu.Simulation.load(tmp_path / "fresh.tsubu")
    assert back.step_count == 0 and len(back.contacts()["i"]) == 0
    assert_same_bits(sim.run(steps=500), back.run(steps=500))


def test_the_hertz_default_speed_is_kept(tmp_path):
    """A Hertzian scene's default dt is fixed by its first run; a restored one keeps it even
    though the spheres are slower now (docs/physics.md)."""
    sim = box_scene("hertz").run(steps=3000)
    sim.save(tmp_path / "h.tsubu")
    assert tsubu.Simulation.load(tmp_path / "h.tsubu").dt == sim.dt


# ---- files: damaged, foreign, newer --------------------------------------------------------

@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    path = tmp_path_factory.mktemp("ckpt") / "good.tsubu"
    box_scene("rough").run(steps=300).save(path)
    return path.read_bytes()


def refused(tmp_path, data: bytes, match: str):
    path = tmp_path / "bad.tsubu"
    path.write_bytes(data)
    with pytest.raises(CheckpointError, match=match):
        tsubu.Simulation.load(path)


@pytest.mark.parametrize("keep", [0, 5, 40, 52, 1000, -1])
def test_a_truncated_file_is_refused(tmp_path, saved, keep):
    refused(tmp_path, saved[:keep] if keep >= 0 else saved[:-1], "truncated|not a tsubu")


@pytest.mark.parametrize("where", [60, 0.5, -1])
def test_a_corrupted_file_is_refused(tmp_path, saved, where):
    at = int(where * len(saved)) if isinstance(where, float) else where % len(saved)
    data = bytearray(saved)
    data[at] ^= 0x10
    refused(tmp_path, bytes(data), "corrupted")


def test_a_foreign_file_is_refused(tmp_path):
    np.savez(tmp_path / "x.npz", a=np.arange(3))
    refused(tmp_path, (tmp_path / "x.npz").read_bytes(), "not a tsubu checkpoint")
    refused(tmp_path, b"[simulation]\ngravity = [0, 0, -9.81]\n" * 10, "not a tsubu checkpoint")


def test_a_newer_format_is_refused(tmp_path, saved):
    data = bytearray(saved)
    struct.pack_into("<I", data, len(MAGIC), FORMAT_VERSION + 1)
    refused(tmp_path, bytes(data), f"version {FORMAT_VERSION + 1} was written by a newer tsubu")


def test_bad_arguments_are_named(tmp_path):
    sim = box_scene("rough")
    with pytest.raises(TypeError, match="path"):
        sim.save(12)
    with pytest.raises(TypeError, match="metadata"):
        sim.save(tmp_path / "m.tsubu", metadata={"f": object()})
    with pytest.raises(FileNotFoundError):
        tsubu.Simulation.load(tmp_path / "missing.tsubu")
    with pytest.raises(ValueError, match="checkpoint_every needs checkpoint"):
        sim.run(steps=10, checkpoint_every=5)
    with pytest.raises(ValueError, match="checkpoint_every"):
        sim.run(steps=10, checkpoint=tmp_path / "c.tsubu", checkpoint_every=0)


# ---- atomic writes ---------------------------------------------------------------------------

def test_a_failed_write_leaves_the_old_file(tmp_path, saved, monkeypatch):
    path = tmp_path / "run.tsubu"
    path.write_bytes(saved)

    def broken(*args):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken)
    with pytest.raises(OSError, match="disk full"):
        box_scene("rough").run(steps=10).save(path)
    assert path.read_bytes() == saved
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.tsubu"]  # no temporary left


def test_saving_into_a_missing_directory_names_the_path_asked_for(tmp_path):
    """The error names the checkpoint's path and its missing directory, not the temporary file
    the write goes through (issue 26)."""
    sim = box_scene("rough")
    path = tmp_path / "no such dir" / "run.tsubu"
    with pytest.raises(FileNotFoundError) as info:
        sim.save(path)
    assert info.value.filename == str(path)
    assert f"the directory {str(tmp_path / 'no such dir')!r} does not exist" in str(info.value)
    assert ".tmp" not in str(info.value)
    (tmp_path / "a file").write_text("")
    with pytest.raises(NotADirectoryError, match="is not a directory") as info:
        sim.save(tmp_path / "a file" / "run.tsubu")
    assert info.value.filename == str(tmp_path / "a file" / "run.tsubu")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a file"]


WRITER = textwrap.dedent("""
    import sys, numpy as np, tsubu
    m = tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)
    sim = tsubu.Simulation(threads=1)
    x = np.random.default_rng(0).uniform(0, 0.2, (60000, 3))
    sim.add_spheres(x, 1e-4, m)
    print("ready", flush=True)
    k = 0
    while True:
        sim.metadata = {"k": k}
        sim.save(sys.argv[1])
        k += 1
""")


@pytest.mark.slow
def test_killing_a_writer_at_random_moments_leaves_a_whole_file(tmp_path):
    """A process saving a 60,000-sphere checkpoint over and over is killed (SIGKILL) at random
    moments: the file there is always a complete checkpoint (the old one or the new one)."""
    path = tmp_path / "live.tsubu"
    rng = np.random.default_rng(3)
    seen = set()
    for _ in range(4):
        with subprocess.Popen([sys.executable, "-c", WRITER, str(path)],
                              stdout=subprocess.PIPE) as proc:
            assert proc.stdout.readline().strip() == b"ready"
            time.sleep(0.2 + float(rng.uniform(0, 0.4)))
            proc.kill()
        if path.exists():
            sim = tsubu.Simulation.load(path)
            assert sim.size == 60000
            seen.add(sim.metadata["k"])
    assert seen, "no save completed: the writer was killed too early to test anything"


# ---- during runs -----------------------------------------------------------------------------

def test_periodic_checkpoints_keep_the_newest(tmp_path):
    sim = box_scene("rough")
    sim.run(steps=1000, checkpoint=tmp_path / "run.tsubu", checkpoint_every=200, checkpoint_keep=2)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["run.step000000000800.tsubu", "run.step000000001000.tsubu", "run.tsubu"]
    middle = tsubu.Simulation.load(tmp_path / "run.step000000000800.tsubu")
    assert middle.step_count == 800
    assert_same_bits(sim, middle.run(steps=200))
    assert tsubu.Simulation.load(tmp_path / "run.tsubu").step_count == 1000


def test_ctrl_c_writes_a_checkpoint_that_continues_the_run(tmp_path):
    """SIGINT during a run with checkpoint=: KeyboardInterrupt, and the checkpoint holds the
    state of the last completed step, from which the rest of the run gives the same bits."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")
    steps = 400_000
    sim = box_scene("rough")
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        sim.run(steps=steps, checkpoint=tmp_path / "stop.tsubu")
    timer.join()
    done = sim.step_count
    assert 0 < done < steps
    resumed = tsubu.Simulation.load(tmp_path / "stop.tsubu")
    assert resumed.step_count == done
    assert_same_bits(sim, resumed)
    whole = box_scene("rough").run(steps=done + 300)
    assert_same_bits(whole, resumed.run(steps=300))


# ---- format 1 files and the core's bytes (issue 25, item 4) ----------------------------------

DATA = os.path.join(os.path.dirname(__file__), "data")


def _v1_tools():
    sys.path.insert(0, DATA)
    try:
        import make_checkpoint_v1
    finally:
        sys.path.remove(DATA)
    import json
    with open(os.path.join(DATA, "checkpoint_v1.json")) as f:
        return make_checkpoint_v1, json.load(f)


def test_a_format_1_file_still_loads_and_runs_on_as_it_did():
    """tests/data/checkpoint_v1.tsubu was written by tsubu's format 1 (tests/data/
    make_checkpoint_v1.py); loaded now and run on, it gives the numbers recorded then."""
    maker, expected = _v1_tools()
    path = os.path.join(DATA, "checkpoint_v1.tsubu")
    with open(path, "rb") as f:
        assert struct.unpack_from("<I", f.read(12), len(MAGIC))[0] == 1
    sim = tsubu.Simulation.load(path)
    assert maker.numbers(sim) == expected["at_save"]
    assert [m.name for m in sim.materials] == ["bead", "heavy", "wall"]
    assert len(sim.inserters) == 1 and sim.metadata == {"made_by": "tests/data/make_checkpoint_v1.py"}
    sim.run(steps=expected["run_steps_after_load"])
    assert maker.numbers(sim) == expected["after_run"]


def test_a_format_1_file_saved_again_as_format_2_runs_on_the_same(tmp_path):
    maker, expected = _v1_tools()
    old = tsubu.Simulation.load(os.path.join(DATA, "checkpoint_v1.tsubu"))
    old.save(tmp_path / "v2.tsubu")
    assert struct.unpack_from("<I", (tmp_path / "v2.tsubu").read_bytes(), len(MAGIC))[0] == FORMAT_VERSION == 2
    new = tsubu.Simulation.load(tmp_path / "v2.tsubu", threads=2)
    assert_same_bits(old, new)
    new.run(steps=expected["run_steps_after_load"])
    assert maker.numbers(new) == expected["after_run"]


def test_inconsistent_core_bytes_under_a_good_checksum_are_refused(tmp_path, saved):
    """A payload whose checksum matches but whose core part is cut short (a bug, or a forged
    file) is refused as inconsistent, naming the record that ran past the end."""
    from tsubu import checkpoint
    payload = saved[52:]
    refused(tmp_path, checkpoint._frame(payload[:-100]), "inconsistent checkpoint contents.*truncated")
    (n,) = struct.unpack_from("<Q", payload)
    refused(tmp_path, checkpoint._frame(struct.pack("<Q", n + 10**6) + payload[8:]), "JSON section")

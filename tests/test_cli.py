"""The command line: tsubu run / resume / demo / info, their exit codes and one-line errors."""

import os
import pathlib
import re
import shutil
import subprocess
import sys

import pytest

import tsubu
from tsubu.__main__ import main

SCENES = pathlib.Path(__file__).resolve().parent / "scenes"


def copy_scene(tmp_path, name="drop.toml"):
    for f in (name, "beads.csv"):
        shutil.copy(SCENES / f, tmp_path / f)
    return tmp_path / name


def test_run_a_scene(tmp_path, capsys):
    path = copy_scene(tmp_path)
    assert main(["run", str(path), "--no-progress", "--threads", "1"]) == 0
    out = capsys.readouterr().out
    assert re.match(rf"tsubu run {re.escape(str(path))}: 3 spheres, t = 0\.00[12]\d* s \(step \d+\)", out)


def test_a_bad_scene_exits_2_with_one_line_per_error(capsys):
    path = str(SCENES / "bad.toml")
    assert main(["run", path]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 12
    assert all(line.startswith(f"tsubu: error: {path}: ") for line in err)
    assert f"tsubu: error: {path}: materials.glass.restitution = 1.5: must be in (0, 1]" in err


def test_the_installed_command_prints_no_traceback(tmp_path):
    bad = tmp_path / "scene.toml"
    bad.write_text('[simulation]\nduration = 1.0\ndt = 1e-3\n[materials.glass]\nrestitution = 1.5\n')
    result = subprocess.run([sys.executable, "-m", "tsubu", "run", str(bad)], capture_output=True, text=True,
                            cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr == f"tsubu: error: {bad}: materials.glass.restitution = 1.5: must be in (0, 1]\n"
    assert result.stdout == ""


@pytest.mark.parametrize("text, message", [
    ("[simulation\n", "not a valid TOML file: "),
    ("", "simulation: required key missing"),
    ("[simulation]\nduration = 1\n[materials]\n[[walls]]\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\n"
     "material = \"glass\"\n", 'walls[0].material = "glass": no such material; defined: none'),
])
def test_file_errors(tmp_path, capsys, text, message):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    assert main(["run", str(path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith(f"tsubu: error: {path}: {message}")


def test_a_missing_scene_file(tmp_path, capsys):
    path = tmp_path / "none.toml"
    assert main(["run", str(path)]) == 2
    assert capsys.readouterr().err == f"tsubu: error: {path}: cannot read the scene file: No such file or directory\n"


def test_an_unstable_run_exits_1(tmp_path, capsys):
    path = copy_scene(tmp_path)
    text = path.read_text().replace("dt_fraction = 0.02", "dt = 1e-3\nallow_unstable_dt = true\nmax_overlap = 0.01")
    text = text.replace("duration = 0.002", "duration = 0.1")
    path.write_text(text)
    assert main(["run", str(path), "--no-progress"]) == 1
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"tsubu: error: {path}: the run went unstable: unstable at step ")


# ---- scenes with valid syntax that the library refuses: one line, exit 2 (issue 26) ------------

@pytest.mark.parametrize("change, message", [
    (("point = [0, 0, 0]\nnormal = [0, 0, 1]", "point = [0, 0, 0.0005]\nnormal = [0, 0, 1]"),
     "initial overlap: sphere 0 overlaps wall 0"),
    (("dt_fraction = 0.02", "dt = 1e-3"), "dt = 0.001 s exceeds the stability bound"),
])
def test_a_scene_the_library_refuses_exits_2_in_one_line(tmp_path, capsys, change, message):
    path = copy_scene(tmp_path)
    assert change[0] in path.read_text()
    path.write_text(path.read_text().replace(*change))
    assert main(["run", str(path), "--no-progress"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"tsubu: error: {path}: the scene cannot start: {message}")


def test_the_installed_command_refuses_such_a_scene_without_a_traceback(tmp_path):
    path = copy_scene(tmp_path)
    path.write_text(path.read_text().replace("dt_fraction = 0.02", "dt = 1e-3"))
    here = str(pathlib.Path(tsubu.__file__).resolve().parents[1])  # this tsubu, not an installed one
    result = subprocess.run([sys.executable, "-m", "tsubu", "run", str(path), "--no-progress"],
                            capture_output=True, text=True, cwd=tmp_path,
                            env={**os.environ, "PYTHONPATH": here})
    assert result.returncode == 2
    assert result.stderr.startswith(f"tsubu: error: {path}: the scene cannot start: dt = ")
    assert "Traceback" not in result.stderr and len(result.stderr.splitlines()) == 1


@pytest.mark.parametrize("where", ["--output", "output.directory"])
def test_an_output_directory_that_cannot_be_written_exits_2_before_the_run(tmp_path, capsys, where):
    path = copy_scene(tmp_path)
    (tmp_path / "taken").write_text("a file, not a directory")
    argv = ["run", str(path), "--no-progress"]
    if where == "--output":
        argv += ["--output", str(tmp_path / "taken")]
        path.write_text(path.read_text() + '\n[checkpoint]\npath = "run.tsubu"\n')
    else:
        path.write_text(path.read_text() + '\n[output]\ndirectory = "taken"\nnpz = { every = 50 }\n')
    assert main(argv) == 2
    assert capsys.readouterr().err == (f"tsubu: error: {path}: {where} = {tmp_path / 'taken'}: not a "
                                       "directory (a file of that name exists)\n")


def test_output_that_cannot_be_written_during_the_run_exits_2(tmp_path, capsys, monkeypatch):
    path = copy_scene(tmp_path)
    path.write_text(path.read_text() + '\n[checkpoint]\npath = "run.tsubu"\n')

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device", str(tmp_path / "output" / "run.tsubu"))

    monkeypatch.setattr(tsubu.Simulation, "save", full)
    assert main(["run", str(path), "--no-progress"]) == 2
    assert capsys.readouterr().err == (f"tsubu: error: {path}: cannot write the output: "
                                       f"{tmp_path / 'output' / 'run.tsubu'}: No space left on device\n")


@pytest.mark.parametrize("command", ["run", "resume", "demo"])
def test_threads_out_of_range_is_the_command_line_options_error(tmp_path, capsys, command):
    """--threads 100000 is reported as the option it is, not as the scene key simulation.threads."""
    argv = {"run": ["run", str(copy_scene(tmp_path))], "resume": ["resume", "c.tsubu"], "demo": ["demo"]}
    with pytest.raises(SystemExit) as info:
        main(argv[command] + ["--threads", "100000"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "argument --threads: must be an integer from 1 to 4096, got '100000'" in err
    assert "simulation.threads" not in err


def test_an_internal_error_is_not_swallowed(tmp_path, monkeypatch):
    """Only the library's refusals (ValueError, TypeError, OSError) become exit 2: anything else
    is a bug, and keeps its traceback."""
    from tsubu.scene import Scene

    def bug(self, *args, **kwargs):
        raise KeyError("a bug")

    monkeypatch.setattr(Scene, "run", bug)
    with pytest.raises(KeyError, match="a bug"):
        main(["run", str(copy_scene(tmp_path)), "--no-progress"])


def test_output_directory_override(tmp_path, capsys):
    pytest.importorskip("tsubu.output")
    path = copy_scene(tmp_path)
    path.write_text(path.read_text() + "\n[output]\ndirectory = \"here\"\nnpz = { every = 50 }\n")
    assert main(["run", str(path), "--no-progress", "--output", str(tmp_path / "there")]) == 0
    assert not (tmp_path / "here").exists()
    assert any(f.endswith(".npz") for f in os.listdir(tmp_path / "there"))
    assert f"output in {tmp_path / 'there'}" in capsys.readouterr().out


@pytest.mark.parametrize("argv", [
    ["run", "scene.toml", "--threads", "0"],
    ["run", "scene.toml", "--threads", "two"],
    ["resume", "c.tsubu", "--time", "1", "--until", "2"],
    ["resume", "c.tsubu", "--time", "-1"],
    ["resume", "c.tsubu", "--until", "nan"],
    ["run"],
])
def test_bad_arguments_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    assert "error:" in capsys.readouterr().err


def needs_checkpoints():
    if not hasattr(tsubu.Simulation, "save"):
        pytest.skip("checkpoints (Simulation.save) not in this build")


def test_resume_refuses_a_file_that_is_not_a_checkpoint(tmp_path, capsys):
    needs_checkpoints()
    for content in (b"", b"not a checkpoint at all\n" * 10):
        path = tmp_path / "c.tsubu"
        path.write_bytes(content)
        assert main(["resume", str(path)]) == 2
        (line,) = capsys.readouterr().err.splitlines()
        assert line.startswith(f"tsubu: error: {path}: ")
    assert main(["resume", str(tmp_path / "missing.tsubu")]) == 2
    assert capsys.readouterr().err == (f"tsubu: error: {tmp_path / 'missing.tsubu'}: cannot read the "
                                       "checkpoint: No such file or directory\n")


def test_resume_refuses_a_checkpoint_without_a_scene(tmp_path, capsys):
    needs_checkpoints()
    sim = tsubu.Simulation(dt=1e-5)
    sim.add_sphere((0, 0, 0.01), 1e-3, tsubu.Material())
    sim.save(tmp_path / "plain.tsubu")
    assert main(["resume", str(tmp_path / "plain.tsubu")]) == 2
    assert "was not written by a scene run" in capsys.readouterr().err


def _scene_run_to_its_checkpoint(tmp_path):
    path = copy_scene(tmp_path)
    path.write_text(path.read_text() + "\n[checkpoint]\npath = \"run.tsubu\"\n")
    assert main(["run", str(path), "--no-progress"]) == 0
    return tmp_path / "output" / "run.tsubu"


def test_run_then_resume_continues_to_the_end(tmp_path, capsys):
    needs_checkpoints()
    checkpoint = _scene_run_to_its_checkpoint(tmp_path)
    end = tsubu.Simulation.load(checkpoint)
    assert abs(end.time - 0.002) < end.dt
    # resume with --time: 1 ms more, then --until 0.0025
    assert main(["resume", str(checkpoint), "--time", "0.001", "--no-progress"]) == 0
    assert abs(tsubu.Simulation.load(checkpoint).time - 0.003) < end.dt
    assert tsubu.Simulation.load(checkpoint).metadata["end_time"] == pytest.approx(0.003, abs=end.dt)  # the new end
    assert main(["resume", str(checkpoint), "--no-progress"]) == 0  # already at the end: nothing to do
    assert abs(tsubu.Simulation.load(checkpoint).time - 0.003) < end.dt
    assert "tsubu resume" in capsys.readouterr().out
    # (--until before the checkpoint's time is refused: test_resume_until_in_the_past_is_refused)


def test_a_scene_run_until_a_time_already_past_is_refused(tmp_path, capsys):
    # resume --until 0.5 on a checkpoint at t = 1 ran 0 steps and exited 0.
    needs_checkpoints()
    scene = tsubu.scene.resume(_scene_run_to_its_checkpoint(tmp_path))
    t = scene.simulation.time
    with pytest.raises(ValueError, match=rf"until=0\.001 s is before the simulation's time t = "
                                         rf"{re.escape(repr(t))} s \(step \d+\): a run cannot go back"):
        scene.run(until=0.001, progress=False)
    assert scene.simulation.time == t
    scene.run(until=t - 0.4 * scene.simulation.dt, progress=False)  # within half a step: no step
    assert scene.simulation.time == t


def test_resume_until_in_the_past_is_refused(tmp_path, capsys):
    needs_checkpoints()
    checkpoint = _scene_run_to_its_checkpoint(tmp_path)
    before = checkpoint.read_bytes()
    t = tsubu.Simulation.load(checkpoint).time
    # the tsubu under test, wherever it is imported from
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [os.path.dirname(os.path.dirname(tsubu.__file__))] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    result = subprocess.run([sys.executable, "-m", "tsubu", "resume", str(checkpoint), "--until", "0.001",
                             "--no-progress"], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert result.returncode != 0
    assert re.search(rf"until=0\.001 s is before the simulation's time t = {re.escape(repr(t))} s",
                     result.stderr), result.stderr
    assert checkpoint.read_bytes() == before


def test_resume_refuses_what_the_library_refuses_in_one_line(tmp_path, capsys):
    """tsubu resume as tsubu run: a checkpoint whose scene cannot start, or an output directory
    that cannot be written, ends in one line and exit 2 (issue 26)."""
    needs_checkpoints()
    checkpoint = _scene_run_to_its_checkpoint(tmp_path)
    sim = tsubu.Simulation.load(checkpoint)
    sim.dt = 1e-3  # above the stability bound: refused when the run starts
    sim.save(tmp_path / "bad dt.tsubu")
    capsys.readouterr()
    assert main(["resume", str(tmp_path / "bad dt.tsubu"), "--time", "0.01", "--no-progress"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"tsubu: error: {tmp_path / 'bad dt.tsubu'}: the scene cannot start: dt = 0.001 s "
                           "exceeds the stability bound")
    (tmp_path / "taken").write_text("")
    assert main(["resume", str(checkpoint), "--time", "0.001", "--output", str(tmp_path / "taken"),
                 "--no-progress"]) == 2
    assert capsys.readouterr().err == (f"tsubu: error: {checkpoint}: --output = {tmp_path / 'taken'}: "
                                       "not a directory (a file of that name exists)\n")


def test_demo_and_info_still_work(capsys):
    assert main(["info"]) == 0
    assert capsys.readouterr().out.startswith(f"tsubu {tsubu.__version__}")
    assert main(["demo", "--nx", "2", "--nz", "2", "--time", "0.001", "--threads", "1"]) == 0
    assert "demo: 8 glass beads" in capsys.readouterr().out


def test_demo_says_why_it_runs_on_one_thread(capsys):
    assert main(["demo", "--nx", "2", "--nz", "2", "--time", "0.001", "--threads", "2"]) == 0
    out = capsys.readouterr().out
    if tsubu.openmp:
        assert "on 1 thread: 8 beads are below parallel_min = 2048, under which a scene runs on one thread" in out
    else:
        assert "on 1 thread: this build has no OpenMP" in out

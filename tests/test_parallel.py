"""A scene cut over MPI ranks (tsubu.parallel, docs/parallel.md) gives the same bits as one
process: positions, velocities, spins, forces, every contact's history and force, each sphere's
dissipated energy and the outlets' log, on 1 to 4 ranks (more ranks than this machine's cores:
oversubscribed), and through a checkpoint written on 3 ranks and resumed on 2 and on 1.

The scene (tests/mpi/scene.py) is a frictional Hertz-Mindlin pack on an irregular mesh floor in
a box of planes, pushed by tilted gravity out of its open side into an outlet, with glued and
driven spheres: every kind of state a rank's halo carries.
"""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mpi4py", reason='the MPI tests need mpi4py: pip install "tsubu[mpi]"')

from tsubu import parallel  # noqa: E402

SCENE = Path(__file__).parent / "mpi" / "scene.py"
MPIEXEC = Path(sys.executable).parent / "mpiexec"
needs_mpiexec = pytest.mark.skipif(not MPIEXEC.exists(), reason=f"no {MPIEXEC} (the mpich wheel)")

STEPS = 12_000  # long enough for ~20 redistributions, cuts moved and spheres leaving


def _run(args, ranks=None, timeout=600):
    cmd = [sys.executable, str(SCENE), *map(str, args)]
    if ranks is not None:
        cmd = [str(MPIEXEC), "-n", str(ranks), *cmd]
    # (More threads than cores here: OpenMP's threads sleep rather than spin at barriers.)
    env = dict(os.environ, OMP_WAIT_POLICY="PASSIVE")
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def _same(a_path, b_path):
    a, b = np.load(a_path), np.load(b_path)
    assert a.files == b.files
    differ = [k for k in a.files if not np.array_equal(a[k], b[k])]
    assert not differ, f"differ from one process: {differ}"
    return a


def _same_sums(a_path, b_path):
    """Decomposed.energy and .stress (reductions over the ranks' shares) against one process's:
    each sphere's stress bracket bit for bit (a rank holds all of its own spheres' contacts),
    the sums to round-off (summed over the ranks, not over all spheres in id order)."""
    a, b = np.load(f"{a_path}.sums.npz"), np.load(f"{b_path}.sums.npz")
    assert a.files == b.files
    assert np.array_equal(a["brackets"], b["brackets"])
    scale = np.abs(a["brackets"]).sum(axis=0) / 0.03 / 0.024 / 0.02
    assert np.all(np.abs(a["stress"] - b["stress"]) <= 1e-12 * scale + 1e-300)
    for k in (f for f in a.files if f.startswith("energy_")):
        size = max(abs(float(a[k])), abs(float(a["energy_kinetic"])), abs(float(a["energy_gravitational"])))
        assert abs(float(a[k]) - float(b[k])) <= 1e-12 * size, (k, float(a[k]), float(b[k]))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("mpi") / "one.npz"
    _run(["reference", STEPS, out])
    ref = np.load(out)
    # The scene does what it is for: spheres leave through the outlet, contacts touch walls.
    assert len(ref["removed_id"]) > 0 and (ref["cwall"] >= 0).any() and (ref["cj"] >= 0).any()
    return out


@pytest.mark.slow
@needs_mpiexec
@pytest.mark.parametrize("ranks", [1, 2, 3, 4])
def test_any_number_of_ranks_gives_the_bits_of_one_process(reference, tmp_path, ranks):
    out = tmp_path / f"ranks{ranks}.npz"
    said = _run(["decomposed", STEPS, out], ranks=ranks)
    _same(reference, out)
    _same_sums(reference, out)
    if ranks > 1:  # spheres moved between ranks, and every rank owned some at the end
        words = said.split()
        assert int(words[words.index("redistributions") + 1]) > 0
        owned = said[said.index("owned") + 5:].strip().strip("[]").split(",")
        assert all(int(k) > 0 for k in owned), said


@pytest.mark.slow
@needs_mpiexec
def test_two_ranks_of_two_threads_give_the_bits_of_one_process(reference, tmp_path):
    out = tmp_path / "threads.npz"
    _run(["decomposed", STEPS, out, "--threads", 2], ranks=2)
    _same(reference, out)


@pytest.mark.slow
@needs_mpiexec
def test_spheres_added_by_parts_give_the_bits_of_one_process_adding_them_all(tmp_path):
    # No rank builds the whole scene: each adds its share after decompose.
    _run(["reference", STEPS // 2, tmp_path / "one.npz", "--parts"])
    for ranks in (2, 3):
        _run(["decomposed", STEPS // 2, tmp_path / f"parts{ranks}.npz", "--parts"], ranks=ranks)
        _same(tmp_path / "one.npz", tmp_path / f"parts{ranks}.npz")


@pytest.mark.slow
@needs_mpiexec
def test_an_inserter_pours_over_ranks_as_in_one_process(tmp_path):
    # Each event places its spheres against every sphere of the scene, on every rank alike;
    # rank 0 adds them (ids as one process hands them out). Also through a checkpoint.
    _run(["reference", STEPS // 2, tmp_path / "one.npz", "--pour"])
    ref = np.load(tmp_path / "one.npz")
    assert ref["inserted"][0] > 100
    _run(["decomposed", STEPS // 2, tmp_path / "two.npz", "--pour"], ranks=2)
    _same(tmp_path / "one.npz", tmp_path / "two.npz")
    saved = tmp_path / "three.tsubu"
    _run(["decomposed", STEPS // 4, tmp_path / "three.npz", "--save", saved, "--pour"], ranks=3)
    _run(["decomposed", STEPS // 2 - STEPS // 4, tmp_path / "two_more.npz", "--load", saved, "--pour"],
         ranks=2)
    _same(tmp_path / "one.npz", tmp_path / "two_more.npz")


@pytest.mark.slow
def test_adding_by_parts_needs_the_defaults_that_all_spheres_decide():
    from mpi4py import MPI
    sys.path.insert(0, str(SCENE.parent))
    import scene

    import tsubu
    import tsubu.fill
    empty = tsubu.Simulation(gravity=(0, 0, -9.81), dt=1e-6)  # (skin and impact_speed not set)
    with pytest.raises(ValueError, match="skin, impact_speed set"):
        parallel.decompose(empty, comm=MPI.COMM_SELF)
    sim = scene.build()  # (defaults: taken from its spheres when decomposed, not given)
    part = parallel.decompose(sim, comm=MPI.COMM_SELF)
    with pytest.raises(ValueError, match="needs the scene's dt, skin, impact_speed set"):
        part.add_spheres([[0.01, 0.01, 0.05]], 0.001, sim.materials[0])
    pour = scene.build()
    pour.add_inserter(tsubu.fill.Box((0.002, 0.002, 0.03), (0.02, 0.02, 0.035)), rate=100.0, sizes=0.001,
                      material=pour.materials[0])
    with pytest.raises(ValueError, match="inserters needs dt, skin, impact_speed set"):
        parallel.decompose(pour, comm=MPI.COMM_SELF)


@pytest.fixture(scope="module")
def chute_reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("mpi") / "chute.npz"
    _run(["reference", STEPS, out, "--chute"])
    ref = np.load(out)
    # Spheres crossed the periodic faces (and wrapped at the rebuilds), touching across them.
    assert np.abs(ref["images"]).sum() > 20
    return out


@pytest.mark.slow
@needs_mpiexec
@pytest.mark.parametrize("ranks", [2, 4])
def test_a_periodic_chute_cut_across_its_periodic_axes_gives_the_bits_of_one_process(chute_reference, tmp_path,
                                                                                    ranks):
    # A periodic scene wraps its spheres at the lists' rebuilds: every rank books the whole
    # scene's largest speed, so that its rebuilds fall where one process's do.
    out = tmp_path / f"chute{ranks}.npz"
    _run(["decomposed", STEPS, out, "--chute"], ranks=ranks)
    _same(chute_reference, out)
    _same_sums(chute_reference, out)


@pytest.mark.slow
@needs_mpiexec
def test_a_periodic_checkpoint_written_on_three_ranks_resumes_on_two(chute_reference, tmp_path):
    half = STEPS // 2
    saved = tmp_path / "three.tsubu"
    _run(["decomposed", half, tmp_path / "three.npz", "--save", saved, "--chute"], ranks=3)
    _run(["decomposed", STEPS - half, tmp_path / "two.npz", "--load", saved, "--chute"], ranks=2)
    _same(chute_reference, tmp_path / "two.npz")


@pytest.fixture(scope="module", params=["", "--fixed"], ids=["free", "with fixed spheres"])
def shear_reference(request, tmp_path_factory):
    out = tmp_path_factory.mktemp("mpi") / "shear.npz"
    flags = ["--shear"] + ([request.param] if request.param else [])
    _run(["reference", STEPS, out, *flags])
    ref = np.load(out)
    assert np.abs(ref["images"]).sum() > 5 and len(ref["ci"]) > 20
    return out, flags


@pytest.mark.slow
@needs_mpiexec
def test_a_lees_edwards_cell_gives_the_bits_of_one_process(shear_reference, tmp_path):
    # Its lists book the motion relative to the mean flow (max |v - u|, from the particle pass,
    # or after the fixed spheres are placed): every rank books the whole cell's.
    reference, flags = shear_reference
    for ranks in (2, 3):
        out = tmp_path / f"shear{ranks}.npz"
        _run(["decomposed", STEPS, out, *flags], ranks=ranks)
        _same(reference, out)
        _same_sums(reference, out)
    half = STEPS // 2
    saved = tmp_path / "three.tsubu"  # (the slides and images go into the checkpoint)
    _run(["decomposed", half, tmp_path / "three.npz", "--save", saved, *flags], ranks=3)
    _run(["decomposed", STEPS - half, tmp_path / "two.npz", "--load", saved, *flags], ranks=2)
    _same(reference, tmp_path / "two.npz")


@pytest.mark.slow
@needs_mpiexec
def test_a_checkpoint_written_on_three_ranks_resumes_on_two_and_on_one(reference, tmp_path):
    half = STEPS // 2
    saved = tmp_path / "three.tsubu"
    _run(["decomposed", half, tmp_path / "three.npz", "--save", saved], ranks=3)
    _run(["decomposed", STEPS - half, tmp_path / "two.npz", "--load", saved], ranks=2)
    _same(reference, tmp_path / "two.npz")
    _run(["reference", STEPS - half, tmp_path / "one.npz", "--load", saved])
    _same(reference, tmp_path / "one.npz")


def test_energy_and_stress_of_one_rank_are_the_scenes():
    from mpi4py import MPI
    sys.path.insert(0, str(SCENE.parent))
    import scene

    one, other = scene.build(), scene.build()
    one.run(300)
    part = parallel.decompose(other, comm=MPI.COMM_SELF)
    part.run(300)
    assert part.energy() == one.energy()  # (one rank's share is everything, in the same order)
    assert np.array_equal(part.stress(1e-5), one.stress(1e-5))
    assert np.array_equal(part.stress(per_particle=True), one.stress(per_particle=True))
    with pytest.raises(ValueError, match="needs a periodic box"):
        part.stress()


def test_grid_shape_cuts_the_longest_extent_first():
    assert parallel.grid_shape(1, (1, 1, 1)) == (1, 1, 1)
    assert parallel.grid_shape(2, (1, 1, 3)) == (1, 1, 2)
    assert parallel.grid_shape(4, (4, 1, 1)) == (4, 1, 1)
    assert parallel.grid_shape(4, (2, 2, 1)) == (2, 2, 1)
    assert parallel.grid_shape(8, (1, 1, 1)) == (2, 2, 2)
    assert np.prod(parallel.grid_shape(12, (3, 2, 1))) == 12
    assert parallel.grid_shape(4, (1, 1, 8), uncut=2) == (2, 2, 1)  # (a column under gravity)
    assert parallel.grid_shape(3, (1, 2, 8), uncut=2) == (1, 3, 1)
    # A Lees-Edwards flow axis (x) stays uncut, and gravity's (z) where it can.
    assert parallel.grid_shape(2, (8, 1, 1), uncut=[0, 2]) == (1, 2, 1)
    assert parallel.grid_shape(4, (8, 1, 1), uncut=[0, 1, 2]) == (1, 1, 4)  # (the last one gives)
    with pytest.raises(ValueError, match="uncut"):
        parallel.grid_shape(2, (1, 1, 1), uncut=3)
    with pytest.raises(ValueError, match="ranks"):
        parallel.grid_shape(0, (1, 1, 1))


@pytest.mark.slow
@needs_mpiexec
def test_ranks_that_built_different_scenes_are_refused(tmp_path):
    said = _run(["differ", 0, tmp_path / "x.npz"], ranks=2)
    assert said.count("the scene differs between ranks") == 2, said  # (the ranks print interleaved)


# (slow: these start MPI in the test's own process, which the sanitizer run leaves out)
@pytest.mark.slow
@pytest.mark.parametrize("change, message", [
    (lambda s: (s.set_box((0, 0, -1), (0.03, 0.03, 1), periodic="xz"),
                s.set_pressure(100.0, gain=1e-6, axis="z")), "pressure-controlled"),
    (lambda s: s.set_wall_servo(1, force=1.0, max_speed=0.1), "servo wall"),
])
def test_what_is_not_cut_over_ranks_yet_is_refused(change, message):
    from mpi4py import MPI
    sys.path.insert(0, str(SCENE.parent))
    import scene

    sim = scene.build()
    change(sim)
    with pytest.raises(ValueError, match=message):
        parallel.decompose(sim, comm=MPI.COMM_SELF)


@pytest.mark.slow
@pytest.mark.parametrize("kwargs, message", [
    ({"shape": (1, 2, 1)}, "product is the number of ranks"),
    ({"shape": (1, 1)}, "shape"),
    ({"margin": 0.0}, "margin"),
    ({"margin": float("nan")}, "margin"),
    ({"imbalance": 1.0}, "imbalance"),
])
def test_bad_arguments_are_refused_naming_them(kwargs, message):
    from mpi4py import MPI
    sys.path.insert(0, str(SCENE.parent))
    import scene

    with pytest.raises(ValueError, match=message):
        parallel.decompose(scene.build(), comm=MPI.COMM_SELF, **kwargs)


@pytest.mark.slow
@needs_mpiexec
def test_tsubu_run_over_ranks_writes_the_files_of_one_process(tmp_path):
    # The column-collapse scene (a gate the schedule removes, output every 0.02 s and npz
    # dumps), shortened: `mpiexec -n 3 tsubu run` writes the same files, byte for byte.
    examples = Path(__file__).parents[1] / "examples" / "scenes"
    text = (examples / "column_collapse.toml").read_text()
    text = text.replace("duration = 0.8 ", "duration = 0.045")
    assert "duration = 0.045" in text
    (tmp_path / "scene.toml").write_text(text)
    (tmp_path / "column_collapse_start.npz").write_bytes((examples / "column_collapse_start.npz").read_bytes())
    outputs = {}
    for ranks in (None, 3):
        out = tmp_path / f"out{ranks}"
        cmd = [sys.executable, "-m", "tsubu", "run", str(tmp_path / "scene.toml"), "--output", str(out),
               "--no-progress"]
        if ranks:
            cmd = [str(MPIEXEC), "-n", str(ranks), *cmd]
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stdout + done.stderr
        assert done.stdout.count("tsubu run") == 1, done.stdout  # (rank 0 reports)
        outputs[ranks] = {p.name: p.read_bytes() for p in sorted(out.iterdir())}
    assert len(outputs[None]) > 10 and outputs[None].keys() == outputs[3].keys()
    differ = [name for name in outputs[None] if outputs[None][name] != outputs[3][name]]
    assert not differ


@pytest.mark.slow
@needs_mpiexec
def test_tsubu_resume_over_ranks_continues_a_checkpoint_written_over_ranks(tmp_path):
    # The periodic shear scene with checkpoints every 0.03 s: run on 2 ranks, resume its
    # numbered checkpoint on 2 ranks; the frames equal those of one uninterrupted process.
    examples = Path(__file__).parents[1] / "examples" / "scenes"
    text = (examples / "periodic_shear.toml").read_text()
    text = text.replace("duration = 0.1 ", "duration = 0.06").replace("[checkpoint]", "[checkpoint]\ninterval = 0.03", 1)
    assert "duration = 0.06" in text and "interval = 0.03" in text
    (tmp_path / "scene.toml").write_text(text)

    def tsubu(ranks, *args):
        cmd = [sys.executable, "-m", "tsubu", *map(str, args), "--no-progress"]
        if ranks:
            cmd = [str(MPIEXEC), "-n", str(ranks), *cmd]
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stdout + done.stderr

    tsubu(None, "run", tmp_path / "scene.toml", "--output", tmp_path / "one")
    tsubu(2, "run", tmp_path / "scene.toml", "--output", tmp_path / "two")
    numbered = sorted((tmp_path / "two").glob("checkpoint.step*.tsubu"))[-1]
    assert numbered.name != "checkpoint.step000000000000.tsubu"
    tsubu(2, "resume", numbered, "--output", tmp_path / "resumed")
    frames = sorted(p.name for p in (tmp_path / "resumed").glob("*.npz"))
    assert len(frames) >= 3
    for name in frames:
        assert (tmp_path / "resumed" / name).read_bytes() == (tmp_path / "one" / name).read_bytes(), name
        assert (tmp_path / "two" / name).read_bytes() == (tmp_path / "one" / name).read_bytes(), name

"""The hopper benchmark against LIGGGHTS (benchmarks/hopper_liggghts.py): what it hands LIGGGHTS must
be tsubu's scene. The dashpots written into the deck are the ones tsubu applies, the STL's triangles
lie in the planes the packing settled against, the data file keeps every bit of the packing, and a
machine without LIGGGHTS gets a message, not a traceback. (The runs themselves are benchmarks, not
tests: they take minutes and need the liggghts binary.)"""

import math
import os
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "benchmarks"))

import hopper_liggghts as hl  # noqa: E402

import tsubu  # noqa: E402


def _measured_eta(wall: bool) -> float:
    """The normal dashpot tsubu applies to the hopper's grains [N s/m], from one step's force."""
    mat = hl.material()
    delta, vn = 1e-6, -0.02
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    if wall:
        sim.add_sphere((0, 0, hl.R - delta), hl.R, mat, velocity=(0, 0, vn))
        sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=mat)
        sim.run(steps=1)
        fn = float(np.asarray(sim.contacts()["force"])[0][2])
    else:
        sim.add_spheres([[0, 0, 0], [hl.D - delta, 0, 0]], hl.R, mat,
                        velocities=[[-vn / 2, 0, 0], [vn / 2, 0, 0]])
        sim.run(steps=1)
        c = sim.contacts()
        sign = -1.0 if int(np.asarray(c["i"])[0]) == 0 else 1.0
        fn = sign * float(np.asarray(c["force"])[0][0])
    return (hl.KN * delta - fn) / vn


def test_the_decks_damping_is_the_dashpot_tsubu_applies_to_pairs_and_walls():
    v = hl.liggghts_vars(dt=1e-6, steps=10, every=5, n0=3)
    # LIGGGHTS's hooke/stiffness multiplies gamman [1/s] by m_eff: m/2 for two grains, m on a wall.
    assert float(v["gnp"]) * hl.MASS / 2 == pytest.approx(_measured_eta(wall=False), rel=1e-9)
    assert float(v["gnw"]) * hl.MASS == pytest.approx(_measured_eta(wall=True), rel=1e-9)
    assert float(v["kn"]) == hl.KN and float(v["kt"]) == hl.KT and float(v["mu"]) == hl.MU
    assert float(v["mgrain"]) == hl.MASS


@pytest.mark.parametrize("divisions", [1, 3])
def test_the_meshs_triangles_lie_in_the_filling_planes_and_face_into_the_hopper(divisions):
    vertices, faces = hl.hopper_mesh(divisions)
    assert faces.shape == (8 * divisions ** 2, 3)
    planes = hl.hopper_planes()[:4]              # the plates and the end walls (not the floor)
    area = 0.0
    for f in faces:
        a, b, c = vertices[f]
        n = np.cross(b - a, c - a)
        area += 0.5 * np.linalg.norm(n)
        n /= np.linalg.norm(n)
        hits = [k for k, (p, m) in enumerate(planes)
                if np.allclose(n, m, atol=1e-12) and np.allclose((vertices[f] - p) @ np.array(m), 0, atol=1e-15)]
        assert len(hits) == 1, (f, n)
    plate = hl.DEPTH * hl.HEIGHT / math.cos(hl.HALF_ANGLE)
    end_wall = 0.5 * (hl.ORIFICE + hl.TOP) * hl.HEIGHT
    assert area == pytest.approx(2 * plate + 2 * end_wall, rel=1e-12)


def test_the_liggghts_data_file_keeps_every_bit_of_the_packing(tmp_path):
    rng = np.random.default_rng(5)
    state = {"x": rng.normal(size=(7, 3)) * 0.01, "v": rng.normal(size=(7, 3)),
             "w": rng.normal(size=(7, 3)) * 100}
    path = tmp_path / "packing.data"
    hl.write_data(str(path), state)
    text = path.read_text()
    atoms = text.split("Atoms\n\n")[1].split("\n\nVelocities")[0]
    velocities = text.split("Velocities\n\n")[1]
    a = np.array([[float(t) for t in line.split()] for line in atoms.strip().splitlines()])
    v = np.array([[float(t) for t in line.split()] for line in velocities.strip().splitlines()])
    assert np.array_equal(a[:, 0], np.arange(1, 8)) and np.all(a[:, 1] == 1)
    assert np.all(a[:, 2] == hl.D) and np.all(a[:, 3] == hl.RHO)
    assert np.array_equal(a[:, 4:], state["x"])
    assert np.array_equal(v[:, 1:4], state["v"]) and np.array_equal(v[:, 4:], state["w"])
    assert f"{hl.Z_OUT!r} " in text      # the box floor is the outlet


def test_the_discharge_rate_is_the_slope_of_the_steady_part():
    t = np.linspace(0.0, 0.1, 101)
    m = np.where(t > 0.03, 0.2 * (t - 0.03), 0.0)          # 0.2 kg/s once grains are out
    r = hl.discharge_rate(t, m, None, n0=100000)
    assert r["rate_kg_s"] == pytest.approx(0.2, rel=1e-9)
    assert r["window_s"][0] == pytest.approx(0.03 + hl.FIT_DELAY)


def test_without_liggghts_the_benchmark_says_so_and_exits_2(monkeypatch, capsys):
    monkeypatch.setattr(hl.shutil, "which", lambda name: None)
    assert hl.main(["--only", "liggghts"]) == 2
    assert "liggghts is not installed" in capsys.readouterr().out


@pytest.mark.parametrize("divisions", [1, 4])
def test_the_finer_meshs_triangles_share_their_edges_across_the_hoppers_corners(divisions):
    vertices, faces = hl.hopper_mesh(divisions)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, uses = np.unique(edges, axis=0, return_counts=True)
    # Open only along the top rim (4 k edges), the slot's two lips and the end walls' bottoms (4 k);
    # every other edge, the four corners between plates and end walls included, joins two triangles.
    assert sorted(set(uses)) == [1, 2] and np.sum(uses == 1) == 8 * divisions
    assert len(np.unique(vertices, axis=0)) == len(vertices)


def test_tsubus_particle_steps_count_the_grains_present_in_each_timed_step(monkeypatch):
    class Emptying:                  # stands in for the discharge scene: 10 grains, 3 leave
        size = 10

        def run(self, steps):
            pass

        def removed(self):       # removed at the end of steps 3, 5 and 5
            return {"step": np.array([5, 3, 5]), "time": np.array([5.0, 3.0, 5.0])}

    monkeypatch.setattr(hl, "build_tsubu", lambda state, threads, divisions: Emptying())
    r = hl.run_tsubu({"dt": 0.5}, steps=6, every=2, warmup=1)
    assert r["steps"] == 5
    assert r["particle_steps"] == 10 + 10 + 9 + 9 + 7     # timed steps 2..6
    assert r["t"] == [0.0, 1.0, 2.0, 3.0]
    assert r["discharged_kg"] == [0.0, 0.0, hl.MASS, 3 * hl.MASS]

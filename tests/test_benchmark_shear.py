"""The Lees-Edwards shear benchmark against LAMMPS (benchmarks/shear_lammps.py): what it hands LAMMPS
must be tsubu's scene. The dashpot written into the deck is the one tsubu applies to a pair, the
deck shears the cell along x over z at the rate given, the data file keeps every bit of the packing
and starts it on tsubu's mean-flow profile, the stress read from LAMMPS's log has tsubu's sign
convention, and a machine without LAMMPS gets a message, not a traceback. (The runs themselves are
benchmarks, not tests: they need the lmp binary.)"""

import os
import re
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "benchmarks"))

import shear_lammps as sl  # noqa: E402

import tsubu  # noqa: E402


def _measured_pair_eta() -> float:
    """The normal dashpot tsubu applies between two of the benchmark's grains [N s/m], from one
    step's contact force: F_n = kn delta - eta v_n."""
    delta, vn = 1e-6, -0.02
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    sim.add_spheres([[0, 0, 0], [sl.D - delta, 0, 0]], sl.R, sl.material(),
                    velocities=[[-vn / 2, 0, 0], [vn / 2, 0, 0]])
    sim.run(steps=1)
    c = sim.contacts()
    sign = -1.0 if int(np.asarray(c["i"])[0]) == 0 else 1.0
    fn = sign * float(np.asarray(c["force"])[0][0])
    return (sl.KN * delta - fn) / vn


def test_the_decks_damping_is_the_dashpot_tsubu_applies_to_a_pair():
    v = sl.lammps_vars(dt=1e-6, rate=3.0, steps=10, every=5)
    # gran/hooke/history multiplies gamma_n [1/s] by m_eff = m/2 for two equal grains.
    assert float(v["gnp"]) * sl.MASS / 2 == pytest.approx(_measured_pair_eta(), rel=1e-9)
    assert float(v["kn"]) == sl.KN and float(v["kt"]) == sl.KT and float(v["mu"]) == sl.MU
    assert float(v["kt"]) == sl.material().kt
    assert float(v["rate"]) == 3.0 and float(v["dt"]) == 1e-6 and float(v["skin"]) == sl.SKIN


def test_the_deck_uses_the_hooke_history_law_without_tangential_damping_and_shears_xz():
    with open(sl.DECK) as fh:
        deck = fh.read()
    code = "\n".join(line.split("#")[0] for line in deck.splitlines())
    assert re.search(r"pair_style\s+gran/hooke/history \$\{kn\} \$\{kt\} \$\{gnp\} 0\.0 \$\{mu\} 0\s", code)
    assert re.search(r"boundary\s+p p p", code)
    assert re.search(r"fix\s+\w+ all deform 1 xz erate \$\{rate\} remap v", code)
    assert re.search(r"fix\s+\w+ all nve/sphere", code)
    assert "gravity" not in code
    assert re.search(r"compute\s+pv all pressure NULL virial", code)


def test_the_data_file_keeps_every_bit_of_the_packing_on_tsubus_mean_flow(tmp_path):
    rng = np.random.default_rng(5)
    length = 0.04
    state = {"x": rng.uniform(0, length, size=(7, 3)), "L": length}
    path = tmp_path / "shear.data"
    sl.write_data(str(path), state, rate=4.0)
    text = path.read_text()
    atoms = text.split("Atoms # sphere\n\n")[1].split("\n\nVelocities")[0]
    velocities = text.split("Velocities\n\n")[1]
    a = np.array([[float(t) for t in line.split()] for line in atoms.strip().splitlines()])
    v = np.array([[float(t) for t in line.split()] for line in velocities.strip().splitlines()])
    assert np.array_equal(a[:, 0], np.arange(1, 8)) and np.all(a[:, 1] == 1)
    assert np.all(a[:, 2] == sl.D) and np.all(a[:, 3] == sl.RHO)
    assert np.array_equal(a[:, 4:], state["x"])
    # u_x = rate (z - L/2): tsubu's set_shear flow, centred on the box; no spin.
    assert np.array_equal(v[:, 1], 4.0 * (state["x"][:, 2] - 0.5 * length))
    assert np.all(v[:, 2:] == 0.0)
    assert "0.0 0.0 0.0 xy xz yz" in text            # triclinic (fix deform on xz needs it)
    assert f"0.0 {length!r} zlo zhi" in text


def test_the_lammps_stress_is_read_with_tsubus_sign_convention():
    # thermo: step time p pxx pyy pzz pxy pxz pyz xz; LAMMPS's P = -sigma, so tau = sigma_xz = -pxz.
    log = ("Step Time c_pv c_pv[1] c_pv[2] c_pv[3] c_pv[4] c_pv[5] c_pv[6] Xz \n"
           "       0            0 3 2 3 4 0 -1.5 0 0\n"
           "      10      1e-05 6 5 6 7 0 -2.5 0 1e-6\n"
           "Loop time of 0.5 on 1 procs for 10 steps with 100 atoms\n")
    loop, rows = sl.parse_lammps_log(log)
    assert loop == {"loop_s": 0.5, "steps": 10, "atoms": 100}
    assert rows.shape == (2, 10) and rows[1, 2] == 6.0 and rows[1, 7] == -2.5
    m = sl.mean_stress(rows[:, 0], rows[:, 2], -rows[:, 7], steps=10, average=0.5)
    assert m == {"p_mean": 6.0, "tau_mean": 2.5, "mu": 2.5 / 6.0, "samples": 1}


def test_the_kinetic_stress_removes_the_mean_flow():
    class Moving:                 # two grains: one on the profile, one 1 m/s faster along y
        positions = np.array([[0.0, 0.0, 0.3], [0.0, 0.0, 0.7]])
        velocities = np.array([[2.0 * (0.3 - 0.5), 0.0, 0.0], [2.0 * (0.7 - 0.5), 1.0, 0.0]])
        masses = np.array([1.0, 3.0])

    k = sl.kinetic_stress(Moving(), length=1.0, rate=2.0)
    expected = np.zeros((3, 3))
    expected[1, 1] = -3.0                                      # -(1/V) m v'_y v'_y
    assert np.allclose(k, expected, atol=1e-15)


def test_the_inertial_number_is_rate_d_over_sqrt_p_over_rho():
    assert sl.inertial_number(5.0, sl.RHO * 4.0) == pytest.approx(5.0 * sl.D / 2.0, rel=1e-15)


def test_without_lammps_the_benchmark_says_so_and_exits_2(monkeypatch, capsys):
    monkeypatch.setattr(sl.shutil, "which", lambda name: None)
    assert sl.main(["--only", "lammps"]) == 2
    assert "lmp is not installed" in capsys.readouterr().out


def test_the_cells_side_holds_the_spheres_at_the_solid_fraction():
    length = sl.side(10000, 0.6)
    assert 10000 * 4.0 / 3.0 * np.pi * sl.R ** 3 / length ** 3 == pytest.approx(0.6, rel=1e-12)
    assert length > 2 * (2 * sl.D + sl.SKIN)          # long enough for set_box's periodic check

"""The examples in examples/, each in its reduced --quick mode: they run, write their output, and
their physics result holds (a few seconds each). The figures need matplotlib (the bench extra):
drawn from the written output when it is installed."""

from __future__ import annotations

import importlib.util
import json
import math
import pathlib
import sys

import numpy as np
import pytest

EXAMPLES = pathlib.Path(__file__).resolve().parent.parent / "examples"
sys.path.insert(0, str(EXAMPLES))  # the scripts import example_support from their folder, as when run
from example_support import read_npz  # noqa: E402


def load_example(name: str):
    """The example script as a module (examples/ is not a package)."""
    spec = importlib.util.spec_from_file_location(f"tsubu_example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def draw_figure(module, out: pathlib.Path) -> None:
    """The figure from the output folder alone, when matplotlib is there."""
    pytest.importorskip("matplotlib")
    figure = out / "figure.png"
    module.plot(str(out), str(figure))
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def oblique(tmp_path_factory):
    out = tmp_path_factory.mktemp("oblique_collision")
    module = load_example("oblique_collision")
    return module, module.main(["--quick", "--no-figure", "--out", str(out)]), out


def test_oblique_collision_normal_force_is_hertz(oblique):
    module, summary, out = oblique
    assert set(summary) == {f"{rule} {a:g}" for rule in module.SLIP_RULES for a in module.ANGLES}
    for key, s in summary.items():
        # Head-on (10 and 30 degrees) the peak is Hertz's to 0.1 %; at 75 degrees the line of
        # centres turns during the contact and the normal approach slows: 0.6 % below.
        assert abs(s["peak_force_error"]) < (0.01 if key.endswith(" 75") else 1e-3), (key, s)
        # The duration is counted in steps of t_c/50.
        assert abs(s["duration_error"]) <= 1.5 / 50, (key, s)


def test_oblique_collision_friction_obeys_coulomb(oblique):
    module, summary, out = oblique
    for key, s in summary.items():
        assert s["max_friction_ratio"] <= 1.0 + 1e-9, (key, s)
    # Beyond the rigid-body threshold (64.5 degrees) the contact slides throughout; at 10
    # degrees it sticks most of the time and the tangential force reverses.
    assert summary["truncate 75"]["sliding_fraction"] == 1.0
    assert summary["frozen 75"]["sliding_fraction"] > 0.9
    for rule in module.SLIP_RULES:
        assert summary[f"{rule} 10"]["sliding_fraction"] < 0.2
        assert summary[f"{rule} 10"]["force_reverses"]
        assert not summary[f"{rule} 75"]["force_reverses"]


def test_oblique_collision_output_files(oblique):
    module, summary, out = oblique
    assert json.loads((out / "oblique_collision.json").read_text()) == summary
    for rule in module.SLIP_RULES:
        data = np.loadtxt(out / f"oblique_collision_{rule}.csv", delimiter=",", skiprows=1)
        assert sorted(np.unique(data[:, 0])) == sorted(module.ANGLES)
        assert np.all(data[:, 2] >= 0) and np.all(np.isfinite(data))
        peak = max(data[data[:, 0] == 10.0, 3])
        assert math.isclose(peak, summary[f"{rule} 10"]["peak_normal_force"])
    draw_figure(module, out)


@pytest.mark.slow
def test_column_collapse_run_out(tmp_path):
    module = load_example("column_collapse")
    (s,) = module.main(["--quick", "--no-figure", "--out", str(tmp_path)])
    assert s["at_rest"] and not s["gate_touched"]
    assert 0.8 < s["aspect_ratio"] < 1.05
    # Lube et al. (2005): 1.2 a. This column is 6 grains wide (finite size): within a factor 2.
    assert 0.6 * s["aspect_ratio"] < s["normalised_run_out"] < 2.4 * s["aspect_ratio"], s
    # The column has spread: lower than it was, and no grain left the channel.
    assert s["final_height"] < 0.95 * s["height"]
    data = read_npz(tmp_path / "column_a1.npz")
    final = data["final_positions"]
    assert len(final) == s["grains"] and np.all(final[:, 2] > 0)
    assert np.all((final[:, 1] > 0) & (final[:, 1] < s["width"]))
    assert np.all(final[:, 0] > 0) and final[:, 0].max() < s["gate_position"]
    assert s["run_out"] <= s["farthest_grain"] + 1e-12
    draw_figure(module, tmp_path)


@pytest.mark.slow
def test_pouring_heap(tmp_path):
    module = load_example("pouring_heap")
    s = module.main(["--quick", "--no-figure", "--out", str(tmp_path)])
    assert s["at_rest"] and s["grains"] == s["inserted"] == 300
    data = read_npz(tmp_path / "pouring_heap.npz")
    x, r = data["positions"], data["radii"]
    assert np.all((r >= module.SIZES.min_radius) & (r <= module.SIZES.max_radius))
    assert math.isclose(s["inserted_mass"], float(np.sum(module.DENSITY * 4 / 3 * math.pi * r ** 3)),
                        rel_tol=1e-12)
    assert np.all(x[:, 2] > 0.9 * r) and np.all((x[:, 1] > 0) & (x[:, 1] < module.WIDTH))
    # A heap, not a layer: both flanks stand at an angle of repose of beads (20-35 degrees,
    # within the noise of a 300-bead heap), and it is several grains high.
    assert 12 < s["angle_left"] < 45 and 12 < s["angle_right"] < 45, s
    assert s["heap_height"] > 4 * s["mean_diameter"]
    # A random packing of beads between flat walls: looser than random close packing (0.64).
    assert 0.45 < s["mean_packing_fraction"] < 0.64, s
    draw_figure(module, tmp_path)


def test_pouring_heap_slices_add_up_to_the_spheres():
    module = load_example("pouring_heap")
    zc, r = np.array([0.3, 1.0, 2.2]), np.array([0.5, 0.25, 1.0])
    edges = np.linspace(-2.0, 4.0, 14)
    total = sum(module.segment_volume(zc, r, a, b) for a, b in zip(edges[:-1], edges[1:]))
    assert np.allclose(total, 4 / 3 * math.pi * r ** 3, rtol=1e-12)


SCENES = EXAMPLES / "scenes"


@pytest.mark.parametrize("name, spheres", [("oblique_collision", 2), ("pouring_heap", 0),
                                           ("column_collapse", 449), ("periodic_shear", 276)])
def test_example_scene_files_load(name, spheres, tmp_path):
    scene_module = pytest.importorskip("tsubu.scene")
    scene = scene_module.load_scene(SCENES / f"{name}.toml", output_directory=tmp_path)
    assert scene.simulation.size == spheres
    assert scene.end_time > 0


def test_oblique_collision_scene_matches_the_script(tmp_path):
    """The scene file's 30-degree impact gives the script's peak normal force."""
    scene_module = pytest.importorskip("tsubu.scene")
    scene = scene_module.load_scene(SCENES / "oblique_collision.toml", output_directory=tmp_path)
    sim = scene.simulation
    assert np.allclose(sim.positions, [[0, 0, 0], [0.02, 0, 0]], atol=1e-15)
    peak = 0.0
    while sim.time < scene.end_time - 0.5 * sim.dt:
        sim.run(steps=1)
        c = sim.contacts()
        if len(c["i"]):
            peak = max(peak, -float(c["force"][0, 0]))  # almost along -x: the line of centres
    module = load_example("oblique_collision")
    _, f_ref, _ = module.hertz_impact(math.cos(math.radians(30.0)))
    assert abs(peak / f_ref.max() - 1) < 2e-3


@pytest.mark.slow
def test_hopper_discharges_faster_through_a_wider_slot(tmp_path):
    """The quick hopper (about 400 beads, slots of 4 d and 6 d): beads leave at a steady,
    positive rate that grows with the slot as Beverloo's slot law allows."""
    module = load_example("hopper")
    s = module.main(["--quick", "--no-figure", "--out", str(tmp_path)])
    narrow, wide = s["runs"]
    assert (narrow["width_ratio"], wide["width_ratio"]) == (4.0, 6.0)
    for run in s["runs"]:
        assert run["flow_rate"] > 0, run
        # A settled random pack in a slab: between loose random packing and close packing.
        assert 0.45 < run["solid_fraction"] < 0.64, run
        data = read_npz(tmp_path / f"hopper_D{run['width_ratio']:g}.npz")
        m = data["discharged"]
        assert m[0] == 0 and np.all(np.diff(m) >= 0) and m[-1] <= run["total_mass"]
        assert m[-1] > 0.2 * run["total_mass"]
        # The line fits the steady discharge: within 10 % of the mass it covers.
        t = data["times"]
        used = (t >= run["fit_range"][0]) & (t <= run["fit_range"][1])
        residual = m[used] - (run["fit_intercept"] + run["flow_rate"] * t[used])
        assert np.max(np.abs(residual)) < 0.1 * (m[used].max() - m[used].min()), run
    # W ~ (D - k d)^(3/2): W(6 d)/W(4 d) is 1.84 for k = 0 and 15.6 for k = 3.
    assert 1.5 < wide["flow_rate"] / narrow["flow_rate"] < 16, s
    assert 0 < s["k"] < 3.5 and s["C"] > 0, s
    draw_figure(module, tmp_path)


def test_hopper_beverloo_fit_recovers_the_law():
    module = load_example("hopper")
    widths = np.array([4.0, 5.0, 6.0, 7.0]) * module.DIAMETER
    rates = module.beverloo(widths, 0.7, 1.8, 1500.0, 0.01)
    c, k = module.fit_beverloo(widths, rates, 1500.0, 0.01)
    assert math.isclose(c, 0.7, rel_tol=1e-9) and math.isclose(k, 1.8, rel_tol=1e-9)


def test_hopper_counts_the_beads_its_outlet_removes():
    """The discharged mass is that of the beads below the slot plus those the outlet (a plane
    OUTLET_BELOW d below the slot) removed: a bead above, one between, one that falls through
    the outlet's plane during the chunk."""
    import tsubu

    module = load_example("hopper")
    grain, _ = module.materials()
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    d = module.DIAMETER
    below = module.OUTLET_BELOW * d
    sim.add_spheres([(0, 0, 5 * d), (2 * d, 0, -2 * d), (4 * d, 0, -below + 0.1 * d)], d / 2, grain,
                    velocities=[(0, 0, 0), (0, 0, 0), (0, 0, -1)])
    gate = sim.add_plane(point=(0, 0, 20 * d), normal=(0, 0, -1), material=grain)
    result = module.discharge(sim, gate, {}, duration=module.CHUNK, snapshot_at=1.0)
    m = module.bead_mass() if hasattr(module, "bead_mass") else result["total_mass"] / 3
    assert sim.size == 2 and sim.removed()["id"].tolist() == [2]
    assert result["discharged"][-1] == pytest.approx(2 * m, rel=1e-12)

@pytest.mark.slow
def test_drum_torque_resists_the_spin(tmp_path):
    """The quick drum (about 150 beads) turning about +y at two speeds: the spheres' torque on
    it is against the spin (the driving torque is positive), and the drum's torque balances the
    moment of the bed's weight, lifted on the side the wall rises."""
    module = load_example("drum")
    s = module.main(["--quick", "--no-figure", "--out", str(tmp_path)])
    for run in s["runs"]:
        assert run["omega"] > 0
        assert run["torque"] > 0, run
        # Lifted toward -x (the wall moves up on that side): M g x_c < 0, so the balance > 0.
        assert run["torque_balance"] > 0
        assert abs(run["torque"] / run["torque_balance"] - 1) < 0.25, run
        # A dynamic angle of repose of beads (the quick drum is 16 beads across: noisy), and
        # the bed turns with the rough lining, not slipping on it.
        assert 20 < run["angle"] < 55 and 15 < run["principal_angle"] < 60, run
        assert run["bed_rotation"] > 0.9, run
        data = read_npz(tmp_path / f"drum_Fr{s['runs'].index(run)}.npz")
        # Every bead is in the drum: within its radius R (the flat faces are nearer), less
        # overlaps under 5 % of d; between the caps.
        x = data["positions"]
        assert np.all(np.hypot(x[:, 0], x[:, 2]) + data["radii"] < s["radius"] + 0.05 * module.DIAMETER)
        assert np.all(np.abs(x[:, 1]) + data["radii"] < 0.5 * s["length"] + 0.05 * module.DIAMETER)
    draw_figure(module, tmp_path)


def test_drum_surface_fit_finds_a_tilted_surface():
    module = load_example("drum")
    d = module.DIAMETER
    # A tilted slab of a square lattice whose top rises toward -x at 30 degrees.
    i, j = np.meshgrid(np.arange(-20, 21), np.arange(-10, 1))
    x = np.stack([i.ravel() * d / 2, np.zeros(i.size), j.ravel() * d / 2], axis=1)
    x[:, 2] -= np.tan(np.radians(30)) * x[:, 0]
    angle, *_ = module.surface_fit(x, np.full(len(x), d / 4), 1.0)
    assert abs(angle - 30) < 2
    assert abs(module.principal_angle(x, np.ones(len(x))) - 30) < 5
    assert math.isclose(module.segment_area(1.0, module.segment_level(1.0, 0.35)), 0.35 * math.pi,
                        rel_tol=1e-9)


@pytest.mark.slow
def test_chute_flows_down_the_incline_over_its_rough_base(tmp_path):
    """The quick chute (a 6 d x 6 d periodic base, about 240 spheres, 24 and 26 degrees, 15 tau
    each): the layer flows along x over the fixed base without a sphere getting through it,
    faster at the top, with a dense bulk under a looser surface, and the Bagnold fit and the
    figure come out of the written files."""
    module = load_example("chute")
    s = module.main(["--quick", "--no-figure", "--out", str(tmp_path)])
    assert json.loads((tmp_path / "chute.json").read_text()) == s
    assert [run["angle"] for run in s["runs"]] == [24.0, 26.0]
    assert s["base_spheres"] > 0.5 * 36 / (math.pi / 4) and s["free_spheres"] > 200
    for run in s["runs"]:
        data = read_npz(tmp_path / f"chute_theta{run['angle']:g}.npz")
        x, fixed = data["positions"], data["fixed"]
        # The glued base stayed where it was (centres d/2 above the board); every free sphere
        # is above the board and inside the periodic cell (wrapped, up to the lists' skin).
        assert fixed.sum() == s["base_spheres"] and np.all(x[fixed, 2] == 0.5)
        assert run["lowest_free_sphere"] > 0.45 and np.all(x[~fixed, 2] > 0.45)
        assert np.all((x[:, :2] > -0.5) & (x[:, :2] < np.array(s["base"]) + 0.5))
        # Downhill along x, none across: the mean v_y is noise next to v_x.
        v = data["velocities"][~fixed]
        assert run["mean_velocity"] > 0.3 and abs(v[:, 1].mean()) < 0.2 * run["mean_velocity"]
        # Faster at the top than near the base; a dense bulk under the surface.
        z, vx = data["z"], data["vx"]
        near_base = vx[(z > 0) & (z < 1.5)]
        near_top = vx[(z > run["surface_height"] - 2) & (z < run["surface_height"])]
        assert np.nanmean(near_top) > 2 * np.nanmean(near_base) > 0
        assert 0.5 < run["phi_bulk"] < 0.65 and 4 < run["surface_height"] < 8, run
        assert data["phi"][z > run["surface_height"] + 1.5].max() < 0.5 * run["phi_bulk"]
        assert run["bagnold_A"] > 0 and run["bagnold_residual"] < 0.25, run
    draw_figure(module, tmp_path)


def test_chute_bagnold_fit_recovers_the_profile():
    """A Bagnold profile sampled in slabs (with a looser surface layer above h) gives back its
    A with no residual; the surface is found where phi falls to half its bulk value."""
    module = load_example("chute")
    d = module.DIAMETER
    z = (np.arange(40) + 0.5) * 0.5 * d - d
    h = 12.3 * d
    v = module.bagnold(z, 0.7, h)
    a, residual = module.fit_bagnold(z, v, h)
    assert math.isclose(a, 0.7, rel_tol=1e-12) and residual < 1e-12
    phi = np.where(z < h, 0.58, 0.0)
    phi[np.argmin(np.abs(z - h))] = 0.29  # the slab at the surface, half full
    found, bulk = module.surface_and_bulk(z, phi)
    assert bulk == pytest.approx(0.58) and abs(found - z[np.argmin(np.abs(z - h))]) < 0.26 * d


def test_chute_base_leaves_no_room_for_a_sphere():
    """The random monolayer of the base is saturated: no point of a grid over the periodic
    rectangle is as far as d from every centre (no sphere fits on the board between them), and
    no two discs overlap (across the faces too)."""
    module = load_example("chute")
    d = module.DIAMETER
    size = np.array([7 * d, 5 * d])
    c = module.rough_base(*size, seed=3)
    gap = c[:, None] - c[None]
    gap -= np.round(gap / size) * size
    dist = np.sqrt((gap ** 2).sum(-1)) + np.eye(len(c)) * d
    assert dist.min() >= d * (1 - 1e-12)
    gx, gy = np.meshgrid(np.linspace(0, size[0], 141), np.linspace(0, size[1], 101))
    p = np.column_stack([gx.ravel(), gy.ravel()])
    gap = p[:, None] - c[None]
    gap -= np.round(gap / size) * size
    assert np.sqrt((gap ** 2).sum(-1)).min(1).max() < d
    assert 0.5 < len(c) * math.pi / 4 * d * d / (size[0] * size[1]) < 0.6


def test_chute_steadiness_test_tells_a_plateau_from_a_rise():
    """A kinetic energy flat within noise passes; one rising by 10 % over the window does not;
    too short a record is never steady."""
    module = load_example("chute")
    tau, window = module.TAU, module.STEADY_WINDOW
    t = np.arange(1, 121) * tau
    noise = 0.01 * np.sin(np.arange(120) * 2.1)
    assert module.steady(t, 3.0 + noise)[0]
    rising = 3.0 * (1 + 0.1 * (t - t[-1] + window * tau) / (window * tau)) + noise
    flat, change = module.steady(t, rising)
    assert not flat and change == pytest.approx(0.1, rel=0.1)
    assert not module.steady(t[:10], np.full(10, 3.0))[0]


def test_mu_of_i_quick_cell_flows_at_the_target_pressure(tmp_path):
    """The quick mu(I) run (500 spheres, I = 0.03, 0.1, 0.3, strain 0.5): each cell shears at
    about the target normal stress, mu = tau/p is a granular friction that grows with I, the
    solid fraction falls with I, and the output holds what the figure needs."""
    module = load_example("mu_of_i")
    s = module.main(["--quick", "--no-figure", "--threads", "1", "--out", str(tmp_path)])
    points = s["points"]
    assert [p["target_inertial"] for p in points] == [0.03, 0.1, 0.3]
    for p in points:
        # The pressure control holds -sigma_zz near 5 kPa (it is still settling in so short a run).
        assert 0.5 < p["pressure"] / s["pressure_target"] < 2.0, p
        assert 0.6 < p["inertial"] / p["target_inertial"] < 1.5, p
        # Shear stress with the sign of the rate; mu within the range of dense granular flows.
        assert p["tau"] > 0 and 0.25 < p["mu"] < 0.8, p
        assert 0.5 < p["phi"] < 0.62 and p["mu_error"] >= 0 and p["phi_error"] >= 0, p
        # The tensor is symmetric within the flow's noise.
        assert abs(p["tau_zx"] - p["tau"]) < 0.2 * p["tau"], p
    assert points[-1]["mu"] > points[0]["mu"] + 0.05
    assert points[-1]["phi"] < points[0]["phi"] - 0.01
    data = read_npz(tmp_path / "mu_of_i_2.npz")
    assert data["samples"].shape == (round(0.5 / module.SAMPLE), 6)
    assert json.loads((tmp_path / "mu_of_i.json").read_text())["fit"] == s["fit"]
    draw_figure(module, tmp_path)


def test_mu_of_i_fit_recovers_the_law():
    module = load_example("mu_of_i")
    i = np.logspace(-3, math.log10(0.3), 6)
    mu = module.mu_law(i, 0.38, 0.64, 0.28)
    mu_s, mu_2, i_0 = module.fit_mu(i, mu)
    assert math.isclose(mu_s, 0.38, rel_tol=1e-3) and math.isclose(mu_2, 0.64, rel_tol=1e-3)
    assert math.isclose(i_0, 0.28, rel_tol=1e-2)
    # The rate that makes I: I = rate d / sqrt(p / rho).
    rate = module.shear_rate(0.01, 5000.0)
    assert math.isclose(rate * module.D / math.sqrt(5000.0 / module.RHO), 0.01, rel_tol=1e-12)

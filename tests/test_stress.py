"""The stress tensor (Simulation.stress, docs/stress.md): Love-Weber averaging.

    sigma V = sum_i [ -m_i v'_i (x) v'_i + sum_{c of i} (x_c - x_i) (x) f_c ]

(Love 1927, Weber 1966; e.g. Andreotti, Forterre & Pouliquen, "Granular Media" (2013), sec. 2.3),
tension positive. Summed over a pair's two contacts at one point x_c the pair terms cancel
(f_ji = -f_ij), so the contact part equals what crosses the boundary: with F_i the contact
force on sphere i,

    sum_i sum_c (x_c - x_i) (x) f_c = sum_{wall contacts} x_c (x) f_c - sum_i x_i (x) F_i,

and at equilibrium F_i = -m_i g: the walls' loads and the weight set the stress.
"""
import math

import numpy as np
import pytest

import tsubu

G = 9.81


def walled_pack(gravity=True, friction=0.0, seed=3, **options):
    """64 slightly polydisperse spheres (r 0.8-0.85 mm), off a 2 mm lattice by up to 0.15 mm
    sideways (so that they settle into a disordered pack that pushes on the side walls), in a
    8 x 8 mm box of six planes, the lid at 12 mm; returns sim, material, walls {name: index}."""
    mat = tsubu.Material(density=2500, kn=1e4, restitution=0.3, friction=friction)
    sim = tsubu.Simulation(gravity=(0, 0, -G) if gravity else (0, 0, 0), **options)
    rng = np.random.default_rng(seed)
    g = (np.arange(4) + 0.5) * 0.002 - 0.004
    X, Y, Z = np.meshgrid(g, g, 0.0011 + 0.0022 * np.arange(4), indexing="ij")
    pos = np.stack([X.ravel(), Y.ravel(), Z.ravel()], 1)
    pos[:, :2] += rng.uniform(-0.15e-3, 0.15e-3, (len(pos), 2))
    sim.add_spheres(pos, rng.uniform(0.8e-3, 0.85e-3, len(pos)), mat)
    walls = {"floor": sim.add_plane((0, 0, 0), (0, 0, 1), mat)}
    for name, p, n in [("x-", (-0.004, 0, 0), (1, 0, 0)), ("x+", (0.004, 0, 0), (-1, 0, 0)),
                       ("y-", (0, -0.004, 0), (0, 1, 0)), ("y+", (0, 0.004, 0), (0, -1, 0))]:
        walls[name] = sim.add_plane(p, n, mat)
    walls["lid"] = sim.add_plane((0, 0, 0.012), (0, 0, -1), mat)
    return sim, mat, walls


def contact_force_sums(sim):
    """F_i: each sphere's contact forces, what forces() holds less the weight."""
    return sim.forces - sim.masses[:, None] * np.asarray(sim.gravity)[None, :]


def boundary_sum(sim):
    """sum over wall contacts of x_c (x) f_c, and minus sum_i x_i (x) F_i."""
    c = sim.contacts()
    w = c["wall"] >= 0
    walls = np.einsum("ka,kb->ab", c["wall_point"][w], c["force"][w])
    bodies = -np.einsum("ia,ib->ab", sim.positions, contact_force_sums(sim))
    return walls, bodies


def kinetic(sim):
    v = sim.velocities
    return -np.einsum("i,ia,ib->ab", sim.masses, v, v)


def test_settled_pack_love_sum_equals_wall_loads_plus_weight():
    sim, mat, walls = walled_pack(gravity=True)
    sim.run(time=0.3)
    V = 0.008 * 0.008 * 0.012
    sigma = sim.stress(volume=V)
    contact = sigma * V - kinetic(sim)
    walls_term, bodies_term = boundary_sum(sim)
    scale = np.abs(walls_term).max()
    # The identity, at any instant: pair terms cancel exactly (one contact point per pair).
    np.testing.assert_allclose(contact, walls_term + bodies_term, rtol=0, atol=1e-12 * scale)
    # At equilibrium F_i = -m_i g: the walls and the weight alone, to the residual force.
    m, x = sim.masses, sim.positions
    weight_term = np.einsum("ia,i,b->ab", x, m, np.asarray(sim.gravity))
    residual = np.abs(x).max() * np.abs(sim.forces).sum()
    assert residual < 1e-2 * scale  # settled
    np.testing.assert_allclose(contact, walls_term + weight_term, rtol=0, atol=residual + 1e-12 * scale)
    # Frictionless walls: the floor (at z = 0) and the side walls add no z z moment, so
    # sigma_zz V = -W z_cm (a hydrostatic column: -rho g A h^2 / 2), W the floor's load.
    floor_load = -sim.wall_forces()[walls["floor"]][2]
    assert floor_load == pytest.approx(m.sum() * G, rel=1e-3)
    z_cm = (m * x[:, 2]).sum() / m.sum()
    assert sigma[2, 2] * V == pytest.approx(-floor_load * z_cm, rel=1e-3)
    # Lateral: the x walls' thrust times their distance.
    fx = sim.wall_forces()[walls["x+"]][0]
    assert fx > 0 and sigma[0, 0] * V == pytest.approx(-fx * 0.008, rel=1e-3)
    assert sim.pressure(volume=V) == pytest.approx(-np.trace(sigma) / 3)


def test_a_servo_lid_sets_the_normal_stress_and_the_side_walls_the_lateral_ones():
    sim, mat, walls = walled_pack(gravity=False)
    F = 0.5  # N
    sim.set_wall_servo(walls["lid"], force=F, max_speed=0.05)
    sim.run(time=0.25)
    h = sim.wall(walls["lid"])["point"][2]  # the floor is at z = 0
    A = 0.008 * 0.008
    sigma = sim.stress(volume=A * h)
    loads = sim.wall_forces()
    assert sigma[2, 2] == pytest.approx(-F / A, rel=1e-3)
    assert sigma[0, 0] == pytest.approx(-loads[walls["x+"]][0] / (0.008 * h), rel=1e-3)
    assert sigma[1, 1] == pytest.approx(-loads[walls["y+"]][1] / (0.008 * h), rel=1e-3)
    assert sigma[0, 0] < 0 and sigma[1, 1] < 0


def test_a_static_frictionless_pack_has_a_symmetric_stress_and_per_particle_sums_to_it():
    sim, mat, walls = walled_pack(gravity=False)
    sim.set_wall_servo(walls["lid"], force=0.5, max_speed=0.05)
    sim.run(time=0.25)
    V = 1e-6
    sigma = sim.stress(volume=V)
    # Central forces along the line of centres: (x_c - x_i) and f_c are parallel, up to the
    # drift of one step and round-off.
    assert np.abs(sigma - sigma.T).max() < 1e-6 * np.abs(sigma).max()
    per = sim.stress(per_particle=True)
    assert per.shape == (len(sim), 3, 3)
    np.testing.assert_allclose(per.sum(axis=0), sigma * V, rtol=0, atol=1e-13 * np.abs(sigma * V).max())
    assert np.array_equal(sim.stress(volume=V, per_particle=True), per)  # no volume in the brackets


def two_pressed_spheres(radii, delta, n, *, shift=(0.0, 0.0, 0.0)):
    mat = tsubu.Material(density=2500, kn=1e4, restitution=0.5, friction=0.0)
    sim = tsubu.Simulation(gravity=(0, 0, 0), initial_overlap=0.5)
    n = np.asarray(n, float) / np.linalg.norm(n)
    d0 = radii[0] + radii[1] - delta
    a = np.asarray(shift, float)
    sim.add_spheres(np.array([a, a + d0 * n]), np.array(radii), mat)
    return sim, mat, n


def test_two_spheres_pressed_together_have_the_closed_form_stress():
    r, delta = (1e-3, 0.6e-3), 2e-6
    sim, mat, n = two_pressed_spheres(r, delta, (1, 2, 2))
    sim.run(steps=1)
    k, dt = sim.pair_parameters(mat, mat)["kn"], sim.dt
    m = sim.masses
    f = k * delta  # the repulsion evaluated at the start of the step (at rest: no dashpot)
    # One symplectic Euler step: v_i = -/+ f dt / m_i along n, x += dt v.
    v = f * dt / m
    d = r[0] + r[1] - delta + dt * (v[0] + v[1])
    # sigma V = -sum m v (x) v + (x_c - x_i) (x) f_i + (x_c - x_j) (x) f_j = -(m v^2 + d f) n (x) n
    expected = -((m * v * v).sum() + d * f) * np.outer(n, n)
    V = 2e-9
    np.testing.assert_allclose(sim.stress(volume=V) * V, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
    # Each sphere's share: its lever c = r - delta/2 of the branch vector.
    c = np.array(r) - delta / 2
    per = sim.stress(per_particle=True)
    for i in range(2):
        share = -(m[i] * v[i] ** 2 + c[i] / c.sum() * d * f) * np.outer(n, n)
        np.testing.assert_allclose(per[i], share, rtol=1e-9, atol=1e-9 * np.abs(share).max())


def test_a_gas_of_free_spheres_has_the_kinetic_stress_only():
    mat = tsubu.Material(density=2500, kn=1e4, restitution=0.5)
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    rng = np.random.default_rng(1)
    g = np.arange(5) * 0.004
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    sim.add_spheres(np.stack([X.ravel(), Y.ravel(), Z.ravel()], 1), 1e-3, mat,
                    velocities=rng.normal(0, 0.01, (125, 3)))
    V = 0.02 ** 3
    for steps in (0, 10):  # before any run, and after a few contact-free steps
        if steps:
            sim.run(steps=steps)
            assert len(sim.contacts()["i"]) == 0
        np.testing.assert_allclose(sim.stress(volume=V), kinetic(sim) / V, rtol=1e-13, atol=0)


def test_a_periodic_box_gives_the_volume_and_a_contact_across_a_face_counts_once():
    # The same pressed pair inside a fully periodic box and straddling its x faces (through a
    # ghost image): the same stress, divided by the box's volume without being told it.
    L = 0.012
    r, delta = (1e-3, 1e-3), 2e-6
    inside, mat, n = two_pressed_spheres(r, delta, (1, 0, 0), shift=(0.005, 0.006, 0.006))
    across, _, _ = two_pressed_spheres(r, delta, (1, 0, 0), shift=(L - 0.0009, 0.006, 0.006))
    for sim in (inside, across):
        sim.set_box((0, 0, 0), (L, L, L), periodic="xyz")
        sim.run(steps=3)
    assert len(across.contacts()["i"]) == 1 and across.images.any()  # one sphere wrapped
    assert across.box.volume == pytest.approx(L ** 3)
    sigma = across.stress()
    assert np.array_equal(sigma, across.stress(volume=across.box.volume))
    np.testing.assert_allclose(sigma, inside.stress(), rtol=1e-9, atol=0)
    assert sigma[0, 0] < 0 and abs(sigma[1, 1]) < 1e-12 * abs(sigma[0, 0])
    # The pair's term is -b (x) f, b = x_i - x_j the minimum image across the face.
    c = across.contacts()
    ids = across.ids
    xi, xj = (across.positions[np.searchsorted(ids, c[k][0])] for k in ("i", "j"))
    b = xi - xj
    b -= L * np.round(b / L)
    assert abs(b[0]) < 0.002
    np.testing.assert_allclose(sigma * L ** 3 - kinetic(across), -np.outer(b, c["force"][0]),
                               rtol=0, atol=1e-9 * abs(sigma[0, 0]) * L ** 3)
    np.testing.assert_allclose(across.stress(per_particle=True).sum(axis=0), sigma * L ** 3, rtol=1e-12)


def test_the_kinetic_stress_is_taken_relative_to_the_lees_edwards_mean_flow():
    # Spheres moving exactly with the mean shear flow u_x = rate (z - z_centre): no stress;
    # a fluctuation on top of it gives -m v' (x) v' / V.
    L, rate = 0.02, 3.0
    mat = tsubu.Material(density=2500, kn=1e4, restitution=0.5)
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    z = np.array([0.003, 0.008, 0.013, 0.017])
    x = np.stack([0.01 + 0 * z, 0.01 + 0 * z, z], 1)
    u = np.stack([rate * (z - L / 2), 0 * z, 0 * z], 1)
    sim.add_spheres(x, 1e-3, mat, velocities=u)
    sim.set_box((0, 0, 0), (L, L, L), periodic="xyz")
    sim.set_shear(rate, flow="x", gradient="z")
    assert np.abs(sim.stress()).max() < 1e-12 * (sim.masses.sum() * (rate * L) ** 2 / L ** 3)
    dv = np.array([0.0, 0.01, 0.0])
    sim.velocities = u + dv
    expected = -sim.masses.sum() * np.outer(dv, dv) / L ** 3
    np.testing.assert_allclose(sim.stress(), expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("volume, error", [
    (0.0, ValueError), (-1e-6, ValueError), (float("nan"), ValueError), (float("inf"), ValueError),
    ("1e-6", TypeError), ([1e-6], TypeError),
])
def test_bad_volumes_are_refused_by_name(volume, error):
    sim, _, _ = walled_pack()
    with pytest.raises(error, match="volume"):
        sim.stress(volume=volume)
    with pytest.raises(error, match="volume"):
        sim.pressure(volume=volume)


def test_a_walled_scene_needs_an_explicit_volume():
    sim, _, _ = walled_pack()
    with pytest.raises(ValueError, match="explicit volume"):
        sim.stress()
    with pytest.raises(TypeError, match="per_particle"):
        sim.stress(volume=1e-6, per_particle="yes")


def test_the_stress_is_the_same_bits_on_any_thread_count_and_its_rows_follow_the_ids():
    """The brackets are computed on the run's threads and the total is summed over the spheres in
    id order: the same bits for 1 and 2 threads. After a removal the rows hold the spheres left
    by increasing id (as every per-sphere array): a sphere with no contact has the kinetic
    bracket -m v (x) v alone, at its row."""
    results = []
    for threads in (1, 2):
        sim, mat, walls = walled_pack(friction=0.3, threads=threads, parallel_min=1)
        sim.run(time=0.05)
        sim.remove_spheres([3, 17, 40])
        far = sim.add_spheres([[0.0, 0.0, 0.0105]], 0.8e-3, mat, velocities=[[0.01, -0.02, 0.03]])
        sim.run(steps=20)
        results.append((sim.stress(volume=1e-6), sim.stress(per_particle=True)))
        row = int(np.searchsorted(sim.ids, far[0]))
        v = sim.velocities[row]
        np.testing.assert_array_equal(results[-1][1][row], np.outer(-sim.masses[row] * v, v))
        assert len(results[-1][1]) == len(sim) == 62
    for a, b in zip(results[0], results[1]):
        np.testing.assert_array_equal(a, b)

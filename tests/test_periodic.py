"""Periodic boxes and Lees-Edwards shear (docs/periodic.md): images as ghosts of the owned
spheres, contacts across the faces with their history, image counters, checkpoints."""

import numpy as np
import pytest

import tsubu

R = 1.0e-3  # radius [m]


def elastic():
    return tsubu.Material(density=2500.0, kn=1e4, restitution=1.0, friction=0.0)


def frictional():
    return tsubu.Material(density=2500.0, kn=1e4, restitution=0.5, friction=0.5)


def lattice(per_side: int, length: float, jitter: float = 0.0, seed: int = 1) -> np.ndarray:
    g = (np.arange(per_side) + 0.5) * length / per_side
    x = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    return x + np.random.default_rng(seed).normal(0.0, jitter, x.shape)


def sheared_cell(threads=1, rate=20.0):
    """512 frictional spheres nearly touching in a 16 mm periodic cube, sheared along x over z."""
    length = 0.016
    sim = tsubu.Simulation(gravity=(0, 0, 0), threads=threads)
    sim.add_spheres(lattice(8, length, 1e-5, seed=2), 0.99 * R, frictional())
    sim.set_box((0, 0, 0), (length,) * 3, "xyz")
    sim.set_shear(rate, "x", "z")
    return sim, length


def test_a_cluster_across_a_face_moves_as_the_same_cluster_inside():
    # Two spheres colliding obliquely (friction on) right on the x face follow, to round-off,
    # the trajectory of the same pair in the middle of the box shifted by the box vector.
    length = 0.02
    v = np.array([[0.3, 0.05, 0.0], [-0.3, 0.0, 0.02]])
    w = np.array([[0.0, 0.0, 40.0], [10.0, 0.0, 0.0]])

    def run(x):
        sim = tsubu.Simulation(gravity=(0, 0, 0))
        sim.add_spheres(x, R, frictional(), velocities=v, angular_velocities=w)
        sim.set_box((0, 0, 0), (length,) * 3, "xyz")
        sim.run(steps=4000)
        return sim

    centre = np.array([[0.0097, 0.01, 0.01], [0.0121, 0.0103, 0.01]])
    shift = np.array([-0.0103, 0.0, 0.0])  # the pair straddles x = 0 (sphere 0 starts outside)
    inside, edge = run(centre), run(centre + shift)
    assert np.abs(inside.velocities - edge.velocities).max() < 1e-12
    assert np.abs(inside.angular_velocities - edge.angular_velocities).max() < 1e-9
    moved = edge.unwrapped_positions - shift
    assert np.abs(moved - inside.unwrapped_positions).max() < 1e-15
    assert edge.images[0, 0] == -1  # wrapped into the box, counted


def test_an_elastic_frictionless_gas_conserves_energy_and_momentum():
    # Symplectic Euler keeps the energy within its O(dt) band (docs/physics.md, (2.2)); momentum
    # is exact to round-off: every contact force acts on both spheres, across the faces too.
    length = 0.02
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    x = lattice(6, length)
    sim.add_spheres(x, R, elastic(), velocities=np.random.default_rng(1).normal(0, 0.1, x.shape))
    sim.set_box((0, 0, 0), (length,) * 3, "xyz")
    e0 = sim.energy()["total"]
    p0 = (sim.masses[:, None] * sim.velocities).sum(0)
    sim.run(steps=100_000)
    assert abs(sim.energy()["total"] - e0) / e0 < 1e-4
    p1 = (sim.masses[:, None] * sim.velocities).sum(0)
    assert np.abs(p1 - p0).max() < 1e-12 * np.abs(sim.masses[:, None] * sim.velocities).sum()
    assert np.abs(sim.images).max() >= 1  # spheres did cross the faces
    assert np.all(sim.positions >= 0) and np.all(sim.positions < length)
    np.testing.assert_array_equal(sim.unwrapped_positions, sim.positions + sim.images * length)


def test_gravity_along_a_periodic_axis_keeps_the_energy_audit_exact():
    # A falling gas in a box periodic along z: the gravitational energy uses unwrapped heights.
    length = 0.02
    sim = tsubu.Simulation(gravity=(0, 0, -9.81))
    sim.add_spheres(lattice(4, length), R, elastic())
    sim.set_box((0, 0, 0), (length,) * 3, "xyz")
    e0 = sim.energy()["total"]
    sim.run(steps=60_000)  # ~0.07 s: each sphere falls through the box more than once
    assert sim.images[:, 2].min() <= -1
    e = sim.energy()
    assert abs(e["total"] - e0) < 1e-4 * abs(e["kinetic"])


def test_lees_edwards_reaches_the_linear_mean_profile():
    # u_x(z) = rate (z - L/2) develops from rest through the sliding images alone (no walls).
    sim, length = sheared_cell()
    rate = 20.0
    sim.run(time=0.3)
    x, v = sim.positions, sim.velocities
    edges = np.linspace(0, length, 5)
    mid = 0.5 * (edges[1:] + edges[:-1])
    u = [v[(x[:, 2] >= a) & (x[:, 2] < b), 0].mean() for a, b in zip(edges[:-1], edges[1:])]
    slope = np.polyfit(mid, u, 1)[0]
    assert 0.6 * rate < slope < 1.2 * rate
    assert np.all(np.diff(u) > 0)
    box = sim.box
    assert box.shear_rate == rate and box.flow == "x" and box.gradient == "z"


def test_same_bits_for_any_thread_count_and_through_a_checkpoint(tmp_path):
    a, _ = sheared_cell()
    a.run(steps=30_000)  # (spheres have crossed the faces and the images slid)
    assert np.abs(a.images).max() >= 1
    b = tsubu.Simulation.load(a.save(tmp_path / "cell.tsubu"))
    a.run(steps=20_000)
    b.run(steps=20_000)
    for name in ("positions", "velocities", "angular_velocities", "images"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.box.shear_offset == b.box.shear_offset
    c, _ = sheared_cell(threads=2)
    c.run(steps=50_000)
    np.testing.assert_array_equal(a.positions, c.positions)
    np.testing.assert_array_equal(a.velocities, c.velocities)


def test_bad_boxes_are_refused():
    sim = tsubu.Simulation()
    sim.add_spheres(lattice(2, 0.02), R, elastic())
    with pytest.raises(ValueError, match="upper must exceed lower"):
        sim.set_box((0, 0, 0), (0.02, 0.0, 0.02), "xyz")
    with pytest.raises(ValueError, match="periodic"):
        sim.set_box((0, 0, 0), (0.02, 0.02, 0.02), "xw")
    with pytest.raises(TypeError, match="periodic"):
        sim.set_box((0, 0, 0), (0.02, 0.02, 0.02), 3)
    with pytest.raises(ValueError, match="lower"):
        sim.set_box((0, float("nan"), 0), (0.02, 0.02, 0.02))
    with pytest.raises(ValueError, match="set_box first"):
        sim.set_shear(1.0)
    sim.set_box((0, 0, 0), (0.02, 0.02, 0.02), "xy")
    with pytest.raises(ValueError, match="gradient"):
        sim.set_shear(1.0, "x", "z")
    with pytest.raises(ValueError, match="different axes"):
        sim.set_shear(1.0, "x", "x")
    small = tsubu.Simulation()
    small.add_spheres(lattice(2, 0.0045), R, elastic())  # reach 2 r + skin = 2.4 mm
    small.set_box((0, 0, 0), (0.0045,) * 3, "xyz")
    with pytest.raises(ValueError, match="less than twice the neighbour reach"):
        small.run(steps=1)


def test_an_open_scene_has_no_box_and_zero_images():
    sim = tsubu.Simulation()
    sim.add_spheres(lattice(2, 0.02), R, elastic())
    assert sim.box is None
    np.testing.assert_array_equal(sim.images, np.zeros((8, 3)))
    np.testing.assert_array_equal(sim.unwrapped_positions, sim.positions)


def squeezed_lattice():
    """512 spheres on a simple cubic lattice 0.5 % closer than touching, in a periodic cube: each
    of the 512 z-pairs carries f = kn delta, so the normal stress along z is
    P_zz = 512 f (2 R - delta) / L^3 (Love-Weber, the contacts' virial)."""
    spacing = 1.99e-3
    length = 8 * spacing
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    sim.add_spheres(lattice(8, length), R, frictional())
    sim.set_box((0, 0, 0), (length,) * 3, "xyz")
    return sim, length, spacing


def test_the_box_pressure_of_a_squeezed_lattice_is_the_virial_closed_form():
    sim, length, spacing = squeezed_lattice()
    sim.run(steps=1)
    delta = 2 * R - spacing
    expected = 512 * (1e4 * delta) * spacing / length**3
    assert sim.box_pressure("z") == pytest.approx(expected, rel=1e-3)
    assert sim.box_pressure("z") == pytest.approx(-sim.stress()[2, 2], rel=1e-12)


def test_a_pressure_controlled_box_relaxes_to_its_target():
    # strain rate = gain (P - P*): first-order relaxation with time constant 1 / (K gain),
    # K ~ kn / d (docs/periodic.md); from 25 kPa to 5 kPa in ~6 time constants.
    sim, length, _ = squeezed_lattice()
    d = 2 * R
    gain = 4 * d / (1e4 * 20 * (length / d) * sim.contact_duration())
    sim.set_pressure(5000.0, gain=gain)
    assert sim.box.pressure == 5000.0 and sim.box.pressure_axis == "z"
    sim.run(steps=15_000)
    assert sim.box_pressure("z") == pytest.approx(5000.0, rel=0.01)
    assert sim.box.lengths[2] > length  # it expanded
    assert sim.box.lengths[0] == length  # only z


def test_a_pressure_controlled_sheared_box_resumes_bit_for_bit(tmp_path):
    a, length = sheared_cell()
    d = 2 * R
    a.set_pressure(100.0, gain=d / (1e4 * 20 * (length / d) * a.contact_duration()))
    a.run(steps=5000)
    b = tsubu.Simulation.load(a.save(tmp_path / "p.tsubu"))
    a.run(steps=5000)
    b.run(steps=5000)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.box.upper, b.box.upper)


def test_bad_pressure_control_is_refused():
    sim, _, _ = squeezed_lattice()
    with pytest.raises(ValueError, match="pressure"):
        sim.set_pressure(-1.0, gain=1e-5)
    with pytest.raises(ValueError, match="gain"):
        sim.set_pressure(1.0, gain=0.0)
    with pytest.raises(ValueError, match="axis"):
        sim.set_pressure(1.0, gain=1e-5, axis="w")
    with pytest.raises(ValueError, match="max_strain_rate"):
        sim.set_pressure(1.0, gain=1e-5, max_strain_rate=float("nan"))
    open_scene = tsubu.Simulation()
    open_scene.add_spheres(lattice(2, 0.02), R, elastic())
    with pytest.raises(ValueError, match="set_box"):
        open_scene.set_pressure(1.0, gain=1e-5)


def test_a_contact_across_a_face_is_drawn_to_the_nearest_image():
    # Two spheres pressed together across the x face: the contact network's segment runs from
    # one centre to the other's image just outside the box, one contact length long.
    length = 0.02
    sim = tsubu.Simulation(gravity=(0, 0, 0))
    sim.add_spheres([[0.0005, 0.01, 0.01], [length - 0.00149, 0.01, 0.01]], R, elastic())
    sim.set_box((0, 0, 0), (length,) * 3, "xyz")
    sim.run(steps=1)
    c = sim.contacts()
    assert len(c["i"]) == 1
    np.testing.assert_allclose(c["branch"][0], [-0.00199, 0, 0], atol=1e-7)
    net = tsubu.output.contact_data(sim)
    assert np.linalg.norm(net["end"][0] - net["start"][0]) == pytest.approx(0.00199, abs=1e-7)


def _pair_across_the_sheared_corner(slide_fraction: float, x_low: float):
    """Two spheres 1.8 mm apart (d = 2 mm) whose minimum image crosses a sheared z face: A low
    (z = 0.5 mm) at x = ``x_low``, B high (z = L - 0.5 mm) placed so that its image below (x -
    slide, modulo L) lies 1.5 mm beyond A along x. The slide is grown to ``slide_fraction`` of
    the box with the spheres far apart, then they are put in place and stepped once. Returns
    the number of contacts found."""
    length, rate = 0.02, 100.0
    sim = tsubu.Simulation(gravity=(0, 0, 0), initial_overlap=1.0)
    sim.add_spheres([(0.005, 0.01, 0.005), (0.015, 0.01, 0.015)], R, frictional())
    sim.set_box((0, 0, 0), (length,) * 3, "xyz")
    sim.set_shear(rate, "x", "z")
    sim.run(time=slide_fraction / rate)
    slide = sim.box.shear_offset
    sim.positions = [(x_low, 0.01, 0.5e-3), ((x_low + 1.5e-3 + slide) % length, 0.01, length - 0.5e-3)]
    sim.velocities = np.zeros((2, 3))
    sim.run(steps=1)
    return len(sim.contacts()["i"])


@pytest.mark.parametrize("slide_fraction, x_low", [(0.5, 0.010), (0.97, 0.010), (0.5, 0.0197),
                                                    (0.97, 0.0197)])
def test_lees_edwards_finds_a_contact_across_the_sheared_faces(slide_fraction, x_low):
    # (0.97, 0.0197): the slide is 0.97 of the box and A sits 0.3 mm below the upper x face, so
    # B's image below is x_B - slide + 2 L, just beyond that face. Before d6f610a the ghosts took
    # flow images -2..1 only and this contact was never found (examples/mu_of_i.py met it as an
    # overlap of 0.63 r at a strain of 0.98).
    assert _pair_across_the_sheared_corner(slide_fraction, x_low) == 1


def _touching_pairs_by_brute_force(sim, length, depth):
    """Every pair (lower id, higher id) whose Lees–Edwards minimum-image distance is below the sum
    of the radii less `depth`: an image of j across the gradient faces (z) is slid along the flow
    (x) by the box's shear offset."""
    x = np.asarray(sim.positions)
    r = np.asarray(sim.radii)
    ids = np.asarray(sim.ids)
    offset = sim.box.shear_offset
    d = x[:, None, :] - x[None, :, :]
    nz = np.round(d[..., 2] / length)
    d[..., 2] -= nz * length
    d[..., 0] -= nz * offset
    d[..., :2] -= length * np.round(d[..., :2] / length)
    touching = np.linalg.norm(d, axis=-1) < r[:, None] + r[None, :] - depth
    i, j = np.nonzero(np.triu(touching, 1))
    return {(min(a, b), max(a, b)) for a, b in zip(ids[i].tolist(), ids[j].tolist())}


@pytest.mark.parametrize("threads", [1, 2])
def test_a_sheared_cell_keeps_every_touching_pair_listed(threads):
    # The lists are refreshed by a displacement bound taken relative to the mean flow, which the
    # particle pass finds as it moves the spheres (ParticlePass::drift). Agitated spheres in a
    # fast shear make the lists fall due many times; a bound that fell short would leave a
    # touching pair unlisted, and so missing from contacts().
    sim, length = sheared_cell(threads, rate=200.0)
    v = np.asarray(sim.velocities) + np.random.default_rng(3).normal(0.0, 0.05, (sim.size, 3))
    sim.velocities = v
    refreshes = sim.near_refresh_count
    for _ in range(12):
        sim.run(steps=150)
        c = sim.contacts()
        listed = {(min(a, b), max(a, b)) for a, b, w in zip(c["i"], c["j"], c["wall"]) if w < 0}
        # (contacts() holds the pairs that touched when the last step's contacts were evaluated,
        # before it moved the spheres: a pair that closed in that move overlaps by less than the
        # step's largest relative displacement, far below a micrometre here.)
        missing = _touching_pairs_by_brute_force(sim, length, depth=1e-6) - listed
        assert not missing, f"touching pairs not in contacts(): {sorted(missing)[:5]}"
    assert sim.near_refresh_count - refreshes >= 10  # (the bound was used, many times)

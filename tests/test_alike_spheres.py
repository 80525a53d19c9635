"""Alike spheres share one contact cut-off and one set of the law's per-pair terms.

Where every sphere a scene holds has one radius, the near list keeps one (r_i + r_j)^2 for all
its entries, and where they also have one mass, material and mobility (fixed or free), one set of
the law's entry terms (the linear dashpot eta_n = 2 sqrt(m* k_n) beta, Hertz's sqrt(R*)), instead
of one per entry (docs/architecture.md, "The near list"). Both ways must give the same bits: a pile
of alike spheres ends the same, to the bit, whether or not a sphere that differs (in radius, in
mass, or fixed) rests far from it and so makes the lists keep a value per entry.
"""

from __future__ import annotations

import numpy as np
import pytest

import tsubu

R = 0.005  # m


def pile(odd: str | None, law: str = "linear"):
    """A 3 x 3 x 3 lattice of alike spheres dropped onto a frictional floor, sliding; `odd`: a
    sphere that differs ("radius", "density", "fixed") or is alike ("alike"), far away, added
    last (so the pile's ids are the same)."""
    glass = tsubu.Material(density=2500.0, kn=2e4, restitution=0.6, friction=0.4)
    if law == "hertz":
        glass = tsubu.Material(density=2500.0, youngs_modulus=1e8, poisson_ratio=0.3,
                               restitution=0.6, friction=0.4)
    # dt and skin fixed: their defaults follow the smallest and lightest sphere held.
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -9.81), dt=2e-5, skin=0.2 * R)
    sim.add_plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material=glass, velocity=(0.02, 0.0, 0.0))
    rng = np.random.default_rng(7)
    lattice = [(2.1 * R * i, 2.1 * R * j, R + 2.1 * R * k) for i in range(3) for j in range(3) for k in range(3)]
    sim.add_spheres(np.array(lattice) + rng.uniform(-0.02 * R, 0.02 * R, (27, 3)), R, glass,
                    velocities=rng.uniform(-0.1, 0.1, (27, 3)))  # (m/s: they collide every way)
    if odd == "radius":
        sim.add_sphere((1.0, 0.0, 1.5 * R), 1.5 * R, glass)  # (on the floor, a metre away)
    elif odd == "density":
        sim.add_sphere((1.0, 0.0, R), R, tsubu.Material(density=7800.0, kn=2e4, restitution=0.6, friction=0.4)
                       if law == "linear" else
                       tsubu.Material(density=7800.0, youngs_modulus=1e8, poisson_ratio=0.3,
                                      restitution=0.6, friction=0.4))
    elif odd in ("fixed", "alike"):
        far = sim.add_sphere((1.0, 0.0, R), R, glass)
        if odd == "fixed":
            sim.fix_spheres(far)
    sim.run(steps=3000)
    return sim


def assert_same_pile(a: tsubu.Simulation, b: tsubu.Simulation, n: int = 27):
    for name in ("positions", "velocities", "angular_velocities", "forces", "torques"):
        assert np.array_equal(getattr(a, name)[:n], getattr(b, name)[:n]), name
    ca, cb = a.contacts(), b.contacts()
    keep_a, keep_b = ca["i"] < n, cb["i"] < n
    for key in ca:
        assert np.array_equal(ca[key][keep_a], cb[key][keep_b]), key


@pytest.mark.parametrize("law", ["linear", "hertz"])
def test_the_pile_has_contacts_and_an_alike_sphere_far_away_changes_no_bit(law):
    alone = pile(None, law)
    c = alone.contacts()
    pairs = c["j"] >= 0
    assert pairs.sum() >= 10 and (~pairs).sum() >= 5  # the pile presses on itself and the floor
    assert np.abs(alone.velocities[:27]).max() > 1e-3  # and moves (the floor slides)
    assert_same_pile(alone, pile("alike", law))


@pytest.mark.parametrize("law", ["linear", "hertz"])
@pytest.mark.parametrize("odd", ["radius", "density", "fixed"])
def test_one_value_for_all_entries_gives_the_bits_of_one_per_entry(odd, law):
    assert_same_pile(pile(None, law), pile(odd, law))

"""The neighbour list against brute force.

Contract (Simulation.neighbor_pairs): after a rebuild the list holds every pair (lower id
first) with |x_i - x_j| < r_i + r_j + skin, and no other. Brute force computes the same
criterion over all N (N-1)/2 pairs with numpy.

Round-off: the engine and numpy may round |x_i - x_j|^2 and (r_i + r_j + skin)^2 differently
in the last bit, so a pair whose squared distance lies within a relative 1e-12 of the squared
cutoff may legitimately go either way. Those pairs are counted separately (and must be rare);
every other pair must agree exactly. Pairs placed on purpose at (1 -/+ 1e-9) of the cutoff,
well outside that band, check that the cutoff really is r_i + r_j + skin.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu

BAND = 1e-12  # relative band around the squared cutoff where either answer is accepted


def brute_force(x, r, skin):
    """(sure, ambiguous): sets of pairs (i < j) certainly inside the cutoff, and pairs within
    the round-off band of it."""
    n = len(r)
    i, j = np.triu_indices(n, k=1)
    d2 = np.sum((x[i] - x[j]) ** 2, axis=1)
    cut2 = (r[i] + r[j] + skin) ** 2
    sure = d2 < cut2 * (1.0 - BAND)
    ambiguous = np.abs(d2 - cut2) <= cut2 * BAND
    return (set(zip(i[sure].tolist(), j[sure].tolist())),
            set(zip(i[ambiguous].tolist(), j[ambiguous].tolist())))


def listed_pairs(sim):
    p = sim.neighbor_pairs()
    assert p.ndim == 2 and p.shape[1] == 2
    assert np.all(p[:, 0] < p[:, 1])  # lower id first
    pairs = set(map(tuple, p.tolist()))
    assert len(pairs) == len(p)  # no duplicates
    return pairs


def compare(sim):
    """Assert the list equals brute force (up to the round-off band); return counts."""
    sim.rebuild_neighbors()
    got = listed_pairs(sim)
    sure, ambiguous = brute_force(sim.positions, sim.radii, sim.skin)
    missing = sure - got
    extra = got - sure - ambiguous
    assert not missing, f"{len(missing)} pairs within the cutoff missing, e.g. {sorted(missing)[:5]}"
    assert not extra, f"{len(extra)} pairs beyond the cutoff listed, e.g. {sorted(extra)[:5]}"
    assert len(ambiguous) <= max(2, len(sure) // 1000)
    return len(sure), len(ambiguous)


def material():
    return tsubu.Material(density=2500.0, kn=1e3, restitution=0.5, friction=0.5)


def random_radii(rng, n, r_min=0.05e-3, r_max=0.5e-3):
    """Log-uniform radii over a 10:1 range, with both extremes present."""
    r = np.exp(rng.uniform(math.log(r_min), math.log(r_max), n))
    r[0], r[1] = r_min, r_max
    return r


def scene(x, r, skin=None):
    sim = tsubu.Simulation(gravity=(0.0, 0.0, 0.0), skin=skin, threads=1)
    sim.add_spheres(x, r, material())
    return sim


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
@pytest.mark.parametrize("density", ["sparse", "dense"])
@pytest.mark.parametrize("skin", [None, 0.05e-3])
def test_random_polydisperse_packings(seed, density, skin):
    """Spheres with radii 0.05-0.5 mm (log-uniform) at random positions (overlaps allowed:
    the list does not care): 600 in a cube of side 15 mm (sparse, ~30 pairs) or 800 in a
    cube of side 4 mm (dense, ~2500 pairs)."""
    rng = np.random.default_rng(seed)
    n = 600 if density == "sparse" else 800
    side = 15e-3 if density == "sparse" else 4e-3
    x = rng.uniform(0.0, side, (n, 3)) - 0.5 * side
    r = random_radii(rng, n)
    sim = scene(x, r, skin)
    if skin is not None:
        assert sim.skin == skin
    else:  # documented default: 0.2 x the mean diameter
        assert sim.skin == pytest.approx(0.2 * 2.0 * r.mean(), rel=1e-12)
    n_sure, _ = compare(sim)
    if density == "dense":
        assert n_sure > 1500  # the test has something to check
    else:
        assert n_sure > 10


@pytest.mark.parametrize("seed", [4, 5])
def test_spheres_spanning_a_large_box(seed):
    """A dense cluster of 400 small and large spheres plus 100 spread over a 2 m box
    (and one pair far out at +-1e3 m): a grid sized by the extent must not lose pairs."""
    rng = np.random.default_rng(seed)
    cluster = rng.uniform(-3e-3, 3e-3, (400, 3))
    spread = rng.uniform(-1.0, 1.0, (100, 3))
    # a few pairs inside the spread set and far away, touching
    spread[1] = spread[0] + [0.3e-3, 0.0, 0.0]
    far = np.array([[1e3, 1e3, -1e3], [1e3 + 0.6e-3, 1e3, -1e3]])
    x = np.vstack([cluster, spread, far])
    r = random_radii(rng, len(x))
    n_sure, _ = compare(scene(x, r))
    assert n_sure > 150


@pytest.mark.parametrize("skin", [None, 1e-4])
def test_pairs_at_the_cutoff(skin):
    """Pairs of (large, small) and (small, small) spheres along random directions at
    (1 - 1e-9) and (1 + 1e-9) of r_i + r_j + skin: the first are listed, the second not."""
    rng = np.random.default_rng(9)
    radii_pairs = [(0.5e-3, 0.05e-3), (0.05e-3, 0.05e-3), (0.5e-3, 0.5e-3), (0.3e-3, 0.07e-3)]
    x, r, expect_in, expect_out = [], [], set(), set()
    # the default skin depends on the mean radius: compute it from the final radii
    all_r = [ri for pair in radii_pairs for ri in pair] * 2
    s = skin if skin is not None else 0.2 * 2.0 * float(np.mean(all_r))
    k = 0
    for factor, target in ((1.0 - 1e-9, expect_in), (1.0 + 1e-9, expect_out)):
        for ri, rj in radii_pairs:
            centre = np.array([k * 10e-3, 0.0, 0.0])
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            x += [centre, centre + u * (ri + rj + s) * factor]
            r += [ri, rj]
            target.add((2 * k, 2 * k + 1))
            k += 1
    sim = scene(np.array(x), np.array(r), skin)
    assert sim.skin == pytest.approx(s, rel=1e-12)
    compare(sim)
    got = listed_pairs(sim)
    assert expect_in <= got
    assert not (expect_out & got)


def test_list_after_a_run_with_motion():
    """A falling, colliding polydisperse cloud (radii 0.1-0.5 mm, 5:1 so that the time step
    stays affordable; 10:1 in the static scenes above) in a closed 6 mm box. During the run
    every touching pair is in the current list (the skin/2 rebuild rule); after the run
    rebuild_neighbors() equals brute force on the new positions, and rebuilds happened."""
    rng = np.random.default_rng(12)
    n = 400
    side = 6e-3
    # random sequential placement without overlap, largest first (so it cannot jam) ...
    r = np.sort(random_radii(rng, n, 0.1e-3, 0.5e-3))[::-1]
    x = np.empty((n, 3))
    placed = 0
    while placed < n:
        c = rng.uniform(r[placed], side - r[placed], 3)
        if placed == 0 or np.all(np.linalg.norm(x[:placed] - c, axis=1) > r[:placed] + r[placed]):
            x[placed] = c
            placed += 1
    # ... then ids in random order of size
    order = rng.permutation(n)
    x, r = x[order], r[order]
    mat = material()
    # dt = 5e-7 s: t_c/14 for the lightest pair, 0.11 of the bound (2.31)
    sim = tsubu.Simulation(gravity=(0.0, 0.0, -50.0), dt=5e-7, threads=1)
    sim.add_spheres(x, r, mat, velocities=rng.normal(0.0, 0.3, (n, 3)))
    for ax in range(3):
        nrm = np.zeros(3)
        nrm[ax] = 1.0
        sim.add_plane(point=(0.0, 0.0, 0.0), normal=nrm, material=mat)
        sim.add_plane(point=nrm * side, normal=-nrm, material=mat)
    touching_seen = 0
    for _ in range(50):
        sim.run(steps=100)
        got = listed_pairs(sim)
        xs, rs = sim.positions, sim.radii
        i, j = np.triu_indices(n, k=1)
        touching = np.linalg.norm(xs[i] - xs[j], axis=1) < rs[i] + rs[j]
        touch = set(zip(i[touching].tolist(), j[touching].tolist()))
        touching_seen += len(touch)
        assert touch <= got, sorted(touch - got)[:5]
        # the contacts the engine reports are pairs of the list too
        c = sim.contacts()
        pair_rows = c["j"] >= 0
        reported = set(zip(np.minimum(c["i"], c["j"])[pair_rows].tolist(),
                           np.maximum(c["i"], c["j"])[pair_rows].tolist()))
        assert reported <= got
    assert touching_seen > 100
    assert sim.rebuild_count > 5
    moved = np.linalg.norm(sim.positions - x, axis=1)
    assert np.median(moved) > sim.skin  # the list had to follow real motion
    compare(sim)

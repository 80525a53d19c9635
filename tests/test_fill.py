"""tsubu.fill: regions, size distributions (sample statistics against closed forms), lattices and
random packings (no overlap, inside, counts, solid fraction, seeds), and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tsubu
from tsubu import fill

from conftest import make_material

# Sample size of the distribution tests; statistics are compared within Z standard errors.
N_SAMPLE = 200_000
Z = 5.0


def Phi(x):
    return 0.5 * (1.0 + math.erf(x / math.sqrt(2.0)))


def phi(x):
    return math.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)


def assert_no_overlap(x, r, slack=0.0):
    """Every pair: |x_i - x_j| >= (r_i + r_j) (1 - slack), computed directly."""
    n = len(x)
    for s in range(0, n, 400):
        d = np.sqrt(((x[s:s + 400, None, :] - x[None, :, :]) ** 2).sum(axis=2))
        gap = d - (r[s:s + 400, None] + r[None, :]) * (1.0 - slack)
        gap[np.arange(min(400, n - s)), np.arange(s, min(s + 400, n))] = np.inf
        assert gap.min() >= 0, f"spheres overlap by {-gap.min()!r} m"


def assert_cdf(sample, radius, expected):
    """The sample's cumulative fraction below ``radius`` is ``expected`` within Z binomial
    standard errors."""
    got = float(np.mean(sample <= radius))
    se = math.sqrt(max(expected * (1 - expected), 1e-12) / len(sample))
    assert abs(got - expected) <= Z * se + 1e-12, (radius, got, expected)


def assert_mean(values, expected):
    se = float(np.std(values)) / math.sqrt(len(values))
    assert abs(float(np.mean(values)) - expected) <= Z * se + 1e-15 * abs(expected), \
        (float(np.mean(values)), expected, se)


def assert_variance(values, expected):
    centred = values - np.mean(values)
    se = math.sqrt(float(np.mean(centred ** 4)) - float(np.mean(centred ** 2)) ** 2) / math.sqrt(len(values))
    assert abs(float(np.var(values)) - expected) <= Z * se, (float(np.var(values)), expected, se)


# ---- regions ----------------------------------------------------------------------------------
def test_box_contains_whole_spheres():
    box = fill.Box((0, 0, 0), (1, 2, 3))
    pts = np.array([[0.5, 1, 1.5], [0.1, 1, 1.5], [0.95, 1, 1.5], [-0.1, 1, 1.5], [0.5, 1.9, 2.95]])
    assert box.contains(pts).tolist() == [True, True, True, False, True]
    assert box.contains(pts, 0.1).tolist() == [True, True, False, False, False]
    assert box.contains(pts, np.array([0.1, 0.05, 0.05, 0, 0.05])).tolist() == [True, True, True, False, True]
    assert box.volume == 6.0
    assert box.lower.tolist() == [0, 0, 0] and box.upper.tolist() == [1, 2, 3]


@pytest.mark.parametrize("axis", ["x", "y", "z"])
def test_cylinder_contains_and_bounds(axis):
    cyl = fill.Cylinder(base=(1, 2, 3), radius=0.5, height=2.0, axis=axis)
    k = "xyz".index(axis)
    up = np.eye(3)[k]
    side = np.eye(3)[(k + 1) % 3]
    base = np.array([1.0, 2.0, 3.0])
    pts = np.array([base + up, base + up + 0.45 * side, base + up + 0.55 * side, base + 0.05 * up,
                    base + 1.99 * up, base - 0.01 * up])
    assert cyl.contains(pts).tolist() == [True, True, False, True, True, False]
    assert cyl.contains(pts, 0.1).tolist() == [True, False, False, False, False, False]
    assert cyl.volume == pytest.approx(math.pi * 0.25 * 2.0)
    assert cyl.lower[k] == base[k]
    assert cyl.upper[k] == base[k] + 2.0
    assert cyl.upper[(k + 1) % 3] == base[(k + 1) % 3] + 0.5


def test_regions_round_trip_through_dicts():
    for region in (fill.Box((0, 0, 0), (1, 2, 3)), fill.Cylinder((0, 0, 1), 2.0, 3.0, axis="x")):
        again = fill.region_from_dict(region.to_dict())
        assert type(again) is type(region) and again.to_dict() == region.to_dict()
    with pytest.raises(ValueError, match="cannot be written"):
        fill.Region(lambda x: np.ones(len(x), bool), (0, 0, 0), (1, 1, 1)).to_dict()


def test_region_dicts_name_bad_keys():
    with pytest.raises(ValueError, match="unknown key 'centre'"):
        fill.region_from_dict({"type": "box", "lower": [0, 0, 0], "upper": [1, 1, 1], "centre": 1})
    with pytest.raises(ValueError, match="missing key 'upper'"):
        fill.region_from_dict({"type": "box", "lower": [0, 0, 0]})
    with pytest.raises(ValueError, match="region.type must be one of"):
        fill.region_from_dict({"type": "sphere"})
    with pytest.raises(ValueError, match="missing key 'type'"):
        fill.region_from_dict({"lower": [0, 0, 0]})


def test_function_region_volume_and_margin():
    def ball(points):
        return np.einsum("ij,ij->i", points, points) <= 1.0

    region = fill.Region(ball, (-1, -1, -1), (1, 1, 1))
    assert region.volume == pytest.approx(4 / 3 * math.pi, rel=0.01)
    assert fill.Region(ball, (-1, -1, -1), (1, 1, 1), volume=4.0).volume == 4.0
    pts = np.array([[0, 0, 0], [0.85, 0, 0], [0.5, 0.5, 0.5], [0.0, 0.0, 1.01]])
    # a centre-only function: centre and 64 surface points probed
    assert region.contains(pts, 0.1).tolist() == [True, True, True, False]
    assert region.contains(pts, 0.2).tolist() == [True, False, False, False]

    def ball_with_margin(points, margin):
        return np.sqrt(np.einsum("ij,ij->i", points, points)) + margin <= 1.0

    exact = fill.Region(ball_with_margin, (-1, -1, -1), (1, 1, 1))
    assert exact.contains(pts, 0.1).tolist() == [True, True, True, False]
    assert exact.contains(pts, 0.14).tolist() == [True, True, False, False]  # 0.866 + 0.14 > 1
    assert exact.contains(pts, 0.16).tolist() == [True, False, False, False]


def test_regions_refuse_bad_input():
    with pytest.raises(ValueError, match="lower must be < upper"):
        fill.Box((0, 0, 0), (1, -1, 1))
    with pytest.raises(ValueError, match="radius must be a finite number > 0"):
        fill.Cylinder((0, 0, 0), -1.0, 1.0)
    with pytest.raises(ValueError, match="height"):
        fill.Cylinder((0, 0, 0), 1.0, 0.0)
    with pytest.raises(ValueError, match="axis must be"):
        fill.Cylinder((0, 0, 0), 1.0, 1.0, axis="w")
    with pytest.raises(TypeError, match="contains must be a function"):
        fill.Region(3, (0, 0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="contains must return a bool array"):
        fill.Region(lambda x: True, (0, 0, 0), (1, 1, 1)).contains([[0.5, 0.5, 0.5]])


# ---- size distributions -----------------------------------------------------------------------
def test_monodisperse_and_uniform_statistics():
    rng = np.random.default_rng(1)
    assert np.all(fill.Monodisperse(2e-3).sample(10, rng) == 2e-3)
    assert fill.Monodisperse(2e-3).mean_volume == pytest.approx(4 / 3 * math.pi * 8e-9, rel=1e-15)
    a, b = 1e-3, 3e-3
    u = fill.Uniform(a, b)
    r = u.sample(N_SAMPLE, rng)
    assert r.min() >= a and r.max() <= b and (u.min_radius, u.max_radius) == (a, b)
    assert_mean(r, (a + b) / 2)
    assert_variance(r, (b - a) ** 2 / 12)
    for p in (0.1, 0.5, 0.9):
        assert_cdf(r, a + p * (b - a), p)
    assert_mean(4 / 3 * math.pi * r ** 3, u.mean_volume)


def truncated_normal_moments(mu, s, lo, hi):
    a, b = (lo - mu) / s, (hi - mu) / s
    z = Phi(b) - Phi(a)
    mean = mu + s * (phi(a) - phi(b)) / z
    var = s * s * (1 + (a * phi(a) - b * phi(b)) / z - ((phi(a) - phi(b)) / z) ** 2)
    return mean, var, lambda r: (Phi((r - mu) / s) - Phi(a)) / z


@pytest.mark.parametrize("bounds", [(None, None), (0.8e-3, 1.6e-3)])
def test_normal_statistics(bounds):
    mu, s = 1e-3, 0.25e-3
    dist = fill.Normal(mu, s, *bounds)
    lo, hi = bounds if bounds[0] is not None else (mu - 3 * s, mu + 3 * s)
    assert (dist.min_radius, dist.max_radius) == pytest.approx((lo, hi))
    r = dist.sample(N_SAMPLE, np.random.default_rng(2))
    assert r.min() >= lo and r.max() <= hi
    mean, var, cdf = truncated_normal_moments(mu, s, lo, hi)
    assert_mean(r, mean)
    assert_variance(r, var)
    for q in (0.9e-3, 1e-3, 1.2e-3):
        assert_cdf(r, q, cdf(q))
    assert_mean(4 / 3 * math.pi * r ** 3, dist.mean_volume)


@pytest.mark.parametrize("bounds", [(None, None), (0.5e-3, 3e-3)])
def test_lognormal_statistics(bounds):
    median, sigma = 1e-3, 0.4
    dist = fill.LogNormal(median, sigma, *bounds)
    lo, hi = bounds if bounds[0] is not None else (median * math.exp(-3 * sigma), median * math.exp(3 * sigma))
    assert (dist.min_radius, dist.max_radius) == pytest.approx((lo, hi))
    r = dist.sample(N_SAMPLE, np.random.default_rng(3))
    assert r.min() >= lo and r.max() <= hi
    a, b = math.log(lo / median) / sigma, math.log(hi / median) / sigma
    z = Phi(b) - Phi(a)

    def moment(k):  # E[r^k] of the truncated log-normal
        return median ** k * math.exp(0.5 * (k * sigma) ** 2) * (Phi(b - k * sigma) - Phi(a - k * sigma)) / z

    assert_mean(r, moment(1))
    assert_variance(r, moment(2) - moment(1) ** 2)
    for q in (0.7e-3, 1e-3, 1.5e-3):
        assert_cdf(r, q, (Phi(math.log(q / median) / sigma) - Phi(a)) / z)
    assert dist.mean_volume == pytest.approx(4 / 3 * math.pi * moment(3), rel=1e-12)
    assert_mean(4 / 3 * math.pi * r ** 3, dist.mean_volume)


TABLE_RADII = [0.2e-3, 0.4e-3, 0.5e-3, 0.8e-3, 1.5e-3]
TABLE_FRACTIONS = [0.0, 0.1, 0.1, 0.6, 1.0]  # one empty bin


def test_tabulated_by_number_follows_the_table():
    dist = fill.Tabulated(TABLE_RADII, TABLE_FRACTIONS)
    r = dist.sample(N_SAMPLE, np.random.default_rng(4))
    assert r.min() >= 0.2e-3 and r.max() <= 1.5e-3
    assert not np.any((r > 0.4e-3) & (r < 0.5e-3))  # the empty bin
    for radius, fraction in zip(TABLE_RADII, TABLE_FRACTIONS):
        assert_cdf(r, radius, fraction)
    assert_cdf(r, 0.3e-3, 0.05)  # linear between table points
    assert_cdf(r, 1.0e-3, 0.6 + 0.4 * (0.2 / 0.7))
    assert_mean(4 / 3 * math.pi * r ** 3, dist.mean_volume)


def test_tabulated_by_mass_follows_the_table_in_mass():
    dist = fill.Tabulated(TABLE_RADII, TABLE_FRACTIONS, basis="mass")
    r = dist.sample(N_SAMPLE, np.random.default_rng(5))
    assert r.min() >= 0.2e-3 and r.max() <= 1.5e-3
    v = r ** 3
    checks = list(zip(TABLE_RADII, TABLE_FRACTIONS)) + [(1.0e-3, 0.6 + 0.4 * (0.2 / 0.7))]
    for radius, fraction in checks:
        finer = r <= radius
        got = float(v[finer].sum() / v.sum())
        # the standard error of a ratio estimator: std(v (1{finer} - F)) / (mean v sqrt n)
        se = float(np.std(v * (finer - fraction))) / (float(v.mean()) * math.sqrt(len(r)))
        assert abs(got - fraction) <= Z * se + 1e-12, (radius, got, fraction, se)
    # by number, fine spheres dominate far more than by mass
    assert np.mean(r <= 0.4e-3) > 0.5
    assert_mean(4 / 3 * math.pi * r ** 3, dist.mean_volume)


def test_distributions_are_reproducible_and_round_trip():
    dists = [fill.Monodisperse(1e-3), fill.Uniform(1e-3, 2e-3), fill.Normal(1e-3, 1e-4),
             fill.LogNormal(1e-3, 0.3, max_radius=2e-3), fill.Tabulated(TABLE_RADII, TABLE_FRACTIONS, "mass")]
    for dist in dists:
        a = dist.sample(100, np.random.default_rng(7))
        assert np.array_equal(a, dist.sample(100, np.random.default_rng(7)))
        if not isinstance(dist, fill.Monodisperse):
            assert not np.array_equal(a, dist.sample(100, np.random.default_rng(8)))
        again = fill.distribution_from_dict(dist.to_dict())
        assert again.to_dict() == dist.to_dict()
        assert np.array_equal(again.sample(100, np.random.default_rng(7)), a)
        assert again.mean_volume == dist.mean_volume


@pytest.mark.parametrize("make, match", [
    (lambda: fill.Monodisperse(-1e-3), "radius must be a finite number > 0"),
    (lambda: fill.Uniform(2e-3, 1e-3), "min_radius must be < max_radius"),
    (lambda: fill.Uniform(0.0, 1e-3), "min_radius must be a finite number > 0"),
    (lambda: fill.Normal(1e-3, 0.5e-3), r"min_radius defaults to mean_radius - 3 std = .*give min_radius > 0"),
    (lambda: fill.Normal(1e-3, -1e-4), "std must be a finite number > 0"),
    (lambda: fill.Normal(1e-3, 1e-4, min_radius=2e-3, max_radius=3e-3), "keep only"),
    (lambda: fill.LogNormal(1e-3, 0.0), "sigma must be a finite number > 0"),
    (lambda: fill.LogNormal(1e-3, 0.3, min_radius=2e-3, max_radius=1e-3), "min_radius must be < max_radius"),
    (lambda: fill.Tabulated([1e-3, 2e-3, 3e-3], [0, 0.7, 0.5]), r"fractions must be non-decreasing .*entry 2"),
    (lambda: fill.Tabulated([1e-3, 2e-3, 3e-3], [0, 0.5, 0.9]), "fractions must start at 0 and end at 1"),
    (lambda: fill.Tabulated([1e-3, 2e-3, 3e-3], [0.2, 0.5, 1.0]), "fractions must start at 0 and end at 1"),
    (lambda: fill.Tabulated([1e-3, 1e-3, 3e-3], [0, 0.5, 1.0]), "radii must be strictly increasing"),
    (lambda: fill.Tabulated([-1e-3, 2e-3], [0, 1.0]), "radii must be finite and > 0: entry 0"),
    (lambda: fill.Tabulated([1e-3, 2e-3], [0, 0.5, 1.0]), "one value per radius"),
    (lambda: fill.Tabulated([1e-3, 2e-3], [0, 1.0], basis="volume"), "basis must be"),
])
def test_distributions_refuse_bad_input(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_distribution_dicts_name_bad_keys():
    with pytest.raises(ValueError, match="unknown key 'mean'"):
        fill.distribution_from_dict({"type": "normal", "mean": 1e-3, "std": 1e-4})
    with pytest.raises(ValueError, match="sizes.type must be one of"):
        fill.distribution_from_dict({"type": "weibull"})


# ---- lattice ----------------------------------------------------------------------------------
def test_cubic_lattice_counts_and_touches():
    box = fill.Box((0, 0, 0), (10e-3, 8e-3, 6e-3))
    p = fill.lattice(box, 0.5e-3)
    assert isinstance(p, fill.Packing) and len(p.positions) == 10 * 8 * 6
    assert np.all(p.radii == 0.5e-3)
    assert box.contains(p.positions, p.radii).all()
    assert_no_overlap(p.positions, p.radii, slack=1e-12)
    d = np.sqrt(((p.positions[1] - p.positions[0]) ** 2).sum())
    assert d == pytest.approx(1e-3, rel=1e-12)
    wider = fill.lattice(box, 0.5e-3, spacing=2e-3)
    assert len(wider.positions) == 5 * 4 * 3


def test_hexagonal_lattice_is_close_packed():
    box = fill.Box((0, 0, 0), (12e-3, 12e-3, 12e-3))
    p = fill.lattice(box, 0.5e-3, kind="hexagonal")
    x = p.positions
    assert box.contains(x, p.radii).all()
    assert_no_overlap(x, p.radii, slack=1e-12)
    # every sphere away from the walls touches twelve others
    inner = np.all((x > 2.5e-3) & (x < 9.5e-3), axis=1)
    d = np.sqrt(((x[inner][:, None] - x[None]) ** 2).sum(axis=2))
    touching = np.sum(np.abs(d - 1e-3) < 1e-12, axis=1)
    assert inner.sum() > 100 and np.all(touching == 12)
    cubic = fill.lattice(box, 0.5e-3, kind="cubic")
    assert len(p.positions) > len(cubic.positions)  # 0.740 against 0.524, less the walls
    small = fill.Box((0, 0, 0), (6e-3, 6e-3, 6e-3))
    shaken = fill.lattice(small, 0.5e-3, kind="hexagonal", spacing=1.1e-3, jitter=1.0, seed=2)
    assert len(shaken.positions) > 100
    assert small.contains(shaken.positions, shaken.radii).all()
    assert_no_overlap(shaken.positions, shaken.radii)


def test_lattice_in_a_cylinder_with_jitter():
    cyl = fill.Cylinder((0, 0, 0), 5e-3, 10e-3)
    plain = fill.lattice(cyl, 0.5e-3, spacing=1.2e-3)
    shaken = fill.lattice(cyl, 0.5e-3, spacing=1.2e-3, jitter=1.0, seed=3)
    for p in (plain, shaken):
        assert cyl.contains(p.positions, p.radii).all()
        assert_no_overlap(p.positions, p.radii)
    moved = np.sqrt(((shaken.positions - fill.lattice(cyl, 0.5e-3, spacing=1.2e-3, jitter=1e-9).positions) ** 2).sum(1))
    assert moved.max() <= 0.1e-3 and moved.mean() > 0.03e-3  # up to (1.2 - 1) / 2 mm
    assert not np.array_equal(shaken.positions, fill.lattice(cyl, 0.5e-3, spacing=1.2e-3, jitter=1.0, seed=4).positions)


def test_lattice_refuses_bad_input():
    box = fill.Box((0, 0, 0), (1e-2, 1e-2, 1e-2))
    with pytest.raises(ValueError, match="radius must be a finite number > 0"):
        fill.lattice(box, -1e-3)
    with pytest.raises(ValueError, match="spacing must be >= 2 radius"):
        fill.lattice(box, 1e-3, spacing=1e-3)
    with pytest.raises(ValueError, match="kind must be"):
        fill.lattice(box, 1e-3, kind="fcc")
    with pytest.raises(ValueError, match="needs room to move"):
        fill.lattice(box, 1e-3, jitter=0.5)
    with pytest.raises(ValueError, match=r"jitter must be in \[0, 1\]"):
        fill.lattice(box, 1e-3, spacing=3e-3, jitter=1.5)
    with pytest.raises(TypeError, match="region must be"):
        fill.lattice((0, 0, 1), 1e-3)


# ---- random packing ---------------------------------------------------------------------------
def test_random_packing_by_count_in_a_box():
    box = fill.Box((0, 0, 0), (10e-3, 10e-3, 10e-3))
    p = fill.random_packing(box, 0.5e-3, count=400, seed=1)
    assert p.positions.shape == (400, 3) and np.all(p.radii == 0.5e-3)
    assert box.contains(p.positions, p.radii).all()
    assert_no_overlap(p.positions, p.radii)
    again = fill.random_packing(box, 0.5e-3, count=400, seed=1)
    assert np.array_equal(again.positions, p.positions)
    other = fill.random_packing(box, 0.5e-3, count=400, seed=2)
    assert not np.array_equal(other.positions, p.positions)
    # spread over the whole box, not clustered
    assert np.all(np.abs(p.positions.mean(axis=0) - 5e-3) < 0.5e-3)


@pytest.mark.parametrize("target", [0.1, 0.3])
def test_random_packing_reaches_a_solid_fraction_in_a_cylinder(target):
    cyl = fill.Cylinder((0, 0, 0), 6e-3, 12e-3)
    sizes = fill.Uniform(0.3e-3, 0.6e-3)
    p = fill.random_packing(cyl, sizes, solid_fraction=target, seed=3)
    assert cyl.contains(p.positions, p.radii).all()
    assert_no_overlap(p.positions, p.radii)
    reached = float(np.sum(4 / 3 * math.pi * p.radii ** 3)) / cyl.volume
    assert target <= reached <= target + 4 / 3 * math.pi * 0.6e-3 ** 3 / cyl.volume
    assert np.all(np.diff(p.radii) <= 0)  # largest first
    assert p.radii.min() >= 0.3e-3 and p.radii.max() <= 0.6e-3


def test_random_packing_in_a_function_region():
    def ball(points, margin):  # exact: the sphere inside the ball of radius 5 mm at the origin
        return np.sqrt(np.einsum("ij,ij->i", points, points)) + margin <= 5e-3

    region = fill.Region(ball, (-5e-3,) * 3, (5e-3,) * 3, volume=4 / 3 * math.pi * 125e-9)
    p = fill.random_packing(region, fill.LogNormal(0.3e-3, 0.2), count=300, seed=4)
    assert np.all(np.sqrt((p.positions ** 2).sum(1)) + p.radii <= 5e-3)
    assert_no_overlap(p.positions, p.radii)

    def centre_ball(points):  # centre-only: surface points probed, a few percent of a radius
        return np.einsum("ij,ij->i", points, points) <= 25e-6

    p = fill.random_packing(fill.Region(centre_ball, (-5e-3,) * 3, (5e-3,) * 3), 0.5e-3, count=200, seed=4)
    assert np.all(np.sqrt((p.positions ** 2).sum(1)) + 0.5e-3 <= 5e-3 + 0.05 * 0.5e-3)
    assert_no_overlap(p.positions, p.radii)


def test_random_packing_plugs_into_a_simulation():
    box = fill.Box((0, 0, 0.1e-3), (5e-3, 5e-3, 10e-3))
    p = fill.random_packing(box, fill.Normal(0.3e-3, 0.03e-3), solid_fraction=0.2, seed=5)
    glass = make_material()
    sim = tsubu.Simulation()
    ids = sim.add_spheres(p.positions, p.radii, glass)
    sim.add_plane(point=(0, 0, 0), normal=(0, 0, 1), material=glass)
    sim.run(steps=20)  # the first run refuses initial overlaps: there are none
    assert len(ids) == len(p.radii) and sim.step_count == 20


def test_random_packing_says_what_it_reached():
    box = fill.Box((0, 0, 0), (5e-3, 5e-3, 5e-3))
    with pytest.raises(ValueError, match=r"placed \d+ of \d+ spheres \(solid fraction 0\.[23]\d* of "
                                         r"0\.5[0-9]* asked\).*lattice\(\)"):
        fill.random_packing(box, 0.5e-3, solid_fraction=0.5, max_attempts=500)
    with pytest.raises(ValueError, match="more than any packing of equal spheres"):
        fill.random_packing(box, 0.5e-3, count=1000)
    with pytest.raises(ValueError, match="does not fit in the region"):
        fill.random_packing(box, 3e-3, count=1)


def test_random_packing_refuses_bad_input():
    box = fill.Box((0, 0, 0), (5e-3, 5e-3, 5e-3))
    with pytest.raises(TypeError, match="exactly one of count= or solid_fraction="):
        fill.random_packing(box, 0.5e-3)
    with pytest.raises(TypeError, match="exactly one of count= or solid_fraction="):
        fill.random_packing(box, 0.5e-3, count=10, solid_fraction=0.1)
    with pytest.raises(ValueError, match=r"solid_fraction must be in \(0, 1\)"):
        fill.random_packing(box, 0.5e-3, solid_fraction=1.2)
    with pytest.raises(ValueError, match="count must be >= 0"):
        fill.random_packing(box, 0.5e-3, count=-3)
    with pytest.raises(ValueError, match="radius must be a finite number > 0"):
        fill.random_packing(box, -0.5e-3, count=3)
    with pytest.raises(TypeError, match="sizes must be a size distribution"):
        fill.random_packing(box, "big", count=3)
    with pytest.raises(ValueError, match="max_attempts must be >= 1"):
        fill.random_packing(box, 0.5e-3, count=3, max_attempts=0)
    assert len(fill.random_packing(box, 0.5e-3, count=0).radii) == 0

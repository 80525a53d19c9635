"""The thread-scaling benchmark (benchmarks/scaling.py) and what it reads from the engine: the tiled
bed it builds is shared/bench/device's (tile.py's copy order and offsets, the same state the
LAMMPS data file gets), the per-region times it reports add up (Simulation.region_seconds: the
regions lie inside the phases, the busiest thread works no longer than the region lasts, the
average no longer than the busiest), and its smoke run prints a table for both scenes. (Speed is
a benchmark, not a test: nothing here is timed against a target.)"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = os.path.join(HERE, "..", "benchmarks")
sys.path.insert(0, BENCH)

import reference_scene as rs  # noqa: E402


def test_the_tiled_bed_is_the_shared_tiling():
    """tile.py (shared/bench/device): copy (a, b) of the bed is shifted by (a L, b L, 0), copies in
    the order a, then b, L = 0.022 m; velocities and spins copied unchanged."""
    bed, tiled = rs.dense_bed_state(), rs.tiled_bed_state(3)
    n = len(bed["x"])
    L = 0.022000000000000002
    assert len(tiled["x"]) == 9 * n and tiled["lx"] == tiled["ly"] == 3 * L
    for copy, (a, b) in enumerate((a, b) for a in range(3) for b in range(3)):
        rows = slice(copy * n, (copy + 1) * n)
        assert np.array_equal(tiled["x"][rows, 0], bed["x"][:, 0] + a * L)
        assert np.array_equal(tiled["x"][rows, 1], bed["x"][:, 1] + b * L)
        assert np.array_equal(tiled["x"][rows, 2], bed["x"][:, 2])
        assert np.array_equal(tiled["v"][rows], bed["v"]) and np.array_equal(tiled["w"][rows], bed["w"])


def test_a_rectangular_bed_tiles_as_the_square_one_does():
    """mpi_scaling.py's weak scaling: a x b tiles, a b = cores, as square as the count allows."""
    import mpi_scaling as ms

    assert [ms.tiles_for_cores(c) for c in (1, 2, 4, 8, 16, 6)] == [(1, 1), (2, 1), (2, 2), (4, 2), (4, 4), (3, 2)]
    square, rect = rs.tiled_bed_state(2), rs.tiled_bed_state((2, 1))
    n = len(rs.dense_bed_state()["x"])
    assert len(rect["x"]) == 2 * n and rect["lx"] == square["lx"] and 2 * rect["ly"] == square["ly"]
    # (square: copies (0,0), (0,1), (1,0), (1,1); the 2 x 1 bed: (0,0), (1,0))
    assert np.array_equal(rect["x"][:n], square["x"][:n]) and np.array_equal(rect["x"][n:], square["x"][2 * n:3 * n])
    assert ms.parse_config("4x2") == (4, 2) and ms.parse_config("16") == (16, 1)
    with pytest.raises(Exception, match="RxT"):
        ms.parse_config("four")


def test_the_tiled_bed_scene_has_its_walls_and_sliding_floor():
    sim = rs.build_tiled_bed(2, threads=1)
    assert len(sim) == 4 * len(rs.dense_bed_state()["x"])
    floor = sim.plane(0)
    assert np.array_equal(floor["normal"], [0.0, 0.0, 1.0])
    assert np.array_equal(floor["velocity"], [0.05, 0.0, 0.0])
    assert sim.plane(2)["point"][0] == pytest.approx(2 * 0.022, rel=1e-15)


@pytest.mark.parametrize("threads", [1, 2])
def test_region_times_lie_inside_the_phases(threads):
    """200 steps of the bed tiled 2 x 2 (N = 40,000, below the fused pass's 65,536: every step is
    a contact region and a particle region): the regions' times lie within the loop's phases,
    and wall >= slowest >= mean (equal with one thread)."""
    sim = rs.build_tiled_bed(2, threads=threads)
    sim.run(200)
    phases, regions = sim.phase_seconds(), sim.region_seconds()
    assert set(regions) == {"contacts", "particles", "fused"}
    assert regions["contacts"]["count"] == regions["particles"]["count"] == 200
    assert regions["fused"]["count"] == 0
    inside = sum(r["wall"] for r in regions.values())
    assert 0 < inside <= phases["contacts"] + phases["integrate"]
    for r in regions.values():
        assert r["wall"] >= r["slowest"] >= r["mean"] >= 0
        if threads == 1:
            assert r["slowest"] == r["mean"]


def test_smoke_run_prints_both_scenes(tmp_path):
    out = tmp_path / "scaling.json"
    p = subprocess.run([sys.executable, os.path.join(BENCH, "scaling.py"), "--quick", "--json", str(out)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    assert "bed: N = 10,000" in p.stdout and "drop: N = 20,000" in p.stdout
    results = json.loads(out.read_text())
    for scene in results["scenes"]:
        rows = {r["threads"]: r for r in scene["rows"]}
        assert set(rows) == {1, 2} and rows[1]["speedup"] == 1.0
        assert all(r["rate"] > 0 for r in rows.values())

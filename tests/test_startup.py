"""Start-up and set-up of a map (issue 23, parts 1 and 5): what a small run imports and builds.

A small run (``python -m hw4 run --task 1 --grid-size 0.5``) must not pay for what it does not
use: numba (the numpy engine runs it), scipy.spatial (its nearest poses are compared directly),
scipy.io (the data's arrays come from the cache) nor, with ``--no-figures``, matplotlib. The
pieces that replace them must give what they replace bit for bit: the cached arrays are
loadmat's, the lazy ``occMap`` / ``mdl`` are the template's KD-trees, the compiled bin table and
the direct nearest-pose comparison are the numpy table and the KD-tree's answer. Timings are
the benchmark's business (``benchmarks/bench_models.py`` prints the start-up line).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import KDTree, cKDTree

from hw4.core import compiled, data
from hw4.core.evidence import nearest_pose_query
from hw4.core.grid import Grid
from hw4.core.sensor import BeamTable
from hw4.ogm_CSM import ogm_CSM
from hw4.tasks import load_task_data

ROOT = Path(__file__).resolve().parent.parent


def _modules_after_run(tmp_path, *extra) -> set:
    """Top-level packages a fresh ``python -m hw4 run --task 1 --grid-size 0.5`` imported."""
    code = ("import sys, runpy; sys.argv = ['hw4', 'run', '--task', '1', '--grid-size', '0.5', "
            f"'--out', {str(tmp_path)!r}, '--force'{''.join(f', {e!r}' for e in extra)}]\n"
            "try:\n    runpy.run_module('hw4', run_name='__main__')\n"
            "except SystemExit as e:\n    assert not e.code, e.code\n"
            "import json; print(json.dumps(sorted(sys.modules)))")
    data.load_intel()  # the cache exists (the first run after an install writes it)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         env=dict(os.environ, MPLBACKEND="Agg"), check=True)
    return set(json.loads(out.stdout.strip().splitlines()[-1]))


def test_small_run_imports_neither_numba_nor_scipy(tmp_path):
    mods = _modules_after_run(tmp_path, "--no-figures")
    assert (tmp_path / "task1_grid0.5.npz").is_file()
    for heavy in ("numba", "scipy.spatial", "scipy.io", "matplotlib", "hw4.bki", "hw4.grading"):
        assert heavy not in mods, heavy


def test_small_run_with_figures_skips_numba_and_scipy(tmp_path):
    mods = _modules_after_run(tmp_path)
    assert (tmp_path / "task1_grid0.5_mean.png").is_file()
    assert (tmp_path / "task1_grid0.5_variance.png").is_file()
    assert "matplotlib" in mods
    for heavy in ("numba", "scipy.spatial", "scipy.io", "matplotlib.pyplot"):
        assert heavy not in mods, heavy


def test_plotting_imports_pyplot_only_for_a_figure_it_makes():
    code = ("import sys; from hw4.core import plotting; a = 'matplotlib.pyplot' in sys.modules\n"
            "plotting._new(None); print(a, 'matplotlib.pyplot' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         env=dict(os.environ, MPLBACKEND="Agg"), check=True)
    assert out.stdout.split() == ["False", "True"]


@pytest.mark.parametrize("task", [1, 3], ids=["binary", "semantic"])
@pytest.mark.parametrize("what", ["mean", "variance"])
def test_cli_png_is_savefig_tight_pixel_for_pixel(tmp_path, task, what):
    """save_map_png (one drawing, no pyplot) writes the pixels of the figure the CLI drew before:
    pyplot, savefig(bbox_inches='tight'), the semantic map's legend outside the axes kept."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image
    from hw4.core import plotting
    from hw4.tasks import build_map

    ogm = build_map(task, 0.5)
    title = f"{ogm.name} {what}, grid 0.5 m"
    fig, ax = plt.subplots(figsize=(6.4, 5.4), dpi=100)
    {"mean": plotting.plot_map, "variance": plotting.plot_variance}[what](ogm, ax=ax, title=title)
    fig.savefig(tmp_path / "before.png", bbox_inches="tight", dpi=100)
    plt.close(fig)
    plotting.save_map_png(ogm, tmp_path / "after.png", what, title)
    before = np.asarray(Image.open(tmp_path / "before.png"))
    after = np.asarray(Image.open(tmp_path / "after.png"))
    assert after.shape == before.shape
    np.testing.assert_array_equal(after, before)
    assert after.shape[1] > (650 if task == 3 and what == "mean" else 500)  # legend, colour bar


@pytest.mark.parametrize("semantic", [False, True], ids=["binary", "semantic"])
def test_cached_arrays_are_loadmats(semantic):
    name = data.INTEL_SEMANTIC if semantic else data.INTEL
    raw = data._loadmat(data.ensure(name))
    poses = data.poses_from_struct(raw["robotPose"])
    scans = data.scans_from_cell(raw["laserScan"])
    data.load_intel(semantic=semantic)  # writes the cache when missing
    assert data._cache_file(name, data.manifest()[name][0]).is_file()
    got = data.load_intel(semantic=semantic)
    assert got.poses.dtype == poses.dtype and got.poses.strides == poses.strides
    np.testing.assert_array_equal(got.poses, poses)
    assert len(got.scans) == len(scans)
    for a, b in zip(got.scans, scans):
        assert a.dtype == b.dtype and a.shape == b.shape and a.strides == b.strides
        np.testing.assert_array_equal(a, b)


def test_unreadable_cache_falls_back_to_the_mat_file(tmp_path):
    bad = tmp_path / "x.npz"
    bad.write_bytes(b"not a zip file")
    assert data._read_cache(bad) is None
    assert data._read_cache(tmp_path / "missing.npz") is None
    np.savez(bad, poses=np.zeros((2, 3)), scans=np.zeros((2, 5)), counts=np.array([2, 2]))
    assert data._read_cache(bad) is None  # counts do not add up to the beams


def test_validation_fast_path_finds_what_the_loop_finds():
    d = load_task_data(3)
    data.validate(d.poses, d.scans, semantic=True)
    scans = [s.copy() for s in d.scans]
    scans[5][0, 3] = np.nan
    scans[9][2, 0] = 7.0
    with pytest.raises(data.InputError, match="scan 5 contains NaN"):
        data.validate(d.poses, scans, semantic=True)
    scans[5][0, 3] = 1.0
    with pytest.raises(data.InputError, match="scan 9 has label 7"):
        data.validate(d.poses, scans, semantic=True)
    data.validate(d.poses, scans, semantic=False)  # labels are not checked for binary models


def test_occmap_and_pose_tree_are_the_templates_kd_trees():
    d = load_task_data(1)
    m = ogm_CSM(grid_size=0.5)
    m.construct_map(d.poses, [s[:2] for s in d.scans])
    cells = Grid(0.5).cells
    np.testing.assert_array_equal(m.map["occMap"].data, cells)
    assert m.map["occMap"]._tree is None  # nothing built until it is used
    q = np.array([[0.3, -2.1], [5.0, 5.0]])
    for lazy, points in ((m.map["occMap"], cells), (m.pose["mdl"], d.poses[:, :2])):
        want = KDTree(points).query(q, 4)
        got = lazy.query(q, 4)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
        assert lazy.n == len(points)
    assert isinstance(m.map["occMap"].tree, KDTree)


def test_compiled_bin_table_is_the_numpy_one():
    d = load_task_data(1)
    rng = np.random.default_rng(3)
    variants = ([s[:2] for s in d.scans], [np.round(s[:2], 1) for s in d.scans],
                [s[:2, rng.permutation(s.shape[1])] for s in d.scans])
    for scans in variants:
        a = BeamTable.from_scans(scans)
        b = BeamTable.from_scans(scans, compiled=True)
        assert b._bin_lo.dtype == a._bin_lo.dtype == np.int32
        np.testing.assert_array_equal(b._bin_lo, a._bin_lo)
        np.testing.assert_array_equal(b._dense, a._dense)
        pose = rng.integers(0, len(scans), 50000)
        phi = rng.uniform(-np.pi, np.pi, 50000)
        for x, y in zip(a.nearest(pose, phi, True), b.nearest(pose, phi, True)):
            np.testing.assert_array_equal(x, y)
    assert BeamTable.from_scans(variants[1])._dense.any()  # the binary-search poses are tested


@pytest.mark.parametrize("k", [1, 16, 17, 743, 800])
def test_direct_nearest_poses_are_the_kd_trees(k):
    pxy = load_task_data(1).poses[:, :2]
    cells = Grid(0.5).cells
    kk = min(k, len(pxy))
    _, nn = cKDTree(pxy).query(cells, k=kk)
    np.testing.assert_array_equal(nearest_pose_query(cells, pxy, k), np.reshape(nn, (-1, kk)))
    np.testing.assert_array_equal(compiled.nearest_poses(cells, pxy, k, spacing=0.5),
                                  np.reshape(nn, (-1, kk)))


def test_direct_nearest_poses_ties_are_the_kd_trees():
    g = np.arange(0.0, 10.0, 1.0)
    pxy = np.array([(x, y) for x in g for y in g] + [(3.0, 3.0), (7.0, 2.0)])
    cells = Grid(0.25, range_x=(-2.0, 12.0), range_y=(-2.0, 12.0)).cells
    for k in (1, 4, 9):
        _, nn = cKDTree(pxy).query(cells, k=k)
        np.testing.assert_array_equal(nearest_pose_query(cells, pxy, k), np.reshape(nn, (-1, k)))

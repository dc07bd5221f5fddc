"""The compiled counting engine (hw4.core.compiled) against the numpy reference (engine='numpy').

The compiled kernels repeat the numpy formulation's floating-point steps per pair, so on this
machine the two engines give the same evidence bit for bit for every model and option checked
here (asserted below for the counts, which are integers, and for the continuous sums to 1e-12
relative: a machine whose numpy ``sin``/``cos`` differ from its C library's in the last ulp may
differ there, never more). Cost: about 15 s (grids of 0.5 m and windows of 0.27 m).
"""
from __future__ import annotations

import math
import os

import numpy as np
import pytest
from scipy.spatial import cKDTree

from hw4.core import compiled
from hw4.core.evidence import count_evidence
from hw4.core.grid import Grid
from hw4.tasks import load_task_data

RTOL = 1e-12


@pytest.fixture(scope="module")
def intel():
    return {False: load_task_data(1), True: load_task_data(3)}


def _both(grid, data, semantic, **kw):
    scans = data.scans if semantic else [s[:2] for s in data.scans]
    a = count_evidence(grid, data.poses, scans, semantic=semantic, engine="compiled", **kw)
    b = count_evidence(grid, data.poses, scans, semantic=semantic, engine="numpy", **kw)
    return a, b


def _agree(a, b, continuous):
    assert a.shape == b.shape and b.sum() > 0
    if continuous:
        np.testing.assert_allclose(a, b, rtol=RTOL, atol=0)
    else:
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("semantic", [False, True], ids=["binary", "semantic"])
@pytest.mark.parametrize("model", ["discrete", "continuous"])
@pytest.mark.parametrize("nearest", [16, 1, 3], ids=lambda k: f"nn{k}")
def test_nearest_beam_engines_agree(intel, model, semantic, nearest):
    grid = Grid(0.5, n_classes=7 if semantic else 2)
    a, b = _both(grid, intel[semantic], semantic, model=model, nearest_poses=nearest)
    _agree(a, b, model == "continuous")


@pytest.mark.parametrize("kind", ["through", "arange", "arange_world"])
def test_sample_count_readings_agree(intel, kind):
    a, b = _both(Grid(0.5), intel[False], False, model="continuous", sample_count=kind)
    _agree(a, b, True)


@pytest.mark.parametrize("semantic", [False, True], ids=["binary", "semantic"])
@pytest.mark.parametrize("nearest, beams", [(None, "nearest"), (16, "all"), (None, "all")],
                         ids=["all-poses", "all-beams", "all-poses-all-beams"])
def test_full_sums_agree(intel, semantic, nearest, beams):
    """All poses within z_max and every beam, on the southern strip at 0.27 m."""
    grid = Grid(0.27, range_y=(-25.0, -18.0), n_classes=7 if semantic else 2)
    a, b = _both(grid, intel[semantic], semantic, model="continuous", nearest_poses=nearest,
                 beams=beams)
    _agree(a, b, True)
    d, e = _both(grid, intel[semantic], semantic, model="discrete", nearest_poses=nearest) \
        if beams == "nearest" else (a, b)
    _agree(d, e, beams == "all")


def test_bit_identical_here_and_on_two_threads(intel, monkeypatch):
    """The default map is the same bit for bit on one and two threads (cells are independent)."""
    grid = Grid(0.5, n_classes=7)
    data = intel[True]
    one = count_evidence(grid, data.poses, data.scans, model="continuous", semantic=True)
    monkeypatch.setenv("HW4_THREADS", "2")
    two = count_evidence(grid, data.poses, data.scans, model="continuous", semantic=True)
    np.testing.assert_array_equal(one, two)


@pytest.mark.parametrize("k", [1, 16, 17, 50])
def test_nearest_poses_is_the_kd_tree(intel, k):
    cells = Grid(0.27).cells
    pxy = intel[False].poses[:, :2]
    _, nn = cKDTree(pxy).query(cells, k=k)
    np.testing.assert_array_equal(compiled.nearest_poses(cells, pxy, k), np.reshape(nn, (-1, k)))


def test_nearest_poses_ties_answered_by_the_kd_tree():
    """Poses on a lattice (many equal distances) and duplicated poses: the KD-tree's choice."""
    g = np.arange(0.0, 10.0, 1.0)
    pxy = np.array([(x, y) for x in g for y in g] + [(3.0, 3.0), (7.0, 2.0)])
    cells = Grid(0.25, range_x=(-2.0, 12.0), range_y=(-2.0, 12.0)).cells
    for k in (1, 4, 9):
        _, nn = cKDTree(pxy).query(cells, k=k)
        np.testing.assert_array_equal(compiled.nearest_poses(cells, pxy, k),
                                      np.reshape(nn, (-1, k)))


@pytest.mark.parametrize("copies", [1, 16])
def test_nearest_poses_all_in_one_spot(copies):
    """One pose, or 16 copies of it, seen from the whole template grid (cells up to 30 m away):
    the KD-tree's answer, quickly (a degenerate bucket grid once took minutes here)."""
    pxy = np.zeros((copies, 2))
    cells = Grid(0.5).cells
    k = min(16, copies)
    _, nn = cKDTree(pxy).query(cells, k=k)
    np.testing.assert_array_equal(compiled.nearest_poses(cells, pxy, 16),
                                  np.reshape(nn, (-1, k)))


def test_fast_arctangent_error_below_its_bound():
    """The bound EPS the kernels use is 100 times the fast arctangent's largest error."""
    rng = np.random.default_rng(1)
    scale = 10.0 ** rng.uniform(-6, 6, size=(2, 20000))
    y, x = rng.standard_normal((2, 20000)) * scale
    err = max(abs(compiled._atan2_fast(a, b) - math.atan2(a, b)) for a, b in zip(y, x))
    for a, b in ((0.0, 1.0), (0.0, -1.0), (-0.0, -1.0), (1.0, 0.0), (-1.0, -0.0), (1.0, 1.0)):
        err = max(err, abs(compiled._atan2_fast(a, b) - math.atan2(a, b)))
    assert err < compiled.EPS / 100


def test_engine_is_checked(intel):
    from hw4.core.errors import InputError
    with pytest.raises(InputError, match="engine"):
        count_evidence(Grid(0.5), intel[False].poses, intel[False].scans, engine="fortran")


def test_threads_from_environment(monkeypatch):
    monkeypatch.setenv("HW4_THREADS", "2")
    assert compiled.threads() == 2
    monkeypatch.setenv("HW4_THREADS", "many")
    assert compiled.threads() == 1
    monkeypatch.delenv("HW4_THREADS")
    assert compiled.threads() == 1 and "HW4_THREADS" not in os.environ

"""The log-odds baseline: a literal loop of the course's occupancy-grid example vs hw4.evaluation.logodds.

The loop below is written from the course's ``occupancy_grid_map.py`` (per cell: the 16 nearest
poses, the perceptual field, the nearest beam by ``nanargmin`` of the wrapped bearing difference,
the inverse sensor model with l_occ = 3, l_free = -3, l_0 = 0, and ``l += l_inv - l_0``), for
clarity, not speed. hw4.evaluation.logodds computes the map from the discrete CSM's counts instead; they must
agree exactly, cell by cell.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import KDTree

from hw4.core.data import IntelData, load_intel
from hw4.core.grid import Grid
from hw4.evaluation.logodds import (L_FREE, L_OCC, LogOddsMap, build_logodds, logodds_from_counts,
                         probability)


def _wrap(a):
    x = np.remainder(a, 2 * np.pi)
    while np.any(np.abs(x) > np.pi):
        x = np.where(np.abs(x) > np.pi, x - 2 * np.pi * np.sign(x), x)
    return x


def literal_logodds(cells, poses, scans, grid_size, nn=16, z_max=30.0, n_beams=133,
                    l_occ=3.0, l_free=-3.0, l_prior=0.0):
    """Log-odds of each cell in ``cells`` (M, 2) by the course example's loops."""
    alpha = 2 * grid_size
    beta = 2 * np.pi / n_beams
    tree = KDTree(poses[:, :2])
    out = np.full(len(cells), l_prior)
    for i, m in enumerate(cells):
        _, idxs = tree.query(m, nn)
        for k in np.atleast_1d(idxs):
            p = poses[k]
            d = m - p[:2]
            r = np.sqrt(np.sum(d ** 2))
            phi = _wrap(np.arctan2(d[1], d[0]) - p[2])
            if not (0 < r < z_max and -np.pi < phi < np.pi):
                continue
            s = scans[k]
            z_r = np.sqrt(s[0] ** 2 + s[1] ** 2)
            z_b = np.arctan2(s[1], s[0])
            diff = np.abs(_wrap(z_b - phi))
            b = np.nanargmin(diff)
            if r > min(z_max, z_r[b] + alpha / 2) or diff[b] > beta / 2:
                l_inv = l_prior
            elif z_r[b] < z_max and abs(r - z_r[b]) < alpha / 2:
                l_inv = l_occ
            elif r < z_r[b] and z_r[b] < z_max:
                l_inv = l_free
            else:
                l_inv = l_prior
            out[i] += l_inv - l_prior
    return out


@pytest.fixture(scope="module")
def intel():
    return load_intel(semantic=False)


def _windows(grid, lo_map, n=10):
    """Cell ids of three n x n windows: the strongest wall cell, a strongly free cell, a map corner."""
    img = lo_map.reshape(grid.shape)
    ny, nx = grid.shape
    out = []
    for flat in (int(np.argmax(lo_map)), int(np.argmin(lo_map)), 0):
        iy, ix = divmod(flat, nx)
        y0 = int(np.clip(iy - n // 2, 0, ny - n))
        x0 = int(np.clip(ix - n // 2, 0, nx - n))
        yy, xx = np.mgrid[y0:y0 + n, x0:x0 + n]
        out.append(grid.index(xx.reshape(-1), yy.reshape(-1)))
    assert img.shape == grid.shape
    return np.concatenate(out)


@pytest.mark.parametrize("grid_size", [0.135, 0.27, 0.5])
def test_logodds_equals_literal_loop(intel, grid_size):
    m = build_logodds(grid_size, intel)
    ids = _windows(m.grid, m.logodds)
    ref = literal_logodds(m.grid.cells[ids], intel.poses, intel.scans, grid_size)
    assert np.any(ref > 0) and np.any(ref < 0)  # the windows hold walls and free space
    np.testing.assert_array_equal(m.logodds[ids], ref)


def test_logodds_is_linear_in_the_csm_counts():
    counts = np.array([[0, 0], [3, 1], [1, 3], [2, 2], [5, 0]], dtype=float)
    l = logodds_from_counts(counts)
    np.testing.assert_array_equal(l, [0, 6, -6, 0, 15])
    np.testing.assert_array_equal(logodds_from_counts(counts, 2.0, -1.0, 0.5),
                                  0.5 + counts[:, 0] * 1.5 + counts[:, 1] * -1.5)
    assert (L_OCC, L_FREE) == (3.0, -3.0)


def test_unobserved_and_balanced_cells_look_alike_in_log_odds():
    """What counting keeps: (0 hits, 0 passes) and (50, 50) both give l = 0, p = 0.5."""
    grid = Grid(1.0, (0.0, 1.0), (0.0, 1.0))  # 2 x 2 cells
    m = LogOddsMap(grid, np.array([[0.0, 0.0], [50.0, 50.0], [1.0, 0.0], [0.0, 1.0]]))
    np.testing.assert_array_equal(m.logodds, [0.0, 0.0, 3.0, -3.0])
    np.testing.assert_array_equal(m.map["prob"].ravel()[:2], [0.5, 0.5])
    np.testing.assert_array_equal(m.observed, [False, True, True, True])


def test_probability_is_the_logistic_without_overflow():
    l = np.array([-1e4, -3.0, 0.0, 3.0, 1e4])
    p = probability(l)
    np.testing.assert_allclose(p[1:4], 1 - 1 / (1 + np.exp(l[1:4])), rtol=1e-13)
    assert p[0] == 0.0 and p[-1] == 1.0
    np.testing.assert_allclose(p + probability(-l), 1.0, rtol=1e-15)


def test_logodds_on_a_single_synthetic_scan():
    """One pose at the origin facing +x, one beam to a wall 2 m ahead."""
    data = IntelData(np.array([[0.0, 0.0, 0.0]]), [np.array([[2.0], [0.0]])])
    m = build_logodds(0.5, data, range_x=(-1.0, 3.0), range_y=(-1.0, 1.0))
    ref = literal_logodds(m.grid.cells, data.poses, data.scans, 0.5, nn=1)
    np.testing.assert_array_equal(m.logodds, ref)
    row = m.logodds.reshape(m.grid.shape)[m.grid.shape[0] // 2]  # y = 0: x = -1 .. 3
    np.testing.assert_array_equal(row, [0, 0, 0, -3, -3, -3, 3, 0, 0])


def test_clamp_clips_the_sum_and_rejects_non_positive():
    counts = np.array([[10.0, 0.0], [0.0, 10.0], [2.0, 1.0], [0.0, 0.0]])
    np.testing.assert_array_equal(logodds_from_counts(counts, 3.0, -3.0, 0.0, clamp=5.0),
                                  [5.0, -5.0, 3.0, 0.0])
    np.testing.assert_array_equal(logodds_from_counts(counts, 3.0, -3.0), [30, -30, 3, 0])
    with pytest.raises(Exception):
        logodds_from_counts(counts, clamp=0.0)


def test_tuning_picks_the_best_combination_and_never_sees_the_validation_scans():
    from hw4.evaluation.logodds import tune_logodds
    d = load_intel(semantic=False)
    d = IntelData(d.poses[:40], d.scans[:40])
    seen = []

    def score(m, val):
        seen.append(len(val.scans))
        return -abs(m.l_occ - 0.85) - abs(m.l_free + 1.5) - (m.clamp != np.inf)

    best, rows = tune_logodds(0.5, d, score, every=10, offset=4)
    assert best == {"l_occ": 0.85, "l_free": -1.5, "clamp": np.inf}
    assert len(rows) == 4 * 4 * 3 and set(seen) == {4}
    inner = IntelData(d.poses[np.arange(40) % 10 != 4],
                      [s for i, s in enumerate(d.scans) if i % 10 != 4])
    ref = build_logodds(0.5, inner)
    m = build_logodds(0.5, inner, **best)
    np.testing.assert_array_equal(m.counts, ref.counts)

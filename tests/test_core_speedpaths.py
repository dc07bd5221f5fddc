"""The speed paths of the core give the arrays of their plain numpy forms bit for bit."""
import numpy as np
import pytest

from hw4.core import posterior
from hw4.core.sensor import BeamTable


@pytest.mark.parametrize("k", list(range(1, 21)))
def test_row_sum_and_max_are_numpy_reductions(k):
    rng = np.random.default_rng(k)
    a = rng.random((5000, k)) * 10.0 ** rng.integers(-8, 8, (5000, k))
    assert np.array_equal(posterior._row_sum(a), a.sum(axis=1, keepdims=True))
    assert np.array_equal(posterior._row_max(a), a.max(axis=1, keepdims=True))
    s = a.sum(axis=1, keepdims=True)
    mean = a / s
    p = mean.max(axis=1, keepdims=True)
    m2, v2 = posterior.dirichlet_mean_variance(a)
    assert np.array_equal(m2, mean) and np.array_equal(v2, p * (1 - p) / (s + 1))
    b = a.copy()
    b[rng.integers(0, 5000, 50), rng.integers(0, k, 50)] = np.nan
    np.testing.assert_array_equal(posterior._row_max(b), b.max(axis=1, keepdims=True))


def _scans(rng, n_poses=60, shuffle=False, rows=3):
    out = []
    for t in range(n_poses):
        n = int(rng.integers(1, 200))
        ang = np.sort(rng.uniform(-np.pi, np.pi, n))
        if t % 7 == 0 and n > 3:
            ang[1] = ang[0]  # a repeated bearing
        if shuffle and t % 3 == 0:
            rng.shuffle(ang)
        r = rng.uniform(0.1, 30, n)
        s = np.vstack([r * np.cos(ang), r * np.sin(ang), rng.integers(1, 7, n)][:rows])
        out.append(s)
    return out


@pytest.mark.parametrize("shuffle", [False, True])
@pytest.mark.parametrize("rows", [2, 3])
def test_beam_table_compiled_is_numpy(shuffle, rows):
    rng = np.random.default_rng(3 + shuffle + rows)
    scans = _scans(rng, shuffle=shuffle, rows=rows)
    a = BeamTable.from_scans(scans)
    b = BeamTable.from_scans(scans, compiled=True)
    c = BeamTable.from_scans([s.tolist() for s in scans])  # the general path (lists)
    for x in (b, c):
        for f in ("ranges", "bearings", "labels", "pose_of", "first", "_sorted", "_key",
                  "_seg_start", "_seg_len", "_dense", "_sorted_bearing", "bearing_min",
                  "bearing_max"):
            assert np.array_equal(getattr(x, f), getattr(a, f)), f
    assert np.array_equal(b._bin_lo, a._bin_lo)

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


def test_nearest_at_is_the_chain_of_ifs():
    """compiled._nearest_at (branch-free) gives the position and difference of _nearest (bin
    table, wrap by _wrap) for bearings anywhere, near beams and at the wrap."""
    from hw4.core import compiled
    from hw4.core.sensor import BINS
    rng = np.random.default_rng(11)
    scans = _scans(rng, n_poses=40, rows=2)
    scans.append(np.array([[1.0, -1.0, 0.5], [0.0, 1e-17, -0.5]]))  # bearings 0, pi, -pi/4
    t = BeamTable.from_scans(scans, compiled=True)
    srt = t._sorted.astype(np.int64)
    seg_start, seg_len = t._seg_start.astype(np.int64), t._seg_len.astype(np.int64)
    sb = t._sorted_bearing
    for p in range(len(scans)):
        if t._dense[p]:
            continue
        beams = sb[seg_start[p]:seg_start[p] + seg_len[p]]
        phis = np.concatenate([rng.uniform(-np.pi, np.pi, 300), beams, np.nextafter(beams, 9),
                               np.nextafter(beams, -9), [-np.pi, np.pi, 0.0, -0.0]])
        for phi in phis:
            k, d, sure = compiled._nearest_fast(p, phi, srt, seg_start, seg_len, t._bin_lo, sb,
                                                BINS / (2 * np.pi), BINS)
            k2, d2 = compiled._nearest(p, phi, srt, t._key, seg_start, seg_len, t._bin_lo,
                                       t._dense, sb, BINS / (2 * np.pi), BINS)
            if sure:
                assert (k, d) == (k2, d2)


def test_beam_gap_is_the_sine_test():
    from hw4.core import compiled
    rng = np.random.default_rng(5)
    lim = 0.2 + 1e-9
    r = 10.0 ** rng.uniform(-3, 1.5, 200000)
    diff = rng.uniform(0, np.pi / 2, 200000)
    diff[:50000] = (lim / r[:50000]) * (1 + rng.uniform(-1e-6, 1e-6, 50000))  # at the threshold
    diff[50000:60000] = np.arcsin(np.minimum(lim / r[50000:60000], 1.0))
    diff = np.minimum(diff, np.nextafter(np.pi / 2, 0))
    for a, b in zip(r, diff):
        g = a * np.sin(b)
        near, ok = compiled._beam_gap(a, b, lim)
        assert near == (g < lim) and ok == (abs(g - lim) > a * compiled.EPS + 1e-12)


@pytest.mark.parametrize("span", [np.pi / 2, np.pi, 1.9 * np.pi, 2 * np.pi])
@pytest.mark.parametrize("model", ["discrete", "continuous"])
@pytest.mark.parametrize("nearest", [16, None], ids=["nn16", "all"])
def test_cells_behind_the_laser_agree_with_numpy(span, model, nearest):
    """Lasers of narrow to full spans (the cells behind them skip the lookup): the compiled
    map is the numpy engine's (discrete bit for bit, continuous to 1e-12 as elsewhere)."""
    from hw4.core.evidence import count_evidence
    from hw4.core.grid import Grid
    rng = np.random.default_rng(int(span * 100) + (model == "discrete"))
    n_poses, n_beams = 60, 90
    poses = np.column_stack([rng.uniform(-4, 4, n_poses), rng.uniform(-4, 4, n_poses),
                             rng.uniform(-np.pi, np.pi, n_poses)])
    scans = []
    for _ in range(n_poses):
        ang = np.linspace(-span / 2, span / 2, n_beams, endpoint=span < 2 * np.pi)
        z = rng.uniform(0.5, 6.0, n_beams)
        scans.append(np.vstack([z * np.cos(ang), z * np.sin(ang)]))
    grid = Grid(0.1, (-5.0, 5.0), (-5.0, 5.0))
    kw = dict(model=model, nearest_poses=nearest, z_max=8.0)
    a = count_evidence(grid, poses, scans, engine="compiled", **kw)
    b = count_evidence(grid, poses, scans, engine="numpy", **kw)
    assert b.sum() > 0
    if model == "continuous":
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=0)
    else:
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("dtype", [np.bool_, np.int32, np.int64, np.float16, np.float32])
def test_row_sum_of_other_dtypes_is_numpys(dtype):
    """The column chain serves float64 only: other dtypes get numpy's promotion (bool and int32
    sum as int64, no overflow)."""
    a = np.array([[1, 1, 0], [2 ** 15 - 1, 1, 7]]).astype(dtype)
    if dtype is np.int32:
        a[1, 0] = 2 ** 31 - 1
    got, want = posterior._row_sum(a), a.sum(axis=1, keepdims=True)
    assert got.dtype == want.dtype and np.array_equal(got, want)


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("where", ["scan nan", "scan inf", "pose nan", "pose inf"])
def test_non_finite_inputs_are_refused_by_both_engines(engine, where):
    """The shortcuts are exact for finite data only (the data checks refuse the rest on the
    command line): count_evidence itself refuses NaN or inf end points and poses in one line."""
    from hw4.core.errors import InputError
    from hw4.core.evidence import count_evidence
    from hw4.core.grid import Grid
    rng = np.random.default_rng(3)
    poses = np.column_stack([rng.uniform(-1, 1, 6), rng.uniform(-1, 1, 6), rng.uniform(-3, 3, 6)])
    ang = np.linspace(-np.pi / 2, np.pi / 2, 40)
    scans = [np.vstack([2 * np.cos(ang), 2 * np.sin(ang)]) for _ in range(6)]
    bad = np.nan if "nan" in where else np.inf
    if where.startswith("scan"):
        scans[2][0, 5] = bad
    else:
        poses[4, 2 if bad is np.nan else 0] = bad
    grid = Grid(0.2, (-3.0, 3.0), (-3.0, 3.0))
    with pytest.raises(InputError, match="finite"):
        count_evidence(grid, poses, scans, model="continuous", nearest_poses=4, engine=engine)
    with pytest.raises(InputError, match="finite"):
        count_evidence(grid, poses, scans, model="discrete", nearest_poses=None, engine=engine)

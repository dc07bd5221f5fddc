"""The vectorised bearing loop of the pose-by-pose pass (hw4.core.compiled._bearings_simd).

Its ranges must be the numpy reference's own (bit for bit: the decisions on r are exact) and its
bearings within the fast arctangent's bound of the exact wrapped bearing, since every decision
taken from them closer than EPS to its threshold is taken again with ``math.atan2``.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from hw4.core import compiled


def _exact(dx, dy, h):
    return compiled._wrap(math.atan2(dy, dx) - h)


def _run(dx, dy, h, px=0.25, py=-0.5):
    """_bearings_simd on cells at (px + dx, py + dy), and the kernels' exact r and bearings."""
    cells = np.column_stack([px + np.asarray(dx, float), py + np.asarray(dy, float)])
    n = len(cells)
    ent = np.arange(n, dtype=np.int32)[::-1].copy()  # gathered through ent, in any order
    out = [np.empty(n) for _ in range(4)]
    compiled._bearings_simd(ent, 0, n, cells, px, py, h, *out)
    ddx, ddy, r, pa = out
    ex = cells[ent, 0] - px
    ey = cells[ent, 1] - py
    return ex, ey, r, pa, ddx, ddy


@pytest.mark.parametrize("h", [0.0, 1.0, -2.5, math.pi, -math.pi, 3.1302130831850477])
def test_bearings_within_bound_and_ranges_exact(h):
    rng = np.random.default_rng(7)
    scale = 10.0 ** rng.uniform(-4, 1.5, size=(2, 5000))
    dx, dy = rng.standard_normal((2, 5000)) * scale
    # axes, diagonals, the tan(pi/8) switch, the pose's own cell
    t8 = compiled.TAN_PI_8
    edge = [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0), (1.0, 1.0), (-1.0, 1.0),
            (-1.0, -1.0), (1.0, -1.0), (1.0, t8), (t8, 1.0), (-1.0, -t8), (0.0, 0.0),
            (3.0, 1e-300), (-3.0, -1e-300)]
    dx = np.concatenate([dx, [e[0] for e in edge]])
    dy = np.concatenate([dy, [e[1] for e in edge]])
    ex, ey, r, pa, ddx, ddy = _run(dx, dy, h)
    np.testing.assert_array_equal(ddx, ex)
    np.testing.assert_array_equal(ddy, ey)
    np.testing.assert_array_equal(r, np.sqrt(ex ** 2 + ey ** 2))  # hw4.core.sensor.relative's r
    exact = np.array([_exact(a, b, h) for a, b in zip(ex, ey)])
    err = np.abs(pa - exact)
    err = np.minimum(err, 2 * np.pi - err)  # pi and -pi are the same bearing
    assert err.max() < compiled.EPS / 100
    assert np.all((pa >= -np.pi) & (pa <= np.pi))


def test_simd_arctangent_matches_the_scalar_one():
    """The same reduction and series as _atan2_fast: the two agree to rounding."""
    rng = np.random.default_rng(3)
    y, x = rng.standard_normal((2, 20000)) * 10.0 ** rng.uniform(-6, 6, size=(2, 20000))
    d = max(abs(compiled._atan2_simd(a, b) - compiled._atan2_fast(a, b)) for a, b in zip(y, x))
    assert d < 1e-14
    for a, b in ((0.0, 1.0), (0.0, -1.0), (-0.0, -1.0), (1.0, 0.0), (-1.0, -0.0), (0.0, 0.0)):
        assert abs(compiled._atan2_simd(a, b) - math.atan2(a, b)) < 1e-15


@pytest.mark.parametrize("model", ["discrete", "continuous"])
@pytest.mark.parametrize("nearest", [16, None], ids=["nn16", "all"])
def test_scalar_poses_beside_vectorised_ones_agree_with_numpy(model, nearest):
    """Poses the vectorised loops skip (a heading beyond [-pi, pi]; two bearings in one bin of
    the bearing table) take the scalar path beside the others: the map is the numpy engine's."""
    from hw4.core.evidence import count_evidence
    from hw4.core.grid import Grid
    from hw4.tasks import load_task_data
    data = load_task_data(1)
    poses = np.array(data.poses, dtype=float)
    poses[::3, 2] += 2 * np.pi  # the same heading, written beyond pi
    poses[1::7, 2] -= 4 * np.pi
    scans = [np.asarray(s[:2], dtype=float) for s in data.scans]
    for t in range(0, len(scans), 5):  # a second beam 1e-6 rad from the first: a dense bin
        s = scans[t]
        r = np.hypot(s[0, 0], s[1, 0])
        b = np.arctan2(s[1, 0], s[0, 0]) + 1e-6
        scans[t] = np.column_stack([s, [r * 0.9 * np.cos(b), r * 0.9 * np.sin(b)]])
    grid = Grid(0.5)
    kw = dict(model=model, nearest_poses=nearest)
    a = count_evidence(grid, poses, scans, engine="compiled", **kw)
    b = count_evidence(grid, poses, scans, engine="numpy", **kw)
    assert b.sum() > 0
    if model == "continuous":
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=0)
    else:
        np.testing.assert_array_equal(a, b)

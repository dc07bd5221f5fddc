"""Properties of the package's maps, synthetic scenes, and the sparse kernel."""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import build_map, evidence, intel_map, synthetic_scene
from literal import (CONTINUOUS, FREE, MODELS, SEMANTIC, Z_MAX, cell_grid, kernel,
                     literal_counts, wrap_to_pi)

SIGMA0, L = 0.1, 0.2


def _variants():
    """(model, beams) pairs: every model, plus beams='all' for the continuous ones."""
    out = [(m, "nearest") for m in MODELS]
    out += [(m, "all") for m in MODELS if m in CONTINUOUS]
    return out


VARIANTS = [pytest.param(m, b, id=f"{m}-{b}") for m, b in _variants()]


def _hit_free(model, alpha, beta):
    """Per cell (hit evidence, free evidence) of a package or literal result."""
    if model in SEMANTIC:
        return alpha[:, :FREE].sum(axis=1), alpha[:, FREE]
    return alpha[:, 0], beta[:, 0]


def _kw(model, beams, **kw):
    if beams != "nearest":
        kw["beams"] = beams
    return kw


# ------------------------------------------------------------------------------------------
# Full Intel maps
# ------------------------------------------------------------------------------------------
FULL_MAPS = [pytest.param(m, g, 16, b, id=f"{m}-g{g}-nn16-{b}")
             for m, b in _variants() for g in (0.135, 0.27, 0.5)]
FULL_MAPS += [pytest.param(m, 0.5, None, "nearest", id=f"{m}-g0.5-nnNone-nearest")
              for m in MODELS]


@pytest.mark.parametrize("model, grid_size, nearest_poses, beams", FULL_MAPS)
def test_full_map_counts_never_negative(model, grid_size, nearest_poses, beams):
    semantic = model in SEMANTIC
    obj = intel_map(model, grid_size, nearest_poses, beams)
    assert obj.prior_alpha > 0
    alpha, beta = evidence(obj, semantic)
    n = obj.map["size"]
    assert alpha.shape == ((n, FREE + 1) if semantic else (n, 1))
    assert np.isfinite(alpha).all() and alpha.max() > 0
    assert (alpha >= 0).all(), (f"{(alpha < 0).sum()} negative alpha counts, min {alpha.min()!r}"
                                f" at cell {np.unravel_index(alpha.argmin(), alpha.shape)}")
    if not semantic:
        assert beta.shape == (n, 1)
        assert np.isfinite(beta).all() and beta.max() > 0
        assert (beta >= 0).all(), (f"{(beta < 0).sum()} negative beta counts, min {beta.min()!r}"
                                   f" at cell {np.unravel_index(beta.argmin(), beta.shape)}")


@pytest.mark.parametrize("model", MODELS)
def test_full_map_mean_and_variance_follow_eqs_3_and_10(model):
    """Mean and variance from the evidence (prior included) by Eq. 3/6 or Eq. 10."""
    obj = intel_map(model, 0.27, 16, "nearest")
    a = np.asarray(obj.map["alpha"], dtype=float)
    mean = np.asarray(obj.map["mean"], dtype=float)
    var = np.asarray(obj.map["variance"], dtype=float).reshape(-1)
    if model in SEMANTIC:
        total = a.sum(axis=1)
        np.testing.assert_allclose(mean, a / total[:, None], rtol=1e-12, atol=0)
        p = a.max(axis=1) / total
        np.testing.assert_allclose(var, p * (1 - p) / (total + 1), rtol=1e-9, atol=1e-300)
    else:
        a = a.reshape(-1)
        b = np.asarray(obj.map["beta"], dtype=float).reshape(-1)
        np.testing.assert_allclose(mean.reshape(-1), a / (a + b), rtol=1e-12, atol=0)
        np.testing.assert_allclose(var, a * b / ((a + b) ** 2 * (a + b + 1)),
                                   rtol=1e-9, atol=1e-300)


# ------------------------------------------------------------------------------------------
# Synthetic scenes
# ------------------------------------------------------------------------------------------
def _scene_front():
    """One pose, a fan of 41 beams only in front of the robot (bearings -1..1 rad, 0.05 rad
    apart, wider than w_beam = 2 pi / 133 ~ 0.047, so some cells fall between beams)."""
    pose = (2.0, -3.0, 0.4)
    bearings = np.linspace(-1.0, 1.0, 41)
    ranges = 2.5 + 0.5 * np.sin(3.0 * bearings)
    labels = 1 + np.arange(41) % 6
    return pose, (ranges, bearings, labels)


def _scene_max_range():
    """One pose in the south-west corner looking north-east; 13 max-range readings of 40 m
    (beyond z_max = 30 m) whose end points still fall inside the map, and two readings of
    29.5 m (just short of z_max) at bearings +-0.45 rad."""
    pose = (-12.0, -22.0, math.pi / 4)
    bearings = np.concatenate([[-0.45], np.linspace(-0.3, 0.3, 13), [0.45]])
    ranges = np.concatenate([[29.5], np.full(13, 40.0), [29.5]])
    labels = 1 + np.arange(15) % 6
    return pose, (ranges, bearings, labels)


def _scene_full_circle():
    """One pose, 133 beams evenly spaced all around (so some nearest beams are across the
    +-pi seam from the cell's bearing), ranges between 1 and 4 m."""
    pose = (1.0, -2.0, 2.9)
    bearings = -np.pi + (np.arange(133) + 0.25) * (2 * np.pi / 133)
    ranges = 2.5 + 1.5 * np.sin(5.0 * bearings) * np.cos(2.0 * bearings)
    labels = 1 + np.arange(133) % 6
    return pose, (ranges, bearings, labels)


def _scene(model, which):
    pose, (ranges, bearings, labels) = which()
    scan = (ranges, bearings, labels) if model in SEMANTIC else (ranges, bearings)
    return pose, synthetic_scene([pose], [scan])


def _package(model, beams, robot_pose, laser_scan, grid_size=0.5, nearest_poses=None, **kw):
    obj = build_map(model, robot_pose, laser_scan,
                    **_kw(model, beams, grid_size=grid_size, nearest_poses=nearest_poses, **kw))
    return evidence(obj, model in SEMANTIC)


def _range_bearing(cells, pose):
    d = cells - np.array(pose[:2])
    r = np.hypot(d[:, 0], d[:, 1])
    phi = np.array([wrap_to_pi(a) for a in np.arctan2(d[:, 1], d[:, 0]) - pose[2]])
    return r, phi


@pytest.mark.parametrize("model, beams", VARIANTS)
def test_cells_behind_the_robot_are_untouched(model, beams):
    pose, (robot_pose, laser_scan) = _scene(model, _scene_front)
    alpha, beta = _package(model, beams, robot_pose, laser_scan)
    hit, free = _hit_free(model, alpha, beta)
    cells, _, _ = cell_grid(0.5)
    r, phi = _range_bearing(cells, pose)
    # the cell nearest to 1.5 m straight behind the robot
    behind = np.array(pose[:2]) + 1.5 * np.array([math.cos(pose[2] + math.pi),
                                                  math.sin(pose[2] + math.pi)])
    i = int(np.argmin(np.hypot(*(cells - behind).T)))
    assert r[i] > L and abs(phi[i]) > 2.6
    assert hit[i] == 0 and free[i] == 0
    # every cell behind (|phi| > pi/2 + 1 rad: farther than r from every beam) beyond l
    back = (np.abs(phi) > math.pi / 2 + 1.0 + 1e-6) & (r > L)
    assert back.sum() > 500
    assert (hit[back] == 0).all() and (free[back] == 0).all()
    # ... while the scene does produce evidence in front of the robot
    front = (np.abs(phi) < 1.0) & (r < 2.0)
    assert (free[front] > 0).any() and (hit > 0).any()


@pytest.mark.parametrize("model, beams", VARIANTS)
def test_cells_beyond_z_max_are_untouched(model, beams):
    pose, (robot_pose, laser_scan) = _scene(model, _scene_max_range)
    alpha, beta = _package(model, beams, robot_pose, laser_scan)
    hit, free = _hit_free(model, alpha, beta)
    cells, _, _ = cell_grid(0.5)
    r, phi = _range_bearing(cells, pose)
    beyond = r >= Z_MAX
    # end points (40 m) and the last 10 m of every beam lie inside the map, beyond z_max
    along = beyond & (np.abs(phi) < 0.3) & (r < 40.0)
    assert along.sum() > 10
    assert (hit[beyond] == 0).all() and (free[beyond] == 0).all()
    # the 29.5 m readings are seen, up to z_max, from 25+ m away (a continuous hit needs a cell
    # centre within l of the end point, which the 0.5 m grid need not have)
    if model not in CONTINUOUS:
        assert (hit[(r > 29.0) & (r < Z_MAX)] > 0).any()
    assert (free[(r > 25.0) & (r < 29.0) & (np.abs(phi) > 0.4)] > 0).any()
    # Algorithm 1 counts nothing for a reading at or beyond z_max (cells whose nearest beam is
    # a 40 m one, or no beam within w_beam / 2); Algorithm 2 has no z_max test on the reading,
    # so cells in range along the 40 m beams do get free evidence
    fan = np.abs(phi) < 0.35
    if model in CONTINUOUS:
        assert (free[fan & (r < Z_MAX - L)] > 0).sum() > 10
    else:
        assert (hit[fan] == 0).all() and (free[fan] == 0).all()


@pytest.mark.parametrize("scene", [_scene_front, _scene_max_range, _scene_full_circle],
                         ids=["front", "max_range", "full_circle"])
@pytest.mark.parametrize("model, beams", VARIANTS)
def test_synthetic_scene_matches_literal_everywhere(model, beams, scene):
    """Every cell of the 0.5 m map of a one-pose scene, package vs literal."""
    pose, (robot_pose, laser_scan) = _scene(model, scene)
    alpha, beta = _package(model, beams, robot_pose, laser_scan)
    cells, _, _ = cell_grid(0.5)
    lit = literal_counts(model, robot_pose, laser_scan, range(len(cells)), grid_size=0.5,
                         nearest_poses=None, beams=beams)
    np.testing.assert_allclose(alpha, lit["alpha"], rtol=0, atol=1e-9)
    if model not in SEMANTIC:
        np.testing.assert_allclose(beta, lit["beta"], rtol=0, atol=1e-9)


@pytest.mark.parametrize("model, beams", VARIANTS)
def test_fewer_poses_than_nearest_poses_uses_them_all(model, beams):
    """With one pose, nearest_poses=16 means that pose (KDTree pads the 15 missing ones)."""
    _, (robot_pose, laser_scan) = _scene(model, _scene_front)
    a16, b16 = _package(model, beams, robot_pose, laser_scan, nearest_poses=16)
    a_all, b_all = _package(model, beams, robot_pose, laser_scan, nearest_poses=None)
    assert a_all.max() > 0
    np.testing.assert_allclose(a16, a_all, rtol=0, atol=1e-12)
    if model not in SEMANTIC:
        np.testing.assert_allclose(b16, b_all, rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------------
# The hand-checked scene
# ------------------------------------------------------------------------------------------
# One pose at the origin, heading 0; one beam straight ahead, range 1.0 m (label 3); grid 0.5.
# Cells on the row y = 0 are at x = ..., 0, 0.5, 1.0, 1.5, ... (all exact in binary).
#
# Discrete (w_obstacle = 1.0, so w_obstacle/2 = 0.5; w_beam/2 = pi/133 ~ 0.0236 rad):
#   only the row y = 0, x > 0 is within w_beam/2 of the beam (a cell at y = 0.5 would need
#   x > 0.5 / tan(0.0236) ~ 21 m, outside the map); the cell (0, 0) has r = 0: not in the field.
#   x = 0.5: r = 0.5; r > min(30, 1.5)? no; |0.5 - 1.0| < 0.5? no (equal); r < 1.0 -> beta = 1.
#   x = 1.0: |1.0 - 1.0| = 0 < 0.5 -> alpha = 1.
#   x = 1.5: r > 1.5? no; |1.5 - 1.0| < 0.5? no (equal); r < 1.0? no -> nothing.
#   x >= 2.0: r > 1.5 -> nothing.
# Continuous (l = 0.2, step 0.1: free samples at s = 0.0, 0.1, ..., 0.9; s = 1.0 is not < 1.0):
#   the end point (1, 0) is the centre of the cell (1.0, 0): alpha = k(0) = sigma0 = 0.1; every
#   other cell centre is >= 0.5 m from it.
#   k(0.1) = k(l/2) = 0.1 * [(2 + cos(pi)) (1 - 1/2) / 3 + sin(pi) / (2 pi)] = 0.1 / 6.
#   cell (0.5, 0): samples 0.4, 0.5, 0.6 at d = 0.1, 0, 0.1 (0.3 and 0.7 are at d = l up to
#   rounding, where k is 0 to ~1e-17) -> beta = 0.1 + 2 * 0.1/6 = 0.4/3.
#   cell (1.0, 0): sample 0.9 at d = 0.1 (0.8 at d = l) -> beta = 0.1/6.
#   cell (0, 0): r = 0, not in the field. No other cell centre is within 0.2 m of a sample.
# Semantic: the hit goes to class 3 (column 2), free evidence to column 6, same values.
# With beams='all' the only beam is the nearest one: same counts.
HAND_POSE = (0.0, 0.0, 0.0)
HAND_SCAN = ([1.0], [0.0], [3])
HAND_EXPECTED = {  # (x, y): (hit, free)
    False: {(0.5, 0.0): (0.0, 1.0), (1.0, 0.0): (1.0, 0.0)},
    True: {(0.5, 0.0): (0.0, 0.4 / 3), (1.0, 0.0): (0.1, 0.1 / 6)},
}


def _hand_expected(model, cells, copies):
    n_alpha = FREE + 1 if model in SEMANTIC else 1
    alpha = np.zeros((len(cells), n_alpha))
    beta = np.zeros((len(cells), 1))
    for (x, y), (hit, free) in HAND_EXPECTED[model in CONTINUOUS].items():
        i = int(np.flatnonzero((cells[:, 0] == x) & (cells[:, 1] == y))[0])
        if model in SEMANTIC:
            alpha[i, HAND_SCAN[2][0] - 1] = copies * hit
            alpha[i, FREE] = copies * free
        else:
            alpha[i, 0] = copies * hit
            beta[i, 0] = copies * free
    return alpha, beta


@pytest.mark.parametrize("copies, nearest_poses", [(1, None), (16, 16)],
                         ids=["one-pose-nnNone", "16-copies-nn16"])
@pytest.mark.parametrize("model, beams", VARIANTS)
def test_hand_checked_scene(model, beams, copies, nearest_poses):
    scan = HAND_SCAN if model in SEMANTIC else HAND_SCAN[:2]
    robot_pose, laser_scan = synthetic_scene([HAND_POSE] * copies, [scan] * copies)
    cells, _, _ = cell_grid(0.5)
    want_alpha, want_beta = _hand_expected(model, cells, copies)

    # the literal code on every cell (one pose) or, with 16 poses, on the cells within 3 m
    near = np.flatnonzero(np.hypot(cells[:, 0], cells[:, 1]) < (np.inf if copies == 1 else 3.0))
    lit = literal_counts(model, robot_pose, laser_scan, near, grid_size=0.5,
                         nearest_poses=nearest_poses, beams=beams)
    np.testing.assert_allclose(lit["alpha"], want_alpha[near], rtol=0, atol=1e-12)
    alpha, beta = _package(model, beams, robot_pose, laser_scan, nearest_poses=nearest_poses)
    np.testing.assert_allclose(alpha, want_alpha, rtol=0, atol=1e-9)
    if model not in SEMANTIC:
        np.testing.assert_allclose(lit["beta"], want_beta[near], rtol=0, atol=1e-12)
        np.testing.assert_allclose(beta, want_beta, rtol=0, atol=1e-9)


# ------------------------------------------------------------------------------------------
# The sparse kernel
# ------------------------------------------------------------------------------------------
def test_kernel_end_values():
    from hw4.core.kernel import sparse_kernel
    assert sparse_kernel(0.0, sigma0=SIGMA0, l=L) == pytest.approx(SIGMA0, rel=1e-15)
    assert sparse_kernel(L, sigma0=SIGMA0, l=L) == 0.0
    assert np.all(sparse_kernel(np.array([L, 0.2000001, 0.5, 3.0]), sigma0=SIGMA0, l=L) == 0.0)
    # half-way: (2 + cos(pi)) (1 - 1/2) / 3 = 1/6
    assert sparse_kernel(L / 2, sigma0=SIGMA0, l=L) == pytest.approx(SIGMA0 / 6, rel=1e-12)


def test_kernel_continuous_and_decreasing_on_0_l():
    from hw4.core.kernel import sparse_kernel
    d = np.linspace(0.0, L, 2001)
    k = sparse_kernel(d, sigma0=SIGMA0, l=L)
    assert np.all(np.diff(k) < 0), "not strictly decreasing on [0, l]"
    # continuous (Lipschitz): with u = d / l the bracket's derivative is
    # [-2 pi sin(2 pi u)(1 - u) - (2 + cos(2 pi u))] / 3 + cos(2 pi u), at most 2 pi / 3 + 2
    assert np.max(np.abs(np.diff(k))) <= SIGMA0 / L * (2 * np.pi / 3 + 2) * (d[1] - d[0])
    # and continuous at l, where it meets the zero branch
    near = sparse_kernel(np.array([L - 1e-9, L - 1e-6, L - 1e-3]), sigma0=SIGMA0, l=L)
    assert np.all(np.abs(near) < 1e-9) and np.all(np.abs(near[:2]) < 1e-15)


def test_kernel_never_negative_near_l():
    """k >= 0 (it is a count of evidence), also just short of l, where the two terms of the
    bracket, (1 - u) and -(1 - u) to first order, cancel to O((1 - u)^5)."""
    from hw4.core.kernel import sparse_kernel
    d = np.concatenate([np.linspace(L - 1e-3, L, 100001), L - np.logspace(-16, -2, 1401)])
    k = sparse_kernel(d, sigma0=SIGMA0, l=L)
    assert np.all(k >= 0.0), f"k({d[k.argmin()]!r}) = {k.min()!r} < 0"


def test_kernel_matches_the_handout_formula():
    from hw4.core.kernel import sparse_kernel
    d = np.linspace(0.0, 0.3, 301)
    np.testing.assert_allclose(sparse_kernel(d, sigma0=SIGMA0, l=L),
                               [kernel(x, SIGMA0, L) for x in d], rtol=0, atol=1e-15)


# ------------------------------------------------------------------------------------------
# Corners of the spec: ties between beams, and the bearing pi itself
# ------------------------------------------------------------------------------------------
# Two beams at the same bearing 0 (an exact tie for every cell), ranges 1.0 m and 3.0 m, pose at
# the origin heading 0, grid 0.5. nanargmin takes the FIRST beam: in scan order (1.0, 3.0) the
# cell (1.0, 0) is a discrete hit (|1 - 1| < 0.5), in order (3.0, 1.0) it is free (1 < 3), and
# the hit moves to (3.0, 0). Continuous: the end point, and so alpha = sigma0, is at (1, 0),
# respectively (3, 0).
@pytest.mark.parametrize("order", [(1.0, 3.0), (3.0, 1.0)], ids=["short-first", "long-first"])
@pytest.mark.parametrize("model", MODELS)
def test_ties_between_beams_go_to_the_first(model, order):
    scan = (list(order), [0.0, 0.0], [2, 5]) if model in SEMANTIC else (list(order), [0.0, 0.0])
    robot_pose, laser_scan = synthetic_scene([HAND_POSE], [scan])
    cells, _, _ = cell_grid(0.5)
    lit = literal_counts(model, robot_pose, laser_scan, range(len(cells)), grid_size=0.5,
                         nearest_poses=None)
    hit, free = _hit_free(model, lit["alpha"], lit.get("beta"))
    hit_cell = int(np.flatnonzero((cells[:, 0] == order[0]) & (cells[:, 1] == 0.0))[0])
    other = int(np.flatnonzero((cells[:, 0] == order[1]) & (cells[:, 1] == 0.0))[0])
    assert hit[hit_cell] == pytest.approx(1.0 if model not in CONTINUOUS else SIGMA0)
    assert hit[other] == 0.0 and hit.sum() == hit[hit_cell]
    alpha, beta = _package(model, "nearest", robot_pose, laser_scan)
    np.testing.assert_allclose(alpha, lit["alpha"], rtol=0, atol=1e-9)
    if model not in SEMANTIC:
        np.testing.assert_allclose(beta, lit["beta"], rtol=0, atol=1e-9)


# One pose at the origin heading 0, one beam straight back (bearing pi, range 1.0), grid 0.5.
# The cells on the beam, (-0.5, 0) and (-1.0, 0), have phi = wrapToPI(pi - 0) = pi exactly,
# outside the template's field -pi < phi < pi; every other cell is >= 0.5 m from the beam
# (so > l for the continuous models) and, seen from the robot, more than w_beam / 2 off it.
# So nothing at all is counted.
@pytest.mark.parametrize("model, beams", VARIANTS)
def test_bearing_exactly_pi_is_outside_the_field(model, beams):
    scan = ([1.0], [np.pi], [4]) if model in SEMANTIC else ([1.0], [np.pi])
    robot_pose, laser_scan = synthetic_scene([HAND_POSE], [scan])
    cells, _, _ = cell_grid(0.5)
    lit = literal_counts(model, robot_pose, laser_scan, range(len(cells)), grid_size=0.5,
                         nearest_poses=None, beams=beams)
    assert lit["alpha"].max() == 0.0 and lit.get("beta", np.zeros(1)).max() == 0.0
    alpha, beta = _package(model, beams, robot_pose, laser_scan)
    assert np.abs(alpha).max() <= 1e-9
    if model not in SEMANTIC:
        assert np.abs(beta).max() <= 1e-9

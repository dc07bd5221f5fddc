"""A literal, loop-by-loop transcription of the homework's Algorithms 1 and 2.

This module is the *reference* the vectorised package is tested against. It is written from
the homework handout (Algorithms 1 and 2, Eqs. 1-10) and the course template's conventions
(``utils.wrapToPI``, ``utils.cart2pol``, ``ogm_CSM.is_in_perceptual_field``), for clarity,
not speed, and it deliberately shares no code with ``hw4`` (not even the kernel).

Evidence counts start at 0 here (no prior): compare with ``map['alpha'] - obj.prior_alpha``.

Conventions (course template):

* cells: ``x = np.arange(-15, 20 + g, g)``, ``y = np.arange(-25, 10 + g, g)``,
  ``X, Y = np.meshgrid(x, y)``; cell ``i = iy * len(x) + ix``;
* poses ``(px, py, h)`` in the world frame; a scan is a 2xN (or 3xN, row 3 = label 1..6) array
  of beam end points in the ROBOT frame; beam ``j`` has range ``hypot(x_j, y_j)`` and bearing
  ``arctan2(y_j, x_j)``;
* cell ``m`` uses the 16 nearest poses (``KDTree.query(m, 16)``) or, with
  ``nearest_poses=None``, every pose with ``||m - p|| < z_max``; a pose is used only if ``m``
  is in its perceptual field: ``0 < r < z_max`` and ``-pi < phi < pi``;
* the beam through the cell is ``k = nanargmin |wrapToPI(theta_j - phi)|``.

The only liberty taken for speed is *pruning* (``prune=True``, the default) in the continuous
models: a beam, or a free sample along it, that is provably farther than ``l`` from the cell
(by a margin of at least 1e-6 m, or of two sample steps) is not visited. Such a point would
have added ``kernel(d) = 0`` anyway, so pruning never changes a count; ``prune=False`` visits
everything, and ``tests/test_exactness.py`` checks that both agree.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial import KDTree

RANGE_X = (-15.0, 20.0)
RANGE_Y = (-25.0, 10.0)
Z_MAX = 30.0
N_BEAMS = 133
SIGMA0 = 0.1
LENGTH = 0.2
N_CLASSES = 6          # semantic labels 1..6; index 6 of alpha is free space
FREE = N_CLASSES       # column of the free-space class in the semantic alpha

MODELS = ("CSM", "continuous_CSM", "S_CSM", "continuous_S_CSM")
CONTINUOUS = {"continuous_CSM", "continuous_S_CSM"}
SEMANTIC = {"S_CSM", "continuous_S_CSM"}


# ------------------------------------------------------------------------------------------
# Small helpers, as in the course's utils.py
# ------------------------------------------------------------------------------------------
def wrap_to_pi(angle: float) -> float:
    """wrapToPI of utils.py for one angle: remainder mod 2 pi, then shift into [-pi, pi]."""
    w = float(np.remainder(angle, 2.0 * np.pi))
    while abs(w) > np.pi:
        w -= 2.0 * np.pi * np.sign(w)
    return w


def wrap_to_pi_array(angles: np.ndarray) -> np.ndarray:
    """wrapToPI of utils.py for an array (element-wise identical to :func:`wrap_to_pi`)."""
    w = np.remainder(np.asarray(angles, dtype=float), 2.0 * np.pi)
    idx = np.argwhere(np.abs(w) > np.pi)
    while len(idx):
        w[idx] -= 2.0 * np.pi * np.sign(w[idx])
        idx = np.argwhere(np.abs(w) > np.pi)
    return w


def kernel(d: float, sigma0: float = SIGMA0, l: float = LENGTH) -> float:
    """Sparse kernel, Eq. (7) of the handout, for one distance d >= 0."""
    if d < l:
        return sigma0 * ((2.0 + math.cos(2.0 * math.pi * d / l)) * (1.0 - d / l) / 3.0
                         + math.sin(2.0 * math.pi * d / l) / (2.0 * math.pi))
    return 0.0


def cell_grid(grid_size: float, range_x=RANGE_X, range_y=RANGE_Y):
    """Cell centres exactly as the template builds them: (cells (n, 2), len(x), len(y))."""
    x = np.arange(range_x[0], range_x[1] + grid_size, grid_size)
    y = np.arange(range_y[0], range_y[1] + grid_size, grid_size)
    X, Y = np.meshgrid(x, y)
    cells = np.column_stack([X.ravel(), Y.ravel()])
    return cells, len(x), len(y)


def poses_from_struct(robot_pose) -> list[tuple[float, float, float]]:
    """``robotPose`` struct as scipy.io.loadmat returns it -> list of (x, y, h)."""
    xs = robot_pose["x"][0][0].ravel()
    ys = robot_pose["y"][0][0].ravel()
    hs = robot_pose["h"][0][0].ravel()
    return [(float(xs[t]), float(ys[t]), float(hs[t])) for t in range(len(xs))]


def scans_from_cell(laser_scan) -> list[dict]:
    """``laserScan`` cell -> per scan: ranges, bearings (robot frame; cart2pol) and labels."""
    scans = []
    for t in range(laser_scan.shape[0]):
        a = np.asarray(laser_scan[t][0], dtype=float)
        ranges = np.sqrt(a[0, :] ** 2 + a[1, :] ** 2)
        bearings = np.arctan2(a[1, :], a[0, :])
        labels = a[2, :].astype(int) if a.shape[0] > 2 else None
        scans.append({"range": ranges, "bearing": bearings, "label": labels})
    return scans


# ------------------------------------------------------------------------------------------
# The per-cell steps of the template's build_ogm
# ------------------------------------------------------------------------------------------
def select_poses(m, poses, tree, nearest_poses, z_max=Z_MAX) -> list[int]:
    """Indices of the poses used for cell m."""
    if nearest_poses is None:
        chosen = []
        for t, (px, py, _) in enumerate(poses):
            if math.sqrt((m[0] - px) ** 2 + (m[1] - py) ** 2) < z_max:
                chosen.append(t)
        return chosen
    _, idxs = tree.query(m, nearest_poses)
    # with fewer than nearest_poses poses, KDTree pads with index len(poses): use them all
    return [int(t) for t in np.atleast_1d(idxs) if t < len(poses)]


def perceptual_field(m, pose, z_max=Z_MAX):
    """(inside, r, phi) of cell m seen from pose, as the template's is_in_perceptual_field."""
    px, py, h = pose
    dx = m[0] - px
    dy = m[1] - py
    r = math.sqrt(dx * dx + dy * dy)
    phi = wrap_to_pi(np.arctan2(dy, dx) - h)
    inside = (0 < r < z_max) and (-np.pi < phi < np.pi)
    return inside, r, phi


def nearest_beam(scan, phi):
    """(k, |wrapToPI(theta_k - phi)|): the beam nearest in bearing (first on ties)."""
    bearing_diff = np.abs(wrap_to_pi_array(scan["bearing"] - phi))
    k = int(np.nanargmin(bearing_diff))
    return k, float(bearing_diff[k])


def discrete_update(alpha, beta, r, scan, k, bearing_min, *, semantic, w_obstacle, w_beam,
                    z_max=Z_MAX):
    """Algorithm 1 (and its semantic version, Eq. 8) for one cell and one pose, in place."""
    z_k = float(scan["range"][k])
    if r > min(z_max, z_k + w_obstacle / 2) or bearing_min > w_beam / 2:
        pass                                            # outside the beam
    elif z_k < z_max and abs(r - z_k) < w_obstacle / 2:
        if semantic:
            alpha[int(scan["label"][k]) - 1] += 1       # hit: the beam's class
        else:
            alpha[0] += 1                               # hit: occupied
    elif r < z_k and z_k < z_max:
        if semantic:
            alpha[FREE] += 1                            # pass-through: free-space class
        else:
            beta[0] += 1                                # pass-through: free


def continuous_beam_update(alpha, beta, m, pose, scan, j, r, *, semantic, sample_step,
                           sigma0=SIGMA0, l=LENGTH, prune=True):
    """Algorithm 2 (and Eq. 9) for one cell, one pose and one beam j, in place."""
    px, py, h = pose
    z_j = float(scan["range"][j])
    direction = float(scan["bearing"][j]) + h           # beam direction in the world frame
    c, s = math.cos(direction), math.sin(direction)

    # end point x* = global(x_j); alpha gets kernel(||m - x*||)
    ex = px + z_j * c
    ey = py + z_j * s
    d1 = math.sqrt((m[0] - ex) ** 2 + (m[1] - ey) ** 2)
    if d1 < l:
        if semantic:
            alpha[int(scan["label"][j]) - 1] += kernel(d1, sigma0, l)
        else:
            alpha[0] += kernel(d1, sigma0, l)

    # free samples at s_i = i * step, i = 0, 1, 2, ... while s_i < z_j
    if prune:
        # ||m - x(s)|| >= |r - s|: only samples with s in (r - l, r + l) can be within l;
        # two extra steps either side keep clear of any rounding.
        i_first = max(0, int(math.floor((r - l) / sample_step)) - 2)
        i_last = int(math.ceil((r + l) / sample_step)) + 2
    else:
        i_first, i_last = 0, None
    i = i_first
    while i * sample_step < z_j and (i_last is None or i <= i_last):
        s_i = i * sample_step
        fx = px + s_i * c
        fy = py + s_i * s
        d2 = math.sqrt((m[0] - fx) ** 2 + (m[1] - fy) ** 2)
        if d2 < l:
            if semantic:
                alpha[FREE] += kernel(d2, sigma0, l)
            else:
                beta[0] += kernel(d2, sigma0, l)
        i += 1


def beams_near_cell(scan, r, phi, l=LENGTH, margin=1e-6) -> list[int]:
    """Beams whose ray from the robot can pass within l (+ margin) of the cell (pruning).

    A point at distance s along a beam at angle delta from the cell's bearing is at distance
    sqrt(r^2 + s^2 - 2 r s cos(delta)) from the cell, which is at least r |sin(delta)| when
    cos(delta) > 0 and at least r otherwise.
    """
    delta = wrap_to_pi_array(scan["bearing"] - phi)
    lower = np.where(np.cos(delta) > 0, r * np.abs(np.sin(delta)), r)
    return [int(j) for j in np.nonzero(lower < l + margin)[0]]


# ------------------------------------------------------------------------------------------
# build_ogm for a list of cells
# ------------------------------------------------------------------------------------------
def literal_counts(model: str, robot_pose, laser_scan, cell_ids, *, grid_size: float,
                   nearest_poses=16, beams: str = "nearest", sample_step: float = 0.1,
                   z_max: float = Z_MAX, n_beams: int = N_BEAMS, sigma0: float = SIGMA0,
                   l: float = LENGTH, prune: bool = True, poses=None, scans=None):
    """Evidence counts (no prior) of the cells ``cell_ids`` of the template's grid.

    Parameters
    ----------
    model : one of MODELS
    robot_pose, laser_scan : the ``robotPose`` struct and ``laserScan`` cell as loadmat returns
        them (or ``poses`` / ``scans`` already converted by :func:`poses_from_struct` /
        :func:`scans_from_cell`, to save time when called repeatedly).
    cell_ids : iterable of int, cell indices i = iy * len(x) + ix.

    Returns
    -------
    dict with ``alpha`` (n, 1) and ``beta`` (n, 1) for the binary models, ``alpha`` (n, 7) for
    the semantic ones (free space last), and ``cells`` (n, 2), the centres used.
    """
    if model not in MODELS:
        raise ValueError(model)
    semantic = model in SEMANTIC
    continuous = model in CONTINUOUS
    if beams not in ("nearest", "all"):
        raise ValueError(beams)
    if beams == "all" and not continuous:
        raise ValueError("beams='all' is an option of the continuous models only")

    w_obstacle = 2 * grid_size
    w_beam = 2 * np.pi / n_beams
    if poses is None:
        poses = poses_from_struct(robot_pose)
    if scans is None:
        scans = scans_from_cell(laser_scan)
    tree = KDTree(np.array([[px, py] for px, py, _ in poses]))
    all_cells, _, _ = cell_grid(grid_size)

    cell_ids = [int(i) for i in cell_ids]
    n_alpha = N_CLASSES + 1 if semantic else 1
    alpha = np.zeros((len(cell_ids), n_alpha))
    beta = np.zeros((len(cell_ids), 1))

    for row, i in enumerate(cell_ids):
        m = all_cells[i]
        a = [0.0] * n_alpha
        b = [0.0]
        for t in select_poses(m, poses, tree, nearest_poses, z_max):
            inside, r, phi = perceptual_field(m, poses[t], z_max)
            if not inside:
                continue
            scan = scans[t]
            if not continuous:
                k, bearing_min = nearest_beam(scan, phi)
                discrete_update(a, b, r, scan, k, bearing_min, semantic=semantic,
                                w_obstacle=w_obstacle, w_beam=w_beam, z_max=z_max)
                continue
            if beams == "nearest":
                k, _ = nearest_beam(scan, phi)
                beam_list = [k]
            elif prune:
                beam_list = beams_near_cell(scan, r, phi, l)
            else:
                beam_list = range(len(scan["range"]))
            for j in beam_list:
                continuous_beam_update(a, b, m, poses[t], scan, j, r, semantic=semantic,
                                       sample_step=sample_step, sigma0=sigma0, l=l,
                                       prune=prune)
        alpha[row] = a
        beta[row] = b

    out = {"alpha": alpha, "cells": all_cells[cell_ids]}
    if not semantic:
        out["beta"] = beta
    return out

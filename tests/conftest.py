"""Shared test helpers: the Intel data as loadmat returns it, synthetic structs, cached maps."""
from __future__ import annotations

import functools
import importlib

import numpy as np
from scipy.io import loadmat

MODEL_CLASS = {
    "CSM": ("hw4.ogm_CSM", "ogm_CSM"),
    "continuous_CSM": ("hw4.ogm_continuous_CSM", "ogm_continuous_CSM"),
    "S_CSM": ("hw4.ogm_S_CSM", "ogm_S_CSM"),
    "continuous_S_CSM": ("hw4.ogm_continuous_S_CSM", "ogm_continuous_S_CSM"),
}


def model_class(model: str):
    module, name = MODEL_CLASS[model]
    return getattr(importlib.import_module(module), name)


@functools.lru_cache(maxsize=None)
def intel_raw(semantic: bool):
    """(robotPose, laserScan) of the Intel data exactly as scipy.io.loadmat returns them."""
    from hw4.core.data import INTEL, INTEL_SEMANTIC, ensure
    raw = loadmat(ensure(INTEL_SEMANTIC if semantic else INTEL))
    return raw["robotPose"], raw["laserScan"]


def make_pose_struct(xs, ys, hs):
    """A ``robotPose`` struct shaped like loadmat's: (1, 1) record, fields (N, 1) float arrays."""
    s = np.empty((1, 1), dtype=[("x", "O"), ("y", "O"), ("h", "O")])
    s["x"][0, 0] = np.asarray(xs, dtype=float).reshape(-1, 1)
    s["y"][0, 0] = np.asarray(ys, dtype=float).reshape(-1, 1)
    s["h"][0, 0] = np.asarray(hs, dtype=float).reshape(-1, 1)
    return s


def make_scan_cell(scans):
    """A ``laserScan`` cell shaped like loadmat's: (N, 1) object array of 2xB / 3xB arrays."""
    c = np.empty((len(scans), 1), dtype=object)
    for t, a in enumerate(scans):
        c[t, 0] = np.asarray(a, dtype=float)
    return c


def build_map(model: str, robot_pose, laser_scan, **kw):
    """Construct and build one package map."""
    obj = model_class(model)(**kw)
    obj.construct_map(robot_pose, laser_scan)
    obj.build_ogm()
    return obj


@functools.lru_cache(maxsize=None)
def intel_map(model: str, grid_size: float, nearest_poses, beams: str, range_y=None,
              sample_step=None):
    """The package's Intel map for one parameter set, built once per test session.

    ``range_y=(-25, hi)`` builds only the southern rows of the template grid (same x extent,
    same cell centres, same cell indices i = iy * nx + ix for the rows kept): a cell's counts
    depend only on its centre, and the map is that much cheaper to build.
    """
    kw = {"grid_size": grid_size, "nearest_poses": nearest_poses}
    if beams != "nearest":
        kw["beams"] = beams
    if range_y is not None:
        kw["range_y"] = list(range_y)
    if sample_step is not None:
        kw["sample_step"] = sample_step
    pose, scan = intel_raw(model in ("S_CSM", "continuous_S_CSM"))
    return build_map(model, pose, scan, **kw)


def evidence(obj, semantic: bool):
    """The package's counts with its prior removed: (alpha, beta or None)."""
    alpha = np.asarray(obj.map["alpha"], dtype=float) - obj.prior_alpha
    if semantic:
        return alpha, None
    beta = np.asarray(obj.map["beta"], dtype=float) - obj.prior_alpha
    return alpha.reshape(-1, 1), beta.reshape(-1, 1)


def synthetic_scene(poses, scans):
    """(robotPose, laserScan) as loadmat would return them, from poses [(x, y, h), ...] and
    robot-frame scans given as (ranges, bearings[, labels]) triples of equal-length sequences."""
    arrays = []
    for s in scans:
        r = np.asarray(s[0], dtype=float)
        b = np.asarray(s[1], dtype=float)
        rows = [r * np.cos(b), r * np.sin(b)]
        if len(s) > 2:
            rows.append(np.asarray(s[2], dtype=float))
        arrays.append(np.vstack(rows))
    xs, ys, hs = zip(*poses)
    return make_pose_struct(xs, ys, hs), make_scan_cell(arrays)

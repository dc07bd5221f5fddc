"""Shared test helpers: the Intel data as loadmat returns it, synthetic structs, cached maps."""
from __future__ import annotations

import functools
import importlib

import numpy as np
import pytest
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
    from hw4.data import INTEL, INTEL_SEMANTIC, ensure
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
def intel_map(model: str, grid_size: float, nearest_poses, beams: str):
    """The package's full Intel map for one parameter set, built once per test session."""
    kw = {"grid_size": grid_size, "nearest_poses": nearest_poses}
    if beams != "nearest":
        kw["beams"] = beams
    pose, scan = intel_raw(model in ("S_CSM", "continuous_S_CSM"))
    return build_map(model, pose, scan, **kw)


def evidence(obj, semantic: bool):
    """The package's counts with its prior removed: (alpha, beta or None)."""
    alpha = np.asarray(obj.map["alpha"], dtype=float) - obj.prior_alpha
    if semantic:
        return alpha, None
    beta = np.asarray(obj.map["beta"], dtype=float) - obj.prior_alpha
    return alpha.reshape(-1, 1), beta.reshape(-1, 1)


@pytest.fixture(scope="session")
def intel_binary():
    return intel_raw(False)


@pytest.fixture(scope="session")
def intel_semantic():
    return intel_raw(True)

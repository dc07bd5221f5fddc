"""Numbers that compare two voxel maps of the same scene (e.g. S-CSM and S-BKI)."""
from __future__ import annotations

import numpy as np

from .voxelmap import FREE, OCCUPIED, UNKNOWN, MapView


def summary(view: MapView) -> dict:
    """Counts and mean variances of one map.

    Returns
    -------
    dict with ``voxels`` (with evidence), ``occupied``, ``free``, ``unknown`` (var_thresh view),
    ``occupied_reference`` (without var_thresh), ``mean_variance`` (over the voxels with evidence)
    and ``mean_variance_occupied``.
    """
    occ = view.state == OCCUPIED
    return {"voxels": len(view), "occupied": int(occ.sum()), "free": int((view.state == FREE).sum()),
            "unknown": int((view.state == UNKNOWN).sum()),
            "occupied_reference": int((view.state_reference == OCCUPIED).sum()),
            "mean_variance": float(view.variance.mean()) if len(view) else float("nan"),
            "mean_variance_occupied": float(view.variance[occ].mean()) if occ.any() else float("nan")}


def _keys(view: MapView) -> np.ndarray:
    idx = np.floor(view.centres / view.resolution).astype(np.int64) + (1 << 20)
    return (idx[:, 0] << 42) | (idx[:, 1] << 21) | idx[:, 2]


def compare(a: MapView, b: MapView) -> dict:
    """How two maps of the same voxel grid differ.

    Returns
    -------
    dict with ``common`` (voxels with evidence in both), ``only_a``, ``only_b``,
    ``class_differs`` (share of the common voxels whose most likely class differs) and
    ``class_differs_occupied`` (the same among common voxels that either map calls occupied),
    and the numbers of common voxels whose most likely class goes from free in ``a`` to a class
    in ``b`` (``free_to_class``), the reverse (``class_to_free``), or from one class to another
    (``class_to_class``).
    """
    if a.resolution != b.resolution:
        raise ValueError("the maps have different voxel sizes")
    ka, kb = _keys(a), _keys(b)
    _, ia, ib = np.intersect1d(ka, kb, assume_unique=True, return_indices=True)
    ca, cb = a.cls[ia], b.cls[ib]
    differ = ca != cb
    occ = (a.state[ia] == OCCUPIED) | (b.state[ib] == OCCUPIED)
    return {"common": len(ia), "only_a": len(ka) - len(ia), "only_b": len(kb) - len(ia),
            "class_differs": float(differ.mean()) if len(ia) else float("nan"),
            "class_differs_occupied": float(differ[occ].mean()) if occ.any() else float("nan"),
            "free_to_class": int(((ca == 0) & (cb > 0)).sum()),
            "class_to_free": int(((ca > 0) & (cb == 0)).sum()),
            "class_to_class": int(((ca > 0) & (cb > 0) & differ).sum())}


def distance_to_path(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Horizontal distance [m] from each of ``points`` (N, 3) to the nearest of the sensor origins
    ``path`` (T, 3), world frame (a proxy for the range at which the scans saw a voxel)."""
    from scipy.spatial import cKDTree
    return cKDTree(np.asarray(path, float)[:, :2]).query(np.asarray(points, float)[:, :2])[0]

"""One labelled 3D scan in the world frame, and the checks every scan passes before mapping.

A :class:`Scan` is what every reader (:mod:`hw4.bki.pcd`, :mod:`hw4.bki.kitti`) returns and what
:mod:`hw4.bki.training` consumes: end points and their class labels, both in the world frame, and
the sensor origin of the scan in the same frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError


@dataclass
class Scan:
    """A labelled scan.

    Attributes
    ----------
    points : (N, 3) float array [m], world frame
        Beam end points.
    labels : (N,) int array
        Class of each end point, ``1 .. num_class - 1`` (0 is free space and is never a hit label
        after :func:`validate_scan`; readers drop or reject it).
    origin : (3,) float array [m], world frame
        Sensor origin of the scan (every ray starts here).
    name : str
        Where the scan came from (file name), used in error messages.
    """

    points: np.ndarray
    labels: np.ndarray
    origin: np.ndarray
    name: str = "scan"


def validate_scan(scan: Scan, num_class: int) -> Scan:
    """Check a scan for mapping; return it with canonical dtypes.

    Raises :class:`~hw4.core.errors.InputError` (one sentence) when the scan has no points, a point,
    label or origin is not finite, or a label lies outside ``1 .. num_class - 1``.

    Parameters
    ----------
    scan : Scan
    num_class : int
        Number of map classes including free space (class 0).
    """
    pts = np.asarray(scan.points, dtype=float)
    lab = np.asarray(scan.labels)
    org = np.asarray(scan.origin, dtype=float).reshape(-1)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"{scan.name}: points must be an (N, 3) array; got shape {pts.shape}.")
    if len(pts) == 0:
        raise InputError(f"{scan.name} has no points: nothing to map.")
    if lab.shape != (len(pts),):
        raise InputError(f"{scan.name} has {len(pts)} points but {lab.size} labels.")
    if org.shape != (3,) or not np.all(np.isfinite(org)):
        raise InputError(f"{scan.name}: the sensor origin must be 3 finite numbers; got {org}.")
    finite = np.all(np.isfinite(pts), axis=1)
    if not finite.all():
        i = int(np.flatnonzero(~finite)[0])
        raise InputError(f"{scan.name}: point {i} has a NaN or infinite coordinate "
                         f"({int((~finite).sum())} such points); clean the scan first.")
    labf = np.asarray(lab, dtype=float)
    bad = ~np.isfinite(labf) | (labf != np.round(labf)) | (labf < 1) | (labf > num_class - 1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"{scan.name}: point {i} has label {labf[i]:g}, outside the map's classes "
                         f"1..{num_class - 1} (0 is free space); check num_class in the config.")
    return Scan(pts, labf.astype(np.int64), org, scan.name)

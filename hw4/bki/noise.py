"""A simulated semantic segmenter: the ground-truth labels of a scan with errors like a network's.

This is **not a network**. It stands in for one (the reference paper feeds SqueezeSegV2-kNN
predictions to the map) so that the map's ability to correct labels can be measured on real scans
whose ground truth is known. Its errors are spatially coherent, as a network's are:

* **objects**: every point of an instance (SemanticKITTI's instance id, the high 16 bits of the raw
  label; temporally consistent in a sequence) takes one wrong class with probability ``rate``; the
  draw depends on the instance only, so the same object is wrong in every scan, as a network
  tends to be wrong about one object;
* **range-image patches**: the scan is cut into patches of the range image (``patch_rows`` laser
  rows by ``patch_cols`` of ``cols`` azimuth columns, velodyne frame); every (patch, class) segment
  of the points without an instance takes one wrong class with probability ``rate``, drawn anew
  per scan;
* **scattered noise**: every point independently takes a wrong class with probability ``scatter``
  (default ``rate / 5``).

A wrong class is a plausible one: :data:`CONFUSION` lists the partners of each class
(road/sidewalk/parking, terrain/vegetation, car/other-vehicle/truck, building/fence, pole/sign,
...); the partner is drawn uniformly from the list. Points of class 0 (unlabeled) stay 0, so the
map's unlabeled option applies to this output as to the ground truth.

All draws come from a counter-based hash of ``(seed, what, key)``, so the output is a pure function
of the seed, the scan and its labels, and the sets of wrong segments and points grow with ``rate``
(a larger rate keeps every error of a smaller one).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError
from .kitti import learning_labels

CONFUSION = {
    1: (5, 4),        # car -> other-vehicle, truck
    2: (3, 7),        # bicycle -> motorcycle, bicyclist
    3: (2, 8),        # motorcycle -> bicycle, motorcyclist
    4: (1, 5),        # truck -> car, other-vehicle
    5: (1, 4),        # other-vehicle -> car, truck
    6: (7, 8),        # person -> bicyclist, motorcyclist
    7: (6, 2),        # bicyclist -> person, bicycle
    8: (7, 3),        # motorcyclist -> bicyclist, motorcycle
    9: (11, 10),      # road -> sidewalk, parking
    10: (9, 11),      # parking -> road, sidewalk
    11: (9, 10, 17),  # sidewalk -> road, parking, terrain
    12: (17, 11),     # other-ground -> terrain, sidewalk
    13: (14, 15),     # building -> fence, vegetation
    14: (13, 15),     # fence -> building, vegetation
    15: (17, 16, 14),  # vegetation -> terrain, trunk, fence
    16: (15, 18),     # trunk -> vegetation, pole
    17: (15, 11),     # terrain -> vegetation, sidewalk
    18: (19, 16),     # pole -> traffic-sign, trunk
    19: (18, 13),     # traffic-sign -> pole, building
}
"""Plausible wrong classes of each SemanticKITTI training class (1..19)."""

_NP = max(len(v) for v in CONFUSION.values())
_PARTNERS = np.zeros((20, _NP), np.int64)
_NPART = np.ones(20, np.int64)
for _c, _p in CONFUSION.items():
    _PARTNERS[_c, :len(_p)] = _p
    _NPART[_c] = len(_p)

_M64 = np.uint64(0xFFFFFFFFFFFFFFFF)


def _uniform(keys: np.ndarray, seed: int, salt: int) -> np.ndarray:
    """Uniforms in [0, 1), one per int64 key: splitmix64 of ``key`` mixed with seed and salt."""
    with np.errstate(over="ignore"):
        z = (np.asarray(keys).astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)
             + np.uint64((seed * 1000003 + salt) & 0xFFFFFFFFFFFFFFFF) * np.uint64(0xD1B54A32D192ED03))
        for shift, mult in ((30, 0xBF58476D1CE4E5B9), (27, 0x94D049BB133111EB)):
            z = (z ^ (z >> np.uint64(shift))) * np.uint64(mult)
        z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) / float(1 << 53)


def range_image(xyz: np.ndarray, rows: int = 64, cols: int = 2048, fov_up: float = 3.0,
                fov_down: float = -25.0):
    """Row and column of each point in a spherical range image (velodyne frame, angles in degrees).

    Rows split the elevation range ``[fov_down, fov_up]`` evenly (the HDL-64E's span), columns the
    azimuth; points outside the elevation range are clipped to the first or last row.
    """
    x, y, z = np.asarray(xyz, float).T
    az = np.arctan2(y, x)
    el = np.degrees(np.arctan2(z, np.hypot(x, y)))
    col = np.floor((az + np.pi) / (2 * np.pi) * cols).astype(np.int64) % cols
    row = np.clip(np.floor((fov_up - el) / (fov_up - fov_down) * rows), 0, rows - 1).astype(np.int64)
    return row, col


@dataclass(frozen=True)
class SimulatedSegmenter:
    """Seeded simulated segmenter (see the module docstring); call it as ``seg(t, xyz, raw)``.

    Parameters
    ----------
    rate : float in [0, 1]
        Probability that an object or a (patch, class) segment takes a wrong class.
    seed : int
    scatter : float in [0, 1], optional
        Per-point probability of a wrong class (default ``rate / 5``).
    patch_rows, patch_cols, cols : int
        Patch size in laser rows and azimuth columns, and columns of the range image (64 rows).
    """

    rate: float = 0.3
    seed: int = 0
    scatter: float | None = None
    patch_rows: int = 8
    patch_cols: int = 64
    cols: int = 2048

    def __post_init__(self):
        for nm in ("rate", "scatter"):
            v = getattr(self, nm)
            if v is not None and not (0.0 <= v <= 1.0):
                raise InputError(f"{nm} must lie in [0, 1]; got {v}.")

    def __call__(self, t: int, xyz: np.ndarray, raw: np.ndarray) -> np.ndarray:
        """Noisy classes 0..19 of scan ``t``: ``xyz`` (N, 3) [m] velodyne frame, ``raw`` (N,) uint32."""
        raw = np.asarray(raw, np.uint32)
        gt = learning_labels(raw)
        inst = (raw >> np.uint32(16)).astype(np.int64)
        row, col = range_image(xyz, cols=self.cols)
        patch = (row // self.patch_rows) * (self.cols // self.patch_cols + 1) + col // self.patch_cols
        # segment keys: objects by (instance, class), the rest by (scan, patch, class)
        obj = inst > 0
        key = np.where(obj, (inst << 8) | gt, (((np.int64(t) + 1) << 40) | (patch << 8) | gt))
        uniq, inv = np.unique(key, return_inverse=True)
        flip = _uniform(uniq, self.seed, 1)[inv] < self.rate
        pick_seg = _uniform(uniq, self.seed, 2)[inv]
        pid = (np.int64(t) << 24) | np.arange(len(gt), dtype=np.int64)
        scatter = self.rate / 5 if self.scatter is None else self.scatter
        scat = _uniform(pid, self.seed, 3) < scatter
        pick = np.where(scat, _uniform(pid, self.seed, 4), pick_seg)
        wrong = (flip | scat) & (gt > 0)
        j = np.minimum((pick * _NPART[gt]).astype(np.int64), _NPART[gt] - 1)
        return np.where(wrong, _PARTNERS[gt, j], gt)

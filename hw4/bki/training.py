"""Training data of one scan: downsampled labelled hits plus free-space samples along their rays.

This follows the reference implementation's construction (BKISemanticMapping,
``get_training_data``), stated exactly:

1. Downsample the labelled end points on a voxel grid of ``ds_resolution``: the leaf of a point is
   ``floor(x / ds_resolution)`` per axis; each occupied leaf gives one point at the centroid of its
   points, with the majority label (ties go to the smallest label).
2. Drop downsampled hits farther than ``max_range`` from the sensor origin (when ``max_range > 0``).
3. Along each kept ray of length ``L`` place free points at distances ``free_resolution``,
   ``2 free_resolution``, ... ``< L`` from the origin, one more at ``L - free_resolution`` when
   ``L > free_resolution``, and the sensor origin itself.
4. Downsample the free points on the same grid (centroids) and give them class 0 (free).

Everything is in the world frame and in metres.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError
from .scan import Scan

_OFF = np.int64(1 << 20)  # leaf index offset: keys are valid for |x| < 2^20 ds_resolution
MAX_FREE_BYTES = 2 * 2**30  # refuse one scan's free samples beyond this working memory
BYTES_PER_FREE_SAMPLE = 120  # positions, ray and step indices, leaf keys per free sample [bytes]


@dataclass
class TrainingData:
    """Training points of one scan.

    Attributes
    ----------
    points : (N, 3) float array [m], world frame
        Downsampled hits first, then downsampled free points.
    labels : (N,) int array
        Class of each point; 0 = free.
    n_hits, n_free : int
        How many of the points are hits and free samples.
    """

    points: np.ndarray
    labels: np.ndarray
    n_hits: int
    n_free: int


def _far(size: float) -> InputError:
    return InputError(f"a point lies farther than {float(_OFF) * size:g} m from the world origin "
                      f"for a grid of {size} m; check the units and poses of the scan.")


def leaf_keys(points: np.ndarray, size: float) -> np.ndarray:
    """Pack the leaf index ``floor(x / size)`` of each point into one int64 key (lexicographic order).

    Parameters
    ----------
    points : (N, 3) float array [m], world frame
    size : float [m]
        Leaf (voxel) edge length.
    """
    cells = np.floor(points / size)
    if cells.size and (cells.min() < -_OFF or cells.max() >= _OFF):  # checked before the int cast
        raise _far(size)
    idx = cells.astype(np.int64) + _OFF
    return (idx[:, 0] << 42) | (idx[:, 1] << 21) | idx[:, 2]


def downsample(points: np.ndarray, labels: np.ndarray | None, size: float,
               num_labels: int | None = None):
    """Voxel-grid downsampling: centroid per leaf and (optionally) its majority label.

    Parameters
    ----------
    points : (N, 3) float array [m], world frame
    labels : (N,) int array or None
        Labels ``0 .. num_labels - 1``; the majority per leaf is returned, ties to the smallest.
    size : float [m]
        Leaf size; a non-positive size returns the input unchanged (as the reference does).
    num_labels : int, optional
        Upper bound on the labels (default ``labels.max() + 1``).

    Returns
    -------
    centroids : (M, 3) float array [m], one per occupied leaf, in increasing leaf-key order
    majority : (M,) int array or None
    """
    if size <= 0:
        return points.copy(), (None if labels is None else labels.copy())
    if len(points) == 0:
        return np.zeros((0, 3)), (None if labels is None else np.zeros(0, dtype=np.int64))
    keys = leaf_keys(points, size)
    uniq, inv, cnt = np.unique(keys, return_inverse=True, return_counts=True)
    m = len(uniq)
    cen = np.column_stack([np.bincount(inv, points[:, a], minlength=m) for a in range(3)]) / cnt[:, None]
    if labels is None:
        return cen, None
    k = int(num_labels if num_labels is not None else labels.max() + 1)
    if m * k <= 4 * len(labels):  # few bins: count every leaf's votes
        votes = np.bincount(inv * k + labels, minlength=m * k).reshape(m, k)
        return cen, np.argmax(votes, axis=1)  # argmax takes the first maximum: smallest label wins
    # a leaf whose points share one label has it as majority; vote only in the other leaves
    majority = np.empty(m, np.int64)
    majority[inv] = labels  # some label of each leaf's points
    other = labels != majority[inv]
    mixed = np.zeros(m, bool)
    mixed[inv[other]] = True
    if mixed.any():
        rank = np.cumsum(mixed) - 1
        sel = mixed[inv]
        votes = np.bincount(rank[inv[sel]] * k + labels[sel], minlength=int(mixed.sum()) * k)
        majority[mixed] = np.argmax(votes.reshape(-1, k), axis=1)  # first maximum: smallest label
    return cen, majority


def _check_free_resolution(free_resolution: float) -> None:
    if free_resolution <= 0:
        raise InputError(f"free_resolution must be positive; got {free_resolution}.")


def _check_free_memory(length: np.ndarray, free_resolution: float) -> None:
    """Refuse, before allocating, free samples of rays of ``length`` [m] beyond MAX_FREE_BYTES."""
    with np.errstate(over="ignore"):
        total = float(np.sum(length / free_resolution)) + 2.0 * len(length)
    if total * BYTES_PER_FREE_SAMPLE > MAX_FREE_BYTES:
        raise InputError(f"free_resolution {free_resolution:g} m gives about {total:.3g} free samples "
                         f"for the {len(length):,} rays of one scan (longest {length.max():.3g} m), "
                         f"about {total * BYTES_PER_FREE_SAMPLE / 2**30:.3g} GiB: use a larger "
                         "free_resolution or a max_range.")


def free_samples(hits: np.ndarray, origin: np.ndarray, free_resolution: float) -> np.ndarray:
    """Free-space points along the rays from ``origin`` to each hit, plus the origin.

    For a ray of length ``L``: points at ``j * free_resolution`` for every integer ``j >= 1`` with
    ``j * free_resolution < L``, one at ``L - free_resolution`` when ``L > free_resolution``, and the
    origin once per ray. A hit at the origin itself (``L = 0``) gives only the origin.

    Parameters
    ----------
    hits : (N, 3) float array [m], world frame
    origin : (3,) float array [m], world frame
    free_resolution : float [m], > 0

    Returns
    -------
    (M, 3) float array [m], world frame (not downsampled; rays in input order, origin first)
    """
    _check_free_resolution(free_resolution)
    diff = hits - origin
    length = np.linalg.norm(diff, axis=1)
    _check_free_memory(length, free_resolution)
    # number of j >= 1 with j * fr < L (guarded against rounding of L / fr)
    n = np.maximum(np.ceil(length / free_resolution).astype(np.int64) - 1, 0)
    n = np.where((n > 0) & (n * free_resolution >= length), n - 1, n)
    n = np.where((n + 1) * free_resolution < length, n + 1, n)
    tail = length > free_resolution
    per_ray = 1 + n + tail  # origin, the regular samples, the last one
    start = np.cumsum(per_ray) - per_ray
    more = np.flatnonzero(per_ray > 1)  # rays longer than free_resolution (so L > 0)
    if 2 * len(more) > len(hits):  # most rays have samples beyond the origin: all in one go
        with np.errstate(invalid="ignore", divide="ignore"):
            unit = np.where(length[:, None] > 0, diff / length[:, None], 0.0)
        ray = np.repeat(np.arange(len(hits)), per_ray)
        pos = np.arange(per_ray.sum()) - start[ray]  # 0 = origin, 1..n regular, n+1 tail
        dist = np.where(pos <= n[ray], pos * free_resolution, length[ray] - free_resolution)
        return origin + unit[ray] * dist[:, None]
    out = np.empty((int(per_ray.sum()), 3))
    out[start] = origin  # each ray's first sample (what origin + unit * 0 gives)
    if len(more):
        k = per_ray[more] - 1
        ray = np.repeat(more, k)
        pos = np.arange(int(k.sum())) - np.repeat(np.cumsum(k) - k, k) + 1  # 1..n regular, n+1 tail
        dist = np.where(pos <= n[ray], pos * free_resolution, length[ray] - free_resolution)
        unit = diff[more] / length[more, None]
        out[start[ray] + pos] = origin + unit[np.repeat(np.arange(len(more)), k)] * dist[:, None]
    return out


def training_data(scan: Scan, ds_resolution: float, free_resolution: float, max_range: float,
                  num_class: int, engine: str = "compiled") -> TrainingData:
    """Build the training points of one validated scan (see the module docstring).

    Parameters
    ----------
    scan : Scan
        Points [m] and origin [m] in the world frame, labels ``1 .. num_class - 1``.
    ds_resolution : float [m]
        Downsampling leaf size (hits and free points).
    free_resolution : float [m]
        Spacing of free samples along each ray.
    max_range : float [m]
        Hits (after downsampling) farther than this from the origin are dropped; ``<= 0`` keeps all.
    num_class : int
        Number of classes including free (0).
    engine : {"compiled", "numpy"}
        ``"compiled"`` (:mod:`hw4.bki.compiled`, numba) or the numpy functions of this module:
        the same points bit for bit.
    """
    if engine == "compiled" and ds_resolution > 0:
        return _training_compiled(scan, ds_resolution, free_resolution, max_range, num_class)
    if engine not in ("compiled", "numpy"):
        raise InputError(f"unknown engine {engine!r}; use compiled or numpy.")
    hits, lab = downsample(scan.points, scan.labels, ds_resolution, num_class)
    if max_range > 0:
        keep = np.linalg.norm(hits - scan.origin, axis=1) <= max_range
        hits, lab = hits[keep], lab[keep]
    if len(hits) == 0:
        return TrainingData(np.zeros((0, 3)), np.zeros(0, dtype=np.int64), 0, 0)
    free, _ = downsample(free_samples(hits, scan.origin, free_resolution), None, ds_resolution)
    pts = np.vstack([hits, free])
    labels = np.concatenate([lab, np.zeros(len(free), dtype=np.int64)])
    return TrainingData(pts, labels, len(hits), len(free))


def _training_compiled(scan: Scan, ds_resolution: float, free_resolution: float, max_range: float,
                       num_class: int) -> TrainingData:
    """:func:`training_data` by :mod:`hw4.bki.compiled` (``ds_resolution > 0``), step by step."""
    from . import compiled
    hits, lab, far = compiled.downsample(scan.points, scan.labels, ds_resolution, num_class)
    if far:
        raise _far(ds_resolution)
    origin = np.asarray(scan.origin, dtype=np.float64)
    length = compiled.lengths(hits, origin)      # the ray lengths, computed once
    if max_range > 0:
        keep = length <= max_range
        if not keep.all():
            hits, lab, length = hits[keep], lab[keep], length[keep]
    if len(hits) == 0:
        return TrainingData(np.zeros((0, 3)), np.zeros(0, dtype=np.int64), 0, 0)
    _check_free_resolution(free_resolution)
    _check_free_memory(length, free_resolution)
    free, far = compiled.free_leaves(hits, origin, length, free_resolution, ds_resolution)
    if far:
        raise _far(ds_resolution)
    pts = np.vstack([hits, free])
    labels = np.concatenate([lab, np.zeros(len(free), dtype=np.int64)])
    return TrainingData(pts, labels, len(hits), len(free))

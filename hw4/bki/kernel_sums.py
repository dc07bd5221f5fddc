"""S-BKI evidence of one scan: sparse-kernel sums over all (training point, voxel) pairs, in numpy.

For every training point ``p`` of class ``c`` and every voxel whose centre ``v`` lies at
``d = |p - v| < ell``, S-BKI adds ``k(d)`` to the voxel's evidence for class ``c``. This is the
readable numpy formulation (the ``engine="numpy"`` update of :class:`hw4.bki.voxelmap.VoxelMap`),
the reference that the compiled engine (:mod:`hw4.bki.compiled`) is tested against: per chunk of
points, the squared distances to the centres of the ``(2R + 1)^3`` voxels around each point's
voxel, the pairs within ``ell`` in (point, offset) order, their kernel weights, and one
``bincount`` per (voxel, class) that sums them from 0 in that order.

Conventions (as :mod:`hw4.bki.voxelmap`): voxel ``i = floor(x / r)`` per axis (world frame) has
its centre at ``(i + 0.5) r``; the voxels a scan can reach lie in a box with origin ``lo`` (voxel
indices) and shape ``dims``, raveled in C order (x slowest, z fastest). Distances are computed
exactly as ``((p_x - c_x)^2 + (p_y - c_y)^2) + (p_z - c_z)^2`` with ``c = (i + o + 0.5) r``, and
the kernel by :func:`hw4.core.kernel.sparse_kernel_pieces`; per voxel and class the weights are
summed in the order of the points, offset by offset (x, then y, then z): the map is
deterministic.
"""
from __future__ import annotations

import numpy as np

from ..core.kernel import sparse_kernel_pieces

PAIRS_PER_STEP = 1 << 17  # candidate (point, voxel) pairs per vectorised step (1 MB per array)


def kernel_sums(points: np.ndarray, labels: np.ndarray, base: np.ndarray, lo: np.ndarray,
                dims: np.ndarray, R: int, resolution: float, ell: float, sf2: float, num_class: int):
    """Sparse-kernel evidence of one scan's training points, per touched voxel and class.

    Parameters
    ----------
    points : (N, 3) float array [m], world frame
    labels : (N,) int array, classes ``0 .. num_class - 1``
    base : (N, 3) int array, the voxel of each point (``floor(points / resolution)``)
    lo, dims : (3,) int arrays, origin (voxel indices) and shape of a box that holds every voxel
        within ``R`` voxels of a point's voxel
    R : int, per-axis voxel reach of the kernel (:func:`hw4.bki.voxelmap.kernel_reach`)
    resolution, ell : float [m], voxel edge and kernel length scale
    sf2 : float, kernel scale

    Returns
    -------
    vt : (V,) int64 array, raveled box codes of the voxels reached, increasing
    add : (V, num_class) float array, summed kernel weights per voxel and class
    cnt : (V,) int64 array, number of pairs per voxel
    """
    points = np.asarray(points, dtype=np.float64)
    labels = np.asarray(labels, dtype=np.int64)
    base = np.asarray(base, dtype=np.int64)
    lo = np.asarray(lo, dtype=np.int64)
    dims = np.asarray(dims, dtype=np.int64)
    ell2 = float(ell) ** 2
    off = np.arange(-int(R), int(R) + 1)
    half = off + 0.5
    stride = np.array([dims[1] * dims[2], dims[2], 1], np.int64)
    codes, cls, d2s = [], [], []
    step = max(64, PAIRS_PER_STEP // len(off) ** 3)   # points per step
    for s in range(0, len(points), step):
        p, b = points[s:s + step], base[s:s + step]
        dx = [p[:, a, None] - (b[:, a, None] + half) * resolution for a in range(3)]
        sq = [d * d for d in dx]
        d2 = (sq[0][:, :, None, None] + sq[1][:, None, :, None]) + sq[2][:, None, None, :]
        within = d2 < ell2
        pt, ix, iy, iz = np.nonzero(within)       # (point, offset x, y, z) in lexicographic order
        d2s.append(d2[within])
        cls.append(labels[s + pt])
        codes.append((b[pt] + off[np.column_stack([ix, iy, iz])] - lo) @ stride)
    codes = np.concatenate(codes) if codes else np.zeros(0, np.int64)
    k = sparse_kernel_pieces(np.sqrt(np.concatenate(d2s)) if d2s else np.zeros(0), float(sf2), float(ell))
    vt, rank = np.unique(codes, return_inverse=True)
    V = len(vt)
    add = np.bincount(rank * num_class + np.concatenate(cls or [np.zeros(0, np.int64)]), k,
                      minlength=V * num_class).reshape(V, num_class)
    return vt, add, np.bincount(rank, minlength=V)

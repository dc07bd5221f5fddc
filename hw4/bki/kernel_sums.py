"""S-BKI evidence of one scan: sparse-kernel sums over all (training point, voxel) pairs, compiled.

For every training point ``p`` of class ``c`` and every voxel whose centre ``v`` lies at
``d = |p - v| < ell``, S-BKI adds ``k(d)`` to the voxel's evidence for class ``c``. A scan has
millions of such pairs (3.9 million for the 12 toy scans at 0.1 m voxels, ell = 0.3 m), so the
loop over them is compiled with numba: two passes over the pairs, the first marks the voxels that
any pair reaches, the second sums the kernel per (voxel, class) of those.

Conventions (as :mod:`hw4.bki.voxelmap`): voxel ``i = floor(x / r)`` per axis (world frame) has
its centre at ``(i + 0.5) r``; the voxels a scan can reach lie in a box with origin ``lo`` (voxel
indices) and shape ``dims``, raveled in C order (x slowest, z fastest). Distances are computed
exactly as ``((p_x - c_x)^2 + (p_y - c_y)^2) + (p_z - c_z)^2`` with ``c = (i + o + 0.5) r``, and
the kernel by the same table of polynomial pieces as :func:`hw4.core.kernel.sparse_kernel_pieces`, so
every pair's weight is the one that function gives; per voxel and class the weights are summed in
the order of the points, offset by offset (x, then y, then z), one thread: the map is
deterministic.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..core.kernel import _PIECES, _pieces


@njit(cache=True, nogil=True)
def _pairs(points, labels, base, lo, dims, R, res, ell2, scale, sf2, table, seen, rank, add, cnt):  # pragma: no cover - compiled
    """Visit every (point, voxel) pair with ``d^2 < ell2``. Without ``rank`` (empty), only mark
    ``seen[code] = True``; with it, add ``k(d)`` to ``add[rank[code], label]`` and 1 to
    ``cnt[rank[code]]``. ``code`` is the voxel's raveled index in the box."""
    marking = rank.shape[0] == 0
    top = table.shape[0] - 1
    deg = table.shape[1] - 1
    for i in range(points.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        bx, by, bz = base[i, 0], base[i, 1], base[i, 2]
        c = labels[i]
        for ox in range(-R, R + 1):
            dx = px - (bx + (ox + 0.5)) * res
            sx = dx * dx
            if sx >= ell2:
                continue
            cx = (bx + ox - lo[0]) * dims[1]
            for oy in range(-R, R + 1):
                dy = py - (by + (oy + 0.5)) * res
                sxy = sx + dy * dy
                if sxy >= ell2:
                    continue
                cxy = (cx + by + oy - lo[1]) * dims[2] - lo[2] + bz
                for oz in range(-R, R + 1):
                    dz = pz - (bz + (oz + 0.5)) * res
                    d2 = sxy + dz * dz
                    if d2 >= ell2:
                        continue
                    if marking:
                        seen[cxy + oz] = True
                        continue
                    # the kernel's piece j and u = x P - j - 1/2, as sparse_kernel_pieces
                    r = np.sqrt(d2) * scale
                    j = int(r)
                    if j > top:
                        j = top
                    u = r - j
                    u -= 0.5
                    k = table[j, deg] * u
                    for q in range(deg - 1, 0, -1):
                        k += table[j, q]
                        k *= u
                    k += table[j, 0]
                    k *= sf2
                    if k < 0.0:
                        k = 0.0
                    v = rank[cxy + oz]
                    add[v, c] += k
                    cnt[v] += 1


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
    points = np.ascontiguousarray(points, dtype=np.float64)
    labels = np.ascontiguousarray(labels, dtype=np.int64)
    base = np.ascontiguousarray(base, dtype=np.int64)
    lo = np.ascontiguousarray(lo, dtype=np.int64)
    dims = np.ascontiguousarray(dims, dtype=np.int64)
    ell2 = float(ell) ** 2
    table = _pieces()
    args = (points, labels, base, lo, dims, int(R), float(resolution), ell2, _PIECES / float(ell),
            float(sf2), table)
    n_box = int(np.prod(dims))
    seen = np.zeros(n_box, np.bool_)
    _pairs(*args, seen, np.zeros(0, np.int32), np.zeros((0, num_class)), np.zeros(0, np.int64))
    vt = np.flatnonzero(seen)
    del seen
    rank = np.empty(n_box, np.int32)
    rank[vt] = np.arange(len(vt))
    add = np.zeros((len(vt), num_class))
    cnt = np.zeros(len(vt), np.int64)
    _pairs(*args, np.zeros(0, np.bool_), rank, add, cnt)
    return vt, add, cnt

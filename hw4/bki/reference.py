"""What the reference C++ package (BKISemanticMapping) does differently, as options of our map.

Each function or wrapper reproduces one behaviour of the reference so that its effect on the map
can be measured with our implementation (the book's Task 5 section "beyond the homework" cites
the reference's files and lines). Nothing here changes :class:`~hw4.bki.voxelmap.VoxelMap`.

1. **World frame.** The reference's SemanticKITTI node maps scan ``t`` with
   ``init_trans_to_ground @ P_t @ Tr`` (:data:`INIT_TRANS_TO_GROUND`: camera axes to x right,
   y forward, z up, raised 1 m); ours is ``inv(Tr) @ P_t @ Tr`` (the velodyne frame of scan 0).
   The two frames differ by the fixed rigid transform :func:`frame_change`, so the axis-aligned
   voxel grids differ: :func:`world_poses`.
2. **Unlabeled hits.** The reference inserts hits of class 0 as they are (free-space evidence at
   the hit point); we drop them: the reader's ``unlabeled=`` option
   (:class:`~hw4.bki.kitti.SemanticKITTISequence`).
3. **Sensor origin.** The reference passes the translation of ``P_t`` (the camera position in the
   camera frame of scan 0, before the ground transform) as the origin of every ray:
   :func:`sensor_origins`.
4. **Free-space sampling.** ``free_resolution`` of the config (the reference's KITTI value is
   100 m): no code here, a config setting.
5. **S-CSM grid.** The reference's S-CSM map (block depth 1) has voxel centres on multiples of the
   resolution, half a voxel away from the S-BKI grid: :class:`ShiftedGrid` shifts the training
   points by half a voxel before insertion and the centres back after.
6. **Block neighbourhood.** The reference's S-BKI prediction takes, for the voxels of a block, the
   training points of that block and of its 6 face neighbours only, so kernel contributions from
   points in the 20 edge and corner neighbours are lost: :func:`missed_pairs`,
   :class:`FaceNeighbourMap`.

Units are metres; frames are named in each function.
"""
from __future__ import annotations

import numpy as np

from ..core.errors import InputError
from ..core.kernel import sparse_kernel_pieces
from .voxelmap import MapView, VoxelMap, kernel_reach, posterior_view

FRAMES = ("velodyne", "reference")
ORIGINS = ("true", "reference")

INIT_TRANS_TO_GROUND = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 1], [0, 0, 0, 1]])
"""The reference node's fixed transform from the camera frame of scan 0 to its map frame
(x right, y forward, z up, 1 m above the camera)."""


def frame_change(Tr: np.ndarray) -> np.ndarray:
    """(4, 4) transform from our world frame (velodyne of scan 0) to the reference's map frame.

    ``init_trans_to_ground @ P_t @ Tr = G @ (inv(Tr) @ P_t @ Tr)`` with ``G = init_trans_to_ground @ Tr``.
    """
    return INIT_TRANS_TO_GROUND @ np.asarray(Tr, float)


def world_poses(P: np.ndarray, Tr: np.ndarray, frame: str = "velodyne") -> np.ndarray:
    """Velodyne poses of the scans in the chosen world frame.

    Parameters
    ----------
    P : (T, 4, 4) camera poses (``poses.txt``), camera frame of scan 0
    Tr : (4, 4) velodyne -> camera
    frame : {"velodyne", "reference"}
        ``velodyne``: ``inv(Tr) @ P_t @ Tr`` (ours); ``reference``: ``init_trans_to_ground @ P_t @ Tr``.

    Returns
    -------
    (T, 4, 4) array mapping velodyne coordinates of scan t [m] to world coordinates [m].
    """
    if frame not in FRAMES:
        raise InputError(f"unknown frame {frame!r}; use one of {', '.join(FRAMES)}.")
    P, Tr = np.asarray(P, float), np.asarray(Tr, float)
    left = np.linalg.inv(Tr) if frame == "velodyne" else INIT_TRANS_TO_GROUND
    return left[None] @ P @ Tr[None]


def sensor_origins(P: np.ndarray, Tr: np.ndarray, frame: str = "velodyne",
                   origin: str = "true") -> np.ndarray:
    """(T, 3) sensor origin [m] of each scan, in the world frame ``frame``.

    ``origin="true"``: the velodyne's position (translation of :func:`world_poses`).
    ``origin="reference"``: what the reference node passes (``origin = transform(0..2, 3)`` of
    ``P_t``): the camera position in the camera frame of scan 0 (x right, y down, z forward),
    taken as coordinates of its map frame, so its z grows with the distance driven. Only defined
    with ``frame="reference"``.
    """
    if origin not in ORIGINS:
        raise InputError(f"unknown origin {origin!r}; use one of {', '.join(ORIGINS)}.")
    if origin == "reference":
        if frame != "reference":
            raise InputError("origin='reference' (the camera translation the reference passes) "
                             "only makes sense with frame='reference'.")
        return np.asarray(P, float)[:, :3, 3].copy()
    return world_poses(P, Tr, frame)[:, :3, 3].copy()


# --------------------------------------------------------------------------- 5. S-CSM grid
class ShiftedGrid:
    """A :class:`VoxelMap` whose grid is moved by ``shift`` [m] (per axis) in the world frame.

    Voxel ``i`` covers ``[i r - shift, (i + 1) r - shift)``; with ``shift = r / 2`` its centre is
    ``i r`` (the reference's S-CSM grid, block depth 1). Training points are moved by ``+shift``
    before insertion and the centres of :meth:`view` by ``-shift`` after.

    Attributes
    ----------
    offset : (3,) float array [m]
        The grid origin: the voxel of a world point ``p`` is ``floor((p - offset) / r)``.
    """

    def __init__(self, vmap: VoxelMap, shift):
        self.map = vmap
        self.shift = np.broadcast_to(np.asarray(shift, float), (3,)).copy()
        self.offset = -self.shift
        self.resolution = vmap.resolution

    @classmethod
    def reference_csm(cls, resolution: float, num_class: int, **kw) -> "ShiftedGrid":
        """The reference's S-CSM grid: an S-CSM map with voxel centres on multiples of ``resolution``."""
        return cls(VoxelMap(resolution, num_class, "scsm", **kw), resolution / 2)

    def update(self, points: np.ndarray, labels: np.ndarray) -> None:
        """Insert training points (N, 3) [m], world frame, with their classes."""
        self.map.update(np.asarray(points, float) + self.shift, labels)

    def view(self) -> MapView:
        """The map's :class:`MapView` with centres in the world frame."""
        v = self.map.view()
        v.centres = v.centres - self.shift
        return v


# --------------------------------------------------------------------------- 6. neighbourhood
def reference_block(voxel: np.ndarray, block_depth: int = 3) -> np.ndarray:
    """The reference's block of each voxel index (M, 3): blocks of ``D = 2**(block_depth-1)``
    voxels per axis centred on multiples of ``D r`` (``block_to_hash_key`` rounds ``x / size``),
    so voxel ``i`` lies in block ``floor((i + D/2) / D)``."""
    D = 2 ** (block_depth - 1)
    return (np.asarray(voxel, np.int64) + D // 2) // D


def missed_pairs(points: np.ndarray, labels: np.ndarray, resolution: float, ell: float,
                 sf2: float, block_depth: int = 3):
    """Kernel contributions the reference's 7-block neighbourhood leaves out.

    The reference predicts the voxels of a block from the training points of that block and of its
    6 face neighbours (``get_extended_block``, 7 keys unless compiled with ``PREDICT``); a point in
    an edge or corner neighbour (blocks that differ in two or three axes) is never used, even when
    it lies within ``ell`` of the voxel's centre.

    Parameters
    ----------
    points : (N, 3) float array [m], world frame; labels : (N,) int array
    resolution, ell : float [m]; sf2 : float; block_depth : int (the reference's 3 for S-BKI)

    Returns
    -------
    voxel : (P, 3) int64 voxel indices, cls : (P,) int, weight : (P,) float kernel value
        One row per missed (training point, voxel) pair; and ``total`` (float), the summed kernel
        weight of all pairs within ``ell`` (missed or not).
    """
    points = np.asarray(points, float)
    labels = np.asarray(labels, np.int64)
    R = kernel_reach(resolution, ell)
    o = np.arange(-R, R + 1)
    offs = np.stack(np.meshgrid(o, o, o, indexing="ij"), -1).reshape(-1, 3)       # (m, 3)
    out_v, out_c, out_w, total = [], [], [], 0.0
    # a pair can only be missed when the point lies within ell of block faces on two axes
    D = 2 ** (block_depth - 1)
    u = points / resolution + D / 2                       # block faces at multiples of D
    near_face = np.abs(u - D * np.round(u / D)) * resolution < ell
    cand = np.flatnonzero(near_face.sum(axis=1) >= 2)
    total = float(_kernel_total(points, resolution, ell, sf2, offs))
    step = max(1, (1 << 21) // len(offs))
    for s in range(0, len(cand), step):                     # chunks bound the temporaries
        sel = cand[s:s + step]
        p = points[sel]
        base = np.floor(p / resolution).astype(np.int64)                        # (n, 3)
        vox = base[:, None, :] + offs[None]                                     # (n, m, 3)
        d = np.linalg.norm(p[:, None, :] - (vox + 0.5) * resolution, axis=2)    # (n, m)
        near = d < ell
        diff = reference_block(vox, block_depth) != reference_block(base, block_depth)[:, None, :]
        n, j = np.nonzero(near & (diff.sum(axis=2) >= 2))
        out_v.append(vox[n, j])
        out_c.append(labels[sel][n])
        out_w.append(sparse_kernel_pieces(d[n, j], sf2, ell))
    if not out_v:
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64), np.zeros(0), 0.0
    return np.concatenate(out_v), np.concatenate(out_c), np.concatenate(out_w), total


def _kernel_total(points, resolution, ell, sf2, offs) -> float:
    """Summed kernel weight of all (point, voxel) pairs within ``ell`` (chunked)."""
    total = 0.0
    step = max(1, (1 << 21) // len(offs))
    for s in range(0, len(points), step):
        p = points[s:s + step]
        c = (np.floor(p / resolution)[:, None, :] + offs[None] + 0.5) * resolution
        d = np.linalg.norm(p[:, None, :] - c, axis=2)
        total += float(sparse_kernel_pieces(d[d < ell], sf2, ell).sum())
    return total


def test_blocks(points: np.ndarray, resolution: float, block_depth: int = 3) -> np.ndarray:
    """Sorted keys of the blocks the reference predicts for one scan's training points.

    A block is predicted ("test block") when it or one of its 6 face neighbours holds a training
    point (``has_gp_points_in_bbox`` of the extended block). Keys pack the block indices like
    :func:`reference_block` numbers them.
    """
    blk = np.unique(reference_block(np.floor(np.asarray(points, float) / resolution), block_depth),
                    axis=0)
    faces = np.vstack([np.zeros((1, 3), np.int64), np.eye(3, dtype=np.int64), -np.eye(3, dtype=np.int64)])
    return np.unique(_keys((blk[:, None, :] + faces[None]).reshape(-1, 3)))


def on_block_faces(points: np.ndarray, resolution: float, block_depth: int = 3) -> int:
    """How many points lie exactly (in float32, as the reference stores them) on a face of a
    reference block; such a point is gathered by both blocks' closed-box R-tree search and so
    counted twice for voxels that have both blocks in their neighbourhood."""
    size = np.float32(2 ** (block_depth - 1) * resolution)
    p = np.asarray(points, np.float32)
    k = np.floor(p / size + np.float32(0.5))
    face = (k * size + size / np.float32(2)).astype(np.float32)
    lower = ((k - 1) * size + size / np.float32(2)).astype(np.float32)
    return int(np.any((p == face) | (p == lower), axis=1).sum())


class FaceNeighbourMap:
    """Our S-BKI map emulating the reference's block neighbourhood (point 6).

    Inserts into a full :class:`VoxelMap` (``method="sbki"``) and records the contributions
    :func:`missed_pairs` finds; :meth:`view` subtracts them, so it shows what the reference's
    7-block search computes. A voxel whose whole evidence was missed keeps its place with the prior
    only (class 0, free), as the reference's voxels of a block that is predicted but gets nothing.

    Attributes
    ----------
    missed_weight, total_weight : float
        Summed kernel weight of the missed pairs and of all pairs, over the inserted scans.
    n_missed : int
        Number of missed (training point, voxel) pairs.
    """

    def __init__(self, vmap: VoxelMap, block_depth: int = 3):
        if vmap.method != "sbki":
            raise InputError("the block neighbourhood only matters for S-BKI maps.")
        self.map, self.block_depth = vmap, block_depth
        self.resolution = vmap.resolution
        self._vox, self._cls, self._w = [], [], []
        self.missed_weight = self.total_weight = 0.0
        self.n_missed = 0

    def update(self, points: np.ndarray, labels: np.ndarray) -> None:
        """Insert training points (N, 3) [m], world frame, with their classes."""
        self.map.update(points, labels)
        vox, cls, w, total = missed_pairs(points, labels, self.map.resolution, self.map.ell,
                                          self.map.sf2, self.block_depth)
        self._vox.append(vox)
        self._cls.append(cls)
        self._w.append(w)
        self.missed_weight += float(w.sum())
        self.total_weight += total
        self.n_missed += len(w)

    def view(self) -> MapView:
        """The full map's view with the missed evidence removed (classes and states recomputed)."""
        v = self.map.view()
        if not self._vox:
            return v
        vox = np.vstack(self._vox)
        K = self.map.num_class
        idx = np.floor(v.centres / v.resolution).astype(np.int64)
        keys, qkeys = _keys(idx), _keys(vox)
        order = np.argsort(keys)
        pos = np.searchsorted(keys, qkeys, sorter=order)
        pos = order[np.minimum(pos, len(keys) - 1)]
        if not np.all(keys[pos] == qkeys):  # every missed pair lies within ell of its point
            raise AssertionError("a missed kernel pair has no voxel in the full map")
        sub = np.bincount(pos * K + np.concatenate(self._cls), weights=np.concatenate(self._w),
                          minlength=len(keys) * K).reshape(-1, K)
        # what is left once the missed pairs are taken out; rounding residues (the two sums
        # run in different orders) are zero
        left = v.alpha - self.map.prior - sub
        left[left < 1e-12 * self.map.sf2] = 0.0
        alpha = self.map.prior + left
        return _posterior(v, alpha, self.map.var_thresh)


def _keys(idx: np.ndarray) -> np.ndarray:
    u = np.asarray(idx, np.int64) + (1 << 20)
    return (u[:, 0] << 42) | (u[:, 1] << 21) | u[:, 2]


def _posterior(v: MapView, alpha: np.ndarray, var_thresh: float) -> MapView:
    """A :class:`MapView` like ``v`` with new concentrations ``alpha`` (classes, states recomputed)."""
    return posterior_view(v.centres, alpha, v.count, v.resolution, var_thresh)

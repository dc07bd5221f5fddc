"""Sparse semantic voxel map updated scan by scan with S-BKI or S-CSM.

Voxel ``i = floor(x / resolution)`` (per axis, world frame) covers ``[i r, (i + 1) r)`` and has its
centre at ``(i + 0.5) r``. Each voxel holds Dirichlet concentrations ``alpha_k = prior + e_k`` for
the ``K`` classes (0 = free), where ``e_k`` is the evidence gathered from training points:

* **S-BKI** (semantic Bayesian kernel inference): every training point of class ``k`` adds
  ``k(d)`` to ``e_k`` of *every* voxel whose centre lies at distance ``d < ell`` from it, with the
  sparse kernel ``k(d) = sf2 [(2 + cos(2 pi d / ell))(1 - d / ell) / 3 + sin(2 pi d / ell) / (2 pi)]``
  (:func:`hw4.kernel.sparse_kernel`, clamped at 0 against rounding just below ``ell``).
* **S-CSM** (semantic counting sensor model): every training point adds 1 to ``e_k`` of the one
  voxel that contains it.

Storage is a hash of blocks: the voxels are grouped in blocks of ``4 x 4 x 4``; a sorted array of
the keys of the blocks seen so far maps each block to a slot of a pool of evidence arrays that grows
(by half its size at a time) with the observed volume, never with a bounding box. Updates are
vectorised over all (training point, voxel) pairs of a scan and summed in a fixed order, so the
result is deterministic and independent of thread count.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..kernel import sparse_kernel

B = 4                    # block edge [voxels]
B3 = B ** 3
_SHIFT = 2               # log2(B)
_OFF = np.int64(1 << 20)  # block index offset for packing; |block index| < 2^20
_CHUNK_PAIRS = 1 << 21   # candidate (point, voxel) pairs handled at once (bounds temporary memory)

UNKNOWN, FREE, OCCUPIED = 0, 1, 2
METHODS = ("sbki", "scsm")


def _pack(idx: np.ndarray) -> np.ndarray:
    """Pack (N, 3) block indices into int64 keys whose order is lexicographic in (x, y, z)."""
    u = idx + _OFF
    if u.size and (u.min() < 0 or u.max() >= 2 * _OFF):
        raise InputError("a training point lies too far from the world origin for the voxel map's "
                         "key range; check the units and poses of the scans.")
    return (u[:, 0] << 42) | (u[:, 1] << 21) | u[:, 2]


def _unpack(keys: np.ndarray) -> np.ndarray:
    mask = (1 << 21) - 1
    return np.column_stack([(keys >> 42) & mask, (keys >> 21) & mask, keys & mask]) - _OFF


def kernel_offsets(resolution: float, ell: float) -> np.ndarray:
    """Voxel offsets ``o`` that can hold a centre within ``ell`` of a point in voxel ``0``.

    A point in voxel ``i`` sits at fraction ``f in [0, 1)`` of it per axis, so the centre of voxel
    ``i + o`` is ``(o + 0.5 - f) r`` away along that axis, at least ``max(0, |o| - 0.5) r``. Offsets
    whose smallest possible distance is below ``ell`` are kept (a superset of what any point needs).

    Returns
    -------
    (M, 3) int64 array of offsets [voxels]
    """
    n = int(np.ceil(ell / resolution)) + 1
    r = np.arange(-n, n + 1)
    o = np.stack(np.meshgrid(r, r, r, indexing="ij"), axis=-1).reshape(-1, 3)
    gap = np.maximum(np.abs(o) - 0.5, 0.0) * resolution
    keep = (gap ** 2).sum(axis=1) < ell ** 2 * (1 + 1e-9)
    return o[keep].astype(np.int64)


def contributions(points: np.ndarray, labels: np.ndarray, resolution: float, method: str,
                  sf2: float = 10.0, ell: float = 0.3):
    """Evidence that training points give to voxels: one row per (point, voxel) pair.

    Parameters
    ----------
    points : (N, 3) float array [m], world frame
    labels : (N,) int array, classes 0..K-1
    resolution : float [m]
    method : {"sbki", "scsm"}
    sf2 : float
        Kernel scale (value at distance 0) [evidence per point], S-BKI only.
    ell : float [m]
        Kernel length scale, S-BKI only.

    Returns
    -------
    voxels : (P, 3) int64 array, voxel indices
    classes : (P,) int64 array
    weights : (P,) float array, evidence added (kernel value or 1)
    """
    if method == "scsm":
        return (np.floor(points / resolution).astype(np.int64), labels.astype(np.int64),
                np.ones(len(points)))
    if method != "sbki":
        raise InputError(f"unknown method {method!r}; use one of {', '.join(METHODS)}.")
    offs = kernel_offsets(resolution, ell)
    base = np.floor(points / resolution).astype(np.int64)
    out_v, out_c, out_w = [], [], []
    step = max(1, _CHUNK_PAIRS // len(offs))
    for s in range(0, len(points), step):
        p, b, lab = points[s:s + step], base[s:s + step], labels[s:s + step]
        vox = b[:, None, :] + offs[None, :, :]                       # (n, M, 3)
        diff = p[:, None, :] - (vox + 0.5) * resolution
        d = np.sqrt(np.einsum("nmi,nmi->nm", diff, diff))
        pi, mi = np.nonzero(d < ell)
        w = np.maximum(sparse_kernel(d[pi, mi], sigma0=sf2, l=ell), 0.0)
        out_v.append(vox[pi, mi])
        out_c.append(lab[pi].astype(np.int64))
        out_w.append(w)
    if not out_v:
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(out_v), np.concatenate(out_c), np.concatenate(out_w)


@dataclass
class MapView:
    """Posterior of every voxel with evidence, in increasing (block key, voxel) order.

    Attributes
    ----------
    centres : (M, 3) float array [m], world frame
        Voxel centres.
    alpha : (M, K) float array
        Dirichlet concentrations, prior included.
    probs : (M, K) float array
        Class probabilities ``alpha / sum(alpha)``.
    cls : (M,) int array
        Most likely class (smallest index on ties); 0 = free.
    variance : (M,) float array
        Variance of the most likely class, ``p (1 - p) / (sum(alpha) + 1)``.
    state : (M,) int array
        ``UNKNOWN`` (variance above ``var_thresh``), ``FREE`` or ``OCCUPIED``.
    state_reference : (M,) int array
        The reference implementation's state, which ignores ``var_thresh``: FREE or OCCUPIED by
        ``cls`` alone.
    resolution : float [m]
    """

    centres: np.ndarray
    alpha: np.ndarray
    probs: np.ndarray
    cls: np.ndarray
    variance: np.ndarray
    state: np.ndarray
    state_reference: np.ndarray
    resolution: float

    def __len__(self) -> int:
        return len(self.centres)

    @property
    def occupied(self) -> np.ndarray:
        """Mask of voxels occupied in the var_thresh view."""
        return self.state == OCCUPIED


class VoxelMap:
    """Sparse semantic voxel map (S-BKI or S-CSM), updated incrementally.

    Parameters
    ----------
    resolution : float [m]
        Voxel edge length.
    num_class : int
        Number of classes ``K`` including free (class 0).
    method : {"sbki", "scsm"}
    sf2 : float
        Sparse-kernel scale, S-BKI only.
    ell : float [m]
        Sparse-kernel length scale, S-BKI only.
    prior : float
        Prior concentration per class.
    var_thresh : float
        Voxels whose most-likely-class variance exceeds this are unknown.
    """

    def __init__(self, resolution: float, num_class: int, method: str = "sbki", sf2: float = 10.0,
                 ell: float = 0.3, prior: float = 0.001, var_thresh: float = 0.09):
        if method not in METHODS:
            raise InputError(f"unknown method {method!r}; use one of {', '.join(METHODS)}.")
        for nm, v in (("resolution", resolution), ("ell", ell), ("sf2", sf2), ("prior", prior)):
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"{nm} must be a positive number; got {v}.")
        if int(num_class) != num_class or num_class < 2:
            raise InputError(f"num_class must be an integer >= 2 (free plus one class); got {num_class}.")
        self.resolution, self.num_class, self.method = float(resolution), int(num_class), method
        self.sf2, self.ell, self.prior, self.var_thresh = float(sf2), float(ell), float(prior), float(var_thresh)
        self.keys = np.zeros(0, np.int64)    # sorted block keys
        self.slots = np.zeros(0, np.int64)   # pool slot of each key
        self.pool = np.zeros((16, B3, self.num_class))  # evidence e_k (prior excluded)
        self.n_blocks = 0
        self.n_scans = 0

    # ------------------------------------------------------------------ update
    def update(self, points: np.ndarray, labels: np.ndarray) -> None:
        """Add the evidence of one scan's training points.

        Parameters
        ----------
        points : (N, 3) float array [m], world frame
        labels : (N,) int array, classes ``0 .. K - 1``
        """
        points = np.asarray(points, dtype=float)
        labels = np.asarray(labels)
        if len(points) and (labels.min() < 0 or labels.max() >= self.num_class):
            raise InputError(f"a training label lies outside 0..{self.num_class - 1}.")
        vox, cls, w = contributions(points, labels, self.resolution, self.method, self.sf2, self.ell)
        self.n_scans += 1
        if len(vox):
            self._accumulate(vox, cls, w)

    def _accumulate(self, vox: np.ndarray, cls: np.ndarray, w: np.ndarray) -> None:
        blk = vox >> _SHIFT
        local = ((vox[:, 0] & (B - 1)) * B + (vox[:, 1] & (B - 1))) * B + (vox[:, 2] & (B - 1))
        lo = blk.min(axis=0)
        dims = blk.max(axis=0) - lo + 1
        if np.prod(dims.astype(float)) <= 1 << 23:  # dense scratch grid over the scan's blocks
            flat = np.ravel_multi_index((blk - lo).T, dims)
            seen = np.bincount(flat, minlength=int(np.prod(dims))) > 0
            touched_flat = np.flatnonzero(seen)
            rank_of = np.cumsum(seen) - 1
            rank = rank_of[flat]
            touched = np.column_stack(np.unravel_index(touched_flat, dims)) + lo
        else:  # very spread-out scan: sort instead
            keys = _pack(blk)
            uk, rank = np.unique(keys, return_inverse=True)
            touched = _unpack(uk)
        tkeys = _pack(touched)  # sorted: lexicographic order = raveled order
        T, K = len(tkeys), self.num_class
        add = np.bincount((rank * B3 + local) * K + cls, weights=w, minlength=T * B3 * K)
        slots = self._slots_for(tkeys)  # may grow (replace) the pool: look it up afterwards
        self.pool[slots] += add.reshape(T, B3, K)

    def _slots_for(self, tkeys: np.ndarray) -> np.ndarray:
        """Pool slots of the sorted block keys ``tkeys``, allocating the new ones."""
        pos = np.searchsorted(self.keys, tkeys)
        found = np.zeros(len(tkeys), bool)
        inside = pos < len(self.keys)
        found[inside] = self.keys[pos[inside]] == tkeys[inside]
        slots = np.empty(len(tkeys), np.int64)
        slots[found] = self.slots[pos[found]]
        new = ~found
        n_new = int(new.sum())
        if n_new:
            first = self.n_blocks
            slots[new] = np.arange(first, first + n_new)
            need = first + n_new
            if need > len(self.pool):
                cap = max(need, len(self.pool) + len(self.pool) // 2)
                grown = np.zeros((cap, B3, self.num_class))
                grown[:first] = self.pool[:first]
                self.pool = grown
            self.keys = np.insert(self.keys, pos[new], tkeys[new])
            self.slots = np.insert(self.slots, pos[new], slots[new])
            self.n_blocks = need
        return slots

    # ------------------------------------------------------------------ queries
    @property
    def nbytes(self) -> int:
        """Bytes held by the map's arrays."""
        return self.pool.nbytes + self.keys.nbytes + self.slots.nbytes

    def evidence(self):
        """Voxel indices and evidence of every voxel with evidence, in (block key, voxel) order.

        Returns
        -------
        voxels : (M, 3) int64 array, voxel indices
        e : (M, K) float array, evidence per class (prior excluded)
        """
        ev = self.pool[self.slots].reshape(-1, self.num_class)
        has = ev.sum(axis=1) > 0
        loc = np.arange(B3)
        local = np.column_stack([loc // (B * B), (loc // B) % B, loc % B])
        vox = (_unpack(self.keys)[:, None, :] * B + local[None, :, :]).reshape(-1, 3)
        return vox[has], ev[has]

    def view(self) -> MapView:
        """Posterior of every voxel with evidence (see :class:`MapView`)."""
        vox, ev = self.evidence()
        alpha = ev + self.prior
        total = alpha.sum(axis=1)
        probs = alpha / total[:, None]
        cls = np.argmax(alpha, axis=1)
        p = probs[np.arange(len(cls)), cls]
        var = p * (1 - p) / (total + 1)
        ref = np.where(cls == 0, FREE, OCCUPIED)
        state = np.where(var > self.var_thresh, UNKNOWN, ref)
        return MapView((vox + 0.5) * self.resolution, alpha, probs, cls, var, state, ref,
                       self.resolution)

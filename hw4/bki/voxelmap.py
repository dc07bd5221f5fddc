"""Sparse semantic voxel map updated scan by scan with S-BKI or S-CSM.

Voxel ``i = floor(x / resolution)`` (per axis, world frame) covers ``[i r, (i + 1) r)`` and has its
centre at ``(i + 0.5) r``. Each voxel holds Dirichlet concentrations ``alpha_k = prior + e_k`` for
the ``K`` classes (0 = free), where ``e_k`` is the evidence gathered from training points:

* **S-BKI** (semantic Bayesian kernel inference): every training point of class ``k`` adds
  ``k(d)`` to ``e_k`` of *every* voxel whose centre lies at distance ``d < ell`` from it, with the
  sparse kernel ``k(d) = sf2 [(2 + cos(2 pi d / ell))(1 - d / ell) / 3 + sin(2 pi d / ell) / (2 pi)]``
  (evaluated by :func:`hw4.core.kernel.sparse_kernel_pieces`, which agrees with the closed form
  :func:`hw4.core.kernel.sparse_kernel` to rounding, clamped at 0 just below ``ell``).
* **S-CSM** (semantic counting sensor model): every training point adds 1 to ``e_k`` of the one
  voxel that contains it.

Storage is a hash of blocks: the voxels are grouped in blocks of ``4 x 4 x 4``; a sorted array of
the keys of the blocks seen so far maps each block to a row of a table that holds, per voxel of the
block, the slot of its evidence in a pool with one row per voxel with evidence (``-1``: none yet).
Table and pool grow (by half their size at a time; the pool in place, ``ndarray.resize``, while
small and not viewed, beyond 4 MiB into fresh arrays) with the observed volume, never with
a bounding box, and empty voxels cost 4 bytes. A scan's S-BKI sums over all its (training point,
voxel) pairs run in one order (points in raveled voxel order, per point the offsets in
lexicographic order), so the map is deterministic. Two engines give the same map bit for bit: ``"compiled"`` (the
default; :mod:`hw4.bki.compiled`, numba; ``HW4_THREADS`` threads, default 1, the same map on any
number) and ``"numpy"``, the readable vectorised
reference (:mod:`hw4.bki.kernel_sums` and the S-CSM counts and merge below), which needs no numba.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError


from .kernel_sums import kernel_sums

ENGINES = ("compiled", "numpy")

B = 4                    # block edge [voxels]
B3 = B ** 3
_SHIFT = 2               # log2(B)
_OFF = np.int64(1 << 20)  # block index offset for packing; |block index| < 2^20
_MAX_BOX = 1 << 24       # most voxels in one scan's scratch box of voxels
_MAX_DIRECT = 1 << 21    # most (voxel, class) counts of a scan's box binned without compaction
_FRESH = 1 << 22         # pool evidence [bytes] from which it grows into fresh arrays (see _reserve)

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


def kernel_reach(resolution: float, ell: float) -> int:
    """Largest per-axis voxel offset ``R`` whose centre can lie within ``ell`` of a point.

    A point in voxel ``i`` sits at fraction ``f in [0, 1)`` of it per axis, so the centre of voxel
    ``i + o`` is ``|o + 0.5 - f| r >= (|o| - 0.5) r`` away along that axis; only offsets with
    ``|o| - 0.5 <= ell / r`` can matter, so ``R = floor(ell / r + 0.5)`` (inclusive: a superset; the
    distance test ``d < ell`` decides).
    """
    return int(np.floor(ell / resolution + 0.5))


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
    count : (M,) int array
        Number of training points that reached each voxel (within ``ell`` for S-BKI, inside it for
        S-CSM), summed over scans.
    resolution : float [m]
    """

    centres: np.ndarray
    alpha: np.ndarray
    probs: np.ndarray
    cls: np.ndarray
    variance: np.ndarray
    state: np.ndarray
    state_reference: np.ndarray
    count: np.ndarray
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
    engine : {"compiled", "numpy"}
        How a scan's evidence is summed and merged (the same map either way; see the module).
    threads : int, optional
        Threads of the compiled engine (default: ``HW4_THREADS``, else 1); the same map bit for
        bit on any number.
    """

    def __init__(self, resolution: float, num_class: int, method: str = "sbki", sf2: float = 10.0,
                 ell: float = 0.3, prior: float = 0.001, var_thresh: float = 0.09,
                 engine: str = "compiled", threads: int | None = None):
        if method not in METHODS:
            raise InputError(f"unknown method {method!r}; use one of {', '.join(METHODS)}.")
        if engine not in ENGINES:
            raise InputError(f"unknown engine {engine!r}; use one of {', '.join(ENGINES)}.")
        self.engine = engine
        self.threads = threads   # compiled engine; None: HW4_THREADS (default 1)
        self._scratch = []       # compiled engine: per thread, the scratch of a scan's sums
        for nm, v in (("resolution", resolution), ("ell", ell), ("sf2", sf2), ("prior", prior)):
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"{nm} must be a positive number; got {v}.")
        if int(num_class) != num_class or num_class < 2:
            raise InputError(f"num_class must be an integer >= 2 (free plus one class); got {num_class}.")
        self.resolution, self.num_class, self.method = float(resolution), int(num_class), method
        self.sf2, self.ell, self.prior, self.var_thresh = float(sf2), float(ell), float(prior), float(var_thresh)
        self.keys = np.zeros(0, np.int64)    # sorted block keys
        self.slots = np.zeros(0, np.int64)   # table row of each key
        # per block (row) and voxel in it: the voxel's pool slot, -1 while it has no evidence
        self.table = np.full((16, B3), -1, np.int32)
        # per voxel with evidence: e_0 .. e_{K-1} (prior excluded) and the number of training
        # points that reached it (decides "has evidence", free of rounding); rows from n_voxels
        # on are spare room, undefined (see _reserve)
        self.ev = np.zeros((1024, self.num_class))
        self.count = np.zeros(1024, np.int64)
        self.n_blocks = 0
        self.n_voxels = 0
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
        labels = np.ascontiguousarray(labels, dtype=np.int64)   # read only: no copy when int64
        if points.ndim != 2 or points.shape[1] != 3 or labels.shape != (len(points),):
            raise InputError(f"training points must be (N, 3) with N labels; got {points.shape} "
                             f"and {labels.shape}.")
        if len(points) and (labels.min() < 0 or labels.max() >= self.num_class):
            raise InputError(f"a training label lies outside 0..{self.num_class - 1}.")
        if not np.all(np.isfinite(points)):
            raise InputError("a training point has a NaN or infinite coordinate.")
        self.n_scans += 1
        if len(points) == 0:
            return
        R = 0 if self.method == "scsm" else kernel_reach(self.resolution, self.ell)
        if self.engine == "compiled":
            from .compiled import bases
            base, bmin, bmax = bases(np.ascontiguousarray(points), self.resolution)
        else:
            base = np.floor(points / self.resolution).astype(np.int64)
            bmin, bmax = base.min(axis=0), base.max(axis=0)
        lo = bmin - R   # the scan's scratch box of voxels: origin and shape
        dims = bmax + R - lo + 1
        _pack(np.array([lo >> _SHIFT, (lo + dims - 1) >> _SHIFT]))  # range check of the block keys
        if int(np.prod(dims.astype(np.int64))) > _MAX_BOX:  # very spread out: split along x, recurse
            order = np.argsort(base[:, 0], kind="stable")
            half = len(order) // 2
            if half == 0:
                raise InputError("a single training point spans too many voxels; check resolution.")
            self.n_scans -= 2
            self.update(points[order[:half]], labels[order[:half]])
            self.update(points[order[half:]], labels[order[half:]])
            return
        if self.engine == "compiled":
            self._update_compiled(points, labels, base, lo, dims, R)
        elif self.method == "scsm":
            stride = np.array([dims[1] * dims[2], dims[2], 1], np.int64)
            shift = max(1, int(np.prod(dims.astype(np.int64))) - 1).bit_length()
            vt, add, cnt = self._count((labels << shift) + (base - lo) @ stride, shift, dims)
        else:
            # points in raveled voxel order: consecutive points update neighbouring voxels
            order = np.argsort((base - lo) @ np.array([dims[1] * dims[2], dims[2], 1]), kind="stable")
            vt, add, cnt = kernel_sums(points[order], labels[order], base[order], lo, dims, R,
                                       self.resolution, self.ell, self.sf2, self.num_class)
        if self.engine == "numpy":
            self._merge(vt, add, cnt, lo, dims)

    def _update_compiled(self, points, labels, base, lo, dims, R) -> None:
        """The compiled engine: the scan's sparse evidence (one part per thread, blocks of
        consecutive x slabs), then its merge into the pool, part after part (key order)."""
        from .compiled import _accumulate, _assign, _block_rows, scan_evidence
        parts = scan_evidence(np.ascontiguousarray(points), np.ascontiguousarray(labels), base, lo,
                              dims, R, self.resolution, self.ell, self.sf2, self.method == "scsm",
                              self.threads, self.num_class, self._scratch)
        lo = np.ascontiguousarray(lo, dtype=np.int64)
        dims = np.ascontiguousarray(dims, dtype=np.int64)
        for blk, vloc, vcnt, c0, w0, more, ecls, evalue, enext, acc in parts:
            # touched blocks in key order, their rows (new blocks merged into keys / slots)
            # What can fail (memory, the 2^31 limit) leaves the map as it was before this part:
            # the block keys change once the table has room, and new slots are taken back from
            # the table when the pool cannot grow (MemoryError, an interrupt).
            rows, lbs, keys, slots, n_new = _block_rows(blk, lo, dims, self.keys, self.slots,
                                                        self.n_blocks)
            self._grow_table(self.n_blocks + n_new)
            self.keys, self.slots = keys, slots
            self.n_blocks += n_new
            if self.n_voxels + len(vcnt) >= np.iinfo(np.int32).max:   # near the limit: refuse
                self._reserve(int(np.count_nonzero(  # before the table changes
                    (vloc.reshape(-1, B3)[lbs] >= 0) & (self.table[rows] < 0))))
            first = self.n_voxels
            try:
                slot_of, n_voxels = _assign(self.table, rows, lbs, vloc, len(vcnt), first)
                self._reserve(n_voxels - first)
            except BaseException:
                taken = self.table[rows]
                taken[taken >= first] = -1
                self.table[rows] = taken
                raise
            self.n_voxels = n_voxels
            _accumulate(slot_of, vcnt, c0, w0, more, ecls, evalue, enext, acc, self.ev,
                        self.count)

    def _reserve(self, n_new: int) -> None:
        """Room in the pool for ``n_new`` more voxels, their rows zeroed. The pool grows by half
        its size at a time: in place (``ndarray.resize``: realloc, no copy) while the evidence
        stays under ``_FRESH`` bytes and nothing views it, else into fresh arrays (``np.empty``:
        untouched pages, which numpy advises as transparent huge pages from 4 MiB, so filling
        them takes a fraction of the page faults) with the rows in use copied. Rows beyond
        ``n_voxels`` are spare room, undefined until reserved."""
        need = self.n_voxels + n_new
        if need >= np.iinfo(np.int32).max:
            raise InputError("the voxel map would exceed 2^31 voxels; use a coarser resolution.")
        first = self.n_voxels
        if need > len(self.count):
            cap = max(need, len(self.count) + len(self.count) // 2)
            grown = False
            if cap * self.num_class * 8 < _FRESH:
                try:    # in place unless something views the pool
                    self.ev.resize((cap, self.num_class))
                    self.count.resize(cap)
                    grown = True
                except ValueError:
                    pass
            if not grown:
                ev = np.empty((cap, self.num_class))
                ev[:first] = self.ev[:first]
                count = np.empty(cap, np.int64)
                count[:first] = self.count[:first]
                self.ev, self.count = ev, count
        self.ev[first:need] = 0.0     # the new voxels' rows, in order (pages touched in order)
        self.count[first:need] = 0

    def _count(self, key, shift, dims):
        """S-CSM: the number of training points per touched voxel and class.

        ``key`` is ``class << shift | code`` with ``code`` the raveled index of each point's voxel
        in the scan's box (shape ``dims``). Returns the touched codes (increasing), the counts per
        (voxel, class) as floats and the counts per voxel.
        """
        n_box = int(np.prod(dims.astype(np.int64)))
        K = self.num_class
        if K << shift <= min(_MAX_DIRECT, 2 * len(key)):  # small box: straight into (class, voxel) bins
            full = np.bincount(key, minlength=K << shift).reshape(K, -1)
            cnt = np.bincount(key & ((1 << shift) - 1), minlength=n_box)
            vt = np.flatnonzero(cnt)                   # touched voxels, raveled box order
            return vt, full[:, vt].T.astype(float), cnt[vt]
        code = key & ((1 << shift) - 1)                # compact the touched voxels first
        seen = np.zeros(n_box, bool)
        seen[code] = True
        vt = np.flatnonzero(seen)
        V = len(vt)
        rank = np.empty(n_box, np.int32 if V < 2 ** 31 else np.int64)
        rank[vt] = np.arange(V)
        vr = rank[code]
        add = np.bincount(vr * K + (key >> shift), minlength=V * K).reshape(V, K).astype(float)
        return vt, add, np.bincount(vr, minlength=V)

    def _merge(self, vt, add, cnt, lo, dims) -> None:
        """Add the evidence ``add`` (V, K) and pair counts ``cnt`` (V,) of the touched voxels
        ``vt`` (raveled codes in the scan's box, origin ``lo``, shape ``dims``) to the map."""
        K = self.num_class
        vox = np.column_stack(np.unravel_index(vt, tuple(int(x) for x in dims))) + lo
        local = (vox & (B - 1)) @ np.array([B * B, B, 1], np.int64)
        # the blocks of the touched voxels, sorted by key: marked in the scan's box of blocks
        blo = lo >> _SHIFT
        bdims = tuple(int(x) for x in ((lo + dims - 1) >> _SHIFT) - blo + 1)
        bcode = np.ravel_multi_index(tuple(((vox >> _SHIFT) - blo).T), bdims)
        present = np.zeros(int(np.prod(bdims)), bool)
        present[bcode] = True
        ub = np.flatnonzero(present)                   # raveled (x, y, z) order = key order
        brank = np.empty(len(present), np.int64)
        brank[ub] = np.arange(len(ub))
        tkeys = _pack(np.column_stack(np.unravel_index(ub, bdims)) + blo)
        rows = self._rows_for(tkeys)[brank[bcode]]     # may grow the table
        slots = self.table[rows, local].astype(np.int64)
        new = slots < 0
        n_new = int(new.sum())
        if n_new:
            first = self.n_voxels
            slots[new] = np.arange(first, first + n_new)
            self._reserve(n_new)
            self.table[rows[new], local[new]] = slots[new]
            self.n_voxels = first + n_new
        self.ev[slots] += add
        self.count[slots] += cnt

    def _grow_table(self, need: int) -> None:
        """Room in the table for ``need`` blocks (grown by half its size at a time; new rows -1)."""
        if need > len(self.table):
            first = self.n_blocks
            cap = max(need, len(self.table) + len(self.table) // 2)
            grown = np.full((cap, B3), -1, np.int32)
            grown[:first] = self.table[:first]
            self.table = grown

    def _rows_for(self, tkeys: np.ndarray) -> np.ndarray:
        """Table rows of the sorted block keys ``tkeys``, allocating the new ones."""
        pos = np.searchsorted(self.keys, tkeys)
        found = np.zeros(len(tkeys), bool)
        inside = pos < len(self.keys)
        found[inside] = self.keys[pos[inside]] == tkeys[inside]
        rows = np.empty(len(tkeys), np.int64)
        rows[found] = self.slots[pos[found]]
        new = ~found
        n_new = int(new.sum())
        if n_new:
            first = self.n_blocks
            rows[new] = np.arange(first, first + n_new)
            need = first + n_new
            self._grow_table(need)
            self.keys = np.insert(self.keys, pos[new], tkeys[new])
            self.slots = np.insert(self.slots, pos[new], rows[new])
            self.n_blocks = need
        return rows

    # ------------------------------------------------------------------ queries
    @property
    def nbytes(self) -> int:
        """Bytes held by the map's arrays."""
        return self.table.nbytes + self.ev.nbytes + self.count.nbytes + self.keys.nbytes + self.slots.nbytes

    def evidence(self):
        """Voxel indices and evidence of every voxel with evidence, in (block key, voxel) order.

        Returns
        -------
        voxels : (M, 3) int64 array, voxel indices
        e : (M, K) float array, evidence per class (prior excluded)
        n : (M,) int array, number of training points that reached each voxel (>= 1)
        """
        slot = self.table[self.slots].reshape(-1)
        has = np.flatnonzero(slot >= 0)
        slot = slot[has]
        loc = np.arange(B3)
        local = np.column_stack([loc // (B * B), (loc // B) % B, loc % B])
        vox = _unpack(self.keys)[has >> (3 * _SHIFT)] * B + local[has & (B3 - 1)]
        return vox, self.ev[slot], self.count[slot]

    def view(self) -> MapView:
        """Posterior of every voxel with evidence (see :class:`MapView`)."""
        vox, alpha, count = self.evidence()
        alpha += self.prior   # a fresh copy: in place, the same values as ev + prior
        return posterior_view((vox + 0.5) * self.resolution, alpha, count,
                              self.resolution, self.var_thresh)


def posterior_view(centres: np.ndarray, alpha: np.ndarray, count: np.ndarray, resolution: float,
                   var_thresh: float) -> MapView:
    """The :class:`MapView` of voxels with Dirichlet concentrations ``alpha`` (M, K): class
    probabilities, most likely class (smallest on ties), its variance ``p (1 - p) / (S + 1)`` and
    the states with and without ``var_thresh``."""
    total = alpha.sum(axis=1)
    probs = alpha / total[:, None]
    cls = np.argmax(alpha, axis=1)
    p = probs[np.arange(len(cls)), cls]
    var = p * (1 - p) / (total + 1)
    ref = np.where(cls == 0, FREE, OCCUPIED)
    state = np.where(var > var_thresh, UNKNOWN, ref)
    return MapView(centres, alpha, probs, cls, var, state, ref, count, resolution)

"""The S-BKI / S-CSM insertion of one scan compiled (numba): training data and map update.

:mod:`hw4.bki.training` (``downsample``, ``free_samples``) and the ``engine="numpy"`` update of
:class:`hw4.bki.voxelmap.VoxelMap` keep the readable numpy formulation as the reference; this
module repeats every arithmetic step of it in loops, so the training points and the map are the
same bit for bit (the tests compare the two engines):

* **Downsampling** (:func:`downsample`): the leaf ``floor(x / size)`` of every point (keys
  relative to the scan's box of leaves, lexicographic in x, y, z), the points grouped into runs
  (consecutive points in one leaf), one ``np.sort`` of the values ``key << nb | run`` (each
  leaf's runs in input order), then each leaf's points streamed run by run into its sums (from
  0, in input order: what ``bincount`` adds), divided by their number, and the majority label,
  ties to the smallest.
* **Free samples** (:func:`free_samples`): per ray the numpy formulas, element by element
  (``origin + (diff / L) * dist``, ``L = sqrt((dx^2 + dy^2) + dz^2)`` as ``np.linalg.norm``);
  :func:`free_leaves` downsamples them as they are made (a hash of leaves, sums in sample
  order), the same centroids without holding the samples.
* **Evidence of a scan** (:func:`scan_evidence`): the training points in raveled voxel order
  (stable), taken point by point, each point's pairs in lexicographic offset order (as
  :mod:`hw4.bki.kernel_sums`): per axis only the window of offsets it can reach within ell
  (:func:`window_span`; all of them where rounding lets more in), the pairs within ell listed
  without branches, batch by batch of points, each batch's kernel weights from the table of
  :func:`hw4.core.kernel.sparse_kernel_pieces` in loops of their own (:func:`_kernels`, the
  square roots vectorised); per (voxel, class) the weights are summed from 0
  in that order into a sparse per-scan structure (a target's local voxel found in a
  cache-resident ring of x slabs); ``_assign`` gives the new voxels their pool slots and
  ``_accumulate`` adds the sums to the map's evidence. Adding a
  scan's sum first and the map's value after is the order of the numpy engine
  (``ev[slot] += add``). The same path serves every reach (the toy scans: up to 6^3 of the 7^3
  offsets per point). S-CSM (:func:`_count_evidence`) adds whole numbers, exact in any order:
  its points are counted in input order (no voxel order), each voxel found through its block.

The merge (one compiled pass each): :func:`_block_rows` finds the map rows of the scan's blocks
(new ones merged into the sorted keys), :func:`_assign` gives new voxels pool slots in (block
key, voxel in block) order (the numpy engine: raveled voxel order of the scan's box), and
:func:`_accumulate` adds the sums; the pool's row order is internal, :meth:`VoxelMap.evidence` and
:meth:`VoxelMap.view` are the same. Threads (``HW4_THREADS``, default 1; :func:`threads`): each
sums the voxels of its own slab of x (whole blocks) over the same points in the same order, and
the slabs are merged in key order, so map and pool are the same bit for bit on any number of
threads. Units: metres, world frame; voxel ``i = floor(x / r)``, centre ``(i + 0.5) r``.
"""
from __future__ import annotations

import os
import sys

import numpy as np
from numba import njit

from ..core.kernel import _DEGREE, _PIECES, _pieces

_OFF = 1 << 20   # leaf / block index offset of the packed keys (as training.py, voxelmap.py)


@njit(cache=True, nogil=True)
def _leaf_keys(points, size, nb=0):  # pragma: no cover - compiled
    """Per point a key of its leaf ``floor(x / size)``, lexicographic in (x, y, z) (relative to the
    scan's box of leaves, or the packed key of training.py when that box is too large), and the
    largest key possible. ``far`` when a leaf index lies outside +-2^20 (keys then unset). The
    leaves first in a loop without branches (the divisions vectorised), then the box, then the
    keys; ``points`` C-contiguous. Returns ``(keys, starts, top, far, packed)``.

    With ``nb`` > 0 and the box's keys and ``nb`` bits fitting in 63 (then ``packed``), the
    points come as runs: maximal stretches of consecutive points in one leaf (a lidar's
    neighbouring beams share leaves: about half the points of a SemanticKITTI scan start no new
    run), ``keys[r] = key << nb | r`` per run ``r`` in input order and ``starts`` (one more than
    the runs) the first point of each run and the point count. Otherwise ``keys`` is per point
    and ``starts`` empty."""
    n = points.shape[0]
    flat = points.reshape(-1)
    cells = np.empty(3 * n)
    for j in range(3 * n):
        cells[j] = np.floor(flat[j] / size)
    keys = np.empty(n, np.int64)
    starts = np.empty(0, np.int64)
    if n == 0:
        return keys, starts, 0, False, False
    lo0 = lo1 = lo2 = np.inf
    hi0 = hi1 = hi2 = -np.inf
    for i in range(n):
        lo0 = min(lo0, cells[3 * i])
        hi0 = max(hi0, cells[3 * i])
        lo1 = min(lo1, cells[3 * i + 1])
        hi1 = max(hi1, cells[3 * i + 1])
        lo2 = min(lo2, cells[3 * i + 2])
        hi2 = max(hi2, cells[3 * i + 2])
    if not (lo0 >= -_OFF and lo1 >= -_OFF and lo2 >= -_OFF and hi0 < _OFF and hi1 < _OFF
            and hi2 < _OFF):
        return keys, starts, 0, True, False
    l0, l1, l2 = np.int64(lo0), np.int64(lo1), np.int64(lo2)
    nx = np.int64(hi0) - l0 + 1
    ny = np.int64(hi1) - l1 + 1
    nz = np.int64(hi2) - l2 + 1
    if float(nx) * ny * nz >= 2.0 ** 62:
        for i in range(n):
            keys[i] = (((np.int64(cells[3 * i]) + _OFF) << 42)
                       | ((np.int64(cells[3 * i + 1]) + _OFF) << 21)
                       | (np.int64(cells[3 * i + 2]) + _OFF))
        return keys, starts, (1 << 63) - 1, False, False
    top = nx * ny * nz - 1
    bits = 0
    while (np.int64(1) << bits) <= top:
        bits += 1
    if not (nb > 0 and bits + nb <= 63):
        for i in range(n):
            keys[i] = (((np.int64(cells[3 * i]) - l0) * ny + (np.int64(cells[3 * i + 1]) - l1))
                       * nz + (np.int64(cells[3 * i + 2]) - l2))
        return keys, starts, top, False, False
    starts = np.empty(n + 1, np.int64)
    r = 0
    prev = np.int64(-1)               # keys are >= 0: the first point starts a run
    for i in range(n):                # without branches: slot r written, kept if a run starts
        kk = (((np.int64(cells[3 * i]) - l0) * ny + (np.int64(cells[3 * i + 1]) - l1)) * nz
              + (np.int64(cells[3 * i + 2]) - l2))
        keys[r] = (kk << nb) | r
        starts[r] = i
        r += kk != prev
        prev = kk
    starts[r] = n
    return keys[:r], starts[:r + 1], top, False, True


@njit(cache=True, nogil=True)
def _group_runs(points, labels, packed, starts, nb, num_labels):  # pragma: no cover - compiled
    """Centroid and majority label (``labels`` empty: none) of each leaf, from ``packed``: the
    sorted values ``key << nb | run`` (``run`` numbered in input order, its points
    ``starts[run]`` .. ``starts[run + 1] - 1``). Each run's leaf (its rank among the distinct
    keys) is scattered to the run; then the runs are streamed in input order, each point added
    to its leaf's sums (from 0, in input order: what the stable order and ``bincount`` add), and
    the sums divided by the counts. The majority: a leaf whose points share one label has it
    (each point against the previous one of its leaf); the votes of the other leaves are
    counted over the sorted order, run by run (ties to the smallest label)."""
    nr = packed.shape[0]
    mask = (np.int64(1) << nb) - 1
    inv = np.empty(nr, np.int32)
    has = labels.shape[0] > 0
    m = 0
    prev = np.int64(-1)               # keys are >= 0: the first run starts a leaf
    for t in range(nr):               # without branches
        kk = packed[t] >> nb
        m += kk != prev
        prev = kk
        inv[packed[t] & mask] = m - 1
    sums = np.zeros((m, 4))           # per leaf: the sums of x, y, z and the count (exact)
    maj = np.full(m if has else 0, -1, np.int64)   # per leaf: the label of its latest point
    mixed = np.zeros(m if has else 0, np.bool_)
    for r in range(nr):
        g = inv[r]
        sx = sums[g, 0]
        sy = sums[g, 1]
        sz = sums[g, 2]
        c = sums[g, 3]
        for i in range(starts[r], starts[r + 1]):
            sx += points[i, 0]
            sy += points[i, 1]
            sz += points[i, 2]
            c += 1.0
        sums[g, 0] = sx
        sums[g, 1] = sy
        sums[g, 2] = sz
        sums[g, 3] = c
        if has:                       # a label unlike its leaf's previous one: mixed
            rr = maj[g]
            mx = mixed[g]
            for i in range(starts[r], starts[r + 1]):
                lab = labels[i]
                mx |= (rr >= 0) & (lab != rr)
                rr = lab
            maj[g] = rr
            mixed[g] = mx
    n_mixed = 0
    for g in range(mixed.shape[0]):
        n_mixed += mixed[g]
    cen = np.empty((m, 3))
    for g in range(m):
        c = sums[g, 3]
        cen[g, 0] = sums[g, 0] / c
        cen[g, 1] = sums[g, 1] / c
        cen[g, 2] = sums[g, 2] / c
    if n_mixed:
        votes = np.zeros(max(num_labels, 1), np.int64)
        t = 0
        g = 0
        while t < nr:
            kk = packed[t] >> nb
            e = t + 1
            while e < nr and (packed[e] >> nb) == kk:
                e += 1
            if mixed[g]:
                best = -1
                bestc = 0
                for u in range(t, e):
                    r = packed[u] & mask
                    for i in range(starts[r], starts[r + 1]):
                        lab = labels[i]
                        v = votes[lab] + 1
                        votes[lab] = v
                        if v > bestc or (v == bestc and lab < best):
                            best = lab
                            bestc = v
                for u in range(t, e):
                    r = packed[u] & mask
                    for i in range(starts[r], starts[r + 1]):
                        votes[labels[i]] = 0
                maj[g] = best
            g += 1
            t = e
    return cen, maj


@njit(cache=True, nogil=True)
def _lengths(points, origin):  # pragma: no cover - compiled
    """|p - origin| per point, as ``np.linalg.norm(points - origin, axis=1)`` rounds it."""
    n = points.shape[0]
    out = np.empty(n)
    for i in range(n):
        dx = points[i, 0] - origin[0]
        dy = points[i, 1] - origin[1]
        dz = points[i, 2] - origin[2]
        out[i] = np.sqrt((dx * dx + dy * dy) + dz * dz)
    return out


@njit(cache=True, nogil=True)
def _free_samples(hits, origin, length, fr):  # pragma: no cover - compiled
    """The free samples of :func:`hw4.bki.training.free_samples`, ray by ray."""
    n = hits.shape[0]
    cnt = np.empty(n, np.int64)
    total = 0
    for i in range(n):
        L = length[i]
        k = np.int64(np.ceil(L / fr)) - 1
        if k < 0:
            k = 0
        if k > 0 and k * fr >= L:
            k -= 1
        if (k + 1) * fr < L:
            k += 1
        cnt[i] = k
        total += 1 + k + (1 if L > fr else 0)
    out = np.empty((total, 3))
    p = 0
    for i in range(n):
        L = length[i]
        k = cnt[i]
        out[p, 0] = origin[0]
        out[p, 1] = origin[1]
        out[p, 2] = origin[2]
        p += 1
        last = k + (1 if L > fr else 0)
        if last == 0:
            continue
        ux = (hits[i, 0] - origin[0]) / L
        uy = (hits[i, 1] - origin[1]) / L
        uz = (hits[i, 2] - origin[2]) / L
        for pos in range(1, last + 1):
            dist = pos * fr if pos <= k else L - fr
            out[p, 0] = origin[0] + ux * dist
            out[p, 1] = origin[1] + uy * dist
            out[p, 2] = origin[2] + uz * dist
            p += 1
    return out


@njit(cache=True, nogil=True)
def _free_leaves(hits, origin, length, fr, size):  # pragma: no cover - compiled
    """The leaves of :func:`_free_samples`' samples, as :func:`_leaf_keys` and :func:`_group_runs`
    make them from the samples (without holding the samples): each sample's leaf
    ``floor(x / size)`` found in a hash of the leaves seen so far, its coordinates added to the
    leaf's sums in sample order (from 0): per leaf (in order of its first sample) its packed key,
    sums and count, and ``far`` when a leaf index lies outside +-2^20 (the leaves then unset).
    :func:`free_leaves` orders them and divides."""
    n = hits.shape[0]
    kk = np.empty(n, np.int64)      # per ray: its regular samples (as _free_samples)
    total = 0
    for i in range(n):
        L = length[i]
        k = np.int64(np.ceil(L / fr)) - 1
        if k < 0:
            k = 0
        if k > 0 and k * fr >= L:
            k -= 1
        if (k + 1) * fr < L:
            k += 1
        kk[i] = k
        total += k + (1 if L > fr else 0)
    total += 1          # every ray's first sample is the origin: one leaf for all of them
    hbits = 4
    while (1 << hbits) < 2 * total:
        hbits += 1
    mask = (1 << hbits) - 1
    hkey = np.full(1 << hbits, -1, np.int64)
    hid = np.empty(1 << hbits, np.int64)
    lkey = np.empty(total, np.int64)    # per leaf (in order of first sample): key, sums, count
    sums = np.empty((total, 3))
    cnt = np.empty(total, np.int64)
    m = 0
    last_key = -1
    last_id = -1
    origin_key = -1
    key = -1
    for i in range(n):
        L = length[i]
        k = kk[i]
        last = k + (1 if L > fr else 0)
        ux = uy = uz = 0.0
        if last > 0:
            ux = (hits[i, 0] - origin[0]) / L
            uy = (hits[i, 1] - origin[1]) / L
            uz = (hits[i, 2] - origin[2]) / L
        for pos in range(last + 1):
            if pos == 0:    # each ray's first sample: the origin itself (its leaf known)
                x, y, z = origin[0], origin[1], origin[2]
                if origin_key >= 0:
                    key = origin_key
            else:
                dist = pos * fr if pos <= k else L - fr
                x = origin[0] + ux * dist
                y = origin[1] + uy * dist
                z = origin[2] + uz * dist
            if pos > 0 or origin_key < 0:
                cx = np.floor(x / size)
                cy = np.floor(y / size)
                cz = np.floor(z / size)
                if (cx < -_OFF or cx >= _OFF or cy < -_OFF or cy >= _OFF or cz < -_OFF
                        or cz >= _OFF):
                    return lkey[:0], sums[:0], cnt[:0], True
                key = (((np.int64(cx) + _OFF) << 42) | ((np.int64(cy) + _OFF) << 21)
                       | (np.int64(cz) + _OFF))
                if pos == 0:
                    origin_key = key
            if key != last_key:
                h = np.int64((np.uint64(key) * np.uint64(0x9E3779B97F4A7C15))
                             >> np.uint64(64 - hbits))
                while hkey[h] >= 0 and hkey[h] != key:
                    h = (h + 1) & mask
                if hkey[h] < 0:     # a new leaf
                    lkey[m] = key
                    sums[m, 0] = 0.0
                    sums[m, 1] = 0.0
                    sums[m, 2] = 0.0
                    cnt[m] = 0
                    hkey[h] = key
                    hid[h] = m
                    m += 1
                last_id = hid[h]
                last_key = key
            sums[last_id, 0] += x
            sums[last_id, 1] += y
            sums[last_id, 2] += z
            cnt[last_id] += 1
    return lkey[:m], sums[:m], cnt[:m], False


@njit(cache=True, nogil=True)
def _bases(points, res):  # pragma: no cover - compiled
    """``floor(points / res)`` as int64 and its per-axis minimum and maximum (``points``
    C-contiguous; the divisions in a loop without branches, vectorised)."""
    n = points.shape[0]
    flat = points.reshape(-1)
    base = np.empty((n, 3), np.int64)
    bflat = base.reshape(-1)
    for j in range(3 * n):
        bflat[j] = np.int64(np.floor(flat[j] / res))
    lo = np.full(3, np.iinfo(np.int64).max)
    hi = np.full(3, np.iinfo(np.int64).min)
    for i in range(n):
        for a in range(3):
            v = base[i, a]
            lo[a] = min(lo[a], v)
            hi[a] = max(hi[a], v)
    return base, lo, hi


@njit(cache=True, nogil=True)
def _codes(base, lo, dims, nb):  # pragma: no cover - compiled
    """Raveled index of each point's voxel in the scan's box (origin ``lo``, shape ``dims``),
    shifted left by ``nb`` bits with the point's index below (``nb`` = 0: the codes alone)."""
    n = base.shape[0]
    s1 = dims[1] * dims[2]
    codes = np.empty(n, np.int64)
    for i in range(n):
        c = (base[i, 0] - lo[0]) * s1 + (base[i, 1] - lo[1]) * dims[2] + (base[i, 2] - lo[2])
        codes[i] = (c << nb) | (i if nb else 0)
    return codes


_BATCH = 4096
"""Pairs per batch of :func:`_scan_evidence` (points of one x slab whose candidates fit): their
kernel weights in the loops of :func:`_kernels`, then their sums."""


@njit(cache=True, nogil=True)
def _kernels(d2, out, uu, jj, m, scale, sf2, table):  # pragma: no cover - compiled
    """The sparse kernel at the squared distances ``d2[:m] < ell^2`` [m^2] into ``out[:m]``, as
    :func:`sparse_kernel_pieces` rounds it: ``r = d P / ell`` (``scale = P / ell``), its piece
    ``j`` and ``u = r - j - 1/2``, the piece's polynomial by Horner from the top (the degree a
    constant: unrolled), times sf2, clamped at 0. Two loops without branches: ``u`` and ``j``
    (into the scratch ``uu``, ``jj``; vectorised, square roots included), then the polynomials
    (the coefficients of ``table`` read per pair)."""
    for q in range(m):
        r = np.sqrt(d2[q]) * scale
        j = min(np.int32(r), np.int32(_PIECES - 1))     # int32: AVX2 converts it vectorised
        u = r - j
        uu[q] = u - 0.5
        jj[q] = j * np.int32(_DEGREE + 1)
    tab = table.reshape(-1)
    for q in range(m):
        u = uu[q]
        b = jj[q]
        k = tab[b + _DEGREE] * u
        for h in range(_DEGREE - 1, 0, -1):
            k += tab[b + h]
            k *= u
        k += tab[b]
        k *= sf2
        out[q] = 0.0 if k < 0.0 else k


@njit(cache=True, nogil=True, inline="always")
def _axis2(p, b, res, ell2):  # pragma: no cover - compiled
    """One axis of a point (coordinate ``p`` [m], voxel ``b``) with R = 1: the squared distances
    to the centres of offsets -1, 0, 1 (as :func:`_scan_evidence` computes them), how many lie
    below ``ell2`` and the first that does (3: none)."""
    d0 = p - (b + (-1 + 0.5)) * res
    d1 = p - (b + (0 + 0.5)) * res
    d2 = p - (b + (1 + 0.5)) * res
    q0 = d0 * d0
    q1 = d1 * d1
    q2 = d2 * d2
    n = np.int64(q0 < ell2) + np.int64(q1 < ell2) + np.int64(q2 < ell2)
    f = 0 if q0 < ell2 else (1 if q1 < ell2 else (2 if q2 < ell2 else 3))
    return q0, q1, q2, n, f


@njit(cache=True, nogil=True)
def _scan_evidence(points, labels, base, order, omask, t0, t1, x0, x1, lo, dims, R, res, ell2,
                   scale, sf2, table, counting, dense_k, span, vloc, vcnt, c0, w0, more, acc,
                   ecls, evalue, enext):  # pragma: no cover - compiled
    """Per-scan evidence in a sparse form. The points ``order[t0:t1] & omask`` (raveled voxel
    order, stable: the sorted ``code << nb | index`` masked, or a stable argsort with ``omask``
    all ones) are taken one by one, and each point's pairs in lexicographic offset order: per
    (voxel, class) the weights are summed from 0 in the points' order, as
    :func:`hw4.bki.kernel_sums.kernel_sums` sums them. ``counting`` (S-CSM): every point adds 1
    to its own voxel (``R`` = 0). Only voxels with x index in ``[x0, x1)`` are summed (a
    thread's share).

    Per point and axis, the offsets whose squared distance is below ``ell2`` are consecutive
    (the distance is unimodal in the offset); at most ``span`` of them for any point in exact
    arithmetic (``ceil(2 ell / r)``, capped at ``2 R + 1``). The point's candidates are the
    ``span^3`` offsets of the window that starts at the first such offset per axis (a point with
    more per axis, by rounding, takes all ``(2 R + 1)^3``; with R = 1 and span 2, the
    SemanticKITTI settings, the window and its 8 pairs come from :func:`_axis2` per axis,
    unrolled); those within ell are listed without branches. The points go in batches
    (consecutive points of one x slab whose pairs fit in ``_BATCH``): the batch's pairs are
    listed, their kernel weights computed in the loops of :func:`_kernels`, then summed pair by
    pair in the same order. A target's local voxel is looked up in a ring of x slabs of the box
    (``2^ceil(log2(2 R + 1))`` slabs of ``dims[1] * dims[2]`` int32, at most
    the box): the points come in increasing x, so a target's slab lies within ``R`` of the
    current one, and a slot is cleared (only the entries set, from a list per slot) when a slab
    further on takes it. The ring stays in cache where a box-sized table would not.

    ``vloc`` .. ``enext`` are scratch arrays kept by the caller (``vloc`` at least 64 per block
    the scan can touch, ``vcnt`` .. ``more`` at least one per voxel it can touch, ``acc``
    ``dense_k`` per voxel, the list ``ecls``, ``evalue``, ``enext`` one per pair it can make:
    nothing grows in the loop).
    Returns ``blk`` (per block of the scan's box of 4^3-voxel blocks: its local block, -1 if not
    touched), ``vloc`` (per local block and voxel in it: the local voxel, -1 if not touched) and
    per local voxel its pair count ``vcnt``, first class ``c0`` and its summed weight ``w0`` and
    the head ``more`` of a list of further (class ``ecls``, sum ``evalue``, next ``enext``), as
    views of the scratch.
    With ``dense_k`` > 0 (few classes), the sums are kept per local voxel and class in ``acc``
    (``dense_k`` per voxel, from 0) instead, and ``c0``, ``w0``, ``more`` and the list are empty."""
    blo0, blo1, blo2 = lo[0] >> 2, lo[1] >> 2, lo[2] >> 2
    bd0 = ((lo[0] + dims[0] - 1) >> 2) - blo0 + 1
    bd1 = ((lo[1] + dims[1] - 1) >> 2) - blo1 + 1
    bd2 = ((lo[2] + dims[2] - 1) >> 2) - blo2 + 1
    blk = np.full(bd0 * bd1 * bd2, -1, np.int32)
    w = 2 * R + 1
    s1 = dims[1] * dims[2]
    d2z = dims[2]
    nb = 0
    nv = 0
    ne = 0
    nslot = 1
    while nslot < w:
        nslot *= 2
    smask = nslot - 1
    if nslot > dims[0]:
        nslot = dims[0]               # slab x - lo[0] < dims[0] <= nslot: its own slot
    ring = np.full(nslot * s1, -1, np.int32)     # slot * s1 + (y, z) code: local voxel, -1
    held = np.full(nslot, -1, np.int64)          # the slab x each slot holds
    nset = np.zeros(nslot, np.int64)             # entries set in each slot, listed in setlist
    setlist = np.empty(nslot * s1, np.int32)
    sq = np.empty((3, w))             # per axis and offset: the point's squared distance
    L = min(max(span, 1), w)
    w3 = w * w * w
    cap = max(_BATCH, w3)             # pairs of a batch of points (a point's w3 candidates fit)
    cand_d2 = np.empty(cap + w3)      # the batch's pairs within ell: squared distance, ring
    cand_r = np.empty(cap + w3, np.int64)   # index, offset (a << 42 | b << 21 | c)
    cand_o = np.empty(cap + w3, np.int64)
    cand_k = np.empty(cap + w3)       # their kernel weights
    cand_u = np.empty(cap + w3)
    cand_j = np.empty(cap + w3, np.int32)
    sq2 = np.empty(9)
    bpt = np.empty(cap + 1, np.int64)   # the batch's points (with pairs) and their first pair
    bfirst = np.empty(cap + 2, np.int64)
    prev_x = np.int64(-(1 << 62))
    t = t0
    while t < t1:
        bx = base[order[t] & omask, 0]
        if bx != prev_x:              # the slabs within R of this x: their slots
            prev_x = bx
            for a in range(w):
                vx = bx + a - R
                if vx < x0 or vx >= x1:
                    continue
                slot = (vx - lo[0]) & smask
                if held[slot] != vx:  # a new slab takes the slot: clear the entries set
                    roff = slot * s1
                    for h in range(nset[slot]):
                        ring[roff + setlist[roff + h]] = -1
                    nset[slot] = 0
                    held[slot] = vx
        # a batch: the next points of this slab x while their candidates fit
        m = 0
        nbp = 0
        while t < t1 and m <= cap - w3:
            i = order[t] & omask
            if base[i, 0] != bx:
                break
            t += 1
            by, bz = base[i, 1], base[i, 2]
            m_start = m
            use_general = False
            if counting:
                if bx >= x0 and bx < x1:
                    cand_d2[m] = 0.0
                    cand_r[m] = ((bx - lo[0]) & smask) * s1 + (by - lo[1]) * d2z + (bz - lo[2])
                    cand_o[m] = (R << 42) | (R << 21) | R
                    m += 1
            elif w == 3 and L == 2:
                # the window of 2 offsets per axis (as the general path finds it), unrolled
                q0, q1, q2, nx, fx = _axis2(points[i, 0], bx, res, ell2)
                r0, r1, r2, ny, fy = _axis2(points[i, 1], by, res, ell2)
                u0, u1, u2, nz, fz = _axis2(points[i, 2], bz, res, ell2)
                if nx == 0 or ny == 0 or nz == 0:
                    continue
                if nx > 2 or ny > 2 or nz > 2:     # 3 offsets on an axis (rounding)
                    use_general = True
                else:
                    use_general = False
                    f0 = min(fx, 1)
                    f1 = min(fy, 1)
                    f2 = min(fz, 1)
                    sxa = q0 if f0 == 0 else q1
                    sxb = q1 if f0 == 0 else q2
                    sya = r0 if f1 == 0 else r1
                    syb = r1 if f1 == 0 else r2
                    sza = u0 if f2 == 0 else u1
                    szb = u1 if f2 == 0 else u2
                    rz = bz + f2 - 1 - lo[2]
                    for a in range(2):
                        vx = bx + f0 + a - 1
                        inx = (vx >= x0) & (vx < x1)
                        rx = ((vx - lo[0]) & smask) * s1
                        sx = sxa if a == 0 else sxb
                        for b in range(2):
                            vy = by + f1 + b - 1
                            sxy = sx + (sya if b == 0 else syb)
                            rxy = rx + (vy - lo[1]) * d2z + rz
                            oab = ((f0 + a) << 42) | ((f1 + b) << 21) | f2
                            d2 = sxy + sza
                            cand_d2[m] = d2
                            cand_r[m] = rxy
                            cand_o[m] = oab
                            m += (d2 < ell2) & inx
                            d2 = sxy + szb
                            cand_d2[m] = d2
                            cand_r[m] = rxy + 1
                            cand_o[m] = oab + 1
                            m += (d2 < ell2) & inx
            else:
                use_general = True
            if use_general and not counting:
                px, py, pz = points[i, 0], points[i, 1], points[i, 2]
                f0 = w
                f1 = w
                f2 = w
                n0 = 0
                n1 = 0
                n2 = 0
                for a in range(w):
                    dx = px - (bx + ((a - R) + 0.5)) * res
                    dy = py - (by + ((a - R) + 0.5)) * res
                    dz = pz - (bz + ((a - R) + 0.5)) * res
                    sq[0, a] = dx * dx
                    sq[1, a] = dy * dy
                    sq[2, a] = dz * dz
                    ok0 = dx * dx < ell2
                    ok1 = dy * dy < ell2
                    ok2 = dz * dz < ell2
                    n0 += ok0
                    n1 += ok1
                    n2 += ok2
                    f0 = min(f0, a if ok0 else w)
                    f1 = min(f1, a if ok1 else w)
                    f2 = min(f2, a if ok2 else w)
                if n0 == 0 or n1 == 0 or n2 == 0:
                    continue
                l0 = L
                l1 = L
                l2 = L
                if n0 > L or n1 > L or n2 > L:   # more than span offsets (rounding): all of them
                    f0 = f1 = f2 = 0
                    l0 = l1 = l2 = w
                f0 = min(f0, w - l0)
                f1 = min(f1, w - l1)
                f2 = min(f2, w - l2)
                zmin = -np.inf            # wide windows: rows beyond ell (from the nearest z) skipped
                if l2 > 2:
                    zmin = np.inf
                    for cz in range(f2, f2 + l2):
                        zmin = min(zmin, sq[2, cz])
                if l0 == 2 and l1 == 2 and l2 == 2:   # the common window (ell <= r): constant loops
                    for a in range(f0, f0 + 2):
                        vx = bx + a - R
                        inx = vx >= x0 and vx < x1
                        rx = ((vx - lo[0]) & smask) * s1
                        for b in range(f1, f1 + 2):
                            vy = by + b - R
                            sxy = sq[0, a] + sq[1, b]
                            rxy = rx + (vy - lo[1]) * d2z - lo[2]
                            for cz in range(f2, f2 + 2):
                                vz = bz + cz - R
                                d2 = sxy + sq[2, cz]
                                cand_d2[m] = d2
                                cand_r[m] = rxy + vz
                                cand_o[m] = (a << 42) | (b << 21) | cz
                                m += (d2 < ell2) & inx
                else:
                    for a in range(f0, f0 + l0):
                        vx = bx + a - R
                        inx = vx >= x0 and vx < x1
                        rx = ((vx - lo[0]) & smask) * s1
                        for b in range(f1, f1 + l1):
                            vy = by + b - R
                            sxy = sq[0, a] + sq[1, b]
                            if sxy + zmin >= ell2:
                                continue
                            rxy = rx + (vy - lo[1]) * d2z - lo[2]
                            for cz in range(f2, f2 + l2):
                                vz = bz + cz - R
                                d2 = sxy + sq[2, cz]
                                cand_d2[m] = d2
                                cand_r[m] = rxy + vz
                                cand_o[m] = (a << 42) | (b << 21) | cz
                                m += (d2 < ell2) & inx
            if m > m_start:
                bpt[nbp] = i
                bfirst[nbp] = m_start
                nbp += 1
        bfirst[nbp] = m
        if counting:
            for j in range(m):
                cand_k[j] = 1.0
        else:
            _kernels(cand_d2, cand_k, cand_u, cand_j, m, scale, sf2, table)
        for p in range(nbp):
            i = bpt[p]
            by, bz = base[i, 1], base[i, 2]
            c = labels[i]
            for j in range(bfirst[p], bfirst[p + 1]):
                k = cand_k[j]
                ridx = cand_r[j]
                v = ring[ridx]
                if v < 0:    # the voxel's first pair of this scan (its block's, maybe)
                    o = cand_o[j]
                    vx = bx + (o >> 42) - R
                    vy = by + ((o >> 21) & 2097151) - R
                    vz = bz + (o & 2097151) - R
                    bc = (((vx >> 2) - blo0) * bd1 + ((vy >> 2) - blo1)) * bd2 + ((vz >> 2) - blo2)
                    lb = blk[bc]
                    if lb < 0:
                        lb = nb
                        blk[bc] = lb
                        for h in range(lb * 64, lb * 64 + 64):
                            vloc[h] = -1
                        nb += 1
                    v = nv
                    vloc[lb * 64 + (((vx & 3) << 4) | ((vy & 3) << 2) | (vz & 3))] = v
                    vcnt[v] = 0
                    c0[v] = c
                    w0[v] = 0.0
                    more[v] = -1
                    for cq in range(dense_k):
                        acc[v * dense_k + cq] = 0.0
                    ring[ridx] = v
                    slot = (vx - lo[0]) & smask
                    setlist[slot * s1 + nset[slot]] = ridx - slot * s1
                    nset[slot] += 1
                    nv += 1
                vcnt[v] += 1
                if dense_k:
                    acc[v * dense_k + c] += k
                    continue
                if c0[v] == c:
                    w0[v] += k
                    continue
                e = more[v]
                while e >= 0 and ecls[e] != c:
                    e = enext[e]
                if e < 0:
                    e = ne
                    ecls[e] = c
                    evalue[e] = 0.0
                    enext[e] = more[v]
                    more[v] = e
                    ne += 1
                evalue[e] += k
    nc = 0 if dense_k else nv
    return (blk, vloc[:nb * 64], vcnt[:nv], c0[:nc], w0[:nc], more[:nc], ecls[:ne], evalue[:ne],
            enext[:ne], acc[:nv * dense_k])


@njit(cache=True, nogil=True)
def _count_evidence(labels, base, x0, x1, lo, dims, dense_k, vloc, vcnt, c0, w0, more, acc, ecls,
                    evalue, enext):  # pragma: no cover - compiled
    """S-CSM's per-scan evidence in the sparse form of :func:`_scan_evidence` (same scratch, same
    returns): every point adds 1 to its own voxel's count and its class's sum, in input order (the
    sums are whole numbers, exact in any order: no voxel order needed). A voxel's local index is
    found through its block (the scan's box of blocks, then the 64 voxels of the block). Only
    voxels with x index in ``[x0, x1)`` (a thread's share)."""
    blo0, blo1, blo2 = lo[0] >> 2, lo[1] >> 2, lo[2] >> 2
    bd0 = ((lo[0] + dims[0] - 1) >> 2) - blo0 + 1
    bd1 = ((lo[1] + dims[1] - 1) >> 2) - blo1 + 1
    bd2 = ((lo[2] + dims[2] - 1) >> 2) - blo2 + 1
    blk = np.full(bd0 * bd1 * bd2, -1, np.int32)
    nb = 0
    nv = 0
    ne = 0
    for i in range(base.shape[0]):
        vx, vy, vz = base[i, 0], base[i, 1], base[i, 2]
        if vx < x0 or vx >= x1:
            continue
        c = labels[i]
        bc = (((vx >> 2) - blo0) * bd1 + ((vy >> 2) - blo1)) * bd2 + ((vz >> 2) - blo2)
        lb = blk[bc]
        if lb < 0:
            lb = nb
            blk[bc] = lb
            for h in range(lb * 64, lb * 64 + 64):
                vloc[h] = -1
            nb += 1
        q = lb * 64 + (((vx & 3) << 4) | ((vy & 3) << 2) | (vz & 3))
        v = vloc[q]
        if v < 0:
            v = nv
            vloc[q] = v
            vcnt[v] = 0
            c0[v] = c
            w0[v] = 0.0
            more[v] = -1
            for cq in range(dense_k):
                acc[v * dense_k + cq] = 0.0
            nv += 1
        vcnt[v] += 1
        if dense_k:
            acc[v * dense_k + c] += 1.0
            continue
        if c0[v] == c:
            w0[v] += 1.0
            continue
        e = more[v]
        while e >= 0 and ecls[e] != c:
            e = enext[e]
        if e < 0:
            e = ne
            ecls[e] = c
            evalue[e] = 0.0
            enext[e] = more[v]
            more[v] = e
            ne += 1
        evalue[e] += 1.0
    nc = 0 if dense_k else nv
    return (blk, vloc[:nb * 64], vcnt[:nv], c0[:nc], w0[:nc], more[:nc], ecls[:ne], evalue[:ne],
            enext[:ne], acc[:nv * dense_k])


@njit(cache=True, nogil=True)
def _block_rows(blk, lo, dims, keys, slots, n_blocks):  # pragma: no cover - compiled
    """Map rows of the scan's touched blocks (``blk >= 0`` over its box of 4^3-voxel blocks, in
    raveled order = key order), new blocks taking rows ``n_blocks``, ``n_blocks + 1``, ... in key
    order: ``(rows, lbs, keys, slots, n_new)`` with ``lbs`` the touched blocks' local indices and
    ``keys`` / ``slots`` the map's sorted block keys and their rows with the new ones merged in
    (the arrays given when there are none). Keys as :func:`hw4.bki.voxelmap._pack`."""
    blo0, blo1, blo2 = lo[0] >> 2, lo[1] >> 2, lo[2] >> 2
    bd1 = ((lo[1] + dims[1] - 1) >> 2) - blo1 + 1
    bd2 = ((lo[2] + dims[2] - 1) >> 2) - blo2 + 1
    n_t = 0
    for bc in range(blk.shape[0]):
        n_t += blk[bc] >= 0
    tkeys = np.empty(n_t, np.int64)
    rows = np.empty(n_t, np.int64)
    lbs = np.empty(n_t, np.int32)
    j = 0
    for bc in range(blk.shape[0]):
        if blk[bc] >= 0:
            x = bc // (bd1 * bd2)
            y = (bc // bd2) % bd1
            z = bc % bd2
            tkeys[j] = (((blo0 + x + _OFF) << 42) | ((blo1 + y + _OFF) << 21)
                        | (blo2 + z + _OFF))
            lbs[j] = blk[bc]
            j += 1
    n_new = 0
    p = 0
    nk = keys.shape[0]
    for j in range(n_t):
        tk = tkeys[j]
        while p < nk and keys[p] < tk:
            p += 1
        if p < nk and keys[p] == tk:
            rows[j] = slots[p]
        else:
            rows[j] = n_blocks + n_new
            n_new += 1
    if n_new == 0:
        return rows, lbs, keys, slots, 0
    mk = np.empty(nk + n_new, np.int64)
    ms = np.empty(nk + n_new, np.int64)
    p = 0
    q = 0
    for j in range(n_t):      # merge: the map's keys below each touched key, then it if new
        tk = tkeys[j]
        while p < nk and keys[p] < tk:
            mk[q] = keys[p]
            ms[q] = slots[p]
            p += 1
            q += 1
        if p < nk and keys[p] == tk:
            continue
        mk[q] = tk
        ms[q] = rows[j]
        q += 1
    while p < nk:
        mk[q] = keys[p]
        ms[q] = slots[p]
        p += 1
        q += 1
    return rows, lbs, mk, ms, n_new


@njit(cache=True, nogil=True)
def _assign(table, rows, lbs, vloc, n_local, n_voxels):  # pragma: no cover - compiled
    """Pool slot of every touched voxel (local blocks ``lbs`` at map rows ``rows``, ``n_local``
    local voxels): the voxels without one take the next slots in (block key, voxel) order, set
    in ``table``. Branch-free over the 64 voxels of each block. Returns the slots per local
    voxel and the new number of voxels."""
    slot_of = np.empty(n_local + 1, np.int64)   # the last entry: where untouched voxels write
    for b in range(lbs.shape[0]):
        row = rows[b]
        base = lbs[b] * 64
        for q in range(64):
            v = vloc[base + q]
            s = np.int64(table[row, q])
            new = (v >= 0) and (s < 0)
            s = n_voxels if new else s
            n_voxels += new
            table[row, q] = s
            slot_of[v if v >= 0 else n_local] = s
    return slot_of[:n_local], n_voxels


@njit(cache=True, nogil=True)
def _accumulate(slot_of, vcnt, c0, w0, more, ecls, evalue, enext, acc, ev, count):  # pragma: no cover - compiled
    """Add the scan's evidence of each local voxel to its pool slot ``slot_of`` (voxel after
    voxel; the voxels are distinct, so the order does not change a value): its pair count, and
    per class the scan's sum (``ev[s, c] += sum``, as the numpy engine adds them)."""
    K = ev.shape[1]
    dense = acc.shape[0] > 0
    for v in range(slot_of.shape[0]):
        s = slot_of[v]
        count[s] += vcnt[v]
        if dense:   # dense sums: every class (adding a 0 leaves a value as it is)
            for q in range(K):
                ev[s, q] += acc[v * K + q]
            continue
        ev[s, c0[v]] += w0[v]
        e = more[v]
        while e >= 0:
            ev[s, ecls[e]] += evalue[e]
            e = enext[e]


# ----------------------------------------------------------------------------- Python side


def downsample(points: np.ndarray, labels, size: float, num_labels: int = 0):
    """Compiled :func:`hw4.bki.training.downsample` for ``size > 0``: ``(centroids, majority or
    None, far)``; ``far`` when a leaf index lies beyond +-2^20 (the caller raises its error)."""
    _announce()
    points = np.ascontiguousarray(points, dtype=np.float64)
    if labels is None:
        lab, k = np.zeros(0, np.int64), 1
    else:
        lab = np.ascontiguousarray(labels, dtype=np.int64)
        k = int(num_labels) if num_labels else (int(lab.max()) + 1 if len(lab) else 1)
    nb = max(1, int(len(points) - 1).bit_length())
    keys, starts, top, far, packed = _leaf_keys(points, float(size), nb)   # per run: key << nb | run
    if far:
        return np.zeros((0, 3)), None, True
    if not packed:                            # too wide to pack: rank the keys, a run per point
        keys = np.unique(keys, return_inverse=True)[1].astype(np.int64)
        keys <<= nb
        keys |= np.arange(len(keys))
        starts = np.arange(len(keys) + 1, dtype=np.int64)
    keys.sort()                               # sorted: each leaf's runs in input order
    cen, maj = _group_runs(points, lab, keys, starts, nb, k)
    return cen, (None if labels is None else maj), False


def lengths(points: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(points - origin, axis=1)`` [m], the same values."""
    return _lengths(np.ascontiguousarray(points, dtype=np.float64),
                    np.ascontiguousarray(origin, dtype=np.float64))


def free_samples(hits: np.ndarray, origin: np.ndarray, length: np.ndarray, fr: float) -> np.ndarray:
    """Compiled :func:`hw4.bki.training.free_samples` (its checks done by the caller)."""
    return _free_samples(np.ascontiguousarray(hits, dtype=np.float64),
                         np.ascontiguousarray(origin, dtype=np.float64), length, float(fr))


def free_leaves(hits: np.ndarray, origin: np.ndarray, length: np.ndarray, fr: float,
                size: float):
    """``downsample(free_samples(hits, origin, length, fr), None, size)`` without the samples
    held: ``(centroids, far)``, the same centroids bit for bit (see :func:`_free_leaves`)."""
    lkey, sums, cnt, far = _free_leaves(np.ascontiguousarray(hits, dtype=np.float64),
                                        np.ascontiguousarray(origin, dtype=np.float64), length,
                                        float(fr), float(size))
    if far:
        return np.zeros((0, 3)), True
    order = np.argsort(lkey)        # distinct keys: increasing lexicographic leaf order
    return sums[order] / cnt[order, None], False   # each sum / its count, as bincount's mean


def bases(points: np.ndarray, resolution: float):
    """``(floor(points / resolution), its minimum, its maximum)`` per axis, int64."""
    _announce()
    return _bases(np.ascontiguousarray(points, dtype=np.float64), float(resolution))


_announced = False


def _announce() -> None:
    """Before the first compiled call of a process: when numba's cache does not hold every kernel
    for this source (the first run after an install or a change), say so once on stderr, when it
    is a terminal (notebooks and piped runs keep their outputs)."""
    global _announced
    if _announced:
        return
    _announced = True
    if not getattr(sys.stderr, "isatty", lambda: False)():
        return
    for k in KERNELS:
        try:
            index = k._cache._cache_file._index_path
            if not (os.path.exists(index) and os.path.getmtime(index) >= os.path.getmtime(__file__)):
                break
        except (AttributeError, OSError):
            break
    else:
        return
    print("hw4: compiling the 3D mapping kernels (once after an install; 20-60 s) ...",
          file=sys.stderr, flush=True)


def voxel_order(base, lo, dims):
    """The points in raveled voxel order of the box (origin ``lo``, shape ``dims``), stable:
    ``(okeys, omask, nb)`` with the point indices ``okeys & omask`` in that order; ``okeys`` the
    sorted ``code << nb | index`` when both fit in 63 bits (one ``np.sort``), else a stable
    argsort (``omask`` all ones, ``nb`` = 0)."""
    n = len(base)
    nb = max(1, int(n - 1).bit_length())
    if int(np.prod(dims) - 1).bit_length() + nb <= 63:
        okeys = _codes(base, lo, dims, nb)
        okeys.sort()
        return okeys, (1 << nb) - 1, nb
    return np.argsort(_codes(base, lo, dims, 0), kind="stable"), -1, 0


def stable_order(keys: np.ndarray, top: int):
    """Stable ascending order of int64 ``keys`` in ``[0, top]`` and the keys in that order: one
    ``np.sort`` of the keys with the index packed below them when both fit in 63 bits, else a
    stable argsort."""
    nb = max(1, int(len(keys) - 1).bit_length())
    if int(top).bit_length() + nb <= 63:
        packed = np.sort((keys << nb) | np.arange(len(keys)))
        return packed & ((1 << nb) - 1), packed >> nb
    order = np.argsort(keys, kind="stable")
    return order, keys[order]


def window_span(R: int, resolution: float, ell: float) -> int:
    """Most consecutive voxel offsets per axis whose centres a point can have within ``ell``
    (exact arithmetic): the integers in an open interval of length ``2 ell / r``, i.e.
    ``ceil(2 ell / r)``, at most ``2 R + 1`` (``R`` = 0: 1). :func:`_scan_evidence` checks it per
    point and takes every offset where rounding lets more in."""
    if R == 0:
        return 1
    return int(min(2 * R + 1, max(1, np.ceil(2.0 * float(ell) / float(resolution)))))


def threads() -> int:
    """Threads of the compiled update: ``HW4_THREADS`` (default 1). The map is the same bit for bit
    on any number: each thread sums the voxels of its own range of x (whole blocks), over the same
    points in the same order."""
    try:
        return max(1, int(os.environ.get("HW4_THREADS", "1")))
    except ValueError:
        return 1


_pool = None


DENSE_CLASSES = 8
"""Up to this many classes the compiled update sums a scan's evidence per voxel and class in a
dense array (no per-pair search of the class); beyond, the first class of each voxel inline and
a list for the others (a voxel rarely sees more than one or two of 20 classes)."""


def _scratch(store: list, j: int, n_vox: int, n_blk: int, n_pairs: int, dense_k: int):
    """Scratch arrays of job ``j`` for :func:`_scan_evidence` with room for ``n_vox`` voxels,
    ``n_blk`` blocks and ``n_pairs`` list entries, kept in ``store`` from scan to scan (grown by a
    quarter at least when short; pages never written cost no memory)."""
    while len(store) <= j:
        store.append(None)
    have = store[j]
    if (have is None or len(have[1]) < n_vox or len(have[0]) < 64 * n_blk
            or len(have[5]) < n_vox * dense_k or len(have[6]) < n_pairs):
        old = (0, 0, 0) if have is None else (len(have[1]), len(have[0]) // 64, len(have[6]))
        nv = max(n_vox, old[0] + old[0] // 4)
        nb = max(n_blk, old[1] + old[1] // 4)
        ne = max(n_pairs, old[2] + old[2] // 4)
        have = (np.empty(64 * nb, np.int32), np.empty(nv, np.int64), np.empty(nv, np.int32),
                np.empty(nv), np.empty(nv, np.int32),
                np.empty(nv * dense_k), np.empty(ne, np.int32), np.empty(ne), np.empty(ne, np.int32))
        store[j] = have
    return have


def scan_evidence(points, labels, base, lo, dims, R: int, resolution: float, ell: float,
                  sf2: float, counting: bool, n_threads: int | None = None, num_class: int = 0,
                  scratch: list | None = None):
    """The sparse evidence of one scan's training points (see :func:`_scan_evidence`), as a list
    of parts, one per thread, whose blocks follow each other in key order (x slabs of blocks).
    ``scratch``: a list the caller keeps from scan to scan (the parts are views of it, valid until
    the next call with it); by default new arrays."""
    lo = np.ascontiguousarray(lo, dtype=np.int64)
    dims = np.ascontiguousarray(dims, dtype=np.int64)
    n_box = int(np.prod(dims))
    n_threads = threads() if n_threads is None else max(1, int(n_threads))
    dense_k = int(num_class) if 0 < num_class <= DENSE_CLASSES else 0
    n_blk = int(np.prod(((lo + dims - 1) >> 2) - (lo >> 2) + 1))
    store = [] if scratch is None else scratch
    if counting:      # S-CSM: whole-number sums, the points in input order
        edges = [int(lo[0]), int(lo[0] + dims[0])]
        if n_threads > 1:   # x ranges of whole blocks, cut at the points' quantiles
            cuts = np.unique(np.quantile(base[:, 0], np.arange(1, n_threads) / n_threads)
                             .astype(np.int64) >> 2) << 2
            edges = edges[:1] + [int(c) for c in cuts if lo[0] < c < lo[0] + dims[0]] + edges[1:]
        n_vox = max(1, min(len(base), n_box))
        jobs = [(labels, base, x0, x1, lo, dims, dense_k)
                + _scratch(store, j, n_vox, min(n_vox, n_blk), 0 if dense_k else n_vox, dense_k)
                for j, (x0, x1) in enumerate(zip(edges[:-1], edges[1:]))]
        return _run(_count_evidence, jobs)
    order, omask, nb = voxel_order(base, lo, dims)
    edges = [int(lo[0]), int(lo[0] + dims[0])]
    if n_threads > 1:   # x ranges of whole blocks, cut at the points' quantiles
        scodes = order >> nb if nb else _codes(base, lo, dims, 0)[order]
        bx = lo[0] + scodes // (dims[1] * dims[2])          # voxel x of the sorted points
        cuts = np.unique(np.quantile(bx, np.arange(1, n_threads) / n_threads).astype(np.int64) >> 2) << 2
        edges = edges[:1] + [int(c) for c in cuts if lo[0] < c < lo[0] + dims[0]] + edges[1:]
    const = (lo, dims, int(R), float(resolution), float(ell) ** 2, _PIECES / float(ell),
             float(sf2), _pieces(), bool(counting), dense_k, window_span(R, resolution, ell))
    w3 = (2 * int(R) + 1) ** 3
    jobs = []
    for j, (x0, x1) in enumerate(zip(edges[:-1], edges[1:])):
        t0, t1 = 0, len(order)
        if len(edges) > 2:      # the points within R voxels of the range
            t0 = int(np.searchsorted(bx, x0 - R, "left"))
            t1 = int(np.searchsorted(bx, x1 + R - 1, "right"))
        n_pairs = max(1, (t1 - t0) * w3)                # pairs the job can make, at most
        n_vox = min(n_pairs, n_box)                       # voxels it can touch
        jobs.append((points, labels, base, order, omask, t0, t1, x0, x1) + const
                    + _scratch(store, j, n_vox, min(n_vox, n_blk), 0 if dense_k else n_pairs,
                               dense_k))
    return _run(_scan_evidence, jobs)


def _run(kernel, jobs):
    """``kernel(*job)`` for every job: in this thread when there is one, else on the pool."""
    global _pool
    if len(jobs) == 1:
        return [kernel(*jobs[0])]
    if _pool is None or _pool._max_workers < len(jobs):
        from concurrent.futures import ThreadPoolExecutor
        _pool = ThreadPoolExecutor(len(jobs))
    return list(_pool.map(lambda a: kernel(*a), jobs))


KERNELS = (_kernels, _leaf_keys, _group_runs, _lengths, _free_samples, _free_leaves, _bases, _codes, _scan_evidence,
           _count_evidence, _block_rows, _assign, _accumulate)

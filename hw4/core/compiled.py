"""The counting core compiled: the loops of :mod:`hw4.core.evidence` as numba kernels.

:func:`hw4.core.evidence.count_evidence` keeps its readable numpy formulation (``engine='numpy'``)
as the reference; this module is the default engine (``engine='compiled'``). Every kernel repeats
the numpy formulation's floating-point steps in the same order, per pair, so that each cell gets
the same pairs, the same nearest beam and the same sums:

* :func:`nearest_poses` is the exact k-nearest-pose query (squared distances ``dx dx + dy dy``
  as scipy's KD-tree computes them, sorted by distance) over tiles of cells sharing one sorted
  candidate list (the tile's bound from a selection, ``np.partition``, over one vectorised
  loop of distances; candidates kept by a compaction without branches), each cell's k + 1
  nearest placed by their ranks among its candidates (:func:`_rank_select`, a vectorised
  count); cells whose ranking has a tie (two poses at the same distance) are flagged and
  answered by scipy's KD-tree itself, so the poses and their order are always the KD-tree's.
* :func:`bin_table` builds the per-pose bin table of :class:`hw4.core.sensor.BeamTable` in one
  pass over the bearings, each bearing's bin computed once (the same arrays as its numpy form).
* :func:`cell_evidence` evaluates, per (cell, pose) pair: range, wrapped bearing (``np.remainder``
  as numpy computes it), the perceptual field, the nearest beam from the same sorted bearing
  index (:class:`hw4.core.sensor.BeamTable`; the beams' ranges, classes and directions are read
  in that index's order, at the beam's sorted position), then Algorithm 1 or 2. With the
  nearest poses it visits the pairs pose by pose (:func:`_pose_pass`: one pose's bearing index
  stays in the cache, and its cells' ranges and fast bearings come from one vectorised loop,
  :func:`_bearings_simd`); the discrete counts are whole numbers, so their order does not
  matter, and the continuous sums are then formed cell by cell (:func:`_kernel_pass`). The
  nearest of a bearing's two neighbours is chosen without branches (:func:`_nearest_at`: the
  wrap's shifts as multiples of 2 pi, the choice as index arithmetic); cells behind the laser,
  beyond every beam's width (discrete) or farther than l from every beam's line (continuous,
  bounded without the sine), skip the lookup, and the continuous gap test skips the sine
  where bounds decide (:func:`_beam_gap`); every shortcut keeps a margin of at least 2 EPS or
  1e-9 m, so its outcome is the exact one.
  Sums per cell are formed in the numpy path's order (end points per class over the cell's
  poses, then the free samples offset by offset), so the map does not depend on how cells are
  split among threads.
* :func:`all_beams_evidence` is ``beams='all'``: pose by pose, every end point and free sample
  against the cells within ``l``, each pose's sums added to the map in pose order as
  ``np.bincount`` does.

Differences to numpy can only come from the transcendental functions (numpy may use its own SIMD
``sin``, ``cos`` and ``arctan2``, numba calls the C library's): those agree to an ulp or so, and
the tests compare the two engines to 1e-12 relative (bit for bit where the machine's functions
agree). Compiled once per install (numba's cache, beside the package); :func:`warm` says so.
"""
from __future__ import annotations

import math
import os
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numba import njit

TWO_PI = 2.0 * np.pi
PI = np.pi


@njit(cache=True, nogil=True)
def _wrap(a):  # pragma: no cover - compiled
    """``wrap_to_pi``: numpy's ``remainder(a, 2 pi)``, then the shift above pi."""
    if 0.0 < a < TWO_PI:  # fmod(a, 2 pi) = a exactly: skip the slow fmod
        w = a
    elif -TWO_PI < a < 0.0:  # fmod = a, then the divisor's sign: a + 2 pi
        w = a + TWO_PI
    else:  # Python's float modulo: fmod, then the divisor's sign, as numpy's remainder
        w = a % TWO_PI
    if w > PI:
        w -= TWO_PI
    return w


@njit(cache=True, nogil=True)
def _kernel(d, a, b, c3, inv2pi, sigma0):  # pragma: no cover - compiled
    """``sparse_kernel_inside`` of one distance d < l: a = 2 pi / l, b = -1 / (3 l), c3 = 1/3."""
    t = d * a
    c = math.cos(t)
    c += 2.0
    e = d * b
    e += c3
    c *= e
    s = math.sin(t)
    s *= inv2pi
    c += s
    c *= sigma0
    if c < 0.0:
        c = 0.0
    return c


@njit(cache=True, nogil=True)
def _nearest(pose, phi, srt, key, seg_start, seg_len, bin_lo, dense, sbearing, bin_scale,
             bins):  # pragma: no cover - compiled
    """``BeamTable._nearest`` for one (pose, bearing): the nearest beam's position in the sorted
    tables (``srt[position]`` is its index) and |wrapped difference|."""
    start = seg_start[pose]
    n = seg_len[pose]
    if dense[pose]:
        v = pose * 8.0 + phi
        lo = 0
        hi = n
        while lo < hi:
            mid = (lo + hi) // 2
            if key[start + mid] < v:
                lo = mid + 1
            else:
                hi = mid
        pos = lo
        o0 = -2
        o1 = 2
    else:
        b = math.floor((phi + PI) * bin_scale)
        ib = int(b) if b > 0 else 0
        if ib > bins - 1:
            ib = bins - 1
        pos = bin_lo[pose, ib]
        nxt = pos if pos < n - 1 else n - 1
        if pos < n and sbearing[start + nxt] < phi:
            pos += 1
        o0 = -1
        o1 = 1
    best = -1
    best_d = 0.0
    for off in range(o0, o1):
        i = pos + off  # in [-2, n + 1]: Python's (pos + off) % n without a division
        while i < 0:
            i += n
        while i >= n:
            i -= n
        d = abs(_wrap(sbearing[start + i] - phi))  # sbearing[p] is bearings[srt[p]]
        if best < 0 or d < best_d or (d == best_d and srt[start + i] < srt[best]):
            best = start + i
            best_d = d
    return best, best_d


EPS = 1e-8  # [rad] bound used for the fast arctangent's error (its true error is below 1e-10)
TAN_PI_8 = 0.41421356237309503


@njit(cache=True, nogil=True, inline="always")
def _beam_gap(r, diff, lim):  # pragma: no cover - compiled
    """For 0 <= diff < pi/2 [rad] and r [m]: whether the gap ``r sin(diff)`` (computed so) lies
    below lim [m], and whether that is certain (farther than ``r EPS + 1e-12`` from lim, as
    the kernels require of a fast bearing). The sine is skipped where bounds decide with a
    margin: fl(sin x) <= x (the sine lies below x and rounding cannot pass the float x), so
    fl(r fl(sin x)) <= fl(r x); and sin x >= x - x^3 / 6. Same outcome as computing it."""
    tol = r * EPS + 1e-12
    rx = r * diff
    if rx < lim - 2.0 * tol - 1e-9:
        return True, True
    if r * (diff - diff * diff * diff / 6.0) * (1.0 - 1e-12) > lim + 2.0 * tol + 1e-9:
        return False, True
    g_ = r * math.sin(diff)
    return g_ < lim, abs(g_ - lim) > tol


@njit(cache=True, nogil=True, inline="always")
def _lines_beyond(pa, hi_out, bmin_t, bmax_t, r, lim):  # pragma: no cover - compiled
    """For a cell behind the laser (fast bearing ``pa`` [rad] outside the pose's beams, below
    ``lo_out`` or above ``hi_out``; ``bmin_t``, ``bmax_t`` its first and last beam's bearing)
    at range r [m]: whether every beam's line passes farther than lim [m] from it, with a
    margin. The angle to the nearer end of the beams (around the wrap), less 2 EPS, bounds the
    angle to every beam from below; r sin of it (bounded below by x - x^3 / 6) bounds the gap."""
    if pa > hi_out:
        dlt = min(pa - bmax_t, (bmin_t + TWO_PI) - pa)
    else:
        dlt = min(bmin_t - pa, pa - (bmax_t - TWO_PI))
    dlt = min(dlt - 2.0 * EPS - 1e-12, PI / 2)
    return dlt > 0.0 and (r * (dlt - dlt * dlt * dlt / 6.0) * (1.0 - 1e-12)
                          > lim + 2.0 * (r * EPS + 1e-12) + 1e-9)


@njit(cache=True, nogil=True, inline="always")
def _atan2_fast(y, x):  # pragma: no cover - compiled
    """arctan2(y, x) [rad] within 1e-10 (octant reduction, then atan(u) for |u| <= tan(pi/8) by
    its Taylor series to u^21: remainder below 0.4143^23 / 23 < 7e-11)."""
    ax = abs(x)
    ay = abs(y)
    swap = ay > ax
    if swap:
        a = ax / ay
    elif ax > 0.0:
        a = ay / ax
    else:
        a = 0.0
    base = 0.0
    if a > TAN_PI_8:
        a = (a - 1.0) / (a + 1.0)
        base = PI / 4
    u2 = a * a
    p = 1.0 / 21.0
    p = p * u2 - 1.0 / 19.0
    p = p * u2 + 1.0 / 17.0
    p = p * u2 - 1.0 / 15.0
    p = p * u2 + 1.0 / 13.0
    p = p * u2 - 1.0 / 11.0
    p = p * u2 + 1.0 / 9.0
    p = p * u2 - 1.0 / 7.0
    p = p * u2 + 1.0 / 5.0
    p = p * u2 - 1.0 / 3.0
    v = base + (a + a * u2 * p)
    if swap:
        v = PI / 2 - v
    if x < 0.0 or (x == 0.0 and math.copysign(1.0, x) < 0.0):
        v = PI - v
    if y < 0.0 or (y == 0.0 and math.copysign(1.0, y) < 0.0):
        v = -v
    return v


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _atan2_simd(y, x):  # pragma: no cover - compiled
    """:func:`_atan2_fast` without branches, for loops the compiler vectorises: the same
    reduction and series (its polynomial in u^2 by Estrin's scheme, so the last bits differ),
    arctan2(y, x) [rad] within 1e-10. Callers compile with ``error_model='numpy'`` (no
    division check: x = y = 0 gives 0/0, replaced by 0 as in :func:`_atan2_fast`)."""
    ax = abs(x)
    ay = abs(y)
    swap = ay > ax
    num = min(ax, ay)
    den = max(ax, ay)
    a = num / den
    a = a if den > 0.0 else 0.0
    big = a > TAN_PI_8
    a = (a - 1.0) / (a + 1.0) if big else a
    base = PI / 4 if big else 0.0
    u2 = a * a
    u4 = u2 * u2
    u8 = u4 * u4
    q0 = (-1.0 / 3.0) + u2 * (1.0 / 5.0)  # the series' coefficients (-1)^(i+1) / (2 i + 3)
    q1 = (-1.0 / 7.0) + u2 * (1.0 / 9.0)
    q2 = (-1.0 / 11.0) + u2 * (1.0 / 13.0)
    q3 = (-1.0 / 15.0) + u2 * (1.0 / 17.0)
    q4 = (-1.0 / 19.0) + u2 * (1.0 / 21.0)
    p = (q0 + u4 * q1) + u8 * ((q2 + u4 * q3) + u8 * q4)
    v = base + (a + a * u2 * p)
    v = PI / 2 - v if swap else v
    v = PI - v if math.copysign(1.0, x) < 0.0 else v
    v = -v if math.copysign(1.0, y) < 0.0 else v
    return v


@njit(cache=True, nogil=True, error_model="numpy")
def _bearings_simd(ent, e0, e1, cells, px, py, h, dx_s, dy_s, r_s,
                   pa_s):  # pragma: no cover - compiled
    """For the cells ``ent[e0:e1]`` seen from (px, py, h) [m, m, rad], |h| <= pi: offsets
    ``dx_s``, ``dy_s`` and ranges ``r_s`` [m] (as the kernels compute them) and bearings
    ``pa_s`` [rad] within 1e-10 of the exact wrapped bearing. The cells are gathered first, so
    that the second loop, without branches, is vectorised by the compiler. With |h| <= pi,
    atan2 - h lies in [-2 pi, 2 pi], where ``_wrap`` is the two shifts below."""
    m = e1 - e0
    for i in range(m):
        ci = ent[e0 + i]
        dx_s[i] = cells[ci, 0] - px
        dy_s[i] = cells[ci, 1] - py
    for i in range(m):
        dx = dx_s[i]
        dy = dy_s[i]
        r_s[i] = math.sqrt(dx ** 2 + dy ** 2)
        a = _atan2_simd(dy, dx) - h
        w = a + TWO_PI if a < 0.0 else a
        pa_s[i] = w - TWO_PI if w > PI else w


@njit(cache=True, nogil=True, error_model="numpy")
def _row_simd(gx, i0, i1, cy, px, py, h, r_s, pa_s):  # pragma: no cover - compiled
    """:func:`_bearings_simd` for the cells ``gx[i0:i1]`` of one row (centre y ``cy``) [m]:
    ranges ``r_s`` [m] and fast bearings ``pa_s`` [rad] from (px, py, h), |h| <= pi."""
    dy = cy - py
    for i in range(i1 - i0):
        dx = gx[i0 + i] - px
        r_s[i] = math.sqrt(dx ** 2 + dy ** 2)
        a = _atan2_simd(dy, dx) - h
        w = a + TWO_PI if a < 0.0 else a
        pa_s[i] = w - TWO_PI if w > PI else w


@njit(cache=True, nogil=True, inline="always")
def _nearest_at(pos, start, n, phi, srt, sbearing):  # pragma: no cover - compiled
    """The tail of :func:`_nearest_fast`: given ``pos``, the number of the pose's sorted
    bearings below ``phi`` (its segment ``start``, length ``n``), the nearest beam's sorted
    position, its |difference| and whether both are certain.

    Written without branches where the outcome is a coin toss (which neighbour is nearer, the
    wrap's shifts): the shifts as multiples of 2 pi (``a + 2 pi [a < 0]`` is ``a + 2 pi`` or
    ``a + 0.0``, the values :func:`_wrap` gives for -2 pi < a < 2 pi; beyond, ``_wrap`` itself),
    the choice as index arithmetic; the same position and difference as a chain of ifs, 1.3x
    faster in the pose-by-pose pass."""
    i0 = pos - 1
    i0 += n * (i0 < 0)
    i1 = pos - n * (pos >= n)
    p0 = start + i0
    p1 = start + i1
    b0 = sbearing[p0]  # sbearing[p] is bearings[srt[p]]; b0 = sbearing[start + pos - 1] if pos > 0
    b1 = sbearing[p1]  # and b1 = sbearing[start + pos] if pos < n
    sure = not (((pos > 0) & (b0 > phi - EPS)) | ((pos < n) & (b1 < phi + EPS)))
    a0 = b0 - phi
    a1 = b1 - phi
    if abs(a0) < TWO_PI and abs(a1) < TWO_PI:
        w0 = a0 + TWO_PI * (a0 < 0.0)
        w1 = a1 + TWO_PI * (a1 < 0.0)
        d0 = abs(w0 - TWO_PI * (w0 > PI))
        d1 = abs(w1 - TWO_PI * (w1 > PI))
    else:  # beyond the two shifts: the full wrap
        d0 = abs(_wrap(a0))
        d1 = abs(_wrap(a1))
    sure = sure & ((p0 == p1) | (abs(d0 - d1) > 2.0 * EPS + 1e-12))
    one = (d1 < d0) | ((d1 == d0) & (srt[p1] < srt[p0]))
    return p0 + (p1 - p0) * one, min(d0, d1), sure


@njit(cache=True, nogil=True, inline="always")
def _nearest_fast(pose, phi, srt, seg_start, seg_len, bin_lo, sbearing, bin_scale,
                  bins):  # pragma: no cover - compiled
    """``_nearest`` (bin-table poses) for a bearing ``phi`` known within EPS: the beam's sorted
    position, its |difference| and whether both are certain (no bearing within EPS of phi, and
    the two neighbours' differences apart by more than 2 EPS)."""
    start = seg_start[pose]
    n = seg_len[pose]
    b = math.floor((phi + PI) * bin_scale)
    ib = int(b) if b > 0 else 0
    if ib > bins - 1:
        ib = bins - 1
    pos = bin_lo[pose, ib]
    nxt = pos if pos < n - 1 else n - 1
    if pos < n and sbearing[start + nxt] < phi:
        pos += 1
    return _nearest_at(pos, start, n, phi, srt, sbearing)


@njit(cache=True, nogil=True, inline="always")
def _insert(d, t, bd, bi, have, m):  # pragma: no cover - compiled
    """Insert pose t at squared distance d into the sorted (bd, bi) of length m; new ``have``."""
    if have < m or d < bd[m - 1] or (d == bd[m - 1] and t < bi[m - 1]):
        j = have if have < m else m - 1
        while j > 0 and (bd[j - 1] > d or (bd[j - 1] == d and bi[j - 1] > t)):
            bd[j] = bd[j - 1]
            bi[j] = bi[j - 1]
            j -= 1
        bd[j] = d
        bi[j] = t
        if have < m:
            have += 1
    return have


RANK_MAX = 96  # candidates up to which a cell's k + 1 nearest are placed by their ranks


@njit(cache=True, nogil=True, inline="always")
def _rank_select(bufd, bufi, nb, bd, bi, m):  # pragma: no cover - compiled
    """The first m of the nb (squared distance, pose) pairs ``bufd``, ``bufi`` (distinct poses,
    nb >= m) in the order (distance, then pose) into ``bd``, ``bi``: each pair goes to its rank,
    the number of pairs before it in that order (a loop without branches, vectorised; the
    insertion sort's mispredicted branches cost more at these sizes). The same arrays as
    inserting them one by one with :func:`_insert`."""
    for a in range(nb):
        da = bufd[a]
        ta = bufi[a]
        rk = 0
        for b in range(nb):
            db = bufd[b]
            rk += (db < da) | ((db == da) & (bufi[b] < ta))
        if rk < m:
            bd[rk] = da
            bi[rk] = ta


@njit(cache=True, nogil=True)
def _bin_table(sbearing, seg_start, seg_len, bins, lo, dense):  # pragma: no cover - compiled
    """Per pose t: ``lo[t, b]`` the number of its sorted bearings [rad] in bins below b, and
    ``dense[t]`` two of them share a bin. One pass over the bearings, each bin computed once
    (``sensor._bin``, as numpy computes it): the bins up to a bearing's own get the count
    before it (a run of stores), the bins beyond the last one the pose's count."""
    scale = bins / TWO_PI
    for t in range(seg_start.shape[0]):
        a = seg_start[t]
        n = seg_len[t]
        b = 0
        prev = -1
        for j in range(n):
            v = math.floor((sbearing[a + j] + PI) * scale)
            ib = int(v) if v > 0 else 0
            if ib > bins - 1:
                ib = bins - 1
            if ib == prev:
                dense[t] = True
            prev = ib
            while b <= ib:
                lo[t, b] = j
                b += 1
        while b < bins:
            lo[t, b] = n
            b += 1


def bin_table(sorted_bearings, seg_start, seg_len, bins) -> tuple:
    """``BeamTable._bins`` compiled: (T, bins) int32, the number of the pose's sorted bearings
    [rad] in lower bins, and (T,) bool, some bin holds two bearings; the same arrays."""
    lo = np.empty((len(seg_start), bins), np.int32)
    dense = np.zeros(len(seg_start), np.bool_)
    warm(_bin_table)
    _bin_table(np.ascontiguousarray(sorted_bearings, dtype=np.float64),
               np.ascontiguousarray(seg_start, dtype=np.int64),
               np.ascontiguousarray(seg_len, dtype=np.int64), int(bins), lo, dense)
    return lo, dense


KNN_TILE = 16  # cells per side of the tiles of the nearest-pose query (in units of the cell spacing)


@njit(cache=True, nogil=True)
def _knn_tiles(cells, pxy, k, tile, out, tie):  # pragma: no cover - compiled
    """The ``k`` nearest poses of every cell (sorted by squared distance, then index); ``tie``
    marks cells whose first k + 1 squared distances hold two equal values.

    Cells are grouped into square tiles of side ``tile`` [m] (a counting sort by tile). Per tile,
    with centre c, D the (k+1)-th distance from c over all poses and h the largest distance of a
    cell of the tile from c: a cell's k + 1 nearest poses lie within D + h of it, so within
    D + 2 h of c; those candidates, sorted by their distance dc from c, are what the tile's cells
    search. A cell at distance hc from c stops at the first candidate with dc - hc beyond its
    (k+1)-th distance so far (no later one can be nearer). Neighbouring cells so share one
    candidate list, and each cell looks at little more than its own k + 1 poses.

    Per tile, D comes from one vectorised loop of squared distances and a selection
    (``np.partition``), the candidates from a compaction without branches; per cell, the
    candidates within its bound u are kept the same way (a store at the end of the kept ones,
    whose count grows by the test), then ranked (:func:`_rank_select`).
    """
    n = pxy.shape[0]
    nc = cells.shape[0]
    m = k + 1 if n > k else k
    # tiles: counting sort of the cells by (tile row, tile column)
    x0 = np.inf
    y0 = np.inf
    x1 = -np.inf
    y1 = -np.inf
    for i in range(nc):
        x0 = min(x0, cells[i, 0])
        x1 = max(x1, cells[i, 0])
        y0 = min(y0, cells[i, 1])
        y1 = max(y1, cells[i, 1])
    ntx = int((x1 - x0) / tile) + 1
    nty = int((y1 - y0) / tile) + 1
    tid = np.empty(nc, np.int64)
    count = np.zeros(ntx * nty + 1, np.int64)
    for i in range(nc):
        tx = min(int((cells[i, 0] - x0) / tile), ntx - 1)
        ty = min(int((cells[i, 1] - y0) / tile), nty - 1)
        tid[i] = ty * ntx + tx
        count[tid[i] + 1] += 1
    for b in range(ntx * nty):
        count[b + 1] += count[b]
    order = np.empty(nc, np.int64)
    fill = count[:-1].copy()
    for i in range(nc):
        order[fill[tid[i]]] = i
        fill[tid[i]] += 1
    bd = np.empty(m)
    bi = np.empty(m, np.int64)
    cd = np.empty(n)
    ci_ = np.empty(n, np.int64)
    bufd = np.empty(n)
    bufi = np.empty(n, np.int64)
    ext = np.empty(m, np.int64)
    d2all = np.empty(n)
    d2sel = np.empty(n)
    for b in range(ntx * nty):
        q0 = count[b]
        q1 = count[b + 1]
        if q0 == q1:
            continue
        # the tile's centre and half-size h
        mx = 0.0
        my = 0.0
        for q in range(q0, q1):
            mx += cells[order[q], 0]
            my += cells[order[q], 1]
        mx /= q1 - q0
        my /= q1 - q0
        h = 0.0
        for q in range(q0, q1):
            i = order[q]
            h = max(h, math.sqrt((cells[i, 0] - mx) ** 2 + (cells[i, 1] - my) ** 2))
        for t in range(n):
            dx = mx - pxy[t, 0]
            dy = my - pxy[t, 1]
            d2all[t] = dx * dx + dy * dy
        for t in range(n):
            d2sel[t] = d2all[t]
        dm = np.partition(d2sel, m - 1)[m - 1]
        rad = (math.sqrt(dm) + 2.0 * h) * (1.0 + 1e-9) + 1e-9
        nc_ = 0
        for t in range(n):
            d = math.sqrt(d2all[t])
            cd[nc_] = d
            ci_[nc_] = t
            nc_ += d <= rad
        srt = np.argsort(cd[:nc_])
        cdist = cd[:nc_][srt]
        cidx = ci_[:nc_][srt]
        prev = -1
        for q in range(q0, q1):
            i = order[q]
            cx = cells[i, 0]
            cy = cells[i, 1]
            hc = math.sqrt((cx - mx) ** 2 + (cy - my) ** 2) * (1.0 + 1e-9) + 1e-9
            # u: a bound on this cell's (k+1)-th distance (the previous cell's k + 1 poses, or
            # the first k + 1 candidates, are k + 1 poses within u of it)
            u2 = 0.0
            for j in range(m):
                t = out[prev, j] if prev >= 0 and j < k else (ext[j] if prev >= 0 else cidx[j])
                dx = cx - pxy[t, 0]
                dy = cy - pxy[t, 1]
                u2 = max(u2, dx * dx + dy * dy)
            u = math.sqrt(u2) * (1.0 + 1e-9) + 1e-9
            lim = u + hc
            u2 = u * u
            nb = 0
            for j in range(nc_):  # every pose within u, in the order of dc
                if cdist[j] > lim:
                    break
                t = cidx[j]
                dx = cx - pxy[t, 0]
                dy = cy - pxy[t, 1]
                d = dx * dx + dy * dy
                bufd[nb] = d
                bufi[nb] = t
                nb += d <= u2
            if nb <= RANK_MAX:
                _rank_select(bufd, bufi, nb, bd, bi, m)
            else:
                have = 0
                for j in range(nb):
                    have = _insert(bufd[j], bufi[j], bd, bi, have, m)
            t_ = False
            for j in range(k):
                out[i, j] = bi[j]
            if m > k:
                ext[k] = bi[m - 1]  # the (k+1)-th pose, for the next cell's bound
            for j in range(m - 1):
                if bd[j] == bd[j + 1]:
                    t_ = True
            tie[i] = t_
            prev = i


def nearest_poses(cells: np.ndarray, pose_xy: np.ndarray, k: int, tree=None,
                  spacing: float | None = None) -> np.ndarray:
    """(n_cells, k) int64: for every cell centre [m] the indices of its ``k`` nearest poses [m]
    (world frame), nearest first; the same poses in the same order as
    ``scipy.spatial.cKDTree(pose_xy).query(cells, k)`` (tied cells are answered by the KD-tree).

    spacing : float [m], optional; the cells' spacing (a grid's ``grid_size``), which sets the
        tile size of the search (``KNN_TILE`` cells); by default estimated from the cells' extent.
    """
    cells = np.ascontiguousarray(cells, dtype=np.float64)
    pxy = np.ascontiguousarray(pose_xy, dtype=np.float64)
    n = len(pxy)
    k = min(int(k), n)
    out = np.empty((len(cells), k), np.int64)
    tie = np.zeros(len(cells), np.bool_)
    if len(cells) == 0:
        return out
    if spacing is None or not spacing > 0:
        span = float(np.max(cells.max(axis=0) - cells.min(axis=0)))
        spacing = span / max(1.0, np.sqrt(len(cells))) if span > 0 else 1.0
    warm(_knn_tiles)
    _knn_tiles(cells, pxy, k, float(spacing) * KNN_TILE, out, tie)
    if tie.any():
        from scipy.spatial import cKDTree
        tree = tree if tree is not None else cKDTree(pxy)
        _, nn = tree.query(cells[tie], k=k)
        out[tie] = np.asarray(nn).reshape(-1, k)
    return out


@njit(cache=True, nogil=True)
def _cells_kernel(c0, c1, cells, poses, nn, reach, ranges, cls_hit, srt, key, seg_start,
                  seg_len, bin_lo, dense, sbearing, bin_scale, bins, continuous, z_max, half, wb2,
                  bmin, bmax, l, step, count_kind, ka, kb, kc3, kinv2pi, sigma0, n_off, bcos, bsin,
                  acc, pairs):  # pragma: no cover - compiled
    """Evidence of cells c0:c1 into ``acc`` (n_cells, K); ``pairs[0]`` counts the (cell, pose)
    pairs inside the field, ``pairs[1]`` the free samples evaluated."""
    n_classes = acc.shape[1]
    free = n_classes - 1
    all_poses = nn.shape[0] == 0
    n_per = poses.shape[0] if all_poses else nn.shape[1]
    s_end = np.zeros(n_classes)
    s_off = np.zeros(n_off)
    lim = l + 1e-9
    n_pairs = 0
    n_samp = 0
    n_fast = 0
    k = 0
    diff = 0.0
    zk = 0.0
    near = False
    wide = False
    reach_ok = False
    for ci in range(c0, c1):
        cx = cells[ci, 0]
        cy = cells[ci, 1]
        for c in range(n_classes):
            s_end[c] = 0.0
        for o in range(n_off):
            s_off[o] = 0.0
        for q in range(n_per):
            t = q if all_poses else nn[ci, q]
            px = poses[t, 0]
            py = poses[t, 1]
            if all_poses:
                if not ((cx - px) ** 2 + (cy - py) ** 2 < reach[t] ** 2):
                    continue
            dx = cx - px
            dy = cy - py
            r = math.sqrt(dx ** 2 + dy ** 2)
            if not (r > 0.0 and r < z_max):
                continue
            # The bearing's decisions (field, nearest beam, beam width or gap) from a fast
            # arctangent within EPS; any decision closer than EPS to its threshold is taken
            # again with the exact bearing, so the outcome is the exact one.
            sure = False
            if not dense[t]:
                pa = _wrap(_atan2_fast(dy, dx) - poses[t, 2])
                if abs(pa) < PI - EPS:
                    k, diff, sure = _nearest_fast(t, pa, srt, seg_start, seg_len,
                                                  bin_lo, sbearing, bin_scale, bins)
                if sure:
                    if not continuous:
                        lo_ = bmin[t] - wb2 - 1e-9
                        hi_ = bmax[t] + wb2 + 1e-9
                        wraps = (bmin[t] - wb2 <= -PI + 1e-9) or (bmax[t] + wb2 >= PI - 1e-9)
                        if not wraps and (abs(pa - lo_) < EPS or abs(pa - hi_) < EPS):
                            sure = False
                        reach_ok = wraps or (pa >= lo_ and pa <= hi_)
                        if abs(diff - wb2) < EPS:
                            sure = False
                        wide = diff > wb2
                    else:
                        zk = ranges[k]
                        if r - zk >= lim:
                            near = False
                        elif abs(diff - PI / 2) < EPS:
                            sure = False
                        elif diff < PI / 2:
                            near, ok = _beam_gap(r, diff, lim)
                            sure = sure and ok
                        else:
                            near = r < lim
            if not sure:
                phi = _wrap(math.atan2(dy, dx) - poses[t, 2])
                if not (phi > -PI and phi < PI):
                    continue
                if not continuous:
                    lo_ = bmin[t] - wb2
                    hi_ = bmax[t] + wb2
                    wraps = (lo_ <= -PI + 1e-9) or (hi_ >= PI - 1e-9)
                    reach_ok = wraps or (phi >= lo_ - 1e-9 and phi <= hi_ + 1e-9)
                k, diff = _nearest(t, phi, srt, key, seg_start, seg_len, bin_lo, dense,
                                   sbearing, bin_scale, bins)
                wide = diff > wb2
                if continuous:
                    zk = ranges[k]
                    gap = r * math.sin(diff) if diff < PI / 2 else r
                    if r - zk > gap:
                        gap = r - zk
                    near = gap < lim
            else:
                n_fast += 1
            n_pairs += 1
            zk = ranges[k]
            if not continuous:
                if not reach_ok:
                    continue
                outside = (r > min(z_max, zk + half)) or wide
                hit = (not outside) and zk < z_max and abs(r - zk) < half
                if hit:
                    acc[ci, cls_hit[k]] += 1.0
                elif (not outside) and r < zk and zk < z_max:
                    acc[ci, free] += 1.0
                continue
            if not near:
                continue
            c = bcos[k]
            s = bsin[k]
            d1 = math.sqrt((cx - (px + zk * c)) ** 2 + (cy - (py + zk * s)) ** 2)
            if d1 < l:
                s_end[cls_hit[k]] += _kernel(d1, ka, kb, kc3, kinv2pi, sigma0)
            tt = dx * c + dy * s
            e = dx * s - dy * c
            if not (abs(e) < l and tt > -l and tt < zk + l):
                continue
            if count_kind == 3:  # arange_world
                zw = math.sqrt((px - (px + zk * c)) ** 2 + (py - (py + zk * s)) ** 2)
                cnt = max(math.ceil(zw / step), 0.0)
                count = int(cnt)
            elif count_kind == 2:  # arange
                count = int(max(math.ceil(zk / step), 0.0))
            else:
                count = int(math.ceil(zk / step))
                if (count - 1) * step >= zk:
                    count -= 1
                if count * step < zk:
                    count += 1
                if count_kind == 1 and count * step < zk + 1e-9:
                    count += 1
            j_lo = int(math.floor((tt - l) / step))
            if j_lo < 0:
                j_lo = 0
            j_hi = int(math.ceil((tt + l) / step))
            if j_hi > count - 1:
                j_hi = count - 1
            for o in range(n_off):
                j = j_lo + o
                if j > j_hi:
                    break
                sj = j * step
                d2 = math.sqrt((cx - (px + sj * c)) ** 2 + (cy - (py + sj * s)) ** 2)
                n_samp += 1
                if d2 < l:
                    s_off[o] += _kernel(d2, ka, kb, kc3, kinv2pi, sigma0)
        if continuous:
            for c in range(free):
                acc[ci, c] += s_end[c]
            for o in range(n_off):
                acc[ci, free] += s_off[o]
    pairs[0] += n_pairs
    pairs[1] += n_samp
    pairs[2] += n_fast



PASS_PAIRS = 1 << 20  # (cell, pose) pairs per block of the pose-by-pose pass (bounds its memory)


@njit(cache=True, nogil=True)
def _pose_pass(c0, c1, cells, poses, nn, ranges, cls_hit, srt, key, seg_start, seg_len, bin_lo,
               dense, sbearing, bin_scale, bins, continuous, z_max, half, wb2, bmin, bmax, l,
               acc, kk, ent, ent_q, pairs):  # pragma: no cover - compiled
    """The nearest beams of the (cell, pose) pairs of cells c0:c1 (poses ``nn``), pose by pose.

    Each pair takes the steps of :func:`_cells_kernel`. Discrete models add their counts to
    ``acc`` at once (whole numbers: any order gives the same sums). Continuous models write
    ``kk[(ci - c0) * k + q]``: the sorted position of the nearest beam of pair (ci, nn[ci, q])
    when that beam can come within l of the cell, else -1 (their sums are formed cell by cell
    by :func:`_kernel_pass`). ``ent`` and, continuous, ``ent_q`` (at least (c1 - c0) k int32
    each) are scratch: the pairs' cells and slots q, pose by pose.

    A pose meets its cells in ascending order, so one pose's bearing index stays in the cache,
    and along a row of cells the count of the pose's bearings below the cell's bearing (from
    which the nearest beam follows) is found by stepping from the previous cell's count; the
    steps end where ``sbearing[pos - 1] < phi <= sbearing[pos]``, the count the bin table gives.
    Discrete models skip the lookup for cells whose fast bearing lies farther than 2 EPS beyond
    the pose's beams widened by half a beam width (behind a laser that does not see all
    around): the exact bearing lies beyond them too, so no beam is within half a width and
    the pair adds nothing (it is counted as a pair decided by the fast bearing). Continuous
    models skip it there when even the nearest beam's line passes farther than l from the
    cell: the angle to the nearest beam is at least d, the fast bearing's distance to the
    pose's first or last beam less 2 EPS, so the gap r sin(diff) (or r) is at least
    r (d - d^3 / 6) for d <= pi / 2; beyond l by the margin of :func:`_beam_gap`, no sums.
    """
    n_per = nn.shape[1]
    n_poses = poses.shape[0]
    free = acc.shape[1] - 1
    lim = l + 1e-9
    start = np.zeros(n_poses + 1, np.int64)  # the pairs by pose: a counting sort
    for ci in range(c0, c1):
        for q in range(n_per):
            start[nn[ci, q] + 1] += 1
    for t in range(n_poses):
        start[t + 1] += start[t]
    fill = start[:-1].copy()
    for ci in range(c0, c1):
        for q in range(n_per):
            t = nn[ci, q]
            ent[fill[t]] = ci
            if continuous:
                ent_q[fill[t]] = q
            fill[t] += 1
    if continuous:
        for e in range((c1 - c0) * n_per):
            kk[e] = -1
    most = 0
    for t in range(n_poses):
        most = max(most, start[t + 1] - start[t])
    r_s = np.empty(most)
    pa_s = np.empty(most)
    dx_s = np.empty(most)
    dy_s = np.empty(most)
    n_pairs = 0
    n_fast = 0
    k = 0
    diff = 0.0
    zk = 0.0
    near = False
    wide = False
    reach_ok = False
    for t in range(n_poses):
        px = poses[t, 0]
        py = poses[t, 1]
        h = poses[t, 2]
        dn = dense[t]
        lo_t = bmin[t] - wb2
        hi_t = bmax[t] + wb2
        wraps = (lo_t <= -PI + 1e-9) or (hi_t >= PI - 1e-9)
        behind = not wraps
        bmin_t = bmin[t]
        bmax_t = bmax[t]
        lo_out = lo_t - 1e-9 - 2.0 * EPS
        hi_out = hi_t + 1e-9 + 2.0 * EPS
        st = seg_start[t]
        n = seg_len[t]
        ppos = 0
        pci = -2
        e0 = start[t]
        simd = abs(h) <= PI and not dn
        if simd:  # ranges and fast bearings of all the pose's cells in one vectorised loop
            _bearings_simd(ent, e0, start[t + 1], cells, px, py, h, dx_s, dy_s, r_s, pa_s)
        for e in range(e0, start[t + 1]):
            ci = ent[e]
            if simd:
                dx = dx_s[e - e0]
                dy = dy_s[e - e0]
                r = r_s[e - e0]
            else:
                dx = cells[ci, 0] - px
                dy = cells[ci, 1] - py
                r = math.sqrt(dx ** 2 + dy ** 2)
            if not (r > 0.0 and r < z_max):
                continue
            # as in _cells_kernel: a fast arctangent within EPS decides, and any decision
            # closer than EPS to its threshold is taken again with the exact bearing
            sure = False
            if not dn:
                pa = pa_s[e - e0] if simd else _wrap(_atan2_fast(dy, dx) - h)
                if behind and (pa < lo_out or pa > hi_out) and abs(pa) < PI - EPS:
                    if not continuous:
                        n_pairs += 1  # beyond every beam's width, by more than EPS: no count
                        n_fast += 1
                        continue
                    if _lines_beyond(pa, hi_out, bmin_t, bmax_t, r, lim):
                        n_pairs += 1  # every beam's line passes farther than l: no sums
                        n_fast += 1
                        continue
                if abs(pa) < PI - EPS:
                    if ci == pci + 1:  # the next cell of a row: step from its count
                        pos = ppos
                        while pos > 0 and sbearing[st + pos - 1] >= pa:
                            pos -= 1
                        while pos < n and sbearing[st + pos] < pa:
                            pos += 1
                    else:  # the bin table
                        b = math.floor((pa + PI) * bin_scale)
                        ib = int(b) if b > 0 else 0
                        if ib > bins - 1:
                            ib = bins - 1
                        pos = bin_lo[t, ib]
                        nxt = pos if pos < n - 1 else n - 1
                        if pos < n and sbearing[st + nxt] < pa:
                            pos += 1
                    ppos = pos
                    pci = ci
                    k, diff, sure = _nearest_at(pos, st, n, pa, srt, sbearing)
            if sure:
                if not continuous:
                    lo_ = lo_t - 1e-9
                    hi_ = hi_t + 1e-9
                    if not wraps and (abs(pa - lo_) < EPS or abs(pa - hi_) < EPS):
                        sure = False
                    reach_ok = wraps or (pa >= lo_ and pa <= hi_)
                    if abs(diff - wb2) < EPS:
                        sure = False
                    wide = diff > wb2
                else:
                    zk = ranges[k]
                    if r - zk >= lim:
                        near = False
                    elif abs(diff - PI / 2) < EPS:
                        sure = False
                    elif diff < PI / 2:
                        near, ok = _beam_gap(r, diff, lim)
                        sure = sure and ok
                    else:
                        near = r < lim
            if not sure:
                phi = _wrap(math.atan2(dy, dx) - h)
                if not (phi > -PI and phi < PI):
                    continue
                if not continuous:
                    reach_ok = wraps or (phi >= lo_t - 1e-9 and phi <= hi_t + 1e-9)
                k, diff = _nearest(t, phi, srt, key, seg_start, seg_len, bin_lo, dense,
                                   sbearing, bin_scale, bins)
                wide = diff > wb2
                if continuous:
                    zk = ranges[k]
                    gap = r * math.sin(diff) if diff < PI / 2 else r
                    if r - zk > gap:
                        gap = r - zk
                    near = gap < lim
            else:
                n_fast += 1
            n_pairs += 1
            zk = ranges[k]
            if not continuous:
                if not reach_ok:
                    continue
                outside = (r > min(z_max, zk + half)) or wide
                hit = (not outside) and zk < z_max and abs(r - zk) < half
                if hit:
                    acc[ci, cls_hit[k]] += 1.0
                elif (not outside) and r < zk and zk < z_max:
                    acc[ci, free] += 1.0
                continue
            if near:
                kk[(ci - c0) * n_per + ent_q[e]] = k
    pairs[0] += n_pairs
    pairs[2] += n_fast


@njit(cache=True, nogil=True)
def _kernel_pass(c0, c1, cells, poses, nn, kk, ranges, cls_hit, l, step, count_kind, ka, kb,
                 kc3, kinv2pi, sigma0, n_off, bcos, bsin, acc, pairs):  # pragma: no cover
    """The continuous sums of cells c0:c1 from the nearest beams ``kk`` of :func:`_pose_pass`:
    cell by cell, its poses in ``nn`` order, each pair's steps and sums as in
    :func:`_cells_kernel` (so the same sums in the same order)."""
    n_classes = acc.shape[1]
    free = n_classes - 1
    n_per = nn.shape[1]
    s_end = np.zeros(n_classes)
    s_off = np.zeros(n_off)
    n_samp = 0
    for ci in range(c0, c1):
        cx = cells[ci, 0]
        cy = cells[ci, 1]
        for c in range(n_classes):
            s_end[c] = 0.0
        for o in range(n_off):
            s_off[o] = 0.0
        base = (ci - c0) * n_per
        for q in range(n_per):
            k = kk[base + q]
            if k < 0:
                continue
            t = nn[ci, q]
            px = poses[t, 0]
            py = poses[t, 1]
            dx = cx - px
            dy = cy - py
            zk = ranges[k]
            c = bcos[k]
            s = bsin[k]
            d1 = math.sqrt((cx - (px + zk * c)) ** 2 + (cy - (py + zk * s)) ** 2)
            if d1 < l:
                s_end[cls_hit[k]] += _kernel(d1, ka, kb, kc3, kinv2pi, sigma0)
            tt = dx * c + dy * s
            e = dx * s - dy * c
            if not (abs(e) < l and tt > -l and tt < zk + l):
                continue
            if count_kind == 3:  # arange_world
                zw = math.sqrt((px - (px + zk * c)) ** 2 + (py - (py + zk * s)) ** 2)
                cnt = max(math.ceil(zw / step), 0.0)
                count = int(cnt)
            elif count_kind == 2:  # arange
                count = int(max(math.ceil(zk / step), 0.0))
            else:
                count = int(math.ceil(zk / step))
                if (count - 1) * step >= zk:
                    count -= 1
                if count * step < zk:
                    count += 1
                if count_kind == 1 and count * step < zk + 1e-9:
                    count += 1
            j_lo = int(math.floor((tt - l) / step))
            if j_lo < 0:
                j_lo = 0
            j_hi = int(math.ceil((tt + l) / step))
            if j_hi > count - 1:
                j_hi = count - 1
            for o in range(n_off):
                j = j_lo + o
                if j > j_hi:
                    break
                sj = j * step
                d2 = math.sqrt((cx - (px + sj * c)) ** 2 + (cy - (py + sj * s)) ** 2)
                n_samp += 1
                if d2 < l:
                    s_off[o] += _kernel(d2, ka, kb, kc3, kinv2pi, sigma0)
        for c in range(free):
            acc[ci, c] += s_end[c]
        for o in range(n_off):
            acc[ci, free] += s_off[o]
    pairs[1] += n_samp


def _nn_pass(c0, c1, args, kargs, nn, continuous, acc, pairs):
    """Cells c0:c1 with their poses ``nn``: :func:`_pose_pass`, then for the continuous models
    :func:`_kernel_pass`, in blocks of at most ``PASS_PAIRS`` pairs (whole cells)."""
    per = max(1, PASS_PAIRS // max(1, nn.shape[1]))
    size = min(per, c1 - c0) * nn.shape[1]
    ent = np.empty(size, np.int32)
    kk = np.empty(size if continuous else 1, np.int32)
    ent_q = np.empty(size if continuous else 1, np.int32)
    for a in range(c0, c1, per):
        b = min(a + per, c1)
        _pose_pass(a, b, *args, acc, kk, ent, ent_q, pairs)
        if continuous:
            _kernel_pass(a, b, *kargs[:3], kk, *kargs[3:], acc, pairs)


@njit(cache=True, nogil=True)
def _poses_kernel(row0, row1, gx, gy, poses, reach, ranges, cls_hit, srt, key,
                  seg_start, seg_len, bin_lo, dense, sbearing, bin_scale, bins, continuous, z_max,
                  half, wb2, bmin, bmax, l, step, count_kind, ka, kb, kc3, kinv2pi, sigma0, n_off,
                  bcos, bsin, acc, s_end, s_off, pairs):  # pragma: no cover - compiled
    """``nearest_poses=None``, pose by pose: the cells of rows row0:row1 within the pose's reach,
    each pair exactly as :func:`_cells_kernel` (a cell meets its poses in index order, the order
    of the cell-by-cell path), the continuous sums kept per cell in ``s_end`` (n_cells, K) and
    ``s_off`` (n_cells, n_off) and added to ``acc`` at the end in the same order. Keeping one
    pose's beam index hot in the cache makes this several times faster than cell by cell.
    Cells behind the laser skip the nearest-beam lookup as in :func:`_pose_pass`."""
    n_classes = acc.shape[1]
    free = n_classes - 1
    nx = gx.shape[0]
    g = (gx[nx - 1] - gx[0]) / (nx - 1) if nx > 1 else 1.0
    gyy = (gy[gy.shape[0] - 1] - gy[0]) / (gy.shape[0] - 1) if gy.shape[0] > 1 else 1.0
    lim = l + 1e-9
    n_pairs = 0
    n_samp = 0
    n_fast = 0
    k = 0
    diff = 0.0
    zk = 0.0
    near = False
    wide = False
    reach_ok = False
    r_s = np.empty(nx)
    pa_s = np.empty(nx)
    for t in range(poses.shape[0]):
        px = poses[t, 0]
        py = poses[t, 1]
        rt = reach[t]
        simd = abs(poses[t, 2]) <= PI and not dense[t]
        bmin_t = bmin[t]
        bmax_t = bmax[t]
        behind = not ((bmin_t - wb2 <= -PI + 1e-9) or (bmax_t + wb2 >= PI - 1e-9))
        lo_out = bmin_t - wb2 - 1e-9 - 2.0 * EPS
        hi_out = bmax_t + wb2 + 1e-9 + 2.0 * EPS
        ix0 = max(0, int(math.floor((px - rt - gx[0]) / g)) - 1)
        ix1 = min(nx - 1, int(math.ceil((px + rt - gx[0]) / g)) + 1)
        iy0 = max(row0, int(math.floor((py - rt - gy[0]) / gyy)) - 1)
        iy1 = min(row1 - 1, int(math.ceil((py + rt - gy[0]) / gyy)) + 1)
        for iy in range(iy0, iy1 + 1):
            cy = gy[iy]
            if simd:  # the row's ranges and fast bearings in one vectorised loop
                _row_simd(gx, ix0, ix1 + 1, cy, px, py, poses[t, 2], r_s, pa_s)
            pix = -2
            ppos = 0
            st = seg_start[t]
            n = seg_len[t]
            for ix in range(ix0, ix1 + 1):
                cx = gx[ix]
                if not ((cx - px) ** 2 + (cy - py) ** 2 < rt ** 2):
                    continue
                ci = iy * nx + ix
                dx = cx - px
                dy = cy - py
                r = r_s[ix - ix0] if simd else math.sqrt(dx ** 2 + dy ** 2)
                if not (r > 0.0 and r < z_max):
                    continue
                # The bearing's decisions (field, nearest beam, beam width or gap) from a fast
                # arctangent within EPS; any decision closer than EPS to its threshold is taken
                # again with the exact bearing, so the outcome is the exact one.
                sure = False
                if not dense[t]:
                    pa = pa_s[ix - ix0] if simd else _wrap(_atan2_fast(dy, dx) - poses[t, 2])
                    if behind and (pa < lo_out or pa > hi_out) and abs(pa) < PI - EPS:
                        if not continuous:  # as in _pose_pass: beyond every beam's width
                            n_pairs += 1
                            n_fast += 1
                            continue
                        if _lines_beyond(pa, hi_out, bmin_t, bmax_t, r, lim):
                            n_pairs += 1  # every beam's line passes farther than l
                            n_fast += 1
                            continue
                    if abs(pa) < PI - EPS:
                        if ix == pix + 1:  # the next cell of the row: step from its count
                            pos = ppos
                            while pos > 0 and sbearing[st + pos - 1] >= pa:
                                pos -= 1
                            while pos < n and sbearing[st + pos] < pa:
                                pos += 1
                        else:  # the bin table
                            b = math.floor((pa + PI) * bin_scale)
                            ib = int(b) if b > 0 else 0
                            if ib > bins - 1:
                                ib = bins - 1
                            pos = bin_lo[t, ib]
                            nxt = pos if pos < n - 1 else n - 1
                            if pos < n and sbearing[st + nxt] < pa:
                                pos += 1
                        ppos = pos
                        pix = ix
                        k, diff, sure = _nearest_at(pos, st, n, pa, srt, sbearing)
                    if sure:
                        if not continuous:
                            lo_ = bmin[t] - wb2 - 1e-9
                            hi_ = bmax[t] + wb2 + 1e-9
                            wraps = (bmin[t] - wb2 <= -PI + 1e-9) or (bmax[t] + wb2 >= PI - 1e-9)
                            if not wraps and (abs(pa - lo_) < EPS or abs(pa - hi_) < EPS):
                                sure = False
                            reach_ok = wraps or (pa >= lo_ and pa <= hi_)
                            if abs(diff - wb2) < EPS:
                                sure = False
                            wide = diff > wb2
                        else:
                            zk = ranges[k]
                            if r - zk >= lim:
                                near = False
                            elif abs(diff - PI / 2) < EPS:
                                sure = False
                            elif diff < PI / 2:
                                near, ok = _beam_gap(r, diff, lim)
                                sure = sure and ok
                            else:
                                near = r < lim
                if not sure:
                    phi = _wrap(math.atan2(dy, dx) - poses[t, 2])
                    if not (phi > -PI and phi < PI):
                        continue
                    if not continuous:
                        lo_ = bmin[t] - wb2
                        hi_ = bmax[t] + wb2
                        wraps = (lo_ <= -PI + 1e-9) or (hi_ >= PI - 1e-9)
                        reach_ok = wraps or (phi >= lo_ - 1e-9 and phi <= hi_ + 1e-9)
                    k, diff = _nearest(t, phi, srt, key, seg_start, seg_len, bin_lo, dense,
                                       sbearing, bin_scale, bins)
                    wide = diff > wb2
                    if continuous:
                        zk = ranges[k]
                        gap = r * math.sin(diff) if diff < PI / 2 else r
                        if r - zk > gap:
                            gap = r - zk
                        near = gap < lim
                else:
                    n_fast += 1
                n_pairs += 1
                zk = ranges[k]
                if not continuous:
                    if not reach_ok:
                        continue
                    outside = (r > min(z_max, zk + half)) or wide
                    hit = (not outside) and zk < z_max and abs(r - zk) < half
                    if hit:
                        acc[ci, cls_hit[k]] += 1.0
                    elif (not outside) and r < zk and zk < z_max:
                        acc[ci, free] += 1.0
                    continue
                if not near:
                    continue
                c = bcos[k]
                s = bsin[k]
                d1 = math.sqrt((cx - (px + zk * c)) ** 2 + (cy - (py + zk * s)) ** 2)
                if d1 < l:
                    s_end[ci, cls_hit[k]] += _kernel(d1, ka, kb, kc3, kinv2pi, sigma0)
                tt = dx * c + dy * s
                e = dx * s - dy * c
                if not (abs(e) < l and tt > -l and tt < zk + l):
                    continue
                if count_kind == 3:  # arange_world
                    zw = math.sqrt((px - (px + zk * c)) ** 2 + (py - (py + zk * s)) ** 2)
                    cnt = max(math.ceil(zw / step), 0.0)
                    count = int(cnt)
                elif count_kind == 2:  # arange
                    count = int(max(math.ceil(zk / step), 0.0))
                else:
                    count = int(math.ceil(zk / step))
                    if (count - 1) * step >= zk:
                        count -= 1
                    if count * step < zk:
                        count += 1
                    if count_kind == 1 and count * step < zk + 1e-9:
                        count += 1
                j_lo = int(math.floor((tt - l) / step))
                if j_lo < 0:
                    j_lo = 0
                j_hi = int(math.ceil((tt + l) / step))
                if j_hi > count - 1:
                    j_hi = count - 1
                for o in range(n_off):
                    j = j_lo + o
                    if j > j_hi:
                        break
                    sj = j * step
                    d2 = math.sqrt((cx - (px + sj * c)) ** 2 + (cy - (py + sj * s)) ** 2)
                    n_samp += 1
                    if d2 < l:
                        s_off[ci, o] += _kernel(d2, ka, kb, kc3, kinv2pi, sigma0)
    if continuous:
        for iy in range(row0, row1):
            for ci in range(iy * nx, (iy + 1) * nx):
                for c in range(free):
                    acc[ci, c] += s_end[ci, c]
                for o in range(n_off):
                    acc[ci, free] += s_off[ci, o]
    pairs[0] += n_pairs
    pairs[1] += n_samp
    pairs[2] += n_fast


def beam_directions(table, poses) -> tuple:
    """cos and sin of every beam's world bearing ``bearing + heading`` [rad] (as the numpy path
    computes them per pair: the same value, once per beam)."""
    theta = table.bearings + np.asarray(poses, dtype=float)[table.pose_of, 2]
    return np.cos(theta), np.sin(theta)


COUNT_KINDS = {"strict": 0, "through": 1, "arange": 2, "arange_world": 3}


def threads() -> int:
    """Threads for the per-cell kernels: ``HW4_THREADS`` (default 1). The map is the same bit for
    bit on any number (cells are independent and each cell's sums keep their order)."""
    try:
        return max(1, int(os.environ.get("HW4_THREADS", "1")))
    except ValueError:
        return 1


def cell_evidence(cells, poses, nn, reach, table, cls_hit, n_classes, *, continuous, z_max,
                  w_obstacle, w_beam, sigma0, l, step, sample_count="strict", n_threads=None,
                  stats=None, grid=None) -> np.ndarray:
    """(n_cells, n_classes) evidence, ``beams='nearest'``; see :func:`hw4.core.evidence.count_evidence`.

    nn : (n_cells, k) int64 nearest poses per cell, or None for all poses (pose order).
    reach : (T,) [m] the pose's longest beam plus half an obstacle (discrete) or l (continuous).
    stats : dict, optional; receives ``pairs`` (cell-pose pairs inside the field) and
        ``samples`` (free samples evaluated).
    grid : Grid, optional; with ``nn=None`` the pairs are visited pose by pose (same sums).
    """
    cells = np.ascontiguousarray(cells, dtype=np.float64)
    acc = np.zeros((len(cells), n_classes))
    nn = np.zeros((0, 1), np.int64) if nn is None else np.ascontiguousarray(nn, dtype=np.int64)
    n_off = int(np.ceil(2 * l / step)) + 2
    from .sensor import BINS
    srt = table._sorted.astype(np.int64)
    if continuous:
        bcos, bsin = beam_directions(table, poses)
        bcos, bsin = bcos[srt], bsin[srt]
    else:  # the discrete models use no beam directions
        bcos = bsin = np.zeros(1)
    # per-beam arrays in the sorted order of the bearing index: a pair's nearest beam is read
    # at its sorted position, with no indirection through the beam index
    pposes = np.ascontiguousarray(poses, dtype=np.float64)
    ranges = table.ranges[srt]
    hit = np.ascontiguousarray(cls_hit, dtype=np.int64)[srt]
    seg_start = table._seg_start.astype(np.int64)
    seg_len = table._seg_len.astype(np.int64)
    args = (cells, pposes, nn, np.ascontiguousarray(reach, dtype=np.float64), ranges, hit, srt,
            table._key, seg_start, seg_len, table._bin_lo, table._dense, table._sorted_bearing,
            BINS / TWO_PI, BINS, bool(continuous), float(z_max), float(w_obstacle) / 2,
            float(w_beam) / 2, table.bearing_min, table.bearing_max, float(l), float(step),
            COUNT_KINDS[sample_count], 2.0 * np.pi / l, -1.0 / (3.0 * l), 1.0 / 3.0,
            1.0 / (2.0 * np.pi), float(sigma0), n_off, bcos, bsin)
    n = len(cells)
    nt = min(threads() if n_threads is None else int(n_threads), max(1, n // 256))
    if nn.shape[0]:  # the nearest poses: pose by pose, then the sums cell by cell
        warm(_pose_pass, _kernel_pass)
        pargs = (cells, pposes, nn, ranges, hit, srt, table._key, seg_start, seg_len,
                 table._bin_lo, table._dense, table._sorted_bearing, BINS / TWO_PI, BINS,
                 bool(continuous), float(z_max), float(w_obstacle) / 2, float(w_beam) / 2,
                 table.bearing_min, table.bearing_max, float(l))
        kargs = (cells, pposes, nn, ranges, hit, float(l), float(step),
                 COUNT_KINDS[sample_count], 2.0 * np.pi / l, -1.0 / (3.0 * l), 1.0 / 3.0,
                 1.0 / (2.0 * np.pi), float(sigma0), n_off, bcos, bsin)
        bounds = np.linspace(0, n, nt + 1).astype(int)
        pairs = np.zeros((nt, 3), np.int64)
        run = lambda i: _nn_pass(bounds[i], bounds[i + 1], pargs, kargs, nn, continuous, acc,
                                 pairs[i])
        if nt <= 1:
            run(0)
        else:
            with ThreadPoolExecutor(nt) as ex:
                list(ex.map(run, range(nt)))
        pairs = pairs.sum(axis=0)
    elif grid is not None:
        warm(_poses_kernel)
        ny = len(grid.y)
        nt = min(nt, ny)
        rest = args[3:] + (acc, np.zeros((n, n_classes)) if continuous else np.zeros((1, 1)),
                           np.zeros((n, n_off)) if continuous else np.zeros((1, 1)))
        rows = np.linspace(0, ny, nt + 1).astype(int)
        pairs = np.zeros((nt, 3), np.int64)
        run = lambda i: _poses_kernel(rows[i], rows[i + 1], grid.x, grid.y, args[1], *rest,
                                      pairs[i])
        if nt <= 1:
            run(0)
        else:
            with ThreadPoolExecutor(nt) as ex:
                list(ex.map(run, range(nt)))
        pairs = pairs.sum(axis=0)
    elif nt <= 1:
        warm(_cells_kernel)
        pairs = np.zeros(3, np.int64)
        _cells_kernel(0, n, *args, acc, pairs)
    else:
        warm(_cells_kernel)
        bounds = np.linspace(0, n, nt + 1).astype(int)
        pairs = np.zeros((nt, 3), np.int64)
        with ThreadPoolExecutor(nt) as ex:
            list(ex.map(lambda i: _cells_kernel(bounds[i], bounds[i + 1], *args, acc, pairs[i]),
                        range(nt)))
        pairs = pairs.sum(axis=0)
    if stats is not None:
        stats["pairs"] = stats.get("pairs", 0) + int(pairs[0])
        stats["samples"] = stats.get("samples", 0) + int(pairs[1])
        stats["fast"] = stats.get("fast", 0) + int(pairs[2])
    return acc


@njit(cache=True, nogil=True)
def _all_kernel(poses, first, ranges, bearings, cls_hit, free, gx, gy, g, cell_of_pose_start,
                cell_of_pose, use_sel, z_max, l, step, ka, kb, kc3, kinv2pi, sigma0, acc,
                scratch, touched, state, selected, pairs):  # pragma: no cover - compiled
    """``beams='all'``: pose by pose, end points then free samples (beam order), each against the
    cells within l; the pose's sums go into ``acc`` (flat, cell * K + class) after the pose."""
    n_classes = acc.shape[0] // (gx.shape[0] * gy.shape[0])
    nx = gx.shape[0]
    ny = gy.shape[0]
    R = int(math.ceil(l / g)) + 1
    x0 = gx[0]
    y0 = gy[0]
    n_entries = 0
    for t in range(poses.shape[0]):
        px = poses[t, 0]
        py = poses[t, 1]
        h = poses[t, 2]
        if use_sel:
            for q in range(cell_of_pose_start[t], cell_of_pose_start[t + 1]):
                selected[cell_of_pose[q]] = True
        n_t = 0
        b0 = first[t]
        b1 = first[t + 1]
        for phase in range(2):
            for b in range(b0, b1):
                theta = bearings[b] + h
                c = math.cos(theta)
                s = math.sin(theta)
                z = ranges[b]
                if phase == 0:
                    ns = 1
                else:
                    ns = int(math.ceil(z / step))
                    if (ns - 1) * step >= z:
                        ns -= 1
                    if ns * step < z:
                        ns += 1
                for jj in range(ns):
                    if phase == 0:
                        qx = px + z * c
                        qy = py + z * s
                        cls = cls_hit[b]
                    else:
                        sj = jj * step
                        qx = px + sj * c
                        qy = py + sj * s
                        cls = free
                    ix = int(np.rint((qx - x0) / g))
                    iy = int(np.rint((qy - y0) / g))
                    for cyy in range(max(iy - R, 0), min(iy + R + 1, ny)):
                        ddy = gy[cyy] - qy
                        if abs(ddy) >= l:
                            continue
                        for cxx in range(max(ix - R, 0), min(ix + R + 1, nx)):
                            ddx = gx[cxx] - qx
                            if abs(ddx) >= l:
                                continue
                            d = math.sqrt(ddx ** 2 + ddy ** 2)
                            if not d < l:
                                continue
                            cell = cyy * nx + cxx
                            if use_sel and not selected[cell]:
                                continue
                            st = state[cell]
                            if st == 0:
                                dx = gx[cxx] - px
                                dy = gy[cyy] - py
                                r = math.sqrt(dx ** 2 + dy ** 2)
                                phi = _wrap(math.atan2(dy, dx) - h)
                                st = 1 if (r > 0.0 and r < z_max and phi > -PI and phi < PI) else 2
                                state[cell] = st
                                touched[n_t] = cell
                                n_t += 1
                            if st != 1:
                                continue
                            n_entries += 1
                            scratch[cell * n_classes + cls] += _kernel(d, ka, kb, kc3, kinv2pi,
                                                                       sigma0)
        for q in range(n_t):
            cell = touched[q]
            state[cell] = 0
            for c in range(n_classes):
                acc[cell * n_classes + c] += scratch[cell * n_classes + c]
                scratch[cell * n_classes + c] = 0.0
        if use_sel:
            for q in range(cell_of_pose_start[t], cell_of_pose_start[t + 1]):
                selected[cell_of_pose[q]] = False
    pairs[0] += n_entries


def all_beams_evidence(grid, poses, table, cls_hit, n_classes, nn, *, z_max, sigma0, l, step,
                       stats=None) -> np.ndarray:
    """(n_cells, n_classes) evidence, ``beams='all'`` (one thread; see ``count_evidence``).

    nn : (n_cells, k) int64 nearest poses per cell, or None (every pose within z_max counts).
    """
    n_cells, n_poses = grid.n_cells, len(poses)
    use_sel = nn is not None
    if use_sel:
        flat = nn.reshape(-1)
        order = np.argsort(flat, kind="stable")
        cell_of_pose = (order // nn.shape[1]).astype(np.int64)
        start = np.searchsorted(flat[order], np.arange(n_poses + 1)).astype(np.int64)
    else:
        cell_of_pose = np.zeros(0, np.int64)
        start = np.zeros(n_poses + 1, np.int64)
    acc = np.zeros(n_cells * n_classes)
    pairs = np.zeros(1, np.int64)
    warm(_all_kernel)
    _all_kernel(np.ascontiguousarray(poses, dtype=np.float64), table.first.astype(np.int64),
                table.ranges, table.bearings, np.ascontiguousarray(cls_hit, dtype=np.int64),
                n_classes - 1, grid.x, grid.y, float(grid.grid_size), start, cell_of_pose,
                use_sel, float(z_max), float(l), float(step), 2.0 * np.pi / l, -1.0 / (3.0 * l),
                1.0 / 3.0, 1.0 / (2.0 * np.pi), float(sigma0), acc, np.zeros(n_cells * n_classes),
                np.zeros(n_cells, np.int64), np.zeros(n_cells, np.int8),
                np.zeros(n_cells if use_sel else 1, np.bool_), pairs)
    if stats is not None:
        stats["pairs"] = stats.get("pairs", 0) + int(pairs[0])
    return acc.reshape(n_cells, n_classes)


_announced = False


def _cached(kernel) -> bool:
    """True when numba's cache holds ``kernel`` for this source (index newer than this file)."""
    try:
        index = kernel._cache._cache_file._index_path
        return os.path.exists(index) and os.path.getmtime(index) >= os.path.getmtime(__file__)
    except (AttributeError, OSError):
        return False


def warm(*kernels, announce: bool = True) -> None:
    """Before a kernel's first call in a process: when numba's cache does not hold it (the first
    run after an install or a change), say once on stderr, when it is a terminal, that the
    kernels are being compiled (10-30 s, once). Cheap otherwise (one stat per kernel)."""
    global _announced
    if _announced or not announce or not getattr(sys.stderr, "isatty", lambda: False)():
        return  # said in a terminal only: notebooks and piped runs keep their outputs
    if not all(_cached(k) for k in kernels):
        _announced = True
        print("hw4: compiling the counting kernels (once after an install; 10-30 s) ...",
              file=sys.stderr, flush=True)

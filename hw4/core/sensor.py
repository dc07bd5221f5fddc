"""Laser geometry: polar scans, the perceptual field, and the beam nearest in bearing.

Frames: scans are beam end points in the robot frame [m]; poses are (x, y, heading) in the
world frame [m, m, rad]. Bearings are radians in the robot frame, wrapped to [-pi, pi].
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError

TWO_PI = 2.0 * np.pi
Z_MAX = 30.0           # maximum range of the laser [m]
N_BEAMS = 133          # the template's beam count; w_beam = 2 pi / N_BEAMS [rad]
BINS = 2048            # bearing bins of the nearest-beam lookup table


def wrap_to_pi(a):
    """Wrap angles [rad] to [-pi, pi] exactly as the course template's ``wrapToPI`` does.

    ``np.remainder(a, 2 pi)`` lies in [0, 2 pi); values above pi are shifted down by 2 pi, so
    pi stays pi. Keeping the same floating-point steps keeps the nearest-beam choice identical.
    """
    w = np.remainder(a, TWO_PI)  # in [0, 2 pi): |w| > pi is w > pi, and sign(w) is 1 there
    return np.where(w > np.pi, w - TWO_PI, w)


def polar(scan) -> tuple:
    """Range [m] and bearing [rad] of each beam end point of a (2, N) robot-frame scan."""
    scan = np.asarray(scan, dtype=float)
    return np.sqrt(scan[0] ** 2 + scan[1] ** 2), np.arctan2(scan[1], scan[0])


def relative(cell_xy, pose) -> tuple:
    """Range r [m] and wrapped bearing phi [rad] of cells seen from poses (broadcasting).

    cell_xy : (..., 2) world frame [m]; pose : (..., 3) world frame [m, m, rad].
    """
    dx = cell_xy[..., 0] - pose[..., 0]
    dy = cell_xy[..., 1] - pose[..., 1]
    r = np.sqrt(dx ** 2 + dy ** 2)
    phi = wrap_to_pi(np.arctan2(dy, dx) - pose[..., 2])
    return r, phi


def in_field(r, phi, z_max: float = Z_MAX):
    """Template perceptual field: 0 < r < z_max and -pi < phi < pi (the laser sees all around)."""
    return (r > 0) & (r < z_max) & (phi > -np.pi) & (phi < np.pi)


def _bin(theta):
    """Bearing bin [0, BINS) of angles theta [rad] in [-pi, pi]; monotone in theta."""
    return np.clip(np.floor((theta + np.pi) * (BINS / TWO_PI)).astype(np.int64), 0, BINS - 1)


@dataclass
class BeamTable:
    """All beams of all scans as flat arrays, with a per-pose bearing index for nearest-beam lookups.

    Attributes
    ----------
    ranges, bearings : (B,) float [m], [rad], robot frame
    labels : (B,) int, semantic label 1..6 (0 when the scans carry none)
    pose_of : (B,) int, index of the pose that took the beam
    first : (T + 1,) int, beams of pose t are ``first[t]:first[t + 1]``
    """
    ranges: np.ndarray
    bearings: np.ndarray
    labels: np.ndarray
    pose_of: np.ndarray
    first: np.ndarray

    @classmethod
    def from_scans(cls, scans, compiled: bool = False) -> "BeamTable":
        """The table of a list of T scans (2, N) or (3, N) [m], robot frame (finite end points,
        else :class:`hw4.core.errors.InputError`). ``compiled``: build
        the per-pose bin table with :func:`hw4.core.compiled.bin_table` (the same arrays, one
        pass instead of five numpy passes over its T x BINS entries)."""
        shapes = [np.shape(s) for s in scans]
        counts = np.array([sh[1] for sh in shapes])
        first = np.concatenate([[0], np.cumsum(counts)])
        rows = {sh[0] for sh in shapes}
        if len(rows) == 1 and all(type(s) is np.ndarray and s.dtype == np.float64 for s in scans):
            every = np.concatenate(scans, axis=1)  # one copy of all scans (the same values)
            xy = every[:2]
            labels = every[2].astype(np.int64) if every.shape[0] >= 3 else None
        else:
            xy = np.concatenate([np.asarray(s, dtype=float)[:2] for s in scans], axis=1)
            labels = (np.concatenate([np.asarray(s)[2] for s in scans]).astype(np.int64)
                      if all(sh[0] >= 3 for sh in shapes) else None)
        if not np.isfinite(xy).all():
            raise InputError("scans must hold finite end points [m] (no NaN or inf); "
                             "drop beams without a return before counting.")
        ranges, bearings = polar(xy)
        if labels is None:
            labels = np.zeros(len(ranges), dtype=np.int64)
        pose_of = np.repeat(np.arange(len(scans)), counts)
        table = cls(ranges, bearings, labels, pose_of, first)
        table._index(compiled)
        return table

    def _index(self, compiled: bool = False):
        # Per pose, the distinct bearings in ascending order, each represented by the smallest
        # beam index that has it (np.nanargmin returns the first of equal minima).
        key = self.pose_of * 8.0 + self.bearings  # bearings lie in (-4, 4): pose blocks are disjoint
        order = self._order()
        same_order = self._identity  # scans already in bearing order: no gathers needed
        pose_o = self.pose_of if same_order else self.pose_of[order]
        bear_o = self.bearings if same_order else self.bearings[order]
        keep = np.ones(len(order), dtype=bool)
        keep[1:] = (pose_o[1:] != pose_o[:-1]) | (bear_o[1:] != bear_o[:-1])
        if keep.all():
            self._sorted = order
            self._key = key if same_order else key[order]
            pose_s, bear_s = pose_o, bear_o
        else:
            self._sorted = order[keep]
            self._key = key[self._sorted]
            pose_s, bear_s = self.pose_of[self._sorted], self.bearings[self._sorted]
        seg = np.searchsorted(pose_s, np.arange(len(self.first)))
        self._seg_start, self._seg_len = seg[:-1], np.diff(seg)
        # Bin table. With bin(theta) = floor((theta + pi) B / 2 pi), monotone in theta, a bearing
        # in a lower bin than phi lies below phi and one in a higher bin above it. Where every
        # bin of a pose holds at most one bearing, the number of bearings below phi is
        # L = (bearings in lower bins) plus one if the next sorted bearing is below phi: exact.
        # Poses with two bearings in one bin use binary search instead.
        n_poses = len(self.first) - 1
        self._bin_table = None
        if compiled:
            from .compiled import bin_table
            self._bin_table, self._dense = bin_table(bear_s, self._seg_start, self._seg_len, BINS)
        else:  # the table itself only when asked for (_bin_lo): lookups search the bin keys
            self._bin_key = pose_s * BINS + _bin(bear_s)  # ascending
            same = np.zeros(n_poses, dtype=bool)
            two = self._bin_key[1:] == self._bin_key[:-1]  # two bearings of one pose in one bin
            same[pose_s[1:][two]] = True
            self._dense = same
        self._sorted_bearing = np.append(bear_s, np.inf)
        if np.all(self._seg_len > 0):  # a pose's sorted bearings: its smallest first, largest last
            self.bearing_min = self._sorted_bearing[self._seg_start]
            self.bearing_max = self._sorted_bearing[self._seg_start + self._seg_len - 1]
        else:
            self.bearing_min = np.full(n_poses, np.inf)
            self.bearing_max = np.full(n_poses, -np.inf)
            np.minimum.at(self.bearing_min, self.pose_of, self.bearings)
            np.maximum.at(self.bearing_max, self.pose_of, self.bearings)

    @property
    def _bin_lo(self) -> np.ndarray:
        """(T, BINS) int32: per pose and bearing bin, the pose's sorted bearings in lower bins."""
        if self._bin_table is None:
            self._bin_table, _ = self._bins(len(self.first) - 1)
        return self._bin_table

    def _lower(self, pose_idx, b) -> np.ndarray:
        """``_bin_lo[pose_idx, b]``, from the table when built, else by searching the bin keys
        (the count of the pose's sorted bearings with a key below ``pose * BINS + b``)."""
        if self._bin_table is not None:
            return self._bin_lo[pose_idx, b]
        return np.searchsorted(self._bin_key, pose_idx * BINS + b) - self._seg_start[pose_idx]

    def _bins(self, n_poses: int) -> tuple:
        """(T, BINS) int32 bearings of the pose in lower bins, and (T,) bool: a bin holds two."""
        pose_s = self.pose_of[self._sorted]
        count = np.bincount(pose_s * BINS + _bin(self.bearings[self._sorted]),
                            minlength=n_poses * BINS).astype(np.int32)
        # bearings of the pose in lower bins: the running count over all poses' bins (one flat
        # pass), less the bin's own count and the bearings of the poses before
        below = np.cumsum(count, dtype=np.int32)
        below -= count
        count = count.reshape(n_poses, BINS)
        below = below.reshape(n_poses, BINS)
        below -= self._seg_start.astype(np.int32)[:, None]
        return below, count.max(axis=1, initial=0) > 1

    def _order(self) -> np.ndarray:
        """Beam indices sorted by (pose, bearing, index): ``np.lexsort`` of the three, taken scan
        by scan (scans are contiguous blocks), and skipped for scans already in bearing order
        (a laser's usually are: the order is then the identity, and ``_identity`` says so)."""
        b = self.bearings
        n = len(b)
        up = np.ones(n, dtype=bool)
        up[1:] = b[1:] >= b[:-1]
        up[self.first[:-1][self.first[:-1] < n]] = True  # a scan's first beam starts its block
        self._identity = bool(up.all())  # (read by _index)
        if self._identity:
            return np.arange(n)
        order = np.arange(n)
        for t in np.unique(self.pose_of[~up]):
            a, e = self.first[t], self.first[t + 1]
            order[a:e] = a + np.argsort(b[a:e], kind="stable")
        return order

    def nearest(self, pose_idx, phi, return_diff: bool = False):
        """Global index of the beam of pose ``pose_idx`` nearest in bearing to ``phi`` [rad].

        Same choice as the template's ``nanargmin(|wrapToPI(theta - phi)|)``: the candidates are
        the sorted neighbours around phi (cyclically), compared with the same wrapped difference,
        ties going to the smaller beam index. With ``return_diff`` also returns that wrapped
        bearing difference |wrapToPI(theta_k - phi)| [rad].
        """
        pose_idx = np.asarray(pose_idx)
        phi = np.asarray(phi, dtype=float)
        dense = self._dense[pose_idx]
        if dense.any():
            out = np.empty(len(pose_idx), dtype=np.int64)
            diff = np.empty(len(pose_idx))
            out[dense], diff[dense] = self._nearest(pose_idx[dense], phi[dense], exact=True)
            out[~dense], diff[~dense] = self._nearest(pose_idx[~dense], phi[~dense], exact=False)
        else:
            out, diff = self._nearest(pose_idx, phi, exact=False)
        return (out, diff) if return_diff else out

    def _nearest(self, pose_idx, phi, exact):
        start, n = self._seg_start[pose_idx], self._seg_len[pose_idx]
        if exact:  # binary search; the float key may be off by one near a bearing: 4 candidates
            pos = np.searchsorted(self._key, pose_idx * 8.0 + phi) - start
            offsets = (-2, -1, 0, 1)
        else:  # exact position from the bin table: its two neighbours are the candidates
            pos = self._lower(pose_idx, _bin(phi))
            nxt = np.minimum(pos, n - 1)
            pos = pos + ((pos < n) & (self._sorted_bearing[start + nxt] < phi))
            offsets = (-1, 0)
        best = best_d = None
        for off in offsets:
            cand = self._sorted[start + np.mod(pos + off, n)]
            d = np.abs(wrap_to_pi(self.bearings[cand] - phi))
            if best is None:
                best, best_d = cand, d
            else:
                better = (d < best_d) | ((d == best_d) & (cand < best))
                best = np.where(better, cand, best)
                best_d = np.where(better, d, best_d)
        return best, best_d

    def may_reach(self, pose_idx, phi, half_width) -> np.ndarray:
        """False where no beam of the pose lies within ``half_width`` [rad] of bearing ``phi``.

        A conservative pre-filter (true where unsure): a pose whose beams span [b_min, b_max]
        without wrapping cannot have a beam within half_width of phi outside
        [b_min - half_width, b_max + half_width].
        """
        lo = self.bearing_min[pose_idx] - half_width
        hi = self.bearing_max[pose_idx] + half_width
        wraps = (lo <= -np.pi + 1e-9) | (hi >= np.pi - 1e-9)
        return wraps | ((phi >= lo - 1e-9) & (phi <= hi + 1e-9))

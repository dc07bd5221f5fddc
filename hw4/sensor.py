"""Laser geometry: polar scans, the perceptual field, and the beam nearest in bearing.

Frames: scans are beam end points in the robot frame [m]; poses are (x, y, heading) in the
world frame [m, m, rad]. Bearings are radians in the robot frame, wrapped to [-pi, pi].
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TWO_PI = 2.0 * np.pi
Z_MAX = 30.0           # maximum range of the laser [m]
N_BEAMS = 133          # the template's beam count; w_beam = 2 pi / N_BEAMS [rad]


def wrap_to_pi(a):
    """Wrap angles [rad] to [-pi, pi] exactly as the course template's ``wrapToPI`` does.

    ``np.remainder(a, 2 pi)`` lies in [0, 2 pi); values above pi are shifted down by 2 pi, so
    pi stays pi. Keeping the same floating-point steps keeps the nearest-beam choice identical.
    """
    w = np.remainder(a, TWO_PI)
    return np.where(np.abs(w) > np.pi, w - TWO_PI * np.sign(w), w)


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
    def from_scans(cls, scans) -> "BeamTable":
        counts = np.array([np.shape(s)[1] for s in scans])
        first = np.concatenate([[0], np.cumsum(counts)])
        xy = np.concatenate([np.asarray(s, dtype=float)[:2] for s in scans], axis=1)
        ranges, bearings = polar(xy)
        if all(np.shape(s)[0] >= 3 for s in scans):
            labels = np.concatenate([np.asarray(s)[2] for s in scans]).astype(np.int64)
        else:
            labels = np.zeros(len(ranges), dtype=np.int64)
        pose_of = np.repeat(np.arange(len(scans)), counts)
        table = cls(ranges, bearings, labels, pose_of, first)
        table._index()
        return table

    def _index(self):
        # Per pose, the distinct bearings in ascending order, each represented by the smallest
        # beam index that has it (np.nanargmin returns the first of equal minima).
        key = self.pose_of * 8.0 + self.bearings  # bearings lie in (-4, 4): pose blocks are disjoint
        order = np.lexsort((np.arange(len(key)), self.bearings, self.pose_of))
        keep = np.ones(len(order), dtype=bool)
        keep[1:] = (self.pose_of[order][1:] != self.pose_of[order][:-1]) | (
            self.bearings[order][1:] != self.bearings[order][:-1])
        self._sorted = order[keep]
        self._key = key[self._sorted]
        seg = np.searchsorted(self.pose_of[self._sorted], np.arange(len(self.first)))
        self._seg_start, self._seg_len = seg[:-1], np.diff(seg)

    def nearest(self, pose_idx, phi) -> np.ndarray:
        """Global index of the beam of pose ``pose_idx`` nearest in bearing to ``phi`` [rad].

        Same choice as the template's ``nanargmin(|wrapToPI(theta - phi)|)``: the candidates are
        the sorted neighbours around phi (cyclically), compared with the same wrapped difference,
        ties going to the smaller beam index.
        """
        pose_idx = np.asarray(pose_idx)
        start, n = self._seg_start[pose_idx], self._seg_len[pose_idx]
        pos = np.searchsorted(self._key, pose_idx * 8.0 + phi) - start
        best = best_d = None
        for off in (-2, -1, 0, 1):
            cand = self._sorted[start + np.mod(pos + off, n)]
            d = np.abs(wrap_to_pi(self.bearings[cand] - phi))
            if best is None:
                best, best_d = cand, d
            else:
                better = (d < best_d) | ((d == best_d) & (cand < best))
                best = np.where(better, cand, best)
                best_d = np.where(better, d, best_d)
        return best

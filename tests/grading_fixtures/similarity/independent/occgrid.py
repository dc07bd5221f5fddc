"""An independent solution written for the similarity tests: every (cell, pose) pair at once.

Not derived from ../../exact: the pairs of all cells with their 16 nearest poses are built in
one KD-tree query and the sensor models are evaluated pair by pair in numpy arrays.
"""
import numpy as np
from scipy.spatial import KDTree

from utils import wrapToPI


class Base:
    kind = "discrete"
    labelled = False

    def __init__(self):
        self.range_x, self.range_y = [-15, 20], [-25, 10]
        self.z_max, self.n_beams, self.nn = 30, 133, 16
        self.grid_size = 0.135
        self.w_obstacle = 2 * self.grid_size
        self.w_beam = 2 * np.pi / self.n_beams
        self.l, self.sigma = 0.2, 0.1
        self.prior = self.prior_alpha = 0.001
        self.num_classes = 6
        self.map, self.pose = {}, {}

    def construct_map(self, pose, scan):
        gx = np.arange(self.range_x[0], self.range_x[1] + self.grid_size, self.grid_size)
        gy = np.arange(self.range_y[0], self.range_y[1] + self.grid_size, self.grid_size)
        GX, GY = np.meshgrid(gx, gy)
        self.centres = np.column_stack([GX.ravel(), GY.ravel()])
        self.map['occMap'] = KDTree(self.centres)
        self.map['size'] = len(self.centres)
        self.P = np.column_stack([pose['x'][0][0][:, 0], pose['y'][0][0][:, 0], pose['h'][0][0][:, 0]])
        self.beams = [scan[t][0] for t in range(len(self.P))]

    def weight(self, dist):
        q = dist / self.l
        w = self.sigma * ((2 + np.cos(2 * np.pi * q)) / 3 * (1 - q) + np.sin(2 * np.pi * q) / (2 * np.pi))
        return np.where(dist < self.l, w, 0.0)

    def build_ogm(self):
        ncol = self.num_classes + 1 if self.labelled else 2
        counts = np.zeros((self.map['size'], ncol))
        _, near = KDTree(self.P[:, :2]).query(self.centres, self.nn)
        for t in range(len(self.P)):
            cells = np.nonzero((near == t).any(axis=1))[0]
            if len(cells):
                self.update(counts, cells, t)
        total = counts + self.prior_alpha
        if self.labelled:
            s = total.sum(axis=1)
            self.map['mean'] = total / s[:, None]
            top = self.map['mean'].max(axis=1)
            self.map['variance'] = (top * (1 - top) / (s + 1))[:, None]
        else:
            a, b = total[:, 0], total[:, 1]
            self.map['mean'] = (a / (a + b))[:, None]
            self.map['variance'] = (a * b / ((a + b) ** 2 * (a + b + 1)))[:, None]

    def update(self, counts, cells, t):
        px, py, ph = self.P[t]
        raw = self.beams[t]
        rng = np.sqrt(raw[0] ** 2 + raw[1] ** 2)
        ang = np.arctan2(raw[1], raw[0])
        cls = raw[2].astype(int) - 1 if self.labelled else np.zeros(len(rng), dtype=int)
        dx, dy = self.centres[cells, 0] - px, self.centres[cells, 1] - py
        dist = np.sqrt(dx ** 2 + dy ** 2)
        rel = wrapToPI(np.arctan2(dy, dx) - ph)
        ok = (dist > 0) & (dist < self.z_max) & (rel > -np.pi) & (rel < np.pi)
        cells, dist, rel = cells[ok], dist[ok], rel[ok]
        gaps = np.abs(wrapToPI(ang[None, :] - rel[:, None]))
        j = np.nanargmin(gaps, axis=1)
        free = counts.shape[1] - 1
        if self.kind == "discrete":
            z, gap = rng[j], gaps[np.arange(len(j)), j]
            inside = (dist <= np.minimum(self.z_max, z + self.w_obstacle / 2)) & (gap <= self.w_beam / 2)
            occ = inside & (z < self.z_max) & (np.abs(dist - z) < self.w_obstacle / 2)
            emp = inside & ~occ & (dist < z) & (z < self.z_max)
            np.add.at(counts, (cells[occ], cls[j[occ]]), 1)
            np.add.at(counts, (cells[emp], free), 1)
            return
        z, th = rng[j], ang[j] + ph
        mx, my = self.centres[cells, 0], self.centres[cells, 1]
        d1 = np.sqrt((mx - (px + z * np.cos(th))) ** 2 + (my - (py + z * np.sin(th))) ** 2)
        np.add.at(counts, (cells, cls[j]), self.weight(d1))
        top = int(np.ceil(z.max() / 0.1)) + 1
        for n in range(top):
            s = n * 0.1
            live = s < z
            if not live.any():
                break
            d2 = np.sqrt((mx[live] - (px + s * np.cos(th[live]))) ** 2
                         + (my[live] - (py + s * np.sin(th[live]))) ** 2)
            np.add.at(counts, (cells[live], free), self.weight(d2))

import numpy as np
from scipy.spatial import KDTree

from utils import cart2pol, wrapToPI


def finish(m, labelled):
    acc = m.map['alpha']
    if labelled:
        tot = acc.sum(axis=1, keepdims=True)
        m.map['mean'] = acc / tot
        best = m.map['mean'].max(axis=1, keepdims=True)
        m.map['variance'] = best * (1 - best) / (tot + 1)
    else:
        occ, emp = acc[:, 0:1], acc[:, 1:2]
        m.map['alpha'], m.map['beta'] = occ, emp
        m.map['mean'] = occ / (occ + emp)
        m.map['variance'] = occ * emp / ((occ + emp) ** 2 * (occ + emp + 1))


def kernel_sum(m, labelled, spacing=0.1):
    last = m.map['alpha'].shape[1] - 1
    pts = m.map['occMap'].data
    for c, q, dist, bearing in pairs(m):
        zs, bs, tags = m.polar[q]
        b = np.nanargmin(np.abs(wrapToPI(bs - bearing)))
        qx, qy, qh = m.pose['x'][q][0], m.pose['y'][q][0], m.pose['h'][q][0]
        zz, ang = zs[b], bs[b] + qh
        cx, cy = pts[c, 0], pts[c, 1]
        e1 = np.sqrt((cx - (qx + zz * np.cos(ang))) ** 2 + (cy - (qy + zz * np.sin(ang))) ** 2)
        if e1 < m.l:
            m.map['alpha'][c, tags[b] - 1 if labelled else 0] += weight(e1, m.sigma, m.l)
        cnt = int(np.ceil(zz / spacing)) + 1
        along = np.arange(cnt) * spacing
        along = along[along < zz]
        e2 = np.sqrt((cx - (qx + along * np.cos(ang))) ** 2 + (cy - (qy + along * np.sin(ang))) ** 2)
        e2 = e2[e2 < m.l]
        m.map['alpha'][c, last] += weight(e2, m.sigma, m.l).sum()


def weight(e, s0, ell):
    return s0 * ((2 + np.cos(2 * np.pi * e / ell)) / 3 * (1 - e / ell)
                 + np.sin(2 * np.pi * e / ell) / (2 * np.pi))


def pairs(m):
    pts = m.map['occMap'].data
    c = 0
    while c < m.map['size']:
        here = pts[c, :]
        _, near = m.pose['mdl'].query(here, m.nn)
        near = np.atleast_1d(near)
        n = 0
        while n < len(near):
            q = near[n]
            n += 1
            qx, qy, qh = m.pose['x'][q][0], m.pose['y'][q][0], m.pose['h'][q][0]
            dist = np.sqrt((here[0] - qx) ** 2 + (here[1] - qy) ** 2)
            bearing = wrapToPI(np.arctan2(here[1] - qy, here[0] - qx) - qh)
            if 0 < dist < m.z_max and -np.pi < bearing < np.pi:
                yield c, q, dist, bearing
        c += 1


def counting(m, labelled):
    last = m.map['alpha'].shape[1] - 1
    for c, q, dist, bearing in pairs(m):
        zs, bs, tags = m.polar[q]
        off = np.abs(wrapToPI(bs - bearing))
        b = np.nanargmin(off)
        zz = zs[b]
        if dist > min(m.z_max, zz + m.w_obstacle / 2) or off[b] > m.w_beam / 2:
            continue
        if zz < m.z_max and abs(dist - zz) < m.w_obstacle / 2:
            m.map['alpha'][c, tags[b] - 1 if labelled else 0] += 1
        elif dist < zz and zz < m.z_max:
            m.map['alpha'][c, last] += 1


def prepare(m, pose, scan, width):
    xs = np.arange(m.range_x[0], m.range_x[1] + m.grid_size, m.grid_size)
    ys = np.arange(m.range_y[0], m.range_y[1] + m.grid_size, m.grid_size)
    XX, YY = np.meshgrid(xs, ys)
    grid = np.hstack((XX.reshape(-1, 1), YY.reshape(-1, 1)))
    m.map['occMap'] = KDTree(grid)
    m.map['size'] = grid.shape[0]
    m.pose['x'] = pose['x'][0][0]
    m.pose['y'] = pose['y'][0][0]
    m.pose['h'] = pose['h'][0][0]
    m.pose['mdl'] = KDTree(np.hstack((m.pose['x'], m.pose['y'])))
    m.scan = scan
    m.polar = []
    for q in range(len(m.pose['x'])):
        raw = scan[q][0]
        zb = cart2pol(raw[0, :], raw[1, :])
        tags = raw[2, :].astype(int) if raw.shape[0] > 2 else np.zeros(raw.shape[1], dtype=int)
        m.polar.append((zb[:, 0], zb[:, 1], tags))
    m.map['alpha'] = np.full((m.map['size'], width), float(m.prior_alpha))


class Params:
    labelled = False

    def __init__(self):
        self.range_x = [-15, 20]
        self.range_y = [-25, 10]
        self.z_max = 30
        self.n_beams = 133
        self.grid_size = 0.135
        self.w_obstacle = 2 * self.grid_size
        self.w_beam = 2 * np.pi / self.n_beams
        self.nn = 16
        self.map = {}
        self.pose = {}
        self.scan = []
        self.m_i = {}
        self.l = 0.2
        self.sigma = 0.1
        self.num_classes = 6
        self.prior = 0.001
        self.prior_alpha = 0.001

    def construct_map(self, pose, scan):
        prepare(self, pose, scan, self.num_classes + 1 if self.labelled else 2)

"""Loop-by-loop transcription of the S-BKI and S-CSM map update, written for clarity, not speed.

It follows the method's statement directly: for every training point, visit every voxel in a box
around it, measure the distance from the point to the voxel centre, and add the sparse kernel to
the evidence of the point's class. The tests compare :class:`hw4.bki.voxelmap.VoxelMap` with it.
"""
from __future__ import annotations

import math


def sparse_kernel(d: float, sf2: float, ell: float) -> float:
    """k(d) = sf2 [(2 + cos(2 pi d / ell)) (1 - d / ell) / 3 + sin(2 pi d / ell) / (2 pi)], d < ell."""
    if d >= ell:
        return 0.0
    k = sf2 * ((2.0 + math.cos(2.0 * math.pi * d / ell)) * (1.0 - d / ell) / 3.0
               + math.sin(2.0 * math.pi * d / ell) / (2.0 * math.pi))
    return max(k, 0.0)  # rounding just below ell can give -1e-17


def literal_update(evidence: dict, counts: dict, points, labels, resolution: float,
                   num_class: int, method: str, sf2: float = 10.0, ell: float = 0.3) -> None:
    """Add the evidence of one scan's training points to ``evidence`` (voxel -> list of K floats).

    ``counts`` (voxel -> int) records how many training points reached each voxel.
    """
    for p, c in zip(points, labels):
        x, y, z = float(p[0]), float(p[1]), float(p[2])
        c = int(c)
        if method == "scsm":
            key = (math.floor(x / resolution), math.floor(y / resolution), math.floor(z / resolution))
            evidence.setdefault(key, [0.0] * num_class)[c] += 1.0
            counts[key] = counts.get(key, 0) + 1
            continue
        # every voxel whose centre could be within ell, with one voxel to spare on each side
        lo = [math.floor((v - ell) / resolution) - 1 for v in (x, y, z)]
        hi = [math.floor((v + ell) / resolution) + 1 for v in (x, y, z)]
        for i in range(lo[0], hi[0] + 1):
            for j in range(lo[1], hi[1] + 1):
                for k in range(lo[2], hi[2] + 1):
                    dx = x - (i + 0.5) * resolution
                    dy = y - (j + 0.5) * resolution
                    dz = z - (k + 0.5) * resolution
                    d = math.sqrt(dx * dx + dy * dy + dz * dz)
                    if d < ell:
                        key = (i, j, k)
                        evidence.setdefault(key, [0.0] * num_class)[c] += sparse_kernel(d, sf2, ell)
                        counts[key] = counts.get(key, 0) + 1


def literal_posterior(e: list, prior: float, var_thresh: float):
    """(probabilities, most likely class, its variance, state) of one voxel with evidence ``e``."""
    alpha = [prior + v for v in e]
    total = sum(alpha)
    probs = [a / total for a in alpha]
    best = 0
    for k in range(1, len(alpha)):
        if alpha[k] > alpha[best]:
            best = k
    p = probs[best]
    var = p * (1 - p) / (total + 1)
    state = "unknown" if var > var_thresh else ("free" if best == 0 else "occupied")
    return probs, best, var, state

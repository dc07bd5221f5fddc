"""Small computations behind the design-choice figures: the evidence one beam leaves along its line.

Algorithm 2 turns a beam of range ``z`` into occupied evidence around its end point and free
evidence around free sample points ``x_l`` along it. The handout leaves three choices open: the
spacing of the samples, whether a cell counts every sample within ``l`` or only the closest one,
and whether a sample sits at the end point. The package takes samples at ``s = 0, step, 2 step,
...`` strictly short of the end point (``step = 0.1`` m = l/2) and counts every one of them;
:func:`beam_profile` evaluates the evidence a point receives from one beam under any of the
choices, so that the book can show what the others give.

Distances are metres along the beam (``s``, from the robot) and across it (``offset``).
"""
from __future__ import annotations

import numpy as np

from ..core.evidence import SAMPLE_STEP, n_samples
from ..core.kernel import LENGTH, SIGMA0, sparse_kernel


def free_samples(z: float, step: float = SAMPLE_STEP, end_sample: bool = False) -> np.ndarray:
    """Distances [m] of the free samples along a beam of range ``z`` [m].

    ``s = 0, step, 2 step, ...`` strictly short of ``z``, exactly as :mod:`hw4.core.evidence` places
    them; with ``end_sample`` one more sample at ``s = z`` itself.
    """
    n = int(n_samples(np.asarray([float(z)]), step)[0])
    s = np.arange(n) * step
    return np.append(s, float(z)) if end_sample else s


def beam_profile(s, z: float, step: float = SAMPLE_STEP, offset: float = 0.0,
                 closest_only: bool = False, end_sample: bool = False,
                 sigma0: float = SIGMA0, l: float = LENGTH) -> tuple:
    """Occupied and free evidence that points near one beam receive from it (Algorithm 2).

    Parameters
    ----------
    s : array_like [m]
        Positions along the beam, measured from the robot.
    z : float [m]
        Range of the beam (its end point is at ``s = z``).
    step : float [m]
        Spacing of the free samples.
    offset : float [m]
        Distance of the points from the beam's line (0: on the beam).
    closest_only : bool
        Count only the free sample closest to each point instead of every sample within l.
    end_sample : bool
        Also place a free sample at the end point.
    sigma0, l : float
        Sparse kernel scale and length scale [m].

    Returns
    -------
    alpha, beta : arrays shaped like ``s``: kernel-weighted occupied and free evidence.
    """
    s = np.asarray(s, dtype=float)
    alpha = sparse_kernel(np.hypot(s - z, offset), sigma0, l)
    d = np.hypot(s[..., None] - free_samples(z, step, end_sample), offset)
    k = sparse_kernel(d, sigma0, l)
    if closest_only:
        nearest = np.argmin(d, axis=-1)
        beta = np.take_along_axis(k, nearest[..., None], axis=-1)[..., 0]
    else:
        beta = k.sum(axis=-1)
    return alpha, beta


def uncovered_share(z: float, step: float, l: float = LENGTH, n: int = 20001) -> float:
    """Share of the beam's length [0, z) farther than ``l`` from every free sample.

    Points there get no free evidence from the beam. Between samples this happens only when
    ``step > 2 l``; a stretch just short of the end point is also bare when ``step > l`` (the
    end point's occupied evidence covers it).
    """
    s = np.linspace(0.0, z, n, endpoint=False)
    d = np.abs(s[:, None] - free_samples(z, step)[None, :]).min(axis=1)
    return float((d >= l).mean())

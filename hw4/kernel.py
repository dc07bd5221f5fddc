"""The sparse kernel of Melkumyan and Ramos (2009), as used by the continuous CSMs and BKI.

.. math::
    k(d) = \\sigma_0\\Big[\\tfrac13\\big(2+\\cos\\tfrac{2\\pi d}{l}\\big)\\big(1-\\tfrac{d}{l}\\big)
           + \\tfrac{1}{2\\pi}\\sin\\tfrac{2\\pi d}{l}\\Big] \\text{ for } d < l, \\quad 0 \\text{ otherwise.}

It is exactly zero beyond the length scale ``l``, so a cell only gathers evidence from points
within ``l`` of its centre; ``k(0) = sigma0`` and ``k`` decreases smoothly to ``k(l) = 0``.
"""
from __future__ import annotations

import numpy as np

SIGMA0 = 0.1  # kernel scale sigma_0 of the homework [evidence count per point]
LENGTH = 0.2  # kernel length scale l of the homework [m]


def sparse_kernel(d, sigma0: float = SIGMA0, l: float = LENGTH):
    """Evaluate the sparse kernel.

    Parameters
    ----------
    d : array_like [m]
        Non-negative Euclidean distances between a cell centre and a point (world frame).
    sigma0 : float
        Kernel scale (value at d = 0).
    l : float [m]
        Length scale; the kernel is zero for d >= l.

    Returns
    -------
    ndarray, same shape as ``d``: kernel weights (0 where d >= l).
    """
    d = np.asarray(d, dtype=float)
    inside = d < l
    k = np.zeros(d.shape)
    k[inside] = sparse_kernel_inside(d[inside], sigma0, l)
    return k


def sparse_kernel_inside(d: np.ndarray, sigma0: float = SIGMA0, l: float = LENGTH) -> np.ndarray:
    """The sparse kernel for distances already known to be below ``l``, overwriting ``d``.

    The fast path for large batches (3D BKI): no mask, few temporaries. Just below ``l`` the
    kernel is of order (1 - d/l)^3 and rounding can make it about -1e-17; it is clamped at 0 so
    that evidence never decreases.

    Parameters
    ----------
    d : (P,) float array [m], all < l; overwritten (pass a copy to keep it)
    """
    t = np.multiply(d, 2.0 * np.pi / l)
    c = np.cos(t)
    c += 2.0
    np.multiply(d, -1.0 / (3.0 * l), out=d)
    d += 1.0 / 3.0
    c *= d
    np.sin(t, out=t)
    t *= 1.0 / (2.0 * np.pi)
    c += t
    c *= sigma0
    np.maximum(c, 0.0, out=c)
    return c

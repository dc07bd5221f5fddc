"""Posterior summaries of the Beta (binary) and Dirichlet (semantic) cell models.

Inputs are concentration parameters, prior included: ``alpha`` (n, 1) and ``beta`` (n, 1) for the
Beta model (Eq. 3), or ``alpha`` (n, K) for the Dirichlet model with free space last (Eq. 10).
"""
from __future__ import annotations

import numpy as np

COLUMN_CHAIN = 8  # up to this many columns the row sums and maxima are taken column by column


def beta_mean_variance(alpha, beta) -> tuple:
    """Mean alpha/(alpha+beta) and variance alpha beta / ((alpha+beta)^2 (alpha+beta+1)) (Eq. 3)."""
    s = alpha + beta
    return alpha / s, alpha * beta / (s ** 2 * (s + 1))


def _row_sum(alpha):
    """``alpha.sum(axis=1, keepdims=True)``. For fewer than ``COLUMN_CHAIN`` columns numpy adds a
    row's entries one after the other from the first; so does the chain of column additions
    here, the same sums bit for bit (tests/test_core_speedpaths.py), in a third of the time of
    the row reduction (its inner loop of K < 8 entries is slow). float64 only: for other dtypes
    numpy's sum promotes (bool and small ints to int64) and is used as it is."""
    k = alpha.shape[1]
    if not 1 <= k < COLUMN_CHAIN or alpha.dtype != np.float64:   # (other dtypes: numpy's promotion)
        return alpha.sum(axis=1, keepdims=True)
    s = alpha[:, 0].copy()
    for j in range(1, k):
        s += alpha[:, j]
    return s[:, None]


def _row_max(values):
    """``values.max(axis=1, keepdims=True)`` by a chain of ``np.maximum`` over the columns (the
    same values, NaN propagated alike; 9x faster than the row reduction for K = 7)."""
    k = values.shape[1]
    if not 1 <= k <= COLUMN_CHAIN:
        return values.max(axis=1, keepdims=True)
    p = values[:, 0].copy()
    for j in range(1, k):
        np.maximum(p, values[:, j], out=p)
    return p[:, None]


def dirichlet_mean_variance(alpha) -> tuple:
    """Class means alpha_k / sum alpha (n, K) and the variance of the most likely class (n, 1) (Eq. 10).

    The variance is p (1 - p) / (sum alpha + 1) with p the largest mean of the cell.
    """
    alpha = np.asarray(alpha)
    s = _row_sum(alpha)
    mean = alpha / s
    p = _row_max(mean)
    return mean, p * (1 - p) / (s + 1)


def most_likely_class(alpha) -> np.ndarray:
    """Index of the largest concentration per cell (first on ties); free space is the last index."""
    return np.argmax(alpha, axis=1)

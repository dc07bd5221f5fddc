"""Posterior summaries of the Beta (binary) and Dirichlet (semantic) cell models.

Inputs are concentration parameters, prior included: ``alpha`` (n, 1) and ``beta`` (n, 1) for the
Beta model (Eq. 3), or ``alpha`` (n, K) for the Dirichlet model with free space last (Eq. 10).
"""
from __future__ import annotations

import numpy as np


def beta_mean_variance(alpha, beta) -> tuple:
    """Mean alpha/(alpha+beta) and variance alpha beta / ((alpha+beta)^2 (alpha+beta+1)) (Eq. 3)."""
    s = alpha + beta
    return alpha / s, alpha * beta / (s ** 2 * (s + 1))


def dirichlet_mean_variance(alpha) -> tuple:
    """Class means alpha_k / sum alpha (n, K) and the variance of the most likely class (n, 1) (Eq. 10).

    The variance is p (1 - p) / (sum alpha + 1) with p the largest mean of the cell.
    """
    s = alpha.sum(axis=1, keepdims=True)
    mean = alpha / s
    p = mean.max(axis=1, keepdims=True)
    return mean, p * (1 - p) / (s + 1)


def most_likely_class(alpha) -> np.ndarray:
    """Index of the largest concentration per cell (first on ties); free space is the last index."""
    return np.argmax(alpha, axis=1)

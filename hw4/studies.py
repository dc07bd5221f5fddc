"""Parameter studies on held-out data: kernel length scale and scale, and template vs fuller options.

Both studies build maps from the mapping scans of :func:`hw4.evaluate.intel_split` and score them
with :func:`hw4.evaluate.score_map`, so their numbers are comparable with the evaluation table.
"""
from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np

from . import evaluate as ev
from .grid import Grid
from .kernel import SIGMA0
from .posterior import beta_mean_variance, dirichlet_mean_variance
from .template import PRIOR

LENGTHS = (0.1, 0.2, 0.3, 0.5)  # kernel length scales l of the study [m]
SIGMAS = (0.01, 0.1, 1.0)       # kernel scales sigma_0 of the study
OPTIONS = (                      # (label, nearest_poses, beams)
    ("template: 16 poses, nearest beam", 16, "nearest"),
    ("all poses, nearest beam", None, "nearest"),
    ("16 poses, all beams", 16, "all"),
    ("all poses, all beams", None, "all"),
)


def map_from_counts(grid: Grid, counts, semantic: bool, prior: float = PRIOR):
    """A minimal built map (``grid``, ``counts``, ``observed``, ``map``) from evidence counts.

    Same posterior as the template faces: alpha = prior + counts (Beta: alpha from column 0,
    beta from column 1; Dirichlet: every column, free space last).
    """
    counts = np.asarray(counts, dtype=float)
    if semantic:
        alpha = prior + counts
        mean, var = dirichlet_mean_variance(alpha)
        mp = {"alpha": alpha, "mean": mean, "variance": var}
    else:
        a, b = prior + counts[:, :1], prior + counts[:, 1:2]
        mean, var = beta_mean_variance(a, b)
        mp = {"alpha": a, "beta": b, "mean": mean, "variance": var}
    return SimpleNamespace(grid=grid, counts=counts, observed=counts.sum(axis=1) > 0, map=mp,
                           semantic=semantic, num_classes=counts.shape[1] - 1 if semantic else 1)


def kernel_study(lengths=LENGTHS, sigmas=SIGMAS, grid_size: float = 0.135, tasks=(2, 4),
                 split: ev.Split | None = None, maps: dict | None = None, **kw) -> list:
    """Held-out scores of the continuous models for every kernel length scale l and scale sigma_0.

    The kernel is linear in sigma_0 (``k = sigma_0 * f(d / l)``), so the evidence for every
    sigma_0 is that for sigma_0 = 0.1 times ``sigma_0 / 0.1``: one build per (task, l), exact
    (``tests/test_evaluate.py`` checks it against a build with that sigma_0).

    Pass a dict as ``maps`` to receive the built maps (sigma_0 = 0.1) keyed by ``(task, l)``.

    Returns
    -------
    list of dict: ``task``, ``model``, ``l`` [m], ``sigma``, the scores of
    :func:`hw4.evaluate.score_map` (without ROC curves) and ``median_variance`` (median posterior
    variance over observed cells).
    """
    split = split or ev.intel_split()
    rows = []
    for task in tasks:
        for l in lengths:
            base = ev.build_eval_map(task, grid_size, split, l=l, sigma=SIGMA0, **kw)
            if maps is not None:
                maps[(task, float(l))] = base
            for s in sigmas:
                m = map_from_counts(base.grid, base.counts * (s / SIGMA0), base.semantic)
                row = {"task": task, "model": ev.MODEL_NAMES[task], "l": float(l),
                       "sigma": float(s), "grid_size": float(grid_size),
                       "accuracy": np.nan, "miou": np.nan, "free_accuracy": np.nan}
                row.update(ev.score_map(m, split.samples, keep_roc=False))
                row["median_variance"] = float(np.median(m.map["variance"].reshape(-1)[m.observed]))
                rows.append(row)
    return rows


def evidence_totals(counts) -> tuple:
    """(occupied, free) evidence summed over the map: all non-free columns, and the free column."""
    counts = np.asarray(counts, dtype=float)
    return float(counts[:, :-1].sum()), float(counts[:, -1].sum())


def options_study(grid_size: float = 0.27, tasks=(1, 2, 4), options=OPTIONS,
                  split: ev.Split | None = None) -> list:
    """Template options versus the fuller options of the models, scored on held-out data.

    For each task and option: evidence kept (occupied and free, as a share of the fullest option
    of that task), held-out scores, and build time. The discrete CSM has no ``beams`` option, so
    it runs the two pose options only.

    Returns
    -------
    list of dict: ``task``, ``model``, ``option``, ``nearest_poses``, ``beams``, ``occupied_evidence``,
    ``free_evidence``, ``occupied_kept``, ``free_kept`` (share of the fullest option's evidence),
    ``build_seconds`` and the scores of :func:`hw4.evaluate.score_map` (without ROC curves).
    """
    split = split or ev.intel_split()
    rows = []
    for task in tasks:
        mine = []
        for label, npose, beams in options:
            if task in (1, 3) and beams != "nearest":
                continue
            kw = {"nearest_poses": npose}
            if task in (2, 4):
                kw["beams"] = beams
            t0 = time.perf_counter()
            m = ev.build_eval_map(task, grid_size, split, **kw)
            secs = time.perf_counter() - t0
            occ, free = evidence_totals(m.counts)
            row = {"task": task, "model": ev.MODEL_NAMES[task], "option": label,
                   "nearest_poses": npose, "beams": beams, "grid_size": float(grid_size),
                   "occupied_evidence": occ, "free_evidence": free, "build_seconds": secs,
                   "accuracy": np.nan, "miou": np.nan, "free_accuracy": np.nan}
            row.update(ev.score_map(m, split.samples, keep_roc=False))
            mine.append(row)
        full = mine[-1]
        for r in mine:
            r["occupied_kept"] = r["occupied_evidence"] / full["occupied_evidence"]
            r["free_kept"] = r["free_evidence"] / full["free_evidence"]
        rows += mine
    return rows


"""Reference maps, the family of legitimate variants, and the cell-by-cell comparison.

Everything here runs in the grader's process, after the submission's child has ended: the
reference arrays never exist where a submission could read them.

Variants (continuous tasks; each is a documented reading of the handout): free samples every
0.1 m (= l/2, the default), every 2l/3, every grid size, or only the sample closest to the cell
(a later template's hint). Whether a sample falls on the end point depends on the last bit of
the range (``np.arange(0, z, step)``, perhaps on a range recomputed from the end point's world
coordinates), so for each step a cell agrees when it matches the reference with samples strictly
short of the end point OR one of the readings that may also sample it (``sample_count`` of
:func:`hw4.core.evidence.count_evidence`). The posterior uses the submission's own prior (its ``prior_alpha`` or
``prior`` attribute, the prior its unobserved cells imply, or the template's 1e-3): priors from
1e-19 to 0.5 are all legitimate.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.evidence import count_evidence
from ..core.grid import Grid
from ..core.posterior import beta_mean_variance, dirichlet_mean_variance
from ..tasks import load_task_data, model_class

L = 0.2
END_READINGS = ("through", "arange", "arange_world")  # per cell, besides 'strict'


def variants(task: int, grid_size: float) -> list[tuple[str, dict]]:
    """(label, count_evidence options) of the legitimate variants of a task."""
    if not model_class(task).continuous:
        return [("Algorithm 1 as written", {})]
    out = []
    for label, step in (("free samples every 0.1 m (l/2)", 0.1),
                        ("free samples every 2l/3", 2 * L / 3),
                        ("free samples every grid size", grid_size)):
        out.append((label, {"sample_step": step}))
    for label, step in (("every 0.1 m", 0.1), ("every 2l/3", 2 * L / 3),
                        ("every grid size", grid_size)):
        out.append((f"closest free sample only ({label})", {"sample_step": step,
                                                           "free_samples": "closest"}))
    return out


_cache: dict = {}


def evidence(task: int, grid_size: float, **opts) -> tuple[Grid, np.ndarray]:
    """(grid, evidence counts) of the exact core for a task, a grid size and variant options."""
    key = (task, float(grid_size), tuple(sorted(opts.items())))
    if key not in _cache:
        cls = model_class(task)
        data = load_task_data(task)
        scans = data.scans if cls.semantic else [s[:2] for s in data.scans]
        grid = Grid(grid_size, n_classes=7 if cls.semantic else 2)
        kw = dict(model="continuous" if cls.continuous else "discrete", semantic=cls.semantic)
        if cls.semantic:
            kw["num_labels"] = 6
        _cache[key] = (grid, count_evidence(grid, data.poses, scans, **kw, **opts))
    return _cache[key]


def posterior(counts: np.ndarray, prior: float, semantic: bool) -> tuple[np.ndarray, np.ndarray]:
    """(mean, variance) with prior ``prior`` added to every count. Binary: mean and variance
    (n,); semantic: class means (n, K) and the variance of the most likely class (n,)."""
    a = counts + prior
    if semantic:
        mean, var = dirichlet_mean_variance(a)
        return mean, var[:, 0]
    mean, var = beta_mean_variance(a[:, 0], a[:, 1])
    return mean, var


@dataclass
class Comparison:
    """Agreement of a submission's map with one reference."""
    share: float                 # share of compared cells where mean and variance both agree
    compared: int                # cells compared (observed by the reference, or differing)
    agree: np.ndarray = field(repr=False)   # (n,) bool, mean and variance agree
    ref_value: np.ndarray = field(repr=False)  # (n,) what the reference says (mean or class)
    ref_var: np.ndarray = field(repr=False)
    label: str = ""
    prior: float = 0.0
    mean_share: float = 0.0      # share of compared cells whose mean (class) agrees
    var_share: float = 0.0       # share of compared cells whose variance agrees
    opts: dict = field(default_factory=dict)  # count_evidence options of the variant


def credit(c: Comparison, mean_weight: float, lo: float, hi: float) -> float:
    """Fraction of a task's points: ``mean_weight`` for the means (semantic: the most likely
    classes), the rest for the variances, each growing linearly from share ``lo`` to ``hi``."""
    def f(x):
        return float(np.clip((x - lo) / (hi - lo), 0.0, 1.0))
    return mean_weight * f(c.mean_share) + (1 - mean_weight) * f(c.var_share)


def student_arrays(mean, variance, n_cells: int, semantic: bool, n_classes: int = 7):
    """Validate and reshape the arrays a submission returned; (mean, variance) or a reason."""
    mean = np.asarray(mean)
    variance = np.asarray(variance)
    if mean.dtype.kind not in "fiu" or variance.dtype.kind not in "fiu":
        return f"map['mean'] / map['variance'] are not numeric arrays ({mean.dtype}, {variance.dtype})"
    want_mean = (n_cells, n_classes) if semantic else (n_cells,)
    m = mean.reshape(n_cells, -1) if mean.size in (n_cells, n_cells * n_classes) else None
    if m is None or (semantic and m.shape[1] != n_classes) or (not semantic and m.shape[1] != 1):
        return (f"map['mean'] has shape {mean.shape}; expected {want_mean} (or (n, 1)) for "
                f"{n_cells:,} cells: the grid size or the map extent was not used as given")
    if variance.size != n_cells:
        return (f"map['variance'] has shape {variance.shape}; expected ({n_cells},) or "
                f"({n_cells}, 1)")
    m = m.astype(float) if semantic else m[:, 0].astype(float)
    v = variance.reshape(-1).astype(float)
    bad = int((~np.isfinite(m)).sum() + (~np.isfinite(v)).sum())
    if bad:
        return f"map['mean'] / map['variance'] hold {bad:,} values that are NaN or infinite"
    return m, v


def compare(mean, var, counts, prior: float, semantic: bool, rtol: float, atol: float,
            alt_counts=None) -> Comparison:
    """Cell-by-cell agreement of (mean, var) with the reference of ``counts`` (or, per cell, with
    any of ``alt_counts``: the other readings of the end point)."""
    mean_ok, var_ok, ref_val, ref_var = _agree(mean, var, counts, prior, semantic, rtol, atol)
    agree = mean_ok & var_ok
    observed = counts.sum(axis=1) > 0
    for alt in alt_counts or ():
        m2, v2, _, _ = _agree(mean, var, alt, prior, semantic, rtol, atol)
        agree |= m2 & v2
        mean_ok |= m2
        var_ok |= v2
        observed |= alt.sum(axis=1) > 0
    considered = observed | ~agree
    n = int(considered.sum())
    if not n:
        return Comparison(1.0, 0, agree, ref_val, ref_var, prior=prior, mean_share=1.0,
                          var_share=1.0)
    return Comparison(float(agree[considered].mean()), n, agree, ref_val, ref_var, prior=prior,
                      mean_share=float(mean_ok[considered].mean()),
                      var_share=float(var_ok[considered].mean()))


def _agree(mean, var, counts, prior, semantic, rtol, atol):
    """(mean or class agrees, variance agrees, reference mean or class, reference variance)."""
    ref_mean, ref_var = posterior(counts, prior, semantic)
    var_ok = np.isclose(var, ref_var, rtol=rtol, atol=atol)
    if semantic:
        top = ref_mean.max(axis=1)
        student_cls = np.argmax(mean, axis=1)
        ref_cls = np.argmax(ref_mean, axis=1)
        # a tie in the reference: any of the tied classes is right
        tied = np.isclose(ref_mean[np.arange(len(top)), student_cls], top, rtol=rtol, atol=atol)
        return tied, var_ok, ref_cls, ref_var
    return np.isclose(mean, ref_mean, rtol=rtol, atol=atol), var_ok, ref_mean, ref_var


def implied_prior(var, counts, semantic: bool, n_classes: int = 7):
    """The prior a submission's unobserved cells imply (their variance), or None."""
    unobserved = counts.sum(axis=1) == 0
    if not unobserved.any():
        return None
    v = float(np.median(var[unobserved]))
    if not 0 < v < 1:
        return None
    if semantic:  # p = 1/K, var = p (1 - p) / (K a + 1)
        p = 1.0 / n_classes
        a = (p * (1 - p) / v - 1) / n_classes
    else:  # var = 1 / (4 (2 a + 1))
        a = (1 / (4 * v) - 1) / 2
    return a if np.isfinite(a) and a > 0 else None


def best_match(task: int, grid_size: float, mean, var, priors, rtol: float, atol: float):
    """The legitimate variant and prior the submission matches best: (label, Comparison)."""
    semantic = model_class(task).semantic
    best = None
    for label, opts in variants(task, grid_size):
        _, counts = evidence(task, grid_size, **opts)
        alt = None
        if model_class(task).continuous:
            alt = [evidence(task, grid_size, **opts, sample_count=k)[1] for k in END_READINGS]
        cand = list(priors)
        ip = implied_prior(var, counts, semantic)
        if ip is not None:
            cand.append(ip)
        for prior in dict.fromkeys(p for p in cand if p is not None and np.isfinite(p) and p > 0):
            c = compare(mean, var, counts, prior, semantic, rtol, atol, alt)
            c.label, c.opts = label, dict(opts)
            if best is None or (c.share, c.mean_share + c.var_share) > \
                    (best.share + 1e-12, best.mean_share + best.var_share + 1e-12):
                best = c
            if best.share == 1.0:
                return best
    return best


def diagnose(task: int, grid_size: float, mean, var, prior: float, rtol: float, atol: float,
             opts: dict | None = None):
    """What a difference most likely means: (sentence, share of cells it explains) or None.

    Each hypothesis is a deliberately wrong version of the reference of the variant ``opts``
    (count_evidence options); the one the submission matches best (at least 80 % of cells) is
    named.
    """
    cls = model_class(task)
    semantic = cls.semantic
    opts = dict(opts or {})
    _, counts = evidence(task, grid_size, **opts)
    hyps = []
    free = counts.shape[1] - 1
    zero_free = counts.copy()
    zero_free[:, free] = 0
    hyps.append(("free space is never updated (no free-space evidence)", zero_free))
    zero_occ = counts.copy()
    zero_occ[:, :free] = 0
    hyps.append(("occupied (hit) evidence is never added", zero_occ))
    hyps.append(("the map is never updated (every cell keeps its prior)", np.zeros_like(counts)))
    if semantic:
        shifted = np.zeros_like(counts)
        shifted[:, 1:free] = counts[:, :free - 1]
        shifted[:, free] = counts[:, free]
        hyps.append(("label k is stored as k+1 (alpha indexed by the label, not label - 1)",
                     shifted))
        swapped = counts.copy()
        swapped[:, [0, free]] = counts[:, [free, 0]]
        hyps.append(("free-space evidence goes to class 1 (and class 1's to free space)", swapped))
    else:
        hyps.append(("alpha and beta are swapped (occupied counted as free)", counts[:, ::-1]))
    if cls.continuous:
        if opts.get("free_samples", "all") == "all":
            _, dense = evidence(task, grid_size, beams="all", **opts)
            hyps.append(("every beam is used, not only the beam nearest in bearing", dense))
    else:
        _, cont = evidence(4 if semantic else 2, grid_size)
        hyps.append(("the continuous (kernel) model was submitted for the discrete task", cont))
        _, thin = evidence(task, grid_size, w_obstacle=grid_size)
        hyps.append(("the obstacle is one grid size thick (w_obstacle = grid_size)", thin))
    best = None
    for text, c in hyps:
        comp = compare(mean, var, c, prior, semantic, rtol, atol)
        if best is None or comp.share > best[1]:
            best = (text, comp.share)
    # mean right, variance wrong
    mean_ok, var_ok, _, ref_var = _agree(mean, var, counts, prior, semantic, rtol, atol)
    if mean_ok.mean() > 0.97 and var_ok.mean() < 0.97:
        bad = ~var_ok
        cap = float(var.max())
        if np.all(ref_var[bad] > cap) and np.all(np.isclose(var[bad], cap, rtol=rtol, atol=atol)):
            return (f"the variance is capped at {cap:g} (the reference's is larger in those "
                    "cells)", float(bad.mean() + var_ok.mean()))
        return ("the means (classes) agree but the variances do not: check the variance formula "
                "(Eq. 3 / Eq. 10, the variance of the most likely class)", float(mean_ok.mean()))
    if best and best[1] >= 0.8:
        return best
    return None

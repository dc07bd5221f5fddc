"""Held-out evaluation of occupancy and semantic maps.

The homework asks which resolution and which model make the better map, but gives no measure of
map quality. The published counting-sensor-model papers (Doherty et al. 2019, Gan et al. 2020)
measure it on held-out data; this module does the same for the Intel sample:

1. :func:`split_scans` holds out every ``every``-th scan (deterministic, no randomness);
   the maps are built from the remaining *mapping* scans only.
2. :func:`held_out_samples` turns each held-out scan into labelled points in the world frame:
   every beam end point is an **occupied** sample (with its semantic label when the scan has
   one), and points along the beam at ``s = step, 2 step, ...`` strictly short of
   ``range - margin`` are **free** samples. The defaults ``step = 0.1 m`` (the free-sample spacing
   of the continuous models, half the kernel length scale, so every 0.135 m cell a beam crosses
   gets a sample) and ``margin = 0.25 m`` (half the coarsest cell of the study, so that at every
   grid size a free sample lies at least half a cell before the surface it is contrasted with)
   do not depend on the map: every map, at every grid size, is scored on the *same* points.
3. A sample is scored in the cell whose centre is nearest to it (:meth:`hw4.core.grid.Grid.nearest_cell`).
   Samples in cells without evidence (or outside the map) are **not** scored: the prior's 0.5 is
   no prediction. Their share is reported separately (``unobserved``; ``coverage`` is the rest).
4. Occupancy is scored by the ROC curve and its area (AUC) of the predicted probability of
   occupancy: the Beta mean for the binary maps, ``1 - mean[free]`` for the semantic maps, the
   log-odds for the classical baseline (:mod:`hw4.evaluation.logodds`). Semantic maps are also scored by the
   accuracy and per-class IoU of the most likely class at the held-out end points, the share of
   free samples predicted free, and a confusion matrix.

The one-call entry point for the notebooks is :func:`evaluate_all` (all models x grid sizes plus
the baseline, one row per map). AUC is computed exactly from ranks (ties count one half), with
no dependence on scikit-learn.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..core import data as _data
from ..core.errors import InputError
from ..core.posterior import most_likely_class

GRID_SIZES = (0.135, 0.27, 0.5)  # the homework's resolution study [m]
HOLD_OUT_EVERY = 10              # default split: every 10th scan is held out
FREE_STEP = 0.1                  # spacing of the held-out free samples along a beam [m]
FREE_MARGIN = 0.25               # free samples stop this far before the end point [m]
N_LABELS = _data.N_LABELS        # semantic labels 1..6; class index 6 is free space


# --------------------------------------------------------------------------------------------
# Split and held-out samples
# --------------------------------------------------------------------------------------------

def split_scans(n_scans: int, every: int = HOLD_OUT_EVERY, offset: int | None = None) -> tuple:
    """Deterministic split of scan indices into mapping and held-out scans.

    Parameters
    ----------
    n_scans : int
        Number of scans (743 for the Intel sample).
    every : int
        Hold out one scan in ``every`` (default 10).
    offset : int, optional
        Which scan of each block of ``every`` is held out (default ``every - 1``: scans 9, 19, ...,
        so that the first scans, which start the map, are mapping scans).

    Returns
    -------
    (mapping, held_out) : two sorted int arrays that partition ``range(n_scans)``.
    """
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 2:
        raise InputError(f"every must be an integer >= 2 (hold out one scan in `every`); got {every!r}.")
    offset = every - 1 if offset is None else offset
    if not 0 <= offset < every:
        raise InputError(f"offset must lie in 0..{every - 1}; got {offset!r}.")
    idx = np.arange(int(n_scans))
    held = idx % every == offset
    return idx[~held], idx[held]


def subset(data: _data.IntelData, idx) -> _data.IntelData:
    """The poses and scans with indices ``idx`` as a new :class:`~hw4.core.data.IntelData`."""
    idx = np.asarray(idx, dtype=np.int64)
    return _data.IntelData(np.asarray(data.poses)[idx], [data.scans[i] for i in idx])


@dataclass
class HeldOut:
    """Labelled test points from held-out scans, world frame.

    Attributes
    ----------
    points : (N, 2) float [m], world frame
    occupied : (N,) bool, True for beam end points, False for free samples along beams
    label : (N,) int, semantic label 1..6 of end points (0 for free samples and for unlabelled scans)
    scan : (N,) int, index (into the full data) of the scan the sample comes from
    step, margin : float [m], the free-sample spacing and end margin used
    """
    points: np.ndarray
    occupied: np.ndarray
    label: np.ndarray
    scan: np.ndarray
    step: float = FREE_STEP
    margin: float = FREE_MARGIN

    @property
    def n_occupied(self) -> int:
        return int(self.occupied.sum())

    @property
    def n_free(self) -> int:
        return int((~self.occupied).sum())

    @property
    def truth_class(self) -> np.ndarray:
        """(N,) class index of each sample: label - 1 for end points, ``N_LABELS`` (free) otherwise."""
        return np.where(self.occupied, self.label - 1, N_LABELS)


def held_out_samples(data: _data.IntelData, idx, step: float = FREE_STEP,
                     margin: float = FREE_MARGIN, z_max: float = 30.0) -> HeldOut:
    """Occupied and free test points of the scans ``idx``, in the world frame.

    Parameters
    ----------
    data : IntelData
        Poses (T, 3) [m, m, rad] world frame; scans (2, N) or (3, N) [m] robot frame.
    idx : array of int
        Held-out scan indices.
    step : float [m]
        Free samples at ``s = step, 2 step, ...`` along each beam (the robot's own position,
        ``s = 0``, is not sampled).
    margin : float [m]
        Free samples satisfy ``s < range - margin`` strictly.
    z_max : float [m]
        End points at or beyond the maximum range are not surfaces: no occupied sample there.
    """
    for v, name in ((step, "step"), (margin, "margin"), (z_max, "z_max")):
        if isinstance(v, bool) or not np.isscalar(v) or not np.isfinite(v) or v <= 0:
            raise InputError(f"{name} must be a positive number of metres; got {v!r}.")
    pts, occ, lab, src = [], [], [], []
    for t in np.asarray(idx, dtype=np.int64):
        x, y, h = np.asarray(data.poses[t], dtype=float)
        s = np.asarray(data.scans[t], dtype=float)
        r = np.hypot(s[0], s[1])
        u = np.column_stack([s[0], s[1]]) / np.maximum(r, 1e-300)[:, None]  # beam directions
        c, sn = np.cos(h), np.sin(h)
        rot = np.array([[c, -sn], [sn, c]])
        hit = r < z_max
        end = (rot @ s[:2]).T + [x, y]
        labels = s[2].astype(np.int64) if s.shape[0] == 3 else np.zeros(s.shape[1], np.int64)
        # free samples j * step, j = 1 .. n_j, with j * step < r - margin
        n_j = np.maximum(np.ceil((r - margin) / step).astype(np.int64) - 1, 0)
        n_j = np.where((n_j + 1) * step < r - margin, n_j + 1, n_j)  # guard float rounding
        n_j = np.where(n_j * step >= r - margin, n_j - 1, n_j)
        n_j = np.maximum(n_j, 0)
        beam = np.repeat(np.arange(len(r)), n_j)
        j = np.arange(n_j.sum()) - np.repeat(np.cumsum(n_j) - n_j, n_j) + 1
        d = (j * step)[:, None] * u[beam]
        free = (rot @ d.T).T + [x, y]
        pts += [end[hit], free]
        occ += [np.ones(hit.sum(), bool), np.zeros(len(free), bool)]
        lab += [labels[hit], np.zeros(len(free), np.int64)]
        src += [np.full(hit.sum() + len(free), t)]
    if not pts:
        raise InputError("no held-out scans were given.")
    return HeldOut(np.concatenate(pts), np.concatenate(occ), np.concatenate(lab),
                   np.concatenate(src), float(step), float(margin))


# --------------------------------------------------------------------------------------------
# Metrics
# --------------------------------------------------------------------------------------------

def _check_scores(scores, positive):
    scores = np.asarray(scores, dtype=float).reshape(-1)
    positive = np.asarray(positive, dtype=bool).reshape(-1)
    if scores.shape != positive.shape:
        raise InputError(f"scores and labels differ in length ({len(scores)} vs {len(positive)}).")
    if not np.all(np.isfinite(scores)):
        raise InputError("scores contain NaN or inf.")
    n_pos = int(positive.sum())
    if n_pos == 0 or n_pos == len(positive):
        raise InputError("AUC needs at least one positive and one negative sample.")
    return scores, positive


def _tie_groups(scores, positive):
    """Per distinct score, descending: (score, positives, negatives)."""
    order = np.argsort(-scores, kind="stable")
    s = scores[order]
    p = positive[order]
    start = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
    pos = np.add.reduceat(p.astype(np.int64), start)
    neg = np.diff(np.r_[start, len(s)]) - pos
    return s[start], pos, neg


def roc_curve(scores, positive) -> tuple:
    """ROC curve of a score that should be high on positives.

    One point per distinct score (ties move the curve diagonally), from (0, 0) to (1, 1).

    Parameters
    ----------
    scores : (N,) float
    positive : (N,) bool

    Returns
    -------
    fpr, tpr : (M + 1,) float, false and true positive rates
    thresholds : (M,) float, the distinct scores, descending (point i + 1 classifies score >= t_i
        positive)
    """
    scores, positive = _check_scores(scores, positive)
    thr, pos, neg = _tie_groups(scores, positive)
    tpr = np.r_[0, np.cumsum(pos)] / pos.sum()
    fpr = np.r_[0, np.cumsum(neg)] / neg.sum()
    return fpr, tpr, thr


def auc(scores, positive) -> float:
    """Area under the ROC curve, exactly: P(score of a positive > score of a negative) + P(tie) / 2.

    Computed from integer counts per tie group (the Mann-Whitney statistic), which equals the
    trapezoid area under :func:`roc_curve`.
    """
    scores, positive = _check_scores(scores, positive)
    _, pos, neg = _tie_groups(scores, positive)
    neg_above = np.cumsum(neg) - neg  # negatives with a strictly higher score
    n_pos, n_neg = int(pos.sum()), int(neg.sum())
    # pairs (positive, negative) ranked wrongly, ties counted one half (integers x 2: exact)
    wrong2 = int(np.sum(pos * (2 * neg_above + neg)))
    return 1.0 - wrong2 / (2.0 * n_pos * n_neg)


def trapezoid_auc(fpr, tpr) -> float:
    """Trapezoid area under a piecewise linear ROC curve."""
    fpr, tpr = np.asarray(fpr, float), np.asarray(tpr, float)
    return float(np.sum(np.diff(fpr) * (tpr[1:] + tpr[:-1]) / 2))


def confusion_matrix(truth, predicted, n_classes: int) -> np.ndarray:
    """(n_classes, n_classes) int counts; rows true class, columns predicted class."""
    truth = np.asarray(truth, dtype=np.int64).reshape(-1)
    predicted = np.asarray(predicted, dtype=np.int64).reshape(-1)
    if truth.shape != predicted.shape:
        raise InputError("truth and predicted differ in length.")
    for a, name in ((truth, "truth"), (predicted, "predicted")):
        if a.size and (a.min() < 0 or a.max() >= n_classes):
            raise InputError(f"{name} classes must lie in 0..{n_classes - 1}.")
    return np.bincount(truth * n_classes + predicted, minlength=n_classes ** 2).reshape(
        n_classes, n_classes)


def iou_from_confusion(cm, classes=None) -> np.ndarray:
    """Intersection over union TP / (TP + FP + FN) per class of a confusion matrix.

    Parameters
    ----------
    cm : (K, K) counts, rows true, columns predicted.
    classes : sequence of int, optional
        Classes to report (default all). FP and FN count every row and column of ``cm``.

    Returns
    -------
    (len(classes),) float; NaN for a class that is neither present nor predicted.
    """
    cm = np.asarray(cm, dtype=float)
    classes = np.arange(len(cm)) if classes is None else np.asarray(classes)
    tp = np.diag(cm)[classes]
    fn = cm.sum(axis=1)[classes] - tp
    fp = cm.sum(axis=0)[classes] - tp
    den = tp + fp + fn
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, tp / np.where(den > 0, den, 1), np.nan)


# --------------------------------------------------------------------------------------------
# Scoring one map
# --------------------------------------------------------------------------------------------

def occupancy_score(m) -> np.ndarray:
    """(n_cells,) score of occupancy of a map, higher = more likely occupied.

    Binary maps: the Beta mean. Semantic maps: 1 - mean of free space. Log-odds maps
    (:class:`hw4.evaluation.logodds.LogOddsMap`): the log-odds itself (same order as the probability, but
    without the ties that saturating ``1 / (1 + exp(-l))`` to exactly 0 or 1 would create).
    """
    if getattr(m, "logodds", None) is not None:
        return np.asarray(m.logodds, dtype=float).reshape(-1)
    mean = np.asarray(m.map["mean"], dtype=float)
    if getattr(m, "semantic", False):
        return 1.0 - mean[:, -1]
    return mean.reshape(-1)


def scored_cells(m, samples: HeldOut):
    """The cell of each sample (its nearest cell centre, -1 outside the map) and whether the
    sample is scored there (inside the map, in a cell with evidence): ``(cell, scored)``."""
    cell = m.grid.nearest_cell(samples.points)
    scored = cell >= 0
    scored[scored] = np.asarray(m.observed, dtype=bool).reshape(-1)[cell[scored]]
    return cell, scored


def score_map(m, samples: HeldOut, keep_roc: bool = True) -> dict:
    """Score one built map on held-out samples.

    Parameters
    ----------
    m : a built map with ``.grid``, ``.observed`` (n_cells,) bool, ``.map['mean']`` (and
        ``.map['alpha']``, ``.semantic`` for semantic maps), or a :class:`hw4.evaluation.logodds.LogOddsMap`.
    samples : HeldOut

    Returns
    -------
    dict with
        ``n_samples``, ``n_scored`` : samples in total, and in observed cells;
        ``coverage`` : share of samples in observed cells (scored);
        ``unobserved`` : share in unobserved cells or outside the map (not scored) = 1 - coverage;
        ``coverage_occupied``, ``coverage_free`` : the same for end points / free samples only;
        ``auc`` : ROC AUC of :func:`occupancy_score` on the scored samples;
        ``fpr``, ``tpr`` : the ROC curve (when ``keep_roc``);
        binary maps also: ``occupied_recall`` (scored end points with P(occupied) > 0.5) and
        ``free_accuracy`` (scored free samples with P(occupied) <= 0.5), the map read at 0.5;
        semantic maps also: ``accuracy`` (most likely class at scored labelled end points),
        ``free_accuracy`` (scored free samples predicted free), ``occupied_recall`` (scored end
        points predicted as any class but free), ``label_accuracy`` (correct class among those;
        so accuracy = occupied_recall x label_accuracy), ``iou`` (6,) and ``miou``
        (their mean; IoU from the end points' rows of the confusion matrix, a free prediction
        counting as a miss), ``confusion`` (7, 7) counts over all scored samples, rows true
        class (labels 1..6 then free), columns predicted.
    """
    cell, scored = scored_cells(m, samples)
    occ = samples.occupied
    out = {
        "n_samples": int(len(cell)),
        "n_scored": int(scored.sum()),
        "coverage": float(scored.mean()),
        "unobserved": float(1.0 - scored.mean()),
        "coverage_occupied": float(scored[occ].mean()) if occ.any() else np.nan,
        "coverage_free": float(scored[~occ].mean()) if (~occ).any() else np.nan,
    }
    score = occupancy_score(m)[cell[scored]]
    truth = occ[scored]
    out["auc"] = auc(score, truth)
    if keep_roc:
        out["fpr"], out["tpr"], _ = roc_curve(score, truth)
    if not getattr(m, "semantic", False):  # the map read at probability 0.5 (log-odds 0)
        called = score > (0.0 if getattr(m, "logodds", None) is not None else 0.5)
        out["occupied_recall"] = float(called[truth].mean()) if truth.any() else np.nan
        out["free_accuracy"] = float((~called[~truth]).mean()) if (~truth).any() else np.nan
    if getattr(m, "semantic", False):
        if not np.all(samples.label[occ] >= 1):
            raise InputError("semantic scoring needs held-out samples from labelled (3xN) scans.")
        pred = most_likely_class(np.asarray(m.map["alpha"]))[cell[scored]]
        true_cls = samples.truth_class[scored]
        k = N_LABELS + 1
        cm = confusion_matrix(true_cls, pred, k)
        ends = cm[:N_LABELS]
        out["confusion"] = cm
        out["accuracy"] = float(np.trace(ends[:, :N_LABELS]) / max(ends.sum(), 1))
        out["free_accuracy"] = float(cm[N_LABELS, N_LABELS] / max(cm[N_LABELS].sum(), 1))
        occ_pred = ends[:, :N_LABELS].sum()
        out["label_accuracy"] = float(np.trace(ends[:, :N_LABELS]) / occ_pred) if occ_pred else np.nan
        out["occupied_recall"] = float(occ_pred / max(ends.sum(), 1))
        out["iou"] = iou_from_confusion(ends_only(cm), np.arange(N_LABELS))
        out["miou"] = float(np.nanmean(out["iou"]))
    return out


BOOT_METRICS = ("auc", "occupied_recall", "accuracy", "miou")
INTERVAL_METHODS = ("percentile", "bca")   # bootstrap interval methods of :func:`paired_difference`


@dataclass
class _ScanStats:
    """One map's scores on its scored samples, summed per held-out scan (``S`` scans).

    Every metric of :data:`BOOT_METRICS` under scan weights ``w`` (S,) is a function of these
    sums: the AUC of the quadratic form ``w @ wrong2 @ w`` over ``(w @ pos) * (w @ neg)``, the
    others of linear forms. Exact for integer weights (the counts are integers, or half-integers
    doubled).
    """
    pos: np.ndarray            # (S,) end points scored, per scan
    neg: np.ndarray            # (S,) free samples scored, per scan
    wrong2: np.ndarray         # (S, S) 2 x (pairs (end point of scan i, free sample of scan j)
                               #   ranked wrongly, ties counting one half)
    called: np.ndarray         # (S,) end points called occupied, per scan
    confusion: np.ndarray | None  # (S, K*K) confusion counts per scan (semantic maps), else None


def _scan_stats(m, cell, mine, samples: HeldOut, scan_idx, n_scans: int) -> _ScanStats:
    """:class:`_ScanStats` of map ``m`` on the samples ``mine`` (indices into ``samples``);
    ``scan_idx`` (len(mine),) is each sample's scan as 0..n_scans-1."""
    s = occupancy_score(m)[cell[mine]]
    positive = samples.occupied[mine]
    ps, pscan = s[positive], scan_idx[positive]
    ns, nscan = s[~positive], scan_idx[~positive]
    pos = np.bincount(pscan, minlength=n_scans).astype(float)
    neg = np.bincount(nscan, minlength=n_scans).astype(float)
    # free samples grouped by scan, each group sorted by score: per scan j one binary search of
    # every end point's score gives the free samples of scan j above it and tied with it
    order = np.lexsort((ns, nscan))
    ns_sorted = ns[order]
    bounds = np.r_[0, np.cumsum(neg.astype(np.int64))]
    wrong2 = np.zeros((n_scans, n_scans))
    for j in np.flatnonzero(neg):
        nj = ns_sorted[bounds[j]:bounds[j + 1]]
        right = np.searchsorted(nj, ps, "right")
        left = np.searchsorted(nj, ps, "left")
        wrong2[:, j] = np.bincount(pscan, weights=2 * (len(nj) - right) + (right - left),
                                   minlength=n_scans)
    k = N_LABELS + 1
    if getattr(m, "semantic", False):
        pred = most_likely_class(np.asarray(m.map["alpha"]))[cell[mine]]
        called = pred != N_LABELS
        codes = scan_idx * (k * k) + samples.truth_class[mine] * k + pred
        confusion = np.bincount(codes, minlength=n_scans * k * k).reshape(n_scans, k * k)
        confusion = confusion.astype(float)
    else:
        called = s > (0.0 if getattr(m, "logodds", None) is not None else 0.5)
        confusion = None
    called_pos = np.bincount(pscan, weights=called[positive].astype(float), minlength=n_scans)
    return _ScanStats(pos, neg, wrong2, called_pos, confusion)


def _metrics_under_weights(st: _ScanStats, w) -> np.ndarray:
    """(B, len(BOOT_METRICS)) scores of one map for B scan-weight vectors ``w`` (B, S)."""
    w = np.asarray(w, dtype=float)
    wp, wn = w @ st.pos, w @ st.neg
    with np.errstate(invalid="ignore", divide="ignore"):
        den = wp * wn
        auc_ = np.where(den > 0, 1.0 - np.einsum("bi,ij,bj->b", w, st.wrong2, w) / (2 * den),
                        np.nan)
        recall = np.where(wp > 0, (w @ st.called) / wp, np.nan)
        out = np.full((len(w), len(BOOT_METRICS)), np.nan)
        out[:, 0], out[:, 1] = auc_, recall
        if st.confusion is None:
            return out
        k = N_LABELS + 1
        ends = (w @ st.confusion).reshape(len(w), k, k)[:, :N_LABELS, :]   # end points' rows
        total = ends.sum(axis=(1, 2))
        tp = np.diagonal(ends[:, :, :N_LABELS], axis1=1, axis2=2)
        out[:, 2] = np.where(total > 0, tp.sum(axis=1) / total, np.nan)
        # IoU as iou_from_confusion(ends_only(cm)): FN over the region's row, FP over its column
        # within the end points' rows, a free prediction counting as a miss
        fn = ends.sum(axis=2)[:, :N_LABELS] - tp
        fp = ends.sum(axis=1)[:, :N_LABELS] - tp
        iou_den = tp + fp + fn
        iou = np.where(iou_den > 0, tp / np.where(iou_den > 0, iou_den, 1), np.nan)
        n_def = np.isfinite(iou).sum(axis=1)
        out[:, 3] = np.where(n_def > 0, np.nansum(iou, axis=1) / np.maximum(n_def, 1), np.nan)
    return out


def bootstrap_scores(maps, samples: HeldOut, n_boot: int = 200, seed: int = 0,
                     common: bool = True) -> dict:
    """Scores of several maps under resampling of the held-out *scans* (paired, seeded).

    Samples from one scan are strongly correlated, so the unit of resampling is the scan (a
    cluster bootstrap): each replicate draws the held-out scans with replacement and weights
    every sample by how often its scan was drawn. Every map sees the same draws, so differences
    between maps are paired. With ``common`` (default) every map is scored on the samples that
    all of them observe, so a difference compares the maps on the same points.

    Each metric is computed from per-scan sums (:class:`_ScanStats`: the AUC's pair counts per
    pair of scans, confusion counts per scan), so a replicate costs a few small matrix products
    instead of a pass over the samples: thousands of draws take well under a second. The result
    equals the weighted scoring of every sample exactly (up to float rounding; tested).

    Metrics (:data:`BOOT_METRICS`): ``auc`` (occupancy, :func:`occupancy_score`), and on the
    end points ``occupied_recall`` (called occupied: P > 0.5 for binary maps, any region for
    semantic maps), ``accuracy`` and ``miou`` (semantic maps only; NaN for the others) as in
    :func:`score_map`.

    Parameters
    ----------
    maps : sequence of built maps (see :func:`score_map`)
    samples : HeldOut
    n_boot : int
        Replicates (the book uses 2,000).
    seed : int
        Seed of ``numpy.random.default_rng``: the result is reproducible. Replicate ``b`` draws
        ``rng.integers(0, S, S)`` in turn (S held-out scans), as one call of shape (n_boot, S).
    common : bool
        True (default): every map is scored on the samples all of them observe. False: each map
        on the samples it observes itself, as :func:`score_map` scores it (the estimates then
        equal :func:`score_map`'s); the scan draws are still shared, so differences stay paired.

    Returns
    -------
    dict with, per metric, the estimate (n_maps,) under the metric's name, its replicates
    (n_boot, n_maps) under ``"<metric>_replicates"`` and its leave-one-scan-out jackknife values
    (S, n_maps) under ``"<metric>_jackknife"`` (for BCa intervals); ``replicates`` is an alias
    of ``auc_replicates``; ``n_common`` (samples scored by every map), ``n_scored`` (n_maps,)
    (samples each map is scored on here), ``n_scans`` (S), ``scan_weights`` (n_boot, S) int
    (how often each scan was drawn), ``n_boot`` and ``seed``.
    """
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)) or n_boot < 1:
        raise InputError(f"n_boot must be a positive integer; got {n_boot!r}.")
    if len(maps) == 0:
        raise InputError("bootstrap_scores needs at least one map.")
    cells, scored = zip(*(scored_cells(m, samples) for m in maps))
    shared = np.logical_and.reduce(scored)
    use = shared if common else np.logical_or.reduce(scored)
    scans, scan_of = np.unique(samples.scan[use], return_inverse=True)
    n_scans = len(scans)
    scan_idx = np.full(len(use), -1, np.int64)
    scan_idx[use] = scan_of.reshape(-1)
    stats, n_scored = [], []
    for m, c, ok in zip(maps, cells, scored):
        mine = np.flatnonzero(shared if common else ok)
        stats.append(_scan_stats(m, c, mine, samples, scan_idx[mine], n_scans))
        n_scored.append(len(mine))

    rng = np.random.default_rng(seed)
    draws = rng.integers(0, n_scans, (int(n_boot), n_scans))
    weights = np.zeros((int(n_boot), n_scans), np.int64)
    np.add.at(weights, (np.repeat(np.arange(int(n_boot)), n_scans), draws.reshape(-1)), 1)
    jack = 1.0 - np.eye(n_scans)
    base = np.array([_metrics_under_weights(st, np.ones((1, n_scans)))[0] for st in stats])
    reps = np.stack([_metrics_under_weights(st, weights) for st in stats], axis=1)
    jk = np.stack([_metrics_under_weights(st, jack) for st in stats], axis=1)
    out = {"n_common": int(shared.sum()), "n_scored": np.array(n_scored), "n_scans": n_scans,
           "scan_weights": weights, "n_boot": int(n_boot), "seed": int(seed)}
    for i, name in enumerate(BOOT_METRICS):
        out[name] = base[:, i]
        out[f"{name}_replicates"] = reps[:, :, i]
        out[f"{name}_jackknife"] = jk[:, :, i]
    out["replicates"] = out["auc_replicates"]
    return out


def bootstrap_auc(maps, samples: HeldOut, n_boot: int = 200, seed: int = 0) -> dict:
    """AUCs of several maps under paired resampling of held-out scans (see :func:`bootstrap_scores`).

    Returns a dict with ``auc`` (n_maps,) on the common samples, ``replicates`` (n_boot, n_maps)
    and ``n_common``.
    """
    b = bootstrap_scores(maps, samples, n_boot, seed)
    return {"auc": b["auc"], "replicates": b["auc_replicates"], "n_common": b["n_common"]}


def bootstrap_interval(replicates, estimate: float, level: float = 0.95,
                       method: str = "percentile", jackknife=None) -> tuple:
    """Two-sided bootstrap interval ``(lo, hi)`` of a statistic from its replicates.

    Parameters
    ----------
    replicates : (B,) float
        The statistic on each bootstrap replicate (non-finite ones are dropped).
    estimate : float
        The statistic on the data.
    level : float
        Coverage, strictly between 0 and 1.
    method : ``"percentile"`` or ``"bca"``
        Percentile: the ``(1 - level) / 2`` and ``(1 + level) / 2`` quantiles of the replicates.
        BCa (bias-corrected and accelerated, Efron 1987; Efron & Tibshirani 1993, ch. 14): the
        quantiles moved by the bias ``z0 = Phi^-1(share of replicates below the estimate, ties
        one half)`` and the acceleration ``a`` from the jackknife's skewness, which corrects a
        percentile interval's coverage to second order when the statistic's distribution is
        skewed or biased (as an AUC near 1 is).
    jackknife : (n,) float
        Leave-one-unit-out values of the statistic (BCa only).
    """
    from scipy.special import ndtr, ndtri
    if not 0 < level < 1:
        raise InputError(f"level must lie strictly between 0 and 1; got {level!r}.")
    if method not in INTERVAL_METHODS:
        raise InputError(f"method must be one of {', '.join(INTERVAL_METHODS)}; got {method!r}.")
    r = np.asarray(replicates, dtype=float).reshape(-1)
    r = r[np.isfinite(r)]
    if r.size == 0:
        raise InputError("no finite bootstrap replicates.")
    q = np.array([(1 - level) / 2, (1 + level) / 2])
    if method == "bca":
        if jackknife is None:
            raise InputError("a BCa interval needs the jackknife values.")
        below = (np.sum(r < estimate) + 0.5 * np.sum(r == estimate)) / r.size
        below = np.clip(below, 0.5 / r.size, 1 - 0.5 / r.size)   # finite z0 for any data
        z0 = ndtri(below)
        j = np.asarray(jackknife, dtype=float).reshape(-1)
        d = j[np.isfinite(j)].mean() - j[np.isfinite(j)]
        ss = float(np.sum(d ** 2))
        a = float(np.sum(d ** 3)) / (6 * ss ** 1.5) if ss > 0 else 0.0
        z = ndtri(q)
        q = ndtr(z0 + (z0 + z) / (1 - a * (z0 + z)))
    lo, hi = np.quantile(r, q)
    return float(lo), float(hi)


def score_interval(boot: dict, i: int, metric: str = "auc", level: float = 0.95,
                   method: str = "percentile") -> dict:
    """Map ``i``'s score of :func:`bootstrap_scores` with its bootstrap interval:
    a dict ``est``, ``lo``, ``hi`` (see :func:`bootstrap_interval` for ``method``)."""
    est = float(boot[metric][i])
    jack = boot.get(f"{metric}_jackknife")
    lo, hi = bootstrap_interval(boot[f"{metric}_replicates"][:, i], est, level, method,
                                None if jack is None else jack[:, i])
    return {"est": est, "lo": lo, "hi": hi}


def paired_difference(boot: dict, a: int, b: int, metric: str = "auc",
                      level: float = 0.95, method: str = "percentile") -> dict:
    """Difference ``metric[a] - metric[b]`` of two maps of :func:`bootstrap_scores`, with its
    interval over the paired replicates (``method``: ``"percentile"``, the default, or
    ``"bca"``; see :func:`bootstrap_interval`).

    Returns a dict ``diff``, ``lo``, ``hi`` and ``p_le0`` (share of replicates with a
    difference <= 0: how often the resampled data do not favour map ``a``).
    """
    if not 0 < level < 1:
        raise InputError(f"level must lie strictly between 0 and 1; got {level!r}.")
    d = boot[f"{metric}_replicates"][:, a] - boot[f"{metric}_replicates"][:, b]
    d = d[np.isfinite(d)]
    if d.size == 0:
        raise InputError(f"no finite bootstrap replicates of {metric!r} for maps {a} and {b}.")
    diff = float(boot[metric][a] - boot[metric][b])
    jack = boot.get(f"{metric}_jackknife")
    jd = None if jack is None else jack[:, a] - jack[:, b]
    lo, hi = bootstrap_interval(d, diff, level, method, jd)
    return {"diff": diff, "lo": lo, "hi": hi, "p_le0": float(np.mean(d <= 0))}


def table_difference(boot: dict, a: int, b: int, metric: str = "auc", digits: int = 3,
                     level: float = 0.95, method: str = "percentile") -> dict:
    """:func:`paired_difference` as a table's reader computes it: from the printed entries.

    The estimate is ``round(metric[a], digits) - round(metric[b], digits)``, the difference of the
    two scores as a table printing ``digits`` decimals shows them (``boot`` from
    :func:`bootstrap_scores` with ``common=False`` holds exactly the tables' scores); the interval
    is that of the paired replicates. ``inside`` tells whether the printed estimate lies within the
    interval rounded to ``digits`` decimals, so that a text quoting both never contradicts itself.

    Returns
    -------
    dict ``diff``, ``lo``, ``hi``, ``p_le0`` (as :func:`paired_difference`) and ``inside`` (bool).
    """
    d = paired_difference(boot, a, b, metric, level, method)
    est = boot[metric]
    diff = round(round(float(est[a]), digits) - round(float(est[b]), digits), digits)
    inside = round(d["lo"], digits) <= diff <= round(d["hi"], digits)
    return {**d, "diff": diff, "inside": bool(inside)}


PAIRED_BOOT = 2000
"""Bootstrap draws of every paired difference the book quotes (seeded; BCa needs thousands)."""
PAIRED_METHOD = "bca"
"""The interval of every paired difference the book quotes: bias-corrected and accelerated."""


def paired_comparison(a, b, samples: HeldOut, metric: str = "auc", digits: int = 4,
                      seed: int = 0, level: float = 0.95) -> dict:
    """The book's one convention for comparing two maps on held-out scans: ``metric(a) -
    metric(b)`` on the test points *both* maps score, with the 95 % BCa interval of a paired
    cluster bootstrap over the held-out scans (:data:`PAIRED_BOOT` draws of ``seed``).

    Every chapter that compares two maps calls this, so the same comparison has the same points,
    draws and interval wherever it is quoted. The difference is that of the two scores rounded to
    ``digits`` decimals (:func:`table_difference`), so a text printing both scores agrees with it.

    Returns a dict: ``diff``, ``lo``, ``hi``, ``p_le0``, ``inside`` (as :func:`table_difference`),
    ``a`` and ``b`` (the two scores on the common points, rounded to ``digits``), ``n`` (points
    scored by both) and ``n_boot``.
    """
    boot = bootstrap_scores([a, b], samples, n_boot=PAIRED_BOOT, seed=seed, common=True)
    d = table_difference(boot, 0, 1, metric, digits=digits, level=level, method=PAIRED_METHOD)
    return {**d, "a": round(float(boot[metric][0]), digits),
            "b": round(float(boot[metric][1]), digits), "n": int(boot["n_common"]),
            "n_boot": PAIRED_BOOT}


def threshold_scores(m, samples: HeldOut, threshold: float) -> dict:
    """A map read at an occupancy threshold: ``occupied_recall`` (scored end points with
    :func:`occupancy_score` > ``threshold``) and ``free_accuracy`` (scored free samples with a
    score <= ``threshold``); for a semantic map the score is 1 - P(free)."""
    cell, scored = scored_cells(m, samples)
    called = occupancy_score(m)[cell[scored]] > threshold
    truth = samples.occupied[scored]
    return {"threshold": float(threshold),
            "occupied_recall": float(called[truth].mean()) if truth.any() else np.nan,
            "free_accuracy": float((~called[~truth]).mean()) if (~truth).any() else np.nan}


def ends_only(cm) -> np.ndarray:
    """The confusion matrix with the free-space row zeroed: end points only (what IoU uses)."""
    cm = np.array(cm, copy=True)
    cm[N_LABELS:] = 0
    return cm


# --------------------------------------------------------------------------------------------
# All models x grid sizes
# --------------------------------------------------------------------------------------------

BASELINE = "log-odds"
MODEL_NAMES = {0: BASELINE, 1: "CSM", 2: "Continuous CSM", 3: "S-CSM", 4: "Continuous S-CSM"}
COLUMNS = ("model", "task", "grid_size", "auc", "coverage", "unobserved", "occupied_recall",
           "free_accuracy", "accuracy", "label_accuracy", "miou", "n_scored", "build_seconds")


@dataclass
class Split:
    """A mapping / held-out split of the Intel data with its held-out samples (both datasets)."""
    mapping: np.ndarray
    held_out: np.ndarray
    samples: HeldOut           # from the semantic scans: labels on end points
    every: int = HOLD_OUT_EVERY


_split_cache: dict = {}


def intel_split(every: int = HOLD_OUT_EVERY, offset: int | None = None, step: float = FREE_STEP,
                margin: float = FREE_MARGIN) -> Split:
    """The default held-out split of the Intel data and its samples (cached per process).

    The binary and semantic Intel files hold the same poses and beam end points (the semantic one
    adds the label row), so one sample set, taken from the semantic file, scores every model.
    """
    from ..tasks import load_task_data
    key = (every, offset, step, margin)
    if key not in _split_cache:
        sem = load_task_data(3)
        mapping, held = split_scans(len(sem.scans), every, offset)
        _split_cache[key] = Split(mapping, held, held_out_samples(sem, held, step, margin), every)
    return _split_cache[key]


def mapping_data(task: int, split: Split) -> _data.IntelData:
    """The mapping scans of the data task ``task`` uses (semantic copy for tasks 3, 4)."""
    from ..tasks import load_task_data
    return subset(load_task_data(task), split.mapping)


_tuned_cache: dict = {}


def tuned_logodds(grid_size: float, split: Split | None = None, **kw) -> tuple:
    """The log-odds baseline's increments and clamp, tuned on validation scans of the mapping set.

    :func:`hw4.evaluation.logodds.tune_logodds` on the mapping scans of ``split`` (one in ten of them set
    aside for validation; the held-out test scans are never used), maximising the AUC of
    :func:`score_map` on the validation scans' samples (same step and margin as the split).
    Cached per process. Returns ``(best, rows)`` as :func:`~hw4.evaluation.logodds.tune_logodds` does.
    """
    from .logodds import tune_logodds
    split = split or intel_split()
    key = (float(grid_size), split.every, tuple(split.held_out[:3]), split.samples.step,
           split.samples.margin, tuple(sorted(kw.items())))
    if key not in _tuned_cache:
        step, margin = split.samples.step, split.samples.margin

        samples = {}

        def score(m, val):
            if id(val) not in samples:   # one validation set per tuning: its samples once
                samples[id(val)] = held_out_samples(val, np.arange(len(val.scans)), step, margin)
            return score_map(m, samples[id(val)], keep_roc=False)["auc"]

        _tuned_cache[key] = tune_logodds(grid_size, mapping_data(1, split), score, **kw)
    return _tuned_cache[key]


def build_eval_map(task: int, grid_size: float, split: Split | None = None, tuned: bool = True,
                   **kw):
    """Build the map of task 1..4, or the log-odds baseline (``task=0``), from the mapping scans.

    The baseline uses the increments and clamp of :func:`tuned_logodds` unless ``tuned=False``
    (then the course example's 3, -3 and no clamp, or those given in ``kw``).
    """
    from ..tasks import build_map
    split = split or intel_split()
    if task == 0:
        from .logodds import build_logodds
        if tuned:
            kw = {**tuned_logodds(grid_size, split, **kw)[0], **kw}
        return build_logodds(grid_size, mapping_data(1, split), **kw)
    return build_map(task, grid_size, data=mapping_data(task, split), **kw)


def evaluate_all(grid_sizes=GRID_SIZES, tasks=(1, 2, 3, 4), baseline: bool = True,
                 split: Split | None = None, keep_roc: bool = True, progress: bool = False,
                 maps: dict | None = None, **model_kw) -> list:
    """Evaluate every model at every grid size (plus the log-odds baseline) on held-out scans.

    Parameters
    ----------
    grid_sizes : sequence of float [m]
        Cell sizes (default the homework's 0.135, 0.27, 0.5).
    tasks : sequence of int
        Homework tasks 1..4 (CSM, continuous CSM, S-CSM, continuous S-CSM).
    baseline : bool
        Add the classical log-odds grid (:mod:`hw4.evaluation.logodds`) at every grid size, as ``task`` 0.
    split : Split, optional
        Mapping / held-out split and samples (default :func:`intel_split`: every 10th scan held
        out, free samples every 0.1 m up to 0.25 m before the end point).
    keep_roc : bool
        Keep each row's ROC curve (``fpr``, ``tpr`` arrays) for plotting.
    progress : bool
        Print one line per map.
    maps : dict, optional
        Receives every built map, keyed by ``(task, grid_size)`` (for bootstrap intervals and
        re-scoring without rebuilding).
    **model_kw
        Passed to every model (e.g. ``nearest_poses=None``); continuous-only keywords (``l``,
        ``sigma``, ``beams``, ``sample_step``) go to tasks 2 and 4 only.

    Returns
    -------
    list of dict, one row per (model, grid size): for each grid size in order, the baseline
    (``task`` 0, if asked) then the tasks in order. Keys: those of :data:`COLUMNS` (``accuracy``,
    ``label_accuracy`` and ``miou`` are NaN for the binary maps) plus the extra keys of
    :func:`score_map` (``fpr``, ``tpr`` when ``keep_roc``; ``iou`` (6,) and ``confusion`` (7, 7)
    for the semantic maps; ``n_samples``, ``coverage_occupied``, ``coverage_free``).
    ``model`` is the display name (:data:`MODEL_NAMES`). Use :func:`as_array` for a structured
    array; the book's table writers are in :mod:`hw4.book`.
    """
    split = split or intel_split()
    cont_only = {"l", "sigma", "beams", "sample_step"}
    rows = []
    for g in grid_sizes:
        for task in ((0,) if baseline else ()) + tuple(tasks):
            kw = {k: v for k, v in model_kw.items() if task in (2, 4) or k not in cont_only}
            t0 = time.perf_counter()
            m = build_eval_map(task, g, split, **kw)
            build = time.perf_counter() - t0
            if maps is not None:
                maps[(task, float(g))] = m
            row = {"model": MODEL_NAMES[task], "task": task, "grid_size": float(g),
                   "accuracy": np.nan, "miou": np.nan, "free_accuracy": np.nan,
                   "label_accuracy": np.nan, "occupied_recall": np.nan,
                   "build_seconds": build}
            row.update(score_map(m, split.samples, keep_roc=keep_roc))
            rows.append(row)
            if progress:
                print(f"{row['model']:>17s} g={g:<5} AUC {row['auc']:.3f} "
                      f"coverage {row['coverage']:.3f} mIoU {row['miou']:.3f}", flush=True)
    return rows


def as_array(rows, columns=COLUMNS) -> np.ndarray:
    """The scalar columns of :func:`evaluate_all` rows as a numpy structured array."""
    kinds = {"model": "U20", "task": "i8", "n_scored": "i8"}
    dtype = [(c, kinds.get(c, "f8")) for c in columns]
    return np.array([tuple(r[c] for c in columns) for r in rows], dtype=dtype)


def select(rows, **where) -> list:
    """Rows whose keys equal the given values, e.g. ``select(rows, task=2, grid_size=0.27)``."""
    return [r for r in rows if all(np.isclose(r[k], v) if isinstance(v, float) else r[k] == v
                                   for k, v in where.items())]

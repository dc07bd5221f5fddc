"""Parameter studies on held-out data: kernel length scale and scale, and template vs fuller options.

The studies build maps from the mapping scans of :func:`hw4.evaluation.evaluate.intel_split` and score them
with :func:`hw4.evaluation.evaluate.score_map`, so their numbers are comparable with the evaluation table.
Build times for the book come from :func:`options_seconds`, timed as the book's other build times
(:func:`hw4.book.best_seconds`: shortest of a few builds of the task's whole Intel file).
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from . import evaluate as ev
from ..core.errors import InputError
from ..core.evidence import count_evidence
from ..core.grid import Grid
from ..core.kernel import SIGMA0
from ..core.posterior import beta_mean_variance, dirichlet_mean_variance
from ..template import PRIOR

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
    :func:`hw4.evaluation.evaluate.score_map` (without ROC curves) and ``median_variance`` (median posterior
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


KERNEL_METRICS = {2: "auc", 4: "miou"}   # what each continuous model's kernel is chosen for


def kernel_validation(lengths=LENGTHS, sigmas=SIGMAS, grid_size: float = 0.135, tasks=(2, 4),
                      split: ev.Split | None = None, every: int = 10, offset: int = 4,
                      metrics: dict | None = None, default=(0.2, SIGMA0)) -> tuple:
    """Choose the kernel's length scale ``l`` and scale ``sigma_0`` on validation scans.

    As :func:`tune_free_weight`: one scan in ``every`` of the *mapping* scans of ``split`` is set
    aside for validation (the held-out test scans are never seen), each continuous model is
    built from the rest for every ``l`` (one build per ``l``; ``sigma_0`` rescales the evidence
    exactly, as in :func:`kernel_study`) and scored on the validation scans' samples. Each task
    is chosen by its own score (``metrics``, default :data:`KERNEL_METRICS`: the continuous CSM
    by occupancy AUC, the continuous S-CSM by mIoU). Equal scores keep the homework's ``l``
    of ``default`` (``(l, sigma_0)``) if it is among them, then its ``sigma_0`` (the most likely
    class, hence the mIoU, does not depend on ``sigma_0``), else the first in the order of
    ``lengths`` x ``sigmas``.

    Returns
    -------
    (chosen, rows): ``chosen`` maps each task to its chosen ``(l, sigma_0)``; ``rows`` holds one
    dict per (task, l, sigma_0): ``task``, ``model``, ``l`` [m], ``sigma``, ``metric`` (the
    name of the task's choosing score), ``n_val``, ``n_fit`` (scans) and the validation scores of
    :func:`hw4.evaluation.evaluate.score_map` (without ROC curves).
    """
    from ..tasks import build_map
    metrics = {**KERNEL_METRICS, **(metrics or {})}
    chosen, rows = {}, []
    for task in tasks:
        fit, samples, n_val = validation_split(task, split, every, offset)
        mine = []
        for l in lengths:
            base = build_map(task, grid_size, data=fit, l=l, sigma=SIGMA0)
            for sg in sigmas:
                m = map_from_counts(base.grid, base.counts * (sg / SIGMA0), base.semantic)
                row = {"task": task, "model": ev.MODEL_NAMES[task], "l": float(l),
                       "sigma": float(sg), "grid_size": float(grid_size),
                       "metric": metrics[task], "n_val": n_val, "n_fit": len(fit.scans),
                       "accuracy": np.nan, "miou": np.nan}
                row.update(ev.score_map(m, samples, keep_roc=False))
                mine.append(row)
        best = max(mine, key=lambda r: (r[r["metric"]], bool(np.isclose(r["l"], default[0])),
                                        bool(np.isclose(r["sigma"], default[1]))))
        chosen[task] = (best["l"], best["sigma"])
        rows += mine
    return chosen, rows


def evidence_totals(counts) -> tuple:
    """(occupied, free) evidence summed over the map: all non-free columns, and the free column."""
    counts = np.asarray(counts, dtype=float)
    return float(counts[:, :-1].sum()), float(counts[:, -1].sum())


def option_kw(task: int, nearest_poses, beams: str):
    """The model keywords of one option of :data:`OPTIONS` for task 1..4, or None if it has none.

    The discrete models (tasks 1, 3) have no ``beams`` option: they run the ``"nearest"``
    options only (their pose option alone), and None marks the others as not applicable.
    """
    if task in (1, 3):
        return None if beams != "nearest" else {"nearest_poses": nearest_poses}
    return {"nearest_poses": nearest_poses, "beams": beams}


def options_seconds(grid_size: float = 0.27, tasks=(1, 2, 4), options=OPTIONS,
                    repeats: int = 3) -> dict:
    """Build time [s] of every (task, option) of :func:`options_study`, timed as the book times maps.

    Each time is the shortest of ``repeats`` builds with :func:`hw4.book.best_seconds`: the
    wall-clock time of the counting and the posterior (``build_ogm``; not loading the data or
    setting up the grid), one process, with the task's whole Intel file as in the chapters' build
    times (not only the mapping scans that :func:`options_study` scores). The options are built
    in turn, ``repeats`` rounds, so that a change in the machine's load hits every option alike;
    the shortest build is the one least slowed down by other processes.

    Returns
    -------
    dict ``(task, nearest_poses, beams) -> seconds``, the keys of :func:`options_study`'s rows.
    """
    from ..book import best_seconds
    if repeats < 1:
        raise InputError(f"repeats must be at least 1; got {repeats!r}.")
    secs: dict = {}
    for _ in range(repeats):
        for task in tasks:
            for _label, npose, beams in options:
                kw = option_kw(task, npose, beams)
                if kw is None:
                    continue
                t = best_seconds(task, grid_size, repeats=1, **kw)
                secs[task, npose, beams] = min(secs.get((task, npose, beams), np.inf), t)
    return secs


def options_study(grid_size: float = 0.27, tasks=(1, 2, 4), options=OPTIONS,
                  split: ev.Split | None = None, maps: dict | None = None) -> list:
    """Template options versus the fuller options of the models, scored on held-out data.

    For each task and option: evidence kept (occupied and free, as a share of the fullest option
    of that task), held-out scores, and build time. The discrete CSM has no ``beams`` option, so
    it runs the two pose options only.

    Returns
    -------
    list of dict: ``task``, ``model``, ``option``, ``nearest_poses``, ``beams``, ``occupied_evidence``,
    ``free_evidence``, ``occupied_kept``, ``free_kept`` (share of the fullest option's evidence),
    ``build_seconds`` (one build of this map from the mapping scans, the counting only, as
    :func:`hw4.tasks.build_map` times it; the book quotes :func:`options_seconds` instead) and the
    scores of :func:`hw4.evaluation.evaluate.score_map` (without ROC curves).
    Pass a dict as ``maps`` to receive the built maps keyed by ``(task, nearest_poses, beams)``.
    """
    split = split or ev.intel_split()
    rows = []
    for task in tasks:
        mine = []
        for label, npose, beams in options:
            kw = option_kw(task, npose, beams)
            if kw is None:
                continue
            m = ev.build_eval_map(task, grid_size, split, **kw)
            secs = m.build_seconds
            if maps is not None:
                maps[(task, npose, beams)] = m
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



MARGINS = (0.1, 0.25, 0.5)  # free-sample margins before the held-out end point [m]


def margin_study(maps: dict, margins=MARGINS, split: ev.Split | None = None) -> list:
    """Held-out scores of already built maps for several end-point margins of the free samples.

    The held-out free samples stop ``margin`` short of each end point (default 0.25 m). Closer to
    the end point they fall in or next to the wall's cell and every map calls some of them
    occupied; farther away they test only open space. Only the samples change: the maps (built
    from the mapping scans of ``split``) are scored as they are.

    Parameters
    ----------
    maps : dict ``(task, grid_size) -> built map``, e.g. from :func:`hw4.evaluation.evaluate.evaluate_all`'s
        ``maps`` argument.
    margins : sequence of float [m]

    Returns
    -------
    list of dict: ``task``, ``model``, ``grid_size``, ``margin`` and the scores of
    :func:`hw4.evaluation.evaluate.score_map` (without ROC curves).
    """
    split = split or ev.intel_split()
    rows = []
    for margin in margins:
        samples = ev.intel_split(split.every, None, split.samples.step, margin).samples
        for (task, g), m in maps.items():
            row = {"task": task, "model": ev.MODEL_NAMES[task], "grid_size": float(g),
                   "margin": float(margin), "accuracy": np.nan, "miou": np.nan}
            row.update(ev.score_map(m, samples, keep_roc=False))
            rows.append(row)
    return rows


FREE_VARIANTS = (  # (key, label, count_evidence keywords, free-evidence factor)
    ("package", "every sample within l, step 0.1 m", {}, 1.0),
    ("closest", "closest sample only", {"free_samples": "closest"}, 1.0),
    ("step_grid", "step = grid size", {"sample_step": None}, 1.0),
    ("free_half", "free weight x 0.5", {}, 0.5),
    ("free_quarter", "free weight x 0.25", {}, 0.25),
    ("free_tenth", "free weight x 0.1", {}, 0.1),
)


def free_sample_study(grid_size: float = 0.135, task: int = 4, variants=FREE_VARIANTS,
                      split: ev.Split | None = None, n_boot: int = 0, seed: int = 0) -> tuple:
    """Held-out scores of a continuous model under the free-sample alternatives.

    Variants (:data:`FREE_VARIANTS`): the package's choice (every sample within ``l``, step
    0.1 m); only the closest sample counting; a step equal to the grid size (``sample_step:
    None`` stands for ``grid_size``); and the free-space evidence multiplied by a factor (same
    counts, free column scaled, posterior recomputed).

    Returns
    -------
    (rows, maps, boot): one row per variant (``key``, ``label``, ``task``, ``grid_size`` and the
    scores of :func:`hw4.evaluation.evaluate.score_map`, without ROC curves); the maps keyed by variant;
    and, when ``n_boot > 0``, :func:`hw4.evaluation.evaluate.bootstrap_scores` of the maps in variant
    order (else None).
    """
    split = split or ev.intel_split()
    rows, maps, built = [], {}, {}
    for key, label, kw, factor in variants:
        kw = {k: (grid_size if (k == "sample_step" and v is None) else v) for k, v in kw.items()}
        tag = tuple(sorted(kw.items()))
        if tag not in built:
            data = ev.mapping_data(task, split)
            semantic = task == 4
            grid = Grid(grid_size, n_classes=7 if semantic else 2)
            scans = data.scans if semantic else [np.asarray(s)[:2] for s in data.scans]
            counts = count_evidence(grid, data.poses, scans, model="continuous",
                                    semantic=semantic, **kw)
            built[tag] = map_from_counts(grid, counts, semantic)
        base = built[tag]
        if factor != 1.0:
            counts = base.counts.copy()
            counts[:, -1] *= factor
            m = map_from_counts(base.grid, counts, base.semantic)
        else:
            m = base
        maps[key] = m
        row = {"key": key, "label": label, "task": task, "model": ev.MODEL_NAMES[task],
               "grid_size": float(grid_size), "accuracy": np.nan, "miou": np.nan}
        row.update(ev.score_map(m, split.samples, keep_roc=False))
        rows.append(row)
    boot = ev.bootstrap_scores([maps[k] for k, *_ in variants], split.samples, n_boot, seed) \
        if n_boot else None
    return rows, maps, boot


FREE_WEIGHTS = (1.0, 0.5, 0.25, 0.1, 0.05, 0.025, 0.01)  # free-evidence factors tried by tune_free_weight


def validation_split(task: int, split: ev.Split | None = None, every: int = 10, offset: int = 4):
    """The mapping scans of ``split`` (the held-out test scans never enter) cut into scans to
    build from and validation scans, one in ``every`` (index ``offset`` mod ``every``).

    Returns
    -------
    (fit, samples, n_val): the task's data of the scans to build from, the validation scans'
    held-out samples (same step and margin as the split) and the number of validation scans.
    """
    split = split or ev.intel_split()
    data = ev.mapping_data(task, split)
    fit_idx, val_idx = ev.split_scans(len(data.scans), every, offset)
    held = ev.subset(data, val_idx)
    samples = ev.held_out_samples(held, np.arange(len(held.scans)), split.samples.step,
                                  split.samples.margin)
    return ev.subset(data, fit_idx), samples, len(val_idx)


def tune_free_weight(grid_size: float = 0.135, factors=FREE_WEIGHTS,
                     split: ev.Split | None = None, every: int = 10, offset: int = 4,
                     metric: str = "miou_all") -> tuple:
    """Choose the free-evidence factor of the continuous S-CSM on validation scans, not test scans.

    As :func:`hw4.evaluation.evaluate.tuned_logodds` does for the log-odds baseline: from the *mapping*
    scans of ``split`` (the held-out test scans are never seen here) one scan in ``every`` (index
    ``offset`` mod ``every``) is set aside for validation; the evidence is counted once from the
    rest (the package's free samples), its free column multiplied by each factor, and each map
    scored on the validation scans' samples (same step and margin as the split) by ``metric``:
    a score of :func:`hw4.evaluation.evaluate.score_map`, or ``miou_all`` (default), the mean IoU over the
    six regions *and* free space from the whole confusion matrix, so that free points called a
    region count against it (the end-point ``miou`` alone only rises as the free weight goes to
    zero). Ties keep the first factor in ``factors``.

    Returns
    -------
    (best, rows): the chosen factor (float) and one dict per factor (``factor``, ``n_val`` scans,
    ``n_fit`` scans, ``miou_all`` and the validation scores, without ROC curves).
    """
    fit, samples, n_val = validation_split(4, split, every, offset)
    grid = Grid(grid_size, n_classes=ev.N_LABELS + 1)
    base = count_evidence(grid, fit.poses, fit.scans, model="continuous", semantic=True)
    rows = []
    for factor in factors:
        counts = base.copy()
        counts[:, -1] *= factor
        row = {"factor": float(factor), "n_fit": len(fit.scans), "n_val": n_val}
        row.update(ev.score_map(map_from_counts(grid, counts, True), samples, keep_roc=False))
        row["miou_all"] = float(np.nanmean(ev.iou_from_confusion(row["confusion"],
                                                                  np.arange(ev.N_LABELS + 1))))
        rows.append(row)
    best = max(rows, key=lambda r: r[metric])   # max keeps the first of equal scores
    return best["factor"], rows


def tune_threshold(task: int = 4, grid_size: float = 0.135, split: ev.Split | None = None,
                   every: int = 10, offset: int = 4, digits: int = 2, **kw) -> tuple:
    """Choose the occupancy threshold a planner should read a map at, on validation scans.

    As :func:`tune_free_weight`: one scan in ``every`` of the *mapping* scans of ``split`` is set
    aside (the held-out test scans are never seen), the map of ``task`` is built from the rest
    (``kw``: its options, e.g. ``beams="all", nearest_poses=None``), and the threshold ``t`` on
    :func:`hw4.evaluation.evaluate.occupancy_score` (1 - P(free) for a semantic map) that maximises the
    balanced accuracy on the validation samples, (occupied recall + free accuracy) / 2, is taken
    half-way between two distinct scores and rounded to ``digits`` decimals (the number the text
    prints; the map is read as occupied where its score is > ``t``).

    Returns
    -------
    (t, row): the threshold [probability] and the validation scores at ``t``
    (:func:`hw4.evaluation.evaluate.threshold_scores` plus ``n_val``, ``balanced``).
    """
    from ..tasks import build_map
    fit, samples, n_val = validation_split(task, split, every, offset)
    m = build_map(task, grid_size, data=fit, **kw)
    cell, scored = ev.scored_cells(m, samples)
    fpr, tpr, thr = ev.roc_curve(ev.occupancy_score(m)[cell[scored]], samples.occupied[scored])
    i = int(np.argmax(tpr[1:] - fpr[1:]))          # point i + 1: score >= thr[i] is occupied
    below = thr[i + 1] if i + 1 < len(thr) else 0.0
    t = round(float((thr[i] + below) / 2), digits)
    row = ev.threshold_scores(m, samples, t)
    row["n_val"] = n_val
    row["balanced"] = (row["occupied_recall"] + row["free_accuracy"]) / 2
    return t, row

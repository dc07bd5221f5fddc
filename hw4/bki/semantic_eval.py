"""Scoring a semantic map against ground-truth labels, as the reference package evaluates it.

The reference node (BKISemanticMapping, ``semantickitti_util.h``, ``query_scan``) looks up, after
inserting scan ``t``, the map's class at every point of scans ``t-10 .. t``: the class of the voxel
that contains the point if that voxel is occupied (its most likely class is not free; the
reference's state ignores ``var_thresh``), else 0. Its evaluation notebook then drops the points
whose ground truth is 0 (unlabeled) and computes per-class IoU. A point in a voxel that is free,
or in no voxel at all, therefore counts as wrong.

Each scan's result file is rewritten at every lookup, so what is scored in the end is each scan
looked up in the map after inserting scan ``min(q + 10, T - 1)``: :func:`run` with
``schedule="reference"``. ``schedule="every"`` accumulates every lookup instead (each scan up to
11 times, in growing maps).

IoU of class ``c``: ``TP / (TP + FP + FN)`` over the scored points; the mIoU is the mean over the
classes present in the ground truth of those points (class 0 excluded).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError
from .kitti import learning_labels, read_bin, read_label
from .scan import Scan, validate_scan
from .training import training_data

SCHEDULES = ("reference", "every")


def confusion(gt: np.ndarray, pred: np.ndarray, num_class: int) -> np.ndarray:
    """(K, K) int64 counts, rows ground truth, columns prediction; points with ``gt == 0`` ignored."""
    gt, pred = np.asarray(gt, np.int64), np.asarray(pred, np.int64)
    if gt.shape != pred.shape:
        raise InputError(f"{gt.size} ground-truth labels for {pred.size} predictions.")
    k = gt > 0
    return np.bincount(gt[k] * num_class + pred[k], minlength=num_class * num_class).reshape(
        num_class, num_class)


@dataclass
class Score:
    """Per-class IoU and mIoU of a confusion matrix.

    Attributes
    ----------
    conf : (K, K) int64, rows ground truth, columns prediction (row 0 is empty)
    iou : (K,) float, NaN for class 0 and for classes absent from the ground truth
    miou : float, mean of the non-NaN entries of ``iou``
    accuracy : float, share of scored points predicted right
    n_points : int, scored points
    """

    conf: np.ndarray
    iou: np.ndarray
    miou: float
    accuracy: float
    n_points: int


def score(conf: np.ndarray) -> Score:
    """IoU per class and mIoU of a confusion matrix (see :class:`Score`)."""
    conf = np.asarray(conf, np.int64)
    tp = np.diag(conf).astype(float)
    gt_n = conf.sum(axis=1).astype(float)
    pred_n = conf[1:].sum(axis=0).astype(float)  # predictions on scored points (gt > 0)
    union = gt_n + pred_n - tp
    present = gt_n > 0
    present[0] = False
    iou = np.full(len(conf), np.nan)
    iou[present] = tp[present] / union[present]
    n = int(gt_n.sum())
    return Score(conf, iou, float(np.mean(iou[present])) if present.any() else float("nan"),
                 float(tp[1:].sum() / n) if n else float("nan"), n)


def _keys(idx: np.ndarray) -> np.ndarray:
    u = np.asarray(idx, np.int64) + (1 << 20)
    return (u[:, 0] << 42) | (u[:, 1] << 21) | u[:, 2]


class Lookup:
    """The map's class at query points: the class of the containing voxel, 0 where none.

    Parameters
    ----------
    view : MapView
    offset : (3,) float [m], optional
        Grid origin: the voxel of ``p`` is ``floor((p - offset) / resolution)`` (0 for our grid;
        :class:`hw4.bki.reference.ShiftedGrid` gives its own).
    """

    def __init__(self, view, offset=0.0):
        self.offset = np.broadcast_to(np.asarray(offset, float), (3,))
        self.r = view.resolution
        keys = _keys(np.floor((view.centres - self.offset) / self.r).astype(np.int64))
        self.order = np.argsort(keys)
        self.keys = keys[self.order]
        self.cls = np.asarray(view.cls)[self.order]

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """(N,) int class of the voxel of each point [m], world frame; 0 for free or no voxel."""
        q = _keys(np.floor((np.asarray(points, float) - self.offset) / self.r).astype(np.int64))
        if len(self.keys) == 0:
            return np.zeros(len(q), np.int64)
        pos = np.minimum(np.searchsorted(self.keys, q), len(self.keys) - 1)
        return np.where(self.keys[pos] == q, self.cls[pos], 0)


def predictions(view, seq, offset=0.0) -> tuple[np.ndarray, np.ndarray]:
    """Ground truth and the map's class at every point of every scan of ``seq`` (concatenated).

    ``seq`` gives the scans in the map's world frame (``.scan(t)``, ``len()``); ``offset`` is the
    map's grid origin (see :class:`Lookup`). Returns two (N,) int arrays.
    """
    look = Lookup(view, offset)
    gts, preds = [], []
    for t in range(len(seq)):
        s = seq.scan(t)
        gts.append(np.asarray(s.labels, np.int64))
        preds.append(look(s.points))
    return np.concatenate(gts), np.concatenate(preds)


def label_score(seq, relabel=None, num_class: int = 20) -> Score:
    """Score per-point labels against the ground truth over every scan of a sequence.

    ``relabel(t, xyz, raw)`` gives the labels to score (e.g. a
    :class:`~hw4.bki.noise.SimulatedSegmenter`); ``None`` scores the ground truth itself.
    ``seq`` is a :class:`~hw4.bki.kitti.SemanticKITTISequence`.
    """
    conf = np.zeros((num_class, num_class), np.int64)
    for t, b in enumerate(seq.bins):
        raw = read_label(seq.label_dir / (b.stem + ".label"))
        gt = learning_labels(raw)
        pred = gt if relabel is None else relabel(int(b.stem) if b.stem.isdigit() else t,
                                                  read_bin(b)[:, :3].astype(float), raw)
        conf += confusion(gt, pred, num_class)
    return score(conf)


@dataclass
class Run:
    """What :func:`run` returns.

    Attributes
    ----------
    map : the map object after the last scan
    score : Score of the map's lookups
    n_hits, n_free : int, training hits and free samples inserted
    insert_s, eval_s : float [s], CPU time of this process spent inserting and scoring (CPU, not
        wall-clock, time: on a shared machine it does not count the waits)
    """

    map: object
    score: Score
    n_hits: int = 0
    n_free: int = 0
    insert_s: float = 0.0
    eval_s: float = 0.0
    views: dict = field(default_factory=dict)


def _checked(scan: Scan, num_class: int) -> Scan:
    """validate_scan, letting label 0 through (unlabeled hits inserted as free evidence)."""
    lab = np.asarray(scan.labels)
    zero = lab == 0
    if not zero.any():
        return validate_scan(scan, num_class)
    v = validate_scan(Scan(scan.points, np.where(zero, 1, lab), scan.origin, scan.name), num_class)
    v.labels[zero] = 0
    return v


def run(insert_seq, query_seq, make_map, cfg, window: int = 10, schedule: str = "reference",
        keep_views=()) -> Run:
    """Map ``insert_seq`` and score the map's lookups at the points of ``query_seq``.

    Parameters
    ----------
    insert_seq, query_seq : objects with ``len()`` and ``.scan(t)`` (e.g.
        :class:`~hw4.bki.kitti.SemanticKITTISequence`) in the same world frame; scan ``t`` of
        ``insert_seq`` is inserted (its labels may be noisy, and may hold 0 for unlabeled hits),
        scan ``q`` of ``query_seq`` carries the ground truth (1..19).
    make_map : callable returning an empty map with ``update(points, labels)``, ``view()`` and
        optionally ``offset`` (see :class:`Lookup`)
    cfg : BKIConfig (``ds_resolution``, ``free_resolution``, ``max_range``, ``num_class``)
    window : int, scans looked up after each insertion are ``t - window .. t``
    schedule : {"reference", "every"} (see the module docstring)
    keep_views : scan indices after which to keep the map's view (``Run.views[t]``)
    """
    if schedule not in SCHEDULES:
        raise InputError(f"unknown schedule {schedule!r}; use one of {', '.join(SCHEDULES)}.")
    T = len(insert_seq)
    if len(query_seq) != T:
        raise InputError(f"{T} scans to insert but {len(query_seq)} to score.")
    K = cfg.num_class
    vmap = make_map()
    conf = np.zeros((K, K), np.int64)
    cache: dict = {}
    out = Run(vmap, None)
    for t in range(T):
        t0 = time.process_time()
        td = training_data(_checked(insert_seq.scan(t), K), cfg.ds_resolution, cfg.free_resolution,
                           cfg.max_range, K)
        vmap.update(td.points, td.labels)
        out.n_hits += td.n_hits
        out.n_free += td.n_free
        t1 = time.process_time()
        if schedule == "every":
            qs = range(max(0, t - window), t + 1)
        else:
            qs = [q for q in range(T) if min(q + window, T - 1) == t]
        if qs or t in keep_views:
            view = vmap.view()
            if t in keep_views:
                out.views[t] = view
            look = Lookup(view, getattr(vmap, "offset", 0.0))
            for q in qs:
                if q not in cache:
                    cache[q] = query_seq.scan(q)
                s = cache[q]
                conf += confusion(s.labels, look(s.points), K)
                if schedule == "reference":
                    cache.pop(q)
            for q in [q for q in cache if q < t + 1 - window]:
                cache.pop(q)
        out.insert_s += t1 - t0
        out.eval_s += time.process_time() - t1
    out.score = score(conf)
    return out

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

The 2024 template's reading of Algorithm 2 (``if d1 < l: alpha += k(d1)`` ``else: beta += ...``:
free evidence only for the (cell, pose) pairs whose cell lies farther than ``l`` from the end
point; the handout's Algorithm 2 adds both) is one more family, with each sample placement
(``free_where='far'`` of :func:`evidence`); its credit is ``else_credit`` of the configuration.

Semantic maps are compared on every class probability (the whole ``n x K`` mean) and on the
variance of the most likely class. A cell where the reference holds no evidence is compared
only where the submission departs from the prior there (a disagreement); a cell both leave at
the prior is not compared, so a map of the right shape with no correct cell scores 0.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import evidence as _ev
from ..core.evidence import count_evidence
from ..core.grid import Grid
from ..core.sensor import Z_MAX, BeamTable
from ..core.posterior import beta_mean_variance, dirichlet_mean_variance
from ..tasks import load_task_data, model_class

L = 0.2
END_READINGS = ("through", "arange", "arange_world")  # per cell, besides 'strict'


ELSE_READING = ("free evidence only for cells farther than l from the end point: the 2024 "
                "template's reading; the handout's Algorithm 2 adds both")


def variants(task: int, grid_size: float) -> list[tuple[str, dict]]:
    """(label, options of :func:`evidence`) of the legitimate variants of a task: each sample
    placement, with free evidence from every pair (the handout) or, the 2024 template's
    ``else``, only from pairs whose cell lies farther than ``l`` from the end point."""
    if not model_class(task).continuous:
        return [("Algorithm 1 as written", {})]
    base = []
    for label, step in (("free samples every 0.1 m (l/2)", 0.1),
                        ("free samples every 2l/3", 2 * L / 3),
                        ("free samples every grid size", grid_size)):
        base.append((label, {"sample_step": step}))
    for label, step in (("every 0.1 m", 0.1), ("every 2l/3", 2 * L / 3),
                        ("every grid size", grid_size)):
        base.append((f"closest free sample only ({label})", {"sample_step": step,
                                                            "free_samples": "closest"}))
    return base + [(f"{label}; {ELSE_READING}", {**o, "free_where": "far"}) for label, o in base]


def variant_credit(opts: dict, cfg: dict | None) -> float:
    """Share of the points a variant can earn (the 2024 ``else`` reading: ``else_credit``)."""
    if opts.get("free_where") == "far":
        return float((cfg or {}).get("else_credit", 1.0))
    return 1.0


_cache: dict = {}


def evidence(task: int, grid_size: float, **opts) -> tuple[Grid, np.ndarray]:
    """(grid, evidence counts) of the exact core for a task, a grid size and variant options
    (those of :func:`hw4.core.evidence.count_evidence`, and ``free_where='far'``: the 2024
    template's ``else``, see :func:`else_evidence`)."""
    key = (task, float(grid_size), tuple(sorted(opts.items())))
    if key not in _cache:
        cls = model_class(task)
        data = load_task_data(task)
        scans = data.scans if cls.semantic else [s[:2] for s in data.scans]
        grid = Grid(grid_size, n_classes=7 if cls.semantic else 2)
        opts = dict(opts)
        if opts.pop("free_where", "always") == "far":
            counts = else_evidence(grid, data.poses, scans, semantic=cls.semantic, **opts)
        else:
            kw = dict(model="continuous" if cls.continuous else "discrete", semantic=cls.semantic)
            if cls.semantic:
                kw["num_labels"] = 6
            counts = count_evidence(grid, data.poses, scans, **kw, **opts)
        _cache[key] = (grid, counts)
    return _cache[key]


def else_evidence(grid: Grid, poses, scans, *, semantic: bool, sample_step: float = 0.1,
                  free_samples: str = "all", sample_count: str = "strict", l: float = L,
                  sigma0: float = 0.1, nearest_poses: int = 16) -> np.ndarray:
    """Evidence (n_cells, K) of Algorithm 2 read as the 2024 template's ``if d1 < l: alpha += k(d1)``
    ``else: beta += k(...)``: a (cell, pose) pair whose cell lies within ``l`` of the beam's end
    point adds occupied evidence only, any other pair free evidence only (every sample within
    ``l``, or the closest, at ``sample_step`` [m]). The same (cell, pose) pairs, nearest beam,
    distances and kernel as :func:`hw4.core.evidence.count_evidence` (its helpers are used)."""
    poses = np.asarray(poses, dtype=float)
    table = BeamTable.from_scans(scans)
    n_classes = 7 if semantic else 2
    cls_hit = table.labels - 1 if semantic else np.zeros(len(table.ranges), dtype=np.int64)
    free = n_classes - 1
    acc = np.zeros(grid.n_cells * n_classes)

    def add(cell, cls, w=None):
        acc[:] += np.bincount(cell * n_classes + cls, weights=w, minlength=acc.size)

    def add_occupied(cell, cls, w=None):
        keep = cls != free
        add(cell[keep], cls[keep], None if w is None else w[keep])

    longest = np.zeros(len(poses))
    np.maximum.at(longest, table.pose_of, table.ranges)
    reach = longest + l + 1e-6
    for cell, pose, r, phi in _ev._pairs(grid, poses, nearest_poses, Z_MAX, False, reach):
        k, diff = table.nearest(pose, phi, return_diff=True)
        zk = table.ranges[k]
        gap = np.maximum(np.where(diff < np.pi / 2, r * np.sin(diff), r), r - zk)
        near = gap < l + 1e-9
        cell, pose, k, zk = cell[near], pose[near], k[near], zk[near]
        p = poses[pose]
        theta = table.bearings[k] + p[:, 2]
        cxy = grid.cells[cell]
        d1 = np.sqrt((cxy[:, 0] - (p[:, 0] + zk * np.cos(theta))) ** 2
                     + (cxy[:, 1] - (p[:, 1] + zk * np.sin(theta))) ** 2)
        hit = d1 < l
        for sel, how in ((hit, add_occupied), (~hit, add)):
            _ev._continuous_nearest(grid, poses, table, cls_hit, free, how, cell[sel], pose[sel],
                                    k[sel], sigma0, l, sample_step, free_samples == "closest",
                                    sample_count)
    return acc.reshape(grid.n_cells, n_classes)


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
    ref_value: np.ndarray = field(repr=False)  # (n,) the reference's mean (semantic: its class)
    ref_var: np.ndarray = field(repr=False)
    label: str = ""
    prior: float = 0.0
    mean_share: float = 0.0      # share of compared cells whose mean (semantic: all K) agrees
    var_share: float = 0.0       # share of compared cells whose variance agrees
    opts: dict = field(default_factory=dict)  # options of evidence() of the variant
    ref_mean: np.ndarray = field(default=None, repr=False)  # (n,) or (n, K) reference mean
    factor: float = 1.0          # share of the points the variant can earn (variant_credit)


def credit(c: Comparison, mean_weight: float, lo: float, hi: float) -> float:
    """Fraction of a task's points: ``mean_weight`` for the means (semantic: every class
    probability), the rest for the variances, each growing linearly from share ``lo`` to
    ``hi``, times the variant's own credit (``c.factor``)."""
    def f(x):
        return float(np.clip((x - lo) / (hi - lo), 0.0, 1.0))
    return c.factor * (mean_weight * f(c.mean_share) + (1 - mean_weight) * f(c.var_share))


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
    any of ``alt_counts``: the other readings of the end point). Compared: the cells any of
    these references observes, and every cell where the submission differs from all of them
    (a cell without evidence where the submission departs from the prior)."""
    mean_ok, var_ok, ref_mean, ref_var = _agree(mean, var, counts, prior, semantic, rtol, atol)
    agree = mean_ok & var_ok
    observed = counts.sum(axis=1) > 0
    for alt in alt_counts or ():
        m2, v2, _, _ = _agree(mean, var, alt, prior, semantic, rtol, atol)
        agree |= m2 & v2
        mean_ok |= m2
        var_ok |= v2
        observed |= alt.sum(axis=1) > 0
    # a cell no reference observes agrees only where the submission leaves it at the prior
    # (mean and variance); departing from the prior there is one disagreement, in both
    mean_ok = np.where(observed, mean_ok, agree)
    var_ok = np.where(observed, var_ok, agree)
    considered = observed | ~agree
    n = int(considered.sum())
    ref_val = np.argmax(ref_mean, axis=1) if semantic else ref_mean
    if not n:
        return Comparison(1.0, 0, agree, ref_val, ref_var, prior=prior, mean_share=1.0,
                          var_share=1.0, ref_mean=ref_mean)
    return Comparison(float(agree[considered].mean()), n, agree, ref_val, ref_var, prior=prior,
                      mean_share=float(mean_ok[considered].mean()),
                      var_share=float(var_ok[considered].mean()), ref_mean=ref_mean)


def _close(a, b, rtol, atol):
    """Per cell: every value of ``a`` within the tolerances of ``b`` ((n,) or (n, K))."""
    ok = np.isclose(a, b, rtol=rtol, atol=atol)
    return ok.all(axis=1) if ok.ndim == 2 else ok


def _agree(mean, var, counts, prior, semantic, rtol, atol):
    """(mean agrees, variance agrees, reference mean, reference variance) per cell; semantic:
    the mean agrees when every class probability does."""
    ref_mean, ref_var = posterior(counts, prior, semantic)
    return _close(mean, ref_mean, rtol, atol), _close(var, ref_var, rtol, atol), ref_mean, ref_var


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


DEFAULT_SCORING = {"mean_weight": 0.5, "zero_credit_share": 0.5, "full_credit_share": 0.99}


def best_match(task: int, grid_size: float, mean, var, priors, rtol: float, atol: float,
               cfg: dict | None = None) -> Comparison:
    """The legitimate variant and prior the submission earns most with (ties: the larger share
    of agreeing cells); ``cfg`` the grading configuration (weights, ``else_credit``)."""
    cfg = {**DEFAULT_SCORING, **(cfg or {})}
    semantic = model_class(task).semantic
    best, best_key = None, None
    for label, opts in variants(task, grid_size):
        factor = variant_credit(opts, cfg)
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
            c.label, c.opts, c.factor = label, dict(opts), factor
            key = (round(credit(c, cfg["mean_weight"], cfg["zero_credit_share"],
                                cfg["full_credit_share"]), 12), round(c.share, 12))
            if best is None or key > best_key:
                best, best_key = c, key
            if best.share == 1.0 and best.factor == 1.0:
                return best
    return best


EXPLAINS = 0.75   # a diagnosis must explain at least this share of the differing cells ...
NEAR_FULL = 0.95  # ... and, applied to the reference, bring the agreement to at least this


def _hypotheses(task: int, grid_size: float, counts, prior: float, opts: dict):
    """(sentence, evidence or None, variance function or None) of each diagnosed bug: a
    deliberately wrong version of the reference of variant ``opts``."""
    cls = model_class(task)
    semantic = cls.semantic
    free = counts.shape[1] - 1
    out = []
    zero_free = counts.copy()
    zero_free[:, free] = 0
    out.append(("free space is never updated (no free-space evidence)", zero_free, None))
    zero_occ = counts.copy()
    zero_occ[:, :free] = 0
    out.append(("occupied (hit) evidence is never added", zero_occ, None))
    out.append(("the map is never updated (every cell keeps its prior)", np.zeros_like(counts),
                None))
    if semantic:
        shifted = np.zeros_like(counts)
        shifted[:, 1:] = counts[:, :free]
        shifted[:, free] += counts[:, free]
        out.append(("label k is stored as k+1 (alpha indexed by the label, not label - 1; "
                    "label 6 lands in free space)", shifted, None))
        swapped = counts.copy()
        swapped[:, [0, free]] = counts[:, [free, 0]]
        out.append(("free-space evidence goes to class 1 (and class 1's to free space)", swapped,
                    None))
        K = counts.shape[1]
        for c in range(K):
            what = "free space" if c == free else f"class {c + 1}"
            out.append((f"the variance is that of {what}, not of the most likely class", None,
                        lambda m, s, c=c: m[:, c] * (1 - m[:, c]) / (s + 1)))
        out.append(("the variance is computed from the mean of the class probabilities (1/K), "
                    "not from the most likely class", None,
                    lambda m, s: m.mean(axis=1) * (1 - m.mean(axis=1)) / (s + 1)))
    else:
        out.append(("alpha and beta are swapped (occupied counted as free)", counts[:, ::-1],
                    None))
    if cls.continuous:
        for length in (0.1, 0.3, 0.4):
            _, c = evidence(task, grid_size, **{**opts, "l": length})
            out.append((f"the kernel length is l = {length:g} m, not 0.2 m", c, None))
        for sigma in (0.01, 0.05, 0.2, 1.0):
            out.append((f"the kernel scale is sigma0 = {sigma:g}, not 0.1", counts * (sigma / 0.1),
                        None))
    else:
        _, cont = evidence(4 if semantic else 2, grid_size)
        out.append(("the continuous (kernel) model was submitted for the discrete task", cont,
                    None))
        _, thin = evidence(task, grid_size, w_obstacle=grid_size)
        out.append(("the obstacle is one grid size thick (w_obstacle = grid_size)", thin, None))
    return out


def diagnose(task: int, grid_size: float, mean, var, best: Comparison, rtol: float, atol: float):
    """What the differences most likely mean: (sentence, share of the differing cells it
    explains, share of the cells agreeing with it) or None.

    Each hypothesis is the reference of the best variant (or of the same sample placement with
    Algorithm 2's both updates, or of the default variant) with one bug applied. It is named only
    when it explains at least ``EXPLAINS`` of the cells that differ from the reference AND the
    submission agrees with it in at least ``NEAR_FULL`` of the cells compared; the one
    explaining most is named. Call it only for a task that loses points."""
    semantic = model_class(task).semantic
    differ = ~best.agree
    if not differ.any():
        return None
    bases = [best.opts, {k: v for k, v in best.opts.items() if k != "free_where"}, {}]
    found = None
    for opts in [dict(o) for o in {tuple(sorted(o.items())): o for o in bases}.values()]:
        _, counts = evidence(task, grid_size, **opts)
        observed = counts.sum(axis=1) > 0
        for text, c, var_fn in _hypotheses(task, grid_size, counts, best.prior, opts):
            if c is not None:
                m_ok, v_ok, _, _ = _agree(mean, var, c, best.prior, semantic, rtol, atol)
                seen = observed | (c.sum(axis=1) > 0)
            else:
                ref_mean, _ = posterior(counts, best.prior, semantic)
                s = (counts + best.prior).sum(axis=1)
                m_ok = _close(mean, ref_mean, rtol, atol)
                v_ok = _close(var, var_fn(ref_mean, s), rtol, atol)
                seen = observed
            ok = m_ok & v_ok
            considered = seen | ~ok | differ
            explained = float(ok[differ].mean())
            share = float(ok[considered].mean())
            if explained >= EXPLAINS and share >= NEAR_FULL and (
                    found is None or (explained, share) > found[1:]):
                found = (text, explained, share)
    return found

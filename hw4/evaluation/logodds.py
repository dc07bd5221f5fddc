"""The classical log-odds occupancy grid, the baseline every robotics student knows.

This is the course's occupancy-grid example (``code-examples/Python/mapping/occupancy_grid_map.py``
of UMich ROB 530): for every cell, the 16 nearest robot poses; for each pose that sees the cell,
the beam nearest in bearing; the inverse sensor model returns

* ``l_occ = 3`` when the cell lies within ``alpha / 2`` (alpha = 2 grid_size) of that beam's
  range, the range is below ``z_max`` and the bearing difference is at most ``beta / 2``
  (beta = 2 pi / 133);
* ``l_free = -3`` when it lies short of the range (same bearing rule);
* the prior ``l_0 = 0`` otherwise,

and the cell's log-odds is the sum of ``l_inv - l_0`` over those poses (the binary Bayes filter),
optionally clamped to ``[-clamp, clamp]``.

These are exactly the discrete counting sensor model's rules (Algorithm 1): every ``l_occ`` is
one of that model's hits and every ``l_free`` one of its pass-throughs. So the log-odds map is
a linear function of the CSM's evidence,

.. math::  l_i = \\operatorname{clip}\\big(l_0 + n^{hit}_i\\,(l_{occ} - l_0)
            + n^{pass}_i\\,(l_{free} - l_0),\\ -c,\\ c\\big),

(the clamp ``c`` applied to the sum; ``c = inf`` is no clamp) and :func:`build_logodds` computes it from :func:`hw4.core.evidence.count_evidence` rather than
repeating the geometry (``tests/test_logodds.py`` checks this against a literal loop).

What the counting model keeps and the log-odds grid throws away: the log-odds is one number per
cell, ``3 (n_hit - n_pass)`` here, so a cell seen 100 times free and 100 times occupied looks like
a cell never seen (both 0), and there is no variance. The Beta posterior keeps both counts.
"""
from __future__ import annotations

import numpy as np

from ..core import data as _data
from ..core.errors import InputError
from ..core.evidence import count_evidence
from ..core.grid import Grid
from ..core.sensor import N_BEAMS, Z_MAX

L_OCC = 3.0    # log-odds of an occupied reading (course example)
L_FREE = -3.0  # log-odds of a free reading (course example)
L_PRIOR = 0.0  # prior log-odds (p = 0.5)


def logodds_from_counts(counts, l_occ: float = L_OCC, l_free: float = L_FREE,
                        l_prior: float = L_PRIOR, clamp: float = np.inf) -> np.ndarray:
    """Log-odds per cell from the discrete CSM's evidence.

    Parameters
    ----------
    counts : (n_cells, 2) array
        Column 0 hits (alpha evidence), column 1 pass-throughs (beta evidence), no prior.
    clamp : float
        The sum is clipped to ``[-clamp, clamp]`` (default ``inf``: no clamp).

    Returns
    -------
    (n_cells,) float log-odds
    ``clip(l_prior + n_hit (l_occ - l_prior) + n_pass (l_free - l_prior), -clamp, clamp)``.
    """
    if not clamp > 0:
        raise InputError(f"clamp must be a positive number (or inf); got {clamp!r}.")
    counts = np.asarray(counts, dtype=float)
    l = l_prior + counts[:, 0] * (l_occ - l_prior) + counts[:, 1] * (l_free - l_prior)
    return np.clip(l, -clamp, clamp)


def probability(logodds) -> np.ndarray:
    """p = 1 - 1 / (1 + exp(l)), computed without overflow."""
    l = np.asarray(logodds, dtype=float)
    return np.where(l >= 0, 1.0 / (1.0 + np.exp(-np.abs(l))),
                    np.exp(-np.abs(l)) / (1.0 + np.exp(-np.abs(l))))


class LogOddsMap:
    """A built log-odds occupancy grid.

    Attributes
    ----------
    grid : Grid
    logodds : (n_cells,) float
    counts : (n_cells, 2) float, the hits and pass-throughs behind it (kept for bookkeeping: the
        log-odds alone cannot tell an unobserved cell from one with as many hits as passes)
    map : dict with ``'logodd'`` and ``'prob'`` (n_cells, 1) as in the course example, and
        ``'mean'`` (= ``'prob'``) so that :func:`hw4.core.plotting.plot_mean` draws it
    observed : (n_cells,) bool, any hit or pass-through
    """

    semantic = False
    name = "log-odds"

    def __init__(self, grid: Grid, counts, l_occ=L_OCC, l_free=L_FREE, l_prior=L_PRIOR,
                 clamp=np.inf):
        self.grid = grid
        self.grid_size = grid.grid_size
        self.counts = np.asarray(counts, dtype=float)
        self.l_occ, self.l_free, self.l_prior, self.clamp = l_occ, l_free, l_prior, clamp
        self.logodds = logodds_from_counts(self.counts, l_occ, l_free, l_prior, clamp)
        p = probability(self.logodds).reshape(-1, 1)
        self.map = {"logodd": self.logodds.reshape(-1, 1), "prob": p, "mean": p}

    @property
    def observed(self) -> np.ndarray:
        return self.counts.sum(axis=1) > 0


def build_logodds(grid_size: float, data: _data.IntelData | None = None, *,
                  l_occ: float = L_OCC, l_free: float = L_FREE, l_prior: float = L_PRIOR,
                  clamp: float = np.inf, nearest_poses: int | None = 16, z_max: float = Z_MAX, n_beams: int = N_BEAMS,
                  **grid_kw) -> LogOddsMap:
    """Build the course's log-odds occupancy grid.

    Parameters
    ----------
    grid_size : float [m]
        Cell size; alpha = 2 grid_size (obstacle thickness).
    data : IntelData, optional
        Poses (T, 3) [m, m, rad] world frame and scans (2, N) [m] robot frame; default the Intel
        sample. Label rows, if any, are ignored.
    l_occ, l_free, l_prior : float
        Inverse sensor model log-odds (course example: 3, -3, 0).
    clamp : float
        Clip the summed log-odds to ``[-clamp, clamp]`` (default inf: none).
    nearest_poses : int or None
        Poses per cell (course example: 16 nearest); None for every pose within ``z_max``.
    z_max : float [m]; n_beams : int (beta = 2 pi / n_beams)
    **grid_kw
        ``range_x``, ``range_y`` of :class:`hw4.core.grid.Grid`.
    """
    import time
    if data is None:
        data = _data.load_intel(semantic=False)
    scans = [np.asarray(s)[:2] for s in data.scans]
    _data.validate(data.poses, scans)
    grid = Grid(grid_size, **grid_kw)
    t0 = time.perf_counter()
    counts = count_evidence(grid, data.poses, scans, model="discrete", semantic=False,
                            nearest_poses=nearest_poses, z_max=z_max,
                            w_obstacle=2 * grid_size, w_beam=2 * np.pi / n_beams)
    m = LogOddsMap(grid, counts, l_occ, l_free, l_prior, clamp)
    m.build_seconds = time.perf_counter() - t0
    return m


# --------------------------------------------------------------------------------------------
# Tuning on validation scans
# --------------------------------------------------------------------------------------------

L_OCC_GRID = (0.4, 0.85, 1.5, 3.0)      # hit increments tried [log-odds]
L_FREE_GRID = (-0.4, -0.85, -1.5, -3.0)  # miss increments tried [log-odds]
CLAMP_GRID = (np.inf, 20.0, 5.0)         # clamps tried (inf: none)


def tune_logodds(grid_size: float, data: _data.IntelData, score, every: int = 10, offset: int = 4,
                 l_occ_grid=L_OCC_GRID, l_free_grid=L_FREE_GRID, clamp_grid=CLAMP_GRID,
                 **kw) -> tuple:
    """Choose the hit / miss increments and the clamp of the log-odds grid on validation scans.

    ``data`` are the *mapping* scans only (the held-out test scans are never seen here). One
    scan in ``every`` of them (those with index ``offset`` mod ``every``) is set aside for
    validation; the evidence is counted once from the rest, and every combination of the grids
    is scored on the validation scans by ``score(map, validation_data)``, which returns a number
    to maximise (the notebooks pass the held-out AUC of :mod:`hw4.evaluation.evaluate`). Ties keep the
    first combination in grid order.

    Returns
    -------
    (best, rows): ``best`` a dict ``l_occ``, ``l_free``, ``clamp``; ``rows`` one dict per
    combination with those keys and ``score``.
    """
    idx = np.arange(len(data.scans))
    val = idx % every == offset
    inner = _data.IntelData(np.asarray(data.poses)[~val], [data.scans[i] for i in idx[~val]])
    held = _data.IntelData(np.asarray(data.poses)[val], [data.scans[i] for i in idx[val]])
    base = build_logodds(grid_size, inner, **kw)
    rows = []
    for l_occ in l_occ_grid:
        for l_free in l_free_grid:
            for clamp in clamp_grid:
                m = LogOddsMap(base.grid, base.counts, l_occ, l_free, base.l_prior, clamp)
                rows.append({"l_occ": float(l_occ), "l_free": float(l_free),
                             "clamp": float(clamp), "score": float(score(m, held))})
    best = max(rows, key=lambda r: r["score"])
    return {k: best[k] for k in ("l_occ", "l_free", "clamp")}, rows

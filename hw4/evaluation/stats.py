"""Map statistics the book quotes: coverage, uncertainty, labels, and changes between maps.

Every function takes a built map as :func:`hw4.tasks.build_map` returns it (or any object with
the same attributes: ``grid`` (:class:`hw4.core.grid.Grid`), ``map['mean']``, ``map['variance']``,
``map['alpha']``, ``counts`` (evidence without the prior, free space in the last column) and
``semantic``). :func:`from_counts` makes such an object from plain arrays, for tests and for
small hand-made examples.

Cell labels (:func:`cell_labels`) use one convention for both kinds of map, that of the evidence
columns: binary maps ``0`` occupied, ``1`` free; semantic maps ``0..K-2`` the region classes
(label ``c`` of the data is class ``c - 1``) and ``K-1`` free space; ``-1`` (:data:`UNKNOWN`) a
cell without evidence. Areas are in square metres, variances are those of Eq. 3 (binary) or of
the most likely class, Eq. 10 (semantic).
"""
from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ..core.grid import Grid
from ..core.posterior import beta_mean_variance, dirichlet_mean_variance

UNKNOWN = -1  # label of a cell without evidence


def from_counts(grid: Grid, counts, semantic: bool = False, prior: float = 1e-3):
    """A map object from evidence counts, with the package's posterior summaries.

    Parameters
    ----------
    grid : Grid
        Cell centres [m], world frame.
    counts : (n_cells, K) array_like
        Evidence without prior: binary ``K = 2`` (occupied, free), semantic ``K`` classes with
        free space last.
    semantic : bool
        Dirichlet (True) or Beta (False) posterior.
    prior : float
        alpha_0 = beta_0 added to every count.

    Returns
    -------
    SimpleNamespace with ``grid``, ``counts``, ``map`` (``alpha``, ``beta`` if binary, ``mean``,
    ``variance``), ``semantic``, ``num_classes`` (semantic only) and ``observed``.
    """
    counts = np.asarray(counts, dtype=float).reshape(grid.n_cells, -1)
    m = {}
    if semantic:
        m["alpha"] = prior + counts
        m["mean"], m["variance"] = dirichlet_mean_variance(m["alpha"])
    else:
        m["alpha"], m["beta"] = prior + counts[:, 0:1], prior + counts[:, 1:2]
        m["mean"], m["variance"] = beta_mean_variance(m["alpha"], m["beta"])
    ns = SimpleNamespace(grid=grid, counts=counts, map=m, semantic=semantic,
                         observed=counts.sum(axis=1) > 0)
    if semantic:
        ns.num_classes = counts.shape[1] - 1
    return ns


def observed(ogm) -> np.ndarray:
    """(n_cells,) bool: the cell received any evidence (prior excluded)."""
    return np.asarray(ogm.counts).sum(axis=1) > 0


def cell_area(ogm) -> float:
    """Area of one cell [m^2]."""
    return float(ogm.grid.grid_size) ** 2


def observed_share(ogm) -> float:
    """Share of the map's cells that received any evidence, in [0, 1]."""
    return float(observed(ogm).mean())


def observed_area(ogm) -> float:
    """Area covered by cells with evidence [m^2]."""
    return float(observed(ogm).sum()) * cell_area(ogm)


def mean_variance(ogm, observed_only: bool = True) -> float:
    """Mean posterior variance over the observed cells (or over all cells).

    The variance is Eq. 3's Beta variance for binary maps and the variance of the most likely
    class (Eq. 10) for semantic maps; a cell without evidence keeps the prior's variance.
    """
    var = np.asarray(ogm.map["variance"]).reshape(-1)
    if observed_only:
        var = var[observed(ogm)]
    return float(var.mean()) if var.size else float("nan")


def evidence_per_cell(ogm) -> float:
    """Mean total evidence (sum of the counts, prior excluded) over the observed cells."""
    c = np.asarray(ogm.counts)
    obs = observed(ogm)
    return float(c[obs].sum(axis=1).mean()) if obs.any() else 0.0


def cell_labels(ogm, threshold: float = 0.5) -> np.ndarray:
    """(n_cells,) int label of every cell: most likely class, or :data:`UNKNOWN`.

    Binary maps: ``0`` occupied where ``E[theta] > threshold``, else ``1`` free. Semantic maps:
    index of the largest concentration (first on ties), free space being the last index.
    Cells without evidence are :data:`UNKNOWN` (-1) either way.
    """
    if ogm.semantic:
        lab = np.argmax(np.asarray(ogm.map["alpha"]), axis=1)
    else:
        lab = np.where(np.asarray(ogm.map["mean"]).reshape(-1) > threshold, 0, 1)
    return np.where(observed(ogm), lab, UNKNOWN).astype(np.int64)


def free_label(ogm) -> int:
    """The label of free space: 1 for binary maps, the last class index for semantic maps."""
    return int(np.asarray(ogm.counts).shape[1] - 1)


def label_counts(ogm, threshold: float = 0.5) -> np.ndarray:
    """Cells per label, (K,) int: index ``k`` counts cells labelled ``k`` (unknown excluded)."""
    lab = cell_labels(ogm, threshold)
    return np.bincount(lab[lab >= 0], minlength=free_label(ogm) + 1)


def occupied_cells(ogm, threshold: float = 0.5) -> int:
    """Observed cells whose most likely state is not free space (occupied, or a region class)."""
    lab = cell_labels(ogm, threshold)
    return int(((lab >= 0) & (lab != free_label(ogm))).sum())


def occupied_area(ogm, threshold: float = 0.5) -> float:
    """Area of the cells :func:`occupied_cells` counts [m^2]."""
    return occupied_cells(ogm, threshold) * cell_area(ogm)


def interior_gaps(ogm) -> int:
    """Cells without evidence whose four edge neighbours all have evidence.

    Such one-cell holes inside mapped space are left where no beam's counted region reached
    the cell although every neighbour was reached (sparse beams far from the robot).
    """
    obs = observed(ogm).reshape(ogm.grid.shape)
    inner = ~obs[1:-1, 1:-1]
    around = obs[:-2, 1:-1] & obs[2:, 1:-1] & obs[1:-1, :-2] & obs[1:-1, 2:]
    return int((inner & around).sum())


def labels_at(ogm, points, threshold: float = 0.5) -> np.ndarray:
    """Label of the map's cell nearest to each point, :data:`UNKNOWN` outside the map.

    points : (N, 2) array [m], world frame.
    """
    idx = ogm.grid.nearest_cell(points)
    lab = cell_labels(ogm, threshold)
    return np.where(idx >= 0, lab[np.maximum(idx, 0)], UNKNOWN)


@dataclass
class LabelChange:
    """Outcome of :func:`compare_labels` (counts are cells of the reference map).

    Attributes
    ----------
    compared : int
        Reference cells observed in both maps (at the reference cell centre).
    changed : int
        Of those, cells whose label differs.
    to_free, from_free : int
        Changed cells that the other map calls free (reference not free), and the reverse.
    only_reference, only_other : int
        Reference cells observed in one map only.
    region_compared : int
        Compared cells that the reference map calls occupied (a region of a semantic map).
    region_kept : int
        Of those, cells the other map also calls occupied (any region).
    region_swapped : int
        Of those, cells the other map gives another region (semantic maps; 0 for binary maps).
    """
    compared: int
    changed: int
    to_free: int
    from_free: int
    only_reference: int
    only_other: int
    region_compared: int = 0
    region_kept: int = 0
    region_swapped: int = 0

    @property
    def share_changed(self) -> float:
        """changed / compared, in [0, 1] (nan when nothing is compared)."""
        return self.changed / self.compared if self.compared else float("nan")

    @property
    def share_swapped(self) -> float:
        """region_swapped / region_compared: the share of the reference's occupied (region)
        cells that the other map puts in another region, in [0, 1] (nan without such cells)."""
        return self.region_swapped / self.region_compared if self.region_compared else float("nan")

    @property
    def share_swapped_kept(self) -> float:
        """region_swapped / region_kept: of the reference's region cells that the other map
        still calls a region, the share in another region, in [0, 1] (nan without such cells)."""
        return self.region_swapped / self.region_kept if self.region_kept else float("nan")


def compare_labels(reference, other, threshold: float = 0.5) -> LabelChange:
    """Compare two maps' labels at the reference map's cell centres.

    The other map (e.g. a coarser one, or another model) is sampled at every reference cell
    centre through its nearest cell, so maps of different resolution are compared on the
    reference's grid: each count below is a number of reference cells.

    Parameters
    ----------
    reference, other : built maps of the same kind (both binary or both semantic)
    threshold : float
        Occupancy threshold of binary maps (see :func:`cell_labels`).
    """
    if bool(reference.semantic) != bool(other.semantic):
        raise ValueError("compare_labels needs two binary or two semantic maps.")
    a = cell_labels(reference, threshold)
    b = labels_at(other, reference.grid.cells, threshold)
    free = free_label(reference)
    both = (a >= 0) & (b >= 0)
    diff = both & (a != b)
    region = both & (a != free)                  # the reference's occupied / region cells
    kept = region & (b != free)
    return LabelChange(
        compared=int(both.sum()), changed=int(diff.sum()),
        to_free=int((diff & (b == free)).sum()), from_free=int((diff & (a == free)).sum()),
        only_reference=int(((a >= 0) & (b < 0)).sum()), only_other=int(((a < 0) & (b >= 0)).sum()),
        region_compared=int(region.sum()), region_kept=int(kept.sum()),
        region_swapped=int((kept & (b != a)).sum()))


def occupied_recall(reference, other, radius: float, threshold: float = 0.5) -> float:
    """Share of the reference map's occupied cells that the other map also marks nearby.

    A reference cell counts as kept when the other map has an occupied cell (label not free,
    see :func:`cell_labels`) whose centre lies within ``radius`` [m] of the reference cell's
    centre. With ``radius`` one cell of the coarser map this measures how much of a fine map's
    walls a coarse map keeps, independently of how thick it draws them.

    Returns a share in [0, 1] (nan when the reference has no occupied cell).
    """
    from scipy.spatial import cKDTree

    def occupied_centres(ogm):
        lab = cell_labels(ogm, threshold)
        return ogm.grid.cells[(lab >= 0) & (lab != free_label(ogm))]

    a, b = occupied_centres(reference), occupied_centres(other)
    if len(a) == 0:
        return float("nan")
    if len(b) == 0:
        return 0.0
    d, _ = cKDTree(b).query(a)
    return float((d <= radius + 1e-9).mean())


def summary(ogm, threshold: float = 0.5) -> dict:
    """The numbers a chapter quotes about one map, as plain Python numbers.

    Keys: ``grid_size`` [m], ``cells``, ``observed_share`` [0-1], ``observed_area`` [m^2],
    ``occupied_cells``, ``occupied_area`` [m^2], ``mean_variance`` (observed cells),
    ``evidence_per_cell`` (observed cells), ``interior_gaps``.
    """
    return {
        "grid_size": float(ogm.grid.grid_size),
        "cells": int(ogm.grid.n_cells),
        "observed_share": observed_share(ogm),
        "observed_area": observed_area(ogm),
        "occupied_cells": occupied_cells(ogm, threshold),
        "occupied_area": occupied_area(ogm, threshold),
        "mean_variance": mean_variance(ogm),
        "evidence_per_cell": evidence_per_cell(ogm),
        "interior_gaps": interior_gaps(ogm),
    }


def seed_interval(values, level: float = 0.95) -> dict:
    """Mean of a score over repeated runs with different seeds, and its interval.

    For a study whose input is random (e.g. the simulated segmenter of Task 5's beyond section,
    one run per seed), the runs are independent draws: the interval is Student's t interval of
    the mean, ``mean +- t_{(1+level)/2, n-1} * sd / sqrt(n)``, with ``sd`` the sample standard
    deviation (``ddof=1``) over the ``n`` seeds.

    Parameters
    ----------
    values : (n,) or (n, ...) array_like
        One score per seed along the first axis (more axes: one interval per entry, e.g. per
        error rate and map).
    level : float
        Coverage, strictly between 0 and 1.

    Returns
    -------
    dict of arrays (scalars for 1-D input): ``mean``, ``sd``, ``lo``, ``hi``, ``min``, ``max``
    and ``n`` (seeds).
    """
    from scipy.stats import t as student_t

    from ..core.errors import InputError
    v = np.asarray(values, dtype=float)
    if v.ndim == 0 or v.shape[0] < 2:
        raise InputError("seed_interval needs scores from at least two seeds (first axis).")
    if not np.all(np.isfinite(v)):
        raise InputError("seed_interval: the scores contain NaN or inf.")
    if not 0 < level < 1:
        raise InputError(f"level must lie strictly between 0 and 1; got {level!r}.")
    n = v.shape[0]
    mean, sd = v.mean(axis=0), v.std(axis=0, ddof=1)
    half = student_t.ppf((1 + level) / 2, n - 1) * sd / np.sqrt(n)
    out = {"mean": mean, "sd": sd, "lo": mean - half, "hi": mean + half, "min": v.min(axis=0),
           "max": v.max(axis=0), "n": n}
    return {k: (float(x) if np.ndim(x) == 0 else x) for k, x in out.items()}

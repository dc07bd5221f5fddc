"""The counting core: evidence per cell for the four counting sensor models.

One function, :func:`count_evidence`, computes the pseudo-counts that Algorithms 1 and 2 of the
homework (and their semantic versions, Eqs. 8 and 9) add to every cell, as a plain
``(n_cells, K)`` array; priors and posteriors live in :mod:`hw4.core.posterior`.

Columns: binary models ``K = 2`` (column 0 occupied = alpha, column 1 free = beta);
semantic models ``K = num_labels + 1`` (column ``c - 1`` for label ``c``, free space last).

How the loops of the template become array code
-----------------------------------------------
The template loops over cells, over the 16 poses nearest to each cell, and (inside
``nanargmin``) over beams. Here the (cell, pose) pairs of a block of cells are built at once
(KD-tree query), the pairs outside the perceptual field are dropped, and the nearest beam of
every pair comes from a per-pose sorted bearing index (:class:`hw4.core.sensor.BeamTable`). The
continuous model then evaluates, per pair, only the free samples that can lie within ``l`` of
the cell (at most ``2 l / step + 2`` of them), computed with the same floating-point steps as
the loop. Counts are summed with ``np.bincount``. With ``beams='all'`` the loop runs over poses
instead, each pose's end points and free samples being matched to the grid cells within ``l``.
"""
from __future__ import annotations

import os

import numpy as np

from .errors import InputError
from .grid import Grid
from .kernel import LENGTH, SIGMA0, sparse_kernel
from .sensor import N_BEAMS, Z_MAX, BeamTable, in_field, relative

last_stats: dict = {}  # work counted by the last compiled count_evidence call (pairs, samples)
PAIRS_PER_BLOCK = 1 << 21  # (cell, pose) pairs processed at once; bounds the working memory
SAMPLE_STEP = 0.1          # default free-sample spacing along a beam [m] (= l / 2)
MAX_SAMPLE_CHECKS = 2e9    # refuse runs needing more (pair, free sample) or (sample, cell) checks
MAX_WORK_BYTES = 4 * 2**30  # refuse runs whose per-pose working arrays would exceed this
COMPILED_FROM = 250_000   # (cell, pose) pairs from which engine='auto' runs the compiled kernels
BYTES_PER_CHECK = 64       # all-beams working memory per (sample, cell) candidate [bytes]
BRUTE_KNN = 8_000_000      # (cell, pose) distances up to which nearest_pose_query compares all
KNN_CHUNK = 128            # cells per chunk of that comparison


def _refuse_heavy(grid, poses, table, model, beams, nearest_poses, l, step) -> None:
    """Estimate the work (and for beams='all' the memory) up front; refuse with the numbers.

    Nearest beam: every considered (cell, pose) pair tests at most ``min(2 l / step + 2, samples
    on the longest beam + 1)`` free samples. All beams: every beam end point and free sample is
    compared with the ``(2 ceil(l / g) + 3)^2`` cells around it, one pose at a time.
    """
    if model != "continuous":
        return
    n_poses = len(poses)
    z = table.ranges
    if beams == "nearest":
        per_cell = n_poses if nearest_poses is None else min(nearest_poses, n_poses)
        per_pair = min(np.ceil(2 * l / step) + 2, float(z.max()) / step + 2)
        checks = float(grid.n_cells) * per_cell * per_pair
        if checks > MAX_SAMPLE_CHECKS:
            raise InputError(
                f"sample_step {step:g} m with l {l:g} m means up to {per_pair:.3g} free samples per "
                f"(cell, pose) pair, about {checks:.3g} checks for {grid.n_cells:,} cells x "
                f"{per_cell} poses, more than the limit of {MAX_SAMPLE_CHECKS:.0e}: use a larger "
                "sample_step, a smaller l, fewer nearest_poses or a larger grid_size.")
        return
    side = 2.0 * (np.ceil(l / grid.grid_size) + 1) + 1
    samples = np.bincount(table.pose_of, weights=z / step + 2, minlength=n_poses)  # floats
    worst = float(samples.max()) * side ** 2
    total = float(samples.sum()) * side ** 2
    need = worst * BYTES_PER_CHECK
    if need > MAX_WORK_BYTES or total > MAX_SAMPLE_CHECKS * 10:
        t = int(np.argmax(samples))
        raise InputError(
            f"beams='all' with sample_step {step:g} m and l {l:g} m places {samples[t]:.3g} end "
            f"points and free samples on the beams of pose {t} (longest beam {z[table.pose_of == t].max():.3g} m), "
            f"each checked against {side ** 2:.0f} cells: about {need / 2**30:.3g} GiB of working "
            f"memory and {total:.3g} checks in all, more than the limits of "
            f"{MAX_WORK_BYTES / 2**30:.0f} GiB and {MAX_SAMPLE_CHECKS * 10:.0e}: use a larger "
            "sample_step or a smaller l, or drop the beams longer than z_max.")


def _check(value, name, lo=0.0, allow_none=False):
    if value is None and allow_none:
        return
    try:
        finite = np.isscalar(value) and not isinstance(value, (str, bytes)) \
            and np.isfinite(float(value))
    except (OverflowError, TypeError, ValueError):
        finite = False
    if isinstance(value, bool) or not finite or value <= lo:
        raise InputError(f"{name} must be a finite number greater than {lo:g}; got {value!r}.")


def count_evidence(grid: Grid, poses, scans, *, model: str = "discrete", semantic: bool = False,
                   nearest_poses: int | None = 16, beams: str = "nearest", z_max: float = Z_MAX,
                   w_obstacle: float | None = None, w_beam: float = 2 * np.pi / N_BEAMS,
                   sigma0: float = SIGMA0, l: float = LENGTH, sample_step: float = SAMPLE_STEP,
                   num_labels: int = 6, progress: bool = False,
                   free_samples: str = "all", sample_count: str = "strict",
                   engine: str | None = None, stats: dict | None = None) -> np.ndarray:
    """Evidence (pseudo-counts, prior excluded) of every grid cell.

    Parameters
    ----------
    grid : Grid
        Cell centres [m], world frame.
    poses : (T, 3) array [m, m, rad], world frame
        Robot poses (x, y, heading).
    scans : list of T arrays (2, N) or (3, N)
        Beam end points [m] in the robot frame; row 3 holds labels 1..num_labels (semantic).
    model : {'discrete', 'continuous'}
        Algorithm 1 (counting in cells) or Algorithm 2 (sparse-kernel weighted counts).
    semantic : bool
        Dirichlet counts per label plus free space instead of Beta (alpha, beta).
    nearest_poses : int or None
        Poses considered per cell: the ``nearest_poses`` nearest (template: 16), or all poses
        within ``z_max`` when None.
    beams : {'nearest', 'all'}
        Continuous models only: the beam nearest in bearing (Algorithm 2) or every beam of each
        considered pose whose end point or free samples lie within ``l`` (Eqs. 4, 5, 9 in full).
    z_max : float [m]
        Maximum laser range; also the radius of the perceptual field.
    w_obstacle : float [m]
        Obstacle thickness of Algorithm 1 (template: 2 grid_size, the default).
    w_beam : float [rad]
        Beam width of Algorithm 1 (template: 2 pi / 133).
    sigma0, l : float
        Sparse kernel scale and length scale [m].
    sample_step : float [m]
        Spacing of the free samples at s = 0, step, 2 step, ... strictly short of the end point.
    num_labels : int
        Semantic labels 1..num_labels.
    progress : bool
        Show a tqdm progress bar.
    free_samples : {'all', 'closest'}
        Continuous models with ``beams='nearest'``: every free sample within ``l`` of the cell
        counts (Algorithm 2 as written), or only the sample closest to the cell.
    sample_count : {'strict', 'through', 'arange', 'arange_world'}
        Continuous models with ``beams='nearest'``: which free samples ``j step`` a beam of range
        ``z`` has. 'strict' (default): ``j step < z``; 'through': also one on the end point
        (``j step < z + 1e-9``); 'arange': ``len(np.arange(0, z, step))`` of them;
        'arange_world': ``len(np.arange(0, z', step))`` with ``z'`` the range recomputed from
        the end point's world coordinates. The last three are readings of the handout that
        differ from 'strict' only where a sample falls on the end point (the grader accepts them).
    engine : {'auto', 'compiled', 'numpy'}, optional (default: ``HW4_ENGINE``, else 'auto')
        'compiled': the numba kernels of :mod:`hw4.core.compiled`, the same steps per pair;
        'numpy': the vectorised formulation below, the reference the compiled path is tested
        against (``free_samples='closest'`` always runs it); 'auto' (default): compiled for
        runs of at least ``COMPILED_FROM`` (cell, pose) pairs or with beams='all', numpy for
        smaller ones, which finish before numba would have loaded (about 0.5 s). Both give the
        same map (bit for bit on this project's machine; tests/test_compiled.py).
    stats : dict, optional
        Compiled engine: receives ``pairs`` (cell-pose pairs inside the perceptual field, or
        (point, cell) pairs within l for beams='all') and ``samples`` (free samples evaluated);
        the same counts are kept in ``hw4.core.evidence.last_stats`` (for the benchmarks).

    Returns
    -------
    (n_cells, K) float array of evidence, free space in the last column.
    """
    if model not in ("discrete", "continuous"):
        raise InputError(f"model must be 'discrete' or 'continuous'; got {model!r}.")
    if beams not in ("nearest", "all"):
        raise InputError(f"beams must be 'nearest' or 'all'; got {beams!r}.")
    if beams == "all" and model == "discrete":
        raise InputError("beams='all' applies to the continuous models only.")
    if nearest_poses is not None and (isinstance(nearest_poses, bool)
                                      or not isinstance(nearest_poses, (int, np.integer))
                                      or nearest_poses < 1):
        raise InputError(f"nearest_poses must be a positive integer or None; got {nearest_poses!r}.")
    if sample_count not in ("strict", "through", "arange", "arange_world"):
        raise InputError("sample_count must be 'strict', 'through', 'arange' or 'arange_world'; "
                         f"got {sample_count!r}.")
    if free_samples not in ("all", "closest") or (free_samples == "closest" and beams == "all"):
        raise InputError(f"free_samples must be 'all' or 'closest' (the latter with beams='nearest'); "
                         f"got {free_samples!r}.")
    if engine is None:
        engine = os.environ.get("HW4_ENGINE", "auto")
    if engine not in ("auto", "compiled", "numpy"):
        raise InputError(f"engine must be 'auto', 'compiled' or 'numpy'; got {engine!r}.")
    if w_obstacle is None:
        w_obstacle = 2 * grid.grid_size
    for v, name in ((z_max, "z_max"), (w_obstacle, "w_obstacle"), (w_beam, "w_beam"),
                    (sigma0, "sigma0"), (l, "l"), (sample_step, "sample_step")):
        _check(v, name)
    poses = np.asarray(poses, dtype=float)
    if engine == "auto":
        per_cell = len(poses) if nearest_poses is None else min(nearest_poses, len(poses))
        big = beams == "all" or grid.n_cells * per_cell >= COMPILED_FROM
        engine = "compiled" if big else "numpy"
    if poses.ndim != 2 or poses.shape[1] < 3 or not np.isfinite(poses[:, :3]).all():
        raise InputError("poses must be a (T, 3) array of finite x [m], y [m], heading [rad].")
    table = BeamTable.from_scans(scans, compiled=engine == "compiled")
    n_classes = num_labels + 1 if semantic else 2
    if semantic:
        cls_hit = table.labels - 1
        if np.any((cls_hit < 0) | (cls_hit >= num_labels)):
            raise InputError(f"semantic models need labels 1..{num_labels} in row 3 of every scan.")
    else:
        cls_hit = np.zeros(len(table.ranges), dtype=np.int64)
    _refuse_heavy(grid, poses, table, model, beams, nearest_poses, l, sample_step)
    free = n_classes - 1
    longest = _longest(table, len(poses))
    last_stats.clear()
    if engine == "compiled" and free_samples == "all" and np.all(np.diff(table.first) > 0):
        from . import compiled
        stats = last_stats if stats is None else stats
        nn = None if nearest_poses is None else compiled.nearest_poses(
            grid.cells, poses[:, :2], nearest_poses, spacing=grid.grid_size)
        if beams == "all":
            acc = compiled.all_beams_evidence(grid, poses, table, cls_hit, n_classes, nn,
                                              z_max=z_max, sigma0=sigma0, l=l, step=sample_step,
                                              stats=stats)
            if stats is not last_stats:
                last_stats.update(stats)
            return acc
        reach = longest + (w_obstacle / 2 if model == "discrete" else l) + 1e-6
        acc = compiled.cell_evidence(grid.cells, poses, nn, reach, table, cls_hit, n_classes,
                                     continuous=model == "continuous", z_max=z_max,
                                     w_obstacle=w_obstacle, w_beam=w_beam, sigma0=sigma0, l=l,
                                     step=sample_step, sample_count=sample_count, stats=stats,
                                     grid=grid)
        if stats is not last_stats:
            last_stats.update(stats)
        return acc
    acc = np.zeros(grid.n_cells * n_classes)

    def add(cell, cls, w=None):
        acc[:] += np.bincount(cell * n_classes + cls, weights=w, minlength=acc.size)

    if beams == "all":
        _all_beams(grid, poses, table, cls_hit, free, add, nearest_poses, z_max, sigma0, l,
                   sample_step, progress)
        return acc.reshape(grid.n_cells, n_classes)

    # A pose adds nothing to cells beyond its longest beam plus half an obstacle (discrete) or
    # plus l (continuous): skip those pairs before any trigonometry.
    reach = longest + (w_obstacle / 2 if model == "discrete" else l) + 1e-6
    for cell, pose, r, phi in _pairs(grid, poses, nearest_poses, z_max, progress, reach):
        if model == "discrete":  # cells outside every beam's width get nothing
            keep = table.may_reach(pose, phi, w_beam / 2)
            cell, pose, r, phi = cell[keep], pose[keep], r[keep], phi[keep]
        k, bearing_diff = table.nearest(pose, phi, return_diff=True)
        zk = table.ranges[k]
        if model == "discrete":
            half = w_obstacle / 2
            outside = (r > np.minimum(z_max, zk + half)) | (bearing_diff > w_beam / 2)
            hit = ~outside & (zk < z_max) & (np.abs(r - zk) < half)
            passed = ~outside & ~hit & (r < zk) & (zk < z_max)
            add(cell[hit], cls_hit[k[hit]])
            add(cell[passed], np.full(passed.sum(), free))
        else:
            # Every point of the beam lies at least r |sin(diff)| (r when diff >= pi/2) and
            # r - z_k from the cell: pairs farther than l from the whole beam add nothing.
            gap = np.maximum(np.where(bearing_diff < np.pi / 2, r * np.sin(bearing_diff), r),
                             r - zk)
            near = gap < l + 1e-9
            _continuous_nearest(grid, poses, table, cls_hit, free, add, cell[near], pose[near],
                                k[near], sigma0, l, sample_step, free_samples == "closest",
                                sample_count)
    return acc.reshape(grid.n_cells, n_classes)


def _longest(table, n_poses: int) -> np.ndarray:
    """(T,) [m] the longest beam of every pose (0 for a pose without beams): the maximum over
    each pose's block of ranges (``np.maximum.reduceat``; ``np.maximum.at`` on an array of zeros
    gives the same values, ranges being >= 0, four times slower)."""
    longest = np.zeros(n_poses)
    if n_poses and len(table.first) == n_poses + 1 and np.all(np.diff(table.first) > 0):
        np.maximum(np.maximum.reduceat(table.ranges, table.first[:-1]), 0.0, out=longest)
    else:
        np.maximum.at(longest, table.pose_of, table.ranges)
    return longest


def nearest_pose_query(cells, pose_xy, k: int) -> np.ndarray:
    """(n_cells, k) int: the ``k`` nearest poses [m] of every cell centre [m] (world frame),
    nearest first, as ``scipy.spatial.cKDTree(pose_xy).query(cells, k)`` gives them.

    Up to ``BRUTE_KNN`` (cell, pose) pairs (small maps) every squared distance
    ``(cx - px)**2 + (cy - py)**2`` is compared, as the KD-tree compares them, and cells with
    two equal distances among their first k + 1 are asked of the KD-tree; so the answer is the
    KD-tree's, and small runs never import scipy.spatial (a third of a second). Larger maps ask
    the KD-tree for every cell.
    """
    cells = np.asarray(cells, dtype=float)
    pose_xy = np.asarray(pose_xy, dtype=float)
    n = len(pose_xy)
    k = min(int(k), n)
    if len(cells) * n > BRUTE_KNN:
        from scipy.spatial import cKDTree
        _, nn = cKDTree(pose_xy).query(cells, k=k, workers=2)
        return np.reshape(nn, (-1, k))
    m = min(k + 1, n)
    nn = np.empty((len(cells), k), np.int64)
    tie = np.zeros(len(cells), bool)
    for a in range(0, len(cells), KNN_CHUNK):  # chunks of cells whose distances stay in cache
        c = cells[a:a + KNN_CHUNK]
        d2 = (c[:, None, 0] - pose_xy[None, :, 0]) ** 2 + (c[:, None, 1] - pose_xy[None, :, 1]) ** 2
        part = np.argpartition(d2, m - 1, axis=1)[:, :m] if m < n else np.tile(np.arange(n), (len(c), 1))
        dp = np.take_along_axis(d2, part, axis=1)
        order = np.argsort(dp, axis=1, kind="stable")
        ds = np.take_along_axis(dp, order, axis=1)
        nn[a:a + len(c)] = np.take_along_axis(part, order, axis=1)[:, :k]
        tie[a:a + len(c)] = np.any(ds[:, 1:] == ds[:, :-1], axis=1)
    if tie.any():  # the KD-tree's order among equal distances
        from scipy.spatial import cKDTree
        _, nt = cKDTree(pose_xy).query(cells[tie], k=k)
        nn[tie] = np.reshape(nt, (-1, k))
    return nn


def _pairs(grid, poses, nearest_poses, z_max, progress, reach=None):
    """Yield blocks of (cell, pose, r, phi) for the poses each cell considers, inside the field.

    ``reach`` (T,) [m], optional: drop pairs farther than ``reach[pose]`` from the pose first.
    """
    cells = grid.cells
    n_poses = len(poses)
    per_cell = n_poses if nearest_poses is None else min(nearest_poses, n_poses)
    block = max(1, PAIRS_PER_BLOCK // per_cell)
    knn = nearest_pose_query(cells, poses[:, :2], per_cell) if nearest_poses is not None else None
    starts = range(0, len(cells), block)
    if progress and len(starts) > 1:
        from tqdm import tqdm
        starts = tqdm(starts, desc="cells", unit="block", leave=False)
    for s in starts:
        idx = np.arange(s, min(s + block, len(cells)))
        if knn is not None:
            pose = knn[idx].reshape(-1)
        else:
            pose = np.tile(np.arange(n_poses), len(idx))
        cell = np.repeat(idx, per_cell)
        if reach is not None and knn is None:  # all poses: most pairs are out of reach
            near = ((cells[cell, 0] - poses[pose, 0]) ** 2 + (cells[cell, 1] - poses[pose, 1]) ** 2
                    < reach[pose] ** 2)
            cell, pose = cell[near], pose[near]
        r, phi = relative(cells[cell], poses[pose])
        keep = in_field(r, phi, z_max)
        yield cell[keep], pose[keep], r[keep], phi[keep]


def n_samples(z, step):
    """Number of free samples j * step (j = 0, 1, ...) strictly short of range z [m]."""
    n = np.ceil(z / step).astype(np.int64)
    n = np.where((n - 1) * step >= z, n - 1, n)
    return np.where(n * step < z, n + 1, n)


END_TOLERANCE = 1e-9  # [m] a free sample this close past the end point counts as on it


def n_samples_through(z, step):
    """Number of free samples j * step (j = 0, 1, ...) with j * step < z + END_TOLERANCE [m]:
    samples strictly short of the end point, plus one on it (within the last bits of a range
    recomputed from world coordinates, as ``np.arange(0, z', step)`` on such a range does)."""
    n = n_samples(z, step)
    return np.where(n * step < z + END_TOLERANCE, n + 1, n)


def _sample_count(kind, zk, step, p, c, s):
    """Free samples per beam under the reading ``kind`` (see ``count_evidence``)."""
    if kind == "strict":
        return n_samples(zk, step)
    if kind == "through":
        return n_samples_through(zk, step)
    if kind == "arange_world":  # as a loop that recomputes the range from the end point
        zk = np.sqrt((p[:, 0] - (p[:, 0] + zk * c)) ** 2 + (p[:, 1] - (p[:, 1] + zk * s)) ** 2)
    return np.maximum(np.ceil(zk / step), 0).astype(np.int64)


def _continuous_nearest(grid, poses, table, cls_hit, free, add, cell, pose, k, sigma0, l, step,
                        closest=False, sample_count="strict"):
    """Algorithm 2 for (cell, pose) pairs whose nearest beam is ``k`` (``closest``: only the free
    sample nearest to the cell counts)."""
    cells = grid.cells[cell]
    p = poses[pose]
    zk = table.ranges[k]
    theta = table.bearings[k] + p[:, 2]
    c, s = np.cos(theta), np.sin(theta)
    # end point -> occupied evidence
    d1 = np.sqrt((cells[:, 0] - (p[:, 0] + zk * c)) ** 2 + (cells[:, 1] - (p[:, 1] + zk * s)) ** 2)
    near = d1 < l
    add(cell[near], cls_hit[k[near]], sparse_kernel(d1[near], sigma0, l))
    # free samples: only those within l of the cell can count
    dx, dy = cells[:, 0] - p[:, 0], cells[:, 1] - p[:, 1]
    t = dx * c + dy * s
    e = dx * s - dy * c
    m = (np.abs(e) < l) & (t > -l) & (t < zk + l)
    cell, p, zk, c, s, t, cells = cell[m], p[m], zk[m], c[m], s[m], t[m], cells[m]
    count = _sample_count(sample_count, zk, step, p, c, s)
    if closest:  # samples lie on the beam's line: the nearest is the one nearest in t
        j = np.clip(np.rint(t / step).astype(np.int64), 0, count - 1)
        d2 = np.sqrt((cells[:, 0] - (p[:, 0] + j * step * c)) ** 2
                     + (cells[:, 1] - (p[:, 1] + j * step * s)) ** 2)
        near = d2 < l
        add(cell[near], np.full(near.sum(), free), sparse_kernel(d2[near], sigma0, l))
        return
    j_lo = np.maximum(np.floor((t - l) / step).astype(np.int64), 0)
    j_hi = np.minimum(np.ceil((t + l) / step).astype(np.int64), count - 1)
    for o in range(int(np.ceil(2 * l / step)) + 2):
        j = j_lo + o
        ok = j <= j_hi
        if not ok.any():
            break
        sj = j[ok] * step
        d2 = np.sqrt((cells[ok, 0] - (p[ok, 0] + sj * c[ok])) ** 2
                     + (cells[ok, 1] - (p[ok, 1] + sj * s[ok])) ** 2)
        near = d2 < l
        add(cell[ok][near], np.full(near.sum(), free), sparse_kernel(d2[near], sigma0, l))


def _all_beams(grid, poses, table, cls_hit, free, add, nearest_poses, z_max, sigma0, l, step,
               progress):
    """Full kernel sums: every beam of every considered pose, matched to cells within l."""
    n_poses, n_cells = len(poses), grid.n_cells
    selected = None
    if nearest_poses is not None:
        nn = nearest_pose_query(grid.cells, poses[:, :2], nearest_poses)
        order = np.argsort(nn.reshape(-1), kind="stable")
        by_pose = (order // nn.shape[1])  # cells, grouped by the pose they consider
        bounds = np.searchsorted(nn.reshape(-1)[order], np.arange(n_poses + 1))
        selected = np.zeros(n_cells, dtype=bool)
    g = grid.grid_size
    reach = int(np.ceil(l / g)) + 1
    off = np.arange(-reach, reach + 1)
    oy, ox = [a.reshape(-1) for a in np.meshgrid(off, off, indexing="ij")]
    nx, ny = len(grid.x), len(grid.y)
    it = range(n_poses)
    if progress:
        from tqdm import tqdm
        it = tqdm(it, desc="poses", unit="pose", leave=False)
    for t in it:
        b = np.arange(table.first[t], table.first[t + 1])
        px, py, h = poses[t]
        theta = table.bearings[b] + h
        c, s = np.cos(theta), np.sin(theta)
        z = table.ranges[b]
        ns = n_samples(z, step)
        beam = np.repeat(np.arange(len(b)), ns)
        sj = (np.arange(ns.sum()) - np.repeat(np.cumsum(ns) - ns, ns)) * step
        pts = np.concatenate([np.column_stack([px + z * c, py + z * s]),
                              np.column_stack([px + sj * c[beam], py + sj * s[beam]])])
        cls = np.concatenate([cls_hit[b], np.full(len(sj), free)])
        ix = np.rint((pts[:, 0] - grid.x[0]) / g).astype(np.int64)
        iy = np.rint((pts[:, 1] - grid.y[0]) / g).astype(np.int64)
        cx = (ix[:, None] + ox[None, :]).reshape(-1)
        cy = (iy[:, None] + oy[None, :]).reshape(-1)
        pi = np.repeat(np.arange(len(pts)), len(ox))
        inside = (cx >= 0) & (cx < nx) & (cy >= 0) & (cy < ny)
        cx, cy, pi = cx[inside], cy[inside], pi[inside]
        d = np.sqrt((grid.x[cx] - pts[pi, 0]) ** 2 + (grid.y[cy] - pts[pi, 1]) ** 2)
        near = d < l
        cx, cy, pi, d = cx[near], cy[near], pi[near], d[near]
        cell = cy * nx + cx
        if selected is not None:
            mine = by_pose[bounds[t]:bounds[t + 1]]
            selected[mine] = True
            ok = selected[cell]
            selected[mine] = False
            cell, cx, cy, pi, d = cell[ok], cx[ok], cy[ok], pi[ok], d[ok]
        r, phi = relative(np.column_stack([grid.x[cx], grid.y[cy]]), poses[t])
        ok = in_field(r, phi, z_max)
        add(cell[ok], cls[pi[ok]], sparse_kernel(d[ok], sigma0, l))

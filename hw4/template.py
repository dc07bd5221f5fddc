"""The course template's map class, once: the four homework files subclass it.

A template map is built as the students' files are used::

    ogm = ogm_CSM()                          # keyword arguments override parameters
    ogm.construct_map(robotPose, laserScan)  # structures exactly as scipy.io.loadmat returns them
    ogm.build_ogm()
    ogm.map['mean'], ogm.map['variance']

and carries the attributes the course's ``utils.py`` plotting code reads (``map['occMap'].data``,
``map['size']``, ``grid_size``, ``range_x``, ``range_y``, ``num_classes``). The work is done by
:func:`hw4.core.evidence.count_evidence`; this class only converts data on the way in and fills
``self.map`` on the way out.
"""
from __future__ import annotations

import math

import numpy as np

from .core import data as _data
from .core.errors import InputError
from .core.evidence import SAMPLE_STEP, count_evidence
from .core.grid import RANGE_X, RANGE_Y, GRID_SIZE, Grid, check_grid, check_range
from .core.kernel import LENGTH, SIGMA0
from .core.posterior import beta_mean_variance, dirichlet_mean_variance
from .core.sensor import N_BEAMS, Z_MAX

PRIOR = 1e-3  # alpha_0 = beta_0 (per class for the Dirichlet): small and uninformative
MIN_PRIOR = 1e-100  # smaller priors underflow in the variance alpha beta / (s^2 (s + 1))
MAX_SCALE = 1e50    # larger priors or kernel scales overflow s^2 (s + 1) [evidence]


class CellTree:
    """The template's ``scipy.spatial.KDTree`` of some points, built only when used:
    ``map['occMap']`` (the cell centres) and ``pose['mdl']`` (the poses' x, y).

    ``.data`` is the (n, 2) array of points [m], world frame, template order (what the course's
    ``utils.py`` reads), available at once; any other attribute (``query``,
    ``query_ball_point``, ``n``, ...) builds ``KDTree(data)`` on first use and is the tree's.
    Building the cells' tree up front took 16-22 ms of a map's 0.135 m build that the counting
    never uses, and importing scipy.spatial a third of a second of a small run.
    """

    __slots__ = ("data", "_tree")

    def __init__(self, data: np.ndarray):
        self.data = np.ascontiguousarray(data, dtype=np.float64)
        self._tree = None

    @property
    def tree(self):
        """The ``scipy.spatial.KDTree`` of ``data`` (built once)."""
        if self._tree is None:
            from scipy.spatial import KDTree
            self._tree = KDTree(self.data)
        return self._tree

    def __getattr__(self, name):  # only for names not set above: the tree's attributes
        if name.startswith("__") or name in ("data", "_tree", "tree"):
            raise AttributeError(name)  # (copies and pickles look these up before __init__)
        return getattr(self.tree, name)

    def __repr__(self) -> str:
        return f"CellTree({len(self.data)} cell centres; KDTree built on first use)"


def _finite(v) -> bool:
    """True for a finite number (Python ints too large for a float are not)."""
    try:
        return math.isfinite(float(v))
    except OverflowError:
        return False


def _positive(v, name: str, unit: str, hi: float = np.inf) -> float:
    """``v`` when it is a finite number in (0, hi], else :class:`InputError`."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
            or not (_finite(v) and 0 < float(v) <= hi):
        bound = f" and at most {hi:g}" if np.isfinite(hi) else ""
        raise InputError(f"{name} must be a finite positive number{' of ' + unit if unit else ''}"
                         f"{bound}; got {v!r}.")
    return v


class CountingSensorMap:
    """Occupancy (Beta) or semantic (Dirichlet) grid map built with a counting sensor model.

    Keyword parameters (all optional; defaults are the course template's)
    ---------------------------------------------------------------------
    grid_size : float [m]          cell edge length (0.135)
    range_x, range_y : [lo, hi] [m] map extent, world frame ([-15, 20], [-25, 10])
    z_max : float [m]              laser maximum range (30)
    n_beams : int                  beam count defining w_beam = 2 pi / n_beams (133)
    nearest_poses : int or None    poses per cell: 16 nearest (template) or all within z_max
    prior_alpha : float            alpha_0 = beta_0 added to every count (1e-3)
    progress : bool                tqdm progress bar while building
    Continuous models also take ``sigma`` (0.1), ``l`` [m] (0.2), ``sample_step`` [m] (0.1) and
    ``beams`` ('nearest' = Algorithm 2, or 'all' = every beam within l: Eqs. 4, 5, 9 in full).
    """

    continuous = False
    semantic = False

    def __init__(self, grid_size=GRID_SIZE, range_x=RANGE_X, range_y=RANGE_Y, z_max=Z_MAX,
                 n_beams=N_BEAMS, nearest_poses=16, prior_alpha=PRIOR, progress=False, **kw):
        check_range(range_x, "range_x")
        check_range(range_y, "range_y")
        self.range_x = list(range_x)
        self.range_y = list(range_y)
        self.z_max = _positive(z_max, "z_max", "m")
        if isinstance(n_beams, bool) or not isinstance(n_beams, (int, np.integer)) or n_beams < 1:
            raise InputError(f"n_beams must be a positive integer; got {n_beams!r}.")
        self.n_beams = n_beams
        self.grid_size = grid_size
        self.w_obstacle = 2 * grid_size if isinstance(grid_size, (int, float)) else None
        self.w_beam = 2 * np.pi / n_beams
        if nearest_poses is not None and (isinstance(nearest_poses, bool) or not isinstance(
                nearest_poses, (int, np.integer)) or nearest_poses < 1):
            raise InputError(f"nearest_poses must be a positive integer or None (all poses); got "
                             f"{nearest_poses!r}.")
        self.nn = nearest_poses
        self.nearest_poses = nearest_poses
        self.prior = prior_alpha
        self.prior_alpha = prior_alpha
        if not isinstance(progress, (bool, np.bool_)):
            raise InputError(f"progress must be True or False; got {progress!r}.")
        self.progress = bool(progress)
        if self.continuous:
            self.sigma = _positive(kw.pop("sigma", SIGMA0), "sigma", "", hi=MAX_SCALE)
            self.l = _positive(kw.pop("l", LENGTH), "l", "m")
            self.sample_step = _positive(kw.pop("sample_step", SAMPLE_STEP), "sample_step", "m")
            self.beams = kw.pop("beams", "nearest")
            if not isinstance(self.beams, str) or self.beams not in ("nearest", "all"):
                raise InputError(f"beams must be 'nearest' or 'all'; got {self.beams!r}.")
        if self.semantic:
            self.num_classes = kw.pop("num_classes", _data.N_LABELS)
            if isinstance(self.num_classes, bool) or not isinstance(
                    self.num_classes, (int, np.integer)) or not 1 <= self.num_classes <= 1 << 16:
                raise InputError(f"num_classes must be a positive integer (at most 65536); got "
                                 f"{self.num_classes!r}.")
        if kw:
            raise InputError(f"{type(self).__name__} got unknown parameter(s): {', '.join(kw)}.")
        if isinstance(prior_alpha, bool) or not np.isscalar(prior_alpha) or not isinstance(
                prior_alpha, (int, float, np.integer, np.floating)) or not prior_alpha > 0:
            raise InputError(f"prior_alpha must be a positive number; got {prior_alpha!r}.")
        if not MIN_PRIOR <= float(prior_alpha) <= MAX_SCALE:
            raise InputError(f"prior_alpha must lie between {MIN_PRIOR:g} and {MAX_SCALE:g} (beyond, "
                             f"the posterior mean and variance overflow or underflow); got "
                             f"{prior_alpha!r}.")
        check_grid(grid_size, range_x, range_y, self.n_columns)
        self.map = {}
        self.pose = {}
        self.scan = []
        self.m_i = {}
        self.grid = None

    @property
    def n_columns(self) -> int:
        """Evidence columns: 2 (alpha, beta) or num_classes + 1 (free space last)."""
        return self.num_classes + 1 if self.semantic else 2

    def construct_map(self, pose, scan):
        """Set up the grid and the data.

        Parameters
        ----------
        pose : ``robotPose`` struct as ``scipy.io.loadmat`` returns it (fields x, y, h: world
            frame [m, m, rad]), or a (T, 3) array.
        scan : ``laserScan`` cell as ``loadmat`` returns it (each 2xN, or 3xN with labels, robot
            frame [m]), or a list of such arrays.
        """
        poses = _data.real_array(pose, "pose") if isinstance(pose, np.ndarray) and pose.dtype != object \
            and pose.dtype.names is None else _data.poses_from_struct(pose)
        scans = list(scan) if isinstance(scan, list) else _data.scans_from_cell(scan)
        _data.validate(poses, scans, semantic=self.semantic)
        self.grid = Grid(self.grid_size, tuple(self.range_x), tuple(self.range_y), self.n_columns)
        t = self.grid.cells
        self.map['occMap'] = CellTree(t)  # the template's KDTree, built when a student uses it
        self.map['size'] = t.shape[0]
        self.pose = {"x": poses[:, 0:1], "y": poses[:, 1:2], "h": poses[:, 2:3],
                     "mdl": CellTree(poses[:, :2])}  # the template's KDTree of the poses
        self.poses = poses
        self.scans = scans
        self.scan = scan
        if self.semantic:
            self.map['alpha'] = np.full((t.shape[0], self.n_columns), float(self.prior_alpha))
        else:
            self.map['alpha'] = np.full((t.shape[0], 1), float(self.prior_alpha))
            self.map['beta'] = np.full((t.shape[0], 1), float(self.prior_alpha))
        self._summarise(prior=True)

    def evidence_options(self) -> dict:
        """Keyword arguments for :func:`hw4.core.evidence.count_evidence` from this map's parameters."""
        opts = dict(model="continuous" if self.continuous else "discrete", semantic=self.semantic,
                    nearest_poses=self.nearest_poses, z_max=self.z_max, w_beam=self.w_beam,
                    w_obstacle=2 * self.grid_size, progress=self.progress)
        if self.semantic:
            opts["num_labels"] = self.num_classes
        if self.continuous:
            opts.update(beams=self.beams, sigma0=self.sigma, l=self.l, sample_step=self.sample_step)
        return opts

    def build_ogm(self, disable_print=None):
        """Accumulate the evidence of every scan and compute mean and variance of every cell.

        ``disable_print`` (the course's 2024 template): True hides the progress bar, False shows
        it; by default the ``progress`` parameter decides.
        """
        if self.grid is None:
            raise InputError("call construct_map(pose, scan) before build_ogm().")
        opts = self.evidence_options()
        if disable_print is not None:
            opts["progress"] = not bool(disable_print)
        counts = count_evidence(self.grid, self.poses, self.scans, **opts)
        self.counts = counts
        if self.semantic:
            self.map['alpha'] = self.prior_alpha + counts
        else:
            self.map['alpha'] = self.prior_alpha + counts[:, 0:1]
            self.map['beta'] = self.prior_alpha + counts[:, 1:2]
        self._summarise()

    def _summarise(self, prior: bool = False):
        """``map['mean']`` and ``map['variance']`` from ``map['alpha']`` (and ``'beta'``).

        ``prior``: every cell holds the same prior, so the first cell's mean and variance are
        computed and repeated (the same arrays, bit for bit, in a fraction of the time)."""
        n = self.map['alpha'].shape[0]
        rows = slice(0, 1) if prior and n else slice(None)
        if self.semantic:
            mean, var = dirichlet_mean_variance(self.map['alpha'][rows])
        else:
            mean, var = beta_mean_variance(self.map['alpha'][rows], self.map['beta'][rows])
        if prior and n:
            mean, var = np.repeat(mean, n, axis=0), np.repeat(var, n, axis=0)
        self.map['mean'], self.map['variance'] = mean, var
        if not (np.all(np.isfinite(self.map['mean'])) and np.all(np.isfinite(self.map['variance']))):
            raise InputError("the posterior mean or variance is not finite: lower prior_alpha or "
                             "sigma.")

    @property
    def observed(self) -> np.ndarray:
        """(n_cells,) bool: the cell received any evidence."""
        return self.counts.sum(axis=1) > 0

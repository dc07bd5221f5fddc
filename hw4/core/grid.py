"""The map grid: cell centres in the course template's order, and world <-> cell index.

Template convention: centres ``x = np.arange(x_lo, x_hi + g, g)`` and likewise ``y``;
``X, Y = np.meshgrid(x, y)``; cell ``i = iy * len(x) + ix`` has centre ``(x[ix], y[iy])``.
All coordinates are metres in the world frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError

RANGE_X = (-15.0, 20.0)  # template map extent [m], world frame
RANGE_Y = (-25.0, 10.0)
GRID_SIZE = 0.135        # template cell size [m]
MAX_MAP_BYTES = 4 * 2**30  # refuse maps whose arrays would need more than this
BYTES_PER_CELL_CLASS = 48  # alpha, mean, working copies per cell and class [bytes]
BYTES_PER_CELL = 160       # centres, KD-tree, variance, indices per cell [bytes]


def estimate_bytes(n_cells: int, n_classes: int = 2) -> int:
    """Rough peak memory [bytes] of a map with ``n_cells`` cells and ``n_classes`` evidence columns."""
    return int(n_cells) * (BYTES_PER_CELL + BYTES_PER_CELL_CLASS * n_classes)


def _number(v) -> bool:
    return not isinstance(v, bool) and isinstance(v, (int, float, np.integer, np.floating))


def _finite(v) -> bool:
    try:
        return math.isfinite(float(v))
    except OverflowError:
        return False


def check_range(r, name: str) -> tuple:
    """``r`` as a (lo, hi) pair of finite floats [m] with lo < hi, else :class:`InputError`."""
    if isinstance(r, (str, bytes)) or not hasattr(r, "__len__") or len(r) != 2 \
            or not all(_number(v) for v in r):
        raise InputError(f"{name} must be a pair [lo, hi] of numbers in metres; got {r!r}.")
    if not (_finite(r[0]) and _finite(r[1])):
        raise InputError(f"{name} must be finite with lo < hi; got [{r[0]}, {r[1]}].")
    lo, hi = float(r[0]), float(r[1])
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise InputError(f"{name} must be finite with lo < hi; got [{r[0]}, {r[1]}].")
    if max(abs(lo), abs(hi)) > 1e9:
        raise InputError(f"{name} [{r[0]}, {r[1]}] reaches beyond 1e9 m: check the units.")
    return lo, hi


def check_grid(grid_size, range_x=RANGE_X, range_y=RANGE_Y, n_classes: int = 2) -> tuple:
    """Check a grid's parameters and its memory estimate without building it; return (nx, ny).

    Raises :class:`InputError` with one sentence (the estimate in GiB when it is too large).
    """
    g = grid_size
    if not _number(g):
        raise InputError(f"grid_size must be a number of metres; got {g!r}.")
    if not _finite(g) or g <= 0:
        raise InputError(f"grid_size must be a positive number of metres; got {g}.")
    (x0, x1), (y0, y1) = check_range(range_x, "range_x"), check_range(range_y, "range_y")
    g = float(g)
    cells = math.ceil((x1 + g - x0) / g) * 1.0 if (x1 + g - x0) / g < 1e300 else math.inf
    cells *= math.ceil((y1 + g - y0) / g) * 1.0 if (y1 + g - y0) / g < 1e300 else math.inf
    need = float(cells) * (BYTES_PER_CELL + BYTES_PER_CELL_CLASS * float(n_classes))
    if need > MAX_MAP_BYTES:
        many = f"{float(cells):.3g}" if math.isfinite(need) else "more than 1e300"
        gib = (f"about {need / 2**30:.1f}" if need < 1e20 else f"about {need / 2**30:.3g}"
               if math.isfinite(need) else "more than 1e290")
        raise InputError(
            f"grid_size {g:g} m gives {many} cells needing {gib} GiB, "
            f"more than the {MAX_MAP_BYTES / 2**30:.0f} GiB limit: use a larger grid_size.")
    fx, fy = math.ceil((x1 + g - x0) / g), math.ceil((y1 + g - y0) / g)
    return fx, fy


@dataclass
class Grid:
    """A regular 2D grid of cell centres (template convention).

    Parameters
    ----------
    grid_size : float [m]
        Cell edge length.
    range_x, range_y : (float, float) [m], world frame
        Extent of the map; centres start at the lower bound.
    n_classes : int
        Evidence columns per cell (2 binary, 7 semantic); only used for the memory estimate.
    """
    grid_size: float = GRID_SIZE
    range_x: tuple = RANGE_X
    range_y: tuple = RANGE_Y
    n_classes: int = 2
    x: np.ndarray = field(init=False, repr=False)
    y: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        nx, ny = check_grid(self.grid_size, self.range_x, self.range_y, self.n_classes)
        self.grid_size = float(self.grid_size)
        g, x0, y0 = self.grid_size, self.range_x[0], self.range_y[0]
        self.x = np.arange(x0, self.range_x[1] + g, g)
        self.y = np.arange(y0, self.range_y[1] + g, g)
        if (len(self.x), len(self.y)) != (nx, ny):  # never seen; guards the estimate above
            raise InputError(f"grid_size {g} m gives {len(self.x)} x {len(self.y)} cells, not the "
                             f"{nx} x {ny} estimated: choose a grid_size that divides the ranges "
                             "less awkwardly.")

    @property
    def shape(self) -> tuple:
        """(ny, nx): rows are y, columns are x (image order of ``meshgrid(x, y)``)."""
        return (len(self.y), len(self.x))

    @property
    def n_cells(self) -> int:
        return len(self.x) * len(self.y)

    @property
    def cells(self) -> np.ndarray:
        """(n_cells, 2) cell centres [m], world frame, in template order."""
        X, Y = np.meshgrid(self.x, self.y)
        return np.column_stack([X.reshape(-1), Y.reshape(-1)])

    def index(self, ix, iy):
        """Flat cell index of column ``ix`` and row ``iy``."""
        return np.asarray(iy) * len(self.x) + np.asarray(ix)

    def nearest_cell(self, points) -> np.ndarray:
        """Flat index of the cell whose centre is nearest to each point, -1 outside the map.

        points : (N, 2) array [m], world frame.
        """
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        g = self.grid_size
        ix = np.rint((p[:, 0] - self.x[0]) / g).astype(np.int64)
        iy = np.rint((p[:, 1] - self.y[0]) / g).astype(np.int64)
        inside = (ix >= 0) & (ix < len(self.x)) & (iy >= 0) & (iy < len(self.y))
        return np.where(inside, self.index(ix, iy), -1)

    def to_image(self, values) -> np.ndarray:
        """Reshape a per-cell array (n_cells,) or (n_cells, 1) to (ny, nx), row 0 at y[0]."""
        return np.asarray(values).reshape(self.shape)

"""The map grid: cell centres in the course template's order, and world <-> cell index.

Template convention: centres ``x = np.arange(x_lo, x_hi + g, g)`` and likewise ``y``;
``X, Y = np.meshgrid(x, y)``; cell ``i = iy * len(x) + ix`` has centre ``(x[ix], y[iy])``.
All coordinates are metres in the world frame.
"""
from __future__ import annotations

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
        g = self.grid_size
        if isinstance(g, bool) or not isinstance(g, (int, float, np.integer, np.floating)):
            raise InputError(f"grid_size must be a number of metres; got {g!r}.")
        if not np.isfinite(g) or g <= 0:
            raise InputError(f"grid_size must be a positive number of metres; got {g}.")
        (x0, x1), (y0, y1) = self.range_x, self.range_y
        if not (np.all(np.isfinite([x0, x1, y0, y1])) and x1 > x0 and y1 > y0):
            raise InputError(f"map ranges must be finite with lo < hi; got x {self.range_x}, "
                             f"y {self.range_y}.")
        nx = int(np.ceil((x1 + g - x0) / g))
        ny = int(np.ceil((y1 + g - y0) / g))
        need = estimate_bytes(nx * ny, self.n_classes)
        if need > MAX_MAP_BYTES:
            raise InputError(
                f"grid_size {g} m gives {nx * ny:,} cells needing about {need / 2**30:.1f} GiB, "
                f"more than the {MAX_MAP_BYTES / 2**30:.0f} GiB limit: use a larger grid_size.")
        self.x = np.arange(x0, x1 + g, g)
        self.y = np.arange(y0, y1 + g, g)

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

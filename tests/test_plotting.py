"""hw4.core.plotting: cells without evidence get their own colour in the variance map."""
from __future__ import annotations

from types import SimpleNamespace

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from hw4.core import plotting  # noqa: E402
from hw4.core.grid import Grid  # noqa: E402


def _rendered(unobserved):
    """A 4 x 4 cell map whose left half (in the image) has evidence, its variance drawn on a log
    scale filling the figure; returns the figure's RGB pixels."""
    grid = Grid(1.0, (0.0, 3.0), (0.0, 3.0))
    n = len(grid.x) * len(grid.y)
    cell_of_pixel = np.asarray(grid.to_image(np.arange(n)))    # (ny, nx) cell index per pixel
    observed = np.zeros(n, bool)
    observed[cell_of_pixel[:, :2].ravel()] = True
    counts = np.zeros((n, 2))
    counts[observed, 0] = 5
    ogm = SimpleNamespace(grid=grid, counts=counts,
                          map={"variance": np.where(observed, 0.01, 0.2495)})
    fig, ax = plt.subplots(figsize=(2, 2), dpi=50)
    ax.set_position([0, 0, 1, 1])
    plotting.plot_variance(ogm, ax=ax, vmax=0.25, colorbar=False, log=True, vmin=1e-4,
                           unobserved=unobserved)
    ax.set_axis_off()
    fig.canvas.draw()
    rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3] / 255.0
    plt.close(fig)
    return rgb


def test_unobserved_cells_take_their_own_colour_in_the_variance_map():
    grey = np.array(matplotlib.colors.to_rgb(plotting.UNOBSERVED_VARIANCE))
    plain, shaded = _rendered(None), _rendered(plotting.UNOBSERVED_VARIANCE)
    h, w, _ = shaded.shape
    rows = slice(h // 4, 3 * h // 4)
    assert np.allclose(shaded[rows, 7 * w // 8], grey, atol=0.02)          # unobserved: grey
    assert not np.allclose(plain[rows, 7 * w // 8], grey, atol=0.1)        # ... not without it
    assert np.allclose(shaded[rows, w // 8], plain[rows, w // 8], atol=0.02)  # observed unchanged
    assert not np.allclose(shaded[rows, w // 8], grey, atol=0.1)

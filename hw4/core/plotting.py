"""One look for every map in the book, the CLI and the notebooks.

Maps are drawn in metres (world frame) with equal aspect, a colour bar, and a fixed palette:
occupancy from white (free) to black (occupied) with unobserved cells at the prior's grey;
variance in ``viridis``; semantic classes in the course's colours, free space white and
unknown (no evidence) grey.
"""
from __future__ import annotations

import numpy as np
import matplotlib as mpl
import matplotlib.colors  # noqa: F401  (mpl.colors below)
from matplotlib.patches import Patch

# pyplot is imported where a figure is made without an ``ax`` (:func:`_new`, :func:`map_figure`),
# not here: the CLI writes its PNGs through :func:`save_map_png` with the Agg canvas alone, and
# importing pyplot (its backend machinery) costs a small run a good part of its time.

CLASS_NAMES = ["north rooms", "west rooms", "east rooms", "south rooms", "middle rooms", "hallways"]
CLASS_COLORS = np.array([[0.0, 0.447, 0.741], [0.850, 0.325, 0.098], [0.929, 0.694, 0.125],
                         [0.494, 0.184, 0.556], [0.466, 0.674, 0.188], [0.800, 0.475, 0.655]])
# hallways reddish purple (Okabe-Ito #CC79A7), not a second blue next to the north rooms
FREE_COLOR = np.array([1.0, 1.0, 1.0])
UNKNOWN_COLOR = np.array([0.5, 0.5, 0.5])
VARIANCE_CMAP = "viridis"
OCCUPANCY_CMAP = "gray_r"
UNOBSERVED_LIGHT = "#c6dbef"   # pale blue for cells without evidence (plot_mean(unobserved=...))
UNOBSERVED_VARIANCE = "0.82"   # light grey, outside viridis, for them in plot_variance(unobserved=...)
# The two logarithmic variance scales of the book's maps (vmin, vmax): one for the discrete models
# (Tasks 1 and 3, whose cells with agreeing counts reach a few 1e-6) and one for the continuous
# models (Tasks 2 and 4, each observation weighing at most sigma0, so none falls below 1e-4); a
# figure comparing a discrete with a continuous map uses the discrete scale, which holds both.
VARIANCE_LOG_DISCRETE = (4e-6, 0.25)
VARIANCE_LOG_CONTINUOUS = (1e-4, 0.25)
# Figure sizes [in] of one map of the whole building on its own (with its colour bar, or with the
# class legend on its right): small enough that a page shows the map at about its drawn size, so
# that the 8.5-9 pt text of hw4.book.style() prints at 8.5-9 pt, not scaled down to 5 pt.
MAP_FIGSIZE = (4.3, 3.55)
SEMANTIC_MAP_FIGSIZE = (5.5, 3.55)


def style():
    """Set the book's matplotlib defaults (call once in a notebook's setup cell)."""
    mpl.rcParams.update({
        "figure.figsize": (6.0, 5.0), "figure.dpi": 100, "savefig.dpi": 120,
        "savefig.bbox": "tight", "font.size": 10, "axes.titlesize": 11,
        "image.interpolation": "nearest", "axes.grid": False,
    })


def _extent(grid):
    h = grid.grid_size / 2
    return (grid.x[0] - h, grid.x[-1] + h, grid.y[0] - h, grid.y[-1] + h)


def _axes(ax, grid, title):
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    ax.set_xlim(grid.range_x)
    ax.set_ylim(grid.range_y)
    if title:
        ax.set_title(title)


def _new(ax):
    if ax is None:
        import matplotlib.pyplot as plt
        _, ax = plt.subplots()
    return ax


def plot_mean(ogm, ax=None, title=None, colorbar=True, unobserved=None):
    """Occupancy probability E[theta] of a binary map: white free, black occupied, grey unknown.

    ``unobserved``: a matplotlib colour for the cells without evidence (prior excluded) instead
    of the prior's grey, e.g. :data:`UNOBSERVED_LIGHT`, so that black walls stand out against
    the unexplored area.
    """
    ax = _new(ax)
    extent = _extent(ogm.grid)
    im = ax.imshow(ogm.grid.to_image(ogm.map["mean"]), origin="lower", extent=extent,
                   cmap=OCCUPANCY_CMAP, vmin=0, vmax=1)
    if unobserved is not None:
        _shade_unobserved(ax, ogm, unobserved)
    _axes(ax, ogm.grid, title)
    if colorbar:
        ax.figure.colorbar(im, ax=ax, shrink=0.8, label="P(occupied)")
    return im


def _shade_unobserved(ax, ogm, colour) -> None:
    """Paint the cells without evidence (no count of any kind, prior excluded) in ``colour``."""
    empty = ogm.grid.to_image(np.asarray(ogm.counts).sum(axis=1) == 0)
    overlay = np.zeros(empty.shape + (4,))
    overlay[empty] = mpl.colors.to_rgba(colour)
    ax.imshow(overlay, origin="lower", extent=_extent(ogm.grid))


def plot_variance(ogm, ax=None, title=None, vmax=None, colorbar=True, log=False, vmin=1e-4,
                  unobserved=None):
    """Posterior variance per cell (Beta variance, or that of the most likely class).

    ``log``: a logarithmic colour scale from ``vmin`` to ``vmax`` (values below ``vmin`` drawn
    at ``vmin``), so that the differences among observed cells show next to the prior's value.
    ``unobserved``: a matplotlib colour for the cells without evidence instead of the prior's
    variance (which sits at the top of the scale, like the most uncertain walls), e.g.
    :data:`UNOBSERVED_VARIANCE`.
    """
    ax = _new(ax)
    var = ogm.grid.to_image(ogm.map["variance"])
    top = vmax if vmax is not None else float(var.max())
    scale = (dict(norm=mpl.colors.LogNorm(vmin, top, clip=True)) if log
             else dict(vmin=0, vmax=top))
    im = ax.imshow(var, origin="lower", extent=_extent(ogm.grid), cmap=VARIANCE_CMAP, **scale)
    if unobserved is not None:
        _shade_unobserved(ax, ogm, unobserved)
    _axes(ax, ogm.grid, title)
    if colorbar:
        ax.figure.colorbar(im, ax=ax, shrink=0.8, label="variance")
    return im


def semantic_rgb(ogm) -> np.ndarray:
    """(ny, nx, 3) colours of a semantic map: class colour, free white, no evidence grey."""
    cls = np.argmax(ogm.map["alpha"], axis=1)
    palette = np.vstack([CLASS_COLORS[: ogm.num_classes], FREE_COLOR])
    rgb = palette[cls]
    rgb[~ogm.observed] = UNKNOWN_COLOR
    return rgb.reshape(ogm.grid.shape + (3,))


def class_legend(ax, num_classes=6, loc="upper left", **kw):
    """Legend naming the six regions, free space and unknown (outside the axes, on the right,
    one entry a line, unless ``loc``/``bbox_to_anchor`` say otherwise)."""
    if loc == "upper left" and "bbox_to_anchor" not in kw:
        kw["bbox_to_anchor"] = (1.02, 1.0)
        kw.setdefault("borderaxespad", 0.0)
    return ax.legend(handles=class_handles(num_classes, wrap=False), loc=loc, framealpha=0.9,
                     **kw)


def class_label(c: int, wrap: bool = False) -> str:
    """Legend text of the data's label ``c`` (1..6): "label 1 (north rooms)", the number the
    data set gives the region and the handout's name for that number (``wrap``: the name on a
    second line, for legends set in columns under a map)."""
    return f"label {c}{chr(10) if wrap else ' '}({CLASS_NAMES[c - 1]})"


def class_handles(num_classes=6, wrap: bool = True) -> list:
    """Legend handles of the regions (:func:`class_label`), free space and unknown, in the
    maps' colours; ``wrap`` (default, for legends in columns) puts each name on a second line."""
    handles = [Patch(color=CLASS_COLORS[i], label=class_label(i + 1, wrap))
               for i in range(num_classes)]
    handles += [Patch(facecolor=FREE_COLOR, edgecolor="0.6", label="free"),
                Patch(color=UNKNOWN_COLOR, label="unknown")]
    return handles


def plot_semantic(ogm, ax=None, title=None, legend=True):
    """Most likely class per cell of a semantic map, with a legend naming the regions."""
    ax = _new(ax)
    im = ax.imshow(semantic_rgb(ogm), origin="lower", extent=_extent(ogm.grid))
    _axes(ax, ogm.grid, title)
    if legend:
        class_legend(ax, ogm.num_classes)
    return im


def plot_map(ogm, ax=None, title=None, **kw):
    """The map itself: class map for semantic models, occupancy probability otherwise."""
    return (plot_semantic if ogm.semantic else plot_mean)(ogm, ax=ax, title=title, **kw)


def plot_dataset(data, ax=None, every=3, title=None, path_color="crimson"):
    """Robot trajectory and scan end points in the world frame, coloured by label when present.

    data : :class:`hw4.core.data.IntelData`; every : plot every n-th scan (keeps the figure light);
    path_color : matplotlib colour of the trajectory (a dark grey sets it apart from the class
    colours of a semantic data set).
    """
    ax = _new(ax)
    pts, labels = [], []
    for (x, y, h), s in list(zip(data.poses, data.scans))[::every]:
        c, sn = np.cos(h), np.sin(h)
        pts.append(np.column_stack([x + c * s[0] - sn * s[1], y + sn * s[0] + c * s[1]]))
        labels.append(s[2].astype(int) if s.shape[0] == 3 else np.zeros(s.shape[1], int))
    pts, labels = np.concatenate(pts), np.concatenate(labels)
    if data.semantic:
        ax.scatter(pts[:, 0], pts[:, 1], s=0.3, c=CLASS_COLORS[labels - 1], linewidths=0,
                   rasterized=True)
        handles = [Patch(color=CLASS_COLORS[i], label=class_label(i + 1)) for i in range(6)]
    else:
        ax.scatter(pts[:, 0], pts[:, 1], s=0.3, c="k", linewidths=0, rasterized=True)
        handles = []
    (line,) = ax.plot(data.poses[:, 0], data.poses[:, 1], "-", color=path_color, lw=0.8,
                      label="robot path")
    ax.legend(handles=handles + [line], loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8,
              framealpha=0.9)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    if title:
        ax.set_title(title)
    return ax


def map_figure(ogm, title: str):
    """A figure with the map (left) and its variance (right), as the CLI writes them."""
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.8), constrained_layout=True)
    plot_map(ogm, ax=a, title=f"{title}: mean")
    plot_variance(ogm, ax=b, title=f"{title}: variance")
    return fig


def save_map_png(ogm, path, what: str, title: str, figsize=(6.4, 5.4), dpi: float = 100.0,
                 pad_inches: float = 0.1) -> None:
    """Write one map figure as the CLI does: ``what`` ``'mean'`` (:func:`plot_map`) or
    ``'variance'`` (:func:`plot_variance`), titled ``title``, to the PNG file ``path``.

    The figure is laid out at ``figsize`` [in], then cut to its content plus ``pad_inches``
    [in] (the class legend right of a semantic map included): the same pixels as
    ``savefig(bbox_inches='tight')`` at ``dpi`` [pixels per inch], but on a bare Agg canvas (no
    pyplot) and without that option's first, dry drawing of the figure. The axes keep their
    size and place in inches; the figure's edges move to the content's bounding box.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    draw = {"mean": plot_map, "variance": plot_variance}[what]
    fig = Figure(figsize=figsize, dpi=dpi)
    canvas = FigureCanvasAgg(fig)
    draw(ogm, ax=fig.add_subplot(), title=title)
    for ax in fig.axes:
        ax.apply_aspect()                      # the map's equal aspect, before measuring
    box = fig.get_tightbbox(canvas.get_renderer()).padded(pad_inches)  # [in] from the corner
    w, h = fig.get_size_inches()
    places = [ax.get_position().bounds for ax in fig.axes]   # fractions of the w x h figure
    fig.set_size_inches(box.width, box.height)
    for ax, (x, y, dx, dy) in zip(fig.axes, places):          # the same place in inches
        ax.set_position([(x * w - box.x0) / box.width, (y * h - box.y0) / box.height,
                         dx * w / box.width, dy * h / box.height])
    canvas.print_png(path)

"""Helpers the book's chapters share: gluing numbers, timing builds, table writers, zoom windows.

Nothing here computes a map or a score (that is :mod:`hw4.evaluation.evaluate`, :mod:`hw4.evaluation.stats` and the
models); this module only carries results into the book's prose and tables:

* :func:`put` glues one number under a name for ``{glue:text}`` (myst-nb), rounded to 10
  significant digits so that the stored text never hinges on the last bit of a float;
* :func:`best_seconds` times a few builds of one map and keeps the shortest (timings on a shared
  machine are noisy; only cells that nbval does not compare may call it);
* :func:`glue_rows`, :func:`myst_table`, :func:`markdown_table` turn the rows of
  :func:`hw4.evaluation.evaluate.evaluate_all` into glued numbers and tables;
* :func:`zoom` sets an axis onto a named window of the building [m, world frame].
"""
from __future__ import annotations

import numpy as np

# Zoom windows [m], world frame: (x range, y range).
WINDOWS = {
    "south-west": ((-10.0, -1.0), (-24.0, -15.0)),   # south-west rooms (Tasks 1-2)
    "regions": ((-12.0, 0.0), (-22.0, -10.0)),       # where four regions meet (Tasks 3-4)
    "north-east": ((2.0, 19.0), (-9.0, 8.0)),        # north-east rooms and the cluttered lab
    "south-west-wide": ((-12.0, 1.0), (-24.0, -13.0)),  # south-west rooms and corridor (T6)
    "building": ((-12.5, 19.5), (-24.5, 8.0)),       # every observed cell, at every grid size
}


PRINT_WIDTH = 7.0   # [in] width of a full-width figure; the PDF scales it to the text width


def style():
    """The book's plot style: :func:`hw4.core.plotting.style` plus sizes for print.

    Figures are drawn at most :data:`PRINT_WIDTH` wide with 9 pt text, so that the PDF, which
    scales them to the text width, prints no text below 8 pt; 200 dpi so that one-cell walls of
    a full-building map stay visible.
    """
    import matplotlib as mpl
    from ..core import plotting
    plotting.style()
    mpl.rcParams.update({
        "figure.dpi": 200, "savefig.dpi": 200, "font.size": 9, "axes.titlesize": 9.5,
        "axes.labelsize": 9, "xtick.labelsize": 8.5, "ytick.labelsize": 8.5,
        "legend.fontsize": 8.5, "figure.figsize": (PRINT_WIDTH, 3.2),
    })


def _glue():
    from myst_nb import glue  # imported late: the package does not depend on myst-nb
    return glue


def plain(value):
    """A number as a plain Python value: numpy scalars unwrapped, floats to 10 significant digits."""
    value = value.item() if hasattr(value, "item") else value
    if isinstance(value, float):
        value = float(f"{value:.10g}")
    return value


def put(name: str, value, glue=None):
    """Glue ``value`` under ``name`` for the prose (nothing is displayed in place).

    ``glue`` defaults to ``myst_nb.glue``; tests pass a stand-in with the same signature.
    """
    (glue or _glue())(name, plain(value), display=False)


def sci(value, digits: int = 1) -> str:
    """A number as inline maths in powers of ten, e.g. 6.2e-05 -> ``$6.2 \\times 10^{-5}$``."""
    m, e = f"{float(value):.{digits}e}".split("e")
    return f"${m} \\times 10^{{{int(e)}}}$"


def put_sci(name: str, value, digits: int = 1, glue=None):
    """Glue ``value`` as Markdown maths (:func:`sci`) under ``name``, for ``{glue:md}``."""
    if glue is None:
        from IPython.display import Markdown
        _glue()(name, Markdown(sci(value, digits)), display=False)
    else:
        glue(name, sci(value, digits), display=False)


def signed_text(value, digits: int = 3) -> str:
    """A signed number as text with a typographic minus (U+2212): ``+0.035``, ``\u22120.227``.

    Glued by :func:`put` and printed by ``{glue:text}`name``` without a format (myst-nb strips
    the quotes); a format spec such as ``:+.3f`` would print an ASCII hyphen for the minus.
    """
    return f"{float(value):+.{int(digits)}f}".replace("-", "\u2212")


def put_interval(name: str, estimate, interval, glue=None, signed_digits: int | None = None):
    """Glue an estimate and its interval as ``name``, ``name_lo`` and ``name_hi``.

    With ``signed_digits`` also ``name_s``, ``name_lo_s`` and ``name_hi_s``: the three as
    :func:`signed_text` with that many decimals (a minus sign, not a hyphen, in the prose).
    """
    lo, hi = interval
    put(name, estimate, glue)
    put(f"{name}_lo", lo, glue)
    put(f"{name}_hi", hi, glue)
    if signed_digits is not None:
        for suffix, v in (("", estimate), ("_lo", lo), ("_hi", hi)):
            put(f"{name}{suffix}_s", signed_text(v, signed_digits), glue)


def best_seconds(task: int, grid_size: float, repeats: int = 3, **kw) -> float:
    """Shortest build time [s] of ``repeats`` builds of one task's map (see :func:`hw4.tasks.build_map`)."""
    from ..tasks import build_map
    return min(build_map(task, grid_size=grid_size, **kw).build_seconds for _ in range(repeats))


def zoom(ax, window: str):
    """Set the limits of ``ax`` to one of the named :data:`WINDOWS`."""
    (x0, x1), (y0, y1) = WINDOWS[window]
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)


def grid_key(grid_size: float) -> str:
    """Glue-name suffix of a grid size: 0.135 -> '0135', 0.27 -> '027', 0.5 -> '05'."""
    return str(float(grid_size)).replace(".", "")


# --------------------------------------------------------------------------------------------
# Evaluation rows -> glue and tables
# --------------------------------------------------------------------------------------------

def glue_key(row: dict, metric: str, prefix: str = "") -> str:
    """A glue name for one number of a row, e.g. ``auc_t2_g0135`` (task 0 is the baseline)."""
    return f"{prefix}{metric}_t{row['task']}_g{grid_key(row['grid_size'])}"


GLUE_METRICS = ("auc", "coverage", "unobserved", "occupied_recall", "free_accuracy", "accuracy",
                "miou", "label_accuracy")


def glue_rows(rows, glue=None, metrics=GLUE_METRICS, prefix: str = "", digits: int = 5) -> list:
    """Glue every finite metric of every row under :func:`glue_key` names; return the names.

    ``glue`` defaults to ``myst_nb.glue``. Values are rounded to ``digits`` decimals so that the
    stored text does not hinge on the last bit.
    """
    glue = glue or _glue()
    names = []
    for r in rows:
        for m in metrics:
            v = r.get(m, np.nan)
            if np.isfinite(v):
                name = glue_key(r, m, prefix)
                glue(name, round(float(v), digits), display=False)
                names.append(name)
    return names


HEADS = {"model": "model", "task": "task", "grid_size": "grid [m]", "auc": "AUC",
         "coverage": "coverage", "unobserved": "unobserved", "accuracy": "accuracy",
         "miou": "mIoU", "free_accuracy": "free acc.", "n_scored": "scored samples",
         "build_seconds": "build [s]", "label_accuracy": "label acc.",
         "occupied_recall": "occ. recall", "occupied_kept": "hits kept",
         "free_kept": "free kept"}

DEFAULT_COLUMNS = ("model", "grid_size", "auc", "coverage", "occupied_recall", "free_accuracy",
                   "accuracy", "miou")


def _rule(columns):
    return "|" + "|".join(":--" if c == "model" else "--:" for c in columns) + "|"


def myst_table(rows, columns=DEFAULT_COLUMNS, fmt: str = ".3f", prefix: str = "") -> str:
    """MyST source of a pipe table whose numbers are ``{glue:text}`` references (see :func:`glue_rows`).

    Paste it into a *markdown* cell (after gluing the rows with the same ``prefix``): it renders
    in HTML and PDF alike, and every number in it comes from the code. Missing values show a dash.
    """
    lines = ["| " + " | ".join(HEADS.get(c, c) for c in columns) + " |", _rule(columns)]
    for r in rows:
        cells = []
        for c in columns:
            v = r[c]
            if c == "model":
                cells.append(str(v))
            elif c == "grid_size":
                cells.append(f"{v:g}")
            elif isinstance(v, (float, np.floating)) and not np.isfinite(v):
                cells.append("–")
            else:
                cells.append(f"{{glue:text}}`{glue_key(r, c, prefix)}:{fmt}`")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def markdown_table(rows, columns=DEFAULT_COLUMNS, digits: int = 3) -> str:
    """A Markdown table of the rows with the numbers written out (NaN shown as a dash).

    For printing and for notebooks (myst-nb renders a ``text/markdown`` *output* as CommonMark,
    which has no tables); for the book, prefer :func:`myst_table` in a markdown cell.
    """
    def fmt(c, v):
        if isinstance(v, str):
            return v
        if c == "grid_size":
            return f"{v:g}"
        if c in ("task", "n_scored"):
            return f"{int(v):,}"
        return "–" if not np.isfinite(v) else f"{v:.{digits}f}"

    lines = ["| " + " | ".join(HEADS.get(c, c) for c in columns) + " |", _rule(columns)]
    lines += ["| " + " | ".join(fmt(c, r[c]) for c in columns) + " |" for r in rows]
    return "\n".join(lines)


def class_legend_below(fig, num_classes: int = 6, ncol: int = 4):
    """One legend for a figure of semantic maps, below its panels: the regions, free, unknown."""
    from ..core import plotting
    return fig.legend(handles=plotting.class_handles(num_classes), loc="outside lower center",
                      ncol=ncol, frameon=False)


def class_and_variance(m, axes, label: str, vmax: float = 0.25, window: str | None = None,
                       log: bool = True, vmin: float = 1e-3, unobserved=None):
    """Class map (``axes[0]``) and variance of the most likely class (``axes[1]``) of a semantic
    map, zoomed onto ``window`` when given; returns the variance image (for a colour bar).
    ``unobserved``: colour of the cells without evidence in the variance panel
    (:func:`hw4.core.plotting.plot_variance`)."""
    from ..core import plotting
    plotting.plot_semantic(m, ax=axes[0], title=f"class, {label}", legend=False)
    im = plotting.plot_variance(m, ax=axes[1], title=f"variance, {label}", vmax=vmax,
                                colorbar=False, log=log, vmin=vmin, unobserved=unobserved)
    if window:
        for ax in axes:
            zoom(ax, window)
    return im


# --------------------------------------------------------------------------------------------
# Claims glued from the comparison they state, and the resolution studies' figures
# --------------------------------------------------------------------------------------------

def ratio_words(ratio: float, tolerance: float = 0.15) -> str:
    """A time ratio as the prose states it: "about as long as" within ``tolerance`` of 1,
    else "1.8 times as long as" or "0.6 times as long as" (one decimal), so that a sentence
    glued from it cannot claim a difference the measured times do not show."""
    ratio = float(ratio)
    if abs(ratio - 1.0) <= tolerance:
        return "about as long as"
    return f"{ratio:.1f} times as long as"


def trend_words(values, rising: str = "rises", falling: str = "falls",
                neither: str = "does not change monotonically") -> str:
    """``falling`` if ``values`` strictly decrease, ``rising`` if they strictly increase, else
    ``neither``: the verb of a sentence that quotes the values in order."""
    d = np.diff(np.asarray(values, dtype=float))
    if np.all(d < 0):
        return falling
    if np.all(d > 0):
        return rising
    return neither


def check_variance_scale(maps, scale) -> float:
    """Smallest variance of an observed cell over ``maps``; raises if it lies below the log
    scale's lower end ``scale[0]`` (it would be clipped to the scale's darkest colour)."""
    low = min(float(m.map["variance"][m.observed, 0].min()) for m in maps)
    if low < scale[0]:
        raise ValueError(f"observed variance {low:.3g} below the scale's lower end {scale[0]:g}")
    return low


def map_and_variance(m, axes, label: str, scale, window: str = "building"):
    """One map of a resolution study as a pair of panels: the occupancy mean (binary maps) or
    the most likely class (semantic maps) in ``axes[0]`` and the variance on the logarithmic
    ``scale`` = (vmin, vmax) in ``axes[1]``, both zoomed onto ``window`` (default: the whole
    observed building, without the empty margins of the template's map). A colour bar sits under
    each panel that needs one (under a class map: its legend); returns the variance image."""
    import matplotlib as mpl
    from ..core import plotting
    fig = axes[0].figure
    if m.map["mean"].shape[1] > 1:        # semantic: class map, its legend where a colour bar goes
        plotting.plot_semantic(m, ax=axes[0], title=f"class, {label}", legend=False)
        # an invisible colour bar keeps the two panels the same size; the legend sits on it
        bar = fig.colorbar(mpl.cm.ScalarMappable(), ax=axes[0], location="bottom", shrink=0.8,
                           aspect=30, label=" ")
        bar.solids.set_visible(False)
        cax = bar.ax
        cax.set_axis_off()
        cax.legend(handles=plotting.class_handles(m.num_classes), loc="center", ncol=3,
                   frameon=False, fontsize=8, handlelength=1.2, columnspacing=0.8,
                   borderaxespad=0.0)
    else:
        im = plotting.plot_mean(m, ax=axes[0], title=f"mean, {label}", colorbar=False,
                                unobserved=plotting.UNOBSERVED_LIGHT)
        fig.colorbar(im, ax=axes[0], location="bottom", shrink=0.8, aspect=30,
                     label="P(occupied)")
    im = plotting.plot_variance(m, ax=axes[1], title=f"variance, {label}", vmax=scale[1],
                                log=True, vmin=scale[0], colorbar=False,
                                unobserved=plotting.UNOBSERVED_VARIANCE)
    fig.colorbar(im, ax=axes[1], location="bottom", shrink=0.8, aspect=30, label="variance")
    for ax in axes:
        zoom(ax, window)
    return im

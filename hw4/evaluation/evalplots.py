"""Figures of the held-out evaluation: ROC curves, confusion matrix, study curves.

Same look as :mod:`hw4.core.plotting` (call :func:`hw4.core.plotting.style` first): one colour per model,
one line style per grid size, the semantic classes named as in the map legends.
"""
from __future__ import annotations

import numpy as np
import matplotlib.pyplot as plt

from ..core.plotting import CLASS_NAMES

MODEL_COLORS = {0: "0.45", 1: "#0072BD", 2: "#D95319", 3: "#7E2F8E", 4: "#77AC30"}
GRID_STYLES = {0.135: "-", 0.27: "--", 0.5: ":"}


def _new(ax, figsize=(5.0, 4.4)):
    if ax is None:
        _, ax = plt.subplots(figsize=figsize)
    return ax


def plot_roc(rows, ax=None, title=None, legend=True, zoom: float | None = None,
             style_by: str = "grid"):
    """ROC curves (false positive rate vs true positive rate) of evaluation rows with ``fpr``/``tpr``.

    Parameters
    ----------
    rows : list of dict from :func:`hw4.evaluation.evaluate.evaluate_all` (``keep_roc=True``).
    ax : Axes, optional
    zoom : float, optional
        Show only false positive rates up to ``zoom`` (the region where good maps differ).
    style_by : {'grid', 'semantic'}
        Line style per grid size (solid 0.135, dashed 0.27, dotted 0.5), or solid for the
        binary maps and dashed for the semantic ones.
    """
    ax = _new(ax)
    for r in rows:
        ls = (("--" if r["task"] in (3, 4) else "-") if style_by == "semantic"
              else GRID_STYLES.get(round(r["grid_size"], 3), "-"))
        label = (r["model"] if style_by == "semantic"
                 else f"{r['model']}, {r['grid_size']:g} m (AUC {r['auc']:.3f})")
        ax.plot(r["fpr"], r["tpr"], ls,
                color=MODEL_COLORS.get(r["task"], "k"), lw=1.2, label=label)
    ax.plot([0, 1], [0, 1], color="0.8", lw=0.8, zorder=0)
    ax.set_xlabel("false positive rate")
    ax.set_ylabel("true positive rate")
    ax.set_xlim(0, zoom if zoom else 1)
    ax.set_ylim(0, 1.0)
    if title:
        ax.set_title(title)
    if legend:
        ax.legend(fontsize=8, loc="lower right", framealpha=0.9)
    return ax


def roc_figure(rows, grid_sizes=None, zoom: float | None = 0.2, width: float = 7.0):
    """One ROC panel per grid size, every model of ``rows`` in each; returns the figure.

    Colour per model (:data:`MODEL_COLORS`), semantic maps dashed; one legend for the figure,
    below the panels (the AUCs are in the chapters' tables). ``width`` [in] is the print width,
    so that the 9 pt text stays at least 8 pt on the page.
    """
    sizes = sorted({r["grid_size"] for r in rows}) if grid_sizes is None else list(grid_sizes)
    fig, axes = plt.subplots(1, len(sizes), figsize=(width, 2.9), sharey=True,
                             layout="constrained")
    for ax, g in zip(np.atleast_1d(axes), sizes):
        plot_roc([r for r in rows if np.isclose(r["grid_size"], g)], ax=ax, zoom=zoom,
                 title=f"grid {g:g} m", style_by="semantic", legend=False)
        ax.label_outer()
    handles, labels = np.atleast_1d(axes)[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 5),
               fontsize=9, frameon=False)
    return fig


def plot_confusion(cm, ax=None, title=None, normalize: bool = True, colorbar: bool = True,
                   fontsize: float = 9.5):
    """Confusion matrix of a semantic map: rows true class (six regions, then free), columns predicted.

    With ``normalize`` every row is divided by its total (the share of each true class's samples
    that went to each predicted class) and shown, annotated and colour-barred in percent (0-100).
    ``fontsize`` [pt] of the cell numbers at the figure's own size (the book draws figures at
    print size, so 9.5 pt stays above 8 pt in the PDF).
    """
    cm = np.asarray(cm, dtype=float)
    names = list(CLASS_NAMES[: len(cm) - 1]) + ["free"]
    show = 100 * cm / np.maximum(cm.sum(axis=1, keepdims=True), 1) if normalize else cm
    ax = _new(ax, figsize=(5.6, 4.8))
    im = ax.imshow(show, cmap="Blues", vmin=0, vmax=100 if normalize else None)
    for i in range(len(cm)):
        for j in range(len(cm)):
            v = show[i, j]
            txt = f"{v:.0f}" if normalize else f"{int(cm[i, j])}"
            ax.text(j, i, txt, ha="center", va="center", fontsize=fontsize,
                    color="white" if (normalize and v > 50) else "black")
    ax.set_xticks(range(len(cm)), names, rotation=45, ha="right")
    ax.set_yticks(range(len(cm)), names)
    ax.set_xlabel("predicted class (most likely)")
    ax.set_ylabel("true class (held-out sample)")
    if title:
        ax.set_title(title)
    if colorbar:
        ax.figure.colorbar(im, ax=ax, shrink=0.8,
                           label="share of row [%]" if normalize else "samples")
    return im


def plot_study(rows, x: str, y: str, by: str, ax=None, label_fmt="{by} = {v:g}", xlabel=None,
               ylabel=None, title=None, style="o-"):
    """Line plot of metric ``y`` against parameter ``x``, one line per value of ``by``."""
    ax = _new(ax)
    for v in sorted({r[by] for r in rows}):
        sel = sorted((r for r in rows if r[by] == v), key=lambda r: r[x])
        ax.plot([r[x] for r in sel], [r[y] for r in sel], style, ms=4, lw=1.2,
                label=label_fmt.format(by=by, v=v))
    ax.set_xlabel(xlabel or x)
    ax.set_ylabel(ylabel or y)
    if title:
        ax.set_title(title)
    ax.legend(fontsize=9)
    return ax

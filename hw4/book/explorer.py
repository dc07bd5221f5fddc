"""A live explorer of the continuous models (Tasks 2 and 4), and where one cell's evidence comes from.

Two parts:

* :func:`cell_evidence` lists, for one cell of a built continuous map, every observation that
  added to it: each considered pose, the beam nearest in bearing, the end point and the free
  samples within ``l`` of the cell centre, each with its distance [m] and kernel weight. It is a
  small, readable numpy transcription of Algorithm 2 for a single cell (every sample of the beam
  is tried, no pruning), so its sums are an independent check of the map:
  ``prior + cell_evidence(ogm, i).totals()`` is the map's ``alpha`` (and ``beta``) of cell ``i``
  to rounding (``tests/test_explorer.py``).
* :class:`Explorer`, the ipywidgets explorer of the Task 2 and Task 4 chapters: sliders for the
  grid size, ``l``, ``sigma0``, the prior and the free-sample step; the map and its variance
  redrawn when a slider is released; a click on the map (with ``ipyevents``) or the two
  cell sliders pick a cell, whose evidence is drawn on the map and tabulated below it.

The figure is drawn with matplotlib's Agg canvas into an ``ipywidgets.Image`` (a PNG): no
matplotlib widget backend and no JavaScript beyond the ipywidgets (and ipyevents) extensions
that pip installs prebuilt, so it runs offline in JupyterLab 4, Notebook 7 and classic Notebook.
In a notebook::

    from hw4.book.explorer import Explorer
    Explorer(task=2)            # task=4: the continuous S-CSM, with its class counts

``python -m hw4.book.explorer --task 2 --still FILE`` writes the figure the explorer shows at its
start as a PNG. The stills of the static book (``notebooks/_static/t2_explorer.png``,
``t4_explorer.png``) are screenshots of the explorer live in Notebook 7 (headless Chromium
through selenium, after a click on the cell at (-9, -18.5) m), so that they show the sliders and
the evidence table as a reader sees them; ``python scripts/explorer_stills.py`` retakes both
(a Notebook 7 server on localhost, the chapters' explorer cells, the click through ipyevents).
"""
from __future__ import annotations

import html
import io
import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..core import plotting
from ..core.errors import InputError
from ..core.evidence import SAMPLE_STEP, n_samples
from ..core.grid import RANGE_X, RANGE_Y
from ..core.kernel import LENGTH, SIGMA0, sparse_kernel
from ..core.sensor import BeamTable, in_field, relative
from ..template import PRIOR

END, FREE = 0, 1   # kinds of a contribution: a beam's end point, a free sample along the beam


@dataclass
class CellEvidence:
    """Every contribution to one cell of a continuous map (Algorithm 2, nearest-beam rule).

    Attributes
    ----------
    cell : int, flat cell index (template order); centre : (2,) [m], world frame
    considered : (P,) int, the poses the cell considers (its nearest poses, nearest first)
    pose, beam : (M,) int, pose index and beam index within that pose's scan of each contribution
    kind : (M,) int, :data:`END` (occupied / class evidence) or :data:`FREE` (free sample)
    sample : (M,) int, free-sample index ``j`` (the sample at ``j * sample_step`` m from the
        robot), -1 for end points
    distance : (M,) float [m], from the contributing point to the cell centre (all < ``l``)
    weight : (M,) float, kernel weight ``k(distance)`` added to the evidence
    column : (M,) int, evidence column: binary 0 = alpha, 1 = beta; semantic ``label - 1``,
        free space last
    range, bearing_diff : (M,) float [m], [rad], the beam's range and its bearing's distance to
        the cell's bearing (the nearest-beam choice)
    n_columns : int, 2 (binary) or the classes + 1 (semantic)
    """
    cell: int
    centre: np.ndarray
    considered: np.ndarray
    pose: np.ndarray
    beam: np.ndarray
    kind: np.ndarray
    sample: np.ndarray
    distance: np.ndarray
    weight: np.ndarray
    column: np.ndarray
    range: np.ndarray
    bearing_diff: np.ndarray
    n_columns: int

    def totals(self) -> np.ndarray:
        """(n_columns,) evidence per column, the sum of the weights (prior excluded)."""
        return np.bincount(self.column, weights=self.weight, minlength=self.n_columns)

    def by_beam(self) -> list[dict]:
        """One row per (pose, beam) that counted: its end point's weight and its free samples'.

        Keys: ``pose``, ``beam``, ``range`` [m], ``bearing_diff`` [rad], ``end_distance`` [m]
        (None when the end point is farther than ``l``), ``end_weight``, ``end_column``,
        ``free_samples`` (how many lie within ``l``), ``free_weight`` (their summed weight).
        Rows in the order of :attr:`considered` (nearest pose first).
        """
        rows = []
        for t in self.considered:
            mine = self.pose == t
            if not mine.any():
                continue
            end = mine & (self.kind == END)
            free = mine & (self.kind == FREE)
            e = np.flatnonzero(end)
            rows.append(dict(
                pose=int(t), beam=int(self.beam[mine][0]), range=float(self.range[mine][0]),
                bearing_diff=float(self.bearing_diff[mine][0]),
                end_distance=float(self.distance[e[0]]) if len(e) else None,
                end_weight=float(self.weight[e[0]]) if len(e) else 0.0,
                end_column=int(self.column[e[0]]) if len(e) else None,
                free_samples=int(free.sum()), free_weight=float(self.weight[free].sum())))
        return rows


def cell_at(ogm, x: float, y: float) -> int:
    """Flat index of the cell whose centre is nearest to the world point (x, y) [m], or
    :class:`InputError` when the point lies outside the map."""
    i = int(ogm.grid.nearest_cell([[x, y]])[0])
    if i < 0:
        raise InputError(f"the point ({x:g}, {y:g}) m lies outside the map "
                         f"x {ogm.range_x}, y {ogm.range_y}.")
    return i


def cell_evidence(ogm, cell: int, table: BeamTable | None = None) -> CellEvidence:
    """Every observation that adds evidence to ``cell`` of a continuous map, with its weight.

    Parameters
    ----------
    ogm : a continuous template face (:class:`hw4.ogm_continuous_CSM.ogm_continuous_CSM` or
        :class:`hw4.ogm_continuous_S_CSM.ogm_continuous_S_CSM`) after ``construct_map``; its
        parameters (``l``, ``sigma``, ``sample_step``, ``nearest_poses``, ``z_max``) are used.
        Only the template's nearest-beam rule (``beams='nearest'``) is covered.
    cell : int, flat cell index (template order; :func:`cell_at` finds it from metres)
    table : the scans' :class:`hw4.core.sensor.BeamTable`, optional (built when not given;
        callers asking about many cells of one map pass it once)

    The steps are Algorithm 2's for one cell: its nearest poses (the KD-tree's, as the map's),
    those with the cell inside their perceptual field, per pose the beam nearest in bearing,
    then the end point (to ``alpha`` or its class) and every free sample ``j * sample_step``
    short of the end point (to ``beta`` or free space), each counting ``k(d)`` when its distance
    ``d`` to the centre is below ``l``.
    """
    if not getattr(ogm, "continuous", False) or getattr(ogm, "beams", "nearest") != "nearest":
        raise InputError("cell_evidence covers the continuous models with beams='nearest' only.")
    if ogm.grid is None:
        raise InputError("call construct_map(pose, scan) before cell_evidence().")
    if isinstance(cell, bool) or not isinstance(cell, (int, np.integer)) \
            or not 0 <= cell < ogm.grid.n_cells:
        raise InputError(f"cell must be an index in 0..{ogm.grid.n_cells - 1}; got {cell!r}.")
    poses = np.asarray(ogm.poses, dtype=float)
    table = BeamTable.from_scans(ogm.scans) if table is None else table
    K = ogm.n_columns
    cls_hit = table.labels - 1 if ogm.semantic else np.zeros(len(table.ranges), dtype=np.int64)
    centre = ogm.grid.cells[cell]
    if ogm.nearest_poses is None:
        considered = np.arange(len(poses))
    else:
        k = min(ogm.nearest_poses, len(poses))
        _, nn = cKDTree(poses[:, :2]).query(centre[None, :], k=k, workers=2)
        considered = np.asarray(nn).reshape(-1)
    cells = np.repeat(centre[None, :], len(considered), axis=0)
    r, phi = relative(cells, poses[considered])
    seen = in_field(r, phi, ogm.z_max)
    pose_ids, phi = considered[seen], phi[seen]
    beams, diffs = table.nearest(pose_ids, phi, return_diff=True)
    rec = {name: [] for name in ("pose", "beam", "kind", "sample", "distance", "column",
                                 "range", "bearing_diff")}
    l, sigma0, step = ogm.l, ogm.sigma, ogm.sample_step
    cx, cy = centre
    for t, b, diff in zip(pose_ids, beams, diffs):
        px, py, h = poses[t]
        z = table.ranges[b]
        theta = table.bearings[b] + h
        c, s = np.cos(theta), np.sin(theta)
        d1 = np.sqrt((cx - (px + z * c)) ** 2 + (cy - (py + z * s)) ** 2)
        sj = np.arange(int(n_samples(np.array([z]), step)[0])) * step
        d2 = np.sqrt((cx - (px + sj * c)) ** 2 + (cy - (py + sj * s)) ** 2)
        j = np.flatnonzero(d2 < l)
        ends = [d1] if d1 < l else []
        n = len(ends) + len(j)
        rec["pose"] += [t] * n
        rec["beam"] += [b - table.first[t]] * n
        rec["kind"] += [END] * len(ends) + [FREE] * len(j)
        rec["sample"] += [-1] * len(ends) + list(j)
        rec["distance"] += ends + list(d2[j])
        rec["column"] += [cls_hit[b]] * len(ends) + [K - 1] * len(j)
        rec["range"] += [z] * n
        rec["bearing_diff"] += [diff] * n
    arr = {name: np.asarray(v, dtype=float if name in ("distance", "range", "bearing_diff")
                            else np.int64) for name, v in rec.items()}
    weight = sparse_kernel(arr["distance"], sigma0, l)
    return CellEvidence(cell=int(cell), centre=centre, considered=considered, weight=weight,
                        n_columns=K, **arr)


# ----------------------------------------------------------------------------- the explorer

GRID_CHOICES = (0.135, 0.2, 0.27, 0.35, 0.5)                 # [m]
L_CHOICES = (0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5)            # [m]
SIGMA_CHOICES = (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0)
PRIOR_CHOICES = (1e-6, 1e-4, 1e-3, 1e-2, 0.1, 1.0)
STEP_CHOICES = (0.025, 0.05, 0.1, 0.15, 0.2, 0.3)            # [m]
DEFAULT_GRID = 0.5           # [m]: a redraw (count + draw) takes a few tenths of a second
DEFAULT_CELL = (-2.0, -18.0)   # [m] world frame: a south-west wall cell with hits and free samples
FIG_PX = (1080, 340)         # the figure [px]; the Image widget shows it at its natural size
FIG_DPI = 100
PANELS = ((50, 50, 260, 260), (420, 50, 260, 260), (800, 50, 260, 260))  # x0, y0, w, h [px]
COLORBARS = ((318, 50, 12, 260), (688, 50, 12, 260))                     # from the bottom left
MAX_BEAMS_DRAWN = 40         # beams drawn on the map (the table lists all of them)


def _choices(values, value, name):
    if value not in values:
        raise InputError(f"{name} must be one of {', '.join(f'{v:g}' for v in values)}; got {value!r}.")
    return value


class Explorer:
    """The ipywidgets explorer of a continuous model: parameters on sliders, map, variance, and
    where a picked cell's evidence comes from.

    Parameters
    ----------
    task : 2 (continuous CSM) or 4 (continuous S-CSM)
    grid_size, l [m], sigma, prior, sample_step [m] : start values (one of the slider choices:
        :data:`GRID_CHOICES`, :data:`L_CHOICES`, :data:`SIGMA_CHOICES`, :data:`PRIOR_CHOICES`,
        :data:`STEP_CHOICES`)
    cell : (x, y) [m], world frame: the point whose cell is picked first
    data : :class:`hw4.core.data.IntelData`, default the task's Intel data

    Attributes kept for tests and for the curious: ``ogm`` (the map drawn, a template face
    built with ``construct_map`` and ``build_ogm``), ``evidence`` (:class:`CellEvidence` of the
    picked cell), ``png`` (the figure's bytes), ``seconds`` (``build`` and ``draw`` of the last
    redraw [s]), and the widgets ``grid``, ``l``, ``sigma``, ``prior``, ``step``, ``x``, ``y``,
    ``image``, ``table``, ``status``, ``widget`` (the whole box) and ``events`` (the ipyevents
    click watcher, None without ipyevents).
    """

    def __init__(self, task: int = 2, grid_size: float = DEFAULT_GRID, l: float = LENGTH,
                 sigma: float = SIGMA0, prior: float = PRIOR, sample_step: float = SAMPLE_STEP,
                 cell: tuple = DEFAULT_CELL, data=None):
        import ipywidgets as w
        from ..tasks import load_task_data, model_class
        if task not in (2, 4):
            raise InputError(f"the explorer shows the continuous models, task 2 or 4; got {task!r}.")
        self.task = task
        self.cls = model_class(task)
        self.data = data if data is not None else load_task_data(task)
        self._cache: dict = {}

        def slider(values, value, name, description, fmt="{:g}"):
            return w.SelectionSlider(options=[(fmt.format(v), v) for v in values],
                                     value=_choices(values, value, name), description=description,
                                     continuous_update=False, style={"description_width": "7em"})

        self.grid = slider(GRID_CHOICES, grid_size, "grid_size", "grid size [m]")
        self.l = slider(L_CHOICES, l, "l", "l [m]")
        self.sigma = slider(SIGMA_CHOICES, sigma, "sigma", "σ₀")
        self.prior = slider(PRIOR_CHOICES, prior, "prior", "prior α₀")
        self.step = slider(STEP_CHOICES, sample_step, "sample_step", "free step [m]")
        x, y = cell
        if not (RANGE_X[0] <= x <= RANGE_X[1] and RANGE_Y[0] <= y <= RANGE_Y[1]):
            raise InputError(f"cell ({x:g}, {y:g}) m lies outside the map x {RANGE_X}, y {RANGE_Y}.")
        self.x = w.FloatSlider(value=x, min=RANGE_X[0], max=RANGE_X[1], step=0.05,
                               description="cell x [m]", continuous_update=False,
                               style={"description_width": "7em"})
        self.y = w.FloatSlider(value=y, min=RANGE_Y[0], max=RANGE_Y[1], step=0.05,
                               description="cell y [m]", continuous_update=False,
                               style={"description_width": "7em"})
        self.image = w.Image(format="png", layout=w.Layout(max_width="100%", height="auto"))
        self.table = w.HTML()
        self.status = w.HTML()
        try:
            from ipyevents import Event
        except ImportError:   # the cell sliders still pick cells
            self.events = None
        else:
            self.events = Event(source=self.image, watched_events=["click"])
            self.events.on_dom_event(self.on_click)
        params = [self.grid, self.l, self.sigma, self.prior, self.step]
        for s in params:
            s.observe(self._on_parameter, names="value")
        for s in (self.x, self.y):
            s.observe(self._on_cell, names="value")
        hint = ("click a cell on the map, or move the cell sliders" if self.events is not None
                else "move the cell sliders to pick a cell (install ipyevents to click on the map)")
        self.widget = w.VBox([
            w.HBox([w.VBox(params[:3]), w.VBox(params[3:] + [self.x, self.y])]),
            self.status, self.image, w.HTML(f"<i>{hint}</i>"), self.table])
        self._axes_px: list = []
        self.redraw()

    # --- the parameters and the map

    @property
    def params(self) -> dict:
        """The model's keyword parameters the sliders set (``grid_size`` [m], ``l`` [m], ``sigma``,
        ``prior_alpha``, ``sample_step`` [m])."""
        return dict(grid_size=self.grid.value, l=self.l.value, sigma=self.sigma.value,
                    prior_alpha=self.prior.value, sample_step=self.step.value)

    def set(self, **values):
        """Set sliders by name (``grid``, ``l``, ``sigma``, ``prior``, ``step``, ``x``, ``y``) and
        redraw once, as releasing the sliders one after the other would end."""
        widgets = dict(grid=self.grid, l=self.l, sigma=self.sigma, prior=self.prior,
                       step=self.step, x=self.x, y=self.y)
        unknown = set(values) - set(widgets)
        if unknown:
            raise InputError(f"unknown slider(s): {', '.join(sorted(unknown))}.")
        self._hold = True
        try:
            for name, v in values.items():
                widgets[name].value = v
        finally:
            self._hold = False
        self.redraw()

    _hold = False

    def _on_parameter(self, change):
        if not self._hold:
            self.redraw()

    def _on_cell(self, change):
        if not self._hold:
            self.redraw(rebuild=False)

    def build(self):
        """The map of the current parameters: the template face, ``construct_map`` then
        ``build_ogm`` (the last few maps are kept, so that going back is instant)."""
        key = tuple(sorted(self.params.items()))
        if key not in self._cache:
            scans = self.data.scans if self.cls.semantic else [s[:2] for s in self.data.scans]
            ogm = self.cls(**self.params)
            ogm.construct_map(self.data.poses, scans)
            ogm.build_ogm()
            if len(self._cache) >= 6:
                self._cache.pop(next(iter(self._cache)))
            self._cache[key] = ogm
        return self._cache[key]

    def redraw(self, rebuild: bool = True):
        """Build (or reuse) the map, find the picked cell's evidence, draw figure and table."""
        t0 = time.perf_counter()
        if rebuild or not hasattr(self, "ogm"):
            self.ogm = self.build()
        t1 = time.perf_counter()
        if getattr(self, "_table_of", None) is not self.ogm:
            self._table, self._table_of = BeamTable.from_scans(self.ogm.scans), self.ogm
        self.evidence = cell_evidence(self.ogm, cell_at(self.ogm, self.x.value, self.y.value),
                                      self._table)
        self.png = self._draw()
        self.image.value = self.png
        self.table.value = self.table_html()
        t2 = time.perf_counter()
        self.seconds = dict(build=t1 - t0, draw=t2 - t1)
        self.status.value = (f"<b>{self.ogm.__class__.__name__}</b>, {self.ogm.grid.n_cells:,} "
                             f"cells; map {1000 * self.seconds['build']:.0f} ms, cell and figure "
                             f"{1000 * self.seconds['draw']:.0f} ms" + self._legend_html())

    # --- picking a cell

    def select(self, x: float, y: float):
        """Pick the cell nearest to the world point (x, y) [m] (as a click there does); the cell
        sliders move to its centre."""
        cx, cy = self.ogm.grid.cells[cell_at(self.ogm, x, y)]
        self._hold = True
        try:
            self.x.value = float(np.clip(cx, self.x.min, self.x.max))
            self.y.value = float(np.clip(cy, self.y.min, self.y.max))
        finally:
            self._hold = False
        self.redraw(rebuild=False)

    def pixel_to_world(self, px: float, py: float):
        """World point (x, y) [m] under the image pixel (px, py) (origin top left, the PNG's own
        pixels), or None when it is not on one of the two maps."""
        for (x0, y0, x1, y1), inverse in self._axes_px:
            if x0 <= px <= x1 and y0 <= self._height_px - py <= y1:
                return tuple(float(v) for v in inverse((px, self._height_px - py)))
        return None

    def on_click(self, event: dict):
        """The ipyevents handler: ``event['dataX'], event['dataY']`` are the clicked pixel in the
        image's own pixels; a click on either map picks the cell there."""
        if event.get("type", "click") != "click":
            return
        xy = self.pixel_to_world(event["dataX"], event["dataY"])
        if xy is not None:
            self.select(*xy)

    # --- drawing

    def _draw(self) -> bytes:
        import matplotlib as mpl
        with mpl.rc_context({"image.interpolation": "nearest", "font.size": 9,
                             "axes.titlesize": 10}):   # cells as squares, whatever the style
            return self._draw_figure()

    def _draw_figure(self) -> bytes:
        """The explorer's figure as PNG bytes: map, variance, and the picked cell's neighbourhood.

        The figure, its axes, ticks, labels and colour bars are made and drawn once
        (:meth:`_figure`; their pixels are kept); a redraw restores those pixels and draws only
        what the axes show (blitting), which keeps the text rendering of the ticks, most of a
        full draw, out of every redraw. The panels' pixel boxes are kept for
        :meth:`pixel_to_world`.
        """
        from matplotlib.patches import Circle, Rectangle
        from PIL import Image
        ogm, ev = self.ogm, self.evidence
        fig, axes = self._figure()
        for ax in axes:   # what the axes show is made again
            for a in [*ax.images, *ax.lines, *ax.collections, *ax.patches]:
                a.remove()
            if ax.get_legend() is not None:
                ax.get_legend().remove()
        kw = dict(unobserved=plotting.UNOBSERVED_LIGHT, colorbar=False)
        if ogm.semantic:
            plotting.plot_semantic(ogm, ax=axes[0], title="most likely class", legend=False)
        else:
            plotting.plot_mean(ogm, ax=axes[0], title="P(occupied)", **kw)
        lo, hi = plotting.VARIANCE_LOG_CONTINUOUS   # a variance never exceeds 1/4
        plotting.plot_variance(ogm, ax=axes[1], title="variance (log scale)", log=True, vmin=lo,
                               vmax=hi, colorbar=False, unobserved=plotting.UNOBSERVED_VARIANCE)
        poses, g = ogm.poses, ogm.grid.grid_size
        cx, cy = ev.centre
        rows = ev.by_beam()
        ends = {(r["pose"], r["beam"]): self._end_point(r) for r in rows}
        for ax in axes[:2]:
            for r in rows[:MAX_BEAMS_DRAWN]:
                (px, py, _), (ex, ey) = poses[r["pose"]], ends[r["pose"], r["beam"]]
                ax.plot([px, ex], [py, ey], "-", color="tab:orange", lw=0.6)
            ax.plot(poses[ev.considered, 0], poses[ev.considered, 1], ".", color="tab:red", ms=3)
            ax.add_patch(Rectangle((cx - g / 2, cy - g / 2), g, g, fill=False, color="red", lw=1.2))
        # the neighbourhood of the cell: the points that counted, sized by their weight
        ax = axes[2]
        half = max(1.0, 3 * ogm.l, 3 * g)   # [m] half the window's side
        if ogm.semantic:
            plotting.plot_semantic(ogm, ax=ax, legend=False)
        else:
            plotting.plot_mean(ogm, ax=ax, **kw)
        ax.set_title(f"cell {ev.cell} ({cx:.2f}, {cy:.2f}) m, {2 * half:g} m wide")
        ax.set_xlabel("")
        ax.set_ylabel("")
        for r in rows:
            (px, py, _), (ex, ey) = poses[r["pose"]], ends[r["pose"], r["beam"]]
            ax.plot([px, ex], [py, ey], "-", color="tab:orange", lw=0.8, zorder=2)
        xs, ys = self._points()
        top = max(float(ogm.sigma), 1e-300)
        free = ev.kind == FREE
        ax.scatter(xs[~free], ys[~free], s=12 + 80 * ev.weight[~free] / top, marker="x",
                   linewidths=1.2, color="tab:red", zorder=3,
                   label="end points" + (" (class)" if ogm.semantic else " (α)"))
        ax.scatter(xs[free], ys[free], s=4 + 50 * ev.weight[free] / top, color="tab:blue",
                   alpha=0.8, linewidths=0, zorder=4,
                   label="free samples" + ("" if ogm.semantic else " (β)"))
        ax.add_patch(Circle((cx, cy), ogm.l, fill=False, ls="--", color="k", lw=0.8, zorder=3))
        ax.add_patch(Rectangle((cx - g / 2, cy - g / 2), g, g, fill=False, color="red", lw=1.2,
                               zorder=5))
        ax.set_xlim(cx - half, cx + half)   # square, as the panel: its box stays
        ax.set_ylim(cy - half, cy + half)
        ax.legend(loc="lower left", fontsize=7, framealpha=0.85)
        shown = []
        for ax in axes:
            arts = [*ax.images, *ax.lines, *ax.collections, *ax.patches, ax.get_legend()]
            arts = sorted((a for a in arts if a is not None), key=lambda a: a.get_zorder())
            for a in arts:
                a.set_animated(True)   # left out of the kept pixels
            shown.append(arts)
        axes[2].title.set_animated(True)
        canvas = fig.canvas
        if self._background is None:
            canvas.draw()
            self._background = canvas.copy_from_bbox(fig.bbox)
            self._height_px = FIG_PX[1]   # the panels as drawn (display px, origin bottom left)
            self._axes_px = [(a.bbox.extents, a.transData.inverted().frozen().transform)
                             for a in axes[:2]]
        else:
            canvas.restore_region(self._background)
        for ax, arts in zip(axes, shown):
            for a in arts:
                ax.draw_artist(a)
        axes[2].draw_artist(axes[2].title)
        buf = io.BytesIO()
        Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3]).save(
            buf, format="png", compress_level=1)
        return buf.getvalue()

    def _legend_html(self) -> str:
        """The class colours of a semantic map as HTML swatches ('' for a binary map)."""
        if not self.cls.semantic:
            return ""
        from matplotlib.colors import to_hex
        hexes = [to_hex(c) for c in plotting.CLASS_COLORS]
        names = [plotting.class_label(c) for c in range(1, len(plotting.CLASS_NAMES) + 1)]
        items = list(zip(names, hexes)) + [("free", "#ffffff"), ("unknown", "#808080")]
        return "<br>" + " ".join(
            f'<span style="display:inline-block;width:0.9em;height:0.9em;background:{c};'
            f'border:1px solid #999;vertical-align:middle"></span> {html.escape(n)}' for n, c in items)

    def _figure(self):
        """The explorer's figure and its three panels, made once: a fixed layout in pixels
        (:data:`PANELS`, :data:`COLORBARS`), no layout engine (it would cost more than the map)."""
        if getattr(self, "_fig", None) is None:
            import matplotlib as mpl
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            from matplotlib.figure import Figure
            W, H = FIG_PX
            fig = Figure(figsize=(W / FIG_DPI, H / FIG_DPI), dpi=FIG_DPI)
            FigureCanvasAgg(fig)

            def box(x0, y0, w, h):   # pixels from the bottom left -> figure fraction
                return fig.add_axes((x0 / W, y0 / H, w / W, h / H))

            axes = [box(*p) for p in PANELS]
            for a in axes:
                a.tick_params(labelsize=8)
                a.xaxis.label.set_size(8)
                a.yaxis.label.set_size(8)
            axes[2].set_xticks([])   # the window moves with the cell: its title gives its size
            axes[2].set_yticks([])
            lo, hi = plotting.VARIANCE_LOG_CONTINUOUS
            scales = [(mpl.colors.Normalize(0, 1), plotting.OCCUPANCY_CMAP, "P(occupied)"),
                      (mpl.colors.LogNorm(lo, hi), plotting.VARIANCE_CMAP, "variance")]
            if self.cls.semantic:   # the class colours are named below the figure instead
                scales[0] = None
            for cb, scale in zip(COLORBARS, scales):
                if scale is not None:
                    cax = box(*cb)
                    fig.colorbar(mpl.cm.ScalarMappable(norm=scale[0], cmap=scale[1]), cax=cax)
                    cax.tick_params(labelsize=8)
            self._fig, self._axes, self._background = fig, axes, None
        return self._fig, self._axes

    def _end_point(self, row):
        px, py, h = self.ogm.poses[row["pose"]]
        scan = self.ogm.scans[row["pose"]]
        bx, by = scan[0][row["beam"]], scan[1][row["beam"]]
        c, s = np.cos(h), np.sin(h)
        return px + c * bx - s * by, py + s * bx + c * by

    def _points(self):
        """World coordinates [m] of every contribution's point (end point or free sample)."""
        ev = self.evidence
        xs, ys = np.empty(len(ev.weight)), np.empty(len(ev.weight))
        table = {}
        for i in range(len(ev.weight)):
            key = (ev.pose[i], ev.beam[i])
            if key not in table:
                scan = self.ogm.scans[ev.pose[i]]
                table[key] = np.arctan2(scan[1][ev.beam[i]], scan[0][ev.beam[i]])
            px, py, h = self.ogm.poses[ev.pose[i]]
            dist = ev.range[i] if ev.kind[i] == END else ev.sample[i] * self.ogm.sample_step
            xs[i] = px + dist * np.cos(table[key] + h)
            ys[i] = py + dist * np.sin(table[key] + h)
        return xs, ys

    def table_html(self) -> str:
        """The picked cell's evidence as an HTML table: one row per (pose, beam) that counted,
        then the prior and the sums, which are the map's own alpha and beta (class counts)."""
        ogm, ev = self.ogm, self.evidence
        prior = float(ogm.prior_alpha)
        i = ev.cell
        names = (plotting.CLASS_NAMES[: ogm.num_classes] + ["free"]) if ogm.semantic else None
        esc = html.escape
        head = ["pose", "pose x, y [m]", "beam", "range [m]", "|Δ bearing| [°]",
                "end point to cell [m]", "k → " + ("class" if ogm.semantic else "α"),
                "free samples < l", "Σ k → " + ("free" if ogm.semantic else "β")]
        body = []
        for row in ev.by_beam():
            px, py, _ = ogm.poses[row["pose"]]
            end = ("—" if row["end_distance"] is None else f"{row['end_distance']:.3f}")
            w_end = f"{row['end_weight']:.5f}"
            if ogm.semantic and row["end_column"] is not None:
                w_end += f" ({names[row['end_column']]})"
            body.append([row["pose"], f"{px:.2f}, {py:.2f}", row["beam"], f"{row['range']:.2f}",
                         f"{np.degrees(row['bearing_diff']):.2f}", end, w_end,
                         row["free_samples"], f"{row['free_weight']:.5f}"])
        tot = ev.totals()
        cols = ["α", "β"] if not ogm.semantic else names
        values = ogm.map["alpha"][i] if ogm.semantic else np.array(
            [ogm.map["alpha"][i, 0], ogm.map["beta"][i, 0]])
        style = ('style="border-collapse:collapse;font-size:12px;font-family:sans-serif" '
                 'border="1" cellpadding="3"')
        out = [f"<p><b>Cell {i}</b> at ({ev.centre[0]:.3f}, {ev.centre[1]:.3f}) m: "
               f"{len(ev.considered)} poses considered, {len(body)} of them with a beam that "
               f"counted ({len(ev.weight)} points within l = {ogm.l:g} m).</p>",
               f"<table {style}><tr>" + "".join(f"<th>{esc(h)}</th>" for h in head) + "</tr>"]
        out += ["<tr>" + "".join(f"<td>{esc(str(v))}</td>" for v in r) + "</tr>" for r in body]
        out.append("</table>")
        out.append(f"<table {style} style='margin-top:6px'><tr><th></th>"
                   + "".join(f"<th>{esc(c)}</th>" for c in cols) + "</tr>")
        out.append("<tr><td>evidence Σ k</td>" + "".join(f"<td>{v:.6g}</td>" for v in tot) + "</tr>")
        out.append("<tr><td>prior</td>" + "".join(f"<td>{prior:g}</td>" for _ in cols) + "</tr>")
        out.append("<tr><td>prior + Σ k</td>" + "".join(
            f"<td>{prior + v:.6g}</td>" for v in tot) + "</tr>")
        out.append("<tr><td><b>the map's cell</b></td>" + "".join(
            f"<td><b>{v:.6g}</b></td>" for v in values) + "</tr></table>")
        mean = ogm.map["mean"][i]
        var = float(ogm.map["variance"][i, 0])
        if ogm.semantic:
            out.append(f"<p>most likely: {esc(names[int(np.argmax(values))])} "
                       f"(p = {float(mean.max()):.4f}), variance {var:.4g}</p>")
        else:
            out.append(f"<p>P(occupied) = {float(mean[0]):.4f}, variance {var:.4g}</p>")
        return "".join(out)

    # --- display

    def __repr__(self) -> str:
        return (f"<{self.ogm.__class__.__name__} explorer: grid {self.grid.value:g} m, "
                f"l {self.l.value:g} m, sigma0 {self.sigma.value:g}, prior {self.prior.value:g}, "
                f"free step {self.step.value:g} m (live in Jupyter)>")

    def _repr_mimebundle_(self, **kw):
        """The widget box, with a fixed plain-text form (nbval compares it; model ids it skips)."""
        bundle = self.widget._repr_mimebundle_(**kw)
        bundle["text/plain"] = repr(self)
        return bundle

    def save_still(self, path):
        """Write the figure the explorer shows now as a PNG (the static book's still)."""
        with open(path, "wb") as f:
            f.write(self.png)


def main(argv=None) -> int:
    """``python -m hw4.book.explorer --task 2 --still FILE``: the still of the explorer."""
    import argparse
    import sys
    p = argparse.ArgumentParser(prog="python -m hw4.book.explorer", description=__doc__.split("\n")[0])
    p.add_argument("--task", type=int, default=2, choices=(2, 4))
    p.add_argument("--still", required=True, help="PNG file to write")
    a = p.parse_args(argv)
    try:
        Explorer(task=a.task).save_still(a.still)
    except (InputError, OSError) as e:
        print(f"hw4.book.explorer: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""An interactive 3D view of a voxel map for the browser (rotate, zoom, pan, as in RViz).

:func:`interactive_figure` turns the occupied voxels of a :class:`~hw4.bki.voxelmap.MapView` into
a plotly figure: one ``Mesh3d`` trace per class (its colour and name in the legend, a click hides
it), each made of the voxel faces that no other occupied voxel covers, so that surfaces read as
surfaces; the car's path is a line. :func:`write_interactive` writes it as a stand-alone HTML page
that works with no network: plotly.js is written once beside it (``plotly.min.js``, from the
installed plotly package) and loaded by a relative path, never from a CDN.

Page weight: vertex coordinates are float32 and face indices int32, stored base64-encoded (plotly
>= 6), about 50 bytes per shown face. A map with more than ``max_voxels`` occupied voxels is
aggregated first (:func:`aggregate`; default 50,000): voxels are merged into cubes of 2, 4, ... voxels per edge,
each taking the most frequent class of the voxels it holds, until at most ``max_voxels`` remain.
"""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from .palette import class_colors, class_names
from .voxelmap import MapView

# corners of the unit cube's faces (outward normals +x, -x, +y, -y, +z, -z), two triangles each
_DIRS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
_FACE = np.array([
    [[1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]], [[0, 0, 0], [0, 0, 1], [0, 1, 1], [0, 1, 0]],
    [[0, 1, 0], [0, 1, 1], [1, 1, 1], [1, 1, 0]], [[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]],
    [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], [[0, 0, 0], [0, 1, 0], [1, 1, 0], [1, 0, 0]]])


def _keys(idx: np.ndarray) -> np.ndarray:
    u = idx.astype(np.int64) + (1 << 20)
    return (u[:, 0] << 42) | (u[:, 1] << 21) | u[:, 2]


def aggregate(idx: np.ndarray, cls: np.ndarray, factor: int) -> tuple[np.ndarray, np.ndarray]:
    """Merge voxels into cubes of ``factor`` voxels per edge, each with its most frequent class.

    Parameters
    ----------
    idx : (M, 3) int voxel indices; cls : (M,) int classes
    factor : int >= 1

    Returns
    -------
    (N, 3) int indices of the merged cubes (in units of ``factor`` voxels) and their (N,) classes
    (ties go to the smaller class).
    """
    big = np.floor_divide(idx, factor)
    keys = _keys(big)
    pair = np.unique(np.column_stack([keys, cls]), axis=0, return_counts=True)
    (k, c), n = pair[0].T, pair[1]
    order = np.lexsort((c, -n, k))             # per cube: most frequent first, then smaller class
    k, c = k[order], c[order]
    first = np.r_[True, k[1:] != k[:-1]]
    keep_k, keep_c = k[first], c[first]
    mask = (1 << 21) - 1
    out = np.column_stack([(keep_k >> 42) & mask, (keep_k >> 21) & mask, keep_k & mask]) - (1 << 20)
    return out, keep_c


def exposed_faces(idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Faces of voxels ``idx`` (M, 3 int) not covered by another voxel of ``idx``.

    Returns the voxel of each face (F,) and its direction (F,), an index into the six directions.
    """
    keys = np.sort(_keys(idx))
    vox, dirs = [], []
    for d in range(6):
        nb = _keys(idx + _DIRS[d])
        pos = np.minimum(np.searchsorted(keys, nb), len(keys) - 1)
        free = np.flatnonzero(keys[pos] != nb)
        vox.append(free)
        dirs.append(np.full(len(free), d))
    return np.concatenate(vox), np.concatenate(dirs)


def cube_mesh(idx: np.ndarray, edge: float) -> tuple[np.ndarray, np.ndarray]:
    """A triangle mesh of the exposed faces of voxels ``idx`` with edge ``edge`` [m].

    Returns (V, 3) float32 vertices [m] (shared between faces) and (2F, 3) int32 triangles.
    """
    vox, d = exposed_faces(idx)
    corners = idx[vox, None, :] + _FACE[d]                        # (F, 4, 3) lattice points
    flat = corners.reshape(-1, 3)
    uniq, inv = np.unique(flat, axis=0, return_inverse=True)
    q = inv.reshape(-1, 4).astype(np.int32)
    tri = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return (uniq * edge).astype(np.float32), tri


def interactive_figure(view: MapView, trajectory=None, box=None, max_voxels: int = 50_000,
                       title: str = ""):
    """The occupied voxels of ``view`` as a plotly figure (one mesh per class, the car's path).

    Parameters
    ----------
    view : MapView
    trajectory : (T, 3) array [m], optional, world frame
    box : (lo, hi) pair of (3,) arrays [m], optional: show only voxels whose centre lies inside
    max_voxels : int, aggregate (see :func:`aggregate`) until at most this many voxels remain
    title : str

    Returns
    -------
    plotly.graph_objects.Figure, and the aggregation factor used (1 = the map's own voxels)
    """
    import plotly.graph_objects as go
    m = view.occupied.copy()
    if box is not None:
        m &= np.all((view.centres >= np.asarray(box[0])) & (view.centres <= np.asarray(box[1])), axis=1)
    own = np.floor(view.centres[m] / view.resolution).astype(np.int64)
    idx, cls, factor = own, view.cls[m], 1
    while len(idx) > max_voxels:
        factor *= 2
        idx, cls = aggregate(own, view.cls[m], factor)
    edge = view.resolution * factor
    K = view.probs.shape[1]
    pal, names = class_colors(K, np.unique(cls)), class_names(K)
    fig = go.Figure()
    for k in np.unique(cls):
        verts, tri = cube_mesh(idx[cls == k], edge)
        r, g, b = (int(c) for c in pal[k])
        fig.add_trace(go.Mesh3d(
            x=verts[:, 0], y=verts[:, 1], z=verts[:, 2], i=tri[:, 0], j=tri[:, 1], k=tri[:, 2],
            color=f"rgb({r},{g},{b})", flatshading=True, name=names[k], showlegend=True,
            hoverinfo="name", lighting=dict(ambient=0.8, diffuse=0.45, specular=0.0),
            lightposition=dict(x=-1e4, y=-5e3, z=2e4)))
    if trajectory is not None:
        p = np.asarray(trajectory, float)
        fig.add_trace(go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2] + 0.3, mode="lines+markers",
                                   line=dict(color="black", width=5), marker=dict(size=3, color="white",
                                   line=dict(color="black", width=1)), name="car trajectory",
                                   hoverinfo="name"))
    lo = np.floor(view.centres[m].min(0)) if m.any() else np.zeros(3)
    hi = np.ceil(view.centres[m].max(0)) if m.any() else np.ones(3)
    span = np.maximum(hi - lo, 1e-6)
    fig.update_layout(meta=dict(voxels=int(len(idx)), factor=factor, edge=edge),
                      **_layout(title, dict(x=1, y=span[1] / span[0], z=span[2] / span[0])))
    return fig, factor


def _layout(title: str, aspectratio: dict) -> dict:
    """Layout of the view, one for every screen: the legend is a horizontal row below the scene
    (it wraps into a few rows on a phone instead of covering the map; entries of a fixed 92 px
    of text form even columns, as plotly's wrap of text-sized entries can run past the right
    edge), the tool bar stands upright at the right edge (clear of the title), and the camera
    looks from behind the car."""
    return dict(
        title=dict(text=title, x=0.01, xanchor="left", y=0.985, yanchor="top", font=dict(size=14)),
        margin=dict(l=0, r=0, t=30 if title else 0, b=0), paper_bgcolor="white",
        legend=dict(orientation="h", x=0, xanchor="left", y=0, yanchor="top",
                    itemsizing="constant", itemwidth=30, font=dict(size=12),
                    entrywidth=92, entrywidthmode="pixels"),
        modebar=dict(orientation="v"),
        scene=dict(aspectmode="manual", aspectratio=aspectratio,
                   xaxis_title="x [m]", yaxis_title="y [m]", zaxis_title="z [m]",
                   camera=dict(eye=dict(EYE), center=dict(x=0.1, y=0, z=-0.1))))


EYE = dict(x=-1.1, y=0.0, z=0.55)
"""The first camera of the view: its eye in plotly's scene units (the scene's aspect ratio is the
map's, so the direction is the same in metres)."""


def still_camera(box):
    """The :class:`~hw4.bki.render.Camera` that looks at ``box`` (a (lo, hi) pair of (3,) arrays
    [m], world frame) from the direction of the interactive view's first camera (:data:`EYE`):
    the view's still image, for a page where the view is loaded only on a click."""
    from .render import Camera
    e = np.array([EYE["x"], EYE["y"], EYE["z"]], float)
    elev = float(np.degrees(np.arctan2(e[2], np.hypot(e[0], e[1]))))
    azim = float(np.degrees(np.arctan2(e[1], e[0])))
    return Camera(elev, azim, tuple(np.asarray(box[0], float)), tuple(np.asarray(box[1], float)),
                  zoom=1.5, persp=True)


def write_still(view: MapView, path, box, trajectory=None, title: str = "", width: float = 4.0,
                dpi: int = 220) -> Path:
    """Write a PNG of the occupied voxels of ``view`` inside ``box`` as the interactive view first
    shows them (:func:`still_camera`; shaded cubes, the class legend below), ``width`` inch wide;
    written under a temporary name and renamed, so a failed run leaves no still.

    The still fills the HTML column (about 390 px on a phone): drawn 4 in wide with the book's
    8.5 pt text and the legend in three columns, its labels stay about 11 px high there (7 in
    wide they were 8 px); 220 dpi keeps it sharp at a desktop's 830 px."""
    import matplotlib.pyplot as plt
    from . import render
    fig = render.plot_maps({title: view}, still_camera(box), width=width, trajectory=trajectory,
                           legend="below", below_cols=3)
    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    try:
        tmp.write_bytes(render.png_bytes(fig, dpi))
        tmp.replace(path)
    finally:
        plt.close(fig)
        tmp.unlink(missing_ok=True)
    return path


def vendor_plotly(folder, target=None) -> Path:
    """Write plotly.js (``plotly.min.js`` of the installed plotly package) into ``folder``
    (or to the file ``target``, e.g. a temporary name that the caller renames)."""
    from plotly.offline import get_plotlyjs
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    text = get_plotlyjs()
    if target is not None:              # the caller's temporary name: write it directly
        Path(target).write_text(text, encoding="utf-8")
        return Path(target)
    target = folder / "plotly.min.js"
    if not target.exists() or target.read_text(encoding="utf-8") != text:
        _write_atomic(target, text)
    return target


def _write_atomic(target: Path, text: str) -> None:
    tmp = target.with_name(target.name + ".partial")
    try:
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(target)
    finally:
        tmp.unlink(missing_ok=True)


def write_interactive(view: MapView, path, trajectory=None, box=None, max_voxels: int = 50_000,
                      title: str = "", js_path=None) -> dict:
    """Write the interactive view of :func:`interactive_figure` as a stand-alone offline HTML page.

    ``plotly.min.js`` is written beside ``path`` (once; or to ``js_path``, which the caller then
    moves beside the page; both are then written directly, as the caller's temporary names) and
    loaded from there by its name. Returns a summary: ``voxels``
    (shown), ``factor`` (aggregation), ``faces``, ``bytes`` (page) and ``js_bytes``.
    """
    path = Path(path)
    fig, factor = interactive_figure(view, trajectory, box, max_voxels, title)
    js = vendor_plotly(path.parent, js_path)
    html = _page_html(fig)
    if js_path is not None:
        path.write_text(html, encoding="utf-8")
    else:
        _write_atomic(path, html)
    faces = sum(len(t.i) for t in fig.data if t.type == "mesh3d") // 2
    return dict(voxels=fig.layout.meta["voxels"], factor=factor, faces=faces,
                bytes=path.stat().st_size, js_bytes=js.stat().st_size)


# Run once the plot is drawn. The camera's field of view is fixed vertically, so a plot area
# taller than wide (a phone held upright) cuts the map off at the sides: the camera then moves
# back along its line of sight until the map is as wide, relative to the area, as on a wide
# screen, and a quarter further, so that the axis titles (z at the left edge) fit too. Only the
# first view changes; a rotation the reader makes later is left alone.
_FIT_CAMERA = """
(function () {
  var gd = document.getElementById('{plot_id}');
  var size = gd && gd._fullLayout && gd._fullLayout._size;
  var cam = gd && gd.layout.scene && gd.layout.scene.camera;
  if (!size || !cam || !size.w) return;
  var k = Math.min(3, 1.25 * size.h / size.w);
  if (k <= 1) return;
  var e = cam.eye, c = cam.center || {x: 0, y: 0, z: 0};
  Plotly.relayout(gd, {'scene.camera.eye': {x: c.x + k * (e.x - c.x), y: c.y + k * (e.y - c.y),
                                            z: c.z + k * (e.z - c.z)}});
})();
"""


def _page_html(fig) -> str:
    """The stand-alone page of ``fig``: plotly.js by its relative name, the plot filling the window
    (on a phone too: the page declares the device's width as its own, and the first view backs
    off on a screen taller than wide so that the map fits across). The mouse wheel does not zoom
    (``scrollZoom`` off: on a book page it scrolls the page instead of being trapped by the view;
    zoom with the tool bar's zoom mode, dragging up or down; the wheel is stopped before plotly's
    3D camera, which would cancel it, so that it scrolls the book page around the frame). The page never scrolls: the
    plot fills it exactly, and a scroll bar would narrow the window and call up the other one."""
    html = fig.to_html(include_plotlyjs="plotly.min.js", full_html=True, div_id="map3d",
                       default_width="100%", default_height="100%", post_script=_FIT_CAMERA,
                       config=dict(displaylogo=False, scrollZoom=False, responsive=True))
    return html.replace("<head>", "<head><title>3D semantic map</title>"
                        '<meta name="viewport" content="width=device-width, initial-scale=1">'
                        "<style>html,body{height:100%;margin:0;overflow:hidden}</style>"
                        + _WHEEL_TO_PAGE, 1)


# plotly's 3D camera cancels every wheel event over the plot, scrollZoom off or not, so a book page
# would stop scrolling under the cursor: the view's own page stops the wheel before plotly sees it
# (capture phase), and the browser hands the scroll on to the book page around the frame. A pinch
# on a touchpad arrives as a wheel event with ctrlKey and still reaches the plot.
_WHEEL_TO_PAGE = ('<script>window.addEventListener("wheel", function (e) {'
                  ' if (!e.ctrlKey) { e.stopPropagation(); } }, {capture: true});</script>')


def copy_page(src, dest_folder) -> Path:
    """Copy an interactive page and its ``plotly.min.js`` into ``dest_folder``; return the page."""
    dest_folder = Path(dest_folder)
    dest_folder.mkdir(parents=True, exist_ok=True)
    src = Path(src)
    shutil.copyfile(src.parent / "plotly.min.js", dest_folder / "plotly.min.js")
    shutil.copyfile(src, dest_folder / src.name)
    return dest_folder / src.name

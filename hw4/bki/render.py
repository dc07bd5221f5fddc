"""Pictures of 3D semantic voxel maps: voxel renders, top-down views and the mapping video.

* :func:`draw_voxels` draws voxels as shaded cubes (only the faces that are exposed and turned to
  the camera, so tens of thousands of voxels render in a few seconds) on a 3D axis whose camera
  (elevation, azimuth, limits) the caller fixes, so maps of two methods are seen identically.
* :func:`topdown` makes a top view: for every (x, y) column the highest selected voxel, coloured by
  class or by a scalar (variance).
* :func:`write_video` writes frames as GIF (imageio) and MP4 (imageio-ffmpeg ships its own ffmpeg).
* :func:`first_coloured_frame`, :func:`trim_video` and :func:`video_poster` cut a screen recording
  (RViz's, ``scripts/reference_ros.sh``) so that it starts at the first frame with a map drawn, and
  take a poster frame for the HTML player.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .palette import class_colors
from .voxelmap import MapView

# the six face directions, the four corners of each face (unit cube [0, 1]^3) and a fixed shading
_DIRS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
_CORNERS = np.array([
    [[1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]], [[0, 0, 0], [0, 0, 1], [0, 1, 1], [0, 1, 0]],
    [[0, 1, 0], [0, 1, 1], [1, 1, 1], [1, 1, 0]], [[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]],
    [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], [[0, 0, 0], [0, 1, 0], [1, 1, 0], [1, 0, 0]]],
    dtype=float)
_SHADE = np.array([0.78, 0.62, 0.70, 0.86, 1.0, 0.45])


@dataclass(frozen=True)
class Camera:
    """A fixed 3D view: elevation and azimuth [deg] and axis limits [m], world frame."""

    elev: float
    azim: float
    lo: tuple
    hi: tuple
    zoom: float = 1.2
    persp: bool = False
    """Perspective projection (a view from the car) instead of the orthographic overview."""

    def inside(self, centres: np.ndarray) -> np.ndarray:
        """(M,) bool: which voxel centres [m] lie in the camera's box (the part drawn)."""
        return np.all((centres >= np.asarray(self.lo)) & (centres <= np.asarray(self.hi)), axis=1)


def camera_for(views, elev: float = 38.0, azim: float = -115.0, pad: float = 0.2) -> Camera:
    """One camera framing the occupied voxels of all ``views`` (so every panel looks the same)."""
    pts = np.vstack([v.centres[v.occupied] for v in views if v.occupied.any()] or [np.zeros((1, 3))])
    return Camera(elev, azim, tuple(pts.min(0) - pad), tuple(pts.max(0) + pad))


def chase_camera(trajectory: np.ndarray, behind: float = 14.0, ahead: float = 26.0,
                 side: float = 16.0, below: float = 2.6, above: float = 4.0, elev: float = 28.0,
                 zoom: float = 1.5) -> Camera:
    """A camera behind and above the car, looking along its direction of travel (as an RViz view
    that follows the car): the box spans ``behind`` m before the first pose to ``ahead`` m past the
    last, ``side`` m either side and ``below``/``above`` m around the sensor height.

    ``trajectory`` is the (T, 3) sensor origins [m], world frame; the heading is that of the
    displacement from the first to the last origin (the x axis when the car has not moved).
    """
    p = np.asarray(trajectory, float)
    d = p[-1, :2] - p[0, :2]
    heading = np.degrees(np.arctan2(d[1], d[0])) if np.hypot(*d) > 1e-6 else 0.0
    lo = (min(p[:, 0].min() - behind, p[:, 0].min() - side), p[:, 1].min() - side, p[:, 2].min() - below)
    hi = (max(p[:, 0].max() + ahead, p[:, 0].max() + side), p[:, 1].max() + side, p[:, 2].max() + above)
    return Camera(elev, heading + 180.0, lo, hi, zoom=zoom, persp=True)


def _view_vector(cam: Camera) -> np.ndarray:
    e, a = np.radians(cam.elev), np.radians(cam.azim)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


def visible_faces(idx: np.ndarray, cam: Camera):
    """Faces of voxels ``idx`` (M, 3 int) that no other voxel covers and that face the camera.

    Returns
    -------
    voxel : (F,) int array, the voxel of each face
    direction : (F,) int array, index into the six face directions
    """
    key = lambda a: (a[:, 0] + (1 << 20)) * (1 << 42) + (a[:, 1] + (1 << 20)) * (1 << 21) + (a[:, 2] + (1 << 20))
    keys = np.sort(key(idx))
    # perspective: a face turned slightly away from the view axis can still be seen off-centre
    toward = _DIRS @ _view_vector(cam) > (-0.5 if cam.persp else 0.0)
    vox, dirs = [], []
    for d in np.flatnonzero(toward):
        nb = key(idx + _DIRS[d])
        pos = np.minimum(np.searchsorted(keys, nb), len(keys) - 1)
        free = keys[pos] != nb
        vox.append(np.flatnonzero(free))
        dirs.append(np.full(int(free.sum()), d))
    return np.concatenate(vox), np.concatenate(dirs)


def draw_voxels(ax, centres: np.ndarray, rgb: np.ndarray, resolution: float, cam: Camera) -> None:
    """Draw voxels as shaded cubes on a 3D axis, seen from ``cam``.

    Parameters
    ----------
    ax : matplotlib 3D axis
    centres : (M, 3) float array [m], world frame
    rgb : (M, 3) float array in [0, 1], colour of each voxel
    resolution : float [m], voxel edge
    cam : Camera
    """
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    ax.view_init(elev=cam.elev, azim=cam.azim)
    ax.set_xlim(cam.lo[0], cam.hi[0])
    ax.set_ylim(cam.lo[1], cam.hi[1])
    ax.set_zlim(cam.lo[2], cam.hi[2])
    ax.set_box_aspect(np.array(cam.hi) - np.array(cam.lo), zoom=cam.zoom)
    if cam.persp:
        ax.set_proj_type("persp", focal_length=0.5)
    from matplotlib.ticker import MaxNLocator
    ax.set_xlabel("x [m]", labelpad=-6)
    ax.set_ylabel("y [m]", labelpad=-6)
    ax.set_zlabel("z [m]", labelpad=-5)
    ax.tick_params(labelsize=8, pad=-2)
    # the z extent is short on the page: three ticks at most, so that labels do not collide
    ax.zaxis.set_major_locator(MaxNLocator(nbins=2, steps=[1, 2, 5, 10]))
    ax.tick_params(axis="z", pad=1)
    if cam.persp:   # seen from behind the car the z axis is end-on: no z ticks, x labels off the box
        ax.set_zticks([])
        ax.set_zlabel("")
        ax.tick_params(axis="x", pad=3)
        ax.set_xlabel("x [m]", labelpad=4)
    if len(centres) == 0:
        return
    idx = np.floor(centres / resolution).astype(np.int64)
    vox, d = visible_faces(idx, cam)
    quads = (idx[vox, None, :] + _CORNERS[d]) * resolution
    colour = np.clip(rgb[vox] * _SHADE[d, None], 0, 1)
    ax.add_collection3d(Poly3DCollection(quads, facecolors=colour, edgecolors="none",
                                         linewidths=0, rasterized=True))


def class_rgb(view: MapView, mask: np.ndarray, present=None) -> np.ndarray:
    """(M, 3) colours in [0, 1] of the selected voxels' most likely classes (``present``: the
    classes the whole figure shows, see :func:`hw4.bki.palette.class_colors`)."""
    return class_colors(view.probs.shape[1], present)[view.cls[mask]] / 255.0


def variance_norm(vmax: float, log: bool = False, vmin: float | None = None):
    """The colour scale of variances: linear on ``[0, vmax]`` or logarithmic on
    ``[vmin, vmax]`` (default ``vmin = vmax / 1000``), clipped at both ends."""
    from matplotlib.colors import LogNorm, Normalize
    if not log:
        return Normalize(0, vmax, clip=True)
    return LogNorm(vmax / 1000 if vmin is None else vmin, vmax, clip=True)


def scalar_rgb(values: np.ndarray, vmax: float, cmap: str = "viridis", log: bool = False,
               vmin: float | None = None) -> np.ndarray:
    """(M, 3) colours in [0, 1] of scalars on the scale of :func:`variance_norm`."""
    from matplotlib import colormaps
    norm = variance_norm(vmax, log, vmin)
    return colormaps[cmap](np.ma.filled(norm(np.asarray(values, float)), 1.0))[:, :3]


def topdown(view: MapView, mask: np.ndarray, values: np.ndarray | None = None, lo=None, hi=None):
    """Top view: per (x, y) column the highest selected voxel.

    Parameters
    ----------
    view : MapView
    mask : (M,) bool, voxels to show (e.g. occupied)
    values : (M,) float, optional
        Show this scalar (e.g. variance) instead of the class.
    lo, hi : (2,) [m], optional
        x, y extent of the image (default: the selected voxels').

    Returns
    -------
    image : (H, W) int array of classes (-1 = empty) or (H, W) float array (NaN = empty);
        row 0 is the smallest y (use ``origin="lower"``)
    extent : (xmin, xmax, ymin, ymax) [m] for ``imshow``
    """
    r = view.resolution
    idx = np.floor(view.centres[mask] / r).astype(np.int64)
    if lo is None:
        lo = view.centres[mask, :2].min(0) if mask.any() else np.zeros(2)
        hi = view.centres[mask, :2].max(0) if mask.any() else np.ones(2)
    i0 = np.floor(np.asarray(lo) / r).astype(np.int64)
    i1 = np.floor(np.asarray(hi) / r).astype(np.int64)
    shape = (int(i1[1] - i0[1] + 1), int(i1[0] - i0[0] + 1))
    src = view.cls[mask] if values is None else values[mask]
    inside = np.all((idx[:, :2] >= i0) & (idx[:, :2] <= i1), axis=1)
    idx, src = idx[inside], src[inside]
    order = np.lexsort((idx[:, 2], idx[:, 0], idx[:, 1]))  # by column, then height
    idx, src = idx[order], src[order]
    col = (idx[:, 1] - i0[1]) * shape[1] + (idx[:, 0] - i0[0])
    last = np.r_[col[1:] != col[:-1], True]  # the highest voxel of each column
    if values is None:
        img = np.full(shape[0] * shape[1], -1, np.int64)
    else:
        img = np.full(shape[0] * shape[1], np.nan)
    img[col[last]] = src[last]
    extent = ((i0[0]) * r, (i1[0] + 1) * r, (i0[1]) * r, (i1[1] + 1) * r)
    return img.reshape(shape), extent


EMPTY = (0.80, 0.82, 0.86)
"""Colour of a top view's columns without a voxel: a blue-grey that prints clearly darker than the
paper (a light grey there read as the page itself) and is no class's colour."""


def class_image(img: np.ndarray, num_class: int, present=None) -> np.ndarray:
    """RGB image (H, W, 3) in [0, 1] of a class image from :func:`topdown` (empty = :data:`EMPTY`);
    ``present``: the classes the whole figure shows (default: those of ``img``), which decide the
    palette (:func:`hw4.bki.palette.class_colors`)."""
    if present is None:
        present = np.unique(img[img >= 0])
    pal = np.vstack([class_colors(num_class, present) / 255.0, [EMPTY]])
    return pal[np.where(img < 0, num_class, img)]


def figure_to_array(fig) -> np.ndarray:
    """The rendered figure as an (H, W, 3) uint8 array."""
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy()


def _blend(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    """The frame ``t`` of the way from ``a`` to ``b`` (0 <= t <= 1), both (H, W, 3) uint8."""
    return np.rint((1.0 - t) * a + t * b).astype(np.uint8)


def write_video(frames, gif_path=None, mp4_path=None, fps: float = 2.0, hold: int = 1,
                fade: int = 0, gif_fade: int | None = None, poster=None) -> list[Path]:
    """Write frames (list of (H, W, 3) uint8 arrays) as a looping GIF and/or an H.264 MP4.

    The MP4 plays at ``fps`` frames per second and shows each given frame for ``hold`` video
    frames, then cross-fades to the next over ``fade`` frames (each a blend of the two), so a few
    maps make a smooth video: 24 fps, ``hold=24`` and ``fade=12`` show each map for a second and
    take half a second to turn into the next. The GIF lasts as long but stores each map once, shown
    for ``hold / fps`` s, and the cross-fade in ``gif_fade`` frames (default ``min(fade, 1)``: one
    halfway blend), to stay small (each GIF frame is stored whole; the MP4 is the smooth one). The defaults (``hold=1``, ``fade=0``) write one video frame per given frame.
    The MP4 uses the ffmpeg binary shipped by ``imageio-ffmpeg``; frames are padded to even sizes.
    Beside the MP4 goes its poster frame, the last frame (the whole map), as ``<name>_poster.jpg``
    (:func:`poster_path`; the book's HTML player shows it before the video plays), or at
    ``poster`` when given.
    """
    import imageio.v2 as imageio
    if hold < 1 or fade < 0:
        raise ValueError(f"hold must be >= 1 and fade >= 0 (got {hold}, {fade})")
    gif_fade = min(fade, 1) if gif_fade is None else min(gif_fade, fade)
    out = []
    if gif_path is not None:
        seq, durations = [], []
        for i, f in enumerate(frames):
            seq.append(f)
            durations.append(1000.0 * hold / fps)
            if i + 1 < len(frames):
                for j in range(1, gif_fade + 1):
                    seq.append(_blend(f, frames[i + 1], j / (gif_fade + 1)))
                    durations.append(1000.0 * fade / fps / gif_fade)
        imageio.mimsave(gif_path, seq, duration=durations, loop=0)
        out.append(Path(gif_path))
    if mp4_path is not None:
        h, w = frames[0].shape[:2]
        pad = [np.pad(f, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge") for f in frames]
        with imageio.get_writer(mp4_path, fps=fps, codec="libx264", quality=7,
                                macro_block_size=1, ffmpeg_log_level="error",
                                output_params=["-pix_fmt", "yuv420p"]) as wr:
            for i, f in enumerate(pad):
                for _ in range(hold):
                    wr.append_data(f)
                if i + 1 < len(pad):
                    for j in range(1, fade + 1):
                        wr.append_data(_blend(f, pad[i + 1], j / (fade + 1)))
        out.append(Path(mp4_path))
        write_poster(frames[-1], poster if poster is not None else poster_path(mp4_path))
    return out


def _ffmpeg(ffmpeg=None) -> str:
    """The ffmpeg program: ``ffmpeg`` if given, else the binary shipped by ``imageio-ffmpeg``."""
    if ffmpeg:
        return str(ffmpeg)
    import imageio_ffmpeg
    return imageio_ffmpeg.get_ffmpeg_exe()


def poster_path(video) -> Path:
    """Where a video's poster frame goes: ``<video stem>_poster.jpg`` beside it."""
    video = Path(video)
    return video.with_name(video.stem + "_poster.jpg")


def write_poster(frame: np.ndarray, path) -> Path:
    """Save one (H, W, 3) uint8 frame as a JPEG poster (quality 85)."""
    from PIL import Image
    Image.fromarray(np.asarray(frame, np.uint8)[..., :3]).save(path, quality=85)
    return Path(path)


def first_coloured_frame(video, crop: str | None = None, min_fraction: float = 0.02,
                         min_chroma: int = 60, fps: float = 10.0, ffmpeg=None) -> float:
    """The time [s] of the first frame of ``video`` in which a map is drawn.

    A map's voxels are drawn in saturated class colours on RViz's grey or white background, its
    grid and panels (and on the black screen, the grey splash before RViz's window opens): a frame
    shows a map when at least ``min_fraction`` of the pixels of the region ``crop`` (``"w:h:x:y"``
    [px of the video], e.g. RViz's 3D view; ``None``: the whole frame) have a chroma (largest minus
    smallest of R, G, B, 0-255) of at least ``min_chroma``. Frames are sampled at ``fps`` [1/s].
    Raises ``ValueError`` when no frame shows a map."""
    import subprocess
    w, h = 160, 120                                   # decoded small: the fraction is what counts
    vf = f"fps={fps}," + (f"crop={crop}," if crop else "") + f"scale={w}:{h}"
    raw = subprocess.run([_ffmpeg(ffmpeg), "-loglevel", "error", "-i", str(video), "-vf", vf,
                          "-f", "rawvideo", "-pix_fmt", "rgb24", "-"],
                         check=True, capture_output=True).stdout
    frames = np.frombuffer(raw, np.uint8).reshape(-1, h, w, 3).astype(np.int16)
    chroma = frames.max(axis=3) - frames.min(axis=3)
    frac = (chroma >= min_chroma).mean(axis=(1, 2))
    hit = np.flatnonzero(frac >= min_fraction)
    if hit.size == 0:
        raise ValueError(f"no frame of {video} shows a map (largest coloured fraction "
                         f"{frac.max() if frac.size else 0:.4f} < {min_fraction}).")
    return float(hit[0] / fps)


def trim_video(video, out, start: float, ffmpeg=None, crf: int = 26) -> Path:
    """Write ``video`` from ``start`` [s] on to ``out`` (H.264, yuv420p, the index at the front so a
    browser can show the first frame before the rest arrives). ``out`` must differ from
    ``video``."""
    import subprocess
    if Path(out).resolve() == Path(video).resolve():
        raise ValueError("trim_video writes a new file: out must differ from video")
    subprocess.run([_ffmpeg(ffmpeg), "-loglevel", "error", "-y", "-ss", f"{max(start, 0.0):.2f}",
                    "-i", str(video), "-an", "-c:v", "libx264", "-preset", "veryfast", "-crf",
                    str(crf), "-pix_fmt", "yuv420p", "-movflags", "+faststart", str(out)], check=True)
    return Path(out)


def video_poster(video, out, before_end: float = 0.5, width: int | None = None,
                 ffmpeg=None) -> Path:
    """The poster frame of ``video`` (what the HTML player shows before it plays): its frame
    ``before_end`` [s] before the end, where the map is complete, as an image ``out`` (PNG or JPEG
    by its suffix), ``width`` [px] wide (``None``: the video's width)."""
    import subprocess
    cmd = [_ffmpeg(ffmpeg), "-loglevel", "error", "-y", "-sseof", f"-{before_end:.2f}", "-i",
           str(video), "-frames:v", "1"]
    if width:
        cmd += ["-vf", f"scale={int(width)}:-2"]
    if str(out).lower().endswith((".jpg", ".jpeg")):
        cmd += ["-q:v", "4"]
    subprocess.run(cmd + [str(out)], check=True)
    return Path(out)


def _mask(view: MapView, which: str) -> np.ndarray:
    if which == "occupied":
        return view.occupied
    if which == "reference":
        return view.state_reference == 2
    raise ValueError(f"unknown voxel selection {which!r}")


def draw_trajectory(ax, trajectory: np.ndarray, lift: float = 0.3) -> None:
    """The sensor origins (T, 3) [m] as a line with a dot per scan, ``lift`` m above the sensor,
    drawn over the voxels (on a 3D axis) or on a top view (2D axis)."""
    p = np.asarray(trajectory, float)
    kw = dict(color="black", lw=1.6, marker="o", ms=3.2, mfc="white", mec="black", mew=0.8,
              zorder=1000, label="car trajectory")
    if getattr(ax, "name", "") == "3d":
        ax.computed_zorder = False
        ax.plot(p[:, 0], p[:, 1], p[:, 2] + lift, **kw)
    else:
        ax.plot(p[:, 0], p[:, 1], **kw)


def plot_maps(views: dict, cam: Camera, colour: str = "class", which: str = "occupied",
              vmax: float = 0.09, width: float = 5.0, fig=None, trajectory=None,
              legend_cols: int = 1, log_variance: bool = False, legend: str = "right",
              stack: bool = False, tall: float | None = None, below_cols: int = 6):
    """3D voxel renders of several maps side by side, all seen from the same camera.

    Parameters
    ----------
    views : dict of title -> MapView
    cam : Camera (only voxels inside its box are drawn)
    colour : {"class", "variance"}
    which : {"occupied", "reference"}
        Occupied voxels with ``var_thresh`` applied, or as the reference shows them (without).
    vmax : float, top of the variance colour scale
    width : float [inch] per panel
    trajectory : (T, 3) array [m], optional
        Sensor origins, drawn as the car's path.
    legend_cols : int, columns of the class legend
    log_variance : bool, logarithmic variance scale (see :func:`variance_norm`)
    legend : {"right", "below"}
        Where the class legend goes. ``"below"`` (for print) keeps the figure ``width * n`` wide:
        the legend runs under the panels, and a variance colour bar takes its width from them.
    stack : bool
        With ``legend="below"``: the panels one above the other, each ``width`` inch wide (a
        full-page figure of a large map), instead of side by side.
    tall : float, optional
        Height / width of a panel (default: 0.85 for a perspective camera, else 0.8).
    below_cols : int
        Columns of the class legend below the panels (``legend="below"``); fewer for a narrow
        figure, whose legend would otherwise run wider than the panels.
    """
    import matplotlib.pyplot as plt
    n = len(views)
    below = legend == "below"
    if fig is None:
        given, tall = tall, 1.0 if cam.persp else 0.8  # a zoomed view from the car reaches past its axes
        if below:
            tall = given or (0.85 if cam.persp else 0.8)
            side = 0.75 if colour == "variance" else 0.0
            rows = 0 if colour == "variance" else 1 + (len(legend_handles(views, cam, trajectory is not None)) - 1) // below_cols
            foot = 0.2 * rows + 0.25 * (rows > 0)             # [in] for the legend rows
            w_total, h_total = width * n, (width * n - side) / n * tall + foot
            if stack:
                w_total, h_total = width, (width - side) * tall * n + foot
            fig = plt.figure(figsize=(w_total, h_total))
            fig.subplots_adjust(left=0.0, right=1 - side / w_total,
                                bottom=foot / h_total + (0.08 if cam.persp else 0.0) / (n if stack else 1),
                                top=0.97 if stack else (1.02 if cam.persp else 0.95),
                                wspace=0.05, hspace=0.02)
        else:
            side = 0.8 if colour == "variance" else 1.45      # [in] for the colour bar or legend
            if not cam.persp:   # room for the titles and the x / z labels around the tilted box
                tall = 0.95
            fig = plt.figure(figsize=(width * n + side, width * tall))
            fig.subplots_adjust(left=0.0 if cam.persp else 0.05, right=1 - side / (width * n + side),
                                bottom=0.17 if cam.persp else 0.1, top=0.92 if cam.persp else 0.88,
                                wspace=0.05 if cam.persp else 0.12)
    axes = []
    present = shown_classes(views, cam)
    for i, (title, v) in enumerate(views.items()):
        ax = fig.add_subplot(*((n, 1) if stack else (1, n)), i + 1, projection="3d")
        m = _mask(v, which) & cam.inside(v.centres)
        rgb = class_rgb(v, m, present) if colour == "class" else scalar_rgb(v.variance[m], vmax, log=log_variance)
        draw_voxels(ax, v.centres[m], rgb, v.resolution, cam)
        if trajectory is not None:
            draw_trajectory(ax, trajectory)
        # stacked: the title just above the drawing, clear of the x label of the panel above
        ax.set_title(title, fontsize=9.5, y=0.86 if stack else None)
        axes.append(ax)
    if colour == "variance":
        if below:
            variance_colorbar(fig, axes, vmax, log=log_variance, cax=side_axis(fig, 0.55))
        else:
            variance_colorbar(fig, axes, vmax, log=log_variance)
    elif below:
        _class_legend(fig, views, loc="lower center", cam=cam, trajectory=trajectory is not None,
                      ncol=below_cols)
    else:
        _class_legend(fig, views, loc="center right", cam=cam, ncol=legend_cols,
                      trajectory=trajectory is not None)
    return fig


def side_axis(fig, height: float, width: float = 0.12):
    """An axis for a colour bar at the right edge of ``fig``, ``height`` of the figure's height
    (centred on the panels' area) and ``width`` inch wide."""
    fw, _ = fig.get_size_inches()
    p = fig.subplotpars
    mid, h = (p.bottom + p.top) / 2, height * (p.top - p.bottom)
    return fig.add_axes([p.right + 0.06 / fw, mid - h / 2, width / fw, h])


def variance_colorbar(fig, axes, vmax: float, log: bool = False, cax=None):
    """A colour bar for variance colours (scale of :func:`variance_norm`) beside ``axes``
    (or in ``cax``, an axis of its own)."""
    from matplotlib.cm import ScalarMappable
    sm = ScalarMappable(variance_norm(vmax, log), "viridis")
    if cax is not None:
        return fig.colorbar(sm, cax=cax, label="variance of the\nmost likely class")
    return fig.colorbar(sm, ax=axes, shrink=0.6, pad=0.02, label="variance of the most likely class")


def shown_classes(views, cam: Camera | None = None) -> list:
    """The classes of the occupied voxels inside ``cam``'s box over all ``views``, sorted."""
    shown = [w.cls[w.occupied & (cam.inside(w.centres) if cam is not None else True)]
             for w in views.values()]
    return sorted(set(np.concatenate(shown).tolist()) - {0})


def legend_handles(views, cam: Camera | None = None, trajectory: bool = False) -> list:
    """Legend handles of the classes shown (occupied voxels inside ``cam``'s box) and the path."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from .palette import class_names
    v = next(iter(views.values()))
    K = v.probs.shape[1]
    present = shown_classes(views, cam)
    pal, names = class_colors(K, present) / 255.0, class_names(K)
    handles = [Patch(color=pal[k], label=names[k]) for k in present]
    if trajectory:
        handles.append(Line2D([], [], color="black", lw=1.6, marker="o", ms=3.2, mfc="white",
                              mec="black", label="car trajectory"))
    return handles


def _class_legend(fig, views, loc: str = "lower center", cam: Camera | None = None,
                  ncol: int | None = None, trajectory: bool = False) -> None:
    """A legend of the classes shown (occupied voxels inside ``cam``'s box), 8.5 pt."""
    handles = legend_handles(views, cam, trajectory)
    if ncol is None:
        ncol = 1 if loc == "center right" else 6
    if loc != "center right":
        ncol = min(len(handles), ncol) or 1
    fig.legend(handles=handles, loc=loc, ncol=ncol, fontsize=8.5, frameon=False,
               handlelength=1.2, handletextpad=0.5, columnspacing=1.0)


def plot_topdown(views: dict, cam: Camera, colour: str = "class", which: str = "occupied",
                 vmax: float = 0.09, width: float = 4.0, trajectory=None, log_variance: bool = False,
                 vmin: float | None = None):
    """Top views of several maps side by side (highest selected voxel per column), same extent.

    ``which`` selects the voxels: "occupied" (with var_thresh) or "reference" (every voxel with a
    class, without it). ``trajectory`` (T, 3) [m] draws the car's path; ``log_variance`` puts the
    variance on a logarithmic colour scale from ``vmin`` (default ``vmax / 1000``) to ``vmax``
    (real scans span several decades).
    """
    import matplotlib.pyplot as plt
    n = len(views)
    aspect = (cam.hi[1] - cam.lo[1]) / max(cam.hi[0] - cam.lo[0], 1e-9)
    height = min(width * aspect, width * 1.5) + (0.9 if colour == "variance" or trajectory is None else 1.3)
    fig, axes = plt.subplots(1, n, figsize=(width * n + (0.8 if colour == "variance" else 0), height),
                             squeeze=False, layout="constrained")
    im = None
    present = shown_classes(views, cam)
    for ax, (title, v) in zip(axes[0], views.items()):
        m = _mask(v, which)
        if colour == "class":
            img, ext = topdown(v, m, lo=cam.lo[:2], hi=cam.hi[:2])
            ax.imshow(class_image(img, v.probs.shape[1], present), origin="lower", extent=ext,
                      interpolation="nearest")
        else:
            img, ext = topdown(v, m, values=v.variance, lo=cam.lo[:2], hi=cam.hi[:2])
            ax.set_facecolor(EMPTY)
            im = ax.imshow(img, origin="lower", extent=ext, cmap="viridis",
                           norm=variance_norm(vmax, log_variance, vmin),
                           interpolation="nearest")
        if trajectory is not None:
            draw_trajectory(ax, trajectory)
        ax.set_title(title, fontsize=9.5)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_aspect("equal")
    if im is not None:   # a bar exactly as tall as the (aspect-locked) panel beside it
        cax = axes[0, -1].inset_axes([1.04, 0.0, 0.045, 1.0])
        fig.colorbar(im, cax=cax, label="variance of the\nmost likely class")
    else:
        _class_legend(fig, views, loc="outside lower center", cam=cam,
                      trajectory=trajectory is not None)
    return fig


def state_slice(view: MapView, z: float, which: str = "occupied", lo=None, hi=None, present=None):
    """RGB image of the voxel layer containing height ``z`` [m]: occupied voxels in their class
    colour, free white, unknown (variance above var_thresh) mid grey, no evidence light grey.

    ``which="reference"`` ignores var_thresh as the reference implementation does; ``present``
    (the classes of the whole figure) picks the palette. Returns the (H, W, 3) image (row 0 =
    smallest y) and its ``imshow`` extent [m].
    """
    r = view.resolution
    k = int(np.floor(z / r))
    layer = np.floor(view.centres[:, 2] / r).astype(np.int64) == k
    state = view.state if which == "occupied" else view.state_reference
    img, ext = topdown(view, layer, values=state.astype(float), lo=lo, hi=hi)
    cls, _ = topdown(view, layer, lo=lo, hi=hi)
    K = view.probs.shape[1]
    rgb = np.empty(img.shape + (3,))
    rgb[:] = 0.85                                         # no evidence
    rgb[img == 0] = 0.5                                   # unknown
    rgb[img == 1] = 1.0                                   # free
    occ = img == 2
    rgb[occ] = class_colors(K, present)[cls[occ]] / 255.0
    return rgb, ext


def vertical_slice(view: MapView, x: float, which: str = "occupied", lo=None, hi=None,
                   present=None):
    """RGB image of the voxel layer across the x axis that contains ``x`` [m] (a cut in the y-z
    plane, seen along +x): occupied voxels in their class colour, free white, unknown (variance
    above var_thresh) mid grey, no evidence light grey.

    ``lo``, ``hi`` : (2,) [m], the (y, z) extent (default: the layer's voxels'); ``which`` and
    ``present`` as in :func:`state_slice`. Returns the (H, W, 3) image (row 0 = lowest z, column
    0 = smallest y) and its ``imshow`` extent (ymin, ymax, zmin, zmax) [m].
    """
    r = view.resolution
    idx = np.floor(view.centres / r).astype(np.int64)
    layer = idx[:, 0] == int(np.floor(x / r))
    yz = idx[layer][:, 1:]
    if lo is None:
        lo = yz.min(0) * r if len(yz) else np.zeros(2)
        hi = yz.max(0) * r if len(yz) else np.ones(2)
    i0 = np.floor(np.asarray(lo) / r).astype(np.int64)
    i1 = np.floor(np.asarray(hi) / r).astype(np.int64)
    state = (view.state if which == "occupied" else view.state_reference)[layer]
    cls = view.cls[layer]
    inside = np.all((yz >= i0) & (yz <= i1), axis=1)
    yz, state, cls = yz[inside] - i0, state[inside], cls[inside]
    rgb = np.full((int(i1[1] - i0[1] + 1), int(i1[0] - i0[0] + 1), 3), 0.85)   # no evidence
    rgb[yz[state == 0, 1], yz[state == 0, 0]] = 0.5                              # unknown
    rgb[yz[state == 1, 1], yz[state == 1, 0]] = 1.0                              # free
    occ = state == 2
    rgb[yz[occ, 1], yz[occ, 0]] = class_colors(view.probs.shape[1], present)[cls[occ]] / 255.0
    extent = (i0[0] * r, (i1[0] + 1) * r, i0[1] * r, (i1[1] + 1) * r)
    return rgb, extent


def plot_vertical_slices(views: dict, x: float, lo, hi, width: float = 7.0, panel_height=None):
    """Vertical cuts (:func:`vertical_slice`) of several maps at the same ``x`` [m], one above the
    other, over the (y, z) box ``lo``..``hi`` [m], with one legend of the classes in the cuts.

    Voxels are drawn square; ``width`` [inch] is the figure's width.
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch
    from .palette import class_names
    r = next(iter(views.values())).resolution
    k = int(np.floor(x / r))
    box_lo, box_hi = np.r_[k * r, lo], np.r_[(k + 1) * r, hi]
    cut = {t: (np.all((w.centres >= box_lo) & (w.centres <= box_hi), axis=1), w) for t, w in views.items()}
    present = sorted(set(np.concatenate([w.cls[m & (w.state == 2)] for m, w in cut.values()]).tolist()) - {0})
    states = set(np.concatenate([w.state[m] for m, w in cut.values()]).tolist())
    n = len(views)
    aspect = (hi[1] - lo[1]) / (hi[0] - lo[0])
    ph = panel_height or (width - 0.6) * aspect + 0.45
    fig, axes = plt.subplots(n, 1, figsize=(width, ph * n + 0.75), squeeze=False,
                             layout="constrained", sharex=True)
    for ax, (title, v) in zip(axes[:, 0], views.items()):
        rgb, ext = vertical_slice(v, x, "occupied", lo=lo, hi=hi, present=present)
        ax.imshow(rgb, origin="lower", extent=ext, interpolation="nearest")
        ax.set_title(title, fontsize=9.5)
        ax.set_ylabel("z [m]")
        ax.set_aspect("equal")
    axes[-1, 0].set_xlabel("y [m]")
    K = next(iter(views.values())).probs.shape[1]
    pal, names = class_colors(K, present) / 255.0, class_names(K)
    handles = [Patch(color=pal[c], label=names[c]) for c in present]
    if 1 in states:
        handles.append(Patch(facecolor="white", edgecolor="0.3", label="free"))
    if 0 in states:
        handles.append(Patch(color="0.5", label="unknown"))
    handles.append(Patch(color="0.85", label="no evidence"))
    fig.legend(handles=handles, loc="outside lower center",
               ncol=len(handles) if len(handles) <= 8 else 6,
               fontsize=8.5, frameon=False, handlelength=1.2, columnspacing=1.0)
    return fig


def plot_slices(panels: dict, z: float, cam: Camera, width: float = 4.0, fit: bool = False):
    """Horizontal slices at height ``z`` [m] side by side: ``panels`` maps a title to
    ``(MapView, which)`` with ``which`` in {"occupied", "reference"}, ``width`` inch per panel.

    ``fit=True``: the figure is as tall as the slices' aspect ratio needs for each to fill its
    ``width`` (instead of ``1.15 * width``), and the panels share their y axis (labelled once)."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch
    n = len(panels)
    span = np.asarray(cam.hi[:2], float) - np.asarray(cam.lo[:2], float)
    height = width * 1.15 if not fit else (width - 0.15) * span[1] / span[0] + 1.25
    fig, axes = plt.subplots(1, n, figsize=(width * n, height), squeeze=False,
                             layout="constrained", sharey=fit)
    present = sorted(set(np.concatenate([w.cls[w.state_reference == 2] for w, _ in panels.values()]).tolist()))
    for ax, (title, (v, which)) in zip(axes[0], panels.items()):
        rgb, ext = state_slice(v, z, which, lo=cam.lo[:2], hi=cam.hi[:2], present=present)
        ax.imshow(rgb, origin="lower", extent=ext, interpolation="nearest")
        ax.set_title(title, fontsize=9.5)
        ax.set_xlabel("x [m]")
        if not fit or ax is axes[0][0]:
            ax.set_ylabel("y [m]")
    from .palette import class_names
    v = next(iter(panels.values()))[0]
    K = v.probs.shape[1]
    handles = [Patch(color=class_colors(K, present)[k] / 255.0, label=class_names(K)[k]) for k in present]
    handles += [Patch(facecolor="white", edgecolor="0.3", label="free"),
                Patch(color="0.5", label="unknown (variance > var_thresh)"),
                Patch(color="0.85", label="no evidence")]
    fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 4), fontsize=8.5,
               frameon=False)
    return fig


def release_memory() -> None:
    """Collect garbage and hand freed heap memory back to the system (glibc's ``malloc_trim``;
    elsewhere only the collection): a 3D figure of ~100k voxel faces is a reference cycle, and
    the heap keeps the room of freed figures and views, which counts as the process's memory."""
    import ctypes
    import gc
    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def mapping_video(view_groups, cam: Camera, titles, gif=None, mp4=None, strip=None,
                  strip_scans=None, width: float = 4.0, dpi: int = 120, fps: float = 2.0,
                  trajectory=None, strip_width: float = 7.0, hold: int = 1, fade: int = 0,
                  poster=None) -> list:
    """Render the map after each scan (methods side by side) and write GIF, MP4 and a PNG strip.

    Parameters
    ----------
    view_groups : iterable of tuples of MapView, one tuple per inserted scan (one view per method)
    cam : Camera, the same for every frame
    titles : sequence of str, one per method
    gif, mp4, strip : path, optional
        Where to write the animation (GIF, MP4) and a PNG of some frames stacked (for print).
    strip_scans : sequence of int, optional
        1-based scan numbers of the strip's frames (default: four evenly spaced, ending with the last).
    strip_width : float [inch], width of the strip (:func:`plot_strip`), its print size
    fps, hold, fade : frame rate, video frames per map and cross-fade frames between maps
        (:func:`write_video`; e.g. 24, 24, 12 for a smooth video)
    poster : path, optional
        Where the MP4's poster frame goes (default: beside it, :func:`poster_path`).
    trajectory : (T, 3) array [m], optional
        Sensor origins; frame ``i`` draws the path up to scan ``i``.

    Returns
    -------
    list of (H, W, 3) uint8 frames
    """
    import matplotlib.pyplot as plt
    frames, kept = [], []
    for i, views in enumerate(view_groups):
        keep = strip is not None and (strip_scans is None or i + 1 in strip_scans)
        kept.append(views if keep else None)
        fig = plot_maps({f"{t}, {scans_done(i + 1)}": v for t, v in zip(titles, views)}, cam, width=width,
                        trajectory=None if trajectory is None else np.asarray(trajectory)[:i + 1])
        fig.set_dpi(dpi)
        frames.append(figure_to_array(fig))
        plt.close(fig)
        del fig, views  # free this frame's map views and figure before the next map is viewed
        release_memory()
    write_video(frames, gif, mp4, fps, hold=hold, fade=fade, poster=poster)
    if strip is not None:
        n = len(frames)
        picks = strip_scans or sorted({max(1, round(n * q)) for q in (0.25, 0.5, 0.75, 1.0)})
        fig = plot_strip([kept[k - 1] for k in picks], picks, cam, titles,
                         trajectory=trajectory, width=strip_width)
        save_png(fig, strip, dpi=200)
        plt.close(fig)
    return frames


def plot_strip(view_groups, scans, cam: Camera, titles, trajectory=None, width: float = 7.0,
               max_height: float = 7.0, dpi: int = 200):
    """Some frames of the mapping video for print: one row per scan, the methods side by side in
    it (as in the video), ``width`` inch wide and at most ``max_height`` inch tall, with one class
    legend under all of them.

    Each still is drawn on its own (from ``cam``, without axes, the axes being those of the
    full-size figures) and all are cropped to the box that holds the drawing of any of them, so
    the maps fill the stills and every still shows the same part of the scene.
    ``view_groups`` holds one tuple of MapView per row, ``scans`` the 1-based scan number of each.
    """
    import dataclasses
    import matplotlib.pyplot as plt
    rows, cols = len(view_groups), len(titles)
    label_w, head = 0.3, 0.25                    # [in] row labels at the left, column titles
    cam = dataclasses.replace(cam, zoom=min(cam.zoom, 1.15))   # so that the drawing fits its axes
    last = {t: v for t, v in zip(titles, view_groups[-1])}
    present = shown_classes(last, cam)
    legend_rows = 1 + (len(legend_handles(last, cam, trajectory is not None)) - 1) // 6
    foot = 0.2 * legend_rows + 0.15
    side = (width - label_w) / cols              # [in] the square each still is drawn in
    stills = []
    for views, k in zip(view_groups, scans):
        for v in views:
            f = plt.figure(figsize=(side, side))
            ax = f.add_axes([0, 0, 1, 1], projection="3d")
            m = v.occupied & cam.inside(v.centres)
            draw_voxels(ax, v.centres[m], class_rgb(v, m, present), v.resolution, cam)
            if trajectory is not None:
                draw_trajectory(ax, np.asarray(trajectory)[:k])
            ax.set_axis_off()
            f.set_dpi(dpi * 1.25)                # a little finer than print: the crop is enlarged
            stills.append(figure_to_array(f))
            plt.close(f)
    ink = np.any(np.stack([np.any(a < 245, axis=-1) for a in stills]), axis=0)
    r = np.flatnonzero(ink.any(1))
    c = np.flatnonzero(ink.any(0))
    r0, r1 = max(r[0] - 4, 0), r[-1] + 5
    c0, c1 = max(c[0] - 4, 0), c[-1] + 5
    aspect = (r1 - r0) / (c1 - c0)               # height / width of a cropped still
    w = min(side, (max_height - head - foot) / rows / aspect)
    h = w * aspect
    fw = label_w + cols * w
    height = head + rows * h + foot
    fig = plt.figure(figsize=(width, height))
    x0 = (width - fw) / 2 + label_w              # [in] left edge of the stills, centred
    for i, a in enumerate(stills):
        row, col = divmod(i, cols)
        ax = fig.add_axes([(x0 + col * w) / width, (foot + (rows - 1 - row) * h) / height,
                           w / width, h / height])
        ax.imshow(a[r0:r1, c0:c1], interpolation="antialiased")
        ax.set_axis_off()
        if row == 0:
            ax.set_title(titles[col], fontsize=9.5, pad=2)
        if col == 0:
            ax.text(-0.02, 0.5, scans_done(scans[row]), transform=ax.transAxes, rotation=90,
                    ha="right", va="center", fontsize=9)
    _class_legend(fig, last, loc="lower center", cam=cam, trajectory=trajectory is not None)
    return fig


def scans_done(n: int) -> str:
    """Label of a map after its first ``n`` scans: 'after 1 scan', 'after 5 scans' (a count, so
    that it never reads as a scan's index, which the book counts from 0)."""
    return f"after {n} scan" + ("" if n == 1 else "s")


def save_png(fig, path, dpi: int = 200) -> None:
    """Write ``fig`` as a PNG of at most 256 colours (:func:`png_bytes`) to ``path``."""
    Path(path).write_bytes(png_bytes(fig, dpi))


def png_bytes(fig, dpi: int = 200, n_exact: int = 200) -> bytes:
    """``fig`` as PNG bytes at ``dpi`` with a palette of 256 colours, without dithering.

    The palette holds the ``n_exact`` most frequent colours exactly (the flat class colours of
    faces and legend patches stay true) and fills the rest by maximum coverage (edges, gradients);
    voxel renders hold few distinct colours, and the file is about a third of the RGB PNG's size.
    """
    import io
    from PIL import Image
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    img = Image.open(io.BytesIO(buf.getvalue())).convert("RGB")
    a = np.asarray(img)
    packed = (a[..., 0].astype(np.int64) << 16) | (a[..., 1].astype(np.int64) << 8) | a[..., 2]
    vals, inverse, counts = np.unique(packed.ravel(), return_inverse=True, return_counts=True)
    top = vals[np.argsort(-counts, kind="stable")[:n_exact]]
    rest = 256 - len(top)
    cover = img.quantize(rest, method=Image.Quantize.MAXCOVERAGE, dither=Image.Dither.NONE)
    palette = np.vstack([np.column_stack([(top >> 16) & 255, (top >> 8) & 255, top & 255]),
                         np.asarray(cover.getpalette()[:3 * rest]).reshape(-1, 3)]).astype(np.int64)
    colours = np.column_stack([(vals >> 16) & 255, (vals >> 8) & 255, vals & 255])
    nearest = np.empty(len(vals), np.uint8)       # each distinct colour to its nearest entry
    for i in range(0, len(vals), 4096):
        d = ((colours[i:i + 4096, None, :] - palette[None]) ** 2).sum(-1)
        nearest[i:i + 4096] = d.argmin(1)
    out_img = Image.fromarray(nearest[inverse].reshape(a.shape[:2]), mode="P")
    out_img.putpalette(palette.astype(np.uint8).ravel().tolist())
    out = io.BytesIO()
    out_img.save(out, format="PNG", optimize=True, dpi=(dpi, dpi))  # print size = drawn size
    return out.getvalue()


def show(fig, dpi: int = 200):
    """Display ``fig`` in a notebook as a palette PNG (:func:`png_bytes`) at ``dpi`` and close it:
    print-size figures at print resolution, at a third of the stored size."""
    import matplotlib.pyplot as plt
    from IPython.display import Image, display
    data = png_bytes(fig, dpi)
    plt.close(fig)
    display(Image(data=data, format="png"))

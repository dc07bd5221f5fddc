"""The map growing scan by scan: incremental evidence, frames, GIF / MP4 and a strip of frames.

A counting sensor model is incremental by construction when a scan's evidence does not depend
on the other scans: the counts after scans ``0 .. n`` are those after ``0 .. n - every`` plus the
evidence of the new block. That holds with ``nearest_poses=None`` (every pose within range). The
template's rule "the 16 poses nearest to the cell" picks poses from the whole trajectory, so it
is a batch rule; :func:`incremental_counts` refuses it.
"""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import matplotlib.pyplot as plt

from ..core.errors import InputError
from ..core.evidence import count_evidence
from ..core.grid import Grid
from ..core import plotting

EVERY = 25  # scans per animation frame
PATH_COLOR = "black"  # the robot's path: apart from every class colour (crimson was close to hallways' pink)


def incremental_counts(data, every: int = EVERY, grid_size: float = 0.135, semantic: bool = True,
                       model: str = "continuous", nearest_poses=None, beams: str = "all", **kw):
    """Yield ``(n_scans, grid, counts)`` after the first ``every``, ``2 every``, ... scans.

    Parameters
    ----------
    data : IntelData
        Poses (T, 3) [m, m, rad] world frame, scans robot frame (3 x N for ``semantic``).
    every : int
        Scans per step; the last step may be shorter (743 = 29 x 25 + 18).
    grid_size : float [m]
    semantic, model, beams, **kw
        Passed to :func:`hw4.core.evidence.count_evidence`; default the continuous semantic CSM with
        every beam (the full kernel sums of Eq. 9).
    nearest_poses : None
        Must be None (every pose within range), see the module docstring.

    The ``counts`` array yielded is updated in place by the next step: copy it to keep it.
    """
    if nearest_poses is not None:
        raise InputError("incremental maps need nearest_poses=None: the nearest-poses rule "
                         "depends on the whole trajectory.")
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise InputError(f"every must be a positive integer number of scans; got {every!r}.")
    grid = Grid(grid_size, n_classes=7 if semantic else 2)
    if model == "continuous":
        kw["beams"] = beams
    counts = None
    n = len(data.scans)
    for s in range(0, n, every):
        e = min(s + every, n)
        c = count_evidence(grid, data.poses[s:e], data.scans[s:e], model=model,
                           semantic=semantic, nearest_poses=None, **kw)
        if counts is None:
            counts = c
        else:
            counts += c
        yield e, grid, counts


def _semantic_view(grid, counts, prior=1e-3):
    """What :func:`hw4.core.plotting.semantic_rgb` needs, from semantic counts (free last)."""
    return SimpleNamespace(grid=grid, map={"alpha": prior + counts}, num_classes=counts.shape[1] - 1,
                           observed=counts.sum(axis=1) > 0)


def draw_frame(ax, grid, counts, poses, n_scans: int, legend: bool = False):
    """Draw the semantic map after ``n_scans`` scans, with the path so far and the current pose."""
    view = _semantic_view(grid, counts)
    plotting.plot_semantic(view, ax=ax, legend=legend)
    p = np.asarray(poses)[:n_scans]
    ax.plot(p[:, 0], p[:, 1], "-", color=PATH_COLOR, lw=0.8)
    ax.plot(p[-1, 0], p[-1, 1], "o", color=PATH_COLOR, ms=4)
    ax.text(0.98, 0.02, f"{n_scans} scans", transform=ax.transAxes, ha="right", va="bottom",
            fontsize=9, bbox=dict(facecolor="white", edgecolor="0.7", pad=2))


def render_frames(data, every: int = EVERY, grid_size: float = 0.135, size_px: int = 512,
                  keep=(), **kw) -> tuple:
    """RGB frames (uint8, ``size_px`` square) of the growing semantic map, one per step.

    Returns ``(frames, kept)``: the list of frames, and ``{n_scans: counts copy}`` for the step
    counts listed in ``keep`` (for a strip of frames).
    """
    if size_px % 16:
        raise InputError(f"size_px must be a multiple of 16 (video macro blocks); got {size_px}.")
    dpi = 100
    fig = plt.figure(figsize=(size_px / dpi, size_px / dpi), dpi=dpi)
    ax = fig.add_axes([0.11, 0.08, 0.87, 0.9])
    frames, kept = [], {}
    for n, grid, counts in incremental_counts(data, every, grid_size, **kw):
        ax.clear()
        draw_frame(ax, grid, counts, data.poses, n, legend=True)
        fig.canvas.draw()
        frames.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
        if n in keep:
            kept[n] = (grid, counts.copy())
    plt.close(fig)
    return frames, kept


def write_gif(frames, path, seconds_per_frame: float = 0.25, hold_last: int = 6) -> Path:
    """Write an endlessly looping GIF; the last frame is held ``hold_last`` times as long."""
    import imageio.v3 as iio
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ms = int(round(seconds_per_frame * 1000))
    durations = [ms] * (len(frames) - 1) + [ms * hold_last]
    iio.imwrite(path, np.stack(frames), extension=".gif", duration=durations, loop=0)
    return path


def write_mp4(frames, path, fps: int = 4) -> Path | None:
    """Write an H.264 MP4 with the ffmpeg that imageio-ffmpeg ships, and its poster frame (the last
    frame) as ``<name>_poster.jpg`` beside it; None when imageio-ffmpeg is unavailable."""
    try:
        import imageio.v2 as iio2
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        return None
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    w = iio2.get_writer(path, format="FFMPEG", mode="I", fps=fps, codec="libx264",
                        pixelformat="yuv420p", quality=7, macro_block_size=16,
                        ffmpeg_log_level="error",
                        output_params=["-threads", "1", "-fflags", "+bitexact",
                                       "-map_metadata", "-1"])
    for f in list(frames) + [frames[-1]] * (2 * fps):  # hold the final map two seconds
        w.append_data(f)
    w.close()
    from ..bki.render import poster_path, write_poster
    write_poster(frames[-1], poster_path(path))   # the HTML player's poster: the whole map
    return path


def strip_figure(kept: dict, poses, ncols: int = 3, width: float = 7.0):
    """A grid of frames (the PDF's stand-in for the animation) from ``render_frames``' ``kept``.

    Drawn at its print size, ``width`` [in] wide (text 8.5-9 pt), with one legend below the
    panels.
    """
    ns = sorted(kept)
    nrows = int(np.ceil(len(ns) / ncols))
    grid0 = kept[ns[0]][0]
    aspect = np.ptp(grid0.y) / max(np.ptp(grid0.x), 1e-9)
    height = nrows * (width / ncols) * aspect + 0.75   # + the legend row
    fig, axes = plt.subplots(nrows, ncols, figsize=(width, height), layout="constrained",
                             sharex=True, sharey=True)
    axes = np.atleast_1d(axes).reshape(-1)
    for ax, n in zip(axes, ns):
        grid, counts = kept[n]
        draw_frame(ax, grid, counts, poses, n)
        ax.label_outer()
    for ax in axes[len(ns):]:
        ax.axis("off")
    fig.legend(handles=plotting.class_handles(6), loc="outside lower center", ncol=4,
               frameon=False, fontsize=8.5)
    return fig


def label_changes(kept: dict) -> list:
    """How the most likely class of cells changes between kept frames of the growing map.

    Parameters
    ----------
    kept : dict ``n_scans -> (grid, counts)`` as :func:`render_frames` returns it (semantic
        counts, free space last).

    Returns
    -------
    list of dict, one per pair of consecutive kept frames (``n_from``, ``n_to``):
    ``region_both`` (cells with a region class in both frames), ``swapped`` (their share whose
    region changed), ``to_free`` (share of the earlier frame's region cells now most likely free),
    ``mixed_swapped`` (share of the swapped cells whose region evidence, at the later frame, comes
    from more than one label: the label noise behind the colour change).
    """
    steps = sorted(kept)
    out = []
    for a, b in zip(steps[:-1], steps[1:]):
        (_, ca), (_, cb) = kept[a], kept[b]
        free = ca.shape[1] - 1
        la = np.where(ca.sum(axis=1) > 0, np.argmax(ca, axis=1), -1)
        lb = np.where(cb.sum(axis=1) > 0, np.argmax(cb, axis=1), -1)
        ra = (la >= 0) & (la != free)
        rb = (lb >= 0) & (lb != free)
        both = ra & rb
        swapped = both & (la != lb)
        mixed = (cb[:, :free] > 0).sum(axis=1) > 1
        out.append({"n_from": int(a), "n_to": int(b), "region_both": int(both.sum()),
                    "swapped": float(swapped.sum() / max(both.sum(), 1)),
                    "to_free": float((ra & (lb == free)).sum() / max(ra.sum(), 1)),
                    "mixed_swapped": float((swapped & mixed).sum() / max(swapped.sum(), 1))})
    return out

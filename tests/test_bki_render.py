"""The mapping video's timing: each map held, cross-faded into the next (render.write_video)."""
import numpy as np
import pytest

from hw4.bki import render


def _decoded(path, shape=(16, 24, 3)) -> np.ndarray:
    """The frames of an MP4 (decoded by the ffmpeg binary of imageio-ffmpeg), (N, H, W, 3)."""
    import subprocess
    import imageio_ffmpeg
    raw = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-i", str(path),
                          "-f", "rawvideo", "-pix_fmt", "rgb24", "-"], check=True,
                         capture_output=True).stdout
    return np.frombuffer(raw, np.uint8).reshape((-1,) + shape)


def _frames():
    return [np.full((16, 24, 3), v, np.uint8) for v in (0, 200, 100)]


def test_mp4_holds_each_map_and_cross_fades(tmp_path):
    render.write_video(_frames(), mp4_path=tmp_path / "v.mp4", fps=10, hold=3, fade=2)
    got = [f.mean() for f in _decoded(tmp_path / "v.mp4")]
    assert len(got) == 3 * 3 + 2 * 2                  # three maps held, two fades between them
    want = [0, 0, 0, 200 / 3, 400 / 3, 200, 200, 200, 500 / 3, 400 / 3, 100, 100, 100]
    assert np.allclose(got, want, atol=4)             # H.264 is lossy by a few grey levels


def test_gif_stores_each_map_once_with_its_hold(tmp_path):
    from PIL import Image
    render.write_video(_frames(), gif_path=tmp_path / "v.gif", fps=10, hold=3, fade=6, gif_fade=3)
    with Image.open(tmp_path / "v.gif") as img:
        n = img.n_frames
        durations = []
        for k in range(n):
            img.seek(k)
            durations.append(img.info["duration"])
    assert n == 3 + 2 * 3                  # the fade in three GIF frames
    assert durations[0] == 300 and durations[1] == 200 # 3 / 10 s held, 6 / 10 s over three frames
    assert sum(durations) == 3 * 300 + 2 * 600        # as long as the MP4


def test_default_writes_one_video_frame_per_map(tmp_path):
    render.write_video(_frames(), mp4_path=tmp_path / "v.mp4", fps=2)
    assert len(_decoded(tmp_path / "v.mp4")) == 3


def test_bad_timing_is_refused(tmp_path):
    with pytest.raises(ValueError, match="hold"):
        render.write_video(_frames(), mp4_path=tmp_path / "v.mp4", hold=0)


def test_stacked_panels_are_full_width_one_above_the_other():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from test_bki_export import small_map
    rng = np.random.default_rng(0)
    view = small_map(rng.uniform(0, 3, size=(200, 3)), rng.integers(1, 4, 200), method="sbki",
                     resolution=0.25)
    cam = render.camera_for([view])
    fig = render.plot_maps({"a": view, "b": view}, cam, width=5.0, legend="below", stack=True, tall=0.6)
    axes = [ax for ax in fig.axes if ax.name == "3d"]
    assert fig.get_size_inches()[0] == 5.0
    a, b = (ax.get_position() for ax in axes)
    assert a.y0 > b.y1 - 1e-9 and abs(a.x0 - b.x0) < 1e-9   # "a" above "b", same column
    plt.close(fig)


def test_interactive_markup_states_the_size_it_loads():
    """The Task 5 page's load button names the size of the view it loads (page + plotly.js)."""
    import json
    import re
    from pathlib import Path
    root = Path(__file__).resolve().parents[1] / "notebooks"
    nb = json.loads((root / "T5_bki_3d.ipynb").read_text(encoding="utf-8"))
    cell = next("".join(c["source"]) for c in nb["cells"] if 'class="hw4-interactive"' in "".join(c["source"]))
    assert "<iframe" not in cell
    said = int(re.search(r"about (\d+) MB", cell).group(1))
    folder = root / "_static" / "interactive"
    page = folder / "t5_kitti04_map3d.html"
    if not (folder / "plotly.min.js").exists():
        pytest.skip("the notebook has not been run here (plotly.min.js is written by it)")
    size = page.stat().st_size + (folder / "plotly.min.js").stat().st_size
    assert said == round(size / 1e6)
    assert (folder / "t5_kitti04_map3d_still.png").exists()


def test_fitted_slices_are_as_tall_as_the_map_needs():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from test_bki_export import small_map
    rng = np.random.default_rng(0)
    view = small_map(rng.uniform(0, 3, size=(200, 3)) * [1, 2, 1], rng.integers(1, 4, 200),
                     method="sbki", resolution=0.25)
    cam = render.Camera(30.0, -60.0, (0.0, 0.0, 0.0), (3.0, 6.0, 3.0))   # twice as long in y
    panels = {"a": (view, "occupied"), "b": (view, "reference")}
    fig = render.plot_slices(panels, z=1.0, cam=cam, width=2.0, fit=True)
    w, h = fig.get_size_inches()
    assert w == 4.0 and h == pytest.approx((2.0 - 0.15) * 2 + 1.25)
    a, b = fig.axes[:2]
    assert a.get_ylabel() == "y [m]" and b.get_ylabel() == ""     # labelled once, shared
    assert a.get_shared_y_axes().joined(a, b)
    plt.close(fig)
    fig = render.plot_slices(panels, z=1.0, cam=cam, width=2.0)  # the default keeps its layout
    assert tuple(fig.get_size_inches()) == (4.0, 2.3) and fig.axes[1].get_ylabel() == "y [m]"
    plt.close(fig)


def _recording(tmp_path, grey_s=2.0, map_s=1.0, fps=10):
    """A screen recording as RViz's starts: black, then grey (the splash, the empty window), then a
    map: a saturated square in the middle from ``grey_s`` [s] on. (64, 96) px, ``fps`` frames/s."""
    frames = []
    for k in range(int(round((grey_s + map_s) * fps))):
        f = np.full((64, 96, 3), 0 if k < fps else 128, np.uint8)
        if k >= grey_s * fps:
            f[16:48, 32:64] = (230, 20, 200)   # magenta, a third of the 3D view's region below
        frames.append(f)
    render.write_video(frames, mp4_path=tmp_path / "rec.mp4", fps=fps)
    return tmp_path / "rec.mp4"


def test_recording_starts_at_the_first_frame_with_a_map_and_gets_a_poster(tmp_path):
    rec = _recording(tmp_path)
    assert render.first_coloured_frame(rec) == pytest.approx(2.0, abs=0.11)
    # the region of interest: only the map's square, so a tiny fraction threshold is enough
    assert render.first_coloured_frame(rec, crop="32:32:32:16") == pytest.approx(2.0, abs=0.11)
    out = render.trim_video(rec, tmp_path / "cut.mp4", render.first_coloured_frame(rec))
    frames = _decoded(out, (64, 96, 3))
    assert 8 <= len(frames) <= 11                        # the last second only
    assert render.first_coloured_frame(out) == 0.0      # starts with the map drawn
    poster = render.video_poster(out, tmp_path / "cut_poster.jpg")
    from PIL import Image
    img = np.asarray(Image.open(poster).convert("RGB")).astype(int)
    assert img.shape == (64, 96, 3) and img[32, 48, 0] > 180 and img[32, 48, 1] < 80
    with pytest.raises(ValueError, match="must differ"):
        render.trim_video(out, out, 0.0)


def test_a_recording_without_a_map_is_refused(tmp_path):
    rec = _recording(tmp_path, grey_s=2.0, map_s=0.0)
    with pytest.raises(ValueError, match="no frame"):
        render.first_coloured_frame(rec)


def test_write_video_puts_the_last_frame_beside_the_mp4_as_its_poster(tmp_path):
    from PIL import Image
    render.write_video(_frames(), mp4_path=tmp_path / "v.mp4", fps=2)
    poster = tmp_path / "v_poster.jpg"
    assert render.poster_path(tmp_path / "v.mp4") == poster
    img = np.asarray(Image.open(poster).convert("L")).astype(int)
    assert img.shape == (16, 24) and abs(img.mean() - 100) < 3   # the last map, not the first

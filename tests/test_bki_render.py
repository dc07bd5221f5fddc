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
    render.write_video(_frames(), gif_path=tmp_path / "v.gif", fps=10, hold=3, fade=6)
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

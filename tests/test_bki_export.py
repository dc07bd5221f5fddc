"""The map's exports for other tools: the MCAP recording (ROS 2 MarkerArray) and the offline
interactive HTML view."""
from __future__ import annotations

import re

import numpy as np
import pytest

from hw4.bki import interactive, ros2_mcap
from hw4.bki.palette import class_colors, class_names
from hw4.bki.voxelmap import VoxelMap


def small_map(points, labels, num_class=4, method="scsm", resolution=0.5):
    vm = VoxelMap(resolution, num_class, method)
    vm.update(np.asarray(points, float), np.asarray(labels))
    return vm.view()


# ---- MCAP ---------------------------------------------------------------------------------------

def test_mcap_round_trip_every_message_decodes_to_the_map(tmp_path):
    a = small_map([[0.1, 0.1, 0.1], [0.6, 0.1, 0.1], [2.1, 0.1, 0.1], [0.1, 3.1, 0.1]], [1, 1, 2, 3])
    # in the second map class 3 is gone (a free sample outvotes it) and class 2 has moved
    b = small_map([[0.1, 0.1, 0.1], [2.6, 0.1, 0.1], [0.1, 3.1, 0.1], [0.1, 3.2, 0.1],
                   [0.1, 3.3, 0.1]], [1, 2, 0, 0, 3])
    origins = [[0.0, 0.0, 1.0], [1.0, 0.5, 1.2]]
    path = tmp_path / "map.mcap"
    with ros2_mcap.MapRecorder(path, rate=10.0, t0_ns=5_000_000_000) as rec:
        rec.add(a, origins[0])
        rec.add(b, origins[1])
    assert not (tmp_path / "map.mcap.partial").exists()
    msgs = ros2_mcap.read_markers(path)
    # the path (a LINE_STRIP) is published once it has two points
    assert [(t, n) for t, n, _ in msgs] == [("/semantic_map", 5_000_000_000),
                                            ("/semantic_map", 5_100_000_000), ("/trajectory", 5_100_000_000)]
    pal, names = class_colors(4) / 255.0, class_names(4)
    for (topic, _, msg), view in ((msgs[0], a), (msgs[1], b)):
        occ = view.occupied
        live = [m for m in msg.markers if m.action == ros2_mcap.ADD]
        assert sorted(m.id for m in live) == sorted(set(view.cls[occ].tolist()))
        for m in live:
            assert m.type == ros2_mcap.CUBE_LIST and m.header.frame_id == "map"
            assert m.ns == names[m.id]
            assert (m.scale.x, m.scale.y, m.scale.z) == (view.resolution,) * 3
            np.testing.assert_allclose([m.color.r, m.color.g, m.color.b, m.color.a],
                                       [*pal[m.id], 1.0], rtol=1e-6)
            got = np.array([[p.x, p.y, p.z] for p in m.points])
            np.testing.assert_array_equal(got, view.centres[occ & (view.cls == m.id)])
    gone = [m for m in msgs[1][2].markers if m.action == ros2_mcap.DELETE]
    assert gone
    assert [m.id for m in gone] == sorted(set(a.cls[a.occupied].tolist()) - set(b.cls[b.occupied].tolist()))
    path_msg = msgs[2][2].markers[0]
    assert path_msg.type == ros2_mcap.LINE_STRIP
    np.testing.assert_array_equal([[p.x, p.y, p.z] for p in path_msg.points], origins)


def test_our_cdr_bytes_equal_the_mcap_ros2_encoder(tmp_path):
    """The numpy CDR layout is byte-identical to what mcap-ros2-support's encoder writes."""
    from mcap.reader import make_reader
    from mcap_ros2.writer import Writer

    view = small_map([[0.1, 0.1, 0.1], [0.6, 0.1, 0.1], [2.1, 0.7, 0.1]], [1, 1, 2])
    ours, _ = ros2_mcap.map_message(view, 1_234_567_890_123, previous={3})
    occ = view.occupied
    pal, names = class_colors(4) / 255.0, class_names(4)

    def marker(k, action, pts):
        return {"header": {"stamp": {"sec": 1234, "nanosec": 567_890_123}, "frame_id": "map"},
                "ns": names[k], "id": k, "type": 6, "action": action,
                "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                         "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
                "scale": {"x": 0.5, "y": 0.5, "z": 0.5},
                "color": {"r": pal[k][0], "g": pal[k][1], "b": pal[k][2], "a": 1.0},
                "lifetime": {"sec": 0, "nanosec": 0}, "frame_locked": False,
                "points": [{"x": x, "y": y, "z": z} for x, y, z in pts], "colors": [],
                "texture_resource": "", "texture": {"header": {"stamp": {"sec": 0, "nanosec": 0},
                                                               "frame_id": ""}, "format": "", "data": b""},
                "uv_coordinates": [], "text": "", "mesh_resource": "",
                "mesh_file": {"filename": "", "data": b""}, "mesh_use_embedded_materials": False}

    msg = {"markers": [marker(k, 0, view.centres[occ & (view.cls == k)]) for k in (1, 2)]
           + [marker(3, 2, [])]}
    ref = tmp_path / "ref.mcap"
    with open(ref, "wb") as f:
        w = Writer(f)
        schema = w.register_msgdef("visualization_msgs/msg/MarkerArray", ros2_mcap.MARKER_ARRAY_DEF)
        w.write_message("/semantic_map", schema, msg, log_time=0, publish_time=0)
        w.finish()
    with open(ref, "rb") as f:
        (_, _, raw), = list(make_reader(f).iter_messages())
    assert raw.data == ours


def test_mcap_failure_leaves_no_file(tmp_path):
    path = tmp_path / "map.mcap"
    view = small_map([[0.1, 0.1, 0.1]], [1])
    with pytest.raises(RuntimeError):
        with ros2_mcap.MapRecorder(path) as rec:
            rec.add(view, [0, 0, 0])
            raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []


# ---- interactive view ---------------------------------------------------------------------------

def test_cube_mesh_hides_shared_faces():
    v, t = interactive.cube_mesh(np.array([[0, 0, 0]]), 0.3)
    assert v.shape == (8, 3) and t.shape == (12, 3)
    np.testing.assert_allclose(np.unique(v), [0.0, 0.3], rtol=1e-6)
    v, t = interactive.cube_mesh(np.array([[0, 0, 0], [1, 0, 0]]), 1.0)
    assert v.shape == (12, 3) and t.shape == (20, 3)   # 10 exposed faces, the shared one hidden
    # every triangle is a real one (three distinct corners) and lies on a cube face
    assert all(len(set(tri)) == 3 for tri in t.tolist())
    tri = v[t]
    assert np.all(np.ptp(tri, axis=1).min(axis=1) == 0)


def test_aggregate_takes_the_most_frequent_class():
    idx = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 1], [2, 0, 0], [3, 1, 1]])
    cls = np.array([5, 7, 7, 5, 3, 9])
    big, c = interactive.aggregate(idx, cls, 2)
    got = {tuple(b): k for b, k in zip(big.tolist(), c.tolist())}
    assert got == {(0, 0, 0): 5, (1, 0, 0): 3}   # 5 and 7 tie twice each: the smaller class wins


def test_interactive_page_is_offline_and_complete(tmp_path):
    rng = np.random.default_rng(0)
    pts = rng.uniform(0, 5, size=(400, 3))
    lab = rng.integers(1, 4, size=400)
    view = small_map(pts, lab, method="sbki", resolution=0.25)
    info = interactive.write_interactive(view, tmp_path / "map3d.html", trajectory=[[0, 0, 0], [1, 0, 0]],
                                         max_voxels=10 ** 6)
    html = (tmp_path / "map3d.html").read_text()
    assert (tmp_path / "plotly.min.js").stat().st_size > 1_000_000
    assert not re.search(r"<(script|link)[^>]+(src|href)=\"https?://", html)  # no CDN
    assert 'src="plotly.min.js"' in html
    assert info["factor"] == 1 and info["voxels"] == int(view.occupied.sum())
    fig, _ = interactive.interactive_figure(view, trajectory=[[0, 0, 0], [1, 0, 0]], max_voxels=10 ** 6)
    names = [t.name for t in fig.data]
    want = [class_names(4)[k] for k in np.unique(view.cls[view.occupied])]
    assert names == want + ["car trajectory"]
    # phones: the legend is a row below the scene (never over it), the page is as wide as the device
    assert fig.layout.legend.orientation == "h" and fig.layout.legend.y <= 0
    assert fig.layout.legend.yanchor == "top"
    assert 'name="viewport" content="width=device-width' in html
    assert "overflow:hidden" in html          # no scroll bars that narrow the window in turn
    assert "1.25 * size.h / size.w" in html   # a tall screen backs off far enough for the z title
    # aggregation bounds the voxel count
    small = interactive.write_interactive(view, tmp_path / "small.html", max_voxels=50)
    assert small["factor"] > 1 and small["voxels"] <= 50
    # the wheel scrolls the book's page, it is not trapped by the view
    assert '"scrollZoom": false' in html


def test_still_looks_from_the_interactive_views_first_camera(tmp_path):
    box = (np.zeros(3), np.array([4.0, 2.0, 1.0]))
    cam = interactive.still_camera(box)
    e = interactive.EYE
    elev, azim = np.radians(cam.elev), np.radians(cam.azim)
    d = np.array([np.cos(elev) * np.cos(azim), np.cos(elev) * np.sin(azim), np.sin(elev)])
    eye = np.array([e["x"], e["y"], e["z"]])
    assert np.allclose(d, eye / np.linalg.norm(eye))   # the same direction towards the eye
    assert np.allclose(cam.lo, box[0]) and np.allclose(cam.hi, box[1])
    rng = np.random.default_rng(0)
    view = small_map(rng.uniform(0, 4, size=(300, 3)) * [1, 0.5, 0.25], rng.integers(1, 4, 300),
                     method="sbki", resolution=0.25)
    out = interactive.write_still(view, tmp_path / "still.png", box, trajectory=[[0, 1, 0.5], [4, 1, 0.5]],
                                  width=3.0, dpi=60)
    from PIL import Image
    img = np.asarray(Image.open(out).convert("RGB"))
    assert img.shape[1] == 180 and (img < 200).any()   # 3 in at 60 dpi, and something drawn
    assert [p.name for p in tmp_path.iterdir()] == ["still.png"]   # no temporary left behind


def test_mcap_error_on_finish_leaves_no_file(tmp_path, monkeypatch):
    from mcap.writer import Writer
    view = small_map([[0.1, 0.1, 0.1]], [1])

    def broken(self):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(Writer, "finish", broken)
    with pytest.raises(OSError):
        with ros2_mcap.MapRecorder(tmp_path / "map.mcap") as rec:
            rec.add(view, [0, 0, 0])
    assert list(tmp_path.iterdir()) == []


def test_bki_cli_writes_mcap_and_interactive_page_whole(tmp_path, capsys):
    """The toy run with --mcap: every declared output, no temporary file left, the MCAP's last
    map is the written map, and a rerun needs --force."""
    from hw4.__main__ import main
    from hw4.bki import build_map, load_config, scan_source
    out = tmp_path / "o"
    argv = ["bki", "--dataset", "toy", "--mcap", "--out", str(out)]
    assert main(argv) == 0
    names = sorted(p.name for p in out.iterdir())
    assert not [n for n in names if "partial" in n or n.startswith(".")]
    for n in ("voxels.csv", "voxels.ply", "map.mcap", "map3d.html", "plotly.min.js",
              "map3d_class.png", "topdown_variance.png"):
        assert n in names
    cfg = load_config("toy")
    view = build_map(scan_source("toy"), cfg, "sbki")[0].view()
    msgs = ros2_mcap.read_markers(out / "map.mcap")
    maps = [m for t, _, m in msgs if t == "/semantic_map"]
    assert len(maps) == 12
    got = sum(len(m.points) for m in maps[-1].markers if m.action == ros2_mcap.ADD)
    assert got == int(view.occupied.sum())
    html = (out / "map3d.html").read_text()
    assert 'src="plotly.min.js"' in html
    capsys.readouterr()
    assert main(argv) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(argv + ["--force"]) == 0


def test_standalone_bki_usage_error_is_one_line(capsys):
    from hw4.bki.cli import main as bki_main
    with pytest.raises(SystemExit) as e:
        bki_main(["--scans", "many"])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: python -m hw4.bki:")


def test_palette_png_keeps_exact_colours_and_its_print_size():
    """render.png_bytes: at most 256 colours, the flat colours exact, and the resolution it was
    drawn at stored in the file, so that LaTeX prints it at its drawn size (not at 72 dpi)."""
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    from hw4.bki import render
    fig, ax = plt.subplots(figsize=(2.0, 1.0))
    ax.add_patch(plt.Rectangle((0, 0), 1, 1, color=(0.2, 0.4, 0.6)))
    ax.plot([0, 1], [0, 1], lw=3, color="black")
    img = Image.open(io.BytesIO(render.png_bytes(fig, dpi=150)))
    plt.close(fig)
    assert img.mode == "P" and img.size == (300, 150)
    assert np.allclose(img.info["dpi"], (150, 150), atol=0.02)   # pHYs: whole pixels per metre
    rgb = np.asarray(img.convert("RGB")).reshape(-1, 3)
    assert len(np.unique(rgb, axis=0)) <= 256
    assert (rgb == (51, 102, 153)).all(axis=1).any()    # the patch colour, exactly


# ---- palette and print strips -------------------------------------------------------------------

def test_kitti_palette_separates_person_and_traffic_sign_only_when_both_are_shown():
    from hw4.bki.palette import KITTI_DISTINCT
    base = class_colors(20)
    assert base[6][0] == base[19][0] == 255 and max(base[6][1:].max(), base[19][1:].max()) <= 30  # both red
    both = class_colors(20, present=[1, 6, 9, 19])
    assert tuple(both[6]) == KITTI_DISTINCT[(6, 19)][1] and (both[19] == base[19]).all()
    assert (np.delete(both, 6, axis=0) == np.delete(base, 6, axis=0)).all()
    assert (class_colors(20, present=[6, 9]) == base).all()   # person alone keeps its red
    assert (class_colors(4, present=[1, 2]) == class_colors(4)).all()


def test_kitti_palette_separates_car_and_other_vehicle_only_when_both_are_shown():
    from hw4.bki.palette import KITTI_DISTINCT
    base = class_colors(20)
    both = class_colors(20, present=[1, 5, 9])
    assert tuple(both[5]) == KITTI_DISTINCT[(1, 5)][1] and (both[1] == base[1]).all()
    assert (np.delete(both, 5, axis=0) == np.delete(base, 5, axis=0)).all()
    assert (class_colors(20, present=[5, 9]) == base).all()   # other-vehicle alone keeps its blue
    everything = class_colors(20, present=range(20))          # both rules at once
    assert tuple(everything[6]) == KITTI_DISTINCT[(6, 19)][1]
    assert tuple(everything[5]) == KITTI_DISTINCT[(1, 5)][1]


def test_strip_puts_methods_side_by_side_one_scan_per_row():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from hw4.bki import render
    rng = np.random.default_rng(1)
    pts = rng.uniform(0, 4, size=(300, 3))
    lab = rng.integers(1, 4, size=300)
    a, b = small_map(pts, lab), small_map(pts, lab, method="sbki")
    cam = render.camera_for([a, b])
    fig = render.plot_strip([(a, b), (a, b), (a, b)], [1, 2, 3], cam, ("S-CSM", "S-BKI"),
                            width=7.0, max_height=6.0)
    w, h = fig.get_size_inches()
    assert w == 7.0 and h <= 6.0 + 1e-9
    stills = [ax for ax in fig.axes if ax.images]
    assert len(stills) == 6
    titles = [ax.get_title() for ax in stills if ax.get_title()]
    assert titles == ["S-CSM", "S-BKI"]                 # columns: the methods, as in the video
    x = sorted({round(ax.get_position().x0, 3) for ax in stills})
    y = sorted({round(ax.get_position().y0, 3) for ax in stills})
    assert len(x) == 2 and len(y) == 3                  # rows: the scans
    plt.close(fig)


def test_vertical_slice_draws_each_voxel_of_the_layer_at_its_y_and_z():
    from hw4.bki import render
    # voxels 0.5 m: class 1 at (x, y, z) voxel (0, 1, 0), class 2 at (0, 3, 2); one in layer x = 1
    view = small_map([[0.1, 0.6, 0.1], [0.2, 1.7, 1.2], [0.7, 0.6, 0.1]], [1, 2, 3])
    rgb, ext = render.vertical_slice(view, 0.2, lo=(0.0, 0.0), hi=(2.0, 1.4))
    assert ext == (0.0, 2.5, 0.0, 1.5) and rgb.shape == (3, 5, 3)    # rows: z, columns: y
    pal = class_colors(4) / 255.0
    np.testing.assert_allclose(rgb[0, 1], pal[1])
    np.testing.assert_allclose(rgb[2, 3], pal[2])
    np.testing.assert_allclose(rgb[0, 0], 0.85)                       # no evidence
    assert not np.isclose(rgb, pal[3]).all(axis=-1).any()             # layer x = 1 is not drawn


def test_log_variance_scale_starts_at_the_given_floor():
    from hw4.bki import render
    norm = render.variance_norm(0.09, log=True, vmin=1e-5)
    assert norm.vmin == 1e-5 and norm.vmax == 0.09
    assert render.variance_norm(0.09, log=True).vmin == pytest.approx(9e-5)   # the default floor
    rgb = render.scalar_rgb(np.array([1e-6, 1e-5, 0.5]), 0.09, log=True, vmin=1e-5)
    np.testing.assert_allclose(rgb[0], rgb[1])                                # clipped below

"""hw4.bki.rosref without ROS: the bag reader, the MarkerArray decoder, colours back to classes,
the comparison, the predictions the reference node reads and the RViz configuration copies.

The messages are written here from the ROS 1 wire format as documented (genmsg's serialization:
little-endian, uint32 length before strings and arrays); the recorded bags of the real node are
checked by tests/test_bki_rosref_ros.py where ROS runs.
"""
import struct

import numpy as np
import pytest

from hw4.bki import rosref
from hw4.bki.kitti import COLORS, learning_labels, read_label
from hw4.core.errors import InputError


def _s(text: str) -> bytes:
    b = text.encode()
    return struct.pack("<I", len(b)) + b


def _marker(points, colors, scale=0.3, mtype=6, ns="map", mid=0) -> bytes:
    out = struct.pack("<III", 7, 100, 5) + _s("map") + _s(ns) + struct.pack("<iii", mid, mtype, 0)
    out += struct.pack("<7d", 0, 0, 0, 0, 0, 0, 1) + struct.pack("<3d", scale, scale, scale)
    out += struct.pack("<4f", 0, 0, 1, 1) + struct.pack("<ii", 0, 0) + b"\x00"
    out += struct.pack("<I", len(points)) + np.asarray(points, "<f8").tobytes()
    out += struct.pack("<I", len(colors)) + np.asarray(colors, "<f4").tobytes()
    return out + _s("") + _s("") + b"\x00"


def _array(*markers) -> bytes:
    return struct.pack("<I", len(markers)) + b"".join(markers)


def _record(fields: dict, data: bytes) -> bytes:
    h = b"".join(struct.pack("<I", len(k) + 1 + len(v)) + k.encode() + b"=" + v
                 for k, v in fields.items())
    return struct.pack("<I", len(h)) + h + struct.pack("<I", len(data)) + data


def _bag(messages) -> bytes:
    """A bag 2.0 with one chunk holding a connection record and the messages (topic, sec, data)."""
    topics = sorted({t for t, _, _ in messages})
    chunk = b""
    for i, t in enumerate(topics):
        chunk += _record({"op": b"\x07", "conn": struct.pack("<I", i), "topic": t.encode()},
                         _record({"topic": t.encode(), "type": b"visualization_msgs/MarkerArray"}, b""))
    for t, sec, data in messages:
        chunk += _record({"op": b"\x02", "conn": struct.pack("<I", topics.index(t)),
                          "time": struct.pack("<II", sec, 500_000_000)}, data)
    out = b"#ROSBAG V2.0\n" + _record({"op": b"\x03", "index_pos": struct.pack("<Q", 0),
                                        "conn_count": struct.pack("<I", 1),
                                        "chunk_count": struct.pack("<I", 1)}, b" " * 16)
    return out + _record({"op": b"\x05", "compression": b"none", "size": struct.pack("<I", len(chunk))},
                         chunk)


def test_reference_colours_are_the_dataset_bgr_used_as_rgb():
    # the reference's SemanticKITTI colours are the dataset's BGR triples read as RGB, except
    # other-vehicle (5), which takes a bus-like (255, 80, 100)
    same = np.arange(1, 20) != 5
    assert np.array_equal(rosref.REF_KITTI_RGB[1:][same], COLORS[1:, ::-1][same].astype(float))
    assert np.array_equal(rosref.REF_KITTI_RGB[5], [255, 80, 100])
    assert len(np.unique(rosref.REF_KITTI_RGB, axis=0)) == 20


def test_marker_array_round_trip_to_voxels():
    pts = np.array([[0.15, 0.45, -0.15], [1.05, 0.15, 0.15], [3.0, 2.1, 0.3]])
    cls = np.array([9, 1, 13])
    rgba = np.column_stack([rosref.REF_KITTI_RGB[cls] / 255.0, np.ones(3)])
    data = _array(_marker([], [], 0.3, mid=0), _marker(pts, rgba, 0.6, mid=1))
    ms = rosref.parse_marker_array(data)
    assert [m["id"] for m in ms] == [0, 1] and ms[1]["frame_id"] == "map"
    centres, got, edge = rosref.marker_voxels(ms, rosref.REF_KITTI_RGB)
    assert np.array_equal(centres, pts) and np.array_equal(got, cls) and edge == 0.6


def test_unknown_colour_and_truncated_message_are_refused():
    data = _array(_marker([[0, 0, 0]], [[0.5, 0.5, 0.5, 1]]))
    with pytest.raises(InputError):
        rosref.marker_voxels(rosref.parse_marker_array(data), rosref.REF_KITTI_RGB)
    with pytest.raises(InputError):
        rosref.parse_marker_array(data[:-20])


def test_read_bag_and_bag_maps(tmp_path):
    a = _array(_marker([[0.05, 0.05, 0.05]], [[1, 0, 0, 1]], 0.1))
    b = _array(_marker([[0.05, 0.05, 0.05], [0.15, 0.05, 0.05]],
                       [[1, 0, 0, 1], [218 / 255, 112 / 255, 214 / 255, 1]], 0.1))
    p = tmp_path / "x.bag"
    p.write_bytes(_bag([("/semantic_bki", 10, a), ("/other", 11, b"junk"), ("/semantic_bki", 12, b)]))
    msgs = rosref.read_bag(p)
    assert [m.topic for m in msgs] == ["/semantic_bki", "/other", "/semantic_bki"]
    assert msgs[2].t == pytest.approx(12.5)
    maps = rosref.bag_maps(p, "/semantic_bki", rosref.REF_TOY_RGB)
    assert len(maps) == 2 and list(maps[1][2]) == [1, 3]
    bad = tmp_path / "bad.bag"
    bad.write_bytes(p.read_bytes()[:-7])
    with pytest.raises(InputError):
        rosref.read_bag(bad)
    (tmp_path / "no.bag").write_bytes(b"hello")
    with pytest.raises(InputError):
        rosref.read_bag(tmp_path / "no.bag")


def test_compare_voxels_counts_and_half_voxel_grids():
    r = 0.3
    ref = (np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]) + 0.5) * r
    ours = (np.array([[1, 0, 0], [2, 0, 0], [3, 0, 0], [4, 0, 0], [5, 0, 0]]) + 0.5) * r
    out = rosref.compare_voxels(ref.astype(np.float32), [1, 2, 3, 4], ours, [2, 3, 9, 5, 5], r)
    assert (out["common"], out["only_ref"], out["only_ours"], out["class_differ"]) == (3, 1, 2, 1)
    assert out["jaccard"] == pytest.approx(3 / 6) and out["class_agree"] == pytest.approx(2 / 3)
    # a grid of centres on multiples of r (the reference's S-CSM grid) keys apart from (i + 0.5) r
    assert not np.isin(rosref.half_keys(ref, r), rosref.half_keys(ref - r / 2, r)).any()


def test_predictions_are_the_ground_truth_or_the_segmenter(tmp_path):
    from hw4.bki.kitti import read_bin
    from hw4.bki.pipeline import kitti_04_folder
    folder = kitti_04_folder()
    assert rosref.write_predictions(folder, tmp_path / "c", "clean", scans=2) == 2
    assert rosref.write_predictions(folder, tmp_path / "n", "noisy", scans=2) == 2
    raw = read_label(folder / "labels" / "000001.label")
    clean = read_label(tmp_path / "c" / "000001.label")
    noisy = read_label(tmp_path / "n" / "000001.label")
    assert np.array_equal(clean, learning_labels(raw))
    seg = rosref.segmenter()
    assert np.array_equal(noisy, seg(1, read_bin(folder / "velodyne" / "000001.bin")[:, :3].astype(float), raw))
    assert 0 < np.mean(noisy != clean) < 0.5
    assert not list(tmp_path.glob("*/*.part"))


def test_rviz_config_copy():
    src = "\n".join([
        "Visualization Manager:", "  Displays:",
        "    - Class: rviz/MarkerArray", "      Enabled: true", "      Marker Topic: /a",
        "      Value: true",
        "    - Class: rviz/MarkerArray", "      Enabled: true", "      Marker Topic: /b",
        "      Value: true",
        "  Views:", "    Current:", "      Class: rviz/Orbit", "      Distance: 10",
        "      Focal Point:", "        X: 1", "        Y: 2", "        Z: 3", "    Saved: ~",
        "Window Geometry:", "  Height: 1056", "  Hide Left Dock: false", "  Width: 1855",
        "  X: 167", "  Y: 307"])
    out = rosref.rviz_config(src, topics=["/b"], view={"Class": "rviz/TopDownOrtho", "Scale": 11},
                             hide_docks=True, size=(1600, 1000)).splitlines()
    assert out[3] == "      Enabled: false" and out[5] == "      Value: false"
    assert out[7] == "      Enabled: true"
    assert "      Class: rviz/TopDownOrtho" in out and "      Distance: 10" not in out
    assert "    Saved: ~" in out
    for line in ("  X: 0", "  Y: 0", "  Width: 1600", "  Height: 1000", "  Hide Left Dock: true"):
        assert line in out


def test_stored_reference_maps_round_trip(tmp_path):
    r = 0.3
    pts = (np.array([[0, 0, 0], [3, -2, 1], [-5, 4, 2]]) + 0.5) * r
    cls = np.array([9, 13, 1])
    rgba = np.column_stack([rosref.REF_KITTI_RGB[cls] / 255.0, np.ones(3)])
    kitti = tmp_path / "k.bag"
    kitti.write_bytes(_bag([("/occupied_cells_vis_array", 1, _array(_marker(pts[:1], rgba[:1], 0.6))),
                            ("/occupied_cells_vis_array", 3, _array(_marker(pts, rgba, 0.6)))]))
    toy_pts = np.array([[0.0, 0.1, 0.2], [0.05, 0.05, 0.05]])
    toy_rgba = np.column_stack([rosref.REF_TOY_RGB[[1, 3]] / 255.0, np.ones(2)])
    toy = tmp_path / "t.bag"
    toy.write_bytes(_bag([("/semantic_csm", 1, _array(_marker(toy_pts[:1], toy_rgba[:1], 0.1))),
                          ("/semantic_bki", 2, _array(_marker(toy_pts[1:], toy_rgba[1:], 0.1)))]))
    path = rosref.save_reference_maps(tmp_path / "store", {"kitti04_clean": kitti, "toy": toy})
    maps = rosref.load_reference_maps(path)
    k = maps["kitti04_clean", "/occupied_cells_vis_array"]
    assert np.allclose(k.centres, pts) and np.array_equal(k.cls, cls)
    assert k.resolution == 0.3 and k.cube_edge == pytest.approx(0.6) and len(k.times) == 2
    assert np.array_equal(maps["toy", "/semantic_csm"].cls, [1])
    assert np.allclose(maps["toy", "/semantic_bki"].centres, toy_pts[1:])
    with pytest.raises(InputError):
        rosref.save_reference_maps(tmp_path / "x", {"toy": kitti})   # no toy topics in it
    with pytest.raises(InputError):
        rosref.load_reference_maps(tmp_path / "missing.npz")

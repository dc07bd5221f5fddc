"""PCD reader: ASCII and binary, the toy files' undeclared fifth value, malformed files."""
from __future__ import annotations

import numpy as np
import pytest

from hw4.bki.pcd import read_labelled_scan, read_pcd
from hw4.bki.pipeline import toy_paths
from hw4.core.errors import InputError

HEADER = """# .PCD v0.7 - Point Cloud Data file format
VERSION 0.7
FIELDS x y z label
SIZE 4 4 4 4
TYPE F F F U
COUNT 1 1 1 1
WIDTH {n}
HEIGHT 1
VIEWPOINT 1.5 -2 0.25 1 0 0 0
POINTS {n}
DATA {kind}
"""


def _points(n=7, seed=0):
    rng = np.random.default_rng(seed)
    xyz = rng.uniform(-5, 5, (n, 3)).astype(np.float32)
    lab = rng.integers(1, 4, n).astype(np.uint32)
    return xyz, lab


def _ascii(path, xyz, lab, extra=""):
    lines = [f"{x!r} {y!r} {z!r} {l}{extra}" for (x, y, z), l in zip(xyz.tolist(), lab.tolist())]
    path.write_text(HEADER.format(n=len(xyz), kind="ascii") + "\n".join(lines) + "\n")
    return path


def _binary(path, xyz, lab, cut=0):
    rec = np.zeros(len(xyz), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("label", "<u4")])
    rec["x"], rec["y"], rec["z"], rec["label"] = xyz[:, 0], xyz[:, 1], xyz[:, 2], lab
    data = rec.tobytes()
    path.write_bytes(HEADER.format(n=len(xyz), kind="binary").encode() + data[:len(data) - cut])
    return path


@pytest.mark.parametrize("extra", ["", " -1", " -1 7.5"])
def test_ascii_reads_declared_fields_and_ignores_undeclared_values(tmp_path, extra):
    xyz, lab = _points()
    scan = read_labelled_scan(_ascii(tmp_path / "a.pcd", xyz, lab, extra))
    np.testing.assert_array_equal(scan.points, xyz.astype(float))
    np.testing.assert_array_equal(scan.labels, lab)
    np.testing.assert_array_equal(scan.origin, [1.5, -2, 0.25])


def test_binary_matches_ascii(tmp_path):
    xyz, lab = _points(50, seed=3)
    a = read_labelled_scan(_ascii(tmp_path / "a.pcd", xyz, lab))
    b = read_labelled_scan(_binary(tmp_path / "b.pcd", xyz, lab))
    assert read_pcd(tmp_path / "b.pcd").data == "binary"
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.labels, b.labels)
    assert b.labels.dtype == np.int64


def test_real_toy_files_have_the_fifth_value_and_read_completely():
    paths = toy_paths()
    assert [p.name for p in paths][:3] == ["sim_unstructured_annotated_1.pcd",
                                           "sim_unstructured_annotated_2.pcd",
                                           "sim_unstructured_annotated_3.pcd"]
    first_line = paths[0].read_text().split("DATA ascii\n")[1].splitlines()[0]
    assert len(first_line.split()) == 5  # declared x y z label, plus the undeclared -1
    scans = [read_labelled_scan(p) for p in paths]
    assert sum(len(s.points) for s in scans) == 40_712
    for p, s in zip(paths, scans):
        declared = int(p.read_text().split("POINTS ")[1].split()[0])
        assert len(s.points) == declared
        assert set(np.unique(s.labels)) <= {1, 2, 3}


@pytest.mark.parametrize("mutate, message", [
    (lambda h: h.replace("FIELDS x y z label\n", ""), "lacks FIELDS"),
    (lambda h: h.replace("SIZE 4 4 4 4", "SIZE 4 4 4"), "different numbers"),
    (lambda h: h.replace("TYPE F F F U", "TYPE F F F Q"), "unsupported"),
    (lambda h: h.replace("WIDTH 7", "WIDTH 6"), "WIDTH x HEIGHT"),
    (lambda h: h.replace("POINTS 7", "POINTS seven"), "POINTS must be"),
    (lambda h: h.replace("VIEWPOINT 1.5 -2 0.25 1 0 0 0", "VIEWPOINT 1 2"), "VIEWPOINT"),
    (lambda h: h.replace("DATA ascii", "DATA zipped"), "unknown PCD DATA"),
    (lambda h: h.replace("DATA ascii", "DATA binary_compressed"), "binary_compressed"),
    (lambda h: h.replace("HEIGHT 1\n", "HEIGHT 1\nCOLOUR red\n"), "unexpected PCD header line"),
    (lambda h: h.split("DATA")[0], "ends before its DATA"),
])
def test_malformed_header_gives_one_clear_sentence(tmp_path, mutate, message):
    xyz, lab = _points()
    path = _ascii(tmp_path / "a.pcd", xyz, lab)
    path.write_text(mutate(path.read_text()))
    with pytest.raises(InputError, match=message) as e:
        read_pcd(path)
    assert str(e.value).count(". ") == 0 and str(e.value).endswith(".")


def test_truncated_or_short_ascii_data_is_an_error_not_a_shorter_cloud(tmp_path):
    xyz, lab = _points()
    path = _ascii(tmp_path / "a.pcd", xyz, lab)
    text = path.read_text()
    path.write_text(text.rsplit("\n", 3)[0] + "\n")  # two data lines lost
    with pytest.raises(InputError, match="only 5 lines"):
        read_pcd(path)
    lines = text.splitlines()
    lines[-2] = " ".join(lines[-2].split()[:3])  # a line with 3 of the 4 declared values
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match="has 3 values"):
        read_pcd(path)
    path.write_text(text.replace(lines[-1].split()[0], "abc", 1))
    with pytest.raises(InputError, match="not a number"):
        read_pcd(path)
    head, body = text.split("DATA ascii\n")
    body = body.replace(" 1\n", " 1.5\n").replace(" 2\n", " 2.5\n").replace(" 3\n", " 3.5\n")
    path.write_text(head + "DATA ascii\n" + body)
    with pytest.raises(InputError, match="not such an integer"):
        read_pcd(path)


def test_truncated_binary_data(tmp_path):
    xyz, lab = _points()
    with pytest.raises(InputError, match="truncated"):
        read_pcd(_binary(tmp_path / "b.pcd", xyz, lab, cut=3))


def test_missing_label_field_and_missing_file(tmp_path):
    xyz, lab = _points()
    path = _ascii(tmp_path / "a.pcd", xyz, lab)
    path.write_text(path.read_text().replace("FIELDS x y z label", "FIELDS x y z intensity"))
    with pytest.raises(InputError, match="no field 'label'"):
        read_labelled_scan(path)
    with pytest.raises(InputError, match="cannot read"):
        read_pcd(tmp_path / "missing.pcd")

"""Bad inputs give one clear sentence (InputError), never a silently empty or wrong map."""
from __future__ import annotations

import numpy as np
import pytest
from test_bki_kitti import write_sequence

from hw4.bki import Scan, load_config, map_scans, scan_source, validate_scan
from hw4.bki.cli import main
from hw4.bki.kitti import SemanticKITTISequence
from hw4.core.errors import InputError

PCD = """VERSION 0.7
FIELDS x y z label
SIZE 4 4 4 4
TYPE F F F U
COUNT 1 1 1 1
WIDTH {n}
HEIGHT 1
VIEWPOINT 0 0 0 1 0 0 0
POINTS {n}
DATA ascii
{body}"""


def _pcd(folder, rows):
    folder.mkdir(exist_ok=True)
    body = "".join(" ".join(str(v) for v in r) + " -1\n" for r in rows)
    (folder / "scan_1.pcd").write_text(PCD.format(n=len(rows), body=body))
    return folder


def _map_toy(folder):
    cfg = load_config("toy")
    return list(map_scans(scan_source("toy", folder, cfg), cfg))


def _one_sentence(e):
    msg = str(e.value)
    assert msg.endswith(".") and "\n" not in msg
    return msg


def test_no_points(tmp_path):
    with pytest.raises(InputError, match="has no points") as e:
        _map_toy(_pcd(tmp_path / "d", []))
    _one_sentence(e)


def test_nan_coordinates(tmp_path):
    with pytest.raises(InputError, match="NaN or infinite") as e:
        _map_toy(_pcd(tmp_path / "d", [(1, 2, 0.5, 1), (np.nan, 2, 0.5, 2)]))
    assert "point 1" in _one_sentence(e)


@pytest.mark.parametrize("label", [0, 4, 7])
def test_labels_out_of_range(tmp_path, label):
    with pytest.raises(InputError, match=f"label {label}, outside the map's classes 1..3") as e:
        _map_toy(_pcd(tmp_path / "d", [(1, 2, 0.5, 1), (1, 2, 0.6, label)]))
    _one_sentence(e)


def test_scan_checks_direct():
    with pytest.raises(InputError, match="origin"):
        validate_scan(Scan(np.ones((2, 3)), np.array([1, 1]), np.array([0, np.inf, 0])), 4)
    with pytest.raises(InputError, match="2 points but 1 labels"):
        validate_scan(Scan(np.ones((2, 3)), np.array([1]), np.zeros(3)), 4)


@pytest.mark.parametrize("bad", ["scaled", "sheared", "reflected", "nan"])
def test_pose_that_is_not_a_rigid_transform(tmp_path, bad):
    def hook(t, P):
        if t == 2:
            P = P.copy()
            if bad == "scaled":
                P[:3, :3] *= 1.5
            elif bad == "sheared":
                P[0, 1] += 0.3
            elif bad == "reflected":
                P[:3, 0] *= -1
            else:
                P[1, 3] = np.nan
        return P
    write_sequence(tmp_path / "04", n_scans=3, pose_hook=hook)
    with pytest.raises(InputError, match="pose 2 .line 3") as e:
        SemanticKITTISequence(tmp_path / "04")
    _one_sentence(e)


def test_kitti_layout_errors(tmp_path):
    seq = tmp_path / "04"
    write_sequence(seq, n_scans=2)
    (seq / "velodyne" / "000001.bin").write_bytes((seq / "velodyne" / "000001.bin").read_bytes()[:-5])
    s = SemanticKITTISequence(seq)
    with pytest.raises(InputError, match="not a multiple of 16"):
        s.scan(1)
    (seq / "labels" / "000000.label").write_bytes((seq / "labels" / "000000.label").read_bytes()[:-8])
    with pytest.raises(InputError, match="labels for the"):
        s.scan(0)
    drive = tmp_path / "drive"  # not a KITTI sequence number: no published Tr to fall back on
    write_sequence(drive, n_scans=1)
    (drive / "calib.txt").write_text("P0: 1 0 0 0 0 1 0 0 0 0 1 0\n")
    with pytest.raises(InputError, match="no 'Tr:' line"):
        SemanticKITTISequence(drive)
    with pytest.raises(InputError, match="not a folder"):
        SemanticKITTISequence(tmp_path / "nowhere")


def test_cli_prints_one_sentence_and_exits_2(tmp_path, capsys):
    assert main(["--dataset", "toy", str(tmp_path / "nothing-here")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "neither a PCD file nor a folder" in err and "\n" not in err


# --- checks added after review: config values, unit quaternion, empty map, outputs ---------------

@pytest.mark.parametrize("content,msg", [
    (b'[map]\nresolution = "a"\n', "resolution in .* must be a finite number"),
    (b"[map]\nvar_thresh = -1.0\n", "var_thresh in .* must be positive"),
    (b'scans = "x"\n', "scans in .* must be an integer"),
    (b"[map]\nnum_class = true\n", "num_class in .* must be an integer"),
    (b"[map]\nnum_class = 1\n", "num_class in .* must be at least 2"),
    (b"[kernel]\nsf2 = 1e308\n", "sf2 in .* overflow"),              # would give NaN posteriors
    (b"[kernel]\nprior = 1e308\n", "prior in .* overflow"),
    (b"[kernel]\nprior = 1e-320\n", "prior in .* overflow"),
    (b"[map]\nresolution = 0.1\n[kernel]\nresolution = 0.5\n",
     r"sets resolution twice \(\[map\] and \[kernel\]\)"),
    (b"[map]\nresolution = 0.1 # \xe9\n", "not a UTF-8 text file"),
    (b"[map]\nresolution = 1e-20\n", "resolution in .* below 0.0001 m"),
    (b"[map]\nnum_class = 1e9\n", "num_class in .* must be an integer"),
    (b"[map]\nnum_class = 1000000000\n", "num_class in .* more than the 65536"),
])
def test_config_values_are_checked(tmp_path, content, msg):
    p = tmp_path / "c.toml"
    p.write_bytes(content)
    with pytest.raises(InputError, match=msg) as e:
        load_config(p)
    _one_sentence(e)


def test_viewpoint_must_be_a_unit_quaternion(tmp_path):
    d = _pcd(tmp_path / "d", [(1, 2, 0.5, 1), (1, 2, 0.6, 2)])
    f = d / "scan_1.pcd"
    f.write_text(f.read_text().replace("VIEWPOINT 0 0 0 1 0 0 0", "VIEWPOINT 0 0 0 2 0 0 0"))
    with pytest.raises(InputError, match="not a unit quaternion") as e:
        _map_toy(d)
    _one_sentence(e)


def test_all_points_beyond_max_range_is_an_error_not_an_empty_map(tmp_path, capsys):
    d = _pcd(tmp_path / "d", [(100, 0, 0.5, 1), (100, 1, 0.5, 2)])
    out = tmp_path / "out"
    assert main([str(d), "--out", str(out), "--no-figures"]) == 2
    assert "map would be empty" in capsys.readouterr().err
    assert not out.exists()


def test_bki_refuses_to_overwrite_and_out_must_be_a_folder(tmp_path, capsys):
    d = _pcd(tmp_path / "d", [(1, 2, 0.5, 1), (1, 2, 0.6, 2), (2, 2, 0.5, 3)])
    out = tmp_path / "out"
    assert main([str(d), "--out", str(out), "--no-figures"]) == 0
    before = (out / "voxels.csv").read_bytes()
    capsys.readouterr()
    assert main([str(d), "--out", str(out), "--no-figures"]) == 2
    assert "already exists" in capsys.readouterr().err
    assert (out / "voxels.csv").read_bytes() == before
    assert main([str(d), "--out", str(out), "--no-figures", "--force"]) == 0
    afile = tmp_path / "afile"
    afile.write_text("mine")
    assert main([str(d), "--out", str(afile), "--no-figures"]) == 2
    assert "is a file, not a folder" in capsys.readouterr().err
    assert afile.read_text() == "mine"

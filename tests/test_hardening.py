"""Regression tests of issue 10: each bad input is refused in one line or handled correctly, and a
failed or interrupted run leaves nothing that looks finished."""
from __future__ import annotations

import ast
import errno
import os
import resource
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from hw4.core import atomic
from hw4 import tasks
from hw4.__main__ import main
from hw4.bki.config import load_config
from hw4.bki.kitti import SemanticKITTISequence, read_calib
from hw4.bki.pcd import read_labelled_scan, read_pcd
from hw4.core.data import IntelData, ensure, ensure_all, load_intel
from hw4.core.errors import InputError
from hw4.ogm_CSM import ogm_CSM
from hw4.ogm_S_CSM import ogm_S_CSM
from hw4.ogm_continuous_CSM import ogm_continuous_CSM
from hw4.ogm_continuous_S_CSM import ogm_continuous_S_CSM

from test_bki_kitti import write_sequence

ROOT = Path(__file__).resolve().parent.parent
ENV = {"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), "TQDM_DISABLE": "1"}


def one_line(e) -> str:
    msg = str(e.value if hasattr(e, "value") else e)
    assert msg and "\n" not in msg, msg
    return msg


def cli_err(capsys, argv) -> str:
    """Run the CLI in-process; it must exit 2 with one line 'error: ...' on stderr."""
    capsys.readouterr()
    rc = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2, err
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


def finished_files(folder: Path) -> list[str]:
    """Every file in ``folder`` (hidden temporary files included)."""
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


# --------------------------------------------------------------------------- tiny datasets

def tiny_intel(semantic=False) -> IntelData:
    """Three poses in a 6 m room: a fast stand-in for the Intel data in CLI tests."""
    poses = np.array([[0.0, 0.0, 0.0], [0.5, 0.2, 0.4], [-0.4, 0.3, -0.6]])
    ang = np.linspace(-np.pi, np.pi, 90, endpoint=False)
    scans = []
    for t, (x, y, h) in enumerate(poses):
        r = 2.5 + 0.3 * np.cos(3 * ang)
        xy = np.vstack([r * np.cos(ang), r * np.sin(ang)])
        lab = 1 + (np.arange(90) // 15)
        scans.append(np.vstack([xy, lab]) if semantic else xy)
    return IntelData(poses, scans)


@pytest.fixture
def tiny_tasks(monkeypatch):
    monkeypatch.setattr(tasks, "load_task_data", lambda task: tiny_intel(task in (3, 4)))


PCD = """VERSION 0.7
FIELDS {fields}
SIZE {size}
TYPE {type}
COUNT {count}
WIDTH {n}
HEIGHT 1
VIEWPOINT 0 0 0 1 0 0 0
POINTS {n}
DATA {kind}
"""


def pcd_text(rows, n=None, fields="x y z label", size="4 4 4 4", type_="F F F U",
             count="1 1 1 1", extra_header=""):
    n = len(rows) if n is None else n
    head = PCD.format(fields=fields, size=size, type=type_, count=count, n=n, kind="ascii")
    head = head.replace("DATA ascii\n", extra_header + "DATA ascii\n")
    return head + "".join(" ".join(str(v) for v in r) + "\n" for r in rows)


def toy_folder(folder: Path, n=40, seed=0) -> Path:
    """A folder with one small labelled PCD scan (labels 1..3, within 3 m of the origin)."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    xyz = rng.uniform(-3, 3, (n, 3)).round(3)
    lab = rng.integers(1, 4, n)
    (folder / "scan_1.pcd").write_text(pcd_text([(*p, l) for p, l in zip(xyz.tolist(), lab)]))
    return folder


# =========================================================================== readers: silently wrong

def test_pcd_surplus_ascii_lines_refused(tmp_path):
    p = tmp_path / "a.pcd"
    p.write_text(pcd_text([(1, 2, 3, 1), (4, 5, 6, 2), (7, 8, 9, 3)], n=2))
    with pytest.raises(InputError, match="declares 2 points but the data has 3 lines") as e:
        read_pcd(p)
    one_line(e)


def test_pcd_surplus_binary_records_refused(tmp_path):
    rec = np.zeros(3, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("label", "<u4")])
    head = PCD.format(fields="x y z label", size="4 4 4 4", type="F F F U", count="1 1 1 1", n=2,
                      kind="binary")
    p = tmp_path / "b.pcd"
    p.write_bytes(head.encode() + rec.tobytes())
    with pytest.raises(InputError, match="16 bytes more than its 2 POINTS") as e:
        read_pcd(p)
    one_line(e)
    p.write_bytes(head.encode() + rec[:2].tobytes() + b"\n")  # a trailing newline is harmless
    assert len(read_pcd(p)) == 2


@pytest.mark.parametrize("label", ["1.5", "2.9", "3.7", "nan"])
def test_pcd_fractional_float_labels_refused(tmp_path, label):
    p = tmp_path / "a.pcd"
    p.write_text(pcd_text([(1, 2, 3, 1), (4, 5, 6, label)], type_="F F F F"))
    with pytest.raises(InputError, match=f"point 1 has label {label}, which is not an integer") as e:
        read_labelled_scan(p)
    one_line(e)
    p.write_text(pcd_text([(1, 2, 3, 1.0), (4, 5, 6, 3.0)], type_="F F F F"))
    np.testing.assert_array_equal(read_labelled_scan(p).labels, [1, 3])


def test_pcd_duplicate_field_ascii_refused(tmp_path):
    p = tmp_path / "a.pcd"
    p.write_text(pcd_text([(1, 2, 3, 1, 9)], fields="x y z label x", size="4 4 4 4 4",
                          type_="F F F U F", count="1 1 1 1 1"))
    with pytest.raises(InputError, match="names field 'x' twice") as e:
        read_pcd(p)
    one_line(e)


@pytest.mark.parametrize("line", ["FIELDS x y z label", "SIZE 4 4 4 4", "TYPE F F F U",
                                  "VIEWPOINT 5 0 0 1 0 0 0", "COUNT 1 1 1 1", "POINTS 1"])
def test_pcd_repeated_header_line_refused(tmp_path, line):
    p = tmp_path / "a.pcd"
    p.write_text(pcd_text([(1, 2, 3, 1)], extra_header=line + "\n"))
    with pytest.raises(InputError, match=f"two {line.split()[0]} lines") as e:
        read_pcd(p)
    one_line(e)


def test_kitti_two_different_tr_lines_refused(tmp_path):
    seq = tmp_path / "04"
    write_sequence(seq, n_scans=1)
    calib = (seq / "calib.txt").read_text()
    (seq / "calib.txt").write_text(calib + "Tr: 1 0 0 0 0 1 0 0 0 0 1 0\n")
    with pytest.raises(InputError, match="different 'Tr:' lines") as e:
        SemanticKITTISequence(seq)
    one_line(e)
    (seq / "calib.txt").write_text(calib + calib.splitlines()[-1] + "\n")  # the same Tr twice: fine
    assert read_calib(seq / "calib.txt").shape == (4, 4)


def _mat(path, poses, scans):
    pose = {"x": poses[:, :1], "y": poses[:, 1:2], "h": poses[:, 2:3]}
    cell = np.empty((len(scans), 1), dtype=object)
    for t, s in enumerate(scans):
        cell[t, 0] = s
    savemat(path, {"robotPose": pose, "laserScan": cell})
    return path


@pytest.mark.parametrize("where", ["robotPose", "laserScan"])
def test_mat_complex_values_refused(tmp_path, where):
    d = tiny_intel()
    poses, scans = d.poses.astype(complex), [s.astype(complex) for s in d.scans]
    if where == "robotPose":
        poses[1, 0] += 1j
        scans = d.scans
    else:
        poses = d.poses
        scans[2][0, 3] += 0.5j
    path = _mat(tmp_path / "c.mat", poses, scans)
    with pytest.raises(InputError, match="complex numbers") as e:
        load_intel(path=path)
    one_line(e)
    good = load_intel(path=_mat(tmp_path / "g.mat", d.poses, d.scans))
    np.testing.assert_array_equal(good.poses, d.poses)


def _scene_map(cls, **kw):
    d = tiny_intel(cls.semantic)
    m = cls(range_x=[-4, 4], range_y=[-4, 4], grid_size=0.25, **kw)
    m.construct_map(d.poses, d.scans)
    m.build_ogm()
    return m


@pytest.mark.parametrize("kw", [dict(prior_alpha=np.inf), dict(prior_alpha=1e308),
                                dict(prior_alpha=1e-320), dict(sigma=1e308)])
def test_template_numbers_that_would_give_nan_refused(kw):
    with pytest.raises(InputError, match="prior_alpha|sigma") as e:
        _scene_map(ogm_continuous_CSM, **kw)
    one_line(e)
    m = _scene_map(ogm_continuous_CSM, **{k: (1e-3 if k == "prior_alpha" else 0.1) for k in kw})
    assert np.all(np.isfinite(m.map["mean"])) and np.all(np.isfinite(m.map["variance"]))


def test_config_missing_keys_take_the_dataset_defaults(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text("[map]\nresolution = 0.4\n")
    cfg = load_config(p, defaults="semantickitti")
    kitti = load_config("semantickitti")
    assert cfg.resolution == 0.4
    assert cfg.max_range == kitti.max_range == -1.0 and cfg.num_class == 20
    assert cfg.with_(resolution=kitti.resolution) == kitti
    assert load_config(p).max_range == load_config("toy").max_range  # no dataset: toy defaults


# =========================================================================== tracebacks

def test_pcd_binary_padding_fields_are_skipped(tmp_path):
    rec = np.zeros(3, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("p1", "<f4"),
                             ("label", "<u4"), ("p2", "<u1", (12,))])
    rec["x"], rec["y"], rec["z"], rec["label"] = [1, 2, 3], [4, 5, 6], [7, 8, 9], [1, 2, 3]
    rec["p1"] = 99
    head = PCD.format(fields="x y z _ label _", size="4 4 4 4 4 1", type="F F F F U U",
                      count="1 1 1 1 1 12", n=3, kind="binary")
    p = tmp_path / "b.pcd"
    p.write_bytes(head.encode() + rec.tobytes())
    scan = read_labelled_scan(p)
    np.testing.assert_array_equal(scan.points, [[1, 4, 7], [2, 5, 8], [3, 6, 9]])
    np.testing.assert_array_equal(scan.labels, [1, 2, 3])
    assert "_" not in read_pcd(p).fields
    p.write_bytes(head.replace("x y z _ label _", "x y z x label _").encode() + rec.tobytes())
    with pytest.raises(InputError, match="names field 'x' twice"):
        read_pcd(p)


@pytest.mark.parametrize("count", ["99999999999999999999", "1048577", "²"])
def test_pcd_huge_or_odd_count_refused(tmp_path, count):
    p = tmp_path / "a.pcd"
    for kind in ("ascii", "binary"):
        text = pcd_text([(1, 2, 3, 1)], count=f"1 1 1 {count}").replace("ascii", kind)
        p.write_bytes(text.encode())
        with pytest.raises(InputError, match="COUNT") as e:
            read_pcd(p)
        one_line(e)


@pytest.mark.parametrize("which", ["poses.txt", "calib.txt"])
def test_kitti_text_that_is_not_utf8_refused(tmp_path, which):
    seq = tmp_path / "04"
    write_sequence(seq, n_scans=1)
    (seq / which).write_bytes(b"\xff\xfe" + (seq / which).read_bytes())
    with pytest.raises(InputError, match="not a UTF-8 text file") as e:
        SemanticKITTISequence(seq)
    one_line(e)


def test_kitti_tr_without_colon_refused(tmp_path):
    seq = tmp_path / "04"
    write_sequence(seq, n_scans=1)
    (seq / "calib.txt").write_text((seq / "calib.txt").read_text().replace("Tr:", "Tr"))
    with pytest.raises(InputError, match="starts with Tr but has no colon") as e:
        SemanticKITTISequence(seq)
    one_line(e)


def test_kitti_scan_named_with_a_non_ascii_digit(tmp_path):
    seq = tmp_path / "04"
    write_sequence(seq, n_scans=2)
    for kind, ext in (("velodyne", "bin"), ("labels", "label")):
        (seq / kind / f"000001.{ext}").rename(seq / kind / f"².{ext}")
    s = SemanticKITTISequence(seq)
    assert [b.name for b in s.bins] == ["000000.bin", "².bin"]
    scan = s.scan(1)  # no number in the name: the scan's position in the sorted list gives the pose
    assert np.all(np.isfinite(scan.points)) and len(scan.points) > 0


def test_kitti_folder_named_bin_is_not_a_scan(tmp_path):
    seq = tmp_path / "04"
    write_sequence(seq, n_scans=1)
    (seq / "velodyne" / "000001.bin").mkdir()
    assert len(SemanticKITTISequence(seq)) == 1


@pytest.mark.parametrize("cls,kw,msg", [
    (ogm_CSM, dict(n_beams=0), "n_beams must be a positive integer"),
    (ogm_CSM, dict(n_beams="133"), "n_beams must be a positive integer"),
    (ogm_CSM, dict(range_x=[-15, 0, 20]), "range_x must be a pair"),
    (ogm_CSM, dict(range_x="ab"), "range_x must be a pair"),
    (ogm_CSM, dict(range_y=[10, -25]), "range_y must be finite with lo < hi"),
    (ogm_S_CSM, dict(num_classes=6.5), "num_classes must be a positive integer"),
    (ogm_CSM, dict(z_max=np.nan), "z_max must be a finite positive"),
    (ogm_CSM, dict(nearest_poses=0), "nearest_poses must be a positive integer"),
    (ogm_CSM, dict(progress="yes"), "progress must be True or False"),
    (ogm_continuous_CSM, dict(l=np.inf), "l must be a finite positive"),
    (ogm_continuous_CSM, dict(beams=["all"]), "beams must be 'nearest' or 'all'"),
    (ogm_continuous_S_CSM, dict(sample_step=-1), "sample_step must be a finite positive"),
    (ogm_CSM, dict(grid_size=1e-300), "needing more than"),
])
def test_template_bad_keywords_refused_at_construction(cls, kw, msg):
    with pytest.raises(InputError, match=msg) as e:
        cls(**kw)
    one_line(e)


def test_run_grid_size_1e_300_is_one_line(capsys, tmp_path):
    err = cli_err(capsys, ["run", "--task", "1", "--grid-size", "1e-300", "--out", str(tmp_path / "o")])
    assert "more than the 4 GiB limit" in err
    assert not (tmp_path / "o").exists()


# =========================================================================== outputs

class locked_folder:
    """A folder nobody may write into: immutable (``chattr +i``) for root, mode 555 otherwise."""

    def __init__(self, path: Path):
        self.path = path

    def __enter__(self) -> Path:
        self.path.mkdir()
        if os.geteuid() == 0:
            r = subprocess.run(["chattr", "+i", str(self.path)], capture_output=True)
            if r.returncode:
                pytest.skip("root, and chattr +i is not available to lock a folder")
        else:
            self.path.chmod(0o555)
        return self.path

    def __exit__(self, *exc):
        if os.geteuid() == 0:
            subprocess.run(["chattr", "-i", str(self.path)], capture_output=True)
        self.path.chmod(0o755)


DENIED = ("Permission denied", "Operation not permitted")


def _fake_pdf(folder: Path) -> Path:
    pdf = folder / "book.pdf"
    pdf.write_bytes(b"%PDF-1.5\n% stand-in for the book\n%%EOF\n")
    (folder / "mapping.mp4").write_bytes(b"\x00\x00\x00\x18ftypmp42")
    return pdf


def _commands(base: Path) -> dict:
    toy = toy_folder(base / "toy")
    pdf = _fake_pdf(base)
    return {
        "run": ["run", "--task", "1", "--grid-size", "0.5", "--no-figures"],
        "bki": ["bki", str(toy), "--no-figures"],
        "package": ["package", "--uniqname", "jdoe", "--pdf", str(pdf), "--video",
                    str(base / "mapping.mp4")],
    }


def _cli(argv, **kw):
    return subprocess.run([sys.executable, "-m", "hw4", *argv], capture_output=True, text=True,
                          cwd="/", env={**ENV, "HOME": os.environ.get("HOME", "/tmp")},
                          timeout=600, **kw)


@pytest.mark.parametrize("cmd", ["run", "bki", "package"])
def test_unwritable_out_is_one_line(cmd, tmp_path, capsys, tiny_tasks):
    argv = _commands(tmp_path)[cmd]
    with locked_folder(tmp_path / "locked") as locked:
        for out in (locked, locked / "out"):
            err = cli_err(capsys, argv + ["--out", str(out)])
            assert "cannot write into the output folder" in err and any(d in err for d in DENIED)
        assert finished_files(locked) == []


def test_data_into_an_unwritable_folder_is_one_line(tmp_path, capsys, monkeypatch):
    from hw4.core import data
    with locked_folder(tmp_path / "locked") as locked:
        monkeypatch.setattr(data, "DATA_DIR", locked / "data")
        err = cli_err(capsys, ["data", "--only", "intel/"])
        assert "cannot create the data folder" in err and any(d in err for d in DENIED)
        monkeypatch.setattr(data, "DATA_DIR", locked)
        err = cli_err(capsys, ["data", "--only", "intel/"])
        assert any(d in err for d in DENIED)
        assert finished_files(locked) == []


def test_read_only_file_system_is_one_line(monkeypatch, tmp_path):
    real = os.open

    def read_only(path, flags, *a):
        if flags & os.O_CREAT:
            raise OSError(errno.EROFS, "Read-only file system", str(path))
        return real(path, flags, *a)
    folder = tmp_path / "out"
    folder.mkdir()
    monkeypatch.setattr(atomic.os, "open", read_only)
    with pytest.raises(InputError, match=r"cannot write into the output folder .*Read-only file system") as e:
        atomic.Outputs(folder, ["a.npz"])
    one_line(e)


@pytest.mark.parametrize("cmd", ["run", "bki", "package"])
def test_full_disk_leaves_nothing_that_looks_finished(cmd, tmp_path):
    argv = _commands(tmp_path)[cmd] + ["--out", str(tmp_path / "out")]
    if cmd == "run":
        argv.remove("--no-figures")

    def small_disk():  # writes beyond 8 KiB fail with EFBIG, as on a full disk
        resource.setrlimit(resource.RLIMIT_FSIZE, (8192, 8192))
    import matplotlib
    mpl = tmp_path / "mpl"  # a copy of matplotlib's font cache: nothing else needs writing
    shutil.copytree(matplotlib.get_cachedir(), mpl, ignore=shutil.ignore_patterns("tex.cache"))
    r = subprocess.run([sys.executable, "-m", "hw4", *argv], capture_output=True, text=True,
                       cwd="/", timeout=600, preexec_fn=small_disk,
                       env={**ENV, "HOME": str(tmp_path), "MPLCONFIGDIR": str(mpl),
                            "PYTHONDONTWRITEBYTECODE": "1"})
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines()[-1].startswith("error: cannot write"), r.stderr
    assert "Traceback" not in r.stderr
    assert finished_files(tmp_path / "out") == []  # no file, no temporary, no new folder


@pytest.mark.parametrize("cmd", ["run", "bki", "package"])
def test_output_name_that_is_a_folder_refused_even_with_force(cmd, tmp_path, capsys, tiny_tasks):
    out = tmp_path / "out"
    name = {"run": "task1_grid0.5.npz", "bki": "voxels.csv", "package": "jdoe_hw4.tgz"}[cmd]
    (out / name).mkdir(parents=True)
    argv = _commands(tmp_path)[cmd] + ["--out", str(out), "--force"]
    err = cli_err(capsys, argv)
    assert f"{name} is a folder, not a file" in err
    assert finished_files(out) == [name]


def test_package_out_is_a_file_or_under_a_file(tmp_path, capsys):
    argv = _commands(tmp_path)["package"]
    afile = tmp_path / "afile"
    afile.write_text("mine")
    assert "is a file, not a folder" in cli_err(capsys, argv + ["--out", str(afile)])
    assert "lies under" in cli_err(capsys, argv + ["--out", str(afile / "sub")])
    assert afile.read_text() == "mine"


def test_package_pdf_that_is_a_folder_or_unreadable(tmp_path, capsys, monkeypatch):
    from hw4 import package
    argv = _commands(tmp_path)["package"]
    pdf = argv[argv.index("--pdf") + 1]
    argv[argv.index("--pdf") + 1] = str(tmp_path)
    assert "is a folder, not a PDF" in cli_err(capsys, argv + ["--out", str(tmp_path / "o")])
    argv[argv.index("--pdf") + 1] = pdf

    def denied(path, *a, **k):  # root reads any file: stand in for a file the user may not read
        raise PermissionError(errno.EACCES, "Permission denied", str(path))
    monkeypatch.setattr(package, "open", denied, raising=False)
    err = cli_err(capsys, argv + ["--out", str(tmp_path / "o")])
    assert "cannot read the PDF" in err and "Permission denied" in err
    assert not (tmp_path / "o").exists()


def test_data_folder_whose_entry_is_a_file(tmp_path):
    (tmp_path / "intel").write_text("not a folder")
    with pytest.raises(InputError, match="intel is a file") as e:
        ensure("intel/sample_Intel_dataset.mat", data_dir=tmp_path)
    one_line(e)


def test_interrupted_run_removes_its_temporary_files(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        with atomic.Outputs(out, ["a.npz", "b.png"]) as o:
            o["a.npz"].write_bytes(b"complete-looking")
            raise KeyboardInterrupt
    assert not out.exists()
    (out).mkdir()
    (out / "a.npz").write_text("mine")
    with pytest.raises(RuntimeError):
        with atomic.Outputs(out, ["a.npz"], force=True) as o:
            o["a.npz"].write_bytes(b"new")
            raise RuntimeError("boom")
    assert finished_files(out) == ["a.npz"] and (out / "a.npz").read_text() == "mine"


def test_run_writes_all_outputs_or_none(tmp_path, capsys, tiny_tasks, monkeypatch):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    out = tmp_path / "out"
    assert main(["run", "--task", "3", "--grid-size", "0.5", "--out", str(out)]) == 0
    assert finished_files(out) == ["task3_grid0.5.npz", "task3_grid0.5_mean.png",
                                   "task3_grid0.5_variance.png"]

    def fail(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")
    # the disk fills while a PNG is written (print_png: what savefig and the CLI's own
    # figure writer both end in)
    monkeypatch.setattr(FigureCanvasAgg, "print_png", fail)
    err = cli_err(capsys, ["run", "--task", "1", "--grid-size", "0.5", "--out", str(out)])
    assert "No space left on device" in err and "nothing was written" in err
    assert finished_files(out) == ["task3_grid0.5.npz", "task3_grid0.5_mean.png",
                                   "task3_grid0.5_variance.png"]


# =========================================================================== runs that never end

def test_tiny_sample_step_refused_up_front(capsys, tmp_path):
    err = cli_err(capsys, ["run", "--task", "2", "--sample-step", "1e-6", "--out", str(tmp_path / "o")])
    assert "4e+05 free samples per (cell, pose) pair" in err and "checks" in err
    assert not (tmp_path / "o").exists()


def test_all_beams_with_one_very_long_beam_refused():
    d = tiny_intel()
    d.scans[1][:, 7] = [1e6, 0.0]  # one finite 1e6 m beam
    m = ogm_continuous_CSM(beams="all", range_x=[-4, 4], range_y=[-4, 4], grid_size=0.25)
    m.construct_map(d.poses, d.scans)
    with pytest.raises(InputError, match=r"pose 1 \(longest beam 1e\+06 m\).* GiB of working memory") as e:
        m.build_ogm()
    one_line(e)


def test_tiny_free_resolution_refused_with_the_estimate(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[training]\nfree_resolution = 1e-6\n")
    err = cli_err(capsys, ["bki", str(toy_folder(tmp_path / "toy")), "--config", str(cfg),
                           "--out", str(tmp_path / "o"), "--no-figures"])
    assert "free_resolution 1e-06 m gives about" in err and "GiB" in err
    assert not (tmp_path / "o").exists()


def test_huge_num_class_refused_with_the_estimate(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[map]\nnum_class = 60000\n")
    err = cli_err(capsys, ["bki", str(toy_folder(tmp_path / "toy", n=400)), "--config", str(cfg),
                           "--out", str(tmp_path / "o"), "--no-figures"])
    assert "num_class 60000 with the" in err and "GiB for the map's evidence" in err


# =========================================================================== smaller

def test_build_ogm_accepts_every_template_signature(capsys):
    for call in (lambda m: m.build_ogm(), lambda m: m.build_ogm(disable_print=True),
                 lambda m: m.build_ogm(True), lambda m: m.build_ogm(disable_print=False)):
        d = tiny_intel()
        m = ogm_CSM(0.25)  # the 2024 template takes grid_size positionally
        m.range_x, m.range_y = [-4, 4], [-4, 4]
        m.construct_map(d.poses, d.scans)
        call(m)
        assert m.map["mean"].shape == (m.map["size"], 1) and m.counts.sum() > 0


def test_run_py_has_the_course_plot_flag(tmp_path, tiny_tasks, capsys):
    sys.path.insert(0, str(ROOT))
    try:
        import run
    finally:
        sys.path.remove(str(ROOT))
    assert run.main(["--task_num", "1", "--grid_size", "0.5", "--out", str(tmp_path / "a")]) == 0
    assert finished_files(tmp_path / "a") == ["task1_grid0.5.npz"]
    assert run.main(["--task_num", "3", "--grid_size", "0.5", "--plot", "--out", str(tmp_path / "b")]) == 0
    assert finished_files(tmp_path / "b") == ["task3_grid0.5.npz", "task3_grid0.5_mean.png",
                                              "task3_grid0.5_variance.png"]


def test_semantic_figure_legend_is_not_clipped(tmp_path, tiny_tasks):
    import matplotlib.image
    assert main(["run", "--task", "3", "--grid-size", "0.5", "--out", str(tmp_path)]) == 0
    img = matplotlib.image.imread(tmp_path / "task3_grid0.5_mean.png")
    edge = img[:, -3:, :3]  # the rightmost columns: white margin, not a cut legend
    assert np.all(edge > 0.99)
    assert img.shape[1] > img.shape[0]  # the legend beside the map widens the image


def test_package_readme_says_what_was_checked(tmp_path):
    from hw4 import package
    pdf = _fake_pdf(tmp_path)
    tgz, _ = package.build_package("jdoe", pdf=pdf, out=tmp_path / "o",
                                   videos=[tmp_path / "mapping.mp4"])
    with tarfile.open(tgz) as tar:
        readme = tar.extractfile("jdoe_hw4/README.txt").read().decode()
        sources = {m.name: tar.extractfile(m).read().decode() for m in tar.getmembers()
                   if m.name.endswith(".py")}
    py = ".".join(map(str, sys.version_info[:3]))
    assert f"Python {py}" in readme and ">= 3.10" not in readme and "Python 3.8 syntax" in readme
    for name, text in sources.items():  # the claim: every bundled file parses as Python 3.8
        ast.parse(text, filename=name, feature_version=(3, 8))


def test_data_only_prefix_that_matches_nothing(capsys):
    err = cli_err(capsys, ["data", "--only", "Intel/"])
    assert "no dataset file in data/manifest.tsv starts with 'Intel/'" in err and "intel/" in err
    with pytest.raises(InputError):
        ensure_all("nothing/")


@pytest.mark.parametrize("var", ["HW4_DATA_DIR", "HW4_SHARED_DATA"])
def test_empty_data_dir_variable_refused(monkeypatch, tmp_path, var):
    monkeypatch.setenv(var, "")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError, match=f"{var} is set but empty") as e:
        ensure("intel/sample_Intel_dataset.mat")
    one_line(e)
    assert finished_files(tmp_path) == []


def test_coarse_resolution_is_blamed_not_max_range(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[map]\nresolution = 1e6\n")
    err = cli_err(capsys, ["bki", str(toy_folder(tmp_path / "toy")), "--config", str(cfg),
                           "--out", str(tmp_path / "o"), "--no-figures"])
    assert "resolution 1000000.0 m is too coarse for ell" in err and "max_range" not in err


@pytest.mark.parametrize("where", ["pose", "scan"])
def test_huge_coordinates_refused_not_overflowed(where):
    """Found by the fuzz suite: 1e308 m poses or beams overflowed in the geometry (warnings)."""
    d = tiny_intel()
    if where == "pose":
        d.poses[1, 0] = 1e308
    else:
        d.scans[2][1, 4] = 1e308
    m = ogm_continuous_CSM(range_x=[-4, 4], range_y=[-4, 4], grid_size=0.25)
    with pytest.raises(InputError, match="beyond 1e\\+09 m") as e:
        m.construct_map(d.poses, d.scans)
    one_line(e)


@pytest.mark.parametrize("kw", [dict(grid_size=2**64 - 3), dict(grid_size=2.6e-202),
                                dict(prior_alpha=np.float32(0.5)), dict(num_classes=10**20),
                                dict(z_max=10**400)])
def test_extreme_keyword_numbers_checked_without_overflow(kw):
    """Found by the long fuzz profile: these raised TypeError/OverflowError or cast warnings."""
    cls = ogm_S_CSM if "num_classes" in kw else ogm_CSM
    try:
        m = cls(range_x=[-3, 3], range_y=[-3, 3], **{"grid_size": 0.5, **kw})
    except InputError as e:
        one_line(e)
        return
    d = tiny_intel(cls.semantic)
    m.construct_map(d.poses, d.scans)
    m.build_ogm()
    assert np.all(np.isfinite(m.map["mean"])) and np.all(np.isfinite(m.map["variance"]))


def test_kitti_pose_with_a_huge_rotation_entry_refused(tmp_path):
    seq = tmp_path / "04"
    write_sequence(seq, n_scans=1)
    words = (seq / "poses.txt").read_text().split(" ")
    words[0] = "1e308"
    (seq / "poses.txt").write_text(" ".join(words))
    with pytest.raises(InputError, match="not a rigid transform") as e:
        SemanticKITTISequence(seq)
    one_line(e)

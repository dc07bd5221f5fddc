"""Property-based tests of the command line, called in-process with generated argument lists:
exit 0 with every output whole and no temporary left, or exit 2 with one line ``error: ...`` on
stderr and the output folder exactly as it was."""
from __future__ import annotations

import atexit
import hashlib
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

from test_fuzz_settings import examples
from test_hardening import tiny_intel, toy_folder

from hw4 import tasks
from hw4.__main__ import main

_DIR = Path(tempfile.mkdtemp(prefix="fuzz-cli-"))
atexit.register(shutil.rmtree, _DIR, True)
_n = [0]
OUTS = ["new"] * 5 + ["existing", "existing", "folder_name", "file", "under_file"]
NUMBERS = ["0.5", "1", "0.75", "0", "-1", "nan", "inf", "1e-300", "1e300", "abc", "", "2", "0.25"]


@pytest.fixture(autouse=True)
def quiet(monkeypatch):
    monkeypatch.setenv("TQDM_DISABLE", "1")
    monkeypatch.setattr(tasks, "load_task_data", lambda task: tiny_intel(task in (3, 4)))


def fresh() -> Path:
    _n[0] += 1
    d = _DIR / str(_n[0])
    d.mkdir()
    return d


def snapshot(folder: Path) -> dict:
    if not folder.exists():
        return {}
    if folder.is_file():
        return {".": hashlib.sha256(folder.read_bytes()).hexdigest()}
    return {str(p.relative_to(folder)): (hashlib.sha256(p.read_bytes()).hexdigest()
                                         if p.is_file() else "dir")
            for p in sorted(folder.rglob("*"))}


def out_choice(base: Path, kind: str, existing: list[str]) -> Path:
    if kind == "file":
        (base / "afile").write_text("mine")
        return base / "afile"
    if kind == "under_file":
        (base / "afile").write_text("mine")
        return base / "afile" / "sub"
    out = base / "out"
    if kind in ("existing", "folder_name"):
        out.mkdir()
        for name in existing:
            if kind == "folder_name":
                (out / name).mkdir()
            else:
                (out / name).write_text("mine")
    return out


def run_cli(capsys, argv, out: Path):
    before = snapshot(out)
    capsys.readouterr()
    try:
        rc = main(argv)
    except SystemExit as e:  # argparse: usage errors
        rc = e.code
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert rc in (0, 2), (rc, err)
    if rc == 2:
        assert err and err[-1].startswith("error: "), err
        assert all(ln.startswith(("error: ", "note: ")) for ln in err), err
        assert len([ln for ln in err if ln.startswith("error: ")]) == 1, err
        assert snapshot(out) == before, "a failed run changed the output folder"
    else:
        assert not [ln for ln in err if ln.startswith("error")], err
        if out.is_dir():
            assert not [p for p in out.iterdir() if ".partial" in p.name], list(out.iterdir())
    event(f"exit {rc}")
    return rc


@settings(max_examples=examples(60))
@given(task=st.sampled_from(["1", "2", "3", "4", "1", "3", "5", "x"]), grid=st.sampled_from(["0.5", "1", "0.75"] * 4 + NUMBERS),
       nearest=st.sampled_from([None] * 6 + ["16", "all", "0", "-3", "2.5", "x"]),
       beams=st.sampled_from([None] * 6 + ["nearest", "all", "some"]),
       step=st.sampled_from([None] * 8 + ["0.1", "0.25", "1e-6", "0", "nan", "x"]),
       out_kind=st.sampled_from(OUTS), force=st.booleans(), figures=st.integers(0, 4))
def test_run_arguments(capsys, task, grid, nearest, beams, step, out_kind, force, figures):
    base = fresh()
    stem = f"task{task}_grid{grid}"
    out = out_choice(base, out_kind, [f"{stem}.npz", f"{stem}_mean.png"])
    argv = ["run", "--task", task, "--grid-size", grid, "--out", str(out)]
    for flag, v in (("--nearest-poses", nearest), ("--beams", beams), ("--sample-step", step)):
        if v is not None:
            argv += [flag, v]
    argv += (["--force"] if force else []) + ([] if figures == 0 else ["--no-figures"])
    if run_cli(capsys, argv, out) == 0:
        npz = sorted(out.glob("task*.npz"))
        assert len(npz) == 1
        arrays = np.load(npz[0])
        assert np.all(np.isfinite(arrays["mean"])) and np.all(np.isfinite(arrays["variance"]))
        assert len(list(out.glob(npz[0].stem + "_*.png"))) == (2 if figures == 0 else 0)


@settings(max_examples=examples(50))
@given(path=st.sampled_from(["toy"] * 6 + ["missing", "file", "empty", "bad_pcd"]),
       dataset=st.sampled_from(["toy"] * 6 + ["semantickitti", "other"]),
       method=st.sampled_from(["sbki", "scsm"] * 3 + ["x"]),
       scans=st.sampled_from([None] * 4 + ["0", "1", "5", "-1", "x"]),
       config=st.sampled_from([None] * 4 + ["ok", "ok", "twice", "bad", "coarse", "missing"]),
       out_kind=st.sampled_from(OUTS), force=st.booleans())
def test_bki_arguments(capsys, path, dataset, method, scans, config, out_kind, force):
    base = fresh()
    paths = {"toy": toy_folder(base / "toy"), "missing": base / "nowhere", "file": base / "f.pcd",
             "empty": base / "empty", "bad_pcd": base / "bad"}
    paths["file"].write_text("not a pcd")
    paths["empty"].mkdir()
    paths["bad_pcd"].mkdir()
    (paths["bad_pcd"] / "a.pcd").write_text("VERSION 0.7\nFIELDS x\n")
    out = out_choice(base, out_kind, ["voxels.csv"])
    argv = ["bki", str(paths[path]), "--dataset", dataset, "--method", method, "--out", str(out),
            "--no-figures"]
    if scans is not None:
        argv += ["--scans", scans]
    if config is not None:
        cfg = base / "c.toml"
        cfg.write_text({"ok": "[map]\nresolution = 0.2\n", "twice": "resolution = 0.1\n[map]\n"
                        "resolution = 0.2\n", "bad": "[map\n", "coarse": "[map]\nresolution = 1e6\n",
                        "missing": ""}[config])
        if config == "missing":
            cfg.unlink()
        argv += ["--config", str(cfg)]
    if force:
        argv.append("--force")
    if run_cli(capsys, argv, out) == 0:
        csv = (out / "voxels.csv").read_text().splitlines()
        assert csv[0].startswith("x,y,z,state,class,variance,p_0") and len(csv) > 1
        probs = np.array([[float(v) for v in row.split(",")[6:]] for row in csv[1:]])
        assert np.all(np.isfinite(probs))
        np.testing.assert_allclose(probs.sum(axis=1), 1.0, atol=1e-4)
        assert (out / "voxels.ply").read_text().startswith("ply\n")


@settings(max_examples=examples(25))
@given(name=st.sampled_from(["jdoe"] * 4 + ["ab12", "JDoe", "", "toolongname", "../x"]),
       pdf=st.sampled_from(["ok"] * 5 + ["missing", "folder", "text"]),
       video=st.sampled_from(["ok"] * 5 + ["missing", "text"]),
       out_kind=st.sampled_from(OUTS), force=st.booleans())
def test_package_arguments(capsys, name, pdf, video, out_kind, force):
    base = fresh()
    pdfs = {"ok": base / "b.pdf", "missing": base / "nope.pdf", "folder": base, "text": base / "t.txt"}
    pdfs["ok"].write_bytes(b"%PDF-1.5\n%%EOF\n")
    pdfs["text"].write_text("hello")
    videos = {"ok": base / "m.mp4", "missing": base / "nope.mp4", "text": base / "t.txt"}
    videos["ok"].write_bytes(b"\x00\x00\x00\x18ftypmp42")
    out = out_choice(base, out_kind, [f"{name}_hw4.tgz"])
    argv = ["package", "--uniqname", name, "--pdf", str(pdfs[pdf]), "--video", str(videos[video]),
            "--out", str(out)] + (["--force"] if force else [])
    if run_cli(capsys, argv, out) == 0:
        import tarfile
        with tarfile.open(out / f"{name}_hw4.tgz") as tar:
            names = tar.getnames()
        assert f"{name}_hw4/ogm_CSM.py" in names and f"{name}_hw4/README.txt" in names
        assert (out / f"{name}_hw4.pdf").read_bytes().startswith(b"%PDF-")


@settings(max_examples=examples(20))
@given(only=st.sampled_from(["Intel/", "intel/", "intel/sample_Intel_dataset.mat", "zzz", "/",
                             "intel", "INTEL/", "bki_toy/sim"]))
def test_data_arguments(capsys, only):
    run_cli(capsys, ["data", "--only", only], _DIR / "no-output")

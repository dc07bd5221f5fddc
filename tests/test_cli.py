"""The command line: help everywhere, outputs written, bad input -> one line and exit 2."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent


def cli(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "hw4", *args], capture_output=True, text=True,
                          cwd=cwd, env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin",
                                        "PYTHONPATH": str(ROOT)})


@pytest.mark.parametrize("cmd", [[], ["run"], ["data"], ["bki"], ["package"]])
def test_help(cmd):
    r = cli(*cmd, "--help")
    assert r.returncode == 0 and "usage:" in r.stdout


def test_run_writes_map_and_figures_and_refuses_to_overwrite(tmp_path):
    r = cli("run", "--task", "2", "--grid-size", "0.5", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    npz = np.load(tmp_path / "task2_grid0.5.npz")
    assert {"cells", "alpha", "beta", "mean", "variance", "counts"} <= set(npz.files)
    assert npz["cells"].shape == (5041, 2) and npz["mean"].shape == (5041, 1)
    np.testing.assert_allclose(npz["mean"], npz["alpha"] / (npz["alpha"] + npz["beta"]))
    for kind in ("mean", "variance"):
        png = tmp_path / f"task2_grid0.5_{kind}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    before = (tmp_path / "task2_grid0.5.npz").read_bytes()
    r = cli("run", "--task", "2", "--grid-size", "0.5", "--out", str(tmp_path))
    assert r.returncode == 2 and "already exists" in r.stderr
    assert (tmp_path / "task2_grid0.5.npz").read_bytes() == before


@pytest.mark.parametrize("args,msg", [
    (["--task", "1", "--grid-size", "0"], "grid_size must be a positive"),
    (["--task", "1", "--grid-size", "0.0001"], "GiB"),
    (["--task", "1", "--beams", "all"], "continuous tasks 2 and 4 only"),
])
def test_run_bad_input_one_line(tmp_path, args, msg):
    r = cli("run", *args, "--out", str(tmp_path))
    assert r.returncode == 2
    assert msg in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_run_bad_task_number(tmp_path):
    r = cli("run", "--task", "7", "--out", str(tmp_path))
    assert r.returncode == 2 and "invalid choice" in r.stderr


def test_run_py_as_in_the_handout(tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "run.py"), "--task_num", "3", "--grid_size",
                        "0.5", "--out", str(tmp_path)], capture_output=True, text=True,
                       env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "task3_grid0.5.npz").exists()
    assert np.load(tmp_path / "task3_grid0.5.npz")["alpha"].shape == (5041, 7)


def test_data_command_verifies():
    r = cli("data", "--only", "intel/")
    assert r.returncode == 0 and "2 file(s) present and verified" in r.stdout


def test_run_out_is_a_file(tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("mine")
    r = cli("run", "--task", "1", "--grid-size", "0.5", "--out", str(afile))
    assert r.returncode == 2 and "is a file, not a folder" in r.stderr
    assert afile.read_text() == "mine"


def test_run_with_a_damaged_data_cache_rebuilds_it_and_gives_the_same_map(tmp_path):
    """A cache file cut short (a full disk, a killed process, a bad copy): the run says so in one
    line, reads the verified .mat file instead, and writes the map of a run with a sound cache."""
    from hw4.core import data
    mine = tmp_path / "data"
    (mine / "intel").mkdir(parents=True)
    (mine / data.INTEL).symlink_to(data.ensure(data.INTEL).resolve())
    env = {"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT),
           "HW4_DATA_DIR": str(mine)}
    run = ["run", "--task", "1", "--grid-size", "0.5", "--no-figures", "--force"]

    def go(out):
        return subprocess.run([sys.executable, "-m", "hw4", *run, "--out", str(out)],
                              capture_output=True, text=True, cwd=ROOT, env=env)

    r = go(tmp_path / "a")  # the first run writes the cache
    assert r.returncode == 0 and r.stderr == "", r.stderr
    (cache,) = (mine / ".cache").glob("*.npz")
    sound = cache.read_bytes()
    cache.write_bytes(sound[: len(sound) * 2 // 3])
    r = go(tmp_path / "b")
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr and len(r.stderr.splitlines()) == 1
    assert "data cache" in r.stderr and "rebuilding it" in r.stderr
    assert cache.read_bytes() == sound
    a, b = (np.load(tmp_path / d / "task1_grid0.5.npz") for d in "ab")
    for k in a.files:
        np.testing.assert_array_equal(a[k], b[k])

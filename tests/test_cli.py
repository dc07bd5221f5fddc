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



_DRAW = """
import inspect, sys
from hw4 import cli
if sys.argv[1] == "without docstrings":
    cli._import_figure_classes()
from hw4.core import plotting
from hw4.tasks import build_map
for task in (1, 3):
    ogm = build_map(task, 0.5)
    for what in ("mean", "variance"):
        plotting.save_map_png(ogm, f"{sys.argv[2]}/{task}_{what}.png", what, f"{ogm.name} {what}")
import matplotlib.artist as artist
from matplotlib import _docstring
from matplotlib.lines import Line2D
class Mine(artist.Artist):  # defined after the import: gets its generated set() as usual
    def set_colour_name(self, name):
        self.colour_name = name
line = Line2D([0, 1], [0, 1])
line.set(lw=3.5, color="r")  # aliases and properties work whatever the docstrings
print(line.get_linewidth(), line.get_color(), "colour_name" in inspect.signature(Mine.set).parameters,
      "linewidth" in inspect.signature(Line2D.set).parameters, artist.kwdoc(Line2D) != "",
      any(v == "" for k, v in _docstring.interpd.params.items() if k.endswith(":kwdoc")))
"""


def test_figure_code_imported_without_docstrings_draws_the_same_pngs(tmp_path):
    """The CLI imports matplotlib without its import-time docstrings: the same PNG bytes, set()
    and aliases working, matplotlib's hooks restored for what is defined afterwards."""
    out = {}
    for mode in ("as it is", "without docstrings"):
        folder = tmp_path / mode.replace(" ", "_")
        folder.mkdir()
        r = subprocess.run([sys.executable, "-c", _DRAW, mode, str(folder)], capture_output=True,
                           text=True, cwd=ROOT, env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin",
                                                     "PYTHONPATH": str(ROOT)})
        assert r.returncode == 0, r.stderr
        out[mode] = r.stdout.split(), _files(folder)
    (plain, as_is), (skipped, without) = out["as it is"], out["without docstrings"]
    assert sorted(as_is) == ["1_mean.png", "1_variance.png", "3_mean.png", "3_variance.png"]
    assert without == as_is  # byte for byte
    assert plain == ["3.5", "r", "True", "True", "True", "False"]
    # skipped at import: Line2D.set has the generic signature; all else as matplotlib has it
    assert skipped == ["3.5", "r", "True", "False", "True", "False"]


def _files(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_cli_imports_matplotlib_without_docstrings_only_when_it_is_not_loaded():
    code = ("import matplotlib.figure, inspect\nfrom matplotlib.lines import Line2D\n"
            "from hw4 import cli\ncli._plotting()\n"
            "print('linewidth' in inspect.signature(Line2D.set).parameters)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                       env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0 and r.stdout.split() == ["True"], r.stderr


def test_figure_import_leaves_the_garbage_collector_as_it_found_it():
    code = ("import gc, sys\nfrom hw4 import cli\nif sys.argv[1] == 'off':\n    gc.disable()\n"
            "cli._plotting()\nprint(gc.isenabled())")
    for state, want in (("on", "True"), ("off", "False")):
        r = subprocess.run([sys.executable, "-c", code, state], capture_output=True, text=True,
                           cwd=ROOT, env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin",
                                          "PYTHONPATH": str(ROOT)})
        assert r.returncode == 0 and r.stdout.split() == [want], r.stderr


def test_objects_are_frozen_only_in_a_process_of_its_own(tmp_path):
    """``python -m hw4`` freezes the long-lived objects out of the garbage collector's reach
    (hw4.cli.freeze_gc); main() called from Python leaves the collector as it was."""
    import gc
    from hw4.__main__ import main
    before = gc.get_freeze_count()
    assert main(["run", "--task", "1", "--grid-size", "0.5", "--out", str(tmp_path / "a")]) == 0
    assert gc.get_freeze_count() == before
    code = ("import gc, runpy, sys\nsys.argv = ['hw4'] + sys.argv[1:]\ntry:\n"
            "    runpy.run_module('hw4', run_name='__main__')\nexcept SystemExit as e:\n"
            "    assert not e.code, e.code\nprint(gc.get_freeze_count(), gc.isenabled())")
    r = subprocess.run([sys.executable, "-c", code, "run", "--task", "1", "--grid-size", "0.5",
                        "--out", str(tmp_path / "b")], capture_output=True, text=True, cwd=ROOT,
                       env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0, r.stderr
    frozen, enabled = r.stdout.split()[-2:]
    assert int(frozen) > 50_000 and enabled == "True"
    assert _files(tmp_path / "a") == _files(tmp_path / "b")  # the same files either way

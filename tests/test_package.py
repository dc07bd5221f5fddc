"""The submission packager: NAME_hw4.tgz runs on its own, next to the course's run.py.

The main test builds a package into a temporary folder, extracts it, and runs the five face
classes from the extracted folder in a fresh interpreter whose PYTHONPATH is clean and in which
``hw4`` is made unimportable; the maps they build on the real Intel data at grid 0.5 m must equal
the maps of the repository's package cell by cell.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tarfile
from pathlib import Path

import numpy as np
import pytest

from hw4 import package
from hw4.core.errors import InputError

from conftest import build_map, intel_raw

GRID = 0.5
MODELS = {  # module in the bundle -> (class name, conftest model, semantic data)
    "ogm_CSM": ("ogm_CSM", "CSM", False),
    "ogm_continuous_CSM": ("ogm_continuous_CSM", "continuous_CSM", False),
    "ogm_S_CSM": ("ogm_S_CSM", "S_CSM", True),
    "ogm_continuous_S_CSM": ("ogm_continuous_S_CSM", "continuous_S_CSM", True),
    "ogm_continous_S_CSM": ("ogm_continous_S_CSM", "continuous_S_CSM", True),
}

# Written into the extracted folder and run there, as the course's run.py would be.
DRIVER = """\
import sys
sys.modules["hw4"] = None  # nothing from the repository may be used
import numpy as np
from scipy.io import loadmat
{imports}
plain, semantic, out = sys.argv[1], sys.argv[2], sys.argv[3]
results = {{}}
for module, cls, is_semantic in {models!r}:
    raw = loadmat(semantic if is_semantic else plain)
    ogm = globals()[cls](grid_size={grid})
    ogm.construct_map(raw["robotPose"], raw["laserScan"])
    ogm.build_ogm()
    results[module + "/alpha"] = np.asarray(ogm.map["alpha"])
    results[module + "/mean"] = np.asarray(ogm.map["mean"])
    results[module + "/variance"] = np.asarray(ogm.map["variance"])
    if not is_semantic:
        results[module + "/beta"] = np.asarray(ogm.map["beta"])
    assert ogm.map["size"] == ogm.map["occMap"].data.shape[0]
np.savez(out, **results)
print("hw4 loaded:", "hw4" in sys.modules and sys.modules["hw4"] is not None)
"""


@pytest.fixture
def fake_pdf(tmp_path):
    pdf = tmp_path / "book.pdf"
    pdf.write_bytes(b"%PDF-1.5\n% stand-in for the book\n%%EOF\n")
    return pdf


def _extract(tgz: Path, dest: Path) -> list[str]:
    with tarfile.open(tgz) as tar:
        names = tar.getnames()
        for member in tar.getmembers():
            assert not member.name.startswith(("/", "..")) and ".." not in Path(member.name).parts
        tar.extractall(dest, filter="data")
    return names


def test_package_runs_without_the_repository(tmp_path, fake_pdf):
    out = tmp_path / "out"
    tgz, pdf = package.build_package("jdoe", pdf=fake_pdf, out=out)
    assert tgz == out / "jdoe_hw4.tgz" and pdf == out / "jdoe_hw4.pdf"
    assert pdf.read_bytes() == fake_pdf.read_bytes()

    names = _extract(tgz, tmp_path / "x")
    assert all(n == "jdoe_hw4" or n.startswith("jdoe_hw4/") for n in names)
    for video in package.VIDEOS:  # task 5: the mapping videos travel with the submission
        src = package.PROJECT_ROOT / video
        assert (tmp_path / "x" / "jdoe_hw4" / "videos" / src.name).read_bytes() == src.read_bytes()
    for face in ("ogm_CSM", "ogm_continuous_CSM", "ogm_S_CSM", "ogm_continuous_S_CSM",
                 "ogm_continous_S_CSM"):
        assert f"jdoe_hw4/{face}.py" in names
    assert not any("__pycache__" in n for n in names)
    folder = tmp_path / "x" / "jdoe_hw4"
    for path in folder.rglob("*.py"):
        text = path.read_text()
        assert "from hw4." not in text and "import hw4\n" not in text and "from hw4 " not in text, path
        assert "from ." not in text or "hw4core" in path.parts, path  # faces import absolutely

    from hw4.core.data import INTEL, INTEL_SEMANTIC, ensure
    models = [(m, c, s) for m, (c, _, s) in MODELS.items()]
    script = folder / "drive.py"
    script.write_text(DRIVER.format(
        imports="\n".join(f"from {m} import {c}" for m, (c, _, _) in MODELS.items()),
        models=models, grid=GRID))
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "MPLBACKEND": "Agg"}
    res = subprocess.run([sys.executable, str(script), str(ensure(INTEL)),
                          str(ensure(INTEL_SEMANTIC)), str(tmp_path / "maps.npz")],
                         cwd=folder, env=env, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert "hw4 loaded: False" in res.stdout

    got = np.load(tmp_path / "maps.npz")
    for module, (_, model, semantic) in MODELS.items():
        ref = build_map(model, *intel_raw(semantic), grid_size=GRID)
        keys = ("alpha", "mean", "variance") + (() if semantic else ("beta",))
        for key in keys:
            np.testing.assert_array_equal(got[f"{module}/{key}"], np.asarray(ref.map[key]),
                                          err_msg=f"{module} {key}")


@pytest.mark.parametrize("name", ["", "JDoe", "jdoe!", "toolongname", "j doe", "../x"])
def test_bad_uniqname(tmp_path, fake_pdf, name):
    with pytest.raises(InputError, match="uniqname"):
        package.build_package(name, pdf=fake_pdf, out=tmp_path)
    assert not list(tmp_path.glob("*.tgz"))


def test_never_overwrites_without_force(tmp_path, fake_pdf):
    tgz, _ = package.build_package("ab12", pdf=fake_pdf, out=tmp_path)
    before = tgz.read_bytes()
    with pytest.raises(InputError, match="--force"):
        package.build_package("ab12", pdf=fake_pdf, out=tmp_path)
    assert tgz.read_bytes() == before
    package.build_package("ab12", pdf=fake_pdf, out=tmp_path, force=True)


def test_missing_or_wrong_pdf(tmp_path, monkeypatch):
    with pytest.raises(InputError, match="does not exist"):
        package.build_package("jdoe", pdf=tmp_path / "nothing.pdf", out=tmp_path)
    not_pdf = tmp_path / "notes.txt"
    not_pdf.write_text("hello")
    with pytest.raises(InputError, match="not a PDF"):
        package.build_package("jdoe", pdf=not_pdf, out=tmp_path)
    monkeypatch.setattr(package, "PROJECT_ROOT", tmp_path)  # a checkout without a built book
    with pytest.raises(InputError, match="has not been built"):
        package.build_package("jdoe", out=tmp_path)
    assert not list(tmp_path.glob("*.tgz"))


def test_register_adds_the_subcommand(tmp_path, fake_pdf, capsys):
    parser = argparse.ArgumentParser(prog="hw4")
    package.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["package", "--uniqname", "jdoe", "--pdf", str(fake_pdf),
                              "--out", str(tmp_path)])
    assert args.func(args) == 0
    assert (tmp_path / "jdoe_hw4.tgz").is_file() and (tmp_path / "jdoe_hw4.pdf").is_file()
    assert "jdoe_hw4.tgz" in capsys.readouterr().out


def test_package_takes_the_videos_given(tmp_path, fake_pdf):
    clip = tmp_path / "my_run.mp4"
    clip.write_bytes(b"\x00\x00\x00\x18ftypmp42 not really a video")
    tgz, _ = package.build_package("jdoe", pdf=fake_pdf, out=tmp_path / "o", videos=[clip])
    names = _extract(tgz, tmp_path / "x")
    assert [n for n in names if "/videos/" in n] == ["jdoe_hw4/videos/my_run.mp4"]
    for bad, msg in ((tmp_path / "none.mp4", "is not a file"), (fake_pdf, "is not a video")):
        with pytest.raises(InputError, match=msg):
            package.build_package("jdoe", pdf=fake_pdf, out=tmp_path / "p", videos=[bad])
    assert not (tmp_path / "p" / "jdoe_hw4.tgz").exists()

"""``python -m hw4 similarity`` and the similarity columns of ``grade --batch``, on submissions
written for these tests (``tests/grading_fixtures``: our exact solution, its disguised copy, an
independent solution of ours, a skeleton standing in for the course template). No public
solution's code is used here. About 5 s.
"""
from __future__ import annotations

import csv
import shutil
from pathlib import Path

import pytest

from hw4.__main__ import main
from hw4.grading import similarity as sim

pytest.importorskip("copydetect")
FIX = Path(__file__).parent / "grading_fixtures"
SIM = FIX / "similarity"


def _set(tmp: Path, **subs) -> Path:
    d = tmp / "subs"
    d.mkdir()
    for name, src in subs.items():
        shutil.copytree(src, d / name, ignore=shutil.ignore_patterns("__pycache__"))
    return d


def _rows(out: Path) -> dict:
    with open(out / "similarity.csv", newline="") as f:
        return {r["student"]: r for r in csv.DictReader(f)}


def test_disguised_copy_flags_independent_solution_does_not(tmp_path):
    subs = _set(tmp_path, exact=FIX / "exact", disguised=SIM / "disguised",
                independent=SIM / "independent")
    for tpl in ([], ["--template", str(SIM / "template")]):
        out = tmp_path / f"out{len(tpl)}"
        assert main(["similarity", str(subs), "--out", str(out), *tpl]) == 0
        r = _rows(out)
        assert r["disguised"]["most_similar_submission"] == "exact"
        assert float(r["disguised"]["submission_score"]) >= sim.THRESHOLD + 0.3
        assert "not a verdict" in r["disguised"]["flag"] and r["exact"]["flag"]
        assert float(r["independent"]["submission_score"]) < sim.THRESHOLD - 0.3
        assert r["independent"]["flag"] == ""
        page = (out / "similarity.html").read_text()
        assert "never a verdict" in page and "disguised" in page and "exact" in page
        assert "hw4sim-" not in page  # the students' names, not the scratch copies' paths


def test_known_sources_and_template_discount(tmp_path):
    """A submission holding a known source's code flags against that file; two submissions
    sharing only the template's code flag without --template and not with it."""
    skeleton = (SIM / "template" / "ogm_template.py").read_text()
    a, b = tmp_path / "a", tmp_path / "b"
    for d, extra in ((a, "def build_a(self):\n    return sum(range(10))\n"),
                     (b, "def build_b(obj):\n    total = 1\n    for v in [1, 2]:\n"
                         "        total *= v\n    return total\n")):
        d.mkdir()
        (d / "ogm_CSM.py").write_text(skeleton + "\n\n" + extra)
    subs = _set(tmp_path, alice=a, bob=b, carol=SIM / "disguised")
    known = tmp_path / "known" / "public_repo"
    known.mkdir(parents=True)
    shutil.copyfile(FIX / "exact" / "mapping_core.py", known / "mapping_core.py")
    out = tmp_path / "o1"
    sim.similarity(subs, out, against=[known.parent])
    r = _rows(out)
    assert r["alice"]["most_similar_submission"] == "bob" and r["alice"]["flag"]
    assert r["carol"]["most_similar_known"] == "known/public_repo"  # a subfolder: one source
    assert float(r["carol"]["known_score"]) >= sim.THRESHOLD and "known source" in r["carol"]["flag"]
    out2 = tmp_path / "o2"
    sim.similarity(subs, out2, against=[known.parent], template=SIM / "template")
    r2 = _rows(out2)
    assert r2["alice"]["flag"] == "" and r2["bob"]["flag"] == ""
    assert float(r2["alice"]["submission_score"] or 0) < float(r["alice"]["submission_score"])
    assert r2["carol"]["flag"]


def test_hostile_code_is_shown_escaped(tmp_path):
    evil = tmp_path / "evil"
    shutil.copytree(FIX / "exact", evil, ignore=shutil.ignore_patterns("__pycache__"))
    core = evil / "mapping_core.py"
    core.write_text(core.read_text().replace('"""Shared loops', '"""<script>alert(1)</script> Shared loops'))
    subs = _set(tmp_path, evil=evil, exact=FIX / "exact")
    sim.similarity(subs, tmp_path / "o")
    page = (tmp_path / "o" / "similarity.html").read_text()
    assert "<script>alert(1)</script>" not in page and "&lt;script&gt;alert(1)" in page


@pytest.mark.parametrize("argv,msg", [
    (["similarity", "{tmp}/nope"], "is not a folder of submissions"),
    (["similarity", "{tmp}/subs", "--against", "{tmp}/nope"], "is not a folder"),
])
def test_bad_input_is_one_line(tmp_path, capsys, argv, msg):
    (tmp_path / "subs" / "x").mkdir(parents=True)
    (tmp_path / "subs" / "x" / "ogm_CSM.py").write_text("x = 1\n")
    rc = main([a.replace("{tmp}", str(tmp_path)) for a in argv])
    err = capsys.readouterr().err
    assert rc != 0 and msg in err and "Traceback" not in err and len(err.strip().splitlines()) == 1

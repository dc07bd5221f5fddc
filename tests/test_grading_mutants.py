"""Every diagnosis of the report against a mutant that has that bug
(``tests/grading_fixtures/mutants``): each single-bug mutant keeps at most half of its task,
and the report names its bug (and only it); exact submissions are told none. The sixteen
mutants run four to a submission, graded together at 2 m (324 cells): about 40 s.
"""
from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import pytest

from hw4.grading.batch import grade_batch

FIX = Path(__file__).parent / "grading_fixtures"
sys.path.insert(0, str(FIX / "mutants"))
import mutants  # noqa: E402

G = 2.0
PHRASES = [d for _, _, _, d in mutants.MUTANTS.values() if d]


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("mutants")
    subs = tmp / "subs"
    for name, names in mutants.SUBMISSIONS.items():
        shutil.copytree(FIX / "exact", subs / name, ignore=shutil.ignore_patterns("__pycache__"))
        mutants.write(subs / name, names)
    shutil.copytree(FIX / "exact", subs / "zz_exact", ignore=shutil.ignore_patterns("__pycache__"))
    grade_batch(subs, tmp / "out", jobs=2, grid_sizes=[G], similarity=False, figures=False)
    return {s.name: json.loads((tmp / "out" / s.name / "results.json").read_text())
            for s in subs.iterdir()}


def test_every_mutant_is_diagnosed_and_loses_half(graded):
    for sub, names in mutants.SUBMISSIONS.items():
        tests = {int(t["name"].split()[1]): t for t in graded[sub]["tests"]}
        for name in names:
            task, _, _, phrase = mutants.MUTANTS[name]
            t = tests[task]
            assert t["score"] <= 0.5 * t["max_score"] + 1e-9, (name, t["output"][:300])
            if phrase is None:
                assert t["output"].startswith("0 points:"), name
                continue
            said = [ln for ln in t["output"].splitlines() if ln.startswith("Most likely:")]
            assert len(said) == 1 and phrase in said[0], (name, t["output"][:600])
            others = [p for p in PHRASES if p != phrase and p in said[0]]
            assert not others, (name, others)


def test_exact_submission_gets_no_diagnosis(graded):
    for t in graded["zz_exact"]["tests"]:
        assert t["score"] == t["max_score"] and "Most likely" not in t["output"], t["output"]

"""Regrades (``grade --batch --previous OLD`` writes ``changes.csv``), identical results for the
same submission graded twice, and the similarity columns of ``grades.csv``. Submissions of one
task file at 1 m (2 m for the repeat) so that each run takes a few seconds (about 45 s in all
on this shared machine).
"""
from __future__ import annotations

import csv
import json
import shutil
import sys
from pathlib import Path

from hw4.__main__ import main
from hw4.grading.grade import TIMING_FIELDS, grade

FIX = Path(__file__).parent / "grading_fixtures"
sys.path.insert(0, str(FIX / "mutants"))
import mutants  # noqa: E402


def _one_task(dest: Path, mutant: str | None = None) -> Path:
    dest.mkdir(parents=True)
    shutil.copyfile(FIX / "exact" / "mapping_core.py", dest / "mapping_core.py")
    shutil.copyfile(FIX / "exact" / "ogm_CSM.py", dest / "ogm_CSM.py")
    if mutant:
        mutants.write(dest, [mutant])
    return dest


def _csv(path: Path) -> list:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_regrade_lists_changes_and_why(tmp_path, capsys):
    subs = tmp_path / "subs"
    _one_task(subs / "ann")
    _one_task(subs / "ben", "alpha/beta swapped")
    base = ["grade", str(subs), "--batch", "--grid-size", "1", "--jobs", "2"]
    assert main(base + ["--out", str(tmp_path / "v1")]) == 0
    rows = {r["student"]: r for r in _csv(tmp_path / "v1" / "grades.csv")}
    assert float(rows["ann"]["task1"]) == 20 and float(rows["ben"]["task1"]) == 10
    assert rows["ann"]["similar_to"] == "ben" and rows["ann"]["similarity"]
    assert (tmp_path / "v1" / "similarity.html").is_file()
    # an unchanged regrade: the header alone
    assert main(base + ["--out", str(tmp_path / "v2"), "--previous", str(tmp_path / "v1")]) == 0
    text = (tmp_path / "v2" / "changes.csv").read_text().splitlines()
    assert len(text) == 1 and text[0].startswith("student,task1_old,task1_new")
    # the means weigh 0.75: ben's swap (means wrong, variances right) drops, ann's does not
    cfg = tmp_path / "c.toml"
    cfg.write_text((FIX.parents[1] / "hw4" / "grading" / "config.toml").read_text()
                   .replace("mean_weight = 0.5 ", "mean_weight = 0.75"))
    assert main(base + ["--out", str(tmp_path / "v3"), "--previous", str(tmp_path / "v1"),
                        "--config", str(cfg)]) == 0
    ch = _csv(tmp_path / "v3" / "changes.csv")
    assert [r["student"] for r in ch] == ["ben"]
    assert float(ch[0]["task1_old"]) == 10 and float(ch[0]["task1_new"]) == 5
    assert "mean_weight 0.5 -> 0.75" in ch[0]["reason"]
    assert ch[0]["task1_reading_old"] == ch[0]["task1_reading_new"] == "Algorithm 1 as written"
    assert "1 student(s) with changed points" in capsys.readouterr().out
    assert main(base + ["--out", str(tmp_path / "v4"), "--previous", str(tmp_path / "nope")]) == 2


def test_same_submission_twice_gives_identical_results(tmp_path):
    sub = _one_task(tmp_path / "s", "labels off by one")
    shutil.copyfile(FIX / "exact" / "ogm_continuous_CSM.py", sub / "ogm_continuous_CSM.py")
    a = grade(sub, tmp_path / "a", grid_sizes=[2.0])
    b = grade(sub, tmp_path / "b", grid_sizes=[2.0])
    for r in (a, b):
        for k in TIMING_FIELDS:
            r.pop(k)
    assert a == b
    assert a["extra_data"]["readings"]["2"] == "free samples every 0.1 m (l/2)"
    assert a["extra_data"]["config"]["mean_weight"] == 0.5
    on_disk = json.loads((tmp_path / "a" / "results.json").read_text())
    assert {k: v for k, v in on_disk.items() if k not in TIMING_FIELDS} == a

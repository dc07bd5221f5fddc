"""Grade a folder of submissions in parallel: ``grades.csv`` and one report folder per student;
the similarity of the submissions (:mod:`hw4.grading.similarity`) as two columns of it; with
``previous``, ``changes.csv``: what a regrade changed, and why (:func:`changes`)."""
from __future__ import annotations

import csv
import multiprocessing as mp
import re
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from ..core.errors import InputError
from .archive import ARCHIVES

_slot = None


def _init(counter):
    global _slot
    with counter.get_lock():
        counter.value += 1
        _slot = counter.value  # one unprivileged user per worker: killing one's leftovers
        # never touches another's processes


def student_name(path: Path) -> str:
    name = path.name
    for ext in ARCHIVES:
        if name.lower().endswith(ext):
            name = name[: -len(ext)]
    name = re.sub(r"_hw4$", "", name)
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name) or "submission"


def _one(sub: Path, out: Path, kw: dict):
    from .grade import grade
    try:
        res = grade(sub, out, slot=_slot or 0, **kw)
    except InputError as e:
        return sub, None, str(e)
    return sub, res, None


def list_submissions(folder: Path) -> list[Path]:
    """The submissions in ``folder``: archives and folders, not hidden, by name."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder} is not a folder of submissions")
    subs = sorted(p for p in folder.iterdir()
                  if not p.name.startswith(".") and (p.is_dir() or p.name.lower().endswith(ARCHIVES)))
    if not subs:
        raise InputError(f"{folder} holds no submission (.tgz, .tar.gz, .zip or folder)")
    return subs


def student_names(subs: list) -> dict:
    """A distinct, file-name-safe student name for each submission (uniqname_hw4.tgz -> uniqname)."""
    names = {}
    for s in subs:
        n = student_name(s)
        k = 2
        while n in names.values():
            n = f"{student_name(s)}_{k}"
            k += 1
        names[s] = n
    return names


COLUMNS = ["student", "submission", "task1", "task2", "task3", "task4", "total", "seconds",
           "failure", "similar_to", "similarity"]


def grade_batch(folder: Path, out: Path, *, jobs: int = 1, previous: Path | None = None,
                similarity: bool = True, against=(), template: Path | None = None, **kw) -> int:
    """Grade every submission in ``folder`` into ``out/<student>/``; write ``out/grades.csv``
    (with the similarity columns unless ``similarity`` is False: ``against`` known-source
    folders, ``template`` the course skeleton) and, with ``previous`` (an earlier batch's
    folder), ``out/changes.csv``. ``kw`` goes to :func:`hw4.grading.grade.grade`."""
    subs = list_submissions(folder)
    out = Path(out)
    if previous is not None:
        previous = Path(previous)
        if not (previous / "grades.csv").is_file():
            raise InputError(f"{previous} holds no grades.csv of an earlier batch (--previous)")
        if previous.resolve() == out.resolve():
            raise InputError("--previous must be another folder than --out (the earlier grades "
                             "are kept)")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"cannot write to {out}: {e.strerror}")
    names, rows = student_names(subs), []
    from tqdm import tqdm
    counter = mp.get_context("fork").Value("i", 0)
    with ProcessPoolExecutor(max_workers=jobs, mp_context=mp.get_context("fork"),
                             initializer=_init, initargs=(counter,)) as ex:
        futs = [ex.submit(_one, s, out / names[s], kw) for s in subs]
        for f in tqdm(as_completed(futs), total=len(futs), desc="grading", unit="submission"):
            sub, res, err = f.result()
            row = {"student": names[sub], "submission": sub.name}
            if res is None:
                row.update(total=0, failure=err)
            else:
                row["total"] = res["score"]
                for t in res["tests"]:
                    key = t["name"].split(" (")[0].replace(" ", "").lower()
                    row[key] = row.get(key, 0) + t["score"]
                row["seconds"] = res["execution_time"]
                fails = [t["output"].split(":", 1)[1].split("\n")[0].strip()
                         for t in res["tests"] if t["output"].startswith("0 points:")]
                row["failure"] = "; ".join(dict.fromkeys(fails))
            rows.append(row)
    rows.sort(key=lambda r: r["student"])
    if similarity:
        _add_similarity(folder, out, rows, names, against, template)
    with open(out / "grades.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    print(f"graded {len(rows)} submission(s): {out / 'grades.csv'}")
    if previous is not None:
        n = changes(previous, out, names.values())
        print(f"{n} student(s) with changed points: {out / 'changes.csv'}")
    return 0


def _add_similarity(folder, out, rows, names, against, template) -> None:
    """similarity.csv / .html beside grades.csv; its highest score and flag as two columns."""
    from . import similarity as sim
    try:
        table = sim.similarity(folder, out, against=against, template=template, names=names)
    except InputError as e:  # copydetect missing: the grades are still written
        for r in rows:
            r["similarity"] = f"not run: {e}"
        return
    by = {t["student"]: t for t in table}
    for r in rows:
        t = by.get(r["student"], {})
        cands = [(t.get("submission_score"), t.get("most_similar_submission")),
                 (t.get("known_score"), t.get("most_similar_known"))]
        cands = [(float(s), n) for s, n in cands if s not in ("", None)]
        if cands:
            score, name = max(cands)
            r["similar_to"] = name
            r["similarity"] = f"{score:.2f}" + (" FLAG (for a TA to look at)" if t["flag"] else "")


def changes(previous: Path, new: Path, students) -> int:
    """Write ``new/changes.csv``: one row per student whose points changed between the batch in
    ``previous`` and the one in ``new`` (only the header when none did), with the old and new
    points per task and why: the configuration keys that differ and, per task, the reading
    (variant) matched before and now. Returns the number of rows."""
    import json
    old_rows = _read_grades(previous / "grades.csv")
    new_rows = _read_grades(new / "grades.csv")
    keys = ["task1", "task2", "task3", "task4", "total"]
    out_rows = []
    for st in sorted(set(old_rows) | set(new_rows)):
        o, n = old_rows.get(st, {}), new_rows.get(st, {})
        if all(_num(o.get(k)) == _num(n.get(k)) for k in keys):
            continue
        meta_o, meta_n = _grader_meta(previous / st), _grader_meta(new / st)
        cfg_o, cfg_n = meta_o.get("config", {}), meta_n.get("config", {})
        diff = sorted(k for k in set(cfg_o) | set(cfg_n) if cfg_o.get(k) != cfg_n.get(k))
        why = []
        if diff:
            why.append("configuration: " + ", ".join(
                f"{k} {json.dumps(cfg_o.get(k))} -> {json.dumps(cfg_n.get(k))}" for k in diff))
        if meta_o.get("grader") != meta_n.get("grader"):
            why.append(f"grader {meta_o.get('grader')} -> {meta_n.get('grader')}")
        row = {"student": st}
        for k in keys:
            row[f"{k}_old"], row[f"{k}_new"] = o.get(k, ""), n.get(k, "")
        for t in ("1", "2", "3", "4"):
            vo = meta_o.get("readings", {}).get(t, "")
            vn = meta_n.get("readings", {}).get(t, "")
            row[f"task{t}_reading_old"], row[f"task{t}_reading_new"] = vo, vn
            if vo != vn and _num(o.get(f"task{t}")) != _num(n.get(f"task{t}")):
                why.append(f"task {t} reading: {vo or 'none'} -> {vn or 'none'}")
        if not o:
            why.append("not in the earlier batch")
        elif not n:
            why.append("not in this batch")
        row["reason"] = "; ".join(why) or "the submission's maps changed (same configuration)"
        out_rows.append(row)
    cols = ["student"] + [f"{k}_{w}" for k in keys for w in ("old", "new")] + \
        [f"task{t}_reading_{w}" for t in "1234" for w in ("old", "new")] + ["reason"]
    with open(new / "changes.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols)
        w.writeheader()
        w.writerows(out_rows)
    return len(out_rows)


def _num(v):
    try:
        return round(float(v), 4)
    except (TypeError, ValueError):
        return v or None


def _read_grades(path: Path) -> dict:
    with open(path, newline="") as f:
        return {r["student"]: r for r in csv.DictReader(f)}


def _grader_meta(folder: Path) -> dict:
    """What a student's results.json says about how it was graded (config, readings)."""
    import json
    try:
        extra = json.loads((folder / "results.json").read_text())["extra_data"]
        return extra if isinstance(extra, dict) else {}
    except (OSError, ValueError, KeyError, TypeError):
        return {}

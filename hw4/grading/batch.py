"""Grade a folder of submissions in parallel: ``grades.csv`` and one report folder per student."""
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


def grade_batch(folder: Path, out: Path, *, jobs: int = 1, **kw) -> int:
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder} is not a folder of submissions")
    subs = sorted(p for p in folder.iterdir()
                  if not p.name.startswith(".") and (p.is_dir() or p.name.lower().endswith(ARCHIVES)))
    if not subs:
        raise InputError(f"{folder} holds no submission (.tgz, .tar.gz, .zip or folder)")
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"cannot write to {out}: {e.strerror}")
    names, rows = {}, []
    for s in subs:
        n = student_name(s)
        k = 2
        while n in names.values():
            n = f"{student_name(s)}_{k}"
            k += 1
        names[s] = n
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
    cols = ["student", "submission", "task1", "task2", "task3", "task4", "total", "seconds", "failure"]
    rows.sort(key=lambda r: r["student"])
    with open(out / "grades.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    print(f"graded {len(rows)} submission(s): {out / 'grades.csv'}")
    return 0

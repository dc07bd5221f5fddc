"""Similarity of submissions (``python -m hw4 similarity``): a prompt for a TA, never a grade.

The detector is copydetect (PyPI; winnowing over the tokens of each file, identifiers and
literals normalised, so renaming, comments and layout do not hide a copy; a side-by-side HTML
report of the matched fragments). Each submission's Python files (its four task files and any
helper module, by name) make one document; every pair of submissions is compared, and each
submission with every file of the known sources (``--against``: a folder the staff fill with
public solutions they found: each subfolder is one known solution, each loose .py file one
source). The course template's own code (``--template``) is boilerplate:
its fingerprints are removed from every document first, so the skeleton all students start
from never counts as shared.

A pair's score is the larger of its two shares (copydetect's: the share of one document's
fingerprints found in the other), so a copied public file flags inside a submission that holds
more. A submission is flagged when its highest score against another submission, or against a
known source, reaches ``threshold`` AND at least ``min_tokens`` tokens match (a short document
cannot flag by a few common lines). The threshold (0.5) and ``min_tokens`` (300) were measured
(README, "Grading"): independent solutions stay below, disguised copies above.

The submissions' code is only read (tokenised), never run or imported. The student's file
names come from the archive or folder; :mod:`hw4.grading.archive` extracts archives safely.
"""
from __future__ import annotations

import csv
import html
import os
import shutil
import tempfile
from pathlib import Path

from ..core.errors import InputError
from . import archive
from .batch import list_submissions, student_names

THRESHOLD = 0.5     # pair score at or above which a submission is flagged (measured)
MIN_TOKENS = 300    # and at least this many matched tokens
NOISE_T, GUARANTEE_T = 25, 30  # copydetect's k-gram length and guarantee (its defaults)
MAX_FILE_BYTES = 1_000_000
COLUMNS = ["student", "submission", "most_similar_submission", "submission_score",
           "most_similar_known", "known_score", "matched_tokens", "flag"]


def _detector():
    try:
        import copydetect
    except ImportError:
        raise InputError("similarity needs copydetect: pip install copydetect "
                         "(or pip install -e '.[dev]')")
    return copydetect


def _python_files(root: Path) -> list[Path]:
    """The .py files under ``root`` (no links followed, none larger than 1 MB), by path."""
    out = []
    for dirpath, dirs, files in os.walk(root, followlinks=False):
        dirs[:] = sorted(d for d in dirs if not d.startswith((".", "__")))
        for f in sorted(files):
            p = Path(dirpath) / f
            if f.endswith(".py") and not p.is_symlink() and p.is_file() \
                    and p.stat().st_size <= MAX_FILE_BYTES:
                out.append(p)
    return out


def _document(sub: Path, scratch: Path, notes: list) -> str:
    """The Python text of one submission (archive or folder): its files by name, each
    headed by its name."""
    if sub.is_file():
        raw = scratch / "raw"
        sandbox_remove(raw)
        try:
            notes += archive.extract(sub, raw)
        except InputError as e:
            notes.append(f"{sub.name}: {e}")
            return ""
        root = raw
    else:
        root = sub
    parts = []
    for p in _python_files(root):
        try:
            text = p.read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
        parts.append(f"# ---- {p.relative_to(root)}\n{text}\n")
    return "".join(parts)


def sandbox_remove(path: Path) -> None:
    from .sandbox import remove_tree
    remove_tree(path)


def similarity(submissions: Path, out: Path, *, against=(), template: Path | None = None,
               threshold: float = THRESHOLD, min_tokens: int = MIN_TOKENS,
               names: dict | None = None) -> list[dict]:
    """Compare every pair of ``submissions`` (a folder of archives / folders) and each with the
    files of the ``against`` folders; write ``out/similarity.csv`` and ``out/similarity.html``;
    return the csv's rows (one per submission)."""
    cd = _detector()
    subs = list_submissions(Path(submissions))
    names = names or student_names(subs)
    against = [Path(a) for a in against]
    for a in against + ([Path(template)] if template else []):
        if not a.is_dir():
            raise InputError(f"{a} is not a folder")
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"cannot write to {out}: {e.strerror}")
    for f in ("similarity.csv", "similarity.html"):
        if (out / f).is_symlink() or ((out / f).exists() and not (out / f).is_file()):
            raise InputError(f"{out / f} is not a plain file: refusing to replace it")
    work = Path(tempfile.mkdtemp(prefix="hw4sim-"))
    notes: list[str] = []
    try:
        sub_dir, known_dir, tpl_dir = work / "submissions", work / "known", work / "template"
        for d in (sub_dir, known_dir, tpl_dir):
            d.mkdir()
        docs = {}
        for s in subs:
            text = _document(s, work, notes)
            if text.strip():
                p = sub_dir / f"{names[s]}.py"
                p.write_text(text)
                docs[s] = p
        known = {}
        for k, a in enumerate(against):
            for entry in sorted(a.iterdir()):
                if entry.name.startswith(".") or entry.is_symlink():
                    continue
                if entry.is_dir():  # one known solution (a repository's files) = one document
                    text = _document(entry, work, notes)
                elif entry.suffix == ".py" and entry.stat().st_size <= MAX_FILE_BYTES:
                    text = entry.read_text(encoding="utf-8", errors="replace")
                else:
                    continue
                if not text.strip():
                    continue
                label = f"{a.name}/{entry.name}" if len(against) == 1 else \
                    f"{k + 1}:{a.name}/{entry.name}"
                dest = known_dir / f"k{len(known):04d}_{entry.stem}.py"
                dest.write_text(text)
                known[dest] = label
        if template:
            for i, f in enumerate(_python_files(Path(template))):
                shutil.copyfile(f, tpl_dir / f"t{i:04d}_{f.name}")
        test = sorted(docs.values())
        ref = test + sorted(known)
        rows = _compare(cd, test, ref, known, tpl_dir, out, threshold, min_tokens)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    by_doc = {r["_doc"]: r for r in rows}
    table = []
    for s in subs:
        r = by_doc.get(f"{names[s]}.py")
        row = {"student": names[s], "submission": s.name}
        if r is None:
            row.update(most_similar_submission="", submission_score="", most_similar_known="",
                       known_score="", matched_tokens="", flag="no Python files")
        else:
            row.update({k: v for k, v in r.items() if not k.startswith("_")})
        table.append(row)
    tmp = out / ".similarity.csv.partial"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(table)
    tmp.replace(out / "similarity.csv")
    return table


def _compare(cd, test, ref, known, tpl_dir, out, threshold, min_tokens) -> list[dict]:
    rows = []
    if not test:
        (out / "similarity.html").write_text("<p>No submission holds Python files.</p>\n")
        return rows
    bp = [str(tpl_dir)] if any(tpl_dir.iterdir()) else None
    det = cd.CopyDetector(boilerplate_dirs=bp, extensions=["py"], noise_t=NOISE_T,
                          guarantee_t=GUARANTEE_T, display_t=threshold, autoopen=False,
                          silent=True, force_language="python",
                          out_file=str(out / ".similarity.partial.html"))
    for p in test:
        det.add_file(str(p), type="test")
    for p in ref:
        det.add_file(str(p), type="ref")
    if len(ref) > 1:
        det.run()
    sim = det.similarity_matrix
    overlap = det.token_overlap_matrix
    for i, t in enumerate(det.test_files):
        best_s = best_k = (None, -1.0, 0)
        for j, r in enumerate(det.ref_files):
            if sim.size == 0 or sim[i, j, 0] < 0:
                continue
            score = float(max(sim[i, j]))
            cand = (r, score, int(overlap[i, j]))
            if Path(r) in known:
                if score > best_k[1]:
                    best_k = cand
            elif score > best_s[1]:
                best_s = cand
        flags = []
        for kind, (r, score, tok) in (("submission", best_s), ("known source", best_k)):
            if r is not None and score >= threshold and tok >= min_tokens:
                flags.append(f"similar to {kind} {_label(r, known)} ({score:.0%})")
        rows.append({
            "_doc": Path(t).name,
            "most_similar_submission": _label(best_s[0], known) if best_s[0] else "",
            "submission_score": round(best_s[1], 3) if best_s[0] else "",
            "most_similar_known": _label(best_k[0], known) if best_k[0] else "",
            "known_score": round(best_k[1], 3) if best_k[0] else "",
            "matched_tokens": max(best_s[2], best_k[2]),
            "flag": "; ".join(flags) + ("; for a TA to look at, not a verdict" if flags else ""),
        })
    if sim.size:
        _html_report(det, known, out, threshold)
    else:
        (out / "similarity.html").write_text("<p>One document only: nothing to compare.</p>\n")
    return rows


def _label(path, known) -> str:
    p = Path(path)
    return known.get(p, p.stem)


def _html_report(det, known, out, threshold) -> None:
    """copydetect's report (matched fragments side by side), file names shown as the
    students' and the known sources' names, with a note that a flag is not a verdict."""
    import warnings
    with warnings.catch_warnings():  # copydetect 0.5 reads its page template with a
        warnings.simplefilter("ignore", DeprecationWarning)  # deprecated importlib call
        import matplotlib
        if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg"):
            matplotlib.use("Agg")
        det.generate_html_report()
    partial = out / ".similarity.partial.html"
    text = partial.read_text(encoding="utf-8")
    for p in list(det.test_files) + list(det.ref_files):
        text = text.replace(html.escape(str(p)), html.escape(_label(p, known)))
        text = text.replace(str(p), html.escape(_label(p, known)))
    text = text.replace(str(Path(det.test_files[0]).parents[1]), "(scratch copy)")
    note = ("<div style='margin:1em;padding:1em;border:1px solid #999'><b>HW4 similarity.</b> "
            f"Pairs at or above {threshold:.0%} are listed (the course template's code "
            "removed first). A high score is a prompt for a TA to read both files side by "
            "side, never a verdict and never a deduction: independent solutions of one "
            "homework share much.</div>")
    text = text.replace("<body>", "<body>" + note, 1)
    partial.write_text(text, encoding="utf-8")
    partial.replace(out / "similarity.html")


def summary(rows) -> str:
    flagged = [r for r in rows if r["flag"] and r["flag"] != "no Python files"]
    return (f"{len(rows)} submission(s) compared, {len(flagged)} flagged for a TA to look at "
            "(a flag is not a verdict)")


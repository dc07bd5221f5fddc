"""The ``grade``, ``check``, ``similarity`` and ``autograder`` subcommands of ``python -m hw4``."""
from __future__ import annotations

import argparse
import os
import re
from pathlib import Path

from ..core.errors import InputError


def _positive(kind):
    def parse(text):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a positive number, not {text!r}")
        if not v > 0:
            raise argparse.ArgumentTypeError(f"expected a positive number, not {text!r}")
        return v
    return parse


def register(sub) -> None:
    g = sub.add_parser(
        "grade", help="grade a submission (archive or folder) into results.json and a report",
        description="Grade a homework submission (uniqname_hw4.tgz/.zip or a folder with the four "
                    "task files): each task runs sandboxed and is compared cell by cell with the "
                    "exact maps. Writes DIR/results.json (Gradescope format) and DIR/report.md. "
                    "With --batch, SUBMISSION is a folder of submissions: DIR/grades.csv and one "
                    "report folder per student.")
    g.add_argument("submission", type=Path, metavar="SUBMISSION")
    g.add_argument("--out", type=Path, default=Path("grading"), metavar="DIR",
                   help="output folder (default ./grading)")
    g.add_argument("--grid-size", type=_positive(float), action="append", metavar="G",
                   help="grid size to grade at [m] (repeatable; default from the configuration)")
    g.add_argument("--timeout", type=_positive(float), metavar="SECONDS",
                   help="wall-clock limit per task (default from the configuration)")
    g.add_argument("--memory", type=_positive(int), metavar="MB",
                   help="memory limit per task (default from the configuration)")
    g.add_argument("--config", type=Path, metavar="FILE", help="grading configuration (TOML)")
    g.add_argument("--batch", action="store_true", help="SUBMISSION is a folder of submissions")
    g.add_argument("--jobs", type=_positive(int), metavar="N",
                   help="batch: submissions graded at once (default: the number of cores)")
    g.add_argument("--previous", type=Path, metavar="OLD",
                   help="batch: an earlier batch's --out folder; writes DIR/changes.csv (the "
                        "students whose points changed, and why)")
    g.add_argument("--against", type=Path, action="append", default=[], metavar="KNOWN_DIR",
                   help="batch: known sources for the similarity columns (repeatable)")
    g.add_argument("--template", type=Path, metavar="DIR",
                   help="batch: the course template, discounted in the similarity")
    g.add_argument("--no-similarity", action="store_true",
                   help="batch: skip the similarity check")
    g.set_defaults(func=run_grade)

    s = sub.add_parser(
        "similarity", help="compare submissions with each other and with known sources",
        description="Compare every pair of submissions (archives or folders in SUBMISSIONS_DIR) "
                    "and each submission with every file of the known sources (copydetect: "
                    "winnowing over normalised tokens), the course template's code discounted. "
                    "Writes DIR/similarity.csv and DIR/similarity.html (matched fragments side "
                    "by side). A flag is a prompt for a TA to look, never a verdict.")
    s.add_argument("submissions", type=Path, metavar="SUBMISSIONS_DIR")
    s.add_argument("--against", type=Path, action="append", default=[], metavar="KNOWN_DIR",
                   help="a folder of known sources, e.g. public solutions (repeatable)")
    s.add_argument("--template", type=Path, metavar="DIR",
                   help="the course template every student starts from (its code is discounted)")
    s.add_argument("--out", type=Path, default=Path("similarity"), metavar="DIR",
                   help="output folder (default ./similarity)")
    s.set_defaults(func=run_similarity)

    c = sub.add_parser(
        "check", help="check your own four task files before submitting (visible tests)",
        description="Run the visible part of the grading on your own files (a folder with "
                    "ogm_CSM.py, ogm_continuous_CSM.py, ogm_S_CSM.py, ogm_continuous_S_CSM.py, "
                    "or an archive) and write the report to DIR/report.md.")
    c.add_argument("path", type=Path, metavar="PATH")
    c.add_argument("--out", type=Path, default=Path("check"), metavar="DIR",
                   help="report folder (default ./check)")
    c.add_argument("--timeout", type=_positive(float), metavar="SECONDS")
    c.set_defaults(func=run_check)

    a = sub.add_parser(
        "autograder", help="write the Gradescope autograder zip",
        description="Write the zip Gradescope takes (setup.sh, run_autograder, this package, the "
                    "data and the configuration) for its Ubuntu 22.04 image.")
    a.add_argument("--out", type=Path, default=Path("autograder.zip"), metavar="ZIP")
    a.add_argument("--config", type=Path, metavar="FILE", help="grading configuration (TOML)")
    a.set_defaults(func=run_autograder)


def _print_results(results: dict, out: Path) -> None:
    for t in results["tests"]:
        first = t["output"].splitlines()[0] if t["output"] else ""
        first = re.sub(r"\\([\\`*_\[\]<>|#!~&])", r"\1", first)  # the report's Markdown escapes
        print(f"{t['name']}: {t['score']:g} / {t['max_score']:g}  {first}")
    total = sum(t["max_score"] for t in results["tests"])
    print(f"score {results['score']:g} / {total:g}; report: {out / 'report.md'}")
    if results.get("extra_data", {}).get("grader_error"):
        import sys
        print("warning: the grader itself failed on some task (see the report): regrade after "
              "fixing the grading machine", file=sys.stderr)


def run_grade(args) -> int:
    if args.batch:
        from .batch import grade_batch
        return grade_batch(args.submission, args.out, config=args.config, grid_sizes=args.grid_size,
                           timeout=args.timeout, memory=args.memory,
                           jobs=args.jobs or os.cpu_count() or 1, previous=args.previous,
                           similarity=not args.no_similarity, against=args.against,
                           template=args.template)
    if args.previous or args.against or args.template or args.no_similarity:
        raise InputError("--previous, --against, --template and --no-similarity go with --batch")
    from .grade import grade
    results = grade(args.submission, args.out, config=args.config, grid_sizes=args.grid_size,
                    timeout=args.timeout, memory=args.memory)
    _print_results(results, args.out)
    return 0


def run_similarity(args) -> int:
    from .similarity import similarity, summary
    rows = similarity(args.submissions, args.out, against=args.against, template=args.template)
    for r in rows:
        if r["flag"]:
            print(f"{r['student']}: {r['flag']}")
    print(f"{summary(rows)}: {args.out / 'similarity.csv'}, {args.out / 'similarity.html'}")
    return 0


def run_check(args) -> int:
    from .grade import grade
    if not args.path.exists():
        raise InputError(f"{args.path} does not exist")
    results = grade(args.path, args.out, timeout=args.timeout, visible_only=True)
    _print_results(results, args.out)
    return 0


def run_autograder(args) -> int:
    from .autograder import build_zip
    path = build_zip(args.out, config=args.config)
    print(f"wrote {path}")
    return 0

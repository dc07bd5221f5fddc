"""Grading time: the exact core's reference maps vs a submission's template-style loops.

    python benchmarks/bench_grading.py [SUBMISSION ...] [--grid-size G]

For each grid size (default the configuration's, 0.5 m) it times, side by side, (a) what the
grader computes itself for all four tasks (the exact core's reference maps for every legitimate
variant, the end-point readings included) and (b) the full grading of each submission (default:
the loop submission ``tests/grading_fixtures/exact``, numpy over each pose's beams, and its twin
``template_speed`` that loops like the course template), and prints the ratio, the score and
whether the total fits Gradescope's 10 minutes. Then (c) the similarity check
(``python -m hw4 similarity``) over the test set of ``tests/grading_fixtures`` (exact,
disguised, independent) copied ``--copies`` times, as a class of that many submissions.
"""
from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from hw4.grading import reference
from hw4.grading.config import load
from hw4.grading.grade import grade

ROOT = Path(__file__).resolve().parents[1]
GRADESCOPE_LIMIT = 600.0  # s, Gradescope's default


def core_seconds(g: float) -> float:
    reference._cache.clear()
    t = time.perf_counter()
    for task in (1, 2, 3, 4):
        for _, opts in reference.variants(task, g):
            reference.evidence(task, g, **opts)
            if reference.model_class(task).continuous:
                for kind in reference.END_READINGS:
                    reference.evidence(task, g, sample_count=kind, **opts)
    return time.perf_counter() - t


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    fixtures = ROOT / "tests" / "grading_fixtures"
    p.add_argument("submissions", nargs="*", type=Path,
                   default=[fixtures / "exact", fixtures / "template_speed"])
    p.add_argument("--grid-size", type=float, action="append")
    p.add_argument("--copies", type=int, default=20, help="similarity: copies of the 3 fixtures")
    a = p.parse_args()
    sizes = a.grid_size or load()["grid_sizes"]
    for g in sizes:
        reference.evidence(1, g)  # data loaded once, outside the timings
        core = core_seconds(g)
        print(f"grid {g:g} m: exact core, all reference maps and variants of tasks 1-4: {core:.2f} s")
        for sub in a.submissions:
            with tempfile.TemporaryDirectory() as out:
                t = time.perf_counter()
                res = grade(sub, Path(out), grid_sizes=[g], figures=False)
                total = time.perf_counter() - t
                per = json.loads((Path(out) / "results.json").read_text())
            tasks = "  ".join(f"T{i + 1} {x['score']:g}/{x['max_score']:g}"
                              for i, x in enumerate(per["tests"]))
            print(f"  {sub.name}: graded in {total:.1f} s ({total / core:.0f}x the core; "
                  f"{'within' if total < GRADESCOPE_LIMIT else 'OVER'} Gradescope's "
                  f"{GRADESCOPE_LIMIT:.0f} s); score {res['score']:g}: {tasks}")
    similarity_seconds(fixtures, a.copies)


def similarity_seconds(fixtures: Path, copies: int) -> None:
    import shutil
    from hw4.grading.similarity import similarity
    srcs = [fixtures / "exact", fixtures / "similarity" / "disguised",
            fixtures / "similarity" / "independent"]
    with tempfile.TemporaryDirectory() as tmp:
        subs = Path(tmp) / "subs"
        for k in range(copies):
            for s in srcs:
                shutil.copytree(s, subs / f"{s.name}_{k}",
                                ignore=shutil.ignore_patterns("__pycache__"))
        t = time.perf_counter()
        similarity(subs, Path(tmp) / "out", template=fixtures / "similarity" / "template")
        n = 3 * copies
        print(f"similarity of {n} submissions ({n * (n - 1) // 2} pairs): "
              f"{time.perf_counter() - t:.1f} s")


if __name__ == "__main__":
    main()

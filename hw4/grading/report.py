"""The Markdown report a student and a TA read beside ``results.json``."""
from __future__ import annotations

from pathlib import Path

BUDGET = ("Maps are graded at {sizes} so that a solution as slow as the course template (about a "
          "minute per task at 0.5 m) finishes all four tasks within Gradescope's 10 minutes on one "
          "core; each task has {timeout:g} s and {memory} MB. A cell agrees when its mean "
          "(semantic: every class probability) and its variance match the exact reference within "
          "a relative tolerance of {rtol:g} (absolute {atol:g}); a cell without evidence in the "
          "reference is compared only where the submission departs from the prior there. "
          "{mw:.0%} of a task's points go to the means, the rest to the variances, each growing "
          "linearly from {lo:.0%} to {hi:.0%} of the compared cells agreeing. Legitimate readings "
          "of the handout (free-sample step 0.1 m, 2l/3 or the grid size, the closest sample "
          "only, a sample on the end point or not, the 2024 template's free evidence only for "
          "cells farther than l from the end point ({ec:.0%} of the points), any prior) each "
          "have their own reference: the best one counts. A diagnosis ('Most likely: ...') is "
          "given only for a task that loses points, and only when that bug, applied to the "
          "reference, explains most of the differing cells.")


def write_report(out: Path, results: dict, tests: list, notes: list, sizes: list, cfg: dict,
                 isolation: list = ()) -> Path:
    """Write ``out/report.md``; return its path. ``isolation``: what the sandbox could not do
    on the grading machine (for the TA)."""
    lines = ["# HW4 mapping: autograder report", "", results["output"], ""]
    lines.append(BUDGET.format(sizes=", ".join(f"{g:g} m" for g in sizes), timeout=cfg["timeout"],
                               memory=cfg["memory"], rtol=cfg["rtol"], atol=cfg["atol"],
                               lo=cfg["zero_credit_share"], hi=cfg["full_credit_share"],
                               mw=cfg["mean_weight"], ec=cfg.get("else_credit", 1.0)))
    if isolation:
        lines += ["", "Sandbox on this machine: " + "; ".join(isolation) + "."]
    lines += ["", "| test | points | time |", "|---|---|---|"]
    for t in tests:
        secs = t.get("_seconds")
        lines.append(f"| {t['name']} | {t['score']:g} / {t['max_score']:g} | "
                     f"{'' if secs is None else f'{secs:g} s'} |")
    for t in tests:
        lines += ["", f"## {t['name']}", "", t["output"]]
        if t.get("_figure"):
            lines += ["", f"![reference, submission and differing cells]({t['_figure']})"]
    path = Path(out) / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path

"""Time the held-out evaluation of all 12 model x resolution combinations (target: <= 60 s).

    .venv/bin/python benchmarks/bench_evaluate.py [--no-baseline] [--repeat N]

Builds each of the four homework models at 0.135, 0.27 and 0.5 m from the mapping scans (every
10th scan held out) and scores it on the held-out samples (ROC/AUC, coverage; accuracy and IoU
for the semantic maps), plus the log-odds baseline. Prints one line per map and the total time.
The data loading and the held-out samples are timed separately (done once per process).
"""
from __future__ import annotations

import argparse
import time

from hw4 import book
from hw4.evaluation import evaluate as ev
from hw4.tasks import load_task_data

TARGET_SECONDS = 60.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-baseline", action="store_true", help="skip the log-odds baseline")
    ap.add_argument("--repeat", type=int, default=1, help="repeat the evaluation N times")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    load_task_data(1), load_task_data(3)
    split = ev.intel_split()
    prep = time.perf_counter() - t0
    print(f"data + held-out samples: {prep:.2f} s "
          f"({split.samples.n_occupied:,} occupied, {split.samples.n_free:,} free samples "
          f"from {len(split.held_out)} held-out scans)")

    best = float("inf")
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        rows = ev.evaluate_all(baseline=not args.no_baseline, split=split)
        best = min(best, time.perf_counter() - t0)
    print(book.markdown_table(rows, columns=("model", "grid_size", "auc", "coverage", "accuracy",
                                           "miou", "build_seconds")))
    n12 = sum(r["task"] > 0 for r in rows)
    verdict = "OK" if best <= TARGET_SECONDS else "SLOWER THAN TARGET"
    print(f"\nevaluation of {n12} model x resolution maps"
          f"{'' if args.no_baseline else ' + 3 baseline maps'}: {best:.2f} s "
          f"(target <= {TARGET_SECONDS:.0f} s: {verdict})")
    return 0 if best <= TARGET_SECONDS else 1


if __name__ == "__main__":
    raise SystemExit(main())

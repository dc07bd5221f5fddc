"""Time the held-out evaluation of all 12 model x resolution combinations (target: <= 60 s).

    .venv/bin/python benchmarks/bench_evaluate.py [--no-baseline] [--repeat N] [--boot N]

Builds each of the four homework models at 0.135, 0.27 and 0.5 m from the mapping scans (every
10th scan held out) and scores it on the held-out samples (ROC/AUC, coverage; accuracy and IoU
for the semantic maps), plus the log-odds baseline. Prints one line per map and the total time.
The data loading and the held-out samples are timed separately (done once per process).

Then the bootstrap of Chapter 7 (:func:`hw4.evaluation.evaluate.bootstrap_scores`, the five maps
at 0.135 m, ``--boot`` draws, default 2,000) side by side with a per-sample reference that
re-scores every sample under each draw's scan weights (timed on 50 draws and scaled), and the
largest difference of their AUC replicates on those draws.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from hw4 import book
from hw4.evaluation import evaluate as ev
from hw4.tasks import load_task_data

TARGET_SECONDS = 60.0
REFERENCE_DRAWS = 50


def reference_auc_replicates(m, samples, weights_per_scan, scans):
    """AUC of map ``m`` under each row of scan weights, by weighting every sample (the slow way)."""
    cell, ok = ev.scored_cells(m, samples)
    s = ev.occupancy_score(m)[cell[ok]]
    pos = samples.occupied[ok]
    idx = np.searchsorted(scans, samples.scan[ok])
    order = np.argsort(-s, kind="stable")
    ss = s[order]
    start = np.flatnonzero(np.r_[True, ss[1:] != ss[:-1]])
    out = []
    for w_scan in weights_per_scan:
        w = w_scan[idx].astype(float)
        wp = np.add.reduceat((w * pos)[order], start)
        wn = np.add.reduceat((w * ~pos)[order], start)
        above = np.cumsum(wn) - wn
        out.append(1.0 - float(np.sum(wp * (above + wn / 2))) / (wp.sum() * wn.sum()))
    return np.array(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-baseline", action="store_true", help="skip the log-odds baseline")
    ap.add_argument("--repeat", type=int, default=1, help="repeat the evaluation N times")
    ap.add_argument("--boot", type=int, default=2000, help="bootstrap draws (default 2000)")
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

    maps: dict = {}
    for r in ev.evaluate_all(grid_sizes=(0.135,), split=split, keep_roc=False, maps=maps):
        pass
    fine = [maps[t, 0.135] for t in range(5)]
    t0 = time.perf_counter()
    boot = ev.bootstrap_scores(fine, split.samples, n_boot=args.boot, seed=0, common=False)
    fast = time.perf_counter() - t0
    scans = np.unique(split.samples.scan)
    w = boot["scan_weights"][:REFERENCE_DRAWS]
    t0 = time.perf_counter()
    ref = np.stack([reference_auc_replicates(m, split.samples, w, scans) for m in fine], axis=1)
    slow = (time.perf_counter() - t0) * args.boot / len(w)
    gap = float(np.max(np.abs(ref - boot["auc_replicates"][:len(w)])))
    print(f"\nbootstrap, 5 maps at 0.135 m, {args.boot} draws: per-scan sums {fast:.2f} s, "
          f"per-sample reference {slow:.1f} s (timed on {len(w)} draws, scaled): "
          f"{slow / fast:.0f}x; largest AUC replicate difference {gap:.1e}")
    return 0 if best <= TARGET_SECONDS and gap < 1e-12 else 1


if __name__ == "__main__":
    raise SystemExit(main())

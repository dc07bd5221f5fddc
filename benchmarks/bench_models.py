"""Speed and memory of the four counting sensor models on the full Intel map.

Prints, per model and grid size: the vectorised build time (best of --repeat runs), the time the
literal loop transcription in ``tests/literal.py`` would take for the whole map (timed on a
random sample of cells, scaled by the cell count), their ratio, and the peak resident memory
of a fresh process building the map. Everything is measured side by side in one run, so the
ratios hold on a noisy machine even when the absolute times drift.

    python benchmarks/bench_models.py [--repeat 3] [--sample 150] [--sizes 0.135 0.27 0.5]

Targets (issue 3, grid 0.135 m): discrete CSM <= 0.25 s, continuous CSM <= 1.0 s, semantic
versions <= 1.5x those; peak memory <= 1 GB; hundreds of times faster than the loops.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.io import loadmat

from hw4.core.data import INTEL, INTEL_SEMANTIC, ensure
from hw4.tasks import build_map, load_task_data, task_name

ROOT = Path(__file__).resolve().parent.parent
LITERAL_NAMES = {1: "CSM", 2: "continuous_CSM", 3: "S_CSM", 4: "continuous_S_CSM"}
TARGET = {1: 0.25, 2: 1.0, 3: 0.375, 4: 1.5}  # seconds at 0.135 m


def load_literal():
    spec = importlib.util.spec_from_file_location("literal", ROOT / "tests" / "literal.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def peak_memory_mb(task: int, grid_size: float) -> float:
    """Peak RSS [MB] of a fresh Python process that builds one map."""
    code = ("import resource, hw4.tasks as t; t.build_map(%d, %r); "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)" % (task, grid_size))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--sample", type=int, default=150, help="cells timed with the literal loops")
    ap.add_argument("--sizes", type=float, nargs="+", default=[0.135, 0.27, 0.5])
    ap.add_argument("--json", type=Path, help="also write the rows to this JSON file")
    args = ap.parse_args(argv)

    literal = load_literal()
    raw = {False: loadmat(ensure(INTEL)), True: loadmat(ensure(INTEL_SEMANTIC))}
    rng = np.random.default_rng(0)
    rows = []
    print(f"{'model':<18}{'grid':>7}{'cells':>9}{'vectorised':>12}{'loops (est.)':>14}"
          f"{'speed-up':>10}{'peak MB':>9}{'target':>9}")
    for task in (1, 2, 3, 4):
        data = load_task_data(task)
        for g in args.sizes:
            times = []
            for _ in range(args.repeat):
                ogm = build_map(task, g, data=data)
                times.append(ogm.build_seconds)
            best = min(times)
            n = ogm.map["size"]
            ids = rng.choice(n, size=min(args.sample, n), replace=False)
            r = raw[ogm.semantic]
            poses = literal.poses_from_struct(r["robotPose"])
            scans = literal.scans_from_cell(r["laserScan"])
            t0 = time.perf_counter()
            literal.literal_counts(LITERAL_NAMES[task], None, None, ids, grid_size=g,
                                   poses=poses, scans=scans)
            loops = (time.perf_counter() - t0) / len(ids) * n
            mem = peak_memory_mb(task, g)
            target = TARGET[task] if g == 0.135 else None
            ok = "" if target is None else ("ok" if best <= target else "MISSED")
            rows.append(dict(model=task_name(task), grid=g, cells=n, seconds=best,
                             loops_seconds=loops, speedup=loops / best, peak_mb=mem,
                             target=target))
            print(f"{task_name(task):<18}{g:>7.3f}{n:>9,}{best:>11.3f}s{loops:>13.1f}s"
                  f"{loops / best:>9.0f}x{mem:>9.0f}{ok:>9}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()

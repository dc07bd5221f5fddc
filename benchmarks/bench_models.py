"""Speed and memory of the four counting sensor models on the full Intel map.

Prints, per model and grid size, side by side in one run (so the ratios hold on a noisy machine
even when the absolute times drift):

* the compiled engine (the default) on one thread and on two, and the numpy reference engine,
  each ``construct_map + build_ogm`` with the data loaded (best of --repeat runs), and the
  CPU time of the one-thread runs (best; on a loaded machine the wall time includes the time
  other jobs held the cores; the targets are judged on the wall time);
* the work it evaluated: the (cell, pose) pairs inside the perceptual field and, for the
  continuous models, the free samples tested; pairs per second (pairs + samples over the time);
* the share of the floor it reaches: the floor model is ``FLOOR_NS`` per pair and per free
  sample (the top of the 5-10 ns range of issue 23), and the share is floor time / time;
* the literal loop transcription of ``tests/literal.py`` (timed on a random sample of cells,
  scaled by the cell count) and the speed-up over it; the peak resident memory of a fresh
  process building the map.

Then where the time of each model at 0.135 m goes (one thread, best of --repeat per part:
``construct_map``, the beam table, the nearest-pose query, the pair kernels, and the rest of
``build_ogm``: evidence set-up and posterior; ns per pair of the pair kernels); the two heavy
options at 0.135 m (``nearest_poses=None``; ``beams='all'``), same columns;
whether the default map is the same bit for bit on one and two threads; and the start-up: the
wall time of ``python -m hw4 run --task 1 --grid-size 0.5`` in a fresh process (best of 3, the
compiled kernels and the data cached), against its 1 s target (issue 23, part 5).

    python benchmarks/bench_models.py [--repeat 5] [--sample 150] [--sizes 0.135 0.27 0.5]
                                      [--no-loops] [--json rows.json]

Targets (issue 23, grid 0.135 m, one thread): CSM <= 55 ms, S-CSM <= 65 ms, continuous CSM <=
90 ms, continuous S-CSM <= 110 ms; nearest_poses=None <= 0.6 s; beams='all' <= 1.2 s; start-up
<= 1 s. Absolute times depend on the machine's load: the load average is printed with them.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.io import loadmat

from machine import describe

from hw4.core.data import INTEL, INTEL_SEMANTIC, ensure
from hw4.tasks import load_task_data, model_class, task_name

ROOT = Path(__file__).resolve().parent.parent
LITERAL_NAMES = {1: "CSM", 2: "continuous_CSM", 3: "S_CSM", 4: "continuous_S_CSM"}
TARGET = {1: 0.055, 2: 0.090, 3: 0.065, 4: 0.110}  # seconds at 0.135 m, one thread (issue 23)
HEAVY = ((1, dict(nearest_poses=None), 0.6), (2, dict(nearest_poses=None), 0.6),
         (2, dict(beams="all"), 1.2), (4, dict(beams="all"), 1.2))
FLOOR_NS = 10.0  # floor model: ns per (cell, pose) pair and per free sample
STARTUP = ["-m", "hw4", "run", "--task", "1", "--grid-size", "0.5"]
STARTUP_TARGET = 1.0  # [s] wall time of `python -m hw4 run --task 1 --grid-size 0.5`


def load_average() -> str:
    """The 1, 5 and 15 minute load averages (Linux), or '?'."""
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "?"


def startup_seconds(repeat: int = 3) -> float:
    """Best wall time [s] of ``python -m hw4 run --task 1 --grid-size 0.5`` (figures included)
    in a fresh process, writing into a temporary folder; one unmeasured run first fills the
    caches (compiled kernels, data arrays)."""
    import tempfile
    best = np.inf
    env = dict(os.environ, MPLBACKEND="Agg")
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeat + 1):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, *STARTUP, "--out", tmp, "--force"], check=True,
                           capture_output=True, env=env, cwd=ROOT)
            if i:
                best = min(best, time.perf_counter() - t0)
    return best


def timed(task, g, data, repeat, engine="auto", threads=1, **kw):
    """Best wall time [s] of construct_map + build_ogm, the work counted, and the map; the best
    CPU time of the process over the same runs is left in ``timed.cpu`` [s] (on one thread the
    wall time less the time other jobs held the cores)."""
    from hw4.core import evidence
    cls = model_class(task)
    scans = data.scans if cls.semantic else [s[:2] for s in data.scans]
    best, cpu, ogm = np.inf, np.inf, None
    os.environ.update(HW4_THREADS=str(threads), HW4_ENGINE=engine)
    try:
        for _ in range(repeat):
            ogm = cls(grid_size=g, **kw)
            t0, c0 = time.perf_counter(), time.process_time()
            ogm.construct_map(data.poses, scans)
            ogm.build_ogm()
            best = min(best, time.perf_counter() - t0)
            cpu = min(cpu, time.process_time() - c0)
    finally:
        os.environ.pop("HW4_THREADS", None)
        os.environ.pop("HW4_ENGINE", None)
    timed.cpu = cpu  # the CPU time of the same runs (best), for loaded machines
    return best, dict(evidence.last_stats), ogm


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


def phases(task, g, data, repeat) -> dict:
    """Where the time of one map goes [s of CPU time, steadier than wall time on a shared
    machine], one thread, compiled engine, best of ``repeat`` each: ``construct_map``, the beam table (``BeamTable.from_scans``), the nearest poses
    (``compiled.nearest_poses``), the pair kernels (``compiled.cell_evidence``), and the rest of
    ``construct_map + build_ogm`` (the whole, best of ``repeat``, less those parts)."""
    from hw4.core import compiled
    from hw4.core.sensor import BeamTable
    cls = model_class(task)
    scans = data.scans if cls.semantic else [s[:2] for s in data.scans]

    def best(f):
        b = np.inf
        for _ in range(repeat):
            t0 = time.process_time()
            f()
            b = min(b, time.process_time() - t0)
        return b

    os.environ.update(HW4_THREADS="1", HW4_ENGINE="compiled")
    try:
        ogm = cls(grid_size=g)
        ogm.construct_map(data.poses, scans)
        ogm.build_ogm()
        whole = best(lambda: (lambda m: (m.construct_map(data.poses, scans), m.build_ogm()))(
            cls(grid_size=g)))
        out = {"construct_map": best(lambda: cls(grid_size=g).construct_map(data.poses, scans))}
        table = BeamTable.from_scans(scans, compiled=True)
        out["beam table"] = best(lambda: BeamTable.from_scans(scans, compiled=True))
        grid, poses = ogm.grid, np.asarray(data.poses, dtype=float)
        out["nearest poses"] = best(lambda: compiled.nearest_poses(
            grid.cells, poses[:, :2], 16, spacing=grid.grid_size))
        nn = compiled.nearest_poses(grid.cells, poses[:, :2], 16, spacing=grid.grid_size)
        opts = ogm.evidence_options()
        cont = opts["model"] == "continuous"
        longest = np.zeros(len(poses))
        np.maximum.at(longest, table.pose_of, table.ranges)
        reach = longest + (opts["w_obstacle"] / 2 if not cont else ogm.l) + 1e-6
        cls_hit = (table.labels - 1 if cls.semantic else np.zeros(len(table.ranges), np.int64))
        kw = dict(continuous=cont, z_max=ogm.z_max, w_obstacle=opts["w_obstacle"],
                  w_beam=ogm.w_beam, sigma0=opts.get("sigma0", 0.1), l=opts.get("l", 0.2),
                  step=opts.get("sample_step", 0.1), grid=grid)
        out["pairs"] = best(lambda: compiled.cell_evidence(
            grid.cells, poses, nn, reach, table, cls_hit, ogm.n_columns, **kw))
    finally:
        os.environ.pop("HW4_THREADS", None)
        os.environ.pop("HW4_ENGINE", None)
    out["rest"] = max(0.0, whole - sum(out.values()))
    out["whole"] = whole
    return out


def _row(name, g, n, t1, t2, tn, stats, target, cpu=np.nan):
    work = stats.get("pairs", 0) + stats.get("samples", 0)
    floor = work * FLOOR_NS * 1e-9
    ok = "" if target is None else ("met" if t1 <= target else "missed")
    print(f"{name:<26}{g:>6.3f}{n:>8,}{t1 * 1e3:>9.1f}{cpu * 1e3:>9.1f}{t2 * 1e3:>9.1f}{tn * 1e3:>9.1f}"
          f"{tn / t1:>7.1f}x{stats.get('pairs', 0) / 1e6:>8.2f}M{stats.get('samples', 0) / 1e6:>8.2f}M"
          f"{work / t1 / 1e6:>9.1f}M{floor / t1:>8.0%}{'' if target is None else f'{target * 1e3:>8.0f}'}"
          f"{ok:>7}", end="")
    return dict(model=name, grid=g, cells=n, seconds=t1, cpu_seconds=cpu, seconds_2_threads=t2,
                numpy_seconds=tn,
                pairs=stats.get("pairs", 0), samples=stats.get("samples", 0),
                pairs_per_second=work / t1, floor_share=floor / t1, target=target)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--sample", type=int, default=150, help="cells timed with the literal loops")
    ap.add_argument("--sizes", type=float, nargs="+", default=[0.135, 0.27, 0.5])
    ap.add_argument("--no-loops", action="store_true", help="skip the literal loops and memory")
    ap.add_argument("--json", type=Path, help="also write the rows to this JSON file")
    args = ap.parse_args(argv)

    literal = load_literal()
    raw = {False: loadmat(ensure(INTEL)), True: loadmat(ensure(INTEL_SEMANTIC))}
    rng = np.random.default_rng(0)
    rows = []
    same_threads = []
    print(describe())
    print(f"load average {load_average()} ({os.cpu_count()} cores)")
    print(f"times in ms, best of {args.repeat}; pairs = (cell, pose) pairs in the field (beams='all':"
          f" (point, cell) pairs within l); floor = {FLOOR_NS:g} ns per pair and free sample")
    print(f"{'model':<26}{'grid':>6}{'cells':>8}{'1 thr':>9}{'1 CPU':>9}{'2 thr':>9}{'numpy':>9}{'gain':>8}"
          f"{'pairs':>9}{'samples':>9}{'pairs/s':>10}{'floor':>8}{'target':>8}{'':>7}"
          + ("" if args.no_loops else f"{'loops':>10}{'speed-up':>10}{'peak MB':>9}"))
    for task in (1, 2, 3, 4):
        data = load_task_data(task)
        timed(task, 0.5, data, 1)  # load the compiled kernels before timing
        for g in args.sizes:
            t1, stats, ogm = timed(task, g, data, args.repeat, "compiled", 1)
            cpu = timed.cpu
            t2, _, ogm2 = timed(task, g, data, args.repeat, "compiled", 2)
            same_threads.append(np.array_equal(ogm.counts, ogm2.counts))
            tn, _, _ = timed(task, g, data, max(1, args.repeat // 2), "numpy", 1)
            n = ogm.map["size"]
            row = _row(task_name(task), g, n, t1, t2, tn, stats,
                       TARGET[task] if g == 0.135 else None, cpu)
            if not args.no_loops:
                ids = rng.choice(n, size=min(args.sample, n), replace=False)
                r = raw[ogm.semantic]
                poses = literal.poses_from_struct(r["robotPose"])
                scans = literal.scans_from_cell(r["laserScan"])
                t0 = time.perf_counter()
                literal.literal_counts(LITERAL_NAMES[task], None, None, ids, grid_size=g,
                                       poses=poses, scans=scans)
                loops = (time.perf_counter() - t0) / len(ids) * n
                mem = peak_memory_mb(task, g)
                row.update(loops_seconds=loops, speedup=loops / t1, peak_mb=mem)
                print(f"{loops:>9.1f}s{loops / t1:>9.0f}x{mem:>9.0f}", end="")
            print()
            rows.append(row)
    parts = ("construct_map", "beam table", "nearest poses", "pairs", "rest")
    print(f"where the time goes at 0.135 m (one thread, CPU time, best of {args.repeat} per part; "
          "ms and share of the parts' sum; ns/pair: the pair kernels per (cell, pose) pair and "
          "free sample)")
    print(f"{'model':<26}" + "".join(f"{p:>20}" for p in parts) + f"{'whole':>9}{'ns/pair':>9}")
    for task in (1, 2, 3, 4):
        data = load_task_data(task)
        ph = phases(task, 0.135, data, args.repeat)
        total = sum(ph[p] for p in parts)
        st = next(r for r in rows if r["model"] == task_name(task) and r["grid"] == 0.135) \
            if 0.135 in args.sizes else None
        work = (st["pairs"] + st["samples"]) if st else 0
        print(f"{task_name(task):<26}" + "".join(
            f"{ph[p] * 1e3:>11.1f} ({ph[p] / total:>4.0%})" for p in parts)
            + f"{ph['whole'] * 1e3:>9.1f}"
            + (f"{ph['pairs'] / work * 1e9:>9.0f}" if work else f"{'':>9}"))
        rows.append(dict(model=task_name(task) + " phases", grid=0.135,
                         **{p: ph[p] for p in parts}, whole=ph["whole"]))
    print("heavy options at 0.135 m (one thread; 'all' beams run on one thread only)")
    for task, kw, target in HEAVY:
        data = load_task_data(task)
        name = task_name(task) + " " + ", ".join(f"{k}={v}" for k, v in kw.items())
        rep = max(1, args.repeat // 2)
        t1, stats, ogm = timed(task, 0.135, data, rep, "compiled", 1, **kw)
        cpu = timed.cpu
        if "beams" not in kw:
            t2, _, ogm2 = timed(task, 0.135, data, rep, "compiled", 2, **kw)
            same_threads.append(np.array_equal(ogm.counts, ogm2.counts))
        else:
            t2 = t1
        tn, _, _ = timed(task, 0.135, data, 1, "numpy", 1, **kw)
        rows.append(_row(name[:26], 0.135, ogm.map["size"], t1, t2, tn, stats, target, cpu))
        print()
    print(f"default maps the same bit for bit on 1 and 2 threads: "
          f"{'yes' if all(same_threads) else 'NO'} ({sum(same_threads)} of {len(same_threads)})")
    start = startup_seconds()
    ok = "met" if start <= STARTUP_TARGET else "missed"
    print(f"start-up, python {' '.join(STARTUP)} (fresh process, kernels and data cached, "
          f"best of 3): {start:.2f} s, target {STARTUP_TARGET:g} s: {ok}")
    rows.append(dict(model="start-up", seconds=start, target=STARTUP_TARGET))
    print(f"load average {load_average()}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()

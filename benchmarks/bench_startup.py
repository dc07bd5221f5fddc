"""Start-up of a small run, side by side with an earlier version (issue 23, part 5).

    python benchmarks/bench_startup.py [--against REV] [--repeat N]

Times ``python -m hw4 run --task 1 --grid-size 0.5`` (with its two figures, and with
``--no-figures``) in fresh processes, kernels and data cached, and prints the best and median
wall time of each. With ``--against REV`` it times, interleaved in the same run (old, new, new,
old, ...: both see the same load), a copy of today's ``hw4/`` in which the start-up files
(``--files``, default the CLI, its data and figure code) are those of git revision ``REV``, and
checks that both write the same files byte for byte. The load average is printed before and
after: on this shared 2-core machine absolute times are noisy, the ratio less so.
"""
from __future__ import annotations

import argparse
import hashlib
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUN = ["-m", "hw4", "run", "--task", "1", "--grid-size", "0.5"]
TARGET = 1.0  # [s] wall, with figures (issue 23, part 5)
START_UP_FILES = ["hw4/cli.py", "hw4/__main__.py", "hw4/__init__.py", "hw4/tasks.py",
                  "hw4/core/data.py", "hw4/core/plotting.py", "hw4/core/atomic.py",
                  "hw4/core/parser.py", "hw4/core/errors.py"]


def load_average() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def old_copy(rev: str, files: list[str], into: Path) -> Path:
    """A project folder holding today's hw4/ with ``files`` as they are at ``rev`` (data/ linked)."""
    shutil.copytree(ROOT / "hw4", into / "hw4", ignore=shutil.ignore_patterns("__pycache__"))
    for f in files:
        text = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:{f}"], check=True,
                              capture_output=True).stdout
        (into / f).write_bytes(text)
    (into / "data").symlink_to(ROOT / "data")
    return into


def run_once(project: Path, out: Path, extra: list[str]) -> tuple[float, float]:
    """(wall, CPU) time [s] of one fresh ``python -m hw4 run ...`` in ``project`` (its own hw4/);
    CPU = user + system time of the process and its children, less sensitive to the load."""
    env = dict(os.environ, MPLBACKEND="Agg", OMP_NUM_THREADS="1")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run([sys.executable, *RUN, "--out", str(out), "--force", *extra], cwd=project,
                       env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        sys.exit(f"{project}: run failed:\n{r.stderr}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def digests(folder: Path) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--against", metavar="REV", help="git revision to compare with (e.g. HEAD~3)")
    p.add_argument("--files", nargs="+", default=START_UP_FILES, metavar="PATH",
                   help="the files taken from REV (default: the start-up files)")
    p.add_argument("--repeat", type=int, default=8, help="runs of each version and mode")
    args = p.parse_args(argv)
    print(f"load average {load_average()} ({os.cpu_count()} cores)")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        versions = {"new": ROOT}
        if args.against:
            versions = {"old": old_copy(args.against, args.files, tmp / "old"), "new": ROOT}
        for mode, extra in (("figures", []), ("no figures", ["--no-figures"])):
            times = {v: [] for v in versions}
            cpu = {v: [] for v in versions}
            for v, project in versions.items():  # warm-up: .pyc files, page cache
                run_once(project, tmp / f"out-{v}", extra)
            order = list(versions)
            for i in range(args.repeat):
                for v in (order if i % 2 == 0 else order[::-1]):
                    wall, used = run_once(versions[v], tmp / f"out-{v}", extra)
                    times[v].append(wall)
                    cpu[v].append(used)
            if mode == "figures":
                best_with_figures = min(times["new"])
            same = ""
            if args.against:
                same = ("same files byte for byte" if digests(tmp / "out-old") ==
                        digests(tmp / "out-new") else "FILES DIFFER")
            line = []
            for v, ts in times.items():
                line.append(f"{v} best {min(ts):.2f} s, median {statistics.median(ts):.2f} s "
                            f"(CPU best {min(cpu[v]):.2f}, median {statistics.median(cpu[v]):.2f} s)")
            ratio = (f"; new/old best {min(times['new']) / min(times['old']):.2f}, median "
                     f"{statistics.median(times['new']) / statistics.median(times['old']):.2f}"
                     if args.against else "")
            print(f"{mode:>10}: " + "; ".join(line) + ratio + (f"; {same}" if same else ""))
            shutil.rmtree(tmp / "out-new", ignore_errors=True)
            shutil.rmtree(tmp / "out-old", ignore_errors=True)
    ok = "met" if best_with_figures <= TARGET else "missed"
    print(f"load average {load_average()}; target {TARGET:g} s with figures: {ok} "
          f"(new, best {best_with_figures:.2f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

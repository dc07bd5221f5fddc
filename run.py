"""The homework's entry point: ``python run.py --task_num N [--plot]`` builds task N's map.

Same command line as the course's run.py (``--task_num``; ``--plot`` also draws the mean and
variance figures), plus ``--grid_size``, ``--out`` and ``--force``; it runs ``python -m hw4 run``
and always writes the map as ``OUT/taskN_grid<G>.npz``.
"""
import argparse
import sys

from hw4.__main__ import main as hw4_main


def parse_args(argv=None):
    p = argparse.ArgumentParser(description="Run HW4 (mapping): build the map of one task.")
    p.add_argument("--task_num", type=int, default=1, choices=[1, 2, 3, 4],
                   help="which task are you running? (1-4; task 5 is `python -m hw4 bki`)")
    p.add_argument("--plot", action="store_true",
                   help="also write the mean and variance figures (as the course's run.py)")
    p.add_argument("--grid_size", type=float, default=0.135, help="cell size in metres")
    p.add_argument("--out", default="out", help="folder for the .npz map and the figures")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    return p.parse_args(argv)


def hw4_argv(a) -> list:
    """The ``python -m hw4`` arguments for the parsed run.py arguments."""
    argv = ["run", "--task", str(a.task_num), "--grid-size", repr(a.grid_size), "--out", a.out]
    return argv + (["--force"] if a.force else []) + ([] if a.plot else ["--no-figures"])


def main(argv=None) -> int:
    return hw4_main(hw4_argv(parse_args(argv)))


if __name__ == "__main__":
    sys.exit(main())

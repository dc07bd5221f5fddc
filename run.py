"""The homework's entry point: ``python run.py --task_num N`` builds and plots task N's map.

Same command line as the course's run.py (``--task_num``, ``--plot`` to switch plotting off),
plus ``--grid_size`` and ``--out``; it runs ``python -m hw4 run``.
"""
import argparse
import sys

from hw4.__main__ import main as hw4_main


def parse_args(argv=None):
    p = argparse.ArgumentParser(description="Run HW4 (mapping): build the map of one task.")
    p.add_argument("--task_num", type=int, default=1, choices=[1, 2, 3, 4],
                   help="which task are you running? (1-4; task 5 is `python -m hw4 bki`)")
    p.add_argument("--grid_size", type=float, default=0.135, help="cell size in metres")
    p.add_argument("--out", default="out", help="folder for the figures and the .npz map")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    return p.parse_args(argv)


if __name__ == "__main__":
    a = parse_args()
    argv = ["run", "--task", str(a.task_num), "--grid-size", str(a.grid_size), "--out", a.out]
    sys.exit(hw4_main(argv + (["--force"] if a.force else [])))

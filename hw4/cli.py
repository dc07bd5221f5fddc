"""The `run` and `data` subcommands of ``python -m hw4``."""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from .core.errors import InputError


def _grid_size(text: str) -> float:
    try:
        g = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"grid size must be a number of metres, not {text!r}")
    return g


def _nearest_poses(text: str):
    if text.lower() in ("all", "none"):
        return None
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--nearest-poses takes a positive integer or 'all', not {text!r}")
    return n


def register(sub) -> None:
    """Add the ``run`` and ``data`` subcommands to an argparse subparsers object."""
    p = sub.add_parser(
        "run", help="build the map of task 1-4 and write its figures and arrays",
        description="Build the map of homework task N on the Intel dataset and write "
                    "DIR/taskN_grid<G>_mean.png, DIR/taskN_grid<G>_variance.png and "
                    "DIR/taskN_grid<G>.npz (cell centres, evidence, mean, variance).")
    p.add_argument("--task", type=int, required=True, choices=[1, 2, 3, 4],
                   help="1 CSM, 2 continuous CSM, 3 semantic CSM, 4 continuous semantic CSM")
    p.add_argument("--grid-size", type=_grid_size, default=0.135, metavar="G",
                   help="cell size in metres (default 0.135)")
    p.add_argument("--out", type=Path, default=Path("out"), metavar="DIR",
                   help="output folder (default ./out)")
    p.add_argument("--nearest-poses", type=_nearest_poses, default=16, metavar="N|all",
                   help="poses per cell: N nearest (template: 16) or 'all' within range")
    p.add_argument("--beams", choices=["nearest", "all"], default="nearest",
                   help="continuous models: nearest beam (Algorithm 2) or all beams within l")
    p.add_argument("--sample-step", type=float, default=None, metavar="S",
                   help="continuous models: free-sample spacing along a beam [m] (default 0.1)")
    p.add_argument("--no-figures", action="store_true", help="write only the .npz map")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.set_defaults(func=run_task)

    d = sub.add_parser(
        "data", help="make the datasets present in data/ and verify their checksums",
        description="Find each dataset file in data/, else copy it from ../shared/data/, else "
                    "download it from its upstream URL; always verify its SHA-256.")
    d.add_argument("--only", default="", metavar="PREFIX",
                   help="only files whose path starts with PREFIX (e.g. intel/)")
    d.set_defaults(func=fetch_data)


def fetch_data(args) -> int:
    from .core.data import ensure_all
    paths = ensure_all(args.only)
    for p in paths:
        print(f"ok  {p}")
    print(f"{len(paths)} file(s) present and verified.")
    return 0


def _plotting():
    """The figure code, hw4.core.plotting, with matplotlib's Figure and Agg canvas (no pyplot)."""
    import matplotlib.figure  # noqa: F401  (most of matplotlib's import time: here, on the thread)
    from matplotlib.backends import backend_agg  # noqa: F401
    from .core import plotting
    return plotting


class _Background:
    """Run ``fn`` on a daemon thread; ``result()`` waits for it (and raises what it raised)."""

    def __init__(self, fn):
        import threading
        self._out = None
        self._error = None
        self._thread = threading.Thread(target=self._run, args=(fn,), daemon=True)
        self._thread.start()

    def _run(self, fn):
        try:
            self._out = fn()
        except BaseException as e:  # handed to the main thread by result()
            self._error = e

    def result(self):
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._out


def run_task(args) -> int:
    from .core.atomic import Outputs
    from .tasks import build_map, model_class, task_name

    kw = {"nearest_poses": args.nearest_poses, "progress": True}
    if model_class(args.task).continuous:
        kw["beams"] = args.beams
        if args.sample_step is not None:
            kw["sample_step"] = args.sample_step
    elif args.beams != "nearest" or args.sample_step is not None:
        raise InputError("--beams and --sample-step apply to the continuous tasks 2 and 4 only.")
    model_class(args.task)(grid_size=args.grid_size, **kw)  # every option checked before any work
    stem = f"task{args.task}_grid{args.grid_size:g}"
    names = [f"{stem}.npz"]
    if not getattr(args, "no_figures", False):
        names += [f"{stem}_mean.png", f"{stem}_variance.png"]
    with Outputs(args.out, names, force=args.force) as out:
        # matplotlib (a good part of a small run's time) is imported while the map is built
        figures = _Background(_plotting) if len(names) > 1 else None
        ogm = build_map(args.task, args.grid_size, **kw)
        arrays = dict(cells=ogm.grid.cells, x=ogm.grid.x, y=ogm.grid.y, grid_size=ogm.grid_size,
                      alpha=ogm.map["alpha"], mean=ogm.map["mean"], variance=ogm.map["variance"],
                      counts=ogm.counts, prior_alpha=ogm.prior_alpha)
        if not ogm.semantic:
            arrays["beta"] = ogm.map["beta"]
        np.savez_compressed(out[names[0]], **arrays)
        name = task_name(args.task)
        if figures is not None:
            plotting = figures.result()
            for target, what in ((names[1], "mean"), (names[2], "variance")):
                plotting.save_map_png(ogm, out[target], what,
                                      title=f"{name} {what}, grid {args.grid_size:g} m")
    print(f"{name}: {ogm.map['size']:,} cells, {ogm.observed.mean():.1%} observed, "
          f"built in {ogm.build_seconds:.2f} s")
    for t in out.written:
        print(f"wrote {t}")
    return 0

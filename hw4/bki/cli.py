"""``python -m hw4 bki``: map a labelled scan sequence and write the map, figures and video.

The lead's ``hw4/__main__.py`` calls :func:`register` on its subparsers; ``python -m hw4.bki``
runs the same command on its own.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ..core.atomic import Outputs
from ..core.errors import InputError
from ..core.parser import OneLineParser
from .config import DATASETS, check_map_memory, check_method, load_config
from .voxelmap import ENGINES, METHODS

AUTO_NUMPY_SCANS = 20
"""``--engine auto`` maps runs of at most this many scans with the numpy engine: for them, loading
numba and LLVM (about 2 s and 170 MB of memory) costs more than the compiled update saves (about
0.1 s per scan and pass on SemanticKITTI; the video maps every scan twice)."""


def choose_engine(engine: str, n_scans: int) -> str:
    """The engine that ``--engine`` names, ``auto`` resolved by the number of scans."""
    if engine == "auto":
        return "numpy" if n_scans <= AUTO_NUMPY_SCANS else "compiled"
    return engine

DESCRIPTION = """\
Build a 3D semantic voxel map from a sequence of labelled scans with semantic Bayesian kernel
inference (S-BKI, Gan et al. 2020) or the semantic counting sensor model (S-CSM), inserting the
scans one after another. Writes DIR/voxels.csv (every voxel with evidence: centre, state, class,
variance, class probabilities), DIR/voxels.ply (occupied voxels as a coloured point cloud for
CloudCompare or MeshLab), figures (3D render and top view, with and without var_thresh; for
SemanticKITTI seen from behind and above the car, with its path), DIR/map3d.html (an interactive 3D
view that works offline, with plotly.min.js beside it), with --video the map after each scan as
GIF and MP4, and with --mcap DIR/map.mcap (the map after each scan as ROS 2 MarkerArray messages,
for Foxglove or `ros2 bag play` into RViz 2)."""

EPILOG = """\
examples:
  python -m hw4 bki --dataset toy                       # the 12 toy scans, S-BKI
  python -m hw4 bki --dataset toy --method scsm --out out/toy_csm
  python -m hw4 bki --dataset semantickitti            # the 10 verified scans of sequence 04
  python -m hw4 bki --dataset semantickitti /data/kitti/dataset/sequences/04 --scans 100
PATH is a folder of PCD scans (toy) or a SemanticKITTI sequence folder with velodyne/, labels/
(or --config with labels = "predictions"), poses.txt and calib.txt. Without PATH the verified toy
scans (or the 10 scans of SemanticKITTI sequence 04) from data/ are used. A calib.txt without a
Tr line falls back on KITTI's published extrinsic for sequences 00-10; --calib FILE supplies
another (a file with a 'Tr: <12 numbers>' line)."""


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the ``bki`` options to a parser."""
    p.add_argument("path", nargs="?", metavar="PATH", default=None,
                   help="folder of labelled PCD scans (toy) or a SemanticKITTI sequence folder")
    p.add_argument("--dataset", choices=DATASETS, default="toy",
                   help="dataset layout and default settings (default: toy)")
    p.add_argument("--method", choices=METHODS, default="sbki",
                   help="sbki: sparse-kernel inference; scsm: counting sensor model (default: sbki)")
    p.add_argument("--scans", type=int, default=None, metavar="N",
                   help="insert the first N scans (default: the config's, 0 = all)")
    p.add_argument("--out", type=Path, default=None, metavar="DIR",
                   help="output folder (default: out/bki/<dataset>_<method>)")
    p.add_argument("--config", type=Path, default=None, metavar="TOML",
                   help="settings file instead of hw4/bki/configs/<dataset>.toml")
    p.add_argument("--calib", type=Path, default=None, metavar="FILE",
                   help="SemanticKITTI: use the 'Tr:' line of FILE (velodyne -> camera 0) instead "
                        "of the sequence's calib.txt")
    p.add_argument("--video", action="store_true",
                   help="also write the map after each scan as mapping.gif and mapping.mp4")
    p.add_argument("--mcap", action="store_true",
                   help="also write map.mcap: the map after each scan as ROS 2 MarkerArray messages "
                        "(/semantic_map, /trajectory) for Foxglove or RViz 2")
    p.add_argument("--no-figures", action="store_true",
                   help="write only voxels.csv and voxels.ply (no figures, no map3d.html)")
    p.add_argument("--engine", choices=("auto",) + ENGINES, default="auto",
                   help="compiled: numba (fastest per scan, but loading numba and LLVM costs about "
                        "2 s and 170 MB); numpy: the vectorised reference; the same map bit for bit. "
                        f"auto (default): numpy for at most {AUTO_NUMPY_SCANS} scans, else compiled")
    p.add_argument("--force", action="store_true", help="overwrite existing output files in DIR")


def register(subparsers) -> argparse.ArgumentParser:
    """Add the ``bki`` subcommand to an argparse subparsers object."""
    p = subparsers.add_parser("bki", help="3D semantic mapping (S-BKI / S-CSM) of labelled scans",
                              description=DESCRIPTION, epilog=EPILOG,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p)
    p.set_defaults(func=run_bki)
    return p


def run_bki(args) -> int:
    """Run the ``bki`` command; return the exit code (errors raise :class:`InputError`)."""
    import matplotlib
    matplotlib.use("Agg")

    from .pipeline import scan_source

    cfg = load_config(args.config, defaults=args.dataset) if args.config else load_config(args.dataset)
    check_method(cfg, args.method)
    n = cfg.scans if args.scans is None else args.scans
    if n < 0:
        raise InputError(f"--scans must be 0 (all) or a positive number; got {n}.")
    loaders = scan_source(args.dataset, args.path, cfg, calib=getattr(args, "calib", None))
    if loaders.note:
        print(f"note: {loaders.note}.", file=sys.stderr)
    if args.scans is not None and n > len(loaders):
        print(f"note: {n} scans asked for, {len(loaders)} exist: mapping all {len(loaders)}.",
              file=sys.stderr)
    if n:
        loaders = loaders[:n]
    out = args.out or Path("out") / "bki" / f"{args.dataset}_{args.method}"
    ours = ["voxels.csv", "voxels.ply", "mapping.gif", "mapping.mp4", "mapping_poster.jpg",
            "map.mcap", "map3d.html",
            "plotly.min.js"] + [
        f"map3d_{c}{s}.png" for c in ("class", "variance") for s in ("", "_no_var_thresh")] + [
        "topdown_class.png", "topdown_variance.png"]
    with Outputs(out, ours, force=getattr(args, "force", False)) as o:
        return _map_and_write(args, cfg, loaders, out, o)


def _voxels(vmap) -> int:
    """Voxels with evidence in a map so far."""
    n = getattr(vmap, "n_voxels", None)
    if n is None:
        n = int(np.count_nonzero(vmap.pool[:vmap.n_blocks, :, -1]))
    return int(n)


def _check_first_scan(loaders, cfg, method: str, engine: str) -> None:
    """Map the first scan with two classes to count its voxels; refuse a num_class that won't fit."""
    from .pipeline import map_scans
    if not len(loaders) or cfg.num_class <= 2:
        return
    two = cfg.with_(num_class=2)

    def load():
        s = loaders[0]()
        return type(s)(s.points, np.minimum(np.asarray(s.labels), 1), s.origin, s.name)
    step = next(iter(map_scans([load], two, method, engine=engine)))
    check_map_memory(cfg, _voxels(step.map), "the first scan")


def _map_and_write(args, cfg, loaders, out, o) -> int:
    """Map the scans and write every output through ``o`` (:class:`hw4.core.atomic.Outputs`)."""
    import matplotlib.pyplot as plt
    from tqdm import tqdm

    from . import render
    from .io import write_csv, write_ply
    from .pipeline import map_scans, new_map
    from .voxelmap import FREE, OCCUPIED, UNKNOWN

    from contextlib import nullcontext

    from .ros2_mcap import MapRecorder

    engine = choose_engine(getattr(args, "engine", "auto"), len(loaders))
    _check_first_scan(loaders, cfg, args.method, engine)
    vmap = new_map(cfg, args.method, engine)
    hits = free = 0
    origins = []
    recorder = MapRecorder(o["map.mcap"], atomic=False) if getattr(args, "mcap", False) else nullcontext()
    with recorder as rec:
        for step in tqdm(map_scans(loaders, cfg, args.method, vmap), total=len(loaders), unit="scan",
                         desc=f"{args.method} {args.dataset}", file=sys.stderr,
                         disable=not sys.stderr.isatty()):  # a bar on a terminal only, so that
            # a log or a caller reading stderr sees nothing but the one-line error, if any
            hits += step.training.n_hits
            free += step.training.n_free
            check_map_memory(cfg, _voxels(vmap), f"the first {step.index + 1} scan(s)")
            origins.append(step.scan.origin)
            if rec is not None:
                rec.add(step.map.view(), step.scan.origin)
    origins = np.array(origins)
    view = vmap.view()
    if len(view) == 0 and hits == 0:
        raise InputError(f"the {len(loaders)} scan(s) gave no training points within max_range "
                         f"{cfg.max_range} m (or no labelled hits): the map would be empty.")
    if len(view) == 0:
        raise InputError(f"the {hits:,} training hits and {free:,} free points reached no voxel "
                         f"centre within ell {cfg.ell} m: resolution {cfg.resolution} m is too "
                         "coarse for ell (use a resolution below 2 ell).")
    if not (np.all(np.isfinite(view.probs)) and np.all(np.isfinite(view.variance))):
        raise InputError("the map's class probabilities are not finite: lower sf2 or prior.")
    write_csv(view, o["voxels.csv"])
    write_ply(view, o["voxels.ply"])
    written = ["voxels.csv", "voxels.ply"]
    if getattr(args, "mcap", False):
        written.append("map.mcap")
    title = {"sbki": "S-BKI", "scsm": "S-CSM"}[args.method]
    # a street scene is seen from behind and above the car, with its path; the toy scene whole
    street = args.dataset == "semantickitti"
    cam = render.chase_camera(origins) if street else render.camera_for([view])
    path = origins if street else None
    if not args.no_figures and len(view):
        from .interactive import write_interactive
        for colour in ("class", "variance"):
            for which in ("occupied", "reference"):
                name = f"map3d_{colour}{'' if which == 'occupied' else '_no_var_thresh'}.png"
                fig = render.plot_maps({title: view}, cam, colour, which, vmax=cfg.var_thresh,
                                       trajectory=path, log_variance=street)
                fig.savefig(o[name], dpi=110, bbox_inches="tight")
                plt.close(fig)
                written.append(name)
            fig = render.plot_topdown({title: view}, cam, colour, vmax=cfg.var_thresh,
                                      trajectory=path, log_variance=street)
            fig.savefig(o[f"topdown_{colour}.png"], dpi=110)
            plt.close(fig)
            written.append(f"topdown_{colour}.png")
        info = write_interactive(view, o["map3d.html"], trajectory=origins,
                                 box=(cam.lo, cam.hi) if street else None, title=title,
                                 js_path=o["plotly.min.js"])
        written += ["map3d.html", "plotly.min.js"]
        if info["factor"] > 1:
            print(f"note: map3d.html shows {info['voxels']:,} cubes of {info['factor']} voxels per "
                  "edge (most frequent class), to keep the page light.", file=sys.stderr)
    st = view.state
    summary = (f"{len(loaders)} scans: {hits:,} training hits and {free:,} free points "
               f"(after {cfg.ds_resolution} m downsampling)\n"
               f"{title} map at {cfg.resolution} m: {len(view):,} voxels with evidence, "
               f"{int((st == OCCUPIED).sum()):,} occupied, {int((st == FREE).sum()):,} free, "
               f"{int((st == UNKNOWN).sum()):,} unknown (variance > {cfg.var_thresh}); "
               f"{int((view.state_reference == OCCUPIED).sum()):,} occupied without var_thresh")
    if args.video:  # a second pass, now that the final map fixes the camera of every frame
        del view, vmap, step, st  # the final map is written: free it before the second map grows
        render.release_memory()
        groups = ((step.map.view(),) for step in map_scans(loaders, cfg, args.method, engine=engine))
        render.mapping_video(groups, cam, (title,), o["mapping.gif"], o["mapping.mp4"],
                             width=5.0, trajectory=path, poster=o["mapping_poster.jpg"])
        written += ["mapping.gif", "mapping.mp4", "mapping_poster.jpg"]
    print(summary)
    print(f"wrote {', '.join(written)} to {out}")
    return 0


def main(argv=None) -> int:
    """Stand-alone entry point (``python -m hw4.bki``)."""
    parser = OneLineParser(prog="python -m hw4.bki", description=DESCRIPTION, epilog=EPILOG,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return run_bki(args)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2

"""The mapping loop: scans from a dataset -> training data -> incremental voxel-map updates.

:func:`scan_source` turns a dataset name and folder into a list of scan loaders (read lazily, so a
long SemanticKITTI sequence streams scan by scan); :func:`map_scans` inserts them one after another
and yields after each, so callers can draw the growing map or show progress.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from ..core.errors import InputError
from .config import BKIConfig
from .kitti import SemanticKITTISequence
from .pcd import read_labelled_scan
from .scan import Scan, validate_scan
from .training import TrainingData, training_data
from .voxelmap import VoxelMap


def _natural(p: Path):
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name)]


def toy_paths(folder=None) -> list[Path]:
    """The labelled PCD scans of a folder in natural order (``..._2.pcd`` before ``..._10.pcd``).

    Without ``folder``, the 12 toy scans made present and verified by :mod:`hw4.core.data`.
    """
    if folder is None:
        from ..core.data import ensure_all
        return sorted(ensure_all("bki_toy/"), key=_natural)
    folder = Path(folder)
    if folder.is_file():
        return [folder]
    if not folder.is_dir():
        raise InputError(f"{folder} is neither a PCD file nor a folder of PCD files.")
    paths = sorted(folder.glob("*.pcd"), key=_natural)
    if not paths:
        raise InputError(f"{folder} holds no .pcd files.")
    return paths


class Loaders(list):
    """A list of scan loaders; ``note`` says where the calibration came from ('' when not needed),
    ``trajectory`` is the (T, 3) sensor origins [m, world frame] when known without reading the
    scans (SemanticKITTI: from the poses; ``None`` for PCD scans)."""

    note: str = ""
    trajectory = None

    def __getitem__(self, i):
        got = super().__getitem__(i)
        if isinstance(i, slice):
            out = Loaders(got)
            out.note = self.note
            out.trajectory = None if self.trajectory is None else self.trajectory[i]
            return out
        return got


KITTI_04 = "semantickitti_04/sequences/04/"
"""The verified copy of SemanticKITTI sequence 04 (scans 0-9) in :mod:`hw4.core.data`."""


def kitti_04_folder() -> Path:
    """The sequence 04 folder in ``data/``, made present and verified first."""
    from ..core.data import DATA_DIR, ensure_all
    ensure_all(KITTI_04)
    return DATA_DIR / KITTI_04


def scan_source(dataset: str, path=None, cfg: BKIConfig | None = None,
                calib=None) -> Loaders:
    """Loaders of the scans of a dataset, in mapping order.

    Parameters
    ----------
    dataset : {"toy", "semantickitti"}
    path : str or Path, optional
        Folder of PCD scans (toy) or a SemanticKITTI sequence folder; by default the verified toy
        scans or the 10 verified scans of SemanticKITTI sequence 04 of :mod:`hw4.core.data`.
    cfg : BKIConfig, optional
        Supplies the SemanticKITTI label folder.
    calib : str or Path, optional
        SemanticKITTI only: a file whose ``Tr:`` line replaces the sequence's calibration.
    """
    if dataset == "toy":
        if calib is not None:
            raise InputError("--calib applies to SemanticKITTI sequences only (toy scans carry "
                             "their pose in VIEWPOINT).")
        return Loaders(lambda p=p: read_labelled_scan(p) for p in toy_paths(path))
    if dataset == "semantickitti":
        if path is None:
            path = kitti_04_folder()
        seq = SemanticKITTISequence(path, labels=(cfg.labels if cfg else "labels"), calib=calib)
        out = Loaders(lambda t=t: seq.scan(t) for t in range(len(seq)))
        out.note = seq.calib_note if "published" in seq.calib_note else ""
        rows = [int(b.stem) if (b.stem.isascii() and b.stem.isdigit()
                                and int(b.stem) < len(seq.origins)) else t
                for t, b in enumerate(seq.bins)]  # scan NNNNNN has the pose on line NNNNNN
        out.trajectory = np.asarray(seq.origins)[rows].copy()
        return out
    raise InputError(f"unknown dataset {dataset!r}; use toy or semantickitti.")


@dataclass
class Step:
    """What :func:`map_scans` yields after inserting one scan."""

    index: int
    scan: Scan
    training: TrainingData
    map: VoxelMap


def new_map(cfg: BKIConfig, method: str, engine: str = "compiled") -> VoxelMap:
    """An empty voxel map with the settings of ``cfg`` (``engine``: see :class:`VoxelMap`)."""
    return VoxelMap(cfg.resolution, cfg.num_class, method, cfg.sf2, cfg.ell, cfg.prior, cfg.var_thresh,
                    engine=engine)


def map_scans(loaders, cfg: BKIConfig, method: str = "sbki",
              vmap: VoxelMap | None = None, engine: str | None = None) -> Iterator[Step]:
    """Insert scans one after another; yield a :class:`Step` after each.

    Parameters
    ----------
    loaders : sequence of callables returning :class:`~hw4.bki.scan.Scan`
    cfg : BKIConfig
    method : {"sbki", "scsm"}
    vmap : VoxelMap, optional
        Map to extend (default: a new one).
    engine : {"compiled", "numpy"}, optional
        Engine of the training data and of a new map (default: the map's, else "compiled"); the
        same map bit for bit either way.
    """
    engine = engine or (vmap.engine if vmap is not None else "compiled")
    vmap = vmap if vmap is not None else new_map(cfg, method, engine)
    for i, load in enumerate(loaders):
        scan = validate_scan(load(), cfg.num_class)
        td = training_data(scan, cfg.ds_resolution, cfg.free_resolution, cfg.max_range, cfg.num_class,
                           engine=engine)
        vmap.update(td.points, td.labels)
        yield Step(i, scan, td, vmap)


def build_map(loaders, cfg: BKIConfig, method: str = "sbki",
              engine: str = "compiled") -> tuple[VoxelMap, int, int]:
    """Insert every scan; return the map and the total numbers of training hits and free points."""
    hits = free = 0
    vmap = new_map(cfg, method, engine)
    for step in map_scans(loaders, cfg, method, vmap):
        hits += step.training.n_hits
        free += step.training.n_free
    return vmap, hits, free

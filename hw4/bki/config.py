"""Per-dataset settings of the 3D semantic map, read from ``hw4/bki/configs/<dataset>.toml``."""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, fields, replace
from pathlib import Path

from ..errors import InputError

CONFIG_DIR = Path(__file__).resolve().parent / "configs"
DATASETS = ("toy", "semantickitti")


@dataclass(frozen=True)
class BKIConfig:
    """Settings of one run (see the TOML files for the meaning of each).

    Attributes
    ----------
    resolution, free_resolution, ds_resolution, max_range, ell : float [m]
    num_class : int (including free, class 0)
    sf2, prior, var_thresh : float
    scans : int (0 = all)
    labels : str (SemanticKITTI label folder)
    """

    resolution: float = 0.1
    num_class: int = 4
    free_resolution: float = 0.5
    ds_resolution: float = 0.1
    max_range: float = 8.0
    sf2: float = 10.0
    ell: float = 0.3
    prior: float = 0.001
    var_thresh: float = 0.09
    scans: int = 0
    labels: str = "labels"

    def with_(self, **kw) -> "BKIConfig":
        """A copy with some settings changed."""
        return replace(self, **kw)


def load_config(dataset_or_path: str | Path) -> BKIConfig:
    """Read a config: a dataset name (``toy``, ``semantickitti``) or a path to a TOML file.

    The TOML tables (``[map]``, ``[training]``, ...) only group the keys; every key must be a
    field of :class:`BKIConfig`.
    """
    path = Path(dataset_or_path)
    if str(dataset_or_path) in DATASETS:
        path = CONFIG_DIR / f"{dataset_or_path}.toml"
    try:
        raw = tomllib.loads(path.read_text())
    except OSError as e:
        raise InputError(f"cannot read the config {path} ({e.strerror}).") from None
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"the config {path} is not valid TOML ({e}).") from None
    flat = {}
    for k, v in raw.items():
        flat.update(v if isinstance(v, dict) else {k: v})
    known = {f.name: f.type for f in fields(BKIConfig)}
    unknown = sorted(set(flat) - set(known))
    if unknown:
        raise InputError(f"the config {path} has unknown setting {unknown[0]!r}; known: {', '.join(known)}.")
    for name, value in flat.items():
        want = {"float": float, "int": int, "str": str}[known[name]]  # annotations are strings
        if want is str:
            ok = isinstance(value, str) and value != ""
        elif want is int:
            ok = isinstance(value, int) and not isinstance(value, bool)
        else:
            ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        if not ok:
            kind = {int: "an integer", float: "a finite number", str: "a non-empty string"}[want]
            raise InputError(f"{name} in {path} must be {kind}; got {value!r}.")
    cfg = BKIConfig(**flat)
    for name in ("resolution", "free_resolution", "ds_resolution", "ell", "sf2", "prior",
                 "var_thresh"):
        if not getattr(cfg, name) > 0:
            raise InputError(f"{name} in {path} must be positive; got {getattr(cfg, name)}.")
    if cfg.num_class < 2:
        raise InputError(f"num_class in {path} must be at least 2 (free and one class); got {cfg.num_class}.")
    if cfg.scans < 0:
        raise InputError(f"scans in {path} must be 0 (all) or a positive number; got {cfg.scans}.")
    return cfg

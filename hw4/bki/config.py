"""Per-dataset settings of the 3D semantic map, read from ``hw4/bki/configs/<dataset>.toml``."""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, fields, replace
from pathlib import Path

from ..core.errors import InputError

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


MIN_LENGTH = 1e-4     # smallest resolution, ds_resolution, ell [m] (0.1 mm)
MAX_SCALE = 1e50      # largest sf2 and prior: beyond, the Dirichlet sums overflow
MIN_PRIOR = 1e-100    # smallest prior
MAX_CLASSES = 1 << 16  # SemanticKITTI label ids are 16-bit


def _read(path: Path) -> dict:
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as e:
        raise InputError(f"cannot read the config {path} ({e.strerror}).") from None
    except UnicodeDecodeError:
        raise InputError(f"the config {path} is not a UTF-8 text file.") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"the config {path} is not valid TOML ({str(e).splitlines()[0]}).") from None


def _flatten(raw: dict, path: Path) -> dict:
    """The settings of a config file, tables merged; a key given twice is refused."""
    flat: dict = {}
    where: dict = {}
    for k, v in raw.items():
        items = v.items() if isinstance(v, dict) else [(k, v)]
        for key, value in items:
            table = f"[{k}]" if isinstance(v, dict) else "the top level"
            if isinstance(value, dict):
                raise InputError(f"the config {path} nests a table [{k}.{key}]; use one level of "
                                 "tables ([map], [training], ...).")
            if key in flat:
                raise InputError(f"the config {path} sets {key} twice ({where[key]} and {table}); "
                                 "keep one.")
            flat[key], where[key] = value, table
    return flat


def load_config(dataset_or_path: str | Path, defaults: str | None = None) -> BKIConfig:
    """Read a config: a dataset name (``toy``, ``semantickitti``) or a path to a TOML file.

    The TOML tables (``[map]``, ``[training]``, ...) only group the keys; every key must be a
    field of :class:`BKIConfig` and appear once. Keys a file leaves out take the values of the
    dataset ``defaults`` (its ``configs/<dataset>.toml``) when given, else the toy values.
    """
    path = Path(dataset_or_path)
    if str(dataset_or_path) in DATASETS:
        path = CONFIG_DIR / f"{dataset_or_path}.toml"
    if defaults is not None and defaults not in DATASETS:
        raise InputError(f"unknown dataset {defaults!r}; use one of {', '.join(DATASETS)}.")
    if path.is_dir():
        raise InputError(f"the config {path} is a folder, not a TOML file.")
    flat = _flatten(_read(path), path)
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
        if want is float:
            flat[name] = float(value)  # TOML integers are 64-bit: always finite as floats
    base = BKIConfig()
    if defaults is not None and path != CONFIG_DIR / f"{defaults}.toml":
        base = load_config(defaults)
    cfg = replace(base, **flat)
    check_config(cfg, str(path))
    return cfg


def check_config(cfg: BKIConfig, where: str = "the config") -> None:
    """Refuse settings that are out of range or would overflow (one sentence naming the setting)."""
    for name in ("resolution", "free_resolution", "ds_resolution", "ell", "sf2", "prior",
                 "var_thresh"):
        v = getattr(cfg, name)
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                and v > 0):
            raise InputError(f"{name} in {where} must be positive; got {v}.")
    for name in ("resolution", "ds_resolution", "ell"):  # free_resolution: see free_samples
        if getattr(cfg, name) < MIN_LENGTH:
            raise InputError(f"{name} in {where} is {getattr(cfg, name)} m, below {MIN_LENGTH:g} m "
                             "(0.1 mm): check the units (metres).")
    if cfg.sf2 > MAX_SCALE or not MIN_PRIOR <= cfg.prior <= MAX_SCALE:
        name = "sf2" if cfg.sf2 > MAX_SCALE else "prior"
        raise InputError(f"{name} in {where} is {getattr(cfg, name)}: sf2 must be at most "
                         f"{MAX_SCALE:g} and prior between {MIN_PRIOR:g} and {MAX_SCALE:g}, or the "
                         "class probabilities overflow.")
    if not (isinstance(cfg.max_range, (int, float)) and math.isfinite(cfg.max_range)):
        raise InputError(f"max_range in {where} must be a finite number; got {cfg.max_range}.")
    if cfg.num_class < 2:
        raise InputError(f"num_class in {where} must be at least 2 (free and one class); got {cfg.num_class}.")
    if cfg.num_class > MAX_CLASSES:
        raise InputError(f"num_class in {where} is {cfg.num_class}, more than the {MAX_CLASSES} "
                         "label ids a scan can carry.")
    if cfg.scans < 0:
        raise InputError(f"scans in {where} must be 0 (all) or a positive number; got {cfg.scans}.")


MAX_NEIGHBOURHOOD = 1 << 20  # most voxels one training point may reach (S-BKI kernel support)


def check_method(cfg: BKIConfig, method: str) -> None:
    """Refuse up front when one S-BKI training point would reach too many voxels (with the number).

    A point reaches the voxels within ``R = floor(ell / resolution + 0.5)`` per axis, ``(2 R + 1)^3``
    of them; the map's scratch arrays hold that many entries per point.
    """
    if method != "sbki":
        return
    side = 2 * math.floor(cfg.ell / cfg.resolution + 0.5) + 1
    if side ** 3 > MAX_NEIGHBOURHOOD:
        raise InputError(f"with ell {cfg.ell} m and resolution {cfg.resolution} m each training point "
                         f"would reach {side ** 3:.3g} voxels ({side}^3), more than the limit of "
                         f"{MAX_NEIGHBOURHOOD:,}: use a coarser resolution or a smaller ell.")


MAX_MAP_BYTES = 4 * 2**30  # refuse maps whose evidence arrays would need more than this
BYTES_PER_VOXEL_CLASS = 48  # peak memory per voxel and class [bytes]: measured 348 MB for the
                            # toy map (126k voxels) with num_class 50, about 40 B above the interpreter


def check_map_memory(cfg: BKIConfig, voxels: int, scans: str = "one scan") -> None:
    """Refuse when ``voxels`` voxels of ``cfg.num_class`` classes would exceed :data:`MAX_MAP_BYTES`.

    The caller measures ``voxels`` (e.g. the voxels the first scan reaches, mapped with two
    classes); the message gives the estimate in GiB.
    """
    need = float(voxels) * (cfg.num_class + 1) * BYTES_PER_VOXEL_CLASS
    if need > MAX_MAP_BYTES:
        raise InputError(f"num_class {cfg.num_class} with the {voxels:,} voxels of {scans} would need "
                         f"about {need / 2**30:.3g} GiB for the map's evidence, more than the "
                         f"{MAX_MAP_BYTES / 2**30:.0f} GiB limit: use fewer classes or a coarser "
                         "resolution.")

"""Datasets: make them present and verified, and load the Intel ``.mat`` files.

The registry is ``data/manifest.tsv`` (path relative to ``data/``, SHA-256, upstream URL).
:func:`ensure` makes one file present in ``data/`` by, in order:

1. using the copy already in ``data/`` (verified);
2. copying it from ``../shared/data/`` beside the project root (verified);
3. downloading it from its upstream URL (verified).

A checksum mismatch never overwrites a file the user has: the bad download is kept
aside as ``<name>.partial`` and an :class:`~hw4.core.errors.InputError` says what to do.

:func:`load_intel` returns plain arrays (poses and scans) and validates the structure. The arrays
of a verified Intel file are kept in ``data/.cache/`` (keyed by its SHA-256) so that later
processes skip ``scipy.io`` (a quarter of a second to import) and the parsing. A cache file
carries the source's SHA-256 and one of its own arrays, checked on every load (about 2 ms); a
cache file that is cut short, unreadable or does not match is rebuilt from the verified source.
"""
from __future__ import annotations

import errno
import hashlib
import os
import shutil
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError

PROJECT_ROOT = Path(__file__).resolve().parents[2]
DATA_DIR = Path(os.environ.get("HW4_DATA_DIR") or PROJECT_ROOT / "data")
SHARED_DIR = Path(os.environ.get("HW4_SHARED_DATA") or PROJECT_ROOT.parent / "shared" / "data")


_WRITE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EACCES, errno.EPERM)


def _check_environment() -> None:
    """Refuse ``HW4_DATA_DIR`` / ``HW4_SHARED_DATA`` set to an empty string (it would mean ``.``)."""
    for var in ("HW4_DATA_DIR", "HW4_SHARED_DATA"):
        if var in os.environ and not os.environ[var].strip():
            raise InputError(f"{var} is set but empty: unset it (to use the default folder) or set "
                             "it to a folder.")
MANIFEST = PROJECT_ROOT / "data" / "manifest.tsv"

INTEL = "intel/sample_Intel_dataset.mat"
INTEL_SEMANTIC = "intel/sample_Intel_dataset_semantic.mat"
N_LABELS = 6  # Intel semantic labels 1..6
MAX_COORD = 1e9  # largest |pose| or |beam end point| coordinate accepted [m] (rad for headings)


def manifest() -> dict[str, tuple[str, str]]:
    """Return ``{relative path: (sha256, url)}`` from ``data/manifest.tsv`` (url '-' = none)."""
    rows = {}
    for line in MANIFEST.read_text().splitlines()[1:]:
        if line.strip():
            path, sha, url = line.split("\t")
            rows[path] = (sha, url)
    return rows


def sha256(path: Path) -> str:
    """SHA-256 hex digest of a file."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def ensure(name: str, data_dir: Path | None = None, shared_dir: Path | None = None,
           download: bool = True) -> Path:
    """Make the manifest file ``name`` present and verified in ``data_dir``; return its path.

    Parameters
    ----------
    name : str
        Path relative to ``data/`` as listed in the manifest, e.g. ``"intel/sample_Intel_dataset.mat"``.
    data_dir, shared_dir : Path, optional
        Override ``data/`` and ``../shared/data/`` (tests use temporary folders).
    download : bool
        Allow the last resort, the download from the upstream URL.
    """
    _check_environment()
    data_dir = Path(data_dir or DATA_DIR)
    shared_dir = Path(shared_dir or SHARED_DIR)
    rows = manifest()
    if name not in rows:
        raise InputError(f"{name} is not a dataset file listed in data/manifest.tsv.")
    want, url = rows[name]
    target = data_dir / name
    if target.is_dir():
        raise InputError(f"{target} is a folder, not the dataset file: move it away and run "
                         "`python -m hw4 data` again.")
    if target.exists():
        if sha256(target) != want:
            raise InputError(
                f"{target} does not match its SHA-256 in data/manifest.tsv (corrupt or a different "
                f"file): move it away and run `python -m hw4 data` to fetch a verified copy.")
        return target
    for parent in reversed(target.relative_to(data_dir).parents):
        folder = data_dir / parent
        if folder.exists() and not folder.is_dir():
            raise InputError(f"{folder} is a file, but {name} must go inside a folder of that name: "
                             "move the file away.")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"cannot create the data folder {target.parent} ({e.strerror}): set "
                         "HW4_DATA_DIR to a writable folder.") from None
    source = shared_dir / name
    partial = target.with_name(target.name + ".partial")
    try:
        if source.is_file():
            shutil.copyfile(source, partial)
            origin = str(source)
        elif download and url != "-":
            import urllib.request  # only for a download (http.client is slow to import)
            try:
                with urllib.request.urlopen(url, timeout=60) as r, open(partial, "wb") as f:
                    shutil.copyfileobj(r, f)
            except OSError as e:
                if e.errno in _WRITE_ERRNOS:
                    raise
                partial.unlink(missing_ok=True)
                raise InputError(f"{name} is missing from {data_dir} and {shared_dir}, and its "
                                 f"download from {url} failed ({e}): copy the file there by "
                                 "hand.") from None
            origin = url
        else:
            raise InputError(f"{name} is missing from {data_dir} and {shared_dir} and has no "
                             f"upstream URL to download from: copy the file into {data_dir / name}.")
    except OSError as e:
        partial.unlink(missing_ok=True)
        raise InputError(f"cannot write {partial} ({e.strerror or e}): free some space or set "
                         "HW4_DATA_DIR to a writable folder.") from None
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    if sha256(partial) != want:
        raise InputError(f"{name} copied from {origin} does not match its SHA-256 in "
                         f"data/manifest.tsv (kept as {partial} for inspection): get a clean copy.")
    partial.replace(target)
    return target


def ensure_all(prefix: str = "", **kw) -> list[Path]:
    """Ensure every manifest file whose path starts with ``prefix``; return their paths.

    A prefix that matches no file is refused (it would otherwise check nothing).
    """
    names = [n for n in manifest() if n.startswith(prefix)]
    if not names:
        folders = sorted({n.split("/")[0] + "/" for n in manifest()})
        raise InputError(f"no dataset file in data/manifest.tsv starts with {prefix!r}; the "
                         f"datasets are {', '.join(folders)} (paths are case-sensitive).")
    return [ensure(n, **kw) for n in names]


@dataclass
class IntelData:
    """The Intel Research Lab sample as plain arrays.

    Attributes
    ----------
    poses : (T, 3) float array [m, m, rad]
        Robot poses (x, y, heading) in the world frame.
    scans : list of T arrays, each (2, N) or (3, N)
        Beam end points (x; y) in the robot frame [m]; a third row holds the semantic label 1..6.
    """
    poses: np.ndarray
    scans: list

    @property
    def semantic(self) -> bool:
        return self.scans[0].shape[0] == 3


def _loadmat(path: Path) -> dict:
    from scipy.io import loadmat
    try:
        return loadmat(str(path))
    except (ValueError, TypeError, OSError, EOFError, zipfile.BadZipFile, IndexError, KeyError) as e:
        raise InputError(f"{path} is not a readable MATLAB .mat file ({type(e).__name__}: "
                         f"{str(e).splitlines()[0] if str(e) else 'truncated'}): "
                         f"re-fetch it with `python -m hw4 data`.") from None
    except Exception as e:  # scipy raises assorted errors on truncated files
        raise InputError(f"{path} is a corrupt or truncated .mat file ({type(e).__name__}): "
                         f"re-fetch it with `python -m hw4 data`.") from None


def real_array(a, what: str) -> np.ndarray:
    """``a`` as a float array; :class:`InputError` when it holds complex values or no numbers."""
    try:
        arr = np.asarray(a)
    except (ValueError, TypeError):
        raise InputError(f"{what} is not an array of numbers.") from None
    if arr.dtype.kind == "c":
        raise InputError(f"{what} holds complex numbers; it must be real (metres and radians).")
    if arr.dtype.kind not in "biuf":
        raise InputError(f"{what} must hold numbers; got an array of {arr.dtype}.")
    return arr.astype(float)


def poses_from_struct(pose) -> np.ndarray:
    """Convert the ``robotPose`` struct as ``scipy.io.loadmat`` returns it into a (T, 3) array.

    Raises :class:`InputError` when the fields ``x``, ``y``, ``h`` are missing, disagree in
    length or are not real numbers.
    """
    try:
        raw = [np.asarray(pose[k][0][0]) for k in ("x", "y", "h")]
    except (KeyError, IndexError, ValueError, TypeError):
        raise InputError("robotPose must be the MATLAB struct with fields x, y, h "
                         "(as scipy.io.loadmat returns it).") from None
    cols = [real_array(c, f"robotPose.{k}").reshape(-1) for c, k in zip(raw, "xyh")]
    if not (len(cols[0]) == len(cols[1]) == len(cols[2])):
        raise InputError("robotPose fields x, y, h have different lengths "
                         f"({len(cols[0])}, {len(cols[1])}, {len(cols[2])}).")
    return np.column_stack(cols)


def scans_from_cell(scan) -> list:
    """Convert the ``laserScan`` cell array as ``scipy.io.loadmat`` returns it into a list of arrays."""
    try:
        arr = np.asarray(scan, dtype=object).reshape(-1)
    except (ValueError, TypeError):
        raise InputError("laserScan must be the MATLAB cell array of 2xN (or 3xN) arrays "
                         "(as scipy.io.loadmat returns it).") from None
    out = []
    for t, s in enumerate(arr):
        a = np.asarray(s) if not isinstance(s, np.ndarray) else s
        while a.dtype == object and a.size == 1:  # a cell inside the cell
            a = np.asarray(a.reshape(-1)[0])
        if a.ndim == 3 and a.shape[0] == 1:
            a = a[0]
        out.append(real_array(a, f"laserScan scan {t}"))
    return out


def _scans_ok(scans: list, semantic: bool | None) -> bool:
    """True when every scan passes every check of :func:`validate` (all scans at once: a few
    array operations instead of a dozen per scan, 1-2 ms for the Intel data instead of 15-35);
    False when any check fails, and then :func:`validate` finds the first problem scan by scan."""
    rows = 3 if semantic else None
    for s in scans:
        if not (isinstance(s, np.ndarray) and s.dtype.kind == "f" and s.ndim == 2
                and s.shape[0] in (2, 3) and s.shape[1] > 0) or (rows and s.shape[0] != rows):
            return False
    if all(s.shape[0] == scans[0].shape[0] for s in scans):
        every = np.concatenate(scans, axis=1)
        if not np.isfinite(every).all() or np.abs(every[:2]).max() > MAX_COORD:
            return False
        lab = every[2] if semantic else None
    else:  # mixed 2xN and 3xN (labels ignored)
        xy = np.concatenate([s[:2] for s in scans], axis=1)
        if not all(np.isfinite(s[2:]).all() for s in scans if s.shape[0] == 3):
            return False
        if not np.isfinite(xy).all() or np.abs(xy).max() > MAX_COORD:
            return False
        lab = None
    if lab is not None and np.any((lab < 1) | (lab > N_LABELS) | (lab != np.round(lab))):
        return False
    return True


def validate(poses: np.ndarray, scans: list, semantic: bool | None = None) -> None:
    """Check poses and scans; raise :class:`InputError` with one sentence on the first problem.

    Parameters
    ----------
    poses : (T, 3) array [m, m, rad], world frame
    scans : list of T arrays (2, N) or (3, N) [m], robot frame (row 3: label 1..6)
    semantic : bool, optional
        When True every scan must have the label row; when False it is ignored.
    """
    poses = real_array(poses, "poses")
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise InputError(f"poses must be a (T, 3) array of x, y, heading; got shape {poses.shape}.")
    if len(poses) == 0:
        raise InputError("there are no robot poses.")
    if not np.all(np.isfinite(poses)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(poses), axis=1))[0])
        raise InputError(f"robot pose {bad} contains NaN or inf.")
    if np.abs(poses).max() > MAX_COORD:
        bad = int(np.flatnonzero(np.abs(poses).max(axis=1) > MAX_COORD)[0])
        raise InputError(f"robot pose {bad} lies beyond {MAX_COORD:g} m (or turns beyond "
                         f"{MAX_COORD:g} rad): check the units.")
    if len(scans) != len(poses):
        raise InputError(f"there are {len(poses)} poses but {len(scans)} scans; "
                         "each pose needs exactly one scan.")
    if _scans_ok(scans, semantic):
        return
    for t, s in enumerate(scans):  # something is wrong: find the first problem, scan by scan
        s = real_array(s, f"scan {t}")
        if s.ndim != 2 or s.shape[0] not in (2, 3):
            raise InputError(f"scan {t} must be a 2xN (or 3xN with labels) array; got shape {s.shape}.")
        if s.shape[1] == 0:
            raise InputError(f"scan {t} is empty (no beam end points).")
        if not np.all(np.isfinite(s)):
            raise InputError(f"scan {t} contains NaN or inf.")
        if np.abs(s[:2]).max() > MAX_COORD:
            raise InputError(f"scan {t} has a beam end point beyond {MAX_COORD:g} m: check the units.")
        if semantic:
            if s.shape[0] != 3:
                raise InputError(f"scan {t} has no label row (2xN): a semantic model needs the "
                                 "3xN scans of sample_Intel_dataset_semantic.mat.")
            lab = s[2]
            if np.any((lab < 1) | (lab > N_LABELS) | (lab != np.round(lab))):
                bad = lab[(lab < 1) | (lab > N_LABELS) | (lab != np.round(lab))][0]
                raise InputError(f"scan {t} has label {bad:g}; labels must be integers 1..{N_LABELS}.")


CACHE = ".cache"  # folder in data/ holding the loaded arrays of each verified .mat file
CACHE_VERSION = 2  # layout of a cache file (v1 had no checksum of its own)
_CACHE_KEYS = {"poses", "scans", "counts", "source", "digest"}


def _cache_file(name: str, sha: str) -> Path:
    """``data/.cache/<stem>-<sha256[:16]>-v2.npz``: the arrays of the verified file ``name``."""
    return DATA_DIR / CACHE / f"{Path(name).stem}-{sha[:16]}-v{CACHE_VERSION}.npz"


def _cache_digest(source: str, poses: np.ndarray, flat: np.ndarray, counts: np.ndarray) -> str:
    """SHA-256 (hex) of a cache file's content: the source file's SHA-256, then each array's
    shape, dtype and bytes in C order (about 2 ms for the Intel data)."""
    h = hashlib.sha256(f"hw4 intel cache v{CACHE_VERSION} {source}".encode())
    for a in (poses, flat, counts):
        h.update(f" {a.shape} {a.dtype.str} ".encode())
        h.update(np.ascontiguousarray(a).data)
    return h.hexdigest()


def _cache_problem(path: Path, source: str | None):
    """((poses, scans), None) from a cache file, or (None, why) when it is missing ('missing'),
    unreadable, cut short, of another layout, made from another source file or fails its
    checksum. ``source``: the SHA-256 the cache must have been made from (None: any)."""
    try:
        # np.load is given an open file: given a path, it leaves the file open when the zip is bad
        with open(path, "rb") as f, np.load(f, allow_pickle=False) as z:
            if set(z.files) != _CACHE_KEYS:
                return None, "not a cache file of this version"
            poses, flat, counts = z["poses"], z["scans"], z["counts"]
            made_from, digest = str(z["source"]), str(z["digest"])
    except FileNotFoundError:
        return None, "missing"
    except Exception as e:  # any failure to read it (truncated zip, bad CRC, bad header, ...)
        return None, f"unreadable ({type(e).__name__})"
    if not (poses.ndim == 2 and poses.shape[1] == 3 and poses.dtype == np.float64
            and flat.ndim == 2 and flat.shape[0] in (2, 3) and flat.dtype == np.float64
            and counts.ndim == 1 and counts.dtype == np.int64 and len(counts) == len(poses)
            and (counts > 0).all() and counts.sum() == flat.shape[1]):
        return None, "arrays of the wrong shape or type"
    if source is not None and made_from != source:
        return None, "made from another source file"
    if digest != _cache_digest(made_from, poses, flat, counts):
        return None, "checksum mismatch"
    bounds = np.concatenate([[0], np.cumsum(counts)])
    # each scan in the memory order loadmat gives it (MATLAB's column order)
    return (poses, [np.asfortranarray(flat[:, a:b]) for a, b in zip(bounds[:-1], bounds[1:])]), None


def _read_cache(path: Path, source: str | None = None):
    """(poses, scans) from a cache file, or None when it is missing, unreadable or fails its
    checks (layout, source file ``source``, SHA-256 of its arrays); see :func:`_cache_problem`."""
    return _cache_problem(path, source)[0]


def _write_cache(path: Path, poses: np.ndarray, scans: list, source: str) -> None:
    """Keep the loaded arrays of the source file with SHA-256 ``source`` for the next process,
    with their own SHA-256: written to a temporary name, synced and renamed (the file appears
    whole or not at all; a read-only data folder just goes without)."""
    if len({s.shape[0] for s in scans}) != 1:
        return
    flat = np.concatenate(scans, axis=1)
    counts = np.array([s.shape[1] for s in scans], dtype=np.int64)
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{os.urandom(4).hex()}.tmp")
    try:
        path.parent.mkdir(exist_ok=True)
        with open(tmp, "wb") as f:
            np.savez(f, poses=poses, scans=flat, counts=counts, source=np.array(source),
                     digest=np.array(_cache_digest(source, poses, flat, counts)))
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError:
        try:
            tmp.unlink()
        except OSError:
            pass


def load_intel(semantic: bool = False, path: Path | None = None) -> IntelData:
    """Load (and first ensure) the Intel sample as plain arrays, validated.

    Parameters
    ----------
    semantic : bool
        Load ``sample_Intel_dataset_semantic.mat`` (3xN scans with labels) instead of the plain one.
    path : Path, optional
        Read this ``.mat`` file instead of the verified copy in ``data/``.
    """
    cache = source = None
    if path is None:
        name = INTEL_SEMANTIC if semantic else INTEL
        path = ensure(name)  # verified against its SHA-256
        if Path(path).parent == DATA_DIR / Path(name).parent:
            source = manifest()[name][0]
            cache = _cache_file(name, source)
            hit, problem = _cache_problem(cache, source)
            if hit is not None:  # the arrays loadmat gave for this very file, bit for bit
                validate(*hit, semantic=semantic)
                return IntelData(*hit)
            if problem != "missing":
                print(f"note: the data cache {cache} is {problem}; rebuilding it from the verified "
                      f"{name}.", file=sys.stderr)
    raw = _loadmat(Path(path))
    for key in ("robotPose", "laserScan"):
        if key not in raw:
            raise InputError(f"{path} has no variable '{key}': it is not an Intel dataset file.")
    poses = poses_from_struct(raw["robotPose"])
    scans = scans_from_cell(raw["laserScan"])
    validate(poses, scans, semantic=semantic)
    if cache is not None:
        _write_cache(cache, poses, scans, source)
    return IntelData(poses, scans)


def load_intel_raw(semantic: bool = False) -> tuple:
    """Return ``(robotPose, laserScan)`` exactly as ``scipy.io.loadmat`` gives them (template faces)."""
    raw = _loadmat(ensure(INTEL_SEMANTIC if semantic else INTEL))
    return raw["robotPose"], raw["laserScan"]

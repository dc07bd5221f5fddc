"""Reader for PCD v0.7 point clouds (ASCII and binary), tolerant of undeclared trailing values.

The toy scans of BKISemanticMapping carry a fifth value (always ``-1``) on every ASCII data line
although the header declares four fields; current PCL skips such lines and returns an empty cloud.
This reader keeps the declared columns and ignores trailing extras. Anything truly malformed (a
missing, repeated or inconsistent header entry, a field name used twice, too few values on a
line, too few or too many lines or bytes for ``POINTS``, a value that is not a number of the
declared type) raises :class:`~hw4.core.errors.InputError` with one sentence; it never returns a
silently empty, shortened or truncated cloud. Fields named ``_`` are PCL's padding: skipped.

``binary_compressed`` (LZF) files are rejected with a clear message: convert them with
``pcl_convert_pcd_ascii_binary`` first.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from .scan import Scan

_TYPES = {("F", 4): "<f4", ("F", 8): "<f8", ("U", 1): "<u1", ("U", 2): "<u2", ("U", 4): "<u4",
          ("U", 8): "<u8", ("I", 1): "<i1", ("I", 2): "<i2", ("I", 4): "<i4", ("I", 8): "<i8"}
_REQUIRED = ("FIELDS", "SIZE", "TYPE", "WIDTH", "HEIGHT", "POINTS", "DATA")


@dataclass
class PCD:
    """A parsed PCD file.

    Attributes
    ----------
    fields : dict of str -> (POINTS,) or (POINTS, COUNT) array
        One array per declared field, in the declared type.
    viewpoint : (7,) float array
        ``tx ty tz qw qx qy qz``: sensor origin [m] and orientation (unit quaternion), world frame.
    data : str
        ``"ascii"`` or ``"binary"``.
    header : dict of str -> list of str
        The raw header entries.
    """

    fields: dict
    viewpoint: np.ndarray
    data: str
    header: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(next(iter(self.fields.values())))


def _parse_header(raw: bytes, name: str) -> tuple[dict, int]:
    """Return the header entries and the byte offset where the data starts."""
    header: dict = {}
    pos = 0
    while True:
        end = raw.find(b"\n", pos)
        if end < 0:
            raise InputError(f"{name}: the PCD header ends before its DATA line; the file is truncated "
                             "or not a PCD file.")
        line = raw[pos:end].decode("ascii", errors="replace").strip()
        pos = end + 1
        if not line or line.startswith("#"):
            continue
        key, *vals = line.split()
        key = key.upper()
        if key not in ("VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT",
                       "POINTS", "DATA"):
            raise InputError(f"{name}: unexpected PCD header line {line[:60]!r} before DATA; "
                             "the header is malformed.")
        if key in header:
            raise InputError(f"{name}: the PCD header has two {key} lines; keep the one that is right.")
        header[key] = vals
        if key == "DATA":
            return header, pos


MAX_COUNT = 1 << 20  # largest COUNT accepted (PCL's widest descriptors hold a few hundred)
PADDING = "_"        # PCL's name for padding fields: skipped, and they may repeat


def _digits(text: str) -> bool:
    """True for a non-empty string of ASCII digits (``str.isdigit`` also accepts '²')."""
    return text.isascii() and text.isdigit()


def _int_entry(header: dict, key: str, name: str) -> int:
    vals = header[key]
    if len(vals) != 1 or not _digits(vals[0]):
        raise InputError(f"{name}: PCD header {key} must be one non-negative integer; got {' '.join(vals)!r}.")
    return int(vals[0])


def read_pcd(path) -> PCD:
    """Read a PCD v0.7 file (ASCII or binary).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    PCD
    """
    path = Path(path)
    name = path.name
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise InputError(f"cannot read {path} ({e.strerror}).") from None
    header, start = _parse_header(raw, name)
    missing = [k for k in _REQUIRED if k not in header]
    if missing:
        raise InputError(f"{name}: the PCD header lacks {', '.join(missing)}; the header is malformed.")
    names = header["FIELDS"]
    sizes, types = header["SIZE"], header["TYPE"]
    counts = header.get("COUNT", ["1"] * len(names))
    if not (len(names) == len(sizes) == len(types) == len(counts)) or not names:
        raise InputError(f"{name}: PCD header FIELDS, SIZE, TYPE and COUNT list different numbers of "
                         f"entries ({len(names)}, {len(sizes)}, {len(types)}, {len(counts)}).")
    dtypes = []
    for f, s, t, c in zip(names, sizes, types, counts):
        if not (_digits(s) and _digits(c) and int(c) >= 1) or (t.upper(), int(s)) not in _TYPES:
            raise InputError(f"{name}: field {f!r} has an unsupported SIZE/TYPE/COUNT {s}/{t}/{c}.")
        if int(c) > MAX_COUNT:
            raise InputError(f"{name}: field {f!r} has COUNT {c}, more than the {MAX_COUNT} values "
                             "per point this reader accepts; the header is malformed.")
        dtypes.append((f, _TYPES[(t.upper(), int(s))], int(c)))
    real = [f for f in names if f != PADDING]
    dup = sorted({f for f in real if real.count(f) > 1})
    if dup:
        raise InputError(f"{name}: the PCD header names field {dup[0]!r} twice in FIELDS; every field "
                         f"needs its own name ('{PADDING}' only for padding).")
    width = _int_entry(header, "WIDTH", name)
    height = _int_entry(header, "HEIGHT", name)
    n = _int_entry(header, "POINTS", name)
    if width * height != n:
        raise InputError(f"{name}: PCD header says WIDTH x HEIGHT = {width} x {height} but POINTS = {n}.")
    vp = header.get("VIEWPOINT", ["0", "0", "0", "1", "0", "0", "0"])
    try:
        viewpoint = np.array([float(v) for v in vp])
    except ValueError:
        viewpoint = np.array([])
    if viewpoint.shape != (7,) or not np.all(np.isfinite(viewpoint)):
        raise InputError(f"{name}: PCD VIEWPOINT must be 7 finite numbers tx ty tz qw qx qy qz; "
                         f"got {' '.join(vp)!r}.")
    if abs(np.linalg.norm(viewpoint[3:]) - 1.0) > 1e-3:
        raise InputError(f"{name}: PCD VIEWPOINT orientation qw qx qy qz = {' '.join(vp[3:])} is not a "
                         "unit quaternion, so the sensor pose is not a rigid transform.")
    kind = " ".join(header["DATA"]).lower()
    ncol = sum(c for _, _, c in dtypes)
    if kind == "ascii":
        table = _read_ascii(raw[start:], n, ncol, name)
        cols, j = {}, 0
        for f, dt, c in dtypes:
            block = table[:, j:j + c]
            j += c
            if f == PADDING:
                continue
            info = np.iinfo(dt) if np.dtype(dt).kind in "iu" else np.finfo(dt)
            if np.dtype(dt).kind in "iu":
                bad = (block != np.round(block)) | (block < info.min) | (block >= float(info.max) + 1)
                if np.any(bad):
                    raise InputError(f"{name}: field {f!r} is declared as {np.dtype(dt).name} but holds "
                                     f"the value {block[bad][0]:g}, which is not such an integer.")
            elif np.any(np.isfinite(block) & (np.abs(block) > info.max)):
                raise InputError(f"{name}: field {f!r} is declared as {np.dtype(dt).name} but holds a "
                                 f"value beyond its range ({np.abs(block[np.isfinite(block)]).max():g}).")
            cols[f] = (block[:, 0] if c == 1 else block).astype(dt)
    elif kind == "binary":
        itemsize = sum(np.dtype(dt).itemsize * c for _, dt, c in dtypes)
        need = n * itemsize
        have = len(raw) - start
        if have < need:
            raise InputError(f"{name}: binary PCD data is truncated ({have} bytes for "
                             f"{n} points of {itemsize} bytes = {need}).")
        if raw[start + need:].strip(b"\r\n"):
            raise InputError(f"{name}: binary PCD data holds {have - need} bytes more than its "
                             f"{n} POINTS of {itemsize} bytes; the header or the file is wrong.")
        rec = np.dtype({"names": [f"f{i}" for i in range(len(dtypes))],
                        "formats": [(dt, (c,)) if c > 1 else dt for _, dt, c in dtypes]})
        arr = np.frombuffer(raw, dtype=rec, count=n, offset=start)
        cols = {f: arr[f"f{i}"].copy() for i, (f, _, _) in enumerate(dtypes) if f != PADDING}
    elif kind == "binary_compressed":
        raise InputError(f"{name}: DATA binary_compressed (LZF) PCD files are not supported; convert "
                         "to ascii or binary first with pcl_convert_pcd_ascii_binary.")
    else:
        raise InputError(f"{name}: unknown PCD DATA kind {kind!r}; expected ascii or binary.")
    if not cols:
        raise InputError(f"{name}: the PCD declares only padding fields ('{PADDING}').")
    return PCD(cols, viewpoint, kind, header)


def _read_ascii(body: bytes, n: int, ncol: int, name: str) -> np.ndarray:
    """Parse ``n`` ASCII data lines into an (n, ncol) float array, ignoring undeclared extras."""
    lines = [ln for ln in body.decode("ascii", errors="replace").splitlines() if ln.strip()]
    if len(lines) < n:
        raise InputError(f"{name}: PCD header declares {n} points but the data has only "
                         f"{len(lines)} lines; the file is truncated.")
    if len(lines) > n:
        raise InputError(f"{name}: PCD header declares {n} points but the data has {len(lines)} "
                         "lines; fix POINTS/WIDTH or remove the extra lines.")
    if n == 0:
        return np.zeros((0, ncol))
    rows = [ln.split() for ln in lines]
    counts = np.fromiter(map(len, rows), dtype=np.int64, count=n)
    if counts.min() < ncol:
        i = int(np.argmin(counts))
        raise InputError(f"{name}: data line {i + 1} has {counts[i]} values but the header declares "
                         f"{ncol}; the data is malformed.")
    try:
        if counts.max() == ncol:
            table = np.array(rows, dtype=float)
        else:  # undeclared trailing values: keep the declared columns only
            table = np.array([r[:ncol] for r in rows], dtype=float)
    except ValueError:
        raise InputError(f"{name}: the ASCII data holds a value that is not a number.") from None
    if table.shape[1] < ncol:
        raise InputError(f"{name}: data lines have {table.shape[1]} values but the header declares {ncol}.")
    return table[:, :ncol]


def read_labelled_scan(path, label_field: str = "label") -> Scan:
    """Read a labelled PCD scan whose points are in the world frame and whose VIEWPOINT is the sensor.

    Parameters
    ----------
    path : str or Path
        PCD file with fields ``x y z`` and ``label_field``.
    label_field : str
        Name of the class-label field.

    Returns
    -------
    Scan
        Points [m] and origin [m] in the world frame; labels as integers (not yet range-checked:
        see :func:`hw4.bki.scan.validate_scan`).
    """
    pcd = read_pcd(path)
    need = [f for f in ("x", "y", "z", label_field) if f not in pcd.fields]
    if need:
        raise InputError(f"{Path(path).name}: the PCD has no field {need[0]!r} (fields: "
                         f"{' '.join(pcd.fields)}); a labelled scan needs x y z {label_field}.")
    wide = [f for f in ("x", "y", "z", label_field) if pcd.fields[f].ndim != 1]
    if wide:
        raise InputError(f"{Path(path).name}: the PCD field {wide[0]!r} has COUNT > 1; a labelled scan "
                         "needs one value per point in x y z and the label.")
    pts = np.column_stack([pcd.fields[c].astype(float) for c in "xyz"])
    lab = pcd.fields[label_field]
    if lab.dtype.kind == "f":
        bad = ~np.isfinite(lab) | (lab != np.round(lab)) | (np.abs(lab) > 2.0 ** 31)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"{Path(path).name}: point {i} has label {lab[i]:g}, which is not an "
                             "integer class id.")
    elif lab.dtype == np.uint64 and len(lab) and lab.max() > np.iinfo(np.int64).max:
        raise InputError(f"{Path(path).name}: a label exceeds the largest class id this reader takes.")
    return Scan(pts, lab.astype(np.int64), pcd.viewpoint[:3].copy(), Path(path).name)

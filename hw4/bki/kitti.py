"""Reader for a SemanticKITTI sequence folder: scans, labels, poses and calibration.

Layout of ``sequences/NN/`` (http://www.semantic-kitti.org/dataset.html):

* ``velodyne/000000.bin`` -- float32 ``x, y, z, remission`` per point [m], velodyne frame;
* ``labels/000000.label`` (or a folder of predictions) -- uint32 per point, the semantic id in the
  low 16 bits and the instance id in the high 16 bits;
* ``poses.txt`` -- one 3x4 row-major matrix per scan: the pose ``P_t`` of the left camera of scan
  ``t`` in the frame of the camera of scan 0;
* ``calib.txt`` -- the line ``Tr:`` (3x4 row-major): velodyne -> left camera.

A ``calib.txt`` without ``Tr`` (some public copies carry only ``P0``-``P3``) falls back on KITTI
odometry's published extrinsic of the sequence's recording day (:data:`PUBLISHED_TR`: sequences
00-02, 03 and 04-10, the values the reference C++ package hard-codes); a ``Tr`` in ``calib.txt``
always wins, and ``calib=`` (``python -m hw4 bki --calib FILE``) names another file whose ``Tr``
line is used instead. Any other sequence without ``Tr`` is refused with what to supply.

As in SemanticKITTI's own tools, the velodyne pose of scan ``t`` in the world frame (the velodyne
frame of scan 0, z up) is ``inv(Tr) @ P_t @ Tr``; the sensor origin is its translation. Raw ids are
mapped to the 19 training classes plus class 0 (unlabeled) with the dataset's ``learning_map``, and
classes get the dataset's colours (converted from the yaml's BGR to RGB).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.errors import InputError
from .scan import Scan

CLASS_NAMES = ("free", "car", "bicycle", "motorcycle", "truck", "other-vehicle", "person",
               "bicyclist", "motorcyclist", "road", "parking", "sidewalk", "other-ground",
               "building", "fence", "vegetation", "trunk", "terrain", "pole", "traffic-sign")
"""Map classes: 0 is free space in the map (SemanticKITTI's 'unlabeled', dropped from hits)."""

LEARNING_MAP = {0: 0, 1: 0, 10: 1, 11: 2, 13: 5, 15: 3, 16: 5, 18: 4, 20: 5, 30: 6, 31: 7, 32: 8,
                40: 9, 44: 10, 48: 11, 49: 12, 50: 13, 51: 14, 52: 0, 60: 9, 70: 15, 71: 16, 72: 17,
                80: 18, 81: 19, 99: 0, 252: 1, 253: 7, 254: 6, 255: 8, 256: 5, 257: 5, 258: 4, 259: 5}
"""SemanticKITTI ``learning_map``: raw semantic id -> training class 0..19."""

_COLOR_BGR = {0: (0, 0, 0), 10: (245, 150, 100), 11: (245, 230, 100), 15: (150, 60, 30),
              18: (180, 30, 80), 20: (255, 0, 0), 30: (30, 30, 255), 31: (200, 40, 255),
              32: (90, 30, 150), 40: (255, 0, 255), 44: (255, 150, 255), 48: (75, 0, 75),
              49: (75, 0, 175), 50: (0, 200, 255), 51: (50, 120, 255), 70: (0, 175, 0),
              71: (0, 60, 135), 72: (80, 240, 150), 80: (150, 240, 255), 81: (0, 0, 255)}
_LEARNING_MAP_INV = (0, 10, 11, 15, 18, 20, 30, 31, 32, 40, 44, 48, 49, 50, 51, 70, 71, 72, 80, 81)

COLORS = np.array([_COLOR_BGR[r][::-1] for r in _LEARNING_MAP_INV], dtype=np.uint8)
"""(20, 3) uint8 RGB colour of each training class (SemanticKITTI's palette)."""

_LUT = np.full(1 << 16, -1, dtype=np.int64)
for _raw, _cls in LEARNING_MAP.items():
    _LUT[_raw] = _cls


def learning_labels(raw: np.ndarray, name: str = "labels") -> np.ndarray:
    """Map raw uint32 labels (semantic id in the low 16 bits) to training classes 0..19.

    Raises :class:`InputError` for a semantic id that SemanticKITTI does not define.
    """
    sem = np.asarray(raw, dtype=np.uint32) & 0xFFFF
    cls = _LUT[sem]
    if np.any(cls < 0):
        bad = int(sem[cls < 0][0])
        raise InputError(f"{name} holds semantic id {bad}, which is not a SemanticKITTI label id "
                         "(not in its learning_map); is this a .label file?")
    return cls


_TR_2011_10_03 = (4.276802385584e-04, -9.999672484946e-01, -8.084491683471e-03, -1.198459927713e-02,
                  -7.210626507497e-03, 8.081198471645e-03, -9.999413164504e-01, -5.403984729748e-02,
                  9.999738645903e-01, 4.859485810390e-04, -7.206933692422e-03, -2.921968648686e-01)
_TR_2011_09_26 = (2.34773698147e-04, -9.99944154543764e-01, -1.0563477811052e-02, -2.796816941295e-03,
                  1.0449407416593e-02, 1.0565353641379e-02, -9.99889574117649e-01, -7.5108791382965e-02,
                  9.99945388562002e-01, 1.24365378387e-04, 1.0451302995669e-02, -2.72132796405873e-01)
_TR_2011_09_30 = (-1.857739385241e-03, -9.999659513510e-01, -8.039975204516e-03, -4.784029760483e-03,
                  -6.481465826011e-03, 8.051860151134e-03, -9.999466081774e-01, -7.337429464231e-02,
                  9.999773098287e-01, -1.805528627661e-03, -6.496203536139e-03, -3.339968064433e-01)
PUBLISHED_TR = {0: _TR_2011_10_03, 1: _TR_2011_10_03, 2: _TR_2011_10_03, 3: _TR_2011_09_26,
                **{n: _TR_2011_09_30 for n in range(4, 11)}}
"""KITTI odometry's published velodyne -> camera-0 extrinsic (3x4 row-major) per sequence 0..10."""


def _matrix_rows(text: str, name: str) -> np.ndarray:
    try:
        vals = [[float(v) for v in ln.split()] for ln in text.splitlines() if ln.strip()]
    except ValueError:
        raise InputError(f"{name} holds a value that is not a number.") from None
    if not vals or any(len(v) != 12 for v in vals):
        raise InputError(f"{name} must hold one 3x4 matrix (12 numbers) per line.")
    m = np.array(vals).reshape(-1, 3, 4)
    out = np.tile(np.eye(4), (len(m), 1, 1))
    out[:, :3, :] = m
    return out


def check_rigid(T: np.ndarray, name: str, tol: float = 1e-4) -> None:
    """Raise :class:`InputError` unless ``T`` (4, 4) is a finite rigid transform (rotation + translation).

    ``tol`` bounds ``|R^T R - I|`` (the published poses are rounded to about 1e-9 relative).
    """
    if not np.all(np.isfinite(T)):
        raise InputError(f"{name} contains NaN or infinite values.")
    if np.abs(T[:3, 3]).max() > 1e9:
        raise InputError(f"{name} has a translation beyond 1e9 m; check the units.")
    if np.abs(T[:3, :3]).max() > 1 + tol:
        raise InputError(f"{name} is not a rigid transform (an entry of its 3x3 part is "
                         f"{np.abs(T[:3, :3]).max():.3g}, beyond a rotation's 1).")
    R = T[:3, :3]
    err = np.abs(R.T @ R - np.eye(3)).max()
    if err > tol or np.linalg.det(R) < 0:
        raise InputError(f"{name} is not a rigid transform (its 3x3 part is not a rotation: "
                         f"|R^T R - I| = {err:.2g}, det = {np.linalg.det(R):.3g}).")


def _decode(path: Path, data: bytes) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{path} is not a UTF-8 text file.") from None


def _read_text(path: Path) -> str:
    try:
        data = path.read_bytes()
    except OSError as e:
        raise InputError(f"cannot read {path} ({e.strerror}).") from None
    return _decode(path, data)


def read_calib(path, required: bool = True) -> np.ndarray | None:
    """Read ``Tr`` (velodyne -> left camera) from ``calib.txt`` as a (4, 4) array.

    With ``required=False`` a file without a ``Tr:`` line gives ``None``. Two different ``Tr``
    lines, or a ``Tr`` line without its colon, are refused.
    """
    path = Path(path)
    rows = []
    for n, ln in enumerate(_read_text(path).splitlines(), 1):
        key, colon, rest = ln.partition(":")
        if key.strip() == "Tr":
            rows.append(rest)
        elif not colon and ln.split()[:1] == ["Tr"]:
            raise InputError(f"line {n} of {path} starts with Tr but has no colon ('Tr: 12 numbers').")
    if not rows:
        if required:
            raise InputError(f"{path} has no 'Tr:' line (velodyne -> camera calibration).")
        return None
    mats = [_matrix_rows(r, f"{path} (Tr)")[0] for r in rows]
    if any(not np.array_equal(m, mats[0]) for m in mats[1:]):
        raise InputError(f"{path} has {len(mats)} different 'Tr:' lines; keep the one that is right.")
    check_rigid(mats[0], f"the Tr calibration in {path}")
    return mats[0]


def sequence_calib(folder, calib=None) -> tuple[np.ndarray, str]:
    """The velodyne -> camera extrinsic of a sequence folder and a sentence saying where it came from.

    Order: the ``Tr`` line of ``calib`` (a file) when given; else the ``Tr`` of the folder's
    ``calib.txt``; else KITTI's published value for the sequence named by the folder (00..10).
    """
    folder = Path(folder)
    if calib is not None:
        return read_calib(calib), f"Tr from {calib}"
    Tr = read_calib(folder / "calib.txt", required=False)
    if Tr is not None:
        return Tr, f"Tr from {folder / 'calib.txt'}"
    name = folder.resolve().name
    seq = int(name) if name.isascii() and name.isdigit() else None
    if seq not in PUBLISHED_TR:
        raise InputError(f"{folder / 'calib.txt'} has no 'Tr:' line and sequence {name!r} has no "
                         "published KITTI extrinsic (known: 00-10): add the 'Tr: <12 numbers>' line "
                         "(velodyne -> camera 0, 3x4 row-major) or pass --calib FILE.")
    Tr = np.eye(4)
    Tr[:3, :] = np.reshape(PUBLISHED_TR[seq], (3, 4))
    return Tr, (f"{folder / 'calib.txt'} has no Tr: using KITTI's published velodyne-to-camera "
                f"extrinsic of sequence {seq:02d}")


def read_poses(path) -> np.ndarray:
    """Read ``poses.txt``: (T, 4, 4) camera poses, camera frame of scan 0. Each must be rigid."""
    path = Path(path)
    P = _matrix_rows(_read_text(path), str(path))
    for t, T in enumerate(P):
        check_rigid(T, f"pose {t} (line {t + 1}) of {path}")
    return P


def velodyne_poses(P: np.ndarray, Tr: np.ndarray) -> np.ndarray:
    """Velodyne poses in the world frame (velodyne frame of scan 0): ``inv(Tr) @ P_t @ Tr``.

    Parameters
    ----------
    P : (T, 4, 4) camera poses, camera frame of scan 0
    Tr : (4, 4) velodyne -> camera

    Returns
    -------
    (T, 4, 4) array mapping velodyne coordinates of scan t [m] to world coordinates [m]
    """
    return np.linalg.inv(Tr)[None] @ P @ Tr[None]


def _read_records(path, record: int, what: str) -> bytes:
    """The bytes of ``path``, checked to hold whole records of ``record`` bytes."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise InputError(f"cannot read {path} ({e.strerror}).") from None
    if len(raw) % record:
        raise InputError(f"{path} has {len(raw)} bytes, not a multiple of {record} ({what}): "
                         "the file is truncated or of another kind.")
    return raw


def read_bin(path) -> np.ndarray:
    """Read a velodyne ``.bin``: (N, 4) float32 ``x, y, z`` [m] (velodyne frame) and remission."""
    raw = _read_records(path, 16, "4 float32 per point")
    return np.frombuffer(raw, dtype="<f4").reshape(-1, 4)


def read_label(path) -> np.ndarray:
    """Read a ``.label`` file: (N,) uint32 raw labels."""
    return np.frombuffer(_read_records(path, 4, "one uint32 per point"), dtype="<u4")


class SemanticKITTISequence:
    """A SemanticKITTI sequence folder, read scan by scan (streaming).

    Parameters
    ----------
    folder : str or Path
        The sequence folder, e.g. ``.../dataset/sequences/04``, with ``velodyne/``, the label
        folder, ``poses.txt`` and ``calib.txt``.
    labels : str
        Name of the label folder (``labels`` for ground truth, ``predictions`` for network output;
        either way raw SemanticKITTI ids).
    calib : str or Path, optional
        A file whose ``Tr:`` line replaces the folder's calibration (see :func:`sequence_calib`).
    frame : {"velodyne", "reference"}
        World frame: ``velodyne`` (default) is the velodyne frame of scan 0, ``inv(Tr) @ P_t @ Tr``;
        ``reference`` is the reference C++ node's ``init_trans_to_ground @ P_t @ Tr``
        (:func:`hw4.bki.reference.world_poses`).
    unlabeled : {"drop", "insert"}
        Hits whose raw id maps to class 0: dropped (default), or kept with class 0 as the reference
        inserts them (free-space evidence at the hit; such scans carry label 0, which
        :func:`~hw4.bki.scan.validate_scan` refuses, so they are mapped by
        :func:`hw4.bki.semantic_eval.run`).
    origin : {"true", "reference"}
        Sensor origin of each scan: the velodyne position (default), or the camera translation the
        reference passes (``frame="reference"`` only; :func:`hw4.bki.reference.sensor_origins`).
    relabel : callable, optional
        ``relabel(t, xyz, raw) -> classes``: replaces the classes of scan ``t`` (``xyz`` (N, 3) [m]
        in the velodyne frame, ``raw`` (N,) uint32 raw labels; returns (N,) ints 0..19), e.g. a
        simulated segmenter (:class:`hw4.bki.noise.SimulatedSegmenter`). Applied before
        ``unlabeled``.

    Attributes
    ----------
    calib_note : str
        Where the extrinsic came from (one sentence, for the command to print).
    """

    def __init__(self, folder, labels: str = "labels", calib=None, frame: str = "velodyne",
                 unlabeled: str = "drop", origin: str = "true", relabel=None):
        from . import reference
        if unlabeled not in ("drop", "insert"):
            raise InputError(f"unknown unlabeled option {unlabeled!r}; use drop or insert.")
        self.frame, self.unlabeled, self.relabel = frame, unlabeled, relabel
        self.folder = Path(folder)
        if not self.folder.is_dir():
            raise InputError(f"{self.folder} is not a folder; give a SemanticKITTI sequence folder "
                             "such as dataset/sequences/04.")
        vel = self.folder / "velodyne"
        self.bins = sorted(p for p in vel.glob("*.bin") if p.is_file()) if vel.is_dir() else []
        if not self.bins:
            raise InputError(f"{vel} holds no .bin scans; is {self.folder} a SemanticKITTI sequence folder?")
        self.label_dir = self.folder / labels
        if not self.label_dir.is_dir():
            raise InputError(f"{self.label_dir} is missing: the scans need per-point labels "
                             "(labels/ or predictions/).")
        self.Tr, self.calib_note = sequence_calib(self.folder, calib)
        cam = read_poses(self.folder / "poses.txt")
        self.poses = reference.world_poses(cam, self.Tr, frame)
        self.origins = reference.sensor_origins(cam, self.Tr, frame, origin)
        if len(self.poses) < len(self.bins):
            raise InputError(f"{self.folder / 'poses.txt'} has {len(self.poses)} poses for "
                             f"{len(self.bins)} scans; each scan needs a pose.")

    def __len__(self) -> int:
        return len(self.bins)

    def scan(self, t: int) -> Scan:
        """Scan ``t`` in the world frame, hits of class 0 (unlabeled, outlier, ...) dropped.

        Returns
        -------
        Scan
            Points [m] and origin [m] in the world frame (velodyne frame of scan 0 unless
            ``frame`` says otherwise); labels 1..19 (0..19 with ``unlabeled="insert"``).
        """
        b = self.bins[t]
        lab_path = self.label_dir / (b.stem + ".label")
        pts = read_bin(b)
        raw = read_label(lab_path)
        if len(raw) != len(pts):
            raise InputError(f"{lab_path.name} has {len(raw)} labels for the {len(pts)} points of "
                             f"{b.name}; they must match one to one.")
        cls = learning_labels(raw, str(lab_path))
        i = int(b.stem) if (b.stem.isascii() and b.stem.isdigit()) else t  # scan NNNNNN has the pose on line NNNNNN
        if i >= len(self.poses):
            raise InputError(f"{b.name} has no pose: {self.folder / 'poses.txt'} has {len(self.poses)} lines.")
        T = self.poses[i]
        if self.relabel is not None:
            cls = np.asarray(self.relabel(i, pts[:, :3].astype(float), raw), dtype=np.int64)
            if cls.shape != raw.shape or (cls.size and (cls.min() < 0 or cls.max() >= len(CLASS_NAMES))):
                raise InputError(f"relabel gave {cls.shape} classes for the {len(raw)} points of "
                                 f"{b.name}; it must give one class 0..{len(CLASS_NAMES) - 1} per point.")
        keep = cls > 0 if self.unlabeled == "drop" else np.ones(len(cls), bool)
        xyz = pts[keep, :3].astype(float)
        finite = np.all(np.isfinite(xyz), axis=1)
        if not finite.all():
            raise InputError(f"{b.name}: point {int(np.flatnonzero(~finite)[0])} of the kept points "
                             f"has a NaN or infinite coordinate ({int((~finite).sum())} such points); "
                             "the scan is corrupt.")
        world = xyz @ T[:3, :3].T + T[:3, 3]
        return Scan(world, cls[keep], self.origins[i].copy(), b.name)

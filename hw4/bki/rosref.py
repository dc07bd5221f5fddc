"""The real C++/ROS reference package's map as data, and ours measured against it.

``scripts/reference_ros.sh`` builds BKISemanticMapping (Gan et al., RA-L 2020) with catkin, runs its
own nodes and records what they publish with ``rosbag``. This module reads that recording without
ROS and compares it with the maps of :mod:`hw4.bki`:

* :func:`read_bag` -- the messages of a ROS 1 bag (format 2.0, uncompressed or bz2 chunks), in pure
  Python; :func:`parse_marker_array` -- one ``visualization_msgs/MarkerArray`` (ROS 1 wire format);
* :func:`marker_voxels` -- the occupied voxels the reference publishes: each ``CUBE_LIST`` point is a
  voxel centre [m] in its frame ``map``, each colour one of the reference's class colours
  (:data:`REF_KITTI_RGB`, :data:`REF_TOY_RGB`, transcribed from its ``markerarray_pub.h``), turned
  back into the class;
* :func:`write_predictions` -- the ``predictions/`` folder the reference's SemanticKITTI node reads
  (one uint32 class id 0..19 per point): the ground truth through ``learning_map`` (``clean``) or
  the simulated segmenter's labels (``noisy``, :class:`hw4.bki.noise.SimulatedSegmenter`);
* :func:`our_kitti_maps`, :func:`our_toy_maps` -- our maps of the same scans, in the reference's
  frame and with its inputs, so that voxel grids coincide;
* :func:`compare_voxels` -- Jaccard of the occupied voxels, class agreement, voxels only one side
  has.

``python -m hw4.bki.rosref {predictions,compare}`` are the steps the shell script calls.
Units are metres; frames are named in each function.
"""
from __future__ import annotations

import argparse
import bz2
import json
import struct
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import InputError

REF_KITTI_RGB = np.array([
    (255, 255, 255),   # 0 free / default: white (never published as occupied)
    (245, 150, 100),   # 1 car
    (245, 230, 100),   # 2 bicycle
    (150, 60, 30),     # 3 motorcycle
    (180, 30, 80),     # 4 truck
    (255, 80, 100),    # 5 other-vehicle
    (30, 30, 255),     # 6 person
    (200, 40, 255),    # 7 bicyclist
    (90, 30, 150),     # 8 motorcyclist
    (255, 0, 255),     # 9 road
    (255, 150, 255),   # 10 parking
    (75, 0, 75),       # 11 sidewalk
    (75, 0, 175),      # 12 other-ground
    (0, 200, 255),     # 13 building
    (50, 120, 255),    # 14 fence
    (0, 175, 0),       # 15 vegetation
    (0, 60, 135),      # 16 trunk
    (80, 240, 150),    # 17 terrain
    (150, 240, 255),   # 18 pole
    (0, 0, 255),       # 19 traffic-sign
], dtype=float)
"""RGB (0-255) of each SemanticKITTI class as the reference draws it
(``SemanticKITTISemanticMapColor`` in ``include/semantic_bki/common/markerarray_pub.h``): the
dataset's BGR triples used as RGB, so red and blue are swapped against SemanticKITTI's palette
(:data:`hw4.bki.kitti.COLORS`), and other-vehicle is (255, 80, 100); the colours still tell every
class apart."""

REF_TOY_RGB = np.array([(255, 255, 255), (255, 0, 0), (70, 130, 180), (218, 112, 214)], dtype=float)
"""RGB (0-255) of the toy classes 0-3 as the reference draws them (``SemanticMapColor``)."""

TOPICS = {"semantickitti": ("/occupied_cells_vis_array",),
          "toy": ("/semantic_csm", "/semantic_bki")}
"""The MarkerArray topics of the reference's nodes (frame ``map``)."""

REF_TREE_SHA256 = "93e6032792a2fbab601d14446e6d63ee85457f00b9a4806d1e779aae0723fc39"
"""sha256 of the pinned source tree (commit 66e32583c12b2c61acd2b0ffb2878d0dc05a69fa), computed from
inside the package folder (``find . -type f | LC_ALL=C sort | xargs sha256sum | sha256sum``), so
that it does not depend on the folder name an archive gives; ../shared/upstream/README.md's
``ed227fed...`` is the same tree hashed from the folder above, with its name in every path."""


# --------------------------------------------------------------------------- the bag
@dataclass
class BagMessage:
    """One message of a bag: ``topic``, receive time ``t`` [s since the epoch], ``data`` (bytes)."""

    topic: str
    t: float
    data: bytes


def _fields(header: bytes) -> dict:
    out, i = {}, 0
    while i < len(header):
        (n,) = struct.unpack_from("<I", header, i)
        name, _, value = header[i + 4:i + 4 + n].partition(b"=")
        out[name.decode("ascii", "replace")] = value
        i += 4 + n
    return out


def _records(buf: bytes, start: int = 0):
    """Yield (header fields, data) of the records in ``buf`` from ``start``."""
    i = start
    while i + 4 <= len(buf):
        (hl,) = struct.unpack_from("<I", buf, i)
        if i + 8 + hl > len(buf):
            raise InputError("the bag ends inside a record: it is truncated (was rosbag record "
                             "stopped with SIGINT?).")
        h = _fields(buf[i + 4:i + 4 + hl])
        (dl,) = struct.unpack_from("<I", buf, i + 4 + hl)
        data = buf[i + 8 + hl:i + 8 + hl + dl]
        if len(data) != dl:
            raise InputError("the bag ends inside a record: it is truncated.")
        yield h, data
        i += 8 + hl + dl


def read_bag(path) -> list[BagMessage]:
    """Messages of a ROS 1 bag file (format 2.0), in file order.

    Chunks may be uncompressed or bz2 (``rosbag record``'s default is uncompressed); lz4 chunks are
    refused with what to do. Raises :class:`InputError` for a file that is not such a bag.
    """
    path = Path(path)
    buf = path.read_bytes()
    magic = b"#ROSBAG V2.0\n"
    if not buf.startswith(magic):
        raise InputError(f"{path} is not a ROS 1 bag (format 2.0).")
    conns: dict[int, str] = {}
    out: list[BagMessage] = []

    def handle(h, data):
        op = h.get("op", b"\x00")[0]
        if op == 0x07:                                   # connection
            (cid,) = struct.unpack("<I", h["conn"])
            conns[cid] = h["topic"].decode()
        elif op == 0x02:                                 # message data
            (cid,) = struct.unpack("<I", h["conn"])
            sec, nsec = struct.unpack("<II", h["time"])
            out.append(BagMessage(conns.get(cid, "?"), sec + nsec * 1e-9, data))
        elif op == 0x05:                                 # chunk
            comp = h.get("compression", b"none")
            if comp == b"bz2":
                data = bz2.decompress(data)
            elif comp != b"none":
                raise InputError(f"{path}: chunks compressed with {comp.decode()}; decompress first "
                                 "(rosbag decompress).")
            for hh, dd in _records(data):
                handle(hh, dd)

    for h, data in _records(buf, len(magic)):
        handle(h, data)
    # a connection record may follow its first message inside a chunk: resolve afterwards
    for m in out:
        if m.topic == "?":
            raise InputError(f"{path}: a message without a connection record.")
    return out


class _Reader:
    def __init__(self, data: bytes):
        self.b, self.i = data, 0

    def take(self, fmt: str):
        v = struct.unpack_from("<" + fmt, self.b, self.i)
        self.i += struct.calcsize("<" + fmt)
        return v

    def string(self) -> str:
        (n,) = self.take("I")
        s = self.b[self.i:self.i + n].decode("utf-8", "replace")
        self.i += n
        return s

    def array(self, dtype: str, width: int) -> np.ndarray:
        (n,) = self.take("I")
        a = np.frombuffer(self.b, dtype=dtype, count=n * width, offset=self.i).reshape(n, width)
        self.i += a.nbytes
        return a


def parse_marker_array(data: bytes) -> list[dict]:
    """Decode a ``visualization_msgs/MarkerArray`` (ROS 1 serialization).

    Returns
    -------
    list of dict, one per marker: ``frame_id``, ``ns``, ``id``, ``type``, ``action``,
    ``scale`` (3,) [m], ``points`` (N, 3) float64 [m] (in ``frame_id``), ``colors`` (N, 4) float32
    RGBA in [0, 1], ``color`` (4,) the marker's colour.
    """
    r = _Reader(data)
    (n,) = r.take("I")
    out = []
    try:
        for _ in range(n):
            r.take("III")                                # header.seq, stamp
            frame = r.string()
            ns = r.string()
            mid, mtype, action = r.take("iii")
            r.take("7d")                                 # pose
            scale = np.array(r.take("3d"))
            color = np.array(r.take("4f"))
            r.take("ii")                                 # lifetime
            r.take("B")                                  # frame_locked
            pts = r.array("<f8", 3)
            cols = r.array("<f4", 4)
            r.string()                                   # text
            r.string()                                   # mesh_resource
            r.take("B")                                  # mesh_use_embedded_materials
            out.append({"frame_id": frame, "ns": ns, "id": mid, "type": mtype, "action": action,
                        "scale": scale, "color": color, "points": pts, "colors": cols})
    except (struct.error, ValueError) as e:
        raise InputError(f"a MarkerArray message is malformed ({e}).") from None
    return out


CUBE_LIST = 6


def marker_voxels(markers: list[dict], palette: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Occupied voxels of one published map.

    Parameters
    ----------
    markers : output of :func:`parse_marker_array`
    palette : (K, 3) RGB 0-255 of the classes (:data:`REF_KITTI_RGB` or :data:`REF_TOY_RGB`)

    Returns
    -------
    centres : (M, 3) float [m], the marker frame (the reference's ``map``)
    cls : (M,) int, the class whose colour each cube has (exact to 1/255 or refused)
    scale : float [m], the edge RViz draws the cubes with (largest scale among non-empty lists)
    """
    pts, cols, scale = [], [], 0.0
    for m in markers:
        if m["type"] == CUBE_LIST and len(m["points"]):
            pts.append(m["points"])
            c = m["colors"][:, :3] if len(m["colors"]) == len(m["points"]) else \
                np.broadcast_to(m["color"][:3], (len(m["points"]), 3))
            cols.append(c)
            scale = max(scale, float(m["scale"][0]))
    if not pts:
        return np.zeros((0, 3)), np.zeros(0, np.int64), scale
    rgb = np.vstack(cols).astype(float) * 255.0
    d = np.abs(rgb[:, None, :] - np.asarray(palette, float)[None]).max(axis=2)
    cls = d.argmin(axis=1)
    if np.any(d[np.arange(len(cls)), cls] > 1.0):
        raise InputError("a published cube has a colour that is none of the reference's classes.")
    return np.vstack(pts), cls.astype(np.int64), scale


def bag_maps(path, topic: str, palette: np.ndarray) -> list[tuple[float, np.ndarray, np.ndarray, float]]:
    """Every map published on ``topic`` in a bag: (receive time [s], centres, cls, cube edge [m])."""
    msgs = [m for m in read_bag(path) if m.topic == topic]
    return [(m.t, *marker_voxels(parse_marker_array(m.data), palette)) for m in msgs]


# --------------------------------------------------------------------------- stored maps
def save_reference_maps(out_dir, bags: dict) -> Path:
    """Store the reference's published maps compactly for the book (``reference_maps.npz``).

    ``bags`` maps a name (``kitti04_clean``, ``kitti04_noisy``, ``toy``) to a bag path. For each
    map topic of the bag the last map is kept as voxel indices ``floor(2 c / r)`` on the half-voxel
    lattice (int32, (M, 3)) and classes (uint8), and the receive times of all its messages [s]
    (the node's pace). Written atomically; returns the path.
    """
    arrays = {}
    for name, bag in bags.items():
        kitti = name.startswith("kitti")
        palette = REF_KITTI_RGB if kitti else REF_TOY_RGB
        r = 0.3 if kitti else 0.1
        msgs = read_bag(bag)
        for topic in TOPICS["semantickitti" if kitti else "toy"]:
            got = [m for m in msgs if m.topic == topic]
            if not got:
                raise InputError(f"{bag} holds no map on {topic}.")
            c, k, edge = marker_voxels(parse_marker_array(got[-1].data), palette)
            key = f"{name}{topic.replace('/', '__')}"
            arrays[key + "__idx"] = np.round(2 * c / r).astype(np.int32)
            arrays[key + "__cls"] = k.astype(np.uint8)
            arrays[key + "__times"] = np.array([m.t for m in got])
            arrays[key + "__meta"] = np.array([r, edge])
    out = Path(out_dir) / "reference_maps.npz"
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".part.npz")
    np.savez_compressed(tmp, **arrays)
    tmp.replace(out)
    return out


@dataclass
class ReferenceMap:
    """One map the reference published: voxel ``centres`` (M, 3) [m] in its frame ``map``, classes
    ``cls`` (M,), ``resolution`` and RViz's ``cube_edge`` [m], the receive ``times`` [s] of all
    maps on the topic (one per scan for SemanticKITTI)."""

    centres: np.ndarray
    cls: np.ndarray
    resolution: float
    cube_edge: float
    times: np.ndarray


def load_reference_maps(path) -> dict:
    """{(name, topic): :class:`ReferenceMap`} from :func:`save_reference_maps`'s file."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path} is missing: run 'bash scripts/reference_ros.sh --book'.")
    z = np.load(path)
    out = {}
    for key in z.files:
        if key.endswith("__idx"):
            base = key[:-5]
            name, topic = base.split("__", 1)
            r, edge = z[base + "__meta"]
            out[name, "/" + topic.replace("__", "/")] = ReferenceMap(
                z[key].astype(float) * r / 2, z[base + "__cls"].astype(np.int64), float(r),
                float(edge), z[base + "__times"])
    return out


# --------------------------------------------------------------------------- comparison
def half_keys(centres: np.ndarray, resolution: float) -> np.ndarray:
    """Int64 keys of voxel centres on the half-voxel lattice (``round(2 c / r)`` per axis), so that
    the S-BKI grid (centres at odd multiples of r/2) and the reference's S-CSM grid (centres at
    multiples of r) both key exactly, despite float32 centres."""
    u = np.round(2 * np.asarray(centres, float) / resolution).astype(np.int64) + (1 << 20)
    return (u[:, 0] << 42) | (u[:, 1] << 21) | u[:, 2]


def compare_voxels(ref_centres, ref_cls, our_centres, our_cls, resolution: float) -> dict:
    """How our occupied voxels agree with the reference's.

    Parameters
    ----------
    ref_centres, our_centres : (M, 3) [m], same frame and grid; ref_cls, our_cls : (M,) classes >= 1

    Returns
    -------
    dict: ``ref``, ``ours`` (occupied voxels), ``common``, ``only_ref``, ``only_ours``,
    ``jaccard`` (common / union), ``class_agree`` (share of the common voxels with the same class),
    ``class_differ`` (their number).
    """
    kr, ko = half_keys(ref_centres, resolution), half_keys(our_centres, resolution)
    if len(np.unique(kr)) != len(kr):
        raise InputError("the reference's map lists a voxel twice.")
    _, ir, io = np.intersect1d(kr, ko, assume_unique=True, return_indices=True)
    same = np.asarray(ref_cls)[ir] == np.asarray(our_cls)[io]
    union = len(kr) + len(ko) - len(ir)
    return {"ref": int(len(kr)), "ours": int(len(ko)), "common": int(len(ir)),
            "only_ref": int(len(kr) - len(ir)), "only_ours": int(len(ko) - len(ir)),
            "jaccard": float(len(ir) / union) if union else float("nan"),
            "class_agree": float(same.mean()) if len(ir) else float("nan"),
            "class_differ": int((~same).sum())}


def only_masks(ref_centres, our_centres, resolution: float):
    """Boolean masks: reference voxels we lack, our voxels the reference lacks."""
    kr, ko = half_keys(ref_centres, resolution), half_keys(our_centres, resolution)
    return ~np.isin(kr, ko), ~np.isin(ko, kr)


# --------------------------------------------------------------------------- inputs
LABEL_SOURCES = ("clean", "noisy")


def segmenter(rate: float = 0.3, seed: int = 0):
    """The simulated segmenter whose labels stand in for a network's predictions."""
    from .noise import SimulatedSegmenter
    return SimulatedSegmenter(rate=rate, seed=seed)


def write_predictions(folder, out, source: str = "clean", scans: int | None = None,
                      rate: float = 0.3, seed: int = 0) -> int:
    """Write ``out/NNNNNN.label`` (uint32 class 0..19 per point) for the scans of ``folder``.

    ``source="clean"``: the ground truth of ``labels/`` through ``learning_map``; ``"noisy"``: the
    simulated segmenter's classes. Returns the number of files written.
    """
    from .kitti import SemanticKITTISequence, learning_labels, read_bin, read_label
    if source not in LABEL_SOURCES:
        raise InputError(f"unknown label source {source!r}; use clean or noisy.")
    seq = SemanticKITTISequence(folder)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    seg = segmenter(rate, seed) if source == "noisy" else None
    n = len(seq) if not scans else min(scans, len(seq))
    for t in range(n):
        b = seq.bins[t]
        raw = read_label(seq.label_dir / (b.stem + ".label"))
        if seg is None:
            cls = learning_labels(raw)
        else:
            cls = seg(int(b.stem), read_bin(b)[:, :3].astype(float), raw)
        tmp = out / (b.stem + ".label.part")
        np.asarray(cls, "<u4").tofile(tmp)
        tmp.replace(out / (b.stem + ".label"))
    return n


# --------------------------------------------------------------------------- our maps
@dataclass
class OurMap:
    """One of our maps built as the reference builds it: the view and the CPU time of the updates."""

    view: object
    seconds: float
    scans: int


def _insert(vmap, scans, cfg) -> float:
    """Insert scans (already checked) into a map; return the CPU time [s] of the updates."""
    from .training import training_data
    cpu = 0.0
    for scan in scans:
        t0 = time.process_time()
        td = training_data(scan, cfg.ds_resolution, cfg.free_resolution, cfg.max_range, cfg.num_class)
        vmap.update(td.points, td.labels)
        cpu += time.process_time() - t0
    return cpu


def _maps(make, scans, cfg, methods) -> dict:
    """Build the maps ``methods`` (``sbki``, ``scsm``, ``sbki_blocks``) over the same scans.

    ``sbki_blocks`` is S-BKI with the reference's 7-block neighbourhood
    (:class:`hw4.bki.reference.FaceNeighbourMap`); when it is asked for, ``sbki`` comes from the
    same run (the full map it wraps) and shares its time.
    """
    from .reference import FaceNeighbourMap
    out = {}
    for method in methods:
        if method == "sbki" and "sbki_blocks" in methods:
            continue
        if method == "sbki_blocks":
            vmap = FaceNeighbourMap(make("sbki"))
            cpu = _insert(vmap, scans(), cfg)
            out["sbki_blocks"] = OurMap(vmap.view(), cpu, 0)
            if "sbki" in methods:
                out["sbki"] = OurMap(vmap.map.view(), cpu, 0)
        else:
            vmap = make(method)
            cpu = _insert(vmap, scans(), cfg)
            out[method] = OurMap(vmap.view(), cpu, 0)
    return out


def our_kitti_maps(folder, source: str = "clean", scans: int = 10, methods=("sbki", "scsm"),
                   rate: float = 0.3, seed: int = 0) -> dict:
    """Our maps of the first ``scans`` scans with the reference's inputs.

    The reference's frame (``init_trans_to_ground @ P_t @ Tr``), its sensor origin (the camera
    translation), its label classes (``source``) with unlabeled hits inserted as class 0, and the
    settings of ``semantickitti.toml`` (the reference's). ``methods`` from ``sbki``, ``scsm`` and
    ``sbki_blocks`` (S-BKI with the reference's 7-block neighbourhood,
    :class:`hw4.bki.reference.FaceNeighbourMap`). Returns {method: :class:`OurMap`}.
    """
    from .config import load_config
    from .kitti import SemanticKITTISequence
    from .pipeline import new_map
    from .semantic_eval import _checked
    cfg = load_config("semantickitti")
    rl = segmenter(rate, seed) if source == "noisy" else None
    seq = SemanticKITTISequence(folder, frame="reference", origin="reference", unlabeled="insert",
                                relabel=rl)
    n = min(scans, len(seq))
    out = _maps(lambda m: new_map(cfg, m), lambda: (_checked(seq.scan(t), cfg.num_class)
                                                   for t in range(n)), cfg, methods)
    for om in out.values():
        om.scans = n
    return out


def our_toy_maps(folder=None, methods=("scsm", "sbki")) -> dict:
    """Our maps of the toy scans on the reference's grids (S-CSM centres on multiples of the voxel
    edge, :class:`hw4.bki.reference.ShiftedGrid`); ``methods`` as in :func:`our_kitti_maps`.
    Returns {method: :class:`OurMap`}."""
    from .config import load_config
    from .pipeline import new_map, scan_source
    from .reference import ShiftedGrid
    from .scan import validate_scan
    cfg = load_config("toy")
    loaders = scan_source("toy", folder)[:cfg.scans]
    scans = [validate_scan(load(), cfg.num_class) for load in loaders]

    def make(method):
        if method == "scsm":
            return ShiftedGrid.reference_csm(cfg.resolution, cfg.num_class, prior=cfg.prior,
                                             sf2=cfg.sf2, ell=cfg.ell, var_thresh=cfg.var_thresh)
        return new_map(cfg, method)
    out = _maps(make, lambda: iter(scans), cfg, methods)
    for om in out.values():
        om.scans = len(scans)
    return out


def occupied_as_reference(view) -> tuple[np.ndarray, np.ndarray]:
    """Centres and classes of the voxels the reference would publish: most likely class not free,
    without ``var_thresh`` (the reference never applies it)."""
    m = view.cls > 0
    return view.centres[m], view.cls[m]


# --------------------------------------------------------------------------- video strip
def video_strip(video, bag, t0: float, out, scans=(2, 3, 4, 6, 8, 10), crop=None,
                topic: str = TOPICS["semantickitti"][0], tile: str = "3x2") -> Path:
    """A strip of frames of the RViz screen recording ``video`` for print: for each scan ``k`` of
    ``scans`` (1-based), the frame just before the node published the map of scan ``k + 1`` (RViz
    has then drawn the map of scan ``k``; the last one 4 s after the last map; RViz, starting up, may
    not have drawn the first map before the second arrives, hence no scan 1). ``t0`` is the
    wall-clock time [s since the epoch] of the video's first frame, ``bag`` the recording of the
    same run; ``crop`` = ``"w:h:x:y"`` [px of the video]. Needs the ``ffmpeg`` program."""
    import subprocess
    import tempfile
    times = [m.t for m in read_bag(bag) if m.topic == topic]
    if not times:
        raise InputError(f"{bag} holds no map on {topic}.")
    at = [(times[k] - 0.3 if k < len(times) else times[-1] + 4.0) - t0 for k in scans if k <= len(times)]
    with tempfile.TemporaryDirectory() as tmp:
        for i, t in enumerate(at):
            vf = (f"crop={crop}," if crop else "") + "scale=640:-2"
            subprocess.run(["ffmpeg", "-loglevel", "error", "-y", "-ss", f"{max(t, 0):.2f}", "-i",
                            str(video), "-frames:v", "1", "-vf", vf, f"{tmp}/f{i:02d}.png"], check=True)
        out = Path(out)
        subprocess.run(["ffmpeg", "-loglevel", "error", "-y", "-i", f"{tmp}/f%02d.png", "-vf",
                        f"tile={tile}:padding=8:color=white", "-frames:v", "1", str(out)], check=True)
    return out


# --------------------------------------------------------------------------- RViz configurations
def rviz_config(text: str, topics=None, view: dict | None = None, hide_docks: bool = False,
                size=None) -> str:
    """A copy of an RViz configuration (the package's ``rviz/*.rviz``) for a screenshot.

    The window goes to (0, 0) of the screen (the package's configurations put it at an offset).
    ``topics``: the MarkerArray topics to leave enabled (others disabled; ``None`` keeps all).
    ``view``: replaces the current view, e.g. ``{"Class": "rviz/TopDownOrtho", "Scale": 12,
    "X": 0, "Y": 20, "Angle": 0}`` or an orbit ``{"Class": "rviz/Orbit", "Distance": ..,
    "Focal Point": (x, y, z), "Pitch": .., "Yaw": ..}`` (metres, radians, frame ``map``).
    ``hide_docks`` hides the side panels so that the 3D view fills the window;
    ``size`` = (width, height) [px] of the window.
    """
    import re
    lines = text.splitlines()
    out, i = [], 0
    while i < len(lines):
        ln = lines[i]
        if ln.strip() == "- Class: rviz/MarkerArray" and topics is not None:
            block = [ln]
            i += 1
            while i < len(lines) and lines[i].startswith("      "):
                block.append(lines[i])
                i += 1
            topic = next((b.split(":", 1)[1].strip() for b in block if "Marker Topic:" in b), "")
            on = "true" if topic in topics else "false"
            block = [re.sub(r"^(      (Enabled|Value)): \w+$", rf"\1: {on}", b) for b in block]
            out.extend(block)
            continue
        if view is not None and ln == "    Current:":
            out.append(ln)
            i += 1
            while i < len(lines) and lines[i].startswith("      "):
                i += 1
            for k, v in view.items():
                if isinstance(v, (tuple, list)):
                    out.append(f"      {k}:")
                    out.extend(f"        {a}: {b}" for a, b in zip("XYZ", v))
                else:
                    out.append(f"      {k}: {v}")
            out.append("      Name: Current View")
            out.append("      Target Frame: <Fixed Frame>")
            out.append("      Near Clip Distance: 0.01")
            continue
        m = re.match(r"^  (X|Y|Width|Height|Hide Left Dock|Hide Right Dock): (.*)$", ln)
        if m:
            key = m.group(1)
            if key in ("X", "Y"):
                ln = f"  {key}: 0"
            elif key in ("Width", "Height") and size is not None:
                ln = f"  {key}: {size[0] if key == 'Width' else size[1]}"
            elif key.startswith("Hide") and hide_docks:
                ln = f"  {key}: true"
        out.append(ln)
        i += 1
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- command line
def compare_kitti(bag, folder, source: str = "clean", scans: int = 10) -> dict:
    """The reference's last published map in ``bag`` against ours (see :func:`our_kitti_maps`).

    Returns a dict: ``messages``, ``cube_edge`` [m] (RViz's cube), ``ref_voxels``,
    ``node_s_per_scan`` (median time between published maps: insertion and publishing [s]) and,
    per map of ours (``sbki``, ``scsm``, ``sbki_blocks``), :func:`compare_voxels` plus
    ``our_cpu_s_per_scan`` and ``max_extra_evidence`` (the largest evidence of a voxel that only
    ours calls occupied).
    """
    maps = bag_maps(bag, TOPICS["semantickitti"][0], REF_KITTI_RGB)
    if not maps:
        raise InputError(f"{bag} holds no map on {TOPICS['semantickitti'][0]}.")
    t, centres, cls, edge = maps[-1]
    times = np.array([m[0] for m in maps])
    res = {"messages": len(maps), "cube_edge": edge, "ref_voxels": int(len(centres)),
           "node_s_per_scan": float(np.median(np.diff(times))) if len(times) > 1 else float("nan")}
    ours = our_kitti_maps(folder, source, scans, methods=("sbki", "scsm", "sbki_blocks"))
    for name, om in ours.items():
        res[name] = against(centres, cls, om, 0.3)
    return res


def compare_toy(bag, folder=None) -> dict:
    """The reference's toy maps (S-CSM and S-BKI topics of ``bag``) against ours, as
    :func:`compare_kitti` (no timing: the toy node prints its own)."""
    res = {}
    ours = our_toy_maps(folder, methods=("scsm", "sbki", "sbki_blocks"))
    msgs = read_bag(bag)
    for method, topic in (("scsm", "/semantic_csm"), ("sbki", "/semantic_bki")):
        got = [m for m in msgs if m.topic == topic]
        if not got:
            raise InputError(f"{bag} holds no map on {topic}.")
        centres, cls, edge = marker_voxels(parse_marker_array(got[-1].data), REF_TOY_RGB)
        for name in (method, method + "_blocks"):
            if name in ours:
                res[name] = against(centres, cls, ours[name], 0.1)
                res[name]["cube_edge"] = edge
    return res


def against(centres, cls, om: OurMap, resolution: float, prior: float = 0.001) -> dict:
    """:func:`compare_voxels` of the reference's voxels and ours, with our CPU time per scan and the
    largest evidence (concentration minus the ``prior`` of the configs) of a voxel only ours has."""
    c, k = occupied_as_reference(om.view)
    out = compare_voxels(centres, cls, c, k, resolution)
    out["our_cpu_s_per_scan"] = om.seconds / max(om.scans, 1)
    _, extra = only_masks(centres, c, resolution)
    ev = om.view.alpha[om.view.cls > 0][extra] - prior
    top = ev.max(axis=1) if len(ev) else np.zeros(0)
    out["max_extra_evidence"] = float(top.max()) if len(top) else 0.0
    out["extra_tiny"] = float(np.mean(top < TINY)) if len(top) else 1.0
    from .voxelmap import UNKNOWN
    unk = om.view.state[om.view.cls > 0][extra] == UNKNOWN
    out["extra_unknown"] = float(unk.mean()) if len(unk) else 1.0
    return out


TINY = 1e-5
"""Evidence below which a voxel's weight is a kernel tail that the reference's float32 kernel
(``bki.h``: distances scaled by ``1 / ell`` in float, results <= 0 dropped) rounds to nothing:
the sparse kernel's two terms cancel near ``d = ell`` to about ``sf2 * 1e-7`` in float32."""


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m hw4.bki.rosref",
                                description="Steps of scripts/reference_ros.sh: write the reference "
                                            "node's predictions/, compare its recorded map with ours.")
    sub = p.add_subparsers(dest="cmd", required=True)
    q = sub.add_parser("predictions", help="write predictions/*.label (class ids 0..19)")
    q.add_argument("folder", type=Path, help="SemanticKITTI sequence folder (velodyne/, labels/)")
    q.add_argument("out", type=Path, help="the predictions folder to write")
    q.add_argument("--labels", choices=LABEL_SOURCES, default="clean")
    q.add_argument("--scans", type=int, default=0)
    c = sub.add_parser("compare", help="compare the recorded map with ours; print JSON")
    c.add_argument("dataset", choices=("semantickitti", "toy"))
    c.add_argument("bag", type=Path)
    c.add_argument("--folder", type=Path, default=None, help="sequence folder (default: data/)")
    c.add_argument("--labels", choices=LABEL_SOURCES, default="clean")
    c.add_argument("--scans", type=int, default=10)
    c.add_argument("--json", type=Path, default=None, help="also write the numbers here")
    r = sub.add_parser("rviz-config", help="write a copy of an RViz configuration for a screenshot")
    r.add_argument("src", type=Path)
    r.add_argument("dst", type=Path)
    r.add_argument("--topics", default=None, help="comma-separated MarkerArray topics to keep on")
    r.add_argument("--view", default=None, help="JSON object replacing the current view")
    r.add_argument("--hide-docks", action="store_true")
    r.add_argument("--size", default=None, help="WIDTHxHEIGHT of the window [px]")
    args = p.parse_args(argv)
    try:
        if args.cmd == "rviz-config":
            size = tuple(int(v) for v in args.size.split("x")) if args.size else None
            topics = args.topics.split(",") if args.topics else None
            view = json.loads(args.view) if args.view else None
            args.dst.write_text(rviz_config(args.src.read_text(), topics, view, args.hide_docks, size))
            return 0
        if args.cmd == "predictions":
            n = write_predictions(args.folder, args.out, args.labels, args.scans or None)
            print(f"wrote {n} prediction files ({args.labels}) to {args.out}")
            return 0
        if args.dataset == "semantickitti" and args.folder is None:
            from .pipeline import kitti_04_folder
            args.folder = kitti_04_folder()
        if args.dataset == "semantickitti":
            res = compare_kitti(args.bag, args.folder, args.labels, args.scans)
        else:
            res = compare_toy(args.bag, args.folder)
        text = json.dumps(res, indent=1)
        print(text)
        if args.json:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(text + "\n")
        return 0
    except (InputError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

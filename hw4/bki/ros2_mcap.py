"""The 3D semantic map as an MCAP recording of ROS 2 messages, for Foxglove or RViz 2.

:class:`MapRecorder` writes, after each inserted scan, one ``visualization_msgs/msg/MarkerArray``
on the topic ``/semantic_map`` -- as the reference node publishes it: one ``CUBE_LIST`` marker per
class (namespace = class name, id = class index, ``scale`` = the voxel edge, the class colour),
holding the centres of the occupied voxels of that class -- and, from the second scan on, one on
``/trajectory``: the sensor origins so far as a ``LINE_STRIP``. Markers are in the frame ``map`` (the world frame of
the map: for SemanticKITTI the velodyne frame of scan 0, z up; metres). A class that had voxels
before and has none now is removed with a ``DELETE`` action, so the map is always complete.

Messages use the ROS 2 Humble (and later: Iron, Jazzy) definition of ``Marker``, with its texture
and mesh-file fields. The container is written by the maintained ``mcap`` library (zstd chunks,
``ros2`` profile); the CDR payload is laid out here with numpy (the ``mcap-ros2-support`` encoder
builds a Python dict per point, slow for maps of 10^5 voxels), and the tests decode every message back with
``mcap-ros2-support``'s decoder and compare it with that library's own encoding; message
times are ``t0 + i / rate`` (the scanner's 10 Hz by default), so that ``ros2 bag play map.mcap``
or Foxglove replays the map growing. Open it in Foxglove (3D panel, fixed frame ``map``) or play
it into RViz 2 (``ros2 bag play``, then add a MarkerArray display on ``/semantic_map``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .palette import class_colors, class_names
from .voxelmap import MapView

_SEP = "=" * 80 + "\n"
_DEFS = {
    "visualization_msgs/Marker": """\
int32 ARROW=0
int32 CUBE=1
int32 SPHERE=2
int32 CYLINDER=3
int32 LINE_STRIP=4
int32 LINE_LIST=5
int32 CUBE_LIST=6
int32 SPHERE_LIST=7
int32 POINTS=8
int32 TEXT_VIEW_FACING=9
int32 MESH_RESOURCE=10
int32 TRIANGLE_LIST=11
int32 ADD=0
int32 MODIFY=0
int32 DELETE=2
int32 DELETEALL=3
std_msgs/Header header
string ns
int32 id
int32 type
int32 action
geometry_msgs/Pose pose
geometry_msgs/Vector3 scale
std_msgs/ColorRGBA color
builtin_interfaces/Duration lifetime
bool frame_locked
geometry_msgs/Point[] points
std_msgs/ColorRGBA[] colors
string texture_resource
sensor_msgs/CompressedImage texture
visualization_msgs/UVCoordinate[] uv_coordinates
string text
string mesh_resource
visualization_msgs/MeshFile mesh_file
bool mesh_use_embedded_materials
""",
    "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "builtin_interfaces/Time": "int32 sec\nuint32 nanosec\n",
    "geometry_msgs/Pose": "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Quaternion": "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "std_msgs/ColorRGBA": "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n",
    "builtin_interfaces/Duration": "int32 sec\nuint32 nanosec\n",
    "sensor_msgs/CompressedImage": "std_msgs/Header header\nstring format\nuint8[] data\n",
    "visualization_msgs/UVCoordinate": "float32 u\nfloat32 v\n",
    "visualization_msgs/MeshFile": "string filename\nuint8[] data\n",
}
MARKER_ARRAY_DEF = "visualization_msgs/Marker[] markers\n" + "".join(
    f"{_SEP}MSG: {name}\n{text}" for name, text in _DEFS.items())
"""The ``visualization_msgs/msg/MarkerArray`` definition with its dependencies, as ROS 2 records it."""

CUBE_LIST, LINE_STRIP, ADD, DELETE = 6, 4, 0, 2
FRAME = "map"


class _CDR:
    """Little-endian CDR (XCDR1, as ROS 2's Fast DDS writes it): each primitive aligned to its
    size, counted from the end of the 4-byte encapsulation header; strings carry their length
    with the terminating NUL; sequences a uint32 count."""

    def __init__(self):
        self.parts = [b"\x00\x01\x00\x00"]
        self.n = 0                                  # bytes after the encapsulation header

    def _put(self, data: bytes, align: int) -> None:
        pad = -self.n % align
        if pad:
            self.parts.append(b"\x00" * pad)
        self.parts.append(data)
        self.n += pad + len(data)

    def u32(self, v): self._put(np.uint32(v).tobytes(), 4)
    def i32(self, v): self._put(np.int32(v).tobytes(), 4)
    def f64s(self, *v): self._put(np.asarray(v, "<f8").tobytes(), 8)
    def f32s(self, *v): self._put(np.asarray(v, "<f4").tobytes(), 4)
    def boolean(self, v): self._put(b"\x01" if v else b"\x00", 1)

    def string(self, s: str) -> None:
        b = s.encode("utf-8") + b"\x00"
        self.u32(len(b))
        self._put(b, 1)

    def stamp(self, t_ns: int) -> None:
        self.i32(t_ns // 1_000_000_000)
        self.u32(t_ns % 1_000_000_000)

    def points(self, xyz: np.ndarray) -> None:
        xyz = np.ascontiguousarray(xyz, dtype="<f8").reshape(-1, 3)
        self.u32(len(xyz))
        if len(xyz):
            self._put(xyz.tobytes(), 8)

    def bytes(self) -> bytes:
        return b"".join(self.parts)


def _marker(c: _CDR, t_ns: int, ns: str, mid: int, mtype: int, action: int, scale, rgba,
            points: np.ndarray) -> None:
    """Append one ``visualization_msgs/msg/Marker`` (fields in the order of :data:`MARKER_ARRAY_DEF`)."""
    c.stamp(t_ns)
    c.string(FRAME)
    c.string(ns)
    c.i32(mid)
    c.i32(mtype)
    c.i32(action)
    c.f64s(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)       # pose: position, orientation (identity)
    c.f64s(*scale)
    c.f32s(*rgba)
    c.i32(0)                                        # lifetime 0 = forever
    c.u32(0)
    c.boolean(False)                                # frame_locked
    c.points(points)
    c.u32(0)                                        # colors: one colour per marker instead
    c.string("")                                    # texture_resource
    c.stamp(0)                                      # texture (empty CompressedImage)
    c.string("")
    c.string("")
    c.u32(0)
    c.u32(0)                                        # uv_coordinates
    c.string("")                                    # text
    c.string("")                                    # mesh_resource
    c.string("")                                    # mesh_file (empty)
    c.u32(0)
    c.boolean(False)                                # mesh_use_embedded_materials


def map_message(view: MapView, t_ns: int, previous: set | None = None) -> tuple[bytes, set]:
    """CDR bytes of a ``MarkerArray``: one ``CUBE_LIST`` of the occupied voxels per class.

    ``previous`` is the set of classes published before: those now empty get a ``DELETE``.
    Returns the message and the set of classes published now.
    """
    K = view.probs.shape[1]
    pal, names = class_colors(K) / 255.0, class_names(K)
    occ = view.occupied
    now = sorted(int(k) for k in np.unique(view.cls[occ]))
    gone = sorted((previous or set()) - set(now))
    c = _CDR()
    c.u32(len(now) + len(gone))
    edge = [view.resolution] * 3
    for k in now:
        _marker(c, t_ns, names[k], k, CUBE_LIST, ADD, edge, (*pal[k], 1.0),
                view.centres[occ & (view.cls == k)])
    for k in gone:
        _marker(c, t_ns, names[k], k, CUBE_LIST, DELETE, edge, (*pal[k], 1.0), np.zeros((0, 3)))
    return c.bytes(), set(now)


def trajectory_message(origins: np.ndarray, t_ns: int, width: float = 0.15) -> bytes:
    """CDR bytes of a ``MarkerArray`` holding the sensor origins [m] as one black ``LINE_STRIP``."""
    c = _CDR()
    c.u32(1)
    _marker(c, t_ns, "trajectory", 0, LINE_STRIP, ADD, (width, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0),
            np.asarray(origins, float))
    return c.bytes()


class MapRecorder:
    """Write the map after each scan and the trajectory into an MCAP file (see the module doc).

    Use as a context manager; :meth:`add` after each scan. With ``atomic`` (the default) the file
    is written under a temporary name and renamed to ``path`` only when the recorder closes without
    an error; on any error nothing is left. ``atomic=False`` writes ``path`` directly, for callers
    that already write to a temporary name (:class:`hw4.core.atomic.Outputs`).

    Parameters
    ----------
    path : str or Path, the ``.mcap`` file
    rate : float [Hz], scans per second of the recording's clock (message times)
    t0_ns : int, time of the first scan [ns]
    atomic : bool
    """

    def __init__(self, path, rate: float = 10.0, t0_ns: int = 1_000_000_000, atomic: bool = True):
        self.path = Path(path)
        self.atomic = atomic
        self.rate, self.t0_ns = float(rate), int(t0_ns)
        self.count = 0
        self._origins: list = []
        self._classes: set = set()

    def __enter__(self) -> "MapRecorder":
        from mcap.writer import CompressionType, Writer
        self._tmp = self.path.with_name(self.path.name + ".partial") if self.atomic else self.path
        self._file = open(self._tmp, "wb")
        self._writer = Writer(self._file, compression=CompressionType.ZSTD)
        self._writer.start(profile="ros2", library="hw4.bki.ros2_mcap")
        schema = self._writer.register_schema(name="visualization_msgs/msg/MarkerArray",
                                              encoding="ros2msg", data=MARKER_ARRAY_DEF.encode())
        self._channels = {topic: self._writer.register_channel(topic=topic, message_encoding="cdr",
                                                               schema_id=schema)
                          for topic in ("/semantic_map", "/trajectory")}
        return self

    def add(self, view: MapView, origin) -> None:
        """Record the map ``view`` after a scan whose sensor origin [m] is ``origin``."""
        t = self.t0_ns + int(round(self.count * 1e9 / self.rate))
        data, self._classes = map_message(view, t, self._classes)
        self._origins.append(np.asarray(origin, float))
        topics = [("/semantic_map", data)]
        if len(self._origins) > 1:  # a LINE_STRIP needs two points to be drawn
            topics.append(("/trajectory", trajectory_message(np.array(self._origins), t)))
        for topic, payload in topics:
            self._writer.add_message(channel_id=self._channels[topic], log_time=t, data=payload,
                                     publish_time=t, sequence=self.count)
        self.count += 1

    def __exit__(self, exc_type, exc, tb) -> None:
        ok = False
        try:
            if exc_type is None:
                self._writer.finish()
                ok = True
        finally:
            self._file.close()
            if self.atomic:
                if ok:
                    self._tmp.replace(self.path)
                else:
                    self._tmp.unlink(missing_ok=True)


def read_markers(path) -> list[tuple[str, int, dict]]:
    """Decode every message of an MCAP file written by :class:`MapRecorder`.

    Returns ``(topic, log_time_ns, message)`` tuples, the messages as decoded by
    ``mcap-ros2-support`` (attribute access: ``msg.markers[0].points[0].x``).
    """
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [(ch.topic, m.log_time, dec) for _, ch, m, dec in reader.iter_decoded_messages()]

"""Read vessel motion logs (MCAP, ROS1 bag, ROS2 bag, CSV, Parquet) into one table per topic.

Every container format ends in the same place: the raw bytes of each message, with the time the logger
received it, are collected per topic and decoded *in bulk* — messages of one topic with one byte length share
one binary layout, so a block of them is viewed as a NumPy structured array (CDR little/big endian with its
alignment, or ROS1 packing) instead of building a Python object per message. A block whose layout does not check
out (varying string lengths inside one block, odd encapsulation) falls back to the typestore's deserializer
(``rosbags``), message by message, with the same output. Hence every format gives identical tables.

Schema of a :class:`TopicTable` (spec/ecosystem.md §4.7, REP-103, SI units as in the message):

- ``time``: ``header.stamp`` (``datetime64[ns, UTC]``); ``log_time``: when the logger received it;
- Imu: ``qx qy qz qw`` (NaN when ``orientation_covariance[0] == -1``, "not provided"), ``wx wy wz`` [rad/s],
  ``ax ay az`` [m/s²];
- NavSatFix: ``latitude longitude altitude`` [deg, deg, m], ``status`` (int8, -1 = no fix);
- TwistStamped: ``vx vy vz wx wy wz``; Vector3Stamped / PointStamped: ``x y z``;
- Odometry: ``x y z qx qy qz qw vx vy vz wx wy wz`` (pose in ``frame_id``, twist in ``attrs["child_frame_id"]``).

Rows are in the order the logger received them (``log_time``, stable); header stamps are left as they are —
unsorted or duplicated stamps are repaired and counted downstream (``seatune.pipeline.motions.repair_time``).

Damaged logs (DESIGN §6): a file cut short (a logger that lost power) is read up to the cut, including the
complete messages of a half-written chunk, and the :class:`LogContents` says so in ``warnings`` and
``truncated``. Unreadable input raises :class:`~seatune.errors.UserError` naming the file and the place.
"""

from __future__ import annotations

import bz2
import os
import re
import sqlite3
import struct
import time as _time
import zlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np
import pandas as pd

from seatune.errors import UserError

__all__ = [
    "FORMATS",
    "MSGTYPES",
    "LogContents",
    "TopicTable",
    "benchmark_mcap",
    "detect_format",
    "read_log",
    "read_table_log",
]

FORMATS = ("mcap", "ros1bag", "ros2bag", "csv", "parquet")

IMU = "sensor_msgs/msg/Imu"
FIX = "sensor_msgs/msg/NavSatFix"
TWIST = "geometry_msgs/msg/TwistStamped"
ODOM = "nav_msgs/msg/Odometry"
VEC3 = "geometry_msgs/msg/Vector3Stamped"
POINT = "geometry_msgs/msg/PointStamped"
TF = "tf2_msgs/msg/TFMessage"  # read from /tf_static only: the sensors' mounting (StaticTransform)

_NS = 1_000_000_000
_MCAP_MAGIC = b"\x89MCAP0\r\n"
_BAG_MAGIC = b"#ROSBAG V2.0\n"
_SQLITE_MAGIC = b"SQLite format 3\x00"
_PARQUET_MAGIC = b"PAR1"

# -------------------------------------------------------------------------------------------------------------
# message layouts: wire order of every field, (output column or None, kind, count). The header comes first.

_F8 = "f8"


def _fields(*groups) -> list[tuple[str | None, str, int]]:
    out = []
    for g in groups:
        out.extend(g)
    return out


def _f(*names) -> list[tuple[str | None, str, int]]:
    return [(n, _F8, 1) for n in names]


def _skip(n: int, kind: str = _F8) -> list[tuple[str | None, str, int]]:
    return [(None, kind, n)]


_HEADER = {
    "cdr": [("sec", "i4", 1), ("nsec", "u4", 1), ("frame_id", "str", 1)],
    "ros1": [(None, "u4", 1), ("sec", "u4", 1), ("nsec", "u4", 1), ("frame_id", "str", 1)],
}

_BODY: dict[str, list[tuple[str | None, str, int]]] = {
    IMU: _fields(_f("qx", "qy", "qz", "qw", "ocov0"), _skip(8), _f("wx", "wy", "wz"), _skip(9),
                 _f("ax", "ay", "az"), _skip(9)),
    FIX: _fields([("status", "i1", 1), (None, "u2", 1)], _f("latitude", "longitude", "altitude"), _skip(9),
                 _skip(1, "u1")),
    TWIST: _f("vx", "vy", "vz", "wx", "wy", "wz"),
    VEC3: _f("x", "y", "z"),
    POINT: _f("x", "y", "z"),
    ODOM: _fields([("child_frame_id", "str", 1)], _f("x", "y", "z", "qx", "qy", "qz", "qw"), _skip(36),
                  _f("vx", "vy", "vz", "wx", "wy", "wz"), _skip(36)),
}

#: Supported message types → output field columns (after ``time`` and ``log_time``).
MSGTYPES: dict[str, tuple[str, ...]] = {
    IMU: ("qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az"),
    FIX: ("latitude", "longitude", "altitude", "status"),
    TWIST: ("vx", "vy", "vz", "wx", "wy", "wz"),
    ODOM: ("x", "y", "z", "qx", "qy", "qz", "qw", "vx", "vy", "vz", "wx", "wy", "wz"),
    VEC3: ("x", "y", "z"),
    POINT: ("x", "y", "z"),
}

# the same fields as attribute paths of a deserialised message (the per-message fallback)
_ATTRS: dict[str, dict[str, str]] = {
    IMU: {"qx": "orientation.x", "qy": "orientation.y", "qz": "orientation.z", "qw": "orientation.w",
          "ocov0": "orientation_covariance.0", "wx": "angular_velocity.x", "wy": "angular_velocity.y",
          "wz": "angular_velocity.z", "ax": "linear_acceleration.x", "ay": "linear_acceleration.y",
          "az": "linear_acceleration.z"},
    FIX: {"status": "status.status", "latitude": "latitude", "longitude": "longitude", "altitude": "altitude"},
    TWIST: {"vx": "twist.linear.x", "vy": "twist.linear.y", "vz": "twist.linear.z", "wx": "twist.angular.x",
            "wy": "twist.angular.y", "wz": "twist.angular.z"},
    VEC3: {"x": "vector.x", "y": "vector.y", "z": "vector.z"},
    POINT: {"x": "point.x", "y": "point.y", "z": "point.z"},
    ODOM: {"child_frame_id": "child_frame_id",
           **{c: f"pose.pose.position.{c}" for c in "xyz"},
           **{f"q{c}": f"pose.pose.orientation.{c}" for c in "xyzw"},
           **{f"v{c}": f"twist.twist.linear.{c}" for c in "xyz"},
           **{f"w{c}": f"twist.twist.angular.{c}" for c in "xyz"}},
}

_SIZE = {"i1": 1, "u1": 1, "u2": 2, "i4": 4, "u4": 4, "f8": 8, "str": 4}


def normalize_msgtype(name: str) -> str:
    """'sensor_msgs/Imu' (ROS1, MCAP ros1msg schema) → 'sensor_msgs/msg/Imu'."""
    parts = name.strip().strip("/").split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    return "/".join(parts)


# -------------------------------------------------------------------------------------------------------------
# public data


@dataclass
class TopicTable:
    """One topic of a log as a table (see the module docstring for the columns)."""

    topic: str
    msgtype: str
    frame_id: str
    table: pd.DataFrame
    source: str | None = None  # the log file it came from (for messages)


@dataclass(frozen=True)
class StaticTransform:
    """One transform of ``/tf_static``: the pose of ``child`` in ``parent`` (v_parent = R v_child + t)."""

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]  # quaternion (x, y, z, w)


@dataclass
class LogContents:
    """Everything read from one log."""

    path: Path
    format: str
    topics: dict[str, TopicTable]
    warnings: list[str] = field(default_factory=list)
    truncated: bool = False
    skipped: dict[str, str] = field(default_factory=dict)  # topic → message type of topics not read
    static_transforms: list[StaticTransform] = field(default_factory=list)  # from /tf_static

    def of_type(self, msgtype: str) -> list[TopicTable]:
        """Topics of one message type (ROS1 or ROS2 spelling), largest first."""
        msgtype = normalize_msgtype(msgtype)
        return sorted((t for t in self.topics.values() if t.msgtype == msgtype), key=lambda t: -len(t.table))


# -------------------------------------------------------------------------------------------------------------
# format detection


def detect_format(path: str | os.PathLike) -> str:
    """The log format from the content: "mcap", "ros1bag", "ros2bag", "csv" or "parquet".

    MCAP magic, ``#ROSBAG V2.0``, a rosbag2 directory (``metadata.yaml`` or ``*.db3`` / ``*.mcap`` storage files)
    or a bare ``.db3`` (SQLite) storage file, Parquet ``PAR1``, and delimited text with a header line. The file
    extension is not trusted.
    """
    p = Path(path)
    if not p.exists():
        raise UserError(str(p), None, "no such file or directory")
    if p.is_dir():
        if (p / "metadata.yaml").is_file() or _storage_files(p):
            return "ros2bag"
        raise UserError(str(p), None, "a directory without metadata.yaml or .db3/.mcap storage files is not a "
                                      "ROS2 bag")
    size = p.stat().st_size
    if size == 0:
        raise UserError(str(p), None, "empty file (0 bytes)")
    with open(p, "rb") as f:
        head = f.read(65536)
    if head.startswith(_MCAP_MAGIC):
        return "mcap"
    if head.startswith(b"#ROSBAG V"):
        if not head.startswith(_BAG_MAGIC):
            version = head[:16].split(b"\n")[0].decode("ascii", "replace")
            raise UserError(str(p), "file header", f"unsupported ROS bag version {version!r} (only V2.0)")
        return "ros1bag"
    if head.startswith(_SQLITE_MAGIC):
        return "ros2bag"
    if head.startswith(_PARQUET_MAGIC):
        return "parquet"
    if _looks_like_table_text(head):
        return "csv"
    raise UserError(str(p), "first bytes", f"unknown log format (starts {head[:8]!r}): not MCAP, a ROS1 bag, "
                                           "a ROS2 bag, CSV or Parquet")


def _looks_like_table_text(head: bytes) -> bool:
    if b"\x00" in head:
        return False
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as err:  # the buffer may end inside a multi-byte character
        if err.start < len(head) - 4:
            return False
        text = head[: err.start].decode("utf-8")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        return False
    sep = _delimiter(lines[0])
    return sep is not None and len(lines[0].split(sep)) >= 2


def _delimiter(line: str) -> str | None:
    counts = {s: line.count(s) for s in (",", ";", "\t")}
    sep = max(counts, key=counts.get)
    return sep if counts[sep] else None


def _storage_files(directory: Path) -> list[Path]:
    return sorted(f for f in directory.iterdir() if f.is_file() and f.suffix in (".db3", ".mcap"))


# -------------------------------------------------------------------------------------------------------------
# collecting raw messages per topic, decoding in blocks


class _Result:
    """What a container reader found: per-topic sinks, warnings, and whether the file was cut short."""

    def __init__(self, path: Path, topics: Iterable[str] | None):
        self.path = path
        self.wanted = None if topics is None else set(topics)
        self.sinks: dict[str, _Sink] = {}
        self.skipped: dict[str, str] = {}  # topic → msgtype of topics not read (unsupported type)
        self.tf_static: _Sink | None = None  # raw /tf_static messages, decoded one by one at the end
        self.warnings: list[str] = []
        self.truncated = False
        self.cut_note: str | None = None

    def sink(self, topic: str, msgtype: str, encoding: str) -> _Sink | None:
        """The sink of a topic, or None when the topic is not read (filtered out or of an unsupported type)."""
        msgtype = normalize_msgtype(msgtype)
        if self.wanted is not None and topic not in self.wanted:
            return None
        s = self.sinks.get(topic)
        if s is not None:
            if s.msgtype != msgtype or s.encoding != encoding:
                self.warnings.append(f"{self.path.name}: topic {topic} also published as {msgtype} ({encoding}); "
                                     f"only its {s.msgtype} messages are read")
                return None
            return s
        if msgtype == TF and topic == "/tf_static" and encoding in ("cdr", "ros1"):
            if self.tf_static is None:
                self.tf_static = _Sink(topic, msgtype, encoding)
            return self.tf_static
        if msgtype not in _BODY or encoding not in ("cdr", "ros1"):
            self.skipped[topic] = msgtype if encoding in ("cdr", "ros1") else f"{msgtype}, {encoding} encoding"
            return None
        s = self.sinks[topic] = _Sink(topic, msgtype, encoding)
        return s

    def flush_large(self, limit: int = 100_000) -> None:
        for s in self.sinks.values():
            if len(s.raw) >= limit:
                s.flush()

    @property
    def count(self) -> int:
        return sum(s.count for s in self.sinks.values())

    @property
    def last_log_ns(self) -> int | None:
        ends = [s.last_log for s in self.sinks.values() if s.last_log is not None]
        return max(ends) if ends else None


class _Sink:
    """Raw payloads and log times of one topic; decoded into column blocks every so often (bounded memory)."""

    __slots__ = ("topic", "msgtype", "encoding", "raw", "log", "parts", "count", "last_log", "corrupt")

    def __init__(self, topic: str, msgtype: str, encoding: str):
        self.topic, self.msgtype, self.encoding = topic, msgtype, encoding
        self.raw: list[bytes] = []
        self.log: list[int] = []
        self.parts: list[dict] = []
        self.count = 0
        self.corrupt = 0
        self.last_log: int | None = None

    def flush(self) -> None:
        if not self.raw:
            return
        part = _decode(self.raw, self.msgtype, self.encoding)
        log = np.asarray(self.log, dtype=np.int64)
        keep = part.pop("keep")
        if keep is not None:
            self.corrupt += len(log) - int(keep.sum())
            log = log[keep]
        part["log"] = log
        self.count += len(log)
        if len(log):
            self.last_log = max(int(log.max()), self.last_log or int(log[0]))
        self.parts.append(part)
        self.raw.clear()  # in place: readers hold the lists' bound append methods
        self.log.clear()

    def table(self, source: str, warnings: list[str]) -> TopicTable:
        self.flush()
        cols = MSGTYPES[self.msgtype]
        parts = self.parts
        stamp, log = (np.concatenate([p.pop(c) for p in parts]) for c in ("stamp", "log"))
        data = {c: np.concatenate([p.pop(c) for p in parts]) for c in cols}  # each block freed as it is joined
        order = np.argsort(log, kind="stable")
        if (np.diff(order) != 1).any():  # not already in receive order
            stamp, log = stamp[order], log[order]
            data = {c: v[order] for c, v in data.items()}
        frames = _merge_counts([p["frames"] for p in parts])
        frame_id = max(frames, key=frames.get) if frames else ""
        if len(frames) > 1:
            warnings.append(f"{Path(source).name}: topic {self.topic} has several frame_ids "
                            f"({', '.join(f'{k!r}: {v:,}' for k, v in frames.items())}); using {frame_id!r}")
        df = pd.DataFrame({"time": _utc(stamp), "log_time": _utc(log), **data}, copy=False)
        if self.msgtype == ODOM:
            children = _merge_counts([p["children"] for p in parts])
            df.attrs["child_frame_id"] = max(children, key=children.get) if children else ""
        return TopicTable(self.topic, self.msgtype, frame_id, df, source)


def _merge_counts(dicts: Iterable[dict[str, int]]) -> dict[str, int]:
    out: dict[str, int] = {}
    for d in dicts:
        for k, v in d.items():
            out[k] = out.get(k, 0) + v
    return out


def _utc(ns: np.ndarray) -> pd.Series:
    return pd.Series(pd.DatetimeIndex(np.asarray(ns, dtype=np.int64).view("datetime64[ns]"), tz="UTC"))


def _decode(raws: list[bytes], msgtype: str, encoding: str) -> dict:
    """Decode payloads of one topic: {column: array, 'stamp': int64 ns, 'frames': {frame_id: count},
    'keep': bool mask of the messages that decoded (None = all)}."""
    n = len(raws)
    lens = np.fromiter(map(len, raws), dtype=np.int64, count=n)
    if n and (lens == lens[0]).all():
        groups = [(np.arange(n), int(lens[0]))]
    else:
        groups = [(np.flatnonzero(lens == L), int(L)) for L in np.unique(lens)]
    parts = []
    for idx, L in groups:
        sub = raws if len(groups) == 1 else [raws[i] for i in idx.tolist()]
        if L < 16:
            parts.append((idx, None, sub))
            continue
        buf = np.frombuffer(b"".join(sub), dtype=np.uint8).reshape(len(sub), L)
        # header.frame_id's length sits at byte 12 in both encodings; in CDR, alignment padding can give
        # messages with different frame_ids one total length: split such a block by that length too
        key = buf[:, 12:16].copy().view(np.uint32).ravel()
        if (key == key[0]).all():
            parts.append((idx, buf, sub))
        else:
            for k in np.unique(key):
                m = np.flatnonzero(key == k)
                parts.append((idx[m], buf[m], [sub[i] for i in m.tolist()]))
    blocks = []
    for idx, buf, sub in parts:
        block = None if buf is None else _decode_block(buf, msgtype, encoding)
        if block is None:
            block = _decode_slow(sub, msgtype, encoding)
            idx = idx[block.pop("keep")]
        blocks.append((idx, block))
    kept = sum(len(b[0]) for b in blocks)
    if len(blocks) == 1:
        out = _finish(blocks[0][1], msgtype)
    else:
        order = np.argsort(np.concatenate([b[0] for b in blocks]), kind="stable")
        merged = {"frames": _merge_counts(b[1]["frames"] for b in blocks),
                  "children": _merge_counts(b[1].get("children", {}) for b in blocks)}
        for key in blocks[0][1]:
            if key not in merged:
                merged[key] = np.concatenate([b[1][key] for b in blocks])[order]
        out = _finish(merged, msgtype)
    out["keep"] = None
    if kept < n:
        keep = np.zeros(n, dtype=bool)
        for idx, _ in blocks:
            keep[idx] = True
        out["keep"] = keep
    return out


def _finish(block: dict, msgtype: str) -> dict:
    out = {"stamp": block["sec"].astype(np.int64) * _NS + block["nsec"].astype(np.int64),
           "frames": block["frames"], "children": block.get("children", {})}
    for c in MSGTYPES[msgtype]:
        v = block[c]
        out[c] = v.astype(np.int8) if c == "status" else v.astype(np.float64)
    if msgtype == IMU:  # sensor_msgs/Imu: orientation_covariance[0] == -1 → orientation not provided
        absent = block["ocov0"] == -1.0
        if absent.any():
            for c in ("qx", "qy", "qz", "qw"):
                out[c][absent] = np.nan
    return out


def _layout(msgtype: str, row: bytes, encoding: str, endian: str):
    """(numeric fields [(name, kind, offset)], strings [(name, offset, length)], end) of one serialised message,
    or None when the bytes do not fit the definition. CDR (XCDR1, as ROS2 uses it): 4-byte encapsulation header,
    every primitive aligned to its size relative to the end of that header, strings = uint32 length including a
    terminating NUL. ROS1: packed, strings = uint32 length without NUL."""
    cdr = encoding == "cdr"
    base = 4 if cdr else 0
    pos = 0
    numeric, strings = [], []
    unpack_u32 = struct.Struct(endian + "I").unpack_from
    for name, kind, count in _HEADER[encoding] + _BODY[msgtype]:
        size = _SIZE[kind]
        if cdr and size > 1:
            pos = (pos + size - 1) // size * size
        if base + pos + size * (1 if kind == "str" else count) > len(row):
            return None
        if kind == "str":
            length = unpack_u32(row, base + pos)[0]
            if base + pos + 4 + length > len(row) or (cdr and length == 0):
                return None
            strings.append((name, base + pos, length))
            pos += 4 + length
        else:
            if name is not None:
                numeric.append((name, kind, base + pos))
            pos += size * count
    end = base + pos
    if end > len(row) or len(row) - end >= (8 if cdr else 1):  # CDR payloads may end in alignment padding
        return None
    return numeric, strings, end


def _decode_block(buf: np.ndarray, msgtype: str, encoding: str) -> dict | None:
    """Vectorised decode of k messages of identical length L (buf: k × L bytes); None if the layout fails."""
    k, L = buf.shape
    row0 = buf[0].tobytes()
    endian = "<"
    if encoding == "cdr":
        if row0[:2] == b"\x00\x01":
            endian = "<"
        elif row0[:2] == b"\x00\x00":
            endian = ">"
        else:
            return None
        if k > 1 and not (buf[:, :2] == buf[0, :2]).all():
            return None
    lay = _layout(msgtype, row0, encoding, endian)
    if lay is None:
        return None
    numeric, strings, _ = lay
    for _, off, _ in strings:  # every message must have the same string lengths, hence the same layout
        if k > 1 and not (buf[:, off:off + 4] == buf[0, off:off + 4]).all():
            return None
    dtype = np.dtype({"names": [n for n, _, _ in numeric], "formats": [endian + kind for _, kind, _ in numeric],
                      "offsets": [o for _, _, o in numeric], "itemsize": L})
    rec = buf.reshape(-1).view(dtype)
    out = {n: rec[n] for n, _, _ in numeric}
    nul = 1 if encoding == "cdr" else 0
    for name, off, length in strings:
        a, b = off + 4, off + 4 + length - nul
        col = buf[:, a:b]
        if k == 1 or (col == col[0]).all():
            counts = {row0[a:b].decode("utf-8", "replace"): k}
        else:
            counts = {}
            for s in map(bytes, col):
                key = s.decode("utf-8", "replace")
                counts[key] = counts.get(key, 0) + 1
        out["frames" if name == "frame_id" else "children"] = counts
    return out


@lru_cache(maxsize=2)
def _typestore(encoding: str):
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if encoding == "ros1" else Stores.ROS2_HUMBLE)


def _decode_slow(raws: list[bytes], msgtype: str, encoding: str) -> dict:
    """Message-by-message decode with the rosbags typestore (the fallback of `_decode_block`)."""
    ts = _typestore(encoding)
    deser = ts.deserialize_ros1 if encoding == "ros1" else ts.deserialize_cdr
    attrs = _ATTRS[msgtype]
    getters = {c: _getter(p) for c, p in attrs.items() if c != "child_frame_id"}
    cols: dict[str, list] = {c: [] for c in getters}
    sec, nsec, frames, children = [], [], {}, {}
    keep = np.zeros(len(raws), dtype=bool)
    for i, raw in enumerate(raws):
        try:
            m = deser(raw, msgtype)
            values = [g(m) for g in getters.values()]
        except Exception:  # noqa: BLE001 - any deserializer failure is a corrupt message: skipped, counted
            continue
        keep[i] = True
        st = m.header.stamp
        sec.append(st.sec)
        nsec.append(st.nanosec)
        frames[m.header.frame_id] = frames.get(m.header.frame_id, 0) + 1
        if msgtype == ODOM:
            children[m.child_frame_id] = children.get(m.child_frame_id, 0) + 1
        for c, v in zip(getters, values, strict=True):
            cols[c].append(v)
    out = {c: np.asarray(v, dtype=np.float64) for c, v in cols.items()}
    out["keep"] = keep
    out.update(sec=np.asarray(sec, dtype=np.int64), nsec=np.asarray(nsec, dtype=np.int64), frames=frames,
               children=children)
    return out


def _getter(path: str) -> Callable:
    parts = path.split(".")

    def get(m):
        for p in parts:
            m = m[int(p)] if p.isdigit() else getattr(m, p)
        return m

    return get


# -------------------------------------------------------------------------------------------------------------
# MCAP


_MCAP_REC = struct.Struct("<BQ")
_MCAP_HEAD = struct.Struct("<BQHIQ")  # opcode, length, then a Message's channel_id, sequence, log_time


class _McapState:
    def __init__(self, res: _Result):
        self.res = res
        self.schemas: dict[int, tuple[str, str]] = {}  # id → (name, encoding)
        self.channels: dict[int, tuple | None] = {}  # id → (raw.append, log.append) or None (skipped)
        self.unknown_channel = 0

    def schema(self, sid: int, name: str, encoding: str) -> None:
        self.schemas[sid] = (name, encoding)

    def channel(self, cid: int, sid: int, topic: str, message_encoding: str) -> None:
        if cid in self.channels:
            return
        name = self.schemas.get(sid, ("", ""))[0]
        s = self.res.sink(topic, name or "?", message_encoding)
        self.channels[cid] = None if s is None else (s.raw.append, s.log.append)

    def scan(self, data: bytes) -> bool:
        """Walk the records of a chunk (or the tail of a cut chunk); True if it ends inside a record.

        The hot loop: one struct call reads a record's opcode, length, channel id, sequence and log time at once
        (meaningful only for a Message; other records are re-read properly)."""
        unpack_head = _MCAP_HEAD.unpack_from
        unpack_rec = _MCAP_REC.unpack_from
        get = self.channels.get
        n, pos = len(data), 0
        last = n - _MCAP_HEAD.size
        while pos + 9 <= n:
            if pos <= last:
                op, length, cid, _, log_ns = unpack_head(data, pos)
            else:
                op, length = unpack_rec(data, pos)
                cid = log_ns = None
            end = pos + 9 + length
            if end > n:
                return True
            if op == 0x05 and cid is not None:  # Message: channel_id, sequence, log_time, publish_time, data
                sink = get(cid, False)
                if sink:
                    sink[0](data[pos + 31:end])
                    sink[1](log_ns)
                elif sink is False:
                    self.unknown_channel += 1
            elif op == 0x04:  # Channel
                self._channel_record(data[pos + 9:end])
            elif op == 0x03:  # Schema
                self._schema_record(data[pos + 9:end])
            elif op == 0x05:
                return True  # a message record shorter than its fixed fields: damaged
            pos = end
        return pos != n

    def _schema_record(self, body: bytes) -> None:
        from mcap.data_stream import ReadDataStream
        from mcap.records import Schema

        rec = Schema.read(ReadDataStream(_BytesIO(body)))
        self.schema(rec.id, rec.name, rec.encoding)

    def _channel_record(self, body: bytes) -> None:
        from mcap.data_stream import ReadDataStream
        from mcap.records import Channel

        rec = Channel.read(ReadDataStream(_BytesIO(body)))
        self.channel(rec.id, rec.schema_id, rec.topic, rec.message_encoding)


def _BytesIO(b: bytes):
    from io import BytesIO

    return BytesIO(b)


def _decompress(compression: str, data: bytes, size: int | None, partial: bool) -> bytes:
    """Chunk contents; for a cut chunk (`partial`) as much as the streaming decompressor gives."""
    if compression in ("", "none"):
        return data
    if compression == "zstd":
        import zstandard

        if partial:
            return zstandard.ZstdDecompressor().decompressobj().decompress(data)
        return zstandard.decompress(data, size or 0)
    if compression == "lz4":
        import lz4.frame

        if partial:
            return lz4.frame.LZ4FrameDecompressor().decompress(data)
        return lz4.frame.decompress(data)
    if compression == "bz2":
        return bz2.BZ2Decompressor().decompress(data) if partial else bz2.decompress(data)
    raise ValueError(f"unsupported chunk compression {compression!r}")


def _lean_stream_reader():
    """mcap's StreamReader that skips MessageIndex records unparsed (they are 16 B per message and only serve
    seeking; parsing them costs more than the messages themselves). Overrides a private hook of mcap's reader;
    should it disappear, the plain StreamReader is used, which is slower but gives the same result."""
    from mcap.opcode import Opcode
    from mcap.stream_reader import StreamReader

    class _Lean(StreamReader):
        record_start = 0  # offset of the last record read, from where the stream started

        def _read_record(self, opcode, length):
            self.record_start = self._stream.count - 9  # opcode and length are read
            if opcode == Opcode.MESSAGE_INDEX:
                self._stream.read(length)
                return None
            return super()._read_record(opcode, length)

    return _Lean if hasattr(StreamReader, "_read_record") else StreamReader


def _read_mcap(path: Path, res: _Result) -> None:
    """MCAP in file order with mcap's non-seeking stream reader (no summary, no message index needed): Schema and
    Channel records as they come, each Chunk decompressed and walked by `_McapState.scan`. A file cut short ends
    in McapError / struct.error / EndOfFile; the complete messages of the half-written last chunk are salvaged.

    CRCs: a chunk whose contents fail its ``uncompressed_crc`` (or do not decompress) is dropped whole and named
    in a warning (byte offset, time range); the data-section CRC of DataEnd, where written, is checked too. A chunk
    without a CRC (0) is read up to any damage, as before."""
    from mcap.exceptions import McapError
    from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Schema

    state = _McapState(res)
    damaged: list[str] = []
    dropped: list[str] = []  # chunks failing their CRC or decompression: none of their messages kept
    resumed: list[list] = []  # [where and why, offset resumed at] of unreadable records stepped over
    summary: list = []  # [mcap Summary or None] once looked at
    seen: set[int] = set()  # start offsets of the chunks read
    last_good = pos = len(_MCAP_MAGIC)
    complete = False
    data_end = None  # (offset, crc) of DataEnd
    with open(path, "rb") as f:
        if f.read(len(_MCAP_MAGIC)) != _MCAP_MAGIC:
            raise UserError(str(path), "first bytes", "not an MCAP file (no MCAP magic)")
        while pos is not None:
            base = 0 if pos == len(_MCAP_MAGIC) else pos
            f.seek(base)
            reader = _lean_stream_reader()(f, emit_chunks=True, skip_magic=base != 0)
            at, pos = last_good, None
            try:
                for rec in reader.records:
                    at = base + reader.record_start if hasattr(reader, "record_start") else last_good
                    if isinstance(rec, Chunk):
                        seen.add(at)
                        try:
                            data = _decompress(rec.compression, rec.data, rec.uncompressed_size, partial=False)
                        except Exception as err:  # noqa: BLE001 - a chunk that does not decompress is dropped
                            data, problem = None, f"does not decompress ({_err(err)})"
                        else:
                            problem = (None if not rec.uncompressed_crc or zlib.crc32(data) == rec.uncompressed_crc
                                       else "fails its CRC")
                        if problem is not None:
                            _summary_channels(path, state, summary)  # the chunk may have declared channels
                            dropped.append(f"byte {at:,}{_chunk_span(rec)} {problem}")
                        else:
                            try:
                                if state.scan(data):
                                    raise ValueError("a record runs past the chunk's end")
                            except Exception as err:  # noqa: BLE001 - damage in a chunk without a CRC: keep what it gave
                                damaged.append(f"byte {at:,} ({_err(err)})")
                        res.flush_large()
                    elif isinstance(rec, Message):
                        sink = state.channels.get(rec.channel_id)
                        if sink:
                            sink[0](rec.data)
                            sink[1](rec.log_time)
                    elif isinstance(rec, Schema):
                        state.schema(rec.id, rec.name, rec.encoding)
                    elif isinstance(rec, Channel):
                        state.channel(rec.id, rec.schema_id, rec.topic, rec.message_encoding)
                    elif isinstance(rec, DataEnd):
                        complete = True  # everything after is summary
                        data_end = (at, rec.data_section_crc)
                    elif isinstance(rec, Footer):
                        complete = True
                    last_good = f.tell()
            except (McapError, struct.error, EOFError, UnicodeDecodeError, ValueError, MemoryError) as err:
                if complete:  # a damaged summary section after DataEnd loses nothing
                    res.warnings.append(f"{path.name}: summary section damaged after the data ({_err(err)}); "
                                        "all messages were read")
                    break
                pos, lost = _resume_at(path, state, summary, seen, at)
                if pos is not None:  # a damaged record header mid-file: go on at the next indexed chunk
                    if not (resumed and at == base == last_good):  # else: the chunk resumed at failed at once
                        resumed.append([f"after byte {last_good:,} ({_err(err)})", pos])
                    resumed[-1][1] = pos
                    dropped += [f"byte {c.chunk_start_offset:,}{_chunk_span(c)} unreachable" for c in lost]
                    last_good = pos
                    continue
                res.truncated = True
                salvaged = _salvage_mcap_tail(f, last_good, state)
                res.cut_note = (f"file cut short (no footer) at byte {last_good:,} of {path.stat().st_size:,}: "
                                f"{_err(err)}" + (f"; {salvaged:,} messages of the last chunk recovered"
                                                  if salvaged else ""))
        if (data_end is not None and data_end[1] and not dropped and not resumed
                and _crc_of(f, data_end[0]) != data_end[1]):
            res.warnings.append(f"{path.name}: the data section fails its CRC (DataEnd at byte {data_end[0]:,}) "
                                "although every chunk passes its own: the damage is outside the messages "
                                "(a chunk header, a message index or a record between chunks)")
    if resumed:
        res.warnings.append(f"{path.name}: unreadable record(s) stepped over with the summary's chunk index: "
                            + "; ".join(f"{note}, resumed at byte {at:,}" for note, at in resumed[:5]))
    if dropped:
        kept = res.count + sum(len(s.raw) for s in res.sinks.values())
        if not kept and not res.truncated:
            raise UserError(str(path), f"chunk at {dropped[0]}", f"nothing readable: every chunk is damaged "
                            f"({len(dropped)} dropped)")
        res.warnings.append(f"{path.name}: {len(dropped)} damaged chunk(s) dropped with all their messages: "
                            + "; ".join(dropped[:5]) + ("; …" if len(dropped) > 5 else ""))
    if damaged:
        res.warnings.append(f"{path.name}: {len(damaged)} damaged chunk(s) read up to the damage: "
                            + "; ".join(damaged[:5]))
    if state.unknown_channel:
        res.warnings.append(f"{path.name}: {state.unknown_channel:,} messages on channels never declared "
                            "were skipped")


def _chunk_span(rec) -> str:
    """" (messages <start> to <end> UTC)" of a Chunk record, or "" when its times are not plausible."""
    try:
        a, b = (pd.Timestamp(int(t), unit="ns", tz="UTC") for t in (rec.message_start_time, rec.message_end_time))
    except (ValueError, OverflowError, pd.errors.OutOfBoundsDatetime):
        return ""
    return f" (messages {a:%Y-%m-%d %H:%M:%S} to {b:%H:%M:%S} UTC)"


def _crc_of(f, size: int) -> int:
    """CRC-32 of the first `size` bytes of the open file (the MCAP data section), read in 16 MiB blocks."""
    f.seek(0)
    crc = 0
    while size > 0:
        block = f.read(min(size, 1 << 24))
        if not block:
            break
        crc = zlib.crc32(block, crc)
        size -= len(block)
    return crc


def _summary_channels(path: Path, state: _McapState, cache: list):
    """The summary section (None when absent or unsound; looked up once, kept in `cache`), its schemas and
    channels registered, so that a dropped chunk that declared them does not orphan later chunks' messages."""
    if cache:
        return cache[0]
    from mcap.reader import make_reader

    try:
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
    except Exception:  # noqa: BLE001 - no (sound) summary: channels come only from the chunks
        summary = None
    cache.append(summary)
    if summary is not None:
        for sid, sch in summary.schemas.items():
            state.schema(sid, sch.name, sch.encoding)
        for cid, ch in summary.channels.items():
            state.channel(cid, ch.schema_id, ch.topic, ch.message_encoding)
    return summary


def _resume_at(path: Path, state: _McapState, cache: list, seen: set[int], after: int) -> tuple[int | None, list]:
    """(offset of the next indexed chunk not read yet that starts after `after`, the indexed chunks stepped over)
    from the summary's chunk index; (None, []) without a sound summary."""
    summary = _summary_channels(path, state, cache)
    if summary is None:
        return None, []
    todo = sorted((c for c in summary.chunk_indexes if c.chunk_start_offset not in seen),
                  key=lambda c: c.chunk_start_offset)
    nxt = next((c for c in todo if c.chunk_start_offset > after), None)
    if nxt is None:
        return None, []
    return nxt.chunk_start_offset, [c for c in todo if c.chunk_start_offset < nxt.chunk_start_offset]


def _err(err: BaseException) -> str:
    text = str(err).strip()
    return type(err).__name__ + (f" {text}" if text else "")


def _salvage_mcap_tail(f, offset: int, state: _McapState) -> int:
    """Messages of the cut record at `offset` when it is a Chunk (zstd/lz4 streams decode up to the cut)."""
    f.seek(offset)
    tail = f.read()
    before = state.res.count + sum(len(s.raw) for s in state.res.sinks.values())
    try:
        if len(tail) < 9 or tail[0] != 0x06:
            return 0
        pos = 9
        pos += 8 + 8  # message_start_time, message_end_time
        usize = struct.unpack_from("<Q", tail, pos)[0]
        pos += 8 + 4  # uncompressed_size, uncompressed_crc
        clen = struct.unpack_from("<I", tail, pos)[0]
        compression = tail[pos + 4:pos + 4 + clen].decode("utf-8")
        pos += 4 + clen + 8  # records length
        data = _decompress(compression, tail[pos:], usize, partial=True)
        state.scan(data)
    except Exception:  # noqa: BLE001 - salvage is best effort: whatever decodes before the damage is kept
        pass
    return state.res.count + sum(len(s.raw) for s in state.res.sinks.values()) - before


# -------------------------------------------------------------------------------------------------------------
# ROS1 bag


def _read_ros1(path: Path, res: _Result) -> None:
    """Indexed bags with rosbags (AnyReader for ``*.bag``); a bag without (a sound) index — a recorder that died,
    a cut copy — or with a damaged chunk, with `_scan_ros1_bag`."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag1 import Reader

    try:
        # AnyReader picks the ROS version from the suffix; the format was detected from the content
        reader = AnyReader([path]) if path.suffix == ".bag" else Reader(path)
        _via_rosbags(reader, res, "ros1")
    except Exception as err:  # noqa: BLE001 - whatever rosbags refuses, the record scanner reads what it can
        res.warnings.append(f"{path.name}: rosbags cannot read it ({_rosbags_error(err)}); scanning its records")
        res.sinks, res.skipped = {}, {}
        _scan_ros1_bag(path, res)


def _rosbags_error(err: BaseException) -> str:
    return " ".join(str(a) for a in err.args).strip() or type(err).__name__


def _via_rosbags(reader, res: _Result, encoding: str) -> None:
    """Every wanted message of an (Any)Reader into the sinks; raises whatever rosbags raises."""
    reader.open()
    try:
        sinks = {}
        for c in reader.connections:
            s = res.sink(c.topic, c.msgtype, encoding)
            sinks[id(c)] = None if s is None else (s.raw.append, s.log.append)
        wanted = [c for c in reader.connections if sinks[id(c)] is not None]
        if wanted:
            _pump(((id(c), t, raw) for c, t, raw in reader.messages(connections=wanted)), sinks, res)
    finally:
        reader.close()


def _pump(messages, sinks: dict, res: _Result) -> None:
    """(key, log_ns, raw) → sinks; the per-message work is a dict lookup and two appends."""
    i = 0
    for i, (key, t, raw) in enumerate(messages, 1):  # noqa: B007
        sink = sinks[key]
        sink[0](bytes(raw))
        sink[1](t)
        if not i & 0xFFFF:
            res.flush_large()


_BAG_OP_MSG, _BAG_OP_HEADER, _BAG_OP_INDEX, _BAG_OP_CHUNK, _BAG_OP_CHUNKINFO, _BAG_OP_CONN = 2, 3, 4, 5, 6, 7
_U32 = struct.Struct("<I")


def _bag_fields(buf: bytes, start: int, end: int) -> dict[bytes, bytes]:
    """A ROS1 record header: repeated (uint32 length, b"name=value")."""
    out = {}
    unpack = _U32.unpack_from
    pos = start
    while pos + 4 <= end:
        (n,) = unpack(buf, pos)
        pos += 4
        if pos + n > end:
            raise ValueError("header field runs past the header")
        name, eq, value = buf[pos:pos + n].partition(b"=")
        if not eq:
            raise ValueError("header field without '='")
        out[name] = value
        pos += n
    if pos != end:
        raise ValueError("header length mismatch")
    return out


class _BagScanner:
    """ROS1 bag format 2.0 record walker: bag header, chunks (none/bz2/lz4) holding connection and message
    records, index records (skipped). Works without the index section, i.e. on an unindexed or cut bag."""

    def __init__(self, res: _Result):
        self.res = res
        self.conns: dict[int, tuple | None] = {}
        self.damaged: list[str] = []

    def connection(self, fields: dict, data: bytes) -> None:
        cid = _U32.unpack(fields[b"conn"])[0]
        if cid in self.conns:
            return
        info = _bag_fields(data, 0, len(data))
        topic = (info.get(b"topic") or fields.get(b"topic", b"")).decode()
        msgtype = info.get(b"type", b"?").decode()
        s = self.res.sink(topic, msgtype, "ros1")
        self.conns[cid] = None if s is None else (s.raw.append, s.log.append)

    def records(self, buf: bytes, pos: int, outer: bool) -> tuple[int, bool]:
        """Walk records from `pos`; returns (end of the last complete record, ended inside a record)."""
        n = len(buf)
        unpack = _U32.unpack_from
        conns = self.conns
        while pos < n:
            if pos + 4 > n:
                return pos, True
            (hlen,) = unpack(buf, pos)
            hstart = pos + 4
            dpos = hstart + hlen
            if dpos + 4 > n:
                return pos, True
            fields = _bag_fields(buf, hstart, dpos)
            (dlen,) = unpack(buf, dpos)
            dstart = dpos + 4
            dend = dstart + dlen
            op = fields.get(b"op", b"\x00")[0]
            if dend > n:
                if outer and op == _BAG_OP_CHUNK:  # the cut chunk: salvage the messages that made it
                    self.chunk(fields, buf[dstart:], partial=True)
                return pos, True
            if op == _BAG_OP_MSG:
                sink = conns.get(unpack(fields[b"conn"], 0)[0])
                if sink:
                    sec, nsec = struct.unpack("<II", fields[b"time"])
                    sink[0](buf[dstart:dend])
                    sink[1](sec * _NS + nsec)
            elif op == _BAG_OP_CONN:
                self.connection(fields, buf[dstart:dend])
            elif op == _BAG_OP_CHUNK:
                if not outer:
                    raise ValueError("chunk inside a chunk")
                self.chunk(fields, buf[dstart:dend], partial=False)
                self.res.flush_large()
            elif op not in (_BAG_OP_HEADER, _BAG_OP_INDEX, _BAG_OP_CHUNKINFO):
                raise ValueError(f"unknown record op {op}")
            pos = dend
        return pos, False

    def chunk(self, fields: dict, data: bytes, partial: bool) -> None:
        compression = fields.get(b"compression", b"none").decode()
        size = _U32.unpack(fields[b"size"])[0] if b"size" in fields else None
        try:
            raw = _decompress(compression, data, size, partial)
        except Exception as err:  # noqa: BLE001 - a chunk that does not decompress is skipped, and said so
            if not partial:
                self.damaged.append(_err(err))
            return
        try:
            _, cut = self.records(raw, 0, outer=False)
            if cut and not partial:
                raise ValueError("a record runs past the chunk's end")
        except (ValueError, KeyError, struct.error, IndexError, UnicodeDecodeError) as err:
            if not partial:
                self.damaged.append(_err(err))


def _scan_ros1_bag(path: Path, res: _Result) -> None:
    buf = path.read_bytes()
    if not buf.startswith(_BAG_MAGIC):
        raise UserError(str(path), "first bytes", "not a ROS1 bag (no '#ROSBAG V2.0' magic)")
    scanner = _BagScanner(res)
    pos = len(_BAG_MAGIC)
    indexed = False
    try:
        (hlen,) = _U32.unpack_from(buf, pos)
        fields = _bag_fields(buf, pos + 4, pos + 4 + hlen)
        indexed = struct.unpack("<Q", fields.get(b"index_pos", bytes(8)))[0] != 0
        end, cut = scanner.records(buf, pos, outer=True)
        where = f"byte {end:,} of {len(buf):,}"
        if cut:
            res.truncated = True
            res.cut_note = f"file cut short at {where} ({'index lost' if indexed else 'bag not closed: no index'})"
        elif not indexed:
            res.truncated = True
            res.cut_note = "bag not indexed (the recorder did not close it)"
    except (ValueError, KeyError, struct.error, IndexError, UnicodeDecodeError) as err:
        res.truncated = True
        res.cut_note = f"damaged record ({_err(err)}); read up to it"
    if scanner.damaged:
        res.warnings.append(f"{path.name}: {len(scanner.damaged)} damaged chunk(s) read up to the damage: "
                            + "; ".join(scanner.damaged[:5]))


# -------------------------------------------------------------------------------------------------------------
# ROS2 bag


def _read_ros2(path: Path, res: _Result) -> None:
    """A rosbag2 directory with rosbags' AnyReader (sqlite3 or mcap storage); a directory without a readable
    ``metadata.yaml`` (recorder died) or with damaged storage through its storage files one by one; a bare
    ``.db3``."""
    from rosbags.highlevel import AnyReader

    if path.is_file() and path.suffix != ".db3":  # a bare SQLite storage file under another name
        _read_sqlite(path, res)
        return
    try:
        _via_rosbags(AnyReader([path], default_typestore=_typestore("cdr")), res, "cdr")
        return
    except Exception as err:  # noqa: BLE001 - whatever rosbags refuses, the storage files are read directly
        files = _storage_files(path) if path.is_dir() else [path]
        if not files:
            raise UserError(str(path), None, "ROS2 bag directory without .db3 or .mcap storage files") from None
        missing = path.is_dir() and not (path / "metadata.yaml").exists()
        res.warnings.append(f"{path.name}: rosbags cannot read it ("
                            + ("metadata.yaml missing" if missing else _rosbags_error(err))
                            + "); reading " + ", ".join(f.name for f in files))
        res.sinks, res.skipped = {}, {}
    for f in files:
        with open(f, "rb") as fh:
            magic = fh.read(len(_MCAP_MAGIC))
        if magic == _MCAP_MAGIC:
            sub = _Result(f, res.wanted)
            sub.sinks, sub.skipped = res.sinks, res.skipped
            _read_mcap(f, sub)
            res.warnings += sub.warnings
            if sub.truncated:
                res.truncated = True
                res.cut_note = f"{f.name}: {sub.cut_note}"
        else:
            _read_sqlite(f, res)


def _read_sqlite(path: Path, res: _Result) -> None:
    """A rosbag2 SQLite storage file read with sqlite3 directly (rows in insertion order); when SQLite refuses
    a damaged or cut-short file, the remaining rows come from `_scan_sqlite_pages`."""
    sinks: dict[int, tuple | None] = {}

    def add_topics(rows) -> None:
        for tid, name, msgtype, fmt in rows:
            if tid not in sinks:
                s = res.sink(name, msgtype, fmt or "cdr")
                sinks[tid] = None if s is None else (s.raw.append, s.log.append)

    last_id = -1
    problem = None
    try:
        con = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro&immutable=1", uri=True)
    except sqlite3.Error as err:
        raise UserError(str(path), None, f"not an SQLite database ({err})") from None
    try:
        add_topics(con.execute("SELECT id, name, type, serialization_format FROM topics").fetchall())
        cur = con.execute("SELECT id, topic_id, timestamp, data FROM messages ORDER BY id")
        for i, (mid, tid, t, data) in enumerate(cur, 1):
            sink = sinks.get(tid)
            if sink:
                sink[0](bytes(data))
                sink[1](t)
            last_id = mid
            if not i & 0xFFFF:
                res.flush_large()
    except sqlite3.Error as err:
        problem = str(err)
    finally:
        con.close()
    if problem is None:
        return
    topics, rows = _scan_sqlite_pages(path.read_bytes())
    add_topics(topics)
    if not sinks:
        raise UserError(str(path), "table 'topics'", f"nothing readable: {problem}")
    rows = sorted(r for r in rows if r[0] > last_id)
    for _, tid, t, data in rows:
        sink = sinks.get(tid)
        if sink:
            sink[0](data)
            sink[1](t)
    res.truncated = True
    res.cut_note = (f"{path.name}: SQLite storage damaged or cut short ({problem}); rows recovered from its "
                    "intact pages")


def _varint(b: bytes, pos: int) -> tuple[int, int]:
    v = 0
    for i in range(8):
        c = b[pos + i]
        v = (v << 7) | (c & 0x7F)
        if c < 0x80:
            return v, pos + i + 1
    return (v << 8) | b[pos + 8], pos + 9


def _scan_sqlite_pages(buf: bytes) -> tuple[list[tuple], list[tuple]]:
    """Rows of a rosbag2 SQLite file read straight from its table-leaf pages (SQLite file format §1.6, §2.1),
    for a file SQLite refuses (cut short: b-tree pages past the end). Returns (topics [(id, name, type,
    serialization_format)], messages [(id, topic_id, timestamp, data)]); rows recognised by their shape:
    messages (id, int, int, blob), topics (id, '/name', text, text, text…)."""
    if len(buf) < 100 or not buf.startswith(_SQLITE_MAGIC):
        return [], []
    page = struct.unpack_from(">H", buf, 16)[0]
    page = 65536 if page == 1 else page
    usable = page - buf[20]
    x = usable - 35
    m = ((usable - 12) * 32 // 255) - 23
    npages = len(buf) // page
    topics, messages = [], []

    def payload(cell: int, size: int, base: int) -> bytes | None:
        if size <= x:
            return buf[cell:cell + size]
        k = m + (size - m) % (usable - 4)
        local = k if k <= x else m
        out = [buf[cell:cell + local]]
        nxt = struct.unpack_from(">I", buf, cell + local)[0]
        got = local
        while got < size:  # follow the overflow chain
            if not 1 <= nxt <= npages:
                return None
            o = (nxt - 1) * page
            nxt = struct.unpack_from(">I", buf, o)[0]
            take = min(usable - 4, size - got)
            out.append(buf[o + 4:o + 4 + take])
            got += take
        return b"".join(out)

    def record(p: bytes) -> list | None:
        hsize, pos = _varint(p, 0)
        types = []
        while pos < hsize:
            t, pos = _varint(p, pos)
            types.append(t)
        vals, pos = [], hsize
        for t in types:
            if t == 0:
                vals.append(None)
            elif 1 <= t <= 6:
                n = (1, 2, 3, 4, 6, 8)[t - 1]
                vals.append(int.from_bytes(p[pos:pos + n], "big", signed=True))
                pos += n
            elif t == 7:
                vals.append(struct.unpack_from(">d", p, pos)[0])
                pos += 8
            elif t in (8, 9):
                vals.append(t - 8)
            elif t >= 12:
                n = (t - 12) // 2
                vals.append(p[pos:pos + n] if t % 2 == 0 else p[pos:pos + n].decode("utf-8", "replace"))
                pos += n
            else:
                return None
        return vals if pos <= len(p) else None

    for i in range(npages):
        o = i * page
        h = o + (100 if i == 0 else 0)
        if buf[h] != 0x0D:  # table b-tree leaf
            continue
        ncells = struct.unpack_from(">H", buf, h + 3)[0]
        for j in range(ncells):
            try:
                cell = o + struct.unpack_from(">H", buf, h + 8 + 2 * j)[0]
                size, pos = _varint(buf, cell)
                rowid, pos = _varint(buf, pos)
                p = payload(pos, size, o)
                vals = record(p) if p is not None else None
            except (IndexError, struct.error):
                continue
            if not vals:
                continue
            if (len(vals) == 4 and vals[0] is None and isinstance(vals[1], int) and isinstance(vals[2], int)
                    and isinstance(vals[3], bytes)):
                messages.append((rowid, vals[1], vals[2], vals[3]))
            elif (len(vals) >= 5 and vals[0] is None and isinstance(vals[1], str) and vals[1].startswith("/")
                  and all(isinstance(v, str) for v in vals[2:5])):
                topics.append((rowid, vals[1], vals[2], vals[3]))
    return topics, messages


# -------------------------------------------------------------------------------------------------------------
# CSV / Parquet


_ALIASES = {"lat": "latitude", "lon": "longitude", "alt": "altitude", "vel_east": "vx", "vel_north": "vy",
            "vel_up": "vz"}
# motion-table names of IMU fields: a column mapped to (or named) roll_rate is read as the IMU's wx, etc.
_MOTION_FIELDS = {"roll_rate": "wx", "pitch_rate": "wy", "yaw_rate": "wz", "imu_fx": "ax", "imu_fy": "ay",
                  "imu_fz": "az"}
_IMU_ANGLES = ("roll", "pitch", "heading_deg")  # attitude given as angles by a table export (seatune convention)

#: Units a run YAML may declare for a table-log column: unit → (quantity, factor to SI).
COLUMN_UNITS: dict[str, tuple[str, float]] = {
    "rad": ("angle", 1.0), "deg": ("angle", np.pi / 180.0),
    "rad/s": ("angular rate", 1.0), "deg/s": ("angular rate", np.pi / 180.0),
    "m/s^2": ("acceleration", 1.0), "g": ("acceleration", 9.80665),  # standard gravity
    "m/s": ("speed", 1.0), "knots": ("speed", 1852.0 / 3600.0), "km/h": ("speed", 1.0 / 3.6),
    "m": ("length", 1.0),
}
#: Quantity of each table field a unit can be declared for (after renaming).
FIELD_QUANTITY: dict[str, str] = {
    "roll": "angle", "pitch": "angle", **dict.fromkeys(("wx", "wy", "wz"), "angular rate"),
    **dict.fromkeys(("ax", "ay", "az"), "acceleration"), **dict.fromkeys(("vx", "vy", "vz", "sog"), "speed"),
    **dict.fromkeys(("x", "y", "z", "altitude"), "length"),
}
_KNOWN = set().union(*MSGTYPES.values()) | {"roll", "pitch", "heading_deg", "yaw_rate", "roll_rate", "pitch_rate",
                                             "imu_fx", "imu_fy", "imu_fz", "lat", "lon", "sog", "cog_deg"}
_UNIX_RE = re.compile(r"^\s*[+-]?\d+(\.\d*)?\s*$")


def read_table_log(
    path: str | os.PathLike,
    *,
    time_column: str = "time",
    column_map: dict[str, str] | None = None,
    time_format: str = "auto",
    column_units: dict[str, str] | None = None,
) -> TopicTable:
    """A CSV or Parquet log as one table.

    Parameters
    ----------
    path : path-like
        ``.csv`` (comma, semicolon or tab separated, one header line, ``#`` comment lines before it allowed)
        or Parquet.
    time_column : str
        The log's time column; becomes ``time``. A ``log_time`` column is read the same way (default: ``time``).
    column_map : dict, optional
        Log column → seatune name, e.g. ``{"Roll": "roll", "GPS_Lat": "latitude"}``. Columns without an entry
        keep their name, except the common aliases ``lat lon alt vel_east vel_north vel_up`` →
        ``latitude longitude altitude vx vy vz`` (ENU velocity). Motion-table names ``roll_rate pitch_rate
        yaw_rate imu_fx imu_fy imu_fz`` become the IMU fields ``wx wy wz ax ay az``.
    time_format : str
        ``"auto"``: a datetime column, ISO 8601 strings (no zone = UTC, said so), or Unix time (decimal seconds,
        exact to the ns; values above 1e11 / 1e14 / 1e17 are taken as ms / µs / ns, said so); ``"iso"``;
        ``"unix"`` (seconds), ``"unix_ms"``, ``"unix_us"``, ``"unix_ns"``; or a ``strftime`` pattern (UTC).
    column_units : dict, optional
        Log column → its unit (a key of :data:`COLUMN_UNITS`, e.g. ``{"gyro_x": "deg/s"}``): the column is
        converted to SI (rad, rad/s, m/s², m/s, m). Columns declared so are listed in
        ``table.attrs["declared_units"]``; ``table.attrs["log_columns"]`` maps every field to its log column.

    Returns
    -------
    TopicTable
        topic ``/<file stem>``; msgtype of the first message type whose columns it holds (Imu, NavSatFix,
        TwistStamped, Vector3Stamped; "" if none); frame_id ""; ``table`` with ``time``, ``log_time`` and every
        numeric column (float64; ``status`` int8); notes (text columns not read, rows without a time) in
        ``table.attrs["warnings"]``.
    """
    p = Path(path)
    fmt = detect_format(p)
    if fmt not in ("csv", "parquet"):
        raise UserError(str(p), None, f"a {fmt} log is not a table (CSV or Parquet)")
    notes: list[str] = []
    if fmt == "csv":
        raw, line_of = _read_csv(p, time_column)
    else:
        try:
            raw = pd.read_parquet(p)
        except Exception as err:  # noqa: BLE001 - any pyarrow failure means the file is unreadable
            raise UserError(str(p), None, f"unreadable Parquet file ({_err(err)})") from None
        raw = raw.reset_index(drop=raw.index.name is None)

        def line_of(i: int) -> str:
            return f"row {i + 1}"

    if raw.empty:
        raise UserError(str(p), None, "no data rows")
    raw.columns = [str(c).strip() for c in raw.columns]
    if time_column not in raw.columns:
        raise UserError(str(p), "header", f"no time column {time_column!r} (columns: {list(raw.columns)})")
    cmap = dict(column_map or {})
    rename = {}
    for c in raw.columns:
        if c == time_column:
            rename[c] = "time"
        elif c in cmap:
            rename[c] = _MOTION_FIELDS.get(cmap[c], cmap[c])
        elif c in _ALIASES and _ALIASES[c] not in raw.columns and _ALIASES[c] not in cmap.values():
            rename[c] = _ALIASES[c]
        else:
            rename[c] = _MOTION_FIELDS.get(c, c)
    names = list(rename.values())
    dupes = sorted({v for v in names if names.count(v) > 1})
    if dupes:
        raise UserError(str(p), "header", f"several columns become {dupes} (column_map and aliases)")
    raw = raw.rename(columns=rename)

    times = _parse_time(raw["time"], p, time_column, time_format, line_of, notes)
    log = times
    if "log_time" in raw.columns:
        log = _parse_time(raw["log_time"], p, "log_time", time_format, line_of, notes)
        log = np.where(np.isnat(log), times, log)
    data = {}
    for c in raw.columns:
        if c in ("time", "log_time"):
            continue
        col = _numeric(raw[c], p, c, line_of, notes)
        if col is not None:
            data[c] = col
    declared = _declare_units(p, data, rename, column_units or {})
    keep = ~np.isnat(times)
    if not keep.all():
        notes.append(f"{p.name}: {int((~keep).sum()):,} rows without a time dropped")
    df = pd.DataFrame({"time": _utc(times.view(np.int64)[keep]), "log_time": _utc(log.view(np.int64)[keep]),
                       **{c: v[keep] for c, v in data.items()}})
    if "status" in df.columns and df["status"].notna().all() and (df["status"] % 1 == 0).all():
        df["status"] = df["status"].astype(np.int8)
    df.attrs["warnings"] = notes
    df.attrs["declared_units"] = declared
    df.attrs["log_columns"] = {new: old for old, new in rename.items() if new in data}
    return TopicTable(f"/{p.stem}", _table_msgtype(df.columns), "", df, str(p))


def _declare_units(p: Path, data: dict[str, np.ndarray], rename: dict[str, str], units: dict[str, str]) -> dict:
    """Convert, in place, the columns whose unit the run YAML declares; {field: declared unit}."""
    declared = {}
    for column, unit in units.items():
        name = rename.get(column)
        if name is None or name not in data:
            continue  # not in this file (a declaration shared by several logs)
        if unit not in COLUMN_UNITS:
            raise UserError(str(p), f"column {column!r}", f"unknown unit {unit!r} (one of {', '.join(COLUMN_UNITS)})")
        quantity, factor = COLUMN_UNITS[unit]
        want = FIELD_QUANTITY.get(name)
        if want is None:
            raise UserError(str(p), f"column {column!r}", f"{name} is not a column whose unit can be declared")
        if want != quantity:
            fits = ", ".join(u for u, (q, _) in COLUMN_UNITS.items() if q == want)
            raise UserError(str(p), f"column {column!r}", f"{name} takes a unit of {want} ({fits}), not {unit!r}")
        if factor != 1.0:
            data[name] = data[name] * factor
        declared[name] = unit
    return declared


def _read_csv(p: Path, time_column: str) -> tuple[pd.DataFrame, Callable[[int], str]]:
    skip, header = 0, ""
    with open(p, encoding="utf-8", errors="replace") as f:
        for line in f:
            if line.strip() and not line.lstrip().startswith("#"):
                header = line
                break
            skip += 1
    sep = _delimiter(header) or ","
    try:  # numbers parsed exactly (shortest repr round-trips); times kept as text
        df = pd.read_csv(p, sep=sep, skiprows=skip, dtype={time_column: str, "log_time": str},
                         float_precision="round_trip", skipinitialspace=True, skip_blank_lines=False)
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as err:
        raise UserError(str(p), None, f"unreadable CSV ({_err(err)})") from None
    blank = df.isna().all(axis=1).to_numpy()
    lines = np.arange(len(df)) + skip + 2  # 1-based line of each row (header at skip + 1)
    if blank.any():
        df, lines = df[~blank].reset_index(drop=True), lines[~blank]

    def line_of(i: int) -> str:
        return f"line {int(lines[i])}"

    return df, line_of


_NA = {"", "nan", "NaN", "NAN", "NA", "N/A", "n/a", "null", "NULL", "None", "none", "-", "<NA>"}


def _numeric(col: pd.Series, p: Path, name: str, line_of, notes: list[str]) -> np.ndarray | None:
    """A column as float64; text → UserError naming the first bad row, unless every value is text and the column
    is not a seatune field (then it is not read, and said so)."""
    if pd.api.types.is_bool_dtype(col.dtype) or pd.api.types.is_numeric_dtype(col.dtype):
        return col.to_numpy(dtype=np.float64, na_value=np.nan)
    if pd.api.types.is_datetime64_any_dtype(col.dtype):
        notes.append(f"{p.name}: datetime column {name!r} is not read")
        return None
    values = col.tolist()
    out = np.full(len(values), np.nan)
    first_bad, n_bad, n_text = None, 0, 0
    for i, v in enumerate(values):
        if v is None or (isinstance(v, float) and v != v):
            continue
        if isinstance(v, str):
            s = v.strip()
            if s in _NA:
                continue
            n_text += 1
            try:
                out[i] = float(s)
                continue
            except ValueError:
                pass
        else:
            try:
                out[i] = float(v)
                continue
            except (TypeError, ValueError):
                n_text += 1
        n_bad += 1
        if first_bad is None:
            first_bad = i
    if first_bad is None:
        return out
    if n_bad == n_text and name not in _KNOWN:
        notes.append(f"{p.name}: text column {name!r} is not read")
        return None
    raise UserError(str(p), f"column {name!r}, {line_of(first_bad)}",
                    f"text {str(values[first_bad]).strip()!r} in a numeric column")


_UNITS = {"unix": "s", "unix_s": "s", "unix_ms": "ms", "unix_us": "us", "unix_ns": "ns"}
_DIGITS = {"s": 9, "ms": 6, "us": 3, "ns": 0}


def _parse_time(col: pd.Series, p: Path, name: str, time_format: str, line_of, notes: list[str]) -> np.ndarray:
    """datetime64[ns] (UTC, NaT where empty) from a datetime / numeric / string column."""
    where = f"column {name!r}"
    if isinstance(col.dtype, pd.DatetimeTZDtype):
        return col.dt.tz_convert("UTC").dt.tz_localize(None).to_numpy(dtype="datetime64[ns]")
    if pd.api.types.is_datetime64_any_dtype(col.dtype):
        notes.append(f"{p.name}: {where} has no time zone; taken as UTC")
        return col.to_numpy(dtype="datetime64[ns]")
    unit = _UNITS.get(time_format)
    numeric_ok = time_format == "auto" or unit is not None
    out = np.full(len(col), np.datetime64("NaT"), dtype="datetime64[ns]")
    if pd.api.types.is_numeric_dtype(col.dtype) and numeric_ok:
        v = col.to_numpy(dtype=np.float64, na_value=np.nan)
        unit = unit or _guess_unit(v, p, name, notes)
        ns = np.round(v * 10.0 ** _DIGITS[unit])
        ok = np.isfinite(ns)
        out[ok] = ns[ok].astype(np.int64).view("datetime64[ns]")
        return out
    s = col.astype(str).str.strip()
    na = s.isin(_NA).to_numpy() | col.isna().to_numpy()
    vals = s[~na]
    if vals.empty:
        raise UserError(str(p), where, "no times")
    is_num = vals.str.match(_UNIX_RE).to_numpy()
    if numeric_ok and (is_num.all() or unit is not None):
        if not is_num.all():
            i = int(np.flatnonzero(~na)[np.flatnonzero(~is_num)[0]])
            raise UserError(str(p), f"{where}, {line_of(i)}", f"cannot read {s.iloc[i]!r} as Unix time")
        unit = unit or _guess_unit(vals.astype(np.float64).to_numpy(), p, name, notes)
        out[~na] = _decimal_ns(vals, _DIGITS[unit]).view("datetime64[ns]")
        return out
    fmt = "ISO8601" if time_format in ("auto", "iso") else time_format
    parsed = pd.to_datetime(vals, utc=True, errors="coerce", format=fmt)
    bad = parsed.isna().to_numpy()
    if bad.any():
        i = int(np.flatnonzero(~na)[np.flatnonzero(bad)[0]])
        raise UserError(str(p), f"{where}, {line_of(i)}", f"cannot read {s.iloc[i]!r} as a time")
    if not vals.str.contains(r"(?:Z|[+-]\d\d:?\d\d)$", regex=True).all():
        notes.append(f"{p.name}: {where} has times without a zone; taken as UTC")
    out[~na] = parsed.dt.tz_localize(None).to_numpy(dtype="datetime64[ns]")
    return out


def _decimal_ns(vals: pd.Series, digits: int) -> np.ndarray:
    """Exact ns from decimal strings ('1714564800.123456789' s), no float rounding; `digits` = 9 - log10(unit)."""
    s = vals.str.strip()
    neg = s.str.startswith("-").to_numpy()
    parts = s.str.lstrip("+-").str.partition(".")
    whole = parts[0].astype(np.int64).to_numpy()
    frac = parts[2].str.ljust(max(digits, 1), "0").str[:digits] if digits else None
    ns = whole * 10**digits + (frac.astype(np.int64).to_numpy() if frac is not None else 0)
    return np.where(neg, -ns, ns)


def _guess_unit(values: np.ndarray, p: Path, name: str, notes: list[str]) -> str:
    m = float(np.nanmedian(np.abs(values))) if np.isfinite(values).any() else 0.0
    unit = "s" if m < 1e11 else "ms" if m < 1e14 else "us" if m < 1e17 else "ns"
    if unit != "s":
        notes.append(f"{p.name}: column {name!r} read as Unix time in {unit} (values ~{m:.3g})")
    return unit


def _table_msgtype(columns) -> str:
    cols = set(columns)
    for msgtype, need in ((IMU, ("wx", "wy", "wz")), (IMU, ("ax", "ay", "az")), (FIX, ("latitude", "longitude")),
                          (TWIST, ("vx", "vy")), (VEC3, ("x", "y", "z"))):
        if cols.issuperset(need):
            return msgtype
    return ""


def _split_table(tt: TopicTable) -> tuple[dict[str, TopicTable], list[str]]:
    """One TopicTable per message type whose columns a CSV/Parquet log holds (rows with all fields NaN dropped)."""
    df = tt.table
    cols = set(df.columns)
    out: dict[str, TopicTable] = {}
    used = {"time", "log_time"}
    stem = tt.topic
    groups = []
    if cols & {"wx", "wy", "wz", "ax", "ay", "az", "roll", "pitch"}:
        groups.append(("imu", IMU))
    if {"latitude", "longitude"} <= cols:
        groups.append(("fix", FIX))
    if {"vx", "vy"} <= cols:
        groups.append(("vel", TWIST))
    if {"x", "y", "z"} <= cols:
        groups.append(("vector", VEC3))
    for name, msgtype in groups:
        fields = list(MSGTYPES[msgtype])
        if msgtype == TWIST and any(g[1] == IMU for g in groups):
            fields = ["vx", "vy", "vz"]  # wx wy wz belong to the IMU
        extra = [c for c in _IMU_ANGLES if c in cols] if msgtype == IMU else []
        present = [c for c in fields + extra if c in cols]
        sub = df[["time", "log_time", *present]]
        sub = sub[sub[present].notna().any(axis=1)].reset_index(drop=True)
        for c in MSGTYPES[msgtype]:
            if c not in sub.columns:
                sub[c] = np.int8(0) if c == "status" else np.nan
        if "status" in sub.columns and sub["status"].notna().all():
            sub["status"] = sub["status"].astype(np.int8)
        sub = sub[["time", "log_time", *MSGTYPES[msgtype], *extra]]
        sub.attrs = {k: {c: v for c, v in df.attrs.get(k, {}).items() if c in present}
                     for k in ("declared_units", "log_columns")}
        used.update(present)
        out[f"{stem}/{name}"] = TopicTable(f"{stem}/{name}", msgtype, tt.frame_id, sub, tt.source)
    notes = list(tt.table.attrs.get("warnings", []))
    rest = [c for c in df.columns if c not in used]
    if rest:
        notes.append(f"{Path(tt.source or stem).name}: columns not read as ROS fields: {rest}")
    return out, notes


# -------------------------------------------------------------------------------------------------------------
# read_log


def read_log(
    path: str | os.PathLike,
    format: str = "auto",
    topics: Iterable[str] | None = None,
    *,
    table_options: dict | None = None,
) -> LogContents:
    """Read a log into one :class:`TopicTable` per supported topic.

    Parameters
    ----------
    path : path-like
        MCAP file, ROS1 ``.bag``, ROS2 bag directory (or its bare ``.db3``), CSV or Parquet file.
    format : str
        ``"auto"`` (from the content, :func:`detect_format`) or one of :data:`FORMATS`.
    topics : iterable of str, optional
        Read only these topics; a topic not in the log is a :class:`UserError`. Default: every topic of a
        supported type (others are listed in a warning).
    table_options : dict, optional
        Keyword arguments of :func:`read_table_log` for CSV / Parquet logs, whose columns are split into
        ``/<stem>/imu``, ``/<stem>/fix``, ``/<stem>/vel``, ``/<stem>/vector`` topics.

    Returns
    -------
    LogContents
    """
    p = Path(path)
    fmt = detect_format(p) if format == "auto" else format
    if fmt not in FORMATS:
        raise UserError(str(p), None, f"unknown format {format!r}; one of {list(FORMATS)}")
    if format != "auto" and not p.exists():
        raise UserError(str(p), None, "no such file or directory")
    if p.is_file() and p.stat().st_size == 0:
        raise UserError(str(p), None, "empty file (0 bytes)")
    topics = None if topics is None else list(topics)

    if fmt in ("csv", "parquet"):
        tt = read_table_log(p, **(table_options or {}))
        tables, notes = _split_table(tt)
        if not tables:
            raise UserError(str(p), "header", f"no IMU, GNSS or velocity columns (columns: "
                                              f"{[c for c in tt.table.columns if c != 'log_time']})")
        if topics is not None:
            _check_topics(p, topics, tables)
            tables = {k: v for k, v in tables.items() if k in topics}
        return LogContents(p, fmt, tables, notes, False)

    res = _Result(p, topics)
    reader = {"mcap": _read_mcap, "ros1bag": _read_ros1, "ros2bag": _read_ros2}[fmt]
    try:
        reader(p, res)
    except UserError:
        raise
    except (OSError, ValueError, KeyError, struct.error) as err:
        raise UserError(str(p), None, f"unreadable {fmt} log ({_err(err)})") from None
    warnings = list(res.warnings)
    for s in res.sinks.values():
        s.flush()
    tables = {t: s.table(str(p), warnings) for t, s in res.sinks.items() if s.count}
    corrupt = {t: s.corrupt for t, s in res.sinks.items() if s.corrupt}
    if corrupt:
        if not tables:
            raise UserError(str(p), None, "nothing readable: no message deserializes ("
                            + ", ".join(f"{t}: {k:,}" for t, k in corrupt.items()) + ")")
        warnings.append(f"{p.name}: corrupt messages skipped: " + ", ".join(f"{t}: {k:,}" for t, k in corrupt.items()))
    if res.skipped:
        warnings.append(f"{p.name}: skipped {len(res.skipped)} topic(s) of unsupported types: "
                        + ", ".join(f"{t} ({m})" for t, m in sorted(res.skipped.items())))
    n = sum(len(t.table) for t in tables.values())
    if res.truncated:
        if n == 0:
            raise UserError(str(p), None, f"nothing readable: {res.cut_note}")
        last = res.last_log_ns
        up_to = pd.Timestamp(last, unit="ns", tz="UTC").isoformat() if last is not None else "?"
        warnings.insert(0, f"{p.name}: {res.cut_note}: read {n:,} messages up to {up_to}")
    if topics is not None:
        _check_topics(p, topics, {**tables, **dict.fromkeys(res.skipped)})
    static = _static_transforms(res.tf_static, p, warnings)
    return LogContents(p, fmt, tables, warnings, res.truncated, dict(res.skipped), static)


def _static_transforms(sink: _Sink | None, p: Path, warnings: list[str]) -> list[StaticTransform]:
    """The transforms of the /tf_static messages (the last one of each child frame wins)."""
    if sink is None or not sink.raw:
        return []
    ts = _typestore(sink.encoding)
    if TF not in ts.types:  # ROS1 Noetic's store lacks tf2_msgs; the definition is the same in both
        from rosbags.typesys import get_types_from_msg

        ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", TF))
    deser = ts.deserialize_ros1 if sink.encoding == "ros1" else ts.deserialize_cdr
    out: dict[str, StaticTransform] = {}
    bad = 0
    for raw in sink.raw:
        try:
            msg = deser(raw, TF)
        except Exception:  # noqa: BLE001 - a corrupt message is skipped and counted
            bad += 1
            continue
        for tr in msg.transforms:
            t, r = tr.transform.translation, tr.transform.rotation
            out[tr.child_frame_id.strip("/")] = StaticTransform(tr.header.frame_id.strip("/"),
                                                                 tr.child_frame_id.strip("/"),
                                                                 (t.x, t.y, t.z), (r.x, r.y, r.z, r.w))
    if bad:
        warnings.append(f"{p.name}: {bad} corrupt /tf_static message(s) skipped")
    return list(out.values())


def _check_topics(p: Path, topics: list[str], have: dict) -> None:
    missing = [t for t in topics if t not in have]
    if missing:
        raise UserError(str(p), None, f"topic(s) {missing} not in the log")


# -------------------------------------------------------------------------------------------------------------
# benchmark


def benchmark_mcap(path: str | os.PathLike) -> dict:
    """Messages/s of :func:`read_log` against a plain loop over mcap's reader that decodes every message with
    the mcap_ros2 (or mcap_ros1) decoder and collects the IMU fields into a table, in the same process.

    Returns
    -------
    dict
        ``messages``, ``seatune_s``, ``seatune_msgs_per_s``, ``plain_s``, ``plain_msgs_per_s``, ``speedup``
        (plain / seatune time), ``identical`` (the IMU columns of both agree exactly).
    """
    import lz4.frame  # noqa: F401 - lazy imports of the reader, loaded before the clock starts
    import zstandard  # noqa: F401
    from mcap.reader import make_reader

    p = Path(path)
    _lean_stream_reader()
    t0 = _time.perf_counter()
    log = read_log(p)
    t_ours = _time.perf_counter() - t0
    n_ours = sum(len(t.table) for t in log.topics.values())

    with open(p, "rb") as f:
        profile = make_reader(f).get_header().profile
    if profile == "ros1":
        from mcap_ros1.decoder import DecoderFactory
    else:
        from mcap_ros2.decoder import DecoderFactory

    t0 = _time.perf_counter()
    rows: dict[str, list] = {}
    with open(p, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        n_plain = 0
        for schema, channel, message, m in reader.iter_decoded_messages(log_time_order=False):
            n_plain += 1
            if normalize_msgtype(schema.name) != IMU:
                continue
            st = m.header.stamp
            o, w, a = m.orientation, m.angular_velocity, m.linear_acceleration
            rows.setdefault(channel.topic, []).append((
                st.sec * _NS + (st.nanosec if hasattr(st, "nanosec") else st.nsecs), message.log_time,
                o.x, o.y, o.z, o.w, w.x, w.y, w.z, a.x, a.y, a.z))
    plain = {k: pd.DataFrame(v, columns=["stamp", "log", "qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay",
                                         "az"]) for k, v in rows.items()}
    t_plain = _time.perf_counter() - t0

    identical = True
    for topic, df in plain.items():
        ours = log.topics.get(topic)
        if ours is None or len(ours.table) != len(df):
            identical = False
            continue
        ours_t = ours.table
        identical &= bool((ours_t["time"].astype("int64").to_numpy() == df["stamp"].to_numpy()).all())
        for c in ("wx", "wy", "wz", "ax", "ay", "az"):
            identical &= bool(np.array_equal(ours_t[c].to_numpy(), df[c].to_numpy(), equal_nan=True))
    return {"messages": n_ours, "plain_messages": n_plain, "seatune_s": t_ours,
            "seatune_msgs_per_s": n_ours / t_ours if t_ours else float("inf"), "plain_s": t_plain,
            "plain_msgs_per_s": n_plain / t_plain if t_plain else float("inf"),
            "speedup": t_plain / t_ours if t_ours else float("inf"), "identical": identical}

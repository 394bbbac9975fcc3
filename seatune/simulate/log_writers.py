"""Write sensor time series as genuine logger files: MCAP, ROS1 bag, ROS2 bag, CSV.

The simulator (`seatune simulate`) produces pandas tables; this module turns them into the files a vessel's
logger would have written, with the real libraries, so that ingest is tested on genuine files:

- messages are built from the typestore's own message classes (``rosbags.typesys``: ROS2 Humble for CDR,
  ROS1 Noetic for ROS1 encoding) and serialised by the typestore, so the bytes are what ROS writes;
- messages from all streams are interleaved in the order of their log (receive) time, as a recorder does;
- every file is written atomically (temporary file or folder beside the target, then rename) so a crash
  never leaves a half file (DESIGN §5) — except `truncate`, which damages a file on purpose to imitate a
  logger that lost power (no footer, no index, no ``metadata.yaml``).

Message conventions follow ``sensor_msgs`` (spec/ecosystem.md §4.7): SI units, covariances row-major with
all zeros meaning "unknown" and element 0 = -1 meaning "not provided".
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd

import seatune
from seatune.atomic import atomic_path

__all__ = [
    "MSGTYPES",
    "Stream",
    "truncate",
    "write_csv",
    "write_mcap",
    "write_ros1_bag",
    "write_ros2_bag",
]

#: Supported message types and the table columns each reads: (required, optional).
MSGTYPES: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "sensor_msgs/msg/Imu": (
        ("wx", "wy", "wz", "ax", "ay", "az"),
        ("qx", "qy", "qz", "qw", "var_q", "var_w", "var_a"),
    ),
    "sensor_msgs/msg/NavSatFix": (("latitude", "longitude"), ("altitude", "status", "service", "var_pos", "var_alt")),
    "geometry_msgs/msg/TwistStamped": (("vx", "vy", "vz", "wx", "wy", "wz"), ()),
    "geometry_msgs/msg/Vector3Stamped": (("x", "y", "z"), ()),
}

_QUAT = ("qx", "qy", "qz", "qw")
_NS = 1_000_000_000
# builtin_interfaces/Time.sec is int32 in ROS2 and uint32 in ROS1: both hold [0, 2**31).
_MAX_NS = (2**31 - 1) * _NS


def _normalize_msgtype(msgtype: str) -> str:
    """'sensor_msgs/Imu' (ROS1 spelling) → 'sensor_msgs/msg/Imu'."""
    parts = msgtype.strip("/").split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    return "/".join(parts)


@dataclass(frozen=True)
class Stream:
    """One topic of a log: a table of samples and how to publish them.

    Parameters
    ----------
    topic : str
        ROS topic name, e.g. ``"/imu/data"``.
    msgtype : str
        ROS2-style message type: ``"sensor_msgs/msg/Imu"``, ``"sensor_msgs/msg/NavSatFix"``,
        ``"geometry_msgs/msg/TwistStamped"`` or ``"geometry_msgs/msg/Vector3Stamped"`` (the ROS1
        spelling ``"sensor_msgs/Imu"`` is accepted and normalised).
    frame_id : str
        ``header.frame_id`` of every message.
    table : pandas.DataFrame
        One row per message. ``time`` (``datetime64[ns, UTC]``) is ``header.stamp``; optional
        ``log_time`` (``datetime64[ns, UTC]``) is when the logger received the message (default: ``time``).
        Field columns by message type (SI units, REP-103):

        - Imu: ``wx wy wz`` [rad/s], ``ax ay az`` [m/s², specific force including gravity], ``qx qy qz qw``
          (if all four are absent the orientation is marked "not provided": covariance element 0 = -1);
          optional ``var_q var_w var_a``: scalar variance put on the 3 diagonal entries of the
          orientation / angular-velocity / linear-acceleration covariance (a negative value marks the field
          "not provided"); absent = all zeros = unknown.
        - NavSatFix: ``latitude longitude`` [deg], ``altitude`` [m, default NaN = not available],
          ``status`` (int, default 0 = STATUS_FIX), ``service`` (int, default 1 = SERVICE_GPS), ``var_pos``
          [m²] (diagonal of ``position_covariance``, ``position_covariance_type`` = 2 DIAGONAL_KNOWN when
          given, else 0 UNKNOWN), ``var_alt`` [m²] (overrides the vertical entry).
        - TwistStamped: ``vx vy vz`` [m/s], ``wx wy wz`` [rad/s].
        - Vector3Stamped: ``x y z``.

        NaN in a field column is written as NaN (ROS allows it); duplicated or unsorted stamps are written
        as they are (a simulator injects such defects on purpose).
    """

    topic: str
    msgtype: str
    frame_id: str
    table: pd.DataFrame

    def __post_init__(self) -> None:
        msgtype = _normalize_msgtype(self.msgtype)
        if msgtype not in MSGTYPES:
            raise ValueError(
                f"stream {self.topic!r}: unsupported msgtype {self.msgtype!r}; supported: {list(MSGTYPES)}"
            )
        object.__setattr__(self, "msgtype", msgtype)
        if not self.topic.startswith("/"):
            raise ValueError(f"stream {self.topic!r}: a ROS topic name starts with '/'")
        required, _ = MSGTYPES[msgtype]
        cols = set(self.table.columns)
        missing = [c for c in ("time", *required) if c not in cols]
        if missing:
            raise ValueError(f"stream {self.topic!r} ({msgtype}): missing columns {missing}")
        if msgtype.endswith("/Imu") and 0 < len(cols.intersection(_QUAT)) < 4:
            raise ValueError(f"stream {self.topic!r}: give all of {list(_QUAT)} or none")
        if "var_alt" in cols and "var_pos" not in cols:
            raise ValueError(f"stream {self.topic!r}: 'var_alt' needs 'var_pos' (the horizontal variance)")


# --------------------------------------------------------------------------------------------------------
# time columns


def _time_ns(table: pd.DataFrame, column: str, where: str) -> np.ndarray:
    """A tz-aware datetime column → int64 ns since the Unix epoch (UTC)."""
    col = table[column]
    if not isinstance(col.dtype, pd.DatetimeTZDtype):
        raise ValueError(f"{where}: column {column!r} must be datetime64[ns, UTC], got {col.dtype}")
    if col.isna().any():
        raise ValueError(f"{where}: column {column!r} holds {int(col.isna().sum())} NaT")
    ns = col.dt.tz_convert("UTC").astype("datetime64[ns, UTC]").array.asi8
    return np.asarray(ns, dtype=np.int64)


def _check_ros_time(ns: np.ndarray, where: str) -> None:
    if len(ns) and (ns.min() < 0 or ns.max() > _MAX_NS):
        raise ValueError(f"{where}: times must lie between 1970 and 2038 to fit a ROS builtin_interfaces/Time")


@dataclass
class _Prepared:
    """A validated stream with its header stamps and log times as int64 ns since the epoch (UTC)."""

    stream: Stream
    stamp_ns: np.ndarray
    log_ns: np.ndarray


def _prepare(streams: Sequence[Stream]) -> list[_Prepared]:
    if not streams:
        raise ValueError("no streams to write")
    topics = [s.topic for s in streams]
    if len(set(topics)) != len(topics):
        raise ValueError(f"each topic may appear in one stream only: {topics}")
    out = []
    for s in streams:
        where = f"stream {s.topic!r}"
        stamp = _time_ns(s.table, "time", where)
        log = _time_ns(s.table, "log_time", where) if "log_time" in s.table.columns else stamp
        _check_ros_time(stamp, where)
        _check_ros_time(log, where)
        out.append(_Prepared(s, stamp, log))
    return out


def _merge_order(prepared: Sequence[_Prepared]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(stream index, row index, log time) of every message, ordered by log time (ties: stream, row)."""
    log = np.concatenate([p.log_ns for p in prepared])
    sidx = np.concatenate([np.full(len(p.log_ns), i, dtype=np.int64) for i, p in enumerate(prepared)])
    ridx = np.concatenate([np.arange(len(p.log_ns), dtype=np.int64) for p in prepared])
    order = np.lexsort((ridx, sidx, log))
    return sidx[order], ridx[order], log[order]


# --------------------------------------------------------------------------------------------------------
# messages: typestore classes, columns converted once, one lean loop per stream


def _typestore(ros1: bool):
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)


def _col(table: pd.DataFrame, name: str, default: float = np.nan) -> list:
    if name in table.columns:
        return table[name].to_numpy(dtype=np.float64).tolist()
    return [default] * len(table)


def _covariance_matrix(table: pd.DataFrame, name: str, diag: tuple[int, ...] = (0, 4, 8)) -> np.ndarray | None:
    """(n, 9) row-major 3×3 covariances from a scalar variance column (negative → "not provided")."""
    if name not in table.columns:
        return None
    var = table[name].to_numpy(dtype=np.float64)
    cov = np.zeros((len(var), 9))
    cov[:, list(diag)] = var[:, None]
    absent = var < 0
    cov[absent] = 0.0
    cov[absent, 0] = -1.0
    return cov


def _covariances(table: pd.DataFrame, name: str, diag: tuple[int, ...] = (0, 4, 8)) -> list[np.ndarray] | None:
    """Per-row 3×3 row-major covariance from a scalar variance column (negative → "not provided")."""
    cov = _covariance_matrix(table, name, diag)
    return None if cov is None else list(cov)


def _headers(ts, p: _Prepared, ros1: bool, first: int = 0) -> list:
    """Headers of a stream's rows; `first`: the index of the first row in the whole stream (ROS1 seq)."""
    Header, Time = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    sec, nsec = np.divmod(p.stamp_ns, _NS)
    frame = p.stream.frame_id
    if ros1:  # ROS1 headers carry a per-publisher sequence number
        return [
            Header(seq=(first + i) & 0xFFFFFFFF, stamp=Time(sec=s, nanosec=n), frame_id=frame)
            for i, (s, n) in enumerate(zip(sec.tolist(), nsec.tolist(), strict=True))
        ]
    return [
        Header(stamp=Time(sec=s, nanosec=n), frame_id=frame)
        for s, n in zip(sec.tolist(), nsec.tolist(), strict=True)
    ]


def _build_imu(ts, t: pd.DataFrame, headers: list) -> Iterator:
    Imu, Q, V3 = (
        ts.types[k] for k in ("sensor_msgs/msg/Imu", "geometry_msgs/msg/Quaternion", "geometry_msgs/msg/Vector3")
    )
    n = len(t)
    zero = np.zeros(9)
    has_q = "qw" in t.columns
    q_default = zero.copy()
    q_default[0] = -1.0  # REP / sensor_msgs: orientation not provided
    cq = _covariances(t, "var_q") or [zero if has_q else q_default] * n
    cw = _covariances(t, "var_w") or [zero] * n
    ca = _covariances(t, "var_a") or [zero] * n
    qx, qy, qz, qw = (_col(t, c, 0.0) for c in _QUAT)
    wx, wy, wz, ax, ay, az = (_col(t, c) for c in ("wx", "wy", "wz", "ax", "ay", "az"))
    for i, h in enumerate(headers):
        yield Imu(
            header=h,
            orientation=Q(x=qx[i], y=qy[i], z=qz[i], w=qw[i]),
            orientation_covariance=cq[i],
            angular_velocity=V3(x=wx[i], y=wy[i], z=wz[i]),
            angular_velocity_covariance=cw[i],
            linear_acceleration=V3(x=ax[i], y=ay[i], z=az[i]),
            linear_acceleration_covariance=ca[i],
        )


def _build_navsatfix(ts, t: pd.DataFrame, headers: list) -> Iterator:
    Fix, Status = ts.types["sensor_msgs/msg/NavSatFix"], ts.types["sensor_msgs/msg/NavSatStatus"]
    n = len(t)
    lat, lon, alt = _col(t, "latitude"), _col(t, "longitude"), _col(t, "altitude")
    status = t["status"].to_numpy(dtype=np.int64).tolist() if "status" in t.columns else [0] * n
    service = t["service"].to_numpy(dtype=np.int64).tolist() if "service" in t.columns else [1] * n
    cov = _covariances(t, "var_pos")
    if cov is not None and "var_alt" in t.columns:
        for c, v in zip(cov, t["var_alt"].to_numpy(dtype=np.float64), strict=True):
            c[8] = v
    ctype = [0] * n if cov is None else [2] * n  # COVARIANCE_TYPE_UNKNOWN / _DIAGONAL_KNOWN
    cov = cov or [np.zeros(9)] * n
    for i, h in enumerate(headers):
        yield Fix(
            header=h,
            status=Status(status=status[i], service=service[i]),
            latitude=lat[i],
            longitude=lon[i],
            altitude=alt[i],
            position_covariance=cov[i],
            position_covariance_type=ctype[i],
        )


def _build_twist(ts, t: pd.DataFrame, headers: list) -> Iterator:
    TS, Twist, V3 = (ts.types[k] for k in ("geometry_msgs/msg/TwistStamped", "geometry_msgs/msg/Twist",
                                            "geometry_msgs/msg/Vector3"))
    vx, vy, vz, wx, wy, wz = (_col(t, c) for c in ("vx", "vy", "vz", "wx", "wy", "wz"))
    for i, h in enumerate(headers):
        yield TS(header=h, twist=Twist(linear=V3(x=vx[i], y=vy[i], z=vz[i]), angular=V3(x=wx[i], y=wy[i], z=wz[i])))


def _build_vector3(ts, t: pd.DataFrame, headers: list) -> Iterator:
    VS, V3 = ts.types["geometry_msgs/msg/Vector3Stamped"], ts.types["geometry_msgs/msg/Vector3"]
    x, y, z = (_col(t, c) for c in ("x", "y", "z"))
    for i, h in enumerate(headers):
        yield VS(header=h, vector=V3(x=x[i], y=y[i], z=z[i]))


_BUILDERS: dict[str, Callable] = {
    "sensor_msgs/msg/Imu": _build_imu,
    "sensor_msgs/msg/NavSatFix": _build_navsatfix,
    "geometry_msgs/msg/TwistStamped": _build_twist,
    "geometry_msgs/msg/Vector3Stamped": _build_vector3,
}


def _serialize(ts, p: _Prepared, ros1: bool):
    """Every message of a stream, in table order, serialised by the typestore (CDR little-endian or ROS1): a
    sequence of bytes-like rows. IMU streams take the fixed-layout path (`_ImuRows`) when it reproduces the
    typestore's bytes."""
    msgtype = p.stream.msgtype
    if msgtype == "sensor_msgs/msg/Imu" and len(p.stream.table):
        rows = _ImuRows.of(ts, p, ros1)
        if rows is not None:
            return rows
    return _serialize_each(ts, p, ros1)


def _serialize_each(ts, p: _Prepared, ros1: bool, first: int = 0, stop: int | None = None) -> list[bytes]:
    """Rows first … stop of a stream, message by message (the typestore's own path)."""
    msgtype = p.stream.msgtype
    rows = slice(first, stop)
    sub = _Prepared(replace(p.stream, table=p.stream.table.iloc[rows]), p.stamp_ns[rows], p.log_ns[rows])
    headers = _headers(ts, sub, ros1, first)
    msgs = _BUILDERS[msgtype](ts, sub.stream.table, headers)
    if ros1:
        return [bytes(ts.serialize_ros1(m, msgtype)) for m in msgs]
    return [bytes(ts.serialize_cdr(m, msgtype, little_endian=True)) for m in msgs]


class _ImuRows:
    """sensor_msgs/Imu messages of one stream as fixed-size records filled by numpy, encoded a block at a time.

    With one frame_id every message of a stream has the same length and layout; the layout (byte offset of the
    stamp, the ROS1 seq and each of the 37 float64 fields) is read off a message the typestore serialises with
    distinct marker values, so the bytes are the typestore's. `of` checks the first and last rows against the
    typestore and returns None (the message-by-message path) if they differ."""

    BLOCK = 1 << 16

    def __init__(self, template: bytes, offsets: dict, p: _Prepared, ros1: bool):
        self.template, self.p, self.ros1, self.size = template, p, ros1, len(template)
        self.dtype = np.dtype({"names": list(offsets), "offsets": list(offsets.values()), "itemsize": self.size,
                               "formats": ["<u4" if k in ("sec", "nanosec", "seq") else ("<f8", (1,))
                                           for k in offsets]})
        self._start, self._block = -1, None

    @classmethod
    def of(cls, ts, p: _Prepared, ros1: bool):
        msgtype = "sensor_msgs/msg/Imu"
        marks = {f"f{k}": 1.0e9 + k + 0.25 for k in range(37)}
        marks_u = {"sec": 0x11223344, "nanosec": 0x35667788, "seq": 0x0A0B0C0D}
        Time, Header = ts.types["builtin_interfaces/msg/Time"], ts.types["std_msgs/msg/Header"]
        stamp = Time(sec=marks_u["sec"], nanosec=marks_u["nanosec"])
        header = (Header(seq=marks_u["seq"], stamp=stamp, frame_id=p.stream.frame_id) if ros1
                  else Header(stamp=stamp, frame_id=p.stream.frame_id))
        f = list(marks.values())
        Q, V3 = ts.types["geometry_msgs/msg/Quaternion"], ts.types["geometry_msgs/msg/Vector3"]
        msg = ts.types[msgtype](header=header, orientation=Q(x=f[0], y=f[1], z=f[2], w=f[3]),
                                orientation_covariance=np.array(f[4:13]), angular_velocity=V3(*f[13:16]),
                                angular_velocity_covariance=np.array(f[16:25]), linear_acceleration=V3(*f[25:28]),
                                linear_acceleration_covariance=np.array(f[28:37]))
        raw = bytes(ts.serialize_ros1(msg, msgtype) if ros1 else ts.serialize_cdr(msg, msgtype, little_endian=True))
        offsets = {}
        for name, v in (*marks_u.items(), *marks.items()):
            if name == "seq" and not ros1:
                continue
            packed = np.array([v], dtype="<u4" if name in marks_u else "<f8").tobytes()
            at = raw.find(packed)
            if at < 0 or raw.find(packed, at + 1) >= 0:
                return None
            offsets[name] = at
        rows = cls(raw, offsets, p, ros1)
        n = len(p.stream.table)
        for r in {0, n - 1}:
            if bytes(rows[r]) != _serialize_each(ts, p, ros1, r, r + 1)[0]:
                return None
        return rows

    def __len__(self) -> int:
        return len(self.p.stream.table)

    def __getitem__(self, r: int) -> bytes:
        if self._block is None or not self._start <= r < self._start + self.BLOCK:
            self._encode(r - r % self.BLOCK)
        k = (r - self._start) * self.size
        return self._block[k:k + self.size].tobytes()

    def _encode(self, start: int) -> None:
        stop = min(start + self.BLOCK, len(self))
        raw = np.frombuffer(self.template * (stop - start), dtype=np.uint8).copy()  # the constant bytes kept
        out = raw.view(self.dtype)
        sec, nsec = np.divmod(self.p.stamp_ns[start:stop], _NS)
        out["sec"], out["nanosec"] = sec, nsec
        if self.ros1:
            out["seq"] = np.arange(start, stop, dtype=np.int64) & 0xFFFFFFFF
        values = _imu_values(self.p.stream.table.iloc[start:stop])  # a block at a time: memory flat in length
        for k in range(37):
            out[f"f{k}"][:, 0] = values[:, k]
        self._start, self._block = start, memoryview(raw)


def _imu_values(t: pd.DataFrame) -> np.ndarray:
    """The 37 float64 fields of each row's Imu message in message order (orientation, its covariance, angular
    velocity, its covariance, linear acceleration, its covariance): (n, 37), by `_build_imu`'s rules (the
    message-by-message path keeps its own loop: the reference `make bench` times, and `_ImuRows.of` checks the two
    agree)."""
    n = len(t)

    def column(name, default=np.nan):
        return t[name].to_numpy(dtype=np.float64) if name in t.columns else np.full(n, default)

    def covariance(name, not_provided):  # absent column: all zeros (unknown), or "not provided"
        c = _covariance_matrix(t, name)
        if c is None:
            c = np.zeros((n, 9))
            c[:, 0] = -1.0 if not_provided else 0.0
        return c

    q = np.column_stack([column(c, 0.0) for c in _QUAT])
    w = np.column_stack([column(c) for c in ("wx", "wy", "wz")])
    a = np.column_stack([column(c) for c in ("ax", "ay", "az")])
    return np.hstack([q, covariance("var_q", "qw" not in t.columns), w, covariance("var_w", False), a,
                      covariance("var_a", False)])


# --------------------------------------------------------------------------------------------------------
# writers


def _sensor_qos():
    """The QoS a ROS2 sensor driver offers (rclcpp SensorDataQoS): keep last 5, best effort, volatile."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    infinite = QosTime(sec=2147483647, nsec=4294967295)
    return Qos(QosHistory.KEEP_LAST, 5, QosReliability.BEST_EFFORT, QosDurability.VOLATILE,
               infinite, infinite, QosLiveliness.AUTOMATIC, infinite, False)


# The same profile as rosbag2 (Humble) writes it in an MCAP channel's `offered_qos_profiles` (MCAP ros2 profile).
_SENSOR_QOS_YAML = (
    "- history: 1\n  depth: 5\n  reliability: 2\n  durability: 2\n"
    "  deadline:\n    sec: 2147483647\n    nsec: 4294967295\n"
    "  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n"
    "  liveliness: 1\n"
    "  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n"
    "  avoid_ros_namespace_conventions: false"
)


def _library_id() -> str:
    from importlib.metadata import version

    return f"seatune {seatune.__version__}; rosbags {version('rosbags')}; mcap {version('mcap')}"


def write_mcap(
    path: str | os.PathLike,
    streams: Sequence[Stream],
    *,
    profile: Literal["ros2", "ros1"] = "ros2",
    chunk_size: int = 1024 * 1024,
    compression: Literal["zstd", "lz4", "none"] = "zstd",
    message_index: bool = True,
    zstd_level: int = 3,
) -> Path:
    """Write streams to one MCAP file, as ``ros2 bag record -s mcap`` or a ROS1 MCAP recorder would.

    Parameters
    ----------
    path : path-like
        Target ``.mcap`` file; replaced atomically if it exists.
    streams : sequence of Stream
        One channel per stream; messages of all streams interleaved in log-time order.
    profile : {"ros2", "ros1"}
        ``"ros2"``: CDR messages (ROS2 Humble definitions), ``ros2msg`` schemas named ``pkg/msg/Type``, channel
        metadata ``offered_qos_profiles`` (sensor-data QoS). ``"ros1"``: ROS1 serialisation (Noetic),
        ``ros1msg`` schemas named ``pkg/Type`` with the md5sum in the channel metadata.
    chunk_size : int
        Uncompressed bytes per chunk [B] (MCAP default 1 MiB). Smaller chunks lose less of a cut-short file.
    compression : {"zstd", "lz4", "none"}
        Chunk compression.
    message_index : bool
        Write per-chunk message indexes (16 B per message). Without them the file is still a valid,
        chunk-indexed MCAP that readers scan chunk by chunk; small sample logs leave them out.
    zstd_level : int
        zstd level of the chunks (the mcap library always uses 3; 19 makes committed samples smaller).

    Returns
    -------
    pathlib.Path
        The written file. Message ``log_time`` = ``publish_time`` = the table's ``log_time``; ``sequence`` is the
        row's index in its table (the publisher's counter, in stamp order).
    """
    from mcap.well_known import MessageEncoding, Profile, SchemaEncoding
    from mcap.writer import CompressionType, IndexType, Writer

    if profile not in ("ros2", "ros1"):
        raise ValueError(f"profile must be 'ros2' or 'ros1', got {profile!r}")
    ros1 = profile == "ros1"
    prepared = _prepare(streams)
    ts = _typestore(ros1)
    payloads = [_serialize(ts, p, ros1) for p in prepared]
    sidx, ridx, log = _merge_order(prepared)

    path = Path(path)
    with atomic_path(path) as tmp, open(tmp, "wb") as f, _zstd_level(zstd_level):
        index = IndexType.ALL if message_index else IndexType.ALL & ~IndexType.MESSAGE
        writer = Writer(f, chunk_size=chunk_size, compression=CompressionType[compression.upper()], index_types=index)
        writer.start(profile=Profile.ROS1 if ros1 else Profile.ROS2, library=_library_id())
        schema_ids: dict[str, int] = {}
        channel_ids = []
        for p in prepared:
            msgtype = p.stream.msgtype
            if msgtype not in schema_ids:
                msgdef, md5 = ts.generate_msgdef(msgtype, ros_version=1 if ros1 else 2)
                name = msgtype.replace("/msg/", "/") if ros1 else msgtype
                encoding = SchemaEncoding.ROS1 if ros1 else SchemaEncoding.ROS2
                schema_ids[msgtype] = writer.register_schema(name=name, encoding=encoding, data=msgdef.encode())
            if ros1:
                meta = {"md5sum": ts.generate_msgdef(msgtype)[1]}
            else:
                meta = {"offered_qos_profiles": _SENSOR_QOS_YAML}
            channel_ids.append(writer.register_channel(
                topic=p.stream.topic,
                message_encoding=MessageEncoding.ROS1 if ros1 else MessageEncoding.CDR,
                schema_id=schema_ids[msgtype],
                metadata=meta,
            ))
        for s, r, t in zip(sidx.tolist(), ridx.tolist(), log.tolist(), strict=True):
            writer.add_message(channel_id=channel_ids[s], log_time=t, data=payloads[s][r], publish_time=t,
                               sequence=r & 0xFFFFFFFF)
        writer.finish()
    return path


@contextmanager
def _zstd_level(level: int):
    """The mcap writer compresses chunks with the module-level `zstandard.compress` (level 3); swap in a
    compressor of another level for the duration of the write."""
    import mcap.writer as mw

    if level == 3 or mw.zstandard is None:
        yield
        return
    original = mw.zstandard
    compressor = original.ZstdCompressor(level=level)

    class _Leveled:
        def __getattr__(self, name):
            return getattr(original, name)

        @staticmethod
        def compress(data):
            return compressor.compress(data)

    mw.zstandard = _Leveled()
    try:
        yield
    finally:
        mw.zstandard = original


def write_ros1_bag(
    path: str | os.PathLike,
    streams: Sequence[Stream],
    *,
    compression: Literal["none", "bz2", "lz4"] = "none",
    chunk_size: int = 1024 * 1024,
) -> Path:
    """Write streams to a ROS1 bag (format 2.0) with ``rosbags.rosbag1.Writer``, as ``rosbag record`` would.

    Parameters
    ----------
    path : path-like
        Target ``.bag`` file; replaced atomically if it exists.
    streams : sequence of Stream
        One connection per stream (ROS1 Noetic definitions and md5sums); messages in log-time order, the record
        time of each message being the table's ``log_time``; ``header.seq`` is the row's index in its table.
    compression : {"none", "bz2", "lz4"}
        Chunk compression (``rosbag record`` writes "none" unless asked).
    chunk_size : int
        Uncompressed bytes per chunk [B] before the chunk is written out.

    Returns
    -------
    pathlib.Path
        The written file.
    """
    from rosbags.rosbag1 import Writer

    prepared = _prepare(streams)
    ts = _typestore(ros1=True)
    payloads = [_serialize(ts, p, ros1=True) for p in prepared]
    sidx, ridx, log = _merge_order(prepared)

    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.unlink()  # the rosbags writer creates its file itself and refuses to overwrite
        writer = Writer(tmp)
        if compression != "none":
            writer.set_compression(Writer.CompressionFormat[compression.upper()])
        writer.chunk_threshold = chunk_size
        with writer:
            conns = [writer.add_connection(p.stream.topic, p.stream.msgtype, typestore=ts) for p in prepared]
            for s, r, t in zip(sidx.tolist(), ridx.tolist(), log.tolist(), strict=True):
                writer.write(conns[s], t, payloads[s][r])
    return path


def write_ros2_bag(
    directory: str | os.PathLike,
    streams: Sequence[Stream],
    *,
    storage: Literal["sqlite3", "mcap"] = "sqlite3",
) -> Path:
    """Write streams to a ROS2 bag directory with ``rosbags.rosbag2.Writer``, as ``ros2 bag record`` would.

    Parameters
    ----------
    directory : path-like
        Target bag directory (``metadata.yaml`` + ``<name>.db3`` or ``<name>.mcap``); replaced if it exists
        (the new bag is complete in a temporary folder first; the swap is two renames).
    streams : sequence of Stream
        One connection per stream (ROS2 Humble definitions, RIHS01 hashes, sensor-data QoS); messages in
        log-time order with the table's ``log_time`` as the bag timestamp.
    storage : {"sqlite3", "mcap"}
        Storage plugin.

    Returns
    -------
    pathlib.Path
        The bag directory (rosbag2 metadata version 9).
    """
    from rosbags.rosbag2 import StoragePlugin, Writer

    plugin = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}.get(storage)
    if plugin is None:
        raise ValueError(f"storage must be 'sqlite3' or 'mcap', got {storage!r}")
    prepared = _prepare(streams)
    ts = _typestore(ros1=False)
    payloads = [_serialize(ts, p, ros1=False) for p in prepared]
    sidx, ridx, log = _merge_order(prepared)
    qos = [_sensor_qos()]

    directory = Path(directory)
    with _atomic_dir(directory) as tmp:
        with Writer(tmp, version=Writer.VERSION_LATEST, storage_plugin=plugin) as writer:
            conns = [writer.add_connection(p.stream.topic, p.stream.msgtype, typestore=ts, offered_qos_profiles=qos)
                     for p in prepared]
            for s, r, t in zip(sidx.tolist(), ridx.tolist(), log.tolist(), strict=True):
                writer.write(conns[s], t, payloads[s][r])
    return directory


@contextmanager
def _atomic_dir(target: Path):
    """Yield a not-yet-existing path named like `target` inside a temporary folder beside it; on success the
    finished directory replaces `target` (storage files inside a rosbag2 bag are named after the folder)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    holder = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    try:
        tmp = holder / target.name
        yield tmp
        if not target.exists():
            os.replace(tmp, target)
            return
        old = holder / (target.name + ".old")
        os.replace(target, old)
        try:
            os.replace(tmp, target)
        except BaseException:
            os.replace(old, target)  # put the previous bag back before the holder is removed
            raise
    finally:
        shutil.rmtree(holder, ignore_errors=True)


def _time_strings(ns: np.ndarray, time_format: str) -> np.ndarray:
    if time_format == "iso":  # ISO 8601, UTC, nanoseconds: 2024-05-01T12:00:00.123456789Z
        return np.char.add(np.datetime_as_string(ns.view("datetime64[ns]"), unit="ns"), "Z")
    if time_format == "unix":  # exact decimal seconds since the epoch: 1714564800.123456789
        a = np.abs(ns)
        sec, frac = np.divmod(a, _NS)
        s = np.char.add(np.char.add(sec.astype(str), "."), np.char.zfill(frac.astype(str), 9))
        return np.where(ns < 0, np.char.add("-", s), s)
    raise ValueError(f"time_format must be 'iso' or 'unix', got {time_format!r}")


def write_csv(path: str | os.PathLike, table: pd.DataFrame, *, time_format: Literal["iso", "unix"] = "iso") -> Path:
    """Write a table as a plain CSV with the ``time`` column first, as a data logger's export would.

    Parameters
    ----------
    path : path-like
        Target ``.csv`` file; replaced atomically if it exists.
    table : pandas.DataFrame
        Must have a ``time`` column (``datetime64[ns, UTC]``); every tz-aware datetime column is written in
        `time_format`. Floats are written with the shortest repr that reads back to the same double.
    time_format : {"iso", "unix"}
        ``"iso"``: ``2024-05-01T12:00:00.123456789Z``; ``"unix"``: seconds since the epoch with 9 decimals
        (exact to the nanosecond, unlike a float).

    Returns
    -------
    pathlib.Path
        The written file.
    """
    if "time" not in table.columns:
        raise ValueError("write_csv: the table has no 'time' column")
    out = table.reset_index(drop=True)
    out = out[["time", *[c for c in out.columns if c != "time"]]].copy()
    for c in out.columns:
        if isinstance(out[c].dtype, pd.DatetimeTZDtype):
            out[c] = _time_strings(_time_ns(out, c, "write_csv"), time_format)
        elif c == "time":
            raise ValueError(f"write_csv: column 'time' must be datetime64[ns, UTC], got {out[c].dtype}")
    path = Path(path)
    with atomic_path(path) as tmp:
        out.to_csv(tmp, index=False, lineterminator="\n")
    return path


def truncate(
    path: str | os.PathLike,
    keep_fraction: float,
    *,
    dest: str | os.PathLike | None = None,
    crash: bool = True,
) -> Path:
    """Cut a log short as a logger that lost power would leave it: no footer, no index, no summary.

    Parameters
    ----------
    path : path-like
        A log file (``.mcap``, ``.bag``, ``.db3``, ``.csv``, …) or a rosbag2 directory (its ``.db3`` / ``.mcap``
        storage files are cut).
    keep_fraction : float
        Fraction of the bytes kept, in (0, 1]; the cut falls wherever that is, usually inside a record.
        1 keeps every byte and, with `crash`, only imitates the recorder's missing close: the realistic crash
        of an SQLite bag, which is intact up to its last commit.
    dest : path-like, optional
        Write the damaged copy here and leave `path` untouched; default: damage `path` in place.
    crash : bool
        Besides the byte cut, leave what a recorder that died leaves: a ROS1 bag's file header goes back to the
        unindexed state ``rosbag record`` writes on open (``index_pos`` = ``conn_count`` = ``chunk_count`` = 0);
        a rosbag2 directory loses ``metadata.yaml`` (written on close). An MCAP needs nothing more: its writer
        never goes back to the start. ``crash=False`` is a plain byte cut (e.g. an interrupted copy).

    Returns
    -------
    pathlib.Path
        The damaged file or directory. Damage in place is not atomic, on purpose; a damaged copy at `dest` (a
        file) appears atomically.
    """
    if not 0.0 < keep_fraction <= 1.0:
        raise ValueError(f"keep_fraction must be in (0, 1], got {keep_fraction}")
    src = Path(path)
    if not src.exists():
        raise FileNotFoundError(src)
    target = src if dest is None else Path(dest)
    if src.is_dir():
        if dest is not None:
            if target.exists():
                shutil.rmtree(target)
            shutil.copytree(src, target)
        storage = sorted(f for f in target.iterdir() if f.suffix in (".db3", ".mcap"))
        if not storage:
            raise ValueError(f"{src}: no .db3 or .mcap storage file in this directory")
        for f in storage:
            os.truncate(f, int(f.stat().st_size * keep_fraction))
        if crash:
            (target / "metadata.yaml").unlink(missing_ok=True)
        return target
    keep = int(src.stat().st_size * keep_fraction)
    if dest is None:
        os.truncate(src, keep)
        if crash:
            _unindex_ros1_bag(target)
        return target
    with atomic_path(target) as tmp:  # the damaged copy appears whole (the damage itself is deliberate)
        with open(src, "rb") as fi, open(tmp, "wb") as fo:
            fo.write(fi.read(keep))
        if crash:
            _unindex_ros1_bag(tmp)
    return target


_BAG_MAGIC = b"#ROSBAG V2.0\n"


def _unindex_ros1_bag(path: Path) -> None:
    """Zero index_pos / conn_count / chunk_count in a ROS1 bag's file header (same layout, fixed-width values)."""
    with open(path, "r+b") as f:
        head = f.read(len(_BAG_MAGIC) + 4096)
        if not head.startswith(_BAG_MAGIC):
            return
        for name, width in ((b"index_pos=", 8), (b"conn_count=", 4), (b"chunk_count=", 4)):
            at = head.find(name)
            if at < 0 or at + len(name) + width > len(head):
                continue
            f.seek(at + len(name))
            f.write(bytes(width))

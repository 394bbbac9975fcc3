"""From log topics to the motion table (``motions.parquet``, DESIGN §5). Pure computation: no file I/O.

Conventions (DESIGN §3): body FLU (x forward, y port, z up), world ENU; roll positive starboard down, pitch
positive bow down, yaw positive bow to port — exactly the ZYX Euler angles of the body→ENU rotation of REP-103
(``seatune.physics.imu.attitude`` builds its quaternion the same way). Heading ψ [deg] is the compass heading,
ψ = 90° − yaw_ENU. Angles in radians; columns in degrees end in ``_deg``; times ``datetime64[ns, UTC]``.

Columns produced: ``imu_motions`` → time, roll, pitch, heading_deg, roll_rate, pitch_rate, yaw_rate (body rates
p, q, r [rad/s]), imu_fx, imu_fy, imu_fz (specific force [m/s²], body FLU); ``gnss_motions`` → time, lat, lon
[deg], sog [m/s], cog_deg; ``resample`` joins them on one uniform UTC grid with a ``record`` column.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from seatune.errors import UserError
from seatune.io.log_readers import FIX, IMU, ODOM, TWIST, VEC3, LogContents, TopicTable

__all__ = [
    "GNSS_COLUMNS",
    "IMU_COLUMNS",
    "UNITS",
    "IngestReport",
    "UnitFinding",
    "LogSources",
    "build_motions",
    "check_named_topics",
    "check_units",
    "gnss_motions",
    "imu_motions",
    "log_sources",
    "no_imu_error",
    "overlap_counts",
    "mounting_warnings",
    "repair_time",
    "resample",
    "tf_mounting",
    "unit_findings",
]

IMU_COLUMNS = ("roll", "pitch", "heading_deg", "roll_rate", "pitch_rate", "yaw_rate", "imu_fx", "imu_fy", "imu_fz")
GNSS_COLUMNS = ("lat", "lon", "sog", "cog_deg")
#: Unit of every motion-table column, for the Parquet field metadata (seatune.io.parquet.write_table).
UNITS = {"time": "", "record": "", "roll": "rad", "pitch": "rad", "heading_deg": "deg", "roll_rate": "rad/s",
         "pitch_rate": "rad/s", "yaw_rate": "rad/s", "imu_fx": "m/s^2", "imu_fy": "m/s^2", "imu_fz": "m/s^2",
         "lat": "deg", "lon": "deg", "sog": "m/s", "cog_deg": "deg"}

G0 = 9.80665  # standard gravity [m/s²] (an accelerometer reporting in g)
_DEG = 180.0 / np.pi
_NS = 1_000_000_000

# angle-valued columns: unwrapped before interpolation, wrapped back after — (period, lower bound of the range)
_WRAPPED = {"roll": (2 * np.pi, -np.pi), "pitch": (2 * np.pi, -np.pi), "yaw": (2 * np.pi, -np.pi),
            "heading_deg": (360.0, 0.0), "cog_deg": (360.0, 0.0), "lon": (360.0, -180.0)}

# NED/FRD → ENU/FLU (REP-103): v_ENU = A v_NED (swap north/east, flip down), v_FLU = B v_FRD (flip y and z).
# Both are proper rotations (180° about (1, 1, 0)/√2 and about x), so R_ENU←FLU = A · R_NED←FRD · B.
_A_ENU_NED = Rotation.from_matrix([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
_B_FRD_FLU = Rotation.from_matrix([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
_FLIP_YZ = np.array([1.0, -1.0, -1.0])


@dataclass
class IngestReport:
    """What ingest repaired, masked or converted (DESIGN §6: counted, never silent)."""

    counts: dict[str, int] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # what was applied (the IMU mounting and where it came from)

    def add(self, counts: dict[str, int]) -> None:
        for k, v in counts.items():
            self.counts[k] = self.counts.get(k, 0) + int(v)


# ---------------------------------------------------------------------------------------------------- helpers


def _source(t: TopicTable | LogContents | None) -> str | None:
    if isinstance(t, LogContents):
        return str(t.path)
    return getattr(t, "source", None)


def _pick(log: LogContents, msgtype: str) -> TopicTable | None:
    found = log.of_type(msgtype)
    if msgtype == IMU and found:  # prefer an IMU that reports orientation, then the longest
        found.sort(key=lambda t: (-int(t.table["qw"].notna().any()), -len(t.table)))
    return found[0] if found else None


def _seconds(time: pd.Series) -> np.ndarray:
    ns = time.astype("int64").to_numpy()
    return (ns - ns[0]) / 1e9 if len(ns) else ns.astype(float)


# ---------------------------------------------------------------------------------------------------- IMU


def imu_motions(imu: TopicTable | LogContents | None, frame: str = "FLU",
                mounting: Rotation | None = None) -> pd.DataFrame:
    """Attitude, body rates and specific force from a ``sensor_msgs/msg/Imu`` topic.

    Parameters
    ----------
    imu : TopicTable or LogContents
        The IMU topic (a :class:`LogContents` → its IMU topic with orientation and the most messages).
    frame : {"FLU", "NED", "auto"}
        ``"FLU"``: REP-103 — orientation = rotation body FLU → world ENU, vectors in body FLU. ``"NED"``: the IMU
        reports an FRD body in a NED world (marine MRUs, Fossen); converted as R_ENU←FLU = A R_NED←FRD B with
        A = [[0,1,0],[1,0,0],[0,0,−1]] (NED → ENU) and B = diag(1,−1,−1) (FLU → FRD), and body vectors
        (ω, f) as B·v. ``"auto"``: NED when ``frame_id`` ends in ``_ned`` (REP-103's rule for NED frames).
    mounting : scipy Rotation, optional
        Sensor (FLU) → body rotation M (v_body = M v_sensor, the vessel YAML's ``sensors.<tag>.rotation`` or
        /tf_static): rates and specific force become M·v, the attitude R_ENU←body = R_ENU←sensor M⁻¹.

    Returns
    -------
    pandas.DataFrame
        ``time`` (header stamp) and :data:`IMU_COLUMNS`; roll, pitch [rad] = ZYX Euler angles of R_ENU←FLU
        (roll + starboard down, pitch + bow down), heading_deg = (90° − yaw_ENU) mod 360; NaN attitude where
        the orientation is not provided (covariance[0] = −1) or not a unit quaternion — unless the table
        carries ``roll``, ``pitch``, ``heading_deg`` columns itself (a CSV export; seatune convention, taken
        as they are, FLU only). Absent columns (a CSV without a quaternion or without accelerations) give NaN.
    """
    if isinstance(imu, LogContents):
        log = imu
        imu = _pick(log, IMU)
        if imu is None:
            have = ", ".join(f"{t.topic} ({t.msgtype})" for t in log.topics.values()) or "none"
            raise UserError(str(log.path), None, f"no sensor_msgs/Imu topic (topics: {have})")
    if imu is None:
        raise UserError(None, None, "no sensor_msgs/Imu topic")
    if imu.msgtype != IMU:
        raise UserError(_source(imu), f"topic {imu.topic}", f"no sensor_msgs/Imu topic: {imu.msgtype}")
    if frame not in ("FLU", "NED", "auto"):
        raise ValueError(f"frame must be 'FLU', 'NED' or 'auto', got {frame!r}")
    ned = frame == "NED" or (frame == "auto" and imu.frame_id.lower().endswith("_ned"))

    t = imu.table
    n = len(t)
    q = t.reindex(columns=["qx", "qy", "qz", "qw"]).to_numpy(dtype=np.float64)  # absent columns: NaN
    w = t.reindex(columns=["wx", "wy", "wz"]).to_numpy(dtype=np.float64)
    f = t.reindex(columns=["ax", "ay", "az"]).to_numpy(dtype=np.float64)
    if ned:
        w, f = w * _FLIP_YZ, f * _FLIP_YZ
    if mounting is not None:
        w, f = mounting.apply(w), mounting.apply(f)
    norm = np.linalg.norm(q, axis=1)
    ok = np.isfinite(norm) & (np.abs(norm - 1.0) < 0.1)  # a unit quaternion (all zeros = orientation unknown)
    roll = np.full(n, np.nan)
    pitch = np.full(n, np.nan)
    yaw = np.full(n, np.nan)
    if ok.any():
        r = Rotation.from_quat(q[ok])  # ROS order (x, y, z, w) = scipy's scalar-last default
        if ned:
            r = _A_ENU_NED * r * _B_FRD_FLU
        if mounting is not None:
            r = r * mounting.inv()
        ypr = r.as_euler("ZYX")  # intrinsic: yaw about z, pitch about y', roll about x''
        yaw[ok], pitch[ok], roll[ok] = ypr[:, 0], ypr[:, 1], ypr[:, 2]
    heading = np.mod(90.0 - yaw * _DEG, 360.0)
    given = [c for c in ("roll", "pitch", "heading_deg") if c in t.columns]
    if given and not ok.all():  # a table export (CSV) with the attitude as angles instead of a quaternion
        for c, arr in (("roll", roll), ("pitch", pitch), ("heading_deg", heading)):
            if c in given:
                arr[~ok] = t[c].to_numpy(dtype=np.float64)[~ok]
        if mounting is not None:  # the given angles are the sensor's attitude too
            rows = ~ok & np.isfinite(roll) & np.isfinite(pitch)
            yaw_given = np.radians(90.0 - np.nan_to_num(heading[rows]))
            r = Rotation.from_euler("ZYX", np.column_stack([yaw_given, pitch[rows], roll[rows]])) * mounting.inv()
            ypr = r.as_euler("ZYX")
            pitch[rows], roll[rows] = ypr[:, 1], ypr[:, 2]
            heading[rows] = np.where(np.isfinite(heading[rows]), np.mod(90.0 - ypr[:, 0] * _DEG, 360.0), np.nan)
    out = pd.DataFrame({
        "time": t["time"].reset_index(drop=True),
        "roll": roll,
        "pitch": pitch,
        "heading_deg": heading,
        "roll_rate": w[:, 0],
        "pitch_rate": w[:, 1],
        "yaw_rate": w[:, 2],
        "imu_fx": f[:, 0],
        "imu_fy": f[:, 1],
        "imu_fz": f[:, 2],
    }, copy=False)
    no_att = int((~ok & ~np.isfinite(roll)).sum())
    out.attrs = {"source": _source(imu), "topic": imu.topic, "frame": "NED→FLU" if ned else "FLU",
                 "no_orientation": no_att}
    return out


# ---------------------------------------------------------------------------------------------------- GNSS

_WGS84_A = 6378137.0
_WGS84_E2 = 6.69437999014e-3


def _radii(lat_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """WGS-84 meridional (M) and prime-vertical (N) radii of curvature [m] at a latitude."""
    s2 = np.sin(np.radians(lat_deg)) ** 2
    d = 1.0 - _WGS84_E2 * s2
    return _WGS84_A * (1 - _WGS84_E2) / d**1.5, _WGS84_A / np.sqrt(d)


def gnss_motions(fix: TopicTable | None, vel: TopicTable | None) -> pd.DataFrame:
    """Position, speed and course over ground from NavSatFix and velocity topics.

    Parameters
    ----------
    fix : TopicTable or None
        ``sensor_msgs/msg/NavSatFix``; fixes with ``status`` −1 (no fix) or NaN positions are left out (their
        number in ``attrs["no_fix"]``).
    vel : TopicTable or None
        ``geometry_msgs/msg/TwistStamped`` with the velocity over ground in ENU (x east, y north — what GNSS
        drivers publish), or NED when ``frame_id`` ends in ``_ned``; or ``nav_msgs/msg/Odometry``, whose twist
        (in the body, ``child_frame_id``) is rotated by its pose orientation into ``frame_id`` (ENU, or NED).

    Returns
    -------
    pandas.DataFrame
        ``time``, ``lat``, ``lon`` [deg], ``sog`` [m/s], ``cog_deg`` [deg clockwise from true North], one row per
        stamp of either topic (outer join). sog/cog come from the velocity when given, else from successive fixes
        (central differences on the WGS-84 ellipsoid, ``np.gradient``); at standstill cog is NaN.
    """
    if fix is None and vel is None:
        raise UserError(None, None, "no sensor_msgs/NavSatFix or velocity topic")
    parts = []
    no_fix = 0
    lat = lon = t_fix = None
    if fix is not None:
        if fix.msgtype != FIX:
            raise UserError(_source(fix), f"topic {fix.topic}", f"not a sensor_msgs/NavSatFix topic: {fix.msgtype}")
        ft = fix.table
        good = ft["latitude"].notna().to_numpy() & ft["longitude"].notna().to_numpy()
        if "status" in ft.columns:
            good &= ~(ft["status"].to_numpy() < 0)
        no_fix = int((~good).sum())
        ft = ft[good]
        t_fix = ft["time"].reset_index(drop=True)
        lat = ft["latitude"].to_numpy(dtype=np.float64)
        lon = ft["longitude"].to_numpy(dtype=np.float64)
        parts.append(pd.DataFrame({"time": t_fix, "lat": lat, "lon": lon}))
    if vel is not None:
        if vel.msgtype not in (TWIST, ODOM):
            raise UserError(_source(vel), f"topic {vel.topic}", f"not a velocity topic: {vel.msgtype}")
        vt = vel.table
        v = vt.reindex(columns=["vx", "vy", "vz"]).to_numpy(dtype=np.float64)
        if vel.msgtype == ODOM:  # nav_msgs/Odometry: twist in child_frame_id (the body) → rotate into frame_id
            q = vt[["qx", "qy", "qz", "qw"]].to_numpy(dtype=np.float64)
            ok = np.isfinite(q).all(axis=1) & (np.abs(np.linalg.norm(q, axis=1) - 1) < 0.1)
            world = np.full_like(v, np.nan)
            if ok.any():
                world[ok] = Rotation.from_quat(q[ok]).apply(v[ok])
            v = world
        vx, vy = v[:, 0], v[:, 1]
        ve, vn = (vy, vx) if vel.frame_id.lower().endswith("_ned") else (vx, vy)
        sog = np.hypot(ve, vn)
        cog = np.where(sog > 0, np.mod(np.degrees(np.arctan2(ve, vn)), 360.0), np.nan)
        parts.append(pd.DataFrame({"time": vt["time"].reset_index(drop=True), "sog": sog, "cog_deg": cog}))
    elif lat is not None and len(lat) > 1:
        ts = _seconds(t_fix)
        m, nrad = _radii(lat)
        lat_u = np.unwrap(np.radians(lat))
        lon_u = np.unwrap(np.radians(lon))
        dt_ok = np.diff(ts) > 0
        if dt_ok.all():
            vn = m * np.gradient(lat_u, ts)
            ve = nrad * np.cos(lat_u) * np.gradient(lon_u, ts)
        else:  # repeated stamps: the caller should run repair_time first; differences would divide by zero
            vn = ve = np.full(len(ts), np.nan)
        sog = np.hypot(ve, vn)
        cog = np.where(sog > 0, np.mod(np.degrees(np.arctan2(ve, vn)), 360.0), np.nan)
        parts[0]["sog"], parts[0]["cog_deg"] = sog, cog
    if len(parts) == 2:
        out = pd.merge(parts[0], parts[1], on="time", how="outer", sort=True)
    else:
        out = parts[0]
        for c in GNSS_COLUMNS:
            if c not in out.columns:
                out[c] = np.nan
    out = out[["time", *GNSS_COLUMNS]].reset_index(drop=True)
    out.attrs = {"source": _source(fix if fix is not None else vel), "no_fix": no_fix}
    return out


# ---------------------------------------------------------------------------------------------------- time


def repair_time(table: pd.DataFrame | TopicTable) -> tuple[pd.DataFrame | TopicTable, dict[str, int]]:
    """Sort rows by ``time`` (stable: receive order kept among equal stamps) and drop repeated stamps (the first
    received is kept).

    Returns
    -------
    (table, counts)
        The repaired table (same type as given) and ``non_monotonic_repaired`` (rows whose stamp was earlier
        than the previous row's), ``duplicates_removed``, ``missing_stamps_removed`` (NaT).
    """
    df = table.table if isinstance(table, TopicTable) else table
    ns = df["time"].astype("int64").to_numpy() if len(df) else np.zeros(0, dtype=np.int64)
    nat = df["time"].isna().to_numpy()
    valid_ns = ns[~nat]
    backwards = int((np.diff(valid_ns) < 0).sum())
    order = np.argsort(np.where(nat, np.iinfo(np.int64).max, ns), kind="stable")
    order = order[~nat[order]]
    sorted_ns = ns[order]
    dup = np.zeros(len(order), dtype=bool)
    dup[1:] = sorted_ns[1:] == sorted_ns[:-1]
    keep = order[~dup]
    if len(keep) == len(df) and (np.diff(keep) == 1).all():  # already in order: no copy
        out = df if df.index.equals(pd.RangeIndex(len(df))) else df.reset_index(drop=True)
    else:  # column by column: DataFrame.iloc would first join the columns into one block (3× the memory)
        out = pd.DataFrame({c: df[c].take(keep).reset_index(drop=True) for c in df.columns}, copy=False)
    out.attrs = dict(df.attrs)
    counts = {"non_monotonic_repaired": backwards, "duplicates_removed": int(dup.sum()),
              "missing_stamps_removed": int(nat.sum())}
    if isinstance(table, TopicTable):
        return TopicTable(table.topic, table.msgtype, table.frame_id, out, table.source), counts
    return out, counts


# ---------------------------------------------------------------------------------------------------- resample


def _period_ns(ns: np.ndarray) -> float:
    d = np.diff(ns)
    d = d[d > 0]
    return float(np.median(d)) if len(d) else 0.0


def _segments(ns: np.ndarray, thr_ns: float) -> np.ndarray:
    """(k, 2) start/end of the runs of stamps whose successive spacing is ≤ thr."""
    if len(ns) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    brk = np.flatnonzero(np.diff(ns) > thr_ns)
    starts = np.concatenate([[0], brk + 1])
    ends = np.concatenate([brk, [len(ns) - 1]])
    return np.stack([ns[starts], ns[ends]], axis=1)


def _bracket_ok(t: np.ndarray, grid: np.ndarray, thr: float) -> tuple[np.ndarray, np.ndarray]:
    """(valid, gap) for each grid point: on a sample, or between two samples ≤ thr apart; gap = their spacing."""
    j = np.searchsorted(t, grid, side="right")
    left = np.clip(j - 1, 0, len(t) - 1)
    right = np.clip(j, 0, len(t) - 1)
    on = (j >= 1) & (t[left] == grid)
    gap = (t[right] - t[left]).astype(np.float64)
    inside = (j >= 1) & (j < len(t))
    return on | (inside & (gap <= thr)), np.where(on, 0.0, np.where(inside, gap, np.inf))


def _interp(t: np.ndarray, v: np.ndarray, grid: np.ndarray, thr: float, wrap: tuple | None) -> np.ndarray:
    ok = np.isfinite(v)
    if not ok.any():
        return np.full(len(grid), np.nan)
    t, v = t[ok], v[ok]
    if wrap is not None:
        v = np.unwrap(v, period=wrap[0])
    out = np.interp(grid, t, v)
    valid, _ = _bracket_ok(t, grid, thr)
    out[~valid] = np.nan
    if wrap is not None:
        period, low = wrap
        out = np.mod(out - low, period) + low
    return out


def resample(tables: Sequence[pd.DataFrame], rate_hz: float, max_gap_s: float,
             keep: tuple[int, int] | None = None) -> tuple[pd.DataFrame, dict]:
    """Join sources on one uniform UTC grid per contiguous record.

    Parameters
    ----------
    tables : sequence of DataFrame
        Each with a ``time`` column and numeric columns. Tables with the same columns are one source (e.g. the
        IMU motions of several logs back to back) and are concatenated; different sources must not share
        columns.
    rate_hz : float
        Grid rate; grid instants are whole multiples of the period since the Unix epoch, so records of different
        logs line up.
    max_gap_s : float
        A source is interpolated (linearly; angle columns unwrapped first and wrapped back) only between samples
        at most ``max(max_gap_s, 1.5 × its own median spacing)`` apart — so a 1 Hz GNSS survives a 0.5 s limit;
        elsewhere its columns are NaN (masked). Where *every* source pauses for more than `max_gap_s`, the
        record ends and a new one starts (``record`` = 0, 1, …): nothing is invented across a logging gap.
    keep : (start, end) in ns since the epoch, optional
        Only the grid instants start ≤ t < end, counted over those alone: one piece of a long log, given the
        sources a margin wider (longer than their gaps) so the piece equals that stretch of the whole table.

    Returns
    -------
    (DataFrame, counts)
        ``time``, ``record`` and every source column; counts ``records``, ``gaps_split``,
        ``samples_interpolated`` (grid samples filled across missing samples of a source), ``samples_masked``
        (grid samples a source leaves NaN inside a record), ``duplicates_removed``, ``non_monotonic_repaired``.
    """
    if rate_hz <= 0 or max_gap_s <= 0:
        raise ValueError("rate_hz and max_gap_s must be positive")
    dt = int(round(_NS / rate_hz))
    gap_ns = max_gap_s * _NS
    counts = {"records": 0, "gaps_split": 0, "samples_interpolated": 0, "samples_masked": 0,
              "duplicates_removed": 0, "non_monotonic_repaired": 0}

    groups: dict[tuple, list[pd.DataFrame]] = {}
    for df in tables:
        if df is None or len(df) == 0:
            continue
        cols = tuple(c for c in df.columns if c != "time")
        groups.setdefault(cols, []).append(df)
    seen: dict[str, tuple] = {}
    for cols in groups:
        for c in cols:
            if c in seen and seen[c] != cols:
                raise ValueError(f"column {c!r} appears in two different sources: {seen[c]} and {cols}")
            seen[c] = cols
    sources = []
    for cols, dfs in groups.items():
        df = pd.concat(dfs, ignore_index=True) if len(dfs) > 1 else dfs[0]
        if keep is not None:  # the repairs of this piece's own stretch, not of the margins
            core = df["time"].astype("int64").to_numpy()
            _, c = repair_time(df[(core >= keep[0]) & (core < keep[1])])
            df, _ = repair_time(df)
        else:
            df, c = repair_time(df)
        counts["duplicates_removed"] += c["duplicates_removed"]
        counts["non_monotonic_repaired"] += c["non_monotonic_repaired"]
        ns = df["time"].astype("int64").to_numpy()
        data = df[list(cols)]
        anyv = data.notna().any(axis=1).to_numpy()
        period = _period_ns(ns[anyv])
        thr = max(gap_ns, 1.5 * period)
        sources.append((cols, ns, data, anyv, period, thr))
    columns = [c for cols, *_ in sources for c in cols]
    segs = np.concatenate([_segments(ns[anyv], thr) for _, ns, _, anyv, _, thr in sources]) if sources else []
    if len(segs) == 0:  # nothing but NaN
        empty = {"time": pd.Series([], dtype="datetime64[ns, UTC]"), "record": np.zeros(0, np.int64),
                 **{c: np.zeros(0) for c in columns}}
        return pd.DataFrame(empty), counts

    # records: the union of every source's covered stretches, split where all of them pause > max_gap_s
    segs = segs[np.argsort(segs[:, 0], kind="stable")]
    records = []
    cur_s, cur_e = segs[0]
    for s, e in segs[1:]:
        if s - cur_e <= gap_ns:
            cur_e = max(cur_e, e)
        else:
            records.append((cur_s, cur_e))
            cur_s, cur_e = s, e
    records.append((cur_s, cur_e))

    grids = []
    for s, e in records:
        first = -(-int(s) // dt) * dt
        g = np.arange(first, int(e) + 1, dt, dtype=np.int64)
        if keep is not None:
            g = g[(g >= keep[0]) & (g < keep[1])]
        if len(g):
            grids.append(g)
    counts["records"] = len(grids)
    counts["gaps_split"] = max(len(grids) - 1, 0)
    if not grids:  # records shorter than one grid step
        empty = {"time": pd.Series([], dtype="datetime64[ns, UTC]"), "record": np.zeros(0, np.int64),
                 **{c: np.zeros(0) for c in columns}}
        return pd.DataFrame(empty), counts
    grid = np.concatenate(grids)
    record = np.concatenate([np.full(len(g), i, dtype=np.int64) for i, g in enumerate(grids)])
    g0 = grid[0]
    gf = (grid - g0).astype(np.float64)
    out = {"time": pd.Series(pd.DatetimeIndex(grid.view("datetime64[ns]"), tz="UTC")), "record": record}
    for cols, ns, data, anyv, period, thr in sources:
        tf = (ns - g0).astype(np.float64)
        rows_t = tf[anyv]
        if len(rows_t) == 0:
            counts["samples_masked"] += len(gf)
            out.update({c: np.full(len(gf), np.nan) for c in cols})
            continue
        valid, gapv = _bracket_ok(rows_t, gf, thr)
        counts["samples_interpolated"] += int((valid & (gapv > 1.5 * period)).sum()) if period else 0
        counts["samples_masked"] += int((~valid).sum())
        for c in cols:
            v = data[c].to_numpy(dtype=np.float64)
            out[c] = _interp(tf, v, gf, thr, _WRAPPED.get(c))
    return pd.DataFrame(out)[["time", "record", *columns]], counts


# ---------------------------------------------------------------------------------------------------- units

# motion-table column → the table-log field it comes from (for the column named in an error)
_FIELD = {"roll": "roll", "pitch": "pitch", "roll_rate": "wx", "pitch_rate": "wy", "yaw_rate": "wz",
          "imu_fx": "ax", "imu_fy": "ay", "imu_fz": "az", "sog": "vx"}


@dataclass
class UnitFinding:
    """Evidence that columns are not in SI: ``unit`` is what they look like (deg, deg/s, g, knots, km/h);
    ``certain`` = unambiguous (the old guesser converted these), else only "probably"."""

    columns: tuple[str, ...]
    unit: str
    evidence: str
    certain: bool = True


def _slope(x: np.ndarray, y: np.ndarray) -> float | None:
    """Least-squares slope of y on x through the origin, None without enough signal."""
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 50:
        return None
    x, y = x[ok], y[ok]
    sxx = float(np.dot(x, x))
    if sxx <= 0 or np.std(x) < 1e-9:
        return None
    return float(np.dot(x, y) / sxx)


def _p99(v: np.ndarray) -> float:
    v = np.abs(v[np.isfinite(v)])
    return float(np.percentile(v, 99)) if len(v) else float("nan")


def unit_findings(df: pd.DataFrame, *, angles: bool = True) -> list[UnitFinding]:
    """What the numbers say about the units of a motion table; changes nothing.

    - specific force ``imu_fx/fy/fz``: median |f| ≈ 1 instead of 9.81 m/s² → in g;
    - ``roll/pitch`` vs ``roll_rate/pitch_rate``: slope of d(angle)/dt on the rate 57.3 → angle in degrees,
      1/57.3 → rate in deg/s, 1 with |angle| 99th percentile > 1.6 (92° if radians) → both in degrees; without
      the pair, |angle| 99th percentile > 1.6 (and ≤ 180) → degrees, > 0.8 → probably; rates: > 1.6 rad/s →
      deg/s, > 1.0 → probably;
    - ``heading_deg`` all within ±2π with a spread → probably radians;
    - ``sog`` vs the speed from successive ``lat/lon``: ratio 1.944 → knots, 3.6 → km/h.

    ``angles=False`` skips the angle checks (angles computed from a quaternion cannot be in degrees).
    """
    out: list[UnitFinding] = []
    n = len(df)
    if n == 0:
        return out
    fcols = tuple(c for c in ("imu_fx", "imu_fy", "imu_fz") if c in df.columns)
    if fcols:
        f = df[list(fcols)].to_numpy(dtype=np.float64)
        norm = np.sqrt(np.nansum(f**2, axis=1))[np.isfinite(f).any(axis=1)]
        med = float(np.median(norm)) if len(norm) else float("nan")
        if 0.8 <= med <= 1.25:
            out.append(UnitFinding(fcols, "g", f"median |f| {med:.3f} (≈ 1 g; 9.81 expected in m/s²)"))
    secs = _seconds(df["time"]) if "time" in df.columns and n > 1 else None
    rate_done = set()
    for angle, rate in (("roll", "roll_rate"), ("pitch", "pitch_rate")):
        if angle not in df.columns:
            continue
        a = df[angle].to_numpy(dtype=np.float64)
        k = None
        if rate in df.columns and secs is not None and (np.diff(secs) > 0).all():
            ok = np.isfinite(a)
            if ok.sum() >= 50:
                dadt = np.full(n, np.nan)
                dadt[ok] = np.gradient(a[ok], secs[ok])
                k = _slope(df[rate].to_numpy(dtype=np.float64), dadt)
        if k is not None and 0.8 <= k / _DEG <= 1.25 and angles:
            out.append(UnitFinding((angle,), "deg", f"d{angle}/dt = {k:.1f} × {rate}"))
            rate_done.add(rate)
            continue
        if k is not None and 0.8 <= k * _DEG <= 1.25:
            out.append(UnitFinding((rate,), "deg/s", f"d{angle}/dt = {k:.4f} × {rate}"))
            rate_done.add(rate)
            continue
        p = _p99(a)
        if k is not None and 0.8 <= k <= 1.25:  # consistent units: both rad or both degrees
            rate_done.add(rate)
            if angles and p > 0.8:
                certain = p > 1.6 and np.nanmax(np.abs(a)) <= 180.0
                out.append(UnitFinding((angle, rate), "deg", f"{angle} and {rate} agree and |{angle}| 99th "
                                       f"percentile {p:.3g} (> {'92' if certain else '46'}° if radians)", certain))
            continue
        if angles and p > 0.8:
            certain = p > 1.6 and np.nanmax(np.abs(a)) <= 180.0
            out.append(UnitFinding((angle,), "deg", f"|{angle}| 99th percentile {p:.3g} "
                                   f"(> {'92' if certain else '46'}° if radians)", certain))
    for rate in ("roll_rate", "pitch_rate", "yaw_rate"):
        if rate in df.columns and rate not in rate_done:
            p = _p99(df[rate].to_numpy(dtype=np.float64))
            if p > 1.0:
                out.append(UnitFinding((rate,), "deg/s", f"|{rate}| 99th percentile {p:.3g} "
                                       f"(> {'92' if p > 1.6 else '57'}°/s if rad/s)", p > 1.6))
    if angles and "heading_deg" in df.columns:
        h = df["heading_deg"].to_numpy(dtype=np.float64)
        h = h[np.isfinite(h)]
        if len(h) > 10 and np.abs(h).max() <= 2 * np.pi + 0.01 and np.ptp(h) > 0.5:
            out.append(UnitFinding(("heading_deg",), "rad", "every value within ±2π", False))
    if {"lat", "lon", "sog", "time"} <= set(df.columns) and n > 10:
        sub = df[["time", "lat", "lon", "sog"]].dropna()
        if len(sub) > 10:
            ts = _seconds(sub["time"])
            if (np.diff(ts) > 0).all():
                lat = sub["lat"].to_numpy()
                m, nrad = _radii(lat)
                vn = m * np.gradient(np.radians(lat), ts)
                ve = nrad * np.cos(np.radians(lat)) * np.gradient(np.unwrap(np.radians(sub["lon"].to_numpy())), ts)
                fixes = np.median(np.hypot(ve, vn))
                sog = float(np.median(sub["sog"]))
                if fixes > 0.5 and sog > 0:
                    ratio = sog / fixes
                    for name, factor in (("knots", 3600 / 1852), ("km/h", 3.6)):
                        if abs(ratio / factor - 1) < 0.1:
                            out.append(UnitFinding(("sog",), name,
                                                   f"sog = {ratio:.2f} × the speed from successive fixes"))
                            break
    return out


def check_units(df: pd.DataFrame, source: TopicTable, *, table: bool) -> list[str]:
    """The units policy: ROS message fields are SI by definition (REP-103/145) and are never rescaled — a
    finding only warns. A table log's (CSV / Parquet) column whose unit the run YAML does not declare and whose
    numbers say degrees, g, knots or km/h stops ingest with a UserError naming the column and the evidence;
    weaker evidence warns. Returns the warnings."""
    declared = source.table.attrs.get("declared_units", {})
    log_columns = source.table.attrs.get("log_columns", {})
    cols = source.table.columns
    quaternion = "qw" in cols and source.table["qw"].notna().any()
    given_angles = table and not quaternion and bool({"roll", "pitch"} & set(cols))  # not from a quaternion
    notes = []
    for f in unit_findings(df, angles=given_angles):
        if not table:
            cols = ", ".join(f.columns)
            notes.append(f"{cols} look{'s' if len(f.columns) == 1 else ''} like {f.unit}: {f.evidence}; "
                         f"{source.msgtype} is SI by definition (REP-103): left as is")
            continue
        cols = [c for c in f.columns if _FIELD.get(c, c) not in declared]
        if not cols:
            continue
        names = [log_columns.get(_FIELD.get(c, c), c) for c in cols]
        if not f.certain:
            notes.append(f"{', '.join(names)}: {f.evidence}: probably {f.unit}; left as is (declare the unit "
                         "in the run YAML's columns to be sure)")
            continue
        units = ["deg/s" if f.unit == "deg" and c.endswith("_rate") else f.unit for c in cols]
        example = ", ".join(f"{n}: {{name: {c}, unit: {u}}}" for n, c, u in zip(names, cols, units, strict=True))
        raise UserError(source.source, "column " + ", ".join(repr(n) for n in names),
                        f"{f.evidence}: looks like {' and '.join(dict.fromkeys(units))}, not SI; declare the unit "
                        f"in the run YAML (logs[].columns: {{{example}}}) or convert the column")
    return notes


# ---------------------------------------------------------------------------------------------------- mounting


def tf_mounting(transforms, frame_id: str, body: str = "base_link") -> tuple[Rotation, list[str]] | None:
    """Rotation sensor → body (v_body = R v_sensor) from /tf_static: the chain of transforms from the sensor's
    ``frame_id`` up to ``body`` (or to the root of its tree), with the frames passed; None when ``frame_id`` is
    the body or not in the tree."""
    parent = {t.child: t for t in transforms}
    frame = frame_id.strip("/")
    if frame == body or frame not in parent:
        return None
    rot, chain = Rotation.identity(), [frame]
    while frame in parent and frame != body and len(chain) <= len(parent):
        t = parent[frame]
        rot = Rotation.from_quat(t.rotation) * rot
        frame = t.parent
        chain.append(frame)
    return rot, chain[::-1]


def _euler_deg(rot: Rotation) -> np.ndarray:
    """(yaw, pitch, roll) [deg]; at pitch ±90° scipy's gimbal-lock warning is moot (roll takes it all)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return rot.as_euler("ZYX", degrees=True)


def _rpy(rot: Rotation) -> str:
    yaw, pitch, roll = _euler_deg(rot)
    return f"{{roll_deg: {roll + 0.0:.1f}, pitch_deg: {pitch + 0.0:.1f}, yaw_deg: {yaw + 0.0:.1f}}}"


_AXES = {(1, 0, 0): "+x", (-1, 0, 0): "−x", (0, 1, 0): "+y", (0, -1, 0): "−y", (0, 0, 1): "+z", (0, 0, -1): "−z"}


def _axis(v: np.ndarray) -> np.ndarray | None:
    """The body axis (±x, ±y, ±z) within 15° of the unit vector v, or None."""
    axis = np.zeros(3)
    i = int(np.argmax(np.abs(v)))
    axis[i] = np.sign(v[i])
    return axis if float(np.dot(axis, v)) > np.cos(np.radians(15.0)) else None


def _direction(v: np.ndarray) -> str:
    axis = _axis(v)
    if axis is not None:
        return _AXES[tuple(int(c) for c in axis)]
    return "(" + ", ".join(f"{c:+.2f}" for c in v) + ")"


def _looks(rot: Rotation) -> str:
    """'rolled 90°', 'pitched −90°', … for a rotation about one axis, else 'mounted rotated'."""
    yaw, pitch, roll = np.round(_euler_deg(rot), 1) + 0.0
    turned = [(name, a) for name, a in (("rolled", roll), ("pitched", pitch), ("yawed", yaw)) if a]
    return f"{turned[0][0]} {turned[0][1]:g}°" if len(turned) == 1 else "mounted rotated"


def mounting_warnings(m: pd.DataFrame, imu: TopicTable, mounting: Rotation | None, sensor: str) -> list[str]:
    """Warnings that name the likely mounting rotation: a mean specific force not along body +z (gravity not
    along −z, DESIGN §3 FLU), and an orientation that never moves (a driver filling in a constant quaternion)."""
    out = []
    f = m[["imu_fx", "imu_fy", "imu_fz"]].to_numpy(dtype=np.float64)
    f = f[np.isfinite(f).all(axis=1)]
    mean = f.mean(axis=0) if len(f) >= 10 else np.zeros(3)
    size = float(np.linalg.norm(mean))
    if size > 0.5 * G0 and mean[2] / size < np.cos(np.radians(15.0)):
        total = mounting if mounting is not None else Rotation.identity()
        in_sensor = total.inv().apply(mean / size)
        up = _axis(in_sensor)  # a mounting is usually a whole number of quarter turns
        up = in_sensor if up is None else up
        if up[2] < -0.99:  # upside down: the smallest rotation is ambiguous, a roll of 180° is the usual one
            likely = Rotation.from_euler("x", 180.0, degrees=True)
        else:
            likely = Rotation.align_vectors([[0.0, 0.0, 1.0]], [up])[0]
        out.append(f"the accelerometers read gravity along {_direction(in_sensor)} of the IMU frame (mean specific "
                   f"force {np.round(mean, 2).tolist()} m/s² in the body), expected along body +z: the IMU looks "
                   f"{_looks(likely)}; set sensors.{sensor}.rotation: {_rpy(likely)} in the vessel YAML")
    q = imu.table.reindex(columns=["qx", "qy", "qz", "qw"]).to_numpy(dtype=np.float64)
    q = q[np.isfinite(q).all(axis=1)]
    if len(q) >= 10 and abs(np.linalg.norm(q[0]) - 1.0) < 0.1 and (q == q[0]).all():
        ident = " (identity)" if (np.abs(q[0]) == [0.0, 0.0, 0.0, 1.0]).all() else ""
        out.append(f"orientation is the same quaternion {q[0].tolist()}{ident} in all {len(q):,} messages: the "
                   "IMU does not estimate its attitude; roll and pitch from it are constant")
    return out


# ---------------------------------------------------------------------------------------------------- all

_EPOCH_MIN = pd.Timestamp("1990-01-01", tz="UTC")


def _check_epoch(tt: TopicTable, log: LogContents) -> None:
    """Stamps before 1990 (a clock never set: time since boot) or more than a day in the future: one line."""
    t = tt.table["time"]
    if not len(t):
        return
    first, last = t.min(), t.max()
    late = pd.Timestamp.now(tz="UTC") + pd.Timedelta(days=1)
    if first < _EPOCH_MIN or last > late:
        what = ("before 1990: a clock that was never set (time since boot?)" if first < _EPOCH_MIN
                else "in the future: a wrong clock or time unit")
        raise UserError(str(log.path), f"topic {tt.topic}", f"stamps from {first.isoformat()} to {last.isoformat()} "
                        f"are {what}; the hindcast cannot be matched")


def _topics_present(logs: Sequence[LogContents]) -> str:
    have = [f"{t.topic} ({t.msgtype})" for log in logs for t in log.topics.values()]
    have += [f"{topic} ({msgtype}, not read)" for log in logs for topic, msgtype in log.skipped.items()]
    return ", ".join(have) or "none"


def _check_named_topics(logs: Sequence[LogContents], named: dict[str, str | None]) -> None:
    for place, topic in named.items():
        if topic is not None and not any(topic in log.topics for log in logs):
            files = ", ".join(str(log.path) for log in logs) or None
            raise UserError(files, place, f"topic {topic} not in the log(s); topics present: {_topics_present(logs)}")


@dataclass
class LogSources:
    """One log's contribution to the motion table, before resampling: its IMU motions, GNSS motions and point
    sensors (name → time and vertical component), each with a ``time`` column."""

    imu: pd.DataFrame | None = None
    gnss: pd.DataFrame | None = None
    points: dict[str, pd.DataFrame] = field(default_factory=dict)

    def tables(self) -> list[pd.DataFrame]:
        return [t for t in (self.imu, self.gnss) if t is not None] + list(self.points.values())


def log_sources(log: LogContents, report: IngestReport, *, frame: str = "auto", imu_topic: str | None = None,
                fix_topic: str | None = None, vel_topic: str | None = None, mounting: Rotation | None = None,
                sensor: str = "imu") -> LogSources:
    """The IMU / NavSatFix / velocity topics of one log picked (or named), their time repaired and checked (1990
    to tomorrow), turned into motions (the IMU rotated into the body by `mounting` — the vessel YAML's
    ``sensors.<sensor>.rotation`` — or else by the log's /tf_static) and unit-checked (:func:`check_units`); what
    was repaired or found goes into `report`."""
    out = LogSources()
    table_log = log.format in ("csv", "parquet")
    for vec in log.of_type(VEC3):  # point sensors (e.g. heave at a point): the vertical component
        t, c = repair_time(vec)
        report.add(c)
        _check_epoch(t, log)
        name = vec.topic.strip("/").replace("/", "_")
        out.points[name] = t.table[["time"]].assign(**{name: t.table["z"].to_numpy()})
    report.warnings += log.warnings
    if log.truncated:
        report.add({"logs_cut_short": 1})

    def named(topic, msgtype):
        return _pick(log, msgtype) if topic is None else log.topics.get(topic)

    imu = named(imu_topic, IMU)
    others = [t.topic for t in log.of_type(IMU) if imu is not None and t.topic != imu.topic]
    if others:
        report.warnings.append(f"{log.path.name}: IMU topic {imu.topic} used; not used: {', '.join(others)}")
    if imu is not None:
        imu, c = repair_time(imu)
        report.add(c)
        _check_epoch(imu, log)
        mount, where = mounting, f"vessel YAML sensors.{sensor}.rotation"
        tf = tf_mounting(log.static_transforms, imu.frame_id) if log.static_transforms else None
        if tf is not None and mounting is not None:
            where += f" (wins over /tf_static {' → '.join(tf[1])}: {_rpy(tf[0])})"
        elif tf is not None:
            mount, where = tf[0], f"/tf_static {' → '.join(tf[1])}"
        if mount is not None:
            report.notes.append(f"{log.path.name} {imu.topic}: IMU mounting {_rpy(mount)} from {where}")
        m = imu_motions(imu, frame=frame, mounting=mount)
        report.add({"imu_samples_without_orientation": m.attrs["no_orientation"]})
        report.warnings += [f"{log.path.name} {imu.topic}: {w}" for w in check_units(m, imu, table=table_log)]
        report.warnings += [f"{log.path.name} {imu.topic}: {w}" for w in mounting_warnings(m, imu, mount, sensor)]
        out.imu = m
    fix = named(fix_topic, FIX)
    vel = named(vel_topic, TWIST)
    if vel is None and vel_topic is None:
        vel = _pick(log, ODOM)
    if fix is not None or vel is not None:
        if fix is not None:
            fix, c = repair_time(fix)
            report.add(c)
            _check_epoch(fix, log)
        if vel is not None:
            vel, c = repair_time(vel)
            report.add(c)
            _check_epoch(vel, log)
        g = gnss_motions(fix, vel)
        report.add({"gnss_no_fix_removed": g.attrs["no_fix"]})
        if vel is not None:
            report.warnings += [f"{log.path.name} GNSS: {w}" for w in check_units(g, vel, table=table_log)]
        out.gnss = g
    return out


def check_named_topics(logs: Sequence[LogContents], imu_topic=None, fix_topic=None, vel_topic=None) -> None:
    _check_named_topics(logs, {"topics.imu": imu_topic, "topics.gnss_fix": fix_topic,
                               "topics.gnss_vel/odometry": vel_topic})


def no_imu_error(logs: Sequence[LogContents]) -> UserError:
    """The error when no log has an IMU topic (the file and its topics named)."""
    if len(logs) == 1:
        imu_motions(logs[0])  # raises the UserError naming the file and its topics
    names = ", ".join(str(log.path) for log in logs) or None
    return UserError(names, None, f"no sensor_msgs/Imu topic (topics: {_topics_present(logs)})")


def overlap_counts(counts: dict[str, int]) -> dict[str, int]:
    """resample's counts with the repairs it made across logs named as overlaps (each log's own are counted
    when its topics are read)."""
    out = dict(counts)
    for k in ("duplicates_removed", "non_monotonic_repaired"):
        v = out.pop(k, 0)
        if v:
            out[f"overlap_{k}"] = v
    return out


def build_motions(
    logs: Sequence[LogContents],
    *,
    rate_hz: float = 10.0,
    max_gap_s: float = 2.0,
    frame: str = "auto",
    imu_topic: str | None = None,
    fix_topic: str | None = None,
    vel_topic: str | None = None,
    mounting: Rotation | None = None,
    sensor: str = "imu",
) -> tuple[pd.DataFrame, IngestReport]:
    """The motion table of a trial from its logs (back to back, or complementary: an MCAP with the IMU and a
    CSV with GNSS): each log's sources (:func:`log_sources`) resampled on one grid. Log warnings are carried into
    the report. Raises UserError when no log has an IMU topic, or a named topic is in no log."""
    report = IngestReport()
    check_named_topics(logs, imu_topic, fix_topic, vel_topic)
    sources = [log_sources(log, report, frame=frame, imu_topic=imu_topic, fix_topic=fix_topic, vel_topic=vel_topic,
                           mounting=mounting, sensor=sensor) for log in logs]
    if not any(s.imu is not None for s in sources):
        raise no_imu_error(logs)
    imus = [s.imu for s in sources if s.imu is not None]
    gnss = [s.gnss for s in sources if s.gnss is not None]
    points: dict[str, list[pd.DataFrame]] = {}
    for s in sources:
        for name, f in s.points.items():
            points.setdefault(name, []).append(f)
    table, c = resample(imus + gnss + [f for frames in points.values() for f in frames], rate_hz, max_gap_s)
    report.add(overlap_counts(c))
    return table, report

"""Plausibility gate of logged samples: values no vessel motion sensor can show (a flipped bit, a dead
sensor's garbage) are masked before they reach the physics.

Limits (run YAML ``ingest.plausibility``): |specific force| ≤ 5 g per axis, |roll|, |pitch| ≤ 90°, |angular rate|
≤ 5 rad/s per axis, |speed| ≤ 50 m/s, latitude / longitude on the globe, every gated value finite; a header stamp
more than an hour away from the topic's usual stamp − receive-time offset is a corrupt stamp. A NaN among a ROS
field's finite values counts as implausible; in a CSV / Parquet log NaN is an empty cell and is not counted. Pure
functions on tables: they return the masked copy and the counts per column; nothing here reads or writes files.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

G0 = 9.80665  # standard gravity [m/s²]


@dataclass(frozen=True)
class Limits:
    max_specific_force_g: float = 5.0
    max_angle_deg: float = 90.0
    max_rate_rad_s: float = 5.0
    max_speed_m_s: float = 50.0
    max_stamp_offset_s: float = 3600.0


# gated columns of a topic table → the quantity whose limit applies ("finite": only ±inf is implausible)
_VECTOR_LIMITS = {
    **dict.fromkeys(("ax", "ay", "az"), "specific_force"),
    **dict.fromkeys(("wx", "wy", "wz"), "rate"),
    **dict.fromkeys(("vx", "vy", "vz"), "speed"),
    **dict.fromkeys(("x", "y", "z", "altitude"), "finite"),  # point sensors, odometry position, GNSS altitude
}
_POSITION = {"latitude": 90.0, "longitude": 180.0}  # masked together: one bad coordinate voids the fix
_QUAT = ("qx", "qy", "qz", "qw")  # masked together when not a unit quaternion (all zeros: "unknown", kept)
_ANGLES = ("roll", "pitch")


def bound(kind: str, limits: Limits) -> float:
    """The largest plausible magnitude of a quantity kind, in SI units."""
    return {"specific_force": limits.max_specific_force_g * G0, "rate": limits.max_rate_rad_s,
            "speed": limits.max_speed_m_s, "angle": np.radians(limits.max_angle_deg),
            "finite": np.finfo(np.float64).max}[kind]


def implausible(values: np.ndarray, limit: float) -> np.ndarray:
    """True where a value is infinite or its magnitude exceeds `limit`; NaN (no value) is not counted."""
    v = np.asarray(values, dtype=np.float64)
    return np.abs(np.nan_to_num(v, nan=0.0, posinf=np.inf, neginf=np.inf)) > limit


def _stray_nan(v: np.ndarray) -> np.ndarray:
    """NaN in a field that is finite in most messages of its topic (a sensor that never gives the field, or a
    table log's rows of another sensor, are "no value", not a defect)."""
    nan = np.isnan(v)
    return nan if nan.any() and nan.mean() < 0.5 else np.zeros(v.shape, dtype=bool)


def gate_topic(table: pd.DataFrame, limits: Limits, *, messages: bool = True) -> tuple[pd.DataFrame, dict[str, int]]:
    """A topic table (``time``, ``log_time`` and message fields) with implausible samples masked (NaN) and rows
    with a corrupt stamp given no stamp (NaT: dropped and counted by the time repair downstream).

    Parameters
    ----------
    table : DataFrame
    limits : Limits
    messages : bool
        The table holds ROS messages (every message carries every field): a NaN among finite values of a field
        counts as implausible too. False for CSV / Parquet logs, whose NaN are empty cells.

    Returns
    -------
    (DataFrame, counts)
        The table (a copy when anything changed) and the number of masked values per column (``stamp`` for
        corrupt stamps, ``orientation`` for quaternions that are not unit ones), only those above zero.
        Latitude and longitude are masked together, as are the four quaternion components.
    """
    masks: dict[str, np.ndarray] = {}
    for column, kind in _VECTOR_LIMITS.items():
        if column in table:
            v = table[column].to_numpy(dtype=np.float64)
            stray = _stray_nan(v) if messages and kind != "finite" else False  # altitude NaN: "not available"
            masks[column] = implausible(v, bound(kind, limits)) | stray
    groups = {"position": [c for c in _POSITION if c in table], "orientation": [c for c in _QUAT if c in table]}
    if len(groups["position"]) == len(_POSITION):
        bad = np.zeros(len(table), dtype=bool)
        for column, limit in _POSITION.items():
            v = table[column].to_numpy(dtype=np.float64)
            bad |= implausible(v, limit) | (_stray_nan(v) if messages else False)
        masks["position"] = bad
    if len(groups["orientation"]) == len(_QUAT):
        q = table[list(_QUAT)].to_numpy(dtype=np.float64)
        nan = np.isnan(q)
        with np.errstate(over="ignore"):  # a wild component (1e300) squares to inf: not a unit quaternion
            norm = np.linalg.norm(np.nan_to_num(q, nan=0.0, posinf=np.inf, neginf=np.inf), axis=1)
        # all zeros ("unknown") and all NaN ("not provided") are a writer's choice; a partly NaN one is not
        masks["orientation"] = ((norm > 0) & ~(np.abs(norm - 1.0) <= 0.1)) | (nan.any(axis=1) & ~nan.all(axis=1))
    stamp = corrupt_stamps(table, limits.max_stamp_offset_s)
    counts = {c: int(m.sum()) for c, m in masks.items() if m.any()}
    if stamp.any():
        counts["stamp"] = int(stamp.sum())
    if not counts:
        return table, {}
    out = table.copy()
    for name, m in masks.items():
        if m.any():
            out.loc[m, groups.get(name, [name])] = np.nan
    if stamp.any():
        out.loc[stamp, "time"] = pd.NaT
    return out, counts


def corrupt_stamps(table: pd.DataFrame, max_offset_s: float) -> np.ndarray:
    """True where a header stamp is more than `max_offset_s` from the receive time plus the topic's median
    stamp − receive-time offset (a clock offset common to the topic is allowed; a lone wild stamp is not)."""
    if "time" not in table or "log_time" not in table or not len(table):
        return np.zeros(len(table), dtype=bool)
    stamp, log = (pd.to_datetime(table[c], utc=True).astype("int64").to_numpy() for c in ("time", "log_time"))
    nat = np.iinfo(np.int64).min
    ok = (stamp != nat) & (log != nat)
    if not ok.any():
        return np.zeros(len(table), dtype=bool)
    offset = (stamp - log).astype(np.float64) * 1e-9
    median = float(np.median(offset[ok]))
    return ok & (np.abs(offset - median) > max_offset_s)


def gate_angles(motions: pd.DataFrame, limits: Limits) -> tuple[pd.DataFrame, dict[str, int]]:
    """Roll and pitch [rad] of the motion table beyond ``max_angle_deg`` masked (NaN); the counts per column."""
    limit = bound("angle", limits)
    counts, out = {}, motions
    for column in _ANGLES:
        if column in motions:
            bad = implausible(motions[column].to_numpy(dtype=np.float64), limit)
            if bad.any():
                out = out.copy() if out is motions else out
                out.loc[bad, column] = np.nan
                counts[column] = int(bad.sum())
    return out, counts


def constant_columns(table: pd.DataFrame, columns) -> dict[str, float]:
    """Columns whose every finite value is the same (a dead sensor), with that value; at least 10 samples."""
    out = {}
    for column in columns:
        if column in table:
            v = table[column].to_numpy(dtype=np.float64)
            v = v[np.isfinite(v)]
            if v.size >= 10 and v.min() == v.max():
                out[column] = float(v[0])
    return out


_SENSOR_FIELDS = ("wx", "wy", "wz", "ax", "ay", "az")


def gate_logs(logs, limits: Limits) -> tuple[dict[str, int], list[str]]:
    """Every topic table of the logs (objects with ``path`` and ``topics``: topic → object with ``table``, as
    :class:`seatune.io.log_readers.LogContents`) passed through :func:`gate_topic`, in place.

    Returns
    -------
    (counts, warnings)
        ``"implausible <topic> <column>"`` → masked values (``stamp``: rows given no stamp), and one warning per
        log that had any, plus one per dead (constant) IMU field.
    """
    counts: dict[str, int] = {}
    warnings: list[str] = []
    for log in logs:
        masked = []
        for topic, tt in log.topics.items():
            tt.table, c = gate_topic(tt.table, limits, messages=log.format not in ("csv", "parquet"))
            for column, k in c.items():
                counts[f"implausible {topic} {column}"] = counts.get(f"implausible {topic} {column}", 0) + k
                masked.append(f"{topic} {column} {k:,}")
            dead = constant_columns(tt.table, _SENSOR_FIELDS) if tt.msgtype == "sensor_msgs/msg/Imu" else {}
            for column, value in dead.items():
                warnings.append(f"{log.path.name} {topic}: {column} is {value:g} in all {len(tt.table):,} messages "
                                "(a dead sensor?)")
        if masked:
            warnings.append(f"{log.path.name}: implausible values masked (ingest.plausibility: "
                            f"|f| ≤ {limits.max_specific_force_g:g} g, |ω| ≤ {limits.max_rate_rad_s:g} rad/s, "
                            f"|v| ≤ {limits.max_speed_m_s:g} m/s, finite; stamps within "
                            f"{limits.max_stamp_offset_s:g} s): " + ", ".join(masked))
    return counts, warnings

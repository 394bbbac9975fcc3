"""`seatune ingest`: logger files + hindcast → motions.parquet and waves.parquet (DESIGN §5)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seatune.errors import UserError
from seatune.io.run_yaml import Run

KIND_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}
WAVE_UNITS = {"time": "UTC", "hs": "m", "tp": "s", "dir_from_deg": "deg", "spreading": "rad", "mwp": "s",
              "tm01": "s", "wind_hs": "m", "wind_tp": "s", "wind_dir_from_deg": "deg", "swell_hs": "m",
              "swell_tp": "s", "swell_dir_from_deg": "deg", "wind_mwp": "s", "swell_mwp": "s", "source": "",
              "lat": "deg", "lon": "deg"}
WAVE_UNITS.update({"sea_corners": "dimensionless", "stencil_corners": "dimensionless"})  # neighbours used / all


SOURCE_FIELDS = {"roll": "orientation / qx..qw", "pitch": "orientation / qx..qw",
                 "roll_rate": "angular_velocity.x / wx",
                 "pitch_rate": "angular_velocity.y / wy", "yaw_rate": "angular_velocity.z / wz",
                 "imu_fx": "linear_acceleration.x / ax", "imu_fy": "linear_acceleration.y / ay",
                 "imu_fz": "linear_acceleration.z / az"}


def read_logs(run: Run, echo=print) -> list:
    """Every log of the run, read by the reader its content calls for."""
    import sys

    from rich.progress import track

    bar = track(run.logs, description="reading logs", transient=True, console=None,
                disable=not sys.stderr.isatty())
    return [read_one(run, path, log) for path, log in bar]


def read_one(run: Run, path, log):
    """One log file of a `logs:` entry, read by the reader its content calls for."""
    from seatune.io.log_readers import read_log
    from seatune.io.run_yaml import column_options

    names, units = column_options(run.spec.ingest.columns, log.columns)
    options = {"time_column": log.time_column, "column_map": names or None, "column_units": units or None}
    return read_log(path, format=log.format, table_options=options)


def time_span(log) -> tuple[pd.Timestamp, pd.Timestamp] | None:
    """First and last stamp of any topic of a log (None when it holds no sample)."""
    times = [t.table["time"] for t in log.topics.values() if len(t.table)]
    if not times:
        return None
    return min(t.min() for t in times), max(t.max() for t in times)


def in_time_order(run: Run, logs: list) -> tuple[list, list[str]]:
    """The logs with the files of each `logs:` entry that matched several (a logger's split files) in the order of
    their first stamp, whatever their names; and a warning per such entry whose files overlap (the repeated
    samples are removed when resampled), leave a gap longer than `ingest.max_gap_s`, or sort otherwise by name."""
    order, notes = time_order(run, [time_span(log) for log in logs], [log.path.name for log in logs])
    return [logs[k] for k in order], notes


def time_order(run: Run, spans: list, names: list[str]) -> tuple[list[int], list[str]]:
    """:func:`in_time_order` from each log's (first, last) stamp (None: no sample) and file name: the order of the
    logs (indices into ``run.logs``) and the warnings."""
    groups: dict[int, list[int]] = {}
    for k, (_, spec) in enumerate(run.logs):
        groups.setdefault(id(spec), []).append(k)
    order, notes = [], []
    for members in groups.values():
        members = sorted(members, key=lambda k: (spans[k] is None, spans[k][0] if spans[k] else 0, k))
        order += members
        if len(members) < 2:
            continue
        entry = run.logs[members[0]][1].path
        parts = []
        timed = [k for k in members if spans[k] is not None]
        for a, b in zip(timed, timed[1:], strict=False):
            step = (spans[b][0] - spans[a][1]).total_seconds()
            if step < 0:
                parts.append(f"{names[b]} overlaps {names[a]} by {-step:.1f} s")
            elif step > run.spec.ingest.max_gap_s:
                parts.append(f"{step:.1f} s gap between {names[a]} and {names[b]}")
        renamed = members != sorted(members, key=lambda k: names[k])
        if parts or renamed:
            notes.append(f"{entry}: {len(members)} files read in time order"
                         + (" (not their name order)" if renamed else "")
                         + (f"; {'; '.join(parts)}" if parts else ""))
    return order, notes


def build_motions(run: Run, logs: list, heave_names: dict[str, str],
                  mounting=(None, "imu")) -> tuple[pd.DataFrame, dict, list[str]]:
    """The motion table on a uniform grid, with the counts of what was repaired and the warnings (all in memory:
    :func:`ingest` streams the same table piece by piece)."""
    from seatune.pipeline.motions import build_motions as assemble

    t = run.spec.topics
    mounting, sensor = mounting
    motions, report = assemble(logs, rate_hz=run.spec.ingest.rate_hz, max_gap_s=run.spec.ingest.max_gap_s,
                               frame=run.spec.ingest.frame, imu_topic=t.imu, fix_topic=t.gnss_fix,
                               vel_topic=t.gnss_vel or t.odometry, mounting=mounting, sensor=sensor)
    counts = dict(report.counts)
    _check_source_fields(run, logs, {c for c in SOURCE_FIELDS if c in motions
                                     and np.isfinite(motions[c].to_numpy()).any()}, set(motions.columns))
    imu = np.isfinite(motions["roll"].to_numpy())  # the IMU defines the trial; GNSS alone is no motion record
    if imu.any():
        first, last = np.argmax(imu), imu.size - np.argmax(imu[::-1])
        counts["samples_outside_imu"] = int(imu.size - (last - first))
        motions = motions.iloc[first:last].reset_index(drop=True)
    motions = motions.rename(columns={**heave_names, **run.spec.channels})
    if "lat" not in motions or not np.isfinite(motions["lat"].to_numpy()).any():
        raise _no_position(logs)
    return motions, counts, list(report.notes) + list(report.warnings)


def _check_source_fields(run: Run, logs: list, finite: set[str], columns: set[str]) -> None:
    for column, field in SOURCE_FIELDS.items():
        if column in columns and column not in finite:
            where = ", ".join(str(log.path) for log in logs if log.of_type("sensor_msgs/msg/Imu") or
                              log.format in ("csv", "parquet"))
            raise UserError(where or str(run.path), column, f"no finite value in the whole trial (IMU {field})")


def _no_position(logs: list) -> UserError:
    vel = [f"{tt.topic} ({tt.msgtype})" for log in logs for tt in log.topics.values()
           if tt.msgtype in ("nav_msgs/msg/Odometry", "geometry_msgs/msg/TwistStamped")]
    return UserError(", ".join(str(log.path) for log in logs), None,
                     "no position (no NavSatFix topic or GNSS CSV with latitude/longitude"
                     + (f"; {', '.join(vel)} give velocity only" if vel else "")
                     + "): the hindcast cannot be placed on the track")


# ------------------------------------------------------------------------------------- streaming the motion table

CHUNK_S = 3600.0  # grid time per resampling step, and per row group of motions.parquet


def skeleton(log):
    """The log without its samples (paths, topics, warnings kept for the messages that name them)."""
    import dataclasses

    from seatune.io.log_readers import TopicTable

    empty = {k: TopicTable(t.topic, t.msgtype, t.frame_id, t.table.iloc[:0].copy(), t.source)  # copy: no view
             for k, t in log.topics.items()}
    return dataclasses.replace(log, topics=empty)


class Spool:
    """Each log's motion sources (:class:`~seatune.pipeline.motions.LogSources`) on disk, read back one stretch of
    time at a time, so no more than one log and one stretch are in memory."""

    def __init__(self, folder):
        from pathlib import Path

        self.folder = Path(folder)
        self.parts: dict[tuple, list[tuple[int, object, int, int]]] = {}  # columns → (log, file, first, last ns)
        self.periods: dict[tuple, float] = {}

    def add(self, log_index: int, sources) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        from seatune.pipeline.motions import _period_ns

        for df in sources.tables():
            if not len(df):
                continue
            cols = tuple(c for c in df.columns if c != "time")
            ns = df["time"].astype("int64").to_numpy()
            path = self.folder / f"{sum(map(len, self.parts.values()))}.parquet"
            pq.write_table(pa.table({"time": ns, **{c: df[c].to_numpy(dtype=np.float64) for c in cols}}), path,
                           row_group_size=1 << 16)
            self.parts.setdefault(cols, []).append((log_index, path, int(ns.min()), int(ns.max())))
            anyv = df[list(cols)].notna().any(axis=1).to_numpy()
            self.periods[cols] = max(self.periods.get(cols, 0.0), _period_ns(ns[anyv]))

    def columns(self) -> list[str]:
        return [c for cols in self.parts for c in cols]

    def span(self) -> tuple[int, int]:
        parts = [p for ps in self.parts.values() for p in ps]
        return min(p[2] for p in parts), max(p[3] for p in parts)

    def read(self, lo: int, hi: int, order: list[int]) -> tuple[list[pd.DataFrame], list[tuple]]:
        """Every source's samples lo ≤ t < hi [ns], its logs in `order`; and the sources that have none."""
        import pyarrow.parquet as pq

        rank = {k: i for i, k in enumerate(order)}
        out, absent = [], []
        for cols, parts in self.parts.items():
            found = []
            for _, path, first, last in sorted(parts, key=lambda p: rank[p[0]]):
                if last < lo or first >= hi:
                    continue
                df = pq.read_table(path, filters=[("time", ">=", lo), ("time", "<", hi)]).to_pandas()
                if len(df):
                    df["time"] = pd.DatetimeIndex(df["time"].to_numpy().view("datetime64[ns]"), tz="UTC")
                    found.append(df)
            out += found
            if not found:
                absent.append(cols)
        return out, absent


def stream_motions(run: Run, spool: Spool, order: list[int], writer, rename: dict[str, str], limits) -> dict:
    """The motion table written to `writer` one :data:`CHUNK_S` piece at a time (the pieces equal the rows of the
    whole table resampled at once, :func:`~seatune.pipeline.motions.resample`); rows before the first and after
    the last IMU attitude dropped, then angles gated. Returns the counts and what the checks and the hindcast
    need: finite source fields, first/last time, a thinned track (the fixes around each whole hour)."""
    from seatune.physics.plausibility import gate_angles
    from seatune.pipeline.motions import IngestReport, resample

    fs, gap = run.spec.ingest.rate_hz, run.spec.ingest.max_gap_s
    dt = int(round(1e9 / fs))
    step = max(1, int(round(CHUNK_S * 1e9 / dt))) * dt
    thr = max([gap * 1e9, *(1.5 * p for p in spool.periods.values())])
    margin = int(max(60e9, 3 * thr))
    columns = spool.columns()
    resampled, masked = IngestReport(), IngestReport()  # counts summed over the pieces
    state = {"record": -1, "last": None, "started": False, "pending": [], "outside": 0, "rows": 0, "first": None,
             "final": None, "records": set(), "finite": set(), "finite_angles": set(), "track": [],
             "any_lat": False}

    def emit(df):
        if not len(df):
            return
        df = df.rename(columns=rename)
        df, angles = gate_angles(df, limits)
        masked.add(angles)
        if "lat" in df:
            state["track"].append(_track_points(df))
            state["any_lat"] |= bool(np.isfinite(df["lat"].to_numpy()).any())
        state["finite_angles"].update(c for c in ("roll", "pitch") if c in df and df[c].notna().any())
        state["first"] = df["time"].iloc[0] if state["first"] is None else state["first"]
        state["final"] = df["time"].iloc[-1]
        state["rows"] += len(df)
        state["records"].update(np.unique(df["record"].to_numpy()).tolist())
        writer.write(df)

    lo0, end = spool.span()
    lo = (lo0 // dt) * dt
    while lo <= end:
        hi = lo + step
        tables, absent = spool.read(lo - margin, hi + margin, order)
        lo_now = lo
        lo = hi
        if not tables:
            continue
        df, c = resample(tables, fs, gap, keep=(lo_now, hi))
        if not len(df):
            continue
        c.pop("records", None)
        c.pop("gaps_split", None)
        c["samples_masked"] = c.get("samples_masked", 0) + len(df) * sum(len(a) > 0 for a in absent)
        resampled.add(c)
        for col in columns:
            if col not in df:
                df[col] = np.nan
        df = df[["time", "record", *columns]]
        ns = df["time"].astype("int64").to_numpy()
        new = np.r_[state["last"] is None or ns[0] - state["last"] != dt, np.diff(df["record"].to_numpy()) != 0]
        df["record"] = state["record"] + np.cumsum(new)
        state["record"], state["last"] = int(df["record"].iloc[-1]), int(ns[-1])
        state["finite"].update(col for col in SOURCE_FIELDS if col in df and np.isfinite(df[col].to_numpy()).any())
        imu = np.isfinite(df["roll"].to_numpy())  # the IMU defines the trial; GNSS alone is no motion record
        if not state["started"]:
            if not imu.any():
                state["outside"] += len(df)
                continue
            first = int(np.argmax(imu))
            state["outside"] += first
            df, imu, state["started"] = df.iloc[first:], imu[first:], True
        if imu.any():
            last = len(imu) - int(np.argmax(imu[::-1]))
            for p in state["pending"]:
                emit(p)
            emit(df.iloc[:last])
            state["pending"] = [df.iloc[last:]]
        else:
            state["pending"].append(df)
    state["outside"] += sum(len(p) for p in state["pending"])
    records = state["record"] + 1
    counts = {"records": records, "gaps_split": max(records - 1, 0), **resampled.counts}
    if state["started"]:
        counts["samples_outside_imu"] = state["outside"]
    state["counts"], state["angles"] = counts, masked.counts
    return state


def _track_points(df: pd.DataFrame) -> pd.DataFrame:
    """The fixes :func:`build_waves` interpolates between: first, last, and the two around each whole hour."""
    from seatune.io.motion_table import placed

    tr = df.loc[placed(df), ["time", "lat", "lon"]]
    if not len(tr):
        return tr
    hours = pd.date_range(tr["time"].iloc[0].ceil("h"), tr["time"].iloc[-1].floor("h"), freq="h")
    j = np.searchsorted(pd.DatetimeIndex(tr["time"]).asi8, hours.asi8)  # ns since the epoch (UTC): no Timestamp objects
    keep = np.unique(np.clip(np.r_[0, len(tr) - 1, j - 1, j], 0, len(tr) - 1))
    return tr.iloc[keep]


def imu_mounting(run: Run, model):
    """(rotation sensor → body or None, sensor tag) of the IMU: the vessel YAML's ``sensors.<tag>.rotation`` of
    the tag carried by the channels the IMU's columns fill."""
    from seatune.pipeline.motions import IMU_COLUMNS

    names = {run.spec.channels.get(c, c) for c in IMU_COLUMNS}
    tags = sorted({c.sensor for c in model.spec.channels if c.name in names and c.sensor})
    sensors = model.spec.sensors
    given = [tag for tag in tags if tag in sensors and sensors[tag].rotation is not None]
    if len(given) > 1:
        raise UserError(str(run.vessel_path), "sensors", f"the IMU's channels belong to several sensors with a "
                                                         f"rotation ({', '.join(given)}): give one")
    if given:
        return sensors[given[0]].mounting(), given[0]
    return None, tags[0] if tags else "imu"


def heave_column_names(model) -> dict[str, str]:
    """`/<sensor>/<kind>` topic → vessel channel name, from the channels' sensor tags."""
    out = {}
    for c in model.spec.channels:
        if c.sensor and c.kind in KIND_UNITS:
            out[f"{c.sensor}_{c.kind}"] = c.name
    return out


def build_waves(run: Run, motions: pd.DataFrame, t0=None, t1=None):
    """Hourly hindcast at the vessel track (bilinear in space, linear in time); `motions` holds time, lat and lon
    (the whole table, or :func:`stream_motions`' thinned track with the table's first and last time t0, t1)."""
    from seatune.io.hindcast_readers import at_track, read_hindcast

    hc = read_hindcast(run.hindcast_path, format=run.spec.hindcast.format)
    track = motions[np.isfinite(motions["lat"]) & np.isfinite(motions["lon"])]
    t0 = motions["time"].iloc[0] if t0 is None else t0
    t1 = motions["time"].iloc[-1] if t1 is None else t1
    hours = pd.date_range(t0.floor("h"), t1.ceil("h"), freq="h")
    secs = (track["time"] - t0).dt.total_seconds().to_numpy()
    at = np.clip((hours - t0).total_seconds().to_numpy(), secs[0], secs[-1])
    lat = np.interp(at, secs, track["lat"].to_numpy())
    lon = np.degrees(np.interp(at, secs, np.unwrap(np.radians(track["lon"].to_numpy()))))
    lon = (lon + 180.0) % 360.0 - 180.0
    waves = at_track(hc, hours, lat, lon)
    waves["lat"], waves["lon"] = lat, lon
    return waves, hc


def motion_units(columns, model) -> dict[str, str]:
    from seatune.pipeline.motions import UNITS

    units = dict(UNITS)
    for c in model.spec.channels:
        units.setdefault(c.name, {"angle": "rad", "rate": "rad/s", **KIND_UNITS,
                                  "specific_force": "m/s^2"}[c.kind])
    return {c: units.get(c, "") for c in columns}


def ingest(run: Run, model, echo=print, force: bool = False) -> dict:
    """Run the stage; returns a summary dict. Skips when the artefacts are fresh."""
    import tempfile

    from seatune.io.parquet import table_writer, write_table
    from seatune.io.rundir import fingerprint, is_fresh
    from seatune.physics.plausibility import Limits, gate_logs
    from seatune.pipeline.motions import (
        IMU_COLUMNS,
        IngestReport,
        check_named_topics,
        log_sources,
        no_imu_error,
        overlap_counts,
    )

    inputs = [p for p, _ in run.logs] + [run.hindcast_path, run.vessel_path]
    settings = {"logs": [log.model_dump() for log in run.spec.logs], "topics": run.spec.topics.model_dump(),
                "channels": run.spec.channels, "ingest": run.spec.ingest.model_dump(),
                "hindcast": run.spec.hindcast.model_dump()}
    fp = fingerprint(inputs, settings)
    out_m, out_w = run.artefact("motions.parquet"), run.artefact("waves.parquet")
    if not force and is_fresh([out_m, out_w], fp):
        return {"skipped": True}
    t = run.spec.topics
    topics = {"imu_topic": t.imu, "fix_topic": t.gnss_fix, "vel_topic": t.gnss_vel or t.odometry}
    mounting, sensor = imu_mounting(run, model)
    limits = Limits(**run.spec.ingest.plausibility.model_dump())
    report, gated = IngestReport(), IngestReport()
    gate_warnings, logs, spans = [], [], []
    run.run_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=".ingest-", suffix=".tmp", dir=run.run_dir) as folder:
        spool = Spool(folder)
        for k, (path, spec) in enumerate(run.logs):  # one log in memory at a time
            log = read_one(run, path, spec)
            spans.append(time_span(log))
            c, w = gate_logs([log], limits)  # implausible samples masked before they are resampled
            gated.add(c)
            gate_warnings += w
            spool.add(k, log_sources(log, report, frame=run.spec.ingest.frame, mounting=mounting, sensor=sensor,
                                     **topics))
            logs.append(skeleton(log))
            del log
        order, split_notes = time_order(run, spans, [log.path.name for log in logs])
        logs = [logs[k] for k in order]
        check_named_topics(logs, **topics)
        if not any(cols[:1] == IMU_COLUMNS[:1] for cols in spool.parts):
            raise no_imu_error(logs)
        rename = {**heave_column_names(model), **run.spec.channels}
        columns = [rename.get(c, c) for c in ["time", "record", *spool.columns()]]
        with table_writer(out_m, motion_units(columns, model)) as writer:
            streamed = stream_motions(run, spool, order, writer, rename, limits)
            _check_source_fields(run, logs, streamed["finite"], set(spool.columns()))
            for c in streamed["angles"]:
                if c not in streamed["finite_angles"]:
                    raise UserError(str(run.path), "ingest.plausibility.max_angle_deg", f"every {c} sample is "
                                    f"beyond ±{limits.max_angle_deg:g}°: an IMU mounted rotated (give "
                                    "sensors.<tag>.rotation in the vessel YAML) or a wrong frame (ingest.frame)")
            if "lat" not in columns:
                raise UserError(str(run.path), "logs", "no position (NavSatFix or GNSS CSV): the hindcast cannot "
                                                        "be placed on the track")
            if not streamed["any_lat"]:
                raise _no_position(logs)
            counts = dict(report.counts) | overlap_counts(streamed["counts"])
            angles = streamed["angles"]
            counts.update(gated.counts | {f"implausible attitude {c}": k for c, k in angles.items()})
            warnings = list(report.notes) + list(report.warnings)
            warnings += gate_warnings + ([f"attitude beyond ±{limits.max_angle_deg:g}° masked: "
                                          + ", ".join(f"{c} {k:,}" for c, k in angles.items())] if angles else [])
            waves, hc = build_waves(run, pd.concat(streamed["track"], ignore_index=True), streamed["first"],
                                    streamed["final"])
            warnings = split_notes + warnings
            writer.metadata = {"fingerprint": fp, "counts": counts, "warnings": warnings,
                               "truncated_logs": [str(log.path) for log in logs if log.truncated]}
        write_table(waves, out_w, {c: WAVE_UNITS.get(c, "") for c in waves.columns}, {"fingerprint": fp})
    for w in warnings:
        echo(f"warning: {w}")
    partial = int((waves["sea_corners"] < waves["stencil_corners"]).sum()) if "sea_corners" in waves else 0
    if partial:
        echo(f"hindcast: {partial} of {len(waves)} track hours next to land or ice (a partial stencil: the sea "
             "corners' weights renormalised)")
    return {"skipped": False, "samples": streamed["rows"], "records": len(streamed["records"]),
            "hours": (streamed["final"] - streamed["first"]).total_seconds() / 3600,
            "counts": counts, "hindcast_hours": len(waves), "partial_stencil_hours": partial}

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

    from seatune.io.log_readers import read_log
    from seatune.io.run_yaml import column_options

    out = []
    bar = track(run.logs, description="reading logs", transient=True, console=None,
                disable=not sys.stderr.isatty())
    for path, log in bar:
        names, units = column_options(run.spec.ingest.columns, log.columns)
        options = {"time_column": log.time_column, "column_map": names or None, "column_units": units or None}
        out.append(read_log(path, format=log.format, table_options=options))
    return out


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
    groups: dict[int, list[int]] = {}
    for k, (_, spec) in enumerate(run.logs):
        groups.setdefault(id(spec), []).append(k)
    order, notes = [], []
    for members in groups.values():
        spans = {k: time_span(logs[k]) for k in members}
        members = sorted(members, key=lambda k: (spans[k] is None, spans[k][0] if spans[k] else 0, k))
        order += members
        if len(members) < 2:
            continue
        entry = run.logs[members[0]][1].path
        parts = []
        timed = [k for k in members if spans[k] is not None]
        for a, b in zip(timed, timed[1:], strict=False):
            step = (spans[b][0] - spans[a][1]).total_seconds()
            name_a, name_b = logs[a].path.name, logs[b].path.name
            if step < 0:
                parts.append(f"{name_b} overlaps {name_a} by {-step:.1f} s")
            elif step > run.spec.ingest.max_gap_s:
                parts.append(f"{step:.1f} s gap between {name_a} and {name_b}")
        renamed = members != sorted(members, key=lambda k: logs[k].path.name)
        if parts or renamed:
            notes.append(f"{entry}: {len(members)} files read in time order"
                         + (" (not their name order)" if renamed else "")
                         + (f"; {'; '.join(parts)}" if parts else ""))
    return [logs[k] for k in order], notes


def build_motions(run: Run, logs: list, heave_names: dict[str, str],
                  mounting=(None, "imu")) -> tuple[pd.DataFrame, dict, list[str]]:
    """The motion table on a uniform grid, with the counts of what was repaired and the warnings."""
    from seatune.pipeline.motions import build_motions as assemble

    t = run.spec.topics
    mounting, sensor = mounting
    motions, report = assemble(logs, rate_hz=run.spec.ingest.rate_hz, max_gap_s=run.spec.ingest.max_gap_s,
                               frame=run.spec.ingest.frame, imu_topic=t.imu, fix_topic=t.gnss_fix,
                               vel_topic=t.gnss_vel or t.odometry, mounting=mounting, sensor=sensor)
    counts = dict(report.counts)
    for column, field in SOURCE_FIELDS.items():
        if column in motions and not np.isfinite(motions[column].to_numpy()).any():
            where = ", ".join(str(log.path) for log in logs if log.of_type("sensor_msgs/msg/Imu") or
                              log.format in ("csv", "parquet"))
            raise UserError(where or str(run.path), column, f"no finite value in the whole trial (IMU {field})")
    imu = np.isfinite(motions["roll"].to_numpy())  # the IMU defines the trial; GNSS alone is no motion record
    if imu.any():
        first, last = np.argmax(imu), imu.size - np.argmax(imu[::-1])
        counts["samples_outside_imu"] = int(imu.size - (last - first))
        motions = motions.iloc[first:last].reset_index(drop=True)
    motions = motions.rename(columns={**heave_names, **run.spec.channels})
    if "lat" not in motions or not np.isfinite(motions["lat"].to_numpy()).any():
        vel = [f"{tt.topic} ({tt.msgtype})" for log in logs for tt in log.topics.values()
               if tt.msgtype in ("nav_msgs/msg/Odometry", "geometry_msgs/msg/TwistStamped")]
        raise UserError(", ".join(str(log.path) for log in logs), None,
                        "no position (no NavSatFix topic or GNSS CSV with latitude/longitude"
                        + (f"; {', '.join(vel)} give velocity only" if vel else "")
                        + "): the hindcast cannot be placed on the track")
    return motions, counts, list(report.notes) + list(report.warnings)


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


def build_waves(run: Run, motions: pd.DataFrame):
    """Hourly hindcast at the vessel track (bilinear in space, linear in time)."""
    from seatune.io.hindcast_readers import at_track, read_hindcast

    hc = read_hindcast(run.hindcast_path, format=run.spec.hindcast.format)
    track = motions[np.isfinite(motions["lat"]) & np.isfinite(motions["lon"])]
    t0, t1 = motions["time"].iloc[0], motions["time"].iloc[-1]
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
    from seatune.io.parquet import write_table
    from seatune.io.rundir import fingerprint, is_fresh
    from seatune.physics.plausibility import Limits, gate_angles, gate_logs

    inputs = [p for p, _ in run.logs] + [run.hindcast_path, run.vessel_path]
    settings = {"logs": [log.model_dump() for log in run.spec.logs], "topics": run.spec.topics.model_dump(),
                "channels": run.spec.channels, "ingest": run.spec.ingest.model_dump(),
                "hindcast": run.spec.hindcast.model_dump()}
    fp = fingerprint(inputs, settings)
    out_m, out_w = run.artefact("motions.parquet"), run.artefact("waves.parquet")
    if not force and is_fresh([out_m, out_w], fp):
        return {"skipped": True}
    logs, split_notes = in_time_order(run, read_logs(run))
    limits = Limits(**run.spec.ingest.plausibility.model_dump())
    gated, gate_warnings = gate_logs(logs, limits)  # implausible samples masked before they are resampled
    motions, counts, warnings = build_motions(run, logs, heave_column_names(model), imu_mounting(run, model))
    motions, angles = gate_angles(motions, limits)
    for c in angles:
        if not motions[c].notna().any():
            raise UserError(str(run.path), "ingest.plausibility.max_angle_deg", f"every {c} sample is beyond "
                            f"±{limits.max_angle_deg:g}°: an IMU mounted rotated (give sensors.<tag>.rotation in "
                            "the vessel YAML) or a wrong frame (ingest.frame)")
    counts.update(gated | {f"implausible attitude {c}": k for c, k in angles.items()})
    warnings += gate_warnings + ([f"attitude beyond ±{limits.max_angle_deg:g}° masked: "
                                  + ", ".join(f"{c} {k:,}" for c, k in angles.items())] if angles else [])
    if "lat" not in motions:
        raise UserError(str(run.path), "logs", "no position (NavSatFix or GNSS CSV): the hindcast cannot be "
                                                "placed on the track")
    waves, hc = build_waves(run, motions)
    warnings = split_notes + warnings
    meta = {"fingerprint": fp, "counts": counts, "warnings": warnings,
            "truncated_logs": [str(log.path) for log in logs if log.truncated]}
    write_table(motions, out_m, motion_units(motions.columns, model), meta)
    write_table(waves, out_w, {c: WAVE_UNITS.get(c, "") for c in waves.columns}, {"fingerprint": fp})
    for w in warnings:
        echo(f"warning: {w}")
    partial = int((waves["sea_corners"] < waves["stencil_corners"]).sum()) if "sea_corners" in waves else 0
    if partial:
        echo(f"hindcast: {partial} of {len(waves)} track hours next to land or ice (a partial stencil: the sea "
             "corners' weights renormalised)")
    return {"skipped": False, "samples": len(motions), "records": int(motions["record"].nunique()),
            "hours": (motions["time"].iloc[-1] - motions["time"].iloc[0]).total_seconds() / 3600,
            "counts": counts, "hindcast_hours": len(waves), "partial_stencil_hours": partial}

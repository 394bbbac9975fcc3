"""`seatune simulate`: a synthetic sea trial with known truth, written as a vessel's logger would.

simulate() is pure computation (scenario + vessel → tables); write_trial() is the I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from seatune.physics import imu as imu_model
from seatune.physics.channels import AXES, Channel, point_translation
from seatune.physics.response import motion_raos_at
from seatune.physics.spectra import SpectrumPartition, discrete_spreading
from seatune.physics.synthesis import BlockPlan, amplitudes, draw_components, synthesize
from seatune.physics.voyage import Kinematics, Segment, kinematics
from seatune.pipeline.vessel import VesselModel
from seatune.simulate.effects import EFFECTS, EffectContext, effect_transfer
from seatune.simulate.hindcast_writers import hindcast_table_from_partitions
from seatune.simulate.scenario_yaml import PartitionSpec, ScenarioSpec

ORDER = {"angle": 0, "rate": 1, "displacement": 0, "velocity": 1, "acceleration": 2, "specific_force": 2}


def partition(p: PartitionSpec) -> SpectrumPartition:
    return SpectrumPartition(hs=p.hs, tp=p.tp, dir_from_deg=p.dir_from_deg, gamma=p.gamma,
                             spreading=p.spreading, spreading_param=p.spreading_param)


def sea_state_partitions(spec: ScenarioSpec) -> list[list[SpectrumPartition]]:
    return [[partition(p) for p in (s.wind_sea, s.swell) if p is not None] for s in spec.sea_states]


def plan_segments(spec: ScenarioSpec) -> list[Segment]:
    out, end = [], 0.0
    for s in spec.segments:
        start = s.start if s.start is not None else end
        course = s.course_deg if s.course_deg is not None else (s.heading_deg or 0.0)
        heading = s.heading_deg if s.heading_deg is not None else course
        out.append(Segment(kind=s.kind, start=start, duration=s.duration, heading_deg=heading,
                           heading_rate_deg_s=s.heading_rate_deg_per_h / 3600.0, speed=s.speed, course_deg=course))
        end = start + s.duration
    return out


@dataclass
class SimulatedTrial:
    time: pd.DatetimeIndex  # UTC sample times
    kin: Kinematics
    channels: dict[str, np.ndarray]  # noise-free linear channels of the vessel YAML
    streams: dict[str, pd.DataFrame]  # sensor tables, noise and defects included
    hindcast: pd.DataFrame  # hourly hindcast at the track (with its errors)
    hindcast_wind: list  # SpectrumPartition or None per hindcast hour
    hindcast_swell: list
    truth: dict
    lat: np.ndarray = field(repr=False, default=None)
    lon: np.ndarray = field(repr=False, default=None)


def component_densities(components, partitions: list[list[SpectrumPartition]]) -> np.ndarray:
    """S(ω_n, D_n) per sea state [m²·s/rad²]: (n_states, N), spreading normalised on the direction grid."""
    grid = np.unique(components.dir_from_deg)
    col = np.searchsorted(grid, components.dir_from_deg)
    out = np.zeros((len(partitions), components.omega.size))
    for i, parts in enumerate(partitions):
        for p in parts:
            d = discrete_spreading(np.radians(grid), np.radians(p.dir_from_deg), p.spreading, p.spreading_param)
            out[i] += p.spectrum(components.omega) * d[col]
    return out


def simulate(spec: ScenarioSpec, model: VesselModel, progress=None) -> SimulatedTrial:
    rng = np.random.default_rng(spec.seed)
    fs = spec.sensors.sample_rate_hz
    dt = 1.0 / fs
    segments = plan_segments(spec)
    duration = max(s.end for s in segments)
    n = int(round(duration * fs))
    t = np.arange(n) * dt
    kin = kinematics(segments, t, spec.transition_s)
    truth_loading = model.loading(**spec.truth_loading)
    db = model.db

    # one realisation of the directional sea; Han thesis eq. 2.8
    syn = spec.synthesis
    comps = draw_components(rng, syn.omega_min, syn.omega_max, syn.components_per_direction)
    densities = component_densities(comps, sea_state_partitions(spec))
    hours = np.array([s.hour for s in spec.sea_states]) * 3600.0
    block = int(2 * round(syn.block_seconds * fs / 2))
    plan = BlockPlan.covering(n, block)
    tb = np.minimum(plan.centres, n - 1)
    w = np.clip(np.interp(t[tb], hours, np.arange(len(hours))), 0, len(hours) - 1)
    lo = np.floor(w).astype(int)
    hi = np.minimum(lo + 1, len(hours) - 1)
    frac = (w - lo)[:, None]
    amp = amplitudes(comps, (1 - frac) * densities[lo] + frac * densities[hi])  # variance linear in time
    transfer = motion_raos_at(db, truth_loading, comps.omega)  # (N, nb, 6), solved at each ω_n
    transfer = effect_transfer(db, truth_loading, comps.omega, transfer, spec.effects)
    motions = synthesize(dt, n, comps, plan, amp, transfer, kin.heading_deg[tb], kin.velocity_en[tb],
                         kin.position_en[tb], orders=(0, 1, 2))
    if progress:
        progress("waves")
    xi, xi_dot, xi_ddot = motions[:, :6], motions[:, 6:12], motions[:, 12:18]
    draft = float(_truth_draft(model, truth_loading))
    derivs = {0: xi, 1: xi_dot, 2: xi_ddot}

    channels = {ch.name: _linear_channel(ch, derivs, draft, db.g) for ch in model.channels}
    ctx = EffectContext(t=t, fs=fs, rng=rng, model=model, draft=draft, xi=derivs, kin=kin, channels=channels,
                        loading=truth_loading)
    for eff in spec.effects:
        EFFECTS[eff.kind].before_sensors(ctx, eff)

    time = pd.DatetimeIndex(pd.Timestamp(spec.start_time).tz_convert("UTC") + pd.to_timedelta(t, unit="s"))
    lat, lon = kin.latlon(*spec.start_position)
    streams = {"/imu/data": _imu_table(spec, ctx, time, draft)}
    del ctx, derivs, xi, xi_dot, xi_ddot, motions  # the 6-DOF series are in the channels and the IMU table now
    streams.update(_gnss_tables(spec, kin, time, lat, lon, rng))
    streams.update(_heave_tables(spec, model, channels, time, rng))
    if spec.sensors.quantize:
        _quantize(streams)
    defects = _apply_defects(spec, streams, rng)

    hind_parts, errors = hindcast_partitions(spec, rng)
    hours = hindcast_hours(spec, duration)
    wind, swell = hindcast_at_hours(spec, hind_parts, hours)
    t0 = pd.Timestamp(spec.start_time).tz_convert("UTC")
    hindcast = hindcast_table_from_partitions(t0 + pd.to_timedelta(hours, unit="h"), wind, swell)
    truth = _truth(spec, model, truth_loading, draft, segments, time, defects, errors)
    return SimulatedTrial(time=time, kin=kin, channels=channels, streams=streams, hindcast=hindcast,
                          hindcast_wind=wind, hindcast_swell=swell, truth=truth, lat=lat, lon=lon)


def _truth_draft(model: VesselModel, loading) -> np.ndarray:
    return model.db.draft_for_volume(loading.mass / model.db.rho)[0]


def _point_row(ch: Channel, draft: float) -> np.ndarray:
    p = np.array(ch.point, dtype=float)
    return point_translation(np.array([p[0], p[1], p[2] - draft]), AXES[ch.axis])


def _linear_channel(ch: Channel, derivs: dict, draft: float, g: float) -> np.ndarray:
    """The channel as the linear model defines it (DESIGN §4), from the synthesised 6-DOF motions."""
    order = ORDER[ch.kind]
    a = AXES[ch.axis]
    if ch.kind in ("angle", "rate"):
        return derivs[order][:, 3 + a].copy()
    value = derivs[order] @ _point_row(ch, draft)
    if ch.kind == "specific_force" and a < 2:
        value = value + (-g * derivs[0][:, 4] if a == 0 else g * derivs[0][:, 3])
    return value


def _imu_table(spec: ScenarioSpec, ctx: EffectContext, time, draft: float) -> pd.DataFrame:
    """Exact strapdown IMU: quaternion of the attitude, body rates, Rᵀ(a + g e_z) at the IMU point."""
    cfg = spec.sensors.imu
    xi, xi_dot, xi_ddot = ctx.xi[0], ctx.xi[1], ctx.xi[2]
    kin = ctx.kin
    yaw_slow = imu_model.compass_to_enu_yaw(kin.heading_deg)
    roll, pitch, yaw = xi[:, 3], xi[:, 4], yaw_slow + xi[:, 5]
    rot = imu_model.attitude(roll, pitch, yaw)
    rates = imu_model.body_rates(roll, pitch, xi_dot[:, 3], xi_dot[:, 4], xi_dot[:, 5] - kin.heading_rate)
    p = np.array([cfg.point[0], cfg.point[1], cfg.point[2] - draft])
    acc_body = np.stack([xi_ddot @ point_translation(p, a) for a in range(3)], axis=-1)
    heading_rot = imu_model.attitude(np.zeros_like(yaw_slow), np.zeros_like(yaw_slow), yaw_slow)
    acc_world = heading_rot.apply(acc_body) + np.c_[kin.acceleration_en, np.zeros(len(yaw_slow))]
    del acc_body, heading_rot  # a day at 10 Hz: each of these is tens of MB
    force = imu_model.specific_force(rot, acc_world, ctx.model.db.g)
    del acc_world
    ctx.imu = {"rotation": rot, "rates": rates, "force": force}
    for eff in spec.effects:
        EFFECTS[eff.kind].imu(ctx, eff)
    rot, rates, force = ctx.imu.pop("rotation"), ctx.imu.pop("rates"), ctx.imu.pop("force")
    rng, fs = ctx.rng, ctx.fs
    noise_rot = imu_model.Rotation.from_rotvec(rng.normal(0.0, cfg.angle_noise_std, (len(roll), 3)))
    q = (rot * noise_rot).as_quat()  # x, y, z, w as ROS orders them
    del rot, noise_rot
    w = rates + np.array(cfg.gyro_bias) + rng.normal(0.0, cfg.gyro_noise_density * np.sqrt(fs), rates.shape)
    f = force + np.array(cfg.accel_bias) + rng.normal(0.0, cfg.accel_noise_density * np.sqrt(fs), force.shape)
    return pd.DataFrame({"time": time, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3],
                         "wx": w[:, 0], "wy": w[:, 1], "wz": w[:, 2], "ax": f[:, 0], "ay": f[:, 1], "az": f[:, 2]})


def _gnss_tables(spec, kin: Kinematics, time, lat, lon, rng) -> dict[str, pd.DataFrame]:
    cfg = spec.sensors.gnss
    step = max(1, int(round(spec.sensors.sample_rate_hz / cfg.rate_hz)))
    idx = np.arange(0, len(time), step)
    m_per_deg = 111_320.0
    fix = pd.DataFrame({
        "time": time[idx],
        "latitude": lat[idx] + rng.normal(0, cfg.position_std, idx.size) / m_per_deg,
        "longitude": lon[idx] + rng.normal(0, cfg.position_std, idx.size) / (m_per_deg * np.cos(np.radians(lat[idx]))),
        "altitude": rng.normal(0, 2 * cfg.position_std, idx.size),
        "status": np.zeros(idx.size, dtype=int),
        "var_pos": np.full(idx.size, cfg.position_std**2),
    })
    v = kin.velocity_en[idx] + rng.normal(0, cfg.velocity_std, (idx.size, 2))
    vel = pd.DataFrame({"time": time[idx], "vx": v[:, 0], "vy": v[:, 1], "vz": np.zeros(idx.size),
                        "wx": np.zeros(idx.size), "wy": np.zeros(idx.size), "wz": np.zeros(idx.size)})
    return {"/gnss/fix": fix, "/gnss/vel": vel}


def heave_channels(spec: ScenarioSpec, model: VesselModel) -> list[Channel]:
    cfg = spec.sensors.heave
    if cfg is None:
        return []
    tags = {c.name: c.sensor for c in model.spec.channels}
    chosen = [ch for ch in model.channels if ch.kind in ("displacement", "velocity", "acceleration") and ch.axis == "z"]
    if cfg.sensors is not None:
        chosen = [ch for ch in chosen if tags.get(ch.name) in cfg.sensors]
    return chosen


def _heave_tables(spec, model: VesselModel, channels: dict, time, rng) -> dict[str, pd.DataFrame]:
    """Point heave sensors with white noise σ_N² = σ_X²/SNR (Han A2 eq. 18, σ_X² of the clean record)."""
    tags = {c.name: c.sensor or c.name for c in model.spec.channels}
    out = {}
    for ch in heave_channels(spec, model):
        clean = channels[ch.name]
        noisy = clean + rng.normal(0.0, np.std(clean) / np.sqrt(spec.sensors.heave.snr), clean.size)
        out[f"/{tags[ch.name]}/{ch.kind}"] = pd.DataFrame({"time": time, "x": 0.0, "y": 0.0, "z": noisy})
    return out


# Output resolution of the sensors. IMU values are fixed-point counts × a power-of-two LSB, as an MRU's
# binary output is; GNSS and heave sensors print decimals (NMEA-like).
IMU_LSB = {"q": 2.0**-16, "w": 2.0**-14, "a": 2.0**-10}  # quaternion, rad/s, m/s²
RESOLUTION = {"latitude": 1e-6, "longitude": 1e-6, "altitude": 1e-2, "vx": 1e-3, "vy": 1e-3, "z": 1e-4}


def _quantize(streams: dict[str, pd.DataFrame]) -> None:
    imu = streams["/imu/data"]
    for c in ("qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az"):
        lsb = IMU_LSB[c[0]]
        imu[c] = np.round(imu[c].to_numpy() / lsb) * lsb
    for tab in streams.values():
        for c, step in RESOLUTION.items():
            if c in tab and tab is not imu:
                tab[c] = np.round(np.round(tab[c].to_numpy() / step) * step, 9)


def _apply_defects(spec: ScenarioSpec, streams: dict[str, pd.DataFrame], rng) -> dict:
    """Logger awkwardness: outages (gaps), duplicated stamps, out-of-order writes; latency in log_time."""
    d = spec.defects
    record = {"gaps": [], "duplicate_stamps": [], "out_of_order": []}
    t0 = pd.Timestamp(spec.start_time).tz_convert("UTC")
    for gap in d.gaps:
        a, b = t0 + pd.Timedelta(seconds=gap.at), t0 + pd.Timedelta(seconds=gap.at + gap.duration)
        for topic, tab in streams.items():
            streams[topic] = tab[(tab.time < a) | (tab.time >= b)].reset_index(drop=True)
        record["gaps"].append({"start": a.isoformat(), "end": b.isoformat()})
    for tab in streams.values():
        latency = np.round(rng.uniform(0.002, 0.008, len(tab)), 4)  # the logger's clock ticks at 0.1 ms
        tab["log_time"] = tab["time"] + pd.to_timedelta(latency, unit="s")
    imu = streams["/imu/data"]
    if d.duplicate_stamps:
        rows = np.sort(rng.choice(np.arange(1, len(imu) - 1), d.duplicate_stamps, replace=False))
        dup = imu.iloc[rows].copy()
        dup["log_time"] = dup["log_time"] + pd.Timedelta(milliseconds=1)
        imu = pd.concat([imu, dup]).sort_values("log_time", kind="stable").reset_index(drop=True)
        record["duplicate_stamps"] = [str(x) for x in dup["time"]]
    if d.out_of_order:
        rows = np.sort(rng.choice(np.arange(10, len(imu) - 10), d.out_of_order, replace=False))
        for r in rows:  # the logger writes message r+1 before message r: stamps go back once
            imu.loc[[r, r + 1], "time"] = imu.loc[[r + 1, r], "time"].to_numpy()
        record["out_of_order"] = [str(imu.loc[r, "time"]) for r in rows]
    streams["/imu/data"] = imu
    return record


def hindcast_partitions(spec: ScenarioSpec, rng) -> tuple[list[list[SpectrumPartition]], list[dict]]:
    """Hindcast = truth with bias and noise per hour and partition (A5 Table 4.1 error model)."""
    e = spec.hindcast.error
    out, errors = [], []
    for s in spec.sea_states:
        hour_parts, hour_err = [], {"hour": s.hour}
        for label, p in zip(("wind_sea", "swell"), (s.wind_sea, s.swell), strict=True):
            if p is None or (label == "swell" and e.drop_swell):
                continue
            dhs = e.hs_rel_bias + rng.normal(0, e.hs_rel_std)
            dtp = e.tp_bias + rng.normal(0, e.tp_std)
            ddir = e.dir_bias_deg + rng.normal(0, e.dir_std_deg)
            hour_parts.append(SpectrumPartition(hs=max(p.hs * (1 + dhs), 0.0), tp=max(p.tp + dtp, 1.0),
                                                dir_from_deg=(p.dir_from_deg + ddir) % 360.0, gamma=p.gamma,
                                                spreading=p.spreading, spreading_param=p.spreading_param))
            hour_err[label] = {"hs_rel": float(dhs), "tp": float(dtp), "dir_deg": float(ddir)}
        out.append(hour_parts)
        errors.append(hour_err)
    return out, errors


def hindcast_hours(spec: ScenarioSpec, duration: float) -> np.ndarray:
    """Hourly hindcast times [h from the start]: one hour before the trial to one after."""
    return np.arange(-1, int(np.ceil(duration / 3600.0)) + 2, dtype=float)


def hindcast_at_hours(spec: ScenarioSpec, parts: list[list[SpectrumPartition]], hours: np.ndarray):
    """(wind, swell) partitions of the hindcast at each hour (the scenario state at or before it)."""
    spec_hours = np.array([s.hour for s in spec.sea_states])
    wind, swell = [], []
    for h in hours:
        i = int(np.clip(np.searchsorted(spec_hours, h, side="right") - 1, 0, len(parts) - 1))
        state = spec.sea_states[i]
        it = iter(parts[i])
        wind.append(next(it) if state.wind_sea is not None else None)
        swell.append(next(it, None) if state.swell is not None else None)
    return wind, swell


def _truth(spec, model, loading, draft, segments, time, defects, errors) -> dict:
    t0 = time[0]
    lo = {k: float(getattr(loading, k)[0]) for k in ("mass", "xcg", "ycg", "zcg", "r44", "r55", "r66",
                                                      "gmt_fs", "gml_fs", "beta33", "beta44", "beta55")}
    lo["displacement"] = lo["mass"] / model.db.rho
    lo["draft"] = float(draft)
    half = spec.transition_s / 2
    segs = []
    for s in segments:
        start = t0 + pd.Timedelta(seconds=s.start + (half if s.start > 0 else 0.0))
        end = t0 + pd.Timedelta(seconds=s.end - half)
        segs.append({"kind": s.kind, "free_floating": s.free_floating, "start": start.isoformat(),
                     "end": end.isoformat(), "heading_deg": float(s.heading_deg % 360),
                     "heading_rate_deg_per_h": float(s.heading_rate_deg_s * 3600), "speed": float(s.speed)})
    seas = []
    for s in spec.sea_states:
        seas.append({"time": (t0 + pd.Timedelta(hours=s.hour)).isoformat(),
                     **{k: getattr(s, k).model_dump() for k in ("wind_sea", "swell") if getattr(s, k) is not None}})
    return {
        "scenario": spec.name, "seed": spec.seed, "vessel": spec.vessel,
        "start_time": t0.isoformat(), "end_time": (time[-1]).isoformat(),
        "sample_rate_hz": spec.sensors.sample_rate_hz,
        "loading": lo, "segments": segs, "sea_states": seas, "hindcast_errors": errors,
        "defects": defects, "effects": [e.model_dump() for e in spec.effects],
    }


# ---------------------------------------------------------------------------------------------- I/O

MSGTYPE = {"/imu/data": ("sensor_msgs/msg/Imu", "imu_link"), "/gnss/fix": ("sensor_msgs/msg/NavSatFix", "gnss"),
           "/gnss/vel": ("geometry_msgs/msg/TwistStamped", "enu")}


def stream_group(topic: str) -> str:
    return "imu" if topic.startswith("/imu") else "gnss" if topic.startswith("/gnss") else "heave"


def ros_streams(spec: ScenarioSpec, trial: SimulatedTrial, groups: list[str]) -> list:
    from seatune.simulate.log_writers import Stream

    out = []
    for topic, table in trial.streams.items():
        if stream_group(topic) not in groups:
            continue
        msgtype, frame = MSGTYPE.get(topic, ("geometry_msgs/msg/Vector3Stamped", topic.split("/")[1]))
        if topic == "/imu/data":
            frame = spec.sensors.imu.frame_id
        out.append(Stream(topic=topic, msgtype=msgtype, frame_id=frame, table=table))
    return out


def write_trial(spec: ScenarioSpec, trial: SimulatedTrial, out: Path, scenario_path: Path | None = None,
                echo=print) -> list[Path]:
    """Write the logs, the hindcast and truth.yaml into `out` (every file atomically)."""
    import yaml

    from seatune.atomic import atomic_path
    from seatune.simulate import log_writers as lw

    out.mkdir(parents=True, exist_ok=True)
    name = spec.name
    written = []
    o = spec.outputs
    if o.mcap:
        written.append(lw.write_mcap(out / f"{name}.mcap", ros_streams(spec, trial, o.mcap),
                                     message_index=o.mcap_message_index, zstd_level=o.mcap_zstd_level))
        if spec.defects.truncate_mcap is not None:
            lw.truncate(written[-1], spec.defects.truncate_mcap)
    if o.ros1_bag:
        written.append(lw.write_ros1_bag(out / f"{name}.bag", ros_streams(spec, trial, o.ros1_bag)))
    if o.ros2_bag:
        written.append(lw.write_ros2_bag(out / f"{name}_ros2", ros_streams(spec, trial, o.ros2_bag)))
    if o.csv:
        written += _write_csvs(trial, out, name, o.csv)
    if o.hindcast_netcdf or o.hindcast_csv:
        written += _write_hindcast(spec, trial, out, name)
    with atomic_path(out / "truth.yaml") as tmp:
        tmp.write_text(yaml.safe_dump(trial.truth, sort_keys=False))
    written.append(out / "truth.yaml")
    if scenario_path is not None:
        with atomic_path(out / "scenario.yaml") as tmp:
            tmp.write_text(Path(scenario_path).read_text())
        written.append(out / "scenario.yaml")
    return written


def _write_csvs(trial: SimulatedTrial, out: Path, name: str, groups: list[str]) -> list[Path]:
    from seatune.simulate.log_writers import write_csv

    paths = []
    if "imu" in groups:
        paths.append(write_csv(out / f"{name}_imu.csv", trial.streams["/imu/data"].drop(columns="log_time")))
    if "gnss" in groups:
        fix = trial.streams["/gnss/fix"].drop(columns=["log_time", "status", "var_pos"])
        vel = trial.streams["/gnss/vel"][["time", "vx", "vy"]].rename(columns={"vx": "vel_east", "vy": "vel_north"})
        paths.append(write_csv(out / f"{name}_gnss.csv", fix.merge(vel, on="time", how="outer")))
    heave = {t: tab for t, tab in trial.streams.items() if stream_group(t) == "heave"}
    if heave and "heave" in groups:
        first = next(iter(heave.values()))
        wide = pd.DataFrame({"time": first["time"]})
        for topic, tab in heave.items():
            wide[topic.strip("/").replace("/", "_")] = tab["z"].to_numpy()
        paths.append(write_csv(out / f"{name}_heave.csv", wide))
    return paths


def _write_hindcast(spec: ScenarioSpec, trial: SimulatedTrial, out: Path, name: str) -> list[Path]:
    from seatune.simulate import hindcast_writers as hw

    paths = []
    times = trial.hindcast["time"]
    t_rel = (times - trial.time[0]).dt.total_seconds().to_numpy()
    k = np.clip(np.searchsorted(trial.kin.t, t_rel), 0, len(trial.kin.t) - 1)
    if spec.outputs.hindcast_netcdf:
        bulk = hw.era5_bulk_fields(trial.hindcast_wind, trial.hindcast_swell)
        d2fd = None
        if spec.hindcast.spectra_2d:
            d2fd = hw.era5_d2fd([[p for p in (w, s) if p is not None]
                                 for w, s in zip(trial.hindcast_wind, trial.hindcast_swell, strict=True)])
        grid = hw.grid_fields_around_track(times, trial.lat[k], trial.lon[k], bulk,
                                           resolution=spec.hindcast.resolution_deg, d2fd=d2fd)
        paths.append(hw.write_era5_netcdf(out / f"{name}_era5.nc", times, grid.latitudes, grid.longitudes,
                                          grid.fields, grid.d2fd))
    if spec.outputs.hindcast_csv:
        paths.append(hw.write_hindcast_csv(out / f"{name}_hindcast.csv", trial.hindcast))
    return paths

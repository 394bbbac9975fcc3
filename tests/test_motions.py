"""seatune.pipeline.motions: sign conventions against hand-built rotations, GNSS speed/course against the
WGS-84 radii, time repair, resampling with gaps, unit detection.

Expected numbers come from the construction of each case (rotation matrices written out axis by axis from the
physical attitude, velocities along the equator where the radii are the textbook constants a and a(1 − e²)),
never from the code under test.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from seatune.errors import UserError
from seatune.io.log_readers import TopicTable, read_log
from seatune.pipeline.motions import (
    IMU_COLUMNS,
    build_motions,
    gnss_motions,
    imu_motions,
    repair_time,
    resample,
    unit_findings,
)
from seatune.simulate.log_writers import Stream, write_csv, write_mcap

T0 = pd.Timestamp("2026-03-14T06:00:00Z")
IMU = "sensor_msgs/msg/Imu"
s2 = np.sqrt(0.5)


def _t(seconds) -> pd.Series:
    return pd.Series(T0 + pd.to_timedelta(np.round(np.asarray(seconds, float) * 1e9).astype(np.int64), unit="ns"))


def imu_table(matrices, w=None, f=None, frame_id="imu_link") -> TopicTable:
    """An Imu topic whose orientation is the body→world rotation with the given columns (images of the body
    x, y, z axes in world coordinates)."""
    m = np.asarray(matrices, float)
    n = len(m)
    q = Rotation.from_matrix(m).as_quat()  # (x, y, z, w), as sensor_msgs stores it
    w = np.zeros((n, 3)) if w is None else np.asarray(w, float)
    f = np.tile([0.0, 0.0, 9.81], (n, 1)) if f is None else np.asarray(f, float)
    t = _t(np.arange(n) * 0.1)
    df = pd.DataFrame({"time": t, "log_time": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3],
                       "wx": w[:, 0], "wy": w[:, 1], "wz": w[:, 2], "ax": f[:, 0], "ay": f[:, 1], "az": f[:, 2]})
    return TopicTable("/imu/data", IMU, frame_id, df, "test.mcap")


def cols(x, y, z):
    return np.column_stack([x, y, z])


# ------------------------------------------------------------------------------------------------ IMU: FLU/ENU


def test_flu_sign_conventions_against_hand_built_rotations():
    phi, theta = 0.1, 0.05
    c, s = np.cos, np.sin
    cases = [  # (body x, body y (port), body z) in ENU → expected (roll, pitch, heading_deg)
        (cols((0, 1, 0), (-1, 0, 0), (0, 0, 1)), (0.0, 0.0, 0.0)),  # bow north, port west
        (cols((1, 0, 0), (0, 1, 0), (0, 0, 1)), (0.0, 0.0, 90.0)),  # bow east: heading 90°
        (cols((-s2, -s2, 0), (s2, -s2, 0), (0, 0, 1)), (0.0, 0.0, 225.0)),  # bow south-west
        # bow east, starboard (−y) down: port side rises → +roll
        (cols((1, 0, 0), (0, c(phi), s(phi)), (0, -s(phi), c(phi))), (phi, 0.0, 90.0)),
        # bow east, bow down → +pitch
        (cols((c(theta), 0, -s(theta)), (0, 1, 0), (s(theta), 0, c(theta))), (0.0, theta, 90.0)),
        # bow north, bow down: x_b = (0, cos θ, −sin θ)
        (cols((0, c(theta), -s(theta)), (-1, 0, 0), (0, s(theta), c(theta))), (0.0, theta, 0.0)),
    ]
    m = imu_motions(imu_table([c_ for c_, _ in cases]))
    assert list(m.columns) == ["time", *IMU_COLUMNS]
    want = np.array([e for _, e in cases])
    np.testing.assert_allclose(m["roll"], want[:, 0], atol=1e-12)
    np.testing.assert_allclose(m["pitch"], want[:, 1], atol=1e-12)
    dh = (m["heading_deg"].to_numpy() - want[:, 2] + 180) % 360 - 180
    np.testing.assert_allclose(dh, 0, atol=1e-9)
    np.testing.assert_allclose(m["imu_fz"], 9.81)


def test_rates_and_specific_force_pass_through_in_flu():
    w = [[0.01, -0.02, 0.03]]
    f = [[0.1, -0.2, 9.7]]
    m = imu_motions(imu_table([np.eye(3)], w=w, f=f))
    assert m[["roll_rate", "pitch_rate", "yaw_rate"]].to_numpy().tolist() == w
    assert m[["imu_fx", "imu_fy", "imu_fz"]].to_numpy().tolist() == f


def test_simulator_attitude_round_trip():
    """The simulator's quaternion (seatune.physics.imu.attitude, ZYX body→ENU) reads back as its angles."""
    from seatune.physics.imu import attitude

    rng = np.random.default_rng(3)
    roll, pitch = rng.uniform(-0.3, 0.3, 50), rng.uniform(-0.2, 0.2, 50)
    heading = rng.uniform(0, 360, 50)
    r = attitude(roll, pitch, np.radians(90.0 - heading))
    m = imu_motions(imu_table(r.as_matrix()))
    np.testing.assert_allclose(m["roll"], roll, atol=1e-12)
    np.testing.assert_allclose(m["pitch"], pitch, atol=1e-12)
    np.testing.assert_allclose((m["heading_deg"] - heading + 180) % 360 - 180, 0, atol=1e-9)


# ------------------------------------------------------------------------------------------------ IMU: FRD/NED


def test_ned_frd_imu_is_converted():
    """An MRU reporting FRD body axes in a NED world: the same physical attitudes as above, built in NED."""
    phi, theta, g = 0.1, 0.05, 9.81
    c, s = np.cos, np.sin
    cases = [  # (body x fwd, body y starboard, body z down) in NED → (roll, pitch, heading)
        (cols((0, 1, 0), (-1, 0, 0), (0, 0, 1)), (0.0, 0.0, 90.0)),  # bow east, starboard south
        (cols((1, 0, 0), (0, 1, 0), (0, 0, 1)), (0.0, 0.0, 0.0)),  # bow north
        (cols((0, c(theta), s(theta)), (-1, 0, 0), (0, -s(theta), c(theta))), (0.0, theta, 90.0)),  # bow down
        (cols((0, 1, 0), (-c(phi), 0, s(phi)), (s(phi), 0, c(phi))), (phi, 0.0, 90.0)),  # starboard down
    ]
    w_frd = [[0.01, 0.02, 0.03]] * len(cases)  # p (starboard down), q (bow up), r (bow to starboard)
    f_frd = [[0.0, 0.0, -g]] * len(cases)  # at rest: the specific force points up = −z_FRD
    want = np.array([e for _, e in cases])
    for frame, frame_id in (("NED", "imu_link"), ("auto", "imu_link_ned")):
        m = imu_motions(imu_table([c_ for c_, _ in cases], w=w_frd, f=f_frd, frame_id=frame_id), frame=frame)
        np.testing.assert_allclose(m["roll"], want[:, 0], atol=1e-12)
        np.testing.assert_allclose(m["pitch"], want[:, 1], atol=1e-12)
        np.testing.assert_allclose((m["heading_deg"] - want[:, 2] + 180) % 360 - 180, 0, atol=1e-9)
        # body FLU: roll rate unchanged, pitch rate + bow down, yaw rate + bow to port; f_z = +g up
        np.testing.assert_allclose(m[["roll_rate", "pitch_rate", "yaw_rate"]], [[0.01, -0.02, -0.03]] * 4)
        np.testing.assert_allclose(m[["imu_fx", "imu_fy", "imu_fz"]], [[0.0, 0.0, g]] * 4)
    flu = imu_motions(imu_table([c_ for c_, _ in cases], frame_id="imu_link_ned"), frame="FLU")
    assert not np.allclose(flu["heading_deg"], want[:, 2])  # FLU forced: no conversion


def test_orientation_not_provided_and_missing_imu():
    tt = imu_table([np.eye(3)] * 3, w=[[0.1, 0.2, 0.3]] * 3)
    tt.table.loc[1, ["qx", "qy", "qz", "qw"]] = np.nan  # the reader's "orientation not provided"
    tt.table.loc[2, ["qx", "qy", "qz", "qw"]] = 0.0  # all zeros: not a rotation
    m = imu_motions(tt)
    assert m["roll"].isna().tolist() == [False, True, True]
    assert m["heading_deg"].isna().tolist() == [False, True, True]
    assert m["yaw_rate"].tolist() == [0.3] * 3 and m.attrs["no_orientation"] == 2
    csv_like = TopicTable("/mru", IMU, "", pd.DataFrame({  # a table export: angles, rates, no quaternion
        "time": _t([0.0, 0.1]), "roll": [0.1, 0.2], "pitch": [-0.1, 0.0], "heading_deg": [10.0, 11.0],
        "wx": [0.01, 0.02], "wy": 0.0, "wz": 0.0}))
    m = imu_motions(csv_like)
    assert m["roll"].tolist() == [0.1, 0.2] and m["heading_deg"].tolist() == [10.0, 11.0]
    assert m["imu_fz"].isna().all() and m.attrs["no_orientation"] == 0
    with pytest.raises(UserError, match="no sensor_msgs/Imu topic"):
        imu_motions(None)
    fix = TopicTable("/gnss/fix", "sensor_msgs/msg/NavSatFix", "gnss", pd.DataFrame(), "x.bag")
    with pytest.raises(UserError, match="x.bag: topic /gnss/fix: no sensor_msgs/Imu topic"):
        imu_motions(fix)


# ------------------------------------------------------------------------------------------------ GNSS


def _fix_table(lat, lon, status=None, start=0.0):
    t = _t(start + np.arange(len(lat)))
    df = pd.DataFrame({"time": t, "log_time": t, "latitude": lat, "longitude": lon, "altitude": 0.0,
                       "status": np.zeros(len(lat), np.int8) if status is None else np.asarray(status, np.int8)})
    return TopicTable("/gnss/fix", "sensor_msgs/msg/NavSatFix", "gnss", df, "g.bag")


def _vel_table(vx, vy, frame_id="enu"):
    t = _t(np.arange(len(vx)))
    df = pd.DataFrame({"time": t, "log_time": t, "vx": vx, "vy": vy, "vz": 0.0, "wx": 0.0, "wy": 0.0, "wz": 0.0})
    return TopicTable("/gnss/vel", "geometry_msgs/msg/TwistStamped", frame_id, df, "g.bag")


def test_gnss_speed_and_course_from_velocity():
    fix = _fix_table([60.0] * 4, [5.0] * 4)
    for vel in (_vel_table([3.0] * 4, [4.0] * 4), _vel_table([4.0] * 4, [3.0] * 4, frame_id="gps_ned")):
        g = gnss_motions(fix, vel)
        assert list(g.columns) == ["time", "lat", "lon", "sog", "cog_deg"]
        np.testing.assert_allclose(g["sog"], 5.0)
        np.testing.assert_allclose(g["cog_deg"], np.degrees(np.arctan2(3.0, 4.0)))  # 36.87°: east of north
    g = gnss_motions(None, _vel_table([-1.0], [0.0]))
    assert g["cog_deg"].tolist() == [270.0] and g["lat"].isna().all()
    # nav_msgs/Odometry: 2 m/s forward in the body (child frame), bow to the north-east → course 45°
    bow_ne = Rotation.from_matrix(cols((s2, s2, 0), (-s2, s2, 0), (0, 0, 1))).as_quat()
    t = _t([0.0])
    odom = pd.DataFrame({"time": t, "log_time": t, "x": 0.0, "y": 0.0, "z": 0.0, "qx": bow_ne[0], "qy": bow_ne[1],
                         "qz": bow_ne[2], "qw": bow_ne[3], "vx": 2.0, "vy": 0.0, "vz": 0.0, "wx": 0.0, "wy": 0.0,
                         "wz": 0.0})
    g = gnss_motions(None, TopicTable("/odom", "nav_msgs/msg/Odometry", "odom", odom, "o.bag"))
    np.testing.assert_allclose(g[["sog", "cog_deg"]].to_numpy(), [[2.0, 45.0]])


def test_gnss_speed_and_course_from_fixes_on_the_equator():
    a, e2 = 6378137.0, 6.69437999014e-3
    v, n = 2.0, 20
    t = np.arange(n)
    east = gnss_motions(_fix_table(np.zeros(n), np.degrees(v * t / a)), None)  # prime vertical radius = a
    np.testing.assert_allclose(east["sog"], v, rtol=1e-9)
    np.testing.assert_allclose(east["cog_deg"], 90.0, atol=1e-6)
    m0 = a * (1 - e2)  # meridional radius at the equator, 6,335,439 m
    north = gnss_motions(_fix_table(np.degrees(v * t / m0), np.zeros(n)), None)
    np.testing.assert_allclose(north["sog"], v, rtol=1e-6)
    np.testing.assert_allclose((north["cog_deg"] + 180) % 360 - 180, 0.0, atol=1e-6)
    status = np.zeros(n)
    status[4] = -1  # no fix: left out, counted
    g = gnss_motions(_fix_table(np.zeros(n), np.degrees(v * t / a), status=status), None)
    assert len(g) == n - 1 and g.attrs["no_fix"] == 1
    np.testing.assert_allclose(g["sog"], v, rtol=1e-9)


# ------------------------------------------------------------------------------------------------ time repair


def test_repair_time_counts():
    secs = [0, 1, 1, 3, 2, 4, 4, 5]
    df = pd.DataFrame({"time": _t(secs), "v": np.arange(8.0)})
    out, counts = repair_time(df)
    assert counts == {"non_monotonic_repaired": 1, "duplicates_removed": 2, "missing_stamps_removed": 0}
    assert (out["time"] - T0).dt.total_seconds().tolist() == [0, 1, 2, 3, 4, 5]
    assert out["v"].tolist() == [0, 1, 4, 3, 5, 7]  # the first received of each repeated stamp is kept
    tt, c2 = repair_time(TopicTable("/x", IMU, "f", df, "s"))
    assert isinstance(tt, TopicTable) and c2 == counts and tt.table.equals(out)


# ------------------------------------------------------------------------------------------------ resample


def _imu_like(t, **cols_):
    return pd.DataFrame({"time": _t(t), **{k: v(np.asarray(t)) for k, v in cols_.items()}})


def test_resample_splits_at_a_gap_longer_than_max_gap():
    t_imu = np.concatenate([np.arange(0, 20, 0.1), np.arange(30, 50, 0.1)]) + 0.03  # 10 s gap
    t_gps = np.concatenate([np.arange(0, 20, 1.0), np.arange(30, 50, 1.0)]) + 0.5
    imu = _imu_like(t_imu, roll=lambda t: 0.001 * t, heading_deg=lambda t: (355.0 + 0.5 * t) % 360)
    gps = _imu_like(t_gps, lat=lambda t: 60 + 1e-5 * t, sog=lambda t: 0.1 * t)
    out, counts = resample([imu, gps], rate_hz=10.0, max_gap_s=2.0)
    assert list(out.columns) == ["time", "record", "roll", "heading_deg", "lat", "sog"]
    assert counts["records"] == 2 and counts["gaps_split"] == 1
    secs = (out["time"] - T0).dt.total_seconds().to_numpy()
    assert not ((secs > 20) & (secs < 30)).any()  # nothing invented inside the gap
    assert (out["record"].to_numpy() == (secs > 25)).all()
    assert (out["time"].astype("int64") % 100_000_000 == 0).all()  # grid on whole multiples of 0.1 s
    ok = out["roll"].notna()
    np.testing.assert_allclose(out["roll"][ok], 0.001 * secs[ok], atol=1e-12)  # linear data: exact
    h = out["heading_deg"][ok]
    assert ((h >= 0) & (h < 360)).all()
    np.testing.assert_allclose((h - (355.0 + 0.5 * secs[ok]) + 180) % 360 - 180, 0, atol=1e-9)  # through 0°
    g = out["lat"].notna().to_numpy()
    np.testing.assert_allclose(out["lat"][g], 60 + 1e-5 * secs[g], rtol=0, atol=1e-12)


def test_resample_interpolates_short_gaps_and_masks_one_source():
    k = np.arange(300)
    t = k / 10
    short = t[(k < 100) | (k > 110)]  # samples 10.0 … 11.0 s lost (1.2 s between 9.9 and 11.1): interpolated
    imu = _imu_like(short, roll=lambda t: 0.01 * t)
    out, counts = resample([imu], 10.0, 2.0)
    assert counts["records"] == 1 and counts["samples_interpolated"] == 11 and out["roll"].notna().all()
    secs = (out["time"] - T0).dt.total_seconds().to_numpy()
    np.testing.assert_allclose(out["roll"], 0.01 * secs, atol=1e-12)
    # the IMU pauses 10 s but the GNSS goes on: one record, the IMU masked in its gap
    longer = t[(k < 100) | (k >= 200)]
    gps = _imu_like(np.arange(0, 31, 1.0), sog=lambda t: np.ones_like(t))  # covers the IMU record
    out, counts = resample([_imu_like(longer, roll=lambda t: 0.01 * t), gps], 10.0, 2.0)
    secs = (out["time"] - T0).dt.total_seconds().to_numpy()
    assert counts["records"] == 1 and out["sog"].notna().all()
    covered = (secs < 9.95) | ((secs > 19.95) & (secs < 29.95))  # IMU samples up to 9.9 s, from 20.0 to 29.9 s
    assert out["roll"][~covered].isna().all() and out["roll"][covered].notna().all()
    assert counts["samples_masked"] == (~covered).sum() == 101


def test_resample_joins_logs_back_to_back():
    a = _imu_like(np.arange(0, 10, 0.1), roll=lambda t: 0.01 * t)
    b = _imu_like(np.arange(10, 20, 0.1), roll=lambda t: 0.01 * t)
    overlap = _imu_like(np.arange(19, 20, 0.1), roll=lambda t: 0.01 * t)  # repeated stamps: dropped, counted
    out, counts = resample([a, b, overlap], 10.0, 2.0)
    assert counts["records"] == 1 and len(out) == 200 and counts["duplicates_removed"] == 10
    with pytest.raises(ValueError, match="two different sources"):
        resample([a, a.assign(sog=1.0)], 10.0, 2.0)


# ------------------------------------------------------------------------------------------------ units


def _motion(n=3000, dt=0.1, roll_deg=False, rate_deg=False, f_g=False):
    t = np.arange(n) * dt
    roll = 0.05 * np.sin(2 * np.pi * t / 9.0)
    rate = 0.05 * 2 * np.pi / 9.0 * np.cos(2 * np.pi * t / 9.0)
    pitch = 0.02 * np.sin(2 * np.pi * t / 7.0)
    prate = 0.02 * 2 * np.pi / 7.0 * np.cos(2 * np.pi * t / 7.0)
    fz = np.full(n, 9.81)
    return pd.DataFrame({"time": _t(t), "roll": np.degrees(roll) if roll_deg else roll,
                         "roll_rate": np.degrees(rate) if rate_deg else rate, "pitch": pitch, "pitch_rate": prate,
                         "yaw_rate": np.zeros(n), "imu_fx": 0.0, "imu_fy": 0.0, "imu_fz": fz / 9.80665 if f_g else fz})


def test_unit_findings_name_the_evidence_and_change_nothing():
    ref = _motion()
    assert unit_findings(ref.copy()) == []
    cases = [(dict(roll_deg=True), ("roll",), "deg"), (dict(rate_deg=True), ("roll_rate",), "deg/s"),
             (dict(roll_deg=True, rate_deg=True), ("roll", "roll_rate"), "deg"), (dict(f_g=True), None, "g")]
    for kw, cols, unit in cases:
        df = _motion(**kw)
        before = df.copy()
        found = [f for f in unit_findings(df) if f.certain]
        assert len(found) == 1 and found[0].unit == unit, (kw, found)
        assert cols is None or found[0].columns == cols
        pd.testing.assert_frame_equal(df, before)  # evidence only: the data are not touched
    knots = pd.DataFrame({"time": _t(np.arange(100.0)), "lat": np.zeros(100),
                          "lon": np.degrees(3.0 * np.arange(100.0) / 6378137.0), "sog": 3.0 * 3600 / 1852})
    assert [f.unit for f in unit_findings(knots)] == ["knots"]


# ------------------------------------------------------------------------------------------------ end to end


def test_build_motions_from_an_mcap_and_a_gnss_csv(tmp_path):
    n = 600
    secs = np.arange(n) * 0.1
    secs[100] = secs[99]  # a repeated stamp
    heading = 40.0 + 0 * secs
    r = Rotation.from_euler("ZYX", np.column_stack([np.radians(90 - heading), 0.02 * np.sin(secs),
                                                    0.05 * np.sin(0.7 * secs)]))
    q = r.as_quat()
    imu = pd.DataFrame({"time": _t(secs), "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3],
                        "wx": 0.0, "wy": 0.0, "wz": 0.0, "ax": 0.0, "ay": 0.0, "az": 1.0})  # accelerometer in g
    mcap = write_mcap(tmp_path / "t.mcap", [Stream("/imu/data", IMU, "imu_link", imu)])
    gnss = pd.DataFrame({"time": _t(np.arange(60.0)), "lat": 60.0, "lon": 5.0, "vel_east": 1.0, "vel_north": 0.0})
    csv = write_csv(tmp_path / "gnss.csv", gnss)
    table, report = build_motions([read_log(mcap), read_log(csv)], rate_hz=10.0, max_gap_s=2.0)
    assert report.counts["duplicates_removed"] == 1 and report.counts["records"] == 1
    assert any("like g" in w and "left as is" in w for w in report.warnings)  # a ROS field: SI, only warned
    assert {"roll", "pitch", "heading_deg", "lat", "lon", "sog", "cog_deg", "record"} <= set(table.columns)
    np.testing.assert_allclose(table["heading_deg"], 40.0, atol=1e-9)
    np.testing.assert_allclose(table["imu_fz"], 1.0)
    np.testing.assert_allclose(table["cog_deg"].dropna(), 90.0)
    with pytest.raises(UserError, match="no sensor_msgs/Imu topic"):
        build_motions([read_log(csv)])

"""Issue 19: the units policy and the IMU mounting.

- Public third-party bags (tests/data/third_party/, README there) read with zero rescaling: every rate and
  specific force equals the message field as rosbags' own deserializer gives it, bit for bit; the attitude is
  scipy's ZYX Euler angles of the message quaternion.
- CSV columns: undeclared degrees / g stop ingest (exit 2, one line naming the log column); declared units are
  converted exactly (× π/180, × 9.80665, the definitions); SI columns pass untouched.
- A rotated IMU with its rotation in the vessel YAML (quaternion or roll/pitch/yaw) or in /tf_static gives the
  motions of an upright one to 1e-9; the rotated raw vectors and quaternion come from scipy's Rotation here.
"""

from __future__ import annotations

import types
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from click.testing import CliRunner
from rosbags.highlevel import AnyReader
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from scipy.spatial.transform import Rotation

from seatune.errors import UserError
from seatune.io.log_readers import read_log
from seatune.io.run_yaml import Run
from seatune.io.vessel_yaml import load_vessel
from seatune.pipeline import ingest as ingest_stage
from seatune.pipeline.motions import build_motions, check_units, imu_motions, repair_time
from seatune.simulate.log_writers import Stream, write_mcap
from tests.conftest import ROOT

CORPUS = ROOT / "tests" / "data" / "third_party"
VESSEL = ROOT / "configs" / "vessels" / "sample_osv.yaml"
HINDCAST = ROOT / "sample_logs" / "sample_trial_era5.nc"
T0 = pd.Timestamp("2026-03-14T07:00:00Z")
RATES = {"roll_rate": "angular_velocity.x", "pitch_rate": "angular_velocity.y", "yaw_rate": "angular_velocity.z",
         "imu_fx": "linear_acceleration.x", "imu_fy": "linear_acceleration.y", "imu_fz": "linear_acceleration.z"}
# corpus entry → its IMU topic (the ROS2 versions were made from the ROS1 excerpts by rosbags-convert)
BAGS = {"robot_localization_test1.bag": "/imu/data", "robot_localization_test2.bag": "/imu/data",
        "imu_tools_ardrone_imu.bag": "/ardrone/imu", "imu_tools_ardrone_imu_ros2_mcap": "/ardrone/imu",
        "imu_tools_sparkfun_razor.bag": "/imu/data_raw", "imu_tools_sparkfun_razor_ros2_sqlite3": "/imu/data_raw",
        "imu_tools_phidgets_imu_upside_down.bag": "/imu/data_raw"}


def _field(msg, path):
    for part in path.split("."):
        msg = getattr(msg, part)
    return msg


def rosbags_imu(path: Path, topic: str) -> pd.DataFrame:
    """The IMU messages as rosbags deserialises them (the independent source), sorted by header stamp."""
    rows = []
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        for conn, _, raw in reader.messages(connections=conns):
            m = reader.deserialize(raw, conn.msgtype)
            o = m.orientation
            rows.append({"stamp": m.header.stamp.sec * 10**9 + m.header.stamp.nanosec,
                         "q": (o.x, o.y, o.z, o.w), "ocov0": m.orientation_covariance[0],
                         **{c: _field(m, p) for c, p in RATES.items()}})
    df = pd.DataFrame(rows)
    return df.sort_values("stamp", kind="stable").drop_duplicates("stamp").reset_index(drop=True)


def test_corpus_is_small_and_documented():
    size = sum(p.stat().st_size for p in CORPUS.rglob("*") if p.is_file())
    assert size < 2_000_000
    readme = (CORPUS / "README.md").read_text()
    for name in BAGS:
        assert name in readme


@pytest.mark.parametrize("name", list(BAGS))
def test_third_party_bags_read_with_zero_rescaling(name):
    path, topic = CORPUS / name, BAGS[name]
    want = rosbags_imu(path, topic)
    log = read_log(path)
    imu, _ = repair_time(log.topics[topic])
    m = imu_motions(imu, frame="auto")
    before = m.copy()
    notes = check_units(m, imu, table=False)  # ROS fields: warnings at most, never a change
    pd.testing.assert_frame_equal(m, before)
    assert all("left as is" in n for n in notes)
    assert m["time"].astype("int64").tolist() == want["stamp"].tolist()
    for col in RATES:  # bit-exact: not divided by 57.3, not multiplied by 9.80665
        np.testing.assert_array_equal(m[col].to_numpy(), want[col].to_numpy(), err_msg=col)
    q = np.array(want["q"].tolist())
    ok = (np.abs(np.linalg.norm(q, axis=1) - 1.0) < 0.1) & (want["ocov0"].to_numpy() != -1.0)
    if ok.any():
        yaw_pitch_roll = Rotation.from_quat(q[ok]).as_euler("ZYX")
        np.testing.assert_array_equal(m["roll"].to_numpy()[ok], yaw_pitch_roll[:, 2])
        np.testing.assert_array_equal(m["pitch"].to_numpy()[ok], yaw_pitch_roll[:, 1])
    assert m["roll"].isna().to_numpy()[~ok].all()
    if name == "robot_localization_test2.bag":  # header stamps in 1970: the whole step refuses it in one line
        with pytest.raises(UserError, match="before 1990"):
            build_motions([log])
        return
    # the whole ingest step (resampled to 10 Hz): the rates are numpy's linear interpolation of the fields
    table, report = build_motions([log], rate_hz=10.0, max_gap_s=2.0)
    grid = table["time"].astype("int64").to_numpy()
    at = (grid - grid[0]).astype(float)
    src = (want["stamp"].to_numpy() - grid[0]).astype(float)
    for col in RATES:
        np.testing.assert_allclose(table[col], np.interp(at, src, want[col]), rtol=1e-12, atol=1e-12, err_msg=col)
    assert not any("converted" in w for w in report.warnings)


def test_ros_plausibility_warnings_name_what_they_saw():
    """The three excerpts the old guesser 'converted' (rates up to 31.9 rad/s) are warned about, not changed;
    the rolled and upside-down IMUs and the constant identity quaternion are named."""
    def warnings(name):
        return " | ".join(build_motions([read_log(CORPUS / name)])[1].warnings)

    w = warnings("imu_tools_sparkfun_razor.bag")
    assert "pitch_rate looks like deg/s" in w and "left as is" in w
    assert "same quaternion [0.0, 0.0, 0.0, 1.0] (identity)" in w
    w = warnings("robot_localization_test1.bag")
    assert "gravity along +y of the IMU frame" in w and "looks rolled 90°" in w
    assert "rotation: {roll_deg: 90.0, pitch_deg: 0.0, yaw_deg: 0.0}" in w
    w = warnings("imu_tools_phidgets_imu_upside_down.bag")
    assert "gravity along −z" in w and "looks rolled 180°" in w


# ------------------------------------------------------------------------------------------------ CSV units


def motion(n=600, dt=0.1):
    """A smooth SI motion: roll/pitch [rad], their rates [rad/s] (exact derivatives), specific force [m/s²]."""
    t = np.arange(n) * dt
    w1, w2 = 2 * np.pi / 9.0, 2 * np.pi / 7.0
    return pd.DataFrame({
        "time": (T0 + pd.to_timedelta(np.round(t * 1e9).astype(np.int64), unit="ns")).strftime(
            "%Y-%m-%dT%H:%M:%S.%fZ"),
        "ang_roll": 0.05 * np.sin(w1 * t), "ang_pitch": 0.02 * np.sin(w2 * t),
        "gyro_x": 0.05 * w1 * np.cos(w1 * t), "gyro_y": 0.02 * w2 * np.cos(w2 * t), "gyro_z": 0.001 * np.sin(t),
        "acc_x": 0.1 * np.sin(0.5 * t), "acc_y": 0.2 * np.cos(0.3 * t), "acc_z": 9.81 + 0.3 * np.sin(0.9 * t)})


NAMES = {"ang_roll": "roll", "ang_pitch": "pitch", "gyro_x": "roll_rate", "gyro_y": "pitch_rate",
         "gyro_z": "yaw_rate", "acc_x": "imu_fx", "acc_y": "imu_fy", "acc_z": "imu_fz"}
FIELD = {"ang_roll": "roll", "ang_pitch": "pitch", "gyro_x": "wx", "gyro_y": "wy", "gyro_z": "wz",
         "acc_x": "ax", "acc_y": "ay", "acc_z": "az"}
TO_LOG = {"deg": lambda v: np.degrees(v), "deg/s": lambda v: np.degrees(v), "g": lambda v: v / 9.80665}
FACTOR = {"deg": np.pi / 180.0, "deg/s": np.pi / 180.0, "g": 9.80665}  # the definitions
GROUPS = {"deg": ["ang_roll", "ang_pitch"], "deg/s": ["gyro_x", "gyro_y", "gyro_z"], "g": ["acc_x", "acc_y", "acc_z"]}


def csv_run(tmp_path, in_units=(), declare=(), where="log"):
    """A CSV IMU log whose `in_units` groups are written in deg / deg/s / g, and the run YAML mapping its columns
    (plain names, or {name, unit} for the `declare`d groups, per log or under ingest.columns)."""
    df = motion()
    for unit in in_units:
        for c in GROUPS[unit]:
            df[c] = TO_LOG[unit](df[c].to_numpy())
    csv = tmp_path / "mru.csv"
    df.to_csv(csv, index=False)
    declared = {c: {"name": NAMES[c], "unit": u} for u in declare for c in GROUPS[u]}
    columns = {**NAMES, **declared} if where == "log" else dict(NAMES)
    data = {"name": "t", "run_dir": str(tmp_path / "run"), "vessel": str(VESSEL), "hindcast": {"path": str(HINDCAST)},
            "logs": [{"path": str(csv), "kind": "imu", "columns": columns}]}
    if where == "ingest":
        data["ingest"] = {"columns": declared}
    path = tmp_path / "run.yaml"
    path.write_text(yaml.safe_dump(data))
    return path, df


def cli_ingest(path):
    from seatune.cli import stages  # noqa: F401  (registers the commands)
    from seatune.cli.main import cli

    return CliRunner().invoke(cli, ["ingest", str(path)])


@pytest.mark.parametrize("unit, needle", [("deg/s", "'gyro_x'"), ("g", "'acc_x', 'acc_y', 'acc_z'"),
                                          ("deg", "'ang_roll'")])
def test_undeclared_degrees_or_g_stop_with_one_line_naming_the_column(tmp_path, unit, needle):
    path, _ = csv_run(tmp_path, in_units=[unit])
    res = cli_ingest(path)
    assert res.exit_code == 2, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "mru.csv" in lines[0], res.stderr
    assert f"unit: {unit}" in lines[0] and "Traceback" not in res.output


def test_roll_alone_in_degrees_names_its_percentile(tmp_path):
    df = motion()[["time", "ang_roll", "acc_x", "acc_y", "acc_z"]]
    df["ang_roll"] = np.degrees(df["ang_roll"])
    csv = tmp_path / "roll.csv"
    df.to_csv(csv, index=False)
    log = read_log(csv, table_options={"column_map": {"ang_roll": "roll", "acc_x": "imu_fx", "acc_y": "imu_fy",
                                                      "acc_z": "imu_fz"}})
    want = np.percentile(np.abs(df["ang_roll"]), 99)  # 2.86 "rad" = 164°
    with pytest.raises(UserError, match=rf"column 'ang_roll': \|roll\| 99th percentile {want:.3g} \(> 92° if "
                                        r"radians\): looks like deg"):
        build_motions([log])


@pytest.mark.parametrize("where", ["log", "ingest"])
def test_declared_units_are_converted_exactly_and_si_left_untouched(tmp_path, where):
    path, written = csv_run(tmp_path, in_units=["deg", "deg/s", "g"], declare=["deg", "deg/s", "g"], where=where)
    (tmp_path / "si").mkdir()
    si_path, si = csv_run(tmp_path / "si")
    for run_path, df, converted in ((path, written, True), (si_path, si, False)):
        run = Run(run_path)
        logs = ingest_stage.read_logs(run)
        table = logs[0].topics["/mru/imu"].table
        for unit, cols in GROUPS.items():
            for c in cols:
                want = df[c].to_numpy() * (FACTOR[unit] if converted else 1.0)
                np.testing.assert_array_equal(table[FIELD[c]].to_numpy(), want, err_msg=c)
        motions, report = build_motions(logs)  # no unit error, nothing guessed
        assert not [w for w in report.warnings if "like" in w]
        t = motions["time"].astype("int64").to_numpy()
        src = pd.to_datetime(df["time"]).astype("int64").to_numpy()
        rate = df["gyro_x"].to_numpy() * (FACTOR["deg/s"] if converted else 1.0)
        np.testing.assert_allclose(motions["roll_rate"], np.interp(t - src[0], src - src[0], rate), rtol=1e-12)
    np.testing.assert_allclose(written["gyro_x"] * FACTOR["deg/s"], si["gyro_x"], rtol=1e-15)  # same motion


def test_a_declared_unit_of_the_wrong_kind_is_refused(tmp_path):
    path, _ = csv_run(tmp_path)
    data = yaml.safe_load(path.read_text())
    data["logs"][0]["columns"]["gyro_x"] = {"name": "roll_rate", "unit": "g"}
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(UserError, match=r"column 'gyro_x': wx takes a unit of angular rate \(rad/s, deg/s\), not 'g'"):
        ingest_stage.read_logs(Run(path))
    data["logs"][0]["columns"]["gyro_x"] = {"name": "roll_rate", "unit": "furlongs"}
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(UserError, match=r"logs\.0\.columns\.gyro_x.*unknown unit 'furlongs'"):
        Run(path)


# ------------------------------------------------------------------------------------------------ mounting


def body_motion(n=400, dt=0.1):
    """Attitude R_ENU←body, body rates and specific force of an upright IMU (any smooth motion will do)."""
    t = np.arange(n) * dt
    roll, pitch = 0.06 * np.sin(2 * np.pi * t / 9.0), 0.03 * np.sin(2 * np.pi * t / 7.0 + 0.4)
    yaw = np.radians(50.0) + 0.02 * np.sin(2 * np.pi * t / 30.0)
    att = Rotation.from_euler("ZYX", np.column_stack([yaw, pitch, roll]))
    w = np.column_stack([0.04 * np.cos(0.7 * t), 0.02 * np.cos(0.9 * t + 1), 0.003 * np.sin(0.2 * t)])
    f = att.inv().apply([0.0, 0.0, 9.81]) + np.column_stack([0.1 * np.sin(t), 0.05 * np.cos(t), 0.2 * np.sin(0.6 * t)])
    return t, att, w, f


def imu_table(t, att, w, f, mount: Rotation | None = None) -> pd.DataFrame:
    """The raw messages of an IMU mounted with sensor → body rotation `mount` (scipy, the independent source)."""
    if mount is not None:
        att, w, f = att * mount, mount.inv().apply(w), mount.inv().apply(f)
    q = att.as_quat()
    return pd.DataFrame({"time": T0 + pd.to_timedelta(np.round(t * 1e9).astype(np.int64), unit="ns"),
                         **{c: q[:, i] for i, c in enumerate(("qx", "qy", "qz", "qw"))},
                         **{c: w[:, i] for i, c in enumerate(("wx", "wy", "wz"))},
                         **{c: f[:, i] for i, c in enumerate(("ax", "ay", "az"))}})


def ros1_bag_with_tf_static(path, table, mount: Rotation, frame="imu_link"):
    """A ROS1 bag written with rosbags: the IMU messages and a latched /tf_static base_link → mount_plate →
    imu_link (the mounting split over two transforms)."""
    ts = get_typestore(Stores.ROS1_NOETIC)
    ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    T = ts.types
    half = Rotation.from_rotvec(mount.as_rotvec() * 0.5)

    def header(ns, frame_id):
        return T["std_msgs/msg/Header"](seq=0, stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9,
                                                                                     nanosec=ns % 10**9),
                                        frame_id=frame_id)

    def transform(parent, child, rot, ns):
        x, y, z, w = rot.as_quat()
        return T["geometry_msgs/msg/TransformStamped"](
            header=header(ns, parent), child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](translation=T["geometry_msgs/msg/Vector3"](x=1.0, y=0.0, z=2.0),
                                                       rotation=T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)))

    ns = table["time"].astype("int64").to_numpy()
    cov = np.zeros(9)
    with Ros1Writer(path) as writer:
        tf_conn = writer.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=ts, latching=1)
        imu_conn = writer.add_connection("/imu/data", "sensor_msgs/msg/Imu", typestore=ts)
        tf = T["tf2_msgs/msg/TFMessage"](transforms=[transform("base_link", "mount_plate", half, int(ns[0])),
                                                     transform("mount_plate", frame, half, int(ns[0]))])
        writer.write(tf_conn, int(ns[0]), ts.serialize_ros1(tf, "tf2_msgs/msg/TFMessage"))
        vec, quat = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
        for i, row in enumerate(table.itertuples(index=False)):
            msg = T["sensor_msgs/msg/Imu"](header=header(int(ns[i]), frame),
                                           orientation=quat(x=row.qx, y=row.qy, z=row.qz, w=row.qw),
                                           orientation_covariance=cov,
                                           angular_velocity=vec(x=row.wx, y=row.wy, z=row.wz),
                                           angular_velocity_covariance=cov,
                                           linear_acceleration=vec(x=row.ax, y=row.ay, z=row.az),
                                           linear_acceleration_covariance=cov)
            writer.write(imu_conn, int(ns[i]), ts.serialize_ros1(msg, "sensor_msgs/msg/Imu"))
    return path


def ingest_motions(tmp_path, log_path, rotation=None, tag="run"):
    """The ingest stage's motion table (no hindcast needed) with the vessel YAML's sensors.imu.rotation."""
    vessel = yaml.safe_load(VESSEL.read_text())
    if rotation is not None:
        vessel["sensors"] = {"imu": {"rotation": rotation}}
    vpath = tmp_path / f"vessel_{tag}.yaml"
    vpath.write_text(yaml.safe_dump(vessel))
    rpath = tmp_path / f"{tag}.yaml"
    rpath.write_text(yaml.safe_dump({"name": tag, "run_dir": str(tmp_path / tag), "vessel": str(vpath),
                                     "hindcast": {"path": str(HINDCAST)}, "logs": [{"path": str(log_path)}]}))
    run = Run(rpath)
    model = types.SimpleNamespace(spec=load_vessel(vpath)[0])
    logs = ingest_stage.read_logs(run)
    from seatune.pipeline.motions import build_motions as assemble

    motions, report = assemble(logs, rate_hz=10.0, max_gap_s=2.0, frame="FLU", mounting=ingest_stage.imu_mounting(
        run, model)[0], sensor="imu")
    return motions, report


COLUMNS = ["roll", "pitch", "heading_deg", "roll_rate", "pitch_rate", "yaw_rate", "imu_fx", "imu_fy", "imu_fz"]


def test_a_rotated_imu_with_its_rotation_gives_the_upright_motions(tmp_path):
    t, att, w, f = body_motion()
    upright = write_mcap(tmp_path / "upright.mcap", [Stream("/imu/data", "sensor_msgs/msg/Imu", "imu_link",
                                                            imu_table(t, att, w, f))])
    ref, ref_report = ingest_motions(tmp_path, upright, tag="upright")
    assert not ref_report.notes and not [w for w in ref_report.warnings if "gravity" in w]
    truth = att.as_euler("ZYX")
    np.testing.assert_allclose(ref["roll"], truth[:, 2], atol=1e-12)  # the upright log is right to begin with

    cases = {  # YAML form → sensor → body rotation (scipy)
        "rpy": ({"roll_deg": 90.0, "pitch_deg": 0.0, "yaw_deg": 180.0},
                Rotation.from_euler("ZYX", [180.0, 0.0, 90.0], degrees=True)),
        "quaternion": (None, Rotation.from_rotvec([0.3, -1.2, 0.7])),
    }
    for form, (rpy, mount) in cases.items():
        rotation = rpy if rpy is not None else [float(c) for c in mount.as_quat()]
        rotated = write_mcap(tmp_path / f"{form}.mcap", [Stream("/imu/data", "sensor_msgs/msg/Imu", "imu_link",
                                                                imu_table(t, att, w, f, mount))])
        raw, raw_report = ingest_motions(tmp_path, rotated, tag=f"{form}_raw")
        assert any("gravity along" in w and "sensors.imu.rotation" in w for w in raw_report.warnings)
        assert np.abs(raw[["roll", "pitch"]] - ref[["roll", "pitch"]]).max().max() > 0.4  # without it: wrong
        got, report = ingest_motions(tmp_path, rotated, rotation=rotation, tag=form)
        for c in COLUMNS:
            np.testing.assert_allclose(got[c], ref[c], rtol=0, atol=1e-9, err_msg=f"{form} {c}")
        assert any("from vessel YAML sensors.imu.rotation" in n for n in report.notes)
        assert not [w for w in report.warnings if "gravity" in w]


def test_tf_static_gives_the_mounting_and_the_yaml_wins(tmp_path):
    t, att, w, f = body_motion()
    mount = Rotation.from_euler("ZYX", [0.0, -90.0, 0.0], degrees=True)  # x of the IMU pointing up
    upright = write_mcap(tmp_path / "upright.mcap", [Stream("/imu/data", "sensor_msgs/msg/Imu", "imu_link",
                                                            imu_table(t, att, w, f))])
    ref, _ = ingest_motions(tmp_path, upright, tag="upright")
    bag = ros1_bag_with_tf_static(tmp_path / "tf.bag", imu_table(t, att, w, f, mount), mount)
    transforms = read_log(bag).static_transforms
    assert {(s.parent, s.child) for s in transforms} == {("base_link", "mount_plate"), ("mount_plate", "imu_link")}
    got, report = ingest_motions(tmp_path, bag, tag="tf")
    for c in COLUMNS:
        np.testing.assert_allclose(got[c], ref[c], rtol=0, atol=1e-9, err_msg=c)
    assert any("from /tf_static base_link → mount_plate → imu_link" in n for n in report.notes)
    wrong = {"roll_deg": 0.0, "pitch_deg": 0.0, "yaw_deg": 0.0}  # the YAML wins, and says over what
    got, report = ingest_motions(tmp_path, bag, rotation=wrong, tag="yaml")
    assert any("vessel YAML sensors.imu.rotation (wins over /tf_static" in n for n in report.notes)
    assert np.abs(got["pitch"] - ref["pitch"]).max() > 1.0


def test_stamps_in_the_future_are_one_line(tmp_path):
    t, att, w, f = body_motion(n=50)
    table = imu_table(t, att, w, f)
    table["time"] = table["time"] + pd.Timedelta(days=3650)  # a clock ten years ahead
    log = write_mcap(tmp_path / "future.mcap", [Stream("/imu/data", "sensor_msgs/msg/Imu", "imu_link", table)])
    with pytest.raises(UserError, match=r"future\.mcap: topic /imu/data: stamps from 2036-03-1.* are in the future"):
        build_motions([read_log(log)])

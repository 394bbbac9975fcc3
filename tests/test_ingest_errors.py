"""The malformed-input corpus: each exits 2 with one line naming the file, and leaves no partial artefact
(an earlier good artefact in the same run directory stays as it was)."""

import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
import xarray as xr
import yaml

from tests.conftest import ROOT

SAMPLE = ROOT / "sample_logs"


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "seatune", *map(str, args)], capture_output=True, text=True)


def run_yaml(tmp_path, logs, hindcast=None, run_dir="run"):
    data = {"name": "t", "run_dir": str(tmp_path / run_dir), "vessel": str(ROOT / "configs/vessels/sample_osv.yaml"),
            "logs": logs, "hindcast": {"path": str(hindcast or SAMPLE / "sample_trial_era5.nc")}}
    path = tmp_path / "run.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


GOOD_LOGS = [{"path": str(SAMPLE / "sample_trial.mcap")},
             {"path": str(SAMPLE / "sample_trial_gnss.csv"), "kind": "gnss",
              "columns": {"vel_east": "vx", "vel_north": "vy"}}]


def imu_csv(path, n=600, bad=None):
    t = pd.Timestamp("2026-03-14T07:00:00Z") + pd.to_timedelta(np.arange(n) * 0.1, unit="s")
    df = pd.DataFrame({"time": t.strftime("%Y-%m-%dT%H:%M:%S.%fZ"), "qx": 0.0, "qy": 0.0, "qz": 0.0, "qw": 1.0,
                       "wx": 0.0, "wy": 0.0, "wz": 0.0, "ax": 0.0, "ay": 0.0, "az": 9.81})
    if bad is not None:
        bad(df)
    df.to_csv(path, index=False)
    return path


def bag_without_imu(path):
    from seatune.simulate.log_writers import Stream, write_ros1_bag

    t = pd.Timestamp("2026-03-14T07:00:00Z") + pd.to_timedelta(np.arange(100), unit="s")
    fix = pd.DataFrame({"time": t, "latitude": 61.2, "longitude": 3.4, "altitude": 0.0})
    return write_ros1_bag(path, [Stream("/gnss/fix", "sensor_msgs/msg/NavSatFix", "gnss", fix)])


def wrong_netcdf(path):
    xr.Dataset({"waveheight": (("time",), [1.0, 2.0])},
               coords={"time": pd.date_range("2026-03-14", periods=2, freq="h")}).to_netcdf(path)
    return path


def hindcast_elsewhere_in_time(path):
    df = pd.read_csv(SAMPLE / "sample_trial_hindcast.csv")
    df["time"] = (pd.to_datetime(df["time"]) + pd.Timedelta(days=2)).dt.strftime("%Y-%m-%dT%H:%M:%SZ")
    df.to_csv(path, index=False)
    return path


def write_bytes(path, data):
    path.write_bytes(data)
    return path


CASES = {
    "empty file": (lambda p: write_bytes(p / "empty.mcap", b""), None, "empty"),
    "nothing readable": (lambda p: write_bytes(p / "noise.bin", np.random.default_rng(1).bytes(4096)), None,
                         "noise.bin"),
    "text in a numeric column": (lambda p: imu_csv(p / "imu.csv", bad=lambda d: d.__setitem__("wx", "twelve")),
                                 None, "wx"),
    "bag without an IMU topic": (lambda p: bag_without_imu(p / "gnss.bag"), None, "Imu"),
    "all-NaN channel": (lambda p: imu_csv(p / "imu.csv", bad=lambda d: d.__setitem__("az", np.nan)), None, "az"),
    "hindcast not covering the track": (None, hindcast_elsewhere_in_time, "before"),
    "wrong variable names": (None, wrong_netcdf, "waveheight"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_malformed_input_exits_2_and_keeps_earlier_artefacts(tmp_path, case):
    make_log, make_hindcast, needle = CASES[case]
    good = run_yaml(tmp_path, GOOD_LOGS)
    assert run_cli("ingest", good).returncode == 0
    before = {p.name: p.read_bytes() for p in (tmp_path / "run").iterdir()}
    logs = GOOD_LOGS if make_log is None else [{"path": str(make_log(tmp_path))}]
    suffix = ".csv" if case == "hindcast not covering the track" else ".nc"
    hindcast = None if make_hindcast is None else make_hindcast(tmp_path / f"hindcast{suffix}")
    bad = run_yaml(tmp_path, logs, hindcast)
    res = run_cli("ingest", bad)
    assert res.returncode == 2, (res.stdout, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and needle.lower() in lines[0].lower(), res.stderr
    after = {p.name: p.read_bytes() for p in (tmp_path / "run").iterdir()}
    assert after == before  # nothing lost, nothing half-written


def test_non_monotonic_time_is_repaired_and_counted(tmp_path):
    def shuffle(d):
        d.loc[[100, 101], "time"] = d.loc[[101, 100], "time"].to_numpy()
        d.loc[200, "time"] = d.loc[199, "time"]

    csv = imu_csv(tmp_path / "imu.csv", n=3000, bad=shuffle)
    gnss = tmp_path / "gnss.csv"
    shutil.copy(SAMPLE / "sample_trial_gnss.csv", gnss)
    path = run_yaml(tmp_path, [{"path": str(csv), "kind": "imu"},
                               {"path": str(gnss), "kind": "gnss", "columns": {"vel_east": "vx", "vel_north": "vy"}}])
    res = run_cli("ingest", path)
    assert res.returncode == 0, res.stderr
    assert "non monotonic repaired 2" in res.stdout or "non monotonic repaired 1" in res.stdout
    assert "duplicates removed 1" in res.stdout


# ------------------------------------------------------------------------------------------- issue 19


def imu_and_odometry_bag(path):
    """A ROS1 bag written with rosbags: an upright IMU and wheel odometry, no GNSS (a robot's bag)."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC)
    T = ts.types
    vec, quat = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    t0 = int(pd.Timestamp("2026-03-14T07:00:00Z").value)
    with Writer(path) as writer:
        imu_c = writer.add_connection("/imu/data", "sensor_msgs/msg/Imu", typestore=ts)
        odom_c = writer.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
        for i in range(200):
            ns = t0 + i * 100_000_000
            head = T["std_msgs/msg/Header"](seq=i, stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9,
                                                                                       nanosec=ns % 10**9),
                                            frame_id="base_link")
            imu = T["sensor_msgs/msg/Imu"](header=head, orientation=quat(x=0.0, y=0.01 * np.sin(i / 9), z=0.0,
                                                                         w=np.sqrt(1 - (0.01 * np.sin(i / 9)) ** 2)),
                                           orientation_covariance=np.zeros(9),
                                           angular_velocity=vec(x=0.01, y=0.0, z=0.0),
                                           angular_velocity_covariance=np.zeros(9),
                                           linear_acceleration=vec(x=0.0, y=0.0, z=9.81),
                                           linear_acceleration_covariance=np.zeros(9))
            writer.write(imu_c, ns, ts.serialize_ros1(imu, "sensor_msgs/msg/Imu"))
            pose = T["geometry_msgs/msg/PoseWithCovariance"](
                pose=T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=0.1 * i, y=0.0, z=0.0),
                                                 orientation=quat(x=0.0, y=0.0, z=0.0, w=1.0)),
                covariance=np.zeros(36))
            twist = T["geometry_msgs/msg/TwistWithCovariance"](twist=T["geometry_msgs/msg/Twist"](
                linear=vec(x=1.0, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0)), covariance=np.zeros(36))
            odom = T["nav_msgs/msg/Odometry"](header=T["std_msgs/msg/Header"](seq=i, stamp=head.stamp, frame_id="odom"),
                                              child_frame_id="base_link", pose=pose, twist=twist)
            writer.write(odom_c, ns, ts.serialize_ros1(odom, "nav_msgs/msg/Odometry"))
    return path


CORPUS = ROOT / "tests" / "data" / "third_party"
CLEAN_FAILURES = {  # case → (logs, topics, words the one line must hold)
    "odometry without GNSS": (lambda p: [{"path": str(imu_and_odometry_bag(p / "robot.bag"))}], None,
                              ["robot.bag", "no position", "/odom (nav_msgs/msg/Odometry) give velocity only"]),
    "stamps in 1970": (lambda p: [{"path": str(CORPUS / "robot_localization_test2.bag")}], None,
                       ["robot_localization_test2.bag", "topic /imu/data", "1970-01-01T00:01:07.58", "before 1990"]),
    "wrong IMU topic": (lambda p: GOOD_LOGS, {"imu": "/imu/dta"},
                        ["sample_trial.mcap", "topics.imu", "topic /imu/dta not in the log(s)",
                         "/imu/data (sensor_msgs/msg/Imu)", "(sensor_msgs/msg/NavSatFix)"]),
}


@pytest.mark.parametrize("case", list(CLEAN_FAILURES))
def test_clean_failures_at_ingest_are_one_line(tmp_path, case):
    make_logs, topics, words = CLEAN_FAILURES[case]
    path = run_yaml(tmp_path, make_logs(tmp_path))
    if topics:
        data = yaml.safe_load(path.read_text())
        data["topics"] = topics
        path.write_text(yaml.safe_dump(data))
    from click.testing import CliRunner

    from seatune.cli import stages  # noqa: F401  (registers the commands)
    from seatune.cli.main import cli

    res = CliRunner().invoke(cli, ["ingest", str(path)])  # in process: the exit code and stderr of the CLI
    assert res.exit_code == 2, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.output, res.output
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not (tmp_path / "run" / "motions.parquet").exists()

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
    from seatune.io.log_writers import Stream, write_ros1_bag

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

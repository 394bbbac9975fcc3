"""Files written by `seatune simulate`, read back directly with rosbags, mcap, xarray and wavespectra
(not through seatune), and the committed sample_logs/."""


import numpy as np
import pandas as pd
import pytest
import xarray as xr
import yaml

from seatune.simulate.scenario import simulate, write_trial
from tests.conftest import ROOT
from tests.test_simulate import scenario

SAMPLE = ROOT / "sample_logs"


@pytest.fixture(scope="module")
def written(sample_model, tmp_path_factory):
    out = tmp_path_factory.mktemp("trial")
    spec = scenario(11, duration=1500.0, segments=[
        {"kind": "transit", "duration": 500, "speed": 5.0, "course_deg": 80},
        {"kind": "drift", "duration": 1000, "heading_deg": 120, "heading_rate_deg_per_h": 3.0}],
        sensors={"sample_rate_hz": 10, "imu": {"point": [12.0, 0.0, 15.0]}, "heave": {"snr": 100}},
        outputs={"mcap": ["imu", "gnss", "heave"], "ros1_bag": ["imu", "gnss"], "ros2_bag": ["imu", "gnss", "heave"],
                 "csv": ["imu", "gnss", "heave"]},
        defects={"duplicate_stamps": 2, "out_of_order": 1, "gaps": [{"at": 700, "duration": 3}]})
    trial = simulate(spec, sample_model)
    write_trial(spec, trial, out)
    return out, trial


def stamps_ns(table):
    return table["time"].astype("int64").to_numpy()


def test_rosbags_anyreader_reads_every_format(written):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    out, trial = written
    n_all = len(trial.streams)  # IMU, GNSS fix and velocity, and every point heave sensor
    formats = ((out / "stationary.mcap", n_all), (out / "stationary.bag", 3), (out / "stationary_ros2", n_all))
    for path, groups in formats:
        with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            topics = {c.topic: c for c in reader.connections}
            assert len(topics) == groups
            for topic, conn in topics.items():
                assert conn.msgcount == len(trial.streams[topic]), (path, topic)
            imu_conn = [topics["/imu/data"]]
            stamps = [reader.deserialize(raw, c.msgtype).header.stamp for c, _, raw in reader.messages(imu_conn)]
    ns = np.array([s.sec * 10**9 + s.nanosec for s in stamps])
    assert np.array_equal(np.sort(ns), np.sort(stamps_ns(trial.streams["/imu/data"])))


def test_mcap_reader_reads_topics_counts_and_stamps(written):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out, trial = written
    counts, imu_stamps = {}, []
    with open(out / "stationary.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, decoded in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "/imu/data":
                imu_stamps.append(decoded.header.stamp.sec * 10**9 + decoded.header.stamp.nanosec)
                assert decoded.header.frame_id == "imu_link"
    assert counts == {t: len(tab) for t, tab in trial.streams.items()}
    imu = trial.streams["/imu/data"]
    assert np.array_equal(np.array(imu_stamps), stamps_ns(imu.sort_values("log_time", kind="stable")))
    defects = trial.truth["defects"]
    assert len(defects["duplicate_stamps"]) == 2 and len(defects["out_of_order"]) == 1
    stamps = np.array(imu_stamps)
    assert (np.diff(stamps) == 0).sum() >= 2 and (np.diff(stamps) < 0).sum() >= 1
    gap = np.diff(np.unique(stamps)).max() / 1e9
    assert gap == pytest.approx(3.1, abs=0.11)  # 3 s outage at 10 Hz


def test_era5_file_reads_with_xarray_and_wavespectra(written):
    from wavespectra import read_era5

    out, trial = written
    ds = xr.open_dataset(out / "stationary_era5.nc")
    assert {"swh", "pp1d", "mwd", "d2fd"} <= set(ds.data_vars)
    assert ds["swh"].attrs.get("units") == "m"
    spec = read_era5(out / "stationary_era5.nc")
    hs = spec.spec.hs()
    # simulated hindcast at the track position (bilinear in space) vs the hindcast partitions
    times = trial.hindcast["time"].dt.tz_localize(None).to_numpy()
    for i, t in enumerate(times):
        k = min(np.searchsorted(trial.kin.t, (i - 1) * 3600.0), trial.kin.t.size - 1)
        at = hs.sel(time=t).interp(lat=trial.lat[k], lon=trial.lon[k] % 360)
        expected = np.sqrt(sum(p.hs**2 for p in (trial.hindcast_wind[i], trial.hindcast_swell[i]) if p is not None))
        assert float(at) == pytest.approx(expected, rel=0.02)


def test_csv_logs_match_the_streams(written):
    out, trial = written
    imu = pd.read_csv(out / "stationary_imu.csv", float_precision="round_trip")
    assert len(imu) == len(trial.streams["/imu/data"])
    assert np.array_equal(imu["wx"].to_numpy(), trial.streams["/imu/data"]["wx"].to_numpy())
    heave = pd.read_csv(out / "stationary_heave.csv")
    assert {"point_A_displacement", "point_C_acceleration"} <= set(heave.columns)
    truth = yaml.safe_load((out / "truth.yaml").read_text())
    assert [s["kind"] for s in truth["segments"]] == ["transit", "drift"]
    assert truth["loading"]["zcg"] == 6.7


def test_committed_sample_logs():
    files = {p.name: p for p in SAMPLE.iterdir()}
    assert sum(p.stat().st_size for p in files.values()) < 10 * 10**6
    assert {"sample_trial.mcap", "sample_trial_gnss.csv", "sample_trial_era5.nc", "sample_trial_hindcast.csv",
            "truth.yaml"} <= set(files)
    truth = yaml.safe_load((SAMPLE / "truth.yaml").read_text())
    span = pd.Timestamp(truth["end_time"]) - pd.Timestamp(truth["start_time"])
    assert 5.5 <= span.total_seconds() / 3600 <= 6.5
    drifts = [s for s in truth["segments"] if s["free_floating"]]
    assert len(drifts) >= 3
    assert all((pd.Timestamp(s["end"]) - pd.Timestamp(s["start"])).total_seconds() >= 1800 for s in drifts)
    assert len({round(s["heading_deg"]) for s in drifts}) == len(drifts)
    seas = {(round(s["wind_sea"]["hs"], 1), round(s["wind_sea"]["tp"], 1)) for s in truth["sea_states"]}
    assert len(seas) >= 3


def test_sample_mcap_reads_without_message_index():
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    n, g = 0, []
    with open(SAMPLE / "sample_trial.mcap", "rb") as f:
        for _, _, _, msg in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            n += 1
            if n % 500 == 0:
                a = msg.linear_acceleration
                g.append(np.sqrt(a.x**2 + a.y**2 + a.z**2))
    assert 6 * 3600 * 10 * 0.99 < n < 6 * 3600 * 10 * 1.01
    assert np.mean(g) == pytest.approx(9.81, abs=0.01)

"""Ingest of a 24 h, 10 Hz IMU MCAP (864,000 messages): read_log's messages/s against a plain loop over
mcap's reader decoding every message with mcap_ros2 (same file, same process)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd


def run() -> dict:
    from seatune.io.log_readers import benchmark_mcap
    from seatune.simulate.log_writers import Stream, write_mcap

    n = 24 * 3600 * 10
    rng = np.random.default_rng(0)
    t = pd.Timestamp("2026-03-14T00:00:00Z") + pd.to_timedelta(np.arange(n) * 0.1, unit="s")
    table = pd.DataFrame({"time": t, "qx": 0.0, "qy": 0.0, "qz": rng.normal(0, 0.01, n), "qw": 1.0})
    for c in ("wx", "wy", "wz", "ax", "ay"):
        table[c] = rng.normal(0.0, 0.01, n)
    table["az"] = 9.81 + rng.normal(0.0, 0.1, n)
    with tempfile.TemporaryDirectory() as tmp:
        path = write_mcap(Path(tmp) / "day.mcap", [Stream("/imu/data", "sensor_msgs/msg/Imu", "imu_link", table)])
        res = benchmark_mcap(path)
    return {
        "name": "ingest_mcap_24h_10hz_imu",
        "reference_s": round(res["plain_s"], 2),
        "seatune_s": round(res["seatune_s"], 2),
        "ratio": round(res["speedup"], 1),
        "max_rel_diff": 0.0 if res["identical"] else float("nan"),
        "messages": res["messages"],
        "seatune_msgs_per_s": round(res["seatune_msgs_per_s"]),
        "plain_msgs_per_s": round(res["plain_msgs_per_s"]),
        "reference": "plain loop over mcap make_reader + mcap_ros2 decoder",
    }

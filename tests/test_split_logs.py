"""A logger that splits a trial into several files: `logs: - path: <glob>` reads them in time order, whatever their
names, and says where they overlap or leave a gap. The motion table is the one a single file of the same
samples gives."""

import pandas as pd
import pytest

from seatune.io.log_readers import read_log
from seatune.simulate.log_writers import Stream, write_mcap
from tests.test_ingest_errors import SAMPLE, run_cli, run_yaml

GNSS = {"path": str(SAMPLE / "sample_trial_gnss.csv"), "kind": "gnss", "columns": {"vel_east": "vx", "vel_north": "vy"}}


def _mcap(path, table):
    return write_mcap(path, [Stream("/imu/data", "sensor_msgs/msg/Imu", "imu_link", table)], message_index=False)


def test_split_files_are_read_in_time_order_with_their_overlap_and_gap(tmp_path):
    imu = read_log(SAMPLE / "sample_trial.mcap").topics["/imu/data"].table.iloc[:24000].reset_index(drop=True)
    parts = tmp_path / "parts"
    parts.mkdir()
    # named against their order: the first hour's file sorts last
    _mcap(parts / "c_0600.mcap", imu.iloc[:8000])
    _mcap(parts / "a_0613.mcap", imu.iloc[7700:16000])  # repeats the last 30 s of the first file
    _mcap(parts / "b_0627.mcap", imu.iloc[16200:])  # starts 20 s after the second ends
    whole = tmp_path / "whole.mcap"
    _mcap(whole, pd.concat([imu.iloc[:16000], imu.iloc[16200:]]))

    for name in ("split", "whole"):
        (tmp_path / name).mkdir()
    split = run_cli("ingest", run_yaml(tmp_path / "split", [{"path": str(parts / "*.mcap")}, GNSS]))
    single = run_cli("ingest", run_yaml(tmp_path / "whole", [{"path": str(whole)}, GNSS]))
    assert split.returncode == 0, split.stderr
    assert single.returncode == 0, single.stderr

    note = next(line for line in split.stdout.splitlines() if "files read in time order" in line)
    assert "3 files read in time order (not their name order)" in note
    assert "a_0613.mcap overlaps c_0600.mcap by 29.9 s" in note  # 300 samples: stamps 29.9 s apart
    assert "20.1 s gap between a_0613.mcap and b_0627.mcap" in note  # last to first stamp
    assert "time order" not in single.stdout

    a = pd.read_parquet(tmp_path / "split" / "run" / "motions.parquet")
    b = pd.read_parquet(tmp_path / "whole" / "run" / "motions.parquet")
    pd.testing.assert_frame_equal(a, b)
    assert 195 <= a["roll"].isna().sum() <= 205  # the 20 s without IMU is masked (GNSS goes on: one record)


@pytest.mark.parametrize("order", [["x.mcap", "y.mcap"], ["y.mcap", "x.mcap"]])
def test_back_to_back_files_in_name_order_say_nothing(tmp_path, order):
    from seatune.io.run_yaml import Run
    from seatune.pipeline.ingest import in_time_order, read_logs

    imu = read_log(SAMPLE / "sample_trial.mcap").topics["/imu/data"].table.iloc[:2000].reset_index(drop=True)
    _mcap(tmp_path / order[0], imu.iloc[:1000])
    _mcap(tmp_path / order[1], imu.iloc[1000:])
    run = Run(run_yaml(tmp_path, [{"path": str(tmp_path / "*.mcap")}, GNSS]))
    logs, notes = in_time_order(run, read_logs(run))
    assert [log.path.name for log in logs[:2]] == order
    assert bool(notes) == (order != sorted(order))

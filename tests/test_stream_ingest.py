"""Flat memory: ingest resamples the logs a stretch at a time and writes motions.parquet a row group per stretch;
the stages read it a window, a row group or a fix at a time. The pieces must give the table the whole log resampled
at once gives, and the readers the rows pandas picks from the whole table."""

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from seatune.io.motion_table import MotionTable
from seatune.io.parquet import table_metadata
from tests.test_ingest_errors import SAMPLE, run_cli, run_yaml

GNSS = {"path": str(SAMPLE / "sample_trial_gnss.csv"), "kind": "gnss", "columns": {"vel_east": "vx", "vel_north": "vy"}}
CIRCULAR = {"heading_deg": 360.0, "cog_deg": 360.0, "lon": 360.0}


@pytest.fixture(scope="module")
def streamed(tmp_path_factory):
    """The sample trial ingested in 15 min pieces (24 of them over its 6 h), and its logs read back whole."""
    import seatune.pipeline.ingest as ingest_stage
    from seatune.io.run_yaml import Run
    from seatune.pipeline.vessel import open_vessel

    tmp = tmp_path_factory.mktemp("stream")
    path = run_yaml(tmp, [{"path": str(SAMPLE / "sample_trial.mcap")}, GNSS])
    run = Run(path)
    model = open_vessel(run.vessel_path)
    mp = pytest.MonkeyPatch()
    mp.setattr(ingest_stage, "CHUNK_S", 900.0)
    try:
        ingest_stage.ingest(run, model, echo=lambda *_: None, force=True)
    finally:
        mp.undo()
    return run, model


def _whole_table(run, model):
    """The motion table resampled in one piece, as ingest did before it streamed."""
    import seatune.pipeline.ingest as ingest_stage
    from seatune.physics.plausibility import Limits, gate_angles, gate_logs

    logs, _ = ingest_stage.in_time_order(run, ingest_stage.read_logs(run))
    limits = Limits(**run.spec.ingest.plausibility.model_dump())
    gated, _ = gate_logs(logs, limits)
    motions, counts, warnings = ingest_stage.build_motions(run, logs, ingest_stage.heave_column_names(model),
                                                           ingest_stage.imu_mounting(run, model))
    motions, angles = gate_angles(motions, limits)
    return motions, counts | gated | {f"implausible attitude {c}": k for c, k in angles.items()}, warnings


def test_pieces_equal_the_whole_log_resampled_at_once(streamed):
    run, model = streamed
    path = run.artefact("motions.parquet")
    assert pq.ParquetFile(path).num_row_groups == 24  # 6 h in 15 min pieces: no piece held the whole log
    got = pd.read_parquet(path)
    want, counts, warnings = _whole_table(run, model)
    assert list(got.columns) == list(want.columns) and len(got) == len(want) == 215_940
    assert (got["time"] == want["time"]).all() and (got["record"] == want["record"]).all()
    assert got["record"].nunique() == 2  # the sample's 6 s outage, split in the right piece
    for c in want.columns.drop(["time", "record"]):
        a, b = got[c].to_numpy(float), want[c].to_numpy(float)
        assert (np.isnan(a) == np.isnan(b)).all(), c
        d = np.abs(a - b)[np.isfinite(a)]
        if c in CIRCULAR:
            d = np.minimum(d, CIRCULAR[c] - d)  # 359.999… and 0.0 are the same heading
        assert d.max(initial=0.0) < 1e-9, c
    meta = table_metadata(path)
    assert meta["counts"] == counts  # repairs, masks and interpolations counted once, not per piece
    assert meta["warnings"] == warnings


def test_readers_take_the_rows_pandas_takes_from_the_whole_table(streamed):
    run, _ = streamed
    table = MotionTable(run.artefact("motions.parquet"))
    whole = pd.read_parquet(run.artefact("motions.parquet"))
    assert len(table) == len(whole)
    assert table.span() == (whole["time"].iloc[0], whole["time"].iloc[-1]) and table.period_s() == 0.1

    start, end = whole["time"].iloc[20_000], whole["time"].iloc[61_000]  # across three row groups
    rows = table.window(start, end, ["roll", "lat"], record=0)
    inside = (whole["time"] >= start) & (whole["time"] <= end) & (whole["record"] == 0)
    pd.testing.assert_frame_equal(rows, whole.loc[inside, ["time", "roll", "lat"]].reset_index(drop=True))
    pd.testing.assert_frame_equal(pd.concat(table.blocks(["time", "sog"]), ignore_index=True),
                                  whole[["time", "sog"]])
    pd.testing.assert_frame_equal(table.thinned(10, ["time", "lat"]),
                                  whole[["time", "lat"]].iloc[::10].reset_index(drop=True))

    placed = np.flatnonzero(whole["lat"].notna().to_numpy() & whole["lon"].notna().to_numpy())
    for t in (whole["time"].iloc[123_456] + pd.Timedelta("50ms"), whole["time"].iloc[0] - pd.Timedelta("1h"),
              whole["time"].iloc[-1] + pd.Timedelta("1h")):
        k = int(np.clip(whole["time"].searchsorted(t), 0, len(whole) - 1))
        assert table.row_at(t, ["time"])["time"] == whole["time"].iloc[k]
        j = placed[int(np.clip(whole["time"].iloc[placed].searchsorted(t), 0, len(placed) - 1))]
        assert table.fix_at(t) == (whole["lat"].iloc[j], whole["lon"].iloc[j])
    assert table.last_fix() == (whole["lat"].iloc[placed[-1]], whole["lon"].iloc[placed[-1]])


def test_a_stage_stopped_by_bad_input_leaves_the_old_table(tmp_path):
    """The table is written in pieces to a temporary file: an error after the first piece keeps the old one."""
    path = run_yaml(tmp_path, [{"path": str(SAMPLE / "sample_trial.mcap")}, GNSS])
    first = run_cli("ingest", path)
    assert first.returncode == 0, first.stderr
    before = (tmp_path / "run" / "motions.parquet").read_bytes()
    broken = tmp_path / "broken_era5.nc"
    broken.write_bytes((SAMPLE / "sample_trial_era5.nc").read_bytes()[:4000])  # read after the table's pieces
    path.write_text(path.read_text().replace(str(SAMPLE / "sample_trial_era5.nc"), str(broken)))
    again = run_cli("ingest", path)
    assert again.returncode == 2 and "Traceback" not in again.stderr
    assert (tmp_path / "run" / "motions.parquet").read_bytes() == before
    assert not list((tmp_path / "run").glob(".*.tmp"))  # the spool and the partial table are gone


def _reference_windows(table, settings, fs):
    """The scan as it was before it streamed: each record whole, the speed smoothed over it, runs shorter than
    the smoothing joined to the run before (the record's first to the one after), then cut into windows."""
    from seatune.pipeline.windows import _candidate, _runs, _split_slow_run

    out = []
    n = max(1, int(round(settings.sog_smoothing_s * fs)))
    for record, rec in table.groupby("record", sort=True):
        rec = rec.reset_index(drop=True)
        sog = rec["sog"].rolling(n, center=True, min_periods=1).mean().to_numpy()
        slow = sog < settings.max_sog
        runs = _runs(slow)
        for i, (a, b) in enumerate(runs):
            if b - a < n and len(runs) > 1:
                slow[a:b] = slow[runs[i - 1][0]] if i > 0 else slow[runs[1][0]]
        for a, b in _runs(slow):
            if not slow[a]:
                out.append(_candidate(rec.iloc[a:b], record, False, f"moving: speed over ground "
                                      f"{sog[a:b].mean():.1f} m/s > {settings.max_sog:g} m/s", sog[a:b]))
            else:
                _split_slow_run(rec.iloc[a:b], record, sog[a:b], None, settings, fs, out)
    return out


@pytest.mark.parametrize("seed", range(6))
def test_windows_found_a_row_group_at_a_time_equal_the_whole_table(seed):
    """Speeds flickering about the threshold (short runs absorbed), NaN speeds, record breaks: cut into pieces
    of any size, the scan gives the candidates of the table read whole."""
    from seatune.io.run_yaml import WindowSettings
    from seatune.pipeline.windows import scan_windows

    rng = np.random.default_rng(seed)
    settings = WindowSettings(min_duration_s=120, max_duration_s=400, sog_smoothing_s=6)
    n = 20_000
    t = pd.Timestamp("2026-01-01", tz="UTC") + pd.to_timedelta(np.arange(n) * 0.1, unit="s")
    sog = np.repeat(rng.choice([0.2, 0.2, 0.6, 0.49, 0.51], size=n // 400), 400) + rng.normal(0, 0.03, n)
    sog[rng.random(n) < 0.01] = np.nan
    table = pd.DataFrame({"time": t, "record": np.cumsum(rng.random(n) < 2e-4), "sog": sog,
                          "heading_deg": np.cumsum(rng.normal(0, 0.05, n)) % 360, "roll": rng.normal(0, 0.01, n)})
    whole = _reference_windows(table, settings, 10.0)
    assert len(whole) > 20 and any(c.accepted for c in whole) and any("moving" in c.reason for c in whole)
    for size in (37, 701, 5000, n):
        pieces = scan_windows([table.iloc[i:i + size] for i in range(0, n, size)], None, settings, 10.0)
        assert [(c.start, c.end, c.record, c.accepted, c.reason) for c in pieces] == \
               [(c.start, c.end, c.record, c.accepted, c.reason) for c in whole]
        np.testing.assert_allclose([c.sog for c in pieces], [c.sog for c in whole], rtol=1e-12)
        np.testing.assert_allclose([c.heading_deg for c in pieces], [c.heading_deg for c in whole], rtol=1e-12)

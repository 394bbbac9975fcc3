"""ingest → windows → filter on the committed sample_logs/, through the CLI, against truth.yaml."""

import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml

from seatune.io.parquet import table_metadata
from tests.conftest import ROOT

SAMPLE = ROOT / "sample_logs"


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "seatune", *map(str, args)], capture_output=True, text=True)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("run")
    data = yaml.safe_load((ROOT / "configs/runs/sample.yaml").read_text())
    data["run_dir"] = str(tmp / "run")
    data["vessel"] = str(ROOT / "configs/vessels/sample_osv.yaml")
    for log in data["logs"]:
        log["path"] = str(SAMPLE / log["path"].split("/")[-1])
    data["hindcast"]["path"] = str(SAMPLE / data["hindcast"]["path"].split("/")[-1])
    # identify given the sample's hindcast, which is its simulator's own sea: the sea estimated from the motions
    # (tested in test_sea_estimation and on the trial bank) adds a 15 s system for low-frequency heave/pitch energy
    # the sample's linear model lacks, at the roll resonance, and moves roll ω_n by 4 % here (issue 16, open)
    data["sea"] = {"estimate": False}
    path = tmp / "run.yaml"
    path.write_text(yaml.safe_dump(data))
    res = run_cli("filter", path)
    assert res.returncode == 0, res.stderr
    return tmp / "run", path, res.stdout


def intervals(rows):
    return [(pd.Timestamp(r["start"]), pd.Timestamp(r["end"])) for r in rows]


def overlap(a, b):
    return max(pd.Timedelta(0), min(a[1], b[1]) - max(a[0], b[0])).total_seconds()


def test_accepted_windows_match_truth_free_floating_segments(run_dir):
    out, _, stdout = run_dir
    windows = pd.read_parquet(out / "windows.parquet")
    truth = yaml.safe_load((SAMPLE / "truth.yaml").read_text())
    drifts = intervals([s for s in truth["segments"] if s["free_floating"]])
    accepted = intervals(windows[windows.accepted].to_dict("records"))
    for seg in drifts:
        inter = sum(overlap(seg, w) for w in accepted)
        near = [w for w in accepted if overlap(seg, w) > 0]
        union_span = (max([seg[1]] + [w[1] for w in near]) - min([seg[0]] + [w[0] for w in near])).total_seconds()
        assert inter / union_span >= 0.9, (seg, near)
    transits = intervals([s for s in truth["segments"] if not s["free_floating"]])
    rejected = windows[~windows.accepted]
    for seg in transits:
        mid = seg[0] + (seg[1] - seg[0]) / 2
        row = rejected[(rejected.start <= mid) & (rejected.end >= mid)]
        assert len(row) == 1 and row.reason.iloc[0].startswith("moving: speed over ground"), (seg, row)
    assert "windows: 3 of" in stdout or "windows: 4 of" in stdout or "windows: 5 of" in stdout


def test_motion_table_and_repairs(run_dir):
    out, _, _ = run_dir
    meta = pq.read_schema(out / "motions.parquet")
    units = {f.name: f.metadata[b"unit"].decode() for f in meta}
    assert units["roll"] == "rad" and units["imu_fz"] == "m/s^2" and units["heading_deg"] == "deg"
    m = pd.read_parquet(out / "motions.parquet")
    assert np.all(np.diff(m["time"].astype("int64")) > 0)
    assert m["record"].nunique() >= 2  # the 6 s logger outage splits the record (max_gap_s 2)
    truth = yaml.safe_load((SAMPLE / "truth.yaml").read_text())
    counts = table_metadata(out / "motions.parquet")["counts"]  # what the simulator broke, ingest repaired
    assert counts["duplicates_removed"] == len(truth["defects"]["duplicate_stamps"])
    assert counts["non_monotonic_repaired"] == len(truth["defects"]["out_of_order"])
    assert counts["gaps_split"] == len(truth["defects"]["gaps"])
    assert m["imu_fz"].mean() == pytest.approx(9.81, abs=0.02)
    assert abs(np.degrees(m["roll"]).mean()) < 0.5
    drift = truth["segments"][1]
    inside = m[(m.time > pd.Timestamp(drift["start"])) & (m.time < pd.Timestamp(drift["end"]))]
    heading = np.degrees(np.angle(np.exp(1j * np.radians(inside["heading_deg"])).mean())) % 360
    assert heading == pytest.approx(drift["heading_deg"] + 2.0, abs=3.0)  # 4°/h drift over the window


def test_window_stats_and_spectra(run_dir):
    out, _, _ = run_dir
    stats = pd.read_parquet(out / "window_stats.parquet")
    assert {"roll", "pitch", "imu_fz"} <= set(stats.channel)
    assert stats.cutoff_hz.between(0.1, 0.9).all()
    spectra = pd.read_parquet(out / "window_spectra.parquet")
    assert spectra.groupby(["window_id", "channel"]).size().min() > 50


def test_rerun_skips_fresh_stages(run_dir):
    _, path, _ = run_dir
    res = run_cli("filter", path)
    assert res.returncode == 0
    assert res.stdout.count("up to date") == 3
    res = run_cli("windows", path, "--force", "windows")
    assert "windows: up to date" not in res.stdout


def test_truncated_mcap_is_read_up_to_the_cut(tmp_path, run_dir):
    from seatune.simulate.log_writers import truncate

    _, path, _ = run_dir
    cut = tmp_path / "sample_trial.mcap"
    shutil.copy(SAMPLE / "sample_trial.mcap", cut)
    truncate(cut, 0.5)
    data = yaml.safe_load(path.read_text())
    data["logs"][0]["path"] = str(cut)
    data["run_dir"] = str(tmp_path / "run")
    p = tmp_path / "run.yaml"
    p.write_text(yaml.safe_dump(data))
    res = run_cli("ingest", p)
    assert res.returncode == 0, res.stderr
    assert "cut short" in res.stdout or "cut short" in res.stderr
    m = pd.read_parquet(tmp_path / "run" / "motions.parquet")
    hours = (m.time.max() - m.time.min()).total_seconds() / 3600
    assert 2.0 < hours < 4.5


def test_identified_natural_frequencies_and_derived_parameters_against_truth(run_dir, sample_model):
    """Roll ω_n (combined over the sample's three windows) within 2 % of the truth loading's natural frequency
    (the physics core's fixed point, checked against brentq in test_physics_core); heave, whose three windows
    scatter by ±3 %, holds the truth inside its 95 % interval and within 3 %; displacement from heave within two
    of its standard deviations and r44 from roll (with the loading computer's GM, configs/runs/sample.yaml) within
    5 % of truth.yaml;
    RAO intervals hold the truth loading's effective RAO at ≥ 90 % of the energetic-band points."""
    from seatune.physics.response import natural_frequencies
    from tests.test_identify_trials import coverage

    out, path, _ = run_dir
    res = run_cli("identify", path)
    assert res.returncode == 0, res.stderr
    nat = pd.read_parquet(out / "natural_frequencies.parquet")
    best = nat[(nat.window_id == "all") & (nat.method == "admittance_peak_sdof")]
    combined = best[best.derived.isna()].set_index("dof")
    truth = yaml.safe_load((SAMPLE / "truth.yaml").read_text())
    true_loading = sample_model.loading(**{k: truth["loading"][k] for k in ("mass", "zcg", "gmt_fs", "r44", "beta44")})
    omega_true = natural_frequencies(sample_model.db, true_loading)[0]
    omega_prior = natural_frequencies(sample_model.db, sample_model.base_loading)[0]
    heave = combined.loc["Heave"]
    assert heave.ci_low <= omega_true[0] <= heave.ci_high
    assert heave.omega_n == pytest.approx(omega_true[0], rel=0.03)
    assert combined.loc["Roll", "omega_n"] == pytest.approx(omega_true[1], rel=0.02)
    assert abs(combined.loc["Roll", "omega_n"] - omega_true[1]) < 0.2 * abs(omega_prior[1] - omega_true[1])
    derived = best[best.derived.notna()]
    r44 = derived[derived.derived.str.startswith("r44")].iloc[0].derived_value
    disp = derived[derived.derived.str.startswith("displacement")].iloc[0]
    assert r44 == pytest.approx(truth["loading"]["r44"], rel=0.05)
    assert abs(disp.derived_value - truth["loading"]["mass"] / 1e3) < 2 * disp.derived_std
    raos = pd.read_parquet(out / "raos.parquet")
    assert set(raos.wave_source) - {""} == {"hindcast 2-D spectrum"}
    assert {"window", "aggregate"} == set(raos.scope)
    hits, total = coverage(sample_model, path, truth)
    assert total > 500 and hits / total >= 0.90
    units = {f.name: f.metadata[b"unit"].decode() for f in pq.read_schema(out / "raos.parquet")}
    assert units["omega"] == "rad/s" and units["beta_deg"] == "deg"

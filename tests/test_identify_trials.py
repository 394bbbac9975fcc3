"""`seatune identify` on simulated trials (written by `seatune simulate`, read back through the whole pipeline),
against the simulator's truth: RAO interval coverage, natural frequencies, derived r44, and the flag for a
hindcast that misses the swell the motions contain (de Jong's failure case)."""

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
import yaml

from tests.conftest import ROOT

SEA = {"wind_sea": {"hs": 2.2, "tp": 8.0, "dir_from_deg": 230, "spreading_param": 4},
       "swell": {"hs": 1.2, "tp": 12.5, "dir_from_deg": 270, "gamma": 5.0, "spreading_param": 25}}


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "seatune", *map(str, args)], capture_output=True, text=True)


def trial(tmp, seed: int, headings, drop_swell=False, sea=SEA, known=True, estimate_sea=False, logs=None):
    """Simulate a trial of 60-min drifts (or take the `logs` of one simulated before), write its run YAML, run
    identify; returns (run_dir, truth, run YAML)."""
    segments = [{"kind": "transit", "duration": 600, "speed": 5.0, "course_deg": 0}]
    for h in headings:
        segments += [{"kind": "drift", "duration": 3600, "heading_deg": h, "heading_rate_deg_per_h": 2.0,
                      "speed": 0.1, "course_deg": 45},
                     {"kind": "transit", "duration": 600, "speed": 5.0, "course_deg": 90}]
    hours = int(sum(s["duration"] for s in segments) / 3600) + 2
    scenario = {
        "name": f"trial_{seed}", "vessel": str(ROOT / "configs/vessels/sample_osv.yaml"), "seed": seed,
        "start_time": "2026-05-01T00:00:00Z", "start_position": [61.0, 3.5],
        "truth_loading": {"mass": 1.0e7, "zcg": 6.7, "gmt_fs": 0.30, "r44": 8.8, "beta44": 0.06},
        "transition_s": 120, "segments": segments,
        "sea_states": [{"hour": h, **sea} for h in range(hours)],
        "hindcast": {"error": {"drop_swell": drop_swell}, "spectra_2d": True},
        "sensors": {"sample_rate_hz": 10, "imu": {"point": [12.0, 0.0, 15.0]}, "gnss": {"rate_hz": 1}, "heave": None},
        "outputs": {"mcap": ["imu", "gnss"], "csv": [], "hindcast_csv": False},
        "synthesis": {"components_per_direction": 120},
    }
    tmp.mkdir(parents=True, exist_ok=True)
    if logs is None:
        (tmp / "scenario.yaml").write_text(yaml.safe_dump(scenario))
        res = run_cli("simulate", tmp / "scenario.yaml", "--out", tmp / "logs")
        assert res.returncode == 0, res.stderr
        logs = tmp / "logs"
    run = {"name": "trial", "run_dir": str(tmp / "run"), "vessel": str(ROOT / "configs/vessels/sample_osv.yaml"),
           "logs": [{"path": str(next(logs.glob("*.mcap")))}],
           "hindcast": {"path": str(next(logs.glob("*.nc")))},
           "windows": {"max_sog": 0.5, "max_heading_change_deg": 10, "min_duration_s": 1200},
           "filter": {"welch_segment_s": 256},
           # identify given the hindcast (the simulator's sea with Han's errors): with the sea estimated from the
           # same motions the measured RAO is drawn toward the prior model's (the fit assumed it), see issue 16
           "sea": {"estimate": estimate_sea}}
    truth = yaml.safe_load((logs / "truth.yaml").read_text())
    if known:
        run["identify"] = {"known": {k: truth["loading"][k] for k in ("mass", "zcg", "gmt_fs")}}
    (tmp / "run.yaml").write_text(yaml.safe_dump(run))
    res = run_cli("identify", tmp / "run.yaml")
    assert res.returncode == 0, res.stderr
    return tmp / "run", truth, tmp / "run.yaml"


def truth_loading(model, truth):
    return model.loading(**{k: truth["loading"][k] for k in ("mass", "zcg", "gmt_fs", "r44", "beta44")})


def coverage(model, run_yaml, truth) -> tuple[int, int]:
    """Energetic-band points of per-window RAOs whose interval holds the truth loading's effective RAO (same
    directional sea as the estimate; an independent evaluation of the physics core's RAOs)."""
    from seatune.io.hindcast_readers import read_hindcast
    from seatune.io.run_yaml import Run
    from seatune.pipeline import identify as ident

    run = Run(run_yaml)
    win = pd.read_parquet(run.artefact("windows.parquet"))
    raos = pd.read_parquet(run.artefact("raos.parquet"))
    mot = pd.read_parquet(run.artefact("motions.parquet"), columns=["time", "lat", "lon"])
    hc = read_hindcast(run.hindcast_path)
    loading = truth_loading(model, truth)
    hits = total = 0
    for row in win[win.accepted].itertuples():
        r = raos[(raos.scope == "window") & (raos.window_id == str(row.window_id))]
        names = list(r.channel.unique())
        om = r[r.channel == names[0]].omega.to_numpy()
        k = int(np.clip(mot.time.searchsorted(row.start + (row.end - row.start) / 2), 0, len(mot) - 1))
        wave, dirs, _ = ident.window_wave_spectrum(hc, row, mot.lat.iloc[k], mot.lon.iloc[k], om)
        h = ident.effective_model_rao(model, loading, names, om, dirs, wave, row.heading_deg)
        for j, name in enumerate(names):
            p = r[r.channel == name]
            ok = p.rao_amp.notna().to_numpy()
            hits += int(((p.ci_low.to_numpy()[ok] <= h[j][ok]) & (h[j][ok] <= p.ci_high.to_numpy()[ok])).sum())
            total += int(ok.sum())
    return hits, total


@pytest.fixture(scope="module")
def trials(tmp_path_factory):
    base = tmp_path_factory.mktemp("trials")
    return [trial(base / f"s{seed}", seed, headings) for seed, headings in ((11, (200, 300, 100)),
                                                                            (12, (250, 160, 20)))]


def test_rao_intervals_hold_the_true_rao(trials, sample_model):
    counts = [coverage(sample_model, run_yaml, truth) for _, truth, run_yaml in trials]
    hits, total = map(sum, zip(*counts, strict=True))
    assert total > 1000
    assert hits / total >= 0.90, counts


def test_heave_and_roll_natural_frequencies_and_r44(trials, sample_model):
    """Combined ω_n of roll within 2 % of the truth loading's natural frequency (the physics core's fixed point,
    checked against brentq in test_physics_core) and of heave, whose three windows scatter by ±3 %, within 3 %
    with the truth inside its 95 % interval; r44 implied by roll with the known GM within 5 %, and the
    displacement implied by heave within two of its standard deviations."""
    from seatune.physics.response import natural_frequencies

    for out, truth, _ in trials:
        nat = pd.read_parquet(out / "natural_frequencies.parquet")
        best = nat[(nat.window_id == "all") & (nat.method == "admittance_peak_sdof")]
        combined = best[best.derived.isna()].set_index("dof")
        true_omega = natural_frequencies(sample_model.db, truth_loading(sample_model, truth))[0]
        heave = combined.loc["Heave"]
        assert heave.ci_low <= true_omega[0] <= heave.ci_high
        assert heave.omega_n == pytest.approx(true_omega[0], rel=0.03)
        assert combined.loc["Roll", "omega_n"] == pytest.approx(true_omega[1], rel=0.02)
        derived = best[best.derived.notna()].set_index("dof")
        r44 = derived[derived.derived.str.startswith("r44")].iloc[0]
        assert r44.derived_value == pytest.approx(truth["loading"]["r44"], rel=0.05)
        disp = derived[derived.derived.str.startswith("displacement")].iloc[0]
        assert abs(disp.derived_value - truth["loading"]["mass"] / 1e3) < 2 * disp.derived_std
        # with the loading prior (mass, zcg, GM known; r44, xcg, r55 from the vessel's priors): every mode's
        # interval holds the truth, and heave, fixed by the known mass, lands within 1 % (seen: 0.35 %; the
        # measurement alone 2.2–2.8 % off)
        post = nat[(nat.method == "posterior") & nat.derived.isna()].set_index("dof")
        for d, w in zip(("Heave", "Roll", "Pitch"), true_omega, strict=True):
            assert post.loc[d, "ci_low"] <= w <= post.loc[d, "ci_high"], d
        assert post.loc["Heave", "omega_n"] == pytest.approx(true_omega[0], rel=0.01)


def test_hindcast_missing_the_swell_is_flagged_and_left_out(tmp_path):
    """The same trial twice: with the swell in the hindcast no window is flagged; without it every window is
    low-confidence with the reason, and no aggregate row uses it."""
    long_swell = {**SEA, "wind_sea": {**SEA["wind_sea"], "hs": 1.0, "tp": 6.0},
                  "swell": {**SEA["swell"], "hs": 1.8, "tp": 14.0}}
    out, _, _ = trial(tmp_path / "dropped", 21, (260, 90), drop_swell=True, sea=long_swell, known=False)
    raos = pd.read_parquet(out / "raos.parquet")
    per_window = raos[(raos.scope == "window") & (raos.channel == "roll")]
    assert per_window.window_id.nunique() >= 2
    assert per_window.low_confidence.all()
    assert per_window.reason.str.contains("misses low-frequency energy").all()
    assert not (raos.scope == "aggregate").any()
    out, _, _ = trial(tmp_path / "kept", 21, (260, 90), drop_swell=False, sea=long_swell, known=False)
    raos = pd.read_parquet(out / "raos.parquet")
    assert not raos[raos.scope == "window"].low_confidence.any()
    assert (raos.scope == "aggregate").any()
    # the sea estimated from the motions finds the dropped 14 s swell: no window is flagged any more
    out, _, _ = trial(tmp_path / "estimated", 21, (260, 90), drop_swell=True, sea=long_swell, known=False,
                      estimate_sea=True, logs=tmp_path / "dropped" / "logs")
    from seatune.pipeline.sea import system_table

    systems = system_table(pd.read_parquet(out / "sea_states.parquet"))
    swell = systems[(systems.tp - 14.0).abs() < 2.0]
    assert swell.window_id.nunique() == systems.window_id.nunique() and not swell.in_hindcast.any()
    found = swell.loc[swell.groupby("window_id").hs.idxmax()]  # each window's strongest 14 s system
    assert ((found.hs / 1.8 - 1).abs() < 0.25).all(), swell
    assert ((found.dir_from_deg - 270.0 + 180.0) % 360.0 - 180.0).abs().max() < 15.0, swell
    # the horizontal channels may add a weaker crossing system at that period (seen: 0.71 m from 180° beside the
    # 1.78 m swell in one window): the added-system cost the README's sea-channel table reports
    assert (swell.drop(found.index).hs < 0.5 * found.set_index("window_id").hs.max()).all(), swell
    raos = pd.read_parquet(out / "raos.parquet")
    assert not raos[raos.scope == "window"].low_confidence.any()

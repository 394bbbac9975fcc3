"""`seatune predict` (Han A5 RESP / RISK, thesis eqs. 3.10–3.13): the extreme-value model against Monte Carlo
time-domain realisations, the all-headings kernel against the tuning's forward model, prior vs tuned on the
sample trial's held-out window, bad configs, and the end-to-end run on sample_logs/."""

import numpy as np
import pandas as pd
import pytest
import yaml

from seatune.physics.extremes import (
    heading_response_spectra,
    max_exceedance,
    mixture_exceedance,
    mixture_mode,
    mixture_quantile,
    moments,
    optimal_heading,
    rotation_operator,
    upcrossing_rate,
)
from tests.conftest import ROOT, copy_of_sample
from tests.test_pipeline_sample import SAMPLE, run_cli
from tests.test_tune_sample import sample_run

OMEGA = np.linspace(0.2, 2.0, 181)


def pm_velocity(omega, hs, tp):
    """Velocity spectrum ω² S_PM(ω) of a heaving point that follows the waves (PM: DNV-RP-C205 eq. 3.5.5.1)."""
    wp = 2 * np.pi / tp
    return omega**2 * 5 / 16 * hs**2 * wp**4 * omega**-5.0 * np.exp(-1.25 * (omega / wp) ** -4)


def two_peak(omega):
    """A wind sea (Tp 6 s) plus a swell (Tp 13 s) in one response spectrum: a broad, bimodal process."""
    return pm_velocity(omega, 1.5, 6.0) + 0.6 * pm_velocity(omega, 1.2, 13.0) / (omega / 0.48) ** 2


def realisations(rng, S, omega, duration, dt, count):
    """`count` Gaussian records of one period T (random phases, Rayleigh amplitudes: complex normal Fourier
    coefficients with E|c|² = 2 S Δω on ω_k = 2πk/T) by an inverse FFT; independent of seatune."""
    n = int(round(duration / dt))
    k = np.arange(n // 2 + 1)
    om = 2 * np.pi * k / duration
    s = np.interp(om, omega, S, left=0.0, right=0.0)
    var = 2 * s * (2 * np.pi / duration)  # E|c_k|²
    c = (rng.standard_normal((count, k.size)) + 1j * rng.standard_normal((count, k.size))) * np.sqrt(var / 2)
    return np.fft.irfft(c * n / 2, n=n, axis=1)  # x(t_j) = Re Σ c_k e^{iω_k t_j}


def record_maxima(x):
    """Largest value of each (periodic) record, refined by a parabola through the sample peak and its neighbours."""
    i = x.argmax(axis=1)
    rows = np.arange(x.shape[0])
    y0, y1, y2 = x[rows, i - 1], x[rows, i], x[rows, (i + 1) % x.shape[1]]
    denom = y0 - 2 * y1 + y2
    return y1 - 0.125 * (y2 - y0) ** 2 / np.where(denom < 0, denom, -1.0)


def simulate_maxima(seed, S, duration, dt, count, batch=250):
    rng = np.random.default_rng(seed)
    maxima, upcrossings = [], []
    for start in range(0, count, batch):
        x = realisations(rng, S, OMEGA, duration, dt, min(batch, count - start))
        maxima.append(record_maxima(x))
        upcrossings.append(((x[:, :-1] < 0) & (x[:, 1:] >= 0)).sum(axis=1) + ((x[:, -1] < 0) & (x[:, 0] >= 0)))
    return np.concatenate(maxima), np.concatenate(upcrossings)


@pytest.fixture(scope="module")
def monte_carlo():
    """4000 half-hour records of each of two response spectra (dt 0.1 s)."""
    out = {}
    for seed, (name, S) in enumerate({"pm": pm_velocity(OMEGA, 2.5, 9.0), "two_peak": two_peak(OMEGA)}.items()):
        out[name] = (S, *simulate_maxima(seed, S, 1800.0, 0.1, 4000))
    return out


@pytest.mark.parametrize("name", ["pm", "two_peak"])
def test_exceedance_probability_agrees_with_monte_carlo(monte_carlo, name):
    S, maxima, _ = monte_carlo[name]
    m0, m2 = moments(OMEGA, S[:, None])[:, 0]
    sigma = np.sqrt(m0)
    for level in (3.2, 3.6, 4.0):  # P from ~0.8 down to ~0.1 over 30 min
        p = float(max_exceedance(level * sigma, m0, m2, 1800.0))
        p_mc = float(np.mean(maxima > level * sigma))
        se = np.sqrt(p_mc * (1 - p_mc) / maxima.size)  # binomial sampling error of the MC estimate
        print(f"{name} x = {level}σ: AUR eq. 3.11 P = {p:.4f}, Monte Carlo {p_mc:.4f} ± {se:.4f}")
        assert abs(p - p_mc) < 3 * se + 0.005, (level, p, p_mc, se)


def test_mixture_exceedance_and_quantiles_agree_with_monte_carlo(monte_carlo):
    """eq. 3.12: a 30/70 mixture of the two processes, as if the posterior held two loading conditions."""
    weights = np.array([0.3, 0.7])
    spectra = np.stack([monte_carlo["pm"][0], monte_carlo["two_peak"][0]], axis=1)
    m0, m2 = moments(OMEGA, spectra)
    rng = np.random.default_rng(7)
    pick = rng.random(4000) < weights[0]
    maxima = np.where(pick, monte_carlo["pm"][1], monte_carlo["two_peak"][1])
    limit = float(np.sqrt(m0.mean()) * 3.5)
    p = float(mixture_exceedance(limit, m0, m2, 1800.0, weights))
    p_mc = float(np.mean(maxima > limit))
    se = np.sqrt(p_mc * (1 - p_mc) / maxima.size)
    assert abs(p - p_mc) < 3 * se + 0.005, (p, p_mc, se)
    median = float(mixture_quantile(0.5, m0, m2, 1800.0, weights))
    assert abs(np.mean(maxima <= median) - 0.5) < 3 * 0.5 / np.sqrt(maxima.size) + 0.005
    # the mode: the densest bin of the Monte Carlo maxima (kernel density estimate) lies at the model's mode
    mode = float(mixture_mode(m0, m2, 1800.0, weights))
    grid = np.linspace(np.quantile(maxima, 0.05), np.quantile(maxima, 0.95), 200)
    bw = 1.06 * maxima.std() * maxima.size ** -0.2  # Silverman's rule
    kde = np.exp(-0.5 * ((grid[:, None] - maxima[None, :]) / bw) ** 2).sum(axis=1)
    assert abs(grid[kde.argmax()] - mode) < 0.1 * mode, (grid[kde.argmax()], mode)


@pytest.mark.parametrize("name", ["pm", "two_peak"])
def test_rice_rate_matches_counted_upcrossings(monte_carlo, name):
    S, _, ups = monte_carlo[name]
    m0, m2 = moments(OMEGA, S[:, None])[:, 0]
    nu = float(upcrossing_rate(m0, m2))
    rate = ups.mean() / 1800.0
    se = ups.std(ddof=1) / np.sqrt(ups.size) / 1800.0
    print(f"{name}: Rice ν0 = {nu:.5f} Hz, counted {rate:.5f} ± {se:.5f} Hz")
    assert abs(rate - nu) < 4 * se + 1e-4 * nu


def test_gauss_hermite_points_reproduce_mean_and_covariance():
    from seatune.pipeline.predict import gaussian_points

    mean = np.array([0.2, 8.9, 0.08])
    a = np.array([[0.13, -0.5, 0.0], [0.0, 0.4, 0.01], [0.0, 0.0, 0.02]])
    cov = a @ a.T
    pts, w = gaussian_points(mean, cov)
    assert pts.shape == (27, 3)
    np.testing.assert_allclose(w @ pts, mean, atol=1e-12)
    d = pts - mean
    np.testing.assert_allclose((w[:, None] * d).T @ d, cov, atol=1e-12)
    pts, w = gaussian_points(np.zeros(6), np.eye(6))  # the cubature rule above 5 parameters
    assert pts.shape == (12, 6)
    np.testing.assert_allclose((w[:, None] * pts).T @ pts, np.eye(6), atol=1e-12)


def test_all_headings_kernel_matches_the_tuning_forward_model(sample_model):
    """σ of every heading × sea-state hypothesis from the vectorised kernel = WindowStatistics (the tuning's
    forward model, its own direction-interpolation code) heading by heading."""
    from seatune.pipeline.predict import scaled_spectra, sea_state_hypotheses
    from seatune.tuning.forward import ChannelPower, WindowStatistics

    db = sample_model.db
    dirs = 7.5 + 15.0 * np.arange(24)
    rel = np.radians(dirs - 240.0)
    spread = np.where(np.cos(rel) > 0, np.cos(rel) ** 6, 0.0)
    S0 = pm_velocity(db.omega, 2.0, 9.0)[:, None] / db.omega[:, None] ** 2 * spread[None, :] / 2.0
    hs0 = 4 * np.sqrt(np.trapezoid(S0.sum(axis=1) * np.radians(15.0), db.omega))
    names = ["r44", "beta44"]
    phi = np.array([[8.4, 0.07], [9.2, 0.05]])
    power = ChannelPower(sample_model, names, ["crane_tip_vz"])
    hs_ratio, tp_ratio, offsets, _ = sea_state_hypotheses(0.1, 0.5, 9.0, 5.0)
    headings = np.array([0.0, 95.0, 200.0, 255.0])
    spectra = heading_response_spectra(power(phi)[:, :, 0, :].astype(float), scaled_spectra(db.omega, S0, hs_ratio,
                                       tp_ratio), rotation_operator(dirs, np.degrees(db.wave_direction), headings,
                                                                    offsets), np.radians(15.0))
    sigma = np.sqrt(moments(db.omega, spectra)[0])  # (n, h, p)
    for p, heading in enumerate(headings):
        model = WindowStatistics(power, ["crane_tip_vz:sigma"], S0, dirs, heading, (hs0, 9.0, 100.0), {})
        theta = np.stack([hs0 * hs_ratio, 9.0 * tp_ratio, 100.0 + offsets], axis=1)
        np.testing.assert_allclose(sigma[:, :, p], model.predict(phi, theta)[..., 0], rtol=2e-5)


def test_optimal_heading_is_the_argmin():
    p = np.array([[0.3, 0.1, 0.2, 0.1], [0.0, 0.0, 0.5, 0.2]])
    best, best_p = optimal_heading(np.array([0.0, 90.0, 180.0, 270.0]), p)
    np.testing.assert_array_equal(best, [90.0, 0.0])
    np.testing.assert_array_equal(best_p, [0.1, 0.0])


# ------------------------------------------------------------------------------------- the pipeline on sample_logs


@pytest.fixture(scope="module")
def tuned_sample(tmp_path_factory, finished_sample):
    """A copy of the finished sample run (conftest.py; the predict block from configs/runs/sample.yaml)."""
    tmp = tmp_path_factory.mktemp("predict")
    return tmp, copy_of_sample(finished_sample, tmp)


def with_predict(tmp, name, **predict):
    data = yaml.safe_load(sample_run(tmp).read_text())
    if predict.pop("drop", False):
        data.pop("predict", None)
    else:
        data["predict"] = {**data.get("predict", {}), **predict}
    path = tmp / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_predict_end_to_end_on_the_sample(tuned_sample):
    from seatune.io.parquet import column_units

    tmp, path = tuned_sample
    res = run_cli("predict", path, "--forecast", SAMPLE / "sample_trial_era5.nc")
    assert res.returncode == 0, res.stderr
    last = res.stdout.strip().splitlines()[-1]
    assert last.startswith("predict: P(max crane_tip_vz > 1.5 m/s in 3 h)") and "prediction.parquet" in last
    out = tmp / "run" / "prediction.parquet"
    t = pd.read_parquet(out)
    assert set(t.model) == {"prior", "tuned"} and t.heading_deg.nunique() == 72
    assert t.groupby(["time", "model"]).size().eq(72).all() and t.time.nunique() == 9  # every forecast step
    assert t.exceedance_probability.between(0, 1).all()
    for _, g in t.groupby(["time", "model"]):
        assert (g.optimal_probability.iloc[0] <= g.exceedance_probability + 1e-15).all()
        assert g.is_optimal.sum() == 1 and g[g.is_optimal].heading_deg.iloc[0] == g.optimal_heading_deg.iloc[0]
        assert (g.sigma > 0).all() and (g.tz > 3).all() and (g.tz < 15).all()
        assert (g.most_probable_max > 2.5 * g.sigma).all() and (g.median_max > g.most_probable_max).all()
    ok = t[(t.model == "tuned")]
    assert ((ok.optimal_probability > 0.001) & (ok.exceedance_probability.groupby(ok.time).transform("max")
                                                > 0.5)).any()  # the sample limit gives non-trivial probabilities
    units = column_units(out)
    assert units["sigma"] == "m/s" and units["heading_deg"] == "deg" and units["tz"] == "s"
    res = run_cli("predict", path, "--forecast", SAMPLE / "sample_trial_era5.nc")
    assert "predict: up to date (skipped)" in res.stdout


@pytest.mark.parametrize(("predict", "key"), [
    ({"channel": "crane_tip_vx"}, "predict.channel"),
    ({"limit": -1.0}, "predict.limit"),
    ({"headings_deg": 0}, "predict.headings_deg"),
    ({"headings_deg": [10, 400]}, "predict.headings_deg"),
    ({"duration_s": "3h"}, "predict.duration_s"),
    ({"surprise": 1}, "predict.surprise"),
    ({"drop": True}, "predict"),
])
def test_bad_predict_config_is_one_line_and_exit_2(tmp_path, predict, key):
    path = with_predict(tmp_path, "bad", **predict)
    res = run_cli("predict", path, "--forecast", SAMPLE / "sample_trial_era5.nc")
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and key in lines[0] and str(path) in lines[0], res.stderr
    assert not (tmp_path / "run").exists()  # failed before any stage ran


def test_missing_forecast_is_a_user_error(tmp_path):
    res = run_cli("predict", with_predict(tmp_path, "ok"), "--forecast", tmp_path / "nope.nc")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1 and "nope.nc" in res.stderr


def test_tuned_model_predicts_held_out_roll_maxima_better_than_prior(tuned_sample):
    """The sample trial (simulated, with a hidden truth) has one held-out window. Its logged roll — the crane tip
    is not logged, and roll is the measured channel the tuned parameters (gmt_fs, r44, β44) act on — is filtered
    as the filter stage does, cut into 5-min blocks, and the observed block maxima (of x and −x) are compared
    with the predicted distribution of the 5-min maximum at the window's time, position and heading, with the
    hindcast as the "forecast"."""
    from scipy.signal import butter, sosfiltfilt

    tmp, _ = tuned_sample
    run = tmp / "run"
    val = pd.read_parquet(run / "validation.parquet")
    wid = val[val.role == "holdout"].window_id.iloc[0]
    windows = pd.read_parquet(run / "windows.parquet")
    win = windows[windows.window_id.astype(str) == wid].iloc[0]
    stats = pd.read_parquet(run / "window_stats.parquet")
    cutoff = float(stats[(stats.window_id.astype(str) == wid) & (stats.channel == "roll")].cutoff_hz.iloc[0])
    motions = pd.read_parquet(run / "motions.parquet", columns=["time", "roll", "lat", "lon"])
    part = motions[(motions.time >= win.start) & (motions.time <= win.end)]
    roll = part.roll.interpolate().bfill().ffill().to_numpy()
    fs = 1 / part.time.diff().dt.total_seconds().median()
    roll = sosfiltfilt(butter(4, cutoff, fs=fs, output="sos"), roll - roll.mean())
    block = int(round(300 * fs))
    blocks = roll[: roll.size // block * block].reshape(-1, block)
    observed = np.concatenate([blocks.max(axis=1), (-blocks).max(axis=1)])
    limit = float(np.median(observed))
    mid = win.start + (win.end - win.start) / 2
    path = with_predict(tmp, "holdout", channel="roll", limit=limit, duration_s=300.0,
                        headings_deg=[round(float(win.heading_deg), 1) % 360], times=[mid.isoformat()],
                        position=[float(part.lat.mean()), float(part.lon.mean())])
    res = run_cli("predict", path, "--forecast", SAMPLE / "sample_trial_era5.nc", "--force")
    assert res.returncode == 0, res.stderr
    t = pd.read_parquet(run / "prediction.parquet").set_index("model")
    obs_p = float(np.mean(observed > limit))
    err = {m: abs(t.loc[m, "exceedance_probability"] - obs_p) for m in ("prior", "tuned")}
    med = {m: abs(np.log(t.loc[m, "median_max"] / limit)) for m in ("prior", "tuned")}
    print(f"held-out window {wid}: {observed.size} observed 5-min roll maxima, P(max > {limit:.4f} rad) observed "
          f"{obs_p:.2f}, prior {t.loc['prior', 'exceedance_probability']:.2f}, tuned "
          f"{t.loc['tuned', 'exceedance_probability']:.2f}; median max error prior {med['prior']:.2f}, tuned "
          f"{med['tuned']:.2f} (log ratio)")
    assert err["tuned"] < err["prior"]
    assert med["tuned"] < 0.8 * med["prior"]


def test_sample_config_has_a_predict_block():
    data = yaml.safe_load((ROOT / "configs/runs/sample.yaml").read_text())
    assert data["predict"]["channel"] == "crane_tip_vz" and data["predict"]["limit"] > 0

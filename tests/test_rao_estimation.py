"""RAO estimation: spectral ratio (long/short-crested), H1 with measured waves, aggregation, flags.

Expected values come from the synthesis itself: random-phase waves filtered through a KNOWN
second-order transfer function (exactly in the frequency domain, or by scipy.signal.lsim in the time
domain for H1), and χ² quantiles straight from scipy.stats.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps
from scipy import stats

from seatune.identification.rao_estimation import (
    RaoEstimate,
    aggregate,
    chi2_interval,
    energetic_band,
    h1_confidence,
    h1_estimator,
    quality_flags,
    rao_long_crested,
    rao_short_crested,
)
from seatune.physics.adaptive_filter import welch_spectrum

FS = 2.0  # Hz
DURATION = 3600.0  # s
SEGMENT = 300.0  # s


def bretschneider(omega, hs, tp):
    """Two-parameter PM (Bretschneider) spectrum [m²·s/rad], written out independently of seatune."""
    w = np.asarray(omega, dtype=float)
    wp = 2 * np.pi / tp
    out = np.zeros_like(w)
    pos = w > 0
    out[pos] = 5 / 16 * hs**2 * wp**4 / w[pos] ** 5 * np.exp(-1.25 * (wp / w[pos]) ** 4)
    return out


def h_second_order(omega, wn, zeta):
    """Displacement RAO of m ẍ + c ẋ + k x = k ζ in the DESIGN convention Re{X e^{−iωt}}."""
    r = np.asarray(omega) / wn
    return 1.0 / (1.0 - r**2 - 2j * zeta * r)


def random_phase_waves(spectrum, rng, fs=FS, duration=DURATION, rayleigh=True):
    """η(t) = Σ a_k cos(ω_k t + ε_k) on the record's own FFT grid ω_k = 2πk/T; returns (n, ω_k, rfft coeffs).

    ε_k uniform; a_k Rayleigh with E a_k² = 2 S(ω_k) Δω (a Gaussian sea). With deterministic a_k
    (``rayleigh=False``) the Welch average over segments tiling the record is almost deterministic
    (cross terms cancel), so a χ² interval would over-cover trivially — not a valid coverage test.
    """
    n = int(round(fs * duration))
    k = np.arange(n // 2 + 1)
    omega = 2 * np.pi * k / duration
    amp = np.sqrt(2 * spectrum(omega) * (2 * np.pi / duration))
    if rayleigh:
        amp = amp * np.sqrt(rng.exponential(1.0, k.size))  # |c|, E|c|² = 1
    amp[0] = 0.0
    amp[-1] = 0.0
    coeffs = 0.5 * n * amp * np.exp(1j * rng.uniform(0, 2 * np.pi, k.size))
    return n, omega, coeffs


def synth_response(n, omega, coeffs, transfer):
    """Wave and response records; numpy's irfft is e^{+iωt}, so the FFT-side factor is conj(H)."""
    eta = np.fft.irfft(coeffs, n)
    x = np.fft.irfft(np.conj(transfer(omega)) * coeffs, n)
    return eta, x


# --------------------------------------------------------------------------------------------- χ²


@pytest.mark.parametrize("dof", [4.0, 21.3, 60.0])
@pytest.mark.parametrize("level", [0.9, 0.95])
def test_chi2_interval_against_scipy(dof, level):
    s = np.array([0.5, 1.0, 3.0])
    low, high = chi2_interval(s, dof, level)
    a = 1 - level
    np.testing.assert_allclose(low, dof * s / stats.chi2.ppf(1 - a / 2, dof), rtol=1e-12)
    np.testing.assert_allclose(high, dof * s / stats.chi2.ppf(a / 2, dof), rtol=1e-12)
    # the tail probabilities of ν Ŝ / S at the bounds
    np.testing.assert_allclose(stats.chi2.cdf(dof * s / low, dof), 1 - a / 2, rtol=1e-9)
    np.testing.assert_allclose(stats.chi2.cdf(dof * s / high, dof), a / 2, rtol=1e-9)


def test_chi2_interval_monte_carlo_coverage():
    rng = np.random.default_rng(1)
    dof, true = 12.0, 2.5
    s_hat = true * stats.chi2.rvs(dof, size=40000, random_state=rng) / dof
    low, high = chi2_interval(s_hat, dof, 0.95)
    cover = np.mean((low <= true) & (true <= high))
    assert abs(cover - 0.95) < 0.005


def test_chi2_interval_rejects_bad_input():
    with pytest.raises(ValueError):
        chi2_interval(1.0, 0.0)
    with pytest.raises(ValueError):
        chi2_interval(1.0, 10.0, level=1.0)


# --------------------------------------------------------------------------------------------- band


def test_energetic_band_threshold():
    w = np.linspace(0.2, 3.0, 400)
    s = bretschneider(w, 2.0, 8.0)
    mask = energetic_band(w, s, 0.05)
    assert np.all(s[mask] >= 0.05 * s.max())
    assert np.all(s[~mask] < 0.05 * s.max())
    assert mask[np.argmax(s)]
    assert not energetic_band(w, np.zeros_like(w)).any()


# --------------------------------------------------------------------------------------------- long-crested


def _long_crested_coverage(seed, wn=0.9, zeta=0.15):
    rng = np.random.default_rng(seed)
    spec = lambda w: bretschneider(w, 2.0, 9.0)  # noqa: E731
    h = lambda w: h_second_order(w, wn, zeta)  # noqa: E731
    n, om, co = random_phase_waves(spec, rng)
    _, x = synth_response(n, om, co, h)
    w, s_x, dof = welch_spectrum(x, FS, segment_s=SEGMENT)
    est = rao_long_crested(w, s_x, dof, spec(w))
    true = np.abs(h(w))
    m = est.mask
    inside = (est.low[m] <= true[m]) & (true[m] <= est.high[m])
    return inside.mean(), m.sum(), est, true, dof


def test_long_crested_coverage_over_seeds():
    covers = []
    for seed in range(6):
        cover, n_band, est, true, dof = _long_crested_coverage(seed)
        assert n_band > 20
        assert np.all(np.isnan(est.amplitude[~est.mask]))
        assert 35 < dof < 50  # 23 Hann segments at 50 % overlap
        covers.append(cover)
    pooled = float(np.mean(covers))
    assert pooled >= 0.90, covers
    assert min(covers) >= 0.80, covers


def test_long_crested_amplitude_unbiased_on_average():
    ratios = []
    for seed in range(6):
        _, _, est, true, _ = _long_crested_coverage(seed)
        ratios.append(est.amplitude[est.mask] / true[est.mask])
    r = np.concatenate(ratios)
    # E|Ĥ| = |H| E√(χ²_ν/ν) ≈ |H| (1 − 1/(4ν)) — within a few per cent
    assert abs(np.median(r) - 1.0) < 0.05


# --------------------------------------------------------------------------------------------- short-crested

BETA = np.linspace(0, 2 * np.pi, 36, endpoint=False)
BETA0 = 10  # 100°


def _cos2_weights(beta0):
    d = np.cos(BETA - BETA[beta0]) ** 2
    d[np.cos(BETA - BETA[beta0]) < 0] = 0.0
    return d / d.sum()


def test_short_crested_de_jong_recovers_mean_direction_exactly():
    w = np.linspace(0.3, 2.0, 120)
    s1 = bretschneider(w, 2.0, 8.0)
    wts = _cos2_weights(BETA0)
    p = 2.0
    shape = np.abs(np.sin(BETA)) ** p  # de Jong's D(φ) = a|sin φ|^p (a arbitrary)
    f = np.abs(h_second_order(w, 0.8, 0.1))
    h_true = f[:, None] * shape[None, :]
    s_resp = s1 * np.sum(wts * h_true**2, axis=1)  # seed 002 eq. 2.8 integrated over β
    est = rao_short_crested(w, s_resp, 30.0, s1, wts, 7.3 * shape, method="de_jong")
    m = est.mask
    assert m.sum() > 30
    np.testing.assert_allclose(est.amplitude[m], h_true[m, BETA0], rtol=1e-12)
    assert np.all((est.low[m] < est.amplitude[m]) & (est.amplitude[m] < est.high[m]))
    # D ≡ 1: the spread-weighted RMS amplitude, not |H(β0)|
    rms = rao_short_crested(w, s_resp, 30.0, s1, wts)
    np.testing.assert_allclose(rms.amplitude[m], np.sqrt(np.sum(wts * h_true**2, axis=1))[m], rtol=1e-12)
    assert np.all(rms.amplitude[m] < h_true[m, BETA0])


def test_short_crested_model_shape_recovers_scale():
    w = np.linspace(0.3, 2.0, 120)
    s1 = bretschneider(w, 2.0, 8.0)
    wts = np.tile(_cos2_weights(BETA0), (w.size, 1))
    wn_beta = 0.7 + 0.2 * np.abs(np.cos(BETA))  # frequency-dependent directional shape
    h_model = np.abs(h_second_order(w[:, None], wn_beta[None, :], 0.1)) * (0.2 + np.abs(np.sin(BETA)))
    h_true = 1.3 * h_model
    s_resp = s1 * np.sum(wts * h_true**2, axis=1)
    est = rao_short_crested(w, s_resp, 30.0, s1, wts, h_model, method="model_shape")
    m = est.mask
    np.testing.assert_allclose(est.scale[m], 1.3, rtol=1e-12)
    np.testing.assert_allclose(est.amplitude[m], h_true[m, BETA0], rtol=1e-12)
    with pytest.raises(ValueError):
        rao_short_crested(w, s_resp, 30.0, s1, wts, None, method="model_shape")


def test_short_crested_stochastic_synthesis():
    """Independent random-phase wave trains per direction, each through its own RAO."""
    wts = _cos2_weights(BETA0)
    shape = np.abs(np.sin(BETA)) ** 1.5
    covers = []
    for seed in range(4):
        rng = np.random.default_rng(100 + seed)
        x = 0.0
        for k in np.flatnonzero(wts > 0):
            n, om, co = random_phase_waves(lambda w, k=k: wts[k] * bretschneider(w, 2.0, 9.0), rng)
            _, xk = synth_response(n, om, co, lambda w, k=k: shape[k] * h_second_order(w, 0.9, 0.15))
            x = x + xk
        w, s_x, dof = welch_spectrum(x, FS, segment_s=SEGMENT)
        est = rao_short_crested(w, s_x, dof, bretschneider(w, 2.0, 9.0), wts, shape, method="de_jong")
        true = shape[BETA0] * np.abs(h_second_order(w, 0.9, 0.15))
        m = est.mask
        covers.append(np.mean((est.low[m] <= true[m]) & (true[m] <= est.high[m])))
    assert np.mean(covers) >= 0.90, covers


# --------------------------------------------------------------------------------------------- H1


def _h1_records(seed, noise_std=0.0, wn=0.9, zeta=0.15, fs=4.0, duration=2400.0):
    rng = np.random.default_rng(seed)
    spec = lambda w: bretschneider(w, 2.0, 9.0)  # noqa: E731
    n, om, co = random_phase_waves(spec, rng, fs=fs, duration=duration)
    eta = np.fft.irfft(co, n)
    t = np.arange(n) / fs
    # time-domain ODE, independent of any phase convention: x'' + 2ζωn x' + ωn² x = ωn² η
    _, x, _ = sps.lsim(([wn**2], [1.0, 2 * zeta * wn, wn**2]), eta, t)
    keep = t >= 200.0  # drop the start-up transient
    x = x[keep] + noise_std * rng.standard_normal(keep.sum())
    return eta[keep], x, spec, fs


def test_h1_recovers_complex_transfer_noise_free():
    eta, x, spec, fs = _h1_records(3)
    w, h1, coh, dof = h1_estimator(x, eta, fs, 200.0)
    band = energetic_band(w, spec(w))
    h = h_second_order(w, 0.9, 0.15)
    assert band.sum() > 15
    # residual errors are the Welch resolution bias and random error at γ² ≈ 0.997 (ν ≈ 40)
    np.testing.assert_allclose(np.abs(h1[band]), np.abs(h[band]), rtol=0.05)
    np.testing.assert_allclose(np.angle(h1[band] / h[band]), 0.0, atol=0.05)
    assert np.all(np.angle(h[band]) >= 0)  # causal lag is a positive phase in Re{X e^{−iωt}}
    assert np.median(coh[band]) > 0.99 and np.min(coh[band]) > 0.95
    assert dof > 20


def test_h1_with_output_noise_lower_coherence_and_ci_coverage():
    covers, cohs = [], []
    for seed in range(4):
        eta, x, spec, fs = _h1_records(seed, noise_std=1.0)
        w, h1, coh, dof = h1_estimator(x, eta, fs, 200.0)
        band = energetic_band(w, spec(w))
        h = h_second_order(w, 0.9, 0.15)
        lo, hi, half = h1_confidence(h1, coh, dof, 0.95)
        covers.append(np.mean((lo[band] <= np.abs(h[band])) & (np.abs(h[band]) <= hi[band])))
        cohs.append(np.median(coh[band]))
        phase_err = np.abs(np.angle(h1[band] / h[band]))
        assert np.mean(phase_err <= half[band]) >= 0.8
    assert max(cohs) < 0.9
    assert np.mean(covers) >= 0.9, covers


def test_h1_confidence_shrinks_with_coherence():
    lo, hi, half = h1_confidence(np.array([1.0, 1.0]), np.array([0.99, 0.5]), 40.0)
    assert hi[0] - lo[0] < hi[1] - lo[1]
    assert half[0] < half[1]
    r = hi[1] - 1.0
    expected = np.sqrt(2 / 38 * stats.f.ppf(0.95, 2, 38) * 0.5 / 0.5)
    assert r == pytest.approx(expected)


# --------------------------------------------------------------------------------------------- aggregation


def test_aggregate_inverse_variance_and_drops_flagged():
    ests, groups, true = [], [], None
    for seed in range(6):
        _, _, est, true, _ = _long_crested_coverage(seed)
        ests.append(est)
        groups.append(("sector_090", "hs_2"))
    bad = RaoEstimate(ests[0].omega, 10 * ests[0].amplitude, ests[0].low, ests[0].high, ests[0].mask,
                      ests[0].dof, 0.95, "long_crested", None, {"low_confidence": True})
    ests.append(bad)
    groups.append(("sector_090", "hs_2"))
    table = aggregate(ests, groups)
    assert set(table["n_windows"]) == {6}
    w = table["omega"].to_numpy()
    t = np.interp(w, ests[0].omega, true)
    rel = table["amplitude"].to_numpy() / t
    assert abs(np.median(rel) - 1.0) < 0.03
    cover = np.mean((table["low"] <= t) & (t <= table["high"]))
    assert cover >= 0.8
    # single-window spread is wider than the aggregated interval
    single = (ests[0].high / ests[0].low)[ests[0].mask]
    assert np.median(table["high"] / table["low"]) < np.median(single)


# --------------------------------------------------------------------------------------------- flags


def test_missing_swell_flag():
    rng = np.random.default_rng(11)
    wind = lambda w: bretschneider(w, 1.5, 5.0)  # noqa: E731
    swell = lambda w: bretschneider(w, 1.0, 13.0)  # noqa: E731
    full = lambda w: wind(w) + swell(w)  # noqa: E731
    n, om, co = random_phase_waves(full, rng)
    _, x = synth_response(n, om, co, lambda w: h_second_order(w, 0.7, 0.2))
    w, s_x, dof = welch_spectrum(x, FS, segment_s=SEGMENT)

    hindcast_missing_swell = quality_flags(w, s_x, wind(w))
    assert hindcast_missing_swell["missing_low_frequency_energy"]
    assert hindcast_missing_swell["low_confidence"]
    complete = quality_flags(w, s_x, full(w))
    assert not complete["missing_low_frequency_energy"]
    assert complete["response_share_below_band"] < 0.1 < hindcast_missing_swell["response_share_below_band"]

    # resonance flag: ω_n outside the wind sea's energetic band
    assert quality_flags(w, s_x, wind(w), omega_n=0.45)["resonance_unexcited"]
    assert not quality_flags(w, s_x, wind(w), omega_n=1.2)["resonance_unexcited"]
    est = rao_long_crested(w, s_x, dof, wind(w), omega_n=0.7)
    assert est.low_confidence


def test_wave_log_std_matches_a_perturbed_jonswap():
    """σ of ln|H| from Hs/Tp errors equals ½|Δ ln S| of a JONSWAP actually recomputed with Tp·(1 + ε) and
    Hs·(1 + ε) (finite differences of the spectra module, not the slope formula)."""
    from seatune.identification.rao_estimation import wave_log_std
    from seatune.physics.spectra import jonswap

    omega = np.linspace(0.3, 2.0, 4000)
    hs, tp, eps = 2.5, 9.0, 1e-5
    s0 = jonswap(omega, hs, tp, 3.3)
    d_tp = (np.log(jonswap(omega, hs, tp * (1 + eps), 3.3)) - np.log(s0)) / eps
    d_hs = (np.log(jonswap(omega, hs * (1 + eps), tp, 3.3)) - np.log(s0)) / eps
    np.testing.assert_allclose(d_hs, 2.0, rtol=1e-4)
    inner = slice(5, -5)
    only_tp = wave_log_std(omega, s0, 0.0, 0.05)
    # atol: the σa|σb kink at the peak
    np.testing.assert_allclose(only_tp[inner], 0.5 * np.abs(d_tp[inner]) * 0.05, rtol=1e-3, atol=3e-4)
    only_hs = wave_log_std(omega, s0, 0.1, 0.0)
    np.testing.assert_allclose(only_hs, 0.1)

"""Tests for seatune.identification.natural_frequency.

Expected numbers come from: the digest of de Jong's thesis (/work/shared/spec/seed_002.md, its [CHECK]
recomputations), textbook SDOF results (peak frequencies), exact synthetic curves, χ² quantiles from
scipy.stats, and Monte Carlo simulation.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import optimize, stats

from seatune.identification import natural_frequency as nf

T = 1e3  # tonne → kg; de Jong's "∇ [t]" is a mass (digest §1.4)
A_WL = 1406.0  # m², digest §1.5 / Table 7.6
A33_ID = 7302 * T  # added mass "at the identified frequency" (Tables 7.6, 8.4, 8.14)
A44 = 5.55e7  # kg·m² (Tables 7.8, 8.6)


# ---------------------------------------------------------------------------------------------------------
# de Jong's worked numbers (digest §3.5, §4.2, §5)
# ---------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("omega3", "delta_t"),
    [
        (1.0167, 6376),  # case 1, Table 7.6 ([CHECK] §4.2)
        (1.0062, 6663),  # 17 Oct, Table 8.4 ([CHECK]: needs ω = 1.0062)
        (1.0011, 6805),  # 12 Nov, Table 8.14 ([CHECK]: needs ω = 1.0011)
        (0.998, 6892),  # [CHECK/INCONS] Table 8.14's tabulated ω
        (1.0145, 6434),  # [CHECK] mean of Table 8.3
    ],
)
def test_displacement_de_jong(omega3, delta_t):
    # Δ reported to 1 t, ω to 4 decimals (×4.3 sensitivity → ±1.4 t): tolerance 2 t
    m = nf.displacement_from_heave(omega3, A33_ID, A_WL)
    assert m / T == pytest.approx(delta_t, abs=2.0)


def test_displacement_buoy_frequency_out_of_range():
    # digest §5.2 [CHECK]: ω_n3 = 0.910 would imply Δ ≈ 9770 t
    assert nf.displacement_from_heave(0.910, A33_ID, A_WL) / T == pytest.approx(9770, abs=5)


def test_heave_natural_frequency_de_jong():
    # [CHECK] §5.1: Eq. 7.1 gives 1.021 for Δ = 6261 t, a33 = 7302 t; §3.5: nominal 1.025 with a33 = 7195 t
    assert nf.heave_natural_frequency(6261 * T, A33_ID, A_WL) == pytest.approx(1.021, abs=5e-4)
    assert nf.heave_natural_frequency(6261 * T, 7195 * T, A_WL) == pytest.approx(1.025, abs=5e-4)


def test_roll_natural_frequency_de_jong():
    # [CHECK] §3.5: nominal ω_n4 = 0.492 for GM 1.2, Δ 6261 t, k_xx 6.3, a44 5.55e7
    assert nf.roll_natural_frequency(6261 * T, 1.2, 6.3, A44) == pytest.approx(0.492, abs=5e-4)


@pytest.mark.parametrize(
    ("delta_t", "gm", "omega4", "kxx", "tol"),
    [
        (6261, 1.20, 0.481, 6.482, 5e-4),  # true case, digest §1.4 [CHECK]
        (6376, 1.18, 0.481, 6.43, 5e-3),  # case 1 TC1, Table 7.11
        (6663, 1.44, 0.571, 5.92, 5e-3),  # 17 Oct, Table 8.7
        (6805, 1.44, 0.512, 6.76, 5e-3),  # 12 Nov [CHECK] (thesis reports 6.80)
    ],
)
def test_r44_corrected_formula_de_jong(delta_t, gm, omega4, kxx, tol):
    assert nf.r44_from_roll(omega4, delta_t * T, gm, A44) == pytest.approx(kxx, abs=tol)


def test_printed_r44_formula_is_the_typo():
    # digest §4.2: the printed form (extra g in the denominator) gives ≈ 2.05 m; ours must not
    r = nf.r44_from_roll(0.481, 6376 * T, 1.18, A44)
    assert r / np.sqrt(nf.G) == pytest.approx(2.05, abs=0.01)
    assert r == pytest.approx(6.43, abs=5e-3)


def test_relative_sensitivity_of_displacement():
    # digest §4.2: dΔ/Δ ≈ −4.3 dω/ω
    d = nf.displacement_from_heave_u(1.0167, A33_ID, A_WL, std_omega3=0.01)
    assert d.partials["omega3"] * 1.0167 / d.value == pytest.approx(-4.3, abs=0.02)


# ---------------------------------------------------------------------------------------------------------
# Peak search
# ---------------------------------------------------------------------------------------------------------

GRID = np.arange(0.3, 1.6, 0.0325)  # de Jong's apparent grid spacing (digest §2.5)


def test_search_window_heave_de_jong():
    # §3.5: 1.03 ± 7.7 % → 0.95 – 1.11 rad/s; peaks at 0.90 (larger) and 1.00, only the second is in range
    amp = np.exp(-(((GRID - 0.90) / 0.02) ** 2)) * 3 + np.exp(-(((GRID - 1.00) / 0.05) ** 2))
    w, k = nf.peak_in_range(GRID, amp, 1.03, rel_range=0.077)
    assert k >= 0 and 0.95 <= w <= 1.11
    assert w == pytest.approx(GRID[np.argmin(abs(GRID - 1.0))])


def test_search_window_roll_rejects_peak_above_range():
    # §3.5 [INCONS]: a roll peak at 0.608 lies above 0.48·1.24 = 0.595; the strict search reports "–"
    # on de Jong's grid (… 0.543, 0.576, 0.608 …, digest §2.5) the in-range maximum 0.576 is an edge, not a peak
    grid = 0.446 + 0.0325 * np.arange(-4, 12)
    amp = nf.sdof_amplitude(grid, 0.608, 0.05, 1.0, order=1)
    w, k = nf.peak_in_range(grid, amp, 0.48, rel_range=0.24)
    assert np.isnan(w) and k == -1
    w, k = nf.peak_in_range(grid, amp, 0.48, rel_range=0.30)
    assert w == pytest.approx(0.608, abs=1e-3)


def test_peak_in_range_ignores_nan_and_empty():
    amp = np.where(GRID < 0.5, np.nan, np.exp(-(((GRID - 0.7) / 0.1) ** 2)))
    w, k = nf.peak_in_range(GRID, amp, 0.7)
    assert np.isfinite(amp[k]) and abs(w - 0.7) < 0.0325
    assert nf.peak_in_range(GRID, amp, 0.1, rel_range=0.2)[1] == -1


def test_spectrum_peak_parabolic_exact_on_parabola():
    S = 5.0 - 3.0 * (GRID - 0.517) ** 2
    pk = nf.spectrum_peak(GRID, S, (0.36, 0.62))
    assert pk.omega == pytest.approx(0.517, abs=1e-12)
    assert pk.value == pytest.approx(5.0, abs=1e-12)


def test_spectrum_peak_gaussian_exact_on_gaussian_nonuniform_grid():
    w = np.sort(np.concatenate([GRID, [0.501, 0.533]]))
    S = 2.0 * np.exp(-(((w - 0.5123) / 0.04) ** 2))
    pk = nf.spectrum_peak(w, S, (0.36, 0.62), method="gaussian")
    assert pk.omega == pytest.approx(0.5123, abs=1e-10)
    assert pk.value == pytest.approx(2.0, rel=1e-10)


def test_spectrum_peak_refines_sdof_peak():
    # roll velocity spectrum under white excitation: |H_1|² peaks exactly at ω_n (textbook)
    # ω_n swept across one grid bin; grid-only error reaches ≈ Δω/2 = 0.016 rad/s (digest §6 item 4)
    err = {"grid": [], "parabolic": [], "gaussian": []}
    for wn in np.linspace(0.48, 0.48 + 0.0325, 15):
        S = nf.sdof_amplitude(GRID, wn, 0.08, 1.0, order=1) ** 2
        for method in ("parabolic", "gaussian"):
            pk = nf.spectrum_peak(GRID, S, (0.36, 0.59), method=method)
            err[method].append(abs(pk.omega - wn))
        err["grid"].append(abs(GRID[pk.index] - wn))
    assert max(err["grid"]) > 0.014
    assert max(err["parabolic"]) < 0.25 * max(err["grid"])
    assert max(err["gaussian"]) < 0.15 * max(err["grid"])


@pytest.mark.parametrize("order", [0, 1, 2])
def test_peak_to_natural_against_numeric_maximum(order):
    wn, zeta = 1.02, 0.15
    res = optimize.minimize_scalar(
        lambda w: -nf.sdof_amplitude(w, wn, zeta, 1.0, order),
        bounds=(0.5, 1.5),
        method="bounded",
        options={"xatol": 1e-12},
    )
    assert nf.peak_to_natural(res.x, zeta, order) == pytest.approx(wn, rel=1e-7)


# ---------------------------------------------------------------------------------------------------------
# SDOF fit
# ---------------------------------------------------------------------------------------------------------

W_FIT = np.linspace(0.5, 1.5, 101)
WN, ZETA, K = 1.0, 0.05, 1.0


def test_fit_sdof_noise_free_exact():
    for order in (0, 2):
        amp = nf.sdof_amplitude(W_FIT, WN, ZETA, K, order)
        fit = nf.fit_sdof(W_FIT, amp, omega_guess=0.98, order=order)
        assert fit.omega_n == pytest.approx(WN, rel=1e-8)
        assert fit.zeta == pytest.approx(ZETA, rel=1e-6)
        assert fit.gain == pytest.approx(K, rel=1e-6)


def test_fit_sdof_coverage_additive_noise():
    """Jacobian covariance × residual variance, t-quantile: 95 % CIs cover the truth in ≥ 90 % of 200 replicas."""
    rng = np.random.default_rng(20220217)
    clean = nf.sdof_amplitude(W_FIT, WN, ZETA, K)
    sigma = 0.02 * clean.max()
    hit_w = hit_z = hit_both = 0
    for _ in range(200):
        fit = nf.fit_sdof(W_FIT, clean + sigma * rng.standard_normal(W_FIT.size))
        in_w = fit.omega_n_ci[0] <= WN <= fit.omega_n_ci[1]
        in_z = fit.zeta_ci[0] <= ZETA <= fit.zeta_ci[1]
        hit_w += in_w
        hit_z += in_z
        hit_both += in_w and in_z
    assert hit_w >= 180 and hit_z >= 180
    assert hit_both >= 170  # Bonferroni: ≥ 90 % expected for two 95 % intervals
    assert fit.residual == pytest.approx(sigma, rel=0.3)


def test_fit_sdof_coverage_chi2_amplitude_cis():
    """Amplitudes from ν-dof spectral estimates, |Ĥ|² = |H|² χ²_ν/ν, with their χ² 95 % CIs as weights."""
    rng = np.random.default_rng(7)
    nu = 40
    clean = nf.sdof_amplitude(W_FIT, WN, ZETA, K)
    q_lo, q_hi = stats.chi2.ppf([0.025, 0.975], nu)
    hit_w = hit_z = 0
    for _ in range(200):
        est = clean * np.sqrt(rng.chisquare(nu, W_FIT.size) / nu)
        lo, hi = est * np.sqrt(nu / q_hi), est * np.sqrt(nu / q_lo)
        fit = nf.fit_sdof(W_FIT, est, ci_low=lo, ci_high=hi)
        hit_w += fit.omega_n_ci[0] <= WN <= fit.omega_n_ci[1]
        hit_z += fit.zeta_ci[0] <= ZETA <= fit.zeta_ci[1]
    assert hit_w >= 180 and hit_z >= 180


def test_fit_sdof_relative_weights_and_errors():
    amp = nf.sdof_amplitude(W_FIT, WN, ZETA, K)
    fit = nf.fit_sdof(W_FIT, amp * 1.0001, weights=1 / amp)
    assert fit.omega_n == pytest.approx(WN, rel=1e-6)
    with pytest.raises(ValueError):
        nf.fit_sdof(W_FIT, amp, ci_low=amp * 0.9)
    with pytest.raises(ValueError):
        nf.fit_sdof(W_FIT[:3], amp[:3])


# ---------------------------------------------------------------------------------------------------------
# Round trips, callable added mass
# ---------------------------------------------------------------------------------------------------------


def a33_of_w(w):
    return 7302 * T * (1 + 0.15 * (w - 1.0))


def a44_of_w(w):
    return A44 * (1 - 0.2 * (w - 0.48))


def test_roundtrip_heave():
    m = np.array([5574, 6261, 6986]) * T
    w = nf.heave_natural_frequency(m, A33_ID, A_WL)
    np.testing.assert_allclose(nf.displacement_from_heave(w, A33_ID, A_WL), m, rtol=1e-12)


def test_roundtrip_heave_callable_fixed_point():
    w = nf.heave_natural_frequency(6261 * T, a33_of_w, A_WL)
    assert w**2 * (6261 * T + a33_of_w(w)) == pytest.approx(nf.RHO * nf.G * A_WL, rel=1e-12)
    assert nf.displacement_from_heave(w, a33_of_w, A_WL) == pytest.approx(6261 * T, rel=1e-10)


def test_roundtrip_roll_r44_and_gm():
    m, gm, r = 6261 * T, 1.2, np.array([5.4, 6.48, 7.2])
    w = nf.roll_natural_frequency(m, gm, r, A44)
    np.testing.assert_allclose(nf.r44_from_roll(w, m, gm, A44), r, rtol=1e-12)
    np.testing.assert_allclose(nf.gm_from_roll(w, m, r, A44), gm, rtol=1e-12)
    wc = nf.roll_natural_frequency(m, gm, 6.48, a44_of_w)
    assert nf.r44_from_roll(wc, m, gm, a44_of_w) == pytest.approx(6.48, rel=1e-10)
    assert nf.gm_from_roll(wc, m, 6.48, a44_of_w) == pytest.approx(gm, rel=1e-10)


def test_r44_impossible_raises():
    with pytest.raises(ValueError):
        nf.r44_from_roll(0.8, 6261 * T, 0.2, A44)


# ---------------------------------------------------------------------------------------------------------
# First-order propagation vs Monte Carlo (within 10 %)
# ---------------------------------------------------------------------------------------------------------

N_MC = 200_000


def _mc_std(f, means, stds, seed):
    rng = np.random.default_rng(seed)
    draws = {k: means[k] + stds[k] * rng.standard_normal(N_MC) for k in means}
    return float(np.std(f(**draws)))


def test_displacement_uncertainty_vs_monte_carlo():
    means = {"omega3": 1.0167, "a33": A33_ID, "awp": A_WL}
    stds = {"omega3": 0.005, "a33": 0.03 * A33_ID, "awp": 0.0135 * A_WL}
    d = nf.displacement_from_heave_u(**means, std_omega3=0.005, std_a33=stds["a33"], std_awp=stds["awp"])
    mc = _mc_std(nf.displacement_from_heave, means, stds, 1)
    assert d.std == pytest.approx(mc, rel=0.10)
    assert sum(d.contributions.values()) == pytest.approx(1.0)


def test_displacement_uncertainty_callable_added_mass_vs_monte_carlo():
    d = nf.displacement_from_heave_u(1.0167, a33_of_w, A_WL, std_omega3=0.01)
    rng = np.random.default_rng(2)
    mc = np.std(nf.displacement_from_heave(1.0167 + 0.01 * rng.standard_normal(N_MC), a33_of_w, A_WL))
    assert d.std == pytest.approx(mc, rel=0.10)


def test_r44_uncertainty_vs_monte_carlo():
    means = {"omega4": 0.481, "mass": 6376 * T, "gm": 1.18, "a44": A44}
    stds = {"omega4": 0.005, "mass": 0.05 * 6376 * T, "gm": 0.04, "a44": 0.029 * A44}
    d = nf.r44_from_roll_u(**means, std_omega4=0.005, std_mass=stds["mass"], std_gm=0.04, std_a44=stds["a44"])
    mc = _mc_std(nf.r44_from_roll, means, stds, 3)
    assert d.std == pytest.approx(mc, rel=0.10)


def test_gm_uncertainty_vs_monte_carlo():
    means = {"omega4": 0.481, "mass": 6376 * T, "r44": 6.43, "a44": A44}
    stds = {"omega4": 0.005, "mass": 0.05 * 6376 * T, "r44": 0.2, "a44": 0.029 * A44}
    d = nf.gm_from_roll_u(**means, std_omega4=0.005, std_mass=stds["mass"], std_r44=0.2, std_a44=stds["a44"])
    mc = _mc_std(nf.gm_from_roll, means, stds, 4)
    assert d.std == pytest.approx(mc, rel=0.10)


def test_fit_sdof_unweighted_moves_for_tiny_amplitudes():
    """An admittance in m/N is ~1e-8: the unweighted fit must still converge (tolerances are absolute)."""
    clean = nf.sdof_amplitude(W_FIT, WN, ZETA, 3e-9)
    fit = nf.fit_sdof(W_FIT, clean, omega_guess=0.9 * WN)
    assert fit.omega_n == pytest.approx(WN, rel=1e-6)


# ---------------------------------------------------------------------------------------------------------
# ω_n given the loading prior (mode_posterior)
# ---------------------------------------------------------------------------------------------------------


def _normal_draws(n: int, seed: int = 0) -> np.ndarray:
    return stats.norm.ppf(stats.qmc.Sobol(1, seed=seed).random(n)[:, 0])


def test_mode_posterior_is_the_conjugate_normal_posterior_for_a_linear_mode():
    """ω = a + bθ with θ ~ N(0, 1) and a measurement m ± s: the textbook conjugate posterior of a linear-Gaussian
    model, mean (a/b² + m/s²)/(1/b² + 1/s²), variance 1/(1/b² + 1/s²)."""
    a, b, m, s = 0.80, 0.03, 0.85, 0.02
    omega = (a + b * _normal_draws(2 ** 16))[:, None]
    post = nf.mode_posterior(omega, np.array([m]), np.array([s]), model_rel_std=0.0)
    precision = 1 / b ** 2 + 1 / s ** 2
    assert post.omega[0] == pytest.approx((a / b ** 2 + m / s ** 2) / precision, rel=2e-4)
    assert post.std[0] == pytest.approx(precision ** -0.5, rel=5e-3)
    assert post.prior_mean[0] == pytest.approx(a, rel=1e-4) and post.prior_std[0] == pytest.approx(b, rel=1e-3)


def test_mode_posterior_of_one_draw_fuses_the_model_form_error_with_the_measurement():
    """One loading (nothing uncertain): the model's ω_n ± f·ω_n and the measurement combine by inverse variance."""
    w0, f, m, s = 1.02, 0.01, 1.05, 0.02
    post = nf.mode_posterior(np.array([[w0, 0.5]]), np.array([m, np.nan]), np.array([s, np.nan]), model_rel_std=f)
    v = (f * w0) ** 2
    assert post.omega[0] == pytest.approx((w0 / v + m / s ** 2) / (1 / v + 1 / s ** 2), rel=1e-12)
    assert post.std[0] == pytest.approx((1 / v + 1 / s ** 2) ** -0.5, rel=1e-9)
    assert post.omega[1] == 0.5 and post.std[1] == pytest.approx(0.005)  # unmeasured: the model, its form error


def test_mode_posterior_moves_an_unmeasured_mode_through_the_shared_loading():
    """Two modes of one parameter, ω₁ = a + bθ and ω₂ = c + dθ, only the first measured: the second's posterior
    is c + d·E[θ | m] with E[θ | m] = (m − a)·b / (b² + s²) (conditioning a bivariate normal)."""
    a, b, c, d, m, s = 1.0, 0.02, 0.9, -0.03, 1.03, 0.01
    theta = _normal_draws(2 ** 16, seed=1)
    omega = np.stack([a + b * theta, c + d * theta], axis=1)
    post = nf.mode_posterior(omega, np.array([m, np.nan]), np.array([s, np.nan]), model_rel_std=0.0)
    assert post.omega[1] == pytest.approx(c + d * (m - a) * b / (b ** 2 + s ** 2), rel=2e-4)
    assert post.effective_draws < 2 ** 16  # the measurement weighted the draws

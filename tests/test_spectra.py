"""Tests of seatune.physics.spectra.

Every expected number comes from an analytic formula (Γ-function moments of PM, the cos-2s / cosⁿ
normalisations, hand-worked direction cases), an adaptive quadrature (scipy.integrate.quad) of the
function under test, or the independent implementation in wavespectra (MetOcean Solutions, MIT).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal
from scipy import integrate, optimize
from scipy.special import gamma as Gamma

from seatune.physics import spectra as sp

TWO_PI = 2.0 * np.pi
GRID_24 = np.deg2rad(np.arange(0.0, 360.0, 15.0))  # ERA5-like 24 × 15° direction grid


def quad_inf(fun, peak: float) -> float:
    """∫₀^∞ fun dω, split at the peak so quad resolves it."""
    a, _ = integrate.quad(fun, 0.0, peak, epsabs=0.0, epsrel=1e-12, limit=400)
    b, _ = integrate.quad(fun, peak, np.inf, epsabs=0.0, epsrel=1e-12, limit=400)
    return a + b


# --------------------------------------------------------------------------------------------------
# Pierson–Moskowitz
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("hs", "tp"), [(1.0, 5.6), (2.5, 8.0), (6.0, 14.0)])
def test_pm_m0_is_hs2_over_16(hs, tp):
    # analytic: ∫ A ω⁻⁵ exp(−Bω⁻⁴) dω = A/(4B) with A = 5/16 Hs² ωp⁴, B = 5/4 ωp⁴ → Hs²/16
    m0 = quad_inf(lambda w: sp.pierson_moskowitz(w, hs, tp).item(), TWO_PI / tp)
    assert_allclose(m0, hs**2 / 16.0, rtol=1e-10)


@pytest.mark.parametrize("gamma", [1.0, 3.3])
def test_peak_is_at_omega_p(gamma):
    tp = 9.0
    res = optimize.minimize_scalar(lambda w: -sp.jonswap(w, 2.0, tp, gamma).item(), bracket=(0.5, 0.7, 0.9), tol=1e-12)
    assert_allclose(res.x, TWO_PI / tp, rtol=1e-6)  # dS/dω = 0 at ωp analytically (both factors)


def test_pm_analytic_moments_and_tz():
    # With u = Bω⁻⁴: m_n = (A/4) B^{(n-4)/4} Γ((4-n)/4)  → m0 = A/(4B), m1 = (A/4)B^{-3/4}Γ(3/4),
    # m2 = (A/4) B^{-1/2} Γ(1/2); hence Tp/Tz = (5π/4)^{1/4} = 1.40775 and Tm01/Tz = 1.0865 (DNV-RP-C205: 1.086).
    hs, tp = 3.0, 10.0
    wp = TWO_PI / tp
    a, b = 5.0 / 16.0 * hs**2 * wp**4, 1.25 * wp**4
    m_exact = [a / 4.0 * b ** ((n - 4) / 4.0) * Gamma((4.0 - n) / 4.0) for n in (0, 1, 2)]
    assert_allclose(m_exact[0], hs**2 / 16.0, rtol=1e-14)
    for n, expected in enumerate(m_exact):
        got = quad_inf(lambda w, n=n: w**n * sp.pierson_moskowitz(w, hs, tp).item(), wp)
        assert_allclose(got, expected, rtol=1e-9)

    tz_exact = TWO_PI * math.sqrt(m_exact[0] / m_exact[2])
    assert_allclose(tp / tz_exact, (5.0 * math.pi / 4.0) ** 0.25, rtol=1e-14)
    assert_allclose(tp / tz_exact, 1.4049, rtol=3e-3)  # Han A2 quotes Tp = 1.4049 Tz (0.2 % below exact)

    # trapezoidal moments on a fine, long grid (tail of m2 beyond 80 rad/s ≈ 1e-4 relative)
    omega = np.linspace(0.05, 80.0, 200_001)
    hs_num, tz_num = sp.hs_tz_from_spectrum(omega, sp.pierson_moskowitz(omega, hs, tp))
    assert_allclose(hs_num, hs, rtol=1e-6)
    assert_allclose(tz_num, tz_exact, rtol=1e-3)


# --------------------------------------------------------------------------------------------------
# JONSWAP
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("gamma", "sigma_a", "sigma_b"), [(1.5, 0.07, 0.09), (3.3, 0.07, 0.09), (5.0, 0.07, 0.09), (7.0, 0.05, 0.12)]
)
def test_jonswap_m0_is_hs2_over_16(gamma, sigma_a, sigma_b):
    hs, tp = 2.0, 11.0
    m0 = quad_inf(lambda w: sp.jonswap(w, hs, tp, gamma, sigma_a, sigma_b).item(), TWO_PI / tp)
    assert_allclose(m0, hs**2 / 16.0, rtol=1e-9)


def test_jonswap_gamma_one_is_pm_exactly():
    omega = np.linspace(0.0, 4.0, 801)
    hs, tp = np.array([[0.5], [2.0], [7.0]]), np.array([4.0, 9.0, 16.0])
    assert_allclose(sp.jonswap(omega, hs, tp, gamma=1.0), sp.pierson_moskowitz(omega, hs, tp), rtol=1e-12, atol=0)


def test_jonswap_does_not_depend_on_the_grid():
    # the normalisation is a property of (γ, σ), not of the evaluation grid
    omega = np.linspace(0.1, 3.0, 3001)
    full = sp.jonswap(omega, 2.0, 8.0, 3.3)
    for i in (0, 700, 1500, 3000):
        assert_allclose(sp.jonswap(omega[i], 2.0, 8.0, 3.3), full[i], rtol=1e-15)
    assert_allclose(sp.jonswap(omega[::50], 2.0, 8.0, 3.3), full[::50], rtol=1e-15)


def test_broadcasting_puts_frequency_last():
    omega = np.linspace(0.2, 2.0, 50)
    hs, tp, gamma = np.array([[1.0], [2.0], [3.0]]), np.array([6.0, 8.0, 10.0, 12.0]), np.array([1.0, 2.0, 3.3, 5.0])
    out = sp.jonswap(omega, hs, tp, gamma)
    assert out.shape == (3, 4, 50)
    for i in range(3):
        for j in range(4):
            assert_allclose(out[i, j], sp.jonswap(omega, hs[i, 0], tp[j], gamma[j]), rtol=1e-15)
    assert sp.pierson_moskowitz(omega.reshape(5, 10), 1.0, [5.0, 6.0]).shape == (2, 5, 10)
    assert sp.jonswap(1.0, 2.0, 8.0).shape == ()


def test_zero_and_negative_frequencies_and_zero_hs():
    out = sp.jonswap(np.array([-1.0, 0.0, 1e-300, 1e-3]), 2.0, 8.0)
    assert_array_equal(out, 0.0)  # ω ≤ 0 → 0 by definition, tiny ω underflows to 0 without NaN
    assert_array_equal(sp.jonswap(np.linspace(0, 3, 10), 0.0, 8.0), 0.0)


def test_invalid_parameters_raise():
    with pytest.raises(ValueError, match="tp"):
        sp.jonswap(1.0, 2.0, 0.0)
    with pytest.raises(ValueError, match="hs"):
        sp.pierson_moskowitz(1.0, -1.0, 8.0)
    with pytest.raises(ValueError, match="gamma"):
        sp.jonswap(1.0, 2.0, 8.0, gamma=0.0)


# wavespectra: E(f) [m²/Hz] = α g² (2π)⁻⁴ f⁻⁵ exp(−5/4 (f/fp)⁻⁴) γ^r with σ switching at f ≤ fp. Without `hs`
# it is the unscaled Phillips form; with `hs` it rescales to 4√m0 = hs computed *on the supplied grid*
# (np.gradient df + an f⁻⁴ tail), so its normalisation depends on the grid. We therefore compare with the
# unscaled form, whose m0 we integrate independently, and S(f) = 2π S(ω = 2πf).


def _wavespectra_m0(fun, fp: float) -> float:
    """m0 [m²] of a wavespectra frequency shape: Simpson on a fine grid + analytic f⁻⁵ tail."""
    f = np.linspace(0.2 * fp, 60.0 * fp, 400_001)  # E < 1e-300 of the peak below 0.2 fp
    e = fun(f)
    return float(integrate.simpson(e, x=f) + e[-1] * f[-1] / 4.0)


def test_pm_matches_wavespectra():
    ws_freq = pytest.importorskip("wavespectra.construct.frequency")
    fp, alpha = 0.08, 0.0081
    g = 9.80665  # scipy.constants.g, as wavespectra uses
    hs = 4.0 * math.sqrt(alpha * g**2 * (TWO_PI) ** -4 / (5.0 * fp**4))  # analytic m0 = αg²(2π)⁻⁴/(4·5/4·fp⁴)
    f = np.linspace(0.03, 0.6, 300)
    ref = ws_freq.pierson_moskowitz(f, fp=fp, alpha=alpha).values
    got = TWO_PI * sp.pierson_moskowitz(TWO_PI * f, hs, 1.0 / fp)
    assert_allclose(got, ref, rtol=1e-12, atol=1e-14 * ref.max())


@pytest.mark.parametrize(
    ("fp", "gamma", "sigma_a", "sigma_b"), [(0.1, 3.3, 0.07, 0.09), (0.07, 5.0, 0.07, 0.09), (0.15, 2.0, 0.06, 0.1)]
)
def test_jonswap_matches_wavespectra(fp, gamma, sigma_a, sigma_b):
    ws_freq = pytest.importorskip("wavespectra.construct.frequency")

    def ws(f):
        return ws_freq.jonswap(f, fp=fp, gamma=gamma, sigma_a=sigma_a, sigma_b=sigma_b).values

    hs = 4.0 * math.sqrt(_wavespectra_m0(ws, fp))
    f = np.linspace(0.02, 1.0, 500)
    ref = ws(f)
    got = TWO_PI * sp.jonswap(TWO_PI * f, hs, 1.0 / fp, gamma, sigma_a, sigma_b)
    assert_allclose(got, ref, rtol=1e-9, atol=1e-12 * ref.max())  # agrees to ~3e-11


def test_jonswap_gamma_dnv_hand_values():
    # DNV-RP-C205 §3.5.5.5: φ = Tp/√Hs; γ = 5 (φ ≤ 3.6), exp(5.75 − 1.15φ) (3.6 < φ < 5), 1 (φ ≥ 5)
    hs = np.array([4.0, 4.0, 4.0, 4.0, 1.0, 0.0])
    tp = np.array([6.0, 8.0, 9.0, 16.0, 5.0, 7.0])  # φ = 3, 4, 4.5, 8, 5, ∞
    expected = [5.0, math.exp(1.15), math.exp(0.575), 1.0, 1.0, 1.0]
    assert_allclose(sp.jonswap_gamma_dnv(hs, tp), expected, rtol=1e-14)
    assert sp.jonswap_gamma_dnv([[1.0], [2.0]], [5.0, 6.0, 7.0]).shape == (2, 3)


def test_two_peak_variance_and_shape():
    wind_hs, wind_tp, swell_hs, swell_tp = 2.0, 6.0, 1.5, 14.0
    m0 = quad_inf(lambda w: sp.two_peak(w, wind_hs, wind_tp, swell_hs, swell_tp).item(), TWO_PI / swell_tp)
    assert_allclose(m0, (wind_hs**2 + swell_hs**2) / 16.0, rtol=1e-8)
    omega = np.linspace(0.1, 3.0, 100)
    out = sp.two_peak(omega, [1.0, 2.0, 3.0], 6.0, 1.0, 14.0)
    assert out.shape == (3, 100)
    i_wind, i_swell = np.argmin(abs(omega - TWO_PI / 6.0)), np.argmin(abs(omega - TWO_PI / 14.0))
    assert out[2, i_wind] > out[2, i_wind + 5] and out[2, i_swell] > out[2, i_swell + 3]  # two separate peaks


# --------------------------------------------------------------------------------------------------
# Spreading
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("s", [0.0, 1.0, 4.0, 15.5, 100.0])
def test_cos2s_integrates_to_one(s):
    total, _ = integrate.quad(lambda t: sp.spreading_cos2s(t, s).item(), -np.pi, np.pi, epsabs=0, epsrel=1e-12)
    assert_allclose(total, 1.0, rtol=1e-10)


@pytest.mark.parametrize("n", [0.0, 2.0, 3.5, 8.0, 40.0])
def test_cosn_integrates_to_one_and_vanishes_beyond_90deg(n):
    total, _ = integrate.quad(lambda t: sp.spreading_cosn(t, n).item(), -np.pi / 2, np.pi / 2, epsabs=0, epsrel=1e-12)
    assert_allclose(total, 1.0, rtol=1e-10)
    assert_array_equal(sp.spreading_cosn(np.array([1.6, -1.6, 3.0, np.pi]), n), 0.0)


def test_spreading_hand_values_and_wrapping():
    # s = 1: C = Γ(2)/(2√π Γ(3/2)) = 1/π → D = cos²(θ/2)/π; n = 2: C = Γ(2)/(√π Γ(3/2)) = 2/π → D = 2cos²θ/π
    theta = np.array([0.0, 0.5, -2.0, np.pi])
    assert_allclose(sp.spreading_cos2s(theta, 1.0), np.cos(theta / 2) ** 2 / np.pi, rtol=1e-14, atol=1e-30)
    assert_allclose(sp.spreading_cosn(theta[:2], 2.0), 2.0 * np.cos(theta[:2]) ** 2 / np.pi, rtol=1e-14)
    assert_allclose(sp.spreading_cos2s(0.3 + 4 * np.pi, 6.0), sp.spreading_cos2s(0.3, 6.0), rtol=1e-12)
    assert_allclose(sp.spreading_cosn(-0.3 - TWO_PI, 3.0), sp.spreading_cosn(-0.3, 3.0), rtol=1e-12)
    assert sp.spreading_cos2s(theta[:, None], [1.0, 2.0, 3.0]).shape == (4, 3)
    assert_allclose(sp.wrap_angle([np.pi, -np.pi, 3 * np.pi, 0.0, -0.1]), [np.pi, np.pi, np.pi, 0.0, -0.1], atol=1e-15)


def test_cos2s_with_s_equal_2n_matches_cosn_near_the_peak():
    # 2s ln cos(θ/2) = −sθ²/4 − sθ⁴/96 …, n ln cos θ = −nθ²/2 − nθ⁴/12 …: same curvature when s = 2n
    n, theta = 3.0, 0.05
    ratio_2s = sp.spreading_cos2s(theta, 2 * n) / sp.spreading_cos2s(0.0, 2 * n)
    ratio_n = sp.spreading_cosn(theta, n) / sp.spreading_cosn(0.0, n)
    assert_allclose(ratio_2s, ratio_n, rtol=1e-4)


@pytest.mark.parametrize("s", [1.0, 4.0, 20.0])
def test_cos2s_s_from_circular_spread(s):
    # circular spread σ² = 2(1 − ∫cos θ D dθ) of the continuous cos-2s, by quadrature
    m1, _ = integrate.quad(lambda t: math.cos(t) * sp.spreading_cos2s(t, s).item(), -np.pi, np.pi, epsrel=1e-12)
    assert_allclose(sp.cos2s_s_from_spread(math.sqrt(2.0 * (1.0 - m1))), s, rtol=1e-8)


@pytest.mark.parametrize(
    ("kind", "param"), [("cos2s", 1.0), ("cos2s", 15.0), ("cosn", 2.0), ("cosn", 9.0), ("long_crested", None)]
)
@pytest.mark.parametrize("n_dir", [24, 36, 7])
def test_discrete_spreading_sums_to_one(kind, param, n_dir):
    rng = np.random.default_rng(n_dir)
    grid = 0.3 + np.arange(n_dir) * TWO_PI / n_dir - np.pi  # offset grid, partly negative angles
    grid = grid[rng.permutation(n_dir)]  # any order
    means = rng.uniform(-10.0, 10.0, size=5)
    d = sp.discrete_spreading(grid, means, kind, param)
    assert d.shape == (5, n_dir)
    assert_allclose(d.sum(axis=-1) * TWO_PI / n_dir, 1.0, rtol=1e-14)
    assert np.all(d >= 0)


def test_discrete_cos2s_matches_wavespectra_cartwright():
    ws_dir = pytest.importorskip("wavespectra.construct.direction")
    dirs_deg, dm, dspr = np.arange(0.0, 360.0, 15.0), 37.0, 25.0
    ref = ws_dir.cartwright(dirs_deg, dm, dspr).values * (180.0 / np.pi)  # [1/deg] → [1/rad]
    s = 2.0 / np.deg2rad(dspr) ** 2 - 1.0  # wavespectra's own s(dspr)
    got = sp.discrete_spreading(np.deg2rad(dirs_deg), np.deg2rad(dm), "cos2s", s)
    assert_allclose(got, ref, rtol=1e-12)


def test_discrete_spreading_approaches_continuous_on_a_fine_grid():
    grid = np.linspace(0.0, TWO_PI, 720, endpoint=False)
    theta = sp.wrap_angle(grid - 1.0)
    assert_allclose(sp.discrete_spreading(grid, 1.0, "cos2s", 8.0), sp.spreading_cos2s(theta, 8.0), rtol=1e-10)
    # cosⁿ has a kink at ±90°, so the rectangle rule is only O(Δβ²) accurate
    assert_allclose(sp.discrete_spreading(grid, 1.0, "cosn", 2.0), sp.spreading_cosn(theta, 2.0), rtol=2e-5, atol=1e-9)


def test_discrete_spreading_very_narrow_degrades_to_long_crested():
    d = sp.discrete_spreading(GRID_24, np.deg2rad(31.0), "cos2s", 1e7)
    assert np.all(np.isfinite(d))
    assert_allclose(d, sp.discrete_spreading(GRID_24, np.deg2rad(31.0), "long_crested"), atol=1e-12)


def test_long_crested_nearest_and_interpolated():
    dbeta = np.deg2rad(15.0)
    d = sp.discrete_spreading(GRID_24, np.deg2rad(20.0), "long_crested")
    expected = np.zeros(24)
    expected[1] = 1.0 / dbeta  # 20° is nearest to 15°
    assert_allclose(d, expected, rtol=1e-14)

    d = sp.discrete_spreading(GRID_24, np.deg2rad(20.0), "long_crested", interpolate=True)
    expected = np.zeros(24)
    expected[[1, 2]] = [2.0 / 3.0 / dbeta, 1.0 / 3.0 / dbeta]  # 20° = 15° + 1/3 · 15°
    assert_allclose(d, expected, rtol=1e-12, atol=1e-12)

    d = sp.discrete_spreading(GRID_24, np.deg2rad(-5.0), "long_crested", interpolate=True)  # 355°: wrap-around
    expected = np.zeros(24)
    expected[[23, 0]] = [1.0 / 3.0 / dbeta, 2.0 / 3.0 / dbeta]
    assert_allclose(d, expected, rtol=1e-12, atol=1e-12)

    d = sp.discrete_spreading(GRID_24, np.deg2rad(359.0), "long_crested")
    assert np.argmax(d) == 0


def test_discrete_spreading_rejects_bad_input():
    with pytest.raises(ValueError, match="equally spaced"):
        sp.discrete_spreading(np.deg2rad([0.0, 10.0, 30.0]), 0.0)
    with pytest.raises(ValueError, match="equally spaced"):
        sp.discrete_spreading(np.deg2rad(np.arange(0.0, 180.0, 15.0)), 0.0)  # half circle only
    with pytest.raises(ValueError, match="kind"):
        sp.discrete_spreading(GRID_24, 0.0, "cos4")
    with pytest.raises(ValueError, match="no parameter"):
        sp.discrete_spreading(GRID_24, 0.0, "long_crested", 3.0)


# --------------------------------------------------------------------------------------------------
# Directions
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("dir_from", "heading", "beta_deg"),
    [
        (0.0, 0.0, 180.0),  # heading N, waves from N: from ahead → head seas
        (180.0, 0.0, 0.0),  # heading N, waves from S: from astern → following
        (0.0, 90.0, 270.0),  # heading E, waves from N (port side), travelling S = body −y
        (180.0, 90.0, 90.0),  # heading E, waves from S (starboard side), travelling N = body +y (port)
        (90.0, 0.0, 90.0),  # heading N, waves from E (starboard), travelling W = body +y
        (170.0, 350.0, 0.0),  # wrap-around: travelling towards 350° = the heading → following
        (200.0, 10.0, 350.0),  # travelling towards 20°, 10° clockwise of the bow = −10° CCW
        (-90.0, 720.0, 270.0),  # inputs outside [0, 360)
    ],
)
def test_wave_direction_hand_cases(dir_from, heading, beta_deg):
    assert_allclose(sp.wave_direction_from_nautical(dir_from, heading), np.deg2rad(beta_deg), atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(st.floats(-720.0, 720.0), st.floats(-720.0, 720.0))
def test_wave_direction_matches_vector_geometry(dir_from, heading):
    # independent derivation: travel vector and body axes in (east, north) coordinates
    to = np.deg2rad(dir_from + 180.0)
    travel = np.array([np.sin(to), np.cos(to)])
    psi = np.deg2rad(heading)
    x_body, y_body = np.array([np.sin(psi), np.cos(psi)]), np.array([-np.cos(psi), np.sin(psi)])  # y to port
    expected = np.arctan2(travel @ y_body, travel @ x_body)
    beta = sp.wave_direction_from_nautical(dir_from, heading)
    assert 0.0 <= beta < TWO_PI
    assert abs(sp.wrap_angle(beta - expected)) < 1e-9


def test_wave_direction_is_vectorised_and_in_range():
    beta = sp.wave_direction_from_nautical(np.array([[0.0], [180.0]]), np.array([0.0, 180.0, -1e-14]))
    assert beta.shape == (2, 3)
    assert np.all((beta >= 0) & (beta < TWO_PI))


# --------------------------------------------------------------------------------------------------
# Directional spectrum and moments
# --------------------------------------------------------------------------------------------------


def test_long_crested_head_seas_column():
    omega = np.linspace(0.2, 2.5, 60)
    part = sp.SpectrumPartition(hs=2.0, tp=8.0, dir_from_deg=30.0, gamma=1.0, spreading="long_crested")
    s2 = sp.directional_spectrum(omega, GRID_24, part, heading_deg=30.0)  # bow into the waves
    assert s2.shape == (60, 24)
    head = 12  # β = 180°
    assert_allclose(s2[:, head] * np.deg2rad(15.0), sp.pierson_moskowitz(omega, 2.0, 8.0), rtol=1e-14)
    assert_array_equal(np.delete(s2, head, axis=1), 0.0)


_partition = st.builds(
    sp.SpectrumPartition,
    hs=st.floats(0.0, 8.0),
    tp=st.floats(3.0, 20.0),
    dir_from_deg=st.floats(-360.0, 720.0),
    gamma=st.sampled_from([1.0, 2.0, 3.3, 5.0]),
    spreading=st.sampled_from(["cos2s", "cosn"]),
    spreading_param=st.sampled_from([0.0, 1.0, 2.0, 4.0, 10.0, 60.0]),
) | st.builds(
    sp.SpectrumPartition,
    hs=st.floats(0.0, 8.0),
    tp=st.floats(3.0, 20.0),
    dir_from_deg=st.floats(-360.0, 720.0),
    gamma=st.sampled_from([1.0, 3.3]),
    spreading=st.just("long_crested"),
)


@settings(max_examples=60, deadline=None)
@given(
    parts=st.lists(_partition, min_size=1, max_size=3),
    heading=st.floats(-360.0, 360.0),
    n_dir=st.sampled_from([8, 24, 36]),
    interpolate=st.booleans(),
)
def test_directional_variance_equals_1d_variance(parts, heading, n_dir, interpolate):
    omega = np.linspace(0.1, 4.0, 120)
    grid = np.linspace(0.0, TWO_PI, n_dir, endpoint=False)
    s2 = sp.directional_spectrum(omega, grid, parts, heading, interpolate=interpolate)
    w = np.full(omega.size, omega[1] - omega[0])  # trapezoid weights w_ω
    w[[0, -1]] /= 2
    total = np.sum(w[:, None] * s2 * (TWO_PI / n_dir))
    m0_1d = sum(np.trapezoid(sp.jonswap(omega, p.hs, p.tp, p.gamma), omega) for p in parts)
    assert_allclose(total, m0_1d, rtol=1e-12, atol=1e-15)


def test_partition_defaults_and_validation():
    part = sp.SpectrumPartition(hs=1.0, tp=7.0, dir_from_deg=0.0)
    assert part.gamma == 3.3 and part.spreading == "cos2s" and part.spreading_param is None
    with pytest.raises(ValueError, match="tp"):
        sp.SpectrumPartition(hs=1.0, tp=-7.0, dir_from_deg=0.0)
    with pytest.raises(ValueError, match="kind"):
        sp.SpectrumPartition(hs=1.0, tp=7.0, dir_from_deg=0.0, spreading="cos3")
    with pytest.raises(AttributeError):
        part.hs = 2.0  # frozen
    assert_array_equal(sp.directional_spectrum(np.linspace(0.1, 1, 5), GRID_24, [], 0.0), 0.0)


def test_spectral_moments_shapes_and_axis():
    omega = np.linspace(0.0, 2.0, 201)
    s = np.ones((3, 201))  # white spectrum: m_n = 2^{n+1}/(n+1) exactly for n ≤ 1 with the trapezoid rule
    m = sp.spectral_moments(omega, s, orders=(0, 1))
    assert m.shape == (2, 3)
    assert_allclose(m[0], 2.0, rtol=1e-14)
    assert_allclose(m[1], 2.0, rtol=1e-14)
    m0, m1, m2 = sp.spectral_moments(omega, s.T, axis=0)
    assert m0.shape == (3,)
    assert_allclose(m2, 8.0 / 3.0, rtol=1e-4)
    hs, tz = sp.hs_tz_from_spectrum(omega, s.T, axis=0)
    assert_allclose(hs, 4.0 * np.sqrt(2.0), rtol=1e-14)
    assert_allclose(tz, TWO_PI * np.sqrt(2.0 / m2), rtol=1e-14)
    with pytest.raises(ValueError, match="does not match"):
        sp.spectral_moments(omega[:-1], s)

"""UKF tuning backend (Han, paper A6; A7).

Where the expectations come from:

* seed digest §2.3's weight table (A6 eq. 5 for N = 5, κ = −2 and N = 6, κ = −3);
* filterpy (an independent UKF): `MerweScaledSigmaPoints` for the weights and sigma points, and
  `UnscentedKalmanFilter` driven as A6 needs it for whole updates. Its own `predict()` would redraw the
  sigma points from P + Q, so the test sets x, P to the weather update (A6 eq. 1), calls
  `compute_process_sigmas` with identity fx (sigma points from P^w), sets P ← P + Q (eq. 6b), then
  `update(z, R)` (eq. 11);
* A6 eqs. 5 and 11 evaluated literally in exact rational arithmetic (fractions) on the same sigma points;
* analytic forward models defined here (a toy, and an A6-like heave model: damped one-DOF RAOs under a
  Pierson–Moskowitz spectrum, A6 eq. 12) with known truth; A6 Tables 2, 5 and 9 for the set-up and the
  magnitudes (Hs variance reduction ≈ 50 % on average, ≥ 30 % asked);
* A7 Table 4 / thesis Table 4.3 for the R rules.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
from scipy.linalg import sqrtm
from scipy.special import expit, logit

from seatune.tuning.interface import Observation, Parameter, SeaState
from seatune.tuning.ukf import UKF, _nearest_spd, sigma_points

G = 9.81


# ---------------------------------------------------------------- forward models (analytic, test-side)
class Toy:
    """z = [hs e^(−a) (1 + b²), hs² (1 + a b / 2), hs sin b + a²] (a ignored if uses_a is False)."""

    names = ("m1:sigma", "m2:sigma", "m3:sigma")
    parameter_names = ("a", "b")
    sea_state_names = ("hs",)

    def __init__(self, uses_a: bool = True):
        self.uses_a = uses_a

    def predict_paired(self, phi, theta):
        a, b = np.atleast_2d(phi).T
        a = a if self.uses_a else 0.0 * a
        hs = np.atleast_2d(theta)[:, 0]
        return np.stack([hs * np.exp(-a) * (1 + b**2), hs**2 * (1 + 0.5 * a * b), hs * np.sin(b) + a**2], axis=1)

    def predict(self, phi, theta):
        raise NotImplementedError


class Heading(Toy):
    """A Toy whose statistics also depend on the wave direction β [deg]."""

    sea_state_names = ("hs", "beta_deg")

    def predict_paired(self, phi, theta):
        b = np.radians(np.atleast_2d(theta)[:, 1:2])
        return super().predict_paired(phi, theta) * (1 + 0.5 * np.sin(b)) * (1 + 0.3 * np.cos(b))


OMEGA = np.linspace(0.15, 2.1, 80)
POINTS = ((60.0, 0.0), (60.0, 13.0), (0.0, 10.0))  # A6 Table 3 (x, y) of sensors A, B, C


class HeaveModel:
    """A6-like: σ of heave displacement/velocity/acceleration at A, B, C; roll damping β44 and XCG tuned."""

    parameter_names = ("beta44", "xcg")
    sea_state_names = ("hs", "tp", "beta_deg")
    names = tuple(f"heave_{kind}_{p}:sigma" for kind in ("disp", "vel", "acc") for p in "ABC")

    def predict_paired(self, phi, theta):
        b44, xcg = (c[:, None] for c in np.atleast_2d(phi).T)
        hs, tp, beta = (c[:, None] for c in np.atleast_2d(theta).T)
        w, wp = OMEGA, 2 * np.pi / tp
        s = 5 / 16 * hs**2 * wp**4 * w**-5 * np.exp(-1.25 * (w / wp) ** -4)  # A6 eq. 12
        b, slope = np.radians(beta), w**2 / G
        h3 = 1 / (1 - (w / 0.8) ** 2 + 0.4j * w / 0.8)
        h4 = np.sin(b) * slope / (1 - (w / 0.55) ** 2 + 2j * b44 * w / 0.55)
        h5 = 0.8 * np.cos(b) * slope / (1 - (w / 0.9) ** 2 + 0.6j * w / 0.9)
        out = [np.sqrt((np.abs(h3 + y * h4 - (x - xcg) * h5) ** 2 * w**k * s).sum(1) * (w[1] - w[0]))
               for k in (0, 2, 4) for x, y in POINTS]
        return np.stack(out, axis=1)

    def predict(self, phi, theta):
        raise NotImplementedError


A6_PARAMS = [Parameter("beta44", 0.07, 0.035, 0.0, 0.3), Parameter("xcg", 59.4, 4.0, 50.0, 70.0)]  # Table 5
A6_Q = {"beta44": 0.005, "xcg": 0.1**0.5, "hs": 0.05, "tp": 0.1, "beta_deg": 0.5}  # A6 Table 5 (as std)
A6_TRUTH = np.array([0.04, 61.4])  # A6 φ*
TOY_PARAMS = [Parameter("a", 0.5, 0.3, -10.0, 10.0), Parameter("b", 1.0, 0.4, -10.0, 10.0)]


def _obs(model, z, k=0, variance=None):
    return Observation(f"w{k}", model.names, z, np.zeros(z.size) if variance is None else variance, 1800.0)


def _sea(names, mean, std):
    mean, std = np.asarray(mean, float), np.asarray(std, float)
    return SeaState(tuple(names), mean, np.diag(std**2), mean[None], np.ones(1))


def _a6_windows(n, seed, truth=A6_TRUTH, noise=0.03):
    """A6 Tables 2/4: Hs* ~ U[1, 4] m, Tp* ~ U[5, 20] s, β* ~ U[0, 360)°; acquired = true + N(0, σ) with
    σ = (10 % Hs*, 0.5 s, 5°); measured σ̂ = model at the truth × (1 + noise·N(0, 1))."""
    rng = np.random.default_rng(seed)
    model = HeaveModel()
    for k in range(n):
        true = np.array([rng.uniform(1, 4), rng.uniform(5, 20), rng.uniform(0, 360)])
        sd = np.array([0.1 * true[0], 0.5, 5.0])
        acquired = true + sd * rng.normal(size=3)
        z = model.predict_paired(truth[None], true[None])[0] * (1 + noise * rng.normal(size=9))
        yield k, true, sd, _obs(model, z, k), _sea(model.sea_state_names, acquired, sd)


# ---------------------------------------------------------------- sigma points and weights
@pytest.mark.parametrize("n, w0m, w0c", [(5, -16665.67, -16662.67), (6, -19999.0, -19996.0)])
def test_weights_match_seed_table_and_filterpy(n, w0m, w0c):
    """Digest §2.3 table (α = 0.01, β = 2, κ = 3 − N), printed to 2 decimals; w_i = 1666.667."""
    _, wm, wc = sigma_points(np.zeros(n), np.eye(n))
    assert wm[0] == pytest.approx(w0m, abs=0.005)
    assert wc[0] == pytest.approx(w0c, abs=0.005)
    np.testing.assert_allclose(wm[1:], 1666.667, atol=5e-4)
    np.testing.assert_array_equal(wm[1:], wc[1:])
    ref = MerweScaledSigmaPoints(n, 0.01, 2.0, 3.0 - n)
    np.testing.assert_allclose(wm, ref.Wm, rtol=1e-14)
    np.testing.assert_allclose(wc, ref.Wc, rtol=1e-14)
    assert wm.sum() == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("method, fp_sqrt", [("cholesky", None), ("sqrtm", sqrtm)])
def test_sigma_points_match_filterpy(method, fp_sqrt):
    rng = np.random.default_rng(7)
    A = rng.normal(size=(5, 5))
    P = A @ A.T + np.diag([1e-3, 16.0, 0.06, 0.25, 25.0])  # A6-like scales
    x = np.array([0.07, 59.4, 2.5, 13.4, 317.4])
    pts, _, _ = sigma_points(x, P, 0.01, 2.0, None, method)
    ref = MerweScaledSigmaPoints(5, 0.01, 2.0, -2.0, sqrt_method=fp_sqrt).sigma_points(x, P)
    np.testing.assert_allclose(pts, ref, rtol=1e-13, atol=1e-13)
    # spread √(N + λ) = 0.017321 σ (digest §2.3) about the centre
    d = pts[1:6] - x
    np.testing.assert_allclose(np.einsum("ki,ij,kj->k", d, np.linalg.inv(P), d), 3e-4, rtol=1e-8)


def test_sigma_points_reject_bad_scaling():
    with pytest.raises(ValueError, match="N \\+ λ"):
        sigma_points(np.zeros(3), np.eye(3), kappa=-3.0)
    with pytest.raises(ValueError, match="sqrt_method"):
        sigma_points(np.zeros(3), np.eye(3), sqrt_method="svd")


# ---------------------------------------------------------------- whole updates against references
def _phi_of_u(params, u):
    """Test-side scaled logit: φ = lo + (hi − lo)·expit(logit(p0) + (u − m)/s), s = (hi − lo)p0(1 − p0)."""
    lo, hi, m = (np.array([getattr(p, a) for p in params]) for a in ("lower", "upper", "prior_mean"))
    p0 = (m - lo) / (hi - lo)
    return lo + (hi - lo) * expit(logit(p0) + (u - m) / ((hi - lo) * p0 * (1 - p0)))


@pytest.mark.parametrize("bounded", [False, True])
@pytest.mark.parametrize("method, fp_sqrt", [("cholesky", None), ("sqrtm", sqrtm)])
def test_updates_match_filterpy(bounded, method, fp_sqrt):
    """8 sea states, A6 eqs. 1–11 with the same R = 2 % z² and Q; agreement to ~1e-10."""
    params = [Parameter("a", 0.5, 0.3, -1.0, 2.0), Parameter("b", 1.0, 0.4, -0.5, 3.0)]
    model, q = Toy(), {"a": 0.02, "b": 0.03, "hs": 0.05}
    ukf = UKF(params, process_noise=q, use_sampling_variance=False, bounded=bounded, sqrt_method=method)
    to_phi = (lambda u: _phi_of_u(params, u)) if bounded else (lambda u: u)
    fp = UnscentedKalmanFilter(3, 3, 1.0, hx=lambda x: model.predict_paired(to_phi(x[:2])[None], x[None, 2:])[0],
                               fx=lambda x, dt: x, points=MerweScaledSigmaPoints(3, 0.01, 2.0, 0.0, fp_sqrt))
    u, P_u = np.array([0.5, 1.0]), np.diag([0.3, 0.4]) ** 2  # u = φ, du/dφ = 1 at the prior
    rng = np.random.default_rng(3)
    for k in range(8):
        hs = rng.uniform(1, 3)
        acquired, var = hs * (1 + 0.1 * rng.normal()), (0.1 * hs) ** 2
        z = model.predict_paired(np.array([[0.3, 1.3]]), np.array([[hs]]))[0] * (1 + 0.02 * rng.normal(size=3))
        ukf.update(model, _obs(model, z, k), _sea(["hs"], [acquired], [var**0.5]))
        fp.x, fp.P = np.r_[u, acquired], np.zeros((3, 3))
        fp.P[:2, :2], fp.P[2, 2] = P_u, var  # A6 eq. 1
        fp.compute_process_sigmas(1.0)  # sigma points from P^w, identity fx
        fp.P = fp.P + np.diag([0.02, 0.03, 0.05]) ** 2  # A6 eq. 6b
        fp.update(z, R=np.diag(0.02 * z**2))  # A6 eq. 11
        u, P_u = fp.x[:2].copy(), fp.P[:2, :2].copy()
        np.testing.assert_allclose(ukf.x_, fp.x, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(ukf.P_, fp.P, rtol=1e-9, atol=1e-14)
    assert abs(ukf.x_[0] - 0.3) < abs(0.5 - 0.3)  # and it learnt something


def _exact_eq11(X, Z, x_bar, P_bar, z, R, alpha, beta, kappa):
    """A6 eqs. 4, 5 and 11 literally, in exact rationals, on the given float sigma points X and predictions Z."""
    fr = np.vectorize(Fraction, otypes=[object])
    X, Z, x_bar, P_bar, z, R = map(fr, (X, Z, x_bar, P_bar, z, R))
    a, b, n = Fraction(alpha), Fraction(beta), X.shape[1]
    k = Fraction(kappa)
    lam = a**2 * (n + k) - n
    wm = np.array([lam / (n + lam)] + [1 / (2 * (n + lam))] * (2 * n), dtype=object)
    wc = wm.copy()
    wc[0] = lam / (n + lam) + 1 - a**2 + b
    z_bar = wm @ Z
    D = Z - z_bar
    P_z = (wc * D.T) @ D + np.diag(R)
    P_xz = (wc * (X - x_bar).T) @ D
    aug = np.concatenate([P_z, P_xz.T], axis=1)  # Gauss–Jordan: P_z⁻¹ P_xzᵀ
    J = P_z.shape[0]
    for i in range(J):
        aug[i] = aug[i] / aug[i, i]
        for r in range(J):
            if r != i:
                aug[r] = aug[r] - aug[r, i] * aug[i]
    M = aug[:, J:]
    to_float = np.vectorize(float)
    return to_float(x_bar + M.T @ (z - z_bar)), to_float(P_bar - P_xz @ M)


def test_update_matches_exact_eq11():
    """The centre-point rearrangement of eq. 11 equals the literal sums with exact weights."""
    model, q = Toy(), {"a": 0.02, "b": 0.03, "hs": 0.05}
    ukf = UKF(TOY_PARAMS, process_noise=q, use_sampling_variance=False, bounded=False)
    z = np.array([1.7, 4.3, 1.9])
    ukf.update(model, _obs(model, z), _sea(["hs"], [2.0], [0.2]))
    x_w, P_w = np.array([0.5, 1.0, 2.0]), np.diag([0.3, 0.4, 0.2]) ** 2
    X, _, _ = sigma_points(x_w, P_w)
    x_ref, P_ref = _exact_eq11(X, model.predict_paired(X[:, :2], X[:, 2:]), x_w, P_w + np.diag([0.02, 0.03, 0.05]) ** 2,
                               z, 0.02 * z**2, 0.01, 2.0, 0.0)
    np.testing.assert_allclose(ukf.x_, x_ref, rtol=1e-13)
    np.testing.assert_allclose(ukf.P_, P_ref, rtol=1e-11, atol=1e-16)


# ---------------------------------------------------------------- behaviour on an A6-like problem
def test_converges_on_a6_like_problem():
    ukf = UKF(A6_PARAMS, process_noise=A6_Q, use_sampling_variance=False)  # R = 2 % z², α, β, κ of Table 5
    prior = ukf.posterior()
    reduction, err_acq, err_tuned = [], [], []
    for _, true, sd, obs, sea in _a6_windows(20, seed=0):
        post = ukf.update(HeaveModel(), obs, sea)
        reduction.append(1 - np.diag(post.sea_state_cov) / sd**2)  # A6 eq. 19 against the acquired variance
        err_acq.append(np.abs(sea.mean - true))
        err_tuned.append(np.abs(post.sea_state_mean - true))
    err0, err1 = np.abs(prior.mean - A6_TRUTH), np.abs(post.mean - A6_TRUTH)
    assert np.all(err1 < 0.5 * err0), (prior.mean, post.mean)
    assert np.all(post.std < 0.5 * prior.std)
    assert np.all((post.quantiles[0.05] < A6_TRUTH) & (A6_TRUTH < post.quantiles[0.95]))
    mean_reduction = np.mean(reduction, axis=0)
    assert mean_reduction[0] > 0.30  # Hs: A6 Table 9 averages 50 %
    assert np.all(mean_reduction > 0.0)  # Tp, β: 32 % each in A6
    assert np.mean(err_tuned, axis=0)[0] < 0.7 * np.mean(err_acq, axis=0)[0]  # A6: 0.205 → 0.120 m
    assert ukf.n_updates_ == 20 and ukf.n_spd_repairs_ == 0
    assert post.used == HeaveModel.names


def test_bounded_mean_stays_inside_when_data_push_out():
    """Truth outside the bounds (β44 0.005 < 0.02, XCG 66 > 62): unbounded crosses them, bounded does not."""
    params = [Parameter("beta44", 0.05, 0.03, 0.02, 0.3), Parameter("xcg", 59.4, 4.0, 50.0, 62.0)]
    lo, hi = np.array([0.02, 50.0]), np.array([0.3, 62.0])
    bounded, free = UKF(params, use_sampling_variance=False), UKF(params, use_sampling_variance=False, bounded=False)
    for _, _, _, obs, sea in _a6_windows(20, seed=2, truth=np.array([0.005, 66.0]), noise=0.0):
        post = bounded.update(HeaveModel(), obs, sea)
        q05, q50, q95 = (post.quantiles[k] for k in (0.05, 0.5, 0.95))
        assert np.all((lo < post.mean) & (post.mean < hi)) and np.all(np.isfinite(post.cov))
        assert np.all((lo <= q05) & (q05 <= q50) & (q50 <= q95) & (q95 <= hi))
        free_post = free.update(HeaveModel(), obs, sea)
    assert free_post.mean[0] < lo[0] and free_post.mean[1] > hi[1]  # the data really push past the bounds
    assert post.mean[0] - lo[0] < 0.005 and hi[1] - post.mean[1] < 0.5  # and the bounded filter follows them


def test_prior_posterior_and_transform():
    ukf = UKF(A6_PARAMS)
    prior = ukf.posterior()
    np.testing.assert_allclose(prior.quantiles[0.5], [0.07, 59.4], rtol=1e-12)  # u = φ at the prior mean
    np.testing.assert_allclose(ukf.P_u_, np.diag([0.035, 4.0]) ** 2)  # delta rule, du/dφ = 1
    # reported moments of the logit-normal prior against 80-point Gauss–Hermite quadrature
    x, w = np.polynomial.hermite_e.hermegauss(80)
    phi = _phi_of_u(A6_PARAMS, np.array([0.07, 59.4]) + np.array([0.035, 4.0]) * x[:, None])
    mean = w @ phi / w.sum()
    np.testing.assert_allclose(prior.mean, mean, rtol=0.01)  # 0.0754, 59.47
    np.testing.assert_allclose(prior.std, np.sqrt(w @ (phi - mean) ** 2 / w.sum()), rtol=0.02)  # 0.0349, 3.52
    assert prior.used == () and prior.sea_state_mean is None
    m = ukf._map
    phi = np.array([[0.001, 50.01], [0.07, 59.4], [0.299, 69.9]])
    np.testing.assert_allclose(m.to_phi(m.to_u(phi)), phi, rtol=1e-9)
    np.testing.assert_allclose(m.dphi_du(m.to_u(np.array([0.07, 59.4]))), 1.0)
    np.testing.assert_allclose(m.to_phi(np.array([[-1e6, -1e6], [1e6, 1e6]])), [[0.0, 50.0], [0.3, 70.0]], atol=1e-12)
    free = UKF(A6_PARAMS, bounded=False).posterior()
    np.testing.assert_array_equal(free.mean, [0.07, 59.4])
    np.testing.assert_allclose(free.std, [0.035, 4.0])
    np.testing.assert_allclose(free.quantiles[0.95], [0.07, 59.4] + 1.6448536269514722 * np.array([0.035, 4.0]))


def test_one_sided_bounds():
    params = [Parameter("m", 2.0, 1.0, 0.0, np.inf), Parameter("n", -2.0, 1.0, -np.inf, 0.0),
              Parameter("f", 0.0, 1.0, -np.inf, np.inf)]
    m = UKF(params)._map
    u = np.array([[-10.0, 10.0, 3.0], [2.0, -2.0, 0.0]])
    phi = m.to_phi(u)
    assert phi[0, 0] > 0 and phi[0, 1] < 0 and phi[0, 2] == 3.0
    np.testing.assert_allclose(phi[1], [2.0, -2.0, 0.0])
    np.testing.assert_allclose(m.dphi_du(u[1]), 1.0)
    np.testing.assert_allclose(m.to_u(phi), u, rtol=1e-12)


# ---------------------------------------------------------------- sea state
def test_known_sea_state_is_the_a7_form():
    """Zero acquired variance: θ' is used as known and the state is φ only (A7, N = p)."""
    model = HeaveModel()
    ukf = UKF(A6_PARAMS, use_sampling_variance=False)
    theta = [2.5, 13.4, 317.4]
    z = model.predict_paired(A6_TRUTH[None], np.array([theta]))[0]
    post = ukf.update(model, _obs(model, z), SeaState.certain(model.sea_state_names, theta))
    assert ukf.state_names_ == ("beta44", "xcg") and ukf.x_.shape == (2,)
    np.testing.assert_array_equal(post.sea_state_mean, theta)
    np.testing.assert_array_equal(post.sea_state_cov, np.zeros((3, 3)))
    # partly known: only the uncertain components enter the state
    sea = SeaState(model.sea_state_names, np.array(theta), np.diag([0.25**2, 0.0, 25.0]), np.array([theta]),
                   np.ones(1))
    post = ukf.update(model, _obs(model, z), sea)
    assert ukf.state_names_ == ("beta44", "xcg", "hs", "beta_deg")
    assert post.sea_state_mean[1] == 13.4 and post.sea_state_cov[1, 1] == 0.0
    assert post.sea_state_cov[0, 0] < 0.25**2


def test_beta_wraps_mod_360():
    """Acquired β 358° ± 5°, truth 3°: the tuned β passes 360° and is reported as ≈ 3°."""
    model = Heading()
    ukf = UKF(TOY_PARAMS, r_fraction=1e-5, use_sampling_variance=False, bounded=False)
    z = model.predict_paired(np.array([[0.5, 1.0]]), np.array([[2.0, 3.0]]))[0]
    for k in range(3):
        post = ukf.update(model, _obs(model, z, k), _sea(model.sea_state_names, [2.0, 358.0], [0.01, 5.0]))
        beta = post.sea_state_mean[1]
        assert 0.0 <= beta < 360.0
    assert abs(beta - 3.0) < 1.0  # β' 358 ± 5 each window; the same z pulls it to ≈ 362.3 → 2.3


def test_fresh_replaces_belief_and_zeroes_cross_covariance():
    """After correlated updates, a fresh (mean, var) for `a` and a window blind to `a` leave `a` at exactly the
    fresh mean with variance var + q² (A6 eq. 6b); without `fresh`, the correlation with `b` moves it."""
    q, model, blind = {"a": 0.02, "b": 0.03, "hs": 0.05}, Toy(), Toy(uses_a=False)
    filters = [UKF(TOY_PARAMS, process_noise=q, use_sampling_variance=False, bounded=False) for _ in range(2)]
    z = model.predict_paired(np.array([[0.3, 1.3]]), np.array([[2.0]]))[0]
    for ukf in filters:
        for k in range(3):
            ukf.update(model, _obs(model, z, k), _sea(["hs"], [2.0], [0.2]))
    with_fresh, without = filters
    assert abs(without.P_u_[0, 1]) > 1e-4
    z_blind = blind.predict_paired(np.array([[0.0, 1.6]]), np.array([[2.0]]))[0]
    a_before = without.u_[0]
    post = with_fresh.update(blind, _obs(blind, z_blind), _sea(["hs"], [2.0], [0.2]), fresh={"a": (0.7, 0.01)})
    assert post.mean[0] == pytest.approx(0.7, abs=1e-14)
    assert post.cov[0, 0] == pytest.approx(0.01 + 0.02**2, rel=1e-12)
    assert post.cov[0, 1] == pytest.approx(0.0, abs=1e-15)
    assert abs(without.update(blind, _obs(blind, z_blind), _sea(["hs"], [2.0], [0.2])).mean[0] - a_before) > 1e-3
    with pytest.raises(ValueError, match="unknown parameter"):
        with_fresh.update(blind, _obs(blind, z_blind), _sea(["hs"], [2.0], [0.2]), fresh={"zcg": (1.0, 1.0)})


# ---------------------------------------------------------------- R and P
def test_measurement_variance_a7_rules():
    """A7 Table 4 / thesis Table 4.3 (β_W < 90°): max(2 % σ², 1e-6) heave, max(9 % σ², 1e-4) roll,
    max(2 % σ², 1e-4) pitch, T_z 0.1 s² (0.25 s² roll); plus the sampling-variance floor."""
    names = ("heave:sigma", "roll:sigma", "pitch:sigma", "heave:tz", "roll:tz", "other:sigma")
    z = np.array([0.5, 0.01, 1.0, 8.0, 12.0, 2.0])
    variance = np.array([0.0, 0.0, 0.2, 0.0, 0.0, 0.0])
    obs = Observation("w", names, z, variance, 1800.0)
    kw = dict(r_fraction={"heave*:sigma": 0.02, "roll*:sigma": 0.09, "pitch*:sigma": 0.02, "*:tz": 0.0},
              r_floor={"heave*:sigma": 1e-6, "roll*:sigma": 1e-4, "pitch*:sigma": 1e-4, "roll*:tz": 0.25,
                       "*:tz": 0.1})
    expected = [0.005, 1e-4, 0.02, 0.1, 0.25, 0.02 * 4.0]
    np.testing.assert_allclose(UKF(A6_PARAMS, use_sampling_variance=False, **kw).measurement_variance(obs),
                               expected)
    expected[2] = 0.2
    np.testing.assert_allclose(UKF(A6_PARAMS, **kw).measurement_variance(obs), expected)
    np.testing.assert_allclose(UKF(A6_PARAMS, use_sampling_variance=False).measurement_variance(obs), 0.02 * z**2)
    with pytest.raises(ValueError, match="zero measurement variance"):
        UKF(A6_PARAMS).measurement_variance(Observation("w", ("x:sigma",), np.zeros(1), np.zeros(1), 1.0))
    total = Observation("modes", ("roll:omega_n",), np.array([0.5]), np.array([1e-6]), 0.0, variance_is_total=True)
    np.testing.assert_allclose(UKF(A6_PARAMS, **kw).measurement_variance(total), [1e-6])  # no 2 % of z², no floor


@pytest.mark.parametrize("bounded", [True, False])
def test_p_stays_spd_over_50_updates(bounded):
    """Hard conditioning: R = 1e-6 z² (σ̂ trusted to 0.1 %), Q ≈ 0, state scales 1e-3 … 25."""
    ukf = UKF(A6_PARAMS, r_fraction=1e-6, process_noise={"beta44": 1e-7, "xcg": 1e-6},
              use_sampling_variance=False, bounded=bounded)
    for _, _, _, obs, sea in _a6_windows(50, seed=1, noise=0.0):
        ukf.update(HeaveModel(), obs, sea)
        for P in (ukf.P_, ukf.P_u_, ukf.posterior().cov):
            np.testing.assert_array_equal(P, P.T)
            np.linalg.cholesky(P)
            d = np.sqrt(np.diag(P))
            assert np.linalg.eigvalsh(P / np.outer(d, d)).min() > 1e-8
    assert ukf.n_spd_repairs_ == 0  # the rearranged eq. 11 never needed the repair here
    np.testing.assert_allclose(ukf.posterior().mean, A6_TRUTH, rtol=0.01)


def test_nearest_spd_repairs_indefinite_matrix():
    P = np.array([[1e-3, 0.2], [0.2, 16.0]])  # correlation 1.58: indefinite
    fixed, repaired = _nearest_spd(P, np.sqrt(np.diag(P)))
    assert repaired
    np.linalg.cholesky(fixed)
    np.testing.assert_allclose(np.diag(fixed), np.diag(P), rtol=0.3)
    good = np.array([[1e-3, 0.05], [0.05, 16.0]])
    same, repaired = _nearest_spd(good, np.ones(2))
    assert not repaired and np.array_equal(same, good)


# ---------------------------------------------------------------- errors
def test_errors_name_the_problem():
    model = HeaveModel()
    z = np.ones(9)
    sea = _sea(model.sea_state_names, [2.0, 10.0, 90.0], [0.2, 0.5, 5.0])
    with pytest.raises(ValueError, match="not the tuned parameters"):
        UKF([A6_PARAMS[0]]).update(model, _obs(model, z), sea)
    with pytest.raises(ValueError, match="process_noise names \\['zcg'\\]"):
        UKF(A6_PARAMS, process_noise={"zcg": 0.1}).update(model, _obs(model, z), sea)
    with pytest.raises(ValueError, match="sea-state names \\['beta_deg'\\]"):
        UKF(A6_PARAMS).update(model, _obs(model, z), _sea(["hs", "tp"], [2.0, 10.0], [0.2, 0.5]))
    with pytest.raises(ValueError, match="measurement names \\['yaw:sigma'\\]"):
        UKF(A6_PARAMS).update(model, Observation("w", ("yaw:sigma",), np.ones(1), np.zeros(1), 1.0), sea)
    bad_cov = SeaState(model.sea_state_names, np.array([2.0, 10.0, 90.0]), np.array([[1.0, 2.0, 0], [2.0, 1.0, 0],
                       [0, 0, 1.0]]), np.array([[2.0, 10.0, 90.0]]), np.ones(1))
    with pytest.raises(ValueError, match="not positive definite"):
        UKF(A6_PARAMS).update(model, _obs(model, z), bad_cov)
    with pytest.raises(ValueError, match="non-finite"), np.errstate(all="ignore"):  # Tp = 0
        UKF(A6_PARAMS).update(model, _obs(model, z), _sea(model.sea_state_names, [2.0, 0.0, 90.0], [0.2, 0.5, 5.0]))
    with pytest.raises(ValueError, match="sqrt_method"):
        UKF(A6_PARAMS, sqrt_method="svd")
    with pytest.raises(ValueError, match="duplicate"):
        UKF([A6_PARAMS[0], A6_PARAMS[0]])

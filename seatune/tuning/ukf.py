"""Unscented-Kalman-filter tuning backend (Han, paper A6; validated on model tests in A7).

One UKF step per sea state (seed digest §2.10):

1. weather update, A6 eq. 1: x^w = [u_k; θ'], P^w = blkdiag(P_u, P'_θ), the cross-covariances zeroed;
2. scaled sigma points from (x^w, P^w), A6 eqs. 2–5, drawn *before* Q is added (digest §2.4);
3. identity propagation, A6 eq. 6: x̄ = x^w, P̄ = P^w + Q (the sigma points are not redrawn);
4. predicted statistics Z_i of all 2N+1 sigma points in one `ForwardModel.predict_paired` call, A6 eq. 10;
5. measurement update, A6 eq. 11, with R = diag(max(r_fraction·z², floor, sampling variance)).

State: x = [u(φ); θ]. θ holds the sea-state components with a positive acquired variance; components
with zero variance are used as known (all zero: the A7 form, x = φ, N = p).

Deliberate deviations from A6/A7, each for a stated reason:

* bounded parameters are filtered in u = c + s·logit((φ − lower)/(upper − lower)) (scaled log for one
  finite bound), with s, c chosen so that u = φ and du/dφ = 1 at the prior mean. The papers have no
  constraint handling (digest §2.8), but a sigma point or a mean outside the bounds breaks the forward
  model (negative damping, COG off the hull). The prior and `fresh` values (in φ units) enter u by the
  first-order (delta) rule at their mean; Q (φ units) by the same rule at the prior mean, i.e. unchanged
  (at the current mean it would grow without limit near a bound). The belief is reported in φ by an unscented
  transform of the u-Gaussian, and the quantiles are the monotone images of the u-quantiles.
  ``bounded=False`` filters φ itself (A6 exactly);
* the sums of eq. 11 are taken about the centre sigma point. This is algebraically identical, but the
  ±1.7·10⁴ weights of α = 0.01 (digest §2.3) no longer cancel in floating point;
* P is symmetrised after every update. If its Cholesky factorisation fails, it is replaced by the
  nearest SPD matrix (eigenvalue clip) and `n_spd_repairs_` counts the repair. A7 saw non-PSD P;
* R also floors at the sampling variance of σ̂ for the record length (`Observation.variance`), so a
  short record is never trusted more than its degrees of freedom allow.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from fnmatch import fnmatchcase
from typing import Literal

import numpy as np
import scipy.linalg
from scipy.special import expit, logit

from seatune.tuning.interface import ForwardModel, Observation, Parameter, Posterior, SeaState

__all__ = ["UKF", "sigma_points", "DEFAULT_Q_FRACTION", "DEFAULT_R_FRACTION", "QUANTILES"]

QUANTILES = (0.05, 0.5, 0.95)
_Z95 = 1.6448536269514722  # standard-normal 0.95 quantile
# Default Q std as a fraction of the prior (parameters) or acquired (sea state) std. A6 Table 5 has
# 0.005/0.035 = 0.14 (β44), √0.1/4 = 0.08 (XCG), 0.05/0.25 = 0.2 (Hs), 0.1/0.5 = 0.2 (Tp), 0.5/5 = 0.1 (βW).
DEFAULT_Q_FRACTION = 0.1
DEFAULT_R_FRACTION = 0.02  # A6 Table 5: R = 2 % · diag(σ̂²)
BETA_NAME = "beta_deg"  # sea-state component that wraps mod 360° (digest §2.8)

SqrtMethod = Literal["cholesky", "sqrtm"]


def sigma_points(x: np.ndarray, P: np.ndarray, alpha: float = 0.01, beta: float = 2.0, kappa: float | None = None,
                 sqrt_method: SqrtMethod = "cholesky") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scaled sigma points and weights (A6 eqs. 2–5, the Van der Merwe set used by filterpy).

    Parameters
    ----------
    x : (N,) centre; P : (N, N) SPD covariance
    alpha, beta, kappa : scaling (kappa None → 3 − N, as in A6/A7)
    sqrt_method : "cholesky" (columns of the lower factor, i.e. the rows of the upper factor that filterpy's
        default ``scipy.linalg.cholesky`` returns) or "sqrtm" (principal root by the Schur method, which
        thesis L1055 says was used)

    Returns
    -------
    points : (2N+1, N) ordered X_0, X_1..N = x + columns, X_N+1..2N = x − columns
    Wm, Wc : (2N+1,) weights of the means and of the covariances
    """
    x = np.atleast_1d(np.asarray(x, dtype=float))
    P = np.atleast_2d(np.asarray(P, dtype=float))
    n = x.size
    if P.shape != (n, n):
        raise ValueError(f"sigma_points: P has shape {P.shape}, expected ({n}, {n})")
    kappa = 3.0 - n if kappa is None else float(kappa)
    lam = alpha**2 * (n + kappa) - n  # A6 eq. 4
    if not n + lam > 0:
        raise ValueError(f"sigma_points: N + λ = α²(N + κ) = {n + lam:g} must be > 0 (alpha={alpha}, kappa={kappa})")
    if sqrt_method == "cholesky":
        root = np.linalg.cholesky((n + lam) * P)
    elif sqrt_method == "sqrtm":
        root = np.real(scipy.linalg.sqrtm((n + lam) * P))
    else:
        raise ValueError(f"sigma_points: sqrt_method must be 'cholesky' or 'sqrtm', not {sqrt_method!r}")
    points = np.concatenate([x[None, :], x + root.T, x - root.T])  # A6 eqs. 2–3
    wm = np.full(2 * n + 1, 0.5 / (n + lam))  # A6 eq. 5c
    wc = wm.copy()
    wm[0] = lam / (n + lam)  # A6 eq. 5a
    wc[0] = lam / (n + lam) + 1.0 - alpha**2 + beta  # A6 eq. 5b
    return points, wm, wc


class _BoundMap:
    """Elementwise φ ↔ u for p parameters; u = φ and du/dφ = 1 at the prior mean.

    Two finite bounds: u = c + s·logit((φ − lo)/(hi − lo)); only lo: u = c + s·log(φ − lo); only hi:
    u = c − s·log(hi − φ); none (or ``bounded=False``): u = φ.
    """

    _MARGIN = 1e-9  # φ on or past a bound is mapped from this far inside, relative to the range (or to s)

    def __init__(self, parameters: Sequence[Parameter], bounded: bool):
        lo = np.array([p.lower for p in parameters], dtype=float)
        hi = np.array([p.upper for p in parameters], dtype=float)
        m = np.array([p.prior_mean for p in parameters], dtype=float)
        fin_lo, fin_hi = bounded & np.isfinite(lo), bounded & np.isfinite(hi)
        self.lo, self.hi = lo, hi
        self.both, self.low, self.high = fin_lo & fin_hi, fin_lo & ~fin_hi, ~fin_lo & fin_hi
        self.any = bool((self.both | self.low | self.high).any())
        p0 = np.where(self.both, (m - lo) / np.where(self.both, hi - lo, 1.0), 0.5)
        self.s = np.select([self.both, self.low, self.high], [(hi - lo) * p0 * (1 - p0), m - lo, hi - m], 1.0)
        self.c = np.zeros_like(m)
        self.c = m - self.to_u(m)  # u(prior mean) = prior mean

    def to_u(self, phi: np.ndarray) -> np.ndarray:
        phi = np.asarray(phi, dtype=float)
        u = phi.copy()
        b, lw, hg = self.both, self.low, self.high
        eps = self._MARGIN
        u[..., b] = logit(np.clip((phi[..., b] - self.lo[b]) / (self.hi[b] - self.lo[b]), eps, 1 - eps))
        u[..., lw] = np.log(np.maximum(phi[..., lw] - self.lo[lw], eps * self.s[lw]))
        u[..., hg] = -np.log(np.maximum(self.hi[hg] - phi[..., hg], eps * self.s[hg]))
        return np.where(b | lw | hg, self.c + self.s * u, phi)

    def _raw(self, u: np.ndarray) -> np.ndarray:
        return np.clip((np.asarray(u, dtype=float) - self.c) / self.s, -700.0, 700.0)

    def to_phi(self, u: np.ndarray) -> np.ndarray:
        r = self._raw(u)
        phi = np.asarray(u, dtype=float).copy()
        b, lw, hg = self.both, self.low, self.high
        phi[..., b] = self.lo[b] + (self.hi[b] - self.lo[b]) * expit(r[..., b])
        phi[..., lw] = self.lo[lw] + np.exp(r[..., lw])
        phi[..., hg] = self.hi[hg] - np.exp(-r[..., hg])
        return phi

    def dphi_du(self, u: np.ndarray) -> np.ndarray:
        r = self._raw(u)
        d = np.ones_like(r)
        b, lw, hg = self.both, self.low, self.high
        e = expit(r[..., b])
        d[..., b] = (self.hi[b] - self.lo[b]) * e * (1 - e) / self.s[b]
        d[..., lw] = np.exp(r[..., lw]) / self.s[lw]
        d[..., hg] = np.exp(-r[..., hg]) / self.s[hg]
        return np.maximum(d, np.finfo(float).tiny)


def _per_name(rule: float | Mapping[str, float], names: Sequence[str], default: float) -> np.ndarray:
    """One value per measurement name: a float for all, or {fnmatch pattern: value}; the first match wins."""
    if not isinstance(rule, Mapping):
        return np.full(len(names), float(rule))
    return np.array([next((float(v) for pat, v in rule.items() if fnmatchcase(n, pat)), default) for n in names])


def _nearest_spd(P: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, bool]:
    """Symmetrised P, and whether it had to be repaired: if Cholesky fails, clip the eigenvalues of the
    scaled matrix P/(s sᵀ) (so β44 ~ 10⁻³ and XCG ~ 10 are treated alike) at 10⁻¹⁰ of the largest."""
    P = 0.5 * (P + P.T)
    try:
        np.linalg.cholesky(P)
        return P, False
    except np.linalg.LinAlgError:
        pass
    ss = np.outer(scale, scale)
    vals, vecs = np.linalg.eigh(P / ss)
    vals = np.maximum(vals, 1e-10 * max(vals.max(), 1e-300))
    P = ss * ((vecs * vals) @ vecs.T)
    return 0.5 * (P + P.T), True


class UKF:
    """UKF tuning backend (implements `seatune.tuning.interface.Backend`).

    Parameters
    ----------
    parameters : the tuned loading parameters φ with their Gaussian priors and hard bounds
    alpha, beta, kappa : sigma-point scaling, A6/A7: 0.01, 2, 3 − N (kappa None → 3 − N per update)
    process_noise : Q standard deviation per parameter name (φ units) and per sea-state name (θ units).
        Defaults: DEFAULT_Q_FRACTION × the prior std (parameters) or × the acquired std (sea state)
    r_fraction : R_jj ≥ r_fraction·z_j² (A6 Table 5: 0.02). A float, or {fnmatch pattern on the measurement
        name: fraction}, first match wins, unmatched names get 0.02 (A7 Table 4.3: {"heave*": 0.02,
        "roll*": 0.09, "pitch*": 0.05 (0.02 for β_W < 90°), "*:tz": 0.0})
    r_floor : absolute variance floors, a float or {pattern: floor}, first match wins, unmatched 0
        (A7 Table 4.3: {"heave*:sigma": 1e-6, "roll*:sigma": 1e-4, "pitch*:sigma": 1e-4, "roll*:tz": 0.25,
        "*:tz": 0.1})
    use_sampling_variance : R_jj ≥ Observation.variance[j] as well
    sqrt_method : "cholesky" or "sqrtm" (see `sigma_points`)
    bounded : filter bounded parameters in the scaled-logit coordinate u (module docstring); False: φ itself

    Attributes (learned, updated by `update`)
    ----------
    u_, P_u_ : mean and covariance of the parameters in u (= φ when unbounded)
    theta_, theta_cov_ : tuned sea state of the last update, in `SeaState.names` order (components not in
        the state keep their acquired values); theta_prior_cov_ : the acquired P'_θ of that window (for A6 eq. 19)
    state_names_, x_, P_ : the full state [u; θ_tuned] and its covariance after the last update
    innovation_, predicted_ : y and the predicted mean Z̄ of the last update
    n_updates_, n_spd_repairs_ : updates done; updates whose P needed the eigenvalue-clip repair
    """

    name = "ukf"

    def __init__(self, parameters: Sequence[Parameter], *, alpha: float = 0.01, beta: float = 2.0,
                 kappa: float | None = None, process_noise: Mapping[str, float] | None = None,
                 r_fraction: float | Mapping[str, float] = DEFAULT_R_FRACTION,
                 r_floor: float | Mapping[str, float] = 0.0, use_sampling_variance: bool = True,
                 sqrt_method: SqrtMethod = "cholesky", bounded: bool = True):
        self.parameters = tuple(parameters)
        names = tuple(p.name for p in self.parameters)
        if not names:
            raise ValueError("UKF: at least one parameter is needed")
        if len(set(names)) != len(names):
            raise ValueError(f"UKF: duplicate parameter names in {names}")
        if not alpha > 0:
            raise ValueError(f"UKF: alpha must be > 0, not {alpha}")
        if sqrt_method not in ("cholesky", "sqrtm"):
            raise ValueError(f"UKF: sqrt_method must be 'cholesky' or 'sqrtm', not {sqrt_method!r}")
        for label, rule in (("r_fraction", r_fraction), ("r_floor", r_floor)):
            values = rule.values() if isinstance(rule, Mapping) else [rule]
            if any(not float(v) >= 0 for v in values):
                raise ValueError(f"UKF: {label} values must be >= 0")
        self.process_noise = dict(process_noise or {})
        if any(not float(v) >= 0 for v in self.process_noise.values()):
            raise ValueError("UKF: process_noise standard deviations must be >= 0")
        self.alpha, self.beta, self.kappa = float(alpha), float(beta), kappa
        self.r_fraction, self.r_floor = r_fraction, r_floor
        self.use_sampling_variance, self.sqrt_method, self.bounded = use_sampling_variance, sqrt_method, bounded

        self._names = names
        self._map = _BoundMap(self.parameters, bounded)
        mean = np.array([p.prior_mean for p in self.parameters])
        std = np.array([p.prior_std for p in self.parameters])
        self.u_ = self._map.to_u(mean)
        self.P_u_ = np.diag((std / self._map.dphi_du(self.u_)) ** 2)  # delta rule (= std² at the prior)
        self.theta_: np.ndarray | None = None
        self.theta_cov_: np.ndarray | None = None
        self.theta_prior_cov_: np.ndarray | None = None
        self.state_names_: tuple[str, ...] = names
        self.x_, self.P_ = self.u_.copy(), self.P_u_.copy()
        self.innovation_: np.ndarray | None = None
        self.predicted_: np.ndarray | None = None
        self.n_updates_ = 0
        self.n_spd_repairs_ = 0
        self._used: tuple[str, ...] = ()

    # ------------------------------------------------------------------ measurement noise
    def measurement_variance(self, observation: Observation) -> np.ndarray:
        """Diagonal of R for this window: max(r_fraction·z², r_floor, sampling variance) per measurement.

        A6 Table 5 (R = 2 % σ̂²) and A7 Table 4 / thesis Table 4.3 (max(x % σ², floor); fixed T_z variance
        as fraction 0 with a floor); the sampling-variance floor is seatune's (module docstring).
        """
        names = tuple(observation.names)
        z = np.asarray(observation.z, dtype=float)
        if observation.variance_is_total:
            r = np.asarray(observation.variance, dtype=float)
            if not np.all(r > 0):
                raise ValueError(f"UKF: window {observation.window_id!r}: a total variance must be > 0")
            return r
        frac = _per_name(self.r_fraction, names, DEFAULT_R_FRACTION)
        r = np.maximum(frac * z**2, _per_name(self.r_floor, names, 0.0))
        if self.use_sampling_variance:
            r = np.maximum(r, np.asarray(observation.variance, dtype=float))
        bad = [n for n, v in zip(names, r, strict=True) if not v > 0]
        if bad:
            raise ValueError(f"UKF: window {observation.window_id!r}: zero measurement variance R for {bad}; "
                             "set r_floor for these names")
        return r

    # ------------------------------------------------------------------ one step per sea state
    def update(self, model: ForwardModel, observation: Observation, sea_state: SeaState,
               fresh: Mapping[str, tuple[float, float]] | None = None) -> Posterior:
        """Assimilate one window (one sea state) and return the posterior after it.

        fresh : {parameter name: (mean, variance)} in φ units, e.g. a sea-state-dependent damping predicted
            by the GPR (A4). It replaces that parameter's belief and zeroes its cross-covariances before
            the sigma points are drawn.
        """
        p = len(self._names)
        if sorted(model.parameter_names) != sorted(self._names):
            raise ValueError(f"UKF: the forward model's parameters {tuple(model.parameter_names)} are not the "
                             f"tuned parameters {self._names}")
        phi_cols = self._order(model.parameter_names, self._names, "parameter")
        theta_names = tuple(sea_state.names)
        unknown = sorted(set(self.process_noise) - set(self._names) - set(theta_names))
        if unknown:
            raise ValueError(f"UKF: process_noise names {unknown} are neither parameters nor sea-state components")
        theta_cols = self._order(model.sea_state_names, theta_names, "sea-state")
        z_cols = self._order(observation.names, tuple(model.names), "measurement")
        z = np.asarray(observation.z, dtype=float)
        if z.shape != (len(z_cols),) or not np.isfinite(z).all():
            raise ValueError(f"UKF: window {observation.window_id!r}: z must be {len(z_cols)} finite values")
        R = self.measurement_variance(observation)

        u, P_u = self.u_.copy(), self.P_u_.copy()
        for name, (mean, var) in (fresh or {}).items():
            if name not in self._names:
                raise ValueError(f"UKF: fresh value for unknown parameter {name!r}")
            if not var > 0:
                raise ValueError(f"UKF: fresh variance of {name!r} must be > 0, not {var}")
            i = self._names.index(name)
            phi = self._map.to_phi(u)
            phi[i] = mean
            u[i] = self._map.to_u(phi)[i]
            P_u[i, :] = P_u[:, i] = 0.0
            P_u[i, i] = var / self._map.dphi_du(u)[i] ** 2  # delta rule

        # Weather update, A6 eq. 1: [φ_k; θ'], P_φθ zeroed. Components with zero acquired variance are
        # used as known and stay out of the state (all zero: A7 form, N = p).
        theta_w = np.asarray(sea_state.mean, dtype=float).copy()
        cov_w = np.asarray(sea_state.cov, dtype=float)
        tuned = (np.diag(cov_w) > 0) & np.array([k in theta_cols for k in range(len(theta_names))], dtype=bool)
        x_w = np.concatenate([u, theta_w[tuned]])  # A6 eq. 1a
        P_w = np.zeros((x_w.size, x_w.size))
        P_w[:p, :p], P_w[p:, p:] = P_u, cov_w[np.ix_(tuned, tuned)]  # A6 eq. 1b
        q = np.concatenate([self._q_parameters(), self._q_sea_state(theta_names, cov_w)[tuned]])

        try:
            X, wm, wc = sigma_points(x_w, P_w, self.alpha, self.beta, self.kappa, self.sqrt_method)  # A6 eqs. 2–5
        except np.linalg.LinAlgError:
            raise ValueError(f"UKF: window {observation.window_id!r}: the sea-state covariance of "
                             f"{tuple(np.array(theta_names)[tuned])} is not positive definite") from None
        P_bar = P_w + np.diag(q**2)  # A6 eq. 6b; x̄ = x^w (6a): sigma points drawn before Q (digest §2.4)

        theta_sig = np.repeat(theta_w[None, :], X.shape[0], axis=0)
        theta_sig[:, tuned] = X[:, p:]
        Z = np.asarray(model.predict_paired(self._map.to_phi(X[:, :p])[:, phi_cols], theta_sig[:, theta_cols]))
        Z = Z[:, z_cols]  # A6 eq. 10: Z_i, (2N+1, J)
        if not np.isfinite(Z).all():
            raise ValueError(f"UKF: window {observation.window_id!r}: the forward model returned non-finite "
                             f"predictions at the sigma points (φ = {self._map.to_phi(u)}, θ = {theta_w})")

        # A6 eq. 11 about the centre point: with ΔZ_i = Z_i − Z_0, ΔX_i = X_i − x̄ and w = w_i (i ≥ 1),
        # Z̄ = Z_0 + Σ w ΔZ_i, P_z = Σ w ΔZ ΔZᵀ + (β − α²) δδᵀ + R (δ = Z̄ − Z_0), P_xz = Σ w ΔX (ΔZ − δ)ᵀ.
        w = wm[1]
        dX, dZ = X[1:] - x_w, Z[1:] - Z[0]
        delta = w * dZ.sum(axis=0)
        z_pred = Z[0] + delta  # eq. 11a
        P_z = w * dZ.T @ dZ + (wc[0] - wm[0] - 1.0) * np.outer(delta, delta) + np.diag(R)  # eq. 11c
        P_xz = w * dX.T @ (dZ - delta)  # eq. 11d
        try:
            K = np.linalg.solve(P_z, P_xz.T).T  # eq. 11e: K = P_xz P_z⁻¹
        except np.linalg.LinAlgError:
            K = P_xz @ np.linalg.pinv(P_z)
        y = z - z_pred  # eq. 11b
        x_new = x_w + K @ y  # eq. 11f
        P_new, repaired = _nearest_spd(P_bar - K @ P_z @ K.T, np.sqrt(np.diag(P_bar)))  # eq. 11g
        self.n_spd_repairs_ += int(repaired)

        beta_idx = [k for k, n in enumerate(np.array(theta_names)[tuned]) if n == BETA_NAME]
        x_new[[p + k for k in beta_idx]] %= 360.0  # the state may drift past 360° (digest §2.8)
        if BETA_NAME in theta_names:
            theta_w[theta_names.index(BETA_NAME)] %= 360.0

        self.u_, self.P_u_ = x_new[:p].copy(), P_new[:p, :p].copy()
        theta_w[tuned] = x_new[p:]
        theta_cov = cov_w.copy()  # components used as known, or unused by the model, keep P'_θ
        theta_cov[tuned, :] = theta_cov[:, tuned] = 0.0
        theta_cov[np.ix_(tuned, tuned)] = P_new[p:, p:]
        self.theta_, self.theta_cov_, self.theta_prior_cov_ = theta_w, theta_cov, cov_w.copy()
        self.state_names_ = self._names + tuple(np.array(theta_names)[tuned])
        self.x_, self.P_ = x_new, P_new
        self.innovation_, self.predicted_ = y, z_pred
        self.n_updates_ += 1
        self._used = tuple(observation.names)
        return self.posterior()

    def posterior(self) -> Posterior:
        """Current belief in φ (the prior before any update), with the last tuned sea state."""
        if self._map.any:
            mean, cov, quantiles = self._report_bounded()
        else:
            std = np.sqrt(np.diag(self.P_u_))
            mean, cov = self.u_.copy(), self.P_u_.copy()
            quantiles = {0.05: mean - _Z95 * std, 0.5: mean.copy(), 0.95: mean + _Z95 * std}
        return Posterior(names=self._names, mean=mean, cov=cov, quantiles=quantiles, used=self._used,
                         sea_state_mean=None if self.theta_ is None else self.theta_.copy(),
                         sea_state_cov=None if self.theta_cov_ is None else self.theta_cov_.copy())

    # ------------------------------------------------------------------ helpers
    def _report_bounded(self) -> tuple[np.ndarray, np.ndarray, dict[float, np.ndarray]]:
        """φ summary of the u-Gaussian: unscented transform with non-negative weights (α = 1, β = 0,
        κ = max(3 − p, 0): points ±√max(p, 3) σ, exact to 4th moments in 1-D, PSD cov), quantiles as images."""
        p = self.u_.size
        X, wm, wc = sigma_points(self.u_, self.P_u_, alpha=1.0, beta=0.0, kappa=max(3.0 - p, 0.0))
        F = self._map.to_phi(X)
        mean = wm @ F
        D = F - mean
        cov = (wc * D.T) @ D
        std_u = np.sqrt(np.diag(self.P_u_))
        quantiles = {0.05: self._map.to_phi(self.u_ - _Z95 * std_u), 0.5: self._map.to_phi(self.u_),
                     0.95: self._map.to_phi(self.u_ + _Z95 * std_u)}
        return mean, 0.5 * (cov + cov.T), quantiles

    def _q_parameters(self) -> np.ndarray:
        """Q std of the parameters in u: the φ-unit values mapped at the prior mean, where du/dφ = 1.

        Not at the current mean: du/dφ grows exponentially towards a bound, so a Q mapped there widens u
        without limit once data push a parameter against its bound (the mean then runs off to ±∞)."""
        return np.array([self.process_noise.get(p.name, DEFAULT_Q_FRACTION * p.prior_std) for p in self.parameters])

    def _q_sea_state(self, names: Sequence[str], cov: np.ndarray) -> np.ndarray:
        std = np.sqrt(np.maximum(np.diag(cov), 0.0))
        return np.array([self.process_noise.get(n, DEFAULT_Q_FRACTION * s) for n, s in zip(names, std, strict=True)])

    @staticmethod
    def _order(wanted: Sequence[str], have: Sequence[str], what: str) -> list[int]:
        """Index into `have` of every name in `wanted` (ValueError naming the missing ones)."""
        missing = [n for n in wanted if n not in have]
        if missing:
            raise ValueError(f"UKF: {what} names {missing} not found among {tuple(have)}")
        return [list(have).index(n) for n in wanted]

"""Discrete Bayesian inference (DBI) tuning backend (Han et al., papers A2, A4, A5 / thesis ch. 3).

The belief over the loading parameters φ is a joint probability mass function (PMF) on a fine tensor grid
(K_1 × … × K_M cells). Each sea state updates it (A2 §2, thesis eqs. 3.3–3.8, A4 eqs. 6 and 18):

1. A4 eq. 18: a sea-state-dependent parameter (β44 from the A4 Gaussian process) may get a fresh
   marginal; its old correlation with the other parameters is discarded.
2. A2 step 3, thesis eq. 3.4: the forward model predicts every statistic at every point of a coarse
   database grid (I_1 × … × I_M = R points, A2 eq. 7) and every sea-state hypothesis θ_s.
3. A2 eq. 9: a measurement whose prediction barely varies over the database is screened out.
4. A2 eq. 10 / thesis eq. 3.5 (inverse-distance weights) or a Gaussian likelihood with the sampling
   variance of the measured statistic; the hypotheses are mixed with their PMF (thesis eq. 3.7).
5. A2 step 6: interpolation from the database grid to the PMF grid (the weights, or for the Gaussian
   likelihood the predicted statistics; see below).
6. A2 eqs. 12–13, A4 eq. 6: posterior = NO(prior ⊙ likelihood).

Choices where the papers are silent, and deliberate deviations:

* Hypothesis mixing. Thesis eq. 3.7 mixes the hypotheses per sensor, W_j = Σ_s PMF(θ_s) W_{j,s}, then
  multiplies over sensors — as if every sensor saw its own sea state. All sensors see the same sea, so the
  default (``hypothesis_mixing="joint"``) is L = Σ_s PMF(θ_s) Π_j W_{j,s}; ``"per_sensor"`` is eq. 3.7.
  With one hypothesis the two agree.
* What is interpolated. A2 step 6 interpolates each sensor's inverse-distance weights, and the thesis each
  W_{j,s} before mixing; we keep that for the inverse-distance weights (linear, per sensor and hypothesis,
  multiplied / mixed on the PMF grid; mixing per sensor, eq. 3.7, is linear, so it is done on the database
  grid first — same result, S times fewer interpolations). The Gaussian likelihood instead interpolates the
  predicted statistics σ_{j,s}(φ) (as A6 does, digest A5–A7 §2.9) and forms log W = −(σ − z)²/(2v) on the PMF
  grid. σ is smooth and nearly linear between database points; a likelihood interpolated between them sags
  by up to h²·curvature/8, which once the posterior is narrower than the database spacing puts it on the
  database node that fits best (a 2-parameter A6 trial on the sample vessel ended on the node 4 m from the
  truth). Products and mixtures are formed in log space (log-sum-exp), so no cell underflows.
* ``interpolation="cubic"`` (not in A2): a tensor not-a-knot spline instead of the multilinear interpolant,
  of the predictions (Gaussian) — it follows the curvature of σ(φ) where the linear one cuts corners.
* Interpolation outside the database range takes the edge value (clamped). A2 does not say; the prior's
  ±3σ range can exceed the database range (β44, r55 in A2 Tables 6/18).
* The inverse-distance weights get a guard ε·|z_j| (relative, so unit-free) against |σ_pred − z| = 0, and
  are normalised to mean 1 over the database instead of sum 1 (A2 eq. 10's 𝒩): the factor R is the same
  for every sensor and hypothesis and cancels in NO(·).
* Screening (A2 eq. 9) uses the hypothesis-weighted mean prediction Σ_s PMF(θ_s) σ_{r,j,s}, one decision
  per sensor and sea state (the thesis, eq. 3.6, decides per sensor and hypothesis).
* The posterior over the sea-state hypotheses p(θ_s | z) ∝ PMF(θ_s) Σ_φ PMF(φ) L_s(φ), with L_s = Π_j W_{j,s}
  on the PMF grid, is reported whatever the mixing option (it is the only coherent posterior over θ). With
  the inverse-distance weights it carries little evidence: each W_{j,s} is normalised on its own (eq. 3.7),
  so a hypothesis that fits badly everywhere is not penalised.
* Two-step procedure (A4 §2.5, inverse-distance weights only): both posteriors start from the same joint
  prior; the sea-state-dependent parameters — those given a fresh marginal in this update — take their
  marginal from the posterior with p2, all others from the posterior with p. The stored joint is the
  product of the two (their correlation is discarded at the next update by A4 eq. 18 anyway).
* Grid size (not in A2, which tunes 2–3 parameters on 40 points each). ``pmf_points="auto"`` takes
  K = min(40, ⌊budget^(1/M)⌋) per axis, so five parameters use 18⁵ ≈ 1.9 M cells instead of 40⁵ ≈ 100 M
  (a 5-parameter tune grew past 14 GB and never finished).
* Grid zoom (``regrid=True``, not in A2; a point-mass filter's adaptive grid). After an update each axis
  whose posterior is much narrower than its grid is re-gridded to mean ± 6·std inside the prior
  range (at least ±2Δ), the log-PMF interpolated onto it by a cubic spline (exact for a Gaussian). When
  an update's posterior reaches the edge of a zoomed grid (edge-cell mass > 1e-3), the *prior* of that
  update is widened (×2, its log-PMF's edge parabola continued: a Gaussian tail) and the update made
  again. A coarse grid so keeps its resolution where the posterior lives. Axes given a fresh marginal
  (A4 eq. 18) keep the prior range.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import CubicSpline

from seatune.tuning.interface import ForwardModel, Observation, Parameter, Posterior, SeaState

__all__ = ["DBI", "QUANTILES", "auto_pmf_points", "cubic_interpolation_matrix", "discretised_gaussian",
           "interpolate_tensor", "linear_interpolation_matrix"]

QUANTILES = (0.05, 0.5, 0.95)
Likelihood = Literal["idw", "gaussian"]
Mixing = Literal["joint", "per_sensor"]
Interpolation = Literal["linear", "cubic"]


def linear_interpolation_matrix(nodes: ArrayLike, points: ArrayLike) -> np.ndarray:
    """1-D linear interpolation as a matrix: f(points) = M @ f(nodes).

    Parameters
    ----------
    nodes : (I,) strictly increasing
    points : (K,); points outside [nodes[0], nodes[-1]] take the edge value (clamped)

    Returns
    -------
    M : (K, I), at most two non-zeros per row, rows sum to 1
    """
    nodes = np.asarray(nodes, dtype=float)
    x = np.clip(np.asarray(points, dtype=float), nodes[0], nodes[-1])
    m = np.zeros((x.size, nodes.size))
    if nodes.size == 1:
        m[:, 0] = 1.0
        return m
    i = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    t = (x - nodes[i]) / (nodes[i + 1] - nodes[i])
    rows = np.arange(x.size)
    m[rows, i] = 1.0 - t
    m[rows, i + 1] += t
    return m


def cubic_interpolation_matrix(nodes: ArrayLike, points: ArrayLike) -> np.ndarray:
    """1-D not-a-knot cubic-spline interpolation as a matrix (K, I), clamped like the linear one.

    Not in A2: an option for the Gaussian log-likelihood, which is nearly quadratic in φ between database
    points — a spline follows it where the linear interpolant sags by h²·curvature/8 between the nodes.
    With 2 or 3 nodes the not-a-knot spline is the straight line / parabola through them.
    """
    nodes = np.asarray(nodes, dtype=float)
    x = np.clip(np.asarray(points, dtype=float), nodes[0], nodes[-1])
    return CubicSpline(nodes, np.eye(nodes.size), bc_type="not-a-knot")(x)


def interpolate_tensor(values: ArrayLike, matrices: Sequence[np.ndarray], dtype=float) -> np.ndarray:
    """Apply one matrix per axis: out[k_1…k_M] = Σ_i M_1[k_1, i_1] ⋯ M_M[k_M, i_M] values[i_1…i_M].

    Leading axes beyond the M interpolated ones are a batch: values (B…, I_1…I_M) → out (K_1…K_M, B…).

    With `linear_interpolation_matrix` per axis this is multilinear interpolation onto a tensor grid
    (A2 step 6). Each step contracts the trailing axis with one matrix product and puts the new axis in
    front, so after M steps (last axis first) the axes are back in order and no transposed copy is made.
    The product is (K_m × I_m) @ (I_m × rest): a wide result, which BLAS threads well (the transposed
    orientation, rest × K_m, ran 50× slower under multi-threaded OpenBLAS).
    """
    out = np.asarray(values, dtype=dtype)
    if out.ndim < len(matrices):
        raise ValueError(f"{out.ndim}-D values but {len(matrices)} interpolation matrices")
    for mat in reversed(matrices):
        trail = out.shape[-1]
        out = (mat @ out.reshape(-1, trail).T).reshape(mat.shape[0], *out.shape[:-1])
    return out


def discretised_gaussian(grid: ArrayLike, mean: float, std: float) -> np.ndarray:
    """PMF of N(mean, std²) on a uniform grid: PDF · Δ (A2 eq. 4), renormalised to sum 1."""
    g = np.asarray(grid, dtype=float)
    if not std > 0:
        raise ValueError(f"std must be > 0, got {std}")
    pmf = np.exp(-0.5 * ((g - mean) / std) ** 2)  # A2 eq. 2; 1/(σ√2π) and Δ cancel in the normalisation
    total = pmf.sum()
    if not total > 0:
        raise ValueError(f"N({mean}, {std}²) has no mass on the grid [{g[0]}, {g[-1]}]")
    return pmf / total


def _per_axis(value: int | Sequence[int], n: int, what: str) -> tuple[int, ...]:
    if isinstance(value, str):
        raise ValueError(f"{what}: {value!r} is not a size")
    sizes = (value,) * n if np.isscalar(value) else tuple(value)
    if len(sizes) != n:
        raise ValueError(f"{what}: {len(sizes)} values for {n} parameters")
    if any(int(s) != s or s < 2 for s in sizes):
        raise ValueError(f"{what}: every size must be an integer >= 2, got {sizes}")
    return tuple(int(s) for s in sizes)


def _logsumexp(a: np.ndarray, axis: int | None = None) -> np.ndarray:
    m = np.max(a, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.sum(np.exp(a - m), axis=axis, keepdims=True)) + m
    return out.squeeze() if axis is None else np.squeeze(out, axis=axis)


def _columns(have: Sequence[str], want: Sequence[str], what: str) -> np.ndarray:
    """Indices into `have` for each name of `want`."""
    missing = [n for n in want if n not in have]
    if missing:
        raise ValueError(f"{what}: {missing} not among {tuple(have)}")
    return np.array([list(have).index(n) for n in want], dtype=int)


class DBI:
    """Discrete Bayesian inference on a tensor grid of the loading parameters (A2 §2, A4 §2–4, thesis ch. 3).

    Parameters
    ----------
    parameters : the tuned parameters with their Gaussian priors and hard bounds
    database_points : I_m, points per parameter of the coarse grid the forward model is evaluated on (A2 eq. 7)
    pmf_points : K_m, points per parameter of the PMF grid (A2 step 1)
    likelihood : "gaussian" (calibrated, uses Observation.variance) or "idw" (A2 eq. 10)
    power : p of the inverse-distance weights (A2 eq. 10, thesis eq. 3.5)
    power_sea_state_dependent : p2 of A4's two-step procedure (idw only); None = one step
    screening_alpha : α0 of the sensor screening (A2 eq. 9, thesis eq. 3.6)
    model_error : relative model-error STD; the Gaussian variance is Observation.variance + (model_error·z)²
    hypothesis_mixing : "joint" (Σ_s PMF(θ_s) Π_j W_{j,s}, default) or "per_sensor" (thesis eq. 3.7)
    interpolation : "linear" (multilinear, A2 step 6) or "cubic" (tensor not-a-knot spline, gaussian only)
    epsilon : guard of the inverse-distance weights, relative to |z_j|

    Attributes
    ----------
    grids : per parameter, the PMF grid (K_m,)
    database_grids : per parameter, the database grid (I_m,)
    database_points : (R, M) every database combination, C order over the parameter axes
    joint_ : (K_1, …, K_M) current joint PMF
    alpha_ : {measurement name: α_j} of the last update
    sea_state_posterior_ : p(θ_s | z) of the last update, or None
    n_updates_ : number of updates so far
    """

    name = "dbi"

    def __init__(self, parameters: Sequence[Parameter], *, database_points: int | Sequence[int] = 7,
                 pmf_points: int | Sequence[int] | Literal["auto"] = 40, likelihood: Likelihood = "gaussian",
                 power: float = 0.4,
                 power_sea_state_dependent: float | None = None, screening_alpha: float = 0.05,
                 model_error: float = 0.0, hypothesis_mixing: Mixing = "joint", interpolation: Interpolation = "linear",
                 epsilon: float = 1e-9, pmf_budget: int = 2_000_000, regrid: bool = False):
        self.parameters = tuple(parameters)
        names = [p.name for p in self.parameters]
        if not names:
            raise ValueError("DBI needs at least one parameter")
        if len(set(names)) != len(names):
            raise ValueError(f"DBI: duplicate parameter names in {names}")
        if likelihood not in ("idw", "gaussian"):
            raise ValueError(f"likelihood must be 'idw' or 'gaussian', got {likelihood!r}")
        if hypothesis_mixing not in ("joint", "per_sensor"):
            raise ValueError(f"hypothesis_mixing must be 'joint' or 'per_sensor', got {hypothesis_mixing!r}")
        if interpolation not in ("linear", "cubic"):
            raise ValueError(f"interpolation must be 'linear' or 'cubic', got {interpolation!r}")
        if interpolation == "cubic" and likelihood != "gaussian":
            raise ValueError("interpolation='cubic' needs likelihood='gaussian' (a spline of the idw weights "
                             "overshoots at their cusps and can go negative)")
        if not power > 0:
            raise ValueError(f"power must be > 0, got {power}")
        if power_sea_state_dependent is not None:
            if not power_sea_state_dependent > 0:
                raise ValueError(f"power_sea_state_dependent must be > 0, got {power_sea_state_dependent}")
            if likelihood != "idw":
                raise ValueError("power_sea_state_dependent (A4 two-step) needs likelihood='idw'")
        if not screening_alpha >= 0:
            raise ValueError(f"screening_alpha must be >= 0, got {screening_alpha}")
        if not model_error >= 0:
            raise ValueError(f"model_error must be >= 0, got {model_error}")
        if not epsilon > 0:
            raise ValueError(f"epsilon must be > 0, got {epsilon}")
        self.likelihood = likelihood
        self.power = float(power)
        self.power_sea_state_dependent = power_sea_state_dependent
        self.screening_alpha = float(screening_alpha)
        self.model_error = float(model_error)
        self.hypothesis_mixing = hypothesis_mixing
        self.interpolation = interpolation
        self.epsilon = float(epsilon)

        m = len(self.parameters)
        if isinstance(pmf_points, str) and pmf_points == "auto":
            pmf_points = auto_pmf_points(m, pmf_budget)
        self.pmf_points = _per_axis(pmf_points, m, "pmf_points")
        self.regrid = bool(regrid)
        self._fresh_axes: set[int] = set()
        self.database_points_per_axis = _per_axis(database_points, m, "database_points")
        # A2 step 1: μ ± 3σ, clipped to the hard bounds ("unrealistic values are removed").
        ranges = [(max(p.lower, p.prior_mean - 3 * p.prior_std), min(p.upper, p.prior_mean + 3 * p.prior_std))
                  for p in self.parameters]
        self.prior_ranges = tuple(ranges)
        self.grids = tuple(np.linspace(lo, hi, k) for (lo, hi), k in zip(ranges, self.pmf_points, strict=True))
        self.database_grids = tuple(np.linspace(lo, hi, i)
                                    for (lo, hi), i in zip(ranges, self.database_points_per_axis, strict=True))
        mesh = np.meshgrid(*self.database_grids, indexing="ij")
        self.database_points = np.stack([g.ravel() for g in mesh], axis=1)  # (R, M), A2 eq. 7
        self._set_grids(self.grids)

        # A2 eqs. 2–4: independent Gaussian priors, joint = product of the discretised marginals.
        marginals = [discretised_gaussian(g, p.prior_mean, p.prior_std) for g, p in zip(self.grids, self.parameters,
                                                                                       strict=True)]
        self.joint_ = self._outer(marginals)
        self.alpha_: dict[str, float] = {}
        self.sea_state_posterior_: np.ndarray | None = None
        self.hs_scale_: float | None = None
        self.n_updates_ = 0
        self._summary: Posterior | None = None

    # ------------------------------------------------------------------ public

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    def gaussian_pmf(self, name: str, mean: float, std: float) -> np.ndarray:
        """A Gaussian discretised on `name`'s PMF grid (A4 §2.4 step 1: the GPR prediction as a PMF)."""
        return discretised_gaussian(self.grids[self._axis(name)], mean, std)

    def replace_marginals(self, fresh: Mapping[str, ArrayLike]) -> tuple[int, ...]:
        """A4 eq. 18: joint ← (marginal of the other parameters) ⊗ fresh PMFs; returns the replaced axes."""
        axes = tuple(self._axis(n) for n in fresh)
        pmfs = []
        for name, axis in zip(fresh, axes, strict=True):
            pmf = np.asarray(fresh[name], dtype=float)
            if pmf.shape != (self.pmf_points[axis],):
                raise ValueError(f"fresh marginal '{name}': shape {pmf.shape}, grid has {self.pmf_points[axis]} "
                                 "points")
            if not (np.all(np.isfinite(pmf)) and np.all(pmf >= 0) and pmf.sum() > 0):
                raise ValueError(f"fresh marginal '{name}' must be finite, >= 0 and not all zero")
            pmfs.append(pmf / pmf.sum())
        joint = self.joint_.sum(axis=axes, keepdims=True)  # A4 eq. 20: marginal of the others
        for axis, pmf in zip(axes, pmfs, strict=True):
            joint = joint * self._along(pmf, axis)
        self.joint_ = joint / joint.sum()
        self._summary = None
        return axes

    def update(self, model: ForwardModel, observation: Observation, sea_state: SeaState,
               fresh_marginals: Mapping[str, ArrayLike] | None = None) -> Posterior:
        """Assimilate one window (A2 steps 3–7 with the thesis' hypotheses θ_s and A4 eq. 18).

        fresh_marginals : {parameter name: PMF on its grid} replacing that marginal before the update; these
        parameters are the sea-state-dependent ones of the two-step procedure.
        Returns the posterior summary; `used` lists the measurements that passed screening, and
        `sea_state_mean` / `sea_state_cov` summarise p(θ_s | z) when there are several hypotheses.
        """
        dependent = self.replace_marginals(fresh_marginals) if fresh_marginals else ()
        names, z, variance, predicted = self._predict(model, observation, sea_state)
        hyp_weights = np.asarray(sea_state.weights, dtype=float)
        if hyp_weights.shape != (predicted.shape[1],) or np.any(hyp_weights < 0) or not hyp_weights.sum() > 0:
            raise ValueError(f"sea state: {hyp_weights.shape} weights for {predicted.shape[1]} hypotheses, "
                             "must be >= 0 and not all zero")
        hyp_weights = hyp_weights / hyp_weights.sum()

        # A2 eq. 9 (thesis eq. 3.6): α_j = STD over the database of the predicted statistic / measured one.
        mean_prediction = np.einsum("rsj,s->rj", predicted, hyp_weights)
        alpha = mean_prediction.std(axis=0, ddof=1) / np.maximum(np.abs(z), np.finfo(float).tiny)
        self.alpha_ = dict(zip(names, alpha.tolist(), strict=True))
        total = observation.variance_is_total
        keep = alpha > 0 if total else alpha >= self.screening_alpha
        used = tuple(n for n, k in zip(names, keep, strict=True) if k)

        sea_post, scale = None, None
        if keep.any():
            predicted, z, variance = predicted[..., keep], z[keep], variance[keep]
            scaled, r2 = self._common_scale(used, z, observation, sea_state)
            for _ in range(_MAX_WIDENINGS + 1):
                log_prior = self._log(self.joint_)
                log_like, log_evidence, scale = self._log_likelihood(predicted, z, variance, hyp_weights,
                                                                     self.power, log_prior, scaled, r2, total)
                posterior = self._bayes(log_prior, log_like)  # A2 eqs. 12–13, A4 eq. 6
                if not (self.regrid and self._regrid(posterior, widen_prior=True)):
                    break  # else the prior was widened where the posterior reached a zoomed edge: again
            p2 = self.power_sea_state_dependent
            if p2 is not None and dependent:
                # A4 §2.5 two-step: same prior, p2 for the sea-state-dependent marginals, p for the others.
                log_like_2, _, _ = self._log_likelihood(predicted, z, variance, hyp_weights, p2, None, total=total)
                posterior_2 = self._bayes(log_prior, log_like_2)
                joint = posterior.sum(axis=dependent, keepdims=True)
                for axis in dependent:
                    joint = joint * self._along(self._marginal(posterior_2, axis), axis)
                posterior = joint / joint.sum()
            self.joint_ = posterior
            if predicted.shape[1] > 1:  # p(θ_s | z) ∝ PMF(θ_s) Σ_φ PMF(φ) L_s(φ) (with p, not p2)
                with np.errstate(divide="ignore"):
                    log_post = np.log(hyp_weights) + log_evidence
                sea_post = np.exp(log_post - _logsumexp(log_post))
        elif predicted.shape[1] > 1:
            sea_post = hyp_weights  # nothing informative: the hypotheses keep their prior PMF
        self.sea_state_posterior_ = sea_post
        self.n_updates_ += 1
        self.hs_scale_ = scale
        self._summary = self._summarise(used, sea_state, sea_post, scale)
        self._fresh_axes.update(dependent)
        if self.regrid and keep.any():
            self._regrid(self.joint_)  # after the summary, which stays on the grid the update was made on
        return self._summary

    def posterior(self) -> Posterior:
        """Current belief (the prior before any update)."""
        if self._summary is None:
            self._summary = self._summarise((), None, None)
        return self._summary

    # ------------------------------------------------------------------ likelihood

    def _predict(self, model: ForwardModel, observation: Observation, sea_state: SeaState):
        """Predicted statistics at every database point and hypothesis: (R, S, J) for the finite measurements."""
        z = np.asarray(observation.z, dtype=float)
        variance = np.asarray(observation.variance, dtype=float)
        names = tuple(observation.names)
        finite = np.isfinite(z)  # a missing statistic is skipped, not an error
        param_cols = _columns(self.names, getattr(model, "parameter_names", self.names), "forward model parameters")
        if len(param_cols) != len(self.names):
            raise ValueError(f"forward model parameters {model.parameter_names} differ from DBI's {self.names}")
        theta = np.asarray(sea_state.points, dtype=float)
        model_sea = getattr(model, "sea_state_names", sea_state.names)
        theta = theta[:, _columns(sea_state.names, model_sea, "sea-state names the model needs")]
        predicted = np.asarray(model.predict(self.database_points[:, param_cols], theta), dtype=float)
        model_names = getattr(model, "names", names)
        if predicted.shape != (len(self.database_points), theta.shape[0], len(model_names)):
            raise ValueError(f"forward model returned shape {predicted.shape}, expected "
                             f"{(len(self.database_points), theta.shape[0], len(model_names))}")
        predicted = predicted[..., _columns(model_names, names, "measurements the model predicts")]
        keep = np.flatnonzero(finite)
        if not np.all(np.isfinite(predicted[..., keep])):
            raise ValueError("forward model returned non-finite predictions on the database grid")
        return tuple(names[k] for k in keep), z[keep], variance[keep], predicted[..., keep]

    def _gaussian_variance(self, z: np.ndarray, variance: np.ndarray, total: bool = False) -> np.ndarray:
        v = variance if total else variance + (self.model_error * z) ** 2
        bad = ~(v > 0)
        if np.any(bad):
            raise ValueError(f"gaussian likelihood needs a positive variance; got {v[bad]} "
                             "(set model_error > 0 or use likelihood='idw')")
        return v

    def _log_weights(self, predicted: np.ndarray, z: np.ndarray, variance: np.ndarray, power: float) -> np.ndarray:
        """log W_{r,s,j} on the database grid, (R, S, J)."""
        if self.likelihood == "gaussian":
            return -((predicted - z) ** 2) / (2.0 * self._gaussian_variance(z, variance))
        lw = -power * np.log(np.abs(predicted - z) + self.epsilon * np.abs(z))  # A2 eq. 10, thesis eq. 3.5
        return lw - (_logsumexp(lw, axis=0) - np.log(lw.shape[0]))  # 𝒩(·) over the database, to mean 1

    def _grid_log_likelihood(self, log_w: np.ndarray) -> np.ndarray:
        """log Π_j W_j on the PMF grid from log W_j on the database grid, (R, J) → (K_1, …, K_M)."""
        shape = self.database_points_per_axis
        if self.likelihood == "gaussian":  # per-sensor mixing only: Σ_j interp(log W_j) = interp(Σ_j log W_j)
            return interpolate_tensor(log_w.sum(axis=1).reshape(shape), self._to_pmf)
        scale = log_w.max(axis=0)  # each sensor's weights interpolated as in A2 step 6, then multiplied
        product = None
        for j in range(log_w.shape[1]):
            w = interpolate_tensor(np.exp(log_w[:, j] - scale[j]).reshape(shape), self._to_pmf)
            product = w if product is None else np.multiply(product, w, out=product)
        with np.errstate(divide="ignore"):
            return np.log(product) + scale.sum()

    def _gaussian_grid_log_likelihood(self, predicted: np.ndarray, z: np.ndarray, v: np.ndarray, scaled: np.ndarray,
                                      r2: float) -> tuple[np.ndarray, np.ndarray | None]:
        """Gaussian log-likelihood on the PMF grid with σ_j interpolated from the database, (R, J) → (K…).

        With a common scale error (r2 > 0): z = a·σ + e, a ~ N(1, r2) for the σ measurements (`scaled`), e ~
        N(0, diag v); marginalised by Sherman–Morrison with A = Σ d²/v, B = Σ σd/v, C = Σ σ²/v (d = z − σ):
        log L = −½ [A − r2 B²/(1 + r2 C)] − ½ log(1 + r2 C). Also returns E[a | z, φ] = 1 + B/(1/r2 + C)."""
        # float32: σ keeps 7 digits, so (σ − z)²/v errs by < 1e-3 where the posterior lives (2.5× faster)
        on_grid = interpolate_tensor(predicted.T.reshape(-1, *self.database_points_per_axis), self._to_pmf32,
                                     dtype=np.float32)
        d = z.astype(np.float32) - on_grid  # (K…, J)
        inv_v = (1.0 / v).astype(np.float32)
        a = ((d * d) @ inv_v).astype(float)
        if not r2 > 0:
            return -0.5 * a, None
        w = np.where(scaled, inv_v, 0.0).astype(np.float32)
        b = ((on_grid * d) @ w).astype(float)
        c = ((on_grid * on_grid) @ w).astype(float)
        return -0.5 * (a - r2 * b * b / (1.0 + r2 * c)) - 0.5 * np.log1p(r2 * c), 1.0 + b / (1.0 / r2 + c)

    def _log_likelihood(self, predicted, z, variance, hyp_weights, power, log_prior, scaled=None, r2=0.0,
                        total=False):
        """Mixed log-likelihood on the PMF grid; given the log prior, also log Σ_φ PMF(φ) L_s(φ) per hypothesis
        θ_s (for p(θ_s | z)) and, with a common scale error, its posterior mean E[a | z]. `total`: the variance
        is the whole error (Gaussian, no model error, whatever the likelihood setting)."""
        n_hyp = predicted.shape[1]
        joint = self.hypothesis_mixing == "joint" or n_hyp == 1 or total
        if (self.likelihood == "gaussian" or total) and joint:
            v = self._gaussian_variance(z, variance, total)

            def grid_ll(s):
                return self._gaussian_grid_log_likelihood(predicted[:, s, :], z, v, scaled, r2)
        else:
            log_w = self._log_weights(predicted, z, variance, power)

            def grid_ll(s):
                return self._grid_log_likelihood(log_w[:, s, :]), None
        with np.errstate(divide="ignore"):
            log_pi = np.log(hyp_weights)
        log_like, log_evidence, scale_means = None, np.full(n_hyp, -np.inf), np.full(n_hyp, np.nan)
        if joint or log_prior is not None:
            for s in np.flatnonzero(hyp_weights > 0):
                log_l_s, a_hat = grid_ll(s)  # log Π_j W_{j,s} on the PMF grid
                if log_prior is not None:
                    log_post_s = log_prior + log_l_s
                    log_evidence[s] = _logsumexp(log_post_s)
                    if a_hat is not None:
                        scale_means[s] = np.sum(np.exp(log_post_s - log_evidence[s]) * a_hat)
                if joint:  # L = Σ_s PMF(θ_s) Π_j W_{j,s}
                    log_l_s += log_pi[s]
                    log_like = log_l_s if log_like is None else np.logaddexp(log_like, log_l_s, out=log_like)
        if not joint:  # thesis eq. 3.7: W_j = Σ_s PMF(θ_s) W_{j,s}, mixed on the database grid (linear in W)
            log_like = self._grid_log_likelihood(_logsumexp(log_w + log_pi[None, :, None], axis=1))
        if log_prior is None:
            return log_like, None, None
        log_sea = log_pi + log_evidence
        sea_weights = np.exp(log_sea - _logsumexp(log_sea))
        scale = float(sea_weights @ np.nan_to_num(scale_means)) if np.isfinite(scale_means).any() else None
        return log_like, log_evidence, scale

    @staticmethod
    def _common_scale(names, z, observation: Observation, sea_state: SeaState) -> tuple[np.ndarray, float]:
        """Which measurements scale with Hs (σ, not Tz) and the variance r2 of their common relative error:
        the observation's common sampling factor, plus the hindcast's Hs uncertainty when the hypotheses do not
        vary Hs (σ ∝ Hs, so it is marginalised exactly instead of by discrete points)."""
        scaled = np.array([n.endswith(":sigma") for n in names])
        if not scaled.any():
            return scaled, 0.0
        r2 = float(observation.common_scale_variance)
        if "hs" in sea_state.names:
            k = sea_state.names.index("hs")
            hs = np.asarray(sea_state.points, dtype=float)[:, k]
            if np.ptp(hs) == 0 and hs[0] > 0:
                r2 += float(np.asarray(sea_state.cov, dtype=float)[k, k]) / hs[0] ** 2
        return scaled, r2

    @staticmethod
    def _bayes(log_prior: np.ndarray, log_like: np.ndarray) -> np.ndarray:
        """NO(prior ⊙ likelihood), formed in log space (A2 eq. 12, A4 eq. 6)."""
        log_post = log_prior + log_like
        top = log_post.max()
        if not np.isfinite(top):
            raise ValueError("DBI: the posterior vanished on the whole grid (prior and likelihood do not overlap)")
        log_post -= top
        post = np.exp(log_post, out=log_post)
        return post / post.sum()

    # ------------------------------------------------------------------ summary

    def _summarise(self, used: tuple[str, ...], sea_state: SeaState | None, sea_post: np.ndarray | None,
                   scale: float | None = None) -> Posterior:
        joint, m = self.joint_, len(self.parameters)
        marginals = [self._marginal(joint, a) for a in range(m)]
        mean = np.array([g @ p for g, p in zip(self.grids, marginals, strict=True)])  # A4 eq. 19b
        cov = np.diag([((g - mu) ** 2) @ p for g, p, mu in zip(self.grids, marginals, mean, strict=True)])
        for a in range(m):  # off-diagonal terms from the pairwise marginals of the joint PMF
            for b in range(a + 1, m):
                pair = joint.sum(axis=tuple(k for k in range(m) if k not in (a, b)))
                cov[a, b] = cov[b, a] = (self.grids[a] - mean[a]) @ pair @ (self.grids[b] - mean[b])
        quantiles = {q: np.array([_quantile(g, p, q) for g, p in zip(self.grids, marginals, strict=True)])
                     for q in QUANTILES}
        sea_mean = sea_cov = None
        if sea_state is not None and (sea_post is not None or scale is not None):
            theta = _unwrap_angles(np.asarray(sea_state.points, dtype=float), sea_state.names, sea_state.mean)
            if scale is not None:  # the common scale a multiplies Hs (E[a | z] from the Gaussian likelihood)
                theta[:, sea_state.names.index("hs")] *= scale
            weights = sea_post if sea_post is not None else np.ones(1)
            sea_mean = weights @ theta
            d = theta - sea_mean
            sea_cov = (d * weights[:, None]).T @ d
        return Posterior(names=self.names, mean=mean, cov=cov, quantiles=quantiles, used=used,
                         sea_state_mean=sea_mean, sea_state_cov=sea_cov,
                         marginals={n: (g.copy(), p) for n, g, p in zip(self.names, self.grids, marginals,
                                                                        strict=True)})

    # ------------------------------------------------------------------ grid zoom

    def _set_grids(self, grids: Sequence[np.ndarray]) -> None:
        self.grids = tuple(np.asarray(g, dtype=float) for g in grids)
        matrix = linear_interpolation_matrix if self.interpolation == "linear" else cubic_interpolation_matrix
        self._to_pmf = [matrix(d, g) for d, g in zip(self.database_grids, self.grids, strict=True)]
        self._to_pmf32 = [m.astype(np.float32) for m in self._to_pmf]

    def _zoomed_range(self, axis: int, pmf: np.ndarray) -> tuple[float, float] | None:
        """Where axis `axis` should be zoomed to from its posterior marginal `pmf`, or None to keep it."""
        grid = self.grids[axis]
        lo0, hi0 = self.prior_ranges[axis]
        mean = float(grid @ pmf)
        # a posterior narrower than a cell shows a std near 0 but lies within about ±Δ of its cell
        half = max(_ZOOM_SIGMAS * float(np.sqrt(((grid - mean) ** 2) @ pmf)), 2.0 * (grid[1] - grid[0]))
        if 2 * half > _ZOOM_WHEN * (grid[-1] - grid[0]):
            return None
        return max(lo0, mean - half), min(hi0, mean + half)

    def _widened_range(self, axis: int, pmf: np.ndarray) -> tuple[float, float] | None:
        """A range twice as wide around the posterior mean if it reaches an edge inside the prior range."""
        grid = self.grids[axis]
        lo0, hi0 = self.prior_ranges[axis]
        if not ((pmf[0] > _EDGE_MASS and grid[0] > lo0) or (pmf[-1] > _EDGE_MASS and grid[-1] < hi0)):
            return None
        mean, width = float(grid @ pmf), grid[-1] - grid[0]
        return max(lo0, min(grid[0], mean - width)), min(hi0, max(grid[-1], mean + width))

    def _regrid(self, posterior: np.ndarray, widen_prior: bool = False) -> bool:
        """Zoom each axis onto `posterior` (the current joint), or, with widen_prior, widen the axes where the
        posterior reaches a zoomed edge and re-grid the prior (the current joint) onto them, so the update can
        be made again. Axes given fresh marginals keep the prior range. Returns whether a grid changed."""
        grids = list(self.grids)
        log_joint = self._log(self.joint_)
        changed = False
        for axis, grid in enumerate(self.grids):
            if axis in self._fresh_axes:
                continue
            marginal = self._marginal(posterior, axis)
            new_range = self._widened_range(axis, marginal) if widen_prior else self._zoomed_range(axis, marginal)
            if new_range is None:
                continue
            new = np.linspace(*new_range, grid.size)
            log_joint = np.moveaxis(_log_interpolate(grid, np.moveaxis(log_joint, axis, -1), new), -1, axis)
            grids[axis], changed = new, True
        if changed:
            log_joint -= log_joint.max()
            joint = np.exp(log_joint)
            self.joint_ = joint / joint.sum()
            self._set_grids(grids)
        return changed

    # ------------------------------------------------------------------ helpers

    def _axis(self, name: str) -> int:
        if name not in self.names:
            raise ValueError(f"unknown parameter '{name}'; DBI tunes {self.names}")
        return self.names.index(name)

    def _along(self, vector: np.ndarray, axis: int) -> np.ndarray:
        shape = [1] * len(self.parameters)
        shape[axis] = vector.size
        return vector.reshape(shape)

    def _outer(self, vectors: Sequence[np.ndarray]) -> np.ndarray:
        joint = np.ones((1,) * len(vectors))
        for axis, v in enumerate(vectors):
            joint = joint * self._along(v, axis)
        return joint / joint.sum()

    @staticmethod
    def _marginal(joint: np.ndarray, axis: int) -> np.ndarray:
        return joint.sum(axis=tuple(k for k in range(joint.ndim) if k != axis))  # A4 eqs. 19a, 20

    @staticmethod
    def _log(pmf: np.ndarray) -> np.ndarray:
        with np.errstate(divide="ignore"):
            return np.log(pmf)


_EDGE_MASS = 1e-3  # a zoomed axis whose edge cell holds more posterior mass than this is widened
_ZOOM_SIGMAS = 6.0  # a zoomed grid spans mean ± this many posterior STDs (at least ± 2 cells)
_LOG_FLOOR = 60.0  # nats below the peak where the log-PMF is floored before it is re-gridded
_MAX_WIDENINGS = 4  # times one update may widen its prior's grid and start again
_ZOOM_WHEN = 0.5  # zoom only when the new grid is at most this fraction of the current one


def auto_pmf_points(n_parameters: int, budget: int = 2_000_000, most: int = 40) -> int:
    """Points per axis so the PMF grid holds at most `budget` cells (and at most `most` per axis, A2's 40)."""
    k = int(np.floor(budget ** (1.0 / n_parameters) + 1e-9))
    return max(3, min(most, k))


def _log_interpolate(grid: np.ndarray, log_values: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Log-PMF values along the last axis at `points`: a not-a-knot cubic spline inside the grid (exact for a
    Gaussian, whose log is quadratic; a linear one loses h²·curvature/8 nats between cells that a narrow
    posterior undersamples). Beyond the grid, the parabola through the three edge cells (a Gaussian tail
    continued; a convex one is taken as straight), capped at the edge value (no belief is invented).
    Values more than 60 nats below the peak (e⁻⁶⁰ of the mass) are floored there so the spline does not ring."""
    top = np.max(log_values)
    floored = np.maximum(np.where(np.isfinite(log_values), log_values, -np.inf), top - _LOG_FLOOR)
    inside = (points >= grid[0]) & (points <= grid[-1])
    out = np.empty((*floored.shape[:-1], points.size))
    out[..., inside] = np.minimum(CubicSpline(grid, floored, axis=-1)(points[inside]), top)
    h = grid[1] - grid[0]
    for beyond, side in ((points < grid[0], 1), (points > grid[-1], -1)):
        if beyond.any():  # f(u) = f0 + a·u + ½c·u², u outward from the edge, fitted to the 3 edge cells
            f0, f1, f2 = (floored[..., ::side][..., k, None] for k in range(3))
            c = np.minimum((f0 - 2 * f1 + f2) / h**2, 0.0)  # log-concave tails only
            a = (f0 - f1) / h + 0.5 * c * h
            u = np.abs(points[beyond] - grid[0 if side == 1 else -1])
            out[..., beyond] = np.minimum(f0 + a * u + 0.5 * c * u**2, f0)
    return out


def _quantile(grid: np.ndarray, pmf: np.ndarray, q: float) -> float:
    """q-quantile of a PMF on a uniform grid, each mass spread over its cell (CDF linear between grid points)."""
    cdf = np.cumsum(pmf) - 0.5 * pmf  # the cell-histogram CDF at the grid points
    return float(np.interp(q, cdf, grid))


def _unwrap_angles(theta: np.ndarray, names: Sequence[str], centre: np.ndarray) -> np.ndarray:
    """Directions in degrees (names ending in _deg) moved into (centre − 180, centre + 180]."""
    out = theta.copy()
    for k, name in enumerate(names):
        if name.endswith("_deg"):
            out[:, k] = centre[k] - np.mod(centre[k] - theta[:, k] + 180.0, 360.0) + 180.0
    return out

"""Sea-state-dependent roll damping β44 by Gaussian-process regression (paper A4).

Paper A4 (Han, Sævik, Leira, *Tuning of vessel parameters including sea state dependent roll damping*,
Ocean Eng. 233 (2021) 109084) tunes the extra roll damping β44 (fraction of critical) separately in every
sea state and carries what it learnt to the next sea state through a GPR over two sea-state inputs,
x = (Hs·sin β_W, ω_p) (A4 eq. 22a). Per sea state SS_n (A4 §4.1, Fig. 3):

1. :meth:`DampingGPR.predict` at x(SS_n) gives β44's mean and std from SS_1 … SS_{n−1};
   :meth:`DampingGPR.pmf_on` turns them into the β44 prior PMF on the tuning grid (step 1);
2. the backend (DBI / UKF, `seatune.tuning.interface`) tunes β44 jointly with the other parameters;
3. :meth:`DampingGPR.add` stores the posterior mean and variance of β44 as a noisy sample (step 5).

The GPR is stochastic kriging with fixed hyperparameters (A4 §3, §5, Table 5): an anisotropic RBF with
σ_f = 0.02 and length scales (0.7 m, 0.2 rad/s), prior N(0.07, 0.02²), and each sample's noise variance
equal to that sample's posterior variance. It is scikit-learn's ``GaussianProcessRegressor`` with a fixed
``ConstantKernel × RBF``, ``optimizer=None`` and ``alpha`` = the per-sample variances, fitted on y − prior
mean — the configuration the digest confirmed against A4 Table A.6 (digest §2.8b; reproduced in
``tests/test_damping_gpr.py``).

Choices where A4 is silent, and deviations:

* x1 = Hs·|sin β|, not Hs·sin β. A4 only meets β_W ∈ [30°, 150°], where sin β_W > 0. In DESIGN §3 (β the
  direction the waves travel towards, counter-clockwise from body +x) a beam sea is β = 90° *or* 270°, and
  for a port–starboard symmetric hull waves from port excite roll as waves from starboard do, so β and
  −β must give the same damping. The abs() is that symmetric extension; on A4's range it changes nothing.
* A4 step 1 asks for a Gaussian PMF at the grid points without saying how it is discretised. We use A4
  eq. 7, PMF = PDF · ΔΦ: the Gaussian density at each node times the node's cell width (cell edges half
  way between nodes, the end cells reaching half a spacing beyond the end nodes), then normalised to
  sum 1. On a uniform grid that is the normalised density at the nodes. Point sampling
  keeps the mean and variance of the Gaussian (no h²/12 Sheppard term, as cell-integrated CDF differences
  would add); only the truncation at the grid ends removes mass (variance about −1e-3 relative at ±4σ).
* Table A.6 prints the *unconditioned* prior variance at SS2 and SS3 (digest §2.8b, PART 5 #10), as if
  A4 only refit after three samples. We condition on every sample from the first one; the means agree
  (the first samples equal the prior mean), the SS2/SS3 variances do not (3.6e-4, 1.9e-4 vs 4.0e-4).
* A4 eq. 17 (log marginal likelihood) is not used: like A4, the hyperparameters are fixed.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel

__all__ = [
    "A4_LENGTH_SCALES",
    "A4_PRIOR_MEAN",
    "A4_SIGMA_F",
    "INPUT_NAMES",
    "DampingGPR",
    "gpr_inputs",
]

A4_PRIOR_MEAN = 0.07  # β44 prior mean [-], A4 eq. 23
A4_SIGMA_F = 0.02  # prior std = kernel signal std σ_f [-], A4 eq. 23 and Table 5 (σ_f² = 0.02²)
A4_LENGTH_SCALES = (0.7, 0.2)  # l(Hs·sin β_W) [m], l(ω_p) [rad/s], A4 §5 and Table 5
INPUT_NAMES = ("hs_sin_beta", "omega_p")  # the two GPR inputs, units m and rad/s (A4 eq. 22a)


def gpr_inputs(hs: ArrayLike, tp: ArrayLike, beta_deg: ArrayLike) -> np.ndarray:
    """GPR inputs of A4 eq. 22a for one or more sea states.

    Parameters
    ----------
    hs : significant wave height Hs [m], ≥ 0.
    tp : peak period Tp [s], > 0.
    beta_deg : model wave direction β [deg] (DESIGN §3: travelling towards, counter-clockwise from body +x;
        90° and 270° are both beam seas).

    The three broadcast against each other; the result has one row per broadcast element.

    Returns
    -------
    (n, 2) array: column 0 is x1 = Hs·|sin β| [m], column 1 is x2 = ω_p = 2π/Tp [rad/s]. The abs() makes
    waves from port and from starboard the same input (module docstring; A4 only has sin β_W > 0).
    """
    hs, tp, beta = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (hs, tp, beta_deg)))
    if not np.all(np.isfinite(hs)) or np.any(hs < 0):
        raise ValueError("hs: significant wave height must be finite and >= 0 (metres)")
    if not np.all(np.isfinite(tp)) or np.any(tp <= 0):
        raise ValueError("tp: peak period must be finite and > 0 (seconds)")
    if not np.all(np.isfinite(beta)):
        raise ValueError("beta_deg: wave direction must be finite (degrees)")
    x1 = hs * np.abs(np.sin(np.radians(beta)))  # Hs·|sin β_W|, A4 eq. 22a (abs: port/starboard symmetry)
    x2 = 2.0 * np.pi / tp  # ω_p = 2π/Tp, A4 §5
    return np.column_stack([x1.ravel(), x2.ravel()])


def _as_points(x: ArrayLike, name: str = "x") -> np.ndarray:
    """(2,) or (n, 2) → (n, 2) finite float array."""
    pts = np.atleast_2d(np.asarray(x, dtype=float))
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ValueError(f"{name}: expected shape (2,) or (n, 2) of (Hs·|sin β| [m], ω_p [rad/s]), "
                         f"got {np.shape(x)}")
    if not np.all(np.isfinite(pts)):
        raise ValueError(f"{name}: GPR inputs must be finite")
    return pts


class DampingGPR:
    """GPR of β44 over (Hs·|sin β|, ω_p) with fixed hyperparameters (A4 §3, §5).

    Parameters
    ----------
    prior_mean : prior mean of β44 [-] everywhere in the input space (A4 eq. 23).
    sigma_f : prior std of β44 [-], the kernel's signal std (A4 eq. 11, 23).
    length_scales : RBF length scales (l for Hs·|sin β| [m], l for ω_p [rad/s]) (A4 §5: 10–20 % of each range).

    Samples are added one sea state at a time with :meth:`add`; the sklearn model is refit lazily, on the
    next prediction. With no samples every prediction is the prior (prior_mean, sigma_f).
    """

    def __init__(
        self,
        prior_mean: float = A4_PRIOR_MEAN,
        sigma_f: float = A4_SIGMA_F,
        length_scales: Sequence[float] = A4_LENGTH_SCALES,
    ):
        if not np.isfinite(prior_mean):
            raise ValueError("prior_mean: must be finite")
        if not (np.isfinite(sigma_f) and sigma_f > 0):
            raise ValueError("sigma_f: must be finite and > 0")
        ls = np.asarray(length_scales, dtype=float)
        if ls.shape != (2,) or not np.all(np.isfinite(ls)) or np.any(ls <= 0):
            raise ValueError("length_scales: expected two finite values > 0 (Hs·|sin β| [m], ω_p [rad/s])")
        self.prior_mean = float(prior_mean)
        self.sigma_f = float(sigma_f)
        self.length_scales = (float(ls[0]), float(ls[1]))
        self._x = np.empty((0, 2))
        self._mean = np.empty(0)
        self._var = np.empty(0)
        self._gpr: GaussianProcessRegressor | None = None

    # ---------------------------------------------------------------------------------------------
    # samples
    # ---------------------------------------------------------------------------------------------

    def add(self, x: ArrayLike, mean: float, variance: float) -> None:
        """Append one sea state's tuned β44 posterior as a noisy sample (A4 §4.1 step 5).

        x : (2,) GPR input of the sea state (:func:`gpr_inputs`).
        mean : posterior mean of β44 [-] (A4 eq. 19b), the sample value ỹ.
        variance : posterior variance of β44 [-²] (A4 eq. 19c squared), the sample's noise σ_y² (> 0).
        """
        pts = _as_points(x)
        if pts.shape[0] != 1:
            raise ValueError(f"x: add() takes one sea state, got {pts.shape[0]} rows")
        if not np.isfinite(mean):
            raise ValueError("mean: must be finite")
        if not (np.isfinite(variance) and variance > 0):
            raise ValueError("variance: posterior variance must be finite and > 0 (it is the sample's noise)")
        self._x = np.vstack([self._x, pts])
        self._mean = np.append(self._mean, float(mean))
        self._var = np.append(self._var, float(variance))
        self._gpr = None

    @property
    def samples(self) -> pd.DataFrame:
        """The samples in the order added: columns hs_sin_beta [m], omega_p [rad/s], mean [-], variance [-²]."""
        return pd.DataFrame({
            INPUT_NAMES[0]: self._x[:, 0].copy(),
            INPUT_NAMES[1]: self._x[:, 1].copy(),
            "mean": self._mean.copy(),
            "variance": self._var.copy(),
        })

    def __len__(self) -> int:
        return self._mean.size

    # ---------------------------------------------------------------------------------------------
    # model
    # ---------------------------------------------------------------------------------------------

    @property
    def kernel(self) -> ConstantKernel:
        """σ_f² · exp(−½ Σ_d (Δx_d / l_d)²), all hyperparameters fixed."""
        # RBF kernel, A4 eq. 11, with one length scale per input (anisotropic; A4 §5, Table 5)
        return ConstantKernel(self.sigma_f**2, "fixed") * RBF(list(self.length_scales), "fixed")

    @property
    def gpr_(self) -> GaussianProcessRegressor | None:
        """The fitted scikit-learn regressor on y − prior_mean (None without samples)."""
        if self._gpr is None and len(self):
            # Noisy samples ỹ_i = f(x_i) + ε_i, ε_i ~ N(0, σ_yi²), A4 eq. 12–13; alpha puts Σ_Y on the
            # diagonal, K_Ỹ = K_Y + Σ_Y, A4 eq. 15a–c; optimizer=None keeps the hyperparameters fixed (A4 §5).
            gpr = GaussianProcessRegressor(self.kernel, alpha=self._var, optimizer=None, normalize_y=False)
            # Non-zero prior mean: fit on ỹ − μ, A4 eq. 16
            self._gpr = gpr.fit(self._x, self._mean - self.prior_mean)
        return self._gpr

    def predict(self, x: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Predicted β44 mean and std at x, (2,) or (n, 2) → two (n,) arrays.

        The std is that of the latent β44 (A4 eq. 14c), without any sample noise; it is what step 1 of
        A4 §4.1 turns into the prior PMF. Without samples: (prior_mean, sigma_f).
        """
        pts = _as_points(x)
        gpr = self.gpr_
        if gpr is None:
            # Prior, A4 eq. 23
            return np.full(pts.shape[0], self.prior_mean), np.full(pts.shape[0], self.sigma_f)
        # Posterior mean and covariance with K_Ỹ⁻¹, A4 eq. 14b–c (digest PART 5 #8: the print's K_Y⁻¹ is K_Ỹ⁻¹)
        mean, std = gpr.predict(pts, return_std=True)
        # Add the prior mean back, A4 eq. 16
        return mean + self.prior_mean, std

    def pmf_on(self, grid: ArrayLike, x: ArrayLike) -> np.ndarray:
        """Gaussian PMF of β44 at x on a parameter grid (A4 §4.1 step 1).

        grid : (K,) strictly increasing β44 values [-] (the DBI grid of β44).
        x : (2,) one sea state → (K,) PMF; or (n, 2) → (n, K), one PMF per row.

        PMF_k ∝ N(φ_k; μ, σ²) · Δφ_k with Δφ_k the cell width of node k (A4 eq. 7, PMF = PDF · ΔΦ), normalised
        to sum 1 per row (module docstring). A σ far below the grid spacing puts the mass on the nearest nodes
        (computed in log space, never 0/0).
        """
        g = np.asarray(grid, dtype=float)
        if g.ndim != 1 or g.size < 1 or not np.all(np.isfinite(g)):
            raise ValueError("grid: expected a 1-D array of finite β44 values")
        if g.size > 1 and np.any(np.diff(g) <= 0):
            raise ValueError("grid: β44 values must be strictly increasing")
        one = np.asarray(x).ndim == 1
        mu, sd = self.predict(x)
        if g.size == 1:
            pmf = np.ones((mu.size, 1))
            return pmf[0] if one else pmf
        edges = np.concatenate([[g[0] - 0.5 * (g[1] - g[0])], 0.5 * (g[1:] + g[:-1]), [g[-1] + 0.5 * (g[-1] - g[-2])]])
        width = np.diff(edges)
        pmf = np.empty((mu.size, g.size))
        for i, (m, s) in enumerate(zip(mu, sd, strict=True)):
            if s > 0:
                # Gaussian PMF at the grid points, PMF = PDF · ΔΦ, A4 eq. 7, in log space
                logp = -0.5 * ((g - m) / s) ** 2 + np.log(width)
                p = np.exp(logp - logp.max())
            else:  # a degenerate Gaussian: all mass on the nearest node
                p = np.zeros(g.size)
                p[np.argmin(np.abs(g - m))] = 1.0
            pmf[i] = p / p.sum()  # NO(·): normalise to sum 1, A4 eq. 6
        return pmf[0] if one else pmf

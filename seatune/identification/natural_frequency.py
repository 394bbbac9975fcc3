"""Natural frequencies from identified RAOs / response spectra, and the loading parameters they imply.

Source: de Jong (TU Delft MSc 2022), digest ``/work/shared/spec/seed_002.md`` (cited "dJ" below with the
thesis equation numbers the digest gives). De Jong identifies the heave and roll natural frequencies as the
peak of an identified RAO *inside a search range* around the model's prediction (dJ §5.6, digest §3.5–3.6),
then derives the displacement from ω_n3 in closed form (dJ Eq. 6.2 = 7.1) and the roll radius of gyration
from ω_n4 and GM_t (dJ Eq. 6.4 = 7.2, **corrected** form, digest §4.2).

Contents

* :func:`peak_in_range` — de Jong's peak search (argmax inside ω_model·(1 ± rel_range)).
* :func:`fit_sdof` — single-degree-of-freedom resonance fit |H| = K rᵠ / √((1 − r²)² + (2ζr)²), r = ω/ω_n,
  with 95 % confidence intervals (:class:`SdofFit`).
* :func:`spectrum_peak` — peak of a response spectrum with sub-bin refinement.
* :func:`peak_to_natural` — damped-peak → undamped ω_n for displacement / velocity / acceleration RAOs.
* :func:`mode_posterior` — the measured ω_n combined with the coupled modes over the loading prior.
* Closed forms (all plain floats or numpy arrays, SI, mass in kg — the digest's "∇ [t]" is a mass, §1.4):
  :func:`heave_natural_frequency`, :func:`displacement_from_heave`, :func:`roll_natural_frequency`,
  :func:`r44_from_roll`, :func:`gm_from_roll`; and first-order uncertainty propagation
  :func:`displacement_from_heave_u`, :func:`r44_from_roll_u`, :func:`gm_from_roll_u` (:class:`Derived`).

Added mass is a float (A at the natural frequency, as de Jong does) or a callable A(ω). In the forward
direction (ω from the loading) a callable makes ω_n the fixed point ω² (M + A(ω)) = C, solved by
:func:`scipy.optimize.brentq`. In the inverse direction ω is given, so A(ω) is simply evaluated, and the
first-order uncertainty includes the slope dA/dω (central difference).

Deliberate deviations from / additions to de Jong

* Peak search: de Jong enforced his range only loosely (digest §3.5: a roll peak of 0.608 > 0.59 was
  accepted). Here the range is strict, and a maximum on the window edge that is not a local maximum of the
  whole curve is reported as "no peak" (``nan, -1``) — de Jong's "–" entries — instead of the edge value.
* The grid quantises de Jong's ω_n (Δω ≈ 0.0325 rad/s, ±7 % in Δ; digest §6 item 4). :func:`spectrum_peak`
  refines the peak with a parabola (or a Gaussian = parabola in log, Gasior & Gonzalez, which the thesis
  cites but does not apply), and :func:`fit_sdof` fits a resonance curve to all points near the peak.
* The peak of a damped response is not ω_n: displacement peaks at ω_n √(1 − 2ζ²), velocity at ω_n,
  acceleration at ω_n / √(1 − 2ζ²) (textbook SDOF). De Jong takes the peak of the heave *acceleration* and
  roll *velocity* RAOs as ω_n; :func:`peak_to_natural` removes the bias when ζ is known.
* Uncertainty: de Jong sums relative uncertainties linearly (digest §3.5 [CHECK]); here first-order
  (Gaussian, independent inputs) propagation with analytic partial derivatives.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from scipy import optimize, stats

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "G",
    "RHO",
    "Derived",
    "ModePosterior",
    "SdofFit",
    "SpectrumPeak",
    "displacement_from_heave",
    "displacement_from_heave_u",
    "fit_sdof",
    "gm_from_roll",
    "gm_from_roll_u",
    "heave_natural_frequency",
    "mode_posterior",
    "peak_in_range",
    "peak_to_natural",
    "r44_from_roll",
    "r44_from_roll_u",
    "roll_natural_frequency",
    "sdof_amplitude",
    "spectrum_peak",
]

RHO = 1025.0  # sea-water density [kg/m³]; de Jong never states ρ, 1025 reproduces his numbers (digest §0)
G = 9.81  # gravity [m/s²] (digest §0)

AddedMass = float | Callable[[float], float]
MODES_SHIFTED_BY = {"anti_roll_tank": "Roll", "moonpool": "Heave"}  # vessel effects whose peak is not the bare mode


def shifted_modes(effects) -> set[str]:
    """The DOFs whose measured peak a declared vessel effect (vessel YAML `effects`) moves off the bare mode."""
    return {MODES_SHIFTED_BY[e["kind"]] for e in effects if e["kind"] in MODES_SHIFTED_BY}


# ---------------------------------------------------------------------------------------------------------
# Peak search (de Jong §5.6)
# ---------------------------------------------------------------------------------------------------------


def peak_in_range(
    omega: np.ndarray, amplitude: np.ndarray, omega_model: float, rel_range: float = 0.3
) -> tuple[float, int]:
    """RAO peak inside a search range around the model's natural frequency (de Jong §5.6.2, step 6).

    Parameters
    ----------
    omega : array_like, shape (n,)
        Frequencies [rad/s], strictly increasing.
    amplitude : array_like, shape (n,)
        Identified RAO amplitude F(ω) (any unit; only the argmax matters). NaN bins (e.g. masked where the
        wave spectrum has no energy) are ignored.
    omega_model : float
        Natural frequency predicted by the current model [rad/s] (dJ Eqs. 5.7, 5.9).
    rel_range : float, optional
        Half-width of the search window relative to ``omega_model``: the window is
        ``omega_model * (1 ± rel_range)``. De Jong's windows are 1.03 ± 7.7 % (heave) and 0.48 ± 24 % (roll).

    Returns
    -------
    omega_peak : float
        Frequency of the largest amplitude inside the window [rad/s], or ``nan`` when there is no peak.
    index : int
        Its index into ``omega``, or ``-1`` when there is no peak.

    Notes
    -----
    "No peak" (de Jong's "–") means the window holds no finite bin, or the maximum sits on the window edge
    while the curve keeps rising outside it (the edge is then not a local maximum of the whole curve).
    """
    omega = np.asarray(omega, dtype=float)
    amp = np.asarray(amplitude, dtype=float)
    if omega.shape != amp.shape or omega.ndim != 1:
        raise ValueError("omega and amplitude must be 1-D arrays of equal length")
    if not 0 < rel_range < 1:
        raise ValueError("rel_range must lie in (0, 1)")
    lo, hi = omega_model * (1 - rel_range), omega_model * (1 + rel_range)
    inside = (omega >= lo) & (omega <= hi) & np.isfinite(amp)
    if not inside.any():
        return float("nan"), -1
    idx = np.flatnonzero(inside)
    k = int(idx[np.argmax(amp[idx])])
    # a true local maximum of the whole curve: no finite neighbour is larger
    for j in (k - 1, k + 1):
        if 0 <= j < amp.size and np.isfinite(amp[j]) and amp[j] > amp[k]:
            return float("nan"), -1
    return float(omega[k]), k


class SpectrumPeak(NamedTuple):
    """Refined spectral peak returned by :func:`spectrum_peak`."""

    omega: float  #: refined peak frequency [rad/s]
    value: float  #: refined peak value [unit of S]
    index: int  #: index of the grid maximum (−1: no peak)


def spectrum_peak(
    omega: np.ndarray, S: np.ndarray, omega_range: tuple[float, float], method: str = "parabolic"
) -> SpectrumPeak:
    """Peak of a response spectrum inside ``omega_range``, refined between grid points.

    De Jong takes the roll natural frequency as the roll(-velocity) peak (§5.6); his peaks are quantised to
    the grid (digest §6 item 4). The grid maximum and its two neighbours define a parabola (``"parabolic"``)
    or a Gaussian, i.e. a parabola through ln S (``"gaussian"``, exact for a Gaussian peak; Gasior &
    Gonzalez), whose vertex is returned. Non-uniform grids are handled (three-point Lagrange parabola).

    Parameters
    ----------
    omega : array_like, shape (n,)
        Frequencies [rad/s], strictly increasing.
    S : array_like, shape (n,)
        One-sided spectrum [unit²·s/rad]; non-finite bins are ignored.
    omega_range : (float, float)
        Search window [rad/s], inclusive.
    method : {"parabolic", "gaussian"}
        Sub-bin interpolation.

    Returns
    -------
    SpectrumPeak
        ``(omega, value, index)``; ``(nan, nan, -1)`` when the window holds no local maximum (see
        :func:`peak_in_range`). A peak on the first/last grid point is returned unrefined.
    """
    omega = np.asarray(omega, dtype=float)
    S = np.asarray(S, dtype=float)
    lo, hi = omega_range
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    w_pk, k = peak_in_range(omega, S, centre, rel_range=half / centre)
    if k < 0:
        return SpectrumPeak(float("nan"), float("nan"), -1)
    if k == 0 or k == omega.size - 1 or not np.all(np.isfinite(S[k - 1 : k + 2])):
        return SpectrumPeak(w_pk, float(S[k]), k)
    x = omega[k - 1 : k + 2]
    y = S[k - 1 : k + 2]
    if method == "gaussian":
        if np.any(y <= 0):
            raise ValueError("gaussian refinement needs positive spectrum values around the peak")
        y = np.log(y)
    elif method != "parabolic":
        raise ValueError("method must be 'parabolic' or 'gaussian'")
    a, b, c = np.polyfit(x - x[1], y, 2)  # exact through three points
    if a >= 0:  # flat top (two equal maxima): no curvature to refine with
        return SpectrumPeak(w_pk, float(S[k]), k)
    dx = float(np.clip(-b / (2 * a), x[0] - x[1], x[2] - x[1]))
    val = c - b * b / (4 * a)
    if method == "gaussian":
        val = np.exp(val)
    return SpectrumPeak(float(x[1] + dx), float(val), k)


def peak_to_natural(omega_peak: float, zeta: float, order: int = 0) -> float:
    """Undamped natural frequency from the peak of a damped SDOF response.

    |H_q| = K rᵠ / √((1 − r²)² + (2ζr)²) (order q = 0 displacement, 1 velocity, 2 acceleration) peaks at
    r² = 1 − 2ζ² (q = 0), r = 1 (q = 1), r² = 1 / (1 − 2ζ²) (q = 2) — textbook SDOF results.

    Parameters
    ----------
    omega_peak : float
        Observed peak frequency [rad/s].
    zeta : float
        Damping ratio [-], ζ < 1/√2.
    order : {0, 1, 2}
        Time-derivative order of the response (de Jong: heave acceleration q = 2, roll velocity q = 1).

    Returns
    -------
    float
        ω_n [rad/s].
    """
    if not 0 <= zeta < np.sqrt(0.5):
        raise ValueError("zeta must lie in [0, 1/sqrt(2)) for a resonance peak to exist")
    s = np.sqrt(1 - 2 * zeta**2)
    return {0: omega_peak / s, 1: omega_peak, 2: omega_peak * s}[order]


# ---------------------------------------------------------------------------------------------------------
# SDOF resonance fit
# ---------------------------------------------------------------------------------------------------------


def sdof_amplitude(omega, omega_n: float, zeta: float, gain: float, order: int = 0):
    """|H_q(ω)| = K rᵠ / √((1 − r²)² + (2ζr)²), r = ω/ω_n. Shapes broadcast; units of ``gain``."""
    r = np.asarray(omega, dtype=float) / omega_n
    return gain * r**order / np.sqrt((1 - r * r) ** 2 + (2 * zeta * r) ** 2)


def _sdof_log_jacobian(omega, omega_n: float, zeta: float, gain: float, order: int = 0) -> np.ndarray:
    """∂ ln|H_q| / ∂(ω_n, ζ, K) of :func:`sdof_amplitude`, shape (n, 3)."""
    r = np.asarray(omega, dtype=float) / omega_n
    d = (1 - r * r) ** 2 + (2 * zeta * r) ** 2
    d_omega_n = -order / omega_n - 2 * r * r * (1 - r * r - 2 * zeta * zeta) / (omega_n * d)
    d_zeta = -4 * zeta * r * r / d
    return np.column_stack([d_omega_n, d_zeta, np.full_like(r, 1.0 / gain if gain > 0 else 0.0)])


@dataclass(frozen=True)
class SdofFit:
    """Result of :func:`fit_sdof`.

    Attributes
    ----------
    omega_n : float
        Undamped natural frequency [rad/s].
    zeta : float
        Damping ratio [-].
    gain : float
        K, the quasi-static gain (|H| at r → 0 for order 0) [unit of the amplitude].
    omega_n_ci, zeta_ci, gain_ci : (float, float)
        95 % confidence intervals (see :func:`fit_sdof` for the method).
    residual : float
        Residual standard error √(Σ wᵢ² eᵢ² / (n − 3)) of the weighted residuals; ≈ 1 when the amplitude
        CIs were given and the model fits.
    cov : ndarray, shape (3, 3)
        Covariance of (ω_n, ζ, K).
    n_points : int
        Number of points used.
    mask : ndarray of bool, shape (n,)
        Which input points were used.
    """

    omega_n: float
    zeta: float
    gain: float
    omega_n_ci: tuple[float, float]
    zeta_ci: tuple[float, float]
    gain_ci: tuple[float, float]
    residual: float
    cov: np.ndarray = field(repr=False)
    n_points: int = 0
    mask: np.ndarray | None = field(default=None, repr=False)


def _half_power_zeta(omega: np.ndarray, amp: np.ndarray, k: int) -> float:
    """ζ ≈ (ω₂ − ω₁)/(2ω_p) from the half-power (|H|max/√2) points; 0.1 if they are not bracketed."""
    level = amp[k] / np.sqrt(2)
    left = np.flatnonzero(amp[:k] < level)
    right = np.flatnonzero(amp[k + 1 :] < level)
    if left.size == 0 or right.size == 0:
        return 0.1
    w1, w2 = omega[left[-1]], omega[k + 1 + right[0]]
    return float(np.clip((w2 - w1) / (2 * omega[k]), 1e-3, 0.5))


def fit_sdof(
    omega: np.ndarray,
    amplitude: np.ndarray,
    ci_low: np.ndarray | None = None,
    ci_high: np.ndarray | None = None,
    weights: np.ndarray | None = None,
    omega_guess: float | None = None,
    *,
    rel_range: float = 0.3,
    order: int = 0,
    confidence: float = 0.95,
) -> SdofFit:
    """Fit a single-degree-of-freedom resonance to an RAO amplitude near its peak.

    Model: |H_q(ω)| = K rᵠ / √((1 − r²)² + (2ζr)²), r = ω/ω_n (q = ``order``; 0 for displacement-type RAOs).
    Fitted by nonlinear least squares (:func:`scipy.optimize.least_squares`, trust-region reflective, bounds
    ω_n > 0, 0 < ζ < 2, K > 0) on the points with ω in ω_p (1 ± ``rel_range``), ω_p = ``omega_guess`` or
    the frequency of the largest amplitude.

    Three weighting modes and how the confidence intervals follow from them:

    1. Unweighted (default) or ``weights`` (relative, ∝ 1/σᵢ): residuals wᵢ (model − data). Covariance
       C = s² (JᵀJ)⁻¹ with J the Jacobian of the weighted residuals at the optimum and s² = Σ (wᵢeᵢ)²/(n − 3)
       the residual variance (what ``curve_fit(absolute_sigma=False)`` does). CI = estimate ± t₀.₉₇₅,n−3 √Cᵢᵢ.
    2. ``ci_low``/``ci_high`` given: per-point 95 % intervals of the amplitude, e.g. from the χ² intervals
       of a spectral estimate with ν degrees of freedom (|Ĥ|² ∝ χ²_ν/ν). Such intervals are symmetric in
       ln|H|, so the fit is done on ln|H| with σᵢ = (ln hiᵢ − ln loᵢ)/(2 z₀.₉₇₅); the σᵢ are taken as
       absolute, C = (JᵀJ)⁻¹, CI = estimate ± z₀.₉₇₅ √Cᵢᵢ. A constant bias of ln|Ĥ| (E[ln χ²_ν/ν] ≠ 0)
       is absorbed by K alone; ω_n and ζ stay unbiased.

    Parameters
    ----------
    omega : array_like, shape (n,)
        Frequencies [rad/s].
    amplitude : array_like, shape (n,)
        |H| at ``omega`` (any unit > 0). Non-finite points are dropped.
    ci_low, ci_high : array_like, shape (n,), optional
        95 % confidence limits of ``amplitude`` (mode 2). Both or neither.
    weights : array_like, shape (n,), optional
        Relative weights ∝ 1/σᵢ (mode 1). Ignored when the CIs are given.
    omega_guess : float, optional
        Centre of the fitting window and start value of ω_n [rad/s]; e.g. from :func:`peak_in_range`.
    rel_range : float, keyword
        Half-width of the fitting window relative to its centre.
    order : {0, 1, 2}, keyword
        Derivative order of the RAO (velocity 1, acceleration 2).
    confidence : float, keyword
        Two-sided confidence level of the intervals.

    Returns
    -------
    SdofFit
    """
    omega = np.asarray(omega, dtype=float)
    amp = np.asarray(amplitude, dtype=float)
    if (ci_low is None) != (ci_high is None):
        raise ValueError("give both ci_low and ci_high, or neither")
    use_ci = ci_low is not None
    ok = np.isfinite(omega) & np.isfinite(amp) & (amp > 0)
    if use_ci:
        lo_ci, hi_ci = np.asarray(ci_low, dtype=float), np.asarray(ci_high, dtype=float)
        ok &= np.isfinite(lo_ci) & np.isfinite(hi_ci) & (lo_ci > 0) & (hi_ci > lo_ci)
    w = np.ones_like(amp) if weights is None or use_ci else np.asarray(weights, dtype=float)
    ok &= np.isfinite(w) & (w > 0)
    if not ok.any():
        raise ValueError("no usable points")
    centre = float(omega_guess) if omega_guess is not None else float(omega[ok][np.argmax(amp[ok])])
    mask = ok & (omega >= centre * (1 - rel_range)) & (omega <= centre * (1 + rel_range))
    n = int(mask.sum())
    if n < 4:
        raise ValueError(f"only {n} points near the peak; need at least 4 for a 3-parameter fit")
    x, y = omega[mask], amp[mask]

    kpk = int(np.argmax(y))
    w0 = centre if omega_guess is not None else float(x[kpk])
    z0 = _half_power_zeta(x, y, kpk)
    k0 = float(y[kpk]) * 2 * z0  # |H|max ≈ K/(2ζ)
    p0 = np.array([w0, z0, k0])
    scale = p0.copy()

    if use_ci:
        z = stats.norm.ppf(0.5 + confidence / 2)
        sig = (np.log(hi_ci[mask]) - np.log(lo_ci[mask])) / (2 * stats.norm.ppf(0.975))
        ly = np.log(y)

        def resid(p):
            return (np.log(sdof_amplitude(x, p[0], p[1], p[2], order)) - ly) / sig

        def jac(p):
            return _sdof_log_jacobian(x, *p, order) / sig[:, None]
    else:
        ww = w[mask] / float(y.max())  # residuals of order 1 whatever the amplitude's unit (tolerances are absolute)

        def resid(p):
            return ww * (sdof_amplitude(x, p[0], p[1], p[2], order) - y)

        def jac(p):
            return (ww * sdof_amplitude(x, p[0], p[1], p[2], order))[:, None] * _sdof_log_jacobian(x, *p, order)

    lb = np.array([x.min() * 0.5, 1e-6, 0.0])
    ub = np.array([x.max() * 2.0, 2.0, np.inf])
    p0 = np.clip(p0, lb * 1.0001 + 1e-12, np.where(np.isfinite(ub), ub * 0.9999, np.inf))
    sol = optimize.least_squares(resid, p0, jac=jac, bounds=(lb, ub), x_scale=scale, method="trf", xtol=1e-12,
                                 ftol=1e-12)
    J = sol.jac
    dof = n - 3
    rss = float(sol.fun @ sol.fun)
    s2 = rss / dof if dof > 0 else np.nan
    # pseudo-inverse of JᵀJ through the SVD of J (as scipy.optimize.curve_fit)
    _, sv, vt = np.linalg.svd(J, full_matrices=False)
    keep = sv > np.finfo(float).eps * max(J.shape) * sv[0]
    cov = (vt[keep].T / sv[keep] ** 2) @ vt[keep]
    if use_ci:
        q = z
    else:
        cov = cov * s2
        q = stats.t.ppf(0.5 + confidence / 2, dof) if dof > 0 else np.inf
    se = np.sqrt(np.diag(cov))
    p = sol.x
    ci = [(float(p[i] - q * se[i]), float(p[i] + q * se[i])) for i in range(3)]
    return SdofFit(
        omega_n=float(p[0]),
        zeta=float(p[1]),
        gain=float(p[2]),
        omega_n_ci=ci[0],
        zeta_ci=ci[1],
        gain_ci=ci[2],
        residual=float(np.sqrt(s2)) * (1.0 if use_ci else float(y.max())),
        cov=cov,
        n_points=n,
        mask=mask,
    )


# ---------------------------------------------------------------------------------------------------------
# Closed-form natural-frequency relations (de Jong ch. 5–7)
# ---------------------------------------------------------------------------------------------------------


def _eval_added(a: AddedMass, omega):
    return a(omega) if callable(a) else a


def _solve_omega(stiffness: float, inertia: float, added: AddedMass) -> float:
    """ω > 0 with ω² (inertia + A(ω)) = stiffness; A a float or a callable A(ω)."""
    if not callable(added):
        return float(np.sqrt(stiffness / (inertia + added)))

    def f(w):
        return w * w * (inertia + added(w)) - stiffness

    hi = np.sqrt(stiffness / inertia)
    for _ in range(60):  # f(0) = −C < 0; f(hi) ≥ 0 whenever A(hi) ≥ 0, otherwise widen
        if f(hi) > 0:
            break
        hi *= 1.5
    else:  # pragma: no cover - pathological A(ω)
        raise ValueError("could not bracket the natural frequency")
    return float(optimize.brentq(f, 1e-9 * hi, hi, xtol=1e-14, rtol=1e-13))


def heave_natural_frequency(mass, a33: AddedMass, awp, rho: float = RHO, g: float = G):
    """Heave natural frequency ω3 = √(ρ g A_wp / (m + A33(ω3))) [rad/s].

    Parameters
    ----------
    mass : float or ndarray
        Displacement mass m [kg] (de Jong's "∇" in tonnes is this mass; digest §1.4).
    a33 : float or callable
        Heave added mass at ω3 [kg], or A33(ω) [kg] (then ω3 is the fixed point; scalar inputs only).
    awp : float or ndarray
        Waterplane area [m²].
    rho, g : float
        Water density [kg/m³], gravity [m/s²].
    """
    # dJ Eq. 5.7 / 6.1: ω_n3 = sqrt(ρ g A_WL / (ρ∇ + a33)), with ρ∇ → m (digest §1.4)
    if callable(a33):
        return _solve_omega(rho * g * float(awp), float(mass), a33)
    return np.sqrt(rho * g * np.asarray(awp) / (np.asarray(mass) + a33))


def displacement_from_heave(omega3, a33: AddedMass, awp, rho: float = RHO, g: float = G):
    """Displacement mass from the heave natural frequency: m = ρ g A_wp / ω3² − A33(ω3) [kg].

    Parameters
    ----------
    omega3 : float or ndarray
        Heave natural frequency [rad/s].
    a33 : float or callable
        Heave added mass at ω3 [kg], or A33(ω) [kg] (evaluated at ``omega3``).
    awp : float or ndarray
        Waterplane area [m²].
    rho, g : float
        Water density [kg/m³], gravity [m/s²].
    """
    omega3 = np.asarray(omega3, dtype=float)
    # dJ Eq. 6.2 = 7.1: ∇ = (ρ g A_WL − ω² a33)/(ω² ρ), i.e. Δ = ρ g A_WL/ω² − a33 (digest §4.2)
    return rho * g * np.asarray(awp) / omega3**2 - _eval_added(a33, omega3)


def roll_natural_frequency(mass, gm, r44, a44: AddedMass, g: float = G):
    """Roll natural frequency ω4 = √(m g GM / (m r44² + A44(ω4))) [rad/s].

    Parameters
    ----------
    mass : float or ndarray
        Displacement mass m [kg].
    gm : float or ndarray
        Transverse metacentric height GM_t [m] (including any free-surface correction).
    r44 : float or ndarray
        Roll radius of gyration about the COG [m].
    a44 : float or callable
        Roll added moment of inertia at ω4 [kg·m²], or A44(ω) (fixed point; scalar inputs only).
    g : float
        Gravity [m/s²].
    """
    # dJ Eq. 5.9 / 6.3: ω_n4 = sqrt(ρ g ∇ GM_t / (k_xx² ρ∇ + a44)), ρ∇ → m (digest §1.4, §3.5)
    if callable(a44):
        return _solve_omega(float(mass) * g * float(gm), float(mass) * float(r44) ** 2, a44)
    mass = np.asarray(mass)
    return np.sqrt(mass * g * np.asarray(gm) / (mass * np.asarray(r44) ** 2 + a44))


def r44_from_roll(omega4, mass, gm, a44: AddedMass, g: float = G):
    """Roll radius of gyration from the roll natural frequency and GM_t [m].

    r44 = √((m g GM − ω4² A44) / (m ω4²)) — de Jong's Eq. 6.4 / 7.2 as **corrected** in the digest §4.2:
    the printed form has an extra g in the denominator (giving ≈ 2.05 m instead of 6.43 m).

    Parameters
    ----------
    omega4 : float or ndarray
        Roll natural frequency [rad/s].
    mass : float or ndarray
        Displacement mass [kg].
    gm : float or ndarray
        GM_t [m].
    a44 : float or callable
        Roll added moment of inertia at ω4 [kg·m²], or A44(ω) (evaluated at ``omega4``).
    g : float
        Gravity [m/s²].

    Raises
    ------
    ValueError
        When m g GM ≤ ω4² A44 (the added inertia alone already exceeds the total): no real r44.
    """
    omega4 = np.asarray(omega4, dtype=float)
    mass = np.asarray(mass, dtype=float)
    w2 = omega4**2
    # dJ Eq. 6.4 = 7.2, corrected (digest §4.2): k_xx = sqrt((Δ g GM_t − ω² a44)/(Δ ω²)), no g in the denominator
    rad = (mass * g * np.asarray(gm) - w2 * _eval_added(a44, omega4)) / (mass * w2)
    if np.any(rad <= 0):
        raise ValueError("m g GM <= omega4^2 A44: no real roll radius of gyration")
    return np.sqrt(rad)


def gm_from_roll(omega4, mass, r44, a44: AddedMass, g: float = G):
    """GM_t from the roll natural frequency and r44: GM = ω4² (m r44² + A44) / (m g) [m].

    Parameters as :func:`r44_from_roll` with ``r44`` [m] in place of ``gm``.
    """
    omega4 = np.asarray(omega4, dtype=float)
    mass = np.asarray(mass, dtype=float)
    # dJ Eq. 6.3 solved for GM_t
    return omega4**2 * (mass * np.asarray(r44) ** 2 + _eval_added(a44, omega4)) / (mass * g)


# ---------------------------------------------------------------------------------------------------------
# First-order uncertainty propagation
# ---------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Derived:
    """A derived parameter with first-order (linearised, independent Gaussian inputs) uncertainty.

    Attributes
    ----------
    value : float
        The estimate [unit of the parameter].
    std : float
        Standard deviation √(Σ (∂f/∂xᵢ σᵢ)²) [same unit].
    partials : dict[str, float]
        ∂f/∂xᵢ for every input name.
    contributions : dict[str, float]
        (∂f/∂xᵢ σᵢ)² / std², the share of the variance from each input (sums to 1 when std > 0).
    """

    value: float
    std: float
    partials: dict[str, float]
    contributions: dict[str, float]

    @property
    def rel_std(self) -> float:
        """std / |value| [-]."""
        return self.std / abs(self.value)


def _derived(value: float, partials: dict[str, float], sigmas: dict[str, float]) -> Derived:
    terms = {k: (partials[k] * sigmas.get(k, 0.0)) ** 2 for k in partials}
    var = sum(terms.values())
    contrib = {k: (t / var if var > 0 else 0.0) for k, t in terms.items()}
    return Derived(float(value), float(np.sqrt(var)), partials, contrib)


def _dadw(a: AddedMass, omega: float) -> float:
    """dA/dω of a callable added mass (central difference, step 1e-4 ω); 0 for a constant."""
    if not callable(a):
        return 0.0
    h = 1e-4 * omega
    return float((a(omega + h) - a(omega - h)) / (2 * h))


def displacement_from_heave_u(
    omega3: float,
    a33: AddedMass,
    awp: float,
    *,
    std_omega3: float = 0.0,
    std_a33: float = 0.0,
    std_awp: float = 0.0,
    rho: float = RHO,
    g: float = G,
) -> Derived:
    """:func:`displacement_from_heave` with first-order uncertainty.

    ∂m/∂ω3 = −2 ρ g A_wp / ω3³ − dA33/dω, ∂m/∂A33 = −1, ∂m/∂A_wp = ρ g / ω3². Relative sensitivity to ω3:
    −2 (1 + A33/m) (≈ −4.3 for de Jong's vessel, digest §4.2). Standard deviations in the inputs' units
    (``std_a33`` in kg is the uncertainty of the value A33(ω3)).
    """
    m = float(displacement_from_heave(omega3, a33, awp, rho, g))
    partials = {
        "omega3": -2 * rho * g * awp / omega3**3 - _dadw(a33, omega3),
        "a33": -1.0,
        "awp": rho * g / omega3**2,
    }
    return _derived(m, partials, {"omega3": std_omega3, "a33": std_a33, "awp": std_awp})


def r44_from_roll_u(
    omega4: float,
    mass: float,
    gm: float,
    a44: AddedMass,
    *,
    std_omega4: float = 0.0,
    std_mass: float = 0.0,
    std_gm: float = 0.0,
    std_a44: float = 0.0,
    g: float = G,
) -> Derived:
    """:func:`r44_from_roll` with first-order uncertainty.

    With r² = g GM/ω² − A44/m: ∂r/∂GM = g/(2 r ω²), ∂r/∂m = A44/(2 r m²), ∂r/∂A44 = −1/(2 r m),
    ∂r/∂ω = (−2 g GM/ω³ − A44'(ω)/m)/(2 r).
    """
    r = float(r44_from_roll(omega4, mass, gm, a44, g))
    a = float(_eval_added(a44, omega4))
    partials = {
        "omega4": (-2 * g * gm / omega4**3 - _dadw(a44, omega4) / mass) / (2 * r),
        "mass": a / (2 * r * mass**2),
        "gm": g / (2 * r * omega4**2),
        "a44": -1.0 / (2 * r * mass),
    }
    return _derived(r, partials, {"omega4": std_omega4, "mass": std_mass, "gm": std_gm, "a44": std_a44})


def gm_from_roll_u(
    omega4: float,
    mass: float,
    r44: float,
    a44: AddedMass,
    *,
    std_omega4: float = 0.0,
    std_mass: float = 0.0,
    std_r44: float = 0.0,
    std_a44: float = 0.0,
    g: float = G,
) -> Derived:
    """:func:`gm_from_roll` with first-order uncertainty.

    GM = ω² (r² + A44/m)/g: ∂GM/∂ω = 2 GM/ω + ω² A44'(ω)/(m g), ∂GM/∂r = 2 ω² r/g,
    ∂GM/∂A44 = ω²/(m g), ∂GM/∂m = −ω² A44/(m² g).
    """
    gm = float(gm_from_roll(omega4, mass, r44, a44, g))
    a = float(_eval_added(a44, omega4))
    partials = {
        "omega4": 2 * gm / omega4 + omega4**2 * _dadw(a44, omega4) / (mass * g),
        "mass": -(omega4**2) * a / (mass**2 * g),
        "r44": 2 * omega4**2 * r44 / g,
        "a44": omega4**2 / (mass * g),
    }
    return _derived(gm, partials, {"omega4": std_omega4, "mass": std_mass, "r44": std_r44, "a44": std_a44})


class ModePosterior(NamedTuple):
    """Natural frequencies given the loading prior and the measured ω_n, per DOF (arrays of the DOFs)."""

    omega: np.ndarray  # posterior mean [rad/s]
    std: np.ndarray  # posterior std [rad/s]
    prior_mean: np.ndarray  # the model's ω_n over the loading prior [rad/s]
    prior_std: np.ndarray  # its spread, with the model-form error [rad/s]
    effective_draws: float  # Kish's effective sample size of the prior draws after weighting
    weights: np.ndarray  # each draw's posterior weight (sums to 1): the loading given the modes


def mode_posterior(model_omega: np.ndarray, measured: np.ndarray, measured_std: np.ndarray,
                   model_rel_std: float) -> ModePosterior:
    """ω_n of each DOF given the coupled modes `model_omega` (n draws of the loading prior × DOFs) and the measured
    ω_n ± `measured_std` (NaN where a DOF has none; per draw where `measured` is n × DOFs: the estimator's bias
    taken at each draw), the model form off by N(0, `model_rel_std`) relative.

    Given draw i the true ω_n is N(ω_i, (f ω_i)²) a priori, so the measurement fuses with it in closed form; the
    draws are weighted by the likelihood of every measured DOF at once (they share the loading), and the
    posterior is that Gaussian mixture's mean and std. The spread is not linearised: a symmetric hull's heave
    falls with |xcg − LCF| either way, which a central difference about the prior mean reads as zero."""
    model_omega = np.asarray(model_omega, float)
    measured, s2 = np.asarray(measured, float), np.asarray(measured_std, float) ** 2
    have = np.isfinite(measured) & np.isfinite(s2) & (s2 > 0)
    v_model = (model_rel_std * model_omega) ** 2  # (n, d)
    total = np.where(have, s2, 0.0) + v_model
    resid = np.where(have, measured - model_omega, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_like = np.where(have, -0.5 * (resid ** 2 / total + np.log(total)), 0.0).sum(axis=1)
        gain = np.where(have, v_model / total, 0.0)  # Kalman gain of the measurement on draw i's ω_n
    w = np.exp(log_like - log_like.max())
    w /= w.sum()
    mu = model_omega + gain * resid
    var = (1.0 - gain) * v_model
    mean = w @ mu
    std = np.sqrt(np.maximum(w @ (var + mu ** 2) - mean ** 2, 0.0))
    prior_mean = model_omega.mean(axis=0)
    prior_std = np.sqrt(model_omega.var(axis=0) + np.mean(v_model, axis=0))
    return ModePosterior(mean, std, prior_mean, prior_std, float(1.0 / np.sum(w ** 2)), w)


def primary_natural_frequencies(nf: pd.DataFrame, measured_only: bool = False) -> pd.DataFrame:
    """One combined estimate per DOF of natural_frequencies.parquet (window 'all', not a derived row), indexed by
    DOF: the hull's mode in the model with diagnose's named effects where one moves that DOF's peak, else the
    posterior with the loading prior, else the admittance SDOF fit, else the response-spectrum peak; a value before
    a reason it has none. `measured_only`: without the model's (for what takes the loading prior itself — tune, the
    derived loading parameters — and must not count it twice)."""
    rows = nf[(nf["window_id"] == "all") & nf["derived"].isna()] if "derived" in nf else nf[nf["window_id"] == "all"]
    if measured_only:
        rows = rows[~rows["method"].isin(("posterior", "model_with_effects"))]
    rank = rows["method"].map({"model_with_effects": 0, "posterior": 1, "admittance_peak_sdof": 2}).fillna(3)
    rows = rows.assign(_pref=rank + 3 * rows["omega_n"].isna().astype(int))  # a value before a reason it has none
    return rows.sort_values("_pref", kind="stable").drop_duplicates("dof").drop(columns="_pref").set_index("dof")

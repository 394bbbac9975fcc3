"""Non-parametric RAO estimation from measured response spectra (sea trials) and model tests.

Conventions (DESIGN §3): spectra one-sided in rad/s, S(ω) [unit²·s/rad]; complex amplitudes in
Capytaine's convention x(t) = Re{X e^{−iωt}}, so a causal lag gives arg H > 0.

What each estimator assumes
---------------------------
* :func:`rao_long_crested` — the wave spectrum S_ζζ(ω) (hindcast / nowcast / buoy) is treated as
  **known and exact**; only the sampling error of the measured response spectrum S_xx (a χ²_ν
  variable, ν from the Welch estimate) enters the interval. Wave-model error (Hs ±10–15 %, Tp, swell
  missing, seed 002 §2.5 / A5 Table 2) is not in the interval: it is a bias, flagged by
  :func:`quality_flags`.
* :func:`rao_short_crested` — separable sea S_ζ(ω, β) = S(ω)·W(β) (de Jong §1.2/§3.3) and a known
  directional shape of the RAO; the result is the amplitude along the chosen (mean) direction.
* :func:`h1_estimator` — wave elevation η measured at the body origin (model tests, A7): the H1
  estimator with its coherence-based confidence region (Bendat & Piersol).
* :func:`aggregate` — inverse-variance mean of ln|H| over windows of a group (heading sector × Hs
  bin), bias-corrected for the χ² log mean.

All functions are pure numpy/scipy; frequencies are in rad/s.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from scipy import signal as sps
from scipy import special, stats

from seatune.physics.adaptive_filter import welch_segments

TWO_PI = 2.0 * np.pi

__all__ = [
    "RaoEstimate",
    "aggregate",
    "chi2_interval",
    "energetic_band",
    "h1_confidence",
    "h1_estimator",
    "quality_flags",
    "wave_log_std",
    "rao_long_crested",
    "rao_short_crested",
]


# ---------------------------------------------------------------------------------------------
# building blocks
# ---------------------------------------------------------------------------------------------


def energetic_band(omega: ArrayLike, S_wave: ArrayLike, fraction: float = 0.05) -> np.ndarray:
    """Frequencies where the wave spectrum carries energy: S_ζζ(ω) ≥ fraction · max S_ζζ.

    Parameters
    ----------
    omega : array_like, shape (n_omega,)
        Frequencies [rad/s] (only used for the shape check).
    S_wave : array_like, shape (n_omega,)
        Wave spectrum S_ζζ(ω) [m²·s/rad] on `omega`.
    fraction : float, default 0.05
        Threshold relative to the spectral peak (A7 §4.1: wave PSD < 5 % of its maximum is discarded).

    Returns
    -------
    mask : ndarray of bool, shape (n_omega,)
        True inside the energetic band (may be several disjoint intervals, e.g. wind sea + swell).
        All False for a spectrum without positive values.
    """
    w = np.asarray(omega, dtype=float)
    s = np.asarray(S_wave, dtype=float)
    if s.shape != w.shape or s.ndim != 1:
        raise ValueError(f"omega and S_wave must be 1-D of equal shape, got {w.shape} and {s.shape}")
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction must be in (0, 1), got {fraction!r}")
    finite = np.isfinite(s)
    peak = np.max(s[finite]) if finite.any() else 0.0
    if not peak > 0.0:
        return np.zeros(s.shape, dtype=bool)
    # A7 §4.1: keep ω where S_ζζ(ω) ≥ 5 % of max S_ζζ
    return finite & (s >= fraction * peak) & (s > 0.0)


def chi2_interval(S: ArrayLike, dof: ArrayLike, level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided confidence interval of a true spectrum from an estimate with ν degrees of freedom.

    ν Ŝ / S ~ χ²_ν, hence P(ν Ŝ/χ²_ν(1−α/2) ≤ S ≤ ν Ŝ/χ²_ν(α/2)) = 1 − α (Bendat & Piersol §8.5;
    Percival & Walden eq. 292b for the Welch ν), with χ²_ν(p) the p-quantile.

    Parameters
    ----------
    S : array_like
        Spectral estimate(s) Ŝ [any unit], ≥ 0.
    dof : array_like
        Equivalent degrees of freedom ν > 0 (broadcast against `S`).
    level : float, default 0.95
        Coverage 1 − α in (0, 1).

    Returns
    -------
    low, high : ndarray
        Interval bounds, same unit and broadcast shape as `S`.
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    s = np.asarray(S, dtype=float)
    nu = np.asarray(dof, dtype=float)
    if np.any(nu <= 0):
        raise ValueError("dof must be positive")
    alpha = 1.0 - level
    low = nu * s / stats.chi2.ppf(1.0 - alpha / 2.0, nu)
    high = nu * s / stats.chi2.ppf(alpha / 2.0, nu)
    return low, high


def wave_log_std(omega: ArrayLike, S_wave: ArrayLike, hs_rel_std: float, tp_rel_std: float) -> np.ndarray:
    """Standard deviation of ln|Ĥ| = ½ ln S_xx − ½ ln S_ζζ caused by errors of the hindcast's Hs and Tp.

    A sea state scales as S(ω) = Hs² Tp f(ω Tp), so ∂ln S/∂ln Hs = 2 and ∂ln S/∂ln Tp = 1 + ∂ln S/∂ln ω
    (evaluated on the spectrum itself, whatever its shape). Hence, to first order,
    σ_ln|H| = ½ √((2 σ_Hs/Hs)² + ((1 + ∂ln S/∂ln ω) σ_Tp/Tp)²). The error is common to all frequencies of a
    window (it shifts the whole estimate), unlike the χ² sampling error.
    """
    w, arrs = _check_1d(omega, S_wave=S_wave)
    s = arrs["S_wave"]
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.gradient(np.log(np.where(s > 0, s, np.nan)), np.log(w))
    return 0.5 * np.sqrt((2.0 * hs_rel_std) ** 2 + ((1.0 + slope) * tp_rel_std) ** 2)


def _log_amplitude_moments(dof: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bias and variance of ln|Ĥ| = ½ ln Ŝ_xx − ½ ln S_ζζ when ν Ŝ_xx/S_xx ~ χ²_ν.

    E[ln(χ²_ν/ν)] = ψ(ν/2) − ln(ν/2) and Var[ln χ²_ν] = ψ'(ν/2) (digamma/trigamma of a log-gamma
    variable), so ln|Ĥ| has bias ½(ψ(ν/2) − ln(ν/2)) and variance ¼ ψ'(ν/2).
    """
    half = dof / 2.0
    return 0.5 * (special.digamma(half) - np.log(half)), 0.25 * special.polygamma(1, half)


@dataclass(frozen=True)
class RaoEstimate:
    """RAO amplitude estimate of one window on a frequency grid.

    Attributes
    ----------
    omega : ndarray, shape (n_omega,)
        Frequencies [rad/s].
    amplitude : ndarray, shape (n_omega,)
        |Ĥ(ω)| [response unit / m]; NaN outside `mask`.
    low, high : ndarray, shape (n_omega,)
        Confidence bounds of |H| at `level` (sampling error of S_xx only); NaN outside `mask`.
    mask : ndarray of bool, shape (n_omega,)
        Energetic band (and, short-crested, a non-zero directional denominator).
    dof : float or ndarray
        Degrees of freedom ν of the response spectrum.
    level : float
        Confidence level of `low`/`high`.
    method : str
        "long_crested", "de_jong" or "model_shape".
    scale : ndarray or None, shape (n_omega,)
        "model_shape" only: measured/model response amplitude ratio √(S_xx / S_xx,model).
    flags : dict
        Output of :func:`quality_flags` when it was evaluated; ``flags.get("low_confidence")`` makes
        :func:`aggregate` drop the window.
    """

    omega: np.ndarray
    amplitude: np.ndarray
    low: np.ndarray
    high: np.ndarray
    mask: np.ndarray
    dof: float | np.ndarray
    level: float
    method: str
    scale: np.ndarray | None = None
    flags: dict = field(default_factory=dict)
    wave_log_std: np.ndarray | None = None  # σ of ln|H| from the wave spectrum's errors (common to the window)

    @property
    def low_confidence(self) -> bool:
        return bool(self.flags.get("low_confidence", False))


def _check_1d(omega: ArrayLike, **arrays: ArrayLike) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    w = np.asarray(omega, dtype=float)
    if w.ndim != 1 or w.size < 2 or np.any(np.diff(w) <= 0):
        raise ValueError("omega must be 1-D, strictly increasing, with at least two points")
    out = {}
    for name, a in arrays.items():
        arr = np.asarray(a, dtype=float)
        if arr.shape != w.shape:
            raise ValueError(f"{name} must have the shape of omega {w.shape}, got {arr.shape}")
        out[name] = arr
    return w, out


def _amplitude_from_ratio(S_resp: np.ndarray, denom: np.ndarray, dof, level: float, mask: np.ndarray,
                          log_std_wave: np.ndarray | None = None):
    """|H| = √(S_xx/denom) with the χ² interval of S_xx mapped through the (monotone) square root.

    With `log_std_wave`, each half-width of the interval in ln|H| is combined root-sum-square with
    z·σ_wave (the χ² interval is asymmetric in ln|H|, so lower and upper halves are widened separately).
    """
    lo_s, hi_s = chi2_interval(S_resp, dof, level)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        amp = np.sqrt(S_resp / denom)
        low = np.sqrt(lo_s / denom)
        high = np.sqrt(hi_s / denom)
        if log_std_wave is not None:
            zw = stats.norm.ppf(0.5 + level / 2.0) * np.asarray(log_std_wave, dtype=float)
            low = amp * np.exp(-np.hypot(np.log(amp / low), zw))
            high = amp * np.exp(np.hypot(np.log(high / amp), zw))
    nan = np.full_like(amp, np.nan)
    return np.where(mask, amp, nan), np.where(mask, low, nan), np.where(mask, high, nan)


# ---------------------------------------------------------------------------------------------
# quality flags
# ---------------------------------------------------------------------------------------------


def quality_flags(
    omega: ArrayLike,
    S_resp: ArrayLike,
    S_wave: ArrayLike,
    omega_n: float | None = None,
    *,
    fraction: float = 0.05,
    low_frequency_share: float = 0.25,
) -> dict:
    """Screen one window for the two failure modes of spectral-ratio RAO estimation.

    * ``resonance_unexcited``: the wave spectrum at the natural frequency ω_n (linear interpolation)
      is below the energetic threshold ``fraction · max S_ζζ`` — the window cannot show the peak.
    * ``missing_low_frequency_energy``: the share of response variance at frequencies below the lower
      edge of the energetic band exceeds `low_frequency_share`. This is de Jong's failure case
      (seed 002 §3.6, §7 item 1): the hindcast lacks swell the vessel responds to, and √(S_xx/S_ζζ)
      explodes there. A lightly damped resonance below the wave band raises the same flag; that is
      intended — such a window cannot identify the RAO there either.

    Parameters
    ----------
    omega : array_like, shape (n_omega,)
        Frequencies [rad/s], increasing.
    S_resp : array_like, shape (n_omega,)
        Measured response spectrum [unit²·s/rad].
    S_wave : array_like, shape (n_omega,)
        Wave spectrum used for the estimate [m²·s/rad].
    omega_n : float, optional
        Natural frequency [rad/s] of the mode (e.g. from the loading condition).
    fraction : float, default 0.05
        Energetic-band threshold (A7).
    low_frequency_share : float, default 0.25
        Largest acceptable share of response variance below the band.

    Returns
    -------
    dict
        ``resonance_unexcited`` (bool, False when `omega_n` is None), ``missing_low_frequency_energy``
        (bool), ``response_share_below_band`` (float), ``band_low`` [rad/s] (lower band edge, NaN if the
        band is empty), ``low_confidence`` (bool: any flag, or an empty band).
    """
    w, arrs = _check_1d(omega, S_resp=S_resp, S_wave=S_wave)
    s_x, s_z = arrs["S_resp"], arrs["S_wave"]
    band = energetic_band(w, s_z, fraction)
    if not band.any():
        return {"resonance_unexcited": omega_n is not None, "missing_low_frequency_energy": False,
                "response_share_below_band": float("nan"), "band_low": float("nan"), "low_confidence": True}
    peak = np.nanmax(s_z)
    unexcited = False
    if omega_n is not None:
        unexcited = bool(np.interp(omega_n, w, s_z, left=0.0, right=0.0) < fraction * peak)
    band_low = float(w[np.argmax(band)])
    below = w < band_low
    # m0 = ∫ S dω (DESIGN §3), trapezoid on the given grid
    total = np.trapezoid(s_x, w)
    share = float(np.trapezoid(np.where(below, s_x, 0.0), w) / total) if total > 0 else 0.0
    missing = share > low_frequency_share
    return {"resonance_unexcited": unexcited, "missing_low_frequency_energy": bool(missing),
            "response_share_below_band": share, "band_low": band_low,
            "low_confidence": bool(unexcited or missing)}


# ---------------------------------------------------------------------------------------------
# spectral-ratio estimators
# ---------------------------------------------------------------------------------------------


def rao_long_crested(
    omega: ArrayLike,
    S_resp: ArrayLike,
    dof_resp: float | ArrayLike,
    S_wave: ArrayLike,
    fraction: float = 0.05,
    *,
    level: float = 0.95,
    omega_n: float | None = None,
    low_frequency_share: float = 0.25,
    wave_log_std: ArrayLike | None = None,
) -> RaoEstimate:
    """Long-crested RAO amplitude |H(ω)| = √(S_xx(ω)/S_ζζ(ω)) inside the energetic band.

    Without `wave_log_std` the wave spectrum S_ζζ is treated as **known and exact** (probe in a basin);
    the interval reflects only the χ² sampling error of the measured S_xx with ν = `dof_resp`:
    [√(S_low/S_ζζ), √(S_high/S_ζζ)] with (S_low, S_high) from :func:`chi2_interval` (the square root is
    monotone, so the coverage is exact). With `wave_log_std` (σ of ln|H| from the hindcast's errors, see
    :func:`wave_log_std`) the interval is widened by it. Outside the band (S_ζζ < fraction·max)
    everything is NaN.

    Parameters
    ----------
    omega : array_like, shape (n_omega,)
        Frequencies [rad/s], increasing (e.g. from :func:`~seatune.physics.adaptive_filter.welch_spectrum`).
    S_resp : array_like, shape (n_omega,)
        Measured response spectrum S_xx [unit²·s/rad].
    dof_resp : float or array_like, shape (n_omega,)
        Equivalent degrees of freedom ν of `S_resp`.
    S_wave : array_like, shape (n_omega,)
        Wave spectrum S_ζζ [m²·s/rad] on the same grid (interpolate beforehand).
    fraction : float, default 0.05
        Energetic-band threshold (A7 §4.1).
    level : float, default 0.95
        Confidence level.
    omega_n : float, optional
        Natural frequency [rad/s] passed to :func:`quality_flags`.

    Returns
    -------
    RaoEstimate
        ``method="long_crested"``; amplitude in [unit/m]; ``flags`` from :func:`quality_flags`.
    """
    w, arrs = _check_1d(omega, S_resp=S_resp, S_wave=S_wave)
    s_x, s_z = arrs["S_resp"], arrs["S_wave"]
    mask = energetic_band(w, s_z, fraction)
    # seed 002 eq. 2.8: S_r = |RAO|² S_ζ  ⇒  |RAO| = √(S_r/S_ζ)
    amp, low, high = _amplitude_from_ratio(s_x, s_z, dof_resp, level, mask, wave_log_std)
    flags = quality_flags(w, s_x, s_z, omega_n, fraction=fraction, low_frequency_share=low_frequency_share)
    wls = None if wave_log_std is None else np.asarray(wave_log_std, dtype=float)
    return RaoEstimate(w, amp, low, high, mask, dof_resp, level, "long_crested", None, flags, wls)


def rao_short_crested(
    omega: ArrayLike,
    S_resp: ArrayLike,
    dof: float | ArrayLike,
    S_wave_1d: ArrayLike,
    directional_weights: ArrayLike,
    model_rao_amplitude_by_direction: ArrayLike | None = None,
    method: Literal["de_jong", "model_shape"] = "de_jong",
    *,
    mean_index: int | None = None,
    fraction: float = 0.05,
    level: float = 0.95,
    omega_n: float | None = None,
) -> RaoEstimate:
    """RAO amplitude along the mean wave direction in a short-crested sea (de Jong / Bonaschi).

    Model of the data (seed 002 eqs. 2.8, 5.3–5.4): the sea is separable, S_ζ(ω, β_k) Δβ =
    S(ω)·W_k with Σ_k W_k = 1, and the RAO amplitude has a known directional shape D,
    |H(ω, β)| = F(ω)·D(ω, β). Then S_xx(ω) = F(ω)² S(ω) Σ_k W_k D_k², so

        F(ω) = √( S_xx(ω) / (S(ω) Σ_k W_k D_k(ω)²) ),   estimate = |H(ω, β₀)| = F(ω)·D(ω, β₀),

    β₀ the mean direction (`mean_index`, default the direction of largest weight). The scale of D
    cancels (de Jong's normalisation constant a is irrelevant).

    * ``method="de_jong"``: D is frequency independent, shape (n_beta,) — de Jong's a·|sin φ|^p
      evaluated on the grid, or any fixed shape. With ``None``, D ≡ 1: the estimate is then the
      spread-weighted RMS amplitude √(Σ_k W_k |H(ω,β_k)|²), which equals |H(ω, β₀)| only if the
      RAO is constant across the spread (it is what "response spectrum / directionally weighted wave
      spectrum" gives).
    * ``method="model_shape"``: D = |H_model(ω, β)|, shape (n_omega, n_beta) — the model's relative
      RAO shape at every frequency (the frequency-dependent D(φ, ω) de Jong recommends, §7). Then
      ``scale`` = F = √(S_xx / S_xx,model) is the measured/model amplitude ratio and the estimate is
      scale·|H_model(ω, β₀)|.

    The wave spectrum, spreading and shape are treated as exact; the interval is the χ² interval of
    S_xx mapped through the square root, as in :func:`rao_long_crested`.

    Parameters
    ----------
    omega : array_like, shape (n_omega,)
        Frequencies [rad/s].
    S_resp : array_like, shape (n_omega,)
        Measured response spectrum [unit²·s/rad].
    dof : float or array_like
        Degrees of freedom ν of `S_resp`.
    S_wave_1d : array_like, shape (n_omega,)
        Frequency part S(ω) = ∫ S_ζ(ω, β) dβ [m²·s/rad].
    directional_weights : array_like, shape (n_beta,) or (n_omega, n_beta)
        Spreading W_k ∝ D_wave(β_k) Δβ (e.g. :func:`~seatune.physics.spectra.discrete_spreading` times
        Δβ); normalised here to sum 1 over directions. A 2-D array allows frequency-dependent spreading.
    model_rao_amplitude_by_direction : array_like, optional
        RAO directional shape D: (n_beta,) for "de_jong" (optional), (n_omega, n_beta) for
        "model_shape" (required).
    method : {"de_jong", "model_shape"}
    mean_index : int, optional
        Direction index of β₀; default argmax of the frequency-summed weights.
    fraction, level, omega_n
        As in :func:`rao_long_crested`.

    Returns
    -------
    RaoEstimate
        Amplitude of |H(ω, β₀)|; ``scale`` = F(ω) for "model_shape".
    """
    w, arrs = _check_1d(omega, S_resp=S_resp, S_wave_1d=S_wave_1d)
    s_x, s_1 = arrs["S_resp"], arrs["S_wave_1d"]
    wts = np.asarray(directional_weights, dtype=float)
    if wts.ndim == 1:
        wts = np.broadcast_to(wts, (w.size, wts.size))
    if wts.ndim != 2 or wts.shape[0] != w.size or np.any(wts < 0):
        raise ValueError("directional_weights must be non-negative, shape (n_beta,) or (n_omega, n_beta)")
    tot = wts.sum(axis=1, keepdims=True)
    if np.any(tot <= 0):
        raise ValueError("directional_weights must have a positive sum at every frequency")
    wts = wts / tot
    n_beta = wts.shape[1]
    k0 = int(np.argmax(wts.sum(axis=0))) if mean_index is None else int(mean_index)
    if not 0 <= k0 < n_beta:
        raise ValueError(f"mean_index {k0} outside 0..{n_beta - 1}")

    if method == "de_jong":
        if model_rao_amplitude_by_direction is None:
            shape = np.ones((w.size, n_beta))
        else:
            d = np.abs(np.asarray(model_rao_amplitude_by_direction, dtype=float))
            if d.shape != (n_beta,):
                raise ValueError(f"de_jong takes a frequency-independent shape (n_beta,)=({n_beta},), got {d.shape}")
            shape = np.broadcast_to(d, (w.size, n_beta))
    elif method == "model_shape":
        if model_rao_amplitude_by_direction is None:
            raise ValueError("model_shape needs model_rao_amplitude_by_direction of shape (n_omega, n_beta)")
        shape = np.abs(np.asarray(model_rao_amplitude_by_direction, dtype=float))
        if shape.shape != (w.size, n_beta):
            raise ValueError(f"model_shape needs shape (n_omega, n_beta)=({w.size}, {n_beta}), got {shape.shape}")
    else:
        raise ValueError(f"method must be 'de_jong' or 'model_shape', got {method!r}")

    # seed 002 eq. 5.4: F(ω) = √( S_r / ∫ D(φ)² S_ζ(ω, φ) dφ )
    denom = s_1 * np.sum(wts * shape**2, axis=1)
    mask = energetic_band(w, s_1, fraction) & (denom > 0)
    f_amp, f_low, f_high = _amplitude_from_ratio(s_x, np.where(denom > 0, denom, np.nan), dof, level, mask)
    d0 = shape[:, k0]
    # estimate along β₀: |H(ω, β₀)| = F(ω) D(ω, β₀)  (seed 002 §3.3: plotted RAO is D(φ_main)·F(ω))
    scale = f_amp if method == "model_shape" else None
    flags = quality_flags(w, s_x, s_1, omega_n, fraction=fraction)
    return RaoEstimate(w, f_amp * d0, f_low * d0, f_high * d0, mask, dof, level, method, scale, flags)


# ---------------------------------------------------------------------------------------------
# H1 with measured wave elevation
# ---------------------------------------------------------------------------------------------


def h1_estimator(
    x: ArrayLike,
    eta: ArrayLike,
    fs: float,
    segment_s: float,
    *,
    overlap: float = 0.5,
    window: str | tuple = "hann",
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """H1 transfer-function estimate from a response record x and the measured wave elevation η.

    H1(ω) = G_ηx(ω) / G_ηη(ω) (Bendat & Piersol eq. 9.26), Welch-averaged with scipy.signal.csd /
    welch (mean removed per segment). Noise on x (not on η) averages out of H1; noise on η biases
    |H1| low by γ². The result is returned in the DESIGN §3 convention x(t) = Re{X e^{−iωt}}, i.e.
    the complex conjugate of the FFT-convention ratio, so a response lagging the waves has arg H > 0.
    Ordinary coherence γ²(ω) = |G_ηx|² / (G_ηη G_xx) ∈ [0, 1].

    Parameters
    ----------
    x : array_like, shape (n,)
        Response record [unit].
    eta : array_like, shape (n,)
        Wave elevation at the body origin [m], sampled with `x`.
    fs : float
        Sample rate [Hz].
    segment_s : float
        Welch segment length [s].
    overlap : float, default 0.5
        Segment overlap fraction in [0, 1).
    window : str or tuple, default "hann"

    Returns
    -------
    omega : ndarray, shape (n_freq,)
        Frequencies [rad/s].
    H1 : ndarray of complex, shape (n_freq,)
        Transfer function [unit/m] (DESIGN convention); NaN where G_ηη = 0.
    coherence : ndarray, shape (n_freq,)
        γ², NaN where undefined.
    dof : float
        Equivalent degrees of freedom ν of the auto-spectra (:func:`welch_dof`); ν/2 plays the role of
        the number of averages n_d in :func:`h1_confidence`.
    """
    xa = np.asarray(x, dtype=float)
    ea = np.asarray(eta, dtype=float)
    if xa.ndim != 1 or xa.shape != ea.shape or not (np.all(np.isfinite(xa)) and np.all(np.isfinite(ea))):
        raise ValueError("x and eta must be finite 1-D records of equal length")
    seg = welch_segments(xa.size, fs, segment_s, overlap, window)
    kw = dict(fs=fs, window=seg.window, nperseg=seg.nperseg, noverlap=seg.noverlap, detrend="constant")
    f, g_ee = sps.welch(ea, **kw)
    _, g_xx = sps.welch(xa, **kw)
    _, g_ex = sps.csd(ea, xa, **kw)  # scipy: G_ηx = E[conj(Η) X] (FFT convention e^{+iωt})
    with np.errstate(divide="ignore", invalid="ignore"):
        h_fft = np.where(g_ee > 0, g_ex / g_ee, np.nan)
        coh = np.where((g_ee > 0) & (g_xx > 0), np.abs(g_ex) ** 2 / (g_ee * g_xx), np.nan)
    # DESIGN §3: Re{X e^{−iωt}} convention is the conjugate of numpy's e^{+iωt} one
    return TWO_PI * f, np.conj(h_fft), np.clip(coh, 0.0, 1.0), seg.dof


def h1_confidence(
    H1: ArrayLike, coherence: ArrayLike, dof: float, level: float = 0.95
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coherence-based confidence region of H1 and the implied bounds on |H| and arg H.

    Bendat & Piersol (Random Data, §9.2.4, after Goodman 1965), single input, n = ν = 2 n_d:

        |H − Ĥ1| ≤ r,   r² = 2/(n − 2) · F_{2, n−2; α} · (1 − γ̂²)/γ̂² · |Ĥ1|²

    with F_{2, n−2; α} the upper-α point of the F distribution and ν the equivalent Welch degrees of
    freedom (overlap handled approximately through ν). Hence |H| ∈ [max(|Ĥ1| − r, 0), |Ĥ1| + r] and
    arg H ∈ arg Ĥ1 ± arcsin(min(r/|Ĥ1|, 1)). The region assumes noise only on the output.

    Parameters
    ----------
    H1 : array_like of complex, shape (n_freq,)
    coherence : array_like, shape (n_freq,)
        γ̂² in (0, 1].
    dof : float
        ν > 2.
    level : float, default 0.95
        1 − α.

    Returns
    -------
    amp_low, amp_high : ndarray, shape (n_freq,)
        Bounds of |H| [unit/m].
    phase_halfwidth : ndarray, shape (n_freq,)
        Half-width of the phase interval [rad] (π/2 when r ≥ |Ĥ1|).
    """
    if not dof > 2:
        raise ValueError(f"dof must exceed 2, got {dof!r}")
    h = np.asarray(H1)
    g2 = np.asarray(coherence, dtype=float)
    amp = np.abs(h)
    fq = stats.f.ppf(level, 2, dof - 2.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.sqrt(2.0 / (dof - 2.0) * fq * (1.0 - g2) / g2) * amp
        half = np.arcsin(np.clip(r / amp, 0.0, 1.0))
    return np.maximum(amp - r, 0.0), amp + r, half


# ---------------------------------------------------------------------------------------------
# aggregation
# ---------------------------------------------------------------------------------------------


def aggregate(
    estimates: Sequence[RaoEstimate],
    groups: Sequence[Hashable],
    *,
    level: float = 0.95,
) -> pd.DataFrame:
    """Combine per-window amplitude estimates within each group by inverse-variance weighting of ln|H|.

    Per window and frequency, ln|Ĥ| is bias-corrected and weighted with the χ² log moments
    (ν Ŝ/S ~ χ²_ν): bias b = ½(ψ(ν/2) − ln(ν/2)), variance v = ¼ψ'(ν/2). The group value is
    exp(Σ (ln|Ĥ_i| − b_i)/v_i / Σ 1/v_i) with the normal interval exp(mean ± z √(1/Σ 1/v_i)). Windows
    with ``estimate.low_confidence`` are dropped; NaN (out-of-band) points do not contribute. Only
    the response-spectrum sampling error is propagated, plus the wave spectrum's error when the estimate
    carries ``wave_log_std`` (independent between windows: each has its own hindcast error).

    Parameters
    ----------
    estimates : sequence of RaoEstimate
        All on the same frequency grid.
    groups : sequence of hashable, same length
        Group label per window, e.g. ``(heading_sector, hs_bin)``.
    level : float, default 0.95
        Confidence level of the group interval.

    Returns
    -------
    pandas.DataFrame
        Long table, one row per (group, ω) with at least one contributing window: ``group``,
        ``omega`` [rad/s], ``amplitude``, ``low``, ``high``, ``log_std`` (std of the mean ln|H|),
        ``n_windows``. Sorted by first appearance of the group, then ω.
    """
    if len(estimates) != len(groups):
        raise ValueError("estimates and groups must have equal length")
    cols = ["group", "omega", "amplitude", "low", "high", "log_std", "n_windows"]
    if not estimates:
        return pd.DataFrame(columns=cols)
    omega = np.asarray(estimates[0].omega)
    for e in estimates:
        if e.omega.shape != omega.shape or not np.allclose(e.omega, omega):
            raise ValueError("all estimates must share one frequency grid")
    z = stats.norm.ppf(0.5 + level / 2.0)
    order: dict[Hashable, list[RaoEstimate]] = {}
    for e, g in zip(estimates, groups, strict=True):
        order.setdefault(g, [])
        if not e.low_confidence:
            order[g].append(e)
    rows = []
    for g, members in order.items():
        if not members:
            continue
        num = np.zeros(omega.size)
        den = np.zeros(omega.size)
        cnt = np.zeros(omega.size, dtype=int)
        for e in members:
            bias, var = _log_amplitude_moments(np.broadcast_to(np.asarray(e.dof, dtype=float), omega.shape))
            if e.wave_log_std is not None:
                var = var + np.nan_to_num(e.wave_log_std, nan=np.inf) ** 2
            ok = np.isfinite(e.amplitude) & (e.amplitude > 0)
            y = np.where(ok, np.log(np.where(ok, e.amplitude, 1.0)) - bias, 0.0)
            wgt = np.where(ok, 1.0 / var, 0.0)
            num += wgt * y
            den += wgt
            cnt += ok
        have = den > 0
        mean = num[have] / den[have]
        sd = np.sqrt(1.0 / den[have])
        rows.append(pd.DataFrame({"group": [g] * int(have.sum()), "omega": omega[have],
                                  "amplitude": np.exp(mean), "low": np.exp(mean - z * sd),
                                  "high": np.exp(mean + z * sd), "log_std": sd, "n_windows": cnt[have]}))
    if not rows:
        return pd.DataFrame(columns=cols)
    return pd.concat(rows, ignore_index=True)[cols]

"""Adaptive lowpass cutoff (paper A3) and Welch spectra for the ``filter`` and ``identify`` stages.

Paper A3 (Han, Ren, Leira, Sævik, *Adaptive identification of lowpass filter cutoff frequency for
online vessel model tuning*, Ocean Eng. 236 (2021) 109483) lowpasses a noisy motion record with an
FFT brick-wall filter at every cutoff of an ascending grid, follows the STD σ̂(f) and the
zero-upcrossing period T̂z(f) of the filtered record, and picks the first cutoff where both curves have
flattened: the normalised slopes θ (eq. 12) and γ (eq. 13) fall below 0.05 Hz⁻¹ and 0.9 Hz⁻¹
(eq. 17, Algorithm 1); the result is clamped to [0.1, 0.9] Hz (eq. 18).

Two implementations of the same filter and decision rule:

* :func:`adaptive_cutoff` (production): one rfft of the record; σ̂(f) for every candidate is a
  cumulative sum of the periodogram (Parseval on the bins the brick-wall filter keeps), T̂z(f) follows
  from cumulative spectral moments. Cost: one FFT + O(N) for any number of candidates.
* :func:`adaptive_cutoff_reference` (plain, used by the tests and the benchmark): for each candidate,
  rfft → zero the bins above the cutoff → irfft (A2 §2.2's filter), ``np.std(ddof=1)`` (A3 eq. 1a) and
  T̂z by counting zero up-crossings of the filtered record.

How the two agree (tested in ``tests/test_adaptive_filter.py``):

* σ̂ is identical up to round-off (~1e-13 relative). For the N-sample record with DFT X_k, the
  brick-wall output with bins K = {k ≥ 1: f_k ≤ f} kept has (Parseval, mean removed by dropping DC)
  Σ_t (x̂_t − x̄)² = (1/N) Σ_{k∈K} w_k |X_k|², w_k = 2 (w = 1 at the Nyquist bin of an even N), so
  σ̂² = Σ_{k∈K} w_k |X_k|² / (N (N − 1)) reproduces ``np.std(x̂, ddof=1)`` with A3's N − 1 (eq. 1a).
* T̂z: counted up-crossings are a random quantity whose *expectation* the spectrum gives; no
  spectral formula can reproduce one realisation's count. The default ``tz_method="sampled"`` is
  Rice's formula for a *sampled* stationary Gaussian record (the cosine formula, Kedem 1986:
  E[up-crossings per step] = arccos(ρ₁)/(2π), ρ₁ the lag-one autocorrelation), and ρ₁ is the exact
  circular lag-one autocorrelation of the filtered record, Σ w_k|X_k|² cos(ω_k Δt) / Σ w_k|X_k|²
  (Wiener–Khinchin on the DFT). So T̂z = 2π Δt / arccos(ρ₁) is what the counting estimates, and it tends
  to DESIGN §3's Tz = 2π √(m0/m2) as Δt → 0 (``tz_method="moments"`` gives that form). The counted
  T̂z scatters around it by its sampling error, ~1/√(N_up) relative for N_up crossings — larger than
  the ±1-crossing resolution 1/N_up of the count itself. For a pure tone the count is deterministic and
  the two agree to ±1 crossing.

Deliberate deviations from A3, and choices where A3 is silent:

* T̂z from the spectrum (above) instead of counting; it is smooth in f, so γ is less noisy than with
  counted crossings (A3 §4 makes γ a loose, supplementary criterion because of that noise).
* Velocity/acceleration statistics of a displacement record come from S_ẋ = ω² S_x (Han thesis
  eq. 2.10), never from differencing. The reference does the same differentiation exactly (×(iω)^q on
  the rfft bins). For odd q the Nyquist bin is dropped: a real sampled tone at Nyquist has no
  derivative samples (irfft discards its imaginary part, and so does the fast path).
* Before differentiating, the end-to-end ramp (x_{N−1} − x_0)·t/((N−1)Δt) is subtracted, so the
  periodic extension the DFT assumes has no jump. Its derivative is a constant, which the STD removes,
  so the statistic is unchanged — but the jump's leakage (|X_k|² ∝ 1/k², flat after ×ω²) is gone.
  Without it a 30-min heave record's acceleration σ̂ at 0.9 Hz came out 9–16 % high; with it < 0.1 %
  (velocity < 0.01 % at any cutoff; acceleration near Nyquist still ~1–5 % from the slope mismatch).
* The 83-value validation grid of A3 §5.1 is not listed in the paper (only a histogram, Fig. 12);
  :data:`A3_VALIDATION_GRID_HZ` is our reconstruction with the stated properties (83 values in
  [0.06, 5.13] Hz, finest in [0.1, 0.3] Hz). :data:`A3_EXPLORATION_GRID_HZ` is the 26-value grid A3
  §3.2 does list.
* A grid exhausted before the criteria hold (A3 leaves it undefined) returns f_max and ``clamped``.
* Optional brick-wall highpass against drift / low-frequency motion (A3 §5.2.2 used 0.04 Hz).
* Froude scaling (not in A3): a model-scale record runs √λ faster, so A3's full-scale frequencies
  (default grid, f_min, f_max) are multiplied by √λ and its slope limits θ_max, γ_max [Hz⁻¹] divided
  by √λ; the decision on the scaled record is then the decision on the full-scale record.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy import signal as sps

__all__ = [
    "A3_EXPLORATION_GRID_HZ",
    "A3_VALIDATION_GRID_HZ",
    "FilterResult",
    "adaptive_cutoff",
    "adaptive_cutoff_reference",
    "brickwall_filter",
    "slopes",
    "select_cutoff",
    "snr_removed",
    "upcrossing_period",
    "welch_dof",
    "welch_spectrum",
]

TWO_PI = 2.0 * np.pi
Kind = Literal["displacement", "velocity", "acceleration"]
TzMethod = Literal["sampled", "moments"]
_ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}

# A3 §3.2: the cutoffs of the exploration study ("25" in the text, 26 listed; the first 17 are 1/T for
# T = 20, 19, ..., 4 s, rounded) [Hz].
A3_EXPLORATION_GRID_HZ = np.array([
    0.050, 0.053, 0.056, 0.059, 0.063, 0.067, 0.071, 0.077, 0.083, 0.091, 0.10, 0.111, 0.125, 0.143, 0.167,
    0.20, 0.25, 0.30, 0.33, 0.40, 0.50, 0.60, 0.75, 1.0, 1.5, 2.0,
])

# A3 §5.1: "83 values of f_lp ∈ [0.06, 5.13] Hz ... resolution gradually increased with decreasing f_lp,
# especially for f_lp ∈ [0.1, 0.3] Hz". The values are not published; this reconstruction steps by
# 0.008 Hz in [0.06, 0.1), 0.005 in [0.1, 0.3), 0.02 in [0.3, 0.5), 0.05 in [0.5, 1), 0.1 in [1, 2),
# 0.5 in [2, 5], then 5.13 [Hz].
A3_VALIDATION_GRID_HZ = np.round(np.concatenate([
    0.06 + 0.008 * np.arange(5),
    0.10 + 0.005 * np.arange(40),
    0.30 + 0.02 * np.arange(10),
    0.50 + 0.05 * np.arange(10),
    1.00 + 0.10 * np.arange(10),
    2.00 + 0.50 * np.arange(7),
    [5.13],
]), 6)


@dataclass(frozen=True)
class FilterResult:
    """Outcome of the adaptive cutoff search for one record.

    Attributes
    ----------
    cutoff_hz : float
        Chosen cutoff after the clamp (A3 eq. 18) [Hz, in the record's time base].
    sigma : float
        STD (ddof = 1) of the record lowpassed at `cutoff_hz` [unit of the statistic].
    tz : float
        Zero-upcrossing period of the record lowpassed at `cutoff_hz` [s].
    candidates_hz : ndarray, shape (n,)
        Candidate cutoffs, ascending [Hz].
    sigma_curve, tz_curve : ndarray, shape (n,)
        σ̂(f) and T̂z(f) at every candidate (NaN T̂z where nothing passes the filter).
    theta, gamma : ndarray, shape (n,)
        Normalised slopes of A3 eqs. 12–13 [Hz⁻¹]; NaN at the first candidate.
    clamped : bool
        The cutoff hit the [f_min, f_max] clamp (or the grid was exhausted, see `selected_index`).
    selected_index : int
        Index of the first candidate meeting both criteria (A3's f̃*, before the clamp), or −1 when
        no candidate does (then `cutoff_hz` is f_max).
    sigma_raw : float
        STD (ddof = 1) of the record before the lowpass (after the optional highpass).
    """

    cutoff_hz: float
    sigma: float
    tz: float
    candidates_hz: np.ndarray
    sigma_curve: np.ndarray
    tz_curve: np.ndarray
    theta: np.ndarray
    gamma: np.ndarray
    clamped: bool
    selected_index: int = -1
    sigma_raw: float = float("nan")

    @property
    def unclamped_cutoff_hz(self) -> float:
        """A3's f̃*: the first candidate meeting both criteria (NaN if the grid was exhausted)."""
        return float(self.candidates_hz[self.selected_index]) if self.selected_index >= 0 else float("nan")

    @property
    def snr_estimate(self) -> float:
        """SNR treating all the lowpass removed as noise: σ̂²/(σ_raw² − σ̂²) (as annotated in A3 Figs. 14, 17)."""
        return snr_removed(self.sigma_raw, self.sigma)


# --------------------------------------------------------------------------------------------------
# Decision rule (shared by both implementations)
# --------------------------------------------------------------------------------------------------


def slopes(candidates_hz: ArrayLike, sigma: ArrayLike, tz: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Normalised backward-difference slopes θ and γ of the σ̂(f) and T̂z(f) curves.

    Parameters
    ----------
    candidates_hz : array_like, shape (n,)
        Ascending cutoffs [Hz].
    sigma, tz : array_like, shape (n,)
        σ̂ and T̂z at the cutoffs.

    Returns
    -------
    theta, gamma : ndarray, shape (n,)
        [Hz⁻¹]; element 0 is NaN (no backward neighbour). θ = +inf where σ̂ = 0; NaN where T̂z is
        undefined — both fail the criteria.
    """
    f = np.asarray(candidates_hz, dtype=float)
    s = np.asarray(sigma, dtype=float)
    t = np.asarray(tz, dtype=float)
    df = np.diff(f)
    theta = np.full(f.shape, np.nan)
    gamma = np.full(f.shape, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        theta[1:] = (s[1:] - s[:-1]) / (s[1:] * df)  # A3 eq. 12: θ(f_i) = [σ̂(f_i) − σ̂(f_i−1)] / [σ̂(f_i) Δf]
        gamma[1:] = (t[:-1] - t[1:]) / (t[1:] * df)  # A3 eq. 13: γ(f_i) = [T̂z(f_i−1) − T̂z(f_i)] / [T̂z(f_i) Δf]
    theta[1:][s[1:] == 0.0] = np.inf
    return theta, gamma


def select_cutoff(theta: ArrayLike, gamma: ArrayLike, theta_max: float = 0.05, gamma_max: float = 0.9) -> int:
    """Index of the first candidate with θ ≤ θ_max and γ ≤ γ_max (A3 Algorithm 1, eq. 17), or −1.

    Algorithm 1 starts from θ = 1, γ = 10 and evaluates the slopes from the second candidate on, so the
    first candidate can never be chosen; the loop runs "while θ > θ_max **or** γ > γ_max", i.e. it stops
    at the first index where *both* hold (the thesis copy's "≥ … and ≥" contradicts A3's prose).
    """
    th = np.asarray(theta, dtype=float)
    ga = np.asarray(gamma, dtype=float)
    ok = (th <= theta_max) & (ga <= gamma_max)  # A3 eq. 17a, 17b (NaN compares False)
    ok[:1] = False
    hits = np.flatnonzero(ok)
    return int(hits[0]) if hits.size else -1


def snr_removed(sigma_raw: float, sigma_filtered: float) -> float:
    """SNR = σ̂*² / (σ_X² − σ̂*²): everything the lowpass removed counted as noise.

    This is how the SNR annotations of A3 §5.2 (CaseA1: σ_X = 44.0235, σ̂* = 43.9935, SNR 732.9) are
    evidently computed (A3 eq. 7 with σ_N² = σ_X² − σ̂*²).
    """
    removed = sigma_raw**2 - sigma_filtered**2
    return float(sigma_filtered**2 / removed) if removed > 0 else float("inf")


# --------------------------------------------------------------------------------------------------
# Shared argument handling
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Setup:
    x: np.ndarray
    fs: float
    q: int
    candidates: np.ndarray
    theta_max: float
    gamma_max: float
    f_lo: float
    f_hi: float
    highpass_hz: float | None


def _end_matched(x: np.ndarray) -> np.ndarray:
    """x minus the ramp joining its ends: no jump in the DFT's periodic extension (derivatives only)."""
    return x - (x[-1] - x[0]) * np.arange(x.size) / (x.size - 1)


def _setup(x, fs, candidates_hz, theta_max, gamma_max, f_min, f_max, froude_scale, highpass_hz, kind) -> _Setup:
    arr = np.asarray(x, dtype=float)
    if arr.ndim != 1 or arr.size < 8:
        raise ValueError(f"x must be a 1-D record of at least 8 samples, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("x contains NaN or inf samples; repair or mask gaps before filtering")
    if not (np.isfinite(fs) and fs > 0):
        raise ValueError(f"fs must be a positive sample rate [Hz], got {fs!r}")
    if kind not in _ORDER:
        raise ValueError(f"kind must be one of {sorted(_ORDER)}, got {kind!r}")
    if not (np.isfinite(froude_scale) and froude_scale > 0):
        raise ValueError(f"froude_scale must be a positive length ratio λ = L_full / L_record, got {froude_scale!r}")
    root = float(np.sqrt(froude_scale))
    if candidates_hz is None:
        cand = A3_VALIDATION_GRID_HZ * root  # full-scale grid → record time base (f_record = f_full √λ)
    else:
        cand = np.asarray(candidates_hz, dtype=float)
        if cand.ndim != 1 or cand.size < 2 or not np.all(np.isfinite(cand)) or cand[0] <= 0:
            raise ValueError("candidates_hz must be a 1-D array of at least 2 positive cutoffs [Hz]")
        if np.any(np.diff(cand) <= 0):
            raise ValueError("candidates_hz must be strictly ascending (A3 Algorithm 1)")
    if not 0 < f_min <= f_max:
        raise ValueError(f"need 0 < f_min <= f_max, got f_min={f_min!r}, f_max={f_max!r}")
    if theta_max <= 0 or gamma_max <= 0:
        raise ValueError(f"theta_max and gamma_max must be positive, got {theta_max!r}, {gamma_max!r}")
    if highpass_hz is not None and not (np.isfinite(highpass_hz) and highpass_hz > 0):
        raise ValueError(f"highpass_hz must be a positive frequency [Hz] or None, got {highpass_hz!r}")
    q = _ORDER[kind]
    if q:
        arr = _end_matched(arr)
    # Froude: slopes are per Hz, so a record √λ faster has slopes √λ smaller.
    return _Setup(arr, float(fs), q, cand, theta_max / root, gamma_max / root, f_min * root,
                  f_max * root, highpass_hz)


def _finish(s: _Setup, sigma_curve, tz_curve, stats_at, sigma_raw: float) -> FilterResult:
    theta, gamma = slopes(s.candidates, sigma_curve, tz_curve)
    i = select_cutoff(theta, gamma, s.theta_max, s.gamma_max)
    f_tilde = s.candidates[i] if i >= 0 else np.inf  # grid exhausted → f_max (not defined by A3)
    cutoff = float(min(max(f_tilde, s.f_lo), s.f_hi))  # A3 eq. 18 (clamp)
    clamped = bool(i < 0 or f_tilde < s.f_lo or f_tilde > s.f_hi)
    if i >= 0 and not clamped:
        sigma, tz = float(sigma_curve[i]), float(tz_curve[i])
    else:
        sigma, tz = stats_at(cutoff)
    return FilterResult(cutoff, sigma, tz, s.candidates, np.asarray(sigma_curve), np.asarray(tz_curve), theta, gamma,
                        clamped, i, float(sigma_raw))


# --------------------------------------------------------------------------------------------------
# Fast path
# --------------------------------------------------------------------------------------------------


class _CumulativeSpectrum:
    """Cumulative periodogram sums of one record: σ̂ and T̂z of the brick-wall output at any cutoff."""

    def __init__(self, s: _Setup, tz_method: TzMethod):
        n = s.x.size
        self.n, self.fs, self.tz_method = n, s.fs, tz_method
        self.freq = np.fft.rfftfreq(n, 1.0 / s.fs)
        omega = TWO_PI * self.freq
        spec = np.fft.rfft(s.x)
        power = spec.real**2 + spec.imag**2
        weight = np.full(self.freq.size, 2.0)  # one-sided bins count twice in Parseval ...
        weight[0] = 0.0  # ... the DC bin is the mean, removed by the STD
        if n % 2 == 0:
            weight[-1] = 1.0 if s.q % 2 == 0 else 0.0  # Nyquist bin once; no derivative for odd orders
        if s.highpass_hz is not None:
            weight[self.freq < s.highpass_hz] = 0.0  # brick-wall highpass: drop bins below highpass_hz
        p = weight * power * omega ** (2 * s.q)  # Han eq. 2.10: S_ẋ = ω² S_x per derivative order
        self.c0 = np.cumsum(p)
        if tz_method == "sampled":
            self.c1 = np.cumsum(p * np.cos(omega / s.fs))  # circular lag-one autocovariance (× N²/…)
        elif tz_method == "moments":
            self.c1 = np.cumsum(p * omega**2)  # second spectral moment m2 (same scale as c0)
        else:
            raise ValueError(f"tz_method must be 'sampled' or 'moments', got {tz_method!r}")

    def stats(self, cutoffs: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        last = np.searchsorted(self.freq, np.asarray(cutoffs, dtype=float), side="right") - 1  # bins f_k ≤ f
        m0 = self.c0[last]
        sigma = np.sqrt(m0 / (self.n * (self.n - 1.0)))  # A3 eq. 1a via Parseval (N − 1 as in A3)
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.tz_method == "sampled":
                rho1 = np.clip(self.c1[last] / m0, -1.0, 1.0)
                tz = TWO_PI / (self.fs * np.arccos(rho1))  # cosine formula: E[up-crossings/step] = arccos(ρ₁)/2π
            else:
                tz = TWO_PI * np.sqrt(m0 / self.c1[last])  # DESIGN §3: Tz = 2π √(m0/m2)
        tz = np.where(m0 > 0, tz, np.nan)
        return sigma, tz


def adaptive_cutoff(
    x: ArrayLike,
    fs: float,
    *,
    candidates_hz: ArrayLike | None = None,
    theta_max: float = 0.05,
    gamma_max: float = 0.9,
    f_min: float = 0.1,
    f_max: float = 0.9,
    froude_scale: float = 1.0,
    highpass_hz: float | None = None,
    kind: Kind = "displacement",
    tz_method: TzMethod = "sampled",
) -> FilterResult:
    """Adaptive lowpass cutoff of A3 (Algorithm 1) evaluated for all candidates from one FFT.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Uniformly sampled record (finite; repair gaps first). Any unit.
    fs : float
        Sample rate [Hz].
    candidates_hz : array_like, shape (n,), optional
        Ascending cutoffs [Hz] in the record's time base. Default: A3's 83-value grid
        (:data:`A3_VALIDATION_GRID_HZ`, reconstructed) times √froude_scale.
    theta_max, gamma_max : float, default 0.05, 0.9
        Criteria on θ and γ (A3 eq. 17, "Crit1") [Hz⁻¹ at full scale].
    f_min, f_max : float, default 0.1, 0.9
        Clamp of the chosen cutoff (A3 eq. 18) [Hz at full scale].
    froude_scale : float, default 1.0
        λ = L_full / L_record: 1 for a full-scale record, e.g. 50 for a 1:50 model test. The default
        grid and f_min, f_max are multiplied by √λ, theta_max and gamma_max divided by √λ (Froude:
        f_record = f_full √λ). `candidates_hz` and `highpass_hz` are taken as given.
    highpass_hz : float, optional
        Brick-wall highpass applied first (bins below it dropped), against drift and low-frequency
        motion (A3 §5.2.2 used 0.04 Hz) [Hz, record time base].
    kind : {"displacement", "velocity", "acceleration"}, default "displacement"
        The statistic wanted from the record x: of x itself, of ẋ or of ẍ; the derivatives are taken
        on the spectrum, S_ẋ = ω² S_x (Han thesis eq. 2.10). This is the derivative to take, *not*
        the sensor type: a rate-gyro or accelerometer channel analysed as recorded uses
        "displacement" ("no differentiation"); "acceleration" on an accelerometer record would
        return the statistics of its second derivative.
    tz_method : {"sampled", "moments"}, default "sampled"
        T̂z = 2π Δt / arccos(ρ₁) (expected up-crossing period of the sampled record, the quantity A3's
        counting estimates) or 2π √(m0/m2) (DESIGN §3, the Δt → 0 limit).

    Returns
    -------
    FilterResult
        Chosen cutoff, σ̂ and T̂z there, the curves and slopes over the candidates.
    """
    s = _setup(x, fs, candidates_hz, theta_max, gamma_max, f_min, f_max, froude_scale, highpass_hz, kind)
    cum = _CumulativeSpectrum(s, tz_method)
    sigma_curve, tz_curve = cum.stats(s.candidates)
    sigma_raw = float(cum.stats([np.inf])[0][0])

    def stats_at(cutoff: float) -> tuple[float, float]:
        sig, tz = cum.stats([cutoff])
        return float(sig[0]), float(tz[0])

    return _finish(s, sigma_curve, tz_curve, stats_at, sigma_raw)


# --------------------------------------------------------------------------------------------------
# Plain reference
# --------------------------------------------------------------------------------------------------


def brickwall_filter(x: ArrayLike, fs: float, cutoff_hz: float, *, highpass_hz: float | None = None,
                     order: int = 0) -> np.ndarray:
    """Ideal FFT lowpass (A2 §2.2 / A3 §3.2 "FFT lowpass filter"): rfft, zero bins with f > cutoff, irfft.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Record.
    fs : float
        Sample rate [Hz].
    cutoff_hz : float
        Bins with f_k > cutoff_hz are zeroed [Hz].
    highpass_hz : float, optional
        Bins with f_k < highpass_hz are zeroed too [Hz].
    order : int, default 0
        Derivative order q: the bins are multiplied by (iω)^q (exact spectral differentiation), after
        the end-to-end ramp of x is removed (it only shifts the derivative's mean; see module notes).

    Returns
    -------
    ndarray, shape (n_samples,)
        Filtered (and differentiated) record.
    """
    xa = np.asarray(x, dtype=float)
    if order:
        xa = _end_matched(xa)
    spec = np.fft.rfft(xa)
    freq = np.fft.rfftfreq(xa.size, 1.0 / fs)
    if order:
        spec = spec * (1j * TWO_PI * freq) ** order
    spec[freq > cutoff_hz] = 0.0
    if highpass_hz is not None:
        spec[freq < highpass_hz] = 0.0
    return np.fft.irfft(spec, n=xa.size)


def upcrossing_period(y: ArrayLike, fs: float) -> float:
    """T̂z = record duration / number of zero up-crossings of y − ȳ [s] (NaN without crossings).

    A3 does not define its T̂z estimator; this is the plain reading (digest §1.6). Resolution: ±1
    crossing, i.e. ΔT̂z/T̂z ≈ 1/N_up.
    """
    ya = np.asarray(y, dtype=float)
    ya = ya - ya.mean()
    n_up = np.count_nonzero((ya[:-1] < 0.0) & (ya[1:] >= 0.0))
    return ya.size / fs / n_up if n_up else float("nan")


def adaptive_cutoff_reference(
    x: ArrayLike,
    fs: float,
    *,
    candidates_hz: ArrayLike | None = None,
    theta_max: float = 0.05,
    gamma_max: float = 0.9,
    f_min: float = 0.1,
    f_max: float = 0.9,
    froude_scale: float = 1.0,
    highpass_hz: float | None = None,
    kind: Kind = "displacement",
) -> FilterResult:
    """A3 Algorithm 1 done literally: filter the record at every candidate, STD and counted T̂z.

    Same parameters and result as :func:`adaptive_cutoff`; T̂z comes from :func:`upcrossing_period`.
    Kept plain on purpose: the tests and ``benchmarks/bench_filter.py`` compare the fast path with it.
    (All candidates are evaluated so that the curves can be compared; Algorithm 1 would stop at the
    chosen one, which does not change the choice.)
    """
    s = _setup(x, fs, candidates_hz, theta_max, gamma_max, f_min, f_max, froude_scale, highpass_hz, kind)

    def stats_at(cutoff: float) -> tuple[float, float]:
        y = brickwall_filter(s.x, s.fs, cutoff, highpass_hz=s.highpass_hz, order=s.q)
        return float(np.std(y, ddof=1)), upcrossing_period(y, s.fs)  # A3 eq. 1a

    curves = np.array([stats_at(c) for c in s.candidates])
    return _finish(s, curves[:, 0], curves[:, 1], stats_at, stats_at(np.inf)[0])


# --------------------------------------------------------------------------------------------------
# Welch spectrum
# --------------------------------------------------------------------------------------------------


def welch_dof(n_segments: int, window: np.ndarray, step: int) -> float:
    """Equivalent degrees of freedom of a Welch estimate (Welch 1967; Percival & Walden 1993, eq. 292b).

    ν = 2 K / (1 + 2 Σ_{m=1}^{K−1} (1 − m/K) ρ²(m)), ρ(m) = Σ_t h_t h_{t+mD} / Σ_t h_t² the overlap
    correlation of the window h at a shift of m steps D. Valid away from ω = 0 and the Nyquist
    frequency (there ν halves). For Hann at 50 % overlap ρ(1) = 1/6 and ν = 36K²/(19K − 1) (P&W 292c).
    """
    h = np.asarray(window, dtype=float)
    k = int(n_segments)
    if k < 1:
        raise ValueError(f"n_segments must be >= 1, got {n_segments!r}")
    norm = np.dot(h, h)
    total = 0.0
    for m in range(1, k):
        shift = m * step
        if shift >= h.size:
            break
        rho = np.dot(h[shift:], h[: h.size - shift]) / norm
        total += (1.0 - m / k) * rho**2
    return 2.0 * k / (1.0 + 2.0 * total)


def welch_spectrum(
    x: ArrayLike,
    fs: float,
    *,
    segment_s: float = 300.0,
    overlap: float = 0.5,
    window: str | tuple = "hann",
) -> tuple[np.ndarray, np.ndarray, float]:
    """One-sided Welch spectrum in rad/s (DESIGN §3) with its equivalent degrees of freedom.

    Segments of `segment_s` seconds overlap by the fraction `overlap`, each with its mean removed and
    tapered by `window` (scipy's periodic window); trailing samples that do not fill a segment are
    dropped. The default 300 s segments give Δω = 2π/300 ≈ 0.021 rad/s — fine enough for a roll peak
    with ζ ≈ 0.05 at ω_n ≈ 0.5 rad/s (half-power width 2ζω_n = 0.05 rad/s) — and ≈ 11 segments
    (ν ≈ 21) in a 30-min record.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Record (finite).
    fs : float
        Sample rate [Hz].
    segment_s : float, default 300.0
        Segment length [s]; must not exceed the record.
    overlap : float, default 0.5
        Overlap fraction of consecutive segments, in [0, 1).
    window : str or tuple, default "hann"
        Any window :func:`scipy.signal.get_window` accepts.

    Returns
    -------
    omega : ndarray, shape (n_freq,)
        Frequencies [rad/s], from 0 to the Nyquist frequency.
    S : ndarray, shape (n_freq,)
        One-sided spectral density [unit²·s/rad]; Σ S Δω ≈ variance of x.
    dof : float
        Equivalent degrees of freedom ν (:func:`welch_dof`): ν S / S_true ~ χ²_ν, so a (1 − α)
        interval is [ν S / χ²_ν(1 − α/2), ν S / χ²_ν(α/2)].
    """
    xa = np.asarray(x, dtype=float)
    if xa.ndim != 1 or not np.all(np.isfinite(xa)):
        raise ValueError("x must be a finite 1-D record")
    if not (np.isfinite(fs) and fs > 0):
        raise ValueError(f"fs must be a positive sample rate [Hz], got {fs!r}")
    seg = welch_segments(xa.size, fs, segment_s, overlap, window)
    f, s_f = sps.welch(xa, fs=fs, window=seg.window, nperseg=seg.nperseg, noverlap=seg.noverlap,
                       detrend="constant", return_onesided=True, scaling="density")
    # S(ω) dω = S(f) df with ω = 2πf (DESIGN §3: one-sided, rad/s)
    return TWO_PI * f, s_f / TWO_PI, seg.dof


@dataclass(frozen=True)
class WelchSegments:
    nperseg: int
    noverlap: int
    window: np.ndarray
    dof: float  # equivalent degrees of freedom of the averaged spectrum (welch_dof)


def welch_segments(n: int, fs: float, segment_s: float, overlap: float, window: str) -> WelchSegments:
    """Segment length, overlap, window and ν of a Welch average over a record of n samples."""
    if not 0.0 <= overlap < 1.0:
        raise ValueError(f"overlap must be in [0, 1), got {overlap!r}")
    nperseg = int(round(segment_s * fs))
    if nperseg < 2 or nperseg > n:
        raise ValueError(f"segment_s={segment_s!r} gives {nperseg} samples per segment; the record has {n}")
    noverlap = min(int(round(overlap * nperseg)), nperseg - 1)
    win = sps.get_window(window, nperseg)
    step = nperseg - noverlap
    return WelchSegments(nperseg, noverlap, win, welch_dof((n - noverlap) // step, win, step))

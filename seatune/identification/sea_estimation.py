"""The directional sea of one window from the ship's own motions (the wave-buoy analogy). Pure computation.

The measured cross-spectral matrix Φ̂(ω) of the motion channels is matched by the model

    Φ(ω) = Σ_D H(ω, β_D) H(ω, β_D)ᴴ S(ω, D) ΔD                        (DESIGN §4; Nielsen 2006 eq. 3)

with H the channel RAOs of the current loading and S a parametric sea of up to four partitions (JONSWAP in
ω with its tail's exponent n free, cos-2s in direction; each Hs, Tp, coming-from direction, spread, γ, n). The
hindcast is the prior of the partitions it holds; partitions it lacks are searched for and kept when the data ask
for them.

Choices (Nielsen's Bayesian wave-buoy analogy and the NetSSE spectral-residual method fit the same equation;
neither fixes these):
* Residuals: log autospectra (sampling variance 2/ν of a χ²_ν estimate, the Welch degrees of freedom ν, plus
  0.1² of model error) and the real and imaginary parts of the complex coherency Φ_ij/√(Φ_ii Φ_jj) (an
  approximate sampling variance, see estimate_sea) — phases carry direction, and coherency does not depend
  on the RAO's level.
* Resolution: the model is compared as Welch's estimate sees it, evaluated on a grid 3× finer than the bins and
  convolved with the Hann segment's spectral window |W|² (the expected Welch estimate, Welch 1967; as diagnose
  does): a roll resonance of a few per cent damping or a narrow swell is narrower than a 128 s bin, and the
  model at the bin centres missed such a peak by up to 0.8 in ln S.
* RAO uncertainty: the model's spread of each residual over the prior design loadings (the loading prior's
  mean and ±√3σ per parameter) is added to its variance, so a roll autospectrum near an uncertain roll
  resonance cannot decide the sea. A floor (1 % of the channel's peak) keeps noise-only bins from steering.
* Shape: n = 5 is JONSWAP, γ = 1 and n = 4λ + 1 Ochi–Hubble. Swells are narrower and steeper than JONSWAP: with
  n held at 5, an Ochi–Hubble swell's tail was fitted up to 2.4× too high at a barge's roll resonance in the trough
  below the wind sea, and identify's roll ω_n read off the admittance there came out 5 % low (blind bank).
* Fit: maximum a posteriori by Gauss–Newton (scipy least_squares) with the hindcast partitions as Gaussian
  priors (log Hs, log Tp, direction, log spread, log γ, log n); covariance (JᵀJ)⁻¹ scaled by the reduced χ² when
  the fit is worse than the noise model (model error the variance did not hold).
* Missing partitions: a grid over (Tp, direction, Hs) of an added partition, its three best cells at least 90° apart
  refined; it is kept when, on the residuals the loading hardly changes (design spread < 0.15 of a log autospectrum,
  < 0.1 of a coherency), its likelihood ratio with the residual scale profiled out, n·ln(RSS₀/RSS₁), exceeds k·ln n
  (BIC with k = 7: five parameters, Tp and direction counted twice as they are searched for and exist only under the
  alternative; n those residuals / 2 for the correlation of adjacent Welch bins), its Hs ≥ `min_hs`, and it is not a
  shape correction of a partition at the same period and direction; an added system a later one made redundant is
  pruned. Partitions close in Tp and direction form one wave system. Profiling the scale matters: the assumed
  variances hold model error, and a fixed-variance χ² gain held back crossing swells in well-fitted windows. Bank,
  one window in two, missing swells found / false systems per window: χ² gain > 5 ln n with 3 partitions 55 % /
  0.15; profiled, 5 ln n, 3 partitions 67 % / 0.17; profiled, 7 ln n, 4 partitions 69 % / 0.11.
* Record: a hindcast's error persists over the hours of a record while one window sees it through sampling noise,
  so each window is fitted a second time with its hindcast priors moved by the error the record's other windows
  found (`pooled_priors`, a random-effects mean), and with a prior for each system it found that the hindcast lacks,
  from the same system in the other windows (`record_priors`; kept only by the test a searched system passes).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cache

import numpy as np
from scipy import interpolate, optimize, signal, special

from seatune.physics.spectra import _peak_exponent

TWO_PI = 2.0 * np.pi
FIELDS = ("hs", "tp", "dir_from_deg", "spread_deg", "gamma", "tail")
N_COORD = len(FIELDS)  # fitted coordinates per partition: log Hs, log Tp, direction, log spread, log γ, log n
JONSWAP_TAIL = 5.0  # n of JONSWAP's ω⁻ⁿ tail; an (P, 5) x without the n column means it
# a wind sea's tail lies in the equilibrium range, between Toba's ω⁻⁴ and Phillips's ω⁻⁵ (Donelan et al. 1985): n = 5
# within e^±0.15 (with a swell's e^±0.6, osv_clean_002's wind sea read n 4.0–5.8 against its true 5)
WIND_SEA_TAIL_LOG_STD = 0.15
DIRS_FROM = np.arange(72) * 5.0  # the estimate's direction grid [deg, coming-from]


def _tail_shape(u: np.ndarray, n: np.ndarray) -> np.ndarray:
    """u⁻ⁿ exp(−(n/4) u⁻⁴), u = ω/ω_p: peaked at u = 1 for every n; n = 5 is JONSWAP's (Pierson–Moskowitz's) shape,
    n = 4λ + 1 Ochi–Hubble's single peak of shape λ (Ochi & Hubble 1976, eq. 1)."""
    with np.errstate(over="ignore", divide="ignore"):
        return np.exp(-0.25 * n * u**-4.0 - n * np.log(u))


@cache
def _shape_norm_spline() -> interpolate.RectBivariateSpline:
    """16 ∫ g_n γ^r du over the fitted γ (1–7) and n (3–30), u = ω/ω_p, g_n = `_tail_shape`, as a cubic spline in
    (ln γ, ln n): the spectrum is Hs²/ω_p · g_n γ^r / norm. Quadrature per (γ, n) is too slow for a fit that moves
    both continuously, so the norm is tabulated once, on first use (the tail beyond u = 30 analytically); a spline,
    not a bilinear table, keeps the fit's derivatives continuous. Within 1e-6 of the integral between nodes."""
    u = np.geomspace(0.2, 30.0, 4000)
    log_gamma = np.linspace(0.0, np.log(7.0), 49)
    log_n = np.linspace(np.log(3.0), np.log(30.0), 65)
    peak = np.exp(log_gamma[:, None] * _peak_exponent(u, 0.07, 0.09))  # (nγ, nu)
    norm = np.empty((log_gamma.size, log_n.size))
    for j, n in enumerate(np.exp(log_n)):
        norm[:, j] = 16.0 * (np.trapezoid(peak * _tail_shape(u, n), u, axis=1) + u[-1] ** (1.0 - n) / (n - 1.0))
    return interpolate.RectBivariateSpline(log_gamma, log_n, norm)


def _shape_norm(log_gamma: np.ndarray, log_n: np.ndarray) -> np.ndarray:
    """16 ∫ g_n γ^r du at each (ln γ, ln n) (`_shape_norm_spline`)."""
    return _shape_norm_spline()(log_gamma, log_n, grid=False)


@dataclass(frozen=True)
class PartitionPrior:
    """A Gaussian prior of one partition in the fitted coordinates (log Hs, log Tp, direction, log spread, log γ,
    log n); an infinite std leaves that coordinate free. n, the tail's exponent, is JONSWAP's 5 within a factor
    e^±0.6: a hindcast gives no shape, and swells are narrower (an Ochi–Hubble swell of λ = 5 has n = 21); a wind
    sea's within WIND_SEA_TAIL_LOG_STD."""

    hs: float
    tp: float
    dir_from_deg: float
    spread_deg: float = 25.0
    gamma: float = 3.3
    hs_log_std: float = 0.25
    tp_log_std: float = 0.15
    dir_std_deg: float = 30.0
    spread_log_std: float = 0.5
    gamma_log_std: float = 0.5
    tail: float = JONSWAP_TAIL
    tail_log_std: float = 0.6
    in_hindcast: bool = True

    def mean(self) -> np.ndarray:
        return np.array([np.log(self.hs), np.log(self.tp), self.dir_from_deg, np.log(self.spread_deg),
                         np.log(self.gamma), np.log(self.tail)])

    def std(self) -> np.ndarray:
        return np.array([self.hs_log_std, self.tp_log_std, self.dir_std_deg, self.spread_log_std,
                         self.gamma_log_std, self.tail_log_std])

    def moved(self, mean: np.ndarray, std: np.ndarray) -> PartitionPrior:
        """This prior with the fitted coordinates' mean and std replaced (the inverse of mean() and std())."""
        return replace(self, hs=float(np.exp(mean[0])), tp=float(np.exp(mean[1])), dir_from_deg=float(mean[2] % 360.0),
                       spread_deg=float(np.exp(mean[3])), gamma=float(np.exp(mean[4])), tail=float(np.exp(mean[5])),
                       hs_log_std=float(std[0]), tp_log_std=float(std[1]), dir_std_deg=float(std[2]),
                       spread_log_std=float(std[3]), gamma_log_std=float(std[4]), tail_log_std=float(std[5]))


@dataclass(frozen=True)
class Partition:
    """An estimated partition: values and standard deviations of (hs [m], tp [s], dir_from_deg, spread_deg,
    gamma, tail), and the prior it came from (None: absent from the hindcast)."""

    value: dict
    std: dict
    prior: PartitionPrior | None


@dataclass(frozen=True)
class SeaEstimate:
    partitions: list[Partition]
    systems: list[int]  # per partition, the wave system it belongs to (see wave_systems)
    chi2_reduced: float
    n_residuals: int
    cost_hindcast: float  # ½Σr² of the hindcast sea itself (the prior means), for the residual check
    cost: float
    channel_ratio: dict = field(default_factory=dict)  # per channel: measured / model response variance


def partitions_hs(partitions) -> float:
    """Hs of partitions together, √Σ Hs² [m] (their variances add)."""
    return float(np.sqrt(sum(p.value["hs"] ** 2 for p in partitions)))


def signed_direction_deg(a, b=0.0):
    """a − b of directions in degrees, on the circle: −180 to 180."""
    return (np.asarray(a, dtype=float) - b + 180.0) % 360.0 - 180.0


def direction_difference_deg(a, b):
    """|a − b| of directions in degrees, on the circle: 0–180."""
    return np.abs(signed_direction_deg(a, b))


# ------------------------------------------------------------------------- measured cross-spectra


def cross_spectra(x: np.ndarray, fs: float, segment_s: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Welch cross-spectral matrix of the channels in x (nch, n): ω [rad/s], Φ̂ (nω, nch, nch) one-sided in
    rad/s (DESIGN §3), and its degrees of freedom ν (Welch 1967, Hann window with 50 % overlap).

    scipy.signal.csd's estimate (Hann, 50 % overlap, linear detrend per segment, density scaling, mean over
    segments), with each channel's segments transformed once instead of once per pair (nch² → nch FFTs)."""
    nper = int(min(round(segment_s * fs), x.shape[1]))
    step = nper - nper // 2
    segs = np.lib.stride_tricks.sliding_window_view(x, nper, axis=-1)[:, ::step]  # (nch, K, nper)
    window = signal.get_window("hann", nper)
    spec = np.fft.rfft(signal.detrend(segs, type="linear", axis=-1) * window, axis=-1)  # (nch, K, nf)
    # scipy's conj(X_i)X_j is H_i H̄_j S for x = Re{X e^{−iωt}}
    p = np.einsum("ikf,jkf->fij", spec.conj(), spec) / (segs.shape[1] * fs * float(window @ window))
    p[1 : (None if nper % 2 else -1)] *= 2.0  # one-sided: all but DC (and Nyquist, for an even segment)
    f = np.fft.rfftfreq(nper, 1.0 / fs)
    segments = segs.shape[1]
    nu = 2.0 * segments / (1.0 + 2.0 * 0.167**2 * (segments - 1) / segments)  # Hann 50 %: ρ = 0.167
    return TWO_PI * f, p / TWO_PI, float(nu)


# ------------------------------------------------------------------------- parametric sea


def partition_spectrum(omega: np.ndarray, dirs_from_deg: np.ndarray, x: np.ndarray) -> np.ndarray:
    """S(ω, D) [m²·s/rad²] of partitions x (P, 6) in fitted coordinates on ω × coming-from directions D ((P, 5):
    JONSWAP's n = 5).

    JONSWAP (σa 0.07, σb 0.09) with an ω⁻ⁿ tail (`_tail_shape`: n = 5 JONSWAP, γ = 1 Ochi–Hubble) normalised
    numerically to Hs²/16; cos-2s spreading with s = 2/σθ² − 1 (Kuik et al. 1988), normalised on the discrete
    direction grid."""
    s1, d = _partition_factors(omega, dirs_from_deg, x)
    return s1.T @ d


def _partition_factors(omega: np.ndarray, dirs_from_deg: np.ndarray, x: np.ndarray):
    """Each partition's frequency spectrum (P, nω) and normalised spreading (P, nD): S = Σ_p s1_p ⊗ d_p."""
    x = with_tail(x)
    hs, wp = np.exp(x[:, 0]), TWO_PI / np.exp(x[:, 1])
    spread, gamma, n = np.radians(np.exp(x[:, 3])), np.exp(x[:, 4]), np.exp(x[:, 5])
    u = np.maximum(omega, 1e-9)[None, :] / wp[:, None]
    norm = _shape_norm(x[:, 4], x[:, 5])
    s1 = (_tail_shape(u, n[:, None]) * gamma[:, None] ** _peak_exponent(u, 0.07, 0.09)
          * (hs**2 / (wp * norm))[:, None])  # (P, nω)
    s = np.maximum(2.0 / spread**2 - 1.0, 0.0)
    theta = np.radians(dirs_from_deg[None, :] - x[:, 2:3])
    d = np.abs(np.cos(0.5 * theta)) ** (2.0 * s[:, None])  # cos-2s, unnormalised; |·| makes it 2π-periodic
    d_dir = TWO_PI / dirs_from_deg.size
    d /= np.maximum(d.sum(axis=1, keepdims=True), 1e-300) * d_dir
    return s1, d


def with_tail(x: np.ndarray) -> np.ndarray:
    """Partitions x in the fitted coordinates with the tail's ln n: (P, 5) → JONSWAP's n = 5 appended."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    return x if x.shape[1] == N_COORD else np.column_stack([x, np.full(len(x), np.log(JONSWAP_TAIL))])


def _coordinate(values, field: str):
    """One field's values in the fitted coordinate: the direction as it is, every other field's logarithm."""
    return values[field] if field == "dir_from_deg" else np.log(values[field])


def table_coordinates(part) -> np.ndarray:
    """Partitions given by columns (sea_states.parquet's hs, tp, dir_from_deg, spread_deg, gamma, tail) in the fitted
    coordinates (P, N_COORD); without a tail column (a table written before n was fitted): JONSWAP's."""
    return with_tail(np.column_stack([_coordinate(part, f) for f in FIELDS if f in part]))


def outer_raos(h: np.ndarray) -> np.ndarray:
    """H Hᴴ per (ω, D) as its nch² real numbers (…, nω, nD, nch²) from h (…, nω, nD, nch): the diagonal |H_j|², then
    Re and Im of H_i H̄_j over the pairs i < j (np.triu_indices order). Φ is Hermitian, and as a real product its
    sum over directions costs a quarter of the complex one's flops."""
    nch = h.shape[-1]
    i, j = np.triu_indices(nch, 1)
    cross = h[..., i] * np.conj(h[..., j])
    return np.concatenate([h.real**2 + h.imag**2, cross.real, cross.imag], axis=-1)


def model_cross_spectra(g: np.ndarray, wave: np.ndarray) -> np.ndarray:
    """Φ(ω) = Σ_D H Hᴴ S ΔD, packed as outer_raos, from g = outer_raos(H) (nω, nD, nch²) and wave (nω, nD)."""
    return (wave[:, None, :] @ g)[:, 0, :] * (TWO_PI / g.shape[1])


# ------------------------------------------------------------------------- fit


@dataclass(frozen=True)
class WelchWindow:
    """Where the model is evaluated and how it reaches the Welch bins: the fine grid ω_m, the indices around each
    bin (nω, nt) and the Hann segment's |W(Δω)|² there (nt,), summing to 1 (diagnosis/model.py welch_grid)."""

    omega: np.ndarray
    index: np.ndarray
    kernel: np.ndarray

    def smooth(self, phi: np.ndarray) -> np.ndarray:
        """E[Φ̂] at the bins from Φ on the fine grid, packed (…, nω_m, nch²) → (…, nω, nch²)."""
        return np.moveaxis(phi[..., self.index, :], -2, -1) @ self.kernel


@dataclass
class _Problem:
    omega: np.ndarray  # the model's frequencies: the bins, or the Welch window's fine grid
    dirs: np.ndarray
    g: np.ndarray  # (nω_m, nD, nch²) H Hᴴ of the current loading on the model's frequencies (outer_raos)
    log_auto: np.ndarray  # (nω, nch) measured log(Φ̂_jj + floor)
    coh: np.ndarray  # (nω, npair) measured coherency
    floor: np.ndarray  # (nch,)
    auto_std: np.ndarray  # (nω, nch)
    coh_std: np.ndarray  # (nω, npair)
    pairs: tuple[np.ndarray, np.ndarray]
    welch: WelchWindow | None = None  # None: the model at the bins themselves

    def at_bins(self, phi: np.ndarray) -> np.ndarray:
        return phi if self.welch is None else self.welch.smooth(phi)

    def statistics(self, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Log autospectra and coherencies of Φ packed as outer_raos (…, nω, nch²)."""
        nch, i, j = self.floor.size, *self.pairs
        auto = np.maximum(phi[..., :nch], 0.0) + np.maximum(self.floor, 1e-300)
        cross = phi[..., nch : nch + i.size] + 1j * phi[..., nch + i.size :]
        return np.log(auto), cross / np.sqrt(auto[..., i] * auto[..., j])

    def residuals(self, x_flat: np.ndarray, priors: list[PartitionPrior | None]) -> np.ndarray:
        x = x_flat.reshape(-1, N_COORD)
        wave = partition_spectrum(self.omega, self.dirs, x)
        return np.concatenate([self.data_residuals(self.at_bins(model_cross_spectra(self.g, wave))),
                               prior_residuals(x, priors).ravel()])

    def data_residuals(self, phi: np.ndarray) -> np.ndarray:
        """The data's residuals under Φ at the bins (…, nω, nch²) packed as outer_raos: (…, n_data), the log
        autospectra, then the coherencies' real and imaginary parts, each in its standard deviations."""
        log_auto, coh = self.statistics(phi)
        lead = phi.shape[:-2]
        return np.concatenate([((self.log_auto - log_auto) / self.auto_std).reshape(*lead, -1),
                               ((self.coh.real - coh.real) / self.coh_std).reshape(*lead, -1),
                               ((self.coh.imag - coh.imag) / self.coh_std).reshape(*lead, -1)], axis=-1)

    def jacobian(self, x_flat: np.ndarray, priors: list[PartitionPrior | None], lower, upper) -> np.ndarray:
        """Forward differences of `residuals`, batched: Φ is linear in the spectrum S = Σ_p s1_p ⊗ d_p, and a step
        in a partition's Hs, Tp, γ or n changes its frequency spectrum s1_p only (ΔΦ = Δs1_p · d_p G), in its
        direction or spread its spreading d_p only (ΔΦ = s1_p · Δd_p G): 3 products per partition with the RAOs'
        G = H Hᴴ instead of a whole residual evaluation per column."""
        x = x_flat.reshape(-1, N_COORD)
        n_part = len(x)
        step = 1.49e-8 * np.maximum(1.0, np.abs(x_flat))  # √ε relative, as scipy's 2-point scheme
        step = np.where(x_flat + step > upper, -step, step)
        moved = np.repeat(x, N_COORD, axis=0)  # row q = N_COORD p + c: partition p with coordinate c moved
        moved[np.arange(x.size), np.tile(np.arange(N_COORD), n_part)] += step
        s1_0, d_0 = _partition_factors(self.omega, self.dirs, x)
        s1, d = _partition_factors(self.omega, self.dirs, moved)
        base = np.repeat(np.arange(n_part), N_COORD)
        in_freq = np.flatnonzero(np.tile([True, True, False, False, True, True], n_part))  # Hs, Tp, γ, n
        in_dir = np.flatnonzero(np.tile([False, False, True, True, False, False], n_part))  # direction, spread
        scale = TWO_PI / self.g.shape[1]
        q = d_0 @ self.g  # (nω, P, nch²): each partition's spreading through G
        phi0 = (s1_0.T[:, None, :] @ q)[:, 0, :] * scale
        d_phi = np.empty((self.omega.size, x.size, self.g.shape[2]))
        d_phi[:, in_freq] = (s1[in_freq] - s1_0[base[in_freq]]).T[:, :, None] * q[:, base[in_freq]]
        d_phi[:, in_dir] = s1_0[base[in_dir]].T[:, :, None] * ((d[in_dir] - d_0[base[in_dir]]) @ self.g)
        phi = phi0[None] + np.moveaxis(d_phi, 1, 0) * scale
        phi0, phi = self.at_bins(phi0), self.at_bins(phi)
        log0, coh0 = self.statistics(phi0)
        log_q, coh_q = self.statistics(phi)
        data = np.concatenate([(-(log_q - log0) / self.auto_std).reshape(len(phi), -1),
                               (-(coh_q.real - coh0.real) / self.coh_std).reshape(len(phi), -1),
                               (-(coh_q.imag - coh0.imag) / self.coh_std).reshape(len(phi), -1)], axis=1)
        jac = np.zeros((data.shape[1] + x.size, x.size))
        jac[: data.shape[1]] = (data / step[:, None]).T
        std = prior_std(priors).ravel()  # the prior terms' derivatives: 1/σ (0 where a term is absent)
        jac[data.shape[1] + np.arange(x.size), np.arange(x.size)] = np.where(np.isfinite(std), 1.0 / std, 0.0)
        return jac

    def costs_with_added(self, x: np.ndarray, priors: list[PartitionPrior | None], added: np.ndarray) -> np.ndarray:
        """½Σr² of the partitions x (P, N_COORD) with their priors and one free partition (no prior) more, for each
        row of `added` (n, N_COORD) in turn: (n,), as `residuals` of each stacked (x, added row). Φ is linear in the
        spectrum, so the added partitions' Φ come from one batched product on top of x's."""
        phi_x = model_cross_spectra(self.g, partition_spectrum(self.omega, self.dirs, x))
        s1, _ = _partition_factors(self.omega, self.dirs, added)
        _, first, which = np.unique(added[:, 2:4], axis=0, return_index=True, return_inverse=True)
        _, d = _partition_factors(self.omega, self.dirs, added[first])  # the spreading of each distinct one
        dg = np.moveaxis(d @ self.g, 1, 0) * (TWO_PI / self.g.shape[1])  # (n shapes, nω, nch²)
        data = self.data_residuals(self.at_bins(phi_x[None] + s1[:, :, None] * dg[which.ravel()]))
        fixed = np.sum(prior_residuals(x, priors) ** 2)  # x's prior terms, the same for every row
        free = prior_residuals(added, [None] * len(added))
        return 0.5 * (np.sum(data**2, axis=1) + fixed + np.sum(free**2, axis=1))

    @staticmethod
    def mask(anchor: np.ndarray, steady_pairs: np.ndarray) -> np.ndarray:
        """The data residuals (not the priors') of the autospectra marked in anchor (nω, nch) and of the
        coherencies marked in steady_pairs (nω, npair)."""
        return np.concatenate([anchor.ravel(), steady_pairs.ravel(), steady_pairs.ravel()])

    @property
    def n_data(self) -> int:
        return self.log_auto.size + 2 * self.coh.size


# a partition the hindcast lacks: weak priors (Hs ~ 0.5 m × e^±1.5, Tp ~ 12 s × e^±0.4), direction free
# Hs, Tp, direction, spread, γ of an added partition, and Tp and direction once more: they exist only under the
# alternative and are maximised over a grid, which inflates the null's likelihood ratio (Davies 1987). The tail's n
# is not counted: its prior holds it (as a hindcast partition's), and γ and n share the one peak width.
N_PARAMS_ADDED = 7
_FREE_MEAN = np.array([np.log(0.5), np.log(12.0), 0.0, np.log(20.0), np.log(3.3), np.log(JONSWAP_TAIL)])
_FREE_STD = np.array([1.5, 0.4, np.inf, 0.5, 0.5, 0.6])
# n ≥ 4: no sea's tail is fatter than the equilibrium range's ω⁻⁴ (Toba 1973). Allowed to 3, an added swell's tail
# took up a loading's RAO error (blind bank, barge_clean_003 with the YAML's LCG 1.4 m off: n 3.1–3.5, Hs +19…+35 %)
_LOWER = np.array([np.log(0.02), np.log(3.0), -np.inf, np.log(4.0), np.log(1.0), np.log(4.0)])
_UPPER = np.array([np.log(15.0), np.log(25.0), np.inf, np.log(80.0), np.log(7.0), np.log(30.0)])


def prior_std(priors: list[PartitionPrior | None]) -> np.ndarray:
    """Each partition's prior standard deviations (P, N_COORD); the weak free prior's for one absent from the
    hindcast."""
    return np.array([p.std() if p is not None else _FREE_STD for p in priors])


def prior_residuals(x: np.ndarray, priors: list[PartitionPrior | None]) -> np.ndarray:
    """Each partition's offset from its prior in the prior's standard deviations (P, N_COORD), the direction signed; a
    partition absent from the hindcast (None) against the weak free prior, without a direction term."""
    mean = np.array([p.mean() if p is not None else _FREE_MEAN for p in priors])
    std = prior_std(priors)
    d = x - mean
    d[:, 2] = signed_direction_deg(d[:, 2])
    return np.where(np.isfinite(std), d / std, 0.0)


def _fit(problem: _Problem, x0: np.ndarray, priors) -> optimize.OptimizeResult:
    lo, hi = np.tile(_LOWER, len(priors)), np.tile(_UPPER, len(priors))
    x0 = np.clip(x0.ravel(), lo + 1e-9, hi - 1e-9)
    return optimize.least_squares(problem.residuals, x0, jac=lambda x, p: problem.jacobian(x, p, lo, hi),
                                  args=(priors,), bounds=(lo, hi), x_scale="jac",
                                  method="trf", max_nfev=25 * x0.size, xtol=1e-5, ftol=1e-6)


def _search_added(problem: _Problem, x: np.ndarray, priors, min_hs: float, starts: int = 3) -> list[np.ndarray]:
    """Starting points of an added partition: the best cells of a (Tp, direction, Hs) grid with the others
    fixed, at least 90° apart in direction (the heave/pitch fore–aft mirror is a second minimum), and the splits
    of broad partitions (`_split_starts`)."""
    grid = np.array([[np.log(hs), np.log(tp), d, np.log(20.0), np.log(3.3), np.log(JONSWAP_TAIL)]
                     for tp in (5.0, 7.0, 9.5, 12.0, 15.0, 19.0) for d in np.arange(0.0, 360.0, 30.0)
                     for hs in (max(min_hs, 0.3), 1.0)])
    chosen = []
    for k in np.argsort(problem.costs_with_added(x, priors, grid), kind="stable"):
        d = float(grid[k, 2])
        if all(direction_difference_deg(d, e) >= 90.0 for e, _ in chosen):
            chosen.append((d, np.vstack([x, grid[k]])))
        if len(chosen) == starts:
            break
    return [c for _, c in chosen] + _split_starts(x)


SPLIT_SPREAD_DEG = 25.0  # a fitted partition this broad may be two systems of one period crossing


def _split_starts(x: np.ndarray) -> list[np.ndarray]:
    """Starts that split each broad partition into two narrow ones of its period, ± its spread either side, half
    its energy each: two swells of one period from directions 60–90° apart fit as one broad swell, and a grid
    start with that broad swell held fixed finds nothing to add. The half on either side keeps the old one's
    prior (the hindcast's system may be either)."""
    out = []
    for k, xp in enumerate(x):
        spread = float(np.exp(xp[3]))
        if spread < SPLIT_SPREAD_DEG:
            continue
        offset = min(spread, 60.0)
        for side in (-1.0, 1.0):
            cand = np.vstack([x, xp])
            cand[k, [0, 2, 3]] = xp[0] - 0.5 * np.log(2.0), xp[2] + side * offset, np.log(15.0)
            cand[-1, [0, 2, 3]] = xp[0] - 0.5 * np.log(2.0), xp[2] - side * offset, np.log(15.0)
            out.append(cand)
    return out


def estimate_sea(omega: np.ndarray, phi_measured: np.ndarray, nu: float, dirs_from_deg: np.ndarray,
                 g: np.ndarray, g_design: np.ndarray, priors: list[PartitionPrior], *, max_partitions: int = 4,
                 min_hs: float = 0.3, channel_names=(), welch: WelchWindow | None = None) -> SeaEstimate:
    """MAP directional sea of one window.

    omega : (nω,) the band to fit [rad/s]; phi_measured : (nω, nch, nch) Φ̂ on it; nu : its degrees of freedom
    dirs_from_deg : (nD,) equally spaced coming-from directions; g : (nω, nD, nch²) H Hᴴ of the current loading's
    RAOs there, packed as `outer_raos`; g_design : (L, nω, nD, nch²) those of the loading prior's design points (RAO
    uncertainty)
    priors : the hindcast's partitions (at least one)
    welch : the model compared as Welch's estimate sees it (g and g_design then on welch.omega): a roll resonance or
    a swell narrower than the bin spacing is smeared over its neighbours; None: the model at the bins
    """
    nch = phi_measured.shape[1]
    floor = 0.01 * np.real(np.einsum("wjj->wj", phi_measured)).max(axis=0)
    pairs = np.triu_indices(nch, 1)
    auto_m = np.real(np.einsum("wjj->wj", phi_measured)) + floor
    coh_m = phi_measured[:, pairs[0], pairs[1]] / np.sqrt(auto_m[:, pairs[0]] * auto_m[:, pairs[1]])
    # RAO uncertainty: spread over the design loadings of the modelled statistics in the hindcast's sea
    x_prior = np.array([p.mean() for p in priors])
    model_omega = omega if welch is None else welch.omega
    wave0 = partition_spectrum(model_omega, dirs_from_deg, x_prior)
    base = _Problem(model_omega, dirs_from_deg, g, np.log(auto_m), coh_m, floor, np.ones_like(auto_m),
                    np.ones(coh_m.shape), pairs, welch)
    stats = [base.statistics(base.at_bins(model_cross_spectra(gd, wave0))) for gd in g_design]
    la = np.array([s[0] for s in stats])
    ch = np.array([s[1] for s in stats])
    auto_std = np.sqrt(2.0 / nu + la.std(axis=0) ** 2 + 0.1**2)
    # a coherency component's sampling variance, approximated: (1 − |γ|²)²/ν (the scale of Bendat & Piersol's
    # coherence error, eq. 9.52) floored at 0.5/ν; plus the design spread and 0.05 of model error
    coh_std = np.sqrt((1.0 - np.abs(coh_m) ** 2) ** 2 / nu + 0.5 / nu + ch.real.std(axis=0) ** 2
                      + ch.imag.std(axis=0) ** 2 + 0.05**2)
    # E[ln Ŝ] = ln S + ψ(ν/2) − ln(ν/2) for a χ²_ν estimate (as diagnose's residuals): the measured log taken back
    # by it, in proportion to Ŝ's share of Ŝ + floor
    log_bias = float(special.digamma(nu / 2.0) - np.log(nu / 2.0))
    log_auto = np.log(auto_m) - log_bias * (auto_m - floor) / auto_m
    problem = _Problem(model_omega, dirs_from_deg, g, log_auto, coh_m, floor, auto_std, coh_std, pairs, welch)

    hindcast = [p for p in priors if p.in_hindcast]  # the others: the record's added systems (record_priors)
    x_hindcast = np.array([p.mean() for p in hindcast])
    cost_hindcast = 0.5 * float(np.sum(problem.residuals(x_hindcast.ravel(), hindcast) ** 2))
    fit = _fit(problem, x_prior, list(priors))
    x, used = fit.x.reshape(-1, N_COORD), list(priors)
    # a wave system must be seen where the loading hardly changes the response (design spread of the log
    # autospectrum < 0.15: heave and pitch, away from the roll resonance they share through coupling), not
    # only where an uncertain resonance could explain it
    anchor = la.std(axis=0) < 0.15  # (nω, nch)
    # a coherency is counted where the loading hardly moves it (design spread of |Δγ| < 0.1), whether or not its
    # channels' levels are: the phase between pitch and roll at a swell's period places the swell even where the
    # roll level is uncertain (both ends anchored, as before: missing swells found 50 → 54 of 76 on the bank)
    steady_pairs = np.hypot(ch.real.std(axis=0), ch.imag.std(axis=0)) < 0.1  # (nω, npair)
    mask = problem.mask(anchor, steady_pairs)
    n_eff = max(int(mask.sum()), 2) / 2.0  # adjacent Welch bins of a Hann window are correlated
    penalty = N_PARAMS_ADDED * np.log(n_eff)  # BIC

    def evidence(smaller, larger) -> float:
        # likelihood ratio with the residuals' scale profiled out (F-test analogue): n ln(RSS₀/RSS₁)
        rss0, rss1 = (float(np.sum(f.fun[: mask.size][mask] ** 2)) for f in (smaller, larger))
        return n_eff * np.log(max(rss0, 1e-300) / max(rss1, 1e-300))

    while len(used) < max_partitions and anchor.any():
        cand_priors = [*used, None]
        trial = min((_fit(problem, start, cand_priors) for start in _search_added(problem, x, used, min_hs)),
                    key=lambda f: f.cost)
        hs_new = float(np.exp(trial.x.reshape(-1, N_COORD)[-1, 0]))
        if evidence(fit, trial) <= penalty or hs_new < min_hs or _shape_correction(trial.x.reshape(-1, N_COORD)):
            break
        fit, x, used = trial, trial.x.reshape(-1, N_COORD), cand_priors
    n_given = len(priors)
    for k in reversed([i for i, p in enumerate(priors) if not p.in_hindcast]):  # a record's system: kept as if searched
        keep = [i for i in range(len(used)) if i != k]
        trial = _fit(problem, x[keep], [used[i] for i in keep])
        if evidence(trial, fit) <= penalty or np.exp(x[k, 0]) < min_hs:
            fit, x, used, n_given = trial, trial.x.reshape(-1, N_COORD), [used[i] for i in keep], n_given - 1
    for k in reversed(range(n_given, len(used))):  # prune: an added system a later one made redundant
        if len(used) <= n_given + 1:
            break
        keep = [i for i in range(len(used)) if i != k]
        trial = _fit(problem, x[keep], [used[i] for i in keep])
        if evidence(trial, fit) <= penalty:
            fit, x, used = trial, trial.x.reshape(-1, N_COORD), [used[i] for i in keep]
    dof = max(problem.n_data - x.size, 1)
    chi2 = 2.0 * fit.cost / dof
    try:
        cov = np.linalg.pinv(fit.jac.T @ fit.jac) * max(1.0, chi2)
    except np.linalg.LinAlgError:
        cov = np.full((x.size, x.size), np.nan)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None)).reshape(-1, N_COORD)
    parts = []
    for xp, sp in zip(x, sd, strict=True):
        value = {f: float(c % 360.0) if f == "dir_from_deg" else float(np.exp(c))
                 for f, c in zip(FIELDS, xp, strict=True)}
        std = {f: float(c) if f == "dir_from_deg" else value[f] * float(c) for f, c in zip(FIELDS, sp, strict=True)}
        parts.append(Partition(value, std, None))
    phi_fit = problem.at_bins(model_cross_spectra(g, partition_spectrum(model_omega, dirs_from_deg, x)))
    var_m = np.trapezoid(np.real(np.einsum("wjj->wj", phi_measured)), omega, axis=0)
    var_f = np.trapezoid(phi_fit[:, :nch], omega, axis=0)
    ratio = dict(zip(channel_names, (var_m / np.maximum(var_f, 1e-300)).tolist(), strict=False))
    systems = wave_systems(parts)
    parts = [Partition(p.value, p.std, m) for p, m in zip(parts, match_hindcast(parts, systems, hindcast),
                                                          strict=True)]
    return SeaEstimate(parts, systems, float(chi2), problem.n_data, cost_hindcast, float(fit.cost),
                       ratio)


POOL_MIN_WINDOWS = 3  # other windows with a matched partition needed to pool a hindcast partition's error
# the pooled prior's narrowest std per coordinate (log Hs, log Tp, direction [deg], log spread, log γ, log n): what
# the windows' shared error is known to at best, whatever their number
POOL_FLOOR = np.array([0.03, 0.02, 3.0, 0.1, 0.1, 0.1])


def _random_effects(d: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Random-effects weights 1/(v + τ²) of estimates d (n, k) with variances v (inf: no information; weight 0) and
    τ² (k,), the scatter beyond their own errors (DerSimonian & Laird 1986, eqs. 1–3)."""
    w = np.where(np.isfinite(v), 1.0 / v, 0.0)
    used = (w > 0).sum(axis=0)
    sw = w.sum(axis=0)
    mean = (w * d).sum(axis=0) / np.maximum(sw, 1e-300)
    q = (w * (d - mean) ** 2).sum(axis=0)
    tau2 = np.maximum(0.0, (q - (used - 1)) / np.maximum(sw - (w**2).sum(axis=0) / np.maximum(sw, 1e-300), 1e-300))
    return np.where(w > 0, 1.0 / (np.where(w > 0, v, 1.0) + tau2), 0.0), tau2


def _random_effects_mean(ws: np.ndarray, tau2: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, ...]:
    """The mean of d (n, k) with `_random_effects`' weights ws and τ², its std √(τ² + 1/Σw), and Σw (0: no data)."""
    s = ws.sum(axis=0)
    return (ws * d).sum(axis=0) / np.maximum(s, 1e-300), np.sqrt(tau2 + 1.0 / np.maximum(s, 1e-300)), s


def pooled_priors(priors: list[list[PartitionPrior]], estimates: list[SeaEstimate | None]
                  ) -> list[list[PartitionPrior]]:
    """Each window's hindcast priors moved by the error the record's other windows found in them (leave one out).

    A hindcast's error in a partition (Hs, Tp, direction; and the shape it assumes, spread and γ) persists over a
    record of hours, while one window's estimate of it is noisy. Per partition slot (the k-th of n priors) and
    coordinate, each window's estimate with the prior divided out (Gaussian: d/(1 − v/σ²), v/(1 − v/σ²) from the
    posterior's offset d and variance v) enters a random-effects mean (DerSimonian & Laird 1986, eqs. 1–3: the
    windows' scatter τ² beyond their own errors is estimated, so an error that drifts keeps the prior wide). Window w
    then gets the prior mean + b₋w with std √(τ² + se²(b₋w)), floored at POOL_FLOOR, never wider than before."""
    n_win = len(priors)
    offsets = {}  # (n priors, slot) → list of (window, d (N_COORD,), v (N_COORD,))
    for w, (pr, est) in enumerate(zip(priors, estimates, strict=True)):
        if est is None:
            continue
        for k, prior in enumerate(pr):
            members = [p for p in est.partitions if p.prior is prior]
            if not members:
                continue
            value, std = _coordinates(members)
            d = value - prior.mean()
            d[2] = signed_direction_deg(d[2])
            keep = 1.0 - std**2 / prior.std() ** 2  # the data's share of the posterior precision
            with np.errstate(divide="ignore", invalid="ignore"):
                ok = np.isfinite(std) & (std > 0) & (keep > 0.05)
                offsets.setdefault((len(pr), k), []).append(
                    (w, np.where(ok, d / keep, 0.0), np.where(ok, std**2 / keep, np.inf)))
    out = [list(pr) for pr in priors]
    for (n_pr, k), rows in offsets.items():
        wins = np.array([r[0] for r in rows])
        d, v = np.array([r[1] for r in rows]), np.array([r[2] for r in rows])  # (n, N_COORD)
        ws, tau2 = _random_effects(d, v)
        for w_idx in range(n_win):
            pr = priors[w_idx]
            if len(pr) != n_pr:
                continue
            others = wins != w_idx
            n_other = (ws[others] > 0).sum(axis=0)
            b, se, _ = _random_effects_mean(ws[others], tau2, d[others])
            std0 = pr[k].std()
            std = np.clip(se, POOL_FLOOR, std0)
            pooled = n_other >= POOL_MIN_WINDOWS
            if not pooled.any():
                continue
            out[w_idx][k] = pr[k].moved(pr[k].mean() + np.where(pooled, b, 0.0), np.where(pooled, std, std0))
    return out


def _coordinates(members: list[Partition]) -> tuple[np.ndarray, np.ndarray]:
    """Partitions of one sea in the fitted coordinates (log Hs of them together, and log Tp, direction, log spread,
    log γ, log n of the strongest) and their standard deviations."""
    top = max(members, key=lambda p: p.value["hs"])
    values = top.value | {"hs": partitions_hs(members)}
    std = [top.std[f] if f == "dir_from_deg" else top.std[f] / values[f] for f in FIELDS]  # of a log: relative
    return np.array([_coordinate(values, f) for f in FIELDS]), np.array(std)


def _systems(est: SeaEstimate) -> list[list[Partition]]:
    """The partitions of each wave system of an estimate."""
    return [[p for p, t in zip(est.partitions, est.systems, strict=True) if t == s] for s in dict.fromkeys(est.systems)]


RECORD_TP_REL, RECORD_DIR_DEG = 0.2, 30.0  # one swell in two windows of a record: Tp and direction this close


def record_priors(estimates: list[SeaEstimate | None]) -> list[list[PartitionPrior]]:
    """Per window, a prior for each wave system it found that the hindcast lacks, from the same system as the
    record's other windows found it (leave one out; in_hindcast False).

    A swell the hindcast missed persists over the record as its errors do (pooled_priors), and one window's Hs of
    it is as noisy: on the blind bank the added swells' Hs scattered 9.5 % (rms) about their record's median. Per
    window and added system, the nearest added system of each other window within RECORD_TP_REL in Tp and
    RECORD_DIR_DEG in direction enters the random-effects mean of pooled_priors (DerSimonian & Laird 1986,
    eqs. 1–3) when at least POOL_MIN_WINDOWS others have one; std √(τ² + se²), floored at POOL_FLOOR. The window's
    second fit starts from it and keeps it only by the test a searched system passes."""
    added = []  # per window: (value (n, N_COORD), variance (n, N_COORD)) of its systems absent from the hindcast
    for est in estimates:
        rows = [] if est is None else [
            _coordinates(members) for members in _systems(est) if all(p.prior is None for p in members)]
        added.append((np.array([r[0] for r in rows]).reshape(-1, N_COORD),
                      np.array([np.where(np.isfinite(r[1]) & (r[1] > 0), r[1] ** 2, np.inf) for r in rows]
                               ).reshape(-1, N_COORD)))
    out: list[list[PartitionPrior]] = [[] for _ in estimates]
    for w, (own, _) in enumerate(added):
        for a in own:
            d, v = [], []
            for u, (val, var) in enumerate(added):
                if u == w or not len(val):
                    continue
                dtp = np.abs(val[:, 1] - a[1])  # log Tp
                ddir = direction_difference_deg(val[:, 2], a[2])
                near = (dtp < np.log1p(RECORD_TP_REL)) & (ddir < RECORD_DIR_DEG)
                if near.any():
                    j = int(np.argmin(np.where(near, dtp / np.log1p(RECORD_TP_REL) + ddir / RECORD_DIR_DEG, np.inf)))
                    d.append(np.r_[val[j, :2], a[2] + signed_direction_deg(val[j, 2], a[2]), val[j, 3:]])
                    v.append(var[j])
            if len(d) < POOL_MIN_WINDOWS:
                continue
            d = np.array(d)
            b, se, s = _random_effects_mean(*_random_effects(d, np.array(v)), d)
            b = np.where(s > 0, b, a)
            std = np.where(s > 0, np.maximum(se, POOL_FLOOR), np.inf)
            out[w].append(PartitionPrior(hs=1.0, tp=10.0, dir_from_deg=0.0, in_hindcast=False).moved(b, std))
    return out


def profile_minimum(values: np.ndarray, costs: np.ndarray) -> tuple[float, float, float]:
    """(v̂, σ̂, ĉ) of a misfit profiled over one parameter, costs = −ln L + const at increasing values: the vertex of
    the parabola through the lowest cost and its two neighbours (the nearest three at an end of the grid), held within
    those three, σ̂ = 1/√curvature and ĉ the parabola there. Where the three are not convex: the lowest point, σ̂ inf."""
    k = int(np.clip(np.argmin(costs), 1, len(values) - 2))
    v, c = values[k - 1: k + 2], costs[k - 1: k + 2]
    a, b, c0 = np.polyfit(v, c, 2)
    if not a > 0:
        best = int(np.argmin(costs))
        return float(values[best]), float("inf"), float(costs[best])
    vertex = float(np.clip(-b / (2.0 * a), v[0], v[-1]))
    return vertex, float(1.0 / np.sqrt(2.0 * a)), float(min(np.polyval([a, b, c0], vertex), costs.min()))


def profile_spread(values: np.ndarray, per_window: np.ndarray, prior_std: float = np.inf) -> float:
    """σ̂ of one parameter read from windows' misfit profiles (per_window: costs (n values, n windows)), from each
    window's own minimum and σ_w (`profile_minimum`) and the scatter τ² between them beyond those (DerSimonian &
    Laird 1986, eqs. 1–3): 1/√(Σ 1/(σ_w² + τ²) + 1/σ_prior²). The summed profile's curvature takes every window as
    independent evidence of one value; where the windows disagree, that is what they say. 0 with fewer than two
    windows that have a minimum (no scatter to measure)."""
    own = np.array([profile_minimum(values, per_window[:, w])[:2] for w in range(per_window.shape[1])]).reshape(-1, 2)
    ok = np.isfinite(own[:, 1]) & (own[:, 1] > 0)
    if ok.sum() < 2:
        return 0.0
    weights, _ = _random_effects(own[ok, :1], own[ok, 1:] ** 2)
    return float(1.0 / np.sqrt(weights.sum() + 1.0 / prior_std**2))


def _shape_correction(x: np.ndarray, tp_rel: float = 0.25) -> bool:
    """An added partition (last row) at the period of another is a correction of that one's frequency or
    directional shape (an Ochi–Hubble or wrapped-normal sea fitted by JONSWAP × cos-2s), not a new system, when
    it lies within the two spreads (at least 60°) in direction. A weaker sea at the same period from farther
    away is a crossing swell: the cross-spectra's phases place it (its second directional moments differ from
    one broad peak's). Rejecting every weaker one, as before, lost the bank's missing swells that share the
    hindcast swell's period 70–110° away (found 45 → 58 %, false systems 0.11 → 0.14 per window)."""
    tp, spread = np.exp(x[:, 1]), np.exp(x[:, 3])
    near = np.abs(tp[:-1] - tp[-1]) / tp[:-1] < tp_rel
    ddir = direction_difference_deg(x[:-1, 2], x[-1, 2])
    close = ddir < np.maximum(60.0, spread[:-1] + spread[-1])
    return bool(np.any(near & close))


def match_hindcast(parts: list[Partition], systems: list[int], priors: list[PartitionPrior],
                   tp_rel: float = 0.3, dir_deg: float = 60.0) -> list[PartitionPrior | None]:
    """The hindcast partition each wave system corresponds to (nearest in Tp and direction within the limits,
    each prior used once), whatever slot of the fit it grew from: per partition, that prior or None."""
    energy: dict[int, list[float]] = {}
    for p, s in zip(parts, systems, strict=True):
        energy.setdefault(s, []).append(p.value["hs"])
    main = {s: max((p for p, t in zip(parts, systems, strict=True) if t == s), key=lambda p: p.value["hs"])
            for s in energy}
    pairs = []
    for s, p in main.items():
        for k, pr in enumerate(priors):
            dtp = abs(p.value["tp"] - pr.tp) / pr.tp
            ddir = direction_difference_deg(p.value["dir_from_deg"], pr.dir_from_deg)
            if dtp < tp_rel and ddir < dir_deg:
                pairs.append((dtp / tp_rel + ddir / dir_deg, s, k))
    taken_s, taken_k, match = set(), set(), {}
    for _, s, k in sorted(pairs):
        if s not in taken_s and k not in taken_k:
            match[s] = priors[k]
            taken_s.add(s)
            taken_k.add(k)
    return [match.get(s) for s in systems]


HP01_KAPPA = 1.0  # HP01 eq. 9's spread factor, Hasselmann et al. (1996)'s value (HP01 table 1: 0.4–1)


def _peak_and_spread(value: dict) -> tuple[np.ndarray, float]:
    """A partition's peak in the (f cos θ, f sin θ) plane [Hz] and its spread there, the variance E|f|² − |E f|²
    [Hz²] of its spectrum × cos-2s (cos-2s's first circular moment s/(s + 1))."""
    u = np.geomspace(0.2, 30.0, 3000)
    w = _tail_shape(u, value.get("tail", JONSWAP_TAIL)) * value["gamma"] ** _peak_exponent(u, 0.07, 0.09)
    m1, m2 = np.trapezoid(w * u, u) / np.trapezoid(w, u), np.trapezoid(w * u**2, u) / np.trapezoid(w, u)
    s = max(2.0 / np.radians(value["spread_deg"]) ** 2 - 1.0, 0.0)
    fp, theta = 1.0 / value["tp"], np.radians(value["dir_from_deg"])
    return fp * np.array([np.cos(theta), np.sin(theta)]), fp**2 * (m2 - (m1 * s / (s + 1.0)) ** 2)


def wave_systems(parts: list[Partition], tp_rel: float = 0.3, dir_deg: float = 30.0) -> list[int]:
    """Partitions closer than `tp_rel` in Tp and `dir_deg` (or their two spreads) in direction whose peaks are also
    within HP01's separation (Hanson & Phillips 2001 eq. 9: |Δf|² ≤ κ max(spread) in the (f cos θ, f sin θ)
    plane) are one wave system: one peak fitted by two shapes, e.g. a broad swell by two JONSWAPs. Returns a
    system index per partition. On the blind bank the Tp/direction limits alone joined 15 pairs, 9 of them two true
    systems (a wind sea and a swell 56° and 30 % in Tp apart, scored as one 24 % too high); with eq. 9, 8 of
    those 9 stand apart and the 6 one-peak pairs stay joined. `dir_deg` is wavespectra's angle_max
    (combine_partitions_hp01): at 60° a broad wind sea still took a swell 42–44° away (4 bank windows: the swell
    lost, the wind sea's Hs 5–26 % high), where wavespectra's HP01 finds two systems in the pair's 2-D spectrum."""
    system = list(range(len(parts)))
    shape = [_peak_and_spread(p.value) for p in parts]
    for a in range(len(parts)):
        for b in range(a + 1, len(parts)):
            va, vb = parts[a].value, parts[b].value
            dtp = abs(va["tp"] - vb["tp"]) / (0.5 * (va["tp"] + vb["tp"]))
            ddir = direction_difference_deg(va["dir_from_deg"], vb["dir_from_deg"])
            apart = float(np.sum((shape[a][0] - shape[b][0]) ** 2)) > HP01_KAPPA * max(shape[a][1], shape[b][1])
            if dtp < tp_rel and ddir < max(dir_deg, va["spread_deg"] + vb["spread_deg"]) and not apart:
                old, new = system[b], system[a]
                system = [new if s == old else s for s in system]
    order = {s: k for k, s in enumerate(dict.fromkeys(system))}
    return [order[s] for s in system]

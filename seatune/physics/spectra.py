"""Wave spectra and directional spreading, in the model convention of DESIGN §3.

Spectra are one-sided and in rad/s: S(ω) [m²·s/rad], S(ω, β) [m²·s/rad²]; Hs = 4√m0. β is the
direction the waves travel *towards*, counter-clockwise from body +x (β = π head seas, 0 following,
π/2 waves from starboard). Hindcast directions (nautical, coming-from, degrees clockwise from North)
are converted once with :func:`wave_direction_from_nautical`.

Shapes: the 1-D spectra broadcast their parameters against each other and put the frequency axis
last, ``out.shape == np.broadcast(*params).shape + omega.shape``. :func:`directional_spectrum`
returns ``(n_omega, n_beta)``, the order of the hydro database (``omega``, ``wave_direction``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike
from scipy import integrate, special

__all__ = [
    "SPREADING_KINDS",
    "DEFAULT_SPREADING_PARAM",
    "SpectrumPartition",
    "wave_direction_from_nautical",
    "wrap_angle",
    "pierson_moskowitz",
    "jonswap",
    "jonswap_gamma_dnv",
    "two_peak",
    "spreading_cos2s",
    "spreading_cosn",
    "cos2s_s_from_spread",
    "discrete_spreading",
    "directional_spectrum",
    "spectral_moments",
    "hs_tz_from_spectrum",
]

TWO_PI = 2.0 * np.pi
SPREADING_KINDS = ("cos2s", "cosn", "long_crested")
# Defaults when no spreading parameter is given. DNV-RP-C205 §3.5.8 and Han (paper A5, Eq. 17) use
# cosⁿ with n = 2–4 for wind sea (> 7 for swell); n = 2 is the classic cos² sea. cos-2s with s = 2n has the
# same curvature at the peak (2s·ln cos(θ/2) ≈ −sθ²/4 vs n·ln cos θ ≈ −nθ²/2), hence s = 4.
DEFAULT_SPREADING_PARAM: dict[str, float | None] = {"cos2s": 4.0, "cosn": 2.0, "long_crested": None}


# --------------------------------------------------------------------------------------------------
# Directions
# --------------------------------------------------------------------------------------------------


def wave_direction_from_nautical(dir_from_deg: ArrayLike, heading_deg: ArrayLike) -> np.ndarray:
    """Model wave direction β from a nautical coming-from direction and the vessel heading.

    β = ψ − D − 180° (mod 360°) (DESIGN §3). Check: heading North, waves from North → β = π (head
    seas); heading East, waves from North → β = 3π/2 (waves from port, travelling to −y).

    Parameters
    ----------
    dir_from_deg : array_like
        Direction the waves come *from*, D [deg], clockwise from true North (ERA5, wavespectra).
    heading_deg : array_like
        Vessel heading ψ [deg], clockwise from true North. Broadcasts against `dir_from_deg`.

    Returns
    -------
    ndarray
        β [rad] in [0, 2π), direction the waves travel towards, counter-clockwise from body +x;
        shape ``np.broadcast(dir_from_deg, heading_deg).shape``.
    """
    deg = np.asarray(heading_deg, dtype=float) - np.asarray(dir_from_deg, dtype=float) - 180.0
    beta = np.mod(np.deg2rad(np.mod(deg, 360.0)), TWO_PI)
    # mod() of a tiny negative number can round to exactly 2π; fold it onto 0 so the range is [0, 2π).
    return np.where(beta >= TWO_PI, 0.0, beta)


def direction_step(dirs_deg: ArrayLike) -> float:
    """ΔD [rad] of a uniform grid of directions in degrees covering the circle."""
    dirs_deg = np.asarray(dirs_deg, dtype=float)
    return float(np.radians(np.diff(np.r_[dirs_deg, dirs_deg[0] + 360.0]).mean()))


def omnidirectional(wave: np.ndarray, dirs_deg: ArrayLike) -> np.ndarray:
    """S(ω) = Σ_D S(ω, D) ΔD of a directional spectrum (n_ω, n_D) on a uniform direction grid."""
    return np.asarray(wave).sum(axis=1) * direction_step(dirs_deg)


def wrap_angle(theta: ArrayLike) -> np.ndarray:
    """Wrap angles [rad] to (−π, π] (elementwise, same shape)."""
    return np.pi - np.mod(np.pi - np.asarray(theta, dtype=float), TWO_PI)


# --------------------------------------------------------------------------------------------------
# Frequency spectra
# --------------------------------------------------------------------------------------------------


def _check_positive(name: str, value: np.ndarray, allow_zero: bool = False) -> None:
    bad = value < 0 if allow_zero else value <= 0
    if np.any(bad) or np.any(np.isinf(value)):
        limit = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be finite and {limit}, got {value[bad | np.isinf(value)].ravel()[:3]}")


def _params_against_omega(omega: ArrayLike, *params: ArrayLike) -> tuple[np.ndarray, ...]:
    """Broadcast parameters against each other and append len(omega.shape) unit axes; return omega too."""
    om = np.asarray(omega, dtype=float)
    arrays = np.broadcast_arrays(*(np.asarray(p, dtype=float) for p in params))
    tail = (Ellipsis,) + (None,) * om.ndim
    return (om,) + tuple(a[tail] for a in arrays)


def _pm_shape(x: np.ndarray) -> np.ndarray:
    """Dimensionless PM shape g(x) = 5/16 x⁻⁵ exp(−5/4 x⁻⁴), x = ω/ωp; ∫₀^∞ g dx = 1/16; 0 for x ≤ 0."""
    pos = x > 0
    xs = np.where(pos, x, 1.0)
    with np.errstate(over="ignore", divide="ignore"):
        # log form: x⁻⁵ alone overflows for tiny x while the exponential has long underflowed to 0.
        g = 5.0 / 16.0 * np.exp(-1.25 * xs**-4.0 - 5.0 * np.log(xs))
    return np.where(pos, g, 0.0)


def _peak_exponent(x: np.ndarray, sigma_a: np.ndarray, sigma_b: np.ndarray) -> np.ndarray:
    """JONSWAP exponent r = exp(−(ω−ωp)²/(2σ²ωp²)) with x = ω/ωp; σ = σa for ω ≤ ωp else σb."""
    sigma = np.where(x <= 1.0, sigma_a, sigma_b)
    return np.exp(-((x - 1.0) ** 2) / (2.0 * sigma**2))


@lru_cache(maxsize=512)
def _jonswap_norm_scalar(gamma: float, sigma_a: float, sigma_b: float) -> float:
    """16 ∫₀^∞ g(x) γ^r(x) dx, so that JONSWAP = Hs²/ωp · g γ^r / norm has m0 = Hs²/16 exactly.

    Written as 1 + 16 ∫ g (γ^r − 1) dx: the correction is confined to the peak (well resolved by quad)
    and is exactly 0 for γ = 1, so γ = 1 reproduces PM bit for bit. It depends on (γ, σa, σb) only,
    never on the evaluation grid, because the shape scales with ωp.
    """
    if not (np.isfinite(gamma) and np.isfinite(sigma_a) and np.isfinite(sigma_b)):
        return float("nan")
    if gamma == 1.0:
        return 1.0
    lng = np.log(gamma)

    def integrand(x: float) -> float:
        r = _peak_exponent(np.asarray(x), np.asarray(sigma_a), np.asarray(sigma_b))
        return float(16.0 * _pm_shape(np.asarray(x)) * np.expm1(r * lng))

    # g(x) < 1e-300 for x < 0.07: the lower limit 0.05 loses nothing; split at the peak where σ jumps.
    lo, _ = integrate.quad(integrand, 0.05, 1.0, epsabs=1e-14, epsrel=1e-12, limit=200)
    hi, _ = integrate.quad(integrand, 1.0, np.inf, epsabs=1e-14, epsrel=1e-12, limit=200)
    return 1.0 + lo + hi


def _jonswap_norm(gamma: np.ndarray, sigma_a: np.ndarray, sigma_b: np.ndarray) -> np.ndarray:
    """Vectorised :func:`_jonswap_norm_scalar` (one quadrature per distinct (γ, σa, σb))."""
    g, a, b = np.broadcast_arrays(gamma, sigma_a, sigma_b)
    table = np.stack([g.ravel(), a.ravel(), b.ravel()], axis=-1)
    uniq, inverse = np.unique(table, axis=0, return_inverse=True)
    norms = np.array([_jonswap_norm_scalar(float(u[0]), float(u[1]), float(u[2])) for u in uniq])
    return norms[inverse.ravel()].reshape(g.shape)


def pierson_moskowitz(omega: ArrayLike, hs: ArrayLike, tp: ArrayLike) -> np.ndarray:
    """Pierson–Moskowitz spectrum S(ω) [m²·s/rad].

    S(ω) = 5/16 Hs² ωp⁴ ω⁻⁵ exp(−5/4 (ω/ωp)⁻⁴), ωp = 2π/Tp, whose m0 over (0, ∞) is exactly Hs²/16.

    Parameters
    ----------
    omega : array_like
        Wave frequencies ω [rad/s], any shape; ω ≤ 0 gives 0.
    hs : array_like
        Significant wave height Hs [m], ≥ 0.
    tp : array_like
        Peak period Tp [s], > 0. Broadcasts against `hs`.

    Returns
    -------
    ndarray
        S [m²·s/rad], shape ``np.broadcast(hs, tp).shape + omega.shape``.
    """
    om, hs_, tp_ = _params_against_omega(omega, hs, tp)
    _check_positive("hs", hs_, allow_zero=True)
    _check_positive("tp", tp_)
    wp = TWO_PI / tp_
    # Han paper A2 Eq. (15) with ωp⁴ (as printed in A3), DNV-RP-C205 Eq. (3.5.5.1)
    return hs_**2 / wp * _pm_shape(om / wp)


def jonswap(
    omega: ArrayLike,
    hs: ArrayLike,
    tp: ArrayLike,
    gamma: ArrayLike = 3.3,
    sigma_a: ArrayLike = 0.07,
    sigma_b: ArrayLike = 0.09,
) -> np.ndarray:
    """JONSWAP spectrum S(ω) [m²·s/rad], normalised so that m0 over (0, ∞) is exactly Hs²/16.

    S(ω) = S_PM(ω) · γ^exp(−(ω−ωp)²/(2σ²ωp²)) / N(γ, σa, σb), σ = σa for ω ≤ ωp, σb above.
    N is computed once per (γ, σa, σb) by adaptive quadrature in ω/ωp (it does not depend on Hs, Tp or
    the evaluation grid) instead of DNV's approximation A_γ = 1 − 0.287 ln γ, which is only ~1 %
    accurate. γ = 1 returns :func:`pierson_moskowitz` exactly.

    Parameters
    ----------
    omega : array_like
        Wave frequencies ω [rad/s], any shape; ω ≤ 0 gives 0.
    hs : array_like
        Significant wave height Hs [m], ≥ 0.
    tp : array_like
        Peak period Tp [s], > 0.
    gamma : array_like, default 3.3
        Peak enhancement factor γ [-], > 0 (see :func:`jonswap_gamma_dnv`).
    sigma_a, sigma_b : array_like, default 0.07, 0.09
        Peak widths [-] below and above ωp, > 0.
        All parameters broadcast against each other.

    Returns
    -------
    ndarray
        S [m²·s/rad], shape ``np.broadcast(hs, tp, gamma, sigma_a, sigma_b).shape + omega.shape``.
    """
    _, gamma_, sa_, sb_ = np.broadcast_arrays(*(np.asarray(p, dtype=float) for p in (hs, gamma, sigma_a, sigma_b)))
    for name, value in (("gamma", gamma_), ("sigma_a", sa_), ("sigma_b", sb_)):
        _check_positive(name, value)
    norm = _jonswap_norm(gamma_, sa_, sb_)
    om, tp_, g_, a_, b_, n_ = _params_against_omega(omega, tp, gamma_, sa_, sb_, norm)
    x = om * tp_ / TWO_PI
    # DNV-RP-C205 Eq. (3.5.5.3): S_J = A_γ S_PM γ^exp(−0.5((ω−ωp)/(σωp))²), A_γ replaced by the exact 1/N
    enhancement = np.exp(_peak_exponent(x, a_, b_) * np.log(g_))
    return pierson_moskowitz(omega, hs, tp) * enhancement / n_


def jonswap_gamma_dnv(hs: ArrayLike, tp: ArrayLike) -> np.ndarray:
    """DNV-RP-C205 recommended JONSWAP peak enhancement γ from Tp/√Hs.

    γ = 5 for Tp/√Hs ≤ 3.6; γ = exp(5.75 − 1.15 Tp/√Hs) for 3.6 < Tp/√Hs < 5; γ = 1 for Tp/√Hs ≥ 5
    (Tp in s, Hs in m). Hs = 0 gives γ = 1.

    Parameters
    ----------
    hs : array_like
        Significant wave height Hs [m], ≥ 0.
    tp : array_like
        Peak period Tp [s], > 0. Broadcasts against `hs`.

    Returns
    -------
    ndarray
        γ [-], shape ``np.broadcast(hs, tp).shape``.
    """
    hs_, tp_ = np.broadcast_arrays(np.asarray(hs, dtype=float), np.asarray(tp, dtype=float))
    _check_positive("hs", hs_, allow_zero=True)
    _check_positive("tp", tp_)
    with np.errstate(divide="ignore"):
        phi = tp_ / np.sqrt(hs_)
    # DNV-RP-C205 §3.5.5.5
    return np.where(phi <= 3.6, 5.0, np.where(phi >= 5.0, 1.0, np.exp(5.75 - 1.15 * np.minimum(phi, 5.0))))


def two_peak(
    omega: ArrayLike,
    wind_hs: ArrayLike,
    wind_tp: ArrayLike,
    swell_hs: ArrayLike,
    swell_tp: ArrayLike,
    wind_gamma: ArrayLike = 3.3,
    swell_gamma: ArrayLike = 5.0,
) -> np.ndarray:
    """Two-peak spectrum: wind-sea JONSWAP + swell JONSWAP partitions, S(ω) [m²·s/rad].

    Total m0 = (wind_hs² + swell_hs²)/16, i.e. Hs = √(wind_hs² + swell_hs²).

    Parameters
    ----------
    omega : array_like
        Wave frequencies ω [rad/s].
    wind_hs, wind_tp : array_like
        Wind-sea Hs [m] and Tp [s].
    swell_hs, swell_tp : array_like
        Swell Hs [m] and Tp [s].
    wind_gamma, swell_gamma : array_like, default 3.3, 5.0
        Peak enhancement factors [-] of the two partitions. All parameters broadcast together.

    Returns
    -------
    ndarray
        S [m²·s/rad], shape ``np.broadcast(all parameters).shape + omega.shape``.
    """
    return jonswap(omega, wind_hs, wind_tp, wind_gamma) + jonswap(omega, swell_hs, swell_tp, swell_gamma)


# --------------------------------------------------------------------------------------------------
# Directional spreading
# --------------------------------------------------------------------------------------------------


def spreading_cos2s(theta: ArrayLike, s: ArrayLike) -> np.ndarray:
    """Continuous cos-2s spreading D(θ) [1/rad] (Longuet-Higgins et al. 1963).

    D(θ) = Γ(s+1)/(2√π Γ(s+½)) cos^{2s}(θ/2) on θ ∈ (−π, π], so ∫ D dθ = 1.

    Parameters
    ----------
    theta : array_like
        Angle from the mean direction [rad]; wrapped to (−π, π].
    s : array_like
        Spreading exponent s [-], ≥ 0 (s = 0: uniform). Broadcasts against `theta`.

    Returns
    -------
    ndarray
        D [1/rad], shape ``np.broadcast(theta, s).shape``.
    """
    s_ = np.asarray(s, dtype=float)
    _check_positive("s", s_, allow_zero=True)
    th = wrap_angle(theta)
    log_c = special.gammaln(s_ + 1.0) - special.gammaln(s_ + 0.5) - np.log(2.0 * np.sqrt(np.pi))
    # DNV-RP-C205 Eq. (3.5.8.7) with the exact normalisation; cos(θ/2) ≥ 0 on (−π, π]
    return np.exp(log_c) * np.power(np.clip(np.cos(0.5 * th), 0.0, None), 2.0 * s_)


def spreading_cosn(theta: ArrayLike, n: ArrayLike) -> np.ndarray:
    """Continuous cosⁿ spreading D(θ) [1/rad], zero beyond ±π/2.

    D(θ) = Γ(1+n/2)/(√π Γ(½+n/2)) cosⁿ θ for |θ| ≤ π/2, else 0, so ∫ D dθ = 1.

    Parameters
    ----------
    theta : array_like
        Angle from the mean direction [rad]; wrapped to (−π, π].
    n : array_like
        Spreading exponent n [-], ≥ 0 (Han: 2–4 wind sea, > 7 swell). Broadcasts against `theta`.

    Returns
    -------
    ndarray
        D [1/rad], shape ``np.broadcast(theta, n).shape``.
    """
    n_ = np.asarray(n, dtype=float)
    _check_positive("n", n_, allow_zero=True)
    th = wrap_angle(theta)
    log_c = special.gammaln(1.0 + 0.5 * n_) - special.gammaln(0.5 + 0.5 * n_) - 0.5 * np.log(np.pi)
    # Han paper A5 Eq. (3b) / A6 Eq. (17); DNV-RP-C205 Eq. (3.5.8.4)
    d = np.exp(log_c) * np.power(np.clip(np.cos(th), 0.0, None), n_)
    return np.where(np.abs(th) <= 0.5 * np.pi, d, 0.0)


def cos2s_s_from_spread(spread_rad: ArrayLike) -> np.ndarray:
    """cos-2s exponent s from the circular directional spread σθ [rad] (as hindcasts report it).

    σθ² = 2(1 − m1) with m1 = ∫cos θ D dθ = s/(s+1) for cos-2s, hence s = 2/σθ² − 1 (Kuik et al. 1988;
    the relation wavespectra's Cartwright spreading uses). Spreads above √2 rad (81°) give s = 0.

    Parameters
    ----------
    spread_rad : array_like
        Directional spread σθ [rad], > 0.

    Returns
    -------
    ndarray
        s [-], same shape.
    """
    sp = np.asarray(spread_rad, dtype=float)
    _check_positive("spread_rad", sp)
    return np.maximum(2.0 / sp**2 - 1.0, 0.0)


def _direction_grid(beta_grid: ArrayLike) -> tuple[np.ndarray, np.ndarray, float]:
    """Validate an equally spaced circular grid; return (grid, sort order of grid mod 2π, Δβ = 2π/n)."""
    grid = np.asarray(beta_grid, dtype=float)
    if grid.ndim != 1 or grid.size == 0:
        raise ValueError(f"beta_grid must be a non-empty 1-D array, got shape {grid.shape}")
    n = grid.size
    dbeta = TWO_PI / n
    folded = np.mod(grid, TWO_PI)
    order = np.argsort(folded, kind="stable")
    ring = np.diff(np.append(folded[order], folded[order[0]] + TWO_PI))
    if not np.allclose(ring, dbeta, rtol=0.0, atol=1e-8):
        raise ValueError(
            f"beta_grid must be {n} equally spaced directions covering [0, 2π) (spacing {np.rad2deg(dbeta):g}°), "
            f"got spacings between {np.rad2deg(ring.min()):g}° and {np.rad2deg(ring.max()):g}°"
        )
    return grid, order, dbeta


def _long_crested_weights(
    grid: np.ndarray, order: np.ndarray, dbeta: float, beta_mean: np.ndarray, interpolate: bool
) -> np.ndarray:
    """D on the grid with all energy on the nearest direction (or split linearly between two)."""
    n = grid.size
    flat = beta_mean.ravel()
    start = np.mod(grid[order[0]], TWO_PI)
    pos = np.mod(flat - start, TWO_PI) / dbeta  # fractional index into the sorted grid, in [0, n]
    out = np.zeros((flat.size, n))
    rows = np.arange(flat.size)
    if interpolate:
        k = np.floor(pos).astype(int)
        frac = pos - k
        np.add.at(out, (rows, order[k % n]), (1.0 - frac) / dbeta)
        np.add.at(out, (rows, order[(k + 1) % n]), frac / dbeta)
    else:
        k = np.floor(pos + 0.5).astype(int)  # nearest; a tie goes to the direction counter-clockwise
        out[rows, order[k % n]] = 1.0 / dbeta
    return out.reshape(beta_mean.shape + (n,))


def _resolve_param(kind: str, param: float | ArrayLike | None) -> np.ndarray | None:
    if kind not in SPREADING_KINDS:
        raise ValueError(f"spreading kind must be one of {SPREADING_KINDS}, got {kind!r}")
    if kind == "long_crested":
        if param is not None:
            raise ValueError(f"long_crested spreading takes no parameter, got {param!r}")
        return None
    value = np.asarray(DEFAULT_SPREADING_PARAM[kind] if param is None else param, dtype=float)
    _check_positive("s" if kind == "cos2s" else "n", value, allow_zero=True)
    return value


def discrete_spreading(
    beta_grid: ArrayLike,
    beta_mean: ArrayLike,
    kind: str = "cos2s",
    param: ArrayLike | None = None,
    *,
    interpolate: bool = False,
) -> np.ndarray:
    """Spreading weights D(β) [1/rad] on an equally spaced direction grid, normalised on that grid.

    The weights are normalised so that Σ_β D(β) Δβ = 1 exactly on the grid (Δβ = 2π/n_beta), not
    ∫ D dθ = 1: a directional spectrum S(ω) D(β) then holds exactly the variance of S(ω) whatever the
    grid resolution and mean direction, so Hs is preserved (DESIGN §4, S_FF = Σ_β F Fᴴ S Δβ).

    Parameters
    ----------
    beta_grid : array_like, shape (n_beta,)
        Directions [rad] equally spaced around the circle, any order and offset (e.g. 24 × 15°).
    beta_mean : array_like
        Mean wave direction(s) [rad], model convention (travelling towards, CCW from +x).
    kind : {"cos2s", "cosn", "long_crested"}
        Spreading shape: :func:`spreading_cos2s`, :func:`spreading_cosn`, or all energy in one direction.
    param : array_like, optional
        s for "cos2s", n for "cosn" (defaults in ``DEFAULT_SPREADING_PARAM``); must be None for
        "long_crested". Broadcasts against `beta_mean`.
    interpolate : bool, default False
        "long_crested" only: split the energy linearly between the two grid directions around
        `beta_mean` (D = (1−f)/Δβ and f/Δβ) instead of putting D = 1/Δβ on the nearest one.

    Returns
    -------
    ndarray
        D [1/rad], shape ``np.broadcast(beta_mean, param).shape + (n_beta,)``, direction axis last,
        in the order of `beta_grid`.
    """
    grid, order, dbeta = _direction_grid(beta_grid)
    p = _resolve_param(kind, param)
    mean = np.asarray(beta_mean, dtype=float)
    if p is not None:
        mean, p = np.broadcast_arrays(mean, p)
    if kind == "long_crested":
        return _long_crested_weights(grid, order, dbeta, mean, interpolate)
    theta = wrap_angle(grid - mean[..., None])
    p = p[..., None]
    # Log weights, shifted by their row maximum before exp, so narrow spreading (large s, n) degrades to
    # long-crested instead of underflowing to 0/0. The continuous constants cancel in the normalisation.
    with np.errstate(divide="ignore"):
        if kind == "cos2s":
            logw = special.xlogy(2.0 * p, np.clip(np.cos(0.5 * theta), 0.0, None))
        else:
            logw = special.xlogy(p, np.clip(np.cos(theta), 0.0, None))
            logw = np.where(np.abs(theta) <= 0.5 * np.pi, logw, -np.inf)
    top = logw.max(axis=-1, keepdims=True)
    empty = ~np.isfinite(top[..., 0])  # cosⁿ with no grid direction within ±90° (n_beta ≤ 2)
    w = np.exp(logw - np.where(np.isfinite(top), top, 0.0))
    out = w / (w.sum(axis=-1, keepdims=True) * dbeta)
    if np.any(empty):
        out[empty] = _long_crested_weights(grid, order, dbeta, mean[empty], interpolate=False)
    return out


# --------------------------------------------------------------------------------------------------
# Directional spectrum from partitions
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SpectrumPartition:
    """One wave system (wind sea or swell) of a hindcast sea state.

    Attributes
    ----------
    hs : float
        Significant wave height [m], ≥ 0.
    tp : float
        Peak period [s], > 0.
    dir_from_deg : float
        Mean direction the waves come *from* [deg], clockwise from true North.
    gamma : float, default 3.3
        JONSWAP peak enhancement [-]; 1 gives Pierson–Moskowitz.
    spreading : {"cos2s", "cosn", "long_crested"}, default "cos2s"
    spreading_param : float, optional
        s (cos2s) or n (cosn); None takes ``DEFAULT_SPREADING_PARAM[spreading]``.
    sigma_a, sigma_b : float, default 0.07, 0.09
        JONSWAP peak widths below / above ωp.
    """

    hs: float
    tp: float
    dir_from_deg: float
    gamma: float = 3.3
    spreading: str = "cos2s"
    spreading_param: float | None = None
    sigma_a: float = 0.07
    sigma_b: float = 0.09

    def __post_init__(self) -> None:
        for name in ("hs", "tp", "dir_from_deg", "gamma", "sigma_a", "sigma_b"):
            if np.ndim(getattr(self, name)) != 0 or not np.isfinite(getattr(self, name)):
                raise ValueError(f"SpectrumPartition.{name} must be a finite scalar, got {getattr(self, name)!r}")
        if self.hs < 0:
            raise ValueError(f"SpectrumPartition.hs must be >= 0, got {self.hs!r}")
        for name in ("tp", "gamma", "sigma_a", "sigma_b"):
            if getattr(self, name) <= 0:
                raise ValueError(f"SpectrumPartition.{name} must be > 0, got {getattr(self, name)!r}")
        _resolve_param(self.spreading, self.spreading_param)

    def spectrum(self, omega: ArrayLike) -> np.ndarray:
        """1-D spectrum S(ω) [m²·s/rad] of this partition, shape ``omega.shape``."""
        return jonswap(omega, self.hs, self.tp, self.gamma, self.sigma_a, self.sigma_b)


def directional_spectrum(
    omega: ArrayLike,
    beta_grid: ArrayLike,
    partitions: SpectrumPartition | Sequence[SpectrumPartition],
    heading_deg: float,
    *,
    interpolate: bool = False,
) -> np.ndarray:
    """Directional spectrum S(ω, β) [m²·s/rad²] in the model convention, summed over partitions.

    S(ω, β) = Σ_p S_p(ω) D_p(β − β_p), β_p = ψ − D_p − 180° (DESIGN §3), with the discrete spreading of
    :func:`discrete_spreading`, so Σ_β S(ω, β) Δβ = Σ_p S_p(ω) exactly.

    Parameters
    ----------
    omega : array_like, shape (n_omega,)
        Wave frequencies [rad/s].
    beta_grid : array_like, shape (n_beta,)
        Model wave directions [rad], equally spaced around the circle (e.g. the hydro database's).
    partitions : SpectrumPartition or sequence of SpectrumPartition
        Wave systems; an empty sequence gives zeros.
    heading_deg : float
        Vessel heading ψ [deg], clockwise from true North.
    interpolate : bool, default False
        For long-crested partitions, split between the two neighbouring grid directions.

    Returns
    -------
    ndarray
        S [m²·s/rad²], shape (n_omega, n_beta).
    """
    om = np.asarray(omega, dtype=float)
    if om.ndim != 1:
        raise ValueError(f"omega must be 1-D, got shape {om.shape}")
    if np.ndim(heading_deg) != 0:
        raise ValueError(f"heading_deg must be a scalar, got shape {np.shape(heading_deg)}")
    grid, _, _ = _direction_grid(beta_grid)
    parts = [partitions] if isinstance(partitions, SpectrumPartition) else list(partitions)
    out = np.zeros((om.size, grid.size))
    for part in parts:
        beta_p = wave_direction_from_nautical(part.dir_from_deg, heading_deg)
        d = discrete_spreading(grid, beta_p, part.spreading, part.spreading_param, interpolate=interpolate)
        out += part.spectrum(om)[:, None] * d[None, :]
    return out


# --------------------------------------------------------------------------------------------------
# Moments
# --------------------------------------------------------------------------------------------------


def spectral_moments(omega: ArrayLike, S: ArrayLike, orders: Sequence[float] = (0, 1, 2), axis: int = -1) -> np.ndarray:
    """Spectral moments m_n = ∫ ωⁿ S(ω) dω by the trapezoidal rule on the given grid (DESIGN §3).

    The integral covers only [omega[0], omega[-1]]: a truncated grid misses the tail (for PM/JONSWAP,
    m0 beyond ω is ≈ S(ω) ω / 4).

    Parameters
    ----------
    omega : array_like, shape (n_omega,)
        Frequencies [rad/s], increasing.
    S : array_like
        Spectrum [unit²·s/rad] with the frequency axis at `axis` (length n_omega).
    orders : sequence of float, default (0, 1, 2)
        Moment orders n.
    axis : int, default -1
        Frequency axis of `S`.

    Returns
    -------
    ndarray
        Moments [unit²·(rad/s)ⁿ], shape ``(len(orders),) + S.shape`` without `axis`; unpack with
        ``m0, m1, m2 = spectral_moments(omega, S)``.
    """
    om = np.asarray(omega, dtype=float)
    spec = np.moveaxis(np.asarray(S, dtype=float), axis, -1)
    if om.ndim != 1 or spec.shape[-1] != om.size:
        raise ValueError(f"omega (shape {om.shape}) does not match axis {axis} of S (shape {np.shape(S)})")
    return np.stack([np.trapezoid(om**n * spec, om, axis=-1) for n in orders])


def hs_tz_from_spectrum(omega: ArrayLike, S: ArrayLike, axis: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """Significant wave height Hs = 4√m0 [m] and zero-upcrossing period Tz = 2π√(m0/m2) [s].

    Parameters
    ----------
    omega : array_like, shape (n_omega,)
        Frequencies [rad/s], increasing.
    S : array_like
        Spectrum [m²·s/rad] with the frequency axis at `axis`.
    axis : int, default -1
        Frequency axis of `S`.

    Returns
    -------
    hs, tz : ndarray
        Each of shape ``S.shape`` without `axis` (trapezoidal moments, see :func:`spectral_moments`).
    """
    m0, m2 = spectral_moments(omega, S, orders=(0, 2), axis=axis)
    with np.errstate(divide="ignore", invalid="ignore"):
        return 4.0 * np.sqrt(m0), TWO_PI * np.sqrt(m0 / m2)

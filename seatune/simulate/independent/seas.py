"""Sea-state partitions and their directional spectra, built with wavespectra's constructors.

A partition is a frequency shape (JONSWAP from ``wavespectra.construct.frequency.jonswap`` with γ drawn
1–7, or Ochi–Hubble) times a spreading (cos-2s from ``wavespectra.construct.direction.cartwright``, or a
wrapped normal written here with scipy). Directions are nautical coming-from [deg]; spectra returned in
seatune's units: S(ω, θ) [m²·s/rad²] (one-sided, ω in rad/s, θ in radians).

wavespectra 4.9 has no Ochi–Hubble constructor; :func:`ochi_hubble` is the three-parameter form
(Ochi & Hubble 1976): S(ω) = ¼ [((4λ+1)/4) ω_m⁴]^λ / Γ(λ) · H_s² / ω^{4λ+1} · exp(−(4λ+1)/4 (ω_m/ω)⁴).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.special import gammaln
from scipy.stats import norm

#: fine grid [rad/s] on which every partition is normalised to its Hs
_W_NORM = np.linspace(0.05, 6.0, 6000)


@dataclass
class Partition:
    kind: str  # wind_sea | swell | swell2
    hs: float  # m
    tp: float  # s
    dir_from_deg: float  # nautical coming-from
    gamma: float  # JONSWAP γ (shape "jonswap") or Ochi–Hubble λ (shape "ochihubble")
    spreading: str  # cos2s | wrapped_normal
    spread_deg: float  # directional spread σ_θ [deg] (cos-2s: s = 2/σ² − 1, wavespectra's dspr)
    shape: str = "jonswap"
    in_hindcast: bool = True

    def as_dict(self) -> dict:
        d = asdict(self)
        return {k: (round(v, 6) if isinstance(v, float) else v) for k, v in d.items()}


def _jonswap_raw(w: np.ndarray, p: Partition, alpha: float = 0.0081) -> np.ndarray:
    from wavespectra.construct.frequency import jonswap

    f = np.asarray(w) / (2 * np.pi)
    e = jonswap(f, fp=1.0 / p.tp, alpha=alpha, gamma=p.gamma).values  # m²/Hz
    return e / (2 * np.pi)  # m² s / rad


def ochi_hubble(w: np.ndarray, hs: float, tp: float, lam: float) -> np.ndarray:
    w = np.asarray(w, dtype=float)
    wm = 2 * np.pi / tp
    a = (4 * lam + 1) / 4
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        log_s = lam * np.log(a * wm**4) - gammaln(lam) + np.log(0.25 * hs**2) - (4 * lam + 1) * np.log(w)
        s = np.exp(log_s - a * (wm / w) ** 4)
    return np.where(w > 0, s, 0.0)


def frequency_spectrum(w: np.ndarray, p: Partition) -> np.ndarray:
    """S(ω) [m²·s/rad], exactly Hs on the fine normalisation grid."""
    if p.shape == "ochihubble":
        raw = lambda x: ochi_hubble(x, 1.0, p.tp, p.gamma)  # noqa: E731
    else:
        raw = lambda x: _jonswap_raw(x, p)  # noqa: E731
    m0 = np.trapezoid(raw(_W_NORM), _W_NORM)
    return raw(np.asarray(w, dtype=float)) * (p.hs / 4.0) ** 2 / m0


def spreading(theta_deg: np.ndarray, p: Partition) -> np.ndarray:
    """D(θ) [1/rad] on the given coming-from directions, normalised on that grid (Σ D Δθ = 1)."""
    theta_deg = np.asarray(theta_deg, dtype=float)
    dth = 2 * np.pi / theta_deg.size  # uniform grids only
    if p.spreading == "cos2s":
        from wavespectra.construct.direction import cartwright

        d = cartwright(theta_deg, dm=p.dir_from_deg, dspr=p.spread_deg).values * (180.0 / np.pi)  # 1/rad
    elif p.spreading == "wrapped_normal":
        diff = np.deg2rad(theta_deg - p.dir_from_deg)
        sig = np.deg2rad(p.spread_deg)
        k = np.arange(-3, 4)[:, None] * 2 * np.pi
        d = norm.pdf(diff[None, :] + k, scale=sig).sum(axis=0)
    else:
        raise ValueError(f"unknown spreading {p.spreading!r}")
    return d / (d.sum() * dth)


def directional_spectrum(w: np.ndarray, theta_deg: np.ndarray, parts: list[Partition]) -> np.ndarray:
    """S(ω, θ) [m²·s/rad²] (n_w, n_θ) summed over the partitions."""
    out = np.zeros((np.size(w), np.size(theta_deg)))
    for p in parts:
        out += frequency_spectrum(w, p)[:, None] * spreading(theta_deg, p)[None, :]
    return out


def hs_of(parts: list[Partition]) -> float:
    return float(np.sqrt(sum(p.hs**2 for p in parts)))


def peak_period(parts: list[Partition]) -> float:
    """Peak period [s] of the summed 1-D spectrum (fine grid)."""
    w = np.linspace(0.2, 3.0, 5600)
    s = sum(frequency_spectrum(w, p) for p in parts)
    return float(2 * np.pi / w[int(np.argmax(s))])


def mean_period_m10(parts: list[Partition]) -> float:
    """T_{m−1,0} [s] (ERA5's mwp / mpww / mpts definition)."""
    w = _W_NORM
    s = sum(frequency_spectrum(w, p) for p in parts)
    return float(2 * np.pi * np.trapezoid(s / w, w) / np.trapezoid(s, w))


def mean_direction(parts: list[Partition]) -> float:
    """Energy-weighted vector-mean coming-from direction [deg]."""
    c = sum(p.hs**2 * np.cos(np.deg2rad(p.dir_from_deg)) for p in parts)
    s = sum(p.hs**2 * np.sin(np.deg2rad(p.dir_from_deg)) for p in parts)
    return float(np.mod(np.rad2deg(np.arctan2(s, c)), 360.0))

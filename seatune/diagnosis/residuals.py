"""Residuals of measured against model spectra: log ratio per window × channel × ω with its sampling spread,
aggregated over windows, bands of systematic misfit and their features. Pure computation.

A Welch estimate with ν degrees of freedom is Ŝ = S·χ²_ν/ν, so ln(Ŝ/S) has mean ψ(ν/2) − ln(ν/2) and variance
ψ′(ν/2) (digamma, trigamma); the residual below is bias-corrected and its z-score exact for χ² sampling.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import digamma, polygamma
from scipy.stats import spearmanr

Z_BAND = 3.0  # |aggregated z| that marks a bin as systematic misfit
Z_CHANNEL = 2.5  # mean |z| in a band that counts a channel as affected
DOF_NAMES = {2: "heave", 3: "roll", 4: "pitch"}


def log_ratio(measured: np.ndarray, expected: np.ndarray, dof: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bias-corrected ln(Ŝ/E[Ŝ]) and its standard deviation; dof broadcasts against the spectra."""
    half = np.asarray(dof, dtype=float)[..., None] / 2  # special functions on the dof, not on every bin
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.log(np.maximum(measured, 1e-300) / np.maximum(expected, 1e-300)) - (digamma(half) - np.log(half))
    return r, np.broadcast_to(np.sqrt(polygamma(1, half)), r.shape)


def aggregate_z(r: np.ndarray, sd: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Signed z of the mean residual over windows per channel × ω (Stouffer): (nc, nf); 0 where no window."""
    z = np.where(mask, r / sd, 0.0)
    n = mask.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, z.sum(axis=0) / np.sqrt(np.maximum(n, 1)), 0.0)


@dataclass
class Band:
    omega_lo: float
    omega_hi: float
    omega_peak: float
    channels: list[str]
    sign: int  # +1 measured above the model, −1 below
    z_max: float
    nearest_mode: str
    frequency_ratio: float  # ω_peak / ω_n of the nearest mode
    hs_corr: float  # Spearman ρ of the window's band residual with Hs
    amplitude_corr: float  # … with the measured σ of the most affected channel
    beta_corr: float  # … with |sin β| (beam-sea content)
    sog_corr: float  # … with speed over ground
    bins: np.ndarray  # (nf,) bool
    channel_mask: np.ndarray  # (nc,) bool


def find_bands(z: np.ndarray, min_bins: int = 2) -> list[tuple]:
    """Contiguous runs of bins where some channel's |z| ≥ Z_BAND (gaps of one bin bridged)."""
    hot = (np.abs(z) >= Z_BAND).any(axis=0)
    if hot.size > 2:  # bridge single-bin gaps
        hot[1:-1] |= hot[:-2] & hot[2:]
    runs, start = [], None
    for i, h in enumerate(np.r_[hot, False]):
        if h and start is None:
            start = i
        elif not h and start is not None:
            if i - start >= min_bins:
                runs.append((start, i))
            start = None
    return runs


def bands(data, r: np.ndarray, sd: np.ndarray, modes: dict[str, float]) -> list[Band]:
    """Bands of systematic misfit on the windows of `data` and their features (ω relative to each natural
    frequency, channels, dependence on Hs, amplitude, heading and speed)."""
    mask = data.mask
    z = aggregate_z(r, sd, mask)
    out = []
    for a, b in find_bands(z):
        bins = np.zeros(data.omega.size, dtype=bool)
        bins[a:b] = True
        zc = np.abs(z[:, bins]).mean(axis=1)
        chan = zc >= Z_CHANNEL
        if not chan.any():
            chan = zc == zc.max()
        zz = np.where(chan[:, None], z, 0.0)[:, bins]
        k = np.unravel_index(np.argmax(np.abs(zz)), zz.shape)
        peak = float(data.omega[bins][k[1]])
        name, wn = min(modes.items(), key=lambda kv: abs(np.log(peak / kv[1]))) if modes else ("", np.nan)
        sel = mask[:, chan][:, :, bins]
        flat_sel = sel.reshape(sel.shape[0], -1)
        flat = np.where(flat_sel, r[:, chan][:, :, bins].reshape(sel.shape[0], -1), 0.0)
        per_window = np.where(flat_sel.any(axis=1), flat.sum(axis=1) / np.maximum(flat_sel.sum(axis=1), 1), np.nan)
        top = int(np.argmax(np.where(chan, zc, -1)))
        amp = np.sqrt((data.measured[:, top] * mask[:, top]).sum(axis=1))
        out.append(Band(omega_lo=float(data.omega[a]), omega_hi=float(data.omega[b - 1]), omega_peak=peak,
                        channels=[c for c, k2 in zip(data.channels, chan, strict=True) if k2],
                        sign=int(np.sign(zz[k])), z_max=float(np.abs(zz[k])), nearest_mode=name,
                        frequency_ratio=float(peak / wn), hs_corr=_corr(per_window, data.hs),
                        amplitude_corr=_corr(per_window, amp), beta_corr=_corr(per_window,
                                                                             np.abs(np.sin(np.radians(data.beta_deg)))),
                        sog_corr=_corr(per_window, data.sog), bins=bins, channel_mask=chan))
    return out


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 3 or np.ptp(a[ok]) == 0 or np.ptp(b[ok]) == 0:
        return float("nan")
    return float(spearmanr(a[ok], b[ok]).statistic)


def gap(r: np.ndarray, sd: np.ndarray, select: np.ndarray, smooth: int = 5, bin_correlation: float = 1.5) -> float:
    """Systematic part of the RMS log ratio over the selected bins (nw, nc, nf): residuals averaged over `smooth`
    neighbouring selected bins (a misfit band is wider; sampling noise averages out), then the sampling variance
    of those averages removed: √max(mean(r̄² − var r̄), 0)."""
    if not select.any():
        return float("nan")
    kernel = np.ones(smooth)
    rs = np.where(select, r, 0.0)
    vs = np.where(select, sd**2, 0.0)
    n = np.apply_along_axis(np.convolve, -1, select.astype(float), kernel, mode="same")
    mean = np.apply_along_axis(np.convolve, -1, rs, kernel, mode="same") / np.maximum(n, 1)
    var = np.apply_along_axis(np.convolve, -1, vs, kernel, mode="same") / np.maximum(n, 1) ** 2
    var = np.minimum(var * bin_correlation, np.where(select, sd**2, 0.0))  # neighbouring Welch bins correlate
    return float(np.sqrt(max(np.mean(mean[select] ** 2 - var[select]), 0.0)))


def describe(band: Band) -> str:
    """One line a user reads: where, which channels, how it behaves."""
    where = f"{band.omega_lo:.2f}–{band.omega_hi:.2f} rad/s"
    mode = f" ({band.frequency_ratio:.2f}× the {band.nearest_mode} natural frequency)" if band.nearest_mode else ""
    sense = "measured above the model" if band.sign > 0 else "measured below the model"
    extra = []
    if np.isfinite(band.hs_corr) and abs(band.hs_corr) >= 0.6:
        extra.append(f"grows with Hs (ρ = {band.hs_corr:+.2f})" if band.hs_corr * band.sign > 0
                     else f"shrinks with Hs (ρ = {band.hs_corr:+.2f})")
    return f"{where}{mode}: {', '.join(band.channels)} {sense}, |z| up to {band.z_max:.1f}" + (
        "; " + "; ".join(extra) if extra else "")

"""Time-series synthesis: one directional wave realisation driving every channel coherently.

Han thesis eq. 2.8 / paper A2 eq. 17: x_j(t) = Σ_n Re{H_j(ω_n, β_n) a_n e^{−i(ω_n t + φ_n)}} with
a_n = √(2 S(ω_n, D_n) Δω_n ΔD), random frequencies per direction (stratified in ω so that the record
does not repeat) and uniform random phases. Capytaine's convention: a wave travelling along the earth
unit vector e has complex elevation a e^{i k e·r} at the vessel position r, so a vessel moving with
velocity U meets the component at the encounter frequency ω − k e·U.

The sum is evaluated block by block (the heading, position, velocity and sea state are held per block
and blocks are blended with cos² windows that add up to one). Inside a block the non-uniform
frequencies are summed with FFTs: ω = mΔ + δ with |δτ| ≤ π/2, and e^{−iδτ} by its Taylor series
(a type-3 non-uniform DFT); 12 terms bound the truncation by (π/2)^12/12! = 5e-7 of the amplitude sum.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np
import scipy.fft
import scipy.sparse as sp

from seatune.physics.interp import blend

G = 9.81


@dataclass(frozen=True)
class WaveComponents:
    """N regular wave components of one realisation (earth-fixed directions)."""

    omega: np.ndarray  # (N,) rad/s
    d_omega: np.ndarray  # (N,) rad/s, the frequency band each component stands for
    dir_from_deg: np.ndarray  # (N,) nautical coming-from direction of each component
    d_dir: float  # rad, direction band of each component
    phase: np.ndarray  # (N,) rad

    @property
    def wavenumber(self) -> np.ndarray:
        return self.omega**2 / G  # deep water

    @property
    def unit_to_en(self) -> np.ndarray:
        """(N, 2) east/north unit vector of the propagation (going-to) direction."""
        chi = np.radians(self.dir_from_deg + 180.0)
        return np.stack([np.sin(chi), np.cos(chi)], axis=-1)


def draw_components(rng: np.random.Generator, omega_min: float, omega_max: float,
                    n_per_direction: int, n_directions: int = 24) -> WaveComponents:
    """Random frequencies per direction, one per equal band of [omega_min, omega_max] (Han thesis §2)."""
    edges = np.linspace(omega_min, omega_max, n_per_direction + 1)
    width = np.diff(edges)
    omega = edges[:-1][None, :] + rng.uniform(0.0, 1.0, (n_directions, n_per_direction)) * width[None, :]
    dirs = np.repeat(np.arange(n_directions) * 360.0 / n_directions, n_per_direction)
    return WaveComponents(
        omega=omega.ravel(), d_omega=np.tile(width, n_directions), dir_from_deg=dirs,
        d_dir=2 * np.pi / n_directions, phase=rng.uniform(0.0, 2 * np.pi, omega.size),
    )


def amplitudes(components: WaveComponents, spectrum_density: np.ndarray) -> np.ndarray:
    """a_n = √(2 S(ω_n, D_n) Δω_n ΔD) (A2 eq. 17b) for S given per component (..., N) [m²·s/rad²]."""
    return np.sqrt(2.0 * spectrum_density * components.d_omega * components.d_dir)


@dataclass(frozen=True)
class BlockPlan:
    """Block centres (sample indices) and the per-block state the synthesis holds constant."""

    size: int  # M samples per block (even); blocks overlap by half
    centres: np.ndarray  # (B,) sample index of each block centre

    @classmethod
    def covering(cls, n_samples: int, size: int) -> BlockPlan:
        hop = size // 2
        return cls(size=size, centres=np.arange(0, n_samples + hop, hop))


def synthesize(dt: float, n_samples: int, components: WaveComponents, plan: BlockPlan,
               amp: np.ndarray, transfer: np.ndarray, heading_deg: np.ndarray, velocity_en: np.ndarray,
               position_en: np.ndarray, orders: tuple[int, ...] = (0,), taylor_terms: int = 12) -> np.ndarray:
    """Channel time series (n_samples, nch · len(orders)) of one wave realisation.

    Parameters
    ----------
    dt : sample interval [s]; n_samples : record length
    components : the realisation
    plan : block layout
    amp : (B, N) component amplitudes at each block centre [m]
    transfer : (N, nb, nch) channel RAOs at the component frequencies on an equally spaced β grid over [0, 2π)
    heading_deg : (B,) compass heading; velocity_en, position_en : (B, 2) east/north [m/s, m]
    orders : time derivatives to return, each a block of nch columns (d/dt ↔ −iω_e)
    """
    M = plan.size
    n_beta = transfer.shape[1]
    d_beta = 2 * np.pi / n_beta
    nch = transfer.shape[2] * len(orders)
    k_vec = components.wavenumber[:, None] * components.unit_to_en  # (N, 2)
    tau_max = M * dt / 2
    u = (np.arange(M) - M // 2) / (M // 2)  # τ / τ_max in [−1, 1)
    window = np.cos(np.pi * u / 2) ** 2  # cos² windows at half overlap add up to one
    delta_grid = 2 * np.pi / (M * dt)
    out = np.zeros((n_samples, nch))
    p = np.arange(taylor_terms)
    inv_fact = 1.0 / np.array([factorial(int(q)) for q in p])
    rows = np.arange(components.omega.size)
    for b, centre in enumerate(plan.centres):
        t_b = centre * dt
        beta = np.mod(np.radians(heading_deg[b] - components.dir_from_deg - 180.0), 2 * np.pi)
        i0 = np.floor(beta / d_beta).astype(int) % n_beta
        f = (beta - i0 * d_beta)[:, None] / d_beta
        h = blend(transfer[rows, i0], transfer[rows, (i0 + 1) % n_beta], f)  # (N, nch), power-linear in β
        omega_e = components.omega - k_vec @ velocity_en[b]
        c = (amp[b] * np.exp(1j * (k_vec @ position_en[b] - components.omega * t_b - components.phase)))[:, None] * h
        c = np.concatenate([c * ((-1j * omega_e) ** q)[:, None] for q in orders], axis=1)
        m = np.rint(omega_e / delta_grid).astype(int)
        delta_scaled = (omega_e - m * delta_grid) * tau_max  # |δ τ_max| ≤ π/2
        sign = np.where(m % 2 == 0, 1.0, -1.0)  # e^{iπm}: FFT index j is τ = (j − M/2) dt
        taylor = ((-1j * delta_scaled)[:, None] ** p) * inv_fact * sign[:, None]  # (N, P)
        binning = sp.csr_matrix((np.ones_like(m, dtype=float), (np.mod(m, M), rows)), shape=(M, m.size))
        coeff = binning @ (c[:, None, :] * taylor[:, :, None]).reshape(m.size, -1)  # (M, P·nch)
        spectra = scipy.fft.fft(coeff, axis=0, workers=-1).reshape(M, taylor_terms, nch)
        block = spectra[:, -1, :]
        for q in range(taylor_terms - 2, -1, -1):  # Horner in u
            block = block * u[:, None] + spectra[:, q, :]
        lo = centre - M // 2
        sl = slice(max(lo, 0), min(lo + M, n_samples))
        if sl.start >= sl.stop:
            continue
        part = slice(sl.start - lo, sl.stop - lo)
        out[sl] += window[part, None] * block[part].real
    return out


def direct_sum(t: np.ndarray, components: WaveComponents, amp: np.ndarray, transfer_at_beta: np.ndarray,
               chunk: int = 2048) -> np.ndarray:
    """Reference: Σ_n Re{H_n a_n e^{−i(ω_n t + φ_n)}} sample by sample, for a stationary, non-moving vessel.

    transfer_at_beta : (N, nch) RAO of each component at its (fixed) relative direction.
    """
    c = (amp * np.exp(-1j * components.phase))[:, None] * transfer_at_beta
    out = np.empty((t.size, c.shape[1]))
    for start in range(0, t.size, chunk):
        tt = t[start:start + chunk]
        out[start:start + chunk] = (np.exp(-1j * np.outer(tt, components.omega)) @ c).real
    return out

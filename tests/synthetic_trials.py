"""Synthetic sea-state trials on the sample vessel for the tuning validations (Han A2 §6, A6 §4).

The measured side is a time-domain simulation, independent of the tuning forward model: the truth loading's
equation of motion is solved at every wave component's own frequency (not on the hydro database's grid),
the channel is summed as Σ_n Re{H_j(ω_n, β) a_n e^{−i(ω_n t + φ_n)}} (A6 eq. 14, deterministic amplitudes
a_n = √(2 S Δω_n), random phases, one random frequency per band so the record does not repeat), white noise
at SNR 50 is added (A6 eq. 15), the record is FFT-lowpassed at f_lp and σ̂ is its sample STD (A6 eq. 7b).
"""

from __future__ import annotations

import numpy as np

from seatune.physics.channels import transfer_vectors
from seatune.physics.interp import blend
from seatune.physics.response import motion_raos_at
from seatune.physics.spectra import pierson_moskowitz
from seatune.tuning.forward import ChannelPower, WindowStatistics
from seatune.tuning.interface import Observation

#: Han's Vessel A sensors on the sample vessel: heave displacement, velocity and acceleration at A, B, C.
HEAVE_CHANNELS = tuple(f"heave_{k}_{p}" for k in ("disp", "vel", "acc") for p in "ABC")
DT = 0.1  # s (A2)
SNR = 50.0  # A6 eq. 15
N_COMPONENTS = 400


def measured_sigmas(vessel, truth: dict, channels, hs, tp, beta_deg, duration_s, f_lp_hz, rng) -> np.ndarray:
    """σ̂ of each channel from one long-crested PM realisation (A6 eqs. 12–15, 7b)."""
    db = vessel.db
    edges = np.linspace(db.omega[0], db.omega[-1], N_COMPONENTS + 1)
    d_omega = np.diff(edges)
    omega = edges[:-1] + rng.uniform(0.0, 1.0, N_COMPONENTS) * d_omega
    loading = vessel.loading(**truth)
    xi = motion_raos_at(db, loading, omega)  # (N, nb, 6), solved at each ω_n
    t_vec = transfer_vectors([vessel.channel(c) for c in channels], omega, np.array([_draft(db, loading)]), db.g)[0]
    h_beta = np.einsum("wbd,wdc->wbc", xi, t_vec)  # (N, nb, nch)
    grid = np.degrees(db.wave_direction)
    b = np.mod(beta_deg, 360.0)
    i = int(np.clip(np.searchsorted(np.r_[grid, 360.0], b, side="right") - 1, 0, grid.size - 1))
    f = (b - grid[i]) / ((grid[i + 1] if i + 1 < grid.size else 360.0) - grid[i])
    h = blend(h_beta[:, i], h_beta[:, (i + 1) % grid.size], f)  # (N, nch)
    amp = np.sqrt(2.0 * pierson_moskowitz(omega, hs, tp) * d_omega)  # A6 eq. 14
    coeff = (amp * np.exp(-1j * rng.uniform(0.0, 2 * np.pi, N_COMPONENTS)))[:, None] * h
    t = np.arange(int(round(duration_s / DT))) * DT
    x = np.empty((t.size, len(channels)))
    for start in range(0, t.size, 4096):
        tt = t[start:start + 4096]
        x[start:start + 4096] = (np.exp(-1j * np.outer(tt, omega)) @ coeff).real
    x += rng.normal(0.0, 1.0, x.shape) * x.std(axis=0) / np.sqrt(SNR)
    spec = np.fft.rfft(x - x.mean(axis=0), axis=0)
    spec[np.fft.rfftfreq(t.size, DT) > f_lp_hz] = 0.0  # FFT lowpass (A6 §3.2)
    return np.fft.irfft(spec, n=t.size, axis=0).std(axis=0, ddof=1)


def _draft(db, loading) -> float:
    return float(db.draft_for_volume(loading.mass / db.rho)[0])


def long_crested_model(power: ChannelPower, names, hs, tp, beta_deg, f_lp_hz) -> WindowStatistics:
    """The tuning forward model for a long-crested PM sea at the acquired (Hs, Tp, β): one direction bin."""
    db = power.vessel.db
    spectrum0 = pierson_moskowitz(db.omega, hs, tp)[:, None] / (2 * np.pi)  # × d_dir = 2π of one bin
    dir_from = np.mod(-beta_deg - 180.0, 360.0)  # heading 0: β = −D − 180° (DESIGN §3)
    cutoff = {c.split(":")[0]: 2 * np.pi * f_lp_hz for c in names}
    return WindowStatistics(power, names, spectrum0, np.array([dir_from]), 0.0, (hs, tp, beta_deg), cutoff)


def observation(window_id: str, names, sigma: np.ndarray, model: WindowStatistics, phi0: np.ndarray,
                duration_s: float) -> Observation:
    """σ̂ with its sampling variance σ²/(2ν), ν from the prior model's response spectrum (as the tune stage)."""
    from seatune.pipeline.tune import effective_dof

    spectra = model._spectra(model.power(phi0[None, :]), model.wave_weights(model.theta0[None, :]))[:, 0, :, 0]
    var = []
    for j in range(len(names)):
        band = model._w[j] > 0
        nu = effective_dof(spectra[band, model._chan[j]].astype(float), model.omega[band], duration_s)
        var.append(sigma[j] ** 2 / (2 * max(nu, 1.0)))
    return Observation.of_one_sea(window_id, names, sigma, var, duration_s)

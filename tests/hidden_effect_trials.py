"""Fast long-crested trial windows with an optional hidden physical effect, as Welch spectra.

Measured side only (independent of the tuning forward model): the truth loading's equation of motion is
solved at every wave component's own frequency (with the moonpool / anti-roll tank DOF when asked), the
6-DOF motions are summed as ξ(t) = Re Σ_n ξ_n(β) a_n e^{−iω_n t} with random complex Gaussian amplitudes
a_n = √(S Δω_n)(N(0,1) + i N(0,1)) (Rayleigh, so Welch estimates have χ² statistics), quadratic roll damping
is integrated in the time domain, channels follow linearly at the truth draft (IMU specific force at the
shifted point for a lever arm), and white noise at the SNR is added (A6 eq. 15).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.signal import get_window, welch

from seatune.physics.channels import transfer_vectors
from seatune.physics.interp import blend
from seatune.physics.response import motion_raos_at
from seatune.physics.spectra import jonswap
from seatune.simulate.effects import (
    EFFECTS,
    augmented_raos,
    effect_params,
    loading_draft,
    quadratic_roll_correction,
    roll_constants,
)

N_COMPONENTS = 400
_CHUNK = 2048


def welch_dof(n_samples: int, nperseg: int) -> float:
    """ν of a Welch estimate with a Hann window at 50 % overlap (Welch 1967; Percival & Walden eq. 292b):
    ν = 2K / (1 + 2 c² (1 − 1/K)), c = Σ w_t w_{t+L/2} / Σ w_t² (≈ 0.167 for Hann)."""
    hop = nperseg // 2
    k = max(1, (n_samples - nperseg) // hop + 1)
    w = get_window("hann", nperseg)
    c = float(w[:-hop] @ w[hop:] / (w @ w))
    return 2.0 * k / (1.0 + 2.0 * c**2 * (1.0 - 1.0 / k))


def _is_imu(vessel, name: str) -> bool:
    tags = {c.name: c.sensor for c in vessel.spec.channels}
    return (tags.get(name) or name) == "imu" or name.startswith("imu_")


def _roll_polynomial(t_vec: np.ndarray) -> np.ndarray:
    """(3, nch) real c_q with t_j[3](ω) = Σ_q c_q (−iω)^q, from t at ω = 0 and 1 (orders 0, 1, 2)."""
    c0 = t_vec[0, 3].real
    d = t_vec[1, 3] - c0  # = −i c1 − c2
    return np.stack([c0, -d.imag, -d.real])


def _at_beta(xi: np.ndarray, grid: np.ndarray, beta_deg: float) -> np.ndarray:
    """(N, k) transfer at body-relative β [deg], power-phase blend of the neighbouring grid directions."""
    b = np.mod(beta_deg, 360.0)
    i = int(np.clip(np.searchsorted(np.r_[grid, 360.0], b, side="right") - 1, 0, grid.size - 1))
    f = (b - grid[i]) / ((grid[i + 1] if i + 1 < grid.size else 360.0) - grid[i])
    return blend(xi[:, i], xi[:, (i + 1) % grid.size], f)


def simulate_windows(vessel, truth: dict, effect: dict | list[dict] | None, sea_states: list[dict], channels: list[str],
                     duration_s: float, rng, dt: float = 0.5, welch_segment_s: float = 256.0,
                     snr: float = 50.0, series: bool = False) -> list[dict]:
    """One window per sea state {"hs", "tp", "beta_deg", "gamma"=3.3, optionally "swell": a second system of the
same keys}: Welch spectra of the channels, with one hidden effect or a list of them (at most one of each kind).

    Returns per window {"hs", "tp", "beta_deg", "omega" [rad/s], "S" (nch, nf) [unit²·s/rad], "dof",
    "sigma" (nch,), "channels"}; with `series`, also "x" (T, nch), the noisy time series.
    """
    db = vessel.db
    loading = vessel.loading(**truth)
    draft = loading_draft(db, loading)
    hidden = [] if effect is None else [effect] if isinstance(effect, dict) else list(effect)
    params = {e["kind"]: effect_params(EFFECTS[e["kind"]], e) for e in hidden}
    chans = [vessel.channel(c) for c in channels]
    if "imu_lever_arm" in params:
        d = np.array([params["imu_lever_arm"][k] for k in ("dx", "dy", "dz")], dtype=float)
        chans = [replace(ch, point=tuple(np.asarray(ch.point, dtype=float) + d))
                 if ch.point is not None and _is_imu(vessel, ch.name) else ch for ch in chans]
    rc = roll_constants(db, loading) if "quadratic_roll_damping" in params else None
    attached = [k for k in params if k in ("moonpool", "anti_roll_tank")]
    poly = _roll_polynomial(transfer_vectors(chans, np.array([0.0, 1.0]), np.array([draft]), db.g)[0])
    grid = np.degrees(db.wave_direction)
    edges = np.linspace(db.omega[0], db.omega[-1], N_COMPONENTS + 1)
    d_omega = np.diff(edges)
    n = int(round(duration_s / dt))
    t = np.arange(n) * dt
    nperseg = min(int(round(welch_segment_s / dt)), n)
    out = []
    for sea in sea_states:
        omegas, coeffs, rolls = [], [], []
        for system in [sea, *([sea["swell"]] if sea.get("swell") else [])]:  # a swell: a second long-crested system
            omega = edges[:-1] + rng.uniform(0.0, 1.0, N_COMPONENTS) * d_omega
            a = np.sqrt(jonswap(omega, system["hs"], system["tp"], system.get("gamma", 3.3)) * d_omega)
            a = a * (rng.normal(size=N_COMPONENTS) + 1j * rng.normal(size=N_COMPONENTS))
            if attached:
                xi = augmented_raos(db, loading, omega, [EFFECTS[k].extra_dof(db, loading, omega, params[k])
                                                         for k in attached])[0]
            else:
                xi = motion_raos_at(db, loading, omega)
            xi_b = _at_beta(xi, grid, system["beta_deg"]) * a[:, None]  # (N, 6) complex amplitude of each component
            t_vec = transfer_vectors(chans, omega, np.array([draft]), db.g)[0]  # (N, 6, nch)
            omegas.append(omega)
            coeffs.append(np.einsum("nd,ndc->nc", xi_b, t_vec))
            rolls.append(xi_b[:, 3])
        omega, coeff = np.concatenate(omegas), np.concatenate(coeffs)
        if rc is not None:
            coeff = np.concatenate([coeff, (-1j * omega * np.concatenate(rolls))[:, None]], axis=1)  # + roll rate
        x = np.empty((n, coeff.shape[1]))
        for s in range(0, n, _CHUNK):
            x[s:s + _CHUNK] = (np.exp(-1j * np.outer(t[s:s + _CHUNK], omega)) @ coeff).real
        if rc is not None:
            corr = quadratic_roll_correction(x[:, -1], dt, rc, float(params["quadratic_roll_damping"]["q"]))
            x = x[:, :-1] + np.stack(corr, axis=1) @ poly  # channel j += Σ_q c_qj d^qδφ/dt^q
        x = x + rng.normal(0.0, 1.0, x.shape) * x.std(axis=0) / np.sqrt(snr)
        f, s_f = welch(x, fs=1.0 / dt, window="hann", nperseg=nperseg, noverlap=nperseg // 2,
                       detrend="constant", axis=0)
        out.append({"hs": sea["hs"], "tp": sea["tp"], "beta_deg": sea["beta_deg"], "omega": 2 * np.pi * f,
                    "S": s_f.T / (2 * np.pi), "dof": welch_dof(n, nperseg), "sigma": x.std(axis=0),
                    "channels": list(channels)})
        if series:
            out[-1]["x"] = x
    return out

"""The forward model both backends call: predicted σ (and Tz) of measured channels for loading parameters φ and
sea-state parameters θ = (hs, tp, beta_deg) of one window. Pure computation.

The sea state of a window is the hindcast's own directional spectrum S0(ω, D) at the window, transformed by θ
as a self-similar sea: S(ω, D) = (Hs/Hs0)² (Tp/Tp0) S0(ω Tp/Tp0, D) (Hs² Tp f(ω Tp) scaling), rotated by β − β0.
So hypotheses about Hs, Tp and direction errors keep the hindcast's shape (wind sea + swell) instead of
replacing it by a one-peak parametric spectrum. Channel power |H_j(ω, β)|² of a loading condition is cached:
the DBI database points are solved once per run, not once per window.
"""

from __future__ import annotations

import numpy as np

from seatune.physics.loading import Loading
from seatune.physics.response import channel_raos, trapezoid_weights

SEA_STATE_NAMES = ("hs", "tp", "beta_deg")


class ChannelPower:
    """|H_j(ω, β)|² on the hydro database grid for batches of loading conditions, cached by φ row."""

    def __init__(self, vessel, parameter_names, channel_names, max_cache: int = 200_000):
        self.vessel = vessel
        self.parameter_names = tuple(parameter_names)
        self.channels = [vessel.channel(c) for c in channel_names]
        self.channel_names = tuple(channel_names)
        self._cache: dict[bytes, np.ndarray] = {}
        self.max_cache = max_cache

    def loading(self, phi: np.ndarray) -> Loading:
        return self.vessel.loading(**{name: phi[:, k] for k, name in enumerate(self.parameter_names)})

    def __call__(self, phi: np.ndarray) -> np.ndarray:
        """(n, nw, nb, m) float32."""
        phi = np.atleast_2d(np.asarray(phi, dtype=float))
        keys = [row.tobytes() for row in phi]
        missing = [i for i, k in enumerate(keys) if k not in self._cache]
        if missing:
            for start in range(0, len(missing), 2000):
                idx = missing[start:start + 2000]
                h = channel_raos(self.vessel.db, self.loading(phi[idx]), self.channels)
                power = (h.real**2 + h.imag**2).astype(np.float32)
                if len(self._cache) + len(idx) > self.max_cache:
                    self._cache.clear()
                for j, i in enumerate(idx):
                    self._cache[keys[i]] = power[j]
        return np.stack([self._cache[k] for k in keys])


class WindowStatistics:
    """ForwardModel of one window: measurement names "channel:sigma" / "channel:tz"."""

    sea_state_names = SEA_STATE_NAMES

    def __init__(self, power: ChannelPower, names, spectrum0: np.ndarray, dirs_from: np.ndarray, heading_deg: float,
                 theta0, cutoff_rad_s: dict[str, float]):
        db = power.vessel.db
        self.power = power
        self.names = tuple(names)
        self.parameter_names = power.parameter_names
        self.omega = db.omega
        self.beta_grid = np.degrees(db.wave_direction)
        self.spectrum0 = spectrum0  # (nw, nD) m²·s/rad² on db.omega
        self.dirs_from = np.asarray(dirs_from, dtype=float)
        self.d_dir = np.radians(np.diff(np.r_[self.dirs_from, self.dirs_from[0] + 360.0]).mean())
        self.heading = heading_deg
        self.theta0 = np.asarray(theta0, dtype=float)  # (hs0, tp0, beta0_deg)
        chan_index = {c: i for i, c in enumerate(power.channel_names)}
        self._chan = np.array([chan_index[n.split(":")[0]] for n in self.names])
        self._stat = np.array([n.split(":")[1] for n in self.names])
        w = trapezoid_weights(self.omega)
        self._w = np.stack([w * (self.omega <= cutoff_rad_s.get(n.split(":")[0], np.inf)) for n in self.names])

    def wave_weights(self, theta: np.ndarray) -> np.ndarray:
        """S(ω, β_b)·Δβ on the database's directions for each hypothesis: (h, nw, nb)."""
        theta = np.atleast_2d(theta)
        hs0, tp0, beta0 = self.theta0
        out = np.zeros((theta.shape[0], self.omega.size, self.beta_grid.size))
        grid = self.beta_grid
        ext = np.r_[grid, 360.0]
        for h, (hs, tp, beta) in enumerate(theta):
            r = tp / tp0
            s = np.stack([np.interp(self.omega * r, self.omega, self.spectrum0[:, d], left=0, right=0)
                          for d in range(self.dirs_from.size)], axis=1) * (hs / hs0) ** 2 * r * self.d_dir
            b = np.mod(self.heading - self.dirs_from - 180.0 + (beta - beta0), 360.0)  # DESIGN §3
            i = np.clip(np.searchsorted(ext, b, side="right") - 1, 0, grid.size - 1)
            f = (b - ext[i]) / (ext[i + 1] - ext[i])
            np.add.at(out[h], (slice(None), i), s * (1 - f))
            np.add.at(out[h], (slice(None), (i + 1) % grid.size), s * f)
        return out

    def _statistics(self, spectra: np.ndarray) -> np.ndarray:
        """spectra (..., nw, n_channels) -> (..., m) σ or Tz per measurement (band-limited at the filter cutoff)."""
        s = spectra[..., self._chan]  # (..., nw, m)
        m0 = np.einsum("...wm,mw->...m", s, self._w)
        m2 = np.einsum("...wm,mw->...m", s, self._w * self.omega**2)
        sigma = np.sqrt(np.maximum(m0, 0.0))
        tz = 2 * np.pi * np.sqrt(m0 / np.maximum(m2, 1e-300))
        return np.where(self._stat == "tz", tz, sigma)

    def predict(self, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        power = self.power(phi)  # (n, nw, nb, c)
        waves = self.wave_weights(theta).astype(np.float32)  # (h, nw, nb)
        spectra = np.einsum("nwbc,hwb->nhwc", power, waves, optimize=True)
        return self._statistics(spectra.astype(float))

    def predict_paired(self, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        power = self.power(phi)
        waves = self.wave_weights(theta).astype(np.float32)
        spectra = np.einsum("nwbc,nwb->nwc", power, waves, optimize=True)
        return self._statistics(spectra.astype(float))

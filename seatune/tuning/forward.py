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
from seatune.physics.spectra import direction_step

SEA_STATE_NAMES = ("hs", "tp", "beta_deg")


class ChannelPower:
    """|H_j(ω, β)|² on the hydro database grid for a batch of loading conditions, laid out (nw, n, c, nb) float32
    for one batched matrix product per frequency; the last few batches are cached (the DBI database is the same
    batch in every window)."""

    def __init__(self, vessel, parameter_names, channel_names, max_batches: int = 4):
        self.vessel = vessel
        self.parameter_names = tuple(parameter_names)
        self.channels = [vessel.channel(c) for c in channel_names]
        self.channel_names = tuple(channel_names)
        self._cache: dict[bytes, np.ndarray] = {}
        self.max_batches = max_batches
        from seatune.diagnosis.effects import vessel_effects

        self.effects = vessel_effects(vessel.spec.effects)  # model-side effects diagnose added to the vessel

    def loading(self, phi: np.ndarray) -> Loading:
        return self.vessel.loading(**{name: phi[:, k] for k, name in enumerate(self.parameter_names)})

    def __call__(self, phi: np.ndarray) -> np.ndarray:
        phi = np.ascontiguousarray(np.atleast_2d(np.asarray(phi, dtype=float)))
        key = phi.tobytes()
        if key not in self._cache:
            db = self.vessel.db
            out = np.empty((db.omega.size, phi.shape[0], len(self.channels), db.wave_direction.size), np.float32)
            for start in range(0, phi.shape[0], 2000):
                loading = self.loading(phi[start:start + 2000])
                if self.effects:
                    from seatune.diagnosis.model import effect_channel_raos

                    h = effect_channel_raos(self.vessel, loading, self.channel_names)
                else:
                    h = channel_raos(db, loading, self.channels)  # (n, nw, nb, c)
                out[:, start:start + 2000] = (h.real**2 + h.imag**2).transpose(1, 0, 3, 2)
            if len(self._cache) >= self.max_batches:
                self._cache.pop(next(iter(self._cache)))
            self._cache[key] = out
        return self._cache[key]


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
        self.d_dir = direction_step(self.dirs_from)
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
        """spectra (nw, n, c, h) -> (n, h, m) σ or Tz per measurement (band-limited at the filter cutoff)."""
        out = np.empty(spectra.shape[1:2] + spectra.shape[3:] + (len(self.names),))
        for j, (c, stat) in enumerate(zip(self._chan, self._stat, strict=True)):
            m0 = np.tensordot(self._w[j].astype(np.float32), spectra[:, :, c, :], axes=(0, 0)).astype(float)
            if stat == "tz":
                m2 = np.tensordot((self._w[j] * self.omega**2).astype(np.float32), spectra[:, :, c, :],
                                  axes=(0, 0)).astype(float)
                out[..., j] = 2 * np.pi * np.sqrt(m0 / np.maximum(m2, 1e-300))
            else:
                out[..., j] = np.sqrt(np.maximum(m0, 0.0))
        return out

    def _spectra(self, power: np.ndarray, waves: np.ndarray) -> np.ndarray:
        """Σ_β |H|² S Δβ per frequency as one batched matrix product: (nw, n, c, h)."""
        nw, n, c, nb = power.shape
        spectra = np.matmul(power.reshape(nw, n * c, nb), waves.transpose(1, 2, 0).astype(np.float32))
        return spectra.reshape(nw, n, c, -1)

    def predict(self, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        return self._statistics(self._spectra(self.power(phi), self.wave_weights(theta)))

    def predict_paired(self, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        full = self._statistics(self._spectra(self.power(phi), self.wave_weights(theta)))  # (n, h = n, m)
        idx = np.arange(full.shape[0])
        return full[idx, idx]


class ModeFrequencies:
    """ForwardModel of measured natural frequencies ("roll:omega_n", …): the coupled undamped roots of
    det(C − ω²(M + A(ω))) of each loading φ (physics/modes.py), the same for every sea-state hypothesis."""

    sea_state_names = ()

    def __init__(self, vessel, parameter_names, modes):
        from seatune.physics.modes import MODE_NAMES

        self.vessel = vessel
        self.parameter_names = tuple(parameter_names)
        self.modes = tuple(modes)
        self.names = tuple(f"{m.lower()}:omega_n" for m in self.modes)
        self._cols = [MODE_NAMES.index(m) for m in self.modes]

    def omega_n(self, phi: np.ndarray) -> np.ndarray:
        """(n, m) rad/s; a mode without restoring stiffness (GM ≤ 0) is 0, its limit."""
        from seatune.physics.modes import coupled_modes

        phi = np.atleast_2d(np.asarray(phi, dtype=float))
        loading = self.vessel.loading(**{name: phi[:, k] for k, name in enumerate(self.parameter_names)})
        return np.nan_to_num(coupled_modes(self.vessel.db, loading).omega[:, self._cols], nan=0.0)

    def predict(self, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        om = self.omega_n(phi)
        return np.repeat(om[:, None, :], np.atleast_2d(theta).shape[0], axis=1)

    def predict_paired(self, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
        return self.omega_n(phi)

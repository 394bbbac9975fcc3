"""The spectral model diagnosis fits: channel spectra of every window on the measured (Welch) frequencies, for
one loading condition and one candidate effect. Pure computation.

The tuning forward model works on the hydro database's grid; resonances a missing effect adds (a tank's split
roll peak, a moonpool's piston mode) are narrower than that grid, so here A(ω), B(ω) and F(ω, β) are
interpolated to the analysis frequencies (power and phase for F, physics/interp.py) and the equation of motion
(DESIGN §4) is solved at each of them. An effect changes the parts before the solve (`ModelParts`).
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from seatune.physics.channels import transfer_vectors
from seatune.physics.interp import interp_axis0
from seatune.physics.loading import load


@dataclass
class WindowSet:
    """Measured spectra of the analysed windows, all on one frequency grid (one Welch segment length)."""

    window_ids: list[str]
    roles: np.ndarray  # "train" | "holdout" per window
    omega: np.ndarray  # (nf,) rad/s, Welch bins
    omega_fine: np.ndarray  # (nm,) rad/s, where the model is solved (a uniform refinement around the bins)
    kernel_index: np.ndarray  # (nf, nk) indices into omega_fine around each bin
    kernel: np.ndarray  # (nk,) Welch spectral window |W|² at those offsets, sums to 1
    channels: list[str]
    measured: np.ndarray  # (nw, nc, nf) one-sided, unit²·s/rad
    dof: np.ndarray  # (nw, nc) Welch degrees of freedom per bin
    mask: np.ndarray  # (nw, nc, nf) bins analysed (energetic band, below the filter cutoff)
    wave: np.ndarray  # (nw, nm, nb) S(ω, β_b)·Δβ on omega_fine × the database's body-relative directions
    hs: np.ndarray  # (nw,) m, as the hindcast gives it
    tp: np.ndarray  # (nw,) s
    beta_deg: np.ndarray  # (nw,) mean body-relative wave direction (DESIGN §3)
    heading_deg: np.ndarray  # (nw,)
    sog: np.ndarray  # (nw,) m/s

    def subset(self, keep: np.ndarray) -> WindowSet:
        keep = np.asarray(keep, dtype=bool)
        return WindowSet([w for w, k in zip(self.window_ids, keep, strict=True) if k], self.roles[keep], self.omega,
                         self.omega_fine, self.kernel_index, self.kernel, self.channels, self.measured[keep],
                         self.dof[keep], self.mask[keep], self.wave[keep],
                         self.hs[keep], self.tp[keep], self.beta_deg[keep], self.heading_deg[keep], self.sog[keep])


@dataclass
class ModelParts:
    """What an effect may change, for one loading condition on the analysis grid."""

    omega: np.ndarray  # (nf,)
    impedance: np.ndarray  # (nf, 6, 6) H = −ω²(M + A) − iω(B + B_v) + C, or (nw, nf, 6, 6) per window
    force: np.ndarray  # (nf, nb, 6) excitation per unit wave amplitude
    transfer: np.ndarray  # (nf, 6, nc) channel maps t_j
    wave: np.ndarray  # (nw, nf, nb) S(ω, β)·Δβ
    beta: np.ndarray  # (nb,) rad, database directions
    draft: float
    roll_mode: Callable[[], tuple[float, float]]  # (ω_roll, I44 + A44(ω_roll)), on demand: a coupled eigen-solve
    g: float
    rho: float
    solved: dict = field(default_factory=dict, repr=False)  # the last solve, shared by shallow copies

    @cached_property
    def _roll(self) -> tuple[float, float]:
        return self.roll_mode()

    @property
    def omega_roll(self) -> float:
        """Undamped roll natural frequency [rad/s]."""
        return self._roll[0]

    @property
    def inertia_roll(self) -> float:
        """I44 + A44(ω_roll) about the origin [kg·m²]."""
        return self._roll[1]

    def solve(self) -> np.ndarray:
        """Channel transfer functions H_j(ω, β): (nf, nb, nc) or (nw, nf, nb, nc)."""
        key = (self.impedance, self.force, self.transfer)
        last = self.solved.get("last")
        if last is not None and all(a is b for a, b in zip(last[0], key, strict=True)):
            return last[1]  # a sea-side effect changed only the waves
        motions = self.solved.get("motions")
        if motions is not None and motions[0][0] is self.impedance and motions[0][1] is self.force:
            xi_t = motions[1]  # a sensor-side effect changed only the channel maps
        else:
            xi_t = np.swapaxes(np.linalg.solve(self.impedance, np.swapaxes(self.force, -1, -2)), -1, -2)  # (…, nb, 6)
            self.solved["motions"] = (key[:2], xi_t)  # holds the arrays, so their ids stay theirs
        h = xi_t @ self.transfer  # Σ_d ξ_d t_dc: a batched matmul (BLAS), not einsum
        self.solved["last"] = (key, h)
        return h

    def spectra(self) -> np.ndarray:
        """S_j(ω) = Σ_β |H_j|² S(ω, β) Δβ per window: (nw, nc, nf)."""
        h = self.solve()
        power = h.real**2 + h.imag**2
        return spectra_in_sea(power, self.wave)


def spectra_in_sea(power: np.ndarray, wave: np.ndarray) -> np.ndarray:
    """Σ_β |H_j(ω, β)|² S(ω, β) Δβ: power (nf, nb, nc) or (nw, nf, nb, nc), wave (nw, nf, nb) → (nw, nc, nf).
    As batched matrix products (BLAS); einsum would loop."""
    if power.ndim == 3:
        out = np.swapaxes(wave, 0, 1) @ power  # (nf, nw, nc)
        return out.transpose(1, 2, 0)
    return (wave[:, :, None, :] @ power)[:, :, 0, :].transpose(0, 2, 1)


class SpectralModel:
    """Channel spectra of a vessel over a WindowSet, for a loading condition and an effect."""

    def __init__(self, vessel, parameter_names, data: WindowSet | None = None, omega: np.ndarray | None = None,
                 channels=None):
        """On a WindowSet's fine grid and channels, or (no data: no waves) on `omega` for `channels`."""
        db = vessel.db
        self.vessel = vessel
        self.parameter_names = tuple(parameter_names)
        self.data = data
        self.omega = data.omega_fine if data is not None else np.asarray(omega, dtype=float)
        self.channel_names = list(data.channels if data is not None else channels)
        om = self.omega
        self._A = np.stack([interp_axis0(db.omega, a, om) for a in db.added_mass])  # (nd, nf, 6, 6)
        self._B = np.stack([interp_axis0(db.omega, b, om) for b in db.radiation_damping])
        self._F = np.stack([interp_axis0(db.omega, f, om) for f in db.excitation_force])  # (nd, nf, nb, 6)
        self._channels = [vessel.channel(c) for c in self.channel_names]
        from seatune.diagnosis.effects import vessel_effects

        self.known = vessel_effects(vessel.spec.effects)  # model-side effects already in the vessel YAML
        self._recent: list = []  # (phi bytes, wave array) → ModelParts, most recent first
        self._draft_at: tuple | None = None  # (draft, (A, B, F, channel maps)) of the last draft

    def loading(self, phi: np.ndarray):
        return self.vessel.loading(**{n: float(v) for n, v in zip(self.parameter_names, phi, strict=True)})

    def parts(self, phi: np.ndarray) -> ModelParts:
        """ModelParts at loading parameters phi; a fresh shallow copy of the last few (a finite-difference
        gradient over an effect's parameters asks for the same loading again; effects rebind, never mutate)."""
        key = (np.asarray(phi, dtype=float).tobytes(), self.data.wave if self.data is not None else None)
        for k, parts in self._recent:
            if k[0] == key[0] and k[1] is key[1]:
                return copy.copy(parts)
        parts = self.parts_of(self.loading(phi))
        self._recent = [(key, parts), *self._recent[:3]]
        return copy.copy(parts)

    def parts_of(self, loading) -> ModelParts:
        """ModelParts of one loading condition (a Loading of length 1)."""
        from seatune.physics.response import natural_frequencies

        db = self.vessel.db
        lh = load(db, loading)
        i0, i1, w = (float(a[0]) if k == 2 else int(a[0]) for k, a in enumerate(lh.draft_index))
        A, B, F, t = self._at_draft(float(lh.draft[0]), i0, i1, w)
        om = self.omega[:, None, None]
        M, C, Bv = lh.mass_matrix[0], lh.stiffness[0], lh.extra_damping[0]
        H = -(om**2) * (M + A) - 1j * om * (B + Bv) + C

        found = []  # shared by the shallow copies `parts` hands out for this loading

        def roll_mode():
            if not found:
                w_roll = float(natural_frequencies(db, loading, dofs=(3,))[0, 0])
                a44 = (1 - w) * db.added_mass[i0, :, 3, 3] + w * db.added_mass[i1, :, 3, 3]
                found.append((w_roll, float(M[3, 3] + np.interp(w_roll, db.omega, a44))))
            return found[0]

        wave = self.data.wave.view() if self.data is not None else np.zeros((0, om.shape[0], db.wave_direction.size))
        wave.flags.writeable = False  # the data's own sea: sea-side effects rebind, never mutate
        parts = ModelParts(omega=self.omega, impedance=H, force=F, transfer=t, wave=wave,
                           beta=db.wave_direction, draft=float(lh.draft[0]), roll_mode=roll_mode, g=db.g, rho=db.rho)
        for effect, params in self.known:
            effect.apply(parts, params, self)
        return parts

    def _at_draft(self, draft: float, i0: int, i1: int, w: float) -> tuple[np.ndarray, ...]:
        """A(ω), B(ω), F(ω, β) blended between the database drafts i0, i1 and the channel maps t_j(ω) at `draft`,
        read-only; the last draft's are kept (loadings that leave the draft alone share them; effects rebind, never
        mutate)."""
        if self._draft_at is None or self._draft_at[0] != draft:
            arrays = [(1 - w) * x[i0] + w * x[i1] for x in (self._A, self._B, self._F)]
            arrays.append(transfer_vectors(self._channels, self.omega, np.array([draft]), self.vessel.db.g)[0])
            for x in arrays:
                x.flags.writeable = False
            self._draft_at = (draft, tuple(arrays))
        return self._draft_at[1]

    def spectra(self, phi: np.ndarray, effect=None, params: dict | None = None) -> np.ndarray:
        """Expected Welch spectra E[Ŝ_j] at the bins: the model convolved with the segment's spectral window,
        so a resonance narrower than the Welch resolution is compared as Welch sees it: (nw, nc, nf)."""
        parts = self.parts(phi)
        fine = effect.spectra(parts, params or {}, self) if effect is not None else parts.spectra()
        return fine[..., self.data.kernel_index] @ self.data.kernel


def welch_grid(omega_bins: np.ndarray, segment_s: float, refine: int = 4, lobes: int = 3):
    """The fine grid, the indices around each bin and the Hann segment's |W(Δω)|² there (sums to 1)."""
    d = 2 * np.pi / segment_s
    offsets = np.arange(-lobes * refine, lobes * refine + 1) / refine  # in bins
    start = omega_bins[0] - lobes * d
    n = int(round((omega_bins[-1] - omega_bins[0]) / d)) * refine + 2 * lobes * refine + 1
    fine = start + np.arange(n) * d / refine
    centre = np.rint((omega_bins - start) / (d / refine)).astype(int)
    index = centre[:, None] + np.round(offsets * refine).astype(int)[None, :]
    n_seg = 1024
    t = (np.arange(n_seg) + 0.5) / n_seg
    hann = np.sin(np.pi * t) ** 2
    kernel = np.abs(np.exp(-2j * np.pi * np.outer(offsets, t)) @ hann) ** 2
    return fine, index, kernel / kernel.sum()


def analysis_mask(measured: np.ndarray, omega: np.ndarray, omega_lo: float, omega_hi, rel: float = 0.03) -> np.ndarray:
    """Bins analysed: inside [omega_lo, omega_hi] (per channel allowed) and above `rel` × the window-channel's
    peak, where sensor noise and leakage from outside the band stay below a few per cent: (nw, nc, nf)."""
    hi = np.broadcast_to(np.asarray(omega_hi, dtype=float), measured.shape[:2])
    inside = (omega[None, None, :] >= omega_lo) & (omega[None, None, :] <= hi[..., None])
    peak = np.where(inside, measured, 0.0).max(axis=-1, keepdims=True)
    return inside & (measured >= rel * peak) & (peak > 0)


def long_crested_wave(omega: np.ndarray, spectrum: np.ndarray, beta_deg: np.ndarray,
                      grid_rad: np.ndarray) -> np.ndarray:
    """S(ω) travelling at body-relative β per window, split onto the database directions: (nw, nf, nb)."""
    from seatune.diagnosis.effects import _direction_weights

    weights = _direction_weights(np.atleast_1d(beta_deg), np.degrees(grid_rad))  # (nw, nb)
    return np.atleast_2d(spectrum)[:, :, None] * weights[:, None, :]


def effect_channel_raos(vessel, loading, channel_names, omega: np.ndarray | None = None) -> np.ndarray:
    """Channel transfer functions H_j(ω, β) with the vessel YAML's model-side effects, for every condition of
    `loading`: (N, nω, nb, nc), as physics.response.channel_raos; at `omega` (default the database grid) the
    equation of motion is solved at each frequency, so a resonance between database frequencies is resolved."""
    omega = vessel.db.omega if omega is None else np.asarray(omega, dtype=float)
    model = SpectralModel(vessel, (), omega=omega, channels=channel_names)
    out = np.empty((len(loading), omega.size, vessel.db.wave_direction.size, len(channel_names)), complex)
    for n in range(len(loading)):
        out[n] = model.parts_of(loading.take(slice(n, n + 1))).solve()
    return out

"""RAOs, channel spectra and response statistics for a batch of loading conditions (DESIGN §4).

The kernel both tuning backends call: for N loading conditions × nw frequencies it assembles the
impedance H = −ω²(M + A) − iω(B + B_v) + C, solves Hᵀ g_j = t_j once per (condition, ω) for all
channels, and contracts with the sea state's force cross-spectrum
S_FF(ω) = Σ_β F Fᴴ S(ω,β) Δβ, so no loop over directions is needed:
S_j(ω) = g_jᵀ S_FF ḡ_j  (= t_jᵀ H⁻¹ S_FF H⁻ᴴ t̄_j).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from seatune.physics.channels import Channel, transfer_vectors
from seatune.physics.hydro import HydroDatabase
from seatune.physics.loading import LoadedHydro, Loading, load

_MATRICES_PER_CHUNK = 24_000


def trapezoid_weights(x: np.ndarray) -> np.ndarray:
    """Quadrature weights w with Σ w f = trapezoid(f, x)."""
    dx = np.diff(x)
    w = np.zeros_like(x, dtype=float)
    w[:-1] += dx / 2
    w[1:] += dx / 2
    return w


def direction_weight(db: HydroDatabase) -> float:
    """Δβ of the database's equally spaced direction grid over [0, 2π)."""
    return 2 * np.pi / db.wave_direction.shape[0]


def impedance(db: HydroDatabase, lh: LoadedHydro) -> np.ndarray:
    """H(ω) = −ω²(M + A(ω)) − iω(B(ω) + B_v) + C for each condition: (N, nw, 6, 6), Capytaine's H X = F."""
    i0, i1, w = lh.draft_index
    w = w[:, None, None, None]
    A = (1 - w) * db.added_mass[i0] + w * db.added_mass[i1]
    B = (1 - w) * db.radiation_damping[i0] + w * db.radiation_damping[i1]
    om = db.omega[None, :, None, None]
    return (-(om**2) * (lh.mass_matrix[:, None] + A) - 1j * om * (B + lh.extra_damping[:, None])
            + lh.stiffness[:, None])


def excitation(db: HydroDatabase, lh: LoadedHydro) -> np.ndarray:
    """Excitation force per unit wave amplitude at each condition's draft: (N, nw, nb, 6)."""
    i0, i1, w = lh.draft_index
    w = w[:, None, None, None]
    return (1 - w) * db.excitation_force[i0] + w * db.excitation_force[i1]


def motion_raos(db: HydroDatabase, loading: Loading) -> np.ndarray:
    """ξ(ω, β) per unit wave amplitude for every condition: (N, nw, nb, 6) complex."""
    return _motion_raos(db, load(db, loading))


def _motion_raos(db: HydroDatabase, lh: LoadedHydro) -> np.ndarray:
    H = impedance(db, lh)
    F = excitation(db, lh)
    return np.swapaxes(np.linalg.solve(H, np.swapaxes(F, -1, -2)), -1, -2)


def hull_system(db: HydroDatabase, loading: Loading, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """H(ω) = −ω²(M + A) − iω(B + B_v) + C (len(omega), 6, 6) and F(ω, β) (len(omega), nb, 6) of one loading
    condition at arbitrary frequencies: A, B interpolated linearly in ω and F by power and phase
    (physics/interp.py), at the condition's draft."""
    from seatune.physics.interp import interp_axis0

    lh = load(db, loading.take(slice(0, 1)))
    i0, i1, w = (a[0] for a in lh.draft_index)
    A = interp_axis0(db.omega, (1 - w) * db.added_mass[i0] + w * db.added_mass[i1], omega)
    B = interp_axis0(db.omega, (1 - w) * db.radiation_damping[i0] + w * db.radiation_damping[i1], omega)
    F = interp_axis0(db.omega, (1 - w) * db.excitation_force[i0] + w * db.excitation_force[i1], omega)
    om = omega[:, None, None]
    H = -(om**2) * (lh.mass_matrix[0] + A) - 1j * om * (B + lh.extra_damping[0]) + lh.stiffness[0]
    return H, F


def motion_raos_at(db: HydroDatabase, loading: Loading, omega: np.ndarray) -> np.ndarray:
    """ξ(ω, β) of one loading condition at arbitrary frequencies: (len(omega), nb, 6).

    The equation of motion is solved at each frequency (`hull_system`), so resonance peaks between grid
    points are resolved.
    """
    H, F = hull_system(db, loading, omega)
    return np.swapaxes(np.linalg.solve(H, np.swapaxes(F, -1, -2)), -1, -2)


def channel_raos(db: HydroDatabase, loading: Loading, channels: list[Channel]) -> np.ndarray:
    """Channel transfer functions H_j(ω, β): (N, nw, nb, nch) complex."""
    lh = load(db, loading)
    xi = _motion_raos(db, lh)
    t = transfer_vectors(channels, db.omega, lh.draft, db.g)  # (N, nw, 6, nch)
    return np.einsum("nwbd,nwdc->nwbc", xi, t)


@dataclass(frozen=True)
class ForceSpectrum:
    """S_FF per database draft (and the cross terms of neighbouring drafts) for one sea state."""

    diag: np.ndarray  # (nd, nw, 6, 6): Σ_β F_i F_iᴴ S Δβ
    cross: np.ndarray  # (max(nd-1, 0), nw, 6, 6): Σ_β F_i F_{i+1}ᴴ S Δβ

    def at(self, draft_index) -> np.ndarray:
        """S_FF at each condition's draft, F linear in draft: (N, nw, 6, 6)."""
        i0, i1, w = draft_index
        w = w[:, None, None, None]
        out = (1 - w) ** 2 * self.diag[i0] + w**2 * self.diag[i1]
        if self.cross.shape[0]:
            c = self.cross[np.minimum(i0, self.cross.shape[0] - 1)]
            out = out + w * (1 - w) * (c + np.conj(np.swapaxes(c, -1, -2)))
        return out


def force_spectrum(db: HydroDatabase, wave_spectrum: np.ndarray) -> ForceSpectrum:
    """S_FF(ω) = Σ_β F Fᴴ S(ω,β) Δβ for every draft; `wave_spectrum` is S(ω,β) (nw, nb) on the database grid."""
    F = db.excitation_force
    s = wave_spectrum * direction_weight(db)
    diag = np.einsum("dwbi,dwbj,wb->dwij", F, F.conj(), s)
    cross = np.einsum("dwbi,dwbj,wb->dwij", F[:-1], F[1:].conj(), s)
    return ForceSpectrum(diag=diag, cross=cross)


def channel_spectra(db: HydroDatabase, loading: Loading, channels: list[Channel],
                    wave_spectrum: np.ndarray | ForceSpectrum, compiled: bool = True) -> np.ndarray:
    """S_j(ω) [unit²·s/rad] of every channel for every condition in one sea state: (N, nch, nw).

    `compiled=False` forces the plain numpy path (same numbers; slower).
    """
    from seatune.physics import kernels

    sff = wave_spectrum if isinstance(wave_spectrum, ForceSpectrum) else force_spectrum(db, wave_spectrum)
    if not (compiled and kernels.available()):
        return _channel_spectra_numpy(db, loading, channels, sff)
    lh = load(db, loading)
    t0 = transfer_vectors(channels, db.omega, np.zeros(1), db.g)[0]
    dt = transfer_vectors(channels, db.omega, np.ones(1), db.g)[0] - t0
    return kernels.channel_spectra_compiled(
        db.omega, db.added_mass, db.radiation_damping, lh.draft_index, lh.mass_matrix, lh.stiffness,
        lh.extra_damping, t0, dt, lh.draft, sff.diag, sff.cross)


def _channel_spectra_numpy(db: HydroDatabase, loading: Loading, channels: list[Channel],
                           sff: ForceSpectrum) -> np.ndarray:
    n = len(loading)
    out = np.empty((n, len(channels), db.omega.shape[0]))
    step = max(1, _MATRICES_PER_CHUNK // db.omega.shape[0])
    for start in range(0, n, step):
        part = loading.take(slice(start, start + step))
        lh = load(db, part)
        H = impedance(db, lh)
        t = transfer_vectors(channels, db.omega, lh.draft, db.g)
        G = np.linalg.solve(np.swapaxes(H, -1, -2), t)  # Hᵀ g_j = t_j  →  g_jᵀ = t_jᵀ H⁻¹
        S = sff.at(lh.draft_index)
        out[start:start + step] = np.einsum("nwic,nwij,nwjc->ncw", G, S, G.conj()).real
    return out


def spectral_statistics(omega: np.ndarray, spectra: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """σ = √m0 and Tz = 2π√(m0/m2) (thesis eq. 2.10), trapezoidal in ω over the last axis."""
    w = trapezoid_weights(omega)
    m0 = spectra @ w
    m2 = spectra @ (w * omega**2)
    with np.errstate(divide="ignore", invalid="ignore"):
        tz = 2 * np.pi * np.sqrt(m0 / m2)
    return np.sqrt(m0), tz


def channel_statistics(db: HydroDatabase, loading: Loading, channels: list[Channel],
                       wave_spectrum: np.ndarray | ForceSpectrum) -> tuple[np.ndarray, np.ndarray]:
    """σ and Tz of every channel for every condition: two (N, nch) arrays."""
    return spectral_statistics(db.omega, channel_spectra(db, loading, channels, wave_spectrum))


def natural_frequencies(db: HydroDatabase, loading: Loading, dofs=(2, 3, 4)) -> np.ndarray:
    """Coupled ω_n [rad/s], roots of det(C − ω²(M + A(ω))) = 0 (`physics.modes`): (N, len(dofs))."""
    from seatune.physics.modes import natural_frequencies as coupled

    return coupled(db, loading, dofs)

"""Random-phase superposition with randomised frequencies, evaluated blockwise with FFTs.

x_q(t) = Re Σ_i c_iq e^{−iω_i t} for arbitrary (non-commensurate) ω_i, so the record never repeats.
Per block of L samples centred at t_b, ω_i = k_i Δω + δ_i with Δω = 2π/(M dt), M = 2L, |δ_i| ≤ Δω/2:

    e^{−iω_i (t_b + τ)} = e^{−iω_i t_b} e^{−i k_i Δω τ} Σ_p (−iδ_i τ)^p / p!,   |δ_i τ| ≤ π/4,

so each block is P inverse DFTs of length M of the binned coefficients (Taylor series to P = 10 terms:
truncation (π/4)^10/10! < 1e-7 relative). :func:`direct` is the plain cos-sum it must equal (tests).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

P_TERMS = 10


def direct(omega: np.ndarray, coef: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Reference: Re Σ_i c_iq e^{−iω_i t} (T, Q), by brute force."""
    return np.real(np.exp(-1j * np.outer(t, omega)) @ coef)


def synthesize(omega: np.ndarray, coef: np.ndarray, t0: float, dt: float, n: int, block: int = 2048,
               blocks_per_chunk: int = 8) -> np.ndarray:
    """x (n, Q) at t = t0 + dt·(0..n−1) for components ω (N,) with complex coefficients coef (N, Q)."""
    omega = np.asarray(omega, dtype=float)
    coef = np.asarray(coef, dtype=complex)
    if coef.ndim == 1:
        coef = coef[:, None]
    nq = coef.shape[1]
    L = block
    M = 2 * L
    dw = 2 * np.pi / (M * dt)
    k = np.rint(omega / dw).astype(np.int64)
    if k.max(initial=0) >= M:
        raise ValueError("a component frequency is above the block FFT's Nyquist; use a smaller dt or larger block")
    delta = omega - k * dw
    onehot = sp.csr_matrix((np.ones(k.size), (np.arange(k.size), k)), shape=(k.size, M))
    p = np.arange(P_TERMS)
    fact = np.array([math.factorial(int(i)) for i in p], dtype=float)
    dpow = (-1j * delta[None, :]) ** p[:, None] / fact[:, None]  # (P, N)
    cd = dpow[:, None, :] * coef.T[None, :, :]  # (P, Q, N)
    tau = (np.arange(L) - L / 2) * dt  # block-local time, centred
    taup = tau[None, :] ** p[:, None]  # (P, L)
    # e^{−i k Δω τ} with τ = (m − L/2) dt: shift the bins by e^{+i k Δω (L/2) dt}, then a forward FFT over k
    shift = np.exp(1j * np.arange(M) * dw * (L / 2) * dt)
    nblocks = -(-n // L)
    out = np.empty((nblocks * L, nq))
    for c0 in range(0, nblocks, blocks_per_chunk):
        cb = np.arange(c0, min(nblocks, c0 + blocks_per_chunk))
        tb = t0 + (cb * L + L / 2) * dt  # block centres
        e = np.exp(-1j * np.outer(tb, omega))  # (nb, N)
        # G[b, p, q, i] = coef[i, q] e[b, i] dpow[p, i]  → bins over i
        g = e[:, None, None, :] * cd[None]  # (nb, P, Q, N)
        nb = cb.size
        binned = (onehot.T @ g.reshape(-1, omega.size).T).T.reshape(nb, P_TERMS, nq, M)
        spec = np.fft.fft(binned * shift, axis=-1)[..., :L]  # Σ_k X_k e^{−2πi k m / M}
        x = np.einsum("bpqm,pm->bmq", spec.real, taup)  # Re(Σ_p spec_p τ^p), τ^p real
        out[cb[0] * L:(cb[-1] + 1) * L] = x.reshape(nb * L, nq)
    return out[:n]

"""Compiled kernel for channel spectra over many loading conditions × frequencies (numba).

The numpy path (`response._channel_spectra_numpy`) spends most of its time in per-matrix LAPACK
calls for 6×6 systems; this kernel fuses assembly, LU with partial pivoting (as LAPACK getrf), the
solve Hᵀ g_j = t_j and the quadratic form g_jᵀ S_FF ḡ_j per (condition, ω), parallel over conditions.
It computes exactly what the numpy path computes; tests hold the two together.
"""

from __future__ import annotations

import numpy as np

try:
    import numba
except ImportError:  # pragma: no cover - numba is a dependency; the numpy path remains correct without it
    numba = None


def _kernel(omega, added_mass, damping, i0, i1, w, M, C, Bv, t0, dt, draft, sdiag, scross, out):
    n_cond, nch, nw = out.shape
    has_cross = scross.shape[0] > 0
    for c in numba.prange(n_cond):
        K = np.empty((6, 6), dtype=np.complex128)
        rhs = np.empty((6, nch), dtype=np.complex128)
        S = np.empty((6, 6), dtype=np.complex128)
        a, b, wc = i0[c], i1[c], w[c]
        ic = min(a, scross.shape[0] - 1) if has_cross else 0
        for k in range(nw):
            om = omega[k]
            for i in range(6):
                for j in range(6):
                    am = (1.0 - wc) * added_mass[a, k, i, j] + wc * added_mass[b, k, i, j]
                    bd = (1.0 - wc) * damping[a, k, i, j] + wc * damping[b, k, i, j]
                    # K = Hᵀ with H = −ω²(M + A) − iω(B + B_v) + C (Capytaine's H X = F)
                    K[j, i] = complex(-om * om * (M[c, i, j] + am) + C[c, i, j], -om * (bd + Bv[c, i, j]))
                    s = (1.0 - wc) ** 2 * sdiag[a, k, i, j] + wc * wc * sdiag[b, k, i, j]
                    if has_cross:
                        s += wc * (1.0 - wc) * (scross[ic, k, i, j] + np.conj(scross[ic, k, j, i]))
                    S[i, j] = s
            for i in range(6):
                for q in range(nch):
                    rhs[i, q] = t0[k, i, q] + draft[c] * dt[k, i, q]
            # Gaussian elimination with partial pivoting on [K | rhs]
            for j in range(6):
                p = j
                best = abs(K[j, j])
                for r in range(j + 1, 6):
                    v = abs(K[r, j])
                    if v > best:
                        best, p = v, r
                if p != j:
                    for col in range(6):
                        K[j, col], K[p, col] = K[p, col], K[j, col]
                    for q in range(nch):
                        rhs[j, q], rhs[p, q] = rhs[p, q], rhs[j, q]
                inv = 1.0 / K[j, j]
                for r in range(j + 1, 6):
                    f = K[r, j] * inv
                    if f != 0:
                        for col in range(j + 1, 6):
                            K[r, col] -= f * K[j, col]
                        for q in range(nch):
                            rhs[r, q] -= f * rhs[j, q]
            for j in range(5, -1, -1):
                inv = 1.0 / K[j, j]
                for q in range(nch):
                    acc = rhs[j, q]
                    for col in range(j + 1, 6):
                        acc -= K[j, col] * rhs[col, q]
                    rhs[j, q] = acc * inv
            for q in range(nch):
                total = 0.0
                for i in range(6):
                    gi = rhs[i, q]
                    row = 0.0 + 0.0j
                    for j in range(6):
                        row += S[i, j] * np.conj(rhs[j, q])
                    total += (gi * row).real
                out[c, q, k] = total


if numba is not None:
    _compiled = numba.njit(parallel=True, cache=True)(_kernel)
else:  # pragma: no cover
    _compiled = None


def available() -> bool:
    return _compiled is not None


def channel_spectra_compiled(omega, added_mass, damping, draft_index, M, C, Bv, t0, dt, draft, sdiag, scross):
    """S_j(ω) for every condition: (N, nch, nw). Transfer vectors are affine in draft: t = t0 + draft·dt."""
    i0, i1, w = draft_index
    n = M.shape[0]
    out = np.empty((n, t0.shape[-1], omega.shape[0]))
    if scross.shape[0] == 0:
        scross = np.zeros((0,) + sdiag.shape[1:], dtype=np.complex128)
    _compiled(np.ascontiguousarray(omega, dtype=np.float64), added_mass, damping,
              np.ascontiguousarray(i0, dtype=np.int64), np.ascontiguousarray(i1, dtype=np.int64),
              np.ascontiguousarray(w, dtype=np.float64), M, C, Bv,
              np.ascontiguousarray(t0, dtype=np.complex128), np.ascontiguousarray(dt, dtype=np.complex128),
              np.ascontiguousarray(draft, dtype=np.float64), sdiag, scross, out)
    return out

"""Adaptive lowpass cutoff (A3): one-FFT cumulative spectrum against filtering at every candidate.

Reference: A3 Algorithm 1 done literally for all 83 candidate cutoffs of the (reconstructed) §5.1 grid —
rfft, zero bins above the cutoff, irfft, ``np.std(ddof=1)``, count zero up-crossings
(:func:`seatune.physics.adaptive_filter.adaptive_cutoff_reference`). seatune: one rfft, cumulative sums
of the periodogram and of its lag-one cosine moment (:func:`~seatune.physics.adaptive_filter.adaptive_cutoff`).
Record: 30 min at 10 Hz of a JONSWAP heave response (Hs 2.5 m, Tp 9 s, A3 eq. 8) with white noise at
SNR 10 (A3 eqs. 6–7). Each timing is the best of several runs in this process.
"""

from __future__ import annotations

import numpy as np

from benchmarks.timing import best_of

FS = 10.0
DURATION = 1800.0


def _record(seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = int(DURATION * FS)
    m = 4 * n  # components on a 4× finer grid than the record's bins (off-bin, as in A3)
    omega = 2 * np.pi * np.fft.rfftfreq(m, 1 / FS)
    om = np.where(omega > 0, omega, np.inf)
    hs, tp = 2.5, 9.0
    wp = 2 * np.pi / tp
    gamma = np.exp(5.75 - 1.15 * tp / np.sqrt(hs))
    sig = np.where(om <= wp, 0.07, 0.09)
    s_wave = ((1 - 0.287 * np.log(gamma)) * 5 / 16 * hs**2 * wp**4 * om**-5 * np.exp(-1.25 * (om / wp) ** -4)
              * gamma ** np.exp(-0.5 * ((om - wp) / (sig * wp)) ** 2))
    rao = np.exp(-5.1 * omega**2 / 9.81) / (1 - (omega / 0.78) ** 2 + 0.3j * omega / 0.78)
    amp = np.sqrt(2 * np.abs(rao) ** 2 * s_wave * (omega[1] - omega[0]))
    x = np.fft.irfft(amp * np.exp(1j * rng.uniform(0, 2 * np.pi, omega.size)) * m / 2, n=m)[:n]
    return x + rng.normal(0, np.std(x, ddof=1) / np.sqrt(10.0), n)


def run() -> dict:
    from seatune.physics.adaptive_filter import A3_VALIDATION_GRID_HZ, adaptive_cutoff, adaptive_cutoff_reference

    x = _record()
    adaptive_cutoff(x, FS)  # warm-up (FFT plan caches)
    seatune_s, fast = best_of(lambda: adaptive_cutoff(x, FS), 30)
    reference_s, ref = best_of(lambda: adaptive_cutoff_reference(x, FS), 3)
    rel = np.abs(fast.sigma_curve / ref.sigma_curve - 1.0)
    n_up = DURATION / ref.tz_curve
    tz_dev = np.abs(fast.tz_curve / ref.tz_curve - 1.0) * np.sqrt(n_up)
    return {
        "name": "adaptive_cutoff_83_candidates_30min_10hz",
        "reference_s": round(reference_s, 4),
        "seatune_s": round(seatune_s, 5),
        "ratio": round(reference_s / seatune_s, 1),
        "max_rel_diff": float(rel.max()),
        "candidates": int(A3_VALIDATION_GRID_HZ.size),
        "samples": int(x.size),
        "tz_max_dev_in_counting_sigmas": round(float(np.nanmax(tz_dev)), 2),
        "cutoff_hz": fast.cutoff_hz,
        "cutoff_hz_reference": ref.cutoff_hz,
        "reference": "A3 Algorithm 1 per candidate: rfft/zero/irfft, np.std(ddof=1), counted up-crossings",
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run()))

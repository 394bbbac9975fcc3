"""Interpolation of complex transfer functions by power and phase.

Linear interpolation of complex values between two points whose phases differ by Δφ shrinks the
magnitude by cos(Δφ/2) at the midpoint; interpolating |X|² linearly and the phase along the short arc
keeps the power, so spectra built from interpolated RAOs stay unbiased.
"""

from __future__ import annotations

import numpy as np


def blend(a: np.ndarray, b: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Complex value a fraction f from a to b: |X|² linear in f, phase along the shorter arc."""
    power = (1 - f) * np.abs(a) ** 2 + f * np.abs(b) ** 2
    dphi = np.angle(b * np.conj(a))  # wrapped to (−π, π]
    phase = np.angle(a) + f * dphi
    return np.sqrt(power) * np.exp(1j * phase)


def interp_axis0(grid: np.ndarray, values: np.ndarray, x: np.ndarray, complex_blend: bool = True) -> np.ndarray:
    """values (n, ...) sampled on increasing `grid` → (len(x), ...) at x; held constant beyond the ends."""
    j = np.clip(np.searchsorted(grid, x) - 1, 0, grid.size - 2)
    f = np.clip((x - grid[j]) / (grid[j + 1] - grid[j]), 0.0, 1.0)
    f = f.reshape(f.shape + (1,) * (values.ndim - 1))
    if complex_blend and np.iscomplexobj(values):
        return blend(values[j], values[j + 1], f)
    return (1 - f) * values[j] + f * values[j + 1]

"""Shared timing helper of the benchmarks."""

import time

import numpy as np


def best_of(fn, repeats: int) -> tuple[float, object]:
    """Shortest wall time of `repeats` calls (the least disturbed by other load) and the last result."""
    best, out = np.inf, None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out

"""Coupled natural modes of 10,000 loading conditions of the sample vessel (physics.modes.coupled_modes).

Reference: the per-condition loop a user would write with scipy, each mode by brentq on det(C − ω²(M + A(ω)))/ω⁶ of
the full 6×6 problem (A interpolated linearly in ω), bracketed around the uncoupled value; timed on a subset and
scaled linearly (a per-condition loop), compared on that subset. The former uncoupled fixed point (seatune ≤ this
change) is timed beside it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.timing import best_of

ROOT = Path(__file__).resolve().parents[1]
N_CONDITIONS = 10_000
N_REFERENCE = 30


def _reference(db, loading) -> np.ndarray:
    from scipy.optimize import brentq

    from seatune.physics.loading import load

    lh = load(db, loading)
    out = np.empty((len(loading), 3))
    for n in range(len(loading)):
        i0, i1, w = (a[n] for a in lh.draft_index)
        a = (1 - w) * db.added_mass[i0] + w * db.added_mass[i1]
        m, c = lh.mass_matrix[n], lh.stiffness[n]

        def det(om, m=m, c=c, a=a):
            j = np.clip(np.searchsorted(db.omega, om) - 1, 0, db.omega.size - 2)
            f = np.clip((om - db.omega[j]) / (db.omega[j + 1] - db.omega[j]), 0, 1)
            return np.linalg.det(c - om**2 * (m + (1 - f) * a[j] + f * a[j + 1])) / om**6

        grid = np.linspace(0.3, 1.5, 241)
        d = np.array([det(om) for om in grid])
        roots = [brentq(det, grid[k], grid[k + 1], xtol=1e-12) for k in np.flatnonzero(np.diff(np.sign(d)))]
        out[n] = sorted(roots)[:3] if len(roots) >= 3 else np.nan
    return out


def _uncoupled(db, loading, dofs=(2, 3, 4), iterations=100):
    """The uncoupled fixed point ω = √(C_dd / (M_dd + A_dd(ω))) that seatune used before the coupled modes."""
    from seatune.physics.loading import load

    lh = load(db, loading)
    i0, i1, w = lh.draft_index
    out = np.empty((len(loading), len(dofs)))
    for k, d in enumerate(dofs):
        a = (1 - w[:, None]) * db.added_mass[i0, :, d, d] + w[:, None] * db.added_mass[i1, :, d, d]
        m, c = lh.mass_matrix[:, d, d], lh.stiffness[:, d, d]
        om = np.sqrt(c / (m + a[:, -1]))
        for _ in range(iterations):
            j = np.clip(np.searchsorted(db.omega, om) - 1, 0, db.omega.size - 2)
            f = np.clip((om - db.omega[j]) / (db.omega[j + 1] - db.omega[j]), 0, 1)
            rows = np.arange(om.size)
            new = np.sqrt(c / (m + (1 - f) * a[rows, j] + f * a[rows, j + 1]))
            done = np.allclose(new, om, rtol=1e-12, atol=0)
            om = new
            if done:
                break
        out[:, k] = om
    return out


def run() -> dict:
    from seatune.physics.modes import coupled_modes
    from seatune.pipeline.vessel import open_vessel

    model = open_vessel(ROOT / "configs/vessels/sample_osv.yaml")
    rng = np.random.default_rng(7)
    values = {name: rng.uniform(*p.bounds, N_CONDITIONS) for name, p in model.spec.priors.items()
              if name in ("mass", "zcg", "r44", "r55", "gmt_fs")}
    loading = model.loading(**values)
    t_seatune, modes = best_of(lambda: coupled_modes(model.db, loading), 3)
    sub = loading.take(slice(0, N_REFERENCE))
    t_ref, ref = best_of(lambda: _reference(model.db, sub), 1)
    t_unc, unc = best_of(lambda: _uncoupled(model.db, loading), 3)
    ours = np.sort(modes.omega[:N_REFERENCE], axis=1)
    ok = np.all(np.isfinite(ref), axis=1)
    return {"name": "modes", "conditions": N_CONDITIONS,
            "reference": "scipy brentq on det(C − ω²(M + A(ω))) per condition (scaled from a subset)",
            "reference_s": t_ref * N_CONDITIONS / N_REFERENCE, "seatune_s": t_seatune,
            "ratio": t_ref * N_CONDITIONS / N_REFERENCE / t_seatune,
            "max_rel_diff": float(np.max(np.abs(ours[ok] / ref[ok] - 1))),
            "uncoupled_fixed_point_s": t_unc,
            "max_uncoupled_vs_coupled_roll": float(np.nanmax(np.abs(unc[:, 1] / modes.omega[:, 1] - 1)))}

"""Channel σ for 10,000 loading conditions × 9 channels × 60 ω × 24 directions in one sea state.

Reference path, per condition: Capytaine's `post_pro.rao` on the condition's dataset (coefficients
interpolated in draft with xarray), channel RAOs, then the direct sum Σ_β |H_j|² S(ω,β) Δβ and the
trapezoid in ω. It is timed on a subset of conditions and scaled linearly to the full batch (it is a
per-condition loop, so its time is proportional to the count); the numbers are compared on that subset.
"""

from __future__ import annotations

import time
import tracemalloc
from pathlib import Path

import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]
N_CONDITIONS = 10_000
N_REFERENCE = 100
HEAVE_CHANNELS = [f"heave_{k}_{p}" for k in ("disp", "vel", "acc") for p in "ABC"]


def _conditions(model, n, seed=3):
    rng = np.random.default_rng(seed)
    pri = model.spec.priors
    values = {}
    for name, p in pri.items():
        lo, hi = p.bounds
        values[name] = rng.uniform(lo, hi, n)
    return model.loading(**values)


def _reference(model, ds, loading, channels, S):
    import capytaine as cpt

    from seatune.physics.channels import transfer_vectors
    from seatune.physics.hydro import DOFS
    from seatune.physics.loading import load

    db = model.db
    dofs = list(DOFS)
    coords = {"influenced_dof": dofs, "radiating_dof": dofs}
    dims = ("influenced_dof", "radiating_dof")
    lh = load(db, loading)
    t = transfer_vectors(channels, db.omega, lh.draft, db.g)
    dbeta = 2 * np.pi / db.wave_direction.size
    out = np.empty((len(loading), len(channels)))
    for n in range(len(loading)):
        sub = ds.interp(draft=float(lh.draft[n]))
        case = xr.Dataset({
            "added_mass": sub["added_mass"], "radiation_damping": sub["radiation_damping"],
            "excitation_force": sub["excitation_force"],
            "inertia_matrix": xr.DataArray(lh.mass_matrix[n], dims=dims, coords=coords),
            "hydrostatic_stiffness": xr.DataArray(lh.stiffness[n], dims=dims, coords=coords),
        })
        diss = xr.DataArray(lh.extra_damping[n], dims=dims, coords=coords)
        xi = cpt.post_pro.rao(case, dissipation=diss).transpose("omega", "wave_direction", "radiating_dof")
        h = np.einsum("wbd,wdc->wbc", xi.sel(radiating_dof=dofs).values, t[n])
        m0 = np.trapezoid(np.sum(np.abs(h) ** 2 * S[:, :, None] * dbeta, axis=1), db.omega, axis=0)
        out[n] = np.sqrt(m0)
    return out


def run() -> dict:
    from capytaine.io.xarray import merge_complex_values

    from seatune.physics.response import channel_statistics, force_spectrum
    from seatune.physics.spectra import SpectrumPartition, directional_spectrum
    from seatune.pipeline.vessel import open_vessel

    model = open_vessel(ROOT / "configs/vessels/sample_osv.yaml")
    db = model.db
    channels = [model.channel(c) for c in HEAVE_CHANNELS]
    loading = _conditions(model, N_CONDITIONS)
    sea = [SpectrumPartition(hs=2.5, tp=9.0, dir_from_deg=200.0, gamma=3.3, spreading="cos2s", spreading_param=6)]
    S = directional_spectrum(db.omega, db.wave_direction, sea, heading_deg=75.0)

    start = time.perf_counter()
    channel_statistics(db, loading.take(slice(0, 2)), channels, S)  # JIT compile (cached on disk after)
    warmup_s = time.perf_counter() - start

    tracemalloc.start()
    start = time.perf_counter()
    sigma, _ = channel_statistics(db, loading, channels, force_spectrum(db, S))
    seatune_s = time.perf_counter() - start
    peak_mb = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()

    with xr.open_dataset(ROOT / "configs/vessels/sample_osv_hydro.nc", engine="netcdf4") as raw:
        ds = merge_complex_values(raw.load())
    start = time.perf_counter()
    ref = _reference(model, ds, loading.take(slice(0, N_REFERENCE)), channels, S)
    reference_s = (time.perf_counter() - start) * N_CONDITIONS / N_REFERENCE
    rel = np.abs(sigma[:N_REFERENCE] - ref) / np.abs(ref)
    return {
        "name": "channel_sigma_10000x9x60x24",
        "reference_s": round(reference_s, 3),
        "seatune_s": round(seatune_s, 4),
        "ratio": round(reference_s / seatune_s, 1),
        "max_rel_diff": float(rel.max()),
        "seatune_peak_mb": round(peak_mb, 1),
        "jit_warmup_s": round(warmup_s, 2),
        "reference": f"capytaine post_pro.rao + direct sum, timed on {N_REFERENCE} conditions, "
                     f"scaled to {N_CONDITIONS}",
    }

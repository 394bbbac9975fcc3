"""`seatune filter`: the adaptive lowpass cutoff (Han A3), σ and Tz per accepted window and channel, and
each window's Welch spectra for the identification stage."""

from __future__ import annotations

import numpy as np
import pandas as pd

STATS_UNITS = {"window_id": "", "channel": "", "kind": "", "cutoff_hz": "Hz", "sigma": "channel unit",
               "tz": "s", "snr": "", "clamped": "", "n_samples": ""}
SPECTRA_UNITS = {"window_id": "", "channel": "", "omega": "rad/s", "S": "channel unit^2 s/rad", "dof": ""}
def window_statistics(x: np.ndarray, fs: float, settings) -> dict:
    """Statistics of the measured signal itself (`kind="displacement"`: no derivative is taken)."""
    from seatune.physics.adaptive_filter import adaptive_cutoff

    res = adaptive_cutoff(x, fs, theta_max=settings.theta_max, gamma_max=settings.gamma_max,
                          f_min=settings.f_min_hz, f_max=settings.f_max_hz, highpass_hz=settings.highpass_hz,
                          kind="displacement")
    return {"cutoff_hz": res.cutoff_hz, "sigma": res.sigma, "tz": res.tz, "snr": float(res.snr_estimate),
            "clamped": bool(res.clamped), "n_samples": int(x.size)}


def filter_stage(run, model, echo=print, force: bool = False) -> dict:
    from seatune.io.parquet import write_table
    from seatune.io.rundir import fingerprint, is_fresh
    from seatune.physics.adaptive_filter import welch_spectrum

    src = [run.artefact("motions.parquet"), run.artefact("windows.parquet")]
    settings = run.spec.filter
    fp = fingerprint(src, {"filter": settings.model_dump(), "rate": run.spec.ingest.rate_hz})
    out_s, out_p = run.artefact("window_stats.parquet"), run.artefact("window_spectra.parquet")
    if not force and is_fresh([out_s, out_p], fp):
        return {"skipped": True}
    motions, windows = pd.read_parquet(src[0]), pd.read_parquet(src[1])
    fs = run.spec.ingest.rate_hz
    kinds = {c.name: c.kind for c in model.channels}
    names = settings.channels or [c for c in kinds if c in motions.columns]
    stats, spectra = [], []
    for w in windows[windows["accepted"]].itertuples():
        part = motions[(motions["time"] >= w.start) & (motions["time"] <= w.end)]
        for name in names:
            x = part[name].to_numpy()
            if np.isnan(x).any():
                x = pd.Series(x).interpolate(limit_direction="both").to_numpy()
            row = window_statistics(x, fs, settings)
            stats.append({"window_id": int(w.window_id), "channel": name, "kind": kinds[name], **row})
            omega, S, dof = welch_spectrum(x, fs, segment_s=settings.welch_segment_s)
            spectra.append(pd.DataFrame({"window_id": int(w.window_id), "channel": name, "omega": omega, "S": S,
                                         "dof": dof}))
    stats = pd.DataFrame(stats, columns=list(STATS_UNITS))
    spectra = pd.concat(spectra, ignore_index=True) if spectra else pd.DataFrame(columns=list(SPECTRA_UNITS))
    write_table(stats, out_s, STATS_UNITS, {"fingerprint": fp})
    write_table(spectra, out_p, SPECTRA_UNITS, {"fingerprint": fp})
    return {"skipped": False, "windows": int(windows["accepted"].sum()), "channels": len(names),
            "median_cutoff_hz": float(stats["cutoff_hz"].median()) if len(stats) else float("nan")}

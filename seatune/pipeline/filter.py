"""`seatune filter`: the adaptive lowpass cutoff (Han A3), σ and Tz per accepted window and channel, and
each window's Welch spectra for the identification stage."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seatune.errors import UserError

STATS_UNITS = {"window_id": "", "channel": "", "kind": "", "cutoff_hz": "Hz",
               "sigma": "per row; the unit of the row's channel", "tz": "s", "snr": "dimensionless", "clamped": "",
               "n_samples": ""}
SPECTRA_UNITS = {"window_id": "", "channel": "", "omega": "rad/s",
                 "S": "per row; (unit of the row's channel)^2 s/rad, one-sided in rad/s",
                 "dof": "dimensionless; degrees of freedom of the Welch estimate"}
SPECTRA_HZ_UNITS = {"window_id": "", "channel": "", "freq": "Hz",
                    "S": "per row; (unit of the row's channel)^2/Hz, one-sided in Hz",
                    "dof": "dimensionless; degrees of freedom of the Welch estimate"}


def spectrum_per_hz(omega: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One-sided S(ω) [u²·s/rad] → (f [Hz], S(f) [u²/Hz]): f = ω/2π, S(f) = 2π S(ω), so ∫S df = ∫S dω."""
    return np.asarray(omega) / (2 * np.pi), 2 * np.pi * np.asarray(S)

def window_statistics(x: np.ndarray, fs: float, settings) -> dict:
    """Statistics of the measured signal itself (`kind="displacement"`: no derivative is taken)."""
    from seatune.physics.adaptive_filter import adaptive_cutoff

    res = adaptive_cutoff(x, fs, theta_max=settings.theta_max, gamma_max=settings.gamma_max,
                          f_min=settings.f_min_hz, f_max=settings.f_max_hz, highpass_hz=settings.highpass_hz,
                          kind="displacement")
    return {"cutoff_hz": res.cutoff_hz, "sigma": res.sigma, "tz": res.tz, "snr": float(res.snr_estimate),
            "clamped": bool(res.clamped), "n_samples": int(x.size)}


def filter_stage(run, model, echo=print, force: bool = False) -> dict:
    from seatune.io.motion_table import MotionTable
    from seatune.io.parquet import write_table
    from seatune.io.rundir import fingerprint, is_fresh
    from seatune.physics.adaptive_filter import welch_spectrum

    src = [run.artefact("motions.parquet"), run.artefact("windows.parquet")]
    settings = run.spec.filter
    per_hz = run.spec.output.spectrum_frequency == "Hz"
    fp = fingerprint(src, {"filter": settings.model_dump(), "rate": run.spec.ingest.rate_hz,
                           **({"spectrum_frequency": "Hz"} if per_hz else {})})
    out_s, out_p = run.artefact("window_stats.parquet"), run.artefact("window_spectra.parquet")
    out_hz = run.artefact("window_spectra_hz.parquet")
    if not force and is_fresh([out_s, out_p, *([out_hz] if per_hz else [])], fp):
        return {"skipped": True}
    motions, windows = MotionTable(src[0]), pd.read_parquet(src[1])
    fs = run.spec.ingest.rate_hz
    kinds = {c.name: c.kind for c in model.channels}
    names = settings.channels or [c for c in kinds if c in motions.columns]
    missing = [n for n in names if n not in motions.columns or n not in kinds]
    if missing:
        raise UserError(str(run.path), "filter.channels", f"{missing} not among the motion table's channels "
                                                          f"({[c for c in kinds if c in motions.columns]})")
    stats, spectra, empty = [], [], []
    for w in windows[windows["accepted"]].itertuples():
        part = motions.window(w.start, w.end, names)
        if int(round(settings.welch_segment_s * fs)) > len(part):  # welch_spectrum's own condition
            raise UserError(str(run.path), "filter.welch_segment_s", f"too little data: window {w.window_id} has "
                            f"{len(part) / fs:.0f} s of samples, less than one Welch segment of "
                            f"{settings.welch_segment_s:g} s (shorten it, or raise windows.min_duration_s)")
        for name in names:
            x = part[name].to_numpy(dtype=np.float64)
            if not np.isfinite(x).any():  # a masked or dead channel in this window: nothing to measure
                empty.append(f"{w.window_id}/{name}")
                continue
            if not np.isfinite(x).all():
                x = pd.Series(np.where(np.isfinite(x), x, np.nan)).interpolate(limit_direction="both").to_numpy()
            row = window_statistics(x, fs, settings)
            stats.append({"window_id": int(w.window_id), "channel": name, "kind": kinds[name], **row})
            omega, S, dof = welch_spectrum(x, fs, segment_s=settings.welch_segment_s)
            spectra.append(pd.DataFrame({"window_id": int(w.window_id), "channel": name, "omega": omega, "S": S,
                                         "dof": dof}))
    if empty:
        if not stats:
            raise UserError(str(src[0]), None, f"too little data: no finite sample of {names} in any accepted window")
        echo(f"warning: {len(empty)} window/channel pair(s) without a finite sample left out: "
             + ", ".join(empty[:10]) + (", …" if len(empty) > 10 else ""))
    stats = pd.DataFrame(stats, columns=list(STATS_UNITS))
    spectra = pd.concat(spectra, ignore_index=True) if spectra else pd.DataFrame(columns=list(SPECTRA_UNITS))
    write_table(stats, out_s, STATS_UNITS, {"fingerprint": fp})
    write_table(spectra, out_p, SPECTRA_UNITS, {"fingerprint": fp})
    if per_hz:
        freq, S_f = spectrum_per_hz(spectra["omega"].to_numpy(dtype=float), spectra["S"].to_numpy(dtype=float))
        hz = spectra.drop(columns="omega").assign(freq=freq, S=S_f)[list(SPECTRA_HZ_UNITS)]
        write_table(hz, out_hz, SPECTRA_HZ_UNITS, {"fingerprint": fp})
    return {"skipped": False, "windows": int(windows["accepted"].sum()), "channels": len(names),
            "median_cutoff_hz": float(stats["cutoff_hz"].median()) if len(stats) else float("nan")}

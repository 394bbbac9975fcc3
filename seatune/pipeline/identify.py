"""`seatune identify`: RAOs and natural frequencies from measured response spectra and the hindcast's wave
spectrum (de Jong ch. 5–6; Han A7's energetic band), independent of any tuning.

Per accepted window: the wave spectrum at the window (the hindcast's 2-D spectrum when it has one,
otherwise JONSWAP + cos-2s from the bulk parameters), the effective RAO |H_eff(ω)| = √(S_xx/S_ζζ) of every
channel in the energetic band with its χ² interval, the prior model's effective RAO in the same
directional sea for comparison, and quality flags. Roll's natural frequency comes from the RAO peak near
the prior model's value refined by a single-degree-of-freedom fit, combined over windows.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

RAO_UNITS = {"window_id": "", "channel": "", "omega": "rad/s", "rao_amp": "channel unit/m", "ci_low": "channel unit/m",
             "ci_high": "channel unit/m", "model_prior": "channel unit/m", "low_confidence": "", "heading_deg": "deg",
             "hs": "m", "wave_source": ""}
NF_UNITS = {"dof": "", "method": "", "window_id": "", "omega_n": "rad/s", "ci_low": "rad/s", "ci_high": "rad/s",
            "zeta": "", "model_prior": "rad/s", "derived": "", "derived_value": "", "derived_std": ""}


def window_wave_spectrum(hc, row, lat: float, lon: float, omega: np.ndarray):
    """S(ω, D) [m²·s/rad²] on `omega` × the source's coming-from directions D [deg], and its source name."""
    from seatune.io.hindcast_readers import spectrum_at

    mid = row.start + (row.end - row.start) / 2
    spec = spectrum_at(hc, mid.tz_convert("UTC").tz_localize(None), lat, lon) if hc.spectra is not None else None
    if spec is not None:
        freq = spec["freq"].values
        dirs = spec["dir"].values
        efth = spec.transpose("freq", "dir").values  # m²/(Hz·deg)
        per_rad = np.stack([np.interp(omega / (2 * np.pi), freq, efth[:, k], left=0, right=0)
                            for k in range(dirs.size)], axis=1)
        return per_rad * (180.0 / np.pi) / (2 * np.pi), dirs, "hindcast 2-D spectrum"
    from seatune.physics.spectra import SpectrumPartition, discrete_spreading

    dirs = np.arange(24) * 15.0
    part = SpectrumPartition(hs=row.hs, tp=row.tp, dir_from_deg=row.dir_from_deg)
    spread = discrete_spreading(np.radians(dirs), np.radians(row.dir_from_deg), "cos2s", 4.0)
    return part.spectrum(omega)[:, None] * spread[None, :], dirs, "JONSWAP + cos-2s from bulk"


def effective_model_rao(model, loading, channel_names, omega, dirs_from, S2d, heading_deg) -> np.ndarray:
    """√(Σ_D |H(ω, β_D)|² W(ω, D)) of the model: what √(S_xx/S_ζζ) estimates in that directional sea."""
    from seatune.physics.interp import interp_axis0
    from seatune.physics.response import channel_raos

    db = model.db
    chans = [model.channel(c) for c in channel_names]
    power = np.abs(channel_raos(db, loading, chans)[0]) ** 2  # (nw, nb, nch)
    power = interp_axis0(db.omega, power, omega, complex_blend=False)  # (n, nb, nch)
    beta = np.mod(heading_deg - dirs_from - 180.0, 360.0)  # per source direction
    grid = np.degrees(db.wave_direction)
    ext = np.r_[grid, 360.0]
    idx = np.clip(np.searchsorted(ext, beta, side="right") - 1, 0, grid.size - 1)
    f = (beta - ext[idx]) / (ext[idx + 1] - ext[idx])
    p = (1 - f)[None, :, None] * power[:, idx, :] + f[None, :, None] * power[:, (idx + 1) % grid.size, :]
    weights = S2d / np.maximum(S2d.sum(axis=1, keepdims=True), 1e-300)
    return np.sqrt(np.einsum("wdc,wd->cw", p, weights))


def identify_window(model, prior, row, wave, dirs, source, spectra: pd.DataFrame) -> list[pd.DataFrame]:
    from seatune.physics.rao_estimation import rao_long_crested

    out = []
    names = list(spectra["channel"].unique())
    omega = spectra[spectra["channel"] == names[0]]["omega"].to_numpy()
    s_wave = wave.sum(axis=1) * np.radians(np.diff(np.r_[dirs, dirs[0] + 360.0]).mean())
    h_model = effective_model_rao(model, prior, names, omega, dirs, wave, row.heading_deg)
    for j, name in enumerate(names):
        part = spectra[spectra["channel"] == name]
        est = rao_long_crested(omega, part["S"].to_numpy(), float(part["dof"].iloc[0]), s_wave)
        out.append(pd.DataFrame({
            "window_id": int(row.window_id), "channel": name, "omega": omega, "rao_amp": est.amplitude,
            "ci_low": est.low, "ci_high": est.high, "model_prior": h_model[j],
            "low_confidence": bool(est.low_confidence), "heading_deg": row.heading_deg, "hs": row.hs,
            "wave_source": source,
        }))
    return out


def roll_natural_frequency(raos: pd.DataFrame, prior_omega: float, channel: str = "roll") -> list[dict]:
    """RAO peak near the prior (±30 %), refined by an SDOF fit with its CI (de Jong ch. 6), per window and
    combined by inverse variance."""
    from seatune.physics.natural_frequency import fit_sdof, peak_in_range

    rows = []
    for wid, part in raos[raos["channel"] == channel].groupby("window_id"):
        ok = np.isfinite(part["rao_amp"].to_numpy())
        if ok.sum() < 5:
            continue
        om, amp = part["omega"].to_numpy()[ok], part["rao_amp"].to_numpy()[ok]
        peak, k = peak_in_range(om, amp, prior_omega)
        if k < 0:
            continue
        try:
            fit = fit_sdof(om, amp, part["ci_low"].to_numpy()[ok], part["ci_high"].to_numpy()[ok], omega_guess=peak)
        except (ValueError, RuntimeError):
            continue
        rows.append({"dof": "Roll", "method": "rao_peak_sdof", "window_id": str(wid), "omega_n": fit.omega_n,
                     "ci_low": fit.omega_n_ci[0], "ci_high": fit.omega_n_ci[1], "zeta": fit.zeta,
                     "model_prior": prior_omega})
    if rows:
        w = np.array([1.0 / max((r["ci_high"] - r["ci_low"]) / 3.92, 1e-9) ** 2 for r in rows])
        om = np.array([r["omega_n"] for r in rows])
        mean = float((w * om).sum() / w.sum())
        std = float(1.0 / np.sqrt(w.sum()))
        rows.append({"dof": "Roll", "method": "rao_peak_sdof", "window_id": "all", "omega_n": mean,
                     "ci_low": mean - 1.96 * std, "ci_high": mean + 1.96 * std,
                     "zeta": float(np.mean([r["zeta"] for r in rows])), "model_prior": prior_omega})
    return rows


def derived_roll_parameters(model, prior, combined: dict) -> list[dict]:
    """r44 from ω4 with the prior's mass and GM, and GM from ω4 with the prior's r44 (de Jong eq. 6.4 as
    corrected in spec/seed_002.md), first-order uncertainty from the ω4 interval."""
    from seatune.physics.loading import load
    from seatune.physics.natural_frequency import gm_from_roll_u, r44_from_roll_u

    db = model.db
    lh = load(db, prior)
    a44 = db.interp("added_mass", lh.draft)[0, :, 3, 3]
    added = lambda om: np.interp(om, db.omega, a44)  # noqa: E731
    mass = float(prior.mass[0])
    gm = float(lh.stiffness[0, 3, 3] / (mass * db.g))
    om, std = combined["omega_n"], (combined["ci_high"] - combined["ci_low"]) / 3.92
    base = {k: combined[k] for k in ("dof", "method", "window_id", "omega_n", "ci_low", "ci_high", "zeta",
                                     "model_prior")}
    out = []
    try:
        r = r44_from_roll_u(om, mass, gm, added, std_omega4=std, g=db.g)
        out.append({**base, "derived": "r44 [m] (prior mass and GM)", "derived_value": r.value, "derived_std": r.std})
    except ValueError:
        pass
    g = gm_from_roll_u(om, mass, float(prior.r44[0]), added, std_omega4=std, g=db.g)
    out.append({**base, "derived": "GM [m] (prior mass and r44)", "derived_value": g.value, "derived_std": g.std})
    return out


def identify_stage(run, model, echo=print, force: bool = False) -> dict:
    from seatune.io.hindcast_readers import read_hindcast
    from seatune.io.parquet import write_table
    from seatune.io.rundir import fingerprint, is_fresh
    from seatune.physics.response import natural_frequencies

    src = [run.artefact("windows.parquet"), run.artefact("window_spectra.parquet"), run.artefact("motions.parquet")]
    fp = fingerprint(src + [run.hindcast_path, run.vessel_path], {"stage": "identify"})
    out_r, out_n = run.artefact("raos.parquet"), run.artefact("natural_frequencies.parquet")
    if not force and is_fresh([out_r, out_n], fp):
        return {"skipped": True}
    windows, spectra = pd.read_parquet(src[0]), pd.read_parquet(src[1])
    motions = pd.read_parquet(src[2], columns=["time", "lat", "lon"])
    hc = read_hindcast(run.hindcast_path, format=run.spec.hindcast.format)
    prior = model.base_loading
    parts = []
    for row in windows[windows["accepted"]].itertuples():
        mid = row.start + (row.end - row.start) / 2
        k = int(np.clip(motions["time"].searchsorted(mid), 0, len(motions) - 1))
        spec_w = spectra[spectra["window_id"] == row.window_id]
        omega = spec_w[spec_w["channel"] == spec_w["channel"].iloc[0]]["omega"].to_numpy()
        wave, dirs, source = window_wave_spectrum(hc, row, motions["lat"].iloc[k], motions["lon"].iloc[k], omega)
        parts += identify_window(model, prior, row, wave, dirs, source, spec_w)
    raos = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=list(RAO_UNITS))
    prior_roll = float(natural_frequencies(model.db, prior)[0, 1])
    rows = roll_natural_frequency(raos, prior_roll)
    rows += [d for r in rows if r["window_id"] == "all" for d in derived_roll_parameters(model, prior, r)]
    nat = pd.DataFrame(rows, columns=list(NF_UNITS))
    write_table(raos, out_r, RAO_UNITS, {"fingerprint": fp})
    write_table(nat, out_n, NF_UNITS, {"fingerprint": fp})
    combined = nat[(nat["window_id"] == "all") & nat["derived"].isna()]
    return {"skipped": False, "windows": int(windows["accepted"].sum()), "channels": int(raos["channel"].nunique()),
            "roll_omega_n": float(combined["omega_n"].iloc[0]) if len(combined) else float("nan"),
            "prior_roll_omega_n": prior_roll}

"""`seatune identify`: RAOs and natural frequencies from measured response spectra and the hindcast's wave
spectrum (de Jong ch. 5–6; Han A7's energetic band), independent of any tuning.

Per accepted window: the wave spectrum at the window (the hindcast's 2-D spectrum when it has one,
otherwise JONSWAP + cos-2s from the bulk parameters), the effective RAO |H_eff(ω)| = √(S_xx/S_ζζ) of every
channel in the energetic band with its interval (χ² sampling error of S_xx and the hindcast's Hs/Tp error),
the prior model's effective RAO in the same directional sea, and quality flags (a window whose motions carry
energy below the wave band — a hindcast that misses the swell — is low-confidence). Windows are then
aggregated per sector of wave direction β × Hs bin. Natural frequencies of heave, roll and pitch come from the
RAO peak near the prior model's value refined by a single-degree-of-freedom fit (roll also from its response
spectrum peak), combined over windows, with the loading parameters they imply.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
import pandas as pd

from seatune.errors import UserError
from seatune.physics.spectra import direction_step, omnidirectional

RAO_PER_ROW = "per row; the row's channel unit per m of wave amplitude (vessel YAML `channels`)"
RAO_UNITS = {"scope": "", "window_id": "", "channel": "", "omega": "rad/s", "rao_amp": RAO_PER_ROW,
             "ci_low": RAO_PER_ROW, "ci_high": RAO_PER_ROW, "model_prior": RAO_PER_ROW,
             "low_confidence": "", "reason": "", "beta_deg": "deg", "sector_deg": "deg", "hs": "m",
             "hs_bin_m": "m", "n_windows": "", "wave_source": ""}
NF_UNITS = {"dof": "", "method": "", "window_id": "", "omega_n": "rad/s", "ci_low": "rad/s", "ci_high": "rad/s",
            "zeta": "dimensionless", "model_prior": "rad/s", "derived": "",
            "derived_value": "per row; the unit named in `derived`",
            "derived_std": "per row; the unit named in `derived`",
            "reason": "text", "estimator_bias": "dimensionless", "tp_std": "rad/s", "sea_std": "rad/s",
            "loading_std": "rad/s", "prior_std": "rad/s"}
DIAGNOSED_NF_FILE = "natural_frequencies_diagnosed.parquet"  # diagnose's: ω_n in the sea refitted through its effects


def final_natural_frequencies(run_dir):
    """The run's last natural frequencies: diagnose's (in the sea refitted through the vessel effects it named)
    where it wrote them, else identify's."""
    from pathlib import Path

    diagnosed = Path(run_dir) / DIAGNOSED_NF_FILE
    return diagnosed if diagnosed.is_file() else Path(run_dir) / "natural_frequencies.parquet"


DOF_INDEX = {"Heave": 2, "Roll": 3, "Pitch": 4}


@dataclass(frozen=True)
class ModeChannel:
    """The measured channel that shows a rigid-body mode, and how to turn its RAO into a displacement RAO."""

    dof: str
    channel: str
    order: int  # |H_disp| = |H_channel| / ω^order


def mode_channels(model, available) -> list[ModeChannel]:
    """Heave from a vertical displacement / velocity / acceleration channel (nearest the origin), roll and
    pitch from their angle or rate channels."""
    order = {"displacement": 0, "angle": 0, "velocity": 1, "rate": 1, "acceleration": 2, "specific_force": 2}
    want = {"Heave": ("z", ("displacement", "velocity", "acceleration", "specific_force")),
            "Roll": ("x", ("angle", "rate")), "Pitch": ("y", ("angle", "rate"))}
    out = []
    for dof, (axis, kinds) in want.items():
        best = None
        for ch in model.channels:
            if ch.name not in available or ch.axis != axis or ch.kind not in kinds:
                continue
            dist = 0.0 if ch.point is None else float(np.hypot(ch.point[0], ch.point[1]))
            key = (kinds.index(ch.kind), dist)
            if best is None or key < best[0]:
                best = (key, ch)
        if best is not None:
            out.append(ModeChannel(dof, best[1].name, order[best[1].kind]))
    return out


def window_wave_spectrum(hc, row, lat: float, lon: float, omega: np.ndarray, sea=None):
    """S(ω, D) [m²·s/rad²] on `omega` × the source's coming-from directions D [deg], and its source name: the
    sea estimated from the motions when `sea` (sea_states.parquet) holds the window, else the hindcast's."""
    from seatune.io.hindcast_readers import spectrum_at

    if sea is not None:
        from seatune.pipeline.sea import estimated_wave_spectrum

        found = estimated_wave_spectrum(sea, str(row.window_id), omega)
        if found is not None:
            return found

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


def mean_wave_direction(S2d: np.ndarray, dirs_from: np.ndarray, heading_deg: float) -> float:
    """Energy-weighted circular mean of the model wave direction β [deg] (DESIGN §3: β = ψ − D − 180°)."""
    beta = np.radians(heading_deg - dirs_from - 180.0)
    e = S2d.sum(axis=0)
    return float(np.degrees(np.arctan2((e * np.sin(beta)).sum(), (e * np.cos(beta)).sum())) % 360.0)


def power_in_sea(db, power: np.ndarray, omega: np.ndarray, dirs_from: np.ndarray, heading_deg: float) -> np.ndarray:
    """A database quantity |·|² (nw, nb, k) at `omega` and at the β of each source direction D: (n, nD, k)."""
    from seatune.physics.interp import interp_axis0

    return at_sea_directions(db, interp_axis0(db.omega, power, omega, complex_blend=False), dirs_from, heading_deg)


def at_sea_directions(db, power: np.ndarray, dirs_from: np.ndarray, heading_deg: float) -> np.ndarray:
    """A quantity (…, nb, k) on the database's headings β, linear in β at the β of each source direction D:
    (…, nD, k)."""
    from seatune.physics.extremes import direction_weights

    beta = np.mod(heading_deg - np.asarray(dirs_from, dtype=float) - 180.0, 360.0)  # DESIGN §3
    i0, i1, f = direction_weights(beta, np.degrees(db.wave_direction))
    return (1 - f)[:, None] * power[..., i0, :] + f[:, None] * power[..., i1, :]


def effective_model_rao(model, loading, channel_names, omega, dirs_from, S2d, heading_deg) -> np.ndarray:
    """√(Σ_D |H(ω, β_D)|² W(ω, D)) of the model: what √(S_xx/S_ζζ) estimates in that directional sea."""
    from seatune.physics.response import channel_raos

    chans = [model.channel(c) for c in channel_names]
    power = np.abs(channel_raos(model.db, loading, chans)[0]) ** 2  # (nw, nb, nch)
    p = power_in_sea(model.db, power, omega, dirs_from, heading_deg)
    weights = S2d / np.maximum(S2d.sum(axis=1, keepdims=True), 1e-300)
    return np.sqrt(np.einsum("wdc,wd->cw", p, weights))


def excitation_spectra(model, draft: float, omega, dirs_from, S2d, heading_deg) -> np.ndarray:
    """S_FF,d(ω) = Σ_D |F_d(ω, β_D)|² S(ω, D) ΔD of the heave, roll and pitch excitation: (3, n).

    It depends on the hull and draft only, not on the uncertain mass distribution, so √(S_xx/S_FF) of a mode
    is the mechanical admittance 1/|C − ω²(M + A) − iωB| whatever the directional spreading (uncoupled),
    whose peak is the natural frequency.
    """
    db = model.db
    force = db.interp("excitation_force", np.atleast_1d(draft))[0][:, :, 2:5]  # (nw, nb, 3)
    p = power_in_sea(db, np.abs(force) ** 2, omega, dirs_from, heading_deg)
    dd = direction_step(dirs_from)
    return np.einsum("wdk,wd->kw", p, S2d) * dd


def model_mode_spectra(model, loading, omega, dirs_from, S2d, heading_deg) -> np.ndarray:
    """The model's displacement spectra of heave (body origin), roll and pitch in the window's sea: (3, n). The
    equation of motion is solved at each ω (resonances between database frequencies resolved)."""
    from seatune.physics.response import motion_raos_at

    xi = motion_raos_at(model.db, loading, omega)[:, :, 2:5]
    p = at_sea_directions(model.db, np.abs(xi) ** 2, dirs_from, heading_deg)
    dd = direction_step(dirs_from)
    return np.einsum("wdk,wd->kw", p, S2d) * dd


def heave_at_origin(motions: pd.DataFrame, imu_point) -> np.ndarray:
    """Vertical acceleration of the body origin from the IMU: f_z + x θ̈ − y φ̈ (rigid body, small angles,
    the constant g removed with the mean): z_p = ξ3 + y ξ4 − x ξ5 (DESIGN §3 sign convention)."""
    dt = _dt(motions)
    x, y = imu_point[0], imu_point[1]
    acc = motions["imu_fz"].to_numpy() + x * np.gradient(motions["pitch_rate"].to_numpy(), dt)
    return acc - y * np.gradient(motions["roll_rate"].to_numpy(), dt)


def _reason(est) -> str:
    f = est.flags
    if f.get("missing_low_frequency_energy"):
        return (f"motions carry {100 * f['response_share_below_band']:.0f} % of their variance below the wave band "
                f"(ω < {f['band_low']:.2f} rad/s): hindcast misses low-frequency energy (swell?)")
    return "no energetic band" if est.low_confidence else ""


def identify_window(model, prior, row, wave, dirs, source, spectra: pd.DataFrame, settings, uncertainty):
    """Per-channel effective RAO estimates of one window: (RaoEstimate by channel, rows for raos.parquet)."""
    from seatune.identification.rao_estimation import rao_long_crested, wave_log_std

    names = list(spectra["channel"].unique())
    omega = spectra[spectra["channel"] == names[0]]["omega"].to_numpy()
    s_wave = omnidirectional(wave, dirs)
    h_model = effective_model_rao(model, prior, names, omega, dirs, wave, row.heading_deg)
    wls = wave_log_std(omega, np.maximum(s_wave, 1e-300), uncertainty.hs_rel_std, uncertainty.tp_std_s / uncertainty.tp)
    beta = mean_wave_direction(wave, dirs, row.heading_deg)
    estimates, rows = {}, []
    for name in names:
        part = spectra[spectra["channel"] == name]
        s_resp = part["S"].to_numpy()
        dof = float(part["dof"].iloc[0])
        est = rao_long_crested(omega, s_resp, dof, s_wave, settings.band_fraction, level=settings.confidence,
                               low_frequency_share=settings.low_frequency_share, wave_log_std=wls)
        sampling = rao_long_crested(omega, s_resp, dof, s_wave, settings.band_fraction, level=settings.confidence)
        estimates[name] = (est, sampling)
    kept = rao_bins(model, omega, [e for e, _ in estimates.values()])
    for j, name in enumerate(names):
        est = estimates[name][0]
        rows.append(pd.DataFrame({
            "scope": "window", "window_id": str(row.window_id), "channel": name, "omega": omega[kept],
            "rao_amp": est.amplitude[kept], "ci_low": est.low[kept], "ci_high": est.high[kept],
            "model_prior": h_model[j][kept], "low_confidence": bool(est.low_confidence), "reason": _reason(est),
            "beta_deg": beta, "sector_deg": np.nan, "hs": uncertainty.hs, "hs_bin_m": np.nan, "n_windows": 1,
            "wave_source": source}))
    # the hindcast is common to every channel: when most channels see energy it lacks, the window is suspect
    flagged = [e for e, _ in estimates.values() if e.low_confidence]
    window_flag = len(flagged) >= 0.5 * len(estimates)
    if window_flag:
        worst = max(flagged, key=lambda e: e.flags.get("response_share_below_band", 0.0))
        for r in rows:
            r["low_confidence"] = True
            r["reason"] = f"{len(flagged)} of {len(estimates)} channels: {_reason(worst)}"
    return estimates, rows, beta, window_flag


def rao_bins(model, omega: np.ndarray, estimates) -> np.ndarray:
    """The frequencies raos.parquet keeps: the hydro database's range and wherever a channel's RAO was measured.
    Beyond both the model RAO is an extrapolation and nothing was measured; the Welch grid runs to Nyquist, so
    the table held ~17× more rows (every window's kept in memory until the windows are combined)."""
    measured = np.zeros(omega.size, bool)
    for e in estimates:
        measured |= np.isfinite(e.amplitude)
    lo, hi = float(model.db.omega[0]), float(model.db.omega[-1])
    if measured.any():
        lo, hi = min(lo, float(omega[measured].min())), max(hi, float(omega[measured].max()))
    return (omega >= lo) & (omega <= hi)


def sector_of(beta_deg: float, width: float) -> float:
    """Centre of the β sector [deg]; sectors are centred on multiples of `width` (0 = following seas)."""
    return float((np.round(beta_deg / width) * width) % 360.0)


def aggregate_rows(per_window: list[dict], raos: pd.DataFrame, settings) -> list[pd.DataFrame]:
    """Windows combined per (β sector, Hs bin) and channel by inverse variance of ln|H| (003 thesis);
    low-confidence windows are left out."""
    from seatune.identification.rao_estimation import aggregate

    out = []
    per_window = [w for w in per_window if not w["low_confidence"]]
    channels = per_window[0]["estimates"].keys() if per_window else []
    for name in channels:
        ests = [w["estimates"][name][0] for w in per_window]
        groups = [(w["sector"], w["hs_bin"]) for w in per_window]
        agg = aggregate(ests, groups, level=settings.confidence)
        for (sector, hs_bin), part in agg.groupby("group", sort=False):
            members = [str(w["window_id"]) for w, e in zip(per_window, ests, strict=True)
                       if (w["sector"], w["hs_bin"]) == (sector, hs_bin) and not e.low_confidence]
            prior = raos[(raos["channel"] == name) & raos["window_id"].isin(members)]
            table = prior.pivot(index="omega", columns="window_id", values="model_prior")
            part = part[part["omega"].isin(table.index)]  # the bins the windows' rows keep (rao_bins)
            with np.errstate(divide="ignore"):
                model_prior = np.exp(np.log(table).mean(axis=1)).reindex(part["omega"].to_numpy()).to_numpy()
            out.append(pd.DataFrame({
                "scope": "aggregate", "window_id": "+".join(members), "channel": name,
                "omega": part["omega"].to_numpy(), "rao_amp": part["amplitude"].to_numpy(),
                "ci_low": part["low"].to_numpy(), "ci_high": part["high"].to_numpy(), "model_prior": model_prior,
                "low_confidence": False, "reason": "", "beta_deg": np.nan, "sector_deg": sector,
                "hs": np.nan, "hs_bin_m": hs_bin, "n_windows": part["n_windows"].to_numpy(),
                "wave_source": ""}))
    return out


def _window_weights(rows: list[dict]) -> np.ndarray:
    """Each window's inverse variance in `_combine`: its interval without the part the hindcast's Tp error
    (`tp_std`) shares with the other windows."""
    shared = np.array([r.get("tp_std", 0.0) for r in rows])
    std = np.array([(r["ci_high"] - r["ci_low"]) / 3.92 for r in rows])
    return 1.0 / np.maximum(std**2 - shared**2, 1e-18)


def _over_windows(rows: list[dict], values: np.ndarray) -> np.ndarray:
    """`values` (windows × …) combined as `_combine` combines ω_n: the median from three windows, else the
    inverse-variance mean."""
    if len(rows) >= 3:
        return np.median(values, axis=0)
    w = _window_weights(rows)
    return w @ values / w.sum()


def _combine(rows: list[dict], dof: str, method: str, prior_omega: float) -> dict | None:
    """One value over windows (window_id 'all'). With three or more windows, the median: a window's estimate
    has heavy-tailed errors its interval cannot show (the hindcast's spectral shape at the resonance, heave-pitch
    coupling in quartering seas), and the median ignores one such outlier where the inverse-variance mean
    follows it. The interval is the inverse-variance one, widened by the Birge ratio when the windows disagree
    more than their intervals allow, and by √(π/2) for the median's efficiency. The part of each window's interval
    that comes from the hindcast's Tp error (`tp_std`) is left out of that and added after: one hindcast's error
    persists over a run's windows, so it does not average down."""
    if not rows:
        return None
    shared = np.array([r.get("tp_std", 0.0) for r in rows])
    w = _window_weights(rows)
    om = np.array([r["omega_n"] for r in rows])
    mean = float((w * om).sum() / w.sum())
    sd = float(1.0 / np.sqrt(w.sum()))
    if len(rows) > 1:
        sd *= max(1.0, float(np.sqrt((w * (om - mean) ** 2).sum() / (len(rows) - 1))))
    if len(rows) >= 3:
        mean, sd = float(_over_windows(rows, om)), sd * np.sqrt(np.pi / 2)
    tp_std = float((w * shared).sum() / w.sum())
    sd = float(np.hypot(sd, tp_std))
    zeta = [r["zeta"] for r in rows if np.isfinite(r["zeta"])]
    return {"dof": dof, "method": method, "window_id": "all", "omega_n": mean, "ci_low": mean - 1.96 * sd,
            "ci_high": mean + 1.96 * sd, "zeta": float(np.mean(zeta)) if zeta else np.nan,
            "model_prior": prior_omega, "tp_std": tp_std}


def mode_spectra(model, modes, spectra_w: pd.DataFrame, motions_w: pd.DataFrame | None, segment_s: float):
    """Displacement spectra S_xx,d(ω) [unit²·s/rad] of heave (at the body origin), roll and pitch in one window,
    with their degrees of freedom: {dof: (omega, S, ν)}."""
    from seatune.physics.adaptive_filter import welch_spectrum

    out = {}
    for mode in modes:
        ch = model.channel(mode.channel)
        if mode.dof == "Heave" and ch.kind == "specific_force" and motions_w is not None and ch.point is not None:
            acc = heave_at_origin(motions_w, ch.point)
            if not np.isfinite(acc).any():  # masked in the whole window: no heave spectrum
                continue
            acc = pd.Series(np.where(np.isfinite(acc), acc, np.nan)).interpolate(limit_direction="both").to_numpy()
            omega, S, nu = welch_spectrum(acc, 1.0 / _dt(motions_w), segment_s=segment_s)
            keep = omega > 0
            out[mode.dof] = (omega[keep], S[keep] / omega[keep] ** 4, nu)
            continue
        part = spectra_w[spectra_w["channel"] == mode.channel]
        if part.empty:  # filter left the channel out in this window
            continue
        omega = part["omega"].to_numpy()
        out[mode.dof] = (omega, part["S"].to_numpy() / omega ** (2 * mode.order), float(part["dof"].iloc[0]))
    return out


def _dt(motions: pd.DataFrame) -> float:
    t = motions["time"].to_numpy("datetime64[ns]")  # not to_numpy(): a tz-aware column would become Timestamps
    return float(np.median(np.diff(t).astype("timedelta64[ns]").astype(float)) * 1e-9)


def natural_frequency_rows(model, per_window: list[dict], prior_omega: dict[str, float], settings,
                           loading=None, spread=None) -> list[dict]:
    """Per window whose wave energy reaches the resonance: the peak of the mechanical admittance
    √(S_xx/S_FF) in prior ω_n·(1 ± range) refined by an SDOF fit with its CI (de Jong §5.6.2 and ch. 6, with the
    model's excitation in place of the wave spectrum so that the excitation's own frequency dependence does not
    move the peak); roll also from its response-spectrum peak. Combined over windows by inverse variance.

    With `loading` (the prior with the run's `identify.known` values), each window's fit is corrected for the
    estimator's own bias: the same fit on that loading's noise-free spectra in the window's sea lands at
    ω_fit,model instead of its coupled mode ω_ref (coupled excitation — sway into roll, pitch into heave — and
    frequency-dependent A and B bend the SDOF shape), so the measured fit is scaled by ω_ref/ω_fit,model
    (`estimator_bias` = the inverse).

    That bias is the model's at `loading`, and the true loading is uncertain. With `spread` (`loading_spread`:
    `loading` moved by ±1σ of each uncertain parameter, in pairs), the de-biasing is repeated at each of those
    loadings and the combined ω_n's interval widened by 1.96 · `loading_std` = √Σ_j ½((ω(+σ_j) − ω)² + (ω(−σ_j) − ω)²),
    which, unlike a central difference, keeps an effect even in the parameter (xcg on a symmetric hull). Every
    window shares the loading, so this term does not average down."""
    return natural_frequency_rows_many(model, [(per_window, prior_omega, loading, spread)], settings)[0]


def natural_frequency_rows_many(model, jobs: list[tuple], settings) -> list[list[dict]]:
    """`natural_frequency_rows` of each (per_window, prior_omega, loading, spread[, draws]) job, the modes of all
    jobs fitted side by side (seatune.parallel). With `draws` (a Loading), each window's fit also keeps the same fit
    on the model's spectrum at each draw (`fit_by_draw`, for `posterior_rows`)."""
    from seatune.parallel import map_tasks
    from seatune.physics.modes import natural_frequencies

    jobs = [tuple(job) + (None,) * (5 - len(job)) for job in jobs]
    refs = [(natural_frequencies(model.db, loading)[0] if loading is not None else None,
             natural_frequencies(model.db, spread) if loading is not None and spread is not None else None)
            for _, _, loading, spread, _ in jobs]
    tasks = [(j, dof, prior) for j, job in enumerate(jobs) for dof, prior in job[1].items()]

    def one(task):
        j, dof, prior = task
        per_window, _, loading, spread, draws = jobs[j]
        return _mode_rows(model, per_window, dof, prior, settings, loading, spread, *refs[j], draws=draws)

    done = map_tasks(one, tasks, cost=lambda t: len(jobs[t[0]][0]) * (1 + len(jobs[t[0]][3] or ())
                                                                       + len(jobs[t[0]][4] or ()) // 8))
    out = [[] for _ in jobs]
    for (j, _, _), rows in zip(tasks, done, strict=True):
        out[j] += rows
    return out


def _mode_rows(model, per_window, dof, prior, settings, loading, spread, ref, spread_ref, draws=None) -> list[dict]:
    """One DOF's rows of `natural_frequency_rows`; `ref`, `spread_ref`: the coupled modes at `loading`, `spread`;
    `draws`: loadings whose model spectra each window's fit is repeated on (`fit_by_draw`)."""
    from seatune.identification.natural_frequency import spectrum_peak
    from seatune.identification.rao_estimation import chi2_interval, energetic_band

    rng = settings.search_range
    dof_row = {"Heave": 0, "Roll": 1, "Pitch": 2}
    out = []
    fits, peaks = [], []
    skipped = {"no channel measures it": 0, "low-confidence window": 0,
               f"no wave energy at the prior ω_n {prior:.3f} rad/s": 0, "no resonance peak fitted": 0,
               "the model's own spectrum in this sea shows no resonance to fit": 0}
    reasons = list(skipped)
    for w in per_window:
        if dof in w.get("sea_by_mode", {}):  # the mode's own sea (roll: fitted without the roll channels)
            w = w | w["seas"][w["sea_by_mode"][dof]]
        if dof not in w["modes"] or w["low_confidence"]:
            skipped[reasons[0 if dof not in w["modes"] else 1]] += 1
            continue
        omega, S, nu = w["modes"][dof]
        s_wave = np.interp(omega, w["omega"], w["s_wave"], left=0, right=0)
        band = energetic_band(omega, s_wave, settings.band_fraction)
        if not band.any() or not (omega[band].min() <= prior <= omega[band].max()):
            skipped[reasons[2]] += 1
            continue  # the waves do not reach this resonance
        s_ff = excitation_spectra(model, w["draft"], omega, w["dirs"], _wave_on(w, omega), w["heading"])
        s_ff = s_ff[dof_row[dof]]
        ok = band & (s_ff > 1e-12 * s_ff.max()) & (S > 0)
        lo_s, hi_s = chi2_interval(S, nu, settings.confidence)
        with np.errstate(divide="ignore", invalid="ignore"):
            amp, lo, hi = np.sqrt(S / s_ff), np.sqrt(lo_s / s_ff), np.sqrt(hi_s / s_ff)
        row = _fit_mode(omega[ok], amp[ok], lo[ok], hi[ok], s_wave[ok], prior, rng, w["tp_rel_std"]) \
            if ok.sum() >= 5 else None
        why = 3
        if row is not None and loading is not None:
            bias = partial(_model_bias, model, w=w, omega=omega[ok], amp=amp[ok], lo=lo[ok], hi=hi[ok],
                           s_ff=s_ff[ok], s_wave=s_wave[ok], k=dof_row[dof], prior=prior, rng=rng)
            raw, row = row, _debiased(row, bias(loading, ref[dof_row[dof]]))
            if row is not None and spread_ref is not None:
                row["omega_by_loading"] = raw["omega_n"] / np.array(
                    [bias(spread.take([i]), spread_ref[i, dof_row[dof]]) for i in range(len(spread))])
            if row is not None and draws is not None:
                row["raw_omega"] = raw["omega_n"]
                row["fit_by_draw"] = np.array([bias(draws.take([i]), 1.0) for i in range(len(draws))])
            why = 4
        if row is None:
            skipped[reasons[why]] += 1
        else:
            fits.append({"dof": dof, "method": "admittance_peak_sdof", "window_id": w["window_id"],
                         **row, "model_prior": prior})
        if dof == "Roll":
            pk = spectrum_peak(omega, S, (prior * (1 - rng), prior * (1 + rng)), "gaussian")
            if pk.index >= 0:
                half = 0.5 * float(np.diff(omega).mean())  # grid resolution
                peaks.append({"dof": dof, "method": "response_spectrum_peak", "window_id": w["window_id"],
                              "omega_n": pk.omega, "ci_low": pk.omega - half, "ci_high": pk.omega + half,
                              "zeta": np.nan, "model_prior": prior})
    for rows, method in ((fits, "admittance_peak_sdof"), (peaks, "response_spectrum_peak")):
        combined = _combine(rows, dof, method, prior)
        if combined and method == "admittance_peak_sdof" and spread_ref is not None:
            combined = _with_loading_std(combined, rows, dof, prior)
        out += rows + ([combined] if combined else [])
    if not fits:  # never a silent omission: the row says why
        why = "; ".join(f"{k} ({n} of {len(per_window)} windows)" for k, n in skipped.items() if n) \
            or "no accepted window"
        out.append({"dof": dof, "method": "admittance_peak_sdof", "window_id": "all", "omega_n": np.nan,
                    "ci_low": np.nan, "ci_high": np.nan, "zeta": np.nan, "model_prior": prior,
                    "reason": f"not identified: {why}"})
    return out


def sea_views(per_window: list[dict], prior_omega: dict[str, float]) -> list[tuple[list[dict], dict]] | None:
    """The windows as each of their defensible seas sees them (the hindcast's, the estimate from all channels, the
    estimate without roll), with the modes to fit there again: [(windows, {dof: prior ω_n})]; None: one sea only."""
    names = sorted({n for w in per_window for n in w.get("seas", {})})
    if len(names) < 2:
        return None
    out = []
    for name in names:
        view = [w | w["seas"][name] | {"sea_by_mode": {}, "sea_name": name}
                for w in per_window if name in w.get("seas", {})]
        redo = {dof: omega for dof, omega in prior_omega.items()  # a mode already fitted in this sea moves nowhere
                if len(view) < len(per_window) or any(_sea_name(w, dof) != name for w in per_window)}
        if redo:
            out.append((view, redo))
    return out


def with_sea_spread(rows: list[dict], model, per_window: list[dict], prior_omega: dict[str, float], settings,
                    loading, redone: list[list[dict]] | None = None) -> list[dict]:
    """`rows` with each combined admittance ω_n's interval widened by how far it moves when every window takes
    another of its defensible seas (`sea_views`): `sea_std` = max over seas of |Δω| · √p, p the other sea's
    probability against the one read (`view_probability`): the rms error of the value read when the other sea is
    the true one with probability p; |Δω| / √2 for two equally likely seas. Added in quadrature at 1.96σ. The
    choice is shared by every window, so it does not average down.
    `redone`: the rows of each view, if already fitted."""
    views = sea_views(per_window, prior_omega)
    if views is None:
        return rows
    if redone is None:
        redone = natural_frequency_rows_many(model, [(view, redo, loading, None) for view, redo in views], settings)
    moved: dict[str, list[tuple[float, float]]] = {}
    for (view, _), rows_of in zip(views, redone, strict=True):
        p = view_probability(view)
        for r in rows_of:
            if r["window_id"] == "all" and r["method"] == "admittance_peak_sdof" and np.isfinite(r["omega_n"]):
                moved.setdefault(r["dof"], []).append((r["omega_n"], np.sqrt(p)))
    out = []
    for r in rows:
        if r["window_id"] == "all" and r["method"] == "admittance_peak_sdof" and np.isfinite(r["omega_n"]):
            sea_std = max((abs(v - r["omega_n"]) * f for v, f in moved.get(r["dof"], [])), default=0.0)
            r = _widened(r, "sea_std", sea_std)
        out.append(r)
    return out


def view_probability(view: list[dict]) -> float:
    """The probability of a view's sea against the sea its windows were read in: ½ (the data cannot choose, e.g. the
    estimates with and without the roll channels), unless the windows carry the log-odds of that sea
    (`sea_log_odds`, the hindcast's against the estimate fitted to the same cross-spectra), summed over them."""
    log_odds = sum(w.get("sea_log_odds", {}).get(w["sea_name"], 0.0) for w in view)
    return float(1.0 / (1.0 + np.exp(-np.clip(log_odds, -700.0, 700.0))))


def uncertain_priors(model, known=()) -> dict[str, tuple[float, float, float]]:
    """{Loading field: (std, lower, upper)} of each vessel prior not in `known`, in the Loading's units (a
    displacement prior moves the mass; the mass stays within the database's drafts)."""
    from seatune.pipeline.vessel import with_mass_aliases

    rho = model.db.rho
    known = with_mass_aliases(known)
    out = {}
    for name, p in model.spec.priors.items():
        scale, name = (rho, "mass") if name == "displacement" else (1.0, name)
        lo, hi = (scale * b for b in p.bounds) if p.bounds is not None else (-np.inf, np.inf)
        if name == "mass":
            lo, hi = max(lo, rho * model.db.disp_volume[0]), min(hi, rho * model.db.disp_volume[-1])
        if name not in known:
            out[name] = (scale * p.std, lo, hi)
    return out


def loading_spread(model, center, known=()):
    """`center` moved by +1σ and −1σ (clipped to the bounds) of each vessel prior not in `known`, in pairs: a
    Loading of 2n rows, or None without such priors."""
    from seatune.physics.loading import PARAMETERS, Loading

    steps = uncertain_priors(model, known)
    if not steps:
        return None
    values = {n: np.repeat(getattr(center, n), 2 * len(steps)) for n in steps}
    for j, (n, (std, lo, hi)) in enumerate(steps.items()):
        values[n][2 * j: 2 * j + 2] = np.clip(values[n][2 * j] + np.array([1.0, -1.0]) * std, lo, hi)
    base = {p: getattr(center, p) for p in PARAMETERS}
    return Loading(**(base | values))


def prior_draws(model, center, known=(), n: int = 1024, seed: int = 0):
    """`n` draws of the loading prior: each vessel prior not in `known` normal about `center`'s value with the
    prior's std, truncated to its bounds (scrambled Sobol points, so the spread is smooth in n); a Loading of n
    rows, or None without such priors."""
    from scipy.stats import qmc, truncnorm

    from seatune.physics.loading import PARAMETERS, Loading

    steps = uncertain_priors(model, known)
    if not steps:
        return None
    u = qmc.Sobol(len(steps), seed=seed).random(n)
    values = {}
    for j, (name, (std, lo, hi)) in enumerate(steps.items()):
        mean = float(getattr(center, name)[0])
        values[name] = truncnorm.ppf(u[:, j], (lo - mean) / std, (hi - mean) / std, loc=mean, scale=std)
    base = {p: np.repeat(getattr(center, p)[:1], n) for p in PARAMETERS}
    return Loading(**(base | values))


PITCH_R55 = "r55 [m]"  # the derived row of r55 read from the pitch mode (pipeline.sea.pitch_r55 takes it)


def fit_draw_count(model, known=()) -> int:
    """How many loadings of the prior each window's ω_n fit is repeated on (`fit_by_draw`): about three per term of
    a quadratic in the uncertain parameters, a power of two (Sobol points), 64 or 128."""
    n = len(uncertain_priors(model, known))
    return 64 if 3 * (n + 1) * (n + 2) // 2 <= 64 else 128


def debiased_by_draw(rows: list[dict], dof: str, draws, roots: np.ndarray, priors: dict,
                     fitted=None) -> np.ndarray | None:
    """The combined measured ω_n of `dof` de-biased at each of `draws` (n loadings, coupled roots `roots`): each
    window's raw fit scaled by root / (the same fit on that loading's model spectrum), combined over the windows as
    `_combine` does (`_over_windows`). The model's fit is known at the first `fitted` loadings of the prior
    (`fit_by_draw`) and carried to every draw by a quadratic in the uncertain parameters fitted to its log. Near an
    avoided crossing the labelled roots swap with the loading while the fit on the model's spectrum moves smoothly:
    osv_clean_000's pitch fit lands at 0.90 rad/s with the prior's r55 24 m (root 0.92) and at 0.85 with the truth's
    25.9 m (root 0.83), against 0.87 measured. None without such fits."""
    wins = [r for r in rows if r["dof"] == dof and r["method"] == "admittance_peak_sdof"
            and r["window_id"] != "all" and r.get("fit_by_draw") is not None]
    if not wins or fitted is None:
        return None
    names = list(priors)

    def features(loading):
        z = np.column_stack([(np.asarray(getattr(loading, n), float) - float(getattr(fitted, n).mean()))
                             / priors[n][0] for n in names])
        pairs = [z[:, i] * z[:, j] for i in range(len(names)) for j in range(i, len(names))]
        return np.column_stack([np.ones(len(z)), z, *pairs])

    x_fit, x_all = features(fitted), features(draws)
    ratios = []
    for r in wins:
        y = np.log(r["fit_by_draw"])
        ok = np.isfinite(y)
        if len(y) != len(fitted) or ok.sum() < x_fit.shape[1] + 8:  # other loadings, or too few fits
            return None
        coef, *_ = np.linalg.lstsq(x_fit[ok], y[ok], rcond=None)
        ratios.append(r["raw_omega"] / np.exp(x_all @ coef))
    ratios = np.array(ratios)  # (windows, draws)
    return roots * _over_windows(wins, ratios)


def posterior_rows(model, rows: list[dict], center, known, settings, shifted=()) -> list[dict]:
    """Per DOF with a combined measured ω_n (the admittance's; where its fit failed in every window, the response
    spectrum's peak) and not moved off the bare mode by a declared effect (`shifted`): that ω_n combined with the
    coupled modes over the loading prior (`identification.natural_frequency.mode_posterior`), as a row of method
    "posterior". The measurement's own interval is kept in its row; this one is the best estimate given what the
    vessel YAML and `identify.known` say about the loading. The response peak, reported as it was, had put
    barge_clean_023's roll 13 % off (inside its ±20 % interval); combined, the bank's 4 such rolls land within 2 %.
    A DOF measured more than 3σ from the model over the whole prior is an effect the model lacks (a moonpool, a
    misplaced IMU), not a loading: it is left out of the loading weights, which it would drag to the prior's tail
    (on the bank's osv_imu_lever_arm_042 a heave 6.7σ off moved pitch from −1.2 % to +6.0 %), and its row is the
    model's mode given the other modes, with a note; its measurement keeps its own row.
    r55's read from the pitch mode (a derived row) is its mean and std over the draws so weighted: the inversion at
    the known loading (`derived_parameters`) holds xcg where the vessel YAML puts it, and near the heave–pitch
    crossing it read osv_clean_000's r55 24.5 m against 25.9 m true."""
    from scipy.stats import norm

    from seatune.identification.natural_frequency import mode_posterior
    from seatune.physics.modes import natural_frequencies

    dofs = ("Heave", "Roll", "Pitch")
    measured = {r["dof"]: r for method in ("response_spectrum_peak", "admittance_peak_sdof") for r in rows
                if r["window_id"] == "all" and r["method"] == method and np.isfinite(r["omega_n"])
                and r["dof"] not in shifted}  # the admittance's where both measured
    if not measured:
        return []
    draws = prior_draws(model, center, known)
    model_omega = natural_frequencies(model.db, draws if draws is not None else center)
    z = norm.ppf(0.5 + settings.confidence / 2)
    m = np.array([measured[d]["omega_n"] if d in measured else np.nan for d in dofs])
    s = np.array([(measured[d]["ci_high"] - measured[d]["ci_low"]) / (2 * z) if d in measured else np.nan
                  for d in dofs])
    priors = uncertain_priors(model, known)
    if draws is not None:  # the estimator's bias at each draw, not only at the prior's centre
        fitted = prior_draws(model, center, known, n=fit_draw_count(model, known))
        for i, d in enumerate(dofs):
            by_draw = debiased_by_draw(rows, d, draws, model_omega[:, i], priors, fitted)
            if d in measured and measured[d]["method"] == "admittance_peak_sdof" and by_draw is not None:
                m = np.broadcast_to(m, model_omega.shape).copy()
                m[:, i] = by_draw
                s[i] = np.sqrt(max(s[i] ** 2 - measured[d].get("loading_std", 0.0) ** 2, 0.0)) or s[i]
    post = mode_posterior(model_omega, m, s, settings.mode_model_rel_std)
    miss = np.atleast_2d(m) - model_omega  # what no draw's loading explains, as the prior sees it
    z_prior = miss.mean(axis=0) / np.sqrt(s ** 2 + miss.var(axis=0) + np.mean(
        (settings.mode_model_rel_std * model_omega) ** 2, axis=0))
    apart = np.abs(z_prior) > 3  # no loading the vessel allows explains it: an effect the model lacks, not a loading
    if apart.any():  # such a DOF would drag the others' loading weights to the prior's tail
        post = mode_posterior(model_omega, np.where(apart, np.nan, m), s, settings.mode_model_rel_std)
    out = []
    for i, dof in enumerate(dofs):
        if dof not in measured:
            continue
        omega, std, note = float(post.omega[i]), float(post.std[i]), None
        if apart[i]:
            note = (f"the model's mode given the other modes: the measurement, {measured[dof]['omega_n']:.3f} "
                    f"rad/s, lies {z_prior[i]:+.1f}σ from it over the loading prior ({post.prior_mean[i]:.3f} ± "
                    f"{post.prior_std[i]:.3f} rad/s), which no loading explains")
        out.append({"dof": dof, "method": "posterior", "window_id": "all", "omega_n": omega,
                    "ci_low": omega - z * std, "ci_high": omega + z * std,
                    "zeta": measured[dof]["zeta"], "model_prior": measured[dof]["model_prior"],
                    "prior_std": float(post.prior_std[i]), "reason": note})
    if draws is not None and "Pitch" in measured and not apart[2] and "r55" in priors:
        r55 = np.asarray(draws.r55, float)  # r55 given the modes, the other loading parameters marginalised
        mean = float(post.weights @ r55)
        pitch = next(r for r in out if r["dof"] == "Pitch")
        out.append(pitch | {"derived": PITCH_R55, "derived_value": mean,
                            "derived_std": float(np.sqrt(post.weights @ (r55 - mean) ** 2))})
    return out


def effect_mode_rows(model, parameters, phi: np.ndarray, dofs, note: str, confidence: float = 0.95) -> list[dict]:
    """Per DOF in `dofs` (whose measured peak a named effect moves off the bare mode, MODES_SHIFTED_BY), the hull's
    coupled mode (DESIGN §6) at the loading `phi` that diagnose refitted with the effects in the model, as a row of
    method "model_with_effects"; its interval from each parameter's std (`parameters`' prior_std) by central
    differences, in quadrature (correlations between the parameters are not known here). A tank splits the roll peak
    and a moonpool's piston mode pulls the heave peak, so the peak is the coupled system's, not the hull's; on the
    blind bank the peak read 3.7 and 13.4 % low for the named tanks and 2.0 to 2.4 % off for two moonpool heaves, the
    model with the effects 0.5, 0.7 and 0.9, 0.3 %."""
    from scipy.stats import norm

    from seatune.physics.modes import natural_frequencies

    order = [d for d in ("Heave", "Roll", "Pitch") if d in set(dofs)]
    if not order:
        return []
    k = len(parameters)
    lo, hi = np.array([p.lower for p in parameters]), np.array([p.upper for p in parameters])
    std = np.array([p.prior_std for p in parameters])
    grid = np.repeat(np.asarray(phi, dtype=float)[None, :], 1 + 2 * k, axis=0)  # centre, then ±1σ per parameter
    idx = np.arange(k)
    grid[1 + 2 * idx, idx] = np.minimum(phi + std, hi)
    grid[2 + 2 * idx, idx] = np.maximum(phi - std, lo)
    omega = natural_frequencies(model.db, model.loading(**{p.name: grid[:, j] for j, p in enumerate(parameters)}),
                                tuple(DOF_INDEX[d] for d in order))  # (1 + 2k, len(order))
    step = grid[1 + 2 * idx, idx] - grid[2 + 2 * idx, idx]
    slope = (omega[1::2] - omega[2::2]) / np.where(step > 0, step, np.inf)[:, None]
    spread = np.sqrt(((slope * std[:, None]) ** 2).sum(axis=0))
    z = norm.ppf(0.5 + confidence / 2)
    return [{"dof": d, "method": "model_with_effects", "window_id": "all", "omega_n": float(omega[0, i]),
             "ci_low": float(omega[0, i] - z * spread[i]), "ci_high": float(omega[0, i] + z * spread[i]),
             "loading_std": float(spread[i]), "reason": note} for i, d in enumerate(order)]


def _with_loading_std(combined: dict, fits: list[dict], dof: str, prior: float) -> dict:
    """`combined` with `loading_std` from its windows' ω_n de-biased at each loading of the spread (a window whose
    fit fails there keeps its own value) and the interval widened by 1.96 · loading_std in quadrature."""
    by = [r.get("omega_by_loading") for r in fits]
    if not by or any(b is None for b in by):
        return combined
    moved = []
    for i in range(len(by[0])):
        rows = [r | {"omega_n": b[i], "ci_low": r["ci_low"] + b[i] - r["omega_n"],
                     "ci_high": r["ci_high"] + b[i] - r["omega_n"]} if np.isfinite(b[i]) else r
                for r, b in zip(fits, by, strict=True)]
        moved.append(_combine(rows, dof, combined["method"], prior)["omega_n"])
    dev = np.asarray(moved).reshape(-1, 2) - combined["omega_n"]  # not (ω₊ − ω₋)/2: a symmetric effect would vanish
    return _widened(combined, "loading_std", float(np.sqrt(np.sum(np.mean(dev ** 2, axis=1)))))


def _widened(row: dict, name: str, std: float) -> dict:
    """`row` with `name` = `std` [rad/s], an error its windows share, added to its 95 % interval in quadrature."""
    half = np.hypot(0.5 * (row["ci_high"] - row["ci_low"]), 1.96 * std)
    return row | {"ci_low": row["omega_n"] - half, "ci_high": row["omega_n"] + half, name: std}


def _sea_name(w: dict, dof: str) -> str | None:
    """The name of the sea a window's `dof` mode is read against."""
    return w.get("sea_by_mode", {}).get(dof, w.get("sea_name"))


def _model_bias(model, loading, reference: float, w: dict, omega, amp, lo, hi, s_ff, s_wave, k: int, prior: float,
                rng: float) -> float:
    """ω_fit,model / ω_ref: the same fit on the spectrum of the model at `loading` (same points, same relative
    intervals) over that model's coupled mode ω_ref; NaN when the model's noise-free spectrum gives no fit."""
    s_model = model_mode_spectra(model, loading, omega, w["dirs"], _wave_on(w, omega), w["heading"])[k]
    amp_m = np.sqrt(s_model / s_ff)
    fit_m = _fit_mode(omega, amp_m, amp_m * lo / amp, amp_m * hi / amp, s_wave, prior, rng, 0.0)
    return fit_m["omega_n"] / reference if fit_m is not None else np.nan


def _debiased(row: dict, bias: float) -> dict | None:
    """`row` divided by the estimator's `bias` (`_model_bias`). None when that is NaN: the model's noise-free
    spectrum gives no fit, so the measured one is noise or another system's peak (on the trial bank such roll
    fits were 20 % off in median, 1 in 8 inside their interval)."""
    if not np.isfinite(bias):
        return None
    return row | {"omega_n": row["omega_n"] / bias, "ci_low": row["ci_low"] / bias, "ci_high": row["ci_high"] / bias,
                  "tp_std": row["tp_std"] / bias, "estimator_bias": bias}


def _fit_mode(omega, amp, lo, hi, s_wave, prior: float, rng: float, tp_rel_std: float) -> dict | None:
    """SDOF fit of an admittance near its peak. The interval adds, in quadrature, how far ω_n moves when the
    hindcast's Tp is off by ±1σ: that tilts the spectrum by exp(±(1 + ∂ln S/∂ln ω) σ_Tp/Tp) (see
    rao_estimation.wave_log_std) and shifts the peak — an error the χ² interval cannot see."""
    from seatune.identification.natural_frequency import fit_sdof, peak_in_range

    def fit(factor):
        peak, k = peak_in_range(omega, amp * factor, prior, rng)
        if k < 0:
            return None
        try:
            f = fit_sdof(omega, amp * factor, lo * factor, hi * factor, omega_guess=peak, rel_range=rng)
        except (ValueError, RuntimeError):
            return None
        return f if abs(f.omega_n / prior - 1) <= rng and f.zeta > 1e-3 else None

    best = fit(1.0)
    if best is None:
        return None
    if tp_rel_std == 0:  # no tilt: the shifts below are exactly 0
        half = 0.5 * (best.omega_n_ci[1] - best.omega_n_ci[0])
        return {"omega_n": best.omega_n, "ci_low": best.omega_n - half, "ci_high": best.omega_n + half,
                "zeta": best.zeta, "tp_std": 0.0}
    tilt = 0.5 * (1.0 + np.gradient(np.log(s_wave), np.log(omega))) * tp_rel_std  # on ln|admittance|
    shifts = [abs(f.omega_n - best.omega_n) if f is not None else np.inf
              for f in (fit(np.exp(tilt)), fit(np.exp(-tilt)))]
    shift = max(shifts)
    if not np.isfinite(shift):
        return None
    half = np.hypot(0.5 * (best.omega_n_ci[1] - best.omega_n_ci[0]), 1.96 * shift)
    return {"omega_n": best.omega_n, "ci_low": best.omega_n - half, "ci_high": best.omega_n + half,
            "zeta": best.zeta, "tp_std": shift}


def held_sea(omega: np.ndarray, wave: np.ndarray, dirs: np.ndarray, band_fraction: float) -> dict:
    """A window's directional sea as identify holds it until the windows are combined: S(ω, D) only over the span
    of bins where the omnidirectional spectrum reaches a tenth of the energetic band's threshold (at most 1e-4 of
    its peak; `wave_omega`, zero elsewhere, see `_wave_on`). Every fit reads the sea inside the band only; the
    Welch grid runs to Nyquist, and a JONSWAP tail held whole cost ~0.7 MB per window and sea."""
    s_wave = omnidirectional(wave, dirs)
    floor = min(1e-4, 0.1 * band_fraction)
    live = np.flatnonzero(s_wave >= floor * s_wave.max()) if s_wave.size and s_wave.max() > 0 else []
    part = slice(live[0], live[-1] + 1) if len(live) else slice(0, 0)
    return {"wave": wave[part].copy(), "wave_omega": omega[part], "dirs": dirs, "s_wave": s_wave}


def _wave_on(w: dict, omega: np.ndarray) -> np.ndarray:
    """The window's directional wave spectrum on another frequency grid (zero beyond the bins held)."""
    grid, wave = w.get("wave_omega", w["omega"]), w["wave"]
    if np.array_equal(omega, grid):
        return wave
    if not len(grid):
        return np.zeros((len(omega), len(w["dirs"])))
    # exact on the held bins (np.interp at a node returns its value), zero beyond them
    return np.stack([np.interp(omega, grid, wave[:, k], left=0, right=0) for k in range(wave.shape[1])], axis=1)


def derived_parameters(model, known_loading, nat: list[dict]) -> list[dict]:
    """Loading parameters implied by the combined natural frequencies: displacement from ω3 (de Jong ch. 6);
    r44 with the known GM, GM with the known r44 (both from the roll mode) and r55 from the pitch mode by
    inverting the coupled model (`physics.modes.invert_mode`: the loading at which det(C − ω²(M + A(ω))) has
    its root at the measured ω_n), with the interval of ω_n propagated through it. "Known" = the run's
    `identify.known` values over the vessel YAML's loading."""
    from seatune.identification.natural_frequency import displacement_from_heave_u
    from seatune.physics.loading import load
    from seatune.physics.modes import invert_mode

    db = model.db
    lh = load(db, known_loading)
    mass = float(known_loading.mass[0])
    gm_solid = float(lh.stiffness[0, 3, 3] / (mass * db.g)) + float(known_loading.gmt_fs[0])  # GM without fs
    gm = gm_solid - float(known_loading.gmt_fs[0])
    r44, r55 = float(known_loading.r44[0]), float(known_loading.r55[0])

    def added(dof: int, draft):
        a = db.interp("added_mass", np.atleast_1d(draft))[0, :, dof, dof]
        return lambda om: np.interp(om, db.omega, a)

    best = {r["dof"]: r for r in nat if r["window_id"] == "all" and r["method"] == "admittance_peak_sdof"
            and np.isfinite(r["omega_n"])}
    out = []
    if "Heave" in best:
        r = best["Heave"]
        std = (r["ci_high"] - r["ci_low"]) / 3.92
        draft = lh.draft
        for _ in range(4):  # the waterplane and A33 depend on the draft the displacement implies
            awp = float(db.interp("buoyancy_stiffness", np.atleast_1d(draft))[0, 2, 2] / (db.rho * db.g))
            d = displacement_from_heave_u(r["omega_n"], added(2, draft), awp, std_omega3=std, rho=db.rho, g=db.g)
            draft = db.draft_for_volume(np.clip(d.value / db.rho, db.disp_volume[0], db.disp_volume[-1]))
        out.append({**r, "derived": "displacement [t]", "derived_value": d.value / 1e3, "derived_std": d.std / 1e3})
    inversions = []
    if "Roll" in best:
        fs_bounds = (gm_solid - 4.0 * max(gm, 0.05), gm_solid - 0.01)  # GM from 0.01 m to 4× the known GM
        inversions += [("Roll", "r44", (0.3 * r44, 3.0 * r44), f"r44 [m] (GM {gm:.3f} m)", lambda v: v),
                       ("Roll", "gmt_fs", fs_bounds, f"GM [m] (r44 {r44:.2f} m)", lambda v: gm_solid - v)]
    if "Pitch" in best and not any(r.get("derived") == PITCH_R55 for r in nat):  # posterior_rows read none
        inversions.append(("Pitch", "r55", (0.3 * r55, 3.0 * r55), PITCH_R55, lambda v: v))
    for dof, parameter, bounds, label, to_value in inversions:
        r = best[dof]
        try:
            d = invert_mode(db, known_loading, parameter, dof, r["omega_n"], (r["ci_high"] - r["ci_low"]) / 3.92,
                            bounds)
        except ValueError:
            continue  # the measured ω_n is out of the model's reach for this parameter
        out.append({**r, "derived": label, "derived_value": to_value(d.value), "derived_std": d.std})
    return out


def load_draft(model, loading) -> float:
    from seatune.physics.loading import load

    return float(load(model.db, loading).draft[0])


def identify_stage(run, model, echo=print, force: bool = False) -> dict:
    from seatune.io.parquet import write_table
    from seatune.io.rundir import fingerprint, is_fresh
    from seatune.pipeline.sea import read_sea_states, sea_inputs

    settings, uncertainty = run.spec.identify, run.spec.hindcast.uncertainty
    src = [run.artefact("windows.parquet"), run.artefact("window_spectra.parquet"), run.artefact("motions.parquet"),
           *sea_inputs(run)]
    fp = fingerprint(src + [run.hindcast_path, run.vessel_path],
                     {"stage": "identify", "identify": settings.model_dump(), "uncertainty": uncertainty.model_dump()})
    out_r, out_n = run.artefact("raos.parquet"), run.artefact("natural_frequencies.parquet")
    if not force and is_fresh([out_r, out_n], fp):
        return {"skipped": True}
    windows = pd.read_parquet(src[0])
    raos, nat, per_window, prior_omega = identified(run, model, read_sea_states(run),
                                                    read_sea_states(run, roll_free=True))
    write_table(raos, out_r, RAO_UNITS, {"fingerprint": fp})
    write_table(nat, out_n, NF_UNITS, {"fingerprint": fp})
    combined = nat[(nat["window_id"] == "all") & nat["derived"].isna() & (nat["method"] == "admittance_peak_sdof")]
    omega_n = dict(zip(combined["dof"], combined["omega_n"], strict=True))
    not_identified = {r.dof: r.reason for r in combined.itertuples() if not np.isfinite(r.omega_n)}
    post = nat[(nat["method"] == "posterior") & nat["derived"].isna()]
    posterior = dict(zip(post["dof"], post["omega_n"], strict=True))
    return {"skipped": False, "windows": int(windows["accepted"].sum()),
            "low_confidence": sum(w["low_confidence"] for w in per_window),
            "channels": int(raos["channel"].nunique()), "omega_n": omega_n, "prior_omega_n": prior_omega,
            "not_identified": not_identified, "posterior_omega_n": posterior,
            "roll_omega_n": omega_n.get("Roll", float("nan")), "prior_roll_omega_n": prior_omega["Roll"]}


def identified(run, model, sea: pd.DataFrame | None, sea_roll: pd.DataFrame | None, shifted=()):
    """(raos, natural frequencies, per-window inputs, the prior's ω_n by DOF) of the run's accepted windows in the
    sea `sea` (None: the hindcast), roll also in `sea_roll` (the sea fitted without the roll channels, or None).
    `shifted`: DOFs whose peak an effect named by diagnose moves (kept out of the loading posterior, as the vessel
    YAML's own effects' are)."""
    from seatune.io.hindcast_readers import read_hindcast
    from seatune.io.motion_table import MotionTable
    from seatune.physics.response import natural_frequencies
    from seatune.pipeline.sea import estimated_wave_spectrum, window_uncertainty

    settings, uncertainty = run.spec.identify, run.spec.hindcast.uncertainty
    src = [run.artefact("windows.parquet"), run.artefact("window_spectra.parquet"), run.artefact("motions.parquet")]
    windows, spectra = pd.read_parquet(src[0]), pd.read_parquet(src[1])
    motions = MotionTable(src[2])
    hc = read_hindcast(run.hindcast_path, format=run.spec.hindcast.format)
    prior = model.base_loading
    draft = float(load_draft(model, prior))
    modes = mode_channels(model, set(spectra["channel"].unique()))
    parts, per_window = [], []
    for row in windows[windows["accepted"]].itertuples():
        mid = row.start + (row.end - row.start) / 2
        lat, lon = motions.fix_at(mid)  # the first fix from mid-window on
        spec_w = spectra[spectra["window_id"] == row.window_id]
        if spec_w.empty:  # filter left every channel of this window out (no finite sample)
            continue
        omega = spec_w[spec_w["channel"] == spec_w["channel"].iloc[0]]["omega"].to_numpy()
        wave, dirs, source = window_wave_spectrum(hc, row, lat, lon, omega, sea)
        unc = window_uncertainty(sea, row.window_id, uncertainty, row)
        estimates, rows, beta, window_flag = identify_window(model, prior, row, wave, dirs, source, spec_w, settings,
                                                             unc)
        parts += rows
        held = partial(held_sea, band_fraction=settings.band_fraction)
        seas = {source: held(omega, wave, dirs)}  # every defensible sea of the window
        log_odds = {}
        if source == "estimated from motions":
            hw, hd, hs_name = window_wave_spectrum(hc, row, lat, lon, omega)
            seas[hs_name] = held(omega, hw, hd)
            log_odds[hs_name] = unc.hindcast_log_odds
        by_mode = {}  # a mode's own sea: roll against the sea fitted without the roll channels
        found = estimated_wave_spectrum(sea_roll, str(row.window_id), omega) if sea_roll is not None else None
        if found is not None:
            by_mode["Roll"] = "estimated without the roll channels"
            seas[by_mode["Roll"]] = held(omega, found[0], found[1])
        per_window.append({"window_id": str(row.window_id), "estimates": estimates, "omega": omega,
                           **seas[source], "heading": row.heading_deg, "draft": draft, "seas": seas,
                           "sea_name": source, "sea_by_mode": by_mode, "sea_log_odds": log_odds,
                           "tp_rel_std": unc.tilt_tp_rel_std,
                           "low_confidence": window_flag,
                           "modes": mode_spectra(model, modes, spec_w,
                                                 motions.window(row.start, row.end, record=row.record),
                                                 run.spec.filter.welch_segment_s),
                           "sector": sector_of(beta, settings.heading_sector_deg),
                           "hs_bin": float(np.floor(unc.hs / settings.hs_bin_m) * settings.hs_bin_m)})
    if windows["accepted"].any() and not per_window:
        raise UserError(str(src[1]), None, "too little data: no spectrum of any accepted window (re-run "
                                           "`seatune filter`)")
    raos = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=list(RAO_UNITS))
    if per_window:
        raos = pd.concat([raos, *aggregate_rows(per_window, raos, settings)], ignore_index=True)
    prior_nat = natural_frequencies(model.db, prior)[0]
    prior_omega = {dof: float(prior_nat[i]) for i, dof in enumerate(("Heave", "Roll", "Pitch"))}
    known = model.loading(**settings.known) if settings.known else prior
    center = known if settings.debias_modes else None  # the estimator's bias at the loading as far as it is known
    spread = loading_spread(model, known, settings.known) if center is not None else None
    fit_draws = prior_draws(model, known, settings.known, n=fit_draw_count(model, settings.known)) \
        if center is not None and settings.mode_posterior else None
    views = sea_views(per_window, prior_omega) or []  # every mode in every sea at once (seatune.parallel)
    rows, *redone = natural_frequency_rows_many(
        model, [(per_window, prior_omega, center, spread, fit_draws),
                *((view, redo, center, None) for view, redo in views)], settings)
    rows = with_sea_spread(rows, model, per_window, prior_omega, settings, center, redone)
    if settings.mode_posterior:
        from seatune.identification.natural_frequency import shifted_modes

        rows += posterior_rows(model, rows, known, settings.known, settings,
                              shifted_modes(model.spec.effects) | set(shifted))
    rows += derived_parameters(model, known, rows)
    return raos, pd.DataFrame(rows, columns=list(NF_UNITS)), per_window, prior_omega

"""report.html from the run's tables: the sections an engineer reads instead of the Parquet files."""

from __future__ import annotations

import html
import json
import re

import numpy as np
import pandas as pd

from seatune.diagnosis.effects import own_parameters_text
from seatune.diagnosis.select import HOLDOUT_MIN
from seatune.identification.natural_frequency import primary_natural_frequencies
from seatune.identification.sea_estimation import table_coordinates
from seatune.report import html as H
from seatune.report import plots as P
from seatune.report.inputs import ReportInputs
from seatune.report.summary import DOFS, PARAMETER_UNITS, defect_counts, derived_values, posterior_table

# What ingest did about each defect it counts (seatune/pipeline/motions.py, ingest.py)
DEFECTS = {
    "non_monotonic_repaired": "timestamps earlier than the previous one: rows put back in time order (repaired)",
    "duplicates_removed": "repeated timestamps: the first received kept, the repeats dropped (repaired)",
    "missing_stamps_removed": "rows without a timestamp dropped",
    "imu_samples_without_orientation": "IMU messages without an orientation: attitude masked (NaN)",
    "gnss_no_fix_removed": "GNSS messages without a position fix dropped",
    "gaps_split": "logging gaps longer than ingest.max_gap_s: the record is split, nothing invented across",
    "samples_interpolated": "grid samples interpolated across missing samples of a source (within max_gap_s)",
    "samples_masked": "grid samples a source leaves empty inside a record (masked, NaN)",
    "samples_outside_imu": "samples before the first / after the last IMU sample trimmed",
    # "implausible <topic> <field>": the plausibility gate (seatune/physics/plausibility.py)
    "implausible": "outside ingest.plausibility (|f| ≤ 5 g, |angle| ≤ 90°, |rate| ≤ 5 rad/s, finite, stamp near "
                   "its receive time by default): masked (NaN; a wild stamp drops its row)",
}


def _pct(x: float) -> str:
    return "–" if not np.isfinite(x) else f"{100 * x:.1f} %"


def _num(x: float, digits: int = 4) -> str:
    return H.fmt(float(x), digits)


def tuned_worse(row: dict) -> str:
    """The warning when the tuned model predicts the held-out windows worse than the prior ('' when not)."""
    parts = []
    for label, key in (("all channels", "holdout_sigma_error"),
                       ("the channels the tuned parameters move", "holdout_sigma_error_informative")):
        prior, tuned = row.get(f"{key}_prior", np.nan), row.get(f"{key}_tuned", np.nan)
        if np.isfinite(prior) and np.isfinite(tuned) and tuned > prior:
            parts.append(f"{label} {_pct(prior)} (prior) → {_pct(tuned)} (tuned)")
    if not parts:
        return ""
    held = row.get("holdout_windows", 0)
    where = f"on the {held} held-out window(s)" if held else "on the training windows (none was held out)"
    return (f"The tuned model predicts the measured statistics worse than the prior {where}: mean "
            f"|ln(predicted/measured)| on {'; on '.join(parts)}. The tuned loading may fit the training windows' "
            "sea or noise rather than the vessel: check the sea, the tuned channels and the priors (Validation).")


def alerts(inp: ReportInputs, row: dict) -> str:
    """Warning cards at the top of the page."""
    out = ""
    w = inp.windows
    if not len(w) or not w["accepted"].any():
        out += H.alert("No window accepted", f"0 of {len(w)} candidate windows accepted: "
                       f"{', '.join(f'{n} {kind}' for kind, n in inp.rejections) if len(w) else 'no candidate'}. "
                       "Nothing was filtered, identified or "
                       "tuned; the Windows section shows the timeline and the reason of every candidate.")
    elif inp.not_run:
        out += H.alert("Stages not run", "; ".join(f"{s}: {why}" for s, why in inp.not_run.items())
                       + ". Their sections show nothing from earlier runs.")
    worse = tuned_worse(row)
    if worse:
        out += H.alert("Tuning made the held-out prediction worse", worse)
    return out


def summary_section(inp: ReportInputs, row: dict, units: dict[str, str]) -> str:
    c = inp.ingest_meta.get("counts") or {}
    defects = sum(defect_counts(inp.ingest_meta).values())
    best = primary_natural_frequencies(inp.natural_frequencies)
    tiles = [
        ("vessel", inp.vessel_name, inp.vessel_file),
        ("logged", f"{row['hours_logged']:.2f} h",
         f"{row['samples']:,} samples in {c.get('records', '?')} record(s), "
         f"{inp.time_span[0]:%Y-%m-%d %H:%M} → {inp.time_span[1]:%H:%M} UTC"),
        ("windows accepted", f"{row['windows_accepted']} of {row['windows_candidates']}",
         f"{row['accepted_minutes']:.0f} min free floating; {row['windows_low_confidence']} low-confidence"),
        ("hindcast", f"{len(inp.waves)} times at the track", inp.hindcast),
        ("input defects", f"{defects:,} repaired / masked",
         f"{len(inp.ingest_meta.get('truncated_logs') or [])} truncated log(s), "
         f"{len(inp.ingest_meta.get('warnings') or [])} warning(s)"),
    ]
    if "Roll" in best.index:
        r = best.loc["Roll"]
        tiles.append(("roll natural frequency", f"{r['omega_n']:.3f} rad/s",
                      f"95 % [{r['ci_low']:.3f}, {r['ci_high']:.3f}]; prior model {r['model_prior']:.3f} "
                      f"(T = {2 * np.pi / r['omega_n']:.1f} s)"
                      + ("; measured, with the loading prior" if r["method"] == "posterior" else "")))
    if row.get("backend"):
        tiles.append(("tuning backend", row["backend"].upper(),
                      f"{row['train_windows']} update(s), {row['holdout_windows']} held-out window(s)"))
        tiles.append(("held-out σ error", f"{_pct(row['holdout_sigma_error_prior'])} → "
                                          f"{_pct(row['holdout_sigma_error_tuned'])}",
                      "mean |ln(predicted/measured)|, prior → tuned model, all channels"))
        if np.isfinite(row.get("holdout_sigma_error_informative_prior", np.nan)):
            tiles.append(("held-out σ error, tuned channels",
                          f"{_pct(row['holdout_sigma_error_informative_prior'])} → "
                          f"{_pct(row['holdout_sigma_error_informative_tuned'])}",
                          "channels the tuned parameters move by ≥ 5 % over the prior (A2 eq. 9)"))
    body = alerts(inp, row) + H.cards(tiles)
    body += H.table(pd.DataFrame({"log": inp.logs}), caption="Logs") + H.para(f"Run file: {inp.run_file}")
    post = posterior_table(inp.history)
    if len(post):
        pt = pd.DataFrame({"parameter": post.index, "unit": [PARAMETER_UNITS.get(p, "") for p in post.index],
                           "prior mean": post["prior_mean"].to_numpy(), "prior std": post["prior_std"].to_numpy(),
                           "posterior mean": post["mean"].to_numpy(), "posterior std": post["std"].to_numpy(),
                           "5 %": post["q05"].to_numpy(), "95 %": post["q95"].to_numpy()})
        body += H.table(pt, caption="Tuned loading parameters (units as in the vessel YAML)")
    figures = pd.DataFrame({"figure": list(row), "value": [H.fmt(v) for v in row.values()],
                            "unit": [units.get(k, "") for k in row]})
    body += H.details("All key figures (the row of summary.parquet)", H.table(figures))
    return H.section("summary", "Run summary", body)


def defects_section(inp: ReportInputs) -> str:
    counts = defect_counts(inp.ingest_meta)
    rows = [{"defect": k.replace("_", " "), "count": v,
             "what ingest did": DEFECTS.get(k) or DEFECTS.get(k.split(" ")[0], "counted")}
            for k, v in counts.items()]
    body = H.table(pd.DataFrame(rows, columns=["defect", "count", "what ingest did"]),
                   caption="Defect counts recorded by ingest (motions.parquet metadata)",
                   row_class=lambda r: "flag" if r["count"] else "")
    truncated = inp.ingest_meta.get("truncated_logs") or []
    body += (H.note(f"{len(truncated)} log(s) cut short (read up to the cut): {', '.join(map(str, truncated))}")
             if truncated else H.para("No log was cut short.", ""))
    warnings = inp.ingest_meta.get("warnings") or []
    body += "".join(H.note(f"warning: {w}") for w in warnings) if warnings else H.para("Ingest raised no warning.", "")
    waves = inp.waves
    if {"sea_corners", "stencil_corners"} <= set(waves.columns):  # hindcast readers that mask land and ice
        partial = int((waves["sea_corners"] < waves["stencil_corners"]).sum())
        body += (H.note(f"{partial} of {len(waves)} track points used a partial hindcast stencil: grid corners on "
                        "land or ice left out, the sea corners' interpolation weights renormalised")
                 if partial else H.para(f"All {len(waves)} track points had a full hindcast stencil (no land or ice "
                                        "corner).", ""))
    return H.section("defects", "Input defects repaired or masked", body,
                     "Nothing is dropped silently: every repair, mask and cut that ingest made to the logs is "
                     "counted here (DESIGN §6). Highlighted rows are non-zero.")


def windows_section(inp: ReportInputs) -> str:
    w = inp.windows
    max_sog = (inp.settings.get("windows") or {}).get("max_sog")
    body = H.figure(P.png(P.timeline, inp.track, w, inp.waves, max_sog),
                    "Speed over ground [m/s], heading [deg, clockwise from North] and the hindcast's Hs [m] / Tp [s] "
                    "at the track against time [UTC]. Shaded: candidate windows, green accepted (free floating, "
                    "stationary), grey rejected; labels W<id> as in the table.", "timeline of windows")
    body += H.figure(P.png(P.track_map, inp.track, w),
                     "GNSS track [deg]; accepted windows in colour with their heading and hindcast Hs, rejected "
                     "windows labelled in grey.", "track with windows")
    days = pd.DatetimeIndex(w["start"]).normalize().nunique()
    clock = "%m-%d %H:%M:%S" if days > 1 else "%H:%M:%S"
    t = pd.DataFrame({"window": "W" + w["window_id"].astype(str), "start": w["start"].dt.strftime(clock),
                      "end": w["end"].dt.strftime(clock),
                      "duration": w["duration_s"] / 60.0, "accepted": w["accepted"], "reason": w["reason"],
                      "heading": w["heading_deg"], "SOG": w["sog"], "Hs": w["hs"], "Tp": w["tp"],
                      "waves from": w["dir_from_deg"]})
    units = {"start": "UTC", "end": "UTC", "duration": "min", "heading": "deg", "SOG": "m/s", "Hs": "m", "Tp": "s",
             "waves from": "deg"}
    day = "" if days > 1 else f" on {w['start'].iloc[0]:%Y-%m-%d}"
    counts = inp.rejections
    if counts:
        body += H.table(pd.DataFrame(counts, columns=["reason", "candidates"]), wide=("reason",),
                        caption=f"Rejected candidates by reason ({sum(n for _, n in counts)} of {len(w)})")
    body += H.table(t, units, caption=f"Candidate windows (windows.parquet), times UTC{day}", digits=3,
                    wide=("reason",), row_class=lambda r: "" if r["accepted"] else "rejected")
    return H.section("windows", "Windows", body,
                     f"{int(w['accepted'].sum())} of {len(w)} candidate windows are free floating and stationary; "
                     "a rejected window says why.")


def sea_section(inp: ReportInputs) -> str | None:
    sea = inp.sea_states
    if sea is None or sea.empty:
        return None
    body = H.figure(P.png(P.sea_polars, sea),
                    "The directional sea estimated from the motions per window: S(f, D) against wave period [s, "
                    "radius] and the direction the waves come from [deg, north up, clockwise]; o: estimated "
                    "partitions with Hs, x: the hindcast's partitions.", "estimated directional spectra")
    t = pd.DataFrame({"window": "W" + sea["window_id"].astype(str), "system": sea["system"], "kind": sea["kind"],
                      "hindcast Hs": sea["hindcast_hs"], "Hs": sea["hs"],
                      "± Hs": sea["hs_std"], "hindcast Tp": sea["hindcast_tp"], "Tp": sea["tp"],
                      "± Tp": sea["tp_std"], "hindcast from": sea["hindcast_dir_from_deg"],
                      "from": sea["dir_from_deg"], "± from": sea["dir_from_deg_std"], "spread": sea["spread_deg"],
                      "γ / n": [f"{g:.1f} / {n:.0f}" for g, n in  # n: JONSWAP's 5 in a table without it
                                zip(sea["gamma"], np.exp(table_coordinates(sea)[:, -1]), strict=True)]})
    units = {"hindcast Hs": "m", "Hs": "m", "± Hs": "m", "hindcast Tp": "s", "Tp": "s", "± Tp": "s",
             "hindcast from": "deg", "from": "deg", "± from": "deg", "spread": "deg"}
    body += H.table(t, units, caption="Partitions of the estimated sea (sea_states.parquet): the hindcast's value "
                    "beside the estimate and its standard deviation; a system absent from the hindcast has no "
                    "hindcast value; γ / n: the peak enhancement and the exponent of the ω⁻ⁿ tail (JONSWAP: n = 5)",
                    digits=3, row_class=lambda r: "rejected" if pd.isna(r["hindcast Hs"]) else "")
    if inp.sea_read:
        body += H.note(loading_read_text(inp.sea_read))
    refit = inp.sea_refit_hs
    if refit is not None and not refit.empty:
        t = pd.DataFrame({"window": "W" + refit["window_id"].astype(str), "Hs": refit["hs"],
                          "Hs through the named effects": refit["hs_refit"]})
        body += H.table(t, {"Hs": "m", "Hs through the named effects": "m"}, digits=3,
                        caption="Each window's Hs (√Σ Hs² of its partitions) as the sea stage estimated it, and "
                        "refitted through the vessel with diagnose's named effects (sea_states_diagnosed.parquet): "
                        "an effect the sea stage's model lacked had partly been taken for sea")
    added = sea[~sea["in_hindcast"]]
    return H.section("sea", "Sea state: hindcast and the sea from the ship", body,
                     f"Every stage after this one uses the estimated sea. {len(added)} partition(s) in "
                     f"{added['window_id'].nunique()} window(s) are absent from the hindcast.")


def loading_read_text(read: dict) -> str:
    """The loading the sea fit read, beside the vessel YAML's prior: read {name: (value, std, prior mean, std)}."""
    def one(name, value, std, mean, prior_std):
        unit = f" {PARAMETER_UNITS[name]}" if PARAMETER_UNITS.get(name) else ""
        return f"{name} {value:.2f} ± {std:.2f}{unit} (vessel YAML {mean:g} ± {prior_std:g}{unit})"

    return ("Read from the sea fit's own misfit (sea.read_loading), and modelled by every later stage: "
            + "; ".join(one(name, *v) for name, v in read.items()) + ".")


def filter_section(inp: ReportInputs) -> str:
    st = inp.window_stats.copy()
    st["window"] = "W" + st["window_id"].astype(str)

    def pivot(col: str, factor_of=None) -> pd.DataFrame:
        v = st[col] * (st["channel"].map(factor_of) if factor_of else 1.0)
        p = st.assign(v=v).pivot(index="window", columns="channel", values="v")
        p = p[list(dict.fromkeys(st["channel"]))]
        return p.reset_index()

    cut = pivot("cutoff_hz")
    units_c = {c: "Hz" for c in cut.columns if c != "window"}
    clamped = st[st["clamped"]] if "clamped" in st else st.iloc[:0]
    body = H.table(cut, units_c, caption="Adaptive lowpass cutoff per window × channel (Han A3) [Hz]", digits=3)
    if len(clamped):
        body += H.note("cutoff clamped to the search range: " + ", ".join(
            f"W{r.window_id} {r.channel}" for r in clamped.itertuples()))
    factors = {c: P.display_unit(inp.channel_unit(c))[0] for c in st["channel"].unique()}
    sig = pivot("sigma", factors)
    units_s = {c: P.display_unit(inp.channel_unit(c))[1] for c in sig.columns if c != "window"}
    body += H.table(sig, units_s, caption="Filtered standard deviation σ per window × channel (angles in deg)")
    tz = pivot("tz")
    body += H.details("Zero-crossing period Tz [s] and SNR per window × channel",
                      H.table(tz, {c: "s" for c in tz.columns if c != "window"}, caption="Tz [s]", digits=3)
                      + H.table(pivot("snr"), caption="SNR estimate [-]", digits=3))
    return H.section("filter", "Filter cutoffs and statistics", body,
                     "Per accepted window and channel: the lowpass cutoff chosen from the signal itself, and the σ "
                     "and Tz of the filtered signal that tuning uses as observations.")


def sea_name(beta_deg: float) -> str:
    """Plain name of a model wave direction β (DESIGN §3: going-to, from body +x; 180° head, 90° from starboard)."""
    b = beta_deg % 360.0
    off = abs(b - 180.0)
    side = "" if off <= 22.5 or off >= 157.5 else (" from starboard" if b < 180.0 else " from port")
    name = ("head" if off <= 22.5 else "bow quartering" if off <= 67.5 else "beam" if off <= 112.5
            else "stern quartering" if off < 157.5 else "following")
    return f"{name} seas{side}"


def _sector_title(part: pd.DataFrame) -> tuple[str, str]:
    r = part.iloc[0]
    wins = " + ".join(f"W{w}" for w in str(r["window_id"]).split("+"))
    title = (f"β = {r['sector_deg']:.0f}° sector ({sea_name(r['sector_deg'])}), Hs bin {r['hs_bin_m']:g} m: "
             f"{wins}")
    return title, wins


def raos_section(inp: ReportInputs) -> str:
    raos = inp.raos
    agg = raos[raos["scope"] == "aggregate"].copy()
    if inp.tuned_raos is not None and len(inp.tuned_raos):
        agg = agg.merge(inp.tuned_raos[["window_id", "channel", "omega", "model_tuned"]],
                        on=["window_id", "channel", "omega"], how="left")
    units = {c: inp.channel_unit(c) for c in raos["channel"].unique()}
    body = ""
    if inp.tuned_note:
        body += H.note(inp.tuned_note)
    if agg.empty:
        body += H.note("No aggregate RAO: every window was low-confidence or none was accepted.")
    for (_, _), part in agg.groupby(["sector_deg", "hs_bin_m"], sort=True):
        title, wins = _sector_title(part)
        body += f"<h3>{H.esc(title)}</h3>"
        body += H.figure(P.png(P.rao_sector, part, units),
                         "Effective RAO |H| = √(S_xx/S_ζζ) in the window's directional sea: measured (dots) with its "
                         "confidence interval (grey band: χ² sampling error and hindcast Hs/Tp error), the model with "
                         "the prior loading (blue dashed) and with the tuned loading (orange). Units: channel unit per "
                         "metre of wave amplitude, angles in deg/m; ω in rad/s.", f"RAOs {wins}")
    low = raos[(raos["scope"] == "window") & raos["low_confidence"]].drop_duplicates("window_id")
    if len(low):
        body += H.table(pd.DataFrame({"window": "W" + low["window_id"].astype(str), "reason": low["reason"]}),
                        caption="Low-confidence windows (left out of the aggregates)")
    else:
        body += H.para("No window was flagged low-confidence.", "")
    return H.section("raos", "Measured vs model RAOs", body,
                     "Accepted windows are combined per sector of the mean wave direction β and Hs bin "
                     "(β: direction the waves travel towards, from the bow, counter-clockwise; 180° = head seas, "
                     "90° = waves from starboard).")


def spectra_section(inp: ReportInputs) -> str | None:
    """Per accepted window: the measured response spectra of the main heave / roll / pitch channels against the
    prior and tuned model's."""
    sp = inp.spectra
    if sp is None or sp.empty:
        return None
    roles = {} if inp.validation is None else dict(zip(inp.validation["window_id"].astype(str),
                                                       inp.validation["role"], strict=False))
    windows = inp.windows.assign(key=inp.windows["window_id"].astype(str)).set_index("key")
    units = {c: inp.channel_unit(c) for c in sp["channel"].unique()}
    body = ""
    for wid, part in sp.groupby(sp["window_id"].astype(str), sort=False):
        w = windows.loc[wid]
        role = {"holdout": ", held out of tuning", "train": ", a training window"}.get(roles.get(wid, ""), "")
        title = f"W{wid}: heading {w['heading_deg']:.0f}°, hindcast Hs {w['hs']:.2f} m, Tp {w['tp']:.1f} s{role}"
        body += H.figure(P.png(P.response_spectra, part, units, title),
                         f"W{wid}: one-sided response spectrum S(ω) [channel unit²·s/rad; angles in deg²·s/rad] of the "
                         "main heave, roll and pitch channels: measured (Welch, filter stage; black) against the "
                         "model's |H_eff(ω)|²·S_ζζ(ω) in the window's directional sea with the prior loading (blue "
                         "dashed) and the tuned loading (orange).", f"response spectra W{wid}")
    return H.section("spectra", "Measured vs model response spectra", body,
                     "Where in frequency the model over- or under-predicts each window's motions: the σ that tuning "
                     "fits is the square root of the area under these curves.")


def mode_shape_words(modes, which: str) -> dict[str, str]:
    """The model's coupled mode shapes (`physics.modes.Modes`, first condition) in words, by DOF."""
    draft = float(modes.draft[0])
    shape = modes.shape[0]
    return {
        "Heave": f"{which}: pitch {shape[0, 4]:+.4f} rad per m of heave",
        "Roll": f"{which}: about a roll centre {modes.roll_centre_z[0] + draft:.2f} m above the keel "
                f"(sway {shape[1, 1]:+.2f} m/rad at the waterline)",
        "Pitch": f"{which}: about a pitch centre at x = {modes.pitch_centre_x[0]:+.1f} m, "
                 f"{modes.pitch_centre_z[0] + draft:.2f} m above the keel",
    }


MODE_SOURCES = {"posterior": "measured, with the loading prior",
                "model_with_effects": "the hull's mode in the model with the named effect (its peak is the coupled "
                                      "system's)"}


def diagnosed_sea_modes_table(nf_diagnosed: pd.DataFrame | None, before: pd.DataFrame) -> str:
    """identify's ω_n again in the sea diagnose refitted through the effects it named, beside identify's own (both
    with the loading prior where identify has it)."""
    if nf_diagnosed is None or nf_diagnosed.empty:
        return ""
    after = primary_natural_frequencies(nf_diagnosed)
    rows = [{"DOF": dof, "ω_n": after.loc[dof, "omega_n"],
             "95 % interval": f"{after.loc[dof, 'ci_low']:.3f} – {after.loc[dof, 'ci_high']:.3f}",
             "in the sea stage's sea": before.loc[dof, "omega_n"] if dof in before.index else np.nan,
             "from": MODE_SOURCES.get(after.loc[dof, "method"], after.loc[dof, "method"].replace("_", " "))}
            for dof in DOFS if dof in after.index]
    t = pd.DataFrame(rows)
    t.insert(len(t.columns) - 1, "change", t["ω_n"] / t["in the sea stage's sea"] - 1)
    return H.table(t, {"ω_n": "rad/s", "95 % interval": "rad/s", "in the sea stage's sea": "rad/s", "change": "%"},
                   caption="The natural frequencies seatune delivers: identified once more in the sea refitted "
                           "through the vessel effects diagnose named (the sea stage's fit had absorbed them), with "
                           "the loading prior; where a named effect moves a mode's peak (a tank's roll, a moonpool's "
                           "heave), the hull's mode in the model with it", formats={"change": _pct}, digits=4)


def natural_frequencies_section(inp: ReportInputs, tuned: dict[str, float] | None) -> str:
    nf = inp.natural_frequencies
    body = H.figure(P.png(P.natural_frequency_plot, nf, tuned),
                    "Natural frequencies ω_n [rad/s] per window with their 95 % interval and combined over windows "
                    "(diamonds), against the model with the prior loading (blue dashed) and the tuned loading "
                    "(orange).",
                    "natural frequencies")
    best = primary_natural_frequencies(nf, measured_only=True)
    rows = []
    for dof in DOFS:
        if dof not in best.index:
            continue
        r = best.loc[dof]
        rows.append({"DOF": dof, "ω_n": r["omega_n"], "95 % interval": f"{r['ci_low']:.3f} – {r['ci_high']:.3f}",
                     "T_n": 2 * np.pi / r["omega_n"], "ζ": r["zeta"], "prior ω_n": r["model_prior"],
                     "measured vs prior": (r["omega_n"] / r["model_prior"] - 1),
                     "tuned ω_n": (tuned or {}).get(dof, np.nan),
                     "measured vs tuned": (r["omega_n"] / (tuned or {}).get(dof, np.nan) - 1),
                     "model mode shape": inp.mode_shapes.get(dof, ""),
                     "method": r["method"].replace("_", " ") if np.isfinite(r["omega_n"]) else r.get("reason", "")})
    t = pd.DataFrame(rows)
    units = {"ω_n": "rad/s", "95 % interval": "rad/s", "T_n": "s", "ζ": "-", "prior ω_n": "rad/s",
             "tuned ω_n": "rad/s", "measured vs prior": "%", "measured vs tuned": "%"}
    body += H.table(t, units, caption="Combined natural frequencies measured, beside the model's coupled modes "
                                      "(roots of det(C − ω²(M + A(ω))): roll turns about its roll centre, pitch about "
                                      "its pitch centre; ζ: damping ratio of the SDOF fit)",
                    formats={"measured vs prior": _pct, "measured vs tuned": _pct}, digits=4)
    post = nf[(nf["window_id"] == "all") & (nf["method"] == "posterior") & nf["derived"].isna()]
    if len(post):
        p = pd.DataFrame({"DOF": post["dof"].to_numpy(), "ω_n": post["omega_n"].to_numpy(),
                          "95 % interval": [f"{lo:.3f} – {hi:.3f}" for lo, hi in zip(post["ci_low"], post["ci_high"],
                                                                                  strict=True)],
                          "model spread over the prior": post["prior_std"].to_numpy(),
                          "note": post["reason"].fillna("").to_numpy()})
        body += H.table(p, {"ω_n": "rad/s", "95 % interval": "rad/s", "model spread over the prior": "rad/s"},
                        caption="Natural frequencies with the loading prior: each measured ω_n combined with the "
                                "coupled modes over the vessel's loading priors (identify.known held, with "
                                "identify.mode_model_rel_std): the best estimate before tuning", digits=4)
    body += diagnosed_sea_modes_table(inp.natural_frequencies_diagnosed, primary_natural_frequencies(nf))
    derived = derived_values(nf)
    if derived:
        d = pd.DataFrame([{"derived from ω_n": label, "value": v, "std": s, "unit": u}
                          for v, s, u, label in derived.values()])
        body += H.table(d, caption="Loading parameters implied by the natural frequencies (with the known values of "
                                   "identify.known)")
    return H.section("natural-frequencies", "Natural frequencies", body)


def history_pmfs(history: pd.DataFrame) -> dict | None:
    """{parameter: [(update, grid, pmf), ...]} when the history carries the backend's marginal PMFs."""
    gcol = next((c for c in ("marginal_grid", "pmf_grid", "grid") if c in history), None)
    pcol = next((c for c in ("marginal_pmf", "pmf", "marginal") if c in history), None)
    if gcol is None or pcol is None:
        return None
    out: dict = {}
    for r in history.sort_values("update").itertuples():
        g, p = getattr(r, gcol), getattr(r, pcol)
        if g is None or p is None or len(g) != len(p) or len(g) < 2:
            return None
        out.setdefault(r.parameter, []).append((r.update, np.asarray(g, float), np.asarray(p, float)))
    return out


def history_correlation(history: pd.DataFrame) -> tuple[list[str], np.ndarray] | None:
    """Posterior correlation after the last update when the history carries `cov_<p>` or `corr_<p>` columns."""
    params = list(dict.fromkeys(history["parameter"]))
    for prefix in ("corr_", "cov_"):
        cols = [f"{prefix}{p}" for p in params]
        if all(c in history for c in cols):
            last = history[history["update"] == history["update"].max()].set_index("parameter").reindex(params)
            m = last[cols].to_numpy(dtype=float)
            if prefix == "cov_":
                s = np.sqrt(np.clip(np.diag(m), 1e-300, None))
                m = m / np.outer(s, s)
            return params, m
    return None


def tuning_section(inp: ReportInputs) -> str:
    h = inp.history
    if h is None or h.empty:
        why = inp.not_run.get("tune")
        return H.section("tuning", "Tuning", H.note(f"Not tuned this time: {why}." if why else
                                                    "tuning_history.parquet is absent: the run was not tuned."))
    units = {p: PARAMETER_UNITS.get(p, "") for p in h["parameter"].unique()}
    backend = str(h["backend"].iloc[0])
    body = H.figure(P.png(P.convergence, h, units),
                    "Posterior of each tuned loading parameter after each training window (update 0 = prior): mean, "
                    "±1σ band and 5–95 % interval; units as in the vessel YAML (β44 as a fraction of critical "
                    "damping).", "tuning convergence")
    pmfs = history_pmfs(h)
    body += "<h3>" + ("DBI marginals" if backend == "dbi" else "Marginals") + "</h3>"
    if pmfs is None:
        body += H.para("tuning_history.parquet carries no marginal PMF: the marginals below are the Gaussians with "
                       "the recorded mean and std; ticks on the axis mark the backend's own 5 % and 95 % quantiles.",
                       "")
    body += H.figure(P.png(P.marginals, h, units, pmfs),
                     "Marginal probability density of each parameter after each update ([1/parameter unit]).",
                     "marginals")
    corr = history_correlation(h)
    body += "<h3>" + ("UKF covariance" if backend == "ukf" else "Posterior correlation") + "</h3>"
    if corr is not None:
        body += H.figure(P.png(P.correlation, corr[0], corr[1], "posterior correlation after the last update"),
                         "Correlation of the tuned parameters after the last update [-].", "correlation")
    else:
        body += H.para("tuning_history.parquet carries no covariance (no cov_<parameter> columns): not shown.", "")
    t = h.copy()
    t["unit"] = t["parameter"].map(units)
    t = t[["update", "window_id", "parameter", "unit", "mean", "std", "q05", "q50", "q95", "channels_used"]]
    body += H.details("Tuning history (tuning_history.parquet)", H.table(t))
    return H.section("tuning", f"Tuning ({backend.upper()})", body)


def validation_section(inp: ReportInputs, warning: str = "") -> str:
    v = inp.validation
    if v is None or v.empty:
        why = inp.not_run.get("tune")
        return H.section("validation", "Validation", H.note(f"Not validated: {why}." if why else
                                                            "validation.parquet is absent."))
    units = {c: inp.channel_unit(c) for c in v["measurement"].str.split(":").str[0].unique()}
    body = H.alert("Tuning made the held-out prediction worse", warning) if warning else ""
    body += H.figure(P.png(P.validation_plots, v, units),
                    "Measured σ against the model's prediction with the prior (blue) and tuned (orange) loading; "
                    "open markers: held-out windows not used in tuning. Left: ratio predicted/measured [-] (band "
                    "0.8–1.25). Right: values in the channel unit (angles in deg, rates in deg/s, specific force in "
                    "m/s²).", "validation")
    ch = v["measurement"].str.split(":").str[0]
    stat = v["measurement"].str.split(":").str[1]
    f = np.where(stat == "tz", 1.0, ch.map(lambda c: P.display_unit(units.get(c, ""))[0]).to_numpy(dtype=float))
    unit = np.where(stat == "tz", "s", ch.map(lambda c: P.display_unit(units.get(c, ""))[1]))
    t = pd.DataFrame({"window": "W" + v["window_id"].astype(str), "role": v["role"], "measurement": v["measurement"],
                      "unit": unit, "measured": v["measured"] * f, "prior": v["predicted_prior"] * f,
                      "tuned": v["predicted_tuned"] * f,
                      "prior error": v["predicted_prior"] / v["measured"] - 1,
                      "tuned error": v["predicted_tuned"] / v["measured"] - 1})
    body += H.table(t, {"prior error": "%", "tuned error": "%"},
                    caption="Validation (validation.parquet); error = predicted/measured − 1",
                    formats={"prior error": _pct, "tuned error": _pct},
                    row_class=lambda r: "flag" if r["role"] == "holdout" else "")
    return H.section("validation", "Validation", body,
                     "Every accepted window predicted with the prior and the tuned loading; every third window (by "
                     "`tuning.holdout_every`) is held out of tuning and validates it.")


def _decision(r) -> str:
    """Why diagnose named or passed over a candidate (seatune.diagnosis.select's rule, in words)."""
    if r.effect == "none":
        return "baseline: the loading refitted without an effect"
    p = r.false_alarm_p
    cross = r.cross_fold_gain
    if getattr(r, "withdrawn", False):
        return (f"named at step {r.step}, then withdrawn: tested again in the sea refitted through the other named "
                "effects, it no longer passed, or a vessel effect found in a sea that had not absorbed it took over")
    untouched = getattr(r, "untouched_sea_gain", np.nan)
    if r.selected and np.isfinite(untouched):
        return (f"named at step {r.step}: held out in a sea fitted from the channels it leaves untouched, and in each "
                f"half of a 2-fold split there, ≥ {untouched:.1f} nats")
    own = getattr(r, "own_sea_gain", np.nan)
    if r.selected and np.isfinite(own):
        return (f"named at step {r.step}: held out in its own sea (the held-out windows' sea refitted through it), "
                f"and in each half of a 2-fold split so tested, ≥ {own:.1f} nats")
    if r.selected:
        return (f"named at step {r.step}: the strongest eligible candidate"
                + (f", in each fold of a 2-fold cross-validation (≥ {cross:.1f} nats)" if np.isfinite(cross) else "")
                + (f", false-alarm p {p:.2g}" if np.isfinite(p) else ""))
    why = []
    if np.isfinite(r.gain_holdout):
        if not r.gain_train > r.bic_penalty:
            why.append("training gain ≤ BIC penalty")
        if not r.gain_holdout > HOLDOUT_MIN:
            why.append(f"held-out gain ≤ {HOLDOUT_MIN:g} nats")
    elif not r.gain_train - r.bic_penalty > HOLDOUT_MIN:
        why.append(f"no held-out window: training gain − BIC penalty ≤ {HOLDOUT_MIN:g} nats")
    if r.at_bound:
        why.append(f"at a bound: {r.at_bound}" + (" (search widened to the hull's limit)" if r.widened else ""))
    if not why and np.isfinite(cross) and cross <= HOLDOUT_MIN:
        why.append(f"fits some windows only: 2-fold cross-validation gain {cross:.1f} nats ≤ {HOLDOUT_MIN:g}")
    if not why and np.isfinite(p) and not r.eligible:
        why.append(f"not significant: false-alarm p {p:.2g} against the calibrated null")
    if np.isfinite(untouched) and untouched > HOLDOUT_MIN:
        why.append(f"in a sea fitted from the channels it leaves untouched ≥ {untouched:.1f} nats held out, but at a "
                   "bound there or another vessel candidate fits that sea better")
    elif np.isfinite(untouched):
        why.append(f"held out in a sea fitted from the channels it leaves untouched, or in a half of a 2-fold split "
                   f"there: {untouched:.1f} nats ≤ {HOLDOUT_MIN:g}")
    if np.isfinite(own):
        why.append(f"held out in its own sea, or in a half of a 2-fold split so tested: {own:.1f} nats ≤ "
                   f"{HOLDOUT_MIN:g}")
    if r.eligible and not why:
        return "eligible; a stronger candidate was named"
    return "passed over: " + "; ".join(why or ["not eligible"])


def _parameters(r) -> str:
    """'q 0.0 ± 20 1/rad, …' from the JSON columns fitted, fitted_std, fitted_units."""
    fitted = json.loads(r.fitted or "{}")
    std = json.loads(getattr(r, "fitted_std", "") or "{}")
    units = json.loads(getattr(r, "fitted_units", "") or "{}")
    return ", ".join(f"{k} {v:.3g}" + (f" ± {std[k]:.2g}" if k in std else "")
                     + (f" {units[k].replace('^2', '²')}" if units.get(k) else "") for k, v in fitted.items()) or "–"


#: the diagnosis.parquet columns the section reads (those added by issue 17 are filled in for an older table)
DIAGNOSIS_COLUMNS = ("effect", "fitted", "gain_train", "gain_holdout", "bic_penalty", "at_bound", "eligible",
                     "selected", "bands_before", "bands_after", "gap_before_holdout", "gap_after_holdout",
                     "sigma_error_before_holdout", "sigma_error_after_holdout")


def diagnosis_section(inp: ReportInputs) -> str | None:
    """seatune diagnose: the verdict, the evidence per candidate, before / after gaps and the residual map."""
    d = inp.diagnosis
    if d is None or d.empty:
        return None
    older = {"step": 1, "given": "", "widened": "", "out_of_sample": "", "joint_gain_holdout": d["gain_holdout"],
             "false_alarm_p": np.nan, "null_gain_q95": np.nan, "cross_fold_gain": np.nan}
    d = d.assign(**{k: v for k, v in older.items() if k not in d})  # a diagnosis.parquet from before issue 17
    chosen = d[d["selected"]]
    row = chosen.iloc[-1] if len(chosen) else d[d["effect"] == "none"].iloc[0]  # the final model
    if len(chosen):
        own = [own_parameters_text(json.loads(r.fitted)) for r in chosen.itertuples()]
        named = ", then ".join(f"<b>{H.esc(r.effect)}</b> (fitted {H.esc(o)}; held-out gain {r.gain_holdout:.1f} "
                               "nats)" for r, o in zip(chosen.itertuples(), own, strict=True))
        verdict = (f"{named} explain{'s' if len(chosen) == 1 else ''} the misfit; held-out gap in "
                   f"{'its' if len(chosen) == 1 else 'their'} band {row['gap_before_holdout']:.3f} → "
                   f"{row['gap_after_holdout']:.3f}, σ error {100 * row['sigma_error_before_holdout']:.1f} % → "
                   f"{100 * row['sigma_error_after_holdout']:.1f} % ({row['out_of_sample']}). Written to "
                   "augmented_vessel.yaml.")
        rounds = int(row.get("alternation_rounds", 0) or 0)
        if rounds:  # diagnose alternated the named effects with the sea refitted through them
            verdict += (f" Alternated with the sea refitted through {'it' if len(chosen) == 1 else 'them'} "
                        f"({rounds} round{'s' if rounds > 1 else ''}): "
                        f"{H.esc(own_parameters_text(json.loads(row['fitted_with_sea'])))}, the values written.")
        if np.isfinite(row.get("gap_after_holdout_with_sea", np.nan)):  # each model with its own sea
            verdict += (" With each window's sea refitted through the final model, against the tuned model in the "
                        f"sea stage's sea: held-out gap {row['gap_before_holdout_with_sea']:.3f} → "
                        f"{row['gap_after_holdout_with_sea']:.3f}, σ error "
                        f"{100 * row['sigma_error_before_holdout_with_sea']:.1f} % → "
                        f"{100 * row['sigma_error_after_holdout_with_sea']:.1f} %.")
    elif row["bands_before"] != "no band of systematic misfit":
        verdict = "<b>No known effect explains the misfit</b>; the unexplained bands are listed below."
    else:
        verdict = "The tuned model fits: no band of systematic misfit, no effect named."
    body = f'<p class="intro">{verdict}</p>' + H.para("Misfit located on the training windows: "
                                                      + row["bands_before"], "")
    if len(chosen):
        body += H.para("Left after adding it: " + row["bands_after"], "")
    nat = {"held-out gain": "nat", "training gain": "nat", "BIC penalty": "nat", "null 95 %": "nat",
           "joint held-out gain": "nat"}
    deciding = pd.DataFrame({"step": d["step"], "given": d["given"].replace("", "–"), "effect": d["effect"],
                             "decision": [_decision(r) for r in d.itertuples()],
                             "held-out gain": d["gain_holdout"], "training gain": d["gain_train"],
                             "BIC penalty": d["bic_penalty"], "joint held-out gain": d["joint_gain_holdout"]})
    if np.isfinite(d["false_alarm_p"]).any():  # a calibrated run
        deciding["null 95 %"], deciding["false-alarm p"] = d["null_gain_q95"], d["false_alarm_p"]
    deciding["parameters"] = [_parameters(r) for r in d.itertuples()]
    body += H.table(deciding, nat, wide=("decision", "parameters"),
                    caption="Evidence per candidate effect and step (diagnosis.parquet): an effect named at a step "
                    "is added to the model and the others are fitted again with it (greedy forward selection); "
                    "gains are log-likelihood over the step's model (the loading refitted with the effects "
                    "`given`), joint gains over the model without effect; an effect is named when its held-out "
                    "gain exceeds "
                    f"{HOLDOUT_MIN:g} nats and its training gain the BIC penalty, with no parameter at a bound, "
                    "a vessel-side effect also in each fold of a 2-fold cross-validation over the windows, "
                    "and (calibrated runs) the gain is unlikely under the null: data simulated without effect in a "
                    "sea and vessel model erring as estimates do (diagnose.calibration); p = share of null "
                    "replicas scoring as high",
                    row_class=lambda r: "flag" if r["decision"].startswith("named") else "")
    cols = ["step", "given", "effect", "fitted", "gain_train", "gain_holdout", "bic_penalty", "at_bound", "widened",
            "eligible", "selected", "out_of_sample", "gap_before_holdout", "gap_after_holdout",
            "sigma_error_before_holdout", "sigma_error_after_holdout"]
    shown = d[cols].assign(fitted=d["fitted"].map(
        lambda text: ", ".join(f"{k} {v:.3g}" for k, v in json.loads(text).items()) or "–"))
    units = {**inp.diagnosis_units, "fitted": "units: see diagnosis.parquet fitted_units"}
    body += H.details("All evidence columns: gaps and σ errors before / after on the held-out windows",
                      H.table(shown, units, caption="gaps are the systematic RMS of ln(measured/model) in the bins "
                                                    "the candidate changes"))
    res = inp.diagnosis_residuals
    if res is not None and not res.empty:
        used = res[res["used"]]
        worst = (used.assign(a=used["log_ratio_before"].abs()).groupby("channel")["a"].mean()
                 .sort_values(ascending=False).index[:3].tolist())
        after = f"after: {' + '.join(chosen['effect'])}" if len(chosen) else "after: refitted, no effect"
        body += H.figure(P.png(P.residual_maps, res, worst, after),
                         "Residual map ln(measured / model) over ω × window for the three most misfitting channels, "
                         "before and after (red: measured above the model)", "residual map before and after")
    descriptions = "".join(f"<li><b>{H.esc(r.effect)}</b>: {H.esc(r.signature)}</li>" for r in d.itertuples()
                           if r.effect != "none" and r.step == 1)
    body += H.details("The candidate effects and their signatures", f"<ul>{descriptions}</ul>")
    return H.section("diagnosis", "Diagnosis", body,
                     "Where the tuned model still disagrees with the measurements, which known physical effect "
                     "explains it (fitted on the training windows with the loading, scored on the held-out ones) "
                     "and how much of the gap it closes.")


def prediction_section(inp: ReportInputs) -> str | None:
    """seatune predict (Han A5): exceedance probability against heading at the riskiest forecast time."""
    pred = inp.prediction
    if pred is None or pred.empty:
        return None
    first = pred.iloc[0]
    unit = inp.prediction_units.get("limit", "")
    tuned = pred[pred["model"] == "tuned"] if (pred["model"] == "tuned").any() else pred
    worst_time = tuned.groupby("time")["optimal_probability"].max().idxmax()
    at = pred[pred["time"] == worst_time]
    what = (f"P(max {first['channel']} > {first['limit']:g} {unit} in {first['duration_s'] / 3600:g} h) [%] at "
            f"{pd.Timestamp(worst_time):%Y-%m-%d %H:%M} UTC")
    body = H.figure(P.png(P.exceedance_polar, at, what),
                    "Probability that the largest response of the sea state exceeds the limit, against compass heading "
                    "(north up, clockwise), mixed over the remaining loading uncertainty and the forecast's Hs/Tp/"
                    "direction hypotheses (A5 eqs. 3.11–3.12); dots: the advised heading (eq. 3.13).",
                    "exceedance against heading")
    best = pred[pred["is_optimal"]].copy()
    table = best.pivot_table(index="time", columns="model", values=["optimal_heading_deg", "optimal_probability"],
                             aggfunc="first")
    table.columns = [f"{'heading' if a == 'optimal_heading_deg' else 'P'} ({m})" for a, m in table.columns]
    table = table.reset_index()
    table["time"] = table["time"].map(lambda t: f"{pd.Timestamp(t):%Y-%m-%d %H:%M}")
    fmt = {c: (lambda v: f"{100 * v:.1f} %") for c in table.columns if c.startswith("P ")}
    fmt.update({c: (lambda v: f"{v:.0f}°") for c in table.columns if c.startswith("heading")})
    body += H.table(table, caption="Advised heading and its exceedance probability per forecast time "
                                   "(prediction.parquet)", formats=fmt)
    return H.section("prediction", "Prediction", body,
                     "Decision support from the tuned model: how likely the critical response exceeds its limit in "
                     "the coming sea states, and the heading that minimises it — with the prior model beside it, so "
                     "the value of tuning shows.")


def artefacts_section(inp: ReportInputs) -> str:
    t = pd.DataFrame(inp.artefacts, columns=["file", "size", "fingerprint"])
    t["size"] = t["size"] / 1024.0
    return H.section("artefacts", "Artefacts", H.table(t, {"size": "kB"}, formats={"size": lambda v: f"{v:,.1f}"}),
                     "The run directory this page was built from; the fingerprint is the hash of each stage's inputs "
                     "and settings.")


def build_report(inp: ReportInputs, row: dict, units: dict[str, str]) -> str:
    """The HTML page (a string)."""
    with P.drawn_together() as figures:
        page = _page(inp, row, units)
    return figures.fill(page)


def _page(inp: ReportInputs, row: dict, units: dict[str, str]) -> str:
    def unless_not_run(stage: str, anchor: str, title: str, make):
        why = inp.not_run.get(stage)
        return H.section(anchor, title, H.note(f"Not run this time: {why}.")) if why else make()

    parts = [summary_section(inp, row, units), defects_section(inp), windows_section(inp),
             unless_not_run("filter", "filter", "Filter cutoffs and statistics", lambda: filter_section(inp)),
             sea_section(inp),
             unless_not_run("identify", "raos", "Measured vs model RAOs", lambda: raos_section(inp)),
             spectra_section(inp),
             unless_not_run("identify", "natural-frequencies", "Natural frequencies",
                            lambda: natural_frequencies_section(inp, inp.tuned_omega_n)),
             tuning_section(inp), validation_section(inp, tuned_worse(row)), prediction_section(inp),
             diagnosis_section(inp), artefacts_section(inp)]
    sections = []
    for body in parts:
        if body is None:
            continue
        m = re.match(r'<section id="([^"]+)"><h2>(.*?)</h2>', body)
        sections.append((m.group(1), html.unescape(m.group(2)), body))
    subtitle = (f"vessel {inp.vessel_name} · {inp.time_span[0]:%Y-%m-%d} · {row['hours_logged']:.1f} h logged · "
                f"{row['windows_accepted']} of {row['windows_candidates']} windows accepted")
    footer = (f"seatune {H.esc(inp.version)} · inputs fingerprint <code>{H.esc(inp.fingerprint)}</code> · "
              f"run file {H.esc(inp.run_file)}. Files keep SI units and radians; this page shows angles in degrees.")
    return H.page(f"seatune report — run {inp.run_name}", subtitle, sections, footer, inp.fingerprint)

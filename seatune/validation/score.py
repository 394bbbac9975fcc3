"""Scoring a seatune run against the truth of a blind trial, and the bank's figures against issue 15's targets.

Pure computation: a trial's truth (truth.yaml as a dict) and its run artefacts (DataFrames) in, one row out;
the bank's rows in, the figures out. Nothing here reads or writes files.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.special import erf

from seatune.diagnosis.effects import SEA_SIDE
from seatune.identification.sea_estimation import direction_difference_deg

VESSEL_EFFECTS = ("quadratic_roll_damping", "moonpool", "anti_roll_tank", "imu_lever_arm", "imu_misalignment")
SEA_EFFECTS = SEA_SIDE
DOFS = ("heave", "roll", "pitch")
PARAMETERS = ("gmt_fs", "r44", "beta44", "xcg", "r55")
# issue 15's targets: parameter → (tolerance, "abs" | "rel")
PARAMETER_TOLERANCE = {"gmt_fs": (0.05, "abs"), "r44": (0.02, "rel"), "beta44": (0.005, "abs")}
TARGETS = {"false_alarm_rate": 0.05, "effect_hit_rate": 0.90, "compound_both_rate": 0.80, "omega_reported": 1.0,
           "omega_within_2pct": 1.0, "parameter_within_tolerance": 1.0, "coverage_2sigma": 0.90,
           "effect_parameter_within_tolerance": 1.0, "heldout_gap_halved": 1.0}
# issue 17's targets for a correctly named effect's fitted parameters: effect → parameter → (tolerance, kind)
EFFECT_TOLERANCE = {"moonpool": {"omega_p": (0.03, "rel"), "area": (0.25, "rel")},
                    "imu_lever_arm": {"dx": (1.0, "abs"), "dy": (1.0, "abs"), "dz": (1.0, "abs")},
                    "quadratic_roll_damping": {"q": (0.25, "rel")},
                    "anti_roll_tank": {"omega_t": (0.03, "rel")}}


def verdict(true_effects: set[str], named: set[str]) -> str:
    """correct_none / false_alarm on a clean trial; hit / partial / wrong_effect / miss on a trial with effects.
    Only vessel-side names count: a sea-side explanation (missing swell, Hs bias) of a clean trial is no alarm."""
    named = named & set(VESSEL_EFFECTS)
    if not true_effects:
        return "correct_none" if not named else "false_alarm"
    if true_effects <= named:
        return "hit"
    if true_effects & named:
        return "partial"
    return "wrong_effect" if named else "miss"


def final_posterior(history: pd.DataFrame | None) -> dict[str, tuple[float, float]]:
    """{parameter: (mean, std)} after the last update of tuning_history.parquet."""
    if history is None or history.empty:
        return {}
    last = history[history["update"] == history["update"].max()]
    return {r.parameter: (float(r.mean), float(r.std)) for r in last.itertuples()}


def heldout_error(validation: pd.DataFrame | None, column: str) -> float:
    """Mean |ln(predicted/measured)| of σ over the held-out windows (as `seatune tune` prints it)."""
    if validation is None or validation.empty:
        return np.nan
    held = validation[validation["role"] == "holdout"]
    held = held if len(held) else validation
    return float(np.mean(np.abs(np.log(held[column] / held["measured"]))))


def primary_modes(nf: pd.DataFrame | None, measured_only: bool = False) -> dict[str, dict]:
    """{dof: {omega_n, ci_low, ci_high, reason}} of identify's combined estimate, as the report picks it
    (`identification.natural_frequency.primary_natural_frequencies`), lower-case DOF names."""
    from seatune.identification.natural_frequency import primary_natural_frequencies

    if nf is None or nf.empty:
        return {}
    return {str(dof).lower(): {"omega_n": float(r["omega_n"]), "ci_low": float(r["ci_low"]),
                               "ci_high": float(r["ci_high"]), "reason": str(r.get("reason", "") or "")}
            for dof, r in primary_natural_frequencies(nf, measured_only).iterrows()}


def score_trial(truth: dict, artefacts: dict[str, pd.DataFrame | None], model_modes: dict[str, float] | None = None,
                status: str = "ok", message: str = "", tuned_modes: dict[str, float] | None = None,
                reference: dict[str, tuple[float, float]] | None = None,
                read: dict[str, tuple[float, float]] | None = None) -> dict:
    """One row of bank_summary.parquet. `artefacts`: tuning_history, validation, natural_frequencies (the final:
    diagnose's where it wrote them, then identify's are natural_frequencies_stage), diagnosis (None when missing);
    `model_modes`: the vessel model's coupled ω_n at the true loading by DOF; `tuned_modes`:
    the tuned model's; `reference`: the posterior {parameter: (mean, std)} of the same run tuned with the true
    sea (validation/true_sea.py); `read`: {parameter: (value, std)} the sea fit read (sea_states.parquet)."""
    true_effects = {e["kind"] for e in truth.get("effects") or []}
    diag = artefacts.get("diagnosis")
    named = set() if diag is None else {str(e) for e in diag.loc[diag["selected"].astype(bool), "effect"]} - {"none"}
    row = {"trial": truth["trial"], "hull": truth.get("hull", ""), "category": truth.get("category", ""),
           "status": status, "message": message,
           "hindcast_layout": (truth.get("hindcast") or {}).get("layout", ""),
           "missing_swell": bool((truth.get("hindcast") or {}).get("missing_swell", False)),
           "n_windows": len(truth.get("windows") or []),
           "true_effects": "+".join(sorted(true_effects)) or "none",
           "named_effects": "+".join(sorted(named & set(VESSEL_EFFECTS))) or "none",
           "named_sea_side": "+".join(sorted(named & set(SEA_EFFECTS))) or "none",
           # a vessel effect named beside the true ones (on a clean trial that is the false alarm)
           "wrong_extra_names": "+".join(sorted((named & set(VESSEL_EFFECTS)) - true_effects)) if true_effects
           else "",
           "verdict": verdict(true_effects, named) if status == "ok" else "failed"}
    post = final_posterior(artefacts.get("tuning_history"))
    for p in PARAMETERS:
        t = float(truth["loading"][p]) if p in truth.get("loading", {}) else np.nan
        mean, std = post.get(p, (np.nan, np.nan))
        err = mean - t
        row |= {f"{p}_truth": t, f"{p}_estimate": mean, f"{p}_std": std, f"{p}_error": err,
                f"{p}_within_2sigma": bool(abs(err) <= 2 * std) if np.isfinite(err) else None}
        if p in PARAMETER_TOLERANCE:
            tol, kind = PARAMETER_TOLERANCE[p]
            tol = tol * (abs(t) if kind == "rel" else 1.0)
            row[f"{p}_within_tolerance"] = bool(abs(err) <= tol) if np.isfinite(err) else None
            # what a calibrated posterior reaches: P(|error| ≤ tolerance) for an error ~ N(0, σ̂²)
            row[f"{p}_within_tolerance_expected"] = float(erf(tol / (std * np.sqrt(2.0)))) if std > 0 else np.nan
            row[f"{p}_error_z"] = err / std if std > 0 else np.nan
            if reference is not None:
                ref_mean, ref_std = reference.get(p, (np.nan, np.nan))
                row |= {f"{p}_true_sea_estimate": ref_mean, f"{p}_true_sea_std": ref_std,
                        f"{p}_true_sea_within_tolerance": bool(abs(ref_mean - t) <= tol)
                        if np.isfinite(ref_mean) else None,
                        f"{p}_as_true_sea": bool(abs(mean - ref_mean) <= ref_std)
                        if np.isfinite(ref_mean) and np.isfinite(mean) else None}
    for p, (value, std) in (read or {}).items():
        t = float(truth["loading"].get(p, np.nan))
        row |= {f"{p}_read": value, f"{p}_read_std": std, f"{p}_read_error": value - t,
                f"{p}_read_error_z": (value - t) / std if std > 0 else np.nan}
    modes = primary_modes(artefacts.get("natural_frequencies"))
    measured = primary_modes(artefacts.get("natural_frequencies"), measured_only=True)  # without the loading prior
    # identify's own, where `natural_frequencies` is diagnose's (in the sea refitted through the named effects)
    stage = primary_modes(artefacts["natural_frequencies_stage"]) if artefacts.get(
        "natural_frequencies_stage") is not None else modes
    for d in DOFS:
        t = float((truth.get("natural_frequencies") or {}).get(d, np.nan))
        m = modes.get(d, {"omega_n": np.nan, "ci_low": np.nan, "ci_high": np.nan, "reason": ""})  # silent
        reported = bool(np.isfinite(m["omega_n"]))
        model = (model_modes or {}).get(d, np.nan)
        row |= {f"omega_{d}_truth": t, f"omega_{d}_reported": reported, f"omega_{d}_estimate": m["omega_n"],
                f"omega_{d}_rel_error": m["omega_n"] / t - 1 if reported else np.nan,
                f"omega_{d}_truth_in_ci": bool(m["ci_low"] <= t <= m["ci_high"]) if reported else None,
                f"omega_{d}_reason": "" if reported else m["reason"],
                f"omega_{d}_model_at_truth": model, f"omega_{d}_model_rel_error": model / t - 1,
                f"omega_{d}_model_in_ci": bool(m["ci_low"] <= model <= m["ci_high"]) if reported else None,
                f"omega_{d}_tuned_model_rel_error": (tuned_modes or {}).get(d, np.nan) / t - 1,
                f"omega_{d}_measured_rel_error": measured.get(d, {}).get("omega_n", np.nan) / t - 1,
                f"omega_{d}_stage_rel_error": stage.get(d, m)["omega_n"] / t - 1}
    row["heldout_error_prior"] = heldout_error(artefacts.get("validation"), "predicted_prior")
    row["heldout_error_tuned"] = heldout_error(artefacts.get("validation"), "predicted_tuned")
    return row | named_effect_scores(truth.get("effects") or [], diag)


def named_effect_scores(true_effects: list[dict], diag: pd.DataFrame | None) -> dict:
    """Issue 17's figures of a trial whose effects were named: each correctly named effect's fitted parameters
    against the truth (as the last selected step refitted them; a parameter of an effect named earlier is
    `effect.parameter` there), and the held-out gap of that step before and after (its shrink): the tuned model in
    the sea stage's sea against the final model in the sea refitted through it where diagnose refitted one, and
    (`_common_sea`) both in the sea stage's sea as the selection scored them."""
    import json

    out = {f"{e}_{p}_{k}": (None if k == "within" else np.nan)
           for e, params in EFFECT_TOLERANCE.items() for p in params for k in ("truth", "fitted", "within")}
    out["heldout_gap_shrink"] = out["heldout_gap_shrink_common_sea"] = np.nan
    if diag is None or "fitted" not in diag or not diag["selected"].astype(bool).any():
        return out
    chosen = diag[diag["selected"].astype(bool) & diag["effect"].isin(VESSEL_EFFECTS)]
    if chosen.empty:
        return out
    last = chosen.loc[chosen["step"].idxmax()]
    refined = last.get("fitted_with_sea", "")  # after diagnose's alternation with the sea, where it ran
    fitted = json.loads(refined or last["fitted"]) if isinstance(last["fitted"], str) else {}
    named = set(chosen["effect"]) | {g for g in str(last["given"] or "").split("+") if g}
    right = False
    for effect in true_effects:
        kind = effect["kind"]
        if kind not in named:
            continue
        right = True
        for p, (tol, how) in EFFECT_TOLERANCE.get(kind, {}).items():
            value = fitted.get(p if last["effect"] == kind else f"{kind}.{p}", np.nan)
            t = float(effect[p])
            out |= {f"{kind}_{p}_truth": t, f"{kind}_{p}_fitted": float(value),
                    f"{kind}_{p}_within": bool(abs(value - t) <= tol * (abs(t) if how == "rel" else 1.0))
                    if np.isfinite(value) else None}
    if right and last["gap_before_holdout"] > 0:
        out["heldout_gap_shrink_common_sea"] = float(1.0 - last["gap_after_holdout"] / last["gap_before_holdout"])
        before, after = last.get("gap_before_holdout_with_sea", np.nan), last.get("gap_after_holdout_with_sea", np.nan)
        out["heldout_gap_shrink"] = (float(1.0 - after / before) if before > 0 and np.isfinite(after)
                                     else out["heldout_gap_shrink_common_sea"])
    return out


def match_windows(truth_windows: list[dict], windows: pd.DataFrame) -> dict[str, dict]:
    """{seatune window_id: the truth window it overlaps most} for the accepted windows."""
    out = {}
    starts = [pd.Timestamp(w["start"]) for w in truth_windows]
    ends = [pd.Timestamp(w["end"]) for w in truth_windows]
    for r in windows[windows["accepted"]].itertuples():
        overlap = [min(e, r.end) - max(s, r.start) for s, e in zip(starts, ends, strict=True)]
        k = int(np.argmax(overlap))
        if overlap[k] > pd.Timedelta(0):
            out[str(r.window_id)] = truth_windows[k]
    return out


def sea_rows(truth: dict, sea: pd.DataFrame | None, windows: pd.DataFrame | None) -> list[dict]:
    """Per window and true partition: found (an estimated wave system within 30 % in Tp and 45° in direction,
    each system used once, nearest first), the estimate's errors and the hindcast's; plus one row per estimated
    system absent from the hindcast that matches no true partition (a false system)."""
    from seatune.pipeline.sea import system_table

    if sea is None or windows is None or sea.empty:
        return []
    systems = system_table(sea)
    rows = []
    for wid, tw in match_windows(truth.get("windows") or [], windows).items():
        est = systems[systems["window_id"] == wid].reset_index(drop=True)
        parts = tw.get("partitions") or []
        pairs = []
        for i, p in enumerate(parts):
            for j, e in est.iterrows():
                dtp = abs(e["tp"] - p["tp"]) / p["tp"]
                ddir = direction_difference_deg(e["dir_from_deg"], p["dir_from_deg"])
                if dtp < 0.3 and ddir < 45.0:
                    pairs.append((dtp / 0.3 + ddir / 45.0, i, j))
        match, used = {}, set()
        for _, i, j in sorted(pairs):
            if i not in match and j not in used:
                match[i] = j
                used.add(j)
        for i, p in enumerate(parts):
            e = est.loc[match[i]] if i in match else None
            hc_hs = float(e["hindcast_hs"]) if e is not None else np.nan
            rows.append({"trial": truth["trial"], "window_id": wid, "kind": p["kind"], "truth_hs": p["hs"],
                         "truth_tp": p["tp"], "truth_dir_from_deg": p["dir_from_deg"],
                         "in_hindcast": bool(p.get("in_hindcast", True)), "found": e is not None,
                         "hs_rel_error": float(e["hs"] / p["hs"] - 1) if e is not None else np.nan,
                         "tp_rel_error": float(e["tp"] / p["tp"] - 1) if e is not None else np.nan,
                         "dir_error_deg": (float(direction_difference_deg(e["dir_from_deg"], p["dir_from_deg"]))
                                           if e is not None else np.nan),
                         "hindcast_hs_rel_error": hc_hs / p["hs"] - 1 if np.isfinite(hc_hs) else np.nan,
                         "false_system": False})
        for j, e in est.iterrows():
            if j not in used and not bool(e["in_hindcast"]):
                rows.append({"trial": truth["trial"], "window_id": wid, "kind": "false", "truth_hs": np.nan,
                             "truth_tp": np.nan, "truth_dir_from_deg": np.nan, "in_hindcast": False, "found": False,
                             "hs_rel_error": np.nan, "tp_rel_error": np.nan, "dir_error_deg": np.nan,
                             "hindcast_hs_rel_error": np.nan, "false_system": True, "false_hs": float(e["hs"])})
    return rows


def sea_metrics(sea: pd.DataFrame, estimate: str = "final") -> pd.DataFrame:
    """Issue 16's sea figures over the bank's windows; targets on the `final` estimate (refitted through the
    named vessel effects), the sea stage's own estimate beside it (its groups say so)."""
    out = []

    def add(metric, group, value, n, target=None):
        if estimate != "final":
            group, target = f"{group} ({estimate})", None
        out.append({"metric": metric, "group": group, "value": value, "n": n, "target": _target(target),
                    "passed": None if target is None or not np.isfinite(value) else bool(value >= target)})

    if sea.empty:
        return pd.DataFrame(out, columns=["metric", "group", "value", "n", "target", "passed"])
    parts = sea[~sea["false_system"]]
    missing = parts[~parts["in_hindcast"] & (parts["truth_hs"] >= 0.5)]
    add("sea_missing_found_rate", "swell absent from the hindcast, Hs >= 0.5 m", *_rate(missing["found"]), 0.90)
    found = missing[missing["found"]]
    add("sea_missing_hs_within_15pct", "found", *_rate(found["hs_rel_error"].abs() <= 0.15), 0.90)
    add("sea_missing_tp_within_10pct", "found", *_rate(found["tp_rel_error"].abs() <= 0.10), 0.90)
    add("sea_missing_dir_within_15deg", "found", *_rate(found["dir_error_deg"] <= 15.0), 0.90)
    # the bias beside the rates: a rate misses for scatter or for an offset, which call for different remedies
    add("sea_missing_hs_median_rel_error", "found", *_median(found["hs_rel_error"]))
    wind = parts[parts["kind"] == "wind_sea"]
    add("sea_wind_found_rate", "wind sea", *_rate(wind["found"]))
    add("sea_wind_hs_within_10pct", "wind sea", *_rate(wind["found"] & (wind["hs_rel_error"].abs() <= 0.10)), 0.80)
    better = wind["found"] & ~(wind["hs_rel_error"].abs() > wind["hindcast_hs_rel_error"].abs().fillna(np.inf))
    add("sea_wind_hs_better_than_hindcast", "wind sea", *_rate(better), 0.80)
    add("sea_wind_hs_median_rel_error", "wind sea", *_median(wind.loc[wind["found"], "hs_rel_error"]))
    swell = parts[parts["kind"].str.startswith("swell") & parts["in_hindcast"]]
    add("sea_swell_found_rate", "swell in the hindcast", *_rate(swell["found"]))
    fs = swell[swell["found"]]
    add("sea_swell_hs_within_15pct", "swell in the hindcast", *_rate(fs["hs_rel_error"].abs() <= 0.15))
    add("sea_swell_hs_median_rel_error", "swell in the hindcast", *_median(fs["hs_rel_error"]))
    n_windows = sea["window_id"].astype(str).str.cat(sea["trial"], sep="@").nunique()
    add("sea_false_systems_per_window", "systems absent from the hindcast matching no true one",
        float(sea["false_system"].sum()) / max(n_windows, 1), n_windows)
    return pd.DataFrame(out)


EFFECT_UNITS = {"omega_p": "rad/s", "area": "m^2", "dx": "m", "dy": "m", "dz": "m", "q": "1/rad", "omega_t": "rad/s"}


def summary_units(columns) -> dict[str, str]:
    units = {}
    effect_columns = {f"{e}_{p}_{k}": EFFECT_UNITS[p] for e, params in EFFECT_TOLERANCE.items() for p in params
                      for k in ("truth", "fitted")}
    for c in columns:
        if c in effect_columns:
            units[c] = effect_columns[c]
        elif c.startswith("heldout_gap_shrink") or c.endswith(("_error_z", "_within_tolerance_expected")):
            units[c] = "dimensionless"
        elif c.startswith("omega_") and c.endswith(("_truth", "_estimate", "_model_at_truth")):
            units[c] = "rad/s"
        elif c.endswith(("_rel_error", "_model_rel_error")) or c.startswith("heldout_error"):
            units[c] = "dimensionless"
        elif c.split("_")[0] in ("gmt", "r44", "xcg", "r55") and c.endswith(("_truth", "_estimate", "_std", "_error",
                                                                               "_read")):
            units[c] = "m"
        elif c.startswith("beta44") and c.endswith(("_truth", "_estimate", "_std", "_error")):
            units[c] = "dimensionless"
        else:
            units[c] = ""
    return units


def _target(target: float | None) -> float:
    """A figure's target as a float, NaN where it has none (a column of one dtype in every metrics table)."""
    return np.nan if target is None else float(target)


def _median(x: pd.Series) -> tuple[float, int]:
    x = x.dropna()
    return (float(x.median()) if len(x) else float("nan")), int(len(x))


def _mean(x: pd.Series) -> tuple[float, int]:
    x = x.dropna()
    return (float(x.mean()) if len(x) else float("nan")), int(len(x))


def _rms(x: pd.Series) -> tuple[float, int]:
    x = x.dropna()
    return (float(np.sqrt((x**2).mean())) if len(x) else float("nan")), int(len(x))


def _rate(x: pd.Series) -> tuple[float, int]:
    x = x.dropna().astype(bool)
    return (float(x.mean()) if len(x) else np.nan), int(len(x))


def bank_metrics(summary: pd.DataFrame) -> pd.DataFrame:
    """One row per figure: metric, group, value, n (trials it is over), target, passed (None without target)."""
    ok = summary[summary["status"] == "ok"]
    out = []

    def add(metric, group, value, n, target=None, higher_better=True):
        passed = None if target is None or not np.isfinite(value) else bool(
            value >= target if higher_better else value <= target)
        out.append({"metric": metric, "group": group, "value": value, "n": n, "target": _target(target),
                    "passed": passed})

    add("runs_ok", "all", float(len(ok)), len(summary))
    clean = ok[ok["category"] == "clean"]
    for group, part in (("clean", clean), ("clean, hindcast missing a swell", clean[clean["missing_swell"]]),
                        ("clean, full hindcast", clean[~clean["missing_swell"]])):
        add("false_alarm_rate", group, *_rate(part["verdict"] == "false_alarm"), TARGETS["false_alarm_rate"],
            higher_better=False)
    for effect in VESSEL_EFFECTS:
        part = ok[ok["category"] == effect]
        add("effect_hit_rate", effect, *_rate(part["verdict"] == "hit"), TARGETS["effect_hit_rate"])
    comp = ok[ok["category"] == "compound"]
    add("compound_both_rate", "compound", *_rate(comp["verdict"] == "hit"), TARGETS["compound_both_rate"])
    add("compound_one_or_more_rate", "compound", *_rate(comp["verdict"].isin(["hit", "partial"])))
    effects = ok[ok["category"] != "clean"]
    if "wrong_extra_names" in effects:
        add("wrong_extra_name_rate", "trials with effects", *_rate(effects["wrong_extra_names"].fillna("") != ""),
            TARGETS["false_alarm_rate"], higher_better=False)
    for p in PARAMETERS:  # the loading the sea fit read: its error against its own σ
        if f"{p}_read_error" not in ok:
            continue
        read = ok[ok[f"{p}_read_error"].notna()]
        add("read_median_abs_error", p, float(read[f"{p}_read_error"].abs().median()), len(read))
        add("read_within_2sigma", p, *_rate(read[f"{p}_read_error_z"].abs() <= 2.0), TARGETS["coverage_2sigma"])
        add("read_error_z_rms", p, *_rms(read[f"{p}_read_error_z"]))
    for p in PARAMETERS:
        err = ok[f"{p}_error"].dropna()
        if err.empty:
            continue
        add("parameter_median_abs_error", p, float(err.abs().median()), len(err))
        add("parameter_p90_abs_error", p, float(err.abs().quantile(0.9)), len(err))
        if f"{p}_within_tolerance" in ok:
            add("parameter_within_tolerance", p, *_rate(ok[f"{p}_within_tolerance"]),
                TARGETS["parameter_within_tolerance"])
        add("coverage_2sigma", p, *_rate(ok[f"{p}_within_2sigma"]), TARGETS["coverage_2sigma"])
        if f"{p}_as_true_sea" in ok:  # issue 16: clean trials, degraded hindcasts, against the true sea given
            clean = ok[(ok["category"] == "clean") & ok[f"{p}_as_true_sea"].notna()]
            add("parameter_within_tolerance_clean", p, *_rate(clean[f"{p}_within_tolerance"]),
                TARGETS["parameter_within_tolerance"])
            add("parameter_within_tolerance_clean_true_sea", p, *_rate(clean[f"{p}_true_sea_within_tolerance"]))
            # the tolerance against the information in the records: a calibrated posterior's expected rate, and
            # whether the posteriors are calibrated (rms of error / σ̂ near 1)
            add("parameter_within_tolerance_clean_expected", p, *_mean(clean[f"{p}_within_tolerance_expected"]))
            add("parameter_error_z_rms_clean", p, *_rms(clean[f"{p}_error_z"]))
            add("estimated_sea_within_1sigma_of_true_sea", p, *_rate(clean[f"{p}_as_true_sea"]), 1.0)
    for d in DOFS:
        add("omega_value_or_reason", d, *_rate(ok[f"omega_{d}_reported"] | (ok[f"omega_{d}_reason"] != "")),
            TARGETS["omega_reported"])
        add("omega_reported_with_value", d, *_rate(ok[f"omega_{d}_reported"]))
        reported = ok[ok[f"omega_{d}_reported"] & ok[f"omega_{d}_truth"].notna()]  # a root the generator labelled
        add("omega_within_2pct", d, *_rate(reported[f"omega_{d}_rel_error"].abs() <= 0.02),
            TARGETS["omega_within_2pct"])
        rel = reported[f"omega_{d}_rel_error"].abs()
        add("omega_median_abs_rel_error", d, float(rel.median()) if len(rel) else np.nan, len(rel))
        alone = ok[f"omega_{d}_measured_rel_error"].dropna().abs()  # the admittance fit without the loading prior
        add("measured_omega_within_2pct", d, *_rate(alone <= 0.02))
        stage = reported[f"omega_{d}_stage_rel_error"].abs()  # identify's, before diagnose's sea refit
        add("identify_stage_omega_within_2pct", d, *_rate(stage <= 0.02))
        add("omega_truth_in_ci", d, *_rate(reported[f"omega_{d}_truth_in_ci"]))
        add("model_mode_max_abs_rel_error", d, float(ok[f"omega_{d}_model_rel_error"].abs().max()), len(ok),
            0.005, higher_better=False)
        add("model_mode_in_measured_ci", d, *_rate(reported[f"omega_{d}_model_in_ci"]), 0.90)
        tuned = ok[f"omega_{d}_tuned_model_rel_error"].dropna().abs()
        add("tuned_model_mode_median_abs_rel_error", d, float(tuned.median()) if len(tuned) else np.nan, len(tuned))
        add("tuned_model_mode_within_2pct", d, *_rate(tuned <= 0.02))
    for effect, params in EFFECT_TOLERANCE.items():  # issue 17: where the effect was named correctly
        for p in params:
            if f"{effect}_{p}_within" in ok:
                add("effect_parameter_within_tolerance", f"{effect}.{p}", *_rate(ok[f"{effect}_{p}_within"]),
                    TARGETS["effect_parameter_within_tolerance"])
    if "heldout_gap_shrink" in ok:
        shrink = ok["heldout_gap_shrink"].dropna()
        add("heldout_gap_halved", "correctly named", *_rate(shrink >= 0.5), TARGETS["heldout_gap_halved"])
        add("heldout_gap_median_shrink", "correctly named", float(shrink.median()) if len(shrink) else np.nan,
            len(shrink))
        common = ok["heldout_gap_shrink_common_sea"].dropna()  # the selection's evidence, both in the sea stage's sea
        add("heldout_gap_halved", "correctly named, common sea", *_rate(common >= 0.5))
    for col in ("heldout_error_prior", "heldout_error_tuned"):
        v = ok[col].dropna()
        add(f"median_{col}", "all", float(v.median()) if len(v) else np.nan, len(v))
    add("heldout_improved_rate", "all", *_rate((ok["heldout_error_tuned"] < ok["heldout_error_prior"])
                                                [ok["heldout_error_prior"].notna()]))
    return pd.DataFrame(out)


def confusion(summary: pd.DataFrame) -> pd.DataFrame:
    """Trials counted by truth category (rows) × vessel-side effects named (columns, 'none' included)."""
    ok = summary[summary["status"] == "ok"]
    return pd.crosstab(ok["category"], ok["named_effects"]).sort_index()

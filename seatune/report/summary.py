"""Key figures of one run: the single row of summary.parquet, also shown at the top of the report."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from seatune.identification.natural_frequency import primary_natural_frequencies
from seatune.report.inputs import ReportInputs

DOFS = ("Heave", "Roll", "Pitch")
# always present (NaN when not derived): a stable schema
DERIVED = {"displacement": "t", "r44": "m", "gm": "m", "r55": "m"}
PARAMETER_UNITS = {"mass": "kg", "displacement": "m^3", "xcg": "m", "ycg": "m", "zcg": "m", "r44": "m", "r55": "m",
                   "r66": "m", "gmt_fs": "m", "gml_fs": "m", "beta33": "dimensionless",
                   "beta44": "dimensionless", "beta55": "dimensionless"}
NOT_DEFECTS = ("records",)  # ingest counts that describe the data rather than a repair


def derived_values(nf: pd.DataFrame) -> dict[str, tuple[float, float, str, str]]:
    """{key: (value, std, unit, label)} from natural_frequencies.parquet's `derived` ("r44 [m] (GM 1.777 m)")."""
    out = {}
    if "derived" not in nf:
        return out
    for row in nf.dropna(subset=["derived"]).itertuples():
        m = re.match(r"\s*([^\[]+?)\s*\[([^\]]*)\]", str(row.derived))
        key = re.sub(r"\W+", "_", (m.group(1) if m else str(row.derived)).strip().lower()).strip("_")
        out.setdefault(key, (float(row.derived_value), float(row.derived_std), m.group(2) if m else "",
                             str(row.derived)))
    return out


def defect_counts(meta: dict) -> dict[str, int]:
    return {k: int(v) for k, v in (meta.get("counts") or {}).items() if k not in NOT_DEFECTS}


def posterior_table(history: pd.DataFrame | None) -> pd.DataFrame:
    """Per tuned parameter: prior (update 0) and posterior (last update) mean, std, q05, q95."""
    if history is None or history.empty:
        return pd.DataFrame(columns=["prior_mean", "prior_std", "mean", "std", "q05", "q95"])
    first = history[history["update"] == history["update"].min()].set_index("parameter")
    last = history[history["update"] == history["update"].max()].set_index("parameter")
    out = last[["mean", "std", "q05", "q95"]].copy()
    out.insert(0, "prior_std", first["std"].reindex(out.index))
    out.insert(0, "prior_mean", first["mean"].reindex(out.index))
    return out


def held_out_error(validation: pd.DataFrame | None) -> tuple[float, float, int]:
    """Mean |ln(predicted / measured)| of σ over the held-out windows (all windows when none is held out),
    for the prior and the tuned model, and the number of held-out windows."""
    if validation is None or validation.empty:
        return np.nan, np.nan, 0
    held = validation[validation["role"] == "holdout"]
    n_held = int(held["window_id"].nunique())
    held = held if len(held) else validation
    sig = held[held["measurement"].str.endswith(":sigma")]
    held = sig if len(sig) else held
    meas = held["measured"].to_numpy(dtype=float)

    def err(col):
        return float(np.mean(np.abs(np.log(held[col].to_numpy(dtype=float) / meas))))

    return err("predicted_prior"), err("predicted_tuned"), n_held


def key_figures(inp: ReportInputs) -> tuple[dict, dict[str, str]]:
    """The summary row and the unit of each of its columns."""
    w = inp.windows
    row: dict = {"run": inp.run_name, "vessel": inp.vessel_name, "seatune_version": inp.version,
                 "backend": "", "hours_logged": (inp.time_span[1] - inp.time_span[0]).total_seconds() / 3600.0,
                 "samples": int(inp.samples), "records": int((inp.ingest_meta.get("counts") or {}).get("records", 0)),
                 "defects_repaired": int(sum(defect_counts(inp.ingest_meta).values())),
                 "truncated_logs": len(inp.ingest_meta.get("truncated_logs") or []),
                 "windows_candidates": len(w), "windows_accepted": int(w["accepted"].sum()),
                 "accepted_minutes": float(w.loc[w["accepted"], "duration_s"].sum() / 60.0),
                 "windows_low_confidence": int(inp.raos.loc[(inp.raos["scope"] == "window")
                                                            & inp.raos["low_confidence"], "window_id"].nunique())}
    units = {k: "" for k in row} | {"hours_logged": "h", "accepted_minutes": "min"}
    best = primary_natural_frequencies(inp.natural_frequencies)  # with the loading prior where identify has it
    measured = primary_natural_frequencies(inp.natural_frequencies, measured_only=True)
    nf_final = inp.natural_frequencies_diagnosed  # in the sea refitted through the named effects, if diagnose wrote it
    final = primary_natural_frequencies(nf_final) if nf_final is not None and len(nf_final) else best
    for dof in DOFS:
        key = f"omega_n_{dof.lower()}"
        r = best.loc[dof] if dof in best.index else None
        for suffix, col in (("", "omega_n"), ("_ci_low", "ci_low"), ("_ci_high", "ci_high"), ("_prior", "model_prior")):
            row[key + suffix] = float(r[col]) if r is not None else np.nan
            units[key + suffix] = "rad/s"
        row[key + "_measured"] = float(measured.loc[dof, "omega_n"]) if dof in measured.index else np.nan
        units[key + "_measured"] = "rad/s"
        row[key + "_tuned"] = float((inp.tuned_omega_n or {}).get(dof, np.nan))
        units[key + "_tuned"] = "rad/s"
        row[key + "_final"] = float(final.loc[dof, "omega_n"]) if dof in final.index else np.nan
        units[key + "_final"] = "rad/s"
    derived = derived_values(inp.natural_frequencies)
    for key in dict.fromkeys([*DERIVED, *derived]):
        value, std, unit, _ = derived.get(key, (np.nan, np.nan, DERIVED.get(key, ""), ""))
        row[f"derived_{key}"], row[f"derived_{key}_std"] = value, std
        units[f"derived_{key}"] = units[f"derived_{key}_std"] = unit
    if inp.history is not None and len(inp.history):
        row["backend"] = str(inp.history["backend"].iloc[0])
        post = posterior_table(inp.history)
        for name, r in post.iterrows():
            for col, label in (("prior_mean", "prior_mean"), ("prior_std", "prior_std"), ("mean", "posterior_mean"),
                               ("std", "posterior_std")):
                row[f"{label}_{name}"] = float(r[col])
                units[f"{label}_{name}"] = PARAMETER_UNITS.get(str(name), "")
        row["train_windows"] = int(inp.history["update"].max())
    e_prior, e_tuned, n_held = held_out_error(inp.validation)
    row.update(holdout_windows=n_held, holdout_sigma_error_prior=e_prior, holdout_sigma_error_tuned=e_tuned)
    units.update(train_windows="", holdout_windows="", holdout_sigma_error_prior="dimensionless",
                 holdout_sigma_error_tuned="dimensionless")
    moved = inp.validation
    if moved is not None and "informative" in moved:  # the channels the tuned parameters move (tune stage)
        moved = moved[moved["informative"].astype(bool)]
        i_prior, i_tuned, _ = held_out_error(moved) if len(moved) else (np.nan, np.nan, 0)
        row.update(holdout_sigma_error_informative_prior=i_prior, holdout_sigma_error_informative_tuned=i_tuned)
        units.update(holdout_sigma_error_informative_prior="dimensionless",
                     holdout_sigma_error_informative_tuned="dimensionless")
    row.setdefault("train_windows", 0)
    return row, units

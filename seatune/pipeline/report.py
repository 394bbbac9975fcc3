"""`seatune report`: report.html (one self-contained page an engineer reads instead of the tables) and
summary.parquet (one row of key figures per run) from the artefacts of the stages before it.

The tuned model's RAOs and natural frequencies are recomputed here from the posterior means in
tuning_history.parquet with the same physics identify used for the prior model (effective RAO in the window's
directional sea, aggregated per sector by the geometric mean over windows). Skipped when the input artefacts
(content hashes), the vessel, the hindcast and the run settings did not change.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pandas as pd

import seatune
from seatune.errors import UserError
from seatune.pipeline.sea import read_sea_states

REQUIRED = ("motions.parquet", "waves.parquet", "windows.parquet", "window_stats.parquet", "raos.parquet",
            "natural_frequencies.parquet")
OPTIONAL = ("sea_states.parquet", "tuning_history.parquet", "validation.parquet", "tuned_vessel.yaml",
            "diagnosis.parquet",
            "diagnosis_residuals.parquet",
            "prediction.parquet")
TRACK_COLUMNS = ["time", "record", "lat", "lon", "sog", "heading_deg"]


def html_fingerprint(path: Path) -> str | None:
    """The inputs fingerprint a report.html was built from (its meta tag), or None."""
    if not path.exists():
        return None
    with open(path, encoding="utf-8", errors="replace") as fh:
        m = re.search(r'<meta name="seatune-fingerprint" content="([^"]*)"', fh.read(4096))
    return m.group(1) if m else None


def posterior_means(history: pd.DataFrame | None) -> dict[str, float]:
    if history is None or history.empty:
        return {}
    last = history[history["update"] == history["update"].max()]
    return dict(zip(last["parameter"], last["mean"].astype(float), strict=True))


def tuned_model_raos(run, vessel, loading, windows: pd.DataFrame, motions: pd.DataFrame,
                     raos: pd.DataFrame) -> pd.DataFrame:
    """The model's effective RAO with `loading` on the aggregate rows of raos.parquet: (window_id, channel,
    omega, model_tuned), window_id being the aggregate's '+'-joined members."""
    from seatune.io.hindcast_readers import read_hindcast
    from seatune.pipeline.identify import effective_model_rao, window_wave_spectrum

    agg = raos[raos["scope"] == "aggregate"]
    if agg.empty:
        return pd.DataFrame(columns=["window_id", "channel", "omega", "model_tuned"])
    hc = read_hindcast(run.hindcast_path, format=run.spec.hindcast.format)
    sea = read_sea_states(run)
    omega = np.sort(agg["omega"].unique())
    channels = list(dict.fromkeys(agg["channel"]))
    members = {w for key in agg["window_id"].unique() for w in str(key).split("+")}
    per_window = {}
    for row in windows[windows["window_id"].astype(str).isin(members)].itertuples():
        mid = row.start + (row.end - row.start) / 2
        k = int(np.clip(motions["time"].searchsorted(mid), 0, len(motions) - 1))
        wave, dirs, _ = window_wave_spectrum(hc, row, motions["lat"].iloc[k], motions["lon"].iloc[k], omega, sea)
        per_window[str(row.window_id)] = effective_model_rao(vessel, loading, channels, omega, dirs, wave,
                                                             row.heading_deg)  # (nch, nw)
    out = []
    for key in agg["window_id"].unique():
        stack = np.stack([per_window[w] for w in str(key).split("+")])
        with np.errstate(divide="ignore"):
            geo = np.exp(np.log(stack).mean(axis=0))  # as identify aggregates the prior model
        out.append(pd.DataFrame({"window_id": key, "channel": np.repeat(channels, omega.size),
                                 "omega": np.tile(omega, len(channels)), "model_tuned": geo.ravel()}))
    return pd.concat(out, ignore_index=True)


def _display_path(path: Path) -> str:
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def report_stage(run, vessel, echo=print, force: bool = False) -> dict:
    from seatune.io.atomic import atomic_path
    from seatune.io.parquet import column_units, table_metadata, write_table
    from seatune.io.rundir import fingerprint, is_fresh, recorded_fingerprint
    from seatune.physics.modes import coupled_modes
    from seatune.report.build import build_report, mode_shape_words
    from seatune.report.inputs import ReportInputs
    from seatune.report.summary import key_figures

    for name in REQUIRED:
        if not run.artefact(name).exists():
            raise UserError(str(run.path), "run_dir", f"{run.artefact(name)} is missing: run the stages before "
                                                      "the report first (`seatune tune`)")
    src = [run.artefact(n) for n in REQUIRED + OPTIONAL if run.artefact(n).exists()]
    fp = fingerprint(src + [run.vessel_path, run.hindcast_path],
                     {"stage": "report", "run": run.spec.model_dump(), "version": seatune.__version__})
    out_html, out_sum = run.artefact("report.html"), run.artefact("summary.parquet")
    if not force and is_fresh([out_sum], fp) and html_fingerprint(out_html) == fp:
        return {"skipped": True, "path": _display_path(out_html)}

    def optional(name):
        return pd.read_parquet(run.artefact(name)) if run.artefact(name).exists() else None

    motions = pd.read_parquet(run.artefact("motions.parquet"),
                              columns=[c for c in TRACK_COLUMNS
                                       if c in column_units(run.artefact("motions.parquet"))])
    windows, raos = pd.read_parquet(run.artefact("windows.parquet")), pd.read_parquet(run.artefact("raos.parquet"))
    history, diag_path = optional("tuning_history.parquet"), run.artefact("diagnosis.parquet")
    dt = np.diff(motions["time"].to_numpy()[:2]).astype("timedelta64[ns]").astype(float) * 1e-9
    step = max(int(round(1.0 / float(dt[0]))), 1) if dt.size and dt[0] > 0 else 1
    inp = ReportInputs(
        run_name=run.spec.name, run_file=str(run.path), vessel_name=vessel.spec.name,
        vessel_file=os.path.normpath(run.vessel_path),
        logs=[f"{os.path.normpath(p)} ({spec.format}{', ' + spec.kind if spec.kind != 'auto' else ''})"
              for p, spec in run.logs],
        hindcast=f"{os.path.normpath(run.hindcast_path)} ({run.spec.hindcast.format})", settings=run.spec.model_dump(),
        version=seatune.__version__, fingerprint=fp, samples=len(motions),
        time_span=(motions["time"].iloc[0], motions["time"].iloc[-1]),
        ingest_meta=table_metadata(run.artefact("motions.parquet")),
        motion_units=column_units(run.artefact("motions.parquet")), track=motions.iloc[::step].reset_index(drop=True),
        waves=pd.read_parquet(run.artefact("waves.parquet")), windows=windows,
        window_stats=pd.read_parquet(run.artefact("window_stats.parquet")), raos=raos,
        natural_frequencies=pd.read_parquet(run.artefact("natural_frequencies.parquet")), history=history,
        validation=optional("validation.parquet"), prediction=optional("prediction.parquet"),
        prediction_units=column_units(run.artefact("prediction.parquet")) if run.artefact("prediction.parquet").exists()
        else {},
        diagnosis=pd.read_parquet(diag_path) if diag_path.exists() else None,
        diagnosis_units=column_units(diag_path) if diag_path.exists() else {},
        diagnosis_residuals=(pd.read_parquet(run.artefact("diagnosis_residuals.parquet"))
                             if run.artefact("diagnosis_residuals.parquet").exists() else None),
        sea_states=read_sea_states(run),
        artefacts=[(p.name, p.stat().st_size, recorded_fingerprint(p) or "") for p in sorted(run.run_dir.iterdir())
                   if p.is_file() and not p.name.startswith(".") and p.name not in ("report.html", "summary.parquet")])
    means = posterior_means(history)
    if means:
        try:
            loading = vessel.loading(**means)
            inp.tuned_raos = tuned_model_raos(run, vessel, loading, windows, motions, raos)
            modes = coupled_modes(vessel.db, loading)
            inp.tuned_omega_n = dict(zip(("Heave", "Roll", "Pitch"), modes.omega[0], strict=True))
            inp.mode_shapes = mode_shape_words(modes, "tuned")
        except UserError as err:  # e.g. a tuned mass outside the database's drafts
            inp.tuned_note = f"tuned model not evaluated: {err}"
    else:
        inp.tuned_note = "no tuning history: only the prior model is shown"
    if not inp.mode_shapes:
        inp.mode_shapes = mode_shape_words(coupled_modes(vessel.db, vessel.base_loading), "prior")
    row, units = key_figures(inp)
    page = build_report(inp, row, units)
    meta = {"fingerprint": fp, "inputs": [p.name for p in src]}
    write_table(pd.DataFrame([row]), out_sum, units, meta)
    with atomic_path(out_html) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return {"skipped": False, "path": _display_path(out_html), "figures": page.count("<img "),
            "kb": os.path.getsize(out_html) / 1024.0, "defects": row["defects_repaired"],
            "error_prior": row["holdout_sigma_error_prior"], "error_tuned": row["holdout_sigma_error_tuned"],
            "diagnosis": diag_path.exists()}

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
from seatune.physics.spectra import omnidirectional
from seatune.pipeline.filter import STATS_UNITS
from seatune.pipeline.identify import DIAGNOSED_NF_FILE, NF_UNITS, RAO_UNITS
from seatune.pipeline.sea import read_sea_states, window_hs
from seatune.pipeline.windows import rejection_counts

REQUIRED = ("motions.parquet", "waves.parquet", "windows.parquet", "window_stats.parquet", "raos.parquet",
            "natural_frequencies.parquet")
OPTIONAL = ("window_spectra.parquet", "sea_states.parquet", "tuning_history.parquet", "validation.parquet",
            "tuned_vessel.yaml", "diagnosis.parquet", "diagnosis_residuals.parquet", "sea_states_diagnosed.parquet",
            DIAGNOSED_NF_FILE, "prediction.parquet")
# What each stage after windows writes: left out of the page when the stage did not run this time
STAGE_ARTEFACTS = {"filter": ("window_stats.parquet", "window_spectra.parquet"), "sea": ("sea_states.parquet",),
                   "identify": ("raos.parquet", "natural_frequencies.parquet"),
                   "tune": ("tuning_history.parquet", "validation.parquet", "tuned_vessel.yaml"),
                   "diagnose": ("diagnosis.parquet", "diagnosis_residuals.parquet", "sea_states_diagnosed.parquet",
                                DIAGNOSED_NF_FILE)}
SPECTRUM_OMEGA_MAX = 2.5  # rad/s: the response spectra plotted up to here (or the database's last frequency)
TRACK_COLUMNS = ["time", "record", "lat", "lon", "sog", "heading_deg"]


def sea_refit_hs(sea: pd.DataFrame | None, refit: pd.DataFrame | None) -> pd.DataFrame | None:
    """Per window Hs of the sea stage's estimate and of diagnose's refit through the named effects."""
    if refit is None or sea is None:
        return None
    hs0, hs1 = window_hs(sea).reindex(pd.unique(sea["window_id"])), window_hs(refit)  # in time order
    return pd.DataFrame({"window_id": hs0.index.astype(str), "hs": hs0.to_numpy(),
                         "hs_refit": hs1.reindex(hs0.index).to_numpy()})


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


def tuned_model_raos(run, vessel, loading, windows: pd.DataFrame, motions,
                     raos: pd.DataFrame, hc=None) -> pd.DataFrame:
    """The model's effective RAO with `loading` on the aggregate rows of raos.parquet: (window_id, channel,
    omega, model_tuned), window_id being the aggregate's '+'-joined members; `motions` a MotionTable."""
    from seatune.io.hindcast_readers import read_hindcast
    from seatune.pipeline.identify import effective_model_rao, window_wave_spectrum

    agg = raos[raos["scope"] == "aggregate"]
    if agg.empty:
        return pd.DataFrame(columns=["window_id", "channel", "omega", "model_tuned"])
    hc = hc if hc is not None else read_hindcast(run.hindcast_path, format=run.spec.hindcast.format)
    sea = read_sea_states(run)
    omega = np.sort(agg["omega"].unique())
    channels = list(dict.fromkeys(agg["channel"]))
    members = {w for key in agg["window_id"].unique() for w in str(key).split("+")}
    per_window = {}
    for row in windows[windows["window_id"].astype(str).isin(members)].itertuples():
        mid = row.start + (row.end - row.start) / 2
        at = motions.row_at(mid, ["lat", "lon"])  # the grid row at mid-window
        wave, dirs, _ = window_wave_spectrum(hc, row, at["lat"], at["lon"], omega, sea)
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


def model_spectra(run, vessel, loadings: dict, windows: pd.DataFrame, motions,
                  spectra: pd.DataFrame, hc=None) -> pd.DataFrame:
    """The measured Welch spectrum of the main channel of each DOF (heave, roll, pitch) per accepted window beside
    the model's with each loading in `loadings` ({"prior": …, "tuned": …}) in the window's directional sea:
    (window_id, channel, omega, measured, <one column per loading>) in channel unit²·s/rad. The model's S_xx is
    |H_eff|² S_ζζ with identify's effective RAO, so it is the spectrum whose ratio identify calls the RAO.
    `motions`: the MotionTable (the position at mid-window). The sea is the one tune fitted the loading against
    (sea_for_tuning), so each σ is the tune stage's prediction."""
    from seatune.io.hindcast_readers import read_hindcast
    from seatune.pipeline.identify import effective_model_rao, mode_channels, window_wave_spectrum
    from seatune.pipeline.sea import sea_for_tuning

    columns = ["window_id", "channel", "omega", "measured", *loadings]
    if spectra is None or spectra.empty:
        return pd.DataFrame(columns=columns)
    channels = [m.channel for m in mode_channels(vessel, set(spectra["channel"]))]
    hc = hc if hc is not None else read_hindcast(run.hindcast_path, format=run.spec.hindcast.format)
    sea = sea_for_tuning(run)
    top = min(SPECTRUM_OMEGA_MAX, float(vessel.db.omega.max()))
    spectra = spectra[spectra["channel"].isin(channels) & (spectra["omega"] > 0) & (spectra["omega"] <= top)]
    out = []
    for row in windows[windows["accepted"] & windows["window_id"].isin(spectra["window_id"].unique())].itertuples():
        mine = spectra[spectra["window_id"] == row.window_id]
        omega = np.sort(mine["omega"].unique())
        mid = row.start + (row.end - row.start) / 2
        at = motions.row_at(mid, ["lat", "lon"])  # the grid row at mid-window
        wave, dirs, _ = window_wave_spectrum(hc, row, at["lat"], at["lon"], omega, sea)
        s_wave = omnidirectional(wave, dirs)  # S_ζζ [m²·s/rad]
        have = [c for c in channels if c in set(mine["channel"])]
        part = pd.DataFrame({"window_id": row.window_id, "channel": np.repeat(have, omega.size),
                             "omega": np.tile(omega, len(have))})
        measured = mine.set_index(["channel", "omega"])["S"]
        part["measured"] = measured.reindex(pd.MultiIndex.from_arrays([part["channel"], part["omega"]])).to_numpy()
        for name, loading in loadings.items():
            rao = effective_model_rao(vessel, loading, have, omega, dirs, wave, row.heading_deg)  # (nch, nw)
            part[name] = (rao**2 * s_wave[None, :]).ravel()
        out.append(part)
    return pd.concat(out, ignore_index=True) if out else pd.DataFrame(columns=columns)


def _display_path(path: Path) -> str:
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def loading_read(run, vessel) -> dict[str, tuple[float, float, float, float]]:
    """{name: (value, std, prior mean, prior std)} of the loading parameters the sea fit read (sea_states.parquet),
    beside the vessel YAML's prior for them."""
    from seatune.pipeline.sea import sea_design

    out = {}
    for name, (value, std) in sea_design(run, "read").items():
        prior = vessel.spec.priors.get(name)
        out[name] = (float(value), float(std), *((float(prior.mean), float(prior.std)) if prior else (np.nan, np.nan)))
    return out


def report_stage(run, vessel, echo=print, force: bool = False, not_run: dict[str, str] | None = None) -> dict:
    """`not_run`: {stage: why} of the stages that could not run this time (no accepted window, a stage's error):
    their artefacts, even left from an earlier run, stay off the page, which says why."""
    from seatune.atomic import atomic_path
    from seatune.io.motion_table import MotionTable
    from seatune.io.parquet import column_units, table_metadata, write_table
    from seatune.io.rundir import fingerprint, is_fresh, recorded_fingerprint
    from seatune.physics.modes import coupled_modes
    from seatune.report.build import DIAGNOSIS_COLUMNS, build_report, mode_shape_words
    from seatune.report.inputs import ReportInputs
    from seatune.report.summary import key_figures

    not_run = dict(not_run or {})
    left_out = {name for stage in not_run for name in STAGE_ARTEFACTS.get(stage, ())}
    for name in REQUIRED:
        if name not in left_out and not run.artefact(name).exists():
            raise UserError(str(run.path), "run_dir", f"{run.artefact(name)} is missing: run the stages before "
                                                      "the report first (`seatune tune`)")
    src = [run.artefact(n) for n in REQUIRED + OPTIONAL if n not in left_out and run.artefact(n).exists()]
    fp = fingerprint(src + [run.vessel_path, run.hindcast_path],
                     {"stage": "report", "run": run.spec.model_dump(), "version": seatune.__version__,
                      "not_run": not_run})
    out_html, out_sum = run.artefact("report.html"), run.artefact("summary.parquet")
    if not force and is_fresh([out_sum], fp) and html_fingerprint(out_html) == fp:
        return {"skipped": True, "path": _display_path(out_html)}

    def optional(name):
        return pd.read_parquet(run.artefact(name)) if name not in left_out and run.artefact(name).exists() else None

    def stage_table(name, units):  # the table, or an empty one with its columns when its stage did not run
        return pd.DataFrame(columns=list(units)) if name in left_out else pd.read_parquet(run.artefact(name))

    motions = MotionTable(run.artefact("motions.parquet"))
    windows, raos = pd.read_parquet(run.artefact("windows.parquet")), stage_table("raos.parquet", RAO_UNITS)
    history, diag_path = optional("tuning_history.parquet"), run.artefact("diagnosis.parquet")
    diagnosed = "diagnosis.parquet" not in left_out and diag_path.exists()
    diagnosis = pd.read_parquet(diag_path) if diagnosed else None
    missing = [c for c in DIAGNOSIS_COLUMNS if c not in diagnosis] if diagnosis is not None else []
    if missing:
        raise UserError(str(diag_path), "columns", f"not a table of `seatune diagnose`: no {', '.join(missing)} "
                                                   "(make it again: `seatune diagnose RUN.yaml --force diagnose`)")
    sea_states = None if "sea_states.parquet" in left_out else read_sea_states(run)
    dt = motions.period_s()
    step = max(int(round(1.0 / dt)), 1) if dt else 1  # the track at ~1 Hz
    inp = ReportInputs(
        run_name=run.spec.name, run_file=str(run.path), vessel_name=vessel.spec.name,
        vessel_file=os.path.normpath(run.vessel_path),
        logs=[f"{os.path.normpath(p)} ({spec.format}{', ' + spec.kind if spec.kind != 'auto' else ''})"
              for p, spec in run.logs],
        hindcast=f"{os.path.normpath(run.hindcast_path)} ({run.spec.hindcast.format})", settings=run.spec.model_dump(),
        version=seatune.__version__, fingerprint=fp, samples=len(motions),
        time_span=motions.span(),
        ingest_meta=table_metadata(run.artefact("motions.parquet")),
        motion_units=column_units(run.artefact("motions.parquet")), track=motions.thinned(step, TRACK_COLUMNS),
        waves=pd.read_parquet(run.artefact("waves.parquet")), windows=windows,
        rejections=rejection_counts(windows) if len(windows) else [],
        window_stats=stage_table("window_stats.parquet", STATS_UNITS), raos=raos,
        natural_frequencies=stage_table("natural_frequencies.parquet", NF_UNITS), history=history,
        natural_frequencies_diagnosed=optional(DIAGNOSED_NF_FILE),
        validation=optional("validation.parquet"), prediction=optional("prediction.parquet"),
        prediction_units=column_units(run.artefact("prediction.parquet")) if run.artefact("prediction.parquet").exists()
        else {},
        diagnosis=diagnosis,
        diagnosis_units=column_units(diag_path) if diagnosed else {},
        diagnosis_residuals=optional("diagnosis_residuals.parquet"),
        sea_refit_hs=sea_refit_hs(sea_states, optional("sea_states_diagnosed.parquet")),
        sea_states=sea_states, not_run=not_run, sea_read={} if sea_states is None else loading_read(run, vessel),
        artefacts=[(p.name, p.stat().st_size, recorded_fingerprint(p) or "") for p in sorted(run.run_dir.iterdir())
                   if p.is_file() and not p.name.startswith(".") and p.name not in ("report.html", "summary.parquet")])
    from seatune.io.hindcast_readers import read_hindcast

    hc = read_hindcast(run.hindcast_path, format=run.spec.hindcast.format) if windows["accepted"].any() else None
    means = posterior_means(history)
    loadings = {"prior": vessel.base_loading}
    if means:
        try:
            loading = vessel.loading(**means)
            inp.tuned_raos = tuned_model_raos(run, vessel, loading, windows, motions, raos, hc)
            loadings["tuned"] = loading
            modes = coupled_modes(vessel.db, loading)
            inp.tuned_omega_n = dict(zip(("Heave", "Roll", "Pitch"), modes.omega[0], strict=True))
            inp.mode_shapes = mode_shape_words(modes, "tuned")
        except UserError as err:  # e.g. a tuned mass outside the database's drafts
            inp.tuned_note = f"tuned model not evaluated: {err}"
    else:
        inp.tuned_note = "no tuning history: only the prior model is shown"
    if not inp.mode_shapes:
        inp.mode_shapes = mode_shape_words(coupled_modes(vessel.db, vessel.base_loading), "prior")
    inp.spectra = model_spectra(run, vessel, loadings, windows, motions, optional("window_spectra.parquet"), hc)
    row, units = key_figures(inp)
    page = build_report(inp, row, units)
    meta = {"fingerprint": fp, "inputs": [p.name for p in src]}
    write_table(pd.DataFrame([row]), out_sum, units, meta)
    with atomic_path(out_html) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return {"skipped": False, "path": _display_path(out_html), "figures": page.count("<img "),
            "kb": os.path.getsize(out_html) / 1024.0, "defects": row["defects_repaired"],
            "error_prior": row["holdout_sigma_error_prior"], "error_tuned": row["holdout_sigma_error_tuned"],
            "diagnosis": diagnosed, "not_run": not_run}

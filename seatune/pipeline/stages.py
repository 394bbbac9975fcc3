"""The stages' order and their chaining: each stage runs the ones before it whose artefacts are missing or stale,
and prints one summary line (what `seatune run`, `seatune batch` and each stage command do)."""

from __future__ import annotations

import time

import click

from seatune.atomic import remove_stale_temps

ORDER = ("ingest", "windows", "filter", "sea", "identify", "tune", "diagnose", "report")


def _line(stage: str, summary: dict, seconds: float) -> str:
    if stage == "report":
        return _report_line(summary, seconds)
    if summary.get("skipped"):
        return f"{stage}: up to date (skipped)"
    if stage == "ingest":
        c = summary["counts"]
        fixed = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in c.items() if v) or "no defects"
        return (f"ingest: {summary['samples']:,} samples in {summary['records']} record(s), {summary['hours']:.1f} h, "
                f"{summary['hindcast_hours']} hindcast hours; {fixed} ({seconds:.0f} s)")
    if stage == "tune":
        return _tune_line(summary, seconds)
    if stage == "diagnose":
        return _diagnose_line(summary, seconds)
    if stage == "windows":
        return (f"windows: {summary['accepted']} of {summary['candidates']} candidates accepted, "
                f"{summary['accepted_minutes']:.0f} min free floating; rejected: {summary['rejected']} "
                f"({seconds:.0f} s)")
    if stage in ("filter", "sea", "identify") and summary.get("windows") == 0:
        return f"{stage}: no accepted window: nothing to do ({seconds:.0f} s)"
    if stage == "sea":
        return _sea_line(summary, seconds)
    if stage == "filter":
        return (f"filter: {summary['windows']} windows × {summary['channels']} channels, median cutoff "
                f"{summary['median_cutoff_hz']:.2f} Hz ({seconds:.0f} s)")
    post = summary.get("posterior_omega_n", {})
    nat = ", ".join(f"{dof.lower()} {om:.3f}" + (f" → {post[dof]:.3f}" if dof in post else "")
                    + f" (model {summary['prior_omega_n'][dof]:.3f})" if om == om
                    else f"{dof.lower()} {summary.get('not_identified', {}).get(dof, 'not identified')}"
                    for dof, om in summary["omega_n"].items()) or "none identified"
    heading = "natural frequencies [rad/s], measured → with the loading prior" if post else \
        "natural frequencies [rad/s]"
    return (f"identify: RAOs of {summary['channels']} channels in {summary['windows']} windows "
            f"({summary['low_confidence']} low-confidence); {heading}: {nat} ({seconds:.0f} s)")


def _sea_line(s: dict, seconds: float) -> str:
    if s.get("disabled"):
        return "sea: not estimated (sea.estimate: false): every stage takes the hindcast's sea"
    added = (f"; {s['added']} system(s) absent from the hindcast, Hs {', '.join(f'{h:.2f}' for h in s['added_hs'])} m"
             if s["added"] else "; no system absent from the hindcast")
    return (f"sea: estimated from the motions in {s['windows']} windows, {s['partitions']} partitions, Hs "
            f"{s['hs_ratio']:.2f}× the hindcast's (median){added} ({seconds:.0f} s)")


def _tune_line(summary: dict, seconds: float) -> str:
    post = ", ".join(f"{k} {m:.4g} ± {s:.2g}" for k, (m, s) in summary["posterior"].items())
    return (f"tune: {summary['backend']} on {summary['windows']} windows: {post}; held-out σ error on the "
            f"channels the parameters move ({', '.join(summary['informative'])}) "
            f"{100 * summary['error_prior_informative']:.1f} % (prior) → "
            f"{100 * summary['error_tuned_informative']:.1f} % (tuned), on all channels "
            f"{100 * summary['error_prior']:.1f} % → {100 * summary['error_tuned']:.1f} % "
            f"over {summary['holdout']} windows ({seconds:.0f} s)")


def _diagnose_line(s: dict, seconds: float) -> str:
    from seatune.diagnosis.effects import own_parameters_text

    where = "; ".join(s["bands_before"]) or "no band of systematic misfit"
    gap = (f"held-out gap {s['gap_before']:.3f} → {s['gap_after']:.3f}, σ error {100 * s['sigma_before']:.1f} % → "
           f"{100 * s['sigma_after']:.1f} %")
    if s.get("with_sea"):
        w = s["with_sea"]
        gap += (f" (with the sea refitted through the effects: {w['gap_before']:.3f} → {w['gap_after']:.3f}, "
                f"{100 * w['sigma_error_before']:.1f} % → {100 * w['sigma_error_after']:.1f} %)")
    if s["named"]:
        steps = []
        for step in s["steps"]:
            fitted = own_parameters_text(step["fitted"])
            p = step["false_alarm_p"]
            tested = f", false-alarm p {p:.2g}" if p == p else ""
            u = step.get("untouched_sea_gain", float("nan"))
            tested += f"; ≥ {u:.1f} in a sea fitted from the channels it leaves untouched" if u == u else ""
            steps.append(f"{step['effect']} ({fitted}; held-out gain {step['gain_holdout']:.1f} nats{tested})")
        verdict = f"named {', then '.join(steps)}, {gap}; augmented vessel: {s['augmented']}"
    elif s["bands_before"]:
        rejected = s.get("not_significant") or []
        verdict = "no known effect explains the misfit (unexplained, see diagnosis.parquet)" + (
            f"; not significant against the calibrated null: {', '.join(rejected)}" if rejected else "")
    else:
        verdict = "no effect needed"
    return (f"diagnose: {s['candidates']} candidate effects on {s['windows']} windows ({s['holdout']} held out); "
            f"misfit: {where}; {verdict} ({seconds:.0f} s)")


def _report_line(summary: dict, seconds: float) -> str:
    if summary.get("skipped"):
        return f"report: up to date (skipped): {summary['path']}"
    diag = ", diagnosis included" if summary["diagnosis"] else ""
    return (f"report: {summary['figures']} figures, {summary['kb']:.0f} kB; {summary['defects']} input defects "
            f"counted{diag}; summary.parquet written ({seconds:.0f} s): {summary['path']}")


def _no_window(run) -> str | None:
    """'0 of 2 candidates accepted: 2 moving (…)' when windows.parquet has no accepted window, else None."""
    import pandas as pd

    from seatune.pipeline.windows import rejection_text

    table = pd.read_parquet(run.artefact("windows.parquet"), columns=["accepted", "reason"])
    if table["accepted"].any():
        return None
    return f"0 of {len(table)} candidates accepted: {rejection_text(table)}" if len(table) else \
        "no candidate window in the logs"


def release_memory() -> None:
    """Give the memory a finished stage freed back to the system: glibc keeps freed heap pages, and the next
    stage's peak then stacks on them (a week of logs: 1082 MB for `seatune run` against 749 MB for its largest
    stage alone)."""
    import ctypes
    import gc

    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # not glibc: nothing to trim
        pass


def run_stages(run_yaml: str, last: str, force: tuple[str, ...] = (), progress=None) -> dict[str, str]:
    """Run the stages up to `last`; `progress(stage)` (optional) is called as each stage starts.

    Ingest and windows must work (else the UserError). With no accepted window, `tune` / `diagnose` stop with one
    line naming the rejection reasons; when `last` is the report, the stages after windows that cannot run are
    left out (a line each), the report is still written from what did run, and a warning line on stderr says
    why; a stage's UserError (bad input) is raised again once the report is written (exit 2). Returns
    {stage not run: reason}."""
    from seatune.errors import UserError
    from seatune.io.run_yaml import Run
    from seatune.pipeline.diagnose import diagnose_stage
    from seatune.pipeline.filter import filter_stage
    from seatune.pipeline.identify import identify_stage
    from seatune.pipeline.ingest import ingest
    from seatune.pipeline.report import report_stage
    from seatune.pipeline.sea import sea_stage
    from seatune.pipeline.tune import tune_stage
    from seatune.pipeline.vessel import open_run_vessel
    from seatune.pipeline.windows import windows_stage

    run = Run(run_yaml)
    model = open_run_vessel(run)
    if ORDER.index(last) >= ORDER.index("tune"):
        from seatune.pipeline.tune import tuning_parameters

        tuning_parameters(run, model)  # a bad tuning config fails before any stage runs
    run.run_dir.mkdir(parents=True, exist_ok=True)
    remove_stale_temps(run.run_dir)  # temporaries of a killed run would otherwise pile up
    not_run: dict[str, str] = {}
    stages = {"ingest": lambda f: ingest(run, model, echo=click.echo, force=f),
              "windows": lambda f: windows_stage(run, echo=click.echo, force=f),
              "filter": lambda f: filter_stage(run, model, echo=click.echo, force=f),
              "sea": lambda f: sea_stage(run, model, echo=click.echo, force=f),
              "identify": lambda f: identify_stage(run, model, echo=click.echo, force=f),
              "tune": lambda f: tune_stage(run, model, echo=click.echo, force=f),
              "diagnose": lambda f: diagnose_stage(run, model, echo=click.echo, force=f),
              "report": lambda f: report_stage(run, model, echo=click.echo, force=f, not_run=not_run)}
    redo = False
    why, cause = "", ""  # why the first stage could not run; every later one (but the report) is left out too
    failed: UserError | None = None
    for stage in ORDER[: ORDER.index(last) + 1]:
        redo = redo or stage in force
        if why and stage != "report":
            not_run[stage] = cause
            click.echo(f"{stage}: not run ({cause})")
            continue
        if progress is not None:
            progress(stage)
        start = time.perf_counter()
        try:
            summary = stages[stage](redo)  # later stages see new inputs through their fingerprints
        except UserError as err:
            if last != "report" or stage in ("ingest", "windows", "report"):
                raise
            failed, why = err, str(err)
            not_run[stage] = why
            cause = f"{stage} did not run"
            click.echo(f"{stage}: not run: {err}")
            continue
        click.echo(_line(stage, summary, time.perf_counter() - start))
        release_memory()
        if stage == "sea":  # the loading the sea fit read (xcg), for every later stage
            from seatune.pipeline.sea import with_sea_read

            model = with_sea_read(run, model)
        if stage == "windows" and last == "windows" and (empty := _no_window(run)):
            click.echo(f"warning: no accepted window: {empty}")
        if stage == "windows" and ORDER.index(last) > ORDER.index("identify"):
            empty = _no_window(run)
            if empty and last != "report":
                raise UserError(str(run.path), "windows", f"no accepted window to {last} on: {empty}")
            if empty:
                why, cause = f"no accepted window: {empty}", "no accepted window"
        if stage == "identify" and run.spec.sea.estimate and run.spec.sea.mode_rounds and not summary.get("skipped"):
            from seatune.pipeline.sea import alternate_modes

            alternate_modes(run, model, stages, echo=click.echo)
        if stage == "tune" and run.spec.sea.estimate and run.spec.sea.iterations > 1 and not summary.get("skipped"):
            from seatune.pipeline.sea import alternate

            alternate(run, model, stages, echo=click.echo)
    if failed is not None:
        raise failed
    if why:
        shows = ("the windows timeline and the rejection reasons" if cause == "no accepted window"
                 else "what the stages that ran found")
        click.echo(f"seatune: warning: {why}; not run: {', '.join(not_run)}; report.html shows {shows}", err=True)
    return not_run

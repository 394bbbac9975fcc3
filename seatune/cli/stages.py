"""Stage commands: `seatune ingest | windows | filter | sea | identify | tune | diagnose | report RUN.yaml`, each
running the stages before it (seatune.pipeline.stages)."""

from __future__ import annotations

import click

from seatune.cli.main import cli, handle_errors
from seatune.pipeline.stages import ORDER, run_stages


def _command(stage: str, doc: str):
    @cli.command(name=stage, help=doc)
    @click.argument("run_yaml", type=click.Path(dir_okay=False))
    @click.option("--force", multiple=True, type=click.Choice(ORDER), help="Redo this stage (and what follows).")
    @handle_errors
    def command(run_yaml, force):
        run_stages(run_yaml, stage, tuple(force))

    return command


ingest = _command("ingest", "Logs + hindcast → motions.parquet, waves.parquet.")
windows = _command("windows", "Free-floating, stationary windows → windows.parquet.")
filter_ = _command("filter", "Adaptive lowpass cutoff, σ, Tz and Welch spectra per window → window_stats.parquet.")
sea = _command("sea", "The directional sea of each window estimated from the motions, the hindcast as its "
                      "prior → sea_states.parquet (and sea_states_roll_free.parquet, fitted without roll).")
identify = _command("identify", "RAOs and natural frequencies → raos.parquet, natural_frequencies.parquet.")
tune = _command("tune", "Loading parameters tuned window by window (DBI or UKF) → tuning_history.parquet, "
                        "tuned_vessel.yaml, validation.parquet.")
diagnose = _command("diagnose", "Where the tuned model still misfits, the known effect that explains it, fitted "
                                "and checked on held-out windows → diagnosis.parquet, diagnosis_residuals.parquet, "
                                "augmented_vessel.yaml.")
report = _command("report", "One self-contained page an engineer reads instead of the tables → report.html, "
                            "summary.parquet (key figures, one row).")

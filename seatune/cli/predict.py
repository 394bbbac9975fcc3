"""`seatune predict RUN.yaml --forecast FILE`: exceedance probability of a critical response and heading advice
from the tuned model (Han A5 RESP / RISK) → prediction.parquet."""

from __future__ import annotations

import time
from pathlib import Path

import click

from seatune.cli.main import cli, handle_errors
from seatune.errors import UserError
from seatune.io.hindcast_readers import FORMATS


@cli.command(name="predict", help="Probability that the critical response (run YAML `predict`) exceeds its limit "
                                  "per forecast time and heading, prior vs tuned model, and the heading that "
                                  "minimises it → prediction.parquet.")
@click.argument("run_yaml", type=click.Path(dir_okay=False))
@click.option("--forecast", required=True, type=click.Path(), help="Wave forecast (ERA5 / WW3 netCDF or CSV, "
                                                                   "the hindcast layout).")
@click.option("--format", "forecast_format", default="auto", type=click.Choice(FORMATS), show_default=True,
              help="Forecast file format.")
@click.option("--force", is_flag=True, help="Redo the prediction even when it is up to date.")
@handle_errors
def predict(run_yaml, forecast, forecast_format, force):
    from seatune.cli.stages import run_stages
    from seatune.io.hindcast_readers import read_hindcast
    from seatune.io.run_yaml import Run
    from seatune.pipeline.predict import check_settings, predict_stage, summary_line
    from seatune.pipeline.vessel import open_run_vessel

    run = Run(run_yaml)
    vessel = open_run_vessel(run)
    check_settings(run, vessel)  # a bad predict block fails before any stage runs
    if not Path(forecast).exists():
        raise UserError(str(forecast), None, "forecast file not found")
    hc = read_hindcast(forecast, format=forecast_format)
    run_stages(run_yaml, "tune")
    from seatune.pipeline.sea import with_sea_read

    vessel = with_sea_read(run, vessel)  # the LCG the sea fit read (sea.read_loading), as tune modelled it
    start = time.perf_counter()
    summary = predict_stage(run, vessel, forecast, forecast_format, echo=click.echo, force=force, hc=hc)
    click.echo(summary_line(summary, time.perf_counter() - start))

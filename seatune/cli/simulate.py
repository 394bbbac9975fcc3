"""`seatune simulate SCENARIO.yaml --out DIR`."""

from __future__ import annotations

import time
from pathlib import Path

import click

from seatune.cli.main import cli, handle_errors


@cli.command()
@click.argument("scenario_yaml", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(file_okay=False), help="Folder for the logs and truth.")
@handle_errors
def simulate(scenario_yaml, out):
    """Synthesise a sea trial with known truth: logger files, a hindcast and truth.yaml."""
    from seatune.pipeline.vessel import open_vessel
    from seatune.simulate.scenario import simulate as run
    from seatune.simulate.scenario import write_trial
    from seatune.simulate.scenario_yaml import load_scenario

    spec, vessel_path = load_scenario(scenario_yaml)
    model = open_vessel(vessel_path)
    start = time.perf_counter()
    trial = run(spec, model)
    paths = write_trial(spec, trial, Path(out), scenario_path=Path(scenario_yaml))
    size = sum(p.stat().st_size if p.is_file() else sum(f.stat().st_size for f in p.rglob("*")) for p in paths)
    hours = (trial.time[-1] - trial.time[0]).total_seconds() / 3600
    n_ff = sum(s["free_floating"] for s in trial.truth["segments"])
    click.echo(f"simulate: {hours:.1f} h at {spec.sensors.sample_rate_hz:g} Hz, {n_ff} free-floating segments, "
               f"{len(paths)} files ({size / 2**20:.1f} MiB) → {out} ({time.perf_counter() - start:.0f} s)")

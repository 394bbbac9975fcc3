"""`seatune vessel build | info | rao | export`."""

from __future__ import annotations

import json
from pathlib import Path

import click

from seatune.cli.main import cli, handle_errors
from seatune.errors import UserError


@cli.group()
def vessel():
    """Vessel model: hydro database, loading condition, RAOs."""


@vessel.command()
@click.argument("vessel_yaml", type=click.Path(dir_okay=False))
@click.option("--out", type=click.Path(dir_okay=False), help="Database path (default: hydro_database of the YAML).")
@click.option("--progress/--no-progress", default=True, help="Progress bar per draft.")
@handle_errors
def build(vessel_yaml, out, progress):
    """Run the Capytaine BEM at every draft and write the hydro database (netCDF)."""
    import time

    from seatune.io.vessel_yaml import load_vessel
    from seatune.physics.hydro import save_netcdf
    from seatune.pipeline.vessel import database_path
    from seatune.pipeline.vessel_build import build_database

    spec, base = load_vessel(vessel_yaml)
    target = Path(out) if out else database_path(spec, base)
    if target is None:
        raise UserError(vessel_yaml, "hydro_database", "no output path: give hydro_database in the YAML or --out")
    start = time.perf_counter()
    db = build_database(spec, base, progress=progress, echo=click.echo)
    save_netcdf(db, target)
    click.echo(f"vessel build: {db.n_drafts} drafts × {db.omega.size} frequencies × {db.wave_direction.size} "
               f"directions → {target} ({time.perf_counter() - start:.0f} s)")


@vessel.command()
@click.argument("vessel_yaml", type=click.Path(dir_okay=False))
@click.option("--set", "overrides", multiple=True, metavar="NAME=VALUE", help="Override a loading parameter.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
@handle_errors
def info(vessel_yaml, overrides, as_json):
    """Displacement, drafts, GMT, GML and natural periods of the loading condition."""
    from seatune.pipeline.vessel import open_vessel
    from seatune.pipeline.vessel_report import vessel_summary

    model = open_vessel(vessel_yaml)
    summary = vessel_summary(model, model.loading(**_parse_overrides(overrides, vessel_yaml)))
    if as_json:
        click.echo(json.dumps(summary, indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=summary["name"], show_header=False)
    rows = [
        ("Lpp × B", f"{summary['length_m']:.1f} m × {summary['beam_m']:.1f} m" if summary["length_m"] else "—"),
        ("database drafts", ", ".join(f"{d:g}" for d in summary["database_drafts_m"]) + " m"),
        ("BEM grid", "{} ω in {:g}–{:g} rad/s, {} directions".format(
            summary["n_omega"], *summary["omega_range_rad_s"], summary["n_wave_directions"])),
        ("mass / displacement", f"{summary['mass_kg'] / 1e3:,.0f} t / {summary['displacement_m3']:,.0f} m³"),
        ("draft", f"{summary['draft_m']:.3f} m"),
        ("KB / KG", f"{summary['kb_m']:.2f} m / {summary['kg_m']:.2f} m"),
        ("GMT (free-surface corrected)", f"{summary['gmt_m']:.3f} m (correction {summary['gmt_fs_m']:.2f} m)"),
        ("GML", f"{summary['gml_m']:.1f} m"),
        ("natural period heave (coupled)", f"{summary['natural_period_heave_s']:.2f} s"),
        ("natural period roll (coupled)", f"{summary['natural_period_roll_s']:.2f} s"
         + f"  (uncoupled {summary['natural_period_roll_uncoupled_s']:.2f} s"
         + (f", IMO A.749 estimate {summary['roll_period_imo_s']:.2f} s)" if "roll_period_imo_s" in summary else ")")),
        ("roll centre", f"{summary['roll_centre_above_keel_m']:.2f} m above the keel"),
        ("natural period pitch (coupled)", f"{summary['natural_period_pitch_s']:.2f} s"
         + f"  (pitch centre {summary['pitch_centre_above_keel_m']:.2f} m above the keel)"),
        ("channels", f"{len(summary['channels'])}: " + ", ".join(summary["channels"])),
    ]
    for k, v in rows:
        table.add_row(k, v)
    Console().print(table)


@vessel.command()
@click.argument("vessel_yaml", type=click.Path(dir_okay=False))
@click.option("--set", "overrides", multiple=True, metavar="NAME=VALUE", help="Override a loading parameter.")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="File to write.")
@click.option("--dofs-only", is_flag=True, help="Only the 6 motion RAOs, not the channels.")
@click.option("--format", "fmt", type=click.Choice(["parquet", "xarray", "waveresponse"]), default="parquet",
              show_default=True, help="Long Parquet table, xarray netCDF (complex as Capytaine stores it), or "
              "netCDF with the arguments of waveresponse.RAO.from_amp_phase; conventions in the metadata.")
@handle_errors
def rao(vessel_yaml, overrides, out, dofs_only, fmt):
    """Write motion and channel RAOs of a loading condition."""
    from seatune.io.parquet import write_table
    from seatune.io.rao_export import RAO_CONVENTIONS, rao_dataset, save_rao_xarray, save_waveresponse
    from seatune.pipeline.vessel import file_hash, open_vessel
    from seatune.pipeline.vessel_report import rao_table

    model = open_vessel(vessel_yaml)
    values = _parse_overrides(overrides, vessel_yaml)
    loading = model.loading(**values)
    provenance = {"vessel": str(vessel_yaml), "vessel_hash": file_hash(vessel_yaml), "loading_overrides": values}
    if fmt == "parquet":
        df, units = rao_table(model, loading, include_channels=not dofs_only)
        write_table(df, out, units, {**provenance, "conventions": RAO_CONVENTIONS})
        n_resp = df["response"].nunique()
    else:
        ds = rao_dataset(model, loading, include_channels=not dofs_only)
        ds.attrs.update(vessel_file=str(vessel_yaml), vessel_hash=provenance["vessel_hash"],
                        loading_overrides=json.dumps(values))
        (save_rao_xarray if fmt == "xarray" else save_waveresponse)(ds, out)
        n_resp = ds.sizes["response"]
    click.echo(f"vessel rao: {n_resp} responses × {model.db.omega.size} ω × {model.db.wave_direction.size} "
               f"directions → {out} ({fmt})")


@vessel.command()
@click.argument("vessel_yaml", type=click.Path(dir_okay=False))
@click.option("--set", "overrides", multiple=True, metavar="NAME=VALUE", help="Override a loading parameter.")
@click.option("--out", required=True, type=click.Path(), help="netCDF file; WAMIT: path prefix; Nemoh: folder.")
@click.option("--format", "fmt", type=click.Choice(["netcdf", "wamit", "nemoh"]), default="netcdf",
              show_default=True, help="Capytaine netCDF, or Capytaine's own WAMIT (.1 .3 .hst) / Nemoh export.")
@handle_errors
def export(vessel_yaml, overrides, out, fmt):
    """The hydro database at a loading condition as a Capytaine dataset (inertia matrix, hydrostatic
    stiffness, forward speed, body), for capytaine.post_pro.rao and Capytaine's exporters."""
    from seatune.io.capytaine_export import capytaine_dataset, export_capytaine
    from seatune.pipeline.vessel import open_vessel

    model = open_vessel(vessel_yaml)
    loading = model.loading(**_parse_overrides(overrides, vessel_yaml))
    ds = capytaine_dataset(model.db, loading, body=model.spec.name)
    written = export_capytaine(ds, out, fmt)
    click.echo(f"vessel export: draft {float(ds['draught']):.3f} m, {ds.sizes['omega']} ω × "
               f"{ds.sizes['wave_direction']} directions → {', '.join(map(str, written))}")


def _parse_overrides(items, source) -> dict:
    values = {}
    for item in items:
        name, sep, raw = item.partition("=")
        if not sep:
            raise UserError(str(source), f"--set {item}", "expected NAME=VALUE")
        try:
            values[name.strip()] = float(raw)
        except ValueError:
            raise UserError(str(source), f"--set {item}", f"value {raw!r} is not a number") from None
    return values

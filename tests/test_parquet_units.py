"""Every Parquet column seatune writes has a unit pint parses, or a marker (text, UTC timestamp, per row).

The round trip per unit: pint parses it, formats it (long and abbreviated), parses the text again and gets the
same dimensionality. The schemas are checked in the default run; the files of a whole sample run (every stage,
spectra also per Hz) with `make test-slow`, since tests/conftest.py has no session fixture of a sample run and
a second pipeline run is not for the default suite.
"""

import glob

import numpy as np
import pandas as pd
import pint
import pyarrow.parquet as pq
import pytest
import yaml

from seatune.io.parquet import DIMENSIONLESS, MARKERS, PER_ROW, TEXT, TIMESTAMP, column_units, write_table
from tests.conftest import ROOT, SAMPLE_VESSEL

UREG = pint.UnitRegistry()


def round_trip(unit: str) -> None:
    parsed = UREG.parse_units(unit)
    for spec in ("", "~"):
        text = format(parsed, spec)
        again = UREG.parse_units(text) if text else UREG.dimensionless
        assert again.dimensionality == parsed.dimensionality, (unit, text)


def schemas() -> dict[str, dict[str, str]]:
    from seatune.pipeline import diagnose, filter, identify, ingest, motions, predict, sea, tune, windows
    from seatune.pipeline.batch import BASE_UNITS, LOADING_UNITS
    from seatune.report.summary import DERIVED, PARAMETER_UNITS

    return {"windows": windows.WINDOW_UNITS, "waves": ingest.WAVE_UNITS, "motions": motions.UNITS,
            "window_stats": filter.STATS_UNITS, "window_spectra": filter.SPECTRA_UNITS,
            "window_spectra_hz": filter.SPECTRA_HZ_UNITS, "sea_states": sea.SEA_UNITS, "raos": identify.RAO_UNITS,
            "natural_frequencies": identify.NF_UNITS, "tuning_history": tune.HISTORY_UNITS,
            "validation": tune.VALIDATION_UNITS, "diagnosis": diagnose.DIAGNOSIS_UNITS,
            "diagnosis_residuals": diagnose.RESIDUAL_UNITS, "prediction": predict.PREDICTION_UNITS,
            "fleet_summary": {**BASE_UNITS, **LOADING_UNITS}, "summary": {**PARAMETER_UNITS, **DERIVED}}


def check_field(where: str, unit: str, description: str) -> None:
    if unit == PER_ROW:
        assert description, f"{where}: a per-row unit needs its description"
    elif unit not in MARKERS:
        round_trip(unit)


def test_every_schema_unit_round_trips_in_pint():
    checked = 0
    for table, units in schemas().items():
        for column, spec in units.items():
            unit, _, description = (s.strip() for s in spec.partition(";"))
            if unit:  # empty: filled from the column type by write_table (text, UTC, dimensionless integers)
                check_field(f"{table}.{column}", unit, description)
                checked += 1
    assert checked >= 120


def test_known_bad_strings_are_gone():
    flat = [s.partition(";")[0].strip() for units in schemas().values() for s in units.values()]
    for bad in ("nat", "fraction of critical", "channel unit/m", "channel unit", "channel unit^2 s/rad", "JSON"):
        assert bad not in flat
    with pytest.raises(pint.errors.UndefinedUnitError):  # why they had to go
        UREG.parse_units("fraction of critical")


def test_write_table_fills_markers_and_descriptions(tmp_path):
    df = pd.DataFrame({"name": ["a", "b"], "flag": [True, False], "n": [1, 2],
                       "time": pd.to_datetime(["2024-01-01", "2024-01-02"], utc=True),
                       "nll": [1.5, 2.0], "sigma": [0.1, 0.2], "hs": [1.0, 2.0]})
    path = write_table(df, tmp_path / "t.parquet", {"name": "", "flag": "", "n": "", "time": "", "hs": "m",
                                                    "nll": "dimensionless; log-likelihood in nats",
                                                    "sigma": "per row; the unit of the row's channel"})
    units = column_units(path)
    assert units == {"name": TEXT, "flag": TEXT, "n": DIMENSIONLESS, "time": TIMESTAMP, "nll": DIMENSIONLESS,
                     "sigma": PER_ROW, "hs": "m"}
    fields = {f.name: f.metadata for f in pq.read_schema(path)}
    assert fields["nll"][b"description"] == b"log-likelihood in nats"
    assert b"description" not in fields["hs"]
    assert pd.read_parquet(path).equals(df)


@pytest.mark.slow
def test_parquet_units_of_a_sample_run(tmp_path):
    """The whole sample run (ingest → report, spectra also per Hz): every column of every Parquet file."""
    from click.testing import CliRunner

    import seatune.cli.stages  # noqa: F401  (registers the stage commands)
    from seatune.cli.main import cli

    data = yaml.safe_load((ROOT / "configs/runs/sample.yaml").read_text())
    data["run_dir"] = str(tmp_path / "run")
    data["vessel"] = str(SAMPLE_VESSEL)
    for log in data["logs"]:
        log["path"] = str(ROOT / "sample_logs" / log["path"].split("/")[-1])
    data["hindcast"]["path"] = str(ROOT / "sample_logs" / data["hindcast"]["path"].split("/")[-1])
    data["output"] = {"spectrum_frequency": "Hz"}
    (tmp_path / "run.yaml").write_text(yaml.safe_dump(data))
    res = CliRunner().invoke(cli, ["report", str(tmp_path / "run.yaml")], catch_exceptions=False)
    assert res.exit_code == 0, res.output
    files = sorted(glob.glob(str(tmp_path / "run" / "*.parquet")))
    assert len(files) >= 14
    n = 0
    for path in files:
        for field in pq.read_schema(path):
            meta = field.metadata or {}
            unit, description = meta.get(b"unit", b"").decode(), meta.get(b"description", b"").decode()
            assert unit, f"{path}: {field.name} has no unit"
            if unit == TIMESTAMP:
                assert str(field.type).startswith("timestamp"), (path, field.name)
            check_field(f"{path}:{field.name}", unit, description)
            n += 1
    assert n > 200
    # per-Hz spectra: same variance per window × channel as the rad/s ones
    per_omega = pd.read_parquet(tmp_path / "run" / "window_spectra.parquet")
    per_hz = pd.read_parquet(tmp_path / "run" / "window_spectra_hz.parquet")
    assert column_units(tmp_path / "run" / "window_spectra_hz.parquet")["freq"] == "Hz"
    for (w, ch), g in per_omega.groupby(["window_id", "channel"]):
        h = per_hz[(per_hz["window_id"] == w) & (per_hz["channel"] == ch)]
        np.testing.assert_allclose(h["freq"].to_numpy(), g["omega"].to_numpy() / (2 * np.pi))
        assert np.trapezoid(h["S"], h["freq"]) == pytest.approx(np.trapezoid(g["S"], g["omega"]), rel=1e-12)

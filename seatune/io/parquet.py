"""Parquet artefacts: units in the field metadata, provenance in the schema metadata, atomic writes.

Every field carries `unit`: a unit string pint parses ("m", "rad/s", "m^2 s/rad", "dimensionless"), or a marker:
TEXT (strings, flags, identifiers, JSON), TIMESTAMP (UTC times; the Arrow type holds the zone), PER_ROW (the unit
differs between rows, e.g. the row's channel unit; the field's `description` says where it is given). A units
dict value "UNIT; description" puts the text after the first ";" in the field's `description`. An empty unit is
filled from the column type: TEXT for strings and flags, TIMESTAMP for times, DIMENSIONLESS for integers (counts
and indices); a float column needs its unit spelled out.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

import seatune
from seatune.atomic import atomic_path

TEXT = "text"
TIMESTAMP = "UTC"
DIMENSIONLESS = "dimensionless"
PER_ROW = "per row"
MARKERS = (TEXT, TIMESTAMP, PER_ROW)  # units that are not pint strings


def field_metadata(field: pa.Field, spec: str) -> dict[str, str]:
    """{"unit": ..., ["description": ...]} of one field from its units-dict value "UNIT[; description]"."""
    unit, _, description = spec.partition(";")
    unit = unit.strip()
    if not unit:
        t = field.type
        unit = (TIMESTAMP if pa.types.is_timestamp(t) else DIMENSIONLESS if pa.types.is_integer(t)
                else "" if pa.types.is_floating(t) else TEXT)
    return {"unit": unit, **({"description": description.strip()} if description.strip() else {})}


def write_table(df: pd.DataFrame, path: str | Path, units: dict[str, str], metadata: dict | None = None) -> Path:
    """Write `df` to `path` atomically; every column's unit (and description) goes in its field metadata."""
    missing = [c for c in df.columns if c not in units]
    if missing:
        raise ValueError(f"no unit given for columns {missing}")
    table = pa.Table.from_pandas(df, preserve_index=False)
    fields = [f.with_metadata(field_metadata(f, units[f.name])) for f in table.schema]
    meta = dict(table.schema.metadata or {})
    meta[b"seatune"] = json.dumps({"version": seatune.__version__, **(metadata or {})}).encode()
    table = table.cast(pa.schema(fields, metadata=meta))
    path = Path(path)
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)
    return path


def column_units(path: str | Path) -> dict[str, str]:
    schema = pq.read_schema(path)
    return {f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in schema}


def column_descriptions(path: str | Path) -> dict[str, str]:
    schema = pq.read_schema(path)
    return {f.name: (f.metadata or {}).get(b"description", b"").decode() for f in schema}


def table_metadata(path: str | Path) -> dict:
    return json.loads(pq.read_schema(path).metadata[b"seatune"])

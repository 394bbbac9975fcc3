"""Parquet artefacts: units in the field metadata, provenance in the schema metadata, atomic writes."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

import seatune
from seatune.io.atomic import atomic_path


def write_table(df: pd.DataFrame, path: str | Path, units: dict[str, str], metadata: dict | None = None) -> Path:
    """Write `df` to `path` atomically; every column's unit goes in its field metadata ('' = none)."""
    missing = [c for c in df.columns if c not in units]
    if missing:
        raise ValueError(f"no unit given for columns {missing}")
    table = pa.Table.from_pandas(df, preserve_index=False)
    fields = [f.with_metadata({"unit": units[f.name]}) for f in table.schema]
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


def table_metadata(path: str | Path) -> dict:
    return json.loads(pq.read_schema(path).metadata[b"seatune"])

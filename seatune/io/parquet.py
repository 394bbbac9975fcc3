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
from contextlib import contextmanager
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


def _unit_fields(table: pa.Table, units: dict[str, str]) -> list[pa.Field]:
    """The table's fields with each column's unit (and description) in their metadata."""
    missing = [f.name for f in table.schema if f.name not in units]
    if missing:
        raise ValueError(f"no unit given for columns {missing}")
    return [f.with_metadata(field_metadata(f, units[f.name])) for f in table.schema]


def _provenance(metadata: dict | None) -> str:
    return json.dumps({"version": seatune.__version__, **(metadata or {})})


def write_table(df: pd.DataFrame, path: str | Path, units: dict[str, str], metadata: dict | None = None) -> Path:
    """Write `df` to `path` atomically; every column's unit (and description) goes in its field metadata."""
    table = pa.Table.from_pandas(df, preserve_index=False)
    fields = _unit_fields(table, units)
    meta = dict(table.schema.metadata or {})
    meta[b"seatune"] = _provenance(metadata).encode()
    table = table.cast(pa.schema(fields, metadata=meta))
    path = Path(path)
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)
    return path


class TableWriter:
    """Row groups appended one DataFrame at a time (the same columns each time); see :func:`table_writer`."""

    def __init__(self, path: Path, units: dict[str, str]):
        self.path, self.units = path, units
        self.metadata: dict = {}
        self._writer: pq.ParquetWriter | None = None
        self._schema: pa.Schema | None = None

    def write(self, df: pd.DataFrame) -> None:
        if self._schema is None:
            table = pa.Table.from_pandas(df, preserve_index=False)
            self._schema = pa.schema(_unit_fields(table, self.units),
                                     metadata={k: v for k, v in (table.schema.metadata or {}).items()
                                               if k != b"pandas"})
            self._writer = pq.ParquetWriter(self.path, self._schema)
        self._writer.write_table(pa.Table.from_pandas(df, schema=self._schema, preserve_index=False))

    def close(self) -> None:
        if self._writer is None:
            raise ValueError(f"{self.path}: no rows written")
        self._writer.add_key_value_metadata({"seatune": _provenance(self.metadata)})
        self._writer.close()


@contextmanager
def table_writer(path: str | Path, units: dict[str, str]):
    """Write a table in pieces, atomically: ``with table_writer(p, units) as w: w.write(df); w.metadata = {...}``.
    Each `write` is one row group, so a reader can take a time range without the rest
    (:class:`seatune.io.motion_table.MotionTable`)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        w = TableWriter(tmp, units)
        try:
            yield w
        except BaseException:
            if w._writer is not None:
                w._writer.close()
            raise
        w.close()


def column_units(path: str | Path) -> dict[str, str]:
    schema = pq.read_schema(path)
    return {f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in schema}


def column_descriptions(path: str | Path) -> dict[str, str]:
    schema = pq.read_schema(path)
    return {f.name: (f.metadata or {}).get(b"description", b"").decode() for f in schema}


def table_metadata(path: str | Path) -> dict:
    """The artefact's provenance (version, fingerprint, …): the file's key-value metadata, where a table written in
    pieces keeps it too (its Arrow schema was fixed before the first piece)."""
    return json.loads(pq.ParquetFile(path).metadata.metadata[b"seatune"])

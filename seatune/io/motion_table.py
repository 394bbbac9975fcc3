"""``motions.parquet`` read a window, a row group or a fix at a time (ingest writes it an hour per row group), so no
stage holds the whole log: memory stays flat however long the trial."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq


class MotionTable:
    """The motion table on disk; every read returns a DataFrame of the rows asked for (``time`` in UTC)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.file = pq.ParquetFile(self.path)
        self.columns = list(self.file.schema_arrow.names)
        meta = self.file.metadata
        self.rows = meta.num_rows
        self._time = self._ranges("time")

    def __len__(self) -> int:
        return self.rows

    def _ranges(self, column: str) -> list[tuple]:
        """(min, max) of `column` per row group, from the footer statistics (None where not written)."""
        j = self.columns.index(column)
        out = []
        for g in range(self.file.num_row_groups):
            st = self.file.metadata.row_group(g).column(j).statistics
            out.append((st.min, st.max) if st is not None and st.has_min_max else None)
        return out

    def _groups(self, start=None, end=None) -> list[int]:
        lo = None if start is None else pd.Timestamp(start)
        hi = None if end is None else pd.Timestamp(end)
        keep = []
        for g, r in enumerate(self._time):
            if r is not None and ((hi is not None and pd.Timestamp(r[0]) > hi) or
                                  (lo is not None and pd.Timestamp(r[1]) < lo)):
                continue
            keep.append(g)
        return keep

    def _read(self, groups: list[int], columns) -> pd.DataFrame:
        columns = self.columns if columns is None else [c for c in dict.fromkeys(columns) if c in self.columns]
        if not groups:
            return self.file.schema_arrow.empty_table().select(columns).to_pandas()
        return self.file.read_row_groups(groups, columns=columns).to_pandas()

    def window(self, start, end, columns=None, record: int | None = None) -> pd.DataFrame:
        """Rows with start ≤ time ≤ end (and of `record`, when given)."""
        cols = None if columns is None else ["time", *(["record"] if record is not None else []), *columns]
        df = self._read(self._groups(start, end), cols)
        t = df["time"]
        keep = (t >= pd.Timestamp(start)) & (t <= pd.Timestamp(end))
        if record is not None:
            keep &= df["record"] == record
        df = df[keep.to_numpy()].reset_index(drop=True)
        return df if columns is None else df[[c for c in cols if c in df.columns and
                                               (c in columns or c == "time")]]

    def span(self) -> tuple[pd.Timestamp, pd.Timestamp]:
        """First and last time."""
        first = self.file.read_row_group(0, columns=["time"]).column("time")
        last = self.file.read_row_group(self.file.num_row_groups - 1, columns=["time"]).column("time")
        return pd.Timestamp(first[0].as_py()), pd.Timestamp(last[len(last) - 1].as_py())

    def row_at(self, t, columns) -> pd.Series:
        """The first row at or after `t` (the last row when `t` is after the end): ``searchsorted``, clipped."""
        for g in self._groups(t, None):
            df = self._read([g], ["time", *columns])
            k = int(df["time"].searchsorted(pd.Timestamp(t)))
            if k < len(df):
                return df.iloc[k]
        return self._read([self.file.num_row_groups - 1], ["time", *columns]).iloc[-1]

    def fix_at(self, t) -> tuple[float, float]:
        """(lat, lon) of the first finite fix at or after `t`, else of the last fix before it."""
        for g in self._groups(t, None):
            df = self._read([g], ["time", "lat", "lon"])
            df = df[(df["time"] >= pd.Timestamp(t)).to_numpy() & placed(df)]
            if len(df):
                return float(df["lat"].iloc[0]), float(df["lon"].iloc[0])
        return self.last_fix()

    def last_fix(self) -> tuple[float, float]:
        """(lat, lon) of the last finite fix; NaN when the table has none."""
        for g in reversed(range(self.file.num_row_groups)):
            df = self._read([g], ["lat", "lon"])
            df = df[placed(df)]
            if len(df):
                return float(df["lat"].iloc[-1]), float(df["lon"].iloc[-1])
        return float("nan"), float("nan")

    def blocks(self, columns=None):
        """The table one row group (an hour) at a time, in time order."""
        for g in range(self.file.num_row_groups):
            yield self._read([g], columns)

    def thinned(self, step: int, columns=None) -> pd.DataFrame:
        """Every `step`-th row, read one row group at a time."""
        parts, offset = [], 0
        for df in self.blocks(columns):
            parts.append(df.iloc[(-offset) % step::step])
            offset += len(df)
        return pd.concat(parts, ignore_index=True) if parts else self._read([], columns)

    def period_s(self) -> float | None:
        """The grid spacing [s] from the first two rows (None for fewer)."""
        t = self.file.read_row_group(0, columns=["time"]).column("time").to_pandas()
        if len(t) < 2:
            return None
        return (t.iloc[1] - t.iloc[0]).total_seconds()


def placed(df: pd.DataFrame) -> np.ndarray:
    """Rows with a finite fix (lat and lon)."""
    return np.isfinite(df["lat"].to_numpy(float)) & np.isfinite(df["lon"].to_numpy(float))

"""Free-floating, stationary windows (de Jong ch. 4 criteria; Han uses 20-min records).

Candidates are the runs of the motion table where the speed over ground is low and the runs where it is
not (transits), per contiguous record. A low-speed run is cut into windows whose heading stays within a
band and whose length lies between the minimum and maximum duration; each window is then tested for a
stationary sea: the hindcast Hs may not change by more than a fraction, and the variances of a motion
channel over sub-windows must pass an F-test at the given significance (their effective degrees of
freedom come from the window's own spectrum). Every candidate is kept with accepted / reason.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.stats import f as f_dist

from seatune.errors import UserError
from seatune.io.run_yaml import WindowSettings


@dataclass(frozen=True)
class Candidate:
    start: pd.Timestamp
    end: pd.Timestamp
    record: int
    accepted: bool
    reason: str
    heading_deg: float
    sog: float


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index pairs of the runs of equal values in mask."""
    edges = np.flatnonzero(np.diff(mask.astype(int))) + 1
    bounds = np.r_[0, edges, mask.size]
    return list(zip(bounds[:-1], bounds[1:], strict=True))


def _circular_mean_deg(deg: np.ndarray) -> float:
    r = np.radians(deg)
    return float(np.degrees(np.arctan2(np.sin(r).mean(), np.cos(r).mean())) % 360.0)


def _heading_spread(deg: np.ndarray) -> np.ndarray:
    """Running max − min of the unwrapped heading [deg]; samples without a heading (NaN) change nothing."""
    r = np.radians(np.asarray(deg, dtype=np.float64))
    ok = np.isfinite(r)
    u = np.full(r.shape, np.nan)
    u[ok] = np.degrees(np.unwrap(r[ok]))
    return np.nan_to_num(np.fmax.accumulate(u) - np.fmin.accumulate(u), nan=0.0)


def effective_dof(x: np.ndarray, fs: float) -> float:
    """ν of the sample variance from the record's own periodogram: ν = T m0² / (π ∫ S² dω)."""
    x = x - x.mean()
    spec = np.abs(np.fft.rfft(x)) ** 2
    spec[0] = 0.0
    # one-sided S(ω) up to a constant; ν is scale-free: ν = N (Σ S)² / (2 Σ S²) for the discrete periodogram
    return float(x.size * spec.sum() ** 2 / (2 * spec.size * (spec**2).sum()))


def stationarity_test(x: np.ndarray, fs: float, parts: int, alpha: float) -> tuple[bool, float]:
    """F-test of the largest against the smallest sub-window variance (Bonferroni over the pairs); samples
    without a value (NaN) are left out."""
    chunks = np.array_split(x[np.isfinite(x)], parts)
    if min(c.size for c in chunks) < 2:
        return False, float("nan")
    var = np.array([c.var() for c in chunks])
    if not (var > 0).all():  # a sub-window without motion (a dead sensor): nothing to test
        return False, float("nan")
    nu = np.array([max(effective_dof(c, fs), 2.0) for c in chunks])
    hi, lo = int(var.argmax()), int(var.argmin())
    ratio = var[hi] / var[lo]
    pairs = parts * (parts - 1) / 2
    limit = f_dist.ppf(1 - alpha / (2 * pairs), nu[hi], nu[lo])
    return bool(ratio <= limit), float(ratio)


def find_windows(motions: pd.DataFrame, waves: pd.DataFrame | None, settings: WindowSettings,
                 fs: float) -> list[Candidate]:
    """Candidates over the motion table (columns time, record, sog, heading_deg and motion channels)."""
    return scan_windows([motions], waves, settings, fs)


def scan_windows(blocks, waves: pd.DataFrame | None, settings: WindowSettings, fs: float) -> list[Candidate]:
    """:func:`find_windows` over the table given as consecutive pieces in time order (motions.parquet's row
    groups): the same candidates, holding no more than a window's rows and the smoothing's context."""
    scan = _Scan(waves, settings, fs)
    for block in blocks:
        records = block["record"].to_numpy()
        cuts = np.r_[0, np.flatnonzero(np.diff(records)) + 1, len(block)]
        for a, b in zip(cuts[:-1], cuts[1:], strict=True):
            if b > a:
                scan.feed(int(records[a]), block.iloc[a:b].reset_index(drop=True))
    scan.end_record()
    return scan.out


class _Scan:
    """The streaming state of :func:`scan_windows` within one record: (A) the speed over ground smoothed once a
    row has its context, (B) runs shorter than the smoothing absorbed (a run's value is final once it is that
    long or ended), (C) the low-speed runs cut into windows as soon as `max_duration_s` of them is known."""

    def __init__(self, waves, settings: WindowSettings, fs: float):
        self.waves, self.settings, self.fs = waves, settings, fs
        self.n = max(1, int(round(settings.sog_smoothing_s * fs)))
        self.n_max = int(settings.max_duration_s * fs)
        self.out: list[Candidate] = []
        self.record = None

    def _start(self, record: int) -> None:
        self.record = record
        self.raw = []  # (A) rows whose smoothed speed waits for its right context
        self.ctx = None  # the rows before them (left context)
        self.open: list[pd.DataFrame] = []  # (B) the current run of the raw slow mask
        self.open_value, self.open_len, self.open_long, self.first_run = None, 0, False, True
        self.prev_value = None
        self.run_value = None  # (C) the current absorbed run: slow rows from the next window's start, or sums
        self.buf: list[pd.DataFrame] = []
        self.moving = None

    def feed(self, record: int, rows: pd.DataFrame) -> None:
        if record != self.record:
            self.end_record()
            self._start(record)
        self.raw.append(rows)
        if sum(map(len, self.raw)) > 2 * self.n:
            self._smooth(final=False)

    def end_record(self) -> None:
        if self.record is None:
            return
        self._smooth(final=True)
        self._close_open(final=True)
        self._close_run()
        self.record = None

    # (A) ------------------------------------------------------------------------------------------------
    def _smooth(self, final: bool) -> None:
        raw = pd.concat(self.raw, ignore_index=True) if len(self.raw) > 1 else self.raw[0]
        lead = 0 if self.ctx is None else len(self.ctx)
        sog = pd.concat([self.ctx["sog"], raw["sog"]], ignore_index=True) if lead else raw["sog"]
        smooth = sog.rolling(self.n, center=True, min_periods=1).mean().to_numpy()[lead:]
        done = len(raw) if final else len(raw) - self.n  # the last n wait for their right context
        if done <= 0:
            return
        rows = raw.iloc[:done].assign(sog_smooth=smooth[:done])
        self.ctx = raw.iloc[max(0, done - self.n):done][["sog"]]
        self.raw = [raw.iloc[done:].reset_index(drop=True)] if done < len(raw) else []
        self._runs(rows)

    # (B) ------------------------------------------------------------------------------------------------
    def _runs(self, rows: pd.DataFrame) -> None:
        slow = rows["sog_smooth"].to_numpy() < self.settings.max_sog
        for a, b in _runs(slow):
            if self.open_value is not None and slow[a] != self.open_value:
                self._close_open(final=False)
            if self.open_value is None:
                self.open_value, self.open_len, self.open_long = bool(slow[a]), 0, False
            self.open.append(rows.iloc[a:b])
            self.open_len += b - a
            if self.open_len >= self.n:  # long enough: its value stands whatever follows
                self.open_long = True
                self._segment(self.open_value, self.open)
                self.open = []

    def _close_open(self, final: bool) -> None:
        """The open run ended (final: with the record). A short one takes the previous run's value; the record's
        first, when short and followed by another, the next run's (the only other value)."""
        if self.open_value is None:
            return
        value = self.open_value
        if not self.open_long:
            if self.first_run:
                value = value if final else not value
            else:
                value = self.prev_value
        if self.open:
            self._segment(value, self.open)
        self.prev_value, self.first_run = value, False
        self.open, self.open_value, self.open_len, self.open_long = [], None, 0, False

    # (C) ------------------------------------------------------------------------------------------------
    def _segment(self, slow: bool, parts: list[pd.DataFrame]) -> None:
        if self.run_value is not None and slow != self.run_value:
            self._close_run()
        if self.run_value is None:
            self.run_value, self.buf, self.moving = slow, [], None
        if slow:
            self.buf += parts
            self._windows(final=False)
            return
        for part in parts:
            r = np.radians(part["heading_deg"].to_numpy())
            sums = np.array([np.sin(r).sum(), np.cos(r).sum(), part["sog_smooth"].sum(), len(part)])
            if self.moving is None:
                self.moving = {"start": part["time"].iloc[0], "sums": np.zeros(4)}
            self.moving["sums"] += sums
            self.moving["end"] = part["time"].iloc[-1]

    def _close_run(self) -> None:
        if self.run_value is None:
            return
        if self.run_value:
            self._windows(final=True)
        elif self.moving is not None:
            sin, cos, sog, n = self.moving["sums"]
            mean = sog / n
            self.out.append(Candidate(start=self.moving["start"], end=self.moving["end"], record=int(self.record),
                                      accepted=False, reason=f"moving: speed over ground {mean:.1f} m/s > "
                                                             f"{self.settings.max_sog:g} m/s",
                                      heading_deg=float(np.degrees(np.arctan2(sin / n, cos / n)) % 360.0),
                                      sog=float(mean)))
        self.run_value, self.buf, self.moving = None, [], None

    def _windows(self, final: bool) -> None:
        """Cut the buffered low-speed rows into windows; without `final`, only those whose end is decided."""
        if not self.buf or (not final and sum(map(len, self.buf)) < self.n_max):
            return
        part = pd.concat(self.buf, ignore_index=True) if len(self.buf) > 1 else self.buf[0].reset_index(drop=True)
        start = _split_slow_run(part, self.record, part["sog_smooth"].to_numpy(), self.waves, self.settings,
                                self.fs, self.out, stop_before=None if final else len(part) - self.n_max)
        self.buf = [part.iloc[start:].reset_index(drop=True)] if start < len(part) else []


def _candidate(part: pd.DataFrame, record: int, accepted: bool, reason: str, sog: np.ndarray) -> Candidate:
    return Candidate(start=part["time"].iloc[0], end=part["time"].iloc[-1], record=int(record), accepted=accepted,
                     reason=reason, heading_deg=_circular_mean_deg(part["heading_deg"].to_numpy()),
                     sog=float(np.mean(sog)))


def _split_slow_run(part, record, sog, waves, settings: WindowSettings, fs: float, out: list[Candidate],
                    stop_before: int | None = None) -> int:
    """Cut a low-speed run into windows (appended to `out`) from its start; with `stop_before`, only windows
    starting before that row (their heading band decided within `max_duration_s`). Returns where it stopped."""
    n_min = int(settings.min_duration_s * fs)
    n_max = int(settings.max_duration_s * fs)
    start = 0
    heading = part["heading_deg"].to_numpy()
    while start < len(part) and (stop_before is None or start <= stop_before):
        spread = _heading_spread(heading[start:start + n_max])
        stop = start + int(np.searchsorted(spread, settings.max_heading_change_deg, side="right"))
        piece = part.iloc[start:stop]
        if stop - start < n_min:
            turned = stop < len(part) and stop - start < n_max and spread[-1] > settings.max_heading_change_deg
            why = (f"heading changed more than {settings.max_heading_change_deg:g}° within "
                   f"{(stop - start) / fs / 60:.0f} min") if turned else (
                   f"too short: {(stop - start) / fs / 60:.1f} min < {settings.min_duration_s / 60:g} min")
            out.append(_candidate(piece, record, False, why, sog[start:stop]))
        else:
            out.append(_judge(piece, record, sog[start:stop], waves, settings, fs))
        start = stop
    return start


def _judge(piece, record, sog, waves, settings: WindowSettings, fs: float) -> Candidate:
    if waves is not None and len(waves) >= 2:
        t0, t1 = piece["time"].iloc[0], piece["time"].iloc[-1]
        ref = waves["time"].iloc[0]
        inside = waves.loc[(waves["time"] > t0) & (waves["time"] < t1), "time"]
        inner = (inside - ref).dt.total_seconds().to_numpy()
        at = np.r_[(t0 - ref).total_seconds(), inner, (t1 - ref).total_seconds()]
        hs = np.interp(at, (waves["time"] - ref).dt.total_seconds().to_numpy(), waves["hs"].to_numpy())
        if hs.mean() > 0:  # the hindcast over the window itself, interpolated in time
            change = (hs.max() - hs.min()) / hs.mean()
            if change > settings.max_hs_change:
                limit = 100 * settings.max_hs_change
                why = f"sea not stationary: hindcast Hs changes {100 * change:.0f} % > {limit:g} %"
                return _candidate(piece, record, False, why, sog)
    channel = settings.stationarity_channel
    if channel in piece:
        ok, ratio = stationarity_test(piece[channel].to_numpy(), fs, settings.sub_windows,
                                      settings.stationarity_alpha)
        if not ok:
            return _candidate(piece, record, False, f"motions not stationary: {channel} variance ratio "
                                                    f"{ratio:.2f} over {settings.sub_windows} sub-windows", sog)
    return _candidate(piece, record, True, "free floating, stationary", sog)


def windows_table(candidates: list[Candidate]) -> pd.DataFrame:
    rows = [{
        "window_id": i, "start": c.start, "end": c.end, "duration_s": (c.end - c.start).total_seconds(),
        "record": c.record, "accepted": c.accepted, "reason": c.reason, "heading_deg": c.heading_deg, "sog": c.sog,
    } for i, c in enumerate(candidates)]
    return pd.DataFrame(rows)


# Each rejection reason written above → its kind with the threshold, the measured value dropped
REASON_KINDS = (
    (re.compile(r"moving: speed over ground .* > (?P<limit>.+)"), "moving (speed over ground > {limit})"),
    (re.compile(r"heading changed more than (?P<limit>\S+) within"), "heading changed more than {limit}"),
    (re.compile(r"too short: .* < (?P<limit>.+)"), "too short (< {limit})"),
    (re.compile(r"sea not stationary: hindcast Hs changes .* > (?P<limit>.+)"),
     "sea not stationary (hindcast Hs change > {limit})"),
    (re.compile(r"motions not stationary: (?P<channel>\S+) variance ratio"),
     "motions not stationary ({channel} variance F-test)"),
)


def reason_kind(reason: str) -> str:
    for pattern, kind in REASON_KINDS:
        m = pattern.match(reason)
        if m:
            return kind.format(**m.groupdict())
    return reason.split(":")[0]


def rejection_counts(table: pd.DataFrame) -> list[tuple[str, int]]:
    """(kind of reason, candidates) of the rejected candidates of windows.parquet, most frequent first."""
    rejected = table.loc[~table["accepted"].astype(bool), "reason"].astype(str)
    counts = rejected.map(reason_kind).value_counts(sort=False)
    return sorted(((str(k), int(n)) for k, n in counts.items()), key=lambda kn: -kn[1])


def rejection_text(table: pd.DataFrame) -> str:
    """'4 moving (speed over ground > 0.5 m/s), 2 too short (< 20 min)', or 'none rejected'."""
    return ", ".join(f"{n} {kind}" for kind, n in rejection_counts(table)) or "none rejected"


WINDOW_UNITS = {"window_id": "", "start": "UTC", "end": "UTC", "duration_s": "s", "record": "", "accepted": "",
                "reason": "", "heading_deg": "deg", "sog": "m/s", "hs": "m", "tp": "s", "dir_from_deg": "deg"}


def windows_stage(run, echo=print, force: bool = False) -> dict:
    """Read motions/waves, find the candidates, write windows.parquet (with the hindcast at mid-window)."""
    from seatune.io.motion_table import MotionTable
    from seatune.io.parquet import write_table
    from seatune.io.rundir import fingerprint, is_fresh

    src = [run.artefact("motions.parquet"), run.artefact("waves.parquet")]
    fp = fingerprint(src, run.spec.windows.model_dump())
    out = run.artefact("windows.parquet")
    if not force and is_fresh([out], fp):
        return {"skipped": True}
    motions, waves = MotionTable(src[0]), pd.read_parquet(src[1])
    for path, df in zip(src, (motions, waves), strict=True):
        if not len(df):
            raise UserError(str(path), None, "too little data: no rows (re-run `seatune ingest` on the logs)")
    fs = run.spec.ingest.rate_hz
    columns = ["time", "record", "sog", "heading_deg", run.spec.windows.stationarity_channel]
    table = windows_table(scan_windows(motions.blocks(columns), waves, run.spec.windows, fs))
    mid = table["start"] + (table["end"] - table["start"]) / 2
    secs = (waves["time"] - waves["time"].iloc[0]).dt.total_seconds().to_numpy()
    at = (mid - waves["time"].iloc[0]).dt.total_seconds().to_numpy()
    for col in ("hs", "tp"):
        table[col] = np.interp(at, secs, waves[col].to_numpy())
    d = np.radians(waves["dir_from_deg"].to_numpy())
    east, north = np.interp(at, secs, np.sin(d)), np.interp(at, secs, np.cos(d))
    table["dir_from_deg"] = np.degrees(np.arctan2(east, north)) % 360
    write_table(table, out, WINDOW_UNITS, {"fingerprint": fp})
    return {"skipped": False, "candidates": len(table), "accepted": int(table["accepted"].sum()),
            "accepted_minutes": float(table.loc[table["accepted"], "duration_s"].sum() / 60),
            "rejected": rejection_text(table) if len(table) else "no candidate"}

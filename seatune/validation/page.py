"""The bank's short, self-contained HTML page: figures against targets, the confusion matrix, trial by trial."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import pandas as pd

from seatune.atomic import atomic_path

_STYLE = ("body{font:14px/1.45 system-ui,sans-serif;margin:1.5em auto;max-width:1200px;padding:0 1em;color:#212529}"
          "table{border-collapse:collapse;margin:.6em 0 1.4em;font-size:13px}td,th{border:1px solid #dee2e6;"
          "padding:3px 7px;text-align:right}th{background:#f1f3f5}td:first-child,th:first-child{text-align:left}"
          ".pass{color:#2b8a3e;font-weight:600}.miss{color:#c92a2a;font-weight:600}.wrap{overflow-x:auto}")

_TRIAL_COLUMNS = ["trial", "hull", "category", "hindcast_layout", "missing_swell", "n_windows", "true_effects",
                  "named_effects", "named_sea_side", "verdict", "gmt_fs_error", "r44_error", "beta44_error",
                  "omega_heave_rel_error", "omega_roll_rel_error", "omega_pitch_rel_error", "omega_roll_reason",
                  "heldout_error_prior", "heldout_error_tuned", "status"]


def _fmt(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (float, np.floating)):
        return "–" if not np.isfinite(v) else f"{v:.4g}"
    return html.escape(str(v))


def _table(df: pd.DataFrame, index: bool = False) -> str:
    if index:
        df = df.reset_index()
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
    rows = []
    for r in df.itertuples(index=False):
        cells = []
        for c, v in zip(df.columns, r, strict=True):
            cls = ""
            if c == "passed" and v is not None and not (isinstance(v, float) and np.isnan(v)):
                cls, v = ("pass", "pass") if v else ("miss", "miss")
            cells.append(f'<td class="{cls}">{_fmt(v)}</td>')
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return f'<div class="wrap"><table><tr>{head}</tr>{"".join(rows)}</table></div>'


def write_page(path: Path, summary: pd.DataFrame, metrics: pd.DataFrame, confusion: pd.DataFrame) -> Path:
    ok = summary["status"] == "ok"
    hulls = ", ".join(f"{k}: {v}" for k, v in summary["hull"].value_counts().items())
    body = [
        "<h1>seatune on the blind trial bank</h1>",
        f"<p>{int(ok.sum())} of {len(summary)} trials scored ({hulls}). "
        "Trials come from the independent path (<code>seatune.simulate.independent</code>): Capytaine RAOs, "
        "wavespectra seas, "
        "degraded ERA5 hindcasts; every figure below is measured against their truth. A missed target is shown, "
        "not hidden.</p>",
        "<h2>Figures against the targets</h2>", _table(metrics),
        "<h2>Diagnosis: truth (rows) × vessel-side effects named (columns)</h2>", _table(confusion, index=True),
        "<p>Sea-side explanations (missing swell, Hs bias, spreading) are not counted as alarms; they are listed per "
        "trial in <i>named_sea_side</i>.</p>",
        "<h2>Trial by trial</h2>", _table(summary[[c for c in _TRIAL_COLUMNS if c in summary]]),
    ]
    page = (f"<!doctype html><html lang=en><meta charset=utf-8><title>seatune trial bank</title>"
            f"<style>{_STYLE}</style><body>{''.join(body)}</body></html>")
    with atomic_path(path) as tmp:
        Path(tmp).write_text(page, encoding="utf-8")
    return path

"""The report page: one self-contained HTML file. CSS inline, plots as data: URIs, no script, no external URL,
so it opens the same from a mail attachment, a CI artefact store or a laptop offline."""

from __future__ import annotations

import html
import math
from collections.abc import Callable, Iterable

import numpy as np
import pandas as pd

CSS = """
:root { --ink: #1d2733; --muted: #5b6875; --line: #d5dbe1; --band: #f3f6f9; --ok: #1e7a46; --bad: #b3261e;
        --warn: #9a6700; --accent: #1f5f99; }
* { box-sizing: border-box; }
body { margin: 0; font: 15px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif;
       color: var(--ink); background: #fff; }
header { background: #15324d; color: #fff; padding: 22px 32px 16px; }
header h1 { margin: 0 0 4px; font-size: 26px; font-weight: 600; }
header p { margin: 0; color: #c9d6e3; }
nav { position: sticky; top: 0; z-index: 2; background: #eef2f6; border-bottom: 1px solid var(--line);
      padding: 6px 32px; font-size: 13.5px; display: flex; flex-wrap: wrap; gap: 2px 16px; }
nav a { color: var(--accent); text-decoration: none; white-space: nowrap; }
main { max-width: 1180px; margin: 0 auto; padding: 8px 32px 48px; }
section { border-bottom: 1px solid var(--line); padding: 8px 0 18px; }
h2 { font-size: 21px; margin: 22px 0 6px; color: #15324d; }
h3 { font-size: 16.5px; margin: 18px 0 6px; }
p.intro { color: var(--muted); margin: 2px 0 10px; max-width: 980px; }
table { border-collapse: collapse; margin: 8px 0 14px; font-size: 13.5px; }
caption { caption-side: top; text-align: left; font-weight: 600; padding: 4px 0; color: var(--ink); }
th, td { border-bottom: 1px solid var(--line); padding: 4px 8px; text-align: left; vertical-align: top; }
th { background: var(--band); font-weight: 600; white-space: nowrap; vertical-align: bottom; }
th .unit { font-weight: 400; color: var(--muted); }
td.wide { min-width: 12em; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
tr.rejected td { color: var(--muted); }
tr.flag td { background: #fff6e0; }
.scroll { overflow-x: auto; }
figure { margin: 10px 0 18px; }
figure img { max-width: 100%; height: auto; border: 1px solid var(--line); }
figcaption { color: var(--muted); font-size: 13.5px; max-width: 1000px; margin-top: 4px; }
.cards { display: grid; grid-template-columns: repeat(auto-fill, minmax(210px, 1fr)); gap: 10px; margin: 10px 0; }
.card { border: 1px solid var(--line); border-radius: 6px; padding: 8px 12px; background: var(--band); }
.card .k { font-size: 12.5px; color: var(--muted); text-transform: uppercase; letter-spacing: .03em; }
.card .v { font-size: 19px; font-weight: 600; }
.card .s { font-size: 12.5px; color: var(--muted); overflow-wrap: anywhere; }
.good { color: var(--ok); } .bad { color: var(--bad); } .warn { color: var(--warn); }
.alert { border: 1px solid #e8b4b0; border-left: 6px solid var(--bad); border-radius: 6px; background: #fdf0ef;
         padding: 8px 14px; margin: 10px 0; }
.alert .k { color: var(--bad); font-weight: 600; }
.note { border-left: 4px solid var(--warn); background: #fff8e6; padding: 6px 12px; margin: 8px 0; }
details summary { cursor: pointer; color: var(--accent); margin: 6px 0; }
footer { color: var(--muted); font-size: 12.5px; max-width: 1180px; margin: 0 auto; padding: 0 32px 32px; }
code { font-size: 12.5px; background: var(--band); padding: 0 3px; border-radius: 3px; }
"""


def esc(x) -> str:
    return html.escape(str(x), quote=True)


def fmt(value, digits: int = 4) -> str:
    """A table cell: '–' for missing, yes/no for booleans, `digits` significant figures for floats."""
    if value is None or (isinstance(value, float | np.floating) and not math.isfinite(value)):
        return "–"
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if isinstance(value, int | np.integer):
        return f"{int(value):,}"
    if isinstance(value, float | np.floating):
        v = float(value)
        if v != 0 and (abs(v) >= 10 ** digits or abs(v) < 1e-3):
            return f"{v:.{max(digits - 1, 1)}e}"
        if abs(v) >= 10 ** (digits - 1):
            return f"{v:,.0f}"
        text = f"{v:#.{digits}g}"  # keep significant trailing zeros: 2.00, not 2
        return text[:-1] if text.endswith(".") else text
    if isinstance(value, pd.Timestamp):
        return value.strftime("%Y-%m-%d %H:%M:%S")
    return str(value)


def header_label(name: str, unit: str | None) -> str:
    shown = unit and unit not in ("text", "per row")  # the Parquet markers of text and row-dependent units
    return f'{esc(name)}<br><span class="unit">[{esc(unit)}]</span>' if shown else esc(name)


def table(df: pd.DataFrame, units: dict[str, str] | None = None, caption: str | None = None,
          formats: dict[str, Callable] | None = None, row_class: Callable[[pd.Series], str] | None = None,
          digits: int = 4, wide: tuple[str, ...] = ()) -> str:
    """An HTML table of `df`; each header says its unit; numbers right-aligned; `wide` text columns keep room."""
    units, formats = units or {}, formats or {}
    head = "".join(f"<th>{header_label(c, units.get(c))}</th>" for c in df.columns)
    body = []
    for _, r in df.iterrows():
        cls = row_class(r) if row_class else ""
        cells = []
        for c in df.columns:
            v = r[c]
            text = formats[c](v) if c in formats else fmt(v, digits)
            num = isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool | np.bool_)
            cls_c = "num" if num else "wide" if c in wide else ""
            cells.append(f'<td class="{cls_c}">{esc(text)}</td>' if cls_c else f"<td>{esc(text)}</td>")
        body.append(f'<tr class="{cls}">' + "".join(cells) + "</tr>" if cls else "<tr>" + "".join(cells) + "</tr>")
    cap = f"<caption>{esc(caption)}</caption>" if caption else ""
    return f'<div class="scroll"><table>{cap}<thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table></div>'


def figure(png_base64: str, caption: str, alt: str) -> str:
    return (f'<figure><img src="data:image/png;base64,{png_base64}" alt="{esc(alt)}">'
            f"<figcaption>{esc(caption)}</figcaption></figure>")


def cards(items: Iterable[tuple[str, str, str]]) -> str:
    """Key-figure tiles: (label, value, small print)."""
    return '<div class="cards">' + "".join(
        f'<div class="card"><div class="k">{esc(k)}</div><div class="v">{esc(v)}</div><div class="s">{esc(s)}</div>'
        f"</div>" for k, v, s in items) + "</div>"


def alert(title: str, text: str) -> str:
    """A warning card: something the reader must not miss (no window accepted, tuning made things worse)."""
    return f'<div class="alert" role="alert"><div class="k">{esc(title)}</div><div>{esc(text)}</div></div>'


def note(text: str) -> str:
    return f'<p class="note">{esc(text)}</p>'


def para(text: str, cls: str = "intro") -> str:
    return f'<p class="{cls}">{esc(text)}</p>'


def details(summary: str, body: str) -> str:
    return f"<details><summary>{esc(summary)}</summary>{body}</details>"


def section(anchor: str, title: str, body: str, intro: str | None = None) -> str:
    return (f'<section id="{esc(anchor)}"><h2>{esc(title)}</h2>' + (para(intro) if intro else "") + body
            + "</section>")


def page(title: str, subtitle: str, sections: list[tuple[str, str, str]], footer: str, fingerprint: str) -> str:
    """The whole document; `sections` = (anchor, title, html). The fingerprint of the inputs goes in a meta tag
    so that the stage can tell an up-to-date page without parsing it."""
    nav = "".join(f'<a href="#{esc(a)}">{esc(t)}</a>' for a, t, _ in sections)
    return ("<!DOCTYPE html>\n"
            '<html lang="en"><head><meta charset="utf-8">\n'
            f'<meta name="seatune-fingerprint" content="{esc(fingerprint)}">\n'
            '<meta name="viewport" content="width=device-width, initial-scale=1">'
            '<link rel="icon" href="data:,">'
            f"<title>{esc(title)}</title><style>{CSS}</style></head><body>"
            f"<header><h1>{esc(title)}</h1><p>{esc(subtitle)}</p></header><nav>{nav}</nav><main>"
            + "".join(body for _, _, body in sections)
            + f"</main><footer>{footer}</footer></body></html>\n")

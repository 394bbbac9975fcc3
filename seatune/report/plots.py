"""The report's figures: matplotlib `Figure`s on the Agg canvas (no pyplot state, safe in batch workers), each
returned as a base64 PNG ready for a data: URI. Files keep radians; figures show angles in degrees and say so."""

from __future__ import annotations

import base64
import io
import math
import re
import threading
from collections.abc import Callable
from contextlib import contextmanager

import numpy as np
import pandas as pd
from matplotlib.dates import AutoDateLocator, DateFormatter
from matplotlib.figure import Figure

MEASURED, PRIOR, TUNED = "#222222", "#1f77b4", "#d9480f"
ACCEPTED, REJECTED = "#2b8a3e", "#adb5bd"
DPI = 96


def display_unit(unit: str) -> tuple[float, str]:
    """(factor, label): angles are shown in degrees ('rad/s' → 'deg/s', 'rad/m' → 'deg/m')."""
    if unit.startswith("rad"):
        return 180.0 / math.pi, "deg" + unit[3:]
    return 1.0, unit.replace("^2", "²")


_LOCAL = threading.local()  # .held: the figures png() was given inside drawn_together() on this thread


def png(build: Callable[..., Figure], *args, **kwargs) -> str:
    """The figure `build(*args, **kwargs)` as base64 PNG; inside `drawn_together`, a placeholder its `fill`
    replaces (the figure is then built and drawn there)."""
    held = getattr(_LOCAL, "held", None)
    if held is not None:
        held.append((build, args, kwargs))
        return f"\x00figure {len(held) - 1}\x00"
    return _build_and_draw((build, args, kwargs))


def _draw(fig: Figure) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _build_and_draw(held: tuple) -> str:
    build, args, kwargs = held
    return _draw(build(*args, **kwargs))


class _Held:
    def __init__(self, figures: list[tuple]):
        self.figures = figures

    def fill(self, text: str) -> str:
        """`text` with each placeholder replaced by its figure, the figures built and drawn over the CPUs
        (seatune.parallel): matplotlib's axes and rendering are most of a report's time, and each figure's PNG is
        the same bytes drawn anywhere."""
        from seatune.parallel import map_tasks

        drawn = map_tasks(_build_and_draw, self.figures)
        return re.sub("\x00figure (\\d+)\x00", lambda m: drawn[int(m.group(1))], text)


@contextmanager
def drawn_together():
    """Hold the figures png() is given; `fill` then builds and draws them all at once."""
    outer, _LOCAL.held = getattr(_LOCAL, "held", None), []
    try:
        yield _Held(_LOCAL.held)
    finally:
        _LOCAL.held = outer


def _naive_utc(t: pd.Series | pd.DatetimeIndex) -> np.ndarray:
    t = pd.DatetimeIndex(t)
    return (t.tz_convert("UTC").tz_localize(None) if t.tz is not None else t).to_numpy()


def _with_breaks(t: np.ndarray, *ys: np.ndarray, gap_s: float = 5.0):
    """Insert NaN where the record pauses so that lines do not bridge a logging gap."""
    cut = np.flatnonzero(np.diff(t).astype("timedelta64[ms]").astype(float) > gap_s * 1e3) + 1
    t = np.insert(t, cut, t[np.maximum(cut - 1, 0)])
    return (t, *[np.insert(y.astype(float), cut, np.nan) for y in ys])


def _time_axis(ax, day: str) -> None:
    ax.xaxis.set_major_locator(AutoDateLocator())
    ax.xaxis.set_major_formatter(DateFormatter("%H:%M"))
    ax.set_xlabel(f"time [UTC, {day}]")


def timeline(track: pd.DataFrame, windows: pd.DataFrame, waves: pd.DataFrame, max_sog: float | None) -> Figure:
    """Speed over ground, heading and the hindcast's Hs / Tp against time, candidate windows shaded."""
    fig = Figure(figsize=(11.5, 6.6), layout="constrained")
    axs = fig.subplots(3, 1, sharex=True, height_ratios=[1.1, 1, 1])
    t, sog, hdg = _with_breaks(_naive_utc(track["time"]), track["sog"].to_numpy(), track["heading_deg"].to_numpy())
    axs[0].plot(t, sog, color="#343a40", lw=0.8)
    if max_sog is not None:
        axs[0].axhline(max_sog, color=ACCEPTED, ls="--", lw=1, label=f"free-floating limit {max_sog:g} m/s")
        axs[0].legend(loc="upper right", fontsize=8.5, framealpha=0.9)
    axs[0].set_ylabel("SOG [m/s]")
    axs[1].plot(t, hdg, ".", color="#343a40", ms=0.8)
    axs[1].set_ylabel("heading ψ [deg]")
    axs[1].set_ylim(0, 360)
    axs[1].set_yticks([0, 90, 180, 270, 360])
    tw = _naive_utc(waves["time"])
    axs[2].plot(tw, waves["hs"], "o-", color=PRIOR, ms=3, lw=1.2, label="Hs")
    axs[2].set_ylabel("hindcast Hs [m]", color=PRIOR)
    ax_tp = axs[2].twinx()
    ax_tp.plot(tw, waves["tp"], "s--", color="#7048e8", ms=3, lw=1, label="Tp")
    ax_tp.set_ylabel("hindcast Tp [s]", color="#7048e8")
    start, end = _naive_utc(windows["start"]), _naive_utc(windows["end"])
    for k, row in enumerate(windows.itertuples()):
        colour = ACCEPTED if row.accepted else REJECTED
        for ax in axs:
            ax.axvspan(start[k], end[k], color=colour, alpha=0.18 if row.accepted else 0.12, lw=0)
        mid = start[k] + (end[k] - start[k]) / 2
        if row.accepted or (end[k] - start[k]) > np.timedelta64(15, "m"):
            axs[0].text(mid, 1.02, f"W{row.window_id}", transform=axs[0].get_xaxis_transform(), ha="center",
                        va="bottom", fontsize=8.5, color=colour if row.accepted else "#495057",
                        fontweight="bold" if row.accepted else "normal")
    for ax in axs:
        ax.grid(alpha=0.3)
    _time_axis(axs[2], pd.Timestamp(start[0]).strftime("%Y-%m-%d"))
    return fig


def track_map(track: pd.DataFrame, windows: pd.DataFrame) -> Figure:
    """The GNSS track (lat/lon) with the candidate windows marked: accepted thick and coloured."""
    fig = Figure(figsize=(8.5, 6.8), layout="constrained")
    ax = fig.subplots()
    ok = np.isfinite(track["lat"].to_numpy()) & np.isfinite(track["lon"].to_numpy())
    tr = track[ok]
    t = _naive_utc(tr["time"])
    _, lat, lon = _with_breaks(t, tr["lat"].to_numpy(), tr["lon"].to_numpy())
    ax.plot(lon, lat, color=REJECTED, lw=1.0, label="track (transit / rejected)")
    colours = ["#2b8a3e", "#e8590c", "#1971c2", "#ae3ec9", "#c92a2a", "#0b7285", "#5c940d", "#862e9c"]
    k = 0
    for row in windows.itertuples():
        sel = (tr["time"] >= row.start) & (tr["time"] <= row.end)
        if not sel.any():
            continue
        lo, la = tr.loc[sel, "lon"].to_numpy(), tr.loc[sel, "lat"].to_numpy()
        if row.accepted:
            c = colours[k % len(colours)]
            k += 1
            ax.plot(lo, la, color=c, lw=3, label=f"W{row.window_id}: heading {row.heading_deg:.0f}°, "
                                                   f"Hs {row.hs:.1f} m")
            ax.annotate(f"W{row.window_id}", (lo[len(lo) // 2], la[len(la) // 2]), xytext=(6, 6),
                        textcoords="offset points", color=c, fontweight="bold", fontsize=9)
        else:
            ax.annotate(f"W{row.window_id}", (lo[len(lo) // 2], la[len(la) // 2]), xytext=(4, -10),
                        textcoords="offset points", color="#868e96", fontsize=8)
    ax.plot(tr["lon"].iloc[0], tr["lat"].iloc[0], "k^", ms=7, label="start")
    ax.plot(tr["lon"].iloc[-1], tr["lat"].iloc[-1], "ks", ms=6, label="end")
    ax.set_aspect(1.0 / max(math.cos(math.radians(float(np.nanmean(tr["lat"])))), 1e-3))
    ax.set_xlabel("longitude [deg E]")
    ax.set_ylabel("latitude [deg N]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8.5, loc="best", framealpha=0.9)
    return fig


def rao_sector(rows: pd.DataFrame, units: dict[str, str], ncols: int = 4) -> Figure:
    """Measured effective RAO with its interval against the prior (and tuned) model, one panel per channel.

    rows: aggregate rows of raos.parquet for one (sector, Hs bin), optionally with a `model_tuned` column.
    """
    channels = list(dict.fromkeys(rows["channel"]))
    ncols = min(ncols, len(channels))
    nrows = math.ceil(len(channels) / ncols)
    height = 2.7 * nrows + 0.6
    fig = Figure(figsize=(11.5, height))  # fixed margins: constrained layout took a second per grid
    gap, avail = 0.8, height - 0.55 - 0.6  # inches: between rows (title + x label), for the axes
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.55 / height, top=1 - 0.6 / height, wspace=0.32,
                        hspace=gap / ((avail - gap * (nrows - 1)) / nrows))
    axs = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False)).ravel()
    for ax, ch in zip(axs, channels, strict=False):
        part = rows[rows["channel"] == ch].sort_values("omega")
        f, label = display_unit(units.get(ch, ""))
        om = part["omega"].to_numpy()
        ax.fill_between(om, f * part["ci_low"], f * part["ci_high"], color="#adb5bd", alpha=0.5, lw=0,
                        label="measured, confidence interval")
        ax.plot(om, f * part["rao_amp"], "o-", color=MEASURED, ms=2.5, lw=1.2, label="measured")
        ax.plot(om, f * part["model_prior"], "--", color=PRIOR, lw=1.6, label="model, prior loading", zorder=4)
        if "model_tuned" in part and part["model_tuned"].notna().any():
            ax.plot(om, f * part["model_tuned"], "-", color=TUNED, lw=1.6, label="model, tuned loading", zorder=3)
        ax.set_title(ch, fontsize=10)
        ax.set_ylabel(f"|H| [{label}/m]" if label else "|H| [1/m]", fontsize=9)
        ax.set_xlabel("ω [rad/s]", fontsize=9)
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
    for ax in axs[len(channels):]:
        ax.set_visible(False)
    handles, labels = axs[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncols=4, fontsize=9, frameon=False)
    return fig


def spectrum_unit(unit: str) -> tuple[float, str]:
    """(factor, label) of a response spectrum of a channel in `unit`, angles in degrees: 'deg²·s/rad'."""
    f, label = display_unit(unit)
    label = f"({label})" if "/" in label or "·" in label else label or "1"
    return f * f, f"{label}²·s/rad"


def response_spectra(rows: pd.DataFrame, units: dict[str, str], title: str) -> Figure:
    """One window: the measured Welch spectrum of each main channel against the model's with the prior and the
    tuned loading (rows of `model_spectra`: channel, omega, measured, prior[, tuned])."""
    channels = list(dict.fromkeys(rows["channel"]))
    fig = Figure(figsize=(11.5, 3.4))
    fig.subplots_adjust(left=0.07, right=0.99, bottom=0.15, top=0.72, wspace=0.3)
    axs = np.atleast_1d(fig.subplots(1, max(len(channels), 1), squeeze=False)).ravel()
    for ax, ch in zip(axs, channels, strict=False):
        part = rows[rows["channel"] == ch].sort_values("omega")
        f, label = spectrum_unit(units.get(ch, ""))
        om = part["omega"].to_numpy()
        ax.plot(om, f * part["measured"].to_numpy(dtype=float), "-", color=MEASURED, lw=1.0,
                label="measured (Welch, filter stage)")
        ax.plot(om, f * part["prior"].to_numpy(dtype=float), "--", color=PRIOR, lw=1.6, label="model, prior loading")
        if "tuned" in part and part["tuned"].notna().any():
            ax.plot(om, f * part["tuned"].to_numpy(dtype=float), "-", color=TUNED, lw=1.6,
                    label="model, tuned loading")
        ax.set_title(ch, fontsize=10)
        ax.set_ylabel(f"S [{label}]", fontsize=9)
        ax.set_xlabel("ω [rad/s]", fontsize=9)
        ax.set_xlim(om.min(), om.max())
        ax.set_ylim(bottom=0)
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
    handles, labels = axs[0].get_legend_handles_labels()
    fig.suptitle(title, x=0.07, y=0.985, ha="left", fontsize=10.5)
    fig.legend(handles, labels, loc="upper left", bbox_to_anchor=(0.065, 0.915), ncols=3, fontsize=9, frameon=False)
    return fig


def natural_frequency_plot(nf: pd.DataFrame, tuned: dict[str, float] | None) -> Figure:
    """Per DOF: each window's ω_n with its interval, the combined value (bold), the prior and tuned model."""
    nf = nf[nf["derived"].isna()] if "derived" in nf else nf
    dofs = list(dict.fromkeys(nf["dof"]))
    heights = [max(len(nf[nf["dof"] == d]), 1) + 1 for d in dofs]
    fig = Figure(figsize=(11.0, 0.34 * sum(heights) + 1.4), layout="constrained")
    axs = np.atleast_1d(fig.subplots(len(dofs), 1, height_ratios=heights, squeeze=False)).ravel()
    for ax, dof in zip(axs, dofs, strict=True):
        part = nf[nf["dof"] == dof].reset_index(drop=True)
        y = np.arange(len(part))[::-1]
        combined = (part["window_id"] == "all").to_numpy()
        om = part["omega_n"].to_numpy()
        err = np.vstack([om - part["ci_low"].to_numpy(), part["ci_high"].to_numpy() - om])
        for sel, style in ((~combined, dict(fmt="o", color="#495057", ms=4, lw=1)),
                           (combined, dict(fmt="D", color=MEASURED, ms=6, lw=2.2))):
            if sel.any():
                ax.errorbar(om[sel], y[sel], xerr=err[:, sel], capsize=3, **style)
        ax.set_yticks(y, [f"{m.replace('_', ' ')} · {'combined' if w == 'all' else 'W' + str(w)}"
                          for m, w in zip(part["method"], part["window_id"], strict=True)], fontsize=8.5)
        prior = float(part["model_prior"].iloc[0])
        ax.axvline(prior, color=PRIOR, ls="--", lw=1.6, label=f"prior model {prior:.3f} rad/s", zorder=4)
        if tuned and dof in tuned and np.isfinite(tuned[dof]):
            ax.axvline(tuned[dof], color=TUNED, lw=1.6, label=f"tuned model {tuned[dof]:.3f} rad/s", zorder=3)
        ax.set_title(f"{dof}", fontsize=10, loc="left")
        ax.set_ylim(-0.8, len(part) - 0.2)
        ax.grid(alpha=0.3, axis="x")
        ax.legend(fontsize=8, loc="lower right", framealpha=0.9)
        ax.set_xlabel("natural frequency ω_n [rad/s]", fontsize=9)
    return fig


def _update_labels(history: pd.DataFrame) -> tuple[np.ndarray, list[str]]:
    ups = history.drop_duplicates("update").sort_values("update")
    return ups["update"].to_numpy(), ["prior" if u == 0 else f"W{w}" for u, w in zip(ups["update"], ups["window_id"],
                                                                                     strict=True)]


def convergence(history: pd.DataFrame, units: dict[str, str]) -> Figure:
    """Per parameter, mean ± 1σ and the 5–95 % interval after each update (update 0 = prior)."""
    params = list(dict.fromkeys(history["parameter"]))
    ncols = min(3, len(params))
    nrows = math.ceil(len(params) / ncols)
    fig = Figure(figsize=(11.5, 3.0 * nrows + 0.5), layout="constrained")
    axs = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False)).ravel()
    x, labels = _update_labels(history)
    for ax, p in zip(axs, params, strict=False):
        h = history[history["parameter"] == p].sort_values("update")
        u, m, s = h["update"].to_numpy(), h["mean"].to_numpy(), h["std"].to_numpy()
        ax.fill_between(u, h["q05"], h["q95"], color=TUNED, alpha=0.15, lw=0, label="5–95 % interval")
        ax.fill_between(u, m - s, m + s, color=TUNED, alpha=0.3, lw=0, label="mean ± 1σ")
        ax.plot(u, m, "o-", color=TUNED, lw=1.6, ms=4, label="posterior mean")
        ax.plot(u, h["q50"], ":", color="#495057", lw=1.2, label="median")
        ax.axhline(m[0], color=PRIOR, ls="--", lw=1, label="prior mean")
        ax.set_xticks(x, labels, fontsize=8.5)
        unit = units.get(p, "")
        ax.set_ylabel(f"{p} [{unit}]" if unit else p, fontsize=9)
        ax.set_xlabel("after update (window)", fontsize=9)
        ax.grid(alpha=0.3)
    for ax in axs[len(params):]:
        ax.set_visible(False)
    handles, lab = axs[0].get_legend_handles_labels()
    fig.legend(handles, lab, loc="outside upper center", ncols=5, fontsize=9, frameon=False)
    return fig


def marginals(history: pd.DataFrame, units: dict[str, str], pmf: dict[str, list[tuple[str, np.ndarray,
              np.ndarray]]] | None) -> Figure:
    """Per parameter, the marginal after each update: the backend's PMF where the history carries it, otherwise
    the Gaussian with the recorded mean and std (q05 / q95 marked as ticks)."""
    params = list(dict.fromkeys(history["parameter"]))
    ncols = min(3, len(params))
    nrows = math.ceil(len(params) / ncols)
    fig = Figure(figsize=(11.5, 2.9 * nrows + 0.5), layout="constrained")
    axs = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False)).ravel()
    x, labels = _update_labels(history)
    shades = [PRIOR] + [f"C{k}" for k in range(1, len(x))] if len(x) < 10 else None
    for ax, p in zip(axs, params, strict=False):
        h = history[history["parameter"] == p].sort_values("update").reset_index(drop=True)
        lo = float((h["mean"] - 4 * h["std"]).min())
        hi = float((h["mean"] + 4 * h["std"]).max())
        grid = np.linspace(lo, hi, 400)
        for k, r in h.iterrows():
            colour = shades[k] if shades else None
            lw = 2.2 if k == len(h) - 1 else 1.2
            if pmf and p in pmf and k < len(pmf[p]):
                _, g, w = pmf[p][k]
                dens = w / np.maximum(np.gradient(g), 1e-300)
                ax.plot(g, dens, color=colour, lw=lw, label=labels[k])
            else:
                dens = np.exp(-0.5 * ((grid - r["mean"]) / r["std"]) ** 2) / (r["std"] * math.sqrt(2 * math.pi))
                ax.plot(grid, dens, color=colour, lw=lw, ls="--" if k == 0 else "-", label=labels[k])
            ax.plot([r["q05"], r["q95"]], [0, 0], "|", color=colour, ms=12, mew=2)
        unit = units.get(p, "")
        ax.set_xlabel(f"{p} [{unit}]" if unit else p, fontsize=9)
        ax.set_ylabel("probability density", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, title="after", title_fontsize=8)
    for ax in axs[len(params):]:
        ax.set_visible(False)
    return fig


def correlation(names: list[str], corr: np.ndarray, title: str) -> Figure:
    n = len(names)
    fig = Figure(figsize=(1.3 * n + 2.6, 1.1 * n + 1.4), layout="constrained")
    ax = fig.subplots()
    im = ax.imshow(corr, vmin=-1, vmax=1, cmap="RdBu_r")
    ax.set_xticks(range(n), names)
    ax.set_yticks(range(n), names)
    for i in range(n):
        for j in range(n):
            ax.text(j, i, f"{corr[i, j]:.2f}", ha="center", va="center", fontsize=9,
                    color="white" if abs(corr[i, j]) > 0.6 else "black")
    fig.colorbar(im, ax=ax, label="correlation [-]")
    ax.set_title(title, fontsize=10)
    return fig


def validation_plots(val: pd.DataFrame, units: dict[str, str]) -> Figure:
    """Left: predicted / measured per measurement and window (1 = perfect), prior vs tuned, held-out windows
    marked. Right: predicted against measured on log axes with the 1:1 line and ±20 %."""
    fig = Figure(figsize=(11.5, 4.8), layout="constrained")
    ax_r, ax_s = fig.subplots(1, 2, width_ratios=[1.35, 1])
    names = list(dict.fromkeys(val["measurement"]))
    pos = {n: i for i, n in enumerate(names)}
    x = val["measurement"].map(pos).to_numpy(dtype=float)
    held = (val["role"] == "holdout").to_numpy()
    meas = val["measured"].to_numpy(dtype=float)
    for col, colour, dx, label in (("predicted_prior", PRIOR, -0.13, "prior"), ("predicted_tuned", TUNED, 0.13,
                                                                               "tuned")):
        ratio = val[col].to_numpy(dtype=float) / meas
        ax_r.scatter(x[~held] + dx, ratio[~held], s=22, color=colour, alpha=0.75, label=f"{label}, training window")
        ax_r.scatter(x[held] + dx, ratio[held], s=46, facecolor="white", edgecolor=colour, lw=1.8,
                     label=f"{label}, held-out window")
    ax_r.axhline(1.0, color="#495057", lw=1)
    ax_r.axhspan(0.8, 1.25, color="#adb5bd", alpha=0.2, lw=0)
    ax_r.set_yscale("log")
    lo_r, hi_r = ax_r.get_ylim()
    ticks = [t for t in (0.25, 0.5, 0.67, 0.8, 1.0, 1.25, 1.5, 2.0, 4.0) if lo_r <= t <= hi_r]
    ax_r.set_yticks(ticks, [f"{t:g}" for t in ticks])
    ax_r.minorticks_off()
    ax_r.set_xticks(range(len(names)), [n.replace(":sigma", " σ").replace(":tz", " Tz") for n in names],
                    rotation=35, ha="right", fontsize=8.5)
    ax_r.set_ylabel("predicted / measured [-]")
    ax_r.grid(alpha=0.3, which="both")
    ax_r.legend(fontsize=8, ncols=2, loc="upper left", framealpha=0.9)
    channel = val["measurement"].str.split(":").str[0]
    f = channel.map(lambda c: display_unit(units.get(c, ""))[0]).to_numpy(dtype=float)
    lo, hi = np.nanmin(meas * f), np.nanmax(meas * f)
    line = np.array([lo / 1.5, hi * 1.5])
    ax_s.plot(line, line, color="#495057", lw=1, label="1:1")
    ax_s.fill_between(line, line / 1.2, line * 1.2, color="#adb5bd", alpha=0.25, lw=0, label="±20 %")
    for col, colour, label in (("predicted_prior", PRIOR, "prior"), ("predicted_tuned", TUNED, "tuned")):
        p = val[col].to_numpy(dtype=float) * f
        ax_s.scatter(meas[~held] * f[~held], p[~held], s=20, color=colour, alpha=0.75, label=label)
        ax_s.scatter(meas[held] * f[held], p[held], s=44, facecolor="white", edgecolor=colour, lw=1.8)
    ax_s.set_xscale("log")
    ax_s.set_yscale("log")
    ax_s.set_xlabel("measured [channel unit; angles in deg]")
    ax_s.set_ylabel("predicted [channel unit; angles in deg]")
    ax_s.grid(alpha=0.3, which="both")
    ax_s.legend(fontsize=8, loc="upper left")
    return fig


def exceedance_polar(pred: pd.DataFrame, title: str) -> Figure:
    """P(max > limit) against compass heading (north up, clockwise) for the prior and the tuned model."""
    fig = Figure(figsize=(5.6, 5.2), layout="constrained")
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    for model, color in (("prior", "0.55"), ("tuned", "C0")):
        rows = pred[pred["model"] == model].sort_values("heading_deg")
        if rows.empty:
            continue
        th = np.radians(np.r_[rows["heading_deg"].to_numpy(), rows["heading_deg"].iloc[0]])
        pr = np.r_[rows["exceedance_probability"].to_numpy(), rows["exceedance_probability"].iloc[0]]
        ax.plot(th, 100 * pr, color=color, lw=2 if model == "tuned" else 1.4, label=f"{model} model")
        best = rows.loc[rows["exceedance_probability"].idxmin()]
        ax.plot(np.radians(best["heading_deg"]), 100 * best["exceedance_probability"], "o", color=color)
    ax.set_rlabel_position(135)
    ax.set_ylim(0, 100)
    ax.set_title(title, fontsize=10)
    ax.legend(loc="lower left", bbox_to_anchor=(-0.15, -0.12), fontsize=8)
    return fig


def residual_maps(rows: pd.DataFrame, channels: list[str], title_after: str) -> Figure:
    """Log spectral ratio ln(measured / model) over ω × window, before and after the diagnosis, per channel;
    held-out windows marked; bins not analysed blank."""
    windows = list(dict.fromkeys(rows["window_id"]))
    omega = np.sort(rows["omega"].unique())
    fig = Figure(figsize=(11.5, 1.0 + 1.9 * len(channels)), layout="constrained")
    axes = np.atleast_2d(fig.subplots(len(channels), 2, sharex=True, sharey=True, squeeze=False))
    image = None
    for i, ch in enumerate(channels):
        part = rows[rows["channel"] == ch]
        for j, (col, label) in enumerate((("log_ratio_before", "tuned model before"),
                                          ("log_ratio_after", title_after))):
            grid = part.pivot(index="window_id", columns="omega", values=col).reindex(index=windows, columns=omega)
            used = part.pivot(index="window_id", columns="omega", values="used").reindex(index=windows, columns=omega)
            values = np.where(used.fillna(False).to_numpy(dtype=bool), grid.to_numpy(dtype=float), np.nan)
            ax = axes[i, j]
            image = ax.pcolormesh(omega, np.arange(len(windows)), values, cmap="RdBu_r", vmin=-1.5, vmax=1.5,
                                  shading="nearest")
            held = rows.drop_duplicates("window_id").set_index("window_id").loc[windows, "role"] == "holdout"
            ax.set_yticks(range(len(windows)), [f"{w}{' (held out)' if h else ''}" for w, h in zip(windows, held,
                                                                                               strict=True)],
                          fontsize=7.5)
            ax.set_title(f"{ch}: {label}", fontsize=9)
            if i == len(channels) - 1:
                ax.set_xlabel("ω [rad/s]")
    if image is not None:
        fig.colorbar(image, ax=axes, shrink=0.8, label="ln(measured / model) [-]")
    return fig


def sea_polars(sea: pd.DataFrame, max_windows: int = 6) -> Figure:
    """Per window, the estimated directional spectrum S(f, D) (period rings, waves coming from, north up,
    clockwise), the estimated partitions (o, labelled Hs) and the hindcast's (x)."""
    from seatune.identification.sea_estimation import DIRS_FROM, partition_spectrum, table_coordinates

    ids = list(dict.fromkeys(sea["window_id"]))[:max_windows]
    ncols = min(3, len(ids))
    nrows = int(np.ceil(len(ids) / ncols))
    fig = Figure(figsize=(4.0 * ncols, 3.9 * nrows), layout="constrained")
    periods = np.linspace(4.0, 22.0, 90)
    omega = 2 * np.pi / periods
    for k, wid in enumerate(ids):
        part = sea[sea["window_id"] == wid]
        ax = fig.add_subplot(nrows, ncols, k + 1, projection="polar")
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        s = partition_spectrum(omega, DIRS_FROM, table_coordinates(part))  # (n periods, n directions)
        th = np.radians(np.r_[DIRS_FROM, 360.0])
        ax.contourf(th, periods, np.c_[s, s[:, :1]], levels=12, cmap="Blues")
        ax.plot(np.radians(part["dir_from_deg"]), part["tp"], "o", color="C3", ms=5)
        for r in part.itertuples():
            ax.annotate(f"{r.hs:.1f} m", (np.radians(r.dir_from_deg), r.tp), fontsize=7, color="C3")
        ax.plot(np.radians(part["hindcast_dir_from_deg"]), part["hindcast_tp"], "x", color="k", ms=6)
        ax.set_ylim(0, 22)
        ax.set_yticks([5, 10, 15, 20])
        ax.set_yticklabels(["5 s", "10", "15", "20"], fontsize=7)
        ax.tick_params(labelsize=7)
        ax.set_title(f"W{wid}", fontsize=9)
    return fig

"""`seatune predict`: decision support from the tuned model (Han A5 RESP / RISK; thesis eqs. 3.10–3.13).

For every forecast time at the planned position, the probability that the maximum of a critical response
(run YAML `predict.channel`, e.g. the crane-tip vertical velocity) over `predict.duration_s` exceeds
`predict.limit`, for every heading 0–360°, and the heading that minimises it — once with the tuned model and once
with the prior model, so the value of the tuning is visible.

Uncertainty, as discrete mixtures (A5 eq. 14 / thesis eq. 3.12a):
* loading φ: the Gaussian of the last tuning update (mean and the `cov_<parameter>` covariance of
  tuning_history.parquet) — or, for the prior model, the vessel YAML priors — as 3-point Gauss–Hermite points
  along its principal axes (3^p points, exact to 5th-order moments per axis; a 2p-point spherical cubature rule
  above 5 parameters), clipped to the priors' bounds. DBI's marginal PMFs are not used: their product would
  drop the correlations the covariance keeps.
* sea state θ: the forecast's own 2-D spectrum S0(ω, D) at the position and time (JONSWAP + cos-2s from the
  bulk parameters when the file has no spectra), rescaled self-similarly as the tuning's forward model does,
  S(ω, D) = (Hs/Hs0)² (Tp/Tp0) S0(ω Tp/Tp0, D), and rotated by a direction error δ; 3-point Gauss–Hermite
  hypotheses in each of Hs, Tp, δ (27) with the errors of `predict.uncertainty` (default: the run's
  `hindcast.uncertainty`, A5 Table 2 / thesis Table 4.1).
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd

from seatune.errors import UserError
from seatune.physics.spectra import direction_step

CHANNEL_PER_ROW = "per row; the unit of the row's channel"
PREDICTION_UNITS = {"time": "", "model": "", "channel": "", "heading_deg": "deg",
                    "exceedance_probability": "dimensionless",
                    "most_probable_max": CHANNEL_PER_ROW, "median_max": CHANNEL_PER_ROW, "sigma": CHANNEL_PER_ROW,
                    "tz": "s", "optimal_heading_deg": "deg", "optimal_probability": "dimensionless", "is_optimal": "",
                    "limit": CHANNEL_PER_ROW, "duration_s": "s", "hs": "m", "tp": "s", "dir_from_deg": "deg",
                    "lat": "deg", "lon": "deg", "posterior_points": "", "sea_state_hypotheses": ""}
CHANNEL_UNITS = {"angle": "rad", "rate": "rad/s", "displacement": "m", "velocity": "m/s", "acceleration": "m/s^2",
                 "specific_force": "m/s^2"}  # what the vessel YAML requires of each channel kind
MAX_GH_PARAMETERS = 5  # 3^5 = 243 Gauss–Hermite points; above, the 2p-point cubature rule
SPECTRA_BYTES = 64 * 2**20  # posterior points are evaluated in chunks whose response spectra fit this


# ------------------------------------------------------------------------------------------- pure computation


def gaussian_points(mean: np.ndarray, cov: np.ndarray, lower=None, upper=None) -> tuple[np.ndarray, np.ndarray]:
    """Points and weights of a Gaussian N(mean, cov) over p parameters: (n, p), (n,).

    3-point Gauss–Hermite nodes (0, ±√3; weights 2/3, 1/6) along each principal axis of cov, tensor product
    (p ≤ 5), else the third-degree spherical cubature ±√p along each axis (weights 1/(2p)). Clipped to the bounds.
    """
    from seatune.pipeline.tune import GH_NODES, GH_WEIGHTS

    mean = np.asarray(mean, dtype=float)
    p = mean.size
    vals, vecs = np.linalg.eigh(0.5 * (cov + np.transpose(cov)))
    root = vecs * np.sqrt(np.clip(vals, 0.0, None))  # cov = root rootᵀ
    if p <= MAX_GH_PARAMETERS:
        grids = np.meshgrid(*([GH_NODES] * p), indexing="ij")
        nodes = np.stack([g.ravel() for g in grids], axis=1)
        weights = np.prod(np.stack(np.meshgrid(*([GH_WEIGHTS] * p), indexing="ij")).reshape(p, -1), axis=0)
    else:
        nodes = np.sqrt(p) * np.vstack([np.eye(p), -np.eye(p)])
        weights = np.full(2 * p, 1.0 / (2 * p))
    points = mean + nodes @ root.T
    if lower is not None or upper is not None:
        points = np.clip(points, lower if lower is not None else -np.inf, upper if upper is not None else np.inf)
    return points, weights / weights.sum()


def sea_state_hypotheses(hs_rel_std: float, tp_std_s: float, tp0: float, dir_std_deg: float):
    """27 hypotheses (3-point Gauss–Hermite in Hs × Tp × direction, A5 eq. 14's PMF(θ_s)):
    (hs_ratio, tp_ratio, offset_deg, weights), each (27,)."""
    from seatune.pipeline.tune import GH_NODES, GH_WEIGHTS

    a, b, c = np.meshgrid(GH_NODES, GH_NODES, GH_NODES, indexing="ij")
    hs_ratio = np.maximum(1.0 + a.ravel() * hs_rel_std, 1e-3)
    tp_ratio = np.maximum(1.0 + b.ravel() * tp_std_s / tp0, 1e-3)
    offset = c.ravel() * dir_std_deg
    weights = np.einsum("i,j,k->ijk", GH_WEIGHTS, GH_WEIGHTS, GH_WEIGHTS).ravel()
    return hs_ratio, tp_ratio, offset, weights / weights.sum()


def scaled_spectra(omega: np.ndarray, spectrum0: np.ndarray, hs_ratio: np.ndarray, tp_ratio: np.ndarray):
    """S_h(ω, D) = (Hs/Hs0)² r S0(ω r, D), r = Tp/Tp0 (a self-similar sea; zero outside the grid): (h, nw, nD)."""
    x = omega[None, :] * tp_ratio[:, None]  # (h, nw)
    i = np.clip(np.searchsorted(omega, x) - 1, 0, omega.size - 2)
    f = (x - omega[i]) / (omega[i + 1] - omega[i])
    inside = (x >= omega[0]) & (x <= omega[-1])
    s = (1 - f)[..., None] * spectrum0[i] + f[..., None] * spectrum0[i + 1]  # (h, nw, nD)
    return np.where(inside[..., None], s, 0.0) * (hs_ratio**2 * tp_ratio)[:, None, None]


def risk_over_headings(omega: np.ndarray, power: np.ndarray, belief_weights: np.ndarray, waves: np.ndarray,
                       sea_weights: np.ndarray, rotation: np.ndarray, d_dir: float, limit: float,
                       duration_s: float) -> dict[str, np.ndarray]:
    """Exceedance probability and maxima statistics of one channel per heading (A5 eqs. 11–16, thesis 3.10–3.13).

    power (nw, n, nb) |H|² per posterior point; belief_weights (n,); waves (h, nw, nD); sea_weights (h,);
    rotation (h, p, nD, nb). Returns arrays over the p headings: probability, most_probable_max, median_max,
    sigma (√ of the mixture's variance), tz (of the mixture's m0 and m2).
    """
    from seatune.physics.extremes import (
        heading_response_spectra,
        mixture_exceedance,
        mixture_mode,
        mixture_quantile,
        moments,
    )

    nw, n, _ = power.shape
    h, p = rotation.shape[:2]
    chunk = max(1, int(SPECTRA_BYTES // (8 * nw * h * p)))
    m0 = np.empty((n, h, p))
    m2 = np.empty((n, h, p))
    for s in range(0, n, chunk):
        spectra = heading_response_spectra(power[:, s:s + chunk], waves, rotation, d_dir)  # thesis eq. 3.10
        m0[s:s + chunk], m2[s:s + chunk] = moments(omega, spectra)
    m0 = m0.transpose(2, 0, 1).reshape(p, n * h)
    m2 = m2.transpose(2, 0, 1).reshape(p, n * h)
    w = np.outer(belief_weights, sea_weights).ravel()  # PMF(φ_r)·PMF(θ_s) (eq. 3.12a)
    mean_m0, mean_m2 = m0 @ w, m2 @ w
    return {"probability": mixture_exceedance(limit, m0, m2, duration_s, w),  # eq. 3.12b
            "most_probable_max": mixture_mode(m0, m2, duration_s, w),
            "median_max": mixture_quantile(0.5, m0, m2, duration_s, w),
            "sigma": np.sqrt(mean_m0),
            "tz": 2 * np.pi * np.sqrt(mean_m0 / np.where(mean_m2 > 0, mean_m2, np.nan))}


def time_step(omega, grid_deg, headings, spectrum0, dirs_from, tp0: float, uncertainty, power, belief_weights,
              limit: float, duration_s: float) -> dict:
    """One forecast time, one model: the 27 sea-state hypotheses around the forecast spectrum S0(ω, D) (errors
    `uncertainty` = (hs_rel_std, tp_std_s, dir_std_deg)), every heading, the risk and the optimal heading."""
    from seatune.physics.extremes import optimal_heading, rotation_operator

    d_dir = direction_step(dirs_from)
    hs_ratio, tp_ratio, offsets, sea_w = sea_state_hypotheses(uncertainty[0], uncertainty[1], tp0, uncertainty[2])
    waves = scaled_spectra(omega, spectrum0, hs_ratio, tp_ratio)
    rotation = rotation_operator(dirs_from, grid_deg, headings, offsets)
    r = risk_over_headings(omega, power, belief_weights, waves, sea_w, rotation, d_dir, limit, duration_s)
    best, best_p = optimal_heading(headings, r["probability"])  # thesis eq. 3.13
    return {**r, "optimal_heading_deg": float(best), "optimal_probability": float(best_p),
            "hypotheses": int(sea_w.size)}


# ------------------------------------------------------------------------------------------------- the stage


def check_settings(run, vessel):
    """The predict block and its channel, before any stage runs (a bad config fails fast, exit 2)."""
    settings = run.spec.predict
    if settings is None:
        raise UserError(str(run.path), "predict", "missing: `seatune predict` needs a predict block "
                                                  "{channel, limit, duration_s, headings_deg}")
    names = [c.name for c in vessel.channels]
    if settings.channel not in names:
        raise UserError(str(run.path), "predict.channel",
                        f"no vessel channel {settings.channel!r} (channels: {', '.join(names)})")
    return settings


def beliefs(run, vessel, history: pd.DataFrame):
    """{'prior': (names, points, weights), 'tuned': …}: the vessel priors and the last tuning update."""
    from seatune.pipeline.tune import tuning_parameters

    parameters = tuning_parameters(run, vessel)
    names = [p.name for p in parameters]
    lower = np.array([p.lower for p in parameters])
    upper = np.array([p.upper for p in parameters])
    last = history[history["update"] == history["update"].max()].set_index("parameter")
    missing = [n for n in names if n not in last.index or f"cov_{n}" not in last.columns]
    if missing:
        raise UserError(str(run.artefact("tuning_history.parquet")), "parameter",
                        f"no posterior for {', '.join(missing)}: run `seatune tune --force tune`")
    mean = last.loc[names, "mean"].to_numpy(float)
    cov = last.loc[names, [f"cov_{n}" for n in names]].to_numpy(float)
    prior_mean = np.array([p.prior_mean for p in parameters])
    prior_cov = np.diag([p.prior_std**2 for p in parameters])
    return {"prior": (names, *gaussian_points(prior_mean, prior_cov, lower, upper)),
            "tuned": (names, *gaussian_points(mean, cov, lower, upper))}


def planned_position(run, settings) -> tuple[float, float]:
    if settings.position is not None:
        return float(settings.position[0]), float(settings.position[1])
    from seatune.io.motion_table import MotionTable

    lat, lon = MotionTable(run.artefact("motions.parquet")).last_fix()
    if not np.isfinite(lat):
        raise UserError(str(run.path), "predict.position", "no logged position to default to: give [lat, lon]")
    return lat, lon


def forecast_times(hc, settings) -> pd.DatetimeIndex:
    if settings.times is None:
        return pd.DatetimeIndex(hc.bulk["time"].values).tz_localize("UTC")
    times = pd.DatetimeIndex([pd.Timestamp(t) for t in settings.times])
    return times.tz_localize("UTC") if times.tz is None else times.tz_convert("UTC")


def predict_stage(run, vessel, forecast_path, forecast_format: str = "auto", echo=print, force: bool = False,
                  hc=None) -> dict:
    """Read the tuned posterior and the forecast, evaluate both models, write prediction.parquet."""
    from threadpoolctl import threadpool_limits

    from seatune.io.hindcast_readers import at_track, read_hindcast
    from seatune.io.parquet import write_table
    from seatune.io.rundir import fingerprint, is_fresh
    from seatune.pipeline.identify import window_wave_spectrum
    from seatune.tuning.forward import ChannelPower

    settings = check_settings(run, vessel)
    unc = settings.uncertainty or run.spec.hindcast.uncertainty
    history_path = run.artefact("tuning_history.parquet")
    out = run.artefact("prediction.parquet")
    fp = fingerprint([history_path, run.artefact("motions.parquet"), Path(forecast_path), run.vessel_path],
                     {"stage": "predict", "predict": settings.model_dump(mode="json"), "format": forecast_format,
                      "uncertainty": unc.model_dump(), "parameters": list(run.spec.tuning.parameters)})
    if not force and is_fresh([out], fp):
        return {"skipped": True, "path": str(out)}
    hc = hc if hc is not None else read_hindcast(forecast_path, format=forecast_format)
    lat, lon = planned_position(run, settings)
    times = forecast_times(hc, settings)
    bulk = at_track(hc, times, np.full(times.size, lat), np.full(times.size, lon))
    models = beliefs(run, vessel, pd.read_parquet(history_path))
    db = vessel.db
    omega = db.omega
    grid = np.degrees(db.wave_direction)
    headings = np.asarray(settings.heading_grid())
    channel = settings.channel
    power = {}
    for model, (names, points, _) in models.items():
        p = ChannelPower(vessel, names, [channel])(points)  # (nw, n, 1, nb) float32
        power[model] = p[:, :, 0, :].astype(float)
    rows = []
    unc_args = (unc.hs_rel_std, unc.tp_std_s, unc.dir_std_deg)
    # many small matrix products: BLAS threads only contend with each other (and numba's) on a busy machine
    with threadpool_limits(1):
        for k, b in enumerate(bulk.itertuples()):
            where = SimpleNamespace(start=times[k], end=times[k], hs=b.hs, tp=b.tp, dir_from_deg=b.dir_from_deg)
            spectrum0, dirs, _ = window_wave_spectrum(hc, where, lat, lon, omega)
            if not np.isfinite(spectrum0).all() or not np.isfinite(b.tp):
                raise UserError(str(hc.source), f"time {times[k]:%Y-%m-%dT%H:%MZ}",
                                f"no wave data at ({lat:.3f}, {lon:.3f})")
            for model, (_, _, weights) in models.items():
                r = time_step(omega, grid, headings, spectrum0, dirs, float(b.tp), unc_args, power[model], weights,
                              settings.limit, settings.duration_s)
                rows.append(pd.DataFrame({
                    "time": times[k], "model": model, "channel": channel, "heading_deg": headings,
                    "exceedance_probability": r["probability"], "most_probable_max": r["most_probable_max"],
                    "median_max": r["median_max"], "sigma": r["sigma"], "tz": r["tz"],
                    "optimal_heading_deg": r["optimal_heading_deg"], "optimal_probability": r["optimal_probability"],
                    "is_optimal": headings == r["optimal_heading_deg"], "limit": settings.limit,
                    "duration_s": settings.duration_s, "hs": b.hs, "tp": b.tp, "dir_from_deg": b.dir_from_deg,
                    "lat": lat, "lon": lon, "posterior_points": int(weights.size),
                    "sea_state_hypotheses": r["hypotheses"]}))
    table = pd.concat(rows, ignore_index=True)
    units = {**PREDICTION_UNITS}
    unit = CHANNEL_UNITS[vessel.channel(channel).kind]
    units.update({c: unit for c, u in PREDICTION_UNITS.items() if u == CHANNEL_PER_ROW})
    write_table(table, out, units, {"fingerprint": fp, "forecast": str(forecast_path)})
    return {"skipped": False, "path": str(out), "table": table, "channel": channel, "unit": unit,
            "limit": settings.limit, "duration_s": settings.duration_s, "times": times.size,
            "headings": headings.size, "hypotheses": int(table["sea_state_hypotheses"].iloc[0]),
            "points": {m: int(v[2].size) for m, v in models.items()}}


def summary_line(summary: dict, seconds: float) -> str:
    if summary.get("skipped"):
        return f"predict: up to date (skipped): {summary['path']}"
    t = summary["table"]
    tuned = t[t["model"] == "tuned"]
    tw = tuned.groupby("time")["optimal_probability"].max().idxmax()  # the riskiest forecast time (tuned model)
    parts = []
    for model in ("tuned", "prior"):
        at = t[(t["model"] == model) & (t["time"] == tw)]
        parts.append(f"{model} model P = {100 * at['optimal_probability'].iloc[0]:.1f} % at heading "
                     f"{at['optimal_heading_deg'].iloc[0]:.0f}° (worst heading "
                     f"{100 * at['exceedance_probability'].max():.1f} %)")
    hours = summary["duration_s"] / 3600
    return (f"predict: P(max {summary['channel']} > {summary['limit']:g} {summary['unit']} in {hours:.3g} h) over "
            f"{summary['times']} forecast times × {summary['headings']} headings × {summary['hypotheses']} sea-state "
            f"hypotheses × {summary['points']['tuned']} posterior points; at the riskiest time "
            f"({tw:%Y-%m-%dT%H:%MZ}) {parts[0]}, {parts[1]} ({seconds:.1f} s): {summary['path']}")

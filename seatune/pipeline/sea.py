"""`seatune sea`: each accepted window's directional sea estimated from the ship's motions, with the hindcast
as the prior (identification/sea_estimation.py), → sea_states.parquet. identify, tune, diagnose and report then take
the window's wave spectrum and its uncertainty from the estimate instead of the hindcast. With `sea.roll_free`, the
sea is fitted once more without the roll channels → sea_states_roll_free.parquet, the sea identify reads the roll
mode against: a sea fitted through the prior's roll RAO bends toward it at the roll resonance (where the waves'
own tail is weakest) and pulls the measured roll ω_n toward the prior.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from seatune.identification.sea_estimation import DIRS_FROM, POOL_MIN_WINDOWS, pooled_priors, record_priors

SEA_UNITS = {
    "window_id": "",
    "partition": "",
    "system": "",
    "kind": "",
    "in_hindcast": "",
    "hindcast_total_hs": "m",
    "hindcast_hs": "m",
    "hindcast_tp": "s",
    "hindcast_dir_from_deg": "deg",
    "hs": "m",
    "hs_std": "m",
    "tp": "s",
    "tp_std": "s",
    "dir_from_deg": "deg",
    "dir_from_deg_std": "deg",
    "spread_deg": "deg",
    "spread_deg_std": "deg",
    "gamma": "dimensionless",
    "gamma_std": "dimensionless",
    "tail": "dimensionless",  # n of the spectrum's ω⁻ⁿ tail (5: JONSWAP)
    "tail_std": "dimensionless",
    "heading_deg": "deg",
    "chi2_reduced": "dimensionless",
    "hindcast_misfit": "dimensionless",
    "fitted_misfit": "dimensionless",
    "channels": "",
}
# the model on a grid 3× finer than the Welch bins, ±2 bins around each (the Hann main lobe): within 0.05 of ln S
# of the exact smearing for a resonance of 2 % damping at the 128 s segment
WELCH_REFINE, WELCH_LOBES = 3, 2
ROLL_FREE_FILE = "sea_states_roll_free.parquet"  # the sea fitted without the roll channels (`sea.roll_free`)
_MEASURED_KINDS = ("angle", "specific_force", "acceleration", "displacement", "velocity")


def run_sea_channels(run, vessel, available) -> list[str]:
    """The channels the run's sea is fitted from: `sea.channels`, else `sea_channels` of those `available`."""
    return run.spec.sea.channels or sea_channels(vessel, available)


def sea_channels(model, available) -> list[str]:
    """The angles, the translations on every axis and the rate about an axis no angle measures (the yaw rate): a
    wave buoy's horizontal motions, not only its heave and slopes, carry the direction. Roll and pitch rates repeat
    the angles. On the blind bank, adding the horizontal specific forces and the yaw rate to roll, pitch and the
    vertical ones found 82 % of the missing swells instead of 71 % and took clean-hull false alarms from 6 to 4 of
    24, while the systems the fit added with no true counterpart rose from 0.14 to 0.26 per window."""
    present = [c for c in model.channels if c.name in available]
    angles = {c.axis for c in present if c.kind == "angle"}
    return [c.name for c in present
            if c.kind in _MEASURED_KINDS or (c.kind == "rate" and c.axis not in angles)]


def _shows_roll(channel) -> bool:
    """A channel whose signal is mostly roll: a roll angle or rate, a transverse specific force (g·φ)."""
    return (channel.kind in ("angle", "rate") and channel.axis == "x") or \
        (channel.kind == "specific_force" and channel.axis == "y")


def spectrum_partitions(S2d: np.ndarray, omega: np.ndarray, dirs_from: np.ndarray, max_parts: int = 2):
    """Up to `max_parts` partitions (hs, tp, dir_from_deg, spread_deg) of a 2-D spectrum, split in frequency at
    the trough between the largest peaks of its 1-D spectrum (a hindcast's swell and wind sea)."""
    from scipy.signal import find_peaks

    d_dir = np.radians(360.0 / dirs_from.size)
    e = S2d.sum(axis=1) * d_dir
    if not np.any(e > 0):
        return []
    peaks, prop = find_peaks(np.r_[0.0, e, 0.0], prominence=0.1 * e.max())
    peaks = peaks - 1
    peaks = np.sort(peaks[np.argsort(prop["prominences"])[::-1][:max_parts]])
    edges = [0] + [int(a + np.argmin(e[a : b + 1])) for a, b in zip(peaks[:-1], peaks[1:], strict=True)] + [e.size]
    out = []
    for a, b, p in zip(edges[:-1], edges[1:], peaks, strict=True):
        m0 = np.trapezoid(e[a:b], omega[a:b]) if b - a > 1 else 0.0
        if m0 <= 0:
            continue
        w = S2d[a:b].sum(axis=0)
        th = np.radians(dirs_from)
        c, s = (w * np.cos(th)).sum() / w.sum(), (w * np.sin(th)).sum() / w.sum()
        spread = np.degrees(np.sqrt(max(2.0 * (1.0 - np.hypot(c, s)), 1e-4)))
        out.append(
            (
                4.0 * np.sqrt(m0),
                2 * np.pi / omega[p],
                float(np.degrees(np.arctan2(s, c)) % 360.0),
                float(np.clip(spread, 5.0, 70.0)),
            )
        )
    return out


def hindcast_priors(hc, row, lat, lon, unc, settings):
    """The window's hindcast partitions as PartitionPriors (2-D spectrum: split at the trough, the higher-frequency
    one of two the wind sea; partitions wind_*/swell_*; else the bulk Hs/Tp/direction as one partition)."""
    from seatune.identification.sea_estimation import WIND_SEA_TAIL_LOG_STD, PartitionPrior
    from seatune.io.hindcast_readers import at_track
    from seatune.pipeline.identify import window_wave_spectrum

    def prior(hs, tp, d, spread=25.0, wind=False):
        return PartitionPrior(
            hs=max(float(hs), 0.05),
            tp=float(tp),
            dir_from_deg=float(d),
            spread_deg=spread,
            hs_log_std=max(unc.hs_rel_std, settings.hs_rel_std),
            tp_log_std=max(unc.tp_std_s / float(tp), settings.tp_rel_std),
            dir_std_deg=max(unc.dir_std_deg, settings.dir_std_deg),
            **({"tail_log_std": WIND_SEA_TAIL_LOG_STD} if wind else {}),
        )

    if hc.spectra is not None:
        omega = np.linspace(0.15, 2.5, 200)
        S2d, dirs, _ = window_wave_spectrum(hc, row, lat, lon, omega)
        parts = spectrum_partitions(S2d, omega, np.asarray(dirs, dtype=float))
        if parts:
            return [prior(*p, wind=len(parts) > 1 and k == len(parts) - 1) for k, p in enumerate(parts)]
    mid = row.start + (row.end - row.start) / 2
    track = at_track(hc, [mid], lat, lon).iloc[0]
    parts = []
    for name in ("wind", "swell"):
        hs, d = track.get(f"{name}_hs"), track.get(f"{name}_dir_from_deg")
        tp = track.get(f"{name}_tp", np.nan)
        if not np.isfinite(tp if tp is not None else np.nan):
            mwp = track.get(f"{name}_mwp", np.nan)
            tp = 1.1 * mwp if mwp is not None and np.isfinite(mwp) else np.nan  # Tm−1,0 ≈ 0.9 Tp (JONSWAP)
        if hs is not None and np.isfinite(hs) and hs > 0.05 and np.isfinite(tp) and d is not None and np.isfinite(d):
            parts.append(prior(hs, tp, d, 30.0 if name == "wind" else 15.0, wind=name == "wind"))
    return parts or [prior(row.hs, row.tp, row.dir_from_deg)]


READ_STEPS = (-2.0, -1.0, 1.0, 2.0)  # a read parameter's profile: prior σ steps beside the vessel's own value


def read_parameters(run, vessel, believed) -> list:
    """The loading parameters the sea fit reads (`sea.read_loading`): with a prior in the vessel YAML, neither known
    nor among `believed`; as Parameters centred on the vessel's value with the prior's std and bounds."""
    from seatune.pipeline.vessel import with_mass_aliases
    from seatune.tuning.interface import Parameter

    fixed = with_mass_aliases(set(run.spec.identify.known) | {p.name for p in believed})
    out = []
    for name in run.spec.sea.read_loading:
        prior = vessel.spec.priors.get(name)
        value = getattr(vessel.spec.loading, name, None)
        if prior is None or name in fixed or value is None:
            continue
        lo, hi = prior.bounds if prior.bounds is not None else (-np.inf, np.inf)
        if lo < float(value) < hi:
            out.append(Parameter(name, float(value), float(prior.std), float(lo), float(hi)))
    return out


def read_from_sea(vessel, believed, parameter, channels, inputs, settings, first) -> tuple[float, float, float, dict]:
    """(value, std, gain, {value: misfit}) of one loading parameter read from the sea fit: the windows' summed misfit
    (½Σr² of each MAP fit, the full channel set) profiled over the vessel's value + READ_STEPS prior σ, plus the
    prior's −ln p, and its minimum (`profile_minimum`); gain: the profile's drop from the vessel's value to there.
    std: the summed profile's, or the windows' scatter where wider (`profile_spread`): the summed curvature alone
    put the blind bank's LCG reads at 0.02–0.08 m (error/std rms 7.2 on 41 trials, 2.6 with the scatter; the
    windows' own minima scatter 0.1–0.5 m). `first`: the fits at the vessel's value.

    The sea fit's cross-spectra carry what the σ of the channels (tune) hardly does: on the blind bank the LCG
    (xcg) that tune could not move (barge_clean_003: −0.1 ± 0.5 m tuned, −1.4 m true) is where this misfit is least
    (−1.41 m of the grid −3 … +1), and the vessel's xcg 0 had put a missing swell's Hs 12 % high."""
    from seatune.identification.sea_estimation import profile_minimum, profile_spread

    centre, step = parameter.prior_mean, parameter.prior_std
    values = np.unique(np.clip(centre + step * np.array([0.0, *READ_STEPS]), parameter.lower, parameter.upper))
    tasks = [(k, list(range(len(channels))), pr) for k, (*_, pr) in enumerate(inputs)]
    per_window = []  # (values, windows)
    for v in values:
        if v == centre:
            per_window.append([e.cost for e in first])
            continue
        moved = vessel.with_loading(**{parameter.name: float(v)})
        per_window.append([e.cost for e in estimate_windows(moved, design_loadings(moved, believed), channels, inputs,
                                                            tasks, settings)])
    per_window = np.array(per_window)
    misfit = {float(v): float(c) for v, c in zip(values, per_window.sum(axis=1), strict=True)}
    costs = per_window.sum(axis=1) + 0.5 * ((values - centre) / step) ** 2
    value, std, least = profile_minimum(values, costs)
    std = max(std, profile_spread(values, per_window, step))
    return value, min(std, step), misfit[float(centre)] - least, misfit


def design_loadings(vessel, parameters):
    """The prior mean loading and ±√3σ per tuned parameter (the RAO uncertainty the fit allows for)."""
    from seatune.pipeline.tune import prior_design

    if not parameters:
        return vessel.base_loading
    phi = prior_design(parameters)
    return vessel.loading(**{p.name: phi[:, k] for k, p in enumerate(parameters)})


def raos_at(vessel, loading, channels, omega, dirs_from, heading_deg) -> np.ndarray:
    """Channel RAOs (L, nω, nD, nch) at ω and the coming-from directions D (β = ψ − D − 180°, DESIGN §3): the
    equation of motion solved at each ω with the vessel's effects, linear in β on the database's periodic grid."""
    from seatune.diagnosis.model import effect_channel_raos
    from seatune.pipeline.identify import at_sea_directions

    h = effect_channel_raos(vessel, loading, channels, omega)  # (L, nω, nb, nch), solved at each ω
    return at_sea_directions(vessel.db, h, dirs_from, heading_deg)


def outer_raos_at(vessel, loading, channels, omega, dirs_from, heading_deg) -> np.ndarray:
    """H Hᴴ of the channels packed as `outer_raos` (L, nω, nD, nch²) at ω and the coming-from directions D: the
    products on the database's β grid, then linear in β, as the sea split onto the grid (tune and diagnose do the
    same with |H|²). Not the product of H linear in β: 15° apart, a short wave's phase along the hull turns by
    radians, and the complex mean lost power — against the independent trial path 20 % at 1.5 rad/s and 41 % at
    1.8–2 rad/s for a 5 s sea (tests/test_sea_estimation.py), which the sea fit made up with more Hs."""
    from seatune.diagnosis.model import effect_channel_raos
    from seatune.identification.sea_estimation import outer_raos
    from seatune.pipeline.identify import at_sea_directions

    g = outer_raos(effect_channel_raos(vessel, loading, channels, omega))  # (L, nω, nb, nch²)
    return at_sea_directions(vessel.db, g, dirs_from, heading_deg)


def estimate_window(
    vessel, design, channels, x: np.ndarray, fs: float, priors, settings, heading_deg: float, segment_s: float
):
    """The SeaEstimate of one window from its motion channels x (nch, n)."""
    from seatune.identification.sea_estimation import cross_spectra

    return estimate_from_spectra(vessel, design, channels, cross_spectra(x, fs, segment_s), priors, settings,
                                 heading_deg, segment_s)


def estimate_from_spectra(vessel, design, channels, spectra, priors, settings, heading_deg: float, segment_s: float):
    """The SeaEstimate of one window from its channels' cross-spectra (ω, Φ̂, ν) (`cross_spectra`). On one BLAS
    thread: the fit's arrays are small (a ~1300 × 20 Jacobian with six channels), and threading them on two cores
    made it 4× slower."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        return _estimate_from_spectra(vessel, design, channels, spectra, priors, settings, heading_deg, segment_s)


def _estimate_from_spectra(vessel, design, channels, spectra, priors, settings, heading_deg, segment_s):
    from seatune.diagnosis.model import welch_grid
    from seatune.identification.sea_estimation import WelchWindow, estimate_sea

    omega, phi, nu = spectra
    band = (omega >= max(settings.omega_min, vessel.db.omega[0])) & (
        omega <= min(settings.omega_max, vessel.db.omega[-1])
    )
    welch = WelchWindow(*welch_grid(omega[band], segment_s, refine=WELCH_REFINE, lobes=WELCH_LOBES))
    g_all = outer_raos_at(vessel, design, channels, welch.omega, DIRS_FROM, heading_deg)
    return estimate_sea(
        omega[band],
        phi[band],
        nu,
        DIRS_FROM,
        g_all[0],
        g_all,
        priors,
        max_partitions=settings.max_partitions,
        min_hs=settings.min_hs,
        channel_names=channels,
        welch=welch,
    )


def estimate_windows(vessel, design, channels, inputs, tasks, settings) -> list:
    """SeaEstimates of (window, channel subset, priors) tasks, spread over the CPUs (seatune.parallel); `inputs`:
    per window (id, heading, its channels' cross-spectra, hindcast priors). Each partition's prior is one of the
    task's own prior objects again (a worker's come back as copies), as the stage matches them by identity."""
    from dataclasses import replace

    from seatune.identification.sea_estimation import Partition
    from seatune.parallel import map_tasks

    def one(task):
        k, cols, priors = task
        _, heading, (omega, phi, nu), _ = inputs[k]
        est = estimate_from_spectra(vessel, design, [channels[c] for c in cols], (omega, phi[:, cols][:, :, cols], nu),
                                    priors, settings, heading, settings.segment_s)
        return est, [next((i for i, q in enumerate(priors) if q is p.prior), -1) for p in est.partitions]

    return [replace(est, partitions=[Partition(p.value, p.std, priors[i] if i >= 0 else None)
                                     for p, i in zip(est.partitions, index, strict=True)])
            for (_, _, priors), (est, index) in zip(tasks, map_tasks(one, tasks), strict=True)]


def partition_rows(window_id: str, est, heading_deg: float, channels, priors, fitted_priors) -> list[dict]:
    """Rows of sea_states.parquet; `fitted_priors`: the priors the fit used in place of the hindcast's `priors`
    (pooled, or the same), the hindcast columns still the hindcast's."""
    from seatune.identification.sea_estimation import FIELDS

    hindcast_of = {id(f): p for f, p in zip(fitted_priors[: len(priors)], priors, strict=True)}  # then the record's
    order = sorted(range(len(est.partitions)), key=lambda k: est.partitions[k].value["tp"])
    shortest = est.partitions[order[0]].value["tp"]
    other = min(
        (p.value["tp"] for s, p in zip(est.systems, est.partitions, strict=True) if s != est.systems[order[0]]),
        default=np.inf,
    )
    hindcast_total = float(np.sqrt(sum(p.hs**2 for p in priors)))
    rows = []
    for k, i in enumerate(order):
        p, system = est.partitions[i], est.systems[i]
        wind = system == est.systems[order[0]] and shortest < 0.8 * other
        kind = "wind_sea" if wind else ("total" if len(set(est.systems)) == 1 else "swell")
        pr = hindcast_of.get(id(p.prior)) if p.prior is not None else None
        rows.append(
            {
                "window_id": window_id,
                "partition": k,
                "system": system,
                "kind": kind,
                "in_hindcast": pr is not None,
                "hindcast_total_hs": hindcast_total,
                "hindcast_hs": pr.hs if pr else np.nan,
                "hindcast_tp": pr.tp if pr else np.nan,
                "hindcast_dir_from_deg": pr.dir_from_deg if pr else np.nan,
                **{f: p.value[f] for f in FIELDS},
                **{f"{f}_std": p.std[f] for f in FIELDS},
                "heading_deg": heading_deg,
                "chi2_reduced": est.chi2_reduced,
                "hindcast_misfit": est.cost_hindcast,
                "fitted_misfit": est.cost,
                "channels": ",".join(channels),
            }
        )
    return rows


def sea_stage(run, vessel, echo=print, force: bool = False, parameters=None, artefact: str = "sea_states.parquet",
              vessel_path=None, channels: list[str] | None = None) -> dict:
    """`parameters`: the loading belief whose RAOs (mean and ±√3σ design) the fit uses; default the priors of
    the tuned parameters (the alternation passes the tuned posterior). `artefact` other than sea_states.parquet
    (diagnose's DIAGNOSED_SEA_FILE): only the full fit, with the vessel read from `vessel_path`, from `channels`
    (default the run's)."""
    from seatune.errors import UserError
    from seatune.identification.sea_estimation import cross_spectra
    from seatune.io.hindcast_readers import read_hindcast
    from seatune.io.motion_table import MotionTable
    from seatune.io.parquet import write_table
    from seatune.io.rundir import fingerprint, is_fresh
    from seatune.pipeline.tune import tuning_parameters

    settings = run.spec.sea
    src = [run.artefact("motions.parquet"), run.artefact("windows.parquet")]
    out = run.artefact(artefact)
    main = artefact == "sea_states.parquet"
    fp = fingerprint(
        src + [run.hindcast_path, vessel_path or run.vessel_path],
        {
            "stage": "sea" if main else artefact,
            "parameters_given": None if parameters is None or main else [(p.name, p.prior_mean, p.prior_std)
                                                                         for p in parameters],
            "sea": settings.model_dump(),
            "uncertainty": run.spec.hindcast.uncertainty.model_dump(),
            "parameters": list(run.spec.tuning.parameters),
            "known": run.spec.identify.known,
            **({"channels": channels} if channels else {}),
        },
    )
    out_roll = run.artefact(ROLL_FREE_FILE)
    outs = ([out, out_roll] if settings.roll_free and main else [out]) if settings.estimate else []
    for path in {out, out_roll} - set(outs) if main else ():  # left from a run with other settings
        path.unlink(missing_ok=True)
    if not settings.estimate:
        return {"skipped": True, "disabled": True}
    if not force and is_fresh(outs, fp):
        return {"skipped": True}
    motions, windows = MotionTable(src[0]), pd.read_parquet(src[1])
    hc = read_hindcast(run.hindcast_path, format=run.spec.hindcast.format)
    channels = channels or run_sea_channels(run, vessel, set(motions.columns))
    unknown = [c for c in channels if c not in motions.columns or c not in {ch.name for ch in vessel.channels}]
    if unknown:
        raise UserError(str(run.path), "sea.channels", f"not both a vessel channel and a motion column: "
                        f"{', '.join(unknown)}")
    if not channels:
        raise UserError(str(run.path), "sea.channels", "no angle or vertical channel among the motions")
    believed = parameters if parameters is not None else tuning_parameters(run, vessel)
    design = design_loadings(vessel, believed)
    fs = run.spec.ingest.rate_hz
    keep = [k for k, c in enumerate(channels) if not _shows_roll(vessel.channel(c))]
    roll_free = settings.roll_free and main and 2 <= len(keep) < len(channels)
    without_roll = [channels[k] for k in keep]
    inputs = []  # (window id, heading, cross-spectra of the channels, hindcast priors)
    for row in windows[windows["accepted"]].sort_values("start").itertuples():
        part = motions.window(row.start, row.end, ["lat", "lon", *channels], record=row.record)
        mid = len(part) // 2
        priors = hindcast_priors(
            hc, row, part["lat"].iloc[mid], part["lon"].iloc[mid], run.spec.hindcast.uncertainty, settings
        )
        x = part[channels].to_numpy().T
        bad = ~np.isfinite(x)
        if bad.mean() > 0.05 or len(part) < 4 * settings.segment_s * fs:
            echo(f"sea: window {row.window_id}: {100 * bad.mean():.0f} % of the samples missing or too short for "
                 f"{settings.segment_s:.0f} s segments; the stages take the hindcast's sea there")
            continue
        if bad.any():  # short gaps: linear in time
            idx = np.arange(x.shape[1])
            x = np.array([np.interp(idx, idx[np.isfinite(r)], r[np.isfinite(r)]) for r in x])
        inputs.append((str(row.window_id), float(row.heading_deg), cross_spectra(x, fs, settings.segment_s), priors))

    # every window with every channel set (all; without roll) at once, then the refits from the pooled priors
    subsets = [(channels, list(range(len(channels))))] + ([(without_roll, keep)] if roll_free else [])
    hindcast = [pr for *_, pr in inputs]

    def every_subset(vessel, design) -> list[list]:  # per channel set, each window fitted from its hindcast priors
        fits = estimate_windows(vessel, design, channels, inputs,
                                [(k, cols, pr) for _, cols in subsets for k, pr in enumerate(hindcast)], settings)
        return [fits[s * len(inputs):(s + 1) * len(inputs)] for s in range(len(subsets))]

    est = every_subset(vessel, design)
    # loading parameters read from the sea fit: {name: (value, std)}; a refit the alternations ask for (`parameters`
    # given) keeps the first fit's reading, which the vessel they pass already holds
    fresh = main and parameters is None
    read = {} if fresh or not main else {k: tuple(v) for k, v in sea_design(run, "read").items()}
    for parameter in read_parameters(run, vessel, believed) if fresh and len(inputs) > 1 else ():
        value, std, gain, _ = read_from_sea(vessel, believed, parameter, channels, inputs, settings, est[0])
        # taken where the misfit drops by more than BIC's ½ ln n for one parameter (n: the windows' residuals, halved
        # for the correlation of adjacent Welch bins, as the sea's own search counts them)
        penalty = 0.5 * np.log(max(sum(e.n_residuals for e in est[0]) / 2.0, 2.0))
        keep = "read" if gain > penalty else "kept the vessel's"
        echo(f"sea ↔ {parameter.name}: from the sea fit {value:.2f} ± {std:.2f} (vessel {parameter.prior_mean:g} ± "
             f"{parameter.prior_std:g}; misfit −{gain:.1f}, BIC {penalty:.1f}): {keep}")
        if gain > penalty:
            read[parameter.name] = (value, std)
    refit_all = bool(read) and fresh
    if refit_all:  # every window fitted again through the loading read
        vessel = vessel.with_loading(**{name: v for name, (v, _) in read.items()})
        design = design_loadings(vessel, believed)
    if settings.pool_windows and len(inputs) > POOL_MIN_WINDOWS:
        # the hindcast's partitions moved by the record's error in them, and the record's systems the hindcast lacks
        pooled = [[moved + added for moved, added in zip(pooled_priors(hindcast, e), record_priors(e), strict=True)]
                  for e in est]
        # refitted from the pooled priors, not from the first fit: started there (2.4× cheaper), the blind bank's
        # wind seas found fell 91 → 87 % and clean-hull false alarms rose 3 → 5 of 24
        moved = [(s, k) for s in range(len(subsets)) for k, pr in enumerate(hindcast)
                 if refit_all or len(pooled[s][k]) > len(pr)
                 or not all(a is b for a, b in zip(pooled[s][k], pr, strict=True))]
        again = estimate_windows(vessel, design, channels, inputs,
                                 [(k, subsets[s][1], pooled[s][k]) for s, k in moved], settings)
        for (s, k), e in zip(moved, again, strict=True):
            est[s][k] = e
    else:
        pooled = [hindcast] * len(subsets)
        if refit_all:
            est = every_subset(vessel, design)
    rows, *rows_roll = ([r for (wid, hd, _, pr), e, pp in zip(inputs, est[s], pooled[s], strict=True)
                         for r in partition_rows(wid, e, hd, names, pr, pp)] for s, (names, _) in enumerate(subsets))
    rows_roll = rows_roll[0] if rows_roll else []
    table = pd.DataFrame(rows, columns=list(SEA_UNITS))
    if settings.roll_free and main:  # empty when too few channels remain without roll: identify takes the full fit
        write_table(pd.DataFrame(rows_roll, columns=list(SEA_UNITS)), out_roll, SEA_UNITS, {"fingerprint": fp})
    # the loading belief the RAOs came from: the pitch alternation compares identify's r55 with it
    meta = {"fingerprint": fp, "design": {p.name: [p.prior_mean, p.prior_std] for p in believed},
            "read": {name: [v, sd] for name, (v, sd) in read.items()}}
    write_table(table, out, SEA_UNITS, meta)
    systems = system_table(table)
    added = systems[~systems["in_hindcast"]] if len(systems) else systems
    ratio = (
        (
            window_hs(systems)
            / systems.groupby("window_id")["hindcast_total_hs"].first()
        )
        if len(systems)
        else pd.Series([np.nan])
    )
    return {
        "skipped": False,
        "windows": int(table["window_id"].nunique()) if len(table) else 0,
        "partitions": len(table),
        "added": len(added),
        "hs_ratio": float(np.nanmedian(ratio)) if np.isfinite(ratio).any() else float("nan"),
        "added_hs": [round(float(v), 2) for v in added["hs"]],
        **({"read": {name: round(v, 3) for name, (v, _) in read.items()}} if read else {}),
    }


def combined_hs(part: pd.DataFrame) -> tuple[float, float]:
    """Hs = √Σ Hs² of partitions sharing one sea and its standard deviation (independent partition errors)."""
    hs = float(np.sqrt((part["hs"] ** 2).sum()))
    return hs, float(np.sqrt(((part["hs"] / hs) ** 2 * part["hs_std"] ** 2).sum()))


def system_table(table: pd.DataFrame) -> pd.DataFrame:
    """One row per window and wave system: Hs = √Σ Hs², Tp, direction and spread of its strongest partition,
    in_hindcast if any of its partitions matched a hindcast partition."""
    if table.empty:
        return table.assign(hindcast_total_hs=[])
    rows = []
    for (wid, sys_id), part in table.groupby(["window_id", "system"], sort=False):
        top = part.loc[part["hs"].idxmax()].copy()
        matched = part[part["in_hindcast"]]
        if len(matched):  # the hindcast partition the system matched, whichever of its parts did
            for c in ("hindcast_hs", "hindcast_tp", "hindcast_dir_from_deg"):
                top[c] = matched[c].iloc[0]
        hs, hs_std = combined_hs(part)
        rows.append(
            {
                "window_id": wid,
                "system": int(sys_id),
                "kind": top["kind"],
                "in_hindcast": bool(part["in_hindcast"].any()),
                "hs": hs,
                "hs_std": hs_std,
                "tp": float(top["tp"]),
                "tp_std": float(top["tp_std"]),
                "dir_from_deg": float(top["dir_from_deg"]),
                "dir_from_deg_std": float(top["dir_from_deg_std"]),
                "spread_deg": float(top["spread_deg"]),
                "hindcast_hs": float(top["hindcast_hs"]),
                "hindcast_tp": float(top["hindcast_tp"]),
                "hindcast_dir_from_deg": float(top["hindcast_dir_from_deg"]),
                "hindcast_total_hs": float(top["hindcast_total_hs"]),
            }
        )
    return pd.DataFrame(rows)


def posterior_parameters(run, vessel):
    """The tuned posterior (last update of tuning_history.parquet) as Parameters, bounds from the priors."""
    from seatune.pipeline.tune import tuning_parameters
    from seatune.tuning.interface import Parameter

    hist = pd.read_parquet(run.artefact("tuning_history.parquet"))
    last = hist[hist["update"] == hist["update"].max()].set_index("parameter")
    return [Parameter(p.name, float(last.loc[p.name, "mean"]), max(float(last.loc[p.name, "std"]), 1e-9),
                      p.lower, p.upper) for p in tuning_parameters(run, vessel)]


def mode_parameters(run, vessel) -> list:
    """r55 as identify last read it from the pitch mode, as a Parameter for the sea's design (`pitch_r55`), or []."""
    found, _ = pitch_r55(run, vessel)
    return [found] if found is not None else []


def pitch_r55(run, vessel):
    """(Parameter, "") of r55 as identify last read it from the pitch mode (over the loading prior's draws weighted
    by the measured modes, `identify.posterior_rows`), its std capped at the prior's (a wide interval must not fan
    the sea's design out); else (None, why). A reading outside the vessel YAML's r55 bounds is not taken: something
    the model lacks moved the pitch resonance (blind bank: an IMU lever arm read as r55 30.1 m against 25.0 m
    true)."""
    from seatune.pipeline.identify import PITCH_R55
    from seatune.tuning.interface import Parameter

    path = run.artefact("natural_frequencies.parquet")
    if "r55" in run.spec.identify.known:
        return None, "r55 is known"
    if not path.exists():
        return None, "identify has not run"
    nat = pd.read_parquet(path)
    row = nat[(nat["window_id"] == "all") & (nat["derived"] == PITCH_R55)]
    if row.empty or not np.isfinite(row["derived_value"].iloc[0]):
        return None, "identify read no r55 from the pitch mode"
    base = float(vessel.base_loading.r55[0])
    prior = vessel.spec.priors.get("r55")
    lo, hi = prior.bounds if prior is not None and prior.bounds is not None else (0.3 * base, 3.0 * base)
    mean = float(row["derived_value"].iloc[0])
    if not lo < mean < hi:
        return None, (f"identify reads r55 {mean:.2f} m, outside the vessel's bounds [{lo:g}, {hi:g}] m: the pitch "
                      "resonance moved by something other than r55")
    cap = float(prior.std) if prior is not None else 0.1 * base
    return Parameter("r55", mean, float(np.clip(row["derived_std"].iloc[0], 1e-6, cap)), float(lo), float(hi)), ""


def with_modes(parameters: list, modes: list) -> list:
    """`parameters` with identify's mode parameters in place of (or beside) those of the same name."""
    named = {p.name: p for p in parameters}
    named.update({p.name: p for p in modes})
    return list(named.values())


def alternate_modes(run, vessel, stages, echo=print) -> list[dict]:
    """The sea and the pitch mode alternate (seed_003's iteration of sea and RAO; Han A6/A7): the sea was fitted
    through the pitch RAO at the prior r55, and bends toward it at the resonance, so identify's pitch ω_n lands
    between the truth and the prior (blind bank, OSV: +4.4 % at r55 24 m against 25.9 m true). The sea is fitted
    again with the r55 identify read, then identify again, until identify's r55 is the one the sea assumed (within
    half its std) or after `sea.mode_rounds` rounds. Returns per round the r55 assumed and read and the pitch ω_n."""
    from seatune.pipeline.tune import tuning_parameters

    tuned = tuning_parameters(run, vessel)
    assumed = sea_design(run).get("r55", [float(vessel.base_loading.r55[0])])[0]  # a killed round's too
    rounds, omega = [], _pitch_omega(run)
    for k in range(1, run.spec.sea.mode_rounds + 1):
        read, why = pitch_r55(run, vessel)
        if read is None:
            if k > 1 or why != "identify read no r55 from the pitch mode":
                echo(f"sea ↔ pitch mode: {'no refit' if k == 1 else f'stopped after {k - 1} round(s)'}: {why}")
            break
        if abs(read.prior_mean - assumed) < 0.5 * read.prior_std:
            echo(f"sea ↔ pitch mode: {'settled after ' + str(k - 1) + ' round(s)' if k > 1 else 'no refit'}: identify "
                 f"reads r55 {read.prior_mean:.2f} ± {read.prior_std:.2f} m, within half its std of the sea's "
                 f"{assumed:.2f} m")
            break
        start = time.perf_counter()
        sea_stage(run, vessel, echo=echo, force=True, parameters=with_modes(tuned, [read]))
        stages["identify"](True)
        after = _pitch_omega(run)
        rounds.append({"round": k, "r55_assumed": read.prior_mean, "r55_before": assumed,
                       "pitch_omega_before": omega, "pitch_omega_after": after})
        echo(f"sea ↔ pitch mode {k}: sea refitted through r55 {read.prior_mean:.2f} m (was {assumed:.2f} m), "
             f"identify's pitch ω_n {omega:.4f} → {after:.4f} rad/s ({time.perf_counter() - start:.0f} s)")
        assumed, omega = read.prior_mean, after
    else:
        if rounds:
            echo(f"sea ↔ pitch mode: sea.mode_rounds ({len(rounds)}) reached; the last round moved r55 by "
                 f"{abs(rounds[-1]['r55_assumed'] - rounds[-1]['r55_before']):.2f} m")
    return rounds


def sea_design(run, key: str = "design") -> dict:
    """{parameter: [mean, std]} of the loading belief sea_states.parquet was fitted through ({} when it predates
    this record or is missing); key "read": the loading parameters the sea fit read (`read_from_sea`)."""
    from seatune.io.parquet import table_metadata

    try:
        return table_metadata(run.artefact("sea_states.parquet")).get(key, {})
    except (OSError, KeyError, ValueError):
        return {}


def with_sea_read(run, vessel):
    """The vessel with the loading values the sea fit read (sea_states.parquet) in its base condition, as
    `identify.known` values are: identify, tune and diagnose then model the xcg the motions showed."""
    read = sea_design(run, "read")
    return vessel.with_loading(**{name: float(v[0]) for name, v in read.items()}) if read else vessel


def _pitch_omega(run) -> float:
    """identify's measured pitch ω_n (without the loading prior, which the alternation does not move)."""
    from seatune.identification.natural_frequency import primary_natural_frequencies

    modes = primary_natural_frequencies(pd.read_parquet(run.artefact("natural_frequencies.parquet")),
                                        measured_only=True)
    return float(modes.loc["Pitch", "omega_n"]) if "Pitch" in modes.index else float("nan")


def alternate(run, vessel, stages, echo=print) -> list[dict]:
    """Han A6/A7's alternation of sea and vessel: the sea re-estimated with the tuned loading's RAOs, then
    identify and tune again, `sea.iterations − 1` times. Returns per round the median relative change of the
    windows' Hs and the largest parameter move in posterior standard deviations."""
    rounds = []
    for k in range(2, run.spec.sea.iterations + 1):
        hs0 = window_hs(pd.read_parquet(run.artefact("sea_states.parquet")))
        post0 = posterior_parameters(run, vessel)
        sea_stage(run, vessel, echo=echo, force=True, parameters=with_modes(post0, mode_parameters(run, vessel)))
        stages["identify"](True)
        stages["tune"](True)
        hs1 = window_hs(pd.read_parquet(run.artefact("sea_states.parquet")))
        post1 = posterior_parameters(run, vessel)
        dhs = float(np.nanmedian(np.abs(hs1.reindex(hs0.index) / hs0 - 1)))
        move = max(abs(a.prior_mean - b.prior_mean) / b.prior_std for a, b in zip(post1, post0, strict=True))
        rounds.append({"round": k, "hs_change": dhs, "parameter_move_sigma": float(move),
                       "means": {p.name: p.prior_mean for p in post1}})
        echo(f"alternate {k}: sea re-estimated with the tuned loading, Hs changed {100 * dhs:.1f} % (median over "
             "windows), the tuned parameters moved at most " + f"{move:.2f} σ: "
             + ", ".join(f"{p.name} {p.prior_mean:.4g}" for p in post1))
    return rounds


def window_hs(sea: pd.DataFrame) -> pd.Series:
    return sea.groupby("window_id")[["hs", "hs_std"]].apply(lambda part: combined_hs(part)[0])


# ------------------------------------------------------------------------- downstream


def read_sea_states(run, roll_free: bool = False) -> pd.DataFrame | None:
    """sea_states.parquet of the run (`roll_free`: sea_states_roll_free.parquet), or None when the sea is not
    estimated (then the hindcast is used)."""
    path = run.artefact(ROLL_FREE_FILE if roll_free else "sea_states.parquet")
    if not run.spec.sea.estimate or not path.exists():
        return None
    return pd.read_parquet(path)


ROLL_PARAMETERS = ("gmt_fs", "r44", "beta44", "zcg", "ycg")  # loading parameters the roll channels inform


def sea_for_tuning(run) -> pd.DataFrame | None:
    """The sea tune fits the loading against: per window the fit without the roll channels where there is one and
    roll parameters are tuned (the roll channels then inform the vessel only, not also the sea they are compared
    with: fitted through the prior's roll RAO the sea absorbs part of its damping error), else the full fit."""
    full = read_sea_states(run)
    if full is None or not set(run.spec.tuning.parameters) & set(ROLL_PARAMETERS):
        return full
    free = read_sea_states(run, roll_free=True)
    if free is None or free.empty:
        return full
    return pd.concat([free, full[~full["window_id"].isin(free["window_id"])]], ignore_index=True)


def estimated_wave_spectrum(sea: pd.DataFrame, window_id: str, omega: np.ndarray):
    """S(ω, D) [m²·s/rad²] of the window's estimated partitions on `omega` × DIRS_FROM, or None."""
    from seatune.identification.sea_estimation import partition_spectrum, table_coordinates

    part = sea[sea["window_id"] == str(window_id)]
    if part.empty:
        return None
    return (partition_spectrum(np.asarray(omega, dtype=float), DIRS_FROM, table_coordinates(part)),
            DIRS_FROM.copy(), "estimated from motions")


@dataclass(frozen=True)
class WindowSea:
    """A window's sea as the stages use it: Hs and Tp (the dominant system's), and their uncertainty."""

    hs: float
    tp: float
    hs_rel_std: float
    tp_std_s: float
    dir_std_deg: float
    estimated: bool
    fit_tp_std_s: float = float("nan")  # the estimate's own Tp std, unfloored (NaN: the hindcast's sea)
    # ln p(hindcast's sea) / p(estimate) from the fit's misfits (½Σr² of whitened residuals), halved as the fit's
    # n_eff: adjacent Welch bins of a Hann window are correlated (0: the hindcast's sea)
    hindcast_log_odds: float = 0.0

    @property
    def tilt_tp_rel_std(self) -> float:
        """Relative Tp error for identify's tilt term: the estimate's own where the sea is estimated. Floored at
        0.2 s (tune's floor), it tripled that term, which the windows share: on the blind bank the measured pitch of
        clean hulls then weighed ~¼ against a loading prior 3 % off; unfloored, pitch within 2 % 18 → 23 of 24 clean
        hulls, their coverage 100 → 96 %."""
        own = self.estimated and np.isfinite(self.fit_tp_std_s)
        return (self.fit_tp_std_s if own else self.tp_std_s) / self.tp


def sea_inputs(run) -> list:
    """sea_states.parquet as an input of a later stage's fingerprint when the sea is estimated."""
    if not run.spec.sea.estimate:
        return []
    return [run.artefact("sea_states.parquet")] + ([run.artefact(ROLL_FREE_FILE)] if run.spec.sea.roll_free else [])


def window_uncertainty(sea: pd.DataFrame | None, window_id, unc, hindcast_row=None) -> WindowSea:
    """The window's sea (Hs, Tp) with its uncertainty: the estimate's (Tp and direction of the dominant
    partition), floored at 3 %, 0.2 s and 3°; else the hindcast row's values and the run YAML's
    hindcast.uncertainty."""
    part = None if sea is None else sea[sea["window_id"] == str(window_id)]
    if part is None or part.empty:
        hs = float(hindcast_row.hs) if hindcast_row is not None else np.nan
        tp = float(hindcast_row.tp) if hindcast_row is not None else np.nan
        return WindowSea(hs, tp, unc.hs_rel_std, unc.tp_std_s, unc.dir_std_deg, False)
    hs, hs_std = combined_hs(part)
    top = part.loc[part["hs"].idxmax()]
    return WindowSea(
        hs,
        float(top["tp"]),
        max(hs_std / hs, 0.03),
        max(float(top["tp_std"]), 0.2),
        max(float(top["dir_from_deg_std"]), 3.0),
        True,
        float(top["tp_std"]),
        -0.5 * float(top["hindcast_misfit"] - top["fitted_misfit"]),
    )

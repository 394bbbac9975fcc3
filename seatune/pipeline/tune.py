"""`seatune tune`: the loading parameters named in the run YAML, tuned window by window (one sea state per
accepted window, in time order) with the backend named in the YAML (DBI, Han A1/A2/A5; UKF, Han A6), then
validated on held-out windows.

Per training window: the observation is the filtered σ (and optionally Tz) of each channel from
window_stats.parquet, with the sampling variance of σ̂ for the record (ν = T m0²/(π ∫S² dω) from the window's
Welch spectrum); the sea state is the hindcast's directional spectrum at the window with Hs, Tp and direction
uncertain as the run YAML's `hindcast.uncertainty` (3-point Gauss–Hermite hypotheses per component for DBI,
the Gaussian itself for the UKF's weather update).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from seatune.errors import UserError
from seatune.physics.spectra import direction_step

PARAMETER_PER_ROW = "per row; the unit of the row's parameter (vessel YAML loading)"
HISTORY_UNITS = {"update": "", "window_id": "", "backend": "", "parameter": "", "mean": PARAMETER_PER_ROW,
                 "std": PARAMETER_PER_ROW, "q05": PARAMETER_PER_ROW, "q50": PARAMETER_PER_ROW, "q95": PARAMETER_PER_ROW,
                 "channels_used": "", "marginal_grid": PARAMETER_PER_ROW,
                 "marginal_pmf": "per row; 1/(the unit of the row's parameter)"}
MEASUREMENT_PER_ROW = "per row; the unit of the row's measurement: the channel unit for sigma, s for tz"
VALIDATION_UNITS = {"window_id": "", "role": "", "measurement": "", "measured": MEASUREMENT_PER_ROW,
                    "predicted_prior": MEASUREMENT_PER_ROW, "predicted_tuned": MEASUREMENT_PER_ROW, "informative": ""}
GH_NODES = np.array([-np.sqrt(3.0), 0.0, np.sqrt(3.0)])  # 3-point Gauss–Hermite (probabilists'): exact to 5th moment
GH_WEIGHTS = np.array([1 / 6, 2 / 3, 1 / 6])
INFORMATIVE_ALPHA = 0.05  # a channel is informative on the tuned parameters if its prior spread ≥ 5 % (A2 eq. 9)


def tuning_parameters(run, vessel):
    from seatune.tuning.interface import Parameter

    out = []
    for name in run.spec.tuning.parameters:
        prior = vessel.spec.priors.get(name)
        if prior is None:
            raise UserError(str(run.path), "tuning.parameters",
                            f"'{name}' has no prior in {vessel.source} (priors: {', '.join(vessel.spec.priors)})")
        lo, hi = prior.bounds if prior.bounds is not None else (-np.inf, np.inf)
        try:
            out.append(Parameter(name, float(prior.mean), float(prior.std), float(lo), float(hi)))
        except ValueError as err:
            raise UserError(str(vessel.source), f"priors.{name}", str(err)) from None
    if run.spec.tuning.damping_gpr.enabled and "beta44" not in run.spec.tuning.parameters:
        raise UserError(str(run.path), "tuning.damping_gpr", "needs beta44 among tuning.parameters")
    return out


def damping_gpr(settings, parameters):
    """The A4 GPR of β44, or None when tuning.damping_gpr is off."""
    if not settings.enabled:
        return None
    from seatune.tuning.damping_gpr import DampingGPR

    prior = next(p for p in parameters if p.name == "beta44")
    return DampingGPR(prior_mean=prior.prior_mean if settings.prior_mean is None else settings.prior_mean,
                      sigma_f=prior.prior_std if settings.sigma_f is None else settings.sigma_f,
                      length_scales=settings.length_scales)


def heading_rule_observation(settings, obs, sea):
    """The window's observation restricted by the first heading rule that covers its mean β (A7 Case 4)."""
    from seatune.tuning.interface import Observation

    folded = abs((float(sea.mean[2]) + 180.0) % 360.0 - 180.0)  # port and starboard alike, 180 = head seas
    for rule in settings.heading_rules:
        lo, hi = rule.beta_deg
        if lo <= folded <= hi:
            chans = set(rule.channels or [n.split(":")[0] for n in obs.names])
            stats = set(rule.statistics or settings.statistics)
            keep = [j for j, n in enumerate(obs.names) if n.split(":")[0] in chans and n.split(":")[1] in stats]
            return Observation(obs.window_id, tuple(obs.names[j] for j in keep), obs.z[keep], obs.variance[keep],
                               obs.duration_s, obs.common_scale_variance)
    return obs


def gpr_beta44(gpr, sea):
    """The GPR input of a window's sea state and β44's predicted mean and std there (A4 eq. 22a)."""
    from seatune.tuning.damping_gpr import gpr_inputs

    x = gpr_inputs(*sea.mean[:3])
    mean, std = gpr.predict(x)
    return x, float(mean[0]), float(std[0])


def update_with_gpr(backend, gpr, model, obs, sea):
    """One backend update; with the GPR, β44's belief is first replaced by its prediction at this sea state
    (A4 §4.1 step 1, A4 eq. 18) and the posterior β44 is then stored as a GPR sample (step 5)."""
    if gpr is None:
        return backend.update(model, obs, sea)
    x, mean, std = gpr_beta44(gpr, sea)
    if backend.name == "dbi":
        post = backend.update(model, obs, sea, fresh_marginals={"beta44": backend.gaussian_pmf("beta44", mean, std)})
    else:
        post = backend.update(model, obs, sea, fresh={"beta44": (mean, std**2)})
    i = post.names.index("beta44")
    gpr.add(x[0], float(post.mean[i]), max(float(post.cov[i, i]), 1e-12))
    return post


def make_backend(settings, parameters):
    if settings.backend == "dbi":
        from seatune.tuning.dbi import DBI

        s = settings.dbi
        return DBI(parameters, database_points=s.database_points, pmf_points=s.pmf_points, likelihood=s.likelihood,
                   power=s.power, screening_alpha=s.screening_alpha, model_error=s.model_error,
                   interpolation=s.interpolation if s.likelihood == "gaussian" else "linear",
                   hypothesis_mixing=s.hypothesis_mixing, pmf_budget=s.pmf_budget, regrid=s.regrid)
    from seatune.tuning.ukf import UKF

    s = settings.ukf
    q = {p.name: s.q_fraction * p.prior_std for p in parameters}
    return UKF(parameters, alpha=s.alpha, beta=s.beta, kappa=s.kappa, r_fraction=s.r_fraction, process_noise=q)


def sea_state(theta0: np.ndarray, std: np.ndarray):
    """Gaussian θ' = (Hs, Tp, β) and 9 discrete hypotheses over (Tp, β) (3-point Gauss–Hermite rules each).

    Hs stays at its mean in the hypotheses: σ ∝ Hs, so the DBI's Gaussian likelihood marginalises its
    uncertainty (cov) exactly as a common scale instead of by three points (A5 eq. 3.7 with Hs continuous)."""
    from seatune.tuning.forward import SEA_STATE_NAMES
    from seatune.tuning.interface import SeaState

    tp, beta = np.meshgrid(GH_NODES, GH_NODES, indexing="ij")
    points = np.repeat(theta0[None, :], tp.size, axis=0)
    points[:, 1] = np.maximum(theta0[1] + tp.ravel() * std[1], 1e-3)
    points[:, 2] = theta0[2] + beta.ravel() * std[2]
    weights = np.outer(GH_WEIGHTS, GH_WEIGHTS).ravel()
    return SeaState(SEA_STATE_NAMES, theta0, np.diag(std**2), points, weights / weights.sum())


def effective_dof(S: np.ndarray, omega: np.ndarray, duration_s: float) -> float:
    """ν = T m0² / (π ∫S² dω) of a σ̂² estimate from a record of length T (one-sided S in rad/s)."""
    m0 = np.trapezoid(S, omega)
    return float(duration_s * m0**2 / (np.pi * np.trapezoid(S**2, omega)))


def window_inputs(run, vessel, windows, stats, spectra, motions, hc, power, names, sea=None, given_sea=None):
    """(window_id, ForwardModel, Observation, SeaState) per accepted window, in time order; the sea is the
    estimate of sea_states.parquet (`sea`) where it holds the window, else the hindcast's; `given_sea(row,
    omega)` → (S(ω, D), D, WindowSea) replaces both (the bank's true sea, the reference of validation)."""
    from seatune.pipeline.identify import mean_wave_direction, window_wave_spectrum
    from seatune.pipeline.sea import window_uncertainty
    from seatune.tuning.forward import WindowStatistics
    from seatune.tuning.interface import Observation

    unc = run.spec.hindcast.uncertainty
    db = vessel.db
    out = []
    for row in windows[windows["accepted"]].sort_values("start").itertuples():
        st = stats[stats["window_id"] == row.window_id].set_index("channel")
        sp = spectra[spectra["window_id"] == row.window_id]
        mid = row.start + (row.end - row.start) / 2
        at = motions.row_at(mid, ["lat", "lon"])  # the grid row at mid-window
        if given_sea is not None:
            wave, dirs, ws = given_sea(row, db.omega)
        else:
            wave, dirs, _ = window_wave_spectrum(hc, row, at["lat"], at["lon"], db.omega, sea)
            ws = window_uncertainty(sea, row.window_id, unc, row)  # the estimated sea's, else the hindcast's
        d_dir = direction_step(dirs)
        hs0 = 4.0 * np.sqrt(np.trapezoid(wave.sum(axis=1) * d_dir, db.omega))
        theta0 = np.array([hs0, ws.tp, mean_wave_direction(wave, dirs, row.heading_deg)])
        std = np.array([ws.hs_rel_std * hs0, ws.tp_std_s, ws.dir_std_deg])
        cutoff = {c: 2 * np.pi * float(st.loc[c, "cutoff_hz"]) for c in st.index}
        model = WindowStatistics(power, names, wave, dirs, row.heading_deg, theta0, cutoff)
        z, var = [], []
        for name in names:
            ch, stat = name.split(":")
            part = sp[sp["channel"] == ch]
            om, S = part["omega"].to_numpy(), part["S"].to_numpy()
            band = om <= cutoff[ch]
            nu = effective_dof(S[band], om[band], row.duration_s)
            value = float(st.loc[ch, stat])
            z.append(value)
            var.append(value**2 / (2 * nu))  # Var σ̂ ≈ σ²/(2ν) (delta method on χ²_ν); Tz: same relative error
        obs = Observation.of_one_sea(str(row.window_id), names, z, var, row.duration_s)
        out.append((str(row.window_id), model, obs, sea_state(theta0, std)))
    return out


def mode_inputs(run, vessel, parameters):
    """identify's natural frequencies (window 'all', per DOF with a value) as one sea-independent observation:
    z = ω_n, variance = (CI half-width / z_conf)², predicted by the coupled modes of the loading. σ̂ alone leaves
    r44 and GMT on one ridge and the tuned roll mode free to drift by up to 10 % from the measured one; the measured
    ω_n pins the ridge. None without natural_frequencies.parquet or a mode with a finite interval."""
    from scipy.stats import norm

    from seatune.identification.natural_frequency import primary_natural_frequencies, shifted_modes
    from seatune.tuning.forward import ModeFrequencies
    from seatune.tuning.interface import Observation, SeaState

    path = run.artefact("natural_frequencies.parquet")
    if not path.exists():
        return None
    best = primary_natural_frequencies(pd.read_parquet(path), measured_only=True)  # tune holds the prior itself
    shifted = shifted_modes(vessel.spec.effects)
    z_conf = norm.ppf(0.5 + run.spec.identify.confidence / 2)
    half = (best["ci_high"] - best["ci_low"]) / 2
    ok = np.isfinite(best["omega_n"]) & np.isfinite(half) & (half > 0) & ~best.index.isin(list(shifted))
    if not ok.any():
        return None
    modes = list(best.index[ok])
    model = ModeFrequencies(vessel, [p.name for p in parameters], modes)
    obs = Observation("natural_frequencies", model.names, best.loc[modes, "omega_n"].to_numpy(float),
                      (half[ok].to_numpy(float) / z_conf) ** 2, 0.0, variance_is_total=True)
    return model, obs, SeaState.certain((), [])


def history_rows(update: int, window_id: str, backend: str, post) -> list[dict]:
    """One row per parameter: summary, the covariance row (cov_<parameter>) and the DBI marginal PMF."""
    rows = []
    for i, name in enumerate(post.names):
        grid, pmf = post.marginals.get(name, (None, None))
        rows.append({"update": update, "window_id": window_id, "backend": backend, "parameter": name,
                     "mean": float(post.mean[i]), "std": float(post.std[i]), "q05": float(post.quantiles[0.05][i]),
                     "q50": float(post.quantiles[0.5][i]), "q95": float(post.quantiles[0.95][i]),
                     "channels_used": ",".join(post.used),
                     "marginal_grid": None if grid is None else [float(v) for v in grid],
                     "marginal_pmf": None if pmf is None else [float(v) for v in pmf],
                     **{f"cov_{other}": float(post.cov[i, j]) for j, other in enumerate(post.names)}})
    return rows


def vessel_yaml_data(vessel) -> dict:
    """The vessel YAML as data, with the files it names made absolute (it is rewritten into the run dir)."""
    data = yaml.safe_load(Path(vessel.source).read_text())
    data["loading"] = vessel.spec.loading.model_dump(exclude_none=True)  # with the run's known values
    base = Path(vessel.source).parent

    def absolute(value):  # a path, a glob or a list of them (hull.capytaine.files)
        if isinstance(value, list):
            return [absolute(v) for v in value]
        return str((base / value).resolve()) if isinstance(value, str) else value

    if data.get("hydro_database"):
        data["hydro_database"] = absolute(data["hydro_database"])
    hull = data.get("hull") if isinstance(data.get("hull"), dict) else {}
    for sub in hull.values():  # mesh.file, capytaine.file / files, wamit.prefix / runs[].prefix
        for entry in [sub] + (sub.get("runs") or [] if isinstance(sub, dict) else []):
            if isinstance(entry, dict):
                for key in ("file", "files", "prefix"):
                    if key in entry:
                        entry[key] = absolute(entry[key])
    return data


def tuned_vessel_yaml(vessel, post, path: Path) -> None:
    """The vessel YAML with the posterior means as loading and the posterior as priors (usable everywhere)."""
    data = vessel_yaml_data(vessel)
    for i, name in enumerate(post.names):
        data["loading"][name] = float(post.mean[i])
        if name == "mass":
            data["loading"].pop("displacement", None)
        prior = data.setdefault("priors", {}).setdefault(name, {})
        prior["mean"], prior["std"] = float(post.mean[i]), float(post.std[i])
    data["description"] = (data.get("description", "") + " Tuned by seatune.").strip()
    from seatune.atomic import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))


@dataclass
class Fit:
    """The tuned belief and what it was fitted on (tune_stage writes it; validation compares two of them)."""

    parameters: list
    names: list[str]
    inputs: list
    roles: list[str]
    backend: object
    gpr: object
    rows: list[dict]
    post: object


def fit_loading(run, vessel, echo=print, given_sea=None) -> Fit:
    """The backend run over identify's natural frequencies and then every training window, in time order.
    `given_sea`: see window_inputs."""
    from seatune.diagnosis.effects import MODEL_SIDE
    from seatune.io.hindcast_readers import read_hindcast
    from seatune.io.motion_table import MotionTable
    from seatune.pipeline.sea import sea_for_tuning
    from seatune.tuning.forward import ChannelPower

    settings = run.spec.tuning
    parameters = tuning_parameters(run, vessel)
    unused = [e["kind"] for e in vessel.spec.effects if e["kind"] not in MODEL_SIDE]
    if unused:
        echo(f"tune: note: {', '.join(unused)} (vessel effects) act on the sea or depend on the sea state; "
             f"tuning solves the vessel without them")
    windows, stats, spectra = (pd.read_parquet(run.artefact(n)) for n in
                               ("windows.parquet", "window_stats.parquet", "window_spectra.parquet"))
    motions = MotionTable(run.artefact("motions.parquet"))
    hc = read_hindcast(run.hindcast_path, format=run.spec.hindcast.format)
    available = set(stats["channel"])
    channels = settings.channels or [c.name for c in vessel.channels if c.name in available]
    missing = [c for c in channels if c not in available]
    if missing:
        raise UserError(str(run.path), "tuning.channels", f"not among the filtered channels: {', '.join(missing)}")
    names = [f"{c}:{s}" for c in channels for s in settings.statistics]
    for k, rule in enumerate(settings.heading_rules):
        unknown = sorted(set(rule.channels or []) - set(channels))
        if unknown:
            raise UserError(str(run.path), f"tuning.heading_rules[{k}].channels",
                            f"not among the tuned channels: {', '.join(unknown)}")
    power = ChannelPower(vessel, [p.name for p in parameters], channels)
    sea = None if given_sea is not None else sea_for_tuning(run)
    inputs = window_inputs(run, vessel, windows, stats, spectra, motions, hc, power, names, sea, given_sea)
    if not inputs:
        raise UserError(str(run.path), "windows", "no accepted window to tune on")
    k = settings.holdout_every
    roles = ["holdout" if k and (i % k == k - 1) else "train" for i in range(len(inputs))]
    if "train" not in roles:
        roles[0] = "train"
    backend = make_backend(settings, parameters)
    gpr = damping_gpr(settings.damping_gpr, parameters)
    rows = history_rows(0, "", backend.name, backend.posterior())
    modes = mode_inputs(run, vessel, parameters) if settings.natural_frequencies else None
    if modes is not None:  # first, on the full prior grid: the ridge it draws is then refined by the windows
        rows += history_rows(1, modes[1].window_id, backend.name, backend.update(*modes))
    first = 2 if modes is not None else 1
    for i, ((wid, model, obs, sea), role) in enumerate(zip(inputs, roles, strict=True)):
        if role == "train":
            used = heading_rule_observation(settings, obs, sea)
            rows += history_rows(i + first, wid, backend.name, update_with_gpr(backend, gpr, model, used, sea))
    post = backend.posterior()
    return Fit(parameters, names, inputs, roles, backend, gpr, rows, post)


def tune_stage(run, vessel, echo=print, force: bool = False) -> dict:
    from seatune.io.parquet import write_table
    from seatune.io.rundir import fingerprint, is_fresh
    from seatune.pipeline.sea import sea_inputs

    settings = run.spec.tuning
    src = [run.artefact(n) for n in ("windows.parquet", "window_stats.parquet", "window_spectra.parquet",
                                     "motions.parquet")]
    modal = [run.artefact("natural_frequencies.parquet")] if settings.natural_frequencies else []
    fp = fingerprint(src + sea_inputs(run) + modal + [run.hindcast_path, run.vessel_path],
                     {"stage": "tune", "tuning": settings.model_dump(), "known": run.spec.identify.known,
                      "uncertainty": run.spec.hindcast.uncertainty.model_dump()})
    outs = [run.artefact(n) for n in ("tuning_history.parquet", "validation.parquet")]
    tuned_path = run.artefact("tuned_vessel.yaml")
    if not force and is_fresh(outs, fp) and tuned_path.exists():
        return {"skipped": True}
    fit = fit_loading(run, vessel, echo)
    parameters, names, inputs, roles = fit.parameters, fit.names, fit.inputs, fit.roles
    backend, gpr, rows, post = fit.backend, fit.gpr, fit.rows, fit.post
    prior_phi = np.array([[p.prior_mean for p in parameters]])
    design = prior_design(parameters)
    val = []
    for (wid, model, obs, sea), role in zip(inputs, roles, strict=True):
        tuned_phi = post.mean[None, :].copy()
        if gpr is not None:  # β44 of this window's sea state
            tuned_phi[0, post.names.index("beta44")] = gpr_beta44(gpr, sea)[1]
        pred = model.predict(np.vstack([prior_phi, tuned_phi]), sea.mean[None, :])[:, 0, :]
        spread = model.predict(design, sea.mean[None, :])[:, 0, :].std(axis=0, ddof=1) / obs.z  # A2 eq. 9
        val += [{"window_id": wid, "role": role, "measurement": n, "measured": float(obs.z[j]),
                 "predicted_prior": float(pred[0, j]), "predicted_tuned": float(pred[1, j]),
                 "informative": bool(spread[j] >= INFORMATIVE_ALPHA)}
                for j, n in enumerate(names)]
    cov_units = {f"cov_{p.name}": f"per row; unit of the row's parameter × unit of {p.name}" for p in parameters}
    history, validation = pd.DataFrame(rows, columns=[*HISTORY_UNITS, *cov_units]), pd.DataFrame(val)
    meta = {"fingerprint": fp}
    tuned_vessel_yaml(vessel, post, tuned_path)  # first: the Parquet fingerprints then vouch for it too
    write_table(history, outs[0], {**HISTORY_UNITS, **cov_units}, meta)
    write_table(validation, outs[1], VALIDATION_UNITS, meta)
    held = validation[validation["role"] == "holdout"]
    held = held if len(held) else validation

    informative = held[held["informative"]]

    def err(rows, col):
        return float(np.mean(np.abs(np.log(rows[col] / rows["measured"])))) if len(rows) else float("nan")

    return {"skipped": False, "backend": backend.name, "windows": roles.count("train"),
            "holdout": roles.count("holdout"), "posterior": dict(zip(post.names, zip(post.mean, post.std,
                                                                                         strict=True), strict=True)),
            "error_prior": err(held, "predicted_prior"), "error_tuned": err(held, "predicted_tuned"),
            "informative": sorted({m.split(":")[0] for m in informative["measurement"]}),
            "error_prior_informative": err(informative, "predicted_prior"),
            "error_tuned_informative": err(informative, "predicted_tuned")}


def prior_design(parameters) -> np.ndarray:
    """The prior mean and ±√3σ along each parameter (clipped to its bounds): (2p + 1, p)."""
    mean = np.array([p.prior_mean for p in parameters])
    step = np.sqrt(3.0) * np.diag([p.prior_std for p in parameters])
    lo, hi = np.array([p.lower for p in parameters]), np.array([p.upper for p in parameters])
    return np.clip(np.vstack([mean, mean + step, mean - step]), lo, hi)

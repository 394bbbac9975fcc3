"""`seatune diagnose`: where the tuned model and the measurements still disagree, which known physical effect
explains it, and how much of the gap adding it closes on held-out windows (issue 8).

Per accepted window (the tune stage's roles: every `holdout_every`-th is held out): the Welch spectra of the
filtered channels (window_spectra.parquet, bins up to each channel's cutoff) against the tuned model's expected
Welch spectra in the hindcast's directional sea at the window. Residuals locate bands of systematic misfit;
every candidate effect of the library is fitted with the tuned loading parameters on the training windows and
scored on the held-out ones (diagnosis/select.py). Writes diagnosis.parquet (one row per candidate, DESIGN §5),
diagnosis_residuals.parquet (window × channel × ω, before and after) and, when an effect is named,
augmented_vessel.yaml (the vessel with the effect and the loading refitted with it; `seatune tune` on it re-tunes
with the effect in the model).
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from seatune.errors import UserError
from seatune.physics.spectra import direction_step

DIAGNOSIS_UNITS = {
    "step": "", "given": "", "effect": "", "signature": "", "n_params": "",
    "fitted": "text; JSON, parameter units in fitted_units",
    "fitted_std": "text; JSON", "fitted_units": "text; JSON", "loading": "text; JSON, loading parameter units (SI)",
    "nll_train": "dimensionless; nat", "nll_holdout": "dimensionless; nat", "gain_train": "dimensionless; nat",
    "gain_holdout": "dimensionless; nat", "bic_penalty": "dimensionless; nat",
    "joint_gain_train": "dimensionless; nat, over the model without effect",
    "joint_gain_holdout": "dimensionless; nat, over the model without effect",
    "false_alarm_p": "dimensionless; probability under the null (no effect, sea within its errors); NaN: not tested",
    "null_gain_q95": "dimensionless; nat, the null's 95 % quantile of the score (held-out gain)",
    "cross_fold_gain": "dimensionless; nat, the smaller held-out gain of a 2-fold cross-validation over all windows "
                       "(a vessel-side effect is named only above the held-out threshold); NaN: not tested",
    "own_sea_gain": "dimensionless; nat, the smallest held-out gain with the held-out windows' sea refitted through "
                    "the candidate (all windows and each 2-fold half; held_out_in_own_sea); NaN: not tested",
    "untouched_sea_gain": "dimensionless; nat, the smallest held-out gain in a sea fitted from the channels the "
                          "candidate leaves untouched (all windows and each 2-fold half; held_out_in_untouched_sea); "
                          "NaN: not tested",
    "at_bound": "", "widened": "", "eligible": "", "selected": "", "out_of_sample": "",
    "gap_before_train": "dimensionless",
    "gap_after_train": "dimensionless", "gap_before_holdout": "dimensionless",
    "gap_after_holdout": "dimensionless", "sigma_error_before_train": "dimensionless",
    "sigma_error_after_train": "dimensionless", "sigma_error_before_holdout": "dimensionless",
    "sigma_error_after_holdout": "dimensionless", "bands_before": "", "bands_after": "",
    "fitted_with_sea": "text; JSON, the final step's effects after alternating with the sea, units in fitted_units",
    "alternation_rounds": "",
    "withdrawn": "",
    **{f"{k}_{when}_holdout_with_sea": "dimensionless; the last selected row: the tuned model in the sea stage's sea "
                                        "(before), the final model in the sea refitted through it (after), in the bins "
                                        "its effects move; NaN elsewhere"
       for k in ("gap", "sigma_error") for when in ("before", "after")},
}
WITH_SEA_COLUMNS = tuple(c for c in DIAGNOSIS_UNITS if c.endswith("_with_sea") and c != "fitted_with_sea")
RESIDUAL_UNITS = {"window_id": "", "role": "", "channel": "", "omega": "rad/s", "log_ratio_before": "dimensionless",
                  "log_ratio_after": "dimensionless", "z_before": "dimensionless", "z_after": "dimensionless",
                  "used": ""}


def body_wave(S2d: np.ndarray, dirs_from: np.ndarray, heading_deg: float, grid_rad: np.ndarray) -> np.ndarray:
    """S(ω, D) on coming-from directions → S(ω, β_b)·Δβ on the database's body-relative directions (DESIGN §3)."""
    from seatune.diagnosis.effects import _direction_weights

    d_dir = direction_step(dirs_from)
    beta = np.mod(heading_deg - np.asarray(dirs_from, dtype=float) - 180.0, 360.0)
    return (S2d * d_dir) @ _direction_weights(beta, np.degrees(grid_rad))


def tuned_phi(run, parameters) -> np.ndarray:
    """The tune stage's posterior means (the last update of tuning_history.parquet)."""
    hist = pd.read_parquet(run.artefact("tuning_history.parquet"))
    last = hist[hist["update"] == hist["update"].max()].set_index("parameter")
    return np.array([float(last.loc[p.name, "mean"]) for p in parameters])


def diagnosis_parameters(run, vessel) -> tuple[list, np.ndarray]:
    """The loading the diagnosis refits and where it starts: the tuned parameters at the tune's posterior means, then
    every other parameter with a prior that identify does not take as known, at the vessel's value. Misfit that an
    uncertain loading explains is not left for an effect to absorb: on the blind bank, the untuned r55 and xcg drawn
    from their priors left a pitch misfit that IMU effects and moonpools were named for. A parameter the sea fit read
    (`sea.read_loading`) has the reading as its prior: refitted under the YAML's prior, the LCG moved 0.5–3.0 m off the
    reading in 6 of 41 trials (osv_compound_060: −3.4 m, read −2.2, truth −1.8)."""
    from seatune.pipeline.sea import sea_design
    from seatune.pipeline.tune import tuning_parameters
    from seatune.pipeline.vessel import with_mass_aliases
    from seatune.tuning.interface import Parameter

    tuned = tuning_parameters(run, vessel)
    fixed = with_mass_aliases({p.name for p in tuned} | set(run.spec.identify.known))
    read = sea_design(run, "read")
    extra = []
    for name, prior in vessel.spec.priors.items():
        if name not in fixed and getattr(vessel.spec.loading, name, None) is not None:
            lo, hi = prior.bounds if prior.bounds is not None else (-np.inf, np.inf)
            mean, std = read.get(name, (prior.mean, prior.std))  # a value the sea fit read: its reading is the prior
            extra.append(Parameter(name, float(mean), float(std), float(lo), float(hi)))
    start = [float(getattr(vessel.spec.loading, p.name)) for p in extra]
    return tuned + extra, np.r_[tuned_phi(run, tuned), start]


def window_set(run, vessel, channels, sea_file: str | None = None):
    """The WindowSet of the run's accepted windows with the tune stage's roles; the sea the sea stage estimated,
    or the run's artefact `sea_file` (diagnose's sea refitted through the named effects)."""
    from seatune.diagnosis.model import WindowSet, analysis_mask, welch_grid
    from seatune.io.hindcast_readers import read_hindcast
    from seatune.io.motion_table import MotionTable
    from seatune.pipeline.identify import mean_wave_direction, window_wave_spectrum

    windows = pd.read_parquet(run.artefact("windows.parquet"))
    stats = pd.read_parquet(run.artefact("window_stats.parquet"))
    spectra = pd.read_parquet(run.artefact("window_spectra.parquet"))
    motions = MotionTable(run.artefact("motions.parquet"))
    hc = read_hindcast(run.hindcast_path, format=run.spec.hindcast.format)
    from seatune.pipeline.sea import read_sea_states

    sea = read_sea_states(run) if sea_file is None else pd.read_parquet(run.artefact(sea_file))
    settings = run.spec.diagnose
    segment = run.spec.filter.welch_segment_s
    acc = windows[windows["accepted"]].sort_values("start")
    if acc.empty:
        raise UserError(str(run.path), "windows", "no accepted window to diagnose")
    db = vessel.db
    omega_all = np.sort(spectra["omega"].unique())
    lo = max(settings.omega_min, db.omega[0])
    hi = min(settings.omega_max, db.omega[-1])
    d = 2 * np.pi / segment
    bins = omega_all[(omega_all >= lo - 0.5 * d) & (omega_all <= hi + 0.5 * d)]
    if bins.size < 4:
        raise UserError(str(run.path), "diagnose", f"fewer than 4 Welch bins in {lo:.2f}–{hi:.2f} rad/s")
    fine, index, kernel = welch_grid(bins, segment)
    k = run.spec.tuning.holdout_every
    ids, roles, measured, dof, cutoff, waves, betas, rows = [], [], [], [], [], [], [], []
    for i, row in enumerate(acc.itertuples()):
        sp = spectra[spectra["window_id"] == row.window_id]
        st = stats[stats["window_id"] == row.window_id].set_index("channel")
        m, nu = [], []
        for c in channels:
            part = sp[sp["channel"] == c].set_index("omega").sort_index()
            m.append(np.interp(bins, part.index.to_numpy(), part["S"].to_numpy()))
            nu.append(float(part["dof"].iloc[0]))
        mid = row.start + (row.end - row.start) / 2
        at = motions.row_at(mid, ["lat", "lon"])  # the grid row at mid-window
        S2d, dirs, _ = window_wave_spectrum(hc, row, at["lat"], at["lon"], fine, sea)
        ids.append(str(row.window_id))
        roles.append("holdout" if k and (i % k == k - 1) else "train")
        measured.append(m)
        dof.append(nu)
        cutoff.append([2 * np.pi * float(st.loc[c, "cutoff_hz"]) for c in channels])
        waves.append(body_wave(S2d, dirs, row.heading_deg, db.wave_direction))
        betas.append(mean_wave_direction(S2d, dirs, row.heading_deg))
        rows.append(row)
    if "train" not in roles:
        roles[0] = "train"
    measured = np.array(measured)
    mask = analysis_mask(measured, bins, lo, np.minimum(np.array(cutoff), hi), rel=settings.relative_floor)
    return WindowSet(ids, np.array(roles), bins, fine, index, kernel, list(channels), measured, np.array(dof), mask,
                     np.array(waves), np.array([r.hs for r in rows]), np.array([r.tp for r in rows]),
                     np.array(betas),
                     np.array([r.heading_deg for r in rows]), np.array([r.sog for r in rows]))


def null_sea(calibration):
    """The run YAML's diagnose.calibration as the selection's NullSea."""
    from seatune.diagnosis.select import NullSea

    return NullSea(**calibration.model_dump())


def diagnosis_table(diag, effects, alternated=None, rounds: int = 0, withdrawn=(), with_sea=None) -> pd.DataFrame:
    """One row per candidate and step of the greedy selection (DESIGN §5): the step's gains are over the effects
    named before it (`given`), the joint ones over the model without effect; gaps are the tuned model's against
    the model with the row's effects. `alternated`: the final model's Fit after `rounds` of alternation with the
    sea, its parameters on the last selected row (`fitted_with_sea`). `withdrawn`: sea-side corrections, or a later
    vessel effect, the re-test in the alternated sea dropped (their rows `withdrawn`, no longer `selected`).
    `with_sea`: the final model's gaps with the sea refitted through it (`Diagnoser.gaps_with_sea`), on the last
    selected row."""
    from seatune.diagnosis.residuals import describe

    by_name = {e.name: e for e in effects}
    before = "; ".join(describe(b) for b in diag.bands_before) or "no band of systematic misfit"
    out = []
    for r in diag.rows:
        f = r["fit"]
        eff = by_name.get(r["added"])
        own = f"{r['added']}."
        fitted = {k.removeprefix(own): v for k, v in f.params.items()}
        std = {k.removeprefix(own): v for k, v in f.std.items()}
        units = {q.name.removeprefix(own): q.unit for q in f.effect_used.parameters} if f.effect_used else {}
        g = diag.gaps[f.effect]
        out.append({
            "step": r["step"], "given": "+".join(r["given"]), "effect": r["added"],
            "signature": eff.signature if eff else "the tuned model refitted, no effect",
            "n_params": f.n_params, "fitted": json.dumps({k: round(v, 6) for k, v in fitted.items()}),
            "fitted_std": json.dumps({k: round(v, 6) for k, v in std.items()}), "fitted_units": json.dumps(units),
            "loading": json.dumps({p: round(float(v), 6) for p, v in zip(diag.parameter_names, f.phi, strict=True)}),
            "nll_train": f.nll_train, "nll_holdout": f.nll_holdout, "gain_train": r["gain_train"],
            "gain_holdout": r["gain_holdout"], "bic_penalty": r["bic_penalty"],
            "joint_gain_train": r["joint_gain_train"], "joint_gain_holdout": r["joint_gain_holdout"],
            "false_alarm_p": r["false_alarm_p"], "null_gain_q95": r["null_gain_q95"],
            "cross_fold_gain": r["cross_fold_gain"], "own_sea_gain": r.get("own_sea_gain", np.nan),
            "untouched_sea_gain": r.get("untouched_sea_gain", np.nan),
            "at_bound": r["at_bound"],
            "widened": ", ".join(k.removeprefix(own) for k in f.widened), "eligible": bool(r["eligible"]),
            "selected": bool(r["selected"]), "out_of_sample": out_of_sample(g) if f.n_params else "",
            **{f"{k}_{when}_{role}": g[f"{k}_{role}_{when}"] for k in ("gap", "sigma_error")
               for when in ("before", "after") for role in ("train", "holdout")},
            "bands_before": before,
            "bands_after": "; ".join(describe(b) for b in diag.bands_after[f.effect]) or "none left",
            "fitted_with_sea": "", "alternation_rounds": 0, "withdrawn": False,
            **dict.fromkeys(WITH_SEA_COLUMNS, np.nan)})
    table = pd.DataFrame(out, columns=list(DIAGNOSIS_UNITS))
    gone = table["selected"] & table["effect"].isin(withdrawn)  # what the alternated sea took over
    table.loc[gone, "selected"], table.loc[gone, "withdrawn"] = False, True
    chosen = table.index[table["selected"]]
    if len(chosen) and alternated is not None:  # the final step's effects as the alternation left them
        last, own = chosen[-1], f"{table.loc[chosen[-1], 'effect']}."
        table.loc[last, "fitted_with_sea"] = json.dumps({k.removeprefix(own): round(v, 6)
                                                         for k, v in alternated.params.items()})
        table.loc[last, "alternation_rounds"] = rounds
    if len(chosen) and with_sea is not None:
        for column in WITH_SEA_COLUMNS:
            k, when = column.removesuffix("_holdout_with_sea").rsplit("_", 1)
            table.loc[chosen[-1], column] = with_sea[f"{k}_holdout_{when}"]
    return table


def out_of_sample(gaps: dict) -> str:
    """'helps' when the held-out gap and σ error both fall with the row's effects, else 'fits training only'
    (issue 17; a condition for naming once a vessel effect is in the model, diagnosis/select.py)."""
    from seatune.diagnosis.select import helps_out_of_sample

    helps = helps_out_of_sample(gaps)
    return "no held-out window" if helps is None else "helps" if helps else "fits training only"


def residual_table(data, diag) -> pd.DataFrame:
    (r0, sd0), (r1, sd1) = diag.residual_before, diag.residual_after
    nw, nc, nf = r0.shape
    idx = np.indices((nw, nc, nf)).reshape(3, -1)
    return pd.DataFrame({
        "window_id": np.array(data.window_ids)[idx[0]], "role": data.roles[idx[0]],
        "channel": np.array(data.channels)[idx[1]], "omega": data.omega[idx[2]],
        "log_ratio_before": r0.ravel(), "log_ratio_after": r1.ravel(), "z_before": (r0 / sd0).ravel(),
        "z_after": (r1 / sd1).ravel(), "used": data.mask.ravel()})


def augmented_vessel_yaml(vessel, diag, path: Path) -> None:
    """The run's vessel YAML with the named effects under `effects:` and the loading refitted with them as the
    loading condition; the priors stay the vessel's own, so `seatune tune` on it re-tunes from scratch with the
    effects in the model."""
    from seatune.atomic import atomic_path
    from seatune.pipeline.tune import vessel_yaml_data

    data = vessel_yaml_data(vessel)
    for name, value in zip(diag.parameter_names, diag.winner.phi, strict=True):
        data["loading"][name] = float(value)
        if name == "mass":
            data["loading"].pop("displacement", None)
    entries = []
    for effect, params in diag.named_effects:
        entry = {"kind": effect.name, **{k: float(v) for k, v in params.items()}}
        if effect.name == "moonpool":
            entry.setdefault("x", float(effect.x))
            entry["y"] = float(effect.y)
        entries.append(entry)
    data["effects"] = [*(data.get("effects") or []), *entries]
    data["description"] = (data.get("description", "")
                           + f" Diagnosed by seatune: {', '.join(e['kind'] for e in entries)} added.").strip()
    with atomic_path(path) as tmp:
        tmp.write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))


DIAGNOSED_SEA_FILE = "sea_states_diagnosed.parquet"  # the sea re-estimated with the named effects


def identify_in_diagnosed_sea(run, vessel, meta: dict, echo=print, belief=(), named=()) -> dict:
    """identify's natural frequencies once more, in the sea refitted through the named effects (DIAGNOSED_NF_FILE):
    the sea stage's fit had absorbed the effects, and identify had divided the responses by that sea. The model and
    its loading prior stay identify's (ω_n is the hull's coupled root, DESIGN §6); roll takes that sea too, as it
    was fitted through the refitted roll damping. A DOF whose peak a named effect moves off the bare mode (a tank's
    roll, a moonpool's heave) gets the hull's mode in the model with the effects at the loading refitted with them
    (`effect_mode_rows`; `belief`: that loading with its std, `named`: the effects), the final value. On the blind
    bank (a vessel effect named in 25 of 62 trials), within 2 % against identify's: heave 57 → 59 of 60, roll
    47 → 50 of 58, pitch 50 → 53 of 62."""
    from seatune.identification.natural_frequency import MODES_SHIFTED_BY, primary_natural_frequencies
    from seatune.io.parquet import write_table
    from seatune.pipeline.identify import DIAGNOSED_NF_FILE, NF_UNITS, effect_mode_rows, identified

    moving = [n for n in named if n in MODES_SHIFTED_BY]
    _, nat, _, _ = identified(run, vessel, pd.read_parquet(run.artefact(DIAGNOSED_SEA_FILE)), None,
                              shifted={MODES_SHIFTED_BY[n] for n in moving})
    if moving:
        note = (f"the hull's mode in the model with {' and '.join(moving)}, at the loading diagnose refitted with "
                f"{'it' if len(moving) == 1 else 'them'}: the measured peak is the coupled system's")
        rows = effect_mode_rows(vessel, belief, np.array([p.prior_mean for p in belief]),
                                {MODES_SHIFTED_BY[n] for n in moving}, note, run.spec.identify.confidence)
        nat = pd.concat([nat, pd.DataFrame(rows, columns=list(NF_UNITS))], ignore_index=True)
    write_table(nat, run.artefact(DIAGNOSED_NF_FILE), NF_UNITS, meta)
    best = primary_natural_frequencies(nat)
    found = {str(d): float(r["omega_n"]) for d, r in best.iterrows() if np.isfinite(r["omega_n"])}
    echo("diagnose: natural frequencies in the sea refitted through the named effects [rad/s]: "
         + (", ".join(f"{d.lower()} {w:.3f}" for d, w in found.items()) or "none identified"))
    return found


def loading_belief(run, vessel, parameters, phi) -> list:
    """The loading diagnose refitted, `phi`, as Parameters: the refitted values (inside the bounds) with the tune's
    posterior std (the prior's for the parameters diagnose adds)."""
    from seatune.pipeline.sea import posterior_parameters

    post = {p.name: p.prior_std for p in posterior_parameters(run, vessel)}
    belief = []
    for p, value in zip(parameters, phi, strict=True):
        room = 1e-6 * (p.upper - p.lower) if np.isfinite(p.upper - p.lower) else 1e-9
        belief.append(replace(p, prior_mean=float(np.clip(value, p.lower + room, p.upper - room)),
                              prior_std=post.get(p.name, p.prior_std)))
    return belief


def sea_with_effects(run, vessel, parameters, phi, augmented: Path, echo=print) -> dict:
    """Each window's sea fitted again through the augmented vessel (the named effects, the loading refitted with
    them): an effect the sea stage's model lacked (an IMU lever arm's specific forces, a tank's roll) had been
    absorbed by the sea. The loading belief: the refitted values with the tune's posterior std (the prior's for
    the parameters diagnose adds)."""
    from seatune.pipeline.sea import sea_stage, window_hs
    from seatune.pipeline.vessel import open_run_vessel

    summary = sea_stage(run, open_run_vessel(run, augmented), echo=echo, force=True,
                        parameters=loading_belief(run, vessel, parameters, phi),
                        artefact=DIAGNOSED_SEA_FILE, vessel_path=augmented)
    hs0, hs1 = (window_hs(pd.read_parquet(run.artefact(n))) for n in ("sea_states.parquet", DIAGNOSED_SEA_FILE))
    change = (hs1.reindex(hs0.index) / hs0 - 1).dropna()
    if len(change):
        echo(f"diagnose: the sea refitted through the named effects ({DIAGNOSED_SEA_FILE}): window Hs "
             f"{100 * change.median():+.1f} % (median), {100 * change.min():+.1f} to {100 * change.max():+.1f} %")
    return summary


def run_diagnoser(run, vessel, parameters, data, phi_start, null=None):
    """A Diagnoser of `data` with the run's hindcast uncertainty (its likelihood's sea-state error)."""
    from seatune.diagnosis.select import Diagnoser

    unc = run.spec.hindcast.uncertainty
    return Diagnoser(vessel, parameters, data, phi_start, hs_rel_std=unc.hs_rel_std, tp_std_s=unc.tp_std_s,
                     dir_std_deg=unc.dir_std_deg, null=null)


def in_refitted_sea(run, vessel, diagnoser, channels, roles=None):
    """`diagnoser`'s loading parameters and start in the sea last refitted through the named effects
    (DIAGNOSED_SEA_FILE), with the tune stage's window roles or `roles`; no calibration."""
    data = window_set(run, vessel, channels, sea_file=DIAGNOSED_SEA_FILE)
    if roles is not None:
        data = replace(data, roles=roles)
    return run_diagnoser(run, vessel, diagnoser.parameters, data, diagnoser.phi_start)


def alternate_with_sea(run, vessel, diagnoser, channels, diag, augmented: Path, max_rounds: int, echo=print,
                       rel_tol: float = 0.01):
    """Diagnose alternated with the sea (issue 16, as Han A6/A7 alternate sea and vessel): the named effects and
    the loading refitted in the sea refitted through them (DIAGNOSED_SEA_FILE), then that sea refitted through
    the new values, until no effect parameter moves by more than `rel_tol` of its value (a floor of 0.1 % of its
    search range) or after `max_rounds`. The sea stage's fit had absorbed part of each effect: on the blind bank
    the lever arms named came out 10–20 % short. The selection's evidence (gains, gaps) stays that of the common
    sea; the augmented vessel YAML takes the alternated values. Returns (the final Fit, the rounds made)."""
    fit, moves = diag.winner, []
    for _ in range(max_rounds):
        new = in_refitted_sea(run, vessel, diagnoser, channels).refine(fit)
        moved = max(abs(new.params[q.name] - fit.params[q.name])
                    / max(rel_tol * abs(fit.params[q.name]), 1e-3 * (q.upper - q.lower))
                    for q in fit.effect_used.parameters)  # in units of the tolerance
        moves.append(moved * rel_tol)
        fit = new
        augmented_vessel_yaml(vessel, replace(diag, winner=fit), augmented)
        sea_with_effects(run, vessel, diagnoser.parameters, fit.phi, augmented, echo)
        if moved <= 1.0:
            break
    rounds = len(moves)
    first, own = diag.winner.params, f"{diag.winner.effect}."
    change = ", ".join(f"{k.removeprefix(own)} {first[k]:.3g} → {v:.3g}" for k, v in fit.params.items())
    echo(f"diagnose: alternated with the sea, {rounds} round(s), largest relative change per round "
         f"{', '.join(f'{100 * m:.1f} %' for m in moves)}: {change}")
    return fit, rounds


def retest_sea_side(run, vessel, diagnoser, channels, diag, corrections, augmented: Path, echo=print):
    """Each sea-side correction named before a vessel effect, tested again on top of the vessel effects in the sea
    alternated with them (`Diagnoser.retest`); one that still passes joins the final model and
    augmented_vessel.yaml again. Returns (the final Fit, the names withdrawn)."""
    fit, withdrawn = diag.winner, []
    alternated_sea = in_refitted_sea(run, vessel, diagnoser, channels)
    for effect in corrections:
        kept, gain_t, gain_h = alternated_sea.retest(fit, effect)
        echo(f"diagnose: {effect.name} tested again in the sea alternated with the vessel effects: "
             f"{gain_t:.1f} nats training, {gain_h:.1f} held out: {'kept' if kept else 'withdrawn'}")
        if kept is None:
            withdrawn.append(effect.name)
        else:
            fit = kept
            augmented_vessel_yaml(vessel, replace(diag, winner=fit), augmented)
    return fit, withdrawn


def retest_later_effect(run, vessel, diagnoser, channels, diag, augmented: Path, rounds: int, echo=print):
    """The last vessel effect of a greedy selection that named two, tested again on top of the ones named before it
    in the sea alternated with those alone (`alternate_with_sea`, then `Diagnoser.retest`). The sea stage's fit had
    absorbed part of the first effect, and the second was found in what was left: on the blind bank a tank after a
    lever arm fitted 1.3 m short, a misalignment after a 48 m arm fitted at 39 m. Returns (the diagnosis, the
    names withdrawn, and where it was withdrawn the earlier effects' alternation (Fit, rounds) the sea file holds):
    the earlier effects as the winner where the last no longer passes."""
    from seatune.diagnosis.effects import SEA_SIDE

    steps = [r for r in diag.rows if r["selected"]]
    if len(steps) < 2 or steps[-1]["added"] in SEA_SIDE or sum(r["added"] not in SEA_SIDE for r in steps) < 2:
        return diag, [], None
    earlier, effect = steps[-2]["fit"], diag.named_effects[-1][0]
    alone = diagnoser.without_sea_side(earlier) or earlier  # the vessel effects alternate alone, as below
    augmented_vessel_yaml(vessel, replace(diag, winner=alone), augmented)
    sea_with_effects(run, vessel, diagnoser.parameters, alone.phi, augmented, echo)
    alternated, made = alternate_with_sea(run, vessel, diagnoser, channels, replace(diag, winner=alone), augmented,
                                          rounds, echo)
    in_sea = in_refitted_sea(run, vessel, diagnoser, channels)
    kept, gain_t, gain_h = in_sea.retest(alternated, effect)
    echo(f"diagnose: {effect.name} tested again on top of {alone.effect} in the sea alternated with it: "
         f"{gain_t:.1f} nats training, {gain_h:.1f} held out: {'kept' if kept else 'withdrawn'}")
    if kept is not None:
        return diag, [], None
    return replace(diag, winner=earlier), [effect.name], (alternated, made) if alone is earlier else None


def held_out_and_folds(diagnoser, fit, held_out: float, gain_of, folds: bool = True) -> dict:
    """{"held_out": `held_out`, and where it exceeds HOLDOUT_MIN (and `folds`) "fold_0", "fold_1"}: `gain_of(rep,
    fold_base, fold_fit)` of each half of `diagnoser.fold_fits`, −inf where the fold's fit stops at a bound."""
    from seatune.diagnosis.select import HOLDOUT_MIN, _at_bound

    gains = {"held_out": held_out}
    if folds and held_out > HOLDOUT_MIN:
        for fold in (0, 1):
            rep, fold_base, fold_fit = diagnoser.fold_fits(fit, fold)
            gains[f"fold_{fold}"] = (gain_of(rep, fold_base, fold_fit)
                                     if not _at_bound(fold_fit.effect_used, fold_fit.params) else -np.inf)
    return gains


def held_out_in_own_sea(run, vessel, diagnoser, channels, diag, augmented: Path, echo=print):
    """Where nothing was named, the vessel candidate with the largest training gain over BIC's penalty (no parameter
    at a bound; it failed held out or across the folds, not by the calibrated test nor in a sea fitted from the
    channels it leaves untouched: a 24 h day of seatune's own clean simulator named a 1 m lever arm here, 8.6 nats
    held out, that had lost 4.7 there), tested with each model in its own sea: the held-out windows' sea refitted
    through the candidate (`sea_with_effects`), the model without effect keeping the sea stage's sea, which was fitted
    through that model. The sea stage fits each window's sea to its own motions, so a sensor effect such as a
    misalignment is absorbed there, in the held-out windows as in the training ones. Named when its held-out gain so
    measured, and that of each half of a 2-fold split of the windows (fitted on one half, its sea refitted, held out on
    the other), exceed HOLDOUT_MIN. Returns (the diagnosis, {test: gain} or None)."""
    from seatune.diagnosis.effects import SEA_SIDE
    from seatune.diagnosis.select import HOLDOUT_MIN

    if diag.winner is not None:
        return diag, None
    failed = [r for r in diag.rows if r["added"] not in SEA_SIDE and r["added"] != "none" and not r["at_bound"]
              and r["gain_train"] > r["bic_penalty"] and np.isfinite(r["gain_holdout"])
              and not r["false_alarm_p"] > diagnoser.null_level  # the calibrated test, where run, stands
              and not np.isfinite(r.get("untouched_sea_gain", np.nan))]  # so does the one in its untouched sea
    if not failed:
        return diag, None
    row = max(failed, key=lambda r: r["gain_train"] - r["bic_penalty"])
    base = diag.base

    def own_sea_gain(d, base_fit, fit) -> float:
        augmented_vessel_yaml(vessel, replace(diag, winner=fit), augmented)
        sea_with_effects(run, vessel, diagnoser.parameters, fit.phi, augmented, echo=lambda *a: None)
        own = in_refitted_sea(run, vessel, diagnoser, channels, roles=d.data.roles)
        return float(base_fit.nll_holdout - own.nll(fit.phi, fit.effect_used, fit.params, which=own.holdout))

    gains = held_out_and_folds(diagnoser, row["fit"], own_sea_gain(diagnoser, base, row["fit"]), own_sea_gain)
    passed = min(gains.values()) > HOLDOUT_MIN
    echo(f"diagnose ↔ own sea: {row['added']} held out in its own sea: "  # not the stage's one `diagnose:` line
         + ", ".join(f"{k} {v:.1f}" for k, v in gains.items()) + f" nats: {'named' if passed else 'not named'}")
    row["own_sea_gain"] = min(gains.values())
    augmented.unlink(missing_ok=True)
    run.artefact(DIAGNOSED_SEA_FILE).unlink(missing_ok=True)
    if not passed:
        return diag, gains
    row["eligible"] = row["selected"] = True
    r1, sd1, _ = diagnoser.residuals(row["fit"].phi, row["fit"].effect_used, row["fit"].params)
    return replace(diag, winner=row["fit"], residual_after=(r1, sd1)), gains


def untouched_sea(run, vessel, diagnoser, channels, effect, phi):
    """(`diagnoser`'s loading and start in a sea fitted from the sea's channels `effect` leaves as they were
    (`Effect.untouched`), which cannot have absorbed it; those channels), or None when it leaves none or fewer than
    two. The loading belief: `phi` with the tune's posterior std."""
    import pyarrow.parquet as pq

    from seatune.pipeline.sea import run_sea_channels, sea_stage

    sea = run_sea_channels(run, vessel, set(pq.read_schema(run.artefact("motions.parquet")).names))
    keep = effect.untouched(vessel, sea)
    if keep is None or not 2 <= len(keep) < len(sea):
        return None
    sea_stage(run, vessel, echo=lambda *a: None, force=True, channels=keep, artefact=DIAGNOSED_SEA_FILE,
              parameters=loading_belief(run, vessel, diagnoser.parameters, phi), vessel_path=run.vessel_path)
    found = in_refitted_sea(run, vessel, diagnoser, channels)
    run.artefact(DIAGNOSED_SEA_FILE).unlink(missing_ok=True)
    return found, keep


def _take_untouched_fit(diagnoser, diag, row, fit):
    """`row` (a step-1 candidate) made the winner with `fit`, found in its untouched sea; the row's likelihoods,
    gains, gaps and bands measured in the sea stage's sea, where the other candidates were compared."""
    from seatune.diagnosis import residuals as res

    effect = fit.effect_used
    nll_train, nll_holdout = (diagnoser.nll(fit.phi, effect, fit.params, which=w)
                              for w in (diagnoser.train, diagnoser.holdout))
    fit = replace(fit, nll_train=nll_train, nll_holdout=nll_holdout)
    r1, sd1, _ = diagnoser.residuals(fit.phi, effect, fit.params)
    diag.gaps[fit.effect] = diagnoser.gaps_with_sea(diagnoser.residuals(diag.phi_before), fit)
    diag.bands_after[fit.effect] = res.bands(diagnoser.data.subset(diagnoser.train), r1[diagnoser.train],
                                             sd1[diagnoser.train], diagnoser.modes(fit.phi))
    gain_t, gain_h = diag.base.nll_train - nll_train, diag.base.nll_holdout - nll_holdout
    row.update(fit=fit, gain_train=gain_t, gain_holdout=gain_h, joint_gain_train=gain_t, joint_gain_holdout=gain_h,
               eligible=True, selected=True)
    return replace(diag, winner=fit, residual_after=(r1, sd1))


def held_out_in_untouched_sea(run, vessel, diagnoser, channels, diag, echo=print):
    """Where no vessel effect was named, each vessel candidate that leaves some of the sea's channels as they were
    (`Effect.untouched`: an IMU lever arm moves the specific forces, not the angles and rates) tested in a sea fitted
    from those channels alone (`untouched_sea`): the loading without effect and the candidate refitted on the
    training windows there (every channel), named when its training gain exceeds BIC's penalty and its held-out
    gain, and that of each half of a 2-fold split, exceed HOLDOUT_MIN. The sea stage fits each window's sea through
    the specific forces of an IMU where the YAML puts it: on the blind bank's osv_imu_lever_arm_042 the true 48 m arm
    then looked 1329 nats worse than none on the training windows and the fit stopped at +17 m. Where such an effect
    was named alone, it is refitted there from its scan and from where it stood, and the better fit kept
    (`refit_in_untouched_sea`). Returns (the diagnosis, the names of the sea-side corrections it supersedes)."""
    from seatune.diagnosis.effects import SEA_SIDE
    from seatune.diagnosis.select import HOLDOUT_MIN, _at_bound, _members

    if any(e.name not in SEA_SIDE for e, _ in diag.named_effects):
        return refit_in_untouched_sea(run, vessel, diagnoser, channels, diag, echo), []
    rows = [r for r in diag.rows if r["step"] == 1 and r["added"] not in SEA_SIDE and r["added"] != "none"]
    for row in rows:
        effect = row["fit"].effect_used
        found = untouched_sea(run, vessel, diagnoser, channels, effect, diag.base.phi)
        if found is None:
            continue
        untouched, keep = found
        base = untouched.base_fit()
        fit = untouched.fit(effect, start=base)
        gains = held_out_and_folds(untouched, fit, base.nll_holdout - fit.nll_holdout,
                                   lambda _, fold_base, fold_fit: fold_base.nll_holdout - fold_fit.nll_holdout,
                                   folds=base.nll_train - fit.nll_train > row["bic_penalty"])
        passed = len(gains) == 3 and min(gains.values()) > HOLDOUT_MIN and not _at_bound(fit.effect_used, fit.params)
        stronger = _stronger_there(untouched, base, fit, row, rows) if passed else None
        echo(f"diagnose ↔ untouched sea: {row['added']} in a sea fitted from {', '.join(keep)}: training "
             f"{base.nll_train - fit.nll_train:.1f}, " + ", ".join(f"{k} {v:.1f}" for k, v in gains.items())
             + " nats: " + (f"not named, {stronger[0]} fits the training windows there better ({stronger[1]:.1f} "
                            "nats over BIC's penalty)" if stronger else "named" if passed else "not named"))
        passed = passed and stronger is None
        row["untouched_sea_gain"] = min(gains.values())
        if passed:
            # what a sea-side correction named before had explained, the sea refitted through this effect takes over
            superseded = [e.name for e, _ in (_members(diag.winner) if diag.winner is not None else [])]
            return _take_untouched_fit(diagnoser, diag, row, fit), superseded
    return diag, []


def _stronger_there(untouched, base, fit, row, rows) -> tuple[str, float] | None:
    """(name, training gain over BIC's penalty) of another vessel candidate that fits the training windows of the
    untouched sea better than `fit`, `row`'s candidate, or None. That sea is fitted from fewer channels, and what it
    leaves unexplained in the others another effect may explain better (seatune's 16 h benchmark day: a 36 m²
    moonpool's heave taken for a 2 m lever arm, 5.7 nats held out)."""
    from seatune.diagnosis.select import _at_bound

    own = base.nll_train - fit.nll_train - row["bic_penalty"]
    best = None
    for other in rows:
        if other is row:
            continue
        f = untouched.fit(other["fit"].effect_used, start=base)
        score = base.nll_train - f.nll_train - other["bic_penalty"]
        if score > own and not _at_bound(f.effect_used, f.params) and (best is None or score > best[1]):
            best = (other["added"], float(score))
    return best


def refit_in_untouched_sea(run, vessel, diagnoser, channels, diag, echo=print):
    """A vessel effect named alone that leaves some of the sea's channels untouched, refitted in the sea fitted from
    them (`untouched_sea`) from its scan and from where it stood; where the scan's fit is better there by more than
    HOLDOUT_MIN on the training windows, the named one had stopped at an optimum the sea stage's sea made (blind
    bank, osv_compound_056: a 48 m lever arm named at +23 m), and the scan's is kept."""
    from seatune.diagnosis.select import HOLDOUT_MIN, Compound

    named = diag.winner
    if named is None or named.effect_used is None or isinstance(named.effect_used, Compound):
        return diag
    found = untouched_sea(run, vessel, diagnoser, channels, named.effect_used, named.phi)
    if found is None:
        return diag
    untouched, keep = found
    scanned = untouched.fit(named.effect_used, start=untouched.base_fit())
    stood = untouched.refine(named)
    better = stood.nll_train - scanned.nll_train
    moved = better > HOLDOUT_MIN
    echo(f"diagnose ↔ untouched sea: {named.effect} refitted in a sea fitted from {', '.join(keep)}: from its scan "
         + ", ".join(f"{k} {v:.3g}" for k, v in scanned.params.items()) + f", {better:.1f} nats better on the "
         f"training windows than from where it stood: {'taken' if moved else 'kept as named'}")
    row = next((r for r in diag.rows if r["selected"] and r["added"] == named.effect), None)
    return _take_untouched_fit(diagnoser, diag, row, scanned) if moved and row is not None else diag


def diagnose_stage(run, vessel, echo=print, force: bool = False) -> dict:
    from seatune.diagnosis.effects import EFFECT_NAMES, SEA_SIDE, library
    from seatune.diagnosis.residuals import describe
    from seatune.io.parquet import write_table
    from seatune.io.rundir import fingerprint, is_fresh
    from seatune.pipeline.identify import DIAGNOSED_NF_FILE

    settings = run.spec.diagnose
    src = [run.artefact(n) for n in ("windows.parquet", "window_stats.parquet", "window_spectra.parquet",
                                     "motions.parquet", "tuning_history.parquet")]
    from seatune.pipeline.sea import sea_inputs

    fp = fingerprint(src + sea_inputs(run) + [run.hindcast_path, run.vessel_path],
                     {"stage": "diagnose", "diagnose": settings.model_dump(), "known": run.spec.identify.known,
                      "holdout_every": run.spec.tuning.holdout_every,
                      "uncertainty": run.spec.hindcast.uncertainty.model_dump()})
    outs = [run.artefact(n) for n in ("diagnosis.parquet", "diagnosis_residuals.parquet")]
    augmented = run.artefact("augmented_vessel.yaml")
    if not force and is_fresh(outs, fp):
        return {"skipped": True}
    parameters, phi_start = diagnosis_parameters(run, vessel)
    available = set(pd.read_parquet(src[1], columns=["channel"])["channel"])
    channels = settings.channels or run.spec.tuning.channels or [c.name for c in vessel.channels
                                                                 if c.name in available]
    missing = [c for c in channels if c not in available]
    if missing:
        raise UserError(str(run.path), "diagnose.channels", f"not among the filtered channels: {', '.join(missing)}")
    unknown = [n for n in settings.effects or () if n not in EFFECT_NAMES]
    if unknown:
        raise UserError(str(run.path), "diagnose.effects", f"unknown effect(s): {', '.join(unknown)}")
    data = window_set(run, vessel, channels)
    diagnoser = run_diagnoser(run, vessel, parameters, data, phi_start, null=null_sea(settings.calibration))
    # the tank's range from the roll mode its scan starts from (the model at the start loading)
    effects = library(settings.effects, moonpool_position=settings.moonpool_position, vessel=vessel,
                      omega_roll=diagnoser.model.parts(phi_start).omega_roll)
    diag = diagnoser.run(effects, max_named=settings.max_effects)
    superseded = []  # sea-side corrections named before a vessel effect found in a sea that had not absorbed it
    if run.spec.sea.estimate and settings.alternation_rounds:
        diag, superseded = held_out_in_untouched_sea(run, vessel, diagnoser, channels, diag, echo)
        diag, _ = held_out_in_own_sea(run, vessel, diagnoser, channels, diag, augmented, echo)
    train = data.roles == "train"
    meta = {"fingerprint": fp}
    alternated, rounds, withdrawn, with_sea = None, 0, [], None
    dropped, done = [], None  # a later vessel effect the sea alternated with the earlier ones took over
    if run.spec.sea.estimate and settings.alternation_rounds:
        diag, dropped, done = retest_later_effect(run, vessel, diagnoser, channels, diag, augmented,
                                                  settings.alternation_rounds, echo)
    alone = (diagnoser.without_sea_side(diag.winner)
             if run.spec.sea.estimate and settings.alternation_rounds and diag.winner is not None else None)
    if alone is not None:  # the vessel effects alternate alone; the sea-side correction is tested again after
        withdrawn = [e for e, _ in diag.named_effects if e.name in SEA_SIDE]
        diag = replace(diag, winner=alone)
    if diag.winner is not None:
        augmented_vessel_yaml(vessel, diag, augmented)
    else:
        augmented.unlink(missing_ok=True)  # a previous diagnosis' effect no longer holds
    if run.spec.sea.estimate and any(e.name not in SEA_SIDE for e, _ in diag.named_effects):
        if done is not None:  # the retest above alternated these effects with the sea already
            alternated, rounds = done
            augmented_vessel_yaml(vessel, replace(diag, winner=alternated), augmented)
        else:
            sea_with_effects(run, vessel, parameters, diag.winner.phi, augmented, echo)
            if settings.alternation_rounds:
                alternated, rounds = alternate_with_sea(run, vessel, diagnoser, channels, diag, augmented,
                                                        settings.alternation_rounds, echo)
                if withdrawn:
                    alternated, withdrawn = retest_sea_side(run, vessel, diagnoser, channels,
                                                            replace(diag, winner=alternated), withdrawn, augmented,
                                                            echo)
                    diag = replace(diag, winner=alternated)
        final = alternated if alternated is not None else diag.winner
        with_sea = in_refitted_sea(run, vessel, diagnoser, channels).gaps_with_sea(
            diagnoser.residuals(diag.phi_before), final)
        identify_in_diagnosed_sea(run, vessel, meta, echo, belief=loading_belief(run, vessel, parameters, final.phi),
                                  named=[e.name for e, _ in diag.named_effects])
    else:  # no vessel effect named: the sea stage's model stands
        run.artefact(DIAGNOSED_SEA_FILE).unlink(missing_ok=True)
        run.artefact(DIAGNOSED_NF_FILE).unlink(missing_ok=True)
    table = diagnosis_table(diag, effects, alternated, rounds, withdrawn + dropped + superseded, with_sea)
    write_table(residual_table(data, diag), outs[1], RESIDUAL_UNITS, meta)
    write_table(table, outs[0], DIAGNOSIS_UNITS, meta)
    chosen = table[table["selected"]]
    row = chosen.iloc[-1] if len(chosen) else table[table["effect"] == "none"].iloc[0]  # the final model
    return {"skipped": False, "windows": len(data.window_ids), "holdout": int((~train).sum()),
            "candidates": int((table["step"] == 1).sum()) - 1, "named": diag.named,
            "steps": [{"effect": r.effect, "gain_holdout": float(r.gain_holdout),
                       "untouched_sea_gain": float(r.untouched_sea_gain), "false_alarm_p": float(r.false_alarm_p),
                       "fitted": json.loads(r.fitted_with_sea or r.fitted)}
                      for r in chosen.itertuples()],
            "not_significant": [f"{r.effect} (p {r.false_alarm_p:.2g})" for r in table.itertuples()
                                if np.isfinite(r.false_alarm_p) and not r.eligible],
            "bands_before": [describe(b) for b in diag.bands_before],
            "bands_after": row["bands_after"], "gap_before": float(row["gap_before_holdout"]),
            "gap_after": float(row["gap_after_holdout"]),
            "sigma_before": float(row["sigma_error_before_holdout"]),
            "sigma_after": float(row["sigma_error_after_holdout"]),
            "with_sea": None if with_sea is None else {k: float(row[f"{k}_holdout_with_sea"]) for k in (
                "gap_before", "gap_after", "sigma_error_before", "sigma_error_after")},
            "augmented": str(augmented) if diag.winner is not None else None}

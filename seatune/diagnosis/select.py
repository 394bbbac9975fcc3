"""Model selection over the candidate effects: fit each on the training windows together with the tuned loading
parameters, score it on the held-out windows, name the winner or report the misfit as unexplained. Pure
computation.

Likelihood of a window's log spectral residuals r_jf = ln(Ŝ_jf / E[Ŝ_jf]) (bias-corrected, residuals.py), with
E[Ŝ] the model convolved with the Welch spectral window. One sea realisation drives every channel, so the χ²
sampling of Ŝ at a frequency is largely one factor for all channels, and the hindcast's Hs error is one factor
for the whole window:

    r_jf = u + e_f + η_jf,   u ~ N(0, τ²),  e_f ~ N(0, a_f),  η_jf ~ N(0, b)

with τ = 2·hs_rel_std, a = 0.8 ψ′(ν/2) + (4·tp_std/Tp)² (wave sampling and the hindcast's Tp error moving the
spectrum's flanks), b = 0.05² + 0.2 ψ′(ν/2) (what differs between channels: noise, directional spreading).
u and e_f are marginalised exactly (block Sherman–Morrison). Welch bins of a Hann segment are correlated over
its equivalent noise bandwidth (1.5 bins), so each bin counts 1/1.5. Treating channels as independent instead
lets any candidate "explain" the sea's own sampling noise on the training windows and lose on held-out ones.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from scipy.optimize import minimize
from scipy.special import digamma, polygamma

from seatune.diagnosis import residuals as res
from seatune.diagnosis.effects import SEA_SIDE, Compound
from seatune.diagnosis.model import SpectralModel, WindowSet, spectra_in_sea
from seatune.parallel import map_tasks, workers
from seatune.physics.response import trapezoid_weights

BIN_CORRELATION = 1.5  # Hann window's equivalent noise bandwidth [bins]
AFFECTED_CHANGE = 0.1  # a bin is in an effect's band where it changes the expected spectrum by ≥ 10 % (log)
HOLDOUT_MIN = 4.0  # held-out log-likelihood gain [nats] to name an effect (Jeffreys: "strong", odds > 50)
COMMON_SHARE = 0.8  # share of the χ² sampling variance common to all channels at a frequency
INDEPENDENT_FLOOR = 0.05**2  # per-channel, per-bin variance no model resolves (sensor noise, small effects)
TP_FLANK_SLOPE = 4.0  # |d ln S / d ln ω| on a JONSWAP flank: a Tp error δ moves ln S by about 4 δ/Tp


@dataclass(frozen=True)
class NullSea:
    """The calibration's null: the model without effect in a sea that differs from the one diagnose uses by what
    a sea estimate gets wrong (per window, one draw each for the whole sea), and a vessel model off by a smooth
    error. Defaults: the estimated sea's errors on the blind trial bank (Hs ≈ 10 %, Tp ≈ 4 %, direction ≈ 10°;
    spreading not resolved finer than ≈ 10°); the clean trials' systematic misfit of ln S is ≈ 0.2 RMS with
    sampling noise, 0.15 without. The run YAML's `diagnose.calibration` sets them (replicates 0 there: off)."""

    replicates: int = 19  # 19: the smallest p is 1/20, so a 5 % test is possible
    false_alarm: float = 0.05
    hs_rel_std: float = 0.10
    tp_rel_std: float = 0.04
    dir_std_deg: float = 10.0
    spread_deg: float = 10.0  # scale of an extra cos-2s spreading (half-normal)
    model_error: float = 0.15  # RMS of a smooth per-channel error of the vessel model's ln S, the same in all windows
    model_error_scale: float = 0.1  # its correlation length in ω [rad/s]
    seed: int = 0


def perturbed_wave(wave: np.ndarray, omega: np.ndarray, rng: np.random.Generator, null: NullSea) -> np.ndarray:
    """One draw of the null's sea: per window (nw, nm, nb) Hs scaled, Tp scaled self-similarly, directions turned
    and spread wider, on equally spaced directions."""
    from seatune.diagnosis.effects import spreading_kernel

    nw, _, nb = wave.shape
    hs = np.exp(null.hs_rel_std * rng.standard_normal(nw))
    ratio = np.exp(null.tp_rel_std * rng.standard_normal(nw))
    turn = null.dir_std_deg * rng.standard_normal(nw)
    spread = np.abs(null.spread_deg * rng.standard_normal(nw))
    out = hs[:, None, None] ** 2 * turned(scaled_in_frequency(wave, omega, ratio), turn)
    beta = np.arange(nb) * 2 * np.pi / nb
    for w in np.flatnonzero(spread >= 1.0):
        out[w] = out[w] @ spreading_kernel(beta, spread[w]).T
    return out


def model_error_draw(omega: np.ndarray, n_channels: int, rng: np.random.Generator, rms: float,
                     scale: float) -> np.ndarray:
    """A smooth error of the vessel model's log spectra per channel (nc, nf): a Gaussian process in ω with a
    squared-exponential kernel (what no loading parameter fixes: hull-form and BEM error, the structural
    discrepancy of Kennedy & O'Hagan 2001)."""
    if rms <= 0:
        return np.zeros((n_channels, omega.size))
    d = omega[:, None] - omega[None, :]
    k = rms**2 * np.exp(-0.5 * (d / scale) ** 2) + 1e-10 * rms**2 * np.eye(omega.size)
    return rng.standard_normal((n_channels, omega.size)) @ np.linalg.cholesky(k).T


def _bin_correlated(z: np.ndarray) -> np.ndarray:
    """Unit-variance noise along the last axis with neighbour correlation such that n bins count n / 1.5
    (BIN_CORRELATION): a 3-tap moving average [a, 1, a], (1 + 2a)² / (1 + 2a²) = 1.5."""
    c = BIN_CORRELATION
    a = (-4.0 + np.sqrt(16.0 - 4.0 * (4.0 - 2.0 * c) * (1.0 - c))) / (2.0 * (4.0 - 2.0 * c))
    padded = np.concatenate([z[..., :1], z, z[..., -1:]], axis=-1)
    return (padded[..., 1:-1] + a * (padded[..., :-2] + padded[..., 2:])) / np.sqrt(1.0 + 2.0 * a * a)


def sampled_spectra(expected: np.ndarray, dof: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Welch estimates of expected spectra (nw, nc, nf) with ν = dof (nw, nc): ln Ŝ = ln E + ψ(ν/2) − ln(ν/2) +
    noise of variance ψ′(ν/2) (the χ²_ν law's log moments), 80 % of it common to the channels (one sea drives
    them), plus the per-channel floor — the likelihood's own noise model (window_nll)."""
    half = np.asarray(dof, dtype=float)[..., None] / 2
    common = _bin_correlated(rng.standard_normal((expected.shape[0], 1, expected.shape[2])))
    own = _bin_correlated(rng.standard_normal(expected.shape))
    z = np.sqrt(COMMON_SHARE) * common + np.sqrt(1 - COMMON_SHARE) * own
    noise = np.sqrt(polygamma(1, half)) * z + np.sqrt(INDEPENDENT_FLOOR) * rng.standard_normal(expected.shape)
    return np.maximum(expected, 1e-300) * np.exp(digamma(half) - np.log(half) + noise)


def window_nll(r: np.ndarray, mask: np.ndarray, dof: np.ndarray, tau: float, shape_var: np.ndarray):
    """−ln p of each window's residuals (nw, nc, nf) under the model above; and the posterior mean of u."""
    psi = polygamma(1, np.asarray(dof, dtype=float).mean(axis=1) / 2)  # (nw,)
    a = (COMMON_SHARE * psi + shape_var)[:, None]  # (nw, 1)
    b = (INDEPENDENT_FLOOR + (1 - COMMON_SHARE) * psi)[:, None]
    rm = np.where(mask, r, 0.0)
    n = mask.sum(axis=1)  # (nw, nf)
    s1 = rm.sum(axis=1)
    s2 = (rm**2).sum(axis=1)
    den = b + n * a
    quad = (s2 - a / den * s1**2) / b
    logdet = np.where(n > 0, n * np.log(b) + np.log1p(n * a / b), 0.0)
    s = (n / den).sum(axis=1)
    t = (s1 / den).sum(axis=1)
    prec = s + 1.0 / tau**2
    value = 0.5 * (quad.sum(axis=1) - t**2 / prec + logdet.sum(axis=1) + np.log(tau**2 * prec))
    return value / BIN_CORRELATION, t / prec


@dataclass
class Fit:
    effect: str
    params: dict
    phi: np.ndarray
    nll_train: float
    nll_holdout: float
    n_params: int
    converged: bool
    std: dict = field(default_factory=dict)  # Laplace standard errors of the effect parameters
    effect_used: object = None  # the Effect as fitted (its ranges widened where `widened` says)
    widened: list = field(default_factory=list)  # parameters whose search was widened to the physical limit


class Diagnoser:
    def __init__(self, vessel, parameters, data: WindowSet, phi_start: np.ndarray, hs_rel_std: float = 0.1,
                 tp_std_s: float = 0.0, dir_std_deg: float = 0.0, null: NullSea | None = None):
        """`null`: calibrate the decision by a parametric bootstrap (None or 0 replicates: the fixed rule)."""
        self.null = null
        self.vessel = vessel
        self.parameters = list(parameters)
        self.data = data
        self.model = SpectralModel(vessel, [p.name for p in self.parameters], data)
        self._take_roles()
        self.tau = max(2.0 * hs_rel_std, 1e-3)
        self.shape_var = (TP_FLANK_SLOPE * tp_std_s / data.tp) ** 2
        self.tp_std_s, self.dir_std_deg = tp_std_s, dir_std_deg
        self.phi_start = np.asarray(phi_start, dtype=float)
        self._mean = np.array([p.prior_mean for p in self.parameters])
        self._std = np.array([p.prior_std for p in self.parameters])
        self._lo = np.array([p.lower for p in self.parameters])
        self._hi = np.array([p.upper for p in self.parameters])
        self._base = None

    # --- likelihood -----------------------------------------------------------------------------------------
    def nll(self, phi, effect=None, params=None, which=None) -> float:
        which = self.train if which is None else which
        if not which.any():
            return float("nan")
        pred = self.model.spectra(phi, effect, params)
        d = self.data
        r, _ = res.log_ratio(d.measured[which], pred[which], d.dof[which])
        value, _ = window_nll(r, d.mask[which], d.dof[which], self.tau, self.shape_var[which])
        return float(value.sum())

    def _unpack(self, x, effect):
        p = len(self.parameters)
        phi = np.clip(self.phi_start + x[:p] * self._std, self._lo, self._hi)
        params = {}
        if effect is not None:
            for k, q in enumerate(effect.parameters):
                params[q.name] = q.lower + float(np.clip(x[p + k], 0.0, 1.0)) * (q.upper - q.lower)
        return phi, params

    def _objective(self, x, effect):
        phi, params = self._unpack(x, effect)
        return self.nll(phi, effect, params) + self._prior(phi)

    def _prior(self, phi) -> float:
        """−ln of the loading's Gaussian prior (vessel-YAML priors), up to a constant."""
        return 0.5 * float((((phi - self._mean) / self._std) ** 2).sum())

    # --- fitting --------------------------------------------------------------------------------------------
    def fit(self, effect=None, bands=(), start: Fit | None = None) -> Fit:
        """The loading (from `start`'s, default the refit without effect) and the effect's parameters fitted on the
        training windows. A parameter stopped at a search bound short of its physical limit widens the search to
        the limit once (issue 17); `Fit.effect_used` is the effect as finally searched."""
        start = self._base if start is None else start
        fit = self._fit(effect, bands, start)
        if effect is not None:
            stuck = [q.name for q in effect.parameters if q.widenable and q.name in _at_bound(effect, fit.params)]
            if stuck:
                wide = effect.widened(stuck)
                fit = self._fit(wide, (), start, x_from=fit)
                fit.widened = stuck
        if effect is None:
            self._base = fit = self._restarted(fit)  # candidates start from the refitted loading without effect
        return fit

    def _restarted(self, fit: Fit) -> Fit:
        """The fit without effect restarted from its optimum with a fresh curvature estimate until it gains less than
        0.01 nat (at most 3 restarts): L-BFGS-B can stop short on its finite-difference gradient, and every
        candidate's gain is counted from this fit (blind bank, osv_clean_016: one restart 3.98 nats lower, the gain
        a quadratic roll damping had been named for)."""
        for _ in range(3):
            again = self._fit(None, (), None, x_from=fit)
            gained = self._penalised(fit) - self._penalised(again)
            if gained > 0:
                fit = again
            if gained < 0.01:
                break
        return fit

    def _penalised(self, fit: Fit) -> float:
        """The objective the fits minimise: training −ln p plus the loading's Gaussian prior."""
        return fit.nll_train + self._prior(fit.phi)

    def _fit(self, effect, bands, start: Fit | None, x_from: Fit | None = None) -> Fit:
        p = len(self.parameters)
        x0 = np.zeros(p) if effect is None or start is None else (start.phi - self.phi_start) / self._std
        if x_from is not None:
            x0 = (x_from.phi - self.phi_start) / self._std
        bounds = [((lo - s0) / sd, (hi - s0) / sd) for lo, hi, s0, sd in
                  zip(self._lo, self._hi, self.phi_start, self._std, strict=True)]
        if effect is not None:
            values = x_from.params if x_from is not None else {q.name: q.initial for q in effect.parameters}
            x0 = np.r_[x0, [(values[q.name] - q.lower) / (q.upper - q.lower) for q in effect.parameters]]
            bounds += [(0.0, 1.0)] * len(effect.parameters)
            if x_from is None:
                x0 = self._scan(x0, effect, bands)
        result = minimize(self._objective, x0, args=(effect,), method="L-BFGS-B", bounds=bounds,
                          options={"maxiter": 200, "eps": 1e-4})
        phi, params = self._unpack(result.x, effect)
        nll_h = self.nll(phi, effect, params, self.holdout) if self.holdout.any() else float("nan")
        std = self._effect_std(result, effect) if effect is not None else {}
        return Fit(effect.name if effect else "none", params, phi, self.nll(phi, effect, params), nll_h,
                   len(effect.parameters) if effect else 0, bool(result.success), std, effect_used=effect)

    def refine(self, fit: Fit) -> Fit:
        """`fit`'s effects refitted on this Diagnoser's data from its parameters and loading: a round of diagnose's
        alternation with the sea (the windows' sea refitted through the named effects, then the effects in it)."""
        return self._fit(fit.effect_used, (), fit, x_from=fit)

    def _scan(self, x0, effect, bands):
        p = len(self.parameters)
        parts0 = self.model.parts(self.phi_start)
        scans = effect.scan_values(parts0, bands)
        if not scans:
            return x0
        names = [q.name for q in effect.parameters]
        grids = []
        for q in effect.parameters:
            values = scans.get(q.name, ())
            grids.append([(v - q.lower) / (q.upper - q.lower) for v in values] or [x0[p + names.index(q.name)]])
        best, best_x = np.inf, x0
        for combo in itertools.product(*grids):
            x = x0.copy()
            x[p:] = np.clip(combo, 0.0, 1.0)
            value = self._objective(x, effect)
            if value < best:
                best, best_x = value, x
        return best_x

    def _effect_std(self, result, effect) -> dict:
        """Laplace standard errors from L-BFGS-B's inverse-Hessian approximation (a rough figure)."""
        try:
            cov = result.hess_inv.todense()
        except AttributeError:
            return {}
        p = len(self.parameters)
        out = {}
        for k, q in enumerate(effect.parameters):
            out[q.name] = float(np.sqrt(max(cov[p + k, p + k], 0.0)) * (q.upper - q.lower))
        return out

    def sea_state_search(self, phi) -> np.ndarray:
        """Each window's wave spectrum with the hindcast's Tp and direction errors corrected to their MAP under the
        model without effect: a 5 × 5 grid of ±2σ in Tp and direction (Gaussian prior, A5 Table 4.1 errors)."""
        d = self.data
        steps = np.linspace(-2.0, 2.0, 5)
        parts = self.model.parts(phi)
        h = parts.solve()
        power = h.real**2 + h.imag**2  # (nm, nb, nc)
        best = np.full(len(d.window_ids), np.inf)
        out = d.wave.copy()
        for a in steps:
            for b in steps:
                wave = shifted_wave(d.wave, d.omega_fine, d.tp, a * self.tp_std_s, b * self.dir_std_deg)
                pred = spectra_in_sea(power, wave)[..., d.kernel_index] @ d.kernel
                r, _ = res.log_ratio(d.measured, pred, d.dof)
                value = window_nll(r, d.mask, d.dof, self.tau, self.shape_var)[0] + 0.5 * (a * a + b * b)
                better = value < best
                best = np.where(better, value, best)
                out[better] = wave[better]
        return out

    # --- the whole selection --------------------------------------------------------------------------------
    def residuals(self, phi, effect=None, params=None):
        """(r, sd, û) of every window under a model; r already divided by the window's scale e^û."""
        d = self.data
        pred = self.model.spectra(phi, effect, params)
        r, sd = res.log_ratio(d.measured, pred, d.dof)
        _, u = window_nll(r, d.mask, d.dof, self.tau, self.shape_var)
        return r - u[:, None, None], sd, pred

    def modes(self, phi) -> dict[str, float]:
        from seatune.physics.response import natural_frequencies

        w = natural_frequencies(self.vessel.db, self.model.loading(phi), dofs=(2, 3, 4))[0]
        return {res.DOF_NAMES[d]: float(v) for d, v in zip((2, 3, 4), w, strict=True)}

    def run(self, effects, phi_before: np.ndarray | str | None = None, max_named: int = 1) -> Diagnosis:
        """Greedy forward selection (issue 17): fit every candidate, name the strongest eligible one, add it to the
        model and fit the others with it (its parameters refitted jointly), until none passes or `max_named` vessel
        effects are named. A sea-side correction does not count: the sea gets one, and vessel effects are then
        sought on top of it (on the blind bank a named swell or spreading had hidden a moonpool, a misalignment and
        a lever arm). Once a vessel effect is named, the model with the next one added must also help out of sample
        (held-out gap and σ error below the tuned model's); for the first vessel effect that stays a report, since
        there it would drop half the correct names (`out_of_sample_required`).
        `phi_before`: the tuned loading the gap is measured from (default the start); "refit": the loading refitted
        here without any effect (what a tuning on these windows gives)."""
        wave_given = self.data.wave
        base = self.base_fit()
        if isinstance(phi_before, str):
            phi_before = base.phi
        phi_before = self.phi_start if phi_before is None else np.asarray(phi_before, dtype=float)
        r0, sd0, pred0 = self.residuals(phi_before)
        train_data = self.data.subset(self.train)
        found = res.bands(train_data, r0[self.train], sd0[self.train], self.modes(phi_before))
        ctx = _Context(base, (r0, sd0, pred0), _band_selection(self.data, found), train_data)
        candidates = [e for e in effects if e.applicable(self.vessel, self.data.channels)]
        rows = [self._row(base, base, 1, ctx)]
        named: list[Fit] = []
        step_base, bands_now = base, found
        while sum(_members(f)[-1][0].name not in SEA_SIDE for f in named) < max_named and len(named) <= max_named:
            # (at most one sea-side correction: _may_follow)
            given = _members(step_base)
            left = [e for e in candidates if e.name not in {g.name for g, _ in given}
                    and _may_follow(e.name, given, rows)]
            if not left:
                break
            fits = map_tasks(partial(self._fit_candidate, given, bands_now, step_base), left,
                             cost=lambda e: len(e.parameters))  # the three-parameter candidates first
            step_rows = [self._row(f, step_base, len(named) + 1, ctx) for f in fits]
            rows += step_rows
            best = self._strongest_that_holds(step_rows, step_base, wave_given)
            if best is None:
                break
            best["selected"] = True
            named.append(best["fit"])
            step_base = best["fit"]
            bands_now = ctx.left[step_base.effect]
        winner = named[-1] if named else None
        r1, sd1, _ = ctx.cache[(winner or base).effect]
        return Diagnosis(rows=rows, winner=winner, base=base, phi_before=phi_before, bands_before=found,
                         bands_after=ctx.left, residual_before=(r0, sd0), residual_after=(r1, sd1), gaps=ctx.gaps,
                         parameter_names=tuple(p.name for p in self.parameters))

    def without_sea_side(self, fit: Fit) -> Fit | None:
        """`fit`'s vessel effects refitted alone from their values and loading in `fit`, its sea-side corrections
        dropped; None unless it holds both. The sea it was fitted in had absorbed the vessel effect, and a sea-side
        correction can take the rest (blind bank, osv_imu_lever_arm_042: a 2.6 m swell named on a full hindcast before
        a 48 m lever arm); diagnose alternates the vessel effects alone with the sea and re-tests it (`retest`)."""
        members = _members(fit)
        vessel = [(e, p) for e, p in members if e.name not in SEA_SIDE]
        if not vessel or len(vessel) == len(members):
            return None
        if len(vessel) == 1:
            effect, params = vessel[0][0], vessel[0][1]
        else:
            effect = Compound(vessel[:-1], vessel[-1][0])
            params = {f"{e.name}.{k}": v for e, p in vessel for k, v in p.items()}
        start = Fit(effect.name, params, fit.phi, np.nan, np.nan, len(effect.parameters), True, effect_used=effect)
        return self._fit(effect, (), None, x_from=start)

    def retest(self, fit: Fit, effect) -> tuple[Fit | None, float, float]:
        """`effect` added to `fit` in this Diagnoser's sea and judged by the naming rule's gains (held-out gain over
        the threshold, training gain over BIC's penalty, no parameter at a bound): (the fit with it, or None when it
        fails; training gain; held-out gain)."""
        both = self.fit(Compound(_members(fit), effect), start=fit)
        gain_t, gain_h = fit.nll_train - both.nll_train, fit.nll_holdout - both.nll_holdout
        passes = _strong(gain_t, gain_h, self._bic_penalty(len(effect.parameters))) and not _at_bound(
            both.effect_used, both.params)
        return (both if passes else None), float(gain_t), float(gain_h)

    def _bic_penalty(self, n_params: int) -> float:
        """BIC's penalty [nat] of `n_params` more parameters on the training bins."""
        return 0.5 * n_params * np.log(max(self.n_train, 2.0))

    def _fit_candidate(self, given, bands, step_base: Fit, effect) -> Fit:
        return self.fit(Compound(given, effect) if given else effect, bands, start=step_base)

    def _row(self, f: Fit, step_base: Fit, step: int, ctx: _Context) -> dict:
        """One candidate at one step: its gains over the step's model (the effects named so far), its joint gains
        over the model without effect, the eligibility rule, and (in `ctx`) its residuals, gaps and bands left."""
        added = f.n_params - step_base.n_params
        gain_t, gain_h = step_base.nll_train - f.nll_train, step_base.nll_holdout - f.nll_holdout
        penalty = self._bic_penalty(added)
        edge = ", ".join(_at_bound(f.effect_used, f.params))
        score = _score(gain_t, gain_h, penalty)
        name = _members(f)[-1][0].name if f.n_params else "none"
        strong = _strong(gain_t, gain_h, penalty) or (added > 0 and self._cross_validated(name)
                                                      and _unseen_by_holdout(gain_t, gain_h, penalty))
        r0, sd0, pred0 = ctx.before
        if f.effect not in ctx.cache:
            ctx.cache[f.effect] = rf, sdf, predf = self.residuals(f.phi, f.effect_used, f.params)
            with np.errstate(divide="ignore", invalid="ignore"):
                moved = self.data.mask & (np.abs(np.log(predf / pred0)) >= AFFECTED_CHANGE)
            select = moved if f.n_params and moved.any() else ctx.located
            before = self._gaps(r0, sd0, pred0, select, ctx.located)
            after_ = self._gaps(rf, sdf, predf, select, ctx.located)
            ctx.gaps[f.effect] = {**{f"{k}_before": v for k, v in before.items()},
                                  **{f"{k}_after": v for k, v in after_.items()}}
            ctx.left[f.effect] = res.bands(ctx.train_data, rf[self.train], sdf[self.train], self.modes(f.phi))
        given = tuple(g.name for g, _ in _members(step_base))
        return {"fit": f, "step": step, "given": given,
                "added": name,
                "gain_train": gain_t, "gain_holdout": gain_h, "bic_penalty": penalty,
                "joint_gain_train": ctx.base.nll_train - f.nll_train,
                "joint_gain_holdout": ctx.base.nll_holdout - f.nll_holdout, "at_bound": edge, "score": score,
                "eligible": bool(added > 0 and strong and not edge
                                 and (not out_of_sample_required(given)
                                      or helps_out_of_sample(ctx.gaps[f.effect]) is not False)),
                "selected": False,
                "false_alarm_p": np.nan, "null_gain_q95": np.nan, "cross_fold_gain": np.nan}

    def base_fit(self) -> Fit:
        """The loading refitted without effect; first the windows' sea states as the data see them when the
        hindcast's Tp and direction are uncertain."""
        base = self.fit(None)
        if self.tp_std_s > 0 or self.dir_std_deg > 0:
            self.data.wave = self.sea_state_search(base.phi)
            self._base = None
            base = self.fit(None)
        return base

    def _strongest_that_holds(self, rows, step_base: Fit, wave_given: np.ndarray) -> dict | None:
        """The strongest eligible candidate of a step that also passes the step's further tests, strongest first: a
        vessel-side effect must hold across the windows (`_cross_fold_gain`), and in a calibrated run its score
        must be unlikely under the null (`_calibrated`). A candidate that fails is made ineligible; weaker ones
        after the first that passes are not tested (a stronger one won)."""
        calibrated = self.null is not None and self.null.replicates > 0
        null_state: dict = {}
        for row in sorted((r for r in rows if r["eligible"]), key=lambda r: -r["score"]):
            if self._cross_validated(row["added"]):
                row["cross_fold_gain"] = self._cross_fold_gain(row["fit"], step_base)
                row["eligible"] = row["cross_fold_gain"] > HOLDOUT_MIN
            if row["eligible"] and calibrated:
                self._calibrated(row, step_base, wave_given, null_state)
            if row["eligible"]:
                return row
        return None

    def _cross_validated(self, added: str) -> bool:
        """Whether a candidate adding `added` must hold across the windows (`_cross_fold_gain`): vessel-side
        effects, when there are two windows to split."""
        return added not in SEA_SIDE and len(self.data.window_ids) >= 2

    def _cross_fold_gain(self, fit: Fit, step_base: Fit) -> float:
        """2-fold cross-validation over all windows, alternate in time (Hastie et al. 2009 §7.10): the candidate
        and the loading fitted on one fold, its held-out gain on the other over the step's model fitted there; the
        smaller of the two [nat]. An effect of the ship helps whichever windows it is fitted on; a misfit of some
        windows' sea does not carry over. Blind bank: clean hulls' lever arm −4.2, tank 0.7, misalignment 3.1 nats;
        the true effects still named 30–3500 (a misalignment 30.2, tanks 43.5 and 70.8, a moonpool 55.7)."""
        return float(min(map_tasks(partial(self._fold_gain, fit, step_base), (0, 1))))

    @property
    def null_level(self) -> float:
        """The calibrated test's false-alarm level (NaN when the decision is not calibrated)."""
        return self.null.false_alarm if self.null is not None and self.null.replicates > 0 else float("nan")

    def fold_fits(self, fit: Fit, fold: int, step_base: Fit | None = None) -> tuple[Diagnoser, Fit, Fit]:
        """(this Diagnoser with every other window held out — fold 0 trains on the even ones —, the step's model
        there (`step_base`'s effects from where they stood; default none), `fit`'s effect refitted there)."""
        rep = self._with_data(roles=np.where(np.arange(len(self.data.window_ids)) % 2 == fold, "train", "holdout"))
        base = (rep.fit(None) if step_base is None or step_base.effect_used is None
                else rep._fit(step_base.effect_used, (), None, x_from=step_base))
        # the fold's own optimum: from its scan, or from where the fit on all windows stood (a misalignment's yaw
        # scanned from zero on half the windows of osv_imu_misalignment_048 stopped at +5.6° against −7.5°)
        scanned, warm = rep.fit(fit.effect_used, start=base), rep._fit(fit.effect_used, (), None, x_from=fit)
        return rep, base, min(scanned, warm, key=lambda f: f.nll_train)

    def _fold_gain(self, fit: Fit, step_base: Fit, fold: int) -> float:
        _, base, best = self.fold_fits(fit, fold, step_base)
        return base.nll_holdout - best.nll_holdout

    def _take_roles(self) -> None:
        """The training / held-out masks and the training bins' count from the data's window roles."""
        self.train, self.holdout = self.data.roles == "train", self.data.roles == "holdout"
        self.n_train = float(self.data.mask[self.train].sum() / BIN_CORRELATION)

    def _with_data(self, **changes) -> Diagnoser:
        """This Diagnoser on its data with `changes` (WindowSet fields), sharing the model's caches; no base fit,
        no calibration."""
        rep = copy.copy(self)
        rep.data = dataclasses.replace(self.data, **changes)
        rep.model = copy.copy(self.model)
        rep.model.data = rep.data
        rep._take_roles()
        rep._base, rep.null = None, None
        return rep

    def _calibrated(self, row: dict, base: Fit, wave_given: np.ndarray, state: dict) -> None:
        """Parametric bootstrap of the decision (issue 17): data simulated from the step's model (the effects named
        so far) in a sea drawn around the one diagnose found (NullSea), diagnosed as the real data, give the
        candidate's null distribution of its score; p = (1 + #{null ≥ observed}) / (n + 1) over the n replicas
        drawn (Davison & Hinkley 1997 eq. 4.11), stopping once the test cannot pass. `state` holds the step's
        replicas and their base fits, shared by the candidates tested."""
        null = self.null
        if "draws" not in state:
            rng = np.random.default_rng(null.seed)
            state["draws"] = [self._null_draw(base, rng) for _ in range(null.replicates)]  # the same data each
            state["fitted"] = {}  # replica → (its base fit, its bands), shared by the candidates
        draws, fitted = state["draws"], state["fitted"]
        chunk = workers()  # replicas fitted side by side, then taken in order as one at a time would take them
        task = partial(self._null_score, base, wave_given, draws, fitted, row["fit"].effect_used, row["bic_penalty"])
        scores = []
        for start in range(0, null.replicates, chunk):
            batch = list(range(start, min(start + chunk, null.replicates)))
            stop = False
            for b, (score, made) in zip(batch, map_tasks(task, batch), strict=True):
                fitted.setdefault(b, made)
                scores.append(score)
                exceed = sum(v >= row["score"] for v in scores)
                if (1 + exceed) / (null.replicates + 1) > null.false_alarm:
                    stop = True  # cannot pass any more: the Monte Carlo p-value over the replicas drawn so far
                    break
            if stop:
                break
        scores = np.array(scores)
        row["false_alarm_p"] = float((1 + np.sum(scores >= row["score"])) / (scores.size + 1))
        row["null_gain_q95"] = float(np.quantile(scores, 0.95))
        row["eligible"] = row["false_alarm_p"] <= null.false_alarm

    def _null_draw(self, base: Fit, rng: np.random.Generator) -> np.ndarray:
        """The random part of one dataset under the null (`base`'s model: loading and effects named so far): its
        Welch spectra, measured in a sea drawn around the one diagnose found."""
        truth = copy.copy(self.model)
        truth.data = dataclasses.replace(self.data, wave=perturbed_wave(self.data.wave, self.data.omega_fine, rng,
                                                                        self.null))
        expected = truth.spectra(base.phi, base.effect_used, base.params) * np.exp(model_error_draw(
            self.data.omega, len(self.data.channels), rng, self.null.model_error, self.null.model_error_scale))[None]
        return sampled_spectra(expected, self.data.dof, rng)

    def _null_diagnoser(self, base: Fit, wave_given: np.ndarray, measured: np.ndarray) -> Diagnoser:
        """A Diagnoser of the drawn dataset, as the real data's: the hindcast's sea, searched at the null's
        loading."""
        rep = self._with_data(measured=measured, wave=wave_given)
        rep.phi_start = base.phi  # the null's loading: where the replica's fits start
        if rep.tp_std_s > 0 or rep.dir_std_deg > 0:  # its sea search at the null's loading, then one fit
            rep.data.wave = rep.sea_state_search(base.phi)
        return rep

    def _null_score(self, base: Fit, wave_given, draws, fitted, effect, penalty: float, b: int):
        """(the candidate's score on replica b, (the replica's base fit, its bands)); the base fit and bands from
        `fitted` when another candidate made them."""
        rep = self._null_diagnoser(base, wave_given, draws[b])
        if b in fitted:
            rep_base, bands = fitted[b]
        else:
            rep_base = rep.fit(None) if base.effect_used is None else rep._fit(base.effect_used, (), None,
                                                                               x_from=base)
            r0, sd0, _ = rep.residuals(rep.phi_start, base.effect_used, base.params)
            bands = res.bands(rep.data.subset(rep.train), r0[rep.train], sd0[rep.train], rep.modes(rep.phi_start))
        f = rep.fit(effect, bands, start=rep_base)
        score = _score(rep_base.nll_train - f.nll_train, rep_base.nll_holdout - f.nll_holdout, penalty)
        return score, (rep_base, bands)

    def gaps_with_sea(self, before: tuple, fit: Fit) -> dict:
        """`fit`'s gaps in this Diagnoser's sea (each window's sea refitted through `fit`'s effects) against the tuned
        model's `before` = (r, sd, pred) in the sea it was tuned in, in the bins the effects move here: each model
        with its own sea, the effects and loading from the training windows only. gap_/sigma_error_ {train,
        holdout} _ {before, after}."""
        r1, sd1, p1 = self.residuals(fit.phi, fit.effect_used, fit.params)
        plain = self.model.spectra(fit.phi)
        with np.errstate(divide="ignore", invalid="ignore"):
            moved = self.data.mask & (np.abs(np.log(p1 / plain)) >= AFFECTED_CHANGE)
        b, a = self._gaps(*before, moved, moved), self._gaps(r1, sd1, p1, moved, moved)
        return {**{f"{k}_before": v for k, v in b.items()}, **{f"{k}_after": v for k, v in a.items()}}

    def _gaps(self, r, sd, pred, select, fallback) -> dict:
        """Gap and σ error per role in the `select` bins; a role none of whose bins an effect moves is scored in
        the `fallback` ones (the located misfit), not left without a figure."""
        out = {}
        w = trapezoid_weights(self.data.omega)
        for role, which in (("train", self.train), ("holdout", self.holdout)):
            scored = select if (select & which[:, None, None]).any() or not which.any() else fallback
            out[f"gap_{role}"] = res.gap(r, sd, scored & which[:, None, None])
            chans = scored.any(axis=(0, 2))
            m = self.data.mask & which[:, None, None] & chans[None, :, None]
            meas = np.sqrt((self.data.measured * m) @ w)
            model = np.sqrt((pred * m) @ w)
            ok = (meas > 0) & (model > 0)
            out[f"sigma_error_{role}"] = float(np.mean(np.abs(np.log(model[ok] / meas[ok])))) if ok.any() else np.nan
        return out


def shifted_wave(wave: np.ndarray, omega: np.ndarray, tp: np.ndarray, d_tp: float, d_dir_deg: float) -> np.ndarray:
    """S(ω, β)·Δβ per window (nw, nm, nb) with Tp moved by d_tp and the directions turned by d_dir_deg."""
    out = scaled_in_frequency(wave, omega, (tp + d_tp) / tp) if d_tp else wave
    return turned(out, np.full(wave.shape[0], float(d_dir_deg))) if d_dir_deg else out


def scaled_in_frequency(wave: np.ndarray, omega: np.ndarray, ratio: np.ndarray) -> np.ndarray:
    """Per window w, the sea with its Tp × ratio[w], self-similar: S'(ω) = r S(ω r) (linear in ω, 0 outside)."""
    nm = omega.size
    out = np.empty_like(wave)
    for w, r in enumerate(ratio):
        pos = omega * r
        j = np.clip(np.searchsorted(omega, pos), 1, nm - 1)
        t = ((pos - omega[j - 1]) / (omega[j] - omega[j - 1]))[:, None]
        inside = ((pos >= omega[0]) & (pos <= omega[-1]))[:, None]
        out[w] = r * inside * ((1 - t) * wave[w, j - 1] + t * wave[w, j])
    return out


def turned(wave: np.ndarray, d_dir_deg: np.ndarray) -> np.ndarray:
    """Per window w, the directions (equally spaced bins) turned by d_dir_deg[w], linear between the bins."""
    shift = np.asarray(d_dir_deg, dtype=float) * wave.shape[2] / 360.0
    out = np.empty_like(wave)
    for w, sh in enumerate(shift):
        k = int(np.floor(sh))
        f = sh - k
        out[w] = (1 - f) * np.roll(wave[w], k, axis=1) + f * np.roll(wave[w], k + 1, axis=1)
    return out


def out_of_sample_required(given: tuple[str, ...]) -> bool:
    """Whether a candidate over the effects `given` must also help out of sample to be named: once a vessel effect
    is in the model. Over none, or over a sea-side correction only, it is the first vessel effect and the condition
    stays a report (blind bank: osv_imu_lever_arm_042's 48 m lever arm, behind a swell named on a full hindcast,
    held out 16 nats better but was dropped for a held-out σ error 0.14 → 0.43 in the sea fitted without it)."""
    return any(name not in SEA_SIDE for name in given)


def helps_out_of_sample(gaps: dict) -> bool | None:
    """Whether the held-out gap and σ error both fall with a row's effects (issue 17); None without held-out
    windows."""
    if not np.isfinite(gaps["gap_holdout_before"]):
        return None
    return bool(gaps["gap_holdout_after"] < gaps["gap_holdout_before"]
                and gaps["sigma_error_holdout_after"] <= gaps["sigma_error_holdout_before"])


def _strong(gain_train: float, gain_holdout: float, bic_penalty: float) -> bool:
    """The naming rule's evidence test: the score over HOLDOUT_MIN, and the training gain over BIC's penalty where
    there are held-out windows."""
    return bool(_score(gain_train, gain_holdout, bic_penalty) > HOLDOUT_MIN
                and (gain_train > bic_penalty or not np.isfinite(gain_holdout)))


def _unseen_by_holdout(gain_train: float, gain_holdout: float, bic_penalty: float) -> bool:
    """A training gain over BIC's penalty that the held-out windows neither confirm nor contradict (a gain of 0 to
    HOLDOUT_MIN): they barely excite the effect, so a vessel-side one is left to the 2-fold cross-validation over all
    windows (`_cross_fold_gain`), which then decides alone. Blind bank: barge_moonpool_033's moonpool (223 nats in
    training, 1.0 held out, 60.8 across folds) and osv_anti_roll_tank_040's tank (32.1, 0.2, 5.0) named; the clean
    hulls' candidates of this kind fail across folds (−8.3 to 2.5)."""
    return bool(np.isfinite(gain_holdout) and 0.0 <= gain_holdout <= HOLDOUT_MIN and gain_train > bic_penalty)


def _score(gain_train: float, gain_holdout: float, bic_penalty: float) -> float:
    """A candidate's evidence: its held-out gain, or without held-out windows its training gain less BIC's."""
    return gain_holdout if np.isfinite(gain_holdout) else gain_train - bic_penalty


def _at_bound(effect, params: dict) -> list[str]:
    """Parameters pinned at the edge of their physical range (the data push beyond what the effect can be);
    a lower bound that switches the effect off (q = 0, a vanishing moonpool) does not count."""
    if effect is None:
        return []
    out = []
    for q in effect.parameters:
        span = q.upper - q.lower
        v = params[q.name]
        if v >= q.upper - 0.01 * span or (v <= q.lower + 0.01 * span and q.lower != q.initial):
            out.append(q.name)
    return out


def _band_selection(data: WindowSet, found) -> np.ndarray:
    """Bins × channels of the located misfit bands (all analysed bins when none): (nw, nc, nf)."""
    if not found:
        return data.mask.copy()
    sel = np.zeros(data.mask.shape[1:], dtype=bool)
    for b in found:
        sel |= b.channel_mask[:, None] & b.bins[None, :]
    return data.mask & sel[None]


def _may_follow(name: str, given: list[tuple], rows: list[dict]) -> bool:
    """Whether a candidate is fitted again after others were named: the sea gets one correction (a second sea-side
    effect on top of the first fits the first's excess, e.g. a 4 m, 20 s swell on a widened sea), and only a
    candidate whose first-step training gain beat its BIC penalty is refitted (the others showed no trace of
    their signature in the training windows; each further step costs a fit per candidate)."""
    if not given:
        return True
    if name in SEA_SIDE and any(g.name in SEA_SIDE for g, _ in given):
        return False
    first = next(r for r in rows if r["step"] == 1 and r["added"] == name)
    return first["gain_train"] > first["bic_penalty"]


def _members(fit: Fit) -> list[tuple]:
    """[(Effect, params)] of a fit: none, one, or a Compound's members in the order named."""
    effect = fit.effect_used
    if effect is None:
        return []
    return effect.split(fit.params) if isinstance(effect, Compound) else [(effect, fit.params)]


@dataclass
class _Context:
    """What the rows of one selection share: the model without effect, the tuned model's residuals (r, sd, pred),
    the located misfit, the training windows, and per fit its residuals, gaps and bands left."""

    base: Fit
    before: tuple
    located: np.ndarray
    train_data: WindowSet
    cache: dict = field(default_factory=dict)
    gaps: dict = field(default_factory=dict)
    left: dict = field(default_factory=dict)


@dataclass
class Diagnosis:
    rows: list[dict]
    winner: Fit | None
    base: Fit
    phi_before: np.ndarray
    bands_before: list
    bands_after: dict  # per candidate: the bands left on the training windows with it
    residual_before: tuple
    residual_after: tuple
    gaps: dict  # per fit: gap_/sigma_error_ {train, holdout} _ {before, after}, in the bins it affects
    parameter_names: tuple = ()

    @property
    def named(self) -> str | None:
        """The effects named, joined by '+' in the order named (None: none)."""
        return self.winner.effect if self.winner else None

    @property
    def named_effects(self) -> list[tuple]:
        """[(Effect, params)] of the final model, parameters refitted jointly."""
        return _members(self.winner) if self.winner else []

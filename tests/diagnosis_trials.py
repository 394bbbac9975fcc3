"""Hidden-effect trials for `seatune diagnose` (issue 8): windows simulated with an effect the tuning model
lacks (tests/hidden_effect_trials.py, the simulator's own mechanisms), then diagnosed from their Welch spectra."""

from __future__ import annotations

import numpy as np

from seatune.diagnosis.effects import library
from seatune.diagnosis.model import WindowSet, analysis_mask, long_crested_wave, welch_grid
from seatune.diagnosis.select import Diagnoser
from seatune.physics.spectra import jonswap
from seatune.tuning.interface import Parameter
from tests.hidden_effect_trials import simulate_windows

CHANNELS = ["roll", "pitch", "heave_acc_A", "heave_acc_C", "imu_fx", "imu_fy", "imu_fz"]
MOONPOOL_AT = (20.0, 0.0)
TRUTH = {"gmt_fs": 0.30, "r44": 8.0, "beta44": 0.05}
PARAMETERS = [Parameter("gmt_fs", 0.2, 0.15, 0.0, 0.8), Parameter("r44", 8.4, 0.6, 6.6, 10.2),
              Parameter("beta44", 0.07, 0.03, 0.01, 0.2)]
#: the hidden effects of the trials, by the simulator's parameters
EFFECTS = {
    "quadratic_roll_damping": {"kind": "quadratic_roll_damping", "q": 2.0},
    "moonpool": {"kind": "moonpool", "omega_p": 1.15, "zeta_p": 0.08, "area": 36.0, "x": MOONPOOL_AT[0],
                 "y": MOONPOOL_AT[1]},
    "anti_roll_tank": {"kind": "anti_roll_tank", "zeta_t": 0.1, "mu": 0.08},
    "imu_lever_arm": {"kind": "imu_lever_arm", "dx": -4.0, "dy": 2.0, "dz": -3.0},
}
SEGMENT_S = 256.0
BAND = (0.25, 1.6)  # rad/s analysed


def sea_states(rng, n: int) -> list[dict]:
    # on the hydro database's 15° directions: between them the generator blends 6-DOF RAOs and the model blends
    # channel power, two different (both approximate) interpolations this test is not about
    beta = rng.choice(np.arange(30.0, 166.0, 15.0), n, replace=False)
    return [{"hs": float(h), "tp": float(t), "beta_deg": float(b)}
            for h, t, b in zip(rng.uniform(1.2, 4.0, n), rng.uniform(7.0, 12.0, n), beta, strict=True)]


def window_set(vessel, windows, states, roles, hs_error, tp_error=None, beta_error=None) -> WindowSet:
    d = 2 * np.pi / SEGMENT_S
    omega = windows[0]["omega"]
    keep = (omega >= BAND[0] - 0.5 * d) & (omega <= BAND[1] + 0.5 * d)
    bins = omega[keep]
    fine, index, kernel = welch_grid(bins, SEGMENT_S)
    measured = np.stack([w["S"][:, keep] for w in windows])
    hs = np.array([s["hs"] for s in states]) * hs_error  # what the hindcast says
    tp = np.array([s["tp"] for s in states]) + (0.0 if tp_error is None else tp_error)
    beta = np.array([s["beta_deg"] for s in states]) + (0.0 if beta_error is None else beta_error)
    wave = long_crested_wave(fine, np.stack([jonswap(fine, h, t, 3.3) for h, t in zip(hs, tp, strict=True)]), beta,
                             vessel.db.wave_direction)
    dof = np.array([[w["dof"]] * len(CHANNELS) for w in windows])
    return WindowSet([str(i) for i in range(len(windows))], np.asarray(roles), bins, fine, index, kernel, CHANNELS,
                     measured, dof, analysis_mask(measured, bins, *BAND), wave, hs, tp, beta, np.zeros(len(hs)),
                     np.zeros(len(hs)))


def noise_free_set(vessel, seed: int, n_windows: int = 6) -> tuple[WindowSet, np.ndarray]:
    """Windows of `seed`'s seas (two trained, one held out, in turn) and the true loading vector; the caller sets
    `measured` to a model's expected spectra (no sampling noise)."""
    rng = np.random.default_rng(seed)
    states = sea_states(rng, n_windows)
    windows = simulate_windows(vessel, TRUTH, None, states, CHANNELS, 900.0, rng)
    data = window_set(vessel, windows, states, ["train", "train", "holdout"] * (n_windows // 3), np.ones(n_windows))
    return data, np.array([TRUTH[p.name] for p in PARAMETERS])


def trial(vessel, effect: str | tuple[str, ...] | None, seed: int, n_windows: int = 9, duration_s: float = 1800.0,
          hs_rel_std: float = 0.05, tp_std_s: float = 0.0, dir_std_deg: float = 0.0, null=None, effects=None,
          max_named: int = 1, swell: dict | None = None, moonpool_position=MOONPOOL_AT):
    """(Diagnosis, truth φ) of one trial; every third window is held out. The model's sea state is the truth with
    hindcast errors: Hs × e^N(0, hs_rel_std), Tp + N(0, tp_std_s), β + N(0, dir_std_deg). `effect`: one name or
    a tuple of names (a compound trial). `swell` {"hs", "tp", "beta_deg"}: a swell in every window that the model's
    sea lacks (the headings are all 0: one from D arrives at β = −D − 180°, DESIGN §3). `moonpool_position`: where
    diagnose is told the moonpool is (None: searched)."""
    rng = np.random.default_rng(seed)
    states = [{**s, "swell": swell} if swell else s for s in sea_states(rng, n_windows)]
    hidden = None if effect is None else [EFFECTS[e] for e in ((effect,) if isinstance(effect, str) else effect)]
    windows = simulate_windows(vessel, TRUTH, hidden, states, CHANNELS, duration_s, rng,
                               welch_segment_s=SEGMENT_S)
    roles = ["holdout" if i % 3 == 2 else "train" for i in range(n_windows)]
    data = window_set(vessel, windows, states, roles, np.exp(rng.normal(0.0, hs_rel_std, n_windows)),
                      rng.normal(0.0, tp_std_s, n_windows), rng.normal(0.0, dir_std_deg, n_windows))
    start = np.array([p.prior_mean for p in PARAMETERS])
    diag = Diagnoser(vessel, PARAMETERS, data, start, hs_rel_std=hs_rel_std, tp_std_s=tp_std_s,
                     dir_std_deg=dir_std_deg, null=null)
    truth = np.array([TRUTH[p.name] for p in PARAMETERS])
    diagnosis = diag.run(library(effects, moonpool_position=moonpool_position), phi_before="refit",
                         max_named=max_named)
    return diagnosis, truth

"""Tuning validations on the sample vessel with time-domain simulated trials (tests/synthetic_trials.py).

* Han A6 base case (seed digest A5–A7 §3): β44 and XCG with the sea state in the UKF state, the 20 true and
  acquired sea states of A6 Table 8, Table 5 settings. Done when β44 is within 0.005 and XCG within 1.0 m of
  the truth and the Hs variance falls by ≥ 30 % on average (A6 Table 9: 49.9 %).
* Han A2 validation (seed digest A1–A2 §5.5, Tables 17–19): DBI with GMT correction, β44, r55 and XCG over
  6 random sea states per seed. A2's mean errors over 120 runs: GMT +0.03 m, β44 +0.001, r55 +0.58 m,
  XCG −0.2 m; the truth must lie inside the posterior's 2σ interval in ≥ 85 % of parameter-seed pairs.

Han's Vessel A (Lpp ≈ 120 m) values are moved onto the sample vessel (Lpp 96 m) as offsets from its
loading: the same prior STDs and the same truth − prior differences.
"""

from __future__ import annotations

import numpy as np
import pytest

from seatune.tuning.dbi import DBI
from seatune.tuning.forward import ChannelPower
from seatune.tuning.interface import Parameter, SeaState
from seatune.tuning.ukf import UKF
from tests.synthetic_trials import HEAVE_CHANNELS, long_crested_model, measured_sigmas, observation

NAMES = tuple(f"{c}:sigma" for c in HEAVE_CHANNELS)
F_LP = 0.2  # Hz (A2 Table 17, A6 Table 4)

# A6 Table 8 (τ = 44): true Hs*, Tp*, β* and acquired H̄s, T̄p, β̄ (β going-to, 180° = head sea, as DESIGN §3).
A6_SEA_STATES = np.array([
    [3.5, 14.6, 256.0, 3.3, 15.3, 257.9], [1.3, 7.1, 26.1, 1.1, 7.1, 22.1], [3.2, 11.9, 317.7, 3.5, 12.2, 323.5],
    [2.1, 18.1, 261.4, 1.7, 18.0, 261.5], [2.1, 8.9, 300.0, 2.2, 9.1, 290.5], [2.8, 15.0, 255.7, 2.8, 14.1, 251.4],
    [2.2, 17.9, 251.1, 2.3, 18.0, 250.8], [2.2, 7.2, 334.8, 2.4, 6.9, 341.0], [2.5, 13.4, 317.4, 3.0, 14.1, 314.7],
    [3.1, 7.4, 34.2, 3.6, 7.8, 32.5], [3.9, 7.6, 164.3, 4.3, 7.5, 156.6], [2.4, 6.6, 177.4, 2.7, 6.2, 183.5],
    [2.3, 8.0, 39.2, 2.3, 7.6, 27.9], [1.3, 11.8, 55.3, 1.4, 12.1, 56.4], [1.7, 16.9, 354.3, 1.6, 16.6, 354.1],
    [3.9, 19.9, 97.8, 4.0, 20.7, 99.2], [3.8, 17.1, 323.0, 4.3, 16.5, 326.0], [3.6, 10.7, 59.1, 3.6, 10.3, 64.3],
    [2.9, 12.7, 47.6, 2.9, 12.2, 47.7], [1.6, 5.9, 114.2, 1.5, 5.2, 105.5]])
A6_TRUTH = {"beta44": 0.04, "xcg": 1.0}  # A6: β44* 4 %, XCG* 2 m forward of the prior's 59.4 m
A6_PARAMETERS = [Parameter("beta44", 0.07, 0.035, 0.0, 0.3),  # A6 Table 5: φ0 = [7 %, 59.4 m], P_φ0 = diag(0.035², 4²)
                 Parameter("xcg", -1.0, 4.0, -13.0, 11.0)]
A6_Q = {"beta44": 0.005, "xcg": 0.1**0.5, "hs": 0.05, "tp": 0.1, "beta_deg": 0.5}  # A6 Table 5 (Q as STDs)


def _a6_windows(vessel, power, seed):
    rng = np.random.default_rng(seed)
    for k, (hs, tp, beta, hs_a, tp_a, beta_a) in enumerate(A6_SEA_STATES):
        sigma = measured_sigmas(vessel, A6_TRUTH, HEAVE_CHANNELS, hs, tp, beta, 1800.0, F_LP, rng)
        model = long_crested_model(power, NAMES, hs_a, tp_a, beta_a, F_LP)
        obs = observation(str(k + 1), NAMES, sigma, model, np.array([0.07, -1.0]), 1800.0)
        yield model, obs, np.array([hs_a, tp_a, beta_a]), np.array([0.1 * hs_a, 0.5, 5.0])  # A6 Table 2


@pytest.fixture(scope="module")
def a6_power(sample_model):
    return ChannelPower(sample_model, ["beta44", "xcg"], HEAVE_CHANNELS)


def test_a6_base_case_ukf(sample_model, a6_power):
    ukf = UKF(A6_PARAMETERS, process_noise=A6_Q, r_fraction=0.02)  # α 0.01, β 2, κ = 3 − N (A6 Table 5)
    reduction = []
    for model, obs, mean, std in _a6_windows(sample_model, a6_power, seed=44):
        sea = SeaState(("hs", "tp", "beta_deg"), mean, np.diag(std**2), mean[None, :], np.ones(1))
        post = ukf.update(model, obs, sea)
        reduction.append(1.0 - ukf.theta_cov_[0, 0] / ukf.theta_prior_cov_[0, 0])  # A6 eq. 19
    beta44, xcg = post.mean
    print(f"A6 base case, UKF: β44 {beta44:.4f} ± {post.std[0]:.4f} (truth 0.04), XCG {xcg:+.2f} ± {post.std[1]:.2f} m "
          f"(truth +1.0), mean Hs variance reduction {100 * np.mean(reduction):.1f} % (A6: 49.9 %)")
    assert abs(beta44 - A6_TRUTH["beta44"]) <= 0.005
    assert abs(xcg - A6_TRUTH["xcg"]) <= 1.0
    assert np.mean(reduction) >= 0.30


def test_a6_base_case_dbi(sample_model, a6_power):
    # The same trial through the other backend: 27 → 9 sea-state hypotheses (Tp × β) with Hs marginalised,
    # A6's 7 × 5 database (A6 Table 6) and the Gaussian likelihood on cubic-interpolated σ.
    from seatune.pipeline.tune import sea_state

    dbi = DBI(A6_PARAMETERS, database_points=(7, 5), pmf_points=60, interpolation="cubic", model_error=0.02)
    for model, obs, mean, std in _a6_windows(sample_model, a6_power, seed=44):
        post = dbi.update(model, obs, sea_state(mean, std))
    print(f"A6 base case, DBI: β44 {post.mean[0]:.4f} ± {post.std[0]:.4f}, XCG {post.mean[1]:+.2f} ± {post.std[1]:.2f}")
    assert abs(post.mean[0] - A6_TRUTH["beta44"]) <= 0.005
    assert abs(post.mean[1] - A6_TRUTH["xcg"]) <= 1.0


# ------------------------------------------------------------------------------------------- A2 validation
# A2 Table 18 on the sample vessel: (prior mean, prior STD, truth). GMT 0.5 → 0.4 m is a free-surface reduction
# 0.1 m larger; r55 32.5 → 30.55 m; XCG 59.4 → 61.4 m.
A2_PARAMETERS = [Parameter("gmt_fs", 0.2, 0.015**0.5, -1.0, 1.5), Parameter("beta44", 0.07, 0.02, 0.0, 0.5),
                 Parameter("r55", 24.0, 1.0, 15.0, 35.0), Parameter("xcg", -1.0, 1.1, -10.0, 10.0)]
A2_TRUTH = {"gmt_fs": 0.3, "beta44": 0.04, "r55": 22.05, "xcg": 1.0}
A2_MEAN_ERROR = np.array([0.03, 0.001, 0.58, 0.2])  # |A2 Table 19 tuned mean − truth|, rounded in the paper


def a2_validation(vessel, power, seeds, likelihood):
    """Posterior means and STDs after 6 random A2 sea states (Table 17) per seed; perfect wave knowledge (A2)."""
    means, stds = [], []
    for seed in seeds:
        rng = np.random.default_rng(1000 + seed)
        dbi = DBI(A2_PARAMETERS, database_points=(6, 7, 7, 5), pmf_points=(40, 50, 30, 30), likelihood=likelihood,
                  power=0.4, screening_alpha=0.05, interpolation="cubic" if likelihood == "gaussian" else "linear")
        for k in range(6):
            hs, tp, beta = rng.uniform(1.0, 3.0), 1.4049 * rng.uniform(4.0, 15.0), 15.0 * rng.integers(0, 13)
            sigma = measured_sigmas(vessel, A2_TRUTH, HEAVE_CHANNELS, hs, tp, beta, 3600.0, F_LP, rng)
            model = long_crested_model(power, NAMES, hs, tp, beta, F_LP)
            obs = observation(f"{seed}-{k}", NAMES, sigma, model, np.array([p.prior_mean for p in A2_PARAMETERS]),
                              3600.0)
            post = dbi.update(model, obs, SeaState.certain(("hs", "tp", "beta_deg"), (hs, tp, beta)))
        means.append(post.mean)
        stds.append(post.std)
    return np.array(means), np.array(stds)


def _a2_summary(means, stds, label):
    truth = np.array(list(A2_TRUTH.values()))
    bias = means.mean(axis=0) - truth
    inside = np.abs(means - truth) <= 2 * stds
    print(f"A2 validation, {label}, {len(means)} seeds: mean error {np.round(bias, 4)} (A2: +0.03, +0.001, +0.58, "
          f"-0.2), mean |error| {np.round(np.abs(means - truth).mean(axis=0), 4)}, truth in 2σ "
          f"{np.round(inside.mean(axis=0), 2)} = {100 * inside.mean():.0f} % of pairs, "
          f"mean STD {np.round(stds.mean(0), 4)}")
    return bias, inside


@pytest.fixture(scope="module")
def a2_power(sample_model):
    return ChannelPower(sample_model, [p.name for p in A2_PARAMETERS], HEAVE_CHANNELS)


def test_a2_validation_few_seeds(sample_model, a2_power):
    means, stds = a2_validation(sample_model, a2_power, range(4), "gaussian")
    bias, inside = _a2_summary(means, stds, "gaussian")
    assert inside.mean() >= 0.85
    assert np.all(np.abs(bias) <= 2 * A2_MEAN_ERROR + 0.5 * stds.mean(axis=0))  # 4 seeds: a loose bound


@pytest.mark.slow
def test_a2_validation_twenty_seeds(sample_model, a2_power):
    """The issue's acceptance (make test-slow): 20 seeds, the default Gaussian likelihood; IDW reported."""
    means, stds = a2_validation(sample_model, a2_power, range(20), "gaussian")
    bias, inside = _a2_summary(means, stds, "gaussian")
    idw_means, idw_stds = a2_validation(sample_model, a2_power, range(20), "idw")
    _a2_summary(idw_means, idw_stds, "idw p=0.4")
    assert inside.mean() >= 0.85
    # At least as good as A2: not worse by more than the paper's rounding of its tuned means (0.43, 0.041, 31.13,
    # 61.2) plus two standard errors of our own 20-seed mean.
    rounding = np.array([0.005, 0.0005, 0.005, 0.05])
    standard_error = means.std(axis=0, ddof=1) / np.sqrt(len(means))
    assert np.all(np.abs(bias) <= A2_MEAN_ERROR + rounding + 2 * standard_error)

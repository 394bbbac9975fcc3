"""The simulator against independent references: the model's spectral σ (χ² sampling bound), the
kinematics of the IMU (integrated rates vs quaternion, gravity at rest) and scenario validation."""

import subprocess
import sys

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from seatune.physics.response import channel_spectra, trapezoid_weights
from seatune.physics.spectra import SpectrumPartition, directional_spectrum
from seatune.simulate.scenario import simulate
from seatune.simulate.scenario_yaml import ScenarioSpec
from tests.conftest import ROOT

SEA = {"wind_sea": {"hs": 2.0, "tp": 8.0, "dir_from_deg": 230.0, "spreading_param": 4.0},
       "swell": {"hs": 1.2, "tp": 12.0, "dir_from_deg": 275.0, "gamma": 5.0, "spreading_param": 25.0}}


QUIET_IMU = {"point": [12.0, 0.0, 15.0], "angle_noise_std": 0, "gyro_noise_density": 0, "accel_noise_density": 0}
CALM = {"hour": 0, "wind_sea": {"hs": 0.0, "tp": 8.0, "dir_from_deg": 0.0}}


def scenario(seed, heading=37.0, duration=3600.0, **extra):
    data = {
        "name": "stationary", "vessel": "../vessels/sample_osv.yaml", "seed": seed,
        "start_time": "2026-03-14T06:00:00Z", "start_position": [61.2, 3.4],
        "truth_loading": {"zcg": 6.7, "gmt_fs": 0.3, "beta44": 0.05},
        "segments": [{"kind": "drift", "duration": duration, "heading_deg": heading}],
        "sea_states": [{"hour": 0, **SEA}],
        "sensors": {"sample_rate_hz": 10, "imu": {"point": [12.0, 0.0, 15.0]}},
    }
    data.update(extra)
    return ScenarioSpec.model_validate(data)


def effective_dof(omega, S, T):
    """ν of the sample variance of a Gaussian record of length T with one-sided S(ω):
    Var(σ̂²) = (2π/T) ∫ S² dω  →  ν = 2 m0² / Var = T m0² / (π ∫ S² dω)."""
    w = trapezoid_weights(omega)
    return T * (S @ w) ** 2 / (np.pi * (S**2 @ w))


def test_sample_sigma_matches_spectral_sigma_over_20_seeds(sample_model):
    db = sample_model.db
    seeds = range(20)
    spec0 = scenario(0)
    truth = sample_model.loading(**spec0.truth_loading)
    parts = [SpectrumPartition(hs=2.0, tp=8.0, dir_from_deg=230.0, spreading_param=4.0),
             SpectrumPartition(hs=1.2, tp=12.0, dir_from_deg=275.0, gamma=5.0, spreading_param=25.0)]
    S = directional_spectrum(db.omega, db.wave_direction, parts, heading_deg=37.0)
    spectra = channel_spectra(db, truth, sample_model.channels, S)[0]  # (nch, nw)
    var_model = spectra @ trapezoid_weights(db.omega)
    nu = effective_dof(db.omega, spectra, 3600.0)
    ratios = []
    for seed in seeds:
        trial = simulate(scenario(seed), sample_model)
        var = np.array([np.var(trial.channels[ch.name]) for ch in sample_model.channels])
        ratios.append(var / var_model)
    ratios = np.array(ratios)  # (seeds, nch)
    # each record: σ̂²/σ² ~ χ²_ν/ν; two-sided 99.99 % bound per channel and seed
    lo, hi = chi2.ppf(5e-5, nu) / nu, chi2.ppf(1 - 5e-5, nu) / nu
    assert np.all((ratios > lo) & (ratios < hi)), (ratios.min(0), ratios.max(0), lo, hi)
    # pooled over 20 independent seeds: mean ratio ~ χ²_{20ν}/(20ν); two-sided 99.9 % bound
    n = len(seeds)
    lo, hi = chi2.ppf(5e-4, n * nu) / (n * nu), chi2.ppf(1 - 5e-4, n * nu) / (n * nu)
    mean = ratios.mean(0)
    assert np.all((mean > lo) & (mean < hi)), (mean, lo, hi)


@pytest.fixture(scope="module")
def short_trial(sample_model):
    return simulate(scenario(3, duration=900.0), sample_model)


def test_imu_rates_integrate_to_the_quaternion(short_trial):
    """Integrating the body rates (exact exponential map per step) reproduces the attitude."""
    imu = short_trial.streams["/imu/data"]
    clean = imu  # noise is white and small; compare over 60 s
    q = Rotation.from_quat(clean[["qx", "qy", "qz", "qw"]].to_numpy()[:600])
    w = clean[["wx", "wy", "wz"]].to_numpy()[:600]
    dt = 0.1
    R = q[0]
    err = []
    for k in range(599):
        R = R * Rotation.from_rotvec(0.5 * (w[k] + w[k + 1]) * dt)  # body-frame rates: right multiply
        err.append((R.inv() * q[k + 1]).magnitude())
    assert max(err) < 5e-3  # rad after 60 s, including the sensor noise
    assert np.median(err) < 2e-3


def test_imu_clean_rates_are_exact_derivative_of_attitude(sample_model):
    sensors = {"sample_rate_hz": 20, "quantize": False, "imu": QUIET_IMU}
    trial = simulate(scenario(4, duration=600.0, sensors=sensors), sample_model)
    imu = trial.streams["/imu/data"]
    q = Rotation.from_quat(imu[["qx", "qy", "qz", "qw"]].to_numpy())
    w = imu[["wx", "wy", "wz"]].to_numpy()
    dt = 1 / 20
    numeric = (q[:-2].inv() * q[2:]).as_rotvec() / (2 * dt)  # central difference in the body frame
    assert np.abs(numeric - w[1:-1]).max() < 1e-3 * np.abs(w).max() + 1e-6


def test_specific_force_at_rest_is_gravity(sample_model):
    sensors = {"sample_rate_hz": 10, "quantize": False, "imu": QUIET_IMU}
    trial = simulate(scenario(5, duration=120.0, sea_states=[CALM], sensors=sensors), sample_model)
    f = trial.streams["/imu/data"][["ax", "ay", "az"]].to_numpy()
    assert np.allclose(f, [0.0, 0.0, sample_model.db.g], atol=1e-9)
    assert np.allclose(np.linalg.norm(f, axis=1), 9.81, rtol=1e-12)


def test_imu_misalignment_effect_rotates_the_sensor(sample_model):
    sensors = {"sample_rate_hz": 10, "quantize": False, "imu": QUIET_IMU}
    trial = simulate(scenario(6, duration=60.0, sea_states=[CALM], sensors=sensors,
                              effects=[{"kind": "imu_misalignment", "roll_deg": 1.0}]), sample_model)
    f = trial.streams["/imu/data"][["ax", "ay", "az"]].to_numpy()
    # an IMU rolled by +1° sees gravity tilted: f_y = g sin(1°) (Rᵀ of a roll about x)
    assert f[0, 1] == pytest.approx(9.81 * np.sin(np.radians(1.0)), rel=1e-9)


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "seatune", *map(str, args)], capture_output=True, text=True)


@pytest.mark.parametrize("mutate, key", [
    (lambda d: d.update(vessel="../vessels/no_such_vessel.yaml"), "vessel"),
    (lambda d: d["segments"][0].update(duration=-60), "segments.0.duration"),
    (lambda d: d["segments"].append({"kind": "drift", "duration": 600, "heading_deg": 10, "start": 100}),
     "segments.7.start"),
    (lambda d: d.update(wave_height=3), "wave_height"),
])
def test_bad_scenario_exits_2_with_one_line(tmp_path, mutate, key):
    data = yaml.safe_load((ROOT / "configs/scenarios/sample_trial.yaml").read_text())
    data["vessel"] = str(ROOT / "configs/vessels/sample_osv.yaml") if "no_such" not in key else data["vessel"]
    mutate(data)
    (tmp_path / "vessels").mkdir()
    path = tmp_path / "scenarios" / "bad.yaml"
    path.parent.mkdir()
    path.write_text(yaml.safe_dump(data))
    res = run_cli("simulate", path, "--out", tmp_path / "out")
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and key in lines[0], res.stderr
    assert not (tmp_path / "out").exists()

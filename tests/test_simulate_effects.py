"""Hidden-effect mechanisms of the simulator against independent references: the plain 6-DOF RAOs in the
vanishing-effect limit, SDOF analytics (base-excited column, Den Hartog absorber), stochastic
linearisation of quadratic roll damping and rigid-body kinematics of an IMU lever arm."""

import numpy as np
import pytest
from scipy.signal import argrelextrema

from seatune.physics import imu as imu_model
from seatune.physics.response import motion_raos_at
from seatune.simulate.effects import (
    EFFECTS,
    EffectContext,
    RollConstants,
    anti_roll_tank_dof,
    augmented_raos,
    augmented_solve,
    loading_draft,
    moonpool_dof,
    quadratic_roll_correction,
    roll_inertia,
)
from seatune.simulate.scenario import simulate
from seatune.simulate.scenario_yaml import EffectSpec, ScenarioSpec, load_scenario
from tests.conftest import ROOT
from tests.hidden_effect_trials import simulate_windows, welch_dof

TRUTH = {"gmt_fs": 0.35, "r44": 8.0, "beta44": 0.05}
BEAM = 6  # β = 90° on the database grid


@pytest.fixture(scope="module")
def truth(sample_model):
    return sample_model.loading(**TRUTH)


def test_moonpool_with_vanishing_area_is_the_plain_hull(sample_model, truth):
    db = sample_model.db
    om = np.linspace(0.2, 2.0, 301)
    dof = moonpool_dof(om, db.wave_direction, loading_draft(db, truth), db.rho, db.g, area=1e-6)
    np.testing.assert_allclose(augmented_raos(db, truth, om, [dof])[0], motion_raos_at(db, truth, om),
                               rtol=1e-6, atol=1e-9)


def test_moonpool_column_on_a_held_hull_is_a_base_excited_sdof(sample_model):
    """ζ/η_keel = c̃/(c − ω²m − iωb): peak ≈ 1/(2ζ_p) near ω_p, √(1+4ζ²)/(2ζ) exactly at ω_p."""
    db = sample_model.db
    wp, zp, d, x, y = 1.0, 0.08, 6.0, 20.0, 3.0
    om = np.r_[np.linspace(0.5, 1.5, 4001), wp]
    beta = np.array([0.3, np.pi])
    dof = moonpool_dof(om, beta, d, db.rho, db.g, omega_p=wp, zeta_p=zp, area=50.0, x=x, y=y)
    held = np.broadcast_to(1e20 * np.eye(6), (om.size, 6, 6))
    xi, col = augmented_solve(held, np.zeros((om.size, 2, 6), complex), [dof])
    assert np.abs(xi).max() < 1e-12
    k = om**2 / db.g
    eta_keel = np.exp(-k * d)[:, None] * np.exp(1j * k[:, None] * (x * np.cos(beta) + y * np.sin(beta)))
    ratio = np.abs(col[..., 0] / eta_keel)
    np.testing.assert_allclose(ratio[-1], np.sqrt(1 + 4 * zp**2) / (2 * zp), rtol=1e-9)
    peak = ratio[:-1, 0].argmax()
    assert abs(om[peak] - wp) < 0.01 * wp
    np.testing.assert_allclose(ratio[peak, 0], 1 / (2 * zp), rtol=0.03)
    np.testing.assert_allclose(ratio[:, 0], ratio[:, 1], rtol=1e-12)  # |ζ| independent of the direction


def test_anti_roll_tank_with_vanishing_mass_is_the_plain_hull(sample_model, truth):
    db = sample_model.db
    om = np.linspace(0.2, 2.0, 301)
    inertia, wn = roll_inertia(db, truth)
    dof = anti_roll_tank_dof(om, db.wave_direction.size, inertia, wn, mu=1e-10)
    np.testing.assert_allclose(augmented_raos(db, truth, om, [dof])[0], motion_raos_at(db, truth, om),
                               rtol=1e-6, atol=1e-9)


def test_anti_roll_tank_halves_the_beam_sea_roll_peak_and_splits_it(sample_model, truth):
    """Den Hartog: a tuned absorber (μ = 0.03, ω_t = ω_n) replaces the roll peak by two lower ones around ω_t."""
    db = sample_model.db
    om = np.linspace(0.3, 0.8, 2001)
    inertia, wn = roll_inertia(db, truth)
    bare = np.abs(motion_raos_at(db, truth, om)[:, BEAM, 3])
    assert abs(om[bare.argmax()] - wn) < 0.02 * wn  # the bare roll peak is at ω_n
    tank = np.abs(augmented_raos(db, truth, om, [EFFECTS["anti_roll_tank"].extra_dof(db, truth, om, {})])[0]
                  [:, BEAM, 3])
    assert tank.max() < 0.6 * bare.max()
    # ζ_t = 0.15 is above Den Hartog's optimum √(3μ/(8(1+μ)³)) ≈ 0.10: the peaks merge; below it they split
    light = np.abs(augmented_raos(db, truth, om, [anti_roll_tank_dof(om, db.wave_direction.size, inertia, wn,
                                                                     zeta_t=0.05, mu=0.03)])[0][:, BEAM, 3])
    peaks, dips = om[argrelextrema(light, np.greater)[0]], om[argrelextrema(light, np.less)[0]]
    assert len(peaks) == 2 and peaks[0] < wn < peaks[1]
    assert len(dips) == 1 and abs(dips[0] - wn) < 0.01 * wn
    assert light.max() < 0.7 * bare.max()


def test_quadratic_roll_correction_vanishes_without_q():
    rc = RollConstants(inertia=8e8, damping=4e7, stiffness=2e8, omega_n=0.5)
    u = np.random.default_rng(0).normal(0.0, 0.05, 5000)
    for part in quadratic_roll_correction(u, 0.5, rc, 0.0):
        assert np.all(part == 0.0)


def test_quadratic_roll_matches_stochastic_linearisation():
    """SDOF roll I φ̈ + B φ̇ + C φ + qI|φ̇|φ̇ = M(t), white-ish M: φ_lin + δφ from the RK4 correction vs the
    linear SDOF with b_eq = B + √(8/π) σ_φ̇ qI (seed_002 eq. 2.19, Kaplan), σ_φ̇ solved self-consistently."""
    rc = RollConstants(inertia=8e8, damping=4.1e7, stiffness=2e8, omega_n=0.5)
    q, dt, n = 1.5, 0.25, 2**17
    rng = np.random.default_rng(7)
    om = 2 * np.pi * np.fft.rfftfreq(n, dt)
    band = (om > 0.15) & (om < 1.2)
    d_om = om[1]
    s_m = np.where(band, (0.1 * rc.stiffness) ** 2 * 0.2, 0.0)  # one-sided moment spectrum [(N m)²·s/rad]

    def h(b):
        return 1.0 / (rc.stiffness - rc.inertia * om**2 - 1j * om * b)

    a = np.sqrt(s_m * d_om) * (rng.normal(size=om.size) + 1j * rng.normal(size=om.size))
    # x(t) = Re Σ X_k e^{−iω_k t}: irfft of the conjugate coefficients on the periodic grid
    phi_lin = np.fft.irfft(np.conj(a * h(rc.damping)), n) * n / 2
    phid_lin = np.fft.irfft(np.conj(-1j * om * a * h(rc.damping)), n) * n / 2
    sig_lin = np.sqrt(np.sum(s_m * d_om * np.abs(h(rc.damping)) ** 2))
    assert abs(phi_lin.std() / sig_lin - 1) < 0.05  # the synthesis itself
    dphi, _, _ = quadratic_roll_correction(phid_lin, dt, rc, q)
    sim = (phi_lin + dphi)[n // 8:].std()
    b = rc.damping
    for _ in range(200):
        sd = np.sqrt(np.sum(s_m * d_om * om**2 * np.abs(h(b)) ** 2))
        b = rc.damping + np.sqrt(8 / np.pi) * sd * q * rc.inertia
    ref = np.sqrt(np.sum(s_m * d_om * np.abs(h(b)) ** 2))
    assert sim < 0.8 * sig_lin  # the nonlinear damping matters here
    assert abs(sim / ref - 1) < 0.10, (sim, ref, sig_lin)


def test_quadratic_roll_reduction_grows_with_wave_height(sample_model):
    seas = [{"hs": hs, "tp": 12.0, "beta_deg": 90.0} for hs in (1.0, 4.0) for _ in range(3)]
    lin = simulate_windows(sample_model, TRUTH, None, seas, ["roll"], 1200.0, np.random.default_rng(3), snr=1e12)
    nl = simulate_windows(sample_model, TRUTH, {"kind": "quadratic_roll_damping"}, seas, ["roll"], 1200.0,
                          np.random.default_rng(3), snr=1e12)
    red = np.array([1 - b["sigma"][0] / a["sigma"][0] for a, b in zip(lin, nl, strict=True)]).reshape(2, 3)
    assert np.all(red > 0.02)
    assert red[1].min() > red[0].max(), red


def test_imu_lever_arm_hook_is_rigid_body_kinematics(sample_model):
    """Pure roll φ = φ0 sin ωt, IMU raised by dz: Δf_y = −dz φ̈ = dz ω² φ (to first order in φ)."""
    t = np.arange(0, 60, 0.1)
    w, phi0, dz = 0.6, 1e-3, 2.5
    xi = {k: np.zeros((t.size, 6)) for k in range(3)}
    xi[0][:, 3], xi[1][:, 3], xi[2][:, 3] = phi0 * np.sin(w * t), phi0 * w * np.cos(w * t), -phi0 * w**2 * np.sin(w * t)

    class Kin:
        heading_deg = np.full(t.size, 30.0)

    rot = imu_model.attitude(xi[0][:, 3], xi[0][:, 4], imu_model.compass_to_enu_yaw(Kin.heading_deg))
    ctx = EffectContext(t=t, fs=10.0, rng=None, model=sample_model, draft=6.0, xi=xi, kin=Kin(), channels={},
                        imu={"rotation": rot, "rates": np.zeros((t.size, 3)), "force": np.zeros((t.size, 3))})
    EFFECTS["imu_lever_arm"].imu(ctx, EffectSpec.model_validate({"kind": "imu_lever_arm", "dz": dz}))
    df = ctx.imu["force"]
    np.testing.assert_allclose(df[:, 1], dz * w**2 * xi[0][:, 3], atol=2 * phi0 * dz * w**2 * phi0)
    assert np.abs(df[:, [0, 2]]).max() < 2 * phi0 * dz * w**2 * phi0


def test_trial_generator_lever_arm_and_spectra(sample_model):
    """Generator: f_y at the shifted point differs by −dz φ̈ (rigid body); Welch S integrates to σ²."""
    seas = [{"hs": 2.0, "tp": 10.0, "beta_deg": 75.0}]
    names = ["roll", "imu_fy"]
    kw = {"dt": 0.05, "welch_segment_s": 50.0, "snr": 1e14, "series": True}
    base = simulate_windows(sample_model, TRUTH, None, seas, names, 200.0, np.random.default_rng(1), **kw)[0]
    arm = simulate_windows(sample_model, TRUTH, {"kind": "imu_lever_arm", "dz": 3.0}, seas, names, 200.0,
                           np.random.default_rng(1), **kw)[0]
    roll = base["x"][:, 0]
    acc = (roll[2:] - 2 * roll[1:-1] + roll[:-2]) / 0.05**2
    diff = arm["x"][1:-1, 1] - base["x"][1:-1, 1]
    np.testing.assert_allclose(diff, -3.0 * acc, atol=0.01 * np.abs(acc).max() * 3.0)
    long = simulate_windows(sample_model, TRUTH, None, seas, names, 3600.0, np.random.default_rng(2))[0]
    var = long["S"] @ np.gradient(long["omega"])
    np.testing.assert_allclose(var, long["sigma"] ** 2, rtol=0.05)
    assert abs(welch_dof(2400, 512) - 2 * 8 / (1 + 2 * 0.1667**2 * (1 - 1 / 8))) < 0.01


def _short_sample_scenario(effects):
    spec, _ = load_scenario(ROOT / "configs" / "scenarios" / "sample_trial.yaml")
    data = spec.model_dump()
    data.update(segments=[{"kind": "drift", "duration": 900.0, "heading_deg": 185.0, "speed": 0.1,
                           "course_deg": 45.0}], sea_states=data["sea_states"][:1], effects=effects,
                defects={"duplicate_stamps": 0, "out_of_order": 0, "gaps": []})
    return ScenarioSpec.model_validate(data)


@pytest.mark.parametrize("effect", [{"kind": "anti_roll_tank"}, {"kind": "quadratic_roll_damping"},
                                    {"kind": "moonpool"}, {"kind": "imu_lever_arm", "dz": 2.0}])
def test_simulate_runs_with_each_effect(sample_model, effect):
    plain = simulate(_short_sample_scenario([]), sample_model)
    trial = simulate(_short_sample_scenario([effect]), sample_model)
    roll0, roll1 = np.std(plain.channels["roll"]), np.std(trial.channels["roll"])
    ay0, ay1 = (np.std(tr.streams["/imu/data"]["ay"]) for tr in (plain, trial))
    if effect["kind"] in ("anti_roll_tank", "quadratic_roll_damping"):
        assert roll1 < 0.95 * roll0, (roll0, roll1)
    elif effect["kind"] == "imu_lever_arm":
        assert roll1 == roll0 and ay1 > ay0
    else:
        assert roll1 != roll0

"""The independent trial path (issue 15): separation from the estimator, and its physics against
independent references (Capytaine's own RAO, a brute-force cos-sum, spectral integrals, rigid-body geometry)."""

from __future__ import annotations

import hashlib
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from seatune.simulate.independent import era5, hydro, trial
from seatune.simulate.independent.bank import definitions, make_spec
from seatune.simulate.independent.seas import Partition, frequency_spectrum, hs_of, spreading
from seatune.simulate.independent.synthesis import direct, synthesize

REPO = Path(__file__).resolve().parents[1]
FORBIDDEN = ("seatune.physics", "seatune.identification", "seatune.tuning", "seatune.diagnosis", "seatune.pipeline",
             "seatune.simulate.hindcast_writers", "seatune.simulate.scenario", "seatune.simulate.effects")


def test_separation_from_the_estimator():
    """Importing (and using) the whole path in a fresh interpreter loads none of the estimator's packages."""
    code = (
        "import sys\n"
        "from seatune.simulate.independent import bank, era5, hulls, hydro, seas, synthesis, trial\n"
        "from seatune.simulate.independent import trial, hydro\n"
        "c = hydro.condition(trial.hull_data('osv'), hydro.Loading(9.9e6, -1, 0, 6.5, 8.4, 24, 25))\n"
        "hydro.capytaine_rao(c); hydro.coupled_natural_frequencies(c)\n"
        "import seatune.simulate.log_writers\n"
        "print('\\n'.join(sorted(m for m in sys.modules if m.startswith('seatune'))))\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO)
    loaded = res.stdout.split()
    assert "seatune.simulate.independent.trial" in loaded
    bad = [m for m in loaded if m.startswith(FORBIDDEN)]
    assert not bad, f"the independent path imports the estimator: {bad}"


def test_blockwise_synthesis_equals_the_cos_sum():
    rng = np.random.default_rng(3)
    w = rng.uniform(0.2, 2.0, 400)
    c = rng.normal(size=(400, 2)) + 1j * rng.normal(size=(400, 2))
    t0, dt, n = 17.3, 0.1, 9000
    x = synthesize(w, c, t0, dt, n)
    ref = direct(w, c, t0 + dt * np.arange(n))
    assert np.max(np.abs(x - ref)) < 1e-6 * np.max(np.abs(ref))


@pytest.fixture(scope="module")
def osv():
    return trial.hull_data("osv")


@pytest.fixture(scope="module")
def barge():
    return trial.hull_data("barge")


def _rao_peak(cond: hydro.Condition, dof: int, beta_deg: float, around: float) -> float:
    """Peak of |RAO| from capytaine.post_pro.rao of the lightly damped hull (radiation damping × 0.02) on a fine
    grid around `around`."""
    fine = cond.at_omega(np.linspace(0.8 * around, 1.2 * around, 1601))
    light = replace(fine, B=0.02 * fine.B, Bv=np.zeros((6, 6)))
    x = hydro.capytaine_rao(light)
    j = int(np.argmin(np.abs(np.rad2deg(cond.beta) - beta_deg)))
    return float(fine.omega[np.argmax(np.abs(x[:, j, dof]))])


@pytest.mark.parametrize("hull", ["osv", "barge"])
def test_coupled_roots_at_capytaine_rao_peaks(hull, osv, barge):
    hd = osv if hull == "osv" else barge
    lo = (hydro.Loading(9.9e6, -1.0, 0.0, 6.5, 8.4, 24.0, 25.0, 0.2) if hull == "osv"
          else hydro.Loading(1025.0 * 3600.0, 0.0, 0.0, 7.0, 7.0, 15.0, 15.6, 0.3))  # barge: 3.0 m, keel file
    cond = hydro.condition(hd, lo)
    roots = hydro.coupled_natural_frequencies(cond)
    assert set(roots) == {"heave", "roll", "pitch"}
    assert abs(_rao_peak(cond, 3, 90.0, roots["roll"]) / roots["roll"] - 1) < 0.01
    assert abs(_rao_peak(cond, 2, 180.0, roots["heave"]) / roots["heave"] - 1) < 0.02
    assert abs(_rao_peak(cond, 4, 180.0, roots["pitch"]) / roots["pitch"] - 1) < 0.02


def test_barge_files_give_the_box_hydrostatics_and_a_consistent_frame(barge):
    """Each file is exported about another centre; moved to the waterline its heave–roll and heave–pitch added-mass
    couplings vanish (a symmetric box) and the drafts are increasing."""
    assert np.allclose(barge.drafts, [2.6, 3.0, 3.4])
    for k in range(3):
        a = barge.A[k, 10]
        assert abs(a[2, 4]) < 1e-3 * np.sqrt(a[2, 2] * a[4, 4])
        assert abs(a[1, 3]) < 0.5 * np.sqrt(a[1, 1] * a[3, 3])  # sway–roll coupling about the waterline is modest
    # sway–roll coupling about the waterline has the same sign at every draft (a wrong transform flips it)
    assert len({np.sign(barge.A[k, 10, 1, 3]) for k in range(3)}) == 1


def _one_window_spec(hull="osv", effects=(), minutes=40.0, seed=7):
    spec = make_spec(trial="t", index=seed, hull=hull, category="clean", effects=[], n_windows=1)
    sea = [[Partition("wind_sea", 1.5, 7.0, 60.0, 3.3, "cos2s", 25.0),
            Partition("swell", 1.0, 11.0, 100.0, 2.0, "wrapped_normal", 12.0)]]
    return replace(spec, seas=sea, window_minutes=[minutes], headings_deg=[10.0], transit_minutes=[2.0],
                   effects=list(effects))


def _roll_sigma_expected(cond, parts, heading):
    """σ² = ∫∫ |RAO_roll(ω, β)|² S(ω, β) dω dβ with Capytaine's RAO and wavespectra's spectrum (fine trapezoid)."""
    w = np.linspace(0.2, 2.0, 2001)
    fine = cond.at_omega(w)
    x = hydro.capytaine_rao(fine)[:, :, 3]
    d_from = np.mod(heading - np.rad2deg(cond.beta) - 180.0, 360.0)
    s = sum(frequency_spectrum(w, p)[:, None] * spreading(d_from, p)[None, :] for p in parts)
    return float(np.sqrt(np.trapezoid((np.abs(x) ** 2 * s).sum(axis=1) * 2 * np.pi / cond.beta.size, w)))


def test_roll_sigma_matches_the_spectral_integral_and_quadratic_damping_lowers_it(osv):
    spec = _one_window_spec(minutes=60.0)
    cond = hydro.condition(osv, spec.loading)
    roots = hydro.coupled_natural_frequencies(cond)
    m = trial.simulate_motions(spec, cond, roots, np.random.default_rng(1))
    drift = next(s for s in m.segs if s.kind == "drift")
    sel = (m.t >= drift.t0 + trial.TRANSITION_S) & (m.t < drift.t1)
    measured = float(np.std(m.xi[sel, 3]))
    expected = _roll_sigma_expected(cond, spec.seas[0], drift.heading_deg)
    assert abs(measured / expected - 1) < 0.15, (measured, expected)
    # derivatives are consistent with the motion itself
    assert np.allclose(np.gradient(m.xi[sel, 3], 0.1), m.xid[sel, 3], atol=0.02 * np.std(m.xid[sel, 3]))
    # the quadratic roll moment lowers roll (same sea, same phases)
    m2 = trial.simulate_motions(spec, cond, roots, np.random.default_rng(1))
    trial.apply_quadratic_damping(m2, cond, roots, q=3.0)
    damped = float(np.std(m2.xi[sel, 3]))
    assert damped < 0.95 * measured
    # and nothing else changes
    assert np.array_equal(m2.xi[:, 2], m.xi[:, 2])


def test_rk4_roll_correction_against_the_free_decay():
    """q = 0: no correction; free decay of the SDOF (u = 0 with an initial kick) is not needed — check the linear
    limit: with u a small harmonic and tiny q the correction is ~q·u² and of the moment's sign."""
    t = np.arange(6000) * 0.1
    u = 0.02 * np.cos(0.5 * t)
    y0, z0, a0 = trial.quadratic_roll(u, 0.1, 1.0, 0.05, 0.25, 0.0)
    assert not np.any(y0) and not np.any(z0)
    y, z, a = trial.quadratic_roll(u, 0.1, 1.0, 0.05, 0.25, 1.0)
    # the extra damping removes energy: correlation of the correction's velocity with u is negative
    assert np.mean(z[3000:] * u[3000:]) < 0


def test_imu_specific_force_by_geometry(osv):
    """Static roll φ, pitch θ, no wave: the accelerometer reads Rᵀ (0, 0, g): f_y = g sin φ cos θ, f_x = −g sin θ."""
    spec = _one_window_spec()
    cond = hydro.condition(osv, spec.loading)
    n = 50
    phi, th = 0.05, -0.03
    xi = np.zeros((n, 6))
    xi[:, 3], xi[:, 4] = phi, th
    m = trial.Motions(np.arange(n) / 10, xi, np.zeros((n, 6)), np.zeros((n, 6)), np.full(n, 30.0),
                      np.zeros((n, 2)), [])
    tab = trial.imu_signals(m, cond, np.array([12.0, 0.0, 15.0]), spec, np.random.default_rng(0))
    g = osv.g
    assert np.isclose(tab["ay"].mean(), g * np.sin(phi) * np.cos(th), atol=0.015)  # IMU bias σ 3e-3
    assert np.isclose(tab["ax"].mean(), -g * np.sin(th), atol=0.015)
    # a pure heave acceleration at the point, and the half-ship-length lever arm on a pitch acceleration
    xidd = np.zeros((n, 6))
    xidd[:, 4] = 0.01
    m3 = trial.Motions(m.t, np.zeros((n, 6)), np.zeros((n, 6)), xidd, m.heading_deg, m.vel_en, [])
    a = trial.imu_signals(m3, cond, np.array([12.0, 0.0, 15.0]), spec, np.random.default_rng(0))
    lever = replace(spec, effects=[{"kind": "imu_lever_arm", "dx": -48.0, "dy": 0.0, "dz": 0.0}])
    b = trial.imu_signals(m3, cond, np.array([12.0, 0.0, 15.0]), lever, np.random.default_rng(0))
    # a_z at x = p_x under pitch acceleration θ̈: −x θ̈ (bow down positive)
    assert np.isclose((b["az"] - a["az"]).mean(), 48.0 * 0.01, atol=5e-3)
    # headings: the orientation's ENU yaw is 90° − ψ
    from scipy.spatial.transform import Rotation

    yaw = Rotation.from_quat(tab[["qx", "qy", "qz", "qw"]].to_numpy()).as_euler("ZYX", degrees=True)[:, 0]
    assert np.allclose(np.mod(90.0 - yaw, 360.0), 30.0, atol=0.1)


@pytest.mark.parametrize("layout,time_dim", [("bulk", "valid_time"), ("partitions", "time"), ("d2fd", "time"),
                                             ("d2fd", "valid_time")])
def test_degraded_hindcast_as_era5(tmp_path, layout, time_dim):
    """The hindcast holds the drawn Hs error (not the missing swell) and reads back with seatune's ERA5 reader and
    with wavespectra."""
    from seatune.io.hindcast_readers import read_hindcast

    parts = [Partition("wind_sea", 1.6, 7.0, 200.0, 5.0, "wrapped_normal", 25.0),
             Partition("swell", 1.2, 12.0, 290.0, 2.0, "cos2s", 12.0),
             Partition("swell2", 0.8, 14.0, 20.0, 3.0, "cos2s", 10.0, in_hindcast=False)]
    deg = era5.degrade(parts, 0.12, 0.4, -6.0, 3.3, 1.2)
    assert len(deg) == 2
    steps = [era5.fields(deg, layout)] * 3
    times = pd.date_range("2026-03-01T06:00", periods=3, freq="h", tz="UTC")
    path = era5.write(tmp_path / "h.nc", times, np.array([60.0, 60.5, 61.0]), np.array([3.0, 3.5]), steps, layout,
                      time_dim)
    truth_hs = hs_of([p for p in parts if p.in_hindcast])
    hc = read_hindcast(path)
    hs = float(hc.bulk["hs"].isel(time=0, lat=0, lon=0))
    tol = 0.005 if layout != "d2fd" else 0.04  # d2fd: the ERA5 30-frequency grid's own integration
    assert abs(hs / (1.12 * truth_hs) - 1) < tol
    assert abs(hs / hs_of(parts) - 1) > 0.02  # the missing swell is missing
    with xr.open_dataset(path) as ds:
        assert time_dim in ds.dims
        if layout == "partitions":
            assert {"shww", "mpww", "mdww", "shts", "mpts", "mdts"} <= set(ds.data_vars)
        if layout == "d2fd":
            import wavespectra

            sp = wavespectra.read_era5(path)
            assert abs(float(sp.spec.hs().isel(time=0, lat=0, lon=0)) / (1.12 * truth_hs) - 1) < tol


def _hash_tree(folder: Path) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir()) if p.is_file()}


def test_a_trial_regenerates_bit_identically(tmp_path):
    spec = _one_window_spec(hull="barge", minutes=4.0, seed=11)
    spec = replace(spec, trial="tiny", effects=[{"kind": "moonpool", "omega_p": 1.4, "zeta_p": 0.05, "area": 30.0,
                                                 "x": 5.0, "y": 0.0}],
                   hindcast={**spec.hindcast, "layout": "d2fd", "time_dim": "valid_time"})
    trial.generate(spec, tmp_path / "a")
    spec2 = replace(spec, hindcast=dict(spec.hindcast))
    trial.generate(spec2, tmp_path / "b")
    a, b = _hash_tree(tmp_path / "a" / "tiny"), _hash_tree(tmp_path / "b" / "tiny")
    assert set(a) == {"imu.mcap", "gnss.csv", "era5.nc", "truth.yaml", "run.yaml"}
    assert a == b


def test_bank_definition_meets_the_issue():
    full = definitions("full")
    assert len(full) >= 60
    cats = pd.Series([r["category"] for r in full]).value_counts()
    assert cats["clean"] >= 20 and cats["compound"] >= 6
    for e in ("quadratic_roll_damping", "moonpool", "anti_roll_tank", "imu_lever_arm", "imu_misalignment"):
        assert cats[e] >= 6
    assert {r["hull"] for r in full} == {"osv", "barge"}
    assert min(r["n_windows"] for r in full) >= 3 and max(r["n_windows"] for r in full) <= 12
    assert any(r.get("origin_mistake") for r in full if r["category"] == "imu_lever_arm")
    assert any(r.get("missing_swell") for r in full if r["category"] == "clean")
    assert len({r["trial"] for r in full}) == len(full)
    ci = definitions("ci")
    assert len(ci) == 4 and {r["hull"] for r in ci} == {"osv", "barge"}
    assert {"clean", "compound"} <= {r["category"] for r in ci}
    assert {r["layout"] for r in ci} == {"bulk", "partitions", "d2fd"}
    # loading truth within the priors' bounds
    spec = make_spec(**full[1])
    assert 5.5 <= spec.loading.r44 <= 8.5 and spec.hull == "barge"


def test_seatune_ingest_reads_a_generated_trial(tmp_path):
    """The real CLI reads the MCAP, the GNSS CSV and the ERA5 file the path writes: headings and gravity come out
    as the truth says (the estimator runs in its own process; this path never imports it)."""
    spec = _one_window_spec(hull="barge", minutes=6.0, seed=21)
    spec = replace(spec, trial="ing", hindcast={**spec.hindcast, "layout": "partitions", "time_dim": "time"})
    truth = trial.generate(spec, tmp_path)
    tdir = tmp_path / "ing"
    exe = Path(sys.executable).with_name("seatune")
    res = subprocess.run([str(exe), "ingest", "run.yaml"], cwd=tdir, capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr
    mot = pd.read_parquet(tdir / "run" / "motions.parquet")
    w = truth["windows"][0]
    sel = (mot["time"] >= pd.Timestamp(w["start"])) & (mot["time"] < pd.Timestamp(w["end"]))
    head = mot.loc[sel, "heading_deg"].to_numpy()
    assert abs(((np.median(head) - w["heading_deg"]) + 180) % 360 - 180) < 1.0
    assert abs(mot.loc[sel, "imu_fz"].mean() - 9.81) < 0.05
    assert mot.loc[sel, "sog"].median() < 0.4  # the drift is slow enough for seatune's window detector
    assert np.isclose(mot.loc[sel, "roll"].std(), np.std(mot.loc[sel, "roll"]), rtol=0.01)


def test_coupled_oscillators_change_the_response_where_they_should(osv):
    """Anti-roll tank tuned to the roll root: the roll RAO at the root drops (absorber notch) and two peaks appear
    beside it; moonpool: the heave RAO changes a lot near ω_p and little far below it; the tank reduces to the plain
    Capytaine RAO when their coupling vanishes."""
    spec = _one_window_spec()
    cond = hydro.condition(osv, spec.loading)
    roots = hydro.coupled_natural_frequencies(cond)
    plain = trial.transfer_functions(cond, spec, roots)
    jb = int(np.argmin(np.abs(np.rad2deg(cond.beta) - 90.0)))
    iw = int(np.argmin(np.abs(trial.W_FINE - roots["roll"])))
    tank = replace(spec, effects=[{"kind": "anti_roll_tank", "omega_t": roots["roll"], "zeta_t": 0.05, "mu": 0.05}])
    xt = trial.transfer_functions(cond, tank, roots)
    assert abs(xt[iw, jb, 3]) < 0.7 * abs(plain[iw, jb, 3])
    zero = replace(spec, effects=[{"kind": "anti_roll_tank", "omega_t": roots["roll"], "zeta_t": 0.05, "mu": 1e-12}])
    assert np.allclose(trial.transfer_functions(cond, zero, roots), plain, rtol=1e-6, atol=1e-12)
    mp = replace(spec, effects=[{"kind": "moonpool", "omega_p": 1.2, "zeta_p": 0.05, "area": 80.0, "x": 10.0,
                                 "y": 0.0}])
    xm = trial.transfer_functions(cond, mp, roots)
    jh = int(np.argmin(np.abs(np.rad2deg(cond.beta) - 180.0)))
    near = np.abs(trial.W_FINE - 1.2) < 0.1
    far = trial.W_FINE < 0.4
    rel = np.abs(np.abs(xm[:, jh, 2]) / np.abs(plain[:, jh, 2]) - 1)
    # near ω_p the piston mode dominates; far below it only the column's spring acts (static heave 1 + S/A_wp)
    assert rel[near].max() > 1.0 and rel[far].max() < 0.1

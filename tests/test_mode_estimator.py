"""identify's natural-frequency estimator on noise-free response spectra made by the independent trial path
(Capytaine's own `post_pro.rao` of the bank's hulls, wavespectra-built seas): no sampling error, no sea error, so
what is left is the estimator's own bias. The truth is the generator's coupled root of det(C − ω²(M + A(ω)))."""

from __future__ import annotations

import numpy as np
import pytest

from seatune.io.run_yaml import IdentifySettings
from seatune.physics.modes import natural_frequencies
from seatune.pipeline import identify as ident
from seatune.pipeline.vessel import open_vessel
from seatune.simulate.independent import hydro, trial
from seatune.simulate.independent.seas import Partition, directional_spectrum
from tests.conftest import ROOT

DOFS = {"Heave": 2, "Roll": 3, "Pitch": 4}
# a bank trial's true loading of each hull, with a sea that reaches all three modes
CASES = {
    "osv": ("sample_osv.yaml", dict(mass=9963390.76, xcg=-0.287671, ycg=0.0, zcg=5.9, r44=8.412426, r55=23.829645,
                                    r66=25.0, gmt_fs=0.455214, beta44=0.069639),
            [Partition("wind_sea", 2.0, 8.0, 60.0, 3.3, "cos2s", 25.0),
             Partition("swell", 1.0, 11.0, 100.0, 2.0, "wrapped_normal", 12.0)]),
    "barge": ("barge.yaml", dict(mass=3724601.92, xcg=-1.021459, ycg=0.0, zcg=6.736275, r44=6.0, r55=13.553702,
                                 r66=15.6, gmt_fs=0.36075, beta44=0.061526),
              [Partition("wind_sea", 2.0, 6.5, 60.0, 3.3, "cos2s", 25.0)]),
    # osv_clean_000's: the COG 3.9 m aft and r55 25.9 m put the pitch root (0.831) below the heave root (0.899); the
    # vessel YAML's r55 24 m, xcg −1 m put them the other way round (heave 0.856, pitch 0.922)
    "osv_crossing": ("sample_osv.yaml", dict(mass=10275146.26, xcg=-3.921606, ycg=0.0, zcg=6.275559, r44=8.46793,
                                             r55=25.875963, r66=25.0, gmt_fs=0.196974, beta44=0.025693),
                     [Partition("wind_sea", 1.2, 7.2, 350.0, 4.0, "wrapped_normal", 33.0),
                      Partition("swell", 1.4, 12.3, 127.0, 6.8, "wrapped_normal", 16.0)]),
}


def _window(hull: str, model, heading: float = 30.0, case: str | None = None):
    vessel, loading, sea = CASES[case or hull]
    cond = hydro.condition(trial.hull_data(hull), hydro.Loading(**loading))
    roots = hydro.coupled_natural_frequencies(cond)
    omega = np.arange(1, 80) * 2 * np.pi / 256.0  # a 256 s Welch grid
    omega = omega[(omega >= 0.25) & (omega <= 1.9)]
    xi = hydro.capytaine_rao(cond.at_omega(omega))  # (n, nβ, 6)
    dirs = np.mod(heading - np.degrees(cond.beta) - 180.0, 360.0)  # coming-from of each β (DESIGN §3)
    order = np.argsort(dirs)
    dirs, xi = dirs[order], xi[:, order, :]
    wave = directional_spectrum(omega, dirs, sea)
    dd = np.radians(360.0 / dirs.size)
    modes = {d: (omega, (np.abs(xi[:, :, k]) ** 2 * wave).sum(axis=1) * dd, 400.0) for d, k in DOFS.items()}
    window = {"window_id": "1", "modes": modes, "omega": omega, "s_wave": wave.sum(axis=1) * dd, "wave": wave,
              "dirs": dirs, "heading": heading, "draft": float(ident.load_draft(model, model.base_loading)),
              "tp_rel_std": 0.0, "low_confidence": False}
    return window, roots


@pytest.mark.parametrize("hull", ["osv", "barge"])
def test_the_estimator_bias_is_removed(hull):
    """Raw, the SDOF fit of √(S_xx/S_FF) puts heave 1.7 % (OSV) and 3.4 % (barge) above the coupled root
    (frequency-dependent A33, B33 and the pitch coupling bend the admittance); scaled by the same fit's bias on the
    prior model's spectrum, every mode is within 0.7 % of the generator's root, the prior being 0.4–9 % off."""
    model = open_vessel(ROOT / "configs" / "vessels" / CASES[hull][0])
    window, roots = _window(hull, model)
    nat = natural_frequencies(model.db, model.base_loading)[0]
    prior = {d: float(nat[i]) for i, d in enumerate(DOFS)}

    def fitted(loading):
        rows = ident.natural_frequency_rows(model, [window], prior, IdentifySettings(), loading)
        return {r["dof"]: r for r in rows if r["window_id"] == "1" and r["method"] == "admittance_peak_sdof"}

    raw, debiased = fitted(None), fitted(model.base_loading)
    assert raw["Heave"]["omega_n"] / roots["heave"] - 1 > 0.012
    for dof in DOFS:
        assert debiased[dof]["omega_n"] == pytest.approx(roots[dof.lower()], rel=0.007), dof
        assert debiased[dof]["estimator_bias"] == pytest.approx(raw[dof]["omega_n"] / debiased[dof]["omega_n"])


def test_the_loading_spread_is_the_move_of_separate_fits():
    """`loading_std` of a combined ω_n is √(½((ω(+σ) − ω)² + (ω(−σ) − ω)²)) of the same window de-biased at the
    prior moved by ±1σ of its one uncertain parameter (xcg here: it moves heave-pitch coupling), each fitted on
    its own, and the interval grows by 1.96 · loading_std in quadrature."""
    model = open_vessel(ROOT / "configs" / "vessels" / "sample_osv.yaml")
    window, _ = _window("osv", model)
    base = model.base_loading
    nat = natural_frequencies(model.db, base)[0]
    prior = {d: float(nat[i]) for i, d in enumerate(DOFS)}
    spread = ident.loading_spread(model, base, known=[n for n in model.spec.priors if n != "xcg"])
    assert len(spread) == 2
    assert spread.xcg.tolist() == pytest.approx([base.xcg[0] + 1.5, base.xcg[0] - 1.5])

    def combined(loading, spread=None):
        rows = ident.natural_frequency_rows(model, [window], prior, IdentifySettings(), loading, spread)
        return {r["dof"]: r for r in rows if r["window_id"] == "all" and r["method"] == "admittance_peak_sdof"}

    centre, widened = combined(base), combined(base, spread)
    up, down = combined(spread.take([0])), combined(spread.take([1]))
    for dof in DOFS:
        expected = np.sqrt(0.5 * ((up[dof]["omega_n"] - centre[dof]["omega_n"]) ** 2
                                  + (down[dof]["omega_n"] - centre[dof]["omega_n"]) ** 2))
        assert widened[dof]["loading_std"] == pytest.approx(expected, rel=1e-9, abs=1e-12), dof
        half = np.hypot(0.5 * (centre[dof]["ci_high"] - centre[dof]["ci_low"]), 1.96 * expected)
        assert widened[dof]["ci_high"] - widened[dof]["ci_low"] == pytest.approx(2 * half, rel=1e-9), dof
        assert widened[dof]["omega_n"] == centre[dof]["omega_n"]
    assert widened["Heave"]["loading_std"] > 5e-3 * prior["Heave"]  # xcg does move the heave fit: not vacuous


def test_a_hindcast_tp_error_shared_by_the_windows_does_not_average_down():
    """Every window of a run reads one hindcast, whose Tp error persists over the run: the part of each window's
    interval that comes from it (`tp_std`) is added after the windows are combined, not divided by √N."""
    def row(omega, tp_std, random_std=0.001):
        half = 1.96 * np.hypot(random_std, tp_std)
        return {"omega_n": omega, "ci_low": omega - half, "ci_high": omega + half, "zeta": 0.05, "tp_std": tp_std}

    omegas = [0.999, 1.0, 1.001, 1.0005]
    independent = ident._combine([row(o, 0.0) for o in omegas], "Roll", "admittance_peak_sdof", 1.0)
    shared = ident._combine([row(o, 0.01) for o in omegas], "Roll", "admittance_peak_sdof", 1.0)
    half = 0.5 * (shared["ci_high"] - shared["ci_low"])
    assert half == pytest.approx(np.hypot(0.5 * (independent["ci_high"] - independent["ci_low"]), 1.96 * 0.01))
    assert half > 1.96 * 0.01  # four windows, still the whole of one window's Tp term


def test_the_loading_spread_moves_the_mass_for_a_displacement_prior_and_stays_in_the_database():
    """A displacement prior [m³] moves the mass by ρ·σ; ±1σ that would leave the database's drafts stops at them."""
    from types import SimpleNamespace

    from seatune.io.vessel_yaml import PriorSpec

    model = open_vessel(ROOT / "configs" / "vessels" / "sample_osv.yaml")
    db, base = model.db, model.base_loading
    wide = SimpleNamespace(db=db, spec=SimpleNamespace(priors={"displacement": PriorSpec(std=1.0e4)}))
    spread = ident.loading_spread(wide, base)
    assert spread.mass.tolist() == pytest.approx([db.rho * db.disp_volume[-1], db.rho * db.disp_volume[0]])
    narrow = SimpleNamespace(db=db, spec=SimpleNamespace(priors={"displacement": PriorSpec(std=100.0),
                                                                  "r44": PriorSpec(std=0.5)}))
    spread = ident.loading_spread(narrow, base, known=["r44"])
    assert len(spread) == 2 and spread.mass.tolist() == pytest.approx(base.mass[0] + db.rho * np.array([100, -100]))
    assert ident.loading_spread(narrow, base, known=["displacement", "r44"]) is None


def test_an_uncertainty_even_in_its_parameter_is_not_lost():
    """The barge is fore-aft symmetric: its heave mode falls as the COG moves off midship either way (the model's
    own coupled roots at xcg = ±1 m are equal), so a central difference about xcg = 0 reads no spread. The
    loading spread of a heave fit and the prior draws' spread of the heave mode both keep it."""
    model = open_vessel(ROOT / "configs" / "vessels" / "barge.yaml")
    base = model.base_loading
    known = [n for n in model.spec.priors if n != "xcg"]
    spread = ident.loading_spread(model, base, known=known)
    roots = natural_frequencies(model.db, spread)[:, 0]
    assert roots[0] == pytest.approx(roots[1], rel=1e-9)  # symmetric: the central difference is zero
    centre = natural_frequencies(model.db, base)[0, 0]
    assert centre - roots[0] > 1e-3  # ... yet ±1 m lowers heave by ~0.4 %
    window, _ = _window("barge", model)
    nat = natural_frequencies(model.db, base)[0]
    prior = {d: float(nat[i]) for i, d in enumerate(DOFS)}
    rows = ident.natural_frequency_rows(model, [window], prior, IdentifySettings(), base, spread)
    heave = next(r for r in rows if r["window_id"] == "all" and r["dof"] == "Heave")
    assert heave["loading_std"] > 1e-3
    draws = ident.prior_draws(model, base, known=known, n=512)
    assert len(draws) == 512 and draws.xcg.min() >= -3.0 and draws.xcg.max() <= 3.0  # the prior's bounds
    assert draws.xcg.mean() == pytest.approx(0.0, abs=0.01) and draws.xcg.std() == pytest.approx(1.0, rel=0.05)
    assert natural_frequencies(model.db, draws)[:, 0].std() > 1e-3


def test_a_mode_no_loading_explains_does_not_steer_the_others():
    """A heave measured 20 % below every coupled heave mode the loading prior allows (an IMU lever arm the vessel
    YAML lacks does this on the bank) is an effect the model lacks, not a loading: roll and pitch are combined with
    the loading prior as if heave were unmeasured, and heave's posterior row is the model's mode given them, with a
    note. Weighted into the loading draws, that heave would have dragged pitch to the prior's tail."""
    from scipy.stats import norm

    from seatune.identification.natural_frequency import mode_posterior

    model = open_vessel(ROOT / "configs" / "vessels" / "sample_osv.yaml")
    settings = IdentifySettings()
    center = model.base_loading
    nat = natural_frequencies(model.db, center)[0]
    z = norm.ppf(0.5 + settings.confidence / 2)

    def row(dof, omega):
        return {"dof": dof, "method": "admittance_peak_sdof", "window_id": "all", "omega_n": omega,
                "ci_low": omega * (1 - 0.01 * z), "ci_high": omega * (1 + 0.01 * z), "zeta": 0.1,
                "model_prior": omega}

    rows = [row("Heave", 0.8 * float(nat[0])), row("Roll", 1.01 * float(nat[1])), row("Pitch", 0.99 * float(nat[2]))]
    post = {r["dof"]: r for r in ident.posterior_rows(model, rows, center, (), settings)}
    draws = natural_frequencies(model.db, ident.prior_draws(model, center))
    m = np.array([r["omega_n"] for r in rows])
    unmeasured = mode_posterior(draws, np.r_[np.nan, m[1:]], 0.01 * m, settings.mode_model_rel_std)
    for i, dof in enumerate(("Heave", "Roll", "Pitch")):
        assert post[dof]["omega_n"] == pytest.approx(unmeasured.omega[i], rel=1e-12)
    assert post["Heave"]["reason"].startswith("the model's mode given the other modes")
    assert post["Roll"]["reason"] is None and post["Pitch"]["reason"] is None
    assert abs(post["Heave"]["omega_n"] / nat[0] - 1) < 0.05  # the model's, not the measurement's 20 % off
    dragged = mode_posterior(draws, m, 0.01 * m, settings.mode_model_rel_std).omega[2]
    assert abs(dragged / post["Pitch"]["omega_n"] - 1) > 0.005  # not vacuous: 1.3 % here


def test_a_response_spectrum_peak_enters_the_posterior_where_the_admittance_failed():
    """Roll whose admittance fit failed in every window still has its response spectrum's peak: that value and
    interval are combined with the loading prior as an admittance measurement would be (on the bank the peak alone
    had put barge_clean_023's roll 13 % off); where the admittance measured, its value is the one taken."""
    from scipy.stats import norm

    from seatune.identification.natural_frequency import mode_posterior

    model = open_vessel(ROOT / "configs" / "vessels" / "sample_osv.yaml")
    settings = IdentifySettings()
    center = model.base_loading
    nat = natural_frequencies(model.db, center)[0]
    z = norm.ppf(0.5 + settings.confidence / 2)

    def row(dof, omega, rel_std, method="admittance_peak_sdof"):
        return {"dof": dof, "method": method, "window_id": "all", "omega_n": omega,
                "ci_low": omega * (1 - rel_std * z), "ci_high": omega * (1 + rel_std * z), "zeta": np.nan,
                "model_prior": float(nat[1])}

    failed = {"dof": "Roll", "method": "admittance_peak_sdof", "window_id": "all", "omega_n": np.nan,
              "ci_low": np.nan, "ci_high": np.nan, "zeta": np.nan, "model_prior": float(nat[1]),
              "reason": "not identified: no resonance peak fitted (8 of 8 windows)"}
    peak = row("Roll", 1.13 * float(nat[1]), 0.10, "response_spectrum_peak")
    others = [row("Heave", 1.005 * float(nat[0]), 0.01), row("Pitch", 0.995 * float(nat[2]), 0.01)]
    post = {r["dof"]: r for r in ident.posterior_rows(model, [*others, failed, peak], center, (), settings)}
    draws = natural_frequencies(model.db, ident.prior_draws(model, center))
    m = np.array([others[0]["omega_n"], peak["omega_n"], others[1]["omega_n"]])
    expected = mode_posterior(draws, m, np.array([0.01, 0.10, 0.01]) * m, settings.mode_model_rel_std)
    assert post["Roll"]["omega_n"] == pytest.approx(expected.omega[1], rel=1e-12)
    assert abs(post["Roll"]["omega_n"] / nat[1] - 1) < 0.5 * abs(peak["omega_n"] / nat[1] - 1)  # pulled in
    both = {r["dof"]: r for r in ident.posterior_rows(
        model, [*others, row("Roll", 1.01 * float(nat[1]), 0.01), peak], center, (), settings)}
    alone = {r["dof"]: r for r in ident.posterior_rows(
        model, [*others, row("Roll", 1.01 * float(nat[1]), 0.01)], center, (), settings)}
    assert both["Roll"]["omega_n"] == alone["Roll"]["omega_n"]


def test_the_estimator_bias_is_taken_at_each_loading_of_the_prior_through_an_avoided_crossing():
    """Near the heave–pitch crossing the labelled roots swap with the loading while an SDOF fit of the pitch
    admittance moves smoothly. De-biased at the prior's centre only (the vessel YAML's r55 24 m), pitch reads 2.4 %
    above the generator's root on noise-free spectra; de-biased at each draw of the loading prior (`fit_by_draw`
    carried to every draw by `debiased_by_draw`'s quadratic), the value at the true loading is its root within
    0.3 %, and the posterior over the draws comes closer than the centre's, within 2 % (heave and pitch); r55 over
    the draws so weighted reads 25.8 ± 0.4 m (truth 25.9)."""
    model = open_vessel(ROOT / "configs" / "vessels" / "sample_osv.yaml")
    loading = CASES["osv_crossing"][1]
    windows = []
    for k, heading in enumerate((20.0, 80.0, 150.0)):
        w, roots = _window("osv", model, heading, case="osv_crossing")
        windows.append(w | {"window_id": str(k + 1)})
    settings = IdentifySettings(known={"mass": loading["mass"], "zcg": loading["zcg"]})
    center = model.loading(**settings.known)
    nat = natural_frequencies(model.db, model.base_loading)[0]
    prior = {d: float(nat[i]) for i, d in enumerate(DOFS)}
    assert prior["Heave"] < prior["Pitch"] and roots["pitch"] < roots["heave"]  # the labels do swap
    spread = ident.loading_spread(model, center, settings.known)
    fitted = ident.prior_draws(model, center, settings.known, n=ident.fit_draw_count(model, settings.known))
    rows = ident.natural_frequency_rows_many(model, [(windows, prior, center, spread, fitted)], settings)[0]
    truth = model.loading(**loading)
    truth_roots = natural_frequencies(model.db, truth)[0]
    assert truth_roots[2] == pytest.approx(roots["pitch"], rel=1e-3)  # the same hull in both: the same root
    centred = {r["dof"]: r["omega_n"] for r in rows if r["window_id"] == "all"}
    assert centred["Pitch"] / roots["pitch"] - 1 > 0.02  # not vacuous
    priors = ident.uncertain_priors(model, settings.known)
    for i, dof in ((0, "Heave"), (2, "Pitch")):
        at_truth = ident.debiased_by_draw(rows, dof, truth, truth_roots[i:i + 1], priors, fitted)
        assert at_truth[0] == pytest.approx(roots[dof.lower()], rel=0.003), dof
    post_rows = ident.posterior_rows(model, rows, center, settings.known, settings)
    post = {r["dof"]: r["omega_n"] for r in post_rows if r.get("derived") is None}
    read = next(r for r in post_rows if r.get("derived") == ident.PITCH_R55)
    assert abs(read["derived_value"] - loading["r55"]) < 2 * read["derived_std"] < 1.5  # r55 given the modes
    for r in rows:
        r.pop("fit_by_draw", None)
    only_centre = {r["dof"]: r["omega_n"] for r in ident.posterior_rows(model, rows, center, settings.known, settings)}
    assert abs(post["Pitch"] / roots["pitch"] - 1) < abs(only_centre["Pitch"] / roots["pitch"] - 1)
    for dof in ("Heave", "Pitch"):
        assert post[dof] == pytest.approx(roots[dof.lower()], rel=0.02), dof

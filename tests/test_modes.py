"""Coupled natural modes (physics.modes) and a database independent of the reference point it was exported about.

One box barge (30 × 10 m, 2 m draft, centre of gravity 2.5 m above the waterline, so roll drags sway along and
the uncoupled roll ratio is several per cent off) is solved by Capytaine about three rotation centres: the
waterline origin, the centre of gravity and the keel. Capytaine's own post-processing is the outside reference:
its impedance (`capytaine.post_pro.impedance`) assembled from the dataset's inertia and hydrostatics gives the
undamped modes as the zeros of det Re Z(ω), and its RAO (`capytaine.post_pro.rao`) peaks at the roll mode.
"""

import numpy as np
import pytest
import xarray as xr
import yaml
from numpy.testing import assert_allclose
from scipy.interpolate import CubicSpline

from seatune.io.capytaine_import import read_capytaine_dataset, read_capytaine_files
from seatune.physics.hydro import DOFS
from seatune.physics.loading import Loading
from seatune.physics.modes import coupled_modes, invert_mode

cpt = pytest.importorskip("capytaine")
from capytaine.io.xarray import export_dataset  # noqa: E402
from capytaine.post_pro.impedance import impedance as capytaine_impedance  # noqa: E402
from capytaine.post_pro.rao import rao as capytaine_rao  # noqa: E402

RHO, G = 1025.0, 9.81
LENGTH, BEAM, DRAFT = 30.0, 10.0, 2.0
ZG = 2.5  # centre of gravity above the waterline
R44, R55, R66 = 3.8, 8.0, 8.5  # radii of gyration about the centre of gravity
OMEGA = list(np.round(np.arange(0.30, 1.51, 0.06), 4))
BETA = list(np.linspace(0.0, 2 * np.pi, 8, endpoint=False))
CENTRES = {"waterline": (0.0, 0.0, 0.0), "cog": (0.0, 0.0, ZG), "keel": (0.0, 0.0, -DRAFT)}


def _inertia_about(mass: float, cog, radii, centre) -> np.ndarray:
    """6×6 rigid-body inertia about `centre` (written out here, independently of seatune's loading module)."""
    x, y, z = np.subtract(cog, centre)
    s = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    m = np.zeros((6, 6))
    m[:3, :3] = mass * np.eye(3)
    m[:3, 3:], m[3:, :3] = -mass * s, mass * s
    m[3:, 3:] = mass * np.diag(np.square(radii)) - mass * s @ s
    return m


def _body(centre, draft=DRAFT, zg=ZG):
    mesh = cpt.mesh_parallelepiped(size=(LENGTH, BEAM, 2 * draft + 2.0), center=(0.0, 0.0, 1.0),
                                   resolution=(15, 5, 6))
    body = cpt.FloatingBody(mesh=mesh, dofs=cpt.rigid_body_dofs(rotation_center=centre),
                            center_of_mass=(0.0, 0.0, zg)).immersed_part()
    body.mass = RHO * body.volume  # free floating
    body.hydrostatic_stiffness = body.compute_hydrostatic_stiffness(rho=RHO, g=G)
    inertia = _inertia_about(body.mass, (0.0, 0.0, zg), (R44, R55, R66), centre)
    body.inertia_matrix = body.add_dofs_labels_to_matrix(inertia)
    return body


def _solve(body, omega, beta):
    test = xr.Dataset(coords={"omega": omega, "wave_direction": beta, "radiating_dof": list(body.dofs),
                              "rho": RHO, "g": G, "water_depth": np.inf})
    ds = cpt.BEMSolver().fill_dataset(test, body, progress_bar=False)
    return ds.assign(draught=DRAFT)


@pytest.fixture(scope="module")
def barge():
    """{centre name: Capytaine dataset}, each solved about its own rotation centre."""
    return {name: _solve(_body(c), OMEGA + [np.inf], BETA) for name, c in CENTRES.items()}


@pytest.fixture(scope="module")
def dbs(barge):
    return {name: read_capytaine_dataset(ds) for name, ds in barge.items()}


def _truth(db) -> Loading:
    mass = RHO * float(db.disp_volume[0])
    return Loading(mass=mass, xcg=0.0, ycg=0.0, zcg=DRAFT + ZG, r44=R44, r55=R55, r66=R66, gmt_fs=0.0, gml_fs=0.0,
                   beta33=0.0, beta44=0.0, beta55=0.0)


def test_database_is_the_same_about_every_rotation_centre(dbs):
    ref = dbs["waterline"]
    for name in ("cog", "keel"):
        db = dbs[name]
        for field in ("added_mass", "radiation_damping", "added_mass_inf", "excitation_force", "buoyancy_stiffness"):
            a, b = getattr(db, field), getattr(ref, field)
            assert_allclose(a, b, rtol=0, atol=1e-6 * np.abs(b).max(), err_msg=f"{name}: {field}")


def test_buoyancy_stiffness_about_the_origin_is_capytaines(dbs):
    """seatune's transform of Capytaine's stiffness about the keel equals Capytaine's own about the origin."""
    body = _body(CENTRES["waterline"])
    body.mass = 0.0  # buoyancy only
    ref = body.compute_hydrostatic_stiffness(rho=RHO, g=G).sel(influenced_dof=list(DOFS), radiating_dof=list(DOFS))
    assert_allclose(dbs["keel"].buoyancy_stiffness[0], ref.values, rtol=1e-9, atol=1e-6 * np.abs(ref.values).max())


def test_modes_are_zeros_of_capytaines_undamped_impedance(barge, dbs):
    """det Re Z(ω) of Capytaine's impedance (M + A, C about the keel, at BEM frequencies) changes sign at each
    coupled root; linear interpolation of det between the BEM points locates it to the grid's accuracy."""
    modes = coupled_modes(dbs["keel"], _truth(dbs["keel"]))
    roots = _capytaine_roots(barge)
    assert len(roots) == 3
    assert sorted(modes.omega[0]) == pytest.approx(sorted(roots), rel=2e-3)
    # and the uncoupled roll ratio is what the coupling corrects (a free-floating roll turns about its roll centre)
    assert modes.uncoupled[0, 1] / modes.omega[0, 1] - 1 < -0.02
    assert 0.0 < modes.roll_centre_z[0] < ZG + 0.5


def test_roll_rao_peaks_at_the_coupled_root(dbs):
    """Capytaine's own RAO in beam seas, solved on a fine ω grid around the mode, peaks at the coupled root."""
    wn = float(coupled_modes(dbs["keel"], _truth(dbs["keel"])).omega[0, 1])
    fine = list(wn * np.linspace(0.97, 1.03, 13))
    ds = _solve(_body(CENTRES["keel"]), fine, [np.pi / 2])
    roll = np.abs(capytaine_rao(ds).sel(radiating_dof="Roll").squeeze().values)
    k = int(np.argmax(roll))
    assert 0 < k < len(fine) - 1
    y0, y1, y2 = roll[k - 1:k + 2]
    step = fine[1] - fine[0]
    peak = fine[k] + 0.5 * step * (y0 - y2) / (y0 - 2 * y1 + y2)  # parabola through the three top points
    assert peak == pytest.approx(wn, rel=5e-3)


def test_modes_rao_at_a_point_and_derived_loading_do_not_depend_on_the_origin(dbs):
    from seatune.physics.response import motion_raos

    point = np.array([10.0, -4.0, 3.0 - DRAFT])  # body frame: a deck point 10 m forward, 4 m to starboard
    out = {}
    for name, db in dbs.items():
        truth = _truth(db)
        modes = coupled_modes(db, truth)
        xi = motion_raos(db, truth)[0]  # (nw, nb, 6)
        at_point = xi[..., :3] + np.cross(xi[..., 3:], point)
        r44 = invert_mode(db, truth, "r44", "Roll", float(modes.omega[0, 1]) * 1.02, 0.01, (2.0, 6.0))
        fs = invert_mode(db, truth, "gmt_fs", "Roll", float(modes.omega[0, 1]) * 1.02, 0.01, (-1.0, 0.6))
        out[name] = (modes.omega[0], modes.roll_centre_z[0], at_point, r44, fs)
    ref = out["waterline"]
    for name in ("cog", "keel"):
        omega, rcz, at_point, r44, fs = out[name]
        assert_allclose(omega, ref[0], rtol=2e-3)
        assert rcz == pytest.approx(ref[1], abs=0.01)
        assert_allclose(at_point, ref[2], rtol=0, atol=2e-3 * np.abs(ref[2]).max())
        assert r44.value == pytest.approx(ref[3].value, rel=2e-3) and r44.std == pytest.approx(ref[3].std, rel=0.02)
        assert fs.value == pytest.approx(ref[4].value, rel=2e-3, abs=1e-3)
    # round trip: the measured root at the true loading gives back the true r44
    db = dbs["keel"]
    wn = float(coupled_modes(db, _truth(db)).omega[0, 1])
    assert invert_mode(db, _truth(db), "r44", "Roll", wn, 0.005, (2.0, 6.0)).value == pytest.approx(R44, rel=1e-4)


def _vessel(tmp_path, name, hull, mass):
    spec = {"name": f"barge about the {name}", "hull": hull, "rho": RHO, "g": G,
            "loading": {"mass": mass, "xcg": 0.0, "ycg": 0.0, "zcg": DRAFT + ZG, "r44": R44, "r55": R55, "r66": R66},
            "channels": [{"name": "roll", "kind": "angle", "axis": "x", "units": "rad"},
                         {"name": "pitch", "kind": "angle", "axis": "y", "units": "rad"},
                         {"name": "imu_fy", "kind": "specific_force", "axis": "y", "point": [6.0, 2.0, 5.0],
                          "units": "m/s^2"},
                         {"name": "imu_fz", "kind": "specific_force", "axis": "z", "point": [6.0, 2.0, 5.0],
                          "units": "m/s^2"}],
            "priors": {"r44": {"mean": 3.4, "std": 0.5, "bounds": [2.4, 4.6]},
                       "gmt_fs": {"mean": 0.1, "std": 0.15, "bounds": [-0.3, 0.5]}}}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path


def test_a_tuned_loading_does_not_depend_on_the_origin(barge, tmp_path):
    """The DBI backend tunes r44 and gmt_fs from the σ of one beam-quartering window; the vessel model is the
    barge imported about each rotation centre, the measurements are the waterline model's at the truth."""
    from seatune.pipeline.vessel import open_vessel
    from seatune.tuning.dbi import DBI
    from seatune.tuning.forward import ChannelPower, WindowStatistics
    from seatune.tuning.interface import Observation, Parameter, SeaState

    names = ("roll:sigma", "pitch:sigma", "imu_fy:sigma", "imu_fz:sigma")
    params = [Parameter("r44", 3.4, 0.5, 2.4, 4.6), Parameter("gmt_fs", 0.1, 0.15, -0.3, 0.5)]
    means = {}
    for name, ds in barge.items():
        export_dataset(tmp_path / f"{name}.nc", ds)
        mass = RHO * float(read_capytaine_dataset(ds).disp_volume[0])
        vessel = open_vessel(_vessel(tmp_path, name, {"capytaine": {"file": f"{name}.nc"}}, mass))
        omega = vessel.db.omega
        tp, hs = 7.0, 2.0  # Pierson–Moskowitz, cos² spreading about waves from 120° off the bow
        wp = 2 * np.pi / tp
        s1 = 5 / 16 * hs**2 * wp**4 / omega**5 * np.exp(-1.25 * (wp / omega) ** 4)
        dirs = np.arange(0.0, 360.0, 15.0)
        spread = np.cos(np.radians((dirs - 120.0 + 180.0) % 360.0 - 180.0) / 2) ** 4
        spec2 = s1[:, None] * spread[None] / (spread.sum() * np.radians(15.0))
        model = WindowStatistics(ChannelPower(vessel, ("r44", "gmt_fs"), [n.split(":")[0] for n in names]), names,
                                 spec2, dirs, 0.0, (hs, tp, 60.0), {})  # β = ψ − D − 180°
        if name == "waterline":
            z = model.predict_paired(np.array([[R44, 0.0]]), np.array([[hs, tp, 60.0]]))[0]
        dbi = DBI(params, database_points=9, pmf_points=60, interpolation="cubic")
        post = dbi.update(model, Observation("w", names, z, (0.01 * z) ** 2, 3600.0),
                          SeaState.certain(("hs", "tp", "beta_deg"), (hs, tp, 60.0)))
        means[name], stds = post.mean, post.std
    assert np.all(np.abs(means["waterline"] - [R44, 0.0]) < 2.5 * stds)  # r44 and GM trade off along a ridge
    for name in ("cog", "keel"):
        assert means[name][0] == pytest.approx(means["waterline"][0], rel=2e-3)
        assert means[name][1] == pytest.approx(means["waterline"][1], abs=2e-3)


def _capytaine_roots(barge) -> np.ndarray:
    """The undamped roots of Capytaine's own impedance (det Re Z = 0) about the keel, sorted."""
    ds = barge["keel"].sel(omega=OMEGA)
    z = capytaine_impedance(ds).sel(influenced_dof=list(DOFS), radiating_dof=list(DOFS)).transpose(
        "omega", "influenced_dof", "radiating_dof")
    om = z["omega"].values
    det = np.linalg.det((z.values * -1j * om[:, None, None]).real) / om**6  # H = −iω Z; det of the undamped part
    return np.sort(CubicSpline(om, det).roots(extrapolate=False))


@pytest.mark.parametrize("backend", ["dbi", "ukf"])
def test_a_measured_roll_mode_tunes_r44_and_pins_the_ridge(barge, tmp_path, backend):
    """identify's ω_n as a tuning observation (ModeFrequencies, variance_is_total): the measured roll root is
    Capytaine's own (det Re Z = 0 at the truth), measured to 0.8 %. With GM known, r44 comes back within 2.5σ (σ
    under 2 %, where the σ̂ model error of 5 % would allow 10 %); with gmt_fs tuned too,
    the posterior lies on the ridge: r44 and gmt_fs anti-correlated, the model's roll root at the posterior mean
    within the measurement's σ, and no 5 % model error or σ-screening applied to it."""
    from seatune.pipeline.vessel import open_vessel
    from seatune.tuning.dbi import DBI
    from seatune.tuning.forward import ModeFrequencies
    from seatune.tuning.interface import Observation, Parameter, SeaState
    from seatune.tuning.ukf import UKF

    roots = _capytaine_roots(barge)
    ds = barge["keel"]
    mass = RHO * float(read_capytaine_dataset(ds).disp_volume[0])
    export_dataset(tmp_path / "keel.nc", ds)
    vessel = open_vessel(_vessel(tmp_path, "keel", {"capytaine": {"file": "keel.nc"}}, mass))
    wn = roots[np.argmin(np.abs(roots - coupled_modes(vessel.db, vessel.base_loading).omega[0, 1]))]
    std = 0.008 * wn
    cases = {("r44",): [Parameter("r44", 3.4, 0.5, 2.4, 4.6)],
             ("r44", "gmt_fs"): [Parameter("r44", 3.4, 0.5, 2.4, 4.6), Parameter("gmt_fs", 0.1, 0.15, -0.3, 0.5)]}
    for names, params in cases.items():
        model = ModeFrequencies(vessel, names, ["Roll"])
        obs = Observation("natural_frequencies", model.names, np.array([wn]), np.array([std**2]), 0.0,
                          variance_is_total=True)
        tuner = DBI(params, database_points=9, pmf_points=200 if len(names) == 1 else 80, interpolation="cubic",
                    model_error=0.05) if backend == "dbi" else UKF(params)
        post = tuner.update(model, obs, SeaState.certain((), []))
        assert post.used == ("roll:omega_n",)
        model_wn = float(model.predict_paired(post.mean[None, :], np.zeros((1, 0)))[0, 0])
        assert abs(model_wn - wn) < (1.0 if backend == "dbi" else 2.0) * std  # the UKF: one linearised step
        if len(names) == 1:
            assert abs(post.mean[0] - R44) < 2.5 * post.std[0]
            assert post.std[0] < 0.02 * R44
        else:
            corr = post.cov[0, 1] / np.sqrt(post.cov[0, 0] * post.cov[1, 1])
            assert corr < -0.8  # a larger free-surface loss (lower GM) needs a smaller inertia for one ω_n
            assert abs(post.mean[0] - R44) < 2.5 * post.std[0] and abs(post.mean[1]) < 2.5 * post.std[1]


@pytest.fixture(scope="module")
def per_draft(tmp_path_factory):
    """The barge solved by Capytaine at three drafts (one mesh per draft), one dataset file each."""
    folder = tmp_path_factory.mktemp("per_draft")
    paths = []
    for draft in (1.8, 2.0, 2.2):
        body = _body(CENTRES["keel"], draft=draft)
        ds = _solve(body, OMEGA[::3] + [np.inf], BETA).assign(draught=draft)
        paths.append(folder / f"barge_{draft}.nc")
        export_dataset(paths[-1], ds)
    return paths


def test_per_draft_capytaine_files_make_one_database(per_draft, tmp_path):
    """Three per-draft datasets (the mesh changes with the draft) become one multi-draft database whose mass is
    tunable; at a database draft it equals the single-file import, and mismatched grids are named."""
    paths = per_draft
    db = read_capytaine_files(paths[::-1])
    assert db.drafts.tolist() == [1.8, 2.0, 2.2]
    single = read_capytaine_dataset(paths[1])
    for field in ("added_mass", "excitation_force", "buoyancy_stiffness", "disp_volume"):
        assert_allclose(getattr(db, field)[1], getattr(single, field)[0], rtol=1e-12, err_msg=field)
    mass = RHO * float(single.disp_volume[0])
    one = Loading(mass=mass, xcg=0.0, ycg=0.0, zcg=DRAFT + ZG, r44=R44, r55=R55, r66=R66, gmt_fs=0.0, gml_fs=0.0,
                  beta33=0.0, beta44=0.0, beta55=0.0)
    assert_allclose(coupled_modes(db, one).omega, coupled_modes(single, one).omega, rtol=1e-9)
    heavier = coupled_modes(db, one.with_values(mass=np.array([1.05 * mass]))).omega
    assert heavier[0, 0] < coupled_modes(db, one).omega[0, 0]  # heave slows as the mass grows

    from seatune.errors import UserError

    other = _solve(_body(CENTRES["keel"], draft=2.4), OMEGA[::4] + [np.inf], BETA).assign(draught=2.4)
    export_dataset(tmp_path / "odd.nc", other)
    with pytest.raises(UserError, match="omega") as err:
        read_capytaine_files(paths + [tmp_path / "odd.nc"])
    assert "odd.nc" in str(err.value)


def test_a_vessel_from_per_draft_files_tunes_mass(per_draft, tmp_path):
    """A vessel YAML with `hull.capytaine.files` (a glob of the three per-draft datasets) predicts, at the mass of
    its 2.0 m draft, the same channel σ as the vessel built on that one dataset (to 1e-9); it accepts a mass prior
    (the one-dataset vessel refuses it), and the DBI backend finds a mass between two drafts from the σ it gives."""
    from seatune.errors import UserError
    from seatune.pipeline.vessel import open_vessel
    from seatune.tuning.dbi import DBI
    from seatune.tuning.forward import ChannelPower, WindowStatistics
    from seatune.tuning.interface import Observation, Parameter, SeaState

    mass = RHO * float(read_capytaine_dataset(per_draft[1]).disp_volume[0])  # displacement at 2.0 m
    prior = {"mean": mass, "std": 0.03 * mass, "bounds": [0.92 * mass, 1.08 * mass]}
    many = _vessel(tmp_path, "many", {"capytaine": {"files": str(per_draft[0].parent / "barge_*.nc")}}, mass)
    spec = yaml.safe_load(many.read_text())
    spec["priors"]["mass"] = prior
    many.write_text(yaml.safe_dump(spec))
    one = _vessel(tmp_path, "one", {"capytaine": {"file": str(per_draft[1])}}, mass)
    vessels = {"many": open_vessel(many), "one": open_vessel(one)}
    assert vessels["many"].db.drafts.tolist() == [1.8, 2.0, 2.2]

    names = ("roll:sigma", "pitch:sigma", "imu_fy:sigma", "imu_fz:sigma")
    channels = [n.split(":")[0] for n in names]
    omega = vessels["one"].db.omega
    tp, hs, wp = 7.0, 2.0, 2 * np.pi / 7.0
    s1 = 5 / 16 * hs**2 * wp**4 / omega**5 * np.exp(-1.25 * (wp / omega) ** 4)
    dirs = np.arange(0.0, 360.0, 15.0)
    spread = np.cos(np.radians((dirs - 120.0 + 180.0) % 360.0 - 180.0) / 2) ** 4
    spec2 = s1[:, None] * spread[None] / (spread.sum() * np.radians(15.0))
    theta = np.array([[hs, tp, 60.0]])

    def statistics(vessel, parameters):
        return WindowStatistics(ChannelPower(vessel, parameters, channels), names, spec2, dirs, 0.0, (hs, tp, 60.0), {})

    sigma = {k: statistics(v, ("r44",)).predict_paired(np.array([[R44]]), theta)[0] for k, v in vessels.items()}
    assert_allclose(sigma["many"], sigma["one"], rtol=1e-9)

    spec = yaml.safe_load(one.read_text())
    spec["priors"]["mass"] = prior
    one.write_text(yaml.safe_dump(spec))
    with pytest.raises(UserError, match="single-draft"):
        open_vessel(one)

    heavy = 1.04 * mass  # between the 2.0 and 2.2 m drafts
    by_mass = statistics(vessels["many"], ("mass",))
    z = by_mass.predict_paired(np.array([[heavy]]), theta)[0]
    assert np.max(np.abs(z / by_mass.predict_paired(np.array([[mass]]), theta)[0] - 1)) > 0.01  # mass shows
    dbi = DBI([Parameter("mass", mass, 0.03 * mass, 0.92 * mass, 1.08 * mass)], database_points=9, pmf_points=80,
              interpolation="cubic")
    post = dbi.update(by_mass, Observation("w", names, z, (0.01 * z) ** 2, 3600.0),
                      SeaState.certain(("hs", "tp", "beta_deg"), (hs, tp, 60.0)))
    assert post.mean[0] == pytest.approx(heavy, rel=0.01)
    assert abs(post.mean[0] - heavy) < 2 * post.std[0]


def test_per_draft_wamit_runs_make_the_same_database(tmp_path):
    """The barge's three per-draft BEM runs (one KG, so the centre of gravity sits at a different height above each
    run's waterline), written by Capytaine's own WAMIT exporter, read through `hull.wamit.runs`, give the database
    the Capytaine files of the same runs give (to the 7 digits WAMIT files carry), and a tunable mass."""
    from capytaine.io.wamit import export_to_wamit

    from seatune.errors import UserError
    from seatune.pipeline.vessel import open_vessel

    kg = DRAFT + ZG
    runs, files = [], []
    for draft in (1.8, 2.0, 2.2):
        body = _body(CENTRES["waterline"], draft=draft, zg=kg - draft)
        ds = _solve(body, OMEGA[::3] + [np.inf], BETA).assign(draught=draft)
        files.append(f"barge_{draft}.nc")
        export_dataset(tmp_path / files[-1], ds)
        export_to_wamit(ds, str(tmp_path / f"run_{draft}"), exports=("1", "3", "hst"))
        runs.append({"prefix": f"run_{draft}", "draft": draft, "mass": float(RHO * body.volume)})
    mass = runs[1]["mass"]
    prior = {"mass": {"mean": mass, "std": 0.03 * mass, "bounds": [0.92 * mass, 1.08 * mass]}}
    paths = {}
    for name, hull in (("wamit", {"wamit": {"runs": runs}}), ("capytaine", {"capytaine": {"files": files}})):
        paths[name] = _vessel(tmp_path, name, hull, mass)
        spec = yaml.safe_load(paths[name].read_text())
        spec["priors"] |= prior
        paths[name].write_text(yaml.safe_dump(spec))
    wamit, capy = (open_vessel(paths[k]).db for k in ("wamit", "capytaine"))
    assert wamit.drafts.tolist() == capy.drafts.tolist() == [1.8, 2.0, 2.2]
    # Capytaine's .1 writer swaps WAMIT's I (force) and J (motion), and its coarse BEM matrices are not symmetric
    swapped = ("added_mass", "radiation_damping", "added_mass_inf")
    for field in (*swapped, "excitation_force", "buoyancy_stiffness"):
        ref = getattr(capy, field).swapaxes(-1, -2) if field in swapped else getattr(capy, field)
        assert_allclose(getattr(wamit, field), ref, rtol=1e-5, atol=1e-6 * np.abs(ref).max(), err_msg=field)
    assert_allclose(wamit.disp_volume, capy.disp_volume, rtol=1e-12)
    truth = _truth(capy).with_values(mass=np.array([1.04 * mass]))  # between the 2.0 and 2.2 m drafts
    assert_allclose(coupled_modes(wamit, truth).omega, coupled_modes(capy, truth).omega, rtol=1e-5)

    spec = yaml.safe_load(paths["wamit"].read_text())
    del spec["hull"]["wamit"]["runs"][2]["mass"]  # no .frc either: the run's mass is unknown
    paths["wamit"].write_text(yaml.safe_dump(spec))
    with pytest.raises(UserError, match=r"hull.wamit.runs.2.mass"):
        open_vessel(paths["wamit"])


def test_a_mode_the_waves_do_not_reach_is_reported_with_its_reason():
    """identify never drops a DOF silently: with the wave energy above 1 rad/s and the roll prior at 0.5 rad/s,
    roll gets a row without a value that says why (and counts the windows), beside a low-confidence window."""
    from seatune.io.run_yaml import IdentifySettings
    from seatune.pipeline.identify import natural_frequency_rows

    om = np.linspace(0.2, 2.0, 200)
    s_wave = np.where(om > 1.0, 1.0, 0.0)
    window = {"window_id": "1", "modes": {"Roll": (om, np.ones_like(om), 20.0)}, "low_confidence": False,
              "omega": om, "s_wave": s_wave}
    rows = natural_frequency_rows(None, [window, {**window, "window_id": "2", "low_confidence": True}],
                                  {"Roll": 0.5}, IdentifySettings())
    roll = [r for r in rows if r["window_id"] == "all" and r["method"] == "admittance_peak_sdof"]
    assert len(roll) == 1 and np.isnan(roll[0]["omega_n"])
    assert "no wave energy at the prior ω_n 0.500 rad/s (1 of 2 windows)" in roll[0]["reason"]
    assert "low-confidence window (1 of 2 windows)" in roll[0]["reason"]

"""Importers of third-party hydro databases, checked against files written by Capytaine itself.

One small BEM problem (a 20 x 8 x 3 m box barge at 2 m draft, 96 immersed panels, solved in well under a
second) is exported with Capytaine's own writers (capytaine.io.wamit.export_to_wamit and
capytaine.io.xarray.export_dataset) and read back with seatune's readers.

Tolerances: Capytaine's WAMIT writer prints every number with 7 significant digits ("%12.6e", headings
"%12.6f" in degrees), i.e. a relative rounding of at most 5e-7 per number. Hence rtol = 1e-6 for what is
one printed number scaled (added mass, excitation Re/Im, stiffness, periods -> ω) and rtol = 2e-6 for the
damping, which is B̄ times an ω recovered from a printed period (two roundings). Stiffness entries in
which the weight terms cancel the buoyancy get atol = 1e-6 x max|C|. The netCDF round trip is exact.
"""

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

from seatune.errors import UserError
from seatune.io.capytaine_import import read_capytaine_dataset
from seatune.io.wamit import read_wamit
from seatune.physics.hydro import DOFS, save_netcdf

cpt = pytest.importorskip("capytaine")
from capytaine.io.wamit import export_to_wamit  # noqa: E402
from capytaine.io.xarray import export_dataset, separate_complex_values  # noqa: E402

RHO, G = 1025.0, 9.81
OMEGA = [0.3, 0.6, 1.0, 1.5]
BETA = list(np.arange(6) * np.pi / 3)  # equally spaced over the full circle from 0, as seatune needs
COG = (0.5, 0.0, 1.0)  # off the origin so that every weight term is non-zero but C56
X_B = 1.0  # box centred 1 m forward of the origin: x_b = 1 m, so C_b46 != 0


def _body(mass=None):
    mesh = cpt.mesh_parallelepiped(size=(20.0, 8.0, 3.0), center=(X_B, 0.0, -0.5), resolution=(10, 4, 3))
    body = cpt.FloatingBody(mesh=mesh, dofs=cpt.rigid_body_dofs(rotation_center=(0, 0, 0)),
                            center_of_mass=COG, mass=mass).immersed_part()
    return body


@pytest.fixture(scope="module")
def capy():
    """Capytaine dataset with ω = ∞, hydrostatic_stiffness (weight included) and inertia_matrix."""
    body = _body()
    body.inertia_matrix = body.compute_rigid_body_inertia(rho=RHO)
    body.hydrostatic_stiffness = body.compute_hydrostatic_stiffness(rho=RHO, g=G)
    test = xr.Dataset(coords={"omega": OMEGA + [np.inf], "wave_direction": BETA, "radiating_dof": list(body.dofs),
                              "rho": RHO, "g": G, "water_depth": np.inf})
    ds = cpt.BEMSolver().fill_dataset(test, body, progress_bar=False)
    # Independent reference for seatune's buoyancy_stiffness: Capytaine's own formula with a zero mass.
    buoyancy = _body(mass=0.0).compute_hydrostatic_stiffness(rho=RHO, g=G)
    return ds, buoyancy.sel(influenced_dof=list(DOFS), radiating_dof=list(DOFS)).values


def _sel(da, omega, *dims):
    return da.sel(omega=omega).transpose("omega", *dims).values


def _mass_cog(ds):
    return float(ds.inertia_matrix.sel(influenced_dof="Surge", radiating_dof="Surge")), ds.center_of_mass.values


def _export(ds, tmp_path, name="box"):
    prefix = tmp_path / name
    export_to_wamit(ds, str(prefix), exports=("1", "3", "hst"))
    for ext in (".1", ".3", ".hst"):  # the exporter only logs a warning when it fails
        assert (tmp_path / f"{name}{ext}").exists(), ext
    return prefix


def _weight_terms(mass, cog):
    w = np.zeros((6, 6))
    w[3, 3] = w[4, 4] = -mass * G * cog[2]
    w[3, 5], w[4, 5] = mass * G * cog[0], mass * G * cog[1]
    return w


# --- WAMIT ------------------------------------------------------------------------------------------------------------


def test_wamit_round_trip_of_capytaine_export(capy, tmp_path):
    ds, buoyancy_ref = capy
    mass, cog = _mass_cog(ds)
    db = read_wamit(_export(ds, tmp_path), draft=2.0, rho=RHO, g=G, mass=mass, center_of_mass=cog)

    assert db.drafts.tolist() == [2.0] and db.rho == RHO and db.g == G and np.isinf(db.water_depth)
    assert_allclose(db.omega, OMEGA, rtol=1e-6)
    assert_allclose(db.wave_direction, BETA, rtol=0, atol=1e-7)
    # Capytaine's .1 writer puts the radiating dof in column I and the influenced one in J, the transpose of
    # WAMIT's A_IJ (force I, motion J) that the reader follows; a coarse BEM matrix is not exactly symmetric.
    rad = ("radiating_dof", "influenced_dof")
    assert_allclose(db.added_mass[0], _sel(ds.added_mass, OMEGA, *rad), rtol=1e-6)
    assert_allclose(db.radiation_damping[0], _sel(ds.radiation_damping, OMEGA, *rad), rtol=2e-6)
    assert_allclose(db.added_mass_inf[0], ds.added_mass.sel(omega=np.inf).transpose(*rad).values, rtol=1e-6)
    a = ds.added_mass.sel(omega=OMEGA).values
    asym = np.abs(a - a.swapaxes(-1, -2)).max() / np.abs(a).max()
    assert asym > 1e-4  # so the ordering above is really tested
    assert "added_mass_inf" not in db.attrs

    # The file holds conj(X) (WAMIT's e^{+iωt}); the reader undoes it: back to Capytaine's X.
    x_ref = _sel(ds.excitation_force, OMEGA, "wave_direction", "influenced_dof")
    assert np.abs(x_ref.imag).max() > 0.1 * np.abs(x_ref).max()
    assert_allclose(db.excitation_force[0], x_ref, rtol=1e-6)

    full = ds.hydrostatic_stiffness.transpose("influenced_dof", "radiating_dof").values
    atol = 1e-6 * np.abs(full).max()
    assert_allclose(db.buoyancy_stiffness[0], full - _weight_terms(mass, cog), rtol=1e-6, atol=atol)
    assert_allclose(db.buoyancy_stiffness[0], buoyancy_ref, rtol=1e-6, atol=atol)
    assert_allclose(db.disp_volume, [mass / RHO], rtol=1e-12)
    assert_allclose(db.center_of_buoyancy[0, :2], [X_B, 0.0], atol=1e-5)
    assert np.isnan(db.center_of_buoyancy[0, 2])


def test_wamit_frc_form_2_gives_mass_and_cog(capy, tmp_path):
    ds, buoyancy_ref = capy
    prefix = _export(ds, tmp_path)
    m = ds.inertia_matrix.transpose("influenced_dof", "radiating_dof").values
    rows = "\n".join(" ".join(f"{v:.10e}" for v in row) for row in m)
    (tmp_path / "box.frc").write_text(
        "box barge, alternative form 2\n"
        "1 1 1 1 0 0 0 0 0     IOPTN(1-9)\n"
        f"{RHO}                RHO\n"
        f"{COG[0]} {COG[1]} {COG[2]}   XCG YCG ZCG\n"
        "1                     IMASS\n"
        f"{rows}\n"
        "0                     IDAMP\n"
        "0                     ISTIF\n"
        "0                     NBETAH\n"
        "0                     NFIELD\n")
    # No mass arguments needed; wrong ones are overridden by the .frc file.
    for kwargs in ({}, {"mass": 1.0, "center_of_mass": (9.0, 9.0, 9.0)}):
        db = read_wamit(prefix, draft=2.0, rho=RHO, g=G, **kwargs)
        atol = 1e-6 * np.abs(ds.hydrostatic_stiffness).max().item()
        assert_allclose(db.buoyancy_stiffness[0], buoyancy_ref, rtol=1e-6, atol=atol)
        assert_allclose(db.disp_volume, [m[0, 0] / RHO])
        assert db.attrs["weight_terms_from"] == "box.frc (mass and COG)"

    with pytest.raises(UserError, match="RHO"):
        read_wamit(prefix, draft=2.0, rho=1000.0, g=G)


def test_wamit_frc_form_1_gives_vcg_only(capy, tmp_path):
    ds, buoyancy_ref = capy
    prefix = _export(ds, tmp_path)
    mass, _ = _mass_cog(ds)
    (tmp_path / "box.frc").write_text(
        "box barge, alternative form 1\n"
        "1 1 1 1 0 0 0 0 0   IOPTN(1-9)\n"
        f"{COG[2]}           VCG\n"
        "2.5 0.0 0.0\n0.0 6.0 0.0\n0.0 0.0 6.3   XPRDCT\n"
        "0                   NBETAH\n"
        "0                   NFIELD\n")
    # z_g comes from VCG (the argument's z is overridden), mass and x_g, y_g from the arguments.
    db = read_wamit(prefix, draft=2.0, rho=RHO, g=G, mass=mass, center_of_mass=(COG[0], COG[1], -5.0))
    atol = 1e-6 * np.abs(ds.hydrostatic_stiffness).max().item()
    assert_allclose(db.buoyancy_stiffness[0], buoyancy_ref, rtol=1e-6, atol=atol)
    with pytest.raises(UserError, match="mass and centre of gravity"):
        read_wamit(prefix, draft=2.0, rho=RHO, g=G)


def test_wamit_needs_mass_and_cog(capy, tmp_path):
    prefix = _export(capy[0], tmp_path)
    with pytest.raises(UserError, match="weight terms") as err:
        read_wamit(prefix, draft=2.0, rho=RHO, g=G)
    assert err.value.source == f"{prefix}.hst"


def test_wamit_without_infinite_frequency(capy, tmp_path):
    ds = capy[0].drop_sel(omega=np.inf)
    mass, cog = _mass_cog(ds)
    db = read_wamit(_export(ds, tmp_path), draft=2.0, rho=RHO, g=G, mass=mass, center_of_mass=cog)
    assert db.attrs["added_mass_inf"] == "approximated by highest frequency"
    assert_allclose(db.added_mass_inf[0], db.added_mass[0, -1])
    assert_allclose(db.omega, OMEGA, rtol=1e-6)


def test_wamit_malformed_line_names_file_and_line(capy, tmp_path):
    prefix = _export(capy[0], tmp_path)
    path = tmp_path / "box.1"
    lines = path.read_text().splitlines()
    lines[39] = lines[39].replace("\t    1\t", "\t    x\t", 1)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError) as err:
        read_wamit(prefix, draft=2.0, mass=3.2e5, center_of_mass=COG)
    assert err.value.source == str(path) and err.value.place == "line 40"
    assert str(path) in str(err.value) and "line 40" in str(err.value)

    lines[39] = "4.188790e+00\t    1\t    1"  # too few fields
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError, match="line 40: expected PER I J A"):
        read_wamit(prefix, draft=2.0, mass=3.2e5, center_of_mass=COG)


def test_wamit_periods_must_agree(capy, tmp_path):
    prefix = _export(capy[0], tmp_path)
    path = tmp_path / "box.3"
    path.write_text("".join(line for line in path.read_text().splitlines(True) if not line.startswith("4.188790e")))
    with pytest.raises(UserError, match="missing") as err:
        read_wamit(prefix, draft=2.0, mass=3.2e5, center_of_mass=COG)
    assert err.value.source == str(path)


# --- Capytaine netCDF -------------------------------------------------------------------------------------------------


def _check_capytaine_db(db, ds, buoyancy_ref):
    d4 = ("influenced_dof", "radiating_dof")
    assert db.drafts.tolist() == [2.0]
    assert_allclose(db.omega, OMEGA, rtol=0)
    assert_allclose(db.wave_direction, BETA, rtol=0, atol=1e-12)
    assert_allclose(db.added_mass[0], _sel(ds.added_mass, OMEGA, *d4), rtol=1e-12)
    assert_allclose(db.radiation_damping[0], _sel(ds.radiation_damping, OMEGA, *d4), rtol=1e-12)
    assert_allclose(db.added_mass_inf[0], ds.added_mass.sel(omega=np.inf).transpose(*d4).values, rtol=1e-12)
    assert_allclose(db.excitation_force[0], _sel(ds.excitation_force, OMEGA, "wave_direction", "influenced_dof"),
                    rtol=1e-12)
    assert_allclose(db.buoyancy_stiffness[0], buoyancy_ref, rtol=1e-9, atol=1e-6)
    assert_allclose(db.disp_volume, [float(ds.disp_mass) / RHO], rtol=1e-12)
    assert_allclose(db.center_of_buoyancy[0], ds.center_of_buoyancy.values, rtol=1e-12)
    assert db.rho == RHO and db.g == G


def test_capytaine_netcdf_round_trip(capy, tmp_path):
    ds, buoyancy_ref = capy
    path = tmp_path / "box.nc"
    export_dataset(path, ds)
    db = read_capytaine_dataset(path)
    _check_capytaine_db(db, ds, buoyancy_ref)
    assert db.attrs["source_file"] == str(path)

    path2 = tmp_path / "box_plain.nc"  # the other way Capytaine documents: split complex values, plain xarray
    plain = separate_complex_values(ds)
    plain = plain.assign_coords({d: plain[d].values.astype(str) for d in ("radiating_dof", "influenced_dof")})
    plain.to_netcdf(path2)  # (categorical dof coordinates cast to str: Capytaine issue #683)
    _check_capytaine_db(read_capytaine_dataset(path2), ds, buoyancy_ref)


def test_capytaine_dataset_draft_and_fk_plus_diffraction(capy):
    ds, buoyancy_ref = capy
    bare = ds.drop_vars(["draught", "excitation_force"])
    _check_capytaine_db(read_capytaine_dataset(bare, draft=2.0), ds, buoyancy_ref)
    with pytest.raises(UserError, match="draught"):
        read_capytaine_dataset(bare)
    with pytest.raises(UserError, match="draught"):
        read_capytaine_dataset(ds, draft=3.0)


def test_capytaine_without_infinite_frequency(capy):
    ds = capy[0].drop_sel(omega=np.inf)
    db = read_capytaine_dataset(ds)
    assert db.attrs["added_mass_inf"] == "approximated by highest frequency"
    assert_allclose(db.added_mass_inf[0], db.added_mass[0, -1])


def test_capytaine_rotation_center_is_recorded(capy):
    """A dataset about another rotation centre is moved to the waterline origin (tests/test_modes.py checks the
    numbers against Capytaine solved about three centres); the original centre is kept in the attributes."""
    db = read_capytaine_dataset(capy[0])
    assert_allclose(db.attrs["rotation_center"], [0.0, 0.0, 0.0])


def test_seatune_layout_loads_as_is(capy, tmp_path):
    db = read_capytaine_dataset(capy[0])
    path = tmp_path / "seatune.nc"
    save_netcdf(db, path)
    back = read_capytaine_dataset(path)
    for name in ("omega", "wave_direction", "added_mass", "radiation_damping", "added_mass_inf",
                 "excitation_force", "buoyancy_stiffness", "disp_volume", "center_of_buoyancy", "drafts"):
        assert_allclose(getattr(back, name), getattr(db, name), rtol=1e-12, err_msg=name)


def _vessel_yaml(tmp_path, hull: dict, ds) -> "Path":  # noqa: F821
    import yaml

    mass, cog = _mass_cog(ds)
    spec = {"name": "imported box", "hull": hull, "rho": RHO, "g": G,
            "loading": {"mass": mass, "xcg": float(cog[0]), "ycg": float(cog[1]), "zcg": float(cog[2]) + 2.0,
                        "r44": 3.0, "r55": 6.0, "r66": 6.0}}
    path = tmp_path / "vessel.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path


@pytest.mark.parametrize("source", ["wamit", "capytaine"])
def test_imported_hull_through_vessel_yaml_gives_capytaine_gm(capy, tmp_path, source):
    """`seatune vessel info` on a WAMIT / Capytaine hull: GMT = C44/(m g) of Capytaine's own stiffness."""
    import json
    import subprocess
    import sys

    ds, _ = capy
    if source == "wamit":
        _export(ds, tmp_path)
        hull = {"wamit": {"prefix": "box", "draft": 2.0}}
    else:
        export_dataset(str(tmp_path / "box.nc"), ds)
        hull = {"capytaine": {"file": "box.nc", "draft": 2.0}}
    path = _vessel_yaml(tmp_path, hull, ds)
    res = subprocess.run([sys.executable, "-m", "seatune", "vessel", "info", str(path), "--json"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    mass, _ = _mass_cog(ds)
    c44 = float(ds.hydrostatic_stiffness.sel(influenced_dof="Roll", radiating_dof="Roll"))
    assert info["gmt_m"] == pytest.approx(c44 / (mass * G), rel=1e-5)
    assert info["draft_m"] == 2.0


def test_wamit_half_circle_is_mirrored_to_capytaines_full_circle(capy, tmp_path):
    """0…180° of the (port–starboard symmetric) box, mirrored: Capytaine's own 240°, 300° (the 7 printed digits)."""
    ds, _ = capy
    mass, cog = _mass_cog(ds)
    full = read_wamit(_export(ds, tmp_path, "full"), draft=2.0, mass=mass, center_of_mass=cog)
    half = read_wamit(_export(ds.isel(wave_direction=slice(0, 4)), tmp_path, "half"), draft=2.0, mass=mass,
                      center_of_mass=cog)
    assert_allclose(half.wave_direction, BETA, rtol=0, atol=1e-12)
    assert_allclose(half.excitation_force[0, :, 4:], _sel(ds.excitation_force, OMEGA, "wave_direction",
                                                          "influenced_dof")[:, 4:], rtol=1e-6)
    assert_allclose(half.excitation_force, full.excitation_force, rtol=1e-6)
    with pytest.raises(UserError, match="not equally spaced") as err:
        read_wamit(_export(ds.isel(wave_direction=slice(0, 3)), tmp_path, "third"), draft=2.0, mass=mass,
                   center_of_mass=cog)
    assert err.value.source == str(tmp_path / "third.3")

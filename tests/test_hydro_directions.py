"""Wave-direction grids of imported hydro databases: −180…165°, unsorted, 0…360° and, for a port–starboard
symmetric hull, the half circle 0…180° give the database every consumer indexes by, β_k = k·2π/n.

Expected numbers come from the committed sample database (Capytaine's full-circle BEM result, opened with
plain xarray) and from its RAOs on its own 0…345° grid, never from the normalisation itself.
"""

import dataclasses
import subprocess
import sys

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose

from seatune.errors import UserError
from seatune.io.capytaine_import import read_capytaine_dataset
from seatune.physics.hydro import DOFS, load_netcdf
from seatune.pipeline.sea import raos_at
from tests.conftest import SAMPLE_VESSEL

cpt = pytest.importorskip("capytaine")
from capytaine.io.xarray import separate_complex_values  # noqa: E402

CHANNELS = ["roll", "pitch", "heave_acc_C", "imu_fx", "yaw_rate"]
BETA_DEG = np.array([0.0, 10.0, 45.0, 90.0, 137.5, 180.0, 200.0, 270.0, 350.0])  # on and between grid points
OMEGA = np.linspace(0.3, 1.5, 13)
HALF = slice(0, 13)  # 0, 15, …, 180°


def _write(ds, path):
    separate_complex_values(ds).to_netcdf(path, engine="netcdf4")
    return path


def _raos(vessel, db=None):
    v = vessel if db is None else dataclasses.replace(vessel, db=db)
    dirs_from = np.mod(-BETA_DEG - 180.0, 360.0)  # heading 0: β = −D − 180° (DESIGN §3)
    return raos_at(v, v.base_loading, CHANNELS, OMEGA, dirs_from, 0.0)[0]  # (nω, nβ, nch)


def _excitation(ds):
    return ds["excitation_force"].sel(influenced_dof=list(DOFS)).transpose(
        "draft", "omega", "wave_direction", "influenced_dof").values


def _rolled(ds):  # −180…165°
    beta = ds["wave_direction"].values
    out = ds.roll(wave_direction=beta.size // 2, roll_coords=True)
    b = out["wave_direction"].values
    return out.assign_coords(wave_direction=np.where(b >= np.pi - 1e-9, b - 2 * np.pi, b))


def _shuffled(ds):
    return ds.isel(wave_direction=np.random.default_rng(3).permutation(ds.sizes["wave_direction"]))


def _closed(ds):  # 0…360°, both ends
    import xarray as xr

    end = ds.isel(wave_direction=[0]).assign_coords(wave_direction=[2 * np.pi])
    return xr.concat([ds, end], dim="wave_direction", data_vars="minimal", coords="minimal", compat="override")


@pytest.mark.parametrize("variant", [_rolled, _shuffled, _closed], ids=["minus180", "unsorted", "0to360"])
def test_same_sea_on_another_direction_grid_gives_the_original_raos(sample_dataset, sample_model, tmp_path,
                                                                     variant):
    path = _write(variant(sample_dataset), tmp_path / "hydro.nc")
    want = _raos(sample_model)
    for db in (load_netcdf(path), read_capytaine_dataset(path)):
        assert_allclose(db.wave_direction, np.radians(np.arange(24) * 15.0), rtol=0, atol=1e-12)
        assert_allclose(db.excitation_force, _excitation(sample_dataset), rtol=1e-12)
        # unnormalised, the −180° grid gave raos_at errors of 1.9–8.5 × the RAO's peak
        assert_allclose(_raos(sample_model, db), want, rtol=1e-10, atol=1e-12 * np.abs(want).max())


def test_half_circle_of_a_symmetric_hull_is_mirrored_like_capytaines_full_circle(sample_dataset, sample_model,
                                                                                  tmp_path):
    """0…180° mirrored by y → −y: F_j(2π − β) = ±F_j(β), − for sway, roll and yaw; against the 195…345°
    Capytaine solved (its mesh is not exactly symmetric: the halves differ by ≤ 4.3e-4 of the largest force)."""
    db = load_netcdf(_write(sample_dataset.isel(wave_direction=HALF), tmp_path / "half.nc"))
    assert_allclose(db.wave_direction, np.radians(np.arange(24) * 15.0), rtol=0, atol=1e-12)
    assert "mirrored" in db.attrs["wave_direction"]
    full = _excitation(sample_dataset)
    scale = np.abs(full).max(axis=(0, 1, 2))
    assert_allclose(db.excitation_force / scale, full / scale, rtol=0, atol=1e-3)
    assert (np.abs(full[:, :, 13:, [1, 3, 5]]).max(axis=(0, 1, 2)) > 0.3 * scale[[1, 3, 5]]).all()  # a wrong sign shows

    want = _raos(sample_model)
    got = _raos(sample_model, db)
    peak = np.abs(want).max(axis=(0, 1))
    assert np.abs(got - want).max(axis=(0, 1)).max() < 2e-3 * peak.max()
    assert (np.abs(got - want).max(axis=(0, 1)) < 1e-2 * peak).all()


def _off_centreline(ds, y=2.0):
    """The same hull about a reference point 2 m to port: no longer port–starboard symmetric in that frame."""
    t = np.eye(6)
    t[0, 5], t[2, 3] = -y, y  # ξ_P = T ξ_O: u_P = u_O + θ × r, r = (0, y, 0)
    out = ds.copy()
    for name in ("added_mass", "radiation_damping", "added_mass_inf"):
        da = ds[name].sel(influenced_dof=list(DOFS), radiating_dof=list(DOFS))
        out[name] = da.copy(data=np.einsum("ki,...kl,lj->...ij", t, da.values, t))
    da = ds["excitation_force"].sel(influenced_dof=list(DOFS))
    out["excitation_force"] = da.copy(data=da.values @ t)
    return out


def test_half_circle_of_an_asymmetric_hull_is_a_user_error(sample_dataset, tmp_path):
    moved = _off_centreline(sample_dataset)
    assert load_netcdf(_write(moved, tmp_path / "full.nc")).wave_direction.size == 24  # the full circle is fine
    path = _write(moved.isel(wave_direction=HALF), tmp_path / "half.nc")
    for read in (load_netcdf, read_capytaine_dataset):
        with pytest.raises(UserError, match="not port–starboard symmetric") as err:
            read(path)
        assert err.value.source == str(path) and err.value.place == "wave_direction"


@pytest.mark.parametrize("index", [np.arange(12), [0, 1, 2, 6, 12, 18], [6], np.arange(0, 24, 2)[1:]],
                         ids=["0to165", "uneven", "one", "no-zero"])
def test_grid_that_is_not_a_full_circle_is_a_user_error(sample_dataset, tmp_path, index):
    path = _write(sample_dataset.isel(wave_direction=index), tmp_path / "hydro.nc")
    with pytest.raises(UserError, match="not equally spaced over the full circle") as err:
        read_capytaine_dataset(path)
    assert err.value.source == str(path) and err.value.place == "wave_direction"


def test_cli_names_the_file_of_a_bad_direction_grid(sample_dataset, tmp_path):
    path = _write(sample_dataset.isel(wave_direction=slice(0, 12)), tmp_path / "hydro.nc")
    data = yaml.safe_load(SAMPLE_VESSEL.read_text())
    data["hydro_database"] = str(path)
    vessel = tmp_path / "vessel.yaml"
    vessel.write_text(yaml.safe_dump(data))
    res = subprocess.run([sys.executable, "-m", "seatune", "vessel", "info", str(vessel)], capture_output=True,
                         text=True)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and "wave_direction" in lines[0], res.stderr

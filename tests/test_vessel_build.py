"""`seatune vessel build` end to end on a real (coarse) Capytaine BEM: a box barge from a WAMIT GDF
mesh, checked against the analytic hydrostatics of a box, and a parametric hull."""

import json
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
import yaml

L, B, H, T_REF = 20.0, 8.0, 4.0, 2.0
RHO, G = 1025.0, 9.81


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "seatune", *map(str, args)], capture_output=True, text=True)


def write_gdf(path, faces_vertices):
    lines = ["box barge written for the seatune build test", f"1.0 {G}", "0 0", str(len(faces_vertices))]
    lines += [f"{x:.6f} {y:.6f} {z:.6f}" for face in faces_vertices for x, y, z in face]
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def box_vessel(tmp_path_factory):
    import capytaine as cpt

    tmp = tmp_path_factory.mktemp("box")
    mesh = cpt.mesh_parallelepiped(size=(L, B, H), center=(0, 0, H / 2 - T_REF), resolution=(10, 4, 4))
    faces = mesh.vertices[np.asarray(mesh.faces)]
    write_gdf(tmp / "box.gdf", faces)
    spec = {
        "name": "box barge",
        "hull": {"mesh": {"file": "box.gdf", "draft": T_REF}},
        "hydro_database": "box_hydro.nc",
        "drafts": [1.5, 2.5],
        "rho": RHO, "g": G,
        "bem": {"omega_min": 0.6, "omega_max": 1.2, "n_omega": 2, "n_wave_directions": 4},
        "loading": {"mass": RHO * L * B * T_REF, "zcg": 2.0, "r44": 3.0, "r55": 6.0, "r66": 6.0},
        "priors": {"mass": {"std": 1000.0}},
    }
    path = tmp / "box.yaml"
    path.write_text(yaml.safe_dump(spec))
    res = run_cli("vessel", "build", path, "--no-progress")
    assert res.returncode == 0, res.stderr
    return path


def test_box_database_has_analytic_hydrostatics(box_vessel):
    ds = xr.open_dataset(box_vessel.parent / "box_hydro.nc")
    assert {"added_mass", "radiation_damping", "excitation_force", "added_mass_inf"} <= set(ds.data_vars)
    for k, T in enumerate([1.5, 2.5]):
        V = L * B * T
        C = ds["buoyancy_stiffness"].isel(draft=k)
        assert float(ds["disp_volume"][k]) == pytest.approx(V, rel=1e-9)
        assert float(ds["center_of_buoyancy"][k, 2]) == pytest.approx(-T / 2, rel=1e-9)
        assert float(C.sel(influenced_dof="Heave", radiating_dof="Heave")) == pytest.approx(RHO * G * L * B, rel=1e-9)
        roll = RHO * G * (L * B**3 / 12 - V * T / 2)  # ρg(I_xx,wp + V z_B) about the waterline origin
        pitch = RHO * G * (B * L**3 / 12 - V * T / 2)
        assert float(C.sel(influenced_dof="Roll", radiating_dof="Roll")) == pytest.approx(roll, rel=1e-9)
        assert float(C.sel(influenced_dof="Pitch", radiating_dof="Pitch")) == pytest.approx(pitch, rel=1e-9)
        assert float(ds["added_mass_inf"].isel(draft=k).sel(influenced_dof="Heave", radiating_dof="Heave")) > 0


@pytest.mark.parametrize("draft, tol", [(2.5, 1e-9), (2.0, 0.07)])
def test_box_info_gives_analytic_gm(box_vessel, draft, tol):
    """At a database draft GM is exact; between drafts the hydrostatics are linear in draft, so V·z_B
    (quadratic in T) is off by L·B·ΔT²/8 — 0.0625 m of GM for drafts 1.5 and 2.5 at T = 2.0."""
    res = run_cli("vessel", "info", box_vessel, "--json", "--set", f"mass={RHO * L * B * draft}")
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    assert info["draft_m"] == pytest.approx(draft, rel=1e-9)
    gm = draft / 2 + B**2 / (12 * draft) - 2.0  # KB + BM − KG of a box
    assert info["gmt_m"] == pytest.approx(gm, abs=tol)


def test_parametric_build_runs(tmp_path):
    spec = {
        "name": "tiny ship",
        "hull": {"parametric": {"length": 30.0, "beam": 8.0, "depth": 4.0, "bilge_radius": 1.0,
                                "stations": 12, "girth_panels": 8}},
        "hydro_database": "tiny.nc",
        "drafts": [2.0, 2.5, 3.0],
        "bem": {"omega_min": 0.5, "omega_max": 1.5, "n_omega": 2, "n_wave_directions": 4},
        "loading": {"displacement": 500.0, "zcg": 2.8, "r44": 3.0, "r55": 7.5, "r66": 7.5},
    }
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(spec))
    res = run_cli("vessel", "build", path, "--no-progress")
    assert res.returncode == 0, res.stderr
    assert "3 drafts" in res.stdout
    ds = xr.open_dataset(tmp_path / "tiny.nc")
    vol = ds["disp_volume"].values
    assert np.all(np.diff(vol) > 0)
    assert "lid" in ds.attrs["source"]
    assert not list(tmp_path.glob(".*.tmp"))  # atomic write left nothing behind

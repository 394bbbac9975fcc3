"""The second hull of the trial bank: a box barge, BEM with Capytaine, one dataset per draft.

``python -m seatune.simulate.independent.hulls [--out configs/vessels/barge]`` regenerates
``barge_d2.6.nc``, ``barge_d3.0.nc``, ``barge_d3.4.nc`` (committed). Hull: L = 60 m, B = 20 m, depth 6 m,
box with sharp bilges; drafts bracketing the design draft 3.0 m; ω 0.2–2.0 rad/s (40 values) plus ω = ∞
(radiation only), 24 wave directions over [0, 2π), infinite depth, lid panels against irregular
frequencies (the box's first one is near 1.9 rad/s, inside the band).

Each file is a Capytaine dataset as a user would export it (``capytaine.io.xarray.export_dataset``) about a
different rotation centre — waterline (2.6 m), keel (3.0 m), centre of gravity (3.4 m) — so the importer's
transform to the waterline origin is exercised. ``hydrostatic_stiffness`` follows Capytaine's convention
(buoyancy and the weight terms of ``inertia_matrix[Surge, Surge]`` at ``center_of_mass``); the buoyancy part is
the exact box formula (Capytaine's one-point panel rule on a 24 × 8 waterplane would be a few per cent off,
README "Design notes"); the coarse mesh's displaced volume is exact for a box.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import xarray as xr

LENGTH, BEAM, DEPTH = 60.0, 20.0, 6.0
DRAFTS = (2.6, 3.0, 3.4)
DESIGN_ZCG = 7.0  # m above the keel: deck cargo (the vessel YAML's prior mean)
DESIGN_XCG = 0.0
RHO, G = 1025.0, 9.81
OMEGA = np.linspace(0.2, 2.0, 40)
N_DIR = 24
RESOLUTION = (24, 8, 6)  # panels along x, y, and z over 2·draft (3 below the waterline)
DOFS = ("Surge", "Sway", "Heave", "Roll", "Pitch", "Yaw")


def file_name(draft: float) -> str:
    return f"barge_d{draft:.1f}.nc"


def rotation_centre(draft: float) -> tuple[float, float, float]:
    """Waterline origin for the light draft, keel for the design draft, the design COG for the deep one."""
    if np.isclose(draft, DRAFTS[0]):
        return (0.0, 0.0, 0.0)
    if np.isclose(draft, DRAFTS[1]):
        return (0.0, 0.0, -draft)
    return (DESIGN_XCG, 0.0, DESIGN_ZCG - draft)


def box_buoyancy_stiffness(draft: float, about=(0.0, 0.0, 0.0), rho: float = RHO, g: float = G) -> np.ndarray:
    """Exact hydrostatic stiffness of the box's buoyancy (no weight terms), rotations about `about`.

    About the waterline origin: C33 = ρg L B, C44 = ρg (L B³/12 + V z_B), C55 = ρg (B L³/12 + V z_B),
    z_B = −T/2 (symmetric box: no heave–pitch coupling). About a point r = (x_r, y_r, z_r): the waterplane
    moments are taken about x_r, y_r and the buoyancy lever about z_r: C44 = ρg(I_T + A y_r² + V (z_B − z_r)), …
    """
    xr_, yr_, zr_ = about
    awp = LENGTH * BEAM
    vol = awp * draft
    zb = -draft / 2.0
    c = np.zeros((6, 6))
    c[2, 2] = rho * g * awp
    c[2, 3] = c[3, 2] = -rho * g * awp * yr_  # ρg ∫(y − y_r) dA
    c[2, 4] = c[4, 2] = rho * g * awp * xr_  # −ρg ∫(x − x_r) dA
    c[3, 3] = rho * g * (LENGTH * BEAM**3 / 12.0 + awp * yr_**2 + vol * (zb - zr_))
    c[4, 4] = rho * g * (BEAM * LENGTH**3 / 12.0 + awp * xr_**2 + vol * (zb - zr_))
    c[3, 4] = c[4, 3] = -rho * g * awp * xr_ * yr_
    c[3, 5] = -rho * g * vol * (0.0 - xr_)  # −ρgV (x_B − x_r)
    c[4, 5] = -rho * g * vol * (0.0 - yr_)
    return c


def _weight(mass: float, cog, about, g: float = G) -> np.ndarray:
    """Capytaine's weight terms about `about`: −m g (z_G − z_r) on roll and pitch, m g (x_G − x_r) on roll–yaw …"""
    x, y, z = np.subtract(cog, about)
    w = np.zeros((6, 6))
    w[3, 3] = w[4, 4] = -mass * g * z
    w[3, 5] = mass * g * x
    w[4, 5] = mass * g * y
    return w


def _inertia(mass: float, cog, radii, about) -> np.ndarray:
    s = np.subtract(cog, about)
    sk = np.array([[0, -s[2], s[1]], [s[2], 0, -s[0]], [-s[1], s[0], 0]])
    m = np.zeros((6, 6))
    m[:3, :3] = mass * np.eye(3)
    m[:3, 3:] = -mass * sk
    m[3:, :3] = mass * sk
    m[3:, 3:] = mass * np.diag(np.square(radii)) - mass * sk @ sk
    return m


def _quiet():
    import logging

    logging.getLogger("capytaine").setLevel(logging.ERROR)


def solve_draft(draft: float, omega=OMEGA, n_dir: int = N_DIR, resolution=RESOLUTION, lid: bool = True) -> xr.Dataset:
    import capytaine as cpt

    _quiet()
    centre = rotation_centre(draft)
    mesh = cpt.mesh_parallelepiped(size=(LENGTH, BEAM, 2 * draft), center=(0.0, 0.0, 0.0), resolution=resolution)
    mesh = mesh.immersed_part()
    lid_mesh = mesh.generate_lid(z=-0.01 * draft) if lid else None
    cog = (DESIGN_XCG, 0.0, DESIGN_ZCG - draft)
    mass = RHO * LENGTH * BEAM * draft  # free floating at this draft
    body = cpt.FloatingBody(mesh=mesh, lid_mesh=lid_mesh, dofs=cpt.rigid_body_dofs(rotation_center=centre),
                            center_of_mass=cog, mass=mass, name=f"barge_d{draft:.1f}")
    stiff = box_buoyancy_stiffness(draft, centre) + _weight(mass, cog, centre)
    body.hydrostatic_stiffness = body.add_dofs_labels_to_matrix(stiff)
    body.inertia_matrix = body.add_dofs_labels_to_matrix(_inertia(mass, cog, (0.35 * BEAM, 0.25 * LENGTH,
                                                                              0.26 * LENGTH), centre))
    beta = 2 * np.pi * np.arange(n_dir) / n_dir
    test = xr.Dataset(coords={"omega": np.r_[np.asarray(omega, float), np.inf], "wave_direction": beta,
                              "radiating_dof": list(body.dofs), "rho": RHO, "g": G, "water_depth": np.inf})
    ds = cpt.BEMSolver().fill_dataset(test, body, progress_bar=False)
    ds = ds.assign(draught=xr.DataArray(draft, attrs={"units": "m", "long_name": "draught (even keel)"}))
    ds["draught"] = ds["draught"].astype(float)
    stamps = ("time", "date", "computation", "creation")  # no wall-clock times in committed files
    ds.attrs = {k: v for k, v in ds.attrs.items() if not any(w in k for w in stamps)}
    ds.attrs.update(hull=f"box barge L={LENGTH:g} m B={BEAM:g} m D={DEPTH:g} m",
                    generator="seatune.simulate.independent.hulls",
                    mesh=f"{mesh.nb_faces} hull panels" + (f" + {lid_mesh.nb_faces} lid panels" if lid else ""))
    return ds


def write(out: Path, drafts=DRAFTS, **kw) -> list[Path]:
    from capytaine.io.xarray import export_dataset

    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for d in drafts:
        t0 = time.perf_counter()
        ds = solve_draft(d, **kw)
        path = out / file_name(d)
        tmp = path.with_suffix(".tmp.nc")
        export_dataset(str(tmp), ds, format="netcdf")
        tmp.replace(path)
        print(f"{path}: draft {d} m, {time.perf_counter() - t0:.1f} s, {path.stat().st_size / 1e6:.2f} MB")
        paths.append(path)
    return paths


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="configs/vessels/barge")
    a = p.parse_args(argv)
    write(Path(a.out))


if __name__ == "__main__":
    main()

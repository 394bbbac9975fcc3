"""The hydro database at one loading condition as a dataset Capytaine's post-processing and exporters accept.

seatune's database keeps the hull's buoyancy stiffness per draft and adds the weight terms per loading
condition; Capytaine's `post_pro.rao`, `post_pro.impedance` and `io.xarray.export_dataset` (WAMIT, Nemoh)
expect one body with its `inertia_matrix` and total `hydrostatic_stiffness`. `capytaine_dataset` gives
that body at the loading's draft (A, B, F and the hydrostatics interpolated linearly in draft, as every
seatune stage does), in Capytaine's layout, names and conventions:

- dims `omega` (finite frequencies of the database), `wave_direction`, `influenced_dof`, `radiating_dof`;
  scalar coords `rho`, `g`, `water_depth`, `forward_speed` (0: the database is at zero speed), `body`;
- x(t) = Re{X e^{-iωt}}, `wave_direction` the going-to angle from body +x [rad];
- body frame: origin on the calm waterline of the loading's draft, rotations about it
  (`rotation_center` = 0), `center_of_mass` in that frame;
- `inertia_matrix` M(φ) and `hydrostatic_stiffness` C(φ) = buoyancy + weight − m g (gmt_fs, gml_fs) about
  the origin: exactly the matrices of seatune's equation of motion;
- `dissipation`: the loading's extra linear damping B_v (beta33/44/55 × critical), which Capytaine takes as
  an argument: ``capytaine.post_pro.rao(ds, dissipation=ds["dissipation"])`` is seatune's motion RAO
  (without it, the RAO of the hull with radiation damping only; the same when every beta is 0).
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import xarray as xr

from seatune.physics.hydro import DOFS, HydroDatabase
from seatune.physics.loading import Loading, load


def wavenumber(omega: np.ndarray, g: float, depth: float) -> np.ndarray:
    """Root k of ω² = g k tanh(k h) (deep water: k = ω²/g), by Newton's method from the deep-water value."""
    k = omega**2 / g
    if np.isinf(depth):
        return k
    for _ in range(50):
        th = np.tanh(k * depth)
        f = g * k * th - omega**2
        k = k - f / (g * th + g * k * depth * (1 - th**2))
    return k


def capytaine_dataset(db: HydroDatabase, loading: Loading, body: str = "vessel") -> xr.Dataset:
    """Capytaine dataset of the first loading condition of `loading` (complex values merged)."""
    lh = load(db, loading.take(slice(0, 1)))
    i0, i1, w = (a[0] for a in lh.draft_index)

    def at_draft(name: str) -> np.ndarray:
        a = getattr(db, name)
        return (1 - w) * a[i0] + w * a[i1]

    dofs = list(DOFS)
    mat = ("influenced_dof", "radiating_dof")
    k = wavenumber(db.omega, db.g, db.water_depth)
    draft = float(lh.draft[0])
    mass = float(loading.mass[0])
    ds = xr.Dataset(
        {
            "added_mass": (("omega", *mat), at_draft("added_mass")),
            "radiation_damping": (("omega", *mat), at_draft("radiation_damping")),
            "excitation_force": (("omega", "wave_direction", "influenced_dof"), at_draft("excitation_force")),
            "added_mass_inf": (mat, at_draft("added_mass_inf")),
            "inertia_matrix": (mat, lh.mass_matrix[0]),
            "hydrostatic_stiffness": (mat, lh.stiffness[0]),
            "dissipation": (mat, lh.extra_damping[0]),
            "center_of_buoyancy": ("space_coordinate", at_draft("center_of_buoyancy")),
            "disp_mass": ((), db.rho * float(at_draft("disp_volume"))),
            "draught": ((), draft),
        },
        coords={
            "omega": db.omega, "freq": ("omega", db.omega / (2 * np.pi)), "period": ("omega", 2 * np.pi / db.omega),
            "wavenumber": ("omega", k), "wavelength": ("omega", 2 * np.pi / k),
            "wave_direction": db.wave_direction, "influenced_dof": dofs, "radiating_dof": dofs,
            "space_coordinate": ["x", "y", "z"],
            "rotation_center": ("space_coordinate", np.zeros(3)),
            "center_of_mass": ("space_coordinate", lh.cog[0]),
            "body": body, "g": db.g, "rho": db.rho, "water_depth": db.water_depth, "forward_speed": 0.0,
        },
        attrs={
            **{key: val for key, val in (db.attrs or {}).items() if isinstance(val, str | int | float)},
            "seatune_loading": ", ".join(f"{p}={float(getattr(loading, p)[0]):.6g}" for p in (
                "mass", "xcg", "ycg", "zcg", "r44", "r55", "r66", "gmt_fs", "gml_fs", "beta33", "beta44", "beta55")),
            "mass_kg": mass,
            "frame": "body frame of the loading's draft: x forward, y port, z up, origin on the centreline on the "
                     "calm waterline; rotations about the origin",
            "time_convention": "x(t) = Re{X exp(-i omega t)} (Capytaine's); phases are lags",
            "wave_direction_convention": "going-to angle from body +x, counter-clockwise seen from above, rad "
                                         "(pi = head seas)",
            "dissipation_note": "extra linear damping of the loading; seatune's RAO = "
                                "capytaine.post_pro.rao(ds, dissipation=ds['dissipation'])",
        },
    )
    ds["omega"].attrs["units"] = "rad/s"
    ds["wave_direction"].attrs["units"] = "rad"
    ds["draught"].attrs.update(units="m", description="even-keel draft of the loading condition")
    ds["hydrostatic_stiffness"].attrs["description"] = (
        "buoyancy + weight stiffness about the origin, GMT/GML reduced by the free-surface corrections")
    ds["inertia_matrix"].attrs["description"] = "rigid-body mass matrix about the origin (radii about the COG)"
    ds["added_mass_inf"].attrs["description"] = "added mass at infinite frequency (Capytaine's omega = inf)"
    return ds


def save_capytaine_dataset(ds: xr.Dataset, path) -> None:
    """netCDF as `capytaine.io.xarray.save_dataset_as_netcdf` writes it (complex values along `complex`)."""
    from capytaine.io.xarray import separate_complex_values

    from seatune.atomic import atomic_path

    out = separate_complex_values(ds)
    with atomic_path(path) as tmp:
        out.to_netcdf(tmp, engine="netcdf4", encoding={"radiating_dof": {"dtype": "U"},
                                                       "influenced_dof": {"dtype": "U"}})


WAMIT_FILES = ("1", "3", "hst")  # radiation, total excitation, hydrostatics (the database has no FK/diffraction split)
NEMOH_FILES = ("RadiationCoefficients.tec", "Hydrostatics.dat", "KH.dat")


def export_capytaine(ds: xr.Dataset, out, fmt: str = "netcdf") -> list[Path]:
    """Write `ds` as netCDF, or through Capytaine's own WAMIT / Nemoh exporters; returns the files written."""
    from capytaine.io.xarray import export_dataset

    out = Path(out)
    if fmt == "netcdf":
        save_capytaine_dataset(ds, out)
        return [out]
    if fmt == "wamit":
        out.parent.mkdir(parents=True, exist_ok=True)
        export_dataset(str(out), ds, format="wamit", exports=WAMIT_FILES)
        written = [out.with_name(f"{out.name}.{ext}") for ext in WAMIT_FILES]
    elif fmt == "nemoh":
        legacy = logging.getLogger("capytaine.io.legacy")  # warns about the folder its own caller just made
        level = legacy.level
        legacy.setLevel(logging.ERROR)
        try:
            export_dataset(str(out), ds, format="nemoh")
        finally:
            legacy.setLevel(level)
        written = [out / name for name in NEMOH_FILES]
    else:
        raise ValueError(f"unknown format {fmt!r}")
    missing = [str(p) for p in written if not p.exists()]
    if missing:  # Capytaine logs its exporters' failures as warnings and goes on
        raise RuntimeError(f"Capytaine's {fmt} export did not write {', '.join(missing)}")
    return written

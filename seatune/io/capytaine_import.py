"""Import a hydro database computed by Capytaine (an xarray dataset, usually saved as netCDF).

Capytaine's conventions are seatune's (DESIGN §3): x(t) = Re{X e^{-iωt}}, `wave_direction` = going-to
angle from +x in radians, DOF names "Surge".."Yaw". What this reader has to do:

- merge the complex values (Capytaine's netCDF stores them along a `complex` dim with re/im);
- reduce the frequency grid to finite, positive ω sorted ascending; an ω = ∞ entry becomes
  `added_mass_inf` (ω = 0 entries are dropped); without ω = ∞ the highest-frequency added mass stands in
  and ``attrs['added_mass_inf']`` says so;
- split Capytaine's `hydrostatic_stiffness` (buoyancy *and* weight, computed for the body's mass and
  centre of mass, rotations about the rotation centre) into seatune's `buoyancy_stiffness` by removing
  the weight terms (:func:`weight_stiffness`), with mass = inertia_matrix[Surge, Surge] and the
  `center_of_mass` of the dataset;
- move added mass, damping, excitation and hydrostatics from the dataset's rotation centre to seatune's body
  origin (0, 0, 0) on the calm waterline, so a hull exported about its keel, its centre of gravity or the
  waterline gives the same database.

A dataset already in seatune's layout (a `buoyancy_stiffness` variable and a `draft` dim) is loaded
as it is.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from seatune.errors import UserError
from seatune.physics.hydro import DOFS, DirectionGridError, HydroDatabase
from seatune.physics.loading import skew
from seatune.physics.loading import weight_stiffness as physics_weight_stiffness

_SCALAR_DIMS = ("g", "rho", "water_depth", "forward_speed", "body")
_OTHER_FREQ_DIMS = ("period", "freq", "wavenumber", "wavelength")


def weight_stiffness(mass: float, center_of_mass, g: float) -> np.ndarray:
    """Weight terms of the stiffness (6×6) for one body: `seatune.physics.loading.weight_stiffness`."""
    return physics_weight_stiffness(np.array([float(mass)]), np.asarray(center_of_mass, dtype=float)[None], g)[0]


def center_of_buoyancy_from_stiffness(buoyancy_stiffness: np.ndarray, disp_volume: float, rho: float,
                                      g: float) -> np.ndarray:
    """(x_b, y_b, NaN) from the buoyancy part of the stiffness: C_b46 = -ρgV x_b, C_b56 = -ρgV y_b.

    z_b cannot be recovered from a stiffness matrix alone: C_b44 = ρg(∫y² dS + V z_b) and
    C_b55 = ρg(∫x² dS + V z_b) mix it with the unknown waterplane second moments, so it is NaN.
    """
    rgv = rho * g * disp_volume
    return np.array([-buoyancy_stiffness[3, 5] / rgv, -buoyancy_stiffness[4, 5] / rgv, np.nan])


def read_capytaine_dataset(path_or_dataset, *, draft: float | None = None) -> HydroDatabase:
    """Hydro database of one draft from a Capytaine dataset (or a seatune one) or its netCDF file.

    `draft` [m] is used when the dataset has no `draught` variable (Capytaine writes one from the
    mesh: the depth of its lowest vertex); when both exist they must agree.
    """
    if isinstance(path_or_dataset, xr.Dataset):
        source, ds = "Capytaine dataset", path_or_dataset
    else:
        source = str(path_or_dataset)
        ds = _open(Path(path_or_dataset))
    ds = _merge_complex(ds)
    try:
        if "buoyancy_stiffness" in ds:
            return _from_seatune_layout(ds, source, draft)
        return _from_capytaine_layout(ds, source, draft)
    except DirectionGridError as err:
        raise UserError(source, "wave_direction", str(err)) from None


def read_capytaine_files(paths) -> HydroDatabase:
    """One multi-draft hydro database from Capytaine datasets written one per draft (the mesh changes with the
    draft). Each file's draft is its `draught`; ω, wave directions, ρ, g and depth must agree across files."""
    paths = [Path(p) for p in paths]
    if not paths:
        raise UserError("hull.capytaine.files", None, "no file matches")
    return stack_drafts([read_capytaine_dataset(p) for p in paths], paths, "draught")


def stack_drafts(dbs: list[HydroDatabase], paths: list[Path], draft_field: str) -> HydroDatabase:
    """One multi-draft database from single-draft ones read from `paths` (Capytaine datasets, WAMIT runs): ω, wave
    directions, ρ, g and depth must agree, and no draft may appear twice (the file is named, with `draft_field`)."""
    first = dbs[0]
    for p, db in zip(paths[1:], dbs[1:], strict=True):
        for name in ("omega", "wave_direction"):
            a, b = getattr(first, name), getattr(db, name)
            if a.shape != b.shape or not np.allclose(a, b, rtol=1e-9, atol=1e-12):
                raise UserError(str(p), name, f"differs from {paths[0].name} ({b.size} values {b.min():.4g}–"
                                              f"{b.max():.4g} against {a.size} values {a.min():.4g}–{a.max():.4g})")
        for name in ("rho", "g", "water_depth"):
            if getattr(db, name) != getattr(first, name):
                raise UserError(str(p), name, f"is {getattr(db, name)}, {paths[0].name} has {getattr(first, name)}")
    drafts = np.array([float(db.drafts[0]) for db in dbs])
    order = np.argsort(drafts)
    if np.any(np.diff(drafts[order]) <= 0):
        k = int(order[np.argmin(np.diff(drafts[order])) + 1])
        raise UserError(str(paths[k]), draft_field, f"{drafts[k]:g} m appears in two files")
    dbs = [dbs[k] for k in order]

    def stack(name):
        return np.concatenate([getattr(db, name) for db in dbs])

    attrs = dict(first.attrs or {})
    attrs.pop("source_file", None)
    attrs["source_files"] = ", ".join(str(paths[k]) for k in order)
    return HydroDatabase(
        drafts=drafts[order], omega=first.omega, wave_direction=first.wave_direction,
        added_mass=stack("added_mass"), radiation_damping=stack("radiation_damping"),
        added_mass_inf=stack("added_mass_inf"), excitation_force=stack("excitation_force"),
        buoyancy_stiffness=stack("buoyancy_stiffness"), disp_volume=stack("disp_volume"),
        center_of_buoyancy=stack("center_of_buoyancy"), rho=first.rho, g=first.g, water_depth=first.water_depth,
        attrs=attrs)


# ----------------------------------------------------------------------------------------------------------------------


def _open(path: Path) -> xr.Dataset:
    if not path.exists():
        raise UserError(str(path), None, "file not found")
    try:
        with xr.open_dataset(path) as ds:
            return ds.load()
    except (OSError, ValueError) as err:
        raise UserError(str(path), None, f"cannot be read as a netCDF dataset ({err})") from None


def _merge_complex(ds: xr.Dataset) -> xr.Dataset:
    if "complex" in ds.dims or "complex" in ds.coords:
        from capytaine.io.xarray import merge_complex_values

        ds = merge_complex_values(ds)
    return ds


def _from_seatune_layout(ds: xr.Dataset, source: str, draft: float | None) -> HydroDatabase:
    if "draft" not in ds.dims:
        if draft is None:
            raise UserError(source, "draft", "seatune-layout dataset without a `draft` dim: pass the draft")
        ds = ds.expand_dims(draft=[float(draft)])
    elif draft is not None and not np.isclose(ds["draft"].values, draft, rtol=0, atol=1e-6).any():
        raise UserError(source, "draft", f"the database has drafts {ds['draft'].values.tolist()} m, not {draft:g} m")
    try:
        return HydroDatabase.from_dataset(ds)
    except KeyError as err:
        raise UserError(source, None, f"incomplete seatune hydro database: missing {err}") from None


def _from_capytaine_layout(ds: xr.Dataset, source: str, draft: float | None) -> HydroDatabase:
    attrs = {"source": "Capytaine dataset"}
    if source != "Capytaine dataset":
        attrs["source_file"] = source
    ds = _squeeze_scalar_dims(ds, source)
    if "forward_speed" in ds.coords and float(ds["forward_speed"]) != 0.0:
        raise UserError(source, "forward_speed", f"is {float(ds['forward_speed'])} m/s; only zero speed is supported")
    ds = _to_omega(ds, source)
    _check_dofs(ds, source)
    rc = _rotation_center(ds, attrs)
    dofs = list(DOFS)

    for name in ("added_mass", "radiation_damping", "hydrostatic_stiffness", "inertia_matrix"):
        if name not in ds:
            raise UserError(source, name, _MISSING.get(name, "missing"))
    rho, g = _scalar(ds, "rho", source), _scalar(ds, "g", source)
    water_depth = float(ds["water_depth"]) if "water_depth" in ds.coords or "water_depth" in ds else np.inf

    omega_all = ds["omega"].values.astype(float)
    regular = np.isfinite(omega_all) & (omega_all > 0)
    if not regular.any():
        raise UserError(source, "omega", "no finite, positive frequency")
    omega = np.sort(omega_all[regular])

    def rad(name: str, om) -> np.ndarray:
        da = ds[name]
        if "wave_direction" in da.dims:  # zero speed: identical for every direction (Capytaine issue #574)
            da = da.isel(wave_direction=0)
        return da.sel(omega=om, influenced_dof=dofs, radiating_dof=dofs).transpose(
            ..., "influenced_dof", "radiating_dof").values.astype(float)

    added_mass, damping = rad("added_mass", omega), rad("radiation_damping", omega)
    if np.isinf(omega_all).any():
        added_mass_inf = rad("added_mass", np.inf)
        if not np.isfinite(added_mass_inf).all():
            raise UserError(source, "added_mass", "NaN at omega = inf")
    else:
        added_mass_inf = added_mass[-1].copy()
        attrs["added_mass_inf"] = "approximated by highest frequency"

    excitation = _excitation(ds, source).sel(omega=omega, influenced_dof=dofs)
    if "wave_direction" not in excitation.dims:
        excitation = excitation.expand_dims("wave_direction")
    excitation = excitation.sortby("wave_direction").transpose("omega", "wave_direction", "influenced_dof")
    wave_direction = np.atleast_1d(excitation["wave_direction"].values).astype(float)
    excitation = excitation.values.astype(complex)
    for name, arr in (("added_mass", added_mass), ("radiation_damping", damping), ("excitation_force", excitation)):
        bad = ~np.isfinite(arr).reshape(len(omega), -1).all(axis=1)
        if bad.any():
            raise UserError(source, name, f"NaN at omega = {omega[bad][0]:g} rad/s (a BEM problem that failed?)")

    stiffness = ds["hydrostatic_stiffness"].sel(influenced_dof=dofs, radiating_dof=dofs).transpose(
        "influenced_dof", "radiating_dof").values.astype(float)
    mass = float(ds["inertia_matrix"].sel(influenced_dof="Surge", radiating_dof="Surge"))
    if not (np.isfinite(stiffness).all() and np.isfinite(mass) and mass > 0):
        raise UserError(source, "hydrostatic_stiffness", "NaN stiffness or no positive mass in inertia_matrix")
    cog = _vector(ds, "center_of_mass", source,
                  "missing: the mass and centre of mass at which hydrostatic_stiffness was computed are needed "
                  "to separate the weight terms")
    if "disp_volume" in ds:
        volume = float(ds["disp_volume"])
    elif "disp_mass" in ds:
        volume = float(ds["disp_mass"]) / rho
    else:
        volume = mass / rho
        attrs["disp_volume"] = "mass / rho (free floating)"
    # one reference for everything: the waterline origin (DESIGN §3), whatever the rotation centre was
    t = motion_transfer(rc)
    added_mass, damping = t.T @ added_mass @ t, t.T @ damping @ t
    added_mass_inf = t.T @ added_mass_inf @ t
    excitation = excitation @ t
    buoyancy = buoyancy_stiffness_to_origin(stiffness - weight_stiffness(mass, np.asarray(cog) - rc, g), rc, volume,
                                            rho, g)
    attrs.update(weight_terms_mass=mass, weight_terms_center_of_mass=np.asarray(cog, dtype=float))
    if "center_of_buoyancy" in ds:
        cob = _vector(ds, "center_of_buoyancy", source, "")
    else:
        cob = center_of_buoyancy_from_stiffness(buoyancy, volume, rho, g)
        attrs["center_of_buoyancy_z"] = "unknown: not recoverable from the stiffness matrix"

    drafts = np.array([_draft(ds, source, draft)])
    plain = str | int | float | np.integer | np.floating
    attrs.update({k: v for k, v in ds.attrs.items() if isinstance(v, plain) and k not in attrs})
    return HydroDatabase(
        drafts=drafts, omega=omega, wave_direction=wave_direction,
        added_mass=added_mass[None], radiation_damping=damping[None], added_mass_inf=added_mass_inf[None],
        excitation_force=excitation[None], buoyancy_stiffness=buoyancy[None],
        disp_volume=np.array([volume]), center_of_buoyancy=np.asarray(cob, dtype=float)[None],
        rho=rho, g=g, water_depth=water_depth, attrs=attrs,
    )


_MISSING = {
    "added_mass": "missing: no radiation results in the dataset",
    "radiation_damping": "missing: no radiation results in the dataset",
    "hydrostatic_stiffness": "missing: compute the hydrostatics (e.g. body.hydrostatic_stiffness = "
                             "body.compute_hydrostatic_stiffness()) before assembling the dataset",
    "inertia_matrix": "missing: the body mass (inertia_matrix[Surge, Surge]) is needed to separate the weight terms "
                      "from hydrostatic_stiffness",
}


def _squeeze_scalar_dims(ds: xr.Dataset, source: str) -> xr.Dataset:
    for dim in _SCALAR_DIMS:
        if dim in ds.dims:
            if ds.sizes[dim] != 1:
                what = "several bodies" if dim == "body" else f"{ds.sizes[dim]} values of {dim}"
                raise UserError(source, dim, f"dataset has {what}; seatune needs one (select it with ds.sel)")
            ds = ds.isel({dim: 0})
    return ds


def _to_omega(ds: xr.Dataset, source: str) -> xr.Dataset:
    if "omega" in ds.dims:
        return ds
    for dim in _OTHER_FREQ_DIMS:
        if dim in ds.dims:
            if "omega" in ds.coords and ds["omega"].dims == (dim,):
                return ds.swap_dims({dim: "omega"})
            if dim in ("period", "freq"):
                vals = ds[dim].values.astype(float)
                with np.errstate(divide="ignore"):
                    om = 2 * np.pi / vals if dim == "period" else 2 * np.pi * vals
                return ds.assign_coords(omega=(dim, om)).swap_dims({dim: "omega"})
            raise UserError(source, dim, "frequency given as wavenumber/wavelength without an omega coordinate")
    raise UserError(source, "omega", "no frequency dimension (omega, period or freq)")


def _check_dofs(ds: xr.Dataset, source: str) -> None:
    for dim in ("influenced_dof", "radiating_dof"):
        if dim not in ds.coords:
            raise UserError(source, dim, "missing")
        names = {str(v) for v in np.atleast_1d(ds[dim].values)}
        if names != set(DOFS):
            raise UserError(source, dim, f"is {sorted(names)}; seatune needs exactly the six rigid-body DOFs "
                                         f"{', '.join(DOFS)} of a single body")


def _rotation_center(ds: xr.Dataset, attrs: dict) -> np.ndarray:
    if "rotation_center" not in ds:
        attrs["rotation_center"] = "not recorded in the dataset; assumed (0, 0, 0)"
        return np.zeros(3)
    rc = np.atleast_1d(ds["rotation_center"].values).astype(float)
    attrs["rotation_center"] = rc
    return rc


def motion_transfer(r: np.ndarray) -> np.ndarray:
    """T with ξ_P = T ξ_O for rigid-body motions about O and about P = O + r: u_P = u_O + θ × r."""
    t = np.eye(6)
    t[:3, 3:] = -skew(np.asarray(r, dtype=float)[None])[0]
    return t


def buoyancy_stiffness_to_origin(c: np.ndarray, rc: np.ndarray, volume: float, rho: float, g: float) -> np.ndarray:
    """Buoyancy-only hydrostatic stiffness about the rotation centre rc (Capytaine's) → about the waterline
    origin (0, 0, 0). With S = ∫ over the waterplane and z_b the centre of buoyancy, about a point c:
    C33 = ρgA, C34 = ρg∫(y−y_c), C35 = −ρg∫(x−x_c), C44 = ρg∫(y−y_c)² + ρgV(z_b−z_c), C55 likewise in x,
    C45 = −ρg∫(x−x_c)(y−y_c), C46 = −ρgV(x_b−x_c), C56 = −ρgV(y_b−y_c); the waterplane integrals about rc give
    those about the origin by the parallel-axis theorem."""
    xc, yc, zc = (float(v) for v in rc)
    out = np.array(c, dtype=float)
    rg, rgv = rho * g, rho * g * volume
    area = c[2, 2] / rg
    sy, sx = c[2, 3] / rg, -c[2, 4] / rg  # ∫(y − y_c) dS, ∫(x − x_c) dS
    out[2, 3] = out[3, 2] = rg * (sy + yc * area)
    out[2, 4] = out[4, 2] = -rg * (sx + xc * area)
    out[3, 3] = c[3, 3] + rg * (2 * yc * sy + yc**2 * area) + rgv * zc
    out[4, 4] = c[4, 4] + rg * (2 * xc * sx + xc**2 * area) + rgv * zc
    out[3, 4] = out[4, 3] = c[3, 4] - rg * (yc * sx + xc * sy + xc * yc * area)
    out[3, 5] = c[3, 5] - rgv * xc
    out[4, 5] = c[4, 5] - rgv * yc
    return out


def _excitation(ds: xr.Dataset, source: str) -> xr.DataArray:
    if "excitation_force" in ds:
        return ds["excitation_force"]
    if "diffraction_force" in ds and "Froude_Krylov_force" in ds:
        return ds["diffraction_force"] + ds["Froude_Krylov_force"]
    raise UserError(source, "excitation_force", "missing (and no diffraction_force + Froude_Krylov_force)")


def _scalar(ds: xr.Dataset, name: str, source: str) -> float:
    if name not in ds.coords and name not in ds:
        raise UserError(source, name, "missing")
    return float(ds[name])


def _vector(ds: xr.Dataset, name: str, source: str, problem: str) -> np.ndarray:
    if name not in ds.coords and name not in ds:
        raise UserError(source, name, problem or "missing")
    da = ds[name]
    if "space_coordinate" in da.dims and "space_coordinate" in da.coords:
        da = da.sel(space_coordinate=["x", "y", "z"])
    vec = np.atleast_1d(da.values).astype(float)
    if vec.shape != (3,):
        raise UserError(source, name, f"expected 3 coordinates, got shape {vec.shape}")
    return vec


def _draft(ds: xr.Dataset, source: str, draft: float | None) -> float:
    if "draught" in ds:
        draught = float(ds["draught"])
        if draft is not None and not np.isclose(draught, draft, rtol=0, atol=1e-6):
            raise UserError(source, "draught",
                            f"is {draught:g} m but draft={draft:g} m was given; drop one (e.g. "
                            "ds.drop_vars('draught') when the mesh's lowest point is not the draft)")
        return draught
    if draft is None:
        raise UserError(source, "draught", "missing: pass the draft the mesh was built for (draft=...)")
    return float(draft)

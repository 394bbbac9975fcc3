"""Hydro database: BEM coefficients per draft, and their interpolation to a batch of drafts.

Body frame per draft (DESIGN §3): origin on the centreline at the hydro reference station, on the
calm waterline of that draft; rotations about the origin. Capytaine's names and axis order:
added_mass[draft, omega, influenced_dof, radiating_dof], excitation_force[draft, omega,
wave_direction, influenced_dof], complex amplitudes x(t) = Re{X e^{-iωt}}.

Every database's wave directions are normalised on construction to β_k = k·2π/n, k = 0..n−1 (what the
consumers index by), whatever order or origin (−180…165°, 0…360°) the source used; a half circle 0…180°
of a port–starboard symmetric hull is mirrored to the full circle (`_full_circle`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from seatune.errors import UserError

DOFS = ("Surge", "Sway", "Heave", "Roll", "Pitch", "Yaw")


@dataclass(frozen=True)
class HydroDatabase:
    """Arrays of a hydro database. Shapes: nd drafts, nw frequencies, nb wave directions."""

    drafts: np.ndarray  # (nd,) m
    omega: np.ndarray  # (nw,) rad/s
    wave_direction: np.ndarray  # (nb,) rad, Capytaine's going-to angle from +x; k·2π/nb after construction
    added_mass: np.ndarray  # (nd, nw, 6, 6)
    radiation_damping: np.ndarray  # (nd, nw, 6, 6)
    added_mass_inf: np.ndarray  # (nd, 6, 6)
    excitation_force: np.ndarray  # (nd, nw, nb, 6) complex, per unit wave amplitude
    buoyancy_stiffness: np.ndarray  # (nd, 6, 6) hydrostatic stiffness without the weight terms
    disp_volume: np.ndarray  # (nd,) m^3
    center_of_buoyancy: np.ndarray  # (nd, 3) body frame of each draft
    rho: float = 1025.0
    g: float = 9.81
    water_depth: float = np.inf
    attrs: dict | None = None

    def __post_init__(self):
        beta, force, note = _full_circle(self)
        object.__setattr__(self, "wave_direction", beta)
        object.__setattr__(self, "excitation_force", force)
        if note:
            object.__setattr__(self, "attrs", {**(self.attrs or {}), "wave_direction": note})

    @property
    def n_drafts(self) -> int:
        return len(self.drafts)

    @classmethod
    def from_dataset(cls, ds: xr.Dataset) -> HydroDatabase:
        ds = _merge_complex(ds)
        if "draft" not in ds.dims:
            ds = ds.expand_dims("draft")
        return cls(
            drafts=np.atleast_1d(ds["draft"].values).astype(float),
            omega=ds["omega"].values.astype(float),
            wave_direction=ds["wave_direction"].values.astype(float),
            added_mass=dof_array(ds["added_mass"], "draft", "omega"),
            radiation_damping=dof_array(ds["radiation_damping"], "draft", "omega"),
            added_mass_inf=dof_array(ds["added_mass_inf"], "draft"),
            excitation_force=dof_array(ds["excitation_force"], "draft", "omega", "wave_direction"),
            buoyancy_stiffness=dof_array(ds["buoyancy_stiffness"], "draft"),
            disp_volume=ds["disp_volume"].values.astype(float),
            center_of_buoyancy=ds["center_of_buoyancy"].transpose("draft", "space_coordinate").values,
            rho=float(ds["rho"]),
            g=float(ds["g"]),
            water_depth=float(ds["water_depth"]),
            attrs=dict(ds.attrs),
        )

    def to_dataset(self) -> xr.Dataset:
        dofs = list(DOFS)
        d4 = ("draft", "omega", "influenced_dof", "radiating_dof")
        d3 = ("draft", "influenced_dof", "radiating_dof")
        ds = xr.Dataset(
            {
                "added_mass": (d4, self.added_mass),
                "radiation_damping": (d4, self.radiation_damping),
                "added_mass_inf": (d3, self.added_mass_inf),
                "excitation_force": (("draft", "omega", "wave_direction", "influenced_dof"), self.excitation_force),
                "buoyancy_stiffness": (d3, self.buoyancy_stiffness),
                "disp_volume": ("draft", self.disp_volume),
                "center_of_buoyancy": (("draft", "space_coordinate"), self.center_of_buoyancy),
            },
            coords={
                "draft": self.drafts, "omega": self.omega, "wave_direction": self.wave_direction,
                "influenced_dof": dofs, "radiating_dof": dofs, "space_coordinate": ["x", "y", "z"],
                "rho": self.rho, "g": self.g, "water_depth": self.water_depth,
            },
            attrs=dict(self.attrs or {}),
        )
        ds["draft"].attrs["units"] = "m"
        ds["omega"].attrs["units"] = "rad/s"
        ds["wave_direction"].attrs["units"] = "rad"
        ds["buoyancy_stiffness"].attrs["description"] = (
            "hydrostatic stiffness about the origin without the weight terms (Capytaine's "
            "hydrostatic_stiffness + m g z_g on roll/pitch, - m g x_g / y_g on roll-yaw / pitch-yaw)")
        return ds

    def draft_for_volume(self, volume: np.ndarray) -> np.ndarray:
        """Even-keel draft at which the hull displaces `volume`; linear in the tabulated volumes."""
        volume = np.asarray(volume, dtype=float)
        if self.n_drafts == 1:
            return np.full(volume.shape, self.drafts[0])
        lo, hi = self.disp_volume[0], self.disp_volume[-1]
        tol = 1e-9 * hi
        if np.any(volume < lo - tol) or np.any(volume > hi + tol):
            bad = volume[(volume < lo - tol) | (volume > hi + tol)].ravel()[0]
            raise ValueError(
                f"displaced volume {bad:.1f} m^3 is outside the hydro database "
                f"({lo:.1f}-{hi:.1f} m^3, drafts {self.drafts[0]:g}-{self.drafts[-1]:g} m)")
        return np.interp(volume, self.disp_volume, self.drafts)

    def draft_weights(self, draft: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Indices (i0, i1) of the bracketing drafts and weight w of i1, for linear interpolation."""
        draft = np.asarray(draft, dtype=float)
        if self.n_drafts == 1:
            z = np.zeros(draft.shape, dtype=int)
            return z, z, np.zeros(draft.shape)
        i0 = np.clip(np.searchsorted(self.drafts, draft, side="right") - 1, 0, self.n_drafts - 2)
        w = (draft - self.drafts[i0]) / (self.drafts[i0 + 1] - self.drafts[i0])
        return i0, i0 + 1, w

    def interp(self, name: str, draft: np.ndarray) -> np.ndarray:
        """Field `name` linearly interpolated to each draft of the batch (batch axis first)."""
        i0, i1, w = self.draft_weights(draft)
        a = getattr(self, name)
        w = w.reshape(w.shape + (1,) * (a.ndim - 1))
        return (1.0 - w) * a[i0] + w * a[i1]


class DirectionGridError(ValueError):
    """The wave directions are not, and cannot be made, an equally spaced full circle from 0."""


_DIR_ATOL = 1e-5  # rad; WAMIT prints headings to 1e-6°
_SYMMETRY_RTOL = 1e-2  # sample OSV (Capytaine, symmetric mesh): 1e-6 in A and B, 4e-4 in F
_SYM, _ANTI = [0, 2, 4], [1, 3, 5]  # surge, heave, pitch | sway, roll, yaw
_MIRROR = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])  # F(2π − β) = s F(β) under y → −y


def _is_full_circle(beta: np.ndarray) -> bool:
    """Sorted β in [0, 2π): at least 4, the first at 0, equally spaced over the full circle."""
    n = beta.size
    if n < 4 or abs(beta[0]) > _DIR_ATOL:
        return False
    return np.allclose(np.diff(np.r_[beta, 2 * np.pi]), 2 * np.pi / n, rtol=0, atol=_DIR_ATOL)


def _fold(beta: np.ndarray) -> np.ndarray:
    beta = np.mod(beta, 2 * np.pi)
    return np.where(beta > 2 * np.pi - _DIR_ATOL, 0.0, beta)


def _full_circle(db: HydroDatabase) -> tuple[np.ndarray, np.ndarray, str | None]:
    """(β_k = k·2π/n, excitation on it, note): folded to [0, 2π), sorted, a repeated direction (0° and 360°)
    dropped, a half circle 0…π of a port–starboard symmetric hull mirrored; else DirectionGridError."""
    beta = _fold(np.atleast_1d(np.asarray(db.wave_direction, dtype=float)))
    force = np.asarray(db.excitation_force)
    if beta.ndim != 1 or force.ndim != 4 or force.shape[2] != beta.size:
        raise DirectionGridError(f"{beta.size} wave directions but excitation_force has shape {force.shape}")
    order = np.argsort(beta, kind="stable")
    beta, force = beta[order], force[:, :, order]
    dup = np.r_[False, np.diff(beta) < _DIR_ATOL]
    if dup.any():
        k = np.flatnonzero(dup)
        if not np.allclose(force[:, :, k], force[:, :, k - 1], rtol=1e-6, atol=1e-6 * np.abs(force).max()):
            raise DirectionGridError(f"direction {np.degrees(beta[k[0]]):g}° is given twice with different "
                                     "excitation")
        beta, force = beta[~dup], force[:, :, ~dup]
    note = None
    mirror = _fold(2 * np.pi - beta)
    new = np.abs(mirror[:, None] - beta[None, :]).min(axis=1) > _DIR_ATOL
    if not _is_full_circle(beta) and new.any() and _is_full_circle(np.sort(np.r_[beta, mirror[new]])):
        _check_port_starboard_symmetric(db, beta, force)
        src = np.degrees(beta[new])
        note = (f"{np.degrees(mirror[new]).min():g}–{np.degrees(mirror[new]).max():g}° mirrored from "
                f"{src.min():g}–{src.max():g}° (port–starboard symmetric hull: sway, roll, yaw excitation "
                "change sign)")
        beta = np.r_[beta, mirror[new]]
        force = np.concatenate([force, force[:, :, new] * _MIRROR], axis=2)
        order = np.argsort(beta, kind="stable")
        beta, force = beta[order], force[:, :, order]
    if not _is_full_circle(beta):
        step = np.diff(np.r_[beta, beta[0] + 2 * np.pi])
        raise DirectionGridError(
            f"{beta.size} wave directions {np.degrees(beta.min()):g}–{np.degrees(beta.max()):g}° (spacings "
            f"{np.degrees(step.min()):g}–{np.degrees(step.max()):g}°) are not equally spaced over the full circle "
            "from 0°: seatune needs β = k·360°/n, n ≥ 4 (a half circle 0–180° only for a port–starboard symmetric "
            "hull)")
    return np.arange(beta.size) * (2 * np.pi / beta.size), force, note


def _check_port_starboard_symmetric(db: HydroDatabase, beta: np.ndarray, force: np.ndarray) -> None:
    """No coupling of (surge, heave, pitch) with (sway, roll, yaw) in A, A(∞), B, and no sway, roll, yaw
    excitation at β = 0 and π, within _SYMMETRY_RTOL of the diagonal / the largest excitation per DOF."""
    worst, where = 0.0, ""
    for name in ("added_mass", "added_mass_inf", "radiation_damping"):
        a = np.asarray(getattr(db, name)).reshape(-1, 6, 6)
        d = np.abs(np.diagonal(a, axis1=1, axis2=2)).max(axis=0)
        scale = np.maximum(np.sqrt(np.outer(d, d)), 1e-30)
        r = (np.abs(a) / scale).max(axis=0)
        r = np.maximum(r[np.ix_(_SYM, _ANTI)], r[np.ix_(_ANTI, _SYM)].T)
        if r.max() > worst:
            i, j = np.unravel_index(np.argmax(r), r.shape)
            worst, where = r.max(), f"{name} {DOFS[_SYM[i]]}–{DOFS[_ANTI[j]]}"
    own = np.abs(beta[:, None] - np.array([0.0, np.pi])[None]).min(axis=1) < _DIR_ATOL
    f = np.abs(force[..., _ANTI])
    r = f[:, :, own].reshape(-1, 3).max(axis=0, initial=0.0) / np.maximum(f.reshape(-1, 3).max(axis=0), 1e-30)
    if r.max() > worst:
        worst, where = r.max(), f"{DOFS[_ANTI[int(np.argmax(r))]]} excitation at 0°/180°"
    if worst > _SYMMETRY_RTOL:
        raise DirectionGridError(
            f"wave directions cover half the circle and the hull is not port–starboard symmetric ({where}: "
            f"{worst:.2g} relative, more than {_SYMMETRY_RTOL:g}), so they cannot be mirrored: give the full circle")


def dof_array(da: xr.DataArray, *leading: str) -> np.ndarray:
    """Values with the given leading dims, then influenced_dof (and radiating_dof) in DOFS order."""
    dofs = [d for d in ("influenced_dof", "radiating_dof") if d in da.dims]
    return da.sel({d: list(DOFS) for d in dofs}).transpose(*leading, *dofs).values


def _merge_complex(ds: xr.Dataset) -> xr.Dataset:
    if "complex" in ds.dims:
        from capytaine.io.xarray import merge_complex_values

        ds = merge_complex_values(ds)
    return ds


def save_netcdf(db: HydroDatabase, path) -> None:
    """Write with Capytaine's convention for complex values (a `complex` dim with re/im)."""
    from capytaine.io.xarray import separate_complex_values

    from seatune.atomic import atomic_path

    ds = separate_complex_values(db.to_dataset())
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4")


def load_netcdf(path) -> HydroDatabase:
    with xr.open_dataset(path, engine="netcdf4") as ds:
        try:
            return HydroDatabase.from_dataset(ds.load())
        except DirectionGridError as err:
            raise UserError(str(path), "wave_direction", str(err)) from None

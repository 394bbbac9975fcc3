"""Hydro database: BEM coefficients per draft, and their interpolation to a batch of drafts.

Body frame per draft (DESIGN §3): origin on the centreline at the hydro reference station, on the
calm waterline of that draft; rotations about the origin. Capytaine's names and axis order:
added_mass[draft, omega, influenced_dof, radiating_dof], excitation_force[draft, omega,
wave_direction, influenced_dof], complex amplitudes x(t) = Re{X e^{-iωt}}.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

DOFS = ("Surge", "Sway", "Heave", "Roll", "Pitch", "Yaw")


@dataclass(frozen=True)
class HydroDatabase:
    """Arrays of a hydro database. Shapes: nd drafts, nw frequencies, nb wave directions."""

    drafts: np.ndarray  # (nd,) m
    omega: np.ndarray  # (nw,) rad/s
    wave_direction: np.ndarray  # (nb,) rad, Capytaine's going-to angle from +x
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
        return HydroDatabase.from_dataset(ds.load())

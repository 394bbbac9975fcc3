"""Loading condition φ → mass, stiffness and extra damping matrices, for a batch of conditions.

Every array has the batch axis first: N loading conditions. COG and points in the vessel YAML are in
the hull frame (z above baseline); `Loading.zg_body` moves them to the body frame of DESIGN §3
(origin on the calm waterline of the condition's own draft).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from seatune.physics.hydro import HydroDatabase

PARAMETERS = ("mass", "xcg", "ycg", "zcg", "r44", "r55", "r66", "gmt_fs", "gml_fs", "beta33", "beta44", "beta55")


@dataclass(frozen=True)
class Loading:
    """A batch of loading conditions; every field is an array of shape (N,). Hull frame, SI."""

    mass: np.ndarray
    xcg: np.ndarray
    ycg: np.ndarray
    zcg: np.ndarray  # above baseline
    r44: np.ndarray
    r55: np.ndarray
    r66: np.ndarray
    gmt_fs: np.ndarray
    gml_fs: np.ndarray
    beta33: np.ndarray
    beta44: np.ndarray
    beta55: np.ndarray

    def __post_init__(self):
        names = [f.name for f in fields(self)]
        arrays = np.broadcast_arrays(*(np.atleast_1d(np.asarray(getattr(self, n), dtype=float)) for n in names))
        for f, a in zip(names, arrays, strict=True):
            object.__setattr__(self, f, np.ascontiguousarray(a))

    def __len__(self) -> int:
        return self.mass.shape[0]

    @classmethod
    def from_mapping(cls, values: dict, rho: float | None = None) -> Loading:
        """From a mapping of parameter → scalar or array; `displacement` [m^3] is turned into mass."""
        values = dict(values)
        if values.get("mass") is None:
            if values.get("displacement") is None or rho is None:
                raise ValueError("a loading condition needs mass, or displacement and rho")
            values["mass"] = rho * np.asarray(values["displacement"], dtype=float)
        values.pop("displacement", None)
        return cls(**{p: values[p] for p in PARAMETERS})

    def with_values(self, **changes) -> Loading:
        return replace(self, **changes)

    def take(self, index) -> Loading:
        return Loading(**{p: getattr(self, p)[index] for p in PARAMETERS})


def skew(r: np.ndarray) -> np.ndarray:
    """[r×] for r of shape (..., 3): skew(r) @ v = r × v."""
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    o = np.zeros_like(x)
    return np.stack([np.stack([o, -z, y], -1), np.stack([z, o, -x], -1), np.stack([-y, x, o], -1)], -2)


@dataclass(frozen=True)
class LoadedHydro:
    """The hydro database evaluated for a batch: draft-interpolated coefficients and φ-matrices."""

    draft: np.ndarray  # (N,)
    cog: np.ndarray  # (N, 3) body frame
    mass_matrix: np.ndarray  # (N, 6, 6)
    stiffness: np.ndarray  # (N, 6, 6)
    extra_damping: np.ndarray  # (N, 6, 6)
    draft_index: tuple[np.ndarray, np.ndarray, np.ndarray]  # (i0, i1, w) of the database drafts


def rigid_body_mass_matrix(mass: np.ndarray, cog: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """6×6 mass matrix about the origin for mass (N,), COG (N, 3) and radii of gyration (N, 3) about the COG.

    Principal axes of inertia along the body axes (no products of inertia about the COG).
    """
    n = mass.shape[0]
    m = mass[:, None, None]
    s = skew(cog)
    M = np.zeros((n, 6, 6))
    M[:, :3, :3] = m * np.eye(3)
    M[:, :3, 3:] = -m * s  # F = m α × r_g
    M[:, 3:, :3] = m * s
    inertia_cog = m * (radii[:, :, None] ** 2 * np.eye(3))
    M[:, 3:, 3:] = inertia_cog - m * (s @ s)  # parallel-axis theorem
    return M


def weight_stiffness(mass: np.ndarray, cog: np.ndarray, g: float) -> np.ndarray:
    """Weight terms of the stiffness about the origin (rotation centre), as Capytaine writes them."""
    n = mass.shape[0]
    mg = mass * g
    C = np.zeros((n, 6, 6))
    C[:, 3, 3] = -mg * cog[:, 2]
    C[:, 4, 4] = -mg * cog[:, 2]
    C[:, 3, 5] = mg * cog[:, 0]
    C[:, 4, 5] = mg * cog[:, 1]
    return C


def critical_damping(mass_matrix: np.ndarray, added_mass_inf: np.ndarray, stiffness: np.ndarray) -> np.ndarray:
    """B_cr,dd = 2√((M_dd + A_dd(∞)) C_dd) per DOF (Han thesis eq. 2.1); zero where C_dd ≤ 0. Shape (N, 6)."""
    m = np.diagonal(mass_matrix, axis1=-2, axis2=-1) + np.diagonal(added_mass_inf, axis1=-2, axis2=-1)
    c = np.clip(np.diagonal(stiffness, axis1=-2, axis2=-1), 0.0, None)
    return 2.0 * np.sqrt(m * c)


def load(db: HydroDatabase, loading: Loading) -> LoadedHydro:
    """Evaluate M(φ), C(φ), B_v(φ) and the draft of every loading condition of the batch."""
    draft = db.draft_for_volume(loading.mass / db.rho)
    i0, i1, w = db.draft_weights(draft)
    cog = np.stack([loading.xcg, loading.ycg, loading.zcg - draft], axis=-1)
    radii = np.stack([loading.r44, loading.r55, loading.r66], axis=-1)
    M = rigid_body_mass_matrix(loading.mass, cog, radii)
    C = db.interp("buoyancy_stiffness", draft) + weight_stiffness(loading.mass, cog, db.g)
    mg = loading.mass * db.g
    C[:, 3, 3] -= mg * loading.gmt_fs  # free-surface reduction of GMT
    C[:, 4, 4] -= mg * loading.gml_fs
    a_inf = db.interp("added_mass_inf", draft)
    b_cr = critical_damping(M, a_inf, C)
    B = np.zeros_like(M)
    for dof, beta in ((2, loading.beta33), (3, loading.beta44), (4, loading.beta55)):
        B[:, dof, dof] = beta * b_cr[:, dof]
    return LoadedHydro(draft=draft, cog=cog, mass_matrix=M, stiffness=C, extra_damping=B, draft_index=(i0, i1, w))

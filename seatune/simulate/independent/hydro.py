"""Truth hydrodynamics of a trial: Capytaine datasets at the truth loading, RAOs by ``capytaine.post_pro.rao``.

Frames: vessel-YAML coordinates are in the hull frame (z above the keel); the body frame used here has its
origin on the calm waterline at midship (z_body = z_hull − draft), x forward, y to port, z up, rotations
about that origin (DESIGN §3). Complex amplitudes x(t) = Re{X e^{−iωt}} (Capytaine's).

- OSV: seatune's committed database (``buoyancy_stiffness`` per draft about the waterline origin, complex
  values along a ``complex`` dim) read with xarray, interpolated linearly in draft.
- Barge: the per-draft Capytaine datasets of :mod:`seatune.simulate.independent.hulls`, each moved from its rotation
  centre to the waterline origin by the rigid-body transform (A_o = Tᵀ A_c T, F_o = Tᵀ F_c,
  ξ_c = T ξ_o, T = [[I, −[r]×], [0, I]], r = centre − origin); buoyancy stiffness from the exact box formula.
- Weight terms (ours, as the brief): C44 += −m g z_G, C55 += −m g z_G, C46 += m g x_G, C56 += m g y_G,
  C44 −= m g gmt_fs, C55 −= m g gml_fs. Extra damping B_dd = β_dd · 2√((M_dd + A_dd(∞)) C_dd) (Han eq. 2.1).
- Coupled natural frequencies: roots of det(C − ω²(M + A(ω))) = 0, A linear in ω, found by a sign scan of
  the determinant and Brent's method, labelled by the DOF holding most of the mode's potential energy.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import xarray as xr

DOFS = ["Surge", "Sway", "Heave", "Roll", "Pitch", "Yaw"]


@dataclass
class Loading:
    mass: float
    xcg: float
    ycg: float
    zcg: float  # hull frame (above keel)
    r44: float
    r55: float
    r66: float
    gmt_fs: float = 0.0
    gml_fs: float = 0.0
    beta33: float = 0.0
    beta44: float = 0.0
    beta55: float = 0.0

    def as_dict(self) -> dict:
        return {k: float(v) for k, v in asdict(self).items()}


@dataclass
class HullData:
    """Per-draft hydrodynamics about the waterline origin of each draft."""

    name: str
    drafts: np.ndarray  # (nd,)
    volume: np.ndarray  # (nd,)
    omega: np.ndarray  # (nw,)
    beta: np.ndarray  # (nb,) going-to, from body +x [rad]
    A: np.ndarray  # (nd, nw, 6, 6)  [influenced, radiating]
    B: np.ndarray
    Ainf: np.ndarray  # (nd, 6, 6)
    F: np.ndarray  # (nd, nw, nb, 6) complex
    Cb: np.ndarray  # (nd, 6, 6) buoyancy stiffness (no weight terms)
    rho: float
    g: float
    length: float


def _merge_complex(da: xr.DataArray) -> xr.DataArray:
    from capytaine.io.xarray import merge_complex_values

    return merge_complex_values(da.to_dataset(name="x"))["x"] if "complex" in da.dims else da


def load_osv(path: str | Path) -> HullData:
    """seatune's per-draft database (the committed sample_osv_hydro.nc), read with xarray only."""
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    ex = ds["excitation_force"]
    F = (ex.sel(complex="re") + 1j * ex.sel(complex="im")).transpose("draft", "omega", "wave_direction",
                                                                    "influenced_dof")
    order = ("draft", "omega", "influenced_dof", "radiating_dof")
    return HullData(
        name=str(ds.attrs.get("vessel", "osv")), drafts=ds["draft"].values.astype(float),
        volume=ds["disp_volume"].values.astype(float), omega=ds["omega"].values.astype(float),
        beta=ds["wave_direction"].values.astype(float),
        A=ds["added_mass"].transpose(*order).values, B=ds["radiation_damping"].transpose(*order).values,
        Ainf=ds["added_mass_inf"].transpose("draft", "influenced_dof", "radiating_dof").values,
        F=F.values, Cb=ds["buoyancy_stiffness"].transpose("draft", "influenced_dof", "radiating_dof").values,
        rho=float(ds["rho"]), g=float(ds["g"]), length=float(ds.attrs.get("length", 96.0)))


def _skew(r) -> np.ndarray:
    x, y, z = r
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def shift_matrix(r) -> np.ndarray:
    """T with ξ_c = T ξ_o for a rotation centre c at r from the origin o."""
    t = np.eye(6)
    t[:3, 3:] = -_skew(r)
    return t


def load_barge(paths) -> HullData:
    """Per-draft Capytaine datasets (any rotation centre) → arrays about each draft's waterline origin."""
    from seatune.simulate.independent.hulls import BEAM, LENGTH, box_buoyancy_stiffness

    rows = []
    for p in paths:
        with xr.open_dataset(p) as ds:
            ds = ds.load()
        draft = float(ds["draught"])
        t = shift_matrix(np.asarray(ds["rotation_center"].values, float))
        dims = ("omega", "influenced_dof", "radiating_dof")
        a = ds["added_mass"].sel(influenced_dof=DOFS, radiating_dof=DOFS).transpose(*dims)
        b = ds["radiation_damping"].sel(influenced_dof=DOFS, radiating_dof=DOFS).transpose(*dims)
        fin = np.isfinite(ds["omega"].values)
        exc = _merge_complex(ds["diffraction_force"]) + _merge_complex(ds["Froude_Krylov_force"])
        exc = exc.sel(influenced_dof=DOFS).transpose("omega", "wave_direction", "influenced_dof").values[fin]
        A = np.einsum("ji,wjk,kl->wil", t, a.values[fin], t)
        B = np.einsum("ji,wjk,kl->wil", t, b.values[fin], t)
        Ainf = t.T @ a.values[~fin][0] @ t if (~fin).any() else A[-1]
        F = np.einsum("ji,wbj->wbi", t, exc)
        rows.append(dict(draft=draft, A=A, B=B, Ainf=Ainf, F=F, Cb=box_buoyancy_stiffness(draft),
                         V=LENGTH * BEAM * draft, omega=ds["omega"].values[fin],
                         beta=ds["wave_direction"].values, rho=float(ds["rho"]), g=float(ds["g"])))
    rows.sort(key=lambda r: r["draft"])
    st = lambda k: np.stack([r[k] for r in rows])  # noqa: E731
    return HullData(name="barge", drafts=st("draft"), volume=st("V"), omega=rows[0]["omega"],
                    beta=rows[0]["beta"], A=st("A"), B=st("B"), Ainf=st("Ainf"), F=st("F"), Cb=st("Cb"),
                    rho=rows[0]["rho"], g=rows[0]["g"], length=LENGTH)


def draft_of(hd: HullData, mass: float) -> float:
    """Even-keel draft of the displaced volume mass/ρ, linear in the tabulated volumes."""
    return float(np.interp(mass / hd.rho, hd.volume, hd.drafts))


@dataclass
class Condition:
    """The hull at one loading: everything about the waterline origin of its draft."""

    hull: HullData
    loading: Loading
    draft: float
    omega: np.ndarray
    beta: np.ndarray
    A: np.ndarray  # (nw, 6, 6)
    B: np.ndarray
    Ainf: np.ndarray
    F: np.ndarray  # (nw, nb, 6)
    M: np.ndarray  # (6, 6)
    C: np.ndarray  # (6, 6) buoyancy + weight − free-surface
    Bv: np.ndarray  # (6, 6) extra linear damping

    @property
    def cog(self) -> np.ndarray:
        lo = self.loading
        return np.array([lo.xcg, lo.ycg, lo.zcg - self.draft])

    def at_omega(self, omega: np.ndarray) -> Condition:
        """A, B, F linearly interpolated to other frequencies (clamped at the ends)."""
        w = np.asarray(omega, dtype=float)

        def lin(x):
            flat = x.reshape(x.shape[0], -1)
            out = np.stack([np.interp(w, self.omega, flat[:, j].real) for j in range(flat.shape[1])], axis=1)
            if np.iscomplexobj(x):
                out = out + 1j * np.stack([np.interp(w, self.omega, flat[:, j].imag)
                                           for j in range(flat.shape[1])], axis=1)
            return out.reshape((w.size,) + x.shape[1:])

        return replace(self, omega=w, A=lin(self.A), B=lin(self.B), F=lin(self.F))


def mass_matrix(mass: float, cog, radii) -> np.ndarray:
    s = _skew(cog)
    m = np.zeros((6, 6))
    m[:3, :3] = mass * np.eye(3)
    m[:3, 3:] = -mass * s
    m[3:, :3] = mass * s
    m[3:, 3:] = mass * np.diag(np.square(radii)) - mass * s @ s  # parallel axis theorem
    return m


def condition(hd: HullData, lo: Loading) -> Condition:
    d = draft_of(hd, lo.mass)
    i1 = int(np.clip(np.searchsorted(hd.drafts, d), 1, hd.drafts.size - 1))
    i0 = i1 - 1
    w = (d - hd.drafts[i0]) / (hd.drafts[i1] - hd.drafts[i0])
    mix = lambda x: (1 - w) * x[i0] + w * x[i1]  # noqa: E731
    cog = np.array([lo.xcg, lo.ycg, lo.zcg - d])
    M = mass_matrix(lo.mass, cog, (lo.r44, lo.r55, lo.r66))
    mg = lo.mass * hd.g
    C = mix(hd.Cb).copy()
    C[3, 3] += -mg * cog[2] - mg * lo.gmt_fs
    C[4, 4] += -mg * cog[2] - mg * lo.gml_fs
    C[3, 5] += mg * cog[0]
    C[4, 5] += mg * cog[1]
    Ainf = mix(hd.Ainf)
    Bv = np.zeros((6, 6))
    for dof, beta in ((2, lo.beta33), (3, lo.beta44), (4, lo.beta55)):
        Bv[dof, dof] = beta * 2.0 * np.sqrt(max((M[dof, dof] + Ainf[dof, dof]) * C[dof, dof], 0.0))  # Han eq. 2.1
    return Condition(hull=hd, loading=lo, draft=d, omega=hd.omega, beta=hd.beta, A=mix(hd.A), B=mix(hd.B),
                     Ainf=Ainf, F=mix(hd.F), M=M, C=C, Bv=Bv)


def capytaine_dataset(c: Condition) -> xr.Dataset:
    """The condition as a Capytaine-style dataset (rotation centre = the waterline origin)."""
    dims = ("omega", "influenced_dof", "radiating_dof")
    coords = {"omega": c.omega, "wave_direction": c.beta, "influenced_dof": DOFS, "radiating_dof": DOFS}
    return xr.Dataset(
        {"added_mass": (dims, c.A), "radiation_damping": (dims, c.B),
         "excitation_force": (("omega", "wave_direction", "influenced_dof"), c.F),
         "inertia_matrix": (("influenced_dof", "radiating_dof"), c.M),
         "hydrostatic_stiffness": (("influenced_dof", "radiating_dof"), c.C)},
        coords=coords)


def _dof_matrix(m: np.ndarray) -> xr.DataArray:
    return xr.DataArray(m, dims=("influenced_dof", "radiating_dof"), coords={"influenced_dof": DOFS,
                                                                             "radiating_dof": DOFS})


def capytaine_rao(c: Condition) -> np.ndarray:
    """ξ (nw, nb, 6) per unit wave amplitude from ``capytaine.post_pro.rao`` with the extra damping."""
    from capytaine.post_pro.rao import rao

    r = rao(capytaine_dataset(c), dissipation=_dof_matrix(c.Bv))
    return r.transpose("omega", "wave_direction", "radiating_dof").values


def impedance(c: Condition) -> np.ndarray:
    """H (nw, 6, 6) [influenced, radiating] from Capytaine's ``rao_transfer_function``."""
    from capytaine.post_pro.impedance import rao_transfer_function

    h = rao_transfer_function(capytaine_dataset(c), dissipation=_dof_matrix(c.Bv))
    return h.transpose("omega", "influenced_dof", "radiating_dof").values


def coupled_natural_frequencies(c: Condition, w_lo: float | None = None, w_hi: float | None = None) -> dict:
    """{heave, roll, pitch: ω [rad/s]}: roots of det(C − ω²(M + A(ω))) = 0, A linear in ω (clamped)."""
    from scipy.optimize import brentq

    w_lo = float(c.omega[0]) if w_lo is None else w_lo
    w_hi = float(c.omega[-1]) if w_hi is None else w_hi
    A = c.A.reshape(c.A.shape[0], 36)

    def kmat(w):
        a = np.array([np.interp(w, c.omega, A[:, j]) for j in range(36)]).reshape(6, 6)
        return c.C - w**2 * (c.M + a)

    def det(w):
        return float(np.linalg.det(kmat(w)))

    grid = np.linspace(w_lo, w_hi, 1200)
    vals = np.array([det(w) for w in grid])
    out: dict[str, float] = {}
    for i in np.flatnonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0):
        root = brentq(det, grid[i], grid[i + 1], xtol=1e-10)
        u, s, vt = np.linalg.svd(kmat(root))
        v = vt[-1]
        energy = np.abs(v * (c.C @ v))[[2, 3, 4]]
        label = ("heave", "roll", "pitch")[int(np.argmax(energy))]
        if label not in out:
            out[label] = float(root)
    return out

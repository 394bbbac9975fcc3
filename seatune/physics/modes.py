"""Natural modes of the free-floating hull: the roots of det(C − ω²(M + A(ω))) = 0, for a batch of loadings.

A free-floating hull has no restoring force in surge, sway and yaw (rows 0, 1, 5 of C are zero), so for ω ≠ 0
those rows give (M + A)_rr v_r = −(M + A)_rs v_s: roll drags sway along (it rolls about its roll centre, not
the body origin) and pitch drags surge. Eliminating v_r leaves an exact 3×3 problem in heave, roll, pitch

    (C_ss − C_sr X) v_s = ω² (M_ss − M_sr X) v_s,   X = M_rr⁻¹ M_rs,   M = M + A(ω)

solved per mode at its own frequency (A depends on ω) by fixed-point iteration. The answer does not depend on
the reference point the database is written about. The uncoupled ratio √(C_dd/(M_dd + A_dd)) is kept only as
a labelled diagnostic (`Modes.uncoupled`).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations

import numpy as np

from seatune.physics.hydro import HydroDatabase
from seatune.physics.loading import Loading, load

MODE_DOFS = (2, 3, 4)  # heave, roll, pitch: the DOFs with restoring stiffness
MODE_NAMES = ("Heave", "Roll", "Pitch")
_FREE = np.array([0, 1, 5])  # surge, sway, yaw: no stiffness
_STIFF = np.array(MODE_DOFS)
_PERMS = np.array(list(permutations(range(3))))  # (6, 3): DOF d ↦ root index


@dataclass(frozen=True)
class Modes:
    """Undamped modes of N loading conditions, in the order heave, roll, pitch (labelled by dominant DOF)."""

    omega: np.ndarray  # (N, 3) rad/s, coupled roots
    shape: np.ndarray  # (N, 3, 6) mode shapes about the body origin, the labelled DOF scaled to 1
    effective_inertia: np.ndarray  # (N, 3) generalised mass of each mode per unit of its labelled DOF
    uncoupled: np.ndarray  # (N, 3) √(C_dd / (M_dd + A_dd(ω))), diagnostic only
    draft: np.ndarray  # (N,)

    @property
    def roll_centre_z(self) -> np.ndarray:
        """Height of the roll centre above the calm waterline [m]: rolling by φ about (0, 0, z) sways the
        origin by z φ, so z = η2/η4 of the roll mode."""
        return self.shape[:, 1, 1]

    @property
    def pitch_centre_z(self) -> np.ndarray:
        """Height of the pitch centre above the waterline [m]: pitching by θ about (x, 0, z) surges the origin
        by −z θ, so z = −η1/η5 of the pitch mode."""
        return -self.shape[:, 2, 0]

    @property
    def pitch_centre_x(self) -> np.ndarray:
        """Longitudinal position of the pitch centre [m] (heave of the origin x θ: x = η3/η5 of the pitch mode)."""
        return self.shape[:, 2, 2]


def added_mass_at(db: HydroDatabase, draft_index, omega: np.ndarray, order=slice(None), tables=None) -> np.ndarray:
    """A(ω) at each condition's draft and its own ω (N,): linear in ω on the database grid, the first value below
    it and A(∞) above it; DOFs in `order` (`tables`: the database's A and A(∞) already in that order). (N, 6, 6)."""
    i0, i1, w = draft_index
    grid = db.omega
    j = np.clip(np.searchsorted(grid, omega) - 1, 0, grid.size - 2)
    f = np.clip((omega - grid[j]) / (grid[j + 1] - grid[j]), 0.0, 1.0)[:, None, None]
    wd = w[:, None, None]
    a, a_inf = tables or (db.added_mass[:, :, order][:, :, :, order], db.added_mass_inf[:, order][:, :, order])
    val = ((1 - wd) * ((1 - f) * a[i0, j] + f * a[i0, j + 1]) + wd * ((1 - f) * a[i1, j] + f * a[i1, j + 1]))
    return np.where((omega > grid[-1])[:, None, None], (1 - wd) * a_inf[i0] + wd * a_inf[i1], val)


_ORDER = np.r_[_STIFF, _FREE]  # heave, roll, pitch | surge, sway, yaw


def _reduced(mass: np.ndarray, c_ss: np.ndarray, c_sr: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Heave–roll–pitch problem with surge, sway, yaw eliminated, `mass` in _ORDER: (K, M_eff, X), v_r = −X v_s."""
    x = np.linalg.solve(mass[:, 3:, 3:], mass[:, 3:, :3])
    return c_ss - c_sr @ x, mass[:, :3, :3] - mass[:, :3, 3:] @ x, x


def _cubic_roots(b: np.ndarray) -> np.ndarray:
    """The three eigenvalues of each real 3×3 matrix with real spectrum, from its characteristic polynomial
    (trigonometric solution, one Newton polish): (N, 3). Several times faster than a batched `eig`."""
    tr = np.trace(b, axis1=-2, axis2=-1)
    minors = (b[:, 0, 0] * b[:, 1, 1] - b[:, 0, 1] * b[:, 1, 0] + b[:, 0, 0] * b[:, 2, 2] - b[:, 0, 2] * b[:, 2, 0]
              + b[:, 1, 1] * b[:, 2, 2] - b[:, 1, 2] * b[:, 2, 1])
    det = np.linalg.det(b)
    a2, a1, a0 = -tr, minors, -det  # λ³ + a2 λ² + a1 λ + a0
    p = a1 - a2**2 / 3
    q = 2 * a2**3 / 27 - a2 * a1 / 3 + a0
    r = np.sqrt(np.clip(-p / 3, 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        arg = np.clip(np.where(r > 0, -q / (2 * r**3), 0.0), -1.0, 1.0)
    phi = np.arccos(arg)[:, None] / 3 - 2 * np.pi / 3 * np.arange(3)
    lam = 2 * r[:, None] * np.cos(phi) - a2[:, None] / 3
    f = ((lam + a2[:, None]) * lam + a1[:, None]) * lam + a0[:, None]
    df = (3 * lam + 2 * a2[:, None]) * lam + a1[:, None]
    return lam - np.where(np.abs(df) > 0, f / np.where(df == 0, 1.0, df), 0.0)


def _null_vector(b: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """v with (B − λI) v = 0 for each 3×3 B and eigenvalue λ: the longest cross product of two rows. (N, 3)."""
    d = b - lam[:, None, None] * np.eye(3)
    cand = np.stack([np.cross(d[:, 0], d[:, 1]), np.cross(d[:, 0], d[:, 2]), np.cross(d[:, 1], d[:, 2])], axis=1)
    best = np.argmax(np.einsum("nki,nki->nk", cand, cand), axis=1)
    return cand[np.arange(b.shape[0]), best]


def coupled_modes(db: HydroDatabase, loading: Loading, rtol: float = 1e-10, iterations: int = 60) -> Modes:
    """Coupled natural frequencies and mode shapes of every loading condition (see the module docstring).

    The j-th smallest root is found at its own frequency, ω_j = √λ_(j)(A(ω_j)), by a secant iteration from A(∞);
    all N conditions and the three roots are iterated together. Ordering by size keeps each root continuous when
    heave and pitch come close and mix; the converged modes are then labelled by the DOF holding most of their
    potential energy. A mode with no positive stiffness (e.g. GM ≤ 0) has ω = NaN.
    """
    lh = load(db, loading)
    n = len(loading)
    rep = np.repeat(np.arange(n), 3)
    rows, pick = np.arange(3 * n), np.tile(np.arange(3), n)
    mrb = lh.mass_matrix[:, _ORDER[:, None], _ORDER][rep]
    c = lh.stiffness[:, _ORDER[:, None], _ORDER][rep]
    c_ss, c_sr = c[:, :3, :3], c[:, :3, 3:]
    index = tuple(a[rep] for a in lh.draft_index)
    tables = (db.added_mass[:, :, _ORDER][:, :, :, _ORDER], db.added_mass_inf[:, _ORDER][:, :, _ORDER])
    omega = np.full(3 * n, np.inf)  # A(∞) to start
    k, m, b = (np.empty((3 * n, 3, 3)) for _ in range(3))
    x, mass, lam = np.empty((3 * n, 3, 3)), np.empty((3 * n, 6, 6)), np.empty(3 * n)
    prev_omega, prev_h = np.full(3 * n, np.nan), np.full(3 * n, np.nan)
    act = rows
    for it in range(iterations):  # secant on h(ω) = √λ(A(ω)) − ω, on the roots not yet converged
        sub = tuple(a[act] for a in index)
        mass[act] = mrb[act] + added_mass_at(db, sub, omega[act], tables=tables)
        k[act], m[act], x[act] = _reduced(mass[act], c_ss[act], c_sr[act])
        b[act] = np.linalg.solve(m[act], k[act])
        lam[act] = np.sort(_cubic_roots(b[act]), axis=1)[np.arange(act.size), pick[act]]
        stable = lam[act] > 0
        root = np.sqrt(np.where(stable, lam[act], 0.0))
        if it == 0:
            omega = root
            continue
        h = root - omega[act]
        going = (np.abs(h) > rtol * omega[act]) & stable
        if not going.any():
            break
        act, h = act[going], h[going]
        step = h  # plain fixed point ω ← √λ(A(ω)) until two points give a secant
        dh = h - prev_h[act]
        safe = np.abs(dh) > 1e-300  # False while there is no previous point (NaN)
        gain = -(omega[act] - prev_omega[act]) / np.where(safe, dh, 1.0)  # 1/(1 − g'(ω)), 1 for a flat A(ω)
        step = np.where(safe & (gain > 0.1) & (gain < 10.0), h * gain, h)
        prev_omega[act], prev_h[act] = omega[act], h
        omega[act] = np.clip(omega[act] + step, 0.0, None)
    omega = np.where(lam > 0, omega, np.nan)
    v_s = _null_vector(b, lam)
    # label: root j of condition n is the mode of the DOF with the largest share |K_dd| v_d², as a permutation
    energy = np.abs(np.diagonal(k, axis1=-2, axis2=-1)) * v_s**2
    share = (energy / np.maximum(energy.sum(axis=1, keepdims=True), 1e-300)).reshape(n, 3, 3)  # (n, root, dof)
    score = share[:, _PERMS, np.arange(3)[None, :]].sum(axis=-1)  # (n, 6): perm[d] = root of DOF d
    label = (np.arange(n)[:, None] * 3 + _PERMS[np.argmax(score, axis=1)]).ravel()  # row of (n, dof)
    dof = np.tile(np.arange(3), n)
    v_s, x, m, omega = v_s[label], x[label], m[label], omega[label]
    v_s = v_s / v_s[rows, dof][:, None]
    shape = np.zeros((3 * n, 6))
    shape[:, _STIFF] = v_s
    shape[:, _FREE] = -np.einsum("nij,nj->ni", x, v_s)
    m_eff = np.einsum("ni,nij,nj->n", v_s, m, v_s)
    mass = mass[label]
    uncoupled = np.sqrt(np.clip(c_ss[rows, dof, dof], 0.0, None) / mass[rows, dof, dof])
    return Modes(omega=omega.reshape(n, 3), shape=shape.reshape(n, 3, 6), effective_inertia=m_eff.reshape(n, 3),
                 uncoupled=uncoupled.reshape(n, 3), draft=lh.draft)


def natural_frequencies(db: HydroDatabase, loading: Loading, dofs=MODE_DOFS) -> np.ndarray:
    """Coupled ω_n [rad/s] of the modes labelled by `dofs` (a subset of heave 2, roll 3, pitch 4): (N, len(dofs))."""
    omega = coupled_modes(db, loading).omega
    return omega[:, [MODE_DOFS.index(d) for d in dofs]]


@dataclass(frozen=True)
class Inverted:
    """A loading parameter that makes the model's coupled mode match a measured ω_n, with its 1σ."""

    value: float
    std: float


def invert_mode(db: HydroDatabase, loading: Loading, parameter: str, mode: str, omega_n: float, omega_std: float,
                bounds: tuple[float, float], points: int = 201) -> Inverted:
    """Value of `parameter` (a Loading field) at which the coupled `mode` ("Heave", "Roll", "Pitch") of `loading`
    (one condition) is `omega_n`, by interpolating the mode over `points` values in `bounds` (one batched
    `coupled_modes` call); the 1σ maps ω_n ± σ_ω through the same curve. ValueError when ω_n is outside what the
    model reaches within the bounds."""
    values = np.linspace(bounds[0], bounds[1], points)
    batch = loading.take(np.zeros(points, dtype=int)).with_values(**{parameter: values})
    om = coupled_modes(db, batch).omega[:, MODE_NAMES.index(mode)]
    ok = np.isfinite(om)
    values, om = values[ok], om[ok]
    step = np.sign(np.diff(om))
    if om.size < 2 or not (np.all(step > 0) or np.all(step < 0)):
        raise ValueError(f"the {mode.lower()} mode is not monotonic in {parameter} over {bounds}")
    if not om.min() <= omega_n <= om.max():
        raise ValueError(f"measured {mode.lower()} ω_n {omega_n:.4f} rad/s is outside {om.min():.4f}–{om.max():.4f} "
                         f"rad/s, what the model gives for {parameter} in {bounds[0]:.4g}–{bounds[1]:.4g}")
    order = np.argsort(om)
    om, values = om[order], values[order]
    value = float(np.interp(omega_n, om, values))
    hi, lo = np.interp([omega_n + omega_std, omega_n - omega_std], om, values)
    return Inverted(value=value, std=float(abs(hi - lo) / 2))

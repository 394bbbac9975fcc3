"""Extension point: physical effects the tuning model lacks, each simulated by its own mechanism.

An effect acts on the synthesised trial through hooks, never through the frequency-domain model that
diagnosis will fit: `transfer` may change the 6-DOF transfer functions before the time synthesis (e.g. an
extra degree of freedom coupled to the hull, declared through `extra_dof`), `before_sensors` may change the
6-DOF motions and channels (e.g. a nonlinear roll equation integrated in the time domain), `imu` may change
what the IMU senses (e.g. its mounting). Register a new effect in EFFECTS; the scenario YAML names it under
`effects: [{kind: ..., <params>}]`, the parameters are read from the spec's extra fields.

The physics is in plain functions (`hull_system`, `augmented_solve`, `moonpool_dof`, `anti_roll_tank_dof`,
`roll_constants`, `quadratic_roll_correction`, `lever_arm_rows`) so that test-side trial generators can
use the same mechanisms without the scenario machinery.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from seatune.physics.channels import point_translation
from seatune.physics.loading import load
from seatune.physics.response import hull_system


@dataclass
class EffectContext:
    t: np.ndarray
    fs: float
    rng: np.random.Generator
    model: object
    draft: float
    xi: dict  # {0: ξ, 1: ξ̇, 2: ξ̈}, each (T, 6)
    kin: object
    channels: dict
    imu: dict = field(default_factory=dict)  # rotation (body→world), rates, force (body axes), clean
    loading: object = None  # the truth Loading (batch of one)


def effect_params(effect: Effect, spec) -> dict:
    """The effect's defaults overridden by the spec's extra fields (a pydantic spec or a plain dict)."""
    extra = spec if isinstance(spec, dict) else (spec.model_extra or {})
    return {**effect.defaults, **{k: v for k, v in extra.items() if k != "kind"}}


# ------------------------------------------------------------------ frequency domain: extra DOFs


@dataclass(frozen=True)
class ExtraDof:
    """One extra degree of freedom q coupled linearly to the hull, per frequency (n) and direction (nb).

    hull rows:  (H6 + hull_add) ξ + hull_col q = F6
    its row:    row · ξ + diag q = force
    """

    hull_add: np.ndarray  # (n, 6, 6)
    hull_col: np.ndarray  # (n, 6)
    row: np.ndarray  # (n, 6)
    diag: np.ndarray  # (n,)
    force: np.ndarray  # (n, nb)


def augmented_solve(H: np.ndarray, F: np.ndarray, dofs: list[ExtraDof]) -> tuple[np.ndarray, np.ndarray]:
    """Solve the (6+k)×(6+k) system of the hull and k extra DOFs at every frequency and direction.

    Returns the hull ξ (n, nb, 6) and the extra DOFs q (n, nb, k).
    """
    n, nb, k = H.shape[0], F.shape[1], len(dofs)
    K = np.zeros((n, 6 + k, 6 + k), dtype=complex)
    K[:, :6, :6] = H
    rhs = np.zeros((n, 6 + k, nb), dtype=complex)
    rhs[:, :6] = np.swapaxes(F, -1, -2)
    for j, d in enumerate(dofs):
        K[:, :6, :6] += d.hull_add
        K[:, :6, 6 + j] = d.hull_col
        K[:, 6 + j, :6] = d.row
        K[:, 6 + j, 6 + j] = d.diag
        rhs[:, 6 + j] = d.force
    x = np.swapaxes(np.linalg.solve(K, rhs), -1, -2)  # (n, nb, 6+k)
    return x[..., :6], x[..., 6:]


def augmented_raos(db, loading, omega: np.ndarray, dofs: list[ExtraDof]) -> tuple[np.ndarray, np.ndarray]:
    """Hull ξ (n, nb, 6) and extra DOFs (n, nb, k) per unit wave amplitude, solved at each ω."""
    H, F = hull_system(db, loading, omega)
    return augmented_solve(H, F, dofs)


def loading_draft(db, loading) -> float:
    return float(db.draft_for_volume(loading.mass[:1] / db.rho)[0])


def moonpool_dof(omega: np.ndarray, beta: np.ndarray, draft: float, rho: float, g: float, omega_p: float = 1.0,
                 zeta_p: float = 0.08, area: float = 64.0, x: float = 20.0, y: float = 0.0) -> ExtraDof:
    """Moonpool piston mode ζ (absolute heave of the water column) at (x, y), opening at the keel.

    r = point_translation((x, y, 0), z): r·ξ = hull heave at the moonpool. c_p = ρ g area,
    m_p = c_p/ω_p², b_p = 2 ζ_p √(c_p m_p), c̃ = c_p − iω b_p (relative spring and dashpot):
        hull rows:   (H6 + c̃ r rᵀ) ξ − c̃ r ζ = F6
        column row:  −c̃ rᵀ ξ + (−ω² m_p + c̃) ζ = f_p,  f_p = c̃ e^{−k d} e^{i k (x cos β + y sin β)},
    k = ω²/g, d = draft (the incident wave's heave at the keel opening drives the column).
    """
    c_p = rho * g * area
    m_p = c_p / omega_p**2
    b_p = 2.0 * zeta_p * math.sqrt(c_p * m_p)
    c = c_p - 1j * omega * b_p  # (n,)
    r = point_translation(np.array([x, y, 0.0]), 2)
    k = omega**2 / g
    eta_keel = np.exp(-k * draft)[:, None] * np.exp(1j * k[:, None] * (x * np.cos(beta) + y * np.sin(beta)))
    return ExtraDof(hull_add=c[:, None, None] * np.outer(r, r), hull_col=-c[:, None] * r, row=-c[:, None] * r,
                    diag=-(omega**2) * m_p + c, force=c[:, None] * eta_keel)


def roll_inertia(db, loading) -> tuple[float, float]:
    """(I44 + A44(ω_n), ω_n): rigid-body roll inertia about the body origin plus the database added mass at the
    coupled roll natural frequency (`physics.modes`), at the loading's draft."""
    from seatune.physics.modes import coupled_modes

    one = loading.take(slice(0, 1))
    lh = load(db, one)
    i0, i1, w = (a[0] for a in lh.draft_index)
    wn = float(coupled_modes(db, one).omega[0, 1])
    a44 = (1 - w) * db.added_mass[i0, :, 3, 3] + w * db.added_mass[i1, :, 3, 3]
    return float(lh.mass_matrix[0, 3, 3] + np.interp(wn, db.omega, a44)), wn


def anti_roll_tank_dof(omega: np.ndarray, nb: int, inertia: float, omega_t: float, zeta_t: float = 0.15,
                       mu: float = 0.03) -> ExtraDof:
    """Passive anti-roll tank as a rotational absorber τ coupled to roll (Den Hartog's damped absorber).

    I_t = μ (I44 + A44(ω_n)), k̃ = I_t ω_t² − iω 2 ζ_t I_t ω_t:
        hull roll row:  … + k̃ φ − k̃ τ   (k̃ added to H6[3,3])
        tank row:       −k̃ φ + (−ω² I_t + k̃) τ = 0   (no wave excitation)
    """
    it = mu * inertia
    k = it * omega_t**2 - 1j * omega * 2.0 * zeta_t * it * omega_t
    e = np.zeros(6)
    e[3] = 1.0
    n = omega.shape[0]
    add = np.zeros((n, 6, 6), dtype=complex)
    add[:, 3, 3] = k
    return ExtraDof(hull_add=add, hull_col=-k[:, None] * e, row=-k[:, None] * e, diag=-(omega**2) * it + k,
                    force=np.zeros((n, nb), dtype=complex))


# ------------------------------------------------------------------ time domain: quadratic roll damping


@dataclass(frozen=True)
class RollConstants:
    inertia: float  # modal inertia of the coupled roll mode (roll about its roll centre) [kg m²]
    damping: float  # B44(ω_n) + B_v44 [N m s]
    stiffness: float  # inertia ω_n², so that the SDOF resonates at the coupled root [N m]
    omega_n: float  # rad/s, coupled
    moment_inertia: float | None = None  # I44 + A44(ω_n) about the origin, the scale of −q I₀ |φ̇| φ̇ (None: inertia)


def roll_constants(db, loading) -> RollConstants:
    """Linear roll coefficients of the loading's coupled roll mode (database at its draft)."""
    from seatune.physics.modes import coupled_modes

    one = loading.take(slice(0, 1))
    lh = load(db, one)
    i0, i1, w = (a[0] for a in lh.draft_index)
    moment_inertia, wn = roll_inertia(db, one)
    modal = float(coupled_modes(db, one).effective_inertia[0, 1])
    b44 = (1 - w) * db.radiation_damping[i0, :, 3, 3] + w * db.radiation_damping[i1, :, 3, 3]
    return RollConstants(inertia=modal, damping=float(np.interp(wn, db.omega, b44) + lh.extra_damping[0, 3, 3]),
                         stiffness=modal * wn**2, omega_n=wn, moment_inertia=moment_inertia)


def quadratic_roll_correction(phi_dot_lin: np.ndarray, dt: float, rc: RollConstants,
                              q: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll correction δφ, δφ̇, δφ̈ (each (T,)) for the quadratic roll moment M_q = −q I |φ̇| φ̇:

        I δφ̈ + B δφ̇ + I ω_n² δφ = −q I₀ |φ̇_lin + δφ̇| (φ̇_lin + δφ̇),   B = B44(ω_n) + B_v44,

    I the modal inertia of the coupled roll mode, ω_n its root, I₀ = I44 + A44(ω_n) about the origin,

    so that φ = φ_lin + δφ satisfies the linear roll equation plus M_q. Fixed-step RK4 at the sample step,
    φ̇_lin linearly interpolated at the half steps; δφ(0) = δφ̇(0) = 0.
    """
    if rc.moment_inertia is not None:
        q = q * rc.moment_inertia / rc.inertia  # the moment's scale over the mode's own inertia
    u = np.asarray(phi_dot_lin, dtype=float)
    n = u.shape[0]
    y = np.zeros(n)
    z = np.zeros(n)
    if n == 0:
        return y, z, np.zeros(n)
    b, c = rc.damping / rc.inertia, rc.stiffness / rc.inertia
    y, z = _rk4(u.tolist(), float(dt), b, c, float(q))
    y, z = np.asarray(y), np.asarray(z)
    v = u + z
    acc = -b * z - c * y - q * np.abs(v) * v
    return y, z, acc


def _rk4(u: list, h: float, b: float, c: float, q: float) -> tuple[list, list]:
    """y'' = −b y' − c y − q|u + y'|(u + y'), scalar RK4 (plain floats: ~3 µs per step)."""
    n = len(u)
    ys = [0.0] * n
    zs = [0.0] * n
    y = z = 0.0
    h2 = 0.5 * h
    for i in range(n - 1):
        u0, u2 = u[i], u[i + 1]
        um = 0.5 * (u0 + u2)
        v = u0 + z
        k1y, k1z = z, -b * z - c * y - q * abs(v) * v
        zz = z + h2 * k1z
        v = um + zz
        k2y, k2z = zz, -b * zz - c * (y + h2 * k1y) - q * abs(v) * v
        zz3 = z + h2 * k2z
        v = um + zz3
        k3y, k3z = zz3, -b * zz3 - c * (y + h2 * k2y) - q * abs(v) * v
        zz4 = z + h * k3z
        v = u2 + zz4
        k4y, k4z = zz4, -b * zz4 - c * (y + h * k3y) - q * abs(v) * v
        y += h * (k1y + 2 * k2y + 2 * k3y + k4y) / 6.0
        z += h * (k1z + 2 * k2z + 2 * k3z + k4z) / 6.0
        ys[i + 1] = y
        zs[i + 1] = z
    return ys, zs


# ------------------------------------------------------------------ IMU lever arm


def lever_arm_rows(d: np.ndarray) -> np.ndarray:
    """(3, 6) rows with rows @ ξ = θ × d: extra translation of a point moved by d (rigid body, small angles)."""
    rows = np.stack([point_translation(np.asarray(d, dtype=float), a) for a in range(3)])
    rows[:, :3] = 0.0
    return rows


# ------------------------------------------------------------------ effects


class Effect:
    """Base class: hooks do nothing unless overridden."""

    defaults: dict = {}

    def extra_dof(self, db, loading, omega: np.ndarray, spec) -> ExtraDof | None:
        """An extra DOF coupled to the hull, solved with it at each component frequency (or None)."""
        return None

    def transfer(self, db, loading, draft: float, omega: np.ndarray, beta_grid: np.ndarray, xi: np.ndarray,
                 spec) -> np.ndarray:
        """Change the 6-DOF transfer functions ξ (N, nb, 6) at the component frequencies before synthesis."""
        return xi

    def before_sensors(self, ctx: EffectContext, spec) -> None:
        pass

    def imu(self, ctx: EffectContext, spec) -> None:
        pass


class ImuMisalignment(Effect):
    """IMU mounted with small roll/pitch/yaw offsets [deg] (`roll_deg`, `pitch_deg`, `yaw_deg`).

    Sensor geometry: the IMU frame is the body frame rotated by R_m; it reports its own attitude
    R·R_m and measures rates and specific force in its own axes, R_mᵀ ω and R_mᵀ f.
    """

    def imu(self, ctx: EffectContext, spec) -> None:
        extra = spec.model_extra or {}
        mount = Rotation.from_euler("ZYX", [extra.get("yaw_deg", 0.0), extra.get("pitch_deg", 0.0),
                                            extra.get("roll_deg", 0.0)], degrees=True)
        ctx.imu["rotation"] = ctx.imu["rotation"] * mount
        ctx.imu["rates"] = mount.inv().apply(ctx.imu["rates"])
        ctx.imu["force"] = mount.inv().apply(ctx.imu["force"])


class QuadraticRollDamping(Effect):
    """Quadratic (viscous, bilge-keel) roll damping M_q = −q (I44 + A44(ω_n)) |φ̇| φ̇, `q` [1/rad].

    Integrated in the time domain as a correction of the linear 6-DOF roll (`quadratic_roll_correction`):
    (I44 + A44(ω_n)) δφ̈ + (B44(ω_n) + B_v44) δφ̇ + C44 δφ = M_q(φ̇_lin + δφ̇); roll and its derivatives get
    δφ, δφ̇, δφ̈ added and every channel is recomputed from the corrected motions.
    """

    defaults = {"q": 1.5}

    def before_sensors(self, ctx: EffectContext, spec) -> None:
        from seatune.simulate.scenario import _linear_channel

        p = effect_params(self, spec)
        db = ctx.model.db
        rc = roll_constants(db, ctx.loading)
        corr = quadratic_roll_correction(ctx.xi[1][:, 3], 1.0 / ctx.fs, rc, float(p["q"]))
        for order in (0, 1, 2):
            ctx.xi[order][:, 3] += corr[order]
        for ch in ctx.model.channels:
            ctx.channels[ch.name] = _linear_channel(ch, ctx.xi, ctx.draft, db.g)


class Moonpool(Effect):
    """Moonpool water column (piston mode) as an extra DOF ζ coupled to the hull (`moonpool_dof`).

    Params: `omega_p` [rad/s] 1.0, `zeta_p` 0.08, `area` [m²] 64, `x`, `y` [m, body frame] 20, 0.
    """

    defaults = {"omega_p": 1.0, "zeta_p": 0.08, "area": 64.0, "x": 20.0, "y": 0.0}

    def extra_dof(self, db, loading, omega, spec) -> ExtraDof:
        return moonpool_dof(omega, db.wave_direction, loading_draft(db, loading), db.rho, db.g,
                            **effect_params(self, spec))


class AntiRollTank(Effect):
    """Passive anti-roll tank as a rotational absorber DOF τ coupled to roll (`anti_roll_tank_dof`).

    Params: `omega_t` [rad/s] (default: the truth loading's roll natural frequency), `zeta_t` 0.15, `mu` 0.03.
    """

    defaults = {"omega_t": None, "zeta_t": 0.15, "mu": 0.03}

    def extra_dof(self, db, loading, omega, spec) -> ExtraDof:
        p = effect_params(self, spec)
        inertia, wn = roll_inertia(db, loading)
        omega_t = wn if p["omega_t"] is None else float(p["omega_t"])
        return anti_roll_tank_dof(omega, db.wave_direction.shape[0], inertia, omega_t, p["zeta_t"], p["mu"])


class ImuLeverArm(Effect):
    """The IMU sits at its YAML point + (`dx`, `dy`, `dz`) [m]: specific force sensed at the true point.

    Rigid body: a(p + d) = a(p) + θ̈ × d, so f_true = f + R_IMUᵀ R_h (θ̈ × d) (R_h: heading rotation, R_IMU
    the sensor's attitude, misalignment included whichever order the effects are listed in).
    """

    defaults = {"dx": 0.0, "dy": 0.0, "dz": 0.0}

    def imu(self, ctx: EffectContext, spec) -> None:
        from seatune.physics import imu as imu_model

        p = effect_params(self, spec)
        delta_body = ctx.xi[2] @ lever_arm_rows(np.array([p["dx"], p["dy"], p["dz"]], dtype=float)).T
        yaw = imu_model.compass_to_enu_yaw(ctx.kin.heading_deg)
        heading_rot = imu_model.attitude(np.zeros_like(yaw), np.zeros_like(yaw), yaw)
        ctx.imu["force"] = ctx.imu["force"] + ctx.imu["rotation"].inv().apply(heading_rot.apply(delta_body))


def effect_transfer(db, loading, omega: np.ndarray, xi: np.ndarray, specs) -> np.ndarray:
    """Transfer functions (N, nb, 6) with every effect's extra DOFs and `transfer` hook applied."""
    dofs = [d for s in specs if (d := EFFECTS[s.kind].extra_dof(db, loading, omega, s)) is not None]
    if dofs:
        xi = augmented_raos(db, loading, omega, dofs)[0]
    draft = loading_draft(db, loading)
    for s in specs:
        xi = EFFECTS[s.kind].transfer(db, loading, draft, omega, db.wave_direction, xi, s)
    return xi


EFFECTS: dict[str, Effect] = {
    "imu_misalignment": ImuMisalignment(),
    "quadratic_roll_damping": QuadraticRollDamping(),
    "moonpool": Moonpool(),
    "anti_roll_tank": AntiRollTank(),
    "imu_lever_arm": ImuLeverArm(),
}

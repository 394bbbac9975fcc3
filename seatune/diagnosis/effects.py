"""The library of candidate effects: physics the linear strip/BEM model lacks, each a model extension with few
physical parameters and a documented signature. Pure computation on `ModelParts`.

An extra degree of freedom q attached to the hull by a relative spring-dashpot c̃ = c − iωb along a rigid-body
row r (r·ξ = the hull motion q is attached to), with q's own impedance z = −ω²m + c̃ and wave force f_q,

    [ H + c̃ r rᵀ   −c̃ r ] [ξ]   [F  ]
    [ −c̃ rᵀ         z  ] [q] = [f_q],

is eliminated exactly: (H + c̃(1 − c̃/z) r rᵀ) ξ = F + (c̃ f_q / z) r. So the moonpool and the tank cost one 6×6
solve, as the plain model does.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import numpy as np

from seatune.physics.channels import AXES, Channel, point_translation, transfer_vectors
from seatune.physics.response import trapezoid_weights


@dataclass(frozen=True)
class EffectParameter:
    name: str
    unit: str
    initial: float
    lower: float
    upper: float
    scan: tuple[float, ...] = ()  # values scanned for the start of a multimodal parameter (a resonance)
    limit_lower: float | None = None  # the physical limit a search stopped at its bound widens to (None: lower)
    limit_upper: float | None = None

    @property
    def widenable(self) -> bool:
        return self.widened() != self

    def widened(self) -> EffectParameter:
        lower = self.lower if self.limit_lower is None else min(self.lower, self.limit_lower)
        upper = self.upper if self.limit_upper is None else max(self.upper, self.limit_upper)
        return dataclasses.replace(self, lower=lower, upper=upper)


class Effect:
    """A candidate: `apply` changes the model parts; `spectra` may iterate (stochastic linearisation)."""

    name = ""
    signature = ""
    parameters: tuple[EffectParameter, ...] = ()

    def applicable(self, vessel, channels) -> bool:
        return True

    def untouched(self, vessel, channels) -> list[str] | None:
        """The `channels` this effect leaves exactly as they were (a sea fitted from them alone cannot have absorbed
        it); None: every channel moves with the ship's dynamics."""
        return None

    def scan_values(self, parts0, bands) -> dict[str, tuple[float, ...]]:
        """Start values to scan per parameter: the declared scan plus the centres of residual bands."""
        return with_band_peaks({p.name: p.scan for p in self.parameters if p.scan}, self.parameters, bands)

    def apply(self, parts, params: dict, model) -> None:
        raise NotImplementedError

    def spectra(self, parts, params: dict, model) -> np.ndarray:
        self.apply(parts, params, model)
        return parts.spectra()

    def widened(self, names) -> Effect:
        """A copy whose named parameters search up to their physical limits (a fit stopped at a search bound)."""
        out = copy.copy(self)
        out.parameters = tuple(q.widened() if q.name in names else q for q in self.parameters)
        return out


def own_parameters_text(fitted: dict) -> str:
    """"k v, …" of a step's own fitted parameters, without the refitted ones of the effects named before it (which
    a `Compound` names `effect.parameter`)."""
    return ", ".join(f"{k} {v:.3g}" for k, v in fitted.items() if "." not in k)


class Compound(Effect):
    """Effects named one after another in one model (greedy selection): the given ones start from their fitted
    values and are refitted with the added one. Parameters are named `effect.parameter`; effects that change the
    sea or the transfer functions are applied in turn, one with its own `spectra` (stochastic linearisation) last."""

    def __init__(self, given: list[tuple[Effect, dict]], added: Effect):
        self.members = [e for e, _ in given] + [added]
        self.added = added
        self.name = "+".join(e.name for e in self.members)
        self.signature = "; ".join(e.signature for e in self.members)
        starts = [p for _, p in given] + [{}]
        self.parameters = tuple(
            dataclasses.replace(q, name=f"{e.name}.{q.name}", initial=float(start.get(q.name, q.initial)),
                                scan=() if start else q.scan)
            for e, start in zip(self.members, starts, strict=True) for q in e.parameters)

    def applicable(self, vessel, channels):
        return all(e.applicable(vessel, channels) for e in self.members)

    def scan_values(self, parts0, bands):
        return {f"{self.added.name}.{k}": v for k, v in self.added.scan_values(parts0, bands).items()}

    def split(self, params: dict) -> list[tuple[Effect, dict]]:
        return [(e, {q.name: params[f"{e.name}.{q.name}"] for q in e.parameters}) for e in self.members]

    def widened(self, names) -> Effect:
        out = super().widened(names)
        for k, e in enumerate(out.members):
            own = {n.split(".", 1)[1] for n in names if n.split(".", 1)[0] == e.name}
            if own:
                out.members = [*out.members[:k], e.widened(own), *out.members[k + 1:]]
        out.added = out.members[-1]
        return out

    def spectra(self, parts, params, model):
        pieces = self.split(params)
        last = [(e, p) for e, p in pieces if type(e).spectra is not Effect.spectra]
        for e, p in pieces:
            if (e, p) not in last:
                e.apply(parts, p, model)
        return last[0][0].spectra(parts, last[0][1], model) if last else parts.spectra()


def with_band_peaks(scans: dict, parameters, bands) -> dict[str, tuple[float, ...]]:
    """`scans` with the centres of the located misfit bands added to each resonance frequency (omega_*): a
    resonance starts where the residual says."""
    peaks = tuple(b.omega_peak for b in bands)
    return {**scans, **{q.name: tuple(scans.get(q.name, ())) + peaks for q in parameters
                        if peaks and q.name.startswith("omega")}}


def attach_dof(parts, row: np.ndarray, c_tilde: np.ndarray, z: np.ndarray, f_q: np.ndarray | None = None) -> None:
    """Eliminate an attached DOF (module docstring); row (6,), c_tilde and z (nf,), f_q (nf, nb) or None."""
    rr = np.outer(row, row)
    parts.impedance = parts.impedance + (c_tilde * (1.0 - c_tilde / z))[:, None, None] * rr
    if f_q is not None:
        parts.force = parts.force + (c_tilde / z)[:, None, None] * f_q[:, :, None] * row[None, None, :]


class QuadraticRollDamping(Effect):
    name = "quadratic_roll_damping"
    signature = ("roll damping grows with amplitude: the roll resonance peak is over-predicted more in higher seas "
                 "(roll, roll rate, lateral accelerations; residual correlates with Hs)")
    parameters = (EffectParameter("q", "1/rad", 0.0, 0.0, 20.0, scan=(0.0, 0.3, 1.0, 3.0)),)
    iterations = 8

    def spectra(self, parts, params, model):
        # roll moment −q (I44 + A44(ω_n)) |φ̇| φ̇, linearised per window: b_eq = √(8/π) σ_φ̇ b2 (seed_002 eq. 2.19);
        # H_w = H − iω b_eq e₄e₄ᵀ per window by Sherman–Morrison on one solve of H
        b2 = params["q"] * parts.inertia_roll
        om = parts.omega
        rhs = np.concatenate([np.swapaxes(parts.force, -1, -2), np.broadcast_to(np.eye(6)[:, 3:4], (om.size, 6, 1))],
                             axis=-1)
        sol = np.linalg.solve(parts.impedance, rhs)  # (nf, 6, nb + 1)
        xi0, g = sol[:, :, :-1], sol[:, :, -1]
        h0 = np.swapaxes(xi0, 1, 2) @ parts.transfer  # (nf, nb, nc)
        hg = (g[:, None, :] @ parts.transfer)[:, 0, :]  # (nf, nc)
        x4 = xi0[:, 3, :]  # (nf, nb)
        w = trapezoid_weights(om)
        # every direction's roll is ξ₄/(1 + c g₄₄) and every channel's H₀ − a ξ₄ h_g with a = c/(1 + c g₄₄), c per
        # window: the sums over directions are taken once, before the fixed point
        wave = parts.wave[:, :, None, :]  # (nw, nf, 1, nb)
        roll0 = (wave @ (x4.real**2 + x4.imag**2)[:, :, None])[..., 0, 0]  # Σ_β S |ξ₄|²: (nw, nf)
        sigma = np.zeros(parts.wave.shape[0])
        for k in range(self.iterations):
            c = -1j * om[None, :] * (np.sqrt(8.0 / np.pi) * sigma * b2)[:, None]  # (nw, nf)
            den = 1.0 + c * g[None, :, 3]
            new = np.sqrt((roll0 / (den.real**2 + den.imag**2) * om**2) @ w)
            sigma = new if k == 0 else np.sqrt(sigma * new)  # geometric damping of the fixed point
        a = c / (1.0 + c * g[None, :, 3])  # at the last iteration's damping, as the loop has always returned it
        s0 = (wave @ (h0.real**2 + h0.imag**2))[:, :, 0, :]  # Σ_β S |H₀|²: (nw, nf, nc)
        cross = (wave @ (np.conj(h0) * x4[:, :, None]))[:, :, 0, :]  # Σ_β S H̄₀ ξ₄
        out = s0 - 2.0 * (a[..., None] * hg[None] * cross).real + (a.real**2 + a.imag**2)[..., None] * (
            hg.real**2 + hg.imag**2)[None] * roll0[..., None]
        return np.maximum(out, 0.0).transpose(0, 2, 1)  # (nw, nc, nf), as spectra_in_sea


class Moonpool(Effect):
    name = "moonpool"
    signature = ("piston mode of a moonpool's water column: a narrow extra peak or notch in heave (and pitch / roll "
                 "by the moonpool's position) near its resonance, independent of roll")

    def __init__(self, x: float | None = 0.0, y: float = 0.0, waterplane: float | None = None,
                 length: float | None = None):
        """`waterplane` [m²]: the hull's; the area is searched up to 8 % of it and widened up to 20 % (a
        moonpool's opening is a few per cent of the waterplane). Without it, 1–400 m². `x` None: searched along the
        hull (± half its `length`, else ± 50 m)."""
        self.x, self.y = float(x or 0.0), float(y)
        area = (EffectParameter("area", "m^2", 0.02 * waterplane, 1.0, 0.08 * waterplane,
                                scan=(0.001 * waterplane, 0.02 * waterplane), limit_upper=0.2 * waterplane)
                if waterplane else EffectParameter("area", "m^2", 40.0, 1.0, 400.0, scan=(2.0, 40.0)))
        self.parameters = (
            EffectParameter("omega_p", "rad/s", 1.0, 0.4, 2.0, scan=tuple(np.round(np.arange(0.5, 1.95, 0.1), 2))),
            EffectParameter("zeta_p", "", 0.1, 0.01, 0.5), area)
        if x is None:
            half = 0.5 * (length or 100.0)
            self.parameters += (EffectParameter("x", "m", 0.0, -half, half, scan=(-0.5 * half, 0.0, 0.5 * half)),)

    def apply(self, parts, params, model):
        # column: mass on a relative spring c_p = ρ g S, excited by the wave pressure at the keel (Molin 2001 piston)
        x = params.get("x", self.x)
        om = parts.omega
        c_p = parts.rho * parts.g * params["area"]
        m_p = c_p / params["omega_p"] ** 2
        c_t = c_p - 1j * om * 2.0 * params["zeta_p"] * np.sqrt(c_p * m_p)
        z = -(om**2) * m_p + c_t
        k = om**2 / parts.g
        phase = np.exp(1j * k[:, None] * (x * np.cos(parts.beta) + self.y * np.sin(parts.beta))[None, :])
        f_q = c_t[:, None] * np.exp(-k * parts.draft)[:, None] * phase
        attach_dof(parts, point_translation(np.array([x, self.y, 0.0]), 2), c_t, z, f_q)


class AntiRollTank(Effect):
    name = "anti_roll_tank"
    signature = ("a passive tank tuned near roll resonance: the roll peak is split in two with a notch near the "
                 "tank frequency, independent of amplitude")

    def __init__(self, omega_roll: float | None = None):
        """`omega_roll` [rad/s]: the model's roll natural frequency. A passive tank is tuned to it (Den Hartog's
        optimum ω_t = ω_n/(1 + μ); fill levels keep it there), so ω_t is searched within 0.8–1.25 ω_roll and not
        widened: a notch far from the roll peak is no anti-roll tank (on the blind bank, a "tank" at 1.3 ω_n with an
        extreme loading mimicked a clean hull's roll peak). Without it, 0.2–1.5 rad/s."""
        omega_t = (EffectParameter("omega_t", "rad/s", omega_roll, 0.8 * omega_roll, 1.25 * omega_roll)
                   if omega_roll and np.isfinite(omega_roll) else EffectParameter("omega_t", "rad/s", 0.5, 0.2, 1.5))
        self.parameters = (omega_t, EffectParameter("zeta_t", "", 0.15, 0.02, 0.8),
                           EffectParameter("mu", "", 0.02, 0.001, 0.2))

    def scan_values(self, parts0, bands):
        w = parts0.omega_roll
        return with_band_peaks({"omega_t": tuple(np.round(w * np.array([0.8, 0.9, 1.0, 1.1, 1.2]), 4))},
                               self.parameters, bands)

    def apply(self, parts, params, model):
        # rotational absorber on roll (Den Hartog): I_t = μ (I44 + A44), k̃ = I_t ω_t² − iω 2ζ_t I_t ω_t
        om = parts.omega
        i_t = params["mu"] * parts.inertia_roll
        k_t = i_t * params["omega_t"] ** 2 - 1j * om * 2.0 * params["zeta_t"] * i_t * params["omega_t"]
        attach_dof(parts, np.eye(6)[3], k_t, -(om**2) * i_t + k_t)


def _sensor_channels(model, sensor: str, kinds) -> list[int]:
    specs = {c.name: c for c in model.vessel.spec.channels}
    return [j for j, name in enumerate(model.channel_names)
            if specs[name].sensor == sensor and specs[name].kind in kinds]


def hull_extent(vessel) -> tuple[float, float] | None:
    """Length and beam [m] of the hull: the vessel's own (a built hull), else the box with the waterplane area and
    second moments of the database's middle draft (A = C33/ρg, I = C44 or C55/ρg − V z_b, L = √(12 I_L/A)); None
    when the database cannot give them (a WAMIT hull: z_b unknown)."""
    if vessel.length and vessel.beam:
        return float(vessel.length), float(vessel.beam)
    db = vessel.db
    k = len(db.drafts) // 2
    c = db.buoyancy_stiffness[k] / (db.rho * db.g)
    z_b = float(db.center_of_buoyancy[k, 2])
    area = waterplane_area(vessel)
    i_t, i_l = float(c[3, 3]) - db.disp_volume[k] * z_b, float(c[4, 4]) - db.disp_volume[k] * z_b
    if not (np.isfinite(z_b) and area > 0 and i_t > 0 and i_l > 0):
        return None
    return float(np.sqrt(12 * i_l / area)), float(np.sqrt(12 * i_t / area))


def waterplane_area(vessel) -> float:
    """A_wp = C33 / ρg at the database's middle draft [m²]."""
    db = vessel.db
    return float(db.buoyancy_stiffness[len(db.drafts) // 2][2, 2] / (db.rho * db.g))


class ImuLeverArm(Effect):
    name = "imu_lever_arm"
    signature = ("the IMU is not where the vessel YAML puts it: its accelerations misfit, growing with ω² and "
                 "with the rotations, while angles and rates fit")
    kinds = ("displacement", "velocity", "acceleration", "specific_force")
    order = {"displacement": 0, "velocity": 1, "acceleration": 2, "specific_force": 2}

    def __init__(self, sensor: str = "imu", extent: tuple[float, float] | None = None):
        """`extent` (length, beam) [m]: the YAML point and the true one both lie on the hull, so the error reaches
        ± a length and ± a beam; the commonest mistake, a reference at the aft perpendicular instead of midship,
        is half a length, so dx also starts from ± L/2. Without it, ± 15 m."""
        self.sensor = sensor
        length, beam = extent if extent is not None else (15.0, 15.0)
        self.parameters = (
            EffectParameter("dx", "m", 0.0, -length, length,
                            scan=(-0.5 * length, 0.0, 0.5 * length) if extent is not None else ()),
            EffectParameter("dy", "m", 0.0, -beam, beam), EffectParameter("dz", "m", 0.0, -15.0, 15.0))

    def applicable(self, vessel, channels):
        specs = {c.name: c for c in vessel.spec.channels}
        return any(specs[c].sensor == self.sensor and specs[c].kind in self.kinds for c in channels)

    def untouched(self, vessel, channels):  # the angles and rates: a lever arm moves only the translations
        specs = {c.name: c for c in vessel.spec.channels}
        return [c for c in channels if not (specs[c].sensor == self.sensor and specs[c].kind in self.kinds)]

    def apply(self, parts, params, model):
        d = np.array([params["dx"], params["dy"], params["dz"]])
        iw = -1j * parts.omega
        t = parts.transfer.copy()
        for j in _sensor_channels(model, self.sensor, self.kinds):
            ch = model._channels[j]
            rotation = point_translation(d, AXES[ch.axis]) - point_translation(np.zeros(3), AXES[ch.axis])  # θ × d
            t[:, :, j] += (iw ** self.order[ch.kind])[:, None] * rotation[None, :]
        parts.transfer = t


class ImuMisalignment(Effect):
    name = "imu_misalignment"
    signature = ("the IMU axes are rotated from the body axes: each channel picks up its neighbours' motion "
                 "(roll ↔ pitch, fx ↔ fy), so a misfit on one axis mirrors the other axis' spectrum")
    parameters = (EffectParameter("roll_deg", "deg", 0.0, -15.0, 15.0),
                  EffectParameter("pitch_deg", "deg", 0.0, -15.0, 15.0),
                  EffectParameter("yaw_deg", "deg", 0.0, -15.0, 15.0))

    def __init__(self, sensor: str = "imu"):
        self.sensor = sensor

    def applicable(self, vessel, channels):
        specs = {c.name: c for c in vessel.spec.channels}
        return any(specs[c].sensor == self.sensor for c in channels)

    def apply(self, parts, params, model):
        # the sensor reports R_mᵀ v ≈ v − m × v of each body vector v (small mounting rotation m)
        m = np.radians([params["roll_deg"], params["pitch_deg"], params["yaw_deg"]])
        t = parts.transfer.copy()
        for j in _sensor_channels(model, self.sensor, ("angle", "rate", "acceleration", "specific_force")):
            ch = model._channels[j]
            axes = [Channel(f"{ch.name}_{a}", ch.kind, a, ch.point) for a in "xyz"]
            v = transfer_vectors(axes, parts.omega, np.array([parts.draft]), parts.g)[0]  # (nf, 6, 3)
            a = AXES[ch.axis]
            cross = m[(a + 1) % 3] * v[:, :, (a + 2) % 3] - m[(a + 2) % 3] * v[:, :, (a + 1) % 3]
            t[:, :, j] = t[:, :, j] - cross
        parts.transfer = t


class HsBias(Effect):
    name = "hs_bias"
    signature = "the hindcast's Hs is biased: every channel in every window misfits by one common factor"
    parameters = (EffectParameter("hs_factor", "", 1.0, 0.4, 2.5),)

    def apply(self, parts, params, model):
        parts.wave = parts.wave * params["hs_factor"] ** 2


class MissingSwell(Effect):
    name = "missing_swell"
    signature = ("a swell the hindcast misses: a low-frequency excess below the wind sea in all channels, "
                 "its direction fixed on the compass whatever the heading")
    # the start scans heights too: at the initial 5 cm every direction looks alike
    parameters = (EffectParameter("hs", "m", 0.05, 0.02, 4.0, scan=(0.3, 1.0, 2.0)),
                  EffectParameter("tp", "s", 14.0, 8.0, 25.0, scan=(10.0, 13.0, 16.0, 20.0)),
                  EffectParameter("dir_from_deg", "deg", 180.0, -360.0, 720.0, scan=tuple(np.arange(0.0, 360.0, 45.0))))

    def apply(self, parts, params, model):
        from seatune.physics.spectra import jonswap

        s = jonswap(parts.omega, params["hs"], params["tp"], 3.0)  # swell: peaked JONSWAP
        beta = np.mod(model.data.heading_deg - params["dir_from_deg"] - 180.0, 360.0)  # DESIGN §3
        parts.wave = parts.wave + s[None, :, None] * _direction_weights(beta, np.degrees(parts.beta))[:, None, :]


class WaveSpreading(Effect):
    name = "wave_spreading"
    signature = ("the sea is more short-crested than the hindcast: head/following-sea windows show roll and sway "
                 "the model lacks, beam-sea windows less roll at the peak")
    parameters = (EffectParameter("spread_deg", "deg", 3.0, 3.0, 80.0, scan=(3.0, 10.0, 25.0, 45.0)),)

    def apply(self, parts, params, model):
        parts.wave = parts.wave @ spreading_kernel(parts.beta, params["spread_deg"]).T


def spreading_kernel(beta: np.ndarray, spread_deg: float) -> np.ndarray:
    """(nb_out, nb_in) redistribution of S(ω, β)·Δβ over directions β [rad] by a cos-2s of directional spread
    `spread_deg`; its columns sum to 1, so each frequency keeps its energy (`wave @ kernel.T`)."""
    from seatune.physics.spectra import cos2s_s_from_spread, spreading_cos2s

    kernel = spreading_cos2s(beta - beta[:, None], float(cos2s_s_from_spread(np.radians(spread_deg))))
    return kernel / kernel.sum(axis=0, keepdims=True)


def _direction_weights(beta_deg: np.ndarray, grid_deg: np.ndarray) -> np.ndarray:
    """Split a direction between its two neighbours on the equally spaced grid: (n, nb), rows sum to 1."""
    from seatune.physics.spectra import _long_crested_weights

    grid = np.radians(grid_deg)
    step = 2 * np.pi / grid.size
    return _long_crested_weights(grid, np.argsort(grid), step, np.radians(np.asarray(beta_deg, float)), True) * step


def library(names=None, moonpool_position=None, imu_sensor: str = "imu", vessel=None,
            omega_roll: float | None = None) -> list[Effect]:
    """The candidate effects by name (all by default); with `vessel`, ranges from its hull (`hull_extent`, the
    waterplane area), with `omega_roll` the tank's from the roll natural frequency. `moonpool_position` (x, y):
    where a moonpool is known to be; None: its x is searched along the hull (y 0)."""
    extent = hull_extent(vessel) if vessel is not None else None
    waterplane = waterplane_area(vessel) if vessel is not None else None
    x, y = moonpool_position if moonpool_position is not None else (None, 0.0)
    every = {e.name: e for e in (QuadraticRollDamping(), Moonpool(x, y, waterplane, extent[0] if extent else None),
                                 AntiRollTank(omega_roll),
                                 ImuLeverArm(imu_sensor, extent), ImuMisalignment(imu_sensor), HsBias(),
                                 MissingSwell(), WaveSpreading())}
    if names is None:
        return list(every.values())
    unknown = [n for n in names if n not in every]
    if unknown:
        raise KeyError(", ".join(unknown))
    return [every[n] for n in names]


EFFECT_NAMES = ("quadratic_roll_damping", "moonpool", "anti_roll_tank", "imu_lever_arm", "imu_misalignment",
                "hs_bias", "missing_swell", "wave_spreading")


#: effects that change only the sea the model is driven with
SEA_SIDE = ("hs_bias", "missing_swell", "wave_spreading")

#: effects that change the vessel's transfer functions (tuning and prediction can use them); the others act on
#: the sea (hs_bias, missing_swell, wave_spreading) or depend on the sea state (quadratic_roll_damping)
MODEL_SIDE = ("moonpool", "anti_roll_tank", "imu_lever_arm", "imu_misalignment")


def vessel_effects(entries, kinds=MODEL_SIDE) -> list[tuple[Effect, dict]]:
    """The vessel YAML's `effects:` entries ({kind, parameters}) of the given kinds as (Effect, params)."""
    out = []
    for entry in entries:
        kind = entry["kind"]
        if kind not in kinds:
            continue
        params = {k: float(v) for k, v in entry.items() if k != "kind"}
        effect = Moonpool(params.pop("x", 0.0), params.pop("y", 0.0)) if kind == "moonpool" else library([kind])[0]
        out.append((effect, params))
    return out


def check_entry(entry: dict) -> str | None:
    """What is wrong with a vessel YAML `effects:` entry, or None."""
    kind = entry.get("kind") if isinstance(entry, dict) else None
    if kind not in EFFECT_NAMES:
        return f"kind must be one of {', '.join(EFFECT_NAMES)}, got {kind!r}"
    effect = Moonpool() if kind == "moonpool" else library([kind])[0]
    allowed = {q.name for q in effect.parameters} | ({"x", "y"} if kind == "moonpool" else set())
    given = set(entry) - {"kind"}
    if given - allowed or {q.name for q in effect.parameters} - given:
        return f"{kind} takes {', '.join(sorted(allowed))}; got {', '.join(sorted(given)) or 'none'}"
    if not all(isinstance(entry[k], int | float) for k in given):
        return f"{kind}: parameters must be numbers"
    return None

"""One independent trial: voyage, directional sea, linear response from Capytaine, hidden effects, sensors, files.

Flow (:func:`generate`): the truth loading's Capytaine RAOs on a fine ω grid (0.0025 rad/s) → per segment
(drift window or transit) a random-phase sea of 24 body-relative directions × randomised frequencies →
6-DOF motions, velocities, accelerations by :mod:`seatune.simulate.independent.synthesis` → segments blended over the
manoeuvre between them → quadratic roll damping integrated in the time domain (RK4) → IMU by geometry
(scipy Rotation, exact rigid-body kinematics at the true IMU point) and GNSS → MCAP (``/imu/data``,
``sensor_msgs/msg/Imu``, REP-103 FLU/ENU) + GNSS CSV, ERA5 hindcast, ``truth.yaml``, ``run.yaml``.

Effects (parameters in seatune diagnose's meaning):
- ``quadratic_roll_damping {q}``: roll moment −q (I44 + A44(ω_r)) |φ̇| φ̇. The linear 6-DOF roll is Capytaine's;
  the correction δφ solves  I_r δφ̈ + B_r δφ̇ + C44 δφ = −q I₀ |φ̇_lin + δφ̇|(φ̇_lin + δφ̇)  with I_r = C44/ω_r²
  (the roll equation whose root is the coupled roll root ω_r), B_r = B44(ω_r) + B_v44, I₀ = M44 + A44(ω_r).
- ``moonpool {omega_p, zeta_p, area, x, y}``: piston-mode water column ζ at (x, y) [body frame], an extra DOF
  on a relative spring/dashpot c̃ = ρgS − iω b_p (m_p = ρgS/ω_p², b_p = 2ζ_p√(ρgS m_p)) to the hull's vertical
  motion there, driven by the incident wave at the keel (e^{−kT}).
- ``anti_roll_tank {omega_t, zeta_t, mu}``: rotational absorber τ on roll, I_t = μ(M44 + A44(ω_r)),
  k̃ = I_t ω_t² − 2iω ζ_t I_t ω_t.
- ``imu_lever_arm {dx, dy, dz}``: the IMU is at the vessel-YAML point + d.
- ``imu_misalignment {roll_deg, pitch_deg, yaw_deg}``: IMU axes = body axes rotated by ZYX(yaw, pitch, roll).
Extra DOFs are appended to Capytaine's 6×6 impedance (``rao_transfer_function``) and solved per frequency.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from scipy.spatial.transform import Rotation

from seatune.simulate.independent import era5, hydro
from seatune.simulate.independent.seas import (
    Partition,
    frequency_spectrum,
    hs_of,
    mean_direction,
    peak_period,
    spreading,
)
from seatune.simulate.independent.synthesis import synthesize

logging.getLogger("capytaine").setLevel(logging.WARNING)

FS = 10.0
W_FINE = np.linspace(0.2, 2.0, 721)
TRANSITION_S = 180.0
R_EARTH = 6_371_000.0
REPO = Path(__file__).resolve().parents[3]
VESSELS = {"osv": REPO / "configs" / "vessels" / "sample_osv.yaml",
           "barge": REPO / "configs" / "vessels" / "barge.yaml"}


# ------------------------------------------------------------------ hulls


_HULL_CACHE: dict = {}


def hull_data(hull: str) -> hydro.HullData:
    if hull not in _HULL_CACHE:
        if hull == "osv":
            _HULL_CACHE[hull] = hydro.load_osv(REPO / "configs" / "vessels" / "sample_osv_hydro.nc")
        else:
            from seatune.simulate.independent.hulls import DRAFTS, file_name

            _HULL_CACHE[hull] = hydro.load_barge([REPO / "configs" / "vessels" / "barge" / file_name(d)
                                                  for d in DRAFTS])
    return _HULL_CACHE[hull]


def vessel_yaml(hull: str) -> dict:
    return yaml.safe_load(VESSELS[hull].read_text())


def imu_point(vessel: dict) -> np.ndarray:
    for ch in vessel["channels"]:
        if ch.get("kind") == "specific_force":
            return np.asarray(ch["point"], dtype=float)
    raise ValueError("vessel has no IMU specific-force channel")


# ------------------------------------------------------------------ spec


@dataclass
class Segment:
    kind: str  # drift | transit
    t0: float
    t1: float
    heading_deg: float
    heading_rate_deg_per_h: float
    speed: float
    course_deg: float
    sea: int  # index into the windows' seas


@dataclass
class TrialSpec:
    trial: str
    seed: int
    hull: str
    category: str
    loading: hydro.Loading
    effects: list[dict]
    seas: list[list[Partition]]  # one per drift window
    window_minutes: list[float]
    headings_deg: list[float]
    start: pd.Timestamp
    start_latlon: tuple[float, float]
    hindcast: dict  # layout, time_dim, missing_swell, hs_rel_error, tp_error_s, dir_error_deg, gamma, spread_factor
    tuning_parameters: list[str] = field(default_factory=lambda: ["gmt_fs", "r44", "beta44"])
    transit_minutes: list[float] = field(default_factory=list)
    drift_speed: float = 0.15


def segments_of(spec: TrialSpec, rng: np.random.Generator) -> list[Segment]:
    segs, t = [], 0.0
    n = len(spec.seas)
    for i in range(n):
        tm = spec.transit_minutes[i] if i < len(spec.transit_minutes) else 8.0
        course = float(rng.uniform(0, 360))
        segs.append(Segment("transit", t, t + tm * 60, course, 0.0, float(rng.uniform(4.0, 6.0)), course, i))
        t += tm * 60
        dur = spec.window_minutes[i] * 60 + TRANSITION_S
        rate = float(rng.uniform(-3.0, 3.0))
        segs.append(Segment("drift", t, t + dur, spec.headings_deg[i], rate, spec.drift_speed,
                            float(rng.uniform(0, 360)), i))
        t += dur
    segs.append(Segment("transit", t, t + 5 * 60, float(rng.uniform(0, 360)), 0.0, 5.0,
                        float(rng.uniform(0, 360)), n - 1))
    segs[-1].course_deg = segs[-1].heading_deg
    return segs


# ------------------------------------------------------------------ response


def _smooth(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def effect(spec: TrialSpec, kind: str) -> dict | None:
    for e in spec.effects:
        if e["kind"] == kind:
            return e
    return None


def transfer_functions(cond: hydro.Condition, spec: TrialSpec, roots: dict) -> np.ndarray:
    """ξ (nw, nb, 6) per unit wave amplitude on W_FINE × the database's β, with the coupled extra DOFs."""
    cf = cond.at_omega(W_FINE)
    extra = [e for e in spec.effects if e["kind"] in ("moonpool", "anti_roll_tank")]
    if not extra:
        return hydro.capytaine_rao(cf)
    H = hydro.impedance(cf)  # (nw, 6, 6)
    w = cf.omega
    nb = cf.beta.size
    k = len(extra)
    K = np.zeros((w.size, 6 + k, 6 + k), dtype=complex)
    K[:, :6, :6] = H
    rhs = np.zeros((w.size, nb, 6 + k), dtype=complex)
    rhs[:, :, :6] = cf.F
    for j, e in enumerate(extra):
        col = 6 + j
        if e["kind"] == "moonpool":
            rho, g = cond.hull.rho, cond.hull.g
            cp = rho * g * e["area"]
            mp = cp / e["omega_p"] ** 2
            bp = 2 * e["zeta_p"] * np.sqrt(cp * mp)
            ct = cp - 1j * w * bp
            r = np.zeros(6)
            r[2], r[3], r[4] = 1.0, e["y"], -e["x"]  # vertical motion of the hull at (x, y): ξ3 + y ξ4 − x ξ5
            K[:, :6, :6] += ct[:, None, None] * np.outer(r, r)[None]
            K[:, :6, col] = -ct[:, None] * r
            K[:, col, :6] = -ct[:, None] * r
            K[:, col, col] = -(w**2) * mp + ct
            kw = w**2 / g
            phase = np.exp(1j * np.outer(kw, e["x"] * np.cos(cf.beta) + e["y"] * np.sin(cf.beta)))
            rhs[:, :, col] = ct[:, None] * np.exp(-kw * cond.draft)[:, None] * phase
        else:  # anti-roll tank
            wr = roots["roll"]
            i0 = cond.M[3, 3] + np.interp(wr, cond.omega, cond.A[:, 3, 3])
            it = e["mu"] * i0
            kt = it * e["omega_t"] ** 2 - 1j * w * 2 * e["zeta_t"] * it * e["omega_t"]
            K[:, 3, 3] += kt
            K[:, 3, col] = -kt
            K[:, col, 3] = -kt
            K[:, col, col] = -(w**2) * it + kt
    x = np.linalg.solve(K[:, None], rhs[..., None])[..., 0]  # (nw, nb, 6+k)
    return x[..., :6]


def components(parts: list[Partition], heading_deg: float, beta: np.ndarray, rng: np.random.Generator,
               n_freq: int = 80) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ω (N,), β index (N,), complex wave amplitude at the origin (N,)) for one segment's sea."""
    nb = beta.size
    d_from = np.mod(heading_deg - np.rad2deg(beta) - 180.0, 360.0)  # coming-from of each body direction
    dbeta = 2 * np.pi / nb
    edges = np.linspace(W_FINE[0], W_FINE[-1], n_freq + 1)
    dw = edges[1] - edges[0]
    w = edges[:-1][None, :] + rng.uniform(0, dw, size=(nb, n_freq))
    s = np.zeros((nb, n_freq))
    for p in parts:
        s += spreading(d_from, p)[:, None] * frequency_spectrum(w.ravel(), p).reshape(nb, n_freq)
    amp = np.sqrt(2 * s * dw * dbeta)
    phase = rng.uniform(0, 2 * np.pi, size=(nb, n_freq))
    zeta = amp * np.exp(1j * phase)
    j = np.repeat(np.arange(nb), n_freq)
    keep = amp.ravel() > 1e-4 * amp.max()
    return w.ravel()[keep], j[keep], zeta.ravel()[keep]


def _interp_xi(xi: np.ndarray, w: np.ndarray, j: np.ndarray) -> np.ndarray:
    """ξ at each component (N, 6): linear in ω on W_FINE at the component's own β."""
    pos = np.clip((w - W_FINE[0]) / (W_FINE[1] - W_FINE[0]), 0, W_FINE.size - 1 - 1e-9)
    i = pos.astype(int)
    f = (pos - i)[:, None]
    return (1 - f) * xi[i, j] + f * xi[i + 1, j]


# ------------------------------------------------------------------ main


def quadratic_roll(phi_dot: np.ndarray, dt: float, inertia: float, damping: float, stiffness: float,
                   q_moment: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """δφ, δφ̇, δφ̈ of  I δφ̈ + B δφ̇ + C δφ = −Q |u + δφ̇|(u + δφ̇), u = φ̇_lin (RK4, u linear between samples)."""
    b, c, q = damping / inertia, stiffness / inertia, q_moment / inertia
    u = phi_dot.tolist()
    n = len(u)
    ys, zs = [0.0] * n, [0.0] * n
    y = z = 0.0
    h, h2 = dt, 0.5 * dt
    for i in range(n - 1):
        u0, u2 = u[i], u[i + 1]
        um = 0.5 * (u0 + u2)
        v = u0 + z
        a1 = -b * z - c * y - q * abs(v) * v
        z2 = z + h2 * a1
        v = um + z2
        a2 = -b * z2 - c * (y + h2 * z) - q * abs(v) * v
        z3 = z + h2 * a2
        v = um + z3
        a3 = -b * z3 - c * (y + h2 * z2) - q * abs(v) * v
        z4 = z + h * a3
        v = u2 + z4
        a4 = -b * z4 - c * (y + h * z3) - q * abs(v) * v
        y += h * (z + 2 * z2 + 2 * z3 + z4) / 6.0
        z += h * (a1 + 2 * a2 + 2 * a3 + a4) / 6.0
        ys[i + 1], zs[i + 1] = y, z
    y, z = np.asarray(ys), np.asarray(zs)
    v = phi_dot + z
    return y, z, -b * z - c * y - q * np.abs(v) * v


@dataclass
class Motions:
    t: np.ndarray  # s from start
    xi: np.ndarray  # (T, 6)
    xid: np.ndarray
    xidd: np.ndarray
    heading_deg: np.ndarray  # compass, slow (track)
    vel_en: np.ndarray  # (T, 2) track velocity over ground, east/north
    segs: list[Segment]


def simulate_motions(spec: TrialSpec, cond: hydro.Condition, roots: dict, rng: np.random.Generator,
                     n_freq: int = 80) -> Motions:
    segs = segments_of(spec, rng)
    n = int(round(segs[-1].t1 * FS)) + 1  # whole seconds: the last IMU sample has its GNSS fix
    t = np.arange(n) / FS
    xi_tf = transfer_functions(cond, spec, roots)
    out = np.zeros((n, 18))
    head = np.zeros(n)
    vel = np.zeros((n, 2))
    prev = None
    for k, sg in enumerate(segs):
        last = k == len(segs) - 1
        i0 = int(round(sg.t0 * FS))
        i1 = n if last else min(n, int(round((sg.t1 + TRANSITION_S) * FS)))
        w, j, zeta = components(spec.seas[sg.sea], sg.heading_deg, cond.beta, rng, n_freq)
        x = _interp_xi(xi_tf, w, j) * zeta[:, None]
        coef = np.concatenate([x, -1j * w[:, None] * x, -(w[:, None] ** 2) * x], axis=1)
        seg_x = synthesize(w, coef, t[i0], 1.0 / FS, i1 - i0)
        tt = t[i0:i1] - sg.t0
        h = sg.heading_deg + sg.heading_rate_deg_per_h * tt / 3600.0
        c = np.deg2rad(sg.course_deg)
        v = np.stack([sg.speed * np.sin(c) * np.ones_like(tt), sg.speed * np.cos(c) * np.ones_like(tt)], axis=1)
        if prev is None:
            out[i0:i1], head[i0:i1], vel[i0:i1] = seg_x, h, v
        else:
            wgt = _smooth(tt / TRANSITION_S)
            dh = np.mod(h - head[i0:i1] + 180.0, 360.0) - 180.0
            out[i0:i1] = out[i0:i1] * (1 - wgt[:, None]) + seg_x * wgt[:, None]
            head[i0:i1] = head[i0:i1] + wgt * dh
            vel[i0:i1] = vel[i0:i1] * (1 - wgt[:, None]) + v * wgt[:, None]
        prev = sg
    head = np.mod(head, 360.0)
    return Motions(t, out[:, :6].copy(), out[:, 6:12].copy(), out[:, 12:].copy(), head, vel, segs)


def roll_constants(cond: hydro.Condition, roots: dict) -> tuple[float, float, float, float]:
    """(I_r, B_r, C44, I₀) of the roll equation resonating at the coupled roll root."""
    wr = roots["roll"]
    c44 = cond.C[3, 3]
    i0 = cond.M[3, 3] + np.interp(wr, cond.omega, cond.A[:, 3, 3])
    b = np.interp(wr, cond.omega, cond.B[:, 3, 3]) + cond.Bv[3, 3]
    return c44 / wr**2, b, c44, i0


def apply_quadratic_damping(m: Motions, cond: hydro.Condition, roots: dict, q: float) -> None:
    ir, br, c44, i0 = roll_constants(cond, roots)
    d0, d1, d2 = quadratic_roll(m.xid[:, 3], 1.0 / FS, ir, br, c44, q * i0)
    m.xi[:, 3] += d0
    m.xid[:, 3] += d1
    m.xidd[:, 3] += d2


def imu_signals(m: Motions, cond: hydro.Condition, point_hull: np.ndarray, spec: TrialSpec,
                rng: np.random.Generator) -> pd.DataFrame:
    """IMU by geometry: attitude quaternion (body FLU → ENU), body rates, specific force at the true point."""
    g = cond.hull.g
    lever = effect(spec, "imu_lever_arm")
    p = point_hull - np.array([0.0, 0.0, cond.draft])
    if lever:
        p = p + np.array([lever["dx"], lever["dy"], lever["dz"]])
    phi, th = m.xi[:, 3], m.xi[:, 4]
    yaw_track = np.deg2rad(90.0 - m.heading_deg)
    yaw_rate_track = np.gradient(np.unwrap(yaw_track), 1.0 / FS)
    psi = yaw_track + m.xi[:, 5]
    dphi, dth, dpsi = m.xid[:, 3], m.xid[:, 4], m.xid[:, 5] + yaw_rate_track
    ddphi, ddth, ddpsi = m.xidd[:, 3], m.xidd[:, 4], m.xidd[:, 5] + np.gradient(yaw_rate_track, 1.0 / FS)
    sf, cf, st, ct = np.sin(phi), np.cos(phi), np.sin(th), np.cos(th)
    # body angular velocity and acceleration from ZYX Euler angles (exact)
    w1 = dphi - dpsi * st
    w2 = dth * cf + dpsi * ct * sf
    w3 = -dth * sf + dpsi * ct * cf
    a1 = ddphi - ddpsi * st - dpsi * dth * ct
    a2 = ddth * cf - dth * dphi * sf + ddpsi * ct * sf - dpsi * dth * st * sf + dpsi * dphi * ct * cf
    a3 = -ddth * sf - dth * dphi * cf + ddpsi * ct * cf - dpsi * dth * st * cf - dpsi * dphi * ct * sf
    om = np.stack([w1, w2, w3], axis=1)
    al = np.stack([a1, a2, a3], axis=1)
    rot = Rotation.from_euler("ZYX", np.stack([psi, th, phi], axis=1))
    pp = np.broadcast_to(p, om.shape)
    a_rot_body = np.cross(al, pp) + np.cross(om, np.cross(om, pp))
    # translational accelerations are in the seakeeping frame aligned with the mean heading
    trans = Rotation.from_euler("Z", yaw_track[:, None]).apply(m.xidd[:, :3])
    a_world = trans + rot.apply(a_rot_body)
    f_body = rot.inv().apply(a_world + np.array([0.0, 0.0, g]))
    mis = effect(spec, "imu_misalignment")
    if mis:
        mount = Rotation.from_euler("ZYX", [mis["yaw_deg"], mis["pitch_deg"], mis["roll_deg"]], degrees=True)
        rot = rot * mount
        om = mount.inv().apply(om)
        f_body = mount.inv().apply(f_body)
    n = m.t.size
    gyro = om + rng.normal(0, 3e-4, (n, 3)) + rng.normal(0, 5e-5, 3)
    acc = f_body + rng.normal(0, 8e-3, (n, 3)) + rng.normal(0, 3e-3, 3)
    att_noise = Rotation.from_rotvec(rng.normal(0, 2e-4, (n, 3)))
    q = (rot * att_noise).as_quat()  # x, y, z, w
    return pd.DataFrame({"wx": gyro[:, 0], "wy": gyro[:, 1], "wz": gyro[:, 2], "ax": acc[:, 0], "ay": acc[:, 1],
                         "az": acc[:, 2], "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]})


def gnss_table(m: Motions, spec: TrialSpec, rng: np.random.Generator) -> tuple[pd.DataFrame, np.ndarray, np.ndarray]:
    yaw = np.deg2rad(90.0 - m.heading_deg)
    wave_v = Rotation.from_euler("Z", yaw[:, None]).apply(np.c_[m.xid[:, :2], np.zeros(m.t.size)])[:, :2]
    wave_x = Rotation.from_euler("Z", yaw[:, None]).apply(np.c_[m.xi[:, :2], np.zeros(m.t.size)])[:, :2]
    track = np.cumsum(m.vel_en, axis=0) / FS
    pos = track + wave_x
    lat0, lon0 = spec.start_latlon
    lat = lat0 + np.rad2deg(pos[:, 1] / R_EARTH)
    lon = lon0 + np.rad2deg(pos[:, 0] / (R_EARTH * np.cos(np.deg2rad(lat0))))
    sel = np.arange(0, m.t.size, int(FS))
    k = sel.size
    tab = pd.DataFrame({
        "latitude": np.round(lat[sel] + np.rad2deg(rng.normal(0, 0.8, k) / R_EARTH), 7),
        "longitude": np.round(lon[sel] + np.rad2deg(rng.normal(0, 0.8, k) / (R_EARTH * np.cos(np.deg2rad(lat0)))), 7),
        "vel_east": np.round((m.vel_en + wave_v)[sel, 0] + rng.normal(0, 0.03, k), 3),
        "vel_north": np.round((m.vel_en + wave_v)[sel, 1] + rng.normal(0, 0.03, k), 3)})
    return tab, lat, lon


def _r(x, nd=6):
    return float(round(float(x), nd))


def generate(spec: TrialSpec, out_dir: Path, n_freq: int = 80) -> dict:
    """Write one trial into out_dir/<trial>/ and return its truth dict."""
    from seatune.simulate.log_writers import Stream, write_csv, write_mcap

    rng = np.random.default_rng(spec.seed)
    tdir = Path(out_dir) / spec.trial
    tdir.mkdir(parents=True, exist_ok=True)
    hd = hull_data(spec.hull)
    cond = hydro.condition(hd, spec.loading)
    roots = hydro.coupled_natural_frequencies(cond)
    vessel = vessel_yaml(spec.hull)
    m = simulate_motions(spec, cond, roots, rng, n_freq)
    qd = effect(spec, "quadratic_roll_damping")
    if qd:
        apply_quadratic_damping(m, cond, roots, qd["q"])
    imu = imu_signals(m, cond, imu_point(vessel), spec, rng)
    times = spec.start + pd.to_timedelta(np.round(m.t * 1e9).astype(np.int64), unit="ns")
    imu.insert(0, "time", times)
    write_mcap(tdir / "imu.mcap", [Stream("/imu/data", "sensor_msgs/msg/Imu", "imu_link", imu)],
               message_index=False)
    gnss, lat, lon = gnss_table(m, spec, rng)
    gnss.insert(0, "time", times[:: int(FS)])
    write_csv(tdir / "gnss.csv", gnss)

    # hindcast: hourly, the sea of the segment at each hour, degraded
    hc = spec.hindcast
    t_end = spec.start + pd.Timedelta(seconds=float(m.t[-1]))
    hours = pd.date_range(spec.start.floor("h"), t_end.ceil("h") + pd.Timedelta(hours=1), freq="h")
    steps = []
    for h in hours:
        s = (h - spec.start).total_seconds()
        sg = next((g for g in m.segs if g.t0 <= s < g.t1), m.segs[0] if s < 0 else m.segs[-1])
        parts = era5.degrade(spec.seas[sg.sea], hc["hs_rel_error"], hc["tp_error_s"], hc["dir_error_deg"],
                             hc["gamma"], hc["spread_factor"])
        steps.append(era5.fields(parts, hc["layout"]))
    glat, glon = era5.grid_around(lat, lon)
    era5.write(tdir / "era5.nc", hours, glat, glon, steps, hc["layout"], hc["time_dim"])

    vessel_rel = os.path.relpath(VESSELS[spec.hull], tdir)
    windows = []
    for sg in m.segs:
        if sg.kind != "drift":
            continue
        a = spec.start + pd.Timedelta(seconds=sg.t0 + TRANSITION_S)
        b = spec.start + pd.Timedelta(seconds=sg.t1)
        windows.append({"start": a.isoformat(), "end": b.isoformat(), "heading_deg": _r(sg.heading_deg, 3),
                        "heading_rate_deg_per_h": _r(sg.heading_rate_deg_per_h, 3),
                        "hs": _r(hs_of(spec.seas[sg.sea]), 4), "tp": _r(peak_period(spec.seas[sg.sea]), 4),
                        "dir_from_deg": _r(mean_direction(spec.seas[sg.sea]), 3),
                        "partitions": [p.as_dict() for p in spec.seas[sg.sea]]})
    lo = spec.loading.as_dict()
    lo["draft"] = cond.draft
    truth = {
        "trial": spec.trial, "seed": int(spec.seed), "hull": spec.hull, "vessel": vessel_rel,
        "category": spec.category, "effects": [{k: (_r(v) if isinstance(v, float) else v) for k, v in e.items()}
                                               for e in spec.effects],
        "loading": {k: _r(v, 8 if k == "mass" else 6) for k, v in lo.items()},
        "natural_frequencies": {k: _r(roots[k]) for k in ("heave", "roll", "pitch") if k in roots},
        "hindcast": {"layout": hc["layout"], "time_dim": hc["time_dim"], "missing_swell": bool(hc["missing_swell"]),
                     "hs_rel_error": _r(hc["hs_rel_error"]), "tp_error_s": _r(hc["tp_error_s"]),
                     "dir_error_deg": _r(hc["dir_error_deg"]), "gamma": _r(hc["gamma"]),
                     "spreading": "cos2s", "spread_factor": _r(hc["spread_factor"])},
        "start": spec.start.isoformat(), "end": t_end.isoformat(), "sample_rate_hz": FS,
        "imu_point": [float(x) for x in imu_point(vessel)],
        "windows": windows,
        "generator": "seatune.simulate (independent trial path)",
    }
    (tdir / "truth.yaml").write_text(yaml.safe_dump(truth, sort_keys=False))
    run = {
        "name": spec.trial, "run_dir": "run", "vessel": vessel_rel,
        "logs": [{"path": "imu.mcap"},
                 {"path": "gnss.csv", "kind": "gnss", "time_column": "time",
                  "columns": {"latitude": "latitude", "longitude": "longitude", "vel_east": "vx", "vel_north": "vy"}}],
        "topics": {"imu": "/imu/data"},
        "hindcast": {"path": "era5.nc", "uncertainty": {"hs_rel_std": 0.10, "tp_std_s": 0.5, "dir_std_deg": 5}},
        "ingest": {"rate_hz": 10, "max_gap_s": 2.0, "frame": "FLU"},
        "windows": {"max_sog": 0.5, "max_heading_change_deg": 10, "min_duration_s": 900, "max_duration_s": 3600},
        "filter": {"theta_max": 0.05, "gamma_max": 0.9, "f_min_hz": 0.1, "f_max_hz": 0.9, "welch_segment_s": 256},
        "identify": {"known": {"mass": _r(spec.loading.mass, 2), "zcg": _r(spec.loading.zcg)}},
        "tuning": {"backend": "dbi", "parameters": list(spec.tuning_parameters), "holdout_every": 3},
    }
    (tdir / "run.yaml").write_text(yaml.safe_dump(run, sort_keys=False))
    return truth

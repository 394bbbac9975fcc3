"""`seatune vessel info` and `seatune vessel rao`: what the vessel model says, as a dict or a table."""

from __future__ import annotations

import numpy as np
import pandas as pd

from seatune.io.rao_export import CHANNEL_UNITS, RAO_UNITS
from seatune.physics.hydro import DOFS
from seatune.physics.loading import Loading, load
from seatune.physics.modes import coupled_modes
from seatune.physics.response import channel_raos, motion_raos
from seatune.pipeline.vessel import VesselModel

UNITS_PER_ROW = "per row; the unit in the row's `units`"


def imo_roll_period(length: float, beam: float, draft: float, gm: float) -> float:
    """IMO A.749 weather-criterion estimate T = 2 f B / √GM, f = 0.373 + 0.023 B/T − 0.043 L/100."""
    f = 0.373 + 0.023 * beam / draft - 0.043 * length / 100.0
    return 2 * f * beam / np.sqrt(gm)


def vessel_summary(model: VesselModel, loading: Loading | None = None) -> dict:
    loading = model.base_loading if loading is None else loading
    db = model.db
    lh = load(db, loading)
    mg = loading.mass[0] * db.g
    modes = coupled_modes(db, loading)
    wn = modes.omega[0]
    draft = float(lh.draft[0])
    i0, i1, w = lh.draft_index
    kb = draft + float((1 - w[0]) * db.center_of_buoyancy[i0[0], 2] + w[0] * db.center_of_buoyancy[i1[0], 2])
    gmt = float(lh.stiffness[0, 3, 3] / mg)
    out = {
        "name": model.spec.name,
        "length_m": model.length,
        "beam_m": model.beam,
        "database_drafts_m": [float(d) for d in db.drafts],
        "n_omega": int(db.omega.size),
        "omega_range_rad_s": [float(db.omega[0]), float(db.omega[-1])],
        "n_wave_directions": int(db.wave_direction.size),
        "mass_kg": float(loading.mass[0]),
        "displacement_m3": float(loading.mass[0] / db.rho),
        "draft_m": draft,
        "kb_m": kb,
        "kg_m": float(loading.zcg[0]),
        "gmt_m": gmt,
        "gml_m": float(lh.stiffness[0, 4, 4] / mg),
        "gmt_fs_m": float(loading.gmt_fs[0]),
        "natural_period_heave_s": float(2 * np.pi / wn[0]),
        "natural_period_roll_s": float(2 * np.pi / wn[1]),
        "natural_period_pitch_s": float(2 * np.pi / wn[2]),
        # coupled modes (roots of det(C − ω²(M + A(ω)))): roll about its roll centre, pitch about its pitch centre
        "roll_centre_above_keel_m": float(modes.roll_centre_z[0] + draft),
        "pitch_centre_above_keel_m": float(modes.pitch_centre_z[0] + draft),
        "natural_period_roll_uncoupled_s": float(2 * np.pi / modes.uncoupled[0, 1]),
        "channels": [c.name for c in model.channels],
    }
    if model.length and model.beam and gmt > 0:
        out["roll_period_imo_s"] = float(imo_roll_period(model.length, model.beam, draft, gmt))
    return out


def rao_table(model: VesselModel, loading: Loading, include_channels: bool = True) -> tuple[pd.DataFrame, dict]:
    """Long table of motion (and channel) RAOs for one loading condition."""
    db = model.db
    xi = motion_raos(db, loading)[0]  # (nw, nb, 6)
    parts = [_long(db, xi, list(DOFS), "dof", [RAO_UNITS[d] for d in DOFS])]
    if include_channels and model.channels:
        h = channel_raos(db, loading, model.channels)[0]
        parts.append(_long(db, h, [c.name for c in model.channels], "channel",
                           [CHANNEL_UNITS[c.kind] for c in model.channels]))
    df = pd.concat(parts, ignore_index=True)
    units = {"omega": "rad/s", "wave_direction": "rad", "wave_direction_deg": "deg", "response": "",
             "response_type": "", "units": "", "re": UNITS_PER_ROW, "im": UNITS_PER_ROW,
             "amplitude": UNITS_PER_ROW, "phase": "rad"}
    return df, units


def _long(db, values: np.ndarray, names: list[str], kind: str, units: list[str]) -> pd.DataFrame:
    nw, nb, nr = values.shape
    om, beta, r = np.meshgrid(db.omega, db.wave_direction, np.arange(nr), indexing="ij")
    v = values.ravel()
    return pd.DataFrame({
        "omega": om.ravel(),
        "wave_direction": beta.ravel(),
        "wave_direction_deg": np.degrees(beta.ravel()),
        "response": np.asarray(names)[r.ravel()],
        "response_type": kind,
        "units": np.asarray(units)[r.ravel()],
        "re": v.real,
        "im": v.imag,
        "amplitude": np.abs(v),
        "phase": np.angle(v),  # lag convention of x(t) = Re{X e^{-iωt}}
    })

"""RAO files for other tools: xarray (netCDF) and the layout of `waveresponse.RAO.from_amp_phase`.

Both carry their conventions in the file (RAO_CONVENTIONS), not only in the README.
"""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

from seatune.physics.hydro import DOFS
from seatune.physics.loading import Loading, load
from seatune.physics.response import channel_raos, motion_raos

RAO_CONVENTIONS = {
    "frequency": "omega, wave frequency in rad/s (no forward speed: encounter = wave frequency)",
    "wave_direction": "going-to direction of the waves, counter-clockwise seen from above from body +x, in rad "
                      "(wave_direction_deg in deg): 0 following seas, pi/2 waves from starboard, pi head seas",
    "time_convention": "x(t) = Re{X exp(-i omega t)} (Capytaine's)",
    "phase": "lag in rad: phase = arg X, x(t) = |X| cos(omega t - phase) for a wave crest at the reference "
             "point at t = 0",
    "amplitude": "per unit wave amplitude (1 m); units per response in `units`",
    "angles": "rad (roll, pitch, yaw, rates in rad/s)",
    "reference_point": "wave elevation and rotations at the body origin: centreline, hull-frame x = 0 station, "
                       "calm waterline of the loading's draft; channels at their own points",
    "frame": "body frame x forward, y to port, z up; roll positive starboard down, pitch positive bow down",
}

# waveresponse.RAO.from_amp_phase keywords describing the `waveresponse` file (seatune's native conventions)
WAVERESPONSE_KWARGS = {"freq_hz": False, "degrees": True, "clockwise": False, "waves_coming_from": False,
                       "phase_degrees": False, "phase_leading": False}

RAO_UNITS = {"Surge": "m/m", "Sway": "m/m", "Heave": "m/m", "Roll": "rad/m", "Pitch": "rad/m", "Yaw": "rad/m"}
CHANNEL_UNITS = {"angle": "rad/m", "rate": "rad/s/m", "displacement": "m/m", "velocity": "m/s/m",
                 "acceleration": "m/s^2/m", "specific_force": "m/s^2/m"}


def rao_dataset(model, loading: Loading, include_channels: bool = True) -> xr.Dataset:
    """RAOs of the first loading condition: complex `rao` (response, omega, wave_direction)."""

    db = model.db
    one = loading.take(slice(0, 1))
    values = [np.moveaxis(motion_raos(db, one)[0], -1, 0)]
    names, kinds, units = list(DOFS), ["dof"] * 6, [RAO_UNITS[d] for d in DOFS]
    if include_channels and model.channels:
        values.append(np.moveaxis(channel_raos(db, one, model.channels)[0], -1, 0))
        names += [c.name for c in model.channels]
        kinds += ["channel"] * len(model.channels)
        units += [CHANNEL_UNITS[c.kind] for c in model.channels]
    draft = float(load(db, one).draft[0])
    ds = xr.Dataset(
        {"rao": (("response", "omega", "wave_direction"), np.concatenate(values))},
        coords={"response": names, "response_type": ("response", kinds), "units": ("response", units),
                "omega": db.omega, "wave_direction": db.wave_direction,
                "wave_direction_deg": ("wave_direction", np.degrees(db.wave_direction))},
        attrs={"vessel": model.spec.name, "draft_m": draft, **RAO_CONVENTIONS,
               "loading": json.dumps({p: float(getattr(one, p)[0]) for p in (
                   "mass", "xcg", "ycg", "zcg", "r44", "r55", "r66", "gmt_fs", "gml_fs",
                   "beta33", "beta44", "beta55")})},
    )
    ds["omega"].attrs["units"] = "rad/s"
    ds["wave_direction"].attrs["units"] = "rad"
    ds["wave_direction_deg"].attrs["units"] = "deg"
    ds["rao"].attrs["description"] = "complex RAO per unit wave amplitude, unit per response in `units`"
    return ds


def save_rao_xarray(ds: xr.Dataset, path) -> None:
    """netCDF with complex values along a `complex` dim (re, im), as Capytaine stores them."""
    from capytaine.io.xarray import separate_complex_values

    from seatune.atomic import atomic_path

    with atomic_path(path) as tmp:
        separate_complex_values(ds).to_netcdf(tmp, engine="netcdf4")


def load_rao_xarray(path) -> xr.Dataset:
    from capytaine.io.xarray import merge_complex_values

    with xr.open_dataset(path, engine="netcdf4") as ds:
        return merge_complex_values(ds.load())


def save_waveresponse(ds: xr.Dataset, path) -> None:
    """netCDF holding the arguments of `waveresponse.RAO.from_amp_phase` per response.

    Variables `freq` [rad/s], `dirs` [deg], `amp`, `phase` [rad, lag] (response, freq, dirs); the keywords in
    the attribute `waveresponse_from_amp_phase` (JSON). `waveresponse_raos` rebuilds the RAO objects.
    """
    from seatune.atomic import atomic_path

    rao = ds["rao"].values
    out = xr.Dataset(
        {"amp": (("response", "freq", "dirs"), np.abs(rao)),
         "phase": (("response", "freq", "dirs"), np.angle(rao))},
        coords={"response": ds["response"].values, "units": ("response", ds["units"].values),
                "freq": ds["omega"].values, "dirs": ds["wave_direction_deg"].values},
        attrs={**ds.attrs, "waveresponse_from_amp_phase": json.dumps(WAVERESPONSE_KWARGS)},
    )
    out["freq"].attrs["units"] = "rad/s"
    out["dirs"].attrs["units"] = "deg"
    out["phase"].attrs["units"] = "rad"
    with atomic_path(path) as tmp:
        out.to_netcdf(tmp, engine="netcdf4")


def waveresponse_raos(path) -> dict:
    """{response: waveresponse.RAO} from a file written by `save_waveresponse` (needs `waveresponse`)."""
    import waveresponse as wr

    with xr.open_dataset(path, engine="netcdf4") as ds:
        kwargs = json.loads(ds.attrs["waveresponse_from_amp_phase"])
        return {str(r): wr.RAO.from_amp_phase(ds["freq"].values, ds["dirs"].values, ds["amp"].sel(response=r).values,
                                              ds["phase"].sel(response=r).values, **kwargs)
                for r in ds["response"].values}

"""A degraded wave hindcast written as ERA5 netCDF the way users download it from the CDS (own xarray code).

Layouts (drawn per trial): ``bulk`` (swh, pp1d, mwd), ``partitions`` (bulk + wind sea shww/mpww/mdww and
total swell shts/mpts/mdts) and ``d2fd`` (log10 of F(f, θ) [m²·s/rad] on ERA5's 30 frequencies
f_n = 0.03453·1.1^(n−1) Hz × 24 going-to directions 7.5° + 15°(k−1), the grid ``wavespectra.read_era5``
assumes). Time dims: new CDS (``valid_time``, NETCDF4, float32, int64 seconds since 1970) or legacy
grib_to_netcdf (``time``, NETCDF3 64-bit, int16 packing, int32 hours since 1900). Grid 0.5°, hourly.
No wall-clock time is written anywhere (the bank regenerates bit-identically).

ERA5 definitions: swh = 4√m0; pp1d = 1/f at the peak of the 1-D spectrum; mwd = energy-weighted vector mean
coming-from direction; mpww / mpts = T_{m−1,0}.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from seatune.atomic import atomic_path
from seatune.simulate.independent.seas import (
    Partition,
    directional_spectrum,
    hs_of,
    mean_direction,
    mean_period_m10,
    peak_period,
)

ERA5_FREQ = 0.03453 * 1.1 ** np.arange(30)  # Hz
ERA5_DIR_TO = 7.5 + 15.0 * np.arange(24)  # deg, going-to, clockwise from North
D2FD_FLOOR = 1e-9  # m² s/rad: smaller spectral values are missing in ERA5 (packing threshold)


def degrade(parts: list[Partition], hs_rel: float, tp_err: float, dir_err: float, gamma: float,
            spread_factor: float) -> list[Partition]:
    """The hindcast's version of the partitions it holds: Hs × (1 + hs_rel), Tp + tp_err, direction + dir_err,
    JONSWAP γ and cos-2s spreading of the wave model instead of the truth's."""
    out = []
    for p in parts:
        if not p.in_hindcast:
            continue
        out.append(Partition(kind=p.kind, hs=p.hs * (1 + hs_rel), tp=max(p.tp + tp_err, 2.5),
                             dir_from_deg=float(np.mod(p.dir_from_deg + dir_err, 360.0)), gamma=gamma,
                             spreading="cos2s", spread_deg=float(np.clip(p.spread_deg * spread_factor, 8.0, 60.0)),
                             shape="jonswap"))
    return out


def fields(parts: list[Partition], layout: str) -> dict:
    """Values of one time step at one point: {name: float} or {"d2fd": (30, 24)}."""
    if layout == "d2fd":
        w = 2 * np.pi * ERA5_FREQ
        s = directional_spectrum(w, np.mod(ERA5_DIR_TO + 180.0, 360.0), parts)  # m² s/rad² (ω, θ)
        f = 2 * np.pi * s  # per Hz and per radian: F(f, θ) = 2π S(ω, θ)
        with np.errstate(divide="ignore"):
            return {"d2fd": np.where(f > D2FD_FLOOR, np.log10(np.maximum(f, 1e-300)), np.nan)}
    out = {"swh": hs_of(parts), "pp1d": peak_period(parts), "mwd": mean_direction(parts)}
    if layout == "partitions":
        wind = [p for p in parts if p.kind == "wind_sea"]
        swell = [p for p in parts if p.kind != "wind_sea"]
        for group, names in ((wind, ("shww", "mpww", "mdww")), (swell, ("shts", "mpts", "mdts"))):
            if group:
                out.update(dict(zip(names, (hs_of(group), mean_period_m10(group), mean_direction(group)),
                                    strict=True)))
            else:
                out.update({names[0]: 0.0, names[1]: np.nan, names[2]: np.nan})
    return out


_UNITS = {"swh": "m", "pp1d": "s", "mwd": "Degree true", "shww": "m", "mpww": "s", "mdww": "Degree true",
          "shts": "m", "mpts": "s", "mdts": "Degree true", "d2fd": "m**2 s radian**-1"}
_NAMES = {"swh": "Significant height of combined wind waves and swell", "pp1d": "Peak wave period",
          "mwd": "Mean wave direction", "shww": "Significant height of wind waves",
          "mpww": "Mean period of wind waves", "mdww": "Mean direction of wind waves",
          "shts": "Significant height of total swell", "mpts": "Mean period of total swell",
          "mdts": "Mean direction of total swell", "d2fd": "2D wave spectra (single)"}


def grid_around(lat: np.ndarray, lon: np.ndarray, res: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """ERA5 grid points (0.5°) covering the track with one cell to spare."""
    la = np.arange(np.floor(lat.min() / res) - 1, np.ceil(lat.max() / res) + 2) * res
    lo = np.arange(np.floor(lon.min() / res) - 1, np.ceil(lon.max() / res) + 2) * res
    return la, lo


def write(path: Path, times: pd.DatetimeIndex, lat: np.ndarray, lon: np.ndarray, steps: list[dict],
          layout: str, time_dim: str) -> Path:
    """Write hourly `steps` (one :func:`fields` dict per time, spatially uniform) on the lat/lon grid."""
    t = pd.DatetimeIndex(times).tz_convert("UTC").tz_localize(None) if pd.DatetimeIndex(times).tz else times
    nt, ny, nx = len(t), lat.size, lon.size
    new = time_dim == "valid_time"
    lat_desc = np.sort(lat)[::-1]
    lon = np.sort(lon)
    data_vars, encoding = {}, {}
    names = ["d2fd"] if layout == "d2fd" else list(steps[0])
    for name in names:
        if name == "d2fd":
            arr = np.stack([s["d2fd"] for s in steps])  # (t, f, d)
            arr = np.broadcast_to(arr[:, :, :, None, None], (nt, 30, 24, ny, nx))
            dims = (time_dim, "frequencyNumber" if new else "frequency", "directionNumber" if new else "direction",
                    "latitude", "longitude")
        else:
            arr = np.broadcast_to(np.array([s[name] for s in steps], float)[:, None, None], (nt, ny, nx))
            dims = (time_dim, "latitude", "longitude")
        data_vars[name] = xr.Variable(dims, np.array(arr), {"units": _UNITS[name], "long_name": _NAMES[name]})
    coords = {}
    if new:
        coords["number"] = xr.Variable((), np.int64(0), {"long_name": "ensemble member numerical id"})
        coords[time_dim] = xr.Variable(time_dim, t.values, {"long_name": "time", "standard_name": "time"})
        encoding[time_dim] = {"units": "seconds since 1970-01-01", "calendar": "proleptic_gregorian", "dtype": "int64"}
        coords["latitude"] = xr.Variable("latitude", lat_desc, {"units": "degrees_north", "standard_name": "latitude"})
        coords["longitude"] = xr.Variable("longitude", lon, {"units": "degrees_east", "standard_name": "longitude"})
        coords["expver"] = xr.Variable(time_dim, np.full(nt, "0001"), {"long_name": "Experiment version"})
        for name in data_vars:
            data_vars[name] = data_vars[name].astype(np.float32)
            encoding[name] = {"_FillValue": np.float32(np.nan), "zlib": True, "complevel": 1}
        attrs = {"GRIB_centre": "ecmf", "Conventions": "CF-1.7",
                 "institution": "European Centre for Medium-Range Weather Forecasts",
                 "history": "SYNTHETIC ERA5-layout hindcast (seatune.simulate.independent.era5, trial bank)"}
        fmt = "NETCDF4"
    else:
        hours = np.round((t - pd.Timestamp("1900-01-01")) / pd.Timedelta(hours=1)).astype(np.int32)
        coords["longitude"] = xr.Variable("longitude", lon.astype(np.float32), {"units": "degrees_east"})
        coords["latitude"] = xr.Variable("latitude", lat_desc.astype(np.float32), {"units": "degrees_north"})
        coords[time_dim] = xr.Variable(time_dim, np.asarray(hours), {"units": "hours since 1900-01-01 00:00:00.0",
                                                                      "long_name": "time", "calendar": "gregorian"})
        for name, var in data_vars.items():
            fin = var.values[np.isfinite(var.values)]
            lo, hi = (float(fin.min()), float(fin.max())) if fin.size else (0.0, 0.0)
            scale = (hi - lo) / 65532.0 if hi > lo else 1.0
            encoding[name] = {"dtype": "int16", "scale_factor": scale, "add_offset": 0.5 * (hi + lo),
                              "_FillValue": np.int16(-32767), "missing_value": np.int16(-32767)}
        attrs = {"Conventions": "CF-1.6", "history": "SYNTHETIC ERA5-layout hindcast (legacy grib_to_netcdf layout)"}
        fmt = "NETCDF3_64BIT"
    if layout == "d2fd":
        itype = np.int64 if new else np.int32
        coords["frequencyNumber" if new else "frequency"] = np.arange(1, 31, dtype=itype)
        coords["directionNumber" if new else "direction"] = np.arange(1, 25, dtype=itype)
    ds = xr.Dataset(data_vars, coords=coords, attrs=attrs)
    for name in ds.coords:
        encoding.setdefault(name, {"_FillValue": None})
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, format=fmt, engine="netcdf4", encoding=encoding)
    return Path(path)

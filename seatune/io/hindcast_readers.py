"""Read wave hindcasts (ERA5, WW3 / wavespectra spectra, NORA3-like bulk netCDF, seatune CSV) and put them on a track.

Everything leaves this module in one convention (DESIGN §3, ecosystem §4.3):

* ``Hindcast.bulk``: an xarray Dataset with dims ``(time, lat, lon)`` for a regular grid (lat ascending,
  lon as the file has them, 0..360 or −180..180) or ``(time, site)`` for stations / a single point
  (``lat``/``lon`` coordinates per site when the file has them; the CSV has none). ``time`` is naive
  UTC ``datetime64[ns]``. Variables: ``hs`` [m], ``tp`` [s], ``dir_from_deg`` [deg, nautical
  *coming-from*], optionally ``mwp`` [s] (ERA5 T_{m−1,0}), ``tm01``/``tm02`` [s], ``spreading`` [rad],
  and partitions ``wind_*`` / ``swell_*`` (``_hs``, ``_tp`` or ``_mwp``, ``_dir_from_deg``).
* ``Hindcast.spectra``: ``efth(time, lat, lon | site, freq, dir)`` in wavespectra's convention — freq [Hz],
  dir [deg, coming-from, sorted ascending], m²/(Hz·deg) — or None. Held in memory (the file is closed
  after reading; ERA5 subsets around a trial are a few MB).

Directions that a product stores as *going-to* (WW3 native spectra, some NORA3 products) are turned to
coming-from here and never downstream.

ERA5 partition periods ``mpww``/``mpts`` are *mean* periods (T_{m−1,0}, like ``mwp``), not peak periods:
they become ``wind_mwp``/``swell_mwp``, not ``wind_tp``/``swell_tp`` (about 10 % shorter than Tp for a
JONSWAP sea; calling them Tp would bias any spectrum rebuilt from them).

Interpolation (:func:`at_track`, :func:`spectrum_at`): bilinear in lat/lon on a grid, with longitudes
treated on the circle (a box across 0°/360° or ±180°, or a global grid, is one contiguous interval);
inverse-distance weighting between scattered stations (wavespectra's ``sel(method="idw")`` rule);
linear in time. Directions are interpolated as unit vectors. Corners holding NaN (land, an absent
partition) are left out and the other weights renormalised; the number of such points is kept in
``DataFrame.attrs["partial_stencil"]``.

Land and sea ice: every reader leaves them NaN in every variable and spectrum. ERA5 has them missing;
wavespectra's ERA5 reader fills the missing d2fd with 0, so a spectrum without any positive value is
land / ice unless the file's own ``swh`` says sea. At the track, ``sea_corners`` / ``stencil_corners``
count the neighbours used and those with a weight; a track point without any sea neighbour is a UserError.
"""

from __future__ import annotations

import copy
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from numpy.typing import ArrayLike

from seatune.errors import UserError

__all__ = ["FORMATS", "Hindcast", "read_hindcast", "at_track", "spectrum_at"]

FORMATS = ("auto", "era5", "ww3", "wavespectra", "bulk_netcdf", "csv")

# ERA5 short name → seatune bulk name (ECMWF GRIB table 140; see hindcast_writers for the definitions).
_ERA5_BULK = {
    "swh": "hs",
    "pp1d": "tp",
    "mwd": "dir_from_deg",
    "mwp": "mwp",
    "shww": "wind_hs",
    "mpww": "wind_mwp",
    "mdww": "wind_dir_from_deg",
    "shts": "swell_hs",
    "mpts": "swell_mwp",
    "mdts": "swell_dir_from_deg",
}
_ERA5_NAMES = set(_ERA5_BULK) | {"d2fd"}
_CSV_REQUIRED = ("time", "hs", "tp", "dir_from_deg")
_ORDER = (
    "hs",
    "tp",
    "dir_from_deg",
    "spreading",
    "mwp",
    "tm01",
    "tm02",
    "wind_hs",
    "wind_tp",
    "wind_mwp",
    "wind_dir_from_deg",
    "swell_hs",
    "swell_tp",
    "swell_mwp",
    "swell_dir_from_deg",
)
_UNITS = {"hs": "m", "tp": "s", "mwp": "s", "tm01": "s", "tm02": "s", "spreading": "rad"}
# wavespectra's default search radius [deg] for inverse-distance weighting between stations (core/select.py)
IDW_TOLERANCE_DEG = 2.0
IDW_MAX_SITES = 4
_EPS_DEG = 1e-6  # positions this close outside the grid edge count as on it (float32 coordinates)

# Bulk netCDF (NORA3-like and CF-named products): candidates per seatune name, standard_name first.
_BULK_STANDARD_NAMES = {
    "hs": ("sea_surface_wave_significant_height",),
    "tp": ("sea_surface_wave_period_at_variance_spectral_density_maximum",),
    "dir_from_deg": (
        "sea_surface_wave_from_direction",
        "sea_surface_wave_to_direction",
    ),
}
_BULK_NAMES = {
    "hs": ("hs", "Hs", "hm0", "Hm0", "VHM0"),
    "tp": ("tp", "Tp", "VTPK"),
    "dir_from_deg": ("dir_from_deg", "thq", "mdir", "dm", "Dm", "VMDR", "Pdir", "dir"),
    "tm01": ("tm01", "tm1", "VTM01"),
    "tm02": ("tm02", "tm2", "VTM02"),
    "spreading": ("spreading",),
    "wind_hs": ("wind_hs", "hs_sea", "VHM0_WW"),
    "wind_tp": ("wind_tp", "tp_sea"),
    "wind_dir_from_deg": ("wind_dir_from_deg", "thq_sea", "VMDR_WW"),
    "swell_hs": ("swell_hs", "hs_swell"),
    "swell_tp": ("swell_tp", "tp_swell"),
    "swell_dir_from_deg": ("swell_dir_from_deg", "thq_swell"),
}


@dataclass
class Hindcast:
    """A wave hindcast in seatune's convention (see the module docstring)."""

    source: str  # the file it was read from
    bulk: xr.Dataset
    spectra: xr.DataArray | None = None
    format: str = ""
    notes: list[str] = field(default_factory=list)  # repairs made while reading (counted in the report)


# --------------------------------------------------------------------------------------------------
# small helpers
# --------------------------------------------------------------------------------------------------


def _fmt_num(x: float) -> str:
    """Degrees for messages: 62.0, 60.5, 359.75 (one to four decimals)."""
    s = f"{x:.4f}".rstrip("0")
    s = s + "0" if s.endswith(".") else s
    return "0.0" if s == "-0.0" else s


def _fmt_time(t: pd.Timestamp, ref: pd.Timestamp | None = None) -> str:
    """2026-03-14T04:00Z, or 05:00Z when `ref` is on the same day."""
    t = pd.Timestamp(t)
    clock = t.strftime("%H:%M:%S" if (t.second or t.microsecond) else "%H:%M") + "Z"
    if ref is not None and pd.Timestamp(ref).normalize() == t.normalize():
        return clock
    return f"{t:%Y-%m-%d}T{clock}"


def _utc_naive(times, source: str | None = None, what: str = "times") -> pd.DatetimeIndex:
    try:
        if isinstance(times, str | pd.Timestamp | np.datetime64) or np.ndim(times) == 0:
            times = [times]
        idx = pd.DatetimeIndex(pd.to_datetime(list(times) if not hasattr(times, "dtype") else times, utc=True))
    except (ValueError, TypeError) as exc:
        raise UserError(source, what, f"cannot read times: {exc}") from None
    return idx.tz_convert("UTC").tz_localize(None).as_unit("ns")


def _check_increasing(
    t: pd.DatetimeIndex, source: str, place: str | None = None, row: str = "time", first: int = 1
) -> tuple[pd.DatetimeIndex, np.ndarray]:
    """Strictly increasing times. Exact duplicates are repaired by the caller (index of rows to keep)."""
    if t.hasnans:
        i = int(np.flatnonzero(t.isna())[0])
        raise UserError(source, place, f"time of {row} {i + first} is missing or unreadable")
    keep = np.ones(t.size, bool)
    if t.size > 1:
        d = np.diff(t.asi8)
        bad = np.flatnonzero(d < 0)
        if bad.size:
            i = int(bad[0])
            raise UserError(
                source,
                place,
                f"times not increasing: {_fmt_time(t[i + 1])} ({row} {i + 1 + first}) follows {_fmt_time(t[i])}",
            )
        keep[1:] = d > 0
    return t[keep], keep


def _finish_bulk(ds: xr.Dataset) -> xr.Dataset:
    """Order variables, wrap directions to [0, 360), set units; every variable NaN where Hs is (land, ice)."""
    names = [n for n in _ORDER if n in ds] + sorted(n for n in ds.data_vars if n not in _ORDER)
    ds = ds[names]
    sea = np.isfinite(ds["hs"].astype(float)) if "hs" in ds else None
    for n in names:
        ds[n] = ds[n].astype(float)
        if sea is not None:
            ds[n] = ds[n].where(sea)
        if n.endswith("dir_from_deg"):
            ds[n] = np.mod(ds[n], 360.0)
            ds[n].attrs["units"] = "degree"
            ds[n].attrs["convention"] = "nautical, coming-from, clockwise from true North"
        elif n in _UNITS or n.endswith(("_hs", "_tp", "_mwp")):
            ds[n].attrs["units"] = _UNITS.get(n, "m" if n.endswith("_hs") else "s")
    return ds


# --------------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------------


_READ: dict[tuple, Hindcast] = {}  # the last file read, by (path, size, mtime, format, convention)


def read_hindcast(path: str | Path, format: str = "auto", *, direction_convention: str | None = None) -> Hindcast:
    """Read a wave hindcast file; a file read before and unchanged since (size, mtime) is not parsed again (each
    stage of `seatune run` reads it), and the caller gets its own copy.

    Parameters
    ----------
    path : str or Path
        ERA5 netCDF (new or legacy CDS layout; bulk ``swh pp1d mwd mwp``, partitions ``shww mpww mdww
        shts mpts mdts``, 2-D spectra ``d2fd`` through ``wavespectra.read_era5``), WW3 spectral netCDF
        (``wavespectra.read_ww3``), a wavespectra netCDF (``efth`` over ``freq``, ``dir``), a bulk netCDF
        with CF standard names or NORA3 names (``hs tp thq``, ``hs_sea``…, ``hs_swell``…), or the seatune
        hindcast CSV (``time, hs, tp, dir_from_deg`` [+ ``spreading``, partitions]; one site).
    format : {"auto", "era5", "ww3", "wavespectra", "bulk_netcdf", "csv"}
        "auto" decides by content: netCDF by its signature and the variables present, else CSV.
    direction_convention : {"from", "to"}, optional
        For bulk netCDF only: the convention of direction variables, overriding their attributes. Needed
        when a file says neither (no ``standard_name`` …from/to_direction, no "from"/"to" in the names).

    Returns
    -------
    Hindcast

    Raises
    ------
    UserError
        Missing, empty or malformed file (one line naming the file, the place and the problem).
    """
    try:
        stat = Path(path).stat()
        key = (str(Path(path).resolve()), stat.st_size, stat.st_mtime_ns, format, direction_convention)
    except OSError:
        return _read_hindcast(path, format, direction_convention)  # it says what is wrong with the path
    if key not in _READ:
        hc = _read_hindcast(path, format, direction_convention)
        _READ.clear()
        _READ[key] = hc
    return copy.deepcopy(_READ[key])


def _read_hindcast(path: str | Path, format: str, direction_convention: str | None) -> Hindcast:
    path = Path(path)
    src = str(path)
    if format not in FORMATS:
        raise UserError(src, None, f"unknown hindcast format {format!r}; expected one of {', '.join(FORMATS)}")
    if direction_convention not in (None, "from", "to"):
        raise UserError(src, None, f"direction_convention must be 'from' or 'to', got {direction_convention!r}")
    if not path.is_file():
        raise UserError(src, None, "file not found" if not path.exists() else "not a file")
    with open(path, "rb") as f:
        head = f.read(8)
    if not head or (path.stat().st_size < 1024 and not path.read_bytes().strip()):
        raise UserError(src, None, "file is empty")
    is_nc = head[:3] == b"CDF" or head == b"\x89HDF\r\n\x1a\n"
    if head[:4] == b"GRIB":
        raise UserError(src, None, "is a GRIB file; download the hindcast as netCDF (or convert it, e.g. cfgrib)")
    if format == "csv" or (format == "auto" and not is_nc):
        if is_nc:
            raise UserError(src, None, "is a netCDF file, not CSV (use format 'auto')")
        return _read_csv(path)
    if not is_nc:
        raise UserError(src, None, f"not a netCDF file (format {format!r} expects netCDF)")
    try:
        with xr.open_dataset(path, decode_times=False) as raw:
            names = set(raw.variables)
            kind = _detect_netcdf(raw)
    except (OSError, ValueError, RuntimeError) as exc:
        raise UserError(src, None, f"cannot open as netCDF: {exc}") from None
    if format != "auto" and format != kind:
        expected = {
            "era5": "ERA5 variables (swh, pp1d, mwd and/or d2fd)",
            "ww3": "WW3 spectra (efth over frequency, direction, station)",
            "wavespectra": "wavespectra spectra (efth over freq, dir)",
            "bulk_netcdf": "bulk wave variables (hs, tp and a direction)",
        }[format]
        raise UserError(src, None, f"expected {expected}; found variables {sorted(names)}")
    if kind == "unknown":
        raise UserError(
            src,
            None,
            f"no wave hindcast variables: found {sorted(names) or 'none'}; expected ERA5 (swh, pp1d, mwd and/or "
            "d2fd), WW3/wavespectra spectra (efth over frequency/freq and direction/dir) or bulk (hs, tp, direction)",
        )
    if kind == "bulk_netcdf":
        return _read_bulk_nc(path, direction_convention)
    return {"era5": _read_era5, "ww3": _read_ww3, "wavespectra": _read_wavespectra}[kind](path)


def _detect_netcdf(ds: xr.Dataset) -> str:
    names = set(ds.variables)
    if names & _ERA5_NAMES:
        return "era5"
    if "efth" in names:
        dims = set(ds["efth"].dims)
        if {"frequency", "direction"} <= dims:
            return "ww3"
        if {"freq", "dir"} <= dims:
            return "wavespectra"
    if _find_bulk_var(ds, "hs") is not None:
        return "bulk_netcdf"
    return "unknown"


def _wavespectra(src: str, what: str):
    try:
        import wavespectra
    except ImportError:  # an optional dependency (extra "test"); the user can install it
        raise UserError(src, None, f"reading {what} needs the wavespectra package (pip install wavespectra)") from None
    return wavespectra


def _time_dim(ds: xr.Dataset, src: str) -> str:
    for name in ("time", "valid_time"):
        if name in ds.dims:
            return name
    raise UserError(src, None, f"no time dimension (time or valid_time); dimensions are {sorted(ds.dims)}")


def _regular_time(ds: xr.Dataset, tname: str, src: str) -> xr.Dataset:
    """Decode, check and de-duplicate the time axis; rename it to ``time``."""
    t = _utc_naive(ds[tname].values, src, tname)
    t, keep = _check_increasing(t, src, tname)
    if not keep.all():
        ds = ds.isel({tname: np.flatnonzero(keep)})
    ds = ds.assign_coords({tname: t.values})
    if tname != "time":
        ds = ds.rename({tname: "time"})
    ds.attrs["duplicate_times_removed"] = int((~keep).sum())
    return ds


def _read_era5(path: Path) -> Hindcast:
    src = str(path)
    try:
        ds = xr.open_dataset(path)
    except (OSError, ValueError) as exc:
        raise UserError(src, None, f"cannot decode ERA5 netCDF: {exc}") from None
    with ds:
        tname = _time_dim(ds, src)
        missing_dims = [d for d in ("latitude", "longitude") if d not in ds.dims]
        if missing_dims:
            raise UserError(src, None, f"ERA5 file without {missing_dims} dimension(s); dimensions {sorted(ds.dims)}")
        present = [n for n in _ERA5_BULK if n in ds.data_vars]
        has_spec = "d2fd" in ds.data_vars
        need = [n for n in ("swh", "pp1d", "mwd") if n not in present]
        if need and not has_spec:
            raise UserError(
                src,
                None,
                f"ERA5 file lacks {', '.join(need)} (and has no d2fd spectra to derive them); "
                f"found {sorted(ds.data_vars)}; expected swh, pp1d, mwd (+ mwp, shww, mpww, mdww, shts, mpts, mdts)",
            )
        extra = sorted(set(ds.dims) - {tname, "latitude", "longitude", "expver", "frequency", "direction"})
        extra = [d for d in extra if d not in ("frequencyNumber", "directionNumber") and ds.sizes[d] > 1]
        if extra:
            raise UserError(
                src,
                None,
                f"unexpected dimension(s) {extra} (ensemble or forecast steps?); expected {tname}, latitude, longitude",
            )
        bulk = _merge_expver(ds[present]).load() if present else None
        # Everything is read into memory and the file closed here: lazily opened handles shared through
        # xarray's file cache can be closed under another reader of the same file (netCDF ids are reused),
        # which then fails with "NetCDF: HDF error".
        raw_spec = ds[["d2fd"]].load() if has_spec else None
    n_dup = 0
    if bulk is not None:
        bulk = bulk.squeeze([d for d in bulk.dims if d not in (tname, "latitude", "longitude")], drop=True)
        bulk = bulk.reset_coords(drop=True).rename({n: _ERA5_BULK[n] for n in present})
        bulk = bulk.rename({"latitude": "lat", "longitude": "lon"})
        bulk = _regular_time(bulk, tname, src)
        n_dup = bulk.attrs.pop("duplicate_times_removed", 0)

    spectra = None
    if has_spec:
        _wavespectra(src, "ERA5 2-D spectra (d2fd)")
        try:
            from wavespectra.input.era5 import from_era5  # read_era5 = xr.open_dataset + from_era5

            sds = from_era5(raw_spec)
        except (OSError, ValueError, KeyError) as exc:
            raise UserError(src, "d2fd", f"wavespectra cannot read the spectra: {exc}") from None
        efth = _merge_expver(sds["efth"], zero_filled=True)
        efth = efth.squeeze([d for d in efth.dims if d not in ("time", "lat", "lon", "freq", "dir")], drop=True)
        t = _utc_naive(efth["time"].values, src, "time")
        t, keep = _check_increasing(t, src, "time")
        efth = efth.isel(time=np.flatnonzero(keep)).assign_coords(time=t.values)
        spectra = efth.sortby("lat").sortby("dir").transpose("time", "lat", "lon", "freq", "dir")
        stats = _spectral_bulk(spectra)
        stats["hs"] = stats["hs"].where(_has_spectrum(spectra))  # wavespectra's 0 at land → NaN
        if bulk is None:
            bulk = stats
        else:
            for name in ("hs", "tp", "dir_from_deg"):
                if name not in bulk:
                    bulk[name] = stats[name]
            bulk["spreading"] = stats["spreading"]
    bulk = _finish_bulk(bulk.sortby("lat").transpose("time", "lat", "lon"))
    _check_grid(bulk, src)
    if spectra is not None:  # land / ice by the file's swh when it has one, else by the empty spectra
        spectra = _mask_spectra(spectra, bulk)
    notes = [f"{n_dup} duplicated time(s) dropped"] if n_dup else []
    return Hindcast(src, bulk, spectra, "era5", notes)


def _merge_expver(obj, zero_filled: bool = False):
    """Old CDS files mixing ERA5 and ERA5T carry an ``expver`` dimension: take the first non-missing value.

    Each time is valid in one expver and missing in the other; wavespectra has already turned missing
    spectra into 0 (`zero_filled`), so there the sum over expver is that value.
    """
    if "expver" not in obj.dims:
        return obj
    if zero_filled:
        return obj.sum("expver")
    out = obj.isel(expver=0, drop=True)
    for k in range(1, obj.sizes["expver"]):
        out = out.combine_first(obj.isel(expver=k, drop=True))
    return out


def _has_spectrum(efth: xr.DataArray) -> xr.DataArray:
    """False where a spectrum holds no energy at all: all NaN, or all 0 as wavespectra fills ERA5's missing
    (land / sea-ice) points (``from_era5``: ``fillna(0)``). A sea spectrum of ERA5 is never identically 0:
    its values are 10**d2fd > 0, only single bins below the packing floor are missing."""
    return (efth > 0).any(("freq", "dir"))


def _mask_spectra(efth: xr.DataArray, bulk: xr.Dataset) -> xr.DataArray:
    """Spectra NaN where the bulk Hs is (land, ice); `bulk` has the spectra's (time, space) order."""
    sea = np.isfinite(bulk["hs"].values)
    if sea.all():
        return efth
    return efth.where(xr.DataArray(sea, dims=bulk["hs"].dims))


def _spectral_bulk(efth: xr.DataArray) -> xr.Dataset:
    """hs, tp, dir_from_deg (wavespectra Dm, the mean direction as ERA5's mwd), tm01, spreading [rad]."""
    spec = efth.spec
    out = xr.Dataset(
        {
            "hs": spec.hs(),
            "tp": spec.tp(),
            "dir_from_deg": spec.dm(),
            "tm01": spec.tm01(),
            "spreading": np.deg2rad(spec.dspr()),  # σθ = √(2(1−R)) (Kuik et al. 1988), wavespectra in degrees
        }
    )
    out = out.reset_coords(drop=True).compute()
    # wavespectra's Tp is NaN for a calm sea (no peak) — ok; its Hs is 0 there.
    return out


def _read_ww3(path: Path) -> Hindcast:
    src = str(path)
    _wavespectra(src, "WW3 spectra")
    try:
        from wavespectra.input.ww3 import from_ww3  # read_ww3 = open the file + from_ww3

        with xr.open_dataset(path) as raw:
            raw = raw.load()
        sds = from_ww3(raw)
    except (OSError, ValueError, KeyError) as exc:
        raise UserError(src, None, f"wavespectra cannot read the WW3 spectra: {exc}") from None
    return _from_spec_dataset(sds, src, "ww3")


def _read_wavespectra(path: Path) -> Hindcast:
    src = str(path)
    ws = _wavespectra(src, "wavespectra netCDF spectra")
    with xr.open_dataset(path, decode_times=False) as raw:
        dir_attrs = dict(raw["dir"].attrs) if "dir" in raw.variables else {}
    try:
        sds = ws.read_netcdf(str(path))
        loaded = sds.load()
        sds.close()
        sds = loaded
    except (OSError, ValueError, KeyError) as exc:
        raise UserError(src, None, f"wavespectra cannot read the spectra: {exc}") from None
    if _says_going_to(dir_attrs):  # wavespectra's convention is coming-from; a file may say otherwise
        sds = sds.assign_coords(dir=(sds["dir"] + 180.0) % 360.0)
    return _from_spec_dataset(sds, src, "wavespectra")


def _from_spec_dataset(sds: xr.Dataset, src: str, kind: str) -> Hindcast:
    if "efth" not in sds or "time" not in sds["efth"].dims:
        raise UserError(src, None, f"no efth(time, …, freq, dir) spectra; found {sorted(sds.variables)}")
    efth = sds["efth"]
    t = _utc_naive(efth["time"].values, src, "time")
    t, keep = _check_increasing(t, src, "time")
    efth = efth.isel(time=np.flatnonzero(keep)).assign_coords(time=t.values)
    if "site" in efth.dims:
        efth = efth.reset_coords([c for c in efth.coords if c not in efth.dims], drop=True)
        for std, names in (("lat", ("lat", "latitude")), ("lon", ("lon", "longitude"))):
            name = next((n for n in names if n in sds.variables and set(sds[n].dims) <= {"site", "time"}), None)
            if name is not None:
                v = sds[name]
                v = v.isel(time=0) if "time" in v.dims else v  # stations do not move (as wavespectra's from_ww3)
                v = np.broadcast_to(np.asarray(v.values, float), (efth.sizes["site"],))
                efth = efth.assign_coords({std: ("site", v)})
        space = ("site",)
    elif "lat" in efth.dims and "lon" in efth.dims:
        efth = efth.sortby("lat")
        space = ("lat", "lon")
    else:
        efth = efth.expand_dims("site", axis=1)
        for c in ("lat", "lon"):
            if c in sds and sds[c].size == 1:
                efth = efth.assign_coords({c: ("site", np.atleast_1d(sds[c].values).astype(float))})
        space = ("site",)
    unknown = sorted(set(efth.dims) - {"time", *space, "freq", "dir"})
    if unknown:
        raise UserError(
            src, None, f"spectra with unexpected dimension(s) {unknown}; expected time, {', '.join(space)}, freq, dir"
        )
    efth = efth.sortby("dir").transpose("time", *space, "freq", "dir")
    extra = [c for c in efth.coords if c not in ("time", "lat", "lon", "site", "freq", "dir")]
    efth = efth.reset_coords(extra, drop=True)
    bulk = _spectral_bulk(efth)
    bulk["hs"] = bulk["hs"].where(_has_spectrum(efth))  # an all-NaN or all-0 spectrum is land / ice
    for c in ("lat", "lon"):
        if c in efth.coords:
            bulk = bulk.assign_coords({c: efth[c]})
    bulk = _finish_bulk(bulk.transpose("time", *space))
    if space == ("lat", "lon"):
        _check_grid(bulk, src)
    efth = _mask_spectra(efth, bulk)
    notes = [f"{int((~keep).sum())} duplicated time(s) dropped"] if not keep.all() else []
    return Hindcast(src, bulk, efth, kind, notes)


# ---- bulk netCDF (NORA3-like) -----------------------------------------------------------------------


def _find_bulk_var(ds: xr.Dataset, name: str) -> str | None:
    for sn in _BULK_STANDARD_NAMES.get(name, ()):
        for v in ds.data_vars:
            if ds[v].attrs.get("standard_name") == sn:
                return str(v)
    for cand in _BULK_NAMES.get(name, ()):
        if cand in ds.data_vars:
            return cand
    return None


_TO_PATTERNS = re.compile(
    r"to_direction|going[ -]to(wards?)?\b|propagat\w* (to|towards)\b|direction to\b|\boceanographic\b|\boceanic\b"
)
_FROM_PATTERNS = re.compile(r"from_direction|coming[ -]from|direction from\b|\bmeteorological\b|\bnautical\b")


def _says_going_to(attrs: dict) -> bool | None:
    """True / False when a variable's attributes say going-to / coming-from, None when they do not say."""
    sn = str(attrs.get("standard_name", "")).lower()
    if "to_direction" in sn:
        return True
    if "from_direction" in sn:
        return False
    text = " ".join(
        str(attrs.get(k, "")) for k in ("long_name", "description", "comment", "convention", "direction_convention")
    ).lower()
    to, frm = bool(_TO_PATTERNS.search(text)), bool(_FROM_PATTERNS.search(text))
    if to != frm:
        return to
    return None


def _read_bulk_nc(path: Path, direction_convention: str | None) -> Hindcast:
    src = str(path)
    try:
        ds = xr.open_dataset(path)
    except (OSError, ValueError) as exc:
        raise UserError(src, None, f"cannot decode netCDF: {exc}") from None
    with ds:
        found = {name: _find_bulk_var(ds, name) for name in _BULK_NAMES}
        need = [n for n in ("hs", "tp", "dir_from_deg") if found[n] is None]
        if need:
            raise UserError(
                src,
                None,
                f"bulk wave file lacks {', '.join(need)}; found {sorted(ds.data_vars)}; expected hs, tp and a "
                "direction (CF standard names, NORA3 hs/tp/thq, or ERA5 swh/pp1d/mwd)",
            )
        found = {k: v for k, v in found.items() if v is not None}
        tname = _time_dim(ds, src)
        out = {}
        conventions = []
        for name, var in found.items():
            da = ds[var].load()
            if name.endswith("dir_from_deg"):
                to = _says_going_to(da.attrs)
                if direction_convention is not None:
                    to = direction_convention == "to"
                elif to is None:
                    if var.endswith("_from_deg"):
                        to = False
                    else:
                        raise UserError(
                            src,
                            var,
                            "direction variable does not say whether it is coming-from or going-to (no "
                            "standard_name sea_surface_wave_from/to_direction); set direction_convention 'from' "
                            "or 'to'",
                        )
                if to:
                    da = da + 180.0  # going-to (oceanographic) → coming-from (DESIGN §3)
                conventions.append(f"{var}: {'going-to, converted' if to else 'coming-from'}")
            out[name] = da
        bulk, space = _bulk_space(xr.Dataset(out), tname, src)
        bulk = bulk.reset_coords([c for c in bulk.coords if c not in (tname, "lat", "lon", *space)], drop=True)
        bulk = _regular_time(bulk, tname, src)
    n_dup = bulk.attrs.pop("duplicate_times_removed", 0)
    if space == ("lat", "lon"):
        bulk = bulk.sortby("lat")
    bulk = _finish_bulk(bulk.transpose("time", *space))
    bulk.attrs["directions"] = "; ".join(conventions)
    if space == ("lat", "lon"):
        _check_grid(bulk, src)
    notes = [f"{n_dup} duplicated time(s) dropped"] if n_dup else []
    return Hindcast(src, bulk, None, "bulk_netcdf", notes)


def _bulk_space(bulk: xr.Dataset, tname: str, src: str) -> tuple[xr.Dataset, tuple[str, ...]]:
    """The bulk dataset with its spatial layout as (lat, lon) or (site,), and those dims."""
    for std, names in (("lat", ("latitude", "lat")), ("lon", ("longitude", "lon"))):
        name = next((n for n in names if n in bulk.variables), None)
        if name is not None and name != std:
            bulk = bulk.rename({name: std})
    dims = [d for d in bulk.dims if d != tname]
    singles = [d for d in dims if bulk.sizes[d] == 1]
    if singles:
        bulk = bulk.squeeze(singles)
        dims = [d for d in dims if d not in singles]
    lat = bulk["lat"] if "lat" in bulk.variables else None
    lon = bulk["lon"] if "lon" in bulk.variables else None
    if not dims:  # a single point
        bulk = bulk.reset_coords([c for c in ("lat", "lon") if c in bulk.coords], drop=True).expand_dims("site", axis=1)
        for c, v in (("lat", lat), ("lon", lon)):
            if v is not None and v.size == 1:
                bulk = bulk.assign_coords({c: ("site", np.atleast_1d(np.asarray(v.values, float)))})
        return bulk, ("site",)
    if set(dims) == {"lat", "lon"}:
        return bulk, ("lat", "lon")
    if len(dims) == 1 and (lat is None or lat.dims == (dims[0],)) and (lon is None or lon.dims == (dims[0],)):
        return (bulk.rename({dims[0]: "site"}) if dims[0] != "site" else bulk), ("site",)
    raise UserError(
        src,
        None,
        f"spatial layout {dims} is not supported (curvilinear or rotated grid?); expected a regular latitude/"
        "longitude grid, stations, or a single point",
    )


def _check_grid(bulk: xr.Dataset, src: str) -> None:
    for c in ("lat", "lon"):
        v = bulk[c].values
        if not np.all(np.isfinite(v)):
            raise UserError(src, c, "coordinate holds missing values")
        if np.unique(v).size != v.size:
            raise UserError(src, c, "coordinate repeats values")


# ---- CSV ------------------------------------------------------------------------------------------


def _read_csv(path: Path) -> Hindcast:
    src = str(path)
    try:
        df = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True)
    except pd.errors.EmptyDataError:
        raise UserError(src, None, "file is empty") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UserError(src, None, f"not a readable CSV: {msg}") from None
    df.columns = [str(c).strip() for c in df.columns]
    df = df.fillna("")  # short rows: their missing fields are empty
    missing = [c for c in _CSV_REQUIRED if c not in df.columns]
    if missing:
        raise UserError(
            src,
            "header",
            f"missing column(s) {', '.join(missing)}; found {', '.join(df.columns)}; expected "
            f"{', '.join(_CSV_REQUIRED)} (+ spreading, wind_*/swell_* partitions)",
        )
    if df.empty:
        raise UserError(src, None, "no data rows (header only)")
    raw_t = df["time"].str.strip()
    t = pd.to_datetime(raw_t, utc=True, errors="coerce", format="ISO8601")
    if t.isna().any():
        i = int(np.flatnonzero(t.isna().to_numpy())[0])
        raise UserError(src, f"line {i + 2}, column time", f"not a time: {raw_t.iloc[i]!r}")
    idx = pd.DatetimeIndex(t).tz_convert("UTC").tz_localize(None).as_unit("ns")
    data = {}
    ignored = []
    for col in df.columns:
        if col == "time":
            continue
        s = df[col].str.strip()
        num = pd.to_numeric(s.replace("", np.nan), errors="coerce")
        bad = num.isna() & s.ne("") & ~s.str.lower().isin(("nan", "na", "null"))
        if bad.any():
            if col in _ORDER:
                i = int(np.flatnonzero(bad.to_numpy())[0])
                raise UserError(src, f"line {i + 2}, column {col}", f"not a number: {s.iloc[i]!r}")
            ignored.append(col)  # a user's own text column (e.g. a comment) is not ours to judge
            continue
        if col in _ORDER and np.isinf(num).any():
            i = int(np.flatnonzero(np.isinf(num.to_numpy()))[0])
            raise UserError(src, f"line {i + 2}, column {col}", f"not a finite number: {s.iloc[i]!r}")
        data[col] = num.to_numpy(dtype=float)
    for col in ("hs", "tp") + tuple(c for c in data if c.endswith(("_hs", "_tp"))):
        v = data.get(col)
        if v is None:
            continue
        neg = (v < 0) if col.endswith("hs") else (v <= 0)
        if np.any(neg):
            i = int(np.flatnonzero(neg)[0])
            raise UserError(
                src,
                f"line {i + 2}, column {col}",
                f"{'negative' if col.endswith('hs') else 'non-positive'} value {v[i]:g}",
            )
    idx_ok, keep = _check_increasing(idx, src, "column time", row="line", first=2)
    notes = []
    if not keep.all():
        # an exact duplicate row is a recoverable defect; a duplicated time with other values is not
        first = np.flatnonzero(~keep)
        for i in first:
            same = all((np.isnan(v[i]) and np.isnan(v[i - 1])) or v[i] == v[i - 1] for v in data.values())
            if not same:
                raise UserError(
                    src, f"line {i + 2}", f"time {_fmt_time(idx[i])} repeats line {i + 1} with different values"
                )
        notes.append(f"{int((~keep).sum())} duplicated row(s) dropped")
    bulk = xr.Dataset(
        {k: (("time", "site"), v[keep][:, None]) for k, v in data.items()},
        coords={"time": idx_ok.values},
    )
    bulk = _finish_bulk(bulk)
    if ignored:
        bulk.attrs["ignored_columns"] = ", ".join(ignored)
    return Hindcast(src, bulk, None, "csv", notes)


# --------------------------------------------------------------------------------------------------
# interpolation
# --------------------------------------------------------------------------------------------------


@dataclass
class _Stencil:
    it: np.ndarray  # (n, 2) time indices
    wt: np.ndarray  # (n, 2) time weights
    isp: np.ndarray  # (n, m) flat spatial indices
    ws: np.ndarray  # (n, m) spatial weights


def _time_stencil(hc: Hindcast, t: pd.DatetimeIndex) -> tuple[np.ndarray, np.ndarray]:
    T = pd.DatetimeIndex(hc.bulk["time"].values).as_unit("ns")
    Ti = T.asi8
    ti = t.asi8
    problems = []
    before = ti < Ti[0]
    after = ti > Ti[-1]
    if before.any():
        a = t[before].min()
        b = min(t.max(), T[0])
        problems.append(
            f"track {_fmt_time(a)}–{_fmt_time(b, a)} is before the hindcast's first time {_fmt_time(T[0], a)}"
        )
    if after.any():
        a = max(t.min(), T[-1])
        b = t[after].max()
        problems.append(
            f"track {_fmt_time(a)}–{_fmt_time(b, a)} is after the hindcast's last time {_fmt_time(T[-1], a)}"
        )
    if problems:
        raise UserError(hc.source, None, "; ".join(problems))
    n = ti.size
    if Ti.size == 1:
        return np.zeros((n, 2), int), np.tile([1.0, 0.0], (n, 1))
    i0 = np.clip(np.searchsorted(Ti, ti, side="right") - 1, 0, Ti.size - 2)
    w1 = (ti - Ti[i0]).astype(float) / (Ti[i0 + 1] - Ti[i0]).astype(float)
    return np.stack([i0, i0 + 1], axis=1), np.stack([1.0 - w1, w1], axis=1)


def _axis_1d(x: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Linear stencil on an ascending axis `x` for in-range `q`: indices (n, 2), weights (n, 2)."""
    if x.size == 1:
        return np.zeros((q.size, 2), int), np.tile([1.0, 0.0], (q.size, 1))
    i0 = np.clip(np.searchsorted(x, q, side="right") - 1, 0, x.size - 2)
    w1 = np.clip((q - x[i0]) / (x[i0 + 1] - x[i0]), 0.0, 1.0)
    return np.stack([i0, i0 + 1], axis=1), np.stack([1.0 - w1, w1], axis=1)


def _lon_frame(lon: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, bool]:
    """Longitudes on the circle as one increasing run: (start, positions, file indices, cyclic).

    The run starts after the largest gap between neighbouring longitudes (mod 360), so a box across
    0°/360° ([0, 0.5, 1.0, 359.5] → 359.5, 0, 0.5, 1.0) or across ±180° is contiguous. A global grid
    (all gaps equal) is cyclic: the first node is repeated at +360°.
    """
    L = np.mod(lon, 360.0)
    order = np.argsort(L, kind="stable")
    Ls = L[order]
    if Ls.size == 1:
        return float(Ls[0]), np.zeros(1), order, False
    gaps = np.diff(np.r_[Ls, Ls[0] + 360.0])
    if np.allclose(gaps, gaps[0], rtol=0, atol=1e-6):
        pos = np.r_[Ls - Ls[0], 360.0]
        return float(Ls[0]), pos, np.r_[order, order[0]], True
    j = int(np.argmax(gaps))
    idx = np.roll(order, -(j + 1))
    start = float(L[idx[0]])
    pos = np.mod(L[idx] - start, 360.0)
    pos[0] = 0.0
    return start, pos, idx, False


def _grid_stencil(hc: Hindcast, lat: np.ndarray, lon: np.ndarray, t: pd.DatetimeIndex) -> tuple[np.ndarray, np.ndarray]:
    la = hc.bulk["lat"].values.astype(float)
    lo = hc.bulk["lon"].values.astype(float)
    out_lat = (lat < la[0] - _EPS_DEG) | (lat > la[-1] + _EPS_DEG) | ~np.isfinite(lat)
    if out_lat.any():
        k = int(np.argmax(np.where(out_lat, np.abs(lat - np.clip(lat, la[0], la[-1])), -1.0)))
        if not np.isfinite(lat[k]):
            k = int(np.flatnonzero(~np.isfinite(lat))[0])
        raise UserError(
            hc.source,
            None,
            f"lat {_fmt_num(lat[k])} outside {_fmt_num(la[0])}–{_fmt_num(la[-1])} (track at {_fmt_time(t[k])}; "
            f"{int(out_lat.sum())} of {lat.size} track points outside)",
        )
    start, pos, idx, _cyclic = _lon_frame(lo)
    p = np.mod(lon - start, 360.0)
    p = np.where(p > 360.0 - _EPS_DEG, 0.0, p)
    out_lon = (p > pos[-1] + _EPS_DEG) | ~np.isfinite(lon)
    if out_lon.any():
        # the farthest point: distance to the nearer edge of the run on the circle
        dist = np.minimum(p - pos[-1], 360.0 - p)
        k = int(np.argmax(np.where(out_lon, np.nan_to_num(dist, nan=1e9), -1.0)))
        raise UserError(
            hc.source,
            None,
            f"lon {_fmt_num(lon[k])} outside {_fmt_num(lo[idx[0]])}–{_fmt_num(lo[idx[-1]])} (eastward; track at "
            f"{_fmt_time(t[k])}; {int(out_lon.sum())} of {lon.size} track points outside)",
        )
    p = np.minimum(p, pos[-1])
    iy, wy = _axis_1d(la, np.clip(lat, la[0], la[-1]))
    ixp, wx = _axis_1d(pos, p)
    ix = idx[ixp]
    nx = lo.size
    isp = (iy[:, :, None] * nx + ix[:, None, :]).reshape(lat.size, 4)
    ws = (wy[:, :, None] * wx[:, None, :]).reshape(lat.size, 4)
    return isp, ws


def _site_stencil(hc: Hindcast, lat, lon, t: pd.DatetimeIndex) -> tuple[np.ndarray, np.ndarray]:
    nsite = hc.bulk.sizes["site"]
    n = t.size
    if "lat" not in hc.bulk.coords or "lon" not in hc.bulk.coords or lat is None or lon is None:
        if nsite != 1:
            raise UserError(hc.source, None, f"{nsite} sites without coordinates: cannot place the track among them")
        return np.zeros((n, 1), int), np.ones((n, 1))  # one site (CSV): time only
    slat = hc.bulk["lat"].values.astype(float)
    slon = hc.bulk["lon"].values.astype(float)
    grid = _sites_as_grid(slat, slon)
    if grid is not None:
        glat, glon, lookup = grid
        fake = Hindcast(hc.source, xr.Dataset(coords={"lat": glat, "lon": glon}))
        isp, ws = _grid_stencil(fake, lat, lon, t)
        return lookup.ravel()[isp], ws
    # scattered stations: inverse distance weighting as wavespectra's sel_idw (distance in degrees,
    # ≤ IDW_MAX_SITES neighbours within IDW_TOLERANCE_DEG; a station at the point takes all the weight).
    # Deviation: one neighbour within the tolerance is used (wavespectra masks the point).
    dlon = (lon[:, None] - slon[None, :] + 180.0) % 360.0 - 180.0
    dist = np.hypot(dlon, lat[:, None] - slat[None, :])
    m = min(IDW_MAX_SITES, nsite)
    order = np.argsort(dist, axis=1, kind="stable")[:, :m]
    d = np.take_along_axis(dist, order, axis=1)
    far = ~(d[:, 0] <= IDW_TOLERANCE_DEG)
    if far.any():
        k = int(np.argmax(np.where(far, np.nan_to_num(d[:, 0], nan=1e9), -1.0)))
        raise UserError(
            hc.source,
            None,
            f"lat {_fmt_num(lat[k])}, lon {_fmt_num(lon[k])} (track at {_fmt_time(t[k])}) is {_fmt_num(d[k, 0])}° from "
            f"the nearest site, beyond {_fmt_num(IDW_TOLERANCE_DEG)}° ({int(far.sum())} of {n} track points)",
        )
    with np.errstate(divide="ignore"):
        w = np.where(d <= IDW_TOLERANCE_DEG, 1.0 / d, 0.0)
    exact = d[:, 0] == 0.0
    w[exact] = 0.0
    w[exact, 0] = 1.0
    w /= w.sum(axis=1, keepdims=True)
    return order, w


def _sites_as_grid(slat: np.ndarray, slon: np.ndarray):
    """(lat ascending, lon, lookup[iy, ix] → site) when the sites are every node of a lat/lon grid."""
    ulat, ulon = np.unique(slat), np.unique(slon)
    if ulat.size * ulon.size != slat.size or ulat.size < 2 or ulon.size < 2:
        return None
    iy = np.searchsorted(ulat, slat)
    ix = np.searchsorted(ulon, slon)
    lookup = -np.ones((ulat.size, ulon.size), int)
    lookup[iy, ix] = np.arange(slat.size)
    if (lookup < 0).any():
        return None
    return ulat, ulon, lookup


def _stencil(hc: Hindcast, times, lat, lon) -> tuple[_Stencil, pd.DatetimeIndex]:
    t = _utc_naive(times, hc.source, "track times")
    if t.hasnans:
        raise UserError(hc.source, None, "track times hold missing values")
    n = t.size
    if n == 0:
        raise UserError(hc.source, None, "empty track")
    try:
        la = None if lat is None else np.broadcast_to(np.asarray(lat, dtype=float), (n,)).copy()
        lo = None if lon is None else np.broadcast_to(np.asarray(lon, dtype=float), (n,)).copy()
    except ValueError:
        raise UserError(hc.source, None, f"track lat/lon do not match its {n} times") from None
    for name, v in (("lat", la), ("lon", lo)):
        if v is not None and not np.all(np.isfinite(v)):
            k = int(np.flatnonzero(~np.isfinite(v))[0])
            raise UserError(hc.source, None, f"track {name} missing at {_fmt_time(t[k])}")
    if "site" in hc.bulk.dims:
        isp, ws = _site_stencil(hc, la, lo, t)
    else:
        if la is None or lo is None:
            raise UserError(hc.source, None, "a gridded hindcast needs the track's lat and lon")
        isp, ws = _grid_stencil(hc, la, lo, t)
    it, wt = _time_stencil(hc, t)
    return _Stencil(it, wt, isp, ws), t


def _weighted(values: np.ndarray, st: _Stencil) -> tuple[np.ndarray, np.ndarray]:
    """Σ w v over the (time × space) stencil, leaving NaN corners out and renormalising. values (T, S)."""
    v = values[st.it[:, :, None], st.isp[:, None, :]]  # (n, 2, m)
    w = st.wt[:, :, None] * st.ws[:, None, :]
    ok = np.isfinite(v) & (w > 0)
    wsum = np.where(ok, w, 0.0).sum(axis=(1, 2))
    total = np.where(ok, w * np.where(ok, v, 0.0), 0.0).sum(axis=(1, 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(wsum > 0, total / wsum, np.nan)
    partial = (wsum > 0) & (wsum < np.where(w > 0, w, 0.0).sum(axis=(1, 2)) - 1e-12)
    return out, partial


def _sea_corners(hs: np.ndarray, st: _Stencil) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per track point: spatial corners with a positive weight, those holding sea (finite Hs) at every used
    time, and whether any (time, corner) entry with a positive weight holds sea. hs (T, S)."""
    finite = np.isfinite(hs[st.it[:, :, None], st.isp[:, None, :]])  # (n, 2, m)
    used_t = (st.wt > 0)[:, :, None]
    used_s = st.ws > 0
    sea_always = np.all(finite | ~used_t, axis=1) & used_s
    any_sea = (finite & used_t & used_s[:, None, :]).any(axis=(1, 2))
    return used_s.sum(axis=1), sea_always.sum(axis=1), any_sea


def _no_sea_error(hc: Hindcast, t: pd.DatetimeIndex, lat, lon, n_corners: np.ndarray, any_sea: np.ndarray):
    k = int(np.flatnonzero(~any_sea)[0])
    count = f"{int((~any_sea).sum())} of {any_sea.size} track points"
    single = "site" in hc.bulk.dims and (hc.bulk.sizes["site"] == 1 or "lat" not in hc.bulk.coords)
    if lat is None or lon is None or single:
        where = f"hs missing (land, ice or a gap) at the hindcast times around {_fmt_time(t[k])}"
    else:
        la = float(np.broadcast_to(np.asarray(lat, float), t.shape)[k])
        lo = float(np.broadcast_to(np.asarray(lon, float), t.shape)[k])
        corners = "grid corners" if "site" not in hc.bulk.dims else "nearest sites"
        where = (f"no sea at lat {_fmt_num(la)}, lon {_fmt_num(lo)}, {_fmt_time(t[k])}: all {int(n_corners[k])} "
                 f"{corners} are land or ice (hs missing)")
    raise UserError(hc.source, None, f"{where} ({count})")


def _flat(hc: Hindcast, name: str) -> np.ndarray:
    da = hc.bulk[name]
    space = [d for d in da.dims if d != "time"]
    return da.transpose("time", *space).values.reshape(da.sizes["time"], -1).astype(float)


def at_track(
    hc: Hindcast, times: ArrayLike, lat: ArrayLike | None = None, lon: ArrayLike | None = None
) -> pd.DataFrame:
    """Bulk wave parameters at the vessel track.

    Bilinear in lat/lon (longitudes on the circle: 0..360 or −180..180 grids, boxes across 0°/360° or
    the date line, either convention for the track), inverse-distance weighted between scattered
    stations, time only for a single site (CSV); linear in time. ``*dir_from_deg`` columns are
    interpolated as unit vectors.

    Parameters
    ----------
    hc : Hindcast
    times : array_like (n,)
        Track times (datetime64 / Timestamps / ISO strings; tz-aware, or naive = UTC).
    lat, lon : array_like (n,) or scalar, optional
        Track position [deg]; not needed for a single-site hindcast.

    Returns
    -------
    DataFrame
        ``time`` (datetime64[ns, UTC]), ``hs``, ``tp``, ``dir_from_deg``, the other bulk variables
        (spreading, mwp, partitions …), ``sea_corners`` and ``stencil_corners`` (spatial neighbours with a
        positive weight holding sea at every time used, and all of them: fewer sea corners = a partial
        stencil, renormalised over the sea ones) and ``source`` (the hindcast file).
        ``attrs["partial_stencil"]`` counts the points where NaN neighbours were left out.

    Raises
    ------
    UserError
        A track time or position the hindcast does not cover (naming the file and the uncovered span), or
        one whose neighbours are all land or ice (naming the time and the place).
    """
    st, t = _stencil(hc, times, lat, lon)
    cols: dict[str, np.ndarray] = {"time": pd.DatetimeIndex(t).tz_localize("UTC")}
    partial = np.zeros(t.size, bool)
    sea = None
    if "hs" in hc.bulk:
        hs = _flat(hc, "hs")
        n_corners, n_sea, any_sea = _sea_corners(hs, st)
        if not any_sea.all():
            _no_sea_error(hc, t, lat, lon, n_corners, any_sea)
        sea = np.isfinite(hs)
    for name in hc.bulk.data_vars:
        v = _flat(hc, name)
        if sea is not None:
            v = np.where(sea, v, np.nan)  # land / ice corners are left out of every variable
        if name.endswith("dir_from_deg"):
            rad = np.deg2rad(v)
            s, p1 = _weighted(np.sin(rad), st)
            c, _ = _weighted(np.cos(rad), st)
            deg = np.rad2deg(np.arctan2(s, c))
            # round off the last bits so that 350°/10° averages to 0, not 359.99999999999997
            out = np.mod(np.round(deg, 9), 360.0)
            out = np.where(np.hypot(s, c) > 1e-12, out, np.nan)
        else:
            out, p1 = _weighted(v, st)
        partial |= p1 & np.isfinite(out)
        cols[name] = out
    if sea is not None:
        cols["sea_corners"], cols["stencil_corners"] = n_sea, n_corners
    df = pd.DataFrame(cols)
    df["source"] = hc.source
    df.attrs["partial_stencil"] = int(partial.sum())
    return df


def spectrum_at(hc: Hindcast, time, lat: float | None = None, lon: float | None = None) -> xr.DataArray | None:
    """The 2-D spectrum efth(freq, dir) [m²/(Hz·deg), dir coming-from] at one track point, or None.

    Interpolated with the weights w_i of :func:`at_track` (bilinear / inverse distance, linear in time):
    the weighted mean of the neighbouring spectra S_i, rescaled by (Σ w_i Hs_i)² / Σ w_i Hs_i² with Hs_i
    the bulk Hs of the neighbours. The plain mean has m0 = Σ w_i m0_i, i.e. Hs = √(Σ w_i Hs_i²), which
    exceeds the interpolated bulk Hs = Σ w_i Hs_i when the sea changes between the neighbours (by 2–3 %
    when a wind sea dies within an hour); the factor makes the spectrum's Hs follow the bulk Hs of
    :func:`at_track` and is exactly 1 on a node (a file's own spectrum is returned unchanged). The shape is
    the energy-weighted mix of the neighbours. Corners without a spectrum (all NaN, or NaN bulk Hs such
    as ERA5 land points) are left out; none left is a UserError naming the time and the place.
    """
    if hc.spectra is None:
        return None
    st, t = _stencil(hc, time, lat, lon)
    if t.size != 1:
        raise UserError(hc.source, None, f"spectrum_at takes one time, got {t.size}")
    it, wt, isp, ws = st.it[0], st.wt[0], st.isp[0], st.ws[0]
    w = wt[:, None] * ws[None, :]  # (2, m)
    keep = w > 0
    ut = np.unique(it[keep.any(axis=1)])
    spec = hc.spectra
    hs = _flat(hc, "hs") if "hs" in hc.bulk else None
    total = 0.0
    wsum = whs = whs2 = 0.0
    if "site" in spec.dims:
        us = np.unique(isp[keep.any(axis=0)])
        block = spec.isel(time=ut, site=us).values  # (nt, ns, nf, nd)

        def corner(a, b):
            return block[np.searchsorted(ut, it[a]), np.searchsorted(us, isp[b])]
    else:
        nx = spec.sizes["lon"]
        iy, ix = isp // nx, isp % nx
        uy, ux = np.unique(iy[keep.any(axis=0)]), np.unique(ix[keep.any(axis=0)])
        block = spec.isel(time=ut, lat=uy, lon=ux).values  # (nt, ny, nx, nf, nd)

        def corner(a, b):
            return block[np.searchsorted(ut, it[a]), np.searchsorted(uy, iy[b]), np.searchsorted(ux, ix[b])]

    for a in range(2):
        for b in range(isp.size):
            if not keep[a, b]:
                continue
            s = corner(a, b)
            if not np.isfinite(s).any() or (hs is not None and not np.isfinite(hs[it[a], isp[b]])):
                continue
            total = total + w[a, b] * np.nan_to_num(s)
            wsum += w[a, b]
            if hs is not None:
                whs += w[a, b] * hs[it[a], isp[b]]
                whs2 += w[a, b] * hs[it[a], isp[b]] ** 2
    coords = {"freq": spec["freq"].values, "dir": spec["dir"].values}
    if wsum == 0.0:
        _no_sea_error(hc, t, lat, lon, np.array([int((ws > 0).sum())]), np.array([False]))
    data = total / wsum
    if whs2 > 0.0:
        data = data * ((whs / wsum) ** 2 / (whs2 / wsum))
    out = xr.DataArray(data, dims=("freq", "dir"), coords=coords, name="efth", attrs=dict(spec.attrs))
    out = out.assign_coords(time=t[0])
    if lat is not None and lon is not None:
        out = out.assign_coords(
            lat=float(np.asarray(lat, float).ravel()[0]), lon=float(np.asarray(lon, float).ravel()[0])
        )
    out["freq"].attrs.update(spec["freq"].attrs)
    out["dir"].attrs.update(spec["dir"].attrs)
    return out

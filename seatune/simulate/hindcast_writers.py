"""Write synthetic wave hindcasts in the layouts of real products (ERA5 netCDF, seatune hindcast CSV).

The sea-trial simulator uses these writers so that the ingest stage is tested on genuine file layouts.
Nothing here reads files; the readers live elsewhere and must not depend on anything this module adds
beyond what the real product holds (the files carry a "synthetic" note in their global attributes only).

ERA5 conventions verified for this module (sources in brackets):

* ``d2fd`` (paramId 140251, "2D wave spectra (single)") holds **log10** of F(f, θ) in m²·s/rad, i.e.
  m²/(Hz·rad): per Hz of frequency and per radian of direction [ECMWF CKB "About ERA wave spectra";
  ``wavespectra/input/era5.py`` converts ``10**d2fd * π/180`` to m²/(Hz·deg)]. F(f, θ) = 2π S(ω, θ) with
  S the seatune spectrum in m²·s/rad² (DESIGN §3).
* 30 frequencies f_n = 0.03453·1.1^(n−1) Hz and 24 directions θ_k = 7.5° + 15°(k−1), **going-to**,
  clockwise from North (oceanographic: 0 = towards North, 90 = towards East) [ECMWF CKB]. wavespectra
  adds 180° to get the coming-from directions ((θ_k + 180) mod 360, in file order) [``from_era5``].
* Spectral values below a packing threshold are **missing** in ERA5 (and land points); they are
  "essentially 0" [ECMWF CKB]; wavespectra fills NaN with 0 [``from_era5``]. :func:`era5_d2fd` marks
  values below ``D2FD_FLOOR`` missing (NaN) the same way, so no log10(0) ever reaches the file.
* New CDS netCDF (2024-): dims ``valid_time``, ``latitude`` (descending), ``longitude``, and for the
  spectra ``frequencyNumber`` (1..30), ``directionNumber`` (1..24), variable order
  ``d2fd(valid_time, frequencyNumber, directionNumber, latitude, longitude)``; legacy CDS netCDF
  (grib_to_netcdf) uses ``time``, ``frequency``, ``direction`` and int16 packing. wavespectra's
  ``read_era5`` accepts both (its MAPPING renames either set of names).
* Bulk parameters [ECMWF GRIB table 140; ecWAM ``femean.F90``]: ``swh`` (140229, m) = 4√m0 of the
  2-D spectrum; ``mwd`` (140230, Degree true, coming-from) = spectral mean direction over all frequencies
  and directions (vector mean); ``pp1d`` (140231, s) = reciprocal of the frequency of the peak of the
  1-D spectrum; ``mwp`` (140232, s) = **T_{m−1,0} = m_{−1}/m_0** (ecWAM FEMEAN: mean frequency
  = E / Σ F Δf/f) — not m0/m1, which is the separate parameter ``mp1`` (140220). Wind-sea / total-swell
  partitions: ``shww`` 140234, ``mdww`` 140235, ``mpww`` 140236, ``shts`` 140237, ``mdts`` 140238,
  ``mpts`` 140239 (the partition periods are taken with the same T_{m−1,0} definition — assumed, not
  verified against ecWAM).
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from numpy.typing import ArrayLike
from scipy import optimize, special

from seatune.atomic import atomic_path
from seatune.physics.spectra import (
    DEFAULT_SPREADING_PARAM,
    SpectrumPartition,
    directional_spectrum,
    wave_direction_from_nautical,
)

__all__ = [
    "ERA5_F0",
    "ERA5_FREQ_RATIO",
    "ERA5_N_FREQ",
    "ERA5_N_DIR",
    "D2FD_FLOOR",
    "ERA5_VARIABLES",
    "HINDCAST_CSV_COLUMNS",
    "GriddedFields",
    "era5_frequencies",
    "era5_frequency_edges",
    "era5_directions_deg",
    "era5_directions_from_deg",
    "era5_spectrum",
    "era5_d2fd",
    "bulk_from_partitions",
    "era5_bulk_fields",
    "directional_spread_rad",
    "grid_fields_around_track",
    "write_era5_netcdf",
    "hindcast_table_from_partitions",
    "write_hindcast_csv",
]

TWO_PI = 2.0 * np.pi
ERA5_F0 = 0.03453  # Hz, first ERA5 frequency
ERA5_FREQ_RATIO = 1.1
ERA5_N_FREQ = 30
ERA5_N_DIR = 24
# Values of F(f, θ) below this are written missing, as ERA5's GRIB packing discards small values. At most
# 720 bins × 1e-10 m²/(Hz·rad) × (0.05 Hz × 0.26 rad) ≈ 1e-12 m² of variance is dropped: Hs is unaffected.
D2FD_FLOOR = 1e-10  # m²·s/rad = m²/(Hz·rad)


@dataclass(frozen=True)
class _Era5Var:
    param_id: int
    short_name: str  # ecCodes shortName (GRIB_shortName); the netCDF variable name is the cfVarName key
    name: str  # ecCodes name, used as long_name
    units: str


# ECMWF GRIB table 140 (ecCodes); names, ids and units as ERA5 netCDF files carry them.
ERA5_VARIABLES: dict[str, _Era5Var] = {
    "swh": _Era5Var(140229, "swh", "Significant height of combined wind waves and swell", "m"),
    "mwd": _Era5Var(140230, "mwd", "Mean wave direction", "Degree true"),
    "pp1d": _Era5Var(140231, "pp1d", "Peak wave period", "s"),
    "mwp": _Era5Var(140232, "mwp", "Mean wave period", "s"),
    "shww": _Era5Var(140234, "shww", "Significant height of wind waves", "m"),
    "mdww": _Era5Var(140235, "mdww", "Mean direction of wind waves", "degrees"),
    "mpww": _Era5Var(140236, "mpww", "Mean period of wind waves", "s"),
    "shts": _Era5Var(140237, "shts", "Significant height of total swell", "m"),
    "mdts": _Era5Var(140238, "mdts", "Mean direction of total swell", "degrees"),
    "mpts": _Era5Var(140239, "mpts", "Mean period of total swell", "s"),
    "d2fd": _Era5Var(140251, "2dfd", "2D wave spectra (single)", "m**2 s radian**-1"),
}
_HEIGHT_VARS = ("swh", "shww", "shts")
_SYNTHETIC_NOTE = "SYNTHETIC data written by seatune.simulate.hindcast_writers (sea-trial simulator), ERA5 layout"


# --------------------------------------------------------------------------------------------------
# ERA5 spectral grid
# --------------------------------------------------------------------------------------------------


def era5_frequencies() -> np.ndarray:
    """The 30 ERA5 frequencies f_n = 0.03453·1.1^(n−1) Hz, n = 1..30 (ECMWF CKB; wavespectra)."""
    return ERA5_F0 * ERA5_FREQ_RATIO ** np.arange(ERA5_N_FREQ)


def era5_frequency_edges() -> np.ndarray:
    """Edges (31,) [Hz] of the cells whose widths are wavespectra's ``np.gradient(freq)``.

    Interior edges are the midpoints (f_n + f_{n+1})/2 (width (f_{n+1} − f_{n−1})/2, also ecWAM's DFIM);
    the two end cells are centred on f_1 and f_30 with widths f_2 − f_1 and f_30 − f_29.
    """
    f = era5_frequencies()
    edges = np.empty(f.size + 1)
    edges[1:-1] = 0.5 * (f[1:] + f[:-1])
    edges[0] = f[0] - 0.5 * (f[1] - f[0])
    edges[-1] = f[-1] + 0.5 * (f[-1] - f[-2])
    return edges


def era5_directions_deg() -> np.ndarray:
    """The 24 ERA5 directions as ERA5 stores them [deg]: 7.5, 22.5, …, 352.5, **going-to**, clockwise from N.

    directionNumber k ↔ θ_k = 7.5° + 15°(k−1) (ECMWF CKB, "direction 0 means going towards the north").
    """
    return 7.5 + 15.0 * np.arange(ERA5_N_DIR)


def era5_directions_from_deg() -> np.ndarray:
    """Coming-from directions [deg] of directionNumber 1..24, as wavespectra's reader assigns them.

    (θ_k + 180°) mod 360 = 187.5, 202.5, …, 352.5, 7.5, …, 172.5 (``wavespectra/input/era5.py``).
    """
    return np.mod(era5_directions_deg() + 180.0, 360.0)


# --------------------------------------------------------------------------------------------------
# 2-D spectra
# --------------------------------------------------------------------------------------------------


def _as_partitions(parts: SpectrumPartition | Sequence[SpectrumPartition] | None) -> list[SpectrumPartition]:
    if parts is None:
        return []
    out = [parts] if isinstance(parts, SpectrumPartition) else list(parts)
    for p in out:
        if not isinstance(p, SpectrumPartition):
            raise TypeError(f"expected SpectrumPartition, got {type(p).__name__}")
    return out


def era5_spectrum(
    partitions: SpectrumPartition | Sequence[SpectrumPartition],
    *,
    sampling: str = "cell_mean",
    n_quad: int = 16,
) -> np.ndarray:
    """2-D spectrum F(f_n, θ_k) [m²/(Hz·rad)] on the ERA5 grid, from JONSWAP partitions with spreading.

    F(f, θ) = 2π S(ω = 2πf, β), with S(ω, β) [m²·s/rad²] from
    :func:`seatune.physics.spectra.directional_spectrum` (its discrete spreading is normalised on the
    24-direction grid, so no variance is lost to the direction discretisation). Direction k is the ERA5
    going-to direction θ_k; it is passed to the model convention with heading 0
    (β_k = ψ − D_k − 180°, D_k = θ_k + 180° the coming-from direction; DESIGN §3).

    Parameters
    ----------
    partitions : SpectrumPartition or sequence of SpectrumPartition
        Wave systems; directions are nautical coming-from (``dir_from_deg``). Empty gives zeros.
    sampling : {"cell_mean", "point"}
        "cell_mean" (default): the mean of the continuous spectrum over each frequency cell of
        :func:`era5_frequency_edges` (Gauss–Legendre, `n_quad` nodes), so Σ F Δf Δθ equals the variance
        of the resolved band whatever Tp — a model spectrum holds the energy of its bins. "point": the
        value at f_n (misstates m0 by up to ~0.5 % for peaked spectra on the 10 % grid).
    n_quad : int
        Quadrature nodes per frequency cell for "cell_mean".

    Returns
    -------
    ndarray, shape (30, 24)
        F [m²/(Hz·rad)], axes (frequencyNumber, directionNumber).
    """
    parts = _as_partitions(partitions)
    beta_grid = wave_direction_from_nautical(era5_directions_from_deg(), 0.0)
    f = era5_frequencies()
    if sampling == "point":
        return TWO_PI * directional_spectrum(TWO_PI * f, beta_grid, parts, 0.0)
    if sampling != "cell_mean":
        raise ValueError(f"sampling must be 'cell_mean' or 'point', got {sampling!r}")
    edges = era5_frequency_edges()
    x, w = np.polynomial.legendre.leggauss(n_quad)
    mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * np.diff(edges)
    nodes = mid[:, None] + half[:, None] * x[None, :]  # (30, n_quad) Hz
    s = directional_spectrum(TWO_PI * nodes.ravel(), beta_grid, parts, 0.0)  # m²·s/rad²
    s = s.reshape(f.size, n_quad, ERA5_N_DIR)
    # cell mean = (1/Δf) ∫ F df = ½ Σ_q w_q F(f_q) (Gauss weights sum to 2)
    return TWO_PI * 0.5 * np.einsum("q,fqd->fd", w, s)


def era5_d2fd(
    partitions_per_time: Sequence[SpectrumPartition | Sequence[SpectrumPartition]],
    *,
    sampling: str = "cell_mean",
    floor: float = D2FD_FLOOR,
    below_floor: str = "missing",
) -> np.ndarray:
    """ERA5 ``d2fd`` values: log10 of F(f, θ) [log10 of m²·s/rad], one spectrum per time.

    Parameters
    ----------
    partitions_per_time : sequence
        Per time, the partitions (or one partition, or an empty list for a calm sea).
    sampling : {"cell_mean", "point"}
        See :func:`era5_spectrum`.
    floor : float
        Threshold on F [m²/(Hz·rad)] below which a bin counts as "small" (default ``D2FD_FLOOR``).
    below_floor : {"missing", "floor"}
        "missing" (default, as ERA5): small bins are NaN in the array and missing in the file; readers
        (wavespectra, ECMWF's own recipe) take them as 0. "floor": small bins are set to log10(floor).

    Returns
    -------
    ndarray, shape (n_time, 30, 24)
        log10 F, axes (time, frequencyNumber, directionNumber); NaN marks missing values.
    """
    if below_floor not in ("missing", "floor"):
        raise ValueError(f"below_floor must be 'missing' or 'floor', got {below_floor!r}")
    if not (np.isfinite(floor) and floor > 0):
        raise ValueError(f"floor must be finite and > 0, got {floor!r}")
    out = np.empty((len(partitions_per_time), ERA5_N_FREQ, ERA5_N_DIR))
    for i, parts in enumerate(partitions_per_time):
        spec = era5_spectrum(parts, sampling=sampling)
        small = ~(spec >= floor)
        with np.errstate(divide="ignore"):
            logs = np.log10(np.where(small, floor, spec))
        out[i] = np.where(small, np.nan, logs) if below_floor == "missing" else logs
    return out


# --------------------------------------------------------------------------------------------------
# Bulk parameters
# --------------------------------------------------------------------------------------------------


def _first_circular_moment(p: SpectrumPartition) -> float:
    """r = ∫ cos θ D(θ) dθ of the partition's continuous spreading (mean resultant length)."""
    if p.spreading == "long_crested":
        return 1.0
    q = float(DEFAULT_SPREADING_PARAM[p.spreading] if p.spreading_param is None else p.spreading_param)
    if p.spreading == "cos2s":
        return q / (q + 1.0)  # Kuik et al. (1988); the relation spectra.cos2s_s_from_spread inverts
    # cosⁿ on |θ| ≤ π/2: r = I(n+1)/I(n), I(n) = √π Γ((n+1)/2)/Γ(n/2+1) → Γ(n/2+1)²/(Γ((n+1)/2)Γ((n+3)/2))
    return float(np.exp(2.0 * special.gammaln(q / 2 + 1) - special.gammaln((q + 1) / 2) - special.gammaln((q + 3) / 2)))


def _one_d_hz(parts: list[SpectrumPartition], f: np.ndarray) -> np.ndarray:
    """Summed 1-D spectrum E(f) = 2π Σ S_i(2πf) [m²/Hz]."""
    return TWO_PI * sum(p.spectrum(TWO_PI * f) for p in parts)


def _vector_sum(parts: list[SpectrumPartition]) -> tuple[float, float]:
    """(Σ m0_i r_i sin D_i, Σ m0_i r_i cos D_i): the first directional moments of the 2-D spectrum."""
    m0 = np.array([p.hs**2 / 16.0 for p in parts])
    r = np.array([_first_circular_moment(p) for p in parts])
    d = np.deg2rad([p.dir_from_deg for p in parts])
    return float(np.sum(m0 * r * np.sin(d))), float(np.sum(m0 * r * np.cos(d)))


def bulk_from_partitions(partitions: SpectrumPartition | Sequence[SpectrumPartition]) -> dict[str, float]:
    """ERA5 bulk parameters of one sea state made of JONSWAP partitions (continuous spectra, all ω).

    * ``swh`` = 4√m0 = √(Σ Hs_i²) exactly (each partition has m0 = Hs_i²/16 by construction).
    * ``pp1d`` = 1/f_p, f_p the maximum of the summed 1-D spectrum E(f) = Σ E_i(f) (fine log grid,
      refined by a bounded scalar search); for one JONSWAP/PM partition it is its Tp.
    * ``mwd`` = atan2(Σ m0_i r_i sin D_i, Σ m0_i r_i cos D_i) mod 360 [deg, coming-from]: the vector mean
      of the 2-D spectrum (ERA5 "spectral mean direction over all frequencies and directions"), with r_i
      the mean resultant length of partition i's spreading (s/(s+1) for cos-2s). One partition → its D.
    * ``mwp`` = T_{m−1,0} = m_{−1}/m0 [s], m_n = ∫ fⁿ E(f) df (ERA5 mean wave period; ecWAM FEMEAN).

    A sea state without energy gives swh = 0 and NaN for the others (ERA5 would have them missing).

    Returns
    -------
    dict
        {"swh" [m], "pp1d" [s], "mwd" [deg], "mwp" [s]} as floats.
    """
    parts = [p for p in _as_partitions(partitions) if p.hs > 0]
    if not parts:
        return {"swh": 0.0, "pp1d": np.nan, "mwd": np.nan, "mwp": np.nan}
    m0 = sum(p.hs**2 for p in parts) / 16.0
    fps = np.array([1.0 / p.tp for p in parts])
    # Peak: the largest value on a fine geometric grid around the partition peaks, refined between its neighbours.
    f = np.geomspace(0.5 * fps.min(), 2.0 * fps.max(), 4001)
    e = _one_d_hz(parts, f)
    i = int(np.argmax(e))
    x = np.log(f)
    lo, hi = x[max(i - 1, 0)], x[min(i + 1, f.size - 1)]
    best = optimize.minimize_scalar(
        lambda xx: -float(_one_d_hz(parts, np.exp(np.atleast_1d(xx)))[0]),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-12},
    )
    xp = float(best.x)
    # m_{−1}: JONSWAP is < 1e-60 of its peak below 0.3 fp; the f⁻⁶ tail above 12 fp adds < 1e-5 of m_{−1}.
    fm = np.geomspace(0.3 * fps.min(), 12.0 * fps.max(), 6001)
    m_minus1 = float(np.trapezoid(_one_d_hz(parts, fm) / fm, fm))
    ssin, scos = _vector_sum(parts)
    return {
        "swh": float(4.0 * np.sqrt(m0)),
        "pp1d": float(np.exp(-xp)),
        "mwd": float(np.mod(np.rad2deg(np.arctan2(ssin, scos)), 360.0)),
        "mwp": m_minus1 / m0,
    }


def directional_spread_rad(partitions: SpectrumPartition | Sequence[SpectrumPartition]) -> float:
    """Circular directional spread σθ = √(2(1 − R)) [rad] of the whole sea state (Kuik et al. 1988).

    R = |Σ m0_i r_i e^{iD_i}| / Σ m0_i; the same definition as wavespectra's ``dspr`` (there in degrees)
    and the inverse of :func:`seatune.physics.spectra.cos2s_s_from_spread` for one cos-2s partition.
    NaN without energy.
    """
    parts = [p for p in _as_partitions(partitions) if p.hs > 0]
    if not parts:
        return float("nan")
    ssin, scos = _vector_sum(parts)
    r = np.hypot(ssin, scos) / (sum(p.hs**2 for p in parts) / 16.0)
    return float(np.sqrt(max(2.0 * (1.0 - r), 0.0)))


def era5_bulk_fields(
    wind_per_time: Sequence[SpectrumPartition | Sequence[SpectrumPartition] | None],
    swell_per_time: Sequence[SpectrumPartition | Sequence[SpectrumPartition] | None],
) -> dict[str, np.ndarray]:
    """All ten ERA5 bulk wave fields per time, from wind-sea and swell partitions.

    ``swh, pp1d, mwd, mwp`` of the whole sea (wind + swell), ``shww, mpww, mdww`` of the wind sea and
    ``shts, mpts, mdts`` of the total swell (all swell partitions together), with the definitions of
    :func:`bulk_from_partitions` (partition periods as T_{m−1,0}, like ``mwp``).

    Returns
    -------
    dict[str, ndarray]
        Arrays of shape (n_time,), keyed by ERA5 short name.
    """
    if len(wind_per_time) != len(swell_per_time):
        raise ValueError(f"wind ({len(wind_per_time)}) and swell ({len(swell_per_time)}) have different lengths")
    keys = ("swh", "pp1d", "mwd", "mwp", "shww", "mpww", "mdww", "shts", "mpts", "mdts")
    out = {k: np.empty(len(wind_per_time)) for k in keys}
    for t, (wind, swell) in enumerate(zip(wind_per_time, swell_per_time, strict=True)):
        w, s = _as_partitions(wind), _as_partitions(swell)
        for prefix, parts in (("", w + s), ("ww", w), ("ts", s)):
            b = bulk_from_partitions(parts)
            if prefix:
                out[f"sh{prefix}"][t], out[f"mp{prefix}"][t], out[f"md{prefix}"][t] = b["swh"], b["mwp"], b["mwd"]
            else:
                for k in ("swh", "pp1d", "mwd", "mwp"):
                    out[k][t] = b[k]
    return out


# --------------------------------------------------------------------------------------------------
# Gridded fields around a track
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class GriddedFields:
    """Fields on a small ERA5-like lat/lon box around a vessel track.

    Attributes
    ----------
    latitudes : ndarray (n_lat,)
        Grid latitudes [deg N], descending (as ERA5 stores them).
    longitudes : ndarray (n_lon,)
        Grid longitudes [deg E], ascending in the requested convention; with "0_360" a box across the
        Greenwich meridian is not contiguous (e.g. 0.0, 0.5, 359.0, 359.5), as a subset of ERA5's
        0..359.5 grid is.
    fields : dict[str, ndarray]
        Each (n_time, n_lat, n_lon).
    d2fd : ndarray or None
        (n_time, n_lat, n_lon, 30, 24) log10 spectra when a track spectrum was given.
    height_factor : ndarray
        (n_time, n_lat, n_lon) factor k applied to the wave heights (1 at the track position).
    """

    latitudes: np.ndarray
    longitudes: np.ndarray
    fields: dict[str, np.ndarray]
    d2fd: np.ndarray | None
    height_factor: np.ndarray


def grid_fields_around_track(
    times: ArrayLike,
    track_lat: ArrayLike,
    track_lon: ArrayLike,
    values_at_track: Mapping[str, ArrayLike],
    resolution: float = 0.5,
    pad: int = 1,
    gradient: tuple[float, float] = (0.08, -0.06),
    *,
    d2fd: np.ndarray | None = None,
    height_vars: Sequence[str] = _HEIGHT_VARS,
    field_gradients: Mapping[str, tuple[float, float]] | None = None,
    lon_convention: str = "0_360",
) -> GriddedFields:
    """Spread values known at the vessel onto a small regular lat/lon box, smooth and linear in space.

    The box holds the grid nodes (multiples of `resolution`) nearest to the track, plus `pad` nodes on
    each side: 3×3 nodes for a vessel that stays within half a cell. Heights (`height_vars`) are scaled
    by the linear factor k = 1 + g_lat·Δlat + g_lon·Δlon (Δ in degrees from the track position at that
    time, longitudes unwrapped), so Hs changes by a few % per cell: spatial interpolation matters, yet a
    bilinear interpolation at the track position returns the given value exactly (bilinear interpolation
    reproduces linear functions), and wind-sea/swell heights keep swh² = shww² + shts² at every node.
    Other variables are uniform in space unless `field_gradients` gives them an additive gradient.
    The spectra, when given, are scaled by k² (log10: + 2 log10 k), consistent with the heights.

    Parameters
    ----------
    times : array_like (n_time,)
        Times of the values (only their number is used).
    track_lat, track_lon : array_like (n_time,)
        Vessel position [deg] at those times; longitudes in any convention, may cross 0°/360° or ±180°.
    values_at_track : mapping of str to array_like (n_time,)
        Field values at the vessel, keyed by ERA5 short name (e.g. the output of :func:`era5_bulk_fields`).
    resolution : float
        Grid spacing [deg] (0.5 = ERA5 wave grid).
    pad : int
        Extra nodes on each side of the nodes nearest to the track.
    gradient : (float, float)
        Relative height gradient (per degree of latitude, per degree of longitude), e.g. 0.08 = 8 %/deg
        (4 % per 0.5° cell, a typical open-ocean Hs gradient).
    d2fd : ndarray (n_time, 30, 24), optional
        log10 spectra at the track (:func:`era5_d2fd`); NaN (missing) stays missing.
    height_vars : sequence of str
        Variables scaled by k.
    field_gradients : mapping of str to (float, float), optional
        Additive gradients (units per degree latitude, per degree longitude) for other variables.
        Direction variables are wrapped to [0, 360) afterwards (which breaks linearity across north).
    lon_convention : {"0_360", "-180_180"}
        Longitude range of the output grid.

    Returns
    -------
    GriddedFields
    """
    lat = np.asarray(track_lat, dtype=float)
    lon = np.asarray(track_lon, dtype=float)
    n = np.asarray(times).shape[0] if np.ndim(times) else 0
    if lat.shape != (n,) or lon.shape != (n,) or n == 0:
        raise ValueError(
            f"times, track_lat, track_lon must be 1-D of equal non-zero length, got {n}, {lat.shape}, {lon.shape}"
        )
    if not np.all(np.isfinite(lat) & np.isfinite(lon)):
        raise ValueError("track positions must be finite")
    if not (resolution > 0) or pad < 0:
        raise ValueError(f"resolution must be > 0 and pad >= 0, got {resolution!r}, {pad!r}")
    if lon_convention not in ("0_360", "-180_180"):
        raise ValueError(f"lon_convention must be '0_360' or '-180_180', got {lon_convention!r}")
    field_gradients = dict(field_gradients or {})

    k_lat = np.arange(np.round(lat.min() / resolution) - pad, np.round(lat.max() / resolution) + pad + 1)
    lat_nodes = k_lat[::-1] * resolution  # descending, as ERA5
    if lat_nodes.max() > 90 or lat_nodes.min() < -90:
        raise ValueError("the box around the track reaches beyond a pole")
    lon_u = np.rad2deg(np.unwrap(np.deg2rad(lon)))  # continuous track longitude
    k_lon = np.arange(np.round(lon_u.min() / resolution) - pad, np.round(lon_u.max() / resolution) + pad + 1)
    lon_nodes_u = k_lon * resolution
    if lon_nodes_u.max() - lon_nodes_u.min() >= 360.0:
        raise ValueError("the box around the track spans all longitudes")
    if lon_convention == "0_360":
        lon_out = np.mod(lon_nodes_u, 360.0)
    else:
        lon_out = np.mod(lon_nodes_u + 180.0, 360.0) - 180.0
    order = np.argsort(lon_out, kind="stable")
    lon_out, lon_nodes_u = lon_out[order], lon_nodes_u[order]
    lon_out = np.where(np.abs(lon_out) < 1e-9, 0.0, np.round(lon_out, 9))

    dlat = lat_nodes[None, :, None] - lat[:, None, None]  # (t, lat, 1)
    dlon = lon_nodes_u[None, None, :] - lon_u[:, None, None]  # (t, 1, lon), same unwrapped frame
    factor = 1.0 + gradient[0] * dlat + gradient[1] * dlon
    if factor.min() <= 0.2:
        raise ValueError(f"height gradient {gradient} makes heights (nearly) vanish in the box; use a smaller one")

    shape = (n, lat_nodes.size, lon_out.size)
    fields: dict[str, np.ndarray] = {}
    for name, values in values_at_track.items():
        v = np.asarray(values, dtype=float)
        if v.shape != (n,):
            raise ValueError(f"values_at_track[{name!r}] has shape {v.shape}, expected ({n},)")
        if name in height_vars:
            out = v[:, None, None] * factor
        elif name in field_gradients:
            g_lat, g_lon = field_gradients[name]
            out = v[:, None, None] + g_lat * dlat + g_lon * dlon
            if name in ("mwd", "mdww", "mdts"):
                out = np.mod(out, 360.0)
        else:
            out = np.broadcast_to(v[:, None, None], shape)
        fields[name] = np.ascontiguousarray(np.broadcast_to(out, shape))

    grid_spec = None
    if d2fd is not None:
        spec = np.asarray(d2fd, dtype=float)
        if spec.shape != (n, ERA5_N_FREQ, ERA5_N_DIR):
            raise ValueError(f"d2fd has shape {spec.shape}, expected ({n}, {ERA5_N_FREQ}, {ERA5_N_DIR})")
        grid_spec = spec[:, None, None, :, :] + 2.0 * np.log10(factor)[..., None, None]
    return GriddedFields(lat_nodes, lon_out, fields, grid_spec, np.ascontiguousarray(np.broadcast_to(factor, shape)))


# --------------------------------------------------------------------------------------------------
# ERA5 netCDF
# --------------------------------------------------------------------------------------------------


def _utc_naive(times: ArrayLike) -> pd.DatetimeIndex:
    idx = pd.DatetimeIndex(pd.to_datetime(np.asarray(times) if not isinstance(times, pd.Index) else times))
    if idx.tz is not None:
        idx = idx.tz_convert("UTC").tz_localize(None)
    return idx


def _increment(values: np.ndarray) -> float:
    d = np.abs(np.diff(np.sort(values)))
    d = d[d > 1e-9]
    return float(d.min()) if d.size else 0.0


def _grib_attrs(name: str, lat: np.ndarray, lon: np.ndarray) -> dict:
    """Attributes as the new CDS (cfgrib-based) converter writes them."""
    v = ERA5_VARIABLES[name]
    return {
        "GRIB_paramId": np.int64(v.param_id),
        "GRIB_dataType": "an",
        "GRIB_numberOfPoints": np.int64(lat.size * lon.size),
        "GRIB_typeOfLevel": "meanSea",
        "GRIB_stepUnits": np.int64(1),
        "GRIB_stepType": "instant",
        "GRIB_gridType": "regular_ll",
        "GRIB_uvRelativeToGrid": np.int64(0),
        "GRIB_NV": np.int64(0),
        "GRIB_Nx": np.int64(lon.size),
        "GRIB_Ny": np.int64(lat.size),
        "GRIB_cfName": "unknown",
        "GRIB_cfVarName": name,
        "GRIB_gridDefinitionDescription": "Latitude/Longitude Grid",
        "GRIB_iDirectionIncrementInDegrees": _increment(lon),
        "GRIB_iScansNegatively": np.int64(0),
        "GRIB_jDirectionIncrementInDegrees": _increment(lat),
        "GRIB_jPointsAreConsecutive": np.int64(0),
        "GRIB_jScansPositively": np.int64(0),
        "GRIB_latitudeOfFirstGridPointInDegrees": float(lat[0]),
        "GRIB_latitudeOfLastGridPointInDegrees": float(lat[-1]),
        "GRIB_longitudeOfFirstGridPointInDegrees": float(lon[0]),
        "GRIB_longitudeOfLastGridPointInDegrees": float(lon[-1]),
        "GRIB_missingValue": 3.4028234663852886e38,
        "GRIB_name": v.name,
        "GRIB_shortName": v.short_name,
        "GRIB_totalNumber": np.int64(0),
        "GRIB_units": v.units,
        "long_name": v.name,
        "units": v.units,
        "standard_name": "unknown",
    }


def _packing(values: np.ndarray) -> dict:
    """int16 packing as grib_to_netcdf does it: scale/offset from the finite range, fill −32767."""
    finite = values[np.isfinite(values)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 0.0)
    scale = (hi - lo) / 65532.0 if hi > lo else 1.0  # packed values stay within ±32766, clear of the fill
    return {"dtype": "int16", "scale_factor": scale, "add_offset": 0.5 * (hi + lo), "_FillValue": np.int16(-32767)}


def write_era5_netcdf(
    path: str | Path,
    times: ArrayLike,
    latitudes: ArrayLike,
    longitudes: ArrayLike,
    bulk: Mapping[str, ArrayLike],
    d2fd: ArrayLike | None = None,
    *,
    new_cds_layout: bool = True,
) -> Path:
    """Write ERA5 wave fields (and 2-D spectra) as a netCDF file laid out like a real CDS download.

    New CDS layout (default; CDS since 2024, cfgrib-based conversion): NETCDF4, float32 with NaN fill,
    dims ``valid_time`` (int64 seconds since 1970-01-01), ``latitude`` (descending), ``longitude``;
    scalar ``number`` and per-time ``expver`` coordinates; ``GRIB_*`` attributes per variable; global
    ``Conventions = "CF-1.7"``. Spectra: ``d2fd(valid_time, frequencyNumber, directionNumber, latitude,
    longitude)`` with integer index coordinates 1..30 and 1..24.
    Legacy layout (``new_cds_layout=False``; grib_to_netcdf, CDS before 2024): NETCDF3 64-bit offset,
    dims ``time`` (int32 hours since 1900-01-01), ``latitude``, ``longitude``, ``frequency``,
    ``direction``; every variable int16 with scale_factor/add_offset and fill −32767; CF-1.6.

    Longitudes are written as given (ERA5's native range is 0..359.5 on the 0.5° wave grid; CDS
    subsets may come as −180..180), sorted ascending; latitudes are sorted descending. The file is
    written to a temporary file in the same folder and renamed into place.

    Parameters
    ----------
    path : str or Path
        Target file.
    times : array_like (n_time,)
        UTC times (datetime64, tz-aware or naive = UTC).
    latitudes, longitudes : array_like (n_lat,), (n_lon,)
        Grid coordinates [deg].
    bulk : mapping of str to array_like (n_time, n_lat, n_lon)
        Fields keyed by ERA5 short name: swh [m], mwd [deg true, coming-from], pp1d [s], mwp [s], shww,
        mpww, mdww, shts, mpts, mdts (any subset; may be empty when writing spectra only).
    d2fd : array_like (n_time, n_lat, n_lon, 30, 24), optional
        log10 spectra (:func:`era5_d2fd`), NaN = missing.
    new_cds_layout : bool
        Layout to imitate (see above).

    Returns
    -------
    Path
        The written file.
    """
    t = _utc_naive(times)
    lat = np.asarray(latitudes, dtype=float)
    lon = np.asarray(longitudes, dtype=float)
    nt, ny, nx = t.size, lat.size, lon.size
    if lat.ndim != 1 or lon.ndim != 1 or min(nt, ny, nx) == 0:
        raise ValueError("times, latitudes and longitudes must be non-empty 1-D arrays")
    if np.unique(lat).size != ny or np.unique(lon).size != nx or t.has_duplicates:
        raise ValueError("times, latitudes and longitudes must not repeat")
    if np.any(np.abs(lat) > 90) or np.any(lon < -180) or np.any(lon >= 360):
        raise ValueError("latitudes must be in [-90, 90] and longitudes in [-180, 360)")
    unknown = sorted(set(bulk) - (set(ERA5_VARIABLES) - {"d2fd"}))
    if unknown:
        raise ValueError(f"unknown ERA5 bulk variables {unknown}; known: {sorted(set(ERA5_VARIABLES) - {'d2fd'})}")
    if not bulk and d2fd is None:
        raise ValueError("nothing to write: give bulk fields and/or d2fd")

    iy = np.argsort(-lat, kind="stable")  # ERA5 latitudes run north to south
    ix = np.argsort(lon, kind="stable")
    lat, lon = lat[iy], lon[ix]
    tname, fname, dname = (
        ("valid_time", "frequencyNumber", "directionNumber") if new_cds_layout else ("time", "frequency", "direction")
    )

    data_vars: dict[str, xr.Variable] = {}
    for name, values in bulk.items():
        arr = np.asarray(values, dtype=float)
        if arr.shape != (nt, ny, nx):
            raise ValueError(f"bulk[{name!r}] has shape {arr.shape}, expected ({nt}, {ny}, {nx})")
        data_vars[name] = xr.Variable((tname, "latitude", "longitude"), arr[:, iy][:, :, ix])
    if d2fd is not None:
        spec = np.asarray(d2fd, dtype=float)
        if spec.shape != (nt, ny, nx, ERA5_N_FREQ, ERA5_N_DIR):
            raise ValueError(f"d2fd has shape {spec.shape}, expected ({nt}, {ny}, {nx}, {ERA5_N_FREQ}, {ERA5_N_DIR})")
        if np.any(np.isinf(spec)):
            raise ValueError("d2fd holds ±inf (log10 of 0?); mark small values missing (NaN), see era5_d2fd")
        spec = spec[:, iy][:, :, ix].transpose(0, 3, 4, 1, 2)  # → (time, freq, dir, lat, lon) as in CDS files
        data_vars["d2fd"] = xr.Variable((tname, fname, dname, "latitude", "longitude"), spec)

    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M")
    coords: dict[str, xr.Variable] = {}
    encoding: dict[str, dict] = {}
    if new_cds_layout:
        coords["number"] = xr.Variable(
            (), np.int64(0), {"long_name": "ensemble member numerical id", "units": "1", "standard_name": "realization"}
        )
        coords[tname] = xr.Variable(tname, t.values, {"long_name": "time", "standard_name": "time"})
        encoding[tname] = {"units": "seconds since 1970-01-01", "calendar": "proleptic_gregorian", "dtype": "int64"}
        coords["latitude"] = xr.Variable(
            "latitude",
            lat,
            {
                "units": "degrees_north",
                "standard_name": "latitude",
                "long_name": "latitude",
                "stored_direction": "decreasing",
            },
        )
        coords["longitude"] = xr.Variable(
            "longitude", lon, {"units": "degrees_east", "standard_name": "longitude", "long_name": "longitude"}
        )
        coords["expver"] = xr.Variable(tname, np.full(nt, "0001"), {"long_name": "Experiment version"})
        for name in data_vars:
            data_vars[name] = data_vars[name].astype(np.float32)
            data_vars[name].attrs.update(_grib_attrs(name, lat, lon))
            encoding[name] = {"_FillValue": np.float32(np.nan), "zlib": True, "complevel": 1}
        global_attrs = {
            "GRIB_centre": "ecmf",
            "GRIB_centreDescription": "European Centre for Medium-Range Weather Forecasts",
            "GRIB_subCentre": np.int64(0),
            "Conventions": "CF-1.7",
            "institution": "European Centre for Medium-Range Weather Forecasts",
            "history": f"{stamp} {_SYNTHETIC_NOTE} (new CDS layout)",
        }
        file_format = "NETCDF4"
    else:
        hours = (t - pd.Timestamp("1900-01-01")) / pd.Timedelta(hours=1)
        if not np.allclose(hours, np.round(hours), rtol=0, atol=1e-9):
            raise ValueError("the legacy ERA5 layout stores whole hours (int32 hours since 1900-01-01)")
        coords["longitude"] = xr.Variable(
            "longitude", lon.astype(np.float32), {"units": "degrees_east", "long_name": "longitude"}
        )
        coords["latitude"] = xr.Variable(
            "latitude", lat.astype(np.float32), {"units": "degrees_north", "long_name": "latitude"}
        )
        # encoded by hand: xarray would shorten the units to "hours since 1900-01-01"
        coords[tname] = xr.Variable(
            tname,
            np.round(hours).astype(np.int32),
            {"units": "hours since 1900-01-01 00:00:00.0", "long_name": "time", "calendar": "gregorian"},
        )
        for name, var in data_vars.items():
            v = ERA5_VARIABLES[name]
            var.attrs.update({"units": v.units, "long_name": v.name})
            encoding[name] = {**_packing(var.values), "missing_value": np.int16(-32767)}
        global_attrs = {"Conventions": "CF-1.6", "history": f"{stamp} {_SYNTHETIC_NOTE} (legacy grib_to_netcdf layout)"}
        file_format = "NETCDF3_64BIT"
    if d2fd is not None:
        itype = np.int64 if new_cds_layout else np.int32
        coords[fname] = xr.Variable(
            fname,
            np.arange(1, ERA5_N_FREQ + 1, dtype=itype),
            {"long_name": "frequency number" if new_cds_layout else "frequency"},
        )
        coords[dname] = xr.Variable(
            dname,
            np.arange(1, ERA5_N_DIR + 1, dtype=itype),
            {"long_name": "direction number" if new_cds_layout else "direction"},
        )
    ds = xr.Dataset(data_vars, coords=coords, attrs=global_attrs)
    for name in coords:
        if name not in encoding:
            encoding[name] = {"_FillValue": None}
    path = Path(path)
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, format=file_format, engine="netcdf4", encoding=encoding)
    return path


# --------------------------------------------------------------------------------------------------
# Hindcast CSV
# --------------------------------------------------------------------------------------------------

HINDCAST_CSV_COLUMNS: dict[str, str] = {
    "time": "ISO 8601 UTC (…Z)",
    "hs": "m",
    "tp": "s",
    "dir_from_deg": "deg, coming-from, clockwise from true North",
    "spreading": "rad, circular directional spread σθ (optional)",
    "wind_hs": "m",
    "wind_tp": "s",
    "wind_dir_from_deg": "deg, coming-from",
    "swell_hs": "m",
    "swell_tp": "s",
    "swell_dir_from_deg": "deg, coming-from",
}
_CSV_REQUIRED = ("time", "hs", "tp", "dir_from_deg")
_CSV_GROUPS = (("wind_hs", "wind_tp", "wind_dir_from_deg"), ("swell_hs", "swell_tp", "swell_dir_from_deg"))


def hindcast_table_from_partitions(
    times: ArrayLike,
    wind_per_time: Sequence[SpectrumPartition | None],
    swell_per_time: Sequence[SpectrumPartition | None],
) -> pd.DataFrame:
    """The hindcast table of :func:`write_hindcast_csv` for sea states of one wind sea and one swell.

    hs, tp, dir_from_deg are ERA5-style swh, pp1d, mwd of the whole sea (:func:`bulk_from_partitions`);
    spreading is :func:`directional_spread_rad`; the partition columns are the partitions' own Hs, Tp, D
    (NaN where a partition is absent).
    """
    t = _utc_naive(times).tz_localize("UTC")
    if not (len(t) == len(wind_per_time) == len(swell_per_time)):
        raise ValueError("times, wind_per_time and swell_per_time must have the same length")
    rows = []
    for wind, swell in zip(wind_per_time, swell_per_time, strict=True):
        parts = _as_partitions(wind) + _as_partitions(swell)
        b = bulk_from_partitions(parts)
        row = {"hs": b["swh"], "tp": b["pp1d"], "dir_from_deg": b["mwd"], "spreading": directional_spread_rad(parts)}
        for prefix, p in (("wind", wind), ("swell", swell)):
            row[f"{prefix}_hs"] = p.hs if p is not None else np.nan
            row[f"{prefix}_tp"] = p.tp if p is not None else np.nan
            row[f"{prefix}_dir_from_deg"] = p.dir_from_deg % 360.0 if p is not None else np.nan
        rows.append(row)
    return pd.concat([pd.DataFrame({"time": t}), pd.DataFrame(rows)], axis=1)


def write_hindcast_csv(path: str | Path, table: pd.DataFrame) -> Path:
    """Write a wave hindcast table as CSV (one row per time), atomically.

    Columns, in this order when present (units in ``HINDCAST_CSV_COLUMNS``): ``time`` (written ISO 8601
    UTC with a trailing "Z"; naive input times are taken as UTC), ``hs`` [m], ``tp`` [s],
    ``dir_from_deg`` [deg, coming-from], ``spreading`` [rad] (optional), then the optional partition
    groups ``wind_hs, wind_tp, wind_dir_from_deg`` and ``swell_hs, swell_tp, swell_dir_from_deg`` (each
    group complete or absent); any other columns follow unchanged. Directions are wrapped to [0, 360);
    missing values are written as empty fields. Floats are written at full precision.
    """
    missing = [c for c in _CSV_REQUIRED if c not in table.columns]
    if missing:
        raise ValueError(f"hindcast table lacks required columns {missing}")
    for group in _CSV_GROUPS:
        present = [c for c in group if c in table.columns]
        if present and len(present) != len(group):
            raise ValueError(f"partition columns {sorted(set(group) - set(present))} missing (have {present})")
    out = table.copy()
    t = pd.to_datetime(out["time"])
    t = t.dt.tz_localize("UTC") if t.dt.tz is None else t.dt.tz_convert("UTC")
    if t.isna().any():
        raise ValueError("hindcast table has missing times")
    fmt = "%Y-%m-%dT%H:%M:%S.%fZ" if (t.dt.microsecond != 0).any() else "%Y-%m-%dT%H:%M:%SZ"
    out["time"] = t.dt.strftime(fmt)
    for c in out.columns:
        if c.endswith("dir_from_deg"):
            out[c] = np.mod(out[c].astype(float), 360.0)
    known = [c for c in HINDCAST_CSV_COLUMNS if c in out.columns]
    out = out[known + [c for c in out.columns if c not in HINDCAST_CSV_COLUMNS]]
    path = Path(path)
    with atomic_path(path) as tmp:
        out.to_csv(tmp, index=False, na_rep="")
    return path

"""Hindcast readers (seatune.io.hindcast_readers) on files written in real-product layouts.

Reference values come from outside the reader: what the writers put in the files (hindcast_writers, whose
``grid_fields_around_track`` makes a bilinear interpolation at the track reproduce the track values
exactly, because the fields are linear in space), wavespectra's own WW3 writer, Hs = √(Σ Hs_i²) of the
JONSWAP partitions, and arithmetic (the mean of two hours, the circular mean of 350° and 10°).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from numpy.testing import assert_allclose

from seatune.errors import UserError
from seatune.io.hindcast_readers import Hindcast, at_track, read_hindcast, spectrum_at
from seatune.physics.spectra import SpectrumPartition as SP
from seatune.simulate import hindcast_writers as hw

wavespectra = pytest.importorskip("wavespectra")

TIMES = pd.date_range("2026-03-14T05:00", periods=5, freq="h", tz="UTC")
WIND = [SP(1.5, 6.5, 250.0), SP(1.6, 6.8, 255.0), None, SP(2.0, 7.4, 265.0), SP(2.2, 7.8, 270.0)]
SWELL = [SP(1.2, 13.0, 300.0, gamma=5.0, spreading_param=20)] * 5
# A track crossing the Greenwich meridian eastwards, and one crossing the date line westwards.
LAT_G = np.array([61.05, 61.15, 61.3, 61.42, 61.55])
LON_G = np.array([359.55, 359.8, 0.05, 0.3, 0.62])
LAT_D = np.array([-20.1, -20.25, -20.4, -20.55, -20.7])
LON_D = np.array([-179.4, -179.7, 179.95, 179.7, 179.45])


def _circ_diff(a, b):
    return np.abs((np.asarray(a, float) - np.asarray(b, float) + 180.0) % 360.0 - 180.0)


def _parts(i):
    return [p for p in (WIND[i], SWELL[i]) if p is not None]


@pytest.fixture(scope="module")
def bulk_at_track():
    return hw.era5_bulk_fields(WIND, SWELL)


@pytest.fixture(scope="module")
def d2fd_at_track():
    return hw.era5_d2fd([_parts(i) for i in range(len(TIMES))])


@pytest.fixture(scope="module")
def era5_files(tmp_path_factory, bulk_at_track, d2fd_at_track):
    """{(layout, track): (path, GriddedFields)} for both CDS layouts and both longitude conventions."""
    out = {}
    root = tmp_path_factory.mktemp("era5")
    for track, lat, lon, conv in (("greenwich", LAT_G, LON_G, "0_360"), ("dateline", LAT_D, LON_D, "-180_180")):
        grid = hw.grid_fields_around_track(
            TIMES,
            lat,
            lon,
            bulk_at_track,
            d2fd=d2fd_at_track,
            field_gradients={"mwp": (0.3, -0.2)},  # a non-height field that also varies in space
            lon_convention=conv,
        )
        for new in (True, False):
            layout = "new" if new else "legacy"
            path = hw.write_era5_netcdf(
                root / f"{track}_{layout}.nc",
                TIMES,
                grid.latitudes,
                grid.longitudes,
                grid.fields,
                grid.d2fd,
                new_cds_layout=new,
            )
            out[(layout, track)] = (path, grid)
    return out


def _tolerance(layout, values):
    """Precision of the stored numbers: float32 (new CDS) or int16 packing over the finite range (legacy)."""
    v = np.asarray(values, float)
    if layout == "new":
        return 2e-6 * np.nanmax(np.abs(v)) + 1e-12
    return (np.nanmax(v) - np.nanmin(v)) / 65532.0 + 1e-12


# ------------------------------------------------------------------------------------------------
# ERA5
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("layout", ["new", "legacy"])
@pytest.mark.parametrize("track", ["greenwich", "dateline"])
def test_era5_bulk_equals_what_was_written(era5_files, layout, track):
    path, grid = era5_files[(layout, track)]
    hc = read_hindcast(path)
    assert hc.format == "era5" and hc.source == str(path)
    assert dict(hc.bulk.sizes) == {"time": 5, "lat": grid.latitudes.size, "lon": grid.longitudes.size}
    assert (pd.DatetimeIndex(hc.bulk.time.values) == TIMES.tz_localize(None)).all()
    assert_allclose(hc.bulk.lat.values, grid.latitudes[::-1])  # ascending
    assert_allclose(hc.bulk.lon.values, grid.longitudes, atol=1e-5)  # as written
    names = {"swh": "hs", "pp1d": "tp", "mwp": "mwp", "shww": "wind_hs", "mpww": "wind_mwp", "shts": "swell_hs"}
    for era5, ours in names.items():
        written = grid.fields[era5][:, ::-1, :]
        assert_allclose(hc.bulk[ours].values, written, rtol=0, atol=_tolerance(layout, written), equal_nan=True)
    for era5, ours in {"mwd": "dir_from_deg", "mdts": "swell_dir_from_deg"}.items():
        written = grid.fields[era5][:, ::-1, :]
        assert _circ_diff(hc.bulk[ours].values, written).max() <= _tolerance(layout, written)
    # the calm wind sea of hour 3: no wind-sea direction, zero height
    assert np.isnan(hc.bulk["wind_dir_from_deg"].values[2]).all()
    assert np.abs(hc.bulk["wind_hs"].values[2]).max() <= _tolerance(layout, grid.fields["shww"])
    assert hc.spectra is not None and hc.spectra.dims == ("time", "lat", "lon", "freq", "dir")
    assert np.all(np.diff(hc.spectra.dir.values) > 0)


@pytest.mark.parametrize("layout", ["new", "legacy"])
@pytest.mark.parametrize("track", ["greenwich", "dateline"])
def test_era5_at_track_reproduces_the_track_values(era5_files, bulk_at_track, layout, track):
    path, grid = era5_files[(layout, track)]
    lat, lon = (LAT_G, LON_G) if track == "greenwich" else (LAT_D, LON_D)
    hc = read_hindcast(path)
    df = at_track(hc, TIMES, lat, lon)
    assert list(df.columns[:4]) == ["time", "hs", "tp", "dir_from_deg"] and df.columns[-1] == "source"
    assert str(df["time"].dtype) == "datetime64[ns, UTC]" and (df["time"] == TIMES).all()
    assert (df["source"] == str(path)).all()
    for era5, ours in {"swh": "hs", "pp1d": "tp", "mwp": "mwp", "shts": "swell_hs", "mpts": "swell_mwp"}.items():
        ref = bulk_at_track[era5]
        assert_allclose(df[ours], ref, rtol=0, atol=2 * _tolerance(layout, grid.fields[era5]))
    assert _circ_diff(df["dir_from_deg"], bulk_at_track["mwd"]).max() <= 2 * _tolerance(layout, grid.fields["mwd"])
    # the same track with its longitudes in the other convention gives the same answer
    other = np.where(lon < 0, lon + 360.0, np.where(lon > 180, lon - 360.0, lon))
    assert_allclose(at_track(hc, TIMES, lat, other)["hs"], df["hs"], rtol=1e-12)


def test_box_across_greenwich_is_one_contiguous_cell_row(tmp_path):
    # ERA5 subset across 0°: longitudes [0, 0.5, 1.0, 359.5]; Hs = 2 + 0.4 x, x the unwrapped longitude.
    lon = np.array([0.0, 0.5, 1.0, 359.5])
    x = np.where(lon > 180, lon - 360.0, lon)
    lat = np.array([60.5, 61.0])
    hs = np.broadcast_to(2.0 + 0.4 * x[None, None, :], (2, 2, 4))
    bulk = {"swh": hs, "pp1d": np.full_like(hs, 9.0), "mwd": np.full_like(hs, 200.0)}
    path = hw.write_era5_netcdf(tmp_path / "box.nc", TIMES[:2], lat, lon, bulk)
    hc = read_hindcast(path)
    q = np.array([359.75, -0.25, 0.2, 359.5, 1.0, 0.0])
    got = at_track(hc, TIMES[:2].repeat(3), np.full(6, 60.7), q)["hs"]
    assert_allclose(got, 2.0 + 0.4 * np.array([-0.25, -0.25, 0.2, -0.5, 1.0, 0.0]), rtol=0, atol=2e-6)
    with pytest.raises(UserError, match=r"lon 1\.2 outside 359\.5–1\.0 ") as err:
        at_track(hc, TIMES[:1], 60.7, 1.2)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_global_grid_is_cyclic(tmp_path):
    lon = np.arange(0.0, 360.0, 30.0)
    lat = np.array([0.0, 10.0])
    hs = np.broadcast_to(1.0 + np.cos(np.deg2rad(lon))[None, None, :], (1, 2, lon.size))
    path = hw.write_era5_netcdf(
        tmp_path / "global.nc", TIMES[:1], lat, lon, {"swh": hs, "pp1d": hs + 5, "mwd": 0 * hs + 90}
    )
    hc = read_hindcast(path)
    got = at_track(hc, TIMES[:1], 5.0, 345.0)["hs"].iloc[0]
    assert got == pytest.approx(0.5 * (hs[0, 0, -1] + hs[0, 0, 0]), rel=1e-6)  # between 330° and 0°/360°


def test_time_midway_between_hours_is_the_mean(era5_files):
    path, grid = era5_files[("new", "greenwich")]
    hc = read_hindcast(path)
    # a fixed point on a grid node, half-way between the hours
    iy, ix = 1, 2
    la, lo = grid.latitudes[iy], grid.longitudes[ix]
    mid = TIMES[:-1] + pd.Timedelta(minutes=30)
    df = at_track(hc, mid, la, lo)
    for era5, ours in {"swh": "hs", "pp1d": "tp", "mwp": "mwp", "shts": "swell_hs"}.items():
        v = grid.fields[era5][:, iy, ix].astype(np.float32).astype(float)
        assert_allclose(df[ours], 0.5 * (v[:-1] + v[1:]), rtol=1e-12)


def test_direction_interpolation_across_north(tmp_path):
    # in time (CSV): 350° at 05:00, 10° at 06:00 → 0° at 05:30; at 05:15 the unit-vector mean
    # 0.75·e(−10°) + 0.25·e(10°) points to −atan(0.5·tan 10°) ≈ 355.04°
    table = pd.DataFrame(
        {"time": TIMES[:2], "hs": [1.0, 1.0], "tp": [8.0, 8.0], "dir_from_deg": [350.0, 10.0]},
    )
    hc = read_hindcast(hw.write_hindcast_csv(tmp_path / "north.csv", table))
    df = at_track(hc, [TIMES[0] + pd.Timedelta(minutes=30), TIMES[0] + pd.Timedelta(minutes=15)])
    quarter = 360.0 - math.degrees(math.atan(0.5 * math.tan(math.radians(10.0))))
    assert _circ_diff(df["dir_from_deg"], [0.0, quarter]).max() < 1e-9
    assert df["dir_from_deg"].iloc[0] == 0.0  # not 359.99999999999994
    # in space (ERA5): mwd 350° at lon 359.5, 10° at lon 0.0 → 0° half-way between the two columns
    lon = np.array([0.0, 0.5, 359.0, 359.5])
    mwd = np.broadcast_to(np.array([10.0, 30.0, 330.0, 350.0])[None, None, :], (1, 2, 4))
    bulk = {"swh": np.ones_like(mwd), "pp1d": np.full_like(mwd, 8.0), "mwd": mwd}
    hc = read_hindcast(hw.write_era5_netcdf(tmp_path / "north.nc", TIMES[:1], [60.0, 60.5], lon, bulk))
    assert _circ_diff(at_track(hc, TIMES[:1], 60.2, 359.75)["dir_from_deg"], 0.0).max() < 1e-6


@pytest.mark.parametrize("layout", ["new", "legacy"])
def test_hs_of_the_interpolated_spectrum_matches_bulk_hs(era5_files, layout):
    path, grid = era5_files[(layout, "greenwich")]
    hc = read_hindcast(path)
    hs_in = np.array([math.sqrt(sum(p.hs**2 for p in _parts(i))) for i in range(len(TIMES))])
    for i, t in enumerate(TIMES):
        spec = spectrum_at(hc, t, LAT_G[i], LON_G[i])
        assert spec.dims == ("freq", "dir")
        assert float(spec.spec.hs()) == pytest.approx(hs_in[i], rel=0.02)
    # between hours and off the nodes: against the interpolated bulk Hs
    t = TIMES[1] + pd.Timedelta(minutes=20)
    la, lo = 61.2, 359.9
    spec = spectrum_at(hc, t, la, lo)
    assert float(spec.spec.hs()) == pytest.approx(at_track(hc, [t], la, lo)["hs"].iloc[0], rel=0.02)
    # directions are coming-from: the swell (300°) sits in the north-west quadrant
    e_dir = spec.sum("freq")
    assert 270.0 <= float(e_dir.idxmax("dir")) <= 330.0


def test_era5_spectra_only_file_derives_the_bulk(tmp_path, d2fd_at_track):
    grid = hw.grid_fields_around_track(TIMES, LAT_G, LON_G, {}, d2fd=d2fd_at_track)
    path = hw.write_era5_netcdf(tmp_path / "spec.nc", TIMES, grid.latitudes, grid.longitudes, {}, grid.d2fd)
    hc = read_hindcast(path)
    df = at_track(hc, TIMES, LAT_G, LON_G)
    hs_in = [math.sqrt(sum(p.hs**2 for p in _parts(i))) for i in range(len(TIMES))]
    assert_allclose(df["hs"], hs_in, rtol=0.02)
    assert _circ_diff(df["dir_from_deg"].iloc[2], 300.0) < 1.0  # swell only at hour 3


# ------------------------------------------------------------------------------------------------
# WW3 (written by wavespectra's own WW3 writer) and NORA3-like bulk netCDF
# ------------------------------------------------------------------------------------------------


def _ww3_file(path, lats, lons):
    """Spectra at stations: JONSWAP partitions on the ERA5 grid, per degree, coming-from (wavespectra)."""
    spec = np.stack([hw.era5_spectrum(_parts(i)) for i in range(len(TIMES))]) * np.pi / 180.0  # m²/(Hz·deg)
    nsite = len(lats)
    efth = np.repeat(spec[:, None], nsite, axis=1) * (1.0 + 0.1 * np.arange(nsite))[None, :, None, None] ** 2
    ds = xr.Dataset(
        {"efth": (("time", "site", "freq", "dir"), efth)},
        coords={
            "time": TIMES.tz_localize(None).values,
            "site": np.arange(nsite),
            "freq": hw.era5_frequencies(),
            "dir": hw.era5_directions_from_deg(),
            "lat": ("site", np.asarray(lats, float)),
            "lon": ("site", np.asarray(lons, float)),
        },
    )
    ds.spec.to_ww3(str(path))
    return path


def test_ww3_station_spectra(tmp_path):
    path = _ww3_file(tmp_path / "ww3.nc", [61.0, 61.5], [2.0, 2.8])
    with xr.open_dataset(path) as raw:  # the native file is going-to
        assert "efth" in raw and {"station", "frequency", "direction"} <= set(raw["efth"].dims)
    hc = read_hindcast(path)
    assert hc.format == "ww3" and hc.spectra.dims == ("time", "site", "freq", "dir")
    hs_in = np.array([math.sqrt(sum(p.hs**2 for p in _parts(i))) for i in range(len(TIMES))])
    assert_allclose(hc.bulk["hs"].values[:, 0], hs_in, rtol=0.01)
    assert_allclose(hc.bulk["hs"].values[:, 1], 1.1 * hs_in, rtol=0.01)
    # hour 3 is the swell alone: mean direction 300° coming-from (going-to 120° in the file)
    assert _circ_diff(hc.bulk["dir_from_deg"].values[2, 0], 300.0) < 0.5
    assert hc.bulk["tp"].values[2, 0] == pytest.approx(13.0, rel=0.03)
    # at a station: that station's values; between stations: inverse-distance weights; far: an error
    df = at_track(hc, TIMES, 61.5, 2.8)
    assert_allclose(df["hs"], hc.bulk["hs"].values[:, 1], rtol=1e-12)
    mid = at_track(hc, TIMES[:1], 61.25, 2.4)["hs"].iloc[0]
    assert mid == pytest.approx(0.5 * hc.bulk["hs"].values[0].sum(), rel=1e-12)
    spec = spectrum_at(hc, TIMES[0] + pd.Timedelta(minutes=30), 61.0, 2.0)
    assert float(spec.spec.hs()) == pytest.approx(0.5 * (hs_in[0] + hs_in[1]), rel=0.02)
    with pytest.raises(UserError, match="from the nearest site"):
        at_track(hc, TIMES[:1], 65.0, 2.0)


def test_bulk_netcdf_going_to_directions_are_turned_at_the_reader(tmp_path):
    t = TIMES.tz_localize(None).values
    ds = xr.Dataset(
        {
            "hs": ("time", [1.0, 1.2, 1.4, 1.5, 1.6], {"standard_name": "sea_surface_wave_significant_height"}),
            "tp": ("time", [8.0, 8.5, 9.0, 9.0, 9.5]),
            "thq": ("time", [10.0, 90.0, 180.0, 270.0, 350.0], {"standard_name": "sea_surface_wave_to_direction"}),
            "hs_swell": ("time", [0.5] * 5),
            "thq_swell": ("time", [0.0] * 5, {"long_name": "swell mean direction (going to)"}),
        },
        coords={"time": t, "latitude": 60.0, "longitude": 4.0},
    )
    ds.to_netcdf(tmp_path / "nora3.nc")
    hc = read_hindcast(tmp_path / "nora3.nc")
    assert hc.format == "bulk_netcdf" and hc.bulk["hs"].dims == ("time", "site")
    assert_allclose(hc.bulk["dir_from_deg"].values[:, 0], [190.0, 270.0, 0.0, 90.0, 170.0])
    assert_allclose(hc.bulk["swell_dir_from_deg"].values[:, 0], 180.0)
    # a direction that says neither: an error, unless the caller says
    ds["thq"].attrs = {"long_name": "mean wave direction"}
    ds.to_netcdf(tmp_path / "silent.nc")
    with pytest.raises(UserError, match="coming-from or going-to"):
        read_hindcast(tmp_path / "silent.nc")
    hc = read_hindcast(tmp_path / "silent.nc", direction_convention="from")
    assert_allclose(hc.bulk["dir_from_deg"].values[:, 0], [10.0, 90.0, 180.0, 270.0, 350.0])


# ------------------------------------------------------------------------------------------------
# CSV
# ------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def csv_table():
    return hw.hindcast_table_from_partitions(TIMES, WIND, SWELL)


def test_csv_bulk_equals_what_was_written_and_interpolates_in_time_only(tmp_path, csv_table):
    path = hw.write_hindcast_csv(tmp_path / "hc.csv", csv_table)
    hc = read_hindcast(path)
    assert hc.format == "csv" and hc.spectra is None and spectrum_at(hc, TIMES[0]) is None
    assert dict(hc.bulk.sizes) == {"time": 5, "site": 1}
    for col in csv_table.columns.drop("time"):
        assert_allclose(hc.bulk[col].values[:, 0], csv_table[col], rtol=1e-15, equal_nan=True)
    df = at_track(hc, TIMES[1:3] + pd.Timedelta(minutes=30))  # no position needed
    assert_allclose(df["hs"], 0.5 * (csv_table["hs"].to_numpy()[1:3] + csv_table["hs"].to_numpy()[2:4]))
    assert {"spreading", "wind_hs", "wind_tp", "wind_dir_from_deg", "swell_tp"} <= set(df.columns)
    # hour 3 has no wind sea: its direction is left out, not averaged with NaN
    assert df["wind_dir_from_deg"].iloc[0] == pytest.approx(WIND[1].dir_from_deg)
    # a position, if given, does not matter for a single site
    assert_allclose(at_track(hc, TIMES, 10.0, 20.0)["hs"], csv_table["hs"])


def test_csv_repairs_an_exact_duplicate_row(tmp_path, csv_table):
    path = hw.write_hindcast_csv(tmp_path / "dup.csv", csv_table)
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:3] + [lines[2]] + lines[3:]) + "\n")
    hc = read_hindcast(path)
    assert hc.bulk.sizes["time"] == 5 and hc.notes == ["1 duplicated row(s) dropped"]


# ------------------------------------------------------------------------------------------------
# errors: one line, naming the file and the problem
# ------------------------------------------------------------------------------------------------


def _one_line(exc_info, path):
    msg = str(exc_info.value)
    assert "\n" not in msg and msg.startswith(str(path))
    return msg


def test_track_outside_the_hindcast(era5_files):
    path, grid = era5_files[("new", "greenwich")]
    hc = read_hindcast(path)
    with pytest.raises(UserError) as e:
        at_track(hc, pd.date_range("2026-03-14T04:00", "2026-03-14T06:00", freq="30min", tz="UTC"), 61.0, 0.0)
    assert "track 2026-03-14T04:00Z–05:00Z is before the hindcast's first time 05:00Z" in _one_line(e, path)
    with pytest.raises(UserError) as e:
        at_track(hc, [TIMES[-1], TIMES[-1] + pd.Timedelta(hours=2)], 61.0, 0.0)
    assert "track 2026-03-14T09:00Z–11:00Z is after the hindcast's last time 09:00Z" in _one_line(e, path)
    lo, hi = grid.latitudes.min(), grid.latitudes.max()
    with pytest.raises(UserError) as e:
        at_track(hc, TIMES[:2], [61.0, hi + 1.1], 0.0)
    assert f"lat {hi + 1.1:.1f} outside {lo:.1f}–{hi:.1f} " in _one_line(e, path)
    with pytest.raises(UserError, match="lon 5.0 outside"):
        at_track(hc, TIMES[:1], 61.0, 5.0)


def test_malformed_files(tmp_path, csv_table):
    empty = tmp_path / "empty.nc"
    empty.write_bytes(b"")
    with pytest.raises(UserError, match="file is empty") as e:
        read_hindcast(empty)
    _one_line(e, empty)

    other = tmp_path / "other.nc"
    xr.Dataset({"sst": (("time",), [1.0, 2.0])}, coords={"time": TIMES[:2].tz_localize(None).values}).to_netcdf(other)
    with pytest.raises(UserError) as e:
        read_hindcast(other)
    msg = _one_line(e, other)
    assert "found ['sst', 'time']" in msg and "swh, pp1d, mwd" in msg

    partial = tmp_path / "partial.nc"
    hw.write_era5_netcdf(partial, TIMES[:1], [60.0, 60.5], [1.0, 1.5], {"swh": np.ones((1, 2, 2))})
    with pytest.raises(UserError, match="lacks pp1d, mwd") as e:
        read_hindcast(partial)
    _one_line(e, partial)

    backwards = tmp_path / "backwards.nc"
    ones = np.ones((3, 2, 2))
    hw.write_era5_netcdf(
        backwards, TIMES[[0, 2, 1]], [60.0, 60.5], [1.0, 1.5], {"swh": ones, "pp1d": 8 * ones, "mwd": ones}
    )
    with pytest.raises(
        UserError, match=r"times not increasing: 2026-03-14T06:00Z \(time 3\) follows 2026-03-14T07:00Z"
    ):
        read_hindcast(backwards)

    no_hs = tmp_path / "no_hs.csv"
    csv_table.drop(columns=["hs"]).to_csv(no_hs, index=False)
    with pytest.raises(UserError, match="missing column.* hs; found time, tp") as e:
        read_hindcast(no_hs)
    _one_line(e, no_hs)

    text = tmp_path / "text.csv"
    hw.write_hindcast_csv(text, csv_table)
    lines = text.read_text().splitlines()
    cells = lines[3].split(",")
    cells[2] = "calm"  # tp
    text.write_text("\n".join(lines[:3] + [",".join(cells)] + lines[4:]) + "\n")
    with pytest.raises(UserError, match="line 4, column tp: not a number: 'calm'") as e:
        read_hindcast(text)
    _one_line(e, text)

    order = tmp_path / "order.csv"
    hw.write_hindcast_csv(order, csv_table.iloc[[0, 2, 1, 3]])
    with pytest.raises(
        UserError, match=r"column time: times not increasing: 2026-03-14T06:00Z \(line 4\) follows 2026-03-14T07:00Z"
    ):
        read_hindcast(order)

    with pytest.raises(UserError, match="file not found"):
        read_hindcast(tmp_path / "nowhere.nc")
    with pytest.raises(UserError, match="unknown hindcast format"):
        read_hindcast(order, format="grib")


def test_auto_detection_is_by_content_not_extension(tmp_path, era5_files, csv_table):
    path, _ = era5_files[("legacy", "greenwich")]
    odd = tmp_path / "waves.dat"
    odd.write_bytes(path.read_bytes())
    assert read_hindcast(odd).format == "era5"
    csv = tmp_path / "waves.nc"
    hw.write_hindcast_csv(csv, csv_table)
    assert read_hindcast(csv).format == "csv"
    with pytest.raises(UserError, match="expected WW3 spectra"):
        read_hindcast(odd, format="ww3")


def test_hindcast_is_a_plain_dataclass():
    bulk = xr.Dataset(
        {k: (("time", "site"), [[1.0], [2.0]]) for k in ("hs", "tp", "dir_from_deg")},
        coords={"time": TIMES[:2].tz_localize(None).values},
    )
    df = at_track(Hindcast("mem", bulk, None), TIMES[0] + pd.Timedelta(minutes=45))
    assert df["hs"].iloc[0] == pytest.approx(1.75) and df["source"].iloc[0] == "mem"


def test_old_cds_expver_dimension_is_merged(tmp_path, era5_files):
    # CDS files mixing ERA5 (expver 1) and ERA5T (expver 5): each time is valid in one of the two
    path, grid = era5_files[("new", "greenwich")]
    with xr.open_dataset(path) as ds:
        ds = ds.drop_vars(["expver", "number"]).load()
    first = ds.where(ds.valid_time < ds.valid_time[3])
    second = ds.where(ds.valid_time >= ds.valid_time[3])
    mixed = xr.concat([first, second], dim=xr.DataArray(["0001", "0005"], dims="expver", name="expver"))
    mixed.to_netcdf(tmp_path / "mixed.nc")
    hc = read_hindcast(tmp_path / "mixed.nc")
    ref = read_hindcast(path)
    assert_allclose(hc.bulk["hs"].values, ref.bulk["hs"].values, rtol=1e-7)
    assert_allclose(hc.spectra.values, ref.spectra.values, rtol=1e-6)


def test_era5_spreading_from_the_spectra_matches_the_partitions(era5_files, csv_table):
    # σθ = √(2(1 − R)) from the 2-D spectra (wavespectra dspr) against the closed form of the partitions
    # (cos-2s: R = s/(s+1) per partition, energy-weighted vector sum) that the CSV table carries
    path, _ = era5_files[("new", "greenwich")]
    df = at_track(read_hindcast(path), TIMES, LAT_G, LON_G)
    assert_allclose(df["spreading"], csv_table["spreading"], rtol=0.01)


def test_wavespectra_netcdf_on_a_grid(tmp_path):
    # efth(time, lat, lon, freq, dir) as wavespectra writes it (coming-from, per degree); Hs ∝ (1 + 0.1 i_lon)
    spec = np.stack([hw.era5_spectrum(_parts(i)) for i in range(2)]) * np.pi / 180.0
    scale = (1.0 + 0.1 * np.arange(3)) ** 2
    efth = spec[:, None, None] * scale[None, None, :, None, None] * np.ones((1, 2, 1, 1, 1))
    ds = xr.Dataset(
        {"efth": (("time", "lat", "lon", "freq", "dir"), efth)},
        coords={
            "time": TIMES[:2].tz_localize(None).values,
            "lat": [58.0, 57.5],
            "lon": [179.5, -180.0, -179.5],
            "freq": hw.era5_frequencies(),
            "dir": hw.era5_directions_from_deg(),
        },
    )
    ds.to_netcdf(tmp_path / "grid.nc")
    hc = read_hindcast(tmp_path / "grid.nc")
    assert hc.format == "wavespectra" and hc.bulk["hs"].dims == ("time", "lat", "lon")
    hs_in = np.array([math.sqrt(sum(p.hs**2 for p in _parts(i))) for i in range(2)])
    df = at_track(hc, TIMES[:2], 57.5, 180.0)  # the node stored as −180
    assert_allclose(df["hs"], 1.1 * hs_in, rtol=0.01)
    # half-way between the 179.5 and −180 columns, across the date line: the mean of the two columns
    hs = hc.bulk["hs"].values[0].mean(axis=0)  # lat 57.75 is half-way too
    assert at_track(hc, TIMES[:1], 57.75, 179.75)["hs"].iloc[0] == pytest.approx(0.5 * (hs[0] + hs[1]), rel=1e-12)
    assert at_track(hc, TIMES[:1], 57.75, -179.75)["hs"].iloc[0] == pytest.approx(0.5 * (hs[1] + hs[2]), rel=1e-12)


# ------------------------------------------------------------------------------------------------
# land and sea ice: NaN through every reader, the stencil renormalised over the sea corners
# ------------------------------------------------------------------------------------------------

COAST_TIMES = TIMES[:3]
# nodes 60.5…62.0 N × 2.5…4.0 E (0.5°); land in the north-east, sea ice on (60.5, 4.0) from 07:00
LAND_NODES = [(61.5, 3.5), (61.5, 4.0), (62.0, 3.5), (62.0, 4.0), (61.0, 4.0)]
ICE_NODE, ICE_FROM = (60.5, 4.0), 2
# track points: (time, lat, lon, sea corners at every time used — counted by hand from the nodes above)
COAST_POINTS = [
    ("05:20", 61.25, 3.25, 3),  # one land corner (61.5, 3.5)
    ("05:50", 61.25, 3.75, 1),  # three land corners, only (61.0, 3.5) is sea
    ("06:10", 61.75, 3.25, 2),  # the cell's east side is land
    ("06:45", 60.75, 2.75, 4),  # open sea
    ("06:30", 60.75, 3.75, 2),  # (61.0, 4.0) land, (60.5, 4.0) ice at 07:00
    ("05:00", 61.0, 3.5, 1),  # on a sea node next to land: the land corners have zero weight, not partial
]


def _coast_land(lat, lon):
    """(time, lat, lon) True on land or ice for nodes `lat` × `lon`."""
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    land = np.zeros((COAST_TIMES.size, *la.shape), bool)
    for y, x in LAND_NODES:
        land[:, np.isclose(la, y) & np.isclose(lo, x)] = True
    land[ICE_FROM:, np.isclose(la, ICE_NODE[0]) & np.isclose(lo, ICE_NODE[1])] = True
    return land


@pytest.fixture(scope="module")
def coast_files(tmp_path_factory):
    """ERA5 grids with land / ice nodes missing (NaN), as CDS delivers them: {kind: path}."""
    root = tmp_path_factory.mktemp("coast")
    parts = [_parts(i) for i in range(COAST_TIMES.size)]
    bulk = hw.era5_bulk_fields(WIND[:3], SWELL[:3])
    grid = hw.grid_fields_around_track(
        COAST_TIMES,
        [61.2, 61.25, 61.3],
        [3.2, 3.25, 3.3],
        bulk,
        d2fd=hw.era5_d2fd(parts),
        field_gradients={"pp1d": (0.6, -0.8), "mwd": (10.0, -7.0), "mwp": (0.3, -0.2)},  # Tp, direction vary too
    )
    assert_allclose(grid.latitudes, [62.0, 61.5, 61.0, 60.5]) and assert_allclose(grid.longitudes, [2.5, 3.0, 3.5, 4.0])
    land = _coast_land(grid.latitudes, grid.longitudes)
    fields = {k: np.where(land, np.nan, v) for k, v in grid.fields.items()}
    d2fd = np.where(land[..., None, None], np.nan, grid.d2fd)
    out = {}
    for kind, layout, with_bulk in (("new", True, True), ("legacy", False, True), ("spectra", True, False)):
        out[kind] = hw.write_era5_netcdf(
            root / f"{kind}.nc", COAST_TIMES, grid.latitudes, grid.longitudes, fields if with_bulk else {}, d2fd,
            new_cds_layout=layout,
        )
    # the variant wavespectra produces: its own ERA5 reader fills the missing land spectra with 0
    ws = wavespectra.read_era5(str(out["spectra"]))
    ws.load().to_netcdf(root / "zero_filled.nc")
    ws.close()
    out["zero_filled"] = root / "zero_filled.nc"
    return out


def _points():
    t = pd.DatetimeIndex([f"2026-03-14T{p[0]}" for p in COAST_POINTS])
    lat = np.array([p[1] for p in COAST_POINTS])
    lon = np.array([p[2] for p in COAST_POINTS])
    return t, lat, lon


def _sea_only(field: xr.DataArray, sea: xr.DataArray, t, lat, lon) -> np.ndarray:
    """xarray's own multilinear interpolation over the sea nodes only: interp(field, 0 on land) / interp(sea)."""
    at = {"time": xr.DataArray(t.values, dims="p"), "lat": xr.DataArray(lat, dims="p"),
          "lon": xr.DataArray(lon, dims="p")}
    return (field.where(sea, 0.0).interp(at) / sea.astype(float).interp(at)).values


def _sea_only_dir(deg: xr.DataArray, sea, t, lat, lon) -> np.ndarray:
    s = _sea_only(np.sin(np.deg2rad(deg)), sea, t, lat, lon)
    c = _sea_only(np.cos(np.deg2rad(deg)), sea, t, lat, lon)
    return np.mod(np.rad2deg(np.arctan2(s, c)), 360.0)


def _reference(path, kind):
    """Node values read independently (xarray; wavespectra's own reader and Hs/Tp/Dm for the spectra), land by
    the missing values in the file: (sea, hs, tp, dir, efth) with dims time, lat (ascending), lon."""
    with xr.open_dataset(path) as raw:
        raw = raw.load()
    tname = "valid_time" if "valid_time" in raw.dims else "time"
    raw = raw.rename({tname: "time", "latitude": "lat", "longitude": "lon"}).sortby("lat")
    fdims = [d for d in raw["d2fd"].dims if d not in ("time", "lat", "lon")]
    ws = wavespectra.read_era5(str(path))
    efth = ws["efth"].load().sortby("lat").sortby("dir")  # float32 as wavespectra gives it
    ws.close()
    if kind == "spectra":
        sea = raw["d2fd"].notnull().any(fdims)
        hs, tp, dirs = (v.astype(float) for v in (efth.spec.hs(), efth.spec.tp(), efth.spec.dm()))
    else:
        sea = raw["swh"].notnull()
        hs, tp, dirs = (raw[v].astype(float) for v in ("swh", "pp1d", "mwd"))
    return sea, hs, tp, dirs, efth.astype(float)


@pytest.mark.parametrize("kind", ["new", "legacy", "spectra", "zero_filled"])
def test_land_and_ice_corners_are_left_out_as_xarray_interpolates_the_sea(coast_files, kind):
    path = coast_files[kind]
    sea, hs, tp, dirs, efth = _reference(path, kind) if kind != "zero_filled" else _reference(
        coast_files["spectra"], "spectra")
    if kind == "zero_filled":  # the file holds exact zeros at land, not NaN
        with xr.open_dataset(path) as zf:
            assert float(np.abs(zf["efth"].sortby("lat").where(~sea)).max()) == 0.0
    hc = read_hindcast(path)
    assert hc.format == ("wavespectra" if kind == "zero_filled" else "era5")
    # land / ice stay NaN in every variable and spectrum; the sea is untouched
    land = ~sea.transpose("time", "lat", "lon").values
    assert land.sum() == 3 * 5 + 1
    for name in hc.bulk.data_vars:
        assert np.isnan(hc.bulk[name].values[land]).all(), name
    assert np.isfinite(hc.bulk["hs"].values[~land]).all()
    spec = hc.spectra.transpose("time", "lat", "lon", "freq", "dir").values
    assert np.isnan(spec[land]).all() and np.isfinite(spec[~land]).all()

    t, lat, lon = _points()
    df = at_track(hc, t, lat, lon)
    assert_allclose(df["hs"], _sea_only(hs, sea, t, lat, lon), rtol=0, atol=1e-9)
    assert_allclose(df["tp"], _sea_only(tp, sea, t, lat, lon), rtol=0, atol=1e-9)
    assert _circ_diff(df["dir_from_deg"], _sea_only_dir(dirs, sea, t, lat, lon)).max() < 1e-9
    assert df["sea_corners"].tolist() == [p[3] for p in COAST_POINTS]
    assert df["stencil_corners"].tolist() == [4, 4, 4, 4, 4, 1]
    # the land pulled Hs down before: a plain bilinear interpolation with land as 0 sits well below
    filled = _sea_only(hs.fillna(0.0), xr.ones_like(sea), t, lat, lon)
    assert (df["hs"].to_numpy()[:3] > 1.2 * filled[:3]).all()
    # the spectrum: the weighted mean over the sea corners, scaled by (Σ w Hs)² / Σ w Hs² (spectrum_at)
    for k in (0, 1, 2, 4):
        got = spectrum_at(hc, t[k], lat[k], lon[k])
        one = (t[k : k + 1], lat[k : k + 1], lon[k : k + 1])
        mean = xr.concat([_one_spectrum(efth, sea, *one)], "p")[0]
        factor = _sea_only(hs, sea, *one) ** 2 / _sea_only(hs**2, sea, *one)
        ref = (mean * factor[0]).transpose("freq", "dir").values
        assert_allclose(got.values, ref, rtol=0, atol=1e-9 * ref.max())


def _one_spectrum(efth, sea, t, lat, lon):
    at = {"time": t.values[0], "lat": lat[0], "lon": lon[0]}
    return efth.where(sea, 0.0).interp(at) / sea.astype(float).interp(at)


def test_no_sea_corner_is_a_one_line_error_naming_time_and_place(coast_files):
    path = coast_files["new"]
    hc = read_hindcast(path)
    t = pd.DatetimeIndex(["2026-03-14T05:30", "2026-03-14T06:00"])
    with pytest.raises(UserError) as e:
        at_track(hc, t, [61.25, 61.75], [3.25, 3.75])
    msg = _one_line(e, path)
    assert ("no sea at lat 61.75, lon 3.75, 2026-03-14T06:00Z: all 4 grid corners are land or ice (hs missing) "
            "(1 of 2 track points)") in msg
    with pytest.raises(UserError, match=r"no sea at lat 61\.75, lon 3\.75, 2026-03-14T06:00Z") as e:
        spectrum_at(hc, t[1], 61.75, 3.75)
    _one_line(e, path)
    # a single-site hindcast (CSV) with Hs missing on both sides of the time
    table = hw.hindcast_table_from_partitions(TIMES[:3], WIND[:3], SWELL[:3])
    table.loc[[1, 2], "hs"] = np.nan
    csv = hw.write_hindcast_csv(path.parent / "gap.csv", table)
    hc = read_hindcast(csv)
    assert np.isnan(hc.bulk["tp"].values[1:, 0]).all()  # the row's other values go with its Hs
    assert at_track(hc, TIMES[:1] + pd.Timedelta(minutes=30))["sea_corners"].iloc[0] == 0  # 05:00 only
    gap = r"hs missing \(land, ice or a gap\) at the hindcast times around 2026-03-14T06:30Z"
    with pytest.raises(UserError, match=gap) as e:
        at_track(hc, TIMES[1:2] + pd.Timedelta(minutes=30))
    _one_line(e, csv)


def test_ww3_station_without_spectrum_is_left_out(tmp_path):
    # station 0 ice-covered from 06:00 (spectrum all 0), station 2 on land (all 0 at every time)
    path = _ww3_file(tmp_path / "ww3.nc", [61.0, 61.5, 61.2], [2.0, 2.8, 2.3])
    with xr.open_dataset(path) as raw:
        raw = raw.load()
    efth = raw["efth"].values.copy()
    efth[1:, 0] = 0.0
    efth[:, 2] = 0.0
    raw["efth"].values = efth
    raw.to_netcdf(tmp_path / "coast_ww3.nc")
    hc = read_hindcast(tmp_path / "coast_ww3.nc")
    assert np.isnan(hc.bulk["hs"].values[1:, 0]).all() and np.isnan(hc.bulk["hs"].values[:, 2]).all()
    assert np.isnan(hc.spectra.values[:, 2]).all() and np.isfinite(hc.bulk["tp"].values[:, 1]).all()
    # inverse-distance weights over the sea stations only (wavespectra's rule: 1/d, d in degrees)
    ref = wavespectra.read_ww3(str(path))
    hs_ref = ref.spec.hs().transpose("time", "site").values.astype(float)  # wavespectra's Hs of the untouched file
    ref.close()
    la, lo = 61.22, 2.35
    d = np.hypot(np.array([2.0, 2.8, 2.3]) - lo, np.array([61.0, 61.5, 61.2]) - la)
    w = np.where([[True, True, False]] + [[False, True, False]] * 4, 1.0 / d, 0.0)
    df = at_track(hc, TIMES, la, lo)
    assert_allclose(df["hs"], (w * hs_ref).sum(axis=1) / w.sum(axis=1), rtol=1e-9)
    assert df["sea_corners"].tolist() == [2, 1, 1, 1, 1] and df["stencil_corners"].tolist() == [3] * 5


def test_all_sea_stencils_are_unchanged(era5_files):
    # float.hex of the pre-mask code (commit 395942e) on the existing fixture: bit for bit, but for values decoded
    # from the file's float32 spectra (their rounding varies with the xarray release)
    path, _ = era5_files[("new", "greenwich")]
    hc = read_hindcast(path)
    t = TIMES[:4] + pd.to_timedelta([0, 20, 37, 50], unit="min")
    lat, lon = np.array([61.05, 61.2, 61.37, 61.5]), np.array([359.6, 359.9, 0.1, 0.45])
    df = at_track(hc, t, lat, lon)
    before = {
        "hs": ["0x1.ea48dfd70a3cap+0", "0x1.bb273006d3a13p+0", "0x1.e9378d0432c98p+0", "0x1.3e975f088888cp+1"],
        "tp": ["0x1.a000000000000p+3", "0x1.9ffffaaaaaaacp+3", "0x1.3190994444444p+3", "0x1.ef2afcaaaaaaap+2"],
        "dir_from_deg": ["0x1.0f64effffe63bp+8", "0x1.19cca9c6dabccp+8", "0x1.1cbb96179979cp+8",
                         "0x1.155128a014298p+8"],
        "spreading": ["0x1.532de343dda21p-1", "0x1.108ed64ac31f7p-1", "0x1.004f62e77d40ap-1",
                      "0x1.39c773860edaap-1"],
        "swell_hs": ["0x1.324744a3d709bp+0", "0x1.32e48f1111119p+0", "0x1.35058df92c5f1p+0",
                     "0x1.34a7720000003p+0"],
        "wind_dir_from_deg": ["0x1.f400000000000p+7", "0x1.fe00000000000p+7", "0x1.0900000000000p+8",
                              "0x1.0d2ad12fa6138p+8"],
    }
    for name, hexes in before.items():
        if name == "spreading":  # from the file's packed shorts: float32 rounding varies with the xarray release
            assert_allclose(df[name], [float.fromhex(x) for x in hexes], rtol=1e-6)
            continue
        assert [float(x).hex() for x in df[name]] == hexes, name
    assert df["sea_corners"].tolist() == df["stencil_corners"].tolist() == [4, 4, 4, 2]  # the last on a node row
    s = spectrum_at(hc, t[1], lat[1], lon[1]).values
    assert_allclose([s.sum(), (s**2).sum(), s.max()],  # float32 from the file, as the spreading above
                    [float.fromhex(x) for x in ("0x1.27253c414dd94p+0", "0x1.ccd99d1b936bfp-6",
                                                "0x1.15b73ddd5ecd0p-4")], rtol=1e-6)


def _ingest(tmp_path, hindcast):
    """`seatune ingest` (a subprocess, as a user runs it) on one minute of IMU at 07:00 and the sample GNSS."""
    import subprocess
    import sys

    import yaml

    from tests.conftest import ROOT

    n = 600
    t = pd.Timestamp("2026-03-14T07:00:00Z") + pd.to_timedelta(np.arange(n) * 0.1, unit="s")
    imu = pd.DataFrame({"time": t.strftime("%Y-%m-%dT%H:%M:%S.%fZ"), "qx": 0.0, "qy": 0.0, "qz": 0.0, "qw": 1.0,
                        "wx": 0.0, "wy": 0.0, "wz": 0.0, "ax": 0.0, "ay": 0.0, "az": 9.81})
    imu.to_csv(tmp_path / "imu.csv", index=False)
    logs = [{"path": str(tmp_path / "imu.csv"), "kind": "imu"},
            {"path": str(ROOT / "sample_logs/sample_trial_gnss.csv"), "kind": "gnss",
             "columns": {"vel_east": "vx", "vel_north": "vy"}}]
    run = {"name": "coast", "run_dir": str(tmp_path / "run"), "vessel": str(ROOT / "configs/vessels/sample_osv.yaml"),
           "logs": logs, "hindcast": {"path": str(hindcast)}}
    (tmp_path / "run.yaml").write_text(yaml.safe_dump(run))
    return subprocess.run([sys.executable, "-m", "seatune", "ingest", str(tmp_path / "run.yaml")],
                          capture_output=True, text=True)


def _sample_with_land(path, nodes):
    from tests.conftest import ROOT

    with xr.open_dataset(ROOT / "sample_logs/sample_trial_era5.nc") as ds:
        ds = ds.load()
    land = xr.zeros_like(ds["swh"].isel(valid_time=0, drop=True), dtype=bool)
    for y, x in nodes:
        land = land | ((ds.latitude == y) & (ds.longitude == x))
    for name in ds.data_vars:
        ds[name] = ds[name].where(~land)
    ds.to_netcdf(path)
    return path


def test_ingest_counts_partial_stencils_and_stops_with_no_sea(tmp_path):
    from seatune.io.parquet import column_units

    # the track at 07:00 (61.27 N, 3.16 E) lies in the cell 61.0–61.5 N × 3.0–3.5 E
    res = _ingest(tmp_path, _sample_with_land(tmp_path / "coast.nc", [(61.5, 3.5)]))
    assert res.returncode == 0, res.stderr
    assert "hindcast: 2 of 2 track hours next to land or ice" in res.stdout
    waves = pd.read_parquet(tmp_path / "run" / "waves.parquet")
    assert waves["sea_corners"].tolist() == [3, 3] and waves["stencil_corners"].tolist() == [4, 4]
    units = column_units(tmp_path / "run" / "waves.parquet")
    assert units["sea_corners"] == units["stencil_corners"] == "dimensionless"

    cell = [(61.0, 3.0), (61.0, 3.5), (61.5, 3.0), (61.5, 3.5)]
    bad = _sample_with_land(tmp_path / "land.nc", cell)
    res = _ingest(tmp_path, bad)
    assert res.returncode == 2, (res.stdout, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{bad}: no sea at" in lines[0], res.stderr
    assert re.search(r"no sea at lat 61\.2\d*, lon 3\.1\d*, 2026-03-14T07:00Z: all 4 grid corners are land", lines[0])
    # the earlier good artefact is still there
    assert pd.read_parquet(tmp_path / "run" / "waves.parquet")["sea_corners"].tolist() == [3, 3]


def test_a_file_read_again_is_the_same_unless_it_changed(tmp_path, csv_table):
    """Every stage of `seatune run` reads the hindcast: an unchanged file is parsed once and each reader gets its
    own copy; a file rewritten since is read afresh."""
    import os

    path = hw.write_hindcast_csv(tmp_path / "hc.csv", csv_table)
    first = read_hindcast(path)
    first.notes.append("changed by a caller")
    first.bulk["hs"][:] = -1.0
    again = read_hindcast(path)
    assert again.notes == [] and again.bulk.equals(read_hindcast(path).bulk)
    assert_allclose(again.bulk["hs"].values[:, 0], csv_table["hs"], rtol=1e-15)
    hw.write_hindcast_csv(path, csv_table.assign(hs=2 * csv_table["hs"]))
    stat = os.stat(path)
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))  # whatever the clock's resolution
    assert_allclose(read_hindcast(path).bulk["hs"].values[:, 0], 2 * csv_table["hs"], rtol=1e-15)

"""Hindcast readers (seatune.io.hindcast_readers) on files written in real-product layouts.

Reference values come from outside the reader: what the writers put in the files (hindcast_writers, whose
``grid_fields_around_track`` makes a bilinear interpolation at the track reproduce the track values
exactly, because the fields are linear in space), wavespectra's own WW3 writer, Hs = √(Σ Hs_i²) of the
JONSWAP partitions, and arithmetic (the mean of two hours, the circular mean of 350° and 10°).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from numpy.testing import assert_allclose

from seatune.errors import UserError
from seatune.io import hindcast_writers as hw
from seatune.io.hindcast_readers import Hindcast, at_track, read_hindcast, spectrum_at
from seatune.physics.spectra import SpectrumPartition as SP

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

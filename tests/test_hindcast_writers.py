"""Synthetic hindcasts in real-product layouts (seatune.simulate.hindcast_writers).

Reference numbers come from outside the writer: Hs = √(Σ Hs_i²) (each JONSWAP partition has m0 = Hs_i²/16
by construction, tested in test_spectra.py), the Pierson–Moskowitz closed form T_{m−1,0} = Tp Γ(5/4)/1.25^¼,
the cos-2s mean resultant length s/(s+1), and what wavespectra's own ERA5 reader makes of the files.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from numpy.testing import assert_allclose, assert_array_equal
from scipy.interpolate import RegularGridInterpolator

from seatune.physics.spectra import SpectrumPartition as SP
from seatune.simulate import hindcast_writers as hw

wavespectra = pytest.importorskip("wavespectra")

# Sea states (one per hour): peak periods 5–16 s, the three spreading kinds, directions near 0°/360°.
SEAS = [
    [SP(2.0, 8.0, 37.0)],
    [SP(1.5, 6.5, 250.0, spreading="cosn", spreading_param=2), SP(1.2, 13.0, 300.0, gamma=5.0, spreading_param=20)],
    [SP(1.0, 11.0, 352.0, spreading="long_crested")],
    [SP(3.5, 12.0, 5.0, gamma=2.0, spreading_param=8)],
    [SP(0.8, 5.0, 181.0, gamma=1.0), SP(2.2, 16.0, 175.0, gamma=6.0, spreading_param=30)],
    [],  # calm: every bin missing
]
TIMES = pd.date_range("2024-03-01T06:00", periods=len(SEAS), freq="h", tz="UTC")
HS_IN = np.array([math.sqrt(sum(p.hs**2 for p in parts)) for parts in SEAS])


def _circ_diff(a, b):
    return np.abs((np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0)


@pytest.fixture(scope="module")
def d2fd_track():
    return hw.era5_d2fd(SEAS)


# ------------------------------------------------------------------------------------------------
# grid and spectra
# ------------------------------------------------------------------------------------------------


def test_era5_grid_matches_ecmwf_definition():
    f = hw.era5_frequencies()
    assert f.shape == (30,)
    assert_allclose(f[0], 0.03453)
    assert_allclose(f[1:] / f[:-1], 1.1)
    assert_array_equal(hw.era5_directions_deg(), np.arange(7.5, 360.0, 15.0))  # going-to, as stored
    from_deg = hw.era5_directions_from_deg()
    assert from_deg[0] == 187.5 and from_deg[12] == 7.5 and from_deg[-1] == 172.5
    assert_allclose(np.diff(hw.era5_frequency_edges()), np.gradient(f), rtol=1e-12)  # wavespectra's df


def test_d2fd_marks_small_values_missing_and_never_holds_inf(d2fd_track):
    assert d2fd_track.shape == (len(SEAS), 30, 24)
    assert not np.isinf(d2fd_track).any()
    assert np.isnan(d2fd_track[-1]).all()  # calm sea
    assert np.nanmin(d2fd_track) >= np.log10(hw.D2FD_FLOOR)
    # cosⁿ spreading is exactly 0 beyond ±90°: those bins are missing, not log10(0)
    assert np.isnan(d2fd_track[1]).any()
    floored = hw.era5_d2fd(SEAS[1:2], below_floor="floor")
    assert np.isfinite(floored).all() and floored.min() == pytest.approx(np.log10(hw.D2FD_FLOOR))


def test_cell_mean_keeps_the_variance_of_the_resolved_band():
    # Σ F Δf Δθ over wavespectra's cells equals Hs²/16 minus the tails outside 0.033–0.56 Hz (tiny at Tp 8 s)
    parts = [SP(2.0, 8.0, 100.0, gamma=3.3)]
    spec = hw.era5_spectrum(parts)
    m0 = np.sum(spec * np.diff(hw.era5_frequency_edges())[:, None]) * (2 * np.pi / 24)
    assert 4 * np.sqrt(m0) == pytest.approx(2.0, rel=2e-3)


# ------------------------------------------------------------------------------------------------
# netCDF layouts
# ------------------------------------------------------------------------------------------------


def _write_spectra(tmp_path, d2fd_track, new):
    lat, lon = np.array([60.0, 60.5]), np.array([2.0])
    spec = np.repeat(d2fd_track[:, None, None], 2, axis=1)
    return hw.write_era5_netcdf(tmp_path / f"spec_{new}.nc", TIMES, lat, lon, {}, spec, new_cds_layout=new)


def test_new_cds_layout_opens_with_plain_xarray(tmp_path, d2fd_track):
    bulk = hw.era5_bulk_fields([s[:1] for s in SEAS], [s[1:] for s in SEAS])
    lat, lon = np.array([59.5, 60.0, 60.5]), np.array([1.5, 2.0])  # ascending on input
    fields = {k: np.broadcast_to(v[:, None, None], (len(SEAS), 3, 2)) for k, v in bulk.items()}
    path = hw.write_era5_netcdf(tmp_path / "waves.nc", TIMES, lat, lon, fields)
    with xr.open_dataset(path) as ds:
        assert set(ds.data_vars) == {"swh", "pp1d", "mwd", "mwp", "shww", "mpww", "mdww", "shts", "mpts", "mdts"}
        assert ds.swh.dims == ("valid_time", "latitude", "longitude")
        assert_array_equal(ds.latitude, [60.5, 60.0, 59.5])  # stored north to south, like ERA5
        assert ds.swh.dtype == np.float32
        assert ds.swh.attrs["units"] == "m" and ds.swh.attrs["GRIB_paramId"] == 140229
        assert ds.mwd.attrs["units"] == "Degree true" and ds.mwd.attrs["long_name"] == "Mean wave direction"
        assert ds.pp1d.attrs["units"] == "s" and ds.mwp.attrs["GRIB_paramId"] == 140232
        assert ds.attrs["Conventions"] == "CF-1.7" and "SYNTHETIC" in ds.attrs["history"]
        assert ds.valid_time.encoding["units"] == "seconds since 1970-01-01"
        assert "number" in ds.coords and "expver" in ds.coords
        assert_array_equal(ds.valid_time.values, TIMES.tz_localize(None).values)
        assert_allclose(ds.swh.values[:, 1, 0], bulk["swh"], rtol=1e-6)
        assert np.isnan(ds.pp1d.values[-1]).all()  # calm hour: missing, as ERA5
    spec_path = _write_spectra(tmp_path, d2fd_track, True)
    with xr.open_dataset(spec_path) as ds:
        assert ds.d2fd.dims == ("valid_time", "frequencyNumber", "directionNumber", "latitude", "longitude")
        assert_array_equal(ds.frequencyNumber, np.arange(1, 31))
        assert_array_equal(ds.directionNumber, np.arange(1, 25))
        assert ds.d2fd.attrs["units"] == "m**2 s radian**-1" and ds.d2fd.attrs["GRIB_paramId"] == 140251
        assert_allclose(ds.d2fd.values[:, :, :, 0, 0], d2fd_track, rtol=1e-6)  # float32, NaN = missing


def test_legacy_layout_is_packed_like_grib_to_netcdf(tmp_path, d2fd_track):
    path = _write_spectra(tmp_path, d2fd_track, False)
    with xr.open_dataset(path, mask_and_scale=False, decode_times=False) as raw:
        assert raw.d2fd.dims == ("time", "frequency", "direction", "latitude", "longitude")
        assert raw.d2fd.dtype == np.int16 and raw.d2fd.attrs["missing_value"] == -32767
        assert raw.time.dtype == np.int32 and raw.time.attrs["units"] == "hours since 1900-01-01 00:00:00.0"
        assert raw.attrs["Conventions"] == "CF-1.6"
    with xr.open_dataset(path) as ds:
        got = ds.d2fd.values[:, :, :, 0, 0]
        assert_array_equal(np.isnan(got), np.isnan(d2fd_track))
        assert np.nanmax(np.abs(got - d2fd_track)) < 2e-4  # int16 quantisation of the log10 values


@pytest.mark.parametrize("new", [True, False])
def test_wavespectra_reads_hs_and_direction_back(tmp_path, d2fd_track, new):
    path = _write_spectra(tmp_path, d2fd_track, new)
    ds = wavespectra.read_era5(str(path)).isel(lat=0, lon=0).load()
    assert_allclose(ds.dir.values, hw.era5_directions_from_deg())  # reader's coming-from grid
    hs = ds.spec.hs().values
    rel = hs[:-1] / HS_IN[:-1] - 1.0
    assert np.max(np.abs(rel)) < 0.02, rel
    assert hs[-1] == 0.0  # all missing → 0, as wavespectra fills NaN with 0
    # the bulk mwp (T_{m−1,0} of the continuous spectra) agrees with the same moment ratio of the file's spectra
    e, f = ds.efth.spec.oned().values[:-1], ds.freq.values
    tm10_file = (e / f * np.gradient(f)).sum(axis=1) / (e * np.gradient(f)).sum(axis=1)
    assert_allclose(tm10_file, [hw.bulk_from_partitions(s)["mwp"] for s in SEAS[:-1]], rtol=0.01)
    # single-system seas: the peak and the mean direction are the coming-from direction put in (within a bin)
    for i in (0, 2, 3):
        d_in = SEAS[i][0].dir_from_deg
        assert _circ_diff(ds.spec.dp().values[i], d_in) <= 7.5
        assert _circ_diff(ds.spec.dm().values[i], d_in) <= 7.5
    # two systems: the peak direction is the swell's (narrow, γ = 5–6: it dominates E(f, θ))
    assert _circ_diff(ds.spec.dp().values[1], 300.0) <= 7.5
    assert _circ_diff(ds.spec.dp().values[4], 175.0) <= 7.5


# ------------------------------------------------------------------------------------------------
# bulk parameters
# ------------------------------------------------------------------------------------------------


def test_bulk_swh_is_the_root_sum_of_squares_exactly():
    parts = SEAS[1] + SEAS[4]
    b = hw.bulk_from_partitions(parts)
    assert b["swh"] == pytest.approx(math.sqrt(sum(p.hs**2 for p in parts)), rel=1e-15)
    assert hw.bulk_from_partitions([])["swh"] == 0.0 and math.isnan(hw.bulk_from_partitions([])["mwp"])


@pytest.mark.parametrize(
    "part",
    [
        SP(2.0, 9.0, 123.4),
        SP(1.0, 14.0, 359.9, spreading="cosn", spreading_param=4),
        SP(1.0, 6.0, 0.0, spreading="long_crested"),
    ],
)
def test_bulk_of_one_partition_returns_its_direction_and_peak(part):
    b = hw.bulk_from_partitions(part)
    assert _circ_diff(b["mwd"], part.dir_from_deg) < 1e-9
    assert b["pp1d"] == pytest.approx(part.tp, rel=1e-5)  # JONSWAP/PM peak at fp


def test_mwp_is_the_inverse_moment_period():
    # Pierson–Moskowitz: m_n = (5/64) Hs² fpⁿ 1.25^(n/4−1) Γ(1−n/4) → T_{m−1,0} = Tp Γ(5/4) / 1.25^¼ = 0.857 Tp
    tp = 10.0
    b = hw.bulk_from_partitions(SP(2.0, tp, 0.0, gamma=1.0))
    assert b["mwp"] == pytest.approx(tp * math.gamma(1.25) / 1.25**0.25, rel=1e-4)


def test_mwd_is_the_energy_weighted_vector_mean():
    pair = [SP(1.0, 8.0, 350.0), SP(1.0, 8.0, 10.0)]
    assert _circ_diff(hw.bulk_from_partitions(pair)["mwd"], 0.0) < 1e-9  # not 180°
    # weights m0_i r_i: Hs 2 vs 1 at 80°/100°, same spreading → atan2 of weighted unit vectors
    b = hw.bulk_from_partitions([SP(2.0, 8.0, 80.0), SP(1.0, 8.0, 100.0)])
    expect = math.degrees(
        math.atan2(
            4 * math.sin(math.radians(80)) + math.sin(math.radians(100)),
            4 * math.cos(math.radians(80)) + math.cos(math.radians(100)),
        )
    )
    assert b["mwd"] == pytest.approx(expect, abs=1e-9)
    s = 6.0
    assert hw.directional_spread_rad(SP(1.0, 8.0, 40.0, spreading_param=s)) == pytest.approx(math.sqrt(2 / (s + 1)))


# ------------------------------------------------------------------------------------------------
# CSV
# ------------------------------------------------------------------------------------------------


def test_hindcast_csv_round_trips_with_pandas(tmp_path):
    wind = [SP(1.5, 6.0, 200.0), None, SP(2.0, 7.0, 355.0)]
    swell = [SP(1.0, 12.0, 260.0), SP(0.7, 14.0, 270.0), None]
    table = hw.hindcast_table_from_partitions(TIMES[:3], wind, swell)
    path = hw.write_hindcast_csv(tmp_path / "hindcast.csv", table)
    text = path.read_text().splitlines()
    assert text[0].split(",")[:4] == ["time", "hs", "tp", "dir_from_deg"]
    assert text[1].startswith("2024-03-01T06:00:00Z,")
    back = pd.read_csv(path, parse_dates=["time"], float_precision="round_trip")
    assert str(back["time"].dt.tz) == "UTC"
    assert_array_equal(back["time"].values, table["time"].values)
    pd.testing.assert_frame_equal(back.drop(columns="time"), table.drop(columns="time"), check_exact=True)
    assert math.isnan(back.loc[1, "wind_hs"]) and back.loc[1, "hs"] == pytest.approx(0.7)
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind


def test_hindcast_csv_checks_columns_and_normalises(tmp_path):
    with pytest.raises(ValueError, match="required"):
        hw.write_hindcast_csv(tmp_path / "a.csv", pd.DataFrame({"time": TIMES[:1], "hs": [1.0]}))
    partial = pd.DataFrame({"time": TIMES[:1], "hs": [1.0], "tp": [8.0], "dir_from_deg": [10.0], "wind_hs": [1.0]})
    with pytest.raises(ValueError, match="partition columns"):
        hw.write_hindcast_csv(tmp_path / "b.csv", partial)
    naive = pd.DataFrame(
        {"time": [pd.Timestamp("2024-01-01 12:00")], "hs": [1.0], "tp": [8.0], "dir_from_deg": [-10.0], "note": ["x"]}
    )
    back = pd.read_csv(hw.write_hindcast_csv(tmp_path / "c.csv", naive))
    assert back["time"][0] == "2024-01-01T12:00:00Z" and back["dir_from_deg"][0] == 350.0
    assert list(back.columns) == ["time", "hs", "tp", "dir_from_deg", "note"]


# ------------------------------------------------------------------------------------------------
# gridded fields around the track
# ------------------------------------------------------------------------------------------------


def _bilinear_at_track(grid: hw.GriddedFields, field: np.ndarray, lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """Bilinear interpolation at each track point, grid longitudes unwrapped around the track first."""
    out = np.empty(lat.size)
    for t in range(lat.size):
        glon = lon[t] + (grid.longitudes - lon[t] + 180.0) % 360.0 - 180.0
        ilon, ilat = np.argsort(glon), np.argsort(grid.latitudes)
        interp = RegularGridInterpolator((grid.latitudes[ilat], glon[ilon]), field[t][np.ix_(ilat, ilon)])
        out[t] = interp([[lat[t], lon[t]]])[0]
    return out


def test_grid_fields_are_exact_at_the_track_but_vary_across_the_box(tmp_path, d2fd_track):
    n = len(SEAS)
    lat, lon = np.full(n, 58.13), np.linspace(4.1, 4.3, n)
    bulk = hw.era5_bulk_fields([s[:1] for s in SEAS], [s[1:] for s in SEAS])
    grid = hw.grid_fields_around_track(TIMES, lat, lon, bulk, d2fd=d2fd_track)
    assert_array_equal(grid.latitudes, [58.5, 58.0, 57.5])
    assert_array_equal(grid.longitudes, [3.5, 4.0, 4.5, 5.0])
    for name in ("swh", "shww", "mwd", "mwp"):
        got = _bilinear_at_track(grid, np.nan_to_num(grid.fields[name]), lat, lon)
        assert_allclose(got, np.nan_to_num(bulk[name]), rtol=1e-12, atol=1e-12)
    # nearest node is not the answer: a few % of Hs across a cell
    near = grid.fields["swh"][0, 1, 1]
    assert abs(near / bulk["swh"][0] - 1.0) > 0.003
    assert np.ptp(grid.fields["swh"][0]) / bulk["swh"][0] > 0.05
    # wind sea and swell stay consistent with the total at every node
    assert_allclose(
        np.nan_to_num(grid.fields["shww"]) ** 2 + np.nan_to_num(grid.fields["shts"]) ** 2,
        grid.fields["swh"] ** 2,
        rtol=1e-12,
        atol=1e-12,
    )
    # the spectra scale with the heights: wavespectra's Hs at a corner node is k·Hs at the track
    path = hw.write_era5_netcdf(tmp_path / "box.nc", TIMES, grid.latitudes, grid.longitudes, {}, grid.d2fd)
    ds = wavespectra.read_era5(str(path)).sel(lat=57.5, lon=5.0).load()
    k = grid.height_factor[:-1, 2, 3]
    assert_allclose(ds.spec.hs().values[:-1], HS_IN[:-1] * k, rtol=0.02)


@pytest.mark.parametrize(
    ("convention", "track_lon", "expect"),
    [
        # nodes nearest to the track (359.5 … 360.5 unwrapped) ± 1; a 0..360 subset across Greenwich has a gap
        ("0_360", [359.8, 359.95, 0.1, 0.3], [0.0, 0.5, 1.0, 359.5]),
        ("-180_180", [359.8, 359.95, 0.1, 0.3], [-0.5, 0.0, 0.5, 1.0]),
        ("-180_180", [179.9, -179.9, -179.8, -179.7], [-180.0, -179.5, -179.0, 179.5]),
    ],
)
def test_longitude_wrap(tmp_path, convention, track_lon, expect):
    times = TIMES[:4]
    lat, lon = np.array([-33.9, -33.95, -34.0, -34.05]), np.array(track_lon)
    hs = np.array([1.0, 1.5, 2.0, 2.5])
    grid = hw.grid_fields_around_track(times, lat, lon, {"swh": hs, "mwp": np.full(4, 7.0)}, lon_convention=convention)
    assert_allclose(grid.longitudes, expect)
    assert_allclose(_bilinear_at_track(grid, grid.fields["swh"], lat, lon), hs, rtol=1e-12)
    path = hw.write_era5_netcdf(tmp_path / "wrap.nc", times, grid.latitudes, grid.longitudes, grid.fields)
    with xr.open_dataset(path) as ds:
        assert_allclose(ds.longitude.values, expect)
        assert_allclose(_bilinear_at_track(grid, ds.swh.values.astype(float), lat, lon), hs, rtol=1e-6)


def test_failed_write_keeps_the_old_file(tmp_path, d2fd_track):
    path = _write_spectra(tmp_path, d2fd_track, True)
    before = path.read_bytes()
    bad = np.full((1, 1, 1, 30, 24), -np.inf)
    with pytest.raises(ValueError, match="inf"):
        hw.write_era5_netcdf(path, TIMES[:1], [60.0], [2.0], {}, bad)
    with pytest.raises(ValueError, match="unknown ERA5 bulk"):
        hw.write_era5_netcdf(path, TIMES[:1], [60.0], [2.0], {"hs": np.ones((1, 1, 1))})
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]

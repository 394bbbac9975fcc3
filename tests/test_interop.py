"""Outputs the neighbouring tools open: Capytaine (post_pro.rao, WAMIT / Nemoh export), xarray, waveresponse,
and the per-Hz window spectra. Expected values come from Capytaine, waveresponse and analytic conversions."""

import json
import logging

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from capytaine.io.xarray import merge_complex_values
from capytaine.post_pro import rao as capytaine_rao
from click.testing import CliRunner

import seatune.cli.vessel  # noqa: F401  (registers the vessel commands)
from seatune.cli.main import cli
from seatune.io.capytaine_export import export_capytaine
from tests.conftest import ROOT, SAMPLE_VESSEL


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def seatune_raos(path) -> np.ndarray:
    """`seatune vessel rao --dofs-only` Parquet → X (omega, wave_direction, dof), complex."""
    df = pd.read_parquet(path)
    dofs = ["Surge", "Sway", "Heave", "Roll", "Pitch", "Yaw"]
    df = df.assign(r=pd.Categorical(df["response"], dofs)).sort_values(["omega", "wave_direction", "r"])
    n_w, n_b = df["omega"].nunique(), df["wave_direction"].nunique()
    return (df["re"].to_numpy() + 1j * df["im"].to_numpy()).reshape(n_w, n_b, 6)


def open_capytaine(path) -> xr.Dataset:
    with xr.open_dataset(path) as ds:  # plain xarray + Capytaine's own merge, no seatune code
        return merge_complex_values(ds.load())


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """Sample loading (beta44 = 0.07) and the same loading without extra damping: RAO Parquet + Capytaine netCDF."""
    tmp = tmp_path_factory.mktemp("interop")
    out = {}
    for key, sets in (("base", []), ("undamped", ["--set", "beta44=0"])):
        for cmd, name in (("rao", "rao.parquet"), ("export", "hydro.nc")):
            extra = ["--dofs-only"] if cmd == "rao" else []
            res = invoke("vessel", cmd, SAMPLE_VESSEL, *sets, *extra, "--out", tmp / f"{key}_{name}")
            assert res.exit_code == 0, res.output
        out[key] = (seatune_raos(tmp / f"{key}_rao.parquet"), open_capytaine(tmp / f"{key}_hydro.nc"))
    return tmp, out


def assert_close(got, want, tol=1e-9):
    scale = np.abs(want).max(axis=(0, 1), keepdims=True)  # per DOF
    assert np.all(np.abs(got - want) <= tol * scale), np.abs(got - want).max(axis=(0, 1)) / scale.ravel()


def test_capytaine_rao_equals_seatune_rao(exported):
    _, out = exported
    want, ds = out["base"]
    assert set(ds.dims) >= {"omega", "wave_direction", "influenced_dof", "radiating_dof"}
    assert float(ds["forward_speed"]) == 0.0 and str(ds["body"].values) == 'Sample OSV "Nordkapp Tern"'
    assert 5.0 < float(ds["draught"]) < 6.5  # 9.9e6 kg lies between the database drafts 5.5 and 6.0 m
    got = capytaine_rao(ds, dissipation=ds["dissipation"]).transpose("omega", "wave_direction", "radiating_dof")
    assert_close(got.values, want)
    # without the loading's extra roll damping Capytaine's plain call is seatune's RAO of that loading
    want0, ds0 = out["undamped"]
    assert np.abs(ds0["dissipation"].values).max() == 0.0
    got0 = capytaine_rao(ds0).transpose("omega", "wave_direction", "radiating_dof")
    assert_close(got0.values, want0)
    # the dissipation matters: without beta44 = 0.07 the roll peak is 6.2 times higher (0.76 vs 0.12 rad/m)
    roll = ds["radiating_dof"].values.tolist().index("Roll")
    assert np.abs(want0[..., roll]).max() > 5 * np.abs(want[..., roll]).max()


def test_capytaine_exporters_write_the_dataset(exported, tmp_path, caplog):
    _, out = exported
    ds = out["base"][1].isel(omega=slice(0, None, 12), wave_direction=slice(0, None, 6))
    rho, g = float(ds["rho"]), float(ds["g"])
    with caplog.at_level(logging.WARNING, logger="capytaine"):  # seatune's CLI path: Capytaine's export_dataset
        export_capytaine(ds, tmp_path / "osv", "wamit")
        export_capytaine(ds, tmp_path / "nemoh", "nemoh")
    assert not caplog.records, [r.getMessage() for r in caplog.records]
    hst = np.loadtxt(tmp_path / "osv.hst")  # I J C/(rho g L^k) with L = 1
    C = np.zeros((6, 6))
    C[hst[:, 0].astype(int) - 1, hst[:, 1].astype(int) - 1] = hst[:, 2]
    want = ds["hydrostatic_stiffness"].values / (rho * g)
    np.testing.assert_allclose(C, want, rtol=1e-6, atol=1e-6 * np.abs(want).max())
    three = np.loadtxt(tmp_path / "osv.3")  # PER BETA I |F| phase Re Im, WAMIT's e^{+iwt}: conj of Capytaine's
    assert three.shape == (ds.sizes["omega"] * ds.sizes["wave_direction"] * 6, 7)
    row = three[(three[:, 2] == 3)][0]  # heave force at the longest period
    om = 2 * np.pi / row[0]
    F = ds["excitation_force"].sel(omega=om, method="nearest").sel(
        wave_direction=np.radians(row[1]), method="nearest").sel(influenced_dof="Heave").item()
    np.testing.assert_allclose(row[5] + 1j * row[6], np.conj(F) / (rho * g), rtol=1e-5)
    kh = np.loadtxt(tmp_path / "nemoh" / "KH.dat")
    np.testing.assert_allclose(kh, ds["hydrostatic_stiffness"].values, rtol=1e-5, atol=1.0)
    assert (tmp_path / "nemoh" / "RadiationCoefficients.tec").stat().st_size > 0


def test_export_cli_bad_loading(tmp_path):
    res = invoke("vessel", "export", SAMPLE_VESSEL, "--set", "mass=1e5", "--out", tmp_path / "x.nc")
    assert res.exit_code == 2 and not (tmp_path / "x.nc").exists()
    assert res.output.strip().count("\n") == 0 and "loading.mass" in res.output


def test_rao_xarray_and_waveresponse_formats(exported):
    tmp, out = exported
    want = out["base"][0]
    for fmt in ("xarray", "waveresponse"):
        res = invoke("vessel", "rao", SAMPLE_VESSEL, "--dofs-only", "--format", fmt, "--out", tmp / f"rao_{fmt}.nc")
        assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp / "rao_xarray.nc") as ds:
        ds = merge_complex_values(ds.load())
    for key in ("frequency", "wave_direction", "time_convention", "phase", "reference_point", "angles"):
        assert ds.attrs[key]
    assert ds["omega"].attrs["units"] == "rad/s" and "going-to" in ds.attrs["wave_direction"]
    assert list(ds["units"].values) == ["m/m"] * 3 + ["rad/m"] * 3
    np.testing.assert_array_equal(ds["rao"].transpose("omega", "wave_direction", "response").values, want)

    wr = pytest.importorskip("waveresponse")
    with xr.open_dataset(tmp / "rao_waveresponse.nc") as f:
        kwargs = json.loads(f.attrs["waveresponse_from_amp_phase"])
        freq, dirs = f["freq"].values, f["dirs"].values
        rao = wr.RAO.from_amp_phase(freq, dirs, f["amp"].sel(response="Roll").values,
                                    f["phase"].sel(response="Roll").values, **kwargs)
    X = want[..., 3]
    f_out, d_out, vals = rao.grid(freq_hz=False, degrees=False)
    np.testing.assert_allclose(f_out, freq)
    # waveresponse stores e^{+iwt} (phase-lead) values: the conjugate of seatune's e^{-iwt} amplitudes
    np.testing.assert_allclose(vals, np.conj(X), rtol=1e-12, atol=1e-15)
    amp, phase = rao.to_amp_phase(phase_degrees=False, phase_leading=False, freq_hz=False, degrees=False)[2:]
    np.testing.assert_allclose(amp, np.abs(X), rtol=1e-12)
    # waveresponse's own conversion to 'coming from, clockwise': direction (pi - beta) mod 2pi
    beta = d_out
    rao.set_wave_convention(clockwise=True, waves_coming_from=True)
    d_cw, v_cw = rao.grid(degrees=False)[1:]
    order = np.argsort(np.mod(np.pi - beta, 2 * np.pi))
    np.testing.assert_allclose(d_cw, np.mod(np.pi - beta, 2 * np.pi)[order], atol=1e-12)
    np.testing.assert_allclose(v_cw, np.conj(X)[:, order], rtol=1e-12, atol=1e-15)


def test_parquet_rao_carries_conventions(exported):
    import pyarrow.parquet as pq

    tmp, _ = exported
    meta = json.loads(pq.read_schema(tmp / "base_rao.parquet").metadata[b"seatune"])
    assert "lag" in meta["conventions"]["phase"] and "going-to" in meta["conventions"]["wave_direction"]


def test_spectrum_per_hz_keeps_the_variance():
    from seatune.physics.adaptive_filter import welch_spectrum
    from seatune.pipeline.filter import spectrum_per_hz

    rng = np.random.default_rng(3)
    fs, t = 10.0, np.arange(0, 1800, 0.1)
    x = 0.05 * np.sin(0.6 * t) + 0.02 * np.sin(1.1 * t + 1) + 0.005 * rng.standard_normal(t.size)
    omega, S, _ = welch_spectrum(x, fs, segment_s=256.0)
    f, S_f = spectrum_per_hz(omega, S)
    m0_omega, m0_f = np.trapezoid(S, omega), np.trapezoid(S_f, f)
    assert m0_f == pytest.approx(m0_omega, rel=1e-12)
    assert m0_f == pytest.approx(np.var(x), rel=0.05)  # both are the signal's variance
    np.testing.assert_allclose(f, omega / (2 * np.pi))


def test_run_yaml_spectrum_frequency_option(tmp_path):
    import yaml

    from seatune.errors import UserError
    from seatune.io.run_yaml import Run

    data = yaml.safe_load((ROOT / "configs/runs/sample.yaml").read_text())
    data["vessel"] = str(SAMPLE_VESSEL)
    for log in data["logs"]:
        log["path"] = str(ROOT / "sample_logs" / log["path"].split("/")[-1])
    data["hindcast"]["path"] = str(ROOT / "sample_logs" / data["hindcast"]["path"].split("/")[-1])
    path = tmp_path / "run.yaml"
    path.write_text(yaml.safe_dump(data))
    assert Run(path).spec.output.spectrum_frequency == "rad/s"
    data["output"] = {"spectrum_frequency": "Hz"}
    path.write_text(yaml.safe_dump(data))
    assert Run(path).spec.output.spectrum_frequency == "Hz"
    data["output"] = {"spectrum_frequency": "kHz"}
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(UserError, match="spectrum_frequency"):
        Run(path)

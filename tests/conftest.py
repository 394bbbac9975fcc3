from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SAMPLE_VESSEL = ROOT / "configs" / "vessels" / "sample_osv.yaml"


@pytest.fixture(scope="session")
def sample_model():
    from seatune.pipeline.vessel import open_vessel

    return open_vessel(SAMPLE_VESSEL)


@pytest.fixture(scope="session")
def sample_dataset():
    """The committed hydro database opened with plain xarray + Capytaine's complex merge (not seatune)."""
    import xarray as xr
    from capytaine.io.xarray import merge_complex_values

    with xr.open_dataset(ROOT / "configs" / "vessels" / "sample_osv_hydro.nc", engine="netcdf4") as ds:
        return merge_complex_values(ds.load())

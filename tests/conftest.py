from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SAMPLE_VESSEL = ROOT / "configs" / "vessels" / "sample_osv.yaml"


# the longest files first (pytest --durations, 2 workers): xdist's --dist loadfile hands files out in collection
# order, and a long file handed out last runs alone at the end (the last 3 % of the tests took 3.5 min of 19)
LONGEST_FIRST = ("test_diagnosis.py", "test_validation_bank.py", "test_report.py", "test_batch.py",
                 "test_ingest_errors.py", "test_predict.py", "test_identify_trials.py", "test_tune_sample.py",
                 "test_sea_estimation.py", "test_simulated_files.py", "test_tuning_trials.py")


def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: each file keeps its own order


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


@pytest.fixture(scope="session")
def finished_sample(tmp_path_factory, worker_id):
    """`seatune run` of the sample (configs/runs/sample.yaml, absolute paths) once for all test processes: the
    first to ask runs it under a lock, the others wait for it. (run dir, run YAML, stdout, stderr, seconds). Read
    it or copy it (`copy_of_sample`); never write into it."""
    import fcntl
    import json
    import subprocess
    import sys
    import time

    from tests.test_tune_sample import sample_run

    base = tmp_path_factory.getbasetemp()
    root = base if worker_id == "master" else base.parent  # xdist: the parent is this session's, shared
    done = root / "finished_sample.json"
    with open(root / "finished_sample.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            (root / "finished_sample").mkdir()
            path = sample_run(root / "finished_sample")
            start = time.monotonic()
            res = subprocess.run([sys.executable, "-m", "seatune", "run", str(path)], capture_output=True, text=True)
            assert res.returncode == 0, res.stderr
            done.write_text(json.dumps([str(path), res.stdout, res.stderr, time.monotonic() - start]))
    path, stdout, stderr, seconds = json.loads(done.read_text())
    return Path(path).parent / "run", Path(path), stdout, stderr, seconds


def copy_of_sample(finished, tmp: Path) -> Path:
    """A copy of the finished sample's run directory at tmp/run with its run YAML at tmp/run.yaml (every stage but
    the report, whose page names the YAML, up to date)."""
    import shutil

    from tests.test_tune_sample import sample_run

    shutil.copytree(finished[0], tmp / "run")
    return sample_run(tmp)

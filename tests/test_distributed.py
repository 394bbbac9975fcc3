"""`seatune batch --scheduler` on a real Dask cluster of separate programs: a `dask scheduler` and two
`dask worker` processes. One worker is SIGKILLed while a run is half-way through its stages; the batch must
still finish every run, and its fleet summary must equal that of a serial batch (`--workers 1`) to the last
digit in every column but the run's duration and paths. Runs go up to `tune` (no diagnose / report) to keep
the time down; three runs with different tuning settings so that rows cannot be swapped unnoticed."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml
from distributed import Client

from seatune.pipeline.batch import DONE_MARKER, SINGLE_THREAD_ENV
from tests.conftest import ROOT
from tests.test_batch import manifest, sample_run

DASK = Path(sys.executable).parent / "dask"
RUNS = {"dbi": {}, "ukf": {"backend": "ukf"}, "r44": {"parameters": ["r44", "beta44"], "holdout_every": 2}}
# columns that may differ between two batches of the same runs: duration and where the files are
NOT_COMPARED = ["seconds", "run_dir", "run_yaml", "report", "log"]


def _start(args, cwd, log):
    # own process group: the nanny and its worker process die together
    return subprocess.Popen([str(DASK), *args], cwd=cwd, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True, env=os.environ | SINGLE_THREAD_ENV)


def _kill_group(proc):
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait(timeout=30)


@pytest.fixture
def dask_cluster(tmp_path):
    """A scheduler and two one-thread workers as separate programs → (address, client, {worker address: Popen})."""
    d = tmp_path / "cluster"
    d.mkdir()
    sched_file = d / "scheduler.json"
    procs, client = [], None
    with open(d / "dask.log", "w") as log:
        try:
            procs.append(_start(["scheduler", "--port", "0", "--no-dashboard", "--scheduler-file", str(sched_file)],
                                d, log))
            deadline = time.monotonic() + 60
            while not sched_file.is_file():
                assert procs[0].poll() is None and time.monotonic() < deadline, "the scheduler did not start"
                time.sleep(0.1)
            for i in range(2):
                procs.append(_start(["worker", "--nthreads", "1", "--no-dashboard", "--name", f"w{i}",
                                     "--local-directory", str(d / f"w{i}"), "--scheduler-file", str(sched_file)],
                                    d, log))
            client = Client(scheduler_file=str(sched_file), timeout="30s")
            client.wait_for_workers(2, timeout=120)
            programs = {p.pid: p for p in procs[1:]}  # a worker process's group is its `dask worker` program
            by_address = {a: programs[os.getpgid(pid)] for a, pid in client.run(os.getpid).items()}
            yield json.loads(sched_file.read_text())["address"], client, by_address
        finally:
            if client is not None:
                client.close()
            for p in reversed(procs):
                _kill_group(p)


def _runs(folder):
    """The three runs (the sample's tuning section with RUNS' changes) and their manifest in `folder`."""
    folder.mkdir()
    tuning = yaml.safe_load((ROOT / "configs" / "runs" / "sample.yaml").read_text())["tuning"]
    names = [sample_run(folder / f"{n}.yaml", folder / n, tuning=tuning | t).name for n, t in RUNS.items()]
    return manifest(folder / "fleet.yaml", names)


def _compared(summary):
    df = pd.read_parquet(summary)
    return df.drop(columns=NOT_COMPARED).set_index("name")


@pytest.mark.slow  # 73 s on two idle cores (145 s under load): a serial batch of three runs, then the distributed one
def test_batch_on_a_dask_cluster_survives_a_killed_worker(tmp_path, dask_cluster):
    address, client, workers = dask_cluster
    serial = tmp_path / "serial"
    res = subprocess.run([sys.executable, "-m", "seatune", "batch", str(_runs(serial)), "--workers", "1",
                          "--until", "tune"], capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr

    dist = tmp_path / "dist"
    m = _runs(dist)
    with open(tmp_path / "batch.out", "w") as out:
        batch = subprocess.Popen([sys.executable, "-m", "seatune", "batch", str(m), "--scheduler", address,
                                  "--until", "tune"], stdout=out, stderr=subprocess.STDOUT)
    try:
        # the victim: a worker whose run is past ingest and windows but not finished
        deadline, victim = time.monotonic() + 300, None
        while victim is None:
            assert batch.poll() is None and time.monotonic() < deadline, "the batch ended before the kill"
            for addr, keys in client.processing().items():
                for key in keys:
                    name = str(key).split("-")[2]  # seatune-run-NAME-TOKEN
                    if (dist / name / "windows.parquet").is_file() and not (dist / name / DONE_MARKER).exists():
                        victim = addr, name
            time.sleep(0.2)
        addr, killed_run = victim
        _kill_group(workers[addr])
        assert not (dist / killed_run / DONE_MARKER).exists()  # killed mid-run
        batch.wait(timeout=300)
    finally:
        if batch.poll() is None:
            batch.kill()
            batch.wait()
    output = (tmp_path / "batch.out").read_text()
    assert batch.returncode == 0, output
    [survivor] = [a for a in workers if a != addr]
    assert workers[survivor].poll() is None and list(client.scheduler_info()["workers"]) == [survivor]

    # the killed run was redone on the surviving worker, from where its stages had got to
    survivor_pid = client.run(os.getpid)[survivor]
    log = (dist / "fleet" / "logs" / f"{killed_run}.log").read_text().splitlines()
    assert log[0].endswith(f"process {survivor_pid})") and log[1:3] == [
        "ingest: up to date (skipped)", "windows: up to date (skipped)"], log
    assert f"{killed_run}: ok (" in output
    for name in RUNS:
        assert (dist / name / DONE_MARKER).is_file() and not list((dist / name).glob(".*"))
        for p in (dist / name).glob("*.parquet"):
            pq.read_table(p)

    got = _compared(dist / "fleet" / "fleet_summary.parquet")
    want = _compared(serial / "fleet" / "fleet_summary.parquet")
    assert list(got.index) == list(RUNS) and (got["status"] == "ok").all()
    assert got.shape[1] > 15 and {"r44_tuned", "beta44_tuned", "heldout_error_tuned"} <= set(got.columns)
    assert got.loc["ukf", "backend"] == "ukf" and pd.isna(got.loc["r44", "gmt_fs_tuned"])  # rows differ
    pd.testing.assert_frame_equal(got, want, check_exact=True)
    # and the killed run's artefacts, row for row
    for artefact in ("tuning_history.parquet", "validation.parquet", "natural_frequencies.parquet"):
        pd.testing.assert_frame_equal(pd.read_parquet(dist / killed_run / artefact),
                                      pd.read_parquet(serial / killed_run / artefact), check_exact=True)


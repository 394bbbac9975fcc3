"""seatune.parallel: a stage's independent tasks on forked workers give what the serial loop gives."""

from __future__ import annotations

import multiprocessing as mp
import os
import re
import time

import numpy as np
import pytest

from seatune import parallel


@pytest.fixture
def two_workers(monkeypatch):
    monkeypatch.setenv(parallel.WORKERS_ENV, "2")


def test_tasks_run_in_other_processes_and_return_in_order(two_workers):
    big = np.arange(2_000_000, dtype=float)  # inherited by the workers, never pickled

    def task(k):
        return k, os.getpid(), float(big[k * 1000 : (k + 1) * 1000].sum())

    out = parallel.map_tasks(task, range(12))
    assert [k for k, _, _ in out] == list(range(12))
    assert [s for _, _, s in out] == [float(big[k * 1000 : (k + 1) * 1000].sum()) for k in range(12)]
    assert os.getpid() not in {pid for _, pid, _ in out}


def test_one_worker_runs_the_loop_here(monkeypatch):
    monkeypatch.setenv(parallel.WORKERS_ENV, "1")
    assert parallel.workers() == 1
    assert {pid for pid in parallel.map_tasks(lambda _: os.getpid(), range(4))} == {os.getpid()}


def test_a_failing_task_raises_its_own_error(two_workers):
    def task(k):
        if k == 3:
            raise ValueError(f"task {k} failed")
        return k

    with pytest.raises(ValueError, match="task 3 failed"):
        parallel.map_tasks(task, range(6))


def test_a_users_error_in_a_worker_reaches_the_cli_whole(two_workers):
    """A UserError raised in a worker comes back pickled; it must keep its file, place and problem (exit 2)."""
    from seatune.errors import UserError

    def task(k):
        if k == 2:
            raise UserError("hindcast.nc", "swh", "all NaN")
        return k

    with pytest.raises(UserError) as caught:
        parallel.map_tasks(task, range(4))
    assert (caught.value.source, caught.value.place, caught.value.problem) == ("hindcast.nc", "swh", "all NaN")
    assert str(caught.value) == "hindcast.nc: swh: all NaN"


def test_a_task_that_maps_again_stays_in_its_worker(two_workers):
    def inner(_):
        return os.getpid()

    def outer(_):
        return os.getpid(), set(parallel.map_tasks(inner, range(3)))

    for pid, inner_pids in parallel.map_tasks(outer, range(4)):
        assert inner_pids == {pid}


def _report_workers(queue):
    queue.put(parallel.workers())


def test_a_daemonic_process_does_not_fork(two_workers):
    """A local Dask cluster's workers are daemonic and may not have children: their stages run serially."""
    ctx = mp.get_context("fork")
    queue = ctx.Queue()
    proc = ctx.Process(target=_report_workers, args=(queue,), daemon=True)
    proc.start()
    assert queue.get(timeout=30) == 1
    proc.join(30)


@pytest.mark.slow  # two runs of the sample from the sea stage on: ~2.5 min
def test_the_stages_give_the_same_files_on_one_worker_and_on_two(finished_sample, tmp_path):
    """sea (windows × channel sets), identify (modes), diagnose (candidates) and report (figures) spread their
    tasks over workers: the sample run from the sea stage on, serial and on two workers, writes the same files."""
    import subprocess
    import sys

    import pandas as pd

    from tests.conftest import copy_of_sample

    outputs = {}
    for n in ("1", "2"):
        path = copy_of_sample(finished_sample, tmp_path / n)
        env = {**os.environ, parallel.WORKERS_ENV: n}
        res = subprocess.run([sys.executable, "-m", "seatune", "run", str(path), "--force", "sea"],
                             capture_output=True, text=True, env=env, cwd=tmp_path)
        assert res.returncode == 0, res.stdout + res.stderr
        outputs[n] = path.parent / "run"
    for name in ("sea_states.parquet", "sea_states_roll_free.parquet", "natural_frequencies.parquet",
                 "tuning_history.parquet", "diagnosis.parquet"):
        pd.testing.assert_frame_equal(pd.read_parquet(outputs["1"] / name), pd.read_parquet(outputs["2"] / name),
                                      check_exact=True, obj=name)
    pages = [re.sub(r"\b[0-9a-f]{20}\b", "", (outputs[n] / "report.html").read_text().replace(str(tmp_path / n), ""))
             for n in ("1", "2")]  # the inputs' fingerprint names their paths
    figures = [re.findall(r"data:image/png;base64,([^\"]+)", page) for page in pages]
    assert len(figures[0]) > 10 and figures[0] == figures[1]
    assert pages[0] == pages[1]


def test_the_dearest_tasks_start_first_and_results_keep_the_given_order(two_workers, tmp_path):
    def task(k):
        (tmp_path / f"{time.monotonic_ns()}_{k}").touch()
        time.sleep(0.1)  # long enough for both workers to be taking tasks
        return k * k

    assert parallel.map_tasks(task, range(8), cost=lambda k: k) == [k * k for k in range(8)]
    started = [int(p.name.split("_")[1]) for p in sorted(tmp_path.iterdir(), key=lambda p: int(p.name.split("_")[0]))]
    assert started[0] in (7, 6) and started[-1] in (0, 1)  # handed out dearest first (two workers: a pair may swap)

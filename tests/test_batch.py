"""`seatune run` and `seatune batch` end to end: real runs of the sample trial, a real local Dask cluster,
SIGKILL and resume. Runs are copies of configs/runs/sample.yaml with their run_dir in tmp; most batch runs
start from a copy of one finished run directory (their stages skip, the report is redone for the new
run_dir) to keep the time down."""

import html
import json
import random
import re
import shutil
import signal
import subprocess
import sys
import time

import pandas as pd
import psutil
import pyarrow.parquet as pq
import pytest
import xarray as xr
import yaml

from seatune.cli import stages
from seatune.errors import UserError
from seatune.io.manifest_yaml import read_manifest
from seatune.io.parquet import column_units
from seatune.io.run_yaml import Run
from seatune.pipeline.batch import DONE_MARKER, prepare
from tests.conftest import ROOT


def cli(*args):
    return subprocess.run([sys.executable, "-m", "seatune", *map(str, args)], capture_output=True, text=True)


def popen(*args):
    return subprocess.Popen([sys.executable, "-m", "seatune", *map(str, args)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def sample_run(path, run_dir, **changes):
    """A copy of configs/runs/sample.yaml at `path` (absolute input paths) writing into `run_dir`."""
    src = ROOT / "configs" / "runs" / "sample.yaml"
    data = yaml.safe_load(src.read_text())
    data["vessel"] = str((src.parent / data["vessel"]).resolve())
    for log in data["logs"]:
        log["path"] = str((src.parent / log["path"]).resolve())
    data["hindcast"]["path"] = str((src.parent / data["hindcast"]["path"]).resolve())
    data["run_dir"] = str(run_dir)
    data.update(changes)
    path.write_text(yaml.safe_dump(data))
    return path


def manifest(path, runs, out="fleet"):
    path.write_text(yaml.safe_dump({"out": out, "runs": runs}))
    return path


def numeric_summary(run_dir):
    return pd.read_parquet(run_dir / "summary.parquet").select_dtypes("number").iloc[0]


@pytest.fixture(scope="module")
def finished(finished_sample):
    """One sample run by `seatune run` (conftest.py, shared by the test processes): the reference, and the run
    directory the batch tests copy."""
    return finished_sample


def copy_of(finished, dest):
    shutil.copytree(finished[0], dest)
    return dest


# ------------------------------------------------------------------------------------------------ seatune run


def test_run_prints_one_line_per_stage_and_then_skips_every_stage(finished):
    run_dir, path, first, first_err, _ = finished
    lines = first.strip().splitlines()
    for stage in stages.ORDER:
        assert sum(line.startswith(f"{stage}:") for line in lines) == 1, (stage, first)
    assert first_err == ""  # no progress bar when stderr is not a terminal

    res = cli("run", path)
    assert res.returncode == 0, res.stderr
    out = res.stdout.strip().splitlines()
    for stage in stages.ORDER:
        assert any(line.startswith(f"{stage}: up to date (skipped)") for line in out), (stage, res.stdout)
    assert (run_dir / "report.html").is_file()
    assert out[-1] == f"report at {run_dir / 'report.html'}"


def test_run_rejects_an_unknown_stage(finished):
    res = cli("run", finished[1], "--force", "tunes")
    assert res.returncode == 2
    assert "'tunes' is not a stage" in res.stderr


# ------------------------------------------------------------------------------------------------ seatune batch


def test_batch_with_a_broken_run_finishes_the_others_and_lists_its_error(tmp_path, finished):
    runs = tmp_path / "runs"
    good = [sample_run(tmp_path / f"{n}.yaml", copy_of(finished, runs / n)) for n in ("day1", "day2")]
    bad = sample_run(tmp_path / "day3.yaml", runs / "day3", logs=[{"path": str(tmp_path / "lost.mcap")}])
    m = manifest(tmp_path / "fleet.yaml", [p.name for p in (*good, bad)])

    res = cli("batch", m, "--workers", "2")
    assert res.returncode == 2, res.stderr
    assert res.stderr.strip().splitlines() == [
        f"seatune: error: 1 of 3 runs failed (day3): see {tmp_path / 'fleet' / 'index.html'}"]
    assert f"day3: failed: {bad}: logs.0.path: no file matches {tmp_path / 'lost.mcap'}" in res.stdout

    fleet = tmp_path / "fleet"
    df = pd.read_parquet(fleet / "fleet_summary.parquet")
    assert list(df["name"]) == ["day1", "day2", "day3"]
    assert list(df["status"]) == ["ok", "ok", "failed"]
    assert df["error"].iloc[:2].isna().all()
    assert df["error"].iloc[2] == f"{bad}: logs.0.path: no file matches {tmp_path / 'lost.mcap'}"
    assert df["error_type"].iloc[2] == "user"
    assert (df["seconds"] > 0).all()
    units = column_units(fleet / "fleet_summary.parquet")
    assert units["seconds"] == "s" and units["omega_n_roll"] == "rad/s"
    ref = numeric_summary(finished[0])
    for i in (0, 1):  # key figures of the good runs: those of the run they were copied from
        row = df.iloc[i]
        assert row["run_dir"] == str(runs / row["name"])
        pd.testing.assert_series_equal(row[ref.index].astype(float), ref.astype(float), check_names=False)
    assert df.iloc[2][ref.index].isna().all()

    page = (fleet / "index.html").read_text()
    links = re.findall(r'href="([^"]+)"', page)
    for name in ("day1", "day2"):
        href = f"../runs/{name}/report.html"
        assert href in links and (fleet / href).resolve() == (runs / name / "report.html").resolve()
    assert "../runs/day3/report.html" not in links
    assert html.escape(df["error"].iloc[2]) in page
    for name in ("day1", "day2", "day3"):
        assert f"logs/{name}.log" in links and (fleet / "logs" / f"{name}.log").is_file()
    assert (runs / "day1" / DONE_MARKER).is_file() and not (runs / "day3").exists()


def test_killed_batch_resumes_to_the_summary_of_an_uninterrupted_run(tmp_path, finished):
    # killed batch: run0 starts from a finished copy (done in seconds), run1 from a copy without its diagnosis and
    # report (half a minute of work: the kill lands mid-way at a third of a whole run's cost)
    a = tmp_path / "A"
    a.mkdir()
    copy_of(finished, a / "run0")
    run1 = copy_of(finished, a / "run1")
    for name in ("diagnosis.parquet", "diagnosis_residuals.parquet", "report.html", "summary.parquet"):
        (run1 / name).unlink()
    names = [sample_run(a / f"run{i}.yaml", a / f"run{i}").name for i in range(2)]
    m = manifest(a / "fleet.yaml", names)
    proc = subprocess.Popen([sys.executable, "-m", "seatune", "batch", str(m), "--workers", "2"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 180
    while not (a / "run0" / DONE_MARKER).exists():
        assert proc.poll() is None and time.monotonic() < deadline, "the batch ended before the kill"
        time.sleep(0.1)
    workers = psutil.Process(proc.pid).children(recursive=True)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    _, alive = psutil.wait_procs(workers, timeout=20)
    assert not alive, "worker processes outlived the killed batch"
    done_before = {n for n in ("run0", "run1") if (a / n / DONE_MARKER).exists()}
    assert done_before == {"run0"}  # killed mid-way
    stamps = {p.name: p.stat().st_mtime_ns for p in (a / "run0").iterdir()}

    res = cli("batch", m, "--workers", "2")
    assert res.returncode == 0, res.stderr
    resumed = pd.read_parquet(a / "fleet" / "fleet_summary.parquet")
    assert list(resumed["status"]) == ["skipped", "ok"]
    assert {p.name: p.stat().st_mtime_ns for p in (a / "run0").iterdir()} == stamps  # not touched
    assert "skipped" in (a / "fleet" / "logs" / "run0.log").read_text()
    assert not list(a.glob("run*/.*.tmp"))

    # every summary column of both runs (figures, vessel, backend, version): those of the uninterrupted run they were
    # copied from
    ref = pd.read_parquet(finished[0] / "summary.parquet").iloc[0]
    assert len(ref) > 10
    for i in (0, 1):
        pd.testing.assert_series_equal(resumed.iloc[i][ref.index], ref, check_names=False, check_dtype=False)


def test_manifest_errors_exit_2_with_one_line(tmp_path):
    m = tmp_path / "fleet.yaml"
    m.write_text("out: fleet\nruns: [missing/*.yaml]\n")
    res = cli("batch", m)
    assert res.returncode == 2
    assert res.stderr.strip().splitlines() == [f"seatune: error: {m}: runs.0: no run YAML matches "
                                               f"{tmp_path / 'missing/*.yaml'}"]


@pytest.mark.parametrize("data, place, problem", [
    ({"runs": ["a.yaml"]}, "out", "required key is missing (or give --out DIR)"),
    ({"out": "f", "runs": ["a.yaml"], "workers": 2}, "workers", "unknown key"),
    ({"out": "f", "runs": []}, "runs", "no run listed"),
    ({"out": "f", "runs": ["a.yaml", {"path": "b.yaml", "name": "a"}]}, "runs.1", "run name 'a' is used twice"),
    ({"out": "f", "runs": [{"path": "a.yaml", "name": "day 1"}]}, "runs.0.name", "letters, digits"),
    ({"out": "f", "overrides": [{"name": "x"}]}, "template", "overrides need a template"),
    ({"out": "f", "template": "a.yaml", "overrides": [{"name": "x", "lgos": []}]}, "overrides.0.lgos",
     "unknown key"),
    ({"out": "f", "template": "a.yaml", "overrides": [{"run_dir": "x"}]}, "overrides.0.name",
     "required key is missing"),
])
def test_manifest_validation(tmp_path, data, place, problem):
    sample_run(tmp_path / "a.yaml", tmp_path / "a")
    sample_run(tmp_path / "b.yaml", tmp_path / "b")
    m = tmp_path / "fleet.yaml"
    m.write_text(yaml.safe_dump(data))
    with pytest.raises(UserError) as err:
        read_manifest(m)
    assert str(err.value).startswith(f"{m}: {place}: ") and problem in str(err.value), str(err.value)


def test_two_runs_in_one_run_dir_are_refused(tmp_path):
    (tmp_path / "runs").mkdir()
    for name in ("a", "b"):
        sample_run(tmp_path / "runs" / f"{name}.yaml", tmp_path / "same")
    m = manifest(tmp_path / "fleet.yaml", ["runs/*.yaml"])
    with pytest.raises(UserError, match=r"runs\.0: run 'b' has the same run_dir as 'a'"):
        prepare(read_manifest(m))


def test_template_and_overrides_make_valid_run_yamls(tmp_path):
    template = sample_run(tmp_path / "base.yaml", "unused")
    (tmp_path / "logs").mkdir()
    (tmp_path / "logs" / "day2.mcap").touch()  # only its path matters here
    m = tmp_path / "fleet.yaml"
    m.write_text(yaml.safe_dump({
        "out": "fleet", "runs": ["base.yaml"], "template": "base.yaml",
        "overrides": [{"name": "day2", "logs": [{"path": "logs/day2.mcap"}], "tuning": {"backend": "ukf"}},
                      {"name": "day3", "run_dir": "elsewhere/day3"}]}))
    man = read_manifest(m, out=tmp_path / "out")
    runs = prepare(man)
    assert [r.name for r in runs] == ["base", "day2", "day3"]
    day2, day3 = Run(runs[1].run_yaml), Run(runs[2].run_yaml)
    assert runs[1].run_yaml == tmp_path / "out" / "runs" / "day2.yaml"
    assert day2.run_dir == tmp_path / "out" / "day2" and day3.run_dir == tmp_path / "elsewhere" / "day3"
    assert [p for p, _ in day2.logs] == [tmp_path / "logs" / "day2.mcap"]
    assert day2.spec.tuning.backend == "ukf"
    assert day2.spec.tuning.parameters == Run(template).spec.tuning.parameters  # merged, not replaced
    assert len(day3.logs) == 2 and day3.spec.tuning.backend == "dbi"  # the template's


# ------------------------------------------------------------------------------------------------ kill safety


def readable(path):
    """Every artefact opens completely (a half-written file would not)."""
    if path.suffix == ".parquet":
        pq.read_table(path)
    elif path.suffix == ".nc":
        with xr.open_dataset(path) as ds:
            ds.load()
    elif path.suffix in (".yaml", ".yml"):
        assert isinstance(yaml.safe_load(path.read_text()), dict)
    elif path.suffix == ".json":
        json.loads(path.read_text())
    elif path.suffix == ".html":
        assert path.read_text().rstrip().endswith("</html>")
    else:
        pytest.fail(f"unexpected file in the run directory: {path.name}")


@pytest.mark.slow  # a soak of many kills (~3 min) for `make test-slow`; kill-and-resume stays in `make test`
def test_sigkill_at_random_moments_never_leaves_a_corrupt_artefact(tmp_path, finished):
    path = sample_run(tmp_path / "run.yaml", tmp_path / "run")
    run_dir = tmp_path / "run"
    rng = random.Random(20240607)
    killed = 0
    for i in range(6):  # after the first, each attempt redoes a random stage onwards: kills land in real work
        proc = popen("run", path, *(("--force", rng.choice(stages.ORDER)) if i else ()))
        try:
            proc.wait(timeout=rng.uniform(0.1, 0.9) * finished[4])  # a moment within a whole run's time
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            killed += 1
        if run_dir.exists():
            for p in run_dir.iterdir():
                if not (p.name.startswith(".") and p.name.endswith(".tmp")):  # a cut-off temporary: next run removes it
                    readable(p)
    assert killed >= 2
    (run_dir / ".motions.parquet.x1y2z3.tmp").write_bytes(b"PAR1 cut off")  # a stale temporary, for certain
    res = cli("run", path)
    assert res.returncode == 0, res.stderr
    assert not list(run_dir.glob(".*.tmp"))
    for p in run_dir.iterdir():
        readable(p)
    ref = numeric_summary(finished[0])
    pd.testing.assert_series_equal(numeric_summary(run_dir), ref)

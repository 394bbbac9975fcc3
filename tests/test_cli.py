"""End-to-end CLI: `seatune vessel info | rao`, and one clear line + exit 2 for a bad vessel YAML."""

import json
import subprocess
import sys

import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml

from tests.conftest import SAMPLE_VESSEL


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "seatune", *map(str, args)], capture_output=True, text=True)


def sample_yaml():
    data = yaml.safe_load(SAMPLE_VESSEL.read_text())
    data["hydro_database"] = str(SAMPLE_VESSEL.parent / data["hydro_database"])
    return data


def write(tmp_path, data, name="vessel.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def test_vessel_info_json():
    res = run_cli("vessel", "info", SAMPLE_VESSEL, "--json")
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    assert info["database_drafts_m"] == [5.0, 5.5, 6.0, 6.5, 7.0]
    assert 5.0 < info["draft_m"] < 7.0
    assert 8 < info["natural_period_roll_s"] < 14
    assert info["mass_kg"] == pytest.approx(9.9e6)


def test_vessel_info_table():
    res = run_cli("vessel", "info", SAMPLE_VESSEL)
    assert res.returncode == 0, res.stderr
    assert "natural period roll" in res.stdout and "GMT" in res.stdout


def test_vessel_rao_parquet(tmp_path):
    out = tmp_path / "rao.parquet"
    res = run_cli("vessel", "rao", SAMPLE_VESSEL, "--set", "zcg=7.0", "--set", "gmt_fs=0.4", "--out", out)
    assert res.returncode == 0, res.stderr
    df = pd.read_parquet(out)
    assert {"omega", "wave_direction", "response", "re", "im", "amplitude", "phase"} <= set(df.columns)
    units = {f.name: f.metadata[b"unit"].decode() for f in pq.read_schema(out)}
    assert units["omega"] == "rad/s" and units["phase"] == "rad"
    heave = df[(df.response == "Heave")]
    assert heave.amplitude.max() < 2.0
    assert set(df.response) >= {"Surge", "Roll", "roll", "crane_tip_vz"}


def test_rao_set_changes_roll(tmp_path):
    a, b = tmp_path / "a.parquet", tmp_path / "b.parquet"
    assert run_cli("vessel", "rao", SAMPLE_VESSEL, "--dofs-only", "--out", a).returncode == 0
    assert run_cli("vessel", "rao", SAMPLE_VESSEL, "--dofs-only", "--set", "gmt_fs=0.6", "--out", b).returncode == 0
    ra, rb = pd.read_parquet(a), pd.read_parquet(b)
    roll_peak = lambda df: df[df.response == "Roll"].groupby("omega").amplitude.max().idxmax()  # noqa: E731
    assert roll_peak(rb) < roll_peak(ra)  # less GM → lower roll natural frequency


@pytest.mark.parametrize(
    "mutate, key",
    [
        (lambda d: d["loading"].update(foo=1.0), "loading.foo"),
        (lambda d: d["loading"].update(mass=-5.0), "loading.mass"),
        (lambda d: d.update(hull={"mesh": {"file": "no_such_hull.stl", "draft": 6.0}}), "hull.mesh.file"),
        (lambda d: d.update(drafts=[6.0]), "priors.mass"),
        (lambda d: d["channels"].append({"name": "x", "kind": "velocity", "axis": "z"}), "channels.18"),
        (lambda d: d.update(colour="blue"), "colour"),
    ],
)
def test_bad_vessel_yaml_exits_2_with_one_line(tmp_path, mutate, key):
    data = sample_yaml()
    mutate(data)
    path = write(tmp_path, data)
    res = run_cli("vessel", "info", path)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert str(path) in lines[0] and key in lines[0]


def test_unbuilt_database_says_how_to_build(tmp_path):
    data = sample_yaml()
    data["hydro_database"] = "not_built.nc"
    path = write(tmp_path, data)
    res = run_cli("vessel", "info", path)
    assert res.returncode == 2
    assert "seatune vessel build" in res.stderr


def test_set_unknown_parameter(tmp_path):
    res = run_cli("vessel", "rao", SAMPLE_VESSEL, "--set", "kg=7", "--out", tmp_path / "x.parquet")
    assert res.returncode == 2 and "--set kg" in res.stderr
    assert not (tmp_path / "x.parquet").exists()


def test_ctrl_c_exits_130_with_one_line(tmp_path):
    """SIGINT during a stage: exit 130 (128 + SIGINT), one line, no traceback, no half-written artefact."""
    import signal
    import time

    from tests.conftest import ROOT

    run = yaml.safe_load((ROOT / "configs/runs/sample.yaml").read_text())
    base = ROOT / "configs/runs"
    run["run_dir"] = str(tmp_path / "run")
    run["vessel"] = str((base / run["vessel"]).resolve())
    run["hindcast"]["path"] = str((base / run["hindcast"]["path"]).resolve())
    for log in run["logs"]:
        log["path"] = str((base / log["path"]).resolve())
    (tmp_path / "run.yaml").write_text(yaml.safe_dump(run))
    def as_from_a_shell():  # SIGINT neither ignored nor blocked, whatever this test worker passes on to a child
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})

    proc = subprocess.Popen([sys.executable, "-m", "seatune", "run", str(tmp_path / "run.yaml")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=as_from_a_shell)
    deadline = time.monotonic() + 60
    while not (tmp_path / "run").exists() and time.monotonic() < deadline:  # inside the ingest stage
        time.sleep(0.05)
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, (out, err)
    assert err.strip() == "seatune: interrupted"
    assert not [p for p in (tmp_path / "run").rglob("*") if p.suffix == ".tmp" or ".tmp" in p.name]

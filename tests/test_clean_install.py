"""`pip install .` (no extras, not editable) into a fresh venv runs the README's main job (`make run`): `seatune
vessel info` on the sample vessel and `seatune run` on the sample trial, with the run directory in tmp.

The package is built from a copy of what `pip install .` reads (pyproject.toml, README.md, seatune/): pip builds
in the source tree (build/, *.egg-info), which would otherwise write into the checkout. pip's own cache and
configuration (index, find-links) are the machine's, so installing needs no network when they have the wheels."""

import json
import os
import shutil
import subprocess
import sys

import pandas as pd
import pytest
import yaml

from tests.conftest import ROOT, SAMPLE_VESSEL

# in the `test` extra (or the dev venv) only: a clean install must not have them
TEST_ONLY = ("pytest", "hypothesis", "pint", "playwright", "filterpy")


def _clean_env():
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    return env | {"PYTHONNOUSERSITE": "1"}


@pytest.mark.slow  # ~2 min on two idle cores (~65 s to install, ~45 s for the sample run), 3 min under load
def test_pip_install_without_extras_runs_the_sample(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    shutil.copytree(ROOT / "seatune", src / "seatune", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    venv, env = tmp_path / "venv", _clean_env()

    def run(*args, cwd=tmp_path):
        return subprocess.run([str(a) for a in args], cwd=cwd, env=env, capture_output=True, text=True, timeout=1200)

    res = run(sys.executable, "-m", "venv", venv)
    assert res.returncode == 0, res.stderr
    py, seatune = venv / "bin" / "python", venv / "bin" / "seatune"
    res = run(py, "-m", "pip", "install", "--quiet", ".", cwd=src)
    assert res.returncode == 0, res.stderr[-3000:]

    # the installed package (not the checkout) is the one that runs, and no test-only package came with it
    res = run(py, "-c", "import importlib.util as u, json, seatune; print(json.dumps([seatune.__file__, "
              f"[n for n in {TEST_ONLY!r} if u.find_spec(n)]]))")
    assert res.returncode == 0, res.stderr
    where, test_only = json.loads(res.stdout)
    assert where.startswith(str(venv / "lib")) and test_only == []

    res = run(seatune, "vessel", "info", SAMPLE_VESSEL)
    assert res.returncode == 0 and "Sample OSV" in res.stdout, res.stderr
    installed = json.loads(run(seatune, "vessel", "info", SAMPLE_VESSEL, "--json").stdout)
    checkout = json.loads(subprocess.run([sys.executable, "-m", "seatune", "vessel", "info", str(SAMPLE_VESSEL),
                                          "--json"], capture_output=True, text=True, cwd=ROOT, timeout=300).stdout)
    assert installed.keys() == checkout.keys() and len(installed) > 15
    for key, value in checkout.items():
        assert installed[key] == (pytest.approx(value, rel=1e-12) if isinstance(value, float) else value), key

    sample = ROOT / "configs" / "runs" / "sample.yaml"
    data = yaml.safe_load(sample.read_text())
    data["vessel"] = str((sample.parent / data["vessel"]).resolve())
    for log in data["logs"]:
        log["path"] = str((sample.parent / log["path"]).resolve())
    data["hindcast"]["path"] = str((sample.parent / data["hindcast"]["path"]).resolve())
    data["run_dir"] = str(tmp_path / "run")
    (tmp_path / "sample.yaml").write_text(yaml.safe_dump(data))
    res = run(seatune, "run", tmp_path / "sample.yaml")
    assert res.returncode == 0, res.stderr[-3000:]
    report = tmp_path / "run" / "report.html"
    assert res.stdout.strip().splitlines()[-1] == f"report at {report}"
    assert report.read_text(encoding="utf-8").rstrip().endswith("</html>")
    summary = pd.read_parquet(tmp_path / "run" / "summary.parquet").iloc[0]
    # train_windows counts tuning updates (README): identify's natural frequencies, then the 2 training windows
    assert summary["windows_accepted"] == 3 and summary["train_windows"] == 3 and summary["backend"] == "dbi"

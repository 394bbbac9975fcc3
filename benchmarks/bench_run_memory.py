"""Peak memory of `seatune run` against the length of the log: a 6 h trial, and a week logged as seven 24 h MCAP
files and seven GNSS CSVs (globs of split files) with one hindcast. Same vessel, sea and settings; each day ends
with a 2 h stretch slow enough for the windows stage (`windows.max_sog` 0.05 m/s), so both runs have windows to
tune on while the week's log is 28× longer. Reference: the 6 h run, in the same benchmark; ratio = peak(week) /
peak(6 h) (flat memory: ≤ 1.5). Each run is a fresh process whose own max RSS is read with os.wait4.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]
START = pd.Timestamp("2026-03-14T06:00:00Z")


def scenario(folder: Path, day: int, hours: float) -> Path:
    """The sample scenario drifting `hours` h from day `day`: at 0.1 m/s, then 2 h at 0.02 m/s (the windows)."""
    data = yaml.safe_load((ROOT / "configs/scenarios/sample_trial.yaml").read_text())
    data.update(name=f"day{day}", vessel=str(ROOT / "configs/vessels/sample_osv.yaml"), seed=20261200 + day,
                start_time=(START + pd.Timedelta(days=day)).isoformat())
    drift = dict(kind="drift", heading_deg=40.0, heading_rate_deg_per_h=2.0, course_deg=90.0)
    data["segments"] = [dict(drift, duration=3600.0 * (hours - 2), speed=0.1),
                        dict(drift, duration=7200.0, speed=0.02)]
    step = hours / len(data["sea_states"])
    data["sea_states"] = [dict(s, hour=float(step * i)) for i, s in enumerate(data["sea_states"])]
    data["sensors"]["gnss"]["velocity_std"] = 0.01  # so 0.02 m/s reads slow and 0.1 m/s does not
    data["outputs"].pop("mcap_zstd_level", None)
    path = folder / f"day{day}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def run_yaml(folder: Path, hindcast: Path) -> Path:
    data = yaml.safe_load((ROOT / "configs/runs/sample.yaml").read_text())
    data.update(run_dir=str(folder / "run"), vessel=str(ROOT / "configs/vessels/sample_osv.yaml"))
    data["logs"][0]["path"] = str(folder / "d*" / "*.mcap")
    data["logs"][1]["path"] = str(folder / "d*" / "*_gnss.csv")
    data["hindcast"]["path"] = str(hindcast)
    data["windows"]["max_sog"] = 0.05
    path = folder / "run.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def measured(args: list[str]) -> tuple[float, float]:
    """(seconds, max RSS [MB]) of one command in its own process."""
    t = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "seatune", *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                         cwd=ROOT)
    _, status, usage = os.wait4(p.pid, 0)
    seconds = time.perf_counter() - t
    if status != 0:
        raise RuntimeError(f"seatune {' '.join(args)} failed: {p.stderr.read().decode()[-2000:]}")
    return seconds, usage.ru_maxrss / 1024


def trial(folder: Path, days: int, hours: float) -> dict:
    import xarray as xr

    for d in range(days):
        subprocess.run([sys.executable, "-m", "seatune", "simulate", str(scenario(folder, d, hours)), "--out",
                        str(folder / f"d{d}")], capture_output=True, text=True, check=True, cwd=ROOT)
    parts = [xr.open_dataset(folder / f"d{d}" / f"day{d}_era5.nc") for d in range(days)]
    time_dim = next(k for k in parts[0].dims if "time" in k)
    merged = xr.concat(parts, dim=time_dim)
    merged = merged.isel({time_dim: ~merged.get_index(time_dim).duplicated()})
    merged.to_netcdf(folder / "era5.nc")
    for p in parts:
        p.close()
    seconds, peak = measured(["run", str(run_yaml(folder, folder / "era5.nc"))])
    windows = pd.read_parquet(folder / "run" / "windows.parquet")
    return {"hours": days * hours, "seconds": seconds, "peak_mb": peak, "windows": int(windows["accepted"].sum())}


def run() -> dict:
    with tempfile.TemporaryDirectory() as a, tempfile.TemporaryDirectory() as b:
        short = trial(Path(a), 1, 6.0)
        week = trial(Path(b), 7, 24.0)
    return {
        "name": "run_memory_6h_vs_7x24h",
        "reference_s": round(short["seconds"], 1),
        "seatune_s": round(week["seconds"], 1),
        "ratio": round(week["peak_mb"] / short["peak_mb"], 2),
        "max_rel_diff": 0.0,
        "peak_mb_6h": round(short["peak_mb"]),
        "peak_mb_7x24h": round(week["peak_mb"]),
        "mb_per_logged_hour": round((week["peak_mb"] - short["peak_mb"]) / (week["hours"] - short["hours"]), 2),
        "s_per_logged_hour": round(week["seconds"] / week["hours"], 2),
        "accepted_windows": [short["windows"], week["windows"]],
        "reference": "the same seatune run on a 6 h log (ratio = peak memory of the week / of the 6 h)",
    }

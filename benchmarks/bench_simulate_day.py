"""`seatune simulate` of a 24 h, 10 Hz day, and its MCAP writer against the message-by-message one.

The day is the sample scenario with one 24 h drift (its hourly sea states spread over the day), written with the
library's default zstd level. Reference: the same IMU messages built as typestore objects and serialised one by
one (`_serialize_each`, the writer before the fixed-layout encoder), in the same process on the same trial; the
two files must be byte-identical. The whole CLI run is timed in a fresh process, so its peak memory (max RSS) is
its own.
"""

from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from benchmarks.timing import best_of

ROOT = Path(__file__).resolve().parents[1]

def day_scenario(folder: Path) -> Path:
    data = yaml.safe_load((ROOT / "configs/scenarios/sample_trial.yaml").read_text())
    data["vessel"] = str(ROOT / "configs/vessels/sample_osv.yaml")
    data["segments"] = [dict(kind="drift", duration=86400.0, heading_deg=40.0, heading_rate_deg_per_h=2.0,
                             speed=0.1, course_deg=90.0)]
    data["sea_states"] = [dict(s, hour=float(4 * i)) for i, s in enumerate(data["sea_states"])]
    data["outputs"].pop("mcap_zstd_level", None)  # the library default, not the committed sample's 19
    path = folder / "day.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def day_run_yaml(day: Path, run_dir: Path) -> dict:
    """The sample's run YAML pointed at a simulated day's files (`day`: `seatune simulate`'s output folder)."""
    run_yaml = yaml.safe_load((ROOT / "configs/runs/sample.yaml").read_text())
    run_yaml.update(run_dir=str(run_dir), vessel=str(ROOT / "configs/vessels/sample_osv.yaml"))
    run_yaml["logs"][0]["path"] = str(next(day.glob("*.mcap")))
    run_yaml["logs"][1]["path"] = str(next(day.glob("*_gnss.csv")))
    run_yaml["hindcast"]["path"] = str(next(day.glob("*_era5.nc")))
    return run_yaml


def run() -> dict:
    from seatune.pipeline.vessel import open_vessel
    from seatune.simulate import log_writers as lw
    from seatune.simulate.scenario import ros_streams, simulate
    from seatune.simulate.scenario_yaml import load_scenario

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        scenario = day_scenario(tmp)
        t = time.perf_counter()  # the CLI first: RUSAGE_CHILDREN's max RSS is then its own
        subprocess.run([sys.executable, "-m", "seatune", "simulate", str(scenario), "--out", str(tmp / "out")],
                       capture_output=True, text=True, check=True, cwd=ROOT)
        full = {"seconds": time.perf_counter() - t,
                "max_rss_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}

        spec, vessel = load_scenario(scenario)
        trial = simulate(spec, open_vessel(vessel))
        streams = ros_streams(spec, trial, spec.outputs.mcap)
        messages = sum(len(s.table) for s in streams)
        def write(name):
            return lambda: lw.write_mcap(tmp / name, streams, message_index=spec.outputs.mcap_message_index)

        seatune_s, _ = best_of(write("fast.mcap"), 1)
        of = lw._ImuRows.of
        lw._ImuRows.of = classmethod(lambda cls, *a: None)  # the message-by-message path
        try:
            reference_s, _ = best_of(write("reference.mcap"), 1)
        finally:
            lw._ImuRows.of = of
        identical = (tmp / "fast.mcap").read_bytes() == (tmp / "reference.mcap").read_bytes()
    return {
        "name": "simulate_24h_10hz_mcap_writer",
        "reference_s": round(reference_s, 2),
        "seatune_s": round(seatune_s, 2),
        "ratio": round(reference_s / seatune_s, 2),
        "messages": messages,
        "byte_identical": identical,
        "cli_24h_s": round(full["seconds"], 1),
        "cli_24h_max_rss_mb": round(full["max_rss_mb"]),
        "reference": "typestore message objects serialised one by one (rosbags serialize_cdr)",
    }

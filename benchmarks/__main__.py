"""`make bench`: one JSON line per benchmark (name, reference_s, seatune_s, ratio, max_rel_diff, ...)."""

import json
import sys

from benchmarks import (
    bench_batch,
    bench_channel_sigma,
    bench_day_run,
    bench_dbi,
    bench_diagnose,
    bench_filter,
    bench_ingest,
    bench_modes,
    bench_predict,
    bench_run_memory,
    bench_sea,
    bench_simulate_day,
    bench_synthesis,
    bench_ukf,
)

BENCHMARKS = {"channel_sigma": bench_channel_sigma.run, "synthesis": bench_synthesis.run, "filter": bench_filter.run,
              "ingest": bench_ingest.run, "ukf": bench_ukf.run, "dbi": bench_dbi.run, "batch": bench_batch.run,
              "predict": bench_predict.run, "diagnose": bench_diagnose.run,
              "diagnose_stage": bench_diagnose.stage_with_calibration,
              "modes": bench_modes.run, "sea": bench_sea.run,
              "simulate_day": bench_simulate_day.run, "day_run": bench_day_run.run, "run_memory": bench_run_memory.run}

if __name__ == "__main__":
    names = sys.argv[1:] or list(BENCHMARKS)
    for name in names:
        print(json.dumps(BENCHMARKS[name]()), flush=True)

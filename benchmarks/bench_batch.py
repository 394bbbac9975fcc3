"""`seatune batch`: 8 copies of the sample run on a local Dask cluster of 2 workers against the same 8 runs one
after the other in one process.

Reference (serial): a fresh Python process that runs the 8 runs' whole pipelines in turn
(:func:`seatune.pipeline.batch.run_serial`, numba / BLAS on their default threads). seatune: the CLI,
`seatune batch MANIFEST --workers 2` (a LocalCluster of 2 worker processes, one thread each, numba / BLAS /
OpenMP pinned to one thread per worker). Both are timed from process start to exit (what a user waits for:
interpreter, imports, cluster start, fleet summary included). The same batch without the thread pinning is
timed too. Every run starts from an empty run directory; the key figures of every run (its summary.parquet)
are compared with the serial ones. The ratio is only meaningful on an otherwise idle machine (other load
steals the second core from the batch, not from the serial run).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]
N_RUNS = 8
WORKERS = 2


def _runs(folder: Path, tag: str, n: int):
    """n copies of configs/runs/sample.yaml with absolute paths and their run_dir in `folder`."""
    from seatune.io.manifest_yaml import BatchRun

    src = ROOT / "configs/runs/sample.yaml"
    data = yaml.safe_load(src.read_text())
    data["vessel"] = str((src.parent / data["vessel"]).resolve())
    for log in data["logs"]:
        log["path"] = str((src.parent / log["path"]).resolve())
    data["hindcast"]["path"] = str((src.parent / data["hindcast"]["path"]).resolve())
    runs = []
    for i in range(n):
        path = folder / f"{tag}{i}.yaml"
        path.write_text(yaml.safe_dump({**data, "run_dir": str(folder / "runs" / f"{tag}{i}")}))
        runs.append(BatchRun(f"{tag}{i}", path, f"runs.{i}"))
    return runs


SERIAL = """
import sys
from pathlib import Path
from seatune.io.manifest_yaml import read_manifest
from seatune.pipeline.batch import prepare, run_serial
m = read_manifest(sys.argv[1])
recs = run_serial(prepare(m), m.out)
assert all(r["status"] == "ok" for r in recs), recs
"""

UNPINNED = """
import sys
from seatune.io.manifest_yaml import read_manifest
from seatune.pipeline.batch import dask_client, prepare, run_batch
m = read_manifest(sys.argv[1])
with dask_client(2, one_thread=False) as client:
    recs = run_batch(prepare(m), m.out, client, one_thread=False)
assert all(r["status"] == "ok" for r in recs), recs
"""


def _manifest(folder: Path, tag: str) -> Path:
    runs = _runs(folder, tag, N_RUNS)
    path = folder / f"{tag}_manifest.yaml"
    path.write_text(yaml.safe_dump({"out": str(folder / f"{tag}_fleet"), "runs": [str(r.run_yaml) for r in runs]}))
    return path


def _timed(args) -> float:
    start = time.perf_counter()
    res = subprocess.run(args, capture_output=True, text=True, cwd=ROOT)
    seconds = time.perf_counter() - start
    assert res.returncode == 0, res.stderr[-3000:]
    return seconds


def _figures(folder: Path, tag: str) -> np.ndarray:
    rows = [pd.read_parquet(folder / "runs" / f"{tag}{i}" / "summary.parquet").select_dtypes("number").iloc[0]
            for i in range(N_RUNS)]
    return np.array([r.to_numpy(dtype=float) for r in rows])


def run() -> dict:
    tmp = Path(tempfile.mkdtemp(prefix="seatune-bench-batch-"))
    try:
        py = sys.executable
        reference_s = _timed([py, "-c", SERIAL, str(_manifest(tmp, "serial"))])
        seatune_s = _timed([py, "-m", "seatune", "batch", str(_manifest(tmp, "pinned")), "--workers", str(WORKERS)])
        unpinned_s = _timed([py, "-c", UNPINNED, str(_manifest(tmp, "unpinned"))])
        a = _figures(tmp, "serial")
        b = np.vstack([_figures(tmp, "pinned"), _figures(tmp, "unpinned")])
        both = np.isfinite(a).all(axis=0)
        diff = np.abs(b[:, both] - np.vstack([a, a])[:, both]) / np.maximum(np.abs(np.vstack([a, a])[:, both]), 1e-300)
        return {
            "name": f"batch_{N_RUNS}x_sample_{WORKERS}_workers",
            "reference_s": round(reference_s, 2),
            "seatune_s": round(seatune_s, 2),
            "ratio": round(reference_s / seatune_s, 2),
            "max_rel_diff": float(diff.max()),
            "unpinned_threads_s": round(unpinned_s, 2),
            "ratio_unpinned_threads": round(reference_s / unpinned_s, 2),
            "cpus": len(os.sched_getaffinity(0)),
            "reference": f"the same {N_RUNS} runs one after the other in one fresh process; both timed from process "
                         "start to exit",
        }
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    import json

    print(json.dumps(run()))

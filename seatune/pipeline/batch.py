"""Fleet batches (`seatune batch`): many runs as Dask tasks, each the whole pipeline in a worker process.

A run that finished is skipped by hash: after success its run directory gets `batch_done.json` (written
atomically) with a hash of the run's settings, the content of its inputs (logs, hindcast, vessel YAML and
the files that YAML names), the seatune version and the stage list, and the size and mtime of every artefact.
A batch killed at any point therefore resumes where it was: finished runs are skipped, a run cut short
restarts and its stages skip what is already fresh. One failing run never stops the others; its error line
goes into the fleet summary (`fleet_summary.parquet`) and `index.html`.
"""

from __future__ import annotations

import contextlib
import fnmatch
import hashlib
import html
import json
import logging
import math
import os
import time
import traceback
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

import seatune
from seatune.atomic import atomic_path, remove_stale_temps
from seatune.errors import UserError
from seatune.io.manifest_yaml import BatchRun, Manifest

DONE_MARKER = "batch_done.json"
SUMMARY_FILE = "fleet_summary.parquet"
INDEX_FILE = "index.html"
# variables that make numerical libraries use one thread: each worker process runs one run on one core
SINGLE_THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
                     "NUMBA_NUM_THREADS": "1"}
BASE_UNITS = {"name": "", "status": "", "error": "", "error_type": "", "seconds": "s", "run_dir": "",
              "run_yaml": "", "report": "", "log": ""}
# units of the loading parameters as tuning_history.parquet holds them (vessel-YAML units)
LOADING_UNITS = {"mass": "kg", "displacement": "m^3", "xcg": "m", "ycg": "m", "zcg": "m", "r44": "m", "r55": "m",
                 "r66": "m", "gmt_fs": "m", "gml_fs": "m", "beta33": "dimensionless",
                 "beta44": "dimensionless", "beta55": "dimensionless"}


# ---------------------------------------------------------------------------------------------------------
# planning (driver)


def prepare(manifest: Manifest) -> list[BatchRun]:
    """Write the template runs' YAMLs (only when their content changed), check that no two runs share a run
    directory, make the fleet folders. Returns the runs with their YAML on disk."""
    manifest.out.mkdir(parents=True, exist_ok=True)
    (manifest.out / "logs").mkdir(exist_ok=True)
    for folder in (manifest.out, manifest.out / "runs"):  # temporaries of a killed batch (only it writes here)
        remove_stale_temps(folder)
    runs = []
    for r in manifest.runs:
        if r.data is not None:
            text = "# written by seatune batch from " + manifest.path.name + "; edit the manifest, not this\n"
            text += yaml.safe_dump(r.data, sort_keys=False, allow_unicode=True)
            if not r.run_yaml.is_file() or r.run_yaml.read_text() != text:
                with atomic_path(r.run_yaml) as tmp:
                    tmp.write_text(text)
            r = BatchRun(r.name, r.run_yaml, r.place)
        runs.append(r)
    owners: dict[Path, BatchRun] = {}
    for r in runs:
        run_dir = _declared_run_dir(r.run_yaml)
        if run_dir is None:
            continue  # unreadable run YAML: that run fails on its own
        if run_dir in owners:
            raise UserError(str(manifest.path), r.place, f"run {r.name!r} has the same run_dir as "
                                                         f"{owners[run_dir].name!r} ({run_dir})")
        owners[run_dir] = r
    return runs


def _declared_run_dir(run_yaml: Path) -> Path | None:
    try:
        data = yaml.safe_load(run_yaml.read_text())
        return (run_yaml.parent / data["run_dir"]).resolve()
    except (OSError, yaml.YAMLError, TypeError, KeyError):
        return None


# ---------------------------------------------------------------------------------------------------------
# one run (worker)


def _vessel_files(vessel_path: Path) -> list[Path]:
    """The vessel YAML and every file it names (hydro database, mesh, WAMIT prefix.*), found by value."""
    found = [vessel_path]
    try:
        data = yaml.safe_load(vessel_path.read_text())
    except (OSError, yaml.YAMLError):
        return found

    def walk(v):
        if isinstance(v, dict):
            for x in v.values():
                yield from walk(x)
        elif isinstance(v, list):
            for x in v:
                yield from walk(x)
        elif isinstance(v, str) and 0 < len(v) < 4096 and "\n" not in v:
            yield v

    for s in walk(data):
        p = vessel_path.parent / s
        try:
            if p.is_file():
                found.append(p)
            elif p.parent.is_dir():  # a WAMIT prefix: prefix.1, .3, .hst, .frc
                found += sorted(q for q in p.parent.glob(p.name + ".*") if q.is_file())
        except (OSError, ValueError):
            continue
    return sorted(set(found), key=str)


def run_hash(run, stages: tuple[str, ...]) -> str:
    """Hash of everything a run's artefacts depend on: settings, input contents, seatune version, stages."""
    from seatune.io.rundir import file_digest

    inputs = sorted({p.resolve() for p, _ in run.logs} | {run.hindcast_path.resolve()}
                    | {p.resolve() for p in _vessel_files(run.vessel_path)}, key=str)
    h = hashlib.sha256(json.dumps({"version": seatune.__version__, "stages": list(stages),
                                   "spec": run.spec.model_dump(mode="json"), "run_dir": str(run.run_dir)},
                                  sort_keys=True, default=str).encode())
    for p in inputs:
        h.update(f"{p}\0{file_digest(p)}\0".encode())
    return h.hexdigest()[:24]


def _artefact_stamps(run_dir: Path) -> dict[str, list[int]]:
    return {p.name: [p.stat().st_size, p.stat().st_mtime_ns] for p in sorted(run_dir.iterdir())
            if p.is_file() and p.name != DONE_MARKER and not p.name.startswith(".")}


def is_done(run_dir: Path, h: str) -> bool:
    """The run finished for exactly these inputs and its artefacts were not touched since."""
    try:
        marker = json.loads((run_dir / DONE_MARKER).read_text())
        return marker.get("hash") == h and marker.get("artefacts") == _artefact_stamps(run_dir)
    except (OSError, ValueError):
        return False


def _write_done(run_dir: Path, h: str, seconds: float) -> None:
    marker = {"hash": h, "seatune": seatune.__version__, "finished_utc": datetime.now(UTC).isoformat(),
              "seconds": round(seconds, 3), "artefacts": _artefact_stamps(run_dir)}
    with atomic_path(run_dir / DONE_MARKER) as tmp:
        tmp.write_text(json.dumps(marker, indent=1))


@contextlib.contextmanager
def _one_thread():
    """BLAS/OpenMP pools and numba's parallel loops on one thread: a worker is one core (several workers per
    machine would otherwise oversubscribe it)."""
    with contextlib.ExitStack() as stack:
        try:
            from threadpoolctl import threadpool_limits

            stack.enter_context(threadpool_limits(1))
        except ImportError:  # pragma: no cover - comes with scikit-learn
            pass
        try:
            import numba

            before = numba.get_num_threads()
            numba.set_num_threads(1)
            stack.callback(numba.set_num_threads, before)
        except ImportError:  # pragma: no cover
            pass
        yield


def run_one(name: str, run_yaml: str, log_path: str, one_thread: bool = True, until: str | None = None) -> dict:
    """The Dask task: the pipeline of one run up to `until` (default: every stage), or nothing when it is done
    for these inputs.

    Returns the result record {name, status (ok / skipped / failed), error, error_type (user / internal),
    seconds, run_dir, run_yaml, log}; never raises for a failure of the run itself."""
    import dask

    from seatune.io.run_yaml import Run
    from seatune.pipeline import stages as st  # ORDER is read now: it is the list of every stage there is

    start = time.perf_counter()
    rec = {"name": name, "status": "failed", "error": None, "error_type": None, "seconds": math.nan,
           "run_dir": None, "run_yaml": run_yaml, "log": log_path}
    Path(log_path).parent.mkdir(parents=True, exist_ok=True)
    # dask inside the pipeline (wavespectra's xarray) runs synchronously in this thread: on a worker it would go
    # to the cluster, and the task would secede and let the worker start another run alongside
    with (open(log_path, "w", encoding="utf-8") as log, contextlib.redirect_stdout(log),
          contextlib.redirect_stderr(log), dask.config.set(scheduler="synchronous"),
          _one_thread() if one_thread else contextlib.nullcontext()):
        print(f"seatune {seatune.__version__} batch run {name}: {run_yaml} ({datetime.now(UTC):%Y-%m-%d %H:%M:%SZ}, "
              f"process {os.getpid()})")
        try:
            run = Run(run_yaml)
            rec["run_dir"] = str(run.run_dir)
            stages = tuple(st.ORDER)
            stages = stages[: stages.index(until) + 1] if until else stages
            h = run_hash(run, stages)
            if is_done(run.run_dir, h):
                rec["status"] = "skipped"
                print("finished before for these inputs and settings: skipped")
            else:
                (run.run_dir / DONE_MARKER).unlink(missing_ok=True)
                st.run_stages(run_yaml, stages[-1])
                _write_done(run.run_dir, h, time.perf_counter() - start)
                rec["status"] = "ok"
        except UserError as err:
            rec["error"], rec["error_type"] = str(err), "user"
            print(f"seatune: error: {err}")
        except Exception as err:  # an internal error of this run; the batch goes on
            first = (str(err).strip().splitlines() or [""])[0]
            rec["error"], rec["error_type"] = f"internal error: {type(err).__name__}: {first}", "internal"
            traceback.print_exc()
        rec["seconds"] = time.perf_counter() - start
    return rec


# ---------------------------------------------------------------------------------------------------------
# the batch (driver)


@contextlib.contextmanager
def dask_client(workers: int, scheduler: str | None = None, one_thread: bool = True):
    """A Client on an existing scheduler, or on a LocalCluster of `workers` processes with one thread each
    (and, with `one_thread`, numba / BLAS / OpenMP on one thread in each)."""
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError, ValueError) as err:
            raise UserError(None, "--scheduler", f"cannot connect to {scheduler}: {err}") from None
        with client:
            yield client
        return
    import dask

    # The workers' statistical profiler samples every thread's stack each 10 ms (measured: ~7 % of a run's CPU).
    # Dask's default MALLOC_TRIM_THRESHOLD_ turns off glibc's adaptive mmap threshold, so every large array is a
    # fresh mmap with its page faults (~3 %). Neither helps runs of big numpy / pandas arrays.
    settings = {"distributed.worker.profile.enabled": False,
                "distributed.nanny.pre-spawn-environ": SINGLE_THREAD_ENV if one_thread else {}}
    with dask.config.set(settings):
        # no dashboard, and the scheduler's HTTP routes on a free port: two batches on one machine never clash
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
                               silence_logs=logging.ERROR)
    with cluster, Client(cluster) as client:
        yield client


def run_batch(runs: list[BatchRun], out: Path, client, on_result=None, one_thread: bool = True,
              until: str | None = None) -> list[dict]:
    """Submit one task per run (its stages up to `until`, default all); `on_result(record)` as each finishes.
    Records come back in manifest order."""
    import uuid

    from distributed import as_completed

    token = uuid.uuid4().hex[:8]
    futures = {client.submit(run_one, r.name, str(r.run_yaml), str(out / "logs" / f"{r.name}.log"), one_thread,
                             until, key=f"seatune-run-{r.name}-{token}", pure=False): r for r in runs}
    records = {}
    for fut in as_completed(futures):
        r = futures[fut]
        try:
            rec = fut.result()
        except Exception as err:  # the worker died (killed, out of memory) or the task could not run
            run_dir = _declared_run_dir(r.run_yaml)
            rec = {"name": r.name, "status": "failed", "error": f"internal error: {type(err).__name__}: {err}",
                   "error_type": "internal", "seconds": math.nan, "run_dir": str(run_dir) if run_dir else None,
                   "run_yaml": str(r.run_yaml), "log": str(out / "logs" / f"{r.name}.log")}
        records[r.name] = rec
        if on_result is not None:
            on_result(rec)
    return [records[r.name] for r in runs]


def run_serial(runs: list[BatchRun], out: Path, on_result=None) -> list[dict]:
    """The same runs one after the other in this process (no Dask): the benchmark's reference."""
    records = []
    for r in runs:
        records.append(run_one(r.name, str(r.run_yaml), str(out / "logs" / f"{r.name}.log"), one_thread=False))
        if on_result is not None:
            on_result(records[-1])
    return records


# ---------------------------------------------------------------------------------------------------------
# fleet summary and index


def key_figures(run_dir: Path) -> tuple[dict, dict]:
    """One run's key figures and their units: the report's summary.parquet when there is one, else taken from
    tuning_history / validation / natural_frequencies (columns missing when their artefact is)."""
    from seatune.io.parquet import column_units

    summary = run_dir / "summary.parquet"
    if summary.is_file():
        df = pd.read_parquet(summary)
        if len(df):
            units = column_units(summary)
            row = {k: _scalar(v) for k, v in df.iloc[0].items() if k not in BASE_UNITS}
            return row, {k: units.get(k, "") for k in row}
    row, units = {}, {}
    hist = run_dir / "tuning_history.parquet"
    if hist.is_file():
        h = pd.read_parquet(hist)
        row["backend"], units["backend"] = str(h["backend"].iloc[0]), ""
        prior, last = h[h["update"] == 0], h[h["update"] == h["update"].max()]
        for p in h["parameter"].drop_duplicates():
            u = LOADING_UNITS.get(p, "")
            row[f"{p}_prior"] = float(prior.loc[prior.parameter == p, "mean"].iloc[0])
            row[f"{p}_tuned"] = float(last.loc[last.parameter == p, "mean"].iloc[0])
            row[f"{p}_tuned_std"] = float(last.loc[last.parameter == p, "std"].iloc[0])
            units |= {f"{p}_prior": u, f"{p}_tuned": u, f"{p}_tuned_std": u}
        row["windows_tuned"], units["windows_tuned"] = int(h["update"].max()), ""
    val = run_dir / "validation.parquet"
    if val.is_file():
        v = pd.read_parquet(val)
        held = v[v["role"] == "holdout"] if (v["role"] == "holdout").any() else v
        for col in ("prior", "tuned"):  # mean |log(predicted / measured)|, as tune's summary line
            row[f"heldout_error_{col}"] = float(np.mean(np.abs(np.log(held[f"predicted_{col}"] / held["measured"]))))
            units[f"heldout_error_{col}"] = ""
    from seatune.pipeline.identify import final_natural_frequencies

    nat = final_natural_frequencies(run_dir)
    if nat.is_file():
        from seatune.identification.natural_frequency import primary_natural_frequencies

        for dof, r in primary_natural_frequencies(pd.read_parquet(nat)).iterrows():
            row[f"omega_n_{dof.lower()}"] = float(r["omega_n"])
            units[f"omega_n_{dof.lower()}"] = "rad/s"
    return row, units


def _scalar(v):
    return v.item() if hasattr(v, "item") else v


def fleet_table(records: list[dict], out: Path) -> tuple[pd.DataFrame, dict]:
    rows, units = [], dict(BASE_UNITS)
    for rec in records:
        row = {k: rec.get(k) for k in BASE_UNITS}
        run_dir = Path(rec["run_dir"]) if rec.get("run_dir") else None
        report = run_dir / "report.html" if run_dir else None
        row["report"] = os.path.relpath(report, out) if report and report.is_file() else None
        row["log"] = os.path.relpath(rec["log"], out) if rec.get("log") else None
        if rec["status"] in ("ok", "skipped") and run_dir is not None:
            figures, fig_units = key_figures(run_dir)
            row |= figures
            units |= fig_units
        rows.append(row)
    df = pd.DataFrame(rows)
    for c in df.columns:
        if c not in units:
            units[c] = ""
    return df, units


def write_fleet_outputs(records: list[dict], out: Path, elapsed: float) -> tuple[Path, Path]:
    from seatune.io.parquet import write_table

    df, units = fleet_table(records, out)
    summary = write_table(df, out / SUMMARY_FILE, units, {"runs": len(df), "elapsed_s": round(elapsed, 3)})
    index = out / INDEX_FILE
    with atomic_path(index) as tmp:
        tmp.write_text(index_html(df, elapsed, units), encoding="utf-8")
    return summary, index


STATUS_COLOURS = {"ok": "#1a7f37", "skipped": "#57606a", "failed": "#cf222e"}


def index_html(df: pd.DataFrame, elapsed: float, units: dict | None = None) -> str:
    """A self-contained page: one row per run, linking its report (relative links), status and error line."""
    counts = df["status"].value_counts()
    title = (f"seatune fleet batch: {len(df)} runs, {counts.get('ok', 0)} ok, {counts.get('skipped', 0)} skipped, "
             f"{counts.get('failed', 0)} failed")
    figure_cols = _index_figures(df.columns)
    e = html.escape
    units = units or {}
    labels = ["run", "status", "seconds", "report", "log",
              *(f"{c} [{units[c]}]" if units.get(c) else c for c in figure_cols), "error"]
    head = "".join(f"<th>{e(c)}</th>" for c in labels)
    body = []
    for _, r in df.iterrows():
        report = f'<a href="{e(r["report"])}">report</a>' if isinstance(r["report"], str) else "–"
        log = f'<a href="{e(r["log"])}">log</a>' if isinstance(r["log"], str) else "–"
        secs = f"{r['seconds']:.1f}" if pd.notna(r["seconds"]) else "–"
        figs = "".join(f"<td>{_fmt(r[c])}</td>" for c in figure_cols)
        colour = STATUS_COLOURS.get(r["status"], "#000")
        error = e(r["error"]) if isinstance(r["error"], str) else ""
        body.append(f'<tr><td>{e(str(r["name"]))}</td><td style="color:{colour};font-weight:bold">'
                    f'{e(r["status"])}</td><td>{secs}</td><td>{report}</td><td>{log}</td>{figs}'
                    f'<td class="err">{error}</td></tr>')
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{e(title)}</title>
<style>body{{font-family:sans-serif;margin:2em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #d0d7de;padding:4px 8px;text-align:left}}th{{background:#f6f8fa}}
td.err{{font-family:monospace;color:#cf222e}}</style></head>
<body><h1>{e(title)}</h1>
<p>seatune {e(seatune.__version__)}, written {stamp}, {elapsed:.0f} s. Key figures: fleet_summary.parquet.</p>
<table><thead><tr>{head}</tr></thead><tbody>
{chr(10).join(body)}
</tbody></table></body></html>
"""


# key figures shown on the index (summary.parquet's names, then the fallback's); all are in fleet_summary.parquet
INDEX_FIGURES = ("vessel", "hours_logged", "windows_accepted", "omega_n_roll", "posterior_mean_*", "*_tuned",
                 "holdout_sigma_error_prior", "holdout_sigma_error_tuned", "heldout_error_prior", "heldout_error_tuned")


def _index_figures(columns) -> list[str]:
    out = []
    for pattern in INDEX_FIGURES:
        out += [c for c in columns if fnmatch.fnmatch(c, pattern) and c not in BASE_UNITS and c not in out
                and not (pattern == "*_tuned" and c.startswith(("omega_n_", "holdout_")))]
    return out[:10]


def _fmt(v) -> str:
    if isinstance(v, float):
        return "–" if math.isnan(v) else f"{v:.4g}"
    return html.escape(str(v)) if v is not None else "–"

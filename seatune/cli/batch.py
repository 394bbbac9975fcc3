"""`seatune run RUN.yaml` (every stage, in order) and `seatune batch MANIFEST.yaml` (many runs on Dask)."""

from __future__ import annotations

import contextlib
import os
import sys
import time

import click

from seatune.cli.main import cli, handle_errors


class _ClearingStdout:
    """sys.stdout while a progress bar is on the terminal's stderr: each write first clears the bar's line and
    a finished line redraws it, so summary lines never land on the bar (stdout may be a file or a pipe)."""

    def __init__(self, out, err, bar):
        self._out, self._err, self._bar = out, err, bar
        self.encoding, self.errors = out.encoding, out.errors

    def write(self, text):
        if not isinstance(text, str):
            raise TypeError("text only")  # click then treats this as a text stream
        self._err.write("\r\033[K")
        self._err.flush()
        n = self._out.write(text)
        self._out.flush()
        if text.endswith("\n"):
            self.draw()
        return n

    def draw(self):
        self._err.write(self._bar())
        self._err.flush()

    def flush(self):
        self._out.flush()

    def isatty(self):
        return self._out.isatty()

    def fileno(self):
        return self._out.fileno()


@contextlib.contextmanager
def _bar(total: int, what: str):
    """A progress bar on stderr when it is a terminal, else nothing. Yields `update(done, label)`."""
    if not sys.stderr.isatty():
        yield lambda done, label: None
        return
    state = {"done": 0, "label": "", "start": time.monotonic()}

    def render():
        width = 24
        k = round(width * state["done"] / max(total, 1))
        secs = int(time.monotonic() - state["start"])
        return (f"\r\033[K{what} [{'#' * k}{'-' * (width - k)}] {state['done']}/{total} {secs // 60}:{secs % 60:02d} "
                f"{state['label']}")

    stdout = sys.stdout
    proxy = _ClearingStdout(stdout, sys.stderr, render)

    def update(done, label):
        state.update(done=done, label=label)
        proxy.draw()

    sys.stdout = proxy
    try:
        proxy.draw()
        yield update
    finally:
        sys.stdout = stdout
        sys.stderr.write("\r\033[K")
        sys.stderr.flush()


def _check_force(ctx, param, value):
    from seatune.cli import stages as st

    for v in value:
        if v not in st.ORDER:
            raise click.BadParameter(f"{v!r} is not a stage (one of {', '.join(st.ORDER)})")
    return tuple(value)


@cli.command(name="run")
@click.argument("run_yaml", type=click.Path(dir_okay=False))
@click.option("--force", multiple=True, metavar="STAGE", callback=_check_force,
              help="Redo this stage and those after it (repeatable): ingest, windows, filter, identify, tune, …")
@handle_errors
def run_command(run_yaml, force):
    """Every stage in order, skipping those whose inputs and settings did not change → the run directory."""
    from seatune.cli import stages as st
    from seatune.io.run_yaml import Run

    order = tuple(st.ORDER)  # read now: the stage list grows
    with _bar(len(order), "stage") as update:
        st.run_stages(run_yaml, order[-1], force, progress=lambda s: update(order.index(s), s))
    report = Run(run_yaml).artefact("report.html")
    if report.is_file():
        click.echo(f"report at {report}")


@cli.command(name="batch")
@click.argument("manifest", type=click.Path(dir_okay=False))
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Worker processes of the local Dask cluster, one thread each [default: the CPUs available].")
@click.option("--scheduler", metavar="tcp://HOST:PORT", default=None,
              help="Use this running Dask scheduler instead of a local cluster (workers need seatune installed, "
                   "the same file paths, and one thread each).")
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Fleet folder (summary, index, logs); overrides the manifest's `out`.")
@click.option("--until", metavar="STAGE", default=None,
              callback=lambda ctx, param, v: v if v is None else _check_force(ctx, param, (v,))[0],
              help="Run each pipeline up to this stage only (e.g. diagnose: no report pages) [default: all].")
@handle_errors
def batch_command(manifest, workers, scheduler, out, until):
    """Many runs as Dask tasks; finished runs are skipped → fleet_summary.parquet and index.html."""
    from seatune.io.manifest_yaml import read_manifest
    from seatune.pipeline import batch as pb

    if scheduler and workers:
        raise click.UsageError("--workers sizes the local cluster; it cannot be combined with --scheduler")
    m = read_manifest(manifest, out)
    runs = pb.prepare(m)
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    n_workers = min(workers or cpus, len(runs))
    start = time.perf_counter()
    where = scheduler or f"a local cluster of {n_workers} worker(s)"
    click.echo(f"batch: {len(runs)} run(s) of {manifest} on {where} → {m.out}")
    done = 0

    with pb.dask_client(n_workers, scheduler) as client:
        if any(n > 1 for n in client.nthreads().values()):
            click.echo("seatune: warning: workers with several threads run several runs in one process (their "
                       "logs mix, their cores are shared); start them with --nthreads 1", err=True)
        with _bar(len(runs), "runs") as update:
            def report(rec):
                nonlocal done
                done += 1
                update(done, rec["name"])
                click.echo(_run_line(rec))

            records = pb.run_batch(runs, m.out, client, on_result=report, until=until)
    elapsed = time.perf_counter() - start
    summary, index = pb.write_fleet_outputs(records, m.out, elapsed)
    status = [r["status"] for r in records]
    click.echo(f"batch: {status.count('ok')} ok, {status.count('skipped')} skipped (up to date), "
               f"{status.count('failed')} failed of {len(records)} runs ({elapsed:.0f} s); {summary}; {index}")
    failed = [r for r in records if r["status"] == "failed"]
    if failed:
        internal = any(r["error_type"] == "internal" for r in failed)
        names = ", ".join(r["name"] for r in failed)
        click.echo(f"seatune: error: {len(failed)} of {len(records)} runs failed ({names}): see {index}", err=True)
        sys.exit(1 if internal else 2)


def _run_line(rec: dict) -> str:
    if rec["status"] == "skipped":
        return f"{rec['name']}: up to date (skipped)"
    if rec["status"] == "ok":
        return f"{rec['name']}: ok ({rec['seconds']:.0f} s) → {rec['run_dir']}"
    return f"{rec['name']}: failed: {rec['error']}"


"""Thin click CLI: parse, call a pipeline stage, print, exit code (0 ok, 2 user error, 1 internal, 130 Ctrl-C)."""

from __future__ import annotations

import functools
import sys

import click

import seatune
from seatune.errors import UserError


def handle_errors(func):
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except UserError as err:
            click.echo(f"seatune: error: {err}", err=True)
            sys.exit(2)
        except KeyboardInterrupt:  # the shell convention 128 + SIGINT; atomic writes leave no half-written file
            click.echo("seatune: interrupted", err=True)
            sys.exit(130)
    return wrapper


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(seatune.__version__, prog_name="seatune")
def cli():
    """seatune: tuned, uncertainty-quantified seakeeping models from logged sea trials."""


def main():
    """The console script. Once the command has returned and its output is flushed, the process ends without the
    interpreter's teardown: Arrow's parquet thread pool can abort there (std::terminate, exit −6) after all the
    work is done (apache/arrow#34314; one test subprocess in one of three full suites). Everything seatune opens
    (files, the Dask cluster) is closed by its own context managers before this point."""
    import os

    from seatune.cli import batch, predict, simulate, stages, vessel  # noqa: F401  (registers the commands)

    try:
        cli(prog_name="seatune")
        code = 0
    except SystemExit as done:  # click ends every command this way
        code = done.code if isinstance(done.code, int) else (0 if done.code is None else 1)
        if not isinstance(done.code, int | None):
            click.echo(str(done.code), err=True)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (BrokenPipeError, OSError):  # a reader that stopped early (`| head`)
            pass
    os._exit(code)

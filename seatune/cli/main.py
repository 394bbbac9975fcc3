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
    from seatune.cli import batch, predict, simulate, stages, vessel  # noqa: F401  (registers the commands)

    cli(prog_name="seatune")

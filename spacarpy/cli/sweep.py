"""``spacarpy sweep``: a deck run for every combination of SET parameter values
(docs/batch.md)."""
from __future__ import annotations

import argparse
import logging
from pathlib import Path

from spacarpy.cli.common import (
    _execution_options,
    _jobs,
    _parse_set,
    _positive_int,
    _Progress,
    _user_code_options,
    _verbosity,
)

log = logging.getLogger("spacarpy")


def _sweep_set(text: str):
    """``NAME=START:STOP:COUNT`` or ``NAME=V1,V2,...`` (an axis), or ``NAME=VALUE`` (fixed)."""
    from spacarpy.batch.sweep import parse_sweep_axis
    name, _, value = text.partition("=")
    if ":" in value or "," in value:
        try:
            return parse_sweep_axis(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return _parse_set(text)


def add_parser(sub) -> None:
    """The ``sweep`` subcommand's arguments."""
    swp = sub.add_parser("sweep", help="run a deck for every combination of SET parameter "
                                       "values and collect one HDF5 file and a table")
    swp.add_argument("deck", type=Path, help="SPACAR-style deck (.dat) with SET parameters")
    swp.add_argument("--set", dest="sweep_sets", metavar="NAME=START:STOP:COUNT",
                     type=_sweep_set, action="append", default=[], required=True,
                     help="a swept parameter (COUNT equally spaced values, or V1,V2,...), or "
                          "NAME=VALUE for a fixed override; repeat for a grid")
    swp.add_argument("-o", "--output", type=Path, default=None,
                     help="sweep file (default: <deck>_sweep.h5)")
    swp.add_argument("--collect", action="append", default=[], metavar="PATH",
                     help="dataset to collect, e.g. /eigen/frequency (repeatable; default: "
                          "load factor, frequencies, buckling multipliers, compliances)")
    swp.add_argument("--csv", type=Path, default=None, metavar="FILE",
                     help="also write the table as CSV")
    swp.add_argument("--columns", type=_positive_int, default=3, metavar="N",
                     help="values of each vector shown in the table (default 3)")
    _execution_options(swp)
    _user_code_options(swp)
    _verbosity(swp)


def cmd_sweep(args) -> int:
    """``spacarpy sweep DECK --set ...``: :func:`spacarpy.batch.commands.sweep_command`."""
    from spacarpy.batch.commands import sweep_command
    return sweep_command(args, _jobs(args), _Progress(args.quiet))

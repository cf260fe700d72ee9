"""``spacarpy sweep``: a deck run for every combination of SET parameter values
(docs/batch.md)."""
from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from spacarpy.cli.common import (
    _execution_options,
    _jobs,
    _parse_set,
    _positive_int,
    _Progress,
    _verbosity,
)
from spacarpy.errors import EXIT_INPUT, EXIT_OK

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
    _verbosity(swp)


def cmd_sweep(args) -> int:
    """``spacarpy sweep DECK --set NAME=START:STOP:COUNT ...``: one HDF5 file and a table on
    stdout; exit 1 when any run failed."""
    import shlex

    from spacarpy.batch.sweep import SweepAxis, format_sweep_table, run_sweep, write_sweep

    axes = [s for s in args.sweep_sets if isinstance(s, SweepAxis)]
    fixed = [s for s in args.sweep_sets if not isinstance(s, SweepAxis)]
    if not axes:
        print("sweep: give at least one swept parameter, --set NAME=START:STOP:COUNT",
              file=sys.stderr)
        return EXIT_INPUT
    result = run_sweep(args.deck, axes, fixed=fixed, collect=args.collect or None,
                       jobs=_jobs(args), timeout=args.timeout or None,
                       run_args=shlex.split(args.run_args), dask=args.dask,
                       progress=_Progress(args.quiet))
    out = args.output or args.deck.with_name(args.deck.stem + "_sweep.h5")
    write_sweep(result, out)
    sys.stdout.write(format_sweep_table(result, args.columns))
    if args.csv is not None:
        args.csv.write_text(format_sweep_table(result, args.columns, csv=True),
                            encoding="utf-8")
    n_bad = int((result.status != 0).sum())
    log.info("%s written: %d runs, %d failed", out, result.status.size, n_bad)
    return 1 if n_bad else EXIT_OK

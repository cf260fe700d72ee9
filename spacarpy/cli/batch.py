"""``spacarpy batch``: many decks run and compared with baselines (docs/batch.md)."""
from __future__ import annotations

import logging
import sys
from pathlib import Path

from spacarpy.cli.common import (
    _execution_options,
    _jobs,
    _nonnegative_float,
    _Progress,
    _verbosity,
)
from spacarpy.errors import EXIT_INPUT, EXIT_OK

log = logging.getLogger("spacarpy")


def add_parser(sub) -> None:
    """The ``batch`` subcommand's arguments."""
    bat = sub.add_parser("batch", help="run many decks in parallel and compare the results "
                                       "with baselines (regression test)")
    bat.add_argument("paths", nargs="+", metavar="PATH",
                     help="deck files, directories (searched recursively for .dat) or globs")
    bat.add_argument("--baseline", type=Path, default=None, metavar="DIR",
                     help="baseline result files: DIR/<relative deck path>.h5")
    bat.add_argument("--update-baseline", action="store_true",
                     help="write every finished result as its baseline in --baseline DIR")
    bat.add_argument("--rtol", type=_nonnegative_float, default=1e-6,
                     help="relative tolerance of the comparison (default 1e-6)")
    bat.add_argument("--atol", type=_nonnegative_float, default=1e-9,
                     help="absolute tolerance of the comparison (default 1e-9)")
    bat.add_argument("--report", type=Path, action="append", default=[], metavar="FILE",
                     help="also write a report: .xml JUnit, .json JSON, other: the table "
                          "(repeatable)")
    bat.add_argument("--output-dir", type=Path, default=None, metavar="DIR",
                     help="keep the result files there (default: not kept)")
    _execution_options(bat)
    _verbosity(bat)


def cmd_batch(args) -> int:
    """``spacarpy batch PATH...``: the table on stdout, reports; exit 1 when a deck changed or
    failed, 0 otherwise (new decks without a baseline do not fail the batch)."""
    import shlex

    from spacarpy.batch.report import format_table, write_report
    from spacarpy.batch.runner import run_batch

    if args.update_baseline and args.baseline is None:
        print("batch: --update-baseline needs --baseline DIR", file=sys.stderr)
        return EXIT_INPUT
    outcomes = run_batch(args.paths, baseline=args.baseline, jobs=_jobs(args), rtol=args.rtol,
                         atol=args.atol, timeout=args.timeout or None,
                         update_baseline=args.update_baseline, output_dir=args.output_dir,
                         run_args=shlex.split(args.run_args), dask=args.dask,
                         progress=_Progress(args.quiet))
    sys.stdout.write(format_table(outcomes))
    for path in args.report:
        log.info("%s written", write_report(outcomes, path))
    bad = any(o.status in ("changed", "failed") for o in outcomes)
    return 1 if bad else EXIT_OK

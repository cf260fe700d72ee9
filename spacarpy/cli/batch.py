"""``spacarpy batch``: many decks run and compared with baselines (docs/batch.md)."""
from __future__ import annotations

import logging
from pathlib import Path

from spacarpy.cli.common import (
    _execution_options,
    _jobs,
    _nonnegative_float,
    _Progress,
    _user_code_options,
    _verbosity,
)

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
    _user_code_options(bat)
    _verbosity(bat)


def cmd_batch(args) -> int:
    """``spacarpy batch PATH...``: :func:`spacarpy.batch.commands.batch_command`."""
    from spacarpy.batch.commands import batch_command
    return batch_command(args, _jobs(args), _Progress(args.quiet))

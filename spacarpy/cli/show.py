"""``spacarpy show``: the summary of a result file."""
from __future__ import annotations

import sys
from pathlib import Path

from spacarpy.cli.common import _verbosity
from spacarpy.errors import EXIT_OK


def add_parser(sub) -> None:
    """The ``show`` subcommand's arguments."""
    show = sub.add_parser("show", help="summary of a result file: steps, convergence, "
                                       "extremes, frequencies, buckling multipliers")
    show.add_argument("file", type=Path, help="result file (.h5)")
    _verbosity(show)


def cmd_show(args) -> int:
    """``spacarpy show FILE``: the summary of :func:`spacarpy.results.summary.summary`."""
    from spacarpy.results import open_results
    from spacarpy.results.summary import summary

    with open_results(args.file) as res:
        sys.stdout.write(summary(res))
    return EXIT_OK

"""``spacarpy extract``: one quantity of a result file as text, CSV or JSON."""
from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from spacarpy.cli.common import _dof, _output_path, _selection, _verbosity
from spacarpy.errors import EXIT_OK

log = logging.getLogger("spacarpy")


def add_parser(sub, vocabularies: bool = True) -> None:
    """The ``extract`` subcommand's arguments. ``vocabularies``: False when another
    subcommand is being parsed; extract is then listed with its help but without its
    (imported) list of quantities."""
    if vocabularies:
        from spacarpy.results.tables import QUANTITIES
    else:
        QUANTITIES = {}

    ext = sub.add_parser("extract", help="one quantity as a table (text, CSV or JSON) for "
                                         "scripts and spreadsheets",
                         formatter_class=argparse.RawDescriptionHelpFormatter,
                         epilog="quantities:\n" + "\n".join(
                             f"  {k:<21} {v}" for k, v in QUANTITIES.items()))
    ext.add_argument("file", type=Path, help="result file (.h5)")
    ext.add_argument("what", choices=list(QUANTITIES), metavar="WHAT",
                     help="quantity to extract (listed below)")
    _selection(ext)
    _dof(ext)
    fmt = ext.add_mutually_exclusive_group()
    fmt.add_argument("--csv", dest="format", action="store_const", const="csv",
                     help="comma-separated values with a header line")
    fmt.add_argument("--json", dest="format", action="store_const", const="json",
                     help="a JSON object with columns, units and data")
    ext.add_argument("-o", "--output", type=_output_path, default=None,
                     help="write to this file instead of standard output")
    _verbosity(ext)


def cmd_extract(args) -> int:
    """``spacarpy extract FILE WHAT``: a table as text, CSV or JSON."""
    from spacarpy.outputs import check_output_path
    from spacarpy.results import open_results
    from spacarpy.results.tables import extract

    if args.output is not None:
        check_output_path(args.output, "-o", inputs=[args.file])
    with open_results(args.file) as res:
        table = extract(res, args.what, node=args.node, element=args.element, step=args.step,
                        mode=args.mode, dof=args.dof)
    text = {"csv": table.to_csv, "json": table.to_json}.get(args.format, table.to_text)()
    if args.output is not None:
        from spacarpy.outputs import is_null_device
        if is_null_device(args.output):          # -o /dev/null: discarded, never opened
            return EXIT_OK
        from spacarpy.outputs import atomic_output
        with atomic_output(args.output) as staged:   # whole or not at all (a full disk)
            staged.write_text(text, encoding="utf-8")
        log.info("%s written", args.output)
    else:
        sys.stdout.write(text)
    return EXIT_OK

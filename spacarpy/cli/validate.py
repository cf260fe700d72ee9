"""``spacarpy validate``: a result file checked against the schema."""
from __future__ import annotations

from pathlib import Path

from spacarpy.cli.common import _verbosity
from spacarpy.errors import EXIT_INPUT, EXIT_OK


def add_parser(sub) -> None:
    """The ``validate`` subcommand's arguments."""
    val = sub.add_parser("validate", help="check a result file against the schema "
                                          "(docs/results.md)")
    val.add_argument("file", type=Path, help="result file (.h5)")
    val.add_argument("--require-complete", action="store_true",
                     help="also fail for a run that did not finish (a partial file)")
    _verbosity(val)


def cmd_validate(args) -> int:
    """``spacarpy validate FILE``: 0 if the file follows the schema (a consistent partial file
    does, unless ``--require-complete``), 2 with one line per problem otherwise."""
    from spacarpy.results import validate_file

    problems = validate_file(args.file, require_complete=args.require_complete)
    if problems:
        print(f"{args.file}: INVALID ({len(problems)} problem{'s' * (len(problems) > 1)})")
        for p in problems:
            print(f"  {p}")
        return EXIT_INPUT
    from spacarpy.results import open_results
    res = open_results(args.file)
    version = ".".join(map(str, res.schema_version))
    state = "completed run" if res.completed else (
        "incomplete run: " + (res.error or "the writer did not finish (killed, or still "
                                           "running)"))
    print(f"{args.file}: valid spacarpy results file, schema {version}, {state}")
    return EXIT_OK

"""The ``spacarpy`` command: the parser of every subcommand (built once per process), the
dispatch to the subcommands' modules, and the catching of errors into exit codes.

Exit codes (see :mod:`spacarpy.errors`): 0 success, 1 solver failure, 2 input error (deck or
command line), 3 model not analysable (mechanism, over-constraint), 4 (``run``) an EXPECT line
of the deck failed, 130 interrupted (Ctrl-C), 143 terminated (SIGTERM); ``batch``/``sweep``:
1 when a deck changed or failed.
Progress goes to stderr, silenced by ``-q``; errors are printed without a traceback.
"""
from __future__ import annotations

import argparse
import functools
import logging
import sys

from spacarpy import __version__
from spacarpy.cli import batch, bench, check, export, extract, plot, run, show, sweep, validate
from spacarpy.cli.common import join_option_strings
from spacarpy.cli.process import (
    _capped,
    _printable,
    _quiet_h5py_dealloc,
    _restore_sigterm,
    _single_blas_thread,
    _terminate_like_interrupt,
    exit_process,
)
from spacarpy.errors import (
    EXIT_INPUT,
    EXIT_INTERRUPTED,
    EXIT_SOLVER,
    EXIT_TERMINATED,
    SpacarError,
    Terminated,
)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of every subcommand. ``command``: the subcommand about to be
    parsed, when known; the result-file subcommands then skip importing the plot and table
    vocabularies (only their names and help are needed), which keeps ``spacarpy run``'s
    start-up free of the plotting modules."""
    p = argparse.ArgumentParser(
        prog="spacarpy",
        description="Large-deflection analysis of flexible multibody systems and slender "
                    "structures with the DDM beam (SPACAR-style decks).")
    p.add_argument("--version", action="version", version=f"spacarpy {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run.add_parser(sub)
    check.add_parser(sub)
    bench.add_parser(sub)
    vocabularies = command is None or command in _VOCABULARY_COMMANDS
    validate.add_parser(sub)
    show.add_parser(sub)
    extract.add_parser(sub, vocabularies)
    plot.add_parser(sub, vocabularies)
    export.add_parser(sub)
    batch.add_parser(sub)
    sweep.add_parser(sub)
    return p


#: Subcommands whose arguments list the plot kinds or the extractable quantities.
_VOCABULARY_COMMANDS = frozenset({"extract", "plot"})


@functools.lru_cache(maxsize=2)
def _parser(vocabularies: bool) -> argparse.ArgumentParser:
    """:func:`build_parser`'s parser, built once per process (argparse parsers are reusable):
    building it makes about 110 help formatters, each asking for the terminal's size, 11 ms
    that a batch or sweep worker would pay again for every deck it runs."""
    return build_parser(None if vocabularies else "run")


def _command_name(argv: list[str] | None) -> str | None:
    """The subcommand named on the command line (the first word that is not an option), or
    None when there is none; only a hint for :func:`build_parser`."""
    words = sys.argv[1:] if argv is None else argv
    for word in words:
        if not word.startswith("-"):
            return word
    return None


def console() -> None:
    """The ``spacarpy`` command (console script and ``python -m spacarpy``): :func:`main`,
    then :func:`exit_process` with its exit code.

    For the commands that analyse in this process and in its main thread only (``run``,
    ``check``), numpy's submodules that no analysis uses are made lazy first
    (:mod:`spacarpy.lazy_imports`), after the BLAS thread count is set: that import of numpy
    is the process's first. (Not for ``batch`` and ``sweep``, whose Dask backend has threads:
    Python 3.11's lazy modules are not safe to load from two threads at once.)"""
    if _command_name(None) in _LAZY_NUMPY_COMMANDS:
        from spacarpy.lazy_imports import defer_numpy_submodules
        _single_blas_thread()
        defer_numpy_submodules()
    exit_process(main())


#: The commands for which :func:`console` makes numpy's unused submodules lazy.
_LAZY_NUMPY_COMMANDS = ("run", "check")


def main(argv: list[str] | None = None) -> int:
    _single_blas_thread()
    argv = join_option_strings(sys.argv[1:] if argv is None else list(argv))
    command = _command_name(argv)
    parser = _parser(command is None or command in _VOCABULARY_COMMANDS)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:           # argparse: 2 for usage errors, 0 for --help
        return int(exc.code or 0)
    from spacarpy.memory import keep_freed_memory
    keep_freed_memory()                 # large models: reuse freed memory (spacarpy.memory)
    _quiet_h5py_dealloc()
    previous = None
    try:                    # a SIGTERM anywhere in here, restoring the handler included
        try:
            previous = _terminate_like_interrupt()
            return _main(args)
        finally:
            if previous is not None:
                _restore_sigterm(previous)
    except Terminated:
        print("terminated (SIGTERM)", file=sys.stderr)
        return EXIT_TERMINATED


#: Libraries whose debug/info lines (h5py's "Creating converter from 5 to 3") -v hides.
_QUIET_LIBRARIES = ("h5py", "matplotlib", "PIL")


def _main(args) -> int:
    if getattr(getattr(args, "mode", None), "silent", False):
        args.quiet = True               # a negative SPACAR mode number: SPACAR's silent run
    level = logging.WARNING if args.quiet else (logging.DEBUG if args.verbose else logging.INFO)
    logging.basicConfig(level=level, format="%(message)s", stream=sys.stderr, force=True)
    for name in _QUIET_LIBRARIES:    # -v shows spacarpy's debug lines, not the libraries'
        logging.getLogger(name).setLevel(logging.WARNING)
    try:
        if args.command == "run":
            return run.cmd_run(args)
        if args.command == "check":
            return check.cmd_check(args)
        if args.command == "bench":
            return bench.cmd_bench(args)
        if args.command in _RESULT_COMMANDS:
            from spacarpy.results.h5file import reading
            with reading(args.file):        # a damaged file: a message and exit 2
                return _RESULT_COMMANDS[args.command](args)
        if args.command in ("batch", "sweep"):
            return batch.cmd_batch(args) if args.command == "batch" else sweep.cmd_sweep(args)
    except SpacarError as exc:
        print(_printable(_capped(exc)), file=sys.stderr)
        return exc.exit_code
    except MemoryError:
        # past the estimate of spacarpy.memory (a factorization's fill, another process's
        # memory): a message, never a traceback; a result file keeps its completed steps
        print("error: out of memory: the analysis needed more memory than the system could "
              "give (see docs/performance.md, 'Memory estimate before a run')",
              file=sys.stderr)
        return EXIT_SOLVER
    except (OSError, RuntimeError) as exc:
        from spacarpy.errors import disk_full_text, is_disk_full
        if not is_disk_full(exc):
            raise
        # a write no command wraps (they remove what they were writing themselves)
        where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
        print(f"disk full (or quota exceeded){where}: {disk_full_text(exc)}", file=sys.stderr)
        return EXIT_SOLVER
    except Terminated:
        print("terminated (SIGTERM)", file=sys.stderr)
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_INPUT


_RESULT_COMMANDS = {"validate": validate.cmd_validate, "show": show.cmd_show,
                    "extract": extract.cmd_extract, "plot": plot.cmd_plot,
                    "export": export.cmd_export}

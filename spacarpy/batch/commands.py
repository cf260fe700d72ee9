"""The ``spacarpy batch`` and ``spacarpy sweep`` commands, from parsed arguments to exit code.

The command line (:mod:`spacarpy.cli`) parses the options and hands them here. Every output
(``--report``, ``--output-dir``, ``--baseline`` with ``--update-baseline``, the sweep file,
``--csv``) is checked before any run, as ``spacarpy run`` checks its ``-o``
(:mod:`spacarpy.outputs`); errors are :class:`~spacarpy.errors.SpacarError` (one line,
exit 2). An interrupted batch or sweep (Ctrl-C, SIGTERM) still writes its table, reports
and finished points, then re-raises the interrupt (exit 130 or 143).
"""
from __future__ import annotations

import logging
import shlex
import sys
from pathlib import Path

from spacarpy.errors import EXIT_INPUT, EXIT_OK, SpacarError

__all__ = ["batch_command", "sweep_command"]

log = logging.getLogger(__name__)


class BatchUsageError(SpacarError):
    """A combination of batch or sweep options that cannot work (exit 2)."""

    exit_code = EXIT_INPUT


def batch_command(args, jobs: int, progress=None) -> int:
    """``spacarpy batch PATH...``: the table on stdout, reports; exit 1 when a deck changed or
    failed, 0 otherwise (new decks without a baseline do not fail the batch)."""
    from spacarpy.batch.backends import check_dask_address
    from spacarpy.batch.report import check_report_paths, format_table, write_report
    from spacarpy.batch.runner import BatchInterrupted, find_decks, run_batch

    if args.update_baseline and args.baseline is None:
        raise BatchUsageError("batch: --update-baseline needs --baseline DIR")
    decks = find_decks(args.paths)              # no deck: exit 2 before anything else
    check_report_paths(args.report, inputs=[d for d, _ in decks])
    if args.dask is not None:
        check_dask_address(args.dask)
    from spacarpy.user_routines import batch_run_args
    run_args = shlex.split(args.run_args) + batch_run_args(args, [d for d, _ in decks])
    try:
        outcomes = run_batch(args.paths, baseline=args.baseline, jobs=jobs, rtol=args.rtol,
                             atol=args.atol, timeout=args.timeout or None,
                             update_baseline=args.update_baseline,
                             output_dir=args.output_dir, run_args=run_args,
                             dask=args.dask, progress=progress)
    except BatchInterrupted as stop:
        _finish_batch(stop.outcomes, args.report, format_table, write_report)
        not_run = [o.name for o in stop.outcomes if o.status == "not run"]
        log.warning("batch interrupted: %d of %d decks finished; not run: %s",
                    len(stop.outcomes) - len(not_run), len(stop.outcomes),
                    ", ".join(not_run) or "none")
        raise stop.cause from None
    _finish_batch(outcomes, args.report, format_table, write_report)
    bad = any(o.status in ("changed", "failed") for o in outcomes)
    return 1 if bad else EXIT_OK


def _finish_batch(outcomes, reports, format_table, write_report) -> None:
    sys.stdout.write(format_table(outcomes))
    sys.stdout.flush()
    for path in reports:
        log.info("%s written", write_report(outcomes, path))


def sweep_command(args, jobs: int, progress=None) -> int:
    """``spacarpy sweep DECK --set NAME=START:STOP:COUNT ...``: one HDF5 file and a table on
    stdout; exit 1 when any run failed."""
    from spacarpy.batch.sweep import SweepAxis, SweepInterrupted, run_sweep
    from spacarpy.batch.sweep_file import NOT_RUN
    from spacarpy.outputs import OutputLock, check_output_path, discarding

    axes = [s for s in args.sweep_sets if isinstance(s, SweepAxis)]
    fixed = [s for s in args.sweep_sets if not isinstance(s, SweepAxis)]
    if not axes:
        raise BatchUsageError("sweep: give at least one swept parameter, "
                              "--set NAME=START:STOP:COUNT")
    deck = Path(args.deck)
    out = Path(args.output) if args.output is not None else \
        deck.with_name(deck.stem + "_sweep.h5")
    if not deck.is_file():
        from spacarpy.batch.runner import BatchInputError
        raise BatchInputError(f"sweep: no deck '{deck}'")
    from spacarpy.user_routines import batch_run_args
    run_args = shlex.split(args.run_args) + batch_run_args(args, [deck])
    # at once (the INCLUDE files are known once run_sweep has read the deck; it checks again)
    check_output_path(out, "-o", inputs=[deck], warn=False)
    if args.csv is not None:
        check_output_path(args.csv, "--csv", inputs=[deck], warn=False)
    # -o /dev/null discards: the sweep file goes to a private temporary folder, removed at
    # the end; the null device itself is never opened, locked or replaced
    with discarding(out, ".h5") as target, OutputLock(target):
        try:
            result = run_sweep(deck, axes, fixed=fixed, collect=args.collect or None,
                               jobs=jobs, timeout=args.timeout or None,
                               run_args=run_args, dask=args.dask,
                               progress=progress, output=target,
                               outputs=[("--csv", args.csv)])
        except SweepInterrupted as stop:
            _finish_sweep(stop.result, args)
            n_done = int((stop.result.status != NOT_RUN).sum())
            log.warning("sweep interrupted: %d of %d points finished; kept in %s "
                        "(/sweep/status -2 marks the points not run)", n_done,
                        stop.result.status.size, stop.kept)
            raise stop.cause from None
    _finish_sweep(result, args)
    n_bad = int((result.status != 0).sum())
    log.info("%s written: %d runs, %d failed", out, result.status.size, n_bad)
    return 1 if n_bad else EXIT_OK


def _finish_sweep(result, args) -> None:
    from spacarpy.batch.sweep import format_sweep_table
    from spacarpy.outputs import write_atomically

    sys.stdout.write(format_sweep_table(result, args.columns))
    sys.stdout.flush()
    if args.csv is not None:
        write_atomically(args.csv, format_sweep_table(result, args.columns, csv=True))

"""Command line: ``spacarpy run | check | bench``.

Exit codes (see :mod:`spacarpy.errors`): 0 success, 1 solver failure, 2 input error (deck or
command line), 3 model not analysable (mechanism, over-constraint), 130 interrupted.
Progress goes to stderr, silenced by ``-q``; errors are printed without a traceback.
"""
from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

from spacarpy import __version__
from spacarpy.errors import EXIT_INPUT, EXIT_INTERRUPTED, EXIT_OK, SpacarError

log = logging.getLogger("spacarpy")


def _parse_mode(text: str) -> str:
    from spacarpy.model import ANALYSES, SPACAR_MODE_NUMBERS
    t = text.strip().lower()
    if t in ANALYSES:
        return t
    try:
        num = abs(int(t))
    except ValueError:
        num = None
    if num in SPACAR_MODE_NUMBERS:
        return SPACAR_MODE_NUMBERS[num]
    raise argparse.ArgumentTypeError(
        f"unknown mode {text!r}: expected one of {', '.join(ANALYSES)} or a SPACAR mode "
        f"number ({', '.join(str(k) for k in sorted(SPACAR_MODE_NUMBERS))})")


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}")
    return value


def _parse_set(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    name, value = name.strip(), value.strip()
    if not sep or not name or not value:
        raise argparse.ArgumentTypeError(
            f"expected NAME=VALUE (for example R=100 or EI=1e7/12), got {text!r}")
    return name, value


def _set_option(p):
    p.add_argument("--set", dest="overrides", metavar="NAME=VALUE", type=_parse_set,
                   action="append", default=[],
                   help="override the deck's 'SET NAME ...' line (a number or an expression; "
                        "repeat for several parameters)")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="spacarpy",
        description="Large-deflection analysis of flexible multibody systems and slender "
                    "structures with the DDM beam (SPACAR-style decks).")
    p.add_argument("--version", action="version", version=f"spacarpy {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = sub.add_parser("run", help="analyse a deck and write an HDF5 result file")
    run.add_argument("deck", type=Path, help="SPACAR-style deck (.dat)")
    run.add_argument("-o", "--output", type=Path, default=None,
                     help="result file (default: the deck's name with .h5)")
    run.add_argument("--mode", type=_parse_mode, default=None,
                     help="analysis: static (SPACAR 10), eigen (4, 7), buckling (8); "
                          "overrides the deck's MODE line")
    run.add_argument("--deformations", choices=("modified", "basic"), default=None,
                     help="deformation definitions: modified second-order (Eq. 48, default) "
                          "or basic (Eq. 7); overrides the deck's DEFORMATIONS line")
    run.add_argument("--modes", type=_positive_int, default=10, metavar="N",
                     help="number of eigenmodes / buckling modes per linearization (default 10)")
    run.add_argument("--compliance", type=_positive_int, nargs=2, default=None,
                     metavar=("POS", "ROT"),
                     help="store the 6x6 compliance of position node POS with orientation "
                          "node ROT at the linearized steps (global and body axes)")
    run.add_argument("--modes-per-step", action="store_true",
                     help="linearize at every load step: frequencies (if the model has mass) "
                          "and buckling multipliers (if it is loaded), as SPACAR's mode 10")
    _set_option(run)
    _verbosity(run)

    check = sub.add_parser("check", help="parse and validate a deck without solving it, and "
                                         "print a summary")
    check.add_argument("deck", type=Path, help="SPACAR-style deck (.dat)")
    _set_option(check)
    _verbosity(check)

    bench = sub.add_parser("bench", help="time the solver on straight cantilevers")
    bench.add_argument("--sizes", type=int, nargs="+", default=[10, 100, 1000, 10000],
                       help="numbers of elements (default: 10 100 1000 10000)")
    bench.add_argument("--steps", type=int, default=10, help="load steps (default 10)")
    bench.add_argument("--repeat", type=int, default=3,
                       help="repetitions per size; min and median are shown (default 3)")
    _verbosity(bench)
    return p


def _verbosity(p):
    p.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    p.add_argument("-v", "--verbose", action="store_true", help="solver details")


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:           # argparse: 2 for usage errors, 0 for --help
        return int(exc.code or 0)
    level = logging.WARNING if args.quiet else (logging.DEBUG if args.verbose else logging.INFO)
    logging.basicConfig(level=level, format="%(message)s", stream=sys.stderr, force=True)
    try:
        if args.command == "run":
            return cmd_run(args)
        if args.command == "check":
            return cmd_check(args)
        if args.command == "bench":
            from spacarpy.bench import run_bench
            run_bench(sizes=args.sizes, n_steps=args.steps, repeat=args.repeat)
            return EXIT_OK
    except SpacarError as exc:
        print(str(exc), file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_INPUT


def cmd_check(args) -> int:
    """``spacarpy check DECK``: the summary on stdout; exit 0 if the deck is valid and
    supported, 2 otherwise (syntax errors, semantic errors, features not supported yet)."""
    from spacarpy.deck import check_deck

    summary = check_deck(args.deck, overrides=dict(args.overrides) or None)
    print(summary.format())
    return EXIT_OK if summary.ok else EXIT_INPUT


def cmd_run(args) -> int:
    from spacarpy.deck import load_deck
    from spacarpy.run import RunOptions, run_model

    t0 = time.perf_counter()
    model = load_deck(args.deck, deformations=args.deformations, analysis=args.mode,
                      overrides=dict(args.overrides) or None)
    out = args.output if args.output is not None else args.deck.with_suffix(".h5")
    log.info("%s: %d position nodes, %d orientation nodes, %d beams; %s analysis, %s "
             "deformations", args.deck, model.position_ids.size, model.orientation_ids.size,
             model.beams.n_elem, model.analysis, model.deformations)
    summary = run_model(model, out, RunOptions(n_modes=args.modes,
                                               modes_per_step=args.modes_per_step,
                                               compliance_node=args.compliance))
    log.info("finished %s analysis: %d steps in %.2f s", model.analysis, summary.n_steps,
             time.perf_counter() - t0)
    return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

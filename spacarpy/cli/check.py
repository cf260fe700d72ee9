"""``spacarpy check``: a deck parsed and validated without solving it, its summary printed."""
from __future__ import annotations

from pathlib import Path

from spacarpy.cli.common import (
    _require_elements,
    _set_option,
    _user_code_options,
    _verbosity,
)
from spacarpy.errors import EXIT_INPUT, EXIT_OK


def add_parser(sub) -> None:
    """The ``check`` subcommand's arguments."""
    check = sub.add_parser("check", help="parse and validate a deck without solving it, and "
                                         "print a summary")
    check.add_argument("deck", type=Path, help="SPACAR-style deck (.dat)")
    _user_code_options(check, check=True)
    _set_option(check)
    _verbosity(check)


def cmd_check(args) -> int:
    """``spacarpy check DECK``: the summary on stdout; exit 0 if the deck is valid and
    supported, 2 otherwise (syntax errors, semantic errors, features not supported yet)."""
    from spacarpy.deck import check_deck
    from spacarpy.errors import DeckError
    from spacarpy.memory import memory_line

    summary = check_deck(args.deck, overrides=dict(args.overrides) or None)
    if summary.model is not None:
        try:
            _require_elements(summary.model, args.deck)
        except DeckError as exc:
            summary.errors.extend(exc.items)
    text = summary.format()
    if summary.model is not None and summary.model.n_elem:
        lines = text.split("\n")      # the estimate above the final "OK" line
        lines.insert(len(lines) - 1,
                     f"  {'memory estimate':<20}{memory_line(summary.model.n_elem)}")
        text = "\n".join(lines)
    if summary.model is not None and summary.model.user_routines:
        from spacarpy.user_routines import ALLOW_FLAG, routine_report
        lines = text.split("\n")      # above the final "OK" line; no code is run
        lines[len(lines) - 1:len(lines) - 1] = [
            f"  user routines (Python, run only with {ALLOW_FLAG}):",
            *("  " + ln for ln in routine_report(summary.model, args.deck, args.user_module))]
        text = "\n".join(lines)
    print(text)
    return EXIT_OK if summary.ok else EXIT_INPUT

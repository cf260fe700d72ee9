"""The pieces the subcommands share: argument types, the -q/-v, --set, user-code, selection
and execution options, the usage error, the empty-deck check, the batch progress line."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from spacarpy.errors import EXIT_INPUT, SpacarError


class UsageError(SpacarError):
    """A command-line value that argparse cannot check by itself (exit 2)."""

    exit_code = EXIT_INPUT


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}")
    return value


def _nonnegative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return value


def _positive_float(text: str) -> float:
    """A finite number > 0 (``--fps``): 0, negative, nan and inf are refused by argparse."""
    import math
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return value


def _output_path(text: str) -> Path:
    """An output file name: not empty (``-o ""`` would mean the current directory)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("the output file name is empty")
    return Path(text)


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


def _user_code_options(p, check: bool = False):
    """--allow-user-code and --user-module (run, batch, sweep; check: --user-module)."""
    if not check:
        p.add_argument("--allow-user-code", action="store_true",
                       help="run the Python user routines the deck names (USERSIG, "
                            "USERINP): they are code, run with your rights; without this "
                            "flag such a deck is refused before any work (exit 5)")
    p.add_argument("--user-module", action="append", type=Path, default=[], metavar="PATH",
                   help="a .py file (or a folder of name.py files) holding the deck's user "
                        "routines, searched before name.py beside the deck; repeatable")


def _verbosity(p):
    p.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    p.add_argument("-v", "--verbose", action="store_true", help="solver details")


def _selection(p) -> None:
    p.add_argument("--node", type=int, default=None, help="deck node number")
    p.add_argument("--element", type=int, default=None, help="deck element number")
    p.add_argument("--step", type=int, default=None,
                   help="static step (0 = initial state; -1 = the last)")
    p.add_argument("--mode", type=_positive_int, default=None,
                   help="mode number (1 = the first)")


def _dof(p) -> None:
    p.add_argument("--dof", choices=("x", "y", "z"), default=None,
                   help="path: the displacement component of --node (default: the one that "
                        "moves most)")


def _execution_options(p) -> None:
    p.add_argument("-j", "--jobs", type=_positive_int, default=None, metavar="N",
                   help="runs at the same time (default: the number of CPUs); with --dask "
                        "local, the number of workers")
    p.add_argument("--timeout", type=_nonnegative_float, default=600.0, metavar="S",
                   help="seconds per run before its process is killed (default 600)")
    p.add_argument("--dask", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster: a scheduler address (tcp://host:8786) or "
                        "'local' for a LocalCluster on this machine (needs dask[distributed])")
    p.add_argument("--run-args", default="", metavar="'OPTIONS'",
                   help="more 'spacarpy run' options for every run, in one quoted string "
                        "(e.g. '--modes-per-step --modes 4')")


def _require_elements(model, deck) -> None:
    """An empty deck (an empty file, ``END END``, /dev/null) is an input error, not a model
    with 0 degrees of freedom."""
    from spacarpy.errors import DeckError
    if model.n_elem == 0:
        what = "no elements" if model.position_ids.size else "no nodes and no elements"
        raise DeckError((None, f"{deck}: the deck defines {what}; nothing to analyse"))


class _Progress:
    """A live ``[done/total]`` line on stderr when it is a terminal (and not -q)."""

    def __init__(self, quiet: bool):
        self.live = not quiet and sys.stderr.isatty()
        self.failed = 0

    def __call__(self, done, total, item):
        status = getattr(item, "status", "")
        self.failed += status in ("failed", "changed", "error", "timeout", "expect")
        if self.live:
            name = getattr(item, "name", None) or getattr(item, "key", "")
            sys.stderr.write(f"\r\x1b[K[{done}/{total}] {self.failed} not passing; last: "
                             f"{name} {status}")
            if done == total:
                sys.stderr.write("\n")
            sys.stderr.flush()


def _jobs(args) -> int:
    """The number of worker processes (``-j``, else one per core). With several, each
    worker's PARDISO gets its share of the cores (``SPACARPY_PARDISO_THREADS``, unless the
    user set it or ``MKL_NUM_THREADS``), not all of them each."""
    import os
    jobs = args.jobs or os.cpu_count() or 1
    if jobs > 1 and "MKL_NUM_THREADS" not in os.environ:
        os.environ.setdefault("SPACARPY_PARDISO_THREADS",
                              str(max(1, (os.cpu_count() or 1) // jobs)))
    return jobs


#: Options whose value is itself a string of options: ``--run-args '--modes-per-step'``
#: would be read by argparse as a second option without a value.
OPTION_STRING_OPTIONS = ("--run-args",)


def join_option_strings(argv: list[str]) -> list[str]:
    """``--run-args VALUE`` as ``--run-args=VALUE`` when VALUE starts with a dash, so that the
    quoted form the help shows (``--run-args '--modes-per-step'``) parses as one option with
    its value, as ``--run-args=--modes-per-step`` does."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        word = argv[i]
        if word in OPTION_STRING_OPTIONS and i + 1 < len(argv) and \
                argv[i + 1].startswith("-"):
            out.append(f"{word}={argv[i + 1]}")
            i += 2
            continue
        out.append(word)
        i += 1
    return out

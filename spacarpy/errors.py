"""User-facing error types of spacarpy and the CLI exit codes that go with them.

Every error a user can cause or meet derives from :class:`SpacarError`. The command line maps
the families onto distinct exit codes (see :data:`EXIT_CODES`) so that scripts can tell a bad
deck from a solver failure.
"""
from __future__ import annotations

from dataclasses import dataclass

#: Exit codes of the command line.
EXIT_OK = 0
EXIT_SOLVER = 1        # the model is valid but the analysis failed (no convergence, ...)
EXIT_INPUT = 2         # the deck or the command line is wrong
EXIT_MODEL = 3         # the deck parses but the model is not analysable (mechanism, ...)
# (4 is EXPECT's: spacarpy.deck.expect.EXIT_EXPECTATION)
EXIT_USER_CODE_REFUSED = 5  # the deck names user code and --allow-user-code was not given
EXIT_USER_ROUTINE = 6  # a user routine (USERSIG/USERINP) raised or returned a bad value
EXIT_INTERRUPTED = 130  # Ctrl-C
EXIT_TERMINATED = 143  # SIGTERM (128 + 15), e.g. from a job scheduler


@dataclass(frozen=True)
class SourceLoc:
    """A position in a deck file: 1-based line and column."""

    file: str
    line: int
    column: int = 1

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


class SpacarError(Exception):
    """Base class of every error spacarpy reports to a user."""

    exit_code = EXIT_SOLVER


class Terminated(KeyboardInterrupt):
    """Raised by the command line's SIGTERM handler: ends a run the way Ctrl-C does (the
    result file closed with its ``error`` attribute set), then exit 143."""


class DeckError(SpacarError):
    """One or more errors in a deck, each with its location.

    ``items`` is a list of ``(SourceLoc | None, message, source_line | None)``. ``str()`` gives
    ``file:line:col: error: message`` lines, each followed by the source line and a caret.
    """

    exit_code = EXIT_INPUT

    def __init__(self, items):
        if isinstance(items, tuple) and len(items) in (2, 3) and isinstance(items[1], str):
            items = [items]
        self.items = [tuple(it) + (None,) * (3 - len(it)) for it in items]
        super().__init__(self._format())

    @property
    def loc(self) -> SourceLoc | None:
        return self.items[0][0] if self.items else None

    def _format(self) -> str:
        out = []
        for loc, msg, src in self.items:
            head = f"{loc}: error: {msg}" if loc is not None else f"error: {msg}"
            out.append(head)
            if src is not None and loc is not None:
                out.append("    " + src.rstrip("\n").expandtabs(1))
                out.append("    " + " " * max(loc.column - 1, 0) + "^")
        if len(self.items) > 1:
            out.append(f"{len(self.items)} errors")
        return "\n".join(out)


class ModelError(SpacarError):
    """The deck is syntactically fine but the model cannot be analysed (names nodes/elements)."""

    exit_code = EXIT_MODEL


class SolverError(SpacarError):
    """An analysis failed: non-convergence, singular system during the solve, ..."""

    exit_code = EXIT_SOLVER


class ConvergenceError(SolverError):
    """Newton iterations did not converge even after the allowed step cuts."""


class UserCodeRefused(SpacarError):
    """The deck names user routines (USERSIG/USERINP), which are code, and the command was
    not given ``--allow-user-code``: refused before any work (exit 5)."""

    exit_code = EXIT_USER_CODE_REFUSED


class UserRoutineError(SpacarError):
    """A user routine raised, returned the wrong shape or a value that is not finite, or
    cannot be loaded (exit 6); the steps computed before it are kept."""

    exit_code = EXIT_USER_ROUTINE


class DiskFull(SpacarError):
    """The file system ran out of space (or quota) while an output was written (exit 1).

    The command removes what it was writing; an older file at the output path is kept."""

    exit_code = EXIT_SOLVER


_DISK_FULL_ERRNOS = (28, 122)          # ENOSPC, EDQUOT (Linux)
_DISK_FULL_TEXT = ("No space left on device", "Disk quota exceeded", "errno = 28",
                   "errno = 122")


def is_disk_full(exc: BaseException | None) -> bool:
    """Whether ``exc``, or an exception it was raised from or during, is a full disk or an
    exceeded quota: an ``OSError`` with ``ENOSPC``/``EDQUOT``, or an HDF5 error (h5py raises
    ``RuntimeError``/``OSError`` whose text quotes the failed write's errno)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, OSError) and exc.errno in _DISK_FULL_ERRNOS:
            return True
        if isinstance(exc, (OSError, RuntimeError)) and \
                any(t in str(exc) for t in _DISK_FULL_TEXT):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


def disk_full_text(exc: BaseException | None) -> str:
    """"No space left on device" or "Disk quota exceeded", from ``exc`` or its causes."""
    while exc is not None:
        for text in ("Disk quota exceeded", "No space left on device"):
            if text in str(exc) or (isinstance(exc, OSError) and exc.strerror == text):
                return text
        exc = exc.__cause__ or exc.__context__
    return "No space left on device"

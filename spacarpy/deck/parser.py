"""Deck text -> checked :class:`~spacarpy.deck.statement.Statement` records (syntax only, no
model semantics): :func:`parse_deck`, :func:`parse_deck_tables` and the general per-line path.

The reader (:class:`_Reader`) goes through a text line by line. A line of a keyword and plain
numbers (nearly every line of a large deck) goes to the fast path
(:mod:`spacarpy.deck.fastpath`), which converts it in a batch with the other lines of its
keyword and sends a line that is not simply correct back here. Every other line is lexed
(:mod:`spacarpy.deck.lexer`: without Lark where it can be, with Lark for the column of an
unreadable field) and checked as one record: its fields converted
(:mod:`spacarpy.deck.fields`), the module structure tracked (:mod:`spacarpy.deck.structure`),
SET / INCLUDE / ranges / expressions applied (:mod:`spacarpy.deck.extensions`). The parts are
mixins of the one reader because they share its state (the output, the errors in reading
order, the parameters, the current module); the general and the fast path must give identical
statements (tests/test_deck_fast.py compares them on every deck). Every problem is a
:class:`spacarpy.errors.DeckError` item with file, line and column; Lark's own exceptions
never escape.
"""
from __future__ import annotations

import contextlib
import gc
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from spacarpy.deck.extensions import (
    _Extensions,
)
from spacarpy.deck.fastpath import (
    ParsedDeck,
    PlainTable,
    _FastPath,
    _RangeTable,
    _scan,
)
from spacarpy.deck.fields import (
    _FieldChecks,
    _RangeRows,
)
from spacarpy.deck.lexer import (
    _BLANK_LINE,
    _COMMENT_START,
    _lex_line,
    _Record,
    _Source,
)
from spacarpy.deck.statement import (
    Statement,
    _RangeStatement,
)
from spacarpy.deck.structure import (
    _ModuleStructure,
)
from spacarpy.errors import DeckError, SourceLoc

if TYPE_CHECKING:                      # Lark is imported only when a line needs it
    from lark import Token

__all__ = ["gc_paused", "parse_deck", "parse_deck_tables"]

#: In a text scanned at once (fastpath._SCAN_LINES), runs of at least this many simple lines
#: are appended to their batches at once (_FastPath.run).
_RUN_LINES = 32

def parse_deck(text: str, filename: str = "<deck>", *,
               overrides: Mapping[str, object] | None = None) -> list[Statement]:
    """Parse deck text into checked statements.

    Parameters
    ----------
    text : str
        The deck.
    filename : str
        Used in error locations, and to find the files of ``INCLUDE`` lines (relative to its
        directory; the current directory if the name is not a path such as ``"<deck>"``).
    overrides : mapping of str to number or str, optional
        ``--set name=value``: replaces the value of the deck's ``SET name`` line. The value is a
        number or an expression (with or without braces) that may use the parameters set
        before that line. Naming a parameter the deck does not SET is an error.

    Returns
    -------
    list of Statement
        In deck order (included files in place of their INCLUDE line), including END, HALT,
        SET and the VISUALIZATION section (module -1). INCLUDE lines themselves are dropped.

    Raises
    ------
    DeckError
        With every problem found, each with file:line:column, in deck order.
    """
    return _parse(text, filename, overrides, frozenset()).statements


def parse_deck_tables(text: str, filename: str = "<deck>", *,
                      overrides: Mapping[str, object] | None = None,
                      keywords=frozenset()) -> ParsedDeck:
    """:func:`parse_deck`, with the plain lines of ``keywords`` (a keyword and numbers, many
    of them, simply correct) given as :class:`PlainTable` s instead of one statement each:
    the deck semantics read a large deck's nodes and elements as arrays
    (:mod:`spacarpy.deck.semantics.arrays`). ``ParsedDeck.materialize()`` gives what
    :func:`parse_deck` gives; the errors are the same."""
    return _parse(text, filename, overrides, frozenset(keywords))


def _parse(text: str, filename: str, overrides, keywords: frozenset) -> ParsedDeck:
    reader = _Reader(overrides, keywords)
    path = None if filename.startswith("<") else Path(filename)
    with gc_paused():
        reader.read(text, filename, path)
        reader.flush()
        reader.finish()
    if reader.errors:
        reader.errors.sort(key=lambda it: it[0])
        raise DeckError([it[1:] for it in reader.errors])
    return ParsedDeck(reader.out, reader.tables)


@contextlib.contextmanager
def gc_paused():
    """Pause Python's cyclic garbage collector for the block (reading and building a model).

    A deck of 10^5 elements makes millions of small objects (statements, locations, tuples),
    none of them in a reference cycle; the collector's passes over them, again and again as
    they accumulate, took more time than the reading itself.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


class _Reader(_FastPath, _ModuleStructure, _Extensions, _FieldChecks):
    """Reads files record by record: module structure, parameters, includes, all errors."""

    def __init__(self, overrides, table_keywords=frozenset()):
        self.errors: list = []          # (sort key, loc, message, source line)
        self.out: list[Statement] = []
        self.table_keywords = table_keywords   # plain lines of these become PlainTables
        self.tables: list[PlainTable] = []
        self.params: dict[str, float] = {}
        self.param_locs: dict[str, SourceLoc] = {}
        self.overrides = {str(k): v for k, v in (overrides or {}).items()}
        self.overrides_used: set[str] = set()
        self.order = 0                  # records read so far (sort key of errors)
        self.module = 0
        self.prev_end = False           # the previous record was END
        self.any_end = False            # an END or HALT was seen
        self.closed = False             # END END seen: only VISUALIZATION may follow
        self.visual = False             # inside the VISUALIZATION section
        self.stopped = False            # text after the final END: stop reading
        self.module_start: SourceLoc | None = None
        self.structure_error = False    # a missing END was reported already
        self.unknown_uses: list = []    # (error index, name) of unknown parameters
        self.last: tuple[_Source, int] | None = None   # where the last record is (file, line)
        self.stack: list[Path] = []     # files being read (include cycle detection)
        self.included: dict = {}        # resolved INCLUDEd file -> its first INCLUDE line
        self.batches: dict = {}         # plain lines waiting for conversion (see flush)

    # ---------------------------------------------------------------- errors
    def error(self, loc: SourceLoc | None, message: str, source: _Source | None = None) -> None:
        """Record a problem; problems are reported in reading order (no location first)."""
        src = source.line(loc.line) if (source is not None and loc is not None) else None
        key = (1, self.order, loc.column) if loc is not None else (0, 0, 0)
        self.errors.append((key, loc, message, src))

    def loc(self, rec: _Record, tok: Token, column: int | None = None) -> SourceLoc:
        return SourceLoc(rec.source.name, tok.line, tok.column if column is None else column)

    # ---------------------------------------------------------------- files
    def read(self, text: str, name: str, path: Path | None) -> None:
        raw = text.split("\n")
        source = _Source(name, path, raw)
        if path is not None:
            self.stack.append(path.resolve())
        # the fast path, for a line that may be a keyword and numbers: its numbers are
        # converted in a batch (flush), which sends a line that is not simply correct back to
        # the general path (lexed, checked and reported as any other line). The reader's state
        # is kept in locals between general records, which are the only ones to change it.
        batch_of: dict = {}             # (first word, tokens, module) -> _Batch or None
        out = self.out
        order, module = self.order, self.module
        fast = not (self.visual or self.closed)
        last_fast = 0                   # the last line batched since the last general record
        # a large deck: runs of simple lines appended to their batches at once (see run)
        scan = _scan(text, raw)
        events: dict = {}
        try:
            number, n_lines = 0, len(raw)
            while number < n_lines:
                if scan is not None and fast:
                    data = module >= 1
                    if data not in events:
                        events[data] = self.events(scan, data)
                    ev = events[data]
                    k = int(np.searchsorted(ev, number))
                    end = int(ev[k]) if k < len(ev) else n_lines
                    if end - number >= _RUN_LINES:
                        lines = number + np.flatnonzero(scan.n_tokens[number:end] > 0)
                        if len(lines):
                            self.run(scan, lines, order, module, source, batch_of)
                            order += len(lines)
                            last_fast = int(lines[-1]) + 1
                        number = end
                        continue
                line = raw[number]
                number += 1
                if "#" in line or "%" in line:
                    data = _COMMENT_START.split(line, 1)[0]
                    parts = data.split()
                    if not parts and not _BLANK_LINE.fullmatch(line):
                        parts = None       # not blank after all (not expected)
                else:
                    parts = line.split()
                if not parts:
                    if parts is not None:
                        continue           # blank, or a comment only
                elif fast and ":" not in line and "{" not in line and '"' not in line:
                    key = (parts[0], len(parts), module)
                    batch = batch_of.get(key, False)
                    if batch is False:
                        batch = batch_of[key] = self.batch(parts[0], len(parts) - 1, source)
                    if batch is not None:
                        order += 1
                        batch.where.append((len(out), order, number))
                        batch.texts.extend(parts[1:])
                        out.append(None)
                        last_fast = number
                        continue
                if last_fast:
                    self.prev_end, self.last, last_fast = False, (source, last_fast), 0
                self.order = order + 1
                try:
                    rec = _lex_line(source, number)
                except Exception as exc:  # pragma: no cover - every character is some token
                    from lark.exceptions import UnexpectedInput
                    if not isinstance(exc, UnexpectedInput):
                        raise
                    col = getattr(exc, "column", None)
                    col = col if isinstance(col, int) and col > 0 else 1
                    self.errors.append(((1, self.order, 0), SourceLoc(name, number, col),
                                        "cannot read this line", source.line(number)))
                    break
                self.record(rec)
                if self.stopped:
                    break
                order, fast = self.order, not (self.visual or self.closed)
                if self.module != module:
                    module, batch_of = self.module, {}
        finally:
            if last_fast:
                self.prev_end, self.last = False, (source, last_fast)
            self.order = order
            if path is not None:
                self.stack.pop()

    def last_record(self) -> _Record | None:
        """The last record read (lexed again: the fast path keeps no tokens)."""
        return _lex_line(*self.last) if self.last is not None else None

    def emit(self, rec: _Record, keyword: str, converted: list, module: int) -> None:
        """Output the statements of a record: ``converted`` is a list of
        ``(fields, field_locs)``, one per statement (see check_fields)."""
        loc = self.loc(rec, rec.head)
        source_line = rec.source.line(rec.head.line) or ""
        if isinstance(converted, _RangeRows):      # a table: one row per number
            numbers, rest = converted.numbers, converted.rest
            first = Statement(keyword, (numbers[0],) + rest, loc, converted.locs, source_line,
                              module)
            values = np.empty((len(numbers), 1 + len(rest)))
            values[:, 0] = np.arange(numbers.start, numbers.stop, numbers.step)
            values[:, 1:] = rest
            kinds = (("int", False),) + tuple(("int" if type(v) is int else "float", False)
                                              for v in rest)
            slots = np.arange(len(self.out), len(self.out) + len(numbers), dtype=np.int64)
            self.tables.append(_RangeTable(first, kinds, slots, values))
            self.out.extend([None] * len(numbers))
            return
        first = Statement(keyword, converted[0][0], loc, converted[0][1], source_line, module)
        self.out.append(first)
        if len(converted) > 1:          # a range: one statement per number, the same places
            self.out.extend([_RangeStatement(first, fields) for fields, _ in converted[1:]])

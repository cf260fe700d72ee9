"""Deck text -> checked :class:`Statement` records (syntax only, no model semantics).

Lark (``grammar.lark``) splits each line into a keyword record; the grammar accepts any line, so
that every problem is found and reported at once. This module then checks every record against
the keyword table of :mod:`spacarpy.deck.keywords` (known keyword, field count, field types),
converts the fields to ints/floats/strings, and tracks the module structure (END / HALT / END
END / VISUALIZATION). It also implements the spacarpy extensions that act on the text: ``SET``
parameters, ``{expression}`` fields (:mod:`spacarpy.expressions`), ``1:48`` ranges and
``INCLUDE "file"``. Every problem is a :class:`spacarpy.errors.DeckError` item with file, line
and column; Lark's own exceptions never escape.

A line of a keyword and plain numbers (nearly every line of a large deck) takes a fast path
that gives the same statements: its numbers are converted in a batch with the other lines of
its keyword (:class:`_Batch`), and its statement makes its locations only when asked for. Lines
of readable fields are lexed without Lark (:func:`_simple_tokens`); Lark and the
expressions are imported at the first line that needs them.

The module is longer than most (about 1200 lines) because the general path and the fast path
must give identical statements: both share the field conversion and the module tracking here,
and splitting them would separate code that has to change together.
"""
from __future__ import annotations

import contextlib
import difflib
import functools
import gc
import logging
import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from itertools import accumulate
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from spacarpy.deck.keywords import (
    KEYWORDS,
    KIND_DESCRIPTIONS,
    VISUALIZATION_KEYWORDS,
    FieldSpec,
    KeywordSpec,
)
from spacarpy.deck.linescan import LineScan
from spacarpy.errors import DeckError, SourceLoc

if TYPE_CHECKING:                      # Lark is imported only when a line needs it
    from lark import Token

__all__ = ["MAX_RANGE", "ParsedDeck", "PlainTable", "Statement", "parse_deck", "parse_deck_tables",
           "read_deck_text", "read_text"]

logger = logging.getLogger(__name__)

# The grammar accepts every sequence of tokens, so lexing is all the parsing a deck needs: a
# record is the tokens of one line (no token spans a line end). Lexing alone is twice as fast as
# building the parse tree.
_GRAMMAR = Path(__file__).with_name("grammar.lark")


def _expr():
    """:mod:`spacarpy.expressions` (and with it Lark), imported at the first line that needs
    it: a deck of plain lines is read without either."""
    import spacarpy.expressions
    return spacarpy.expressions


@functools.lru_cache(maxsize=1)
def _lark():
    """The compiled grammar, loaded (with Lark) at the first line that is not plain."""
    from spacarpy.grammars import lalr_parser
    return lalr_parser(_GRAMMAR, lexer="basic")


def _grammar_terminals(names) -> dict:
    """The regular expressions of some terminals, read from the grammar's text (the fast path
    needs no Lark; tests/test_deck_fast.py checks them against Lark's compiled ones)."""
    text = _GRAMMAR.read_text(encoding="utf-8")
    return {name: re.search(rf"^{name}(?:\.\d+)?:\s*/(.*)/\s*$", text, re.M).group(1)
            for name in names}


# Lark lexes a few ten thousand tokens a second: most of the time of reading a deck of 10^5
# elements, nearly all of whose lines are a keyword and plain numbers ("BEAM 7 13 14 15 16 0 1 0").
# Such a line takes a fast path (_Reader.read, _Batch): split, its first token checked against
# the grammar's WORD, its numbers converted in a batch (a text of the characters of numbers is a
# NUMBER exactly when float() reads it; any other text is checked against NUMBER). Its
# locations, when asked for, come from _PLAIN_LINE, made of the grammar's own terminals, at the
# columns Lark would give. Every other line (strings, {expressions}, ranges, unreadable fields,
# ...) and every plain line that is not simply correct is lexed and checked by the general
# code, which reports all errors.
_TERMINALS = _grammar_terminals(("WORD", "NUMBER", "STRING", "RANGE", "EXPR", "COMMENT"))
_PLAIN_LINE = re.compile(r"{ws}*(?P<data>{word}(?:{ws}+{number})*){ws}*(?:{comment})?".format(
    ws=r"[^\S\n]", word=_TERMINALS["WORD"], number=_TERMINALS["NUMBER"],
    comment=_TERMINALS["COMMENT"]))
_PLAIN_FIELD = re.compile(r"[^\s#%]+")
_WORD = re.compile(_TERMINALS["WORD"])
_NUMBER = re.compile(_TERMINALS["NUMBER"])
#: A character that no NUMBER of the fast path has (see _Batch.convert).
_NOT_NUMBER_CHAR = re.compile(r"[^0-9+\-.eEdD]")
_COMMENT_START = re.compile(r"[#%]")
#: A line of readable fields only (see _simple_tokens), and one such token: the grammar's
#: terminals but BAD. At any place at most one of them matches (each must end at a blank, a
#: comment or the line's end), so their order here cannot differ from Lark's priorities.
_SIMPLE_KINDS = ("RANGE", "EXPR", "STRING", "WORD", "NUMBER")
_SIMPLE_TOKEN = re.compile("|".join(f"(?P<{k}>{_TERMINALS[k]})" for k in _SIMPLE_KINDS))
_ANY_SIMPLE = "|".join(f"(?:{_TERMINALS[k]})" for k in _SIMPLE_KINDS)
_SIMPLE_LINE = re.compile(r"{ws}*(?P<data>(?:{tok})(?:{ws}+(?:{tok}))*)?{ws}*(?:{comment})?".format(
    ws=r"[^\S\n]", tok=_ANY_SIMPLE, comment=_TERMINALS["COMMENT"]))
_BLANK_LINE = re.compile(r"{ws}*(?:{comment})?".format(ws=r"[^\S\n]",
                                                       comment=_TERMINALS["COMMENT"]))
#: Keywords whose records always take the general path (module structure, parameters, files).
_GENERAL_KEYWORDS = frozenset({"END", "HALT", "INCLUDE", "SET", "VISUALIZATION"})

#: Largest magnitude accepted for a whole-number field (node/element numbers, counts).
_INT_LIMIT = 2**31 - 1
#: Batches of fewer lines are converted line by line (see _Batch.convert).
_SMALL_BATCH = 16
#: Texts of fewer lines are read line by line; in longer ones, runs of at least _RUN_LINES
#: simple lines are appended to their batches at once (_Reader.run).
_SCAN_LINES = 2048
_RUN_LINES = 32
#: Most numbers a single range (``1:48``) may stand for.
MAX_RANGE = 1_000_000
#: Deepest chain of INCLUDEs (cycles are reported before this is reached).
_MAX_INCLUDE_DEPTH = 32

_INT_TEXT = re.compile(r"[+-]?\d+")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_RANGE_PART = re.compile(r"\{[^}]*\}|\d+")
_GLUED = re.compile(r"([A-Z]+)([+-]?\d[\d.eE+-]*)")


class Statement:
    """One checked keyword record of a deck (read-only by convention; compared and hashed by
    value).

    Attributes
    ----------
    keyword : str
        The keyword in upper case.
    fields : tuple
        The fields converted as the keyword table says (int, float or str). Expressions are
        evaluated and ranges expanded: ``DYNE 1:3 1 2`` gives three statements, one per
        element; ``FIX 7 1:3`` gives the fields ``(7, 1, 2, 3)``.
    loc : SourceLoc
        Where the keyword is.
    field_locs : tuple of SourceLoc
        Where each field is (all the numbers of a range share the range's location).
    source_line : str
        The deck line, without its line end.
    module : int
        0-based index of the END-closed module the record is in; -1 for the VISUALIZATION
        section.
    origin : str or None
        For statements made by a generator (BEAMS, BEAMARC): its keyword; None otherwise.
    file, line : str, int
        ``loc.file`` and ``loc.line``, without making ``loc``.

    The statements of plain lines (a keyword and numbers, the fast path) make ``loc``,
    ``field_locs`` and ``source_line`` only when asked for (an error, ``spacarpy check``):
    a deck of 10^5 elements then needs no location objects at all.
    """

    __slots__ = ("keyword", "fields", "module", "origin", "file", "line", "_loc",
                 "_field_locs", "_source_line", "_src")

    def __init__(self, keyword: str, fields: tuple, loc: SourceLoc, field_locs: tuple,
                 source_line: str, module: int, origin: str | None = None):
        self.keyword = keyword
        self.fields = fields
        self.module = module
        self.origin = origin
        self.file = getattr(loc, "file", None)
        self.line = getattr(loc, "line", None)
        self._loc = loc
        self._field_locs = field_locs
        self._source_line = source_line
        self._src = None

    @property
    def loc(self) -> SourceLoc:
        if self._src is not None:
            self._locate()
        return self._loc

    @property
    def field_locs(self) -> tuple:
        if self._src is not None:
            self._locate()
        return self._field_locs

    @property
    def source_line(self) -> str:
        if self._src is not None:
            self._locate()
        return self._source_line

    def _locate(self) -> None:
        """The locations of a fast-path statement, from its line (lexed as the fast path
        lexed it)."""
        src, line = self._src, self.line
        _, columns = _plain_fields(src.raw[line - 1])
        self._loc = SourceLoc(src.name, line, columns[0])
        self._field_locs = tuple(SourceLoc(src.name, line, column) for column in columns[1:])
        self._source_line = src.line(line)
        self._src = None

    #: The attributes that make a statement (its constructor's arguments), in order.
    _ATTRIBUTES = ("keyword", "fields", "loc", "field_locs", "source_line", "module", "origin")

    def _key(self) -> tuple:
        return tuple(getattr(self, name) for name in self._ATTRIBUTES)

    def __eq__(self, other):
        if not isinstance(other, Statement):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __repr__(self) -> str:
        return ("Statement(" + ", ".join(f"{name}={value!r}" for name, value in zip(
            self._ATTRIBUTES, self._key())) + ")")

    def replace(self, **changes) -> Statement:
        """A copy with some attributes changed (as ``dataclasses.replace``)."""
        return Statement(**{**dict(zip(self._ATTRIBUTES, self._key())), **changes})

    @property
    def spec(self) -> KeywordSpec:
        """The field layout the record was read with (the data-module form where it has
        one)."""
        spec = KEYWORDS.get(self.keyword) or VISUALIZATION_KEYWORDS[self.keyword]
        if self.module > 0 and spec.data_form is not None:
            return spec.data_form
        return spec

    def value(self, name: str, default=None):
        """The value of the field called ``name`` (the ``short`` name of its
        :class:`~spacarpy.deck.keywords.FieldSpec`, e.g. ``st.value("rho_inf")``), or
        ``default`` if the record leaves that optional field out. A variadic field gives its
        first value."""
        i = self.spec.field(name)[0]
        return self.fields[i] if i < len(self.fields) else default

    def values(self, name: str) -> tuple:
        """The values from the field called ``name`` to the end (variadic fields)."""
        return tuple(self.fields[self.spec.field(name)[0]:])

    def loc_of(self, name: str) -> SourceLoc:
        """Where the field called ``name`` is (the keyword's location if it is left out)."""
        i = self.spec.field(name)[0]
        return self.field_locs[i] if i < len(self.field_locs) else self.loc

    def field_spec(self, name: str) -> FieldSpec:
        """The :class:`~spacarpy.deck.keywords.FieldSpec` of the field called ``name``."""
        return self.spec.field(name)[1]

    def __getitem__(self, name: str):
        """``st["rho_inf"]``: the value of a field by name (KeyError if left out)."""
        i = self.spec.field(name)[0]
        if i >= len(self.fields):
            raise KeyError(f"{self.keyword}: the {name} field is not given")
        return self.fields[i]


#: Largest deck file read (a 10^5-element deck is about 10 MB): a bigger file is refused
#: before it fills the memory (``run /dev/urandom``, a log file given by mistake).
MAX_DECK_BYTES = 512 * 2**20
_SNIFF_BYTES = 8192
#: The source of tables that make their statements without reading their line again.
_NO_SOURCE = None
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


class NotADeckError(OSError):
    """The file is not a text deck (binary data, or larger than :data:`MAX_DECK_BYTES`)."""


def read_text(path) -> str:
    """Read a deck file as text: UTF-8 (a byte-order mark is dropped), else latin-1.

    Binary files are refused from their first bytes (a NUL byte: HDF5 results, /dev/zero,
    executables), files above :data:`MAX_DECK_BYTES` after reading that much, so that no
    input fills the memory or is echoed raw to a terminal.

    Raises
    ------
    OSError
        If the file cannot be read or is not a text deck (:class:`NotADeckError`); the caller
        turns it into a DeckError.
    """
    _refuse_blocking(path)
    with open(path, "rb") as fh:
        head = fh.read(_SNIFF_BYTES)
        if head.startswith(_HDF5_SIGNATURE):
            raise NotADeckError("not a deck but an HDF5 file (a result file?)")
        if _utf16(head):
            raise NotADeckError("not a text deck this reader takes: it is UTF-16 encoded; "
                                "save it as UTF-8 (or ASCII)")
        if b"\0" in head:
            raise NotADeckError("not a text deck: it holds binary data (NUL bytes in its "
                                f"first {len(head)} bytes)")
        raw = head + fh.read(MAX_DECK_BYTES + 1 - len(head)) if len(head) == _SNIFF_BYTES \
            else head
        if len(raw) > MAX_DECK_BYTES:
            raise NotADeckError(f"larger than {MAX_DECK_BYTES // 2**20} MB; not read (a deck "
                                "of 10^5 elements is about 10 MB)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    return text.removeprefix("\ufeff")


def _refuse_blocking(path) -> None:
    """Refuse a FIFO or a socket before opening it: ``open`` would wait forever for a
    writer (``INCLUDE "fifo"``)."""
    import stat
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return                          # open() reports it
    if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode):
        kind = "a FIFO (named pipe)" if stat.S_ISFIFO(mode) else "a socket"
        raise NotADeckError(f"not a deck file but {kind}: not opened (reading it could "
                            "wait forever)")


def _utf16(head: bytes) -> bool:
    """UTF-16 text: a byte-order mark, or ASCII with a NUL byte beside every character."""
    if head[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return True
    if len(head) < 4:
        return False
    even, odd = head[0::2], head[1::2]
    return (even.count(0) == len(even) and 0 not in odd) or \
        (odd.count(0) == len(odd) and 0 not in even)


def _os_reason(exc: OSError) -> str:
    if isinstance(exc, NotADeckError):
        return str(exc)
    if isinstance(exc, FileNotFoundError):
        return "no such file"
    if isinstance(exc, IsADirectoryError):
        return "it is a directory"
    return exc.strerror or str(exc)


def read_deck_text(path) -> str:
    """Read a deck file as text (see :func:`read_text`).

    Raises
    ------
    DeckError
        If the file cannot be read.
    """
    try:
        return read_text(path)
    except OSError as exc:
        raise DeckError((None, f"cannot read deck '{path}': {_os_reason(exc)}")) from None


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


# --------------------------------------------------------------------------- lexical level

@dataclass
class _Source:
    """One file being read."""

    name: str                 # as shown in messages
    path: Path | None         # where it is (None for text without a file)
    raw: list[str]            # the lines as read

    def line(self, n: int) -> str | None:
        """Line n as shown (without a carriage return at the end)."""
        return self.raw[n - 1].rstrip("\r") if 1 <= n <= len(self.raw) else None


@dataclass(frozen=True)
class _Record:
    head: Token
    fields: tuple
    source: _Source


def _lex_line(source: _Source, number: int) -> _Record | None:
    """Lex line ``number`` with Lark: its record, or None for a blank or comment line.

    Raises
    ------
    UnexpectedInput
        Not expected: every character is some token.
    """
    line = source.raw[number - 1]
    tokens = _simple_tokens(line, number)
    if tokens is None:
        tokens = list(_lark().lex(line))
        for tok in tokens:
            tok.line = tok.end_line = number
    if not tokens:
        return None
    return _Record(tokens[0], tuple(tokens[1:]), source)


class _Token(str):
    """A token of :func:`_simple_tokens`: the text with the attributes of a Lark ``Token``
    that the parser uses (type, line, column, end_line, end_column)."""


def _simple_tokens(line: str, number: int):
    """The tokens of a line of readable fields only (``DEFORMATIONS modified``, ``END``,
    ``EXPECT run.exit_code 1``, ``DYNE 1:10 1 2 3``, ``X 3 {L/2} 0 0``), as Lark lexes them,
    without Lark; None for a line with an unreadable field (BAD): Lark lexes those, for its
    error's column. (Importing Lark and building its lexer takes 30 ms: a tenth of the whole
    run of a small deck whose elements are given as ranges.)"""
    simple = _SIMPLE_LINE.fullmatch(line)
    if simple is None:
        return None
    tokens = []
    for m in _SIMPLE_TOKEN.finditer(line, *simple.span("data")):
        tok = _Token(m.group())
        tok.type = m.lastgroup
        tok.line = tok.end_line = number
        tok.column = m.start() + 1
        tok.end_column = m.end() + 1
        tokens.append(tok)
    return tokens


def _scan(text: str, raw: list) -> LineScan | None:
    """The :class:`~spacarpy.deck.linescan.LineScan` of a large ASCII text, else None (a few
    lines are cheaper read one by one)."""
    if len(raw) < _SCAN_LINES or not text.isascii():
        return None
    return LineScan(text)


def _plain_fields(line: str):
    """The fast path's lexer (see _PLAIN_LINE): ``(texts, columns)`` of the tokens of a line
    that is a keyword followed by plain numbers, the tokens and columns Lark would give; None
    for any other line."""
    plain = _PLAIN_LINE.fullmatch(line)
    if plain is None:
        return None
    start, end = plain.span("data")
    texts = plain["data"].split()
    # nearly always the fields are one blank apart: then the columns follow from the lengths
    columns = list(accumulate([len(text) + 1 for text in texts[:-1]], initial=start + 1))
    if columns[-1] + len(texts[-1]) - 1 != end:
        columns = [tok.start() + 1 for tok in _PLAIN_FIELD.finditer(line, start, end)]
    return texts, columns


def _bad_token_message(tok: Token) -> str:
    """Why a BAD token (a run of characters that is no field) cannot be read."""
    text = str(tok)
    first = text[0]
    if first == '"':
        if text.count('"') >= 2:
            return f"cannot read '{text}': put a blank after the closing quote"
        return "unterminated string: a quoted string must end on the same line"
    if first == "{":
        if "}" in text:
            return (f"cannot read '{text}': an {{expression}} must be followed by a blank "
                    "(ranges look like 1:{n})")
        return ("unterminated expression: '{' needs a matching '}' on the same line (blanks "
                "inside the braces are fine)")
    if ":" in text and (first.isdigit() or first == "{"):
        return f"cannot read the range '{text}': ranges look like 1:48 or 1:2:47 (first:step:last)"
    if first.isdigit() or first in "+-.":
        hint = ""
        if re.fullmatch(r"[+-]?[\d.]+[-+*/^][\d.()+\-*/^]+", text):
            hint = f"; for arithmetic use braces: {{{text}}}"
        return (f"cannot read '{text}': not a number (numbers look like 3, -1.5, .5, "
                f"2.0e-3; separate fields with blanks{hint})")
    bad = next((c for c in text if not (c.isalnum() or c in "_.-")), text[0])
    if bad.isprintable() and not bad.isspace():
        return (f"unexpected character '{bad}' in '{text}' (fields are numbers, words, "
                "\"strings\" or {expressions})")
    return f"unexpected character U+{ord(bad):04X} in this field"


# --------------------------------------------------------------------------- field checks

class _FieldError(Exception):
    """A field did not match its spec (internal: collected, then raised as DeckError)."""

    def __init__(self, index: int, message: str, offset: int = 0):
        super().__init__(message)
        self.index = index
        self.message = message
        self.offset = offset           # columns after the start of the field


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:                  # a Fortran exponent: 1.0D-3
        return float(text.replace("d", "e").replace("D", "e"))


def _expected(keyword: str, spec: FieldSpec, tok: Token) -> str:
    return f"{keyword}: expected the {spec.name} ({KIND_DESCRIPTIONS[spec.kind]}), found '{tok}'"


def _count_phrase(spec: KeywordSpec) -> str:
    counts = spec.counts
    if spec.variadic is not None:
        return f"at least {counts[0]} field{'s' if counts[0] != 1 else ''}"
    if len(counts) == 1:
        n = counts[0]
        return "no fields" if n == 0 else f"exactly {n} field{'s' if n != 1 else ''}"
    if list(counts) == list(range(counts[0], counts[-1] + 1)):
        return f"{counts[0]} to {counts[-1]} fields"
    return ", ".join(str(c) for c in counts[:-1]) + f" or {counts[-1]} fields"


def _field_specs(spec: KeywordSpec, n: int):
    """The field specs for a record with n fields, or None if n is not an allowed count."""
    fields = list(spec.required)
    if n < len(fields):
        return None
    for group in spec.optional:
        if n == len(fields):
            return fields
        fields.extend(group)
        if n < len(fields):
            return None
    if n == len(fields):
        return fields
    if spec.variadic is None:
        return None
    return fields + [spec.variadic] * (n - len(fields))


@functools.lru_cache(maxsize=1024)
def _plain_kinds(word: str, data_module: bool, n: int):
    """For the fast path: ``(kind, positive)`` of each of the n fields of a record whose first
    token is ``word``, or None if such a record takes the general path (not a keyword,
    module structure, an unknown keyword, a wrong field count, a field that is not a
    number)."""
    if _WORD.fullmatch(word) is None:
        return None
    keyword = word.upper()
    spec = KEYWORDS.get(keyword)
    if spec is None or keyword in _GENERAL_KEYWORDS:
        return None
    if spec.data_form is not None and data_module:
        spec = spec.data_form
    specs = _field_specs(spec, n)
    if specs is None or any(f.kind not in ("int", "float") for f in specs):
        return None
    return tuple((f.kind, f.positive) for f in specs)


class _PlainStatement(Statement):
    """A statement of the fast path: its locations are made from its line when asked for."""

    __slots__ = ()

    def __init__(self, keyword: str, fields: tuple, module: int, src: _Source, line: int):
        self.keyword = keyword
        self.fields = fields
        self.module = module
        self.origin = None
        self.file = src.name
        self.line = line
        self._src = src


class _RangeStatement(Statement):
    """A statement of a range after the first: the first one's places, other fields."""

    __slots__ = ()

    def __init__(self, first: Statement, fields: tuple):
        self.keyword = first.keyword
        self.fields = fields
        self.module = first.module
        self.origin = None
        self.file = first.file
        self.line = first.line
        self._loc = first._loc
        self._field_locs = first._field_locs
        self._source_line = first._source_line
        self._src = None


def _numbers(texts: list):
    """``(values, ok)`` of the texts of numbers, two arrays: a text of the characters of
    numbers only is a NUMBER exactly when float() (or _number, for a Fortran exponent) reads
    it; any other text is checked against the grammar's NUMBER (0 and not ok if it is
    none)."""
    ok = np.ones(len(texts), dtype=bool)
    try:
        if _NOT_NUMBER_CHAR.search("".join(texts)):
            raise ValueError
        values = list(map(float, texts))
    except ValueError:              # a Fortran exponent, or a field that is no NUMBER
        values = []
        for i, text in enumerate(texts):
            try:
                if _NUMBER.fullmatch(text) is None:
                    raise ValueError
                values.append(_number(text))
            except ValueError:
                values.append(0.0)
                ok[i] = False
    return np.array(values, dtype=float), ok


def _row_tuples(table: np.ndarray, kinds: tuple) -> list:
    """The fields tuple of every row of a table of a plain keyword: Python floats and ints
    (those of whole-number fields), as the general path converts them."""
    columns = [table[:, j].tolist() if kind == "float" else table[:, j].astype(np.int64).tolist()
               for j, (kind, _) in enumerate(kinds)]
    return list(zip(*columns))


class PlainTable:
    """The plain lines (a keyword and numbers, simply correct) of one keyword, field count,
    module and file, as arrays: what :func:`parse_deck_tables` gives instead of one
    :class:`Statement` per line.

    Attributes
    ----------
    keyword : str
    kinds : tuple of (kind, positive)
        Of each field (``"int"`` or ``"float"``).
    module : int
    file : str
        The file name shown in messages.
    slots : (n,) int
        The position of each line's statement among the deck's statements.
    lines : (n,) int
        The line number of each line.
    values : (n, n_fields) float
        The fields (whole numbers as floats: exact, at most 2^31 - 1 in magnitude).
    """

    __slots__ = ("keyword", "kinds", "module", "source", "file", "slots", "lines", "values")

    def __init__(self, keyword, kinds, module, source, slots, lines, values):
        self.keyword, self.kinds, self.module, self.source = keyword, kinds, module, source
        self.file = source.name if source is not None else None
        self.slots, self.lines, self.values = slots, lines, values

    def __len__(self) -> int:
        return len(self.lines)

    def statement(self, i: int) -> Statement:
        """The statement of row i, as :func:`parse_deck` gives it."""
        return _PlainStatement(self.keyword, _row_tuples(self.values[i:i + 1], self.kinds)[0],
                               self.module, self.source, int(self.lines[i]))

    def statements(self) -> list:
        """The statements of all rows."""
        keyword, module, src, make = self.keyword, self.module, self.source, _PlainStatement
        return [make(keyword, fields, module, src, line) for fields, line in
                zip(_row_tuples(self.values, self.kinds), self.lines.tolist())]


class _RangeTable(PlainTable):
    """The statements of a range line (``DYNE 1:100000 1 2 3 4 5 6``) as a table: row i is
    the statement of the i-th number, with the places of the line (see :meth:`_Reader.emit`)."""

    __slots__ = ("first",)

    def __init__(self, first: Statement, kinds, slots, values):
        super().__init__(first.keyword, kinds, first.module, _NO_SOURCE, slots,
                         np.full(len(values), first.line, dtype=np.int64), values)
        self.first, self.file = first, first.file

    def statement(self, i: int) -> Statement:
        if i == 0:
            return self.first
        return _RangeStatement(self.first, _row_tuples(self.values[i:i + 1], self.kinds)[0])

    def statements(self) -> list:
        rows = _row_tuples(self.values[1:], self.kinds)
        return [self.first] + [_RangeStatement(self.first, fields) for fields in rows]


class _RangeRows:
    """What :meth:`_Reader.check_fields` gives for a long range of a table keyword: the
    numbers of the range and the other fields, not yet one tuple per number."""

    def __init__(self, numbers: range, rest: tuple, locs: tuple):
        self.numbers, self.rest, self.locs = numbers, rest, locs


class ParsedDeck:
    """What :func:`parse_deck_tables` gives: the statements in deck order, with None where a
    line is a row of one of the tables."""

    def __init__(self, statements: list, tables: list):
        self.statements, self.tables = statements, tables

    def general(self) -> list[tuple[int, Statement]]:
        """``(position, statement)`` of the statements that are no table rows, in deck
        order."""
        rows = np.zeros(len(self.statements), dtype=bool)
        for table in self.tables:
            rows[table.slots] = True
        statements = self.statements
        return [(i, statements[i]) for i in np.flatnonzero(~rows).tolist()]

    def materialize(self) -> list[Statement]:
        """All statements in deck order, as :func:`parse_deck` gives them."""
        out = list(self.statements)
        for table in self.tables:
            for slot, st in zip(table.slots.tolist(), table.statements()):
                out[slot] = st
        return out


class _Batch:
    """The lines of one keyword, field count, module and file that may be plain (a keyword
    and numbers), their numbers converted together (:meth:`convert`)."""

    def __init__(self, keyword: str, kinds: tuple, module: int, source: _Source):
        self.keyword, self.kinds, self.module, self.source = keyword, kinds, module, source
        self.where: list[tuple] = []    # (output slot, record order, line number) per line
        self.texts: list[str] = []      # the fields' texts, line after line
        # lines appended in runs (_Reader.read with a LineScan): (where (m, 3), the token
        # indices of their fields (m, n_fields), the scan)
        self.bulk: list[tuple] = []

    def __len__(self) -> int:
        return len(self.where) + sum(len(w) for w, _, _ in self.bulk)

    def rows(self) -> np.ndarray:
        """(slot, order, line number) of every line, (n, 3): the lines appended one by one,
        then those appended in runs (the order of :meth:`table` and :meth:`convert`)."""
        parts = [np.array(self.where, dtype=np.int64).reshape(-1, 3)]
        parts += [w for w, _, _ in self.bulk]
        return np.concatenate(parts) if self.bulk else parts[0]

    def unbulk(self) -> None:
        """The lines appended in runs as lines appended one by one (their texts cut from
        the text)."""
        for where, tokens, scan in self.bulk:
            text, start, end = scan.text, scan.tok_start, scan.tok_end
            self.where.extend(map(tuple, where.tolist()))
            self.texts.extend(text[i:j] for i, j in zip(start[tokens.ravel()].tolist(),
                                                         end[tokens.ravel()].tolist()))
        self.bulk = []

    def convert(self):
        """``(fields, ok)``: the fields tuple of every line, and for each whether it is a
        plain line (a keyword and NUMBERs) and simply correct (None: all are). Converts as
        :meth:`_Reader.convert` converts a NUMBER: float fields finite, int fields whole, at
        most _INT_LIMIT in magnitude, and at least 1 where positive (see :meth:`table`)."""
        n_fields, n_rows = len(self.kinds), len(self) if self.bulk else len(self.where)
        if n_fields == 0:
            return [()] * n_rows, None
        if n_rows < _SMALL_BATCH:
            if self.bulk:
                self.unbulk()
            return self.convert_lines()
        table, ok = self.table()
        return _row_tuples(table, self.kinds), (None if ok.all() else ok.tolist())

    def table(self):
        """``(table, ok)``: the numbers of every line as floats, (n_rows, n_fields), and for
        each line whether it is plain and simply correct (a bool array; the rows of the lines
        that are not hold 0 where a whole number was expected). A text of the characters of
        numbers only is a NUMBER exactly when float() (or _number, for a Fortran exponent)
        reads it; any other text is checked against the grammar's NUMBER."""
        n_fields = len(self.kinds)
        values, good = _numbers(self.texts)
        tables = [values.reshape(-1, n_fields)]
        oks = [np.ones(len(tables[0]), dtype=bool) if good.all() else
               good.reshape(-1, n_fields).all(axis=1)]
        for _, tokens, scan in self.bulk:
            values, good, texts = scan.numbers(tokens)
            if texts:
                values[~good], good[~good] = _numbers(texts)
            tables.append(values)
            oks.append(good.all(axis=1))
        table, ok = (np.concatenate(tables), np.concatenate(oks)) if self.bulk else \
            (tables[0], oks[0])
        with np.errstate(invalid="ignore"):
            for j, (kind, positive) in enumerate(self.kinds):
                col = table[:, j]
                if kind == "float":
                    ok &= np.isfinite(col)
                    continue
                good = (np.floor(col) == col) & (np.abs(col) <= _INT_LIMIT)
                if positive:
                    good &= col >= 1
                ok &= good
                col[~good] = 0.0
        return table, ok

    def convert_lines(self):
        """:meth:`convert` line by line (a few lines: cheaper than numpy's calls)."""
        n_fields = len(self.kinds)
        fields, ok = [], []
        for start in range(0, len(self.texts), n_fields):
            values = []
            for text, (kind, positive) in zip(self.texts[start:start + n_fields], self.kinds):
                if _NUMBER.fullmatch(text) is None:
                    break
                value = _number(text)
                if kind == "float":
                    if not math.isfinite(value):
                        break
                elif value.is_integer() and abs(value) <= _INT_LIMIT and \
                        (value >= 1 or not positive):
                    value = int(value)
                else:
                    break
                values.append(value)
            good = len(values) == n_fields
            fields.append(tuple(values) if good else None)
            ok.append(good)
        return fields, (None if all(ok) else ok)


class _Reader:
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

    def events(self, scan: LineScan, data_module: bool) -> np.ndarray:
        """The lines (0-based, ascending) :meth:`run` does not take in a module of the kind
        given: lines that are not simple, and simple lines that take the general path."""
        batchable = np.array([_plain_kinds(word, data_module, n - 1) is not None
                              for word, n in scan.combos] + [False], dtype=bool)
        blank = (scan.n_tokens == 0) & scan.simple
        return np.flatnonzero(~blank & ~batchable[scan.combo])

    def run(self, scan: LineScan, lines: np.ndarray, order: int, module: int, source: _Source,
            batch_of: dict) -> None:
        """Append simple lines (0-based numbers, ascending, all of batches: see
        :meth:`events`) to their batches, as the loop of :meth:`read` would one by one."""
        out = self.out
        combos = scan.combo[lines]
        where = np.stack([np.arange(len(out), len(out) + len(lines)),
                          order + 1 + np.arange(len(lines)), lines + 1], axis=1)
        for c in np.unique(combos).tolist():
            word, n = scan.combos[c]
            key = (word, n, module)
            batch = batch_of.get(key, False)
            if batch is False:
                batch = batch_of[key] = self.batch(word, n - 1, source)
            mine = combos == c
            tokens = scan.first_tok[lines[mine]][:, None] + np.arange(1, n)
            batch.bulk.append((where[mine], tokens, scan))
        out.extend([None] * len(lines))

    def batch(self, word: str, n_fields: int, source: _Source):
        """The batch of the lines of ``word`` with n fields in the current module of
        ``source``, or None if such lines take the general path."""
        kinds = _plain_kinds(word, self.module >= 1, n_fields)
        if kinds is None:
            return None
        key = (word.upper(), n_fields, self.module, id(source))
        batch = self.batches.get(key)
        if batch is None:
            batch = self.batches[key] = _Batch(key[0], kinds, self.module, source)
        return batch

    def flush(self) -> None:
        """Convert the batched lines (see read) and put their statements in place. A line
        that is not a keyword and NUMBERs, or whose numbers do not fit its fields (a float for
        a whole number, a non-finite number, ...), is read by the general path instead, which
        reports what is wrong."""
        again = []
        out = self.out
        tables = []
        for batch in self.batches.values():
            if batch.keyword in self.table_keywords and len(batch) >= _SMALL_BATCH \
                    and batch.kinds:
                table, ok = batch.table()
                where = batch.rows()
                if not ok.all():
                    again.extend((order, slot, number, batch) for (slot, order, number) in
                                 where[~ok].tolist())
                    where, table = where[ok], table[ok]
                tables.append(PlainTable(batch.keyword, batch.kinds, batch.module, batch.source,
                                         where[:, 0], where[:, 2], table))
                continue
            fields, ok = batch.convert()
            make = _PlainStatement
            keyword, module, src = batch.keyword, batch.module, batch.source
            where = batch.rows().tolist() if batch.bulk else batch.where
            if ok is None:
                for (slot, _, number), row in zip(where, fields):
                    out[slot] = make(keyword, row, module, src, number)
                continue
            for good, (slot, order, number), row in zip(ok, where, fields):
                if good:
                    out[slot] = make(keyword, row, module, src, number)
                else:
                    again.append((order, slot, number, batch))
        self.batches.clear()
        self.tables.extend(tables)
        if not again:
            return
        order = self.order
        for self.order, slot, number, batch in sorted(again, key=lambda a: a[0]):
            self.out = []
            rec = _lex_line(batch.source, number)
            if rec.head.type != "WORD":
                self.not_a_keyword(rec)
            else:
                keyword = str(rec.head).upper()
                spec = KEYWORDS[keyword]
                if spec.data_form is not None and batch.module >= 1:
                    spec = spec.data_form
                converted = self.check_fields(rec, keyword, spec)
                if converted is not None:
                    self.emit(rec, keyword, converted, batch.module)
            out[slot] = self.out
        if self.tables:                 # the slots of the table rows after the flattening
            sizes = np.fromiter((len(item) if isinstance(item, list) else 1 for item in out),
                                dtype=np.int64, count=len(out))
            start = np.cumsum(sizes) - sizes
            for table in self.tables:
                table.slots = start[table.slots]
        self.order, self.out = order, [x for item in out for x in
                                       (item if isinstance(item, list) else (item,))]

    def last_record(self) -> _Record | None:
        """The last record read (lexed again: the fast path keeps no tokens)."""
        return _lex_line(*self.last) if self.last is not None else None

    def include(self, rec: _Record, st_fields: tuple) -> None:
        name = st_fields[0]
        src = rec.source
        loc = self.loc(rec, rec.fields[0])
        base = src.path.parent if src.path is not None else Path(os.path.dirname(src.name))
        target = base / name
        shown = os.path.normpath(os.path.join(os.path.dirname(src.name), name)) \
            if src.path is not None else name
        try:
            resolved = target.resolve()
        except (OSError, RuntimeError):       # pragma: no cover - resolution loops
            resolved = target
        if resolved in self.stack:
            chain = " -> ".join(p.name for p in self.stack[self.stack.index(resolved):])
            self.error(loc, f"INCLUDE cycle: {chain} -> {resolved.name} (a file may not "
                            "include itself, directly or indirectly)", src)
            return
        if len(self.stack) >= _MAX_INCLUDE_DEPTH:
            self.error(loc, f"INCLUDE: files nested more than {_MAX_INCLUDE_DEPTH} deep", src)
            return
        if resolved in self.included:
            first = self.included[resolved]
            self.error(loc, f"INCLUDE '{name}': {shown} is already included (at {first}); "
                            "a file included twice would define its nodes, elements and "
                            "loads twice", src)
            return
        self.included[resolved] = loc
        try:
            text = read_text(target)
        except OSError as exc:
            self.error(loc, f"INCLUDE: cannot read '{name}' (looked for {target}): "
                            f"{_os_reason(exc)}", src)
            return
        self.read(text, shown, target)

    def finish(self) -> None:
        """Checks at the end of the deck: a missing END, unused --set overrides."""
        if self.any_end and not (self.prev_end or self.closed) and self.last is not None \
                and not self.visual and not self.structure_error:
            rec = self.last_record()
            end = (rec.fields or (rec.head,))[-1]
            loc = SourceLoc(rec.source.name, end.line, end.end_column)
            start = (f" (the last module starts at line {self.module_start.line})"
                     if self.module_start is not None else "")
            self.order += 1
            self.error(loc, "missing END at the end of the deck: close the last module with "
                            f"END, and the deck with END END{start}", rec.source)
        for i, name in self.unknown_uses:
            if name in self.param_locs and i < len(self.errors):
                key, loc, msg, src = self.errors[i]
                where = self.param_locs[name]
                msg = msg.removesuffix("; define it first with SET name value")
                msg += (f" (it is SET at line {where.line}" if where.file == loc.file
                        else f" (it is SET at {where}") + ", after its use: move the SET up)"
                self.errors[i] = (key, loc, msg, src)
        unused = [k for k in self.overrides if k not in self.overrides_used]
        for name in unused:
            known = ", ".join(self.params) if self.params else "none: the deck has no SET lines"
            self.error(None, f"--set {name}: the deck has no 'SET {name}' line to override "
                             f"(its parameters: {known})")

    # ---------------------------------------------------------------- records
    def record(self, rec: _Record) -> None:
        head = rec.head
        if head.type != "WORD":
            self.not_a_keyword(rec)
            self.prev_end = False
            return
        keyword = str(head).upper()
        if keyword in ("INCLUDE", "SET"):
            if self.closed and not self.visual:
                self.after_final_end(rec)
                return
            converted = self.check_fields(rec, keyword, KEYWORDS[keyword])
            if converted is not None:
                if keyword == "INCLUDE":
                    self.include(rec, converted[0][0])
                elif self.set_parameter(rec, converted[0]):
                    name, value = converted[0][0][0], self.params[converted[0][0][0]]
                    self.emit(rec, keyword, [((name, value), converted[0][1])],
                              -1 if self.visual else self.module)
            self.last = (rec.source, rec.head.line)
            return
        if self.visual or keyword == "VISUALIZATION":
            self.visualization(rec, keyword)
            return
        if self.closed:
            self.after_final_end(rec)
            return
        spec = KEYWORDS.get(keyword)
        if spec is None:
            self.unknown_keyword(rec, keyword)
            self.prev_end = False
            self.last = (rec.source, rec.head.line)
            return
        if spec.data_form is not None and self.module >= 1:
            spec = spec.data_form
        converted = self.check_fields(rec, keyword, spec)
        if keyword == "END":
            if self.prev_end:
                self.closed = True
                this_module = self.module - 1
            else:
                this_module = self.module
                self.module += 1
            self.prev_end = True
            self.any_end = True
        else:
            if keyword == "HALT":
                self.any_end = True
                if not self.prev_end:
                    self.structure_error = True
                    self.error(self.loc(rec, head), "missing END before HALT: HALT must directly "
                                                    "follow the END that closes a module",
                               rec.source)
                else:
                    self.module_start = self.loc(rec, head)
            this_module = self.module
            self.prev_end = False
        self.last = (rec.source, rec.head.line)
        if converted is not None:
            self.emit(rec, keyword, converted, this_module)

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

    def visualization(self, rec: _Record, keyword: str) -> None:
        if not self.visual:
            if not (self.prev_end or self.closed):
                self.structure_error = True
                self.error(self.loc(rec, rec.head),
                           "missing END before VISUALIZATION: the VISUALIZATION section comes "
                           "after the final END END", rec.source)
            self.visual = True
        spec = VISUALIZATION_KEYWORDS.get(keyword) if keyword != "VISUALIZATION" \
            else KEYWORDS["VISUALIZATION"]
        if spec is None:
            if keyword in KEYWORDS:
                self.error(self.loc(rec, rec.head),
                           f"'{rec.head}' is not a VISUALIZATION keyword: SPACAR lines must come "
                           "before the final END END (SPACAR stops reading there)", rec.source)
                return
            close = difflib.get_close_matches(keyword, list(VISUALIZATION_KEYWORDS), n=1,
                                              cutoff=0.6)
            logger.warning("%s: unknown VISUALIZATION keyword '%s' is ignored%s",
                           self.loc(rec, rec.head), rec.head,
                           f" (did you mean {close[0]}?)" if close else "")
            fields = []
            for tok in rec.fields:
                try:
                    fields.append(self.as_written(tok))
                except _FieldError:
                    fields.append(str(tok))
            self.emit(rec, keyword, [(tuple(fields), tuple(self.loc(rec, t) for t in rec.fields))],
                      -1)
            return
        converted = self.check_fields(rec, keyword, spec)
        if converted is not None:
            self.emit(rec, keyword, converted, -1)

    def after_final_end(self, rec: _Record) -> None:
        self.error(self.loc(rec, rec.head),
                   f"text after the final END: '{rec.head}' (SPACAR stops reading at END END; "
                   "only a VISUALIZATION section may follow)", rec.source)
        self.stopped = True

    def not_a_keyword(self, rec: _Record) -> None:
        head = rec.head
        loc = self.loc(rec, head)
        if head.type == "BAD":
            self.error(loc, _bad_token_message(head), rec.source)
            return
        what = {"NUMBER": "the number", "EXPR": "the expression", "RANGE": "the range",
                "STRING": "the string"}.get(head.type, "")
        msg = f"expected a keyword at the start of the line, found {what} '{head}'"
        prev = self.last_record()
        n_here = 1 + len(rec.fields)
        if prev is not None and prev.source is rec.source and prev.head.type == "WORD":
            spec = KEYWORDS.get(str(prev.head).upper())
            if spec is not None and _field_specs(spec, len(prev.fields) + n_here) is not None \
                    and _field_specs(spec, len(prev.fields)) is None:
                msg += (f" (is this the rest of the {spec.name} record on line {prev.head.line}? "
                        "a record must be on one line)")
                self.error(loc, msg, rec.source)
                return
        msg += " (every line starts with a keyword such as X, BEAM or FIX)"
        self.error(loc, msg, rec.source)

    def unknown_keyword(self, rec: _Record, keyword: str) -> None:
        tok = rec.head
        glued = _GLUED.fullmatch(keyword)
        if keyword in VISUALIZATION_KEYWORDS:
            msg = (f"'{tok}' belongs to the VISUALIZATION section, which comes after the final "
                   "END END")
        elif glued and glued.group(1) in KEYWORDS:
            msg = (f"unknown keyword '{tok}': put a blank between the keyword and the number "
                   f"('{tok[:len(glued.group(1))]} {tok[len(glued.group(1)):]}')")
        else:
            msg = f"unknown keyword '{tok}'"
            close = difflib.get_close_matches(keyword, list(KEYWORDS), n=1, cutoff=0.6)
            if close:
                msg += f" (did you mean {close[0]}?)"
        self.error(self.loc(rec, tok), msg, rec.source)

    # ---------------------------------------------------------------- parameters
    def set_parameter(self, rec: _Record, converted: tuple) -> bool:
        """Define a parameter (or apply its --set override); False after an error."""
        (name, value), locs = converted
        loc = locs[0]
        if not _NAME.fullmatch(name):
            self.error(loc, f"SET: '{name}' is not a valid parameter name (letters, digits and "
                            "'_', starting with a letter)", rec.source)
            return False
        if name in _expr().RESERVED_NAMES:
            self.error(loc, f"SET: '{name}' is a built-in name and cannot be set", rec.source)
            return False
        if name in self.params:
            first = self.param_locs[name]
            where = f"line {first.line}" if first.file == loc.file else f"{first}"
            self.error(loc, f"SET: parameter '{name}' is already set ({where}); a parameter is "
                            "set once", rec.source)
            return False
        if name in self.overrides:
            self.overrides_used.add(name)
            override = self.overrides[name]
            try:
                if isinstance(override, (int, float)) and not isinstance(override, bool):
                    value = float(override)
                    if not math.isfinite(value):
                        raise _expr().ExpressionError(0, "not a finite number")
                else:
                    text = str(override).strip()
                    if text.startswith("{") and text.endswith("}"):
                        text = text[1:-1]
                    value = _expr().evaluate(text, self.params)
            except _expr().ExpressionError as exc:
                # reported; the deck's own value is kept so that later lines are still checked
                self.error(None, f"--set {name}={override}: {exc.message}")
        self.params[name] = value
        self.param_locs[name] = loc
        return True

    # ---------------------------------------------------------------- fields
    def check_fields(self, rec: _Record, keyword: str, spec: KeywordSpec):
        """Convert the fields of one record.

        Returns a list of ``(fields, field_locs)``, one per statement (several when the first
        field is a range), or None after recording an error.
        """
        bad = [t for t in rec.fields if t.type == "BAD"]
        if bad:
            for tok in bad:
                self.error(self.loc(rec, tok), _bad_token_message(tok), rec.source)
            return None
        n = len(rec.fields)
        specs = _field_specs(spec, n)
        if specs is None:
            counts = spec.counts
            if n > counts[-1] and spec.variadic is None:
                loc = self.loc(rec, rec.fields[counts[-1]])     # the first extra field
            else:
                last = rec.fields[-1] if rec.fields else rec.head
                loc = self.loc(rec, last, last.end_column)      # where a field is missing
            self.error(loc, f"{keyword} takes {_count_phrase(spec)}, got {n} "
                            f"(usage: {spec.usage})", rec.source)
            return None
        values: list = []
        locs: list = []
        first_range = None
        ok = True
        for i, (tok, fspec) in enumerate(zip(rec.fields, specs)):
            tok_loc = self.loc(rec, tok)
            try:
                if tok.type == "RANGE":
                    numbers = self.range_values(tok, fspec, keyword, i)
                    if i == 0 and spec.range_first:
                        first_range = numbers
                        values.append(None)
                        locs.append(tok_loc)
                    elif fspec is spec.variadic and fspec.kind == "int":
                        values.extend(numbers)
                        locs.extend([tok_loc] * len(numbers))
                    else:
                        where = ("the element number of DYNE, RLSE, ESTIFF and EM and in lists "
                                 "of numbers (FIX, DYNE and RLSE modes, BEAMPROPS, ...)")
                        raise _FieldError(i, f"{keyword}: the {fspec.name} cannot be a range "
                                             f"('{tok}'); ranges are allowed for {where}")
                else:
                    values.append(self.convert(tok, fspec, keyword, i))
                    locs.append(tok_loc)
            except _FieldError as exc:
                self.error(SourceLoc(rec.source.name, tok.line, tok.column + exc.offset),
                           exc.message, rec.source)
                ok = False
        if not ok:
            return None
        locs = tuple(locs)
        if first_range is None:
            return [(tuple(values), locs)]
        rest = tuple(values[1:])
        if keyword in self.table_keywords and not self.visual and \
                len(first_range) >= _SMALL_BATCH and \
                all(type(v) in (int, float) for v in rest):
            return _RangeRows(first_range, rest, locs)
        return [((k,) + rest, locs) for k in first_range]

    def expression(self, tok: Token, index: int, text: str | None = None,
                   offset: int = 0) -> float:
        """Evaluate an {expression} field (or the part ``text`` of a range at ``offset``)."""
        text = str(tok)[1:-1] if text is None else text
        try:
            return _expr().evaluate(text, self.params)
        except _expr().ExpressionError as exc:
            if exc.unknown_name is not None:
                self.unknown_uses.append((len(self.errors), exc.unknown_name))
            raise _FieldError(index, exc.message, offset + 1 + exc.offset) from None

    def as_written(self, tok: Token, index: int = 0):
        """A field of kind "value": int, float or str as written; expressions evaluated."""
        if tok.type == "NUMBER":
            if _INT_TEXT.fullmatch(tok):
                return int(tok)
            value = _number(tok)
            if not math.isfinite(value):
                raise _FieldError(index, f"the number '{tok}' is out of range")
            return value
        if tok.type == "EXPR":
            value = self.expression(tok, index)
            whole = _expr().whole_number(value, 0.0)
            return whole if whole is not None and abs(whole) <= _INT_LIMIT else value
        if tok.type == "STRING":
            return str(tok)[1:-1]
        return str(tok)

    def convert(self, tok: Token, spec: FieldSpec, keyword: str, index: int):
        """Convert one token to the value its field spec asks for, or raise _FieldError."""
        if spec.kind == "word":
            if tok.type not in ("WORD", "STRING"):
                raise _FieldError(index, _expected(keyword, spec, tok))
            return self.as_written(tok, index)
        if spec.kind == "value":
            value = self.as_written(tok, index)
            if isinstance(value, float) and value.is_integer() and abs(value) <= _INT_LIMIT:
                value = int(value)
            return value
        if tok.type == "NUMBER":
            value = _number(tok)
            if not math.isfinite(value):
                raise _FieldError(index, f"{keyword}: the {spec.name} '{tok}' is out of range")
        elif tok.type == "EXPR":
            value = self.expression(tok, index)
        else:
            raise _FieldError(index, _expected(keyword, spec, tok))
        if spec.kind == "float":
            return value
        return self.whole(value, tok, spec, keyword, index)

    def whole(self, value: float, tok: Token, spec: FieldSpec, keyword: str, index: int) -> int:
        # int: a float with zero fractional part is accepted (SPACAR writes 5.000000); an
        # expression may be off by round-off ({0.1*30} is 3)
        if tok.type == "NUMBER":        # finite here; exactly whole (no Lark needed)
            ivalue = int(value) if value.is_integer() else None
        else:
            ivalue = _expr().whole_number(value, 1e-9)
        if ivalue is None:
            if tok.type == "EXPR":
                raise _FieldError(index, f"{keyword}: the {spec.name} must be a whole number, "
                                         f"but {tok} = {value:.10g}")
            raise _FieldError(index, _expected(keyword, spec, tok))
        if abs(ivalue) > _INT_LIMIT:
            raise _FieldError(index, f"{keyword}: the {spec.name} '{tok}' is out of range")
        if spec.positive and ivalue < 1:
            shown = f"{tok} = {ivalue}" if tok.type == "EXPR" else f"'{tok}'"
            raise _FieldError(index, f"{keyword}: the {spec.name} must be a positive whole "
                                     f"number, found {shown}")
        return ivalue

    def range_values(self, tok: Token, spec: FieldSpec, keyword: str, index: int) -> range:
        """The numbers of a range field ``first:last`` or ``first:step:last``."""
        parts = _RANGE_PART.findall(str(tok))
        numbers = []
        offset = 0
        for part in parts:
            offset = str(tok).index(part, offset)
            if part.startswith("{"):
                value = self.expression(tok, index, part[1:-1], offset)
                ivalue = _expr().whole_number(value)
                if ivalue is None:
                    raise _FieldError(index, f"{keyword}: the range '{tok}' needs whole "
                                             f"numbers, but {part} = {value:.10g}", offset)
            else:
                ivalue = int(part)
            numbers.append(ivalue)
            offset += len(part)
        if len(numbers) == 3:
            first, step, last = numbers
        else:
            (first, last), step = numbers, 1
        if step < 1:
            raise _FieldError(index, f"{keyword}: the step of the range '{tok}' must be at least "
                                     "1 (first:step:last)")
        if last < first:
            raise _FieldError(index, f"{keyword}: the range '{tok}' is empty: it must count "
                                     f"upwards (first {first} > last {last})")
        if spec.positive and first < 1:
            raise _FieldError(index, f"{keyword}: the range '{tok}' must start at 1 or more")
        if max(abs(first), abs(last)) > _INT_LIMIT:
            raise _FieldError(index, f"{keyword}: the range '{tok}' is out of range")
        values = range(first, last + 1, step)
        if len(values) > MAX_RANGE:
            raise _FieldError(index, f"{keyword}: the range '{tok}' has {len(values)} numbers; "
                                     f"at most {MAX_RANGE} are allowed")
        return values

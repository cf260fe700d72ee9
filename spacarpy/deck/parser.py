"""Deck text -> checked :class:`Statement` records (syntax only, no model semantics).

Lark (grammar.lark) reads the line structure: one keyword record per line, fields that are
numbers, words or quoted strings, comments and blank lines. This module then checks every
record against the keyword table of :mod:`spacarpy.deck.keywords` (known keyword, field count,
field types), converts the fields to ints/floats/strings, tracks the module structure
(END / HALT / END END / VISUALIZATION), and reports every problem as a
:class:`spacarpy.errors.DeckError` with file, line and column. Lark's own exceptions never
escape.
"""
from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass

from lark import Lark, Token, Transformer
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from spacarpy.deck.keywords import KEYWORDS, KIND_DESCRIPTIONS, VISUALIZATION_KEYWORDS, KeywordSpec
from spacarpy.errors import DeckError, SourceLoc

__all__ = ["Statement", "parse_deck"]

_PARSER = Lark.open("grammar.lark", rel_to=__file__, parser="lalr", lexer="contextual",
                    propagate_positions=True, maybe_placeholders=False)

#: Largest magnitude accepted for a whole-number field (node/element numbers, counts).
_INT_LIMIT = 2**31 - 1

_INT_TEXT = re.compile(r"[+-]?\d+")


@dataclass(frozen=True)
class Statement:
    """One checked keyword record of a deck.

    Attributes
    ----------
    keyword : str
        The keyword in upper case.
    fields : tuple
        The fields converted as the keyword table says (int, float or str); for leniently
        parsed keywords numbers written without '.' or exponent are ints, others floats, words
        and quoted strings str.
    loc : SourceLoc
        Where the keyword is.
    field_locs : tuple of SourceLoc
        Where each field is.
    source_line : str
        The deck line, without its line end.
    module : int
        0-based index of the END-closed module the record is in; -1 for the VISUALIZATION
        section.
    """

    keyword: str
    fields: tuple
    loc: SourceLoc
    field_locs: tuple
    source_line: str
    module: int


@dataclass(frozen=True)
class _Record:
    keyword: Token
    fields: tuple


class _ToRecords(Transformer):
    """Parse tree -> list of raw records (tokens still unconverted)."""

    def record(self, children):
        return _Record(children[0], tuple(children[1:]))

    def start(self, children):
        return list(children)


def parse_deck(text: str, filename: str = "<deck>") -> list[Statement]:
    """Parse deck text into checked statements.

    Parameters
    ----------
    text : str
        The deck.
    filename : str
        Used in error locations.

    Returns
    -------
    list of Statement
        In deck order, including END, HALT and the VISUALIZATION section (module -1).

    Raises
    ------
    DeckError
        With every problem found, each with file:line:column. A lexical error (a character or
        token that is not part of any field) stops the parse and is reported alone.
    """
    lines = [ln.rstrip("\r") for ln in text.split("\n")]
    try:
        tree = _PARSER.parse(text)
    except UnexpectedInput as exc:
        raise DeckError([_lark_error(exc, filename, lines)]) from None
    records = _ToRecords().transform(tree)
    return _StatementChecker(filename, lines).run(records)


# --------------------------------------------------------------------------- lark errors

def _line_of(lines: list[str], line: int) -> str | None:
    return lines[line - 1] if 1 <= line <= len(lines) else None


def _lark_error(exc: UnexpectedInput, filename: str, lines: list[str]):
    """Turn a lark exception into one ``(SourceLoc, message, source_line)`` item."""
    line = getattr(exc, "line", None)
    column = getattr(exc, "column", None)
    if not isinstance(line, int) or line < 1:
        line, column = len(lines), len(lines[-1]) + 1 if lines else 1
    if not isinstance(column, int) or column < 1:
        column = 1
    src = _line_of(lines, line)
    loc = SourceLoc(filename, line, column)

    if isinstance(exc, UnexpectedToken):
        tok = exc.token
        if tok.type in ("NUMBER", "STRING"):
            msg = (f"expected a keyword at the start of the line, found '{tok}' "
                   "(each record is one line: KEYWORD field field ...)")
        elif tok.type == "$END":
            msg = "unexpected end of file"
        else:
            msg = f"unexpected '{tok}'"
    elif isinstance(exc, UnexpectedCharacters):
        rest = src[column - 1:] if src is not None else ""
        run = re.match(r"\S*", rest).group(0)
        ch = rest[:1] or getattr(exc, "char", "")
        if ch == '"':
            msg = "unterminated string: a quoted string must end on the same line"
        elif ch and (ch.isdigit() or ch in "+-."):
            msg = (f"cannot read '{run}': not a number (numbers look like 3, -1.5, .5, "
                   "2.0e-3; separate fields with blanks)")
        elif ch and ch.isprintable() and not ch.isspace():
            msg = f"unexpected character '{ch}' (fields are numbers, words or \"strings\")"
        else:
            msg = f"unexpected character U+{ord(ch):04X}" if ch else "unexpected character"
    elif isinstance(exc, UnexpectedEOF):
        msg = "unexpected end of file"
    else:  # pragma: no cover - other UnexpectedInput subclasses
        msg = "cannot read this line"
    return (loc, msg, src)


# --------------------------------------------------------------------------- record checks

class _FieldError(Exception):
    """A field did not match its spec (internal: collected, then raised as DeckError)."""

    def __init__(self, index: int, message: str):
        super().__init__(message)
        self.index = index
        self.message = message


def _number(text: str) -> float:
    return float(text.replace("d", "e").replace("D", "e"))


def _as_written(tok: Token):
    """A field of a leniently parsed keyword: int, float or str as written."""
    if tok.type == "NUMBER":
        if _INT_TEXT.fullmatch(tok):
            return int(tok)
        return _number(tok)
    if tok.type == "STRING":
        return str(tok)[1:-1]
    return str(tok)


def _convert(tok: Token, spec, keyword: str, index: int):
    """Convert one token to the value its field spec asks for, or raise _FieldError."""
    what = f"{keyword}: expected the {spec.name} ({KIND_DESCRIPTIONS[spec.kind]}), found '{tok}'"
    if spec.kind == "word":
        if tok.type == "NUMBER":
            raise _FieldError(index, what)
        return _as_written(tok)
    if spec.kind == "value":
        value = _as_written(tok)
        if isinstance(value, float) and value.is_integer() and math.isfinite(value):
            value = int(value)
        return value
    if tok.type != "NUMBER":
        raise _FieldError(index, what)
    value = _number(tok)
    if not math.isfinite(value):
        raise _FieldError(index, f"{keyword}: the {spec.name} '{tok}' is out of range")
    if spec.kind == "float":
        if spec.positive and value <= 0:
            raise _FieldError(index, f"{keyword}: the {spec.name} must be positive, found '{tok}'")
        return value
    # int: a float with zero fractional part is accepted (SPACAR writes 5.000000)
    if not value.is_integer():
        raise _FieldError(index, what)
    if abs(value) > _INT_LIMIT:
        raise _FieldError(index, f"{keyword}: the {spec.name} '{tok}' is out of range")
    ivalue = int(value)
    if spec.positive and ivalue < 1:
        raise _FieldError(index, f"{keyword}: the {spec.name} must be a positive whole number, "
                                 f"found '{tok}'")
    return ivalue


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


class _StatementChecker:
    """Raw records -> Statements, with the module structure and all errors collected."""

    def __init__(self, filename: str, lines: list[str]):
        self.filename = filename
        self.lines = lines
        self.errors: list = []

    def loc(self, tok: Token, column: int | None = None) -> SourceLoc:
        return SourceLoc(self.filename, tok.line, tok.column if column is None else column)

    def error(self, loc: SourceLoc, message: str) -> None:
        self.errors.append((loc, message, _line_of(self.lines, loc.line)))

    def run(self, records: list[_Record]) -> list[Statement]:
        out: list[Statement] = []
        module = 0
        prev_end = False      # the previous record was END
        closed = False        # END END seen: only VISUALIZATION may follow
        visual = False        # inside the VISUALIZATION section
        for rec in records:
            keyword = str(rec.keyword).upper()
            if visual or keyword == "VISUALIZATION":
                visual = True
                out.append(self.statement(rec, keyword, tuple(_as_written(t) for t in rec.fields),
                                          -1))
                continue
            if closed:
                self.error(self.loc(rec.keyword),
                           f"text after the final END: '{rec.keyword}' (only a VISUALIZATION "
                           "section may follow END END)")
                break
            spec = KEYWORDS.get(keyword)
            if spec is None:
                self.unknown_keyword(rec, keyword)
                prev_end = False
                continue
            fields = self.check_fields(rec, keyword, spec)
            if keyword == "END":
                if prev_end:
                    closed = True
                    this_module = module - 1
                else:
                    this_module = module
                    module += 1
                prev_end = True
            else:
                if keyword == "HALT" and not prev_end:
                    self.error(self.loc(rec.keyword), "HALT must directly follow an END")
                this_module = module
                prev_end = False
            if fields is not None:
                out.append(self.statement(rec, keyword, fields, this_module))
        if self.errors:
            raise DeckError(sorted(self.errors, key=lambda it: (it[0].line, it[0].column)))
        return out

    def statement(self, rec: _Record, keyword: str, fields: tuple, module: int) -> Statement:
        return Statement(keyword=keyword, fields=fields, loc=self.loc(rec.keyword),
                         field_locs=tuple(self.loc(t) for t in rec.fields),
                         source_line=_line_of(self.lines, rec.keyword.line) or "",
                         module=module)

    def unknown_keyword(self, rec: _Record, keyword: str) -> None:
        if keyword in VISUALIZATION_KEYWORDS:
            msg = (f"'{rec.keyword}' belongs to the VISUALIZATION section, which must come "
                   "after the final END")
        else:
            msg = f"unknown keyword '{rec.keyword}'"
            close = difflib.get_close_matches(keyword, list(KEYWORDS), n=1, cutoff=0.6)
            if close:
                msg += f" (did you mean {close[0]}?)"
        self.error(self.loc(rec.keyword), msg)

    def check_fields(self, rec: _Record, keyword: str, spec: KeywordSpec) -> tuple | None:
        """Convert the fields of one record, or record an error and return None."""
        n = len(rec.fields)
        specs = _field_specs(spec, n)
        if specs is None:
            counts = spec.counts
            if n > counts[-1] and spec.variadic is None:
                loc = self.loc(rec.fields[counts[-1]])       # the first extra field
            else:
                last = rec.fields[-1] if rec.fields else rec.keyword
                loc = self.loc(last, last.end_column)         # where a field is missing
            self.error(loc, f"{keyword} takes {_count_phrase(spec)}, got {n} "
                            f"(usage: {spec.usage})")
            return None
        values = []
        ok = True
        for i, (tok, fspec) in enumerate(zip(rec.fields, specs)):
            try:
                values.append(_convert(tok, fspec, keyword, i))
            except _FieldError as exc:
                self.error(self.loc(rec.fields[exc.index]), exc.message)
                ok = False
        return tuple(values) if ok else None

"""Deck lines -> tokens: the grammar's terminals, a line lexed as Lark lexes it (without
Lark where every field is readable: :func:`_simple_tokens`; a line of a keyword and plain
numbers: :func:`_plain_fields`), and why an unreadable field (BAD) cannot be read."""
from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from itertools import accumulate
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:                      # Lark is imported only when a line needs it
    from lark import Token

# The grammar accepts every sequence of tokens, so lexing is all the parsing a deck needs: a
# record is the tokens of one line (no token spans a line end). Lexing alone is twice as fast as
# building the parse tree.
_GRAMMAR = Path(__file__).with_name("grammar.lark")


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
# Such a line takes a fast path (fastpath.py: _Batch): split, its first token checked against
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



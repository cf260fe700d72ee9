"""Field conversion: a record's tokens checked against its keyword's field specs (count,
kind, whole/positive numbers) and converted to ints, floats and strings (:class:`_FieldChecks`,
a part of the parser's reader), with the messages of a field that does not fit."""
from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

from spacarpy.deck.keywords import (
    KIND_DESCRIPTIONS,
    FieldSpec,
    KeywordSpec,
)
from spacarpy.errors import SourceLoc

if TYPE_CHECKING:                      # Lark is imported only when a line needs it
    from lark import Token
from spacarpy.deck.lexer import (
    _bad_token_message,
    _Record,
)

#: Largest magnitude accepted for a whole-number field (node/element numbers, counts).
_INT_LIMIT = 2**31 - 1
#: Batches of fewer lines are converted line by line (see _Batch.convert).
_SMALL_BATCH = 16

_INT_TEXT = re.compile(r"[+-]?\d+")


def _expr():
    """:mod:`spacarpy.expressions` (and with it Lark), imported at the first line that needs
    it: a deck of plain lines is read without either."""
    import spacarpy.expressions
    return spacarpy.expressions


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




class _RangeRows:
    """What :meth:`_Reader.check_fields` gives for a long range of a table keyword: the
    numbers of the range and the other fields, not yet one tuple per number."""

    def __init__(self, numbers: range, rest: tuple, locs: tuple):
        self.numbers, self.rest, self.locs = numbers, rest, locs



class _FieldChecks:
    """The field conversion of :class:`spacarpy.deck.parser._Reader`."""

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

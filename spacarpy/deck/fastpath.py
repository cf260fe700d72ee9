"""The fast path: lines of a keyword and plain numbers read in batches (:class:`_Batch`,
with :mod:`spacarpy.deck.linescan` for a large deck), as statements or as arrays
(:class:`PlainTable`, :class:`ParsedDeck`); a line that is not simply correct goes back to
the general path, so both give identical statements (:class:`_FastPath`, a part of the
parser's reader)."""
from __future__ import annotations

import functools
import math

import numpy as np

from spacarpy.deck.fields import (
    _INT_LIMIT,
    _SMALL_BATCH,
    _field_specs,
    _number,
)
from spacarpy.deck.keywords import (
    KEYWORDS,
)
from spacarpy.deck.lexer import (
    _NOT_NUMBER_CHAR,
    _NUMBER,
    _WORD,
    _lex_line,
    _Source,
)
from spacarpy.deck.linescan import LineScan
from spacarpy.deck.statement import (
    Statement,
    _PlainStatement,
    _RangeStatement,
)

__all__ = ["ParsedDeck", "PlainTable"]

#: Keywords whose records always take the general path (module structure, parameters, files).
_GENERAL_KEYWORDS = frozenset({"END", "HALT", "INCLUDE", "SET", "VISUALIZATION"})
#: Texts of fewer lines are read line by line; in longer ones, runs of at least
#: parser._RUN_LINES simple lines are appended to their batches at once (_FastPath.run).
_SCAN_LINES = 2048
#: The source of tables that make their statements without reading their line again.
_NO_SOURCE = None


def _scan(text: str, raw: list) -> LineScan | None:
    """The :class:`~spacarpy.deck.linescan.LineScan` of a large ASCII text, else None (a few
    lines are cheaper read one by one)."""
    if len(raw) < _SCAN_LINES or not text.isascii():
        return None
    return LineScan(text)



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



class _FastPath:
    """The fast path of :class:`spacarpy.deck.parser._Reader`."""

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

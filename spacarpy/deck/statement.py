"""The :class:`Statement` record of a deck line (and the two cheaper kinds the fast path and
ranges make), with its fields by name and its locations (made lazily for plain lines)."""
from __future__ import annotations

from spacarpy.deck.keywords import (
    KEYWORDS,
    VISUALIZATION_KEYWORDS,
    FieldSpec,
    KeywordSpec,
)
from spacarpy.deck.lexer import (
    _plain_fields,
    _Source,
)
from spacarpy.errors import SourceLoc

__all__ = ["Statement"]


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


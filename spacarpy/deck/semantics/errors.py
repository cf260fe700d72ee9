"""The error collector of the deck semantics: every problem found, reported together, in deck
order.

Each part of :mod:`spacarpy.deck.semantics` reports through one :class:`ErrorCollector`
instead of raising, so that a deck with ten mistakes gets ten messages in one
:class:`spacarpy.errors.DeckError`. The collector orders them as the deck does (problems
without a location first), and reports once the errors a range or generator line repeats for
each of its elements. It also keeps the warnings, which are logged when the deck is valid.
"""
from __future__ import annotations

import re

from spacarpy.deck.statement import Statement
from spacarpy.errors import SourceLoc

__all__ = ["DeckContext", "ErrorCollector", "Part"]

_DIGITS = re.compile(r"\d+")


class ErrorCollector:
    """Errors ``(loc, message, source line)`` and warnings of one deck."""

    def __init__(self, statements=()):
        self.items: list = []
        self.warnings: list[str] = []
        self._statements = statements
        self._by_line: dict | None = None  # (file, line) -> first statement on it
        self._rank: dict | None = None     # (file, line) -> position in deck order

    def _index(self) -> None:
        """The lines of the statements in deck order (made when first needed: a valid deck
        of one element kind never needs them)."""
        self._by_line, self._rank = {}, {}
        for st in self._statements:
            key = (st.file, st.line)
            if key not in self._rank:
                self._by_line[key] = st
                self._rank[key] = len(self._rank)

    @property
    def by_line(self) -> dict:
        if self._by_line is None:
            self._index()
        return self._by_line

    @property
    def rank(self) -> dict:
        if self._rank is None:
            self._index()
        return self._rank

    def __bool__(self) -> bool:
        return bool(self.items)

    def error(self, loc: SourceLoc | None, message: str, st: Statement | None = None) -> None:
        """Report a problem at ``loc`` (None: no location), shown with ``st``'s line."""
        self.items.append((loc, message, st.source_line if st is not None else None))

    def extend(self, items) -> None:
        """Add already formed ``(loc, message, source line)`` items."""
        self.items.extend(items)

    def warn(self, message: str) -> None:
        self.warnings.append(message)

    def line_at(self, loc: SourceLoc) -> Statement | None:
        """The first statement on the line of ``loc``."""
        return self.by_line.get((loc.file, loc.line))

    def order(self, st: Statement) -> int:
        """The position of a statement's line in deck order."""
        return self.rank[(st.file, st.line)]

    def sorted(self) -> list:
        """The errors in deck order. Errors that a range or generator line repeats for each of
        its elements (same place, same message up to the numbers) are reported once."""
        def key(item):
            loc = item[0]
            if loc is None:
                return (0, 0, 0)
            return (1, self.rank.get((loc.file, loc.line), len(self.rank)), loc.column)

        out: list = []
        repeats: dict = {}
        for loc, msg, src in sorted(self.items, key=key):
            same = (loc, _DIGITS.sub("#", msg)) if loc is not None else None
            if same is not None and same in repeats:
                repeats[same][1] += 1
                continue
            if same is not None:
                repeats[same] = [len(out), 0]
            out.append((loc, msg, src))
        for index, count in repeats.values():
            if count:
                loc, msg, src = out[index]
                out[index] = (loc, f"{msg} (and {count} more like it from this line)", src)
        return out


class DeckContext:
    """What every part of the semantics needs to know about the deck as a whole: whether it is
    planar, the elements and nodes of unsupported keywords and of failed generator lines
    (errors about those are already reported), and the keywords that may appear only once."""

    def __init__(self, path: str, statements=(), planar: bool = False, quiet_elements=(),
                 quiet_nodes=()):
        self.path = path
        self.statements = list(statements)       # the deck's statements, in deck order
        self.planar = planar
        self.foreign_elements: set[int] = set()   # elements of unsupported keywords
        self.foreign_nodes: set[int] = set()      # nodes of unsupported element keywords
        self.quiet_elements: set[int] = set(quiet_elements)   # of failed generator lines
        self.quiet_nodes: set[int] = set(quiet_nodes)         # end nodes of those
        self._singletons: dict[str, Statement] = {}
        self.by_keyword: dict | None = None       # the statements of each keyword, in order

    def in_deck_order(self, *keywords: str) -> list[Statement]:
        """The statements of some keywords, in deck order."""
        if self.by_keyword is not None:
            present = [kw for kw in keywords if kw in self.by_keyword]
            if len(present) <= 1:       # already in deck order
                return list(self.by_keyword[present[0]]) if present else []
        return [st for st in self.statements if st.keyword in keywords]

    def once(self, st: Statement, errors: ErrorCollector) -> bool:
        """Record a keyword that may appear only once; report a repeat (then False)."""
        first = self._singletons.get(st.keyword)
        if first is not None:
            errors.error(st.loc, f"{st.keyword} is given twice (lines {first.loc.line} and "
                                 f"{st.loc.line})", st)
            return False
        self._singletons[st.keyword] = st
        return True


class Part:
    """Base of the parts of the semantics: ``self.ctx`` and ``self.errors``, with short names
    for reporting and for the facts of the deck as a whole."""

    ctx: DeckContext
    errors: ErrorCollector

    def error(self, loc: SourceLoc | None, message: str, st: Statement | None = None) -> None:
        self.errors.error(loc, message, st)

    @property
    def planar(self) -> bool:
        return self.ctx.planar

    @property
    def foreign_elements(self) -> set:
        return self.ctx.foreign_elements

    @property
    def foreign_nodes(self) -> set:
        return self.ctx.foreign_nodes

    @property
    def quiet_elements(self) -> set:
        return self.ctx.quiet_elements

    @property
    def quiet_nodes(self) -> set:
        return self.ctx.quiet_nodes

"""The arrays of the array path (:mod:`.arrays`) and the mappings through which the
per-statement parts of the semantics see them: the lines of a keyword as rows of numbers
(:class:`_Lines`), the elements of a kind (:class:`_Kind`), and nodes, elements and
statement locations made as records only when one is asked for."""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from itertools import repeat

import numpy as np

from spacarpy.deck.semantics.topology import KIND_INFO, ElementRecord, Topology
from spacarpy.elements.registry import KINDS
from spacarpy.model import RIGID

__all__ = ["StatementLocs"]


class _GiveUp(Exception):
    """The deck is not the usual valid case: the per-statement semantics take over."""


class _Lines:
    """The lines of one keyword as rows of numbers, in deck order: from the parser's tables
    and from statements (lines that are not plain, or too few to batch).

    Attributes
    ----------
    pos : (n,) int
        Each line's place among the deck's statements (the deck order).
    width : (n,) int
        Its number of fields.
    values : (n, max width) float
        Its fields, NaN after the last.
    """

    def __init__(self, tables: list, statements: list):
        blocks = [(t.slots, t.values, t.statement) for t in tables]
        if statements:
            by_width: dict = {}
            for pos, st in statements:
                by_width.setdefault(len(st.fields), []).append((pos, st))
            for width, items in by_width.items():
                try:
                    values = np.array([st.fields for _, st in items], dtype=float)
                except (TypeError, ValueError):     # a field that is not a number
                    raise _GiveUp from None
                sts = [st for _, st in items]
                blocks.append((np.array([p for p, _ in items], dtype=np.int64),
                               values.reshape(len(items), width), sts.__getitem__))
        n = sum(len(b[0]) for b in blocks)
        wide = max((b[1].shape[1] for b in blocks), default=0)
        pos = np.empty(n, dtype=np.int64)
        width = np.empty(n, dtype=np.int64)
        values = np.full((n, wide), np.nan)
        block = np.empty(n, dtype=np.int64)
        local = np.empty(n, dtype=np.int64)
        start = 0
        for k, (p, v, _) in enumerate(blocks):
            end = start + len(p)
            pos[start:end], width[start:end] = p, v.shape[1]
            values[start:end, :v.shape[1]] = v
            block[start:end], local[start:end] = k, np.arange(len(p))
            start = end
        order = np.argsort(pos, kind="stable")
        self.pos, self.width, self.values = pos[order], width[order], values[order]
        self._block, self._local = block[order], local[order]
        self._makers = [b[2] for b in blocks]

    def __len__(self) -> int:
        return len(self.pos)

    def statement(self, i: int):
        """The statement of row i (made from its line if it came from a table)."""
        return self._makers[self._block[i]](int(self._local[i]))

    def ints(self, j: int) -> np.ndarray:
        """Column j as whole numbers (the field is a whole-number field)."""
        if j >= self.values.shape[1]:
            return np.zeros(len(self), dtype=np.int64)
        return self.values[:, j].astype(np.int64)


class _SortedIds:
    """Distinct numbers and where each is: membership and lookup by binary search."""

    def __init__(self, ids: np.ndarray):
        self.order = np.argsort(ids, kind="stable")
        self.sorted = ids[self.order]

    def find(self, values: np.ndarray):
        """``(index, found)`` of each of ``values`` (index into the original ids)."""
        values = np.asarray(values, dtype=np.int64)
        if len(self.sorted) == 0:
            return np.zeros(values.shape, np.int64), np.zeros(values.shape, bool)
        k = np.minimum(np.searchsorted(self.sorted, values), len(self.sorted) - 1)
        return self.order[k], self.sorted[k] == values

    def index(self, n) -> int | None:
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool):
            return None
        k = int(np.searchsorted(self.sorted, n))
        if k < len(self.sorted) and self.sorted[k] == n:
            return int(self.order[k])
        return None


class _SortedMapping(Mapping):
    """A mapping over distinct numbers ``keys`` (an array), looked up by binary search; the
    value of the i-th key is ``self.value(i)``, made when asked for."""

    def __init__(self, keys: np.ndarray):
        self.keys_array = keys
        self.search = _SortedIds(keys)

    def value(self, i: int):
        raise NotImplementedError

    def __getitem__(self, n):
        i = self.search.index(n)
        if i is None:
            raise KeyError(n)
        return self.value(i)

    def __contains__(self, n) -> bool:
        return self.search.index(n) is not None

    def __iter__(self):
        return iter(self.keys_array.tolist())

    def __len__(self) -> int:
        return len(self.keys_array)


class _Positions(_SortedMapping):
    """Position node -> ((x, y, z), its X statement), as :class:`.topology.Topology` keeps
    them, made from the arrays when asked for."""

    def __init__(self, lines: _Lines, ids: np.ndarray, xyz: np.ndarray):
        super().__init__(ids)
        self.lines, self.ids, self.xyz = lines, ids, xyz

    def value(self, i: int):
        return tuple(self.xyz[i].tolist()), self.lines.statement(i)


class _FirstUse(_SortedMapping):
    """Orientation node -> the first element line using it."""

    def __init__(self, nodes: np.ndarray, statement):
        super().__init__(nodes)                            # nodes: sorted, distinct
        self.nodes, self.statement = nodes, statement

    def value(self, i: int):
        return self.statement(i)


class _Kind:
    """The elements of one kind: their lines and the element data as arrays."""

    def __init__(self, keyword: str, lines: _Lines):
        info = KIND_INFO[keyword]
        kind = KINDS[keyword]
        n = len(lines)
        self.keyword, self.lines, self.info = keyword, lines, info
        self.ids = lines.ints(0)
        self.nodes = lines.values[:, 1:1 + len(info["roles"])].astype(np.int64)
        at = info["vector_at"]
        self.vector_given = (lines.width >= at + 3) if at is not None else np.zeros(n, bool)
        self.vector = np.full((n, 3), np.nan)
        if at is not None and self.vector_given.any():
            self.vector[self.vector_given] = lines.values[self.vector_given, at:at + 3]
        self.def_class = np.full((n, kind.n_def), RIGID, dtype=np.int8)
        self.stiffness = np.zeros((n, kind.n_estiff))
        self.has_stiffness = np.zeros(n, dtype=bool)
        self.mass = np.zeros((n, kind.n_em))
        self.dyne_row = np.full(n, -1, dtype=np.int64)      # the DYNE line of each, or -1
        self.estiff_row = np.full(n, -1, dtype=np.int64)    # the ESTIFF line of each, or -1
        self.em_row = np.full(n, -1, dtype=np.int64)        # the EM line of each, or -1

    def field_columns(self, fields: list) -> np.ndarray:
        """The node numbers of the given field indices (1-based, as KIND_INFO counts)."""
        return self.nodes[:, [i - 1 for i in fields]].reshape(len(self.ids), len(fields))


class _Elements(Mapping):
    """Element number -> :class:`.topology.ElementRecord`, made when asked for from the
    arrays (and kept: the per-statement parts may change it; :meth:`write_back` puts the
    changes into the arrays)."""

    def __init__(self, kinds: list[_Kind], dyne: _Lines | None, estiff: _Lines | None,
                 em: _Lines | None):
        self.kinds, self.dyne, self.estiff, self.em = kinds, dyne, estiff, em
        ids = np.concatenate([k.ids for k in kinds]) if kinds else np.zeros(0, np.int64)
        self.which = np.concatenate([np.full(len(k.ids), i) for i, k in enumerate(kinds)]) \
            if kinds else np.zeros(0, np.int64)
        self.row = np.concatenate([np.arange(len(k.ids)) for k in kinds]) if kinds \
            else np.zeros(0, np.int64)
        self.ids = ids
        self.search = _SortedIds(ids)
        self.records: dict = {}

    def __getitem__(self, e):
        rec = self.records.get(e)
        if rec is not None:
            return rec
        i = self.search.index(e)
        if i is None:
            raise KeyError(e)
        kind, row = self.kinds[self.which[i]], int(self.row[i])
        rec = ElementRecord(kind.lines.statement(row))
        rec.def_class = kind.def_class[row].tolist()
        if kind.dyne_row[row] >= 0:
            st = self.dyne.statement(int(kind.dyne_row[row]))
            modes = st.fields[1:]
            rec.class_line = [st.line] * len(modes)
            rec.flex_locs = dict(zip(modes, zip(repeat(st), modes)))
        if kind.estiff_row[row] >= 0:
            rec.estiff = self.estiff.statement(int(kind.estiff_row[row]))
            rec.stiffness = tuple(kind.stiffness[row].tolist())
        if kind.em_row[row] >= 0:
            rec.em = self.em.statement(int(kind.em_row[row]))
            values = rec.em.fields[1:6]
            rec.mass = tuple(values) + (0.0,) * (5 - len(values))
        self.records[e] = rec
        return rec

    def __contains__(self, e) -> bool:
        return e in self.records or self.search.index(e) is not None

    def __iter__(self):
        return iter(self.ids.tolist())

    def __len__(self) -> int:
        return len(self.ids)

    def write_back(self) -> None:
        """The element data of the records made, into the arrays."""
        for e, rec in self.records.items():
            i = self.search.index(e)
            kind, row = self.kinds[self.which[i]], int(self.row[i])
            kind.def_class[row] = rec.def_class
            kind.stiffness[row] = _fit(rec.stiffness, kind.stiffness.shape[1])
            kind.has_stiffness[row] = rec.estiff is not None
            kind.mass[row] = _fit(rec.mass, kind.mass.shape[1])


def _fit(values, width: int) -> list:
    """Values cut or padded with zeros to a width (as ElementSet reads rows)."""
    values = [float(v) for v in values[:width]]
    return values + [0.0] * (width - len(values))


class _ArrayTopology(Topology):
    """A :class:`.topology.Topology` whose nodes and elements are arrays behind mappings."""

    def __init__(self, ctx, errors, positions, orientation_use, elements):
        super().__init__(ctx, errors)
        self.positions, self.orientation_use, self.elements = \
            positions, orientation_use, elements


class StatementLocs(Sequence):
    """The locations of ``count`` statements (``ElementSet.locs``), ``statement(i)`` the
    i-th, made when asked for: most runs never look at them (see
    :class:`spacarpy.deck.statement.Statement`)."""

    def __init__(self, count: int, statement):
        self._count, self._statement = count, statement

    def __len__(self) -> int:
        return self._count

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self._statement(k).loc for k in range(self._count)[i]]
        if i < 0:
            i += self._count
        if not 0 <= i < self._count:
            raise IndexError(i)
        return self._statement(i).loc

    def __eq__(self, other) -> bool:
        return list(self) == list(other) if isinstance(other, Sequence) else NotImplemented

    __hash__ = None

"""The slips held at zero (non-holonomic constraints), assembled over the global coordinates.

A kind with velocity-level modes (``ElementKind.velocity_modes``: the WHEEL's longitudinal and
lateral slips) gives, per element, the slip velocities ``s = S(x) v`` linear in the velocities
of its local coordinates, with the exact kernels ``slip``, ``slip_dx`` and ``slip_force_dx``
(:mod:`spacarpy.elements.base`). A slip mode left rigid (the default, rolling without slip)
is a constraint ``s = 0`` on the velocities; a released one (RLSE) is free. This module
numbers the held slips and assembles, over all coordinates or over a chosen set of columns:

- ``S(x)`` (n_slip, n), the slip Jacobian;
- ``S(x) v``, the slip velocities;
- ``d(S(x) v)/dx`` (n_slip, n) at fixed v;
- ``S(x)^T nu`` (n,) and ``d(S(x)^T nu)/dx`` (n, n), the generalized forces of the
  multipliers ``nu`` (the tangential contact forces) and their tangent.

The rows are in group order, within a group in element order, and within an element in
mode order. It knows the numbering and the kinds, no solver (docs/rolling.md).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from spacarpy.elements.base import RIGID
from spacarpy.numbering import Numbering

__all__ = ["HeldSlips", "held_slips"]


@dataclass
class _SlipGroup:
    """The held slips of one group: ``elem`` and ``slot`` (the position of the mode among
    the kind's velocity modes) per row, and the rows' first position among all slips."""

    group: int
    elem: np.ndarray
    slot: np.ndarray
    offset: int


@dataclass
class HeldSlips:
    """The held slips of a numbered model and their assembly (module docstring).

    Attributes
    ----------
    n : int
        The number of held slips (rows).
    ids, modes : (n,) int
        Deck element number and 1-based deformation mode of each row.
    keywords : (n,) str
        The element kind of each row.
    """

    num: Numbering
    parts: list
    n: int
    ids: np.ndarray
    modes: np.ndarray
    keywords: np.ndarray

    def __bool__(self) -> bool:
        return self.n > 0

    def none(self) -> HeldSlips:
        """The same model with no held slips (for a solver that imposes them itself)."""
        return HeldSlips(self.num, [], 0, self.ids[:0], self.modes[:0], self.keywords[:0])

    def names(self) -> list:
        """``"WHEEL 5 mode 4"`` per row."""
        return [f"{k} {int(e)} mode {int(m)}" for k, e, m in
                zip(self.keywords, self.ids, self.modes)]

    # ------------------------------------------------------------------ pieces
    def _local(self, part, z):
        g = self.num.groups[part.group]
        elem = np.unique(part.elem)
        return g, elem, z[g.idx[elem]]

    def _rows_of(self, part, elem):
        """For each held row of the part: its position in ``elem`` and its kernel slot."""
        pos = np.searchsorted(elem, part.elem)
        return pos, part.slot

    def _columns(self, cols):
        """Map global coordinates to columns (``cols``: None for all, else an index array of
        the kept coordinates in column order); -1 for dropped coordinates."""
        n_coord = self.num.n_coord
        if cols is None:
            return np.arange(n_coord), n_coord
        where = np.full(n_coord, -1, np.int64)
        where[np.asarray(cols)] = np.arange(len(cols))
        return where, len(cols)

    # ------------------------------------------------------------------ assembly
    def jacobian(self, x: np.ndarray, cols=None, dense: bool = False):
        """``S(x)`` (n, len(cols)) (all coordinates when ``cols`` is None), sparse (CSR) or,
        with ``dense``, an array (for a small model: no sparse construction)."""
        return self._rows_matrix(x, None, cols, dense)

    def rates_dx(self, x: np.ndarray, v: np.ndarray, cols=None, dense: bool = False):
        """``d(S(x) v)/dx`` at fixed ``v`` (global velocities), (n, len(cols)), sparse or
        dense as :meth:`jacobian`."""
        return self._rows_matrix(x, v, cols, dense)

    def rates(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The slip velocities ``S(x) v`` (n,)."""
        out = np.zeros(self.n)
        for part in self.parts:
            g, elem, xl = self._local(part, x)
            vl = v[g.idx[elem]]
            S = g.kind.slip(xl, g.ref.take(elem))
            pos, slot = self._rows_of(part, elem)
            out[part.offset:part.offset + pos.size] = np.einsum(
                "ni,ni->n", S[pos, slot], vl[pos])
        return out

    def force(self, x: np.ndarray, nu: np.ndarray) -> np.ndarray:
        """``S(x)^T nu`` over all coordinates (n_coord,)."""
        out = np.zeros(self.num.n_coord)
        for part in self.parts:
            g, elem, xl = self._local(part, x)
            S = g.kind.slip(xl, g.ref.take(elem))
            pos, slot = self._rows_of(part, elem)
            f = S[pos, slot] * nu[part.offset:part.offset + pos.size, None]
            np.add.at(out, g.idx[elem][pos], f)
        return out

    def force_dx(self, x: np.ndarray, nu: np.ndarray, cols=None, dense: bool = False):
        """``d(S(x)^T nu)/dx`` (len(cols), len(cols)): rows the generalized forces, columns
        the coordinates (not symmetric in general); sparse, or an array with ``dense``."""
        where, m = self._columns(cols)
        r, c, d = [], [], []
        for part in self.parts:
            g, elem, xl = self._local(part, x)
            pos, slot = self._rows_of(part, elem)
            w = np.zeros((elem.size, len(g.kind.velocity_modes)))
            np.add.at(w, (pos, slot), nu[part.offset:part.offset + pos.size])
            blocks = g.kind.slip_force_dx(xl, w, g.ref.take(elem))    # (k, ldof, ldof)
            gi = where[g.idx[elem]]                                    # (k, ldof)
            rr = np.broadcast_to(gi[:, :, None], blocks.shape)
            cc = np.broadcast_to(gi[:, None, :], blocks.shape)
            keep = (rr >= 0) & (cc >= 0)
            r.append(rr[keep])
            c.append(cc[keep])
            d.append(blocks[keep])
        return _matrix(r, c, d, (m, m), dense)

    def _rows_matrix(self, x, v, cols, dense=False):
        where, m = self._columns(cols)
        r, c, d = [], [], []
        for part in self.parts:
            g, elem, xl = self._local(part, x)
            ref = g.ref.take(elem)
            blocks = (g.kind.slip(xl, ref) if v is None
                      else g.kind.slip_dx(xl, v[g.idx[elem]], ref))
            pos, slot = self._rows_of(part, elem)
            rows = blocks[pos, slot]                                   # (k, ldof)
            gi = where[g.idx[elem]][pos]
            rr = np.broadcast_to((part.offset + np.arange(pos.size))[:, None], rows.shape)
            keep = gi >= 0
            r.append(rr[keep])
            c.append(gi[keep])
            d.append(rows[keep])
        return _matrix(r, c, d, (self.n, m), dense)


def _matrix(r: list, c: list, d: list, shape: tuple, dense: bool):
    """The matrix of the triplets (duplicates summed): CSR, or an array with ``dense``."""
    if dense:
        out = np.zeros(shape)
        if r:
            np.add.at(out, (np.concatenate(r), np.concatenate(c)), np.concatenate(d))
        return out
    if not r:
        return sp.csr_matrix(shape)
    return sp.csr_matrix((np.concatenate(d), (np.concatenate(r), np.concatenate(c))),
                         shape=shape)


def _cat(a: list, dtype) -> np.ndarray:
    return np.concatenate(a) if a else np.zeros(0, dtype)


def held_slips(num: Numbering) -> HeldSlips:
    """The slips held at zero (velocity modes whose class is RIGID) of a numbered model."""
    parts, ids, modes, kws = [], [], [], []
    offset = 0
    for gi, g in enumerate(num.groups):
        vm = tuple(g.kind.velocity_modes)
        if not vm:
            continue
        held = g.def_class[:, list(vm)] == RIGID                      # (n_elem, n_vm)
        elem, slot = np.nonzero(held)                                 # element order, then mode
        if not elem.size:
            continue
        parts.append(_SlipGroup(gi, elem, slot, offset))
        offset += elem.size
        ids.append(g.ids[elem])
        modes.append(np.asarray(vm)[slot] + 1)
        kws.append(np.full(elem.size, g.keyword, dtype=object))
    return HeldSlips(num, parts, offset, _cat(ids, np.int64), _cat(modes, np.int64),
                     _cat(kws, object))

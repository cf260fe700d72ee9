"""Configuration-dependent (follower) loads: their generalized forces and their load
stiffness, the derivative of those forces by the coordinates.

A follower load turns with the structure, so its generalized force ``f(x)`` depends on the
configuration and its derivative ``df/dx`` (the load stiffness) is not symmetric: the load
is not conservative. Every such load is a :class:`LoadPart`, one batch of ``n_b`` loads of
one kind, that declares once which coordinates it loads (``rows``) and which it depends on
(``cols``), and then gives, for an amplitude ``amp`` (n_b, k):

- ``force(x, amp) -> (n_coord,)``: the generalized forces, **linear in amp** (so that the
  load path's factors ``a XF + s DELXF``, a transient's ``phi(t)``, scale it and ``df/ds``
  is the force of the increment's amplitude),
- ``stiffness(x, amp) -> (n_b, p, q)``: ``d force / dx`` restricted to rows x cols.

:class:`~spacarpy.solvers.statics.loads.Loads` holds the parts (``Loads.parts``) with their
initial (XF-like) and incremental (DELXF-like) amplitudes; a
:class:`~spacarpy.solvers.statics.loads.LoadState` carries the amplitudes at its load
factors; the static problem adds the forces to ``f_ext`` and ``-stiffness`` to the Newton
matrix on blocks its sparsity pattern reserves (:class:`~spacarpy.assembly.BorderedPattern`),
so statics, arc length, the transient's iteration matrix and the linearizations all see them.

:class:`NodalFollower` is the XFL/DELXFL part: a force on a position node n, or a moment on
an orientation node n, with components in the current axes of orientation node r
(docs/follower.md):

- force: ``f_n = R(q_r) F``; ``d f_n / d q_r = 2 H(F) q_r`` (:mod:`spacarpy.rotation`);
- moment: ``T = R(q_r) M`` acts on q_n as ``2 Lambda(q_n)^T T = 2 B(T) q_n``; its
  derivatives are ``2 B(T)`` by q_n and ``2 Lambda(q_n)^T (2 H(M) q_r)`` by q_r (both
  blocks, summed where n = r).

The follower line loads (QEL/DELQEL) are parts of their own,
:mod:`spacarpy.solvers.statics.follower_lines`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spacarpy.rotation import lambda_matrix, moment_matrix, rotate, vector_jacobians


@dataclass
class LoadPart:
    """One batch of configuration-dependent loads (module docstring).

    Attributes
    ----------
    name : str
        What the loads are (``"XFL force"``), for messages.
    rows : (n_b, p) int
        The coordinates each load acts on (global coordinate indices).
    cols : (n_b, q) int
        The coordinates its force depends on (repeated indices add up).
    initial, increment : (n_b, k) float
        The amplitudes present from the start (XF-like) and added over the load steps
        (DELXF-like).
    named : dict
        The parts of ``increment`` whose lines name a time function (LOADTF), by its name
        ((n_b, k) each); a transient scales them by that function instead of the deck's.
    """

    name: str
    rows: np.ndarray
    cols: np.ndarray
    initial: np.ndarray
    increment: np.ndarray
    named: dict = field(default_factory=dict)

    def force(self, x: np.ndarray, amp: np.ndarray, n_coord: int) -> np.ndarray:
        raise NotImplementedError

    def stiffness(self, x: np.ndarray, amp: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def amplitude(self, a: float, s: float) -> np.ndarray:
        """``a initial + s increment``."""
        return a * self.initial + s * self.increment

    def amplitude_at(self, phi: dict) -> np.ndarray:
        """The amplitude of a transient at the time functions' values ``phi`` (name ->
        value; None the deck's function): ``initial + phi[None] (increment - sum named) +
        sum phi[name] named[name]``."""
        if not self.named:
            return self.amplitude(1.0, phi[None])
        default = self.increment - sum(self.named.values())
        return (self.initial + phi[None] * default
                + sum(phi[name] * inc for name, inc in self.named.items()))


def _add(n_coord: int, rows: np.ndarray, values: np.ndarray) -> np.ndarray:
    out = np.zeros(n_coord)
    np.add.at(out, rows.ravel(), values.ravel())
    return out


class FollowerForces(LoadPart):
    """Forces ``R(q_r) F`` on position nodes: rows the node's 3 positions, cols q_r."""

    def force(self, x, amp, n_coord):
        return _add(n_coord, self.rows, rotate(x[self.cols], amp))

    def stiffness(self, x, amp):
        return vector_jacobians(x[self.cols], amp[:, None, :])[:, 0]


class FollowerMoments(LoadPart):
    """Moments ``R(q_r) M`` on orientation nodes: rows q_n, cols ``[q_n, q_r]``."""

    def force(self, x, amp, n_coord):
        qn, qr = x[self.cols[:, :4]], x[self.cols[:, 4:]]
        t = rotate(qr, amp)
        return _add(n_coord, self.rows, 2.0 * np.einsum("nab,nb->na", moment_matrix(t), qn))

    def stiffness(self, x, amp):
        qn, qr = x[self.cols[:, :4]], x[self.cols[:, 4:]]
        t = rotate(qr, amp)
        dt = vector_jacobians(qr, amp[:, None, :])[:, 0]              # (n, 3, 4)
        d_r = 2.0 * lambda_matrix(qn).transpose(0, 2, 1) @ dt          # (n, 4, 4)
        return np.concatenate([2.0 * moment_matrix(t), d_r], axis=2)


def nodal_followers(model, num, pos_row: dict, rot_row: dict) -> list:
    """The XFL/DELXFL lines of a model (``model.follower_loads``) as load parts: one for
    the forces, one for the moments (only those the model has)."""
    lines = getattr(model, "follower_loads", ())
    out = []
    for cls, is_force in ((FollowerForces, True), (FollowerMoments, False)):
        mine = [ld for ld in lines if (int(ld.node) in pos_row) == is_force]
        if not mine:
            continue
        n = len(mine)
        qr = np.array([num.rot_idx[rot_row[int(ld.axes)]] for ld in mine]).reshape(n, 4)
        if is_force:
            rows = np.array([num.pos_idx[pos_row[int(ld.node)]] for ld in mine]).reshape(n, 3)
            cols = qr
        else:
            rows = np.array([num.rot_idx[rot_row[int(ld.node)]] for ld in mine]).reshape(n, 4)
            cols = np.concatenate([rows, qr], axis=1)
        amp = {k: np.array([ld.value if ld.kind == k else (0.0, 0.0, 0.0) for ld in mine],
                           dtype=float).reshape(n, 3) for k in ("XFL", "DELXFL")}
        named = {}
        for tf in {getattr(ld, "tf", None) for ld in mine} - {None}:
            named[tf] = np.where(np.array([getattr(ld, "tf", None) == tf for ld in mine])[:, None],
                                 amp["DELXFL"], 0.0)
        out.append(cls(name="XFL " + ("force" if is_force else "moment"), rows=rows,
                       cols=cols, initial=amp["XFL"], increment=amp["DELXFL"], named=named))
    return out


__all__ = ["FollowerForces", "FollowerMoments", "LoadPart", "nodal_followers"]

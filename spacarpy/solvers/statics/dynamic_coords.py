"""The DYNX check: do the dynamic coordinates (DYNX) and modes (DYNE) parameterize the model?

SPACAR's degrees of freedom are the dynamic nodal coordinates (DYNX) and deformation modes
(DYNE); every other free coordinate is calculable: the constraints (rigid and prescribed modes,
Euler normalizations), the dynamic coordinates and the kinematic ones (KINE, KINX) must fix
it. So, over the free coordinates, the rows ``[C; E_dyn; E_kin]`` must be square and regular:
as many rows as free coordinates, and independent. spacarpy's solvers keep every free
coordinate with multipliers and do not need this; a deck that declares DYNX commits to
SPACAR's classification, and a deck that does not fit it is refused before any step, naming
the motions that no dynamic coordinate fixes (under-determined) or the dynamic coordinates and
modes that depend on the others (over-determined). The DYNE-only decks of before keep
spacarpy's rule (docs/linearized.md). The rank decision is made on the equilibrated rows
(:func:`~spacarpy.solvers.statics.diagnose.equilibrate`), dense up to :data:`DENSE_LIMIT`
free coordinates; a larger model gets the count check and a sparse LU.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spacarpy.errors import ModelError
from spacarpy.model import FLEXIBLE, KINEMATIC, RIGID
from spacarpy.solvers.statics.diagnose import NONZERO, _fmt, equilibrate, numerical_rank

#: Largest number of free coordinates that gets the dense rank analysis (naming the motions
#: and the dependent entries); larger models get a sparse LU and the counts.
DENSE_LIMIT = 3000

__all__ = ["DENSE_LIMIT", "DynamicCheck", "check_dynamic", "dynamic_analysis", "dynamic_names",
           "dynamic_report"]


def dynamic_names(num) -> list[str]:
    """``DYNX 2 1`` for each dynamic coordinate (deck order)."""
    return [f"DYNX {int(n)} {int(c)}" for n, c in num.dynamic_label]


def _rows(prob, x):
    """(C, E, names_E, K): the constraint rows, the dynamic rows (DYNX, then the DYNE modes
    group by group) with their names, and the kinematic rows (KINE modes, KINX coordinates),
    all over every coordinate at x."""
    num, model = prob.num, prob.model
    ev = prob.evaluate(x, np.zeros(num.n_constraint), prob.loads.unloaded())
    C, E, K = [], [num.dynamic_rows(x)], []
    names = dynamic_names(num)
    for node in num.euler_nodes:
        r = np.zeros(num.n_coord)
        r[num.rot_idx[node]] = 2.0 * x[num.rot_idx[node]]
        C.append(r)
    for g, st in zip(num.groups, ev.states):
        slips = set(getattr(g.kind, "velocity_modes", ()))
        for e in range(g.n_elem):
            for k in range(g.def_class.shape[1]):
                cls = g.def_class[e, k]
                if k in slips or cls not in (RIGID, FLEXIBLE, KINEMATIC):
                    continue
                r = np.zeros(num.n_coord)
                np.add.at(r, g.idx[e], st.D[e, k])
                if cls == RIGID:
                    C.append(r)
                elif cls == FLEXIBLE:
                    E.append(r[None])
                    names.append(f"{g.keyword} {int(g.ids[e])} mode {k + 1}")
                else:
                    K.append(r)
    pos = {int(n): i for i, n in enumerate(model.position_ids)}
    for kin in model.kinematic:
        if kin.keyword == "KINX" and kin.target in pos:
            r = np.zeros(num.n_coord)
            r[num.pos_idx[pos[kin.target], kin.number - 1]] = 1.0
            K.append(r)

    def stack(rows):
        return np.vstack(rows) if rows else np.zeros((0, num.n_coord))

    return stack(C), np.vstack(E), names, stack(K)


@dataclass
class DynamicCheck:
    """What :func:`dynamic_analysis` finds: ``dof`` (free coordinates - rank of the
    constraints and kinematic rows), ``n_dynamic`` (DYNX + DYNE), ``motions`` (the nodes that
    move in each motion that changes no dynamic coordinate), ``dependent`` (names of the
    dynamic entries that depend on the others)."""

    dof: int
    n_dynx: int
    n_dyne: int
    motions: list
    dependent: list

    @property
    def ok(self) -> bool:
        return not self.motions and not self.dependent

    def message(self, model) -> str:
        """The one-paragraph refusal (empty when ``ok``)."""
        if self.ok:
            return ""
        first = model.dynamic_coords[0].loc if model.dynamic_coords else None
        where = f"{first}: " if first is not None else ""
        head = (f"{where}the DYNX coordinates and DYNE modes must be the model's degrees of "
                f"freedom (SPACAR's dynamic class): the model has {self.dof} degree"
                f"{'s' * (self.dof != 1)} of freedom, the deck gives {self.n_dynx} DYNX "
                f"coordinate{'s' * (self.n_dynx != 1)} and {self.n_dyne} DYNE mode"
                f"{'s' * (self.n_dyne != 1)}")
        parts = [head]
        if self.motions:
            nodes = sorted({n for m in self.motions for n in m})
            moving = f" (nodes that move: {_fmt(nodes)})" if nodes else ""
            n = len(self.motions)
            parts.append(f"under-determined: {n} motion{'s' * (n != 1)} "
                         f"change{'s' * (n == 1)} no DYNX coordinate and no DYNE mode{moving}; "
                         "declare a coordinate of those nodes DYNX or a mode of their "
                         "elements DYNE")
        if self.dependent:
            parts.append(f"over-determined: {_fmt(self.dependent, limit=12)} "
                         f"depend{'s' * (len(self.dependent) == 1)} on the others (with the "
                         "constraints); remove them from DYNX, or make those modes RLSE")
        return "; ".join(parts)


def dynamic_analysis(prob) -> DynamicCheck | None:
    """The check of the module docstring in the initial configuration; None for a model
    without DYNX lines."""
    num = prob.num
    if not num.dynamic_idx.size:
        return None
    x = num.x0.copy()
    free = np.flatnonzero(prob.free)
    C, E, names, K = _rows(prob, x)
    n_dynx = int(num.dynamic_idx.size)
    n_dyne = E.shape[0] - n_dynx
    col = np.where(num.is_rotation_coord, 1.0, num.length_scale)[free]
    groups = 2 * num.node_of_coord(prob.model)[free] + num.is_rotation_coord[free]
    H = np.vstack([C, K])[:, free] / col
    Ed = E[:, free] / col
    if free.size > DENSE_LIMIT:
        return _sparse_check(H, Ed, n_dynx, n_dyne, free.size)
    if H.shape[0]:
        Hs, _, cs = equilibrate(H, groups)
        _, N, _ = numerical_rank(Hs)
        if N.shape[1]:
            N, _ = np.linalg.qr(N / cs[:, None])
    else:
        N = np.eye(free.size)
    dof = N.shape[1]
    W = Ed @ N                                        # the dynamic rows on the motions
    norms = np.linalg.norm(W, axis=1)
    Wn = W / np.where(norms > 0, norms, 1.0)[:, None]
    motions, dependent = [], []
    if dof:
        _, s, vh = np.linalg.svd(Wn, full_matrices=True)
        r = int(np.sum(s > 1e-8 * max(s.max(initial=0.0), 1e-300)))
        node_of = num.node_of_coord(prob.model)[free]
        for z in vh[r:]:                              # motions no dynamic entry sees
            v = np.abs(N @ z)
            motions.append(sorted({int(n) for n in node_of[v > NONZERO * v.max()]}))
    else:
        r = 0
    if E.shape[0] > r:                                # which entries repeat the others
        import scipy.linalg as sla
        _, _, piv = sla.qr(Wn.T if dof else np.zeros((0, E.shape[0])), pivoting=True,
                           mode="economic")
        keep = set(piv[:r].tolist())
        dependent = [names[i] for i in range(E.shape[0]) if i not in keep]
    return DynamicCheck(dof=dof, n_dynx=n_dynx, n_dyne=n_dyne, motions=motions,
                        dependent=dependent)


def _sparse_check(H, Ed, n_dynx, n_dyne, n_free) -> DynamicCheck:
    """A large model: the counts, and a sparse LU of the square rows for the regularity."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla
    dof = n_free - H.shape[0]
    ok = dof == Ed.shape[0]
    if ok:
        try:
            spla.splu(sp.csc_matrix(np.vstack([H, Ed])))
        except RuntimeError:
            ok = False
    if ok:
        return DynamicCheck(dof, n_dynx, n_dyne, [], [])
    more = Ed.shape[0] - dof          # unnamed: the model is too large for the dense analysis
    return DynamicCheck(dof, n_dynx, n_dyne, [[]] * max(-more, 1 if not more else 0),
                        ["some of them"] * (more > 0))


def check_dynamic(prob) -> None:
    """Raise a :class:`~spacarpy.errors.ModelError` when the model has DYNX lines and its
    DYNX coordinates and DYNE modes are not exactly its degrees of freedom."""
    dc = dynamic_analysis(prob)
    if dc is not None and not dc.ok:
        err = ModelError(dc.message(prob.model))
        err.dynamic, err.mechanism, err.over_constrained = True, False, False
        raise err


def dynamic_report(prob) -> list[str]:
    """The mode-0 report's lines on the DYNX coordinates (none without DYNX lines)."""
    dc = dynamic_analysis(prob)
    if dc is None:
        return []
    names = dynamic_names(prob.num)
    lines = [f"  dynamic (DYNX)      {len(names)}: {_fmt(names, limit=12)}",
             f"  SPACAR's DOF        {dc.n_dynx} DYNX + {dc.n_dyne} DYNE = "
             f"{dc.n_dynx + dc.n_dyne}" + (f" of {dc.dof}: they are the degrees of freedom"
                                           if dc.ok else f", the model has {dc.dof}")]
    if not dc.ok:
        lines.append("  DYNX check          " + dc.message(prob.model))
    return lines

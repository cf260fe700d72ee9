"""Diagnosis of a singular Newton matrix: which motions are free, which constraints redundant.

When the bordered matrix ``[[K, C^T], [C, 0]]`` is singular the model is either a mechanism
(a motion of the nodes that satisfies every constraint and that no stiffness resists) or
over-constrained (constraint gradients that are linearly dependent: a rigid deformation
mode, a fix or an Euler normalization that repeats what others already impose). A
rank-revealing factorization (SVD) of the matrix gives both: right null vectors with a
position/orientation part are free motions, left null vectors that live on the multipliers
only are redundant constraints. The report names nodes, elements and deformation modes.
"""
from __future__ import annotations

import numpy as np

from spacarpy.errors import ModelError

#: Largest bordered system diagnosed with a dense SVD.
DENSE_LIMIT = 4000


def singular_matrix_error(prob, A, x) -> ModelError:
    """Build the :class:`ModelError` describing why the Newton matrix ``A`` is singular."""
    num, model = prob.num, prob.model
    n = A.shape[0]
    n_x = prob.pattern.n_x
    if n > DENSE_LIMIT:
        err = ModelError(
            f"the Newton matrix ({n} unknowns) is singular: the model is a mechanism or has "
            f"redundant constraints. It is too large for the detailed diagnosis "
            f"(limit {DENSE_LIMIT}); check the FIX lines and the DYNE/RLSE classes.")
        err.mechanism, err.over_constrained = True, True
        return err
    dense = A.toarray()
    u, s, vt = np.linalg.svd(dense)
    smax = s[0] if s.size and s[0] > 0 else 1.0
    null = s <= 1e-10 * smax
    lines = []
    coord_of_unknown = np.flatnonzero(~num.fixed_mask)
    node_of = num.node_of_coord(model)

    # free motions: right null vectors with a coordinate part
    motions = [v for v in vt[null] if np.abs(v[:n_x]).max(initial=0) > 1e-6 * np.abs(v).max()]
    if motions:
        moving = set()
        for v in motions:
            vx = np.abs(v[:n_x])
            hit = coord_of_unknown[vx > 0.05 * vx.max()]
            moving.update(int(node_of[k]) for k in hit)
        elems = _elements_at(model, moving)
        lines.append(
            f"mechanism: {len(motions)} free motion(s) that no flexible element resists; "
            f"nodes that move: {_fmt(sorted(moving))}"
            + (f"; elements attached: {_fmt(elems)}" if elems else "")
            + ". Add FIX lines, or make deformation modes flexible (DYNE with ESTIFF) or rigid.")
    # redundant constraints: left null vectors living on the multipliers only
    redundant = [w for w in u[:, null].T
                 if np.abs(w[:n_x]).max(initial=0) <= 1e-6 * np.abs(w).max()]
    if redundant:
        names = set()
        for w in redundant:
            wm = np.abs(w[n_x:])
            for k in np.flatnonzero(wm > 0.05 * wm.max()):
                names.add(_constraint_name(num, model, int(k)))
        lines.append(
            f"over-constrained: {len(redundant)} redundant constraint(s) among: "
            f"{'; '.join(sorted(names))}")
    if not lines:
        lines.append("the Newton matrix is singular (numerically); no clear mechanism or "
                     "redundant constraint was identified")
    err = ModelError("the model cannot be solved: " + "\n  ".join(lines))
    err.mechanism, err.over_constrained = bool(motions), bool(redundant)
    return err


def _constraint_name(num, model, k: int) -> str:
    if k < num.n_rigid:
        e = int(model.beams.ids[num.rigid_elem[k]])
        m = int(num.rigid_mode[k]) + 1
        return f"element {e} mode {m} (rigid; 'RLSE {e} {m}' would release it)"
    node = int(model.orientation_ids[num.euler_nodes[k - num.n_rigid]])
    return f"Euler-parameter normalization of node {node}"


def _elements_at(model, nodes) -> list:
    if not nodes or model.beams.n_elem == 0:
        return []
    hit = np.isin(model.beams.nodes, list(nodes)).any(axis=1)
    return [int(i) for i in model.beams.ids[hit]]


def _fmt(items, limit=20) -> str:
    items = list(items)
    s = ", ".join(str(i) for i in items[:limit])
    return s + (f", ... ({len(items)} in all)" if len(items) > limit else "")

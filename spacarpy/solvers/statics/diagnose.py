"""Diagnosis of a singular Newton matrix: which motions are free, which constraints redundant.

When the bordered matrix ``[[K, C^T], [C, 0]]`` is singular the model is either a mechanism
(a motion of the nodes that satisfies every constraint and that no stiffness resists) or
over-constrained (constraint gradients that are linearly dependent: a rigid deformation
mode, a fix or an Euler normalization that repeats what others already impose). A
rank-revealing factorization (SVD) of the matrix gives both: right null vectors with a
position/orientation part are free motions, left null vectors that live on the multipliers
only are redundant constraints. The report names nodes, elements and deformation modes.
Large models (more than :data:`DENSE_LIMIT` unknowns) get their null vectors from block
inverse iteration with one sparse LU of the slightly shifted matrix instead of a dense SVD.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.errors import ModelError

#: Largest bordered system diagnosed with a dense SVD (about 10 s at this size on one
#: loaded core; larger ones get the sparse inverse iteration, which the equilibration
#: and the gap test make reliable for chains of 1000 beams).
DENSE_LIMIT = 2000

#: The rank decision of :func:`numerical_rank`: on a matrix whose rows are scaled to unit
#: norm, a singular value below ``ZERO * s_max`` is zero and one above ``NONZERO * s_max``
#: is not. Round-off leaves exact zeros near 1e-15 s_max, so it cannot move a singular
#: value across the gap between the two; a value inside the gap is counted as zero (the
#: model is treated as at the singular configuration it is close to) and reported as
#: unclear.
ZERO, NONZERO = 1e-9, 1e-6


@dataclass
class Rank:
    """A rank decision: ``rank``, whether it was ``clear`` (no singular value in the gap
    between ZERO and NONZERO), the smallest singular value counted (``kept``) and the
    largest one dropped (``dropped``), both relative to the largest."""

    rank: int
    clear: bool
    kept: float
    dropped: float

    def describe(self) -> str:
        if np.isnan(self.kept) and np.isnan(self.dropped):
            return "nothing to decide (no constraint)"
        dropped = ("none dropped" if np.isnan(self.dropped) else
                   "largest dropped < 1e-12 (round-off)" if self.dropped < 1e-12 else
                   f"largest dropped {self.dropped:.1e}")
        text = (f"smallest kept singular value {self.kept:.1e}, {dropped} (relative; zero "
                f"below {ZERO:g}, nonzero above {NONZERO:g})")
        if not self.clear:
            text += ("; NOT CLEAR: a singular value lies between the two (counted as zero): "
                     "the configuration is close to a singular one (a dead point?) and the "
                     "counts are those of that singular configuration")
        return text


def unit_rows(M) -> np.ndarray:
    """``M`` (dense) with every nonzero row scaled to unit norm (the rank and the row
    dependencies do not change; the rank decision becomes independent of the units)."""
    M = np.asarray(M, dtype=float)
    norm = np.linalg.norm(M, axis=1)
    return M / np.where(norm > 0, norm, 1.0)[:, None]


def equilibrate(M, groups=None, sweeps: int = 30, tol: float = 1e-3):
    """Ruiz equilibration: ``(S, r, c)`` with ``S = diag(1/r) M diag(1/c)`` whose nonzero rows
    and column groups all have a largest entry of about one (within ``tol``, or after
    ``sweeps`` passes). The rank and the left null space of ``S`` are those of ``M``; a right
    null vector ``n`` of ``S`` is ``diag(1/c) n`` of ``M``. The scaling removes what units,
    the model's length scale and the lengths of its elements do to the singular values, so
    the rank decision sees only the geometry.

    ``groups`` (one integer label per column, e.g. the position or the Euler parameters of
    one node) shares one factor among the columns of a group: a direction in which nothing
    constrains a node near a dead point must stay small, not be blown up to one."""
    S = np.array(M, dtype=float)
    r, c = np.ones(S.shape[0]), np.ones(S.shape[1])
    if S.size == 0:
        return S, r, c
    if groups is None:
        groups = np.arange(S.shape[1])
    _, label = np.unique(np.asarray(groups), return_inverse=True)
    A = np.abs(S)
    for _ in range(sweeps):
        rm = A.max(axis=1)
        cm = np.zeros(label.max() + 1)
        np.maximum.at(cm, label, A.max(axis=0))
        cm = cm[label]
        rs = np.sqrt(np.where(rm > 0, rm, 1.0))
        cs = np.sqrt(np.where(cm > 0, cm, 1.0))
        S /= rs[:, None]
        S /= cs[None, :]
        A = np.abs(S)
        r *= rs
        c *= cs
        if max(abs(1 - rs).max(), abs(1 - cs).max()) < tol:
            break
    return S, r, c


def symmetric_scaling(A, sweeps: int = 30, tol: float = 1e-3) -> np.ndarray:
    """d (n,) with ``diag(d) A diag(d)`` (A sparse, structurally symmetric) of rows and
    columns whose largest entry is about one (Ruiz). Null vectors of the scaled matrix are
    ``diag(1/d)`` times those of A. The Newton matrix mixes stiffnesses (N/m, N m), lengths
    and unit-free Euler rows; scaled, its singular values no longer depend on units, on the
    model's size or on the number of elements through those scales."""
    A = abs(sp.csr_matrix(A))
    d = np.ones(A.shape[0])
    for _ in range(sweeps):
        S = sp.diags(d) @ A @ sp.diags(d)
        m = np.asarray(S.max(axis=1).todense()).ravel()
        f = 1.0 / np.sqrt(np.where(m > 0, m, 1.0))
        d *= f
        if abs(1 - f).max() < tol:
            break
    return d


def numerical_rank(M, right: bool = True, left: bool = False):
    """The rank of ``M`` (rows of unit norm, see :func:`unit_rows`) by an SVD.

    Returns (Rank, N, L): orthonormal bases of the right null space (columns of N, when
    ``right``) and of the left null space (columns of L, when ``left``); the singular
    vectors are computed only when the rank is deficient and a basis was asked for.
    """
    m, n = M.shape
    if m == 0 or n == 0:
        return Rank(0, True, np.nan, np.nan), np.eye(n), np.eye(m)
    s = np.linalg.svd(M, compute_uv=False)
    smax = s[0] if s[0] > 0 else 1.0
    rel = s / smax
    rank = int(np.count_nonzero(rel >= NONZERO))           # the gap counts as zero
    clear = not np.any((rel > ZERO) & (rel < NONZERO))
    kept = float(rel[rank - 1]) if rank else np.nan
    dropped = float(rel[rank]) if rank < s.size else np.nan
    N, L = np.zeros((n, 0)), np.zeros((m, 0))
    if (right and rank < n) or (left and rank < m):
        u, _, vt = np.linalg.svd(M)
        N, L = vt[rank:].T, u[:, rank:]
    return Rank(rank, clear, kept, dropped), N, L


def dependent_rows(L) -> tuple[list, bool]:
    """The rows of a matrix that repeat earlier rows, from ``L``, an orthonormal basis of
    its left null space (m x k).

    Walking the rows in order, row i repeats earlier ones exactly when a left null vector
    ends at i (its last nonzero entry). Gaussian elimination on the columns of ``L^T`` from
    the last row backwards finds the k rows where the null vectors end: that set does not
    depend on the basis, so the order of the rows decides which rows of a dependent set
    are named, never round-off. An entry counts as nonzero above ``NONZERO`` (the vectors
    kept at unit norm) and as zero below ``ZERO``. Returns (sorted indices, clear).
    """
    W = np.array(L, dtype=float).T.copy()
    k, m = W.shape
    out, clear = [], True
    active = np.ones(k, bool)
    for j in range(m - 1, -1, -1):
        rows = np.flatnonzero(active)
        if not rows.size:
            break
        col = np.abs(W[rows, j])
        v = float(col.max())
        if v < NONZERO:
            clear &= v < ZERO
            continue
        p = rows[int(np.argmax(col))]
        others = rows[rows != p]
        if others.size:
            W[others] -= np.outer(W[others, j] / W[p, j], W[p])
            norm = np.linalg.norm(W[others], axis=1)
            W[others] /= np.where(norm > 0, norm, 1.0)[:, None]
        active[p] = False
        out.append(j)
    return sorted(out), clear and len(out) == k


def canonical_motions(N, drivers) -> tuple[np.ndarray, list]:
    """A basis of the null space spanned by the columns of ``N`` that round-off cannot
    rotate: the first rows of ``drivers`` (in order) whose rates are independent on that
    space are chosen, and motion k moves driver k by one and the other chosen ones not at
    all (a rate of one in the driver's own units: the rows of ``drivers`` are not scaled
    here). Returns (motions as columns, chosen driver indices)."""
    d = N.shape[1]
    if d == 0:
        return N, []
    G = drivers @ N
    scale = np.linalg.norm(G, axis=1)
    chosen = [int(i) for i in _first_independent(unit_rows(G), scale, d)]
    return N @ np.linalg.inv(G[chosen]), chosen


def _first_independent(G, scale, d) -> list:
    """The first ``d`` independent rows of ``G`` (unit norm; rows with ``scale`` ~ 0 skipped)."""
    basis = np.zeros((0, G.shape[1]))
    chosen = []
    for i, row in enumerate(G):
        if scale[i] <= NONZERO * scale.max(initial=0.0):
            continue
        r = row - basis.T @ (basis @ row)
        r -= basis.T @ (basis @ r)
        norm = float(np.linalg.norm(r))
        if norm >= NONZERO:
            basis = np.vstack([basis, r / norm])
            chosen.append(i)
            if len(chosen) == d:
                break
    return chosen


def singular_matrix_error(prob, A, x) -> ModelError:
    """Build the :class:`ModelError` describing why the Newton matrix ``A`` is singular."""
    n = A.shape[0]
    d = symmetric_scaling(A)
    A = sp.diags(d) @ A @ sp.diags(d)
    if n > DENSE_LIMIT:
        right = left = _sparse_null_vectors(A)
        if right is None:
            err = ModelError(
                f"the Newton matrix ({n} unknowns) is singular: the model is a mechanism or "
                f"has redundant constraints, which could not be isolated; check the FIX lines "
                f"and the DYNE/RLSE classes.")
            err.mechanism, err.over_constrained = True, True
            return err
    else:
        u, s, vt = np.linalg.svd(A.toarray())
        null = null_mask(s)
        right, left = vt[null], u[:, null].T
    # back to the unknowns of the unscaled matrix (right: diag(d) v; left: diag(d) w)
    return _report(prob, _unit(right * d), _unit(left * d))


#: A singular value of an (equilibrated) matrix is round-off beside the next larger one
#: when they differ by this factor: exact zeros come out near eps times the largest, the
#: smallest genuine ones of long chains (scaled) fall like 1/n^2 but stay far above.
GAP = 1e4


def null_mask(s, smax: float | None = None, loose: float = 1e-8) -> np.ndarray:
    """Which singular values ``s`` are zero: those below the lowest gap (a ratio of at
    least :data:`GAP` between neighbours) that lies under ``loose * smax``; without such a
    gap, those below ``1e-10 * smax``. The decision looks at the spectrum itself, not at a
    fixed fraction of its largest value, so it does not move with the number of elements
    (a chain of 1000 beams has genuine singular values far below those of 10)."""
    s = np.asarray(s, dtype=float)
    if smax is None:
        smax = float(s.max(initial=0.0))
    smax = smax if smax > 0 else 1.0
    order = np.sort(s)                                   # ascending
    small = order[order <= loose * smax]
    if small.size:
        nxt = order[1:small.size + 1] if small.size < order.size else np.append(
            order[1:], np.inf)
        ratio = nxt / np.maximum(small, np.finfo(float).tiny)
        gaps = np.flatnonzero(ratio >= GAP)
        if gaps.size:                                    # the lowest: above the round-off
            return s <= small[gaps[0]]
    return s <= 1e-10 * smax


def _unit(V) -> np.ndarray:
    """The rows of V scaled to unit norm."""
    return V / np.maximum(np.linalg.norm(V, axis=1, keepdims=True), 1e-300)


def _report(prob, right, left) -> ModelError:
    """The error message from right null vectors (free motions) and left null vectors
    (redundant constraints), both over [unknown coordinates, multipliers]."""
    num, model = prob.num, prob.model
    n_x = prob.pattern.n_x
    lines = []
    coord_of_unknown = np.flatnonzero(~num.fixed_mask)
    node_of = num.node_of_coord(model)

    # free motions: right null vectors with a coordinate part
    motions = [v for v in right if np.abs(v[:n_x]).max(initial=0) > 1e-6 * np.abs(v).max()]
    if motions:
        moving = set()
        for v in motions:
            vx = np.abs(v[:n_x])
            hit = coord_of_unknown[vx > 0.05 * vx.max()]
            moving.update(int(node_of[k]) for k in hit)
        elems = _elements_at(num, moving)
        lines.append(
            f"mechanism: {len(motions)} free motion(s) that no flexible element resists; "
            f"nodes that move: {_fmt(sorted(moving))}"
            + (f"; elements attached: {_fmt(elems)}" if elems else "")
            + ". Add FIX lines, or make deformation modes flexible (DYNE with ESTIFF) or rigid.")
    # redundant constraints: left null vectors living on the multipliers only
    redundant = [w for w in left
                 if np.abs(w[:n_x]).max(initial=0) <= 1e-6 * np.abs(w).max()]
    if redundant:
        names = set()
        for w in redundant:
            wm = np.abs(w[n_x:])
            for k in np.flatnonzero(wm > 0.05 * wm.max()):
                names.add(_constraint_name(num, model, int(k)))
        lines.append(
            f"over-constrained: {len(redundant)} redundant constraint(s) among: "
            f"{_fmt(sorted(names, key=_natural), limit=12, sep='; ')}")
    if not lines:
        lines.append("the Newton matrix is singular (numerically); no clear mechanism or "
                     "redundant constraint was identified")
    err = ModelError("the model cannot be solved: " + "\n  ".join(lines))
    err.mechanism, err.over_constrained = bool(motions), bool(redundant)
    return err


def mechanism_error(prob, A, states, k: int = 8, lu=None) -> ModelError | None:
    """Detect free motions that SuperLU factorized without complaint (tiny pivots).

    The smallest singular directions of ``A`` (block inverse iteration with its LU) are
    candidates; a candidate is a free motion when it changes no deformation that carries
    stiffness or is rigid (``D v`` ~ 0 relative to its size) and keeps every Euler
    normalization. Those exist only in a mechanism; soft but genuine elastic modes deform
    elements and are not reported, nor are motions held by the geometric stiffness of
    stress resultants (singular value above 1e-9 of the largest entry of A). Returns the
    error to raise, or None.

    ``lu`` is a factorization of ``A`` the caller already has (the solve of the Newton
    system that preceded this check), used instead of factorizing ``A`` again: the LU is
    the largest cost here. It must be ``splu(A, permc_spec="COLAMD")`` with the other
    options at their defaults, the factorization made here otherwise (``COLAMD`` is
    scipy's default), so that the result does not depend on who factorized.
    """
    num = prob.num
    n_x = prob.pattern.n_x
    if n_x == 0:
        return None
    if lu is None:
        try:
            lu = spla.splu(A.tocsc(), permc_spec="COLAMD")
        except RuntimeError:
            return None
    rng = np.random.default_rng(1)
    v = rng.standard_normal((A.shape[0], min(k, A.shape[0])))
    for _ in range(3):
        v, _ = np.linalg.qr(lu.solve(v))
    _, sv, wt = np.linalg.svd(A @ v, full_matrices=False)
    cand = (v @ wt.T)[:n_x]                                     # columns, smallest last
    full = np.zeros((num.n_coord, cand.shape[1]))
    full[prob.free] = cand
    deform = np.zeros(cand.shape[1])
    for g, st in zip(num.groups, states):
        rates = st.D @ full[g.idx]                              # (n_elem, n_def, k)
        stiff = (g.stiff_mask | (g.def_class == 0))[:, :, None]
        rel = np.abs(np.where(stiff, rates, 0.0) / g.scale[:, :, None])
        deform = np.maximum(deform, rel.max(axis=(0, 1), initial=0.0))
    rot = num.is_rotation_coord[prob.free]
    size = (np.abs(cand[~rot]).max(axis=0, initial=0.0) / num.length_scale
            + np.abs(cand[rot]).max(axis=0, initial=0.0))
    q = num.x0[num.euler_coords]
    euler = np.abs(np.einsum("na,nak->nk", q, full[num.euler_coords])).max(
        axis=0, initial=0.0)
    # a motion that deforms nothing to first order but that A resists (the geometric
    # stiffness of a pre-stress, ESIG: a taut string's transverse motion) is no mechanism;
    # a mechanism's singular value is round-off, 1e7 below this bound
    held = sv > 1e-9 * float(abs(A).max())
    free_motion = (deform <= 1e-8 * size) & (euler <= 1e-8 * size) & (size > 0) & ~held
    if not np.any(free_motion):
        return None
    right = np.zeros((int(free_motion.sum()), A.shape[0]))
    right[:, :n_x] = cand[:, free_motion].T
    return _report(prob, right, np.zeros((0, A.shape[0])))


def _sparse_null_vectors(A, k: int = 12, iterations: int = 6):
    """Null vectors of a large, singular, symmetric sparse matrix by block inverse iteration.

    ``A + delta I`` (delta tiny against the matrix scale) is regular; repeated solves with it
    amplify the null-space components of a random block by ``1/delta``, so after a few
    iterations a Rayleigh-Ritz step (an SVD of ``A V``) separates the null vectors (singular
    values ~ 0) from the rest. Returns an array (n_null, n), or None when the shifted
    factorization fails too.
    """
    n = A.shape[0]
    scale = float(abs(A).max())
    # small against the genuine singular values of long chains (1e-11 of the scaled
    # matrix at 1000 beams), so that the iteration separates them from the zeros
    shift = 1e-12 * scale
    try:
        lu = spla.splu((A + shift * sp.eye(n, format="csc")).tocsc())
    except RuntimeError:
        return None
    rng = np.random.default_rng(0)
    v = rng.standard_normal((n, min(k, n)))
    for _ in range(iterations):
        v, _ = np.linalg.qr(lu.solve(v))
    _, sing, wt = np.linalg.svd(A @ v, full_matrices=False)
    null = null_mask(sing, scale, loose=1e-7)
    return (v @ wt[null].T).T


def _constraint_name(num, model, k: int) -> str:
    for g in num.groups:
        if g.rigid_offset <= k < g.rigid_offset + g.rigid_elem.size:
            j = k - g.rigid_offset
            e = int(g.ids[g.rigid_elem[j]])
            m = int(g.rigid_mode[j]) + 1
            return f"{g.keyword} {e} mode {m} (rigid; 'RLSE {e} {m}' would release it)"
    node = int(model.orientation_ids[num.euler_nodes[k - num.n_rigid]])
    return f"Euler-parameter normalization of node {node}"


def _elements_at(num, nodes) -> list:
    if not nodes:
        return []
    out = []
    for g in num.groups:
        hit = np.isin(g.nodes, list(nodes)).any(axis=1)
        out += [int(i) for i in g.ids[hit]]
    return sorted(set(out))


def _natural(name: str):
    """Sort key that orders 'element 10 ...' after 'element 9 ...'."""
    return [int(t) if t.isdigit() else t for t in name.replace("'", " ").split()]


def _fmt(items, limit=20, sep=", ") -> str:
    items = list(items)
    s = sep.join(str(i) for i in items[:limit])
    return s + (f", ... ({len(items)} in all)" if len(items) > limit else "")

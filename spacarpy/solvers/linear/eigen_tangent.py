"""The lowest modes of a large model in the tangent space of its Euler normalizations.

Where the static solver's Newton steps run without the Euler constraints
(:mod:`spacarpy.solvers.statics.reduced`: every constraint is the normalization of an orientation
node with four free Euler parameters, no rigid modes, no moment loads), the linearized
pencil ``(K, M)`` restricted to the null space of C is the same pencil in the tangent
coordinates of :class:`~spacarpy.solvers.statics.reduced.ReducedNewton`: with ``T`` the orthonormal
map from them to the free coordinates (identity on positions, ``Lambda(q)^T / |q|`` on
each Euler quadruple), ``K_r = T^T K T`` and ``M_r = T^T M T``. ``K_r`` is the static
solver's reduced tangent, symmetric and, at a stable state, positive definite.
:func:`lowest_modes` then

1. factorizes ``K_r`` once (the LDL^T of :class:`~spacarpy.solvers.linalg.sparse.SPDFactorization`,
   AMD ordering) and runs ARPACK's Lanczos in shift-invert mode about 0 (``eigsh``), each
   operator application one pair of triangular solves;
2. refines the Ritz vectors by Rayleigh-Ritz steps on ``[V, K_r^-1 R]`` (R the residuals
   ``K_r V - M_r V Theta``), every product with ``K_r`` taken element by element with each
   element's positions relative to its first node and the material part as
   ``D^T (S (D v))`` (:meth:`_Tangent.products`), until the estimated error of the wanted
   eigenvalues is below :data:`EST_RTOL` or a step changes them by less than :data:`RTOL`
   (at most :data:`MAX_REFINE` steps).

Why the shift is 0 and why step 2: the bordered solver shifted by ``-1e-6`` times the median
stiffness-to-mass ratio of the diagonal, which grows with the square of the number of
elements while the lowest eigenvalues do not: at 10^5 elements the shift was 3000 times the
tenth eigenvalue, the wanted shifted eigenvalues lay within 2e-3 of each other, and ARPACK
needed minutes (267 s). A stable clamped model needs no shift. But the assembled ``K_r`` of
a finely meshed structure is inaccurate in its soft directions (their stiffness is 1e-15 of
the axial one at 10^5 elements, below the round-off of the axial entries), so the
eigenvalues of the factorized matrix are about 1e-3 off there; the factorization remains an
excellent preconditioner, and the element-wise products make the Rayleigh quotients accurate.

Returns None where this does not apply or ``K_r`` is not positive definite (rigid-body
modes, an unstable state), and the caller takes the bordered solver. The pivots of the
LDL^T alone do not decide that: at 10^5 elements the loaded bench cantilever (Table 1's
tip force; its lowest eigenvalue 2.6e4) factorized with one negative pivot (-0.04 where
the others are 0.165 or more, the round-off of the soft directions), and the bordered
solver it then took ran for minutes and returned no mode. Where the LDL^T has negative
pivots, the refined Ritz values decide: ``K_r`` counts as not positive definite when one
of the wanted ones is negative or zero next to the largest (:data:`ZERO_RTOL`); a model
whose lowest elastic eigenvalue is below that fraction also takes the bordered solver, as
every model with negative pivots did before.
"""
from __future__ import annotations

import logging
import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.elements.base import relative_positions
from spacarpy.solvers.linalg.sparse import FactorizationError, SPDFactorization

log = logging.getLogger(__name__)

#: Relative change of the wanted eigenvalues between two steps below which the refinement
#: stops.
RTOL = 1e-12
#: Estimated relative error of the wanted eigenvalues (``r^T K^-1 r / theta``) below which
#: the refinement stops: 5e-9 in the frequencies. The estimate's round-off floor is 1e-14
#: at 10^4 elements and 1.5e-9 at 10^5, where the eigenvalues it accepts agree with the
#: fully converged ones to 3e-13.
EST_RTOL = 1e-8
#: Most Rayleigh-Ritz refinement steps (two suffice on the bench cantilever up to 10^5
#: elements; the third confirms).
MAX_REFINE = 6
#: ARPACK's relative tolerance of the Ritz values of the factorized pencil. The refinement
#: decides the accuracy (:data:`EST_RTOL`); 1e-8 cost a restart at 10^4 and 10^5 elements
#: (46 solves instead of 30 on the bench cantilever) for vectors no closer to the accurate
#: pencil's at 10^5 elements (the estimate after ARPACK is 3.7e-8 with both).
ARPACK_TOL = 1e-6
#: Where the LDL^T has negative pivots: a Ritz value at most this fraction of the largest
#: one counts as zero (a rigid-body mode's is 9e-18 of it on the free 70-element bench
#: beam; the clamped one's lowest elastic eigenvalue is 1.5e-4 of its 14th).
ZERO_RTOL = 1e-8
#: Extra Lanczos vectors beyond the modes wanted (their convergence protects the last ones).
EXTRA = 4


#: Elements per chunk of the element-wise products (bounds their temporary arrays).
CHUNK = 8192


def _rotate_columns(a, bases, starts):
    """``a`` (n, r, n_ldof) with the columns of each Euler quadruple (local slots
    ``starts``) multiplied by its node's basis (n, 4, 4); a copy."""
    a = a.copy()
    for s, be in zip(starts, bases):
        a[:, :, s:s + 4] = a[:, :, s:s + 4] @ be
    return a


class _Tangent:
    """The pencil in tangent coordinates: the map T, ``M_r``, the assembled ``K_r`` and its
    accurate products of one linearization."""

    def __init__(self, lin, num):
        rn, (parts, euler_diag) = lin.reduced, lin.blocks
        self.rn, self.num = rn, num
        b = rn.basis(lin.x[rn.eu])
        self.euler_diag = euler_diag
        # per group: D and H in the rotated coordinates, and S
        self.parts = []
        k_rot = []
        for (D, S, H), starts, nodes in zip(parts, rn.slots, rn.slot_nodes):
            bases = [b[nd] for nd in nodes]
            d_rot = _rotate_columns(D, bases, starts)
            dt = np.ascontiguousarray(d_rot.transpose(0, 2, 1))
            k = dt @ (S @ d_rot)
            h_rot = None                   # H vanishes in an unstressed state
            if H is not None:
                h_rot = _rotate_columns(H, bases, starts)
                for s, be in zip(starts, bases):
                    h_rot[:, s:s + 4, :] = be.transpose(0, 2, 1) @ h_rot[:, s:s + 4, :]
                k += h_rot
            self.parts.append((d_rot, dt, S, h_rot))
            k_rot.append(k)
        diag = np.broadcast_to(euler_diag[:, None, None] * np.eye(4),
                               (rn.nodes.size, 4, 4))
        self.upper = rn.pattern.assemble(k_rot + [diag])      # K_r, upper triangle
        del k_rot
        # T: reduced unknown -> free coordinate
        u = num.unknown_of
        red = rn.unknown_of
        plain = np.flatnonzero(rn.keep)
        plain = plain[~np.isin(plain, rn.eu)]
        rows = np.concatenate([u[plain], np.repeat(u[rn.eu], 3, axis=1).ravel()])
        cols = np.concatenate([red[plain], np.tile(red[rn.eu[:, 1:]], (1, 4)).ravel()])
        vals = np.concatenate([np.ones(plain.size), b[:, :, 1:].reshape(-1)])
        self.n = rn.n
        self.T = sp.csr_matrix((vals, (rows, cols)), shape=(num.n_unknown, rn.n))
        self.Tt = self.T.T.tocsr()
        self.M = (self.Tt @ lin.M @ self.T).tocsr()
        # per group and chunk of elements: the reduced unknown of every local slot (-1:
        # fixed, or an Euler node's radial slot) and the scatter of the element vectors
        # onto the rows lo..hi of the reduced unknowns that the chunk touches
        self.chunks = []
        for g in num.groups:
            parts = []
            for a in range(0, g.n_elem, CHUNK):
                ridx = red[g.idx[a:a + CHUNK]]
                flat = ridx.ravel()
                ok = flat >= 0
                lo = int(flat[ok].min()) if ok.any() else 0
                hi = int(flat[ok].max()) + 1 if ok.any() else 0
                scat = sp.csr_matrix((np.ones(int(ok.sum())),
                                      (flat[ok] - lo, np.flatnonzero(ok))),
                                     shape=(hi - lo, flat.size))
                parts.append((slice(a, a + CHUNK), ridx, ridx < 0, lo, hi, scat))
            self.chunks.append(parts)
        self.tangent_slots = red[rn.eu[:, 1:]]                     # (n_eu, 3)

    def products(self, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(K_r Y, Y^T K_r Y)`` element by element: each element's positions relative
        to its first node (exact: the blocks are invariant to translations), the material
        part as ``D^T (S (D y))`` and the quadratic form as ``sum (D y)^T S (D y)`` (the
        assembled ``D^T S D`` loses the soft part to the round-off of its entries)."""
        num = self.num
        p = Y.shape[1]
        out = np.zeros((self.n, p))
        gram = np.zeros((p, p))
        for g, (d, dt, s, h), chunks in zip(num.groups, self.parts, self.chunks):
            for sl, ridx, void, lo, hi, scat in chunks:
                ze = Y[ridx]                                   # (n, n_ldof, p)
                ze[void] = 0.0                                 # fixed and radial slots
                ze = relative_positions(ze, g.kind.position_starts)
                rates = d[sl] @ ze
                sr = s[sl] @ rates
                gram += rates.reshape(-1, p).T @ sr.reshape(-1, p)
                f = dt[sl] @ sr
                if h is not None:
                    hz = h[sl] @ ze
                    gram += ze.reshape(-1, p).T @ hz.reshape(-1, p)
                    f += hz
                out[lo:hi] += scat @ f.reshape(-1, p)
        # the Euler nodes' 2 mu on their tangent slots
        t = self.tangent_slots
        yt = Y[t]                                                  # (n_eu, 3, p)
        dyt = self.euler_diag[:, None, None] * yt
        out[t] += dyt
        gram += dyt.reshape(-1, p).T @ yt.reshape(-1, p)
        return out, 0.5 * (gram + gram.T)


def applies(lin) -> bool:
    """Whether :func:`lowest_modes` can work on ``lin``: a mass, the static solver's reduced
    form (:func:`spacarpy.solvers.statics.reduced.applies`) and the element blocks kept by
    :func:`~spacarpy.solvers.linear.linearize.linearize`."""
    return lin.M is not None and getattr(lin, "reduced", None) is not None \
        and getattr(lin, "blocks", None) is not None


def _ritz(blocks, ks, ms, k):
    """Rayleigh-Ritz on the span of the blocks ``(S, K_r S, M_r S)`` with the projected
    ``ks = S^T K_r S`` (from accurate products) and ``ms = S^T M_r S``: the lowest k pairs
    ``(theta, V, K_r V, M_r V)``; no product with K_r or M_r is repeated."""
    # an M-orthonormal basis of the span first: its columns may be nearly dependent
    w, u = np.linalg.eigh(0.5 * (ms + ms.T))
    keep = w > 1e-12 * w.max()
    basis = u[:, keep] / np.sqrt(w[keep])
    theta, z = sla.eigh(basis.T @ ks @ basis)
    z = basis @ z[:, :k]
    rows = np.cumsum([0] + [s.shape[1] for s, _, _ in blocks])
    out = []
    for j in range(3):                                  # V, K_r V, M_r V
        acc = blocks[0][j] @ z[:rows[1]]
        for (b, lo, hi) in zip(blocks[1:], rows[1:-1], rows[2:]):
            acc += b[j] @ z[lo:hi]                     # in place: no third full array
        out.append(acc)
    return (theta[:k], *out)


def _extend(tan, theta, V, KV, MV, W, k):
    """Rayleigh-Ritz on ``[V, W]`` where ``V`` are Ritz vectors (``V^T K_r V`` is
    ``diag(theta)`` up to round-off, ``K_r V`` and ``M_r V`` known): only ``W`` is
    multiplied. The coupling ``W^T K_r V`` is taken from the element-wise ``K_r V``; its
    round-off enters the eigenvalues only squared (V is nearly an invariant subspace)."""
    KW, kw = tan.products(W)
    MW = tan.M @ W
    kc = 0.5 * (W.T @ KV + (V.T @ KW).T)
    mc = 0.5 * (W.T @ MV + (V.T @ MW).T)
    ks = np.block([[np.diag(theta), kc.T], [kc, kw]])
    ms = np.block([[V.T @ MV, mc.T], [mc, W.T @ MW]])
    return _ritz([(V, KV, MV), (W, KW, MW)], ks, ms, k)


def lowest_modes(lin, num, n_modes: int):
    """The lowest ``n_modes`` eigenpairs ``(lam (k,) complex, vec (n_x, k))`` of ``lin``
    over its free coordinates (k = n_modes plus :data:`EXTRA`, at most the tangent
    dimension less one), or None (module docstring)."""
    if not applies(lin):
        return None
    # K's element blocks D^T S D + H: symmetric where every H is (no follower-type terms)
    for _, _, h in lin.blocks[0]:
        if h is not None and np.abs(h - h.transpose(0, 2, 1)).max() > \
                1e-12 * np.abs(h).max():
            return None
    t0 = time.perf_counter()
    tan = _Tangent(lin, num)
    t1 = time.perf_counter()
    n = tan.n
    k = min(n_modes + EXTRA, n - 1)
    if k < 1:
        return None
    factor = SPDFactorization()
    try:
        solve = factor.factorize(tan.upper)
    except FactorizationError:
        return None
    t2 = time.perf_counter()
    neg = factor.negative_pivots()
    if neg is None:
        return None
    op = spla.LinearOperator((n, n), matvec=solve, dtype=float)
    v0 = np.random.default_rng(0).standard_normal(n)     # deterministic, generic start
    try:
        _, V = spla.eigsh(tan.upper, k=k, M=tan.M, sigma=0.0, OPinv=op, which="LM",
                          v0=v0, tol=ARPACK_TOL)
    except (spla.ArpackNoConvergence, spla.ArpackError, FactorizationError) as exc:
        log.debug("tangent eigen solver: ARPACK failed (%s), bordered solver instead", exc)
        return None
    t3 = time.perf_counter()
    KV, kv = tan.products(V)
    MV = tan.M @ V
    theta, V, KV, MV = _ritz([(V, KV, MV)], kv, V.T @ MV, k)
    change = np.inf
    tiny = np.finfo(float).tiny
    nm = min(n_modes, k)                                   # the wanted ones
    for it in range(MAX_REFINE + 1):  # noqa: B007 (logged below)
        if neg > 0 and np.any(theta[:nm] <= ZERO_RTOL * np.abs(theta).max(initial=0.0)):
            # negative pivots, and an accurate Ritz value (an upper bound of an eigenvalue)
            # that is negative or zero next to the others: K_r is not positive definite
            # (the module docstring)
            log.debug("tangent eigen solver: %d negative pivots and a Ritz value %.3g, "
                      "bordered solver instead", neg, float(theta[:nm].min()))
            return None
        R = MV * theta
        np.subtract(KV, R, out=R)                          # K V - M V Theta
        # the wanted modes' corrections (the extra Ritz vectors are there to protect the
        # last wanted ones; their own corrections did not speed the convergence)
        W = np.empty((R.shape[0], nm), order="F")
        try:
            for j in range(nm):
                W[:, j] = solve(R[:, j])
            # the Rayleigh quotient's error, about r^T K^-1 r relative to theta (V is
            # M-orthonormal): below EST_RTOL, the Ritz pairs are the answer
            est = (np.abs(np.einsum("ij,ij->j", R[:, :nm], W[:, :nm]))
                   / np.maximum(np.abs(theta[:nm]), tiny))
            log.debug("tangent eigen solver: refinement %d, estimated error %.1e, "
                      "change %.1e", it, est.max(initial=0.0), change)
            if est.max(initial=0.0) <= EST_RTOL or change <= RTOL or it == MAX_REFINE:
                break
        except FactorizationError:
            return None
        old = theta[:nm]
        theta, V, KV, MV = _extend(tan, theta, V, KV, MV, W, k)
        change = float(np.max(np.abs(theta[:nm] - old)
                              / np.maximum(np.abs(theta[:nm]), tiny), initial=0.0))
    log.debug("tangent eigen solver: tangent pencil %.2f s, LDL^T %.2f s, ARPACK %.2f s, "
              "%d refinement steps %.2f s", t1 - t0, t2 - t1, t3 - t2, it,
              time.perf_counter() - t3)
    return theta.astype(complex), tan.T @ V

"""Newton steps in the tangent space of the Euler-parameter normalizations.

The static solver's Newton system is bordered by one constraint ``q.q = 1`` per orientation
node (and by the rigid-mode constraints). For an orientation node whose four Euler parameters
are all free, the constraint can be eliminated exactly: write the increment of its
parameters in the orthonormal basis ``B(q) = [q/|q|, T(q)]`` with ``T(q) = Lambda(q)^T / |q|``
(three directions tangent to the sphere, :func:`spacarpy.rotation.lambda_matrix`). The
constraint row fixes the radial component, ``2 q.dq = -(q.q - 1)``, the radial rows give the
node's multiplier increment, and what is left is a system in the tangent components only,
``B^T K B`` without its radial rows and columns. This is the same Newton step as the bordered
one in exact arithmetic (a null-space elimination, not an approximation).

When every constraint of a model is of this kind and no dead moment loads it (their
derivative is skew-symmetric), the remaining matrix is the symmetric tangent stiffness in
rotation-like coordinates, which is positive definite at a stable equilibrium and is
factorized by the LDL^T of :class:`~spacarpy.solvers.linalg.sparse.SPDFactorization` with its
ordering and symbolic analysis done once per model (the bordered matrix has zero diagonal
blocks and needs SuperLU's pivoting instead). A step is checked by its residual in the
reduced system; an inaccurate one (an LDL^T without pivoting on an indefinite matrix near a
limit point), or a tangent with a non-positive diagonal entry (beyond a buckling load: the
factorization equilibrates by the diagonal), returns ``None`` and the caller solves the
bordered system with SuperLU instead.
"""
from __future__ import annotations

import logging
import math
import time
from functools import partial

import numpy as np
import scipy.sparse.linalg as spla

from spacarpy.assembly import BlockPattern, scatter_add
from spacarpy.elements.base import relative_positions
from spacarpy.elements.chunks import in_chunks
from spacarpy.linalg import batch_matvec
from spacarpy.rotation import lambda_matrix
from spacarpy.solvers.linalg.sparse import FactorizationError, SPDFactorization

log = logging.getLogger(__name__)


_EYE4 = np.eye(4)
#: ``[q, Lambda(q)^T]`` (4, 4) flattened = ``q @ _BASIS_FORM``: (4, 16).
_BASIS_FORM = np.stack([np.concatenate([e[:, None], lambda_matrix(e).T], axis=1).ravel()
                        for e in np.eye(4)])


def _norm(v: np.ndarray) -> float:
    """The 2-norm of a vector, as ``np.linalg.norm`` computes it (without its overhead)."""
    return math.sqrt(v @ v)


def _rotate_blocks(k, *bases, starts):
    """``B_e^T k B_e`` for blocks k (n, n_ldof, n_ldof) whose Euler quadruples start at the
    local slots ``starts``, with the bases (n, 4, 4) of those nodes (k is overwritten)."""
    for s, be in zip(starts, bases):
        k[:, :, s:s + 4] = k[:, :, s:s + 4] @ be
        k[:, s:s + 4, :] = be.transpose(0, 2, 1) @ k[:, s:s + 4, :]
    return k


def _element_products(k, idx, z, shift):
    """``k_e z_e`` (n, n_ldof) with ``z_e = z[idx_e]``, the position triples starting at the
    local slots ``shift`` taken relative to the first of them (see ReducedNewton._k_times)."""
    return batch_matvec(k, relative_positions(z[idx], shift))


def applies(prob) -> bool:
    """Whether the model's Newton steps can use :class:`ReducedNewton`: every constraint is
    the normalization of a node with four free Euler parameters, no rigid modes, no moment
    loads or follower loads (their load stiffness is not symmetric), and element kinds whose
    Euler parameters come in slots of four."""
    num = prob.num
    if (num.n_rigid or prob.loads.moment_rot.size or prob.loads.parts
            or not num.euler_nodes.size):
        return False
    free = ~num.fixed_mask
    if not free[num.euler_coords].all():
        return False
    try:
        _quaternion_slots(num)
    except ValueError:
        return False
    return True


def _quaternion_slots(num):
    """Per element group, the local slots where an Euler-parameter quadruple starts (its
    four parameters in order lambda0..lambda3 in consecutive slots, the same for every
    element of the group)."""
    comp = np.full(num.n_coord, -1, dtype=np.int64)
    comp[num.rot_idx] = np.arange(4)
    out = []
    for g in num.groups:
        c = comp[g.idx]                                   # (n_e, n_ldof)
        if g.n_elem and (c != c[0]).any():
            raise ValueError(f"{g.keyword}: Euler parameters in varying local slots")
        first = c[0] if g.n_elem else np.full(g.idx.shape[1], -1)
        starts = np.flatnonzero(first == 0)
        for s in starts:
            if s + 4 > first.size or not np.array_equal(first[s:s + 4], np.arange(4)):
                raise ValueError(f"{g.keyword}: Euler parameters not in slots of four")
        if (first >= 0).sum() != 4 * starts.size:
            raise ValueError(f"{g.keyword}: incomplete Euler-parameter slots")
        out.append(starts)
    return out


#: Conjugate-gradient iterations tried with an earlier supernodal (PARDISO) factorization
#: as the preconditioner before a new one is made (docs/solver.md, "Fewer factorizations").
REUSE_ITERATIONS = 12


class ReducedNewton:
    """Newton steps of a :class:`~spacarpy.solvers.statics.equilibrium.StaticProblem` without
    its Euler constraints (see the module docstring); build only where :func:`applies`."""

    def __init__(self, prob):
        self.prob = prob
        num = prob.num
        self.nodes = num.euler_nodes                       # orientation-node indices
        self.eu = num.euler_coords                         # (n_eu, 4) coordinate indices
        self.slots = _quaternion_slots(num)
        self.n_rigid = num.n_rigid                         # (0 where it applies)
        node_of = np.full(num.n_coord, -1, dtype=np.int64)
        node_of[self.eu[:, 0]] = np.arange(self.nodes.size)
        # for each group and quaternion slot: which Euler node (index into self.nodes)
        self.slot_nodes = [[node_of[g.idx[:, s]] for s in starts]
                           for g, starts in zip(num.groups, self.slots)]
        # reduced unknowns: the free coordinates without the radial (lambda0) slot of each
        # Euler node, whose component follows from the constraint
        keep = ~num.fixed_mask
        keep[self.eu[:, 0]] = False
        self.unknown_of = np.full(num.n_coord, -1, dtype=np.int64)
        self.unknown_of[keep] = np.arange(int(keep.sum()))
        self.n = int(keep.sum())
        self.keep = keep
        self.free = ~num.fixed_mask
        self.pattern = BlockPattern(self.n, [self.unknown_of[g.idx] for g in num.groups]
                                    + [self.unknown_of[self.eu]], upper=True)
        self.factor = SPDFactorization()
        self._quick_misses = 0                  # see _refine
        self._last = None                       # see last and chord
        self._reusable = None                   # a supernodal factorization (see step)
        self.negative_pivots = None             # see step

    def basis(self, q: np.ndarray, nq: np.ndarray | None = None) -> np.ndarray:
        """``B(q) = [q/|q|, Lambda(q)^T/|q|]``, (n, 4, 4) orthonormal for every q != 0 (``nq``:
        the norms ``|q|`` where the caller has them)."""
        if nq is None:
            nq = np.linalg.norm(q, axis=1)
        # [q, Lambda(q)^T] is linear in q, its entries signed copies of q's: one product
        # with a constant (exact), then the division
        b = (q @ _BASIS_FORM).reshape(q.shape + (4,))
        b /= nq[:, None, None]
        return b

    def rotate(self, k_el, b):
        """Element blocks in the rotated coordinates: ``B_e^T k B_e`` per element (in place:
        the caller's blocks are its own and not used afterwards)."""
        out = []
        for k, starts, nodes in zip(k_el, self.slots, self.slot_nodes):
            out.append(in_chunks(partial(_rotate_blocks, starts=starts), len(k), k,
                                 *[b[nd] for nd in nodes]))
        return out

    def _k_times(self, k_rot, euler_diag, z, all_slots: bool = False,
                 invariant: bool = True):
        """``K z`` (n_coord,) in the rotated coordinates, element by element. The Euler
        nodes' diagonal (2 mu I in any orthonormal basis) is added on the radial slots only
        (:meth:`step` uses it where z has only radial entries, or reads only radial rows),
        or on all four with ``all_slots``.

        Each element's position slots are first taken relative to its first node
        (:func:`~spacarpy.elements.base.relative_positions`): exact, since the stiffness
        is invariant to a translation of all of an element's nodes, and it keeps the soft
        (bending) part of ``K z``, which the products of ``EA/l0`` with displacements of
        the size of the whole structure lose in their round-off. Blocks that carry mass
        (the transient iteration matrix) are not translation invariant: ``invariant=False``
        multiplies them as they are."""
        num = self.prob.num
        kz = np.zeros(num.n_coord)
        for g, k in zip(num.groups, k_rot):
            shift = g.kind.position_starts if invariant else np.zeros(0, dtype=np.int64)
            kz += scatter_add(num.n_coord, g.idx,
                              in_chunks(partial(_element_products, z=z, shift=shift),
                                        len(k), k, g.idx))
        if all_slots:
            kz[self.eu] += euler_diag[:, None] * z[self.eu]
        else:
            radial = self.eu[:, 0]
            kz[radial] += euler_diag * z[radial]
        return kz

    def _radial_columns(self, k_rot, euler_diag, zr):
        """``K z`` (n_coord,) for a z whose only entries are ``zr`` (n_eu,) on the radial
        slots (the particular solution of the Euler constraints): the radial columns of the
        element blocks, the Euler-node diagonal on the radial slots (what :meth:`_k_times`
        gives for such a z, without its products with zeros)."""
        num = self.prob.num
        kz = np.zeros(num.n_coord)
        zr_all = np.append(zr, 0.0)          # a fixed orientation node (-1): no entry
        for g, k, starts, nodes in zip(num.groups, k_rot, self.slots, self.slot_nodes):
            if starts.size:
                ke = k[:, :, starts[0]] * zr_all[nodes[0]][:, None]
                for s, nd in zip(starts[1:], nodes[1:]):
                    ke += k[:, :, s] * zr_all[nd][:, None]
                kz += scatter_add(num.n_coord, g.idx, ke)
        kz[self.eu[:, 0]] += euler_diag * zr
        return kz

    def _reduced_times(self, k_rot, euler_diag, y, invariant: bool = True):
        """The reduced matrix times y (over the reduced unknowns), element by element."""
        z = np.zeros(self.prob.num.n_coord)
        z[self.keep] = y
        return self._k_times(k_rot, euler_diag, z, all_slots=True,
                             invariant=invariant)[self.keep]

    def _refine(self, solve, matvec, rhs, max_iter: int = 30, quick_matvec=None,
                accept: float = 1e-3):
        """Solve ``A y = rhs`` by conjugate gradients preconditioned with the LDL^T
        ``solve``, with the element-by-element product ``matvec`` (see :meth:`_k_times`).

        The factorization of the assembled matrix is as accurate as the assembled matrix:
        on a 10^5-element cantilever its solution is off by 10-260 % in the soft bending
        directions (their stiffness is 1e-15 of the axial one), which left Newton converging
        linearly at best. As a preconditioner it is excellent, and the element-wise product
        is accurate, so a few iterations give the step that Newton needs. Where the
        preconditioner turns out not to be positive definite (the round-off of the LDL^T can
        flip the sign of the softest pivots) the iterations continue with GMRES. Returns
        None when the result is still inaccurate (relative residual above 1e-3: an LDL^T
        without pivoting of an indefinite matrix near a limit point); the caller then
        takes the bordered system instead. ``quick_matvec`` (the assembled matrix's product,
        cheaper for small models) first tests the plain solution: where its residual is
        below the iterations' tolerance (well-conditioned models) it is taken as it is;
        after three misses in a row that test is no longer made. The accuracy reported and
        checked at the end is CG's updated residual (GMRES's true one)."""
        y = solve(rhs)
        b_norm = _norm(rhs)
        if b_norm == 0.0:
            return y
        tol = 1e-10 * b_norm
        if quick_matvec is not None and self._quick_misses < 3:
            if _norm(rhs - quick_matvec(y)) <= tol:
                self._quick_misses = 0
                return y
            self._quick_misses += 1      # three in a row: a model that needs the iterations
        r = rhs - matvec(y)
        if _norm(r) <= tol:
            return y
        p = z = solve(r)
        rz = r @ z
        method = "conjugate gradients"
        for it in range(max_iter):  # noqa: B007 (it is logged after the loop)
            ap = matvec(p)
            pap = p @ ap
            if not pap > 0.0 or not rz > 0.0:
                # the matrix, or its LDL^T (the round-off of the factorization can flip the
                # sign of the softest pivots), is not positive definite: GMRES does not
                # need that, and converges in a few iterations more
                y, _ = spla.gmres(spla.LinearOperator((rhs.size,) * 2, matvec=matvec),
                                  rhs, x0=y, rtol=1e-10, restart=10, maxiter=1,
                                  M=spla.LinearOperator((rhs.size,) * 2, matvec=solve))
                r = rhs - matvec(y)
                method = "GMRES after conjugate gradients"
                break
            alpha = rz / pap
            y = y + alpha * p
            r = r - alpha * ap
            if _norm(r) <= tol:          # (before the solve the next step needs)
                it += 1
                break
            z = solve(r)
            rz, rz_old = r @ z, rz
            p = z + (rz / rz_old) * p
        final = _norm(r) / b_norm          # (CG's updated residual, or GMRES's)
        log.debug("%s: %d iterations, relative residual %.2e", method, it, final)
        if not final <= accept:
            return None
        return y

    def _right_side(self, ev, nq, b, residual, k_rot, euler_diag, invariant):
        """The rotated residual over all coordinates, the radial particular solution z of
        the Euler constraints (``2 q.dq = -c``) and the reduced right-hand side."""
        num = self.prob.num
        r_full = (ev.f_int - ev.f_ext) if residual is None else residual.copy()
        r_full[self.eu] = np.einsum("nab,na->nb", b, r_full[self.eu])
        z = np.zeros(num.n_coord)
        c_eu = ev.c[self.n_rigid:]
        z[self.eu[:, 0]] = -c_eu / (2.0 * nq)
        # K z for that particular solution, element by element (only radial entries of z
        # are nonzero), plus the Euler-node diagonal 2 mu
        rhs = -(r_full + self._radial_columns(k_rot, euler_diag, z[self.eu[:, 0]]))[self.keep]
        return r_full, z, rhs

    @property
    def last(self):
        """The last successful :meth:`step`'s factorization and element blocks (for
        :meth:`chord`), or None."""
        return self._last

    def chord(self, last, ev, x, residual=None):
        """The chord (modified Newton) increment ``(dx over the free coordinates, dmu)`` at
        the state (x, ``ev``) with an earlier :meth:`step`'s factorization and element
        blocks ``last`` (:attr:`last`), without refinement; None when ``last`` is None or
        the solve fails. The tangent-space basis and the Euler constraints' radial part
        are those of the new state, so the increment keeps ``q.q = 1`` to first order
        whatever the age of the matrix."""
        if last is None:
            return None
        k_rot, euler_diag, invariant, solve = last
        q = x[self.eu]
        nq = np.linalg.norm(q, axis=1)
        b = self.basis(q, nq)
        r_full, z, rhs = self._right_side(ev, nq, b, residual, k_rot, euler_diag, invariant)
        try:
            z[self.keep] = solve(rhs)
        except FactorizationError:
            return None
        radial = self.eu[:, 0]
        dmu = -(r_full[radial] + self._k_times(k_rot, euler_diag, z, invariant=invariant)[
            radial]) / (2.0 * nq)
        z[self.eu] = np.einsum("nab,nb->na", b, z[self.eu])
        return z[self.free], np.concatenate([np.zeros(self.n_rigid), dmu])

    def step(self, ev, x, mu, k_el, euler_diag, residual=None, invariant: bool = True,
             load=None):
        """The Newton increment ``(dx over the free coordinates, dmu)``, or None when the
        factorization fails or its solution is inaccurate (the caller then solves the
        bordered system). ``residual`` (n_coord,) replaces the static force residual
        ``f_int - f_ext`` of ``ev`` (the transient solver adds the inertia forces; its
        ``k_el`` carry ``beta' M + gamma' C``, and it passes ``invariant=False``: blocks
        with mass are not invariant to translations, see :meth:`_k_times`).

        ``load`` (n_coord,), a generalized force: also solve ``K b = load`` with the
        linearized constraints homogeneous (``C b = 0``), with the same factorization (the
        arc-length corrector's load column), and return ``(dx, dmu, b, b_mu)``. After the
        call :attr:`negative_pivots` is the number of negative pivots of the factorized
        reduced tangent (its index, by Sylvester's law of inertia), or None where it was
        not factorized."""
        prob, num = self.prob, self.prob.num
        timings = prob.timings
        t0 = time.perf_counter()
        q = x[self.eu]
        nq = np.linalg.norm(q, axis=1)
        b = self.basis(q, nq)
        k_rot = self.rotate(k_el, b)
        r_full, z, rhs = self._right_side(ev, nq, b, residual, k_rot, euler_diag, invariant)
        self._last = None
        diag = np.broadcast_to(euler_diag[:, None, None] * _EYE4, (self.nodes.size, 4, 4))
        t1 = time.perf_counter()
        a = self.pattern.assemble(k_rot + [diag])
        t2 = time.perf_counter()
        timings.kernels += t1 - t0
        timings.assembly += t2 - t1
        self.negative_pivots = None
        radial = self.eu[:, 0]

        def matvec(v):
            return self._reduced_times(k_rot, euler_diag, v, invariant)
        try:
            # an earlier supernodal factorization as the preconditioner of this matrix:
            # taken where conjugate gradients reach the full tolerance in a few iterations
            # (about a solve each, where a factorization of a 3D model costs 30-100 solves)
            y = solve = None
            if self._reusable is not None and load is None:
                y = self._refine(self._reusable, matvec, rhs, max_iter=REUSE_ITERATIONS,
                                 accept=1e-10)
                if y is not None:
                    solve = self._reusable
                    timings.reuses += 1
            if y is None:
                solve = self.factor.factorize(a)
                timings.factorizations += 1
                self._reusable = solve if self.factor.backend == "pardiso" else None
            if load is not None:
                self.negative_pivots = self.factor.negative_pivots()

            def refined(right):
                return self._refine(solve, matvec, right,
                                    quick_matvec=partial(self.pattern.symmetric_matvec, a.data))
            if y is None:
                y = refined(rhs)
            if y is None:
                return None
            self._last = (k_rot, euler_diag, invariant, solve)
            if load is not None:
                # K b = load with C b = 0: no radial particular part (z = 0)
                l_full = np.asarray(load, dtype=float).copy()
                l_full[self.eu] = np.einsum("nab,na->nb", b, l_full[self.eu])
                yb = refined(l_full[self.keep])
                if yb is None:
                    return None
        except FactorizationError:
            return None
        finally:
            timings.solve += time.perf_counter() - t2
        if load is not None:
            zb = np.zeros(num.n_coord)
            zb[self.keep] = yb
            b_mu = (l_full[radial] - self._k_times(k_rot, euler_diag, zb,
                                                   invariant=invariant)[radial]) / (2.0 * nq)
            zb[self.eu] = np.einsum("nab,nb->na", b, zb[self.eu])
        z[self.keep] = y
        # back to the Euler parameters, and the multiplier increments from the radial rows:
        # (K z)_radial + 2 |q| dmu = -r_radial
        dmu = -(r_full[radial] + self._k_times(k_rot, euler_diag, z, invariant=invariant)[
            radial]) / (2.0 * nq)
        dq = np.einsum("nab,nb->na", b, z[self.eu])
        z[self.eu] = dq
        step = z[self.free], np.concatenate([np.zeros(self.n_rigid), dmu])
        if load is None:
            return step
        return step + (zb[self.free], np.concatenate([np.zeros(self.n_rigid), b_mu]))

"""The kinematic correction: Gauss-Newton iterations that move a configuration onto given
deformations (and the Euler normalizations), and the linear algebra of its Jacobian.

The Jacobian is ``W = [D / scale; 2 q^T]`` (the deformation Jacobians of the elements, each
row scaled by the element's length, and the Euler rows). Square W (trees of elements) is
solved directly, :class:`SquareJacobian`, block triangular where it can be; other models by
the normal equations, :class:`NormalEquations`, or :class:`ReducedNormalEquations` in the
tangent space of the Euler normalizations where Newton's steps are taken there.
:class:`KinematicCorrector` owns the kept factorization between Newton iterations. See
docs/solver.md, "Kinematic correction".
"""
from __future__ import annotations

import logging
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.assembly import BlockPattern, scatter_add
from spacarpy.linalg import batch_matvec
from spacarpy.solvers.linalg.sparse import FactorizationError, SPDFactorization
from spacarpy.solvers.linalg.triangular import BlockTriangular

log = logging.getLogger(__name__)


class SquareJacobian:
    """The kinematic correction's Jacobian ``W = [D / scale; 2 q^T]`` as a square sparse
    matrix, for models with exactly as many deformations and Euler normalizations as free
    coordinates (trees of elements: every element adds its end node). The Gauss-Newton step
    is solved as ``W step = g`` instead of through the normal equations ``W^T W``, whose
    condition number is that of W squared: on a 10^5-element cantilever W^T W is beyond
    double precision and its steps are noise. A tree's W is block triangular, and is solved
    by block forward substitution (:class:`~spacarpy.solvers.linalg.triangular.BlockTriangular`,
    several times faster than a sparse LU of the same matrix); other square patterns by
    SuperLU's LU with partial pivoting (:class:`SparseLU`).

    Like :class:`NormalEquations`: ``factorize(w_e, wq, timings)`` returns
    ``step(g_e, g_q, w_e, wq)``; ``stale_after`` is the Newton increment after which a kept
    factorization is dropped, ``jacobian_each_step`` whether ``step`` needs the current W."""

    stale_after = 1e-2          # its chord steps still contract fast after such increments
    jacobian_each_step = False

    @staticmethod
    def applies(num) -> bool:
        n_rows = sum(g.idx.shape[0] * g.scale.shape[1] for g in num.groups)
        return num.n_unknown > 0 and n_rows + num.euler_nodes.size == num.n_unknown

    def __init__(self, num, triangular: bool = True):
        rows, cols, off = [], [], 0
        for g in num.groups:
            n_e, n_def = g.scale.shape
            r = off + np.arange(n_e * n_def).reshape(n_e, n_def)
            rows.append(np.broadcast_to(r[:, :, None], (n_e, n_def, g.idx.shape[1])).ravel())
            cols.append(np.broadcast_to(num.unknown_of[g.idx][:, None, :],
                                        (n_e, n_def, g.idx.shape[1])).ravel())
            off += n_e * n_def
        eu = num.euler_coords
        rows.append(np.repeat(off + np.arange(eu.shape[0]), 4))
        cols.append(num.unknown_of[eu].ravel())
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        keep = np.flatnonzero(cols >= 0)            # entries in fixed columns are dropped
        n = num.n_unknown
        self.keep = keep
        # a tree's W is block triangular (supports outwards): block forward substitution,
        # its structure found once from the pattern (triangular.py); SuperLU where it is not
        self.solver = None
        if triangular:
            try:
                self.solver = BlockTriangular(rows[keep], cols[keep], n)
            except ValueError as exc:
                log.debug("kinematic correction: not block triangular (%s), SuperLU", exc)
        if self.solver is None:
            self.solver = SparseLU(rows[keep], cols[keep], n)

    def _entries(self, w_e, wq) -> np.ndarray:
        """W's entries, in the pattern's order, from the element blocks and Euler rows."""
        return np.concatenate([w.ravel() for w in w_e] + [wq.ravel()])[self.keep]

    def regular(self, w_e, wq) -> bool:
        """Whether W is block triangular with well-conditioned diagonal blocks (False when
        its structure is not block triangular: then it cannot tell)."""
        return (isinstance(self.solver, BlockTriangular)
                and self.solver.regular(self._entries(w_e, wq)))

    def factorize(self, w_e, wq, timings):
        """Factorize W for the element blocks ``w_e`` (per group (n_e, n_def, n_ldof)) and the
        Euler rows ``wq`` (n_eu, 4)."""
        t0 = time.perf_counter()
        data = self._entries(w_e, wq)
        timings.assembly += time.perf_counter() - t0
        solve = self.solver.factorize(data)

        def step(g_e, g_q, w_e, wq):
            out = solve(np.concatenate([v.ravel() for v in g_e] + [g_q]))
            if not np.isfinite(out).all():
                raise FactorizationError("non-finite Gauss-Newton step")
            return out
        return step


class SparseLU:
    """SuperLU (partial pivoting, COLAMD) for square matrices with the pattern ``(rows,
    cols)``; the same interface as :class:`~spacarpy.solvers.linalg.triangular.BlockTriangular`:
    ``factorize(data) -> solve``."""

    def __init__(self, rows, cols, n: int):
        # the CSC layout once: which entry of ``data`` fills each data slot (no duplicates:
        # a row belongs to one element or node)
        order = sp.csc_matrix((np.arange(1, rows.size + 1, dtype=float), (rows, cols)),
                              shape=(n, n))
        self.source = order.data.astype(np.int64) - 1
        self.indices, self.indptr, self.n = order.indices, order.indptr, n

    def factorize(self, data):
        mat = sp.csc_matrix((data[self.source], self.indices, self.indptr),
                            shape=(self.n, self.n))
        try:
            return spla.splu(mat, permc_spec="COLAMD").solve
        except RuntimeError as exc:              # singular: e.g. a straight-line start
            raise FactorizationError(str(exc)) from None


class NormalEquations:
    """The kinematic correction's Gauss-Newton step from the normal equations
    ``W^T W step = W^T g`` (least squares: closed loops, more deformations than unknowns),
    factorized by QDLDL (:class:`~spacarpy.solvers.linalg.sparse.SPDFactorization`). Same interface
    as :class:`SquareJacobian`; the right side is formed with the current W."""

    stale_after = 1e-3
    jacobian_each_step = True

    def __init__(self, num):
        self.num = num
        self.free = ~num.fixed_mask
        self.eu = num.euler_coords
        self.pattern = BlockPattern(
            num.n_unknown, [num.unknown_of[g.idx] for g in num.groups]
            + [num.unknown_of[self.eu]], upper=True)
        self.factor = SPDFactorization()

    def factorize(self, w_e, wq, timings):
        t0 = time.perf_counter()
        m = self.pattern.assemble([w.transpose(0, 2, 1) @ w for w in w_e]
                                  + [wq[:, :, None] * wq[:, None, :]], diag_shift=1e-12)
        timings.assembly += time.perf_counter() - t0
        solve = self.factor.factorize(m)
        num = self.num

        def step(g_e, g_q, w_e, wq):
            rhs = scatter_add(num.n_coord, self.eu, wq * g_q[:, None])
            for g, w, ge in zip(num.groups, w_e, g_e):
                rhs += scatter_add(num.n_coord, g.idx, batch_matvec(w.transpose(0, 2, 1), ge))
            return solve(rhs[self.free])
        return step


class ReducedNormalEquations:
    """The normal equations in the tangent space of the Euler normalizations: the reduced
    coordinates of :class:`~spacarpy.solvers.statics.reduced.ReducedNewton` (each orientation
    node's four parameter increments in the orthonormal basis ``B(q) = [q/|q|, T(q)]``).

    The Euler row ``2 q.dq = g_q`` fixes a node's radial component exactly,
    ``dz_0 = g_q / (2 |q|)``; the element rows are then fitted in least squares over the
    positions and the three tangent components, ``W_t^T W_t dz_t = W_t^T (g_e - W_0 dz_0)``
    (W_t, W_0 the tangent and radial columns of ``W B``). A null-space elimination of the
    Euler rows, as Newton's own step does: 6 unknowns per orientation node instead of 7,
    the pattern of the reduced tangent. On the 3D lattice of 10^5 beams the factor has
    178 instead of 242 million entries (docs/solver.md, "Kinematic correction"). Used where
    ReducedNewton applies and W is not square; same interface as :class:`NormalEquations`.
    """

    stale_after = 1e-3
    jacobian_each_step = True

    def __init__(self, num, reduced):
        self.num, self.rn = num, reduced
        self.free = ~num.fixed_mask
        self.eu = num.euler_coords
        self.pattern = BlockPattern(reduced.n, [reduced.unknown_of[g.idx] for g in num.groups],
                                    upper=True)
        self.factor = SPDFactorization()

    def factorize(self, w_e, wq, timings):
        t0 = time.perf_counter()
        b = self.rn.basis(0.5 * wq)
        # (W B)^T (W B) = B^T (W^T W) B per element: ReducedNewton's rotation of blocks
        wtw = self.rn.rotate([w.transpose(0, 2, 1) @ w for w in w_e], b)
        m = self.pattern.assemble(wtw, diag_shift=1e-12)
        timings.assembly += time.perf_counter() - t0
        solve = self.factor.factorize(m)
        num, rn, eu = self.num, self.rn, self.eu

        def step(g_e, g_q, w_e, wq):
            q = 0.5 * wq
            nq = np.linalg.norm(q, axis=1)
            b = rn.basis(q, nq)
            z0 = g_q / (2.0 * nq)                          # the radial components
            dq0 = np.zeros(num.n_coord)
            dq0[eu] = q * (z0 / nq)[:, None]               # as Euler-parameter increments
            # (W B)^T (g_e - W dq0): W^T per element, then B^T on each orientation node
            rhs = np.zeros(num.n_coord)
            for g, w, ge in zip(num.groups, w_e, g_e):
                r = ge - batch_matvec(w, dq0[g.idx])
                rhs += scatter_add(num.n_coord, g.idx, batch_matvec(w.transpose(0, 2, 1), r))
            rhs[eu] = batch_matvec(b.transpose(0, 2, 1), rhs[eu])
            z = np.zeros(num.n_coord)
            z[rn.keep] = solve(rhs[rn.keep])
            z[eu[:, 0]] = z0
            z[eu] = batch_matvec(b, z[eu])                 # back to Euler parameters
            return z[self.free]
        return step


class KinematicCorrector:
    """The kinematic correction of one model: its Gauss-Newton system (:attr:`system`, a
    :class:`SquareJacobian` where W is square, else :class:`NormalEquations`, or
    :class:`ReducedNormalEquations` after :meth:`use_reduced`) and the factorization kept
    from one call to the next (a chord iteration).

    ``timings`` (a :class:`~spacarpy.solvers.statics.equilibrium.Timings`) books the kernel,
    assembly and solve time of the correction."""

    def __init__(self, num, variant: str, timings):
        self.num, self.variant, self.timings = num, variant, timings
        self.system = (SquareJacobian(num) if SquareJacobian.applies(num)
                       else NormalEquations(num))
        self.free = ~num.fixed_mask
        self.eu = num.euler_coords
        self.inv_scale = [1.0 / g.scale for g in num.groups]
        self._solve = None                    # the step() of the kept factorization
        self._rate = None                     # the last contraction of the mismatch
        # round-off level of the scaled deformation mismatch: the coordinates' round-off
        # relative to the shortest element scale
        min_scale = min([float(np.min(g.scale, initial=np.inf)) for g in num.groups]
                        + [np.inf])
        self.kin_floor = 64 * np.finfo(float).eps * num.length_scale / (
            min_scale if np.isfinite(min_scale) and min_scale > 0 else 1.0)

    def use_reduced(self, reduced) -> None:
        """Fit the normal equations in the tangent space of the Euler normalizations
        (:class:`ReducedNormalEquations`) where W is not square and Newton's steps are
        reduced: fewer unknowns, the same least-squares fit of the element rows."""
        if isinstance(self.system, NormalEquations):
            self.system = ReducedNormalEquations(self.num, reduced)
            self._solve = None

    def _stationary(self, states, x, g_e, g_q, w_e=None) -> bool:
        """Whether x is a least-squares solution of the targets to round-off: the
        Gauss-Newton step there (with the kept factorization and the current W, which the
        normal equations' right side needs) is below the round-off level
        :attr:`kin_floor` (positions relative to the length scale, Euler parameters as they
        are); ``w_e`` the element blocks of W at x where the caller has them."""
        if w_e is None:
            w_e = self.jacobian_blocks(states, x)[0]
        step = self._solve(g_e, g_q, w_e, 2.0 * x[self.eu])
        rot = self.num.is_rotation_coord[self.free]
        size = max(float(np.abs(step[~rot]).max(initial=0.0)) / self.num.length_scale,
                   float(np.abs(step[rot]).max(initial=0.0)))
        return size <= self.kin_floor

    def jacobian_blocks(self, states, x):
        """The Jacobian W at x by blocks: ``D / scale`` per element group and the Euler rows
        ``2 q`` (see :class:`SquareJacobian`)."""
        return ([st.D * w[:, :, None] for w, st in zip(self.inv_scale, states)],
                2.0 * x[self.eu])

    def regular(self, states, x) -> bool:
        """Whether W at x is square, block triangular and regular (see
        :meth:`SquareJacobian.regular`); False when that cannot be told."""
        return (isinstance(self.system, SquareJacobian)
                and self.system.regular(*self.jacobian_blocks(states, x)))

    def correct(self, x_lin, dx, st_old, size: float, max_iter: int = 8, rigid_target=None,
                return_states: bool = False):
        """Move the linearly updated configuration onto the deformations Newton predicted.

        Newton's increment predicts every deformation to first order,
        ``e_target = e(x_old) + D(x_old) dx``, and the Euler normalization ``q.q = 1``. The
        linear position update itself, however, stretches every element that rotates
        (by ``l0 theta^2 / 2``); with stiff axial or bending modes that artificial strain
        makes the next residual enormous and Newton wanders (hundreds of iterations for a
        finely meshed cantilever). Like SPACAR's kinematic analysis, this step restores the
        geometry: Gauss-Newton iterations on ``e(x) = e_target``, ``q.q = 1`` in the
        least-squares sense (rows scaled by 1/l0).

        The Gauss-Newton matrix ``W^T W`` (W = D / l0) depends on the geometry only, and the
        geometry changes little from one Newton iteration to the next, so its factorization
        is kept and reused (a chord iteration) until it stops contracting fast: in a Newton
        iteration near convergence the correction costs deformation evaluations and
        back-substitutions, no factorization. The iterations stop when the correction is
        below ``|first correction|^2`` (what two exact Gauss-Newton steps reach) or below
        round-off; near the solution it is of second order, so Newton's quadratic
        convergence is kept. With the normal equations (a closed loop: the targets are
        consistent to first order only) they also stop where the mismatch has stalled and
        the next Gauss-Newton step is below round-off (:meth:`_stationary`): the
        least-squares fit is reached. An increment whose square is below round-off cannot stretch
        anything measurably and is taken as it is. With ``return_states`` the kernel states
        at the returned configuration come along (None when not computed there), so that
        the next residual evaluation does not repeat them. ``size`` is the scaled norm of
        ``dx`` (:meth:`StaticProblem.increment_norm
        <spacarpy.solvers.statics.equilibrium.StaticProblem.increment_norm>`).
        """
        num = self.num
        eu = self.eu
        xd = np.zeros(num.n_coord)
        xd[self.free] = dx
        targets = [st.e + batch_matvec(st.D, xd[g.idx]) for g, st in zip(num.groups, st_old)]
        if rigid_target is not None:          # move prescribed deformations to new values
            for g, t in zip(num.groups, targets):
                t[g.rigid_elem, g.rigid_mode] = rigid_target[g.rigid_slice]
        inv_scale = self.inv_scale

        def state_of(g, x):
            return g.kind.state(x[g.idx], g.ref, self.variant, g.prev)

        def full_states(x):
            return [state_of(g, x) for g in num.groups]

        def mismatch(x, full):
            # the deformations alone where the Jacobian is not needed (a chord iteration
            # with the kept square factorization): a third of the kernel's work; a kind
            # without a deformations kernel (HINGE) gives its full state's
            if full:
                states = full_states(x)
                e = [st.e for st in states]
            else:
                states = None
                e = [state_of(g, x).e if g.kind.deformations is None else
                     g.kind.deformations(x[g.idx], g.ref, self.variant, g.prev)
                     for g in num.groups]
            g_e = [(t - ei) * w for t, ei, w in zip(targets, e, inv_scale)]
            q = x[eu]
            g_q = 1.0 - (q * q).sum(axis=1)
            worst = max([np.abs(v).max(initial=0.0) for v in g_e]
                        + [np.abs(g_q).max(initial=0.0)])
            return states, g_e, g_q, (worst if np.isfinite(worst) else np.inf)

        if rigid_target is None and size * size < self.kin_floor:
            return (x_lin, None) if return_states else x_lin
        kin = self.system
        if size > kin.stale_after:
            self._solve = None               # a large step: the kept matrix is too stale
        x = x_lin
        done = None
        worst0 = prev = back = None
        n_factor, reused = 0, False
        rate = self._rate
        for _ in range(max_iter):
            t0 = time.perf_counter()
            full = self._solve is None or kin.jacobian_each_step
            if not full and return_states and prev is not None and rate is not None:
                # the last mismatch's states are the next residual's: where the last
                # contraction says this one ends the iterations, compute them whole (a guess
                # that errs costs the difference of the two kernels once, a miss the states
                # once more; e is the same either way, so the iterations never change)
                full = prev * rate <= max(self.kin_floor, 1e-9 * worst0)
            states, g_e, g_q, worst = mismatch(x, full)
            if prev is not None and prev > 0:
                rate = self._rate = worst / prev
            worst0 = worst if worst0 is None else worst0
            log.debug("kinematic correction: mismatch %.3g (matrix %s)", worst,
                      "kept" if self._solve is not None else "new")
            if worst <= max(self.kin_floor, 1e-9 * worst0):
                done = states
                break
            w_e = None                       # W's element blocks at x, once made
            if prev is not None and not worst <= 0.05 * prev:
                if kin.jacobian_each_step and self._solve is not None:
                    w_e = self.jacobian_blocks(states, x)[0]
                    if self._stationary(states, x, g_e, g_q, w_e):
                        # least squares: the mismatch has stopped falling because x is the
                        # closest fit to the targets; another step would not move it
                        done = states
                        break
                if reused:
                    # the kept matrix was too stale: undo its step, refactorize there
                    x, states, g_e, g_q, worst = back
                    w_e = None
                    self._solve = None
                elif n_factor >= 2:
                    # two fresh Gauss-Newton steps and still no fast contraction: targets
                    # that cannot be met exactly (least squares, a saturated deformation);
                    # stop here, as plain Gauss-Newton with two steps would
                    done = states
                    break
                else:
                    self._solve = None        # far from the targets: a fresh matrix here
            reused = self._solve is not None
            wq = 2.0 * x[eu]
            if w_e is None and (not reused or kin.jacobian_each_step):
                if states is None:
                    states = full_states(x)
                w_e = self.jacobian_blocks(states, x)[0]
            self.timings.kernels += time.perf_counter() - t0
            back = (x, states, g_e, g_q, worst)
            x = x.copy()
            t1, assembly0 = time.perf_counter(), self.timings.assembly
            try:
                if not reused:
                    self._solve = kin.factorize(w_e, wq, self.timings)
                    n_factor += 1
                    self.timings.factorizations += 1
                step = self._solve(g_e, g_q, w_e, wq)
            except FactorizationError:
                self._solve = None            # no correction possible: plain Newton
                return (x_lin, None) if return_states else x_lin
            x[self.free] += step
            # factorization and step; factorize() booked its assembly separately
            self.timings.solve += time.perf_counter() - t1 - (self.timings.assembly - assembly0)
            prev = worst
        return (x, done) if return_states else x


__all__ = ["KinematicCorrector", "NormalEquations", "ReducedNormalEquations", "SparseLU",
           "SquareJacobian"]

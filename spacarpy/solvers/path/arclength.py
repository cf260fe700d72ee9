"""Arc-length continuation of the static equilibrium path (``ARCLENGTH``): through limit
points, snap-through and snap-back, with the critical points on the path located and refined.

The unknowns are the free coordinates x, the constraint multipliers and the load factor s on
DELXF (the XF load, gravity and the initial prescribed values are reached first, at s = 0,
by the static solver's phase A). The method is the Riks normal-plane method with a
linearized constraint, one factorization per iteration (docs/path.md, "Method"):

- **Scaled norm.** ``|(dx, ds)|^2 = (1/n) sum_i (w_i dx_i)^2 + psi^2 ds^2`` over the n free
  coordinates, with ``w = 1/L`` on positions (L: the model's length scale) and ``w = 1`` on
  rotation coordinates (Euler parameters, planar angles), and ``psi = 1``: a mean square,
  so that one arc length means the same path step on a coarse and on a fine mesh.
- **Predictor.** The unit tangent ``T = (t, 1) / |(t, 1)|`` with ``K t = q`` (q: the
  derivative of the external forces by s), oriented so that it makes an acute angle with
  the last converged increment (the secant; the first step increases s). The predicted
  configuration is moved onto its linearly predicted deformations (kinematic correction).
- **Corrector.** Newton on equilibrium plus ``<T, (x - x_k, s - s_k)> = ds`` (the
  hyperplane normal to the predictor). Each iteration factors the Newton matrix once and
  back-substitutes twice, ``K a = -r`` and ``K b = q``; the load factor increment follows
  from the linear constraint, so there is no quadratic root to choose. Where the only
  constraints are Euler normalizations the tangent-space LDL^T of
  :mod:`spacarpy.solvers.statics.reduced` solves both (accurate on slender models with 10^4
  elements); elsewhere, or where its refined solution is inaccurate, SuperLU solves the
  bordered matrix.
- **Step control.** A point whose chord from the last point is longer than
  ``MAX_CHORD ds`` (the corrector moved far along the hyperplane: another branch) is
  rejected like a failed one. After a point converged in ``its`` iterations the next arc length is
  ``ds * clip(sqrt(TARGET_ITERATIONS / its), 1/2, 2)`` within ``[ds_min, ds_max]``; a
  failed point is retried with half the arc length down to ``ds_min``.
- **Critical points.** The sign of the determinant of the bordered Newton matrix (from the
  LU factors of the tangent solve, or ``(-1)^(m + index)`` from the LDL^T's negative pivots,
  the index, with m constraint rows) changes where the reduced tangent becomes singular; the
  index also sees a double crossing. Where either changed, or the tangent's load component
  changed sign, :class:`~spacarpy.solvers.path.stability.PathCertificate` decides, with the
  round-off certificate of the eigenvalues nearest zero: a turn is a limit point, a
  certified sign change a bifurcation, an eigenvalue within its bound "undetermined" (never
  a bifurcation); without LDL^T pivots the index is counted from those eigenvalues. Limit
  points are refined by the Illinois method on the load component, bifurcations by
  bisection on the determinant's sign and the index, until the bracket is below the solver
  tolerance; the refined point is stored as a path
  point, with its critical eigenvector (inverse iteration on the bordered matrix there). A
  step whose tangent turned by more than ``MIN_TANGENT_COS`` with no change seen is halved
  (two limit points within it). With ``BIFURCATION switch`` the path leaves a bifurcation
  point along that eigenvector, or, where it arrived along it, back onto the fundamental
  branch (the bistable beam's return force).
- **End.** When s reaches 1 the last point is solved at s = 1 exactly (load control from
  the interpolated state); after ``n_max`` points the run stops with a warning.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from spacarpy.errors import ConvergenceError, ModelError
from spacarpy.solvers.linalg.lu_sign import determinant_sign
from spacarpy.solvers.path.inertia_bracket import locate_crossing
from spacarpy.solvers.path.point_status import StatusTrack
from spacarpy.solvers.path.stability import (
    UNDETERMINED_POINT,
    PathCertificate,
    canonical_sign,
    near_zero,
    window_negatives,
)
from spacarpy.solvers.statics.errors import StepFailed
from spacarpy.solvers.statics.newton import bordered_solve, newton

log = logging.getLogger(__name__)

#: Newton iterations per point the step control aims at.
TARGET_ITERATIONS = 4
#: Iterative refinement steps of each bordered solve.
REFINEMENTS = 2
#: Weight of the load factor in the scaled norm.
PSI = 1.0
#: Largest chord of a point (scaled norm, from the last point) per unit arc length: a longer
#: one means the corrector left the predictor's neighbourhood (jumped to another branch),
#: and the point is retried with half the arc length.
MAX_CHORD = 1.25
#: At a bifurcation point (BIFURCATION switch): the path arrived along the critical
#: eigenvector (on a crossing branch) when the cosine of the angle between the arrival
#: direction and the eigenvector (scaled inner product) exceeds this.
ALONG_EIGENVECTOR = 0.5
MAX_REFINE = 60             # largest number of refinement iterations of one critical point
#: Solve with the tangent-space LDL^T of :mod:`spacarpy.solvers.statics.reduced` where it applies
#: (False: always the bordered system by SuperLU; the tests compare the two).
USE_REDUCED = True
#: Kinds of critical points (codes stored in /critical/point_type): "undetermined" is a
#: determinant or pivot sign change between two points that the round-off bound cannot
#: confirm or deny (an eigenvalue within it: :mod:`spacarpy.solvers.linalg.certificate`).
CRITICAL_KINDS = ("limit point (load maximum)", "limit point (load minimum)", "bifurcation",
                  "undetermined")
UNDETERMINED_KIND = UNDETERMINED_POINT
#: Smallest cosine (scaled inner product) between the unit tangents of two consecutive
#: points: a path that turned more within one step may have passed two critical points
#: (a snap-through's load maximum and minimum, whose determinant and load-tangent sign
#: changes cancel); the point is retried with half the arc length.
MIN_TANGENT_COS = 0.7


@dataclass
class CriticalPoint:
    """A refined critical point of the path: ``kind`` indexes :data:`CRITICAL_KINDS`;
    ``shape`` is the critical eigenvector over the free coordinates (largest entry 1)."""

    kind: int
    load_factor: float
    arc_length: float
    shape: np.ndarray
    margin: float = np.nan     # the eigenvalue that decided it (its magnitude) ...
    bound: float = np.nan      # ... and its round-off bound (decided: margin > bound)


@dataclass
class _Point:
    """A converged point: state, load factor, cumulative arc length, Newton data, the
    oriented unit tangent (tx, ts) and the determinant sign there."""

    x: np.ndarray
    mu: np.ndarray
    s: float
    arc: float
    its: int = 0
    res: float = 0.0
    tx: np.ndarray | None = None
    ts: float = 0.0
    det: int = 0
    index: int = -1        # negative eigenvalues of the reduced tangent (-1: not computed)
    lu: object = None      # (LU factors of the scaled bordered matrix, the scaling)
    near: object = None    # (eigenvalues nearest zero, their bounds), on first use
    by: str = "tolerance"  # how it was accepted: "tolerance" or "floor" (at_floor)

    def same_stability(self, other: _Point) -> bool:
        """No critical point between the two: the same determinant sign and, where both are
        known, the same index (the LDL^T's pivots, else the certified negative eigenvalues
        nearest zero: a pair crossing leaves the determinant alone)."""
        if self.det != other.det:
            return False
        if self.index >= 0 and other.index >= 0:
            return self.index == other.index
        if self.near is not None and other.near is not None:
            a, b = window_negatives(self.near, other.near)
            return a == b
        return True


def check_applies(prob) -> None:
    """ARCLENGTH needs a load increment (DELXF) and no prescribed motion that changes with
    the load factor (those are displacement control, the other way of tracing a path)."""
    num, loads = prob.num, prob.loads
    if not loads.has_increment:
        raise ModelError("ARCLENGTH follows the path of the DELXF load: the model has no "
                         "DELXF or DELXFL line")
    moving = (not np.array_equal(num.prescribed_values(1.0, 1.0), num.prescribed_values(1.0, 0.0))
              or bool(np.any(num.rotation_angle))
              or not np.array_equal(num.rigid_targets(1.0, 1.0), num.rigid_targets(1.0, 0.0)))
    if moving:
        raise ModelError("ARCLENGTH cannot be combined with DELINPX, DELINPR or DELINPE: a "
                         "prescribed motion that grows over the path is displacement "
                         "control; use load steps (ITERSTEP) for it, or ARCLENGTH with DELXF")


def point_at(path, step) -> _Point:
    """A stored :class:`~spacarpy.solvers.statics.static.StaticStep` of an arc-length run as a
    path point with its tangent (to take one more step from it, e.g. in the benchmark)."""
    p = _Point(x=step.x, mu=step.mu, s=step.load_factor, arc=step.arc_length or 0.0)
    path.tangent(p)
    return p


class ArcLengthPath:
    """The continuation of one problem (see the module docstring). ``opts``: a
    :class:`~spacarpy.solvers.statics.static.StaticOptions` (max_iter, tol, bifurcation);
    ``arc``: the deck's :class:`~spacarpy.settings.ArcLength`."""

    def __init__(self, prob, opts, arc):
        check_applies(prob)
        self.prob, self.opts, self.arc = prob, opts, arc
        num = prob.num
        self.free = prob.free
        rot = prob.rot_mask[self.free]
        self.w = np.where(rot, 1.0, 1.0 / num.length_scale)
        self.n = max(int(self.free.sum()), 1)
        self.n_x = prob.pattern.n_x
        self.ds_min, self.ds_max = arc.bounds
        self.switch = opts.bifurcation == "switch"
        # the tangent-space LDL^T (reduced.py) where it applies: its solves stay accurate on
        # slender models (10^4 elements), and its pivots give the index at any size
        self.reduced = prob.reduced if USE_REDUCED else None
        self.m = prob.pattern.n - self.n_x                 # constraint rows
        self.increments: list = []
        self.check = PathCertificate(prob, self.load)     # classifies the changes
        self.status = StatusTrack(prob, self.load, self.m)  # each stored point's stability
        self._start = None

    # ------------------------------------------------------------------ small pieces
    def inner(self, ux, us, vx, vs) -> float:
        """The scaled inner product of (ux, us) and (vx, vs)."""
        return float(np.dot(self.w * ux, self.w * vx)) / self.n + PSI ** 2 * us * vs

    def load(self, s):
        return self.prob.loads.at(1.0, s)

    def load_vector(self, x) -> np.ndarray:
        """q = d f_ext / ds at x over the free coordinates (DELXF forces, the generalized
        forces of the DELXF moments and of the follower increments DELXFL at x)."""
        return self.prob.loads.rate(x)[self.free]

    def _solve(self, ev, mu, x, bordered: bool = False):
        """``K a = -r`` and ``K b = q`` with one factorization, bordered by the linearized
        constraints: ``(a, a_mu, b, b_mu, factors)``, or None where the matrix is singular.
        Where the reduced solver applies (the only constraints are Euler normalizations) the
        tangent-space LDL^T solves both (``factors``: ``("ldl", negative pivots)``), else,
        where that is inaccurate, or with ``bordered``, SuperLU on the bordered matrix
        (``factors``: the LU factors of the scaled bordered matrix and the scaling)."""
        prob = self.prob
        if self.reduced is not None and not bordered:
            k_el, euler_diag, _ = prob.element_blocks(ev, mu)
            load = np.zeros(prob.num.n_coord)
            load[self.free] = self.load_vector(x)
            out = self.reduced.step(ev, x, mu, k_el, euler_diag, load=load)
            if out is not None:
                return out + (("ldl", self.reduced.negative_pivots),)
        A = prob.matrix(ev, mu)
        rhs = np.zeros((A.shape[0], 2))
        rhs[: self.n_x, 0] = -ev.r
        rhs[self.n_x:, 0] = -prob.scale * ev.c
        rhs[: self.n_x, 1] = self.load_vector(x)
        # symmetric diagonal scaling (the stiffness diagonal of a slender model spans many
        # decades: axial against bending), a congruence that keeps the determinant's sign
        d = np.abs(A.diagonal())
        d = 1.0 / np.sqrt(np.where(d > 0, d, prob.scale))
        D = sp.diags(d)
        A = (D @ A @ D).tocsc()
        rhs = rhs * d[:, None]
        z, lu = bordered_solve(prob, A, rhs)
        if z is None:
            return None
        z = z.reshape(A.shape[0], 2)
        # iterative refinement: the bordered matrix of a long, slender model is
        # ill-conditioned (axial against bending stiffness), and the load column's solution
        # enters every update; a refined step keeps Newton's quadratic convergence there
        for _ in range(REFINEMENTS):
            dz = lu.solve(rhs - A @ z)
            if not np.all(np.isfinite(dz)):
                break
            z = z + dz
        z = z * d[:, None]
        return (z[: self.n_x, 0], z[self.n_x:, 0] * prob.scale,
                z[: self.n_x, 1], z[self.n_x:, 1] * prob.scale, (lu, d))

    def tangent(self, p: _Point, ref=None) -> None:
        """The unit tangent at a converged point, oriented by ``ref`` = (rx, rs) (acute
        angle; None: increasing s), and the determinant sign there."""
        ev = self.prob.evaluate(p.x, p.mu, self.load(p.s))
        out = self._solve(ev, p.mu, p.x)
        if out is None:
            raise StepFailed("singular Newton matrix at a converged point", [])
        _, _, b, _, lu = out
        norm = np.sqrt(self.inner(b, 1.0, b, 1.0))
        tx, ts = b / norm, 1.0 / norm
        if ref is not None and self.inner(tx, ts, *ref) < 0:
            tx, ts = -tx, -ts
        p.tx, p.ts = tx, ts
        neg = self.reduced.negative_pivots if self.reduced is not None else None
        if neg is not None:
            # the bordered matrix has m more positive and m more negative eigenvalues than
            # the reduced tangent (m constraint rows; Haynsworth/Gould), so its determinant
            # has the sign (-1)^(m + index)
            p.det, p.lu = (-1) ** ((self.m + neg) % 2), None
            p.index = neg
        else:
            # no pivots to count: the eigenvalues nearest zero (a few sparse ones; see
            # same_stability), for the index that a pair crossing changes
            p.det, p.lu = determinant_sign(lu[0]), lu
            p.near = near_zero(self.prob, p.x, p.mu, self.load(p.s))

    # ------------------------------------------------------------------ one point
    def correct(self, p: _Point, ds: float, direction=None, fixed_s: float | None = None):
        """A new point at arc length ``ds`` from ``p`` along ``direction`` (default: p's
        tangent), or (``fixed_s``) at that load factor from ``p`` as it is. Raises
        StepFailed."""
        prob, opts = self.prob, self.opts
        tx, ts = direction if direction is not None else (p.tx, p.ts)
        x, mu, s = p.x.copy(), p.mu.copy(), p.s
        if fixed_s is None:
            dx = ds * tx
            x[self.free] += dx
            if prob.kinematic_correction:
                states = prob.evaluate(p.x, p.mu, self.load(p.s)).states
                x = prob.correct_kinematics(x, dx, states)
            s = p.s + ds * ts
        history = []
        self.increments = []        # the scaled increments of this correction, for checks
        dx_norm = np.inf
        states = None
        for it in range(opts.max_iter + 1):
            ev = prob.evaluate(x, mu, self.load(s), states)
            res, _ = prob.residual_norm(ev.r, ev.c, ev.f_int, ev.f_ext)
            history.append(res)
            if not np.isfinite(res):
                raise StepFailed("non-finite residual", history)
            # converged increments, and the residual below the tolerance or every
            # equation within its measured round-off floor (docs/solver.md, Convergence)
            if it > 0 and dx_norm <= opts.tol and (
                    res <= opts.tol or prob.at_floor(ev, x, mu, opts.tol)):
                prob.check_element_range(ev.states)
                return _Point(x=prob.normalize(x), mu=mu, s=s, arc=p.arc + ds, its=it,
                              res=res, by=prob.accepted_by(ev, x, mu, res, opts.tol)
                              ), history
            if it == opts.max_iter:
                break
            if it >= 3 and res > 1e3 * history[1] and res > 1e3 * opts.tol:
                raise StepFailed("diverging", history)
            prob.timings.iterations += 1
            out = self._solve(ev, mu, x)
            if out is None:
                raise StepFailed("singular Newton matrix", history)
            a, a_mu, b, b_mu, _ = out
            if fixed_s is not None:
                dlam = fixed_s - s
            else:
                dxk = (x - p.x)[self.free]
                g = self.inner(dxk, s - p.s, tx, ts) - ds
                dlam = (-g - self.inner(a, 0.0, tx, 0.0)) / self.inner(b, 1.0, tx, ts)
            dx = a + dlam * b
            if not (np.all(np.isfinite(dx)) and np.isfinite(dlam)):
                raise StepFailed("non-finite increment", history)
            dx_norm = max(prob.increment_norm(dx), abs(dlam))
            self.increments.append(dx_norm)
            if dx_norm > 0.5 and np.abs(dx[prob.rot_mask[self.free]]).max(initial=0.0) > 0.5:
                raise StepFailed("increment too large", history)
            x_lin = x.copy()
            x_lin[self.free] += dx
            states = None
            if prob.kinematic_correction:
                x_lin, states = prob.corrector.correct(x_lin, dx, ev.states,
                                                       prob.increment_norm(dx),
                                                       return_states=True)
            x, mu, s = x_lin, mu + a_mu + dlam * b_mu, s + dlam
        raise StepFailed(f"no convergence in {opts.max_iter} iterations", history)

    # ------------------------------------------------------------------ critical points
    def _at(self, p, sigma, direction):
        q, _ = self.correct(p, sigma, direction)
        self.tangent(q, ref=direction)
        return q

    def refine(self, p: _Point, ds: float, new: _Point, direction, turn: bool) -> _Point:
        """The critical point between ``p`` and ``new`` (arc lengths 0 and ds from p along
        ``direction``), to the solver tolerance in arc length (a turn of the path: Illinois
        on the tangent's load component; else bisection on the determinant sign)."""
        lo, hi = 0.0, ds
        f_lo, f_hi = p.ts, new.ts
        best, side = new, 0
        tol = max(self.opts.tol, 1e-14) * max(ds, 1e-300)
        for _ in range(MAX_REFINE):
            if hi - lo <= tol:
                break
            if turn and f_lo != f_hi:
                sigma = hi - f_hi * (hi - lo) / (f_hi - f_lo)
                if not lo < sigma < hi:
                    sigma = 0.5 * (lo + hi)
            else:
                sigma = 0.5 * (lo + hi)
            try:
                q = self._at(p, sigma, direction)
            except StepFailed:
                sigma = 0.5 * (lo + hi)
                try:
                    q = self._at(p, sigma, direction)
                except StepFailed:
                    break
            before = (np.sign(q.ts) == np.sign(p.ts) if turn
                      else q.same_stability(p))
            if before:
                lo, f_lo = sigma, q.ts
                if side == -1:
                    f_hi *= 0.5                  # Illinois: halve the retained end
                side = -1
            else:
                hi, f_hi, best = sigma, q.ts, q
                if side == 1:
                    f_lo *= 0.5
                side = 1
            if turn and abs(q.ts) <= self.opts.tol * 1e-3:
                best = q
                break
        return best

    def critical_shape(self, q: _Point) -> np.ndarray:
        """The critical eigenvector at a refined critical point: inverse iteration with the
        bordered matrix factored there, from a fixed start vector (deterministic)."""
        if q.lu is None:              # solved by the LDL^T: factor the bordered matrix here
            ev = self.prob.evaluate(q.x, q.mu, self.load(q.s))
            out = self._solve(ev, q.mu, q.x, bordered=True)
            if out is None:
                raise StepFailed("singular Newton matrix at a critical point", [])
            q.lu = out[4]
        lu, d = q.lu
        v = np.random.default_rng(1).standard_normal(self.n_x)
        rhs = np.zeros(lu.shape[0])
        for _ in range(4):
            rhs[: self.n_x] = v / np.abs(v).max()
            z = (d * lu.solve(d * rhs))[: self.n_x]
            if not np.all(np.isfinite(z)) or not np.any(z):
                break
            v = z
        v = canonical_sign(v[:, None])[:, 0]
        return v / np.abs(v).max()

    # ------------------------------------------------------------------ the path
    def start_status(self, x0, mu0) -> int:
        """The certified stability (point_status.py) of the start (x0, mu0): step 0."""
        p = _Point(x=x0, mu=mu0, s=0.0, arc=0.0)
        try:
            self.tangent(p)
        except StepFailed:
            return -1                  # (follow says why, with step 0 stored)
        self._start = p
        return self.status.stored(self.status.check(p)[0])

    def follow(self, x0, mu0, store) -> None:
        """Follow the path from the converged state (x0, mu0) at s = 0 (stored already);
        ``store(s, x, mu, its, res, arc, critical, by=, stability=)`` stores a point."""
        try:
            self._follow(x0, mu0, store)
        finally:
            self.status.warn()

    def _follow(self, x0, mu0, store) -> None:
        arc = self.arc
        p = self._start
        if p is None or p.x is not x0:
            p = _Point(x=x0, mu=mu0, s=0.0, arc=0.0)
            self.tangent(p)
            self.status.stored(self.status.check(p)[0])
        direction = (p.tx, p.ts)
        ds, n_stored, switched = arc.ds0, 0, False
        while n_stored < arc.n_max:
            try:
                new, _ = self.correct(p, ds, direction)
                chord = (new.x - p.x)[self.free], new.s - p.s
                if self.inner(*chord, *chord) > (MAX_CHORD * ds) ** 2:
                    raise StepFailed("the corrector left the predictor's neighbourhood",
                                     [new.res])
                self.tangent(new, ref=chord)
                if (not switched and ds / 2 >= self.ds_min and new.same_stability(p)
                        and np.sign(new.ts) == np.sign(p.ts)
                        and self.inner(new.tx, new.ts, *direction) < MIN_TANGENT_COS):
                    raise StepFailed("the path turned too much within the step", [new.res])
            except StepFailed as fail:
                if ds / 2 < self.ds_min:
                    hist = ", ".join(f"{h:.3e}" for h in fail.history)
                    raise ConvergenceError(
                        f"arc-length point {n_stored + 1} did not converge ({fail.reason}) "
                        f"with the smallest arc length {self.ds_min:.3g}; last converged "
                        f"load factor {p.s:.6g} at arc length {p.arc:.6g}; residual history "
                        f"of the last attempt: [{hist}]") from None
                log.info("arc-length point %d: %s at arc length %.3g, halving it",
                         n_stored + 1, fail.reason, ds)
                ds /= 2
                continue
            crossed = (p.s - 1.0) * (new.s - 1.0) <= 0 and new.s != p.s
            # (at a bifurcation point just left, the stability is that of neither branch)
            kind, undetermined, turn = None, None, np.sign(new.ts) != np.sign(p.ts)
            if not switched:     # (a pivot flip's "undetermined": the statuses decide, below)
                kind, cert = self.check.classify(p, new)
                kind = None if kind == UNDETERMINED_KIND and not turn else kind
                if kind is not None and self.prob.loads.parts:
                    log.warning("a critical point on a path with follower loads at s = %.6g: "
                                "classified by the tangent's symmetric part, no stability "
                                "criterion for loads that are not conservative; check it with "
                                "MODE eigen", new.s)
            if kind == UNDETERMINED_KIND:
                undetermined = self._undetermined(new, cert)
            elif kind is not None:
                crit = self.refine(p, ds, new, direction, turn)
                if kind == 2 and not turn and getattr(new, "bracket", None) is not None:
                    crit = locate_crossing(self, p, ds, new, crit, direction)   # (index bound)
                if kind == 2 and not turn and not self.check.passes_zero(p, new, crit) \
                        and ds / 2 >= self.ds_min:
                    log.info("arc-length point %d: signs changed with no eigenvalue passing "
                             "zero (another branch) at arc length %.3g, halving it",
                             n_stored + 1, ds)
                    ds /= 2
                    continue
                if crit is not new and (not crossed or (p.s - 1.0) * (crit.s - 1.0) > 0):
                    cp = CriticalPoint(kind=kind, load_factor=crit.s, arc_length=crit.arc,
                                       shape=self.critical_shape(crit),
                                       margin=cert.margin, bound=cert.bound)
                    store(crit.s, crit.x, crit.mu, crit.its, crit.res, crit.arc, cp,
                          by=crit.by, stability=self.status.critical())
                    self.check.stored()
                    n_stored += 1
                    self._commit(crit)
                    if kind == 2 and self.switch:
                        p = self._leave_along(crit, cp.shape, direction)
                        direction = (p.tx, p.ts)
                        # not less than ds0: from a tiny step the corrector starts where
                        # the tangent is nearly singular and slides along the eigenvector
                        # back onto the branch it arrived on
                        ds = max(min(ds, self.ds_max), self.arc.ds0)
                        switched = True
                        continue
                    if n_stored >= arc.n_max:
                        break
            last = self._land(p, new) if crossed else new
            status, changed = self.status.check(last)
            if changed and undetermined is None:
                undetermined = self._undetermined(last, self.status.stretch)
            if undetermined is not None:
                undetermined.load_factor, undetermined.arc_length = last.s, last.arc
            store(last.s, last.x, last.mu, last.its, last.res, last.arc, undetermined,
                  by=last.by, stability=self.status.stored(status))
            if crossed:
                self._commit(last)
                return
            self.check.seen(new)
            n_stored += 1
            switched = False
            self._commit(new)
            factor = np.clip(np.sqrt(TARGET_ITERATIONS / max(new.its, 1)), 0.5, 2.0)
            ds = float(np.clip(ds * factor, self.ds_min, self.ds_max))
            p = new
            direction = (p.tx, p.ts)
        log.warning("ARCLENGTH: %d points stored and the load factor is %.6g, not 1: raise "
                    "n_max (or ds0) to follow the path further", n_stored, p.s)

    def _undetermined(self, q: _Point, cert) -> CriticalPoint:
        """An "undetermined" critical point at q: a turn of the path, or a change of the
        certified index across a stretch of undetermined points, not located."""
        log.warning("ARCLENGTH: a change of stability before load factor %.6g cannot be "
                    "located: an eigenvalue nearest zero within its round-off bound (margin "
                    "%.3g, bound %.3g); stored as undetermined", q.s, cert.margin, cert.bound)
        return CriticalPoint(kind=UNDETERMINED_KIND, load_factor=q.s, arc_length=q.arc,
                             shape=self.critical_shape(q), margin=cert.margin,
                             bound=cert.bound)

    def _leave_along(self, crit: _Point, shape, arrival) -> _Point:
        """At a bifurcation point (BIFURCATION switch): leave along the other branch. Arrived
        on the fundamental branch (the arrival direction has little of the critical
        eigenvector), the next predictor is the eigenvector, the tangent of the crossing
        branch of a symmetric bifurcation, with no load change. Arrived along the eigenvector
        (on a branch switched to before, returning to the fundamental branch, as on the
        bistable beam's second stage), the next predictor is the fundamental branch's
        tangent: the load tangent ``K b = q`` with its eigenvector component removed (K is
        singular there, b is that component plus the regular part), oriented towards the
        target load factor 1."""
        norm = np.sqrt(self.inner(shape, 0.0, shape, 0.0))
        phi = shape / norm
        ax, as_ = arrival
        along = abs(self.inner(ax, as_, phi, 0.0)) / np.sqrt(self.inner(ax, as_, ax, as_))
        if along > ALONG_EIGENVECTOR:
            ev = self.prob.evaluate(crit.x, crit.mu, self.load(crit.s))
            out = self._solve(ev, crit.mu, crit.x)
            if out is not None:
                b = out[2]
                b = b - self.inner(b, 0.0, phi, 0.0) * phi
                nb = np.sqrt(self.inner(b, 1.0, b, 1.0))
                sign = 1.0 if crit.s <= 1.0 else -1.0
                crit.tx, crit.ts = sign * b / nb, sign / nb
                log.info("BIFURCATION switch: back onto the fundamental branch at the "
                         "bifurcation point at load factor %.6g", crit.s)
                return crit
        crit.tx, crit.ts = phi, 0.0
        log.info("BIFURCATION switch: leaving the bifurcation point at load factor %.6g along "
                 "the critical eigenvector", crit.s)
        return crit

    def _land(self, p: _Point, new: _Point) -> _Point:
        """The point at s = 1 exactly, between p and new (load control from the
        interpolated state)."""
        t = (1.0 - p.s) / (new.s - p.s)
        x = self.prob.normalize(p.x + t * (new.x - p.x))
        mu = p.mu + t * (new.mu - p.mu)
        try:
            xs, mus, its, res, hist = newton(self.prob, x, mu, self.load(1.0), self.opts)
            by = hist.converged_by
        except StepFailed:
            q, _ = self.correct(_Point(x=x, mu=mu, s=1.0, arc=0.0), 0.0, fixed_s=1.0)
            xs, mus, its, res, by = q.x, q.mu, q.its, q.res, q.by
        xs = self.prob.normalize(xs)
        d = self.inner((xs - p.x)[self.free], 1.0 - p.s, (xs - p.x)[self.free], 1.0 - p.s)
        return _Point(x=xs, mu=mus, s=1.0, arc=p.arc + np.sqrt(d), its=its, res=res, by=by)

    def _commit(self, p: _Point) -> None:
        if self.prob.has_commit:
            self.prob.commit(p.x, p.mu, self.load(p.s))


__all__ = ["ArcLengthPath", "CriticalPoint", "CRITICAL_KINDS", "determinant_sign",
           "check_applies", "point_at"]

"""Stability of static equilibria along the load path, and switching to a stable branch.

An equilibrium is stable when the tangent stiffness K0 + G0 + N0, reduced to the degrees of
freedom (the null space T of the constraint Jacobian), is positive definite. The number of
its negative eigenvalues (its *index*) only changes where the path passes a limit or a
bifurcation point. A perfectly symmetric structure (the parallel leaf-spring guidance under
misalignment, an ideal column) keeps Newton on the symmetric, now unstable, branch beyond a
bifurcation: the load steps simply step over it. With ``BIFURCATION switch`` the static
solver checks the index after every load step and, when it has risen, perturbs the state
along the eigenvector of the most negative eigenvalue, by growing amounts and with both
signs, and re-solves at the same load; a new equilibrium with a smaller index is taken (the
branch the physical structure follows, whatever tiny imperfection it has). This is the
classical "perturbation along the critical eigenvector" branch switching, without having
to put an artificial imperfection into the model.

Only models small enough for the dense reduction (``eigen.DENSE_LIMIT`` free coordinates)
are checked; beyond that the solver says so once. :class:`PathStability` does this along
the static solver's load path.
"""
from __future__ import annotations

import logging

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.errors import ConvergenceError
from spacarpy.solvers.linalg.certificate import (
    EPS,
    SAFETY,
    UNDETERMINED,
    Certificate,
    certified_sign,
    inertia,
    round_off_bound,
)
from spacarpy.solvers.linear.eigen import DENSE_LIMIT, FEW_MODES_DENSE_LIMIT, null_space_basis
from spacarpy.solvers.linear.linearize import linearize
from spacarpy.solvers.path.inertia_bracket import bracket_verdict
from spacarpy.solvers.statics.errors import StepFailed
from spacarpy.solvers.statics.loads import LoadState
from spacarpy.solvers.statics.newton import newton

log = logging.getLogger(__name__)

#: Relative difference of potential energy below which two branches count as equally good
#: (mirror images; an equilibrium's energy is stationary, so its round-off is of the order
#: of the squared position error: 1e-12 at a tolerance of 1e-6).
ENERGY_TIE = 1e-10
#: Relative difference of distance (to the state the path came from) below which two
#: equally good branches count as equally near: the mirror images of the leaf-spring
#: guidance are 1e-5 apart in distance from its symmetric state (the misalignment), the
#: side it is already on is more than 1.5 times nearer than the other.
DIST_TIE = 1e-3
#: Perturbation amplitudes tried, as fractions of the model's length scale.
AMPLITUDES = (1e-4, 1e-3, 1e-2, 0.03, 0.1)


#: Factor around the round-off bound within which the index is counted from the eigenvalues
#: of the decomposition with eigenvectors, not from the faster eigenvalues-only one: the two
#: differ by round-off (about n machine epsilons times the largest eigenvalue, a SAFETY-th of
#: the bound), so outside this band both certify the same signs.
INDEX_MARGIN = 2.0


class Stability:
    """Index of the reduced tangent at one state.

    Attributes
    ----------
    index : int
        Number of certified negative eigenvalues (0: stable, or undetermined).
    undetermined : int
        Number of eigenvalues within their round-off bound (sign unknown; never counted as
        negative, so round-off never starts a branch switch or an "unstable" warning).
    lowest : float
        Lowest eigenvalue (of the Jacobi-scaled reduced tangent; its sign is what counts).
    modes : (n_x, max(index, 1)) float
        Eigenvectors of the negative eigenvalues (the lowest one when there is none) over the
        free coordinates, lowest first; decomposed on first use (only a branch switch needs
        them, most checks only the index).
    states : list or None
        The kernel states at the state (per element group), for :func:`potential_energy`.
    """

    def __init__(self, index: int, lowest: float, modes: np.ndarray | None = None,
                 states: list | None = None, pending=None, undetermined: int = 0):
        self.index, self.lowest, self.states = index, lowest, states
        self.undetermined = undetermined
        self._modes = modes
        self._pending = pending            # (T, scaled reduced tangent, scaling d)

    @property
    def modes(self) -> np.ndarray:
        if self._modes is None:
            T, ks, d = self._pending
            _, v = sla.eigh(ks)
            self._modes = canonical_sign(T @ (v[:, :max(self.index, 1)] / d[:, None]))
            self._pending = None
        return self._modes

    def __repr__(self) -> str:
        return f"Stability(index={self.index}, lowest={self.lowest!r})"


def stability(prob, x, mu, load: LoadState) -> Stability | None:
    """Index of the reduced tangent of ``prob`` at (x, mu) under ``load``; None when the
    model is too large for the dense reduction."""
    n_x = prob.pattern.n_x
    if n_x > DENSE_LIMIT:
        return None
    lin = linearize(prob, x, mu, load)
    T = null_space_basis(lin.C, n_x)
    if T.shape[1] == 0:
        return Stability(index=0, lowest=np.inf, modes=np.zeros((n_x, 1)), states=lin.states)
    k = T.T @ (lin.K @ T)
    k = 0.5 * (k + k.T)
    # Jacobi scaling (a congruence: the index is unchanged) so that the tolerance for "zero"
    # is relative to each direction's own stiffness, not to the stiffest axial mode
    d = np.sqrt(np.abs(np.diag(k)))
    d = np.where(d > 1e-300, d, 1.0)
    ks = k / d[:, None] / d[None, :]
    # the eigenvalues alone (three times faster); the eigenvectors when asked for. The
    # index counts the certified negative eigenvalues (certificate.inertia: an eigenvalue of
    # a backward-stable symmetric eigensolver is within a small multiple of n eps ||ks|| of
    # the exact one), an eigenvalue within that bound is undetermined, never negative
    lam = sla.eigvalsh(ks)
    big, n = np.abs(lam).max(initial=0.0), ks.shape[0]
    bound = float(round_off_bound(big, n))
    mag = np.abs(lam)
    if np.any((mag >= bound / INDEX_MARGIN) & (mag <= INDEX_MARGIN * bound)):
        lam = sla.eigh(ks)[0]               # near the bound: as the modes' decomposition
        big = np.abs(lam).max(initial=0.0)
    index, unsure, cert = inertia(lam, big, n)
    if unsure:
        log.info("stability: %d eigenvalue(s) of the reduced tangent within the round-off "
                 "bound %.3g (relative to the largest): sign undetermined, not counted as "
                 "negative", unsure, cert.bound / max(big, 1e-300))
    return Stability(index=index, lowest=float(lam[0]), states=lin.states,
                     pending=(T, ks, d), undetermined=unsure)


#: Eigenvalues nearest zero whose signs certify a crossing (:func:`near_zero`).
NEAR_ZERO = 6


def near_zero(prob, x, mu, load: LoadState, k: int = NEAR_ZERO):
    """The ``k`` eigenvalues nearest zero of the Jacobi-scaled reduced tangent at (x, mu) and
    their round-off bounds: ``(lam, bound)``, nearest first.

    Dense reduction (at most ``FEW_MODES_DENSE_LIMIT`` free coordinates):
    ``ks = D^-1 T^T K T D^-1``,
    all its eigenvalues, the eigenvectors ``u`` of the k nearest zero. Larger models: the
    pencil ``[[K, C^T], [C, 0]] - lam [[W, 0], [0, 0]]`` (W the diagonal of ``|K|``, the same
    scaling) in shift-invert about zero with one sparse LU (the signs are those of the
    reduced tangent: Sylvester). An eigenvalue's round-off is that of ``y^T K y`` for its
    mode y in the coordinates (``y = T u / d``), entry by entry ``eps |y|^T |K| |y|`` (the
    assembled K holds the stiff axial terms, whose round-off is what the soft bending modes
    of a slender model see), plus the eigensolver's ``n eps ||ks||``: ``bound = SAFETY eps
    (n ||ks|| + |y|^T |K| |y|)`` (:mod:`spacarpy.solvers.linalg.certificate`)."""
    n_x = prob.pattern.n_x
    lin = linearize(prob, x, mu, load)
    K = sp.csr_matrix(lin.K)
    if n_x <= FEW_MODES_DENSE_LIMIT:
        T = null_space_basis(lin.C, n_x)
        if T.shape[1] == 0:
            return np.zeros(0), np.zeros(0)
        kr = T.T @ (K @ T)
        kr = 0.5 * (kr + kr.T)
        d = np.sqrt(np.abs(np.diag(kr)))
        d = np.where(d > 1e-300, d, 1.0)
        ks = kr / d[:, None] / d[None, :]
        lam_all = sla.eigvalsh(ks)
        k = min(k, lam_all.size)
        near = np.sort(np.argsort(np.abs(lam_all), kind="stable")[:k])
        lam, u = sla.eigh(ks, subset_by_index=(int(near[0]), int(near[-1])))
        pick = near - near[0]
        lam, u = lam[pick], u[:, pick]
        y = np.abs(T) @ (np.abs(u) / d[:, None])
        rho, n = float(np.abs(lam_all).max()), ks.shape[0]
    else:
        A = sp.bmat([[K, lin.C.T], [lin.C, None]], format="csc")
        # (a floor for the directions without stiffness of their own, held by the
        # constraints: Euler parameters, out-of-plane motion; a congruence all the same)
        dk = np.abs(K.diagonal())
        pos = dk[dk > 0]
        dk = np.maximum(dk, 1e-3 * (np.median(pos) if pos.size else 1.0))
        s = np.concatenate([1.0 / np.sqrt(dk), np.ones(A.shape[0] - n_x)])
        As = (sp.diags(s) @ A @ sp.diags(s)).tocsc()
        B = sp.diags(np.concatenate([np.ones(n_x), np.zeros(A.shape[0] - n_x)]))
        lu = spla.splu(As, permc_spec="COLAMD")
        op = spla.LinearOperator(As.shape, matvec=lambda v: lu.solve(B @ v), dtype=float)
        k = min(k, n_x - 2)
        nu, vec = spla.eigs(op, k=k, which="LM", v0=np.ones(As.shape[0]))
        with np.errstate(divide="ignore"):
            lam = 1.0 / nu.real
        z = vec[:n_x].real
        z = z / np.maximum(np.linalg.norm(z, axis=0), 1e-300)
        y = np.abs(z) * s[:n_x, None]
        # ||ks||_2 (the largest eigenvalue magnitude of the scaled stiffness block)
        kx = As[:n_x, :n_x]
        rho = float(np.abs(spla.eigsh(kx, k=1, which="LM", v0=np.ones(n_x),
                                      return_eigenvectors=False)).max())
        n = n_x
    order = np.argsort(np.abs(lam), kind="stable")
    lam, y = lam[order], y[:, order]
    bound = SAFETY * EPS * (n * rho + np.einsum("ij,ij->j", y, abs(K) @ y))
    return lam, bound


def window_negatives(before, after) -> tuple[int, int]:
    """The numbers of certified negative eigenvalues of two :func:`near_zero` results within
    their common window: the magnitudes up to the smaller of the two sets' largest (every
    eigenvalue of that size is in both sets; all of them where a set holds every
    eigenvalue of its model)."""
    def top(lam):
        return np.inf if lam.size < NEAR_ZERO else float(np.abs(lam).max(initial=0.0))
    w = min(top(before[0]), top(after[0]))
    return tuple(int(np.sum((certified_sign(lam, bound) < 0) & (np.abs(lam) <= w)))
                 for lam, bound in (before, after))


def certify_crossing(before, after):
    """Whether an eigenvalue crossed zero between two states, from the :func:`near_zero`
    results ``(lam, bound)`` there: ``(verdict, Certificate)``, verdict "crossing" (the
    number of certified negative eigenvalues differs), "none" (it does not: a determinant or
    pivot sign that flipped by round-off), or "undetermined" (an eigenvalue within its
    bound at either state). The certificate is that of the eigenvalue nearest its bound."""
    signs, worst = [], Certificate(np.inf, 0.0)
    for lam, bound in (before, after):
        sign = certified_sign(lam, bound)
        signs.append(sign)
        if lam.size:
            i = int(np.argmin(np.abs(lam) / np.maximum(bound, 1e-300)))
            if abs(lam[i]) / max(bound[i], 1e-300) < worst.margin / max(worst.bound, 1e-300):
                worst = Certificate(float(abs(lam[i])), float(bound[i]))
    if any(np.any(sg == UNDETERMINED) for sg in signs):
        return "undetermined", worst
    neg_before, neg_after = window_negatives(before, after)
    if neg_before != neg_after:
        return "crossing", worst
    return "none", worst


#: The code of an undetermined point in /critical/point_type (arclength.CRITICAL_KINDS).
UNDETERMINED_POINT = 3


class PathCertificate:
    """Classifies the changes of stability between two arc-length points (``p``, ``new``:
    :class:`~spacarpy.solvers.path.arclength._Point`, with x, mu, s, the load tangent ts, the
    determinant sign and index of :meth:`same_stability`, and a cache ``near``); ``load(s)``
    the load state at load factor s. :attr:`pending` is the last certified point and its
    certificate while the stability is undetermined (see :meth:`classify`)."""

    def __init__(self, prob, load):
        self.prob, self.load = prob, load
        self.pending = None
        self.last = None           # the last point seen with certified signs ...
        self.since = 0             # ... and the critical points stored after it

    def stored(self) -> None:
        """A limit point or bifurcation was stored (each changes the index by one or two)."""
        self.since += 1

    def near(self, p):
        """The eigenvalues nearest zero at p and their round-off bounds (computed once)."""
        if p.near is None:
            p.near = near_zero(self.prob, p.x, p.mu, self.load(p.s))
        return p.near

    def _explained(self, new) -> bool:
        """Whether the index change from the last certified point to ``new`` (certified) is
        that of the critical points stored since (at most two each, the same parity)."""
        a, b = window_negatives(self.near(self.last), self.near(new))
        return abs(a - b) <= 2 * self.since and (a - b - self.since) % 2 == 0

    def classify(self, p, new):
        """The kind of critical point between two points (None: none) and its certificate.
        A turn of the path is a limit point (where the determinant's sign changed too; else
        a bifurcation, see below). Otherwise, where the determinant sign or the
        index changed, the certified eigenvalues nearest zero decide: a bifurcation where one
        changed sign, none where they kept their signs (a sign flipped by round-off). A point
        with an eigenvalue within its bound opens a stretch of undetermined stability: its
        later points are compared with the last certified point before it, and the stretch
        ends with nothing (the same certified signs) or with "undetermined", stored at the
        point that ends it (a crossing inside it cannot be located)."""
        turned = np.sign(new.ts) != np.sign(p.ts)
        ref = p if self.pending is None else self.pending[0]
        if not (turned or self.pending is not None or not new.same_stability(p)):
            return None, None
        verdict, cert = certify_crossing(self.near(ref), self.near(new))
        if verdict == "undetermined" and not turned:      # the componentwise index bound
            verdict, cert = bracket_verdict(self.prob, self.load, ref, new) or (verdict, cert)
        if turned:
            # a limit point changes the determinant's sign; a turn with the certified
            # eigenvalues' signs kept is a symmetric bifurcation seen from its crossing
            # branch (the load is even in the mode's amplitude: the bistable beam's return)
            self.pending = None
            if new.det != p.det or verdict == "crossing":
                return (0 if p.ts > 0 else 1), cert
            return (2 if verdict == "none" else UNDETERMINED_POINT), cert
        if verdict == "undetermined" and self.pending is None and (
                self._certain(ref) or self.last is not None):
            if not self._certain(ref):
                ref = self.last           # (p is near a critical point just stored)
            else:
                self.since = 0
            self.pending = (ref, cert)
            self.last = ref
            log.info("arc length %.6g: stability undetermined (an eigenvalue of %.3g within "
                     "its round-off bound %.3g)", new.arc, cert.margin, cert.bound)
            return None, cert
        if verdict == "undetermined" and self.pending is not None:
            return None, cert                       # the stretch goes on
        opened, self.pending = self.pending, None
        if opened is not None and self.since and self._explained(new):
            verdict = "none"
        if verdict == "none":
            log.info("arc length %.6g: the certified eigenvalues nearest zero kept their "
                     "signs: no critical point", new.arc)
            return None, cert
        if verdict == "crossing" and opened is None:
            return 2, cert
        return UNDETERMINED_POINT, (opened[1] if opened is not None else cert)

    def passes_zero(self, p, new, crit) -> bool:
        """Whether a sign change between p and new located at crit is an eigenvalue that
        passed zero there (nearer zero than at both ends of the step), not the corrector
        changing branch within the step (docs/path.md, "Critical points")."""
        near = [float(np.abs(self.near(q)[0]).min(initial=np.inf)) for q in (p, new, crit)]
        return crit is new or near[2] < min(near[0], near[1])

    def _certain(self, q) -> bool:
        lam, bound = self.near(q)
        return bool(np.all(certified_sign(lam, bound) != 0))

    def seen(self, q) -> None:
        """A point stored on the path: the last certified one where its signs are known."""
        if self.pending is None and q.near is not None and self._certain(q):
            self.last, self.since = q, 0


def canonical_sign(modes: np.ndarray) -> np.ndarray:
    """Eigenvectors (columns) with a sign that does not depend on round-off: the first entry
    (in coordinate order) of at least half the largest magnitude is positive. (An eigen
    solver's sign is arbitrary, and flips with the last digits of the matrix.)"""
    mag = np.abs(modes)
    first = np.argmax(mag >= 0.5 * mag.max(axis=0, initial=0.0), axis=0)
    sign = np.sign(modes[first, np.arange(modes.shape[1])])
    return modes * np.where(sign == 0, 1.0, sign)


def potential_energy(prob, x, mu, load: LoadState, states=None) -> float:
    """Elastic energy of the flexible modes minus the work of the dead forces (the measure
    by which branches at the same load are ranked; moments and gravity are left out).
    ``states``: the kernel states at x where the caller has them (:attr:`Stability.states`)."""
    if states is None:
        states = prob.evaluate(x, mu, load).states
    elastic = sum(0.5 * float(np.einsum("ni,nij,nj->", st.e, g.S, st.e))
                  + (float(np.sum(g.sigma0 * st.e)) if g.sigma0 is not None else 0.0)
                  for g, st in zip(prob.num.groups, states))
    return elastic - float(load.force @ x)


def switch_branch(prob, x, mu, load: LoadState, opts, stab: Stability, step: int,
                  near=None):
    """Try to leave an unstable equilibrium for a stable(r) one at the same load.

    Every eigenvector of a negative eigenvalue is tried with both signs, each with the
    smallest of :data:`AMPLITUDES` from which Newton reaches an equilibrium of lower index.
    Of the equilibria found, the one with the lowest index and then the lowest potential
    energy is taken. Mirror-image branches have equal energy (to round-off: their energies
    agree to 15 digits on the leaf-spring guidance), so energies within :data:`ENERGY_TIE`
    count as equal and the first candidate tried wins, with the eigenvectors' signs made
    canonical (:func:`canonical_sign`): the branch chosen does not depend on round-off.
    ``near``: the state the path came from; of tied candidates the one nearest to it is
    taken (the side of a mirror pair the structure is already on), distances within
    :data:`DIST_TIE` counting as equal. Returns (x, mu, stability), the given state when
    no perturbation lowers the index.
    """
    num = prob.num
    free = ~num.fixed_mask
    rot = num.is_rotation_coord[free]
    found = []
    for mode in stab.modes.T[:max(stab.index, 1)]:
        size = np.abs(mode[~rot]).max(initial=0.0) / num.length_scale + \
            np.abs(mode[rot]).max(initial=0.0)
        if size == 0:
            continue
        for sign in (1.0, -1.0):
            for amp in AMPLITUDES:
                xp = x.copy()
                xp[free] += sign * amp / size * mode
                try:
                    xn, mun, *_ = newton(prob, prob.normalize(xp), mu, load, opts)
                except StepFailed:
                    continue
                xn = prob.normalize(xn)
                sn = stability(prob, xn, mun, load)
                if sn is not None and sn.index < stab.index:
                    found.append((sn.index, potential_energy(prob, xn, mun, load, sn.states),
                                  xn, mun, sn))
                    break
    if not found:
        return x, mu, stab
    index = min(c[0] for c in found)
    lowest = min(c[1] for c in found if c[0] == index)
    tie = ENERGY_TIE * max(abs(lowest), 1e-300)
    tied = [c for c in found if c[0] == index and c[1] <= lowest + tie]
    if near is not None and len(tied) > 1:
        dist = [prob.increment_norm((c[2] - near)[free]) for c in tied]
        closest = min(dist)
        tied = [c for c, d in zip(tied, dist) if d <= closest * (1 + DIST_TIE)]
    _, _, xb, mub, sb = tied[0]
    log.info("step %d: switched from an unstable equilibrium (%d negative stiffness "
             "eigenvalue(s)) to a branch with %d", step, stab.index, index)
    return xb, mub, sb


class PathStability:
    """``BIFURCATION warn|switch``: the index of the tangent after every stored step, with a
    warning when it rises and (switch) branch switching, see
    :mod:`spacarpy.solvers.path.stability`.

    Switching happens close to the critical point, where the new branch is still near the
    old one: the load interval of the step is bisected (``BISECTIONS`` times) down to a
    state just beyond the point where the index rose, the state there is perturbed along
    the unstable eigenvector, and from the equilibrium found the step is completed along
    the new branch in sub-steps.

    ``predictor`` is the load path's :class:`~spacarpy.solvers.statics.newton.Predictor`;
    ``advance(x, mu, p_from, p_to, n_sub, stored_step)`` follows the path between two load
    parameters with step cutting (the static solver's).
    """

    BISECTIONS = 8

    def __init__(self, prob, opts, predictor, advance):
        self.prob, self.opts = prob, opts
        self.predictor, self.advance = predictor, advance
        self.on = opts.bifurcation in ("warn", "switch")
        self.index = 0
        self.told_size = False
        self.last = None               # (x, mu, params, stability) of the last stored step

    def _stability(self, x, mu, params):
        return stability(self.prob, x, mu, self.prob.loads.at(*params))

    def _solve_at(self, x, mu, params):
        prob = self.prob
        load = prob.loads.at(*params)
        start, states = self.predictor.with_states(x, mu, load)
        x1, mu1, *_ = newton(prob, start, mu, load, self.opts, states)
        return prob.normalize(x1), mu1

    def _bisect(self, lo, hi):
        """Narrow the load interval between ``lo`` (index not above the path's) and ``hi``
        (index above it); both are (x, mu, params, stability). Returns the new ``hi``."""
        x_lo, mu_lo, p_lo, _ = lo
        p_lo = np.asarray(p_lo, float)
        for _ in range(self.BISECTIONS):
            p_mid = 0.5 * (p_lo + np.asarray(hi[2], float))
            try:
                x_mid, mu_mid = self._solve_at(x_lo, mu_lo, p_mid)
            except StepFailed:
                break
            s_mid = self._stability(x_mid, mu_mid, p_mid)
            if s_mid.index > self.index:
                hi = (x_mid, mu_mid, p_mid, s_mid)
            else:
                p_lo, x_lo, mu_lo = p_mid, x_mid, mu_mid
        return hi

    def _switch_at(self, state, step):
        """Perturb-and-solve at one state's load; returns the new state or None."""
        x, mu, p, stab = state
        prob = self.prob
        load = prob.loads.at(*p)
        # the predictor moves to that load (the state is there already: it only
        # re-imposes prescribed values, and the path continues from this load)
        self.predictor(x, mu, load)
        xs, mus, ss = switch_branch(prob, x, mu, load, self.opts, stab, step)
        if ss.index >= stab.index:
            return None
        if prob.has_commit:
            prob.commit(xs, mus, load)
        return xs, mus, p, ss

    #: Sub-steps in which the path from the last stored state is followed when a step's
    #: index rose.
    SUBSTEPS = 8

    def _follow(self, params, step):
        """Follow the path from the last stored (stable) state to ``params`` in
        :attr:`SUBSTEPS` sub-steps, the index checked after each; where it rose, switch
        there (perturbation trials at that sub-step's load, ties broken towards the state
        before it) and go on from the new branch. A step whose index rose because Newton
        landed on another, unstable, equilibrium (the predictor of one large step from a
        buckled state) then needs no switch at all. Returns (x, mu, stability), or None
        when a sub-step fails or no stable branch is found (then the bisection does it)."""
        if self.last is None:
            return None
        prob = self.prob
        x, mu, p0, _ = self.last
        p0, target = np.asarray(p0, float), np.asarray(params, float)
        self.predictor(x, mu, prob.loads.at(*p0))
        sj = None
        for j in range(1, self.SUBSTEPS + 1):
            p_prev = p0 + (j - 1) / self.SUBSTEPS * (target - p0)
            pj = p0 + j / self.SUBSTEPS * (target - p0)
            try:
                xj, muj, *_ = self.advance(x, mu, p_prev, pj, 1, step)
            except ConvergenceError:
                return None
            xj = prob.normalize(xj)
            sj = self._stability(xj, muj, pj)
            if sj.index > self.index:
                load = prob.loads.at(*pj)
                xj, muj, sj = switch_branch(prob, xj, muj, load, self.opts, sj, step, near=x)
                if sj.index > self.index:
                    return None
                if prob.has_commit:
                    prob.commit(xj, muj, load)
            x, mu = xj, muj
        return x, mu, sj

    def _switch(self, x, mu, params, stab, step):
        """Follow the step in sub-steps (:meth:`_follow`); where that fails, the bisection
        (:meth:`_bisect_switch`)."""
        followed = self._follow(params, step)
        if followed is not None:
            return followed
        self.predictor(x, mu, self.prob.loads.at(*np.asarray(params, float)))
        return self._bisect_switch(x, mu, params, stab, step)

    def _bisect_switch(self, x, mu, params, stab, step):
        """Bisect back towards the critical point, switch there and come back to ``params``
        along the new branch (repeatedly, when several eigenvalues cross within the step);
        as a last resort switch at ``params`` itself."""
        target = np.asarray(params, float)
        cur = (x, mu, target, stab)
        lo = self.last
        for _ in range(4):
            if lo is None or cur[3].index <= self.index:
                break
            hi = self._bisect(lo, cur)
            switched = self._switch_at(hi, step)
            if switched is None:
                break
            if np.array_equal(np.asarray(hi[2], float), target):
                cur = switched
                break
            if switched[3].index <= self.index:
                lo = switched
            try:
                xa, mua, *_ = self.advance(switched[0], switched[1],
                                           np.asarray(hi[2], float), target, 8, step)
            except ConvergenceError:
                break
            xa = self.prob.normalize(xa)
            cur = (xa, mua, target, self._stability(xa, mua, target))
        if cur[3].index < stab.index:
            return cur[0], cur[1], cur[3]
        direct = self._switch_at((x, mu, target, stab), step)
        if direct is not None:
            return direct[0], direct[1], direct[3]
        return x, mu, stab

    def check(self, x, mu, params, step):
        if not self.on:
            return x, mu
        prob = self.prob
        stab = self._stability(x, mu, params)
        if stab is None:
            if not self.told_size:
                log.warning("BIFURCATION: the stability check needs the dense reduction "
                            "(at most %d free coordinates); this model has %d, not checked",
                            DENSE_LIMIT, prob.pattern.n_x)
                self.told_size = True
            return x, mu
        if stab.index > self.index and self.opts.bifurcation == "switch":
            x, mu, stab = self._switch(x, mu, params, stab, step)
        if stab.index > self.index:
            log.warning("step %d: the equilibrium is unstable: %d negative stiffness "
                        "eigenvalue(s) (a limit or bifurcation point was passed)%s", step,
                        stab.index, "; no stable branch found nearby"
                        if self.opts.bifurcation == "switch" else
                        "; 'BIFURCATION switch' follows the stable branch")
        self.index = stab.index
        self.last = (x.copy(), mu.copy(), np.asarray(params, float), stab)
        return x, mu


__all__ = ["PathStability", "Stability", "stability", "near_zero", "certify_crossing",
           "PathCertificate", "UNDETERMINED_POINT", "window_negatives",
           "switch_branch", "potential_energy", "canonical_sign"]

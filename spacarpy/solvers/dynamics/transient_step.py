"""One generalized-alpha time step: its Newton iteration (iteration matrix, kept matrices,
simplified norms) and its local error estimate. ``tp`` is the TransientProblem of
transient.py (not imported: transient.py imports this module)."""
from __future__ import annotations

import logging
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.assembly import scatter_add
from spacarpy.rotation import tangent_part
from spacarpy.solvers.dynamics.lie import LieStep, lie_terms
from spacarpy.solvers.dynamics.transient_records import KEEP_CONTRACTION, SLOW_CONTRACTION
from spacarpy.solvers.statics.errors import StepFailed

log = logging.getLogger(__name__)

DENSE_SLIP_SIZE = 400      # rows of the bordered matrix up to which a step with slips is dense

def _error_norm(tp, h, beta, a_tilde_old, a_tilde_new, x, tol) -> float:
    """Largest local error of a step relative to the tolerance ``abs + rel |x|`` over the
    free coordinates that carry mass (positions in m, Euler parameters as they are).

    Coordinates without mass (a rod's massless end node, the length of an Euler-parameter
    vector) are algebraic: their accelerations follow the constraints, not the dynamics,
    and the integrator's recurrences let them oscillate from step to step whatever the step
    size, so they say nothing about the local error and are left out.

    The orientation nodes of a step updated on the rotation group (lie.py) are measured by
    the angle of their rotation's local error, ``h^2 |beta - 1/6| |A1 - A0|`` with A the
    pseudo-accelerations of the update in the step's axes (:meth:`LieStep.angular_error`),
    as the Euler parameters' distance it makes, half the angle, against ``abs + rel`` (unit
    Euler parameters): a constant spin has no error there, where its four Euler
    parameters' pseudo-accelerations (``-|w|^2/4 q``) turn with q at every step
    (docs/transient.md, "Rotations on their group")."""
    c = h * h * abs(beta - 1.0 / 6.0)
    d = tp.inertia.physical(x, a_tilde_new - a_tilde_old)        # no radial Euler part
    e = c * d
    scale = tol[0] + tol[1] * np.abs(x)
    massive = tp.mass_diagonal > 1e-12 * max(float(tp.mass_diagonal.max()), 1e-300)
    keep = tp.free & massive
    worst = 0.0
    lie = tp.lie.last if tp.lie else None
    if lie is not None:
        idx = lie.nodes.idx
        keep[idx] = False
        turn = 0.5 * lie.angular_error(c)[massive[idx].any(axis=1)]
        worst = float(turn.max(initial=0.0)) / (tol[0] + tol[1])
    return max(worst, float(np.abs(e / scale)[keep].max(initial=0.0)))


def _gauge(num, x, v, a, a_tilde):
    """Give the Euler parameters' radial rates their exact values, in place.

    The length of q is a gauge freedom (the orientation is that of q/|q|); its constraint
    ``q.q = 1`` is kept at position level, but the integrator's recurrences for the radial
    velocity and acceleration are only marginally stable (a two-step oscillation that small
    time steps amplify). Their exact values follow from the constraint: ``q.dq = 0`` and
    ``q.ddq = -|dq|^2``; setting them after every step removes the drift without touching
    the orientation or the angular velocity.
    """
    ri = num.euler_coords
    if not ri.size:
        return
    q = x[ri]
    v[ri] = qd = tangent_part(q, v[ri])
    qq = (q * q).sum(axis=1, keepdims=True)
    centripetal = -(qd * qd).sum(axis=1, keepdims=True) / qq
    for acc in (a, a_tilde):
        acc[ri] += (centripetal - (q * acc[ri]).sum(axis=1, keepdims=True) / qq) * q


def _simplified_norm(prob, kept, ev, x, r) -> float:
    """Size (:meth:`StaticProblem.increment_norm`) of the simplified Newton increment at the
    state (x, ``ev``) with the force residual r (over the free coordinates): the last
    iteration matrix's factorization (``kept``, a :class:`KeptMatrix`) applied to the new
    residual (Deuflhard's simplified Newton correction), an estimate of the increment that
    state still needs, for one solve instead of a new tangent, factorization and residual;
    inf where there is no estimate."""
    step = None if kept is None else kept.chord(ev, x, r)
    if step is None or not np.all(np.isfinite(step[0])):
        return np.inf
    return prob.increment_norm(step[0])


@dataclass
class KeptMatrix:
    """A step's factorized iteration matrix, kept for its chord (modified Newton)
    iterations and the simplified Newton increment."""

    m_max: float                     # largest entry of the mass blocks it was formed with
    solve: Callable                  # (ev, x, r over the free coordinates) -> (dx, dmu)|None

    def chord(self, ev, x, r):
        """The increment ``(dx over the free coordinates, dmu)`` this matrix gives for the
        residual r at the state (x, ``ev``), or None where its solve fails."""
        return self.solve(ev, x, r)


def _floors(tp, ev, blocks, x, v, a, mu):
    """The round-off floor of every equation of motion at (x, v, a, mu), measured at this
    state (docs/transient.md, "Convergence"): ``(floor_r, floor_c)``, the static floor of
    the elastic and external forces and the constraints
    (:meth:`StaticProblem.roundoff_floor`) plus that of the inertia forces
    (:meth:`Inertia.roundoff_floor`) and of the damping forces, ``eps (alpha |M| |v| +
    |D|^T |C| |D| |v|)``; it evaluates the mass blocks once."""
    prob = tp.prob
    floor_r, floor_c = prob.roundoff_floor(ev, x, mu)
    blocks = tp.inertia.complete(x, blocks)
    f_floor = tp.inertia.roundoff_floor(x, v, a, blocks)
    alpha, beta = tp.model.damping
    if alpha or beta or any(g.damp is not None for g in tp.num.groups):
        vp = np.abs(tp.inertia.physical(x, v))
        n = tp.num.n_coord
        damp = np.zeros(n)
        if alpha:
            for b, m in zip(tp.inertia.batches, blocks):
                if b.idx.shape[0]:
                    damp += scatter_add(n, b.idx, alpha * np.einsum(
                        "nij,nj->ni", np.abs(m), vp[b.idx]))
        for g, st in zip(tp.num.groups, ev.states):
            if not (beta > 0 or g.damp is not None) or not len(st.D):
                continue
            c = beta * g.S
            if g.damp is not None:
                c = c + g.damp[:, :, None] * np.eye(g.kind.n_def)
            d_abs = np.abs(st.D)
            cdv = np.einsum("nkj,nj->nk", np.abs(c), np.einsum("nkj,nj->nk", d_abs,
                                                                vp[g.idx]))
            damp += scatter_add(n, g.idx, np.einsum("nkj,nk->nj", d_abs, cdv))
        f_floor = f_floor + np.finfo(float).eps * damp
    return floor_r + f_floor[tp.free_idx], floor_c


def _at_floor(tp, floors, r, c, level: float, tol: float) -> bool:
    """Whether every equation of motion meets the tolerance (forces relative to ``level``,
    the step's reference) or lies within a small multiple of its round-off floor
    (``floors``: :func:`_floors`). Called only where the residual is above the tolerance
    and the increments have converged."""
    return tp.prob.within_floor(r, c, *floors, level if level > 0 else 1.0, tol)


def _tolerance_clears_floor(tp, floors, level: float, tol: float) -> bool:
    """Whether the tolerance lies above ``FLOOR_MULTIPLE`` times the round-off floor of
    every equation (``floors``: :func:`_floors`; forces relative to ``level``, weighted as
    in :meth:`StaticProblem.residual_norm`). Where it does not, a converged residual's
    place above or below the tolerance is round-off (the Southwell deck's steps 14 and 16:
    3.8e-10 or 6.9e-11 against 1e-10 after a change of the frame's rate by round-off), so
    the step counts as accepted on its floor (``converged_by`` 1) whichever side it fell;
    the flag then depends only on the floors, smooth functions of the state, and not on
    the residual's round-off (issue 34)."""
    return tp.prob.clears_floor(*floors, level if level > 0 else 1.0, tol)


def _increment_fault(tp, dx, dmu) -> str | None:
    """What is wrong with a Newton increment (not finite, or an Euler-parameter change above
    0.5), or None: a new matrix's increment then fails the step, a chord increment drops
    the kept matrix."""
    if not (np.all(np.isfinite(dx)) and np.all(np.isfinite(dmu))):
        return "non-finite Newton increment"
    if np.abs(dx[tp.free_rot]).max(initial=0.0) > 0.5:
        return "Newton increment too large"
    return None


def _iteration_matrix(tp, opts, slow_newton, t1, x1, v1, a1, mu1, ev, r, blocks,
                      damp_blocks, motion, W, beta_p, gamma_p, nu1=None, g=None, lie=None
                      ) -> tuple[KeptMatrix, tuple]:
    """Form and factorize the iteration matrix at (x1, v1, a1, mu1): the tangent-space
    LDL^T of the static solver (solvers/statics/reduced.py) where it applies, else the bordered
    SuperLU. ``slow_newton``: the last Newton increment reduced the residual by less than
    SLOW_CONTRACTION (switches the exact inertia tangent on). With held slips, ``nu1`` their
    multipliers and ``g`` the pair (slip rows' residual, S over the free coordinates) of
    :meth:`TransientProblem.slip_residual`. ``lie``: the step's Lie-group update
    (:class:`~spacarpy.solvers.dynamics.lie.LieStep`, or None), whose rate derivatives join
    the matrix with the exact inertia tangent. Returns the matrix and its Newton increment
    ``(dx, dmu)`` for the residual r."""
    num, prob = tp.num, tp.prob
    n_x = prob.pattern.n_x
    tp.n_matrices += 1
    blocks = tp.inertia.complete(x1, blocks)             # the mass blocks
    m_max = max([float(np.abs(b).max(initial=0.0)) for b in blocks] + [0.0])
    # iteration matrix [K_t + beta' M, C^T; C, 0] on the Newton matrix's fixed pattern;
    # the constraint rows scaled like its largest entry (the inertia term grows as
    # 1/h^2), which keeps the saddle-point system well conditioned
    # beta' M + gamma' C: the Rayleigh alpha M rides on the mass blocks, the stiffness-
    # proportional and deformation-rate damping are element blocks
    # with the exact tangent: + d(M a + h)/dx + gamma' d h/dv (solvers/dynamics/inertia.py), not
    # symmetric, so the bordered system below takes it (the reduced step's LDL^T needs
    # a symmetric matrix)
    # The tangent costs kernel evaluations and the LDL^T path; where the former matrix
    # converges quadratically anyway (no fast rotation) it brings nothing. So it is taken
    # from the first iteration whose residual fell by less than SLOW_CONTRACTION on
    # (Newton without it converges linearly there), and then for the rest of the run.
    if opts.exact_tangent and not tp.exact_tangent_on and slow_newton:
        tp.exact_tangent_on = True
        log.info("the convective inertia terms slow Newton down at t = %.6g s: the "
                 "exact iteration matrix is used from here on", t1)
    if motion is not None and opts.exact_tangent:
        tp.exact_tangent_on = True   # the frame's W terms are not symmetric anyway
    with_tangent = opts.exact_tangent and tp.exact_tangent_on
    c_h = [] if motion is not None or lie is not None else None
    tangent = (tp.inertia.tangent(x1, v1, a1, gamma_p, velocity_part=c_h)
               if with_tangent else None)
    exact = tangent is not None and any(t is not None for t in tangent)
    extra, nodal = tp.inertia.iteration_parts(
        blocks, beta_p + gamma_p * tp.model.damping[0], tangent)
    for i, cb in damp_blocks.items():
        extra[i] = extra.get(i, 0.0) + gamma_p * cb
    slips = tp.slips.n > 0
    if (prob.reduced is not None and nodal is None and not exact and motion is None
            and not slips):
        # the static solver's tangent-space step (solvers/statics/reduced.py) with the inertia
        # and damping blocks: no Euler multipliers, an LDL^T instead of SuperLU
        k_el, euler_diag, _ = prob.element_blocks(ev, mu1, extra=extra)
        r_full = np.zeros(num.n_coord)
        r_full[tp.free_idx] = r
        step = prob.reduced.step(ev, x1, mu1, k_el, euler_diag, residual=r_full,
                                  invariant=False)
        if step is not None:
            last = prob.reduced.last

            def solve(ev, x, r):                    # the tangent-space LDL^T's
                full = np.zeros(num.n_coord)
                full[tp.free_idx] = r
                return prob.reduced.chord(last, ev, x, residual=full)
            return KeptMatrix(m_max, solve), step
    scale = max(prob.scale, beta_p * m_max)
    S = prob.matrix(ev, mu1, extra=extra, scale=scale)
    if motion is not None:
        coriolis = tp.frame_terms(blocks, c_h, W, gamma_p)
        nodal = coriolis if nodal is None else nodal + coriolis
    user = _user_tangent(tp, t1, x1, v1, ev.states, gamma_p, slow_newton)
    if user is not None:
        nodal = user if nodal is None else nodal + user
    E_v = None
    if lie is not None and with_tangent:
        # the rates' derivatives of the Lie-group update beyond gamma' I and beta' I
        E_v, E_a = lie.jacobians()
        part = lie_terms(tp, blocks, c_h, E_v, E_a)
        nodal = part if nodal is None else nodal + part
    if nodal is not None:
        S = S + _padded(nodal, S.shape[0])
    if slips:
        return _slip_matrix(tp, S, scale, ev, r, x1, v1, nu1, *g, gamma_p, m_max, E_v)
    try:
        lu = spla.splu(S, permc_spec="COLAMD")
    except RuntimeError:
        raise StepFailed("singular iteration matrix") from None

    def solve(ev, x, r):                                # the bordered SuperLU's
        dz = lu.solve(-np.concatenate([r, scale * ev.c]))
        return dz[:n_x], dz[n_x:] * scale
    return KeptMatrix(m_max, solve), solve(ev, x1, r)


def _user_tangent(tp, t, x, v, states, gamma_p, slow_newton):
    """-(d f_user/dx + gamma' d f_user/dv) over the free coordinates (sparse), the direction
    in which a Newton increment moves (x, v), or None: without a user routine's loads, or
    before the difference quotients of a routine that gives no derivatives are needed.

    A routine that returns its derivatives (docs/user-routines.md) has them in every
    iteration matrix (one call); one that does not gets difference quotients (one call per
    free coordinate it reads, :meth:`~spacarpy.user_routines._LoadAdapter.tangent`) from the
    first iteration whose residual fell by less than SLOW_CONTRACTION on. The element states
    are those at x (a routine's dependence on the deformations is not differentiated)."""
    user = tp.prob.loads.user
    if getattr(user, "tangent", None) is None:
        return None
    fd_on = tp.user_tangent_on or slow_newton
    if fd_on and not tp.user_tangent_on and not getattr(user, "gives_derivatives", False):
        tp.user_tangent_on = True
        log.info("the user routine's loads slow Newton down at t = %.6g s: their difference "
                 "quotients join the iteration matrix from here on", t)
    free = tp.free_idx
    if getattr(user, "gives_derivatives", None) is False and not fd_on:
        return None
    k = user.tangent(t, x, v, states, gamma_p, free, difference=fd_on)
    return None if k is None else -k.tocsr()[free]


def _slip_matrix(tp, A, scale, ev, r, x1, v1, nu1, g, S_f, gamma_p, m_max, E_v=None):
    """The iteration matrix of a model with held slips: the bordered matrix ``A`` (free
    coordinates, then the constraints) with ``d(S^T nu)/dx`` added to its force block and
    bordered again by the slip rows ``S + d(S v)/dx / gamma'`` (the derivative of ``S(x)
    v / gamma'`` along ``dv = gamma' dx``) and the columns ``S^T``, both scaled like the
    holonomic rows (with the Lie-group update's ``E_v``, ``dv = (gamma' + E_v) dx``: the
    rows add ``S E_v / gamma'``). Its Newton increment is ``(dx, [dmu, dnu])`` for the
    residuals (r, c, g)."""
    slips, fi = tp.slips, tp.free_idx
    n_x = tp.prob.pattern.n_x
    n_c = A.shape[0] - n_x
    k = slips.n
    dense = dense_slips(tp)
    rows = S_f + slips.rates_dx(x1, v1, fi, dense=dense) / gamma_p
    if E_v is not None:
        rows = rows + (S_f @ E_v) / gamma_p
    F = slips.force_dx(x1, nu1, fi, dense=dense)
    if dense:
        return _dense_slip_matrix(A, F, S_f, rows, scale, ev, x1, r, g, m_max)
    big = sp.bmat([[A + _padded(F, A.shape[0]),
                    sp.vstack([scale * S_f.T, sp.csc_matrix((n_c, k))])],
                   [sp.hstack([scale * rows, sp.csc_matrix((k, n_c))]), None]],
                  format="csc")
    try:
        lu = spla.splu(big, permc_spec="COLAMD")
    except RuntimeError:
        raise StepFailed("singular iteration matrix") from None

    def solve(ev, x, r):         # (the slip rows' residual g of this matrix's state)
        dz = lu.solve(-np.concatenate([r, scale * ev.c, scale * g]))
        return dz[:n_x], dz[n_x:] * scale
    return KeptMatrix(m_max, solve), solve(ev, x1, r)


def dense_slips(tp) -> bool:
    """Whether a model with held slips is small enough (the bordered matrix of at most
    DENSE_SLIP_SIZE rows) for dense arrays and LAPACK's LU in its step: the bicycle's 87
    rows factorize in microseconds, where the sparse construction of the matrix and its
    slip blocks cost milliseconds a Newton iteration (docs/rolling.md "Speed")."""
    return 0 < tp.slips.n and (tp.prob.pattern.n_x + tp.num.n_constraint + tp.slips.n
                               <= DENSE_SLIP_SIZE)


def _dense_slip_matrix(A, F, S_f, rows, scale, ev, x1, r, g, m_max):
    """:func:`_slip_matrix` with dense arrays (``F``, ``S_f`` and ``rows`` arrays, ``A``
    sparse) and LAPACK's LU with partial pivoting."""
    n_x, n_a, k = len(r), A.shape[0], rows.shape[0]
    big = np.zeros((n_a + k, n_a + k))
    big[:n_a, :n_a] = A.toarray()
    big[:n_x, :n_x] += F
    big[:n_x, n_a:] = scale * S_f.T
    big[n_a:, :n_x] = scale * rows
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sla.LinAlgWarning)     # (a zero pivot: below)
        lu = sla.lu_factor(big, check_finite=False)
    if not np.all(np.isfinite(lu[0])) or not np.all(np.diag(lu[0])):
        raise StepFailed("singular iteration matrix")

    def solve(ev, x, r):         # (the slip rows' residual g of this matrix's state)
        dz = sla.lu_solve(lu, -np.concatenate([r, scale * ev.c, scale * g]),
                          check_finite=False)
        return dz[:n_x], dz[n_x:] * scale
    return KeptMatrix(m_max, solve), solve(ev, x1, r)


def _padded(a, n: int) -> sp.csc_matrix:
    """``block_diag([a, 0])`` of size n (n x n, ``a`` in its leading block), made from a's
    arrays without scipy's ``block_diag`` (a COO round trip: 0.5 ms a call)."""
    a = sp.csc_matrix(a)
    indptr = np.concatenate([a.indptr, np.full(n - a.shape[1], a.indptr[-1])])
    return sp.csc_matrix((a.data, a.indices, indptr), shape=(n, n))


def _step(tp, t, h, x, v, a, a_tilde, mu, params, opts):
    """One generalized-alpha step from t to t + h (Arnold & Brüls 2007)."""
    am, af, gamma, beta = params
    num, free, prob, fi = tp.num, tp.free, tp.prob, tp.free_idx
    t1 = t + h
    motion = tp.frame_rate(x, v, h)
    if motion is None:
        yd, ydd, aty = v, a, a_tilde
    else:
        # the step in the frame turning with the model (solvers/dynamics/frame.py):
        # y = x at its start
        yd, ydd, aty = tp.frame.to_frame(motion, x, v, a, a_tilde)
    at_new = (af * ydd - am * aty) / (1 - am)          # a_tilde with a_{n+1} = 0
    # predictor: the accelerations extrapolated linearly from the last two steps, which
    # leaves Newton a residual 3 to 30 times smaller than a_{n+1} = 0 does; but not where
    # the exact inertia tangent is on (fast rotation, a turning frame): there Newton from
    # such a predictor overshoots (measured: 3.2 -> 4.3 iterations per step), from
    # a_{n+1} = 0 it converges quadratically
    smooth = not tp.exact_tangent_on and motion is None
    a1 = np.zeros_like(a)
    if smooth:
        a1 += a
        if tp.previous_acceleration is not None:
            h_prev, a_prev = tp.previous_acceleration
            a1 += (h / h_prev) * (a - a_prev)
    at_pred = at_new + (1 - af) / (1 - am) * a1
    x1 = x + h * yd + h * h * (0.5 - beta) * aty + h * h * beta * at_pred
    v1 = yd + h * (1 - gamma) * aty + h * gamma * at_pred
    W = lie = None
    if tp.lie is not None:
        tp.lie.last = None           # (the error control's: set by a LieStep)
    if motion is not None:
        x1, v1, a1 = tp.frame.from_frame(motion, h, x1, v1, a1)
        W = tp.frame.matrix(motion.omega, free)
    elif tp.lie:
        # the orientations on their group (solvers/dynamics/lie.py): exact for a constant
        # angular velocity, where the linear update above moves q along a chord; a step
        # that would turn a node by more than half a turn is cut (lie.MAX_TURN)
        lie = LieStep(tp.lie, x, v, a, a_tilde, params, h)
        lie.predict(x1, v1, a1)
        if (why := lie.check_turn(start=True)) is not None:
            raise StepFailed(why)
    idx, xp, vp, ap = tp.prescribed(t1)
    if idx.size:
        x1[idx], v1[idx], a1[idx] = xp, vp, ap
    # (no normalization of the predicted Euler parameters: Newton's correction of q.q = 1
    # must pass through the velocity and acceleration updates, which gives them their
    # centripetal radial parts)
    mu1 = mu.copy()
    beta_p = (1 - am) / (h * h * beta * (1 - af))
    gamma_p = gamma / (h * beta)
    dx_norm = np.inf
    history = []
    trial_level = None               # the force level of the step's predictor
    kept = None                      # the step's last iteration matrix (KeptMatrix)
    chord_ok = opts.reuse_matrix and not tp.fresh_only and smooth
    last_chord = False               # whether the last increment came from a kept matrix
    used_chord = False
    slips = tp.slips.n > 0
    nu1, g, res_g, slip_S = tp.nu.copy(), None, 0.0, None
    if slips:
        chord_ok = False             # (a kept matrix has no slip rows' residual of its own)
    for it in range(opts.max_iter + 1):
        ev, blocks, f_in, r, res, _, f_damp, damp_blocks, level = tp.residual(
            t1, x1, v1, a1, mu1, trial_level, mass_blocks=False)
        trial_level = level if trial_level is None else trial_level
        if slips:                    # + S^T nu, and the slip rows S v / gamma'
            r, g, res_g, slip_S = tp.slip_residual(x1, v1, nu1, r, gamma_p)
            ref = max(tp.level, trial_level)
            res = max(prob.residual_norm(r, ev.c, None, None,
                                         level=ref if ref > 0 else 1.0)[0], res_g)
        history.append(res)
        if not np.isfinite(res):
            raise StepFailed("non-finite residual", history, chord=used_chord)
        # converged ("tolerance"): residual and last increment below the tolerance, or a
        # residual so far below it that the equations hold to round-off (the increments of
        # directions the residual hardly sees, such as Euler parameters of nearly massless
        # nodes, may then stall above the tolerance without meaning anything)
        # A residual below the tolerance whose last increment was not yet is tested by the
        # simplified Newton increment (the last factorization applied to this residual:
        # one solve, where a full iteration costs a tangent, a factorization and another
        # residual), which estimates the increment this state still needs
        # Or ("floor"): the residual above the tolerance, the last increment below it, and
        # every equation within its round-off floor measured at this state (_at_floor)
        # (the stored rule: "tolerance" only where the tolerance clears every equation's
        # floor, else "floor" whichever side of it the residual fell, see
        # _tolerance_clears_floor)
        by = None
        ref_level = max(tp.level, trial_level)
        if it > 0 and res <= opts.tol and (
                dx_norm <= max(opts.tol, 1e-13) or res <= 1e-3 * opts.tol
                or (not slips and _simplified_norm(prob, kept, ev, x1, r)
                    <= max(opts.tol, 1e-13))):
            floors = _floors(tp, ev, blocks, x1, v1, a1, mu1)
            by = "tolerance" if _tolerance_clears_floor(tp, floors, ref_level, opts.tol) \
                else "floor"
        elif it > 0 and res > opts.tol and dx_norm <= max(opts.tol, 1e-13) \
                and res_g <= opts.tol and _at_floor(
                tp, _floors(tp, ev, blocks, x1, v1, a1, mu1), r, ev.c, ref_level, opts.tol):
            by = "floor"
        if by is not None:
            if motion is None:
                a_tilde_new = at_new + (1 - af) / (1 - am) * a1
            else:
                y1, yd1, ydd1 = tp.frame.back(motion, h, x1, v1, a1)
                a_tilde_new = tp.frame.from_frame(
                    motion, h, y1, yd1, at_new + (1 - af) / (1 - am) * ydd1)[2]
            if lie is not None:
                if (why := lie.check_turn()) is not None:
                    raise StepFailed(why, history)
                lie.a_tilde(a_tilde_new)
            _gauge(num, x1, v1, a1, a_tilde_new)
            tp.step_nu = nu1
            tp.accept_level(level)
            tp.fresh_only = False
            return x1, v1, a1, a_tilde_new, mu1, it, res, ev, f_in, f_damp, blocks, by
        if it == opts.max_iter:
            break
        # Chord iterations: the step's iteration matrix serves again while each of its
        # increments reduces the residual by KEEP_CONTRACTION at least (or the next one
        # at that rate reaches the tolerance); a new one is formed where it does not. A
        # chord iteration costs a residual and one solve, a Newton iteration also the
        # tangent, the mass blocks and a factorization.
        if (last_chord and history[-1] > KEEP_CONTRACTION * history[-2]
                and history[-1] ** 2 > opts.tol * history[-2]):
            kept = None
        fresh_last = it > 0 and not last_chord
        step = None
        if kept is not None and chord_ok:
            step = kept.chord(ev, x1, r)
            if step is None or _increment_fault(tp, *step):
                step = kept = None
        last_chord = step is not None
        used_chord = used_chord or last_chord
        if step is None:
            slow_newton = (fresh_last and it >= 2
                           and history[-1] > SLOW_CONTRACTION * history[-2] > 0.0)
            try:
                kept, step = _iteration_matrix(
                    tp, opts, slow_newton, t1, x1, v1, a1, mu1, ev, r, blocks,
                    damp_blocks, motion, W, beta_p, gamma_p, nu1, (g, slip_S), lie)
            except StepFailed as fail:
                raise StepFailed(fail.reason, history, chord=used_chord) from None
            fault = _increment_fault(tp, *step)
            if fault:
                raise StepFailed(fault, history, chord=used_chord)
        dx, dmu = step
        dx_norm = prob.increment_norm(dx)
        x1[fi] += dx
        v1[fi] += gamma_p * dx
        a1[fi] += beta_p * dx
        if motion is not None:
            wd = W @ dx
            v1[fi] += wd
            a1[fi] += 2 * gamma_p * wd + W @ wd
        elif lie is not None:
            lie.update(x1, v1, a1, dx)        # (the nodes' x1, v1, a1 anew)
        if slips:
            nu1 = nu1 + dmu[mu1.size:]
            dmu = dmu[:mu1.size]
        mu1 = mu1 + dmu
    hist = ", ".join(f"{v:.2e}" for v in history)
    raise StepFailed(f"no convergence in {opts.max_iter} iterations (residuals {hist})",
                     history, chord=used_chord)



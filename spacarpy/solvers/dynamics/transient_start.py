"""The start of a transient: a consistent initial state, the initial velocities of 5-field
inputs and STARTDE rates, and the initial acceleration. ``tp`` is the TransientProblem of
transient.py (not imported: transient.py imports this module)."""
from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.errors import SpacarError
from spacarpy.model import FLEXIBLE
from spacarpy.solvers.dynamics.transient_step import dense_slips
from spacarpy.solvers.statics.nodal import node_rows

log = logging.getLogger(__name__)

def _initial_velocities(tp, x, v, given: dict):
    """The deck's VELOCITY lines (a position node's velocity, an orientation node's angular
    velocity in global axes: dq/dt = 1/2 (0, w) q), made consistent with the constraints:
    the velocities closest to the given ones (Euler-parameter rates weighted by the length
    scale squared) with ``C v = 0``; the coordinates without a VELOCITY line follow the
    constraints (a weight 1e-6 only keeps the system regular); prescribed velocities are
    kept.

    The rigid modes move at the rates of their targets (INPUTE's velocity, DELINPE times
    phi'(0)). With STARTDE lines every flexible (DYNE) mode is a degree of freedom whose
    rate is given, as in SPACAR: the STARTDE rate, or zero; the released (RLSE) modes and
    the other coordinates follow. The held slips are rows ``S v = 0`` of C."""
    num, prob, free = tp.num, tp.prob, tp.free
    model = tp.model
    pos_row, rot_row = node_rows(model)
    v0 = v.copy()
    target = np.zeros(num.n_coord, dtype=bool)
    for n, value in given.items():
        w = np.asarray(value, dtype=float)
        if int(n) in pos_row:
            v0[num.pos_idx[pos_row[int(n)]]] = w
            target[num.pos_idx[pos_row[int(n)]]] = True
        else:
            ri = num.rot_idx[rot_row[int(n)]]
            target[ri] = True
            q = x[ri]
            v0[ri] = 0.5 * np.concatenate([[-w @ q[1:]], q[0] * w + np.cross(w, q[1:])])
    ev = prob.evaluate(x, np.zeros(num.n_constraint), tp.loads(0.0))
    n_x = prob.pattern.n_x
    C = tp.constraint_jacobian(ev)
    fixed_part = np.where(free, 0.0, v0)
    rhs_c = -_constraint_rates(prob, x, fixed_part)               # prescribed velocities
    rhs_c[:num.n_rigid] += tp.rigid_rates(0.0)[0]                 # driven deformations
    if model.initial_rates:                                       # STARTDE
        E, rates = _flexible_rows(tp, ev.states, model.initial_rates)
        rhs_e = rates - _flexible_rows(tp, ev.states, {}, fixed_part)[1]
        C = sp.vstack([C, E], format="csc")
        rhs_c = np.concatenate([rhs_c, rhs_e])
    if tp.slips.n:                                                # S v = 0
        C = sp.vstack([C, tp.slips.jacobian(x, tp.free_idx)], format="csc")
        rhs_c = np.concatenate([rhs_c, -tp.slips.rates(x, fixed_part)])
    weight = (np.where(prob.rot_mask[free], num.length_scale ** 2, 1.0)
              * np.where(target[free], 1.0, 1e-6))
    big = sp.bmat([[sp.diags(weight), C.T], [C, None]], format="csc")
    try:
        sol = spla.splu(big).solve(np.concatenate([weight * v0[free], rhs_c]))
    except RuntimeError:
        sol = None
    if sol is None or not np.all(np.isfinite(sol)):
        raise SpacarError("the initial velocities (VELOCITY, STARTDE, the rates of INPUTX/"
                          "INPUTE) cannot be met: the flexible modes and the constraints are "
                          "not independent (a statically indeterminate model), or they "
                          "contradict each other")
    out = v0.copy()
    out[free] = sol[:n_x]
    return out


def _flexible_rows(tp, states, given: dict, v=None):
    """The rows ``D_k`` (over the unknowns) of every flexible mode and their target rates
    (``given[(element, mode)]`` or 0); with ``v`` the rates ``D_k v`` instead of the
    targets."""
    num = tp.num
    rows, cols, vals, targets = [], [], [], []
    n_row = 0
    for g, st in zip(num.groups, states):
        el, mode = np.nonzero(g.def_class == FLEXIBLE)
        if not el.size:
            continue
        d = st.D[el, mode]                                      # (n_f, n_ldof)
        if v is not None:
            targets.append(np.einsum("nj,nj->n", d, v[g.idx[el]]))
        else:
            targets.append(np.array([given.get((int(g.ids[e]), int(k) + 1), 0.0)
                                     for e, k in zip(el, mode)]))
        unk = num.unknown_of[g.idx[el]]                          # (n_f, n_ldof)
        keep = unk >= 0
        r = np.broadcast_to(n_row + np.arange(el.size)[:, None], unk.shape)
        rows.append(r[keep])
        cols.append(unk[keep])
        vals.append(d[keep])
        n_row += el.size
    if not n_row:
        return sp.csc_matrix((0, num.n_unknown)), np.zeros(0)
    E = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n_row, num.n_unknown)).tocsc()
    return E, np.concatenate(targets)


def _initial_acceleration(tp, x, v, mu, a_presc, t: float = 0.0, quiet: bool = False):
    """Consistent accelerations and multipliers at time t (default 0) from
    ``[M C^T; C 0] [a; mu] = [f - f_el - h - M_fp a_p; -(C_p a_p + (dC/dt) v - c_tt)]``,
    with the held slips' rows ``S a = -(d(S v)/dx) v - S_p a_p`` and columns ``S^T`` in C
    (their multipliers go to ``tp.nu``);
    zero accelerations (and the given multipliers) when the mass matrix is singular on the
    constraint null space (massless coordinates)."""
    num, free, prob = tp.num, tp.free, tp.prob
    a = np.zeros(num.n_coord)
    a[tp.presc_idx] = a_presc
    ev = prob.evaluate(x, np.zeros_like(mu), tp.loads_at(t, v))  # no constraint forces
    blocks, f_in = tp.inertia.forces(x, v, a)                     # h + M_fp a_p
    M = tp.inertia.assemble(blocks)
    rhs_f = -(ev.f_int - ev.f_ext + f_in)[free]
    n_x = prob.pattern.n_x
    C = tp.constraint_jacobian(ev)
    c_acc = _constraint_rates(prob, x, a)                         # C_p a_p
    if np.any(v):                                                 # (dC/dt) v
        eps = 1e-6 / float(np.abs(v).max())
        c_acc += (_constraint_rates(prob, x + eps * v, v)
                  - _constraint_rates(prob, x - eps * v, v)) / (2 * eps)
    if num.rigid_prescribed.size:                                 # driven deformations
        c_acc[:num.n_rigid] -= tp.rigid_rates(t)[1]
    slips = tp.slips
    if slips.n:                      # S a = -(d(S v)/dx) v - S_p a_p: rows and columns
        S_f = slips.jacobian(x, tp.free_idx)
        C = sp.vstack([C, S_f], format="csc")
        c_acc = np.concatenate([c_acc, slips.rates_dx(x, v) @ v + slips.rates(x, a)])
    big = sp.bmat([[M[free][:, free], C.T], [C, None]], format="csc")
    try:
        sol = spla.splu(big).solve(np.concatenate([rhs_f, -c_acc]))
    except RuntimeError:
        sol = None
    if sol is None or not np.all(np.isfinite(sol)):
        if not quiet:
            log.info("massless coordinates: the initial accelerations start at zero")
        return a, mu
    a[free] = sol[:n_x]
    n_mu = mu.size
    tp.nu = sol[n_x + n_mu:].copy()                               # the slips' multipliers
    return a, sol[n_x:n_x + n_mu]


def _constraint_rates(prob, x, v, states=None):
    """``C(x) v`` for all constraints (rigid modes and Euler normalizations); ``states``:
    the element states at x where the caller has them."""
    num = prob.num
    rates = []
    for i, g in enumerate(num.groups):
        st = (g.kind.state(x[g.idx], g.ref, prob.variant, g.prev) if states is None
              else states[i])
        d = np.einsum("nkj,nj->nk", st.D, v[g.idx])
        rates.append(d[g.rigid_elem, g.rigid_mode])
    q = x[num.euler_coords]
    qd = v[num.euler_coords]
    rates.append(2.0 * np.sum(q * qd, axis=1))
    return np.concatenate(rates)


def _project_velocities(tp, x, v, t: float, ev=None):
    """The velocities of a converged step made consistent with the velocity form of the
    constraints, ``C v = -c_t`` and ``S v = 0``: the closest ones in the mass norm (a
    weight 1e-9 of the largest mass on the massless coordinates).

    The index-3 scheme holds c(x) = 0 but lets the velocities drift from ``C v = -c_t``;
    a model with held slips evaluates ``S v`` with those velocities (a wheel's angular
    velocity from its Euler-parameter rates), and the drift would turn into a slip the
    multipliers then enforce against: a wheel driven at a constant rate would speed up
    (docs/transient.md, "Rolling contact"). ``ev``: the converged step's evaluation at x
    (its constraint Jacobian is all this needs of it), else evaluated here."""
    num, prob, free = tp.num, tp.prob, tp.free
    if ev is None:
        ev = prob.evaluate(x, np.zeros(num.n_constraint), tp.loads(t))
    dense = dense_slips(tp)          # a small model: arrays and LAPACK, no sparse set-up
    C = tp.constraint_jacobian(ev)
    S = tp.slips.jacobian(x, tp.free_idx, dense=dense)
    C = np.vstack([C.toarray(), S]) if dense else sp.vstack([C, S], format="csc")
    fixed_part = np.where(free, 0.0, v)
    rhs_c = (-_constraint_rates(prob, x, fixed_part, ev.states) if np.any(fixed_part)
             else np.zeros(num.n_constraint))
    rhs_c[:num.n_rigid] += tp.rigid_rates(t)[0]
    rhs_c = np.concatenate([rhs_c, -tp.slips.rates(x, fixed_part)])
    M = tp.inertia.matrix(x)[free][:, free]
    d = M.diagonal()
    M = M + sp.diags(np.where(d > 1e-9 * max(float(d.max()), 1e-300), 0.0,
                              1e-9 * max(float(d.max()), 1.0)))
    rhs = np.concatenate([M @ v[free], rhs_c])
    if dense:
        big = np.block([[M.toarray(), C.T], [C, np.zeros((C.shape[0], C.shape[0]))]])
        try:
            sol = np.linalg.solve(big, rhs)
        except np.linalg.LinAlgError:
            return v
    else:
        big = sp.bmat([[M, C.T], [C, None]], format="csc")
        try:
            sol = spla.splu(big).solve(rhs)
        except RuntimeError:
            return v
    if not np.all(np.isfinite(sol)):
        return v
    out = v.copy()
    out[free] = sol[:prob.pattern.n_x]
    return out



def _consistent_acceleration(tp, x, v, a, mu, t: float):
    """The accelerations and multipliers consistent with a converged step's projected
    velocities (:func:`_project_velocities`) in a model with held slips: the equations of
    motion with the acceleration-level constraints ``C a = -(dC/dt) v + c_tt`` and ``S a =
    -(d(S v)/dx) v``, as at the start (:func:`_initial_acceleration`). Returns ``(a, mu)``
    and leaves the slips' multipliers in ``tp.step_nu``; the step's own ``(a, mu)`` where
    the system is singular (massless coordinates).

    They are what the step stores and what the work of the prescribed motions and the next
    step's start use; the generalized-alpha recurrence keeps its own accelerations. The
    index-3 scheme's multipliers satisfy no acceleration-level constraint, and once the
    velocities are projected its accelerations do not either: at RHOINF 1 nothing damps the
    difference, and a prescribed spin's friction alternated between 0 and 0.31 N from step
    to step, and the prescribed hinge's work with it (an energy balance off by 8 % in one
    turn). Putting these accelerations into the recurrence instead made the steady turn
    (check C3) wobble: the Newmark accelerations carry the position constraints'
    corrections (docs/rolling.md, "Transient")."""
    nu_kept = tp.nu
    _, _, _, ap = tp.prescribed(t)
    a_new, mu_new = _initial_acceleration(tp, x, v, mu, ap, t, quiet=True)
    if mu_new is not mu:                                  # (else: singular, kept)
        tp.step_nu = tp.nu
        a, mu = a_new, mu_new
    tp.nu = nu_kept
    return a, mu

"""The Lie-group update of the Euler parameters in a generalized-alpha step: rotations
integrated on their group, exact for a constant angular velocity (docs/transient.md,
"Rotations on their group").

The generalized-alpha step of :mod:`spacarpy.solvers.dynamics.transient_step` updates the
coordinates linearly, ``x1 = x + h v + h^2 (...)``. On the four Euler parameters q of an
orientation node that is the chord of the unit sphere: a wheel spinning at a constant
rate w ends its step with the Newmark rate ``w (1 + (w h)^2/24)`` instead of w.

Here, as in Brüls & Cardona (2010), the generalized-alpha recurrences act on the angular
velocity w (``q' = 1/2 (0, w) q`` in global axes, ``q' = 1/2 q (0, w)`` in body axes), a
pseudo-acceleration A and a rotation vector theta, and the orientation follows the
exponential map::

    theta = h w0 + h^2 (1/2 - beta) A0 + h^2 beta A1  -+  (h^2/12) w0 x w1
    q1    = exp(theta) q0   (global axes)        q1 = q0 exp(theta)   (body axes)
    w1    = w0 + h (1 - gamma) A0 + h gamma A1
    (1 - am) A1 + am A0 = (1 - af) w1' + af w0'

with the commutator term of the two-point Magnus formula (- in global, + in body axes).
Each step takes the axes in which the angular accelerations changed less over the last
step (:meth:`LieNodes.choose_axes`). The Euler parameters and their rates
``q'``, ``q'' = 1/2 (0, w') q - |w|^2/4 q`` stay the state and the unknowns of Newton's
iteration; the rates' derivatives along a tangent increment replace the linear update's
``gamma' I`` and ``beta' I`` in the iteration matrix (:meth:`LieStep.jacobians`).

The nodes updated so are the orientation nodes whose Euler parameters are all free (or,
in a planar model, whose lambda1 and lambda2 are the planar zeros); the others keep the
linear update."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from spacarpy.assembly import csc_with_data
from spacarpy.linalg import cross3


def qmul(p: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The quaternion product ``p r`` of rows (n, 4) (scalar first)."""
    out = np.empty(np.broadcast_shapes(p.shape, r.shape))
    out[..., 0] = p[..., 0] * r[..., 0] - (p[..., 1:] * r[..., 1:]).sum(axis=-1)
    out[..., 1:] = (p[..., :1] * r[..., 1:] + r[..., :1] * p[..., 1:]
                    + cross3(p[..., 1:], r[..., 1:]))
    return out


def conj(q: np.ndarray) -> np.ndarray:
    """The conjugate quaternions ``q*`` of rows (n, 4)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def pure(w: np.ndarray) -> np.ndarray:
    """The pure quaternions ``(0, w)`` of rows w (n, 3)."""
    return np.concatenate([np.zeros(w.shape[:-1] + (1,)), w], axis=-1)


def exp_q(theta: np.ndarray) -> np.ndarray:
    """The unit quaternions of rotation vectors theta (n, 3): (cos(phi/2), sin(phi/2) n)."""
    phi = np.sqrt((theta * theta).sum(axis=-1, keepdims=True))
    half = 0.5 * phi
    # sin(phi/2)/phi, by its series below 1e-4 (error below 1e-18)
    small = phi < 1e-4
    s = np.where(small, 0.5 - phi * phi / 48.0, np.sin(half) / np.where(small, 1.0, phi))
    return np.concatenate([np.cos(half), s * theta], axis=-1)


def log_q(q: np.ndarray) -> np.ndarray:
    """The rotation vectors (n, 3), of angle in [0, pi], of unit quaternions q (n, 4)."""
    q = np.where(q[..., :1] < 0.0, -q, q)            # the shorter way round
    v = q[..., 1:]
    sv = np.sqrt((v * v).sum(axis=-1, keepdims=True))
    phi = 2.0 * np.arctan2(sv, q[..., :1])
    small = sv < 1e-8
    # phi / sin(phi/2) with sin(phi/2) = sv; its limit 2 (1 + phi^2/24) for small angles
    f = np.where(small, 2.0 + phi * phi / 12.0, phi / np.where(small, 1.0, sv))
    return f * v


def tangent_operator(theta: np.ndarray) -> np.ndarray:
    """T(theta) (n, 3, 3) with ``exp(theta + d) = exp(theta) exp(T(theta) d)`` to first
    order (the right Jacobian of the exponential map):
    ``I - (1 - cos phi)/phi^2 [theta~] + (phi - sin phi)/phi^3 [theta~]^2``."""
    phi2 = (theta * theta).sum(axis=-1)[..., None, None]
    phi = np.sqrt(phi2)
    small = phi < 1e-3
    safe = np.where(small, 1.0, phi)
    c1 = np.where(small, 0.5 - phi2 / 24.0 + phi2 * phi2 / 720.0,
                  (1.0 - np.cos(safe)) / (safe * safe))
    c2 = np.where(small, 1.0 / 6.0 - phi2 / 120.0 + phi2 * phi2 / 5040.0,
                  (safe - np.sin(safe)) / safe ** 3)
    t = np.zeros(theta.shape[:-1] + (3, 3))
    t[..., 0, 1], t[..., 0, 2], t[..., 1, 2] = -theta[..., 2], theta[..., 1], -theta[..., 0]
    t[..., 1, 0], t[..., 2, 0], t[..., 2, 1] = theta[..., 2], -theta[..., 1], theta[..., 0]
    return np.eye(3) - c1 * t + c2 * (t @ t)


@dataclass
class LieNodes:
    """The orientation nodes that take the Lie-group update: ``idx`` (n, 4) their Euler
    parameters' coordinate numbers, ``write`` (n, 4) which of them are free (the others
    are a planar model's zeros), ``free_pos`` (n, 4) their rows among the free coordinates
    (-1 where not free)."""

    idx: np.ndarray
    write: np.ndarray
    free_pos: np.ndarray
    n_free: int
    #: (q, global-axis and body-axis angular accelerations, the axes chosen) at the last
    #: step's start (choose_axes)
    history: tuple | None = None
    #: the last step's update (a LieStep; None where it was taken in the turning frame,
    #: whose steps update linearly): the error control reads its pseudo-accelerations
    last: LieStep | None = None

    @classmethod
    def of(cls, num, free: np.ndarray) -> LieNodes:
        rot = num.euler_coords
        planar = num.planar_mask if num.planar_mask.size else np.zeros(num.n_coord, bool)
        ok = (free[rot] | planar[rot]).all(axis=1) & free[rot].any(axis=1) if rot.size \
            else np.zeros(0, bool)
        idx = rot[ok] if rot.size else np.zeros((0, 4), int)
        pos = np.full(num.n_coord, -1)
        pos[np.flatnonzero(free)] = np.arange(int(free.sum()))
        return cls(idx=idx, write=free[idx], free_pos=pos[idx], n_free=int(free.sum()))

    def __bool__(self) -> bool:
        return bool(len(self.idx))

    def choose_axes(self, q0: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Per node, whether its step is taken in global axes (True) or in its body axes:
        all nodes in the axes in which their angular accelerations changed less since the
        last step's start (summed over the nodes: the Newmark part of the update is exact
        for a constant one, and nodes joined by hinges fare better in the same axes), by
        ``SWITCH_FACTOR`` at least, else the last step's axes. Body axes without a history
        (the first step); a step that starts where the last one did (a retry) keeps its
        axes. Measured: docs/transient.md."""
        qc = conj(q0)
        dw_s = 2.0 * qmul(qdd, qc)[:, 1:]
        dw_b = 2.0 * qmul(qc, qdd)[:, 1:]
        hist = self.history
        if hist is not None and np.array_equal(hist[0], q0):
            return hist[3]
        if hist is None or hist[0].shape != q0.shape:
            left = np.zeros(len(q0), bool)
        else:
            now = bool(hist[3][0]) if len(hist[3]) else False
            change_s = float(np.abs(dw_s - hist[1]).sum())
            change_b = float(np.abs(dw_b - hist[2]).sum())
            # the other axes only where they are better by SWITCH_FACTOR: two nearly equal
            # changes (or two at round-off) must not flip the scheme from step to step or
            # from one run to an equal one
            if now and change_b * SWITCH_FACTOR < change_s:
                now = False
            elif not now and change_s * SWITCH_FACTOR < change_b:
                now = True
            left = np.full(len(q0), now)
        self.history = (q0, dw_s, dw_b, left)
        return left


#: The coefficient c of the commutator term ``c h^2 w0 x w1`` of the rotation increment in
#: global axes (-c in body axes; docs/transient.md, "Rotations on their group"): it
#: removes the ``h^3/12 w x w'`` of the exponential map's derivative from the local error
#: (the two-point Magnus formula); 0 would be the plain Lie-group generalized-alpha method.
COMMUTATOR = -1.0 / 12.0


#: The axes of the update change only where the other axes' change of the angular
#: accelerations is smaller by this factor (LieNodes.choose_axes).
SWITCH_FACTOR = 2.0

#: A Newton increment whose turn (rad) is at most this turns the Euler parameters by
#: itself instead of evaluating them anew (LieStep.update): its square is round-off.
SMALL_TURN = 1e-8

#: The largest turn (rad) of a node in one step (LieStep.check_turn): the exponential map
#: is one to one up to half a turn, and a step beyond it is cut. Past pi the new Euler
#: parameters lie nearer the other way round (q1 . q0 < 0): the hinge angles, read from
#: the orientations, lost a turn (a spin of 10 rad/s at two steps a second ended at
#: 10 - 2 pi rad), and the exponential map's tangent operator is singular at 2 pi.
MAX_TURN = np.pi


def _skew(w: np.ndarray) -> np.ndarray:
    """[w~] (n, 3, 3) of rows w (n, 3)."""
    t = np.zeros(w.shape[:-1] + (3, 3))
    t[..., 0, 1], t[..., 0, 2], t[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    t[..., 1, 0], t[..., 2, 0], t[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    return t


def _side(left, *arrays):
    """``left`` (n,) reshaped to broadcast against the first axis of ``arrays``."""
    nd = max(a.ndim for a in arrays)
    return left.reshape(left.shape + (1,) * (nd - 1))


class LieStep:
    """One step's Lie-group update of the nodes ``nodes`` (:class:`LieNodes`) from the
    state (x, v, a, a_tilde) at its start, with the generalized-alpha parameters
    ``(am, af, gamma, beta)`` and the step h; ``left`` (n,) per node whether in global
    axes (None: :meth:`LieNodes.choose_axes`).

    Newton's unknown for the nodes is their pseudo-acceleration A1, accumulated from the
    increments as the linear update accumulates a1 (a function of the Euler parameters
    instead, ``A1 = K^-1 (log(q1 q0*) - theta0)``, would carry their round-off times
    ``1/h^2``); the Euler parameters ``exp(theta) q0`` follow."""

    def __init__(self, nodes: LieNodes, x, v, a, a_tilde, params, h: float, left=None):
        self.nodes = nodes
        am, af, gamma, beta = params
        self.params, self.h = params, h
        q0 = x[nodes.idx]
        q0 = q0 / np.sqrt((q0 * q0).sum(axis=1, keepdims=True))
        self.q0, self.q0c = q0, conj(q0)
        self.left = nodes.choose_axes(q0, a[nodes.idx]) if left is None else left
        self.w0 = self.spatial(v[nodes.idx])                  # angular velocity
        self.dw0 = self.spatial(a[nodes.idx])                 # angular acceleration
        self.at0 = self.spatial(a_tilde[nodes.idx])           # pseudo-acceleration
        # theta = theta0 + K A1: the Newmark update of the rotation vector plus the
        # commutator term c h^2 w0 x w1, w1 = w0 + h (1 - gamma) A0 + h gamma A1
        c = np.where(self.left, COMMUTATOR, -COMMUTATOR)[:, None, None]
        self.theta0 = (h * self.w0 + h * h * (0.5 - beta) * self.at0
                       + c[:, :, 0] * h ** 3 * (1 - gamma) * cross3(self.w0, self.at0))
        self.k = h * h * beta * np.eye(3) + c * h ** 3 * gamma * _skew(self.w0)
        self.k_inv = np.linalg.inv(self.k)
        self.gamma_p = gamma / (h * beta)
        self.beta_p = (1 - am) / (h * h * beta * (1 - af))
        self.at1 = None
        nodes.last = self
        self.length = np.ones((len(q0), 1))      # of the Euler parameters (update)
        self.radial = np.zeros_like(q0)          # the increments' radial parts (update)
        self._state = None

    def turn(self) -> np.ndarray:
        """The nodes' turns ``|theta|`` (rad) over the step, at the current iterate."""
        theta = self.theta0 + np.einsum("nij,nj->ni", self.k, self.at1)
        return np.sqrt((theta * theta).sum(axis=1))

    def check_turn(self, start: bool = False) -> str | None:
        """Why the step must be cut, or None: a node turns by more than ``MAX_TURN``;
        ``start``: already at its initial angular velocity (``h |w0|``, before Newton: the
        predictor's extrapolated accelerations may overshoot where the converged step
        does not)."""
        turn = (self.h * np.sqrt((self.w0 * self.w0).sum(axis=1)) if start
                else self.turn())
        k = int(np.argmax(turn)) if len(turn) else 0
        if not len(turn) or turn[k] <= MAX_TURN:
            return None
        return (f"the step turns an orientation node by {turn[k]:.3g} rad, more than pi "
                f"(the rotation update's limit: half a turn a step)")

    def angular_error(self, c: float) -> np.ndarray:
        """The local error of each node's rotation (rad), ``c |A1 - A0|`` with ``c = h^2
        |beta - 1/6|`` and A the pseudo-accelerations in the step's axes (those of the
        Newmark part of the update, :func:`~spacarpy.solvers.dynamics.transient_step.
        _error_norm`'s estimate for the positions): 0 for a constant angular velocity, where
        the four Euler parameters' pseudo-accelerations (``-|w|^2/4 q`` turning with q)
        change at every step."""
        d = self.at1 - self.at0
        return c * np.sqrt((d * d).sum(axis=1))

    def _rt(self, q, u):
        """``u q`` for the nodes in global axes, ``q u`` for those in body axes."""
        return np.where(_side(self.left, q, u), qmul(u, q), qmul(q, u))

    def _t_inv(self, theta):
        """``T(theta)^-1`` in each node's axes (transposed in global axes)."""
        t = tangent_operator(theta)
        return np.linalg.inv(np.where(self.left[:, None, None], t.transpose(0, 2, 1), t))

    def spatial(self, qd: np.ndarray) -> np.ndarray:
        """The vectors ``2 vec(qd q0*)`` (global axes) or ``2 vec(q0* qd)`` (body axes) of
        Euler-parameter rates qd (n, 4) at the step's start (angular velocity,
        acceleration)."""
        return 2.0 * self._rt(self.q0c, qd)[:, 1:]

    def predict(self, x1, v1, a1) -> None:
        """The predictor, in place: the nodes' accelerations a1 (as the linear predictor
        has them, at the step's start) taken as the angular acceleration w1', the
        orientation and rates from the recurrences."""
        am, af, gamma, beta = self.params
        dw1 = self.spatial(a1[self.nodes.idx])
        self.at1 = (af * self.dw0 - am * self.at0 + (1 - af) * dw1) / (1 - am)
        self._evaluate(x1, v1, a1)

    def update(self, x1, v1, a1, dx) -> None:
        """Newton's increment dx (over the free coordinates) of the nodes, in place: its
        tangent part ``delta = 2 vec(dq q1*)`` turns the rotation vector by ``T(theta)^-1
        delta`` (the radial part is the normalization's, which exp keeps), and x1, v1,
        a1 of the nodes follow.

        The Euler parameters are ``s exp(theta) q0`` anew while the increment is above
        ``SMALL_TURN`` (s their length, which the increments' radial parts change as the
        normalization constraint's row asks); below it they take the increment itself,
        ``q1 + dq`` (the same to ``|delta|^2``), so that an increment at round-off leaves
        them as the linear update does. The radial parts also change the rates by
        ``gamma'`` and ``beta'`` times themselves, as in the linear update: the iteration
        matrix assumes that response (the gauge resets the radial rates after the step).
        Without these, Newton's radial increments (which the normalization's round-off
        asks at every iteration) met no response: the residual of the cantilever's free
        vibration (tolerance 1e-14) stalled at 2e-12 N against its floor of 1e-18 N."""
        q1, theta = self._state[:2]
        dq = np.where(self.nodes.free_pos >= 0, dx[self.nodes.free_pos], 0.0)
        qq = (q1 * q1).sum(axis=1, keepdims=True)
        rho = (q1 * dq).sum(axis=1, keepdims=True) / qq
        self.length = self.length * (1.0 + rho)
        # the radial part's rates as the linear update gives them (the iteration matrix
        # assumes them; the gauge resets them at the end of the step)
        self.radial = self.radial + rho * q1
        delta = 2.0 * self._rt(conj(q1), dq)[:, 1:] / qq
        t_inv = self._t_inv(theta)
        self.at1 = self.at1 + np.einsum("nij,nj->ni", self.k_inv @ t_inv, delta)
        small = float(np.abs(delta).max(initial=0.0)) <= SMALL_TURN
        self._evaluate(x1, v1, a1, q1 + dq if small else None)

    def _evaluate(self, x1, v1, a1, q1=None) -> None:
        am, af, gamma, beta = self.params
        h = self.h
        at1 = self.at1
        theta = self.theta0 + np.einsum("nij,nj->ni", self.k, at1)
        if q1 is None:
            q1 = self.length * self._rt(self.q0, exp_q(theta))
        w1 = self.w0 + h * (1 - gamma) * self.at0 + h * gamma * at1
        dw1 = ((1 - am) * at1 + am * self.at0 - af * self.dw0) / (1 - af)
        qd = 0.5 * self._rt(q1, pure(w1))
        qdd = 0.5 * self._rt(q1, pure(dw1)) - 0.25 * (w1 * w1).sum(axis=1, keepdims=True) * q1
        idx, w = self.nodes.idx, self.nodes.write
        qd = qd + self.gamma_p * self.radial
        qdd = qdd + self.beta_p * self.radial
        x1[idx[w]], v1[idx[w]], a1[idx[w]] = q1[w], qd[w], qdd[w]
        self._state = (q1, theta, w1, dw1)

    def a_tilde(self, a_tilde1) -> None:
        """The converged step's pseudo-accelerations of the nodes, in place: ``1/2 (0,
        A1) q1`` (their radial part is the gauge's, transient_step._gauge)."""
        q1 = self._state[0]
        idx, w = self.nodes.idx, self.nodes.write
        a_tilde1[idx[w]] = (0.5 * self._rt(q1, pure(self.at1)))[w]

    def jacobians(self):
        """``(E_v, E_a)``, sparse over the free coordinates: the derivatives of the
        nodes' rates v1 and a1 along an increment of x1, less the linear update's
        ``gamma' I`` and ``beta' I``, on the tangent space (``(J - c I) P``, P the
        projection off q1: the radial direction is the normalization constraint's)."""
        am, af, gamma, beta = self.params
        q1, theta, w1, dw1 = self._state
        n = len(q1)
        da = self.k_inv @ self._t_inv(theta)
        dv_dd = self.h * gamma * da                  # dw1 = h gamma K^-1 T^-1 delta
        da_dd = (1 - am) / (1 - af) * da             # dw1' = (1 - am)/(1 - af) K^-1 T^-1 delta
        eye = np.eye(3)
        jv = np.empty((n, 4, 3))
        ja = np.empty((n, 4, 3))
        pw, pdw = pure(w1), pure(dw1)
        w2 = (w1 * w1).sum(axis=1)
        for k in range(3):                                      # delta = e_k
            dq = 0.5 * self._rt(q1, pure(np.broadcast_to(eye[k], (n, 3))))
            dwv, dwa = dv_dd[:, :, k], da_dd[:, :, k]
            jv[:, :, k] = (0.5 * self._rt(dq, pw) + 0.5 * self._rt(q1, pure(dwv))
                           - self.gamma_p * dq)
            ja[:, :, k] = (0.5 * self._rt(dq, pdw) + 0.5 * self._rt(q1, pure(dwa))
                           - 0.5 * (w1 * dwv).sum(axis=1)[:, None] * q1
                           - 0.25 * w2[:, None] * dq - self.beta_p * dq)
        # delta = 2 vec(dq q1*) = 2 G(q1) dq
        g = 2.0 * self._rt(conj(q1)[:, None, :], np.eye(4)[None, :, :])[:, :, 1:]
        g = g.transpose(0, 2, 1)                                 # (n, 3, 4)
        return self._sparse(jv @ g), self._sparse(ja @ g)

    def _sparse(self, blocks) -> sp.csc_matrix:
        pos = self.nodes.free_pos
        ok = (pos[:, :, None] >= 0) & (pos[:, None, :] >= 0)
        rows = np.broadcast_to(pos[:, :, None], blocks.shape)[ok]
        cols = np.broadcast_to(pos[:, None, :], blocks.shape)[ok]
        m = self.nodes.n_free
        return sp.csc_matrix((blocks[ok], (rows, cols)), shape=(m, m))


def lie_terms(tp, mass_blocks, velocity_blocks, E_v, E_a):
    """The Lie-group update's part of the Newton matrix over the free coordinates:
    ``M (E_a + alpha E_v) + C_h E_v`` (``C_h = dh/dv``, ``velocity_blocks`` from
    :meth:`Inertia.tangent`, or None; alpha the Rayleigh mass damping). The stiffness-
    proportional and EDAMP damping's ``E_v`` terms are left out (as the frame's are)."""
    sub, sel = tp._free_part
    M_ff = csc_with_data(sub, tp.inertia.assemble(mass_blocks).data[sel])
    out = M_ff @ (E_a + tp.model.damping[0] * E_v)
    if velocity_blocks:
        out = out + csc_with_data(sub, tp.inertia.assemble(velocity_blocks).data[sel]) @ E_v
    return out


__all__ = ["LieNodes", "LieStep", "MAX_TURN", "exp_q", "lie_terms", "log_q", "qmul",
           "tangent_operator"]

"""The rolling wheel WHEEL (SPACAR type 12, ``WHEEL e p r q ax ay az``), vectorized.

A thin rigid disc (a knife edge) rolls on a flat rigid ground. Nodes: the hub p (position),
the wheel's orientation node r, and the contact point q, a position node of its own whose
coordinates are unknowns of the model; ``(ax, ay, az)`` is the axle direction in the reference
configuration, in global axes (required). Six deformation modes: 1, 2, 3 and 6 are holonomic
(position level) and go through the usual ``state`` and ``hessian``; 4 and 5 are the slips, on
the velocity level (non-holonomic), declared as ``velocity_modes = (3, 4)`` (0-based) with
their own kernels :func:`wheel_slip`, :func:`wheel_slip_dx` and :func:`wheel_slip_force_dx`.
docs/rolling.md, "The WHEEL element", has the definitions with their sources.

Local coordinates
-----------------
x : (n_elem, 10)
    ``[x_p (3), lambda_r (4), x_q (3)]``; velocities ``v = (dx_p, dlambda_r, dx_q)``.

Definitions (rolling-contact spec, section 2.3)
-----------------------------------------------
- ground normal ``n = -sign((x_q0 - x_p0) . g_3) g_3`` (from the ground towards the wheel);
  the ground is the horizontal plane through the contact node's initial position;
- ``a = R(lambda_r) a0`` the axle (a0 the deck's vector normalized), ``d = x_q - x_p``,
  ``e_l = (a x n)/|a x n|`` the heading, ``e_t = n x e_l`` lateral, and
  ``u = (a x e_l)/|a|`` the unit vector in the wheel plane from the hub towards the ground,
  ``-(n - (a.n) a)/|n - (a.n) a|`` for unit Euler parameters (written so that it is a unit
  vector for any ``|lambda_r|``);
- holonomic modes (m), zero in the reference configuration::

      e1 = a . d - a0 . d0        (contact point in the wheel plane)
      e2 = e_l . d - e_l0 . d0    (no fore-aft offset: the lowest point of the rim)
      e3 = u . d - r0             (on the rim; r0 = u0 . d0 = |d0| for a valid reference)
      e6 = n . (x_q - x_q0)       (on the ground)

  (the offsets ``a0 . d0`` and ``e_l0 . d0`` are zero to the reference checks' tolerance,
  :func:`wheel_reference_problems`; they make the stored deformations exactly zero there);
- slips (m/s), linear in the velocities: with ``omega = 2 Lambda(lambda_r) dlambda_r/dt``
  (:func:`spacarpy.rotation.lambda_matrix`) the velocity of the wheel's material point at
  the contact is ``v_P = dx_p + omega x d`` and

      s4 = e_l . v_P   (longitudinal),   s5 = e_t . v_P   (lateral),

  ``s = S(x) v`` with ``S`` (2, 10); its ``dx_q`` columns are zero.

Derivatives
-----------
Exact: the kernels are written once with :class:`spacarpy.elements.jet.Jet`, which carries
the value, gradient and Hessian through the dot and cross products, the normalizations and
the rotation (second-order forward differentiation, no differences). The slip kernels
differentiate ``s(x, v)`` in the 20 variables (x, v): ``S = ds/dv``,
``d(S v)/dx = ds/dx`` and ``d(S^T nu)/dx = d^2 (nu . s)/dv dx``.

Properties
----------
No ESTIFF (a WHEEL mode cannot be flexible: tyre compliance is not supported yet) and no EM
(masses and inertias go on p and r with XM). RLSE 4 / RLSE 5 let the wheel slide freely.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from spacarpy.elements.base import POS_P, POS_Q, ROT_AT_P, ElementKind, Reference
from spacarpy.elements.jet import Jet, cross, dot, norm, rotate, unit
from spacarpy.rotation import hessian_combination, lambda_matrix, skew, vector_jacobians
from spacarpy.rotation import rotate as rotate_plain

N_LDOF = 10
N_DEF = 6
#: The 0-based holonomic and velocity-level modes.
HOLONOMIC = (0, 1, 2, 5)
VELOCITY = (3, 4)
#: Relative tolerance of the reference checks (times the radius); the smallest ``|a0 x n|``.
REFERENCE_TOL = 1e-6
VERTICAL_TOL = 1e-6


@dataclass(frozen=True, slots=True, eq=False)
class WheelReference(Reference):
    """A WHEEL group's reference data, from :meth:`Wheel.reference`.

    a0 : (n_elem, 3)
        The axle in the reference configuration (unit vectors).
    n : (n_elem, 3)
        The ground normal (``+-g_3``, from the ground towards the wheel).
    xq0 : (n_elem, 3)
        The contact node's reference position (m): the ground passes through it.
    e0 : (n_elem, 3)
        The reference values ``a0 . d0``, ``e_l0 . d0`` (both ~0) and ``u0 . d0 = r0`` (the
        radius), m.
    """

    a0: np.ndarray
    n: np.ndarray
    xq0: np.ndarray
    e0: np.ndarray


def ground_normal(xp0: np.ndarray, xq0: np.ndarray) -> np.ndarray:
    """``n = -sign((x_q0 - x_p0) . g_3) g_3`` (n, 3) (+z where the hub is above the contact
    point in z)."""
    out = np.zeros((xp0.shape[0], 3))
    out[:, 2] = -np.sign(xq0[:, 2] - xp0[:, 2])
    return out


def _frame_vectors(a, nvec):
    """The heading e_l and the in-plane direction u (plain arrays), for the reference."""
    b = np.cross(a, nvec)
    el = b / np.linalg.norm(b, axis=1, keepdims=True)
    u = np.cross(a, el) / np.linalg.norm(a, axis=1, keepdims=True)
    return el, u


def _vec(v) -> str:
    return "(" + ", ".join(f"{c:.6g}" for c in v) + ")"


def wheel_reference_problems(xp0: np.ndarray, xq0: np.ndarray, vector: np.ndarray) -> list:
    """The reference checks of WHEEL elements: ``[(row, message), ...]`` for the elements
    (rows) whose reference configuration is not a wheel standing on the ground with its
    contact node at the lowest rim point. A missing or zero axle, coincident hub and contact
    node, a contact node level with the hub, a vertical axle, a contact node off the wheel
    plane or not at the lowest rim point (tolerance :data:`REFERENCE_TOL` times the radius)."""
    out = []
    d0 = xq0 - xp0
    r0 = np.linalg.norm(d0, axis=1)
    for i in range(d0.shape[0]):
        v = vector[i]
        shown = "(" + ", ".join(f"{c:g}" for c in v) + ")"
        if np.isnan(v).any():
            out.append((i, "a WHEEL needs its axle direction ax ay az"))
            continue
        if np.linalg.norm(v) < REFERENCE_TOL:
            out.append((i, f"the axle {shown} is (nearly) zero"))
            continue
        if r0[i] == 0.0:
            out.append((i, "the hub and the contact node are at the same position (the "
                           "radius is zero)"))
            continue
        if abs(d0[i, 2]) <= REFERENCE_TOL * r0[i]:
            out.append((i, "the contact node is level with the hub: the ground is the "
                           "horizontal plane through the contact node, so the hub must be "
                           "above or below it in z"))
            continue
        a0 = v / np.linalg.norm(v)
        nvec = ground_normal(xp0[i:i + 1], xq0[i:i + 1])
        if np.linalg.norm(np.cross(a0, nvec[0])) <= VERTICAL_TOL:
            out.append((i, f"the axle {shown} is vertical: the wheel would lie flat on the "
                           "ground"))
            continue
        off = float(a0 @ d0[i])
        if abs(off) > REFERENCE_TOL * r0[i]:
            out.append((i, f"the contact node is not in the wheel plane: the hub-to-contact "
                           f"vector has {off:.6g} m along the axle {shown}"))
            continue
        _, u0 = _frame_vectors(a0[None], nvec)
        gap = np.linalg.norm(d0[i] - r0[i] * u0[0])
        if gap > REFERENCE_TOL * r0[i]:
            out.append((i, "the contact node is not the rim point nearest the ground: the "
                           "hub-to-contact vector " + _vec(d0[i]) + " must point along "
                           + _vec(u0[0]) + ", the wheel plane's direction towards the ground"))
    return out


def wheel_reference(xp0: np.ndarray, xq0: np.ndarray, vector: np.ndarray) -> WheelReference:
    """The reference record (no checks: :func:`wheel_reference_problems` made them)."""
    xp0, xq0 = np.asarray(xp0, float), np.asarray(xq0, float)
    a0 = np.asarray(vector, float)
    a0 = a0 / np.linalg.norm(a0, axis=1, keepdims=True)
    nvec = ground_normal(xp0, xq0)
    el0, u0 = _frame_vectors(a0, nvec)
    d0 = xq0 - xp0
    e0 = np.stack([(a0 * d0).sum(1), (el0 * d0).sum(1), (u0 * d0).sum(1)], axis=1)
    return WheelReference(a0, nvec, xq0.copy(), e0)


# ------------------------------------------------------------------------------ the kernels
class _Frame(NamedTuple):
    d: Jet
    a: Jet
    el: Jet
    u: Jet


def _frame(z: np.ndarray, ref: WheelReference, m: int, second: bool) -> _Frame:
    """The jets of d, a, e_l and u in the variables z (n, m), x = z[:, :10]."""
    xp = Jet.variables(z, 0, 3, m, second)
    lam = Jet.variables(z, 3, 4, m, second)
    xq = Jet.variables(z, 7, 3, m, second)
    d = xq - xp
    a = rotate(lam, ref.a0)
    nvec = Jet.constant(ref.n, m, second)
    el = unit(cross(a, nvec))
    u = cross(a, el) * norm(a).reciprocal()
    return _Frame(d, a, el, u)


class WheelState:
    """Deformations and Jacobian of the holonomic modes (velocity modes: zero rows), plus
    what the Hessian and the check reuse. The Hessians ``H`` are formed on first use (a
    transient step evaluates states more often than it forms an iteration matrix)."""

    __slots__ = ("e", "D", "a", "n", "_x", "_ref", "_H")

    def __init__(self, e, D, a, n, x=None, ref=None, H=None):
        self.e, self.D, self.a, self.n = e, D, a, n       # (n, 6), (n, 6, 10), axle, normal
        self._x, self._ref, self._H = x, ref, H

    @property
    def H(self) -> np.ndarray:
        """(n, 4, 10, 10) the Hessians of modes 1, 2, 3, 6."""
        if self._H is None:
            self._H = wheel_hessians(self._x, self._ref)
        return self._H


def _outer(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[:, :, None] * b[:, None, :]


def _sym(a: np.ndarray, b: np.ndarray) -> np.ndarray:                # a b^T + b a^T
    return _outer(a, b) + _outer(b, a)


def _closed_frame(x: np.ndarray, ref: WheelReference):
    """``a, A, b, B, beta, e_l, grad beta, de_l/dlambda, u, du/dlambda`` at x (notation of
    :func:`wheel_hessians`)."""
    lam, a0, nv = x[:, 3:7], ref.a0, ref.n
    a = rotate_plain(lam, a0)
    A = vector_jacobians(lam, a0[:, None, :])[:, 0]                   # (n, 3, 4)
    B = -skew(nv) @ A
    b = _cross(a, nv)
    beta = np.linalg.norm(b, axis=1)
    el = b / beta[:, None]
    gb = np.einsum("ni,nij->nj", el, B)                               # grad beta
    dl = (B - el[:, :, None] * gb[:, None, :]) / beta[:, None, None]
    al = np.sqrt((a * a).sum(1))
    ga = np.einsum("ni,nij->nj", a, A) / al[:, None]                  # grad |a|
    u = _cross(a, el) / al[:, None]
    du = ((skew(a) @ dl - skew(el) @ A) / al[:, None, None]
          - u[:, :, None] * (ga / al[:, None])[:, None, :])
    return a, A, b, B, beta, el, gb, dl, u, du


def _closed_state(x: np.ndarray, ref: WheelReference):
    """``(e, D, a)`` of :func:`wheel_state` in closed form (:func:`_wheel_jets` with
    first order only is its test oracle)."""
    n = x.shape[0]
    a, A, _, _, _, el, _, dl, u, du = _closed_frame(x, ref)
    d = x[:, 7:10] - x[:, 0:3]
    e = np.zeros((n, N_DEF))
    D = np.zeros((n, N_DEF, N_LDOF))
    for k, (mode, w, J) in enumerate(zip(HOLONOMIC[:3], (a, el, u), (A, dl, du))):
        e[:, mode] = (w * d).sum(axis=1) - ref.e0[:, k]
        D[:, mode, 0:3] = -w
        D[:, mode, 7:10] = w
        D[:, mode, 3:7] = np.einsum("ni,nij->nj", d, J)
    e[:, 5] = ((x[:, 7:10] - ref.xq0) * ref.n).sum(axis=1)           # e6, linear
    D[:, 5, 7:10] = ref.n
    return e, D, a


def wheel_hessians(x: np.ndarray, ref: WheelReference) -> np.ndarray:
    """The Hessians (n, 4, 10, 10) of modes 1, 2, 3, 6 in closed form (the second-order jet
    of :func:`_wheel_jets` is their test oracle). Mode k is ``w . d``, d = x_q - x_p; its
    lambda-lambda block is ``d^2(w . d)/dlambda^2`` at fixed d, its lambda-x blocks
    ``+-dw/dlambda``. With ``a = R a0`` (``A = da/dlambda``, ``Ha(c) = d^2(c . a)``:
    :func:`~spacarpy.rotation.hessian_combination`), ``b = a x n`` (``B = -[n~] A``,
    ``d^2(c . b) = Ha(n x c)``), ``beta = |b|``, ``e_l = b/beta``: ``e_l . d = p/beta``
    with ``p = d . b``; and ``u . d = q/(beta |a|)`` with ``q = d . (a x b) = (d . a)(a .
    n) - (d . n)(a . a)``."""
    a0, nv, d = ref.a0, ref.n, x[:, 7:10] - x[:, 0:3]
    a, A, b, B, beta, el, gb, dl, u, du = _closed_frame(x, ref)
    def ha(c):                                                        # d^2(c . a)/dlambda^2
        return hessian_combination(_outer(c, a0))
    def vt(c, M):                                                     # c^T M (n, 4)
        return np.einsum("ni,nij->nj", c, M)
    hb = ((B.transpose(0, 2, 1) @ B - _outer(gb, gb)) / beta[:, None, None]
          + ha(_cross(nv, el)))                                       # hess beta
    p = (d * b).sum(1)
    gp, hp = vt(d, B), ha(_cross(nv, d))
    ib = (1.0 / beta)[:, None, None]
    h_el = (hp * ib - _sym(gp, gb) * ib ** 2 - (p[:, None, None] * hb) * ib ** 2
            + 2.0 * p[:, None, None] * _outer(gb, gb) * ib ** 3)
    s1, s2, s3, dn = (d * a).sum(1), (a * nv).sum(1), (a * a).sum(1), (d * nv).sum(1)
    g1, g2, g3 = vt(d, A), vt(nv, A), 2.0 * vt(a, A)
    h3 = 2.0 * (A.transpose(0, 2, 1) @ A + ha(a))
    q = s1 * s2 - dn * s3
    gq = g1 * s2[:, None] + s1[:, None] * g2 - dn[:, None] * g3
    hq = (ha(d) * s2[:, None, None] + s1[:, None, None] * ha(nv) + _sym(g1, g2)
          - dn[:, None, None] * h3)
    al = np.sqrt(s3)
    ga = g3 / (2.0 * al[:, None])
    hal = h3 / (2.0 * al[:, None, None]) - _outer(g3, g3) / (4.0 * al ** 3)[:, None, None]
    phi = 1.0 / (beta * al)
    gl = -(gb / beta[:, None] + ga / al[:, None])                     # grad log phi
    hl = -(hb / beta[:, None, None] - _outer(gb, gb) / (beta ** 2)[:, None, None]
           + hal / al[:, None, None] - _outer(ga, ga) / (al ** 2)[:, None, None])
    gphi, hphi = phi[:, None] * gl, phi[:, None, None] * (_outer(gl, gl) + hl)
    h_u = hq * phi[:, None, None] + _sym(gq, gphi) + q[:, None, None] * hphi
    H = np.zeros((x.shape[0], 4, N_LDOF, N_LDOF))
    for k, (hw, J) in enumerate(((ha(d), A), (h_el, dl), (h_u, du))):
        H[:, k, 3:7, 3:7] = hw
        H[:, k, 7:10, 3:7] = J
        H[:, k, 0:3, 3:7] = -J
        H[:, k, 3:7, 7:10] = J.transpose(0, 2, 1)
        H[:, k, 3:7, 0:3] = -J.transpose(0, 2, 1)
    return H


def jet_hessians(x: np.ndarray, ref: WheelReference) -> np.ndarray:
    """The Hessians of :func:`wheel_hessians` through the second-order jet (its test
    oracle)."""
    return _wheel_jets(np.asarray(x, float), ref, True)[2]


def _wheel_jets(x: np.ndarray, ref: WheelReference, second: bool):
    """``(e, D, H or None, a)`` of :func:`wheel_state`: the jet in the Euler parameters
    to first or second order (the first-order parts are the same numbers either way)."""
    n = x.shape[0]
    lam = Jet.variables(x[:, 3:7], 0, 4, 4, second)
    a = rotate(lam, ref.a0)
    el = unit(cross(a, Jet.constant(ref.n, 4, second)))
    u = cross(a, el) * norm(a).reciprocal()
    d = x[:, 7:10] - x[:, 0:3]
    e = np.zeros((n, N_DEF))
    D = np.zeros((n, N_DEF, N_LDOF))
    H = np.zeros((n, 4, N_LDOF, N_LDOF)) if second else None
    for k, (mode, w) in enumerate(zip(HOLONOMIC[:3], (a, el, u))):
        e[:, mode] = (w.val * d).sum(axis=1) - ref.e0[:, k]
        D[:, mode, 0:3] = -w.val
        D[:, mode, 7:10] = w.val
        D[:, mode, 3:7] = np.einsum("ni,nij->nj", d, w.g)
        if second:
            H[:, k, 3:7, 3:7] = np.einsum("ni,nijk->njk", d, w.h)
            H[:, k, 7:10, 3:7] = w.g
            H[:, k, 0:3, 3:7] = -w.g
            H[:, k, 3:7, 7:10] = w.g.transpose(0, 2, 1)
            H[:, k, 3:7, 0:3] = -w.g.transpose(0, 2, 1)
    e[:, 5] = ((x[:, 7:10] - ref.xq0) * ref.n).sum(axis=1)           # e6, linear
    D[:, 5, 7:10] = ref.n
    return e, D, H, a.val


def wheel_state(x: np.ndarray, ref: WheelReference) -> WheelState:
    """Deformations e (n, 6), their exact Jacobian D (n, 6, 10) (zero rows for the slips 4
    and 5, which are no functions of x) and the Hessians of the holonomic modes (formed
    when first used).

    Modes 1-3 are ``w . d`` with ``w`` = a, e_l, u functions of lambda alone and d linear
    in x_p, x_q: the jet runs in the 4 Euler parameters only (a tenth of the work of one
    in all 10 coordinates), and the d parts are assembled from it."""
    x = np.array(x, dtype=float)
    e, D, a = _closed_state(x, ref)
    return WheelState(e, D, a, ref.n, x, ref)


def jet_state(x: np.ndarray, ref: WheelReference):
    """``(e, D)`` of :func:`wheel_state` through the first-order jet (its test oracle)."""
    return _wheel_jets(np.asarray(x, float), ref, False)[:2]


def wheel_weighted_hessian(st: WheelState, w: np.ndarray) -> np.ndarray:
    """``sum_k w_k d^2 e_k / dx^2`` (n, 10, 10) over the holonomic modes (the weights of the
    slips 4 and 5 are ignored: they are no functions of x)."""
    return np.einsum("nk,nkij->nij", w[:, list(HOLONOMIC)], st.H)


def _slip_jet(x: np.ndarray, v: np.ndarray, ref: WheelReference, second: bool) -> Jet:
    """The slips (s4, s5) as a jet in the 20 variables (x, v)."""
    z = np.concatenate([x, v], axis=1)
    m = 2 * N_LDOF
    f = _frame(z, ref, m, second)
    lam = Jet.variables(z, 3, 4, m, second)
    rate = Jet.variables(z, 13, 4, m, second)
    l0, lv = lam.take([0]), lam.take([1, 2, 3])
    r0, rv = rate.take([0]), rate.take([1, 2, 3])
    omega = (l0 * rv - lv * r0 + cross(lv, rv)).times(2.0)         # 2 Lambda(l) dl/dt
    vp = Jet.variables(z, 10, 3, m, second) + cross(omega, f.d)
    et = cross(Jet.constant(ref.n, m, second), f.el)
    s4, s5 = dot(f.el, vp), dot(et, vp)
    return Jet(np.concatenate([s4.val, s5.val], axis=1), np.concatenate([s4.g, s5.g], axis=1),
               None if not second else np.concatenate([s4.h, s5.h], axis=1))


def jet_slip(x: np.ndarray, ref: WheelReference) -> np.ndarray:
    """S (n, 2, 10) through the jet (the test oracle of :func:`wheel_slip`)."""
    return _slip_jet(x, np.zeros_like(x), ref, False).g[:, :, N_LDOF:]


def jet_slip_dx(x: np.ndarray, v: np.ndarray, ref: WheelReference) -> np.ndarray:
    """``d(S(x) v)/dx`` through the jet (the test oracle of :func:`wheel_slip_dx`)."""
    return _slip_jet(x, v, ref, False).g[:, :, :N_LDOF]


def jet_slip_force_dx(x: np.ndarray, nu: np.ndarray, ref: WheelReference) -> np.ndarray:
    """``d(S(x)^T nu)/dx`` through the jet (the test oracle of
    :func:`wheel_slip_force_dx`)."""
    h = _slip_jet(x, np.zeros_like(x), ref, True).h                 # (n, 2, 20, 20)
    return np.einsum("nk,nkji->nji", nu, h[:, :, N_LDOF:, :N_LDOF])


# The closed forms (derived in docs/rolling.md, "Slip kernels in closed form"): with
# A = da/dlambda (3, 4), b = a x n, P = (I - e_l e_l^T)/|b|,
#   de_l/dlambda = -P [n~] A,  de_t/dlambda = [n~] de_l/dlambda,
#   omega = 2 Lambda(lambda) dlambda,  d(omega)/dlambda = 2 [r, -r0 I - [r~]] (r = dlambda),
#   s_k = e_k . v_P = e_k . dx_p + (d x e_k) . omega.
def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` over the last axis (broadcast), without np.cross's overhead on the small
    arrays of a few wheels."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


class _SlipFrame(NamedTuple):
    E: np.ndarray          # (n, 2, 3) the rows e_l, e_t
    dE: np.ndarray         # (n, 2, 3, 4) their derivatives by lambda
    L: np.ndarray          # (n, 3, 4) Lambda(lambda)
    d: np.ndarray          # (n, 3) x_q - x_p


_FRAMES: list = []       # [(x, a0, n, frame)]: the last few frames, newest last


def _slip_frame(x: np.ndarray, ref: WheelReference, derivatives: bool) -> _SlipFrame:
    """The slip frame at x (always with its derivatives), one of the last few again where
    x and the wheels are the same (a Newton iteration forms S, d(S v)/dx and d(S^T nu)/dx
    at one state, a step's slip integral S v at its two ends): the same numbers."""
    for last in reversed(_FRAMES):
        if (last[0].shape == x.shape and np.array_equal(last[0], x)
                and last[1].shape == ref.a0.shape and np.array_equal(last[1], ref.a0)
                and np.array_equal(last[2], ref.n)):
            return last[3]
    frame = _new_slip_frame(x, ref, True)
    _FRAMES[:] = _FRAMES[-2:] + [(x.copy(), ref.a0.copy(), ref.n.copy(), frame)]
    return frame


def _new_slip_frame(x: np.ndarray, ref: WheelReference, derivatives: bool) -> _SlipFrame:
    lam = x[:, 3:7]
    a = rotate_plain(lam, ref.a0)
    nvec = ref.n
    b = _cross(a, nvec)
    nb = np.linalg.norm(b, axis=1)
    el = b / nb[:, None]
    et = _cross(nvec, el)
    E = np.stack([el, et], axis=1)
    dE = None
    if derivatives:
        A = vector_jacobians(lam, ref.a0[:, None, :])[:, 0]           # (n, 3, 4)
        db = -skew(nvec) @ A                                          # d(a x n)/dlambda
        P = (np.eye(3) - el[:, :, None] * el[:, None, :]) / nb[:, None, None]
        del_ = P @ db
        dE = np.stack([del_, skew(nvec) @ del_], axis=1)
    return _SlipFrame(E, dE, lambda_matrix(lam), x[:, 7:10] - x[:, 0:3])


def wheel_slip(x: np.ndarray, ref: WheelReference) -> np.ndarray:
    """S (n, 2, 10) with ``(s4, s5) = S(x) v``: ``[e_k, 2 Lambda^T (d x e_k), 0]``."""
    f = _slip_frame(x, ref, False)
    out = np.zeros((x.shape[0], 2, N_LDOF))
    out[:, :, 0:3] = f.E
    out[:, :, 3:7] = 2.0 * np.einsum("nkj,nji->nki", _cross(f.d[:, None, :], f.E), f.L)
    return out


def _omega(x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The angular velocity ``2 Lambda(lambda) dlambda/dt`` (n, 3)."""
    q, r = x[:, 3:7], v[:, 3:7]
    return 2.0 * (q[:, :1] * r[:, 1:] - q[:, 1:] * r[:, :1] + _cross(q[:, 1:], r[:, 1:]))


def wheel_slips(x: np.ndarray, v: np.ndarray, ref: WheelReference) -> np.ndarray:
    """The slip velocities ``(s4, s5) = S(x) v`` (n, 2), m/s, computed directly."""
    f = _slip_frame(x, ref, False)
    vp = v[:, 0:3] + _cross(_omega(x, v), f.d)
    return np.einsum("nkj,nj->nk", f.E, vp)


def wheel_slip_dx(x: np.ndarray, v: np.ndarray, ref: WheelReference) -> np.ndarray:
    """``d(S(x) v)/dx`` (n, 2, 10) at fixed v."""
    f = _slip_frame(x, ref, True)
    omega = _omega(x, v)
    vp = v[:, 0:3] + _cross(omega, f.d)
    r = v[:, 3:7]
    dw = np.zeros((x.shape[0], 3, 4))                                 # d(omega)/dlambda
    dw[:, :, 0] = 2.0 * r[:, 1:]
    dw[:, :, 1:] = -2.0 * (r[:, :1, None] * np.eye(3) + skew(r[:, 1:]))
    out = np.zeros((x.shape[0], 2, N_LDOF))
    eo = _cross(f.E, omega[:, None, :])                             # e_k x omega
    out[:, :, 0:3] = -eo
    out[:, :, 7:10] = eo
    out[:, :, 3:7] = (np.einsum("nkji,nj->nki", f.dE, vp)
                      + np.einsum("nkj,nji->nki", _cross(f.d[:, None, :], f.E), dw))
    return out


def wheel_slip_force_dx(x: np.ndarray, nu: np.ndarray, ref: WheelReference) -> np.ndarray:
    """``d(S(x)^T nu)/dx`` (n, 10, 10) for the multipliers nu (n, 2): rows the 10 generalized
    forces, columns the 10 coordinates. With ``f = nu4 e_l + nu5 e_t`` and ``c = d x f``,
    ``S^T nu = [f, 2 Lambda^T c, 0]``."""
    fr = _slip_frame(x, ref, True)
    n = x.shape[0]
    f = np.einsum("nk,nkj->nj", nu, fr.E)
    df = np.einsum("nk,nkji->nji", nu, fr.dE)                         # (n, 3, 4)
    c = _cross(fr.d, f)
    LT = fr.L.transpose(0, 2, 1)                                      # (n, 4, 3)
    out = np.zeros((n, N_LDOF, N_LDOF))
    out[:, 0:3, 3:7] = df
    ltf = 2.0 * LT @ skew(f)                                          # d(2 L^T c)/d(x_p)
    out[:, 3:7, 0:3] = ltf
    out[:, 3:7, 7:10] = -ltf
    dlc = np.zeros((n, 4, 4))                                         # d(Lambda^T c)/dlambda
    dlc[:, 0, 1:] = -c
    dlc[:, 1:, 0] = c
    dlc[:, 1:, 1:] = skew(c)
    out[:, 3:7, 3:7] = 2.0 * (dlc + LT @ skew(fr.d) @ df)
    return out


def wheel_check(st: WheelState, ref: WheelReference):
    """The first element whose axle has turned vertical (the disc lies flat): ``(row,
    message)``, or None."""
    a = st.a / np.linalg.norm(st.a, axis=1, keepdims=True)
    flat = np.linalg.norm(np.cross(a, st.n), axis=1) <= VERTICAL_TOL
    if flat.any():
        return int(np.flatnonzero(flat)[0]), ("the wheel's axle has turned vertical (the disc "
                                              "lies flat on the ground)")
    return None


class Wheel(ElementKind):
    """``WHEEL e p r q ax ay az``: a thin rigid disc rolling on the ground (kernels above)."""

    keyword = "WHEEL"
    slots = ("pos", "rot", "pos")
    node_roles = ("p", "r", "q")
    modes = ("contact point off the wheel plane", "contact point off the lowest rim point "
             "(fore-aft)", "contact point off the rim", "longitudinal slip", "lateral slip",
             "contact point off the ground")
    mode_units = ("m",) * 6
    rate_units = ("m/s",) * 6
    stress_units = ("N",) * 6
    deformation_meaning = ("WHEEL deformations: 1-3 and 6 the contact point's place (m), 4-5 "
                           "the accumulated longitudinal and lateral slip (m)")
    stress_meaning = ("WHEEL contact forces: 6 the normal force (compression positive), 4-5 "
                      "the tangential ground forces along the heading and lateral directions, "
                      "1-3 the forces through the contact node")
    length_modes = (True,) * 6
    estiff = None
    em = None
    mode_stiffness = ()
    no_stiffness_why = "tyre compliance"
    vector = "axle"
    vector_required = True
    summary = "thin rigid wheel rolling on the ground (hub p, wheel r, contact point q)"
    node_fields = (POS_P, ROT_AT_P, POS_Q)
    vector_fields = (("x component of the axle direction", "ax"),
                     ("y component of the axle direction", "ay"),
                     ("z component of the axle direction", "az"))
    velocity_modes = VELOCITY
    # stored: the ground's force on the wheel along e_l, e_t (4, 5) and n (6, compression
    # positive); the multipliers are the wheel's force on the ground (docs/rolling.md)
    stress_sign = (1.0, 1.0, 1.0, -1.0, -1.0, -1.0)
    reference_type = WheelReference

    def reference(self, x0, vector):
        ref = wheel_reference(x0[0], x0[2], vector)
        return ref, np.repeat(ref.e0[:, 2:3], N_DEF, axis=1)

    def reference_problems(self, x0, vector):
        return wheel_reference_problems(np.asarray(x0[0], float), np.asarray(x0[2], float),
                                        np.asarray(vector, float))

    def state(self, x, ref, variant, prev):
        return wheel_state(x, ref)

    def hessian(self, st, w):
        return wheel_weighted_hessian(st, w)

    def stiffness(self, props, ref):
        return np.zeros((props.shape[0], N_DEF, N_DEF))

    def check(self, st, ref):
        return wheel_check(st, ref)

    @staticmethod
    def slip(x, ref):
        return wheel_slip(x, ref)

    @staticmethod
    def slip_dx(x, v, ref):
        return wheel_slip_dx(x, v, ref)

    @staticmethod
    def slip_force_dx(x, nu, ref):
        return wheel_slip_force_dx(x, nu, ref)

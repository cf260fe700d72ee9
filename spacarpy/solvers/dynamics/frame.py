"""The rotating frame of a generalized-alpha step: the change of variables that lets the
transient solver (:mod:`spacarpy.solvers.dynamics.transient`) represent a rigid rotation exactly.

Generalized-alpha updates the coordinates linearly, ``x1 = x + h v + h^2 (...)``. For nodes
that turn fast about an axis (a spinning beam) that update moves them along the chord of
their circle, and the stiff axial modes of the beams between them take the difference as
strain: with little numerical damping (``rho_inf`` near 1) the discrete solution then
turns unstable after some revolutions (the nonlinear instability of Newmark-type schemes
on stiff rotating systems; docs/transient.md shows it on a mass on a stiff spring). In
polar coordinates the same scheme is stable, because a rotation is a constant-rate change
of one coordinate there.

Each step is therefore integrated in a frame that coincides with the global one at the
start of the step and moves rigidly at the best rigid fit of the model's nodal velocities at the
start of the step: ``x = c + s u + T(s) (y - c)`` with
``T(s) = exp(s W)``, ``W`` the rate operator (``omega x`` on a position, ``1/2 (0, omega) q``
on Euler parameters, both skew). The step's unknowns are the rotating-frame coordinates
``y``; the equations of motion are unchanged (the residual is evaluated in ``x``), so the
change of variables is exact, and a rigid rotation at ``omega`` costs the linear update
nothing. The frame's origin c and velocity u: for a model whose position nodes all turn (a
free-floating body), the nodes' centroid and its velocity; for a model with held nodes
(fixed or driven), the fitted motion's instantaneous screw axis (rotation about it,
sliding along it), so that a model turning about a pinned axis, such as a beam on a
driven hub, has its held nodes where the frame has them. Newton's correction
``d = T dy`` then updates

    x += d,    v += (gamma' + W) d,    a += (beta' + 2 gamma' W + W^2) d,

and the iteration matrix gets ``M (2 gamma' W + W^2) + alpha_R M W`` (alpha_R the Rayleigh
mass damping). Only nodes whose coordinates are all free turn with the frame (a planar
model: x, y and lambda0, lambda3 about z), so prescribed and fixed coordinates keep their
values; the others keep ``T = I``, which is also a valid change of variables.

This is the generalized-alpha method of Arnold & Brüls (2007) written in a moving frame,
the simplest member of the Lie-group family (Brüls & Cardona 2010) that covers the case
here: one rotation shared by the model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from spacarpy.linalg import cross3

#: Axes about which the nodes' second moment is below this fraction of the largest are
#: left out of the fitted rate (their radius of gyration below 1 % of the largest).
SPREAD = 1e-4

#: A model without a prescribed rotation that is at rest at t = 0 has its steps taken in the
#: turning frame once it has turned by this net angle (rad) since the start: the length of
#: the time integral of its fitted rate, ``|sum h omega|`` over the accepted steps
#: (:meth:`~spacarpy.solvers.dynamics.transient.TransientProblem.frame_rate`), at a rate
#: that rises smoothly from zero there to the fitted one at FRAME_FULL_ANGLE. An angle, not
#: a turn per step: the scheme at a given time is then the same for every step size, which
#: keeps the generalized-alpha method's second order in h. More than a deflection: a
#: loaded or vibrating structure (the bench's suddenly loaded cantilever turns by 0.2 rad,
#: the shipped cantilevers by less) keeps the global frame and its cheaper symmetric Newton
#: matrix.
FRAME_ON_ANGLE = 1.0
FRAME_FULL_ANGLE = 2.0


def _eigenvalues(a: list) -> tuple:
    """The eigenvalues of the symmetric 3 x 3 ``a`` (nested lists) in closed form (Smith
    1961), on Python floats: (largest, middle, least)."""
    (a00, a01, a02), (_, a11, a12), (_, _, a22) = a
    q = (a00 + a11 + a22) / 3.0
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    p2 = (a00 - q) ** 2 + (a11 - q) ** 2 + (a22 - q) ** 2 + 2.0 * p1
    if p2 <= 0.0:
        lam = (q, q, q)
    else:
        pp = math.sqrt(p2 / 6.0)
        b00, b11, b22 = (a00 - q) / pp, (a11 - q) / pp, (a22 - q) / pp
        b01, b02, b12 = a01 / pp, a02 / pp, a12 / pp
        det = (b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02)
               + b02 * (b01 * b12 - b11 * b02))
        phi = math.acos(min(max(0.5 * det, -1.0), 1.0)) / 3.0
        top = q + 2.0 * pp * math.cos(phi)
        low = q + 2.0 * pp * math.cos(phi + 2.0 * math.pi / 3.0)
        lam = (top, 3.0 * q - top - low, low)
    return lam


def _rate_all_kept(a: list, tiny: float, h: tuple):
    """The fitted rate ``a^-1 h`` (by the adjugate, on Python floats) where the fit keeps
    all three axes of the second moment ``a``, each eigenvalue above 1.01 times its
    threshold (``SPREAD`` times the largest, and ``tiny``); None otherwise (the fit's
    ``eigh`` decides). What a step of a model whose frame is usable costs: the rate is
    needed at every step to add up the angle turned (the bench's deflected cantilever: all
    three axes kept)."""
    lam = _eigenvalues(a)
    thr = max(SPREAD * max(lam), tiny)
    if min(lam) <= 1.01 * thr:
        return None
    (a00, a01, a02), (_, a11, a12), (_, _, a22) = a
    c00, c01, c02 = a11 * a22 - a12 * a12, a02 * a12 - a01 * a22, a01 * a12 - a02 * a11
    c11, c12, c22 = a00 * a22 - a02 * a02, a01 * a02 - a00 * a12, a00 * a11 - a01 * a01
    det_a = a00 * c00 + a01 * c01 + a02 * c02
    h0, h1, h2 = h
    return ((c00 * h0 + c01 * h1 + c02 * h2) / det_a, (c01 * h0 + c11 * h1 + c12 * h2) / det_a,
            (c02 * h0 + c12 * h1 + c22 * h2) / det_a)


def _surely_below(a: list, tiny: float, h: tuple, du2: float, max_rate: float) -> bool:
    """Whether the rate the fit gives for the second moment ``a`` (nested lists, 3 x 3,
    positive semi-definite), the moment ``h`` of the relative velocities and their squared
    norm ``du2`` is at most ``max_rate`` for certain, on Python floats.

    The eigenvalues come from their closed form (Smith 1961). Where the fit keeps all three
    (each above ``SPREAD`` times the largest and above ``tiny``) the rate is ``I^-1 H``,
    here by the adjugate (its round-off at most about ``1e4 eps`` relative, the kept
    eigenvalues being at least 1e-4 of the largest); where it leaves some out, the bound
    ``|omega|^2 <= du2 / lambda_min`` of :meth:`RotatingFrame.fit_above` serves. False
    (undecided: the fit decides) where an eigenvalue lies within 1 % of the threshold
    (the closed form's round-off, at most about 1e-7 of the largest eigenvalue for a
    double one, must not decide which are kept), or near ``max_rate`` itself."""
    (a00, a01, a02), (_, a11, a12), (_, _, a22) = a
    lam = _eigenvalues(a)
    thr = max(SPREAD * max(lam), tiny)
    if any(0.99 * thr < e < 1.01 * thr for e in lam):
        return False
    kept = [e for e in lam if e > thr]
    if not kept:
        return True                                 # coincident nodes: no rate at all
    limit = max_rate * (1.0 - 1e-6)
    if len(kept) < 3:
        return du2 <= limit * limit * min(kept)
    c00, c01, c02 = a11 * a22 - a12 * a12, a02 * a12 - a01 * a22, a01 * a12 - a02 * a11
    c11, c12, c22 = a00 * a22 - a02 * a02, a01 * a02 - a00 * a12, a00 * a11 - a01 * a01
    det_a = a00 * c00 + a01 * c01 + a02 * c02
    h0, h1, h2 = h
    w0 = c00 * h0 + c01 * h1 + c02 * h2
    w1 = c01 * h0 + c11 * h1 + c12 * h2
    w2 = c02 * h0 + c12 * h1 + c22 * h2
    return w0 * w0 + w1 * w1 + w2 * w2 <= (limit * det_a) ** 2


def _quat_rate(w: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``1/2 (0, w) q`` for rows q of Euler parameters (lambda0, lambda1..3)."""
    out = np.empty_like(q)
    out[:, 0] = -0.5 * (q[:, 1:] @ w)
    out[:, 1:] = 0.5 * (q[:, :1] * w + cross3(w, q[:, 1:]))
    return out


class Motion(NamedTuple):
    """The rigid motion a step's frame follows: rate (3,), centre (3,) and its velocity."""

    omega: np.ndarray
    centre: np.ndarray
    velocity: np.ndarray


@dataclass
class RotatingFrame:
    """The nodes that turn with the frame and the fit of its rate.

    ``pos`` (n_p, 3) and ``rot`` (n_r, 4) are the coordinate indices of the turning
    position and orientation nodes; ``planar``: the rate is about z only; ``floating``:
    every position node turns (no held nodes)."""

    pos: np.ndarray
    rot: np.ndarray
    planar: bool
    n_coord: int
    floating: bool = True

    @classmethod
    def of(cls, num, free: np.ndarray, planar: bool):
        pos_all, rot_all = num.pos_idx, num.euler_coords
        if planar:                     # x, y (z is fixed) and lambda0, lambda3
            pos_ok = free[pos_all[:, 0]] & free[pos_all[:, 1]]
            rot_ok = free[rot_all[:, 0]] & free[rot_all[:, 3]]
        else:
            pos_ok = free[pos_all].all(axis=1)
            rot_ok = free[rot_all].all(axis=1)
        pos, rot = pos_all[pos_ok], rot_all[rot_ok]
        return cls(pos=pos, rot=rot, planar=planar, n_coord=num.n_coord,
                   floating=bool(pos_ok.all()))

    @property
    def usable(self) -> bool:
        """At least two turning position nodes: a rate can be fitted."""
        return len(self.pos) >= 2

    def rate(self, x: np.ndarray, v: np.ndarray) -> Motion:
        """The rigid motion that fits the turning nodes' velocities best (least squares:
        the velocity ``u`` of their centroid ``c`` and the rate ``omega`` about it,
        ``I omega = H`` with the nodes' second moment I); a straight line of nodes has no
        rate about its own axis (the least-norm solution), nodes that all coincide none at
        all. A kinematic fit, every node counting alike: nodal masses need not be where the
        mass is (a rigid rod's sits on one end node and its orientation)."""
        return self.motion(*self.fit(x, v))

    def fit(self, x: np.ndarray, v: np.ndarray):
        """``(omega, c, u)`` of :meth:`rate` (the rate about the centroid, the centroid and
        its velocity), without the screw axis: what a step needs to decide whether its
        frame turns at all (:meth:`motion` completes it). The 3 x 3 algebra is done on
        Python floats: at every step of a model that does not turn fast this is all the
        frame costs, and numpy's fixed cost per call was most of it."""
        return self._fit(x, v, None)

    def _fit(self, x: np.ndarray, v: np.ndarray, max_rate: float | None):
        """:meth:`fit`; with ``max_rate``, None where the fitted rate is surely at most that
        (:meth:`fit_above`)."""
        p, vel = x[self.pos], v[self.pos]
        n = len(p)
        c, u = p.sum(axis=0) / n, vel.sum(axis=0) / n
        r = p - c
        rd = np.concatenate((r, vel - u), axis=1)
        # r^T r, r^T du and du^T du (du = vel - u) in one product
        (a00, a01, a02, b00, b01, b02), (_, a11, a12, b10, b11, b12), \
            (_, _, a22, b20, b21, b22), (*_, d00, _, _), (*_, d11, _), (*_, d22) = \
            (rd.T @ rd).tolist()
        # H = sum of r x du, from the skew part of r^T du
        h0, h1, h2 = b12 - b21, b20 - b02, b01 - b10
        # the nodes' spread against their distance from the origin: below round-off
        # they coincide and show no rotation
        tiny = 1e-20 * (n * float(np.einsum("ij,ij->i", p, p).max()) + 1e-300)
        if self.planar:
            izz = a00 + a11
            omega = np.array([0.0, 0.0, h2 / izz if izz > tiny else 0.0])
            return omega, c, u
        tr = a00 + a11 + a22
        inertia = [[tr - a00, -a01, -a02], [-a01, tr - a11, -a12], [-a02, -a12, tr - a22]]
        if max_rate is not None and _surely_below(inertia, tiny, (h0, h1, h2),
                                                  d00 + d11 + d22, max_rate):
            return None
        w = _rate_all_kept(inertia, tiny, (h0, h1, h2))
        if w is not None:
            return np.array(w), c, u
        lam, vec = np.linalg.eigh(np.array(inertia))
        # a rate about an axis the nodes hardly spread across (a nearly straight beam's
        # own axis) is not seen by their velocities: the fit leaves it out rather
        # than divide a small moment by a small spread
        keep = lam > max(SPREAD * float(lam[-1]), tiny)
        vk = vec[:, keep]
        omega = vk @ ((np.array([h0, h1, h2]) @ vk) / lam[keep])
        return omega, c, u

    def fit_above(self, x: np.ndarray, v: np.ndarray, max_rate: float):
        """:meth:`fit`, or None where the fitted rate is at most ``max_rate`` for certain.

        The test needs the second moment's eigenvalues only, in closed form
        (:func:`_surely_below`): where the fit keeps every axis the rate is ``I^-1 H``;
        where it leaves some out it is the projection of the relative velocities ``du``
        onto the rigid rotations about the kept axes (eigenvectors e_i of I, the fields
        ``e_i x r`` orthogonal with squared norms ``lambda_i``), so ``|omega|^2 <= sum
        |du|^2 / lambda_min`` (lambda_min the least kept one). A vibrating structure then
        needs no eigendecomposition at its steps; where the test is undecided the fit
        decides."""
        return self._fit(x, v, max_rate)

    def turns(self, x: np.ndarray, v: np.ndarray, omega: np.ndarray, c: np.ndarray) -> bool:
        """Whether the fitted rotation ``omega`` about ``c`` (:meth:`fit` of x, v) moves the
        turning nodes at all: its velocities ``omega x r`` above 1e-6 of the nodes' own
        (a model at rest, or one that only translates, shows a rate of round-off at most)."""
        r = x[self.pos] - c
        spin = cross3(omega, r)
        vel = v[self.pos]
        return float(np.sum(spin * spin)) > 1e-12 * float(np.sum(vel * vel)) > 0.0

    def motion(self, omega: np.ndarray, c: np.ndarray, u: np.ndarray) -> Motion:
        """The :class:`Motion` of a fitted ``(omega, c, u)`` (:meth:`fit`): for a model with
        held nodes (fixed or driven), which do not turn with the frame, the turn is about
        the fitted motion's instantaneous screw axis (its point nearest to c, sliding along
        it), so that a model pinned on that axis keeps its held nodes where the frame has
        them."""
        w2 = float(omega @ omega)
        if self.floating or w2 == 0.0:
            return Motion(omega, c, u)
        return Motion(omega, c + cross3(omega, u) / w2, (u @ omega) / w2 * omega)

    def _shift(self, z: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """z with ``offset`` (3,) subtracted from the turning positions."""
        out = z.copy()
        if self.pos.size:
            out[self.pos] -= offset
        return out

    # ------------------------------------------------------------------ the operators
    def apply_w(self, omega: np.ndarray, z: np.ndarray) -> np.ndarray:
        """``W z`` over all coordinates (zero on the coordinates that do not turn)."""
        out = np.zeros_like(z)
        if self.pos.size:
            out[self.pos] = cross3(omega, z[self.pos])
        if self.rot.size:
            out[self.rot] = _quat_rate(omega, z[self.rot])
        return out

    def apply_t(self, omega: np.ndarray, s: float, z: np.ndarray, transpose=False) -> np.ndarray:
        """``T(s) z`` (or ``T(s)^T z``) over all coordinates: the rotation by ``s omega``
        of the turning positions, the left product with its Euler parameters of the
        turning orientations."""
        out = z.copy()
        angle = s * float(np.linalg.norm(omega))
        if angle == 0.0:
            return out
        if transpose:
            angle = -angle
        axis = omega / np.linalg.norm(omega)
        if self.pos.size:
            p = z[self.pos]
            c, sn = np.cos(angle), np.sin(angle)
            out[self.pos] = (c * p + sn * cross3(axis, p)
                             + (1 - c) * (p @ axis)[:, None] * axis)
        if self.rot.size:
            q = z[self.rot]
            r0, rv = np.cos(angle / 2), np.sin(angle / 2) * axis
            res = np.empty_like(q)
            res[:, 0] = r0 * q[:, 0] - q[:, 1:] @ rv
            res[:, 1:] = r0 * q[:, 1:] + q[:, :1] * rv + cross3(rv, q[:, 1:])
            out[self.rot] = res
        return out

    def matrix(self, omega: np.ndarray, free: np.ndarray) -> sp.csc_matrix:
        """``W`` as a sparse matrix over the free coordinates."""
        n = self.n_coord
        rows, cols, vals = [], [], []
        for idx, size, op in ((self.pos, 3, cross3), (self.rot, 4, _quat_rate)):
            if not idx.size:
                continue
            for j in range(size):                       # column j of the node block
                e = np.zeros((len(idx), size))
                e[:, j] = 1.0
                col = op(omega, e)                      # (n_nodes, size)
                for i in range(size):
                    nz = col[:, i] != 0.0
                    rows.append(idx[nz, i])
                    cols.append(idx[nz, j])
                    vals.append(col[nz, i])
        if not rows:
            return sp.csc_matrix((int(free.sum()),) * 2)
        W = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(n, n))
        return W[free][:, free].tocsc()

    # ------------------------------------------------------------------ the step
    # With the motion (omega, c, u) of the step's start: positions
    # x = c + s u + T(s) (y - c), Euler parameters q = T(s) q_y.
    def to_frame(self, motion: Motion, x, v, a, a_tilde):
        """Rates of the frame's coordinates at the start of a step (where y = x):
        ``(y', y'', y~)``, y~ the integrator's acceleration variable, converted as an
        acceleration."""
        om = motion.omega
        rel = self._shift(x, motion.centre)
        yd = self._shift(v, motion.velocity) - self.apply_w(om, rel)
        centre = 2 * self.apply_w(om, yd) + self.apply_w(om, self.apply_w(om, rel))
        return yd, a - centre, a_tilde - centre

    def from_frame(self, motion: Motion, h, y, yd, ydd):
        """``(x, v, a)`` at the end of a step of length h from the frame's coordinates."""
        om = motion.omega
        rel = self._shift(y, motion.centre)
        w_y = self.apply_w(om, rel)
        x = self._shift(self.apply_t(om, h, rel), -(motion.centre + h * motion.velocity))
        v = self._shift(self.apply_t(om, h, yd + w_y), -motion.velocity)
        a = self.apply_t(om, h, ydd + 2 * self.apply_w(om, yd) + self.apply_w(om, w_y))
        return x, v, a

    def back(self, motion: Motion, h, x, v, a):
        """The inverse of :meth:`from_frame`: ``(y, y', y'')``."""
        om = motion.omega
        rel = self.apply_t(om, h, self._shift(x, motion.centre + h * motion.velocity),
                           transpose=True)
        yd = (self.apply_t(om, h, self._shift(v, motion.velocity), transpose=True)
              - self.apply_w(om, rel))
        ydd = (self.apply_t(om, h, a, transpose=True) - 2 * self.apply_w(om, yd)
               - self.apply_w(om, self.apply_w(om, rel)))
        return self._shift(rel, -motion.centre), yd, ydd


__all__ = ["FRAME_FULL_ANGLE", "FRAME_ON_ANGLE", "Motion", "RotatingFrame"]

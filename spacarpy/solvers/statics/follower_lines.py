"""Follower line loads (QEL/DELQEL): force per current length in a beam's current axes,
consistently lumped at its nodes, with the exact load stiffness.

A line ``QEL e q1 q2 q3 [q1 q2 q3 at q]`` gives, per current length, ``q = qx t + qy e_y +
qz e_z`` with ``t`` the deformed chord ``d = x_q - x_p`` over its length ``L``, ``e_y`` the
element's current local y-axis and ``e_z = t x e_y``; linear from the end p to the end q.
It is lumped as the cubic beam lumps a line load (:mod:`spacarpy.elements.line_load`: the
axial part with the linear functions, the transverse part with the cubic ones), written with
the means ``qm = (q_p + q_q) / 2`` and the differences ``dq = q_q - q_p`` so that a uniform
load takes the same floating-point operations as before the linear form existed:

- forces: ``f_p = ax_p d + L (by_p e_y + bz_p e_z)``, ``ax_p = (qxm - dqx/6) / 2``,
  ``by_p = (qym - dqy/5) / 2`` (q end: ``+``);
- moments: ``M_p = L^2 (cy_p e_z - cz_p e_y)``, ``cy_p = (qym - dqy/10) / 12``;
  ``M_q = -L^2 (cy_q e_z - cz_q e_y)``, ``cy_q = (qym + dqy/10) / 12``; they act on the
  Euler parameters of the orientation nodes r (at p) and s (at q) as ``2 B(M) q``.

The current y-axis (docs/follower.md): a planar beam's is ``z x t``; a spatial beam's
(BEAM, BEAMW) is the mean of its two nodal y-axes ``R(q_r) n_y`` and ``R(q_s) n_y`` (``n_y``
the element's initial y-axis, :func:`spacarpy.elements.beam.reference_triads`) projected
normal to the chord and normalized: invariant under a rigid rotation, smooth, symmetric in
the two ends, and the initial y-axis in the reference configuration.

Each batch is a :class:`~spacarpy.solvers.statics.follower.LoadPart` with rows = cols =
``[x_p (3), x_q (3), q_r (4), q_s (4)]`` (14) and amplitudes ``[q_p (3), q_q (3)]`` (6).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spacarpy.elements.beam import reference_triads
from spacarpy.elements.registry import kind_of
from spacarpy.rotation import lambda_matrix, moment_matrix, rotate, skew, vector_jacobians
from spacarpy.solvers.statics.follower import LoadPart, _add

__all__ = ["FollowerLineBeam", "FollowerLinePlanar", "line_followers"]

#: ``[z~]``: ``z x d`` for the planar element's local y-axis (times its length).
_ZX = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
#: ``B(z)``: the generalized force of a unit moment about z on Euler parameters is 2 B q.
_BZ = moment_matrix(np.array([0.0, 0.0, 1.0]))


def _weights(amp):
    """The lumping weights of amplitudes (n, 6) ``[q_p, q_q]`` (element axes): the force
    factors ``(n, 2, 3)`` (end p, end q; x axial, y and z transverse) and the moment
    factors times 12, ``qm -+ dq/10`` ``(n, 2, 3)`` (the x entry unused; a uniform load's
    ``q |d|^2 / 12`` keeps the operations of the planar element before the linear form)."""
    qm = 0.5 * (amp[:, :3] + amp[:, 3:])
    dq = amp[:, 3:] - amp[:, :3]
    div = np.array([6.0, 5.0, 5.0])
    force = 0.5 * np.stack([qm - dq / div, qm + dq / div], axis=1)
    moment = np.stack([qm - dq / 10.0, qm + dq / 10.0], axis=1)
    return force, moment


class FollowerLinePlanar(LoadPart):
    """QEL/DELQEL on PLBEAMs: ``(qx, qy)`` per current length along the chord ``d = x_q -
    x_p`` and along ``z x d / |d|`` (module docstring): each end ``ax d + by z x d``, end
    moments ``+-c |d|^2`` about z at the orientation nodes r (at p) and s (at q)."""

    def _parts(self, x, amp):
        xe = x[self.cols]
        d = xe[:, 3:6] - xe[:, 0:3]
        fw, mw = _weights(amp)
        dd = np.einsum("na,na->n", d, d)
        m_r = mw[:, 0, 1] * dd / 12.0
        m_s = mw[:, 1, 1] * dd / 12.0
        return d, xe[:, 6:10], xe[:, 10:14], fw, mw, m_r, m_s

    def force(self, x, amp, n_coord):
        d, qr, qs, fw, _, m_r, m_s = self._parts(x, amp)
        zd = d @ _ZX.T
        f_p = fw[:, 0, :1] * d + fw[:, 0, 1:2] * zd
        f_q = fw[:, 1, :1] * d + fw[:, 1, 1:2] * zd
        g_r = 2.0 * m_r[:, None] * (qr @ _BZ.T)
        g_s = -2.0 * m_s[:, None] * (qs @ _BZ.T)
        return _add(n_coord, self.rows, np.concatenate([f_p, f_q, g_r, g_s], axis=1))

    def stiffness(self, x, amp):
        d, qr, qs, fw, mw, m_r, m_s = self._parts(x, amp)
        n = len(d)
        k = np.zeros((n, 14, 14))
        for end, r0 in ((0, 0), (1, 3)):
            F = fw[:, end, 0, None, None] * np.eye(3) + fw[:, end, 1, None, None] * _ZX
            k[:, r0:r0 + 3, 0:3] = -F
            k[:, r0:r0 + 3, 3:6] = F
        for rows, q, sign, c, m in ((slice(6, 10), qr, 1.0, mw[:, 0, 1], m_r),
                                    (slice(10, 14), qs, -1.0, mw[:, 1, 1], m_s)):
            dm = c[:, None] * d / 6.0                             # d m / d x_q (= -d/dx_p)
            bq = 2.0 * sign * (q @ _BZ.T)                         # (n, 4)
            k[:, rows, 0:3] = -bq[:, :, None] * dm[:, None, :]
            k[:, rows, 3:6] = bq[:, :, None] * dm[:, None, :]
            k[:, rows, rows] = 2.0 * sign * m[:, None, None] * _BZ
        return k


@dataclass
class FollowerLineBeam(LoadPart):
    """QEL/DELQEL on spatial beams (BEAM, BEAMW) in their current axes (module docstring);
    ``ny`` (n_b, 3) is each element's initial local y-axis."""

    ny: np.ndarray | None = None

    def _frame(self, x, jac: bool):
        """The chord d, its length, the axes t, e_y, e_z, the Euler parameters q_r, q_s and
        (``jac``) the Jacobians of L (n, 11) and of t, e_y, e_z (n, 3, 11) by
        ``y = [d, q_r, q_s]``."""
        xe = x[self.cols]
        d = xe[:, 3:6] - xe[:, 0:3]
        qr, qs = xe[:, 6:10], xe[:, 10:14]
        length = np.sqrt(np.einsum("na,na->n", d, d))
        t = d / length[:, None]
        a = 0.5 * (rotate(qr, self.ny) + rotate(qs, self.ny))
        at = np.einsum("na,na->n", a, t)
        v = a - at[:, None] * t
        nv = np.sqrt(np.einsum("na,na->n", v, v))
        ey = v / nv[:, None]
        ez = np.cross(t, ey)
        frame = (d, length, t, ey, ez, qr, qs)
        if not jac:
            return frame, None
        n = len(d)
        eye = np.broadcast_to(np.eye(3), (n, 3, 3))
        j_len = np.zeros((n, 11))
        j_len[:, :3] = t
        j_t = np.zeros((n, 3, 11))
        j_t[:, :, :3] = (eye - t[:, :, None] * t[:, None, :]) / length[:, None, None]
        j_a = np.zeros((n, 3, 11))
        j_a[:, :, 3:7] = 0.5 * vector_jacobians(qr, self.ny[:, None, :])[:, 0]
        j_a[:, :, 7:11] = 0.5 * vector_jacobians(qs, self.ny[:, None, :])[:, 0]
        proj = eye - t[:, :, None] * t[:, None, :]
        j_v = proj @ j_a - (t[:, :, None] * a[:, None, :] + at[:, None, None] * eye) @ j_t
        j_ey = (eye - ey[:, :, None] * ey[:, None, :]) @ j_v / nv[:, None, None]
        j_ez = -skew(ey) @ j_t + skew(t) @ j_ey
        return frame, (j_len, j_t, j_ey, j_ez)

    def _ends(self, frame, amp):
        """The end forces and moments (n, 3) each: f_p, f_q, M_p, M_q."""
        d, length, _, ey, ez, _, _ = frame
        fw, mw = _weights(amp)
        ley, lez = length[:, None] * ey, length[:, None] * ez
        l2 = (length * length)[:, None] / 12.0
        f = [fw[:, e, :1] * d + fw[:, e, 1:2] * ley + fw[:, e, 2:3] * lez for e in (0, 1)]
        m = [sign * l2 * (mw[:, e, 1:2] * ez - mw[:, e, 2:3] * ey)
             for e, sign in ((0, 1.0), (1, -1.0))]
        return f[0], f[1], m[0], m[1]

    def force(self, x, amp, n_coord):
        frame, _ = self._frame(x, jac=False)
        f_p, f_q, m_p, m_q = self._ends(frame, amp)
        qr, qs = frame[5], frame[6]
        g_r = 2.0 * np.einsum("nab,nb->na", moment_matrix(m_p), qr)
        g_s = 2.0 * np.einsum("nab,nb->na", moment_matrix(m_q), qs)
        return _add(n_coord, self.rows, np.concatenate([f_p, f_q, g_r, g_s], axis=1))

    def stiffness(self, x, amp):
        frame, (j_len, j_t, j_ey, j_ez) = self._frame(x, jac=True)
        d, length, _, ey, ez, qr, qs = frame
        _, _, m_p, m_q = self._ends(frame, amp)
        fw, mw = _weights(amp)
        n = len(d)
        L = length[:, None, None]
        j_d = np.zeros((n, 3, 11))
        j_d[:, :, :3] = np.eye(3)
        outer = lambda u, j: u[:, :, None] * j[:, None, :]       # noqa: E731  (u dL/dy)
        j_ley = outer(ey, j_len) + L * j_ey                      # d (L e_y) / dy
        j_lez = outer(ez, j_len) + L * j_ez
        j_l2ey = 2.0 * L * outer(ey, j_len) + L * L * j_ey       # d (L^2 e_y) / dy
        j_l2ez = 2.0 * L * outer(ez, j_len) + L * L * j_ez
        rows = []
        for e in (0, 1):
            rows.append(fw[:, e, 0, None, None] * j_d + fw[:, e, 1, None, None] * j_ley
                        + fw[:, e, 2, None, None] * j_lez)
        for e, sign, q, m, c0 in ((0, 1.0, qr, m_p, 3), (1, -1.0, qs, m_q, 7)):
            j_m = sign / 12.0 * (mw[:, e, 1, None, None] * j_l2ez
                                 - mw[:, e, 2, None, None] * j_l2ey)
            j_g = 2.0 * lambda_matrix(q).transpose(0, 2, 1) @ j_m          # (n, 4, 11)
            j_g[:, :, c0:c0 + 4] += 2.0 * moment_matrix(m)
            rows.append(j_g)
        j_y = np.concatenate(rows, axis=1)                                # (n, 14, 11)
        return np.concatenate([-j_y[:, :, :3], j_y[:, :, :3], j_y[:, :, 3:]], axis=2)


def line_followers(model, num, pos_row: dict, rot_row: dict) -> list:
    """The QEL/DELQEL lines of a model (``model.follower_line_loads``) as load parts: one
    for the planar beams, one for the spatial ones (only those the model has)."""
    lines = getattr(model, "follower_line_loads", ())
    out = []
    for keywords, planar in ((("PLBEAM",), True), (("BEAM", "BEAMW"), False)):
        found = []                       # (line, [p, r, q, s], element set, row)
        for ld in lines:
            for kw in keywords:
                es = model.elements.get(kw)
                if es is None:
                    continue
                hit = np.flatnonzero(es.ids == int(ld.element))
                if hit.size:
                    slots = kind_of(kw).slots
                    pick = [slots.index("pos"), slots.index("rot"),
                            len(slots) - 1 - slots[::-1].index("pos"),
                            len(slots) - 1 - slots[::-1].index("rot")]
                    found.append((ld, [int(v) for v in es.nodes[hit[0]][pick]], es, hit[0]))
        if not found:
            continue
        n = len(found)
        rows = np.array([np.concatenate([num.pos_idx[pos_row[p]], num.pos_idx[pos_row[q]],
                                         num.rot_idx[rot_row[r]], num.rot_idx[rot_row[s]]])
                         for _, (p, r, q, s), _, _ in found]).reshape(n, 14)
        amp = {k: np.array([(*ld.q_p, *ld.q_q) if ld.kind == k else (0.0,) * 6
                            for ld, _, _, _ in found], dtype=float).reshape(n, 6)
               for k in ("QEL", "DELQEL")}
        named = {}
        for tf in {ld.tf for ld, _, _, _ in found} - {None}:
            mine = np.array([ld.tf == tf for ld, _, _, _ in found])[:, None]
            named[tf] = np.where(mine, amp["DELQEL"], 0.0)
        common = dict(name="QEL line load", rows=rows, cols=rows, initial=amp["QEL"],
                      increment=amp["DELQEL"], named=named)
        if planar:
            out.append(FollowerLinePlanar(**common))
            continue
        x0 = np.array([[model.position_x0[pos_row[p]], model.position_x0[pos_row[q]]]
                       for _, (p, _, q, _), _, _ in found]).reshape(n, 2, 3)
        vector = np.array([es.vector[i] for _, _, es, i in found]).reshape(n, 3)
        ny = reference_triads(x0[:, 0], x0[:, 1], vector)[1]
        out.append(FollowerLineBeam(**common, ny=ny))
    return out

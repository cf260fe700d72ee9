"""The linearized equations about a steady motion with slips and kinematic coordinates (SPACAR
mode 3 with ``TIMESTEP 0 0``: the initial state only; docs/rolling.md, "Linearization about a
steady motion").

Notation of docs/rolling.md: ``q`` the dynamic coordinates (DYNE modes), ``r`` the rheonomic
ones (INPUTE modes, moving at their deck rates), ``p`` the kinematic ones (KINE, KINX), ``C``
the holonomic constraint rows (rigid modes, Euler normalizations), ``S`` the slips held at
zero. The projected equations

    R(q, q', p) = V^T (M a + h - f),     V = dx/dq' (C V = 0, S V = 0, E_r V = 0, E_q V = I),

are evaluated through the whole chain at t = 0 with q'' = 0 and r'' = 0:

- x = F(q, p, r) by Newton on ``[c(x); e_r - r; e_q - q; e_p - p] = 0`` to round-off;
- v from ``[C; S; E_r; E_q] v = [0; 0; r'; q']``;
- a from the same matrix with the convective terms (``v^T H_k v`` of each mode from the
  kernels' exact Hessians, ``d(S v)/dx v`` of the slips, ``2 |lambda'|^2`` of the Euler
  normalizations) on the right-hand side;
- ``M a + h - f`` from :meth:`~spacarpy.solvers.dynamics.transient.TransientProblem.residual`
  with zero multipliers (``V^T`` removes the constraint forces).

Then ``M0 = V^T M V`` (exact: r is linear in a), ``C0 = dR/dq'`` (exact: R is quadratic in
q', so one central difference of unit step has no truncation error), ``K0 = dR/dq``,
``K0p = dR/dp``, ``G = E_p V``, ``Gq = d(E_p v)/dq``, ``Gp = d(E_p v)/dp`` by central
differences with Richardson extrapolation (steps h0, h0/2, h0/4, h0/8: truncation O(h0^8),
round-off about eps/h0; measured 1e-13 relative to the largest entry on the benchmark
bicycle, tests/test_bicycle_linear.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from spacarpy.errors import ModelError
from spacarpy.model import FLEXIBLE, RELEASED, RIGID
from spacarpy.solvers.statics.slips import held_slips

__all__ = ["SteadyMotion", "SteadyMotionMatrices", "richardson"]

#: First central-difference step (rad, or m over the length scale) of the Richardson table.
STEP = 0.05
#: Levels of the Richardson table (steps STEP / 2^k).
LEVELS = 4
#: Newton on the positions stops when the step is below this (relative to the length scale).
NEWTON_TOL = 1e-15


def richardson(f, h0: float = STEP, levels: int = LEVELS) -> np.ndarray:
    """``f'(0)`` from central differences ``(f(h) - f(-h)) / 2h`` at h0 / 2^k, extrapolated
    to h = 0 (Richardson: the errors are even powers of h)."""
    table = []
    for k in range(levels):
        h = h0 / 2 ** k
        row = [(f(h) - f(-h)) / (2 * h)]
        for j in range(1, k + 1):
            prev = table[k - 1][j - 1]
            row.append(row[j - 1] + (row[j - 1] - prev) / (4 ** j - 1))
        table.append(row)
    return table[-1][-1]


@dataclass
class SteadyMotionMatrices:
    """The linearized equations about the steady motion (docs/rolling.md)."""
    M0: np.ndarray
    C0: np.ndarray
    K0: np.ndarray
    K0p: np.ndarray
    G: np.ndarray
    Gq: np.ndarray
    Gp: np.ndarray
    dof_names: list
    kinematic_names: list

    @property
    def A(self) -> np.ndarray:
        """The state matrix over ``[q; q'; p]``."""
        n, k = self.M0.shape[0], self.G.shape[0]
        A = np.zeros((2 * n + k, 2 * n + k))
        A[:n, n:2 * n] = np.eye(n)
        A[n:2 * n, :n] = -np.linalg.solve(self.M0, self.K0)
        A[n:2 * n, n:2 * n] = -np.linalg.solve(self.M0, self.C0)
        A[n:2 * n, 2 * n:] = -np.linalg.solve(self.M0, self.K0p)
        A[2 * n:, :n] = self.Gq
        A[2 * n:, n:2 * n] = self.G
        A[2 * n:, 2 * n:] = self.Gp
        return A

    def poles(self) -> np.ndarray:
        """The eigenvalues of A, sorted by real part, then imaginary part."""
        lam = np.linalg.eigvals(self.A)
        return lam[np.lexsort((lam.imag, lam.real))]

    def dof_poles(self) -> np.ndarray:
        """The roots of ``det(M0 s^2 + C0 s + K0) = 0`` (the poles of the degrees of
        freedom, without the kinematic states' zeros when K0p = 0)."""
        n = self.M0.shape[0]
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -np.linalg.solve(self.M0, self.K0)
        a[n:, n:] = -np.linalg.solve(self.M0, self.C0)
        lam = np.linalg.eigvals(a)
        return lam[np.lexsort((lam.imag, lam.real))]


def _mode_lists(num, model):
    """(group, row, mode) of the holonomic, rheonomic, dynamic (DYNE) and released (RLSE)
    modes; the kinematic coordinates (KINE modes, KINX coordinates)."""
    prescribed = {(int(p.element), int(p.mode)) for p in model.prescribed_deformations}
    hol, rheo, dyn, rel = [], [], [], []
    where = {}
    for gi, g in enumerate(num.groups):
        vm = set(getattr(g.kind, "velocity_modes", ()))
        for r in range(g.n_elem):
            e = int(g.ids[r])
            for m in range(g.def_class.shape[1]):
                where[(g.keyword, e, m + 1)] = (gi, r, m)
                cls = g.def_class[r, m]
                if m in vm:
                    continue
                if cls == RIGID and (e, m + 1) in prescribed:
                    rheo.append((gi, r, m))
                elif cls == RIGID:
                    hol.append((gi, r, m))
                elif cls == FLEXIBLE:
                    dyn.append((gi, r, m))
                elif cls == RELEASED:
                    rel.append((gi, r, m))
    kin = []                      # ("mode", (gi, r, m)) or ("coord", index)
    for k in model.kinematic:
        if k.keyword == "KINX":
            hit = np.flatnonzero(model.position_ids == k.target)
            kin.append(("coord", int(num.pos_idx[hit[0], k.number - 1])))
        else:
            found = [v for key, v in where.items() if key[1] == k.target and key[2] == k.number]
            kin.append(("mode", found[0]))
    return hol, rheo, dyn, rel, kin


class SteadyMotion:
    """The projected equations R(q, q', p) of a model with slips about its initial state
    (positions from the deck, rates q' from STARTDE, r' from the 5-field INPUTE)."""

    def __init__(self, model, deformations: str = "modified", rotary_inertia: bool = True):
        from spacarpy.solvers.dynamics.transient import TransientOptions, TransientProblem
        from spacarpy.solvers.statics.equilibrium import StaticProblem
        if model.prescribed or model.prescribed_rotations:
            raise ModelError("the linearization about a steady motion does not support "
                             "INPUTX/INPUTR yet: prescribe the motion by INPUTE")
        self.model = model
        self.prob = StaticProblem(model, deformations=deformations)
        self.num = self.prob.num
        self.tp = TransientProblem(model, TransientOptions(t_end=1.0, n_steps=1,
                                                           rotary_inertia=rotary_inertia),
                                   self.prob)
        self.free = np.flatnonzero(self.prob.free)
        self.slips = held_slips(self.num)
        self.hol, self.rheo, self.dyn, rel, self.kin = _mode_lists(self.num, model)
        self.n_x = int(self.num.dynamic_idx.size)   # the DYNX coordinates: q = [x_d; e_d]
        base = (len(self.hol) + self.num.euler_nodes.size + len(self.rheo) + len(self.kin)
                + self.n_x)
        if base + len(self.dyn) < self.free.size and rel and not self.n_x:
            self.dyn = sorted(self.dyn + rel)      # too few DYNE modes: RLSE too, as mode 9
        if not self.dyn and not self.n_x:
            raise ModelError("the linearization about a steady motion needs degrees of "
                             "freedom (DYNE or DYNX)")
        if len(self.kin) != self.slips.n:
            raise ModelError(f"the {self.slips.n} slips held at zero need as many kinematic "
                             f"coordinates (KINE/KINX), the model has {len(self.kin)}")
        n_eq = (len(self.hol) + self.num.euler_nodes.size + len(self.rheo) + len(self.dyn)
                + len(self.kin) + self.n_x)
        if n_eq != self.free.size:
            left = (self.free.size - n_eq + len(self.rheo) + len(self.dyn) + len(self.kin)
                    + self.n_x)
            raise ModelError(
                f"the linearization about a steady motion needs the dynamic (DYNE, DYNX), "
                f"rheonomic (INPUTE) and kinematic (KINE/KINX) coordinates to parameterize "
                f"the configuration: {self.free.size} free coordinates, {len(self.hol)} "
                f"holonomic constraints and {self.num.euler_nodes.size} Euler normalizations "
                f"leave {left} coordinates, the deck gives {len(self.dyn)} DYNE, {self.n_x} "
                f"DYNX, {len(self.rheo)} INPUTE and {len(self.kin)} KINE/KINX")
        self.load = self.tp.loads(0.0)
        self.x0 = self.num.x0.copy()
        self.q0 = np.concatenate([self._dynx_values(self.x0), self._values(self.x0, self.dyn)])
        self.r0 = self._values(self.x0, self.rheo)
        self.p0 = self._kin_values(self.x0)
        self.h0 = self._values(self.x0, self.hol)
        rates = {(int(p.element), int(p.mode)): p for p in model.prescribed_deformations}
        self.dr = np.array([self._rate_of(rates, gi, r, m) for gi, r, m in self.rheo])
        start = model.initial_rates or {}
        self.dq0 = np.concatenate([
            np.zeros(self.n_x),                    # a DYNX coordinate starts at rest
            [float(start.get((int(self.num.groups[gi].ids[r]), m + 1), 0.0))
             for gi, r, m in self.dyn]])
        self.dof_names = ([f"DYNX {n} {c}" for n, c in self.num.dynamic_label.tolist()]
                          + [self._name(s) for s in self.dyn])
        self.kinematic_names = [k.name for k in model.kinematic]

    # ------------------------------------------------------------------ coordinates
    def _name(self, s) -> str:
        gi, r, m = s
        g = self.num.groups[gi]
        return f"{g.keyword} {int(g.ids[r])} {m + 1}"

    def _rate_of(self, rates, gi, r, m) -> float:
        p = rates.get((int(self.num.groups[gi].ids[r]), m + 1))
        return float(getattr(p, "velocity", 0.0) or 0.0) if p is not None else 0.0

    def _states(self, x):
        return [g.kind.state(x[g.idx], g.ref, self.prob.variant, g.prev)
                for g in self.num.groups]

    def _values(self, x, sel, states=None) -> np.ndarray:
        states = states or self._states(x)
        return np.array([states[gi].e[r, m] for gi, r, m in sel])

    def _dynx_values(self, x) -> np.ndarray:
        """The DYNX coordinates at x (the angle ``2 atan2(lambda3, lambda0)`` of a planar
        orientation node, whose row :meth:`Numbering.dynamic_rows
        <spacarpy.numbering.Numbering.dynamic_rows>` is)."""
        num = self.num
        out = x[num.dynamic_idx].copy()
        for i, r in enumerate(num.dynamic_rot.tolist()):
            if r >= 0:
                q = x[num.rot_idx[r]]
                out[i] = 2.0 * np.arctan2(q[3], q[0])
        return out

    def _kin_values(self, x, states=None) -> np.ndarray:
        states = states or self._states(x)
        return np.array([x[w] if kind == "coord" else states[w[0]].e[w[1], w[2]]
                         for kind, w in self.kin])

    def _mode_rows(self, sel, states) -> np.ndarray:
        out = np.zeros((len(sel), self.num.n_coord))
        for i, (gi, r, m) in enumerate(sel):
            np.add.at(out[i], self.num.groups[gi].idx[r], states[gi].D[r, m])
        return out

    def _kin_rows(self, states) -> np.ndarray:
        out = np.zeros((len(self.kin), self.num.n_coord))
        for i, (kind, w) in enumerate(self.kin):
            if kind == "coord":
                out[i, w] = 1.0
            else:
                out[i] = self._mode_rows([w], states)[0]
        return out

    def _euler_rows(self, x) -> tuple[np.ndarray, np.ndarray]:
        num = self.num
        rows = np.zeros((num.euler_nodes.size, num.n_coord))
        vals = np.zeros(num.euler_nodes.size)
        for i, node in enumerate(num.euler_nodes):
            lam = x[num.rot_idx[node]]
            rows[i, num.rot_idx[node]] = 2.0 * lam
            vals[i] = lam @ lam - 1.0
        return rows, vals

    def position(self, q, p) -> np.ndarray:
        """x = F(q, p, r0): Newton on the holonomic constraints with q, p and r fixed."""
        x = self.x0.copy()
        f = self.free
        scale = np.where(self.num.is_rotation_coord[f], 1.0, float(self.num.length_scale))
        target = np.concatenate([self.h0, np.zeros(self.num.euler_nodes.size), self.r0,
                                 np.asarray(q, float), np.asarray(p, float)])
        for _ in range(30):
            st = self._states(x)
            eu_rows, eu_vals = self._euler_rows(x)
            vals = np.concatenate([self._values(x, self.hol, st), eu_vals,
                                   self._values(x, self.rheo, st), self._dynx_values(x),
                                   self._values(x, self.dyn, st), self._kin_values(x, st)])
            J = np.vstack([self._mode_rows(self.hol, st), eu_rows,
                           self._mode_rows(self.rheo, st), self.num.dynamic_rows(x),
                           self._mode_rows(self.dyn, st), self._kin_rows(st)])[:, f]
            try:
                dx = np.linalg.solve(J, target - vals)
            except np.linalg.LinAlgError:
                raise ModelError("the linearization about a steady motion: the dynamic, "
                                 "rheonomic and kinematic coordinates do not parameterize "
                                 "the configuration here (a singular Jacobian)") from None
            x[f] += dx
            if np.max(np.abs(dx / scale)) < NEWTON_TOL:
                break
        else:
            raise ModelError("the linearization about a steady motion: the positions of a "
                             "perturbed configuration do not converge")
        return x

    # ------------------------------------------------------------------ rates
    def _velocity_matrix(self, x, st) -> np.ndarray:
        f = self.free
        eu_rows, _ = self._euler_rows(x)
        S = self.slips.jacobian(x).toarray() if self.slips.n else np.zeros((0, x.size))
        return np.vstack([self._mode_rows(self.hol, st), eu_rows, S,
                          self._mode_rows(self.rheo, st), self.num.dynamic_rows(x),
                          self._mode_rows(self.dyn, st)])[:, f]

    def _convective(self, x, v, st, sel) -> np.ndarray:
        """``v^T H_k v`` of the modes ``sel`` from the kernels' exact Hessians."""
        out = np.zeros(len(sel))
        for i, (gi, r, m) in enumerate(sel):
            g = self.num.groups[gi]
            w = np.zeros((g.n_elem, g.def_class.shape[1]))
            w[r, m] = 1.0
            H = g.kind.hessian(st[gi], w)[r]
            vl = v[g.idx[r]]
            out[i] = vl @ H @ vl
        return out

    def motion(self, q, dq, p):
        """(x, v, a, V, rows) at (q, q', p) with q'' = 0, r' the deck rates and r'' = 0;
        ``rows`` the kernel states at x."""
        x = self.position(q, p)
        st = self._states(x)
        J = self._velocity_matrix(x, st)
        n_h = len(self.hol) + self.num.euler_nodes.size + self.slips.n
        n = len(self.dyn) + self.n_x
        rhs = np.zeros((J.shape[0], n + 1))
        rhs[n_h:n_h + self.dr.size, 0] = self.dr
        rhs[J.shape[0] - n:, 0] = dq
        rhs[J.shape[0] - n:, 1:] = np.eye(n)
        lu = sla.lu_factor(J, check_finite=True)
        if not np.all(np.isfinite(lu[0])) or np.min(np.abs(np.diag(lu[0]))) == 0.0:
            raise ModelError("the linearization about a steady motion: the slips do not fix "
                             "the kinematic rates here (S F_p is singular)")
        sol = sla.lu_solve(lu, rhs)
        v = np.zeros_like(x)
        v[self.free] = sol[:, 0]
        V = np.zeros((x.size, n))
        V[self.free] = sol[:, 1:]
        eu = self.num.euler_coords
        conv_eu = 2.0 * np.sum(v[eu] * v[eu], axis=1)
        conv_s = (self.slips.rates_dx(x, v) @ v) if self.slips.n else np.zeros(0)
        # a DYNX row (unit, or 2 Lambda_z(q) of a planar angle) has d(row)/dt v = 0
        conv = np.concatenate([self._convective(x, v, st, self.hol), conv_eu, conv_s,
                               self._convective(x, v, st, self.rheo), np.zeros(self.n_x),
                               self._convective(x, v, st, self.dyn)])
        a = np.zeros_like(x)
        a[self.free] = sla.lu_solve(lu, -conv)
        return x, v, a, V, st

    def _force(self, x, v, a) -> np.ndarray:
        """``M a + h - f`` over all coordinates (zero multipliers)."""
        mu = np.zeros(self.num.n_constraint)
        r = np.zeros(self.num.n_coord)
        r[self.free] = self.tp.residual(0.0, x, v, a, mu).r
        return r

    def evaluate(self, q, dq, p) -> np.ndarray:
        """``[R; p']`` at (q, q', p): R = V^T (M a + h - f) and the kinematic rates."""
        x, v, a, V, st = self.motion(q, dq, p)
        pdot = self._kin_rows(st)[:, self.free] @ v[self.free]
        return np.concatenate([V.T @ self._force(x, v, a), pdot])

    # ------------------------------------------------------------------ matrices
    def matrices(self) -> SteadyMotionMatrices:
        """M0, C0, K0, K0p, G, Gq, Gp at the initial state."""
        q0, dq0, p0 = self.q0, self.dq0, self.p0
        n, k = q0.size, p0.size
        x, v, a, V, st = self.motion(q0, dq0, p0)
        f0 = self._force(x, v, a)
        M0 = np.column_stack([V.T @ (self._force(x, v, a + V[:, j]) - f0) for j in range(n)])
        M0 = 0.5 * (M0 + M0.T)
        eye_n, eye_k = np.eye(n), np.eye(k)
        # R is quadratic in q': one central difference of unit step is exact
        C0 = np.column_stack([0.5 * (self.evaluate(q0, dq0 + eye_n[j], p0)
                                     - self.evaluate(q0, dq0 - eye_n[j], p0))[:n]
                              for j in range(n)])
        L = float(self.num.length_scale)
        qscale = np.ones(n)             # a DYNX position coordinate: steps per length scale
        qscale[:self.n_x][~self.num.is_rotation_coord[self.num.dynamic_idx]] = L
        dq = np.column_stack([richardson(lambda h, j=j: self.evaluate(
            q0 + h * qscale[j] * eye_n[j], dq0, p0)) / qscale[j] for j in range(n)])
        pscale = np.array([L if kind == "coord" else 1.0 for kind, _ in self.kin])
        dp = np.column_stack([richardson(lambda h, j=j: self.evaluate(
            q0, dq0, p0 + h * pscale[j] * eye_k[j])) / pscale[j] for j in range(k)]) \
            if k else np.zeros((n + k, 0))
        G = self._kin_rows(st)[:, self.free] @ V[self.free]
        return SteadyMotionMatrices(M0, C0, dq[:n], dp[:n].reshape(n, k), G,
                                    dq[n:].reshape(k, n), dp[n:].reshape(k, k),
                                    self.dof_names, self.kinematic_names)

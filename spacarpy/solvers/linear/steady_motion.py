"""The linearized equations about a motion with slips and kinematic coordinates (SPACAR mode 3:
with ``TIMESTEP 0 0`` about the initial steady motion, otherwise about each stored state of a
transient, :meth:`SteadyMotion.at_state`; docs/rolling.md, "Linearization about a steady
motion", "Along a trajectory").

Notation of docs/rolling.md: ``q`` the dynamic coordinates (DYNE modes), ``r`` the rheonomic
ones (INPUTE modes, moving at their deck rates), ``p`` the kinematic ones (KINE, KINX), ``C``
the holonomic constraint rows (rigid modes, Euler normalizations), ``S`` the slips held at
zero. The projected equations

    R(q, q', p) = V^T (M a + h - f),     V = dx/dq' (C V = 0, S V = 0, E_r V = 0, E_q V = I),

are evaluated through the whole chain at t = 0 with q'' = 0 and r'' = 0 (at a stored state:
at its time, with r'' the deck's and q'' from the equations of motion there):

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
bicycle, tests/test_bicycle_linear.py). Differenced entries within their error bound are
certified zeros (:func:`certified`). The inputs give ``B0 = V^T F`` and the outputs their
rows over ``[q; q'; p]`` (:meth:`SteadyMotion.matrices`).
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
#: Safety factor of the round-off bound of a difference (:meth:`SteadyMotion.matrices`).
NOISE = 64.0
#: Newton on the positions stops when the step is below this, relative to the length scale
#: or to the coordinate where it is larger (4 eps: round-off of the coordinate itself).
NEWTON_TOL = 4 * np.finfo(float).eps
#: ... or, below this, when the step no longer shrinks fourfold (Newton converges
#: quadratically: a step that stalls is the round-off of the targets, such as 30 rad of a
#: wheel's rotation read to 7e-15).
STALL = 1e-11


def richardson(f, h0: float = STEP, levels: int = LEVELS, error: bool = False):
    """``f'(0)`` from central differences ``(f(h) - f(-h)) / 2h`` at h0 / 2^k, extrapolated
    to h = 0 (Richardson: the errors are even powers of h). ``error``: also return the
    table's estimate of the truncation error, ``|T_kk - T_k-1,k-1|`` (entry by entry)."""
    table = []
    for k in range(levels):
        h = h0 / 2 ** k
        row = [(f(h) - f(-h)) / (2 * h)]
        for j in range(1, k + 1):
            prev = table[k - 1][j - 1]
            row.append(row[j - 1] + (row[j - 1] - prev) / (4 ** j - 1))
        table.append(row)
    if error:
        return table[-1][-1], np.abs(table[-1][-1] - table[-2][-1])
    return table[-1][-1]


def certified(value: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """``value`` with the entries whose magnitude lies within their error ``bound`` set to
    exactly zero (certified zeros: the computation cannot tell them from 0)."""
    return np.where(np.abs(value) <= bound, 0.0, value)


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
    #: the inputs' generalized forces in the degrees of freedom (n, n_in): ``V^T F``
    B0: np.ndarray | None = None
    #: the outputs over the state ``[q; q'; p]`` (n_out, 2 n + k)
    Cy: np.ndarray | None = None

    @property
    def B(self) -> np.ndarray:
        """The input matrix over ``[q; q'; p]``: ``[0; M0^-1 B0; 0]``."""
        n, k = self.M0.shape[0], self.G.shape[0]
        b0 = self.B0 if self.B0 is not None else np.zeros((n, 0))
        B = np.zeros((2 * n + k, b0.shape[1]))
        B[n:2 * n] = np.linalg.solve(self.M0, b0)
        return B

    @property
    def C(self) -> np.ndarray:
        """The output matrix over ``[q; q'; p]``."""
        n, k = self.M0.shape[0], self.G.shape[0]
        return self.Cy if self.Cy is not None else np.zeros((0, 2 * n + k))

    @property
    def D(self) -> np.ndarray:
        """No feedthrough: the outputs are positions and rates."""
        return np.zeros((self.C.shape[0], self.B.shape[1]))

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

    def __init__(self, model, deformations: str = "modified", rotary_inertia: bool = True,
                 options=None, inputs=(), outputs=()):
        from spacarpy.solvers.dynamics.transient import TransientOptions, TransientProblem
        from spacarpy.solvers.statics.equilibrium import StaticProblem
        if model.prescribed or model.prescribed_rotations:
            raise ModelError("the linearization about a steady motion does not support "
                             "INPUTX/INPUTR yet: prescribe the motion by INPUTE")
        self.model = model
        self.prob = StaticProblem(model, deformations=deformations)
        self.num = self.prob.num
        self.tp = TransientProblem(model, options or TransientOptions(
            t_end=1.0, n_steps=1, rotary_inertia=rotary_inertia), self.prob)
        self.inputs, self.outputs = list(inputs), list(outputs)
        self.t = 0.0
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
        self.ddr = np.zeros(len(self.rheo))
        self.ddq0 = np.zeros(self.n_x + len(self.dyn))
        self.dof_names = ([f"DYNX {n} {c}" for n, c in self.num.dynamic_label.tolist()]
                          + [self._name(s) for s in self.dyn])
        self.kinematic_names = [k.name for k in model.kinematic]

    def at_state(self, t: float, x: np.ndarray, v: np.ndarray, prev=None) -> None:
        """Linearize about the state (t, x, v) of a trajectory (a stored transient step)
        from now on: q, p, r and q' read at (x, v), r' and r'' the deck's at time t, and
        q'' from the equations of motion there, ``M0 q'' = -R(q'' = 0)`` (the accelerations
        of the motion itself, not the integrator's). ``prev``: the element groups' committed
        states of the run (``g.prev``: a hinge's turn count, so that an angle past pi, a
        wheel's rotation, is read on its branch of the trajectory)."""
        if prev is not None:
            for g, p in zip(self.num.groups, prev):
                g.prev = {key: np.array(val, copy=True) for key, val in p.items()}
        self.t = float(t)
        self.load = self.tp.loads(self.t)
        self.x0 = np.array(x, float)
        st = self._states(self.x0)
        self.q0 = np.concatenate([self._dynx_values(self.x0),
                                  self._values(self.x0, self.dyn, st)])
        self.r0 = self._values(self.x0, self.rheo, st)
        self.p0 = self._kin_values(self.x0, st)
        f = self.free
        rows = np.vstack([self.num.dynamic_rows(self.x0), self._mode_rows(self.dyn, st)])
        self.dq0 = rows[:, f] @ np.asarray(v, float)[f]
        rate, acc = self.tp.rigid_rates(self.t)
        where = {}
        for gi, g in enumerate(self.num.groups):
            for j, (r, m) in enumerate(zip(g.rigid_elem, g.rigid_mode)):
                where[(gi, int(r), int(m))] = g.rigid_offset + j
        idx = np.array([where[s] for s in self.rheo], dtype=np.int64)
        self.dr, self.ddr = (rate[idx], acc[idx]) if idx.size else (np.zeros(0),) * 2
        self.ddq0 = np.zeros(self.n_x + len(self.dyn))
        xs, vs, a, V, _ = self.motion(self.q0, self.dq0, self.p0)
        f0 = self._force(xs, vs, a)
        self.ddq0 = -np.linalg.solve(self._mass(xs, vs, a, V, f0), V.T @ f0)

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
        last = np.inf
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
            # to round-off of the coordinates' own size (a contact point metres away), or
            # stalled at the round-off of the targets (a wheel's angle of many turns)
            step = float(np.max(np.abs(dx) / np.maximum(scale, np.abs(x[f]))))
            if step < NEWTON_TOL or (step < STALL and step > 0.25 * last):
                break
            last = step
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
        """(x, v, a, V, rows) at (q, q', p) with q'' = ``ddq0`` (0 about a steady motion), r'
        and r'' the deck's; ``rows`` the kernel states at x."""
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
        rhs_a = -conv
        rhs_a[n_h:n_h + self.ddr.size] += self.ddr
        rhs_a[J.shape[0] - n:] += self.ddq0
        a = np.zeros_like(x)
        a[self.free] = sla.lu_solve(lu, rhs_a)
        return x, v, a, V, st

    def _force(self, x, v, a) -> np.ndarray:
        """``M a + h - f`` over all coordinates (zero multipliers)."""
        mu = np.zeros(self.num.n_constraint)
        r = np.zeros(self.num.n_coord)
        r[self.free] = self.tp.residual(self.t, x, v, a, mu).r
        return r

    def _mass(self, x, v, a, V, f0) -> np.ndarray:
        """``M0 = V^T M V`` (exact: the residual is linear in a)."""
        M0 = np.column_stack([V.T @ (self._force(x, v, a + V[:, j]) - f0)
                              for j in range(V.shape[1])])
        return 0.5 * (M0 + M0.T)

    def _signals(self, x, st):
        """(input forces F (n_x, n_in), output rows (n_out, n_x), is_rate) at x, over the
        free coordinates (:mod:`spacarpy.solvers.linear.state_space`'s definitions)."""
        from types import SimpleNamespace

        from spacarpy.solvers.linear.state_space import input_columns, output_rows
        at = SimpleNamespace(x=x, states=st)
        F = input_columns(at, self.num, self.prob.free, self.model, self.inputs)
        rows, rate = output_rows(at, self.num, self.prob.free, self.model, self.outputs)
        return F, rows, rate

    def evaluate(self, q, dq, p) -> np.ndarray:
        """``[R; p'; y']`` at (q, q', p): R = V^T (M a + h - f), the kinematic rates and the
        rates of the outputs' coordinates or deformations."""
        x, v, a, V, st = self.motion(q, dq, p)
        f = self.free
        pdot = self._kin_rows(st)[:, f] @ v[f]
        ydot = self._signals(x, st)[1] @ v[f] if self.outputs else np.zeros(0)
        return np.concatenate([V.T @ self._force(x, v, a), pdot, ydot])

    def coordinate_maps(self, x, st) -> tuple[np.ndarray, np.ndarray]:
        """(F_q, F_p): the change of the free coordinates with q and with p at x (r and
        the holonomic modes held), ``dx = F_q dq + F_p dp``."""
        eu_rows, _ = self._euler_rows(x)
        J = np.vstack([self._mode_rows(self.hol, st), eu_rows, self._mode_rows(self.rheo, st),
                       self.num.dynamic_rows(x), self._mode_rows(self.dyn, st),
                       self._kin_rows(st)])[:, self.free]
        n, k = self.n_x + len(self.dyn), len(self.kin)
        rhs = np.zeros((J.shape[0], n + k))
        rhs[J.shape[0] - n - k:] = np.eye(n + k)
        sol = np.linalg.solve(J, rhs)
        return sol[:, :n], sol[:, n:]

    # ------------------------------------------------------------------ matrices
    def matrices(self) -> SteadyMotionMatrices:
        """M0, C0, K0, K0p, G, Gq, Gp (and B0 and the output matrix) at the base state.

        The differenced entries that lie within their error bound are certified zeros
        (:func:`certified`): the Richardson table's truncation estimate plus the round-off
        of the differences, ``NOISE eps s / h`` with ``s`` the size of the differenced
        quantities (the largest force of ``M a + h - f`` times the largest entry of V for
        R, the largest rate for p') and h the table's smallest step. The cyclic coordinates'
        columns (the heading, a wheel's rotation, the contact point) then hold exact zeros,
        so the eigenvalue solver finds their zero poles exactly instead of the square root
        of round-off that a Jordan block turns them into."""
        q0, dq0, p0 = self.q0, self.dq0, self.p0
        n, k = q0.size, p0.size
        x, v, a, V, st = self.motion(q0, dq0, p0)
        f = self.free
        f0 = self._force(x, v, a)
        M0 = self._mass(x, v, a, V, f0)
        eye_n, eye_k = np.eye(n), np.eye(k)
        # R is quadratic in q': one central difference of unit step is exact
        dd = np.column_stack([0.5 * (self.evaluate(q0, dq0 + eye_n[j], p0)
                                     - self.evaluate(q0, dq0 - eye_n[j], p0))
                              for j in range(n)])
        L = float(self.num.length_scale)
        qscale = np.ones(n)             # a DYNX position coordinate: steps per length scale
        qscale[:self.n_x][~self.num.is_rotation_coord[self.num.dynamic_idx]] = L
        dq, eq = zip(*[richardson(lambda h, j=j: self.evaluate(
            q0 + h * qscale[j] * eye_n[j], dq0, p0), error=True) for j in range(n)])
        dq, eq = np.column_stack(dq) / qscale, np.column_stack(eq) / qscale
        pscale = np.array([L if kind == "coord" else 1.0 for kind, _ in self.kin])
        if k:
            dp, ep = zip(*[richardson(lambda h, j=j: self.evaluate(
                q0, dq0, p0 + h * pscale[j] * eye_k[j]), error=True) for j in range(k)])
            dp, ep = np.column_stack(dp) / pscale, np.column_stack(ep) / pscale
        else:
            dp = ep = np.zeros((dq.shape[0], 0))
        # round-off of the differences, row by row: R, p', y'
        eps = np.finfo(float).eps
        h_min = STEP / 2 ** (LEVELS - 1)
        size_r = np.abs(V).max(initial=0.0) * np.abs(f0).max(initial=0.0)
        size_v = np.abs(v[f]).max(initial=0.0) * max(1.0, np.abs(V).max(initial=0.0))
        rows = np.concatenate([np.full(n, size_r), np.full(dq.shape[0] - n, size_v)])
        noise = NOISE * eps * rows[:, None]
        dq = certified(dq, eq + noise / (h_min * qscale[None, :]))
        dp = certified(dp, ep + noise / (h_min * np.concatenate([pscale, [1.0]])[:k][None, :])
                       if k else ep)
        dd = certified(dd, noise)
        G = certified(self._kin_rows(st)[:, f] @ V[f], NOISE * eps * np.abs(V).max())
        F, orows, rate = self._signals(x, st)
        B0 = V[f].T @ F
        Cy = np.zeros((orows.shape[0], 2 * n + k))
        if orows.shape[0]:
            Fq, Fp = self.coordinate_maps(x, st)
            y = slice(n + k, None)
            Cy[:, :n] = np.where(rate[:, None], dq[y], orows @ Fq)
            Cy[:, n:2 * n] = np.where(rate[:, None], dd[y], 0.0)
            Cy[:, 2 * n:] = np.where(rate[:, None], dp[y], orows @ Fp)
        return SteadyMotionMatrices(M0, dd[:n], dq[:n], dp[:n].reshape(n, k), G,
                                    dq[n:n + k].reshape(k, n), dp[n:n + k].reshape(k, k),
                                    self.dof_names, self.kinematic_names, B0=B0, Cy=Cy)

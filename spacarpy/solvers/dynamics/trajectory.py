"""The linearized equations along a transient trajectory (SPACAR mode 3).

At a stored time step (t, x, v, a, mu) of :mod:`spacarpy.solvers.dynamics.transient` the equations
of motion over the free coordinates are ``r(x, v, a, mu) = 0`` with ``c(x) = 0``. A
neighbouring motion ``x + dx`` that keeps the constraints has ``dx = Phi(x) dq`` to first
order, with Phi the map of the degrees of freedom q of :func:`spacarpy.solvers.linear.state_space.
dof_map` (the DYNE/RLSE deformation modes, ``C Phi = 0, E Phi = I``). Along the trajectory
Phi changes with time, so

    dv = Phi dq' + Phi' dq,      da = Phi dq'' + 2 Phi' dq' + Phi'' dq,

and projecting the linearized equations ``M da + C_v dv + K_x dx + C^T dmu = F du`` on
Phi^T (which removes the constraint forces) gives ``M0 dq'' + C0 dq' + K0 dq = B0 du`` with

    M0 = Phi^T M Phi,
    C0 = Phi^T (C_v Phi + 2 M Phi'),
    K0 = Phi^T (K_x Phi + C_v Phi' + M Phi''),      B0 = Phi^T F,

where ``M = dr/da``, ``C_v = dr/dv`` (damping, and the gyroscopic / convective inertia
terms) and ``K_x = dr/dx`` (stiffness, geometric and constraint-force terms, and the
derivative of the inertia forces with respect to the coordinates), each at the state.
At rest (v = a = 0) Phi' = Phi'' = 0 and the matrices are mode 9's. The state is the stored
(t, x, v) with the accelerations and multipliers of the equations of motion there, not the
integrator's (its recurrences leave an error in the acceleration of driven coordinates,
undamped with RHOINF 1, and in the multipliers, whose tension enters K_x).

How they are computed (documented approximation): r is evaluated by
:meth:`spacarpy.solvers.dynamics.transient.TransientProblem.residual`; ``M Phi`` exactly (r is
linear in a), ``K_x Phi`` and ``C_v Phi``, ``C_v Phi'`` by central differences along those
directions (step 1e-6 of the model's length scale, an error near 1e-10 relative), and Phi'
and Phi'' by central differences of ``Phi(x + s v + s^2 a / 2)`` in s, the coordinates'
Taylor path, whose first and second derivatives at s = 0 are Phi' and Phi'' exactly (step
1e-3 of the length scale). The cost is about 6 n_dof + 3 residual evaluations and three
linearizations per stored step. Outputs: ``OUTX``/``OUTE`` rows ``R Phi`` on q; the rates
``OUTXP``/``OUTEP`` are ``R v``, so ``R Phi`` on q' and ``(R Phi)'`` on q.
tests/test_mode3.py checks a swinging pendulum and a spinning disc against closed forms.
"""
from __future__ import annotations

import numpy as np

from spacarpy.solvers.dynamics.transient_start import (
    _initial_acceleration,
    _project_velocities,
)
from spacarpy.solvers.linear.linearize import linearize
from spacarpy.solvers.linear.state_space import (
    dof_map,
    first_order,
    input_columns,
    output_rows,
)

__all__ = ["TrajectoryLinearizer"]

#: Central-difference steps, relative to the model's length scale: along the coordinates
#: (first derivatives: truncation h^2, round-off eps/h, both near 1e-10 relative), and along
#: the Taylor path in time (second derivatives: truncation h^2, round-off eps/h^2; 5e-9 relative
#: on the pendulum of tests/test_mode3.py, 2e-7 with 1e-4).
FD_STEP = 1e-6
PATH_STEP = 1e-3


class TrajectoryLinearizer:
    """Linearizes a transient problem ``tp`` (a :class:`~spacarpy.solvers.dynamics.transient.
    TransientProblem`) in the degrees of freedom ``layout`` at its stored steps."""

    def __init__(self, tp, layout, inputs, outputs):
        self.tp, self.layout = tp, layout
        self.inputs, self.outputs = inputs, outputs
        num = tp.num
        self.free = tp.free
        self.length = float(num.length_scale)
        self.rot = num.is_rotation_coord[self.free]

    def _scaled_size(self, d: np.ndarray) -> float:
        """The size of a free-coordinate vector: positions over the length scale."""
        w = np.where(self.rot, 1.0, 1.0 / self.length)
        return float(np.abs(d * w).max(initial=0.0))

    def _full(self, x, d_free):
        out = x.copy()
        out[self.free] += d_free
        return out

    def _lin(self, x, mu, load):
        return linearize(self.tp.prob, x, mu, load)

    def _map(self, x, mu, load):
        """Phi and the output rows at x."""
        tp = self.tp
        lin = self._lin(x, mu, load)
        phi = dof_map(lin, tp.num, self.free, self.layout)
        rows, rate = output_rows(lin, tp.num, self.free, tp.model, self.outputs)
        return lin, phi, rows, rate

    def _r(self, t, x, v, a, mu) -> np.ndarray:
        return self.tp.residual(t, x, v, a, mu).r

    def consistent_state(self, t, x, v, mu):
        """The velocities, accelerations and multipliers of the equations of motion at the
        stored (t, x), from the stored v. The stored ones are the integrator's: the index-3
        scheme holds the constraints at position level only, so its velocities violate
        ``C v = -c_t`` by O(h^2) (a rigid rod's end moving along the rod), and Phi' taken
        along them reads that as stretching (C0 of a swinging planar rod was 1e-3 of
        sqrt(K0 M0), not 0); its recurrences leave an error in the acceleration of
        constraint-driven coordinates (undamped with RHOINF 1) and in the multipliers,
        whose tension enters K_x. So the velocities are projected on the velocity form of
        the constraints (:func:`spacarpy.solvers.dynamics.transient_start.
        _project_velocities`, the closest in the mass norm), and the accelerations and
        multipliers are :func:`spacarpy.solvers.dynamics.transient_start._initial_acceleration`'s
        at time t with them. Returns ``(v, a, mu)``."""
        v = _project_velocities(self.tp, x, v, t)
        a_presc = self.tp.prescribed(t)[3]
        a, mu = _initial_acceleration(self.tp, x, v, mu, a_presc, t=t)
        return v, a, mu

    def _directional(self, t, x, v, a, mu, wrt: str, d: np.ndarray) -> np.ndarray:
        """Central difference of r along the free-coordinate direction d of x or v."""
        size = self._scaled_size(d)
        if size == 0.0:
            return np.zeros(int(np.count_nonzero(self.free)))
        h = FD_STEP / size
        if wrt == "x":
            rp = self._r(t, self._full(x, h * d), v, a, mu)
            rm = self._r(t, self._full(x, -h * d), v, a, mu)
        else:
            rp = self._r(t, x, self._full(v, h * d), a, mu)
            rm = self._r(t, x, self._full(v, -h * d), a, mu)
        return (rp - rm) / (2 * h)

    def __call__(self, step):
        """The :class:`~spacarpy.solvers.linear.state_space.StateSpace` at a stored
        :class:`~spacarpy.solvers.dynamics.transient.TransientStep`."""
        tp = self.tp
        t, x, v, a, mu = step.time, step.x, step.v, step.a, step.mu
        v, a, mu = self.consistent_state(t, x, v, mu)
        load = tp.loads_at(t, v)
        lin, phi, rows, rate = self._map(x, mu, load)
        n = phi.shape[1]
        # Phi' and Phi'' (and the output rows' rate) along the Taylor path x + s v + s^2 a/2
        vs = self._scaled_size(v[self.free])
        as_ = self._scaled_size(a[self.free])
        rows_phi = rows @ phi
        if vs == 0.0 and as_ == 0.0:
            dphi = ddphi = np.zeros_like(phi)
            d_rows_phi = np.zeros_like(rows_phi)
        else:
            s = PATH_STEP / max(vs, np.sqrt(as_))
            _, phi_p, rows_p, _ = self._map(x + s * v + 0.5 * s * s * a, mu, load)
            _, phi_m, rows_m, _ = self._map(x - s * v + 0.5 * s * s * a, mu, load)
            dphi = (phi_p - phi_m) / (2 * s)
            ddphi = (phi_p - 2 * phi + phi_m) / (s * s)
            d_rows_phi = (rows_p @ phi_p - rows_m @ phi_m) / (2 * s)
        r0 = self._r(t, x, v, a, mu)
        M_phi = np.empty_like(phi)
        M_dphi = np.empty_like(phi)
        M_ddphi = np.empty_like(phi)
        Kx_phi = np.empty_like(phi)
        Cv_phi = np.empty_like(phi)
        Cv_dphi = np.empty_like(phi)
        for j in range(n):                     # over the degrees of freedom (few), not elements
            for out, d in ((M_phi, phi[:, j]), (M_dphi, dphi[:, j]), (M_ddphi, ddphi[:, j])):
                out[:, j] = self._r(t, x, v, self._full(a, d), mu) - r0   # r is linear in a
            Kx_phi[:, j] = self._directional(t, x, v, a, mu, "x", phi[:, j])
            Cv_phi[:, j] = self._directional(t, x, v, a, mu, "v", phi[:, j])
            Cv_dphi[:, j] = self._directional(t, x, v, a, mu, "v", dphi[:, j])
        M0 = phi.T @ M_phi
        C0 = phi.T @ (Cv_phi + 2.0 * M_dphi)
        K0 = phi.T @ (Kx_phi + Cv_dphi + M_ddphi)
        B0 = phi.T @ input_columns(lin, tp.num, self.free, tp.model, self.inputs)
        out_q = np.where(rate[:, None], d_rows_phi, rows_phi)
        out_dq = np.where(rate[:, None], rows_phi, 0.0)
        return first_order(M0, C0, K0, B0, out_q, out_dq, self.layout.names)


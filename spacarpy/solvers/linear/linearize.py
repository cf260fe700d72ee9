"""Linearized equations of motion about an equilibrium (Eq. 61-62).

At a converged static state (x, mu) the small-motion equations over the free coordinates,
subject to the linearized constraints ``C dx = 0``, are

    (K0 + G0 + N0) dx + M0 ddx = 0,

with K0 = D^T S D (material), G0 = sum sigma_i d2e_i/dx2 + the second derivatives of the
other constraints times their multipliers (geometric), N0 = -d f_ext/dx (moments), M0 the
consistent mass. spacarpy keeps them in full free coordinates with the constraint Jacobian
C beside them; the degrees of freedom are the null space of C. M0 takes the beams' section
rotary inertia lumped (SPACAR's) or consistent, the choice ``rotary`` of
:class:`MassAssembler`. The eigen solvers either
reduce to an orthonormal null-space basis T (dense, small models: ``T^T K T`` etc.) or work
on the bordered pencil ``[[K, C^T], [C, 0]] - lambda [[M, 0], [0, 0]]`` (sparse
shift-invert, large models): both give the same eigenvalues.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from spacarpy.assembly import BlockPattern
from spacarpy.elements.beam_mass import nodal_rotary_mass
from spacarpy.solvers.statics.nodal import nodal_masses


@dataclass
class Linearization:
    """Linearized equations at one equilibrium, over the free coordinates.

    Attributes
    ----------
    n_x : int
        The number of free coordinates.
    K : (n_x, n_x) sparse
        Tangent stiffness K0 + G0 + N0 (non-symmetric when dead moments act). K and C are
        assembled on first use, together (``bordered``: the function that returns them;
        the tangent-space eigen solver needs neither, and at 10^5 elements their
        assembly costs 1.5 s on first use).
    K_mat : (n_x, n_x) sparse
        Material stiffness K0 = D^T S D, assembled on first use (``material``: the
        function that assembles it; the sparse eigen solver does not need it, and at 10^5
        elements its assembly costs a second).
    C : (n_con, n_x) sparse
        Constraint Jacobian (rigid modes, Euler normalizations).
    M : (n_x, n_x) sparse or None
    states : list
        Per element group, the kernel state at x (its ``D`` classifies rigid-body modes).
    x : (n_coord,)
        The state.
    reduced : ReducedNewton or None
        The static problem's tangent-space Newton solver, where it applies and a mass is
        given (:mod:`spacarpy.solvers.linear.eigen_tangent` solves the lowest modes with it).
    blocks : (list, ndarray) or None
        With ``reduced``: per element group ``(D, S, H)``, the deformation derivatives, the
        stiffness and the load-dependent block ``H`` (the stress resultants' Hessian, less
        the gravity stiffness; None where it vanishes), so that K's element block is
        ``D^T S D + H``; and the Euler-node diagonal ``2 mu``. For products of K element by
        element.
    """

    n_x: int
    bordered: Callable[[], tuple[sp.csc_matrix, sp.csr_matrix]] = field(repr=False)
    M: sp.csc_matrix | None
    states: list
    x: np.ndarray
    reduced: object = None
    blocks: tuple | None = None
    material: Callable[[], sp.csc_matrix] | None = field(default=None, repr=False)
    _k_mat: sp.csc_matrix | None = field(default=None, init=False, repr=False)
    _kc: tuple | None = field(default=None, init=False, repr=False)

    @property
    def K(self) -> sp.csc_matrix:
        if self._kc is None:
            self._kc = self.bordered()
        return self._kc[0]

    @property
    def C(self) -> sp.csr_matrix:
        if self._kc is None:
            self._kc = self.bordered()
        return self._kc[1]

    @property
    def K_mat(self) -> sp.csc_matrix:
        if self._k_mat is None:
            self._k_mat = self.material()
        return self._k_mat

    @property
    def G(self):
        """Load-proportional part G0 + N0 = K - K0."""
        return self.K - self.K_mat


class MassAssembler:
    """Assembles the mass matrix over the free coordinates of a model on a fixed pattern."""

    def __init__(self, model, num, rotary: str = "lumped"):
        self.model, self.num = model, num
        #: the beams' section rotary inertia (:mod:`spacarpy.elements.beam_mass`)
        self.rotary = rotary
        u = num.unknown_of
        point = nodal_masses(model, num)
        self.point_idx, self.point_mass = point.point_idx, point.point_mass
        self.rot_nodes, self.rot_inertia = point.rot_nodes, point.rot_inertia
        # element groups with inertia (a HINGE has none)
        self.groups = [g for g in num.groups if g.kind.mass is not None]
        self.pattern = BlockPattern(num.n_unknown, [u[g.idx] for g in self.groups]
                                    + [u[self.point_idx], u[num.rot_idx[self.rot_nodes]]])

    @property
    def has_mass(self) -> bool:
        return bool(any(np.any(g.mass) for g in self.groups) or self.point_mass.size
                    or self.rot_nodes.size)

    def matrix(self, x: np.ndarray) -> sp.csc_matrix:
        num = self.num
        blocks = [g.kind.mass(x[g.idx], g.ref, g.mass, self.rotary) for g in self.groups]
        m_pt = self.point_mass[:, None, None] * np.eye(3)
        m_rot = nodal_rotary_mass(x[num.rot_idx[self.rot_nodes]], self.rot_inertia)
        return self.pattern.assemble(blocks + [m_pt, m_rot])


def linearize(prob, x, mu, load, mass: MassAssembler | None = None) -> Linearization:
    """Linearized matrices of a :class:`~spacarpy.solvers.statics.equilibrium.StaticProblem` at
    (x, mu) under ``load`` (a :class:`~spacarpy.solvers.statics.loads.LoadState`; the state should
    be an equilibrium of that load)."""
    ev = prob.evaluate(x, mu, load)
    n_x = prob.pattern.n_x
    mu = np.array(mu, dtype=float)           # K and C are assembled later, from this state

    def bordered():
        a = prob.matrix(ev, mu)
        return a[:n_x, :n_x].tocsc(), (a[n_x:, :n_x] / prob.scale).tocsr()

    def material():
        return prob.matrix(ev, mu, material_only=True)[:n_x, :n_x].tocsc()
    M = mass.matrix(x) if mass is not None else None
    reduced = blocks = None
    if M is not None and prob.reduced is not None:
        reduced = prob.reduced
        parts = []
        for i, (g, st, sig) in enumerate(zip(prob.num.groups, ev.states, ev.sigmas)):
            # the weighted Hessian is linear in the stress resultants: none where they vanish
            h = g.kind.hessian(st, sig) if np.any(sig) else 0.0
            if ev.gravity_stiffness and ev.gravity_stiffness[i] is not None:
                h = h - ev.gravity_stiffness[i]
            parts.append((st.D, g.S, h if np.any(h) else None))   # None: unstressed
        blocks = (parts, 2.0 * mu[prob.num.n_rigid:prob.num.n_constraint])
    return Linearization(n_x=n_x, bordered=bordered, M=M, states=ev.states, x=x, reduced=reduced,
                         blocks=blocks, material=material)

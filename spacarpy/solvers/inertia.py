"""Inertia forces of the whole model over all nodal coordinates: ``M(x) a + h(x, v)``.

The kinetic energy is ``T = 1/2 v^T M(x) v`` with the element mass matrices of the kernels
(beam: Hermite centre line, Eq. 57-59, and the section rotary inertia lumped at the end
orientation nodes or consistent, the choice ``rotary``; truss; rigid rod) and the nodal
masses (XM). Lagrange's equations give the generalized inertia force

    d/dt (dT/dv) - dT/dx = M a + h,   h = (dM/dt) v - 1/2 d(v^T M v)/dx        (Eq. 60)

(the convective terms). Every mass matrix here is a polynomial of degree at most two in the
nodal coordinates: positions enter linearly, the tangents ``n = R(q) n0`` and the angular
velocity matrices ``G(q)`` are linear or quadratic in the Euler parameters. A central
difference of a quadratic function is *exact* for any step, so the derivatives of M in h are
taken as central differences with unit step on each element's local coordinates: exact (to
round-off), vectorized over the elements, and valid for every kernel without writing its
convective terms by hand. A kind that provides ``convective`` (the BEAM, whose 19
mass-matrix evaluations per residual dominated the transient runs) has ``dM/dt v`` and
``d(v^T M v)/dx`` computed analytically, and M is evaluated once.

Unlike :class:`spacarpy.solvers.linearize.MassAssembler` (free coordinates only), the matrix
here spans all coordinates, so prescribed motions (INPUTX, INPUTR with their velocities and
accelerations) load the free coordinates through the coupling terms.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from spacarpy.assembly import BlockPattern, scatter_add
from spacarpy.elements.beam_mass import nodal_rotary_mass
from spacarpy.rotation import tangent_part
from spacarpy.solvers.nodal import nodal_masses


class _Batch(NamedTuple):
    """One batch of mass blocks: elements of one kind, point masses or rotary nodes."""

    mass_of: Callable             # (x_local, reps) -> (reps * n, k, k) mass blocks
    idx: np.ndarray               # (n, k) global coordinate indices
    rot: np.ndarray               # local Euler-parameter slots (M depends on them only)
    conv_of: Callable | None      # (x_local, v_local) -> (dM/dt v, d(v^T M v)/dx), or None


class Inertia:
    """Mass matrix and inertia forces of a model over all ``n_coord`` coordinates."""

    def __init__(self, model, num, rotary: str = "lumped"):
        self.num = num
        #: the beams' section rotary inertia, ``"lumped"`` or ``"consistent"``
        #: (:mod:`spacarpy.elements.beam_mass`)
        self.rotary = rotary
        point = nodal_masses(model, num)
        self.point_idx, self.point_mass = point.point_idx, point.point_mass
        self.rot_idx = num.rot_idx[point.rot_nodes].reshape(-1, 4)
        self.rot_inertia = point.rot_inertia
        self.groups = [g for g in num.groups if g.kind.mass is not None and np.any(g.mass)]
        #: position of each of self.groups in num.groups
        self.group_pos = [next(i for i, h in enumerate(num.groups) if h is g)
                          for g in self.groups]
        self.pattern = BlockPattern(num.n_coord, [g.idx for g in self.groups]
                                    + [self.point_idx, self.rot_idx])
        # the nodal masses over the unknown coordinates (their blocks are not element
        # blocks of the Newton matrix's pattern)
        u = num.unknown_of
        self.nodal_pattern = BlockPattern(num.n_unknown, [u[self.point_idx], u[self.rot_idx]])
        self.has_nodal = bool(self.point_idx.size or self.rot_idx.size)
        self.batches = self._batches()

    @property
    def has_mass(self) -> bool:
        return bool(self.groups or self.point_mass.size or self.rot_idx.size)

    def physical(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Velocities with the Euler parameters' radial parts removed (``q.dq = 0``).

        An index-3 integrator keeps ``q.q = 1`` at position level only, so its velocities
        may carry a small spurious component along q. The rotary mass ``4 G^T J G`` ignores
        it, but the beam's tangents ``n = R(q) n0`` are quadratic in q and would read it as a
        stretching of the tangent; the convective terms and the kinetic energy use the
        physical velocities instead.
        """
        ri = self.num.rot_idx
        if not ri.size:
            return v
        v = v.copy()
        v[ri] = tangent_part(x[ri], v[ri])
        return v

    def _batches(self):
        """Per batch (element groups, point masses, rotary nodes): its coordinate indices and
        a mass function ``f(x_local, reps)`` for ``reps`` stacked copies of the batch
        (reference data and properties tiled, so that many configurations are evaluated in
        one vectorized kernel call)."""
        out = []
        for g in self.groups:
            def mass_of(xl, reps, g=g):
                ref = {k: np.concatenate([v] * reps) if isinstance(v, np.ndarray) else v
                       for k, v in g.ref.items()}
                return g.kind.mass(xl, ref, np.concatenate([g.mass] * reps), self.rotary)
            # local Euler-parameter coordinates: the only ones the mass matrix depends on
            rot = np.concatenate([np.arange(4) + sum(3 if t == "pos" else 4
                                                     for t in g.kind.slots[:j])
                                  for j, s in enumerate(g.kind.slots) if s == "rot"]
                                 + [np.zeros(0, np.int64)]).astype(np.int64)
            conv_of = None
            if g.kind.convective is not None:
                def conv_of(xl, vl, g=g):
                    return g.kind.convective(xl, vl, g.ref, g.mass, self.rotary)
            out.append(_Batch(mass_of, g.idx, rot, conv_of))
        pm, jr = self.point_mass, self.rot_inertia
        out.append(_Batch((lambda xl, reps: np.tile(pm, reps)[:, None, None] * np.eye(3)),
                          self.point_idx, np.zeros(0, np.int64), None))
        out.append(_Batch((lambda xl, reps: nodal_rotary_mass(xl, np.concatenate([jr] * reps))),
                          self.rot_idx, np.arange(4), None))
        return out

    def matrix(self, x: np.ndarray) -> sp.csc_matrix:
        """The mass matrix (n_coord, n_coord) at x."""
        return self.pattern.assemble([b.mass_of(x[b.idx], 1) for b in self.batches])

    def forces(self, x: np.ndarray, v: np.ndarray, a: np.ndarray):
        """``(blocks, M a + h)`` at (x, v, a): the mass blocks of every batch (element
        groups, point masses, rotary nodes; :meth:`assemble` makes M of them) and the inertia
        force (n_coord,), with the physical Euler-parameter velocities (:meth:`physical`)."""
        v = self.physical(x, v)
        n = self.num.n_coord
        blocks, force = [], np.zeros(n)
        for mass_of, idx, rot, conv_of in self.batches:
            xl, vl, al = x[idx], v[idx], a[idx]
            n_b, k = xl.shape
            if not n_b:
                blocks.append(np.zeros((0, k, k)))
                continue
            if not np.any(vl) or not rot.size:
                m = mass_of(xl, 1)
                blocks.append(m)
                force += scatter_add(n, idx, np.einsum("nij,nj->ni", m, al))
                continue
            if conv_of is not None:                  # analytic convective terms
                m = mass_of(xl, 1)
                blocks.append(m)
                mdot_v, grad = conv_of(xl, vl)
                force += scatter_add(n, idx, np.einsum("nij,nj->ni", m, al) + mdot_v
                                     - 0.5 * grad)
                continue
            # M at x, at x +- v and at x +- e_j for the r local Euler parameters (positions
            # do not enter M) in one call: the central differences give dM/dt v and
            # d(v^T M v)/dx exactly (M is quadratic in the Euler parameters)
            r = rot.size
            unit = np.zeros((r, k))
            unit[np.arange(r), rot] = 1.0
            steps = np.concatenate([np.zeros((1, k)), unit, -unit])
            shifted = np.concatenate([xl[None] + steps[:, None, :],
                                      (xl + vl)[None], (xl - vl)[None]])
            ms = mass_of(shifted.reshape(-1, k), 2 * r + 3).reshape(2 * r + 3, n_b, k, k)
            m = ms[0]
            blocks.append(m)
            dm_v = 0.5 * (ms[-2] - ms[-1])
            vmv = np.einsum("ni,jnik,nk->jn", vl, ms[1:2 * r + 1], vl)
            grad = np.zeros((n_b, k))
            grad[:, rot] = 0.5 * (vmv[:r] - vmv[r:]).T
            f = np.einsum("nij,nj->ni", m, al) + np.einsum("nij,nj->ni", dm_v, vl) - 0.5 * grad
            force += scatter_add(n, idx, f)
        return blocks, force

    def assemble(self, blocks) -> sp.csc_matrix:
        """M (n_coord, n_coord) from the blocks of :meth:`forces`."""
        return self.pattern.assemble(blocks)

    def iteration_parts(self, blocks, factor: float):
        """``factor * M`` for the Newton matrix: a dict of element-group blocks (keyed by
        the group's position in ``num.groups``) and the nodal masses over the unknowns
        (sparse, or None)."""
        n_g = len(self.groups)
        extra = {p: factor * b for p, b in zip(self.group_pos, blocks[:n_g])}
        nodal = (factor * self.nodal_pattern.assemble(blocks[n_g:]) if self.has_nodal
                 else None)
        return extra, nodal

    def kinetic_energy(self, x: np.ndarray, v: np.ndarray) -> float:
        v = self.physical(x, v)
        return 0.5 * float(v @ (self.matrix(x) @ v))


__all__ = ["Inertia"]

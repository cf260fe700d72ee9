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
``d(v^T M v)/dx`` computed analytically, and M is evaluated once; a kind with
``inertia_force`` (the BEAM, the RBEAM) gives ``M a + h`` without M, which is then formed
only for an iteration matrix.

Unlike :class:`spacarpy.solvers.linear.linearize.MassAssembler` (free coordinates only), the matrix
here spans all coordinates, so prescribed motions (INPUTX, INPUTR with their velocities and
accelerations) load the free coordinates through the coupling terms.
"""
from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from spacarpy.assembly import BlockPattern, scatter_add
from spacarpy.elements.base import SLOT_SIZE
from spacarpy.elements.beam_mass import nodal_rotary_mass
from spacarpy.rotation import tangent_part
from spacarpy.solvers.statics.nodal import nodal_masses


class _Batch(NamedTuple):
    """One batch of mass blocks: elements of one kind, point masses or rotary nodes."""

    mass_of: Callable             # (x_local, reps) -> (reps * n, k, k) mass blocks
    idx: np.ndarray               # (n, k) global coordinate indices
    rot: np.ndarray               # local Euler-parameter slots (M depends on them only)
    conv_of: Callable | None      # (x_local, v_local, reps) -> (dM/dt v, d(v^T M v)/dx)
    force_of: Callable | None     # (x_local, v_local, a_local, reps) -> M a + h, or None


def _tiled(data: np.ndarray, reps: int) -> np.ndarray:
    """Per-element data (element index first) for ``reps`` stacked copies of the
    elements."""
    if reps == 1:
        return data
    return np.concatenate([data] * reps)


#: Stacked copies of a group's reference record (its ``tile``) and EM values are kept for
#: the next call up to this many rows: the central differences of a small model's kinds
#: without analytic convective terms (RBEAM) tile the same few elements at every residual.
TILE_CACHE_ROWS = 4096


def _tiler(ref, mass) -> Callable:
    """``tiles(reps) -> (ref, mass)`` tiled ``reps`` times, kept for reuse where small."""
    cache = {1: (ref, mass)}

    def tiles(reps: int):
        hit = cache.get(reps)
        if hit is None:
            hit = (ref.tile(reps), _tiled(mass, reps))
            if len(mass) * reps <= TILE_CACHE_ROWS:
                cache[reps] = hit
        return hit
    return tiles


@cache
def _unit_steps(k: int, rot: tuple) -> np.ndarray:
    """The steps ``[0; e_j; -e_j]`` (2 r + 1, k) of the central differences in the local
    Euler-parameter slots ``rot`` (a constant per batch; read-only)."""
    r = len(rot)
    unit = np.zeros((r, k))
    unit[np.arange(r), list(rot)] = 1.0
    steps = np.concatenate([np.zeros((1, k)), unit, -unit])
    steps.flags.writeable = False
    return steps


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
            tiles = _tiler(g.ref, g.mass)

            def mass_of(xl, reps, g=g, tiles=tiles):
                return g.kind.mass(xl, *tiles(reps), self.rotary)
            # local Euler-parameter coordinates: the only ones the mass matrix depends on
            rot = np.concatenate([np.arange(4) + sum(SLOT_SIZE[t] for t in g.kind.slots[:j])
                                  for j, s in enumerate(g.kind.slots) if s == "rot"]
                                 + [np.zeros(0, np.int64)]).astype(np.int64)
            conv_of = force_of = None
            if g.kind.convective is not None:
                def conv_of(xl, vl, reps, g=g, tiles=tiles):
                    return g.kind.convective(xl, vl, *tiles(reps), self.rotary)
            if g.kind.inertia_force is not None:
                def force_of(xl, vl, al, reps, g=g, tiles=tiles):
                    return g.kind.inertia_force(xl, vl, al, *tiles(reps), self.rotary)
            out.append(_Batch(mass_of, g.idx, rot, conv_of, force_of))
        pm, jr = self.point_mass, self.rot_inertia
        out.append(_Batch((lambda xl, reps: _tiled(pm, reps)[:, None, None] * np.eye(3)),
                          self.point_idx, np.zeros(0, np.int64), None, None))
        out.append(_Batch((lambda xl, reps: nodal_rotary_mass(xl, _tiled(jr, reps))),
                          self.rot_idx, np.arange(4), None, None))
        return out

    def matrix(self, x: np.ndarray) -> sp.csc_matrix:
        """The mass matrix (n_coord, n_coord) at x."""
        return self.pattern.assemble([b.mass_of(x[b.idx], 1) for b in self.batches])

    def _local(self, b: _Batch, xl, vl, al, reps: int):
        """``(M, M a + h)`` of one batch at ``reps`` stacked configurations ``xl, vl, al``
        ((reps * n, k) each, physical velocities): the mass blocks (reps * n, k, k) and the
        local inertia forces (reps * n, k)."""
        mass_of, _, rot, conv_of, force_of = b
        n_b, k = xl.shape
        if force_of is not None:                     # the kind's own M a + h
            return mass_of(xl, reps), force_of(xl, vl, al, reps)
        if not np.any(vl) or not rot.size:
            m = mass_of(xl, reps)
            return m, np.einsum("nij,nj->ni", m, al)
        if conv_of is not None:                      # analytic convective terms
            m = mass_of(xl, reps)
            mdot_v, grad = conv_of(xl, vl, reps)
            return m, np.einsum("nij,nj->ni", m, al) + mdot_v - 0.5 * grad
        # M at x, at x +- v and at x +- e_j for the r local Euler parameters (positions
        # do not enter M) in one call: the central differences give dM/dt v and
        # d(v^T M v)/dx exactly (M is quadratic in the Euler parameters)
        r = rot.size
        steps = _unit_steps(k, tuple(rot.tolist()))
        shifted = np.concatenate([xl[None] + steps[:, None, :],
                                  (xl + vl)[None], (xl - vl)[None]])
        ms = mass_of(shifted.reshape(-1, k), (2 * r + 3) * reps).reshape(2 * r + 3, n_b, k, k)
        m = ms[0]
        dm_v = 0.5 * (ms[-2] - ms[-1])
        vmv = np.einsum("ni,jnik,nk->jn", vl, ms[1:2 * r + 1], vl)
        grad = np.zeros((n_b, k))
        grad[:, rot] = 0.5 * (vmv[:r] - vmv[r:]).T
        return m, (np.einsum("nij,nj->ni", m, al) + np.einsum("nij,nj->ni", dm_v, vl)
                   - 0.5 * grad)

    def forces(self, x: np.ndarray, v: np.ndarray, a: np.ndarray, blocks: bool = True):
        """``(blocks, M a + h)`` at (x, v, a): the mass blocks of every batch (element
        groups, point masses, rotary nodes; :meth:`assemble` makes M of them) and the inertia
        force (n_coord,), with the physical Euler-parameter velocities (:meth:`physical`).

        ``blocks=False``: a batch whose kind computes ``M a + h`` without its mass matrix
        (``inertia_force``) leaves its block None (:meth:`complete` fills it in when the
        Newton matrix needs it)."""
        v = self.physical(x, v)
        n = self.num.n_coord
        out, force = [], None
        for b in self.batches:
            idx = b.idx
            if not idx.shape[0]:                     # (no gathers for an empty batch)
                out.append(np.zeros((0, idx.shape[1], idx.shape[1])))
                continue
            xl, vl, al = x[idx], v[idx], a[idx]
            if not blocks and b.force_of is not None:
                m, f = None, b.force_of(xl, vl, al, 1)
            else:
                m, f = self._local(b, xl, vl, al, 1)
            out.append(m)
            f = scatter_add(n, idx, f)
            force = f if force is None else force + f
        return out, np.zeros(n) if force is None else force

    def complete(self, x: np.ndarray, blocks: list) -> list:
        """The mass blocks of :meth:`forces` with those it left out (None) evaluated at x."""
        return [b.mass_of(x[b.idx], 1) if m is None else m
                for b, m in zip(self.batches, blocks)]

    def tangent(self, x: np.ndarray, v: np.ndarray, a: np.ndarray, gamma_p: float,
                velocity_part: list | None = None):
        """The derivatives of the inertia force ``M(x) a + h(x, P(x) v)`` other than its
        ``M da``: ``d/dx + gamma_p d/dv`` per batch, local blocks (n, k, k) in the layout of
        :meth:`forces`' blocks (None for a batch whose force does not depend on x or v: no
        Euler parameters).

        The local force is a polynomial of degree two in each Euler parameter (M is
        quadratic in them, the convective terms linear; module docstring) and in the
        velocities, and positions do not enter it, so central differences with unit steps
        in the Euler parameters and in every velocity are its exact partial derivatives
        (to round-off), all configurations of a batch in one vectorized kernel call. The
        physical velocities ``P(q) v = v - q (q.v)/(q.q)`` (:meth:`physical`) add the
        chain-rule terms ``J_v P`` and ``J_v d(P v)/dq``.

        ``velocity_part``, a list, receives the blocks of ``d/dv`` alone per batch (zero
        blocks where the force does not depend on v; the rotating frame of a step needs
        them, solvers/dynamics/frame.py).
        """
        vp = self.physical(x, v)
        out = []
        for b in self.batches:
            xl, vl, al = x[b.idx], vp[b.idx], a[b.idx]
            n_b, k = xl.shape
            rot = b.rot
            if not n_b or not rot.size:
                out.append(None)
                if velocity_part is not None:
                    velocity_part.append(np.zeros((n_b, k, k)))
                continue
            r = rot.size
            ex = np.zeros((r, k))
            ex[np.arange(r), rot] = 1.0
            ev_ = np.eye(k)
            # with analytic convective terms the velocity copies need those only (M a does
            # not depend on v): the mass matrices of 2 r copies instead of 2 r + 2 k
            conv = b.conv_of is not None
            dx = np.concatenate([ex, -ex] + ([] if conv else [np.zeros((2 * k, k))]))
            dv = np.concatenate([np.zeros((2 * r, k))] + ([] if conv else [ev_, -ev_]))
            reps = len(dx)
            xs = (xl[None] + dx[:, None, :]).reshape(-1, k)
            vs = (vl[None] + dv[:, None, :]).reshape(-1, k)
            as_ = np.broadcast_to(al[None], (reps, n_b, k)).reshape(-1, k)
            # (the force alone: the mass blocks of these copies are not needed)
            f = (b.force_of(xs, vs, as_, reps) if b.force_of is not None
                 else self._local(b, xs, vs, as_, reps)[1]).reshape(reps, n_b, k)
            jx = np.zeros((n_b, k, k))
            jx[:, :, rot] = (0.5 * (f[:r] - f[r:2 * r])).transpose(1, 2, 0)
            if conv:
                vs = (vl[None] + np.concatenate([ev_, -ev_])[:, None, :]).reshape(-1, k)
                mdot, grad = b.conv_of(np.tile(xl, (2 * k, 1)), vs, 2 * k)
                f = (mdot - 0.5 * grad).reshape(2 * k, n_b, k)
                jv = (0.5 * (f[:k] - f[k:])).transpose(1, 2, 0)
            else:
                jv = (0.5 * (f[2 * r:2 * r + k] - f[2 * r + k:])).transpose(1, 2, 0)
            # the projection onto the physical velocities, node by node (slots of four)
            p = np.broadcast_to(np.eye(k), (n_b, k, k)).copy()
            dpv = np.zeros((n_b, k, k))
            raw = v[b.idx]
            for s in rot.reshape(-1, 4)[:, 0]:
                sl = slice(s, s + 4)
                q, w = xl[:, sl], raw[:, sl]
                qq = np.sum(q * q, axis=1)[:, None, None]
                qw = np.sum(q * w, axis=1)[:, None, None]
                p[:, sl, sl] -= q[:, :, None] * q[:, None, :] / qq
                dpv[:, sl, sl] = (-qw * np.eye(4) - q[:, :, None] * w[:, None, :]
                                  + 2.0 * qw * q[:, :, None] * q[:, None, :] / qq) / qq
            jvp = jv @ p
            out.append(jx + jv @ dpv + gamma_p * jvp)
            if velocity_part is not None:
                velocity_part.append(jvp)
        return out

    def roundoff_floor(self, x: np.ndarray, v: np.ndarray, a: np.ndarray,
                       blocks: list) -> np.ndarray:
        """The round-off of the inertia force ``M a + h`` (:meth:`forces`) at (x, v, a), per
        coordinate (n_coord,), in its units: eps times the sums of the absolute values of
        its terms, so that a cancellation (the centripetal ``M a`` against ``h`` of a
        spinning body) does not hide them.

        ``M a`` contributes ``|M| |a|``. M is quadratic in the Euler parameters of unit
        length, so ``|dM/dq_k| <= 2 |M|`` entrywise in size, and the convective terms
        ``h = (dM/dt) v - 1/2 d(v^T M v)/dq`` contribute ``2 |M| |v| max|dq/dt|`` and, on
        the Euler parameters, ``|v|^T |M| |v|``; and each element's force ``|M a + h|``
        itself (the rounding of its result, and a size of h where that estimate is
        short: the centripetal force of a rigid body on its position coordinates); summed
        over the elements of each coordinate. ``blocks``: the mass blocks at x (None
        entries are evaluated)."""
        vs = self.physical(x, v)
        vp = np.abs(vs)
        a_abs = np.abs(a)
        n = self.num.n_coord
        floor = np.zeros(n)
        for b, m in zip(self.batches, self.complete(x, blocks)):
            idx = b.idx
            if not idx.shape[0]:
                continue
            m_abs = np.abs(m)
            vl = vp[idx]
            local = np.abs(self._local(b, x[idx], vs[idx], a[idx], 1)[1])
            local += np.einsum("nij,nj->ni", m_abs, a_abs[idx])
            if b.rot.size:
                rate = vl[:, b.rot].max(axis=1)
                mv = np.einsum("nij,nj->ni", m_abs, vl)
                local += 2.0 * mv * rate[:, None]
                local[:, b.rot] += np.einsum("ni,ni->n", vl, mv)[:, None]
            floor += scatter_add(n, idx, local)
        return np.finfo(float).eps * floor

    def assemble(self, blocks) -> sp.csc_matrix:
        """M (n_coord, n_coord) from the blocks of :meth:`forces`."""
        return self.pattern.assemble(blocks)

    def iteration_parts(self, blocks, factor: float, tangent=None):
        """``factor * M`` for the Newton matrix, plus the blocks ``tangent`` of
        :meth:`tangent` where given: a dict of element-group blocks (keyed by the group's
        position in ``num.groups``) and the nodal masses over the unknowns (sparse, or
        None)."""
        n_g = len(self.groups)
        parts = [factor * b for b in blocks]
        if tangent is not None:
            parts = [p if t is None else p + t for p, t in zip(parts, tangent)]
        extra = dict(zip(self.group_pos, parts[:n_g]))
        nodal = self.nodal_pattern.assemble(parts[n_g:]) if self.has_nodal else None
        return extra, nodal

    def kinetic_energy(self, x: np.ndarray, v: np.ndarray, blocks: list | None = None
                       ) -> float:
        """``1/2 v^T M(x) v`` (physical velocities), batch by batch: ``M v`` is the inertia
        force at zero velocity and acceleration v, which a kind with ``inertia_force``
        evaluates without its mass matrix. ``blocks``: the mass blocks of :meth:`forces` at
        this x where the caller has them (a step's last residual; None entries are
        evaluated)."""
        v = self.physical(x, v)
        total = 0.0
        for i, b in enumerate(self.batches):
            if not b.idx.shape[0]:
                continue
            xl, vl = x[b.idx], v[b.idx]
            m = None if blocks is None else blocks[i]
            if m is not None:
                mv = np.einsum("nij,nj->ni", m, vl)
            elif b.force_of is not None:
                mv = b.force_of(xl, np.zeros_like(vl), vl, 1)
            else:
                mv = np.einsum("nij,nj->ni", b.mass_of(xl, 1), vl)
            total += float(np.sum(vl * mv))
        return 0.5 * total


__all__ = ["Inertia"]

"""The static equilibrium equations of one model: residual, Newton matrix, norms, reactions.

Unknowns are all free nodal coordinates x (positions and the four Euler parameters of each
orientation node) and one Lagrange multiplier per constraint. Constraints are

- rigid deformation modes: ``e_i(x) = 0`` (the multiplier *is* the stress resultant sigma_i),
- Euler-parameter normalization ``q.q - 1 = 0`` of every orientation node not fully fixed.

Equilibrium (Eq. 16/55 without inertia) with the constraint forces:

    r(x, mu) = sum_e D_e^T sigma_e + sum_n 2 q_n mu_n - f_ext(x) = 0,     c(x) = 0,

where ``sigma = S e`` for flexible (DYNE) and stiff released (RLSE + ESTIFF) modes and
``sigma = mu`` for rigid ones, and ``f_ext`` holds the dead forces and the generalized forces
``2 Lambda(q)^T T`` of dead moments, and those of follower loads (XFL,
:mod:`spacarpy.solvers.statics.follower`). Newton's matrix is the bordered tangent
``[[K_T, C^T], [C, 0]]`` with ``K_T = D^T S D + sum sigma_i d2e_i + 2 mu I4 - df_ext/dx``
(not symmetric with moments or follower loads: SuperLU factorizes it),
assembled on a fixed sparsity pattern (documented in docs/solver.md).

Held slips (rolling wheels, :mod:`spacarpy.solvers.statics.slips`) add ``S^T nu`` to the
residual, with their multipliers nu after mu in the multiplier vector, and border the Newton
matrix with their rows ``S`` (its K block gets ``d(S^T nu)/dx``): equilibrium for virtual
displacements that satisfy the slips, every increment with ``S dx = 0`` (docs/rolling.md).

:class:`StaticProblem` holds the model's fixed data (numbering, patterns, scales, the
kinematic corrector); the load is an argument of every evaluation (a
:class:`~spacarpy.solvers.statics.loads.LoadState`), never a field of the problem.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from spacarpy.assembly import BorderedPattern, border_slips, scatter_add
from spacarpy.elements.chunks import in_chunks
from spacarpy.errors import SolverError
from spacarpy.linalg import batch_matvec
from spacarpy.model import Model
from spacarpy.numbering import Numbering, number_model
from spacarpy.rotation import lambda_matrix, moment_matrix
from spacarpy.solvers.statics.kinematic_correction import KinematicCorrector
from spacarpy.solvers.statics.loads import Loads, LoadState
from spacarpy.solvers.statics.reduced import ReducedNewton
from spacarpy.solvers.statics.reduced import applies as reduced_applies
from spacarpy.solvers.statics.slips import held_slips

_EPS = float(np.finfo(float).eps)
#: Round-off floor of the residual in units of eps * (largest stiffness) * (length scale).
_FLOOR_FACTOR = 10.0
#: A residual above the tolerance is accepted only within this many times its measured
#: round-off floor (:meth:`StaticProblem.roundoff_floor`), and only with converged
#: increments: the floor is a sum of absolute values (an upper bound of the accumulated
#: round-off), the kernels add a few roundings per term.
FLOOR_MULTIPLE = 10.0


def _material_stiffness(D, S):
    """Element blocks ``D^T S D`` (n, n_ldof, n_ldof)."""
    return D.transpose(0, 2, 1) @ (S @ D)


@dataclass
class Timings:
    """Wall time spent per part of the Newton iterations (seconds) and iteration count."""

    kernels: float = 0.0
    assembly: float = 0.0
    solve: float = 0.0
    iterations: int = 0
    factorizations: int = 0     # sparse LU factorizations (Newton and kinematic correction)
    reuses: int = 0             # Newton solves with an earlier (supernodal) factorization
    total: float = 0.0


@dataclass
class Evaluation:
    """The equilibrium equations evaluated at one (x, mu) under one load."""

    states: list               # per element group: the kernel state (.e, .D, ...)
    sigmas: list               # per element group: stress resultants (n, n_def)
    r: np.ndarray
    c: np.ndarray
    f_int: np.ndarray
    f_ext: np.ndarray
    q_eu: np.ndarray
    load: LoadState            # the load it was evaluated under
    gravity_stiffness: list = field(default_factory=list)   # per group, or empty
    x: np.ndarray | None = None     # the state (the slip rows of the Newton matrix need it)
    nu: np.ndarray | None = None    # the held slips' multipliers (tangential contact forces)


class StaticProblem:
    """Residual, Newton matrix and norms of one model's static equations."""

    def __init__(self, model: Model, num: Numbering | None = None, deformations: str | None = None):
        self.model = model
        self.num = num if num is not None else number_model(model)
        self.variant = deformations or "modified"
        self.loads = Loads(model, self.num)
        self.pattern = BorderedPattern(self.num, self.loads.moment_rot,
                                       [(p.rows, p.cols) for p in self.loads.parts])
        num = self.num
        self.timings = Timings()
        # the kinematic correction after each Newton update (kinematic_correction.py)
        self.corrector = KinematicCorrector(num, self.variant, self.timings)
        # the held slips (WHEEL rolling without slip): velocity-level constraints whose
        # multipliers nu follow the constraint multipliers mu in the multiplier vector
        # ``[mu (n_constraint), nu (n_slip)]``; every Newton increment satisfies S dx = 0
        # (docs/rolling.md, "Statics and the linearizations at rest")
        self.slips = held_slips(num)
        # the kinematic correction projects onto the holonomic constraints only and would
        # move a model with slips along directions that slide: off with slips (Newton's
        # bordered steps converge without it)
        self.kinematic_correction = not self.slips
        # Newton steps without the Euler constraints where the model allows (reduced.py;
        # the tangent-space steps know holonomic constraints only)
        self.reduced = (ReducedNewton(self) if reduced_applies(self) and not self.slips
                        else None)
        if self.reduced is not None:
            self.corrector.use_reduced(self.reduced)
        self.has_commit = any(g.kind.commit is not None for g in num.groups)
        self._states_at = None                  # (x, kernel states at x), see evaluate()
        self.free = ~num.fixed_mask
        self.rot_mask = num.is_rotation_coord
        # the norms' weights, made once: forces (moments divided by the length scale) over
        # all and over the free coordinates, increments (positions divided by it)
        self._force_w = np.where(self.rot_mask, 1.0 / num.length_scale, 1.0)
        self._force_w_free = self._force_w[self.free]
        self._increment_w = np.where(self.rot_mask[self.free], 1.0, 1.0 / num.length_scale)
        # balances the constraint rows of the saddle-point matrix and sets the residual's
        # round-off floor: the largest element stiffness entry (N/m)
        smax = max([float(np.abs(g.S).max(initial=0.0)) for g in num.groups] + [0.0])
        self.scale = smax if smax > 0 else 1.0
        # the round-off of a position is relative to its magnitude, not to the model's size:
        # a model far from the origin has a residual floor that much higher
        pos = num.x0[num.pos_idx]
        self.position_magnitude = max(num.length_scale, float(np.abs(pos).max(initial=0.0)))
        # weights of the constraint violations in the residual norm: rigid length-like
        # modes relative to the length scale, angles and Euler normalizations absolute
        self.constraint_weight = np.concatenate(
            [np.where(np.asarray(g.kind.length_modes)[g.rigid_mode], 1.0 / num.length_scale,
                      1.0) for g in num.groups] + [np.ones(num.euler_nodes.size)])
        self._reaction_setup()

    @property
    def n_multiplier(self) -> int:
        """The length of the multiplier vector: constraints, then held slips."""
        return self.num.n_constraint + self.slips.n

    def slip_multipliers(self, mu) -> np.ndarray:
        """The held slips' multipliers nu of a multiplier vector (zeros where it holds the
        constraint multipliers only)."""
        n_con = self.num.n_constraint
        if len(mu) >= n_con + self.slips.n:
            return np.asarray(mu[n_con:n_con + self.slips.n], dtype=float)
        return np.zeros(self.slips.n)

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, x, mu, load: LoadState, states=None) -> Evaluation:
        """Deformations, stress resultants and residuals at (x, mu) under ``load``.

        ``states`` are the kernel states at exactly this x when the caller has them already
        (the kinematic correction ends with them); the states of the last evaluated x are
        kept and reused when x comes again (a stored step is evaluated once more for its
        results, and then once more as the next step's start)."""
        num = self.num
        t0 = time.perf_counter()
        nu = self.slip_multipliers(mu) if self.slips else None
        known = states
        if known is None and self._states_at is not None and np.array_equal(
                self._states_at[0], x):
            known = self._states_at[1]          # e.g. a stored step, then the next one's start
        states, sigmas, forces = [], [], []
        for i, g in enumerate(num.groups):
            st = (known[i] if known is not None
                  else g.kind.state(x[g.idx], g.ref, self.variant, g.prev))
            sigma = batch_matvec(g.S, st.e)
            if g.sigma0 is not None:            # ESIG pre-stress: sigma = sigma0 + S e
                sigma += g.sigma0
            if g.rigid_elem.size:
                sigma[g.rigid_elem, g.rigid_mode] = mu[g.rigid_slice]
            states.append(st)
            sigmas.append(sigma)
            forces.append((sigma[:, None, :] @ st.D)[:, 0, :])
        # the kernel states of the last configuration (they depend on x alone, unless a kind
        # keeps a persistent state that commit() updates)
        self._states_at = None if self.has_commit else (x.copy(), states)
        t1 = time.perf_counter()
        groups = num.groups
        f_int = (scatter_add(num.n_coord, groups[0].idx, forces[0]) if groups
                 else np.zeros(num.n_coord))
        for g, f_el in zip(groups[1:], forces[1:]):
            f_int += scatter_add(num.n_coord, g.idx, f_el)
        eu = self.num.euler_coords
        q_eu = x[eu]
        f_int[eu] += 2.0 * q_eu * mu[num.n_rigid:num.n_constraint, None]
        if nu is not None:
            f_int += self.slips.force(x, nu)            # S^T nu: the tangential forces
            for part in self.slips.parts:               # stored as the slip modes' sigma
                g = num.groups[part.group]
                vm = np.asarray(g.kind.velocity_modes)
                sigmas[part.group][part.elem, vm[part.slot]] = \
                    nu[part.offset:part.offset + part.elem.size]
        f_ext = load.force.copy()
        loads = self.loads
        if loads.moment_rot.size:
            q_m = x[num.rot_idx[loads.moment_rot]]
            f_ext[num.rot_idx[loads.moment_rot]] += 2.0 * np.einsum(
                "nab,nb->na", moment_matrix(load.moment), q_m)
        if load.user is not None:                   # a user routine's loads (USERSIG)
            f_ext += load.user(x, states)
        if load.follow:                             # follower loads (XFL, follower.py)
            f_part = loads.part_forces(x, load)
            if f_part is not None:
                f_ext += f_part
        gk = []
        if loads.has_gravity and load.gravity_factor:
            gv = load.gravity_factor * loads.gravity
            f_ext += load.gravity_factor * loads.point_weight
            for g_ in num.groups:
                if g_.kind.gravity is None:
                    gk.append(None)
                    continue
                fg, kg = g_.kind.gravity(x[g_.idx], g_.ref, g_.mass, gv)
                f_ext += scatter_add(num.n_coord, g_.idx, fg)
                gk.append(kg)
        r = (f_int - f_ext)[self.free]
        c = np.concatenate([st.e[g.rigid_elem, g.rigid_mode] - load.rigid_target[g.rigid_slice]
                            for g, st in zip(num.groups, states) if g.rigid_elem.size]
                           + [(q_eu * q_eu).sum(axis=1) - 1.0])
        self.timings.kernels += t1 - t0
        self.timings.assembly += time.perf_counter() - t1
        return Evaluation(states=states, sigmas=sigmas, r=r, c=c, f_int=f_int, f_ext=f_ext,
                          q_eu=q_eu, load=load, gravity_stiffness=gk, x=x, nu=nu)

    def matrix(self, ev: Evaluation, mu, material_only: bool = False, extra=None,
               scale: float | None = None):
        """The bordered Newton matrix at an evaluated state (CSC).

        With ``material_only`` the K block holds only the material stiffness D^T S D (K0 of
        Eq. 62); otherwise the full tangent K0 + G0 + N0 (geometric stiffness from the stress
        resultants and all constraint multipliers, load-dependent part of the moments of
        ``ev.load``).
        The constraint blocks are the same in both and scaled by ``self.scale`` (or
        ``scale``). ``extra`` adds blocks to the element blocks of some groups (``{group
        position: (n_elem, n_ldof, n_ldof)}``; the transient solver's ``beta' M``).
        """
        num = self.num
        t0 = time.perf_counter()
        k_el, euler_diag, mom_blocks = self.element_blocks(ev, mu, material_only, extra)
        t1 = time.perf_counter()
        A = self.pattern.assemble(k_el, euler_diag, mom_blocks,
                                  [st.D[g.rigid_elem, g.rigid_mode]
                                   for g, st in zip(num.groups, ev.states)],
                                  2.0 * ev.q_eu,
                                  scale=self.scale if scale is None else scale,
                                  load_blocks=self.load_blocks(ev, material_only))
        user = ev.load.user
        if not material_only and user is not None and user.static:
            A = self._with_user_tangent(A, ev)
        if self.slips:        # the slip rows, and the tangent of their forces d(S^T nu)/dx
            free = np.flatnonzero(self.free)
            k_add = None if material_only else self.slips.force_dx(ev.x, ev.nu, cols=free)
            A = border_slips(A, self.pattern.n_x, self.slips.jacobian(ev.x, cols=free),
                             k_add, scale=self.scale if scale is None else scale)
        self.timings.kernels += t1 - t0
        self.timings.assembly += time.perf_counter() - t1
        return A

    def load_blocks(self, ev: Evaluation, material_only: bool = False) -> list:
        """The load stiffness ``-df/dx`` of the follower load parts at ``ev`` (one block
        batch per part of :attr:`Loads.parts`; zeros with ``material_only``). Not
        symmetric: the Newton matrix with them is factorized by SuperLU (LU), never by a
        symmetric factorization (:func:`~spacarpy.solvers.statics.reduced.applies`)."""
        loads = self.loads
        if not loads.parts:
            return []
        if material_only or ev.x is None:
            return [np.zeros(p.rows.shape + (p.cols.shape[1],)) for p in loads.parts]
        return loads.part_blocks(ev.x, ev.load)

    def _with_user_tangent(self, A, ev: Evaluation):
        """The bordered matrix A plus ``-d f_user/dx`` of a user routine's loads in its
        free-coordinate block (the routine's derivative rows, or difference quotients:
        docs/user-routines.md)."""
        free = np.flatnonzero(self.free)
        k = ev.load.user.tangent(ev.x, ev.states, free)
        if k is None:
            return A
        k = sp.csc_matrix(-k.tocsr()[free])
        n = A.shape[0]
        indptr = np.concatenate([k.indptr, np.full(n - k.shape[1], k.indptr[-1])])
        return (A + sp.csc_matrix((k.data, k.indices, indptr), shape=(n, n))).tocsc()

    def element_blocks(self, ev: Evaluation, mu, material_only: bool = False, extra=None):
        """The K block's pieces: element tangents (one (n_elem, n_ldof, n_ldof) array per
        group), the Euler-node diagonal ``2 mu`` and the moment-load blocks (see
        :meth:`matrix`)."""
        num = self.num
        k_el = []
        for i, (g, st, sigma) in enumerate(zip(num.groups, ev.states, ev.sigmas)):
            if material_only or g.kind.tangent is None:
                k = in_chunks(_material_stiffness, len(st.D), st.D, g.S)
                if not material_only:
                    k += g.kind.hessian(st, sigma)
            else:
                k = g.kind.tangent(st, g.S, sigma)          # the same sum, in one pass
            if not material_only and ev.gravity_stiffness and \
                    ev.gravity_stiffness[i] is not None:
                k -= ev.gravity_stiffness[i]                 # -d f_gravity / dx
            if extra is not None and i in extra:
                k = k + extra[i]
            k_el.append(k)
        n_m = self.loads.moment_rot.size
        if material_only:
            euler_diag, mom_blocks = np.zeros(num.euler_nodes.size), np.zeros((n_m, 4, 4))
        else:
            euler_diag = 2.0 * mu[self.num.n_rigid:self.num.n_constraint]
            mom_blocks = -2.0 * moment_matrix(ev.load.moment) if n_m else np.zeros((0, 4, 4))
        return k_el, euler_diag, mom_blocks

    # ------------------------------------------------------------------ norms
    def force_level(self, *forces) -> float:
        """Largest entry of the given force vectors (n_coord,), the generalized forces on
        Euler parameters (moments) divided by the length scale."""
        w = self._force_w
        return max([float(np.abs(f * w).max(initial=0.0)) for f in forces] + [0.0])

    def residual_norm(self, r, c, f_int, f_ext, level: float | None = None
                      ) -> tuple[float, float]:
        """Scaled residual and its round-off floor.

        Forces are taken relative to the force level (max of external and internal forces,
        :meth:`force_level`, or the given ``level``), constraint violations relative to 1
        (rigid modes divided by the length scale). The floor is what double precision can
        resolve: the stiffest element stiffness times the round-off of the coordinates (of
        the largest of the model's size and its distance from the origin); a residual below
        it cannot be reduced further by any iteration.
        """
        if level is None:
            level = self.force_level(f_ext, f_int)
        rr = np.abs(r * self._force_w_free).max(initial=0.0)
        rel = rr / level if level > 0 else (0.0 if rr == 0 else np.inf)
        cw = self.constraint_weight
        floor = (_FLOOR_FACTOR * _EPS * getattr(self, "scale", 0.0)
                 * self.position_magnitude / level if level > 0 else 0.0)
        return max(rel, np.abs(c * cw).max(initial=0.0)), floor

    def roundoff_floor(self, ev: Evaluation, x, mu) -> tuple[np.ndarray, np.ndarray]:
        """The residual's round-off floor measured at one state, per equation: what double
        precision cannot resolve in each free coordinate's force balance and each
        constraint (docs/solver.md, "Convergence").

        A force residual ``r_i = sum_e (D_e^T sigma_e)_i - f_ext_i`` carries the round-off
        of its sum, ``eps sum_e |D_e|^T |sigma_e|``, and that of the stress resultants
        computed from coordinates stored to ``eps |x|``: ``eps sum_e |D_e|^T |S_e| |D_e|
        |x_e|``; a constraint carries ``eps |D_c| |x|`` (rigid modes) or ``4 eps`` (an
        Euler normalization). Returns ``(floor_r, floor_c)`` in the units of ``ev.r`` and
        ``ev.c``, without a safety factor."""
        num = self.num
        floor = np.abs(ev.f_ext).copy()
        floor_c = []
        for g, st, sigma in zip(num.groups, ev.states, ev.sigmas):
            if not len(st.D):
                continue
            d_abs = np.abs(st.D)
            x_abs = np.abs(x[g.idx])
            de = batch_matvec(d_abs, x_abs)                    # round-off of e / eps
            ds = np.abs(sigma) + batch_matvec(np.abs(g.S), de)
            floor += scatter_add(num.n_coord, g.idx, (ds[:, None, :] @ d_abs)[:, 0, :])
            if g.rigid_elem.size:
                floor_c.append(de[g.rigid_elem, g.rigid_mode])
        eu = num.euler_coords
        if eu.size:
            floor[eu] += 2.0 * np.abs(ev.q_eu) * np.abs(mu[num.n_rigid:num.n_constraint, None])
        if ev.nu is not None:
            floor += np.abs(self.slips.force(x, np.abs(ev.nu)))
        floor_c.append(np.full(num.euler_nodes.size, 4.0))
        return _EPS * floor[self.free], _EPS * np.concatenate(floor_c)

    def at_floor(self, ev: Evaluation, x, mu, tol: float) -> bool:
        """Whether every equation of ``ev`` meets the tolerance (scaled as in
        :meth:`residual_norm`) or lies within :data:`FLOOR_MULTIPLE` times its measured
        round-off floor (:meth:`roundoff_floor`): the residual cannot be reduced further."""
        floor_r, floor_c = self.roundoff_floor(ev, x, mu)
        return self.within_floor(ev.r, ev.c, floor_r, floor_c,
                                 self.force_level(ev.f_ext, ev.f_int), tol)

    def within_floor(self, r, c, floor_r, floor_c, level: float, tol: float) -> bool:
        """Whether every force residual r (free coordinates) meets ``tol`` relative to
        ``level`` (weighted as in :meth:`residual_norm`) or lies within
        :data:`FLOOR_MULTIPLE` times its floor ``floor_r``, and every constraint c likewise
        (``floor_c``); the floors as :meth:`roundoff_floor` gives them (a transient adds
        its inertia forces' own)."""
        r_ok = (np.abs(r) * self._force_w_free <= tol * level) | (
            np.abs(r) <= FLOOR_MULTIPLE * floor_r)
        c_ok = (np.abs(c) * self.constraint_weight <= tol) | (
            np.abs(c) <= FLOOR_MULTIPLE * floor_c)
        return bool(r_ok.all() and c_ok.all())

    def clears_floor(self, floor_r, floor_c, level: float, tol: float) -> bool:
        """Whether ``tol`` lies above :data:`FLOOR_MULTIPLE` times the floor of every force
        equation (relative to ``level``, weighted as in :meth:`residual_norm`) and of every
        constraint: then a converged residual meets or misses the tolerance by more than
        round-off can change."""
        return bool(np.all(FLOOR_MULTIPLE * floor_r * self._force_w_free < tol * level)
                    and np.all(FLOOR_MULTIPLE * floor_c * self.constraint_weight < tol))

    def accepted_by(self, ev: Evaluation, x, mu, res: float, tol: float,
                    level: float | None = None) -> str:
        """How a converged state is recorded (``/static/converged_by``): "tolerance" where
        its residual ``res`` meets ``tol`` and ``tol`` clears every equation's floor
        (:meth:`clears_floor`, forces relative to ``level``, default :meth:`force_level`),
        else "floor" whichever side of ``tol`` the residual fell: where the tolerance does
        not clear the floor, that side is round-off (the flag would flip with the BLAS
        thread count), docs/solver.md, Convergence."""
        if res > tol:
            return "floor"
        if level is None:
            level = self.force_level(ev.f_ext, ev.f_int)
        clear = self.clears_floor(*self.roundoff_floor(ev, x, mu), level, tol)
        return "tolerance" if clear else "floor"

    def null_state(self, x, load: LoadState) -> bool:
        """Whether (x, load) is the unloaded initial configuration of a model without
        pre-stress or history: no force, moment or gravity, no prescribed motion, x = x0.
        That state is its own equilibrium by definition (every deformation is zero); its
        residual is pure round-off, measured against :attr:`force_scale`."""
        num = self.num
        idx, target = num.prescribed_state(load.a, load.s)
        return bool(not np.any(load.force) and not np.any(load.moment)
                    and load.user is None and not any(np.any(f) for f in load.follow)
                    and np.array_equal(num.x0[idx], target)
                    and not (self.loads.has_gravity and load.gravity_factor)
                    and not np.any(load.rigid_target) and not self.has_commit
                    and all(g.sigma0 is None or not np.any(g.sigma0) for g in num.groups)
                    and np.array_equal(x, num.x0))

    @property
    def force_scale(self) -> float:
        """The model's internal force scale (N): the largest element stiffness entry times
        the length scale, the force of a unit strain of the stiffest element."""
        return self.scale * self.num.length_scale

    def increment_norm(self, dx) -> float:
        return float(np.abs(dx * self._increment_w).max(initial=0.0))

    # ------------------------------------------------------------------ reactions
    def _reaction_setup(self):
        """Which reaction components are reported: one per fixed position coordinate, and
        for an orientation node with fixed Euler parameters the moment components whose
        lambda_1..3 are fixed (all three when lambda_0 is fixed too). A planar model reports
        Fx, Fy and Mz only (its out-of-plane coordinates are held by the plane, not by FIX)."""
        num, model = self.num, self.model
        comp_node, comp_name, self._reac_pos, self._reac_rot = [], [], [], []
        held = num.fixed_mask & ~num.planar_mask if num.planar_mask.size else num.fixed_mask
        for i, n in enumerate(model.position_ids):
            for c in range(3):
                if held[num.pos_idx[i, c]]:
                    comp_node.append(int(n))
                    comp_name.append("F" + "xyz"[c])
                    self._reac_pos.append(num.pos_idx[i, c])
        for i, n in enumerate(model.orientation_ids):
            fx = held[num.rot_idx[i]]
            if model.planar:                   # only the moment about z
                comps = [2] if fx.any() else []
            else:
                comps = [0, 1, 2] if fx[0] and fx.any() else [c - 1 for c in (1, 2, 3) if fx[c]]
            for c in comps:
                comp_node.append(int(n))
                comp_name.append("M" + "xyz"[c])
                self._reac_rot.append((i, c))
        self.reaction_node = np.array(comp_node, dtype=np.int64)
        self.reaction_component = comp_name

    def reactions(self, x, f_int, f_ext) -> np.ndarray:
        """Reaction forces (N) and moments (N m) at the fixed coordinates, global axes."""
        g = f_int - f_ext
        out = [g[i] for i in self._reac_pos]
        if self._reac_rot:
            rows = sorted({i for i, _ in self._reac_rot})
            idx = self.num.rot_idx[rows]
            moments = 0.5 * np.einsum("nka,na->nk", lambda_matrix(x[idx]), g[idx])
            where = {r: k for k, r in enumerate(rows)}
            out += [moments[where[i], c] for i, c in self._reac_rot]
        return np.array(out, dtype=float)

    def check_element_range(self, states):
        """Kind-specific validity checks of a converged state (BEAM: Eq. 7 saturation)."""
        for g, st in zip(self.num.groups, states):
            if g.kind.check is None:
                continue
            hit = g.kind.check(st, g.ref)
            if hit is not None:
                i, message = hit
                raise SolverError(f"spurious equilibrium: {g.keyword} {int(g.ids[i])} "
                                  f"{message}")

    def commit(self, x, mu, load: LoadState):
        """Let the element kinds update their persistent state after a converged step."""
        ev = self.evaluate(x, mu, load)
        self.commit_states(ev.states)
        return ev

    def commit_states(self, states) -> None:
        """:meth:`commit` with the kernel states of the converged x already in hand (per
        element group), as a transient step has them from its last residual."""
        for g, st in zip(self.num.groups, states):
            if g.kind.commit is not None:
                g.kind.commit(st, g.prev)

    def element_results(self, ev: Evaluation) -> tuple[dict, dict]:
        """The deformations and stress resultants of every element kind at an evaluated
        state: two dicts keyword -> (n_elem, n_def) (the rigid modes' stress resultants
        are their multipliers, times the kind's ``stress_sign``)."""
        deformation, stress = {}, {}
        for g, st, sig in zip(self.num.groups, ev.states, ev.sigmas):
            if g.kind.stress_sign:                  # the WHEEL's contact forces
                sig = sig * np.asarray(g.kind.stress_sign)
            deformation[g.keyword], stress[g.keyword] = st.e, sig
        return deformation, stress

    def correct_kinematics(self, x_lin, dx, states, **kw):
        """The kinematic correction of a Newton update ``dx`` (see
        :meth:`KinematicCorrector.correct
        <spacarpy.solvers.statics.kinematic_correction.KinematicCorrector.correct>`)."""
        return self.corrector.correct(x_lin, dx, states, self.increment_norm(dx), **kw)

    def normalize(self, x):
        """Project Euler parameters exactly onto q.q = 1 (after convergence)."""
        x = x.copy()
        idx = self.num.euler_coords
        q = x[idx]
        x[idx] = q / np.linalg.norm(q, axis=1)[:, None]
        return x


__all__ = ["Evaluation", "StaticProblem", "Timings"]

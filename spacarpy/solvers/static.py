"""Non-linear static analysis: Newton-Raphson with load stepping and automatic step cutting.

Formulation (documented in docs/solver.md)
------------------------------------------
Unknowns are all free nodal coordinates x (positions and the four Euler parameters of each
orientation node) and one Lagrange multiplier per constraint. Constraints are

- rigid deformation modes: ``e_i(x) = 0`` (the multiplier *is* the stress resultant sigma_i),
- Euler-parameter normalization ``q.q - 1 = 0`` of every orientation node not fully fixed.

Equilibrium (Eq. 16/55 without inertia) with the constraint forces:

    r(x, mu) = sum_e D_e^T sigma_e + sum_n 2 q_n mu_n - f_ext(x) = 0,     c(x) = 0,

where ``sigma = S e`` for flexible (DYNE) and stiff released (RLSE + ESTIFF) modes and
``sigma = mu`` for rigid ones, and ``f_ext`` holds the dead forces and the generalized forces
``2 Lambda(q)^T T`` of dead moments. Newton's matrix is the bordered tangent
``[[K_T, C^T], [C, 0]]`` with ``K_T = D^T S D + sum sigma_i d2e_i + 2 mu I4 - df_ext/dx``,
assembled on a fixed sparsity pattern and factorized with SuperLU; where the only constraints
are Euler normalizations the same step is solved in their tangent space with an LDL^T
(:mod:`spacarpy.solvers.reduced`).

A step is converged when the scaled residual and the scaled last increment are both below
the tolerance (forces relative to the load and internal-force level, moments divided by the
model's length scale; positions relative to that length, Euler parameters absolute). A
failing step (no convergence within ``max_iter``, divergence, a non-finite value) is cut in
half and retried, down to ``1/2**max_cuts`` of the requested increment, then a
:class:`~spacarpy.errors.ConvergenceError` names the step and the residual history.
A singular Newton matrix is diagnosed (:mod:`spacarpy.solvers.diagnose`) and reported as a
:class:`~spacarpy.errors.ModelError` naming the nodes/elements involved.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.assembly import BlockPattern, BorderedPattern, scatter_add
from spacarpy.elements.chunks import in_chunks
from spacarpy.errors import ConvergenceError, ModelError, SolverError
from spacarpy.linalg import batch_matvec
from spacarpy.model import Model
from spacarpy.numbering import Numbering, number_model
from spacarpy.rotation import lambda_matrix, moment_matrix
from spacarpy.solvers.reduced import ReducedNewton
from spacarpy.solvers.reduced import applies as reduced_applies
from spacarpy.solvers.sparse import FactorizationError, SPDFactorization
from spacarpy.solvers.triangular import BlockTriangular

log = logging.getLogger(__name__)

#: Round-off floor of the residual in units of eps * (largest stiffness) * (length scale).
_FLOOR_FACTOR = 10.0


class _SquareJacobian:
    """The kinematic correction's Jacobian ``W = [D / scale; 2 q^T]`` as a square sparse
    matrix, for models with exactly as many deformations and Euler normalizations as free
    coordinates (trees of elements: every element adds its end node). The Gauss-Newton step
    is solved as ``W step = g`` instead of through the normal equations ``W^T W``, whose
    condition number is that of W squared: on a 10^5-element cantilever W^T W is beyond
    double precision and its steps are noise. A tree's W is block triangular, and is solved
    by block forward substitution (:class:`~spacarpy.solvers.triangular.BlockTriangular`,
    0.2 s per factorization at 10^5 elements where SuperLU took 0.8-1.1 s); other square
    patterns by SuperLU's LU with partial pivoting (:class:`_SparseLU`).

    Like :class:`_NormalEquations`: ``factorize(w_e, wq, timings)`` returns
    ``step(g_e, g_q, w_e, wq)``; ``stale_after`` is the Newton increment after which a kept
    factorization is dropped, ``jacobian_each_step`` whether ``step`` needs the current W."""

    stale_after = 1e-2          # its chord steps still contract fast after such increments
    jacobian_each_step = False

    @staticmethod
    def applies(num) -> bool:
        n_rows = sum(g.idx.shape[0] * g.scale.shape[1] for g in num.groups)
        return num.n_unknown > 0 and n_rows + num.euler_nodes.size == num.n_unknown

    def __init__(self, num, triangular: bool = True):
        rows, cols, off = [], [], 0
        for g in num.groups:
            n_e, n_def = g.scale.shape
            r = off + np.arange(n_e * n_def).reshape(n_e, n_def)
            rows.append(np.broadcast_to(r[:, :, None], (n_e, n_def, g.idx.shape[1])).ravel())
            cols.append(np.broadcast_to(num.unknown_of[g.idx][:, None, :],
                                        (n_e, n_def, g.idx.shape[1])).ravel())
            off += n_e * n_def
        eu = num.rot_idx[num.euler_nodes]
        rows.append(np.repeat(off + np.arange(eu.shape[0]), 4))
        cols.append(num.unknown_of[eu].ravel())
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        keep = np.flatnonzero(cols >= 0)            # entries in fixed columns are dropped
        n = num.n_unknown
        self.keep = keep
        # a tree's W is block triangular (supports outwards): block forward substitution,
        # its structure found once from the pattern (triangular.py); SuperLU where it is not
        self.solver = None
        if triangular:
            try:
                self.solver = BlockTriangular(rows[keep], cols[keep], n)
            except ValueError as exc:
                log.debug("kinematic correction: not block triangular (%s), SuperLU", exc)
        if self.solver is None:
            self.solver = _SparseLU(rows[keep], cols[keep], n)

    def _entries(self, w_e, wq) -> np.ndarray:
        """W's entries, in the pattern's order, from the element blocks and Euler rows."""
        return np.concatenate([w.ravel() for w in w_e] + [wq.ravel()])[self.keep]

    def regular(self, w_e, wq) -> bool:
        """Whether W is block triangular with well-conditioned diagonal blocks (False when
        its structure is not block triangular: then it cannot tell)."""
        return (isinstance(self.solver, BlockTriangular)
                and self.solver.regular(self._entries(w_e, wq)))

    def factorize(self, w_e, wq, timings):
        """Factorize W for the element blocks ``w_e`` (per group (n_e, n_def, n_ldof)) and the
        Euler rows ``wq`` (n_eu, 4)."""
        t0 = time.perf_counter()
        data = self._entries(w_e, wq)
        timings.assembly += time.perf_counter() - t0
        solve = self.solver.factorize(data)

        def step(g_e, g_q, w_e, wq):
            out = solve(np.concatenate([v.ravel() for v in g_e] + [g_q]))
            if not np.all(np.isfinite(out)):
                raise FactorizationError("non-finite Gauss-Newton step")
            return out
        return step


class _SparseLU:
    """SuperLU (partial pivoting, COLAMD) for square matrices with the pattern ``(rows,
    cols)``; the same interface as :class:`~spacarpy.solvers.triangular.BlockTriangular`:
    ``factorize(data) -> solve``."""

    def __init__(self, rows, cols, n: int):
        # the CSC layout once: which entry of ``data`` fills each data slot (no duplicates:
        # a row belongs to one element or node)
        order = sp.csc_matrix((np.arange(1, rows.size + 1, dtype=float), (rows, cols)),
                              shape=(n, n))
        self.source = order.data.astype(np.int64) - 1
        self.indices, self.indptr, self.n = order.indices, order.indptr, n

    def factorize(self, data):
        mat = sp.csc_matrix((data[self.source], self.indices, self.indptr),
                            shape=(self.n, self.n))
        try:
            return spla.splu(mat, permc_spec="COLAMD").solve
        except RuntimeError as exc:              # singular: e.g. a straight-line start
            raise FactorizationError(str(exc)) from None


class _NormalEquations:
    """The kinematic correction's Gauss-Newton step from the normal equations
    ``W^T W step = W^T g`` (least squares: closed loops, more deformations than unknowns),
    factorized by QDLDL (:class:`~spacarpy.solvers.sparse.SPDFactorization`). Same interface
    as :class:`_SquareJacobian`; the right side is formed with the current W."""

    stale_after = 1e-3
    jacobian_each_step = True

    def __init__(self, num):
        self.num = num
        self.free = ~num.fixed_mask
        self.eu = num.rot_idx[num.euler_nodes]
        self.pattern = BlockPattern(
            num.n_unknown, [num.unknown_of[g.idx] for g in num.groups]
            + [num.unknown_of[self.eu]], upper=True)
        self.factor = SPDFactorization()

    def factorize(self, w_e, wq, timings):
        t0 = time.perf_counter()
        m = self.pattern.assemble([w.transpose(0, 2, 1) @ w for w in w_e]
                                  + [wq[:, :, None] * wq[:, None, :]], diag_shift=1e-12)
        timings.assembly += time.perf_counter() - t0
        solve = self.factor.factorize(m)
        num = self.num

        def step(g_e, g_q, w_e, wq):
            rhs = scatter_add(num.n_coord, self.eu, wq * g_q[:, None])
            for g, w, ge in zip(num.groups, w_e, g_e):
                rhs += scatter_add(num.n_coord, g.idx, batch_matvec(w.transpose(0, 2, 1), ge))
            return solve(rhs[self.free])
        return step


def _material_stiffness(D, S):
    """Element blocks ``D^T S D`` (n, n_ldof, n_ldof)."""
    return D.transpose(0, 2, 1) @ (S @ D)


@dataclass
class StaticStep:
    """One converged (stored) load step."""

    load_factor: float
    x: np.ndarray             # (n_coord,) all nodal coordinates
    deformation: np.ndarray   # (n_elem, 6)
    stress: np.ndarray        # (n_elem, 6) stress resultants, multipliers for rigid modes
    reaction: np.ndarray      # (n_reac,)
    iterations: int
    residual: float
    mu: np.ndarray | None = None   # (n_constraint,) constraint multipliers
    group_deformation: dict = field(default_factory=dict)   # keyword -> (n, n_def)
    group_stress: dict = field(default_factory=dict)        # keyword -> (n, n_def)


@dataclass
class Timings:
    """Wall time spent per part of the Newton iterations (seconds) and iteration count."""

    kernels: float = 0.0
    assembly: float = 0.0
    solve: float = 0.0
    iterations: int = 0
    factorizations: int = 0     # sparse LU factorizations (Newton and kinematic correction)
    total: float = 0.0


@dataclass
class StaticOptions:
    """Solver settings; defaults come from the deck's ITERSTEP line."""

    max_iter: int = 10
    tol: float = 5e-7
    n_steps: int = 1
    n_init: int = 1
    max_cuts: int = 12
    deformations: str = "modified"
    bifurcation: str = "off"        # stability check of the path: off, warn, switch


class Loads:
    """Dead loads of the model split into XF and DELXF parts, in global coordinates."""

    def __init__(self, model: Model, num: Numbering):
        pos_row = {int(n): i for i, n in enumerate(model.position_ids)}
        rot_row = {int(n): i for i, n in enumerate(model.orientation_ids)}
        self.force = {k: np.zeros(num.n_coord) for k in ("XF", "DELXF")}
        moment = {k: np.zeros((model.orientation_ids.size, 3)) for k in ("XF", "DELXF")}
        for ld in model.loads:
            n = int(ld.node)
            if n in pos_row:
                self.force[ld.kind][num.pos_idx[pos_row[n]]] += ld.value
            else:
                moment[ld.kind][rot_row[n]] += ld.value
        loaded = np.flatnonzero(np.any(moment["XF"] != 0, axis=1)
                                | np.any(moment["DELXF"] != 0, axis=1))
        self.moment_rot = loaded                            # orientation-node indices
        self.moment = {k: v[loaded] for k, v in moment.items()}
        self.has_xf = bool(np.any(self.force["XF"]) or np.any(self.moment["XF"]))
        # gravity (applied by StaticProblem) belongs to the initial load, reached in phase A
        self.has_xf = self.has_xf or bool(np.any(model.gravity))
        self.any = self.has_xf or bool(np.any(self.force["DELXF"]) or np.any(self.moment["DELXF"]))

    def at(self, a: float, s: float):
        """Force vector and moments (n_m, 3) for ``a * XF + s * DELXF``."""
        return (a * self.force["XF"] + s * self.force["DELXF"],
                a * self.moment["XF"] + s * self.moment["DELXF"])


class StaticProblem:
    """Residual, Newton matrix and solution state of one model's static problem."""

    def __init__(self, model: Model, num: Numbering | None = None, deformations: str | None = None):
        self.model = model
        self.num = num if num is not None else number_model(model)
        self.variant = deformations or model.deformations
        self.loads = Loads(model, self.num)
        self.pattern = BorderedPattern(self.num, self.loads.moment_rot)
        num = self.num
        # the kinematic correction's Gauss-Newton system, and the step() of its kept
        # factorization
        self._kin = (_SquareJacobian(num) if _SquareJacobian.applies(num)
                     else _NormalEquations(num))
        self.kinematic_correction = True
        self._kin_solve = None
        # Newton steps without the Euler constraints where the model allows (reduced.py)
        self.reduced = ReducedNewton(self) if reduced_applies(self) else None
        # round-off level of the scaled deformation mismatch in correct_kinematics: the
        # coordinates' round-off relative to the shortest element scale
        min_scale = min([float(np.min(g.scale, initial=np.inf)) for g in num.groups]
                        + [np.inf])
        self.kin_floor = 64 * np.finfo(float).eps * num.length_scale / (
            min_scale if np.isfinite(min_scale) and min_scale > 0 else 1.0)
        self._initial_check = False
        self.has_commit = any(g.kind.commit is not None for g in num.groups)
        self._states_at = None                  # (x, kernel states at x), see evaluate()
        # gravity: applied with the initial load (factor a of the load path), then constant
        self.gravity = np.asarray(model.gravity, dtype=float)
        self.gravity_factor = 1.0
        self.has_gravity = bool(np.any(self.gravity))
        # values the rigid-mode constraints hold at the current load parameters (nonzero
        # only for prescribed deformations, INPUTE/DELINPE); set by move_prescribed
        self.rigid_target = np.zeros(num.n_rigid)
        g_nodes = [(int(m.node), float(m.values[0])) for m in model.nodal_masses
                   if len(m.values) == 1]
        pos_row = {int(n): i for i, n in enumerate(model.position_ids)}
        self.point_weight = np.zeros(num.n_coord)
        for n, m in g_nodes:
            self.point_weight[num.pos_idx[pos_row[n]]] += m * self.gravity
        self.free = ~num.fixed_mask
        self.rot_mask = num.is_rotation_coord
        self.timings = Timings()
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

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, x, mu, force, moment, states=None) -> "_Eval":
        """Deformations, stress resultants and residuals at (x, mu) under the given load.

        ``states`` are the kernel states at exactly this x when the caller has them already
        (the kinematic correction ends with them); the states of the last evaluated x are
        kept and reused when x comes again (a stored step is evaluated once more for its
        results, and then once more as the next step's start)."""
        num = self.num
        t0 = time.perf_counter()
        known = states
        if known is None and self._states_at is not None and np.array_equal(
                self._states_at[0], x):
            known = self._states_at[1]          # e.g. a stored step, then the next one's start
        states, sigmas, forces = [], [], []
        for i, g in enumerate(num.groups):
            st = (known[i] if known is not None
                  else g.kind.state(x[g.idx], g.ref, self.variant, g.prev))
            sigma = batch_matvec(g.S, st.e)
            sigma[g.rigid_elem, g.rigid_mode] = mu[g.rigid_slice]
            states.append(st)
            sigmas.append(sigma)
            forces.append((sigma[:, None, :] @ st.D)[:, 0, :])
        # the kernel states of the last configuration (they depend on x alone, unless a kind
        # keeps a persistent state that commit() updates)
        self._states_at = None if self.has_commit else (x.copy(), states)
        t1 = time.perf_counter()
        f_int = np.zeros(num.n_coord)
        for g, f_el in zip(num.groups, forces):
            f_int += scatter_add(num.n_coord, g.idx, f_el)
        q_eu = x[num.rot_idx[num.euler_nodes]]
        f_int[num.rot_idx[num.euler_nodes]] += 2.0 * q_eu * mu[num.n_rigid:, None]
        f_ext = force.copy()
        if self.loads.moment_rot.size:
            q_m = x[num.rot_idx[self.loads.moment_rot]]
            f_ext[num.rot_idx[self.loads.moment_rot]] += 2.0 * np.einsum(
                "nab,nb->na", moment_matrix(moment), q_m)
        gk = []
        if self.has_gravity and self.gravity_factor:
            gv = self.gravity_factor * self.gravity
            f_ext += self.gravity_factor * self.point_weight
            for g_, st in zip(num.groups, states):
                if g_.kind.gravity is None:
                    gk.append(None)
                    continue
                fg, kg = g_.kind.gravity(x[g_.idx], g_.ref, g_.mass, gv)
                f_ext += scatter_add(num.n_coord, g_.idx, fg)
                gk.append(kg)
        r = (f_int - f_ext)[self.free]
        c = np.concatenate([st.e[g.rigid_elem, g.rigid_mode] - self.rigid_target[g.rigid_slice]
                            for g, st in zip(num.groups, states)]
                           + [np.sum(q_eu * q_eu, axis=1) - 1.0])
        self.timings.kernels += t1 - t0
        self.timings.assembly += time.perf_counter() - t1
        return _Eval(states=states, sigmas=sigmas, r=r, c=c, f_int=f_int, f_ext=f_ext,
                     q_eu=q_eu, gravity_stiffness=gk)

    def matrix(self, ev: "_Eval", mu, moment, material_only: bool = False, extra=None,
               scale: float | None = None):
        """The bordered Newton matrix at an evaluated state (CSC).

        With ``material_only`` the K block holds only the material stiffness D^T S D (K0 of
        Eq. 62); otherwise the full tangent K0 + G0 + N0 (geometric stiffness from the stress
        resultants and all constraint multipliers, load-dependent part of the moments).
        The constraint blocks are the same in both and scaled by ``self.scale`` (or
        ``scale``). ``extra`` adds blocks to the element blocks of some groups (``{group
        position: (n_elem, n_ldof, n_ldof)}``; the transient solver's ``beta' M``).
        """
        num = self.num
        t0 = time.perf_counter()
        k_el, euler_diag, mom_blocks = self.element_blocks(ev, mu, moment, material_only, extra)
        t1 = time.perf_counter()
        A = self.pattern.assemble(k_el, euler_diag, mom_blocks,
                                  [st.D[g.rigid_elem, g.rigid_mode]
                                   for g, st in zip(num.groups, ev.states)],
                                  2.0 * ev.q_eu,
                                  scale=self.scale if scale is None else scale)
        self.timings.kernels += t1 - t0
        self.timings.assembly += time.perf_counter() - t1
        return A

    def element_blocks(self, ev: "_Eval", mu, moment, material_only: bool = False,
                       extra=None):
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
            euler_diag = 2.0 * mu[num.n_rigid:]
            mom_blocks = -2.0 * moment_matrix(moment) if n_m else np.zeros((0, 4, 4))
        return k_el, euler_diag, mom_blocks

    # ------------------------------------------------------------------ norms
    def force_level(self, *forces) -> float:
        """Largest entry of the given force vectors (n_coord,), the generalized forces on
        Euler parameters (moments) divided by the length scale."""
        w = np.where(self.rot_mask, 1.0 / self.num.length_scale, 1.0)
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
        L = self.num.length_scale
        w = np.where(self.rot_mask, 1.0 / L, 1.0)
        if level is None:
            level = self.force_level(f_ext, f_int)
        rr = np.abs(r * w[self.free]).max(initial=0.0)
        rel = rr / level if level > 0 else (0.0 if rr == 0 else np.inf)
        cw = self.constraint_weight
        floor = (_FLOOR_FACTOR * np.finfo(float).eps * getattr(self, "scale", 0.0)
                 * self.position_magnitude / level if level > 0 else 0.0)
        return max(rel, np.abs(c * cw).max(initial=0.0)), floor

    def increment_norm(self, dx) -> float:
        w = np.where(self.rot_mask[self.free], 1.0, 1.0 / self.num.length_scale)
        return float(np.abs(dx * w).max(initial=0.0))

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

    # ------------------------------------------------------------------ Newton
    def newton(self, x, mu, force, moment, opts: StaticOptions):
        """Newton iterations from (x, mu) at the given load. Returns (x, mu, its, res, hist)
        on success, raises _StepFailed otherwise."""
        history = []
        dx_norm = np.inf
        states = None
        for it in range(opts.max_iter + 1):
            ev = self.evaluate(x, mu, force, moment, states)
            r, c = ev.r, ev.c
            res, floor = self.residual_norm(r, c, ev.f_int, ev.f_ext)
            history.append(res)
            log.debug("iteration %d: residual %.3g (floor %.3g), last increment %.3g",
                      it, res, floor, dx_norm)
            if not np.isfinite(res):
                raise _StepFailed("non-finite residual", history)
            # converged: the last increment below the tolerance and the residual below the
            # tolerance or at its round-off floor (with very short, stiff elements the force
            # residual cannot be resolved better, while positions still are)
            # (an untouched configuration needs the residual itself below the tolerance:
            # with millions of elements the round-off floor can exceed the load change)
            if (res <= opts.tol or (it > 0 and res <= floor)) and (
                    it == 0 or dx_norm <= opts.tol):
                self._check_element_range(ev.states)
                return x, mu, it, res, history
            if it == opts.max_iter:
                break
            if it >= 3 and res > 1e3 * history[1] and res > 1e3 * opts.tol:
                raise _StepFailed("diverging", history)
            self.timings.iterations += 1
            step = None
            if self.reduced is not None:
                t0 = time.perf_counter()
                k_el, euler_diag, _ = self.element_blocks(ev, mu, moment)
                self.timings.kernels += time.perf_counter() - t0
                step = self.reduced.step(ev, x, mu, k_el, euler_diag)
            if step is not None:
                dx, dmu = step
            else:
                A = self.matrix(ev, mu, moment)
                t0 = time.perf_counter()
                rhs = -np.concatenate([r, self.scale * c])
                dz = self._solve(A, rhs, x, history)
                self.timings.solve += time.perf_counter() - t0
                dx = dz[: self.pattern.n_x]
                dmu = dz[self.pattern.n_x:] * self.scale
            if not (np.all(np.isfinite(dx)) and np.all(np.isfinite(dmu))):
                raise _StepFailed("non-finite increment", history)
            dx_norm = self.increment_norm(dx)
            if dx_norm > 0.5 and self.num.n_unknown:
                # an Euler-parameter or position jump of order one per iteration: not a
                # Newton step any more, cut the load step instead of wandering off
                if np.abs(dx[self.rot_mask[self.free]]).max(initial=0.0) > 0.5:
                    raise _StepFailed("increment too large", history)
            x_lin = x.copy()
            x_lin[self.free] += dx
            states = None
            if self.kinematic_correction:
                x_lin, states = self.correct_kinematics(x_lin, dx, ev.states,
                                                        return_states=True)
            x = x_lin
            mu = mu + dmu
        raise _StepFailed(f"no convergence in {opts.max_iter} iterations", history)

    def correct_kinematics(self, x_lin, dx, st_old, max_iter: int = 8, rigid_target=None,
                           return_states: bool = False):
        """Move the linearly updated configuration onto the deformations Newton predicted.

        Newton's increment predicts every deformation to first order,
        ``e_target = e(x_old) + D(x_old) dx``, and the Euler normalization ``q.q = 1``. The
        linear position update itself, however, stretches every element that rotates
        (by ``l0 theta^2 / 2``); with stiff axial or bending modes that artificial strain
        makes the next residual enormous and Newton wanders (hundreds of iterations for a
        finely meshed cantilever). Like SPACAR's kinematic analysis, this step restores the
        geometry: Gauss-Newton iterations on ``e(x) = e_target``, ``q.q = 1`` in the
        least-squares sense (rows scaled by 1/l0).

        The Gauss-Newton matrix ``W^T W`` (W = D / l0) depends on the geometry only, and the
        geometry changes little from one Newton iteration to the next, so its factorization
        is kept and reused (a chord iteration) until it stops contracting fast: in a Newton
        iteration near convergence the correction costs deformation evaluations and
        back-substitutions, no factorization. The iterations stop when the correction is
        below ``|first correction|^2`` (what two exact Gauss-Newton steps reach) or below
        round-off; near the solution it is of second order, so Newton's quadratic
        convergence is kept. An increment whose square is below round-off cannot stretch
        anything measurably and is taken as it is. With ``return_states`` the kernel states
        at the returned configuration come along (None when not computed there), so that
        the next residual evaluation does not repeat them.
        """
        num = self.num
        eu = num.rot_idx[num.euler_nodes]
        xd = np.zeros(num.n_coord)
        xd[self.free] = dx
        targets = [st.e + batch_matvec(st.D, xd[g.idx]) for g, st in zip(num.groups, st_old)]
        if rigid_target is not None:          # move prescribed deformations to new values
            for g, t in zip(num.groups, targets):
                t[g.rigid_elem, g.rigid_mode] = rigid_target[g.rigid_slice]
        inv_scale = [1.0 / g.scale for g in num.groups]

        def full_states(x):
            return [g.kind.state(x[g.idx], g.ref, self.variant, g.prev) for g in num.groups]

        def mismatch(x, full):
            # the deformations alone where the Jacobian is not needed (a chord iteration
            # with the kept square factorization): a third of the kernel's work
            if full or any(g.kind.deformations is None for g in num.groups):
                states = full_states(x)
                e = [st.e for st in states]
            else:
                states = None
                e = [g.kind.deformations(x[g.idx], g.ref, self.variant, g.prev)
                     for g in num.groups]
            g_e = [(t - ei) * w for t, ei, w in zip(targets, e, inv_scale)]
            g_q = 1.0 - np.sum(x[eu] ** 2, axis=1)
            worst = max([np.abs(v).max(initial=0.0) for v in g_e]
                        + [np.abs(g_q).max(initial=0.0)])
            return states, g_e, g_q, (worst if np.isfinite(worst) else np.inf)

        size = self.increment_norm(dx)
        if rigid_target is None and size * size < self.kin_floor:
            return (x_lin, None) if return_states else x_lin
        kin = self._kin
        if size > kin.stale_after:
            self._kin_solve = None               # a large step: the kept matrix is too stale
        x = x_lin
        done = None
        worst0 = prev = back = None
        n_factor, reused = 0, False
        for _ in range(max_iter):
            t0 = time.perf_counter()
            states, g_e, g_q, worst = mismatch(
                x, self._kin_solve is None or kin.jacobian_each_step)
            worst0 = worst if worst0 is None else worst0
            log.debug("kinematic correction: mismatch %.3g (matrix %s)", worst,
                      "kept" if self._kin_solve is not None else "new")
            if worst <= max(self.kin_floor, 1e-9 * worst0):
                done = states
                break
            if prev is not None and not worst <= 0.05 * prev:
                if reused:
                    # the kept matrix was too stale: undo its step, refactorize there
                    x, states, g_e, g_q, worst = back
                    self._kin_solve = None
                elif n_factor >= 2:
                    # two fresh Gauss-Newton steps and still no fast contraction: targets
                    # that cannot be met exactly (least squares, a saturated deformation);
                    # stop here, as plain Gauss-Newton with two steps would
                    done = states
                    break
                else:
                    self._kin_solve = None        # far from the targets: a fresh matrix here
            reused = self._kin_solve is not None
            wq = 2.0 * x[eu]
            w_e = None
            if not reused or kin.jacobian_each_step:
                if states is None:
                    states = full_states(x)
                w_e = self._jacobian_blocks(states, x)[0]
            self.timings.kernels += time.perf_counter() - t0
            back = (x, states, g_e, g_q, worst)
            x = x.copy()
            t1, assembly0 = time.perf_counter(), self.timings.assembly
            try:
                if not reused:
                    self._kin_solve = kin.factorize(w_e, wq, self.timings)
                    n_factor += 1
                    self.timings.factorizations += 1
                step = self._kin_solve(g_e, g_q, w_e, wq)
            except FactorizationError:
                self._kin_solve = None            # no correction possible: plain Newton
                return (x_lin, None) if return_states else x_lin
            x[self.free] += step
            # factorization and step; factorize() booked its assembly separately
            self.timings.solve += time.perf_counter() - t1 - (self.timings.assembly - assembly0)
            prev = worst
        return (x, done) if return_states else x

    def _check_element_range(self, states):
        """Kind-specific validity checks of a converged state (BEAM: Eq. 7 saturation)."""
        for g, st in zip(self.num.groups, states):
            if g.kind.check is None:
                continue
            hit = g.kind.check(st, g.ref)
            if hit is not None:
                i, message = hit
                raise SolverError(f"spurious equilibrium: {g.keyword} {int(g.ids[i])} "
                                  f"{message}")

    def at_load(self, x, mu, params):
        """Set the load parameters ``params = (a, s)`` (gravity factor, prescribed values)
        and return ``(x_start, force, moment)``: the predictor of :meth:`move_prescribed`
        and the loads for Newton at that point of the load path."""
        self.gravity_factor = float(params[0])
        force, moment = self.loads.at(*params)
        return self.move_prescribed(x, mu, params), force, moment

    def move_prescribed(self, x, mu, params):
        """Set the prescribed coordinates to their values at load parameters ``params`` and
        carry the rest of the model along kinematically (every deformation kept at its
        current value, Euler normalizations restored): a predictor for the Newton step."""
        num = self.num
        idx, target = num.prescribed_state(*params)
        rigid_target = num.rigid_targets(*params)
        same_e = np.array_equal(rigid_target, self.rigid_target)
        if (not idx.size or np.array_equal(target, x[idx])) and same_e:
            return x
        zero = np.zeros((self.loads.moment_rot.size, 3))
        states = self.evaluate(x, mu, np.zeros(num.n_coord), zero).states
        self.rigid_target = rigid_target
        moved = x.copy()
        moved[idx] = target
        return self.correct_kinematics(moved, np.zeros(num.n_unknown), states, max_iter=8,
                                       rigid_target=None if same_e else rigid_target)

    def commit(self, x, mu, force, moment):
        """Let the element kinds update their persistent state after a converged step."""
        ev = self.evaluate(x, mu, force, moment)
        for g, st in zip(self.num.groups, ev.states):
            if g.kind.commit is not None:
                g.kind.commit(st, g.prev)
        return ev

    def _solve(self, A, rhs, x, history=(), keep_lu: bool = False):
        """Solve the bordered system by SuperLU; with ``keep_lu`` return (solution, LU)."""
        try:
            lu = spla.splu(A, permc_spec="COLAMD")
            self.timings.factorizations += 1
            dz = lu.solve(rhs)
        except RuntimeError:                  # "Factor is exactly singular"
            dz = None
        if dz is None or not np.all(np.isfinite(dz)):
            if self._initial_check:
                from spacarpy.solvers.diagnose import singular_matrix_error
                raise singular_matrix_error(self, A, x)
            # during the iterations: a limit point, a bifurcation or a bad iterate
            raise _StepFailed("singular Newton matrix", list(history))
        return (dz, lu) if keep_lu else dz

    def check_initial(self, allow_mechanism: bool = False):
        """Factorize the unloaded Newton matrix in the initial configuration.

        This is the kinematic check: a mechanism or redundant constraints make it singular,
        and they are reported (with the nodes/elements involved) before any load step, even
        when the loads are zero and Newton would not need a matrix at all. With
        ``allow_mechanism`` (an unloaded model, a transient run) a mechanism's ModelError is
        returned instead of raised; redundant constraints always raise.
        """
        if allow_mechanism:
            try:
                self.check_initial()
            except ModelError as exc:
                if getattr(exc, "over_constrained", True):
                    raise
                return exc
            return None
        num = self.num
        x, mu = num.x0.copy(), np.zeros(num.n_constraint)
        zero_force = np.zeros(num.n_coord)
        zero_moment = np.zeros((self.loads.moment_rot.size, 3))
        factor, self.gravity_factor = self.gravity_factor, 0.0
        try:
            ev = self.evaluate(x, mu, zero_force, zero_moment)
        finally:
            self.gravity_factor = factor
        if not self.pattern.n or self._determinate(ev.states, x):
            return
        A = self.matrix(ev, mu, zero_moment)
        self._initial_check = True
        try:
            _, lu = self._solve(A, np.ones(self.pattern.n), x, keep_lu=True)
        finally:
            self._initial_check = False
        # The LU exists, but round-off can hide an exact singularity behind tiny pivots:
        # look for deformation-free motions among the smallest modes (robust against the
        # huge but legitimate condition numbers of finely meshed stiff structures).
        from spacarpy.solvers.diagnose import mechanism_error
        err = mechanism_error(self, A, ev.states, lu=lu)      # the same LU, not a second
        if err is not None:
            raise err

    def _determinate(self, states, x) -> bool:
        """Whether the model is a tree whose every deformation mode is rigid or carries a
        positive definite stiffness, with a regular square kinematic Jacobian W at x (its
        diagonal blocks well conditioned, :meth:`BlockTriangular.regular`). Such a model has
        no free motion (W v = 0 only for v = 0: every motion deforms a stiff or a rigid
        mode or breaks an Euler normalization) and no redundant constraint (W's rows are
        independent), so its unloaded Newton matrix is regular: the initial check needs no
        LU of it (2-3 s at 10^5 elements, against 0.3 s for this test)."""
        if not isinstance(self._kin, _SquareJacobian):
            return False
        for g in self.num.groups:
            if not np.all(g.stiff_mask | (g.def_class == 0)):
                return False               # a released mode without stiffness: a hinge
            try:                           # S positive definite on the stiff modes
                np.linalg.cholesky(g.S + np.eye(g.S.shape[1]) * ~g.stiff_mask[:, None, :])
            except np.linalg.LinAlgError:
                return False
        return self._kin.regular(*self._jacobian_blocks(states, x))

    def _jacobian_blocks(self, states, x):
        """The kinematic correction's Jacobian W at x by blocks: ``D / scale`` per element
        group and the Euler rows ``2 q`` (see :class:`_SquareJacobian`)."""
        return ([st.D * (1.0 / g.scale)[:, :, None] for g, st in zip(self.num.groups, states)],
                2.0 * x[self.num.rot_idx[self.num.euler_nodes]])

    def normalize(self, x):
        """Project Euler parameters exactly onto q.q = 1 (after convergence)."""
        x = x.copy()
        idx = self.num.rot_idx[self.num.euler_nodes]
        q = x[idx]
        x[idx] = q / np.linalg.norm(q, axis=1)[:, None]
        return x


@dataclass
class _Eval:
    states: list               # per element group: the kernel state (.e, .D, ...)
    sigmas: list               # per element group: stress resultants (n, n_def)
    r: np.ndarray
    c: np.ndarray
    f_int: np.ndarray
    f_ext: np.ndarray
    q_eu: np.ndarray
    gravity_stiffness: list = field(default_factory=list)   # per group, or empty


class _StepFailed(Exception):
    def __init__(self, reason, history):
        super().__init__(reason)
        self.reason = reason
        self.history = history


@dataclass
class StaticResult:
    """All stored steps of a static run plus bookkeeping."""

    steps: list = field(default_factory=list)
    problem: StaticProblem | None = None


def solve_static(model: Model, *, deformations: str | None = None, options: StaticOptions | None = None,
                 on_step=None, problem: StaticProblem | None = None) -> StaticResult:
    """Solve the static problem of ``model`` along its load path.

    Step 0 is the equilibrium under XF (reached in ``n_init`` internal sub-steps); steps
    1..n_steps add DELXF in equal increments. ``on_step(StaticStep)`` is called after each
    stored step (the results writer appends it to the file at once).

    Raises
    ------
    ConvergenceError
        With the step, the load factor reached and the residual history; the steps already
        passed to ``on_step`` stay valid.
    ModelError
        When the Newton matrix is singular (mechanism, over-constraint).
    """
    it = model.iterstep
    opts = options or StaticOptions(max_iter=it.max_iter, tol=it.tol, n_steps=it.n_steps,
                                    n_init=it.n_init,
                                    deformations=deformations or model.deformations,
                                    bifurcation=model.bifurcation)
    prob = problem or StaticProblem(model, deformations=opts.deformations)
    t_start = time.perf_counter()
    num = prob.num
    x = num.x0.copy()
    mu = np.zeros(num.n_constraint)
    result = StaticResult(problem=prob)
    if prob.loads.any:
        prob.check_initial()
    else:
        # no load at all: the initial configuration is the equilibrium, also for a
        # free-floating structure or a mechanism (neutral equilibrium, e.g. before an
        # eigenfrequency analysis): warn instead of refusing. Redundant constraints are
        # an error with or without load.
        exc = prob.check_initial(allow_mechanism=True)
        if exc is not None:
            log.warning("unloaded model: %s", exc)

    warned = []

    def store(load_factor, x, mu, its, res):
        ev = prob.evaluate(x, mu, *prob.loads.at(1.0, load_factor))
        if not warned:
            warned.extend(_strain_warnings(num, ev.states, len(result.steps)))
        by_kind = {g.keyword: (st.e, sig) for g, st, sig in
                   zip(num.groups, ev.states, ev.sigmas)}
        beam_e, beam_s = by_kind.get("BEAM", (np.zeros((0, 6)), np.zeros((0, 6))))
        step = StaticStep(load_factor=load_factor, x=x.copy(), deformation=beam_e,
                          stress=beam_s, reaction=prob.reactions(x, ev.f_int, ev.f_ext),
                          iterations=its, residual=res, mu=mu.copy(),
                          group_deformation={k: v[0] for k, v in by_kind.items()},
                          group_stress={k: v[1] for k, v in by_kind.items()})
        result.steps.append(step)
        if on_step is not None:
            on_step(step)

    path = _PathStability(prob, opts)
    # phase A: reach XF (a: 0 -> 1) at s = 0
    x, mu, its, res = _advance(prob, x, mu, (0.0, 0.0), (1.0, 0.0),
                               opts.n_init if prob.loads.has_xf else 1, opts, stored_step=0)
    x, mu = path.check(prob.normalize(x), mu, (1.0, 0.0), 0)
    store(0.0, x, mu, its, res)
    # phase B: DELXF in n_steps stored increments
    for k in range(1, opts.n_steps + 1):
        s0, s1 = (k - 1) / opts.n_steps, k / opts.n_steps
        x, mu, its, res = _advance(prob, x, mu, (1.0, s0), (1.0, s1), 1, opts, stored_step=k)
        x, mu = path.check(prob.normalize(x), mu, (1.0, s1), k)
        store(s1, x, mu, its, res)
    prob.timings.total = time.perf_counter() - t_start
    return result


class _PathStability:
    """``BIFURCATION warn|switch``: the index of the tangent after every stored step, with a
    warning when it rises and (switch) branch switching, see
    :mod:`spacarpy.solvers.stability`.

    Switching happens close to the critical point, where the new branch is still near the
    old one: the load interval of the step is bisected (``BISECTIONS`` times) down to a
    state just beyond the point where the index rose, the state there is perturbed along
    the unstable eigenvector, and from the equilibrium found the step is completed along
    the new branch in sub-steps.
    """

    BISECTIONS = 8

    def __init__(self, prob, opts):
        self.prob, self.opts = prob, opts
        self.on = opts.bifurcation in ("warn", "switch")
        self.index = 0
        self.told_size = False
        self.last = None               # (x, mu, params, stability) of the last stored step

    def _stability(self, x, mu, params):
        from spacarpy.solvers.stability import stability
        return stability(self.prob, x, mu, *self.prob.loads.at(*params))

    def _solve_at(self, x, mu, params):
        prob = self.prob
        x0, force, moment = prob.at_load(x, mu, params)
        x1, mu1, *_ = prob.newton(x0, mu, force, moment, self.opts)
        return prob.normalize(x1), mu1

    def _bisect(self, lo, hi):
        """Narrow the load interval between ``lo`` (index not above the path's) and ``hi``
        (index above it); both are (x, mu, params, stability). Returns the new ``hi``."""
        x_lo, mu_lo, p_lo, _ = lo
        p_lo = np.asarray(p_lo, float)
        for _ in range(self.BISECTIONS):
            p_mid = 0.5 * (p_lo + np.asarray(hi[2], float))
            try:
                x_mid, mu_mid = self._solve_at(x_lo, mu_lo, p_mid)
            except _StepFailed:
                break
            s_mid = self._stability(x_mid, mu_mid, p_mid)
            if s_mid.index > self.index:
                hi = (x_mid, mu_mid, p_mid, s_mid)
            else:
                p_lo, x_lo, mu_lo = p_mid, x_mid, mu_mid
        return hi

    def _switch_at(self, state, step):
        """Perturb-and-solve at one state's load; returns the new state or None."""
        from spacarpy.solvers.stability import switch_branch
        x, mu, p, stab = state
        prob = self.prob
        _, force, moment = prob.at_load(x, mu, p)           # (the targets at that load)
        xs, mus, ss = switch_branch(prob, x, mu, force, moment, self.opts, stab, step)
        if ss.index >= stab.index:
            return None
        if prob.has_commit:
            prob.commit(xs, mus, force, moment)
        return xs, mus, p, ss

    def _switch(self, x, mu, params, stab, step):
        """Bisect back towards the critical point, switch there and come back to ``params``
        along the new branch (repeatedly, when several eigenvalues cross within the step);
        as a last resort switch at ``params`` itself."""
        target = np.asarray(params, float)
        cur = (x, mu, target, stab)
        lo = self.last
        for _ in range(4):
            if lo is None or cur[3].index <= self.index:
                break
            hi = self._bisect(lo, cur)
            switched = self._switch_at(hi, step)
            if switched is None:
                break
            if np.array_equal(np.asarray(hi[2], float), target):
                cur = switched
                break
            if switched[3].index <= self.index:
                lo = switched
            try:
                xa, mua, *_ = _advance(self.prob, switched[0], switched[1],
                                       np.asarray(hi[2], float), target, 8, self.opts,
                                       stored_step=step)
            except ConvergenceError:
                break
            xa = self.prob.normalize(xa)
            cur = (xa, mua, target, self._stability(xa, mua, target))
        if cur[3].index < stab.index:
            return cur[0], cur[1], cur[3]
        direct = self._switch_at((x, mu, target, stab), step)
        if direct is not None:
            return direct[0], direct[1], direct[3]
        return x, mu, stab

    def check(self, x, mu, params, step):
        if not self.on:
            return x, mu
        from spacarpy.solvers.eigen import DENSE_LIMIT
        prob = self.prob
        stab = self._stability(x, mu, params)
        if stab is None:
            if not self.told_size:
                log.warning("BIFURCATION: the stability check needs the dense reduction "
                            "(at most %d free coordinates); this model has %d, not checked",
                            DENSE_LIMIT, prob.pattern.n_x)
                self.told_size = True
            return x, mu
        if stab.index > self.index and self.opts.bifurcation == "switch":
            x, mu, stab = self._switch(x, mu, params, stab, step)
        if stab.index > self.index:
            log.warning("step %d: the equilibrium is unstable: %d negative stiffness "
                        "eigenvalue(s) (a limit or bifurcation point was passed)%s", step,
                        stab.index, "; no stable branch found nearby"
                        if self.opts.bifurcation == "switch" else
                        "; 'BIFURCATION switch' follows the stable branch")
        self.index = stab.index
        self.last = (x.copy(), mu.copy(), np.asarray(params, float), stab)
        return x, mu


#: Axial strain beyond which a warning says the linear material law is being stretched.
MAX_AXIAL_STRAIN = 0.05


def _strain_warnings(num, states, step) -> list:
    """Warn once when an element's axial strain leaves the small-strain range."""
    out = []
    for g, st in zip(num.groups, states):
        if g.keyword not in ("BEAM", "TRUSS") or not g.n_elem:
            continue
        strain = np.abs(st.e[:, 0]) / g.ref["l0"]
        i = int(np.argmax(strain))
        if strain[i] > MAX_AXIAL_STRAIN:
            msg = (f"step {step}: {g.keyword} {int(g.ids[i])} has an axial strain of "
                   f"{100 * strain[i]:.3g}%, far beyond the small strains the linear "
                   f"stiffness (ESTIFF) describes; check the loads and the model")
            log.warning(msg)
            out.append(msg)
    return out


def _advance(prob, x, mu, p_from, p_to, n_sub, opts, stored_step):
    """Move the load parameters (a, s) from p_from to p_to, cutting steps on failure."""
    p_from, p_to = np.asarray(p_from, float), np.asarray(p_to, float)
    t, t_end = 0.0, 1.0
    dt_nominal = 1.0 / max(n_sub, 1)
    dt = dt_nominal
    min_dt = dt_nominal / 2 ** opts.max_cuts
    total_its, last_res = 0, 0.0
    while t < t_end - 1e-14:
        dt = min(dt, t_end - t)
        p = p_from + (t + dt) * (p_to - p_from)
        try:
            x_start, force, moment = prob.at_load(x, mu, p)
            x_new, mu_new, its, res, _ = prob.newton(x_start, mu, force, moment, opts)
        except _StepFailed as fail:
            if dt / 2 < min_dt:
                lf = p_from[1] + t * (p_to[1] - p_from[1])
                hist = ", ".join(f"{h:.3e}" for h in fail.history)
                raise ConvergenceError(
                    f"static step {stored_step} did not converge ({fail.reason}) after "
                    f"{opts.max_cuts} step cuts; last converged load: XF factor "
                    f"{p_from[0] + t * (p_to[0] - p_from[0]):.6g}, DELXF factor {lf:.6g}; "
                    f"residual history of the last attempt: [{hist}]") from None
            log.info("step %d: %s at increment %.3g, cutting the step", stored_step,
                     fail.reason, dt)
            dt /= 2
            continue
        x, mu = x_new, mu_new
        if prob.has_commit:
            prob.commit(x, mu, force, moment)
        total_its += its
        last_res = res
        t += dt
        dt = min(dt * 2, dt_nominal)            # grow back after a successful cut step
    return x, mu, total_its, last_res


__all__ = ["solve_static", "StaticProblem", "StaticStep", "StaticOptions", "StaticResult"]

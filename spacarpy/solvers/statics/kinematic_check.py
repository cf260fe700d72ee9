"""The kinematic check of a model in its initial configuration (SPACAR's mode 0): is it a
mechanism, or over-constrained? And the degree-of-freedom report of ``MODE check``.

The check factorizes the unloaded Newton matrix; a singular one is diagnosed
(:mod:`spacarpy.solvers.statics.diagnose`) into a :class:`~spacarpy.errors.ModelError` naming the
free motions or the redundant deformation modes. A statically determinate tree with stiff
or rigid modes only is recognised from its kinematic Jacobian, without that factorization.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spacarpy.errors import ModelError
from spacarpy.model import RIGID
from spacarpy.solvers.linalg.sparse import choose, supernodal_lu
from spacarpy.solvers.statics.diagnose import (
    NONZERO,
    Rank,
    _fmt,
    canonical_motions,
    dependent_rows,
    equilibrate,
    numerical_rank,
    unit_rows,
)
from spacarpy.solvers.statics.dynamic_coords import check_dynamic, dynamic_report
from spacarpy.solvers.statics.newton import bordered_solve
from spacarpy.solvers.statics.nonholonomic import kinematic_report

#: Largest model (free coordinates plus constraints) that gets the dense rank analysis of
#: :func:`kinematic_analysis` (two SVDs: about a second at this size on one core). Larger
#: models get the determinate-tree test or the static solver's sparse check.
KINEMATIC_LIMIT = 1200


def check_initial(prob, allow_mechanism: bool = False,
                  dynamic: bool = True) -> ModelError | None:
    """Factorize the unloaded Newton matrix of ``prob`` (a
    :class:`~spacarpy.solvers.statics.equilibrium.StaticProblem`) in the initial configuration.

    This is the kinematic check: a mechanism or redundant constraints make it singular,
    and they are reported (with the nodes/elements involved) before any load step, even
    when the loads are zero and Newton would not need a matrix at all. With
    ``allow_mechanism`` (an unloaded model, a transient run) a mechanism's ModelError is
    returned instead of raised; redundant constraints always raise. A model with DYNX lines
    is then checked to be parameterized by its DYNX coordinates and DYNE modes (unless
    ``dynamic`` is False: :mod:`spacarpy.solvers.statics.dynamic_coords`).
    """
    if allow_mechanism:
        try:
            check_initial(prob, dynamic=dynamic)
        except ModelError as exc:
            if getattr(exc, "over_constrained", True) or getattr(exc, "dynamic", False):
                raise
            if dynamic:
                check_dynamic(prob)
            return exc
        return None
    _check_singular(prob)
    if dynamic:
        check_dynamic(prob)
    return None


def _check_singular(prob) -> None:
    """The factorization of :func:`check_initial`: raise its ModelError."""
    num = prob.num
    x, mu = num.x0.copy(), np.zeros(num.n_constraint)
    ev = prob.evaluate(x, mu, prob.loads.unloaded())
    if not prob.pattern.n or determinate(prob, ev.states, x):
        return None
    A = prob.matrix(ev, mu)
    wide = choose(A) == "pardiso"
    if wide and _reduced_definite(prob, ev, x, mu):
        return None
    # a wide (3D) model: PARDISO's LDL^T, where SuperLU's COLAMD fills badly; a matrix it
    # had to perturb (singular to round-off) goes to SuperLU, whose exact singularity
    # names it
    lu = supernodal_lu(A) if wide else None
    if lu is not None:
        prob.timings.factorizations += 1
    else:
        _, lu = bordered_solve(prob, A, np.ones(A.shape[0]))    # (with the slip rows)
    from spacarpy.solvers.statics.diagnose import mechanism_error, singular_matrix_error
    # The LU may exist, but round-off can hide an exact singularity behind tiny pivots:
    # look for deformation-free motions among the smallest modes (robust against the
    # huge but legitimate condition numbers of finely meshed stiff structures).
    err = (singular_matrix_error(prob, A, x) if lu is None
           else mechanism_error(prob, A, ev.states, lu=lu))      # the same LU, not a second
    if err is None:
        return None
    if A.shape[0] <= KINEMATIC_LIMIT:   # name exactly what the rank analysis finds
        err = analysis_error(prob, kinematic_analysis(prob)) or err
    raise err


def _reduced_definite(prob, ev, x, mu) -> bool:
    """Whether the reduced tangent of a model whose only constraints are the Euler
    normalizations (:mod:`spacarpy.solvers.statics.reduced`) is positive definite in the
    initial configuration, by its supernodal LDL^T: no negative and no perturbed pivot.
    Then the bordered matrix is regular (the normalizations are independent), so there is
    neither mechanism nor redundant constraint, and the factorization is the one the first
    Newton iteration uses (its reuse, :meth:`ReducedNewton.step`): the check costs no
    factorization of its own. False (the bordered check follows) in every other case."""
    reduced = prob.reduced
    if reduced is None:
        return False
    k_el, euler_diag, _ = prob.element_blocks(ev, mu)
    if reduced.step(ev, x, mu, k_el, euler_diag) is None:
        return False
    fac = reduced.factor
    return (fac.backend == "pardiso" and fac.negative_pivots() == 0
            and fac.perturbed_pivots() == 0)


def analysis_error(prob, ka: KinematicAnalysis) -> ModelError | None:
    """The :class:`~spacarpy.errors.ModelError` of a mechanism or an over-constrained
    model (for the static and transient solvers), from :func:`kinematic_analysis`; None
    when it found neither."""
    lines = []
    if ka.motions:
        moving = sorted({n for m in ka.motions for n in m["nodes"]})
        lines.append(
            f"mechanism: {len(ka.motions)} free motion(s) that no flexible element resists; "
            f"nodes that move: {_fmt(moving)}; "
            + "; ".join(f"motion {i} driven by {mode_name(m['driver'])}"
                        for i, m in enumerate(ka.motions[:4], 1))
            + (f" (and {len(ka.motions) - 4} more)" if len(ka.motions) > 4 else "")
            + ". Add FIX lines, or make deformation modes flexible (DYNE with ESTIFF) or "
              "rigid.")
    if ka.redundant:
        lines.append(
            f"over-constrained: {len(ka.redundant)} redundant constraint(s): "
            + _fmt([mode_name(n) + (f" ('RLSE {n[1]} {n[2]}' releases it)"
                                    if n[0] != "EULER" else "") for n in ka.redundant],
                   limit=12, sep="; "))
    if not lines:
        return None
    if not ka.clear:
        lines.append(f"rank decision: {ka.rank.describe()}")
    err = ModelError("the model cannot be solved: " + "\n  ".join(lines))
    err.mechanism, err.over_constrained = bool(ka.motions), bool(ka.redundant)
    return err


def free_motions(exc) -> str:
    """The description of a mechanism's free motions in a :class:`ModelError` (nodes and
    drivers), without the model-error framing and the advice to fix it."""
    text = str(exc).split("\n")[0]
    text = text.removeprefix("the model cannot be solved: ").removeprefix("mechanism: ")
    for advice in (". Add FIX lines", ". Fix them", "; add FIX"):
        text = text.split(advice)[0]
    return text.rstrip(". ")


def determinate(prob, states, x) -> bool:
    """Whether the model is a tree whose every deformation mode is rigid or carries a
    positive definite stiffness, with a regular square kinematic Jacobian W at x (its
    diagonal blocks well conditioned, :meth:`BlockTriangular.regular
    <spacarpy.solvers.linalg.triangular.BlockTriangular.regular>`). Such a model has no free motion
    (W v = 0 only for v = 0: every motion deforms a stiff or a rigid mode or breaks an Euler
    normalization) and no redundant constraint (W's rows are independent), so its unloaded
    Newton matrix is regular: the initial check needs no LU of it, which for large trees
    costs several times this test."""
    from spacarpy.solvers.statics.kinematic_correction import SquareJacobian
    if not isinstance(prob.corrector.system, SquareJacobian):
        return False
    for g in prob.num.groups:
        if not np.all(g.stiff_mask | (g.def_class == 0)):
            return False               # a released mode without stiffness: a hinge
        try:                           # S positive definite on the stiff modes
            np.linalg.cholesky(g.S + np.eye(g.S.shape[1]) * ~g.stiff_mask[:, None, :])
        except np.linalg.LinAlgError:
            return False
    return prob.corrector.regular(states, x)


@dataclass
class KinematicAnalysis:
    """The kinematic check's findings, from the rank of the constraint Jacobian C (the rows
    of the rigid deformation modes and Euler normalizations over the free coordinates) and
    of C stacked on the rows of the modes with stiffness.

    ``dof`` = free coordinates - rank C (the degrees of freedom, elastic ones included);
    ``motions``: the free motions (no stiff or rigid mode changes), one dict per motion with
    its ``driver`` (a released mode or a coordinate that parameterizes it), the ``nodes`` that
    move, the released ``modes`` that change and the ``velocity`` of every coordinate (m or
    Euler parameter per unit rate of the driver, zero on fixed ones); ``redundant``:
    (keyword, element, mode) of the rigid modes that repeat others (an Euler
    normalization: ("EULER", node, 0)); ``rank``/``motion_rank``: the two rank decisions
    (:class:`~spacarpy.solvers.statics.diagnose.Rank`).
    """

    n_unknown: int
    n_constraint: int
    dof: int
    motions: list
    redundant: list
    rank: Rank
    motion_rank: Rank

    @property
    def clear(self) -> bool:
        return self.rank.clear and self.motion_rank.clear


def kinematic_analysis(prob, stiff_resists: bool = True) -> KinematicAnalysis:
    """The rank-revealing analysis of the kinematic check in the initial configuration.

    With ``stiff_resists=False`` the modes with stiffness (DYNE) count as free like the
    released ones: the motions are then those the constraints leave, each a degree of
    freedom that inverse dynamics (SPACAR mode 2) needs prescribed.

    Dense SVDs of the scaled Jacobians (positions in units of the model's length scale,
    every row of unit norm): for models up to :data:`KINEMATIC_LIMIT` unknowns plus
    constraints. The redundant constraints are named by walking the rigid
    modes in a fixed order, Euler normalizations first, then the modes of the bodies (BEAM,
    TRUSS, RBEAM, ...), then those of the joints (HINGE, PLHINGE), each kind by element:
    the last ones of a dependent set are named, so a joint's mode rather than a body's.
    The free motions get a basis that moves one released mode each
    (:func:`~spacarpy.solvers.statics.diagnose.canonical_motions`).
    """
    num, model = prob.num, prob.model
    x = num.x0.copy()
    ev = prob.evaluate(x, np.zeros(num.n_constraint), prob.loads.unloaded())
    free = np.flatnonzero(prob.free)
    col = np.where(num.is_rotation_coord, 1.0, num.length_scale)[free]
    rows, names, kinds = [], [], []          # kinds: 0 rigid, 1 stiff, 2 released
    for node in num.euler_nodes:
        r = np.zeros(num.n_coord)
        r[num.rot_idx[node]] = 2.0 * x[num.rot_idx[node]]
        rows.append(r)
        names.append(("EULER", int(model.orientation_ids[node]), 0))
        kinds.append(0)
    # joints (kinds between orientation nodes only) last: their modes are named redundant
    order = sorted(range(len(num.groups)),
                   key=lambda i: all(s == "rot" for s in num.groups[i].kind.slots))
    for g, st in ((num.groups[i], ev.states[i]) for i in order):
        slips = getattr(g.kind, "velocity_modes", ())    # velocity level: not in C
        for e in range(g.n_elem):
            for k in (k for k in range(g.def_class.shape[1]) if k not in slips):
                r = np.zeros(num.n_coord)
                np.add.at(r, g.idx[e], st.D[e, k])
                rows.append(r)
                names.append((g.keyword, int(g.ids[e]), k + 1))
                kinds.append(0 if g.def_class[e, k] == RIGID else
                             1 if g.stiff_mask[e, k] and stiff_resists else 2)
    J = np.array(rows).reshape(len(rows), num.n_coord)[:, free] / col
    kinds = np.array(kinds, dtype=int)
    node_of = num.node_of_coord(model)[free]
    # one column factor for the position and one for the Euler parameters of each node
    groups = 2 * node_of + num.is_rotation_coord[free]
    C, _, _ = equilibrate(J[kinds == 0], groups)
    rank, _, L = numerical_rank(C, right=False, left=True)
    dep, clear = dependent_rows(L)
    rank.clear &= clear
    cnames = [n for n, k in zip(names, kinds) if k == 0]
    S, _, cs = equilibrate(J[kinds <= 1], groups)
    motion_rank, N, _ = numerical_rank(S)
    if N.shape[1]:                        # the null space in the coordinates of J
        N, _ = np.linalg.qr(N / cs[:, None])
    released = np.flatnonzero(kinds == 2)
    drivers = np.vstack([J[released], np.diag(col)])       # rates in physical units
    V, chosen = canonical_motions(N, drivers)
    motions = []
    for j, c in enumerate(chosen):
        velocity = np.zeros(num.n_coord)
        velocity[free] = V[:, j] / col
        v = np.abs(V[:, j])
        rates = np.abs(unit_rows(J[released]) @ V[:, j])
        motions.append({
            "driver": (names[released[c]] if c < released.size
                       else ("COORD", int(node_of[c - released.size]),
                             _component(num, free[c - released.size]))),
            "nodes": sorted({int(n) for n in node_of[v > NONZERO * v.max()]}),
            "modes": [names[i] for i, rt in zip(released, rates)
                      if rt > NONZERO * rates.max(initial=0.0)],
            "velocity": velocity})
    return KinematicAnalysis(n_unknown=free.size, n_constraint=C.shape[0],
                             dof=free.size - rank.rank, motions=motions,
                             redundant=[cnames[i] for i in dep], rank=rank,
                             motion_rank=motion_rank)


def _component(num, coord) -> str:
    """'x'..'z' of a position coordinate, 'q0'..'q3' of an Euler parameter."""
    hit = np.argwhere(num.pos_idx == coord)
    if hit.size:
        return "xyz"[hit[0, 1]]
    return f"q{np.argwhere(num.rot_idx == coord)[0, 1]}"


def mode_name(name) -> str:
    """'HINGE 21 mode 1', 'Euler normalization of node 9', 'node 3 x'."""
    kw, e, k = name
    if kw == "EULER":
        return f"Euler normalization of node {e}"
    if kw == "COORD":
        return f"node {e} {k}"
    return f"{kw} {e} mode {k}"


def dof_report(prob) -> str:
    """SPACAR's mode 0: count coordinates, constraints and degrees of freedom in the
    initial configuration, with the free motions of a mechanism (the nodes that move in
    each) and the redundant constraints (each with the RLSE line that releases it).

    A mechanism or redundant constraints are results here, not errors (the static solver
    refuses them, :func:`check_initial`). Models with more than :data:`KINEMATIC_LIMIT`
    unknowns and constraints that are not
    statically determinate trees get the static solver's check instead, which raises a
    :class:`~spacarpy.errors.ModelError` naming the free motions or redundant modes.
    """
    num, model = prob.num, prob.model
    kinds = ", ".join(f"{g.n_elem} {g.keyword}" for g in num.groups) or "none"
    n_fixed = int(num.fixed_mask.sum())
    n_con = num.n_constraint
    head = [f"  elements            {kinds}",
            f"  coordinates         {num.n_coord} ({model.position_ids.size} position nodes "
            f"x 3 + {model.orientation_ids.size} orientation nodes x 4), {n_fixed} fixed"]
    con = (f"  constraints         {n_con} ({num.n_rigid} rigid deformation modes + "
           f"{num.euler_nodes.size} Euler normalizations)")
    x = num.x0.copy()
    ev = prob.evaluate(x, np.zeros(n_con), prob.loads.unloaded())
    if (num.n_unknown + n_con > KINEMATIC_LIMIT or not prob.pattern.n
            or determinate(prob, ev.states, x)):
        check_initial(prob, dynamic=False)  # raises for mechanisms / over-constraints
        return "\n".join([f"{model.source_path}: kinematic check passed", *head,
                          con + ", all independent",
                          f"  degrees of freedom  {num.n_unknown - n_con}, no free motion",
                          *dynamic_report(prob), *kinematic_report(prob)])
    ka = kinematic_analysis(prob)
    n_red, n_mot = len(ka.redundant), len(ka.motions)
    if not n_red and not n_mot:
        title = "kinematic check passed"
    else:
        title = "kinematic check: " + ", ".join(
            ([f"a mechanism with {n_mot} free motion{'s' * (n_mot != 1)}"] if n_mot else [])
            + ([f"{n_red} redundant constraint{'s' * (n_red != 1)}"] if n_red else []))
    lines = [f"{model.source_path}: {title}", *head,
             con + (f", rank {n_con - n_red}: {n_red} redundant" if n_red
                    else ", all independent"),
             f"  degrees of freedom  {ka.dof}" + (
                 f" ({ka.n_unknown} free coordinates - rank {n_con - n_red} of the "
                 f"constraints)" if n_red else "")
             + (", no free motion" if not n_mot else
                f", {n_mot} of them free motion{'s' * (n_mot != 1)} that no stiffness "
                f"resists (a mechanism)")]
    for i, m in enumerate(ka.motions, 1):
        lines.append(f"  free motion {i:<7} {mode_name(m['driver'])} (the others held); nodes "
                     f"that move: {_fmt(m['nodes'])}"
                     + (f"; released modes that change: "
                        f"{_fmt([mode_name(n) for n in m['modes']], limit=8)}"
                        if m["modes"] else ""))
    for i, name in enumerate(ka.redundant):
        label = "redundant" if i == 0 else ""
        advice = (f"'RLSE {name[1]} {name[2]}' releases it" if name[0] != "EULER"
                  else "check the FIX lines of this node")
        lines.append(f"  {label:<19} {mode_name(name)}: {advice}")
    lines.append(f"  rank decision       {ka.rank.describe()}")
    if ka.rank.clear and not ka.motion_rank.clear:
        lines.append(f"  free motions        {ka.motion_rank.describe()}")
    return "\n".join(lines + dynamic_report(prob) + kinematic_report(prob))


__all__ = ["KINEMATIC_LIMIT", "KinematicAnalysis", "analysis_error", "check_initial",
           "determinate", "dof_report", "kinematic_analysis", "mode_name"]

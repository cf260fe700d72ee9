"""The kinematic check of a model in its initial configuration (SPACAR's mode 0): is it a
mechanism, or over-constrained? And the degree-of-freedom report of ``MODE check``.

The check factorizes the unloaded Newton matrix; a singular one is diagnosed
(:mod:`spacarpy.solvers.diagnose`) into a :class:`~spacarpy.errors.ModelError` naming the
free motions or the redundant deformation modes. A statically determinate tree with stiff
or rigid modes only is recognised from its kinematic Jacobian, without that factorization.
"""
from __future__ import annotations

import numpy as np

from spacarpy.errors import ModelError
from spacarpy.solvers.newton import bordered_solve


def check_initial(prob, allow_mechanism: bool = False) -> ModelError | None:
    """Factorize the unloaded Newton matrix of ``prob`` (a
    :class:`~spacarpy.solvers.equilibrium.StaticProblem`) in the initial configuration.

    This is the kinematic check: a mechanism or redundant constraints make it singular,
    and they are reported (with the nodes/elements involved) before any load step, even
    when the loads are zero and Newton would not need a matrix at all. With
    ``allow_mechanism`` (an unloaded model, a transient run) a mechanism's ModelError is
    returned instead of raised; redundant constraints always raise.
    """
    if allow_mechanism:
        try:
            check_initial(prob)
        except ModelError as exc:
            if getattr(exc, "over_constrained", True):
                raise
            return exc
        return None
    num = prob.num
    x, mu = num.x0.copy(), np.zeros(num.n_constraint)
    ev = prob.evaluate(x, mu, prob.loads.unloaded())
    if not prob.pattern.n or determinate(prob, ev.states, x):
        return None
    A = prob.matrix(ev, mu)
    _, lu = bordered_solve(prob, A, np.ones(prob.pattern.n))
    from spacarpy.solvers.diagnose import mechanism_error, singular_matrix_error
    if lu is None:
        raise singular_matrix_error(prob, A, x)
    # The LU exists, but round-off can hide an exact singularity behind tiny pivots:
    # look for deformation-free motions among the smallest modes (robust against the
    # huge but legitimate condition numbers of finely meshed stiff structures).
    err = mechanism_error(prob, A, ev.states, lu=lu)      # the same LU, not a second
    if err is not None:
        raise err
    return None


def determinate(prob, states, x) -> bool:
    """Whether the model is a tree whose every deformation mode is rigid or carries a
    positive definite stiffness, with a regular square kinematic Jacobian W at x (its
    diagonal blocks well conditioned, :meth:`BlockTriangular.regular
    <spacarpy.solvers.triangular.BlockTriangular.regular>`). Such a model has no free motion
    (W v = 0 only for v = 0: every motion deforms a stiff or a rigid mode or breaks an Euler
    normalization) and no redundant constraint (W's rows are independent), so its unloaded
    Newton matrix is regular: the initial check needs no LU of it, which for large trees
    costs several times this test."""
    from spacarpy.solvers.kinematic_correction import SquareJacobian
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


def dof_report(prob) -> str:
    """SPACAR's mode 0: count coordinates, constraints and degrees of freedom, and verify in
    the initial configuration that the model is neither a mechanism nor over-constrained.

    Returns the report; raises :class:`~spacarpy.errors.ModelError` (naming the free
    motions or the redundant deformation modes) when the check fails.
    """
    num, model = prob.num, prob.model
    kinds = ", ".join(f"{g.n_elem} {g.keyword}" for g in num.groups) or "none"
    n_fixed = int(num.fixed_mask.sum())
    check_initial(prob)              # raises ModelError for mechanisms / over-constraints
    dof = num.n_unknown - num.n_constraint
    return "\n".join([
        f"{model.source_path}: kinematic check passed",
        f"  elements            {kinds}",
        f"  coordinates         {num.n_coord} ({model.position_ids.size} position nodes x 3 + "
        f"{model.orientation_ids.size} orientation nodes x 4), {n_fixed} fixed",
        f"  constraints         {num.n_constraint} ({num.n_rigid} rigid deformation modes + "
        f"{num.euler_nodes.size} Euler normalizations), all independent",
        f"  degrees of freedom  {dof}, no free motion"])


__all__ = ["check_initial", "determinate", "dof_report"]

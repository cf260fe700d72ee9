"""Stability of static equilibria along the load path, and switching to a stable branch.

An equilibrium is stable when the tangent stiffness K0 + G0 + N0, reduced to the degrees of
freedom (the null space T of the constraint Jacobian), is positive definite. The number of
its negative eigenvalues (its *index*) only changes where the path passes a limit or a
bifurcation point. A perfectly symmetric structure (the parallel leaf-spring guidance under
misalignment, an ideal column) keeps Newton on the symmetric, now unstable, branch beyond a
bifurcation: the load steps simply step over it. With ``BIFURCATION switch`` the static
solver checks the index after every load step and, when it has risen, perturbs the state
along the eigenvector of the most negative eigenvalue, by growing amounts and with both
signs, and re-solves at the same load; a new equilibrium with a smaller index is taken (the
branch the physical structure follows, whatever tiny imperfection it has). This is the
classical "perturbation along the critical eigenvector" branch switching, without having
to put an artificial imperfection into the model.

Only models small enough for the dense reduction (``eigen.DENSE_LIMIT`` free coordinates)
are checked; beyond that the solver says so once.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from spacarpy.solvers.eigen import DENSE_LIMIT, null_space_basis

log = logging.getLogger(__name__)

#: Relative size of an eigenvalue (to the largest one) below which it counts as zero.
ZERO_TOL = 1e-10
#: Relative difference of potential energy below which two branches count as equally good
#: (mirror images; an equilibrium's energy is stationary, so its round-off is of the order
#: of the squared position error: 1e-12 at a tolerance of 1e-6).
ENERGY_TIE = 1e-10
#: Perturbation amplitudes tried, as fractions of the model's length scale.
AMPLITUDES = (1e-4, 1e-3, 1e-2, 0.03, 0.1)


@dataclass
class Stability:
    """Index of the reduced tangent at one state.

    Attributes
    ----------
    index : int
        Number of negative eigenvalues (0: stable).
    lowest : float
        Lowest eigenvalue (of the Jacobi-scaled reduced tangent; its sign is what counts).
    modes : (n_x, max(index, 1)) float
        Eigenvectors of the negative eigenvalues (the lowest one when there is none) over the
        free coordinates, lowest first.
    """

    index: int
    lowest: float
    modes: np.ndarray


def stability(prob, x, mu, force, moment) -> Stability | None:
    """Index of the reduced tangent of ``prob`` at (x, mu); None when the model is too large
    for the dense reduction."""
    from spacarpy.solvers.linearize import linearize
    n_x = prob.pattern.n_x
    if n_x > DENSE_LIMIT:
        return None
    lin = linearize(prob, x, mu, force, moment)
    T = null_space_basis(lin.C, n_x)
    if T.shape[1] == 0:
        return Stability(index=0, lowest=np.inf, modes=np.zeros((n_x, 1)))
    k = T.T @ (lin.K @ T)
    k = 0.5 * (k + k.T)
    # Jacobi scaling (a congruence: the index is unchanged) so that the tolerance for "zero"
    # is relative to each direction's own stiffness, not to the stiffest axial mode
    d = np.sqrt(np.abs(np.diag(k)))
    d = np.where(d > 1e-300, d, 1.0)
    lam, v = sla.eigh(k / d[:, None] / d[None, :])
    big = np.abs(lam).max(initial=0.0)
    index = int(np.sum(lam < -ZERO_TOL * big))
    return Stability(index=index, lowest=float(lam[0]),
                     modes=canonical_sign(T @ (v[:, :max(index, 1)] / d[:, None])))


def canonical_sign(modes: np.ndarray) -> np.ndarray:
    """Eigenvectors (columns) with a sign that does not depend on round-off: the first entry
    (in coordinate order) of at least half the largest magnitude is positive. (An eigen
    solver's sign is arbitrary, and flips with the last digits of the matrix.)"""
    mag = np.abs(modes)
    first = np.argmax(mag >= 0.5 * mag.max(axis=0, initial=0.0), axis=0)
    sign = np.sign(modes[first, np.arange(modes.shape[1])])
    return modes * np.where(sign == 0, 1.0, sign)


def potential_energy(prob, x, mu, force, moment) -> float:
    """Elastic energy of the flexible modes minus the work of the dead forces (the measure
    by which branches at the same load are ranked; moments and gravity are left out)."""
    ev = prob.evaluate(x, mu, force, moment)
    elastic = sum(0.5 * float(np.einsum("ni,nij,nj->", st.e, g.S, st.e))
                  for g, st in zip(prob.num.groups, ev.states))
    return elastic - float(force @ x)


def switch_branch(prob, x, mu, force, moment, opts, stab: Stability, step: int):
    """Try to leave an unstable equilibrium for a stable(r) one at the same load.

    Every eigenvector of a negative eigenvalue is tried with both signs, each with the
    smallest of :data:`AMPLITUDES` from which Newton reaches an equilibrium of lower index.
    Of the equilibria found, the one with the lowest index and then the lowest potential
    energy is taken. Mirror-image branches have equal energy (to round-off: their energies
    agree to 15 digits on the leaf-spring guidance), so energies within :data:`ENERGY_TIE`
    count as equal and the first candidate tried wins, with the eigenvectors' signs made
    canonical (:func:`canonical_sign`): the branch chosen does not depend on round-off.
    Returns (x, mu, stability), the given state when no perturbation lowers the index.
    """
    from spacarpy.solvers.static import _StepFailed
    num = prob.num
    free = ~num.fixed_mask
    rot = num.is_rotation_coord[free]
    found = []
    for mode in stab.modes.T[:max(stab.index, 1)]:
        size = np.abs(mode[~rot]).max(initial=0.0) / num.length_scale + \
            np.abs(mode[rot]).max(initial=0.0)
        if size == 0:
            continue
        for sign in (1.0, -1.0):
            for amp in AMPLITUDES:
                xp = x.copy()
                xp[free] += sign * amp / size * mode
                try:
                    xn, mun, *_ = prob.newton(prob.normalize(xp), mu, force, moment, opts)
                except _StepFailed:
                    continue
                xn = prob.normalize(xn)
                sn = stability(prob, xn, mun, force, moment)
                if sn is not None and sn.index < stab.index:
                    found.append((sn.index, potential_energy(prob, xn, mun, force, moment),
                                  xn, mun, sn))
                    break
    if not found:
        return x, mu, stab
    index = min(c[0] for c in found)
    lowest = min(c[1] for c in found if c[0] == index)
    tie = ENERGY_TIE * max(abs(lowest), 1e-300)
    _, _, xb, mub, sb = next(c for c in found if c[0] == index and c[1] <= lowest + tie)
    log.info("step %d: switched from an unstable equilibrium (%d negative stiffness "
             "eigenvalue(s)) to a branch with %d", step, stab.index, index)
    return xb, mub, sb


__all__ = ["Stability", "stability", "switch_branch", "potential_energy", "canonical_sign"]

"""The conditioning limit of slender beam models, estimated before a run.

The static solver factorizes the assembled tangent (QDLDL) and refines its solutions by
conjugate gradients with an element-by-element product (:mod:`spacarpy.solvers.statics.reduced`);
the sparse eigen solver does the same with its Ritz vectors
(:mod:`spacarpy.solvers.linear.eigen_tangent`). Both need the factorization to be a fair
approximation in every direction. In the soft bending directions of a finely meshed
slender beam it is not exact: the round-off of an axial entry ``EA / l`` of the assembled
matrix is ``eps EA / l``, and the softest bending stiffness of the structure is about
``EI / L^3`` over a mode spread across ``L / l`` nodes, so the relative error of the
assembled matrix in that direction is about

    eps * kappa,    kappa = (L / l)^2 (L / r)^2,

with L the size of the model, l its shortest beam and ``r = sqrt(EI / EA)`` the smallest
radius of gyration of its sections (:func:`soft_direction_ratio`). Measured on the Table 1
cantilever (L / r = 69): the lowest eigenvalue of the factorized tangent is 2.2e-5 off at
10^4 elements (eps kappa = 1.1e-4) and 2.5e-3 at 10^5 (eps kappa = 1.1e-2), where the
refinement still converges in 3-6 iterations; at 10^6 elements eps kappa = 1.1 and the
factorization has no correct digit in those directions: the conjugate gradients stop at a
relative residual of 3e2 (issue 20). :func:`check_conditioning` stops a run above
:data:`LIMIT`, a decade above the largest size measured to work and a decade below the one
measured to fail. A well-conditioned large model (a lattice of stocky members) has a small
``kappa`` however many elements it has.
"""
from __future__ import annotations

import logging

import numpy as np

from spacarpy.elements.registry import KINDS
from spacarpy.errors import EXIT_INPUT, SpacarError

log = logging.getLogger(__name__)

#: Largest ``eps * kappa`` a run is started with (module docstring).
LIMIT = 0.1


class ConditioningLimitError(SpacarError):
    """The model's tangent cannot be factorized to any accuracy in double precision
    (exit 2: the model as given cannot be analysed; a coarser mesh can)."""

    exit_code = EXIT_INPUT


def soft_direction_ratio(model) -> tuple[float, float, float, float] | None:
    """``(kappa, L, l_min, r_min)`` of the model's beams (module docstring): the kinds
    whose ESTIFF has an ``EA`` and bending rigidities ``EI...``; None without such
    elements."""
    if model.position_ids.size < 2:
        return None
    pos_of = dict(zip(model.position_ids.tolist(), range(model.position_ids.size)))
    x0 = np.asarray(model.position_x0, dtype=float)
    size = float(np.linalg.norm(x0.max(axis=0) - x0.min(axis=0)))
    l_min, r2_min = np.inf, np.inf
    for keyword, es in model.elements.items():
        kind = KINDS.get(keyword)
        names = kind.estiff.names if kind is not None and kind.estiff is not None else ()
        bend = [i for i, nm in enumerate(names) if nm.startswith("EI")]
        if "EA" not in names or not bend or es.stiffness is None or not len(es.ids):
            continue
        ea = es.stiffness[:, names.index("EA")]
        ei = es.stiffness[:, bend].min(axis=1)
        ok = (ea > 0) & (ei > 0)
        if es.has_stiffness is not None:
            ok &= es.has_stiffness
        slots = [i for i, s in enumerate(kind.slots) if s == "pos"][:2]
        if not ok.any() or len(slots) < 2:
            continue
        p = np.array([pos_of[n] for n in es.nodes[ok, slots[0]].tolist()])
        q = np.array([pos_of[n] for n in es.nodes[ok, slots[1]].tolist()])
        length = np.linalg.norm(x0[q] - x0[p], axis=1)
        length = length[length > 0]
        if length.size:
            l_min = min(l_min, float(length.min()))
        r2_min = min(r2_min, float(np.min(ei[ok] / ea[ok])))
    if not np.isfinite(l_min) or not np.isfinite(r2_min) or size == 0:
        return None
    kappa = (size / l_min) ** 2 * size ** 2 / r2_min
    return kappa, size, l_min, float(np.sqrt(r2_min))


def check_conditioning(model, ignore: bool = False) -> None:
    """Stop before the solve when ``eps * kappa`` exceeds :data:`LIMIT`; with ``ignore``
    only warn.

    Raises
    ------
    ConditioningLimitError
        Naming kappa, the model size, the shortest beam and the radius of gyration.
    """
    found = soft_direction_ratio(model)
    if found is None:
        return
    kappa, size, l_min, r = found
    level = float(np.finfo(float).eps) * kappa
    log.debug("conditioning: kappa = %.2e, eps kappa = %.2e", kappa, level)
    if level <= LIMIT:
        return
    text = (f"the model's stiffness matrix is too ill-conditioned for double precision: "
            f"its softest bending directions are about {1 / kappa:.1e} as stiff as its "
            f"stiffest axial ones (model size {size:.3g} m / shortest beam {l_min:.3g} m, "
            f"squared, times model size / radius of gyration {r:.3g} m, squared), so "
            f"round-off leaves {level:.1f} relative error there, above the limit "
            f"{LIMIT} within which the solver converges")
    if ignore:
        log.warning("%s; running anyway (--ignore-conditioning-limit)", text)
        return
    n_max = np.sqrt(LIMIT / float(np.finfo(float).eps)) * r / size
    raise ConditioningLimitError(
        f"error: {text}. Use longer elements (the limit is at about {n_max:.3g} elements "
        f"along the model size), or run anyway with --ignore-conditioning-limit")

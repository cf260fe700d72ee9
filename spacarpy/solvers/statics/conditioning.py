"""The conditioning limits of a model, estimated before a run: the factorization's in the
soft directions of slender beams (below), the residual's round-off floor for every element
kind (:func:`check_residual_floor`, issue 34) and nodes far outside the model
(:func:`far_nodes`).

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
refinement still converges in 3-6 iterations (the bench's GA = 10 EA beams; shear-rigid ones
stop at the residual's floor first); at 10^6 elements eps kappa = 1.1 and the
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


#: A node farther than this many times the model's size (the median distance of its nodes
#: from their median) from the other nodes is outside the model: its coordinates' round-off
#: (eps times their magnitude) would exceed the model's size times sqrt(eps).
FAR_NODE = 1e8


def far_nodes(model) -> str | None:
    """A sentence naming the nodes that lie far outside the model's size (a mistyped X
    line, ``X 5 1e20 0 0``), or None."""
    x0 = np.asarray(model.position_x0, dtype=float)
    if x0.shape[0] < 3 or not np.all(np.isfinite(x0)):
        return None
    mid = x0.shape[0] // 2                 # medians by sorting (np.median loads numpy.ma)
    centre = np.sort(x0, axis=0)[mid]
    dist = np.linalg.norm(x0 - centre, axis=1)
    size = float(np.sort(dist)[mid])
    if size == 0:
        size = float(np.sort(dist)[x0.shape[0] // 2 + 1:][:1].sum()) or 1.0
    far = np.flatnonzero(dist > FAR_NODE * size)
    if not far.size:
        return None
    ids = model.position_ids[far].tolist()
    names = ", ".join(str(n) for n in ids[:5]) + (f" and {len(ids) - 5} more" if len(ids) > 5
                                                  else "")
    return (f"node{'s' if len(ids) > 1 else ''} {names} lie{'' if len(ids) > 1 else 's'} "
            f"{dist[far].max():.3g} m from the rest of the model, whose nodes lie within "
            f"about {size:.3g} m of their middle: coordinates that far outside the model's "
            f"size leave no digit for its deformations; check the X line"
            f"{'s' if len(ids) > 1 else ''}")


def check_conditioning(model, ignore: bool = False) -> None:
    """Stop before the solve when a node lies far outside the model (:func:`far_nodes`) or
    when ``eps * kappa`` exceeds :data:`LIMIT`; with ``ignore`` only warn.

    Raises
    ------
    ConditioningLimitError
        Naming kappa, the model size, the shortest beam and the radius of gyration.
    """
    far = far_nodes(model)
    if far is not None:
        if ignore:
            log.warning("%s; running anyway (--ignore-conditioning-limit)", far)
        else:
            raise ConditioningLimitError(
                f"error: {far}, or run anyway with --ignore-conditioning-limit")
        return
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
            f"round-off leaves {level:.3g} relative error there, above the limit "
            f"{LIMIT} within which the solver converges")
    if ignore:
        log.warning("%s; running anyway (--ignore-conditioning-limit)", text)
        return
    n_max = np.sqrt(LIMIT / float(np.finfo(float).eps)) * r / size
    raise ConditioningLimitError(
        f"error: {text}. Use longer elements (the limit is at about {n_max:.3g} elements "
        f"along the model size), or run anyway with --ignore-conditioning-limit")


#: Largest round-off floor of the force residual, relative to the applied load, that a
#: loaded run is started with (:func:`residual_floor`). Measured on the Table 1 cantilever:
#: shear-rigid beams converge at 3.6e-3 (10^4) and 9.6e-2 (3 x 10^4) and fail at 3.6
#: (10^5: Newton's increments stop converging at step 5, issue 34, N4); with the bench's
#: GA = 10 EA they converge at 1.2 (10^5, 4 iterations per step). The limit is the
#: geometric middle of the largest floor measured to work and the smallest measured to fail.
#: Above a floor of 1 the residual carries no digit: such steps are accepted on their
#: converged increments and the measured floor (solvers/statics/newton.py).
FLOOR_LIMIT = 2.0


def residual_floor(prob) -> tuple[float, float] | None:
    """The round-off floor of the static residual a deformed state of ``prob`` will have,
    relative to the full load (XF + DELXF), and the number of elements along the model
    ``L / l_min``; None for an unloaded model.

    It is the measured floor of
    :meth:`~spacarpy.solvers.statics.equilibrium.StaticProblem.roundoff_floor` at the initial
    configuration with every position coordinate counted at least at the model's length
    scale (a deformed state moves its coordinates by that much; a straight beam's
    transverse coordinates are exactly zero at the start). It holds for every element kind.
    Measured on the Table 1 cantilever (shear-rigid ESTIFF): 3.6e-3 at 10^4 elements, where
    the solver's floor at the solution is 2e-3 to 4e-3 of the step's load, and 9.6e-2 at
    3 x 10^4 (measured 5e-2 to 1e-1); it grows with the cube of the number of elements
    along the model (the bending stiffness EI / l over lever arms of L / l), so 10^5
    shear-rigid beams have 3.6, where Newton's increments no longer converge (issue 34, N4);
    with GA = 10 EA 1.2e-3 at 10^4."""
    num = prob.num
    load = prob.loads.at(1.0, 1.0)
    mu = np.zeros(num.n_constraint)
    ev = prob.evaluate(num.x0, mu, load)
    level = prob.force_level(ev.f_ext)
    if not level > 0:
        return None
    xs = num.x0.copy()
    xs[num.pos_idx] = np.maximum(np.abs(xs[num.pos_idx]), num.length_scale)
    floor_r, _ = prob.roundoff_floor(ev, xs, mu)
    w = np.where(prob.rot_mask[prob.free], 1.0 / num.length_scale, 1.0)
    rel = float(np.max(floor_r * w, initial=0.0)) / level
    found = soft_direction_ratio(prob.model)
    along = found[1] / found[2] if found is not None else None
    return rel, along


def check_residual_floor(prob, ignore: bool = False) -> None:
    """Stop a loaded run before the solve when :func:`residual_floor` exceeds
    :data:`FLOOR_LIMIT`; with ``ignore`` only warn.

    Raises
    ------
    ConditioningLimitError
        With the floor, and for beams the number of elements along the model where the
        limit falls."""
    found = residual_floor(prob)
    if found is None:
        return
    rel, along = found
    log.debug("conditioning: residual round-off floor %.3g of the load", rel)
    if rel <= FLOOR_LIMIT:
        return
    text = (f"the residual of the equilibrium equations cannot be resolved in double "
            f"precision: its round-off floor is {rel:.3g} times the applied load (above "
            f"the limit {FLOOR_LIMIT:g}), from the stiffness of the shortest elements times "
            f"the coordinates' round-off")
    if ignore:
        log.warning("%s; running anyway (--ignore-conditioning-limit)", text)
        return
    where = ""
    if along is not None:
        n_lim = along * (FLOOR_LIMIT / rel) ** (1 / 3)
        n_lim = round(n_lim, -int(np.floor(np.log10(n_lim))) + 1)      # two digits
        where = (f" (the limit is at about {n_lim:,.0f} beams along the model size; the "
                 f"floor grows with the cube of their number)")
    raise ConditioningLimitError(
        f"error: {text}. Use longer elements{where}, shear-flexible beams (the ESTIFF "
        f"shear terms), or run anyway with --ignore-conditioning-limit")

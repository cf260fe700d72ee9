"""The kinematic coordinates against the slips held at zero: SPACAR's class K checked and
counted (docs/rolling.md, "Kinematic coordinates").

Notation of docs/rolling.md: ``C`` the holonomic constraint Jacobian (the rigid deformation
modes that are not slips, the Euler normalizations), ``S`` the slips held at zero (the
velocity-level modes of a kind, ``velocity_modes`` on its class, that are not RLSE'd; the
kind's ``slip(x_local, ref)`` gives their rows), ``q`` the dynamic coordinates (DYNE modes,
with the RLSE modes added where the DYNE modes are too few, as the state space does), ``r``
the rheonomic ones (INPUTE, INPUTX, INPUTR) and ``p`` the kinematic ones (KINE, KINX).
``F_p = dx/dp`` along the holonomic manifold with q and r held solves the sparse system
``[C; E_r; E_q; E_p] F_p = [0; 0; 0; I]`` over the free coordinates. The checks, before any
analysis (:func:`check_kinematic`), each a :class:`~spacarpy.errors.ModelError` naming the
deck lines: as many kinematic coordinates as slips held; (q, r, p) a parameterization of the
configuration; ``S F_p`` regular, so that the slips fix the kinematic rates. The counts of
mode 0 (:func:`kinematic_report`): configuration DOF (free coordinates - rank C, the rheonomic
ones counted in), velocity DOF (configuration DOF - rank of S on the null space of C), the
classes of coordinates and deformations with SPACAR's letters, and the total mass.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.errors import ModelError
from spacarpy.model import FLEXIBLE, KINEMATIC, RELEASED, RIGID
from spacarpy.solvers.statics.diagnose import (
    NONZERO,
    _fmt,
    dependent_rows,
    numerical_rank,
    unit_rows,
)
from spacarpy.solvers.statics.slips import held_slips

__all__ = ["KinematicSetup", "check_kinematic", "kinematic_map",
           "kinematic_report", "kinematic_setup", "total_mass"]

#: Largest number of free coordinates whose holonomic rank mode 0 decides by a dense SVD;
#: above it the constraints count as independent (the static check finds redundant ones).
RANK_LIMIT = 1500

#: Relative residual of the F_p solve above which (q, r, p) does not parameterize the
#: configuration (the sparse LU succeeded on a numerically singular matrix).
SOLVE_RTOL = 1e-8


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'s' * (n != 1)}"


def _where(loc) -> str:
    return f" (line {loc.line})" if loc is not None and loc.line else ""


def _mode_name(num, gi, r, m) -> str:
    g = num.groups[gi]
    return f"{g.keyword} {int(g.ids[r])} mode {m + 1}"


def _rows(num, states, sel) -> sp.csr_matrix:
    """The rows ``d e_k / d x`` (len(sel), n_coord) of the modes ``sel`` ((group, row, mode))."""
    data, rows, cols = [], [], []
    for i, (gi, r, m) in enumerate(sel):
        g = num.groups[gi]
        data.append(states[gi].D[r, m])
        cols.append(g.idx[r])
        rows.append(np.full(g.idx.shape[1], i))
    if not sel:
        return sp.csr_matrix((0, num.n_coord))
    return sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(len(sel), num.n_coord))


@dataclass
class KinematicSetup:
    """The classes of a model's coordinates and deformation modes (SPACAR's letters) and
    the Jacobian rows of each (n_coord columns): ``hol`` the holonomic constraints (rigid
    modes that are neither slips nor prescribed, Euler normalizations), ``rheo`` the
    prescribed modes (INPUTE), ``slips`` S, ``kin`` the kinematic coordinates in deck order
    (KINE rows ``D_k``, KINX unit rows)."""

    names: dict = field(default_factory=dict)      # class -> list of names
    hol: sp.csr_matrix | None = None
    rheo: sp.csr_matrix | None = None
    slips: sp.csr_matrix | None = None
    slip_names: list = field(default_factory=list)
    kin: sp.csr_matrix | None = None
    kin_names: list = field(default_factory=list)   # "KINE 1 1 (d.dat:20)"
    dyn_sets: list = field(default_factory=list)    # [(label, rows, names)]: DYNE, DYNE+RLSE
    n_rigid: int = 0
    n_euler: int = 0
    n_prescribed_coords: int = 0
    length_scale: np.ndarray | None = None         # (n_coord,): the model's length or 1


def kinematic_setup(prob, x=None) -> KinematicSetup:
    """The :class:`KinematicSetup` of the static problem ``prob`` at x (default: the
    initial configuration)."""
    num, model = prob.num, prob.model
    x = num.x0.copy() if x is None else x
    ev = prob.evaluate(x, np.zeros(num.n_constraint), prob.loads.unloaded())
    prescribed = {(int(p.element), int(p.mode)) for p in model.prescribed_deformations}
    out = KinematicSetup()
    classes: dict[str, list] = {c: [] for c in ("O", "C", "M", "K", "rheonomic", "slip")}
    hol, rheo, flex, rel = [], [], [], []
    for gi, g in enumerate(num.groups):
        vm = set(getattr(g.kind, "velocity_modes", ()))
        for r in range(g.n_elem):
            e = int(g.ids[r])
            for m in range(g.def_class.shape[1]):
                cls, item = g.def_class[r, m], (gi, r, m)
                if m in vm:
                    if cls == RIGID:
                        classes["slip"].append(item)
                elif cls == RIGID and (e, m + 1) in prescribed:
                    rheo.append(item)
                elif cls == RIGID:
                    hol.append(item)
                elif cls == FLEXIBLE:
                    flex.append(item)
                elif cls == RELEASED:
                    rel.append(item)
    euler = np.zeros((num.euler_nodes.size, num.n_coord))
    for i, node in enumerate(num.euler_nodes):
        euler[i, num.rot_idx[node]] = 2.0 * x[num.rot_idx[node]]
    out.hol = sp.vstack([_rows(num, ev.states, hol), sp.csr_matrix(euler)]).tocsr()
    out.rheo = _rows(num, ev.states, rheo)
    out.n_rigid, out.n_euler = len(hol), int(num.euler_nodes.size)
    slips = held_slips(num)
    out.slips = slips.jacobian(x)
    out.slip_names = slips.names()
    dyn = [("DYNE", _rows(num, ev.states, flex), [_mode_name(num, *s) for s in flex])]
    if rel:
        both = sorted(flex + rel)
        dyn.append(("DYNE and RLSE", _rows(num, ev.states, both),
                    [_mode_name(num, *s) for s in both]))
    out.dyn_sets = dyn
    kin_rows, kin_names, kin_modes = [], [], []
    for kin in model.kinematic:
        kin_names.append(kin.name + _where(kin.loc))
        if kin.keyword == "KINX":
            row = np.zeros(num.n_coord)
            row[_coordinate(num, model, kin.target, kin.number)] = 1.0
            kin_rows.append(sp.csr_matrix(row))
        else:
            hit = _mode_at(num, kin.target, kin.number)
            kin_modes.append(hit)
            kin_rows.append(_rows(num, ev.states, [hit]))
    # KINEMATIC modes set without a KINE entry (a model built in Python)
    for gi, g in enumerate(num.groups):
        for r, m in zip(*np.nonzero(g.def_class == KINEMATIC)):
            if (gi, int(r), int(m)) not in kin_modes:
                kin_names.append(f"KINE {int(g.ids[r])} {int(m) + 1}")
                kin_rows.append(_rows(num, ev.states, [(gi, int(r), int(m))]))
    out.kin = (sp.vstack(kin_rows).tocsr() if kin_rows else sp.csr_matrix((0, num.n_coord)))
    out.kin_names = kin_names
    out.n_prescribed_coords = (len(model.prescribed) + len(model.prescribed_rotations))
    out.length_scale = np.where(num.is_rotation_coord, 1.0, num.length_scale)
    classes["M"] = [_mode_name(num, *s) for s in flex]
    classes["C"] = [_mode_name(num, *s) for s in rel]
    classes["K"] = kin_names
    classes["rheonomic"] = [_mode_name(num, *s) for s in rheo] + [
        f"INPUTX {p.node} {p.coord}" for p in model.prescribed] + [
        f"INPUTR {p.node}" for p in model.prescribed_rotations]
    classes["O"] = [_mode_name(num, *s) for s in hol]
    classes["slip"] = out.slip_names
    out.names = classes
    return out


def _coordinate(num, model, node: int, c: int) -> int:
    hit = np.flatnonzero(model.position_ids == node)
    if hit.size:
        return int(num.pos_idx[hit[0], c - 1])
    return int(num.rot_idx[np.flatnonzero(model.orientation_ids == node)[0], c - 1])


def _mode_at(num, e: int, k: int) -> tuple[int, int, int]:
    for gi, g in enumerate(num.groups):
        hit = np.flatnonzero(g.ids == e)
        if hit.size:
            return gi, int(hit[0]), k - 1
    raise KeyError(e)


def _free_scale(setup: KinematicSetup, free) -> np.ndarray | None:
    return None if setup.length_scale is None else setup.length_scale[np.flatnonzero(free)]


def _config_dof(setup: KinematicSetup, free) -> int:
    """Free coordinates - rank C, plus the prescribed coordinates (INPUTX, INPUTR)."""
    hol = setup.hol.toarray()[:, np.flatnonzero(free)]
    return (int(np.count_nonzero(free)) - _holonomic_rank(hol, _free_scale(setup, free))
            + setup.n_prescribed_coords)


def _holonomic_rank(hol: np.ndarray, scale: np.ndarray | None) -> int:
    """The rank of the holonomic rows over the free coordinates (dense; positions in units
    of the model's length ``scale``, rows of unit norm)."""
    if hol.shape[0] == 0 or hol.shape[1] == 0:
        return 0
    if hol.shape[1] > RANK_LIMIT:
        return hol.shape[0]
    scaled = unit_rows(hol * (1.0 if scale is None else scale[None, :]))
    return numerical_rank(scaled, right=False)[0].rank


def _fp(setup: KinematicSetup, free) -> tuple[np.ndarray | None, str]:
    """F_p over the free coordinates (None when no DOF set parameterizes the configuration)
    and the label of the DOF set used."""
    n_free = int(np.count_nonzero(free))
    k = setup.kin.shape[0]
    for label, dyn, _ in setup.dyn_sets:
        M = sp.vstack([setup.hol, setup.rheo, dyn, setup.kin]).tocsc()[:, np.flatnonzero(free)]
        if M.shape[0] != n_free:
            continue
        rhs = np.zeros((n_free, k))
        rhs[n_free - k:] = np.eye(k)
        try:
            F = spla.splu(M.tocsc()).solve(rhs)
        except RuntimeError:          # exactly singular
            continue
        scale = max(abs(M).max(), 1.0)
        if np.all(np.isfinite(F)) and \
                np.abs(M @ F - rhs).max() <= SOLVE_RTOL * scale * max(np.abs(F).max(), 1.0):
            return F, label
    return None, ""


def _dimensionless(setup: KinematicSetup, free, F) -> np.ndarray:
    """``S F_p`` without units, for its rank: positions in units of the model's length
    (``x~ = x / l``, Euler parameters as they are), each column of F_p (a motion) and each
    slip row of unit norm. Not an equilibration of ``S F_p`` itself: that would blow a
    column that is zero up to round-off (a rate the slips do not see) up to one."""
    idx = np.flatnonzero(free)
    scale = _free_scale(setup, free)
    scale = np.ones(idx.size) if scale is None else scale
    Ft = F / scale[:, None]
    Ft = Ft / np.maximum(np.linalg.norm(Ft, axis=0), np.finfo(float).tiny)
    St = unit_rows(setup.slips.tocsc()[:, idx].toarray() * scale[None, :])
    return St @ Ft


def check_kinematic(prob) -> dict | None:
    """The checks of the module docstring at the initial configuration; None for a model
    without slips and kinematic coordinates, else the counts for :func:`kinematic_report`.

    Raises
    ------
    ModelError
        A wrong number of kinematic coordinates, a choice of dynamic, rheonomic and
        kinematic coordinates that does not parameterize the configuration, or one whose
        ``S F_p`` is singular (naming the dependent slips and the kinematic coordinates
        whose rates they leave free).
    """
    num, model = prob.num, prob.model
    if not model.kinematic and not held_slips(num).n and \
            not any(np.any(g.def_class == KINEMATIC) for g in num.groups):
        return None
    setup = kinematic_setup(prob)
    k, n_kin = setup.slips.shape[0], setup.kin.shape[0]
    if k != n_kin:
        held = f" ({_fmt(setup.slip_names, limit=8)})" if k else ""
        raise ModelError(
            f"{_plural(k, 'slip')} held{held}, {n_kin} kinematic coordinate"
            f"{'s' * (n_kin != 1)} declared ({_fmt(setup.kin_names, limit=8, sep='; ')}): "
            f"the slips need {k} kinematic coordinate{'s' * (k != 1)} (KINE/KINX), one per "
            "slip held at zero (a WHEEL's modes 4 and 5 unless RLSE'd)")
    free = ~num.fixed_mask
    F, label = kinematic_map(setup, free)
    k, n_kin = setup.slips.shape[0], setup.kin.shape[0]
    conf = _config_dof(setup, free)
    return {"setup": setup, "config_dof": conf, "velocity_dof": conf - k, "dof_set": label,
            "F_p": F}


def kinematic_map(setup: KinematicSetup, free) -> tuple[np.ndarray, str]:
    """F_p (n_free, k) and the DOF set used (``DYNE`` or ``DYNE and RLSE``), after checking
    that (q, r, p) parameterize the configuration and that ``S F_p`` is regular.

    Raises
    ------
    ModelError
        As :func:`check_kinematic`.
    """
    k, n_kin = setup.slips.shape[0], setup.kin.shape[0]
    F, label = _fp(setup, free)
    if F is None:
        conf = _config_dof(setup, free)
        dyn = [rows.shape[0] for _, rows, _ in setup.dyn_sets]
        raise ModelError(
            f"the dynamic, rheonomic and kinematic coordinates do not parameterize the "
            f"configuration: it has {conf} degrees of freedom, the model gives "
            f"{' or '.join(str(d) for d in dyn)} dynamic (DYNE, or DYNE and RLSE), "
            f"{setup.rheo.shape[0] + setup.n_prescribed_coords} rheonomic (INPUTE, INPUTX, "
            f"INPUTR) and {n_kin} kinematic (KINE/KINX) coordinates, or they are not "
            "independent")
    if k:
        rank, N, L = numerical_rank(_dimensionless(setup, free, F), right=True, left=True)
        if rank.rank < k:
            dep, _ = dependent_rows(L)
            loose = sorted({j for col in N.T for j in np.flatnonzero(
                np.abs(col) > NONZERO * np.abs(col).max())})
            raise ModelError(
                f"the slips cannot fix the rates of the kinematic coordinates: S F_p has rank "
                f"{rank.rank} of {k}; dependent slip rows: "
                f"{_fmt([setup.slip_names[i] for i in dep], limit=8)}; kinematic "
                f"coordinates whose rates the slips leave free: "
                f"{_fmt([setup.kin_names[j] for j in loose], limit=8, sep='; ')}. The "
                f"{_plural(k, 'slip')} need {k} kinematic coordinates whose rates they "
                "determine; a coordinate whose rate is free (a degree of freedom, such as a "
                "lean angle) must be DYNE, not kinematic")
    return F, label


def total_mass(prob) -> float:
    """The model's total mass (kg): ``u^T M u`` of a unit translation of every position node
    along x, from the nodal masses (XM) and the elements' mass kernels (EM)."""
    num, model = prob.num, prob.model
    positions = set(model.position_ids.tolist())
    total = sum(float(m.values[0]) for m in model.nodal_masses if m.node in positions)
    is_x = np.zeros(num.n_coord)
    is_x[num.pos_idx[:, 0]] = 1.0
    x = num.x0
    for g in num.groups:
        if g.kind.mass is None or not np.any(g.mass):
            continue
        Me = g.kind.mass(x[g.idx], g.ref, g.mass)
        u = is_x[g.idx]
        total += float(np.einsum("ni,nij,nj->", u, Me, u))
    return total


def kinematic_report(prob) -> list[str]:
    """The lines mode 0 adds to the degree-of-freedom report: holonomic and non-holonomic
    constraints, configuration and velocity degrees of freedom, the classes of the
    coordinates and deformations with SPACAR's letters, and the total mass (for a model
    without slips and kinematic coordinates only the mass, when it has any)."""
    num, model = prob.num, prob.model
    counts = check_kinematic(prob)
    total = total_mass(prob)
    mass = f"  total mass          {total:.10g} kg"
    if counts is None:              # no slips, no kinematic coordinates: the report has it
        return [mass] if total else []
    s = counts["setup"]
    n = s.names
    k = s.slips.shape[0]
    lines = [f"  holonomic           {s.n_rigid + s.n_euler} ({s.n_rigid} rigid modes + "
             f"{s.n_euler} Euler normalizations)"
             + (f", {_plural(s.rheo.shape[0], 'prescribed mode')} (rheonomic)"
                if s.rheo.shape[0] else ""),
             f"  non-holonomic       {k}" + (f" ({_fmt(s.slip_names, limit=8)})" if k else ""),
             f"  configuration DOF   {counts['config_dof']}",
             f"  velocity DOF        {counts['velocity_dof']}"]
    for letter, what in (("M", "dynamic"), ("K", "kinematic")):
        items = n[letter]
        lines.append(f"  {letter} {what:<17} {len(items)}"
                     + (f": {_fmt(items, limit=8, sep='; ')}" if items else ""))
    if n["rheonomic"]:
        lines.append(f"  rheonomic           {len(n['rheonomic'])}: "
                     f"{_fmt(n['rheonomic'], limit=8, sep='; ')}")
    n_kinx = sum(kin.keyword == "KINX" for kin in model.kinematic)
    n_free = int(np.count_nonzero(~num.fixed_mask))
    lines.append(f"  C calculable        {_plural(len(n['C']), 'deformation mode')} (RLSE)"
                 + (f": {_fmt(n['C'], limit=8, sep='; ')}" if n["C"] else "")
                 + f", {n_free - n_kinx} coordinates")
    n_fix = sum(len(f.coords) for f in model.fixes)
    lines.append(f"  O fixed             {_plural(len(n['O']), 'deformation mode')}"
                 + (f" and {_plural(k, 'slip')}" if k else "") + f", {n_fix} coordinates (FIX)")
    return lines + [mass]

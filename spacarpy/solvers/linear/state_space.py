"""The linearized equations in degrees of freedom and their first-order state space (SPACAR
mode 9).

About an equilibrium, the linearized equations over the free coordinates dx, subject to the
linearized constraints ``C dx = 0`` (:mod:`spacarpy.solvers.linear.linearize`), are

    M ddx + C_d dx' + K dx = F u,      y = [O_x dx + O_v dx'],

with K = K0 + G0 + N0 the tangent the eigen analysis uses, C_d the damping (DAMPING's
``alpha M + beta K0`` and EDAMP's ``D^T diag(d) D``; at a static state the velocity-dependent
terms vanish), F the INPUTF and INPUTS columns and O the output rows. The degrees of freedom q are
SPACAR's: the flexible deformation modes (DYNE), with a BEAMW warping mode for each free
warping node, or with RLSE modes added when the DYNE modes alone are too few. With ``E``
the rows of the chosen deformations, the coordinates follow from q by ``dx = Phi q``,
where Phi is the one solution of ``C Phi = 0, E Phi = I``
(``Phi = T (E T)^-1`` for any basis T of the null space of C, so no basis choice enters).
Then

    M0 = Phi^T M Phi,  C0 = Phi^T C_d Phi,  K0 = Phi^T K Phi,  B0 = Phi^T F,

the eigenvalues of (K0, M0) are those of :mod:`spacarpy.solvers.linear.eigen`, and the state
``z = [q; q']`` gives ``A = [[0, I], [-M0^-1 K0, -M0^-1 C0]]``, ``B = [[0], [M0^-1 B0]]``,
``C = [O_x Phi, O_v Phi]`` and ``D = 0``. The poles, the eigenvalues of A, are computed from
the second-order equations and refined (:mod:`spacarpy.solvers.linear.refine`): undamped,
``+-i w`` with w^2 the refined eigenvalues of (K0, M0), equal to the eigen analysis' to
their bounds even beside modes 10^4 times stiffer.

Inputs and outputs (:class:`spacarpy.settings.SystemSignal`): ``INPUTF i n c`` is a unit
generalized force on coordinate c of node n: a force along x, y or z on a position node; on
an orientation node the generalized force conjugate to the Euler parameter lambda_(c-1), as
in SPACAR (a moment M acts as ``2 Lambda(q)^T M``; at the identity orientation a unit
generalized force on lambda_j, j = 1..3, is the moment 1/2 about axis j). ``OUTX`` /
``OUTXP`` give that coordinate's change / rate (on an orientation node the Euler parameter:
about the identity, ``dlambda_j = dphi_j / 2``). In a planar model the orientation node's one
coordinate is its rotation about z: a moment about z in, the rotation angle out (as INPUTX
reads it there). ``OUTE`` / ``OUTEP`` give deformation k of element e and its rate.
``INPUTS i e k`` is a unit stress resultant on deformation k of element e (an actuator in a
joint): its generalized force is ``-D_k^T``, so that ``B0`` gets ``-Phi^T D_k^T`` (ESIG's
sign: a positive stress resultant drives its mode negative). Outputs and inputs on fixed
coordinates are zero rows / columns; so are the numbers without a line (gaps).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from spacarpy.elements.base import FLEXIBLE, RELEASED, SLOT_SIZE
from spacarpy.errors import EXIT_INPUT, ModelError, SpacarError
from spacarpy.rotation import lambda_matrix
from spacarpy.solvers.linear.eigen import null_space_basis
from spacarpy.solvers.linear.refine import second_order_poles

__all__ = ["DofLayout", "StateSpace", "StateSpaceError", "dof_layout", "dof_map", "dof_rows",
           "first_order",
           "input_columns", "output_rows", "state_space"]

#: Smallest singular value, relative to the largest, of the scaled map from the degrees of
#: freedom to the chosen deformations for which they count as independent: far above
#: round-off (1e-16), far below any real structure's spread.
INDEPENDENCE_RTOL = 1e-10


class StateSpaceError(SpacarError):
    """The state space cannot be formed (no inertia in some degree of freedom)."""

    exit_code = EXIT_INPUT


@dataclass(frozen=True)
class DofLayout:
    """The degrees of freedom: first the DYNX coordinates (``coords``: (node, coordinate)
    rows, in the order of the numbering's ``dynamic_idx``), then deformation mode
    ``mode[i]`` (1-based) of element ``element[i]`` (deck number) of kind ``keyword[i]``;
    ``group``/``row``/``col`` locate it in the numbering's element groups (0-based)."""

    element: np.ndarray
    mode: np.ndarray
    keyword: tuple
    group: np.ndarray
    row: np.ndarray
    col: np.ndarray
    coords: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))

    @property
    def n_dof(self) -> int:
        return int(self.coords.shape[0] + self.element.size)

    @property
    def names(self) -> list[str]:
        """``node 4 coordinate 1`` for each DYNX coordinate, then ``BEAM 3 mode 2`` for
        each deformation mode."""
        return ([f"node {n} coordinate {c}" for n, c in self.coords.tolist()]
                + [f"{k} {e} mode {m}" for k, e, m in zip(self.keyword, self.element.tolist(),
                                                          self.mode.tolist())])

    @property
    def file_names(self) -> dict:
        """``dof_element``, ``dof_mode`` (and ``dof_node`` with DYNX coordinates) as the
        result file stores them: a DYNX coordinate has element 0, its coordinate number as
        the mode and its node; a deformation mode node 0."""
        n_x = self.coords.shape[0]
        out = dict(dof_element=np.concatenate([np.zeros(n_x, np.int64), self.element]),
                   dof_mode=np.concatenate([self.coords[:, 1], self.mode]).astype(np.int64))
        if n_x:
            out["dof_node"] = np.concatenate([self.coords[:, 0],
                                              np.zeros(self.element.size, np.int64)])
        return out

    @property
    def state_names(self) -> list[str]:
        """The names of the state ``[q; q']``."""
        return self.names + [f"rate of {n}" for n in self.names]


@dataclass
class StateSpace:
    """The linearized equations at one state: second order in the degrees of freedom (M0,
    C0, K0, B0) and first order (A, B, C, D); ``pole`` the eigenvalues of A computed from
    the second-order equations and refined, ``pole_bound`` an error bound of each
    (:func:`spacarpy.solvers.linear.refine.second_order_poles`)."""

    M0: np.ndarray
    C0: np.ndarray
    K0: np.ndarray
    B0: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    pole: np.ndarray | None = field(default=None, kw_only=True)
    pole_bound: np.ndarray | None = field(default=None, kw_only=True)


def _modes_of(num, classes) -> DofLayout:
    """The DYNX coordinates, then the deformation modes of the classes ``classes``, group
    by group, element-major."""
    group, row, col, element, keyword = [], [], [], [], []
    for gi, g in enumerate(num.groups):
        r, c = np.nonzero(np.isin(g.def_class, classes))
        group.append(np.full(r.size, gi, np.int64))
        row.append(r.astype(np.int64))
        col.append(c.astype(np.int64))
        element.append(g.ids[r].astype(np.int64))
        keyword += [g.keyword] * r.size

    def cat(parts):
        return np.concatenate(parts) if parts else np.zeros(0, np.int64)

    return DofLayout(element=cat(element), mode=cat(col) + 1, keyword=tuple(keyword),
                     group=cat(group), row=cat(row), col=cat(col),
                     coords=np.asarray(num.dynamic_label, np.int64).reshape(-1, 2))


def _with_warping(num, free, lay: DofLayout) -> DofLayout:
    """``lay`` with, for each free warping node (BEAMW) that no mode of ``lay`` holds, the
    warping mode (7 at p, 8 at q) of the first BEAMW using it: SPACAR's warping coordinates
    of free warping nodes are degrees of freedom ("ep_7 and ep_8 are always calculable"),
    and that mode is ``l0^2 w`` minus the torsion, so it stands for the coordinate."""
    if not num.warp_idx.size:
        return lay
    taken = {(int(g), int(r), int(c)) for g, r, c in zip(lay.group, lay.row, lay.col)}
    held, extra = set(), []
    for gi, g in enumerate(num.groups):
        slots = [j for j, s in enumerate(g.kind.slots) if s == "warp"]
        if not slots:
            continue
        local = np.cumsum([0] + [SLOT_SIZE[s] for s in g.kind.slots])
        for r in range(g.n_elem):
            for m, j in enumerate(slots):
                coord = int(g.idx[r, local[j]])
                if (gi, r, 6 + m) in taken:
                    held.add(coord)
                elif free[coord] and coord not in held:
                    held.add(coord)
                    extra.append((gi, r, 6 + m))
    if not extra:
        return lay
    rows = sorted(taken | set(extra))
    group, row, col = (np.array(v, np.int64) for v in zip(*rows))
    keyword = tuple(num.groups[g].keyword for g in group)
    element = np.array([num.groups[g].ids[r] for g, r in zip(group, row)], np.int64)
    return DofLayout(element=element, mode=col + 1, keyword=keyword, group=group, row=row,
                     col=col)


def deformation_rows(lin, num, free, group, row, col, scaled: bool = False) -> np.ndarray:
    """The rows ``d e / d x`` (len(row), n_x) over the free coordinates of the deformation
    modes ``col`` of elements ``row`` of the element groups ``group``; ``scaled``: each row
    divided by its mode's length scale and the position columns multiplied by the model's
    length scale (dimensionless)."""
    n_x = int(np.count_nonzero(free))
    u = np.full(num.n_coord, -1, dtype=np.int64)
    u[free] = np.arange(n_x)
    out = np.zeros((row.size, n_x))
    for gi in np.unique(group):
        g, st = num.groups[gi], lin.states[gi]
        sel = np.flatnonzero(group == gi)
        d = st.D[row[sel], col[sel], :]                                # (n_sel, n_ldof)
        if scaled:
            d = d / g.scale[row[sel], col[sel]][:, None]
        cols = u[g.idx[row[sel]]]                                      # (n_sel, n_ldof)
        r = np.broadcast_to(sel[:, None], cols.shape)
        ok = cols >= 0
        np.add.at(out, (r[ok], cols[ok]), d[ok])
    if scaled:
        out[:, ~num.is_rotation_coord[free]] *= num.length_scale
    return out


def dof_rows(lin, num, free, layout: DofLayout, scaled: bool = False) -> np.ndarray:
    """E (n_dof, n_x): the rows of the degrees of freedom over the free coordinates at the
    state of ``lin``: the DYNX coordinates' (:meth:`Numbering.dynamic_rows
    <spacarpy.numbering.Numbering.dynamic_rows>`), then the deformation modes'
    (:func:`deformation_rows`); ``scaled`` as there (a position coordinate per length
    scale)."""
    E = deformation_rows(lin, num, free, layout.group, layout.row, layout.col, scaled=scaled)
    if not layout.coords.shape[0]:
        return E
    X = num.dynamic_rows(lin.x)[:, free]
    if scaled:                      # dimensionless: a position coordinate per length scale
        X[:, ~num.is_rotation_coord[free]] *= num.length_scale
        X[~num.is_rotation_coord[num.dynamic_idx]] /= num.length_scale
    return np.vstack([X, E])


def dof_layout(lin, num, free) -> DofLayout:
    """The degrees of freedom of the linearization ``lin``: the flexible modes (DYNE); or
    those and, for each free warping node, a warping mode (:func:`_with_warping`); or the
    flexible and released ones (DYNE, RLSE) when the first are too few; a model with DYNX
    lines has its DYNX coordinates and DYNE modes (and warping modes), never RLSE ones
    (SPACAR's dynamic class). They must be independent and as many as the model's degrees
    of freedom.

    Raises
    ------
    ModelError
        When neither set fits, with the counts and what to change.
    """
    n_x = int(np.count_nonzero(free))
    T = null_space_basis(lin.C, n_x)
    n_dof = T.shape[1]
    counts = []
    dynx = bool(num.dynamic_idx.size)
    candidates = ((FLEXIBLE,), "warping") + (() if dynx else ((FLEXIBLE, RELEASED),))
    for classes in candidates:
        if classes == "warping":    # the flexible modes and the free warping nodes' modes
            lay = _with_warping(num, free, _modes_of(num, (FLEXIBLE,)))
            if lay.n_dof == counts[0]:
                continue
        else:
            lay = _modes_of(num, classes)
            counts.append(lay.n_dof)
        if lay.n_dof != n_dof:
            continue
        if n_dof == 0:
            return lay
        sv = np.linalg.svd(dof_rows(lin, num, free, lay, scaled=True) @ T, compute_uv=False)
        if sv.min() > INDEPENDENCE_RTOL * sv.max():
            return lay
    if dynx:
        raise ModelError(
            f"the state space needs SPACAR's degrees of freedom: the DYNX coordinates and "
            f"DYNE modes ({counts[0]}) must be independent and as many as the model's "
            f"degrees of freedom ({n_dof})")
    raise ModelError(
        f"the state space needs SPACAR's degrees of freedom: as many independent flexible "
        f"(DYNE) deformation modes as the model has degrees of freedom ({n_dof}); the model "
        f"has {counts[0]} flexible and {counts[1] - counts[0]} released (RLSE) modes, and "
        f"neither set fits (make the modes that carry no stiffness RLSE, or the dependent "
        f"ones rigid)")


def damping_matrix(lin, num, free, model, M) -> sp.csc_matrix:
    """C_d over the free coordinates: Rayleigh ``alpha M + beta D^T S D`` (DAMPING) and
    ``D^T diag(d) D`` (EDAMP), as the transient solver applies them."""
    n_x = int(np.count_nonzero(free))
    alpha, beta = model.damping
    out = sp.csc_matrix((n_x, n_x))
    if alpha and M is not None:
        out = out + alpha * M
    u = np.full(num.n_coord, -1, dtype=np.int64)
    u[free] = np.arange(n_x)
    for g, st in zip(num.groups, lin.states):
        if not beta and g.damp is None:
            continue
        c = beta * g.S
        if g.damp is not None:
            c = c + g.damp[:, :, None] * np.eye(g.kind.n_def)
        blocks = st.D.transpose(0, 2, 1) @ c @ st.D                    # (n, n_ldof, n_ldof)
        idx = u[g.idx]
        r = np.broadcast_to(idx[:, :, None], blocks.shape)
        cc = np.broadcast_to(idx[:, None, :], blocks.shape)
        ok = (r >= 0) & (cc >= 0)
        out = out + sp.csc_matrix((blocks[ok], (r[ok], cc[ok])), shape=(n_x, n_x))
    return out.tocsc()


def coordinate_row(num, model, x, node: int, c: int) -> np.ndarray:
    """The row (n_coord,) that takes coordinate c (1-based) of deck node ``node`` out of a
    change of the coordinates: a unit row, except for the orientation node of a planar model,
    whose coordinate 1 is the rotation about z, ``dphi_z = 2 Lambda_z(q) dq``. Its transpose
    is the generalized force of a unit force (moment) on that coordinate."""
    row = np.zeros(num.n_coord)
    hit = np.flatnonzero(model.position_ids == node)
    if hit.size:
        row[num.pos_idx[hit[0], c - 1]] = 1.0
        return row
    hit = np.flatnonzero(model.warping_ids == node)
    if hit.size:                            # a warping node's rate of twist (a bimoment in)
        row[num.warp_idx[hit[0]]] = 1.0
        return row
    ri = num.rot_idx[np.flatnonzero(model.orientation_ids == node)[0]]
    if model.planar:
        row[ri] = 2.0 * lambda_matrix(x[ri])[2]
    else:
        row[ri[c - 1]] = 1.0
    return row


def _element_at(num, e: int, k: int):
    for gi, g in enumerate(num.groups):
        hit = np.flatnonzero(g.ids == e)
        if hit.size:
            return gi, int(hit[0]), k - 1
    raise KeyError(e)


def dof_map(lin, num, free, layout: DofLayout) -> np.ndarray:
    """Phi (n_x, n_dof): the free-coordinate change ``dx = Phi q`` of the degrees of freedom
    at the linearization ``lin`` (``C Phi = 0``, ``E Phi = I``).

    Raises
    ------
    ModelError
        When the chosen deformations are no longer independent at this state.
    """
    n_x = int(np.count_nonzero(free))
    T = null_space_basis(lin.C, n_x)
    E = dof_rows(lin, num, free, layout)
    W = E @ T
    if layout.n_dof:
        ws = dof_rows(lin, num, free, layout, scaled=True) @ T
        sv = np.linalg.svd(ws, compute_uv=False)
        if W.shape[0] != W.shape[1] or sv.min() <= INDEPENDENCE_RTOL * sv.max():
            raise ModelError("the degrees of freedom of the state space (the DYNX "
                             "coordinates and flexible deformation modes) are not "
                             "independent at this state")
    return T @ np.linalg.solve(W, np.eye(layout.n_dof)) if layout.n_dof else T


def _slots(signals) -> int:
    """The number of inputs or outputs: the largest number (a gap is a zero column/row)."""
    return max((s.index for s in signals), default=0)


def input_columns(lin, num, free, model, inputs) -> np.ndarray:
    """F (n_x, n_in): the generalized forces of the unit inputs at the state of ``lin``,
    column i - 1 for input i (zero for a number without a line). ``INPUTS i e k``, a unit
    stress resultant on deformation k of element e, acts as ``-D_k^T`` (ESIG's sign: a
    positive stress resultant drives its mode negative)."""
    n_x = int(np.count_nonzero(free))
    F = np.zeros((n_x, _slots(inputs)))
    for s in inputs:
        if s.keyword == "INPUTS":
            gi, r, c = _element_at(num, s.target, s.number)
            F[:, s.index - 1] = -deformation_rows(lin, num, free, np.array([gi]),
                                                  np.array([r]), np.array([c]))[0]
        else:
            F[:, s.index - 1] = coordinate_row(num, model, lin.x, s.target, s.number)[free]
    return F


def output_rows(lin, num, free, model, outputs) -> tuple[np.ndarray, np.ndarray]:
    """(rows, is_rate): the row (n_out, n_x) of each output's coordinate or deformation at
    the state of ``lin`` and whether the output is its rate (OUTXP, OUTEP)."""
    n_x = int(np.count_nonzero(free))
    rows = np.zeros((_slots(outputs), n_x))
    rate = np.zeros(rows.shape[0], bool)
    for s in outputs:
        i = s.index - 1
        rate[i] = s.keyword in ("OUTXP", "OUTEP")
        if s.keyword in ("OUTX", "OUTXP"):
            rows[i] = coordinate_row(num, model, lin.x, s.target, s.number)[free]
        else:
            gi, r, c = _element_at(num, s.target, s.number)
            rows[i] = deformation_rows(lin, num, free, np.array([gi]), np.array([r]),
                                       np.array([c]))[0]
    return rows, rate


def first_order(M0, C0, K0, B0, out_q, out_dq, names) -> StateSpace:
    """The state space of ``M0 q'' + C0 q' + K0 q = B0 u``, ``y = out_q q + out_dq q'``
    (``names``: the degrees of freedom, for the message when M0 is singular)."""
    M0 = 0.5 * (M0 + M0.T)
    try:
        chol = sla.cho_factor(M0)
    except np.linalg.LinAlgError:
        diag = np.diag(M0)
        weak = [n for n, m in zip(names, diag) if not m > 0] or names
        raise StateSpaceError(
            "the state space needs inertia in every degree of freedom, but the mass matrix "
            f"is singular there ({', '.join(weak[:8])}{' ...' if len(weak) > 8 else ''}): "
            "give the rotary inertia of EM (rhoIp rhoIy rhoIz) or XM masses") from None
    n = M0.shape[0]
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -sla.cho_solve(chol, K0)
    A[n:, n:] = -sla.cho_solve(chol, C0)
    B = np.zeros((2 * n, B0.shape[1]))
    B[n:] = sla.cho_solve(chol, B0)
    C = np.hstack([out_q, out_dq])
    D = np.zeros((C.shape[0], B0.shape[1]))
    pole, bound = second_order_poles(M0, C0, K0, A)
    return StateSpace(M0=M0, C0=C0, K0=K0, B0=B0, A=A, B=B, C=C, D=D, pole=pole,
                      pole_bound=bound)


def state_space(lin, num, free, model, layout: DofLayout, inputs, outputs) -> StateSpace:
    """The matrices of the module docstring at the linearization ``lin`` (with mass).

    Raises
    ------
    StateSpaceError
        When M0 is not positive definite (a degree of freedom without inertia), naming the
        degrees of freedom concerned.
    ModelError
        When the chosen deformations are no longer independent at this state.
    """
    phi = dof_map(lin, num, free, layout)
    M0 = phi.T @ (lin.M @ phi)
    K0 = phi.T @ (lin.K @ phi)
    C0 = phi.T @ (damping_matrix(lin, num, free, model, lin.M) @ phi)
    B0 = phi.T @ input_columns(lin, num, free, model, inputs)
    rows, rate = output_rows(lin, num, free, model, outputs)
    out_q = np.where(rate[:, None], 0.0, rows) @ phi
    out_dq = np.where(rate[:, None], rows, 0.0) @ phi
    return first_order(M0, C0, K0, B0, out_q, out_dq, layout.names)

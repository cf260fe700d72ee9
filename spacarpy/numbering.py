"""Numbering: from deck node numbers to global coordinates, element groups and constraints.

The global coordinate vector holds every nodal coordinate: 3 per position node, 4 Euler
parameters per orientation node, 1 (the rate of twist) per warping node, nodes in ascending
deck number (so that chains of elements
give banded matrices). Fixed coordinates keep their initial value; every other coordinate is
an unknown of the static problem. Elements are held in *groups*, one per element kind
(:mod:`spacarpy.elements.registry`), each with its global coordinate indices, reference data
and stiffness. The constraints are the rigid deformation modes of all groups (``e_i(x) = 0``, in
group order) followed by the normalization ``q.q = 1`` of each orientation node that is not
completely fixed. See docs/solver.md.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from spacarpy.elements.base import ElementKind, Reference
from spacarpy.elements.registry import KINDS
from spacarpy.model import RIGID, Model


@dataclass
class ElementGroup:
    """All elements of one kind, ready for vectorized evaluation (element index first).

    Attributes
    ----------
    kind : ElementKind
    ids : (n,) int
        Deck element numbers.
    nodes : (n, n_slots) int
        Deck node numbers per slot.
    idx : (n, n_ldof) int
        Global coordinate indices of the local coordinates.
    def_class : (n, n_def) int8
    stiff_mask : (n, n_def) bool
        Modes whose stress resultant is S e (flexible, or released with ESTIFF).
    S : (n, n_def, n_def)
        Stiffness with the rows/columns of modes without stiffness zeroed.
    ref : Reference
        The kind's reference record (:attr:`ElementKind.reference_type`: triads, lengths,
        axes).
    scale : (n, n_def)
        Length (or 1 for angles) that makes each deformation dimensionless.
    mass : (n, n_em)
        EM data in the kind's layout.
    rigid_elem, rigid_mode : (n_rigid_g,) int
        Rows and modes of this group's rigid deformations.
    rigid_offset : int
        Position of the first of them among all rigid constraints.
    prev : dict
        Persistent per-element state between converged steps (hinge turn counts).
    """

    kind: ElementKind
    ids: np.ndarray
    nodes: np.ndarray
    idx: np.ndarray
    def_class: np.ndarray
    stiff_mask: np.ndarray
    S: np.ndarray
    ref: Reference
    scale: np.ndarray
    mass: np.ndarray
    rigid_elem: np.ndarray
    rigid_mode: np.ndarray
    rigid_offset: int = 0
    prev: dict = field(default_factory=dict)
    damp: np.ndarray | None = None       # (n, n_def) EDAMP coefficients (None: none)
    sigma0: np.ndarray | None = None     # (n, n_def) ESIG pre-stress (None: none)

    @property
    def n_elem(self) -> int:
        return int(self.ids.size)

    @property
    def keyword(self) -> str:
        return self.kind.keyword

    @property
    def rigid_slice(self) -> slice:
        return slice(self.rigid_offset, self.rigid_offset + self.rigid_elem.size)


@dataclass
class Numbering:
    """Coordinate and constraint numbering of a model (all arrays entity-first).

    Attributes
    ----------
    n_coord : int
        Total number of nodal coordinates.
    x0 : (n_coord,) float
        Initial coordinates (orientation nodes at the identity).
    pos_idx : (n_pos, 3) int
        Global coordinate indices of each position node (order of ``model.position_ids``).
    rot_idx : (n_rot, 4) int
        Global coordinate indices of each orientation node (order of ``model.orientation_ids``).
    warp_idx : (n_warp,) int
        Global coordinate index of each warping node (order of ``model.warping_ids``).
    groups : list of ElementGroup
        One per element kind present (BEAM first).
    fixed_mask : (n_coord,) bool
        Fixed and prescribed coordinates (neither is an unknown), including the
        out-of-plane coordinates of a planar model (``planar_mask``).
    unknown_of : (n_coord,) int
        Unknown number of each coordinate, -1 where fixed.
    n_unknown : int
    euler_nodes : (n_euler,) int
        Orientation-node indices (into ``rot_idx``) that carry a normalization constraint.
    length_scale : float
        Characteristic length of the model (bounding-box diagonal) used to scale norms.
    prescribed_idx, prescribed_initial, prescribed_delta : (n_presc,)
        Global indices of the prescribed coordinates, their values at step 0 and their
        increments over the load steps.
    rigid_initial, rigid_delta, rigid_prescribed : (n_rigid,)
        Prescribed deformations (INPUTE/DELINPE) among the rigid-mode constraints: their
        values at step 0, their increments, and which constraints they are (empty arrays
        when the model has none).
    """

    n_coord: int
    x0: np.ndarray
    pos_idx: np.ndarray
    rot_idx: np.ndarray
    groups: list
    fixed_mask: np.ndarray
    unknown_of: np.ndarray
    n_unknown: int
    euler_nodes: np.ndarray
    length_scale: float
    prescribed_idx: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    prescribed_initial: np.ndarray = field(default_factory=lambda: np.zeros(0))
    prescribed_delta: np.ndarray = field(default_factory=lambda: np.zeros(0))

    rigid_initial: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rigid_delta: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rigid_prescribed: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    # the transient motion of the 5-field INPUTX/INPUTE: rate and second derivative at t = 0
    prescribed_rate: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    rigid_rate: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    rotation_idx: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), np.int64))
    rotation_axis: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    rotation_angle: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rotation_initial: np.ndarray = field(default_factory=lambda: np.zeros(0))
    planar_mask: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    # LOADTF: the named time function of each INPUTX coordinate, INPUTR node and rigid-mode
    # constraint (None: the deck's); empty where no motion names one
    prescribed_tf: tuple = ()
    rotation_tf: tuple = ()
    rigid_tf: tuple = ()
    warp_idx: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    # DYNX: the global index of each dynamic coordinate, the row in rot_idx of a planar
    # orientation node's angle (-1 otherwise) and the deck (node, coordinate)
    dynamic_idx: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    dynamic_rot: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    dynamic_label: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))

    def dynamic_rows(self, x: np.ndarray) -> np.ndarray:
        """(n_dyn, n_coord): the rows that take the DYNX coordinates out of a change of the
        coordinates at x: unit rows, except for the angle of a planar orientation node,
        ``dphi_z = 2 Lambda_z(q) dq``."""
        from spacarpy.rotation import lambda_matrix
        rows = np.zeros((self.dynamic_idx.size, self.n_coord))
        for i, (k, r) in enumerate(zip(self.dynamic_idx.tolist(), self.dynamic_rot.tolist())):
            if r < 0:
                rows[i, k] = 1.0
            else:
                ri = self.rot_idx[r]
                rows[i, ri] = 2.0 * lambda_matrix(x[ri])[2]
        return rows

    def prescribed_values(self, a: float, s: float) -> np.ndarray:
        """Values of the prescribed coordinates at load parameters (a on the initial values,
        s on the increments): ``x0 + a (initial - x0) + s delta``."""
        start = self.x0[self.prescribed_idx]
        return start + a * (self.prescribed_initial - start) + s * self.prescribed_delta

    def prescribed_state(self, a: float, s, s_rot=None):
        """(indices, values) of every prescribed coordinate at load parameters (a, s):
        INPUTX coordinates, then the Euler parameters of the nodes turned by INPUTR
        (identity turned by ``s * angle`` about the axis). ``s`` may be one value per INPUTX
        coordinate and ``s_rot`` (default ``s``) one per INPUTR node (named time
        functions)."""
        from spacarpy.rotation import from_axis_angle
        idx = np.concatenate([self.prescribed_idx, self.rotation_idx.ravel()])
        s_rot = s if s_rot is None else s_rot
        q = (from_axis_angle(self.rotation_axis,
                             a * self.rotation_initial + s_rot * self.rotation_angle).ravel()
             if self.rotation_angle.size else np.zeros(0))
        return idx, np.concatenate([self.prescribed_values(a, s), q])

    def rigid_targets(self, a: float, s: float) -> np.ndarray:
        """(n_rigid,) values the rigid-mode constraints hold at load parameters (a, s): zero
        for ordinary rigid modes, ``a * initial + s * delta`` for prescribed deformations
        (INPUTE/DELINPE)."""
        if not self.rigid_initial.size:
            return np.zeros(self.n_rigid)
        return a * self.rigid_initial + s * self.rigid_delta

    def input_motion(self, t: float, rigid: bool = False):
        """(value, rate, second derivative) added at time t of a transient run by the 5-field
        INPUTX (or with ``rigid`` the INPUTE) lines: ``v0 t + a0 t^2/2``, ``v0 + a0 t``,
        ``a0``; arrays over the prescribed coordinates (or the rigid-mode constraints), zero
        without such lines."""
        va = self.rigid_rate if rigid else self.prescribed_rate
        n = self.n_rigid if rigid else self.prescribed_idx.size
        if not va.size:
            z = np.zeros(n)
            return z, z, z
        v0, a0 = va[:, 0], va[:, 1]
        return v0 * t + 0.5 * a0 * t * t, v0 + a0 * t, a0.copy()

    # Derived from the fields above, which do not change after number_model; made once on
    # first use (the solvers read them every iteration).
    @functools.cached_property
    def n_rigid(self) -> int:
        """Number of rigid-mode constraints (over all element groups)."""
        return int(sum(g.rigid_elem.size for g in self.groups))

    @functools.cached_property
    def euler_coords(self) -> np.ndarray:
        """(n_euler, 4) int: the coordinate indices of the Euler parameters of each node in
        :attr:`euler_nodes` (``rot_idx[euler_nodes]``)."""
        return self.rot_idx[self.euler_nodes]

    @property
    def n_constraint(self) -> int:
        return self.n_rigid + int(self.euler_nodes.size)

    @property
    def is_rotation_coord(self) -> np.ndarray:
        """(n_coord,) bool: True for Euler-parameter coordinates."""
        mask = np.zeros(self.n_coord, dtype=bool)
        mask[self.rot_idx.ravel()] = True
        return mask

    def group(self, keyword: str) -> ElementGroup | None:
        for g in self.groups:
            if g.keyword == keyword:
                return g
        return None

    def node_of_coord(self, model: Model) -> np.ndarray:
        """(n_coord,) deck node number owning each coordinate."""
        out = np.empty(self.n_coord, dtype=np.int64)
        out[self.pos_idx] = model.position_ids[:, None]
        out[self.rot_idx] = model.orientation_ids[:, None]
        out[self.warp_idx] = model.warping_ids
        return out


def _rows(ids: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """The row of each of ``nodes`` in ``ids`` (distinct node numbers), for all at once.

    Raises
    ------
    KeyError
        A node that is not in ``ids`` (not expected: the model is validated).
    """
    nodes = np.asarray(nodes, dtype=np.int64)
    if ids.size == 0:
        if nodes.size:
            raise KeyError(int(nodes[0]))
        return np.zeros(0, dtype=np.int64)
    order = np.argsort(ids, kind="stable")
    rows = order[np.minimum(np.searchsorted(ids, nodes, sorter=order), ids.size - 1)]
    missing = ids[rows] != nodes
    if missing.any():
        raise KeyError(int(nodes[np.argmax(missing)]))
    return rows.astype(np.int64)


class _RowOf:
    """``n in rows`` and ``rows[n]``: the row of node n among distinct node numbers, by binary
    search."""

    def __init__(self, ids: np.ndarray):
        self.order = np.argsort(ids, kind="stable")
        self.sorted = ids[self.order]

    def _find(self, n: int) -> int:
        k = int(np.searchsorted(self.sorted, n))
        return k if k < self.sorted.size and self.sorted[k] == n else -1

    def __contains__(self, n: int) -> bool:
        return self._find(n) >= 0

    def __getitem__(self, n: int) -> int:
        k = self._find(n)
        if k < 0:
            raise KeyError(n)
        return int(self.order[k])


def _row_of(ids: np.ndarray):
    """The row of each node number: a dict for a small model (its lookups are the
    cheapest), a :class:`_RowOf` for a large one."""
    if ids.size <= 4096:
        return dict(zip(ids.tolist(), range(ids.size)))
    return _RowOf(ids)


def number_model(model: Model) -> Numbering:
    """Build the :class:`Numbering` of a validated model."""
    pos_ids, rot_ids, warp_ids = model.position_ids, model.orientation_ids, model.warping_ids
    # ascending deck number, position, orientation and warping nodes interleaved
    ids = np.concatenate([pos_ids, rot_ids, warp_ids])
    sizes = np.concatenate([np.full(pos_ids.size, 3), np.full(rot_ids.size, 4),
                            np.full(warp_ids.size, 1)])
    order = np.argsort(ids, kind="stable")
    start = np.zeros(ids.size, dtype=np.int64)
    start[order] = np.concatenate([[0], np.cumsum(sizes[order])[:-1]]) if ids.size else []
    n_coord = int(sizes.sum())
    pos_idx = start[: pos_ids.size, None] + np.arange(3)
    rot_idx = start[pos_ids.size:pos_ids.size + rot_ids.size, None] + np.arange(4)
    warp_idx = start[pos_ids.size + rot_ids.size:]

    x0 = np.zeros(n_coord)
    x0[pos_idx] = model.position_x0
    x0[rot_idx[:, 0]] = 1.0

    # the row of a node among the position or orientation nodes, for the few nodes that the
    # fixes and prescribed motions name (a dict of all nodes cost more than the lookups)
    pos_row, rot_row = _row_of(pos_ids), _row_of(rot_ids)
    warp_row = _row_of(warp_ids) if warp_ids.size else {}

    groups = []
    offset = 0
    for keyword, es in model.elements.items():
        kind = KINDS[keyword]
        e_ids, nodes, def_class = es.ids, es.nodes, es.def_class
        idx_parts, x0_slots = [], []
        for j, slot in enumerate(kind.slots):
            if slot == "pos":
                rows = _rows(pos_ids, nodes[:, j])
                idx_parts.append(pos_idx[rows])
                x0_slots.append(model.position_x0[rows])
            elif slot == "warp":
                idx_parts.append(warp_idx[_rows(warp_ids, nodes[:, j])][:, None])
                x0_slots.append(None)
            else:
                rows = _rows(rot_ids, nodes[:, j])
                idx_parts.append(rot_idx[rows])
                x0_slots.append(None)
        ref, scale = kind.reference(x0_slots, es.vector)
        stiff = (def_class != RIGID) & es.has_stiffness[:, None]
        S = kind.stiffness(es.stiffness, ref) * \
            (stiff[:, :, None] & stiff[:, None, :])
        held = def_class == RIGID
        if kind.velocity_modes:     # held slips are velocity-level constraints, no rigid rows
            held = held.copy()
            held[:, list(kind.velocity_modes)] = False
        r_elem, r_mode = np.nonzero(held)
        groups.append(ElementGroup(
            kind=kind, ids=np.asarray(e_ids, np.int64), nodes=np.asarray(nodes, np.int64),
            idx=np.concatenate(idx_parts, axis=1), def_class=np.asarray(def_class, np.int8),
            stiff_mask=stiff, S=S, ref=ref, scale=scale, mass=es.mass,
            rigid_elem=r_elem.astype(np.int64), rigid_mode=r_mode.astype(np.int64),
            rigid_offset=offset))
        if model.element_damping:
            damp = np.array([model.element_damping.get(int(e), (0.0,) * kind.n_def)
                             for e in e_ids], dtype=float).reshape(-1, kind.n_def)
            # only flexible or released modes move; a rigid mode's rate is zero anyway
            groups[-1].damp = damp if np.any(damp) else None
        if model.element_prestress:
            sig0 = np.array([model.element_prestress.get(int(e), (0.0,) * kind.n_def)
                             for e in e_ids], dtype=float).reshape(-1, kind.n_def)
            # a rigid mode's stress resultant is its multiplier (the deck refuses a
            # pre-stress there)
            sig0[groups[-1].def_class == RIGID] = 0.0
            groups[-1].sigma0 = sig0 if np.any(sig0) else None
        offset += r_elem.size

    n_rigid = offset
    rigid_initial = np.zeros(n_rigid if model.prescribed_deformations else 0)
    rigid_delta, rigid_presc = np.zeros_like(rigid_initial), np.zeros(rigid_initial.size, bool)
    rigid_rate = np.zeros((rigid_initial.size, 2))
    rigid_tf: list = [None] * rigid_initial.size
    for pd in model.prescribed_deformations:
        for g in groups:
            hit = np.flatnonzero(g.ids[g.rigid_elem] == int(pd.element))
            hit = hit[g.rigid_mode[hit] == int(pd.mode) - 1]
            if hit.size:
                k = g.rigid_offset + int(hit[0])
                rigid_initial[k] = 0.0 if pd.initial is None else float(pd.initial)
                rigid_delta[k] = float(pd.delta)
                rigid_presc[k] = True
                rigid_rate[k] = (pd.velocity, pd.acceleration)
                if pd.tf is not None:
                    rigid_tf[k] = pd.tf
    if not rigid_rate.any():
        rigid_rate = np.zeros((0, 2))

    fixed = np.zeros(n_coord, dtype=bool)
    for fix in model.fixes:
        n = int(fix.node)
        base = (pos_idx[pos_row[n]] if n in pos_row else rot_idx[rot_row[n]]
                if n in rot_row else warp_idx[warp_row[n]:warp_row[n] + 1])
        fixed[base[np.asarray(fix.coords, dtype=np.int64) - 1]] = True
    # prescribed (input) coordinates: not unknowns either; their values follow the load path
    presc_idx = np.array([(pos_idx[pos_row[int(p.node)]] if int(p.node) in pos_row
                           else rot_idx[rot_row[int(p.node)]] if int(p.node) in rot_row
                           else warp_idx[warp_row[int(p.node)]:][:1])[int(p.coord) - 1]
                          for p in model.prescribed], dtype=np.int64)
    presc_initial = np.array([x0[k] if p.initial is None else float(p.initial)
                              for k, p in zip(presc_idx, model.prescribed)], dtype=float)
    presc_delta = np.array([float(p.delta) for p in model.prescribed], dtype=float)
    presc_rate = np.array([(p.velocity, p.acceleration) for p in model.prescribed],
                          dtype=float).reshape(-1, 2)
    if not presc_rate.any():
        presc_rate = np.zeros((0, 2))
    fixed[presc_idx] = True
    rot_presc_idx = np.array([rot_idx[rot_row[int(r.node)]] for r in model.prescribed_rotations],
                             dtype=np.int64).reshape(-1, 4)
    fixed[rot_presc_idx.ravel()] = True
    # a planar model: z of every position node and lambda1, lambda2 of every orientation
    # node stay 0 (held like fixed coordinates, but no reactions are reported for them)
    planar = np.zeros(n_coord, dtype=bool)
    if model.planar:
        planar[pos_idx[:, 2]] = True
        planar[rot_idx[:, 1:3].ravel()] = True
        planar &= ~fixed
        fixed |= planar
    unknown_of = np.full(n_coord, -1, dtype=np.int64)
    unknown_of[~fixed] = np.arange(int((~fixed).sum()))
    euler_nodes = (np.flatnonzero(~fixed[rot_idx].all(axis=1)) if rot_ids.size
                   else np.zeros(0, dtype=np.int64))

    dyn_idx, dyn_rot = [], []
    for d in model.dynamic_coords:
        n, c = int(d.node), int(d.coord)
        if n in pos_row:
            dyn_idx.append(int(pos_idx[pos_row[n], c - 1]))
            dyn_rot.append(-1)
        elif model.planar:                  # the angle: turns lambda0 and lambda3
            dyn_idx.append(int(rot_idx[rot_row[n], 3]))
            dyn_rot.append(rot_row[n])
        else:
            dyn_idx.append(int(rot_idx[rot_row[n], c - 1]))
            dyn_rot.append(-1)

    span = np.ptp(model.position_x0, axis=0) if pos_ids.size else np.zeros(3)
    lengths = [g.ref.l0.max() for g in groups if hasattr(g.ref, "l0") and g.n_elem]
    length_scale = float(np.linalg.norm(span)) or (max(lengths) if lengths else 1.0)
    return Numbering(n_coord=n_coord, x0=x0, pos_idx=pos_idx, rot_idx=rot_idx, groups=groups,
                     fixed_mask=fixed, unknown_of=unknown_of, n_unknown=int((~fixed).sum()),
                     euler_nodes=euler_nodes, length_scale=length_scale,
                     prescribed_idx=presc_idx, prescribed_initial=presc_initial,
                     prescribed_delta=presc_delta, rigid_initial=rigid_initial,
                     rigid_delta=rigid_delta, rigid_prescribed=rigid_presc,
                     prescribed_rate=presc_rate, rigid_rate=rigid_rate,
                     rotation_idx=rot_presc_idx,
                     rotation_axis=np.array([r.axis for r in model.prescribed_rotations],
                                            dtype=float).reshape(-1, 3),
                     rotation_angle=np.array([r.angle for r in model.prescribed_rotations],
                                             dtype=float),
                     rotation_initial=np.array([r.initial for r in model.prescribed_rotations],
                                               dtype=float),
                     planar_mask=planar, warp_idx=warp_idx,
                     **_motion_tf(model, rigid_tf),
                     dynamic_idx=np.array(dyn_idx, dtype=np.int64),
                     dynamic_rot=np.array(dyn_rot, dtype=np.int64),
                     dynamic_label=np.array([(d.node, d.coord) for d in model.dynamic_coords],
                                            dtype=np.int64).reshape(-1, 2))


def _motion_tf(model, rigid_tf: list) -> dict:
    """The LOADTF names of the prescribed motions (:class:`Numbering`'s ``prescribed_tf``,
    ``rotation_tf``, ``rigid_tf``), all empty where no motion names a function."""
    presc = tuple(p.tf for p in model.prescribed)
    rot = tuple(r.tf for r in model.prescribed_rotations)
    if not any(presc + rot + tuple(rigid_tf)):
        return {}
    return dict(prescribed_tf=presc, rotation_tf=rot, rigid_tf=tuple(rigid_tf))

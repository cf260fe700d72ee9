"""Numbering: from deck node numbers to global coordinates, unknowns and constraints.

The global coordinate vector holds every nodal coordinate: 3 per position node, 4 Euler
parameters per orientation node, nodes in ascending deck number (so that chains of elements
give banded matrices). Fixed coordinates keep their initial value; every other coordinate is
an unknown of the static problem. The constraints are the rigid deformation modes
(``e_i(x) = 0``) and the normalization ``q.q = 1`` of each orientation node that is not
completely fixed. See docs/solver.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spacarpy.elements.beam import reference_triads, stiffness_matrix
from spacarpy.model import RIGID, Model


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
    beam_idx : (n_elem, 14) int
        Global coordinate indices of each beam's local coordinates ``[r^p, q^p, r^q, q^q]``.
    fixed_mask : (n_coord,) bool
    unknown_of : (n_coord,) int
        Unknown number of each coordinate, -1 where fixed.
    n_unknown : int
    rigid_elem, rigid_mode : (n_rigid,) int
        Beam index and deformation index (0-based) of every rigid deformation mode.
    euler_nodes : (n_euler,) int
        Orientation-node indices (into ``rot_idx``) that carry a normalization constraint.
    has_stiffness_mode : (n_elem, 6) bool
        Modes whose stress resultant is S e (flexible, or released with ESTIFF).
    nx, ny, nz : (n_elem, 3)
        Reference triads; ``l0`` (n_elem,) reference lengths.
    S : (n_elem, 6, 6)
        Stiffness matrices with rows/columns of modes without stiffness zeroed.
    length_scale : float
        Characteristic length of the model (bounding-box diagonal) used to scale norms.
    """

    n_coord: int
    x0: np.ndarray
    pos_idx: np.ndarray
    rot_idx: np.ndarray
    beam_idx: np.ndarray
    fixed_mask: np.ndarray
    unknown_of: np.ndarray
    n_unknown: int
    rigid_elem: np.ndarray
    rigid_mode: np.ndarray
    euler_nodes: np.ndarray
    has_stiffness_mode: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    nz: np.ndarray
    l0: np.ndarray
    S: np.ndarray
    length_scale: float

    @property
    def n_rigid(self) -> int:
        return int(self.rigid_elem.size)

    @property
    def n_constraint(self) -> int:
        return self.n_rigid + int(self.euler_nodes.size)

    @property
    def is_rotation_coord(self) -> np.ndarray:
        """(n_coord,) bool: True for Euler-parameter coordinates."""
        mask = np.zeros(self.n_coord, dtype=bool)
        mask[self.rot_idx.ravel()] = True
        return mask

    def describe_coord(self, model: Model, k: int) -> str:
        """A readable name of global coordinate k, e.g. 'node 7 y' or 'node 8 lambda2'."""
        hit = np.argwhere(self.pos_idx == k)
        if hit.size:
            i, c = hit[0]
            return f"node {model.position_ids[i]} {'xyz'[c]}"
        i, c = np.argwhere(self.rot_idx == k)[0]
        return f"node {model.orientation_ids[i]} lambda{c}"

    def node_of_coord(self, model: Model) -> np.ndarray:
        """(n_coord,) deck node number owning each coordinate."""
        out = np.empty(self.n_coord, dtype=np.int64)
        out[self.pos_idx] = model.position_ids[:, None]
        out[self.rot_idx] = model.orientation_ids[:, None]
        return out


def number_model(model: Model) -> Numbering:
    """Build the :class:`Numbering` of a validated model."""
    pos_ids, rot_ids = model.position_ids, model.orientation_ids
    # ascending deck number, position and orientation nodes interleaved
    ids = np.concatenate([pos_ids, rot_ids])
    sizes = np.concatenate([np.full(pos_ids.size, 3), np.full(rot_ids.size, 4)])
    order = np.argsort(ids, kind="stable")
    start = np.zeros(ids.size, dtype=np.int64)
    start[order] = np.concatenate([[0], np.cumsum(sizes[order])[:-1]]) if ids.size else []
    n_coord = int(sizes.sum())
    pos_idx = start[: pos_ids.size, None] + np.arange(3)
    rot_idx = start[pos_ids.size:, None] + np.arange(4)

    x0 = np.zeros(n_coord)
    x0[pos_idx] = model.position_x0
    x0[rot_idx[:, 0]] = 1.0

    pos_row = {int(n): i for i, n in enumerate(pos_ids)}
    rot_row = {int(n): i for i, n in enumerate(rot_ids)}
    beams = model.beams
    nodes = beams.nodes
    p = np.array([pos_row[int(v)] for v in nodes[:, 0]], dtype=np.int64)
    r = np.array([rot_row[int(v)] for v in nodes[:, 1]], dtype=np.int64)
    q = np.array([pos_row[int(v)] for v in nodes[:, 2]], dtype=np.int64)
    s = np.array([rot_row[int(v)] for v in nodes[:, 3]], dtype=np.int64)
    beam_idx = (np.concatenate([pos_idx[p], rot_idx[r], pos_idx[q], rot_idx[s]], axis=1)
                if beams.n_elem else np.zeros((0, 14), dtype=np.int64))

    fixed = np.zeros(n_coord, dtype=bool)
    for fix in model.fixes:
        n = int(fix.node)
        base = pos_idx[pos_row[n]] if n in pos_row else rot_idx[rot_row[n]]
        fixed[base[np.asarray(fix.coords, dtype=np.int64) - 1]] = True
    unknown_of = np.full(n_coord, -1, dtype=np.int64)
    unknown_of[~fixed] = np.arange(int((~fixed).sum()))

    rigid_elem, rigid_mode = np.nonzero(beams.def_class == RIGID)
    euler_nodes = np.flatnonzero(~fixed[rot_idx].all(axis=1)) if rot_ids.size else \
        np.zeros(0, dtype=np.int64)

    nx, ny, nz, l0 = reference_triads(model.position_x0[p], model.position_x0[q],
                                      beams.orientation)
    has_k = (beams.def_class != RIGID) & beams.has_stiffness[:, None]
    S = stiffness_matrix(beams.stiffness, l0) * (has_k[:, :, None] & has_k[:, None, :])

    span = np.ptp(model.position_x0, axis=0) if pos_ids.size else np.zeros(3)
    length_scale = float(np.linalg.norm(span)) or (float(l0.max()) if l0.size else 1.0)
    return Numbering(n_coord=n_coord, x0=x0, pos_idx=pos_idx, rot_idx=rot_idx,
                     beam_idx=beam_idx, fixed_mask=fixed, unknown_of=unknown_of,
                     n_unknown=int((~fixed).sum()), rigid_elem=rigid_elem.astype(np.int64),
                     rigid_mode=rigid_mode.astype(np.int64), euler_nodes=euler_nodes,
                     has_stiffness_mode=has_k, nx=nx, ny=ny, nz=nz, l0=l0, S=S,
                     length_scale=length_scale)

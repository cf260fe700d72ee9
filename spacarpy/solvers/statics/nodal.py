"""Node-numbered model data over the coordinates: which row of ``num.pos_idx`` /
``num.rot_idx`` a deck node number is, and the nodal masses (XM) in those terms.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


def node_rows(model) -> tuple[dict, dict]:
    """``(pos_row, rot_row)``: deck node number -> row of the position nodes
    (``num.pos_idx``) and of the orientation nodes (``num.rot_idx``)."""
    return ({int(n): i for i, n in enumerate(model.position_ids)},
            {int(n): i for i, n in enumerate(model.orientation_ids)})


class NodalMasses(NamedTuple):
    """The XM lines of a model: point masses on position nodes, inertia tensors on
    orientation nodes."""

    point_idx: np.ndarray         # (n, 3) coordinate indices of the point masses
    point_mass: np.ndarray        # (n,) kg
    rot_nodes: np.ndarray         # (m,) orientation-node indices with an inertia tensor
    rot_inertia: np.ndarray       # (m, 3, 3) kg m^2, body frame


def nodal_masses(model, num) -> NodalMasses:
    """The model's nodal masses (XM) over the coordinates of ``num``, in deck order."""
    pos_row, rot_row = node_rows(model)
    point_idx, point_mass, rot_nodes, rot_inertia = [], [], [], []
    for xm in model.nodal_masses:
        n = int(xm.node)
        if n in pos_row:
            point_idx.append(num.pos_idx[pos_row[n]])
            point_mass.append(float(xm.values[0]))
        else:
            ixx, ixy, ixz, iyy, iyz, izz = (tuple(xm.values) + (0.0,) * 6)[:6]
            rot_nodes.append(rot_row[n])
            rot_inertia.append([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    return NodalMasses(point_idx=np.array(point_idx, dtype=np.int64).reshape(-1, 3),
                       point_mass=np.array(point_mass, dtype=float),
                       rot_nodes=np.array(rot_nodes, dtype=np.int64),
                       rot_inertia=np.array(rot_inertia, dtype=float).reshape(-1, 3, 3))


__all__ = ["NodalMasses", "nodal_masses", "node_rows"]

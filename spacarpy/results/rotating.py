"""Motion seen from a rotating frame: a node's displacement in the frame of an orientation node.

One job: from a results file, the position of a node relative to an origin node, expressed in
the axes of an orientation node (the rotating frame), minus the same quantity in the initial
state. For Simo & Vu-Quoc's spin-up (``decks/spinup_beam.dat``) the tip's lag behind the hub
is the y component of :func:`displacement_in_frame` with the tip (node 3), the hub's
orientation node 2 and the hub's position node 1; negative when the tip lags behind::

    t, d = displacement_in_frame(open_results("spin.h5"), node=3, frame=2, origin=1)
    lag = d[:, 1]

The frame's axes come from the stored Euler parameters (normalized here), so no angle is
unwrapped and any orientation of the frame works.
"""
from __future__ import annotations

import numpy as np

from spacarpy.rotation import rotation_matrix

__all__ = ["displacement_in_frame"]


def displacement_in_frame(res, node: int, frame: int, origin: int,
                          group: str = "transient") -> tuple[np.ndarray, np.ndarray]:
    """(time or load factor, d): ``d[k] = R_k^T (p_k - o_k) - R_0^T (p_0 - o_0)``, shape
    (n_step, 3), for an open :class:`spacarpy.results.ResultsFile` ``res``.

    ``p`` is position node ``node``, ``o`` position node ``origin``, ``R`` the rotation matrix
    of orientation node ``frame``; step 0 is the initial state. ``group`` is ``"transient"``
    (first output: time) or ``"static"`` (first output: load factor).
    """
    view = getattr(res, group)
    p = np.asarray(view.position(node=node), dtype=float)
    o = np.asarray(view.position(node=origin), dtype=float)
    q = np.asarray(view.euler(node=frame), dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    local = np.einsum("kji,kj->ki", rotation_matrix(q), p - o)
    scale = view.time if group == "transient" else view.load_factor
    return np.asarray(scale, dtype=float), local - local[0]

"""The ``/model`` datasets of a model's line loads and follower loads (schema 2.23).

This module's one job is turning the model's QE/DELQE/QEL/DELQEL lines
(:class:`~spacarpy.model.LineLoad`, :class:`~spacarpy.model.FollowerLineLoad`) and
XFL/DELXFL lines (:class:`~spacarpy.model.FollowerLoad`) into the optional arrays the writer
stores under ``/model`` (docs/results.md); a model without them gets none.
:func:`spacarpy.results.model_data.model_datasets` adds them to the others.
"""
from __future__ import annotations

import numpy as np

__all__ = ["load_datasets"]


def load_datasets(model) -> dict:
    """The ``/model/line_load_*`` and ``/model/follower_load_*`` datasets of ``model``, by
    path relative to the root; only the groups the model has lines of. The line loads are
    the dead ones (QE, DELQE) in deck order, then the follower ones (QEL, DELQEL)."""
    out = {}
    lines = [*getattr(model, "line_loads", ()), *getattr(model, "follower_line_loads", ())]
    if lines:
        out["model/line_load_element"] = np.array([ld.element for ld in lines], dtype=np.int64)
        out["model/line_load_type"] = np.array([ld.kind.encode("ascii") for ld in lines],
                                               dtype="S6")
        out["model/line_load_value"] = np.array([[ld.q_p, ld.q_q] for ld in lines],
                                                dtype=np.float64).reshape(len(lines), 2, 3)
    follower = list(getattr(model, "follower_loads", ()))
    if follower:
        out["model/follower_load_node"] = np.array([[ld.node, ld.axes] for ld in follower],
                                                   dtype=np.int64)
        out["model/follower_load_type"] = np.array([ld.kind.encode("ascii")
                                                    for ld in follower], dtype="S6")
        out["model/follower_load_value"] = np.array([ld.value for ld in follower],
                                                    dtype=np.float64).reshape(-1, 3)
    return out

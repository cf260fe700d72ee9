"""The equilibrium path of a static run: the load against one displacement of one node, for
``spacarpy plot FILE path`` and ``spacarpy extract FILE path`` (docs/path.md).

This module's one job is to choose the two axes of that curve from a results file:

- the displacement: component ``dof`` (x, y or z) of position node ``node`` at every stored
  step (default: the component that moves most);
- the load: where that coordinate is prescribed (``INPUTX``/``DELINPX``, displacement
  control) or supported, its reaction (the force that imposes the displacement, N), read from
  ``/static/reaction``; otherwise the quantity the run prescribes (a DELXF force in N, see
  :func:`~spacarpy.results.plot_base.x_axis`) or the load factor;
- the critical points, where the file has them: ``/critical/step``, ``point_type`` (named by
  :data:`~spacarpy.results.schema.CRITICAL_POINT_NAMES`) and ``load_factor``, written by the
  arc-length solver (schema 2.4); a file without them has none.

Arc-length runs store their points as ordinary static steps, so the load factor of
``/static/load_factor`` may go down and up again; nothing here assumes it grows.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spacarpy.results.plot_base import x_axis
from spacarpy.results.reader import ResultsFile, ResultsQueryError
from spacarpy.results.schema import CRITICAL_POINT_NAMES

__all__ = ["DOFS", "PathCurve", "path_curve", "critical_points"]

#: the displacement components a path can be drawn against
DOFS = ("x", "y", "z")

#: where the arc-length solver stores the critical points it found (optional)
CRITICAL = "critical"


@dataclass(frozen=True)
class PathCurve:
    """One equilibrium path: arrays over the stored static steps."""

    node: int
    dof: str
    step: np.ndarray            # (n,) step numbers
    load_factor: np.ndarray     # (n,)
    displacement: np.ndarray    # (n,) m
    load: np.ndarray            # (n,) the load axis
    load_name: str              # column name: "reaction_Fy", "load" or "load_factor"
    load_unit: str              # "N", "N m" or "1"
    load_label: str             # axis label
    critical_step: np.ndarray   # (n_crit,) steps of the critical points (empty: none)
    critical_kind: list         # (n_crit,) their kinds ("limit", "bifurcation", ...)
    critical_load_factor: np.ndarray


def critical_points(res: ResultsFile):
    """(step, kind, load_factor) of the critical points stored in ``/critical``, or three
    empty sequences when the file has none. ``kind`` is the name of each point's type."""
    empty = (np.zeros(0, dtype=int), [], np.zeros(0))
    if not res._has(f"{CRITICAL}/step"):
        return empty
    with res._file() as f:
        g = f[res._name(CRITICAL)]
        step = np.asarray(g["step"][()], dtype=int).reshape(-1)
        codes = (np.asarray(g["point_type"][()], dtype=int).reshape(-1)
                 if "point_type" in g else np.full(step.size, -1))
        kind = [CRITICAL_POINT_NAMES[c] if 0 <= c < len(CRITICAL_POINT_NAMES) else "critical"
                for c in codes.tolist()]
        lf = (np.asarray(g["load_factor"][()], dtype=float).reshape(-1)
              if "load_factor" in g else np.full(step.size, np.nan))
    return step, kind, lf


def path_curve(res: ResultsFile, node=None, dof=None, x: str = "auto") -> PathCurve:
    """The equilibrium path of position node ``node`` (default: the one that moves most) in
    direction ``dof`` (default: its component that moves most); ``x`` picks the load axis of
    a run without a prescribed coordinate at that node as in
    :func:`~spacarpy.results.plot_base.x_axis`."""
    s = res.static
    if s is None or s.n_step == 0:
        raise ResultsQueryError(f"{res.path} has no static load steps (/static)")
    m = res.model
    if node is None:
        moved = np.linalg.norm(s.displacement(step=-1), axis=-1)
        node = int(m.position_nodes[int(np.argmax(moved))])
    if m.node_kind(int(node)) != "position":
        raise ResultsQueryError(f"path: node {node} is an orientation node; give a position "
                                "node (--node)")
    u = s.displacement(node=int(node))
    if dof is None:
        dof = DOFS[int(np.argmax(np.ptp(u, axis=0)))]
    if dof not in DOFS:
        raise ResultsQueryError(f"path: --dof {dof!r}: choose x, y or z")
    c = DOFS.index(dof)
    steps = np.arange(s.n_step)
    lf = np.asarray(s.load_factor, dtype=float)
    comp = f"F{dof}"
    rows = np.flatnonzero((np.asarray(s.reaction_node) == int(node))
                          & (np.asarray(s.reaction_component) == comp))
    if rows.size:
        load = np.asarray(s.reaction()[:, rows[0]], dtype=float)
        name, unit = f"reaction_{comp}", "N"
        label = f"reaction {comp} at node {node} [N]"
    else:
        load, label = x_axis(res, lf, steps, x)
        name = "load_factor" if label == "load factor" else "load"
        unit = "1" if name == "load_factor" else label.rsplit("[", 1)[-1].rstrip("]")
    cs, ck, clf = critical_points(res)
    return PathCurve(int(node), dof, steps, lf, np.asarray(u[:, c], dtype=float),
                     np.asarray(load, dtype=float), name, unit, label, cs, ck, clf)

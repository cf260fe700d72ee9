"""The equilibrium path of a static run: the load against one displacement of one node, for
``spacarpy plot FILE path`` and ``spacarpy extract FILE path`` (docs/path.md).

This module's one job is to choose the two axes of that curve from a results file:

- the displacement: component ``dof`` (x, y or z) of position node ``node`` at every stored
  step (default: the node with the largest force, :func:`loaded_node`, and the component
  along that force; else the prescribed coordinate that moves most, found as the supported
  coordinate that moves; else the node that moves most and its component that moves most);
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

__all__ = ["DOFS", "PathCurve", "path_curve", "critical_points", "loaded_node"]

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


def loaded_node(res: ResultsFile) -> int | None:
    """The position node with the largest force of the model's loads (DELXF lines first, then
    the other force lines; the first of equal ones), or None when no force acts on a
    position node (a moment, a prescribed motion)."""
    found = _largest_force(res)
    return None if found is None else found[0]


def _largest_force(res: ResultsFile):
    """(node, force vector) of :func:`loaded_node`, or None."""
    m = res.model
    if m.load_node is None or not len(m.load_node):
        return None
    nodes = np.asarray(m.load_node, dtype=int)
    value = np.asarray(m.load_value, dtype=float).reshape(len(nodes), -1)
    size = np.linalg.norm(value, axis=1)
    kinds = np.asarray(m.load_type).astype(str)
    on_position = np.array([m.node_kind(int(n)) == "position" for n in nodes])
    for rows in (np.flatnonzero(on_position & (kinds == "DELXF") & (size > 0)),
                 np.flatnonzero(on_position & (size > 0))):
        if rows.size:
            j = rows[int(np.argmax(size[rows]))]
            return int(nodes[j]), value[j]
    return None


def _driven_coordinate(res: ResultsFile, dof):
    """(node, dof) of the coordinate with a reaction that moves most (a prescribed motion,
    INPUTX/DELINPX: a support does not move), or (None, dof) when none moves."""
    s, m = res.static, res.model
    best, found = 0.0, (None, dof)
    comps = list(s.reaction_component)
    for node, comp in zip(np.asarray(s.reaction_node).tolist(), comps):
        if comp not in ("Fx", "Fy", "Fz") or m.node_kind(int(node)) != "position":
            continue
        c = "xyz".index(comp[1])
        moved = float(np.ptp(s.displacement(node=int(node))[:, c]))
        if moved > best:
            best, found = moved, (int(node), DOFS[c] if dof is None else dof)
    return found


def path_curve(res: ResultsFile, node=None, dof=None, x: str = "auto") -> PathCurve:
    """The equilibrium path of position node ``node`` (default: the loaded node,
    :func:`loaded_node`, else the one that moves most) in
    direction ``dof`` (default: its component that moves most); ``x`` picks the load axis of
    a run without a prescribed coordinate at that node as in
    :func:`~spacarpy.results.plot_base.x_axis`."""
    s = res.static
    if s is None or s.n_step == 0:
        raise ResultsQueryError(f"{res.path} has no static load steps (/static)")
    m = res.model
    loaded = _largest_force(res)
    if node is None and loaded is not None:
        node = loaded[0]
        if dof is None and loaded[1].size == 3:       # along the load
            dof = DOFS[int(np.argmax(np.abs(loaded[1])))]
    if node is None:                  # displacement control: a supported coordinate moves
        node, dof = _driven_coordinate(res, dof)
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

"""The arrays the ParaView exports carry: one mesh for every element kind, and per-step data.

This module's one job is computing, through the reader API only (:func:`~spacarpy.results.
reader.open_results` and its views, never raw HDF5 paths), what the XDMF and VTK writers of
:mod:`spacarpy.results.export` store, so that both formats carry the same arrays under the
same names:

- **cells**: one line cell per element of every kind, all kinds in one block in the order of
  :data:`~spacarpy.results.schema.KIND_NAMES` (BEAM first), each kind's elements in the order
  of its ``ids``. A cell joins the element's first two position nodes; a kind with one
  position node or none (HINGE, PLHINGE) joins the position nodes its orientation nodes
  belong to (the position node that precedes the orientation node on a BEAM, RBEAM, ...
  line); where they coincide the cell has zero length but still carries the element's data.
  An element whose orientation nodes belong to no position node has no cell (logged).
- **cell arrays**: ``element_id``, ``element_kind`` (index into ``KIND_NAMES``); for every kind
  K of the model ``K_deformation`` and ``K_stress_resultant``, one component per deformation
  mode in the deck's order (a scalar for a kind with one mode), in the kind's own units, NaN
  on the cells of other kinds (one cell block for all kinds); the physical section forces
  ``normal_force`` (N), ``torque``, ``moment_y_p``, ``moment_y_q``, ``moment_z_p``,
  ``moment_z_q`` (N m) of the beam kinds and TRUSS, ``joint_angle`` (rad) and
  ``joint_moment`` (N m) of the hinges (NaN where they do not apply); the BEAM surface
  stresses ``max_normal_stress`` and ``max_von_mises_stress`` (Pa) when the file has them.
- **point arrays**: ``node_id``, ``displacement``, ``velocity`` (transient), the section
  frame ``frame_x``, ``frame_y``, ``frame_z`` (columns of the rotation matrix of the
  orientation node that rides on the point: the node after it on an element line, or the
  body of an RBEAM whose end q it is; NaN for points without one) with
  ``orientation_node_id`` (-1: none), and at linearized steps ``eigenmode_<j>`` and
  ``buckling_mode_<j>`` (the position part of the mode shape).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from spacarpy.rotation import rotation_matrix

log = logging.getLogger(__name__)

__all__ = ["Mesh", "export_mesh", "export_steps", "step_arrays", "group_of", "KIND_CODES",
           "DERIVED_UNITS"]

#: Physical forces derived from the stress resultants, and their units.
DERIVED_UNITS = {"normal_force": "N", "torque": "N m", "moment_y_p": "N m",
                 "moment_y_q": "N m", "moment_z_p": "N m", "moment_z_q": "N m",
                 "joint_angle": "rad", "joint_moment": "N m"}

# kind -> (derived name, stress column (0-based), multiply by l0?) ... ; deformation for angles
_DERIVED = {
    "BEAM": [("normal_force", 0, False), ("torque", 1, True), ("moment_y_p", 2, True),
             ("moment_y_q", 3, True), ("moment_z_p", 4, True), ("moment_z_q", 5, True)],
    "BEAMW": [("normal_force", 0, False), ("torque", 1, True), ("moment_y_p", 2, True),
              ("moment_y_q", 3, True), ("moment_z_p", 4, True), ("moment_z_q", 5, True)],
    "PLBEAM": [("normal_force", 0, False), ("moment_z_p", 1, True), ("moment_z_q", 2, True)],
    "TRUSS": [("normal_force", 0, False)],
    "PLTRUSS": [("normal_force", 0, False)],
    "HINGE": [("joint_moment", 0, False)],
    "PLHINGE": [("joint_moment", 0, False)],
}
_ANGLES = {"HINGE": 0, "PLHINGE": 0}


def _kind_names():
    from spacarpy.results.schema import KIND_NAMES
    return KIND_NAMES


#: element_kind code -> kind keyword.
KIND_CODES = dict(enumerate(_kind_names()))


@dataclass
class Mesh:
    """The model as line cells over the position nodes.

    Attributes
    ----------
    cells : (n_cell, 2) int64 rows of the position arrays
    kinds : kinds of the model, in cell order
    kind_rows : kind -> (rows of that kind's elements that have cells, slice of the cells)
    element_id, element_kind : (n_cell,) int64
    node_id : (n_pos,) int64
    orientation_row : (n_pos,) int64 row of the orientation node riding on each point, -1
    length : kind -> (n,) initial chord length of the cells of that kind (m)
    """

    cells: np.ndarray
    kinds: list
    kind_rows: dict
    element_id: np.ndarray
    element_kind: np.ndarray
    node_id: np.ndarray
    orientation_node_id: np.ndarray
    orientation_row: np.ndarray
    length: dict = field(default_factory=dict)

    @property
    def n_cell(self) -> int:
        return len(self.cells)


def group_of(res) -> str:
    """``transient`` for a file with time steps, else ``static``; None when it has neither."""
    if res.transient is not None and res.transient.n_step:
        return "transient"
    if res.static is None:
        return None
    return "static"


def export_mesh(res) -> Mesh:
    """The cells, ids and node frames' rows of the results file ``res`` (a ResultsFile)."""
    from spacarpy.results.schema import slot_roles

    m = res.model
    kinds = [k for k in m.element_kinds if len(m.element_ids(k))]
    pos_nodes = m.position_nodes
    rot_nodes = m.orientation_nodes
    # the position node each orientation node rides on: the pos slot just before it
    pos_of_rot: dict[int, int] = {}
    rot_of_pos: dict[int, int] = {}
    for kind in kinds:
        roles = slot_roles(kind)
        nodes = m.element_kind_nodes(kind)
        for i in range(1, len(roles)):
            if roles[i] == "rot" and roles[i - 1] == "pos":
                for p, r in nodes[:, [i - 1, i]].tolist():
                    pos_of_rot.setdefault(r, p)
                    rot_of_pos.setdefault(p, r)
    if "RBEAM" in kinds:     # the point q of a rigid beam rides on the body of r as well
        for r, q in m.element_kind_nodes("RBEAM")[:, [1, 2]].tolist():
            rot_of_pos.setdefault(q, r)
    cells, ids, codes, kind_rows, length = [], [], [], {}, {}
    x0 = m.position_x0
    code_of = {k: c for c, k in KIND_CODES.items()}
    for kind in kinds:
        roles = slot_roles(kind)
        nodes = m.element_kind_nodes(kind)
        kept, ends = [], []
        for row, line in enumerate(nodes.tolist()):
            ps = [n for n, r in zip(line, roles) if r == "pos"]
            ps += [pos_of_rot[n] for n, r in zip(line, roles) if r == "rot" and n in pos_of_rot]
            if not ps:
                continue
            kept.append(row)
            ends.append((ps + ps)[:2])
        skipped = len(nodes) - len(kept)
        if skipped:
            log.info("%d %s element(s) have no cell: their orientation nodes belong to no "
                     "position node", skipped, kind)
        start = len(ids)
        rows = np.asarray(kept, dtype=np.int64)
        ends_rows = (m.position_row(np.asarray(ends, dtype=np.int64)).reshape(-1, 2)
                     if ends else np.zeros((0, 2), np.int64))
        cells.append(ends_rows)
        ids.extend(m.element_ids(kind)[rows].tolist())
        codes.extend([code_of[kind]] * len(rows))
        kind_rows[kind] = (rows, slice(start, len(ids)))
        length[kind] = np.linalg.norm(x0[ends_rows[:, 1]] - x0[ends_rows[:, 0]], axis=1)
    if "BEAM" in kind_rows and m.n_elem:
        length["BEAM"] = np.asarray(m.element_length)[kind_rows["BEAM"][0]]
    ori_id = np.array([rot_of_pos.get(int(p), -1) for p in pos_nodes], dtype=np.int64)
    ori_row = np.full(len(pos_nodes), -1, dtype=np.int64)
    has = ori_id >= 0
    if has.any() and len(rot_nodes):
        ori_row[has] = m.orientation_row(ori_id[has])
    return Mesh(cells=(np.concatenate(cells).astype(np.int64) if cells
                       else np.zeros((0, 2), np.int64)),
                kinds=list(kind_rows), kind_rows=kind_rows,
                element_id=np.asarray(ids, dtype=np.int64),
                element_kind=np.asarray(codes, dtype=np.int64),
                node_id=np.asarray(pos_nodes, dtype=np.int64),
                orientation_node_id=ori_id, orientation_row=ori_row, length=length)


def export_steps(view, every: int | None) -> np.ndarray:
    """The steps to export: 0, every, 2 every, ... and always the last one."""
    n = view.n_step
    every = max(int(every or 1), 1)
    steps = np.arange(0, n, every)
    if n and steps[-1] != n - 1:
        steps = np.append(steps, n - 1)
    return steps


def step_arrays(res, mesh: Mesh, group: str, steps):
    """Yield ``(step, time, position, point_data, cell_data)`` for each of ``steps`` (rows of
    ``/static`` or ``/transient``); the arrays are described in the module docstring. The
    steps are read in batches of about :data:`_BATCH_VALUES` values per array."""
    view = getattr(res, group)
    steps = np.asarray(steps, dtype=np.int64)
    if group == "transient":
        times = view.time[steps]
    else:
        lf = view.load_factor
        strict = view.n_step < 2 or np.all(np.diff(lf) > 0)
        times = lf[steps] if strict else steps.astype(float)
    per_step = 3 * max(res.model.n_pos, res.model.n_rot, mesh.n_cell * 2, 1)
    size = max(1, _BATCH_VALUES // per_step)
    for start in range(0, len(steps), size):
        yield from _batch(res, mesh, group, steps[start:start + size],
                          times[start:start + size])


#: Values per array read at once (about 16 MB of float64).
_BATCH_VALUES = 2_000_000


def _batch(res, mesh: Mesh, group: str, steps, times):
    view = getattr(res, group)
    m = res.model
    position = view.position(step=steps)
    velocity = view.velocity(step=steps) if group == "transient" else None
    has_frames = bool((mesh.orientation_row >= 0).any())
    euler = view.euler(step=steps) if has_frames and m.n_rot else None
    kind_data = {}
    for kind in mesh.kinds:
        if kind in view.element_kinds:
            rows = mesh.kind_rows[kind][0]
            kind_data[kind] = (view.deformation(step=steps, kind=kind)[:, rows],
                               view.stress_resultant(step=steps, kind=kind)[:, rows])
    stress = None
    if group == "static" and "BEAM" in kind_data and view.has_stress:
        rows = mesh.kind_rows["BEAM"][0]
        stress = (view.max_normal_stress(step=steps)[:, rows],
                  view.max_von_mises_stress(step=steps)[:, rows])
    modes = _modes(res, group)
    n_cell, x0 = mesh.n_cell, m.position_x0
    for i, k in enumerate(steps.tolist()):
        point = {"node_id": mesh.node_id, "displacement": position[i] - x0}
        if velocity is not None:
            point["velocity"] = velocity[i]
        if euler is not None:
            point["orientation_node_id"] = mesh.orientation_node_id
            frames = np.full((m.n_pos, 3, 3), np.nan)
            has = mesh.orientation_row >= 0
            frames[has] = rotation_matrix(euler[i][mesh.orientation_row[has]])
            for j, axis in enumerate("xyz"):
                point[f"frame_{axis}"] = np.ascontiguousarray(frames[:, :, j])
        for label, (lin, rows) in modes.items():
            if k in rows:
                for j in range(lin.n_mode):
                    point[f"{label}_{j + 1}"] = lin.shape(mode=j + 1, step=k).position
        cell = {"element_id": mesh.element_id, "element_kind": mesh.element_kind}
        derived = {}
        for kind, (e, s) in kind_data.items():
            cells = mesh.kind_rows[kind][1]
            for what, data in (("deformation", e), ("stress_resultant", s)):
                column = np.full((n_cell,) + data.shape[2:], np.nan)
                column[cells] = data[i]
                cell[f"{kind}_{what}"] = column[:, 0] if data.shape[2] == 1 else column
            for name, col, scaled in _DERIVED.get(kind, ()):
                column = derived.setdefault(name, np.full(n_cell, np.nan))
                column[cells] = s[i, :, col] * (mesh.length[kind] if scaled else 1.0)
            if kind in _ANGLES:
                column = derived.setdefault("joint_angle", np.full(n_cell, np.nan))
                column[cells] = e[i, :, _ANGLES[kind]]
        cell.update(derived)
        if stress is not None:
            for name, data in zip(("max_normal_stress", "max_von_mises_stress"), stress):
                column = np.full(n_cell, np.nan)
                column[mesh.kind_rows["BEAM"][1]] = data[i]
                cell[name] = column
        yield k, float(times[i]), position[i], point, cell


def _modes(res, group: str) -> dict:
    """``{"eigenmode": (view, {static step})}`` (and ``buckling_mode``) for a static export."""
    out = {}
    if group != "static":
        return out
    for label, name in (("eigenmode", "eigen"), ("buckling_mode", "buckling")):
        lin = getattr(res, name)
        if lin is not None and lin.n_lin and lin.n_mode:
            out[label] = (lin, set(int(v) for v in lin.step))
    return out

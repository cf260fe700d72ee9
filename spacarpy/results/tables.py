"""Tables from a results file: the data of ``spacarpy extract``.

This module's one job is turning a :class:`~spacarpy.results.reader.ResultsFile` into a
table a script or spreadsheet reads (:func:`extract`, as aligned text, CSV or JSON). It
returns strings; printing them is the command line's business. The summary a person reads
(``spacarpy show``) is :mod:`spacarpy.results.summary`'s.

Extracted tables are *long*: one row per (step, entity), with the index columns first
(``step``, ``load_factor``, then ``node``, ``element`` or ``mode``) and the components after
them, so that ``--node`` and ``--step`` only filter rows and the columns never change. Time
histories of ``/transient`` (``energy``, ``time_*``) have ``time`` as their first column,
then ``step`` and the entity.
"""
from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass

import numpy as np

from spacarpy.results.reader import ResultsFile, ResultsQueryError
from spacarpy.results.stress import SECTION_FORCE_NAMES, SECTION_FORCE_UNITS

__all__ = ["Table", "QUANTITIES", "extract"]

#: What ``extract`` can give: name -> one-line description.
QUANTITIES = {
    "load_factor": "load factor, Newton iterations, residual and strain energy of each step",
    "position": "node positions x y z (m); --node, --step",
    "displacement": "node displacements ux uy uz from the initial positions (m); --node, --step",
    "euler": "Euler parameters of the orientation nodes; --node, --step",
    "deformation": "generalized deformations e1..e6 of the elements (m); --element, --step",
    "stress_resultant": "generalized stress resultants s1..s6 (N); --element, --step",
    "section_forces": "normal force, torque and end bending moments (N, N m); --element, --step",
    "stress": "largest normal and von Mises stress at the surface (Pa); --element, --step",
    "strain_energy": "elastic energy of the elements (J); --element, --step",
    "reaction": "support reactions (N, N m); --node, --step",
    "path": "the equilibrium path of --node: its displacement --dof (x, y, z) and the load "
            "(the reaction of a prescribed coordinate, a DELXF force or the load factor), "
            "critical points named (docs/path.md); plot-ready",
    "frequency": "natural frequencies (Hz) per linearized step; --mode, --step",
    "frequency_table": "one row per linearized step: load factor, prescribed deformations "
                       "(INPUTE), f1..fn (Hz; negative: unstable); plot-ready",
    "buckling": "buckling load multipliers per linearized step; --mode, --step",
    "mode_shape": "eigenmode shape at the position nodes; --mode (default 1), --step, --node",
    "buckling_shape": "buckling mode shape at the position nodes; --mode, --step, --node",
    "compliance": "6x6 nodal compliance (global axes) per linearized step; --step",
    "nodes": "position nodes with their initial coordinates (m)",
    "elements": "elements: nodes, length, cross-section, stiffness",
    "coordinates": "global coordinates: node, index in the node, fixed",
    "deck": "the deck text, verbatim",
    "energy": "time steps of /transient: iterations, residual, energies T U W D (J) and the "
              "balance T + U + D - W",
    "time_position": "time history of node positions x y z (m); --node, --step",
    "time_displacement": "time history of node displacements (m); --node, --step",
    "time_velocity": "time history of node velocities (m/s); --node, --step",
    "time_euler": "time history of Euler parameters; --node, --step",
    "time_deformation": "time history of element deformations (one element kind: that of "
                        "--element, default the first); --element, --step",
    "time_stress_resultant": "time history of element stress resultants; --element, --step",
    "time_reaction": "time history of the reactions, inertia included (N, N m); --node, "
                     "--step",
}


@dataclass
class Table:
    """A table of named columns with units; ``columns`` hold 1-d arrays of equal length.

    ``verbatim`` (a one-column table of text lines, the deck): :meth:`to_text` gives the
    lines as written, left-aligned and without title or header, so that the output is the
    text itself.
    """

    title: str
    names: list
    units: list
    columns: list
    verbatim: bool = False

    @property
    def n_row(self) -> int:
        return len(self.columns[0]) if self.columns else 0

    def rows(self) -> list:
        """Rows as lists of Python values (int, float, str; NaN stays float NaN)."""
        cols = [np.asarray(c).tolist() for c in self.columns]
        return [list(r) for r in zip(*cols)]

    def to_csv(self) -> str:
        """CSV with a header line ``name [unit]``; floats in full precision (round trip)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow([_header(n, u) for n, u in zip(self.names, self.units)])
        w.writerows([[repr(v) if isinstance(v, float) else v for v in r] for r in self.rows()])
        return buf.getvalue()

    def to_json(self) -> str:
        """JSON object with ``title``, ``columns``, ``units`` and ``data`` (list of rows);
        NaN and infinities become ``null``."""
        data = [[None if isinstance(v, float) and not math.isfinite(v) else v for v in r]
                for r in self.rows()]
        return json.dumps({"title": self.title, "columns": self.names, "units": self.units,
                           "data": data}, indent=None) + "\n"

    def to_text(self) -> str:
        """Aligned columns for reading, floats with 7 significant digits (a ``verbatim``
        table: its lines as written)."""
        if self.verbatim:
            return "".join(f"{line}\n" for line in self.columns[0])
        head = [_header(n, u) for n, u in zip(self.names, self.units)]
        body = [[_fmt(v) for v in r] for r in self.rows()]
        return self.title + "\n" + _align([head] + body)


def _header(name, unit):
    return f"{name} [{unit}]" if unit and unit != "1" else name


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.7g}"
    return str(v)


def _align(rows: list) -> str:
    """Right-aligned columns, two spaces apart."""
    if not rows:
        return ""
    widths = [max(len(r[j]) for r in rows) for j in range(len(rows[0]))]
    return "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths)).rstrip()
                     for r in rows) + "\n"


# --------------------------------------------------------------------------------------------
# extract
# --------------------------------------------------------------------------------------------

def extract(res: ResultsFile, what: str, *, node=None, element=None, step=None,
            mode=None, dof=None) -> Table:
    """Extract one quantity as a long table.

    Parameters
    ----------
    res : ResultsFile
    what : str
        A key of :data:`QUANTITIES`.
    node, element : int, optional
        Deck number filter (nodal or element quantities).
    step : int, optional
        Static step filter (0 = initial state; negative counts from the end).
    mode : int, optional
        Mode number (1-based) for frequencies, buckling multipliers and mode shapes.
    dof : str, optional
        ``x``, ``y`` or ``z``: the displacement component of ``path``.

    Returns
    -------
    Table

    Raises
    ------
    ResultsQueryError
        Unknown quantity, a quantity the file does not hold, unknown node/element/step/mode.
    """
    if what not in QUANTITIES:
        raise ResultsQueryError(f"unknown quantity {what!r}; choose one of "
                                f"{', '.join(QUANTITIES)}")
    no_static = res.static is None or res.static.n_step == 0
    if (no_static and f"time_{what}" in QUANTITIES and res.transient is not None
            and res.transient.n_step):
        what = f"time_{what}"          # a transient run: its time history
    if what == "path":
        return _x_path(res, node=node, dof=dof, step=step)
    return _EXTRACTORS[what](res, node=node, element=element, step=step, mode=mode)


def _static(res):
    if res.static is None or res.static.n_step == 0:
        timed = (" (it has time steps: extract time_position, time_displacement, "
                 "time_velocity, ..., energy)"
                 if res.transient is not None and res.transient.n_step else "")
        raise ResultsQueryError(f"{res.path} has no static load steps (/static){timed}")
    return res.static


def _steps(static, step):
    """Selected step numbers (1-d) and their load factors."""
    idx = static.step_index(step)
    steps = np.arange(static.n_step)[idx]
    steps = np.atleast_1d(steps)
    return steps, static.load_factor[steps]


def _long(title, steps, load_factor, entity_name, entity_ids, values, comp_names, units):
    """Long table from values (n_sel_step, n_sel_entity, n_comp)."""
    n_s, n_e = values.shape[:2]
    cols = [np.repeat(steps, n_e), np.repeat(load_factor, n_e), np.tile(entity_ids, n_s)]
    flat = values.reshape(n_s * n_e, -1)
    cols += [flat[:, j] for j in range(flat.shape[1])]
    return Table(title, ["step", "load_factor", entity_name] + list(comp_names),
                 ["1", "1", "1"] + list(units), cols)


def _node_rows(m, orientation: bool, node):
    """Deck numbers and rows of the nodes asked for (None: all) among the orientation nodes
    (``orientation``) or the position nodes of the model view ``m``."""
    if orientation:
        ids = m.orientation_nodes if node is None else np.atleast_1d(node)
        return ids, m.orientation_row(ids)
    ids = m.position_nodes if node is None else np.atleast_1d(node)
    return ids, m.position_row(ids)


def _nodal(res, name, *, node, step, comps, units, title, **_):
    static = _static(res)
    steps, lf = _steps(static, step)
    ids, rows = _node_rows(res.model, name in ("euler",), node)
    values = getattr(static, name)(step=steps)[:, rows]
    return _long(title, steps, lf, "node", ids, values, comps, units)


def _elemental(res, *, element, step, getter, comps, units, title):
    static = _static(res)
    steps, lf = _steps(static, step)
    m = res.model
    ids = m.elements if element is None else np.atleast_1d(element)
    rows = m.element_row(ids)
    values = getter(static, steps)[:, rows]
    if values.ndim == 2:
        values = values[..., None]
    return _long(title, steps, lf, "element", ids, values, comps, units)


def _x_load_factor(res, step, **_):
    static = _static(res)
    steps, lf = _steps(static, step)
    energy = static.total_strain_energy(step=steps)
    return Table("static load steps", ["step", "load_factor", "iterations", "residual",
                                       "strain_energy"], ["1", "1", "1", "1", "J"],
                 [steps, lf, static.iterations[steps], static.residual[steps], energy])


def _x_stress(res, element, step, **_):
    def get(static, steps):
        return np.stack([static.max_normal_stress(step=steps),
                         static.max_von_mises_stress(step=steps)], axis=-1)
    return _elemental(res, element=element, step=step, getter=get,
                      comps=["max_normal_stress", "max_von_mises_stress"], units=["Pa", "Pa"],
                      title="largest stresses at the surface of the cross-section")


def _reactions(res, view, node, steps):
    """The reaction rows of a /static or /transient view at ``steps``, of one node or all:
    (nodes, components, values (n_step, n), units) with units N or N m by component."""
    nodes = view.reaction_node
    comps = np.array(view.reaction_component)
    keep = np.ones(nodes.size, bool) if node is None else nodes == node
    if node is not None and not keep.any():
        res.model.node_kind(int(node))          # unknown node: clear error
        raise ResultsQueryError(f"node {node} has no support reactions (no fixed coordinate)")
    units = np.where(np.char.startswith(comps[keep], "F"), "N", "N m")
    return nodes[keep], comps[keep], view.reaction(step=steps)[:, keep], units


def _reaction_table(title, lead_names, lead_units, lead_values, steps, rows) -> Table:
    """The long table of reactions: the leading columns (step, load factor or time) repeated
    for each reaction row, then node, component, value and unit."""
    nodes, comps, values, units = rows
    n_r = nodes.size
    return Table(title, [*lead_names, "node", "component", "value", "unit"],
                 [*lead_units, "1", "1", "N | N m", "1"],
                 [*(np.repeat(v, n_r) for v in lead_values), np.tile(nodes, steps.size),
                  np.tile(comps, steps.size), values.reshape(-1), np.tile(units, steps.size)])


def _x_reaction(res, node, step, **_):
    static = _static(res)
    steps, lf = _steps(static, step)
    return _reaction_table("support reactions, global axes", ["step", "load_factor"],
                           ["1", "1"], [steps, lf], steps, _reactions(res, static, node, steps))


def _x_path(res, node, dof, step):
    from spacarpy.results.path import path_curve

    c = path_curve(res, node=node, dof=dof)
    kind = dict(zip(c.critical_step.tolist(), c.critical_kind))
    rows = np.atleast_1d(np.arange(c.step.size)[_static(res).step_index(step)])
    return Table(f"equilibrium path of node {c.node}, u{c.dof}",
                 ["step", "load_factor", f"u{c.dof}", c.load_name, "critical"],
                 ["1", "1", "m", c.load_unit, "1"],
                 [c.step[rows], c.load_factor[rows], c.displacement[rows], c.load[rows],
                  np.array([kind.get(int(k), "") for k in c.step[rows]], dtype=object)])


def _lin(res, group):
    view = getattr(res, group)
    if view is None or view.n_lin == 0:
        how = ("spacarpy run --compliance POS ROT" if group == "compliance" else
               f"--mode {group} or --modes-per-step")
        raise ResultsQueryError(f"{res.path} has no /{group} results (run with {how})")
    return view


def _lin_rows(res, view, step):
    if step is None:
        return np.arange(view.n_lin)
    return np.array([view.row(step)])


def _modes(view, mode):
    return np.arange(view.n_mode) if mode is None else np.array([view._mode_index(mode)])


def _x_frequency_table(res, step, mode, **_):
    """Wide: step, load_factor, one column per prescribed deformation (its value at the
    step, from ``/static/elements/<KIND>/deformation``), then one column per mode."""
    view = _lin(res, "eigen")
    rows, modes = _lin_rows(res, view, step), _modes(view, mode)
    steps = view.step[rows]
    names, units = ["step", "load_factor"], ["1", "1"]
    columns = [steps, view.load_factor[rows]]
    inputs = res.model._get("input_deformation")
    for element, k in (inputs if inputs is not None else np.zeros((0, 2), int)):
        for kind, unit in (("HINGE", "rad"), ("TRUSS", "m"), ("RBEAM", "m"), ("BEAM", "m")):
            ids = res.model._get(f"model/elements/{kind}/ids")
            if ids is None or int(element) not in ids.tolist():
                continue
            i = ids.tolist().index(int(element))
            values = res._read(f"static/elements/{kind}/deformation")[:, i, int(k) - 1]
            names.append(f"e{int(element)}.{int(k)}")
            units.append(unit)
            columns.append(values[steps])
            break
    freq = view.frequency[np.ix_(rows, modes)]
    for j, m in enumerate(modes):
        names.append(f"f{m + 1}")
        units.append("Hz")
        columns.append(freq[:, j])
    return Table("natural frequencies per linearized step", names, units, columns)


def _x_frequency(res, step, mode, **_):
    view = _lin(res, "eigen")
    rows, modes = _lin_rows(res, view, step), _modes(view, mode)
    freq, kind = view.frequency[np.ix_(rows, modes)], view.kind[np.ix_(rows, modes)]
    names = np.array(view.kind_names)[kind]
    n_m = modes.size
    return Table("natural frequencies", ["step", "load_factor", "mode", "frequency", "kind"],
                 ["1", "1", "1", "Hz", "1"],
                 [np.repeat(view.step[rows], n_m), np.repeat(view.load_factor[rows], n_m),
                  np.tile(modes + 1, rows.size), freq.reshape(-1), names.reshape(-1)])


def _x_buckling(res, step, mode, **_):
    view = _lin(res, "buckling")
    rows, modes = _lin_rows(res, view, step), _modes(view, mode)
    mult = view.load_multiplier[np.ix_(rows, modes)]
    n_m = modes.size
    crit = view.critical_load_multiplier[rows]
    # a multiplier the solver classified infinite is stored as NaN (docs/linearized.md)
    kind = np.where(np.isnan(mult), "infinite", "finite")
    return Table("buckling load multipliers",
                 ["step", "load_factor", "mode", "load_multiplier", "critical_load_multiplier",
                  "kind"], ["1"] * 6,
                 [np.repeat(view.step[rows], n_m), np.repeat(view.load_factor[rows], n_m),
                  np.tile(modes + 1, rows.size), mult.reshape(-1), np.repeat(crit, n_m),
                  kind.reshape(-1)])


def _x_shape(group):
    def get(res, node, step, mode, **_):
        view = _lin(res, group)
        mode = 1 if mode is None else mode
        r = view.row(step)
        shape = view.shape(mode=mode, step=None if step is None else step).position
        m = res.model
        ids = m.position_nodes if node is None else np.atleast_1d(node)
        rows = m.position_row(ids)
        units = "m" if group == "eigen" else "1"   # eigen: phi^T M phi = 1 kg m^2
        label = "eigenmode" if group == "eigen" else "buckling mode"
        t = _long(f"{label} {mode} at static step {int(view.step[r])}",
                  np.array([view.step[r]]), np.array([view.load_factor[r]]), "node", ids,
                  shape[rows][None], ["dx", "dy", "dz"], [units] * 3)
        return t
    return get


def _x_compliance(res, step, **_):
    view = _lin(res, "compliance")
    rows = _lin_rows(res, view, step)
    c = view.global_[rows]                                   # (n, 6, 6)
    labels = np.array(["ux", "uy", "uz", "phix", "phiy", "phiz"])
    return Table(f"compliance of nodes {view.node[0]}/{view.node[1]}, global axes "
                 "(row = response, columns = load Fx Fy Fz Tx Ty Tz)",
                 ["step", "load_factor", "response", "Fx", "Fy", "Fz", "Tx", "Ty", "Tz"],
                 ["1", "1", "1"] + ["m/N | rad/N"] * 3 + ["m/(N m) | rad/(N m)"] * 3,
                 [np.repeat(view.step[rows], 6), np.repeat(view.load_factor[rows], 6),
                  np.tile(labels, rows.size)] + [c[:, :, j].reshape(-1) for j in range(6)])


def _x_nodes(res, node, **_):
    m = res.model
    ids = m.position_nodes if node is None else np.atleast_1d(node)
    x0 = m.position_x0[m.position_row(ids)]
    return Table("position nodes", ["node", "x0", "y0", "z0"], ["1", "m", "m", "m"],
                 [ids, x0[:, 0], x0[:, 1], x0[:, 2]])


def _x_elements(res, element, **_):
    m = res.model
    ids = m.elements if element is None else np.atleast_1d(element)
    r = m.element_row(ids)
    nodes = m.element_nodes[r]
    cols = [ids, m.element_type[r], nodes[:, 0], nodes[:, 1], nodes[:, 2], nodes[:, 3],
            m.element_length[r]]
    names = ["element", "type", "p", "r", "q", "s", "length"]
    units = ["1"] * 6 + ["m"]
    if m.cross_section_type is not None:
        cols += [m.cross_section_type[r], m.cross_section_dims[r, 0], m.cross_section_dims[r, 1]]
        names += ["section", "dim1", "dim2"]
        units += ["1", "m", "m"]
    if m.stiffness is not None:
        names += ["EA", "GJ", "EIy", "EIz", "cy", "cz"]
        units += ["N", "N m2", "N m2", "N m2", "m2", "m2"]
        cols += [m.stiffness[r, j] for j in range(6)]
    return Table("elements", names, units, cols)


def _x_coordinates(res, node, **_):
    m = res.model
    if m.coordinate_node is None:
        raise ResultsQueryError("this file has no coordinate map (schema 1.0)")
    keep = np.ones(m.coordinate_node.size, bool) if node is None else m.coordinate_node == node
    idx = np.flatnonzero(keep)
    return Table("global coordinates (0-based index)", ["coordinate", "node", "index", "fixed"],
                 ["1"] * 4, [idx, m.coordinate_node[idx], m.coordinate_index[idx],
                             m.coordinate_fixed[idx].astype(int)])


def _transient(res):
    if res.transient is None or res.transient.n_step == 0:
        raise ResultsQueryError(f"{res.path} has no time steps (/transient)")
    return res.transient


def _time_steps(tr, step):
    steps = np.atleast_1d(np.arange(tr.n_step)[tr.step_index(step)])
    return steps, tr.time[steps]


def _x_energy(res, step, **_):
    tr = _transient(res)
    steps, t = _time_steps(tr, step)
    cols = [t, steps, tr.iterations[steps], tr.residual[steps], tr.kinetic_energy[steps],
            tr.elastic_energy[steps], tr.external_work[steps], tr.dissipated_energy[steps],
            tr.energy_balance[steps]]
    return Table("time steps", ["time", "step", "iterations", "residual", "kinetic_energy",
                                "elastic_energy", "external_work", "dissipated_energy",
                                "energy_balance"], ["s", "1", "1", "1"] + ["J"] * 5, cols)


def _time_long(title, t, steps, entity_name, ids, values, comps, units):
    """Long table with the time first, from values (n_sel_step, n_sel_entity, n_comp)."""
    n_s, n_e = values.shape[:2]
    flat = values.reshape(n_s * n_e, -1)
    cols = [np.repeat(t, n_e), np.repeat(steps, n_e), np.tile(ids, n_s)]
    cols += [flat[:, j] for j in range(flat.shape[1])]
    return Table(title, ["time", "step", entity_name] + list(comps),
                 ["s", "1", "1"] + list(units), cols)


def _x_time_nodal(name, comps, units, title):
    def get(res, node, step, **_):
        tr = _transient(res)
        steps, t = _time_steps(tr, step)
        ids, rows = _node_rows(res.model, name in ("euler", "euler_rate"), node)
        values = getattr(tr, name)(step=steps)[:, rows]
        return _time_long(title, t, steps, "node", ids, values, comps, units)
    return get


def _element_kind(res, element) -> str:
    """The element kind of deck element ``element`` (None: the first kind with elements)."""
    m = res.model
    kinds = [k for k in m.element_kinds if m.element_ids(k).size]
    if element is None:
        if not kinds:
            raise ResultsQueryError("the model has no elements")
        return kinds[0]
    for kind in kinds:
        if int(element) in m.element_ids(kind).tolist():
            return kind
    raise ResultsQueryError(f"element {element} is not in this model")


def _x_time_element(what):
    def get(res, element, step, **_):
        tr = _transient(res)
        steps, t = _time_steps(tr, step)
        kind = _element_kind(res, element)
        ids = res.model.element_ids(kind) if element is None else np.atleast_1d(element)
        values = getattr(tr, what)(element=ids, step=steps, kind=kind)
        letter = "e" if what == "deformation" else "s"
        comps = [f"{letter}{i}" for i in range(1, values.shape[-1] + 1)]
        return _time_long(f"{kind} {what.replace('_', ' ')}s", t, steps, "element", ids,
                          values, comps, _component_units(kind, what, len(comps)))
    return get


def _component_units(kind: str, what: str, n: int) -> list:
    """The unit of each of the ``n`` components of a kind's transient ``what``, from the
    schema: its ``units``, or one per mode where they differ (``index_units``: a HINGE's
    deformation, the joint angle in rad, then the small relative rotations in 1)."""
    from spacarpy.results.schema import DATASETS
    spec = DATASETS.get(f"transient/elements/{kind}/{what}")
    if spec is None:
        return ["1"] * n
    if spec.index_units:
        return list(spec.index_units[:n]) + ["1"] * (n - len(spec.index_units))
    return [spec.units] * n


def _x_time_reaction(res, node, step, **_):
    tr = _transient(res)
    steps, t = _time_steps(tr, step)
    return _reaction_table("reactions, inertia included, global axes", ["time", "step"],
                           ["s", "1"], [t, steps], steps, _reactions(res, tr, node, steps))


def _x_deck(res, **_):
    return Table("deck", ["line"], ["1"], [np.array(res.deck.splitlines(), dtype=object)],
                 verbatim=True)


_EXTRACTORS = {
    "load_factor": _x_load_factor,
    "position": lambda res, **kw: _nodal(res, "position", comps=["x", "y", "z"],
                                         units=["m"] * 3, title="node positions", **kw),
    "displacement": lambda res, **kw: _nodal(res, "displacement", comps=["ux", "uy", "uz"],
                                             units=["m"] * 3, title="node displacements", **kw),
    "euler": lambda res, **kw: _nodal(res, "euler", comps=["lambda0", "lambda1", "lambda2",
                                                           "lambda3"], units=["1"] * 4,
                                      title="Euler parameters", **kw),
    "deformation": lambda res, element, step, **_: _elemental(
        res, element=element, step=step, getter=lambda s, st: s.deformation(step=st),
        comps=[f"e{i}" for i in range(1, 7)], units=["m"] * 6,
        title="generalized deformations"),
    "stress_resultant": lambda res, element, step, **_: _elemental(
        res, element=element, step=step, getter=lambda s, st: s.stress_resultant(step=st),
        comps=[f"s{i}" for i in range(1, 7)], units=["N"] * 6,
        title="generalized stress resultants"),
    "section_forces": lambda res, element, step, **_: _elemental(
        res, element=element, step=step, getter=lambda s, st: s.section_forces(step=st),
        comps=list(SECTION_FORCE_NAMES), units=list(SECTION_FORCE_UNITS),
        title="section forces, element axes (N normal force, T torque, M bending moments at "
              "the ends p and q)"),
    "stress": _x_stress,
    "strain_energy": lambda res, element, step, **_: _elemental(
        res, element=element, step=step, getter=lambda s, st: s.strain_energy(step=st),
        comps=["strain_energy"], units=["J"], title="elastic energy of the elements"),
    "reaction": _x_reaction,
    "frequency": _x_frequency,
    "frequency_table": _x_frequency_table,
    "buckling": _x_buckling,
    "mode_shape": _x_shape("eigen"),
    "buckling_shape": _x_shape("buckling"),
    "compliance": _x_compliance,
    "nodes": _x_nodes,
    "elements": _x_elements,
    "coordinates": _x_coordinates,
    "deck": _x_deck,
    "energy": _x_energy,
    "time_position": _x_time_nodal("position", ["x", "y", "z"], ["m"] * 3, "node positions"),
    "time_displacement": _x_time_nodal("displacement", ["ux", "uy", "uz"], ["m"] * 3,
                                       "node displacements"),
    "time_velocity": _x_time_nodal("velocity", ["vx", "vy", "vz"], ["m/s"] * 3,
                                   "node velocities"),
    "time_euler": _x_time_nodal("euler", ["lambda0", "lambda1", "lambda2", "lambda3"],
                                ["1"] * 4, "Euler parameters"),
    "time_deformation": _x_time_element("deformation"),
    "time_stress_resultant": _x_time_element("stress_resultant"),
    "time_reaction": _x_time_reaction,
}

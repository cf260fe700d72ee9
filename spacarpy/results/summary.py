"""The summary of a results file that ``spacarpy show`` prints.

This module's one job is :func:`summary`: a :class:`~spacarpy.results.reader.ResultsFile`
turned into text a person reads (run state and provenance, the model's size, the steps of
every group and their extremes). It returns a string; printing it is the command line's
business. The tables of ``spacarpy extract`` are :mod:`spacarpy.results.tables`'.
"""
from __future__ import annotations

import numpy as np

from spacarpy.results.reader import ResultsFile
from spacarpy.results.tables import _align

__all__ = ["summary"]

_MAX_ROWS = 24        # step tables longer than this show their first and last rows


def summary(res: ResultsFile) -> str:
    """A readable summary of a results file (the output of ``spacarpy show``).

    Run state and provenance, the model's size, every load step (iterations, residual,
    largest displacement), the extreme displacements, section forces, reactions and stresses
    over all steps, and the frequencies and buckling multipliers of the linearized steps.
    """
    a, m = res.attrs, res.model
    state = "completed" if res.completed else (
        "INCOMPLETE: " + (res.error or "the writer did not finish (killed, or still running)"))
    n_fixed = (f", {int(m.coordinate_fixed.sum())} fixed" if m.coordinate_fixed is not None
               else "")
    n_coord = (f", {m.coordinate_node.size} coordinates{n_fixed}"
               if m.coordinate_node is not None else "")
    lines = [f"{res.path}",
             f"  analysis   {res.analysis}, {res.deformations} deformations; {state}",
             f"  written    by spacarpy {a.get('program_version')} at {a.get('created')}, "
             f"schema {res.schema_version[0]}.{res.schema_version[1]}",
             f"  deck       {a.get('deck_path')} (sha256 {str(a.get('deck_sha256'))[:12]}...)",
             f"  model      {m.n_pos} position nodes, {m.n_rot} orientation nodes, "
             f"{m.n_elem} elements{n_coord}"]
    if res.static is not None:
        lines += [""] + _static_summary(res)
        lines += _critical_summary(res)
    if res.transient is not None:
        lines += [""] + _transient_summary(res)
    if res.eigen is not None and res.eigen.n_lin:
        lines += [""] + _eigen_summary(res)
    if res.buckling is not None and res.buckling.n_lin:
        lines += [""] + _buckling_summary(res)
    if res.compliance is not None and res.compliance.n_lin:
        c = res.compliance
        diag = np.diagonal(c.global_[-1])
        lines += ["", f"Compliance of nodes {c.node[0]}/{c.node[1]} at step {int(c.step[-1])} "
                      "(diagonal, global axes; m/N and rad/(N m)):",
                  "  " + "  ".join(f"{v:.4g}" for v in diag)]
    if res.state_space is not None and res.state_space.n_lin:
        lines += [""] + _state_space_summary(res.state_space)
    return "\n".join(lines) + "\n"


def _critical_summary(res) -> list:
    """The critical points an arc-length run stored (``/critical``): step, kind, load
    factor; nothing for a file without them."""
    from spacarpy.results.path import critical_points
    steps, kinds, lfs = critical_points(res)
    if not len(steps):
        return []
    rows = [["step", "kind", "load factor"]]
    rows += [[str(int(k)), kind, f"{lf:.6g}"] for k, kind, lf in zip(steps, kinds, lfs)]
    return ["", f"Critical points of the path: {len(steps)}"] + _indent(_align(rows))


def _kinematic(a, n_dof: int) -> str:
    k = a.shape[0] - 2 * n_dof
    return f", {k} kinematic" if k else ""


def _state_space_summary(v) -> list:
    """The state space's size and signals, and its lowest undamped pole at the last step."""
    a = v.matrix("A")
    n_dof = v.matrix("M0").shape[0]          # (the kinematic states follow [q; q'], 2.13)
    where = ("SPACAR mode 3, along the transient) at {} time" if v.along_trajectory
             else "SPACAR mode 9) at {}").format(v.n_lin)
    out = [f"State space ({where} steps: {a.shape[0]} states "
           f"({n_dof} degrees of freedom{_kinematic(a, n_dof)}), {len(v.input_name)} inputs, "
           f"{len(v.output_name)} outputs (spacarpy export --state-space FILE.mat)",
           "  inputs   " + (", ".join(v.input_name) or "none"),
           "  outputs  " + (", ".join(v.output_name) or "none")]
    if n_dof:
        poles = np.linalg.eigvals(a)
        zero = poles == 0            # exact zeros: a steady motion's kinematic states
        low = poles[~zero][np.argmin(np.abs(poles[~zero]))] if (~zero).any() else 0j
        # a real part at round-off level of the pole (an undamped one) is shown as 0
        re = low.real if abs(low.real) > 1e-9 * abs(low) else 0.0
        besides = (f" (besides {np.count_nonzero(zero)} zero poles)"
                   if zero.any() and (~zero).any() else "")
        out.append(f"  at step {int(v.step[-1])}: the pole of smallest magnitude is "
                   f"{re:.4g} +- {abs(low.imag):.4g}i 1/s ({abs(low) / (2 * np.pi):.4g} Hz)"
                   + besides)
    return out


def _elided(rows: list) -> list:
    if len(rows) <= _MAX_ROWS + 1:
        return rows
    head, tail = rows[1:1 + _MAX_ROWS // 2], rows[-(_MAX_ROWS // 2):]
    return [rows[0]] + head + [["..."] + [""] * (len(rows[0]) - 1)] + tail


def _indent(text: str) -> list:
    return ["  " + line for line in text.rstrip("\n").split("\n")]


def _static_summary(res) -> list:
    s, m = res.static, res.model
    n = s.n_step
    out = [f"Static load steps: {n} committed"]
    if n == 0:
        return out
    u = s.displacement()                                    # (n_step, n_pos, 3)
    umag = np.linalg.norm(u, axis=-1)
    at = np.argmax(umag, axis=1)
    lf, it, resid = s.load_factor, s.iterations, s.residual
    rows = [["step", "load factor", "iterations", "residual", "max |u| [m]", "at node"]]
    rows += [[str(k), f"{lf[k]:.6g}", str(it[k]), f"{resid[k]:.2e}",
              f"{umag[k, at[k]]:.6g}", str(m.position_nodes[at[k]]) if umag[k, at[k]] > 0
              else "-"] for k in range(n)]
    out += _indent(_align(_elided(rows)))

    ext = [["quantity", "value", "unit", "where"]]

    def add(label, values, unit, ids, what, sign=False):
        """values (n_step, n_entity[, k]): the entry of largest magnitude."""
        flat = np.abs(np.nan_to_num(values, nan=-np.inf))
        if flat.size == 0 or not np.isfinite(flat).any() or flat.max() <= 0:
            return
        k, j = np.unravel_index(np.argmax(flat), flat.shape)[:2]
        v = values[(k, j)] if values.ndim == 2 else values[k, j][np.argmax(flat[k, j])]
        ext.append([label, f"{v:.6g}" if sign else f"{abs(v):.6g}", unit,
                    f"{what} {ids[j]}, step {k}"])

    add("displacement |u|", umag, "m", m.position_nodes, "node")
    for c, name in enumerate("xyz"):
        add(f"displacement u{name}", u[..., c], "m", m.position_nodes, "node", sign=True)
    if m.n_elem:
        f = s.section_forces()
        add("normal force N", f[..., 0], "N", m.elements, "element", sign=True)
        add("torque |T|", f[..., 1], "N m", m.elements, "element")
        add("bending moment |My|", f[..., 2:4], "N m", m.elements, "element")
        add("bending moment |Mz|", f[..., 4:6], "N m", m.elements, "element")
        if s.has_stress:
            add("max normal stress", s.max_normal_stress(), "Pa", m.elements, "element")
            add("max von Mises stress", s.max_von_mises_stress(), "Pa", m.elements, "element")
    reac = s.reaction()
    comps = np.array(s.reaction_component)
    if reac.size:
        for prefix, label, unit in (("F", "reaction force", "N"), ("M", "reaction moment",
                                                                   "N m")):
            sel = np.char.startswith(comps, prefix)
            if sel.any():
                vals = reac[:, sel]
                k, j = np.unravel_index(np.argmax(np.abs(vals)), vals.shape)
                if vals[k, j] == 0:
                    continue
                ext.append([f"{label} {comps[sel][j]}", f"{vals[k, j]:.6g}", unit,
                            f"node {s.reaction_node[sel][j]}, step {k}"])
    out += ["", "Extremes over all steps (element axes for the section forces):"]
    out += _indent(_align(ext))
    return out


def _transient_summary(res) -> list:
    tr, m = res.transient, res.model
    n = tr.n_step
    out = [f"Time steps: {n} committed"]
    if n == 0:
        return out
    t = tr.time
    out[0] += f", t = {t[0]:.6g} .. {t[-1]:.6g} s"
    u = np.linalg.norm(tr.displacement(), axis=-1)               # (n_step, n_pos)
    kin, ela = tr.kinetic_energy, tr.elastic_energy
    work, diss = tr.external_work, tr.dissipated_energy
    bal = tr.energy_balance
    rows = [["step", "time [s]", "iterations", "max |u| [m]", "T [J]", "U [J]", "W [J]",
             "D [J]"]]
    rows += [[str(k), f"{t[k]:.6g}", str(tr.iterations[k]), f"{u[k].max():.6g}"
              if u.shape[1] else "-", f"{kin[k]:.6g}", f"{ela[k]:.6g}", f"{work[k]:.6g}",
              f"{diss[k]:.6g}"] for k in range(n)]
    out += _indent(_align(_elided(rows)))
    drift = float(np.max(np.abs(bal - bal[0])))
    top = float(np.max(kin + ela))
    share = f" ({drift / top:.2g} of max(T + U))" if top > 0 else ""
    out += [f"  energy balance T + U + D - W: {bal[0]:.6g} J at t = {t[0]:.6g} s, largest "
            f"change {drift:.3g} J{share}",
            "    (constant but for the integration error; W: the work done on the model by "
            "the loads, gravity and prescribed motions)"]
    if u.size:
        k, j = np.unravel_index(np.argmax(u), u.shape)
        out += [f"  largest displacement |u| {u[k, j]:.6g} m at node {m.position_nodes[j]}, "
                f"t = {t[k]:.6g} s"]
    return out


def _eigen_summary(res) -> list:
    e = res.eigen
    n_show = min(e.n_mode, 6)
    f, kind = e.frequency[:, :n_show], e.kind[:, :n_show]
    rows = [["step", "load factor"] + [f"f{j + 1} [Hz]" for j in range(n_show)]]
    for r in range(e.n_lin):
        cells = [f"{v:.6g}" if kd in (0, 1, 2) else e.kind_names[kd]
                 for v, kd in zip(f[r], kind[r])]
        rows.append([str(e.step[r]), f"{e.load_factor[r]:.6g}"] + cells)
    more = f" (first {n_show} of {e.n_mode} modes)" if e.n_mode > n_show else ""
    return [f"Natural frequencies at {e.n_lin} linearized step(s){more}:"] + \
        _indent(_align(_elided(rows)))


def _buckling_summary(res) -> list:
    b = res.buckling
    n_show = min(b.n_mode, 4)
    mult = b.load_multiplier[:, :n_show]
    crit = b.critical_load_multiplier
    rows = [["step", "load factor", "critical"] + [f"mu{j + 1}" for j in range(n_show)]]
    for r in range(b.n_lin):
        rows.append([str(b.step[r]), f"{b.load_factor[r]:.6g}", f"{crit[r]:.6g}"]
                    + [f"{v:.6g}" if not np.isnan(v) else "infinite" for v in mult[r]])
    return [f"Buckling load multipliers at {b.n_lin} linearized step(s) (critical = smallest "
            "positive):"] + _indent(_align(_elided(rows)))

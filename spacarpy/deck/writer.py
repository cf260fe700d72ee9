"""Model and settings -> deck text: the inverse of reading a deck.

:func:`model_to_deck` writes a :class:`spacarpy.model.Model` and its
:class:`spacarpy.settings.AnalysisSettings` as a deck that reads back into an equal model and
equal settings (every element kind, every array and setting, floats to the last bit: numbers are
written with Python's shortest round-trip representation). By default the deck uses only SPACAR
keywords plus the spacarpy lines the model needs (MODE, DEFORMATIONS, and the extensions whose
settings differ from their defaults); ``compact=True`` also writes element ranges
(``DYNE 1:48 1 2 3 4 5 6``), a spacarpy extension. :func:`format_record` writes one record.

For a :class:`spacarpy.job.Job`, ``model_to_deck(*job)``.
"""
from __future__ import annotations

import math

import numpy as np

from spacarpy.elements.base import FLEXIBLE, KINEMATIC, RELEASED
from spacarpy.elements.registry import KINDS
from spacarpy.settings import AnalysisSettings

__all__ = ["format_record", "format_value", "model_to_deck"]


def format_value(value) -> str:
    """One field as deck text: ints as digits, floats in shortest round-trip form, other
    values (words) as they are.

    Raises
    ------
    ValueError
        For a float that is not finite (a deck cannot hold it).
    """
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"a deck field cannot be a boolean: {value!r}")
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if not math.isfinite(v):
            raise ValueError(f"a deck field must be a finite number, got {v!r}")
        return repr(v)
    return str(value)


def format_record(keyword: str, *fields) -> str:
    """``keyword`` and its fields as one deck line (no line end)."""
    return " ".join([keyword] + [format_value(f) for f in fields])


def _runs(ids: np.ndarray, lines: list[tuple]) -> list[tuple[int, int, tuple]]:
    """Group consecutive element numbers (first, last) that share the same data."""
    out: list = []
    for e, data in zip(ids.tolist(), lines):
        if out and out[-1][2] == data and out[-1][1] + 1 == e:
            out[-1] = (out[-1][0], e, data)
        else:
            out.append((e, e, data))
    return out


def _element_lines(keyword: str, ids: np.ndarray, data: list[tuple], compact: bool) -> list[str]:
    """One line per element, or with compact=True one line per run of equal data."""
    lines = []
    if compact:
        for first, last, values in _runs(ids, data):
            if values is None:
                continue
            head = str(first) if first == last else f"{first}:{last}"
            lines.append(" ".join([keyword, head] + [format_value(v) for v in values]))
        return lines
    for e, values in zip(ids.tolist(), data):
        if values is not None:
            lines.append(format_record(keyword, e, *values))
    return lines


def _axis_for(unit) -> tuple:
    """Axis components that the deck reader's normalization (``a / |a|``) turns into exactly
    ``unit``: ``unit`` itself is not always one (its norm differs from 1 in the last bit), so
    its neighbours one unit in the last place away are tried too."""
    u = np.asarray(unit, dtype=float)
    choices = np.stack([u, np.nextafter(u, -np.inf), np.nextafter(u, np.inf)])  # (3, 3)
    for pick in np.ndindex(3, 3, 3):
        c = choices[list(pick), [0, 1, 2]]
        if np.array_equal(c / np.linalg.norm(c), u):
            return tuple(float(v) for v in c)
    return tuple(float(v) for v in u)


def _quoted(value) -> str:
    """A TIMEFUNCTION parameter: numbers as numbers, an expression in double quotes."""
    return f'"{value}"' if isinstance(value, str) else format_value(value)


def _kinematic_lines(model) -> list[str]:
    """KINE and KINX lines: the model's kinematic list in its order, then KINE lines for the
    KINEMATIC modes it does not list (a model built in Python)."""
    out = [format_record(kin.keyword, kin.target, kin.number) for kin in model.kinematic]
    listed = {(kin.target, kin.number) for kin in model.kinematic if kin.keyword == "KINE"}
    for es in model.elements.values():
        for r, m in zip(*np.nonzero(es.def_class == KINEMATIC)):
            if (int(es.ids[r]), int(m) + 1) not in listed:
                out.append(format_record("KINE", int(es.ids[r]), int(m) + 1))
    return out


def model_to_deck(model, settings: AnalysisSettings | None = None, *, cross_sections=None,
                  compact: bool = False, title: str | None = None) -> str:
    """Write a model and its analysis settings as deck text that reads back into an equal
    model and equal settings.

    Parameters
    ----------
    model : spacarpy.model.Model
    settings : spacarpy.settings.AnalysisSettings, optional
        The analysis settings to write (MODE, ITERSTEP, TIMESTEP, ...); default: the defaults.
    cross_sections : CrossSections, optional
        Written as a VISUALIZATION section (BEAMPROPS / CROSSTYPE / CROSSDIM); default: the
        model's own (``model.cross_sections``).
    compact : bool
        Write element ranges (``ESTIFF 1:48 ...``), a spacarpy extension, instead of one
        line per element.
    title : str, optional
        A comment line at the top (default: where the model came from).

    Returns
    -------
    str
        The deck, ending with a newline.

    Notes
    -----
    The round trip is exact for models read from decks (source locations, the source text
    and path aside). A model built in Python with an ``IterStep`` whose ``extra`` is empty but
    ``n_init != 1`` cannot be written exactly (SPACAR's ITERSTEP needs fields 4 and 5 before
    n_init); fields 4 and 5 are then written as 0.
    """
    planar = bool(model.planar)
    if cross_sections is None:
        cross_sections = model.cross_sections
    settings = settings if settings is not None else AnalysisSettings()
    lin, tr = settings.linearized, settings.transient
    out = [f"# {title if title is not None else 'spacarpy model from ' + model.source_path}",
           f"DEFORMATIONS {settings.deformations}", f"MODE {settings.analysis}"]
    if settings.bifurcation != "off":
        out.append(f"BIFURCATION {settings.bifurcation}")
    if settings.rotary_inertia != "lumped":
        out.append(f"ROTARYINERTIA {settings.rotary_inertia}")
    if lin.n_modes is not None:
        out.append(f"MODES {int(lin.n_modes)} {'each' if lin.modes_each_step else 'last'}")
    out.append("")
    # ---------------------------------------------------------------- kinematics module
    out += [format_record("X", int(n), *(x[:2] if planar else x)) for n, x in
            zip(model.position_ids.tolist(), model.position_x0.tolist())]
    for keyword, es in model.elements.items():
        kind = KINDS[keyword]
        for e, nodes, v in zip(es.ids.tolist(), es.nodes.tolist(), es.vector.tolist()):
            given = kind.vector is not None and not any(math.isnan(c) for c in v)
            out.append(format_record(keyword, e, *nodes, *(v if given else ())))
    for es in model.elements.values():
        for cls, keyword in ((FLEXIBLE, "DYNE"), (RELEASED, "RLSE")):
            data = [tuple(int(k) + 1 for k in np.flatnonzero(row == cls)) or None
                    for row in es.def_class]
            out += _element_lines(keyword, es.ids, data, compact)
    out += _kinematic_lines(model)
    out += [format_record("DYNX", d.node, d.coord) for d in model.dynamic_coords]
    position_nodes, warping_nodes = set(model.position_ids.tolist()), set(
        model.warping_ids.tolist())
    for fix in model.fixes:
        size = 3 if fix.node in position_nodes else 1 if fix.node in warping_nodes else 4
        coords = () if tuple(fix.coords) == tuple(range(1, size + 1)) else fix.coords
        out.append(format_record("FIX", fix.node, *coords))
    for p in model.prescribed:
        out.append(format_record("INPUTX", p.node, p.coord))
    for r in model.prescribed_rotations:
        out.append(format_record("INPUTX", r.node, 1) if planar
                   else format_record("INPUTR", r.node, *_axis_for(r.axis)))
    for d in model.prescribed_deformations:
        out.append(format_record("INPUTE", d.element, d.mode))
    out += ["END", "HALT", ""]
    # ---------------------------------------------------------------- data module
    for es in model.elements.values():
        data = [tuple(float(v) for v in row) if has else None
                for row, has in zip(es.stiffness, es.has_stiffness)]
        out += _element_lines("ESTIFF", es.ids, data, compact)
    for keyword, es in model.elements.items():
        if KINDS[keyword].em is None:
            continue
        data = [tuple(float(v) for v in row) if np.any(row != 0) else None for row in es.mass]
        out += _element_lines("EM", es.ids, data, compact)
    for e, values in model.element_damping.items():
        out.append(format_record("EDAMP", int(e), *[float(v) for v in values]))
    for e, values in model.element_prestress.items():
        out.append(format_record("ESIG", int(e), *[float(v) for v in values]))
    for (e, k), rate in model.initial_rates.items():
        out.append(format_record("STARTDE", int(e), int(k), float(rate)))
    for routine in getattr(model, "user_routines", ()):
        out.append(format_record(routine.keyword, routine.name))
    for xm in model.nodal_masses:
        out.append(format_record("XM", xm.node, *[float(v) for v in xm.values]))
    for load in model.loads:
        value = [float(v) for v in load.value]
        if planar:
            value = value[:2] if load.node in position_nodes else value[2:]
        out.append(format_record(load.kind, load.node, *value))
    for ll in [*getattr(model, "line_loads", ()), *getattr(model, "follower_line_loads", ())]:
        q = [float(v) for v in ll.q_p] + ([] if ll.q_q == ll.q_p
                                          else [float(v) for v in ll.q_q])
        if planar:
            q = [v for i, v in enumerate(q) if i % 3 != 2]
        out.append(format_record(ll.kind, ll.element, *q))
    for load in model.follower_loads:
        value = [float(v) for v in load.value]
        if planar:
            value = value[:2] if load.node in position_nodes else value[2:]
        out.append(format_record(load.kind, load.node, load.axes, *value))
    for p in model.prescribed:
        if p.velocity or p.acceleration:        # the 5-field form (a transient's motion)
            value = p.initial
            if value is None:
                row = list(model.position_ids).index(p.node) if p.node in position_nodes \
                    else None
                value = (model.position_x0[row, p.coord - 1] if row is not None
                         else float(p.coord == 1))
            out.append(format_record("INPUTX", p.node, p.coord, float(value),
                                     float(p.velocity), float(p.acceleration)))
        elif p.initial is not None:
            out.append(format_record("INPUTX", p.node, p.coord, float(p.initial)))
        if p.delta != 0:
            out.append(format_record("DELINPX", p.node, p.coord, float(p.delta)))
    for r in model.prescribed_rotations:
        if planar:
            if r.initial != 0:
                out.append(format_record("INPUTX", r.node, 1, float(r.initial)))
            if r.angle != 0:
                out.append(format_record("DELINPX", r.node, 1, float(r.angle)))
        elif r.angle != 0:
            out.append(format_record("DELINPR", r.node, float(r.angle)))
    for d in model.prescribed_deformations:
        if d.velocity or d.acceleration:
            out.append(format_record("INPUTE", d.element, d.mode, float(d.initial or 0.0),
                                     float(d.velocity), float(d.acceleration)))
        elif d.initial is not None:
            out.append(format_record("INPUTE", d.element, d.mode, float(d.initial)))
        if d.delta != 0:
            out.append(format_record("DELINPE", d.element, d.mode, float(d.delta)))
    if any(g != 0 for g in model.gravity):
        out.append(format_record("GRAVITY", *[float(g) for g in model.gravity]))
    it = settings.static.iterstep
    fields = [it.max_iter, it.n_steps, float(it.tol)]
    if it.extra or it.n_init != 1:
        extra = tuple(float(v) for v in it.extra) + (0.0,) * (2 - len(it.extra))
        fields += [*extra[:2], it.n_init]
    out.append(format_record("ITERSTEP", *fields))
    arc = settings.static.arclength
    if arc is not None:
        bounds = [float(v) for v in (arc.ds_min, arc.ds_max) if v is not None]
        if arc.ds_min is None and arc.ds_max is not None:
            bounds = [float(v) for v in arc.bounds]
        out.append(format_record("ARCLENGTH", int(arc.n_max), float(arc.ds0), *bounds))
    if tr.timestep is not None:
        out.append(format_record("TIMESTEP", float(tr.timestep[0]), int(tr.timestep[1])))
    if tr.error_tol is not None:
        out.append(format_record("ERROR", *[float(v) for v in tr.error_tol]))
    if tr.substeps != 1:
        out.append(format_record("SUBSTEPS", int(tr.substeps)))
    if tr.rho_inf != 0.9:
        out.append(format_record("RHOINF", float(tr.rho_inf)))
    if tuple(model.damping) != (0.0, 0.0):
        out.append(format_record("DAMPING", *[float(v) for v in model.damping]))
    if tr.start != "deck":
        out.append(f"START {tr.start}")
    kind, params = tr.time_function
    if (kind, tuple(params)) != ("constant", ()):
        out.append(" ".join(["TIMEFUNCTION", kind] + [_quoted(v) for v in params]))
    for name, (kind, params) in getattr(tr, "named_time_functions", ()):
        out.append(" ".join(["TIMEFUNCTION", name, kind] + [_quoted(v) for v in params]))
    out += _load_tf_lines(model)
    for n, v in tr.initial_velocities.items():
        out.append(format_record("VELOCITY", int(n), *[float(c) for c in v]))
    if lin.inputs or lin.outputs:          # the third module: the state-space signals
        out += ["END", "HALT", ""]
        out += [format_record(sg.keyword, sg.index, sg.target, sg.number)
                for sg in (*lin.inputs, *lin.outputs)]
    out += ["END", "END"]
    if cross_sections is not None and len(cross_sections):
        out += ["", "VISUALIZATION"]
        groups: dict = {}
        for e, cs in cross_sections.by_element.items():
            groups.setdefault((cs.shape, cs.dims), []).append(e)
        for (shape, dims), elements in groups.items():
            out.append(format_record("BEAMPROPS", *sorted(elements)))
            out.append(f"CROSSTYPE {shape}")
            out.append(format_record("CROSSDIM", *dims))
    return "\n".join(out) + "\n"


def _load_tf_lines(model) -> list[str]:
    """The LOADTF lines of the loads and motions that name a time function."""
    named = [("DELXF", (ld.node,), ld.tf) for ld in model.loads if ld.kind == "DELXF"]
    named += [("DELXFL", (ld.node,), ld.tf) for ld in getattr(model, "follower_loads", ())
              if ld.kind == "DELXFL"]
    named += [(ld.kind, (ld.element,), ld.tf)
              for ld in [*getattr(model, "line_loads", ()),
                         *getattr(model, "follower_line_loads", ())]
              if ld.kind in ("DELQE", "DELQEL")]
    named += [("DELINPX", (p.node, p.coord), p.tf) for p in model.prescribed]
    named += [(("DELINPX", (r.node, 1)) if model.planar else ("DELINPR", (r.node,))) + (r.tf,)
              for r in model.prescribed_rotations]
    named += [("DELINPE", (d.element, d.mode), d.tf) for d in model.prescribed_deformations]
    lines = (format_record("LOADTF", tf, what, *target) for what, target, tf in named
             if tf is not None)
    return list(dict.fromkeys(lines))

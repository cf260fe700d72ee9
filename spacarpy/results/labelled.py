"""Result views as labelled data: readable reprs, ``to_xarray()`` and ``to_dataframe()``.

:class:`LabelledView` is mixed into the views of ``/static``, ``/transient``, ``/eigen`` and
``/buckling`` (:mod:`spacarpy.results.views`, :mod:`spacarpy.results.linearized_views`). It
gives them

- ``repr()``: the group, its sizes (steps, nodes, elements per kind, modes) and units;
  ``_repr_html_()``: the same as a table, for notebooks;
- ``to_xarray()``: an :class:`xarray.Dataset` with coordinates (the step and load factor, the
  time, the deck numbers of the nodes and elements, the mode numbers, the component and
  deformation-mode names) and ``units`` and ``long_name`` in every variable's attributes
  (where a variable's columns differ in units, ``units`` is left out and the coordinate
  ``<KIND>_mode_units`` gives the unit of each column);
- ``to_dataframe(what)``: a :class:`pandas.DataFrame` in long form (one row per step and
  node, element or mode), its columns' units in ``DataFrame.attrs["units"]``.

Everything is built from the views' own accessors (``position()``, ``frequency``,
``shape()``, ...), never from HDF5 paths. xarray and pandas are optional (the ``xarray``
extra) and imported on first use. This module's one job is that labelled form.
"""
from __future__ import annotations

import html

import numpy as np

from spacarpy.elements.registry import KINDS
from spacarpy.errors import SpacarError
from spacarpy.results.schema import DATASETS

__all__ = ["LabelledView", "MissingExtraError"]

_XYZ = ["x", "y", "z"]
_EULER = ["lambda0", "lambda1", "lambda2", "lambda3"]


def _unit(path: str) -> str:
    """The ``units`` the schema gives the dataset ``path`` (so that these cannot drift)."""
    return DATASETS[path].units


def _shape_units(group: str) -> dict:
    """Units of the mode shapes of ``group`` as the file stores them (eigen, schema 3.0:
    scaled so that phi^T M phi = 1 kg m^2: positions in m, Euler parameters in 1)."""
    return {"position": _unit(f"{group}/shape_position"), "euler": _unit(f"{group}/shape_euler")}


class MissingExtraError(SpacarError, ImportError):
    """``to_xarray``/``to_dataframe`` without xarray or pandas installed."""


def _import(name: str):
    try:
        return __import__(name)
    except ImportError as exc:
        raise MissingExtraError(f"{name} is not installed: install it (pip install "
                                f"'spacarpy[xarray]') to use to_xarray/to_dataframe") from exc


def _var(dims, data, units=None, long_name=None, **attrs):
    a = {}
    if units is not None:
        a["units"] = units
    if long_name is not None:
        a["long_name"] = long_name
    a.update(attrs)
    return (dims, np.asarray(data), a)


def _one_unit(units) -> str | None:
    return units[0] if units and len(set(units)) == 1 else None


def _keep_open(res):
    """A context that keeps one handle open while a view reads many arrays (unless the
    caller already holds one)."""
    from contextlib import nullcontext
    return res if getattr(res, "_handle", None) is None else nullcontext()


# --------------------------------------------------------------------------------------------
# the steps of /static and /transient
# --------------------------------------------------------------------------------------------

def _step_axis(view):
    """(dim, coords) of the step axis: /static by step with its load factor, /transient by
    time."""
    if view._group == "transient":
        t = view.time
        return "time", {"time": _var(("time",), t, "s", "time"),
                        "step": _var(("time",), np.arange(t.size), "1", "stored time step")}
    lf = view.load_factor
    return "step", {"step": _var(("step",), np.arange(lf.size), "1",
                                 "load step (0 = the initial state)"),
                    "load_factor": _var(("step",), lf, "1", "load factor")}


def _kinds(view) -> list[str]:
    """The element kinds the view has values of (kinds without elements left out)."""
    model = view._res.model
    return [k for k in view.element_kinds
            if (model.element_ids(k) if k != "BEAM" else _beam_ids(model)).size]


def _step_dataset_vars(view) -> tuple[dict, dict]:
    model = view._res.model
    dim, coords = _step_axis(view)
    pos_ids, rot_ids = model.position_nodes, model.orientation_nodes
    coords.update(position_node=_var(("position_node",), pos_ids, None,
                                     "deck number of the position node"),
                  orientation_node=_var(("orientation_node",), rot_ids, None,
                                        "deck number of the orientation node"),
                  component=_var(("component",), _XYZ),
                  euler_parameter=_var(("euler_parameter",), _EULER))
    data = {
        "position": _var((dim, "position_node", "component"), view.position(), "m",
                         "position of the node"),
        "displacement": _var((dim, "position_node", "component"), view.displacement(), "m",
                             "displacement from the initial position"),
        "euler": _var((dim, "orientation_node", "euler_parameter"), view.euler(), "1",
                      "Euler parameters of the orientation node"),
        "iterations": _var((dim,), view.iterations, "1", "Newton iterations"),
        "residual": _var((dim,), view.residual, "1", "final relative residual"),
    }
    if view._group == "transient":
        data.update(
            velocity=_var((dim, "position_node", "component"), view.velocity(), "m/s",
                          "velocity of the node"),
            euler_rate=_var((dim, "orientation_node", "euler_parameter"), view.euler_rate(),
                            "1/s", "rates of the Euler parameters"),
            kinetic_energy=_var((dim,), view.kinetic_energy, "J", "kinetic energy T"),
            elastic_energy=_var((dim,), view.elastic_energy, "J", "elastic energy U"),
            external_work=_var((dim,), view.external_work, "J", "work W of the loads"),
            energy_balance=_var((dim,), view.energy_balance, "J", "T + U - W"))
    for kind in _kinds(view):
        facts = KINDS.get(kind)
        ids = model.element_ids(kind) if kind != "BEAM" else _beam_ids(model)
        edim, mdim = f"{kind}_element", f"{kind}_mode"
        modes = list(facts.modes) if facts is not None else None
        deformation = view.deformation(kind=kind)
        n_mode = deformation.shape[-1]
        if modes is None or len(modes) != n_mode:
            modes = [f"mode {k + 1}" for k in range(n_mode)]
        mu = list(facts.mode_units) if facts is not None and len(facts.mode_units) == n_mode \
            else None
        su = list(facts.stress_units) if facts is not None and \
            len(facts.stress_units) == n_mode else None
        coords[edim] = _var((edim,), ids, None, f"deck number of the {kind} element")
        coords[mdim] = _var((mdim,), np.arange(1, n_mode + 1), None,
                            f"deformation mode of the {kind} element",
                            mode_names=modes)
        if mu is not None:
            coords[f"{kind}_mode_units"] = _var((mdim,), mu, None, "unit of the deformation")
            coords[f"{kind}_stress_units"] = _var((mdim,), su, None,
                                                  "unit of the stress resultant")
        data[f"{kind}_deformation"] = _var((dim, edim, mdim), deformation,
                                           _one_unit(mu), f"{kind} deformations")
        data[f"{kind}_stress_resultant"] = _var(
            (dim, edim, mdim), view.stress_resultant(kind=kind), _one_unit(su),
            f"{kind} stress resultants")
    reaction = _reactions(view)
    if reaction is not None:
        values, nodes, comps = reaction
        coords["reaction_node"] = _var(("reaction_row",), nodes, None,
                                       "node of the reaction")
        coords["reaction_component"] = _var(("reaction_row",), comps)
        coords["reaction_units"] = _var(("reaction_row",),
                                        [_reaction_unit(c) for c in comps])
        data["reaction"] = _var((dim, "reaction_row"), values, _one_unit(
            [_reaction_unit(c) for c in comps]), "support reaction (global axes)")
    return coords, data


def _beam_ids(model) -> np.ndarray:
    try:
        return model.element_ids("BEAM")
    except SpacarError:
        return model.elements


def _reaction_unit(component: str) -> str:
    return "N m" if str(component).startswith("M") else "N"


def _reactions(view):
    try:
        values = view.reaction()
    except (SpacarError, KeyError, AttributeError):
        return None
    if values is None or values.ndim != 2 or not values.shape[1]:
        return None
    res = view._res
    static = res.static
    nodes = np.asarray(static.reaction_node) if static is not None else None
    comps = list(static.reaction_component) if static is not None else None
    if nodes is None or len(comps) != values.shape[1]:
        return None
    return values, nodes, [str(c) for c in comps]


# --------------------------------------------------------------------------------------------
# /eigen and /buckling
# --------------------------------------------------------------------------------------------

def _linearized_vars(view) -> tuple[dict, dict]:
    res = view._res
    model = res.model
    n_lin, n_mode = view.n_lin, view.n_mode
    steps = view.step
    coords = {
        "linearized_step": _var(("linearized_step",), np.arange(n_lin), "1",
                                "linearization (row)"),
        "step": _var(("linearized_step",), steps, "1", "static load step linearized"),
        "load_factor": _var(("linearized_step",), view.load_factor, "1", "load factor"),
        "mode": _var(("mode",), np.arange(1, n_mode + 1), "1", "mode number"),
        "position_node": _var(("position_node",), model.position_nodes),
        "orientation_node": _var(("orientation_node",), model.orientation_nodes),
        "component": _var(("component",), _XYZ),
        "euler_parameter": _var(("euler_parameter",), _EULER),
    }
    kind_names = ", ".join(f"{i} {name}" for i, name in enumerate(view.kind_names))
    data = {"kind": _var(("linearized_step", "mode"), view.kind, "1", "kind of the mode",
                         flag_meanings=kind_names)}
    if view._group == "eigen":
        ev = view.eigenvalue
        data.update(
            frequency=_var(("linearized_step", "mode"), view.frequency,
                           _unit("eigen/frequency"), "natural frequency"),
            eigenvalue_real=_var(("linearized_step", "mode"), ev.real,
                                 _unit("eigen/eigenvalue_real"), "eigenvalue omega^2, real part"),
            eigenvalue_imag=_var(("linearized_step", "mode"), ev.imag,
                                 _unit("eigen/eigenvalue_imag"),
                                 "eigenvalue omega^2, imaginary part"))
        units, what = _shape_units("eigen"), "mode shape, mass-normalized: phi^T M phi = 1 kg m^2"
    else:
        data.update(
            load_multiplier=_var(("linearized_step", "mode"), view.load_multiplier,
                                 _unit("buckling/load_multiplier"), "buckling load multiplier"),
            critical_load_multiplier=_var(("linearized_step",),
                                          view.critical_load_multiplier,
                                          _unit("buckling/critical_load_multiplier"),
                                          "smallest positive multiplier"))
        units, what = _shape_units("buckling"), "buckling shape"
    pos = np.full((n_lin, n_mode, model.n_pos, 3), np.nan)
    rot = np.full((n_lin, n_mode, model.n_rot, 4), np.nan)
    for r, s in enumerate(steps):
        row_of_step = view.row(int(s)) if res.static is not None else r
        if row_of_step != r:          # a step linearized twice: only the last row has a view
            continue
        for m in range(n_mode):
            shape = view.shape(m + 1, int(s) if res.static is not None else None)
            pos[r, m], rot[r, m] = shape.position, shape.euler
    data["shape_position"] = _var(("linearized_step", "mode", "position_node", "component"),
                                  pos, units["position"], f"{what}: positions")
    data["shape_euler"] = _var(("linearized_step", "mode", "orientation_node",
                                "euler_parameter"), rot, units["euler"],
                               f"{what}: Euler parameters")
    return coords, data


# --------------------------------------------------------------------------------------------
# describing
# --------------------------------------------------------------------------------------------

def _rows(view) -> list[tuple[str, str]]:
    """(what, value) lines describing the view."""
    if view._group in ("compliance", "state_space"):
        from spacarpy.results import labelled_linear
        return labelled_linear.rows(view)
    res = view._res
    model = res.model
    if view._group in ("static", "transient"):
        n = view.n_step
        out = []
        if view._group == "static":
            lf = view.load_factor
            span = f", load factor {lf[0]:.6g} to {lf[-1]:.6g}" if n else ""
            out.append(("steps", f"{n} (0 = the initial state){span}"))
        else:
            t = view.time
            span = f", t = {t[0]:.6g} to {t[-1]:.6g} s" if n else ""
            out.append(("time steps", f"{n}{span}"))
        out.append(("nodes", f"{model.n_pos} position (position, displacement: m"
                    + (", velocity: m/s" if view._group == "transient" else "")
                    + f"), {model.n_rot} orientation (Euler parameters: 1)"))
        for kind in _kinds(view):
            facts = KINDS.get(kind)
            n_e = (model.element_ids(kind) if kind != "BEAM" else _beam_ids(model)).size
            if facts is not None:
                mu = "/".join(dict.fromkeys(facts.mode_units))
                su = "/".join(dict.fromkeys(facts.stress_units))
                out.append((kind, f"{n_e} elements, {len(facts.modes)} modes (deformation: "
                            f"{mu}; stress resultant: {su})"))
            else:
                out.append((kind, f"{n_e} elements"))
        if view._group == "transient":
            out.append(("energies", "kinetic, elastic, external work: J"))
        return out
    out = [("linearizations", f"{view.n_lin} (static steps "
            f"{', '.join(str(s) for s in view.step[:8])}"
            f"{', ...' if view.n_lin > 8 else ''})"),
           ("modes", f"{view.n_mode} per linearization")]
    if view._group == "eigen" and view.n_lin:
        f = view.frequency[-1]
        shown = ", ".join(f"{v:.6g}" for v in f[:6])
        out.append(("frequency", f"Hz; last linearization: {shown}"
                    + (", ..." if f.size > 6 else "")))
        units = _shape_units("eigen")
        out.append(("shapes", f"mass-normalized, phi^T M phi = 1 kg m^2 (positions: "
                    f"{units['position']}, Euler parameters: {units['euler']})"))
    elif view._group == "buckling" and view.n_lin:
        out.append(("critical load multiplier",
                    f"{view.critical_load_multiplier[-1]:.6g} (last linearization; "
                    "multiplies the load acting there)"))
    return out


def describe(view) -> str:
    """The plain-text repr of a view."""
    name = type(view).__name__
    where = getattr(view._res, "path", "?")
    try:
        with _keep_open(view._res):
            rows = _rows(view)
    except SpacarError as exc:          # a damaged file: say so, do not fail the repr
        return f"<{name} /{view._group} of {where!r}: unreadable ({exc})>"
    width = max(len(k) for k, _ in rows)
    body = "\n".join(f"  {k:<{width}}  {v}" for k, v in rows)
    return f"<{name} /{view._group} of {where!r}\n{body}>"


def describe_html(view) -> str:
    """The notebook repr of a view: a small table."""
    name = type(view).__name__
    where = html.escape(str(getattr(view._res, "path", "?")))
    try:
        with _keep_open(view._res):
            rows = _rows(view)
    except SpacarError as exc:
        return f"<p><b>{name}</b> /{view._group}: unreadable ({html.escape(str(exc))})</p>"
    cells = "".join(f"<tr><th style='text-align:left'>{html.escape(k)}</th>"
                    f"<td style='text-align:left'>{html.escape(v)}</td></tr>"
                    for k, v in rows)
    return (f"<div><b>{name}</b> <code>/{view._group}</code> of <code>{where}</code>"
            f"<table>{cells}</table></div>")


class LabelledView:
    """Reprs and labelled exports of a result view (mixed into the views)."""

    _group = ""

    def __repr__(self) -> str:
        return describe(self)

    def _repr_html_(self) -> str:
        return describe_html(self)

    def to_xarray(self):
        """The group as an :class:`xarray.Dataset`.

        Coordinates: ``step`` and ``load_factor`` (/static, along ``step``), ``time``
        (/transient), ``position_node``, ``orientation_node`` (deck numbers), ``component``
        (x y z), ``euler_parameter``, ``<KIND>_element`` (deck numbers) and ``<KIND>_mode``
        (1..n, names in its ``mode_names`` attribute), ``mode`` and ``linearized_step``
        (/eigen, /buckling); ``response`` and ``load_component`` (/compliance, whose entries'
        units are the coordinate ``compliance_units``); ``state``, ``state_column``,
        ``system_input`` and ``system_output`` (/state_space: A, B, C, D, pole, labelled by
        the names). Every variable has ``units`` (pint-parseable; left out where the
        columns differ: then ``<KIND>_mode_units``, ``<KIND>_stress_units`` or
        ``reaction_units`` give each column's) and ``long_name``.

        Raises
        ------
        MissingExtraError
            xarray is not installed (``pip install 'spacarpy[xarray]'``).
        """
        xr = _import("xarray")
        with _keep_open(self._res):
            if self._group in ("static", "transient"):
                coords, data = _step_dataset_vars(self)
            elif self._group in ("compliance", "state_space"):
                from spacarpy.results import labelled_linear
                coords, data = labelled_linear.dataset_vars(self)
            else:
                coords, data = _linearized_vars(self)
        attrs = {"group": self._group, "source": str(getattr(self._res, "path", "")),
                 "analysis": self._res.analysis}
        return xr.Dataset(data, coords=coords, attrs=attrs)

    def to_dataframe(self, what: str | None = None, kind: str = "BEAM"):
        """The group as a long :class:`pandas.DataFrame`.

        Parameters
        ----------
        what : str, optional
            /static, /transient: ``"nodes"`` (the default: one row per step and position
            node, columns ``x y z ux uy uz`` and, in a transient, ``vx vy vz``), ``"steps"``
            (one row per step: load factor or time, iterations, residual, energies) or
            ``"elements"`` (one row per step and element of ``kind``: the deformations
            ``e1..`` and stress resultants ``s1..``). /eigen, /buckling: ``"modes"`` (the
            default: one row per linearization and mode). /compliance: ``"global"`` (the
            default) or ``"local"``, /state_space: ``"A"`` (the default), ``"B"``, ``"C"``
            or ``"D"``: one row per linearization and matrix row (response or state or
            output name), one column per load component, state or input.
        kind : str
            The element kind of ``what="elements"``.

        Returns
        -------
        pandas.DataFrame
            Indexed by (``step`` or ``time``, ``node``/``element``) or (``linearized_step``,
            ``mode``); ``df.attrs["units"]`` maps each column to its unit.

        Raises
        ------
        MissingExtraError
            pandas is not installed.
        ValueError
            An unknown ``what``.
        """
        pd = _import("pandas")
        with _keep_open(self._res):
            if self._group in ("compliance", "state_space"):
                from spacarpy.results import labelled_linear
                return labelled_linear.dataframe(self, pd, what)
            return _dataframe(self, pd, what, kind)


def _dataframe(view, pd, what, kind):
    stepped = view._group in ("static", "transient")
    what = what or ("nodes" if stepped else "modes")
    allowed = ("nodes", "steps", "elements") if stepped else ("modes",)
    if what not in allowed:
        raise ValueError(f"to_dataframe: what must be one of {', '.join(allowed)} for "
                         f"/{view._group}, got {what!r}")
    model = view._res.model
    if what == "modes":
        n_lin, n_mode = view.n_lin, view.n_mode
        index = pd.MultiIndex.from_product([np.arange(n_lin), np.arange(1, n_mode + 1)],
                                           names=["linearized_step", "mode"])
        cols = {"step": np.repeat(view.step, n_mode),
                "load_factor": np.repeat(view.load_factor, n_mode),
                "kind": view.kind.ravel()}
        units = {"step": "1", "load_factor": "1", "kind": "1"}
        if view._group == "eigen":
            ev = view.eigenvalue
            cols.update(frequency=view.frequency.ravel(), eigenvalue_real=ev.real.ravel(),
                        eigenvalue_imag=ev.imag.ravel())
            units.update({name: _unit(f"eigen/{name}") for name in
                          ("frequency", "eigenvalue_real", "eigenvalue_imag")})
        else:
            cols["load_multiplier"] = view.load_multiplier.ravel()
            units["load_multiplier"] = _unit("buckling/load_multiplier")
        df = pd.DataFrame(cols, index=index)
        df.attrs["units"] = units
        return df
    axis = view.time if view._group == "transient" else np.arange(view.n_step)
    axis_name = "time" if view._group == "transient" else "step"
    if what == "steps":
        cols = {"iterations": view.iterations, "residual": view.residual}
        units = {"iterations": "1", "residual": "1"}
        if view._group == "static":
            cols = {"load_factor": view.load_factor, **cols}
            units["load_factor"] = "1"
        else:
            for name in ("kinetic_energy", "elastic_energy", "external_work",
                         "energy_balance"):
                cols[name] = getattr(view, name)
                units[name] = "J"
        df = pd.DataFrame(cols, index=pd.Index(axis, name=axis_name))
        df.attrs["units"] = units
        return df
    if what == "nodes":
        ids = model.position_nodes
        n = ids.size
        index = pd.MultiIndex.from_product([axis, ids], names=[axis_name, "node"])
        pos, disp = view.position().reshape(-1, 3), view.displacement().reshape(-1, 3)
        cols, units = {}, {}
        for j, c in enumerate(_XYZ):
            cols[c], units[c] = pos[:, j], "m"
        for j, c in enumerate(_XYZ):
            cols["u" + c], units["u" + c] = disp[:, j], "m"
        if view._group == "transient":
            vel = view.velocity().reshape(-1, 3)
            for j, c in enumerate(_XYZ):
                cols["v" + c], units["v" + c] = vel[:, j], "m/s"
        df = pd.DataFrame(cols, index=index)
        if view._group == "static":
            df.insert(0, "load_factor", np.repeat(view.load_factor, n))
            units["load_factor"] = "1"
        df.attrs["units"] = units
        return df
    ids = model.element_ids(kind) if kind != "BEAM" else _beam_ids(model)
    deformation = view.deformation(kind=kind)
    stress = view.stress_resultant(kind=kind)
    n_mode = deformation.shape[-1]
    facts = KINDS.get(kind)
    index = pd.MultiIndex.from_product([axis, ids], names=[axis_name, "element"])
    cols, units = {}, {}
    for k in range(n_mode):
        cols[f"e{k + 1}"] = deformation[..., k].ravel()
        units[f"e{k + 1}"] = facts.mode_units[k] if facts is not None else ""
    for k in range(n_mode):
        cols[f"s{k + 1}"] = stress[..., k].ravel()
        units[f"s{k + 1}"] = facts.stress_units[k] if facts is not None else ""
    df = pd.DataFrame(cols, index=index)
    df.attrs["units"] = units
    return df

"""Reprs and labelled data of ``/compliance`` and ``/state_space`` (the other groups' are in
:mod:`spacarpy.results.labelled`, which hands these two groups to this module).

- ``/compliance``: the 6x6 compliance of one node at each linearization, labelled by
  ``response`` (ux uy uz phix phiy phiz) and ``load_component`` (Fx Fy Fz Tx Ty Tz), its
  entries' units in the coordinate ``compliance_units`` (they differ per entry);
- ``/state_space``: A, B, C, D labelled by the state, input and output names (A's columns
  along ``state_column``, the same names), and the poles.

Units and long names come from the schema's :data:`~spacarpy.results.schema.DATASETS`.
"""
from __future__ import annotations

import numpy as np

from spacarpy.results.schema import DATASETS, FIXED_DIMS

__all__ = ["GROUPS", "dataframe", "dataset_vars", "rows"]

#: The groups this module labels.
GROUPS = ("compliance", "state_space")
_MATRIX_DIMS = {"A": ("state", "state_column"), "B": ("state", "system_input"),
                "C": ("system_output", "state"), "D": ("system_output", "system_input")}


def _var(dims, data, units=None, long_name=None):
    attrs = {}
    if units is not None:
        attrs["units"] = units
    if long_name is not None:
        attrs["long_name"] = long_name
    return dims, np.asarray(data), attrs


def _spec_var(dims, data, path: str):
    spec = DATASETS[path]
    return _var(dims, data, spec.units, spec.long_name)


def _lin_coords(view) -> dict:
    n_lin = view.n_lin
    return {"linearized_step": _var(("linearized_step",), np.arange(n_lin), "1",
                                    "linearization (row)"),
            "step": _var(("linearized_step",), view.step, "1", "static load step linearized"),
            "load_factor": _var(("linearized_step",), view.load_factor, "1", "load factor")}


def _compliance_units() -> np.ndarray:
    return np.array(DATASETS["compliance/global"].index_units, dtype=object).reshape(6, 6)


def dataset_vars(view) -> tuple[dict, dict]:
    """(coords, data) of the xarray Dataset of ``view``."""
    coords = _lin_coords(view)
    if view._group == "compliance":
        coords["response"] = _var(("response",), list(FIXED_DIMS["response"]))
        coords["load_component"] = _var(("load_component",),
                                        list(FIXED_DIMS["load_component"]))
        coords["compliance_units"] = _var(("response", "load_component"),
                                          _compliance_units(), None,
                                          "unit of each entry of the compliance")
        dims = ("linearized_step", "response", "load_component")
        data = {"global": _var(dims, view.global_, None,
                               DATASETS["compliance/global"].long_name),
                "local": _var(dims, view.local, None,
                              DATASETS["compliance/local"].long_name)}
        return coords, data
    names = {"state": view.state_name, "state_column": view.state_name,
             "system_input": view.input_name, "system_output": view.output_name}
    for dim, labels in names.items():
        coords[dim] = _var((dim,), labels)
    coords["time"] = _var(("linearized_step",), view.time, "s", "time of the linearized state")
    data = {name: _spec_var(("linearized_step",) + dims, view._array(name),
                            f"state_space/{name}")
            for name, dims in _MATRIX_DIMS.items()}
    poles = _poles(view)
    if poles is not None:
        data["pole"] = _spec_var(("linearized_step", "state"), poles, "state_space/pole")
    return coords, data


def _poles(view) -> np.ndarray | None:
    """(n_lin, n_state) complex poles, or None (a file older than schema 2.9 has none)."""
    return view._array("pole") if view._res._has("state_space/pole") else None


def dataframe(view, pd, what):
    """``view.to_dataframe(what)``: one row per linearization and matrix row, one column
    per matrix column; ``df.attrs["units"]`` the unit of each entry (compliance) or of the
    matrix (state space)."""
    if view._group == "compliance":
        allowed, default = ("global", "local"), "global"
        rows_, cols = FIXED_DIMS["response"], FIXED_DIMS["load_component"]
    else:
        allowed, default = tuple(_MATRIX_DIMS), "A"
    what = what or default
    if what not in allowed:
        raise ValueError(f"to_dataframe: what must be one of {', '.join(allowed)} for "
                         f"/{view._group}, got {what!r}")
    if view._group == "compliance":
        values = view.global_ if what == "global" else view.local
        units = {(r, c): str(u) for r, row in zip(rows_, _compliance_units())
                 for c, u in zip(cols, row)}
    else:
        names = {"state": view.state_name, "state_column": view.state_name,
                 "system_input": view.input_name, "system_output": view.output_name}
        rows_, cols = (names[d] for d in _MATRIX_DIMS[what])
        values = view._array(what)
        units = DATASETS[f"state_space/{what}"].units
    n_lin = values.shape[0]
    index = pd.MultiIndex.from_product([np.arange(n_lin), list(rows_)],
                                       names=["linearized_step", "row"])
    df = pd.DataFrame(values.reshape(n_lin * len(rows_), len(cols)), index=index,
                      columns=list(cols))
    df.attrs["units"] = units
    return df


def _short(names, n: int = 4) -> str:
    return ", ".join(names[:n]) + (", ..." if len(names) > n else "")


def rows(view) -> list[tuple[str, str]]:
    """(what, value) lines of the repr of ``view``."""
    steps = ", ".join(str(s) for s in view.step[:8]) + (", ..." if view.n_lin > 8 else "")
    out = [("linearizations", f"{view.n_lin} (static steps {steps})")]
    if view._group == "compliance":
        pos, rot = view.node
        out.append(("node", f"position {pos}, orientation {rot}"))
        out.append(("matrices", "global, local: 6x6, rows ux uy uz phix phiy phiz, columns "
                    "Fx Fy Fz Tx Ty Tz"))
        out.append(("units", ", ".join(dict.fromkeys(_compliance_units().ravel()))))
        if view.n_lin:
            diag = np.diag(view.global_[-1])
            out.append(("diagonal", "last linearization, global: "
                        + ", ".join(f"{v:.6g}" for v in diag)))
        return out
    states, inputs, outputs = view.state_name, view.input_name, view.output_name
    out += [("states", f"{len(states)}: {_short(states)}"),
            ("inputs", f"{len(inputs)}: {_short(inputs)}"),
            ("outputs", f"{len(outputs)}: {_short(outputs)}"),
            ("matrices", "A, B, C, D (dz/dt = A z + B u, y = C z + D u; SI units, "
             "see units_rule)")]
    if view.n_lin and _poles(view) is not None:
        poles = _poles(view)[-1]
        shown = ", ".join(f"{p:.6g}" for p in poles[:4])
        out.append(("poles", f"1/s; last linearization: {shown}"
                    + (", ..." if poles.size > 4 else "")))
    return out

"""Views of a results file (schema 1.x or 2.x): each group read lazily, by deck numbers.

The classes :func:`spacarpy.results.reader.open_results` hands out: the root attributes, the
``/model`` view, the step views of ``/static`` and ``/transient`` (the views of the linearized
groups are in :mod:`spacarpy.results.linearized_views`). Each reads only what is asked for,
addressing datasets by their 2.0 names (1.x files through
:data:`spacarpy.results.schema.LEGACY_NAMES`), and selects rows by deck node and element
numbers.
"""
from __future__ import annotations

import logging
from functools import cached_property
from typing import NamedTuple

import numpy as np

from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.results.labelled import LabelledView
from spacarpy.results.schema import (
    KIND_NAMES,
)
from spacarpy.results.stress import section_forces, section_properties, surface_stress

log = logging.getLogger(__name__)

#: Reaction components of a position node and of an orientation node.
_FORCES = ("Fx", "Fy", "Fz")
_MOMENTS = ("Mx", "My", "Mz")


class ResultsQueryError(SpacarError, LookupError):
    """A request the file cannot answer: unknown node, element, step or mode, or a quantity
    the run did not compute."""

    exit_code = EXIT_INPUT


class ModeShape(NamedTuple):
    """One eigenmode or buckling mode: the perturbation of every node's coordinates."""

    #: (n_pos, 3): perturbation of the position nodes (zero on fixed coordinates).
    position: np.ndarray
    #: (n_rot, 4): perturbation of the Euler parameters of the orientation nodes.
    euler: np.ndarray


class RootAttributes:
    """Properties over the root attributes ``attrs`` (a dict of Python values), shared by the
    eager :class:`Results` and the lazy :class:`ResultsFile`."""

    @property
    def schema_version(self) -> tuple[int, int]:
        return tuple(self.attrs["schema_version"])

    @property
    def completed(self) -> bool:
        """Whether the run finished; ``False`` for a partial file."""
        return bool(self.attrs.get("completed", False))

    @property
    def error(self) -> str | None:
        """Why the run stopped, or ``None`` (finished, or killed without a chance to say)."""
        return self.attrs.get("error")

    @property
    def analysis(self) -> str:
        return self.attrs["analysis"]

    @property
    def deformations(self) -> str:
        return self.attrs["deformations"]

    @property
    def rotary_inertia(self) -> str:
        """``"lumped"`` or ``"consistent"``: how the beams' section rotary inertia entered the
        mass; ``"consistent"`` for a file without the attribute (spacarpy before schema 2.3
        had only that)."""
        return self.attrs.get("rotary_inertia", "consistent")


# --------------------------------------------------------------------------------------------
# model
# --------------------------------------------------------------------------------------------

class ModelView:
    """``/model``: what was analysed, by deck number. Arrays are read once, on first use.

    Files of schema 1.0 lack the element properties, cross-sections, loads and coordinate
    map; those attributes are then ``None`` (``element_length`` and ``element_position_rows``
    are computed from the node data instead).
    """

    def __init__(self, results):
        self._res = results

    def __repr__(self) -> str:
        kinds = ", ".join(f"{k} {self.element_ids(k).size}" for k in self.element_kinds
                          if self.element_ids(k).size)
        return (f"<ModelView /model: {self.n_pos} position nodes, {self.n_rot} orientation "
                f"nodes; elements {kinds or 'none'}>")

    def _repr_html_(self) -> str:
        import html
        return f"<div><code>{html.escape(repr(self))}</code></div>"

    def _get(self, name):
        path = name if name.startswith("model/") else f"model/{name}"
        if not self._res._has(path):
            return None
        value = self._res._read(path)
        if value.dtype.kind == "S":
            return np.char.decode(value, "utf-8")
        return value

    position_nodes = cached_property(lambda self: self._get("position_nodes"))
    position_nodes.__doc__ = "(n_pos,) int64: deck number of each position node."
    position_x0 = cached_property(lambda self: self._get("position_x0"))
    position_x0.__doc__ = "(n_pos, 3) float64: initial positions (m)."
    orientation_nodes = cached_property(lambda self: self._get("orientation_nodes"))
    orientation_nodes.__doc__ = "(n_rot,) int64: deck number of each orientation node."
    elements = cached_property(lambda self: self._get("elements"))
    elements.__doc__ = "(n_elem,) int64: deck number of each element."
    element_nodes = cached_property(lambda self: self._get("element_nodes"))
    element_nodes.__doc__ = "(n_elem, 4) int64: deck node numbers [p r q s]."
    @cached_property
    def element_type(self) -> np.ndarray:
        """(n_elem,) str: element keyword of the BEAM elements (``"BEAM"``)."""
        return np.full(self.n_elem, "BEAM")
    element_axes = cached_property(lambda self: self._get("element_axes"))
    element_axes.__doc__ = "(n_elem, 3, 3) float64 or None: initial axes x, y, z (rows)."
    deformation_class = cached_property(lambda self: self._get("element_deformation_class"))
    deformation_class.__doc__ = "(n_elem, 6) int8 or None: 0 rigid, 1 flexible, 2 released."
    stiffness = cached_property(lambda self: self._get("element_stiffness"))
    stiffness.__doc__ = "(n_elem, 6) float64 or None: EA GJ EIy EIz cy cz."
    mass = cached_property(lambda self: self._get("element_mass"))
    mass.__doc__ = "(n_elem, 5) float64 or None: rhoA rho(Iy+Iz) rhoIy rhoIz rhoIyz."
    cross_section_type = cached_property(lambda self: self._get("cross_section_type"))
    cross_section_type.__doc__ = "(n_elem,) str or None: RECT, CIRC or ''."
    cross_section_dims = cached_property(lambda self: self._get("cross_section_dims"))
    cross_section_dims.__doc__ = "(n_elem, 2) float64 or None: (w, t) or (d, NaN) (m)."
    load_node = cached_property(lambda self: self._get("load_node"))
    load_node.__doc__ = "(n_load,) int64 or None: node of each load line."
    load_type = cached_property(lambda self: self._get("load_type"))
    load_type.__doc__ = "(n_load,) str or None: XF or DELXF."
    load_value = cached_property(lambda self: self._get("load_value"))
    load_value.__doc__ = "(n_load, 3) float64 or None: force (N) or moment (N m)."
    line_load_element = cached_property(lambda self: self._get("line_load_element"))
    line_load_element.__doc__ = "(n_line_load,) int64 or None: element of each line load line."
    line_load_type = cached_property(lambda self: self._get("line_load_type"))
    line_load_type.__doc__ = "(n_line_load,) str or None: QE, DELQE, QEL or DELQEL."
    line_load_value = cached_property(lambda self: self._get("line_load_value"))
    line_load_value.__doc__ = ("(n_line_load, 2, 3) float64 or None: force per length (N/m) "
                               "at the ends p, q; global (QE) or current element axes (QEL).")
    follower_load_node = cached_property(lambda self: self._get("follower_load_node"))
    follower_load_node.__doc__ = "(n_follower_load, 2) int64 or None: [node, axes node]."
    follower_load_type = cached_property(lambda self: self._get("follower_load_type"))
    follower_load_type.__doc__ = "(n_follower_load,) str or None: XFL or DELXFL."
    follower_load_value = cached_property(lambda self: self._get("follower_load_value"))
    follower_load_value.__doc__ = ("(n_follower_load, 3) float64 or None: force (N) or moment "
                                   "(N m) in the current axes of the axes node.")
    coordinate_node = cached_property(lambda self: self._get("coordinate_node"))
    coordinate_node.__doc__ = "(n_coord,) int64 or None: node owning each global coordinate."
    coordinate_index = cached_property(lambda self: self._get("coordinate_index"))
    coordinate_index.__doc__ = "(n_coord,) int8 or None: 1..3 (x y z) or 1..4 (lambda0..3)."
    coordinate_fixed = cached_property(lambda self: None if self._get("coordinate_fixed") is None
                                       else self._get("coordinate_fixed").astype(bool))
    coordinate_fixed.__doc__ = "(n_coord,) bool or None: fixed coordinates."

    @cached_property
    def element_kinds(self) -> list[str]:
        """Element kinds of the model (``/model/elements/<KIND>``); BEAM first."""
        return [k for k in KIND_NAMES if self._res._has(f"model/elements/{k}/ids")]

    def element_ids(self, kind: str = "BEAM") -> np.ndarray:
        """(n,) int64: deck numbers of the elements of kind ``kind``."""
        ids = self._get(f"model/elements/{kind}/ids")
        if ids is None:
            raise ResultsQueryError(f"the model has no {kind} elements (kinds: "
                                    f"{', '.join(self.element_kinds)})")
        return ids

    def element_kind_nodes(self, kind: str = "BEAM") -> np.ndarray:
        """(n, n_slots) int64: deck node numbers of the elements of kind ``kind``."""
        self.element_ids(kind)
        return self._get(f"model/elements/{kind}/nodes")

    def kind_row(self, kind: str, element) -> np.ndarray | int:
        """Row of element(s) ``element`` among the elements of kind ``kind``."""
        return _rows(self.element_ids(kind), element, f"{kind} element")

    @property
    def n_pos(self) -> int:
        return int(self.position_nodes.size)

    @property
    def n_rot(self) -> int:
        return int(self.orientation_nodes.size)

    @property
    def n_elem(self) -> int:
        return int(self.elements.size)

    @cached_property
    def element_position_rows(self) -> np.ndarray:
        """(n_elem, 2) int64: rows of the position arrays of each element's nodes p, q."""
        stored = self._get("element_position_rows")
        if stored is not None:
            return stored
        return self.position_row(self.element_nodes[:, [0, 2]])

    @cached_property
    def element_length(self) -> np.ndarray:
        """(n_elem,) float64: reference length l0 of each element (m)."""
        stored = self._get("element_length")
        if stored is not None:
            return stored
        x0 = self.position_x0[self.element_position_rows]
        return np.linalg.norm(x0[:, 1] - x0[:, 0], axis=1)

    @cached_property
    def sections(self):
        """:class:`~spacarpy.results.stress.SectionProperties` of the elements (all NaN when no
        cross-section is known)."""
        shape = self.cross_section_type
        if shape is None:
            shape = np.full(self.n_elem, "")
            dims = np.full((self.n_elem, 2), np.nan)
        else:
            dims = self.cross_section_dims
        return section_properties(shape, dims)

    def position_row(self, node) -> np.ndarray | int:
        """Row of position node(s) ``node`` (deck numbers) in the position arrays."""
        return _rows(self.position_nodes, node, "position node")

    def orientation_row(self, node) -> np.ndarray | int:
        """Row of orientation node(s) ``node`` (deck numbers) in the Euler-parameter arrays."""
        return _rows(self.orientation_nodes, node, "orientation node")

    def element_row(self, element) -> np.ndarray | int:
        """Row of element(s) ``element`` (deck numbers) in the element arrays."""
        return _rows(self.elements, element, "element")

    def node_kind(self, node: int) -> str:
        """``"position"`` or ``"orientation"``."""
        if node in set(self.position_nodes.tolist()):
            return "position"
        if node in set(self.orientation_nodes.tolist()):
            return "orientation"
        nodes = np.union1d(self.position_nodes, self.orientation_nodes)
        raise ResultsQueryError(f"node {node} is not a node of this model "
                                f"({_number_list(nodes)})")


def _rows(ids: np.ndarray, wanted, what: str):
    """Rows of deck numbers ``wanted`` (scalar or array) in ``ids``; clear error if absent."""
    wanted_arr = np.asarray(wanted)
    if not np.issubdtype(wanted_arr.dtype, np.integer):
        raise ResultsQueryError(f"{what} numbers must be whole numbers, got {wanted!r}")
    order = np.argsort(ids)
    pos = np.searchsorted(ids, wanted_arr, sorter=order)
    pos = np.minimum(pos, max(ids.size - 1, 0))
    rows = order[pos] if ids.size else np.zeros_like(wanted_arr)
    found = ids[rows] == wanted_arr if ids.size else np.zeros(wanted_arr.shape, bool)
    if not np.all(found):
        missing = np.atleast_1d(wanted_arr)[~np.atleast_1d(found)]
        raise ResultsQueryError(f"{what} {missing[0]} is not in this model ({what}s: "
                                f"{_number_list(ids)})")
    return int(rows) if rows.ndim == 0 else rows


def _number_list(ids) -> str:
    """Compact list of deck numbers: '1, 3, 5, ..., 17' for long lists."""
    ids = np.sort(np.asarray(ids)).tolist()
    if len(ids) > 8:
        return ", ".join(str(v) for v in ids[:3]) + ", ..., " + str(ids[-1])
    return ", ".join(str(v) for v in ids) or "none"


# --------------------------------------------------------------------------------------------
# static
# --------------------------------------------------------------------------------------------

class _StepView(LabelledView):
    """A group with one row per committed step (``/static``, ``/transient``), read lazily.

    Every accessor takes ``step`` (None: all committed steps; an int, negative counting from
    the end; a slice; or a sequence of step numbers) and an entity selector (``node`` or
    ``element``, deck numbers; None: all). A selected single step or entity drops its axis:
    ``position(node=3)`` is (n_step, 3), ``position(step=-1)`` (n_pos, 3).
    """

    _group = ""
    _scale = ""

    def __init__(self, results):
        self._res = results

    @property
    def n_step(self) -> int:
        """Number of committed steps (grows while a run is being written)."""
        return self._res._length(f"{self._group}/{self._scale}")

    def _series(self, name: str) -> np.ndarray:
        return self._res._read(f"{self._group}/{name}", np.s_[:self.n_step])

    @property
    def iterations(self) -> np.ndarray:
        """(n_step,): Newton iterations per step."""
        return self._series("iterations")

    @property
    def residual(self) -> np.ndarray:
        """(n_step,): final relative residual per step."""
        return self._series("residual")

    @property
    def converged_by(self) -> np.ndarray:
        """(n_step,) int: 0 where the step's residual met the tolerance, 1 where it was
        accepted within its measured round-off floor; -1 for a file older than 2.7
        (/static) or 2.10 (/transient)."""
        if not self._res._has(f"{self._group}/converged_by"):
            return np.full(self.n_step, -1, dtype=np.int8)
        return self._series("converged_by")

    @property
    def element_kinds(self) -> list[str]:
        """Element kinds with per-kind datasets in this group."""
        return [k for k in self._res.model.element_kinds
                if self._res._has(f"{self._group}/elements/{k}/deformation")]

    def step_index(self, step=None):
        """Normalize a step selector to an index usable on axis 0 (None: all steps)."""
        n = self.n_step
        if step is None:
            return slice(0, n)
        if isinstance(step, slice):
            return slice(*step.indices(n))
        arr = np.asarray(step)
        if not np.issubdtype(arr.dtype, np.integer):
            raise ResultsQueryError(f"step must be a whole number, got {step!r}")
        if np.any(arr >= n) or np.any(arr < -n):
            raise ResultsQueryError(f"step {step} does not exist: the file has {n} committed "
                                    f"steps (0..{n - 1})")
        arr = np.where(arr < 0, arr + n, arr)
        return int(arr) if arr.ndim == 0 else arr

    def _select(self, name: str, step, entity_rows) -> np.ndarray:
        s = self.step_index(step)
        if isinstance(s, np.ndarray):
            # h5py needs increasing indices: read sorted unique rows, then reorder.
            uniq, inverse = np.unique(s, return_inverse=True)
            data = self._res._read(f"{self._group}/{name}", (uniq,))
            data = data[inverse]
        else:
            data = self._res._read(f"{self._group}/{name}", (s,))
        if entity_rows is None:
            return data
        return data[:, entity_rows] if not isinstance(s, int) else data[entity_rows]

    def position(self, node=None, step=None) -> np.ndarray:
        """Positions (m): (n_step, n_pos, 3), (n_step, 3) for one node, (3,) for one node
        and step."""
        rows = None if node is None else self._res.model.position_row(node)
        return self._select("position", step, rows)

    def displacement(self, node=None, step=None) -> np.ndarray:
        """Displacements from the initial positions (m), shaped as :meth:`position`."""
        rows = slice(None) if node is None else self._res.model.position_row(node)
        return self.position(node, step) - self._res.model.position_x0[rows]

    def euler(self, node=None, step=None) -> np.ndarray:
        """Euler parameters (lambda0..lambda3) of orientation node(s) (1)."""
        rows = None if node is None else self._res.model.orientation_row(node)
        return self._select("euler", step, rows)

    def deformation(self, element=None, step=None, kind: str = "BEAM") -> np.ndarray:
        """Generalized deformations of the elements of kind ``kind``: (n_step, n_elem,
        n_def) or sliced (BEAM: m; see docs/results.md for the other kinds' units)."""
        return self._element("deformation", element, step, kind)

    def stress_resultant(self, element=None, step=None, kind: str = "BEAM") -> np.ndarray:
        """Generalized stress resultants of the elements of kind ``kind`` (BEAM:
        sigma_1..sigma_6, N): (n_step, n_elem, n_def) or sliced."""
        return self._element("stress_resultant", element, step, kind)

    def _element(self, what, element, step, kind):
        model = self._res.model
        if not self._res._has(f"{self._group}/elements/{kind}/{what}"):
            model.element_ids(kind)          # raises for a kind the model has not
            raise ResultsQueryError(f"/{self._group} has no {kind} {what}")
        rows = None if element is None else (
            model.element_row(element) if kind == "BEAM" else model.kind_row(kind, element))
        return self._select(f"elements/{kind}/{what}", step, rows)


class StaticView(_StepView):
    """``/static``: one row per committed load step (see :class:`_StepView` for the
    selectors)."""

    _group = "static"
    _scale = "load_factor"

    @property
    def load_factor(self) -> np.ndarray:
        """(n_step,): factor on DELXF of each step."""
        return self._res._read("static/load_factor")

    @property
    def has_stress(self) -> bool:
        """Whether surface stresses were stored (some element has a known cross-section)."""
        return self._res._has("static/elements/BEAM/max_normal_stress")

    @property
    def reaction_node(self) -> np.ndarray:
        """(n_reac,): node of each reaction component."""
        return self._res._read("static/reaction_node")

    @property
    def reaction_component(self) -> list[str]:
        """Name (Fx ... Mz) of each reaction component."""
        return np.char.decode(self._res._read("static/reaction_component"), "utf-8").tolist()

    def section_forces(self, element=None, step=None) -> np.ndarray:
        """Normal force N (N), torque T and end moments My_p, My_q, Mz_p, Mz_q (N m), element
        axes (see :func:`spacarpy.results.stress.section_forces`): (..., 6)."""
        rows = slice(None) if element is None else self._res.model.element_row(element)
        l0 = np.atleast_1d(self._res.model.element_length[rows])
        sigma = self.stress_resultant(element, step)
        flat = sigma.reshape(-1, l0.size, 6)
        return section_forces(flat, l0).reshape(sigma.shape)

    def strain_energy(self, element=None, step=None) -> np.ndarray:
        """Elastic energy ``sigma . e / 2`` of the element(s) (J): (n_step, n_elem) or
        sliced. Exact for the linear-elastic DDM beam, whose stress resultants are
        ``S e``; rigid modes (``e = 0``) and released modes without stiffness add nothing."""
        return 0.5 * np.sum(self.stress_resultant(element, step)
                            * self.deformation(element, step), axis=-1)

    def total_strain_energy(self, step=None) -> np.ndarray:
        """Elastic energy of the whole model (J): (n_step,) or a scalar for one step."""
        return np.sum(self.strain_energy(None, step), axis=-1)

    def max_normal_stress(self, element=None, step=None) -> np.ndarray:
        """Largest normal stress at the surface (Pa): (n_step, n_elem) or sliced; NaN for
        elements without a cross-section."""
        return self._stress("max_normal_stress", element, step)

    def max_von_mises_stress(self, element=None, step=None) -> np.ndarray:
        """Largest von Mises stress at the surface (Pa): (n_step, n_elem) or sliced."""
        return self._stress("max_von_mises_stress", element, step)

    def _stress(self, name, element, step):
        rows = None if element is None else self._res.model.element_row(element)
        if self.has_stress:
            return self._select(f"elements/BEAM/{name}", step, rows)
        model = self._res.model
        if model.cross_section_type is None or not model.sections.known.any():
            raise ResultsQueryError("no stresses: no element of this model has a known "
                                    "cross-section (give CROSSTYPE/CROSSDIM in the deck's "
                                    "VISUALIZATION section)")
        # a file written without the stress datasets but with cross-sections: compute
        sel = slice(None) if rows is None else rows
        sigma = self.stress_resultant(None, step)
        normal, mises = surface_stress(sigma, model.element_length, model.sections)
        out = normal if name == "max_normal_stress" else mises
        return out[..., sel]

    def reaction(self, node=None, step=None) -> np.ndarray:
        """Support reactions in global axes.

        Without ``node``: (n_step, n_reac) in the order of :attr:`reaction_node` and
        :attr:`reaction_component`. With a position ``node``: (n_step, 3) forces Fx, Fy, Fz
        (N); with an orientation node: moments Mx, My, Mz (N m); NaN for components that are
        not supported (free coordinates).
        """
        data = self._select("reaction", step, None)
        if node is None:
            return data
        kind = self._res.model.node_kind(int(node))
        names = _FORCES if kind == "position" else _MOMENTS
        comps = self.reaction_component
        nodes = self.reaction_node
        out = np.full(data.shape[:-1] + (3,), np.nan)
        for j, name in enumerate(names):
            hit = np.flatnonzero((nodes == node) & (np.asarray(comps) == name))
            if hit.size:
                out[..., j] = data[..., hit[0]]
        return out


class TransientView(_StepView):
    """``/transient``: one row per committed time step (see :class:`_StepView` for the
    selectors; ``step`` counts stored time steps, 0 = the initial state)::

        tr = res.transient
        tr.time                          # (n_step,) s
        tr.position(node=3)              # (n_step, 3): node 3 at every time step
        tr.velocity(node=3, step=-1)     # (3,) m/s at the last time step
        tr.deformation(kind="HINGE")     # (n_step, n_hinge, 3)
        tr.energy_balance                # (n_step,) T + U + D - W (J)
    """

    _group = "transient"
    _scale = "time"

    @property
    def time(self) -> np.ndarray:
        """(n_step,): time of each stored step (s)."""
        return self._res._read("transient/time")

    def step_at(self, time: float) -> int:
        """The stored time step nearest to ``time`` (s)."""
        t = self.time
        if t.size == 0:
            raise ResultsQueryError("/transient holds no time step")
        if not (t[0] - 1e-12 * max(abs(t[-1]), 1.0) <= time <= t[-1] + 1e-12 * max(
                abs(t[-1]), 1.0)):
            raise ResultsQueryError(f"time {time} is outside the stored span "
                                    f"[{t[0]:g}, {t[-1]:g}] s")
        return int(np.argmin(np.abs(t - time)))

    def velocity(self, node=None, step=None) -> np.ndarray:
        """Velocities of position node(s) (m/s), shaped as :meth:`position`."""
        rows = None if node is None else self._res.model.position_row(node)
        return self._select("velocity", step, rows)

    def euler_rate(self, node=None, step=None) -> np.ndarray:
        """Time derivatives of the Euler parameters of orientation node(s) (1/s)."""
        rows = None if node is None else self._res.model.orientation_row(node)
        return self._select("euler_rate", step, rows)

    def acceleration(self, node=None, step=None) -> np.ndarray:
        """Accelerations of position node(s) (m/s^2), shaped as :meth:`position`; only
        inverse dynamics (SPACAR mode 2) stores them (schema 2.15)."""
        if not self._res._has("transient/acceleration"):
            raise ResultsQueryError("this file has no /transient/acceleration: only inverse "
                                    "dynamics (MODE 2) stores the accelerations")
        rows = None if node is None else self._res.model.position_row(node)
        return self._select("acceleration", step, rows)

    @property
    def kinetic_energy(self) -> np.ndarray:
        """(n_step,): kinetic energy T (J)."""
        return self._series("kinetic_energy")

    @property
    def elastic_energy(self) -> np.ndarray:
        """(n_step,): elastic energy U (J)."""
        return self._series("elastic_energy")

    @property
    def external_work(self) -> np.ndarray:
        """(n_step,): work W of the loads, gravity and prescribed motions since t = 0 (J)."""
        return self._series("external_work")

    @property
    def dissipated_energy(self) -> np.ndarray:
        """(n_step,): energy dissipated by damping since t = 0 (J); zeros for an early 1.4
        file without it."""
        if not self._res._has("transient/dissipated_energy"):
            return np.zeros(self.n_step)
        return self._series("dissipated_energy")

    reaction_node = StaticView.reaction_node
    reaction_component = StaticView.reaction_component

    def reaction(self, node=None, step=None) -> np.ndarray:
        """Reactions of the fixed and prescribed coordinates at each time step, inertia and
        damping included (the force that holds a prescribed motion), shaped as
        :meth:`StaticView.reaction`; a file older than schema 2.8 has none."""
        if not self._res._has("transient/reaction"):
            raise ResultsQueryError("this file has no /transient/reaction (written before "
                                    "schema 2.8); run the deck again to get it")
        return StaticView.reaction(self, node, step)

    @property
    def energy_balance(self) -> np.ndarray:
        """(n_step,): T + U + D - W (J), constant for an exact integration."""
        return (self.kinetic_energy + self.elastic_energy + self.dissipated_energy
                - self.external_work)

"""Lazy, typed access to a results file: :func:`open_results`.

This module's one job is reading results conveniently: :func:`open_results` checks the file
once (file type, schema version, layout: the same checks as :func:`~spacarpy.results.read_results`)
and returns a :class:`ResultsFile` whose groups are views that read only what is asked for, by
deck node and element numbers::

    res = spacarpy.open_results("bend.h5")
    res.static.position(node=3)              # (n_step, 3): node 3 at every load step
    res.static.displacement(node=3, step=-1) # (3,): at the last step
    res.static.section_forces(element=1)     # (n_step, 6): N, T, My_p, My_q, Mz_p, Mz_q
    res.eigen.frequency                      # (n_lin, n_mode) Hz
    res.eigen.shape(mode=1).position         # (n_pos, 3) at the last linearized step
    res.buckling.critical_load_multiplier    # (n_lin,)

Nothing but the root attributes is kept in memory: every access opens the file (SWMR-read for
a file whose writer was killed or is still running) and slices the dataset. Inside
``with open_results(path) as res:`` one file handle is kept open instead. Steps are the rows of
``/static`` (0 = the initial state, as ITERSTEP counts them; negative numbers count from the
end); only committed steps are visible. Modes are numbered from 1.
"""
from __future__ import annotations

import os
from contextlib import contextmanager
from functools import cached_property
from typing import NamedTuple

import numpy as np

from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.results.hdf5 import (
    RootAttributes,
    MODE_KIND_NAMES,
    check_readable,
    open_for_reading,
)
from spacarpy.results.stress import section_forces, section_properties, surface_stress

__all__ = ["open_results", "ResultsFile", "ModelView", "StaticView", "EigenView",
           "BucklingView", "ComplianceView", "ModeShape", "ResultsQueryError"]

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


def open_results(path) -> "ResultsFile":
    """Open a results file for lazy reading.

    Parameters
    ----------
    path : str or os.PathLike
        A results file, complete or partial (``*.partial.h5`` of a failed or killed run).

    Returns
    -------
    ResultsFile

    Raises
    ------
    ResultsFormatError
        The file cannot be opened, is not a spacarpy results file, has a newer major schema
        version than this spacarpy reads (the message names both versions), or violates the
        schema.
    """
    return ResultsFile(path)


class ResultsFile(RootAttributes):
    """A results file opened by :func:`open_results`.

    Attributes
    ----------
    path : str
    attrs : dict
        Root attributes as Python values (``schema_version`` a tuple).
    model : ModelView
    static : StaticView or None
        ``None`` when the file has no ``/static`` group.
    eigen : EigenView or None
    buckling : BucklingView or None
    compliance : ComplianceView or None
    """

    def __init__(self, path):
        self.path = os.fspath(path)
        self._handle = None
        self._context = None
        with open_for_reading(self.path) as f:
            self.attrs = check_readable(f, self.path)
            groups = set(f.keys())
        self.model = ModelView(self)
        self.static = StaticView(self) if "static" in groups else None
        self.eigen = EigenView(self, "eigen") if "eigen" in groups else None
        self.buckling = BucklingView(self, "buckling") if "buckling" in groups else None
        self.compliance = ComplianceView(self, "compliance") if "compliance" in groups else None

    # -- file access --------------------------------------------------------------------------

    def __enter__(self) -> "ResultsFile":
        if self._handle is None:
            self._context = open_for_reading(self.path)
            self._handle = self._context.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the handle kept open by ``with``; later accesses open the file again."""
        if self._handle is not None:
            context, self._handle, self._context = self._context, None, None
            context.__exit__(None, None, None)

    @contextmanager
    def _file(self):
        if self._handle is not None:
            yield self._handle
        else:
            with open_for_reading(self.path) as f:
                yield f

    def _read(self, path: str, selection=()) -> np.ndarray:
        with self._file() as f:
            return f[path][selection]

    def _has(self, path: str) -> bool:
        with self._file() as f:
            return path in f

    def _length(self, path: str) -> int:
        with self._file() as f:
            return int(f[path].shape[0])

    # -- root attributes ----------------------------------------------------------------------

    @property
    def deck(self) -> str:
        """The deck text, verbatim."""
        with self._file() as f:
            return f["deck"].asstr()[()]

    def __repr__(self) -> str:
        parts = [f"{self.analysis} analysis",
                 "completed" if self.completed else "INCOMPLETE",
                 f"schema {self.schema_version[0]}.{self.schema_version[1]}"]
        groups = [name for name in ("static", "eigen", "buckling", "compliance")
                  if getattr(self, name) is not None]
        return f"<ResultsFile {self.path!r}: {', '.join(parts)}; groups {', '.join(groups)}>"


# --------------------------------------------------------------------------------------------
# model
# --------------------------------------------------------------------------------------------

class ModelView:
    """``/model``: what was analysed, by deck number. Arrays are read once, on first use.

    Files of schema 1.0 lack the element properties, cross-sections, loads and coordinate
    map; those attributes are then ``None`` (``element_length`` and ``element_position_rows``
    are computed from the node data instead).
    """

    def __init__(self, results: ResultsFile):
        self._res = results

    def _get(self, name):
        path = f"model/{name}"
        if not self._res._has(path):
            return None
        value = self._res._read(path)
        if value.dtype.kind == "S":
            return np.char.decode(value, "ascii")
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
    element_type = cached_property(lambda self: self._get("element_type"))
    element_type.__doc__ = "(n_elem,) str: element keyword."
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
    coordinate_node = cached_property(lambda self: self._get("coordinate_node"))
    coordinate_node.__doc__ = "(n_coord,) int64 or None: node owning each global coordinate."
    coordinate_index = cached_property(lambda self: self._get("coordinate_index"))
    coordinate_index.__doc__ = "(n_coord,) int8 or None: 1..3 (x y z) or 1..4 (lambda0..3)."
    coordinate_fixed = cached_property(lambda self: self._get("coordinate_fixed"))
    coordinate_fixed.__doc__ = "(n_coord,) bool or None: fixed coordinates."

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

class StaticView:
    """``/static``: one row per committed load step, read lazily.

    Every accessor takes ``step`` (None: all committed steps; an int, negative counting from
    the end; a slice; or a sequence of step numbers) and an entity selector (``node`` or
    ``element``, deck numbers; None: all). A selected single step or entity drops its axis:
    ``position(node=3)`` is (n_step, 3), ``position(step=-1)`` (n_pos, 3).
    """

    def __init__(self, results: ResultsFile):
        self._res = results

    @property
    def n_step(self) -> int:
        """Number of committed steps (grows while a run is being written)."""
        return self._res._length("static/load_factor")

    @property
    def load_factor(self) -> np.ndarray:
        """(n_step,): factor on DELXF of each step."""
        return self._res._read("static/load_factor")

    @property
    def iterations(self) -> np.ndarray:
        """(n_step,): Newton iterations per step."""
        return self._res._read("static/iterations", np.s_[:self.n_step])

    @property
    def residual(self) -> np.ndarray:
        """(n_step,): final relative residual per step."""
        return self._res._read("static/residual", np.s_[:self.n_step])

    @property
    def has_stress(self) -> bool:
        """Whether surface stresses were stored (some element has a known cross-section)."""
        return self._res._has("static/max_normal_stress")

    @property
    def reaction_node(self) -> np.ndarray:
        """(n_reac,): node of each reaction component."""
        return self._res._read("static/reaction_node")

    @property
    def reaction_component(self) -> list[str]:
        """Name (Fx ... Mz) of each reaction component."""
        return np.char.decode(self._res._read("static/reaction_component"), "ascii").tolist()

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
            data = self._res._read(f"static/{name}", (uniq,))
            data = data[inverse]
        else:
            data = self._res._read(f"static/{name}", (s,))
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

    def deformation(self, element=None, step=None) -> np.ndarray:
        """Generalized deformations (m): (n_step, n_elem, 6) or sliced."""
        rows = None if element is None else self._res.model.element_row(element)
        return self._select("deformation", step, rows)

    def stress_resultant(self, element=None, step=None) -> np.ndarray:
        """Generalized stress resultants sigma_1..sigma_6 (N): (n_step, n_elem, 6) or
        sliced."""
        rows = None if element is None else self._res.model.element_row(element)
        return self._select("stress_resultant", step, rows)

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
            return self._select(name, step, rows)
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


# --------------------------------------------------------------------------------------------
# linearized analyses
# --------------------------------------------------------------------------------------------

class _LinearizedView:
    """A linearized group: one row per linearized static step."""

    def __init__(self, results: ResultsFile, group: str):
        self._res = results
        self._group = group

    @property
    def step(self) -> np.ndarray:
        """(n_lin,): the static step (row of ``/static``) of each linearization."""
        return self._res._read(f"{self._group}/step")

    @property
    def n_lin(self) -> int:
        return self._res._length(f"{self._group}/step")

    @property
    def n_mode(self) -> int:
        with self._res._file() as f:
            return int(f[self._group].attrs["n_mode"])

    @property
    def load_factor(self) -> np.ndarray:
        """(n_lin,): load factor of each linearized step."""
        if self._res.static is None:
            return np.full(self.n_lin, np.nan)
        return self._res.static.load_factor[self.step]

    def _array(self, name: str) -> np.ndarray:
        return self._res._read(f"{self._group}/{name}", np.s_[:self.n_lin])

    def row(self, step=None) -> int:
        """Row of the linearization at static step ``step`` (None: the last one)."""
        steps = self.step
        if steps.size == 0:
            raise ResultsQueryError(f"/{self._group} holds no linearized step")
        if step is None:
            return steps.size - 1
        if self._res.static is not None:
            step = self._res.static.step_index(step)
        hit = np.flatnonzero(steps == step)
        if not hit.size:
            raise ResultsQueryError(f"static step {step} was not linearized ({self._group} "
                                    f"results exist at steps {_number_list(steps)})")
        return int(hit[-1])

    def _mode_index(self, mode: int) -> int:
        n = self.n_mode
        if not 1 <= int(mode) <= n:
            raise ResultsQueryError(f"mode {mode} does not exist: modes are numbered 1..{n}")
        return int(mode) - 1

    def shape(self, mode: int = 1, step=None) -> ModeShape:
        """Mode shape ``mode`` (1 = first) at static step ``step`` (None: last linearized)."""
        if self._group == "compliance":
            raise ResultsQueryError("/compliance has no mode shapes")
        r, m = self.row(step), self._mode_index(mode)
        return ModeShape(self._res._read(f"{self._group}/shape_position", (r, m)),
                         self._res._read(f"{self._group}/shape_euler", (r, m)))


class EigenView(_LinearizedView):
    """``/eigen``: natural frequencies and mass-normalized mode shapes."""

    @property
    def frequency(self) -> np.ndarray:
        """(n_lin, n_mode) Hz (negative: unstable, NaN: complex/infinite, 0: rigid-body)."""
        return self._array("frequency")

    @property
    def eigenvalue(self) -> np.ndarray:
        """(n_lin, n_mode) complex: omega^2 (s^-2)."""
        return self._array("eigenvalue_real") + 1j * self._array("eigenvalue_imag")

    @property
    def kind(self) -> np.ndarray:
        """(n_lin, n_mode) int8: 0 elastic, 1 rigid-body, 2 unstable, 3 complex, 4 infinite."""
        return self._array("kind")

    kind_names = MODE_KIND_NAMES


class BucklingView(_LinearizedView):
    """``/buckling``: load multipliers and buckling shapes."""

    @property
    def load_multiplier(self) -> np.ndarray:
        """(n_lin, n_mode): multipliers of the load acting in the step."""
        return self._array("load_multiplier")

    @property
    def critical_load_multiplier(self) -> np.ndarray:
        """(n_lin,): smallest positive multiplier (inf: none)."""
        return self._array("critical_load_multiplier")


class ComplianceView(_LinearizedView):
    """``/compliance``: 6x6 compliance of one node at each linearized step."""

    @property
    def global_(self) -> np.ndarray:
        """(n_lin, 6, 6): compliance in global axes."""
        return self._array("global")

    @property
    def local(self) -> np.ndarray:
        """(n_lin, 6, 6): compliance in the node's current body axes."""
        return self._array("local")

    @property
    def node(self) -> tuple[int, int]:
        """(position node, orientation node) whose compliance is stored."""
        with self._res._file() as f:
            a = f[self._group].attrs
            return int(a["position_node"]), int(a["orientation_node"])


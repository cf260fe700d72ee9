"""Reading a results file (schema 1.x or 2.x): lazy open_results, eager read_results.

This module's one job is reading results: :func:`open_results` checks the file once (file
type, schema version, layout: :func:`spacarpy.results.validate.check_readable`) and returns a
:class:`ResultsFile` whose groups are views that read only what is asked for, by deck node and
element numbers; :func:`read_results` loads everything into arrays. Both address datasets by
their 2.0 names and read 1.x files through
:data:`spacarpy.results.schema.LEGACY_NAMES`::

    res = spacarpy.open_results("bend.h5")
    res.static.position(node=3)              # (n_step, 3): node 3 at every load step
    res.static.displacement(node=3, step=-1) # (3,): at the last step
    res.static.section_forces(element=1)     # (n_step, 6): N, T, My_p, My_q, Mz_p, Mz_q
    res.eigen.frequency                      # (n_lin, n_mode) Hz
    res.eigen.shape(mode=1).position         # (n_pos, 3) at the last linearized step
    res.buckling.critical_load_multiplier    # (n_lin,)
    res.transient.position(node=3)           # (n_t, 3): node 3 at every time step

Nothing but the root attributes is kept in memory: every access opens the file (SWMR-read for
a file whose writer was killed or is still running) and slices the dataset. Inside
``with open_results(path) as res:`` one file handle is kept open instead. Steps are the rows of
``/static`` (0 = the initial state, as ITERSTEP counts them; negative numbers count from the
end); only committed steps are visible. Modes are numbered from 1.

The module is longer than 600 lines because it holds one view class per group (model,
static, transient, linearized) plus the eager reader, which share the name mapping, the
selectors and the root attributes; splitting them would scatter one interface over modules.
"""
from __future__ import annotations

import hashlib
import logging
import os
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np

from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.results.h5file import (
    SchemaFile,
    checksum_problems,
    damaged,
    damaged_steps,
    fixed_damaged,
    open_for_reading,
    reading,
    schema_major,
    str_list,
)
from spacarpy.results.schema import (
    DATASETS,
    KIND_NAMES,
    MODE_KIND_NAMES,
    STEP_GROUPS,
    legacy_name,
    new_name,
)
from spacarpy.results.stress import section_forces, section_properties, surface_stress
from spacarpy.results.validate import check_readable, committed_steps

__all__ = ["open_results", "ResultsFile", "ModelView", "StaticView", "TransientView",
           "EigenView", "BucklingView", "ComplianceView", "ModeShape", "ResultsQueryError",
           "read_results", "Results", "StaticResults", "TransientResults",
           "LinearizedResults", "RootAttributes"]

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


def open_results(path, *, verify: bool = True) -> ResultsFile:
    """Open a results file for lazy reading.

    Parameters
    ----------
    path : str or os.PathLike
        A results file, complete or partial (``*.partial.h5`` of a failed or killed run).
    verify : bool
        Check each dataset against its checksums (schema 2.1) the first time it is read:
        the whole dataset is read once more. ``False`` skips it (very large files).

    Returns
    -------
    ResultsFile

    Raises
    ------
    ResultsFormatError
        The file cannot be opened, is not a spacarpy results file, has a newer major schema
        version than this spacarpy reads (the message names both versions), or violates the
        schema; also later, when a dataset read is damaged (truncated, or its values do not
        match its checksum).
    """
    return ResultsFile(path, verify=verify)


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
    transient : TransientView or None
        ``None`` when the file has no ``/transient`` group.
    eigen : EigenView or None
    buckling : BucklingView or None
    compliance : ComplianceView or None
    """

    def __init__(self, path, *, verify: bool = True):
        self.path = os.fspath(path)
        self.verify = verify
        self._verified: set[str] = set()
        self._handle = None
        self._context = None
        with open_for_reading(self.path) as f:
            self.attrs = check_readable(f, self.path)
            groups = set(f.keys())
            self._major = schema_major(f)
        self.model = ModelView(self)
        self.static = StaticView(self) if "static" in groups else None
        self.transient = TransientView(self) if "transient" in groups else None
        self.eigen = EigenView(self, "eigen") if "eigen" in groups else None
        self.buckling = BucklingView(self, "buckling") if "buckling" in groups else None
        self.compliance = ComplianceView(self, "compliance") if "compliance" in groups else None

    # -- file access --------------------------------------------------------------------------

    def __enter__(self) -> ResultsFile:
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
            with reading(self.path):
                yield self._handle
        else:
            with open_for_reading(self.path) as f:
                yield f

    def _name(self, path: str) -> str:
        """Where dataset ``path`` lives in this file: 2.0 names are mapped to 1.x names in a
        1.x file, 1.x names to 2.0 names in a 2.x file (:data:`~spacarpy.results.schema.
        LEGACY_NAMES`), so that either name reads either file."""
        path = path.lstrip("/")
        if self._major < 2:
            return legacy_name(path, self._major)
        return new_name(path) or path

    def _read(self, path: str, selection=()) -> np.ndarray:
        with self._file() as f:
            ds = f[self._name(path)]
            if self.verify and ds.name not in self._verified:
                self._check(f, ds)
            return ds[selection]

    def _check(self, f, ds) -> None:
        """Verify a whole dataset against its checksums, once (the first time it is read)."""
        group, _, inner = ds.name.lstrip("/").partition("/")
        if fixed_damaged(ds):
            raise damaged(self.path, f"{ds.name} does not match its checksum")
        if group in STEP_GROUPS and inner != "checksum":
            steps = damaged_steps(f[group], f[group][STEP_GROUPS[group]].shape[0], only=inner)
            for name, bad in steps.items():
                raise damaged(self.path, f"{name} does not match the checksum stored with "
                                         f"step{'s' * (len(bad) > 1)} {bad[:10]}")
        self._verified.add(ds.name)

    def _has(self, path: str) -> bool:
        with self._file() as f:
            return self._name(path) in f

    def _length(self, path: str) -> int:
        with self._file() as f:
            return int(f[self._name(path)].shape[0])

    # -- root attributes ----------------------------------------------------------------------

    @property
    def deck(self) -> str:
        """The deck text, verbatim."""
        with self._file() as f:
            text = f["deck"].asstr()[()]
        sha = self.attrs.get("deck_sha256")
        if self.verify and isinstance(sha, str) and \
                hashlib.sha256(text.encode("utf-8")).hexdigest() != sha:
            raise damaged(self.path, "/deck does not match the root attribute deck_sha256")
        return text

    def __repr__(self) -> str:
        parts = [f"{self.analysis} analysis",
                 "completed" if self.completed else "INCOMPLETE",
                 f"schema {self.schema_version[0]}.{self.schema_version[1]}"]
        groups = [name for name in ("static", "transient", "eigen", "buckling", "compliance")
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
        path = name if name.startswith("model/") else f"model/{name}"
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
    coordinate_node = cached_property(lambda self: self._get("coordinate_node"))
    coordinate_node.__doc__ = "(n_coord,) int64 or None: node owning each global coordinate."
    coordinate_index = cached_property(lambda self: self._get("coordinate_index"))
    coordinate_index.__doc__ = "(n_coord,) int8 or None: 1..3 (x y z) or 1..4 (lambda0..3)."
    coordinate_fixed = cached_property(lambda self: self._get("coordinate_fixed"))
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

class _StepView:
    """A group with one row per committed step (``/static``, ``/transient``), read lazily.

    Every accessor takes ``step`` (None: all committed steps; an int, negative counting from
    the end; a slice; or a sequence of step numbers) and an entity selector (``node`` or
    ``element``, deck numbers; None: all). A selected single step or entity drops its axis:
    ``position(node=3)`` is (n_step, 3), ``position(step=-1)`` (n_pos, 3).
    """

    _group = ""
    _scale = ""

    def __init__(self, results: ResultsFile):
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
        return np.char.decode(self._res._read("static/reaction_component"), "ascii").tolist()

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

    @property
    def energy_balance(self) -> np.ndarray:
        """(n_step,): T + U + D - W (J), constant for an exact integration."""
        return (self.kinetic_energy + self.elastic_energy + self.dissipated_energy
                - self.external_work)


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



# --------------------------------------------------------------------------------------------
# eager reader
# --------------------------------------------------------------------------------------------

@dataclass
class StaticResults:
    """The ``/static`` group as arrays: one row per committed load step (axis 0 = step).

    Attributes
    ----------
    load_factor : (n_step,) float64
    position : (n_step, n_pos, 3) float64
    euler : (n_step, n_rot, 4) float64
    deformation, stress_resultant : (n_step, n_elem, 6) float64
        Of the BEAM elements (m, N).
    reaction : (n_step, n_reac) float64
    reaction_node : (n_reac,) int64
    reaction_component : list of str, length n_reac
    iterations : (n_step,) int32
    residual : (n_step,) float64
    max_normal_stress, max_von_mises_stress : (n_step, n_elem) float64 or None
        Largest surface stresses of the BEAM elements (Pa); ``None`` without cross-sections.
    elements : dict
        ``{kind: {"deformation": (n_step, n, n_def), "stress_resultant": ...}}`` for every
        element kind of the model, BEAM included.
    """

    load_factor: np.ndarray
    position: np.ndarray
    euler: np.ndarray
    deformation: np.ndarray
    stress_resultant: np.ndarray
    reaction: np.ndarray
    reaction_node: np.ndarray
    reaction_component: list
    iterations: np.ndarray
    residual: np.ndarray
    max_normal_stress: np.ndarray | None = None
    max_von_mises_stress: np.ndarray | None = None
    elements: dict = field(default_factory=dict)

    @property
    def n_step(self) -> int:
        return int(self.load_factor.size)


@dataclass
class TransientResults:
    """The ``/transient`` group as arrays (axis 0 = stored time step): ``time``, ``position``,
    ``euler``, ``velocity``, ``euler_rate``, the energies, ``iterations``, ``residual`` and
    ``elements`` (per kind, as in :class:`StaticResults`)."""

    time: np.ndarray
    arrays: dict
    elements: dict

    def __getattr__(self, name):
        try:
            return self.__dict__["arrays"][name]
        except KeyError:
            raise AttributeError(name) from None

    @property
    def n_step(self) -> int:
        return int(self.time.size)


@dataclass
class LinearizedResults:
    """An ``/eigen``, ``/buckling`` or ``/compliance`` group: one row per linearized step.

    ``step`` (n_lin,) gives the row of ``/static`` each linearization belongs to; the other
    arrays (see docs/results.md) are attributes, e.g. ``res.eigen.frequency`` (n_lin, n_mode)
    or ``res.buckling.critical_load_multiplier`` (n_lin,).
    """

    step: np.ndarray
    arrays: dict

    def __getattr__(self, name):
        try:
            return self.__dict__["arrays"][name]
        except KeyError:
            raise AttributeError(name) from None

    @property
    def n_mode(self) -> int:
        first = next(iter(self.arrays.values()))
        return int(first.shape[1]) if first.ndim > 1 else 0


@dataclass
class Results(RootAttributes):
    """Contents of a results file, as numpy arrays (2.0 names; a 1.x file is read through
    :data:`~spacarpy.results.schema.LEGACY_NAMES`).

    Attributes
    ----------
    path : str
    attrs : dict
        Root attributes as Python values (``schema_version`` a tuple, ``completed`` a bool).
    deck : str
    position_nodes : (n_pos,) int64
    position_x0 : (n_pos, 3) float64
    orientation_nodes : (n_rot,) int64
    elements : (n_elem,) int64
        Deck numbers of the BEAM elements.
    element_nodes : (n_elem, 4) int64
        Deck node numbers ``[p r q s]`` of the BEAM elements.
    element_type : list of str
        ``"BEAM"`` for each BEAM element.
    element_sets : dict
        ``{kind: {"ids": (n,), "nodes": (n, n_slots)}}`` for every element kind.
    static, transient, eigen, buckling, compliance
        The groups, or ``None`` when the file has none.
    """

    path: str
    attrs: dict
    deck: str
    position_nodes: np.ndarray
    position_x0: np.ndarray
    orientation_nodes: np.ndarray
    elements: np.ndarray
    element_nodes: np.ndarray
    element_type: list
    element_sets: dict = field(default_factory=dict)
    static: StaticResults | None = None
    transient: TransientResults | None = None
    eigen: LinearizedResults | None = None
    buckling: LinearizedResults | None = None
    compliance: LinearizedResults | None = None


def _step_arrays(sf, group: str, n: int) -> tuple[dict, dict]:
    """Committed rows of a step group's datasets: (node-based and scalar arrays, per-kind
    element arrays)."""
    arrays, elements = {}, {}
    for path, spec in DATASETS.items():
        if spec.group != group or path not in sf or not spec.shape \
                or path.endswith("/checksum") \
                or spec.shape[0] not in ("step", "time_step", "linearized_step"):
            continue
        data = sf[path][:n]
        name = path[len(group) + 1:]
        if spec.kind is not None:
            what = name.rsplit("/", 1)[-1]
            elements.setdefault(spec.kind, {})[what] = data
        else:
            arrays[name] = data
    return arrays, elements


def read_results(path) -> Results:
    """Read a results file (schema 1.x or 2.x) into numpy arrays.

    Only committed steps are returned. A partial file (``completed`` False) is read like any
    other; check :attr:`Results.completed`.

    Raises
    ------
    ResultsFormatError
        The file cannot be opened, is not a spacarpy results file, has a schema major version
        newer than ``SCHEMA_VERSION[0]``, or violates the schema.
    """
    path = os.fspath(path)
    with open_for_reading(path) as f:
        attrs = check_readable(f, path)
        sf = SchemaFile(f)
        kinds = sf.element_kinds()
        sets = {k: {"ids": sf[f"model/elements/{k}/ids"][()],
                    "nodes": sf[f"model/elements/{k}/nodes"][()]} for k in kinds}
        beam = sets.get("BEAM", {"ids": np.zeros(0, np.int64),
                                 "nodes": np.zeros((0, 4), np.int64)})
        results = Results(
            path=path, attrs=attrs, deck=f["deck"].asstr()[()],
            position_nodes=sf["model/position_nodes"][()],
            position_x0=sf["model/position_x0"][()],
            orientation_nodes=sf["model/orientation_nodes"][()], elements=beam["ids"],
            element_nodes=beam["nodes"], element_type=["BEAM"] * beam["ids"].size,
            element_sets=sets)
        if "static" in f:
            n = f["static/load_factor"].shape[0]
            arrays, elements = _step_arrays(sf, "static", n)
            b = elements.get("BEAM", {})
            results.static = StaticResults(
                reaction_node=sf["static/reaction_node"][()],
                reaction_component=str_list(sf["static/reaction_component"]),
                deformation=b.get("deformation"), stress_resultant=b.get("stress_resultant"),
                max_normal_stress=b.get("max_normal_stress"),
                max_von_mises_stress=b.get("max_von_mises_stress"), elements=elements,
                **arrays)
        if "transient" in f:
            n = f["transient/time"].shape[0]
            arrays, elements = _step_arrays(sf, "transient", n)
            results.transient = TransientResults(time=arrays.pop("time"), arrays=arrays,
                                                 elements=elements)
        for group in ("eigen", "buckling", "compliance"):
            if group in f:
                n = f[group]["step"].shape[0]
                arrays, _ = _step_arrays(sf, group, n)
                setattr(results, group, LinearizedResults(step=arrays.pop("step"),
                                                          arrays=arrays))
        problems = checksum_problems(f, committed_steps(f))
        if problems:
            raise damaged(path, "; ".join(problems[:5]))
    if not results.completed:
        log.warning("%s is an incomplete run: %s", path,
                    results.error or "the writer did not finish (killed, or still running)")
    return results

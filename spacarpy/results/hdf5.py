"""Write, read and validate spacarpy results files (HDF5, schema version 1.4), crash-safely.

This module's one job is the results file: :class:`ResultsWriter` streams an analysis into it
step by step, :func:`read_results` loads it back into numpy arrays, and :func:`validate_file`
checks a file against the schema. The schema itself (every path with dtype, shape, units and
meaning) is documented in ``docs/results.md``; :data:`SCHEMA_VERSION` and that document are
bumped together. Besides the solver's arrays the writer stores what makes the file
self-describing: the model's element properties, cross-sections, loads and coordinate map
(from :func:`spacarpy.numbering.number_model`, schema 1.1), and, for elements with a known
cross-section, the largest surface stresses of every step
(:func:`spacarpy.results.stress.surface_stress`).

Crash safety
------------
A run writes ``<stem>.partial.h5`` next to the requested output ``<stem>.h5`` and only moves it
into place (``os.replace``, atomic on POSIX) after the run has finished, so a good output file
is never replaced by a broken one.

- Every static step is written, then the file is flushed, then the step is *committed* by
  appending its load factor to ``/static/load_factor`` and flushing again. The length of
  ``/static/load_factor`` is the number of committed steps; rows of other step datasets beyond
  it belong to a step that was being written when the process died and are ignored.
- Step datasets are written in HDF5 single-writer/multiple-reader (SWMR) mode. SWMR orders the
  metadata flushes so that the file on disk never holds pointers to unwritten data; a process
  killed at any instant (even inside a write) therefore leaves a consistent file holding every
  committed step. Such a file keeps the "open for SWMR write" mark in its superblock:
  :func:`read_results` and :func:`validate_file` open it in SWMR-read mode; other HDF5 tools
  need ``h5clear -s file`` first (or an SWMR-read open).
- A Python exception (solver failure, Ctrl-C) inside the ``with`` block closes the file cleanly
  with ``completed = False`` and the error message; the partial file is kept.

Symbols: ``n_pos`` position nodes, ``n_rot`` orientation nodes, ``n_elem`` beam elements,
``n_coord`` global coordinates, ``n_load`` load lines, ``n_reac`` reaction components,
``n_step`` committed load steps.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import logging
import operator
import os
import re
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from spacarpy.elements.registry import KINDS
from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.model import ANALYSES, DEFORMATION_VARIANTS, ElementSet, Model

log = logging.getLogger(__name__)

__all__ = [
    "SCHEMA_VERSION",
    "FILETYPE",
    "ResultsFormatError",
    "ResultsWriter",
    "Results",
    "StaticResults",
    "LinearizedResults",
    "read_results",
    "validate_file",
    "partial_path_for",
]

#: (major, minor) version of the results-file schema written and read by this module.
#: MAJOR changes are incompatible; MINOR ones only add optional content.
SCHEMA_VERSION = (1, 4)
#: Value of the root attribute ``filetype``.
FILETYPE = "spacarpy-results"
#: Value of the root attribute ``program``.
PROGRAM = "spacarpy"
#: Reaction component names and their units.
REACTION_COMPONENTS = {"Fx": "N", "Fy": "N", "Fz": "N", "Mx": "N m", "My": "N m", "Mz": "N m"}
#: ``units`` attribute of ``/static/reaction`` (units depend on the component).
REACTION_UNITS = "N | N m (see reaction_component)"

# Lowest file-format version that supports SWMR; readable by every HDF5 >= 1.10. ("latest"
# would let a newer HDF5 use formats older readers, e.g. ParaView's, cannot read.)
_LIBVER = ("v110", "v110")
# Chunks of the step datasets hold whole steps: up to _MAX_CHUNK_ROWS steps, about _CHUNK_BYTES.
_CHUNK_BYTES = 16384
_MAX_CHUNK_ROWS = 64
_INTERRUPTED = "interrupted by user"
_NOT_FINISHED = "results writer closed without finish()"

#: ``(units, long_name)`` of every dataset in the schema, by path relative to the root.
DATASET_ATTRS = {
    "deck": ("1", "input deck text, verbatim"),
    "model/position_nodes": ("1", "deck number of each position node"),
    "model/position_x0": ("m", "initial position of each position node"),
    "model/orientation_nodes": ("1", "deck number of each orientation node"),
    "model/elements": ("1", "deck number of each element"),
    "model/element_nodes": ("1", "deck node numbers [p r q s] of each element"),
    "model/element_type": ("1", "element type keyword of each element"),
    # schema 1.1: element properties, cross-sections, loads and the coordinate map
    "model/element_position_rows": ("1", "rows of /model/position_nodes holding the element's "
                                         "nodes p and q (0-based; a line-cell connectivity)"),
    "model/element_length": ("m", "reference length l0 of each element"),
    "model/element_axes": ("1", "initial element axes: rows x (p to q), y, z as unit vectors "
                                "in global axes"),
    "model/element_deformation_class": ("1", "class of each deformation mode: 0 rigid, "
                                             "1 flexible (DYNE), 2 released (RLSE)"),
    "model/element_stiffness": ("N | N m2 | N m2 | N m2 | m2 | m2",
                                "ESTIFF: EA, GJ, EIy, EIz, cy = EIy/kGA, cz = EIz/kGA "
                                "(0 where not given)"),
    "model/element_mass": ("kg/m | kg m | kg m | kg m | kg m",
                           "EM per unit length: rhoA, rho(Iy+Iz), rhoIy, rhoIz, rhoIyz "
                           "(0 where not given)"),
    "model/cross_section_type": ("1", "cross-section shape of each element: RECT, CIRC, or "
                                      "empty when not known"),
    "model/cross_section_dims": ("m", "cross-section dimensions: RECT (w along y, t along z), "
                                      "CIRC (d, NaN); NaN when not known"),
    "model/load_node": ("1", "deck node number of each nodal load line"),
    "model/load_type": ("1", "XF (acting from the start) or DELXF (scaled by the load "
                             "factor)"),
    "model/load_value": ("N | N m", "force (position node, N) or moment (orientation node, "
                                    "N m) of each load line, global axes"),
    "model/coordinate_node": ("1", "deck node number owning each global coordinate"),
    "model/coordinate_index": ("1", "index of the coordinate in its node: 1..3 = x y z, "
                                    "1..4 = lambda0..lambda3"),
    "model/coordinate_fixed": ("1", "whether the coordinate is fixed (FIX)"),
    "static/max_normal_stress": ("Pa", "largest magnitude of the normal stress at the surface "
                                       "of each element (NaN: cross-section not known)"),
    "static/max_von_mises_stress": ("Pa", "largest von Mises stress at the surface of each "
                                          "element (NaN: cross-section not known)"),
    "static/load_factor": ("1", "load factor on DELXF (load = XF + load_factor * DELXF)"),
    "static/position": ("m", "position of each position node"),
    "static/euler": ("1", "Euler parameters (lambda0, lambda1, lambda2, lambda3) of each "
                          "orientation node"),
    "static/deformation": ("m", "generalized deformations of each element"),
    "static/stress_resultant": ("N", "generalized stress resultants (dual to the deformations) "
                                     "of each element"),
    "static/reaction": (REACTION_UNITS, "reaction force or moment of each reaction component"),
    "static/reaction_node": ("1", "deck node number of each reaction component"),
    "static/reaction_component": ("1", "name (Fx Fy Fz Mx My Mz) of each reaction component"),
    "static/iterations": ("1", "Newton iterations used in the load step"),
    "static/residual": ("1", "final relative residual of the load step"),
    # schema 1.2: elements of the other kinds (present when the model has them)
    **{f"model/{k.lower()}_elements": ("1", f"deck number of each {k} element")
       for k in ("TRUSS", "HINGE", "RBEAM", "PLBEAM", "PLTRUSS", "PLHINGE")},
    **{f"model/{k.lower()}_element_nodes": ("1", f"deck node numbers {slots} of each {k} "
                                                  "element")
       for k, slots in (("TRUSS", "[p q]"), ("HINGE", "[r s]"), ("RBEAM", "[p r q]"),
                        ("PLBEAM", "[p r q s]"), ("PLTRUSS", "[p q]"), ("PLHINGE", "[r s]"))},
    "model/input_deformation": ("1", "[element, mode] of each prescribed deformation "
                                     "(INPUTE), present when the model has them"),
    "static/truss_deformation": ("m", "elongation of each TRUSS element"),
    "static/truss_stress_resultant": ("N", "axial force of each TRUSS element"),
    "static/hinge_deformation": ("rad | 1", "HINGE deformations: 1 the joint angle (rad), "
                                            "2-3 the small relative rotations (1)"),
    "static/hinge_stress_resultant": ("N m", "HINGE stress resultants: the joint moment and "
                                             "the constraint moments"),
    "static/rbeam_deformation": ("m", "RBEAM deformations (position of q in the body of p)"),
    "static/rbeam_stress_resultant": ("N", "RBEAM constraint forces"),
    # schema 1.4: transient analysis
    "transient/time": ("s", "time of each stored time step (the step is committed when its "
                            "time is written)"),
    "transient/position": ("m", "position of each position node"),
    "transient/euler": ("1", "Euler parameters of each orientation node"),
    "transient/velocity": ("m/s", "velocity of each position node"),
    "transient/euler_rate": ("1/s", "time derivative of the Euler parameters (angular "
                                    "velocity in body axes: 2 G(q) dq/dt)"),
    "transient/deformation": ("m", "generalized deformations of each BEAM element"),
    "transient/stress_resultant": ("N", "generalized stress resultants of each BEAM element"),
    "transient/kinetic_energy": ("J", "kinetic energy T of the model"),
    "transient/elastic_energy": ("J", "elastic energy U of the flexible deformation modes"),
    "transient/external_work": ("J", "work W done on the model since t = 0 by the loads, "
                                     "gravity and the prescribed motions; T + U + D - W "
                                     "is constant for an exact integration"),
    "transient/dissipated_energy": ("J", "energy dissipated by the damping (DAMPING, EDAMP) "
                                         "since t = 0"),
    "transient/iterations": ("1", "Newton iterations of the last time step"),
    "transient/residual": ("1", "final relative residual of the last time step"),
    # schema 1.3: planar elements
    "static/plbeam_deformation": ("m", "PLBEAM deformations: 1 elongation, 2-3 bending in the "
                                       "x-y plane at p and q (l0 times a sine)"),
    "static/plbeam_stress_resultant": ("N", "PLBEAM stress resultants: normal force, bending "
                                            "moments divided by l0"),
    "static/pltruss_deformation": ("m", "elongation of each PLTRUSS element"),
    "static/pltruss_stress_resultant": ("N", "axial force of each PLTRUSS element"),
    "static/plhinge_deformation": ("rad", "PLHINGE joint angle"),
    "static/plhinge_stress_resultant": ("N m", "PLHINGE joint moment"),
    "eigen/step": ("1", "index of the static step (row of /static) that was linearized"),
    "eigen/frequency": ("Hz", "natural frequency; negative: unstable mode (divergence rate), "
                              "NaN: complex or infinite eigenvalue, 0: rigid-body mode"),
    "eigen/eigenvalue_real": ("s-2", "real part of the eigenvalue omega^2"),
    "eigen/eigenvalue_imag": ("s-2", "imaginary part of the eigenvalue omega^2"),
    "eigen/kind": ("1", "mode kind: 0 elastic, 1 rigid-body, 2 unstable, 3 complex, "
                        "4 infinite (see attribute kind_names)"),
    "eigen/shape_position": ("m kg-1/2", "mass-normalized mode shape: position perturbation "
                                         "of each position node"),
    "eigen/shape_euler": ("kg-1/2", "mass-normalized mode shape: Euler-parameter perturbation "
                                    "of each orientation node"),
    "buckling/step": ("1", "index of the static step (row of /static) that was linearized"),
    "compliance/step": ("1", "index of the static step (row of /static) that was linearized"),
    "compliance/global": ("m/N | rad/(N m) | m/(N m) = rad/N",
                          "6x6 compliance [dr; dphi] = C [dF; dT] of the chosen node, global "
                          "axes"),
    "compliance/local": ("m/N | rad/(N m) | m/(N m) = rad/N",
                         "6x6 compliance of the chosen node in its current body axes"),
    "buckling/load_multiplier": ("1", "buckling load multipliers of the load acting in the "
                                      "step, smallest magnitude first (NaN: none)"),
    "buckling/critical_load_multiplier": ("1", "smallest positive buckling load multiplier "
                                               "(inf: none)"),
    "buckling/shape_position": ("1", "buckling mode shape (largest component 1): position "
                                     "perturbation of each position node"),
    "buckling/shape_euler": ("1", "buckling mode shape (largest component 1): Euler-parameter "
                                  "perturbation of each orientation node"),
}

#: Linearized-analysis groups: dataset -> (dtype, trailing shape as a function of
#: (n_mode, n_pos, n_rot)). ``step`` is the commit dataset of the group (appended last).
_LIN_DATASETS = {
    "eigen": {
        "frequency": (np.float64, lambda m, p, r: (m,)),
        "eigenvalue_real": (np.float64, lambda m, p, r: (m,)),
        "eigenvalue_imag": (np.float64, lambda m, p, r: (m,)),
        "kind": (np.int8, lambda m, p, r: (m,)),
        "shape_position": (np.float64, lambda m, p, r: (m, p, 3)),
        "shape_euler": (np.float64, lambda m, p, r: (m, r, 4)),
    },
    "compliance": {
        "global": (np.float64, lambda m, p, r: (6, 6)),
        "local": (np.float64, lambda m, p, r: (6, 6)),
    },
    "buckling": {
        "load_multiplier": (np.float64, lambda m, p, r: (m,)),
        "critical_load_multiplier": (np.float64, lambda m, p, r: ()),
        "shape_position": (np.float64, lambda m, p, r: (m, p, 3)),
        "shape_euler": (np.float64, lambda m, p, r: (m, r, 4)),
    },
}
#: Element kinds besides BEAM with their own datasets (schema 1.2): keyword -> modes.
OTHER_KINDS = {k: kind.n_def for k, kind in KINDS.items() if k != "BEAM"}
# schema 1.4: the element datasets of /transient have the units of their /static twins
DATASET_ATTRS.update({
    f"transient/{k.lower()}_{w}": (DATASET_ATTRS[f"static/{k.lower()}_{w}"][0],
                                   f"{k} {w.replace('_', ' ')}s, as in /static")
    for k in OTHER_KINDS for w in ("deformation", "stress_resultant")})
#: Names of the ``/eigen/kind`` codes.
MODE_KIND_NAMES = ("elastic", "rigid-body", "unstable", "complex", "infinite")

#: Required root attributes (``error`` is optional: only present on a failed run).
ROOT_ATTRS = ("filetype", "schema_version", "program", "program_version", "created", "deck_path",
              "deck_sha256", "analysis", "deformations", "completed")

# Static step datasets (axis 0 = step): name -> (dtype, axis labels after "step").
_STEP_DATASETS = {
    "position": (np.float64, ("position_node", "coordinate")),
    "euler": (np.float64, ("orientation_node", "euler_parameter")),
    "deformation": (np.float64, ("element", "deformation_mode")),
    "stress_resultant": (np.float64, ("element", "deformation_mode")),
    "reaction": (np.float64, ("reaction",)),
    "iterations": (np.int32, ()),
    "residual": (np.float64, ()),
}
# Time step datasets of /transient (schema 1.4): name -> (dtype, labels of the trailing axes).
_TRANSIENT_DATASETS = {
    "position": (np.float64, ("position_node", "coordinate")),
    "euler": (np.float64, ("orientation_node", "euler_parameter")),
    "velocity": (np.float64, ("position_node", "coordinate")),
    "euler_rate": (np.float64, ("orientation_node", "euler_parameter")),
    "deformation": (np.float64, ("element", "deformation_mode")),
    "stress_resultant": (np.float64, ("element", "deformation_mode")),
    "kinetic_energy": (np.float64, ()),
    "elastic_energy": (np.float64, ()),
    "external_work": (np.float64, ()),
    "dissipated_energy": (np.float64, ()),
    "iterations": (np.int32, ()),
    "residual": (np.float64, ()),
}
# Optional static step datasets (schema 1.1): present when any element has a cross-section.
_STRESS_DATASETS = {
    "max_normal_stress": (np.float64, ("element",)),
    "max_von_mises_stress": (np.float64, ("element",)),
}
#: Names of the deformation classes in ``/model/element_deformation_class``.
DEFORMATION_CLASS_NAMES = ("rigid", "flexible", "released")
# /model datasets added by schema 1.1: name -> (kind, trailing shape after the entity axis,
# entity count: n_elem, n_coord or n_load).
_MODEL_11 = {
    "element_position_rows": ("int", (2,), "n_elem"),
    "element_length": ("float", (), "n_elem"),
    "element_axes": ("float", (3, 3), "n_elem"),
    "element_deformation_class": ("int", (6,), "n_elem"),
    "element_stiffness": ("float", (6,), "n_elem"),
    "element_mass": ("float", (5,), "n_elem"),
    "cross_section_type": ("ascii", (), "n_elem"),
    "cross_section_dims": ("float", (2,), "n_elem"),
    "load_node": ("int", (), "n_load"),
    "load_type": ("ascii", (), "n_load"),
    "load_value": ("float", (3,), "n_load"),
    "coordinate_node": ("int", (), "n_coord"),
    "coordinate_index": ("int", (), "n_coord"),
    "coordinate_fixed": ("bool", (), "n_coord"),
}


class ResultsFormatError(SpacarError):
    """A results file that is not a spacarpy results file this version can read."""

    exit_code = EXIT_INPUT


def partial_path_for(path) -> Path:
    """Return the partial file used while writing the results file ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        The final output file, e.g. ``run/cantilever.h5``.

    Returns
    -------
    pathlib.Path
        ``<directory>/<stem>.partial.h5``, e.g. ``run/cantilever.partial.h5``.
    """
    path = Path(path)
    return path.with_name(path.stem + ".partial.h5")


# --------------------------------------------------------------------------------------------
# writer
# --------------------------------------------------------------------------------------------

class ResultsWriter:
    """Stream the results of one analysis into a crash-safe HDF5 results file.

    Use it as a context manager; the file is opened on entering the ``with`` block and is
    closed on every way out of it::

        with ResultsWriter("out.h5", model, program_version=__version__,
                           deformations="modified", analysis="static") as w:
            w.begin_static(n_pos, n_rot, n_elem, reaction_node, reaction_component)
            for ...:                      # every converged load step
                w.static_step(...)
            w.finish()                    # completed = True, partial file -> out.h5

    Leaving the block through an exception without :meth:`finish` closes the file with
    ``completed = False`` and ``error`` set, keeps it at :attr:`partial_path` and leaves
    :attr:`final_path` untouched; the exception propagates. Leaving the block normally without
    :meth:`finish` is treated the same way (error "results writer closed without finish()").

    Parameters
    ----------
    path : str or os.PathLike
        Final output file. Written only by :meth:`finish`, atomically.
    model : spacarpy.model.Model
        The analysed model; its node and element numbers and its deck are stored.
    program_version : str
        spacarpy version, stored as root attribute ``program_version``.
    deformations : str
        ``"modified"`` or ``"basic"``.
    analysis : str
        One of :data:`spacarpy.model.ANALYSES`.

    Attributes
    ----------
    final_path : pathlib.Path
        Where the finished file ends up.
    partial_path : pathlib.Path
        Where the file is written until :meth:`finish` (and where an unfinished run stays).
    """

    def __init__(self, path, model: Model, *, program_version: str, deformations: str,
                 analysis: str):
        if deformations not in DEFORMATION_VARIANTS:
            raise ValueError(f"unknown deformation variant {deformations!r}; "
                             f"expected one of {DEFORMATION_VARIANTS}")
        if analysis not in ANALYSES:
            raise ValueError(f"unknown analysis {analysis!r}; expected one of {ANALYSES}")
        self.final_path = Path(path)
        self.partial_path = partial_path_for(self.final_path)
        self.model = model
        self.program_version = str(program_version)
        self.deformations = deformations
        self.analysis = analysis
        self._file: h5py.File | None = None
        self._swmr = False
        self._state = "new"        # new -> open -> (finishing -> finished | aborted)
        self._static: dict[str, h5py.Dataset] | None = None
        self._lin: dict[str, dict] = {}
        self._shapes: dict[str, tuple] = {}
        self._n_step = 0
        self._transient: dict[str, h5py.Dataset] | None = None
        self._tshapes: dict[str, tuple] = {}
        self._n_time = 0
        self._l0: np.ndarray | None = None           # element lengths, for surface stresses
        self._sections = None                        # SectionProperties, set by open()

    # -- context manager ----------------------------------------------------------------------

    def __enter__(self) -> "ResultsWriter":
        return self.open()

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is None:
            if self._state == "open":
                log.warning("%s: %s; keeping the partial file %s", self.final_path, _NOT_FINISHED,
                            self.partial_path)
                self.abort(_NOT_FINISHED)
        elif self._state in ("open", "finishing"):
            if issubclass(exc_type, KeyboardInterrupt):
                message = _INTERRUPTED
            else:
                message = str(exc) or exc_type.__name__
            self.abort(message)
        return False   # never swallow the exception

    # -- public API ---------------------------------------------------------------------------

    @property
    def n_step(self) -> int:
        """Number of static steps written and committed so far."""
        return self._n_step

    def open(self) -> "ResultsWriter":
        """Create the partial file and write the root attributes, ``/deck`` and ``/model``.

        Called by ``__enter__``; call it yourself only when not using ``with`` (and then call
        :meth:`finish` or :meth:`abort` in a ``finally``).

        Returns
        -------
        ResultsWriter
            ``self``.
        """
        if self._state != "new":
            raise RuntimeError("a ResultsWriter can be opened only once")
        if self.partial_path.exists():
            log.info("replacing the stale partial file %s", self.partial_path)
        self._file = h5py.File(self.partial_path, "w", libver=_LIBVER)
        try:
            self._write_header(self._file)
            self._file.flush()
        except BaseException:
            self._file.close()
            self._file = None
            self._state = "aborted"
            self.partial_path.unlink(missing_ok=True)
            raise
        self._state = "open"
        log.debug("writing results to %s", self.partial_path)
        return self

    def begin_static(self, n_position_node: int, n_orientation_node: int, n_elem: int,
                     reaction_node, reaction_component, *, n_eigen_modes: int = 0,
                     n_buckling_modes: int = 0, compliance_node=None,
                     transient: bool = False) -> None:
        """Create the ``/static`` group with empty, extendable step datasets.

        After this call the file is switched to SWMR mode: no new datasets or groups can be
        added, only steps appended.

        Parameters
        ----------
        n_position_node, n_orientation_node, n_elem : int
            ``n_pos``, ``n_rot``, ``n_elem``; must match the model.
        reaction_node : array_like of int, shape (n_reac,)
            Deck node number of each reaction component.
        reaction_component : sequence of str, length n_reac
            ``"Fx" "Fy" "Fz"`` (force on a position node, N) or ``"Mx" "My" "Mz"`` (moment on an
            orientation node, N m).
        n_eigen_modes, n_buckling_modes : int
            When positive, also create the ``/eigen`` or ``/buckling`` group for that many
            modes per linearized step (:meth:`eigen_step`, :meth:`buckling_step`).
        compliance_node : (int, int) or None
            Deck numbers (position node, orientation node) whose 6x6 compliance is stored
            per linearized step (:meth:`compliance_step`).
        transient : bool
            Also create the ``/transient`` group (schema 1.4) for :meth:`transient_step`.
        """
        f = self._require_open("begin_static")
        if self._static is not None:
            raise RuntimeError("begin_static was already called")
        counts = {"n_position_node": (n_position_node, self.model.position_ids.size),
                  "n_orientation_node": (n_orientation_node, self.model.orientation_ids.size),
                  "n_elem": (n_elem, _beams(self.model).n_elem)}
        for name, (given, expected) in counts.items():
            if operator.index(given) != expected:
                raise ValueError(f"{name} = {given} does not match the model ({expected})")
        reaction_node = np.asarray(reaction_node, dtype=np.int64).reshape(-1)
        reaction_component = [str(c) for c in reaction_component]
        if len(reaction_component) != reaction_node.size:
            raise ValueError(f"{reaction_node.size} reaction nodes but "
                             f"{len(reaction_component)} reaction components")
        unknown = sorted(set(reaction_component) - set(REACTION_COMPONENTS))
        if unknown:
            raise ValueError(f"unknown reaction components {unknown}; "
                             f"expected {list(REACTION_COMPONENTS)}")
        n_pos, n_rot, n_reac = int(n_position_node), int(n_orientation_node), reaction_node.size
        n_elem = int(n_elem)
        trailing = {"position": (n_pos, 3), "euler": (n_rot, 4), "deformation": (n_elem, 6),
                    "stress_resultant": (n_elem, 6), "reaction": (n_reac,), "iterations": (),
                    "residual": ()}

        g = f.create_group("static")
        load_factor = _create_extendable(g, "load_factor", (), np.float64)
        load_factor.make_scale("load_factor")
        load_factor.dims[0].label = "step"
        datasets = {}
        step_datasets = dict(_STEP_DATASETS)
        if self._sections is not None and self._sections.known.any():
            step_datasets.update(_STRESS_DATASETS)
            trailing.update({name: (n_elem,) for name in _STRESS_DATASETS})
        for kind, es in sorted(self.model.elements.items()):   # schema 1.2
            if es.n_elem and kind in OTHER_KINDS:
                for what in ("deformation", "stress_resultant"):
                    name = f"{kind.lower()}_{what}"
                    step_datasets[name] = (np.float64, ("element", "deformation_mode"))
                    trailing[name] = (es.n_elem, OTHER_KINDS[kind])
        for name, (dtype, labels) in step_datasets.items():
            ds = _create_extendable(g, name, trailing[name], dtype)
            ds.dims[0].attach_scale(load_factor)
            for axis, label in enumerate(("step",) + labels):
                ds.dims[axis].label = label
            datasets[name] = ds
        _create(g, "reaction_node", reaction_node)
        names = _ascii_array(reaction_component)
        _create(g, "reaction_component", names, dtype=h5py.string_dtype("ascii", names.itemsize))
        for group, n_mode in (("eigen", n_eigen_modes), ("buckling", n_buckling_modes),
                              ("compliance", 1 if compliance_node is not None else 0)):
            if n_mode > 0:
                self._lin[group] = self._create_linearized(f, group, int(n_mode), n_pos, n_rot)
        if compliance_node is not None:
            f["compliance"].attrs["position_node"] = np.int64(compliance_node[0])
            f["compliance"].attrs["orientation_node"] = np.int64(compliance_node[1])
        if transient:
            self._create_transient(f, n_pos, n_rot, n_elem)
        f.flush()
        # From here on only appends: SWMR keeps the file consistent on disk at every instant.
        f.swmr_mode = True
        self._swmr = True
        datasets["load_factor"] = load_factor
        self._static = datasets
        self._shapes = trailing

    def static_step(self, load_factor: float, position, euler, deformation, stress_resultant,
                    reaction, iterations: int, residual: float, group_deformation=None,
                    group_stress=None) -> None:
        """Append one converged static load step and make it durable.

        The step's arrays are appended and flushed first; the step is then committed by
        appending ``load_factor`` to ``/static/load_factor`` and flushing again. When the
        model has cross-sections, the largest surface stresses computed from
        ``stress_resultant`` are appended with the step.

        Parameters
        ----------
        load_factor : float
            Factor on DELXF (load = XF + load_factor * DELXF).
        position : array_like, shape (n_pos, 3)
            Node positions (m).
        euler : array_like, shape (n_rot, 4)
            Euler parameters of the orientation nodes (1).
        deformation : array_like, shape (n_elem, 6)
            Generalized deformations (m).
        stress_resultant : array_like, shape (n_elem, 6)
            Generalized stress resultants (N).
        reaction : array_like, shape (n_reac,)
            Reactions in the order of ``reaction_component`` (N or N m).
        iterations : int
            Newton iterations used.
        residual : float
            Final relative residual.
        """
        self._require_open("static_step")
        if self._static is None:
            raise RuntimeError("static_step called before begin_static")
        given = {"position": position, "euler": euler, "deformation": deformation,
                 "stress_resultant": stress_resultant, "reaction": reaction,
                 "iterations": operator.index(iterations), "residual": float(residual)}
        rows = {}
        for name, value in given.items():
            row = np.asarray(value, dtype=_STEP_DATASETS[name][0])
            if row.shape != self._shapes[name]:
                raise ValueError(f"static_step: {name} has shape {row.shape}, "
                                 f"expected {self._shapes[name]}")
            rows[name] = row
        if "max_normal_stress" in self._static:
            from spacarpy.results.stress import surface_stress
            rows["max_normal_stress"], rows["max_von_mises_stress"] = surface_stress(
                rows["stress_resultant"], self._l0, self._sections)
        for what, values in (("deformation", group_deformation), ("stress_resultant",
                                                                  group_stress)):
            for kind in OTHER_KINDS:
                name = f"{kind.lower()}_{what}"
                if name not in self._static:
                    continue
                if values is None or kind not in values:
                    raise ValueError(f"static_step: {name} is missing (the model has {kind} "
                                     "elements)")
                row = np.asarray(values[kind], dtype=np.float64)
                if row.shape != self._shapes[name]:
                    raise ValueError(f"static_step: {name} has shape {row.shape}, "
                                     f"expected {self._shapes[name]}")
                rows[name] = row
        k = self._n_step
        self._append(self._static, rows, "load_factor", float(load_factor), k)
        self._n_step = k + 1
        log.debug("static step %d written (load factor %g)", k, load_factor)

    def _append(self, datasets: dict, rows: dict, scale: str, value: float, k: int) -> None:
        """Append row k of every dataset and make it durable, then commit the step by
        appending its scale value (load factor, time) and flushing again: a reader never
        sees a scale entry whose rows are not on disk."""
        for name, row in rows.items():
            ds = datasets[name]
            ds.resize(k + 1, axis=0)
            ds[k] = row
        self._file.flush()
        ds = datasets[scale]
        ds.resize(k + 1, axis=0)
        ds[k] = value
        self._file.flush()

    def _create_transient(self, f, n_pos, n_rot, n_elem) -> None:
        g = f.create_group("transient")
        time_ds = _create_extendable(g, "time", (), np.float64)
        time_ds.make_scale("time")
        time_ds.dims[0].label = "time_step"
        trailing = {"position": (n_pos, 3), "euler": (n_rot, 4), "velocity": (n_pos, 3),
                    "euler_rate": (n_rot, 4), "deformation": (n_elem, 6),
                    "stress_resultant": (n_elem, 6), "kinetic_energy": (),
                    "elastic_energy": (), "external_work": (), "dissipated_energy": (),
                    "iterations": (),
                    "residual": ()}
        dtypes = dict(_TRANSIENT_DATASETS)
        for kind, es in sorted(self.model.elements.items()):
            if es.n_elem and kind in OTHER_KINDS:
                for what in ("deformation", "stress_resultant"):
                    name = f"{kind.lower()}_{what}"
                    dtypes[name] = (np.float64, ("element", "deformation_mode"))
                    trailing[name] = (es.n_elem, OTHER_KINDS[kind])
        datasets = {}
        for name, (dtype, labels) in dtypes.items():
            ds = _create_extendable(g, name, trailing[name], dtype)
            ds.dims[0].attach_scale(time_ds)
            for axis, label in enumerate(("time_step",) + labels):
                ds.dims[axis].label = label
            datasets[name] = ds
        datasets["time"] = time_ds
        self._transient = datasets
        self._tshapes = trailing

    def transient_step(self, time: float, position, euler, velocity, euler_rate, deformation,
                       stress_resultant, kinetic_energy: float, elastic_energy: float,
                       external_work: float, iterations: int, residual: float,
                       group_deformation=None, group_stress=None,
                       dissipated_energy: float = 0.0) -> None:
        """Append one time step (arrays as in :meth:`static_step`, plus the velocities
        and the energies) and make it durable: the arrays first, then ``/transient/time``
        commits the step."""
        self._require_open("transient_step")
        if self._transient is None:
            raise RuntimeError("transient_step called without begin_static(transient=True)")
        given = {"position": position, "euler": euler, "velocity": velocity,
                 "euler_rate": euler_rate, "deformation": deformation,
                 "stress_resultant": stress_resultant, "kinetic_energy": kinetic_energy,
                 "elastic_energy": elastic_energy, "external_work": external_work,
                 "dissipated_energy": float(dissipated_energy),
                 "iterations": operator.index(iterations), "residual": float(residual)}
        for what, values in (("deformation", group_deformation), ("stress_resultant",
                                                                  group_stress)):
            for kind in OTHER_KINDS:
                name = f"{kind.lower()}_{what}"
                if name in self._transient:
                    given[name] = (values or {}).get(kind)
        rows = {}
        for name, value in given.items():
            if value is None:
                raise ValueError(f"transient_step: {name} is missing")
            row = np.asarray(value, dtype=self._transient[name].dtype)
            if row.shape != self._tshapes[name]:
                raise ValueError(f"transient_step: {name} has shape {row.shape}, "
                                 f"expected {self._tshapes[name]}")
            rows[name] = row
        self._append(self._transient, rows, "time", float(time), self._n_time)
        self._n_time += 1

    def eigen_step(self, step: int, eigenvalue, frequency, kind, shape_position,
                   shape_euler) -> None:
        """Append the modes of one linearized static step (``step`` = its row in /static).

        Arrays may hold fewer modes than the group was created for; missing ones are NaN
        (kind 4). ``eigenvalue`` is complex (omega^2), ``shape_*`` (n_mode, n_pos, 3) and
        (n_mode, n_rot, 4).
        """
        lam = np.asarray(eigenvalue, dtype=complex)
        self._append_linearized("eigen", step, {
            "frequency": frequency, "eigenvalue_real": lam.real, "eigenvalue_imag": lam.imag,
            "kind": kind, "shape_position": shape_position, "shape_euler": shape_euler})

    def buckling_step(self, step: int, load_multiplier, critical: float, shape_position,
                      shape_euler) -> None:
        """Append the buckling multipliers and shapes of one linearized static step."""
        self._append_linearized("buckling", step, {
            "load_multiplier": load_multiplier, "critical_load_multiplier": critical,
            "shape_position": shape_position, "shape_euler": shape_euler})

    def compliance_step(self, step: int, global_, local) -> None:
        """Append the 6x6 nodal compliance (global and body axes) of one linearized step."""
        self._append_linearized("compliance", step, {"global": global_, "local": local})

    def _create_linearized(self, f, group, n_mode, n_pos, n_rot) -> dict:
        g = f.create_group(group)
        g.attrs["n_mode"] = np.int32(n_mode)
        step = _create_extendable(g, "step", (), np.int32)
        step.dims[0].label = "linearized_step"
        out = {"step": step, "_shape": {}}
        for name, (dtype, shape_of) in _LIN_DATASETS[group].items():
            trailing = shape_of(n_mode, n_pos, n_rot)
            ds = _create_extendable(g, name, trailing, dtype)
            ds.dims[0].label = "linearized_step"
            if name == "kind":
                ds.attrs["kind_names"] = ", ".join(MODE_KIND_NAMES)
            out[name] = ds
            out["_shape"][name] = trailing
        return out

    def _append_linearized(self, group, step, values) -> None:
        self._require_open(f"{group}_step")
        if group not in self._lin:
            raise RuntimeError(f"{group}_step: begin_static was called without "
                               f"n_{group}_modes")
        ds = self._lin[group]
        k = ds["step"].shape[0]
        for name, value in values.items():
            trailing = ds["_shape"][name]
            dtype = _LIN_DATASETS[group][name][0]
            fill = 4 if name == "kind" else np.nan
            row = np.full(trailing, fill, dtype=dtype)
            given = np.asarray(value, dtype=dtype)
            if given.ndim:
                row[tuple(slice(0, min(a, b)) for a, b in zip(given.shape, trailing))] = \
                    given[tuple(slice(0, b) for b in trailing)]
            else:
                row[...] = given
            ds[name].resize(k + 1, axis=0)
            ds[name][k] = row
        self._file.flush()
        ds["step"].resize(k + 1, axis=0)               # commit
        ds["step"][k] = int(step)
        self._file.flush()

    def finish(self) -> None:
        """Mark the run complete, close the file and move it atomically to :attr:`final_path`.

        An existing file at :attr:`final_path` is replaced only here, by a complete file.
        """
        self._require_open("finish")
        self._state = "finishing"
        self._mark(completed=True, error=None)
        _fsync(self.partial_path)
        os.replace(self.partial_path, self.final_path)
        _fsync(self.final_path.parent)
        self._state = "finished"
        what = f"{self._n_step} static steps"
        if self._transient is not None:
            what += f", {self._n_time} time steps"
        log.info("results written to %s (%s)", self.final_path, what)

    def abort(self, error: str) -> None:
        """Close the file as an unfinished run: ``completed = False``, ``error = error``.

        The partial file is kept at :attr:`partial_path`; :attr:`final_path` is not touched.
        Never raises (a failure to mark the file is logged), so that it cannot hide the error
        that caused the abort. Does nothing if the writer is already finished or aborted.

        Parameters
        ----------
        error : str
            Why the run did not finish.
        """
        if self._state in ("finished", "aborted"):
            return
        if self._state == "new":
            self._state = "aborted"
            return
        try:
            if self._file is None:   # finish() failed after closing the file
                self._swmr = False
                self._file = h5py.File(self.partial_path, "r+", libver=_LIBVER)
            self._mark(completed=False, error=error)
        except Exception:
            log.exception("could not mark %s as incomplete", self.partial_path)
        finally:
            self._close()
            self._state = "aborted"
        log.warning("run not completed (%s); %d static steps kept in %s", error, self._n_step,
                    self.partial_path)

    # -- internals ----------------------------------------------------------------------------

    def _require_open(self, what: str) -> h5py.File:
        if self._state != "open":
            raise RuntimeError(f"{what}: the results writer is {self._state}, not open "
                               "(use it as a context manager)")
        return self._file

    def _close(self) -> None:
        if self._file is not None:
            try:
                self._file.close()
            finally:
                self._file = None

    def _mark(self, completed: bool, error: str | None) -> None:
        """Set ``completed``/``error`` and close the file (leaving SWMR mode first)."""
        try:
            if self._swmr:
                # Attributes must not be modified in SWMR mode: close, reopen normally.
                self._close()
                self._swmr = False
                self._file = h5py.File(self.partial_path, "r+", libver=_LIBVER)
            attrs = self._file.attrs
            attrs["completed"] = np.bool_(completed)
            if error is not None:
                attrs["error"] = str(error)
            elif "error" in attrs:
                del attrs["error"]
        finally:
            self._close()

    def _write_header(self, f: h5py.File) -> None:
        model = self.model
        text = model.source_text or ""
        a = f.attrs
        a["completed"] = np.bool_(False)    # first, so that any partial file says "incomplete"
        a["filetype"] = FILETYPE
        a["schema_version"] = np.array(SCHEMA_VERSION, dtype=np.int32)
        a["program"] = PROGRAM
        a["program_version"] = self.program_version
        a["created"] = _dt.datetime.now().astimezone().isoformat(timespec="seconds")
        a["deck_path"] = _absolute_deck_path(model.source_path)
        a["deck_sha256"] = hashlib.sha256(text.encode("utf-8")).hexdigest()
        a["deck_text"] = text    # also here, so the run is identified from the root alone
        a["analysis"] = self.analysis
        a["deformations"] = self.deformations
        _create(f, "deck", text, dtype=h5py.string_dtype("utf-8"))
        g = f.create_group("model")
        beams = _beams(model)
        _create(g, "position_nodes", np.asarray(model.position_ids, dtype=np.int64))
        _create(g, "position_x0", np.asarray(model.position_x0, dtype=np.float64).reshape(-1, 3))
        _create(g, "orientation_nodes", np.asarray(model.orientation_ids, dtype=np.int64))
        _create(g, "elements", np.asarray(beams.ids, dtype=np.int64))
        _create(g, "element_nodes", np.asarray(beams.nodes, dtype=np.int64).reshape(-1, 4))
        _create(g, "element_type", np.full(beams.n_elem, b"BEAM", dtype="S4"),
                dtype=h5py.string_dtype("ascii", 4))
        self._write_model_11(g)
        for kind, es in sorted(model.elements.items()):     # schema 1.2
            if es.n_elem and kind in OTHER_KINDS:
                _create(g, f"{kind.lower()}_elements", np.asarray(es.ids, dtype=np.int64))
                _create(g, f"{kind.lower()}_element_nodes", np.asarray(es.nodes, dtype=np.int64))
        if model.prescribed_deformations:
            _create(g, "input_deformation", np.array(
                [[pd.element, pd.mode] for pd in model.prescribed_deformations], dtype=np.int64))

    def _write_model_11(self, g: h5py.Group) -> None:
        """Write the schema-1.1 part of ``/model``: element properties, cross-sections, loads
        and the map of global coordinates (see docs/results.md)."""
        from spacarpy.numbering import number_model
        from spacarpy.results.stress import section_properties

        model, beams = self.model, _beams(self.model)
        num = number_model(model)
        group = num.group("BEAM")
        idx = group.idx if group is not None else np.zeros((0, 14), np.int64)
        ref = (group.ref if group is not None
               else {k: np.zeros((0, 3)) for k in ("nx", "ny", "nz")})
        l0 = ref["l0"] if group is not None else np.zeros(0)
        row_of = np.full(num.n_coord, -1, dtype=np.int64)
        row_of[num.pos_idx[:, 0]] = np.arange(num.pos_idx.shape[0])
        _create(g, "element_position_rows",
                row_of[idx[:, [0, 7]]].reshape(beams.n_elem, 2))
        _create(g, "element_length", np.asarray(l0, dtype=np.float64))
        _create(g, "element_axes", np.stack([ref["nx"], ref["ny"], ref["nz"]], axis=1)
                .reshape(beams.n_elem, 3, 3))
        ds = _create(g, "element_deformation_class", beams.def_class.astype(np.int8))
        ds.attrs["class_names"] = ", ".join(DEFORMATION_CLASS_NAMES)
        ds = _create(g, "element_stiffness", beams.stiffness.astype(np.float64))
        ds.attrs["columns"] = "EA GJ EIy EIz cy cz"
        ds = _create(g, "element_mass", beams.mass.astype(np.float64))
        ds.attrs["columns"] = "rhoA rho(Iy+Iz) rhoIy rhoIz rhoIyz"
        if model.cross_sections is not None:
            shape, dims = model.cross_sections.arrays(beams.ids)
        else:
            shape, dims = np.full(beams.n_elem, "", dtype="<U4"), np.full((beams.n_elem, 2),
                                                                          np.nan)
        _create(g, "cross_section_type", np.char.encode(shape, "ascii").astype("S4"),
                dtype=h5py.string_dtype("ascii", 4))
        _create(g, "cross_section_dims", dims.astype(np.float64))
        loads = list(model.loads)
        _create(g, "load_node", np.array([ld.node for ld in loads], dtype=np.int64))
        _create(g, "load_type", np.array([ld.kind.encode("ascii") for ld in loads], dtype="S5"),
                dtype=h5py.string_dtype("ascii", 5))
        _create(g, "load_value", np.array([ld.value for ld in loads], dtype=np.float64)
                .reshape(len(loads), 3))
        index = np.zeros(num.n_coord, dtype=np.int8)
        index[num.pos_idx] = np.arange(1, 4, dtype=np.int8)
        index[num.rot_idx] = np.arange(1, 5, dtype=np.int8)
        _create(g, "coordinate_node", num.node_of_coord(model))
        _create(g, "coordinate_index", index)
        _create(g, "coordinate_fixed", num.fixed_mask.astype(bool))
        self._l0 = np.asarray(l0, dtype=np.float64)
        self._sections = section_properties(shape, dims)


def _beams(model) -> ElementSet:
    """The model's BEAM elements (an empty set when it has none)."""
    return model.elements.get("BEAM") or ElementSet.empty("BEAM")


def _absolute_deck_path(source_path: str) -> str:
    """Absolute deck path; pseudo names such as ``<model>`` or ``<string>`` are kept."""
    source_path = str(source_path)
    if source_path.startswith("<"):
        return source_path
    return os.path.abspath(source_path)


def _ascii_array(strings) -> np.ndarray:
    """Fixed-length ASCII array (at least 1 character wide) of ``strings``."""
    encoded = [s.encode("ascii") for s in strings]
    width = max([len(s) for s in encoded] + [1])
    return np.array(encoded, dtype=f"S{width}").reshape(len(encoded))


def _create(group: h5py.Group, name: str, data, dtype=None) -> h5py.Dataset:
    """Create a fixed-size dataset with its ``units`` and ``long_name`` from DATASET_ATTRS."""
    ds = group.create_dataset(name, data=data, dtype=dtype)
    _set_cf_attrs(ds)
    return ds


def _create_extendable(group: h5py.Group, name: str, trailing: tuple, dtype) -> h5py.Dataset:
    """Create an empty step dataset ``(0, *trailing)`` that grows along axis 0."""
    itemsize = np.dtype(dtype).itemsize
    row_bytes = max(int(np.prod(trailing, dtype=np.int64)) * itemsize, 1)
    rows = max(1, min(_MAX_CHUNK_ROWS, _CHUNK_BYTES // row_bytes))
    # A zero-length axis cannot be chunked with a positive chunk size unless it is unlimited.
    maxshape = (None,) + tuple(n if n > 0 else None for n in trailing)
    chunks = (rows,) + tuple(max(n, 1) for n in trailing)
    ds = group.create_dataset(name, shape=(0,) + tuple(trailing), maxshape=maxshape,
                              chunks=chunks, dtype=dtype)
    _set_cf_attrs(ds)
    return ds


def _set_cf_attrs(ds: h5py.Dataset) -> None:
    units, long_name = DATASET_ATTRS[ds.name.lstrip("/")]
    ds.attrs["units"] = units
    ds.attrs["long_name"] = long_name


def _fsync(path: Path) -> None:
    """Flush a file (or directory) to stable storage; best effort for directories."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        if path.is_dir():
            return
        raise
    try:
        os.fsync(fd)
    except OSError:
        if not path.is_dir():
            raise
    finally:
        os.close(fd)


# --------------------------------------------------------------------------------------------
# reader
# --------------------------------------------------------------------------------------------

@dataclass
class StaticResults:
    """The ``/static`` group: one row per committed load step (axis 0 = step).

    Attributes
    ----------
    load_factor : (n_step,) float64
        Factor on DELXF (1).
    position : (n_step, n_pos, 3) float64
        Node positions (m).
    euler : (n_step, n_rot, 4) float64
        Euler parameters (1).
    deformation : (n_step, n_elem, 6) float64
        Generalized deformations (m).
    stress_resultant : (n_step, n_elem, 6) float64
        Generalized stress resultants (N).
    reaction : (n_step, n_reac) float64
        Reactions (N for F*, N m for M* components).
    reaction_node : (n_reac,) int64
        Deck node number of each reaction component.
    reaction_component : list of str, length n_reac
        ``"Fx"`` ... ``"Mz"``.
    iterations : (n_step,) int32
        Newton iterations per step.
    residual : (n_step,) float64
        Final relative residual per step.
    max_normal_stress, max_von_mises_stress : (n_step, n_elem) float64 or None
        Largest surface stresses (Pa); ``None`` when no cross-section is known.
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

    @property
    def n_step(self) -> int:
        return int(self.load_factor.size)


@dataclass
class LinearizedResults:
    """An ``/eigen`` or ``/buckling`` group: one row per linearized static step.

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


class RootAttributes:
    """Properties over the root attributes ``attrs`` (a dict of Python values), shared by the
    eager :class:`Results` and the lazy :class:`spacarpy.results.reader.ResultsFile`."""

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


@dataclass
class Results(RootAttributes):
    """Contents of a results file, as numpy arrays.

    Attributes
    ----------
    path : str
        The file read.
    attrs : dict
        Root attributes as Python values (``schema_version`` a tuple, ``completed`` a bool).
    deck : str
        The deck text, verbatim.
    position_nodes : (n_pos,) int64
    position_x0 : (n_pos, 3) float64
        Initial positions (m).
    orientation_nodes : (n_rot,) int64
    elements : (n_elem,) int64
    element_nodes : (n_elem, 4) int64
        Deck node numbers ``[p r q s]``.
    element_type : list of str, length n_elem
    static : StaticResults or None
        ``None`` when the file has no ``/static`` group.
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
    static: StaticResults | None = None
    eigen: LinearizedResults | None = None
    buckling: LinearizedResults | None = None
    compliance: LinearizedResults | None = None



@contextmanager
def _open_for_reading(path):
    """Open a results file read-only; fall back to SWMR-read for a file left open for writing.

    A writer killed in SWMR mode (or one still running) leaves the "open for SWMR write" mark
    in the superblock, which a plain open refuses but an SWMR-read open accepts.
    """
    try:
        f = h5py.File(path, "r")
    except FileNotFoundError as exc:
        raise ResultsFormatError(f"{path}: no such file") from exc
    except OSError as exc:
        try:
            f = h5py.File(path, "r", swmr=True)
        except OSError:
            raise ResultsFormatError(f"{path}: cannot open as HDF5 ({exc})") from exc
        log.debug("%s is marked as open for SWMR writing (writer killed or still running); "
                  "opened in SWMR-read mode", path)
    try:
        yield f
    finally:
        f.close()


def read_results(path) -> Results:
    """Read a results file into numpy arrays.

    Only committed steps are returned (``len(/static/load_factor)`` rows). A partial file
    (``completed`` False) is read like any other; check :attr:`Results.completed`.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    Results

    Raises
    ------
    ResultsFormatError
        The file cannot be opened, is not a spacarpy results file, has a schema major version
        newer than ``SCHEMA_VERSION[0]``, or violates the schema.
    """
    path = os.fspath(path)
    with _open_for_reading(path) as f:
        attrs = check_readable(f, path)
        m = f["model"]
        results = Results(
            path=path, attrs=attrs, deck=f["deck"].asstr()[()],
            position_nodes=m["position_nodes"][()], position_x0=m["position_x0"][()],
            orientation_nodes=m["orientation_nodes"][()], elements=m["elements"][()],
            element_nodes=m["element_nodes"][()], element_type=_str_list(m["element_type"]))
        if "static" in f:
            g = f["static"]
            n = g["load_factor"].shape[0]
            step = {name: g[name][:n] for name in _STEP_DATASETS}
            step.update({name: g[name][:n] for name in _STRESS_DATASETS if name in g})
            results.static = StaticResults(
                load_factor=g["load_factor"][()], reaction_node=g["reaction_node"][()],
                reaction_component=_str_list(g["reaction_component"]), **step)
        for group in _LIN_DATASETS:
            if group in f:
                g = f[group]
                n = g["step"].shape[0]
                setattr(results, group, LinearizedResults(
                    step=g["step"][()],
                    arrays={name: g[name][:n] for name in _LIN_DATASETS[group]}))
    if not results.completed:
        log.warning("%s is an incomplete run: %s", path,
                    results.error or "the writer did not finish (killed, or still running)")
    return results


def check_readable(f: h5py.File, path) -> dict:
    """Refuse a file this version cannot read; return its root attributes as Python values.

    Shared by :func:`read_results` and :func:`spacarpy.results.reader.open_results`.

    Parameters
    ----------
    f : h5py.File
        Opened with :func:`open_for_reading`.
    path : str
        For the messages.

    Returns
    -------
    dict
        Root attributes; ``schema_version`` as a tuple of two ints.

    Raises
    ------
    ResultsFormatError
        Not a spacarpy results file, a newer major schema version, or schema violations.
    """
    identity = _identity_problems(f)
    if identity:
        raise ResultsFormatError(f"{path}: {identity[0]}")
    problems = _layout_problems(f)
    if problems:
        raise ResultsFormatError(f"{path}: not a valid spacarpy results file:\n  "
                                 + "\n  ".join(problems))
    attrs = {k: _python_value(v) for k, v in f.attrs.items()}
    attrs["schema_version"] = tuple(int(x) for x in attrs["schema_version"])
    if attrs["schema_version"][1] > SCHEMA_VERSION[1]:
        log.info("%s has schema version %d.%d (newer minor version than %d.%d); content "
                 "this version does not know is ignored", path, *attrs["schema_version"],
                 *SCHEMA_VERSION)
    return attrs


#: Open a results file read-only (SWMR-read for a file whose writer was killed or still runs).
open_for_reading = _open_for_reading


# --------------------------------------------------------------------------------------------
# validator
# --------------------------------------------------------------------------------------------

def validate_file(path, *, require_complete: bool = False) -> list[str]:
    """Check a results file against the schema.

    An incomplete run (``completed`` False: the solver failed, the user interrupted, or the
    process was killed) is *not* a problem by itself: a partial file that passes is consistent
    and every committed step in it is readable. Pass ``require_complete=True`` to report it.

    Parameters
    ----------
    path : str or os.PathLike
    require_complete : bool
        Also report a run that did not complete.

    Returns
    -------
    list of str
        One message per problem; empty when the file is valid.
    """
    path = os.fspath(path)
    try:
        with _open_for_reading(path) as f:
            problems = _identity_problems(f)
            if problems:
                return problems
            try:
                problems = _layout_problems(f)
            except (OSError, RuntimeError, ValueError, KeyError, TypeError) as exc:
                return [f"cannot read the file: {exc}"]
            if require_complete and not _python_value(f.attrs.get("completed", False)):
                error = _python_value(f.attrs.get("error"))
                problems.append("run incomplete: " + (
                    error if error else "the writer did not finish (killed, or still running)"))
            return problems
    except ResultsFormatError as exc:
        return [str(exc)]


def _identity_problems(f: h5py.File) -> list[str]:
    """File type and schema-version check; a non-empty result stops any further check."""
    filetype = _python_value(f.attrs.get("filetype"))
    if filetype != FILETYPE:
        return [f"root attribute filetype is {filetype!r}, expected {FILETYPE!r}: "
                "not a spacarpy results file"]
    version = f.attrs.get("schema_version")
    try:
        major, minor = (int(x) for x in np.asarray(version).reshape(-1))
    except (TypeError, ValueError):
        return [f"root attribute schema_version is {version!r}, expected two integers"]
    if major > SCHEMA_VERSION[0]:
        return [f"schema version {major}.{minor} is newer than schema version "
                f"{SCHEMA_VERSION[0]}.{SCHEMA_VERSION[1]} read by this spacarpy (major {major} > "
                f"{SCHEMA_VERSION[0]}); use a newer spacarpy"]
    if major < 1:
        return [f"schema version {major}.{minor} is not supported (this spacarpy reads "
                f"{SCHEMA_VERSION[0]}.x)"]
    return []


def _layout_problems(f: h5py.File) -> list[str]:
    """All schema violations of an opened file whose identity has been checked."""
    problems: list[str] = []
    completed = _check_root_attrs(f, problems)
    deck = _dataset(f, "deck", problems, kind="str", shape=())
    if deck is not None:
        sha = _python_value(f.attrs.get("deck_sha256"))
        actual = hashlib.sha256(deck.asstr()[()].encode("utf-8")).hexdigest()
        if isinstance(sha, str) and sha != actual:
            problems.append("root attribute deck_sha256 does not match /deck")
    counts = _check_model(f, problems)
    if "static" in f:
        _check_static(f, counts, completed, problems)
    elif completed and _python_value(f.attrs.get("analysis")) == "static":
        problems.append("completed static analysis without a /static group")
    for group in _LIN_DATASETS:
        if group in f:
            _check_linearized(f, group, counts, completed, problems)
        elif completed and _python_value(f.attrs.get("analysis")) == group:
            problems.append(f"completed {group} analysis without a /{group} group")
    if "transient" in f:
        _check_transient(f, counts, completed, problems)
    elif completed and _python_value(f.attrs.get("analysis")) == "transient":
        problems.append("completed transient analysis without a /transient group")
    _check_cf_attrs(f, problems)
    return problems


def _check_transient(f: h5py.File, counts: dict, completed: bool, problems: list[str]) -> None:
    """Check ``/transient`` (schema 1.4): datasets, shapes, step counts, the time scale."""
    ts = _dataset(f, "transient/time", problems, kind="float", shape=(None,))
    if ts is None:
        return
    if not h5py.h5ds.is_scale(ts.id):
        problems.append("/transient/time is not a dimension scale")
    trailing = {"position": (counts["n_pos"], 3), "euler": (counts["n_rot"], 4),
                "velocity": (counts["n_pos"], 3), "euler_rate": (counts["n_rot"], 4),
                "deformation": (counts["n_elem"], 6), "stress_resultant": (counts["n_elem"], 6)}
    n_t = ts.shape[0]
    for name, (dtype, _) in _TRANSIENT_DATASETS.items():
        kind = "int" if np.issubdtype(dtype, np.integer) else "float"
        ds = _dataset(f, f"transient/{name}", problems, kind=kind,
                      shape=(None,) + trailing.get(name, ()))
        if ds is None:
            continue
        m = ds.shape[0]
        if m != n_t and (completed or m < n_t):
            problems.append(f"/transient/{name} has {m} steps but /transient/time has {n_t}")
        if not h5py.h5ds.is_attached(ds.id, ts.id, 0):
            problems.append(f"/transient/time is not attached to axis 0 of /transient/{name}")


def _check_root_attrs(f: h5py.File, problems: list[str]) -> bool:
    """Check the required root attributes; return ``completed`` (False if missing/bad)."""
    a = {k: _python_value(v) for k, v in f.attrs.items()}
    for name in ROOT_ATTRS:
        if name not in a:
            problems.append(f"root attribute {name} missing")
    for name in ("program", "program_version", "created", "deck_path", "deck_sha256",
                 "analysis", "deformations"):
        if name in a and not isinstance(a[name], str):
            problems.append(f"root attribute {name} must be a string, not {a[name]!r}")
    if a.get("program", PROGRAM) != PROGRAM:
        problems.append(f"root attribute program is {a['program']!r}, expected {PROGRAM!r}")
    if isinstance(a.get("created"), str):
        try:
            if _dt.datetime.fromisoformat(a["created"]).tzinfo is None:
                problems.append("root attribute created has no time zone")
        except ValueError:
            problems.append(f"root attribute created is not ISO 8601: {a['created']!r}")
    if isinstance(a.get("deck_sha256"), str) and not re.fullmatch(r"[0-9a-f]{64}",
                                                                   a["deck_sha256"]):
        problems.append("root attribute deck_sha256 is not 64 lowercase hex digits")
    if isinstance(a.get("analysis"), str) and a["analysis"] not in ANALYSES:
        problems.append(f"root attribute analysis is {a['analysis']!r}, expected one of "
                        f"{ANALYSES}")
    if isinstance(a.get("deformations"), str) and a["deformations"] not in DEFORMATION_VARIANTS:
        problems.append(f"root attribute deformations is {a['deformations']!r}, expected one "
                        f"of {DEFORMATION_VARIANTS}")
    completed = a.get("completed")
    if "completed" in a and not isinstance(completed, bool):
        problems.append(f"root attribute completed must be a boolean, not {completed!r}")
        completed = False
    if "error" in a:
        if not isinstance(a["error"], str):
            problems.append("root attribute error must be a string")
        if completed:
            problems.append("root attribute error is set on a completed run")
    return bool(completed)


def _check_model(f: h5py.File, problems: list[str]) -> dict:
    """Check ``/model``; return the counts n_pos, n_rot, n_elem (None where unknown)."""
    ds = {name: _dataset(f, f"model/{name}", problems, kind=kind, shape=shape)
          for name, kind, shape in (
              ("position_nodes", "int", (None,)), ("position_x0", "float", (None, 3)),
              ("orientation_nodes", "int", (None,)), ("elements", "int", (None,)),
              ("element_nodes", "int", (None, 4)), ("element_type", "ascii", (None,)))}
    counts = {key: (ds[name].shape[0] if ds[name] is not None else None)
              for key, name in (("n_pos", "position_nodes"), ("n_rot", "orientation_nodes"),
                                ("n_elem", "elements"))}
    for name, count in (("position_x0", "n_pos"), ("element_nodes", "n_elem"),
                        ("element_type", "n_elem")):
        if ds[name] is not None and counts[count] is not None \
                and ds[name].shape[0] != counts[count]:
            problems.append(f"/model/{name} has {ds[name].shape[0]} rows, expected "
                            f"{counts[count]} ({count})")
    for name in ("position_nodes", "orientation_nodes", "elements"):
        if ds[name] is not None:
            ids = ds[name][()]
            if np.unique(ids).size != ids.size:
                problems.append(f"/model/{name} has duplicate numbers")
    if all(ds[n] is not None for n in ("position_nodes", "orientation_nodes", "element_nodes")) \
            and ds["element_nodes"].shape[1:] == (4,):
        nodes = ds["element_nodes"][()]
        for cols, ids, kind in (((0, 2), "position_nodes", "position"),
                                ((1, 3), "orientation_nodes", "orientation")):
            unknown = np.setdiff1d(nodes[:, cols], ds[ids][()])
            if unknown.size:
                problems.append(f"/model/element_nodes refers to unknown {kind} nodes "
                                f"{unknown.tolist()}")
    _check_model_11(f, ds, counts, problems)
    return counts


def _check_model_11(f: h5py.File, ds: dict, counts: dict, problems: list[str]) -> None:
    """Check the schema-1.1 part of ``/model``: required from minor version 1 on, checked
    whenever present; sets ``counts["sections"]`` (any cross-section known)."""
    version = np.asarray(f.attrs.get("schema_version", [1, 0])).reshape(-1)
    required = version.size == 2 and int(version[1]) >= 1
    counts["sections"] = False
    n_coord_expected = (3 * counts["n_pos"] + 4 * counts["n_rot"]
                        if counts["n_pos"] is not None and counts["n_rot"] is not None else None)
    sizes = {"n_elem": counts["n_elem"], "n_coord": n_coord_expected,
             "n_load": f["model/load_node"].shape[0] if "model/load_node" in f else None}
    new = {}
    for name, (kind, trailing, count) in _MODEL_11.items():
        if f"model/{name}" not in f and not required:
            continue
        shape = (sizes[count],) + trailing
        new[name] = _dataset(f, f"model/{name}", problems, kind=kind, shape=shape)

    def values(name):
        return new[name][()] if new.get(name) is not None and new[name].size else None

    rows = values("element_position_rows")
    if rows is not None and ds["position_nodes"] is not None and ds["element_nodes"] is not None:
        ids = ds["position_nodes"][()]
        if rows.min() < 0 or rows.max() >= ids.size or rows.shape[0] != ds["element_nodes"].shape[
                0] or not np.array_equal(ids[rows], ds["element_nodes"][()][:, [0, 2]]):
            problems.append("/model/element_position_rows does not match /model/element_nodes")
    for name, allowed in (("cross_section_type", {"", "RECT", "CIRC"}),
                          ("load_type", {"XF", "DELXF"})):
        if new.get(name) is not None:
            unknown = sorted(set(_str_list(new[name])) - allowed)
            if unknown:
                problems.append(f"/model/{name} has unknown values {unknown}")
            elif name == "cross_section_type":
                counts["sections"] = any(_str_list(new[name]))
    cls = values("element_deformation_class")
    if cls is not None and (cls.min() < 0 or cls.max() > 2):
        problems.append("/model/element_deformation_class has values outside 0..2")
    index = values("coordinate_index")
    if index is not None and (index.min() < 1 or index.max() > 4):
        problems.append("/model/coordinate_index has values outside 1..4")
    if ds["position_nodes"] is not None and ds["orientation_nodes"] is not None:
        nodes = np.concatenate([ds["position_nodes"][()], ds["orientation_nodes"][()]])
        for name in ("coordinate_node", "load_node"):
            v = values(name)
            if v is not None and np.setdiff1d(v, nodes).size:
                problems.append(f"/model/{name} refers to unknown nodes "
                                f"{np.setdiff1d(v, nodes).tolist()}")


def _check_static(f: h5py.File, counts: dict, completed: bool, problems: list[str]) -> None:
    """Check ``/static``: datasets, shapes, step counts and the load_factor scale."""
    lf = _dataset(f, "static/load_factor", problems, kind="float", shape=(None,))
    reac_node = _dataset(f, "static/reaction_node", problems, kind="int", shape=(None,))
    reac_comp = _dataset(f, "static/reaction_component", problems, kind="ascii", shape=(None,))
    n_reac = reac_node.shape[0] if reac_node is not None else None
    if reac_comp is not None:
        names = _str_list(reac_comp)
        if n_reac is not None and len(names) != n_reac:
            problems.append(f"/static/reaction_component has {len(names)} entries, "
                            f"/static/reaction_node {n_reac}")
        unknown = sorted(set(names) - set(REACTION_COMPONENTS))
        if unknown:
            problems.append(f"/static/reaction_component has unknown components {unknown}")
    trailing = {"position": (counts["n_pos"], 3), "euler": (counts["n_rot"], 4),
                "deformation": (counts["n_elem"], 6), "stress_resultant": (counts["n_elem"], 6),
                "reaction": (n_reac,), "iterations": (), "residual": ()}
    n_step = lf.shape[0] if lf is not None else None
    if lf is not None and not h5py.h5ds.is_scale(lf.id):
        problems.append("/static/load_factor is not a dimension scale")
    step_datasets = dict(_STEP_DATASETS)
    for name in _STRESS_DATASETS:      # schema 1.1: required when a cross-section is known
        if counts.get("sections") or f"static/{name}" in f:
            step_datasets[name] = _STRESS_DATASETS[name]
            trailing[name] = (counts["n_elem"],)
    for name, (dtype, _) in step_datasets.items():
        kind = "int" if np.issubdtype(dtype, np.integer) else "float"
        ds = _dataset(f, f"static/{name}", problems, kind=kind, shape=(None,) + trailing[name])
        if ds is None or n_step is None:
            continue
        m = ds.shape[0]
        if m != n_step and (completed or m < n_step):
            # A partial file may hold one uncommitted step (rows beyond load_factor).
            problems.append(f"/static/{name} has {m} steps but /static/load_factor has "
                            f"{n_step}")
        if not h5py.h5ds.is_attached(ds.id, lf.id, 0):
            problems.append(f"/static/load_factor is not attached to axis 0 of /static/{name}")


def _check_linearized(f: h5py.File, group: str, counts: dict, completed: bool,
                      problems: list[str]) -> None:
    """Check ``/eigen`` or ``/buckling``: shapes from n_mode and the model, step indices."""
    n_mode = _python_value(f[group].attrs.get("n_mode"))
    if not isinstance(n_mode, int) or n_mode < 1:
        problems.append(f"/{group} attribute n_mode missing or not a positive integer")
        return
    step = _dataset(f, f"{group}/step", problems, kind="int", shape=(None,))
    if step is None:
        return
    n_lin = step.shape[0]
    n_static = f["static/load_factor"].shape[0] if "static/load_factor" in f else 0
    values = step[()]
    if values.size and (values.min() < 0 or values.max() >= n_static):
        problems.append(f"/{group}/step refers to static steps outside 0..{n_static - 1}")
    for name, (dtype, shape_of) in _LIN_DATASETS[group].items():
        kind = "int" if np.issubdtype(dtype, np.integer) else "float"
        ds = _dataset(f, f"{group}/{name}", problems, kind=kind,
                      shape=(None,) + shape_of(n_mode, counts["n_pos"], counts["n_rot"]))
        if ds is not None and (ds.shape[0] < n_lin or (completed and ds.shape[0] != n_lin)):
            problems.append(f"/{group}/{name} has {ds.shape[0]} rows but /{group}/step has "
                            f"{n_lin}")


def _dataset(f: h5py.File, path: str, problems: list[str], *, kind: str,
             shape: tuple) -> h5py.Dataset | None:
    """Return the dataset at ``path`` after checking its kind and shape (None = any size)."""
    obj = f.get(path)
    if not isinstance(obj, h5py.Dataset):
        problems.append(f"/{path} missing" if obj is None else f"/{path} is not a dataset")
        return None
    dt = obj.dtype
    ok = {"int": np.issubdtype(dt, np.integer),
          "float": np.issubdtype(dt, np.floating),
          "ascii": dt.kind == "S",
          "bool": dt.kind == "b",
          "str": h5py.check_string_dtype(dt) is not None}[kind]
    if not ok:
        problems.append(f"/{path} has dtype {dt}, expected {kind}")
    if len(obj.shape) != len(shape) or any(
            want is not None and have != want for have, want in zip(obj.shape, shape)):
        want = tuple("*" if s is None else s for s in shape)
        problems.append(f"/{path} has shape {obj.shape}, expected {want}")
    return obj


def _check_cf_attrs(f: h5py.File, problems: list[str]) -> None:
    """Every dataset needs ``units`` and ``long_name``; schema datasets the documented units."""
    def visit(name, obj):
        if not isinstance(obj, h5py.Dataset):
            return
        for attr in ("units", "long_name"):
            value = _python_value(obj.attrs.get(attr))
            if not isinstance(value, str) or not value:
                problems.append(f"/{name} has no {attr} attribute")
        expected = DATASET_ATTRS.get(name)
        units = _python_value(obj.attrs.get("units"))
        if expected is not None and isinstance(units, str) and units != expected[0]:
            problems.append(f"/{name} has units {units!r}, expected {expected[0]!r}")
    f.visititems(visit)


def _python_value(value):
    """Attribute value as a plain Python value (str, bool, int, float, list)."""
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _str_list(ds: h5py.Dataset) -> list[str]:
    return [s.decode("ascii", errors="replace") if isinstance(s, bytes) else str(s)
            for s in ds[()].tolist()]

"""Stream an analysis into a crash-safe results file: :class:`ResultsWriter`.

This module's one job is writing: the writer receives arrays (the ``/model`` datasets from
:func:`spacarpy.results.model_data.model_datasets`, then every step's results) and stores them
at the paths, dtypes and shapes of :data:`spacarpy.results.schema.DATASETS`; it computes no
numbering and no stresses. The file's life cycle (partial file, SWMR, commit by scale, fsync)
is :mod:`spacarpy.results.h5file`'s, the empty groups and the header :mod:`~.layout`'s.

- Every step is written with its checksum row (``/<group>/checksum``: the CRC-32 of the step's
  scale value and of its row of every dataset), flushed, then *committed* by appending its
  scale value (``/static/load_factor``, ``/transient/time``, ``/<group>/step``), flushed.
- A Python exception (solver failure, Ctrl-C) inside the ``with`` block closes the file
  cleanly with ``completed = False`` and the error message; the partial file is kept.
"""
from __future__ import annotations

import logging
import operator
import os
from pathlib import Path

import h5py
import numpy as np

from spacarpy.errors import DiskFull, disk_full_text, is_disk_full
from spacarpy.model import Model
from spacarpy.outputs import refuse_non_regular
from spacarpy.results import h5file
from spacarpy.results.h5file import create, partial_path_for, set_index_units
from spacarpy.results.layout import (
    add_dimensions,
    bind_step_group,
    create_step_group,
    string_dataset,
    write_header,
)
from spacarpy.results.schema import (
    ACCELERATIONS,
    DATASETS,
    FIXED_DIMS,
    REACTION_COMPONENTS,
    base_dim,
    n_def,
)
from spacarpy.results.step_writer import StepWriter
from spacarpy.settings import ANALYSES, DEFORMATION_VARIANTS, ROTARY_CHOICES

log = logging.getLogger(__name__)

__all__ = ["ResultsWriter"]

_INTERRUPTED = "interrupted by user"
_NOT_FINISHED = "results writer closed without finish()"
_STRESS = ("max_normal_stress", "max_von_mises_stress")
_ARC_ONLY = ("static/arc_length", "static/stability")     # arc-length runs only


class ResultsWriter(StepWriter):
    """Stream the results of one analysis into a crash-safe HDF5 results file.

    Use it as a context manager; the file is opened on entering the ``with`` block and is
    closed on every way out of it::

        with ResultsWriter("out.h5", model, program_version=__version__,
                           deformations="modified", analysis="static") as w:
            w.begin_static(n_pos, n_rot, reaction_node, reaction_component)
            for ...:                      # every converged load step
                w.static_step(load_factor=..., position=..., euler=...,
                              deformation={"BEAM": e}, stress_resultant={"BEAM": s}, ...)
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
        The analysed model; its deck text and path are stored.
    program_version : str
        spacarpy version, stored as root attribute ``program_version``.
    deformations : str
        ``"modified"`` or ``"basic"``.
    analysis : str
        One of :data:`spacarpy.model.ANALYSES`.
    model_data : dict, optional
        The ``/model`` datasets (:func:`~spacarpy.results.model_data.model_datasets`);
        prepared from ``model`` when not given.

    Attributes
    ----------
    final_path : pathlib.Path
        Where the finished file ends up.
    partial_path : pathlib.Path
        Where the file is written until :meth:`finish` (and where an unfinished run stays).
    """

    def __init__(self, path, model: Model, *, program_version: str, deformations: str,
                 analysis: str, model_data: dict | None = None,
                 rotary_inertia: str | None = None):
        if rotary_inertia is not None and rotary_inertia not in ROTARY_CHOICES:
            raise ValueError(f"unknown rotary inertia {rotary_inertia!r}; "
                             f"expected one of {ROTARY_CHOICES}")
        if deformations not in DEFORMATION_VARIANTS:
            raise ValueError(f"unknown deformation variant {deformations!r}; "
                             f"expected one of {DEFORMATION_VARIANTS}")
        if analysis not in ANALYSES:
            raise ValueError(f"unknown analysis {analysis!r}; expected one of {ANALYSES}")
        if model_data is None:
            from spacarpy.results.model_data import model_datasets
            model_data = model_datasets(model)
        self.final_path = Path(path)
        self.partial_path = partial_path_for(self.final_path)
        self.model = model
        self.model_data = model_data
        self.program_version = str(program_version)
        self.deformations = deformations
        self.rotary_inertia = rotary_inertia
        self.analysis = analysis
        #: element kinds of the file and their element counts
        self.kinds = {p.split("/")[2]: v.shape[0] for p, v in model_data.items()
                      if p.startswith("model/elements/") and p.endswith("/ids")}
        self._file: h5py.File | None = None
        self._swmr = False
        self._state = "new"        # new -> open -> (finishing -> finished | aborted)
        self._groups: dict[str, dict] = {}     # group -> {"scale", "datasets", "shapes", "n"}
        self._arclength = False
        self._warnings: list[str] = []

    # -- context manager ----------------------------------------------------------------------

    def __enter__(self) -> ResultsWriter:
        return self.open()

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is None:
            if self._state == "open":
                log.warning("%s: %s; keeping the partial file %s", self.final_path, _NOT_FINISHED,
                            self.partial_path)
                self.abort(_NOT_FINISHED)
        elif self._state in ("open", "finishing") and is_disk_full(exc):
            raise self._disk_full(exc) from None
        elif self._state in ("open", "finishing"):
            if issubclass(exc_type, KeyboardInterrupt):      # Ctrl-C, or SIGTERM's message
                message = str(exc) or _INTERRUPTED
            else:
                message = str(exc) or exc_type.__name__
            self.abort(message)
        return False   # never swallow the exception

    # -- public API ---------------------------------------------------------------------------

    @property
    def n_step(self) -> int:
        """Number of static steps written and committed so far."""
        return self._groups["static"]["n"] if "static" in self._groups else 0

    @property
    def has_stress(self) -> bool:
        """Whether the file stores surface stresses (some BEAM has a known cross-section)."""
        types = self.model_data.get("model/elements/BEAM/cross_section_type")
        return types is not None and bool(np.any(types != b""))

    def open(self) -> ResultsWriter:
        """Create the partial file and write the root attributes, ``/deck`` and ``/model``.

        Called by ``__enter__``; call it yourself only when not using ``with`` (and then call
        :meth:`finish` or :meth:`abort` in a ``finally``).
        """
        if self._state != "new":
            raise RuntimeError("a ResultsWriter can be opened only once")
        if self.partial_path.exists():
            log.info("replacing the stale partial file %s", self.partial_path)
        try:    # in memory, then one plain write (a full disk: no HDF5 object left open)
            self._file = h5file.create_with(self.partial_path, self._write_header)
        except BaseException as exc:
            h5file.discard_written(None, self.partial_path)
            self._state = "aborted"
            if is_disk_full(exc):
                raise self._disk_full(exc) from None
            raise
        self._state = "open"
        log.debug("writing results to %s", self.partial_path)
        return self

    def begin_static(self, n_position_node: int, n_orientation_node: int, reaction_node,
                     reaction_component, *, n_eigen_modes: int = 0,
                     n_buckling_modes: int = 0, compliance_node=None,
                     transient: bool = False, state_space: dict | None = None,
                     arclength: bool = False, accelerations: bool = False) -> None:
        """Create the ``/static`` group (and the others asked for) with empty step datasets.

        After this call the file is switched to SWMR mode: no new datasets or groups can be
        added, only steps appended.

        Parameters
        ----------
        n_position_node, n_orientation_node : int
            ``n_pos`` and ``n_rot``; must match the model (the element counts of each kind
            come from the model's datasets).
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
            Also create the ``/transient`` group for :meth:`transient_step`.
        state_space : dict or None
            Also create the ``/state_space`` group (:meth:`state_space_step`): its names,
            ``dof_element``, ``dof_mode`` (n_dof,), ``state_name`` (2 n_dof),
            ``input_name`` and ``output_name``.
        arclength : bool
            An arc-length run: ``/static/arc_length`` per step and the ``/critical`` group
            (:meth:`critical_step`). ``accelerations``: /transient has them (mode 2).
        """
        f = self._require_open("begin_static")
        if "static" in self._groups:
            raise RuntimeError("begin_static was already called")
        md = self.model_data
        counts = {"n_position_node": (n_position_node, md["model/position_nodes"].size),
                  "n_orientation_node": (n_orientation_node, md["model/orientation_nodes"].size)}
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
        self._sizes = {"position_node": int(n_position_node),
                       "orientation_node": int(n_orientation_node),
                       "warping_node": int(md.get("model/warping_nodes", np.zeros(0)).size),
                       "reaction": reaction_node.size, "coordinate": 3, "euler_parameter": 4}
        self._arclength = bool(arclength)
        self._accelerations = bool(accelerations)
        # built in memory and written in one piece, as the header (h5file.rebuild_with);
        # if that fails, abort() reopens the file that rebuild_with closed
        self._file = None
        self._file = h5file.rebuild_with(self.partial_path, f, lambda mem: self._begin_groups(
            mem, reaction_node, reaction_component, n_eigen_modes, n_buckling_modes,
            compliance_node, transient, state_space, arclength))
        for entry in self._groups.values():
            bind_step_group(entry, self._file)
        # From here on only appends: SWMR keeps the file consistent on disk at every instant.
        self._file.swmr_mode = True
        self._swmr = True

    def _begin_groups(self, f, reaction_node, reaction_component, n_eigen_modes,
                      n_buckling_modes, compliance_node, transient, state_space, arclength):
        self._create_step_group(f, "static")
        g = f["static"]
        create(g, "reaction_node", reaction_node)
        string_dataset(g, "reaction_component", reaction_component)
        for group, n_mode in (("eigen", n_eigen_modes), ("buckling", n_buckling_modes),
                              ("compliance", 1 if compliance_node is not None else 0)):
            if n_mode > 0:
                self._create_step_group(f, group, n_mode=int(n_mode))
        if compliance_node is not None:
            f["compliance"].attrs["position_node"] = np.int64(compliance_node[0])
            f["compliance"].attrs["orientation_node"] = np.int64(compliance_node[1])
        if transient:
            self._create_step_group(f, "transient")
        if state_space is not None:
            self._begin_state_space(f, state_space)
        if arclength:
            self._create_step_group(f, "critical", n_mode=1)
        units = [REACTION_COMPONENTS[c] for c in reaction_component]
        for group in self._groups:
            if group in ("static", "transient"):
                set_index_units(f[f"{group}/reaction"], units, ("reaction_number",))
            add_dimensions(f, group, self.model_data)

    def add_warning(self, message: str) -> None:
        """A warning about the run (e.g. a load step that jumped between branches), stored
        in the root attribute ``warnings`` (one per line) when the file is closed."""
        self._warnings.append(str(message))

    def _begin_state_space(self, f, names: dict) -> None:
        n_dof = len(names["dof_element"])
        kinematic = list(names.get("kinematic_name", ()))
        self._sizes.update(dof=n_dof, state=2 * n_dof + len(kinematic),
                           kinematic_state=len(kinematic), system_input=len(names["input_name"]),
                           system_output=len(names["output_name"]))
        self._create_step_group(f, "state_space", n_mode=1)
        g = f["state_space"]
        for key in (k for k in ("dof_element", "dof_mode", "dof_node") if k in names):  # DYNX
            create(g, key, np.asarray(names[key], np.int32 if key == "dof_mode" else np.int64))
        for key in ("state_name", "input_name", "output_name") + (
                ("kinematic_name",) if kinematic else ()):
            string_dataset(g, key, names[key])

    def finish(self) -> None:
        """Mark the run complete, close the file and move it atomically to :attr:`final_path`
        (an existing file there is replaced only here, by a complete file)."""
        self._require_open("finish")
        self._state = "finishing"
        self._mark(completed=True, error=None)
        h5file.fsync(self.partial_path)
        refuse_non_regular(self.final_path)    # never replace a device or a FIFO
        os.replace(self.partial_path, self.final_path)
        h5file.fsync(self.final_path.parent)
        self._state = "finished"
        what = self._steps_held()
        log.info("results written to %s (%s)", self.final_path, what)

    def abort(self, error: str) -> None:
        """Close the file as an unfinished run: ``completed = False``, ``error = error``.

        The partial file is kept at :attr:`partial_path`; :attr:`final_path` is not touched.
        Never raises (a failure to mark the file is logged), so that it cannot hide the error
        that caused the abort. Does nothing if the writer is already finished or aborted.
        """
        if self._state in ("finished", "aborted"):
            return
        if self._state == "new":
            self._state = "aborted"
            return
        try:
            if self._file is None:   # finish() failed after closing the file
                self._swmr = False
                self._file = h5py.File(self.partial_path, "r+", libver=h5file.LIBVER)
            self._mark(completed=False, error=error)
        except Exception as exc:
            if is_disk_full(exc):    # the partial file cannot be marked: it goes
                log.warning("%s", self._disk_full(exc))
                return
            log.warning("could not mark %s as incomplete: %s", self.partial_path, exc)
        finally:
            if self._state != "aborted":
                self._close()
                self._state = "aborted"
        kept = self._steps_held()
        # the error itself is the caller's to report (the CLI prints it once)
        log.warning("run not completed; %s kept in %s", kept, self.partial_path)

    # -- internals ----------------------------------------------------------------------------

    def _disk_full(self, exc) -> DiskFull:
        """Give up the partial file after a write failed for lack of space (it is removed:
        a file that could not be written to the end cannot be marked as incomplete either)
        and return the error to raise. The file at :attr:`final_path` is untouched."""
        held = self._steps_held() if self._groups else "nothing"
        h5file.discard_written(self._file, self.partial_path)
        self._file = None
        self._state = "aborted"
        kept = (f"the previous {self.final_path} is unchanged" if self.final_path.exists()
                else f"no {self.final_path} was written")
        return DiskFull(f"disk full (or quota exceeded) while writing {self.partial_path}: "
                        f"{disk_full_text(exc)}; the partial file (with {held}) was removed and "
                        f"{kept}. Free some space or give another -o")

    def _specs(self, group: str):
        """Schema entries of a step group that this file has (per-kind ones for its kinds)."""
        for path, spec in DATASETS.items():
            if spec.group != group or not spec.shape or spec.shape[0] not in (
                    "step", "time_step", "linearized_step"):
                continue
            if (spec.kind is not None and spec.kind not in self.kinds) or (
                    path.endswith(_STRESS) and not self.has_stress) or (
                    path in _ARC_ONLY and not self._arclength) or (
                    path in ACCELERATIONS and not self._accelerations) or (
                    "warping_node" in spec.shape and not self._sizes["warping_node"]):
                continue
            yield path, spec

    def _size(self, dim, kind, n_mode):
        dim = base_dim(dim)
        if isinstance(dim, int):
            return dim
        if dim == "element":
            return self.kinds[kind]
        if dim == "deformation_mode":
            return n_def(kind)
        if dim == "mode":
            return n_mode
        return len(FIXED_DIMS[dim]) if dim in FIXED_DIMS else self._sizes[dim]

    def _create_step_group(self, f, group: str, n_mode: int = 0) -> None:
        self._groups[group] = create_step_group(
            f, group, self._specs(group), lambda dim, kind: self._size(dim, kind, n_mode),
            n_mode)

    def _steps_held(self) -> str:
        """What the file holds, for the log: static steps, time steps and the time reached."""
        if "transient" not in self._groups:
            return f"{self.n_step} static steps"
        tr = self._groups["transient"]
        held = f"{tr['n']} time steps" + (f" (to t = {tr['last']:.6g} s)" if tr["n"] else "")
        return f"{self.n_step} static steps, {held}" if self.n_step else held

    def _require_open(self, what: str) -> h5py.File:
        if self._state != "open":
            raise RuntimeError(f"{what}: the results writer is {self._state}, not open "
                               "(use it as a context manager)")
        return self._file

    def _close(self) -> None:
        try:
            if self._file is not None:
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
                self._file = h5py.File(self.partial_path, "r+", libver=h5file.LIBVER)
            attrs = self._file.attrs
            attrs["completed"] = np.bool_(completed)
            if self._warnings:
                attrs["warnings"] = "\n".join(self._warnings)
            if error is not None:
                attrs["error"] = str(error)
            elif "error" in attrs:
                del attrs["error"]
        finally:
            self._close()

    def _write_header(self, f: h5py.File) -> None:
        write_header(f, self.model, self.model_data, program_version=self.program_version,
                     analysis=self.analysis, deformations=self.deformations,
                     rotary_inertia=self.rotary_inertia)


"""The eager reader of a results file: :func:`read_results` loads every group into arrays.

For scripts that want whole arrays at once (and the batch comparison); the lazy reader is
:func:`spacarpy.results.reader.open_results`. Every dataset is verified against its checksum.
"""
from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field, fields

import numpy as np

from spacarpy.results.h5file import (
    SchemaFile,
    checksum_problems,
    damaged,
    open_for_reading,
    str_list,
)
from spacarpy.results.schema import (
    DATASETS,
)
from spacarpy.results.validate import check_readable, committed_steps
from spacarpy.results.views import RootAttributes

log = logging.getLogger(__name__)


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
    converged_by : (n_step,) int8 or None
        0: the residual met the tolerance, 1: within its round-off floor (schema 2.7; None
        for an older file).
    arc_length : (n_step,) float64 or None
        The arc length from step 0 of an ARCLENGTH run (schema 2.4; None otherwise).
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
    converged_by: np.ndarray | None = None
    arc_length: np.ndarray | None = None
    max_normal_stress: np.ndarray | None = None
    max_von_mises_stress: np.ndarray | None = None
    elements: dict = field(default_factory=dict)

    @property
    def n_step(self) -> int:
        return int(self.load_factor.size)


class _Arrays:
    """Attribute access to the group's datasets held in ``arrays`` (``res.eigen.frequency``)."""

    def __getattr__(self, name):
        try:
            return self.__dict__["arrays"][name]
        except KeyError:
            raise AttributeError(name) from None


@dataclass
class TransientResults(_Arrays):
    """The ``/transient`` group as arrays (axis 0 = stored time step): ``time``, ``position``,
    ``euler``, ``velocity``, ``euler_rate``, the energies, ``iterations``, ``residual``,
    ``converged_by`` (0 the residual met the tolerance, 1 within its round-off floor;
    schema 2.10, None for an older file) and ``elements`` (per kind, as in
    :class:`StaticResults`)."""

    time: np.ndarray
    arrays: dict
    elements: dict


    @property
    def n_step(self) -> int:
        return int(self.time.size)


@dataclass
class LinearizedResults(_Arrays):
    """An ``/eigen``, ``/buckling`` or ``/compliance`` group: one row per linearized step.

    ``step`` (n_lin,) gives the row of ``/static`` each linearization belongs to; the other
    arrays (see docs/results.md) are attributes, e.g. ``res.eigen.frequency`` (n_lin, n_mode)
    or ``res.buckling.critical_load_multiplier`` (n_lin,).
    """

    step: np.ndarray
    arrays: dict


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
    static, transient, eigen, buckling, compliance, state_space
        The groups, or ``None`` when the file has none (``state_space`` also holds the
        names: ``dof_element``, ``dof_mode``, ``state_name``, ``input_name``,
        ``output_name``).
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
    state_space: LinearizedResults | None = None


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
            # a step dataset of a newer minor version that this reader does not know is
            # left out (docs/results.md, "Versions")
            known = {f.name for f in fields(StaticResults)}
            arrays = {k: v for k, v in arrays.items() if k in known}
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
            arrays.setdefault("converged_by", None)            # before 2.10
            results.transient = TransientResults(time=arrays.pop("time"), arrays=arrays,
                                                 elements=elements)
        for group in ("eigen", "buckling", "compliance", "state_space"):
            if group in f:
                n = f[group]["step"].shape[0]
                arrays, _ = _step_arrays(sf, group, n)
                if group == "state_space":
                    g = f[group]
                    arrays.update(dof_element=g["dof_element"][()], dof_mode=g["dof_mode"][()],
                                  **{k: str_list(g[k]) for k in ("state_name", "input_name",
                                                                 "output_name")})
                setattr(results, group, LinearizedResults(step=arrays.pop("step"),
                                                          arrays=arrays))
        problems = checksum_problems(f, committed_steps(f))
        if problems:
            raise damaged(path, "; ".join(problems[:5]))
    if not results.completed:
        log.warning("%s is an incomplete run: %s", path,
                    results.error or "the writer did not finish (killed, or still running)")
    return results

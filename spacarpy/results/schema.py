"""The results-file schema (version 2.0) as one table, and the map from the 1.x names.

This module's one job is to declare the schema: :data:`DATASETS` holds every dataset once
(path, dtype, shape in named dimensions, units, long name, the schema version that introduced
the quantity). :mod:`~spacarpy.results.writer`, :mod:`~spacarpy.results.reader` and
:mod:`~spacarpy.results.validate` all work from it; ``docs/results.md`` documents it (a test
checks the two agree).

Element data are grouped by element kind: ``/model/elements/<KIND>/...``,
``/static/elements/<KIND>/...`` and ``/transient/elements/<KIND>/...``. The per-kind datasets
are generated from the element kinds' declared facts (the number of deformation modes and
node slots of :data:`KINDS`). Schema 1.x stored BEAM data at ``/static/deformation`` and the
other kinds at ``/static/truss_deformation`` etc.; :data:`LEGACY_NAMES` maps every 2.0 path
to its 1.x name, so that 1.x files are read, validated and compared through the 2.0 names.
Node-based datasets (``/static/position`` ...) keep their 1.x paths and shapes.

Dimension names: ``step`` (committed load steps), ``time_step`` (committed time steps),
``linearized_step``, ``mode``, ``position_node`` (n_pos), ``orientation_node`` (n_rot),
``warping_node`` (n_warp, a BEAMW's warping nodes),
``element`` (elements of the dataset's kind), ``deformation_mode`` (the kind's n_def),
``slot`` (the kind's node slots), ``reaction``, ``coordinate`` (3), ``euler_parameter`` (4),
``global_coordinate`` (n_coord), ``load`` (load lines), ``line_load`` and ``follower_load``
(QE/QEL and XFL lines), ``input`` (prescribed deformations),
``checked_dataset`` (the datasets a ``checksum`` covers: its attribute ``columns``);
``dof`` (degrees of freedom of the state space), ``state`` (2 dof), ``system_input`` and
``system_output`` (its INPUTF and OUT* lines); integers are fixed sizes.
"""
from __future__ import annotations

import re

from spacarpy.elements.registry import KINDS as _KINDS
from spacarpy.results.dataset_spec import DatasetSpec
from spacarpy.results.legacy import (  # noqa: F401  (re-exported: the schema's names)
    LEGACY_DROPPED,
    LEGACY_NAMES,
    LEGACY_OPTIONAL,
    legacy_name,
    new_name,
)

__all__ = ["ACCELERATIONS", "SCHEMA_VERSION", "FILETYPE", "PROGRAM", "DatasetSpec", "DATASETS",
           "KIND_NAMES", "LEGACY_NAMES", "LINEARIZED_GROUPS", "legacy_name", "new_name", "spec_for",
           "STEP_GROUPS", "CRITICAL_POINT_NAMES",
           "REACTION_COMPONENTS", "REACTION_UNITS", "MODE_KIND_NAMES",
           "DEFORMATION_CLASS_NAMES", "ROOT_ATTRS", "n_def", "n_slots", "slot_roles"]

#: (major, minor) version of the schema written by this spacarpy. MAJOR changes are
#: incompatible (paths moved); MINOR ones only add optional content. Files of major
#: version 1 are read through :data:`LEGACY_NAMES`.
SCHEMA_VERSION = (3, 1)
#: Value of the root attribute ``filetype``.
FILETYPE = "spacarpy-results"
#: Value of the root attribute ``program``.
PROGRAM = "spacarpy"
#: Required root attributes (``error`` is optional: only present on a failed run).
ROOT_ATTRS = ("filetype", "schema_version", "program", "program_version", "created", "deck_path",
              "deck_sha256", "analysis", "deformations", "completed")
#: Reaction component names and their units.
REACTION_COMPONENTS = {"Fx": "N", "Fy": "N", "Fz": "N", "Mx": "N m", "My": "N m", "Mz": "N m"}
#: ``units`` attribute of ``/static/reaction`` (units depend on the component: the
#: attribute ``units_per_index`` holds one per reaction component, schema 3.0).
REACTION_UNITS = "1"
#: The same in a file of schema 2.x.
REACTION_UNITS_V2 = "N | N m (see reaction_component)"
#: Dimensions of fixed length and the labels of their indices (schema 3.0: the values of
#: their dimension scales).
FIXED_DIMS = {
    "coordinate": ("x", "y", "z"),
    "euler_parameter": ("lambda0", "lambda1", "lambda2", "lambda3"),
    "axis": ("x", "y", "z"),
    "end": ("p", "q"),
    "element_mode": ("element", "mode"),
    "node_coordinate": ("node", "coordinate"),
    "node_axes": ("node", "axes node"),
    "stiffness_term": ("EA", "GJ", "EIy", "EIz", "cy", "cz"),
    "mass_term": ("rhoA", "rho(Iy+Iz)", "rhoIy", "rhoIz", "rhoIyz"),
    "section_dim": ("w or d", "t"),
    "response": ("ux", "uy", "uz", "phix", "phiy", "phiz"),
    "load_component": ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz"),
}
#: Units of the 6x6 compliance, row-major over (response, load_component).
COMPLIANCE_UNITS = tuple(("m/N" if i < 3 else "rad/N") if j < 3 else
                         ("1/N" if i < 3 else "rad/(N m)")
                         for i in range(6) for j in range(6))
#: The /transient datasets of inverse dynamics (SPACAR mode 2) only.
ACCELERATIONS = ("transient/acceleration", "transient/euler_acceleration")
#: Names of the ``/eigen/kind`` codes.
MODE_KIND_NAMES = ("elastic", "rigid-body", "unstable", "complex", "infinite",
                   "undetermined")
#: Names of the deformation classes in ``/model/elements/BEAM/deformation_class``.
DEFORMATION_CLASS_NAMES = ("rigid", "flexible", "released", "kinematic")
#: Element kinds, in the order their groups are written.
KIND_NAMES = tuple(_KINDS)


def base_dim(dim):
    """The dimension whose length ``dim`` has: ``dof`` for ``dof_column`` (the column axis
    of a square matrix has a name of its own, as netCDF needs), else ``dim``."""
    return dim[:-len("_column")] if isinstance(dim, str) and dim.endswith("_column") else dim


def n_def(kind: str) -> int:
    """Number of deformation modes of element kind ``kind``."""
    return _KINDS[kind].n_def


def n_slots(kind: str) -> int:
    """Number of node slots (deck nodes per element) of element kind ``kind``."""
    return len(_KINDS[kind].slots)


def slot_roles(kind: str) -> tuple:
    """``"pos"`` or ``"rot"`` for each node slot of element kind ``kind``."""
    return tuple(_KINDS[kind].slots)


#: Groups whose datasets grow by one row per step, with their commit (scale) dataset.
STEP_GROUPS = {"static": "load_factor", "transient": "time", "eigen": "step",
               "buckling": "step", "compliance": "step", "state_space": "step",
               "critical": "step"}
#: Groups with one row per linearized static step (their scale is ``step``).
LINEARIZED_GROUPS = ("eigen", "buckling", "compliance", "state_space")
#: Names of the ``/critical/point_type`` codes (arc-length runs).
CRITICAL_POINT_NAMES = ("limit point (load maximum)", "limit point (load minimum)",
                        "bifurcation", "undetermined")


def _units(per_mode) -> tuple:
    """``(units, index_units, units_v2)`` of a dataset whose modes have the units
    ``per_mode``: one unit, or ``"1"`` with one per mode (the 2.x string: them joined)."""
    distinct = list(dict.fromkeys(per_mode))
    if len(distinct) <= 1:
        return (distinct[0] if distinct else "1"), (), None
    return "1", tuple(per_mode), " | ".join(distinct)


def _index_units(units: tuple) -> dict:
    """The spec fields of a per-kind dataset from :func:`_units`."""
    if not units[1]:
        return {}
    return {"index_units": units[1], "index_dims": ("deformation_mode",),
            "units_v2": units[2]}


#: The normalization of the eigen mode shapes (attribute ``normalization``, schema 3.0).
_MASS_NORM = ("mass-normalized: shape_position in m and shape_euler in 1 are scaled so that "
              "phi^T M phi = 1 kg m^2 (M the mass matrix in SI units)")
#: The units rule of the state-space matrices (attribute ``units_rule``, schema 3.0).
SS_UNITS_RULE = ("SI units of the degrees of freedom and signals: a degree of freedom is in m "
                 "(a deformation mode of length, a DYNX position) or 1 (an angle in rad, an "
                 "Euler parameter), an input in N or N m, an output in the units of its OUT* "
                 "quantity (and per s for a rate); an entry's units are those that make each "
                 "equation consistent (e.g. M0[i, j] in kg m^2 / (u_i u_j))")
_SS_MATRICES = ("M0", "C0", "K0", "B0", "A", "B", "C", "D", "K0p", "G", "Gq", "Gp")


#: Schema version that introduced each kind's datasets (kinds added later: their own).
_KIND_SINCE = {"BEAM": (1, 0), "TRUSS": (1, 2), "HINGE": (1, 2), "RBEAM": (1, 2),
               "PLBEAM": (1, 3), "PLTRUSS": (1, 3), "PLHINGE": (1, 3), "PINBODY": (2, 11),
               "WHEEL": (2, 11), "BEAMW": (2, 17), "BEAMC": (2, 20)}

_LIN_SHAPE = {"mode": ("linearized_step", "mode"),
              "position": ("linearized_step", "mode", "position_node", "coordinate"),
              "euler": ("linearized_step", "mode", "orientation_node", "euler_parameter")}


def _spec_list() -> list[DatasetSpec]:
    S = DatasetSpec
    v11, v14, v23 = (1, 1), (1, 4), (2, 23)
    out = [
        S("deck", "utf-8", (), "1", "input deck text, verbatim"),
        S("model/position_nodes", "i8", ("position_node",), "1",
          "deck number of each position node"),
        S("model/position_x0", "f8", ("position_node", "coordinate"), "m",
          "initial position of each position node"),
        S("model/orientation_nodes", "i8", ("orientation_node",), "1",
          "deck number of each orientation node"),
        S("model/warping_nodes", "i8", ("warping_node",), "1",
          "deck number of each warping node (BEAMW), present when the model has them",
          (2, 17), optional=True),
        S("model/input_deformation", "i8", ("input", "element_mode"), "1",
          "[element, mode] of each prescribed deformation (INPUTE), present when the model "
          "has them", (1, 2), optional=True),
        S("model/kinematic_deformation", "i8", ("kinematic", "element_mode"), "1",
          "[element, mode] of each kinematic deformation (KINE), present when the model has "
          "them", (2, 11), optional=True),
        S("model/kinematic_coordinate", "i8", ("kinematic", "node_coordinate"), "1",
          "[node, coordinate] of each kinematic nodal coordinate (KINX), present when the "
          "model has them", (2, 11), optional=True),
        S("model/load_node", "i8", ("load",), "1", "deck node number of each nodal load line",
          v11),
        S("model/load_type", "utf-8", ("load",), "1",
          "XF (acting from the start) or DELXF (scaled by the load factor)", v11),
        S("model/load_value", "f8", ("load", "coordinate"), "1",
          "force (position node, N) or moment (orientation node, N m) of each load line, "
          "global axes (units: attribute units_per_index)", v11, units_v2="N | N m",
          index_dims=("load",)),
        S("model/line_load_element", "i8", ("line_load",), "1", "element of each line load "
          "line (QE, DELQE, QEL, DELQEL), present when the model has them", v23, optional=True),
        S("model/line_load_type", "utf-8", ("line_load",), "1", "QE or DELQE (dead, global "
          "axes), QEL or DELQEL (follower, the element's current axes); DEL: an increment",
          v23, optional=True),
        S("model/line_load_value", "f8", ("line_load", "end", "coordinate"), "N/m",
          "force per length of each line load line at the element's ends p and q (linear "
          "between), x y z of its axes (a planar deck's z 0)", v23, optional=True),
        S("model/follower_load_node", "i8", ("follower_load", "node_axes"), "1", "[node, axes "
          "node] of each follower load line (XFL, DELXFL), present when the model has them",
          v23, optional=True),
        S("model/follower_load_type", "utf-8", ("follower_load",), "1",
          "XFL (acting from the start) or DELXFL (an increment)", v23, optional=True),
        S("model/follower_load_value", "f8", ("follower_load", "coordinate"), "1",
          "force (position node, N) or moment (orientation node, N m) of each follower load "
          "line, in the current axes of its axes node (units: attribute units_per_index)",
          v23, optional=True, units_v2="N | N m", index_dims=("follower_load",)),
        S("model/coordinate_node", "i8", ("global_coordinate",), "1",
          "deck node number owning each global coordinate", v11),
        S("model/coordinate_index", "i1", ("global_coordinate",), "1",
          "index of the coordinate in its node: 1..3 = x y z, 1..4 = lambda0..lambda3, 1 = "
          "the rate of twist of a warping node", v11),
        S("model/coordinate_fixed", "i1", ("global_coordinate",), "1",
          "1 where the coordinate is fixed (FIX), else 0 (an HDF5 boolean before 3.1: "
          "ncdump does not show that type)", v11),
        # static
        S("static/load_factor", "f8", ("step",), "1",
          "load factor on DELXF (load = XF + load_factor * DELXF)"),
        S("static/position", "f8", ("step", "position_node", "coordinate"), "m",
          "position of each position node"),
        S("static/euler", "f8", ("step", "orientation_node", "euler_parameter"), "1",
          "Euler parameters (lambda0, lambda1, lambda2, lambda3) of each orientation node"),
        S("static/warping", "f8", ("step", "warping_node"), "1/m",
          "coordinate of each warping node: the rate of twist that sets the warping "
          "amplitude (BEAMW), present when the model has warping nodes", (2, 17),
          optional=True),
        S("static/reaction", "f8", ("step", "reaction"), REACTION_UNITS,
          "reaction force or moment of each reaction component (units: attribute "
          "units_per_index)", units_v2=REACTION_UNITS_V2, index_dims=("reaction",)),
        S("static/iterations", "i4", ("step",), "1", "Newton iterations used in the load step"),
        S("static/residual", "f8", ("step",), "1", "final relative residual of the load step"),
        S("static/converged_by", "i1", ("step",), "1",
          "how the load step was accepted: 0 its residual meets the tolerance, 1 it is above "
          "the tolerance but within its round-off floor measured at that state, with "
          "converged increments (docs/solver.md, Convergence)", (2, 7), optional=True),
        S("static/arc_length", "f8", ("step",), "1",
          "arc length from step 0 in the scaled norm of the arc-length method (present in "
          "ARCLENGTH runs)", (2, 4), optional=True),
        S("static/stability", "i1", ("step",), "1",
          "certified stability of each point of an ARCLENGTH run: 0 stable, 1 unstable, 2 "
          "undetermined (an eigenvalue nearest zero within its round-off bound), 3 a "
          "critical point of /critical; -1 not checked (docs/path.md, Critical points)",
          (2, 22), optional=True),
        S("static/reaction_node", "i8", ("reaction",), "1",
          "deck node number of each reaction component"),
        S("static/reaction_component", "utf-8", ("reaction",), "1",
          "name (Fx Fy Fz Mx My Mz) of each reaction component"),
        # transient
        S("transient/time", "f8", ("time_step",), "s",
          "time of each stored time step (the step is committed when its time is written)",
          v14),
        S("transient/position", "f8", ("time_step", "position_node", "coordinate"), "m",
          "position of each position node", v14),
        S("transient/euler", "f8", ("time_step", "orientation_node", "euler_parameter"), "1",
          "Euler parameters of each orientation node", v14),
        S("transient/warping", "f8", ("time_step", "warping_node"), "1/m",
          "coordinate of each warping node (rate of twist, BEAMW), present when the model "
          "has warping nodes", (2, 17), optional=True),
        S("transient/velocity", "f8", ("time_step", "position_node", "coordinate"), "m/s",
          "velocity of each position node", v14),
        S("transient/euler_rate", "f8", ("time_step", "orientation_node", "euler_parameter"),
          "1/s", "time derivative of the Euler parameters (angular velocity in body axes: "
          "2 G(q) dq/dt)", v14),
        S("transient/kinetic_energy", "f8", ("time_step",), "J", "kinetic energy T of the model",
          v14),
        S("transient/elastic_energy", "f8", ("time_step",), "J",
          "elastic energy U of the flexible deformation modes", v14),
        S("transient/external_work", "f8", ("time_step",), "J",
          "work W done on the model since t = 0 by the loads, gravity and the prescribed "
          "motions; T + U + D - W is constant for an exact integration", v14),
        S("transient/dissipated_energy", "f8", ("time_step",), "J",
          "energy dissipated by the damping (DAMPING, EDAMP) since t = 0", v14),
        S("transient/reaction", "f8", ("time_step", "reaction"), REACTION_UNITS,
          "reaction force or moment of each reaction component of /static/reaction_node "
          "(fixed and prescribed coordinates), inertia and damping included (units: "
          "attribute units_per_index)", (2, 8), units_v2=REACTION_UNITS_V2,
          index_dims=("reaction",)),
        S("transient/iterations", "i4", ("time_step",), "1",
          "Newton iterations of the last time step", v14),
        S("transient/residual", "f8", ("time_step",), "1",
          "final relative residual of the last time step", v14),
        S("transient/converged_by", "i1", ("time_step",), "1",
          "how the last time step was accepted: 0 its residual meets the tolerance, 1 it is "
          "above the tolerance but within its round-off floor measured at that state, with "
          "converged increments (docs/transient.md, Convergence)", (2, 10), optional=True),
        S("transient/acceleration", "f8", ("time_step", "position_node", "coordinate"),
          "m/s^2", "acceleration of each position node (inverse dynamics, SPACAR mode 2)",
          (2, 15), optional=True),
        S("transient/euler_acceleration", "f8",
          ("time_step", "orientation_node", "euler_parameter"), "1/s^2",
          "second time derivative of the Euler parameters (inverse dynamics, SPACAR mode 2)",
          (2, 15), optional=True),
        # linearized groups
        S("eigen/step", "i4", ("linearized_step",), "1",
          "index of the static step (row of /static) that was linearized"),
        S("eigen/frequency", "f8", _LIN_SHAPE["mode"], "Hz",
          "natural frequency; negative: unstable mode (divergence rate), NaN: complex or "
          "infinite eigenvalue, 0: rigid-body mode or undetermined sign"),
        S("eigen/eigenvalue_real", "f8", _LIN_SHAPE["mode"], "s^-2",
          "real part of the eigenvalue omega^2", units_v2="s-2"),
        S("eigen/eigenvalue_imag", "f8", _LIN_SHAPE["mode"], "s^-2",
          "imaginary part of the eigenvalue omega^2", units_v2="s-2"),
        S("eigen/kind", "i1", _LIN_SHAPE["mode"], "1",
          "mode kind: 0 elastic, 1 rigid-body, 2 unstable, 3 complex, 4 infinite, "
          "5 undetermined (w^2 within its round-off bound; since 2.12) (see attribute "
          "kind_names)"),
        S("eigen/shape_position", "f8", _LIN_SHAPE["position"], "m",
          "mass-normalized mode shape: position perturbation of each position node (see "
          "attribute normalization)", units_v2="m kg-1/2", attrs=(("normalization", _MASS_NORM),)),
        S("eigen/shape_euler", "f8", _LIN_SHAPE["euler"], "1",
          "mass-normalized mode shape: Euler-parameter perturbation of each orientation node "
          "(see attribute normalization)", units_v2="kg-1/2",
          attrs=(("normalization", _MASS_NORM),)),
        S("eigen/n_modes_available", "i4", ("linearized_step",), "1",
          "number of finite modes the linearization has: degrees of freedom minus the motions "
          "without inertia (-1: not counted, where the sparse solver found only the lowest); the "
          "lowest of them are stored",
          (2, 5)),
        S("eigen/eigenvalue_bound", "f8", _LIN_SHAPE["mode"], "s^-2",
          "error bound of the eigenvalue omega^2 of the assembled pencil (Kato-Temple's "
          "residual^2 / gap and the Rayleigh quotient's rounding, docs/linearized.md); NaN "
          "where the solver did not refine it (the sparse solvers)", (2, 21), optional=True,
          units_v2="s-2"),
        S("buckling/step", "i4", ("linearized_step",), "1",
          "index of the static step (row of /static) that was linearized"),
        S("buckling/load_multiplier", "f8", _LIN_SHAPE["mode"], "1",
          "buckling load multipliers of the load acting in the step, smallest magnitude "
          "first (NaN: none)"),
        S("buckling/critical_load_multiplier", "f8", ("linearized_step",), "1",
          "smallest positive buckling load multiplier (inf: none)"),
        S("buckling/kind", "i1", _LIN_SHAPE["mode"], "1",
          "multiplier kind: 0 finite, 4 infinite (the load does not load the mode; the "
          "multiplier is NaN), see attribute kind_names", (2, 2)),
        S("buckling/shape_position", "f8", _LIN_SHAPE["position"], "1",
          "buckling mode shape (largest component 1): position perturbation of each "
          "position node"),
        S("buckling/shape_euler", "f8", _LIN_SHAPE["euler"], "1",
          "buckling mode shape (largest component 1): Euler-parameter perturbation of each "
          "orientation node"),
        S("critical/step", "i4", ("linearized_step",), "1",
          "row of /static holding the refined critical point (ARCLENGTH runs)", (2, 4)),
        S("critical/point_type", "i1", ("linearized_step",), "1",
          "0 limit point (load maximum), 1 limit point (load minimum), 2 bifurcation, 3 "
          "undetermined (since 2.9; see attribute type_names)", (2, 4)),
        S("critical/load_factor", "f8", ("linearized_step",), "1",
          "load factor on DELXF at the critical point", (2, 4)),
        S("critical/arc_length", "f8", ("linearized_step",), "1",
          "arc length of the critical point from step 0", (2, 4)),
        S("critical/margin", "f8", ("linearized_step",), "1",
          "magnitude of the Jacobi-scaled eigenvalue that decided the classification (NaN: "
          "not computed)", (2, 9), optional=True),
        S("critical/bound", "f8", ("linearized_step",), "1",
          "round-off bound of that eigenvalue; the classification is certified when margin "
          "> bound, else undetermined", (2, 9), optional=True),
        S("critical/shape_position", "f8", _LIN_SHAPE["position"], "1",
          "critical eigenvector (largest component 1): position perturbation of each "
          "position node", (2, 4)),
        S("critical/shape_euler", "f8", _LIN_SHAPE["euler"], "1",
          "critical eigenvector (largest component 1): Euler-parameter perturbation of each "
          "orientation node", (2, 4)),
        S("compliance/step", "i4", ("linearized_step",), "1",
          "index of the static step (row of /static) that was linearized"),
        S("compliance/global", "f8", ("linearized_step", "response", "load_component"), "1",
          "6x6 compliance [dr; dphi] = C [dF; dT] of the chosen node, global axes (units: "
          "attribute units_per_index)", units_v2="m/N | rad/(N m) | m/(N m) = rad/N",
          index_units=COMPLIANCE_UNITS, index_dims=("response", "load_component")),
        S("compliance/local", "f8", ("linearized_step", "response", "load_component"), "1",
          "6x6 compliance of the chosen node in its current body axes (units: attribute "
          "units_per_index)", units_v2="m/N | rad/(N m) | m/(N m) = rad/N",
          index_units=COMPLIANCE_UNITS, index_dims=("response", "load_component")),
    ]
    out += _state_space_specs()
    for kind in KIND_NAMES:
        facts = _KINDS[kind]
        since = _KIND_SINCE.get(kind, SCHEMA_VERSION)
        eu, su = _units(facts.mode_units), _units(facts.stress_units)
        ru = _units([f"{u}/s" if u != "1" else "1/s" for u in facts.mode_units])
        em = facts.deformation_meaning or f"deformations of each {kind} element"
        sm = facts.stress_meaning or f"stress resultants of each {kind} element"
        m = f"model/elements/{kind}"
        out += [
            S(f"{m}/ids", "i8", ("element",), "1", f"deck number of each {kind} element",
              since, kind),
            S(f"{m}/nodes", "i8", ("element", "slot"), "1",
              f"deck node numbers [{' '.join(facts.node_roles)}] of each {kind} element",
              since, kind)]
        for group, axis0, tsince in (("static", "step", since), ("transient", "time_step",
                                                                  max(since, (1, 4)))):
            g = f"{group}/elements/{kind}"
            shape = (axis0, "element", "deformation_mode")
            out += [S(f"{g}/deformation", "f8", shape, eu[0],
                      em if group == "static" else f"{kind} deformations, as in /static",
                      tsince, kind, **_index_units(eu)),
                    S(f"{g}/stress_resultant", "f8", shape, su[0],
                      sm if group == "static" else f"{kind} stress resultants, as in /static",
                      tsince, kind, **_index_units(su))]
            if group == "transient":
                out.append(S(f"{g}/deformation_rate", "f8", shape, ru[0],
                             f"{kind} deformation rates D v (a WHEEL's slip modes: the slip "
                             "velocities)", max(since, (2, 14)), kind, **_index_units(ru)))
    # the rolling contact's watch in the transient (schema 2.15)
    if "WHEEL" in KIND_NAMES:
        g = "transient/elements/WHEEL"
        out += [S(f"{g}/lift_off", "i1", ("time_step", "element"), "1",
                  "1 where the normal force (stress resultant of mode 6) is negative: the "
                  "wheel would lift off, which the bilateral contact cannot represent; else 0",
                  (2, 19), "WHEEL", optional=True),
                S(f"{g}/friction_ratio", "f8", ("time_step", "element"), "1",
                  "friction coefficient the rolling needs, the norm of (s4, s5) over s6 of the "
                  "stress resultants (inf where the normal force is not positive)", (2, 19),
                  "WHEEL",
                  optional=True)]
    # BEAM element properties and cross-sections (schema 1.1)
    b = "model/elements/BEAM"
    out += [
        S(f"{b}/position_rows", "i8", ("element", "end"), "1",
          "rows of /model/position_nodes holding the element's nodes p and q (0-based; a "
          "line-cell connectivity)", v11, "BEAM"),
        S(f"{b}/length", "f8", ("element",), "m", "reference length l0 of each element",
          v11, "BEAM"),
        S(f"{b}/axes", "f8", ("element", "axis", "coordinate"), "1",
          "initial element axes: rows x (p to q), y, z as unit vectors in global axes",
          v11, "BEAM"),
        S(f"{b}/deformation_class", "i1", ("element", "deformation_mode"), "1",
          "class of each deformation mode: 0 rigid, 1 flexible (DYNE), 2 released (RLSE), "
          "3 kinematic (KINE)",
          v11, "BEAM"),
        S(f"{b}/stiffness", "f8", ("element", "stiffness_term"), "1",
          "ESTIFF: EA, GJ, EIy, EIz, cy = EIy/kGA, cz = EIz/kGA (0 where not given; units: "
          "attribute units_per_index)", v11, "BEAM",
          units_v2="N | N m2 | N m2 | N m2 | m2 | m2",
          index_units=("N", "N m^2", "N m^2", "N m^2", "m^2", "m^2"),
          index_dims=("stiffness_term",)),
        S(f"{b}/mass", "f8", ("element", "mass_term"), "1",
          "EM per unit length: rhoA, rho(Iy+Iz), rhoIy, rhoIz, rhoIyz (0 where not given; "
          "units: attribute units_per_index)", v11, "BEAM",
          units_v2="kg/m | kg m | kg m | kg m | kg m",
          index_units=("kg/m", "kg m", "kg m", "kg m", "kg m"), index_dims=("mass_term",)),
        S(f"{b}/cross_section_type", "utf-8", ("element",), "1",
          "cross-section shape of each element: RECT, CIRC, or empty when not known",
          v11, "BEAM"),
        S(f"{b}/cross_section_dims", "f8", ("element", "section_dim"), "m",
          "cross-section dimensions: RECT (w along y, t along z), CIRC (d, NaN); NaN when "
          "not known", v11, "BEAM"),
        S("static/elements/BEAM/max_normal_stress", "f8", ("step", "element"), "Pa",
          "largest magnitude of the normal stress at the surface of each element (NaN: "
          "cross-section not known)", v11, "BEAM", optional=True),
        S("static/elements/BEAM/max_von_mises_stress", "f8", ("step", "element"), "Pa",
          "largest von Mises stress at the surface of each element (NaN: cross-section not "
          "known)", v11, "BEAM", optional=True),
    ]
    # one CRC-32 per committed step and stored dataset of the group (schema 2.1)
    for group, axis0 in (("static", "step"), ("transient", "time_step"),
                         ("eigen", "linearized_step"), ("buckling", "linearized_step"),
                         ("compliance", "linearized_step"), ("state_space", "linearized_step"),
                         ("critical", "linearized_step")):
        out.append(S(f"{group}/integrity/checksum", "i8", (axis0, "checked_dataset"), "1",
                     "CRC-32 of each step's row of the group's datasets (columns: attribute "
                     "columns), stored with the step (in /<group>/checksum before 3.0)",
                     {"state_space": (2, 3), "critical": (2, 4)}.get(group, (2, 1))))
    return out


def _state_space_specs() -> list[DatasetSpec]:
    """``/state_space`` (schema 2.3): the linearized equations in the degrees of freedom and
    the first-order system of SPACAR mode 9 (docs/linearized.md)."""
    S, v = DatasetSpec, (2, 3)
    lin = "linearized_step"
    per_dof = "1"
    specs = [
        S("state_space/step", "i4", (lin,), "1",
          "index of the static step (row of /static) that was linearized; in a "
          "transient_linearized file (SPACAR 3) the row of /transient", v),
        S("state_space/time", "f8", (lin,), "s",
          "time of the linearized state (transient_linearized, SPACAR 3); NaN for a static "
          "step", (2, 6), optional=True),
        S("state_space/dof_element", "i8", ("dof",), "1",
          "deck element number of each degree of freedom (a deformation mode; 0 for a DYNX "
          "coordinate)", v),
        S("state_space/dof_mode", "i4", ("dof",), "1",
          "deformation mode number (1-based) of each degree of freedom; of a DYNX "
          "coordinate its coordinate number", v),
        S("state_space/dof_node", "i8", ("dof",), "1",
          "deck node of each degree of freedom that is a DYNX coordinate (its dof_element is "
          "0), 0 for a deformation mode; only in a file with DYNX coordinates",
          (2, 16), optional=True),
        S("state_space/state_name", "utf-8", ("state",), "1",
          "name of each state: 'BEAM 3 mode 2' (the deformation), then 'rate of BEAM 3 mode "
          "2'", v),
        S("state_space/input_name", "utf-8", ("system_input",), "1",
          "deck line of each input: 'INPUTF i n c'", v),
        S("state_space/output_name", "utf-8", ("system_output",), "1",
          "deck line of each output: 'OUTX i n c', 'OUTXP i n c', 'OUTE i e k', 'OUTEP i e k'",
          v),
        S("state_space/M0", "f8", (lin, "dof", "dof_column"), per_dof,
          "mass matrix in the degrees of freedom", v),
        S("state_space/C0", "f8", (lin, "dof", "dof_column"), per_dof,
          "damping matrix in the degrees of freedom (DAMPING, EDAMP; the velocity-dependent "
          "terms vanish at a static state)", v),
        S("state_space/K0", "f8", (lin, "dof", "dof_column"), per_dof,
          "tangent stiffness K0 + G0 + N0 in the degrees of freedom", v),
        S("state_space/B0", "f8", (lin, "dof", "system_input"), per_dof,
          "input matrix: generalized force on each degree of freedom per unit input", v),
        S("state_space/A", "f8", (lin, "state", "state_column"), per_dof,
          "state matrix of dz/dt = A z + B u, z = [q; dq/dt] (and the kinematic "
          "coordinates p after them: z = [q; dq/dt; p], schema 2.13)", v),
        S("state_space/B", "f8", (lin, "state", "system_input"), per_dof,
          "input matrix of dz/dt = A z + B u", v),
        S("state_space/C", "f8", (lin, "system_output", "state"), per_dof,
          "output matrix of y = C z + D u", v),
        S("state_space/D", "f8", (lin, "system_output", "system_input"), per_dof,
          "feedthrough matrix of y = C z + D u (zero)", v),
        # schema 2.13: the kinematic states of a steady motion (mode 3, TIMESTEP 0 0) and
        # the poles (docs/rolling.md)
        S("state_space/kinematic_name", "utf-8", ("kinematic_state",), "1",
          "deck line of each kinematic coordinate, the last states of A: 'KINE e k', "
          "'KINX n c'", (2, 13), optional=True),
        S("state_space/pole", "c16", (lin, "state"), "s^-1",
          "eigenvalues of A, sorted by real part, then imaginary part; since 2.21 computed "
          "from the second-order equations and refined (docs/linearized.md, Poles)", (2, 13)),
        S("state_space/pole_bound", "f8", (lin, "state"), "s^-1",
          "error bound of each pole of /state_space/pole (docs/linearized.md, Poles); NaN "
          "where none was computed (a steady motion's poles)", (2, 21), optional=True),
        S("state_space/K0p", "f8", (lin, "dof", "kinematic_state"), per_dof,
          "dR/dp: the generalized forces of the kinematic coordinates p", (2, 13)),
        S("state_space/G", "f8", (lin, "kinematic_state", "dof"), per_dof,
          "G = dp'/dq': the kinematic rates of the degrees of freedom's rates", (2, 13)),
        S("state_space/Gq", "f8", (lin, "kinematic_state", "dof"), per_dof,
          "d(p')/dq at the reference rates", (2, 13)),
        S("state_space/Gp", "f8", (lin, "kinematic_state", "kinematic_state_column"), per_dof,
          "d(p')/dp at the reference rates", (2, 13)),
    ]
    from dataclasses import replace
    return [replace(s, units_v2="kg, m, rad, s (per degree of freedom)",
                    attrs=(("units_rule", SS_UNITS_RULE),))
            if s.path.split("/")[1] in _SS_MATRICES else s for s in specs]


#: Every dataset of the schema, by path relative to the root.
DATASETS: dict[str, DatasetSpec] = {s.path: s for s in _spec_list()}

_KIND_RE = re.compile(r"^(model|static|transient)/elements/([^/]+)/")


def spec_for(path: str) -> DatasetSpec | None:
    """The spec of the 2.0 dataset ``path`` (no leading ``/``), or None if not in the
    schema."""
    return DATASETS.get(path.lstrip("/"))


def element_kind_of(path: str) -> str | None:
    """Element kind of a per-kind path, e.g. ``TRUSS`` for ``static/elements/TRUSS/...``."""
    m = _KIND_RE.match(path.lstrip("/"))
    return m.group(2) if m else None

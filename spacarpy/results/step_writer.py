"""Appending the steps of an analysis to a results file: :class:`StepWriter`.

This module's one job is checking and appending one step's rows (a static load step, a time
step, a linearized step's modes, multipliers, compliance or state space, a critical point):
the methods that :class:`~spacarpy.results.writer.ResultsWriter` offers the solvers. The
file's life cycle and layout stay in :mod:`~spacarpy.results.writer` and
:mod:`~spacarpy.results.layout`; the commit protocol in :mod:`~spacarpy.results.steps`.
"""
from __future__ import annotations

import logging
import operator

import numpy as np

from spacarpy.results.layout import state_space_values
from spacarpy.results.schema import n_def

log = logging.getLogger("spacarpy.results.writer")

__all__ = ["StepWriter"]


class StepWriter:
    """The step methods of :class:`~spacarpy.results.writer.ResultsWriter` (a mixin: it
    uses the writer's ``_groups``, ``kinds``, ``_sizes`` and ``_require_open``)."""

    def static_step(self, load_factor: float, position, euler, deformation: dict,
                    stress_resultant: dict, reaction, iterations: int, residual: float,
                    max_normal_stress=None, max_von_mises_stress=None,
                    arc_length=None, converged_by=0, warping=None, stability=-1) -> None:
        """Append one converged static load step and make it durable.

        Parameters
        ----------
        load_factor : float
            Factor on DELXF (load = XF + load_factor * DELXF).
        position, euler, warping : array_like, (n_pos, 3), (n_rot, 4) and (n_warp,)
            Node positions (m), Euler parameters (1), warping coordinates (1/m; None: none).
        deformation, stress_resultant : dict of str -> array_like (n_elem_of_kind, n_def)
            Generalized deformations and stress resultants of every element kind of the
            model, by kind keyword (``"BEAM"``, ``"TRUSS"`` ...).
        reaction : array_like, shape (n_reac,)
            Reactions in the order of ``reaction_component`` (N or N m).
        iterations, residual : int, float
            Newton iterations used, final relative residual.
        max_normal_stress, max_von_mises_stress : array_like, shape (n_beam,), optional
            Largest surface stresses of the BEAM elements (Pa); required when the model has
            cross-sections (:class:`spacarpy.results.stress.SurfaceStress` computes them).
        arc_length : float, optional
            The arc length from step 0 (required in an arc-length run).
        converged_by, stability : int
            ``/static/converged_by`` (0 the tolerance, 1 the round-off floor) and, in an
            arc-length run, ``/static/stability`` (docs/results.md).
        """
        given = {"position": position, "euler": euler, "reaction": reaction, "warping": warping,
                 "arc_length": None if arc_length is None else float(arc_length),
                 "iterations": operator.index(iterations), "residual": float(residual),
                 "converged_by": operator.index(converged_by), "stability": int(stability),
                 "elements/BEAM/max_normal_stress": max_normal_stress,
                 "elements/BEAM/max_von_mises_stress": max_von_mises_stress}
        self._step("static", float(load_factor), given, deformation, stress_resultant)

    def transient_step(self, time: float, position, euler, velocity, euler_rate,
                       deformation: dict, stress_resultant: dict, kinetic_energy: float,
                       elastic_energy: float, external_work: float, iterations: int,
                       residual: float, dissipated_energy: float = 0.0, reaction=None,
                       converged_by: int = 0, deformation_rate=None, acceleration=None,
                       euler_acceleration=None, warping=None, contact=None) -> None:
        """Append one time step (as :meth:`static_step`, plus velocities, energies, ``reaction``
        (required), ``deformation_rate`` (kind -> (n, n_def); zeros where missing), and where the
        group has them the accelerations and ``contact`` (the WHEEL flags)) and make it durable.
        ``converged_by``: 0 the residual met the tolerance, 1 within its round-off floor."""
        given = {"position": position, "euler": euler, "velocity": velocity, "warping": warping,
                 "acceleration": acceleration, "euler_acceleration": euler_acceleration,
                 "euler_rate": euler_rate, "kinetic_energy": kinetic_energy,
                 "elastic_energy": elastic_energy, "external_work": external_work,
                 "dissipated_energy": float(dissipated_energy), "reaction": reaction,
                 "iterations": operator.index(iterations), "residual": float(residual),
                 "converged_by": operator.index(converged_by)}
        rates = deformation_rate or {}
        given.update({f"elements/{k}/deformation_rate": rates.get(k, np.zeros((n, n_def(k))))
                      for k, n in self.kinds.items()})
        n_w = self.kinds.get("WHEEL")
        for name, fill in (("lift_off", 0), ("friction_ratio", np.nan)) if n_w is not None else ():
            given[f"elements/WHEEL/{name}"] = (contact or {}).get(name, np.full(n_w, fill))
        self._step("transient", float(time), given, deformation, stress_resultant)

    def eigen_step(self, step: int, eigenvalue, frequency, kind, shape_position,
                   shape_euler, n_available: int | None = None, bound=np.nan) -> None:
        """Append the modes of one linearized static step (``step`` = its row in /static).

        Arrays may hold fewer modes than the group was created for; missing ones are NaN
        (kind 4). ``eigenvalue`` is complex (omega^2), ``shape_*`` (n_mode, n_pos, 3) and
        (n_mode, n_rot, 4). ``n_available``: the finite modes the linearization has
        (``/eigen/n_modes_available``; -1: not counted; default: the finite modes given);
        ``bound`` each eigenvalue's error bound (``/eigen/eigenvalue_bound``)."""
        lam = np.asarray(eigenvalue, dtype=complex)
        if n_available is None:
            n_available = int(np.sum(np.asarray(kind) != 4))
        self._append_linearized("eigen", step, {
            "frequency": frequency, "eigenvalue_real": lam.real, "eigenvalue_imag": lam.imag,
            "kind": kind, "shape_position": shape_position, "shape_euler": shape_euler,
            "n_modes_available": n_available, "eigenvalue_bound": bound})

    def buckling_step(self, step: int, load_multiplier, critical: float, shape_position,
                      shape_euler, kind=None) -> None:
        """Append the buckling multipliers and shapes of one linearized static step.

        ``kind`` (n_mode,): 0 finite, 4 infinite (default: 4 where the multiplier is NaN);
        missing modes are NaN of kind 4."""
        if kind is None:
            kind = np.where(np.isnan(np.asarray(load_multiplier, dtype=float)), 4, 0)
        self._append_linearized("buckling", step, {
            "load_multiplier": load_multiplier, "critical_load_multiplier": critical,
            "kind": kind, "shape_position": shape_position, "shape_euler": shape_euler})

    def critical_step(self, step: int, point_type: int, load_factor: float, arc_length: float,
                      shape_position, shape_euler, margin: float = np.nan,
                      bound: float = np.nan) -> None:
        """Append a critical point of an arc-length run: ``step`` is the row of /static
        holding it, ``point_type`` a code of :data:`CRITICAL_POINT_NAMES`, the shapes
        (n_pos, 3) and (n_rot, 4)."""
        self._append_linearized("critical", step, {
            "point_type": np.int8(point_type), "load_factor": float(load_factor),
            "arc_length": float(arc_length), "margin": float(margin), "bound": float(bound),
            "shape_position": np.asarray(shape_position, float)[None],
            "shape_euler": np.asarray(shape_euler, float)[None]})

    def compliance_step(self, step: int, global_, local) -> None:
        """Append the 6x6 nodal compliance (global and body axes) of one linearized step."""
        self._append_linearized("compliance", step, {"global": global_, "local": local})

    def state_space_step(self, step: int, ss, time: float = np.nan) -> None:
        """Append the linearized equations of one static step (or, with ``time``, of row
        ``step`` of /transient, SPACAR mode 3): ``ss`` has the attributes M0, C0, K0, B0, A,
        B, C, D (:class:`spacarpy.solvers.linear.state_space.StateSpace`)."""
        values = state_space_values(ss, self._sizes["kinematic_state"])
        values["time"] = time
        self._append_linearized("state_space", step, values)

    def _step(self, group: str, value: float, given: dict, deformation, stress) -> None:
        self._require_open(f"{group}_step")
        if group not in self._groups:
            raise RuntimeError(f"{group}_step called before begin_static"
                               + ("(transient=True)" if group == "transient" else ""))
        entry = self._groups[group]
        for what, values in (("deformation", deformation), ("stress_resultant", stress)):
            if values is None:
                values = {}
            if not isinstance(values, dict):
                raise TypeError(f"{group}_step: {what} must be a dict kind -> (n, n_def) "
                                f"array, e.g. {{'BEAM': e}}")
            if not values.keys() <= self.kinds.keys():
                extra = sorted(set(values) - set(self.kinds))
                raise ValueError(f"{group}_step: {what} of {extra}, which the model has not")
            for kind, n in self.kinds.items():
                # a kind the model has no elements of (the BEAM group is always written)
                given[f"elements/{kind}/{what}"] = values.get(
                    kind, np.zeros((0, n_def(kind))) if n == 0 else None)
        rows = {}
        for name, dtype, shape in entry["rows"]:
            data = given.get(name)
            if data is None:
                raise ValueError(f"{group}_step: {name} is missing")
            row = np.asarray(data, dtype=dtype)
            if row.shape != shape:
                raise ValueError(f"{group}_step: {name} has shape {row.shape}, "
                                 f"expected {shape}")
            rows[name] = row
        k = entry["n"]
        entry["appender"].append(rows, value, k)
        entry["n"] = k + 1
        entry["last"] = value
        if group == "static":
            log.debug("static step %d written (load factor %g)", k, value)

    def _append_linearized(self, group, step, values) -> None:
        self._require_open(f"{group}_step")
        if group not in self._groups:
            raise RuntimeError(f"{group}_step: begin_static was called without "
                               f"n_{group}_modes")
        entry = self._groups[group]
        rows = {}
        for name, value in values.items():
            trailing, dtype = entry["shapes"][name], entry["dtypes"][name]
            fill = 4 if name == "kind" else np.nan if dtype.kind in "fc" else -1
            row = np.full(trailing, fill, dtype=dtype)
            given = np.asarray(value, dtype=dtype)
            if given.ndim:
                row[tuple(slice(0, min(a, b)) for a, b in zip(given.shape, trailing))] = \
                    given[tuple(slice(0, b) for b in trailing)]
            else:
                row[...] = given
            rows[name] = row
        k = entry["n"]
        entry["appender"].append(rows, int(step), k)
        entry["n"] = k + 1

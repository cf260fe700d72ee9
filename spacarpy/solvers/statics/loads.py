"""The loads of a static or transient problem at one point of the load path.

:class:`Loads` holds what the model's load lines give (dead forces and moments split into
their XF and DELXF parts, gravity, prescribed deformations) and builds from it, for load
parameters ``(a, s)`` (``a`` on the initial XF load, ``s`` on the DELXF increments), a frozen
:class:`LoadState`. A LoadState is what the equilibrium evaluation takes as its load: the
problem object carries no load of its own.

A user routine's loads (USERSIG, docs/user-routines.md) depend on the state: they arrive as
a plain callable ``user(t, x, v, states) -> (n_coord,)`` (:attr:`Loads.user`, set by the
driver), and a LoadState carries it bound to its time and velocities (:attr:`LoadState.user`:
``user(x, states)``, a :class:`BoundUser`), evaluated at every configuration the solvers try;
bound at rest (statics) it also gives its derivative ``d f/dx`` for the Newton matrix
(:meth:`BoundUser.tangent`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spacarpy.solvers.statics.nodal import nodal_masses, node_rows


@dataclass(frozen=True)
class LoadState:
    """The load at load parameters ``(a, s)``.

    Attributes
    ----------
    a, s : float
        The factors on the XF load and on the DELXF increments.
    force : (n_coord,)
        Dead nodal forces ``a XF + s DELXF`` in global axes (zero on Euler parameters).
    moment : (n_m, 3)
        Dead moments of the loaded orientation nodes (:attr:`Loads.moment_rot`).
    gravity_factor : float
        Factor on gravity: applied with the initial load (``a``), then constant.
    rigid_target : (n_rigid,)
        Values the rigid-mode constraints hold: zero for ordinary rigid modes, the
        prescribed deformations (INPUTE/DELINPE) at ``(a, s)``.
    user : callable or None
        The user routine's loads at this load's time and velocities: ``user(x, states)``
        gives the generalized forces (n_coord,) at configuration x (``states``: the element
        kernels' states at x), added to the dead ones; None without a routine.
    """

    a: float
    s: float
    force: np.ndarray
    moment: np.ndarray
    gravity_factor: float
    rigid_target: np.ndarray
    user: object = None


class Loads:
    """Dead loads of the model split into XF and DELXF parts, in global coordinates, plus
    gravity (nodal point masses and the element masses, :attr:`gravity`) and the prescribed
    deformations; :meth:`at` gives the :class:`LoadState` at load parameters ``(a, s)``."""

    def __init__(self, model, num):
        self.num = num
        pos_row, rot_row = node_rows(model)
        self.force = {k: np.zeros(num.n_coord) for k in ("XF", "DELXF")}
        moment = {k: np.zeros((model.orientation_ids.size, 3)) for k in ("XF", "DELXF")}
        for ld in model.loads:
            n = int(ld.node)
            if n in pos_row:
                self.force[ld.kind][num.pos_idx[pos_row[n]]] += ld.value
            else:
                moment[ld.kind][rot_row[n]] += ld.value
        loaded = np.flatnonzero(np.any(moment["XF"] != 0, axis=1)
                                | np.any(moment["DELXF"] != 0, axis=1))
        self.moment_rot = loaded                            # orientation-node indices
        self.moment = {k: v[loaded] for k, v in moment.items()}
        self.has_xf = bool(np.any(self.force["XF"]) or np.any(self.moment["XF"]))
        # gravity belongs to the initial load, reached in phase A
        self.has_xf = self.has_xf or bool(np.any(model.gravity))
        self.any = self.has_xf or bool(np.any(self.force["DELXF"]) or np.any(self.moment["DELXF"]))
        # gravity: the weights of the nodal point masses here, the elements' in their kinds
        self.gravity = np.asarray(model.gravity, dtype=float)
        self.has_gravity = bool(np.any(self.gravity))
        point = nodal_masses(model, num)
        self.point_weight = np.zeros(num.n_coord)
        for idx, m in zip(point.point_idx, point.point_mass):
            self.point_weight[idx] += m * self.gravity
        self.user = None

    def set_user(self, user) -> None:
        """Add a user routine's loads: ``user(t, x, v, states) -> (n_coord,)`` generalized
        forces (forces on positions, Euler-parameter forces on orientation nodes). In a
        static analysis ``t`` is the load factor of the DELXF increments and ``v`` is None."""
        self.user = user
        if user is not None:
            self.any = True

    def bind(self, t: float, v) -> object:
        """The user loads at time t and velocities v, as a function of (x, states); None
        without a routine."""
        return None if self.user is None else BoundUser(self.user, float(t), v)

    def at(self, a: float, s: float, gravity_factor: float | None = None) -> LoadState:
        """The load ``a * XF + s * DELXF`` with gravity times ``gravity_factor`` (default
        ``a``) and the prescribed deformations at ``(a, s)``."""
        return LoadState(a=float(a), s=float(s),
                         force=a * self.force["XF"] + s * self.force["DELXF"],
                         moment=a * self.moment["XF"] + s * self.moment["DELXF"],
                         gravity_factor=float(a if gravity_factor is None else gravity_factor),
                         rigid_target=self.num.rigid_targets(a, s),
                         user=self.bind(s, None))

    def unloaded(self) -> LoadState:
        """No load at all: no forces, moments or gravity, rigid modes held at zero."""
        return LoadState(a=0.0, s=0.0, force=np.zeros(self.num.n_coord),
                         moment=np.zeros((self.moment_rot.size, 3)), gravity_factor=0.0,
                         rigid_target=np.zeros(self.num.n_rigid))


class BoundUser:
    """A user routine's loads bound to a time t and velocities v (None: at rest, a static
    analysis): ``f = bound(x, states)``."""

    def __init__(self, user, t: float, v):
        self.user, self.t, self.v = user, t, v

    @property
    def static(self) -> bool:
        """Bound at rest: the static problem's Newton matrix takes its derivative."""
        return self.v is None

    def __call__(self, x, states):
        return self.user(self.t, x, self.v, states)

    def tangent(self, x, states, cols):
        """``d f/dx`` (sparse, n_coord rows, the columns ``cols``) at x, or None where the
        routine's adapter has no derivative (a plain callable)."""
        tangent = getattr(self.user, "tangent", None)
        return None if tangent is None else tangent(self.t, x, self.v, states, 0.0, cols)


__all__ = ["BoundUser", "LoadState", "Loads"]

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

Follower loads (XFL/DELXFL, and any load whose force depends on the configuration) are
:class:`~spacarpy.solvers.statics.follower.LoadPart` s in :attr:`Loads.parts`, with initial and
incremental amplitudes; a LoadState carries their amplitudes at its factors
(:attr:`LoadState.follow`), :meth:`Loads.part_forces` gives their forces at x and
:meth:`Loads.part_blocks` their load stiffness ``-df/dx`` for the Newton matrix.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from spacarpy.elements.line_load import lump_line_load
from spacarpy.elements.registry import kind_of
from spacarpy.rotation import moment_matrix
from spacarpy.solvers.statics.follower import nodal_followers
from spacarpy.solvers.statics.follower_lines import line_followers
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
    follow : tuple of (n_b, k) arrays
        The amplitudes of the follower load parts (:attr:`Loads.parts`, in their order) at
        ``(a, s)``; empty without follower loads.
    """

    a: float
    s: float
    force: np.ndarray
    moment: np.ndarray
    gravity_factor: float
    rigid_target: np.ndarray
    user: object = None
    follow: tuple = ()


class Loads:
    """Dead loads of the model split into XF and DELXF parts, in global coordinates, plus
    gravity (nodal point masses and the element masses, :attr:`gravity`) and the prescribed
    deformations; :meth:`at` gives the :class:`LoadState` at load parameters ``(a, s)``."""

    def __init__(self, model, num):
        self.num = num
        pos_row, rot_row = node_rows(model)
        self.force = {k: np.zeros(num.n_coord) for k in ("XF", "DELXF")}
        moment = {k: np.zeros((model.orientation_ids.size, 3)) for k in ("XF", "DELXF")}
        # the increments that follow a named time function (LOADTF), by name
        named = {}
        for ld in model.loads:
            n = int(ld.node)
            force, mom = self.force[ld.kind], moment[ld.kind]
            if ld.kind == "DELXF" and ld.tf is not None:
                force, mom = named.setdefault(ld.tf, _zero_part(num, model))
            if n in pos_row:
                force[num.pos_idx[pos_row[n]]] += ld.value
            else:
                mom[rot_row[n]] += ld.value
        for kind, tf, pos, f, rot, m in line_load_parts(model):
            force, mom = self.force[kind], moment[kind]
            if tf is not None:
                force, mom = named.setdefault(tf, _zero_part(num, model))
            np.add.at(force, num.pos_idx[pos], f)
            np.add.at(mom, rot, m)
        # DELXF (all increments: the static path's); named: the parts with their own
        # function (transient), each also in DELXF
        self.default_force, default_moment = self.force["DELXF"].copy(), moment["DELXF"]
        moment["DELXF"] = default_moment.copy()
        for force, mom in named.values():
            self.force["DELXF"] += force
            moment["DELXF"] += mom
        loaded = np.flatnonzero(np.any(moment["XF"] != 0, axis=1)
                                | np.any(moment["DELXF"] != 0, axis=1))
        self.moment_rot = loaded                            # orientation-node indices
        self.moment = {k: v[loaded] for k, v in moment.items()}
        self.default_moment = default_moment[loaded]
        self.named = {name: (force, mom[loaded]) for name, (force, mom) in named.items()}
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
        # configuration-dependent (follower) loads: XFL/DELXFL, follower.py
        self.parts = (nodal_followers(model, num, pos_row, rot_row)
                      + line_followers(model, num, pos_row, rot_row))
        if self.parts:
            self.has_xf = self.has_xf or any(bool(np.any(p.initial)) for p in self.parts)
            self.any = self.any or self.has_xf or any(bool(np.any(p.increment))
                                                      for p in self.parts)

    def add_part(self, part) -> None:
        """Add a configuration-dependent load part (a
        :class:`~spacarpy.solvers.statics.follower.LoadPart`); before the static problem
        builds its sparsity pattern."""
        self.parts.append(part)
        self.has_xf = self.has_xf or bool(np.any(part.initial))
        self.any = self.any or self.has_xf or bool(np.any(part.increment))

    @property
    def uses_named(self) -> bool:
        """Whether a load increment (DELXF, DELQE, DELXFL) names its own time function."""
        return bool(self.named) or any(p.named for p in self.parts)

    @property
    def has_increment(self) -> bool:
        """Whether the load steps add a load (DELXF, DELXFL or another part's increment)."""
        return bool(np.any(self.force["DELXF"]) or np.any(self.moment["DELXF"])
                    or any(np.any(p.increment) for p in self.parts))

    def part_forces(self, x, load: LoadState):
        """The generalized forces (n_coord,) of the follower parts at x under ``load``; None
        without parts."""
        if not self.parts or not load.follow:
            return None
        n = self.num.n_coord
        out = np.zeros(n)
        for part, amp in zip(self.parts, load.follow):
            if np.any(amp):
                out += part.force(x, amp, n)
        return out

    def part_blocks(self, x, load: LoadState) -> list:
        """The load stiffness ``-d f/dx`` of each part at x under ``load`` ((n_b, p, q) per
        part, zeros where its amplitude is zero): the blocks the Newton matrix adds."""
        out = []
        for i, part in enumerate(self.parts):
            amp = load.follow[i] if load.follow else None
            if amp is None or not np.any(amp):
                out.append(np.zeros(part.rows.shape + (part.cols.shape[1],)))
            else:
                out.append(-part.stiffness(x, amp))
        return out

    def rate(self, x):
        """``d f_ext / ds`` at x (n_coord,): the DELXF forces, the generalized forces of the
        DELXF moments and the forces of the follower increments (DELXFL) at x."""
        num = self.num
        out = self.force["DELXF"].copy()
        if self.moment_rot.size:
            idx = num.rot_idx[self.moment_rot]
            out[idx] += 2.0 * np.einsum("nab,nb->na", moment_matrix(self.moment["DELXF"]),
                                        x[idx])
        for part in self.parts:
            if np.any(part.increment):
                out += part.force(x, part.increment, num.n_coord)
        return out

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
                         user=self.bind(s, None),
                         follow=tuple(p.amplitude(a, s) for p in self.parts))

    def at_time(self, phi: dict) -> LoadState:
        """The load of a transient run at time functions' values ``phi`` (name -> value;
        None: the deck's function): XF, the increments that name no function times
        ``phi[None]``, each named part times its function's value, and the prescribed
        deformations at their functions' values (:meth:`at` ``(1, phi[None])`` where
        nothing names a function)."""
        load = self.at(1.0, phi[None])
        if any(p.named for p in self.parts):
            load = replace(load, follow=tuple(p.amplitude_at(phi) for p in self.parts))
        if not self.named and not self.num.rigid_tf:
            return load
        force = self.force["XF"] + phi[None] * self.default_force
        moment = self.moment["XF"] + phi[None] * self.default_moment
        for name, (f, m) in self.named.items():
            force = force + phi[name] * f
            moment = moment + phi[name] * m
        target = (self.num.rigid_targets(1.0, np.array([phi[n] for n in self.num.rigid_tf]))
                  if self.num.rigid_tf else load.rigid_target)
        return replace(load, force=force, moment=moment, rigid_target=target)

    def unloaded(self) -> LoadState:
        """No load at all: no forces, moments or gravity, rigid modes held at zero."""
        return LoadState(a=0.0, s=0.0, force=np.zeros(self.num.n_coord),
                         moment=np.zeros((self.moment_rot.size, 3)), gravity_factor=0.0,
                         rigid_target=np.zeros(self.num.n_rigid))


def _zero_part(num, model) -> tuple:
    """Zero (force, moment) arrays of one named part of the load increments."""
    return np.zeros(num.n_coord), np.zeros((model.orientation_ids.size, 3))


def _rows(ids, nodes):
    """The rows of deck numbers ``nodes`` in ``ids`` (all present)."""
    order = np.argsort(ids, kind="stable")
    return order[np.searchsorted(ids, nodes, sorter=order)]


def line_load_parts(model):
    """The line loads (QE/DELQE) lumped at the nodes (:func:`~spacarpy.elements.line_load.
    lump_line_load`, in the reference configuration), grouped by (kind, time function):
    a list of ``(kind, tf, pos_rows, forces, rot_rows, moments)``, ``kind`` "XF" for QE and
    "DELXF" for DELQE, rows of the position and orientation nodes (``num.pos_idx``,
    ``num.rot_idx``) with their (m, 3) forces and moments."""
    if not model.line_loads:
        return []
    element = np.array([ld.element for ld in model.line_loads], dtype=np.int64)
    q_p = np.array([ld.q_p for ld in model.line_loads], dtype=float)
    q_q = np.array([ld.q_q for ld in model.line_loads], dtype=float)
    group = [("XF" if ld.kind == "QE" else "DELXF", ld.tf) for ld in model.line_loads]
    ends = np.zeros((element.size, 4), dtype=np.int64)      # p, r, q, s (deck numbers)
    for keyword, es in model.elements.items():
        hit = np.isin(element, es.ids)
        if not hit.any():
            continue
        slots = kind_of(keyword).slots
        pick = [slots.index("pos"), slots.index("rot"),
                len(slots) - 1 - slots[::-1].index("pos"),
                len(slots) - 1 - slots[::-1].index("rot")]
        ends[hit] = es.nodes[_rows(es.ids, element[hit])][:, pick]
    pos = _rows(model.position_ids, ends[:, [0, 2]])
    rot = _rows(model.orientation_ids, ends[:, [1, 3]])
    f_p, f_q, m_p, m_q = lump_line_load(model.position_x0[pos[:, 0]],
                                        model.position_x0[pos[:, 1]], q_p, q_q)
    out = []
    for key in dict.fromkeys(group):
        sel = np.array([g == key for g in group])
        out.append((*key, pos[sel].T.ravel(), np.concatenate([f_p[sel], f_q[sel]]),
                    rot[sel].T.ravel(), np.concatenate([m_p[sel], m_q[sel]])))
    return out


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


__all__ = ["BoundUser", "LoadState", "Loads", "line_load_parts"]

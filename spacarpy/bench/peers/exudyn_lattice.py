"""The 3D beam lattice of ``spacarpy bench --cases lattice`` solved with the peer code Exudyn
(``--peer exudyn``).

The problem is :func:`spacarpy.bench.decks.lattice_deck`'s: ``kx x ky x m`` grid points
0.1 m apart, a beam between neighbours along x, y and z (square 0.01 m, steel, shear factor
5/6, the same section as the deck's ESTIFF), the bottom layer clamped, 50 N along +x on every
top node in 2 equal load steps. :func:`lattice` returns the mean displacement along x of the
top nodes (``top_ux``), the quantity spacarpy's bench reports.

Exudyn model (the set-up of :mod:`spacarpy.bench.peers.exudyn_cantilever`):

* Every member is ``mesh`` ``ObjectBeamGeometricallyExact`` elements (two-node, shear
  deformable). Exudyn's element takes its axis and section axes from its node frames, so a
  member's nodes carry a frame whose local x lies along the member: the x members use the grid
  nodes themselves (global frame); the y and z members get their own end nodes, tied to the
  grid node by an ``ObjectJointGeneric`` locking all six axes with marker frames that are
  both global in the reference (the rigid joint of the bend's ``chords`` variant). With one
  element per member Exudyn's beam is about 10 times too stiff on this lattice; 4 to 8 per
  member (``mesh``) converge (the report of issue 36), and the bench extrapolates in ``mesh``.
* Nodes are ``NodeRigidBodyRxyz`` (Tait-Bryan angles, as the cantilever peer's); the z
  members' frame is written with a middle angle of 0 (:data:`_FRAMES`), far from the
  angles' singularity.
* The bottom grid nodes are clamped by six-axis generic joints to ground, loads are
  ``LoadForceVector`` in global coordinates (dead), ``SolveStatic`` with 2 load steps, full
  Newton, the increment test at ``tol`` (m and rad), sparse LU, one thread: the settings of
  the cantilever peer.

Exudyn is imported lazily; without it :func:`lattice` returns ``ok=False`` and the reason.
"""
from __future__ import annotations

import tempfile
import time

import numpy as np

from spacarpy.bench.decks import LATTICE
from spacarpy.bench.peers.exudyn_cantilever import (
    _displacement,
    _not_available,
    _quiet,
    _section,
    _solve_static,
)

#: elements per member of the bench's Exudyn lattice (4 to 8 needed for 1e-4 agreement)
MESH = 4


def _section_stiffness() -> tuple[float, ...]:
    """Exudyn's section stiffness (EA, GAy, GAz, GJ, EIy, EIz) of a lattice member."""
    c = LATTICE
    area, inertia = c["a"] ** 2, c["a"] ** 4 / 12
    g = c["E"] / (2 * (1 + c["nu"]))
    ga = c["kappa"] * g * area
    return (c["E"] * area, ga, ga, g * 0.1406 * c["a"] ** 4, c["E"] * inertia,
            c["E"] * inertia)


#: Tait-Bryan angles (Exudyn's Rxyz) of the member frames, local x along global x, y and z;
#: the z members' frame (90 degrees about x after 90 about z) keeps the middle angle 0, far
#: from the nodes' singularity at 90 degrees about y
_FRAMES = {0: (0.0, 0.0, 0.0), 1: (0.0, 0.0, np.pi / 2), 2: (np.pi / 2, 0.0, np.pi / 2)}


def _rotation(axis: int) -> np.ndarray:
    from exudyn.rigidBodyUtilities import RotXYZ2RotationMatrix
    return np.asarray(RotXYZ2RotationMatrix(list(_FRAMES[axis])))


def _clamp_at(mbs, node: int, position) -> None:
    """Lock all six coordinates of ``node`` (global frame) at ``position``: a six-axis
    generic joint to a ground marker there (the cantilever's clamp is at the origin)."""
    from exudyn.itemInterface import (
        MarkerBodyRigid,
        MarkerNodeRigid,
        ObjectGround,
        ObjectJointGeneric,
    )
    ground = mbs.AddObject(ObjectGround(referencePosition=[0.0, 0.0, 0.0]))
    m_ground = mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground,
                                             localPosition=[float(v) for v in position]))
    m_node = mbs.AddMarker(MarkerNodeRigid(nodeNumber=node))
    mbs.AddObject(ObjectJointGeneric(markerNumbers=[m_ground, m_node],
                                     constrainedAxes=[1, 1, 1, 1, 1, 1]))


def lattice(kx: int, ky: int, m: int, mesh: int = MESH, tol: float = 1e-10) -> dict:
    """The lattice with ``mesh`` Exudyn beams per member: ``top_ux`` (m), ``total`` (solve
    s), ``setup``, ``iterations``, ``ok``, ``reason``, ``peak_mb``."""
    missing = _not_available()
    if missing:
        missing["top_ux"] = float("nan")
        return missing
    import exudyn as exu
    from exudyn.itemInterface import (
        LoadForceVector,
        MarkerNodePosition,
        MarkerNodeRigid,
        NodeRigidBodyRxyz,
        ObjectBeamGeometricallyExact,
        ObjectJointGeneric,
    )
    c = LATTICE
    l = c["l"]                                                 # noqa: E741
    section = _section(exu, _section_stiffness())
    with _quiet():
        t0 = time.perf_counter()
        SC = exu.SystemContainer()
        mbs = SC.AddSystem()

        def add_node(p, axis):
            return mbs.AddNode(NodeRigidBodyRxyz(
                referenceCoordinates=[*map(float, p), *_FRAMES[axis]]))

        def tie(a, b, axis):
            rot = exu.HT(rotation=_rotation(axis).T, translation=[0.0, 0.0, 0.0])
            ma = mbs.AddMarker(MarkerNodeRigid(nodeNumber=a))
            mb = mbs.AddMarker(MarkerNodeRigid(nodeNumber=b, localHT=rot))
            mbs.AddObject(ObjectJointGeneric(markerNumbers=[ma, mb],
                                             constrainedAxes=[1, 1, 1, 1, 1, 1]))

        grid = {}
        for lev in range(m):
            for j in range(ky):
                for i in range(kx):
                    grid[i, j, lev] = add_node((i * l, j * l, lev * l), 0)
        steps = [(1, 0, 0), (0, 1, 0), (0, 0, 1)]
        for (i, j, lev), g in list(grid.items()):
            for axis, d in enumerate(steps):
                q = (i + d[0], j + d[1], lev + d[2])
                if q not in grid:
                    continue
                p0 = np.array([i, j, lev], dtype=float) * l
                if axis == 0:
                    ends = (g, grid[q])
                else:
                    ends = (add_node(p0, axis), add_node(p0 + np.array(d) * l, axis))
                    tie(g, ends[0], axis)
                    tie(grid[q], ends[1], axis)
                chain = [ends[0]] + [add_node(p0 + np.array(d) * l * s / mesh, axis)
                                     for s in range(1, mesh)] + [ends[1]]
                for a, b in zip(chain[:-1], chain[1:]):
                    mbs.AddObject(ObjectBeamGeometricallyExact(
                        nodeNumbers=[a, b], length=l / mesh, sectionData=section))
        for j in range(ky):
            for i in range(kx):
                _clamp_at(mbs, grid[i, j, 0], (i * l, j * l, 0.0))
                marker = mbs.AddMarker(MarkerNodePosition(nodeNumber=grid[i, j, m - 1]))
                mbs.AddLoad(LoadForceVector(markerNumber=marker,
                                            loadVector=[c["F"], 0.0, 0.0]))
        mbs.Assemble()
        setup = time.perf_counter() - t0
    top = [grid[i, j, m - 1] for j in range(ky) for i in range(kx)]
    with tempfile.TemporaryDirectory(prefix="exudyn_peer_") as tmp:
        res = _solve_static(exu, mbs, top[0], c["steps"], tol, setup, tmp)
    res["top_ux"] = (float(np.mean([_displacement(exu, mbs, n)[0] for n in top]))
                     if res["ok"] else float("nan"))
    res["mesh"] = mesh
    del SC
    return res


def extrapolated(kx: int, ky: int, m: int, meshes=(MESH, 2 * MESH)) -> dict:
    """The lattice with ``meshes`` (coarse, fine) Exudyn beams per member, and ``top_ux``
    extrapolated to the converged mesh (Richardson, second order: Exudyn's two-node beam
    converges as the square of the element length, measured on the 1 x 1 x m column:
    errors 1.6e-2, 3.9e-3 and 9.7e-4 with 4, 8 and 16 beams per member). ``total``,
    ``iterations`` and ``peak_mb`` are the fine mesh's solve (the one a user would run);
    ``coarse`` holds the coarse mesh's result."""
    coarse = lattice(kx, ky, m, mesh=meshes[0])
    if not coarse["ok"]:
        return coarse
    fine = lattice(kx, ky, m, mesh=meshes[1])
    if fine["ok"]:
        ratio = (meshes[1] / meshes[0]) ** 2
        fine["top_ux"] += (fine["top_ux"] - coarse["top_ux"]) / (ratio - 1)
    fine["coarse"] = coarse
    return fine

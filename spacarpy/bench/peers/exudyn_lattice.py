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
import scipy.sparse as sp

from spacarpy.bench.decks import LATTICE
from spacarpy.bench.peers.exudyn_cantilever import (
    MAX_ITER,
    _displacement,
    _not_available,
    _quiet,
    _result,
    _section,
    _settings,
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


def _model(exu, kx: int, ky: int, m: int, mesh: int):
    """Exudyn's lattice, assembled: ``(SC, mbs, top)`` with the top grid nodes' numbers."""
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
    return SC, mbs, [grid[i, j, m - 1] for j in range(ky) for i in range(kx)]


def lattice(kx: int, ky: int, m: int, mesh: int = MESH, tol: float = 1e-10) -> dict:
    """The lattice with ``mesh`` Exudyn beams per member: ``top_ux`` (m), ``total`` (solve
    s), ``setup``, ``iterations``, ``ok``, ``reason``, ``peak_mb``."""
    missing = _not_available()
    if missing:
        missing["top_ux"] = float("nan")
        return missing
    import exudyn as exu
    with _quiet():
        t0 = time.perf_counter()
        SC, mbs, top = _model(exu, kx, ky, m, mesh)
        setup = time.perf_counter() - t0
    with tempfile.TemporaryDirectory(prefix="exudyn_peer_") as tmp:
        res = _solve_static(exu, mbs, top[0], LATTICE["steps"], tol, setup, tmp)
    res["top_ux"] = (float(np.mean([_displacement(exu, mbs, n)[0] for n in top]))
                     if res["ok"] else float("nan"))
    res["mesh"] = mesh
    del SC
    return res


def _exudyn_jacobian(exu, mbs, beams, joints, n2: int, pattern) -> sp.csr_matrix:
    """Exudyn's Newton matrix ``[[-K, C^T], [C, 0]]`` at the current state (its own sign
    convention, checked against ``GetSystemJacobian``): the beams' ``JacobianODE2`` and the
    joints' ``ConstraintJacobian`` from ``ComputeItem``, scattered on ``pattern``."""
    jac, cons = exu.ComputeItemType.JacobianODE2, exu.ComputeItemType.ConstraintJacobian
    vals = [-np.asarray(mbs.ComputeItem(exu.ObjectIndex(i), jac)).ravel() for i in beams[0]]
    for i in joints[0]:
        c = np.asarray(mbs.ComputeItem(exu.ObjectIndex(i), cons))
        vals.append(c.T.ravel())
        vals.append(c.ravel())
    rows, cols, perm, shape = pattern
    data = np.bincount(perm, weights=np.concatenate(vals), minlength=len(rows))
    return sp.csr_matrix((data, cols, rows), shape=shape)


def _newton_pattern(sd, beams, joints, n2: int):
    """CSR pattern of the Newton matrix and the map of the per-item values onto it."""
    r, c = [], []
    for i in beams[0]:
        ltg = np.asarray(sd.GetObjectLTGODE2(i))
        r.append(np.repeat(ltg, len(ltg)))
        c.append(np.tile(ltg, len(ltg)))
    for i in joints[0]:
        q = np.asarray(sd.GetObjectLTGODE2(i))
        a = np.asarray(sd.GetObjectLTGAE(i)) + n2
        r.append(np.repeat(q, len(a)))          # C^T: rows q, columns a
        c.append(np.tile(a, len(q)))
        r.append(np.repeat(a, len(q)))          # C: rows a, columns q
        c.append(np.tile(q, len(a)))
    n = n2 + sd.AEsize()
    r, c = np.concatenate(r), np.concatenate(c)
    key = r.astype(np.int64) * n + c
    uniq, perm = np.unique(key, return_inverse=True)
    ur, uc = np.divmod(uniq, n)
    rows = np.searchsorted(ur, np.arange(n + 1))
    return rows, uc, perm, (n, n)


def _refined(lu, jac, rhs, steps: int = 10) -> np.ndarray:
    """``jac^-1 rhs`` by PARDISO's LU and iterative refinement: with the constraints' zero
    diagonal block PARDISO perturbs small pivots, and its solve alone stalls Newton near
    1e-8 m (measured on the 1 020-beam lattice with one beam per member)."""
    x = lu.solve(rhs)
    scale = np.abs(rhs).max()
    for _ in range(steps):
        r = rhs - jac @ x
        if np.abs(r).max() <= 1e-15 * scale:
            break
        x += lu.solve(r)
    return x


def lattice_newton(kx: int, ky: int, m: int, mesh: int = MESH, tol: float = 1e-11) -> dict:
    """Exudyn's lattice equations solved by Newton with MKL PARDISO's sparse LU.

    Exudyn's own ``SolveStatic`` (:func:`lattice`) factorizes with Eigen's SparseLU, whose
    fill on a 3D graph makes its converged meshes take hours at 3x10^4 beams and more memory
    than the 2-core machine has at 10^5. Here the equations are Exudyn's own: the residual
    is Exudyn's ``ComputeNewtonResidual`` at the load factor, the Newton matrix is Exudyn's,
    assembled from its items' ``JacobianODE2`` and ``ConstraintJacobian``
    (:func:`_exudyn_jacobian`); only the linear solve differs (PARDISO LU, nested
    dissection). The same 2 load steps, full Newton, until the largest increment is below
    ``tol`` (m, rad) and the residual stops falling. The root is therefore Exudyn's discrete
    answer, to the Newton tolerance (checked against :func:`lattice` in tests/test_lattice.py).
    Returns ``top_ux``, ``total`` (s, Newton), ``setup`` (s, the Exudyn model),
    ``iterations``, ``unknowns``, ``factor_entries``, ``ok``, ``reason``, ``peak_mb``."""
    missing = _not_available()
    if missing:
        missing["top_ux"] = float("nan")
        return missing
    import exudyn as exu

    from spacarpy.solvers.linalg.pardiso import UNSYMMETRIC, Pardiso, available
    if not available():
        return _result(total=None, setup=None, iterations=None, tip=None, ok=False,
                       reason="MKL PARDISO is not available") | {"top_ux": float("nan")}
    with _quiet():
        t0 = time.perf_counter()
        SC, mbs, top = _model(exu, kx, ky, m, mesh)
        setup = time.perf_counter() - t0
    with tempfile.TemporaryDirectory(prefix="exudyn_peer_") as tmp, _quiet():
        t0 = time.perf_counter()
        sd = mbs.systemData
        n2, nae = sd.ODE2Size(), sd.AEsize()
        kinds: dict[str, list[int]] = {}
        for i in range(sd.NumberOfObjects()):
            kinds.setdefault(mbs.GetObject(i)["objectType"], []).append(i)
        beams, joints = (kinds.get("BeamGeometricallyExact3D", []),), \
            (kinds.get("JointGeneric", []),)
        pattern = _newton_pattern(sd, beams, joints, n2)
        s = _settings(exu, tmp)
        solver = exu.MainSolverStatic()
        solver.InitializeSolver(mbs, s)
        cur = exu.ConfigurationType.Current
        x = np.concatenate([sd.GetODE2Coordinates(configuration=cur),
                            sd.GetAECoordinates(configuration=cur)])
        lu = Pardiso(pattern[0], pattern[1], mtype=UNSYMMETRIC)
        iterations, ok, reason = 0, True, ""
        n_steps = LATTICE["steps"]
        try:
            for k in range(1, n_steps + 1):
                solver.it.currentTime = k / n_steps          # the load factor (endTime 1)
                for _ in range(MAX_ITER):
                    sd.SetODE2Coordinates(x[:n2], configuration=cur)
                    sd.SetAECoordinates(x[n2:], configuration=cur)
                    solver.ComputeNewtonResidual(mbs, s)
                    res = np.asarray(solver.GetSystemResidual())
                    jac = _exudyn_jacobian(exu, mbs, beams, joints, n2, pattern)
                    lu.factorize(jac.data)
                    dx = _refined(lu, jac, res)
                    x -= dx
                    iterations += 1
                    if np.abs(dx[:n2]).max() < tol:
                        break
                else:
                    ok, reason = False, f"Newton did not converge in {MAX_ITER} iterations"
                    break
            sd.SetODE2Coordinates(x[:n2], configuration=cur)
            sd.SetAECoordinates(x[n2:], configuration=cur)
            entries = lu.factor_entries
        finally:
            lu.release()
        total = time.perf_counter() - t0
    out = _result(total=total, setup=setup, iterations=iterations, tip=None, ok=ok,
                  reason=reason)
    ux = [sd.GetNodeLTGODE2(n)[0] for n in top]
    out.update(top_ux=float(np.mean(x[ux])) if ok else float("nan"), mesh=mesh,
               unknowns=n2 + nae, factor_entries=entries)
    del SC
    return out


#: default wall-clock limit (s) of Exudyn's own solve in the bench (``--peer-limit``)
OWN_LIMIT = 900.0


def own_solve(kx: int, ky: int, m: int, mesh: int = MESH, limit: float = OWN_LIMIT,
              memory: int | None = None) -> dict:
    """Exudyn's own ``SolveStatic`` (:func:`lattice`) as a user runs it: a fresh Python
    process (``python -m spacarpy.bench.peers.exudyn_lattice KX KY M MESH``), stopped when it
    has run ``limit`` seconds or its resident memory passes ``memory`` bytes (default: 80 %
    of the memory available at the start; Linux only), so that a size where Eigen's LU of
    the 3D graph takes hours or more memory than the machine has is a lower bound, not a
    hung or swapping machine. Returns :func:`lattice`'s keys and ``whole`` (the process's
    wall seconds), ``stopped`` ("time", "memory" or None) and ``limit``."""
    import json
    import subprocess
    import sys

    from spacarpy.memory import available_bytes
    if memory is None:
        avail = available_bytes()
        memory = int(0.8 * avail) if avail else None
    cmd = [sys.executable, "-m", "spacarpy.bench.peers.exudyn_lattice",
           str(kx), str(ky), str(m), str(mesh)]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    stopped, rss_max = None, 0
    while proc.poll() is None:
        try:
            proc.wait(timeout=min(0.5, limit / 20))
        except subprocess.TimeoutExpired:
            pass
        rss = _resident_bytes(proc.pid)
        rss_max = max(rss_max, rss or 0)
        if proc.poll() is None and time.perf_counter() - t0 > limit:
            stopped = "time"
        elif proc.poll() is None and memory and rss and rss > memory:
            stopped = "memory"
        if stopped:
            proc.kill()
            proc.wait()
            break
    whole = time.perf_counter() - t0
    out = proc.stdout.read() if proc.stdout else ""
    if stopped:
        what = (f"{limit:.0f} s" if stopped == "time"
                else f"{rss_max / 2**30:.1f} GB resident (80 % of the available memory)")
        return dict(ok=False, stopped=stopped, limit=limit, whole=None, total=None,
                    iterations=None, top_ux=float("nan"), peak_mb=rss_max / 2**20,
                    reason=f"Exudyn's own solve stopped after {whole:.0f} s at {what}")
    try:
        res = json.loads(out.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return dict(ok=False, stopped=None, limit=limit, whole=None, total=None,
                    iterations=None, top_ux=float("nan"), peak_mb=None,
                    reason=f"Exudyn's process ended with code {proc.returncode}")
    res.update(whole=whole, stopped=None, limit=limit)
    return res


def _resident_bytes(pid: int) -> int | None:
    """Resident memory of process ``pid`` (Linux /proc), None elsewhere."""
    import os
    try:
        with open(f"/proc/{pid}/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def extrapolated(kx: int, ky: int, m: int, meshes=(MESH, 2 * MESH),
                 newton: bool | None = None) -> dict:
    """The lattice with ``meshes`` (coarse, fine) Exudyn beams per member, and ``top_ux``
    extrapolated to the converged mesh (Richardson, second order: Exudyn's two-node beam
    converges as the square of the element length, measured on the 1 x 1 x m column:
    errors 1.6e-2, 3.9e-3 and 9.7e-4 with 4, 8 and 16 beams per member). ``newton``: solve
    Exudyn's equations with :func:`lattice_newton` (default where PARDISO is available: the
    same roots, hours sooner at 3x10^4 beams) rather than Exudyn's ``SolveStatic``.
    ``total``, ``iterations`` and ``peak_mb`` are the fine mesh's solve; ``coarse`` holds
    the coarse mesh's result."""
    if newton is None:
        from spacarpy.solvers.linalg.pardiso import available
        newton = available()
    solve = lattice_newton if newton else lattice
    coarse = solve(kx, ky, m, mesh=meshes[0])
    if not coarse["ok"]:
        return coarse
    fine = solve(kx, ky, m, mesh=meshes[1])
    if fine["ok"]:
        ratio = (meshes[1] / meshes[0]) ** 2
        fine["top_ux"] += (fine["top_ux"] - coarse["top_ux"]) / (ratio - 1)
    fine["coarse"] = coarse
    fine["meshes"] = tuple(meshes)
    return fine


def main(argv=None) -> int:
    """``python -m spacarpy.bench.peers.exudyn_lattice KX KY M MESH``: :func:`lattice`'s
    result as one line of JSON (the process :func:`own_solve` times)."""
    import json
    import sys
    kx, ky, m, mesh = (int(a) for a in (sys.argv[1:] if argv is None else argv))
    res = lattice(kx, ky, m, mesh=mesh)
    print(json.dumps({k: (v.tolist() if isinstance(v, np.ndarray) else v)
                      for k, v in res.items()}), flush=True)
    return 0 if res["ok"] else 1


if __name__ == "__main__":
    raise SystemExit(main())

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

Three ways to run it:

* :func:`lattice`: Exudyn's own ``SolveStatic`` in this process;
* :func:`own_solve`: the same as a user runs it, a fresh Python process under a time and a
  memory limit (the bench's ``Exudyn s`` and ``Exudyn whole s``; Eigen's sparse LU of the 3D
  graph takes hours at 3x10^4 beams and more memory than 23 GB at 10^5);
* :func:`lattice_newton`: Exudyn's own equations (its residual and its items' Jacobians)
  solved by Newton with PARDISO, the same root in seconds to minutes (the bench's converged
  answer, :func:`extrapolated`).

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


class _ExudynJacobian:
    """Exudyn's Newton matrix ``[[-K, C^T], [C, 0]]`` at the current state (its own sign
    convention; equal to its ``GetSystemJacobian``, tests/test_lattice.py): the beams'
    ``JacobianODE2`` and the joints' ``ConstraintJacobian`` from ``ComputeItem``, written
    into one preallocated array of item blocks whose row and column indices are fixed
    (int32), summed by scipy's COO to CSR conversion. The CSR pattern is the same at every
    state (explicit zeros are kept)."""

    def __init__(self, exu, mbs, objects: dict, n2: int):
        sd = mbs.systemData
        self.exu, self.mbs, self.n = exu, mbs, n2 + sd.AEsize()
        self.beams = objects.get("BeamGeometricallyExact3D", [])
        by_size: dict[int, list[int]] = {}
        for i in objects.get("JointGeneric", []):
            by_size.setdefault(len(sd.GetObjectLTGODE2(i)), []).append(i)
        self.joints = list(by_size.items())
        rows, cols, blocks = [], [], []
        ltg = np.array([sd.GetObjectLTGODE2(i) for i in self.beams], dtype=np.int32)
        ltg = ltg.reshape(len(self.beams), -1)
        rows.append(np.repeat(ltg, ltg.shape[1], axis=1).ravel())
        cols.append(np.tile(ltg, (1, ltg.shape[1])).ravel())
        blocks.append(ltg.shape[1] ** 2 * len(self.beams))
        for size, items in self.joints:
            q = np.array([sd.GetObjectLTGODE2(i) for i in items], dtype=np.int32)
            a = np.array([sd.GetObjectLTGAE(i) for i in items], dtype=np.int32) + n2
            na = a.shape[1]
            rows += [np.repeat(q, na, axis=1).ravel(), np.repeat(a, size, axis=1).ravel()]
            cols += [np.tile(a, (1, size)).ravel(), np.tile(q, (1, na)).ravel()]
            blocks += [size * na * len(items)] * 2
        self.rows, self.cols = np.concatenate(rows), np.concatenate(cols)
        self.vals = np.empty(len(self.rows))
        self.offsets = np.concatenate([[0], np.cumsum(blocks)])
        self.pattern = None

    def __call__(self) -> sp.csr_matrix:
        exu, mbs = self.exu, self.mbs
        jac, cons = exu.ComputeItemType.JacobianODE2, exu.ComputeItemType.ConstraintJacobian
        nb = len(self.beams)
        beam = self.vals[:self.offsets[1]].reshape(nb, -1) if nb else None
        for k, i in enumerate(self.beams):
            beam[k] = np.asarray(mbs.ComputeItem(exu.ObjectIndex(i), jac)).ravel()
        if nb:
            beam *= -1.0
        for g, (_size, items) in enumerate(self.joints):
            ct = self.vals[self.offsets[1 + 2 * g]:self.offsets[2 + 2 * g]]
            c = self.vals[self.offsets[2 + 2 * g]:self.offsets[3 + 2 * g]]
            ct, c = ct.reshape(len(items), -1), c.reshape(len(items), -1)
            for k, i in enumerate(items):
                block = np.asarray(mbs.ComputeItem(exu.ObjectIndex(i), cons))
                ct[k] = block.T.ravel()
                c[k] = block.ravel()
        out = sp.coo_matrix((self.vals, (self.rows, self.cols)),
                            shape=(self.n, self.n)).tocsr()
        out.sort_indices()
        if self.pattern is None:
            self.pattern = (out.indptr.copy(), out.indices.copy())
        elif not (np.array_equal(out.indptr, self.pattern[0])
                  and np.array_equal(out.indices, self.pattern[1])):
            raise RuntimeError("the Newton matrix's pattern changed")
        return out


class _SymmetricPart:
    """PARDISO's LDL^T (Bunch-Kaufman pivots, nested dissection) of the equilibrated
    symmetric part of Exudyn's Newton matrix: the approximate inverse of :func:`_refined`.

    Exudyn's matrix is ``J = [[-K, C^T], [C, 0]] = D S E`` with ``S = [[K, C^T], [C, 0]]``,
    ``D = diag(-I, I)`` and ``E = diag(I, -I)``; ``K`` is nearly symmetric (its skew part
    comes from the loads on the rotation parameters), so ``J^-1 b`` is about
    ``E sym(S)^-1 D b``. Measured at 10^4 beams, one beam per member: the first solve leaves
    1e-9 of the right side, one refinement step 3e-13; the factor has 13.5 million entries.
    An LU of ``J`` itself (PARDISO's unsymmetric type, with its matching and scaling) had
    57 million, perturbed 670 pivots, its refinement stalled near 1e-8 and Newton did not
    converge at 3x10^4 beams; the LDL^T with PARDISO's symmetric matching crashed (MKL
    2025) on the 1 020-beam lattice. ``rows``, ``cols``: J's CSR pattern (structurally
    symmetric)."""

    def __init__(self, rows, cols, n2: int):
        from spacarpy.solvers.linalg.pardiso import SYMMETRIC_INDEFINITE, Pardiso
        n = len(rows) - 1
        r = np.repeat(np.arange(n), np.diff(rows))
        self.d = np.where(np.arange(n) < n2, -1.0, 1.0)
        self.e = -self.d
        self.sign = (self.d[r] * self.e[cols]).astype(np.int8)
        index = sp.csr_matrix((np.arange(1, len(cols) + 1, dtype=float), cols, rows),
                              shape=(n, n)).T.tocsr()
        index.sort_indices()
        if not (np.array_equal(index.indices, cols) and np.array_equal(index.indptr, rows)):
            raise ValueError("the Newton matrix's pattern is not symmetric")
        self.mirror = (index.data - 1).astype(np.int32)         # J's entry (j, i) of (i, j)
        del index
        upper = r <= cols
        missing = np.setdiff1d(np.arange(n), r[r == cols])      # zero diagonal entries
        ur = np.concatenate([r[upper], missing]).astype(np.int32)
        uc = np.concatenate([cols[upper], missing]).astype(np.int32)
        take = np.concatenate([np.flatnonzero(upper), np.full(len(missing), -1)])
        del r, upper
        order = np.lexsort((uc, ur))
        self.take = take[order].astype(np.int32)
        self.lu = Pardiso(np.searchsorted(ur[order], np.arange(n + 1)), uc[order],
                          mtype=SYMMETRIC_INDEFINITE, matching=False)

    def factorize(self, jdata: np.ndarray) -> None:
        """Factorize ``T sym(S) T``, ``T`` the diagonal equilibration of :meth:`_scaling`."""
        s = self.sign * jdata
        sym = np.append(0.5 * (s + s[self.mirror]), 0.0)       # index -1: a zero diagonal
        upper = sp.csr_matrix((sym[self.take], self.lu.ja, self.lu.ia),
                              shape=(self.lu.n, self.lu.n))
        self.t = self._scaling(upper)
        r = np.repeat(self.t, np.diff(self.lu.ia))
        self.lu.factorize(upper.data * r * self.t[self.lu.ja])

    @staticmethod
    def _scaling(upper: sp.csr_matrix, passes: int = 8) -> np.ndarray:
        """Symmetric equilibration (Ruiz): ``t`` with every row of ``T S T`` of largest
        entry about 1. Exudyn's stiffness entries (1e9 N/m) and its constraints' (1) make
        the matrix's condition 1e18 unscaled (the multipliers' Schur complement ~1e-9);
        PARDISO's own scaling left residuals of 1e-3 and crashed on the 1 020-beam
        lattice."""
        t = np.ones(upper.shape[0])
        a = abs(upper)
        for _ in range(passes):
            scaled = sp.diags(t) @ a @ sp.diags(t)
            row = np.maximum(scaled.max(axis=1).toarray().ravel(),
                             scaled.max(axis=0).toarray().ravel())
            t /= np.sqrt(np.where(row > 0, row, 1.0))
        return t

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self.e * self.t * self.lu.solve(self.t * self.d * b)


def _refined(solve, jac, rhs, steps: int = 30) -> np.ndarray:
    """``jac^-1 rhs`` by iterative refinement on ``jac`` with the approximate inverse
    ``solve`` (:class:`_SymmetricPart`), until the residual stops falling by half a step
    (round-off; measured: one or two steps from 1e-9 to 3e-13 of the right side)."""
    x = solve(rhs)
    r = rhs - jac @ x
    size = np.abs(r).max()
    for _ in range(steps):
        if size == 0.0:
            break
        step = solve(r)
        r_new = rhs - jac @ (x + step)
        new = np.abs(r_new).max()
        if new > 0.5 * size:
            if new < size:
                x += step
            break
        x, r, size = x + step, r_new, new
    return x


def lattice_newton(kx: int, ky: int, m: int, mesh: int = MESH, tol: float = 1e-11) -> dict:
    """Exudyn's lattice equations solved by Newton with MKL PARDISO.

    Exudyn's own ``SolveStatic`` (:func:`lattice`) factorizes with Eigen's SparseLU, whose
    fill on a 3D graph makes its converged meshes take hours at 3x10^4 beams and more memory
    than the 2-core machine has at 10^5. Here the equations are Exudyn's own: the residual
    is Exudyn's ``ComputeNewtonResidual`` at the load factor, the Newton matrix is Exudyn's,
    assembled from its items' ``JacobianODE2`` and ``ConstraintJacobian``
    (:class:`_ExudynJacobian`, equal to its ``GetSystemJacobian``); only the linear solve
    differs: iterative refinement on that matrix (:func:`_refined`) with PARDISO's LDL^T of
    its symmetric part (:class:`_SymmetricPart`). The same 2 load steps, full Newton, until
    the largest increment is below ``tol`` (m, rad). The root is therefore Exudyn's discrete
    answer to the Newton tolerance (tests/test_lattice.py compares it with :func:`lattice`;
    measured 12 digits at 10^4 beams).
    Returns ``top_ux``, ``total`` (s, Newton), ``setup`` (s, the Exudyn model),
    ``iterations``, ``unknowns``, ``factor_entries``, ``ok``, ``reason``, ``peak_mb``."""
    missing = _not_available()
    if missing:
        missing["top_ux"] = float("nan")
        return missing
    import exudyn as exu

    from spacarpy.solvers.linalg.pardiso import available
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
        jacobian = _ExudynJacobian(exu, mbs, kinds, n2)
        s = _settings(exu, tmp)
        solver = exu.MainSolverStatic()
        solver.InitializeSolver(mbs, s)
        cur = exu.ConfigurationType.Current
        x = np.concatenate([sd.GetODE2Coordinates(configuration=cur),
                            sd.GetAECoordinates(configuration=cur)])
        pre = None
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
                    jac = jacobian()
                    if pre is None:
                        pre = _SymmetricPart(jac.indptr, jac.indices, n2)
                    pre.factorize(jac.data)
                    dx = _refined(pre.solve, jac, res)
                    x -= dx
                    iterations += 1
                    if np.abs(dx[:n2]).max() < tol:
                        break
                else:
                    ok, reason = False, f"Newton did not converge in {MAX_ITER} iterations"
                    break
            sd.SetODE2Coordinates(x[:n2], configuration=cur)
            sd.SetAECoordinates(x[n2:], configuration=cur)
            entries, factor_mb = pre.lu.factor_entries, pre.lu.peak_bytes / 2**20
        finally:
            if pre is not None:
                pre.lu.release()
        total = time.perf_counter() - t0
    out = _result(total=total, setup=setup, iterations=iterations, tip=None, ok=ok,
                  reason=reason)
    ux = [sd.GetNodeLTGODE2(n)[0] for n in top]
    out.update(top_ux=float(np.mean(x[ux])) if ok else float("nan"), mesh=mesh,
               unknowns=n2 + nae, factor_entries=entries, factor_mb=factor_mb)
    del SC
    return out


#: default wall-clock limit (s) of Exudyn's own solve in the bench (``--peer-limit``)
OWN_LIMIT = 900.0


def own_solve(kx: int, ky: int, m: int, mesh: int = MESH, limit: float | None = None,
              memory: int | None = None) -> dict:
    """Exudyn's own ``SolveStatic`` (:func:`lattice`) as a user runs it: a fresh Python
    process (``python -m spacarpy.bench.peers.exudyn_lattice KX KY M MESH``), stopped when it
    has run ``limit`` seconds (default :data:`OWN_LIMIT`) or its resident memory passes
    ``memory`` bytes (default: 80 %
    of the memory available at the start; Linux only), so that a size where Eigen's LU of
    the 3D graph takes hours or more memory than the machine has is a lower bound, not a
    hung or swapping machine. Returns :func:`lattice`'s keys and ``whole`` (the process's
    wall seconds), ``stopped`` ("time", "memory" or None) and ``limit`` (a lower bound of
    the time of a stopped run: ``limit``, or the seconds before the memory stop)."""
    import json
    import subprocess
    import sys

    from spacarpy.memory import available_bytes
    limit = OWN_LIMIT if limit is None else limit
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
        # the lower bound of its time: the limit, or the seconds it ran before its memory
        # passed the bound (it would not have fitted at all)
        if stopped == "time":
            bound, why = limit, f"at the time limit, {limit:.0f} s (--peer-limit)"
        else:
            bound, why = whole, (f"after {whole:.0f} s at {rss_max / 2**30:.1f} GB resident "
                                 f"(80 % of the available memory)")
        return dict(ok=False, stopped=stopped, limit=bound, whole=None, total=None,
                    iterations=None, top_ux=float("nan"), peak_mb=rss_max / 2**20,
                    reason=f"Exudyn's own solve ({mesh} beams per member) stopped {why}")
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

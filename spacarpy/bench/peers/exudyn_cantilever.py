"""``spacarpy bench`` problems solved with the peer code Exudyn (``spacarpy bench --peer exudyn``).

Four problems, set up like spacarpy's (``spacarpy.bench.cases``, ``spacarpy.bench``):

* :func:`cantilever` - Table 1 of Jonker & Meijaard (2013): straight steel cantilever, L = 2 m
  along x, square 0.1 m section, dead tip force 3 E I / L^2 along +y in ``n_steps`` equal load
  steps;
* :func:`bend` - Table 2 (Bathe-Bolourchi): 45-degree bend of radius 100 m in the x-z plane,
  dead tip force 600 N along +y;
* :func:`eigenfrequencies` - lowest frequencies of the unloaded cantilever with mass
  (rho = 7850 kg/m^3, rho A per length, rotary inertia rho I about both bending axes and
  rho 2I about the beam axis);
* :func:`transient` - the cantilever with mass at rest, a tenth of the Table 1 force raised
  with the smoothstep 3s^2 - 2s^3 (s = t / 20 ms), then held; ``n_steps`` steps of ``dt``.

Exudyn model: ``n`` equal ``ObjectBeamGeometricallyExact`` elements (two-node, SE(3)
interpolated, shear deformable) between ``NodeRigidBodyRxyz`` nodes (Tait-Bryan angles; the
rotations of these problems stay far from the angle singularity at 90 degrees about local y).
The first node is clamped to ground by an ``ObjectJointGeneric`` with all six axes locked (a
Lagrange multiplier constraint; Exudyn has no other way to fix node coordinates in a static
or dynamic solve). Loads are ``LoadForceVector`` on the tip node in global coordinates
(dead loads).

Settings and why:

* Shear: Exudyn's beam cannot be shear rigid; the cantilever uses GA = 10 EA in both shear
  directions (``SHEAR_FACTOR``). Its tip deflection is therefore slightly larger than
  spacarpy's shear-rigid one (u_y about 3.5e-5 m more at 1000 elements). GA = 30 EA still
  converges (about 20 % more iterations, u_y within 1e-6 m of spacarpy's), 100 EA does not.
  The bend has the physical shear stiffness of the paper (kGA = 5e6 N) in both codes.
* The element computes its strains relative to the relative motion of its two node frames in
  the reference configuration, so a curved reference is stress free. The bend is therefore
  modelled by default as Exudyn does naturally: nodes on the arc with frames along the arc
  tangent, element length = arc length; each element is then an exact circular arc. With
  ``chords=True`` each element instead gets its own two nodes with frames along its chord
  (straight elements) and neighbouring elements are tied by rigid six-axis joints that keep
  the reference kink: the polygonal geometry of spacarpy's BEAMARC generator. That variant
  needs 20 load steps; with 10 Newton fails at any mesh size.
* Static solver: ``SolveStatic`` with ``numberOfLoadSteps = n_steps`` (load factor k/n_steps),
  no adaptive step reduction (a failed Newton is reported as a failure), full Newton
  (``useModifiedNewton = False``, Jacobian every iteration), at most 20 iterations per step
  (as spacarpy's bench), sparse LU (``LinearSolverType.EigenSparse``), one thread.
  Convergence test on the Newton increment (``residualMode = 1``, relative = absolute
  tolerance = ``tol``, in m and rad), close to spacarpy's increment test: Exudyn's default
  test on the residual relative to the first iteration's is too loose for the bend at 1e-6
  (tip off by 6e-5 m) and hits the round-off floor at 1e-7 for 10000 elements. With it the
  tips are converged to 1e-8 m at tol = 1e-6.
* Exudyn's analytic beam Jacobian omits the derivative of the rotation parametrization; for
  the coarse bend (8 elements) Newton then wanders off. :func:`bend` retries a failed solve
  with Exudyn's numerical element Jacobian (``numericalDifferentiation.forODE2``, relative
  epsilon 1e-7), which converges there (not for fine meshes), and counts both attempts;
  ``jacobian`` and ``note`` in the result say so.
* Eigenfrequencies: ``mbs.ComputeODE2Eigenvalues`` with ``useSparseSolver=True`` (scipy
  ``eigsh`` shift-invert about 0 for the ``n_modes`` lowest) and the clamped node's six
  coordinates removed via ``constrainedCoordinates`` (no joint). Exudyn 1.13 exports the mass
  and stiffness matrices densely (ru_maxrss 4.5 GB at 2000 elements), so sizes above
  ``EIGEN_MAX_ELEMENTS`` are not run. The mass matrix is Exudyn's lumped (two-point Lobatto)
  one.
* Transient: ``SolveDynamic`` with the generalized-alpha solver, spectral radius 0.5, fixed
  steps (no automatic or adaptive step size), full Newton, increment tolerance 1e-8, sparse
  LU; the load is a Python ``loadVectorUserFunction``.

Exudyn runs silently: verbose modes 0, no solution or sensor files (their names point into a
temporary directory all the same), console output captured. Exudyn is imported lazily, so
this module imports without it. Every function returns a dict with ``total`` (wall seconds of
the solver call), ``setup`` (model building and ``Assemble``), ``iterations`` (total Newton
iterations, None if unknown), ``tip`` (tip displacement, or ``freqs`` in Hz for the
eigenvalue problem), ``ok``, ``reason`` (empty if ok) and ``peak_mb`` (ru_maxrss).
"""
from __future__ import annotations

import contextlib
import importlib
import io
import math
import os
import resource
import tempfile
import time
import warnings

import numpy as np

from spacarpy.bench.cases import BEND, CANTILEVER

#: steel density of the transient and eigenvalue benches (kg/m^3), as spacarpy.bench
RHO = 7850.0
#: Exudyn's beam is shear deformable: GA = SHEAR_FACTOR * EA stands in for "shear rigid"
SHEAR_FACTOR = 10.0
#: Newton iterations allowed per load or time step (spacarpy's bench uses 20)
MAX_ITER = 20
#: largest mesh for the eigenvalues (Exudyn 1.13 builds dense 6(n+1) x 6(n+1) matrices)
EIGEN_MAX_ELEMENTS = 2000
#: time over which the transient's force is raised (s), and its fraction of the Table 1 force
RAMP_TIME = 0.02
TRANSIENT_LOAD_FRACTION = 0.1
#: Exudyn's verbose mode for the solvers; > 0 also lets its output through (for debugging)
VERBOSE = 0


def available() -> tuple[bool, str]:
    """(True, Exudyn's version) if Exudyn imports, else (False, the reason)."""
    try:
        import exudyn
    except Exception as exc:  # ImportError, or a broken binary wheel
        return False, f"exudyn not importable: {exc}"
    return True, str(exudyn.__version__)


# ----------------------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------------------

def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _result(**kw) -> dict:
    res = dict(total=None, setup=None, iterations=None, tip=None, ok=False, reason="",
               peak_mb=None)
    res.update(kw)
    res["peak_mb"] = _peak_mb()
    return res


def _not_available() -> dict | None:
    ok, why = available()
    return None if ok else _result(reason=why)


@contextlib.contextmanager
def _quiet():
    """Capture whatever Exudyn prints (it prints through Python's sys.stdout)."""
    buf = io.StringIO()
    if VERBOSE:
        yield buf
        return
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf), \
            warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield buf


def _failure_reason(exc: Exception | None, log: io.StringIO) -> str:
    """Exudyn's exception and the last informative lines it printed."""
    lines = [ln.strip() for ln in log.getvalue().splitlines()
             if ln.strip() and not set(ln.strip()) <= set("*+-")
             and "showHints" not in ln and "SOLVER FAILED" not in ln]
    text = "; ".join(lines[-2:])
    if exc is not None:
        text = f"{exc}" + (f" ({text})" if text else "")
    return text or "Exudyn solver reported failure"


def _settings(exu, tmp: str):
    """Silent settings with the sparse LU solver, one thread, and no files written."""
    s = exu.SimulationSettings()
    s.solution.file.write = False
    s.solution.file.name = os.path.join(tmp, "solution.txt")
    s.solution.sensors.active = False
    s.solution.restart.write = False
    s.solution.solverInformationFileName = os.path.join(tmp, "solverInformation.txt")
    s.show.globalTimers = False
    s.show.computationTime = False
    s.show.statistics = False
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    s.parallel.numberOfThreads = 1
    return s


def _newton(newton, tol: float, numerical_jacobian: bool = False) -> None:
    """Full Newton, converged when the Newton increment (m, rad) is below ``tol``."""
    newton.useModifiedNewton = False
    newton.maxIterations = MAX_ITER
    newton.residualMode = 1                  # error = norm of the increment, not the residual
    newton.relativeTolerance = tol           # Exudyn asks for relTol = absTol in this mode
    newton.absoluteTolerance = tol
    if numerical_jacobian:
        nd = newton.numericalDifferentiation
        nd.forODE2 = True
        nd.relativeEpsilon = 1e-7
        nd.minimumCoordinateSize = 1.0


def _section(exu, stiffness, mass_per_length: float = 0.0, inertia=(0.0, 0.0, 0.0)):
    """BeamSection: stiffness (EA, GAy, GAz, GJ, EIy, EIz), rho A, diag(rho Ix, rho Iy, rho Iz)."""
    bs = exu.BeamSection()
    bs.stiffnessMatrix = np.diag(np.asarray(stiffness, dtype=float))
    bs.massPerLength = float(mass_per_length)
    bs.inertia = np.diag(np.asarray(inertia, dtype=float))
    return bs


def _clamp(mbs, node: int, rotation=None) -> None:
    """Lock all six coordinates of ``node``, whose reference frame is ``rotation`` (default:
    the global frame). The generic joint locks the relative rotation of its two marker
    frames, so the node's marker is turned back to the global frame in the reference."""
    import exudyn as exu
    from exudyn.itemInterface import (
        MarkerBodyRigid,
        MarkerNodeRigid,
        ObjectGround,
        ObjectJointGeneric,
    )
    ground = mbs.AddObject(ObjectGround())
    m_ground = mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground, localPosition=[0.0, 0.0, 0.0]))
    if rotation is None:
        m_node = mbs.AddMarker(MarkerNodeRigid(nodeNumber=node))
    else:
        m_node = mbs.AddMarker(MarkerNodeRigid(nodeNumber=node, localHT=exu.HT(
            rotation=np.asarray(rotation).T, translation=[0.0, 0.0, 0.0])))
    mbs.AddObject(ObjectJointGeneric(markerNumbers=[m_ground, m_node],
                                     constrainedAxes=[1, 1, 1, 1, 1, 1]))


def _cantilever_model(exu, n: int, with_mass: bool, clamp: bool = True):
    """The Table 1 cantilever: returns (SystemContainer, mbs, node list)."""
    from exudyn.itemInterface import NodeRigidBodyRxyz, ObjectBeamGeometricallyExact
    c = CANTILEVER
    a, E, L = c["a"], c["E"], c["L"]
    area, inertia = a * a, a**4 / 12
    G = E / (2 * (1 + c["nu"]))
    J = 0.1406 * a**4
    EA = E * area
    stiffness = (EA, SHEAR_FACTOR * EA, SHEAR_FACTOR * EA, G * J, E * inertia, E * inertia)
    if with_mass:
        section = _section(exu, stiffness, RHO * area,
                           (RHO * 2 * inertia, RHO * inertia, RHO * inertia))
    else:
        section = _section(exu, stiffness)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = [mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[x, 0.0, 0.0, 0.0, 0.0, 0.0]))
             for x in np.linspace(0.0, L, n + 1)]
    for i in range(n):
        mbs.AddObject(ObjectBeamGeometricallyExact(nodeNumbers=[nodes[i], nodes[i + 1]],
                                                   length=L / n, sectionData=section))
    if clamp:
        _clamp(mbs, nodes[0])
    return SC, mbs, nodes


def _tip_load(mbs, node: int, force, user_function=None) -> None:
    from exudyn.itemInterface import LoadForceVector, MarkerNodePosition
    marker = mbs.AddMarker(MarkerNodePosition(nodeNumber=node))
    if user_function is None:
        mbs.AddLoad(LoadForceVector(markerNumber=marker, loadVector=list(force)))
    else:
        mbs.AddLoad(LoadForceVector(markerNumber=marker, loadVector=list(force),
                                    loadVectorUserFunction=user_function))


def _displacement(exu, mbs, node: int) -> np.ndarray:
    return np.array(mbs.GetNodeOutput(node, exu.OutputVariableType.Displacement), dtype=float)


def _solve_static(exu, mbs, tip_node: int, n_steps: int, tol: float, setup: float,
                  tmp: str, numerical_jacobian: bool = False) -> dict:
    """``SolveStatic`` from the initial (reference) state; the load factor runs k/n_steps."""
    s = _settings(exu, tmp)
    st = s.staticSolver
    st.numberOfLoadSteps = int(n_steps)
    st.loadStepGeometric = False
    st.adaptiveStep = False
    st.verboseMode = VERBOSE
    st.verboseModeFile = 0
    _newton(st.newton, tol, numerical_jacobian)
    exc = None
    with _quiet() as log:
        t0 = time.perf_counter()
        try:
            ok = bool(mbs.SolveStatic(s, storeSolver=True, showHints=False))
        except Exception as e:  # exudyn.SolverError when Newton fails
            ok, exc = False, e
        total = time.perf_counter() - t0
    solver = mbs.sys.get("staticSolver")
    iterations = int(solver.it.newtonStepsCount) if solver is not None else None
    tip = _displacement(exu, mbs, tip_node) if ok else np.full(3, np.nan)
    reason = ""
    if not ok:
        where = f" at load factor {solver.it.currentTime:.3g}" if solver is not None else ""
        reason = f"Newton failed{where}: " + _failure_reason(exc, log)
    return _result(total=total, setup=setup, iterations=iterations, tip=tip, ok=ok,
                   reason=reason)


# ----------------------------------------------------------------------------------------
# the four problems
# ----------------------------------------------------------------------------------------

def cantilever(n: int, n_steps: int = 10, tol: float = 1e-6) -> dict:
    """Table 1 cantilever with ``n`` elements: tip displacement (u_x, u_y, u_z) in ``tip``."""
    missing = _not_available()
    if missing:
        return missing
    import exudyn as exu
    c = CANTILEVER
    force = 3 * c["E"] * (c["a"] ** 4 / 12) / c["L"] ** 2
    with _quiet():
        t0 = time.perf_counter()
        SC, mbs, nodes = _cantilever_model(exu, n, with_mass=False)
        _tip_load(mbs, nodes[-1], (0.0, force, 0.0))
        mbs.Assemble()
        setup = time.perf_counter() - t0
    with tempfile.TemporaryDirectory(prefix="exudyn_peer_") as tmp:
        res = _solve_static(exu, mbs, nodes[-1], n_steps, tol, setup, tmp)
    res["tip_position"] = np.array([c["L"], 0.0, 0.0]) + res["tip"]
    del SC
    return res


def bend(n: int, n_steps: int = 10, tol: float = 1e-6, chords: bool = False) -> dict:
    """Table 2 bend with ``n`` elements: tip displacement in ``tip``, position in
    ``tip_position``. ``chords=False``: curved (exact arc) elements between nodes on the arc;
    ``chords=True``: straight chord elements with rigid kinks, as spacarpy's BEAMARC."""
    missing = _not_available()
    if missing:
        return missing
    import exudyn as exu
    from exudyn.itemInterface import (
        MarkerNodeRigid,
        NodeRigidBodyRxyz,
        ObjectBeamGeometricallyExact,
        ObjectJointGeneric,
    )
    from exudyn.rigidBodyUtilities import RotXYZ2RotationMatrix
    b = BEND
    R = b["R"]
    section = _section(exu, (b["EA"], b["kGA"], b["kGA"], b["EI"], b["EI"], b["EI"]))
    theta = np.linspace(0.0, math.pi / 4, n + 1)
    points = np.column_stack([R * np.sin(theta), np.zeros(n + 1), R * (1 - np.cos(theta))])

    def node(p, angle_y):
        # local x along the direction (cos a, 0, sin a): rotation -a about global y
        return mbs.AddNode(NodeRigidBodyRxyz(
            referenceCoordinates=[p[0], p[1], p[2], 0.0, -angle_y, 0.0]))

    with _quiet():
        t0 = time.perf_counter()
        SC = exu.SystemContainer()
        mbs = SC.AddSystem()
        if not chords:
            nodes = [node(p, a) for p, a in zip(points, theta)]
            for i in range(n):
                mbs.AddObject(ObjectBeamGeometricallyExact(
                    nodeNumbers=[nodes[i], nodes[i + 1]], length=R * (theta[i + 1] - theta[i]),
                    sectionData=section))
            first, tip = nodes[0], nodes[-1]
        else:
            ends = []
            for i in range(n):
                d = points[i + 1] - points[i]
                angle = math.atan2(d[2], d[0])
                n0, n1 = node(points[i], angle), node(points[i + 1], angle)
                mbs.AddObject(ObjectBeamGeometricallyExact(
                    nodeNumbers=[n0, n1], length=float(np.linalg.norm(d)),
                    sectionData=section))
                ends.append((n0, n1, RotXYZ2RotationMatrix([0.0, -angle, 0.0])))
            for (_, left, rot_left), (right, _, rot_right) in zip(ends[:-1], ends[1:]):
                # marker frames both global in the reference: the kink stays rigid
                m_left = mbs.AddMarker(MarkerNodeRigid(
                    nodeNumber=left, localHT=exu.HT(rotation=rot_left.T, translation=[0, 0, 0])))
                m_right = mbs.AddMarker(MarkerNodeRigid(
                    nodeNumber=right,
                    localHT=exu.HT(rotation=rot_right.T, translation=[0, 0, 0])))
                mbs.AddObject(ObjectJointGeneric(markerNumbers=[m_left, m_right],
                                                 constrainedAxes=[1, 1, 1, 1, 1, 1]))
            first, tip = ends[0][0], ends[-1][1]
        # the first chord leaves the clamp at half an element angle: lock the frame it has
        _clamp(mbs, first, ends[0][2] if chords else None)
        _tip_load(mbs, tip, (0.0, b["F"], 0.0))
        mbs.Assemble()
        setup = time.perf_counter() - t0
    with tempfile.TemporaryDirectory(prefix="exudyn_peer_") as tmp:
        res = _solve_static(exu, mbs, tip, n_steps, tol, setup, tmp)
        res["jacobian"] = "analytic"
        if not res["ok"]:
            # coarse bends: Newton with the analytic Jacobian wanders off (it lacks the
            # derivative of the rotation parametrization); Exudyn's numerical Jacobian of the
            # elements converges there. Time and iterations of both attempts are counted.
            first = res
            res = _solve_static(exu, mbs, tip, n_steps, tol, setup, tmp, numerical_jacobian=True)
            res["jacobian"] = "numerical"
            res["note"] = (f"analytic Jacobian failed ({first['iterations']} iterations, "
                           f"{first['total']:.3f} s, included); retried with the numerical one")
            res["total"] += first["total"]
            if res["iterations"] is not None and first["iterations"] is not None:
                res["iterations"] += first["iterations"]
            if not res["ok"]:
                res["reason"] = f"analytic: {first['reason']}; numerical: {res['reason']}"
    res["tip_position"] = points[-1] + res["tip"]
    res["geometry"] = "chords" if chords else "arc"
    del SC
    return res


def eigenfrequencies(n: int, n_modes: int = 10) -> dict:
    """Lowest ``n_modes`` frequencies (Hz) of the unloaded cantilever with mass in ``freqs``."""
    missing = _not_available()
    if missing:
        missing["freqs"] = None
        return missing
    if n > EIGEN_MAX_ELEMENTS:
        return _result(freqs=None, reason=(
            f"not run: Exudyn 1.13 assembles dense mass and stiffness matrices for the "
            f"eigenvalue problem ({6 * (n + 1)} coordinates, "
            f"{(6 * (n + 1)) ** 2 * 8 / 2**30:.1f} GiB each); "
            f"limit {EIGEN_MAX_ELEMENTS} elements"))
    import exudyn as exu
    with _quiet():
        t0 = time.perf_counter()
        SC, mbs, nodes = _cantilever_model(exu, n, with_mass=True, clamp=False)
        mbs.Assemble()
        setup = time.perf_counter() - t0
        # Exudyn's eigen solver imports these: load them here, outside the timed call
        for module in ("scipy.linalg", "scipy.sparse", "scipy.sparse.linalg"):
            importlib.import_module(module)
    clamped = list(range(6))            # the six coordinates of node 0 (the first node)
    exc = None
    with tempfile.TemporaryDirectory(prefix="exudyn_peer_") as tmp, _quiet() as log:
        s = _settings(exu, tmp)
        t0 = time.perf_counter()
        try:
            freqs, _ = mbs.ComputeODE2Eigenvalues(
                simulationSettings=s, useSparseSolver=True, numberOfEigenvalues=int(n_modes),
                constrainedCoordinates=clamped, convert2Frequencies=True)
            freqs = np.sort(np.asarray(freqs, dtype=float))
            ok = True
        except Exception as e:
            freqs, ok, exc = None, False, e
        total = time.perf_counter() - t0
    del SC
    return _result(total=total, setup=setup, iterations=None, freqs=freqs, ok=ok,
                   reason="" if ok else _failure_reason(exc, log))


def _solve_dynamic(exu, mbs, n_steps: int, h: float, rho_inf: float, tol: float,
                   verbose: int = 0, sensors: bool = False):
    """``SolveDynamic`` with Exudyn's generalized-alpha in ``n_steps`` fixed steps of ``h``
    (spectral radius ``rho_inf``, consistent initial accelerations, full Newton to
    ``tol``): ``(ok, wall time, Newton iterations or None, failure reason or "")``.
    ``sensors``: keep the in-memory sensors active."""
    exc = None
    with tempfile.TemporaryDirectory(prefix="exudyn_peer_") as tmp, _quiet() as log:
        s = _settings(exu, tmp)
        if sensors:
            s.solution.sensors.active = True
        ti = s.timeIntegration
        ti.startTime = 0.0
        ti.endTime = n_steps * h
        ti.numberOfSteps = int(n_steps)
        ti.automaticStepSize = False
        ti.adaptiveStep = False
        ti.verboseMode = verbose
        ti.verboseModeFile = 0
        ti.generalizedAlpha.spectralRadius = float(rho_inf)
        ti.generalizedAlpha.computeInitialAccelerations = True
        _newton(ti.newton, tol)
        t0 = time.perf_counter()
        try:
            ok = bool(mbs.SolveDynamic(s, solverType=exu.DynamicSolverType.GeneralizedAlpha,
                                       storeSolver=True, showHints=False))
        except Exception as e:
            ok, exc = False, e
        total = time.perf_counter() - t0
    solver = mbs.sys.get("dynamicSolver")
    iterations = int(solver.it.newtonStepsCount) if solver is not None else None
    reason = ""
    if not ok:
        where = f" at t = {solver.it.currentTime:.4g} s" if solver is not None else ""
        reason = f"Newton failed{where}: " + _failure_reason(exc, log)
    return ok, total, iterations, reason


def transient(n: int, n_steps: int = 1000, dt: float = 1e-3) -> dict:
    """Cantilever with mass, tenth of the Table 1 force raised in 20 ms; ``tip`` at the end."""
    missing = _not_available()
    if missing:
        return missing
    import exudyn as exu
    c = CANTILEVER
    force = TRANSIENT_LOAD_FRACTION * 3 * c["E"] * (c["a"] ** 4 / 12) / c["L"] ** 2

    def load(mbs, t, load_vector):
        s = min(max(t / RAMP_TIME, 0.0), 1.0)
        return [0.0, force * s * s * (3.0 - 2.0 * s), 0.0]

    with _quiet():
        t0 = time.perf_counter()
        SC, mbs, nodes = _cantilever_model(exu, n, with_mass=True)
        _tip_load(mbs, nodes[-1], (0.0, force, 0.0), user_function=load)
        mbs.Assemble()
        setup = time.perf_counter() - t0
    ok, total, iterations, reason = _solve_dynamic(exu, mbs, int(n_steps), dt, 0.5, 1e-8,
                                                   verbose=VERBOSE)
    tip = _displacement(exu, mbs, nodes[-1]) if ok else np.full(3, np.nan)
    del SC
    return _result(total=total, setup=setup, iterations=iterations, tip=tip, ok=ok,
                   steps=int(n_steps), reason=reason)

"""The 3D beam lattice of ``spacarpy bench --cases lattice`` solved with the peer code
OpenSees through openseespy (``--peer opensees``).

The problem is :func:`spacarpy.bench.decks.lattice_deck`'s: ``kx x ky x m`` grid points
0.1 m apart, a beam between neighbours along x, y and z (square 0.01 m, steel, shear factor
5/6, torsion constant 0.1406 a^4: the deck's ESTIFF), the bottom layer clamped, 50 N along +x
on every top node in 2 equal load steps. :func:`lattice` returns the mean displacement along
x of the top nodes (``top_ux``), the quantity spacarpy's bench reports.

OpenSees model:

* ``model basic -ndm 3 -ndf 6``, one node per grid point, ``mesh`` elements per member
  (default one: see :data:`MESH`).
* Every element is a ``forceBeamColumn`` with two Lobatto points on an ``Elastic`` section
  with shear (``E A Iz Iy G J alphaY alphaZ``, alpha = 5/6): the force formulation is exact for
  a linear-elastic Timoshenko member in its basic system, so one element per member is the
  member. OpenSees' ``ElasticTimoshenkoBeam3d`` would be the same, but it accepts only
  the Linear and PDelta transformations.
* ``geomTransf Corotational``: large rigid rotations of the member, small strains in its
  basic system, the same kinematics as spacarpy's beam with ``DEFORMATIONS modified``. The
  vector in the local x-z plane is the deck's orientation vector (``0 0 1`` for the x and y
  members, ``1 0 0`` for the z members); the section is square, so it only names the axes.
* The bottom nodes are fixed in all six dofs; a ``Plain`` load pattern with a ``Linear``
  time series applies ``F`` along +x on every top node (dead load); ``LoadControl`` in
  ``steps`` equal increments, ``Newton`` (tangent every iteration), the ``NormDispIncr``
  test at ``tol`` (m and rad, the increment test of the Exudyn peer), ``RCM`` numbering and
  a sparse direct system (UmfPack, or Mumps on large lattices: :data:`MUMPS_FROM`, the
  fastest measured here).

openseespy is imported lazily; without it (or when its binary does not load) :func:`lattice`
returns ``ok=False`` and the reason.
"""
from __future__ import annotations

import atexit
import ctypes
import importlib.util
import os
import resource
import sys
import tempfile
import time

import numpy as np

from spacarpy.bench.decks import LATTICE

#: OpenSees elements per member: one, as the force-based element with shear is exact for
#: the member's linear basic system (spacarpy's answer to 3e-8 at 4 x 4 x 5, 2e-6 on the
#: 1 x 1 x 3 column)
MESH = 1
#: OpenSees' sparse systems, measured on the loaded 2-core machine (solve s, 2 load steps,
#: 6 Newton iterations): 6 x 6 x 11 (1 020 beams) UmfPack 0.62-1.13, SparseSYM 0.56-0.79,
#: Mumps 0.75-1.14; 9 x 9 x 18 (3 969) UmfPack 4.3-5.6, Mumps 5.5-6.9; 12 x 12 x 25
#: (10 056) UmfPack 25-31, Mumps 20.4-20.6, SparseSYM 51. UmfPack below MUMPS_FROM beams,
#: Mumps from there (the crossover lies between the last two sizes; not measured closer)
MUMPS_FROM = 8000


def _system(kx: int, ky: int, m: int) -> str:
    from spacarpy.bench.decks import lattice_elements
    return "Mumps" if lattice_elements(kx, ky, m) >= MUMPS_FROM else "UmfPack"


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _result(**kw) -> dict:
    res = dict(total=None, setup=None, iterations=None, top_ux=float("nan"), ok=False,
               reason="", peak_mb=None, mesh=None)
    res.update(kw)
    res["peak_mb"] = _peak_mb()
    return res


def _load():
    """openseespy's module. The Linux wheel's LAPACK needs the BLAS shipped beside it, which
    its loader does not find (the RUNPATH covers the extension only): load that BLAS first."""
    spec = importlib.util.find_spec("openseespylinux")
    if spec is not None and spec.origin:
        blas = os.path.join(os.path.dirname(spec.origin), "lib", "libblas.so.3")
        if os.path.exists(blas):
            ctypes.CDLL(blas, mode=ctypes.RTLD_GLOBAL)
    import openseespy.opensees as ops
    if not _SILENCED:
        _SILENCED.append(True)
        atexit.register(_silence_stderr)
    return ops


_SILENCED: list = []


def _silence_stderr() -> None:
    """At exit, silence the C stderr: OpenSees' library writes "Process 0 Terminating" there
    when it is unloaded, which would land in the bench's table (atexit handlers registered
    before openseespy was loaded run after this one, silenced too)."""
    try:
        sys.stderr.flush()
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 2)
        os.close(null)
    except (OSError, ValueError):
        pass


def available() -> tuple[bool, str]:
    """(True, OpenSees' version) if openseespy imports, else (False, the reason)."""
    try:
        ops = _load()
    except Exception as exc:  # ImportError, or a binary that does not load
        return False, f"openseespy not importable: {exc}"
    return True, str(ops.version())


def _section(ops, tag: int) -> None:
    c = LATTICE
    area, inertia = c["a"] ** 2, c["a"] ** 4 / 12
    g = c["E"] / (2 * (1 + c["nu"]))
    ops.section("Elastic", tag, c["E"], area, inertia, inertia, g, 0.1406 * c["a"] ** 4,
                c["kappa"], c["kappa"])


def _build(ops, kx: int, ky: int, m: int, mesh: int) -> list[int]:
    """Nodes, members, clamps and loads; the tags of the top grid nodes."""
    c = LATTICE
    l = c["l"]                                                 # noqa: E741
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    _section(ops, 1)
    ops.beamIntegration("Lobatto", 1, 1, 3)
    # the deck's orientation vectors: 0 0 1 for the x and y members, 1 0 0 for z
    ops.geomTransf("Corotational", 1, 0.0, 0.0, 1.0)
    ops.geomTransf("Corotational", 2, 1.0, 0.0, 0.0)

    def tag(i, j, lev):
        return (lev * ky + j) * kx + i + 1

    for lev in range(m):
        for j in range(ky):
            for i in range(kx):
                ops.node(tag(i, j, lev), i * l, j * l, lev * l)
    extra = kx * ky * m
    element = 0
    for lev in range(m):
        for j in range(ky):
            for i in range(kx):
                for d, transf in (((1, 0, 0), 1), ((0, 1, 0), 1), ((0, 0, 1), 2)):
                    q = (i + d[0], j + d[1], lev + d[2])
                    if q[0] >= kx or q[1] >= ky or q[2] >= m:
                        continue
                    p0 = np.array([i, j, lev], dtype=float) * l
                    chain = [tag(i, j, lev)]
                    for s in range(1, mesh):
                        extra += 1
                        ops.node(extra, *(p0 + np.array(d) * l * s / mesh))
                        chain.append(extra)
                    chain.append(tag(*q))
                    for a, b in zip(chain[:-1], chain[1:]):
                        element += 1
                        ops.element("forceBeamColumn", element, a, b, transf, 1)
    for j in range(ky):
        for i in range(kx):
            ops.fix(tag(i, j, 0), 1, 1, 1, 1, 1, 1)
    top = [tag(i, j, m - 1) for j in range(ky) for i in range(kx)]
    ops.timeSeries("Linear", 1)
    ops.pattern("Plain", 1, 1)
    for n in top:
        ops.load(n, c["F"], 0.0, 0.0, 0.0, 0.0, 0.0)
    return top


def _analysis(ops, tol: float, system: str) -> None:
    ops.constraints("Plain")
    ops.numberer("RCM")
    ops.system(system)
    ops.test("NormDispIncr", tol, 50, 0)
    ops.algorithm("Newton")
    ops.integrator("LoadControl", 1.0 / LATTICE["steps"])
    ops.analysis("Static")


def lattice(kx: int, ky: int, m: int, mesh: int = MESH, tol: float = 1e-10,
            system: str | None = None) -> dict:
    """The lattice with ``mesh`` OpenSees elements per member: ``top_ux`` (m), ``total``
    (solve s), ``setup`` (model s), ``iterations`` (Newton, all steps), ``ok``, ``reason``,
    ``peak_mb``, ``system`` (OpenSees' linear system; None: by the lattice's size)."""
    ok, why = available()
    if not ok:
        return _result(reason=why)
    system = system or _system(kx, ky, m)
    ops = _load()
    with tempfile.TemporaryDirectory(prefix="opensees_peer_") as tmp:
        ops.logFile(os.path.join(tmp, "opensees.log"), "-noEcho")   # keep it off stderr
        t0 = time.perf_counter()
        top = _build(ops, kx, ky, m, mesh)
        _analysis(ops, tol, system)
        setup = time.perf_counter() - t0
        iterations, failed_at = 0, None
        t0 = time.perf_counter()
        for step in range(LATTICE["steps"]):
            if ops.analyze(1) != 0:
                failed_at = step + 1
                break
            iterations += int(ops.testIter())
        total = time.perf_counter() - t0
        if failed_at is not None:
            with open(os.path.join(tmp, "opensees.log"), errors="replace") as f:
                lines = [ln.strip() for ln in f if ln.strip()]
            reason = (f"Newton failed in load step {failed_at}: "
                      + "; ".join(lines[-2:]))
            ops.wipe()
            return _result(total=total, setup=setup, iterations=iterations, reason=reason,
                           mesh=mesh)
        top_ux = float(np.mean([ops.nodeDisp(n, 1) for n in top]))
        ops.wipe()
    return _result(total=total, setup=setup, iterations=iterations, top_ux=top_ux, ok=True,
                   mesh=mesh, system=system)

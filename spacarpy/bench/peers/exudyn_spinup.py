"""Simo & Vu-Quoc's spin-up solved with the peer code Exudyn (``spacarpy bench --peer exudyn``,
``tests/test_spinup_validation.py``).

The problem is that of ``decks/spinup_beam.dat`` (:mod:`spacarpy.bench.spinup` writes the same deck
for spacarpy): a beam of L = 10 m clamped to a hub at the origin, EA = 2.8e7 N, EI = 1.4e4
N m^2, rho A = 1.2 kg/m, section rotary inertia rho I_z = 6e-4 kg m (the deck's EM line), at
rest at t = 0; the hub's angle about z is ``rate * phi(t)`` with phi the ``TIMEFUNCTION
spinup T`` of :mod:`spacarpy.time_functions` (the very function object, not a copy): the
rate rises smoothly from 0 to ``rate`` at t = T = 15 s and stays constant after.

Exudyn model:

* **2D**, ``ObjectBeamGeometricallyExact2D`` (two-node, shear deformable Reissner beam)
  between ``NodeRigidBody2D`` nodes (x, y, rotation angle). The motion is planar: the hub
  turns about z, the beam lies in the x-y plane and nothing loads it out of plane, so a 3D
  model's out-of-plane coordinates stay zero. The 2D node's rotation is one angle with no
  singularity and no wrap-around (the hub turns 90 rad by t = 30 s), where the 3D
  ``NodeRigidBodyRxyz`` would carry Tait-Bryan angles; the 2D beam has half the unknowns.
  The GJ and the out-of-plane EI of the deck play no part in the planar motion.
* Shear: Exudyn's beam cannot be shear rigid; GA = ``shear_factor`` EA (default 10, as
  :mod:`spacarpy.bench.peers.exudyn_cantilever`). GA = 100 EA changes the peak lag by 1e-5 m.
* **The hub** is the first node: its x and y are held at zero and its angle is prescribed
  by three ``CoordinateConstraint`` objects between the node's coordinates and a ground
  coordinate (Lagrange multipliers, index 3, as Exudyn's generalized-alpha solves them);
  the angle's constraint has ``offsetUserFunction`` = rate phi(t) (and
  ``offsetUserFunction_t`` = rate phi'(t)).
* **Time integration**: ``SolveDynamic`` with the generalized-alpha solver, spectral radius
  ``rho_inf``, fixed steps ``h`` (no automatic step size), full Newton (Jacobian every
  iteration), converged when the Newton increment is below 1e-8 (``residualMode = 1``),
  sparse LU, one thread.
* **Output**: a ``SensorNode`` (stored in memory) records the tip's position at every step;
  the tip's lag is its component along the hub's y axis, ``-sin(theta) x + cos(theta) y``
  with theta = rate phi(t) (the hub's prescribed angle): negative when the tip lags behind.
  The Newton iterations of each step are read from the solver's counter in a pre-step user
  function.

Exudyn is imported lazily, so the module imports without it. :func:`spinup` returns a dict
shaped as :func:`spacarpy.bench.spinup.run_spacarpy`'s.
"""
from __future__ import annotations

import time

import numpy as np

from spacarpy.bench.peers.exudyn_cantilever import _not_available, _quiet, _result, _solve_dynamic
from spacarpy.bench.spinup import BEAM, lag_summary, spinup_phi

#: Exudyn's beam is shear deformable: GA = SHEAR_FACTOR * EA stands in for "shear rigid"
SHEAR_FACTOR = 10.0
#: Newton tolerance on the increment (m, rad)
TOL = 1e-8


def spinup(n: int = 10, h: float = 0.05, rho_inf: float = 0.5, rate: float = 4.0,
           t_end: float = 30.0, shear_factor: float = SHEAR_FACTOR) -> dict:
    """The spin-up with ``n`` elements, step ``h`` (s), spectral radius ``rho_inf``, final
    hub rate ``rate`` (rad/s), to ``t_end``: ``t``, ``lag`` and ``radial`` (the tip's
    displacement across and along the hub's x axis, m) at every step (t = 0 included),
    ``its`` (Newton iterations per step), ``total`` (wall s of the solve), ``setup``,
    ``iterations``, ``steps``, ``ok``, ``reason`` and :func:`lag_summary`'s peak, t_peak,
    amplitude (NaN where the run did not get there)."""
    missing = _not_available()
    if missing:
        return missing
    import exudyn as exu
    from exudyn.itemInterface import (
        CoordinateConstraint,
        MarkerNodeCoordinate,
        NodePointGround,
        NodeRigidBody2D,
        ObjectBeamGeometricallyExact2D,
        SensorNode,
    )
    phi = spinup_phi()
    L, EA, EI = BEAM["L"], BEAM["EA"], BEAM["EI"]
    n_steps = int(round(t_end / h))
    with _quiet():
        t0 = time.perf_counter()
        SC = exu.SystemContainer()
        mbs = SC.AddSystem()
        nodes = [mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[x, 0.0, 0.0]))
                 for x in np.linspace(0.0, L, n + 1)]
        for i in range(n):
            mbs.AddObject(ObjectBeamGeometricallyExact2D(
                nodeNumbers=[nodes[i], nodes[i + 1]], length=L / n,
                massPerLength=BEAM["rhoA"], crossSectionInertia=BEAM["rhoIz"],
                bendingStiffness=EI, axialStiffness=EA, shearStiffness=shear_factor * EA))
        ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()),
                                                    coordinate=0))
        for c in range(3):
            m = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=c))
            if c < 2:
                mbs.AddObject(CoordinateConstraint(markerNumbers=[ground, m]))
            else:                                      # the hub's angle: rate * phi(t)
                mbs.AddObject(CoordinateConstraint(
                    markerNumbers=[ground, m],
                    offsetUserFunction=lambda mbs, t, item, offset: rate * phi(t)[0],
                    offsetUserFunction_t=lambda mbs, t, item, offset: rate * phi(t)[1]))
        sensor = mbs.AddSensor(SensorNode(
            nodeNumber=nodes[-1], storeInternal=True, writeToFile=False,
            outputVariableType=exu.OutputVariableType.Position))
        counts = []

        def count(mbs, t):                             # cumulative Newton iterations
            solver = mbs.sys.get("dynamicSolver")
            counts.append(0 if solver is None else int(solver.it.newtonStepsCount))
            return True

        mbs.SetPreStepUserFunction(count)
        mbs.Assemble()
        setup = time.perf_counter() - t0
    ok, total, iterations, reason = _solve_dynamic(exu, mbs, n_steps, h, rho_inf, TOL,
                                                   sensors=True)
    data = np.asarray(mbs.GetSensorStoredData(sensor), dtype=float)
    t = data[:, 0]
    theta = rate * np.array([phi(x)[0] for x in t])
    lag = -np.sin(theta) * data[:, 1] + np.cos(theta) * data[:, 2]
    radial = np.cos(theta) * data[:, 1] + np.sin(theta) * data[:, 2] - L
    its = np.diff(np.append(counts, iterations if iterations is not None else counts[-1]))
    del SC
    return _result(total=total, setup=setup, iterations=iterations, ok=ok, reason=reason,
                   steps=len(its), t=t, lag=lag, radial=radial, its=its, n=n, h=h, rho_inf=rho_inf,
                   rate=rate, **lag_summary(t, lag, t_end=t_end))


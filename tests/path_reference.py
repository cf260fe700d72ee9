"""Reference solutions of the path-following cases (docs/path.md), pure numpy/scipy.

- :func:`elastica_tip`: the cantilever column (clamped at s = 0, free at s = L) under a tip
  force of magnitude F whose line of action is tilted by beta from the column's axis: the
  exact elliptic-integral solution of the inextensible elastica (beta = 0: Euler's
  post-buckling path, P/P_cr = (2 K(k)/pi)^2, k = sin(alpha/2)). A small tilt selects the
  branch in the decks and is part of the reference, so that nothing is fitted.
- Lee's frame: the published limit load of the usual non-dimensional version (as P L^2/EI).
- The curved bistable beam: the closed-form switching forces of Qiu, Lang & Slocum (2004).

The elastica, derived here so that the test can be checked by hand. The angle phi(s) of the
centre line measured from the direction opposite to the force obeys the pendulum equation
``EI phi'' + F sin(phi) = 0`` with ``phi(0) = beta`` (clamped) and ``phi'(L) = 0`` (free, no
moment); with ``k = sin(phi_L / 2)``, ``sin(phi/2) = k sin(psi)`` and ``lam = sqrt(F/EI)``:

    lam L   = K(k) - F(psi0 | k),               psi0 = asin(sin(beta/2) / k)
    lam xi  = 2 (E(k) - E(psi0 | k)) - lam L    (along the line of action, towards the clamp's
                                                 side opposite to the force)
    lam eta = 2 sqrt(k^2 - sin^2(beta/2))       (across it)

and the tip rotation is ``alpha = phi_L - beta = 2 asin(k) - beta``. For beta = 0 these are
the classical ``xi/L = 2E/K - 1``, ``eta/L = 2k/K`` (Timoshenko & Gere, Theory of Elastic
Stability, section 2.7).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

__all__ = ["elastica_tip", "elastica_load_ratio", "LEE_FRAME", "QIU"]


def _psi0(k: float, beta: float) -> float:
    return float(np.arcsin(min(1.0, np.sin(beta / 2) / k)))


def _lam_l(k: float, beta: float) -> float:
    """lam L = K(k) - F(psi0 | k) (scipy's parameter m = k^2)."""
    m = k * k
    return float(ellipk(m) - ellipkinc(_psi0(k, beta), m))


def elastica_load_ratio(alpha) -> np.ndarray:
    """P / P_cr of the perfect cantilever column (beta = 0) at the tip rotation ``alpha``
    (rad): ``(2 K(sin(alpha/2)) / pi)^2``; P_cr = pi^2 EI / (4 L^2)."""
    k = np.sin(np.asarray(alpha, dtype=float) / 2)
    return (2 * ellipk(k * k) / np.pi) ** 2


def elastica_tip(force: float, beta: float = 0.0, L: float = 1.0, EI: float = 1.0) -> dict:
    """The tip of the cantilever elastica under a tip force of magnitude ``force`` (N)
    pointing along ``-(cos beta, -sin beta)``, i.e. the compressive force ``(-F cos beta,
    F sin beta)`` on a column along +x clamped at the origin.

    Returns ``dict(alpha, ux, uy)``: the tip rotation about z (rad) and the tip
    displacement (m) in global x and y, on the branch that starts at the straight column and
    bends towards +y (for beta > 0 the only one continuous in the load; for beta = 0 below
    P_cr the straight column, alpha = 0).
    """
    if force <= 0.0:                                     # unloaded: straight
        return dict(alpha=0.0, ux=0.0, uy=0.0)
    lam = np.sqrt(force / EI)
    target = lam * L
    lo = np.sin(beta / 2)
    if beta == 0.0:
        if target <= np.pi / 2:                          # below P_cr: straight
            return dict(alpha=0.0, ux=0.0, uy=0.0)
        lo = 0.0
    # lam L grows monotonically from 0 (k -> sin(beta/2)) to infinity (k -> 1)
    hi = 1.0 - 1e-16
    k = brentq(lambda kk: _lam_l(kk, beta) - target, lo + 1e-300, hi, xtol=1e-15,
               rtol=1e-15, maxiter=200)
    m = k * k
    p0 = _psi0(k, beta)
    xi = (2 * (ellipe(m) - ellipeinc(p0, m)) - target) / lam
    eta = 2 * np.sqrt(max(m - np.sin(beta / 2) ** 2, 0.0)) / lam
    # xi along u = (cos b, -sin b), eta along v = (sin b, cos b)
    cb, sb = np.cos(beta), np.sin(beta)
    x = xi * cb + eta * sb
    y = -xi * sb + eta * cb
    return dict(alpha=2 * np.arcsin(k) - beta, ux=x - L, uy=y)


#: Lee's frame, the usual non-dimensional version (Lee, Manuel & Rossow 1968; an arc-length
#: benchmark since e.g. Schweizerhof & Wriggers 1986, Simo & Vu-Quoc 1986, Battini 2002): two
#: legs of length 120, hinged at their free ends, E = 720, A = 6, I = 2, a downward load at 24
#: from the corner on the horizontal leg. ``limit_load``: the first (maximum) limit load as
#: P L^2/(EI), 18.5, i.e. P = 1.85 for these E, I, L; ``limit_load_range``: the spread of
#: the published values (18.3 to 18.7, i.e. about +-1 %: beam theories with and without
#: shear and extension, different elements and meshes). [unverified: the values as they are
#: usually quoted; the original papers were not at hand when this was written.]
LEE_FRAME = dict(
    L=120.0, E=720.0, A=6.0, I=2.0, load_at=24.0,
    limit_load=18.5,
    limit_load_range=(18.3, 18.7),
)

#: Qiu, Lang & Slocum, "A curved-beam bistable mechanism", J. Microelectromech. Syst. 13(2)
#: (2004) 137-146: a clamped-clamped beam of span L, initial shape w0 = h/2 (1 - cos(2 pi x/L)),
#: pushed at its midpoint, with its second (antisymmetric) buckling mode suppressed (their
#: double curved beam, or a symmetric model), inextensible, first and third modes only, for
#: Q = h/t large enough that the third mode governs: the switching force
#: ``f_top = 740 EI h / L^3`` near the start, the force at the end of the negative-stiffness
#: stretch ``f_bot = 370 EI h / L^3`` (pulling back), and the second stable position at a
#: travel of 2h (the mirrored shape, midpoint at -h: an equilibrium of the inextensible beam
#: without force). Factors of ``EI h / L^3``; travel in units of h.
QIU = dict(f_top=740.0, f_bot=370.0, travel_second=2.0)

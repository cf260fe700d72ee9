"""Reference values and signal analysis of the centrifugal-stiffening check (docs/transient.md,
"Centrifugal stiffening (Southwell)"; tests/test_southwell.py), pure numpy/scipy.

The problem: a uniform Euler-Bernoulli cantilever (EI, rhoA, L) clamped at the axis of a hub
turning at the constant rate W (zero hub radius). The centrifugal tension is
``N(x) = rhoA W^2 (L^2 - x^2) / 2``, and the small vibrations in the rotating frame obey

    flapwise (out of the plane):  EI w'''' - (N w')' + rhoA w_tt = 0
    lead-lag (in the plane):      EI v'''' - (N v')' - rhoA W^2 v + rhoA v_tt = 0

(the Coriolis coupling of the lead-lag motion with the stretching is left out: the beam is
taken inextensible). The two operators differ by the mass term only, so every lead-lag
frequency is exactly ``w_lag^2 = w_flap^2 - W^2``. :func:`flap_frequencies` solves the flapwise
problem by Rayleigh-Ritz with the basis ``s^2 P_k(2s - 1)`` (k < 12, P_k Legendre), which
satisfies the clamp; the first frequency converges to 1e-9 relative (9 against 12 functions).
Non-dimensional speed ``lam = W sqrt(rhoA L^4 / EI)``.

The Southwell coefficient is the first-order slope ``K = d(w^2)/d(W^2)`` at W = 0; by first-
order perturbation of the eigenvalue it is the Rayleigh quotient of the centrifugal term with
the non-rotating mode phi1: ``K = int (N/W^2) phi1'^2 dx / int rhoA phi1^2 dx`` = 1.19334
(:func:`southwell_coefficient`). The literature value 1.193 (uniform cantilever, zero hub
radius, first flapwise mode; e.g. Bramwell, Helicopter Dynamics) is quoted from memory.
Since w^2 is a concave function of W^2 (the lowest eigenvalue of K_b + W^2 K_N over M), the
linear law ``w0^2 + K W^2`` is tangent at W = 0 and lies above the exact curve.

The tabulated first flapwise frequency of the uniform rotating cantilever, ``w L^2
sqrt(rhoA/EI)`` at lam = 0, 2, ..., 12: 3.5160, 4.1373, 5.5850, 7.3604, 9.2568, 11.2023,
13.1702 (Hodges & Rutkowski 1981, AIAA J. 19(11); also Wright et al. 1982), quoted from memory;
:func:`flap_frequencies` reproduces every digit.

Time integration: for a linear mode of frequency w the generalized-alpha method (Chung &
Hulbert parameters of rho_inf) oscillates at the frequency of the principal root of its
amplification matrix (:func:`alpha_frequency_ratio`), a bit lower than w: 0.9990 w at
w h = 0.09 with rho_inf = 0.5.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sl
from numpy.polynomial import Legendre, Polynomial
from scipy.optimize import minimize_scalar

#: The tabulated first flapwise frequencies (lam, w L^2 sqrt(rhoA/EI)), from memory (above).
HODGES_RUTKOWSKI = ((0, 3.5160), (2, 4.1373), (4, 5.5850), (6, 7.3604), (8, 9.2568),
                    (10, 11.2023), (12, 13.1702))
#: The Southwell coefficient of the first flapwise mode as usually quoted (from memory).
K1_LITERATURE = 1.193
BETA1_L = 1.8751040687119611        # first root of cos(b) cosh(b) = -1


def _quadrature(n: int = 64):
    s, w = np.polynomial.legendre.leggauss(n)
    return (s + 1) / 2, w / 2


def flap_frequencies(lam: float, n_basis: int = 12) -> np.ndarray:
    """The first two non-dimensional flapwise frequencies ``w L^2 sqrt(rhoA/EI)`` of the
    cantilever turning at the non-dimensional speed lam (Rayleigh-Ritz, above)."""
    s, wq = _quadrature()
    basis = [Polynomial([0, 0, 1]) * Legendre.basis(k, domain=[0, 1]).convert(kind=Polynomial)
             for k in range(n_basis)]
    P = np.array([b(s) for b in basis]).T
    P1 = np.array([b.deriv()(s) for b in basis]).T
    P2 = np.array([b.deriv(2)(s) for b in basis]).T
    tension = lam ** 2 * (1 - s ** 2) / 2
    K = (P2 * wq[:, None]).T @ P2 + (P1 * (wq * tension)[:, None]).T @ P1
    M = (P * wq[:, None]).T @ P
    return np.sqrt(sl.eigh(K, M, eigvals_only=True)[:2])


def rotating_frequencies(W: float, EI: float, rhoA: float, L: float) -> tuple[float, float]:
    """(flapwise, lead-lag) first frequencies (rad/s) in the rotating frame at the rate W."""
    c = np.sqrt(EI / (rhoA * L ** 4))
    flap = float(flap_frequencies(W / c)[0] * c)
    return flap, float(np.sqrt(flap ** 2 - W ** 2))


def first_mode(s: np.ndarray):
    """The first non-rotating cantilever mode phi1(s) (tip value 1) and d phi1/ds, s = x/L."""
    b = BETA1_L * s
    r = (np.cosh(BETA1_L) + np.cos(BETA1_L)) / (np.sinh(BETA1_L) + np.sin(BETA1_L))
    phi = ((np.cosh(b) - np.cos(b)) - r * (np.sinh(b) - np.sin(b))) / 2
    dphi = BETA1_L * ((np.sinh(b) + np.sin(b)) - r * (np.cosh(b) - np.cos(b))) / 2
    return phi, dphi


def southwell_coefficient() -> float:
    """K of the first flapwise mode: the Rayleigh quotient of the centrifugal term with the
    non-rotating mode (above)."""
    s, wq = _quadrature(80)
    phi, dphi = first_mode(s)
    return float(np.sum(wq * (1 - s ** 2) / 2 * dphi ** 2) / np.sum(wq * phi ** 2))


def alpha_frequency_ratio(wh: float, rho_inf: float) -> float:
    """The frequency of the generalized-alpha solution of ``u'' + w^2 u = 0`` with the step h,
    over w (w h = wh): the angle of the principal root of the amplification matrix over wh."""
    am = (2 * rho_inf - 1) / (rho_inf + 1)
    af = rho_inf / (rho_inf + 1)
    gamma = 0.5 + af - am
    beta = 0.25 * (gamma + 0.5) ** 2
    w2 = wh ** 2                                  # unknowns (u, h u', h^2 u'') per step
    A = np.array([[w2 * (1 - af), 0, 1 - am], [1, 0, -beta], [0, 1, -gamma]])
    B = np.array([[-w2 * af, 0, -am], [1, 1, 0.5 - beta], [0, 1, 1 - gamma]])
    ev = np.linalg.eigvals(np.linalg.solve(A, B))
    return float(abs(np.angle(ev[np.argmax(np.abs(ev.imag))])) / wh)


def _fit(t, y, w):
    """Least squares of y on (1, cos, sin, t cos, t sin) at the frequency w: the residual."""
    tt = t - t.mean()
    c, s = np.cos(w * tt), np.sin(w * tt)
    X = np.column_stack([np.ones_like(tt), c, s, tt * c, tt * s])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return float(np.sum((X @ coef - y) ** 2))


def measured_frequency(t: np.ndarray, y: np.ndarray) -> float:
    """The frequency (rad/s) of the oscillation y(t): the first guess from the mean spacing of
    the zero crossings of y - mean(y), then the least-squares fit of ``c + (a + a' t) cos(w t)
    + (b + b' t) sin(w t)`` over the whole record, minimized in w (the linear factors of the
    amplitudes take a slow decay or growth)."""
    z = y - y.mean()
    i = np.nonzero(np.sign(z[:-1]) * np.sign(z[1:]) < 0)[0]
    tc = t[i] - z[i] * (t[i + 1] - t[i]) / (z[i + 1] - z[i])
    if len(tc) < 4:
        raise ValueError(f"only {len(tc)} zero crossings: the record is too short")
    w0 = np.pi * (len(tc) - 1) / (tc[-1] - tc[0])
    res = minimize_scalar(lambda w: _fit(t, y, w), bounds=(0.9 * w0, 1.1 * w0),
                          method="bounded", options={"xatol": 1e-10 * w0})
    return float(res.x)


def tip_in_rotating_frame(position: np.ndarray, hub_euler: np.ndarray):
    """(radial, lead-lag, flapwise) of the tip in the frame of a hub turning about z.

    position : (n_t, 3) the tip's global position; hub_euler : (n_t, 4) the hub node's Euler
    parameters (lambda0, lambda1, lambda2, lambda3), a rotation about z by 2 atan2(l3, l0)."""
    theta = 2 * np.arctan2(hub_euler[:, 3], hub_euler[:, 0])
    x, y, z = position.T
    return (np.cos(theta) * x + np.sin(theta) * y, -np.sin(theta) * x + np.cos(theta) * y, z)

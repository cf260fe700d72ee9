"""Time functions phi(t) of a transient run: a small registry of kinds.

phi(t) is the factor on the DELXF loads and on the prescribed-motion increments (deck:
``TIMEFUNCTION kind params``). Each kind declares its description, how many parameters it
takes and which must be positive, and evaluates phi with its first two derivatives. The deck
layer checks TIMEFUNCTION lines against this registry; the transient solver evaluates it.
Both import it from here, so neither depends on the other.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["KINDS", "TIME_FUNCTIONS", "TimeFunction", "TimeFunctionKind"]


@dataclass(frozen=True)
class TimeFunctionKind:
    """One kind of time function.

    Attributes
    ----------
    name : str
        The deck word (``TIMEFUNCTION ramp 0.5``).
    description : str
        What phi is, for messages and docs.
    n_params : int or None
        The number of numeric parameters; None: the kind checks its own (``table``, ``expr``).
    positive_first : bool
        The first parameter must be positive (a duration or a frequency).
    phi : callable
        ``phi(t, params) -> (phi, dphi/dt, d2phi/dt2)``.
    """

    name: str
    description: str
    n_params: int | None
    positive_first: bool
    phi: Callable


def _ramp(t, p):
    T = p[0]
    return (t / T, 1.0 / T, 0.0) if t < T else (1.0, 0.0, 0.0)


def _smoothstep(t, p):
    T = p[0]
    if t >= T:
        return 1.0, 0.0, 0.0
    s = t / T
    return 3 * s * s - 2 * s**3, (6 * s - 6 * s * s) / T, (6 - 12 * s) / T**2


def _spinup(t, p):
    T = p[0]
    if t >= T:
        return t - T / 2, 1.0, 0.0
    w = 2 * math.pi / T
    return ((t * t / 2 + (math.cos(w * t) - 1) / w**2) / T,
            (t - math.sin(w * t) / w) / T, (1 - math.cos(w * t)) / T)


def _sine(t, p):
    w = 2 * math.pi * p[0]
    return math.sin(w * t), w * math.cos(w * t), -w * w * math.sin(w * t)


def _table(t, p):
    ts, vs = np.asarray(p[0::2], float), np.asarray(p[1::2], float)
    if t <= ts[0] or t >= ts[-1]:
        return float(vs[0] if t <= ts[0] else vs[-1]), 0.0, 0.0
    i = int(np.searchsorted(ts, t, side="right")) - 1
    rate = (vs[i + 1] - vs[i]) / (ts[i + 1] - ts[i])
    return float(vs[i] + rate * (t - ts[i])), float(rate), 0.0


def _expr(t, p):
    from spacarpy.expressions import evaluate
    text = str(p[0])
    h = 1e-4 * max(1.0, abs(t))
    f0, fp, fm = (evaluate(text, {"t": t + d}) for d in (0.0, h, -h))
    return f0, (fp - fm) / (2 * h), (fp - 2 * f0 + fm) / (h * h)


def _kind(name, description, n_params, positive_first, phi) -> TimeFunctionKind:
    return TimeFunctionKind(name, description, n_params, positive_first, phi)


#: The time-function kinds by deck word, in the order docs/transient.md lists them.
KINDS: dict[str, TimeFunctionKind] = {k.name: k for k in (
    _kind("constant", "phi = 1 (the loads of the end of the static path, unchanged)", 0, False,
          lambda t, p: (1.0, 0.0, 0.0)),
    _kind("zero", "phi = 0 (DELXF removed at t = 0: release from a static deflection)", 0,
          False, lambda t, p: (0.0, 0.0, 0.0)),
    _kind("linear", "phi = t (DELINPR angle = angular velocity, DELXF = force rate)", 0, False,
          lambda t, p: (t, 1.0, 0.0)),
    _kind("ramp", "phi = min(t / T, 1)", 1, True, _ramp),
    _kind("smoothstep", "phi = 3 s^2 - 2 s^3, s = min(t / T, 1)", 1, True, _smoothstep),
    _kind("spinup", "phi = (t^2/2 + (T/2pi)^2 (cos(2 pi t/T) - 1)) / T for t < T, t - T/2 "
          "after (Simo & Vu-Quoc's spin-up: the rate rises smoothly from 0 to 1 at t = T)", 1,
          True, _spinup),
    _kind("sine", "phi = sin(2 pi f t)", 1, True, _sine),
    _kind("table", "phi piecewise linear through (t1, phi1), (t2, phi2), ...; constant outside",
          None, False, _table),
    _kind("expr", 'phi = the expression in t given as a string, e.g. "1 - exp(-t/0.1)" (the '
          "functions and operators of {expressions}; derivatives by central differences)", None,
          False, _expr),
)}

#: Kind -> description (for messages and docs).
TIME_FUNCTIONS = {name: k.description for name, k in KINDS.items()}


@dataclass(frozen=True)
class TimeFunction:
    """phi(t) with its first and second derivatives (see :data:`KINDS`)."""

    kind: str = "constant"
    params: tuple = ()

    def __call__(self, t: float) -> tuple[float, float, float]:
        k = KINDS.get(self.kind)
        if k is None:
            raise ValueError(f"unknown time function {self.kind!r}")
        return k.phi(t, self.params)

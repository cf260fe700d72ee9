"""Time functions phi(t) of a transient run: the factor on the DELXF loads and on the
prescribed-motion increments (deck: TIMEFUNCTION), with its first two derivatives.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Time functions phi(t) for the DELXF loads and the prescribed-motion increments.
TIME_FUNCTIONS = {
    "constant": "phi = 1 (the loads of the end of the static path, unchanged)",
    "zero": "phi = 0 (DELXF removed at t = 0: release from a static deflection)",
    "linear": "phi = t (DELINPR angle = angular velocity, DELXF = force rate)",
    "ramp": "phi = min(t / T, 1)",
    "smoothstep": "phi = 3 s^2 - 2 s^3, s = min(t / T, 1)",
    "spinup": "phi = (t^2/2 + (T/2pi)^2 (cos(2 pi t/T) - 1)) / T for t < T, t - T/2 after "
              "(Simo & Vu-Quoc's spin-up: the rate rises smoothly from 0 to 1 at t = T)",
    "sine": "phi = sin(2 pi f t)",
    "table": "phi piecewise linear through (t1, phi1), (t2, phi2), ...; constant outside",
    "expr": 'phi = the expression in t given as a string, e.g. "1 - exp(-t/0.1)" (the '
            "functions and operators of {expressions}; derivatives by central differences)",
}


@dataclass(frozen=True)
class TimeFunction:
    """phi(t) with its first and second derivatives (see :data:`TIME_FUNCTIONS`)."""

    kind: str = "constant"
    params: tuple = ()

    def __call__(self, t: float) -> tuple[float, float, float]:
        k, p = self.kind, self.params
        if k == "constant":
            return 1.0, 0.0, 0.0
        if k == "zero":
            return 0.0, 0.0, 0.0
        if k == "linear":
            return t, 1.0, 0.0
        if k == "ramp":
            T = p[0]
            return (t / T, 1.0 / T, 0.0) if t < T else (1.0, 0.0, 0.0)
        if k == "smoothstep":
            T = p[0]
            if t >= T:
                return 1.0, 0.0, 0.0
            s = t / T
            return 3 * s * s - 2 * s**3, (6 * s - 6 * s * s) / T, (6 - 12 * s) / T**2
        if k == "spinup":
            T = p[0]
            if t >= T:
                return t - T / 2, 1.0, 0.0
            w = 2 * math.pi / T
            return ((t * t / 2 + (math.cos(w * t) - 1) / w**2) / T,
                    (t - math.sin(w * t) / w) / T, (1 - math.cos(w * t)) / T)
        if k == "sine":
            w = 2 * math.pi * p[0]
            return math.sin(w * t), w * math.cos(w * t), -w * w * math.sin(w * t)
        if k == "expr":
            from spacarpy.deck.expressions import evaluate
            text = str(p[0])
            h = 1e-4 * max(1.0, abs(t))
            f0, fp, fm = (evaluate(text, {"t": t + d}) for d in (0.0, h, -h))
            return f0, (fp - fm) / (2 * h), (fp - 2 * f0 + fm) / (h * h)
        if k == "table":
            ts, vs = np.asarray(p[0::2], float), np.asarray(p[1::2], float)
            if t <= ts[0] or t >= ts[-1]:
                return float(vs[0] if t <= ts[0] else vs[-1]), 0.0, 0.0
            i = int(np.searchsorted(ts, t, side="right")) - 1
            rate = (vs[i + 1] - vs[i]) / (ts[i + 1] - ts[i])
            return float(vs[i] + rate * (t - ts[i])), float(rate), 0.0
        raise ValueError(f"unknown time function {k!r}")


__all__ = ["TIME_FUNCTIONS", "TimeFunction"]

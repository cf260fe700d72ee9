"""The rolling wheels' contact forces along a static path or a transient: the lift-off
warning, the per-step flags and the largest friction ratio.

A WHEEL's stored stress resultants (``stress_sign`` applied) hold the ground's force on the
wheel: mode 6 the normal force (compression positive), modes 4 and 5 the tangential forces
along the heading and lateral directions. A negative normal force means the ground would
have to pull the wheel down: the wheel would lift off, which the bilateral contact cannot
represent. The friction ratio ``|(nu4, nu5)| / nu6`` is the friction coefficient the rolling
needs (docs/rolling.md, "Statics and the linearizations at rest").
"""
from __future__ import annotations

import logging

import numpy as np

log = logging.getLogger(__name__)

__all__ = ["ContactMonitor"]


class ContactMonitor:
    """Watches the WHEEL contact forces of the stored steps: :meth:`__call__` returns the
    lift-off warning of a step (or None); :attr:`largest` is the largest friction ratio
    seen, with its element and step."""

    def __init__(self, num):
        self.groups = [g for g in num.groups if g.keyword == "WHEEL" and g.n_elem]
        self.largest = None                  # (ratio, element, step)

    def __bool__(self) -> bool:
        return bool(self.groups)

    @staticmethod
    def flags(stress: dict, tol: float = 0.0) -> dict:
        """``{"lift_off": (n,) int8, "friction_ratio": (n,)}`` of the WHEELs of a step's
        stress resultants (empty without wheels): 1 where the normal force is below
        ``-tol`` (N: a bound of its round-off, so that a wheel carrying no load is not
        flagged by the sign of its round-off), and ``|(s4, s5)|/s6`` (inf where the normal
        force is not positive)."""
        sig = stress.get("WHEEL")
        if sig is None:
            return {}
        normal, tangential = sig[:, 5], np.hypot(sig[:, 3], sig[:, 4])
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(normal > 0, tangential / normal, np.inf)
        return {"lift_off": (normal < -tol).astype(np.int8), "friction_ratio": ratio}

    def __call__(self, stress: dict, step: int, label: str, quiet: bool = False,
                 tol: float = 0.0) -> str | None:
        """The lift-off warning of a step (None without one; ``tol`` as in :meth:`flags`),
        logged unless ``quiet``; the step's friction ratios join :attr:`largest`."""
        sig = stress.get("WHEEL")
        if sig is None or not self.groups:
            return None
        ids = self.groups[0].ids
        normal = sig[:, 5]
        ratio = self.flags(stress)["friction_ratio"]
        finite = np.flatnonzero(normal > 0)
        if finite.size:
            i = int(finite[np.argmax(ratio[finite])])
            if self.largest is None or ratio[i] > self.largest[0]:
                self.largest = (float(ratio[i]), int(ids[i]), step)
        lift = np.flatnonzero(normal < -tol)
        if not lift.size:
            return None
        names = ", ".join(f"WHEEL {int(ids[i])} ({normal[i]:.4g} N)" for i in lift)
        msg = (f"{label}: negative normal force (WHEEL mode 6) at {names}: the wheel would "
               f"lift off the ground, which the rolling contact cannot represent (it holds "
               f"the wheel on the ground)")
        if not quiet:
            log.warning(msg)
        return msg

    def report(self, unit: str = "step") -> str | None:
        """The largest friction ratio of the path, one line (None without wheels);
        ``unit`` names the step (``"time step"`` in a transient)."""
        if not self.groups or self.largest is None:
            return None
        r, e, k = self.largest
        return (f"largest friction ratio |(nu4, nu5)|/nu6 needed by the rolling contact: "
                f"{r:.4g} (WHEEL {e}, {unit} {k})")

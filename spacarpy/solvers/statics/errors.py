"""The failure of one solver step, as the load path and time stepping see it.

:class:`StepFailed` is raised by an iteration (static Newton, a transient step) that did not
converge; the caller cuts the step and retries, and only when it can cut no further turns it
into a :class:`~spacarpy.errors.ConvergenceError` for the user.
"""
from __future__ import annotations


class StepFailed(Exception):
    """An iteration did not converge: ``reason`` says why, ``history`` holds the scaled
    residuals of its iterations; ``chord``: some of its increments came from a kept (older)
    iteration matrix, so a retry with new matrices may succeed where it failed."""

    def __init__(self, reason: str, history=(), chord: bool = False):
        super().__init__(reason)
        self.reason = reason
        self.history = list(history)
        self.chord = chord


__all__ = ["StepFailed"]

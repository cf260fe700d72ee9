"""The certified stability of every stored arc-length point (``/static/stability``).

Each point stored on an arc-length path gets one status, decided by a round-off bound and
never by the sign of a pivot: **stable** (the reduced tangent's index is proven 0),
**unstable** (a negative eigenvalue is proven), **undetermined** (an eigenvalue nearest zero
lies within its round-off bound, so neither is proven), or **critical** (a refined critical
point of ``/critical``, where an eigenvalue is zero by construction). The status comes from

- the index proven by two shifted LDL^T factorizations with a componentwise bound
  (:func:`~spacarpy.solvers.path.inertia_bracket.certified_index`) where the tangent-space
  form applies (Euler normalizations the only constraints): different shifted counts are
  undetermined (an eigenvalue in ``[-tau, tau]``);
- else the eigenvalues nearest zero with their normwise bounds
  (:func:`~spacarpy.solvers.path.stability.near_zero`), which the solver computes at every
  point of such a model anyway: one within its bound is undetermined; the sign of the
  bordered determinant adds an odd number of negative eigenvalues outside that window.

A status is a fact about the point or "undetermined": the same with any number of BLAS
threads (an eigenvalue that sits within the round-off of the bound itself could flip it;
the bound is a fixed multiple of the computed round-off, so that band is narrow). Where a
stretch of undetermined points separates two certified points of different index and no
critical point was located in it, an index change is certified but cannot be located:
:meth:`StatusTrack.check` says so, and the path stores an "undetermined" point of
``/critical`` there. A pivot that flips with round-off inside such a stretch stores nothing
(docs/path.md, "Critical points" and Limits).
"""
from __future__ import annotations

import logging

import numpy as np

from spacarpy.solvers.linalg.certificate import Certificate, certified_sign
from spacarpy.solvers.path.inertia_bracket import certified_index
from spacarpy.solvers.path.stability import near_zero

log = logging.getLogger(__name__)

#: Codes of ``/static/stability``.
NOT_CHECKED, STABLE, UNSTABLE, UNDETERMINED, CRITICAL = -1, 0, 1, 2, 3
STATUS_NAMES = {NOT_CHECKED: "not checked", STABLE: "stable", UNSTABLE: "unstable",
                UNDETERMINED: "undetermined", CRITICAL: "critical point"}


def bracket_applies(prob) -> bool:
    """Whether :func:`certified_index` applies to ``prob`` (the tangent-space form and
    qdldl)."""
    from spacarpy.solvers.path import inertia_bracket
    return inertia_bracket._qdldl is not None and getattr(prob, "reduced", None) is not None


def cached_bracket(prob, load, q):
    """:func:`certified_index` at the point q, computed once (``q.bracket``, shared with
    :func:`~spacarpy.solvers.path.inertia_bracket.bracket_verdict`)."""
    if getattr(q, "bracket", None) is None:
        try:
            q.bracket = certified_index(prob, q.x, q.mu, load(q.s))
        except Exception:                  # noqa: BLE001 -- a zero pivot: not proven
            q.bracket = (None, None)
    return q.bracket


def point_status(prob, load, q, m: int = 0):
    """``(status, index, certificate)`` of the point q (``x, mu, s``; ``near``, ``det`` where
    the solver has them) under ``load(s)``: index the certified number of negative
    eigenvalues (None where undetermined, or unstable with negative eigenvalues beyond the
    window of the nearest ones), ``m`` the constraint rows of the bordered determinant."""
    if bracket_applies(prob):
        index, cert = cached_bracket(prob, load, q)
        if index is None:
            # an eigenvalue in [-tau, tau] (or a zero pivot): its magnitude at least 0
            tau = cert.margin if cert is not None else np.inf
            return UNDETERMINED, None, Certificate(0.0, tau)
        return (STABLE if index == 0 else UNSTABLE), index, cert
    if getattr(q, "near", None) is None:
        q.near = near_zero(prob, q.x, q.mu, load(q.s))
    lam, bound = q.near
    sign = certified_sign(lam, bound)
    if not lam.size:
        return STABLE, 0, Certificate(np.inf, 0.0)
    i = int(np.argmin(np.abs(lam) / np.maximum(bound, 1e-300)))
    cert = Certificate(float(abs(lam[i])), float(bound[i]))
    if np.any(sign == 0):
        return UNDETERMINED, None, cert
    neg = int(np.sum(sign < 0))
    det = getattr(q, "det", 0)
    if det and (det * (-1) ** m < 0) != (neg % 2 == 1):
        return UNSTABLE, None, cert           # an odd number beyond the window
    return (UNSTABLE if neg else STABLE), neg, cert


def _ranges(steps) -> str:
    """``1-4, 7, 9-10`` for the steps [1, 2, 3, 4, 7, 9, 10]."""
    out, start = [], None
    for i, k in enumerate(steps):
        if start is None:
            start = k
        if i + 1 == len(steps) or steps[i + 1] != k + 1:
            out.append(f"{start}" if start == k else f"{start}-{k}")
            start = None
    return ", ".join(out)


class StatusTrack:
    """The statuses of the points stored along one path, in order (step 0 first), and
    whether a stretch of undetermined points hides a certified change of the index."""

    def __init__(self, prob, load, m: int = 0):
        self.prob, self.load, self.m = prob, load, m
        self.ref = None              # the index of the last certified point ...
        self.gap = False             # ... and whether undetermined points followed it
        self.stretch = None          # the certificate of the last undetermined point
        self.steps: list[int] = []   # the status of each stored step
        self.undetermined: list[int] = []

    def critical(self) -> int:
        """A refined critical point is stored: its row's status; the index after it is
        compared with nothing before it."""
        self.ref, self.gap = None, False
        return self._add(CRITICAL)

    def check(self, q):
        """``(status, changed)`` of the point q about to be stored: changed where it is
        certified and its index differs from that of the last certified point before a
        stretch of undetermined points (with no critical point stored since)."""
        status, index, cert = point_status(self.prob, self.load, q, self.m)
        changed = False
        if status == UNDETERMINED:
            self.gap, self.stretch = True, cert
        elif index is not None:
            changed = self.gap and self.ref is not None and index != self.ref
            self.ref, self.gap = index, False
        else:
            self.ref, self.gap = None, False
        return status, changed

    def stored(self, status: int) -> int:
        """The point checked last was stored with ``status``; returns it."""
        return self._add(status)

    def _add(self, status: int) -> int:
        if status == UNDETERMINED:
            self.undetermined.append(len(self.steps))
        self.steps.append(status)
        return status

    def warn(self) -> None:
        """Once per path: the steps whose stability is undetermined."""
        if self.undetermined:
            log.warning("ARCLENGTH: the stability of %d of the %d stored points is "
                        "undetermined (static steps %s): an eigenvalue nearest zero lies "
                        "within its round-off bound there; /static/stability stores the "
                        "status of every point, no critical point is stored for them "
                        "(docs/path.md, Limits)", len(self.undetermined), len(self.steps),
                        _ranges(self.undetermined))


__all__ = ["NOT_CHECKED", "STABLE", "UNSTABLE", "UNDETERMINED", "CRITICAL", "STATUS_NAMES",
           "point_status", "StatusTrack", "bracket_applies", "cached_bracket"]

"""Round-off certificates: whether the sign of a computed number is known.

Every stored classification that hangs on the sign of a number near zero (an eigenvalue of
the reduced tangent: stable, unstable, a critical point passed; a buckling multiplier
infinite or finite; a mode infinite) is decided here, by one rule: the number's magnitude
(its *margin*) is compared with a round-off bound computed for that model and state, and
inside the bound the answer is *undetermined*, never a guess.

The bound of a quantity computed by a backward-stable method from a matrix A of n
coordinates is ``SAFETY n eps scale``: the backward error of a symmetric eigensolver, of an
LU or LDL^T with bounded growth, is a small multiple of ``n eps ||A||`` (Golub & Van Loan,
sections 3.3, 8.4), and ``scale`` is that norm (or, for a quadratic form ``v^T A v`` of a unit
vector, ``|v|^T |A| |v|``, the sum of the magnitudes that were added up).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Safety factor above the backward error (measured ratios of the round-off to ``n eps
#: scale`` are 0.4 to 8 on the Table 3 decks' buckling forms, 1e-3 to 1e-1 on the reduced
#: tangents of Lee's frame and the columns, docs/path.md).
SAFETY = 10.0
#: Machine epsilon.
EPS = float(np.finfo(float).eps)
#: The sign of an undetermined value (:func:`certified_sign`).
UNDETERMINED = 0


def round_off_bound(scale, n: int, safety: float = SAFETY):
    """``safety n eps scale``: the round-off of a number computed from a matrix of norm
    ``scale`` (or a sum of magnitudes ``scale``) with n coordinates."""
    return safety * max(int(n), 1) * EPS * np.asarray(scale, dtype=float)


def certified_sign(value, bound) -> np.ndarray:
    """The sign (-1, +1) of each value whose magnitude exceeds its bound, else
    :data:`UNDETERMINED` (0); NaN is undetermined."""
    value = np.asarray(value, dtype=float)
    with np.errstate(invalid="ignore"):
        decided = np.abs(value) > np.asarray(bound, dtype=float)
    return np.where(decided, np.sign(value), UNDETERMINED).astype(int)


@dataclass(frozen=True)
class Certificate:
    """The number that decided a classification (``margin``: its magnitude) and the
    round-off bound it was compared with; ``decided`` when the margin exceeds it."""

    margin: float
    bound: float

    @property
    def decided(self) -> bool:
        return bool(self.margin > self.bound)


def inertia(eigenvalues, scale: float, n: int):
    """Sylvester's inertia of a symmetric matrix from its computed eigenvalues, certified:
    ``(negative, undetermined, certificate)``, the counts of the certified negative and of
    the undetermined eigenvalues, and the certificate of the eigenvalue nearest zero
    (``scale``: the matrix's norm; n: its order)."""
    lam = np.asarray(eigenvalues, dtype=float)
    bound = float(round_off_bound(scale, n))
    sign = certified_sign(lam, bound)
    margin = float(np.abs(lam).min()) if lam.size else np.inf
    return int(np.sum(sign < 0)), int(np.sum(sign == UNDETERMINED)), Certificate(margin, bound)


__all__ = ["Certificate", "SAFETY", "EPS", "UNDETERMINED", "round_off_bound",
           "certified_sign", "inertia"]

"""Second-order forward differentiation of small element kernels (the WHEEL's), vectorized.

A :class:`Jet` carries a function of m variables through a kernel's arithmetic with its value,
gradient and Hessian, for n elements at once:

val : (n, c)
    c components (3 for a vector, 1 for a scalar);
g : (n, c, m)
    the exact first derivatives;
h : (n, c, m, m) or None
    the exact second derivatives (None: first order only, where the caller needs no more).

The operations are those of a kernel built from dot and cross products, normalizations and
Euler-parameter rotations: sums, element-wise products (the product rule), components, sums
over components, and scalar functions with their first two derivatives (the chain rule).
No finite differences anywhere: the derivatives are exact to round-off, as the kernels of the
other kinds (written out by hand there).
"""
from __future__ import annotations

import numpy as np


class Jet:
    """A vector-valued function of m variables with its exact first (and second) derivatives
    (shapes in the module docstring)."""

    __slots__ = ("val", "g", "h")

    def __init__(self, val: np.ndarray, g: np.ndarray, h: np.ndarray | None):
        self.val, self.g, self.h = val, g, h

    # ------------------------------------------------------------------ construction
    @staticmethod
    def variables(z: np.ndarray, start: int, count: int, m: int, second: bool) -> Jet:
        """The variables ``z[:, start:start + count]`` (of m in all) as a jet."""
        n = z.shape[0]
        g = np.zeros((n, count, m))
        g[:, np.arange(count), start + np.arange(count)] = 1.0
        h = np.zeros((n, count, m, m)) if second else None
        return Jet(z[:, start:start + count].copy(), g, h)

    @staticmethod
    def constant(val: np.ndarray, m: int, second: bool) -> Jet:
        """A constant (n, c)."""
        n, c = val.shape
        return Jet(val, np.zeros((n, c, m)), np.zeros((n, c, m, m)) if second else None)

    @property
    def second(self) -> bool:
        return self.h is not None

    # ------------------------------------------------------------------ arithmetic
    def __add__(self, other: Jet) -> Jet:
        return Jet(self.val + other.val, self.g + other.g,
                   None if self.h is None else self.h + other.h)

    def __sub__(self, other: Jet) -> Jet:
        return Jet(self.val - other.val, self.g - other.g,
                   None if self.h is None else self.h - other.h)

    def __neg__(self) -> Jet:
        return Jet(-self.val, -self.g, None if self.h is None else -self.h)

    def __mul__(self, other: Jet) -> Jet:
        """Element-wise product (a component count of 1 broadcasts)."""
        a, b = self, other
        val = a.val * b.val
        g = a.val[:, :, None] * b.g + b.val[:, :, None] * a.g
        h = None
        if a.h is not None:
            outer = a.g[:, :, :, None] * b.g[:, :, None, :]
            h = (a.val[:, :, None, None] * b.h + b.val[:, :, None, None] * a.h
                 + outer + outer.transpose(0, 1, 3, 2))
        return Jet(val, g, h)

    def times(self, c: float) -> Jet:
        """The product with a constant number."""
        return Jet(c * self.val, c * self.g, None if self.h is None else c * self.h)

    def take(self, idx) -> Jet:
        """The components ``idx``."""
        return Jet(self.val[:, idx], self.g[:, idx], None if self.h is None else self.h[:, idx])

    def sum(self) -> Jet:
        """The sum of the components (one component)."""
        return Jet(self.val.sum(axis=1, keepdims=True), self.g.sum(axis=1, keepdims=True),
                   None if self.h is None else self.h.sum(axis=1, keepdims=True))

    def apply(self, f: np.ndarray, df: np.ndarray, ddf: np.ndarray) -> Jet:
        """A scalar function applied component-wise, given its value f, first and second
        derivatives df, ddf at ``self.val`` (each the shape of val): the chain rule."""
        g = df[:, :, None] * self.g
        h = None
        if self.h is not None:
            h = (df[:, :, None, None] * self.h
                 + ddf[:, :, None, None] * self.g[:, :, :, None] * self.g[:, :, None, :])
        return Jet(f, g, h)

    def sqrt(self) -> Jet:
        r = np.sqrt(self.val)
        return self.apply(r, 0.5 / r, -0.25 / (r * self.val))

    def reciprocal(self) -> Jet:
        inv = 1.0 / self.val
        return self.apply(inv, -inv * inv, 2.0 * inv * inv * inv)


_P1, _P2 = [1, 2, 0], [2, 0, 1]


def dot(a: Jet, b: Jet) -> Jet:
    """``a . b`` of two 3-vector jets (one component)."""
    return (a * b).sum()


def cross(a: Jet, b: Jet) -> Jet:
    """``a x b`` of two 3-vector jets."""
    return a.take(_P1) * b.take(_P2) - a.take(_P2) * b.take(_P1)


def norm(a: Jet) -> Jet:
    """``|a|`` (one component)."""
    return dot(a, a).sqrt()


def unit(a: Jet) -> Jet:
    """``a / |a|``."""
    return a * norm(a).reciprocal()


def rotate(q: Jet, v: np.ndarray) -> Jet:
    """``R(q) v`` for Euler parameters q (a 4-component jet) and constant vectors v (n, 3):
    ``(q0^2 - l.l) v + 2 q0 (l x v) + 2 l (l . v)`` (:func:`spacarpy.rotation.rotate`),
    exact for unnormalized q."""
    m, second = q.g.shape[2], q.second
    q0, lam = q.take([0]), q.take([1, 2, 3])
    c = Jet.constant(v, m, second)
    return ((q0 * q0 - dot(lam, lam)) * c + (q0 * cross(lam, c)).times(2.0)
            + (lam * dot(lam, c)).times(2.0))

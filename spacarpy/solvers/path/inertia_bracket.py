"""The index of the reduced tangent certified by two shifted LDL^T factorizations.

Where the eigenvalues nearest zero lie within their normwise bound (``SAFETY n eps
||ks||``, :mod:`spacarpy.solvers.linalg.certificate`), the number of negative eigenvalues
(the index) can still be proven from the inertia of two factorizations, with an a-posteriori
*componentwise* bound instead of ``n eps``: the bound scales with the entries the sums
actually add, not with the order of the matrix (docs/path.md, Limits).

The matrix is the reduced tangent in the tangent coordinates of the Euler normalizations
(:mod:`spacarpy.solvers.linear.eigen_tangent`), ``K = sum_e T_e^T (D_e^T S_e D_e + H_e)
T_e`` from the element blocks as computed, Jacobi-scaled: ``A = W K W``. Its assembled
floating-point form ``fl(A)`` differs from A entrywise by at most ``gamma_c |A|_abs``
(``|A|_abs`` the same sums of magnitudes, ``gamma_c = c eps / (1 - c eps)``, c the length
of the longest chain of rounded operations that makes an entry). The LDL^T of ``fl(A) -
sigma I`` (qdldl, fill-reducing permutation, 1x1 pivots) is the exact factorization of
``fl(A) - sigma I + E`` with ``|E| <= gamma_k |L| |D| |L|^T`` (k from the factor's longest
row: Higham, Accuracy and Stability, Thms. 9.3, 10.3). Both perturbations are bounded in
the 2-norm by the spectral radius of their nonnegative matrices, bounded from above by
Collatz-Wielandt (``rho(N) <= max_i (N x)_i / x_i`` for any positive x). So with ``B``
the sum of the two bounds, Sylvester's law on the computed pivots gives exactly
``nu(sigma) = #eig(A - sigma I + E_total) < 0`` with ``||E_total|| <= B``, and by Weyl

    nu(-tau) <= #eig(A) < 0 <= nu(+tau)      for tau >= B (each shift's own B).

Where the two counts agree the index is proven: no eigenvalue lies in ``[B - tau, tau -
B)``. Where they differ it stays undetermined. The certificate it gives is ``(tau, B)``.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from spacarpy.solvers.linalg.certificate import EPS, Certificate
from spacarpy.solvers.linear.eigen_tangent import _rotate_columns, _Tangent
from spacarpy.solvers.linear.linearize import linearize

try:
    import qdldl as _qdldl
except ImportError:                        # pragma: no cover - qdldl is a dependency
    _qdldl = None

#: The shift over the largest bound: tau = TAU_FACTOR B (a shift of at least B is needed;
#: the nearer to B, the nearer to zero an eigenvalue can be and still be counted).
TAU_FACTOR = 1.25
#: Shifts tried, each TAU_FACTOR times the largest bound of the one before.
SHIFT_TRIES = 3
#: Power iterations before the Collatz-Wielandt bound (any number gives an upper bound).
POWER_STEPS = 30


def gamma(c: int) -> float:
    """``c eps / (1 - c eps)``: the relative error of c rounded operations in a chain."""
    return c * EPS / (1.0 - c * EPS)


def spectral_radius_bound(matvec, n: int) -> float:
    """An upper bound of the spectral radius of a nonnegative symmetric matrix (given by its
    product): Collatz-Wielandt's ``max (N x)_i / x_i`` for a positive x from a few power
    steps, raised by 1e-10 for the rounding of the product's nonnegative sums."""
    x = np.ones(n)
    for _ in range(POWER_STEPS):
        y = matvec(x)
        top = float(y.max(initial=0.0))
        if top <= 0.0:
            return 0.0
        x = np.maximum(y / top, 1e-6)
    return float(np.max(matvec(x) / x)) * (1.0 + 1e-10)


class _NoMass:
    """A zero mass (the statics have none): linearize then keeps the element blocks."""

    def __init__(self, n: int):
        self.n = n

    def matrix(self, x):
        return sp.csr_matrix((self.n, self.n))


def _symmetric(upper) -> sp.csr_matrix:
    upper = sp.csr_matrix(upper)
    return (upper + sp.triu(upper, 1).T).tocsr()


def _tangent_and_magnitudes(prob, x, mu, load):
    """``(K, |K|_abs, c)``: the assembled reduced tangent in tangent coordinates, the same
    sums of the entries' magnitudes and the longest chain of rounded operations of an
    entry (the rotations, the two products of ``D^T S D``, the Hessian's rotations, the
    assembly of the contributions)."""
    num = prob.num
    lin = linearize(prob, x, mu, load, mass=_NoMass(num.n_unknown))
    tan = _Tangent(lin, num)
    rn = lin.reduced
    parts, euler_diag = lin.blocks
    b = rn.basis(lin.x[rn.eu])
    mags, ones, n_def = [], [], 1
    for (D, S, H), starts, nodes in zip(parts, rn.slots, rn.slot_nodes):
        bases = [np.abs(b[nd]) for nd in nodes]
        da = _rotate_columns(np.abs(D), bases, starts)
        k = da.transpose(0, 2, 1) @ (np.abs(S) @ da)
        n_def = max(n_def, S.shape[-1])
        if H is not None:
            ha = _rotate_columns(np.abs(H), bases, starts)
            for s, be in zip(starts, bases):
                ha[:, s:s + 4, :] = be.transpose(0, 2, 1) @ ha[:, s:s + 4, :]
            k = k + ha
        mags.append(k)
        ones.append(np.ones_like(k))
    n_eu = rn.nodes.size
    eye = np.broadcast_to(np.eye(4), (n_eu, 4, 4))
    mag = rn.pattern.assemble(mags + [np.abs(euler_diag)[:, None, None] * eye])
    terms = rn.pattern.assemble(ones + [eye])               # contributions per entry
    # D rotated (4 terms), S D and D^T (S D) (n_def terms each), the rounding of the
    # rotations inside the product (twice 4), the Hessian added, the assembly's sum
    c = 4 + 2 * n_def + 8 + 1 + int(np.ceil(max(abs(terms).max(), 1.0)))
    return _symmetric(tan.upper), _symmetric(mag), c


def _count(a, sigma: float, a_rho: float, c_asm: float):
    """``(nu, B)``: the negative pivots of the LDL^T of ``a - sigma I`` and the bound of
    its backward error plus the assembly's (``c_asm``, already in ``B`` units)."""
    n = a.shape[0]
    m = (a - sigma * sp.identity(n, format="csr")).tocsc()
    solver = _qdldl.Solver(sp.triu(m, format="csc"), upper=True)
    lower, d, _ = solver.factors()
    unit = (sp.identity(n, format="csr") + abs(sp.csr_matrix(lower))).tocsr()
    unit_t = unit.T.tocsr()
    d_abs = np.abs(d)
    k = int(np.diff(unit.indptr).max(initial=1)) + 2
    rho = spectral_radius_bound(lambda v: unit @ (d_abs * (unit_t @ v)), n)
    # (the shift's own rounding, and LDL^T's bound taken twice for the three-factor terms)
    bound = gamma(2 * k) * rho + gamma(2) * (a_rho + abs(sigma)) + c_asm
    return int(np.sum(d < 0)), bound


def certified_index(prob, x, mu, load):
    """``(index, Certificate(tau, B))`` of the reduced tangent at (x, mu) under ``load``,
    index None where the two shifted counts differ (module docstring); ``(None, None)``
    where the tangent-space form does not apply (constraints other than Euler
    normalizations) or qdldl is missing."""
    if _qdldl is None or getattr(prob, "reduced", None) is None:
        return None, None
    k, mag, c = _tangent_and_magnitudes(prob, x, mu, load)
    diag = np.abs(k.diagonal())
    w = sp.diags(np.where(diag > 0, 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0)), 1.0))
    a = (w @ k @ w).tocsr()
    a_abs = (w @ mag @ w).tocsr()
    n = a.shape[0]
    a_rho = spectral_radius_bound(lambda v: a_abs @ v, n)
    c_asm = gamma(c + 2) * a_rho                   # (+2: the scaling's two products)
    _, bound = _count(a, 0.0, a_rho, c_asm)
    for _ in range(SHIFT_TRIES):
        # (a shifted factorization's own bound may exceed the unshifted one: larger
        # entries of L where a pivot comes nearer zero; then a larger shift)
        tau = TAU_FACTOR * bound
        nu_lo, b_lo = _count(a, -tau, a_rho, c_asm)
        nu_hi, b_hi = _count(a, tau, a_rho, c_asm)
        bound = max(b_lo, b_hi)
        cert = Certificate(tau, bound)
        if nu_lo != nu_hi:
            return None, cert
        if cert.decided:
            return nu_lo, cert
    return None, cert


def bracket_verdict(prob, load, before, after):
    """The verdict of :func:`~spacarpy.solvers.path.stability.certify_crossing` from the
    certified indices at two arc-length points (each cached on its point), or None where
    either is not certified: ``("crossing" | "none", Certificate)``."""
    got = []
    for q in (before, after):
        if getattr(q, "bracket", None) is None:
            try:
                q.bracket = certified_index(prob, q.x, q.mu, load(q.s))
            except Exception:              # noqa: BLE001 -- a zero pivot: not proven
                q.bracket = (None, None)
        got.append(q.bracket)
    (i0, c0), (i1, c1) = got
    if i0 is None or i1 is None:
        return None
    worst = c0 if c0.margin / c0.bound < c1.margin / c1.bound else c1
    return ("crossing" if i0 != i1 else "none"), worst


__all__ = ["certified_index", "bracket_verdict", "locate_crossing", "spectral_radius_bound",
           "gamma", "TAU_FACTOR"]


def _rayleigh(prob, q, load, v) -> float:
    """The Rayleigh quotient ``v^T K v / v^T v`` of the reduced tangent at the point q for a
    vector v of tangent coordinates, element by element (accurate where the assembled
    matrix is not: :meth:`~spacarpy.solvers.linear.eigen_tangent._Tangent.products`)."""
    lin = linearize(prob, q.x, q.mu, load, mass=_NoMass(prob.num.n_unknown))
    _, gram = _Tangent(lin, prob.num).products(v[:, None])
    return float(gram[0, 0] / (v @ v))


def _critical_vector(prob, q, load):
    """The eigenvector nearest zero of the assembled reduced tangent at q (tangent
    coordinates), by shift-invert about zero on its Jacobi-scaled form."""
    import scipy.sparse.linalg as spla
    k, _, _ = _tangent_and_magnitudes(prob, q.x, q.mu, load)
    diag = np.abs(k.diagonal())
    w = np.where(diag > 0, 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0)), 1.0)
    a = (sp.diags(w) @ k @ sp.diags(w)).tocsc()
    _, u = spla.eigsh(a, k=1, sigma=0.0, which="LM", v0=np.ones(a.shape[0]))
    return w * u[:, 0]


#: Illinois steps of :func:`locate_crossing` (it stops at the arc-length tolerance).
LOCATE_STEPS = 40


def locate_crossing(path, p, ds, new, crit, direction):
    """The point where an eigenvalue certified to cross zero between p and ``new`` (arc
    lengths 0 and ds) passes zero, by the Illinois method on the accurate Rayleigh quotient
    of the critical eigenvector at ``crit`` (the bisection's point) along the path (``path``:
    the arc-length solver, its ``_at(p, a, direction)`` the point at arc length a from p, to
    the solver tolerance times ds). The bisection on the pivots' signs stops
    where round-off of the assembled matrix flips them (the perfect column at 10^3
    elements: 0.66670 where the crossing is at 0.666668, docs/path.md); the element-wise
    Rayleigh quotient is a smooth function of the load there. Returns ``crit`` where this
    does not apply or the quotient does not change sign between p and new."""
    prob, load = path.prob, path.load
    tol = max(path.opts.tol, 1e-14) * ds
    if _qdldl is None or getattr(prob, "reduced", None) is None:
        return crit
    try:
        v = _critical_vector(prob, crit, load(crit.s))
    except Exception:                      # noqa: BLE001 -- ARPACK: keep the bisection's
        return crit
    lo, hi = 0.0, ds
    f_lo, f_hi = _rayleigh(prob, p, load(p.s), v), _rayleigh(prob, new, load(new.s), v)
    if not (f_lo > 0 > f_hi or f_lo < 0 < f_hi):
        return crit
    best, side = crit, 0
    for _ in range(LOCATE_STEPS):
        if hi - lo <= tol:
            break
        a = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        if not lo < a < hi:
            a = 0.5 * (lo + hi)
        q = path._at(p, a, direction)
        f = _rayleigh(prob, q, load(q.s), v)
        best = q
        if (f > 0) == (f_lo > 0):
            lo, f_lo = a, f
            if side == -1:
                f_hi *= 0.5
            side = -1
        else:
            hi, f_hi = a, f
            if side == 1:
                f_lo *= 0.5
            side = 1
        if f == 0.0:
            break
    return best

"""Accurate eigenvalues of symmetric pencils whose spectrum spans many decades, with an error
bound for each, and the poles of the second-order equations computed the same way.

Why: a warping node of a BEAMW (docs/beamw.md) carries an inertia of 2e-15 kg m^3 beside
nodal masses of 0.3 kg, and its mode lies at 46 kHz beside one at 2.5 Hz. A symmetric
eigensolver's eigenvalue has an error of about ``eps lambda_max`` (a relative
``eps (w_max / w)^2``, 7.5e-8 for the 2.5 Hz mode of the corpus deck mod8_flexure_mode9.dat,
different with 1 and 2 BLAS threads), and a mass bound taken in the units of the coordinates
calls a real 46 kHz mode "massless". Three steps fix both:

1. **Mass-scaled basis** (:func:`mass_scaled_basis`). The basis T of the constrained motions
   is replaced by ``B = T R^-1``, ``S T = Q R`` with ``S = diag(sqrt(M_ii))``: the motions'
   basis is orthonormal in the metric of the mass diagonal, so the reduced mass ``B^T M B``
   has eigenvalues of order 1 whatever the units of the coordinates (rate of twist, metres,
   Euler parameters). A coordinate without any mass (``M_ii = 0``: its row of M is zero,
   M being positive semidefinite) is scaled by the mean of the others.
2. **Motions without inertia** (:func:`split_pencil`): the eigenvalues ``mu`` of the reduced
   mass are compared with the round-off bound ``SAFETY n eps ||B^T M B||_F`` of
   :mod:`spacarpy.solvers.linalg.certificate`: within it the motion has no inertia that
   double precision can tell from zero, which in this scaled form happens only for a
   mass that is zero in exact arithmetic, or below 1e-13 of its coordinates' own diagonal
   (a structurally massless direction: a beam's torsion without rho Ip, a coordinate without
   a mass entry). Those motions are condensed statically (they follow the stiffness) and
   their infinite eigenvalues are not modes; the others, with certified positive mass,
   are the finite modes, however small their inertia in the coordinates' units.
3. **Refinement and bound** (:func:`refine_symmetric`). Each eigenvector ``v`` of the scaled
   pencil gives the Rayleigh quotient ``rho = v^T K v / v^T M v`` with the original K and M,
   whose error is of second order in the eigenvector's (the stiff components' error
   ``eps`` costs ``eps^2 lambda_max``). Its bound is the sum of the Kato-Temple bound
   ``eps_r^2 / gap`` (``eps_r = ||r||_{M^-1} / ||v||_M`` the residual ``r = K v - rho M v``
   of the constrained motions, ``gap`` the distance to the nearest other eigenvalue less
   that one's residual; ``eps_r`` itself where the gap does not exceed it, a cluster) and
   the rounding of the quotient, whose numerator and denominator are summed as if in twice
   the working precision (:func:`quadratic_forms`: in a soft motion the stiffness entries
   cancel, by 6e5 in the 2.5 Hz mode of mod8, so a plain product would lose 1e-10 and
   could lose 1e-7).

:func:`second_order_poles`: the poles of ``M0 q'' + C0 q' + K0 q = 0`` (the state space of
:mod:`spacarpy.solvers.linear.state_space`). Undamped (C0 zero, symmetric K0): ``+-i w``
from the refined eigenvalues of (K0, M0) above, so that they equal the eigen analysis'
frequencies to their bounds. Otherwise the eigenvalues of A, each refined by the Rayleigh
functional of the quadratic eigenproblem (the root of ``x^T (p^2 M0 + p C0 + K0) x = 0``
nearest the pole, x its eigenvector, second-order accurate for symmetric M0, C0, K0), with
the bound ``eta kappa`` of Tisseur (2000), backward error times condition number.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from spacarpy.solvers.linalg.certificate import EPS, certified_sign, round_off_bound

__all__ = ["ScaledPencil", "mass_scaled_basis", "massive_mask", "split_pencil",
           "quadratic_form", "quadratic_forms", "refine_symmetric", "second_order_poles",
           "pole_bounds"]


def _sym(a: np.ndarray) -> np.ndarray:
    return 0.5 * (a + a.T)


def mass_scaled_basis(T: np.ndarray, m_diag: np.ndarray) -> np.ndarray:
    """``B = T R^-1`` with ``diag(sqrt(m_diag)) T = Q R`` (module docstring, step 1): a basis
    of the same space as T's columns, orthonormal in the metric of the mass diagonal."""
    n, k = T.shape
    if k == 0:
        return T
    d = np.abs(np.asarray(m_diag, dtype=float))
    pos = d > 0
    fill = float(np.mean(d[pos])) if pos.any() else 1.0
    s = np.sqrt(np.where(pos, d, fill))
    r = sla.qr(s[:, None] * T, mode="r")[0][:k]
    # R's diagonal has no zero: T has full column rank and s > 0
    return sla.solve_triangular(r, T.T, trans="T", lower=False).T


@dataclass
class ScaledPencil:
    """The symmetric pencil (k, m) in a mass-scaled basis (``n`` coordinates underneath):
    ``mu``, ``W`` the eigenpairs of m; ``massive`` the certified positive ones; ``lam``,
    ``U`` the finite eigenpairs (U over the basis, the massless motions condensed)."""

    k: np.ndarray
    m: np.ndarray
    mu: np.ndarray
    W: np.ndarray
    massive: np.ndarray
    lam: np.ndarray
    U: np.ndarray

    @property
    def n_massless(self) -> int:
        return int(np.count_nonzero(~self.massive))


def massive_mask(m: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(mu, W, massive)``: the eigenpairs of the reduced mass m (symmetric, of a mass-scaled
    basis over n coordinates) and which are certified positive (step 2)."""
    mu, W = sla.eigh(_sym(m)) if m.size else (np.zeros(0), np.zeros((0, 0)))
    bound = round_off_bound(float(np.linalg.norm(m)), n)
    return mu, W, certified_sign(mu, bound) > 0


def split_pencil(k: np.ndarray, m: np.ndarray, n: int) -> ScaledPencil | None:
    """The finite eigenpairs of the symmetric pencil (k, m) of a mass-scaled basis (module
    docstring, step 2); None where the stiffness is singular on the motions without inertia
    (a motion with neither: the pencil is singular)."""
    k, m = _sym(k), _sym(m)
    mu, W, massive = massive_mask(m, n)
    if massive.all():
        lam, U = sla.eigh(k, m)
        return ScaledPencil(k, m, mu, W, massive, lam, U)
    W1, W2 = W[:, massive], W[:, ~massive]
    kw = W.T @ k @ W
    k11 = kw[np.ix_(massive, massive)]
    k12 = kw[np.ix_(massive, ~massive)]
    k22 = kw[np.ix_(~massive, ~massive)]
    scale = float(np.abs(kw).max(initial=0.0))
    try:
        lu = sla.lu_factor(k22, check_finite=True)
    except (np.linalg.LinAlgError, ValueError):
        return None
    piv = np.abs(np.diag(lu[0]))
    if piv.size and not piv.min() > round_off_bound(scale, n):
        return None
    X = sla.lu_solve(lu, k12.T)
    lam, A = sla.eigh(_sym(k11 - k12 @ X), np.diag(mu[massive]))
    return ScaledPencil(k, m, mu, W, massive, lam, W1 @ A - W2 @ (X @ A))


def _split(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Veltkamp's splitting: ``a = hi + lo`` exactly, each with at most 26 significant bits."""
    c = 134217729.0 * a                                   # 2^27 + 1
    hi = c - (c - a)
    return hi, a - hi


def _two_product(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Dekker's product without a fused multiply-add: ``a b = p + e`` exactly."""
    p = a * b
    a1, a2 = _split(a)
    b1, b2 = _split(b)
    return p, a2 * b2 - (((p - a1 * b1) - a2 * b1) - a1 * b2)


def _two_sum(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Knuth's sum: ``a + b = s + e`` exactly."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _cascaded_sum(x: np.ndarray) -> tuple[np.ndarray, int]:
    """The column sums of x (n, k) as if in twice the working precision: a pairwise tree of
    error-free sums (:func:`_two_sum`) whose errors are summed apart (Ogita, Rump & Oishi
    2005, Sum2, in pairwise order); and the depth of the tree."""
    errs, depth = [], 0
    while x.shape[0] > 1:
        if x.shape[0] % 2:
            x = np.vstack([x, np.zeros((1, x.shape[1]))])
        x, e = _two_sum(x[0::2], x[1::2])
        errs.append(e.sum(axis=0))
        depth += 1
    total = x[0] if x.shape[0] else np.zeros(x.shape[1])
    return total + np.sum(errs, axis=0) if errs else total, depth


def quadratic_forms(A, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(q, bound)``: ``v^T A v`` of each column v of V (A sparse or dense, V real) as if
    computed in twice the working precision (step 3): each term ``v_i A_ij v_j`` written
    exactly as four floating-point numbers (:func:`_two_product`), the large ones summed by
    :func:`_cascaded_sum`, so that the cancellation of large stiffness entries in a soft
    motion costs nothing; ``bound`` its rounding, ``2 eps |q| + (2 (depth + 2) eps)^2
    sum |terms|``."""
    if sp.issparse(A):
        a = A.tocoo()
        i, j, d = a.row, a.col, a.data
    else:
        i, j = np.nonzero(A)
        d = np.asarray(A)[i, j]
    q = np.zeros(V.shape[1])
    bound = np.zeros(V.shape[1])
    for c0 in range(0, V.shape[1], 16):                # 16 columns at a time (memory)
        v = V[:, c0:c0 + 16]
        p1, e1 = _two_product(v[i], d[:, None])
        p2, e2 = _two_product(p1, v[j])
        small = e2 + e1 * v[j]                         # e1 v_j: its rounding is eps^2
        big, depth = _cascaded_sum(p2)
        q[c0:c0 + 16] = big + small.sum(axis=0)
        total = np.abs(p2).sum(axis=0)
        bound[c0:c0 + 16] = (2 * EPS * np.abs(q[c0:c0 + 16])
                             + (2 * (depth + 2) * EPS) ** 2 * total)
    return q, bound


def quadratic_form(A, v: np.ndarray) -> float:
    """``v^T A v`` of one vector by :func:`quadratic_forms`."""
    return float(quadratic_forms(A, np.asarray(v, float)[:, None])[0][0])


#: Relative rounding bound of a plain quadratic form above which :func:`_quotient` sums it
#: accurately (a choice of method only: each value's bound is the one of its method).
ACCURATE_RTOL = 1e-10


def _forms(A, V: np.ndarray, kv: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``v^T A v`` of the columns of V and the bound of each: the plain sum (``kv = A V``)
    where its rounding bound ``SAFETY n eps |v|^T |A| |v|`` is below :data:`ACCURATE_RTOL`
    of it, else :func:`quadratic_forms`."""
    q = np.einsum("ij,ij->j", V, kv)
    aV = np.abs(V)
    bound = round_off_bound(np.einsum("ij,ij->j", aV, abs(A) @ aV), n)
    again = ~(bound <= ACCURATE_RTOL * np.abs(q))
    if again.any():
        q[again], bound[again] = quadratic_forms(A, V[:, again])
    return q, bound


def _quotient(K, M, V: np.ndarray, n: int):
    """Rayleigh quotients of the columns of V, their numerators and denominators summed
    accurately where needed (:func:`_forms`), and the rounding bound of the quotient."""
    kv, mv = K @ V, M @ V
    num, nb = _forms(K, V, kv, n)
    den, db = _forms(M, V, mv, n)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = num / den
        rounding = 2 * EPS * np.abs(rho) + (nb + np.abs(rho) * db) / np.abs(den)
    return rho, rounding, kv, mv


def refine_symmetric(K, M, B: np.ndarray, pencil: ScaledPencil, n: int,
                     select: np.ndarray | None = None):
    """``(rho, V, bound)``: the refined finite eigenvalues ``select`` (indices into
    ``pencil.lam``, all by default) of the symmetric pencil (K, M) restricted to the columns
    of B (``pencil`` its scaled form), their eigenvectors over the coordinates (``V = B U``)
    and an error bound of each (module docstring, step 3)."""
    if select is None:
        select = np.arange(pencil.lam.size)
    V = B @ pencil.U[:, select]
    if V.shape[1] == 0:
        return np.zeros(0), V, np.zeros(0)
    rho, rounding, kv, mv = _quotient(K, M, V, n)
    # the residual of the constrained motions, in the inverse of the (massive) reduced mass
    r = B.T @ (kv - mv * rho)
    W1, mu1 = pencil.W[:, pencil.massive], pencil.mu[pencil.massive]
    # its own rounding (the products above): added to the residual's norm
    aV = np.abs(V)
    r_round = np.abs(B.T) @ (abs(K) @ aV + (abs(M) @ aV) * np.abs(rho))
    den = np.einsum("ij,ij->j", V, mv)
    w = 1.0 / np.sqrt(mu1)[:, None]
    res = (np.linalg.norm(w * (W1.T @ r), axis=0)
           + round_off_bound(np.linalg.norm(w * (np.abs(W1.T) @ r_round), axis=0), n))
    eps_r = res / np.sqrt(den)
    # the gap to the other eigenvalues (the scaled pencil's, each within the eigensolver's
    # backward error, a multiple of n eps lambda_max)
    lam = pencil.lam
    err = float(round_off_bound(np.abs(lam).max(initial=0.0), n))
    gap = np.full(rho.size, np.inf)
    for c, i in enumerate(select):
        other = np.delete(lam, i)
        if other.size:
            gap[c] = np.abs(other - rho[c]).min() - err
    bound = eps_r.copy()
    ok = gap > eps_r
    bound[ok] = eps_r[ok] ** 2 / gap[ok]
    return rho, V, bound + rounding


def _undamped_poles(M0, K0):
    """The poles ``+-i w`` (``+-sqrt(-rho)`` for a negative rho) of ``M0 q'' + K0 q = 0``
    from the refined eigenvalues rho of (K0, M0), and their bounds."""
    n = M0.shape[0]
    B = mass_scaled_basis(np.eye(n), np.diag(M0))
    pencil = split_pencil(B.T @ K0 @ B, B.T @ M0 @ B, n)
    if pencil is None or pencil.n_massless:
        return None
    rho, _, bound = refine_symmetric(K0, M0, B, pencil, n)
    root = np.sqrt(np.abs(rho))
    with np.errstate(divide="ignore", invalid="ignore"):
        pb = np.where(np.abs(rho) > bound, bound / (2.0 * root), np.sqrt(bound))
    p = np.where(rho >= 0, 1j * root, root + 0j)
    return np.concatenate([p, -p]), np.concatenate([pb, pb])


def pole_bounds(M0, C0, K0, p: np.ndarray, X: np.ndarray) -> np.ndarray:
    """First-order error bounds ``eta kappa`` of the poles p with right eigenvectors X
    (columns) of the quadratic eigenproblem: backward error times condition number
    (Tisseur 2000), the left eigenvector of a symmetric problem being ``conj(x)``; the
    residual's own rounding is counted in eta."""
    a, b, c = (float(np.linalg.norm(A, 2)) if A.size else 0.0 for A in (M0, C0, K0))
    ap = np.abs(p)
    scale = ap ** 2 * a + ap * b + c
    r = (M0 @ X) * p ** 2 + (C0 @ X) * p + K0 @ X
    aX = np.abs(X)
    r_round = round_off_bound(np.linalg.norm((abs(M0) @ aX) * ap ** 2 + (abs(C0) @ aX) * ap
                                             + abs(K0) @ aX, axis=0), M0.shape[0])
    xn = np.linalg.norm(X, axis=0)
    deriv = np.abs(np.einsum("ij,ij->j", X, (M0 @ X) * (2 * p) + C0 @ X))
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = (np.linalg.norm(r, axis=0) + r_round) / (scale * xn)
        kappa = scale * xn ** 2 / (ap * deriv)
        out = eta * kappa
    return np.where(np.isfinite(out), out, np.inf)


def second_order_poles(M0, C0, K0, A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(poles, bounds)`` of ``M0 q'' + C0 q' + K0 q = 0`` with its first-order matrix A
    (module docstring), in the order of ``np.linalg.eig(A)`` where that is used, else the
    positive imaginary parts first."""
    n = M0.shape[0]
    if n == 0:
        return np.zeros(0, complex), np.zeros(0)
    scale = float(np.abs(K0).max(initial=0.0))
    symmetric = (np.allclose(K0, K0.T, rtol=0, atol=1e-12 * max(scale, 1e-300))
                 and np.allclose(C0, C0.T, rtol=0,
                                 atol=1e-12 * float(np.abs(C0).max(initial=1e-300))))
    if symmetric and not np.any(C0):
        out = _undamped_poles(M0, _sym(K0))
        if out is not None:
            return out
    lam, Z = np.linalg.eig(A)
    X = Z[:n]
    if symmetric:
        Ks, Cs = _sym(K0), _sym(C0)
        a = np.einsum("ij,ij->j", X, M0 @ X)
        b = np.einsum("ij,ij->j", X, Cs @ X)
        c = np.einsum("ij,ij->j", X, Ks @ X)
        with np.errstate(divide="ignore", invalid="ignore"):
            disc = np.sqrt(b * b - 4 * a * c + 0j)
            r1, r2 = (-b + disc) / (2 * a), (-b - disc) / (2 * a)
        near = np.where(np.abs(r1 - lam) <= np.abs(r2 - lam), r1, r2)
        ok = np.isfinite(near) & (np.abs(near - lam) <= 1e-6 * np.maximum(np.abs(lam), 1.0))
        # a real pole stays real (a real eigenvector gives real coefficients)
        near = np.where(np.abs(lam.imag) == 0, near.real + 0j, near)
        lam = np.where(ok, near, lam)
    return lam, pole_bounds(M0, C0, K0, lam, X)


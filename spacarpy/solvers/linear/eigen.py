"""Natural frequencies and mode shapes about an equilibrium: (K0 + N0 + G0) v = w^2 M0 v.

Small models (up to :data:`DENSE_LIMIT` free coordinates) are reduced to a basis of the
constraint null space, scaled by the mass diagonal, and solved densely (all modes, exact
classification), each of the wanted eigenvalues refined with an error bound
(:mod:`spacarpy.solvers.linear.refine`: a warping node's 46 kHz mode beside a 2.5 Hz one
leaves the soft one 1e-11 off instead of 7.5e-8). Larger
models use ARPACK in shift-invert mode on the bordered pencil
``[[K, C^T], [C, 0]] - lambda [[M, 0], [0, 0]]`` with one sparse LU, which returns the
eigenvalues nearest to a small negative shift (the lowest modes, rigid-body modes included).

Every mode is classified (:data:`KIND_NAMES`): elastic; rigid-body (no element deforms: the
deformation rates ``D v`` vanish, and no stress resultant holds the motion either); unstable
(real negative w^2: the state has buckled or is a maximum of the potential); complex
(non-conservative loading, flutter-type). Unusual modes are reported with a warning. An
infinite eigenvalue (a motion without inertia) is not a mode and is not returned (below); the
kind code INFINITE is kept for the padding of a results file whose step has fewer modes than
its columns, and for files written before.

**The modes a model has.** A model with ``n_dof`` degrees of freedom (the dimension of the
null space of C) has ``n_dof`` eigenvalues, of which the motions without inertia (the null
space of the reduced mass ``T^T M0 T``) are infinite: they are constraints in disguise, not
vibrations. The finite ones, ``n_dof`` minus the motions without inertia (the rank of the
reduced mass, for a stiffness that is regular on those motions), are the modes the model
has (:attr:`Modes.n_available`). :func:`eigenmodes` returns the lowest ``n_modes`` of them,
fewer when the model has fewer, and never an infinite mode as if it were one;
:func:`finite_mode_count` counts them beforehand (the results file is sized with it).

Round-off never decides a classification or an order. A motion is **infinite** (without
inertia) when its mass cannot be told from zero in double precision, in its own units: in
the dense solve, an eigenvalue of the reduced mass in the mass-scaled basis at most
``SAFETY n eps`` times that matrix's norm (its eigenvalues are of order 1 whatever the
coordinates' units, so only a mass zero in exact arithmetic, or below ``SAFETY n eps``
(1e-13 for 50 coordinates) of its own coordinates' mass diagonal, falls there: a beam's
torsion without rho Ip, a coordinate without mass entries); those motions are condensed,
their infinite eigenvalues are not modes. The general (non-symmetric) and sparse solvers
test each mode's ``|v^T M v|`` against the rounding of its own sum, ``SAFETY n eps |v|^T |M|
|v|`` (:func:`infinite_mask`; LAPACK returns an infinite eigenvalue as inf, nan or 1e16
depending on the BLAS). Schema 2.19 took ``SAFETY n eps ||M||_F``, in the units of the
coordinates, and so dropped the 46 kHz warping
modes of mod8_flexure_mode9.dat (inertia 2e-15 kg m^3) as massless. A mode is rigid-body
when its deformation rates are below 1e-7 of its size and its eigenvalue below 1e-9 of the
largest diagonal stiffness-to-mass ratio (:func:`_rigid_mask`), bounds far above round-off.
A mode is **unstable** when its ``w^2`` is certified negative: below ``-SAFETY n eps
lambda_max`` (:func:`sign_bound`: the backward error of the eigensolver, lambda_max the
largest eigenvalue magnitude of the pencil, where not all are computed at least the largest
diagonal stiffness-to-mass ratio); a mode that deforms elements with ``|w^2|`` within that
bound is **undetermined** (frequency 0: stable or unstable is not known in double
precision). Modes are ordered by ``|w^2|``; magnitudes equal to
:data:`TIE_RTOL` (an unstable/elastic ``-w^2, +w^2`` pair, complex conjugates) by signed real
part, then by imaginary part, positive first. Each shape's first largest component is
positive (:func:`canonical_sign`).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.elements.base import relative_positions
from spacarpy.solvers.linalg.certificate import UNDETERMINED, certified_sign, round_off_bound
from spacarpy.solvers.linear.eigen_tangent import lowest_modes
from spacarpy.solvers.linear.refine import (
    ScaledPencil,
    mass_scaled_basis,
    massive_mask,
    refine_symmetric,
    split_pencil,
)

log = logging.getLogger(__name__)

DENSE_LIMIT = 2500
#: the dense limit when fewer than a quarter of the modes are wanted (see eigenmodes)
FEW_MODES_DENSE_LIMIT = 400

ELASTIC, RIGID_BODY, UNSTABLE, COMPLEX, INFINITE, UNDETERMINED_SIGN = 0, 1, 2, 3, 4, 5
KIND_NAMES = {ELASTIC: "elastic", RIGID_BODY: "rigid-body", UNSTABLE: "unstable",
              COMPLEX: "complex", INFINITE: "infinite", UNDETERMINED_SIGN: "undetermined"}

#: (SAFETY, the safety factor of the infinity bound, is the one of
#: :mod:`spacarpy.solvers.linalg.certificate`: the backward error of the eigensolver in M is a small
#: multiple of ``n eps ||M||``.)
#: Relative tolerance within which two eigenvalues' magnitudes count as equal for ordering.
TIE_RTOL = 1e-9


@dataclass
class Modes:
    """Eigenvalues and shapes of a linearization.

    Attributes
    ----------
    eigenvalue : (n_mode,) complex
        w^2 (1/s^2).
    frequency : (n_mode,) float
        Natural frequency in Hz, ``sqrt(w^2) / (2 pi)``; for an unstable mode the negative
        of ``sqrt(-w^2) / (2 pi)`` (its divergence rate); NaN for complex or infinite ones.
    kind : (n_mode,) int
        See :data:`KIND_NAMES`.
    shape : (n_x, n_mode) float
        Mode shapes over the free coordinates (real part), mass-normalized where the
        modal mass is positive, else scaled to a largest component of 1.
    n_available : int or None
        The number of finite modes the linearization has (module docstring); None where
        the sparse solver computed only the lowest ones.
    bound : (n_mode,) float or None
        An error bound of each eigenvalue w^2 (1/s^2) of the assembled pencil, where the
        dense symmetric solver refined it (:func:`spacarpy.solvers.linear.refine.
        refine_symmetric`: Kato-Temple's residual^2 / gap and the quotient's rounding);
        NaN for the modes it did not refine, None for the other solvers.
    """

    eigenvalue: np.ndarray
    frequency: np.ndarray
    kind: np.ndarray
    shape: np.ndarray
    n_available: int | None = None
    bound: np.ndarray | None = None


def null_space_basis(C: sp.spmatrix, n_x: int) -> np.ndarray:
    """Orthonormal basis (n_x, n_dof) of the null space of the constraint Jacobian."""
    if C.shape[0] == 0:
        return np.eye(n_x)
    a = C.toarray()
    try:
        return sla.null_space(a, rcond=1e-10)
    except np.linalg.LinAlgError:
        # LAPACK's divide-and-conquer SVD (gesdd) occasionally fails to converge on these
        # sparse, badly scaled Jacobians; the QR-iteration driver (gesvd) does not
        _, sv, vh = sla.svd(a, full_matrices=True, lapack_driver="gesvd")
        rank = int(np.sum(sv > 1e-10 * sv.max(initial=0.0)))
        return vh[rank:].conj().T


def canonical_sign(v: np.ndarray) -> np.ndarray:
    """Real shapes (n, m) from eigenvectors: each column divided by its first largest
    component (within 1e-6 of the largest magnitude), so that component is exactly +1 and
    the sign is not decided by round-off or by the eigensolver."""
    if v.size == 0:
        return np.real(v).astype(float)
    mag = np.abs(v)
    first = np.argmax(mag >= (1.0 - 1e-6) * mag.max(axis=0), axis=0)
    piv = v[first, np.arange(v.shape[1])]
    return np.real(v / np.where(piv == 0, 1.0, piv))


def canonical_order(key: np.ndarray, *ties: np.ndarray) -> np.ndarray:
    """Indices ordering ``key`` (non-negative, inf and nan last) ascending, where entries
    equal to :data:`TIE_RTOL` form one group ordered by ``ties`` (the first one first)."""
    key = np.where(np.isnan(key), np.inf, key)
    order = np.argsort(key, kind="stable")
    k = key[order]
    new = np.ones(k.size, dtype=bool)
    with np.errstate(invalid="ignore"):
        new[1:] = ~(k[1:] - k[:-1] <= TIE_RTOL * np.maximum(k[1:], np.finfo(float).tiny))
    group = np.cumsum(new)
    return order[np.lexsort(tuple(t[order] for t in reversed(ties)) + (group,))]


def exact_conjugates(lam: np.ndarray) -> np.ndarray:
    """Complex eigenvalues of a real pencil come in conjugate pairs, but LAPACK's generalized
    solver divides each by its own ``beta``: the pair's real parts may differ in the last
    bits, and round-off would order it. Each pair (the conjugate within :data:`TIE_RTOL` of
    the value) is made exactly conjugate, its mean; real ones are returned unchanged."""
    cplx = np.flatnonzero(np.isfinite(lam) & (lam.imag != 0))
    if not cplx.size:
        return lam
    lam = lam.copy()
    free = set(cplx[lam[cplx].imag < 0].tolist())
    for i in cplx[lam[cplx].imag > 0]:
        if not free:
            break
        j = min(free, key=lambda j: abs(lam[j] - np.conj(lam[i])))
        if abs(lam[j] - np.conj(lam[i])) <= TIE_RTOL * abs(lam[i]):
            re, im = 0.5 * (lam[i].real + lam[j].real), 0.5 * (lam[i].imag - lam[j].imag)
            lam[i], lam[j] = complex(re, im), complex(re, -im)
            free.discard(j)
    return lam


def infinite_mask(lam, vec, M) -> np.ndarray:
    """True for the modes that are infinite by the module docstring's bound: a mode's mass
    ``|v^H M v|`` within the rounding of its own sum, ``SAFETY n eps |v|^T |M| |v|`` (a
    bound in the mode's own units: a warping coordinate's 2e-15 kg m^3 is not small beside
    its own terms)."""
    norm = np.linalg.norm(vec, axis=0)
    v = vec / np.where(norm > 0, norm, 1.0)
    mv = np.abs(np.einsum("ij,ij->j", v.conj(), M @ v))
    av = np.abs(v)
    bound = round_off_bound(np.einsum("ij,ij->j", av, abs(M) @ av), vec.shape[0])
    return ~np.isfinite(lam) | (certified_sign(mv, bound) == UNDETERMINED)


def _rigid_mask(lin, num, free, shapes: np.ndarray, lam: np.ndarray | None = None
                ) -> np.ndarray:
    """True for shapes that deform no element (relative to their size) and, with ``lam``,
    whose eigenvalue is no larger than 1e-9 of the largest stiffness-to-mass ratio of the
    diagonals: a shape that deforms nothing to first order but is held by the geometric
    stiffness of stress resultants (a taut string's transverse modes, ESIG or loads) is
    elastic. The bound lies 1e7 above the eigenvalues' round-off (eps times that ratio)."""
    n = shapes.shape[1]
    full = np.zeros((num.n_coord, n))
    full[free] = shapes
    rel = np.zeros(n)
    for g, st in zip(num.groups, lin.states):
        rates = st.D @ full[g.idx]                              # (n_elem, n_def, n)
        rel = np.maximum(rel, np.abs(rates / g.scale[:, :, None]).max(axis=(0, 1),
                                                                      initial=0.0))
    rot = num.is_rotation_coord[free]
    size = (np.abs(shapes[~rot]).max(axis=0, initial=0.0) / num.length_scale
            + np.abs(shapes[rot]).max(axis=0, initial=0.0))
    rigid = rel <= 1e-7 * np.maximum(size, 1e-300)
    if lam is not None and rigid.any():
        ratio = stiffness_ratio(lin)
        held = np.isfinite(lam) & (np.abs(lam) > 1e-9 * ratio)
        rigid &= ~held
    return rigid


def stiffness_ratio(lin) -> float:
    """The largest stiffness-to-mass ratio of the diagonals of K and M (the Rayleigh
    quotient of a unit coordinate vector: a lower bound of the largest eigenvalue)."""
    diag_k, diag_m = np.abs(lin.K.diagonal()), np.abs(lin.M.diagonal())
    pos = diag_m > 0
    return float(np.max(diag_k[pos] / diag_m[pos])) if pos.any() else 0.0


def sign_bound(lam_all: np.ndarray, lin, n: int) -> float:
    """The round-off bound of a computed ``w^2`` (module docstring): ``SAFETY n eps`` times
    the largest eigenvalue magnitude of the pencil, or, where not every eigenvalue was
    computed, the larger of the largest one found and :func:`stiffness_ratio`."""
    finite = np.isfinite(lam_all)
    scale = float(np.abs(lam_all[finite]).max(initial=0.0))
    if lam_all.size < n:
        scale = max(scale, stiffness_ratio(lin))
    return float(round_off_bound(scale, n))


def classify(lam: np.ndarray, rigid: np.ndarray, bound: float = 0.0) -> np.ndarray:
    """The kind of each mode (:data:`KIND_NAMES`): unstable where ``w^2`` is certified
    negative (below ``-bound``, :func:`sign_bound`), undetermined where it is within the
    bound and the mode deforms elements (not rigid-body: round-off does not decide
    between stable and unstable)."""
    kind = np.full(lam.shape, ELASTIC, dtype=np.int8)
    scale = np.abs(lam[np.isfinite(lam)]).max(initial=1.0)
    kind[~np.isfinite(lam)] = INFINITE
    cplx = np.isfinite(lam) & (np.abs(lam.imag)
                               > 1e-8 * np.maximum(np.abs(lam.real), 1e-12 * scale))
    kind[cplx] = COMPLEX
    kind[(kind == ELASTIC) & (lam.real < -bound)] = UNSTABLE
    kind[(kind == ELASTIC) & (np.abs(lam.real) <= bound)] = UNDETERMINED_SIGN
    kind[rigid & np.isfinite(lam) & ~cplx] = RIGID_BODY
    return kind


def frequencies(lam: np.ndarray, kind: np.ndarray) -> np.ndarray:
    f = np.full(lam.shape, np.nan)
    ok = (kind == ELASTIC) | (kind == RIGID_BODY) | (kind == UNSTABLE)
    re = lam.real[ok]
    f[ok] = np.sign(re) * np.sqrt(np.abs(re)) / (2.0 * np.pi)
    f[(kind == RIGID_BODY) | (kind == UNDETERMINED_SIGN)] = 0.0
    return f


def eigenmodes(lin, num, free, n_modes: int = 10, dense_limit: int | None = None) -> Modes:
    """Lowest ``n_modes`` modes of the linearization ``lin`` (see module docstring).

    The dense solve is used up to ``dense_limit`` free coordinates (default
    :data:`DENSE_LIMIT`), but not for a few modes of a model larger than
    :data:`FEW_MODES_DENSE_LIMIT`: there one sparse factorization and ARPACK are much faster
    (a dense solve costs the cube of the size, whatever the number of modes wanted) and
    give the same modes."""
    if lin.M is None:
        raise ValueError("no mass: an eigenfrequency analysis needs EM or XM data")
    n_x = lin.n_x
    if dense_limit is None:
        dense_limit = default_dense_limit(n_x, n_modes)
    dense = n_x <= dense_limit
    bound_lam = None
    found = None
    if dense:
        out = _dense(lin, n_x)
        if isinstance(out[0], ScaledPencil):
            lam, vec, bound_lam = _refined(lin, n_x, n_modes, *out)
        else:
            lam, vec = out                         # infinite ones marked (infinite_mask)
    else:
        found = lowest_modes(lin, num, n_modes)
        if found is not None:
            lam, vec = found                       # Rayleigh quotients already
        else:
            lam, vec = _sparse(lin, n_x, n_modes)
            lam = _rayleigh(lin, num, free, lam, vec)
        lam = np.where(infinite_mask(lam, vec, lin.M), complex(np.inf, 0.0), lam)
    finite = np.isfinite(lam)
    # the sign certificate of w^2 (the tangent solver's modes are those of a positive
    # definite K_r, checked by its own Ritz values: module eigen_tangent)
    bound = 0.0 if (not dense and found is not None) else \
        sign_bound(lam.real, lin, int(vec.shape[0]))
    n_available = (int(out[0].lam.size) if bound_lam is not None else int(finite.sum())) \
        if dense else None
    if bound_lam is None:
        bound_lam = np.full(lam.shape, np.nan)
    lam, vec, bound_lam = lam[finite], vec[:, finite], bound_lam[finite]   # infinite: not modes
    if not dense and lam.size < min(n_modes, n_x):
        # the sparse solvers cannot tell a motion without inertia from a mode they did not
        # resolve: say so, rather than store fewer modes without a word
        log.warning("the sparse eigen solver gives %d of the %d mode(s) asked for: the "
                    "others are infinite (motions without inertia) or were not resolved",
                    int(lam.size), n_modes)
    lam = exact_conjugates(lam)
    key = np.abs(lam.real)
    order = canonical_order(key, lam.real, -lam.imag)
    lam, vec = lam[order][:n_modes], vec[:, order][:, :n_modes]
    bound_lam = bound_lam[order][:n_modes]
    vec = _normalize(canonical_sign(vec), lin.M)
    rigid = _rigid_mask(lin, num, free, vec, lam)
    kind = classify(lam, rigid, bound)
    for k, name in ((UNSTABLE, "negative w^2 (unstable or buckled state)"),
                    (UNDETERMINED_SIGN, "w^2 within its round-off bound (sign undetermined)"),
                    (COMPLEX, "complex w^2 (non-conservative loading: flutter where its "
                              "imaginary part grows the motion)")):
        if np.any(kind == k):
            log.warning("%d mode(s) with %s", int(np.sum(kind == k)), name)
    return Modes(eigenvalue=lam, frequency=frequencies(lam, kind), kind=kind, shape=vec,
                 n_available=n_available, bound=bound_lam if dense else None)


def default_dense_limit(n_x: int, n_modes: int) -> int:
    """The size up to which :func:`eigenmodes` solves densely when asked for ``n_modes`` of
    ``n_x`` free coordinates (see there)."""
    return DENSE_LIMIT if 4 * n_modes >= n_x else min(DENSE_LIMIT, FEW_MODES_DENSE_LIMIT)


def finite_mode_count(lin, n_modes: int) -> tuple[int, int] | None:
    """``(n_available, n_dof)`` of a linearization: its degrees of freedom (the null space of
    C) and, of them, the finite modes (module docstring): ``n_dof`` minus the motions without
    inertia, the eigenvalues of the reduced mass ``T^T M T`` (T orthonormal) at most
    ``SAFETY n eps ||M||_F``, the bound of :func:`infinite_mask`. None where
    :func:`eigenmodes` would take the sparse solver for ``n_modes`` modes: the dense count
    would cost more than the solve (for a few modes of 2450 coordinates, 4 times the run)."""
    n_x = lin.n_x
    if lin.M is None or n_x > default_dense_limit(n_x, n_modes):
        return None
    T = null_space_basis(lin.C, n_x)
    B = mass_scaled_basis(T, lin.M.diagonal())
    _, _, massive = massive_mask(B.T @ (lin.M @ B), n_x)
    return int(np.sum(massive)), int(T.shape[1])


def _dense(lin, n_x):
    """All modes of the pencil reduced to the constrained motions, in the mass-scaled basis
    B (:func:`spacarpy.solvers.linear.refine.mass_scaled_basis`): ``(pencil, B)`` for a
    symmetric pencil (:func:`~spacarpy.solvers.linear.refine.split_pencil`: its finite
    modes, the motions without inertia condensed), else ``(lam, vec)`` of the general
    solver with the infinite ones marked (:func:`infinite_mask`)."""
    T = null_space_basis(lin.C, n_x)
    B = mass_scaled_basis(T, lin.M.diagonal())
    k = B.T @ (lin.K @ B)
    m = B.T @ (lin.M @ B)
    m = 0.5 * (m + m.T)
    symmetric = np.allclose(k, k.T, rtol=0, atol=1e-12 * np.abs(k).max(initial=1.0))
    if symmetric:
        pencil = split_pencil(k, m, n_x)
        if pencil is not None:
            return pencil, B
    with np.errstate(divide="ignore", invalid="ignore"):
        lam, v = sla.eig(k, m)
    vec = B @ v
    return np.where(infinite_mask(lam, vec, lin.M), complex(np.inf, 0.0), lam), vec


def _refined(lin, n_x, n_modes, pencil: ScaledPencil, B):
    """``(lam, vec, bound)`` of the finite modes of a symmetric pencil: the lowest
    ``n_modes`` by magnitude (and those tied with the last within 1e-6) refined with their
    error bounds (:func:`~spacarpy.solvers.linear.refine.refine_symmetric`), the others
    as the eigensolver gave them (bound NaN); they are ordered afterwards."""
    lam = pencil.lam
    mag = np.abs(lam)
    if mag.size > n_modes:
        cut = np.sort(mag)[n_modes - 1] if n_modes > 0 else -1.0
        select = np.flatnonzero(mag <= cut * (1 + 1e-6) + round_off_bound(mag.max(), n_x))
    else:
        select = np.arange(mag.size)
    vec = B @ pencil.U
    bound = np.full(lam.size, np.nan)
    out = lam.astype(float).copy()
    rho, v, b = refine_symmetric(lin.K, lin.M, B, pencil, n_x, select)
    out[select], vec[:, select], bound[select] = rho, v, b
    return out.astype(complex), vec, bound


def _sparse(lin, n_x, n_modes):
    n_c = lin.C.shape[0]
    a = sp.bmat([[lin.K, lin.C.T], [lin.C, None]], format="csc")
    b = sp.block_diag([lin.M, sp.csc_matrix((n_c, n_c))], format="csc")
    # a small negative shift keeps (A - s B) regular with rigid-body modes present
    diag_k = np.abs(lin.K.diagonal())
    diag_m = np.abs(lin.M.diagonal())
    ratio = np.median(diag_k[diag_m > 0] / diag_m[diag_m > 0]) if np.any(diag_m > 0) else 1.0
    shift = -1e-6 * ratio
    lu = spla.splu((a - shift * b).tocsc())
    op = spla.LinearOperator(a.shape, matvec=lambda v: lu.solve(b @ v), dtype=float)
    k = min(n_modes + 4, n_x - 1)
    nu, vec = spla.eigs(op, k=k, which="LM")
    with np.errstate(divide="ignore"):
        lam = shift + 1.0 / nu
    return lam, vec[:n_x]


def _rayleigh(lin, num, free, lam, vec):
    """The eigenvalues of a symmetric pencil as Rayleigh quotients ``v^T K v / v^T M v`` of
    their (real) eigenvectors, the material part ``v^T K0 v`` summed element by element.

    ARPACK's eigenvalue comes from the inverse operator, i.e. from the sparse LU's solutions,
    whose error in the soft directions of a finely meshed structure is large (the assembled
    stiffness spans 1e15 between axial and bending terms): the lowest frequency of the
    10^4-element bench cantilever came out 6e-5 too high. The eigenvector is much better
    than that, and a Rayleigh quotient's error is of second order in the eigenvector's. The
    quotient with the assembled K is still 2e-7 off there (its product loses the soft part
    to round-off); with ``v^T K0 v = sum_e (D_e v_e)^T S_e (D_e v_e)``, each element's
    positions taken relative to its first node (:func:`relative_positions`), it is
    20.7271436 Hz, as with 10^3 elements. The load-dependent part ``K - K0`` is small and
    multiplied as assembled. Complex and infinite modes, and non-symmetric pencils
    (follower-type loads), keep ARPACK's values."""
    K, M = lin.K, lin.M
    scale = abs(K).max() if K.nnz else 0.0
    if scale == 0 or abs(K - K.T).max() > 1e-12 * scale:
        return lam
    real = np.isfinite(lam) & (np.abs(lam.imag) <= 1e-8 * np.abs(lam))
    if not real.any():
        return lam
    v = vec[:, real]
    # a real eigenvector up to a complex factor: turn its largest entry real
    big = v[np.argmax(np.abs(v), axis=0), np.arange(v.shape[1])]
    v = (v * (np.abs(big) / np.where(big == 0, 1.0, big))).real
    energy = np.einsum("ij,ij->j", v, lin.G @ v)             # the load-dependent part
    full = np.zeros((num.n_coord, v.shape[1]))
    full[free] = v
    for g, st in zip(num.groups, lin.states):
        rates = st.D @ relative_positions(full[g.idx], g.kind.position_starts)
        energy += np.einsum("eik,eij,ejk->k", rates, g.S, rates)
    mass = np.einsum("ij,ij->j", v, M @ v)
    out = lam.copy()
    ok = mass > 0
    out[np.flatnonzero(real)[ok]] = energy[ok] / mass[ok]
    return out


def _normalize(vec, M):
    mv = M @ vec
    mm = np.einsum("ij,ij->j", vec, mv)
    big = np.abs(vec).max(axis=0, initial=0.0)
    div = np.where(mm > 0, np.sqrt(np.where(mm > 0, mm, 1.0)), np.where(big > 0, big, 1.0))
    return vec / div

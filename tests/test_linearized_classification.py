"""Round-off never decides a stored classification or order (issue 17, D3): an exactly
infinite buckling multiplier perturbed by round-off-size noise stays infinite (NaN, kind
infinite), +mu/-mu pairs keep their order, and the Table 3 decks store the same multipliers
with one and with two BLAS threads."""
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

from spacarpy.batch.compare import INFINITE_MULTIPLIER, canonical_multipliers
from spacarpy.solvers.linear import buckling as B
from spacarpy.solvers.linear import eigen as E

DECKS = Path(__file__).resolve().parents[1] / "decks"
EPS = np.finfo(float).eps


def pencil(seed_q=0):
    """K (SPD) and G with exact multipliers +-1, +-2, +-5 (pairs) and 4 infinite ones (G
    does not load those modes), in a random orthonormal basis."""
    blocks_k, blocks_g = [], []
    for d in (1.0, 2.0, 5.0):
        blocks_k.append(np.eye(2) * d)
        blocks_g.append(np.array([[0.0, 1.0], [1.0, 0.0]]))   # mu = -+d
    k = sp.block_diag(blocks_k + [np.diag([3.0, 7.0, 11.0, 13.0])]).toarray()
    g = sp.block_diag(blocks_g + [np.zeros((4, 4))]).toarray()
    q, _ = np.linalg.qr(np.random.default_rng(seed_q).standard_normal((10, 10)))
    return q.T @ k @ q, q.T @ g @ q


def lin_of(k, g):
    n = k.shape[0]
    return SimpleNamespace(K=sp.csr_matrix(k), K_mat=sp.csr_matrix(k), G=sp.csr_matrix(g),
                           C=sp.csr_matrix((0, n)))


def noisy(a, rng, size):
    e = rng.standard_normal(a.shape) * size * EPS * np.abs(a).max()
    return a + 0.5 * (e + e.T)


EXACT = np.array([-1.0, 1.0, -2.0, 2.0, -5.0, 5.0])


@pytest.mark.parametrize("dense_limit", [10_000, 0], ids=["dense", "sparse"])
def test_an_infinite_multiplier_under_round_off_noise_is_stored_infinite_in_one_order(
        dense_limit):
    k, g = pencil()
    kinds, spurious = [], 0
    for seed in range(12):
        rng = np.random.default_rng(seed)
        kn, gn = noisy(k, rng, 4.0), noisy(g, rng, 4.0)
        # what the old code stored: a finite 1e14..1e17 for a mode the load does not load
        with np.errstate(divide="ignore", invalid="ignore"):
            raw = np.linalg.eigvals(np.linalg.solve(-gn, kn)) if seed == 0 else None
        if raw is not None:
            spurious = np.sum(np.isfinite(raw) & (np.abs(raw) > 1e10))
        bk = B.buckling_modes(lin_of(kn, gn), n_modes=8, dense_limit=dense_limit)
        np.testing.assert_allclose(bk.multiplier[:6], EXACT, rtol=1e-12)
        assert np.isnan(bk.multiplier[6:]).all()
        kinds.append(bk.kind.tolist())
        assert bk.critical == pytest.approx(1.0, rel=1e-12)
        big = np.abs(bk.shape[:, :6]).max(axis=0)
        np.testing.assert_allclose(big, 1.0, rtol=1e-12)       # largest component +1 ...
        assert np.all(bk.shape[:, :6].max(axis=0) == pytest.approx(1.0, rel=1e-12))
    assert spurious > 0 or dense_limit == 0        # the noise does make them finite
    assert all(kd == [B.FINITE] * 6 + [B.INFINITE] * 2 for kd in kinds)


def test_a_vanishing_load_has_only_infinite_multipliers():
    k, _ = pencil()
    for dense_limit in (10_000, 0):
        bk = B.buckling_modes(lin_of(k, np.zeros_like(k)), n_modes=4, dense_limit=dense_limit)
        assert np.isnan(bk.multiplier).all() and bk.critical == np.inf
        assert (bk.kind == B.INFINITE).all()


def test_canonical_order_groups_equal_magnitudes_by_sign():
    mu = np.array([2.0 * (1 + 1e-13), -1.0, 1.0 + 3e-15, -2.0, 7.0])
    assert mu[E.canonical_order(np.abs(mu), mu)].tolist() == [-1.0, 1.0 + 3e-15, -2.0,
                                                              2.0 * (1 + 1e-13), 7.0]
    # the baseline's classification of raw stored values
    row = np.array([[4.43, -4.43 * (1 + 1e-14), 4.9e16, np.nan, 12.6, -12.6]])
    got = canonical_multipliers(row)
    assert got[0, :4].tolist() == [-4.43 * (1 + 1e-14), 4.43, -12.6, 12.6]
    assert np.isnan(got[0, 4:]).all() and 4.9e16 > INFINITE_MULTIPLIER > 1e13


def test_a_massless_coordinate_is_an_infinite_mode_whatever_the_noise():
    k, _ = pencil()
    m = np.diag([1.0] * 8 + [0.0, 0.0])
    q, _ = np.linalg.qr(np.random.default_rng(1).standard_normal((10, 10)))
    m = q.T @ m @ q
    counts = set()
    for seed in range(8):
        rng = np.random.default_rng(seed)
        mn = noisy(m, rng, 4.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            import scipy.linalg as sla
            lam, vec = sla.eig(k, mn)
        counts.add(int(E.infinite_mask(lam, vec, mn).sum()))
    assert counts == {2}


def _multipliers(deck, threads, tmp_path):
    out = tmp_path / f"{deck}-{threads}.h5"
    env = dict(os.environ, OPENBLAS_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads),
               MKL_NUM_THREADS=str(threads))
    proc = subprocess.run([sys.executable, "-m", "spacarpy", "run", str(DECKS / f"{deck}.dat"),
                           "-o", str(out), "-q"], env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    import h5py
    with h5py.File(out, "r") as f:
        return f["buckling/load_multiplier"][()], f["buckling/critical_load_multiplier"][()]


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["basic", "modified"])
def test_table3_decks_classify_alike_with_one_and_two_blas_threads(tmp_path, variant):
    deck = f"table3_lateral_buckling_4el_{variant}"
    (m1, c1), (m2, c2) = (_multipliers(deck, t, tmp_path) for t in (1, 2))
    n_finite = {"basic": 6, "modified": 8}[variant]
    for m in (m1, m2):
        assert np.isfinite(m[0, :n_finite]).all() and np.isnan(m[0, n_finite:]).all()
        # +mu, -mu pairs: negative first
        assert (np.sign(m[0, :n_finite]) == np.tile([-1.0, 1.0], n_finite // 2)).all()
    np.testing.assert_allclose(m1[0, :n_finite], m2[0, :n_finite], rtol=1e-9)
    np.testing.assert_allclose(c1, c2, rtol=1e-9)

"""The factorization chosen per model (issue 36): QDLDL for chains and small models, MKL
PARDISO for wide (3D) graphs, and PARDISO's answers, inertia and LU against exact ones."""
import os
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp

from spacarpy.solvers.linalg import pardiso
from spacarpy.solvers.linalg.sparse import (
    SUPERNODAL_MIN_UNKNOWNS,
    WIDE_GRAPH,
    SPDFactorization,
    choose,
    graph_width,
    supernodal_lu,
)

needs_pardiso = pytest.mark.skipif(not pardiso.available(),
                                   reason="MKL PARDISO not installed (pip install "
                                          "'spacarpy[pardiso]'; x86-64 only)")


def grid_laplacian(k: int, m: int) -> sp.csc_matrix:
    """The upper triangle (CSC) of the 7-point Laplacian plus identity of a k x k x m grid
    of points, numbered x fastest: an SPD matrix with the graph of a 3D lattice."""
    def line(n):
        return sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])
    eye = sp.identity
    a = (sp.kron(eye(m), sp.kron(eye(k), line(k))) + sp.kron(eye(m), sp.kron(line(k), eye(k)))
         + sp.kron(line(m), eye(k * k)) + eye(k * k * m))
    return sp.triu(a, format="csc")


def chain(n: int) -> sp.csc_matrix:
    return sp.triu(sp.diags([-np.ones(n - 1), 3 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]),
                   format="csc")


def test_graph_width_counts_breadth_first_levels_exactly():
    # a path: every level one unknown
    assert graph_width(chain(10_000)) == 1
    # a k x k x m grid from its corner: level l holds the points with i + j + z = l, at most
    # the (l + 1)(l + 2) / 2 of a full triangle below l < k; level k - 1 is the widest of
    # the first k levels of a 6 x 6 x 20 grid: 21 points
    assert graph_width(grid_laplacian(6, 20), levels=5) == 21
    assert graph_width(grid_laplacian(6, 20), levels=4) == 15


def test_the_rule_keeps_chains_and_small_models_on_qdldl(monkeypatch):
    monkeypatch.delenv("SPACARPY_FACTORIZATION", raising=False)
    assert choose(chain(600_000)) == "qdldl"                     # any length
    small = grid_laplacian(12, 12)                               # 1 728 < the minimum
    assert small.shape[0] < SUPERNODAL_MIN_UNKNOWNS and graph_width(small) >= WIDE_GRAPH
    assert choose(small) == "qdldl"
    wide = grid_laplacian(14, 28)                                # 5 488 unknowns, 3D
    assert choose(wide) == ("pardiso" if pardiso.available() else "qdldl")


def test_forcing_a_factorization(monkeypatch):
    monkeypatch.setenv("SPACARPY_FACTORIZATION", "qdldl")
    assert choose(grid_laplacian(14, 28)) == "qdldl"
    monkeypatch.setenv("SPACARPY_FACTORIZATION", "pardiso")
    assert choose(chain(100)) == ("pardiso" if pardiso.available() else "qdldl")


def test_upper_csr_order_is_the_same_triangle():
    rng = np.random.default_rng(3)
    a = sp.random(200, 200, density=0.05, random_state=rng) + sp.identity(200)
    upper = sp.triu(a + a.T, format="csc")
    ia, ja, order = pardiso.upper_csr_order(upper.indptr, upper.indices, 200)
    csr = sp.csr_matrix((upper.data[order], ja, ia), shape=(200, 200))
    assert (csr != upper.tocsr()).nnz == 0
    assert np.all(ja >= np.repeat(np.arange(200), np.diff(ia)))      # upper: col >= row


def _known_inertia(blocks: int, negative: int, seed: int = 5) -> np.ndarray:
    """A symmetric matrix with a positive diagonal and exactly ``negative`` negative
    eigenvalues: 2 x 2 blocks [[1, 2], [2, 1]] (eigenvalues 3, -1) and [[2, 1], [1, 2]]
    (3, 1), coupled by entries of at most 0.002 (a perturbation of norm below 0.5, Weyl:
    no eigenvalue crosses zero) and symmetrically permuted."""
    rng = np.random.default_rng(seed)
    a = np.zeros((2 * blocks, 2 * blocks))
    for b in range(blocks):
        a[2 * b:2 * b + 2, 2 * b:2 * b + 2] = ([[1, 2], [2, 1]] if b < negative
                                               else [[2, 1], [1, 2]])
    e = np.triu(rng.uniform(-0.002, 0.002, a.shape) * (rng.random(a.shape) < 0.1), 1)
    a += e + e.T
    p = rng.permutation(2 * blocks)
    return a[np.ix_(p, p)]


@needs_pardiso
@pytest.mark.parametrize("negative", [0, 1, 7, 30])
def test_pardiso_ldlt_solves_and_counts_negative_eigenvalues(monkeypatch, negative):
    monkeypatch.setenv("SPACARPY_FACTORIZATION", "pardiso")
    a = _known_inertia(30, negative)
    lam = np.linalg.eigvalsh(a)
    assert np.min(np.abs(lam)) > 0.5 and np.sum(lam < 0) == negative
    fac = SPDFactorization()
    rhs = np.arange(60.0)
    x = fac.factorize(sp.triu(sp.csc_matrix(a), format="csc"))(rhs)
    assert fac.backend == "pardiso"
    np.testing.assert_allclose(a @ x, rhs, rtol=0, atol=1e-12 * np.abs(rhs).max())
    assert fac.negative_pivots() == negative


@needs_pardiso
def test_pardiso_and_qdldl_agree_on_a_3d_grid(monkeypatch):
    upper = grid_laplacian(14, 28)
    rhs = np.sin(np.arange(upper.shape[0]))
    out = {}
    for name in ("qdldl", "pardiso"):
        monkeypatch.setenv("SPACARPY_FACTORIZATION", name)
        fac = SPDFactorization()
        solve = fac.factorize(upper)
        assert fac.backend == name
        out[name] = solve(rhs)
        assert fac.negative_pivots() == 0
        # a second factorization on the same pattern (numerical phase only)
        solve = fac.factorize(sp.csc_matrix((2.0 * upper.data, upper.indices, upper.indptr),
                                            shape=upper.shape))
        assert np.linalg.norm(solve(rhs) - 0.5 * out[name]) <= 1e-13 * np.linalg.norm(out[name])
    diff = np.linalg.norm(out["pardiso"] - out["qdldl"])
    assert diff <= 1e-12 * np.linalg.norm(out["qdldl"])       # condition number about 13
    two = SPDFactorization()
    two.backend = "pardiso"
    solve = two.factorize(upper)
    both = solve(np.stack([rhs, 2 * rhs], axis=1))            # several right-hand sides
    np.testing.assert_allclose(both[:, 1], 2 * both[:, 0], rtol=1e-13)


@needs_pardiso
def test_supernodal_lu_solves_a_saddle_point_and_refuses_a_singular_one(monkeypatch):
    monkeypatch.delenv("SPACARPY_FACTORIZATION", raising=False)
    k = grid_laplacian(14, 28)
    n = k.shape[0]
    kf = (k + sp.triu(k, k=1).T).tocsc()
    c = sp.csr_matrix((np.ones(n // 7), (np.arange(n // 7), 7 * np.arange(n // 7))),
                      shape=(n // 7, n))
    a = sp.bmat([[kf, c.T], [c, None]], format="csc")
    rhs = np.cos(np.arange(a.shape[0]))
    lu = supernodal_lu(a)
    assert lu is not None and lu.perturbed == 0
    assert np.linalg.norm(a @ lu.solve(rhs) - rhs) < 1e-10 * np.linalg.norm(rhs)
    # a repeated constraint row: exactly singular; PARDISO perturbs a pivot and hands the
    # matrix back to SuperLU (None), whose "exactly singular" names the redundancy
    c2 = sp.vstack([c, c[:1]])
    singular = sp.bmat([[kf, c2.T], [c2, None]], format="csc")
    assert supernodal_lu(singular) is None


def test_without_mkl_everything_stays_on_qdldl(tmp_path):
    code = ("from spacarpy.solvers.linalg import pardiso, sparse; import scipy.sparse as sp;"
            "import numpy as np;"
            "a = sp.triu(sp.random(3000, 3000, density=0.01, random_state=1) + "
            "sp.identity(3000), format='csc');"
            "print(pardiso.available(), sparse.choose(a))")
    env = dict(os.environ, SPACARPY_NO_PARDISO="1", SPACARPY_FACTORIZATION="pardiso")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["False", "qdldl"]


@needs_pardiso
def test_a_factorization_that_does_not_fit_is_refused_before_it_runs(monkeypatch, caplog):
    """PARDISO's analysis gives the factor's memory before the numerical work; where less
    is available the run stops with the size of a model that would fit (3D fill grows as
    the 4/3 power of the size), or only warns with --ignore-memory-limit."""
    from spacarpy import memory
    upper = grid_laplacian(14, 28)
    ia, ja, order = pardiso.upper_csr_order(upper.indptr, upper.indices, upper.shape[0])
    p = pardiso.Pardiso(ia, ja)
    p.analyse(upper.data[order])
    need = p.peak_bytes
    assert need > 8 * upper.nnz                       # at least the factor's values
    p.release()
    monkeypatch.setattr(memory, "available_bytes", lambda: need // 4)
    monkeypatch.setenv("SPACARPY_FACTORIZATION", "pardiso")
    with pytest.raises(memory.MemoryLimitError, match=r"5488 unknowns .* about 35% of this"):
        SPDFactorization().factorize(upper)           # 0.25^0.75 = 0.354
    token = memory.IGNORE_LIMIT.set(True)
    try:
        solve = SPDFactorization().factorize(upper)
    finally:
        memory.IGNORE_LIMIT.reset(token)
    assert "running anyway" in caplog.text
    full = upper + sp.triu(upper, k=1).T
    rhs = np.ones(upper.shape[0])
    assert np.linalg.norm(full @ solve(rhs) - rhs) < 1e-12 * np.linalg.norm(rhs) * 20


#: the variable as the test session found it (the share test must leave it so)
_SHARE_AT_IMPORT = os.environ.get("SPACARPY_PARDISO_THREADS")

_THREADS = """
from spacarpy.cli.process import _single_blas_thread
_single_blas_thread()
from spacarpy.solvers.linalg import pardiso
print(pardiso.threads())
"""


def _pardiso_threads(**env) -> int:
    clean = {k: v for k, v in os.environ.items()
             if k not in ("MKL_NUM_THREADS", "OMP_NUM_THREADS", "SPACARPY_PARDISO_THREADS")}
    out = subprocess.run([sys.executable, "-c", _THREADS], env={**clean, **env},
                         capture_output=True, text=True, timeout=120, check=True)
    return int(out.stdout.split()[-1])


@needs_pardiso
def test_pardiso_uses_the_cores_the_command_line_keeps_blas_at_one():
    """The command line sets one BLAS thread (OMP_NUM_THREADS=1, which MKL would apply to
    PARDISO too); PARDISO still gets every core the process may use, unless the user sets
    MKL_NUM_THREADS, or batch and sweep give each worker its share."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert _pardiso_threads() == cores
    assert _pardiso_threads(OMP_NUM_THREADS="1") == cores
    assert _pardiso_threads(MKL_NUM_THREADS="1") == 1
    assert _pardiso_threads(SPACARPY_PARDISO_THREADS="1") == 1


def test_batch_workers_share_the_cores(monkeypatch):
    from types import SimpleNamespace

    from spacarpy.cli.common import _jobs
    monkeypatch.delenv("MKL_NUM_THREADS", raising=False)
    # set first so that monkeypatch restores the variable's absence after the test
    # (_jobs sets it: delenv of an absent variable records nothing to undo)
    monkeypatch.setenv("SPACARPY_PARDISO_THREADS", "")
    monkeypatch.delenv("SPACARPY_PARDISO_THREADS")
    monkeypatch.setattr(os, "cpu_count", lambda: 16)
    assert _jobs(SimpleNamespace(jobs=4)) == 4
    assert os.environ["SPACARPY_PARDISO_THREADS"] == "4"
    monkeypatch.delenv("SPACARPY_PARDISO_THREADS")
    monkeypatch.setenv("MKL_NUM_THREADS", "2")          # the user's setting stands
    assert _jobs(SimpleNamespace(jobs=4)) == 4
    assert "SPACARPY_PARDISO_THREADS" not in os.environ


def test_the_share_does_not_outlive_its_test():
    assert os.environ.get("SPACARPY_PARDISO_THREADS") == _SHARE_AT_IMPORT

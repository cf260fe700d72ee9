"""Intel MKL PARDISO through ctypes: a supernodal, threaded LDL^T / LU with nested dissection
that reports its factor's size, its memory and the inertia (docs/solver.md, "Which
factorization when").

The library is the ``mkl_rt`` shared library of the ``mkl`` wheel, found as ``pypardiso``
finds it (that package is the dependency that brings it; its solver class hashes the whole
matrix at every call and converts the indices to one-based, so the calls are made here).
Where MKL has no wheel (macOS on arm64, Linux on aarch64) :func:`available` is False and
the callers keep QDLDL and SuperLU.

One :class:`Pardiso` holds one analysis (ordering, symbolic factorization) of one sparsity
pattern: :meth:`Pardiso.factorize` redoes only the numerical phase, as QDLDL's ``update``.
Indices are zero-based (``iparm[34] = 1``) and a symmetric matrix is given as the upper
triangle in CSR, which is the lower triangle in CSC: :func:`upper_csr_order` maps the
assembled upper-triangle CSC arrays onto it once per pattern.
"""
from __future__ import annotations

import ctypes
import functools
import glob
import os
import sys

import numpy as np
import scipy.sparse as sp

#: Matrix types of PARDISO used here.
SYMMETRIC_INDEFINITE = -2
UNSYMMETRIC = 11

_ERRORS = {-1: "input inconsistent", -2: "not enough memory", -3: "reordering problem",
           -4: "zero pivot, numerical factorization or iterative refinement problem",
           -5: "unclassified (internal) error", -6: "reordering failed",
           -7: "diagonal matrix is singular", -8: "32-bit integer overflow",
           -9: "not enough memory for out-of-core", -10: "error opening out-of-core files",
           -11: "read/write error with out-of-core files", -12: "wrong license / version"}


#: PARDISO's own peak memory (bytes) of every handle not yet released, and the largest sum
#: seen (:func:`factor_high_water`): the factor memory of a run (``spacarpy bench``).
_LIVE: dict[int, int] = {}
_HIGH_WATER = [0]


def factor_high_water(reset: bool = False) -> int:
    """The largest memory (bytes) that the PARDISO handles alive at one time reported from
    their analyses since the last reset; ``reset`` starts a new count from those alive."""
    peak = _HIGH_WATER[0]
    if reset:
        _HIGH_WATER[0] = sum(_LIVE.values())
    return peak


class PardisoError(RuntimeError):
    """PARDISO returned an error code."""


@functools.lru_cache(maxsize=1)
def _library():
    """The mkl_rt library, its PARDISO threads set (:func:`_wanted_threads`), or None."""
    if os.environ.get("SPACARPY_NO_PARDISO"):
        return None
    lib = None
    # the mkl wheel's library (pypardiso would search all of sys.prefix recursively first:
    # 0.6 s in a virtual environment with many packages)
    for folder in ("lib", "Library/bin"):
        for path in sorted(glob.glob(os.path.join(sys.prefix, folder, "*mkl_rt*")), key=len):
            try:
                lib = ctypes.CDLL(path)
                break
            except OSError:
                continue
        if lib is not None:
            break
    if lib is None:
        try:
            import pypardiso
            lib = pypardiso.PyPardisoSolver().libmkl
        except (ImportError, OSError):
            return None
    _set_threads(lib)
    return lib


@functools.lru_cache(maxsize=1)
def _pardiso_function():
    """The ``pardiso`` entry point of mkl_rt with its argument types, or None."""
    lib = _library()
    if lib is None:
        return None
    fn = lib.pardiso
    i32 = ctypes.POINTER(ctypes.c_int32)
    fn.argtypes = [ctypes.POINTER(ctypes.c_int64), i32, i32, i32, i32, i32, ctypes.c_void_p,
                   i32, i32, i32, i32, i32, i32, ctypes.c_void_p, ctypes.c_void_p, i32]
    fn.restype = None
    return fn


#: MKL's function domain of PARDISO (``mkl_domain_set_num_threads``).
_DOMAIN_PARDISO = 4


def _wanted_threads() -> int | None:
    """PARDISO's threads: ``SPACARPY_PARDISO_THREADS`` where set (``batch`` and ``sweep``
    give each worker its share), else None where the user set ``MKL_NUM_THREADS`` (MKL reads
    it itself), else every core this process may run on. The command line sets
    ``OMP_NUM_THREADS=1`` for numpy's BLAS (:mod:`spacarpy.cli.process`), which MKL would
    otherwise apply to PARDISO too."""
    value = os.environ.get("SPACARPY_PARDISO_THREADS")
    if value:
        try:
            return max(1, int(value))
        except ValueError:
            return None
    if "MKL_NUM_THREADS" in os.environ:
        return None
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


def _set_threads(lib) -> None:
    n = _wanted_threads()
    if n is not None:
        try:
            lib.MKL_Domain_Set_Num_Threads(ctypes.c_int(n), ctypes.c_int(_DOMAIN_PARDISO))
        except AttributeError:              # pragma: no cover - an MKL without the call
            pass


def threads() -> int | None:
    """The threads PARDISO factorizes with (MKL's count for its PARDISO domain); None
    without MKL."""
    lib = _library()
    if lib is None:
        return None
    get = lib.MKL_Domain_Get_Max_Threads
    get.restype = ctypes.c_int
    return int(get(ctypes.c_int(_DOMAIN_PARDISO)))


def available() -> bool:
    """Whether MKL PARDISO can be loaded (the ``mkl`` wheel exists for this platform, and
    ``SPACARPY_NO_PARDISO`` is not set)."""
    return _pardiso_function() is not None


def upper_csr_order(indptr: np.ndarray, indices: np.ndarray, n: int):
    """For an upper triangle stored as CSC (``indptr`` over columns, ``indices`` rows), the
    CSR arrays of the same triangle and the order of the CSC data in them:
    ``csr_data = csc_data[order]``. Zero-based int32."""
    pos = sp.csc_matrix((np.arange(len(indices)), indices, indptr), shape=(n, n)).tocsr()
    return pos.indptr.astype(np.int32), pos.indices.astype(np.int32), pos.data


class Pardiso:
    """One PARDISO handle: analysis of a pattern once, then numerical factorizations.

    ``ia``, ``ja``: zero-based CSR pattern (the upper triangle with every diagonal entry for
    the symmetric type). ``matching``: symmetric weighted matching and scaling (for saddle
    point matrices with zero diagonal blocks; measured slower on the definite tangents).
    """

    def __init__(self, ia, ja, mtype: int = SYMMETRIC_INDEFINITE, matching: bool = False):
        fn = _pardiso_function()
        if fn is None:
            raise PardisoError("MKL PARDISO is not available")
        self._fn = fn
        self.n = len(ia) - 1
        self.ia = np.ascontiguousarray(ia, dtype=np.int32)
        self.ja = np.ascontiguousarray(ja, dtype=np.int32)
        self.mtype = mtype
        self.pt = np.zeros(64, dtype=np.int64)
        self.iparm = np.zeros(64, dtype=np.int32)
        p = self.iparm
        p[0] = 1            # no solver defaults: everything below is set
        p[1] = 2            # METIS nested dissection
        p[7] = 0            # iterative refinement: automatic (2 steps after perturbed pivots)
        p[9] = 13 if mtype == UNSYMMETRIC else 8        # pivot perturbation 1e-13 / 1e-8
        p[10] = 1 if (matching or mtype == UNSYMMETRIC) else 0     # scaling
        p[12] = 1 if (matching or mtype == UNSYMMETRIC) else 0     # weighted matching
        p[17] = -1          # report the number of entries of the factors
        p[20] = 1           # Bunch-Kaufman 1x1 and 2x2 pivots (symmetric indefinite)
        p[23] = 0           # classic parallel factorization
        p[26] = 0           # no matrix checker
        p[34] = 1           # zero-based indices
        self._data = None
        self._analysed = False
        self._factored = False

    def _call(self, phase: int, b=None, x=None, nrhs: int = 1) -> None:
        err = ctypes.c_int32(0)
        i32 = ctypes.POINTER(ctypes.c_int32)
        one = ctypes.c_int32(1)
        a = self._data
        self._fn(self.pt.ctypes.data_as(ctypes.POINTER(ctypes.c_int64)), ctypes.byref(one),
                 ctypes.byref(one), ctypes.byref(ctypes.c_int32(self.mtype)),
                 ctypes.byref(ctypes.c_int32(phase)), ctypes.byref(ctypes.c_int32(self.n)),
                 None if a is None else a.ctypes.data, self.ia.ctypes.data_as(i32),
                 self.ja.ctypes.data_as(i32), None, ctypes.byref(ctypes.c_int32(nrhs)),
                 self.iparm.ctypes.data_as(i32), ctypes.byref(ctypes.c_int32(0)),
                 None if b is None else b.ctypes.data, None if x is None else x.ctypes.data,
                 ctypes.byref(err))
        if err.value != 0:
            raise PardisoError(f"PARDISO error {err.value}: "
                               f"{_ERRORS.get(err.value, 'unknown error')}")

    def analyse(self, data: np.ndarray) -> None:
        """Ordering and symbolic factorization (phase 11); ``data`` in the CSR order. Then
        the memory it will need is checked against the available memory
        (:func:`spacarpy.memory.check_factor_memory`) before any numerical work."""
        from spacarpy.memory import check_factor_memory
        self._data = np.ascontiguousarray(data, dtype=float)
        self._call(11)
        self._analysed = True
        _LIVE[id(self)] = self.peak_bytes
        _HIGH_WATER[0] = max(_HIGH_WATER[0], sum(_LIVE.values()))
        check_factor_memory(self.peak_bytes, self.n)

    def factorize(self, data: np.ndarray) -> None:
        """The numerical factorization (phase 22) of new values on the same pattern."""
        if self._analysed:
            self._data = np.ascontiguousarray(data, dtype=float)
        else:
            self.analyse(data)
        self._factored = False
        self._call(22)
        self._factored = True

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve with the last factorization (phase 33); ``rhs`` of shape (n,) or (n, k)."""
        b = np.asfortranarray(rhs, dtype=float)
        x = np.zeros_like(b, order="F")
        self._call(33, b=b, x=x, nrhs=1 if b.ndim == 1 else b.shape[1])
        return np.ascontiguousarray(x)

    # -- what the analysis and the factorization report ----------------------------------
    @property
    def factor_entries(self) -> int:
        """Entries of the factor (L for the symmetric type, L and U otherwise), known after
        the analysis."""
        return int(self.iparm[17])

    @property
    def peak_bytes(self) -> int:
        """PARDISO's own peak memory (analysis, or factors plus work), known after the
        analysis."""
        p = self.iparm
        return 1024 * int(max(p[14], p[15] + p[16]))

    @property
    def negative_pivots(self) -> int | None:
        """Negative eigenvalues of the last factorized matrix (symmetric type only)."""
        if self.mtype != SYMMETRIC_INDEFINITE or not self._factored:
            return None
        return int(self.iparm[22])

    @property
    def perturbed_pivots(self) -> int:
        return int(self.iparm[13])

    def release(self) -> None:
        """Free PARDISO's memory (phase -1)."""
        if self._analysed:
            try:
                self._call(-1)
            except PardisoError:            # pragma: no cover - nothing left to free
                pass
            self._analysed = self._factored = False
            _LIVE.pop(id(self), None)

    def __del__(self):
        try:
            self.release()
        except Exception:                   # pragma: no cover - interpreter shutdown
            pass

"""spacarpy: large-deflection analysis of flexible multibody systems with the DDM beam.

Reads SPACAR-style decks, solves with the discrete-deformation-mode beam element of
Jonker & Meijaard (2013), writes HDF5 results. Entry points: the ``spacarpy`` command
(:mod:`spacarpy.cli`), :func:`spacarpy.deck.load_deck`,
:func:`spacarpy.solvers.static.solve_static` and :func:`spacarpy.open_results` (reading a
result file; imported on first use, so ``import spacarpy`` stays light).
"""
import os as _os

# One BLAS thread unless the user says otherwise. spacarpy's dense work is many small
# matrices (6x6 element blocks, 100x100 reductions) and sparse factorizations: with the
# default multithreaded OpenBLAS a 120x120 eigh takes 37 ms on a 2-core machine instead of
# 3.7 ms, and a Newton iteration of the 1000-element cantilever 75 ms instead of 63 ms
# (`spacarpy bench`). Batch runs and sweeps use one process per core anyway. Effective only
# when spacarpy is imported before numpy; set OPENBLAS_NUM_THREADS to override.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

__version__ = "0.1.0"

__all__ = ["__version__", "open_results"]


def __getattr__(name):
    if name == "open_results":
        from spacarpy.results.reader import open_results
        return open_results
    raise AttributeError(f"module 'spacarpy' has no attribute {name!r}")

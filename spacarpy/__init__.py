"""spacarpy: large-deflection analysis of flexible multibody systems with the DDM beam.

Reads SPACAR-style decks, solves with the discrete-deformation-mode beam element of
Jonker & Meijaard (2013), writes HDF5 results. Entry points: the ``spacarpy`` command
(:mod:`spacarpy.cli`), :func:`spacarpy.deck.load` (a deck's model and analysis settings),
:func:`spacarpy.run.run_job`, :func:`spacarpy.solvers.statics.static.solve_static` and
:func:`spacarpy.open_results` (reading a result file) and :class:`spacarpy.ModelBuilder`
(models scripted in Python, run in memory: :mod:`spacarpy.scripting`); both imported on first
use, so ``import spacarpy`` stays light.
"""
from spacarpy.version import __version__

__all__ = ["__version__", "open_results", "ModelBuilder"]


def __getattr__(name):
    if name == "open_results":
        from spacarpy.results.reader import open_results
        return open_results
    if name == "ModelBuilder":
        from spacarpy.scripting import ModelBuilder
        return ModelBuilder
    raise AttributeError(f"module 'spacarpy' has no attribute {name!r}")

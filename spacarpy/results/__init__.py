"""Results files of spacarpy analyses: writing, reading, checking and post-processing them.

The schema is documented in ``docs/results.md``. Modules: :mod:`~spacarpy.results.hdf5` (the
crash-safe writer, the eager reader and the validator), :mod:`~spacarpy.results.reader` (the
lazy reader :func:`open_results`), :mod:`~spacarpy.results.stress` (section forces and surface
stresses), :mod:`~spacarpy.results.tables` (``show`` and ``extract``),
:mod:`~spacarpy.results.plot` (matplotlib figures) and :mod:`~spacarpy.results.export` (XDMF
and VTK files for ParaView).
"""
from spacarpy.results.hdf5 import (
    FILETYPE,
    LinearizedResults,
    SCHEMA_VERSION,
    Results,
    ResultsFormatError,
    ResultsWriter,
    StaticResults,
    partial_path_for,
    read_results,
    validate_file,
)
from spacarpy.results.reader import ResultsFile, ResultsQueryError, open_results

__all__ = [
    "FILETYPE",
    "LinearizedResults",
    "SCHEMA_VERSION",
    "Results",
    "ResultsFormatError",
    "ResultsWriter",
    "StaticResults",
    "partial_path_for",
    "read_results",
    "validate_file",
    "open_results",
    "ResultsFile",
    "ResultsQueryError",
]

"""Results files of spacarpy analyses: writing, reading, checking and post-processing them.

The schema is documented in ``docs/results.md``. Modules: :mod:`~spacarpy.results.schema` (the
one table of datasets, schema 2.0, and the map of 1.x names), :mod:`~spacarpy.results.h5file`
(the crash-safe file life cycle, opening for reading), :mod:`~spacarpy.results.model_data`
(the ``/model`` arrays of a model), :mod:`~spacarpy.results.writer` (:class:`ResultsWriter`),
:mod:`~spacarpy.results.validate` (:func:`validate_file`), :mod:`~spacarpy.results.reader`
(the eager :func:`read_results` and the lazy :func:`open_results`),
:mod:`~spacarpy.results.stress` (section forces and surface stresses),
:mod:`~spacarpy.results.tables` (``show`` and ``extract``), :mod:`~spacarpy.results.plot`
(matplotlib figures) and :mod:`~spacarpy.results.export` (XDMF and VTK files for ParaView).
"""
from spacarpy.results.h5file import ResultsFormatError, partial_path_for
from spacarpy.results.reader import (
    LinearizedResults,
    Results,
    ResultsFile,
    ResultsQueryError,
    StaticResults,
    TransientResults,
    open_results,
    read_results,
)
from spacarpy.results.schema import FILETYPE, SCHEMA_VERSION
from spacarpy.results.validate import validate_file
from spacarpy.results.writer import ResultsWriter

__all__ = [
    "FILETYPE",
    "LinearizedResults",
    "SCHEMA_VERSION",
    "Results",
    "ResultsFormatError",
    "ResultsWriter",
    "StaticResults",
    "TransientResults",
    "partial_path_for",
    "read_results",
    "validate_file",
    "open_results",
    "ResultsFile",
    "ResultsQueryError",
]

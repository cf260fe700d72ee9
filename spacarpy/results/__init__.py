"""Results files of spacarpy analyses: the crash-safe HDF5 writer, the reader and the validator.

The schema is documented in ``docs/results.md``; the implementation is
:mod:`spacarpy.results.hdf5`.
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
]

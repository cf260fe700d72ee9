"""Results files of spacarpy analyses: writing, reading, checking and post-processing them.

The schema is documented in ``docs/results.md``. Modules: :mod:`~spacarpy.results.schema` (the
one table of datasets, schema 2.0, and the map of 1.x names), :mod:`~spacarpy.results.h5file`
(the crash-safe file life cycle, opening for reading), :mod:`~spacarpy.results.model_data`
(the ``/model`` arrays of a model), :mod:`~spacarpy.results.writer` (:class:`ResultsWriter`),
:mod:`~spacarpy.results.validate` (:func:`validate_file`), :mod:`~spacarpy.results.reader`
(the eager :func:`read_results` and the lazy :func:`open_results`),
:mod:`~spacarpy.results.stress` (section forces and surface stresses),
:mod:`~spacarpy.results.summary` (``show``), :mod:`~spacarpy.results.tables` (``extract``),
:mod:`~spacarpy.results.plot` (matplotlib figures) and :mod:`~spacarpy.results.export`
(XDMF and VTK files for ParaView).
The names below are imported from their modules on first use.
"""
#: Where each public name lives: imported on first use (PEP 562), so that writing a file
#: (``spacarpy run``) does not import the readers and the validator.
_HOME = {
    "FILETYPE": "schema", "SCHEMA_VERSION": "schema",
    "ResultsFormatError": "h5file", "partial_path_for": "h5file",
    "ResultsWriter": "writer", "validate_file": "validate",
    **{name: "reader" for name in (
        "LinearizedResults", "Results", "ResultsFile", "ResultsQueryError", "StaticResults",
        "TransientResults", "open_results", "read_results")},
}

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


def __getattr__(name):
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module 'spacarpy.results' has no attribute {name!r}")
    import importlib
    value = getattr(importlib.import_module(f"spacarpy.results.{home}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))

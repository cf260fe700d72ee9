"""Results held in memory: a results file's bytes read through the views of open_results.

:class:`InMemoryResults` is a :class:`~spacarpy.results.reader.ResultsFile` whose HDF5 file is
an image in memory (``h5py`` on a :class:`io.BytesIO`), not a file on disk: what
``ModelBuilder.run()`` (:mod:`spacarpy.scripting`) returns when no output file is asked for.
Every view, repr and ``to_xarray``/``to_dataframe`` works on it as on an opened file, and the
same checks run (schema, layout, checksums). This module's one job is that in-memory file.
"""
from __future__ import annotations

import io

import h5py

from spacarpy.results.reader import ResultsFile

__all__ = ["InMemoryResults"]


class InMemoryResults(ResultsFile):
    """The results of a run, held in memory.

    Parameters
    ----------
    image : bytes
        The bytes of a complete results file.
    name : str
        What messages and the repr call it (``path``), e.g. ``"<memory: pendulum>"``.
    verify : bool
        As :func:`~spacarpy.results.reader.open_results`.

    Attributes
    ----------
    summary : RunSummary or None
        What the run reported (steps, frequencies, ...), set by the runner.
    """

    def __init__(self, image: bytes, name: str = "<memory>", *, verify: bool = True):
        self.path = name
        self.verify = verify
        self._verified: set[str] = set()
        self._image = bytes(image)
        self._context = None
        self._handle = h5py.File(io.BytesIO(self._image), "r")
        self.summary = None
        self._load(self._handle)

    @property
    def nbytes(self) -> int:
        """The size of the file image (bytes)."""
        return len(self._image)

    def write(self, path) -> None:
        """Write the results to the file ``path`` (the bytes a run would have written)."""
        with open(path, "wb") as f:
            f.write(self._image)

    def close(self) -> None:
        """Nothing to close: the image stays readable while the object lives."""

    def __enter__(self) -> InMemoryResults:
        return self

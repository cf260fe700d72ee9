"""The crash-safe life cycle of a results file, and opening one for reading.

This module's one job is the HDF5 file itself, below the schema's meaning:

- a run writes ``<stem>.partial.h5`` (:func:`partial_path_for`) and moves it into place
  (``os.replace``, atomic on POSIX) only after the run has finished, so a good output file is
  never replaced by a broken one (:func:`fsync` makes both durable);
- step datasets grow by one row per step (:func:`create_extendable`) and a step is
  *committed* by appending its scale value (load factor, time, linearized step) after its
  rows have been flushed (:func:`append_step`): the scale's length is the number of committed
  steps, rows beyond it belong to a step that was being written when the process died;
- after the groups are created the file is switched to HDF5 single-writer/multiple-reader
  (SWMR) mode, which orders the metadata flushes so that the file on disk never points to
  unwritten data. A killed writer leaves the "open for SWMR write" mark in the superblock:
  :func:`open_for_reading` then opens the file in SWMR-read mode (other HDF5 tools need
  ``h5clear -s file`` first);
- :class:`SchemaFile` reads any supported schema version through the 2.0 dataset names
  (:data:`spacarpy.results.schema.LEGACY_NAMES` for 1.x files).

Every created dataset carries the ``units`` and ``long_name`` of its
:data:`~spacarpy.results.schema.DATASETS` entry.
"""
from __future__ import annotations

import logging
import os
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np

from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.results.schema import DATASETS, KIND_NAMES, legacy_name

log = logging.getLogger(__name__)

__all__ = ["ResultsFormatError", "partial_path_for", "open_for_reading", "fsync", "create",
           "create_extendable", "append_step", "ascii_array", "SchemaFile", "LIBVER",
           "python_value", "str_list"]

# Lowest file-format version that supports SWMR; readable by every HDF5 >= 1.10. ("latest"
# would let a newer HDF5 use formats older readers, e.g. ParaView's, cannot read.)
LIBVER = ("v110", "v110")
# Chunks of the step datasets hold whole steps: up to _MAX_CHUNK_ROWS steps, about _CHUNK_BYTES.
_CHUNK_BYTES = 16384
_MAX_CHUNK_ROWS = 64


class ResultsFormatError(SpacarError):
    """A results file that is not a spacarpy results file this version can read."""

    exit_code = EXIT_INPUT


def partial_path_for(path) -> Path:
    """Return the partial file used while writing the results file ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        The final output file, e.g. ``run/cantilever.h5``.

    Returns
    -------
    pathlib.Path
        ``<directory>/<stem>.partial.h5``, e.g. ``run/cantilever.partial.h5``.
    """
    path = Path(path)
    return path.with_name(path.stem + ".partial.h5")


@contextmanager
def open_for_reading(path):
    """Open a results file read-only; fall back to SWMR-read for a file left open for writing.

    A writer killed in SWMR mode (or one still running) leaves the "open for SWMR write" mark
    in the superblock, which a plain open refuses but an SWMR-read open accepts.
    """
    try:
        f = h5py.File(path, "r")
    except FileNotFoundError as exc:
        raise ResultsFormatError(f"{path}: no such file") from exc
    except OSError as exc:
        try:
            f = h5py.File(path, "r", swmr=True)
        except OSError:
            raise ResultsFormatError(f"{path}: cannot open as HDF5 ({exc})") from exc
        log.debug("%s is marked as open for SWMR writing (writer killed or still running); "
                  "opened in SWMR-read mode", path)
    try:
        yield f
    finally:
        f.close()


def fsync(path: Path) -> None:
    """Flush a file (or directory) to stable storage; best effort for directories."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        if path.is_dir():
            return
        raise
    try:
        os.fsync(fd)
    except OSError:
        if not path.is_dir():
            raise
    finally:
        os.close(fd)


def set_cf_attrs(ds: h5py.Dataset) -> None:
    """``units`` and ``long_name`` of the dataset from the schema table."""
    spec = DATASETS[ds.name.lstrip("/")]
    ds.attrs["units"] = spec.units
    ds.attrs["long_name"] = spec.long_name


def create(group: h5py.Group, name: str, data, dtype=None) -> h5py.Dataset:
    """Create a fixed-size dataset with its CF attributes."""
    ds = group.create_dataset(name, data=data, dtype=dtype)
    set_cf_attrs(ds)
    return ds


def create_extendable(group: h5py.Group, name: str, trailing: tuple, dtype) -> h5py.Dataset:
    """Create an empty step dataset ``(0, *trailing)`` that grows along axis 0."""
    itemsize = np.dtype(dtype).itemsize
    row_bytes = max(int(np.prod(trailing, dtype=np.int64)) * itemsize, 1)
    rows = max(1, min(_MAX_CHUNK_ROWS, _CHUNK_BYTES // row_bytes))
    # A zero-length axis cannot be chunked with a positive chunk size unless it is unlimited.
    maxshape = (None,) + tuple(n if n > 0 else None for n in trailing)
    chunks = (rows,) + tuple(max(n, 1) for n in trailing)
    ds = group.create_dataset(name, shape=(0,) + tuple(trailing), maxshape=maxshape,
                              chunks=chunks, dtype=dtype)
    set_cf_attrs(ds)
    return ds


def append_step(f: h5py.File, datasets: dict, rows: dict, scale: h5py.Dataset, value,
                k: int) -> None:
    """Append row ``k`` of every dataset and make it durable, then commit the step by
    appending its scale value (load factor, time, static step) and flushing again: a reader
    never sees a scale entry whose rows are not on disk."""
    for name, row in rows.items():
        ds = datasets[name]
        ds.resize(k + 1, axis=0)
        ds[k] = row
    f.flush()
    scale.resize(k + 1, axis=0)
    scale[k] = value
    f.flush()


def ascii_array(strings) -> np.ndarray:
    """Fixed-length ASCII array (at least 1 character wide) of ``strings``."""
    encoded = [s.encode("ascii") for s in strings]
    width = max([len(s) for s in encoded] + [1])
    return np.array(encoded, dtype=f"S{width}").reshape(len(encoded))


def python_value(value):
    """Attribute value as a plain Python value (str, bool, int, float, list)."""
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def str_list(ds) -> list[str]:
    """An ASCII dataset as a list of str."""
    return [s.decode("ascii", errors="replace") if isinstance(s, bytes) else str(s)
            for s in ds[()].tolist()]


def schema_major(f: h5py.File) -> int:
    """Major schema version of an opened file (1 when unreadable)."""
    try:
        return int(np.asarray(f.attrs.get("schema_version", [1, 0])).reshape(-1)[0])
    except (TypeError, ValueError, IndexError):
        return 1


class SchemaFile:
    """An opened results file addressed by 2.0 dataset names, whatever its schema version.

    ``sf["static/elements/BEAM/deformation"]`` is ``/static/deformation`` in a 1.x file;
    ``path in sf`` and :meth:`get` translate the same way.
    """

    def __init__(self, f: h5py.File):
        self.f = f
        self.major = schema_major(f)

    def name(self, path: str) -> str:
        """The name of the 2.0 dataset ``path`` in this file."""
        return legacy_name(path.lstrip("/"), self.major)

    def __getitem__(self, path: str):
        return self.f[self.name(path)]

    def __contains__(self, path: str) -> bool:
        return self.name(path) in self.f

    def get(self, path: str):
        return self.f.get(self.name(path))

    @property
    def attrs(self):
        return self.f.attrs

    def element_kinds(self) -> list[str]:
        """Element kinds with a ``/model/elements/<KIND>`` group (1.x: BEAM and the kinds
        whose ``/model/<kind>_elements`` exist)."""
        if self.major >= 2:
            g = self.f.get("model/elements")
            if not isinstance(g, h5py.Group):
                return []
            known = [k for k in KIND_NAMES if k in g]
            return known + sorted(set(g) - set(known))
        return [k for k in KIND_NAMES if self.name(f"model/elements/{k}/ids") in self.f]

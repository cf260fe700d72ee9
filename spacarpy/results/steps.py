"""Step datasets: creating them, and appending a step to them with its checksum.

A step dataset grows by one row per step along axis 0 (:func:`create_extendable`). A step
is written by :class:`StepAppender`: its rows first, made durable by a flush, then its
scale value (load factor, time, linearized step) and a second flush, which commits it (the
scale's length is the number of committed steps; see :mod:`spacarpy.results.h5file` for
the file's life cycle). The ``checksum`` dataset gets a :func:`checksum_row` per step.
"""
from __future__ import annotations

import h5py
import numpy as np

from spacarpy.results.h5file import SCALE_COLUMN, crc32, set_cf_attrs

__all__ = ["create_extendable", "StepAppender", "checksum_row"]

# Chunks of the step datasets hold whole steps: up to _MAX_CHUNK_ROWS steps, about _CHUNK_BYTES.
_CHUNK_BYTES = 16384
_MAX_CHUNK_ROWS = 64


def checksum_row(scale_value, rows: dict, columns: list) -> np.ndarray:
    """The ``checksum`` row of a step: CRC-32 of the scale value and of every row."""
    return np.array([crc32(scale_value if name == SCALE_COLUMN else rows[name])
                     for name in columns], dtype=np.int64)


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


class StepAppender:
    """Appends the steps of one step group (its datasets, its scale, its checksum), through
    HDF5's low-level calls: row ``k`` of every dataset is written and made durable, then the
    step is committed by appending its scale value (load factor, time, static step) and
    flushing again, so that a reader never sees a scale entry whose rows are not on disk.
    The ``checksum`` dataset gets the step's :func:`checksum_row` with the rows (schema 2.1).

    h5py's ``Dataset.resize`` and ``Dataset.__setitem__`` re-derive the shape, the selection,
    the memory space and the type of every write (60-140 us each, most of a small model's
    time step); here each dataset's handle, row shape, memory type and spaces are made once,
    and a row is one ``set_extent``, one hyperslab and one ``write`` (about 10 us). The
    bytes written are the same: every row is converted to its dataset's dtype first, as
    h5py would. A row that already has the dataset's dtype and row shape in C order (what
    :class:`~spacarpy.results.writer.ResultsWriter` hands over) is written as it is
    (:func:`_put_row`), without the conversion of :func:`_write_row`.

    Parameters
    ----------
    f : h5py.File
        The open file (flushed after the rows and after the scale value).
    datasets : dict of str -> h5py.Dataset
        The step datasets by the names the rows use, shape ``(n, *trailing)``.
    scale : h5py.Dataset
        The scale whose length is the number of committed steps.
    checksum : (h5py.Dataset, list of str), optional
        The ``checksum`` dataset and its columns (:func:`checksum_row`).
    """

    def __init__(self, f: h5py.File, datasets: dict, scale: h5py.Dataset,
                 checksum: tuple | None = None):
        self._file = f
        self._targets = [(name, *_row_target(ds)) for name, ds in datasets.items()]
        self._scale = _row_target(scale)
        self._checksum = None
        if checksum is not None:
            ds, columns = checksum
            self._checksum = (ds.name, list(columns))
            self._targets.append((ds.name, *_row_target(ds)))

    def append(self, rows: dict, value, k: int) -> None:
        """Write row ``k`` of every dataset from ``rows`` (by name), flush, then commit the
        step by appending ``value`` to the scale, and flush again."""
        value = np.asarray(value, dtype=self._scale[2])
        if self._checksum is not None:
            name, columns = self._checksum
            rows = {**rows, name: checksum_row(value, rows, columns)}
        for name, dsid, trailing, dtype, maxshape, mtype, mspace, fspace in self._targets:
            row = rows[name]
            if (type(row) is not np.ndarray or row.dtype != dtype or row.shape != trailing
                    or mspace is None or not row.flags.c_contiguous):
                _write_row(dsid, trailing, dtype, maxshape, mtype, mspace, fspace, row, k, name)
            else:                               # as it is: no conversion to make
                _put_row(dsid, trailing, maxshape, mtype, mspace, fspace, row, k)
        self._file.flush()
        _write_row(*self._scale, value, k, "scale")
        self._file.flush()


def _row_target(ds: h5py.Dataset) -> tuple:
    """What writing a row of a step dataset needs, looked up once: (low-level id, row shape,
    dtype, maximum shape, memory type, memory space of one row, a file space to select the
    row in); the last three are None when a row is empty."""
    trailing = tuple(ds.shape[1:])
    maxshape = tuple(h5py.h5s.UNLIMITED if n is None else n for n in ds.maxshape)
    if int(np.prod(trailing, dtype=np.int64)) == 0:
        return ds.id, trailing, ds.dtype, maxshape, None, None, None
    return (ds.id, trailing, ds.dtype, maxshape, h5py.h5t.py_create(ds.dtype),
            h5py.h5s.create_simple((1,) + trailing), ds.id.get_space())


def _write_row(dsid, trailing: tuple, dtype, maxshape, mtype, mspace, fspace, row, k: int,
               name: str) -> None:
    """Grow the dataset to ``k + 1`` rows and write ``row`` into row ``k``. As h5py does, an
    array of another dtype is converted by HDF5 (saturating), anything else by numpy."""
    if isinstance(row, np.ndarray):
        if row.dtype != dtype:
            mtype = h5py.h5t.py_create(row.dtype)
        row = np.asarray(row, order="C")
    else:
        row = np.asarray(row, dtype=dtype, order="C")
    if row.shape != trailing:        # a scalar for a whole row: broadcast, as h5py does
        try:
            row = np.array(np.broadcast_to(row, trailing), order="C")
        except ValueError:
            raise ValueError(f"{name}: a row of shape {row.shape}, expected {trailing}") \
                from None
    if mspace is None:               # an empty row: nothing to write (as h5py does)
        dsid.set_extent((k + 1,) + trailing)
        return
    _put_row(dsid, trailing, maxshape, mtype, mspace, fspace, row, k)


def _put_row(dsid, trailing: tuple, maxshape, mtype, mspace, fspace, row: np.ndarray,
             k: int) -> None:
    """Grow the dataset to ``k + 1`` rows and write the C-ordered ``row`` (of the row shape,
    in the memory type ``mtype``) into row ``k``: the four HDF5 calls of a row."""
    shape = (k + 1,) + trailing
    dsid.set_extent(shape)
    fspace.set_extent_simple(shape, maxshape)
    fspace.select_hyperslab((k,) + (0,) * len(trailing), (1,) + trailing)
    dsid.write(mspace, fspace, row, mtype)

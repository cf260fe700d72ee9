"""The sweep file, written crash-safely point by point as the runs of a sweep finish.

Like a run's result file (:mod:`spacarpy.results.h5file`), a sweep writes
``<stem>.partial.h5`` and moves it into place (``os.replace``, after an ``fsync``) only when
every point has run, so a good sweep file is never replaced by an unfinished one. Each
finished point is written and flushed at once: ``/sweep/status`` starts as
:data:`NOT_RUN` (-2) everywhere and gets the point's exit code, the collected datasets
start as NaN. An interrupted sweep (Ctrl-C, SIGTERM) closes the partial file with the root
attributes ``completed = False``, ``error`` (why) and ``n_done`` (the finished points), and
keeps it: every finished point is there, and ``/sweep/status == -2`` marks the missing
ones. The file uses HDF5's earliest format, which has no "open for writing" mark, so it can
be read while the sweep runs (as of its last flush, one point ago) and after a sweep was
killed outright. The layout is that of docs/batch.md.
"""
from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np

__all__ = ["NOT_RUN", "SweepFile", "estimated_size"]

log = logging.getLogger(__name__)

#: ``/sweep/status`` of a point that has not run (yet, or ever: an interrupted sweep).
NOT_RUN = -2


def estimated_size(n_points: int, n_values: int) -> int:
    """Bytes of a sweep file of ``n_points`` with ``n_values`` collected numbers per point
    (status, error reference and the values; HDF5's own overhead aside)."""
    return int(n_points) * (4 + 16 + 8 * max(int(n_values), 1))


def _scale(group, name: str, values, long_name: str):
    """The dimension scale ``name`` of ``group``, made at first use."""
    import h5py
    if name not in group:
        dtype = h5py.string_dtype("utf-8") if values.dtype.kind in "OU" else None
        sc = group.create_dataset(name, data=values, dtype=dtype)
        sc.attrs["units"] = "1"
        sc.attrs["long_name"] = long_name
        sc.make_scale(name)
    return group[name]


def _cannot_write(path: Path, exc: OSError):
    from spacarpy.outputs import OutputError
    reason = getattr(exc, "strerror", None) or str(exc)
    return OutputError(f"cannot write the sweep file {path}: {reason}")


class SweepFile:
    """One sweep file being written: :meth:`add` per finished point, then :meth:`finish`
    (complete: moved into place) or :meth:`abort` (interrupted: the partial file kept).

    Parameters
    ----------
    path : path-like
        The final sweep file (checked by the caller, :func:`spacarpy.outputs.
        check_output_path`).
    deck : path-like
    axes : sequence of SweepAxis
    """

    def __init__(self, path, deck, axes):
        from spacarpy.results.h5file import create_with, partial_path_for

        self.final_path = Path(path)
        self.partial_path = partial_path_for(self.final_path)
        self.axes = list(axes)
        self.shape = tuple(len(a.values) for a in self.axes)
        if self.partial_path.exists():
            log.info("replacing the stale partial file %s", self.partial_path)
        self._f = None
        # HDF5's earliest file format: no "open for writing" mark in the superblock, so the
        # partial file can be read while the sweep runs, and after a kill. Built in memory
        # and written in one piece (a full disk: no HDF5 object left open, h5file.create_with)
        try:
            self._f = create_with(self.partial_path, lambda f: self._header(f, deck),
                                  libver="earliest")
        except (OSError, RuntimeError) as exc:
            raise self._given_up(exc) from None
        self._n_done = 0

    def _header(self, f, deck) -> None:
        import h5py
        f.attrs["filetype"] = "spacarpy-sweep"
        f.attrs["deck_path"] = str(Path(deck).resolve())
        f.attrs["parameters"] = [a.name for a in self.axes]
        f.attrs["completed"] = np.bool_(False)
        f.attrs["n_points"] = np.int64(int(np.prod(self.shape)))
        f.attrs["n_done"] = np.int64(0)
        try:
            f["deck"] = Path(deck).read_text(encoding="utf-8")
            f["deck"].attrs["units"] = "1"
            f["deck"].attrs["long_name"] = "input deck text, verbatim"
        except (OSError, UnicodeDecodeError):
            pass
        for a in self.axes:
            ds = f.create_dataset(f"parameters/{a.name}", data=np.asarray(a.values, float))
            ds.attrs["long_name"] = f"value of the SET parameter {a.name}"
            ds.attrs["units"] = "1"
            ds.make_scale(a.name)
        st = f.create_dataset("sweep/status", data=np.full(self.shape, NOT_RUN, np.int32))
        st.attrs["long_name"] = ("exit code of each run (0 ok, -1 timeout, -2 not run: "
                                 "the sweep was interrupted first)")
        st.attrs["units"] = "1"
        err = f.create_dataset("sweep/error", shape=self.shape, dtype=h5py.string_dtype())
        err.attrs["long_name"] = "error message of each failed run (empty: none)"
        err.attrs["units"] = "1"
        for ds in (st, err):
            self._attach(f, ds, ())

    def _given_up(self, exc):
        """The error to raise after a failed write; on a full disk the partial file is
        removed first (it cannot be written to the end, nor marked)."""
        from spacarpy.errors import is_disk_full
        from spacarpy.outputs import disk_full_error
        from spacarpy.results.h5file import discard_written
        if not is_disk_full(exc):
            return _cannot_write(self.partial_path, exc)
        discard_written(self._f, self.partial_path)
        self._f = None
        return disk_full_error(self.final_path, exc)

    def _dataset(self, f, path: str, row: np.ndarray):
        """Create the collected dataset ``path`` for rows like ``row`` in ``f``."""
        if path not in f:
            ds = f.create_dataset(path, data=np.full(self.shape + row.shape, np.nan,
                                                     dtype=row.dtype))
            from spacarpy.results.h5file import set_index_units
            from spacarpy.results.schema import DATASETS
            ds.attrs["long_name"] = f"last row of {path} of each run"
            spec = DATASETS.get(path.strip("/"))
            ds.attrs["units"] = spec.units if spec is not None else "1"
            if spec is not None and spec.index_units:
                set_index_units(ds, spec.index_units, spec.index_dims)
            for name, value in spec.attrs if spec is not None else ():
                ds.attrs[name] = value
            self._attach(f, ds, spec.shape[1:] if spec is not None
                         and len(spec.shape) == 1 + row.ndim else ())
        return f[path]

    def _attach(self, f, ds, dims) -> None:
        """netCDF-4 dimensions on every axis of ``ds`` (results schema 3.0): the parameters'
        (copies of /parameters' scales in the dataset's group, which netCDF needs), then the
        row's, named as in the results file (``dims``) or ``<name>_axis<k>``."""
        from spacarpy.results.dims import dimension_name
        from spacarpy.results.schema import FIXED_DIMS, base_dim
        group, leaf = ds.parent, ds.name.rsplit("/", 1)[-1]
        for k, a in enumerate(self.axes):
            ds.dims[k].attach_scale(_scale(group, a.name, np.asarray(a.values, float),
                                           f"value of the SET parameter {a.name}"))
            ds.dims[k].label = a.name
        for j in range(len(self.shape), ds.ndim):
            n, dim = ds.shape[j], (dims[j - len(self.shape)] if dims else None)
            name = dimension_name(base_dim(dim)) if isinstance(dim, str) else f"{leaf}_axis{j}"
            if name in group and group[name].shape != (n,):
                name = f"{leaf}_{name}"
            values = (np.array(FIXED_DIMS[dim], dtype=object) if dim in FIXED_DIMS
                      else np.arange(1, n + 1, dtype=np.int32))
            ds.dims[j].attach_scale(_scale(group, name, values,
                                           f"number of each {name.replace('_', ' ')}"))

    def add(self, idx: tuple, status: int, error: str, rows: dict) -> None:
        """Write one finished point and flush: its exit code, message and collected rows
        (a row whose shape differs from the dataset's first one stays NaN). A write that
        fails (a full disk) is an :class:`~spacarpy.outputs.OutputError`."""
        try:
            self._add(idx, status, error, rows)
        except (OSError, RuntimeError) as exc:
            raise self._given_up(exc) from None

    def _add(self, idx: tuple, status: int, error: str, rows: dict) -> None:
        new = {path: row for path, row in rows.items() if path not in self._f}
        if new:     # built in memory, written in one piece (a full disk: h5file.create_with)
            from spacarpy.results.h5file import rebuild_with
            f, self._f = self._f, None
            self._f = rebuild_with(self.partial_path, f, lambda mem: [
                self._dataset(mem, path, row) for path, row in new.items()],
                libver="earliest")
        for path, row in rows.items():
            ds = self._f[path]
            if ds.shape[len(self.shape):] == row.shape:
                ds[idx] = row
        if error:
            self._f["sweep/error"][idx] = error
        self._f["sweep/status"][idx] = np.int32(status)
        self._n_done += 1
        self._f.attrs["n_done"] = np.int64(self._n_done)
        self._f.flush()

    def finish(self) -> Path:
        """Mark the file complete, make it durable and move it into place."""
        from spacarpy.results.h5file import fsync

        try:
            self._f.attrs["completed"] = np.bool_(True)
            self._f.close()
            fsync(self.partial_path)
        except (OSError, RuntimeError) as exc:
            raise self._given_up(exc) from None
        os.replace(self.partial_path, self.final_path)
        fsync(self.final_path.parent)
        return self.final_path

    def abort(self, reason: str) -> Path:
        """Close the partial file as incomplete (``error`` = ``reason``) and keep it."""
        from spacarpy.results.h5file import fsync

        if self._f is None:              # given up after a full disk: nothing kept
            return None
        if self._f.id.valid:
            self._f.attrs["error"] = reason
            self._f.close()
        fsync(self.partial_path)
        return self.partial_path

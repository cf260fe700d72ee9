"""The crash-safe life cycle of a results file, and opening one for reading.

This module's one job is the HDF5 file itself, below the schema's meaning:

- a run writes ``<stem>.partial.h5`` (:func:`partial_path_for`) and moves it into place
  (``os.replace``, atomic on POSIX) only after the run has finished, so a good output file is
  never replaced by a broken one (:func:`fsync` makes both durable);
- step datasets grow by one row per step (:func:`create_extendable`) and a step is
  *committed* by appending its scale value (load factor, time, linearized step) after its
  rows have been flushed (:class:`StepAppender`): the scale's length is the number of
  committed steps, rows beyond it belong to a step being written when the process died;
- after the groups are created the file is switched to HDF5 single-writer/multiple-reader
  (SWMR) mode, which orders the metadata flushes so that the file on disk never points to
  unwritten data. A killed writer leaves the "open for SWMR write" mark in the superblock:
  :func:`open_for_reading` then opens the file in SWMR-read mode (other HDF5 tools need
  ``h5clear -s file`` first);
- opening is bounded in time and never retries: :func:`open_for_reading` reads the
  superblock itself, reports a truncated file with its size and the size it should have, and
  every error h5py raises on a damaged file becomes a :class:`ResultsFormatError` through the
  one function :func:`damaged`;
- :class:`SchemaFile` reads any supported schema version through the 2.0 dataset names
  (:data:`spacarpy.results.schema.LEGACY_NAMES` for 1.x files).

Every created dataset carries the ``units`` and ``long_name`` of its schema entry.
"""
from __future__ import annotations

import functools
import logging
import os
import re
import sys
import time
import zlib
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

import h5py
import numpy as np

from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.results.hdf5_library import h5py_hdf5_library
from spacarpy.results.header_crc import header_problems
from spacarpy.results.schema import DATASETS, KIND_NAMES, legacy_name

log = logging.getLogger(__name__)

__all__ = ["ResultsFormatError", "partial_path_for", "open_for_reading", "read_superblock",
           "Superblock", "damaged", "is_read_error", "reading", "fsync", "create",
           "ascii_array", "SchemaFile", "discard_written", "create_with",
           "rebuild_with", "LIBVER", "crc32",
           "damaged_steps", "fixed_damaged", "bytes_array", "checksum_problems", "CRC_ATTR",
           "python_value",
           "str_list"]

# Lowest file-format version that supports SWMR; readable by every HDF5 >= 1.10. ("latest"
# would let a newer HDF5 use formats older readers, e.g. ParaView's, cannot read.)
LIBVER = ("v110", "v110")


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


_SIGNATURE = b"\x89HDF\r\n\x1a\n"
# Superblock file-consistency flags (superblock version 3): written by a writer that has the
# file open, cleared when it closes it.
_FLAG_WRITE, _FLAG_SWMR_WRITE = 0x01, 0x04
#: How long :func:`open_for_reading` waits for a file that is being written (SWMR mark) to
#: reach the size its superblock gives, before it reports the file as truncated (s).
SWMR_WAIT = 2.0
#: Attribute of a fixed dataset: the CRC-32 of its values (:func:`crc32`).
CRC_ATTR = "crc32"
_BIG_ENDIAN = sys.byteorder == "big"
#: The column of a ``checksum`` dataset that covers the step's scale value.
SCALE_COLUMN = "(scale)"
# Errors that h5py raises on a damaged file (with an h5py frame in the traceback).
_READ_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError, IndexError,
                UnicodeDecodeError, AttributeError, MemoryError)


class Superblock(NamedTuple):
    """What :func:`read_superblock` finds at the start of an HDF5 file."""

    version: int
    #: Where the file's addresses start (absolute offset of address 0).
    base: int
    #: The end-of-file address stored by the writer: the file must have at least
    #: ``base + stored_eof`` bytes.
    stored_eof: int
    #: File-consistency flags (version 3: bit 0 open for writing, bit 2 open for SWMR writing).
    flags: int

    @property
    def size_needed(self) -> int:
        return self.base + self.stored_eof

    @property
    def swmr_write(self) -> bool:
        """The "open for SWMR write" mark: the writer is running, or was killed."""
        return self.version >= 3 and bool(self.flags & _FLAG_SWMR_WRITE)

    @property
    def open_for_write(self) -> bool:
        return self.version >= 3 and bool(self.flags & _FLAG_WRITE)


def read_superblock(path) -> Superblock | None:
    """The superblock of the HDF5 file ``path``; ``None`` when it has no HDF5 signature.

    The signature is looked for at offset 0, 512, 1024, 2048 ... (after a user block), as HDF5
    does. Raises :class:`ResultsFormatError` for a superblock it cannot decode.
    """
    size = os.path.getsize(path)
    with open(path, "rb") as fh:
        where = 0
        while where + len(_SIGNATURE) <= size:
            fh.seek(where)
            head = fh.read(96)
            if head.startswith(_SIGNATURE):
                return _decode_superblock(path, head)
            where = 512 if where == 0 else 2 * where
    return None


def _decode_superblock(path, b: bytes) -> Superblock:
    def field(at, n):
        if at + n > len(b):
            raise damaged(path, "its HDF5 superblock is cut short")
        return int.from_bytes(b[at:at + n], "little")

    version = b[8] if len(b) > 8 else -1
    if version in (0, 1):
        offsets, flags, at = field(13, 1), field(20, 4), 24 + 4 * version
        base_at, eof_at = at, at + 2 * offsets
    elif version in (2, 3):
        offsets, flags = field(9, 1), field(11, 1)
        base_at, eof_at = 12, 12 + 2 * offsets
    else:
        raise damaged(path, f"unknown HDF5 superblock version {version}")
    if offsets not in (2, 4, 8, 16):
        raise damaged(path, f"its HDF5 superblock gives {offsets}-byte addresses")
    return Superblock(version, field(base_at, offsets), field(eof_at, offsets), flags)


def damaged(path, reason) -> ResultsFormatError:
    """The error for a damaged (truncated, corrupt) or unreadable results file.

    ``reason`` is a message or the exception h5py, the OS or a decoder raised; h5py's
    "truncated file: eof = X, ..., stored_eof = Y" becomes "the file is X bytes, it should be
    Y". Every reader and command reports a damaged file through this one function.
    """
    if isinstance(reason, BaseException):
        text = str(reason) or type(reason).__name__
        m = re.search(r"truncated file: eof = (\d+).*?stored_eof = (\d+)", text)
        if m:
            text = f"the file is {m.group(1)} bytes, it should be {m.group(2)} (truncated)"
        elif "already open for write" in text or "file locking flag" in text:
            text = ("its writer was killed before the first step (the file is still marked "
                    "as open for writing): nothing can be read")
        elif isinstance(reason, UnicodeDecodeError):
            text = f"undecodable text ({text})"
        elif isinstance(reason, MemoryError):
            text = "a dataset claims more memory than there is"
        else:
            text = re.sub(r"^(Unable to|Can't) (synchronously )?", "cannot ", text)
    else:
        text = str(reason)
    return ResultsFormatError(f"{os.fspath(path)}: damaged results file: {text}")


def is_read_error(exc: BaseException) -> bool:
    """Whether ``exc`` was raised by h5py (HDF5) while reading: a damaged file."""
    if isinstance(exc, ResultsFormatError) or not isinstance(exc, _READ_ERRORS):
        return False
    tb = exc.__traceback__
    while tb is not None:
        module = tb.tb_frame.f_globals.get("__name__", "")
        if module == "h5py" or module.startswith("h5py."):
            return True
        tb = tb.tb_next
    return False


@contextmanager
def reading(path):
    """Map the errors h5py raises on a damaged file inside the block to
    :class:`ResultsFormatError` (:func:`damaged`); other errors pass through."""
    try:
        yield
    except _READ_ERRORS as exc:
        if is_read_error(exc):
            raise damaged(path, exc) from exc
        raise


@contextmanager
def open_for_reading(path):
    """Open a results file read-only, in bounded time, or raise :class:`ResultsFormatError`.

    The superblock is read first: a file without the HDF5 signature is not a results file, a
    file shorter than its stored end of file is truncated ("the file is N bytes, it should be
    M"). Only a file that carries the "open for SWMR write" mark (its writer is running or was
    killed) is opened in SWMR-read mode, after waiting up to :data:`SWMR_WAIT` seconds for it to
    reach its stored size, and with a single metadata read attempt (SWMR readers otherwise
    retry a failing checksum with back-off for minutes). There is no retry: any error is
    reported at once. Errors h5py raises while the file is open are mapped by :func:`reading`.
    """
    p = os.fspath(path)
    if not os.path.exists(p):
        raise ResultsFormatError(f"{p}: no such file")
    if os.path.isdir(p):
        raise ResultsFormatError(f"{p}: is a directory, not a results file")
    try:
        sb = read_superblock(p)
        if sb is None:
            raise ResultsFormatError(f"{p}: not an HDF5 file (no HDF5 signature), so not a "
                                     "spacarpy results file")
        size = os.path.getsize(p)
        deadline = time.monotonic() + SWMR_WAIT
        while sb.swmr_write and size < sb.size_needed and time.monotonic() < deadline:
            time.sleep(0.05)         # a running writer may be between two flushes
            sb, size = read_superblock(p) or sb, os.path.getsize(p)
        if size < sb.size_needed:
            raise damaged(p, f"the file is {size} bytes, it should be {sb.size_needed} "
                             "(truncated)")
        with reading(p):
            f = _open_swmr_read(p) if sb.swmr_write else h5py.File(p, "r")
    except PermissionError as exc:
        raise ResultsFormatError(f"{p}: cannot read: permission denied") from exc
    except OSError as exc:       # read_superblock's own reads
        raise damaged(p, exc) from exc
    if sb.swmr_write:
        log.debug("%s is marked as open for SWMR writing (writer killed or still running); "
                  "opened in SWMR-read mode", p)
    try:
        with reading(p):
            yield f
    finally:
        f.close()


def _open_swmr_read(path: str) -> h5py.File:
    """SWMR-read open with one metadata read attempt (bounded time on a corrupt file)."""
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    fapl.set_fclose_degree(h5py.h5f.CLOSE_STRONG)
    setter = _metadata_read_attempts()
    if setter is None:
        log.debug("H5Pset_metadata_read_attempts not found; SWMR-read open with HDF5's default")
        return h5py.File(path, "r", swmr=True)
    setter(fapl.id, 1)
    fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ,
                        fapl=fapl)
    return h5py.File(fid)


@functools.cache
def _metadata_read_attempts():
    """``H5Pset_metadata_read_attempts`` of the HDF5 library h5py uses (None if not found):
    h5py does not expose it (:func:`spacarpy.results.hdf5_library.h5py_hdf5_library`)."""
    found = h5py_hdf5_library()
    return None if found is None else found[1]


def create_with(path, write, libver=LIBVER) -> h5py.File:
    """Create the HDF5 file ``path`` holding what ``write(f)`` puts into an empty file, and
    return it open for appending (``r+``).

    The content is built in memory and reaches the disk by one plain write: a disk that
    fills up meanwhile raises a plain ``OSError`` while no HDF5 object of the file is open.
    (Writing it through HDF5 instead, a full disk fails a metadata flush that HDF5 cannot
    undo: the datasets then stay open inside the library, cannot be closed, and the
    interpreter crashes at exit when HDF5 closes them; ``spacarpy`` itself ends by
    ``os._exit``, a library caller of ``spacarpy.cli.main`` does not.)"""
    import io
    return _write_image(path, io.BytesIO(), "w", write, libver)


def rebuild_with(path, f, write, libver=LIBVER) -> h5py.File:
    """Close ``f`` (the file ``path`` open for writing), add what ``write(mem)`` puts into an
    HDF5 file of its content in memory, and write the result back to ``path`` as
    :func:`create_with` does (the same reason); return ``path`` open for appending."""
    import io
    f.close()
    return _write_image(path, io.BytesIO(Path(path).read_bytes()), "r+", write, libver)


def _write_image(path, image, mode, write, libver) -> h5py.File:
    """Open the in-memory HDF5 file ``image`` in ``mode``, let ``write`` fill it, write its
    bytes to ``path`` by one plain write and return ``path`` open for appending."""
    with h5py.File(image, mode, libver=libver) as mem:
        write(mem)
    with open(path, "wb") as out:
        out.write(image.getbuffer())
    del image
    return h5py.File(path, "r+", libver=libver)


def discard_written(f, path) -> None:
    """Give up the HDF5 file ``f`` (open for writing at ``path``) after a failed write (a full
    disk): remove it, never raising.

    HDF5 flushes its metadata and cached data on close; after a write failed for lack of
    space that flush fails again (it may need more than the space there is, even in an
    emptied file), the datasets it could not close stay open inside HDF5, and closing them
    later (the interpreter's exit, a retry) crashes the process (a segmentation fault inside
    HDF5). So HDF5's descriptor of the file is first pointed at the null device (every later
    write succeeds and goes nowhere), the file is truncated to 0 bytes, which gives its space
    back, then closed with every object of it (:meth:`h5py.File.close`), then unlinked."""
    if f is not None:
        _write_to_null_device(f, path)
    try:
        os.truncate(path, 0)
    except OSError as exc:
        log.debug("could not truncate %s: %s", path, exc)
    for _ in range(2 if f is not None else 0):   # a failed flush's state fails the first
        try:
            f.close()
            break
        except Exception as exc:         # noqa: BLE001 - the file is given up
            log.debug("closing %s failed: %s", path, exc)
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass
    except OSError as exc:
        log.warning("could not remove %s: %s", path, exc)


def _write_to_null_device(f, path) -> None:
    """Make HDF5's descriptor of the open file ``f`` (the default sec2 driver) the null
    device: what HDF5 writes from now on is discarded, what it reads is zeros."""
    try:
        fd = f.id.get_vfd_handle()
        null = os.open(os.devnull, os.O_RDWR)
        try:
            os.dup2(null, fd)
        finally:
            os.close(null)
    except Exception as exc:             # noqa: BLE001 - best effort; closing still tried
        log.debug("could not detach %s from HDF5: %s", path, exc)


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


@functools.cache
def _attr_types():      # the HDF5 types and space of new_attrs' attributes
    return {str: h5py.h5t.py_create(h5py.string_dtype(), logical=True),
            np.int64: h5py.h5t.STD_I64LE}, h5py.h5s.create(h5py.h5s.SCALAR)


def new_attrs(obj, values: dict) -> None:
    """New ``str``/``np.int64`` attributes of ``obj`` as ``obj.attrs[name] = value`` writes
    them, by low-level calls (h5py's path: 60-80 us each; a small run's file has ~150)."""
    types, scalar = _attr_types()
    for name, value in values.items():
        kind = str if isinstance(value, str) else np.int64
        if kind is np.int64 and not isinstance(value, np.int64):
            raise TypeError(f"attribute {name!r}: str or np.int64 expected, got {value!r}")
        attr = h5py.h5a.create(obj.id, name.encode(), types[kind], scalar)
        try:
            attr.write(np.array(value, dtype=h5py.string_dtype() if kind is str else "<i8"))
        finally:
            attr.close()


def set_cf_attrs(ds: h5py.Dataset, extra: dict | None = None) -> None:
    """``units``, ``long_name`` (the schema's) and ``extra`` attributes of a new dataset."""
    spec = DATASETS[ds.name.lstrip("/")]
    new_attrs(ds, {"units": spec.units, "long_name": spec.long_name, **dict(spec.attrs),
                   **(extra or {})})
    if spec.index_units:
        set_index_units(ds, spec.index_units, spec.index_dims)


def set_index_units(ds: h5py.Dataset, units, dims) -> None:
    """The companion attributes of a dataset whose indices have different units (its
    ``units`` is ``"1"``; schema 3.0): ``units_per_index``, one unit per index of the
    dimensions ``units_per_index_dims`` (names separated by spaces), row-major."""
    ds.attrs.create("units_per_index", [str(u) for u in units],
                    dtype=h5py.string_dtype("utf-8"))
    new_attrs(ds, {"units_per_index_dims": " ".join(dims)})


def create(group: h5py.Group, name: str, data, dtype=None) -> h5py.Dataset:
    """Create a fixed-size dataset with its CF attributes and, but for variable-length
    strings (``/deck``: its SHA-256 is a root attribute), the ``crc32`` of its stored values."""
    ds = group.create_dataset(name, data=data, dtype=dtype)
    kind, crc = ds.dtype.kind, None
    if kind != "O":         # numbers: the data as numpy converts them, not read back
        stored = np.asarray(data, dtype=ds.dtype) if kind in "biuf" else ds[()]
        crc = {CRC_ATTR: np.int64(crc32(stored))}
    elif ds.ndim:           # an array of strings (schema 3.0), as read back
        crc = {CRC_ATTR: np.int64(crc32(ds[()]))}
    set_cf_attrs(ds, crc)
    return ds


def crc32(values) -> int:
    """CRC-32 of the bytes of ``values`` (little-endian, C order): the same on every machine."""
    a = np.asarray(values)
    if a.dtype.kind in "OU":    # strings (vlen): their UTF-8 bytes, each ended by a NUL
        return zlib.crc32(b"".join((v if isinstance(v, bytes) else str(v).encode("utf-8"))
                                   + b"\0" for v in a.reshape(-1).tolist()))
    a = np.ascontiguousarray(a)
    if a.dtype.byteorder == ">" or (a.dtype.byteorder == "=" and _BIG_ENDIAN):
        a = a.astype(a.dtype.newbyteorder("<"))
    return zlib.crc32(a)                # its buffer: the bytes of a uint8 view, uncopied


def damaged_steps(group: h5py.Group, n: int, only: str | None = None,
                  block: int = 256) -> dict:
    """``{dataset path: [steps]}`` of the first ``n`` (committed) steps of a step group whose
    rows do not match their stored checksum; ``{}`` for a group without checksums. ``only``
    checks one dataset (its path in the group, or the scale's). The datasets are read in
    blocks of ``block`` steps."""
    checksum = group.get("integrity/checksum", group.get("checksum"))   # 3.0, 2.x
    if not isinstance(checksum, h5py.Dataset):
        return {}
    columns = str(python_value(checksum.attrs.get("columns", ""))).split()
    scale = {"static": "load_factor", "transient": "time"}.get(group.name.lstrip("/"), "step")
    n = min(n, checksum.shape[0])
    stored = checksum[:n]
    bad = {}
    for j, name in enumerate(columns):
        if only is not None and only != (scale if name == SCALE_COLUMN else name):
            continue
        ds = group.get(scale if name == SCALE_COLUMN else name)
        if not isinstance(ds, h5py.Dataset) or ds.shape[:1] < (n,) or j >= stored.shape[1]:
            bad[f"{group.name}/{name}"] = list(range(n))
            continue
        steps = []
        for start in range(0, n, block):
            data = ds[start:min(start + block, n)]
            steps += [start + k for k, row in enumerate(data)
                      if crc32(row) != stored[start + k, j]]
        if steps:
            bad[ds.name] = steps
    return bad


def fixed_damaged(ds: h5py.Dataset) -> bool:
    """Whether a fixed dataset (``/model/...``) does not match its ``crc32`` attribute."""
    stored = ds.attrs.get(CRC_ATTR)
    return stored is not None and crc32(ds[()]) != int(stored)


def checksum_problems(f: h5py.File, committed: dict) -> list[str]:
    """Every dataset of an opened file that fails its checksum, one message each;
    ``committed`` gives the number of committed steps of each step group."""
    problems = header_problems(f.attrs)

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and CRC_ATTR in obj.attrs and fixed_damaged(obj):
            problems.append(f"/{name} is damaged (its values do not match its checksum)")
    f.visititems(visit)
    for group, n in committed.items():
        for name, steps in damaged_steps(f[group], n).items():
            problems.append(f"{name} is damaged at {_steps(steps)} (the values do not match "
                            "the checksum stored with the step)")
    return problems


def _steps(steps: list) -> str:
    shown = ", ".join(map(str, steps[:10])) + (", ..." if len(steps) > 10 else "")
    return f"step{'s' * (len(steps) > 1)} {shown}"


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
    """A dataset of strings (fixed-length ASCII before 3.0, UTF-8 since) as a list of str."""
    return [s.decode("utf-8", errors="replace") if isinstance(s, bytes) else str(s)
            for s in ds[()].tolist()]


def bytes_array(ds: h5py.Dataset, selection=()) -> np.ndarray:
    """``ds[selection]``, an array of strings as fixed-length UTF-8 bytes whatever the
    schema (UTF-8 of variable length since 3.0, fixed-length ASCII before)."""
    data = ds[selection]
    if ds.dtype.kind == "O" and ds.ndim and h5py.check_string_dtype(ds.dtype) is not None:
        data = np.array([v if isinstance(v, bytes) else str(v).encode("utf-8")
                         for v in np.ravel(data).tolist()] or [b""],
                        dtype=bytes)[:np.size(data)].reshape(np.shape(data))
    return data


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

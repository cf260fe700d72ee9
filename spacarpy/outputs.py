"""Output files of the command line: checked before the work, locked while written.

:func:`check_output_path` refuses, before any solve or benchmark, an output path that cannot
be written (empty, an existing directory, a directory that does not exist or is read-only)
or that names one of the run's input files, so that a run never ends in a traceback after
the work is done and never replaces its own deck. :class:`OutputLock` holds an advisory
lock (``fcntl.flock``) on a lock file beside the output, ``out.h5.lock``, for the whole
run: a second ``spacarpy run`` writing the same file stops at once with the other run's
process id, instead of both writing the same partial file. An existing device, FIFO or
socket is refused (:func:`refuse_special_output`); the null device means "discard"
(:func:`discarding`). :func:`check_output_dir` checks an output directory the same way, and
:func:`write_atomically` writes a small file that is never left half-written. Creating the
lock file also proves that the directory is writable. The lock is advisory and local: it protects
spacarpy runs from each other, not from other programs, and on network file systems only
as far as they support ``flock``.
"""
from __future__ import annotations

import errno
import logging
import os
import shutil
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path

from spacarpy.errors import EXIT_INPUT, SpacarError

log = logging.getLogger(__name__)

try:                                   # POSIX only; elsewhere the lock is not taken
    import fcntl
except ImportError:                    # pragma: no cover - Windows
    fcntl = None


class OutputError(SpacarError):
    """An output path that cannot or must not be written (exit 2)."""

    exit_code = EXIT_INPUT


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def check_output_path(path, what: str = "output file", inputs=(), warn: bool = True) -> Path:
    """Check that ``path`` can be created as a file before the work that writes it.

    Parameters
    ----------
    path : str or os.PathLike
        The output file given on the command line.
    what : str
        How messages name it, e.g. ``"-o"`` or ``"--markdown"``.
    inputs : iterable of path-like
        Files the command reads (the deck and its INCLUDEs): the output must not be one.
    warn : bool
        Log a warning when ``path`` is a write-protected file (it will be replaced all the
        same, as by ``mv``: the permission that counts is the directory's).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OutputError
        Empty path, an existing directory, a missing or read-only parent directory, a parent
        that is not a directory, or an input file.
    """
    text = os.fspath(path)
    if not str(text).strip():
        raise OutputError(f"{what}: the output file name is empty")
    p = Path(text)
    if p.is_dir():
        raise OutputError(f"{what} {p}: is a directory; give a file name, e.g. {p / 'out'}")
    refuse_special_output(p, what)
    if is_null_device(p):
        return p                        # discarded: nothing is written there (discarding)
    _check_parent(p, what, "")
    for inp in inputs:
        try:
            same = p.exists() and os.path.samefile(p, inp)
        except OSError:
            same = False
        if same:
            raise OutputError(f"{what} {p}: is an input file of this run ({inp}); it would "
                              f"be overwritten. Give another output file")
    if warn and p.is_file() and not p.stat().st_mode & 0o222:     # by its mode bits, also for root
        log.warning("%s is write-protected; it will be replaced by the new results", p)
    return p


def _check_parent(p: Path, what: str, prefix: str) -> None:
    """The directory that will hold ``p`` exists, is a directory and is writable."""
    parent = p.parent
    if not parent.exists():
        raise OutputError(f"{what} {p}: the directory {parent} does not exist")
    if not parent.is_dir():
        raise OutputError(f"{what} {p}: {parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"{what} {p}: {prefix}the directory {parent} is not writable")


def check_output_dir(path, what: str = "output directory") -> Path:
    """Check that ``path`` is, or can be made as, a writable directory before the work.

    The directory itself may not exist yet (it is created by the command, as one level
    only); its parent must exist and be writable: a mistyped path never makes a tree of
    directories silently.

    Raises
    ------
    OutputError
        Empty path, an existing file, a read-only directory, or a missing or read-only
        parent directory.
    """
    text = os.fspath(path)
    if not str(text).strip():
        raise OutputError(f"{what}: the directory name is empty")
    p = Path(text)
    if p.exists() or p.is_symlink():
        if not p.is_dir():
            raise OutputError(f"{what} {p}: is a file, not a directory")
        if not os.access(p, os.W_OK | os.X_OK):
            raise OutputError(f"{what} {p}: the directory is not writable")
        return p
    _check_parent(p, what, "cannot be created: ")
    return p


def write_atomically(path, data: bytes | str) -> Path:
    """Write ``path`` through a temporary file beside it and ``os.replace``: an interrupted
    write never leaves a half-written file in its place, and a device, FIFO or socket is
    never replaced (the null device discards: nothing is written). A full disk or quota is
    :class:`~spacarpy.errors.DiskFull` (exit 1), other errors :class:`OutputError`."""
    from spacarpy.errors import is_disk_full
    path = Path(path)
    if is_null_device(path):
        log.info("%s is the null device: the output is discarded", os.fspath(path))
        return path
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data.encode("utf-8") if isinstance(data, str) else data)
        _install(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        if is_disk_full(exc):
            raise disk_full_error(path, exc) from None
        raise OutputError(f"cannot write {path}: {_reason(exc)}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


class OutputLock:
    """An exclusive advisory lock on ``<path>.lock`` for as long as the run writes ``path``.

    Use as a context manager; :meth:`acquire` never blocks: another holder raises
    :class:`OutputError` naming its process id. The lock file is removed on release.
    """

    def __init__(self, path):
        self.path = Path(path)
        self.lock_path = self.path.with_name(self.path.name + ".lock")
        self._fd: int | None = None

    def acquire(self) -> OutputLock:
        if fcntl is None:              # pragma: no cover - no flock on this platform
            return self
        while True:
            try:
                fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as exc:
                raise OutputError(f"cannot write in {self.lock_path.parent or '.'}: "
                                  f"{_reason(exc)} (creating {self.lock_path})") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                other = _read_pid(fd)
                os.close(fd)
                if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise OutputError(f"cannot lock {self.lock_path}: {_reason(exc)}") \
                        from None
                who = f"process {other}" if other else "another process"
                raise OutputError(f"{self.path} is being written by another spacarpy run "
                                  f"({who}, lock file {self.lock_path}); wait for it to end "
                                  f"or give another -o") from None
            # The holder before us may have removed the file after we opened it: lock the
            # file that is at the path now, or two runs would hold different inodes.
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.lock_path))
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._fd = fd
        return self

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            self.lock_path.unlink(missing_ok=True)     # while still holding the lock
        except OSError:                                # pragma: no cover
            pass
        os.close(self._fd)
        self._fd = None

    def __enter__(self) -> OutputLock:
        return self.acquire()

    def __exit__(self, *exc) -> bool:
        self.release()
        return False


def _read_pid(fd: int) -> int | None:
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
        return int(text) if text.isdigit() else None
    except OSError:                                    # pragma: no cover
        return None


# -- outputs that are not regular files (issue 34 item 5: never harm the system) -------------

def _null_rdev() -> int:
    try:
        st = os.stat(os.devnull)
        if stat.S_ISCHR(st.st_mode):
            return st.st_rdev
    except OSError:                                    # pragma: no cover
        pass
    return os.makedev(1, 3)                            # Linux's null device


def is_null_device(path) -> bool:
    """Whether ``path`` resolves (through symlinks) to the null device, ``/dev/null`` or
    any node of the same character device: the output is to be discarded."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return False
    return stat.S_ISCHR(st.st_mode) and st.st_rdev == _null_rdev()


_KINDS = ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"))


def refuse_special_output(path, what: str = "output file") -> None:
    """Refuse, before any work, an output path that exists and is not a regular file or a
    directory (a device, a FIFO, a socket; also through a symlink): spacarpy writes a new
    file and moves it into place, which would replace the node itself (as root, even
    ``/dev/null``). The null device is not refused here: the commands discard their output
    there (:func:`discarding`)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return
    if is_null_device(path):
        return
    for test, kind in _KINDS:
        if test(mode):
            raise OutputError(f"{what} {os.fspath(path)}: is {kind}, not a regular file; "
                              "spacarpy writes only regular files (-o /dev/null discards the "
                              "output)")


@contextmanager
def discarding(path, suffix: str | None = None):
    """The path a command writes its output to: ``path`` itself, or, when ``path`` is the
    null device (``-o /dev/null``), a file in a new private temporary directory that is
    removed, with whatever was written there, when the block ends. The null device itself is
    never opened, replaced or locked."""
    if not is_null_device(path):
        yield Path(path)
        return
    tmp = Path(tempfile.mkdtemp(prefix="spacarpy-discard-"))
    try:
        name = "discarded" + (suffix if suffix is not None else Path(path).suffix or ".out")
        log.info("%s is the null device: the output is discarded", os.fspath(path))
        yield tmp / name
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


# -- outputs written whole or not at all (issue 34 item 5: a full disk) ----------------------

def disk_full_error(path, exc) -> SpacarError:
    from spacarpy.errors import DiskFull, disk_full_text
    kept = f"the previous {path} is unchanged" if os.path.lexists(path) else \
        f"no {path} was written"
    return DiskFull(f"disk full (or quota exceeded) while writing {path}: "
                    f"{disk_full_text(exc)}; {kept}. Free some space or give another -o")


def refuse_non_regular(path) -> None:
    """Raise :class:`OutputError` when ``path`` exists (through symlinks) and is not a
    regular file: moving a finished file there would replace a device node (``/dev/null`` as
    root) or a FIFO. The commands refuse such paths before the work
    (:func:`refuse_special_output`); this is the last guard before ``os.replace``."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISREG(mode):
        raise OutputError(f"{os.fspath(path)}: is not a regular file (a device, FIFO or "
                          "socket): it is not replaced by the results")


def _install(staged: Path, path: Path) -> None:
    refuse_non_regular(path)
    os.replace(staged, path)


@contextmanager
def atomic_output(path):
    """Write ``path`` whole or not at all: the block writes the yielded sibling file
    (``.<stem>.partial-<pid><suffix>``, the suffix kept for writers that choose the format
    by it), which replaces ``path`` only when the block succeeds. On any error the sibling
    is removed and ``path`` is untouched; a full disk or quota becomes
    :class:`~spacarpy.errors.DiskFull` (one line, exit 1), never a 0-byte file."""
    from spacarpy.errors import is_disk_full
    path = Path(path)
    staged = path.with_name(f".{path.stem}.partial-{os.getpid()}{path.suffix}")
    try:
        yield staged
        _install(staged, path)
    except BaseException as exc:
        try:
            staged.unlink(missing_ok=True)
        except OSError:                                # pragma: no cover
            pass
        if is_disk_full(exc):
            raise disk_full_error(path, exc) from None
        raise


@contextmanager
def staged_outputs(path):
    """Like :func:`atomic_output` for a command that writes ``path`` and files beside it
    (``export --vtk``: the .pvd and one .vtu per step): the block writes them into a new
    directory beside ``path`` (the yielded path is ``path``'s name in it); each then
    replaces its namesake beside ``path`` when the block succeeds. On an error the
    directory is removed and nothing beside ``path`` changed."""
    from spacarpy.errors import is_disk_full
    path = Path(path)
    stage = Path(tempfile.mkdtemp(prefix=f".{path.stem}.partial-", dir=path.parent or "."))
    try:
        yield stage / path.name
        names = sorted(p.name for p in stage.iterdir())
        for name in names:
            refuse_non_regular(path.with_name(name))
        for name in names:                              # path itself last
            if name != path.name:
                _install(stage / name, path.with_name(name))
        _install(stage / path.name, path)
    except BaseException as exc:
        if is_disk_full(exc):
            raise disk_full_error(path, exc) from None
        raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def running_writer(path) -> int | None:
    """The process id of the spacarpy run writing the results file ``path`` (a
    ``<stem>.partial.h5`` or its final name) now, by its :class:`OutputLock`; None when no
    run holds the lock (finished, or killed: then the lock is free)."""
    if fcntl is None:                                  # pragma: no cover
        return None
    p = Path(path)
    final = p.with_name(p.name[:-len(".partial.h5")] + ".h5") \
        if p.name.endswith(".partial.h5") else p
    lock = final.with_name(final.name + ".lock")
    try:
        fd = os.open(lock, os.O_RDONLY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError:
        return _read_pid(fd) or 0          # held: a writer runs
    else:
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)

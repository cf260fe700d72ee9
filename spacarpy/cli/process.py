"""The process around a command: one BLAS thread, SIGTERM handled like Ctrl-C, errors
printed as capped, printable messages, and the exit without the interpreter's teardown."""
from __future__ import annotations

import os
import signal
import sys

from spacarpy.errors import SpacarError, Terminated


def _single_blas_thread() -> None:
    """One BLAS thread unless the user says otherwise (OPENBLAS_NUM_THREADS and
    OMP_NUM_THREADS override).

    spacarpy's dense work is many small matrices (6x6 element blocks, small reductions),
    where a multithreaded BLAS spends more time synchronising than computing; batch runs and
    sweeps use one process per core anyway. Set here rather than on ``import spacarpy``,
    since a library must not change its host's environment; it takes effect only because
    nothing imported so far by this module has imported numpy. ``OMP_NUM_THREADS`` also
    keeps an MKL-linked numpy at one thread. ``MKL_NUM_THREADS`` is left alone: MKL's other
    user here is PARDISO, the sparse factorization of wide models, which should use the
    cores (:func:`spacarpy.solvers.linalg.pardiso.threads`; with ``MKL_NUM_THREADS=1`` set
    by this function it ran on one core in every command: 85 s instead of 55 s for the
    10^5-beam lattice on 2 cores).
    """
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
        os.environ.setdefault(var, "1")


def _quiet_h5py_dealloc() -> None:
    """h5py reports an error of HDF5 while it frees an object (after a write failed for lack
    of space: "Can't decrement id ref count (... No space left on device)") through
    :data:`sys.excepthook` and :data:`sys.unraisablehook`, which print tracebacks on
    stderr. The failure itself reaches the command as the write's own error (one message,
    exit 1): these reports are logged at debug level only. Other errors keep Python's
    default report."""
    default = sys.unraisablehook
    if getattr(default, "spacarpy", False):
        return

    def hook(unraisable):
        where = repr(getattr(unraisable, "object", ""))
        if "h5py" in where and "dealloc" in where:
            import logging
            logging.getLogger("spacarpy").debug("h5py, freeing an object: %s",
                                                unraisable.exc_value)
            return
        default(unraisable)
    hook.spacarpy = True
    sys.unraisablehook = hook
    # Cython first prints the same error through sys.excepthook (PyErr_PrintEx)
    default_except = sys.excepthook

    def except_hook(kind, value, tb):
        frame = tb
        while frame is not None and frame.tb_next is not None:
            frame = frame.tb_next
        code = frame.tb_frame.f_code if frame is not None else None
        if code is not None and "h5py" in code.co_filename and code.co_name.endswith("_dealloc"):
            return
        default_except(kind, value, tb)
    sys.excepthook = except_hook


def _on_sigterm(signum, frame):
    signal.signal(signal.SIGTERM, signal.SIG_DFL)     # a second SIGTERM ends it at once
    raise Terminated("terminated by SIGTERM")


def _terminate_like_interrupt():
    """SIGTERM (job schedulers, ``kill``) ends a command the way Ctrl-C does: the result file
    is closed with ``error`` set and without its SWMR mark, then exit 143. Only in the main
    thread (``signal`` allows no other), and not where SIGTERM is ignored (``nohup``-like).
    Returns the previous handler (restored when :func:`main` returns), or None."""
    import threading
    if threading.current_thread() is not threading.main_thread():
        return None
    previous = signal.getsignal(signal.SIGTERM)
    if previous is signal.SIG_IGN:
        return None
    signal.signal(signal.SIGTERM, _on_sigterm)
    return previous


def _restore_sigterm(previous) -> None:
    """Put back the SIGTERM handler :func:`_terminate_like_interrupt` replaced, with SIGTERM
    blocked meanwhile: one arriving now is delivered to the restored handler. (One that
    arrived just before still runs ours: :func:`main` catches its
    :class:`~spacarpy.errors.Terminated`, which used to escape as a traceback.)"""
    block = hasattr(signal, "pthread_sigmask")
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM}) if block else None
    try:
        signal.signal(signal.SIGTERM, previous)
    finally:
        if block:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def exit_process(code: int) -> None:
    """End the process with exit code ``code``, without the interpreter's teardown.

    After numpy, scipy and h5py are imported, Python's finalization (tearing down every
    module and collecting every object once more) takes 60-100 ms of CPU on the 2-core
    machine: more than the whole solve of a small model, and 15 % of the 8-element Table 1
    deck's run. Nothing spacarpy writes needs it: every result file and export is closed
    before :func:`main` returns. The exit handlers (the batch workers, logging, h5py) still
    run and the standard streams are flushed; then ``os._exit``. Only for a process that
    ends here: :func:`main` itself (tests, the batch workers' loop) returns normally."""
    import atexit
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):   # a closed pipe (``spacarpy ... | head``)
            pass
    os._exit(int(code or 0))


#: Deck errors printed at most; the rest are counted.
MAX_PRINTED_ERRORS = 50


def _capped(exc: SpacarError) -> str:
    """The message of ``exc``; of a DeckError with many items only the first
    :data:`MAX_PRINTED_ERRORS`, then ``... and N more errors``."""
    from spacarpy.errors import DeckError
    items = getattr(exc, "items", None)
    if not isinstance(exc, DeckError) or len(items) <= MAX_PRINTED_ERRORS:
        return str(exc)
    head = str(DeckError(items[:MAX_PRINTED_ERRORS])).rsplit("\n", 1)[0]   # no "50 errors"
    return (f"{head}\n... and {len(items) - MAX_PRINTED_ERRORS} more errors "
            f"({len(items)} errors)")


def _printable(text: str) -> str:
    """``text`` with control characters (other than newline and tab) escaped as ``\\xNN``,
    so that a message quoting a binary or damaged input never drives the terminal."""
    return "".join(c if c.isprintable() or c in "\n\t" else
                   (f"\\x{ord(c):02x}" if ord(c) < 256 else f"\\u{ord(c):04x}")
                   for c in text)

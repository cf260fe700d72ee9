"""Long-lived worker processes for batch runs and sweeps: start-up is paid once per worker.

A deck of a batch or a sweep point used to be a fresh ``python -m spacarpy run`` process,
which spent most of a small model's time importing numpy, scipy, h5py and spacarpy. A
:class:`Worker` is one child process (``python -m spacarpy.batch.serve``) that imports
spacarpy once and then runs ``spacarpy run`` command lines one after another, in-process
(:func:`spacarpy.cli.main`), with their stdout and stderr captured per run. It still isolates
every run from the caller the way a fresh process did: a hang is killed at the task's timeout,
a crash or an exhausted memory ends only the worker, and the next task gets a fresh one.

Protocol: one JSON line per request on the worker's stdin (``{"argv": [...], "cwd": ...}``),
one JSON line per answer on its original stdout (``{"rc", "stdout", "stderr"}``); the worker's
file descriptor 1 is pointed at its stderr, so stray output of native code cannot corrupt the
answers. :func:`worker` gives each calling thread its own worker (the local backend runs one
thread per job; a Dask worker process keeps its workers between tasks);
:func:`close_workers` ends them all. :func:`prestart` starts workers ahead of their threads,
so that their start-up (about half a second of imports) runs while the caller still checks
its input; a thread takes a started one before it starts its own.
"""
from __future__ import annotations

import atexit
import contextlib
import json
import os
import subprocess
import sys
import threading

__all__ = ["Worker", "WorkerDied", "close_workers", "prestart", "worker"]


class WorkerDied(RuntimeError):
    """The worker process ended (crash, kill, timeout) before answering."""


class Worker:
    """One child process that runs ``spacarpy`` command lines on request."""

    def __init__(self) -> None:
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            env.setdefault(var, "1")        # as cli.main does for a fresh process
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "spacarpy.batch.serve"], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env)
        self.timed_out = False

    def alive(self) -> bool:
        return self.proc.poll() is None

    def call(self, argv: list[str], cwd: str, timeout: float | None) -> dict:
        """Run ``spacarpy <argv>`` in ``cwd``; the answer ``{"rc", "stdout", "stderr"}``.

        Raises
        ------
        WorkerDied
            If the worker ended before answering; ``timed_out`` says whether it was killed
            at ``timeout``. The worker is unusable afterwards.
        """
        self.timed_out = False
        timer = None
        if timeout is not None:
            timer = threading.Timer(timeout, self._kill_for_timeout)
            timer.daemon = True
            timer.start()
        try:
            try:
                self.proc.stdin.write(json.dumps({"argv": argv, "cwd": cwd}) + "\n")
                self.proc.stdin.flush()
                line = self.proc.stdout.readline()
            except (BrokenPipeError, OSError, ValueError):
                line = ""
        finally:
            if timer is not None:
                timer.cancel()
        if not line:
            self.close()
            raise WorkerDied(f"the worker process ended (exit code {self.proc.returncode})")
        return json.loads(line)

    def release(self) -> None:
        """Close the worker's stdin: it ends its loop and exits (:meth:`close` waits)."""
        with contextlib.suppress(OSError, ValueError):
            self.proc.stdin.close()

    def _kill_for_timeout(self) -> None:
        self.timed_out = True
        self.proc.kill()

    def close(self) -> None:
        """End the worker (closing its stdin ends its loop; a stuck one is killed)."""
        self.release()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        with contextlib.suppress(OSError, ValueError):
            self.proc.stdout.close()


_LOCAL = threading.local()
_ALL: list[Worker] = []
_SPARE: list[Worker] = []           # started by prestart(), not yet taken by a thread
_ALL_LOCK = threading.Lock()


def prestart(n: int) -> None:
    """Start ``n`` workers now (fewer where some are already waiting), for the next threads
    that ask :func:`worker` for one."""
    with _ALL_LOCK:
        missing = n - len(_SPARE)
    for _ in range(max(missing, 0)):
        w = Worker()
        with _ALL_LOCK:
            _SPARE.append(w)
            _ALL.append(w)


def worker() -> Worker:
    """This thread's worker: a started one (:func:`prestart`) if one is waiting, else started
    (or restarted after it died) on demand."""
    w = getattr(_LOCAL, "worker", None)
    if w is None or not w.alive():
        w = None
        with _ALL_LOCK:
            while _SPARE and w is None:
                spare = _SPARE.pop(0)
                w = spare if spare.alive() else None
        if w is None:
            w = Worker()
            with _ALL_LOCK:
                _ALL.append(w)
        _LOCAL.worker = w
    return w


def close_workers(kill: bool = False) -> None:
    """End every worker this process started: all are told to exit first, then each is
    waited for (their exits overlap). ``kill``: kill them at once, a run in progress
    included (an interrupted batch or sweep does not wait for its running decks)."""
    with _ALL_LOCK:
        workers, _ALL[:], _SPARE[:] = list(_ALL), [], []
    for w in workers:
        if kill:
            with contextlib.suppress(OSError):
                w.proc.kill()
        w.release()
    for w in workers:
        w.close()


atexit.register(close_workers)

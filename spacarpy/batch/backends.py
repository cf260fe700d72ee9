"""Execution backends: run many tasks and hand each result back as soon as it is done.

``local`` runs each task in a thread that hands it to the thread's worker process (the task
itself isolates the deck in a process, see :func:`spacarpy.batch.runner.run_task`), so it
needs nothing beyond the standard library; the workers end with the pool. ``dask`` submits
the same tasks to a Dask distributed cluster (the optional extra ``spacarpy[dask]``):
``"local"`` starts a ``LocalCluster`` on this machine, any other address
(``tcp://host:8786``) connects to a running scheduler; each Dask worker keeps its worker
process between tasks. A malformed address, a scheduler that does not answer within a few
seconds, or a missing dask is a :class:`DaskError` (exit 2) before any task. Results come
back to the client, which writes every file itself.
"""
from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor, as_completed

from spacarpy.errors import EXIT_INPUT, SpacarError

__all__ = ["DASK_CONNECT_TIMEOUT", "DaskError", "DaskUnavailable", "check_dask_address",
           "execute"]

#: Seconds to wait for a Dask scheduler before giving up (Dask's own default is 30 s).
DASK_CONNECT_TIMEOUT = 5.0


class DaskError(SpacarError):
    """``--dask`` names no usable scheduler: a malformed address, or none answers (exit 2)."""

    exit_code = EXIT_INPUT


class DaskUnavailable(DaskError):
    """``--dask`` was asked for but dask.distributed is not installed (exit 2)."""


def check_dask_address(address: str) -> str:
    """``"local"`` or a scheduler address ``[scheme://]host:port``; else :class:`DaskError`.

    Checked before any work, and before dask is imported, so that a mistyped address is
    refused at once whether dask is installed or not.
    """
    text = str(address).strip()
    if text == "local":
        return text
    m = re.fullmatch(r"(?:([a-z][a-z0-9+.-]*)://)?(\[[0-9a-fA-F:]+\]|[^\s:/\[\]]+):(\d+)",
                     text)
    if not m or not 0 < int(m.group(3)) < 65536:
        raise DaskError(f"--dask {address!r}: not a scheduler address; give 'local' or "
                        "tcp://HOST:PORT (e.g. tcp://scheduler:8786)")
    return text


def _local(fn, tasks, jobs) -> Iterator:
    from spacarpy.batch.workers import close_workers
    try:
        with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
            futures = [pool.submit(fn, t) for t in tasks]
            try:
                for fut in as_completed(futures):
                    yield fut.result()
            except BaseException:
                for fut in futures:
                    fut.cancel()
                close_workers(kill=True)    # interrupted: the running decks end now
                raise
    finally:
        close_workers()         # the worker processes of this pool's threads (batch.workers)


def _dask_client(jobs, address):
    """Connect (or start a LocalCluster): ``(client, cluster or None)``, or DaskError."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise DaskUnavailable("--dask needs dask.distributed, which is not installed: pip "
                              "install 'spacarpy[dask]' (or pip install "
                              "'dask[distributed]')") from None
    if address == "local":
        cluster = LocalCluster(n_workers=max(1, jobs), threads_per_worker=1,
                               processes=True, dashboard_address=None)
        return Client(cluster), cluster
    try:
        return Client(address, timeout=DASK_CONNECT_TIMEOUT), None
    except (OSError, ValueError, TimeoutError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DaskError(f"--dask {address}: no Dask scheduler answered within "
                        f"{DASK_CONNECT_TIMEOUT:g} s ({reason})") from None


def _dask(client, cluster, fn, tasks) -> Iterator:
    from distributed import as_completed as dask_completed
    try:
        futures = [client.submit(fn, t, pure=False) for t in tasks]
        for fut in dask_completed(futures):
            yield fut.result()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def execute(fn: Callable, tasks: Iterable, *, jobs: int = 1,
            dask: str | None = None) -> Iterator:
    """Run ``fn(task)`` for every task; yield the results in completion order.

    Parameters
    ----------
    fn : callable
        A module-level function (Dask pickles it by reference).
    tasks : iterable
    jobs : int
        Tasks run at the same time (local), or workers of a ``dask="local"`` cluster.
    dask : str, optional
        None: local processes. ``"local"``: a Dask LocalCluster of ``jobs`` workers. Otherwise
        the address of a Dask scheduler, connected to here (before any task runs).

    Raises
    ------
    DaskError
        If ``dask`` is malformed or no scheduler answers within
        :data:`DASK_CONNECT_TIMEOUT`; :class:`DaskUnavailable` if dask.distributed cannot
        be imported.
    """
    tasks = list(tasks)
    if dask is None:
        return _local(fn, tasks, jobs)
    client, cluster = _dask_client(jobs, check_dask_address(dask))
    return _dask(client, cluster, fn, tasks)

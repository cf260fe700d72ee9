"""Execution backends: run many tasks and hand each result back as soon as it is done.

``local`` runs each task in a thread that hands it to the thread's worker process (the task
itself isolates the deck in a process, see :func:`spacarpy.batch.runner.run_task`), so it
needs nothing beyond the standard library; the workers end with the pool. ``dask`` submits
the same tasks to a Dask distributed cluster (the optional extra ``spacarpy[dask]``):
``"local"`` starts a ``LocalCluster`` on this machine, any other address
(``tcp://host:8786``) connects to a running scheduler; each Dask worker keeps its worker
process between tasks. Results come back to the client, which writes every file itself.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor, as_completed

__all__ = ["DaskUnavailable", "execute"]


class DaskUnavailable(RuntimeError):
    """``--dask`` was asked for but dask.distributed is not installed."""


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
                raise
    finally:
        close_workers()         # the worker processes of this pool's threads (batch.workers)


def _dask(fn, tasks, jobs, address) -> Iterator:
    try:
        from distributed import Client, LocalCluster
        from distributed import as_completed as dask_completed
    except ImportError as exc:          # pragma: no cover - depends on the environment
        raise DaskUnavailable("--dask needs dask.distributed: pip install 'spacarpy[dask]' "
                              "(or pip install 'dask[distributed]')") from exc
    cluster = None
    if address == "local":
        cluster = LocalCluster(n_workers=max(1, jobs), threads_per_worker=1,
                               processes=True, dashboard_address=None)
        client = Client(cluster)
    else:
        client = Client(address)
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
        the address of a Dask scheduler.

    Raises
    ------
    DaskUnavailable
        If ``dask`` is given and dask.distributed cannot be imported.
    """
    tasks = list(tasks)
    if dask is None:
        return _local(fn, tasks, jobs)
    return _dask(fn, tasks, jobs, dask)

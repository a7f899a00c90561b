"""Independent jobs on a local Dask cluster: the one place the suite starts worker processes.

Campaigns (:mod:`maglev_ocp.campaign`) and the diagnosis self-checks
(:mod:`maglev_ocp.diagnosis.selftest`) both scale out over independent,
individually seeded jobs. Inside one job, :func:`fork_pool` gives a pool of forked processes that share the
job's data as it was at the fork (the diagnosis's independent candidate fits). :func:`local_client` starts the
``LocalCluster`` of single-threaded worker processes (Ctrl-C stays the parent's: the workers
inherit an ignored SIGINT), and :func:`map_ordered` runs a function over a list
of arguments on it, in this process when ``workers == 1``; :class:`BackgroundCluster`
starts one while the caller prepares its jobs. Results do not
depend on the number of workers: each job carries its own seed.
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import threading
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar

from tqdm import tqdm

from .errors import UserError
from .interrupts import sigint_ignored

T = TypeVar("T")
R = TypeVar("R")


@contextlib.contextmanager
def _env_without(name: str) -> Iterator[None]:
    """``name`` absent from ``os.environ`` inside the block (worker processes spawned there inherit that)."""
    saved = os.environ.pop(name, None)
    try:
        yield
    finally:
        if saved is not None:
            os.environ[name] = saved


class BackgroundCluster:
    """A ``LocalCluster`` of ``workers`` single-threaded processes, started in a background thread.

    The worker processes start (import, warm up through ``plugin``) while the
    caller goes on preparing its jobs; :meth:`client` waits for them. SIGINT is
    ignored in this process from the start until the cluster is up (the worker
    processes inherit the ignored SIGINT: Ctrl-C is the parent's, no worker
    tracebacks), as it is while a cluster starts in the foreground.

    Parameters
    ----------
    workers : int
        Number of worker processes.
    plugin : callable, optional
        Returns the dask ``WorkerPlugin`` registered on every worker before :meth:`client` returns (e.g. to
        build the shared model once per process); called in the starting thread, where Dask is imported.
    """

    def __init__(self, workers: int, plugin: Callable[[], Any] | None = None) -> None:
        if importlib.util.find_spec("distributed") is None:  # said here, in the caller's thread; imported there
            raise UserError("dask.distributed is not installed: pip install 'maglev-ocp[campaign]'")
        self.workers = workers
        self._plugin = plugin
        self._cluster: Any = None
        self._client: Any = None
        self._error: BaseException | None = None
        self._closed = False
        self._sigint = contextlib.ExitStack()
        self._sigint.enter_context(sigint_ignored())  # undone by the first of client() / close()
        self._thread = threading.Thread(target=self._start, name="maglev-cluster-start", daemon=True)
        self._thread.start()

    def _start(self) -> None:
        import dask
        from dask.distributed import Client, LocalCluster

        # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers; a fixed trim threshold turns off
        # glibc's dynamic mmap threshold, so every array above 128 kB is mapped, page-faulted, zeroed and
        # unmapped again: the gap diagnosis (thousands of MB-sized products) ran 4 times slower in a worker
        # than alone (one dataset 15 -> 60 s; the same with the variable set in a plain process). Left unset,
        # also where an earlier cluster's nanny left it in this process's environment (Dask sets it there
        # before spawning); the BLAS thread limits (one thread per single-threaded worker) stay.
        settings = {
            "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
            # The worker's statistical profiler samples the task thread's stack every 10 ms for the dashboard
            # (which these clusters do not serve): CPU taken from the jobs, the same on every worker.
            "distributed.worker.profile.enabled": False,
            # A job goes to a worker when it has a free thread, not queued behind a running one: a worker
            # slowed by other processes then takes fewer jobs instead of holding the next one (the default
            # 1.1 gives a single-threaded worker two), and jobs start in their priority order.
            "distributed.scheduler.worker-saturation": 1.0,
        }
        try:
            with dask.config.set(settings), _env_without("MALLOC_TRIM_THRESHOLD_"):
                self._cluster = LocalCluster(
                    n_workers=self.workers,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=":0",
                    silence_logs=logging.ERROR,
                )
            self._client = Client(self._cluster)
            if self._plugin is not None:
                self._client.register_plugin(self._plugin())
        except BaseException as exc:  # re-raised in the caller's thread by client()
            self._error = exc

    def client(self) -> Any:
        """The ``dask.distributed`` client, once every worker is up (and warmed up by the plugin)."""
        self._thread.join()
        self._sigint.close()
        if self._error is not None:
            raise self._error
        return self._client

    def close(self, background: bool = False) -> threading.Thread | None:
        """Close the client and the cluster (after the start, if it is still under way).

        With ``background``, the worker processes shut down in a thread (returned: join it before exiting)
        while the caller goes on, e.g. writing a summary; SIGINT is this process's again either way.
        """
        if self._closed:
            return None
        self._closed = True
        self._thread.join()
        self._sigint.close()  # in the caller's (main) thread: signal handlers are set there only
        if not background:
            self._shut_down()
            return None
        closing = threading.Thread(target=self._shut_down, name="maglev-cluster-close", daemon=True)
        closing.start()
        return closing

    def _shut_down(self) -> None:
        if self._client is not None:
            self._client.close()
        if self._cluster is not None:
            self._cluster.close()


@contextlib.contextmanager
def local_client(workers: int, plugin: Any | None = None) -> Iterator[Any]:
    """A ``dask.distributed`` client on a ``LocalCluster`` of ``workers`` single-threaded processes.

    Parameters
    ----------
    workers : int
        Number of worker processes.
    plugin : dask WorkerPlugin, optional
        Registered on every worker (e.g. to build the shared model once per process).
    """
    cluster = BackgroundCluster(workers, None if plugin is None else lambda: plugin)
    try:
        yield cluster.client()
    finally:
        cluster.close()


def map_ordered(
    fn: Callable[[T], R],
    items: Sequence[T],
    workers: int = 1,
    desc: str = "",
    progress: bool = True,
    on_result: Callable[[dict[int, R]], None] | None = None,
) -> list[R]:
    """``[fn(x) for x in items]``, on ``workers`` local processes when ``workers > 1``.

    Parameters
    ----------
    fn : callable
        A module-level (picklable) function of one argument.
    items : sequence
        Its arguments, one job each.
    workers : int
        1 runs the jobs here, one after the other; more starts a local Dask cluster.
    desc : str
        Label of the progress bar.
    progress : bool
        Show a progress bar over the jobs.
    on_result : callable, optional
        Called after every finished job with the results so far (``{index: result}``), e.g. to save a
        partial table that a long run can be watched through.

    Returns
    -------
    list
        The results in the order of ``items``. A job that raises stops the map with its exception.
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    done: dict[int, R] = {}
    bar = tqdm(total=len(items), desc=desc, disable=not progress)
    try:
        if workers == 1 or len(items) <= 1:
            for i, x in enumerate(items):
                done[i] = fn(x)
                bar.update()
                if on_result is not None:
                    on_result(done)
        else:
            from dask.distributed import as_completed

            with local_client(min(workers, len(items))) as client:
                futures = {client.submit(fn, x, pure=False): i for i, x in enumerate(items)}
                for fut in as_completed(list(futures)):
                    done[futures[fut]] = fut.result()
                    bar.update()
                    if on_result is not None:
                        on_result(done)
    finally:
        bar.close()
    return [done[i] for i in range(len(items))]


def available_cpus() -> int:
    """The CPUs this process may run on (its affinity where the platform says, else the CPU count)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except (AttributeError, OSError):
        return max(os.cpu_count() or 1, 1)


def fork_pool(workers: int) -> Any | None:
    """A ``multiprocessing`` pool of ``workers`` forked processes, or None where one cannot be had.

    The workers are forked now: they see this process's memory as it is at this call (module globals set
    before it, e.g. the data every job of the pool works on), so jobs pass only their own small arguments.
    None (the caller then runs its jobs here) for one worker, in a daemonic process (a Dask worker of
    :func:`local_client`, which may not have children and whose siblings already use the cores), or where
    the platform has no ``fork`` start method. SIGINT is ignored in the workers (Ctrl-C stays the parent's).
    """
    import multiprocessing as mp

    if workers <= 1 or mp.current_process().daemon or "fork" not in mp.get_all_start_methods():
        return None
    with sigint_ignored():
        return mp.get_context("fork").Pool(workers)


__all__ = ["BackgroundCluster", "available_cpus", "fork_pool", "local_client", "map_ordered"]

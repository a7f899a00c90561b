"""Independent jobs on a local Dask cluster: the one place the suite starts worker processes.

Campaigns (:mod:`maglev_ocp.campaign`) and the diagnosis self-checks
(:mod:`maglev_ocp.diagnosis.selftest`) both scale out over independent,
individually seeded jobs. :func:`local_client` starts the ``LocalCluster`` of
single-threaded worker processes (Ctrl-C stays the parent's: the workers
inherit an ignored SIGINT), and :func:`map_ordered` runs a function over a list
of arguments on it, in this process when ``workers == 1``. Results do not
depend on the number of workers: each job carries its own seed.
"""

from __future__ import annotations

import contextlib
import logging
import os
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
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise UserError("dask.distributed is not installed: pip install 'maglev-ocp[campaign]'") from None
    import dask

    # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers; a fixed trim threshold turns off glibc's
    # dynamic mmap threshold, so every array above 128 kB is mapped, page-faulted, zeroed and unmapped again:
    # the gap diagnosis (thousands of MB-sized products) ran 4 times slower in a worker than alone (one
    # dataset 15 -> 60 s; the same with the variable set in a plain process). Left unset, also where an
    # earlier cluster's nanny left it in this process's environment (Dask sets it there before spawning);
    # the BLAS thread limits (one thread per single-threaded worker) stay.
    no_trim = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
    with sigint_ignored(), dask.config.set(no_trim), _env_without("MALLOC_TRIM_THRESHOLD_"):
        # the worker processes inherit SIG_IGN: Ctrl-C is the client's (no worker tracebacks)
        cluster = LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=logging.ERROR
        )
    client = Client(cluster)
    try:
        if plugin is not None:
            client.register_plugin(plugin)
        yield client
    finally:
        client.close()
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


__all__ = ["local_client", "map_ordered"]

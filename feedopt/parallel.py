"""Chunks of samples on every core: a thread pool for the numpy-heavy per-chunk loops.

The deflection bound and the replay go over the path in chunks of samples (memory stays
bounded by a chunk). Each chunk is large numpy work (matrix products, ufuncs, sorts) that
releases the GIL, so threads run chunks side by side on several cores without copying
anything; each chunk writes only its own samples, so the result does not depend on the
number of threads or on the order in which chunks finish.

``FEEDOPT_THREADS`` sets the threads (``1``: everything in the caller); the default is the
number of cores this process may use.

The parallelism is ours (these threads, and the forked children of :mod:`feedopt.background`),
so a run keeps BLAS on one thread (:func:`single_threaded_blas`): OpenBLAS otherwise threads
each of our small matrix products and its threads spin between calls, taking the cores our
own threads and children need.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import TypeVar

from feedopt.errors import InputError

T = TypeVar("T")
R = TypeVar("R")

#: Environment variable that caps the worker threads of :func:`for_each_chunk`.
THREADS_ENV = "FEEDOPT_THREADS"


def worker_threads() -> int:
    """Threads for chunk loops: ``FEEDOPT_THREADS`` if set, else the usable cores.

    Raises
    ------
    InputError
        ``FEEDOPT_THREADS`` set to anything but a whole number >= 1.
    """
    value = os.environ.get(THREADS_ENV, "").strip()
    if value:
        if not value.isdigit() or int(value) < 1:
            raise InputError(f"environment variable {THREADS_ENV} is {value!r}; it must be a "
                             "whole number of threads >= 1 (1: no threads), or unset (every "
                             "core)")
        return int(value)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def for_each_chunk(work: Callable[[T], R], chunks: Iterable[T],
                   threads: int | None = None,
                   on_done: Callable[[R], None] | None = None) -> list[R]:
    """``[work(c) for c in chunks]``, the calls spread over ``threads`` threads.

    At most ``2 * threads`` chunks are in flight, so memory stays that of a few chunks. The
    first exception raised by ``work`` is raised here (after the running chunks end).
    ``on_done(result)`` is called in the caller's thread for each chunk, in order (a
    progress bar).
    """
    threads = worker_threads() if threads is None else max(1, threads)
    results: list[R] = []

    def keep(result: R) -> None:
        results.append(result)
        if on_done is not None:
            on_done(result)

    if threads == 1:
        for c in chunks:
            keep(work(c))
        return results
    with ThreadPoolExecutor(max_workers=threads, thread_name_prefix="feedopt-chunk") as pool:
        pending = []
        try:
            for c in chunks:
                pending.append(pool.submit(work, c))
                if len(pending) >= 2 * threads:
                    keep(pending.pop(0).result())
            while pending:
                keep(pending.pop(0).result())
        except BaseException:
            for f in pending:  # what has not started yet never will
                f.cancel()
            raise
    return results


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """BLAS and LAPACK on one thread inside the block (threadpoolctl); the previous thread
    counts are restored after it.

    The limit is the process's: blocks that overlap in several threads of one process (a
    Dask worker with several threads running sweep points) may leave BLAS on one thread
    after the last of them, which is what such a worker wants anyway.

    Measured on 2 cores, 1e5 samples (``benchmarks/bench_scale.py``): with OpenBLAS's two
    threads the run took 4.9-5.3 s and 5.6-6.1 CPU-s in the main process, on one thread
    4.3 s and 4.1-4.3 CPU-s: the products are small ((k, 6) x (6, 3 M) per chunk), so
    OpenBLAS's threads spent their time spinning, on cores that our chunk threads and
    children needed.
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def beside(function: Callable[[], R]) -> Callable[[], R]:
    """Start ``function()`` in a thread beside the caller when there are several worker
    threads (:func:`worker_threads`), else call it at once. Returns ``wait()``: its value, or
    its exception raised in the caller. The thread is a daemon: a caller that fails first
    does not wait for it at exit."""
    if worker_threads() == 1:
        value = function()
        return lambda: value
    box: dict[str, object] = {}

    def run() -> None:
        try:
            box["value"] = function()
        except BaseException as exc:  # noqa: BLE001 - re-raised in the caller by wait()
            box["error"] = exc

    thread = threading.Thread(target=run, name="feedopt-beside", daemon=True)
    thread.start()

    def wait() -> R:
        thread.join()
        if "error" in box:
            raise box["error"]  # type: ignore[misc]
        return box["value"]  # type: ignore[return-value]

    return wait

"""Where the points of a sweep are evaluated: this process, a local Dask cluster, or any
running Dask cluster.

:func:`dask_evaluator` starts a :class:`distributed.LocalCluster` (worker processes, one
thread each, as many as asked or as there are cores) or connects to ``scheduler``
(``tcp://host:8786``); the scenario bundle is sent to every worker once, points are submitted
a few per worker thread at a time and yielded as they finish (``as_completed``), so results
stream into the table and an interrupt loses at most the points in flight. A point whose
worker died (memory, a crash) is yielded as an ``error`` row, never lost.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
from collections.abc import Callable, Iterable, Iterator, Sequence

from feedopt.errors import InputError
from feedopt.sweep.bundle import Bundle
from feedopt.sweep.grid import Axis, Number
from feedopt.sweep.point import PointResult, PointSettings, error_result, evaluate_point

#: Points in flight per worker thread: enough to keep workers busy between results.
IN_FLIGHT_PER_THREAD = 2


def evaluate_serial(bundle: Bundle, axes: Sequence[Axis], points: Iterable[Sequence[Number]],
                    settings: PointSettings) -> Iterator[PointResult]:
    """Evaluate the points one after the other in this process."""
    for values in points:
        yield evaluate_point(bundle, axes, values, settings)


def _worker_ready(laws: Sequence[str]) -> str:
    """Run on each worker before any point: import the pipeline and the laws' modules (toppra,
    cvxpy, ...) once, so points do not pay for them; report the version."""
    import feedopt
    import feedopt.runner  # noqa: F401 - the heavy imports, once per worker
    from feedopt.schedule.laws import LAWS

    for law in laws:
        LAWS[law].plan_function()
    return feedopt.__version__


@contextlib.contextmanager
def _client(scheduler: str | None, workers: int | None):
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="15s")
        except (OSError, ValueError, TypeError) as exc:
            raise InputError(f"--scheduler {scheduler}: cannot connect to a Dask scheduler "
                             f"there ({exc}); start one (dask scheduler) or leave --scheduler "
                             "out for a local cluster") from None
        with client:
            yield client
        return
    n = workers or os.cpu_count() or 1
    with _sigint_ignored():
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=logging.ERROR)
    with cluster, Client(cluster) as client:
        yield client


@contextlib.contextmanager
def _sigint_ignored():
    """SIGINT ignored while the worker processes start: they keep an inherited SIG_IGN (Python
    installs its KeyboardInterrupt handler only over the default), so a Ctrl-C at the terminal
    reaches this process alone, which then shuts them down. A Ctrl-C during these seconds of
    start-up is lost; the next one works."""
    try:
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _check_workers(client, scheduler: str | None, laws: Sequence[str]) -> int:
    """Worker threads of the cluster; InputError if it has none or runs another feedopt."""
    import feedopt

    client.wait_for_workers(1, timeout=60)
    try:
        versions = client.run(_worker_ready, list(laws))
    except Exception as exc:  # noqa: BLE001 - anything a worker raises on import
        raise InputError(f"--scheduler {scheduler}: the workers cannot import feedopt "
                         f"({type(exc).__name__}: {exc}); install feedopt "
                         f"{feedopt.__version__} in the workers' environment") from None
    other = {v for v in versions.values() if v != feedopt.__version__}
    if other:
        raise InputError(f"--scheduler {scheduler}: workers run feedopt {', '.join(other)}, "
                         f"this is {feedopt.__version__}; install the same version on both")
    return sum(client.nthreads().values())


@contextlib.contextmanager
def dask_evaluator(bundle: Bundle, axes: Sequence[Axis], settings: PointSettings,
                   scheduler: str | None = None, workers: int | None = None
                   ) -> Iterator[Callable[[Iterable[Sequence[Number]]], Iterator[PointResult]]]:
    """A Dask cluster, ready: yields ``evaluate(points)``, which yields each point's result
    as it finishes.

    Parameters
    ----------
    scheduler
        Address of a running scheduler (``tcp://host:8786``); None starts a local cluster.
    workers
        Worker processes of the local cluster (default: the number of cores).

    Raises
    ------
    InputError
        No scheduler at ``scheduler``, or its workers cannot run this feedopt.
    """
    with _client(scheduler, workers) as client:
        threads = _check_workers(client, scheduler, settings.laws)
        shipped = client.scatter(bundle, broadcast=True, hash=False)

        def evaluate(points: Iterable[Sequence[Number]]) -> Iterator[PointResult]:
            return _stream(client, shipped, axes, points, settings, threads)

        yield evaluate


def _stream(client, shipped, axes: Sequence[Axis], points: Iterable[Sequence[Number]],
            settings: PointSettings, threads: int) -> Iterator[PointResult]:
    from distributed import as_completed

    todo = iter(points)
    pending: dict = {}
    queue = as_completed()

    def submit(count: int) -> None:
        for values in todo:
            future = client.submit(evaluate_point, shipped, axes, tuple(values), settings,
                                   pure=False)
            pending[future] = tuple(values)
            queue.add(future)
            count -= 1
            if count <= 0:
                return

    submit(IN_FLIGHT_PER_THREAD * max(threads, 1))
    try:
        for future in queue:
            values = pending.pop(future)
            try:
                result = future.result()
            except Exception as exc:  # noqa: BLE001 - a lost worker is a row, not a crash
                result = error_result(values, exc)
            future.release()
            submit(1)
            yield result
    finally:
        for future in pending:
            future.cancel()


@contextlib.contextmanager
def evaluator(bundle: Bundle, axes: Sequence[Axis], settings: PointSettings,
              scheduler: str | None = None, workers: int | None = None
              ) -> Iterator[Callable[[Iterable[Sequence[Number]]], Iterator[PointResult]]]:
    """:func:`dask_evaluator`, or this process for ``workers == 0``."""
    if workers == 0 and scheduler is None:
        yield lambda points: evaluate_serial(bundle, axes, points, settings)
        return
    with dask_evaluator(bundle, axes, settings, scheduler, workers) as evaluate:
        yield evaluate

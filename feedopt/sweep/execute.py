"""Where the points of a sweep are evaluated: this process, a local Dask cluster, or any
running Dask cluster.

:func:`dask_evaluator` starts a :class:`distributed.LocalCluster` (worker processes, one
thread each: as many as asked, at most one per usable core and one per point) or connects to
``scheduler`` (``tcp://host:8786``); points are submitted a few per worker thread at a time
and yielded as they finish, so results stream into the table and an interrupt loses at most
the points in flight.

Surviving the cluster:

- The scenario bundle is a task of its own (:func:`_bundle`, its data held by the scheduler
  in the task's definition), not scattered data: when every worker holding it dies (or a
  one-worker cluster restarts), the scheduler computes it again on a live worker instead of
  cancelling every point that needs it ("lost dependencies"). It costs what scattering did:
  the triangle slot's bundle is 12 KB pickled, ~2 ms of Dask overhead per point either way
  (2.8 ms when sent with every task). A point whose worker died is computed again by Dask;
  one whose workers keep dying (Dask's ``allowed-failures``) is an ``error`` row.
- Losing the scheduler (the connection closes, it stops answering for :data:`PING_TIMEOUT_S`,
  after :data:`PING_S` without a result, or the cluster has had no worker for
  :data:`NO_WORKERS_S`) raises :class:`ClusterLost` (at once when the connection closes),
  never a hang: the sweep stops with what it has, to be resumed.
- The local cluster's workers ignore SIGINT, SIGTERM and SIGHUP (a Ctrl-C or a ``kill`` of the
  whole process group reaches this process alone, which shuts them down without tracebacks);
  a SIGTERM or SIGHUP that arrives while the cluster starts is acted on once it has started
  (a Ctrl-C then is lost: the starting workers must inherit its SIG_IGN).
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue
import signal
import time
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence

from feedopt.errors import FeedoptError, InputError
from feedopt.sweep.bundle import Bundle
from feedopt.sweep.grid import Axis, Number
from feedopt.sweep.point import PointResult, PointSettings, error_result, evaluate_point

#: Points in flight per worker thread: enough to keep workers busy between results.
IN_FLIGHT_PER_THREAD = 2
#: Seconds between checks of the cluster while no point finishes.
POLL_S = 0.5
#: Silence (no point finished) after which the scheduler is asked whether it is alive [s].
PING_S = 10.0
#: A scheduler that does not answer within this is taken as lost [s].
PING_TIMEOUT_S = 10.0
#: A cluster without any worker for this long is taken as lost [s].
NO_WORKERS_S = 60.0
#: Time allowed to close the client and the local cluster [s].
CLOSE_TIMEOUT_S = 10.0
_STOP_SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")
#: ``evaluate(points)``: yields each point's result as it finishes.
Evaluate = Callable[[Iterable[Sequence[Number]]], Iterator[PointResult]]


class ClusterLost(FeedoptError):
    """The Dask scheduler (or every worker) is gone; the message says which and where."""


def usable_cores() -> int:
    """Cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def local_workers(requested: int | None, points: int | None = None) -> int:
    """Worker processes of a local cluster: as requested (default: one per core), at most one
    per usable core (a point runs on one core; more processes only share the cores and add
    ~270 MB each) and one per point."""
    n = min(usable_cores() if requested is None else requested, usable_cores())
    return max(1, n if points is None else min(n, points))


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


def _bundle(bundle: Bundle) -> Bundle:
    """The bundle as a task's result: the scheduler keeps the task (and so the bundle) and
    computes it again on another worker when the workers holding it are lost."""
    return bundle


def _ignore_stop_signals() -> None:
    """In a local cluster's worker: leave SIGINT/SIGTERM/SIGHUP to the sweep's process."""
    import threading

    if threading.current_thread() is threading.main_thread():
        for name in _STOP_SIGNALS:
            signal.signal(getattr(signal, name), signal.SIG_IGN)


def _quiet_worker_plugin():
    from distributed.diagnostics.plugin import WorkerPlugin

    class QuietWorker(WorkerPlugin):
        """Runs on every worker of the local cluster, also on those restarted later."""

        def setup(self, worker) -> None:
            _ignore_stop_signals()

    return QuietWorker()


@contextlib.contextmanager
def _signals_deferred():
    """While the local cluster starts: SIGINT ignored (the starting worker processes inherit
    the SIG_IGN, so a Ctrl-C at the terminal reaches this process alone); SIGTERM and SIGHUP
    recorded and raised again once the cluster has started (or failed to), so that stopping
    never tears down worker processes halfway through their start."""
    caught: list[int] = []
    try:
        previous = {signal.SIGINT: signal.signal(signal.SIGINT, signal.SIG_IGN)}
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    for name in _STOP_SIGNALS[1:]:
        sig = getattr(signal, name, None)
        if sig is not None:
            previous[sig] = signal.signal(sig, lambda signum, _frame: caught.append(signum))
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if caught:
            signal.raise_signal(caught[0])


def _close_quietly(closeable) -> None:
    """Close a client or cluster within :data:`CLOSE_TIMEOUT_S`, whatever state it is in."""
    with contextlib.suppress(Exception):
        closeable.close(timeout=CLOSE_TIMEOUT_S)


@contextlib.contextmanager
def _quiet_dask_logs():
    """Dask's own log lines (worker restarts, lost connections, shutdown) kept out of the
    console: the sweep reports what became of each point and why it stopped. asyncio's too:
    a stop while Dask talks to its workers leaves "exception was never retrieved" lines."""
    import distributed  # noqa: F401 - its import sets the levels of its loggers

    names = ["distributed", "asyncio"] + [n for n in list(logging.root.manager.loggerDict)
                                          if n.startswith(("distributed.", "asyncio."))]
    logs = [logging.getLogger(name) for name in names]  # Dask sets some children's levels
    levels = [log.level for log in logs]
    for log in logs:
        log.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for log, level in zip(logs, levels, strict=True):
            log.setLevel(level)


@contextlib.contextmanager
def _client(scheduler: str | None, workers: int):
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="15s")
        except (OSError, ValueError, TypeError) as exc:
            raise InputError(f"--scheduler {scheduler}: cannot connect to a Dask scheduler "
                             f"there ({exc}); start one (dask scheduler) or leave --scheduler "
                             "out for a local cluster") from None
        try:
            yield client
        finally:
            _close_quietly(client)
        return
    cluster = client = None
    try:
        with _signals_deferred():
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=":0", silence_logs=logging.CRITICAL)
            client = Client(cluster)
            client.register_plugin(_quiet_worker_plugin(), name="feedopt-quiet-worker")
        yield client
    finally:
        for closeable in (client, cluster):
            if closeable is not None:
                _close_quietly(closeable)


def _check_workers(client, scheduler: str | None, laws: Sequence[str]) -> int:
    """Worker threads of the cluster; InputError if it has none or runs another feedopt."""
    import feedopt

    watch = _Watch(client, scheduler or "the local cluster")
    try:
        client.wait_for_workers(1, timeout=60)
    except TimeoutError:
        raise InputError(f"--scheduler {scheduler}: no Dask worker joined that scheduler "
                         "within 60 s; start some (dask worker ADDRESS)") from None
    except Exception:
        watch.check()  # the scheduler went away
        raise
    try:
        versions = client.run(_worker_ready, list(laws))
    except Exception as exc:  # noqa: BLE001 - anything a worker raises on import
        watch.check()
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
                   scheduler: str | None = None, workers: int | None = None,
                   points: int | None = None) -> Iterator[Evaluate]:
    """A Dask cluster, ready: yields ``evaluate(points)``, which yields each point's result
    as it finishes.

    Parameters
    ----------
    scheduler
        Address of a running scheduler (``tcp://host:8786``); None starts a local cluster.
    workers, points
        Worker processes asked for the local cluster (default: one per core) and points to
        evaluate: :func:`local_workers` of them are started.

    Raises
    ------
    InputError
        No scheduler at ``scheduler``, or its workers cannot run this feedopt.
    ClusterLost
        (from ``evaluate``) the scheduler or every worker was lost.
    """
    with _quiet_dask_logs(), _client(scheduler, local_workers(workers, points)) as client:
        threads = _check_workers(client, scheduler, settings.laws)
        with warnings.catch_warnings():  # a large bundle: sent once, on purpose
            warnings.simplefilter("ignore", UserWarning)
            shipped = client.submit(_bundle, bundle, pure=False)
        watch = _Watch(client, scheduler or "the local cluster")

        def evaluate(todo: Iterable[Sequence[Number]]) -> Iterator[PointResult]:
            return _stream(client, watch, shipped, axes, todo, settings, threads)

        yield evaluate


class _Watch:
    """Tells when the cluster is lost: :meth:`check` raises :class:`ClusterLost`."""

    def __init__(self, client, where: str) -> None:
        self.client, self.where = client, where
        self.heard = time.monotonic()  # last sign of life (a result, an answer)
        self.workerless_since: float | None = None

    def alive(self) -> None:
        self.heard = time.monotonic()

    def check(self) -> None:
        if self.client.status != "running":
            raise ClusterLost(f"lost the connection to the Dask scheduler ({self.where})")
        now = time.monotonic()
        if now - self.heard < PING_S:
            return
        try:
            info = self.client.sync(self.client.scheduler.identity, n_workers=-1,
                                    callback_timeout=PING_TIMEOUT_S)
        except Exception:  # noqa: BLE001 - a timeout, a closed connection: the same to us
            raise ClusterLost(f"the Dask scheduler ({self.where}) did not answer within "
                              f"{PING_TIMEOUT_S:.0f} s") from None
        self.heard = now
        if info.get("workers"):
            self.workerless_since = None
        elif self.workerless_since is None:
            self.workerless_since = now
        elif now - self.workerless_since > NO_WORKERS_S:
            raise ClusterLost(f"the Dask cluster ({self.where}) has had no worker for "
                              f"{NO_WORKERS_S:.0f} s")


def _outcome(future, values: tuple[Number, ...], watch: _Watch) -> PointResult:
    """The result of a finished future; ClusterLost if it ended with the connection."""
    try:
        return future.result(timeout=PING_TIMEOUT_S)
    except Exception as exc:  # noqa: BLE001 - a lost worker is a row, not a crash
        watch.check()  # a future cancelled because the scheduler went away is not a row
        return error_result(values, exc)


def _stream(client, watch: _Watch, shipped, axes: Sequence[Axis],
            points: Iterable[Sequence[Number]], settings: PointSettings, threads: int
            ) -> Iterator[PointResult]:
    todo = iter(points)
    pending: dict = {}
    finished: queue.SimpleQueue = queue.SimpleQueue()  # filled by Dask's callback thread

    def submit(count: int) -> None:
        for values in todo:
            watch.check()
            future = client.submit(evaluate_point, shipped, axes, tuple(values), settings,
                                   pure=False)
            pending[future] = tuple(values)
            future.add_done_callback(finished.put)
            count -= 1
            if count <= 0:
                return

    try:
        submit(IN_FLIGHT_PER_THREAD * max(threads, 1))
        while pending:
            try:
                future = finished.get(timeout=POLL_S)
            except queue.Empty:
                watch.check()
                continue
            values = pending.pop(future, None)
            if values is None:
                continue
            result = _outcome(future, values, watch)
            watch.alive()
            future.release()
            submit(1)
            yield result
    finally:
        if pending and client.status == "running":
            with contextlib.suppress(Exception):
                client.cancel(list(pending))


@contextlib.contextmanager
def evaluator(bundle: Bundle, axes: Sequence[Axis], settings: PointSettings,
              scheduler: str | None = None, workers: int | None = None,
              points: int | None = None) -> Iterator[Evaluate]:
    """:func:`dask_evaluator`, or this process for ``workers == 0``."""
    if workers == 0 and scheduler is None:
        yield lambda todo: evaluate_serial(bundle, axes, todo, settings)
        return
    with dask_evaluator(bundle, axes, settings, scheduler, workers, points) as evaluate:
        yield evaluate

"""feedopt.parallel: order, exceptions and the thread count."""

import threading

import pytest

from feedopt.errors import InputError
from feedopt.parallel import beside, for_each_chunk, worker_threads
from tests.conftest import SCENARIOS


def test_results_in_order_on_several_threads() -> None:
    seen = set()

    def work(i: int) -> int:
        seen.add(threading.current_thread().name)
        return i * i

    assert for_each_chunk(work, range(40), threads=3) == [i * i for i in range(40)]
    assert all(name.startswith("feedopt-chunk") for name in seen)


def test_one_thread_runs_in_the_caller() -> None:
    names = for_each_chunk(lambda _i: threading.current_thread().name, range(3), threads=1)
    assert names == [threading.current_thread().name] * 3


def test_the_first_exception_is_raised_and_later_chunks_do_not_start() -> None:
    started = []

    def work(i: int) -> int:
        started.append(i)
        if i == 2:
            raise ValueError("chunk 2")
        return i

    with pytest.raises(ValueError, match="chunk 2"):
        for_each_chunk(work, range(1000), threads=2)
    assert len(started) < 1000


def test_thread_count_from_the_environment(monkeypatch) -> None:
    monkeypatch.setenv("FEEDOPT_THREADS", "3")
    assert worker_threads() == 3
    monkeypatch.delenv("FEEDOPT_THREADS")
    assert worker_threads() >= 1  # the usable cores


@pytest.mark.parametrize("value", ["0", "-2", "two", "1.5"])
def test_a_bad_thread_count_is_refused_by_name(monkeypatch, value: str) -> None:
    from feedopt.errors import InputError

    monkeypatch.setenv("FEEDOPT_THREADS", value)
    with pytest.raises(InputError, match=f"FEEDOPT_THREADS is '{value}'; it must be a whole"):
        worker_threads()


def _blas_threads() -> list[int]:
    import numpy  # noqa: F401 - loads numpy's BLAS
    from threadpoolctl import threadpool_info

    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


def test_single_threaded_blas_inside_and_restored_after() -> None:
    from threadpoolctl import threadpool_limits

    from feedopt.parallel import single_threaded_blas

    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        with single_threaded_blas():
            assert _blas_threads() and set(_blas_threads()) == {1}
        assert _blas_threads() == before


def test_a_run_plans_with_single_threaded_blas(monkeypatch, tmp_path) -> None:
    """The stages of a run see one BLAS thread (run_scenario's block), and after the run
    the caller's setting is back."""
    from threadpoolctl import threadpool_limits

    from feedopt import runner
    from feedopt.errors import InputError

    seen = []

    def stop(*_a, **_k):
        seen.append(_blas_threads())
        raise InputError("stop here")

    monkeypatch.setattr(runner, "prepare", stop)
    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        with pytest.raises(InputError, match="stop here"):
            runner.run_scenario(SCENARIOS / "triangle_slot.yaml", out_dir=tmp_path / "out",
                                report=False, progress=lambda _m: None)
        assert _blas_threads() == before
    assert seen and set(seen[0]) == {1}
    assert not (tmp_path / "out").exists()


def test_beside_runs_in_a_thread_while_the_caller_goes_on(monkeypatch):
    monkeypatch.setenv("FEEDOPT_THREADS", "2")
    go = threading.Event()

    def waits_for_the_caller() -> str:
        assert go.wait(10), "the caller never ran beside this function"
        return "done"

    wait = beside(waits_for_the_caller)
    go.set()  # only reached because beside returned before the function ended
    assert wait() == "done"


def test_beside_raises_the_functions_error_in_the_caller(monkeypatch):
    monkeypatch.setenv("FEEDOPT_THREADS", "2")

    def fails() -> None:
        raise InputError("unreachable sample 7")

    wait = beside(fails)
    with pytest.raises(InputError, match="sample 7"):
        wait()


def test_beside_on_one_thread_calls_at_once(monkeypatch):
    monkeypatch.setenv("FEEDOPT_THREADS", "1")
    calls = []
    wait = beside(lambda: calls.append(threading_name()) or 5)
    assert calls == [threading_name()]  # called in the caller, before beside returned
    assert wait() == 5


def threading_name() -> str:
    return threading.current_thread().name

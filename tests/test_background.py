"""feedopt.background: forked children, started at once or early (prestart), their results
on disk, their failures and their cancellation."""

import os
import sys
from pathlib import Path

import pytest

from feedopt import background

pytestmark = pytest.mark.skipif(not background.fork_available(), reason="needs os.fork")


def _write(path: Path, text: str) -> None:
    path.write_text(text)


def _fail(message: str) -> None:
    raise ValueError(message)


def _warm_marker(path: Path):
    def warm_up() -> None:
        path.write_text(str(os.getpid()))
    return warm_up


def test_started_child_writes_and_joins(tmp_path: Path) -> None:
    target = tmp_path / "out.txt"
    background.start(lambda: _write(target, "drawn"), "writing").join()
    assert target.read_text() == "drawn"


def test_prestarted_child_warms_up_then_runs_the_task_it_is_sent(tmp_path: Path) -> None:
    warm, target = tmp_path / "warm.txt", tmp_path / "out.txt"
    worker = background.prestart(_warm_marker(warm), "writing")
    big = "x" * (3 << 20)  # more than a pipe holds: the sender thread must not block us
    worker.submit(_write, target, big)
    worker.join()
    assert target.read_text() == big
    assert int(warm.read_text()) != os.getpid()  # the warm-up ran in the child


def test_prestarted_child_without_a_task_leaves_quietly(tmp_path: Path) -> None:
    warm = tmp_path / "warm.txt"
    worker = background.prestart(_warm_marker(warm), "writing")
    worker.join()  # no task: nothing raised, nothing written but the warm-up
    assert warm.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["warm.txt"]
    worker.join(cancel=True)  # a second join is harmless


def test_prestarted_task_failure_names_the_task_and_the_error() -> None:
    worker = background.prestart(lambda: None, "drawing the report")
    worker.submit(_fail, "no fonts")
    with pytest.raises(background.BackgroundFailed, match="drawing the report failed: "
                                                          "ValueError: no fonts"):
        worker.join()


def test_failed_warm_up_is_reported_when_joined() -> None:
    worker = background.prestart(lambda: _fail("matplotlib missing"), "drawing the report")
    worker.submit(_write, Path("/nonexistent/never"), "x")
    with pytest.raises(background.BackgroundFailed, match="matplotlib missing"):
        worker.join()


def test_cancelled_child_is_killed_and_writes_nothing(tmp_path: Path) -> None:
    import time

    target = tmp_path / "late.txt"

    def slow_warm_up() -> None:
        time.sleep(30)

    worker = background.prestart(slow_warm_up, "writing")
    worker.submit(_write, target, "too late")
    t0 = time.perf_counter()
    worker.join(cancel=True)
    assert time.perf_counter() - t0 < 10
    assert not target.exists()


def test_the_value_comes_back_and_the_child_s_own_exception_on_request() -> None:
    from feedopt.errors import InputError

    assert background.start(lambda: {"rows": [1.5, 2.5]}, "adding").join() == {
        "rows": [1.5, 2.5]}
    worker = background.prestart(lambda: None, "planning")
    worker.submit(divmod, 7, 2)
    assert worker.join() == (3, 1)

    def bad_input() -> None:
        raise InputError("sample 3: feed 9 mm/s above 4 mm/s")

    with pytest.raises(InputError, match="sample 3: feed 9 mm/s"):
        background.start(bad_input, "planning").join(reraise=True)
    with pytest.raises(background.BackgroundFailed, match="planning failed: InputError"):
        background.start(bad_input, "planning").join()


def test_cancelling_a_child_does_not_wait_for_its_own_child(tmp_path: Path) -> None:
    """A child that forked one more (the report renders half its figures in a grandchild):
    cancelling it returns at once, and a nested child's answer still comes back."""
    import time

    def nested() -> str:
        inner = background.start(lambda: (time.sleep(3.0), "inner")[1], "sleeping")
        return inner.join()

    assert background.start(nested, "nesting").join() == "inner"
    child = background.start(nested, "nesting")
    time.sleep(0.3)  # the grandchild is asleep by now
    t0 = time.perf_counter()
    assert child.join(cancel=True) is None
    assert time.perf_counter() - t0 < 1.5


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/status")
def test_release_free_heap_returns_freed_small_arrays_to_the_system():
    """Freed arrays below the mmap threshold stay resident in the heap until trimmed."""
    import re

    import numpy as np

    from feedopt.background import release_free_heap

    def rss_mb() -> float:
        status = open("/proc/self/status").read()
        return int(re.search(r"VmRSS:\s+(\d+)", status).group(1)) / 1024

    arrays = [np.ones(8000) for _ in range(6_000)]  # 64 kB each, 384 MB in the heap
    keep = arrays[-1]  # the heap's top stays in use: only a trim returns what lies below
    held = rss_mb()
    del arrays
    before = rss_mb()
    release_free_heap()
    after = rss_mb()
    assert keep.sum() == 8000.0
    assert before > held - 50  # freeing alone returned (almost) nothing
    assert after < before - 250

"""Sweeps on a real Dask cluster that loses its workers or its scheduler (issue 26, items 12
and 13), and a local cluster stopped by SIGTERM (item 7): separate ``dask scheduler`` and
``dask worker`` processes started here and killed by PID mid-sweep."""

from __future__ import annotations

import json
import os
import signal
import time

import pytest

from feedopt.sweep import Execution, SweepSettings, run_sweep
from tests.sweep.cluster import (
    POINTS,
    SWEEP_ARGS,
    Processes,
    children,
    data_rows,
    group_alive,
    wait_for,
    without_time,
    workers_of,
)

pytestmark = pytest.mark.skipif(not hasattr(os, "killpg"), reason="POSIX process groups")


@pytest.fixture
def procs(tmp_path):
    started = Processes(tmp_path)
    try:
        yield started
    finally:
        started.stop_all()


@pytest.fixture
def scenario(quick_scenario):
    return quick_scenario("triangle_slot")


@pytest.fixture
def reference(scenario, tmp_path):
    """The same sweep in this process, without Dask: the rows every cluster run must give."""
    run_sweep(scenario, [SWEEP_ARGS[-1]], out_dir=tmp_path / "serial",
              settings=SweepSettings(laws=["constant", "jerk"], spacing_mm=1.0),
              execution=Execution(workers=0, progress=False))
    return without_time(data_rows(tmp_path / "serial"))


def _sigkill(pid: int) -> None:
    os.kill(pid, signal.SIGKILL)


def test_the_scenario_data_survives_the_loss_of_every_worker_holding_it(procs, scenario,
                                                                        reference, tmp_path):
    _, address, file = procs.scheduler("scheduler")
    first = procs.worker(file, "first", nanny=False)
    wait_for(lambda: workers_of(address) == 1, 30, "the first worker")
    out = tmp_path / "sweep"
    sweep = procs.feedopt(["sweep", str(scenario), *SWEEP_ARGS, "--scheduler", address,
                           "--out", str(out)], "sweep")
    wait_for(lambda: len(data_rows(out)) >= 3, 40, "the first rows")
    _sigkill(first.pid)  # the only worker: it held the scenario data and points in flight
    kept = len(data_rows(out))
    assert kept < POINTS
    # a one-worker cluster that restarts: a new worker with a nanny, whose worker is killed too
    second = procs.worker(file, "second", nanny=True)
    wait_for(lambda: len(data_rows(out)) >= kept + 3, 40, "rows from the new worker")
    worker_child = wait_for(lambda: children(second.pid), 10, "the nanny's worker process")
    _sigkill(worker_child[0])  # the nanny starts a fresh one, without the data
    assert sweep.wait(timeout=40) == 0, procs.log("sweep")
    log = procs.log("sweep")
    assert f"{POINTS} points ({POINTS} evaluated now, 0 from the earlier table): {POINTS} " \
           "planned" in log and "0 internal errors" in log, log
    assert "Traceback" not in log and "Cancelled" not in log, log
    rows = without_time(data_rows(out))
    assert rows == reference  # in grid order, every number identical to the serial run
    assert json.loads((out / "best.json").read_text())["point"] == {"cut.axial_depth_mm": 1.0}


def test_a_killed_scheduler_stops_the_sweep_and_it_resumes_on_a_new_one(procs, scenario,
                                                                        reference, tmp_path):
    old, address, file = procs.scheduler("scheduler")
    procs.worker(file, "worker", nanny=True)
    wait_for(lambda: workers_of(address) == 1, 30, "the worker")
    out = tmp_path / "sweep"
    args = ["sweep", str(scenario), *SWEEP_ARGS, "--out", str(out)]
    sweep = procs.feedopt([*args, "--scheduler", address], "sweep")
    wait_for(lambda: len(data_rows(out)) >= 3, 40, "the first rows")
    _sigkill(old.pid)
    killed = time.monotonic()
    code = sweep.wait(timeout=30)
    took = time.monotonic() - killed
    log = procs.log("sweep")
    kept = data_rows(out)
    assert code == 3, log
    assert took < 15, took  # the connection's end is seen at once; closing is bounded
    assert f"stopped (lost the connection to the Dask scheduler ({address}))" in log, log
    assert f"keeps {len(kept)} of {POINTS} points: run the same command again" in log, log
    assert "Traceback" not in log and "bug in feedopt" not in log, log
    assert 3 <= len(kept) < POINTS and {r["status"] for r in kept} == {"ok"}
    assert all(row in reference for row in without_time(kept))  # in the order they finished
    assert not (out / "best.json").exists()

    # resumed on a new scheduler (another address): only the missing points are evaluated
    _, new_address, new_file = procs.scheduler("new-scheduler")
    procs.worker(new_file, "new-worker", nanny=True)
    resumed = procs.feedopt([*args, "--scheduler", new_address], "resumed")
    assert resumed.wait(timeout=50) == 0, procs.log("resumed")
    log = procs.log("resumed")
    assert (f"{POINTS} points ({POINTS - len(kept)} evaluated now, {len(kept)} from the "
            "earlier table)") in log, log
    assert without_time(data_rows(out)) == reference
    assert json.loads((out / "best.json").read_text())["value"] == float(
        reference[0]["t_star_s"])


def test_sigterm_to_a_local_cluster_sweep_stops_cleanly(procs, scenario, tmp_path):
    out = tmp_path / "sweep"
    args = ["sweep", str(scenario), *SWEEP_ARGS, "--out", str(out), "--workers", "1000"]
    sweep = procs.feedopt(args, "sweep")
    wait_for(lambda: len(data_rows(out)) >= 2, 40, "the first rows")
    os.killpg(sweep.pid, signal.SIGTERM)  # the whole group, workers too, as systemd or timeout
    assert sweep.wait(timeout=30) == 128 + signal.SIGTERM
    log = procs.log("sweep")
    kept = len(data_rows(out))
    assert "--workers 1000: this process may use" in log
    assert f"stopped (SIGTERM); {out / 'sweep.csv'} keeps {kept} of {POINTS} points" in log, log
    assert log.count("\n") == 2 and "Traceback" not in log and "distributed" not in log, log
    wait_for(lambda: not group_alive(sweep.pid), 10, "the worker processes to end")
    assert not (out / "best.json").exists()


def test_a_frozen_scheduler_stops_the_sweep_within_a_bounded_time(procs, scenario, tmp_path):
    from feedopt.sweep.execute import CLOSE_TIMEOUT_S, PING_S, PING_TIMEOUT_S

    frozen, address, file = procs.scheduler("scheduler")
    procs.worker(file, "worker", nanny=True)
    wait_for(lambda: workers_of(address) == 1, 30, "the worker")
    out = tmp_path / "sweep"
    sweep = procs.feedopt(["sweep", str(scenario), *SWEEP_ARGS, "--out", str(out),
                           "--scheduler", address], "sweep")
    wait_for(lambda: len(data_rows(out)) >= 3, 40, "the first rows")
    os.kill(frozen.pid, signal.SIGSTOP)  # its connections stay open: nothing ever arrives
    stopped = time.monotonic()
    bound_s = PING_S + PING_TIMEOUT_S + CLOSE_TIMEOUT_S + 5
    assert sweep.wait(timeout=bound_s) == 3, procs.log("sweep")
    assert time.monotonic() - stopped > PING_S  # it waited for the silence, then asked
    log = procs.log("sweep")
    kept = len(data_rows(out))
    assert (f"stopped (the Dask scheduler ({address}) did not answer within "
            f"{PING_TIMEOUT_S:.0f} s); {out / 'sweep.csv'} keeps {kept} of {POINTS}") in log, log
    assert "Traceback" not in log, log

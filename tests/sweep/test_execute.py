"""How many local worker processes a sweep starts (issue 26, item 7a)."""

from __future__ import annotations

import os

import pytest

from feedopt.cli import main
from feedopt.sweep import execute


def test_workers_are_capped_at_the_usable_cores_and_the_points(monkeypatch):
    monkeypatch.setattr(os, "sched_getaffinity", lambda _pid: {0, 1, 2}, raising=False)
    assert execute.usable_cores() == 3
    assert execute.local_workers(1000, 2) == 2
    assert execute.local_workers(1000, 50) == 3
    assert execute.local_workers(None, None) == 3
    assert execute.local_workers(None, 1) == 1
    assert execute.local_workers(2, 50) == 2


@pytest.mark.parametrize("workers", ["-1", "-1000"])
def test_negative_workers_are_refused(quick_scenario, tmp_path, capsys, workers):
    scenario = quick_scenario("triangle_slot")
    out = tmp_path / "sweep"
    assert main(["sweep", str(scenario), "--grid", "cut.axial_depth_mm=1.5", "--workers",
                 workers, "--out", str(out)]) == 2
    assert f"--workers {workers}: give a number of local worker processes >= 0" in \
        capsys.readouterr().err
    assert not out.exists()


def test_the_watch_pings_a_live_scheduler_and_gives_up_on_a_workerless_cluster():
    import logging

    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=":0",
                      silence_logs=logging.CRITICAL) as cluster, Client(cluster) as client:
        watch = execute._Watch(client, "the test cluster")
        watch.heard -= execute.PING_S + 1  # silent for long: it asks the scheduler
        watch.check()  # a live scheduler with a worker: no verdict
        assert watch.workerless_since is None and watch.heard > 0
        client.retire_workers()
        watch.heard -= execute.PING_S + 1
        watch.check()  # no worker yet for long: still waiting
        assert watch.workerless_since is not None
        watch.heard -= execute.PING_S + 1
        watch.workerless_since -= execute.NO_WORKERS_S + 1
        with pytest.raises(execute.ClusterLost, match="the test cluster.* no worker for 60 s"):
            watch.check()
    with pytest.raises(execute.ClusterLost, match="lost the connection"):
        watch.check()  # the client is closed

"""Real Dask processes for the sweep's cluster tests: a scheduler and workers started with the
``dask`` command of this environment, each in a session of its own, stopped by its PID (and
its process group: a nanny's worker child) in :meth:`Processes.stop_all`."""

from __future__ import annotations

import contextlib
import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

BIN = Path(sys.executable).parent
FEEDOPT = str(BIN / "feedopt")
DASK = str(BIN / "dask")
#: The tiny sweep of these tests: triangle slot at 1 mm, two fast laws, 30 points.
SWEEP_ARGS = ["--spacing-mm", "1", "--laws", "constant,jerk", "--no-progress",
              "--grid", "cut.axial_depth_mm=1.0:3.9:0.1"]
POINTS = 30


def wait_for(predicate, timeout_s: float, what: str, step_s: float = 0.05):
    """Poll ``predicate`` until it returns something true; AssertionError after the timeout."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(step_s)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def data_rows(folder: Path) -> list[dict]:
    """The complete rows of a sweep's table (none if it does not exist yet)."""
    try:
        text = (folder / "sweep.csv").read_text(encoding="utf-8")
    except FileNotFoundError:
        return []
    text = text[: text.rfind("\n") + 1]
    return list(csv.DictReader(text.splitlines()))


def without_time(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "seconds"} for r in rows]


class Processes:
    """The processes a test started; :meth:`stop_all` kills every one of them by PID."""

    def __init__(self, tmp: Path) -> None:
        self.tmp = tmp
        self.started: list[subprocess.Popen] = []

    def start(self, args: list[str], name: str) -> subprocess.Popen:
        log = open(self.tmp / f"{name}.log", "w")  # noqa: SIM115 - closed with the process
        proc = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT,
                                start_new_session=True, cwd=self.tmp)
        log.close()
        self.started.append(proc)
        return proc

    def scheduler(self, name: str) -> tuple[subprocess.Popen, str, Path]:
        """A scheduler on a free port of 127.0.0.1: the process, its address, its file."""
        file = self.tmp / f"{name}.json"
        proc = self.start([DASK, "scheduler", "--host", "127.0.0.1", "--port", "0",
                           "--no-dashboard", "--scheduler-file", str(file)], name)
        wait_for(lambda: file.exists() and file.stat().st_size > 0, 30, f"{name} to start")
        address = wait_for(lambda: _address(file), 10, f"{name}'s address")
        return proc, address, file

    def worker(self, scheduler_file: Path, name: str, nanny: bool) -> subprocess.Popen:
        """One worker process (one thread), with or without a nanny."""
        args = [DASK, "worker", "--scheduler-file", str(scheduler_file), "--nworkers", "1",
                "--nthreads", "1", "--no-dashboard", "--name", name]
        return self.start(args + ([] if nanny else ["--no-nanny"]), name)

    def feedopt(self, args: list[str], name: str) -> subprocess.Popen:
        return self.start([FEEDOPT, *args], name)

    def log(self, name: str) -> str:
        return (self.tmp / f"{name}.log").read_text()

    def stop_all(self) -> None:
        for proc in self.started:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(proc.pid, signal.SIGKILL)  # its own session: itself and its children
        for proc in self.started:
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=10)


def _address(file: Path) -> str | None:
    try:
        return json.loads(file.read_text())["address"]
    except (ValueError, KeyError, OSError):
        return None


def workers_of(address: str) -> int:
    """Workers the scheduler at ``address`` knows (a short-lived client)."""
    from distributed import Client

    with Client(address, timeout="10s") as client:
        return len(client.scheduler_info(n_workers=-1)["workers"])


def children(pid: int) -> list[int]:
    """Direct children of ``pid`` (Linux)."""
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        with contextlib.suppress(OSError):
            found += [int(c) for c in (task / "children").read_text().split()]
    return found


def group_alive(pgid: int) -> list[int]:
    """Processes of group ``pgid`` that are not zombies."""
    alive = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        with contextlib.suppress(OSError, IndexError, ValueError):
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            if int(fields[2]) == pgid and fields[0] != "Z":
                alive.append(int(entry.name))
    return alive

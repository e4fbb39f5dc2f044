"""Run one function in a forked child process while the caller goes on.

Used by the runner to draw the report (matplotlib, ~1-2 s) while the exporters format the
controller files, which halves the output stage on two cores. The child is a fork: it shares
everything the parent has computed (copy on write), imports nothing again and pickles
nothing. Where ``os.fork`` is not safe (not Linux) the function simply runs in the caller.

The child's exception is reported to the parent as :class:`BackgroundFailed` (with the
child's message) when the parent joins; a parent that is itself failing (an exception, Ctrl-C,
SIGTERM) kills the child before it removes the staging folder the child writes into.
"""

from __future__ import annotations

import os
import signal
import sys
import traceback
from collections.abc import Callable
from dataclasses import dataclass


class BackgroundFailed(RuntimeError):
    """The background function raised; the message is the child's exception."""


@dataclass
class Background:
    """A started background call: :meth:`join` waits for it (or kills it)."""

    what: str
    pid: int | None = None
    read_fd: int | None = None

    def join(self, cancel: bool = False) -> None:
        """Wait for the child; with ``cancel`` kill it first. Raises BackgroundFailed if the
        child's function raised (not when cancelled)."""
        if self.pid is None:
            return
        pid, self.pid = self.pid, None
        if cancel:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        chunks = []
        while True:
            chunk = os.read(self.read_fd, 65536)
            if not chunk:
                break
            chunks.append(chunk)
        os.close(self.read_fd)
        _, status = os.waitpid(pid, 0)
        if not cancel and status != 0:
            message = b"".join(chunks).decode("utf-8", "replace").strip()
            raise BackgroundFailed(f"{self.what} failed: {message or f'exit status {status}'}")


def fork_available() -> bool:
    """True where a forked child can run numpy and matplotlib safely (Linux)."""
    return hasattr(os, "fork") and sys.platform.startswith("linux")


def start(function: Callable[[], None], what: str) -> Background:
    """Call ``function()`` in a forked child (or here, at once, where fork is unavailable)."""
    if not fork_available():
        function()
        return Background(what)
    sys.stdout.flush()
    sys.stderr.flush()
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: run, report, leave without the parent's exit handlers
        code = 0
        try:
            os.close(read_fd)
            for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
                signal.signal(sig, signal.SIG_DFL)  # the parent decides; this may just die
            function()
        except BaseException as exc:  # noqa: BLE001 - everything goes to the parent
            code = 1
            text = f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"
            os.write(write_fd, text.encode("utf-8", "replace"))
        finally:
            os._exit(code)
    os.close(write_fd)
    return Background(what, pid, read_fd)

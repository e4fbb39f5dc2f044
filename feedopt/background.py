"""Run one function in a forked child process while the caller goes on.

Used by the runner to draw the report (matplotlib, ~1-2 s) while the exporters format the
controller files, which halves the output stage on two cores. The child is a fork: it shares
everything the parent has computed (copy on write), imports nothing again and pickles
nothing. Where ``os.fork`` is not safe (not Linux) the function simply runs in the caller.

The child's exception is reported to the parent as :class:`BackgroundFailed` (with the
child's message) when the parent joins; a parent that is itself failing (an exception, Ctrl-C,
SIGTERM) kills the child before it removes the staging folder the child writes into.

:func:`prestart` forks the child early, lets it import what its task needs (matplotlib for the
report, ~0.5 s) while the parent plans on the other core, and sends it the task later: the
task's function and arguments then go through a pipe, pickled.
"""

from __future__ import annotations

import ctypes
import os
import pickle
import signal
import sys
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


class BackgroundFailed(RuntimeError):
    """The background function raised; the message is the child's exception."""


@dataclass
class Background:
    """A started background call: :meth:`join` waits for it (or kills it) and returns the
    function's value."""

    what: str
    pid: int | None = None
    read_fd: int | None = None
    result: Any = None  # the value, where the function ran in the caller

    def join(self, cancel: bool = False, reraise: bool = False) -> Any:
        """Wait for the child; with ``cancel`` kill it first (and return None). Returns the
        function's value. If it raised: :class:`BackgroundFailed` with the child's message,
        or with ``reraise`` the child's own exception where it could be pickled."""
        if self.pid is None:
            return self.result
        pid, self.pid = self.pid, None
        if cancel:  # no answer wanted: do not wait for the pipe's end
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            os.close(self.read_fd)
            os.waitpid(pid, 0)
            return None
        chunks = []
        while True:
            chunk = os.read(self.read_fd, 1 << 20)
            if not chunk:
                break
            chunks.append(chunk)
        os.close(self.read_fd)
        _, status = os.waitpid(pid, 0)
        try:
            kind, value, text = pickle.loads(b"".join(chunks))
        except Exception:  # noqa: BLE001 - a child that died before it could answer
            kind, value, text = "failed", None, f"exit status {status}"
        if kind == "ok" and status == 0:
            return value
        if reraise and value is not None:
            raise value
        raise BackgroundFailed(f"{self.what} failed: {text}")


def fork_available() -> bool:
    """True where a forked child can run numpy and matplotlib safely (Linux)."""
    return hasattr(os, "fork") and sys.platform.startswith("linux")


def start(function: Callable[[], Any], what: str) -> Background:
    """Call ``function()`` in a forked child (or here, at once, where fork is unavailable)."""
    if not fork_available():
        return Background(what, result=function())
    return _fork(function, what, ())


#: In a forked child, the write end of the pipe its answer goes to. A child that forks one
#: more closes it there, so that the pipe's reader sees its end when the child itself ends
#: (a cancelled child's own children do not hold it open).
_ANSWER_FD: int | None = None


def release_free_heap() -> None:
    """Give the heap that Python and numpy have freed back to the system (glibc's
    ``malloc_trim``; nothing elsewhere). A child forked afterwards does not share those
    pages, and the run's resident memory is what it holds: on the 70k-line raster the
    parent's 1321 MB at the output stage are 1077 MB after it."""
    try:
        libc = ctypes.CDLL(None)
        trim = libc.malloc_trim
    except (OSError, AttributeError):  # not glibc
        return
    trim(0)


def _fork(function: Callable[[], Any], what: str, close_in_child: tuple[int, ...]
          ) -> Background:
    global _ANSWER_FD
    release_free_heap()
    sys.stdout.flush()
    sys.stderr.flush()
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: run, report, leave without the parent's exit handlers
        code = 0
        try:
            os.close(read_fd)
            for fd in close_in_child + ((_ANSWER_FD,) if _ANSWER_FD is not None else ()):
                os.close(fd)
            _ANSWER_FD = write_fd
            for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
                signal.signal(sig, signal.SIG_DFL)  # the parent decides; this may just die
            answer = pickle.dumps(("ok", function(), ""), protocol=pickle.HIGHEST_PROTOCOL)
        except BaseException as exc:  # noqa: BLE001 - everything goes to the parent
            code = 1
            text = f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"
            try:
                answer = pickle.dumps(("raised", exc, text))
                pickle.loads(answer)  # an exception that cannot be rebuilt goes as text
            except Exception:  # noqa: BLE001
                answer = pickle.dumps(("raised", None, text))
        try:
            view = memoryview(answer)
            while view:
                view = view[os.write(write_fd, view):]
        finally:
            os._exit(code)
    os.close(write_fd)
    return Background(what, pid, read_fd)


@dataclass
class Prestarted:
    """A forked child that has imported what its task needs and waits for the task.

    :meth:`submit` sends the task (a module-level function and its arguments, pickled, from a
    thread so that the caller never waits for the child); :meth:`join` waits for it like
    :meth:`Background.join`. A child that is never sent a task ends when joined (or
    cancelled) without doing anything.
    """

    what: str
    child: Background | None = None
    task_fd: int | None = None
    sender: threading.Thread | None = None

    result: Any = None  # the value, where fork is unavailable

    def submit(self, function: Callable[..., Any], *args) -> None:
        """Send ``function(*args)`` to the child (where fork is unavailable: call it here)."""
        if self.child is None:
            self.result = function(*args)
            return
        payload = pickle.dumps((function, args), protocol=pickle.HIGHEST_PROTOCOL)
        fd, self.task_fd = self.task_fd, None

        def send() -> None:
            try:
                view = memoryview(payload)
                while view:
                    view = view[os.write(fd, view):]
            except OSError:  # the child is gone: its join says why
                pass
            finally:
                os.close(fd)

        self.sender = threading.Thread(target=send, name=f"sending {self.what}", daemon=True)
        self.sender.start()

    def join(self, cancel: bool = False, reraise: bool = False) -> Any:
        """Wait for the task and return its value (see :meth:`Background.join`); a child
        that was sent no task ends (None)."""
        if self.task_fd is not None:  # never submitted: end of input tells the child to leave
            os.close(self.task_fd)
            self.task_fd = None
        value = self.result
        if self.child is not None:
            child, self.child = self.child, None
            try:
                value = child.join(cancel, reraise)
            finally:
                if self.sender is not None:
                    self.sender.join()
        return value


def prestart(warm_up: Callable[[], None], what: str) -> Prestarted:
    """Fork a child that runs ``warm_up()`` (imports) at once, then the task that
    :meth:`Prestarted.submit` sends it. Where fork is unavailable, nothing is started and the
    task runs in the caller when submitted."""
    if not fork_available():
        return Prestarted(what)
    task_read, task_write = os.pipe()

    def child() -> Any:
        warm_up()
        chunks = []
        while chunk := os.read(task_read, 1 << 20):
            chunks.append(chunk)
        if chunks:
            function, args = pickle.loads(b"".join(chunks))
            return function(*args)
        return None

    started = _fork(child, what, (task_write,))
    os.close(task_read)
    return Prestarted(what, started, task_write)

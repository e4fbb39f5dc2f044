"""Headless Chromium driven over the DevTools protocol through a pipe (stdlib only).

Loads a local page with every host blocked and records what a reader's browser would show
wrong: console errors and warnings, uncaught exceptions, requests that leave the file (any
URL that is not ``file:``, ``data:``, ``blob:`` or ``about:``); evaluates JavaScript in the
page; takes full-page screenshots. Used by ``tests/report/test_browser.py`` and
``benchmarks/report_screenshots.py``. Chromium is optional: ``apt-get install chromium``.

    with Chromium(find_chromium()) as browser:
        page = browser.load(Path("report.html"), width_px=1400)
        print(page_problems(page), browser.evaluate(page, "document.title"))
        browser.screenshot(page, Path("report.png"))
"""

from __future__ import annotations

import base64
import json
import os
import select
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

#: Executable names tried in order by :func:`find_chromium`.
CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
#: URL schemes that do not leave the machine (a ``file:`` URL other than the page's own is
#: still a problem: the page is no longer one file).
LOCAL_SCHEMES = ("file:", "data:", "blob:", "about:")
#: Flags of the browser: headless, no sandbox (root in a container), WebGL in software
#: (plotly's 3D scenes), no background traffic of the browser itself, every host unresolvable.
FLAGS = (
    "--headless=new", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader", "--hide-scrollbars", "--mute-audio",
    "--no-first-run", "--no-default-browser-check", "--disable-extensions",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--disable-default-apps", "--disable-dev-shm-usage",
    "--host-resolver-rules=MAP * ~NOTFOUND", "--remote-debugging-pipe",
)


def find_chromium() -> str | None:
    """Path of the first Chromium/Chrome executable on PATH (:data:`CANDIDATES`), or None."""
    return next((p for p in map(shutil.which, CANDIDATES) if p is not None), None)


@dataclass
class Page:
    """One loaded page: its DevTools session and what it did while loading and since.

    ``console``: (level, text) of every console call and log entry (levels: ``error``,
    ``warning``, ``info``, ...); ``exceptions``: uncaught exceptions and rejected promises;
    ``requests``: every URL the page asked for (local ones included)."""

    session: str
    url: str
    console: list[tuple[str, str]] = field(default_factory=list)
    exceptions: list[str] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)


def page_problems(page: Page) -> list[str]:
    """What is wrong with a page meant to be one self-contained file: console errors,
    uncaught exceptions, requests that leave the machine and loads of other local files
    (empty: none)."""
    errors = [f"console {level}: {text}" for level, text in page.console
              if level in ("error", "assert")]
    thrown = [f"uncaught: {text}" for text in page.exceptions]
    remote = [f"external request: {url}" for url in page.requests
              if not url.startswith(LOCAL_SCHEMES)]
    other = [f"loads another file: {url}" for url in page.requests
             if url.startswith("file:") and url != page.url]
    return errors + thrown + remote + other


def _console_text(params: dict) -> str:
    return " ".join(str(a.get("value", a.get("description", a.get("type", ""))))
                    for a in params.get("args", []))


def _exception_text(params: dict) -> str:
    details = params.get("exceptionDetails", {})
    exc = details.get("exception", {})
    return f"{details.get('text', '')} {exc.get('description', exc.get('value', ''))}".strip()


def _record(page: Page, method: str, params: dict) -> None:
    """File one DevTools event of ``page`` under console / exceptions / requests."""
    if method == "Runtime.consoleAPICalled":
        page.console.append((params.get("type", "log"), _console_text(params)))
    elif method == "Runtime.exceptionThrown":
        page.exceptions.append(_exception_text(params))
    elif method == "Log.entryAdded":
        entry = params.get("entry", {})
        page.console.append((entry.get("level", "info"), entry.get("text", "")))
    elif method == "Network.requestWillBeSent":
        page.requests.append(params.get("request", {}).get("url", ""))


class BrowserError(RuntimeError):
    """Chromium did not answer, answered with an error, or a page did not settle in time."""


class Chromium:
    """A headless Chromium process (a fresh profile in a temporary folder), as a context
    manager; :meth:`load` opens pages, :meth:`evaluate` and :meth:`screenshot` use them."""

    def __init__(self, binary: str, timeout_s: float = 60.0) -> None:
        self.binary, self.timeout_s = binary, timeout_s
        self._next_id = 0
        self._buffer = b""
        self._pages: dict[str, Page] = {}
        self._events: list[tuple[str, str]] = []  # (session, method) of Page.* events

    def __enter__(self) -> Chromium:
        self._profile = tempfile.TemporaryDirectory(prefix="feedopt-chromium-",
                                                    ignore_cleanup_errors=True)
        to_child, self._write_fd = os.pipe()
        self._read_fd, from_child = os.pipe()

        def _wire() -> None:  # in the child: the protocol's pipe is fds 3 (in) and 4 (out)
            import fcntl
            high_in = fcntl.fcntl(to_child, fcntl.F_DUPFD, 10)
            high_out = fcntl.fcntl(from_child, fcntl.F_DUPFD, 10)
            os.dup2(high_in, 3)
            os.dup2(high_out, 4)

        args = [self.binary, *FLAGS, f"--user-data-dir={self._profile.name}", "about:blank"]
        self._proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL, preexec_fn=_wire,
                                      close_fds=False)
        os.close(to_child)
        os.close(from_child)
        return self

    def __exit__(self, *exc) -> None:
        try:
            self.send("Browser.close")
        except (BrowserError, OSError):
            pass
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        os.close(self._write_fd)
        os.close(self._read_fd)
        self._profile.cleanup()

    def _read_message(self, deadline: float) -> dict:
        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._read_fd], [], [], left)[0]:
                raise BrowserError(f"no answer from {self.binary} within {self.timeout_s} s")
            chunk = os.read(self._read_fd, 1 << 20)
            if not chunk:
                raise BrowserError(f"{self.binary} closed the DevTools pipe (exit status "
                                   f"{self._proc.poll()})")
            self._buffer += chunk
        raw, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(raw)

    def _dispatch(self, message: dict) -> None:
        session, method = message.get("sessionId", ""), message.get("method", "")
        params = message.get("params", {})
        if session in self._pages:
            _record(self._pages[session], method, params)
        if method.startswith("Page."):
            self._events.append((session, method))

    def send(self, method: str, params: dict | None = None, session: str = "") -> dict:
        """Call one DevTools method (on ``session``'s page if given) and return its result;
        events that arrive meanwhile are recorded on their pages."""
        self._next_id += 1
        msg = {"id": self._next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._write_fd, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + self.timeout_s
        while True:
            answer = self._read_message(deadline)
            if answer.get("id") != self._next_id:
                self._dispatch(answer)
                continue
            if "error" in answer:
                raise BrowserError(f"{method}: {answer['error'].get('message', answer)}")
            return answer.get("result", {})

    def _wait_event(self, session: str, method: str) -> None:
        deadline = time.monotonic() + self.timeout_s
        while True:
            if (session, method) in self._events:
                self._events = [e for e in self._events if e != (session, method)]
                return
            self._dispatch(self._read_message(deadline))

    def load(self, path: Path, width_px: int = 1400, height_px: int = 1000) -> Page:
        """Open ``path`` in a new tab of ``width_px`` x ``height_px`` CSS pixels and wait
        for its load event; the page records console, exceptions and requests from the start."""
        target = self.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.send("Target.attachToTarget",
                            {"targetId": target, "flatten": True})["sessionId"]
        url = Path(path).resolve().as_uri()
        page = self._pages[session] = Page(session, url)
        for domain in ("Runtime", "Log", "Network", "Page"):
            self.send(f"{domain}.enable", session=session)
        self.resize(page, width_px, height_px)
        self._events = [e for e in self._events if e[0] != session]  # about:blank's
        self.send("Page.navigate", {"url": url}, session=session)
        self._wait_event(session, "Page.loadEventFired")
        if not self.wait_until(page, f"location.href === {json.dumps(url)} && "
                                     "document.readyState === 'complete'", self.timeout_s):
            raise BrowserError(f"{url} did not load within {self.timeout_s} s")
        self.settle(page)
        return page

    def settle(self, page: Page, wait_ms: int = 100) -> None:
        """Let the page run ``wait_ms`` and two frames (late errors, rejected promises and
        re-layouts arrive meanwhile and are recorded)."""
        self.evaluate(page, f"new Promise(r => setTimeout(() => requestAnimationFrame(() => "
                            f"requestAnimationFrame(r)), {wait_ms}))")

    def resize(self, page: Page, width_px: int, height_px: int) -> None:
        """Set the page's viewport to ``width_px`` x ``height_px`` CSS pixels (scale 1)."""
        self.send("Emulation.setDeviceMetricsOverride",
                  {"width": width_px, "height": height_px, "deviceScaleFactor": 1,
                   "mobile": False}, session=page.session)

    def evaluate(self, page: Page, expression: str):
        """The value of a JavaScript expression in the page (promises awaited)."""
        result = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                                "awaitPromise": True}, session=page.session)
        if "exceptionDetails" in result:
            raise BrowserError(f"{expression!r} threw: {_exception_text(result)}")
        return result.get("result", {}).get("value")

    def wait_until(self, page: Page, expression: str, timeout_s: float = 20.0,
                   poll_s: float = 0.1) -> bool:
        """Poll a JavaScript expression until it is truthy; False if it never was in time."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.evaluate(page, expression):
                return True
            time.sleep(poll_s)
        return False

    def screenshot(self, page: Page, png: Path, max_height_px: int = 16000) -> tuple[int, int]:
        """Write a PNG of the whole page (its full height, at most ``max_height_px``) at the
        current viewport width; returns (width, height) in pixels."""
        width = int(self.evaluate(page, "document.documentElement.clientWidth"))
        height = int(self.evaluate(page, "document.documentElement.scrollHeight"))
        height = max(1, min(height, max_height_px))
        self.resize(page, width, height)
        self.settle(page)
        shot = self.send("Page.captureScreenshot", {"format": "png"}, session=page.session)
        Path(png).write_bytes(base64.b64decode(shot["data"]))
        return width, height

    def clip(self, page: Page, box: list[float]) -> bytes:
        """PNG bytes of the page's region ``box`` = [left, top, width, height] (CSS px, page
        coordinates, also below the viewport)."""
        x, y, w, h = box
        clip = {"x": x, "y": y, "width": max(w, 1), "height": max(h, 1), "scale": 1}
        shot = self.send("Page.captureScreenshot", {"format": "png", "clip": clip,
                                                    "captureBeyondViewport": True},
                         session=page.session)
        return base64.b64decode(shot["data"])


#: JavaScript: one record per plotly graph of the page (``.js-plotly-plot``): laid out, its SVG
#: layers, whether it has a 3D (WebGL) scene, its canvases, and where it and its largest
#: canvas sit on the page [CSS px].
_PLOTLY_PROBE = """[...document.querySelectorAll('.js-plotly-plot')].map(d => {
  const box = e => { const r = e.getBoundingClientRect();
    return [r.left + scrollX, r.top + scrollY, r.width, r.height]; };
  const fl = d._fullLayout, canvases = [...d.querySelectorAll('canvas')];
  const big = canvases.sort((a, b) => b.width * b.height - a.width * a.height)[0];
  return {id: d.id, laid_out: !!fl, svg: d.querySelectorAll('.main-svg').length,
          gl3d: !!(fl && fl._has && fl._has('gl3d')), canvases: canvases.length,
          traces: (d.data || []).length, box: box(d), canvas_box: big ? box(big) : null,
          no_webgl: d.textContent.includes('WebGL is not supported')};
})"""
#: JavaScript: how many inline scripts of the body call Plotly.newPlot (one per figure).
_PLOT_SCRIPTS = ("[...document.body.querySelectorAll('script')]"
                 ".filter(s => s.text.includes('Plotly.newPlot(')).length")


def sideways_overflow_px(browser: Chromium, page: Page) -> int:
    """How far the page scrolls sideways at its viewport width [CSS px] (0: it fits)."""
    return int(browser.evaluate(page, "document.documentElement.scrollWidth - "
                                      "document.documentElement.clientWidth"))


def plotly_figures(browser: Chromium, page: Page, timeout_s: float = 20.0) -> list[dict]:
    """The page's plotly graphs (see :data:`_PLOTLY_PROBE`) once every figure script of the
    body has drawn (or ``timeout_s`` passed: then the records show what is missing)."""
    ready = (f"(() => {{ const f = {_PLOTLY_PROBE}; return f.length >= {_PLOT_SCRIPTS} && "
             "f.every(g => g.laid_out && g.svg > 0 && (!g.gl3d || g.canvases > 0)); })()")
    browser.wait_until(page, ready, timeout_s=timeout_s)
    browser.settle(page, wait_ms=300)
    return browser.evaluate(page, _PLOTLY_PROBE)

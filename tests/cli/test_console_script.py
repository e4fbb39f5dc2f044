"""The installed ``feedopt`` script leaves through os._exit (feedopt.cli.console_main): its
exit codes, its flushed output and a reader that hangs up early are what they were."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FEEDOPT = Path(sys.executable).parent / "feedopt"
if not FEEDOPT.exists():  # tests run with another interpreter: the repository's venv
    FEEDOPT = ROOT / ".venv" / "bin" / "feedopt"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(FEEDOPT), *args], capture_output=True, text=True, timeout=300)


def test_output_is_flushed_and_the_exit_code_is_main_s() -> None:
    ok = _run("validate", str(ROOT / "scenarios" / "triangle_slot.yaml"))
    assert ok.returncode == 0, ok.stderr
    assert ok.stdout.rstrip().endswith("laws constant, thesis, topp, convex, jerk")
    bad = _run("validate", str(ROOT / "scenarios" / "no_such_scenario.yaml"))
    assert bad.returncode == 2
    assert "no_such_scenario.yaml" in bad.stderr and "Traceback" not in bad.stderr


class _ClosedPipe:
    """A stdout whose reader has gone: every flush raises BrokenPipeError."""

    def write(self, text: str) -> int:
        return len(text)

    def flush(self) -> None:
        raise BrokenPipeError(32, "Broken pipe")


def test_a_reader_that_hangs_up_before_the_last_flush(monkeypatch) -> None:
    """Like ``feedopt ... | head -1``: the final flush meets a closed pipe; the exit code is
    still main's and nothing is raised."""
    from feedopt import cli

    exits, ran = [], []
    monkeypatch.setattr(cli, "main", lambda: 3)
    monkeypatch.setattr(cli.atexit, "_run_exitfuncs", lambda: ran.append(True))
    monkeypatch.setattr(cli.os, "_exit", exits.append)
    monkeypatch.setattr(cli.sys, "stdout", _ClosedPipe())
    cli.console_main()
    assert exits == [3] and ran == [True]

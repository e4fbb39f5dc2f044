"""The ``feedopt`` command: a thin dispatcher over :mod:`feedopt.commands`.

Every module in ``feedopt.commands`` exposes ``add_parser(subparsers)``, which registers one
subcommand whose ``func(args) -> int`` does the work. This module owns the exit codes:
0 ok, 2 bad input (:class:`feedopt.errors.InputError`, argparse errors), 1 internal error,
128 + N when stopped by signal N (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP), as shells report it.
"""

from __future__ import annotations

import argparse
import atexit
import importlib
import os
import pkgutil
import signal
import sys
import traceback

from feedopt import __version__, commands
from feedopt.errors import InputError, Terminated

# Order in --help (module names); modules not listed here are appended alphabetically.
_ORDER = ["run", "validate", "sweep", "compare", "path", "engagement", "forces", "calibrate",
          "calibrate_stiffness", "robot", "robot_init", "stream", "rsi_sim"]


def _command_modules() -> list[str]:
    names = [m.name for m in pkgutil.iter_modules(commands.__path__) if not m.name.startswith("_")]
    return sorted(names, key=lambda n: (_ORDER.index(n) if n in _ORDER else len(_ORDER), n))


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="feedopt",
        description=(
            "Plan the fastest C2 feed-rate schedule for robotic milling that keeps the "
            "robot's predicted static deflection under a limit, verify it, and export it "
            "for KUKA RSI."
        ),
    )
    parser.add_argument("--version", action="version", version=f"feedopt {__version__}")
    parser.add_argument(
        "--debug", action="store_true", help="show the Python traceback of internal errors"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _command_modules():
        importlib.import_module(f"feedopt.commands.{name}").add_parser(sub)
    return parser


def _terminate(signum: int, _frame: object) -> None:
    # One is enough: ignore repeats while the unwinding cleans up.
    signal.signal(signum, signal.SIG_IGN)
    raise Terminated(signal.Signals(signum).name, signum)


def _install_signal_handlers() -> dict[int, object]:
    """SIGTERM and SIGHUP unwind like Ctrl-C, so staging folders are removed; returns the
    previous handlers (nothing is installed outside the main thread)."""
    previous: dict[int, object] = {}
    for name in ("SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is None:
            continue
        try:
            previous[sig] = signal.signal(sig, _terminate)
        except ValueError:  # not the main thread (embedded use): leave signals alone
            break
    return previous


#: Commands written as two words, as their parser is registered (``feedopt robot init``).
_TWO_WORDS = {("robot", "init"): "robot-init"}


def _two_word_commands(argv: list[str]) -> list[str]:
    """``argv`` with a two-word command (:data:`_TWO_WORDS`) joined into its parser's name.
    (A robot directory named ``init`` is then written ``./init``.)"""
    first = next((i for i, a in enumerate(argv) if not a.startswith("-")), None)
    if first is not None and tuple(argv[first:first + 2]) in _TWO_WORDS:
        return [*argv[:first], _TWO_WORDS[tuple(argv[first:first + 2])], *argv[first + 2:]]
    return argv


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``feedopt`` console script; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(_two_word_commands(sys.argv[1:] if argv is None else list(argv)))
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        print("\nfeedopt: error: give a command (see the list above)", file=sys.stderr)
        return 2
    previous = _install_signal_handlers()
    try:
        return _dispatch(args)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def console_main() -> None:
    """The ``feedopt`` console script: :func:`main`, then leave without tearing the interpreter
    down. After a run, freeing every module and array of numpy, scipy, cvxpy and pinocchio
    one by one takes about 0.3 s of a 4 s run; the process ends anyway. What must happen at
    exit still does: the ``atexit`` handlers run and stdout/stderr are flushed, then
    ``os._exit`` with main's exit code."""
    code = main()
    try:
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):  # a closed pipe (`| head`) or stream: nothing to add
                pass
        os._exit(code)


def printable(text: str) -> str:
    """``text`` with control characters (but newlines and tabs) shown as escapes: a file
    name or value quoted in a message must not drive the terminal (colours, cursor moves)."""
    return "".join(c if c in "\n\t" or (c.isprintable() and c != "\x7f")
                   else repr(c)[1:-1] for c in text)


def _dispatch(args: argparse.Namespace) -> int:
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"feedopt {args.command}: error: {printable(str(exc))}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into `head` and the like: not an error
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - silence the flush at exit
        return 0
    except KeyboardInterrupt:
        print("feedopt: interrupted (SIGINT); nothing was written", file=sys.stderr)
        return 128 + signal.SIGINT
    except Terminated as exc:
        print(f"feedopt: terminated ({exc.signal_name}); nothing was written", file=sys.stderr)
        return 128 + exc.signal_number
    except Exception as exc:  # noqa: BLE001 - the one place that turns bugs into exit code 1
        if args.debug:
            traceback.print_exc()
        print(
            f"feedopt {args.command}: internal error: {type(exc).__name__}: "
            f"{printable(str(exc))}\n"
            "This is a bug in feedopt; rerun with --debug for the traceback.",
            file=sys.stderr,
        )
        return 1


if __name__ == "__main__":  # pragma: no cover
    # Like the console script: ``os._exit`` with main's code. (``sys.exit`` lets the
    # interpreter end itself by SIGINT when a Ctrl-C once passed through code that a C
    # extension ran with ``PyRun_String``, even though main caught it and returned 130.)
    console_main()

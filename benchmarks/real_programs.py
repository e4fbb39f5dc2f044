"""What ``feedopt path`` does with a folder of G-code programs written by others.

    python benchmarks/real_programs.py FOLDER [FOLDER ...] [--out results.md] [--timeout 120]

Runs ``feedopt path PROGRAM --spacing 1`` on every program under the folders (``.nc``,
``.ngc``, ``.tap``, ``.gcode``, ``.cnc``, ``.mpf``, ``.eia``, ``.iso``), each in its own
process with a time limit, and prints a Markdown table: the program, the exit code, the wall
time and the first line feedopt printed (the path summary, or the refusal with its line and
word), then a count of programs by outcome and of refusals by their cause (the refusal's text
with numbers, quoted words and file names folded, so that one cause is one row).

The programs are not in this repository (most public CAM examples are GPL: LinuxCNC's
``nc_files``, CAMotics' ``examples``, bCNC's ``tests``); fetch them and point this at the
folder. Issue 27 tracks the reader's coverage of real programs with this table.
"""

from __future__ import annotations

import argparse
import collections
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

SUFFIXES = {".nc", ".ngc", ".tap", ".gcode", ".cnc", ".mpf", ".eia", ".iso"}


@dataclass(frozen=True)
class Outcome:
    """One program's result: exit code (None: timed out), wall time [s], first message line."""

    program: Path
    code: int | None
    wall_s: float
    message: str


def programs(folders: list[Path]) -> list[Path]:
    """Every G-code program under ``folders``, sorted."""
    found = [p for f in folders for p in f.rglob("*")
             if p.is_file() and p.suffix.lower() in SUFFIXES]
    return sorted(found)


def run_one(program: Path, timeout_s: float) -> Outcome:
    """``feedopt path PROGRAM --spacing 1`` in a child process."""
    cmd = [sys.executable, "-m", "feedopt.cli", "path", str(program), "--spacing", "1"]
    t0 = time.perf_counter()
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s,
                              check=False)
    except subprocess.TimeoutExpired:
        return Outcome(program, None, time.perf_counter() - t0, f"timed out ({timeout_s:g} s)")
    wall = time.perf_counter() - t0
    text = (done.stderr if done.returncode else done.stdout).strip().splitlines()
    return Outcome(program, done.returncode, wall, text[0] if text else "")


def cause(message: str) -> str:
    """A refusal with its specifics folded: one row per kind of refusal."""
    text = re.sub(r"^feedopt path: (error|internal error): ", "", message)
    text = re.sub(r"^\S+\.(nc|ngc|tap|gcode|cnc|mpf|eia|iso)\b:?", "PROGRAM:", text, flags=re.I)
    text = re.sub(r"'[^']*'|\"[^\"]*\"", "'…'", text)
    # numbers folded, but not the G and M codes: they name the cause
    text = re.sub(r"(?<![GM\d.])[-+]?\d+(\.\d+)?(e[-+]?\d+)?", "#", text)
    return text[:140]


def _cell(text: str) -> str:
    """``text`` safe in a Markdown table cell."""
    return text.replace("|", "\\|")


def table(outcomes: list[Outcome], root: Path | None) -> str:
    """The Markdown report."""
    def name(p: Path) -> str:
        return str(p.relative_to(root)) if root is not None else str(p)

    rows = ["| program | exit | wall [s] | first line |", "|---|---:|---:|---|"]
    for o in outcomes:
        msg = _cell(o.message[:160])
        rows.append(f"| {name(o.program)} | {o.code if o.code is not None else '-'} | "
                    f"{o.wall_s:.1f} | {msg} |")
    read = sum(o.code == 0 for o in outcomes)
    rows += ["", f"read: {read} of {len(outcomes)}; refused (exit 2): "
             f"{sum(o.code == 2 for o in outcomes)}; internal error (exit 1): "
             f"{sum(o.code == 1 for o in outcomes)}; timed out: "
             f"{sum(o.code is None for o in outcomes)}", "", "| refusals | cause |", "|---:|---|"]
    causes = collections.Counter(cause(o.message) for o in outcomes if o.code not in (0,))
    rows += [f"| {n} | {_cell(c)} |" for c, n in causes.most_common()]
    return "\n".join(rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, help="write the Markdown table here too")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per program")
    args = ap.parse_args(argv)
    found = programs(args.folders)
    if not found:
        print(f"no G-code programs ({', '.join(sorted(SUFFIXES))}) under {args.folders}",
              file=sys.stderr)
        return 2
    outcomes = [run_one(p, args.timeout) for p in found]
    root = args.folders[0] if len(args.folders) == 1 else None
    report = table(outcomes, root)
    print(report, end="")
    if args.out is not None:
        args.out.write_text(report, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())

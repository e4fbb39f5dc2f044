"""What ``feedopt path`` and ``feedopt run`` do with a folder of G-code programs written by others.

    python benchmarks/real_programs.py FOLDER [FOLDER ...] [--out results.md] [--timeout 120]
        [--run benchmarks/real_programs_scenario.yaml] [--laws convex,programmed]
        [--tool TOOL.yaml] [--jobs 2]

Runs ``feedopt path PROGRAM --spacing 1`` on every program under the folders (``.nc``,
``.ngc``, ``.tap``, ``.gcode``, ``.gc``, ``.cnc``, ``.mpf``, ``.eia``, ``.iso``), each in its
own process with a time limit. With ``--run TEMPLATE`` it also runs ``feedopt run`` on a
scenario made from the template (a scenario YAML: ``path.file`` becomes the program, relative
file names are resolved against the template's folder, ``name`` becomes the program's) written
to a temporary folder, with ``--laws`` and ``--no-report`` to keep each run short, under the
same time limit (``--tool`` replaces the template's tool file in every run). The template's
``stock: {from_program: true}`` is used when the feedopt being measured supports it; otherwise
the stock is left out and ``FALLBACK_CUT`` (a 1 mm slot) is the engagement (the header says
which).

Prints a Markdown table: the program, its source (the first folder under the root), its
number of lines, then per command the exit code (``-``: timed out), the wall time and the
first line that says what happened (the path summary, the refusal with its line and word; for
a run the cycle time and verdict of every law from ``summary.json``); then the programs by
outcome, per source and overall, and the refusals by their cause (the message with numbers,
quoted words and file names folded, so that one cause is one row), for both commands.

The programs are not in this repository (see ``benchmarks/REAL_PROGRAMS_SOURCES.md``: most
public CAM examples are GPL); fetch them and point this at the folder. Issue 27 tracks the
reader's coverage of real programs with this table. The feedopt measured is the one
``python -m feedopt.cli`` imports (set ``PYTHONPATH`` to measure another checkout).
"""

from __future__ import annotations

import argparse
import collections
import copy
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import yaml

SUFFIXES = {".nc", ".ngc", ".tap", ".gcode", ".gc", ".cnc", ".mpf", ".eia", ".iso"}
#: Scenario fields holding file names, resolved against the template's folder.
FILE_FIELDS = (("robot", "directory"), ("tool",), ("material",), ("stock", "mesh"))
#: The engagement when the measured feedopt has no ``stock.from_program``: a 1 mm slot.
FALLBACK_CUT = {"type": "slot", "axial_depth_mm": 1.0}
MESSAGE_CHARS = 160
#: Children still running. Each has its own session (so that a time-out can stop its whole
#: process group), so Ctrl-C does not reach them: main stops them when interrupted.
_LIVE: set[subprocess.Popen] = set()
_LIVE_LOCK = threading.Lock()
_STOPPING = threading.Event()


@dataclass(frozen=True)
class Outcome:
    """One command's result: exit code (None: timed out), wall time [s], what it said."""

    code: int | None
    wall_s: float
    message: str


@dataclass(frozen=True)
class Row:
    """One program: where it is, its source, its line count and both commands' outcomes."""

    program: Path
    source: str
    lines: int
    path: Outcome
    run: Outcome | None


def programs(folders: list[Path]) -> list[Path]:
    """Every G-code program under ``folders``, sorted."""
    found = [p for f in folders for p in f.rglob("*")
             if p.is_file() and p.suffix.lower() in SUFFIXES]
    return sorted(found)


def _kill_group(proc: subprocess.Popen) -> None:
    """SIGTERM the child's process group (feedopt removes its staging folder), then SIGKILL."""
    for sig, wait_s in ((signal.SIGTERM, 10.0), (signal.SIGKILL, 10.0)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        try:
            proc.wait(timeout=wait_s)
            return
        except subprocess.TimeoutExpired:
            continue


def _execute(cmd: list[str], timeout_s: float) -> tuple[int | None, float, str, str]:
    """Exit code (None: timed out and killed), wall time, stdout and stderr of ``cmd``."""
    t0 = time.perf_counter()
    with _LIVE_LOCK:
        if _STOPPING.is_set():
            raise RuntimeError("the benchmark was interrupted")
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, start_new_session=True)
        _LIVE.add(proc)
    try:
        out, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        _kill_group(proc)
        out, err = proc.communicate()
        return None, time.perf_counter() - t0, out, err
    finally:
        with _LIVE_LOCK:
            _LIVE.discard(proc)
    return proc.returncode, time.perf_counter() - t0, out, err


def stop_children() -> None:
    """Start no more commands and stop the running ones (their process groups)."""
    with _LIVE_LOCK:
        _STOPPING.set()
        live = list(_LIVE)
    for proc in live:
        _kill_group(proc)


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def first_error(stderr: str, stdout: str) -> str:
    """The line that says why a command failed: the first ``error`` line of stderr (warnings
    and stage lines come before it), else its last ``feedopt <command>:`` verdict line, else
    stderr's first line, else stdout's last."""
    err = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    for ln in err:
        if re.match(r"^feedopt( \w[\w-]*)?: (internal )?error", ln) or "Traceback" in ln:
            return ln
    verdicts = [ln for ln in err if re.match(r"^feedopt( \w[\w-]*)?: ", ln)]
    if verdicts:
        return verdicts[-1]
    if err:
        return err[0]
    out = [ln.strip() for ln in stdout.splitlines() if ln.strip()]
    return out[-1] if out else ""


def short(message: str, program: Path) -> str:
    """``message`` with the program's full path written as its file name."""
    for full in {str(program.resolve()), str(program)}:
        message = message.replace(full, program.name)
    return message


def run_path(program: Path, timeout_s: float) -> Outcome:
    """``feedopt path PROGRAM --spacing 1`` in a child process."""
    cmd = [sys.executable, "-m", "feedopt.cli", "path", str(program), "--spacing", "1"]
    code, wall, out, err = _execute(cmd, timeout_s)
    if code is None:
        return Outcome(None, wall, f"timed out ({timeout_s:g} s)")
    if code == 0:
        lines = [ln.strip() for ln in out.splitlines() if ln.strip()]
        return Outcome(0, wall, short(lines[0] if lines else "", program))
    return Outcome(code, wall, short(first_error(err, out), program))


def supports_program_stock() -> bool:
    """Whether the feedopt ``python -m feedopt.cli`` imports knows ``stock.from_program``."""
    code = ("import feedopt.scenario as s; "
            "print('from_program' in s.StockSection.model_fields)")
    try:
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              check=False, timeout=120)
    except subprocess.TimeoutExpired:
        return False
    return done.stdout.strip() == "True"


def load_template(template: Path, tool: Path | None = None) -> dict:
    """The template scenario with its file names made absolute (against its folder); ``tool``
    (relative to the current folder) replaces its tool file."""
    data = yaml.safe_load(template.read_text(encoding="utf-8"))
    if not isinstance(data, dict) or not isinstance(data.get("path"), dict):
        raise SystemExit(f"{template}: not a scenario with a path section")
    if tool is not None:
        data["tool"] = str(tool.resolve())
    base = template.resolve().parent
    for keys in FILE_FIELDS:
        holder = data
        for k in keys[:-1]:
            holder = holder.get(k) if isinstance(holder, dict) else None
        if isinstance(holder, dict) and isinstance(holder.get(keys[-1]), str):
            holder[keys[-1]] = str((base / holder[keys[-1]]).resolve())
    return data


def program_tool(program: Path, template_tool: str, folder: Path) -> str | None:
    """A tool file for the cutter the program's tool comment names (a flat, ball or bull
    end mill with a diameter), written to ``folder``; None when the program cannot be read or
    names none of those with a diameter.

    The comment gives the diameter, shape and corner radius only: the teeth (2), helix
    (30 deg) and lengths are assumptions written into the file's ``source``; the rest is the
    template's tool.
    """
    from feedopt.errors import InputError
    from feedopt.gcode import read_gcode
    from feedopt.gcode.moves import ToolShape
    from feedopt.process.program_tool import header_for

    try:
        prog = read_gcode(program)
    except (InputError, OSError, ValueError):
        return None
    cutting = [m.tool for m in prog.moves if m.kind.value != "rapid" and m.tool is not None]
    header = header_for(prog.tool_headers, cutting[0] if cutting else None)
    if (header is None or header.diameter_mm is None or header.shape not in
            (ToolShape.FLAT, ToolShape.OTHER, ToolShape.BALL, ToolShape.BULL)):
        return None
    base = yaml.safe_load(Path(template_tool).read_text(encoding="utf-8"))
    d = header.diameter_mm
    shape = _shape_fields(header, d)
    if shape is None:
        return None
    base.update(shape)
    flute = max(3.0 * d, abs(header.z_min_mm or 0.0) + d)
    base.update(source=f"assumed by benchmarks/real_programs.py from {program.name} line "
                f"{header.line} (diameter); teeth, helix and lengths assumed",
                name=f"{shape.get('shape', 'flat')} end mill {d:g} mm (from the program's "
                "comment)",
                diameter_mm=d, teeth=2, helix_deg=30.0, flute_length_mm=flute,
                overall_length_mm=flute + 4.0 * d, shank_diameter_mm=d)
    out = folder / "tool.yaml"
    out.write_text(yaml.safe_dump(base, sort_keys=False), encoding="utf-8")
    return str(out)


def _shape_fields(header, d: float) -> dict | None:
    """The tool file's shape fields for a comment's cutter; None for one feedopt can't make
    from a comment (a corner radius of D/2 or more on a bull nose)."""
    from feedopt.gcode.moves import ToolShape

    rc = header.corner_radius_mm or 0.0
    if header.shape is ToolShape.BALL:
        return {"shape": "ball"}
    if header.shape is ToolShape.BULL or rc > 0.0:
        return {"shape": "bull", "corner_radius_mm": rc} if 0.0 < rc < d / 2 else None
    return {}


def scenario_for(template: dict, program: Path, program_stock: bool) -> dict:
    """The template for one program: its name, ``path.file``, and the stock or fallback cut."""
    sc = copy.deepcopy(template)
    sc["name"] = (re.sub(r"[^A-Za-z0-9._-]", "_", program.stem) or "program")[:80]
    sc["path"]["generator"] = "gcode"
    sc["path"]["file"] = str(program.resolve())
    stock = sc.get("stock")
    if isinstance(stock, dict) and stock.get("from_program") and not program_stock:
        del sc["stock"]
        cut = dict(sc.get("cut") or {})
        cut.update(FALLBACK_CUT)
        sc["cut"] = cut
    return sc


def _law_text(name: str, law: dict) -> str:
    t = law.get("cycle_time_s")
    problems = law.get("problems") or []
    verdict = "verified" if law.get("verified") else (
        f"NOT verified ({problems[0]})" if problems else "NOT verified")
    exported = ", exported" if law.get("exported") else ""
    time_text = f"{t:.1f} s" if isinstance(t, (int, float)) else "? s"
    return f"{name} {time_text} {verdict}{exported}"


def run_summary(summary_file: Path) -> str:
    """One line from a run's ``summary.json``: cycle time and verdict per law, declined laws."""
    try:
        data = json.loads(summary_file.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        return f"no readable summary.json ({exc.__class__.__name__})"
    parts = [_law_text(name, law) for name, law in (data.get("laws") or {}).items()]
    declined = data.get("declined_laws") or {}
    if declined:
        parts.append("declined: " + ", ".join(declined))
    return "; ".join(parts) or "no law in summary.json"


def run_run(program: Path, template: dict, program_stock: bool, laws: str,
            timeout_s: float, tool_from_program: bool = False) -> Outcome:
    """``feedopt run`` on the template made for ``program``, in a temporary folder."""
    with tempfile.TemporaryDirectory(prefix="feedopt_real_") as tmp:
        scen_dir = Path(tmp) / "scenario"
        scen_dir.mkdir()
        scen = scen_dir / "scenario.yaml"
        sc = scenario_for(template, program, program_stock)
        tool = program_tool(program, sc["tool"], scen_dir) if tool_from_program else None
        if tool is not None:
            sc["tool"] = tool
        scen.write_text(yaml.safe_dump(sc, sort_keys=False), encoding="utf-8")
        out_dir = Path(tmp) / "out"
        cmd = [sys.executable, "-m", "feedopt.cli", "run", str(scen), "--out", str(out_dir),
               "--no-report"]
        if laws:
            cmd += ["--laws", laws]
        code, wall, out, err = _execute(cmd, timeout_s)
        if code is None:
            return Outcome(None, wall, f"timed out ({timeout_s:g} s)")
        summary = out_dir / "summary.json"
        if code in (0, 3):
            return Outcome(code, wall, run_summary(summary))
        if summary.is_file():  # planned, but no law could be exported (exit 1)
            return Outcome(code, wall, NOTHING_EXPORTED + run_summary(summary))
        return Outcome(code, wall, short(first_error(err, out), program))


def line_count(program: Path) -> int:
    """Lines of the program (bytes that are not UTF-8 do not stop the count)."""
    with program.open("rb") as fh:
        return sum(1 for _ in fh)


def source_of(program: Path, folders: list[Path]) -> str:
    """The first folder under the root the program was found in (the source's folder)."""
    for f in folders:
        try:
            rel = program.relative_to(f)
        except ValueError:
            continue
        return rel.parts[0] if len(rel.parts) > 1 else f.name
    return program.parent.name


def cause(message: str) -> str:
    """A refusal with its specifics folded: one row per kind of refusal."""
    text = re.sub(r"^feedopt( \w[\w-]*)?: (error|internal error): ", "", message)
    text = re.sub(r"^\S+\.(nc|ngc|tap|gcode|gc|cnc|mpf|eia|iso)\b:?", "PROGRAM:", text,
                  flags=re.I)
    text = re.sub(r"(?<![\w.])/[^\s:,'\"()]+", "FILE", text)
    text = re.sub(r"'[^']*'|\"[^\"]*\"", "'…'", text)
    # numbers folded, but not the G and M codes: they name the cause
    text = re.sub(r"(?<![GM\d.])[-+]?\d+(\.\d+)?(e[-+]?\d+)?", "#", text)
    return text[:140]


def _cell(text: str) -> str:
    """``text`` safe in a Markdown table cell."""
    return text.replace("|", "\\|").replace("\n", " ")


def _code(o: Outcome) -> str:
    return "-" if o.code is None else str(o.code)


NOTHING_EXPORTED = "nothing exported: "


def outcome_counts(outcomes: list[Outcome], command: str) -> str:
    """One line: how many programs ended how."""
    n = len(outcomes)
    by = collections.Counter(o.code for o in outcomes)
    unexported = sum(o.code == 1 and o.message.startswith(NOTHING_EXPORTED) for o in outcomes)
    ok = "read" if command == "path" else "planned and exported (exit 0)"
    text = f"{command}: {ok}: {by[0]} of {n}; refused (exit 2): {by[2]}; "
    if command == "run":
        text += (f"planned, some laws broke their promises (exit 3): {by[3]}; planned, a law "
                 f"broke its promises and none was exported (exit 1): {unexported}; ")
    text += f"internal error (exit 1): {by[1] - unexported}; timed out: {by[None]}"
    others = sorted(str(c) for c in by if c not in (0, 1, 2, 3, None))
    return text + (f"; other exit codes: {', '.join(others)}" if others else "")


def cause_table(outcomes: list[Outcome], command: str) -> list[str]:
    """Markdown rows: the causes of the failures of one command, most frequent first."""
    causes = collections.Counter(cause(o.message) for o in outcomes if o.code not in (0, 3))
    rows = ["", f"| {command}: failures | cause |", "|---:|---|"]
    return rows + [f"| {n} | {_cell(c)} |" for c, n in causes.most_common()]


def source_table(rows: list[Row]) -> list[str]:
    """Markdown rows: per source, the programs and how many each command got through."""
    has_run = any(r.run is not None for r in rows)
    head = "| source | programs | path read | path refused | path other |"
    head += (" run exported | run planned, nothing exported | run refused | run other |"
             if has_run else "")
    out = ["", head, "|---|" + "---:|" * (8 if has_run else 4)]
    for src in sorted({r.source for r in rows}):
        mine = [r for r in rows if r.source == src]
        p = collections.Counter(r.path.code for r in mine)
        cells = [src, len(mine), p[0], p[2], len(mine) - p[0] - p[2]]
        if has_run:
            runs = [r.run for r in mine if r.run is not None]
            q = collections.Counter(o.code for o in runs)
            unexported = sum(o.code == 1 and o.message.startswith(NOTHING_EXPORTED)
                             for o in runs)
            cells += [q[0] + q[3], unexported, q[2], len(runs) - q[0] - q[3] - q[2] - unexported]
        out.append("| " + " | ".join(str(c) for c in cells) + " |")
    return out


def table(rows: list[Row], root: Path | None) -> str:
    """The Markdown report."""
    def name(p: Path) -> str:
        return str(p.relative_to(root)) if root is not None else str(p)

    has_run = any(r.run is not None for r in rows)
    head = "| program | source | lines | path exit | path [s] | path: first line |"
    head += " run exit | run [s] | run: first line / laws |" if has_run else ""
    out = [head, "|---|---|---:|---:|---:|---|" + ("---:|---:|---|" if has_run else "")]
    for r in rows:
        line = (f"| {_cell(name(r.program))} | {r.source} | {r.lines} | {_code(r.path)} | "
                f"{r.path.wall_s:.1f} | {_cell(r.path.message[:MESSAGE_CHARS])} |")
        if r.run is not None:
            line += (f" {_code(r.run)} | {r.run.wall_s:.1f} | "
                     f"{_cell(r.run.message[:MESSAGE_CHARS])} |")
        out.append(line)
    out += ["", outcome_counts([r.path for r in rows], "path")]
    if has_run:
        out += ["", outcome_counts([r.run for r in rows if r.run is not None], "run")]
    out += source_table(rows)
    out += cause_table([r.path for r in rows], "path")
    if has_run:
        out += cause_table([r.run for r in rows if r.run is not None], "run")
    return "\n".join(out) + "\n"


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, help="write the Markdown table here too")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per program and "
                    "command")
    ap.add_argument("--run", type=Path, metavar="TEMPLATE", help="also run `feedopt run` on "
                    "a scenario made from this template (e.g. "
                    "benchmarks/real_programs_scenario.yaml)")
    ap.add_argument("--laws", default="convex,programmed", help="`feedopt run --laws` "
                    "(default convex,programmed; empty: the template's list)")
    ap.add_argument("--tool", type=Path, help="tool file for every run instead of the "
                    "template's (e.g. tests/data/gcode/posts/tool_6mm_2flute.yaml)")
    ap.add_argument("--tool-from-program", action="store_true", help="a program whose "
                    "tool comment names a flat end mill runs with a tool file of that "
                    "diameter (2 teeth, 30 deg helix assumed); others with the template's")
    ap.add_argument("--jobs", type=int, default=1, help="programs at once (default 1)")
    return ap


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    found = programs(args.folders)
    if not found:
        print(f"no G-code programs ({', '.join(sorted(SUFFIXES))}) under {args.folders}",
              file=sys.stderr)
        return 2
    template = load_template(args.run, args.tool) if args.run is not None else None
    program_stock = supports_program_stock() if template is not None else False

    def one(p: Path) -> Row:
        path = run_path(p, args.timeout)
        run = (None if template is None else
               run_run(p, template, program_stock, args.laws, args.timeout,
                       args.tool_from_program))
        return Row(p, source_of(p, args.folders), line_count(p), path, run)

    previous = signal.signal(signal.SIGTERM, _interrupt)
    pool = ThreadPoolExecutor(max_workers=max(1, args.jobs))
    try:
        rows = list(pool.map(one, found))
    except KeyboardInterrupt:
        pool.shutdown(wait=False, cancel_futures=True)
        stop_children()
        print("interrupted: the running feedopt commands were stopped, no table written",
              file=sys.stderr)
        return 130
    finally:
        signal.signal(signal.SIGTERM, previous)
    pool.shutdown()
    root = args.folders[0] if len(args.folders) == 1 else None
    report = table(rows, root)
    if template is not None:
        stock = ("stock: {from_program: true}" if program_stock else
                 f"no stock.from_program in this feedopt: stock left out, cut {FALLBACK_CUT}")
        tool = f", tool {args.tool}" if args.tool is not None else ""
        if args.tool_from_program:
            tool += ", the program's flat end mill where its comment names one"
        report = (f"Run template: {args.run}{tool}, laws {args.laws or '(template)'}; "
                  f"{stock}.\n\n" + report)
    print(report, end="")
    if args.out is not None:
        args.out.write_text(report, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())

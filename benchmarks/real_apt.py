"""What the APT CL reader makes of a folder of CL files written by others.

    python benchmarks/real_apt.py FOLDER [--verbose]

Reads every ``*.cls``, ``*.apt``, ``*.aptsource`` and ``*.cl`` file under FOLDER (recursively)
with :func:`feedopt.gcode.read_apt` and prints one line per file: the number of moves, whether
they carry tool vectors (five-axis), the feed moves, the arcs (moves of kind ARC), the notes and
the units; or the one-line refusal. Then the totals and the refusals by statement. Always exits
0 (a refusal is a result, not a failure). ``--verbose`` also prints each file's notes.

The files are not in this repository (most public CL files have no licence or a copyleft one);
the report of the reader's introduction lists where they came from.
"""

from __future__ import annotations

import argparse
import collections
import re
import sys
from pathlib import Path

from feedopt.errors import InputError
from feedopt.gcode import read_apt

SUFFIXES = {".cls", ".apt", ".aptsource", ".cl"}


def cl_files(folder: Path) -> list[Path]:
    """The CL files under ``folder``, sorted."""
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in SUFFIXES)


def describe(path: Path, verbose: bool) -> tuple[str, str | None]:
    """One line about ``path`` and the refused statement (None if it was read)."""
    try:
        program = read_apt(path)
    except InputError as exc:
        message = str(exc).replace(str(path), "").strip(" :")
        cause = re.match(r"line \d+: ([A-Z][A-Z0-9 _/-]*):", message)
        return f"ERROR {message.splitlines()[0][:150]}", cause.group(1) if cause else "other"
    moves = program.moves
    feed = sum(m.feed_mm_s is not None for m in moves)
    arcs = sum(m.kind.value == "arc" for m in moves)
    line = (f"moves {len(moves):6d}  five-axis {'yes' if program.five_axis else 'no ':3s}  "
            f"feed {feed:6d}  arcs {arcs:5d}  notes {len(program.warnings):3d}  "
            f"{program.units}")
    if verbose:
        line += "".join(f"\n      - {w}" for w in program.warnings)
    return line, None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="folder with CL files (searched recursively)")
    parser.add_argument("--verbose", action="store_true", help="print each file's notes")
    args = parser.parse_args(argv)
    files = cl_files(args.folder)
    if not files:
        print(f"no {', '.join(sorted(SUFFIXES))} files under {args.folder}")
        return 0
    causes: collections.Counter[str] = collections.Counter()
    width = max(len(str(p.relative_to(args.folder))) for p in files)
    for path in files:
        line, cause = describe(path, args.verbose)
        if cause is not None:
            causes[cause] += 1
        print(f"{str(path.relative_to(args.folder)):{width}s}  {line}")
    read = len(files) - sum(causes.values())
    print(f"\n{read} of {len(files)} file(s) read")
    for cause, n in causes.most_common():
        print(f"  refused at {cause}: {n}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

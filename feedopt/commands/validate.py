"""``feedopt validate SCENARIO.yaml``: check a scenario without planning it.

``feedopt validate --schema`` prints the field reference (Markdown) instead; ``--out FILE``
writes it to FILE. ``--schema`` takes no scenario: ``--schema x.yaml`` is refused (exit 2)
rather than guessed at, because neither reading (validate it? ignore it?) nor writing
(overwrite the scenario with the reference?) is what every user means.
"""

from __future__ import annotations

import argparse
from pathlib import Path

REFERENCE_SUFFIXES = (".md", ".txt", ".markdown")


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "validate",
        help="check a scenario file (schema, referenced files, path geometry)",
        description="Validate SCENARIO.yaml: schema and units, that every referenced file "
        "exists and loads, and that the path can be built (waypoints, blends that fit). "
        "With --schema (and no SCENARIO), print the reference of every scenario field "
        "instead, as Markdown; add --out FILE.md to write it to a file.",
    )
    p.add_argument("scenario", nargs="?", help="scenario YAML file (not with --schema)")
    p.add_argument(
        "--schema",
        action="store_true",
        help="print the field reference instead of validating; takes no SCENARIO",
    )
    p.add_argument(
        "--out",
        metavar="FILE",
        help="with --schema: write the reference to FILE (.md or .txt) instead of printing it",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from feedopt.errors import InputError
    from feedopt.outfile import write_atomically
    from feedopt.scenario import schema_reference

    if args.schema:
        if args.scenario:
            raise InputError(
                f"--schema prints the field reference and takes no scenario file, got "
                f"{args.scenario!r}; run 'feedopt validate {args.scenario}' to check it, or "
                "'feedopt validate --schema --out reference.md' to write the reference to a "
                "file"
            )
        if args.out is not None:
            target = _check_reference_out(args.out)
            write_atomically(target, schema_reference())
            print(f"wrote {args.out}")
            return 0
        print(schema_reference(), end="")
        return 0
    if args.out is not None:
        raise InputError(
            "--out writes the --schema reference; validating a scenario writes nothing (use "
            "--schema --out FILE.md, or drop --out)"
        )
    if not args.scenario:
        raise InputError("give a scenario file (or --schema)")
    from feedopt.runner import validate_scenario

    print(validate_scenario(args.scenario))
    return 0


def _check_reference_out(name: str) -> Path:
    """The checked target of ``--schema --out``: a writable .md/.txt file (before any work)."""
    from feedopt.errors import InputError
    from feedopt.outfile import check_name, check_output_file

    check_name(name, "--out")
    if not Path(name).is_dir() and Path(name).suffix.lower() not in REFERENCE_SUFFIXES:
        raise InputError(
            f"--out {name!r}: the reference is Markdown text, not a scenario; give a file "
            f"ending in {' or '.join(REFERENCE_SUFFIXES[:2])} (e.g. --out reference.md)"
        )
    return check_output_file(name, "--out", REFERENCE_SUFFIXES, example="reference.md")

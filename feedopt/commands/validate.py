"""``feedopt validate SCENARIO.yaml``: check a scenario without planning it."""

from __future__ import annotations

import argparse


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "validate",
        help="check a scenario file (schema, referenced files, path geometry)",
        description="Validate SCENARIO.yaml: schema and units, that every referenced file "
        "exists and loads, and that the path can be built (waypoints, blends that fit). "
        "With --schema, print the reference of every scenario field instead.",
    )
    p.add_argument("scenario", nargs="?", help="scenario YAML file")
    p.add_argument("--schema", action="store_true", help="print the field reference")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from feedopt.errors import InputError
    from feedopt.scenario import schema_reference

    if args.schema:
        print(schema_reference(), end="")
        return 0
    if not args.scenario:
        raise InputError("give a scenario file (or --schema)")
    from feedopt.runner import validate_scenario

    print(validate_scenario(args.scenario))
    return 0

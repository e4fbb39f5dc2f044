"""``feedopt compare DIR...``: the comparison table of several runs side by side."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers) -> None:
    """Register ``feedopt compare``."""
    p = subparsers.add_parser(
        "compare",
        epilog="docs: docs/running.md",
        help="print the comparison table of several runs",
        description=(
            "Read DIR/summary.json of each run directory written by `feedopt run` and print "
            "one table with a row per (run, timing law): cycle time, lower bound, deflection "
            "and its ratio to the limit, feed range, acceleration, jerk, C2, verification."
        ),
    )
    p.add_argument("dirs", nargs="+", metavar="DIR",
                   help="run directory (or its summary.json)")
    p.set_defaults(func=run)


def _names(paths: list[Path]) -> list[str]:
    """Run names: the directory names, or the full paths when two names collide."""
    dirs = [p if p.is_dir() else p.parent for p in paths]
    short = [d.name or str(d) for d in dirs]
    return short if len(set(short)) == len(short) else [str(d) for d in dirs]


def run(args: argparse.Namespace) -> int:
    """Validate every summary first, then print the table (nothing printed on bad input)."""
    # imported here: feedopt.report pulls in matplotlib, which no other command line needs
    from feedopt.report.data import load_summary
    from feedopt.report.tables import comparison_table

    paths = [Path(d) for d in args.dirs]
    summaries = [load_summary(p) for p in paths]
    print(comparison_table(summaries, names=_names(paths)))
    return 0

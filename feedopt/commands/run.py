"""``feedopt run SCENARIO.yaml``: the whole pipeline, verified, exported and reported."""

from __future__ import annotations

import argparse
import sys

from feedopt.errors import InputError
from feedopt.schedule.laws import LAWS


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "run",
        epilog="docs: docs/running.md",
        help="plan, verify, export and report a scenario",
        description="Run every stage on SCENARIO.yaml and write, per timing law, the RSI CSV "
        "(only for verified laws unless --export-unverified), KRL programs for the thesis "
        "and constant laws, summary.json and report.md/report.html.",
    )
    p.add_argument("scenario", help="scenario YAML file (see scenarios/)")
    p.add_argument("--out", help="output folder (default: out/<scenario name>/). It must be "
                   "new, empty or a previous feedopt output (which is replaced); a folder with "
                   "other files is refused unless --overwrite. Never the current directory, "
                   "the scenario's folder or a parent of them")
    p.add_argument("--overwrite", action="store_true",
                   help="write into an existing --out that holds other files: files of the "
                   "same names are replaced, every other file is kept")
    p.add_argument("--laws", help=f"comma-separated subset of {','.join(LAWS)} "
                   "(default: the scenario's list)")
    p.add_argument("--export-unverified", action="store_true",
                   help="also export laws that failed verification (marked in the files)")
    p.add_argument("--spacing-mm", type=float, help="override the path sample spacing (mm)")
    p.add_argument("--no-report", action="store_true", help="skip report.md/report.html")
    p.add_argument("--profile", action="store_true",
                   help="also print the wall time of every stage and of every law's planning, "
                   "verification and export, and the peak memory (one table)")
    p.set_defaults(func=run)


def parse_laws(text: str | None) -> list[str] | None:
    """Parse ``--laws``; InputError for an unknown name."""
    if not text:
        return None
    laws = [x.strip() for x in text.split(",") if x.strip()]
    unknown = [x for x in laws if x not in LAWS]
    if unknown or not laws:
        raise InputError(f"--laws: unknown law(s) {', '.join(unknown) or '(none given)'}; "
                         f"choose from {', '.join(LAWS)}")
    return list(dict.fromkeys(laws))


def run(args: argparse.Namespace) -> int:
    from feedopt.runner import run_scenario

    if args.spacing_mm is not None and not args.spacing_mm > 0:
        raise InputError(f"--spacing-mm must be positive, got {args.spacing_mm}")
    result = run_scenario(
        args.scenario,
        out_dir=args.out,
        laws=parse_laws(args.laws),
        export_unverified=args.export_unverified,
        spacing_mm=args.spacing_mm,
        report=not args.no_report,
        overwrite=args.overwrite,
    )
    print(result.table)
    if args.profile and result.profile is not None:
        print("\nprofile (wall time per stage and law):\n")
        print(result.profile.table())
    print(f"\nwrote {result.out_dir}")
    return exit_code(result)


#: ``feedopt run`` exit code when some laws failed their own verification while others were
#: verified and exported: the outputs are usable, the failures are real (docs/running.md,
#: exit codes).
PARTIAL = 3


def exit_code(result) -> int:
    """0: every law that planned kept its promises (declined laws are said, not failures);
    3 (PARTIAL): some failed their own verification, others were exported; 1: some failed and
    none was exported."""
    failed = [law for law, r in result.laws.items() if not r.verification.verified]
    if not failed:
        return 0
    exported = [law for law, e in result.summary["laws"].items() if e.get("exported")]
    print(f"feedopt run: {len(failed)} law(s) FAILED their own verification and were not "
          f"exported: {', '.join(failed)} (see summary.json)"
          + (f"; exported: {', '.join(exported)}" if exported else "; nothing was exported"),
          file=sys.stderr)
    return PARTIAL if exported else 1

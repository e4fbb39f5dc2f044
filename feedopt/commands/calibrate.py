"""``feedopt calibrate``: cutting coefficients from slotting forces (thesis Eq. 3.24-3.25)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from feedopt.errors import InputError
from feedopt.outfile import check_output_file, write_atomically
from feedopt.process.calibration import calibrate, calibration_table, read_slot_forces
from feedopt.process.coefficients import AXIAL_SIGN_NOTE, save_coefficients, sign_problems
from feedopt.textio import read_user_text
from feedopt.units import MM


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate",
        help="fit cutting coefficients to average slotting forces",
        description=(
            "Linear regression of full-immersion slotting forces on feed per tooth, per spindle "
            "speed (thesis Eq. 3.24), and the six coefficients of Eq. 3.25. The CSV has columns "
            "spindle_rpm,feed_mm_s,fx_n,fy_n,fz_n (forces on the tool, force-model frame; '#' "
            "comment lines allowed). --out also records the feed-per-tooth range of the cuts "
            "(feed_per_tooth_range_mm), outside which feedopt forces warns. A fit with "
            "Ktc or Krc <= 0 or Kte or Kre < 0 (unphysical signs, thesis 3.6.1) is printed "
            "with a warning, and --out refuses to write it (exit 2): feedopt would refuse "
            "to load that file."
        ),
    )
    p.add_argument("forces_csv", metavar="FORCES.csv", help="average slotting forces")
    p.add_argument("--teeth", type=int, required=True, help="number of flutes N")
    p.add_argument("--axial-depth-mm", type=float, required=True, help="axial depth a [mm]")
    p.add_argument("--out", metavar="YAML", help="write a coefficients file here")
    p.add_argument("--material", default="", help="material name recorded in --out")
    p.add_argument("--tool", default="", help="tool name recorded in --out")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.teeth < 1:
        raise InputError(f"--teeth must be >= 1, got {args.teeth}")
    if not (math.isfinite(args.axial_depth_mm) and args.axial_depth_mm > 0):
        raise InputError(f"--axial-depth-mm must be > 0, got {args.axial_depth_mm!r}")
    if args.out is not None:
        check_output_file(args.out, "--out", example="coeffs.yaml", inputs=[args.forces_csv])
    # read_slot_forces reads with the locale's encoding and no check: let textio refuse an
    # unreadable or non-UTF-8 file first (only a regular file: read_slot_forces refuses the
    # rest, and a device such as /dev/zero would be read forever)
    if Path(args.forces_csv).is_file():
        read_user_text(args.forces_csv, "forces CSV", encoding="utf-8-sig")
    rows = read_slot_forces(args.forces_csv)
    cals = calibrate(rows, args.teeth, args.axial_depth_mm * MM)

    print(
        f"{'rpm':>6} {'Ktc':>7} {'Kte':>7} {'Krc':>7} {'Kre':>7} {'Kac':>7} {'Kae':>7}   "
        f"{'R2 x':>6} {'R2 y':>6} {'R2 z':>6}"
    )
    print(
        f"{'':>6} {'e8N/m2':>7} {'e3N/m':>7} {'e8N/m2':>7} {'e3N/m':>7} {'e8N/m2':>7} {'e3N/m':>7}"
    )
    for cal in cals:
        k = cal.coeffs
        print(
            f"{cal.rpm:6g} {k.ktc / 1e8:7.3f} {k.kte / 1e3:7.3f} {k.krc / 1e8:7.3f} "
            f"{k.kre / 1e3:7.3f} {k.kac / 1e8:7.3f} {k.kae / 1e3:7.3f}   "
            + " ".join(f"{r:6.4f}" for r in cal.r2)
        )
    source = (
        f"feedopt calibrate {Path(args.forces_csv).name} --teeth {args.teeth} "
        f"--axial-depth-mm {args.axial_depth_mm:g} (thesis Eq. 3.24-3.25)"
    )
    table = calibration_table(cals, material=args.material, tool=args.tool, source=source)
    lo, hi = table.feed_per_tooth_range
    print(f"feed per tooth of the cuts: {lo / MM:.5g}..{hi / MM:.5g} mm")
    bad = [(cal.rpm, sign_problems(cal.coeffs)) for cal in cals]
    bad = [(rpm, p) for rpm, p in bad if p]
    if bad:
        what = "; ".join(f"at {rpm:g} rpm: {', '.join(p)}" for rpm, p in bad)
        why = (
            f"the fit gives unphysical coefficient signs ({what}). Check that the forces are "
            "on the tool in the force-model frame (slotting: mean fx < 0, fy > 0 growing with "
            "the feed) and that each speed has cuts over a wide enough range of feeds; "
            f"{AXIAL_SIGN_NOTE}"
        )
        if args.out is not None:
            raise InputError(f"{why}. Not writing {args.out}: feedopt would refuse to load it")
        print(f"feedopt calibrate: warning: {why}", file=sys.stderr)
    if args.out is not None:
        write_atomically(args.out, lambda tmp: save_coefficients(table, tmp))
        print(f"wrote {args.out}")
    return 0

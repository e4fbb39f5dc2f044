"""``feedopt calibrate``: cutting coefficients from slotting forces (thesis Eq. 3.24-3.25),
and optionally the plunge coefficients from straight-plunge thrust and torque
(:mod:`feedopt.process.plunge`)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from feedopt.errors import InputError
from feedopt.outfile import check_output_file, write_atomically
from feedopt.process.calibration import (
    PlungeCalibration,
    calibrate,
    calibrate_plunge,
    calibration_table,
    read_plunge_forces,
    read_slot_forces,
)
from feedopt.process.coefficients import AXIAL_SIGN_NOTE, save_coefficients, sign_problems
from feedopt.process.plunge import plunge_sign_problems
from feedopt.textio import read_user_text
from feedopt.units import MM


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate",
        epilog="docs: docs/calibration.md",
        help="fit cutting coefficients to average slotting forces",
        description=(
            "Linear regression of full-immersion slotting forces on feed per tooth, per spindle "
            "speed (thesis Eq. 3.24), and the six coefficients of Eq. 3.25. The CSV has columns "
            "spindle_rpm,feed_mm_s,fx_n,fy_n,fz_n (forces on the tool, force-model frame; '#' "
            "comment lines allowed). --out also records the feed-per-tooth range of the cuts "
            "(feed_per_tooth_range_mm), outside which feedopt forces warns. A fit with "
            "Ktc or Krc <= 0 or Kte or Kre < 0 (unphysical signs, thesis 3.6.1) is printed "
            "with a warning, and --out refuses to write it (exit 2): feedopt would refuse "
            "to load that file. --plunge-forces adds the plunge block of every speed: a CSV "
            "with exactly the columns spindle_rpm,feed_mm_s,thrust_n,torque_nm (mean thrust "
            "on the tool along its axis, > 0, and spindle torque of full straight plunges "
            "at axial feed feed_mm_s, at the speeds of the slot cuts), fitted by least "
            "squares to F_z = N R (K_tc c + K_te), T = N R^2/2 (K_cc c + K_ce); it needs "
            "--diameter-mm."
        ),
    )
    p.add_argument("forces_csv", metavar="FORCES.csv", help="average slotting forces")
    p.add_argument("--teeth", type=int, required=True, help="number of flutes N")
    p.add_argument("--axial-depth-mm", type=float, required=True, help="axial depth a [mm]")
    p.add_argument("--plunge-forces", metavar="PLUNGE.csv",
                   help="mean thrust [N] and torque [N m] of straight plunges: fit the "
                        "plunge coefficients too")
    p.add_argument("--diameter-mm", type=float,
                   help="tool diameter D [mm] (with --plunge-forces: R = D/2)")
    p.add_argument("--out", metavar="YAML", help="write a coefficients file here")
    p.add_argument("--material", default="", help="material name recorded in --out")
    p.add_argument("--tool", default="", help="tool name recorded in --out")
    p.set_defaults(func=run)


def _check_args(args: argparse.Namespace) -> None:
    if args.teeth < 1:
        raise InputError(f"--teeth must be >= 1, got {args.teeth}")
    if not (math.isfinite(args.axial_depth_mm) and args.axial_depth_mm > 0):
        raise InputError(f"--axial-depth-mm must be > 0, got {args.axial_depth_mm!r}")
    if args.plunge_forces is None and args.diameter_mm is not None:
        raise InputError("--diameter-mm is only used with --plunge-forces (the plunge fit); "
                         "give both or neither")
    if args.plunge_forces is not None and not (
            args.diameter_mm is not None and math.isfinite(args.diameter_mm)
            and args.diameter_mm > 0):
        raise InputError(f"--plunge-forces needs --diameter-mm > 0 (the tool diameter D), got "
                         f"{args.diameter_mm!r}")
    if args.out is not None:
        inputs = [args.forces_csv] + ([args.plunge_forces] if args.plunge_forces else [])
        check_output_file(args.out, "--out", example="coeffs.yaml", inputs=inputs)


def _print_side(cals) -> None:
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


def _print_plunge(cals: list[PlungeCalibration]) -> None:
    print("plunge (fit, thrust F_z = N R (Ktc c + Kte), torque T = N R^2/2 (Kcc c + Kce)):")
    print(f"{'rpm':>6} {'Ktc':>8} {'Kte':>8} {'Kcc':>8} {'Kce':>8}   {'R2 F_z':>6} {'R2 T':>6}")
    print(f"{'':>6} {'N/mm2':>8} {'N/mm':>8} {'N/mm2':>8} {'N/mm':>8}")
    for cal in cals:
        k = cal.coeffs
        print(f"{cal.rpm:6g} {k.thrust_cutting / 1e6:8.2f} {k.thrust_edge / 1e3:8.3f} "
              f"{k.torque_cutting / 1e6:8.2f} {k.torque_edge / 1e3:8.3f}   "
              + " ".join(f"{r:6.4f}" for r in cal.r2))


def _sign_check(args: argparse.Namespace, cals, plunge: list[PlungeCalibration]) -> None:
    """Refuse (with --out) or warn about unphysical coefficient signs."""
    bad = [(cal.rpm, sign_problems(cal.coeffs)) for cal in cals]
    bad += [(cal.rpm, plunge_sign_problems(cal.coeffs)) for cal in plunge]
    bad = [(rpm, p) for rpm, p in bad if p]
    if not bad:
        return
    what = "; ".join(f"at {rpm:g} rpm: {', '.join(p)}" for rpm, p in bad)
    why = (
        f"the fit gives unphysical coefficient signs ({what}). Check that the forces are "
        "on the tool in the force-model frame (slotting: mean fx < 0, fy > 0 growing with "
        "the feed; plunging: thrust_n > 0 and torque_nm > 0 growing with the feed) and that "
        "each speed has cuts over a wide enough range of feeds; "
        f"{AXIAL_SIGN_NOTE}"
    )
    if args.out is not None:
        raise InputError(f"{why}. Not writing {args.out}: feedopt would refuse to load it")
    print(f"feedopt calibrate: warning: {why}", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    _check_args(args)
    # read_slot_forces reads with the locale's encoding and no check: let textio refuse an
    # unreadable or non-UTF-8 file first (only a regular file: read_slot_forces refuses the
    # rest, and a device such as /dev/zero would be read forever)
    if Path(args.forces_csv).is_file():
        read_user_text(args.forces_csv, "forces CSV", encoding="utf-8-sig")
    rows = read_slot_forces(args.forces_csv)
    cals = calibrate(rows, args.teeth, args.axial_depth_mm * MM)
    plunge: list[PlungeCalibration] = []
    if args.plunge_forces is not None:
        plunge = calibrate_plunge(read_plunge_forces(args.plunge_forces), args.teeth,
                                  args.diameter_mm * MM)
    _print_side(cals)
    if plunge:
        _print_plunge(plunge)
    source = (
        f"feedopt calibrate {Path(args.forces_csv).name} --teeth {args.teeth} "
        f"--axial-depth-mm {args.axial_depth_mm:g} (thesis Eq. 3.24-3.25)"
    )
    if plunge:
        source += (f"; plunge blocks: least-squares fit of {Path(args.plunge_forces).name} "
                   f"--diameter-mm {args.diameter_mm:g} (thrust and torque lines, Altintas, "
                   "Manufacturing Automation, ch. 2)")
    table = calibration_table(cals, material=args.material, tool=args.tool, source=source,
                              plunge=plunge or None)
    lo, hi = table.feed_per_tooth_range
    print(f"feed per tooth of the cuts: {lo / MM:.5g}..{hi / MM:.5g} mm")
    if plunge:
        c = [v for cal in plunge for v in cal.feed_per_tooth]
        print(f"feed per tooth of the plunges: {min(c) / MM:.5g}..{max(c) / MM:.5g} mm")
    _sign_check(args, cals, plunge)
    if args.out is not None:
        write_atomically(args.out, lambda tmp: save_coefficients(table, tmp))
        print(f"wrote {args.out}")
    return 0

"""``feedopt calibrate``: cutting coefficients from slotting forces (thesis Eq. 3.24-3.25)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from feedopt.errors import InputError
from feedopt.process.calibration import calibrate, calibration_table, read_slot_forces
from feedopt.process.coefficients import save_coefficients


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate",
        help="fit cutting coefficients to average slotting forces",
        description=(
            "Linear regression of full-immersion slotting forces on feed per tooth, per spindle "
            "speed (thesis Eq. 3.24), and the six coefficients of Eq. 3.25. The CSV has columns "
            "spindle_rpm,feed_mm_s,fx_n,fy_n,fz_n (forces on the tool, force-model frame; '#' "
            "comment lines allowed)."
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
    if args.out and not Path(args.out).resolve().parent.is_dir():
        raise InputError(f"--out: directory {Path(args.out).resolve().parent} does not exist")
    rows = read_slot_forces(args.forces_csv)
    cals = calibrate(rows, args.teeth, args.axial_depth_mm * 1e-3)

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
    if args.out:
        source = (
            f"feedopt calibrate {Path(args.forces_csv).name} --teeth {args.teeth} "
            f"--axial-depth-mm {args.axial_depth_mm:g} (thesis Eq. 3.24-3.25)"
        )
        table = calibration_table(cals, material=args.material, tool=args.tool, source=source)
        save_coefficients(table, args.out)
        print(f"wrote {args.out}")
    return 0

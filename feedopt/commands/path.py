"""``feedopt path``: build an LIPB path from waypoints, sample it, report its continuity."""

from __future__ import annotations

import argparse
from pathlib import Path as FilePath

import numpy as np

from feedopt.errors import InputError
from feedopt.geometry import waves
from feedopt.geometry.blends import BLEND_KINDS
from feedopt.geometry.continuity import continuity_report
from feedopt.geometry.path import REPEAT_TOL, build_lipb_path
from feedopt.geometry.waypoints import read_waypoints_csv
from feedopt.units import MM

BUILTIN = {"builtin:triangle": waves.triangle_wave, "builtin:square": waves.square_wave,
           "builtin:line": waves.straight_line}
MAX_SAMPLES = 20_000_000
HEADER = "s_mm,x_mm,y_mm,z_mm,tx,ty,tz,kx_1_mm,ky_1_mm,kz_1_mm"


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "path",
        help="build a path (lines + corner blends) from waypoints and check its continuity",
        description=(
            "Linear interpolation with a blend at every corner (thesis 3.3). Writes the path "
            "sampled by arc length and prints the G0/G1/G2 jump at every junction."),
    )
    p.add_argument("waypoints", help="CSV with columns x_mm,y_mm,z_mm, or one of "
                   + ", ".join(BUILTIN) + " (thesis test paths)")
    p.add_argument("--blend", choices=BLEND_KINDS, default="varying_radius",
                   help="corner blend (default: varying_radius)")
    p.add_argument("--radius", type=float, metavar="MM",
                   help="blend radius for circle / varying_radius [mm]")
    p.add_argument("--tolerance", type=float, metavar="MM",
                   help="blend tolerance delta for bezier4 / bezier5 [mm]")
    p.add_argument("--spacing", type=float, default=0.1, metavar="MM",
                   help="sample spacing along s [mm] (default 0.1)")
    p.add_argument("--out", metavar="CSV", help="write the samples here")
    p.add_argument("--plot", metavar="PNG", help="draw the path and its curvature here")
    p.add_argument("--drop-repeated", action="store_true",
                   help="drop repeated consecutive waypoints instead of refusing them")
    p.add_argument("--max-rows", type=int, default=40,
                   help="junction rows printed (head and tail; default 40, 0 = all, >= 0)")
    p.set_defaults(func=run)


def _positive_mm(value: float, option: str, example: str) -> float:
    """``value`` [mm] as metres; InputError unless it is a positive finite number."""
    if not (np.isfinite(value) and value > 0):
        raise InputError(
            f"{option} must be a positive, finite number of mm, got {value:g} (e.g. {option} "
            f"{example})"
        )
    return value * MM


def _size(args: argparse.Namespace) -> float:
    if args.blend in ("circle", "varying_radius"):
        if args.tolerance is not None:
            raise InputError(f"--tolerance is for bezier blends; {args.blend} takes --radius")
        if args.radius is None:
            raise InputError(f"blend {args.blend} needs --radius MM (e.g. --radius 12.7)")
        return _positive_mm(args.radius, "--radius", "12.7")
    if args.blend in ("bezier4", "bezier5"):
        if args.radius is not None:
            raise InputError(f"--radius is for circle/varying_radius; {args.blend} takes "
                             "--tolerance MM")
        if args.tolerance is None:
            raise InputError(f"blend {args.blend} needs --tolerance MM (e.g. --tolerance 12.7)")
        return _positive_mm(args.tolerance, "--tolerance", "12.7")
    for value, option in ((args.radius, "--radius"), (args.tolerance, "--tolerance")):
        if value is not None:
            raise InputError(f"{option} sizes a blend; --blend none has none (drop {option})")
    return 0.0


def _check_out(name: str, option: str) -> None:
    parent = FilePath(name).resolve().parent
    if not parent.is_dir():
        raise InputError(f"{option}: directory {parent} does not exist")


def run(args: argparse.Namespace) -> int:
    size = _size(args)
    spacing = _positive_mm(args.spacing, "--spacing", "0.1")
    if args.max_rows < 0:
        raise InputError(
            f"--max-rows must be >= 0 (0 = all junction rows), got {args.max_rows}"
        )
    if args.waypoints.startswith("builtin:") and args.waypoints not in BUILTIN:
        raise InputError(
            f"unknown built-in path {args.waypoints!r}; the built-ins are "
            f"{', '.join(BUILTIN)} (or give a CSV file with columns x_mm,y_mm,z_mm)"
        )
    for name, opt in ((args.out, "--out"), (args.plot, "--plot")):
        if name:
            _check_out(name, opt)
    if args.waypoints in BUILTIN:
        w = BUILTIN[args.waypoints]()
    else:
        w = read_waypoints_csv(args.waypoints)
    n_raw = len(w)
    path = build_lipb_path(w, args.blend, size, drop_repeated=args.drop_repeated)
    n = int(np.ceil(path.length / spacing)) + 1
    if n > MAX_SAMPLES:
        raise InputError(
            f"--spacing {args.spacing} mm gives {n} samples over {path.length * 1e3:.6g} mm "
            f"(limit {MAX_SAMPLES}); use a spacing of at least "
            f"{path.length * 1e3 / (MAX_SAMPLES - 1):.3g} mm")
    report = continuity_report(path)

    kinds = path.segment_kind
    counts = ", ".join(f"{k} {kinds.count(k)}" for k in dict.fromkeys(kinds))
    used = len({g.corner_index for g in path.segments if g.corner_index >= 0})
    print(f"waypoints: {n_raw} (from {args.waypoints})")
    rep = np.flatnonzero(np.linalg.norm(np.diff(w, axis=0), axis=1) <= REPEAT_TOL) + 1
    if rep.size:
        shown = ", ".join(str(i) for i in rep[:10]) + (" ..." if rep.size > 10 else "")
        print(f"dropped {rep.size} repeated waypoint(s): indices {shown}")
    print(f"blend: {args.blend}" + (f", size {size * 1e3:g} mm" if size else "")
          + f", {used} corner(s) blended")
    print(f"path length: {path.length * 1e3:.6f} mm, segments: {len(kinds)} ({counts})")
    print(report.table(max_rows=args.max_rows or None))
    if args.out:
        pts = path.sample(spacing)
        data = np.column_stack([pts.s * 1e3, pts.position * 1e3, pts.tangent,
                                pts.curvature * 1e-3])
        np.savetxt(args.out, data, delimiter=",", header=HEADER, comments="", fmt="%.12g")
        print(f"wrote {len(pts.s)} samples to {args.out}")
    if args.plot:
        from feedopt.geometry.plot import plot_path

        plot_path(path, args.plot, spacing=max(spacing, path.length / 20000), waypoints=w,
                  title=f"{args.waypoints}: {args.blend}")
        print(f"wrote {args.plot}")
    return 0

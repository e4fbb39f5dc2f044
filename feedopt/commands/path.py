"""``feedopt path``: build an LIPB path from waypoints, or the G2 path of a G-code program,
sample it, report its continuity (and, for a program, the deviation at every junction)."""

from __future__ import annotations

import argparse
import math
import os
import re
import stat
from pathlib import Path as PathlibPath

import numpy as np

from feedopt.commands import _path_stock as path_stock
from feedopt.errors import InputError
from feedopt.geometry import waves
from feedopt.geometry.continuity import continuity_report
from feedopt.geometry.path import Path, build_lipb_path, check_sample_count
from feedopt.geometry.registry import NO_BLEND, blend_names, get_blend, size_parameters
from feedopt.geometry.stage import orient_waypoints
from feedopt.geometry.waypoints import read_tool_vectors_csv, read_waypoints_csv
from feedopt.outfile import Writer, check_data_and_plot, write_files_atomically
from feedopt.units import MM, MM_PER_M

BUILTIN = {"builtin:triangle": waves.triangle_wave, "builtin:square": waves.square_wave,
           "builtin:line": waves.straight_line}
HEADER = "s_mm,x_mm,y_mm,z_mm,tx,ty,tz,kx_1_mm,ky_1_mm,kz_1_mm"
PROGRAM_HEADER = HEADER + ",line,n,move,nominal_feed_mm_s"
#: the tool vector's columns of a five-axis path's samples (a waypoint CSV reads them back)
AXIS_COLUMNS = ",i,j,k"
#: file suffixes read as G-code programs (CAM post-processor outputs)
PROGRAM_SUFFIXES = (".nc", ".ngc", ".tap", ".gcode", ".cnc", ".mpf", ".eia", ".iso")
#: APT CL files (five-axis tool paths: GOTO/x,y,z,i,j,k), read like programs
APT_SUFFIXES = (".cls", ".apt", ".aptsource", ".cl")
#: HEIDENHAIN Klartext programs (five-axis LN ... TX TY TZ), read like programs
HEIDENHAIN_SUFFIXES = (".h",)
DEFAULT_PROGRAM_BLEND_SIZE_MM = 12.7
DEFAULT_BLEND = "varying_radius"
REPEAT_HINT = "pass --drop-repeated"
# options of feedopt path itself: a size parameter may not be called like one of them
_FIXED_OPTIONS = ("--help", "--blend", "--spacing", "--out", "--plot", "--drop-repeated",
                  "--max-rows", "--tolerance-mm", "--air-tolerance-mm", "--stock-top",
                  "--arc-tolerance", "--tool", "--stock-box", "--stock-from-program",
                  "--stock-cell", "--orientation-tolerance")


def _option(size_name: str) -> str:
    return "--" + size_name.replace("_", "-")


def _dest(size_name: str) -> str:
    return f"size_{size_name}"


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "path",
        epilog="docs: docs/gcode.md",
        help="build a path (lines + corner blends) from waypoints and check its continuity",
        description=(
            "Linear interpolation with a blend at every corner (thesis 3.3). Writes the path "
            "sampled by arc length and prints the G0/G1/G2 jump at every junction."),
    )
    p.add_argument("waypoints", help="CSV with columns x_mm,y_mm,z_mm (and i,j,k tool "
                   "vectors), one of " + ", ".join(BUILTIN) + " (thesis test paths), a G-code "
                   "program (" + ", ".join(PROGRAM_SUFFIXES) + "), an APT CL file ("
                   + ", ".join(APT_SUFFIXES) + ") or a HEIDENHAIN Klartext program (.h); a "
                   "five-axis path's samples carry i,j,k")
    p.add_argument("--blend", choices=blend_names(), default=DEFAULT_BLEND,
                   help=f"corner blend (default: {DEFAULT_BLEND})")
    # one size option per size parameter of the registered blend kinds (--radius, ...)
    for name, (size, kinds) in size_parameters().items():
        if _option(name) in _FIXED_OPTIONS:
            raise RuntimeError(f"blend {kinds[0]} names its size {name!r}, which clashes with "
                               f"feedopt path's own option {_option(name)}; rename it")
        p.add_argument(_option(name), type=float, metavar="MM", dest=_dest(name),
                       help=f"{size.meaning}; for {' / '.join(kinds)}")
    p.add_argument("--spacing", type=float, default=0.1, metavar="MM",
                   help="sample spacing along s [mm] (default 0.1)")
    p.add_argument("--out", metavar="CSV", help="write the samples here")
    p.add_argument("--plot", metavar="PNG", help="draw the path and its curvature here")
    p.add_argument("--drop-repeated", action="store_true",
                   help="drop repeated consecutive waypoints instead of refusing them")
    p.add_argument("--tolerance-mm", type=float, default=0.01, metavar="MM",
                   help="program: largest deviation from the program next to cuts (default "
                   "0.01)")
    p.add_argument("--air-tolerance-mm", type=float, default=0.5, metavar="MM",
                   help="program: the same between air moves (default 0.5)")
    p.add_argument("--stock-top", type=float, default=0.0, metavar="MM",
                   help="program: Z of the stock top; an air link across a tool change, G28 "
                   "or G53 below it is refused, a plunge below it takes the cutting tolerance "
                   "(default 0)")
    p.add_argument("--arc-tolerance", type=float, default=0.002, metavar="MM",
                   help="program: largest start/end radius difference of an arc (default "
                   "0.002)")
    p.add_argument("--orientation-tolerance", type=float, default=0.2, metavar="DEG",
                   help="five-axis paths (tool vectors): largest angle between the smoothed and "
                   "the programmed tool vector (default 0.2, as path.orientation_tolerance_deg)")
    path_stock.add_arguments(p)
    p.add_argument("--max-rows", type=int, default=40,
                   help="junction rows (and smoothed chains) printed (head and tail; default "
                   "40, 0 = all, >= 0)")
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
    """The blend size [m] from the one size option of the chosen kind; InputError for a
    size option of another kind, a missing one, or any size option with ``--blend none``."""
    kind = get_blend(args.blend)
    given = {name: getattr(args, _dest(name)) for name in size_parameters()
             if getattr(args, _dest(name), None) is not None}
    if kind is None:
        if given:
            option = _option(next(iter(given)))
            raise InputError(f"{option} sizes a blend; --blend {NO_BLEND} has none (drop "
                             f"{option})")
        return 0.0
    own = _option(kind.size.name)
    other = next((name for name in given if name != kind.size.name), None)
    if other is not None:
        users = " / ".join(size_parameters()[other][1])
        raise InputError(f"{_option(other)} is for {users}; {args.blend} takes {own} MM")
    if not hasattr(args, _dest(kind.size.name)):  # kind registered after the parser was built
        raise InputError(f"blend {args.blend} takes {own}, which this command line does not "
                         "have; register the blend before building the parser")
    if kind.size.name not in given:
        raise InputError(f"blend {args.blend} needs {own} MM (e.g. {own} 12.7)")
    return _positive_mm(given[kind.size.name], own, "12.7")


def _orientation_tolerance(args: argparse.Namespace) -> float:
    """--orientation-tolerance [deg], checked as path.orientation_tolerance_deg is."""
    value = args.orientation_tolerance
    if not (np.isfinite(value) and 0.0 < value <= 10.0):
        raise InputError(f"--orientation-tolerance must be in (0, 10] deg, got {value:g}")
    return float(value)


def is_program(name: str) -> bool:
    """True for a file name with a G-code or APT CL suffix."""
    return name.lower().endswith(PROGRAM_SUFFIXES + APT_SUFFIXES + HEIDENHAIN_SUFFIXES)


_APT_LINE = re.compile(r"\s*(GOTO|FEDRAT|RAPID|MULTAX|UNITS|FROM|CIRCLE|LOADTL|CUTTER|TLAXIS"
                       r"|SPINDL|PARTNO)\s*/", re.IGNORECASE)
_GCODE_LINE = re.compile(r"\s*(N\d+\s*)?[GM]\d+(\.\d+)?(\s|[A-Z]|$)", re.IGNORECASE)


def refuse_misnamed_program(name: str, lines: int = 50, head_bytes: int = 1 << 16) -> None:
    """InputError when a regular file read as a waypoint CSV (by its suffix) holds an APT CL
    file or a G-code program: one of its first ``lines`` lines (within ``head_bytes``) is an
    APT statement, or a G-code block (without a comma: a CSV row may hold text such as
    ``G1 start`` in a label column). Names the line and the suffixes that would read it.
    Anything else (a pipe, a device, a missing file) is left to the CSV reader's checks."""
    try:
        if not stat.S_ISREG(os.stat(name).st_mode):
            return
        with open(name, "rb") as f:
            head = f.read(head_bytes).decode("utf-8", errors="replace").splitlines()[:lines]
    except OSError:
        return  # the CSV reader says what is wrong with the file
    for number, text in enumerate(head, start=1):
        kind = ("an APT CL statement", APT_SUFFIXES) if _APT_LINE.match(text) else (
            ("a G-code block", PROGRAM_SUFFIXES) if "," not in text and _GCODE_LINE.match(text)
            else None)
        if kind is not None:
            raise InputError(f"{name} is read as a waypoint CSV (by its name), but its line "
                             f"{number} ({text.strip()[:40]!r}) is {kind[0]}: give the file "
                             f"one of the suffixes {', '.join(kind[1])} to read it as one")


def run(args: argparse.Namespace) -> int:
    if is_program(args.waypoints):
        return _run_program(args)
    if args.tool is not None or args.stock_box is not None or args.stock_from_program:
        raise InputError("--tool, --stock-box and --stock-from-program check a G-code program "
                         f"against its stock; {args.waypoints} is not a program (.nc, .ngc, "
                         "...): use feedopt validate on a scenario with a stock")
    if args.waypoints not in BUILTIN:
        refuse_misnamed_program(args.waypoints)
    size, spacing = _check_args(args)
    w = BUILTIN[args.waypoints]() if args.waypoints in BUILTIN else read_waypoints_csv(
        args.waypoints)
    path = build_lipb_path(w, args.blend, size, drop_repeated=args.drop_repeated,
                           repeat_hint=REPEAT_HINT)
    vectors = None if args.waypoints in BUILTIN else read_tool_vectors_csv(args.waypoints)
    if vectors is not None:
        orient_waypoints(path, w, vectors, PathlibPath(args.waypoints).name,
                         math.radians(_orientation_tolerance(args)))
    check_sample_count(path.length, spacing, "--spacing")
    _print_summary(args, path, len(w), size)
    _write_outputs(args, path, spacing, w)
    return 0


def _run_program(args: argparse.Namespace) -> int:
    """``feedopt path PROGRAM.nc`` (or an APT CL file): the program's G2 path within the
    tolerances."""
    from feedopt.gcode import read_apt, read_gcode, read_heidenhain
    from feedopt.geometry.program_path import ProgramPathOptions, program_path

    given = any(getattr(args, _dest(name), None) is not None for name in size_parameters())
    size = _size(args) if given else DEFAULT_PROGRAM_BLEND_SIZE_MM * MM
    spacing = _positive_mm(args.spacing, "--spacing", "0.1")
    tol = _positive_mm(args.tolerance_mm, "--tolerance-mm", "0.01")
    air = _positive_mm(args.air_tolerance_mm, "--air-tolerance-mm", "0.5")
    arc_tol = _positive_mm(args.arc_tolerance, "--arc-tolerance", "0.002")
    _orientation_tolerance(args)
    if not np.isfinite(args.stock_top):
        raise InputError(f"--stock-top must be a finite number of mm, got {args.stock_top}")
    if args.max_rows < 0:
        raise InputError(f"--max-rows must be >= 0 (0 = all junction rows), got {args.max_rows}")
    stock = path_stock.check_stock_args(args)
    check_data_and_plot(args.out, args.plot, [args.waypoints], "path.csv", "path.png")
    name = args.waypoints.lower()
    reader = (read_apt if name.endswith(APT_SUFFIXES) else
              read_heidenhain if name.endswith(HEIDENHAIN_SUFFIXES) else read_gcode)
    program = reader(args.waypoints, arc_tolerance_mm=arc_tol / MM)
    result = program_path(program, ProgramPathOptions(
        tolerance=tol, air_tolerance=air, blend=args.blend, blend_size=size,
        stock_top=args.stock_top * MM,
        orientation_tolerance=math.radians(_orientation_tolerance(args))))
    path = result.path
    check_sample_count(path.length, spacing, "--spacing")  # the limit of feedopt run
    kinds = path.segment_kind
    counts = ", ".join(f"{k} {kinds.count(k)}" for k in dict.fromkeys(kinds))
    cats = ", ".join(f"{c} {int(np.sum(result.moves.category == c))}"
                     for c in ("cut", "plunge", "retract", "rapid"))
    print(f"program: {args.waypoints}: {len(program.moves)} moves ({cats})")
    for w in (*program.warnings, *result.warnings):
        print(f"note: {w}")
    _print_chains(result.chains, args.max_rows or None)
    print(f"blend: {args.blend} up to {size * MM_PER_M:g} mm; tolerance {tol * MM_PER_M:g} mm "
          f"(air {air * MM_PER_M:g} mm)")
    print(f"path length: {path.length * MM_PER_M:.6f} mm, segments: {len(kinds)} ({counts})")
    print(result.junctions.table(max_rows=args.max_rows or None))
    if stock:
        print(path_stock.stock_check(args, result, spacing))
    _write_outputs(args, path, spacing, program.ends * MM, program=result)
    return 0


def _print_chains(chains, max_rows: int | None) -> None:
    """One line per smoothed chain; long lists keep head and tail (as the junction table)."""
    shown = list(range(len(chains)))
    if max_rows is not None and len(shown) > max_rows:
        half = max_rows // 2
        shown = shown[:half] + [-1] + shown[-half:]
    for i in shown:
        if i < 0:
            print(f"smoothed chains: ... ({len(chains) - 2 * (max_rows // 2)} more; "
                  "--max-rows 0 lists all)")
            continue
        c = chains[i]
        print(f"smoothed chain: lines {c.first_line}-{c.last_line} ({c.moves} moves, "
              f"{c.length * MM_PER_M:.3f} mm): deviation {c.deviation * MM_PER_M:.3g} mm, "
              f"coverage {c.coverage * MM_PER_M:.3g} mm")


def _check_args(args: argparse.Namespace) -> tuple[float, float]:
    """Blend size and spacing [m]; every option checked before anything is read or built."""
    size = _size(args)
    spacing = _positive_mm(args.spacing, "--spacing", "0.1")
    _orientation_tolerance(args)
    if args.max_rows < 0:
        raise InputError(
            f"--max-rows must be >= 0 (0 = all junction rows), got {args.max_rows}"
        )
    if args.waypoints.startswith("builtin:") and args.waypoints not in BUILTIN:
        raise InputError(
            f"unknown built-in path {args.waypoints!r}; the built-ins are "
            f"{', '.join(BUILTIN)} (or give a CSV file with columns x_mm,y_mm,z_mm)"
        )
    _check_outputs(args)
    return size, spacing


def _check_outputs(args: argparse.Namespace) -> None:
    """--out and --plot: writable files, not the waypoint file, not each other."""
    inputs = [] if args.waypoints in BUILTIN else [args.waypoints]
    check_data_and_plot(args.out, args.plot, inputs, "path.csv", "path.png")


def _print_summary(args: argparse.Namespace, path: Path, n_raw: int, size: float) -> None:
    """Waypoints, dropped waypoints, blend, segments and the continuity table."""
    report = continuity_report(path)
    kinds = path.segment_kind
    counts = ", ".join(f"{k} {kinds.count(k)}" for k in dict.fromkeys(kinds))
    used = len({g.corner_index for g in path.segments if g.corner_index >= 0})
    print(f"waypoints: {n_raw} (from {args.waypoints})")
    rep = path.dropped_waypoints
    if rep:
        shown = ", ".join(str(i) for i in rep[:10]) + (" ..." if len(rep) > 10 else "")
        print(f"dropped {len(rep)} repeated waypoint(s): indices {shown}")
    print(f"blend: {args.blend}" + (f", size {size * MM_PER_M:g} mm" if size else "")
          + f", {used} corner(s) blended")
    print(f"path length: {path.length * MM_PER_M:.6f} mm, segments: {len(kinds)} ({counts})")
    print(report.table(max_rows=args.max_rows or None))


def _write_program_csv(out, data: np.ndarray, path: Path, s: np.ndarray) -> None:
    """The samples with each one's program line, N number, move category and programmed
    feed (empty on rapids)."""
    moves = path.moves
    idx = moves.index_at(s)
    numbers = np.char.mod("%.12g", data)
    feed = moves.feed[idx] * MM_PER_M
    feed_text = np.where(np.isfinite(feed), np.char.mod("%.6g", feed), "")
    n_text = np.where(moves.n_number[idx] >= 0, moves.n_number[idx].astype(str), "")
    cols = [*numbers.T, moves.line[idx].astype(str), n_text, moves.category[idx], feed_text]
    rows = cols[0]
    for c in cols[1:]:
        rows = np.char.add(np.char.add(rows, ","), c)
    with open(out, "w", encoding="utf-8") as fh:
        fh.write(PROGRAM_HEADER.replace(",line,", (AXIS_COLUMNS if path.orientation is not None
                                                   else "") + ",line,") + "\n")
        fh.write("\n".join(rows.tolist()))
        fh.write("\n")


def _write_outputs(args: argparse.Namespace, path: Path, spacing: float, w: np.ndarray,
                   program=None) -> None:
    """The samples CSV (--out) and the figure (--plot)."""
    files: list[tuple[str, Writer, str]] = []
    done: list[str] = []
    if args.out is not None:
        pts = path.sample(spacing)
        data = np.column_stack([pts.s * MM_PER_M, pts.position * MM_PER_M, pts.tangent,
                                pts.curvature * MM]  # curvature 1/m -> 1/mm
                               + ([] if pts.axis is None else [pts.axis]))
        if path.moves is None:
            header = HEADER + ("" if pts.axis is None else AXIS_COLUMNS)
            files.append((args.out, lambda tmp: np.savetxt(
                tmp, data, delimiter=",", header=header, comments="", fmt="%.12g"), "--out"))
        else:
            files.append((args.out, lambda tmp: _write_program_csv(tmp, data, path, pts.s),
                          "--out"))
        done.append(f"wrote {len(pts.s)} samples to {args.out}")
    if args.plot is not None and program is not None:
        from feedopt.geometry.plot import plot_program_path

        files.append((args.plot, lambda tmp: plot_program_path(
            program, tmp, spacing=max(spacing, path.length / 50000),
            title=f"{args.waypoints}: {args.blend}"), "--plot"))
        done.append(f"wrote {args.plot}")
    elif args.plot is not None:
        from feedopt.geometry.plot import plot_path

        files.append((args.plot, lambda tmp: plot_path(
            path, tmp, spacing=max(spacing, path.length / 20000), waypoints=w,
            title=f"{args.waypoints}: {args.blend}"), "--plot"))
        done.append(f"wrote {args.plot}")
    write_files_atomically(files)
    for line in done:
        print(line)

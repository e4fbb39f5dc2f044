"""``feedopt forces``: milling forces over one cutter revolution (thesis Algorithm 1, Fig. 3.11)."""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.outfile import Writer, check_data_and_plot, write_files_atomically
from feedopt.process.coefficients import feed_per_tooth_warning, load_coefficients
from feedopt.process.engagement import MILLING_MODES, peripheral_engagement
from feedopt.process.forces import feed_per_tooth, milling_forces
from feedopt.process.tool import load_tool, wider_above_tip
from feedopt.units import MM, MM_PER_M

HEADER = "angle_deg,fx_n,fy_n,fz_n,f_n,torque_nm,power_w"

#: Largest spindle speed accepted [rpm] (high-speed spindles reach 30-60 krpm).
MAX_RPM = 100_000.0
#: Angular step range [deg] (the scenario's angle_step_deg allows 0.01..10).
STEP_DEG_RANGE = (0.01, 90.0)
#: Axial slice range (as the scenario's axial_slices).
SLICES_RANGE = (1, 500)
#: Largest angles x teeth x slices table (about 190 bytes each, so ~0.4 GB and ~1 s).
MAX_TABLE = 2_000_000


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "forces",
        epilog="docs: docs/calibration.md",
        help="simulate milling forces, torque and power over one cutter revolution",
        description=(
            "Static mechanistic milling force model (thesis Algorithm 1, with axial force). "
            "Forces on the tool in the force-model frame: x feed, y normal, z tool axis. "
            "f_n is the resultant in the x-y plane, as in Algorithm 1; torque is D/2 Ft "
            "(r Ft along the edge of a ball, bull, tapered or face mill: docs/tools.md), "
            "power is torque times spindle angular speed."
        ),
    )
    p.add_argument("--tool", required=True, metavar="YAML", help="cutter file (scenarios/tools)")
    p.add_argument(
        "--coeffs",
        required=True,
        metavar="YAML",
        help="cutting coefficients file (feedopt calibrate --out, scenarios/materials)",
    )
    p.add_argument(
        "--rpm", type=float, required=True, help=f"spindle speed [rpm], (0, {MAX_RPM:g}]"
    )
    p.add_argument(
        "--feed-mm-s",
        type=float,
        required=True,
        help="feed rate [mm/s], > 0; the feed per tooth feed / (rpm / 60 * teeth) must be "
        "below the tool radius, and a warning is printed outside the range the coefficients "
        "were calibrated for (feed_per_tooth_range_mm of the coefficients file)",
    )
    p.add_argument("--axial-depth-mm", type=float, required=True, help="axial depth a [mm]")
    p.add_argument(
        "--radial-depth-mm",
        type=float,
        help="radial depth a_e [mm] (default: the tool diameter, i.e. a slot)",
    )
    p.add_argument("--milling", default="down", help="up or down (default: down)")
    p.add_argument(
        "--step-deg",
        type=float,
        default=1.0,
        help=f"angular step [deg], {STEP_DEG_RANGE[0]:g}..{STEP_DEG_RANGE[1]:g} (default 1); "
        "the revolution gets round(360 / step) equal steps",
    )
    p.add_argument(
        "--axial-slices",
        type=int,
        default=20,
        help=f"axial slices, {SLICES_RANGE[0]}..{SLICES_RANGE[1]} (default 20); angles x teeth "
        f"x slices may be at most {MAX_TABLE:,}",
    )
    p.add_argument(
        "--extrapolate",
        action="store_true",
        help="allow a spindle speed outside the calibrated ones (holds the nearest speed)",
    )
    p.add_argument("--out", metavar="CSV", help="write " + HEADER + " here")
    p.add_argument("--plot", metavar="PNG", help="plot Fx, Fy, Fz, F over the revolution here")
    p.set_defaults(func=run)


def _positive(value: float, option: str, unit: str) -> float:
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{option} must be > 0 {unit}, got {value!r}")
    return value


def _check_outputs(args: argparse.Namespace) -> None:
    """--out and --plot: writable files, not an input file, not each other (before any work)."""
    inputs = [args.tool, args.coeffs]
    check_data_and_plot(args.out, args.plot, inputs, "forces.csv", "forces.png")


def _warn(text: str) -> None:
    print(f"feedopt forces: warning: {text}", file=sys.stderr)


@dataclass(frozen=True)
class _Cut:
    """The checked cut of the command line, SI units."""

    rpm: float
    feed: float  # [m/s]
    axial_depth: float  # [m]
    radial_depth: float  # [m]
    step_deg: float
    count: int  # angles over a revolution


def _depths(args: argparse.Namespace, tool) -> tuple[float, float]:
    """Axial and radial depth [m], within the flutes and the diameter."""
    a = _positive(args.axial_depth_mm, "--axial-depth-mm", "mm") * MM
    if a > tool.flute_length * (1 + 1e-12):
        raise InputError(
            f"--axial-depth-mm {args.axial_depth_mm:g} exceeds the flute length "
            f"{tool.flute_length / MM:g} mm of tool {tool.name!r}"
        )
    if args.radial_depth_mm is None:
        return a, tool.diameter
    ae = _positive(args.radial_depth_mm, "--radial-depth-mm", "mm") * MM
    if ae > tool.diameter * (1 + 1e-12):
        raise InputError(
            f"--radial-depth-mm {args.radial_depth_mm:g} exceeds the tool diameter "
            f"{tool.diameter / MM:g} mm (use the diameter for a slot)"
        )
    return a, ae


def _cut(args: argparse.Namespace, tool) -> _Cut:
    """The cut of the command line, every value checked (InputError naming the option)."""
    rpm = _positive(args.rpm, "--rpm", "rpm")
    if rpm > MAX_RPM:
        raise InputError(
            f"--rpm {rpm:g} is above {MAX_RPM:g} rpm, faster than any milling spindle; give "
            "the spindle speed in rpm (revolutions per minute)"
        )
    feed = _positive(args.feed_mm_s, "--feed-mm-s", "mm/s") * MM
    a, ae = _depths(args, tool)
    if args.milling not in MILLING_MODES:
        raise InputError(f"--milling must be 'up' or 'down', got {args.milling!r}")
    step = args.step_deg
    lo, hi = STEP_DEG_RANGE
    if not (math.isfinite(step) and lo <= step <= hi):
        raise InputError(f"--step-deg must be in [{lo:g}, {hi:g}] deg, got {step!r}")
    lo_l, hi_l = SLICES_RANGE
    if not lo_l <= args.axial_slices <= hi_l:
        raise InputError(
            f"--axial-slices must be a whole number in {lo_l}..{hi_l}, got {args.axial_slices}"
        )
    count = max(1, int(round(360.0 / step)))
    size = count * tool.teeth * args.axial_slices
    if size > MAX_TABLE:
        raise InputError(
            f"--step-deg {step:g} ({count} angles) x {tool.teeth} teeth (tool {tool.name!r}) x "
            f"--axial-slices {args.axial_slices} = {size:,} slice evaluations, more than "
            f"{MAX_TABLE:,} (memory); use a larger --step-deg or fewer --axial-slices"
        )
    return _Cut(rpm, feed, a, ae, step, count)


def _coefficients(args: argparse.Namespace, table, cut: _Cut, tool, c: float):
    """The coefficients at the cut's speed, with the warnings of an extrapolated speed, a
    step that does not divide 360 deg and a feed per tooth outside the calibration."""
    radius = tool.diameter / 2
    if c >= radius:
        feed_max = radius * cut.rpm * tool.teeth / 60.0
        raise InputError(
            f"--feed-mm-s {args.feed_mm_s:g} at {cut.rpm:g} rpm with {tool.teeth} teeth is a "
            f"feed per tooth of {c / MM:g} mm, not below the tool radius {radius / MM:g} mm: "
            "the chip model h = c sin(phi) does not apply (milling feeds are typically "
            f"0.01-0.5 mm per tooth); use a feed below {feed_max / MM:.4g} mm/s at this speed"
        )
    coeffs = table.at(cut.rpm, extrapolate=args.extrapolate)
    if cut.rpm < table.rpm[0] or cut.rpm > table.rpm[-1]:  # only reached with --extrapolate
        near = table.rpm[0] if cut.rpm < table.rpm[0] else table.rpm[-1]
        _warn(
            f"--rpm {cut.rpm:g} is outside the calibrated speeds ({table.rpm[0]:g}.."
            f"{table.rpm[-1]:g} rpm); --extrapolate holds the coefficients of {near:g} rpm"
        )
    if abs(cut.count * cut.step_deg - 360.0) > 1e-9 * 360.0:
        _warn(
            f"--step-deg {cut.step_deg:g} does not divide 360 deg; using {cut.count} steps of "
            f"{360.0 / cut.count:.6g} deg"
        )
    warning = feed_per_tooth_warning(table, c)
    if warning:
        _warn(warning)
    return coeffs


def run(args: argparse.Namespace) -> int:
    _check_outputs(args)
    tool = load_tool(args.tool)
    table = load_coefficients(args.coeffs)
    cut = _cut(args, tool)
    c = feed_per_tooth(cut.feed, cut.rpm, tool.teeth)
    coeffs = _coefficients(args, table, cut, tool, c)
    note = wider_above_tip(tool)
    if note is not None:
        _warn(note)
    eng = peripheral_engagement(np.array([cut.radial_depth]), tool.diameter, cut.axial_depth,
                                args.milling)
    angles = np.arange(cut.count) * (2 * math.pi / cut.count)
    split = milling_forces(tool, coeffs, eng, angles, axial_slices=args.axial_slices)
    f = split.forces(c)[0]
    torque = split.torque(c)[0]
    power = split.power(c, cut.rpm)[0]
    fxy = np.hypot(f[:, 0], f[:, 1])
    series = (f, fxy, torque, power)
    _print_result(args, tool, cut, c, eng, series)
    _write(args, angles, series, cut.count)
    return 0


def _print_result(args, tool, cut: _Cut, c: float, eng, series: tuple) -> None:
    """The cut and the forces over the revolution (``series``: F, |Fxy|, torque, power)."""
    f, fxy, torque, power = series
    print(
        f"tool {tool.name}: D {tool.diameter * MM_PER_M:g} mm, {tool.teeth} teeth, helix "
        f"{math.degrees(tool.helix):g} deg"
        + ("" if tool.is_flat else f", {tool.shape.value}, corner radius "
           f"{tool.corner_radius * MM_PER_M:g} mm, taper {math.degrees(tool.taper):g} deg")
    )
    print(
        f"{cut.rpm:g} rpm, feed {cut.feed * MM_PER_M:g} mm/s -> c = {c * MM_PER_M:.5f} mm/tooth;"
        f" a = {cut.axial_depth * MM_PER_M:g} mm, a_e = {cut.radial_depth * MM_PER_M:g} mm, "
        f"{args.milling} milling: entry {math.degrees(eng.entry[0]):.2f} deg, exit "
        f"{math.degrees(eng.exit[0]):.2f} deg"
    )
    mean = f.mean(axis=0)
    print(f"mean force  Fx {mean[0]:9.2f} N  Fy {mean[1]:9.2f} N  Fz {mean[2]:9.2f} N")
    print(
        f"peak        |Fxy| {fxy.max():8.2f} N  |F| {np.linalg.norm(f, axis=1).max():8.2f} N  "
        f"torque {torque.max():.3f} N m  power {power.max():.1f} W"
    )


def _write(args, angles, series: tuple, count: int) -> None:
    """--out (CSV) and --plot, both or neither written."""
    f, fxy, torque, power = series
    files: list[tuple[str, Writer, str]] = []
    done: list[str] = []
    if args.out is not None:
        data = np.column_stack([np.degrees(angles), f, fxy, torque, power])
        files.append((args.out, lambda tmp: np.savetxt(tmp, data, delimiter=",", header=HEADER,
                                                       comments="", fmt="%.6g"), "--out"))
        done.append(f"wrote {args.out} ({count} angles)")
    if args.plot is not None:
        files.append((args.plot, lambda tmp: _plot(tmp, np.degrees(angles), f, fxy, args),
                      "--plot"))
        done.append(f"wrote {args.plot}")
    write_files_atomically(files)
    for line in done:
        print(line)


def _plot(path: str | Path, deg: np.ndarray, f: np.ndarray, fxy: np.ndarray, args) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    try:
        _draw(fig, ax, deg, f, fxy, args)
        fig.savefig(path, dpi=120)
    finally:
        plt.close(fig)


def _draw(fig, ax, deg: np.ndarray, f: np.ndarray, fxy: np.ndarray, args) -> None:
    for k, name in enumerate(("Fx (feed)", "Fy (normal)", "Fz (axial)")):
        ax.plot(deg, f[:, k], label=name)
    ax.plot(deg, fxy, "k", lw=1.5, label="F (x-y resultant)")
    ax.set_xlabel("rotation angle of tooth 1 [deg]")
    ax.set_ylabel("force on the tool [N]")
    ax.set_title(
        f"{args.milling} milling, {args.rpm:g} rpm, {args.feed_mm_s:g} mm/s, "
        f"a = {args.axial_depth_mm:g} mm"
    )
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()

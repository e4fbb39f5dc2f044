"""Generate a 3D raster finishing program of a given number of lines, in the style of a CAM post.

The surface is a sum of sines, z(x, y) = -depth/2 + sum_k a_k sin(2 pi x / wx_k + phase_k)
sin(2 pi y / wy_k), cut flat at a floor, machined by a zigzag raster: rows along X at a
step-over in Y, one G1 X Y Z every ``step`` along the row (3 decimals, as CAM posts write mm;
the inner points of flat runs dropped, so the floor is crossed by long single moves), the
step-over a single G1 across at the row end. The part grows with the number of lines (the
row length and the number of rows both about sqrt(lines)), so the path length grows
linearly with the program. Real CAM rasters mix the same three things: runs of short nearly
tangent moves (smoothed), long moves (lines), and corners between them.

The program reads like a post's output (cf. tests/data/gcode/posts/): a header, a safety line
(G21 G90 G17), the tool comment "(T1 D=6. CR=0. - ZMIN=... - flat end mill)", M6 T1, S, M3, a
G0 approach, a G1 plunge at the plunge feed, the rows (F on the first cutting move), a
retract, M5 M30.

    .venv/bin/python benchmarks/raster_program.py 70000 /tmp/raster70k.nc
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

#: point spacing along a row and step-over [mm]
STEP_MM = 0.5
STEP_OVER_MM = 1.0
DEPTH_MM = 3.0
FLOOR_MM = -2.0  # the surface is cut flat below this
CLEARANCE_MM = 5.0
FEED_MM_MIN = 1200.0
PLUNGE_MM_MIN = 300.0
SPINDLE_RPM = 18000
HEADER_LINES = 15  # lines written besides the rows (header, approach, retract, end)


def surface_mm(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """z of the surface [mm] at (x, y) [mm]: a sum of three sine products about -depth/2,
    cut flat at ``FLOOR_MM`` (a pocket floor: flat runs the post writes as single long moves)."""
    z = (0.6 * np.sin(2 * np.pi * x / 37.0) * np.sin(2 * np.pi * y / 23.0)
         + 0.5 * np.sin(2 * np.pi * x / 11.0 + 0.7) * np.sin(2 * np.pi * y / 41.0 + 0.3)
         + 0.3 * np.sin(2 * np.pi * (x + y) / 17.0))
    return np.maximum(-0.5 * DEPTH_MM + z, FLOOR_MM)


def raster_width_mm(lines: int) -> float:
    """Row length [mm] of a program of ``lines`` lines: rows ~ points per row / 2."""
    body = max(lines - HEADER_LINES, 8)
    return max(4.0, STEP_MM * round(math.sqrt(body * STEP_OVER_MM / STEP_MM)))


def _row(xs: np.ndarray, y: float) -> tuple[np.ndarray, np.ndarray]:
    """x, z [mm] of one row as a post writes them: 3 decimals, the inner points of runs at
    one height (flat floor) dropped, as a post's collinear filter does."""
    z = np.round(surface_mm(xs, np.full_like(xs, y)), 3)
    flat = np.zeros(xs.size, dtype=bool)
    flat[1:-1] = (z[1:-1] == z[:-2]) & (z[1:-1] == z[2:])
    return xs[~flat], z[~flat]


def raster_lines(lines: int) -> list[str]:
    """The program text, one string per line, ``lines`` of them (the last row cut short
    where the count is reached; at least 24)."""
    xs = np.arange(round(raster_width_mm(lines) / STEP_MM) + 1) * STEP_MM
    body: list[str] = []
    z_min = float("inf")
    r = 0
    target = max(lines - HEADER_LINES, 8) + 1  # + the plunge's end point
    while len(body) < target:
        y = r * STEP_OVER_MM
        x, z = _row(xs if r % 2 == 0 else xs[::-1], y)
        z_min = min(z_min, float(z.min()))
        # a row's first point is the step-over move from the previous row's end
        body += [f"G1 X{a:.3f} Y{y:.3f} Z{b:.3f}" for a, b in zip(x, z, strict=True)]
        r += 1
    body = body[:target]
    first_z = float(surface_mm(xs[:1], np.zeros(1))[0])
    body[1] = body[1] + f" F{FEED_MM_MIN:.0f}."  # body[0] is where the plunge ends
    head = [
        "%",
        f"O2801 (RASTER {r} ROWS X {xs[-1]:.1f} MM)",
        f"(T1 D=6. CR=0. - ZMIN={z_min:.3f} - flat end mill)",
        "G21 G90 G17",
        "G0 G40 G49 G80",
        "M6 T1",
        f"S{SPINDLE_RPM} M3",
        f"G0 X{xs[0]:.3f} Y0.000",
        f"G0 Z{CLEARANCE_MM:.3f}",
        f"G1 Z{first_z + 1.0:.3f} F{PLUNGE_MM_MIN:.0f}.",
        f"G1 Z{first_z:.3f}",
    ]
    tail = [f"G0 Z{CLEARANCE_MM:.3f}", "M5", "M30", "%"]
    return head + body[1:] + tail


def write_raster(lines: int, out: Path) -> int:
    """Write the program of about ``lines`` lines to ``out``; returns the number written."""
    text = raster_lines(lines)
    out.write_text("\n".join(text) + "\n", encoding="ascii")
    return len(text)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("lines", type=int, help="number of program lines (about)")
    p.add_argument("out", type=Path, help="the program file (.nc)")
    args = p.parse_args(argv)
    n = write_raster(args.lines, args.out)
    print(f"wrote {n} lines to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

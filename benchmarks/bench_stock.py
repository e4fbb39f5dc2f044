"""Benchmark of the Z-map stock sweep (feedopt.process.stock.sweep) on a pocket-like path.

A 120 x 80 x 30 mm box (0.25 mm cells, 480 x 320 cells) cleared by a 19.05 mm flat end mill
(R = 9.525 mm) along contour-parallel rounded rectangles, inside out with 40 % step-over,
levels 2 mm apart, each entered by a 20 mm straight ramp; 1e5 samples 0.1 mm apart.
Prints the sweep time (best of ``--repeat`` runs, each on a fresh stock), the growth of the
process's peak resident memory during it, and checks that the removed volumes add up.
``--traced`` adds a run under tracemalloc for the peak of the arrays the sweep allocates
(precise but about 8 times slower).

    .venv/bin/python benchmarks/bench_stock.py              # 1e5 samples
    .venv/bin/python benchmarks/bench_stock.py --quick      # 1e4 samples
    .venv/bin/python benchmarks/bench_stock.py --traced     # + tracemalloc peak
"""

from __future__ import annotations

import argparse
import math
import resource
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from feedopt.process.stock import FlatEndMill, ZMap, angle_error_bound, sweep  # noqa: E402

MM = 1e-3
RADIUS = 9.525 * MM
BOX = (0.0, 120 * MM, 0.0, 80 * MM, 0.0, 30 * MM)
SPACING = 0.1 * MM


def _rounded_rectangle(cx, cy, hx, hy, rho, z, step=0.02 * MM):
    """Closed counter-clockwise loop starting and ending at (cx + hx, cy), at height z."""
    rho = min(rho, hx, hy)
    pts = []
    corners = [(hx - rho, hy - rho), (-(hx - rho), hy - rho), (-(hx - rho), -(hy - rho)),
               (hx - rho, -(hy - rho))]
    pts.append((cx + hx, cy))
    for k, (ox, oy) in enumerate(corners):
        a = np.linspace(k * math.pi / 2, (k + 1) * math.pi / 2, max(2, int(rho * 1.6 / step)))
        pts.extend(zip(cx + ox + rho * np.cos(a), cy + oy + rho * np.sin(a), strict=True))
    pts.append((cx + hx, cy))
    xy = np.array(pts)
    return np.column_stack([xy, np.full(len(xy), z)])


def pocket_path(n: int = 100_000, step_over: float = 0.4 * 2 * RADIUS, level_step=2 * MM):
    """Tool tip positions (n, 3) [m] every SPACING and their tangents for the pocket."""
    cx, cy = 60 * MM, 40 * MM
    wall = 5 * MM
    hx0, hy0 = 60 * MM - wall - RADIUS, 40 * MM - wall - RADIUS
    loops = []
    k = 0
    while hy0 - k * step_over > 0.5 * MM:
        d = k * step_over
        loops.append((hx0 - d, hy0 - d, max(12 * MM - RADIUS - d, 2 * MM)))
        k += 1
    loops.reverse()  # inside out
    pieces = []
    z_prev = BOX[5]
    ramp_start = np.array([cx - 20 * MM, cy])
    z_level = z_prev
    length = 0.0
    while length < (n + 10) * SPACING:
        z_level -= level_step
        if z_level <= BOX[4] + 1 * MM:
            raise ValueError("stock too thin for that many samples")
        level = [np.array([[*ramp_start, z_prev], [cx, cy, z_level]])]
        for hx, hy, rho in loops:
            level.append(np.array([[cx + hx, cy, z_level]]))
            level.append(_rounded_rectangle(cx, cy, hx, hy, rho, z_level))
        level.append(np.array([[*ramp_start, z_level]]))
        poly = np.concatenate(level)
        pieces.append(poly)
        length += np.linalg.norm(np.diff(poly[:, :2], axis=0), axis=1).sum()
        z_prev = z_level
    poly = np.concatenate(pieces)
    seg = np.linalg.norm(np.diff(poly, axis=0), axis=1)
    keep = np.concatenate([[True], seg > 0])
    poly = poly[keep]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(poly, axis=0), axis=1))])
    t = np.arange(n) * SPACING
    pos = np.column_stack([np.interp(t, s, poly[:, i]) for i in range(3)])
    return pos, np.gradient(pos, axis=0)


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux


def main(quick: bool = False, repeat: int = 1, traced: bool = False,
         cell_mm: float = 0.25) -> dict[str, float]:
    n = 10_000 if quick else 100_000
    pos, tan = pocket_path(n)
    tool = FlatEndMill(RADIUS, 25 * MM)
    stock0 = ZMap.box(*BOX, cell=cell_mm * MM)
    steps = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    level = np.concatenate([[False], pos[1:, 2] == pos[:-1, 2]])
    print(
        f"sweep: {n} samples every {steps.mean() / MM:.3f} mm ({steps.sum():.2f} m, "
        f"{100 * level.mean():.1f} % at a constant tip height), Z-map {stock0.shape[0]} x "
        f"{stock0.shape[1]} cells of {stock0.cell / MM:g} mm ({stock0.nbytes / 1e6:.2f} MB), "
        f"R = {RADIUS / MM:g} mm"
    )
    rss0 = _peak_rss_mb()
    times = []
    for _ in range(repeat):
        stock = stock0.copy()
        t0 = time.perf_counter()
        res = sweep(stock, tool, pos, tan)
        times.append(time.perf_counter() - t0)
    elapsed = min(times)
    rss1 = _peak_rss_mb()
    before, after = stock0.volume(), stock.volume()
    rel = abs(res.removed.sum() - (before - after)) / (before - after)
    print(f"  time {elapsed:.2f} s ({elapsed / n * 1e6:.1f} us per sample, best of {repeat})")
    err = math.degrees(float(angle_error_bound(math.pi / 2, stock0.cell, RADIUS)))
    err60 = math.degrees(float(angle_error_bound(math.pi / 3, stock0.cell, RADIUS)))
    print(f"  angle error bound of a wall along the feed: {err:.2f} deg at 90 deg, {err60:.2f} "
          f"deg at 60 deg; {int(res.engagement.pieced.sum())} samples on several pieces "
          f"({res.intervals.count} pieces in all)")
    print(
        f"  cutting at {100 * (~res.in_air).mean():.1f} % of the samples; removed "
        f"{res.removed.sum() * 1e9:.0f} mm^3 = volume before - after within {rel:.1e}"
    )
    print(f"  peak resident memory {rss1:.0f} MB (+{rss1 - rss0:.0f} MB during the sweep; "
          f"inputs {pos.nbytes * 2 / 1e6:.1f} MB, Z-map {stock.nbytes / 1e6:.2f} MB)")
    out = {"sweep": elapsed, "peak_rss_mb": rss1}
    if traced:
        stock = stock0.copy()
        tracemalloc.start()
        sweep(stock, tool, pos, tan)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        print(f"  peak traced memory during sweep {peak / 1e6:.1f} MB")
        out["peak_traced_mb"] = peak / 1e6
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1e4 samples")
    parser.add_argument("--repeat", type=int, default=1, help="timed runs (best is shown)")
    parser.add_argument("--traced", action="store_true", help="also a tracemalloc run (slow)")
    parser.add_argument("--cell", type=float, default=0.25, metavar="MM",
                        help="Z-map cell size [mm] (0.2 mm keeps the angles within 1 deg)")
    args = parser.parse_args()
    main(args.quick, args.repeat, args.traced, args.cell)

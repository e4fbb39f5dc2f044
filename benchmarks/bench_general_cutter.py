"""The cost of a general cutter's forces (issue 34) against the flat end mill's, back to back.

The flat end mill keeps the O(1)-per-tooth-and-angle prefix sums of Algorithm 1
(:mod:`feedopt.process.force_sums`); a ball, bull, tapered or face mill sums its slices
directly (each slice has its own radius, immersion and interval: no prefix sum carries over),
one batched product per block (:mod:`feedopt.process.general_forces`). This measures both on
the same engagements: distinct random intervals and depths at 2 000 samples, on the uniform
angle grid (``milling_forces``) and at each sample's critical angles (``milling_forces_at``),
and a stock-like engagement with 4 pieces per sample.

    .venv/bin/python benchmarks/bench_general_cutter.py
        [--out benchmarks/results/general_cutter.txt]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from feedopt.process.coefficients import CuttingCoefficients
from feedopt.process.cutter import CutterShape
from feedopt.process.engagement import Engagement, EngagementPieces
from feedopt.process.forces import critical_angles, milling_forces, milling_forces_at
from feedopt.process.tool import Tool

COEFFS = CuttingCoefficients(8.57e8, 3.19e8, -1.05e8, 7.42e3, 8.45e3, -2.13e3)  # Table 3.3
D, FLUTE, N, HELIX = 10e-3, 20e-3, 2, math.radians(30.0)
TOOLS = {
    "flat": Tool("flat", D, N, HELIX, FLUTE),
    "ball": Tool("ball", D, N, HELIX, FLUTE, shape=CutterShape.BALL, corner_radius=D / 2),
    "bull": Tool("bull", D, N, HELIX, FLUTE, shape=CutterShape.BULL, corner_radius=1e-3),
}
SAMPLES, SLICES = 2000, 20


def engagements(n: int, seed: int = 0) -> tuple[Engagement, Engagement]:
    """(one interval per sample, four pieces per sample), distinct rows."""
    rng = np.random.default_rng(seed)
    entry = rng.uniform(0.0, 1.0, n)
    exit_ = np.minimum(entry + rng.uniform(0.5, 2.0, n), math.pi)
    depth = rng.uniform(0.5e-3, 6e-3, n)
    plain = Engagement(entry, exit_, depth)
    cuts = np.sort(rng.uniform(0.0, math.pi, (n, 5)), axis=1)
    d = rng.uniform(0.5e-3, 6e-3, (n, 4))
    pieces = EngagementPieces(np.repeat(np.arange(n), 4), cuts[:, :4].ravel(),
                              cuts[:, 1:].ravel(), d.ravel())
    return plain, Engagement(cuts[:, 0], cuts[:, 4], d.max(axis=1), pieces=pieces)


def _best(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path)
    args = p.parse_args(argv)
    grid = np.linspace(0.0, math.pi, 180, endpoint=False)  # 1 deg over a 2-tooth pitch
    plain, pieced = engagements(SAMPLES)
    lines = [f"{SAMPLES} samples, {SLICES} slices, {N} teeth; best of 3 [s]",
             "| cutter | grid, 1 interval | critical angles, 1 interval | grid, 4 pieces | "
             "critical angles, 4 pieces |", "|:--|--:|--:|--:|--:|"]
    for name, tool in TOOLS.items():
        cells = []
        for eng in (plain, pieced):
            crit = critical_angles(tool, eng, SLICES)
            cells.append(_best(lambda t=tool, e=eng: milling_forces(t, COEFFS, e, grid, SLICES)))
            cells.append(_best(lambda t=tool, e=eng, c=crit: milling_forces_at(
                t, COEFFS, e, c, SLICES)))
        lines.append(f"| {name} | {cells[0]:.3f} | {cells[1]:.3f} | {cells[2]:.3f} | "
                     f"{cells[3]:.3f} |")
        print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

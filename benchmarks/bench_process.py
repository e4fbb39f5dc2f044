"""Benchmark of the process stage: milling forces for many path samples.

Run: ``.venv/bin/python benchmarks/bench_process.py [--quick]``. Prints timings and returns them
from :func:`main` (seconds, best of ``repeat`` runs) for a combined benchmark.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from feedopt.process import (
    CuttingCoefficients,
    Engagement,
    Tool,
    average_forces,
    feed_per_tooth,
    milling_forces,
    peripheral_engagement,
    radial_depth_profile,
    rotation_angles,
    slot_engagement,
)

TOOL = Tool("2-flute 19.05 mm HSS TiN", 19.05e-3, 2, math.radians(30.0), 23.8125e-3)
COEFFS = CuttingCoefficients(8.57e8, 3.19e8, -1.05e8, 7.42e3, 8.45e3, -2.13e3)  # Table 3.3


def _best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(quick: bool = False) -> dict[str, float]:
    """Time ``milling_forces`` (n samples x 360 angles x 20 slices) and the closed form."""
    n = 1000 if quick else 10_000
    repeat = 2 if quick else 5
    angles = rotation_angles(360)
    s = np.linspace(0.0, 0.2032, n)
    ramp = radial_depth_profile(s, [0.0, 0.2032], [0.0, 9.525e-3])  # chapter 4, all distinct
    cases = {
        "slot (1 distinct engagement)": slot_engagement(n, 1.27e-3),
        "ch.4 ramp, down milling (all distinct)": peripheral_engagement(
            ramp, TOOL.diameter, 2.54e-3, "down"
        ),
        "entry and exit both varying": Engagement(
            np.linspace(0.0, 1.0, n), np.linspace(2.0, 3.0, n), np.full(n, 2.54e-3)
        ),
        "axial depth varying (all distinct)": slot_engagement(n, np.linspace(1e-3, 5e-3, n)),
    }
    results: dict[str, float] = {}
    print(f"milling_forces: {n} samples x {angles.size} angles x 20 slices x {TOOL.teeth} teeth")
    for name, eng in cases.items():
        t = _best(lambda eng=eng: milling_forces(TOOL, COEFFS, eng, angles, 20), repeat)
        results[f"milling_forces[{name}]"] = t
        print(f"  {name:42s} {t * 1e3:8.1f} ms")
    eng = cases["ch.4 ramp, down milling (all distinct)"]
    c = feed_per_tooth(4.23e-3, 2000, TOOL.teeth)
    t = _best(lambda: average_forces(TOOL, COEFFS, eng.entry, eng.exit, eng.axial_depth, c), repeat)
    results["average_forces"] = t
    print(f"average_forces (closed form), {n} samples          {t * 1e3:8.2f} ms")
    return results


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1,000 samples, 2 repeats")
    main(parser.parse_args().quick)

"""Benchmark of the geometry stage: build and sample a 10,000-waypoint random 3D polyline.

Run: ``.venv/bin/python benchmarks/bench_geometry.py [--quick]``. The polyline has steps of
2-8 mm in random 3D directions with turns of at most 90 deg; blends of size 1 mm (radius or
tolerance); samples every 0.1 mm (about 0.5 million samples).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from feedopt.geometry.continuity import continuity_report
from feedopt.geometry.path import build_lipb_path

KINDS = ("circle", "bezier4", "bezier5", "varying_radius")


def random_polyline(n: int, seed: int = 0) -> np.ndarray:
    """n waypoints [m], steps 2-8 mm, turning at most 90 deg at each corner."""
    rng = np.random.default_rng(seed)
    d = np.empty((n - 1, 3))
    d[0] = (1.0, 0.0, 0.0)
    for i in range(1, n - 1):
        while True:
            v = d[i - 1] + rng.normal(size=3)
            v /= np.linalg.norm(v)
            if v @ d[i - 1] > 0.05:
                break
        d[i] = v
    step = rng.uniform(2e-3, 8e-3, size=n - 1)
    return np.vstack([np.zeros(3), np.cumsum(d * step[:, None], axis=0)])


def main(quick: bool = False) -> dict[str, float]:
    """Time build + sample at 0.1 mm for every blend kind; returns seconds per step."""
    n = 1000 if quick else 10_000
    w = random_polyline(n)
    timings: dict[str, float] = {}
    for kind in KINDS:
        t0 = time.perf_counter()
        path = build_lipb_path(w, kind, 1e-3)
        t1 = time.perf_counter()
        pts = path.sample(1e-4)
        t2 = time.perf_counter()
        rep = continuity_report(path)
        t3 = time.perf_counter()
        timings[f"{kind}_build_s"] = t1 - t0
        timings[f"{kind}_sample_s"] = t2 - t1
        timings[f"{kind}_total_s"] = t2 - t0
        timings[f"{kind}_continuity_s"] = t3 - t2
        print(f"{kind:>15}: {n} waypoints, length {path.length:.3f} m, {len(pts.s)} samples: "
              f"build {t1 - t0:.3f} s, sample {t2 - t1:.3f} s, total {t2 - t0:.3f} s "
              f"(continuity report {t3 - t2:.3f} s, max G2 jump {rep.max()[2]:.3g} 1/m)")
    return timings


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="1,000 waypoints instead of 10,000")
    main(ap.parse_args().quick)

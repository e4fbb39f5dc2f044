"""Benchmark of ``feedopt sweep``: points per second on 1 and 2 Dask workers.

The triangle slot (scenarios/triangle_slot.yaml, all five laws) sampled every 1 mm (494
samples), over a grid of workpiece placements: x 1600..1900 mm by 100 and z 700..1000 mm by
100 (16 points, all reachable). For this process alone (no Dask, the reference) and for a
local cluster of 1 and of 2 worker processes it prints the start-up time (cluster start,
workers importing the pipeline and the laws, the scenario sent to them), the time to
evaluate the points as they stream back, points per second, and each worker's peak resident
memory. It checks that every mode gives the same table (bit-identical numbers), and prints
the load average, since other processes on the machine share its cores.

    .venv/bin/python benchmarks/bench_sweep.py            # 16 points
    .venv/bin/python benchmarks/bench_sweep.py --quick    # 4 points
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from feedopt.sweep.bundle import build_bundle  # noqa: E402
from feedopt.sweep.execute import _worker_ready, dask_evaluator, evaluate_serial  # noqa: E402
from feedopt.sweep.grid import parse_grid  # noqa: E402
from feedopt.sweep.point import PointSettings  # noqa: E402
from feedopt.sweep.table import columns, to_row  # noqa: E402

SPACING_MM = 1.0


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _rows(results, grid, laws) -> dict:
    header = [c for c in columns(grid.axes, laws, []) if c != "seconds"]
    out = {}
    for r in results:
        row = to_row(r, grid.axes, laws, [])
        out[tuple(r.values)] = [row[c] for c in header]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="4 points instead of 16")
    args = parser.parse_args()
    spec = ("workpiece.position_mm=x:1600:1700:100,z:700:800:100" if args.quick
            else "workpiece.position_mm=x:1600:1900:100,z:700:1000:100")
    bundle, scenario = build_bundle(ROOT / "scenarios" / "triangle_slot.yaml")
    grid = parse_grid([spec], bundle.raw, bundle.robot_doc)
    laws = tuple(scenario.schedule.laws)
    settings = PointSettings(laws, SPACING_MM)
    points = list(grid.points())
    print(f"triangle slot every {SPACING_MM:g} mm, laws {', '.join(laws)}; grid {spec} "
          f"({len(points)} points); {os.cpu_count()} cores, load average before "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")

    t0 = time.perf_counter()
    _worker_ready(laws)  # what each worker does before its first point: the imports
    start = time.perf_counter() - t0
    t0 = time.perf_counter()
    reference = list(evaluate_serial(bundle, grid.axes, points, settings))
    run = time.perf_counter() - t0
    print(f"{'mode':<16} {'start s':>8} {'points s':>9} {'points/s':>9} {'s/point':>8} "
          f"{'peak RSS per process MB':>24}")
    print(f"{'this process':<16} {start:8.2f} {run:9.2f} {len(points) / run:9.2f} "
          f"{run / len(points):8.3f} {_peak_rss_mb():24.0f}   (start: reading the scenario "
          "had already imported most)")
    expected = _rows(reference, grid, laws)

    for workers in (1, 2):
        from distributed import default_client

        t0 = time.perf_counter()
        with dask_evaluator(bundle, grid.axes, settings, workers=workers) as evaluate:
            start = time.perf_counter() - t0
            t0 = time.perf_counter()
            results = list(evaluate(points))
            run = time.perf_counter() - t0
            rss = default_client().run(_peak_rss_mb)
        same = _rows(results, grid, laws) == expected
        print(f"{f'{workers} worker(s)':<16} {start:8.2f} {run:9.2f} {len(points) / run:9.2f} "
              f"{run / len(points):8.3f} {' / '.join(f'{v:.0f}' for v in rss.values()):>24}"
              f"   results {'identical to this process' if same else 'DIFFER'}")
    print(f"load average after {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()

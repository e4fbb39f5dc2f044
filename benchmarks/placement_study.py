"""How the triangle-slot results depend on the workpiece placement (not given in the thesis).

A call of ``feedopt sweep`` (:func:`feedopt.sweep.run_sweep`): the workpiece origin over
x 1600/1750/1900, y -300/-38.1/250, z 500/800/1100 mm in the robot base frame (tool axis
vertical), the thesis law at 1 mm sampling. Prints per placement the largest predicted
deflection at the constant nominal 4.23 mm/s, the thesis law's feeds on the up (+y) and down
(-y) lines (thesis: 2.75 and 4.02 mm/s) and their ratio down/up (thesis: 1.46), the lower bound T*
and the worst Jacobian condition number; then the placement with the smallest T* and the
one whose up/down ratio is closest to the thesis's. The sweep's folder
(``out/placement_study``: table, heat maps, best.json) is resumed when run again.

    .venv/bin/python benchmarks/placement_study.py [--workers N | --scheduler ADDRESS]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from feedopt.sweep import Execution, SweepSettings, run_sweep  # noqa: E402

GRID = "workpiece.position_mm=x:1600;1750;1900,y:-300;-38.1;250,z:500;800;1100"
THESIS_RATIO = 4.02 / 2.75  # down / up line feeds of the thesis


def line_feeds(prepared, trajectory) -> tuple[float, float]:
    """Mean feed [mm/s] of ``trajectory`` in the middle of the up and of the down lines."""
    up, down = [], []
    for a, b, kind in prepared.problem.segments():
        if kind != "line":
            continue
        mid = np.array([0.5 * (a + b)])
        ty = prepared.path.evaluate(mid).tangent[0, 1]
        (up if ty > 0 else down).append(trajectory.feed_at(mid)[0] * 1e3)
    return float(np.mean(up)), float(np.mean(down))


def up_feed(prepared, results) -> float:
    return line_feeds(prepared, results["thesis"].trajectory)[0]


def down_feed(prepared, results) -> float:
    return line_feeds(prepared, results["thesis"].trajectory)[1]


def _number(text: str) -> float:
    return float(text) if text else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, help="local worker processes (default: cores)")
    parser.add_argument("--scheduler", help="a running Dask scheduler (tcp://host:8786)")
    parser.add_argument("--out", default=str(ROOT / "out" / "placement_study"))
    args = parser.parse_args()
    result = run_sweep(
        ROOT / "scenarios" / "triangle_slot.yaml", [GRID], out_dir=args.out,
        settings=SweepSettings(laws=["thesis"], spacing_mm=1.0,
                               extra=[("up_feed_mm_s", up_feed), ("down_feed_mm_s", down_feed)]),
        execution=Execution(scheduler=args.scheduler, workers=args.workers))
    names = [a.name for a in result.grid.axes]
    print(f"{'x_mm':>7} {'y_mm':>7} {'z_mm':>6} {'const defl mm':>13} {'up mm/s':>8} "
          f"{'down mm/s':>9} {'down/up':>7} {'T* s':>7} {'max cond':>8}")
    closest = None
    for row in result.rows:
        x, y, z = (float(row[n]) for n in names)
        if row["status"] != "ok":
            print(f"{x:7.1f} {y:7.1f} {z:6.0f}  not plannable: {row['reason'][:60]}")
            continue
        up, down = _number(row["up_feed_mm_s"]), _number(row["down_feed_mm_s"])
        if closest is None or abs(down / up - THESIS_RATIO) < abs(closest[1] - THESIS_RATIO):
            closest = ((x, y, z), down / up)
        print(f"{x:7.1f} {y:7.1f} {z:6.0f} {_number(row['max_deflection_nominal_mm']):13.3f} "
              f"{up:8.3f} {down:9.3f} {down / up:7.3f} {_number(row['t_star_s']):7.1f} "
              f"{_number(row['max_condition_number']):8.1f}")
    if result.best is not None:
        best = tuple(float(result.best[n]) for n in names)
        print(f"smallest T*: {result.best_value:.2f} s at {best} mm")
    if closest is not None:
        print(f"down/up ratio closest to the thesis's {THESIS_RATIO:.2f}: "
              f"{closest[1]:.2f} at {closest[0]} mm")
    print(f"sweep folder: {result.out_dir} ({result.evaluated} points evaluated now, "
          f"{result.reused} from its table)")


if __name__ == "__main__":
    main()

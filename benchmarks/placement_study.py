"""How the triangle-slot results depend on the workpiece placement (not given in the thesis).

For a grid of workpiece origins in the robot base frame (tool axis vertical), runs the
pipeline up to the feed bound and the thesis law at 1 mm sampling and prints: the largest
predicted deflection at the constant 4.23 mm/s, the thesis law's feeds on the up (+y) and
down (-y) lines (thesis: 2.75 and 4.02 mm/s) and the lower bound T*.

    .venv/bin/python benchmarks/placement_study.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from feedopt.errors import InputError  # noqa: E402
from feedopt.runner import prepare  # noqa: E402
from feedopt.scenario import load_scenario  # noqa: E402
from feedopt.schedule.thesis import plan_thesis  # noqa: E402


def line_feeds(prepared, trajectory) -> tuple[float, float]:
    """Mean thesis-law feed [mm/s] in the middle of the up and of the down lines."""
    up, down = [], []
    for a, b, kind in prepared.problem.segments():
        if kind != "line":
            continue
        mid = np.array([0.5 * (a + b)])
        ty = prepared.path.evaluate(mid).tangent[0, 1]
        (up if ty > 0 else down).append(trajectory.feed_at(mid)[0] * 1e3)
    return float(np.mean(up)), float(np.mean(down))


def main() -> None:
    scenario, base = load_scenario(ROOT / "scenarios" / "triangle_slot.yaml")
    print(f"{'x_mm':>7} {'y_mm':>7} {'z_mm':>6} {'const defl mm':>13} {'up mm/s':>8} "
          f"{'down mm/s':>9} {'T* s':>7} {'max cond':>8}")
    for x in (1600.0, 1750.0, 1900.0):
        for y in (-300.0, -38.1, 250.0):
            for z in (500.0, 800.0, 1100.0):
                wp = scenario.workpiece.model_copy(update={"position_mm": [x, y, z]})
                sc = scenario.model_copy(update={"workpiece": wp})
                try:
                    p = prepare(sc, base, lambda _m: None, spacing_mm=1.0)
                except InputError as exc:
                    print(f"{x:7.1f} {y:7.1f} {z:6.0f}  not plannable: {str(exc)[:60]}")
                    continue
                d = p.model.deflection(np.full(p.problem.n, 4.23e-3))
                up, down = line_feeds(p, plan_thesis(p.problem))
                print(f"{x:7.1f} {y:7.1f} {z:6.0f} {d.max() * 1e3:13.3f} {up:8.3f} {down:9.3f} "
                      f"{p.problem.lower_bound_time():7.1f} "
                      f"{np.max(p.ik.condition_number):8.1f}", flush=True)


if __name__ == "__main__":
    main()

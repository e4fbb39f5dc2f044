"""Benchmark of the rotation about the tool axis (feedopt.robot.redundancy, issue 14).

T* (= integral ds / v_max) with the nearest IK and with the optimised profile psi(s), on the
triangle and square slots at their default spacing (0.1 mm; the search runs on a 1 mm
resampling), the time the optimisation takes, and every law's cycle time on both robot
stages (planned and replay-verified as in a run). Three cells:

* ``coaxial``: the bundled KR500-3 as the scenarios use it (spindle along A6). Turning about
  the tool axis turns A6 only: nothing to gain, by construction (T* at a constant 90 deg
  offset is printed as the check).
* ``side 1.5``: the same robot with the spindle mounted at 90 deg to A6 (a bracket 150 mm out
  along A6, tool tip 300 mm off the A6 axis: ``robot.yaml`` ``tool.tcp_xyz_mm [150, 0,
  -300]``, ``tcp_rpy_deg [0, 0, 0]``), written to a temporary robot directory, with the
  scenarios' 1.5 mm depth.
* ``side 2.54``: that mount at the thesis's suggested depth of 2.54 mm (where the deflection
  limit binds); ``side 2.54 v`` the same with ``path_acceleration=False`` (only the velocity
  term of the joint accelerations is bounded, so psi may turn faster), and on the triangle
  ``side 2.54 k24`` with 24 knots and 1500 evaluations.

    .venv/bin/python benchmarks/bench_redundancy.py            # both slots, + 24 knots
    .venv/bin/python benchmarks/bench_redundancy.py --quick    # triangle only, no laws
    .venv/bin/python benchmarks/bench_redundancy.py --pocket   # + the G-code pocket (~5 min)
    .venv/bin/python benchmarks/bench_redundancy.py --pocket \\
        --out benchmarks/results/bench_redundancy.txt

``--pocket`` adds scenarios/pocket.yaml (2.18 m, engagement from the stock) on the side mount,
searched on a 2 mm resampling: with its 0.25 mm limit this mount never reaches the limit, so
it runs at 0.15 mm too.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from feedopt.robot.redundancy import (  # noqa: E402
    RedundancyOptions,
    RedundancyTask,
    evaluate_profile,
    optimise_redundancy,
    stiffness_ellipses,
)
from feedopt.runner import plan_and_verify, prepare  # noqa: E402
from feedopt.scenario import load_scenario  # noqa: E402
from feedopt.schedule.stage import schedule_problem  # noqa: E402

KUKA = ROOT / "robots" / "kuka_kr500_3"
SCENARIOS = ROOT / "scenarios"
SIDE_START_DEG = [20.94, -46.16, 102.4, 96.19, -94.12, -33.54]
SEARCH_MM = 1.0


def prepared(name: str, tmp: Path, robot_dir: Path | None, depth: float | None,
             spacing: float, limit: float | None = None):
    doc = yaml.safe_load((SCENARIOS / f"{name}.yaml").read_text())
    if robot_dir is None:
        doc["robot"]["directory"] = str(KUKA)
    else:
        doc["robot"]["directory"] = str(robot_dir)
        doc["robot"]["start_configuration_deg"] = SIDE_START_DEG
    doc["tool"] = str(SCENARIOS / doc["tool"])
    doc["material"] = str(SCENARIOS / doc["material"])
    if depth is not None:
        doc["cut"]["axial_depth_mm"] = depth
    if doc["path"].get("file"):
        doc["path"]["file"] = str(SCENARIOS / doc["path"]["file"])
    if limit is not None:
        doc["deflection"]["limit_mm"] = limit
    doc["path"]["spacing_mm"] = spacing
    path = tmp / f"{name}_{depth}_{limit}_{spacing}_{robot_dir is not None}.yaml"
    path.write_text(yaml.safe_dump(doc))
    sc, base = load_scenario(path)
    return prepare(sc, base, progress=lambda _m: None)


def task(p) -> RedundancyTask:
    return RedundancyTask(
        s=p.samples.s, positions=p.placement.positions, tool_axes=p.placement.tool_axes,
        bound_of=lambda along: schedule_problem(p.scenario, p.process, p.robot, along,
                                                p.placement, p.samples, p.path),
        nearest=p.along)


def law_times(p, along, schedule) -> str:
    """Cycle time [s] of every law of the scenario (``*``: not verified) on the robot stage
    ``along``, planned and replay-verified as a run does."""
    q = dataclasses.replace(p, along=along, schedule=schedule, declined={})
    res = plan_and_verify(q, list(p.scenario.schedule.laws), progress=lambda _m: None)
    return "  ".join(f"{law} {r.trajectory.duration:.1f}{'' if r.verification.verified else '*'}"
                     for law, r in res.items())


def min_stiffness(along, axes) -> float:
    """Median over the path of the smaller in-plane principal stiffness [N/um]."""
    return float(np.median(stiffness_ellipses(along.compliance, axes).stiffness[:, 1])) / 1e6


def one(name: str, cell: str, tmp: Path, robot_dir: Path | None, depth: float | None,
        options: RedundancyOptions, laws: bool, out, search_mm: float = SEARCH_MM,
        limit: float | None = None) -> None:
    coarse = prepared(name, tmp, robot_dir, depth, search_mm, limit)
    fine = prepared(name, tmp, robot_dir, depth, fine_spacing(name), limit)
    r = optimise_redundancy(fine.robot, task(coarse), task(fine),
                            fine.scenario.robot.stiffness, options)
    axes = fine.placement.tool_axes
    out(f"{name:13s} {cell:13s} {fine.samples.s.size:6d} {r.t_star_nearest:9.2f} "
        f"{r.t_star:9.2f} {100 * r.gain:6.2f} {r.evaluations:5d} {r.infeasible:5d} "
        f"{r.iterations:3d} {r.seconds:7.1f}  {np.rad2deg(r.psi.min()):6.1f}.."
        f"{np.rad2deg(r.psi.max()):5.1f}  {min_stiffness(fine.along, axes):6.3f} -> "
        f"{min_stiffness(r.along, axes):6.3f}  {r.knot_s.size:2d}  {r.status.value}")
    if r.reason:
        out(f"{'':28s}{r.reason}")
    if robot_dir is None:  # the physics check: T* at a constant 90 deg offset
        ev = evaluate_profile(coarse.robot, task(coarse), np.full(coarse.samples.s.size,
                                                                  np.pi / 2), "dpp")
        out(f"{'':28s}check on the 1 mm samples: T* {coarse.problem.lower_bound_time():.6f} s "
            f"nearest, {ev.t_star:.6f} s at psi = +90 deg")
    if laws:
        out(f"{'':28s}laws, nearest:   {law_times(fine, fine.along, fine.schedule)}")
        if r.x_axes is not None:
            out(f"{'':28s}laws, optimised: {law_times(fine, r.along, r.schedule)}")


def fine_spacing(name: str) -> float:
    doc = yaml.safe_load((SCENARIOS / f"{name}.yaml").read_text())
    return float(doc["path"]["spacing_mm"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="triangle slot only, no laws")
    parser.add_argument("--pocket", action="store_true", help="also the G-code pocket")
    parser.add_argument("--out", type=Path, help="also write the table here")
    args = parser.parse_args()
    lines: list[str] = []

    def out(line: str) -> None:
        print(line, flush=True)
        lines.append(line)

    load = os.getloadavg()
    flags = (" --quick" if args.quick else "") + (" --pocket" if args.pocket else "")
    out(f"# .venv/bin/python benchmarks/bench_redundancy.py{flags}"
        f" on {os.cpu_count()} cores, {time.strftime('%Y-%m-%d %H:%M')}, load average before "
        f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    out(f"# search on a {SEARCH_MM:g} mm resampling, verified at the scenario's spacing; "
        "defaults of RedundancyOptions (objective time, 50 mm per knot within 6-12, 400 "
        "evaluations, worst-case joint accelerations within the limits) unless noted")
    out("# T* [s]; gain = 1 - T*opt / T*nearest; evals = objective evaluations (infeasible: "
        "refused by the IK, the limit margin or the acceleration share); it = Powell "
        "iterations; psi range [deg]; k_min = median over the path of the smaller principal "
        "stiffness in the plane normal to the tool axis [N/um], nearest -> optimised; "
        "knots of the psi spline; laws: cycle time [s] (* not verified)")
    out(f"{'scenario':13s} {'cell':13s} {'n':>6s} {'T*near':>9s} {'T*opt':>9s} {'gain%':>6s} "
        f"{'evals':>5s} {'infs':>5s} {'it':>3s} {'time s':>7s}  {'psi range':>13s}  "
        f"{'k_min':>16s}  knots  status")
    names = ["triangle_slot"] if args.quick else ["triangle_slot", "square_slot"]
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        side = ROOT / "robots" / "kuka_kr500_3_side"  # the bundled hypothetical cell
        for name in names:
            laws = not args.quick
            one(name, "coaxial", tmp, None, 1.5, RedundancyOptions(), laws, out)
            one(name, "side 1.5", tmp, side, 1.5, RedundancyOptions(), False, out)
            one(name, "side 2.54", tmp, side, 2.54, RedundancyOptions(), laws, out)
            one(name, "side 2.54 v", tmp, side, 2.54, RedundancyOptions(path_acceleration=False),
                laws, out)
        if not args.quick:
            one("triangle_slot", "side 2.54 k24", tmp, side, 2.54,
                RedundancyOptions(knots=24, max_evaluations=1500), False, out)
        if args.pocket:
            one("pocket", "side", tmp, side, None, RedundancyOptions(), False, out, 2.0)
            one("pocket", "side L0.15", tmp, side, None, RedundancyOptions(), True, out, 2.0,
                0.15)
    load = os.getloadavg()
    out(f"# load average after {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    if args.out:
        args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()

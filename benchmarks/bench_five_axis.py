"""The cost of a five-axis path's orientation (issue 35), back to back with the same path
without it, in one process.

Reads the tilted ball-nose surfacing CL file (``scenarios/five_axis/ball_saddle.cls``, 2108
GOTOs), builds its G2 path with and without the tool-vector blends, samples both at 0.2 mm
(the five-axis one more finely where the tool turns fast), and runs the robot stage (path IK,
compliance) on both placements: the IK of a turning tool axis goes sample by sample
(``robot/ik.py``), a fixed one by a coarser sweep. Best of ``--repeat`` runs each, alternated.

    .venv/bin/python benchmarks/bench_five_axis.py [--repeat 3]
        [--out benchmarks/results/five_axis.txt]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from feedopt.cell import place_path
from feedopt.gcode import read_apt
from feedopt.geometry.program_path import program_path
from feedopt.geometry.program_pieces import ProgramPathOptions
from feedopt.robot.model import load_robot
from feedopt.robot.stage import TcpPath, robot_along_path
from feedopt.robot.start import five_axis_x_axes, start_joints
from feedopt.schedule.stage import interior_stop_indices

ROOT = Path(__file__).resolve().parent.parent
CL = ROOT / "scenarios" / "five_axis" / "ball_saddle.cls"
ROBOT = ROOT / "robots" / "kuka_kr500_3"
START_DEG = [9.728, -64.745, 107.062, 0.0, 47.682, 0.0]  # controller axes (the scenario's)
SPACING = 0.2e-3


def _stages(program, robot, five: bool) -> dict[str, float]:
    """Seconds of path building, sampling and the robot stage, and the sample count."""
    t0 = time.perf_counter()
    built = program_path(program, ProgramPathOptions(stock_top=20e-3))
    if not five:
        built.path.orientation = None
    t1 = time.perf_counter()
    samples = built.path.sample(SPACING)
    t2 = time.perf_counter()
    placement = place_path(samples, [1750.0, -300.0, 800.0], [0.0, 0.0, 0.0], None,
                           air=built.path.moves.category[built.path.moves.index_at(samples.s)]
                           != "cut")
    q0 = start_joints(robot, START_DEG)  # as the runner does (feedopt/runner.py)
    tcp = TcpPath(samples.s, placement.positions, placement.tool_axes,
                  x_axes=five_axis_x_axes(robot, q0, placement.tool_axes),
                  breaks=interior_stop_indices(built.path.stops, samples.s))
    robot_along_path(robot, tcp, q0, "dpp")
    t3 = time.perf_counter()
    return {"path": t1 - t0, "sample": t2 - t1, "robot": t3 - t2, "n": samples.s.size}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    program, robot = read_apt(CL), load_robot(ROBOT)
    best = {True: {}, False: {}}
    for _ in range(args.repeat):
        for five in (False, True):
            got = _stages(program, robot, five)
            best[five] = {k: min(v, best[five].get(k, np.inf)) for k, v in got.items()}
    lines = [f"bench_five_axis: {CL.name}, {len(program.moves)} moves, spacing "
             f"{SPACING * 1e3:g} mm, best of {args.repeat} (alternated)",
             "| orientation | samples | path [s] | sampling [s] | robot stage [s] | "
             "robot per sample [us] |", "|---|---:|---:|---:|---:|---:|"]
    for five in (False, True):
        b = best[five]
        lines.append(f"| {'tool vectors' if five else 'none (fixed +Z)'} | {int(b['n'])} | "
                     f"{b['path']:.3f} | {b['sample']:.3f} | {b['robot']:.3f} | "
                     f"{b['robot'] / b['n'] * 1e6:.1f} |")
    text = "\n".join(lines) + "\n"
    print(text, end="")
    if args.out is not None:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

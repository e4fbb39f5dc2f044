"""Robot-stage timings: IK along a path, FK, Jacobians, compliance, deflection.

Run: ``.venv/bin/python benchmarks/bench_robot.py [--quick]``. Target: IK for 10,000 path
samples under 2 s (the 304.8 x 76.2 mm triangle wave, KR500-3, 5-DoF task).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from feedopt.robot.ik import solve_path_ik
from feedopt.robot.model import forward_kinematics, load_robot, tcp_jacobians
from feedopt.robot.stiffness import compliance, deflection

ROBOT_DIR = Path(__file__).resolve().parents[1] / "robots" / "kuka_kr500_3"
WORKPIECE_ORIGIN_M = np.array([1.7476, -0.0381, 0.8])
Q_START_DEG = np.array([1.249, -65.651, 108.658, 0.0, 46.993, 0.0])


def _triangle_wave(n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)
    phase = (s * 3) % 1.0
    phase[-1] = 1.0
    return np.stack([0.3048 * s, 0.0762 * (1.0 - np.abs(2.0 * phase - 1.0)), 0 * s], axis=1)


def _best(fn, repeat: int) -> tuple[float, float]:
    """Best wall-clock and best CPU time [s] over ``repeat`` runs."""
    wall = cpu = np.inf
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        fn()
        wall = min(wall, time.perf_counter() - t)
        cpu = min(cpu, time.process_time() - c)
    return wall, cpu


def main(quick: bool = False) -> dict[str, float]:
    """Time the robot stage; returns ``{name: seconds}`` (best of a few runs)."""
    robot = load_robot(ROBOT_DIR)
    n = 2000 if quick else 10000
    repeat = 1 if quick else 3
    p = _triangle_wave(n) + WORKPIECE_ORIGIN_M
    z = np.tile([0.0, 0.0, 1.0], (n, 1))
    q0 = np.deg2rad(Q_START_DEG)
    res = solve_path_ik(robot, p, z, q0)
    x = forward_kinematics(robot, res.q)[:, :3, 0]
    n_angles = 90 if quick else 360
    c3 = compliance(robot, res.q)[:, :3, :3]
    forces = np.random.default_rng(0).normal(size=(n, n_angles, 3)) * 100.0
    cases = {
        f"ik_5dof_{n}": lambda: solve_path_ik(robot, p, z, q0),
        f"ik_6dof_{n}": lambda: solve_path_ik(robot, p, z, q0, x_axes=x),
        f"fk_{n}": lambda: forward_kinematics(robot, res.q),
        f"jacobians_{n}": lambda: tcp_jacobians(robot, res.q),
        f"compliance_{n}": lambda: compliance(robot, res.q, "dpp"),
        f"deflection_{n}x{n_angles}": lambda: deflection(c3, forces),
    }
    timings: dict[str, float] = {}
    for name, fn in cases.items():
        timings[f"{name}_s"], timings[f"{name}_cpu_s"] = _best(fn, repeat)
    return timings


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer samples, one run")
    args = parser.parse_args()
    result = main(args.quick)
    print(f"{'case':28s} {'wall':>10s} {'cpu':>10s}")
    for name in (k[:-2] for k in result if not k.endswith("_cpu_s")):
        wall, cpu = result[name + "_s"], result[name + "_cpu_s"]
        print(f"{name:28s} {wall * 1e3:8.1f} ms {cpu * 1e3:7.1f} ms")

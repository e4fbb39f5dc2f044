"""Benchmark of the optimising timing laws ``topp`` (toppra) and ``convex`` (cvxpy + Clarabel).

Synthetic problems built here (not imported from the tests): a triangle-slot-like path (lines at
4.0 / 2.75 mm/s, the bound dipping to 2.2 mm/s in the blends, 0.36 m) and a random smooth bound
(2-6 mm/s, 0.3 m), both with a smooth 6-joint path. Limits: tangential acceleration 0.5 m/s^2,
jerk 5 m/s^3, joints 60 deg/s and 200 deg/s^2. Prints planning time and cycle time / T* at
1e3, 1e4, 1e5 samples (``--quick``: 1e3 and 1e4).

    .venv/bin/python benchmarks/bench_schedule_opt.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from feedopt.schedule.checks import check_timing  # noqa: E402
from feedopt.schedule.convex import ConvexOptions, plan_convex  # noqa: E402
from feedopt.schedule.problem import ScheduleProblem  # noqa: E402
from feedopt.schedule.topp import plan_topp  # noqa: E402

MM = 1e-3


def _joints(s: np.ndarray):
    k = np.linspace(3.0, 8.0, 6)
    amp = np.linspace(0.05, 0.02, 6)
    q = np.linspace(-0.5, 0.5, 6) + amp * np.sin(k * s[:, None]) + 0.4 * s[:, None]
    return q, amp * k * np.cos(k * s[:, None]) + 0.4, -amp * k**2 * np.sin(k * s[:, None])


def _problem(s: np.ndarray, v: np.ndarray) -> ScheduleProblem:
    q, dq, d2q = _joints(s)
    return ScheduleProblem(
        s=s, v_max=v, q=q, dq_ds=dq, d2q_ds2=d2q,
        joint_velocity_max=np.full(6, np.deg2rad(60.0)),
        joint_acceleration_max=np.full(6, np.deg2rad(200.0)),
        accel_max=0.5, jerk_max=5.0, nominal_feed=4.23 * MM,
    )


def triangle_slot(n: int) -> ScheduleProblem:
    """Lines alternating 4.0 / 2.75 mm/s joined by 20 mm blends dipping to 2.2 mm/s."""
    s = np.linspace(0.0, 0.36, n)
    line = np.array([4.0, 2.75, 4.0, 2.75]) * MM
    v = np.empty(n)
    for i in range(4):  # lines [0.1 i, 0.1 i + 0.08]
        m = (s >= 0.1 * i) & (s <= 0.1 * i + 0.08)
        v[m] = line[i]
    for i in range(3):  # blends (0.1 i + 0.08, 0.1 i + 0.1)
        m = (s > 0.1 * i + 0.08) & (s < 0.1 * i + 0.1)
        x = (s[m] - 0.1 * i - 0.08) / 0.02
        edge = line[i] + (line[i + 1] - line[i]) * x
        v[m] = edge - (edge - 2.2 * MM) * np.sin(np.pi * x) ** 2
    return _problem(s, v)


def random_bound(n: int, seed: int = 7) -> ScheduleProblem:
    """A smooth random bound between 2 and 6 mm/s on a 0.3 m path."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 0.3, n)
    f = np.zeros(n)
    for _ in range(12):
        f += rng.normal() * np.sin(2 * np.pi * rng.uniform(1, 40) * s / 0.3 + rng.uniform(0, 6))
    f = (f - f.min()) / (f.max() - f.min())
    return _problem(s, (2.0 + 4.0 * f) * MM)


def _run(name: str, problem: ScheduleProblem) -> dict:
    t_star = problem.lower_bound_time()
    t0 = time.perf_counter()
    topp = plan_topp(problem)
    t_topp = time.perf_counter() - t0
    t0 = time.perf_counter()
    cvx = plan_convex(problem, topp=topp)
    t_cvx = time.perf_counter() - t0
    ok_topp = check_timing(topp, problem).problems
    ok_cvx = check_timing(cvx, problem).problems
    return {
        "case": name,
        "n": problem.n,
        "t_star_s": t_star,
        "topp_time_s": t_topp,
        "topp_ratio": topp.duration / t_star,
        "topp_ok": not ok_topp,
        "convex_time_s": t_cvx,
        "convex_socp_s": cvx.stats["socp_time_s"],
        "convex_grid": cvx.stats["gridpoints"],
        "convex_ratio": cvx.duration / t_star,
        "convex_gap_to_topp": cvx.stats["gap_to_topp"],
        "convex_resolves": cvx.stats["resolves"],
        "convex_ok": not ok_cvx,
    }


def main(quick: bool = False) -> dict:
    """Run the benchmark; returns ``{"<case>_<n>": {...timings and ratios...}}``."""
    sizes = (1_000, 10_000) if quick else (1_000, 10_000, 100_000)
    plan_topp(triangle_slot(200))  # warm imports (toppra, cvxpy) out of the timings
    plan_convex(triangle_slot(200), ConvexOptions(compare_topp=False))
    out = {}
    head = (f"{'case':14s} {'n':>7s} {'T* s':>8s} | {'topp s':>7s} {'T/T*':>8s} | "
            f"{'cvx s':>7s} {'socp s':>7s} {'grid':>5s} {'T/T*':>8s} {'gap':>8s} ok")
    print(head)
    for n in sizes:
        for name, make in (("triangle_slot", triangle_slot), ("random_bound", random_bound)):
            r = _run(name, make(n))
            out[f"{name}_{n}"] = r
            print(
                f"{name:14s} {n:7d} {r['t_star_s']:8.3f} | {r['topp_time_s']:7.3f} "
                f"{r['topp_ratio']:8.5f} | {r['convex_time_s']:7.3f} {r['convex_socp_s']:7.3f} "
                f"{r['convex_grid']:5d} {r['convex_ratio']:8.5f} "
                f"{r['convex_gap_to_topp']:+8.5f} {r['topp_ok'] and r['convex_ok']}",
                flush=True,
            )
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1e3 and 1e4 samples only")
    main(parser.parse_args().quick)

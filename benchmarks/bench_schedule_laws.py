"""Benchmark of the ``constant``, ``thesis`` and ``jerk`` timing laws.

Synthetic problems built here (like tests/schedule/conftest.py): a triangle-slot-like wave
(lines at 4.0 / 2.75 mm/s, bound dipping to 2.2 mm/s in the blends, 0.36 m), a chapter-4
ramp (one 203.2 mm line, bound 6 -> 2.9 mm/s, key points every 2.54 mm) and a random bound
(log-normal spline plus 0.3 % sample noise, 0.3 m). Limits: tangential acceleration 0.5 m/s^2,
jerk 5 m/s^3. Prints planning time and cycle time / T* for 1e3, 1e4, 1e5 samples.

Run: ``.venv/bin/python benchmarks/bench_schedule_laws.py [--quick]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from feedopt.schedule.checks import check_timing
from feedopt.schedule.constant import plan_constant
from feedopt.schedule.jerk import plan_jerk
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.thesis import plan_thesis

MM = 1e-3


def _joint_path(s: np.ndarray, dof: int = 6):
    k = np.linspace(3.0, 8.0, dof)
    amp = np.linspace(0.05, 0.02, dof)
    q = np.linspace(-0.5, 0.5, dof) + amp * np.sin(k * s[:, None]) + 0.4 * s[:, None]
    dq = amp * k * np.cos(k * s[:, None]) + 0.4
    d2q = -amp * k**2 * np.sin(k * s[:, None])
    return q, dq, d2q


def _problem(s, v, starts, kinds, key=0.0) -> ScheduleProblem:
    q, dq, d2q = _joint_path(s)
    return ScheduleProblem(
        s=s, v_max=v, q=q, dq_ds=dq, d2q_ds2=d2q,
        joint_velocity_max=np.full(6, np.deg2rad(60.0)),
        joint_acceleration_max=np.full(6, np.deg2rad(200.0)),
        accel_max=0.5, jerk_max=5.0, nominal_feed=4.23 * MM,
        segment_start=np.asarray(starts, dtype=float), segment_kind=tuple(kinds),
        key_point_spacing=key,
    )


def wave(n: int, key: float = 0.0) -> ScheduleProblem:
    """Triangle-slot-like wave (4 lines, 3 varying-radius blends)."""
    length = 0.36
    s = np.linspace(0.0, length, n)
    starts = [0.0, 0.08, 0.10, 0.18, 0.20, 0.28, 0.30]
    ends = starts[1:] + [length]
    kinds = ["line", "varying_radius"] * 3 + ["line"]
    line = [4.0 * MM, 2.75 * MM, 4.0 * MM, 2.75 * MM]
    v = np.empty(n)
    for i, (a, b) in enumerate(zip(starts, ends, strict=True)):
        m = (s >= a) & (s <= b)
        if i % 2 == 0:
            v[m] = line[i // 2]
    for i, (a, b) in enumerate(zip(starts, ends, strict=True)):
        if i % 2:
            m = (s > a) & (s < b)
            x = (s[m] - a) / (b - a)
            edge = line[i // 2] + (line[i // 2 + 1] - line[i // 2]) * x
            v[m] = edge - (edge - 2.2 * MM) * np.sin(np.pi * x) ** 2
    return _problem(s, v, starts, kinds, key)


def ramp(n: int) -> ScheduleProblem:
    """Chapter-4-like line with a decreasing bound and key points every 2.54 mm."""
    s = np.linspace(0.0, 0.2032, n)
    v = (6.0 - 3.1 * np.sqrt(s / 0.2032)) * MM
    return _problem(s, v, [0.0], ["line"], key=2.54 * MM)


def random_bound(n: int, seed: int = 0) -> ScheduleProblem:
    """A 0.3 m line with a random smooth bound (2-6 mm/s typical) plus 0.3 % sample noise."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 0.3, n)
    v = np.exp(np.interp(s, np.linspace(0, 0.3, 40), rng.normal(0, 0.3, 40))) * 3.5 * MM
    v *= 1 + 0.003 * np.random.default_rng(seed + 1).standard_normal(n)
    return _problem(s, v, [0.0], ["line"])


LAWS = {"constant": plan_constant, "thesis": plan_thesis, "jerk": plan_jerk}
CASES = {"wave": wave, "wave+keys": lambda n: wave(n, 2.54 * MM), "ramp": ramp,
         "random": random_bound}


def main(quick: bool = False) -> dict:
    """Run the benchmark; returns ``{(case, n, law): {"time_s", "ratio", "ok"}}``."""
    sizes = [1_000, 10_000] if quick else [1_000, 10_000, 100_000]
    out = {}
    print(f"{'case':10s} {'n':>7s} {'law':9s} {'plan [s]':>9s} {'T/T*':>8s} {'C2':>3s} "
          f"{'jerk':>7s} {'v/vmax':>8s}")
    for case, make in CASES.items():
        for n in sizes:
            p = make(n)
            for law, fn in LAWS.items():
                t0 = time.perf_counter()
                tr = fn(p)
                dt = time.perf_counter() - t0
                chk = check_timing(tr, p)
                ratio = tr.duration / p.lower_bound_time()
                out[(case, n, law)] = {"time_s": dt, "ratio": ratio, "ok": chk.ok}
                print(f"{case:10s} {n:7d} {law:9s} {dt:9.4f} {ratio:8.4f} "
                      f"{'y' if chk.c2 else 'n':>3s} {chk.max_jerk:7.3f} {chk.feed_ratio:8.4f}")
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="only 1e3 and 1e4 samples")
    main(ap.parse_args().quick)

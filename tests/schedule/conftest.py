"""Synthetic schedule problems shared by the timing-law tests.

They stand in for the full pipeline: a path of lines and blends whose deflection bound drops
in the blends and differs between "up" and "down" lines (like the thesis triangle slot), a
bound that decreases along a line (like chapter 4), and a smooth synthetic joint path.
"""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.schedule.problem import ScheduleProblem
from feedopt.units import MM


def _joint_path(s: np.ndarray, dof: int = 6):
    """A smooth joint path q(s) with analytic derivatives (rad, rad/m, rad/m^2)."""
    k = np.linspace(3.0, 8.0, dof)  # rad/m
    amp = np.linspace(0.05, 0.02, dof)  # rad
    q0 = np.linspace(-0.5, 0.5, dof)
    q = q0 + amp * np.sin(k * s[:, None]) + 0.4 * s[:, None]
    dq = amp * k * np.cos(k * s[:, None]) + 0.4
    d2q = -amp * k**2 * np.sin(k * s[:, None])
    return q, dq, d2q


def wave_problem(n: int = 3001, **overrides) -> ScheduleProblem:
    """Triangle-slot-like: 7 segments (4 lines, 3 blends), bound 4.0 / 2.75 mm/s on lines
    alternating down/up, dipping smoothly to 2.2 mm/s inside each blend; nominal 4.23 mm/s."""
    length = 0.36
    s = np.linspace(0.0, length, n)
    starts = np.array([0.0, 0.08, 0.10, 0.18, 0.20, 0.28, 0.30])
    kinds = ("line", "varying_radius", "line", "varying_radius", "line", "varying_radius", "line")
    line_bound = [4.0, 2.75, 4.0, 2.75]
    v = np.empty(n)
    ends = np.append(starts[1:], length)
    li = 0
    for a, b, kind in zip(starts, ends, kinds, strict=True):
        m = (s >= a) & (s <= b)
        if kind == "line":
            v[m] = line_bound[li] * MM
            li += 1
    for i, (a, b, kind) in enumerate(zip(starts, ends, kinds, strict=True)):
        if kind != "line":
            m = (s > a) & (s < b)
            x = (s[m] - a) / (b - a)
            lo = 2.2 * MM
            left, right = line_bound[(i - 1) // 2] * MM, line_bound[(i + 1) // 2] * MM
            edge = left + (right - left) * x
            v[m] = edge - (edge - lo) * np.sin(np.pi * x) ** 2
    q, dq, d2q = _joint_path(s)
    params = dict(
        s=s,
        v_max=v,
        q=q,
        dq_ds=dq,
        d2q_ds2=d2q,
        joint_velocity_max=np.full(6, np.deg2rad(60.0)),
        joint_acceleration_max=np.full(6, np.deg2rad(200.0)),
        accel_max=0.5,
        jerk_max=5.0,
        nominal_feed=4.23 * MM,
        segment_start=starts,
        segment_kind=kinds,
        key_point_spacing=0.0,
    )
    params.update(overrides)
    return ScheduleProblem(**params)


def ramp_problem(n: int = 2001, **overrides) -> ScheduleProblem:
    """Chapter-4-like: one 203.2 mm line whose bound falls from 6 to 2.9 mm/s as the radial
    depth grows, with key points every 2.54 mm."""
    length = 0.2032
    s = np.linspace(0.0, length, n)
    x = s / length
    v = (6.0 - 3.1 * np.sqrt(x)) * MM
    q, dq, d2q = _joint_path(s)
    params = dict(
        s=s,
        v_max=v,
        q=q,
        dq_ds=dq,
        d2q_ds2=d2q,
        joint_velocity_max=np.full(6, np.deg2rad(60.0)),
        joint_acceleration_max=np.full(6, np.deg2rad(200.0)),
        accel_max=0.5,
        jerk_max=5.0,
        nominal_feed=4.23 * MM,
        segment_start=np.array([0.0]),
        segment_kind=("line",),
        key_point_spacing=2.54 * MM,
    )
    params.update(overrides)
    return ScheduleProblem(**params)


@pytest.fixture
def wave() -> ScheduleProblem:
    return wave_problem()


@pytest.fixture
def ramp() -> ScheduleProblem:
    return ramp_problem()

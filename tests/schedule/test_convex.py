"""Tests of the cvxpy + Clarabel SOCP timing law (feedopt.schedule.convex)."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.schedule.checks import check_timing
from feedopt.schedule.convex import (
    grid_bounds_at,
    jerk_limited_reach,
    plan_convex,
    quintic_timing,
)
from feedopt.schedule.topp import plan_topp
from tests.schedule.conftest import ramp_problem, wave_problem


@pytest.mark.parametrize("make", [wave_problem, ramp_problem])
def test_convex_is_c2_jerk_limited_and_under_the_bound(make):
    problem = make(2001)
    topp = plan_topp(problem)
    traj = plan_convex(problem, topp=topp)
    check = check_timing(traj, problem)
    assert check.ok, check.problems  # feed (1e-6 rel), accel, jerk, C2, joints, boundary
    assert traj.law == "convex" and traj.continuity == 2
    assert check.c2 and check.accel_jump <= 1e-9
    assert check.feed_ratio <= 1 + 1e-6
    assert check.max_jerk <= problem.jerk_max * (1 + 1e-6)
    # jerk exactly (quadratic per piece), not only on check_timing's 9 points per piece
    assert traj.stats["max_jerk_m_s3"] <= problem.jerk_max
    t_star = problem.lower_bound_time()
    assert t_star < traj.duration < 1.02 * t_star
    assert traj.stats["gap_to_topp"] == pytest.approx(traj.duration / topp.duration - 1)
    # starts and stops with zero acceleration (jerk-limited from rest)
    d2 = traj.timing.derivative(2)
    assert abs(d2(traj.timing.x[0])) < 1e-12 and abs(d2(traj.timing.x[-1])) < 1e-9


def test_long_path_uses_an_adaptive_grid_and_stays_verified():
    problem = wave_problem(20001)
    traj = plan_convex(problem, max_gridpoints=800, compare_topp=False)
    assert traj.stats["gridpoints"] < 1000
    check = check_timing(traj, problem)
    assert check.ok, check.problems
    assert traj.duration < 1.02 * problem.lower_bound_time()


def test_nonzero_boundary_feeds():
    problem = ramp_problem(1001, v_start=2e-3, v_end=1e-3)
    traj = plan_convex(problem, compare_topp=False)
    check = check_timing(traj, problem)
    assert check.ok, check.problems
    assert check.start_feed == pytest.approx(2e-3, rel=1e-6)
    assert check.end_feed == pytest.approx(1e-3, rel=1e-6)


def test_active_joint_acceleration_limit():
    problem = wave_problem(1501, joint_acceleration_max=np.full(6, 3.0e-3))
    traj = plan_convex(problem, compare_topp=False)
    check = check_timing(traj, problem)
    assert check.joint_acceleration_ratio <= 1 + 1e-6
    assert check.ok, check.problems


def test_needs_a_finite_jerk_limit():
    with pytest.raises(InputError, match="jerk_max"):
        plan_convex(wave_problem(301, jerk_max=np.inf))


def test_jerk_limited_reach_matches_integration():
    j, a = 5.0, 0.5
    dt = 1e-5
    t = np.arange(0, 0.4, dt)
    acc = np.minimum(j * t, a)
    v = np.concatenate([[0], np.cumsum(0.5 * (acc[1:] + acc[:-1]) * dt)])
    s = np.concatenate([[0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    np.testing.assert_allclose(jerk_limited_reach(s[500::500], a, j), v[500::500], rtol=1e-3)


def test_grid_bounds_at_off_sample_grid_matches_brute_force():
    rng = np.random.default_rng(5)
    s = np.linspace(0, 1, 21)
    v = rng.uniform(1, 2, 21)
    grid = np.unique(np.concatenate([[0, 1], rng.uniform(0, 1, 15), s[::4]]))
    interval, node = grid_bounds_at(s, v, grid)
    fine = np.linspace(0, 1, 20001)
    # bound between samples = min of the two neighbouring samples
    i = np.clip(np.searchsorted(s, fine, side="right") - 1, 0, 19)
    v_fine = np.minimum(v[i], v[i + 1])
    for k in range(grid.size - 1):
        inside = (fine >= grid[k]) & (fine <= grid[k + 1])
        assert interval[k] <= v_fine[inside].min() + 1e-15
        # and is not more conservative than the sample intervals it touches
        lo = np.searchsorted(s, grid[k], side="right") - 1
        hi = max(np.searchsorted(s, grid[k + 1], side="left") - 1, lo)
        assert interval[k] == pytest.approx(min(np.minimum(v[:-1], v[1:])[lo : hi + 1]))
    assert np.all(node[1:-1] == np.minimum(interval[:-1], interval[1:]))


def test_quintic_timing_reproduces_constant_jerk_motion():
    # constant-jerk motion sampled at a few times: the quintic pieces must reproduce it
    j = 3.0
    t = np.array([0.0, 0.1, 0.25, 0.3, 0.5])
    s0, v0, a0 = 0.0, 0.01, -0.2
    s = s0 + v0 * t + a0 * t**2 / 2 + j * t**3 / 6
    v = v0 + a0 * t + j * t**2 / 2
    a = a0 + j * t
    pp = quintic_timing(s, v, a)
    np.testing.assert_allclose(pp.x, t, atol=1e-12)
    tt = np.linspace(0, 0.5, 101)
    np.testing.assert_allclose(pp.derivative(3)(tt), j, rtol=1e-6)

"""Tests of the toppra timing law (feedopt.schedule.topp)."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.schedule.checks import check_timing
from feedopt.schedule.topp import (
    SampledJointPath,
    ToppOptions,
    grid_bounds,
    limit_acceleration,
    plan_topp,
)
from feedopt.units import MM_PER_M
from tests.schedule.conftest import ramp_problem, wave_problem


@pytest.mark.parametrize("make", [wave_problem, ramp_problem])
def test_topp_respects_bound_on_fine_samples_and_is_near_lower_bound(make):
    problem = make(3001)
    traj = plan_topp(problem)
    check = check_timing(traj, problem)
    assert check.ok, check.problems
    assert traj.law == "topp" and traj.continuity == 1
    assert check.feed_ratio <= 1 + 1e-6
    assert check.max_accel <= problem.accel_max * (1 + 1e-6)
    t_star = problem.lower_bound_time()
    assert t_star < traj.duration < 1.005 * t_star
    assert abs(traj.length - problem.length) < 1e-12
    assert any("C1" in n for n in traj.notes)


def test_coarse_grid_still_meets_bound_between_gridpoints():
    # the pitfall: a bound imposed only at 200 gridpoints was exceeded by 12 %
    problem = wave_problem(6001)
    traj = plan_topp(problem, ToppOptions(max_gridpoints=200))
    assert traj.stats.gridpoints == 200
    check = check_timing(traj, problem)
    assert check.feed_ratio <= 1 + 1e-9
    assert check.ok, check.problems
    # and the conservative gridpoint bound costs little time
    assert traj.duration < 1.03 * problem.lower_bound_time()


def _brute_force_profile(s, v_node, a_max, x0, x1):
    """Pointwise largest sdot^2 on the grid with |dx/ds| <= 2 a_max, x <= v_node^2 and the
    boundary values: min over all points j of (cap_j + 2 a |s - s_j|), O(N^2)."""
    cap = v_node**2
    cap[0], cap[-1] = x0, x1
    return np.min(cap[None, :] + 2 * a_max * np.abs(s[:, None] - s[None, :]), axis=1)


def test_topp_equals_the_analytic_time_optimal_profile():
    # joint limits inactive: the time-optimal profile under a feed bound and |sddot| <= A is
    # the largest 2A-Lipschitz sdot^2 under the bound (a closed form independent of toppra)
    problem = ramp_problem(401, accel_max=0.002)
    traj = plan_topp(problem, ToppOptions(use_joint_limits=False))
    grid = np.arange(problem.n)
    _, v_node = grid_bounds(problem.v_max, grid)
    x_ref = _brute_force_profile(problem.s, v_node, problem.accel_max, 0.0, 0.0)
    v_ref = np.sqrt(x_ref)
    t_ref = np.sum(2 * np.diff(problem.s) / (v_ref[:-1] + v_ref[1:]))
    assert traj.duration == pytest.approx(t_ref, rel=1e-6)
    t_break = traj.timing.x
    v_got = traj.timing.derivative(1)(t_break)
    np.testing.assert_allclose(v_got, v_ref, rtol=1e-6, atol=1e-9)


def test_boundary_feeds_are_met():
    problem = wave_problem(2001, v_start=1.5e-3, v_end=2.0e-3)
    traj = plan_topp(problem)
    check = check_timing(traj, problem)
    assert check.ok, check.problems
    assert check.start_feed == pytest.approx(1.5e-3, rel=1e-9)
    assert check.end_feed == pytest.approx(2.0e-3, rel=1e-9)


def test_active_joint_acceleration_limit_is_respected_on_the_samples():
    # small joint acceleration limits bind (mostly through q' sddot)
    problem = wave_problem(2001, joint_acceleration_max=np.full(6, 3.0e-3))
    free = plan_topp(problem, ToppOptions(use_joint_limits=False))
    assert check_timing(free, problem).joint_acceleration_ratio > 1.05  # it does bind
    traj = plan_topp(problem)
    check = check_timing(traj, problem)
    assert check.joint_acceleration_ratio <= 1 + 1e-6
    assert traj.duration > free.duration


def test_infeasible_boundary_feed_is_an_input_error():
    problem = wave_problem(501, v_start=10e-3)
    with pytest.raises(InputError, match="v_start"):
        plan_topp(problem)


def test_limit_acceleration_is_the_largest_lipschitz_minorant():
    rng = np.random.default_rng(3)
    s = np.sort(rng.uniform(0, 1, 50))
    x = rng.uniform(0, 1, 50)
    y = limit_acceleration(x, s, 0.3)
    assert np.all(y <= x + 1e-15)
    assert np.all(np.abs(np.diff(y)) <= 2 * 0.3 * np.diff(s) * (1 + 1e-12))
    ref = np.min(x[None, :] + 0.6 * np.abs(s[:, None] - s[None, :]), axis=1)
    np.testing.assert_allclose(y, ref, rtol=1e-12)


def test_grid_bounds_match_a_loop():
    rng = np.random.default_rng(0)
    v = rng.uniform(1, 2, 40)
    grid = np.array([0, 3, 4, 10, 25, 39])
    interval, node = grid_bounds(v, grid)
    for k in range(grid.size - 1):
        assert interval[k] == np.min(v[grid[k] : grid[k + 1] + 1])
    for k in range(grid.size):
        assert node[k] == np.min(interval[max(k - 1, 0) : k + 1])


def test_sampled_joint_path_reproduces_the_samples():
    problem = wave_problem(301)
    path = SampledJointPath(problem, scale=MM_PER_M)
    s_mm = problem.s * MM_PER_M
    np.testing.assert_allclose(path(s_mm), problem.q, atol=1e-12)
    np.testing.assert_allclose(path(s_mm, 1), problem.dq_ds / MM_PER_M, atol=1e-12)
    np.testing.assert_allclose(path(s_mm, 2), problem.d2q_ds2 / MM_PER_M**2, atol=1e-12)
    assert path.dof == 6 and path.path_interval[-1] == pytest.approx(360.0)

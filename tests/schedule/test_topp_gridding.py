"""The topp law against toppra used on its own: default gridding, and which solver runs.

toppra's default gridpoints (``propose_gridpoints``) depend on the unit of the path
parameter, and a velocity bound imposed at gridpoints is exceeded between them; the topp law
checks the bound on every sample. Without binding joint acceleration limits the law's exact
forward-backward pass is toppra's optimum (same cycle time to toppra's tolerance).
"""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.schedule.checks import check_timing
from feedopt.schedule.topp import (
    SampledJointPath,
    ToppMethod,
    ToppOptions,
    _feed_bound_constraint,
    _solve_toppra,
    _toppra_profile,
    grid_bounds,
    joint_acceleration_ratio_on_grid,
    piecewise_quadratic_timing,
    plan_topp,
    sample_feed_bound,
    uniform_grid,
)
from feedopt.units import MM_PER_M
from tests.schedule.conftest import wave_problem


def _toppra_default_grid(problem, scale):
    """toppra with its own gridpoints and the feed bound imposed at them (what a user of
    toppra alone writes); the sdot^2 it plans, linear in s between gridpoints (constant
    acceleration), at every sample, and the number of gridpoints."""
    import toppra.algorithm as algo
    from toppra.interpolator import propose_gridpoints

    path = SampledJointPath(problem, scale=scale,
                            joint_scale=np.asarray(problem.joint_acceleration_max))
    grid = np.asarray(propose_gridpoints(path))
    s_grid = grid / scale
    v_grid = np.interp(s_grid, problem.s, problem.v_max)
    x_bound = np.column_stack([np.zeros(grid.size), (v_grid * scale) ** 2])
    u_bound = np.tile([-problem.accel_max * scale, problem.accel_max * scale], (grid.size, 1))
    instance = algo.TOPPRA([_feed_bound_constraint(x_bound, u_bound)], path, gridpoints=grid,
                           solver_wrapper="seidel", parametrizer="ParametrizeConstAccel")
    _, sd, _ = instance.compute_parameterization(0.0, 0.0)
    return np.interp(problem.s, s_grid, (sd / scale) ** 2), grid.size


def test_toppra_default_gridding_depends_on_the_unit_and_overshoots_ours_does_not():
    problem = wave_problem(3001)
    x_m, n_m = _toppra_default_grid(problem, 1.0)
    x_mm, n_mm = _toppra_default_grid(problem, 1000.0)
    assert n_mm > 20 * n_m  # the same path: 121 gridpoints in metres, 8193 in millimetres
    over = np.sqrt(x_m) / problem.v_max
    assert over.max() > 1.01  # 2.9 % over the bound between the metre gridpoints
    traj = plan_topp(problem)
    check = check_timing(traj, problem)  # sdot against v_max on every sample
    assert check.ok, check.problems
    assert check.feed_ratio <= 1 + 1e-9
    # on a coarse grid of its own too
    coarse = plan_topp(problem, ToppOptions(max_gridpoints=n_m))
    assert check_timing(coarse, problem).feed_ratio <= 1 + 1e-9


@pytest.mark.parametrize("n", [801, 3001])
def test_forward_backward_is_toppras_optimum_when_joint_limits_do_not_bind(n):
    problem = wave_problem(n)
    traj = plan_topp(problem)
    assert traj.stats.method is ToppMethod.FORWARD_BACKWARD
    assert traj.stats.solver == "exact forward-backward pass"
    grid = uniform_grid(problem.n, None)
    _, v_node = grid_bounds(sample_feed_bound(problem), grid)
    x, code, _ = _toppra_profile(problem, grid, v_node, problem.accel_max)
    assert code == "Ok"
    ref, _ = piecewise_quadratic_timing(problem.s[grid], x)
    # toppra stops within its solver tolerance of the optimum, never beyond it
    assert traj.duration <= ref.x[-1] * (1 + 1e-12)
    assert traj.duration == pytest.approx(ref.x[-1], rel=1e-8)
    v = traj.timing.derivative(1)(traj.timing.x)
    np.testing.assert_allclose(v, ref.derivative(1)(ref.x), rtol=1e-7, atol=1e-9)


def test_toppra_runs_when_the_joint_acceleration_limits_bind():
    problem = wave_problem(2001, joint_acceleration_max=np.full(6, 3.0e-3))
    traj = plan_topp(problem)
    assert traj.stats.method is ToppMethod.TOPPRA and traj.stats.toppra_time_s > 0
    assert check_timing(traj, problem).joint_acceleration_ratio <= 1 + 1e-6
    grid = uniform_grid(problem.n, None)
    free = plan_topp(problem, ToppOptions(use_joint_limits=False))
    assert free.stats.method is ToppMethod.FORWARD_BACKWARD
    x_free = free.timing.derivative(1)(free.timing.x) ** 2
    assert joint_acceleration_ratio_on_grid(problem, grid, x_free) > 1.0


def test_joint_acceleration_ratio_on_grid_matches_a_loop():
    problem = wave_problem(101)
    grid = np.array([0, 7, 30, 31, 64, 100])
    x = np.random.default_rng(1).uniform(0.5e-6, 1.5e-5, grid.size)
    want = 0.0
    for k in range(grid.size - 1):
        u = (x[k + 1] - x[k]) / (2 * (problem.s[grid[k + 1]] - problem.s[grid[k]]))
        for i, xi in ((grid[k], x[k]), (grid[k + 1], x[k + 1])):
            qdd = problem.d2q_ds2[i] * xi + problem.dq_ds[i] * u
            want = max(want, np.max(np.abs(qdd) / problem.joint_acceleration_max))
    assert joint_acceleration_ratio_on_grid(problem, grid, x) == pytest.approx(want, rel=1e-14)


def test_an_end_feed_that_cannot_be_reached_is_an_input_error():
    # 2.75 mm/s is the bound at the end sample, but reaching it from the last blend's
    # 2.2 mm/s dip 60 mm before the end needs 136 mm at 0.01 mm/s^2
    problem = wave_problem(3001, accel_max=1e-5, v_end=2.75e-3)
    with pytest.raises(InputError, match="no feasible parameterisation"):
        plan_topp(problem)


@pytest.mark.parametrize("window", [97, 500, 1999])
def test_toppra_in_windows_is_toppra_on_the_whole_grid(window):
    """The windowed passes (controllable sets last window first, then the forward pass
    window by window) give the profile of one toppra instance on the whole grid, where the
    joint acceleration limits bind (the grid of 2001 in 21, 5 and 2 windows, the last
    short)."""
    problem = wave_problem(2001, joint_acceleration_max=np.full(6, 3.0e-3))
    grid = uniform_grid(problem.n, None)
    _, v_node = grid_bounds(sample_feed_bound(problem), grid)
    whole, code, _ = _solve_toppra(problem, grid, v_node, problem.accel_max, window=grid.size)
    assert code == "Ok"
    parts, code, _ = _solve_toppra(problem, grid, v_node, problem.accel_max, window=window)
    assert code == "Ok"
    np.testing.assert_allclose(parts, whole, rtol=1e-9, atol=1e-12)
    # the joint limits bind: the profile is below the feed bound somewhere
    assert np.any(whole < 0.999 * v_node * MM_PER_M)

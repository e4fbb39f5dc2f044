"""Tests of the cvxpy + Clarabel SOCP timing law (feedopt.schedule.convex)."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.schedule.checks import check_timing
from feedopt.schedule.convex import (
    ConvexAttempt,
    ConvexOptions,
    Overshoot,
    SocpStatus,
    _notes,
    _Scales,
    _shrunk,
    _violations,
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
    assert traj.stats.max_jerk_m_s3 <= problem.jerk_max
    t_star = problem.lower_bound_time()
    assert t_star < traj.duration < 1.02 * t_star
    assert traj.stats.gap_to_topp == pytest.approx(traj.duration / topp.duration - 1)
    # starts and stops with zero acceleration (jerk-limited from rest)
    d2 = traj.timing.derivative(2)
    assert abs(d2(traj.timing.x[0])) < 1e-12 and abs(d2(traj.timing.x[-1])) < 1e-9


def test_long_path_uses_an_adaptive_grid_and_stays_verified():
    problem = wave_problem(20001)
    traj = plan_convex(problem, ConvexOptions(max_gridpoints=800, compare_topp=False))
    assert traj.stats.gridpoints < 1000
    check = check_timing(traj, problem)
    assert check.ok, check.problems
    assert traj.duration < 1.02 * problem.lower_bound_time()


def test_nonzero_boundary_feeds():
    problem = ramp_problem(1001, v_start=2e-3, v_end=1e-3)
    traj = plan_convex(problem, ConvexOptions(compare_topp=False))
    check = check_timing(traj, problem)
    assert check.ok, check.problems
    assert check.start_feed == pytest.approx(2e-3, rel=1e-6)
    assert check.end_feed == pytest.approx(1e-3, rel=1e-6)


def test_active_joint_acceleration_limit():
    problem = wave_problem(1501, joint_acceleration_max=np.full(6, 3.0e-3))
    traj = plan_convex(problem, ConvexOptions(compare_topp=False))
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


def _attempt(overshoot=Overshoot.NONE, **kw):
    values = dict(feed_ratio=0.99, max_accel=0.1, max_jerk=4.0, status=SocpStatus.OPTIMAL,
                  feed_scale=1.0, jerk_scale=0.98, accel_scale=1.0)
    values.update(kw)
    return ConvexAttempt(overshoot=overshoot, **values)


def test_attempts_are_typed_and_summarised_as_before():
    problem = wave_problem(1001)
    traj = plan_convex(problem, ConvexOptions(compare_topp=False))
    stats = traj.stats
    assert stats.status is SocpStatus.OPTIMAL and stats.status.solved
    assert stats.resolves == len(stats.attempts) - 1
    last = stats.attempts[-1]
    assert last.overshoot == Overshoot.NONE and stats.violations == Overshoot.NONE
    assert all(a.overshoot for a in stats.attempts[:-1])  # each re-solve had a reason
    row = stats.as_dict()["attempts"][-1]
    assert row == {"feed_ratio": last.feed_ratio, "max_accel": last.max_accel,
                   "max_jerk": last.max_jerk, "status": "optimal",
                   "feed_scale": last.feed_scale, "jerk_scale": last.jerk_scale,
                   "accel_scale": last.accel_scale}
    assert stats.as_dict()["status"] == "optimal" and stats.gap_to_topp is None


def test_overshoot_flags_decide_the_next_limits():
    problem = wave_problem(301)
    opts = ConvexOptions()
    start = _Scales(1.0, 0.98, 1.0)
    assert _shrunk(start, _attempt(), problem, opts) == start
    over = _attempt(Overshoot.FEED | Overshoot.JERK | Overshoot.ACCELERATION,
                    feed_ratio=1.01, max_jerk=2 * problem.jerk_max,
                    max_accel=4 * problem.accel_max)
    feed, jerk, accel, joint = _shrunk(start, over, problem, opts)
    assert feed == pytest.approx((1 - 1e-6) / 1.01)
    assert jerk == pytest.approx(0.98 * 0.999 / 2)
    assert accel == pytest.approx(0.999 / 4)
    assert joint == 1.0
    rev = _shrunk(start, _attempt(Overshoot.REVERSAL), problem, opts)
    assert rev == (1.0, pytest.approx(0.98 * 0.9), 1.0, 1.0)
    # the smoothing between gridpoints overshot a joint acceleration by 2 %
    joints = _shrunk(start, _attempt(Overshoot.JOINT_ACCELERATION, joint_ratio=1.02), problem,
                     opts)
    assert joints == (1.0, 0.98, 1.0, pytest.approx(0.999 / 1.02))


def test_remaining_violations_are_typed_and_noted():
    problem = wave_problem(301)
    ok = _attempt(feed_ratio=1.0 + 1e-12)  # rounding: not a violation
    assert _violations(ok, problem) == Overshoot.NONE
    bad = _attempt(Overshoot.REVERSAL, feed_ratio=1.001, max_jerk=1.01 * problem.jerk_max)
    found = _violations(bad, problem)
    assert found == Overshoot.FEED | Overshoot.JERK | Overshoot.REVERSAL
    notes = _notes(301, (ok, bad), found, problem)
    assert "re-solved 1 time(s)" in notes[1]
    assert sum(n.startswith("VIOLATION") for n in notes) == 3

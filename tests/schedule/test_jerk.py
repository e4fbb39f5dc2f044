"""The ``jerk`` law: ruckig profiles under v_max(s), C2 and jerk-limited."""

from __future__ import annotations

import numpy as np
import pytest
import ruckig
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.schedule.checks import check_timing
from feedopt.schedule.jerk import _reach, _sections, plan_jerk
from feedopt.schedule.quintic import scurve_distance
from feedopt.units import MM
from tests.schedule.conftest import ramp_problem, wave_problem


def _line(v_max, length=0.3, **kw):
    n = v_max.size
    z = np.zeros((n, 6))
    return wave_problem(
        n, s=np.linspace(0, length, n), v_max=v_max, q=z, dq_ds=z, d2q_ds2=z,
        segment_start=None, segment_kind=(), **kw,
    )


@pytest.mark.parametrize("make", [wave_problem, ramp_problem])
def test_follows_bound_c2_jerk_limited_near_optimal(make):
    p = make()
    tr = plan_jerk(p)
    chk = check_timing(tr, p)
    assert chk.ok, chk.problems
    assert chk.c2 and chk.max_jerk <= p.jerk_max * (1 + 1e-9)
    assert chk.feed_ratio <= 1.0
    assert chk.lower_bound < tr.duration < 1.02 * chk.lower_bound


@settings(max_examples=50, deadline=None)
@given(vf=st.floats(0, 0.01), length=st.floats(1e-6, 0.5))
def test_reach_inverts_the_s_curve_distance(vf, length):
    A, J = 0.5, 5.0
    v0 = _reach(vf, length, A, J)
    assert v0 >= vf
    assert scurve_distance(v0, vf, A, J) == pytest.approx(length, rel=1e-9, abs=1e-15)


def test_sections_respect_tolerance():
    v = np.exp(np.random.default_rng(0).normal(0, 0.2, 2000).cumsum() * 0.05) * 3 * MM
    b = _sections(v, 0.01)
    for i, j in zip(b[:-1], b[1:], strict=True):
        seg = v[i : j + 1]
        assert j - i == 1 or seg.max() * 0.99 <= seg.min()


def test_single_section_equals_ruckig():
    p = _line(np.full(1001, 4 * MM), v_start=1 * MM, v_end=0.5 * MM)
    tr = plan_jerk(p)
    assert tr.stats.n_sections == 1
    inp = ruckig.InputParameter(1)
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [1e-3], [0.0]
    inp.target_position, inp.target_velocity, inp.target_acceleration = [0.3], [5e-4], [0.0]
    inp.max_velocity = [4 * MM * (1 - 1e-9)]
    inp.max_acceleration, inp.max_jerk, inp.min_velocity = [0.5], [5.0], [0.0]
    ref = ruckig.Trajectory(1)
    ruckig.Ruckig(1).calculate(inp, ref)
    assert tr.duration == pytest.approx(ref.duration, rel=1e-12)
    for t in np.linspace(0, ref.duration, 57):
        pos, vel, acc = ref.at_time(t)
        m = tr.at(np.array([t]))
        assert m.s[0] == pytest.approx(pos[0], abs=1e-12)
        assert m.sdot[0] == pytest.approx(vel[0], abs=1e-12)
        assert m.sddot[0] == pytest.approx(acc[0], abs=1e-10)


def test_brakes_ahead_of_a_narrow_notch_and_steps():
    s = np.linspace(0, 0.3, 30001)
    v = np.where((s > 0.1) & (s < 0.1003), 0.5 * MM, 5 * MM)
    v = np.where(s > 0.2, 2 * MM, v)
    p = _line(v)
    tr = plan_jerk(p)
    chk = check_timing(tr, p)
    assert chk.ok, chk.problems
    # it has slowed down before the notch (not by lowering the limit on the fly)
    assert tr.feed_at(np.array([0.1]))[0] <= 0.5 * MM * (1 + 1e-9)


def test_noisy_bound_and_boundary_feeds():
    rng = np.random.default_rng(1)
    n = 20000
    s = np.linspace(0, 0.3, n)
    v = np.exp(np.interp(s, np.linspace(0, 0.3, 40), rng.normal(0, 0.4, 40))) * 3 * MM
    v *= 1 + 0.003 * rng.standard_normal(n)
    p = _line(v, v_start=0.5 * v[0], v_end=0.3 * v[-1])
    tr = plan_jerk(p)
    chk = check_timing(tr, p)
    assert chk.ok, chk.problems
    assert tr.duration < 1.02 * chk.lower_bound


def test_bad_input():
    with pytest.raises(InputError, match="jerk_max"):
        plan_jerk(wave_problem(jerk_max=np.inf))
    with pytest.raises(InputError, match="v_start"):
        plan_jerk(wave_problem(v_start=5 * MM))
    # cannot brake from v_start to a very low bound 10 um ahead
    s = np.linspace(0, 1e-5, 11)
    v = np.where(s > 5e-6, 1e-4 * MM, 4 * MM)
    with pytest.raises(InputError, match="brake"):
        plan_jerk(_line(v, length=1e-5, v_start=4 * MM))


def test_handles_1e5_samples():
    p = wave_problem(100_001)
    tr = plan_jerk(p)
    chk = check_timing(tr, p)
    assert chk.ok and tr.duration < 1.02 * chk.lower_bound


def test_joint_accelerations_stay_within_limits_on_a_fast_tight_turn():
    """A rapid (v_max 0.5 m/s) through a stretch where the joint path curves hard (|q_ss| up
    to 400 rad/m^2): without the split the velocity term alone would need 400 * 0.25 =
    100 rad/s^2, 30x the limit. Joint accelerations replayed here from q_s, q_ss and the
    planned sdot, sddot (independently of the law) stay within the limit."""
    n = 4001
    s = np.linspace(0.0, 0.2, n)
    bump = np.exp(-(((s - 0.1) / 0.004) ** 2))
    d2q = np.zeros((n, 6))
    d2q[:, 2] = 400.0 * bump
    dq = np.full((n, 6), 0.3)
    dq[:, 2] += np.concatenate([[0.0], np.cumsum(0.5 * (d2q[1:, 2] + d2q[:-1, 2]) * np.diff(s))])
    qdd_max = np.full(6, 3.0)
    p = wave_problem(n, s=s, v_max=np.full(n, 0.5), q=np.zeros((n, 6)), dq_ds=dq,
                     d2q_ds2=d2q, joint_acceleration_max=qdd_max,
                     joint_velocity_max=np.full(6, 10.0),
                     segment_start=None, segment_kind=())
    tr = plan_jerk(p)
    t = np.linspace(0.0, tr.duration, 200_001)
    m = tr.at(t)
    k = np.clip(np.searchsorted(s, m.s), 1, n - 1)
    w = (m.s - s[k - 1]) / (s[k] - s[k - 1])
    qs = dq[k - 1] + w[:, None] * (dq[k] - dq[k - 1])
    qss = d2q[k - 1] + w[:, None] * (d2q[k] - d2q[k - 1])
    qdd = qss * m.sdot[:, None] ** 2 + qs * m.sddot[:, None]
    assert np.max(np.abs(qdd) / qdd_max) <= 1.0 + 1e-3
    # and it does not crawl: the turn is taken near the speed the velocity term allows
    v_turn = np.sqrt(0.5 * 3.0 / 400.0)
    assert m.sdot[np.argmin(np.abs(m.s - 0.1))] >= 0.9 * v_turn

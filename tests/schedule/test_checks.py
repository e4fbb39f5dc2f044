"""check_timing: start/stop ramps, the minimum cutting feed and messages in user units."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import PPoly

from feedopt.errors import InputError
from feedopt.schedule.checks import (
    BOUND_REACHED_RTOL,
    BOUNDARY_FEED_RTOL,
    Violation,
    check_boundary_feeds,
    check_positive_bound,
    check_timing,
    find_ramps,
)
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.trajectory import Trajectory
from feedopt.units import MM

ROOT = Path(__file__).resolve().parents[2]


def _problem(length: float, v_max, n: int = 201, **overrides) -> ScheduleProblem:
    """A straight path of ``length`` [m] with bound ``v_max(s)`` and a joint path that
    never binds (1 rad/m on every joint, huge joint limits)."""
    s = np.linspace(0.0, length, n)
    params = dict(
        s=s, v_max=np.broadcast_to(v_max(s) if callable(v_max) else v_max, s.shape).copy(),
        q=np.outer(s, np.ones(6)), dq_ds=np.ones((n, 6)), d2q_ds2=np.zeros((n, 6)),
        joint_velocity_max=np.full(6, 1e3), joint_acceleration_max=np.full(6, 1e3),
        accel_max=10.0, jerk_max=1e4, nominal_feed=4e-3,
    )
    params.update(overrides)
    return ScheduleProblem(**params)


def _smooth_profile(v: float, t_up: float, t_cruise: float, d: float, t_dip: float,
                    t_down: float) -> tuple[Trajectory, dict]:
    """C2 s(t): smoothstep ramp 0 -> v in t_up, cruise, a dip to v - d (16 u^2 (1-u)^2 shape)
    in t_dip, cruise, smoothstep ramp v -> 0 in t_down. Returns it and the exact numbers."""
    up = [0.0, -v / (2 * t_up**3), v / t_up**2, 0.0, 0.0, 0.0]  # s = v T (u^3 - u^4 / 2)
    cruise = [0.0, 0.0, 0.0, 0.0, v, 0.0]
    # v(u) = v - 16 d u^2 (1 - u)^2  ->  s = T (v u - 16 d (u^3/3 - u^4/2 + u^5/5))
    t = t_dip
    dip = [-16 * d / 5 / t**4, 8 * d / t**3, -16 * d / 3 / t**2, 0.0, v, 0.0]
    down = [0.0, v / (2 * t_down**3), -v / t_down**2, 0.0, v, 0.0]  # v (1 - 3u^2 + 2u^3)
    pieces = [up, cruise, dip, cruise, down]
    dur = np.array([t_up, t_cruise, t_dip, t_cruise, t_down])
    lengths = np.array([v * t_up / 2, v * t_cruise, v * t_dip - 16 * d * t_dip / 30,
                        v * t_cruise, v * t_down / 2])
    c = np.array(pieces, dtype=float).T
    c[-1] = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    pp = PPoly(c, np.concatenate([[0.0], np.cumsum(dur)]))
    return Trajectory("hand", pp, continuity=2), {"lengths": lengths, "durations": dur}


def test_smooth_profile_ramps_and_dip_are_exact() -> None:
    v, d = 4e-3, 1.5e-3
    traj, ref = _smooth_profile(v, t_up=0.08, t_cruise=20.0, d=d, t_dip=3.0, t_down=0.11)
    length = float(ref["lengths"].sum())
    assert traj.length == pytest.approx(length, rel=1e-12)
    # 0.1 mm samples: sample 1 lies inside the start ramp (the old "min feed" was read there)
    problem = _problem(length, 2 * v, n=int(round(length / (0.1 * MM))) + 1)
    chk = check_timing(traj, problem)
    assert chk.ok, chk.problems
    up, dn = chk.start_ramp, chk.stop_ramp
    assert up.reason == dn.reason == "flat"
    assert up.length == pytest.approx(v * 0.08 / 2, rel=1e-9)  # smoothstep: v T / 2
    assert up.duration == pytest.approx(0.08, rel=1e-9)
    assert up.feed == pytest.approx(v, rel=1e-9)
    assert dn.length == pytest.approx(v * 0.11 / 2, rel=1e-9)
    assert dn.duration == pytest.approx(0.11, rel=1e-9)
    assert dn.s_to == pytest.approx(length, rel=1e-12) and dn.feed == pytest.approx(v, rel=1e-9)
    # the minimum cutting feed is the bottom of the dip, exactly (no sample sits there)
    assert chk.min_cutting_feed == pytest.approx(v - d, rel=1e-9)
    feed = traj.feed_at(problem.s)
    assert problem.s[1] < up.s_to and feed[1] < 0.95 * v  # sample 1 is on the ramp
    cutting = feed[(problem.s > up.s_to) & (problem.s < dn.s_from)]
    assert v - d < cutting.min() < v - d + 1e-6  # the samples miss the exact bottom


def _topp_like(v1: float, a_up: float, a_cruise: float, t_cruise: float, a_down: float):
    """C1 s(t): constant acceleration from rest to v1, a slowly rising feed (a_cruise > 0)
    for t_cruise, constant deceleration to rest. Returns it and (s1, s2, v2)."""
    t1 = v1 / a_up
    s1 = v1**2 / (2 * a_up)
    v2 = v1 + a_cruise * t_cruise
    s2 = s1 + v1 * t_cruise + a_cruise * t_cruise**2 / 2
    t3 = v2 / a_down
    c = np.array([[a_up / 2, a_cruise / 2, -a_down / 2], [0.0, v1, v2], [0.0, s1, s2]])
    pp = PPoly(c, np.array([0.0, t1, t1 + t_cruise, t1 + t_cruise + t3]))
    return Trajectory("topp-like", pp, continuity=1), (s1, s2, v2)


def test_a_ramp_ends_where_the_feed_meets_a_rising_bound() -> None:
    v1, a_up, a_cr, t_cr, a_dn = 3e-3, 0.2, 2e-6, 60.0, 0.3
    traj, (s1, s2, v2) = _topp_like(v1, a_up, a_cr, t_cr, a_dn)
    length = traj.length

    def v_max(s):  # exactly the cruise feed, held at its end values outside the cruise
        return np.sqrt(v1**2 + 2 * a_cr * np.clip(s - s1, 0.0, s2 - s1))

    problem = _problem(length, v_max, n=2001)
    up, dn, cutting = find_ramps(traj, problem)
    # the start ramp meets the bound long before the feed stops rising; the stop ramp starts
    # where the feed starts falling, which is also where it leaves the bound
    assert up.reason == "bound" and dn.reason == "flat"
    assert up.length == pytest.approx(v1**2 / (2 * a_up), rel=1e-9)
    assert up.duration == pytest.approx(v1 / a_up, rel=1e-9)
    assert up.feed == pytest.approx(v1, rel=1e-9)
    assert dn.length == pytest.approx(v2**2 / (2 * a_dn), rel=1e-9)
    assert dn.duration == pytest.approx(v2 / a_dn, rel=1e-9)
    assert cutting == pytest.approx(v1, rel=1e-9)
    # Ignoring the bound (the constant baseline's rule) the feed keeps rising to the cruise
    # end, so the start ramp covers the cruise too.
    up2, dn2, cutting2 = find_ramps(traj, problem, follow_bound=False)
    assert up2.reason == "flat" and up2.length == pytest.approx(s2, rel=1e-9)
    assert dn2.s_from == pytest.approx(s2, rel=1e-9) and cutting2 == pytest.approx(v2, rel=1e-9)
    assert 0 < BOUND_REACHED_RTOL <= 1e-3


def test_a_path_too_short_to_level_off_is_all_ramp() -> None:
    v = 2e-3
    traj, ref = _smooth_profile(v, t_up=0.05, t_cruise=0.0, d=0.0, t_dip=1e-3, t_down=0.05)
    pp = PPoly(traj.timing.c[:, [0, 4]], np.array([0.0, 0.05, 0.10]))
    pp.c[-1, 1] = v * 0.05 / 2
    traj = Trajectory("peak", pp)
    problem = _problem(traj.length, 10 * v, n=11)
    up, dn, cutting = find_ramps(traj, problem)
    assert up.t_to == pytest.approx(0.05, rel=1e-9) and dn.t_from == pytest.approx(0.05)
    assert cutting == pytest.approx(v, rel=1e-9)


@pytest.fixture(scope="module")
def triangle_at_two_spacings():
    """The default scenario's problem at 0.1 and 0.5 mm spacing, every law planned."""
    from feedopt.runner import prepare
    from feedopt.scenario import load_scenario
    from feedopt.schedule.laws import plan_law

    scenario, base = load_scenario(ROOT / "scenarios" / "triangle_slot.yaml")
    out = {}
    for spacing in (0.1, 0.5):
        prepared = prepare(scenario, base, lambda _m: None, spacing_mm=spacing)
        context: dict = {}
        trajs = {law: plan_law(law, prepared.problem, context)
                 for law in ("topp", "constant", "thesis", "convex", "jerk")}
        out[spacing] = (prepared.problem, trajs)
    return out


def test_min_cutting_feed_does_not_depend_on_the_spacing(triangle_at_two_spacings) -> None:
    checks = {}
    for spacing, (problem, trajs) in triangle_at_two_spacings.items():
        checks[spacing] = {law: check_timing(tr, problem, enforce_feed_bound=law != "constant")
                           for law, tr in trajs.items()}
    fine, coarse = checks[0.1], checks[0.5]
    for law in fine:
        assert fine[law].min_cutting_feed == pytest.approx(coarse[law].min_cutting_feed,
                                                           rel=2e-4), law
    assert fine["constant"].min_cutting_feed == pytest.approx(4.23 * MM, rel=1e-12)
    # The weakest line of the bound (about 2.771 mm/s) is what the optimal laws cut at.
    for law in ("topp", "convex", "jerk"):
        assert fine[law].min_cutting_feed == pytest.approx(2.7713 * MM, rel=2e-4), law
    # Ramps of laws whose s(t) does not depend on the sampling are the same too; the
    # constant one matches the law's own ramp length.
    for law in ("constant", "thesis", "jerk", "convex"):
        for which in ("start_ramp", "stop_ramp"):
            a, b = getattr(fine[law], which), getattr(coarse[law], which)
            assert a.length == pytest.approx(b.length, rel=1e-3), (law, which)
            assert a.duration == pytest.approx(b.duration, rel=1e-3), (law, which)
    up_mm, down_mm = triangle_at_two_spacings[0.1][1]["constant"].stats["ramp_lengths_mm"]
    assert fine["constant"].start_ramp.length / MM == pytest.approx(up_mm, rel=1e-9)
    assert fine["constant"].stop_ramp.length / MM == pytest.approx(down_mm, rel=1e-9)
    # What the old sample-based "min feed" read at 0.1 mm: the feed at sample 1 of the ramp.
    problem, trajs = triangle_at_two_spacings[0.1]
    assert trajs["constant"].feed_at(problem.s)[1:-1].min() < 3.9 * MM


def test_problem_strings_are_in_user_units() -> None:
    v = 4e-3
    traj, ref = _smooth_profile(v, t_up=0.02, t_cruise=5.0, d=0.0, t_dip=0.5, t_down=0.02)
    length = traj.length
    # accel of the smoothstep ramp: 1.5 v / T = 0.3 m/s^2; jerk 6 v / T^2 = 60 m/s^3
    problem = _problem(length, 0.5 * v, n=401, accel_max=0.2, jerk_max=5.0,
                       joint_velocity_max=np.full(6, np.deg2rad(0.1)), v_start=1e-3,
                       v_end=0.0)
    chk = check_timing(traj, problem)
    text = "\n".join(chk.problems)
    assert "feed 4 mm/s exceeds its bound 2 mm/s" in text
    assert "tangential acceleration 300 mm/s^2 exceeds its limit 200 mm/s^2" in text
    assert "tangential jerk 60000 mm/s^3 exceeds its limit 5000 mm/s^3" in text
    assert "joint 1 velocity 0.2292 deg/s exceeds its limit 0.1 deg/s" in text
    assert "start feed 0 mm/s differs from the requested 1 mm/s" in text
    for p in chk.problems:
        assert " m/s" not in p and " m " not in p, p
    short = _problem(length * 1.01, 2 * v, n=401)
    assert any(f"covers {length / MM:.9g} mm of a {1.01 * length / MM:.9g} mm path" in p
               for p in check_timing(traj, short).problems)


def test_violations_flag_every_problem() -> None:
    v = 4e-3
    traj, _ = _smooth_profile(v, t_up=0.02, t_cruise=5.0, d=0.0, t_dip=0.5, t_down=0.02)
    length = traj.length
    problem = _problem(length, 0.5 * v, n=401, accel_max=0.2, jerk_max=5.0,
                       joint_velocity_max=np.full(6, np.deg2rad(0.1)), v_start=1e-3)
    chk = check_timing(traj, problem)
    assert chk.violations == (Violation.FEED_BOUND | Violation.ACCELERATION | Violation.JERK
                              | Violation.JOINT_VELOCITY | Violation.START_FEED)
    assert len(chk.problems) == 5
    ok = check_timing(traj, _problem(length, 2 * v, n=401))
    assert ok.ok and ok.violations == Violation.NONE and not ok.violations
    # the constant baseline's bound excess is measured, not flagged
    base = check_timing(traj, _problem(length, 0.5 * v, n=401), enforce_feed_bound=False)
    assert Violation.FEED_BOUND not in base.violations and base.feed_ratio > 1


def test_a_reversing_trajectory_is_flagged_as_reversal() -> None:
    # s(t) = t^3 - 1.5 t^2 + 0.6 t on [0, 1]: sdot = 3 t^2 - 3 t + 0.6 < 0 around t = 0.5
    c = np.array([[1.0], [-1.5], [0.6], [0.0]]) * 1e-3
    traj = Trajectory(law="test", timing=PPoly(c, np.array([0.0, 1.0])), continuity=2)
    chk = check_timing(traj, _problem(traj.length, 1.0, v_start=0.6e-3, v_end=0.6e-3))
    assert Violation.REVERSAL in chk.violations
    assert any("would reverse" in p for p in chk.problems)


def test_boundary_feed_check_refuses_feeds_outside_zero_to_the_bound() -> None:
    p = _problem(0.1, 3e-3, v_start=3e-3, v_end=0.0)
    check_boundary_feeds("some", p)  # at the bound: accepted
    check_boundary_feeds("some", _problem(0.1, 3e-3, v_start=3e-3 * (1 + BOUNDARY_FEED_RTOL)))
    with pytest.raises(InputError, match=r"some law: v_start = 3.003 mm/s is outside "
                                         r"\[0, 3\] mm/s, the feed bound at the path start"):
        check_boundary_feeds("some", _problem(0.1, 3e-3, v_start=3.003e-3))
    with pytest.raises(InputError, match=r"v_end = -1 mm/s .* path end \(sample 200\)"):
        check_boundary_feeds("some", _problem(0.1, 3e-3, v_end=-1e-3))
    # a law may pass a tighter bound (toppra: joint velocities; jerk law: its section cap)
    with pytest.raises(InputError, match=r"outside \[0, 2\] mm/s"):
        check_boundary_feeds("some", p, start_bound=2e-3)
    check_boundary_feeds("some", p, end_bound=0.0)


def test_positive_bound_check() -> None:
    p = _problem(0.1, 3e-3)
    check_positive_bound("some", p, p.v_max)
    v = p.v_max.copy()
    v[7] = 0.0
    with pytest.raises(InputError, match="some law: the feed bound is 0 mm/s at sample 7"):
        check_positive_bound("some", p, v)
    v[7] = np.nan
    with pytest.raises(InputError, match="sample 7"):
        check_positive_bound("some", p, v)


@pytest.mark.parametrize("law", ["thesis", "topp", "convex", "jerk"])
def test_every_law_refuses_a_boundary_feed_above_the_bound(law) -> None:
    from feedopt.schedule import convex, jerk, thesis, topp
    from tests.schedule.conftest import wave_problem

    plan = {"thesis": thesis.plan_thesis, "topp": topp.plan_topp,
            "convex": convex.plan_convex, "jerk": jerk.plan_jerk}[law]
    for field in ("v_start", "v_end"):
        with pytest.raises(InputError, match=f"{law} law: {field} = 5 mm/s is outside"):
            plan(wave_problem(301, **{field: 5 * MM}))

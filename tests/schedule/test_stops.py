"""Planning through stops (feedopt.schedule.stops via plan_law): every law stops, holds and
goes on; checked against the halves planned alone as their own problems, against polynomial
evaluation with numpy, and by replay verification with a real deflection model."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from feedopt.errors import InputError, LawNotApplicable
from feedopt.process.coefficients import CuttingCoefficients
from feedopt.process.engagement import Engagement
from feedopt.process.tool import Tool
from feedopt.schedule.bounds import deflection_feed_bound
from feedopt.schedule.checks import check_timing
from feedopt.schedule.deflection import DeflectionModel, feed_frames
from feedopt.schedule.laws import plan_law
from feedopt.schedule.problem import ScheduleProblem, StopSamples
from feedopt.schedule.stops import StitchedStats, one_sided_end, piece_problem
from feedopt.verify import verify_trajectory

MM = 1e-3
HALF_M = 0.05  # each half of the line [m]
HALF_N = 201  # samples per half (the stop sample shared)
V_MAX = 5 * MM
FAST_LAWS = ("constant", "thesis", "topp", "jerk", "programmed")
C2_LAWS = ("constant", "thesis", "jerk", "programmed", "convex")


def _line(s: np.ndarray, slope: np.ndarray | float = 0.4, v_max: np.ndarray | float = V_MAX,
          law: str = "jerk", **overrides) -> ScheduleProblem:
    """A straight line sampled at ``s``; joint path linear in s with ``slope`` [rad/m] (per
    sample: a corner where it changes)."""
    n = s.size
    slope = np.broadcast_to(np.asarray(slope, dtype=float), (n,))
    q_end = np.concatenate([[0.0], np.cumsum(np.diff(s) * slope[1:])])
    dof = 6
    params = dict(
        s=s, v_max=np.broadcast_to(np.asarray(v_max, dtype=float), (n,)).copy(),
        q=np.linspace(-0.5, 0.5, dof) + q_end[:, None],
        dq_ds=np.repeat(slope[:, None], dof, axis=1), d2q_ds2=np.zeros((n, dof)),
        joint_velocity_max=np.full(dof, np.deg2rad(60.0)),
        joint_acceleration_max=np.full(dof, np.deg2rad(200.0)),
        accel_max=0.5, jerk_max=5.0, nominal_feed=4 * MM,
        segment_start=np.array([0.0]), segment_kind=("line",),
        programmed_feed=np.full(n, 4.5 * MM) if law == "programmed" else None)
    params.update(overrides)
    return ScheduleProblem(**params)


def _stops(index, hold_s) -> StopSamples:
    index = np.atleast_1d(np.asarray(index))
    return StopSamples(index, np.atleast_1d(np.asarray(hold_s, dtype=float)),
                       ("dwell",) * index.size, tuple(f"line {i}: G4" for i in index))


def _whole(law: str, hold_s: float = 1.0, **overrides) -> ScheduleProblem:
    s = np.linspace(0.0, 2 * HALF_M, 2 * HALF_N - 1)
    return _line(s, law=law, stops=_stops(HALF_N - 1, hold_s), **overrides)


def _alone(law: str) -> float:
    """Duration of one half planned as its own problem (both halves are the same line)."""
    return plan_law(law, _line(np.linspace(0.0, HALF_M, HALF_N), law=law)).duration


def _one_sided(pp, t: float, order: int, side: str) -> float:
    """The ``order``-th derivative of the PPoly ``pp`` at ``t`` from the left or the right,
    by numpy's polyval on the piece's own coefficients."""
    i = int(np.searchsorted(pp.x, t, side="left" if side == "left" else "right")) - 1
    i = min(max(i, 0), pp.x.size - 2)
    c = pp.c[:, i]
    for _ in range(order):
        c = np.polyder(c)
    return float(np.polyval(c, t - pp.x[i]))


def _arrival(traj, s_stop: float) -> float:
    """The breakpoint at which ``traj`` arrives at ``s_stop`` (earliest time, snapped)."""
    t = float(traj.time_at(np.array([s_stop]))[0])
    return float(traj.timing.x[np.argmin(np.abs(traj.timing.x - t))])


def _dense(traj, n: int = 20001):
    t = np.linspace(0.0, traj.duration, n)
    return t, traj.at(t)


@pytest.mark.parametrize("law", FAST_LAWS)
def test_a_stop_and_hold_adds_the_halves_and_the_hold(law: str) -> None:
    whole = _whole(law)
    traj = plan_law(law, whole)
    # the SOCP (programmed) moves by ~3e-6 when s moves by an ulp (s - s_stop is not
    # linspace's value to the bit); the other laws to rounding
    rel = 1e-5 if law == "programmed" else 1e-9
    assert traj.duration == pytest.approx(2 * _alone(law) + 1.0, rel=rel)
    assert traj.length == pytest.approx(whole.length, rel=1e-12)
    _check_stop(traj, law, float(whole.s[HALF_N - 1]), hold_s=1.0)


def test_convex_stops_with_topp_pieces_as_context() -> None:
    whole = _whole("convex")
    context: dict = {}
    topp = plan_law("topp", whole, context)
    traj = plan_law("convex", whole, context)
    assert traj.duration == pytest.approx(2 * _alone("convex") + 1.0, rel=1e-5)
    _check_stop(traj, "convex", float(whole.s[HALF_N - 1]), hold_s=1.0)
    # each piece got its own window of the stitched topp trajectory: gap to the half alone
    topp_half = _alone("topp")
    for piece in traj.stats.piece_stats:
        assert piece.topp_duration_s == pytest.approx(topp_half, rel=1e-12)
        assert piece.topp_time_s is None  # toppra was not run again
    assert topp.duration == pytest.approx(2 * topp_half + 1.0, rel=1e-12)


def _check_stop(traj, law: str, s_stop: float, hold_s: float) -> None:
    """Continuous, non-decreasing s(t); at rest at the stop (sddot too for C2 laws); s held
    for ``hold_s``; during the hold every derivative zero."""
    t, m = _dense(traj)
    assert np.all(np.diff(m.s) >= -1e-15)
    assert m.s[0] == 0.0
    pp = traj.timing
    for k in range(1, pp.x.size - 1):  # s continuous at every breakpoint
        assert _one_sided(pp, pp.x[k], 0, "left") == pytest.approx(
            _one_sided(pp, pp.x[k], 0, "right"), abs=1e-12)
    v_top, a_top = float(np.max(m.sdot)), float(np.max(np.abs(m.sddot)))
    t_in = _arrival(traj, s_stop)
    t_out = t_in + hold_s
    assert pp.x[np.argmin(np.abs(pp.x - t_out))] == pytest.approx(t_out, abs=1e-12)
    for when, side in ((t_in, "left"), (t_out, "right")):
        assert abs(_one_sided(pp, when, 1, side)) <= 1e-9 * v_top, (law, side)
        if law in C2_LAWS:
            assert abs(_one_sided(pp, when, 2, side)) <= 1e-9 * a_top, (law, side)
    held = traj.at(np.linspace(t_in, t_out, 101))
    assert np.all(held.s == pytest.approx(s_stop, abs=1e-15))
    assert np.all(held.sdot[1:-1] == 0) and np.all(held.sddot[1:-1] == 0)
    assert np.all(held.sdddot[1:-1] == 0)
    assert traj.at(np.array([t_out + 0.05])).s[0] > s_stop  # and it moves on


@pytest.mark.parametrize("law", FAST_LAWS)
def test_stops_one_sample_apart_are_planned(law: str) -> None:
    """A move of one sample interval between two stops (toppra's grid alone cannot start
    and stop on one interval)."""
    s = np.linspace(0.0, HALF_M, HALF_N)
    p = _line(s, law=law, stops=_stops([100, 101], [0.0, 0.2]))
    traj = plan_law(law, p)
    chk = check_timing(traj, p, enforce_feed_bound=law not in ("constant", "programmed"))
    assert chk.problems == ()
    assert traj.stats.windows[1][:2] == (100, 101)
    t_in = _arrival(traj, float(s[101]))
    assert traj.at(np.array([t_in + 0.1])).s[0] == pytest.approx(s[101], abs=1e-15)


def test_a_hold_at_the_start_waits_then_plans_as_usual() -> None:
    s = np.linspace(0.0, HALF_M, HALF_N)
    traj = plan_law("jerk", _line(s, stops=_stops(0, 1.5)))
    assert isinstance(traj.stats, StitchedStats)
    plain = plan_law("jerk", _line(s))
    assert traj.duration == pytest.approx(plain.duration + 1.5, rel=1e-12)
    m = traj.at(np.linspace(0.0, 1.5, 50))
    assert np.all(m.s == 0.0) and np.all(m.sdot == 0.0)
    late = traj.at(np.array([1.5 + 0.3, traj.duration]))
    assert late.s[0] == pytest.approx(plain.at(np.array([0.3])).s[0], rel=1e-12)
    assert late.s[1] == pytest.approx(HALF_M, rel=1e-12)
    assert any("held 1.5 s in 1 hold (line 0: G4)" in n for n in traj.notes)


def test_a_stop_at_the_start_needs_a_start_at_rest() -> None:
    s = np.linspace(0.0, HALF_M, HALF_N)
    with pytest.raises(InputError, match=r"line 0: G4: the path starts with a stop \(dwell\) "
                                         r"but v_start = 1 mm/s; set v_start to 0"):
        plan_law("jerk", _line(s, stops=_stops(0, 1.0), v_start=1 * MM))


def test_stops_only_at_the_ends_without_holds_plan_the_path_whole() -> None:
    s = np.linspace(0.0, HALF_M, HALF_N)
    traj = plan_law("jerk", _line(s, stops=_stops([0, HALF_N - 1], [0.0, 0.0])))
    plain = plan_law("jerk", _line(s))
    assert not isinstance(traj.stats, StitchedStats)
    np.testing.assert_array_equal(traj.timing.c, plain.timing.c)


def _corner_problem(law: str = "constant") -> ScheduleProblem:
    """Second half: joints 1000x steeper (a corner at the stop): the constant law's nominal
    feed is too fast for the joints there, not on the first half."""
    s = np.linspace(0.0, 2 * HALF_M, 2 * HALF_N - 1)
    steep = s >= s[HALF_N - 1]
    slope = np.where(steep, 400.0, 0.4)  # the stop sample holds the following segment's
    v_max = np.where(steep, 2.5 * MM, V_MAX)
    return _line(s, slope=slope, v_max=v_max, law=law, stops=_stops(HALF_N - 1, 0.0))


def test_a_law_declining_a_piece_declines_naming_it() -> None:
    with pytest.raises(LawNotApplicable) as err:
        plan_law("constant", _corner_problem())
    msg = str(err.value)
    # piece 1 ends at the corner: with the following segment's joint rates there it would
    # decline too; the one-sided estimate keeps its own
    assert msg.startswith(f"constant law, piece 2 of 2 between stops (samples {HALF_N - 1}-"
                          f"{2 * HALF_N - 2}, s = 50.000-100.000 mm; positions below count "
                          "from the piece start): constant law: at the nominal feed 4 mm/s "
                          "joint 1 would need"), msg
    traj = plan_law("jerk", _corner_problem())  # the others plan it
    assert traj.stats.stitched_pieces == 2


def test_the_piece_before_a_corner_keeps_its_own_joint_rates() -> None:
    p = _corner_problem()
    left = piece_problem(p, 0, HALF_N - 1, 0.0, 0.0)
    right = piece_problem(p, HALF_N - 1, p.n - 1, 0.0, 0.0)
    assert np.allclose(left.dq_ds, 0.4, rtol=1e-12)
    assert np.all(right.dq_ds == 400.0)
    assert left.v_max[-1] == 2.5 * MM  # the smaller bound of the two sides
    assert right.s[0] == 0.0 and right.s[-1] == pytest.approx(HALF_M, rel=1e-12)
    assert np.shares_memory(right.q, p.q) and np.shares_memory(right.dq_ds, p.dq_ds)
    assert left.stops is None and left.v_end == 0.0 and right.v_start == 0.0


@pytest.mark.parametrize("m", [1, 2, 3, 4, 7])
def test_one_sided_end_is_exact_for_polynomials_it_can_follow(m: int) -> None:
    s = np.cumsum(np.array([0.0, 0.3, 0.1, 0.45, 0.2, 0.5, 0.25])[:m])
    deg = min(m - 2, 2)  # constant from one sample before, linear from two, quadratic
    coeff = np.array([[3.0, -1.0], [2.0, 0.5], [1.0, 7.0]])[2 - max(deg, 0):]
    values = np.stack([np.polyval(coeff[:, j], s) for j in range(2)], axis=1)
    values[-1] = 1e9  # the other side's value at the corner, ignored
    if m == 1:
        assert np.all(one_sided_end(values, s) == 1e9)  # nothing before it
        return
    want = [np.polyval(coeff[:, j], s[-1]) for j in range(2)]
    np.testing.assert_allclose(one_sided_end(values, s), want, rtol=1e-12)


def test_segments_are_sliced_and_shifted() -> None:
    s = np.linspace(0.0, 0.1, 101)
    p = _line(s, segment_start=np.array([0.0, 0.03, 0.05, 0.08]),
              segment_kind=("line", "circle", "line", "bezier5"))
    at_boundary = piece_problem(p, 50, 100, 0.0, 0.0)  # s = 0.05: starts with segment 3
    np.testing.assert_allclose(at_boundary.segment_start, [0.0, 0.03], atol=1e-15)
    assert at_boundary.segment_kind == ("line", "bezier5")
    inside = piece_problem(p, 20, 60, 0.0, 0.0)  # s = 0.02 .. 0.06
    np.testing.assert_allclose(inside.segment_start, [0.0, 0.01, 0.03], atol=1e-15)
    assert inside.segment_kind == ("line", "circle", "line")


def test_stitched_stats_read_as_the_longest_piece() -> None:
    s = np.linspace(0.0, 0.15, 301)
    traj = plan_law("thesis", _line(s, stops=_stops([100], [0.5])))
    st = traj.stats
    assert st.longest_piece_samples == (100, 300)
    assert st.n_pieces == st.piece_stats[1].n_pieces  # forwarded attribute
    d = st.as_dict()
    assert d["stitched_pieces"] == 2 and d["stitched_stops"] == 1 and d["hold_total_s"] == 0.5
    assert d["iterations"] == st.piece_stats[1].iterations
    assert d["longest_piece_samples"] == [100, 300]
    again = pickle.loads(pickle.dumps(traj))  # law workers send trajectories back pickled
    assert again.stats.as_dict() == d and again.stats.windows == st.windows
    w0, w1 = st.windows
    assert (w0.t_from, w0.t_to + 0.5) == (0.0, pytest.approx(w1.t_from, abs=1e-12))
    assert "planned in 2 pieces between 1 stop (line 100: G4), each from and to rest; held " \
           "0.5 s in 1 hold" in traj.notes


def test_many_stops_keep_the_notes_short() -> None:
    s = np.linspace(0.0, 0.31, 311)
    idx = np.arange(10, 310, 10)
    traj = plan_law("topp", _line(s, stops=_stops(idx, np.zeros(idx.size))))
    assert traj.stats.stitched_pieces == 31
    assert len(traj.notes) <= 4, traj.notes
    assert traj.notes[-1].startswith("planned in 31 pieces between 30 stops (line 10: G4; "
                                     "line 20: G4; line 30: G4; line 40: G4; and 26 more)")


# --- replay verification with a real deflection model ------------------------------------

def _milling_line(law: str, holds: tuple[float, float, float]):
    """A slot along x (2-flute 19.05 mm mill, 1 mm deep, isotropic 1 um/N compliance):
    v_max from the deflection limit, stops at the start, the middle and the end."""
    n = 2 * HALF_N - 1
    s = np.linspace(0.0, 2 * HALF_M, n)
    tool = Tool("hss", 19.05 * MM, 2, math.radians(30), 25 * MM)
    model = DeflectionModel(
        tool=tool, coefficients=CuttingCoefficients(9.19e8, 4.02e8, -1.19e8, 8.8e3, 6.73e3,
                                                    -1.05e3),
        engagement=Engagement(np.zeros(n), np.full(n, math.pi), np.full(n, 1 * MM)),
        angles=np.linspace(0.0, math.pi, 91, endpoint=False),
        frames=feed_frames(np.tile([1.0, 0, 0], (n, 1)), np.tile([0.0, 0, 1], (n, 1))),
        compliance=np.tile(np.eye(3) * 1e-6, (n, 1, 1)), rpm=2500.0, axial_slices=5)
    limit = 0.05 * MM
    v_max = deflection_feed_bound(model, limit)[0]
    stops = _stops([0, HALF_N - 1, n - 1], holds)
    return _line(s, v_max=v_max, law=law, stops=stops, nominal_feed=0.8 * float(v_max[0])
                 ), model, limit


@pytest.mark.parametrize("law", ["jerk", "thesis", "topp", "constant"])
def test_stitched_trajectories_pass_replay_verification(law: str) -> None:
    problem, model, limit = _milling_line(law, (1.0, 2.0, 0.5))
    traj = plan_law(law, problem)
    ver = verify_trajectory(traj, problem, model, limit)
    assert ver.verified and ver.problems == (), ver.problems
    assert ver.exportable == (law != "topp")  # topp is C1
    assert ver.meets_limit and ver.timing.c2 == (law != "topp")
    chk = ver.timing
    # ramps of the moving pieces: the start ramp begins after the start hold, the stop ramp
    # ends before the end hold, and the cutting feed is not the stops' zero
    assert chk.start_ramp.t_from == 1.0 and chk.start_ramp.length > 0
    assert chk.stop_ramp.t_to == pytest.approx(traj.duration - 0.5, abs=1e-12)
    assert chk.stop_ramp.length > 0
    assert chk.min_cutting_feed > 0.5 * float(problem.v_max.min())

"""The ``thesis`` law: chapter 3 (line feeds, Eq. 3.22 blends) and chapter 4 (key points,
acceleration hand-off of section 4.3)."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.schedule.checks import check_timing
from feedopt.schedule.thesis import ThesisOptions, plan_thesis
from feedopt.units import MM
from tests.schedule.conftest import ramp_problem, wave_problem


def _benign_wave(n=3001):
    """The conftest wave with a bound in the blends that never drops below the line feeds."""
    p = wave_problem(n)
    v = p.v_max.copy()
    for a, b, kind in p.segments():
        if kind != "line":
            v[(p.s > a) & (p.s < b)] = 5.0 * MM
    return wave_problem(n, v_max=v)


def _blend_times(tr, p):
    return [(a, b, tr.time_at(np.array([a, b]))) for a, b, k in p.segments() if k != "line"]


def test_chapter3_blends_follow_eq_3_22_and_lines_keep_their_feeds():
    p = _benign_wave()
    tr = plan_thesis(p)
    chk = check_timing(tr, p)
    assert chk.ok, chk.problems
    # down lines 4.0, up lines 2.75 mm/s: the largest feed meeting the bound on each line
    feeds = [f[3] for f in tr.stats.stretch_feeds_mm_s]
    np.testing.assert_allclose(feeds, [4.0, 2.75, 4.0, 2.75], rtol=1e-12)
    assert not any("lowered" in n for n in tr.notes)
    assert not tr.stats.lowered and not tr.stats.ramp_fits and not tr.stats.exceeds_bound
    d1, d2 = tr.timing.derivative(1), tr.timing.derivative(2)
    line = [4.0 * MM, 2.75 * MM, 4.0 * MM, 2.75 * MM]
    for i, (a, b, (t0, t1)) in enumerate(_blend_times(tr, p)):
        # Eq. 3.22: s, sdot = adjacent line feeds, sddot = 0 at both ends ...
        assert d1(t0) == pytest.approx(line[i], rel=1e-9)
        assert d1(t1) == pytest.approx(line[i + 1], rel=1e-9)
        assert abs(d2(t0)) < 1e-12 and abs(d2(t1)) < 1e-12
        # ... and t_f = blend length / min(sdot0, sdotf)
        assert t1 - t0 == pytest.approx((b - a) / min(line[i], line[i + 1]), rel=1e-9)
        # the velocity dips below both line feeds: min - 0.512 (max - min)
        t = np.linspace(t0, t1, 5001)
        lo, hi = min(line[i], line[i + 1]), max(line[i], line[i + 1])
        assert d1(t).min() == pytest.approx(lo - 0.512 * (hi - lo), rel=1e-6)


def test_chapter3_lowers_feeds_where_the_blend_would_exceed_the_bound():
    p = wave_problem()
    pure = plan_thesis(p, ThesisOptions(lower_feeds=False))
    chk_pure = check_timing(pure, p)
    assert chk_pure.feed_ratio > 1.2  # the thesis construction exceeds v_max in the blends
    assert any("exceeds v_max" in n for n in pure.notes) and pure.stats.exceeds_bound
    tr = plan_thesis(p)
    chk = check_timing(tr, p)
    assert chk.ok, chk.problems
    assert chk.c2 and chk.accel_jump < 1e-12
    assert chk.max_jerk <= p.jerk_max and chk.max_jerk == pytest.approx(tr.stats.max_jerk_m_s3)
    feeds = [f[3] for f in tr.stats.stretch_feeds_mm_s]
    assert feeds[0] > feeds[1] and feeds[2] > feeds[3]  # down lines faster than up lines
    assert sum("lowered" in n for n in tr.notes) == 4
    # ... and as typed outcomes: the four lines around the three blends, by up to a few %
    assert [low.kind for low in tr.stats.lowered] == ["line"] * 4 and not tr.stats.ramp_fits
    assert all(0 < low.max_drop < 0.5 for low in tr.stats.lowered)
    # lowering both ends of a blend by one factor scales its quintic feed (closed form):
    # the binding blend touches its bound to the lowering margin
    assert 1 - 1e-8 < chk.feed_ratio <= 1.0
    assert chk.lower_bound < tr.duration


def test_chapter4_key_points_hand_off_and_dip():
    p = ramp_problem()
    tr = plan_thesis(p)
    chk = check_timing(tr, p)
    assert chk.ok, chk.problems
    pp = tr.timing
    x = pp.x
    s_nodes = pp(x)
    v, a = pp.derivative(1)(x), pp.derivative(2)(x)
    l = p.key_point_spacing
    # interior key pieces: length l, t_f = l / min(v0, vf), hand-off sddotf = 2 abar - sddot0
    inner = np.flatnonzero(np.abs(np.diff(s_nodes) - l) < 1e-12)[1:-1]
    assert inner.size > 70
    T = np.diff(x)[inner]
    np.testing.assert_allclose(T, l / np.minimum(v[inner], v[inner + 1]), rtol=1e-9)
    abar = (v[inner + 1] - v[inner]) / T
    # The hand-off holds except where the law restarted its undamped recursion (af = 0),
    # which it counts and notes.
    restarted = (a[inner + 1] == 0.0) & (np.abs(2 * abar - a[inner]) > 1e-12)
    assert restarted.sum() <= tr.stats.handoff_resets <= 3
    ok = ~restarted
    np.testing.assert_allclose(a[inner + 1][ok], (2 * abar - a[inner])[ok], atol=1e-12)
    # key-point feed = min of v_max over the neighbouring intervals (where not lowered)
    k = inner[10]
    near = (p.s >= s_nodes[k] - l - 1e-12) & (p.s <= s_nodes[k] + l + 1e-12)
    assert v[k] <= p.v_max[near].min() * (1 + 1e-12)
    # the dip of section 4.5: inside a piece the feed drops below both key-point feeds
    dips = 0
    for i in inner:
        t = np.linspace(x[i], x[i + 1], 201)
        dips += pp.derivative(1)(t).min() < min(v[i], v[i + 1]) - 1e-9
    assert dips > 0.5 * inner.size
    assert chk.c2 and chk.max_jerk <= p.jerk_max


def test_combined_chapters_and_1e5_samples():
    p = wave_problem(100_001, key_point_spacing=2.54 * MM)
    tr = plan_thesis(p)
    chk = check_timing(tr, p)
    assert chk.ok, chk.problems
    assert tr.duration < plan_thesis(wave_problem(3001)).duration  # key points help


def test_boundary_feed_above_bound_is_an_input_error():
    with pytest.raises(InputError, match="v_start"):
        plan_thesis(wave_problem(v_start=5 * MM))

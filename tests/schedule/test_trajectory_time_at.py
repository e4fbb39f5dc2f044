"""Trajectory.time_at (safeguarded Newton) against references computed another way.

References: the inverse by 200-bit bisection in exact rational arithmetic (``fractions``), the
closed form of cubic pieces, and polynomial.bisect_increasing (the 60-step bisection the
inverse used before).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from scipy.interpolate import PPoly

from feedopt.schedule.polynomial import bisect_increasing
from feedopt.schedule.quintic import QuinticPieces
from feedopt.schedule.trajectory import Trajectory, earliest_crossing


def _random_quintic_trajectory(seed: int, pieces: int = 40) -> Trajectory:
    """C2 quintic pieces through random positive feeds (thesis-like blends and dips), at rest
    at both ends; monotone (checked densely)."""
    rng = np.random.default_rng(seed)
    h = rng.uniform(0.2e-3, 30e-3, pieces)
    v = np.concatenate([[0.0], rng.uniform(1e-3, 6e-3, pieces - 1), [0.0]])
    a = np.zeros(pieces + 1)
    T = 2 * h / np.maximum(v[:-1] + v[1:], 1e-12) * rng.uniform(1.0, 1.2, pieces)
    s0 = np.concatenate([[0.0], np.cumsum(h)[:-1]])
    pp = QuinticPieces(s0=s0, h=h, v0=v[:-1], vf=v[1:], a0=a[:-1], af=a[1:], T=T).ppoly()
    t = np.linspace(pp.x[0], pp.x[-1], 200_001)
    assert np.all(pp(t, 1) >= -1e-12), "test trajectory must be monotone"
    return Trajectory(law="test", timing=pp)


def _exact_inverse(pp: PPoly, s: float) -> float:
    """Earliest t with s(t) >= s, by bisection on exact rationals to 2^-200 of the piece."""
    x = [Fraction(v) for v in pp.x]
    target = Fraction(s)

    def value(i, t):
        acc = Fraction(0)
        for row in pp.c[:, i]:
            acc = acc * (t - x[i]) + Fraction(row)
        return acc

    i = next(k for k in range(len(x) - 1) if value(k, x[k + 1]) >= target)
    lo, hi = x[i], x[i + 1]
    if value(i, lo) >= target:
        return float(lo)
    for _ in range(200):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if value(i, mid) < target else (lo, mid)
    return float(hi)


@pytest.mark.parametrize("seed", [0, 1])
def test_time_at_inverts_quintic_pieces_to_1e12_of_an_exact_reference(seed):
    tr = _random_quintic_trajectory(seed)
    pp = tr.timing
    rng = np.random.default_rng(100 + seed)
    s = np.sort(rng.uniform(0.0, tr.length, 120))
    got = tr.time_at(s)
    want = np.array([_exact_inverse(pp, v) for v in s])
    feed = pp(want, 1)
    moving = feed > 1e-6  # away from the rest ends, where s(t) is flat to rounding
    assert moving.sum() > 100
    np.testing.assert_allclose(got[moving], want[moving], rtol=1e-12, atol=1e-12)
    # near rest the inverse is ill-conditioned: a rounding of s moves t by sqrt(ulp / a)
    assert np.max(np.abs(got - want)) < 1e-6


def test_time_at_matches_the_sixty_step_bisection_on_many_targets():
    tr = _random_quintic_trajectory(3, pieces=400)
    pp = tr.timing
    s = np.linspace(0.0, tr.length, 100_001)
    got = tr.time_at(s)
    s_break = np.maximum.accumulate(pp(pp.x))
    piece = np.clip(np.searchsorted(s_break, s, side="left") - 1, 0, len(pp.x) - 2)
    _, ref = bisect_increasing(pp.c[:, piece], s, pp.x[piece], pp.x[piece + 1], 60,
                               origin=pp.x[piece])
    inner = pp(ref, 1) > 1e-6
    np.testing.assert_allclose(got[inner], ref[inner], rtol=1e-13, atol=1e-13)
    # the feed at the inverse, what the replay reads, agrees to rounding
    np.testing.assert_allclose(tr.feed_at(s[inner]), pp(ref[inner], 1), rtol=1e-12)


def test_cubic_with_a_flat_inflection_matches_the_closed_form():
    # s(t) = (t - 1)^3 + 1 on [0, 2]: sdot = 0 at t = 1, where Newton's steps blow up and the
    # bracket has to take over; inverse t = 1 + cbrt(s - 1)
    c = np.array([[1.0], [-3.0], [3.0], [0.0]])  # (t - 1)^3 + 1 expanded about 0
    tr = Trajectory(law="test", timing=PPoly(c, np.array([0.0, 2.0])))
    s = np.linspace(0.0, 2.0, 2001)
    want = 1.0 + np.cbrt(s - 1.0)
    got = tr.time_at(s)
    away = np.abs(s - 1.0) > 1e-6
    np.testing.assert_allclose(got[away], want[away], rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(got - want)) < 1e-5  # cbrt(rounding of s) at the inflection
    assert np.all((got[1:] - got[:-1]) > 0)


def test_targets_at_a_piece_start_return_the_start_exactly():
    tr = _random_quintic_trajectory(4)
    pp = tr.timing
    s_break = pp(pp.x)
    got = tr.time_at(s_break[:-1])
    # a breakpoint value is reached at the end of the piece before it (the piece's start):
    # there to the rounding of s(t) (a few ulp of s, 1e-14 s at these feeds)
    np.testing.assert_allclose(got, pp.x[:-1], rtol=1e-14, atol=0)
    assert tr.time_at(np.array([0.0]))[0] == 0.0  # the first piece's start, exactly
    single = earliest_crossing(pp.c[:, 3:4], s_break[3:4], pp.x[3:4], pp.x[4:5])
    assert single[0] == pp.x[3]  # the start of the piece itself reaches it: exactly the start


def test_earliest_crossing_finds_the_start_of_a_dwell_inside_the_bracket():
    # constant pieces of a trajectory that stands still: the earliest time is the dwell start
    c = np.array([[0.0, 0.0, 0.0], [1e-3, 0.0, 1e-3], [0.0, 1e-3, 1e-3]])
    lo, hi = np.array([0.0, 1.0, 2.0]), np.array([1.0, 2.0, 3.0])
    got = earliest_crossing(c, np.array([1e-3, 1e-3, 1.5e-3]), lo, hi)
    np.testing.assert_allclose(got, [1.0, 1.0, 2.5], rtol=0, atol=1e-15)

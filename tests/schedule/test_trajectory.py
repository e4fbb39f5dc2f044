"""Trajectory: the s -> t inverse (time_at, feed_at) and typed law stats (LawStats)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pytest
from scipy.interpolate import PPoly

from feedopt.schedule.quintic import QuinticPieces
from feedopt.schedule.trajectory import LawStats, Trajectory, outcome


def _accel_cruise_brake(a: float, v: float, t_cruise: float) -> Trajectory:
    """Constant acceleration a to v, cruise, constant deceleration to rest (piecewise
    quadratic, like toppra's output)."""
    t1 = v / a
    s1 = 0.5 * a * t1**2
    s2 = s1 + v * t_cruise
    c = np.array([[0.5 * a, 0.0, -0.5 * a], [0.0, v, v], [0.0, s1, s2]])
    x = np.array([0.0, t1, t1 + t_cruise, 2 * t1 + t_cruise])
    return Trajectory(law="test", timing=PPoly(c, x), continuity=1)


def test_time_at_matches_the_closed_form_of_constant_acceleration():
    a, v, tc = 0.5, 4e-3, 2.0
    tr = _accel_cruise_brake(a, v, tc)
    t1 = v / a
    s1 = 0.5 * a * t1**2
    L = tr.length
    s = np.linspace(0.0, L, 2001)
    # closed-form inverse of each phase
    brake = tr.duration - np.sqrt(2 * np.maximum(L - s, 0) / a)
    want = np.where(s <= s1, np.sqrt(2 * s / a), np.where(s <= L - s1, t1 + (s - s1) / v, brake))
    got = tr.time_at(s)
    # exact to rounding away from the rest ends; at the ends s(t) is flat, so a rounding
    # error in s of 1 ulp moves t by sqrt(2 ulp / a)
    inner = (s > 1e-6) & (s < L - 1e-6)
    np.testing.assert_allclose(got[inner], want[inner], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got, want, atol=1e-7)
    feed = np.where(s <= s1, a * want, np.where(s <= L - s1, v, a * (tr.duration - want)))
    np.testing.assert_allclose(tr.feed_at(s[inner]), feed[inner], rtol=1e-9)
    assert tr.time_at(np.array([0.0]))[0] < 1e-18 * tr.duration  # 2^-60 of the first piece


def test_time_at_inverts_quintic_pieces_like_a_dense_sampling():
    # thesis-like pieces: ramp from rest, two blends with a dip, ramp to rest
    h = np.array([0.4e-3, 20e-3, 15e-3, 0.3e-3])
    v = np.array([0.0, 4e-3, 2.75e-3, 4e-3, 0.0])
    T = np.array([2 * h[0] / v[1], h[1] / min(v[1], v[2]), h[2] / min(v[2], v[3]),
                  2 * h[3] / v[3]])
    s0 = np.concatenate([[0.0], np.cumsum(h)[:-1]])
    z = np.zeros(4)
    pp = QuinticPieces(s0=s0, h=h, v0=v[:-1], vf=v[1:], a0=z, af=z, T=T).ppoly()
    tr = Trajectory(law="test", timing=pp)
    # independent inverse: s(t) sampled densely, inverted by linear interpolation
    t_dense = np.linspace(0.0, tr.duration, 2_000_001)
    s_dense = pp(t_dense)
    assert np.all(np.diff(s_dense) >= 0)
    s = np.linspace(0.0, tr.length, 5001)[1:-1]
    want = np.interp(s, s_dense, t_dense)
    got = tr.time_at(s)
    dt = t_dense[1]
    assert np.max(np.abs(got - want)) < 2 * dt
    # and exactly consistent with s(t): s(time_at(s)) == s to rounding
    np.testing.assert_allclose(pp(got), s, rtol=1e-13, atol=1e-16)


def test_time_at_is_the_earliest_time_on_a_dwell():
    # move 1 mm in 1 s, stand still for 1 s, move again: s = 1 mm is reached at t = 1
    c = np.array([[0.0, 0.0, 0.0], [1e-3, 0.0, 1e-3], [0.0, 1e-3, 1e-3]])
    tr = Trajectory(law="test", timing=PPoly(c, np.array([0.0, 1.0, 2.0, 3.0])), continuity=0)
    got = tr.time_at(np.array([0.5e-3, 1e-3, 1.5e-3, 2e-3, 5e-3, -1.0]))
    np.testing.assert_allclose(got, [0.5, 1.0, 2.5, 3.0, 3.0, 0.0], atol=1e-12)


class _Row(NamedTuple):
    a: float
    b: str


@dataclass(frozen=True)
class _Record(LawStats):
    x: float
    hidden: int = outcome(0)


@dataclass(frozen=True)
class _Stats(LawStats):
    n: int
    pair: tuple[float, float]
    rows: tuple[_Row, ...]
    records: tuple[_Record, ...]
    optional: float | None = None
    flag: bool = outcome(False)


def test_law_stats_as_dict_is_the_summary_entry():
    st = _Stats(n=3, pair=(1.0, 2.0), rows=(_Row(1.5, "line"),), records=(_Record(2.5, 7),),
                flag=True)
    want = {"n": 3, "pair": (1.0, 2.0), "rows": [(1.5, "line")], "records": [{"x": 2.5}]}
    assert st.as_dict() == want
    assert list(st.as_dict()) == ["n", "pair", "rows", "records"]  # declaration order
    assert type(st.as_dict()["rows"][0]) is tuple
    # typed access, and the mapping interface reads the same entries
    assert st.flag and st.records[0].hidden == 7
    assert st["n"] == 3 and dict(st.items()) == want and len(st) == 4 and "flag" not in st
    assert _Stats(1, (0.0, 0.0), (), (), optional=0.5)["optional"] == 0.5
    json.dumps(st.as_dict())
    assert Trajectory(law="x", timing=PPoly(np.ones((1, 1)), [0.0, 1.0])).stats.as_dict() == {}


def test_law_stats_are_frozen():
    st = _Record(1.0)
    with pytest.raises(AttributeError):
        st.x = 2.0  # type: ignore[misc]

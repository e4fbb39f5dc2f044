"""The five-axis orientation u(s): G2 by finite differences, exact outside the windows, within
the angle tolerance of the programmed great circles (measured densely and independently)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.geometry.orientation import OrientationKnots, blend_orientation


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _knots(s, u, stop=None):
    s = np.asarray(s, dtype=float)
    stop = np.zeros(s.size, bool) if stop is None else np.asarray(stop)
    return OrientationKnots(s, _unit(u), stop, tuple(f"point {i}" for i in range(s.size)))


def _slerp_reference(knots, s):
    """The programmed orientation by textbook slerp per interval (independent of the module)."""
    out = np.empty((s.size, 3))
    for i, x in enumerate(s):
        k = min(max(np.searchsorted(knots.s, x, side="right") - 1, 0), knots.s.size - 2)
        a, b = knots.u[k], knots.u[k + 1]
        om = math.acos(np.clip(a @ b, -1, 1))
        t = (x - knots.s[k]) / (knots.s[k + 1] - knots.s[k])
        out[i] = a if om < 1e-12 else (math.sin((1 - t) * om) * a
                                       + math.sin(t * om) * b) / math.sin(om)
    return out


def _angle(a, b):
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


KNOTS = _knots([0.0, 0.02, 0.05, 0.06, 0.1],
               [[0, 0, 1], [0.3, 0, 1], [0.3, 0.4, 1], [-0.2, 0.1, 1], [0, 0, 1]])


def test_unit_and_exact_outside_windows():
    o = blend_orientation(KNOTS, math.radians(0.5))
    s = np.linspace(0, 0.1, 20001)
    got = o.evaluate(s)
    assert np.allclose(np.linalg.norm(got.axis, axis=1), 1.0, atol=1e-12)
    ref = _slerp_reference(KNOTS, s)
    k = np.abs(s[:, None] - KNOTS.s[None, :])
    outside = np.all(k >= o.half_window[None, :] + 1e-12, axis=1)
    assert outside.sum() > 1000
    assert np.max(_angle(got.axis[outside], ref[outside])) < 1e-12
    assert np.max(_angle(got.axis, ref)) <= math.radians(0.5) * (1 + 1e-9)
    # at the knots themselves u passes near the programmed vector, within the tolerance
    assert np.all(_angle(o.evaluate(KNOTS.s).axis, KNOTS.u) <= math.radians(0.5) + 1e-12)


def test_g2_by_finite_differences():
    o = blend_orientation(KNOTS, math.radians(2.0))
    s = np.linspace(1e-4, 0.1 - 1e-4, 4001)
    e = 1e-7
    p, m, c = o.evaluate(s + e), o.evaluate(s - e), o.evaluate(s)
    assert np.allclose((p.axis - m.axis) / (2 * e), c.d1, atol=1e-5 * np.abs(c.d1).max())
    assert np.allclose((p.d1 - m.d1) / (2 * e), c.d2, atol=2e-4 * np.abs(c.d2).max())
    # continuity of u'' across every window end: one-sided values agree
    ends = np.concatenate([KNOTS.s - o.half_window, KNOTS.s + o.half_window])
    ends = ends[(ends > 1e-6) & (ends < 0.1 - 1e-6)]
    lo, hi = o.evaluate(ends - 1e-10), o.evaluate(ends + 1e-10)
    assert np.max(np.abs(hi.d2 - lo.d2)) < 1e-4 * np.abs(c.d2).max()
    assert np.max(np.abs(hi.d1 - lo.d1)) < 1e-6 * np.abs(c.d1).max()


def test_stop_keeps_the_kink_and_tighter_tolerance_narrower_windows():
    stop = [False, False, True, False, False]
    o = blend_orientation(_knots(KNOTS.s, KNOTS.u, stop), math.radians(0.5))
    assert o.half_window[2] == 0 and o.half_window[1] > 0
    wide = blend_orientation(KNOTS, math.radians(5.0)).half_window
    narrow = blend_orientation(KNOTS, math.radians(0.05)).half_window
    assert np.all(narrow[1:-1] < wide[1:-1])
    assert np.all(wide[1:-1] <= 0.5 * np.minimum(np.diff(KNOTS.s)[:-1], np.diff(KNOTS.s)[1:]))


def test_half_turn_refused_naming_the_point():
    with pytest.raises(InputError, match="point 1.*turns 18"):
        blend_orientation(_knots([0, 1], [[0, 0, 1], [0, 1e-4, -1]]), 0.01)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0.5, 20.0), st.floats(-0.8, 0.8), st.floats(-0.8, 0.8)),
                min_size=3, max_size=7),
       st.floats(0.01, 3.0))
def test_property_within_tolerance_and_unit(rows, tol_deg):
    gaps = np.array([r[0] for r in rows]) * 1e-3
    s = np.concatenate([[0.0], np.cumsum(gaps)])
    u = np.array([[0.0, 0.0, 1.0]] + [[r[1], r[2], 1.0] for r in rows])
    knots = _knots(s, u)
    o = blend_orientation(knots, math.radians(tol_deg))
    x = np.linspace(0, s[-1], 3000)
    got = o.evaluate(x).axis
    assert np.allclose(np.linalg.norm(got, axis=1), 1.0, atol=1e-12)
    assert np.max(_angle(got, _slerp_reference(knots, x))) <= math.radians(tol_deg) * 1.001


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(0.5, 20.0), st.floats(-0.8, 0.8), st.floats(-0.8, 0.8)),
                min_size=3, max_size=6),
       st.floats(0.005, 1.0), st.floats(0.05, 3.0))
def test_peaks_bound_the_rates_between_the_samples(rows, tol_deg, spacing_mm):
    """peaks() against a brute-force 400 points per sample interval (both ends included)."""
    gaps = np.array([r[0] for r in rows]) * 1e-3
    s = np.concatenate([[0.0], np.cumsum(gaps)])
    u = np.array([[0.0, 0.0, 1.0]] + [[r[1], r[2], 1.0] for r in rows])
    o = blend_orientation(_knots(s, u), math.radians(tol_deg))
    x = np.linspace(0.0, s[-1], max(3, int(s[-1] / (spacing_mm * 1e-3)) + 1))
    rate, curv = o.peaks(x)
    dense = np.linspace(0.0, 1.0, 401)
    pts = (x[:-1, None] + np.diff(x)[:, None] * dense).ravel()
    got = o.evaluate(pts)
    d1 = np.linalg.norm(got.d1, axis=1).reshape(x.size - 1, -1).max(axis=1)
    d2 = np.linalg.norm(got.d2, axis=1).reshape(x.size - 1, -1).max(axis=1)
    # each sample's peak covers both intervals beside it (within 1 % between the points)
    assert np.all(rate[:-1] >= 0.99 * d1) and np.all(rate[1:] >= 0.99 * d1)
    assert np.all(curv[:-1] >= 0.99 * d2) and np.all(curv[1:] >= 0.99 * d2)

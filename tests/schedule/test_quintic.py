"""Quintic pieces (thesis Eq. 3.21-3.22), ramps and the jerk-phase integration."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.schedule.polynomial import quintic_hermite
from feedopt.schedule.quintic import (
    QuinticPieces,
    fit_length,
    ppoly_from_jerk_phases,
    quintic_ramp_duration,
    scurve_distance,
    scurve_times,
)
from feedopt.schedule.trajectory import Trajectory

pos = st.floats(0.1, 5.0)
acc = st.floats(-3.0, 3.0)


@settings(max_examples=50, deadline=None)
@given(h=pos, v0=pos, vf=pos, a0=acc, af=acc, T=pos)
def test_coefficients_solve_eq_3_22(h, v0, vf, a0, af, T):
    # Independent: the 6x6 linear system of Eq. 3.22 in the unknowns a0..a5 (Eq. 3.21).
    M = np.array(
        [
            [1, 0, 0, 0, 0, 0],
            [1, T, T**2, T**3, T**4, T**5],
            [0, 1, 0, 0, 0, 0],
            [0, 1, 2 * T, 3 * T**2, 4 * T**3, 5 * T**4],
            [0, 0, 2, 0, 0, 0],
            [0, 0, 2, 6 * T, 12 * T**2, 20 * T**3],
        ]
    )
    want = np.linalg.solve(M, [0.0, h, v0, vf, a0, af])
    got = quintic_hermite(T, h, v0, vf, a0, af)[::-1, 0]
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())


def test_blend_dip_closed_form():
    # Eq. 3.22 with zero end accelerations and t_f = h / min(v0, vf): the feed dips to
    # min - 0.512 (max - min) at u = 0.6 (dense numeric check).
    for v0, vf in [(4.0, 2.75), (2.75, 4.0), (3.0, 3.0), (5.0, 2.0)]:
        h = 20.0
        T = h / min(v0, vf)
        c = quintic_hermite(T, h, v0, vf, 0.0, 0.0)[:, 0]
        t = np.linspace(0, T, 200001)
        v = np.polyval(np.polyder(c), t)
        lo, hi = min(v0, vf), max(v0, vf)
        assert abs(v.min() - (lo - 0.512 * (hi - lo))) < 1e-9
        if v0 > vf:
            assert abs(t[np.argmin(v)] / T - 0.6) < 1e-4


@settings(max_examples=30, deadline=None)
@given(v0=st.floats(0, 6e-3), v1=st.floats(0, 6e-3))
def test_ramp_duration_meets_limits(v0, v1):
    A, J = 0.5, 5.0
    T = float(quintic_ramp_duration(v0, v1, A, J))
    if abs(v1 - v0) < 1e-9:  # (T^5 underflows for denormal feed changes)
        assert T < 1e-4
        return
    c = quintic_hermite(T, 0.5 * (v0 + v1) * T, v0, v1, 0.0, 0.0)[:, 0]
    t = np.linspace(0, T, 4001)
    a = np.abs(np.polyval(np.polyder(c, 2), t)).max()
    j = np.abs(np.polyval(np.polyder(c, 3), t)).max()
    assert a <= A * (1 + 1e-9) and j <= J * (1 + 1e-9)
    assert max(a / A, j / J) > 1 - 1e-3  # the shortest: one limit is reached
    v = np.polyval(np.polyder(c), t)
    assert v.min() >= min(v0, v1) - 1e-15 and v.max() <= max(v0, v1) + 1e-15


@settings(max_examples=30, deadline=None)
@given(v0=st.floats(0, 0.5), v1=st.floats(0, 0.5))
def test_scurve_distance_matches_integration(v0, v1):
    A, J = 0.5, 5.0
    tj, ta = scurve_times(v1 - v0, A, J)
    if abs(v1 - v0) < 1e-12:  # denormal feed changes: nothing to integrate
        assert tj < 1e-6 and ta == 0
        return
    g = 1.0 if v1 >= v0 else -1.0
    pp = ppoly_from_jerk_phases(np.array([tj, ta, tj]), g * np.array([J, 0.0, -J]), v0=v0)
    T = pp.x[-1]
    assert abs(pp.derivative()(T) - v1) < 1e-12
    assert abs(pp.derivative(2)(T)) < 1e-12
    assert abs(pp.derivative(2)(pp.x)).max() <= A * (1 + 1e-12)
    assert abs(pp(T) - scurve_distance(v0, v1, A, J)) < 1e-12


def test_feed_at_matches_trajectory_inverse():
    rng = np.random.default_rng(3)
    m = 6
    h = rng.uniform(1e-3, 3e-3, m)
    v = rng.uniform(2e-3, 3e-3, m + 1)
    T = h / np.minimum(v[:-1], v[1:])
    a = np.concatenate([[0.0], rng.uniform(-2e-4, 2e-4, m - 1), [0.0]])
    pieces = QuinticPieces(
        s0=np.concatenate([[0.0], np.cumsum(h)[:-1]]), h=h, v0=v[:-1], vf=v[1:],
        a0=a[:-1], af=a[1:], T=T,
    )
    traj = Trajectory(law="x", timing=pieces.ppoly())
    s = np.linspace(0, h.sum(), 777)
    piece = np.clip(np.searchsorted(pieces.s0, s, side="right") - 1, 0, m - 1)
    np.testing.assert_allclose(pieces.feed_at(s, piece), traj.feed_at(s), rtol=1e-9)
    lo, hi = pieces.feed_range()
    dense = traj.at(np.linspace(0, traj.duration, 20001)).sdot
    assert lo.min() >= dense.min() - 1e-12 and hi.max() <= dense.max() + 1e-12


def test_fit_length_ends_on_the_path_and_keeps_c2():
    pp = ppoly_from_jerk_phases(np.array([0.1, 0.3, 0.1, 2.0]), np.array([5.0, 0, -5.0, 0]))
    L = float(pp(pp.x[-1])) * (1 + 1e-13)
    out = fit_length(pp, L)
    assert L - 1e-15 <= out(out.x[-1]) <= L
    for k in range(3):
        d = out.derivative(k) if k else out
        left = d(out.x[1:-1] - 1e-12)
        right = d(out.x[1:-1])
        assert np.abs(left - right).max() < 1e-9

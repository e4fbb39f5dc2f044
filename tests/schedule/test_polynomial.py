"""The numerics kernel: quintic Hermite (Eq. 3.21-3.22), Horner, bisection, piece sampling."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import PPoly

from feedopt.schedule.polynomial import (
    bisect_increasing,
    derivative_coefficients,
    horner,
    quintic_hermite,
    quintic_hermite_spline,
    sample_pieces,
)

pos = st.floats(0.1, 5.0)
val = st.floats(-3.0, 3.0)


def _fd_derivatives(c: np.ndarray, x: float, step: float) -> tuple[float, float, float]:
    """Value, first and second derivative of the polynomial ``c`` at ``x`` by central finite
    differences of numpy's polyval (independent of the kernel's evaluation)."""
    f = [np.polyval(c, x + k * step) for k in (-2, -1, 0, 1, 2)]
    d1 = (f[0] - 8 * f[1] + 8 * f[3] - f[4]) / (12 * step)
    d2 = (-f[0] + 16 * f[1] - 30 * f[2] + 16 * f[3] - f[4]) / (12 * step**2)
    return f[2], d1, d2


@settings(max_examples=60, deadline=None)
@given(T=pos, dp=val, v0=val, v1=val, a0=val, a1=val, p0=val)
def test_hermite_end_conditions_by_finite_differences(T, dp, v0, v1, a0, a1, p0):
    c = quintic_hermite(T, dp, v0, v1, a0, a1, p0)[:, 0]
    step = 1e-3 * T
    for x, want in ((0.0, (p0, v0, a0)), (T, (p0 + dp, v1, a1))):
        got = _fd_derivatives(c, x, step)
        scale = 1.0 + abs(dp) / T**2 + abs(v0) / T + abs(v1) / T + abs(a0) + abs(a1)
        np.testing.assert_allclose(got, want, atol=1e-6 * scale * max(1.0, T**2))


def test_hermite_broadcasts_one_width_over_several_curves():
    # toppra's q(s): one width per piece, (m, dof) end values
    rng = np.random.default_rng(1)
    h = rng.uniform(0.1, 2.0, 5)
    p, v, a = (rng.normal(size=(6, 3)) for _ in range(3))
    c = quintic_hermite_spline(h, p, v, a)
    assert c.shape == (6, 5, 3)
    for k in range(5):
        for j in range(3):
            poly = np.poly1d(c[:, k, j])
            for order, y in enumerate((p, v, a)):
                d = poly.deriv(order) if order else poly
                assert d(0.0) == pytest.approx(y[k, j], abs=1e-9)
                assert d(h[k]) == pytest.approx(y[k + 1, j], abs=1e-9)


def test_hermite_spline_is_c2_as_a_ppoly():
    rng = np.random.default_rng(2)
    x = np.cumsum(rng.uniform(0.2, 1.0, 8))
    p, v, a = (rng.normal(size=8) for _ in range(3))
    pp = PPoly(quintic_hermite_spline(np.diff(x), p, v, a), x)
    for order, y in enumerate((p, v, a)):
        d = pp.derivative(order) if order else pp
        left = d(x[1:] - 1e-12)
        np.testing.assert_allclose(d(x), y, atol=1e-9)
        np.testing.assert_allclose(left, y[1:], atol=1e-6)


def test_horner_equals_numpy_polyval_per_piece():
    rng = np.random.default_rng(3)
    c = rng.normal(size=(6, 7))  # 7 quintics
    x = rng.uniform(-2, 2, 7)
    want = [np.polyval(c[:, i], x[i]) for i in range(7)]
    np.testing.assert_allclose(horner(c, x), want, rtol=1e-13, atol=1e-13)
    # every piece at the same points: (p, 1) x (6, m) -> (p, m)
    u = np.linspace(0, 1, 11)
    grid = horner(c, u[:, None])
    assert grid.shape == (11, 7)
    for i in range(7):
        np.testing.assert_allclose(grid[:, i], np.polyval(c[:, i], u), rtol=1e-13, atol=1e-13)
    # scalars and constants
    assert horner(np.array([2.0, -1.0, 3.0]), 2.0) == pytest.approx(9.0)
    assert horner(np.array([[4.0]]), np.zeros(1))[0] == 4.0


def test_derivative_coefficients_match_numpy_and_scipy():
    rng = np.random.default_rng(4)
    c = rng.normal(size=(6, 4))
    for order in range(0, 7):
        got = derivative_coefficients(c, order)
        for i in range(4):
            want = np.polyder(c[:, i], order) if order <= 5 else np.zeros(1)
            np.testing.assert_allclose(got[-want.size:, i], want, rtol=1e-14)
    pp = PPoly(c, np.arange(5.0))
    np.testing.assert_array_equal(derivative_coefficients(c, 2), pp.derivative(2).c)


def test_bisect_increasing_finds_the_roots_of_monotone_cubics():
    rng = np.random.default_rng(5)
    n = 50
    # p(x) = x^3 + b x + d with b > 0: strictly increasing, one real root
    b = rng.uniform(0.1, 2.0, n)
    target = rng.uniform(-3.0, 3.0, n)
    c = np.stack([np.ones(n), np.zeros(n), b, np.zeros(n)])
    lo, hi = bisect_increasing(c, target, np.full(n, -3.0), np.full(n, 3.0), 60)
    roots = np.array([np.real(r[np.abs(np.imag(r)) < 1e-9][0])
                      for r in (np.roots([1, 0, bi, -ti]) for bi, ti in zip(b, target,
                                                                            strict=True))])
    np.testing.assert_allclose(hi, roots, atol=1e-12)
    assert np.all(lo <= hi) and np.all(horner(c, lo) < target)
    # local variable: the same polynomials shifted by an origin
    origin = rng.uniform(-1, 1, n)
    _, hi2 = bisect_increasing(c, target, origin - 3.0, origin + 3.0, 60, origin=origin)
    np.testing.assert_allclose(hi2 - origin, roots, atol=1e-12)


def test_sample_pieces_with_and_without_endpoints():
    breaks = np.array([0.0, 1.0, 3.0])
    with_ends = sample_pieces(breaks, 3)
    np.testing.assert_array_equal(with_ends, [0.0, 0.5, 1.0, 1.0, 2.0, 3.0])
    open_ends = sample_pieces(breaks, 2, endpoint=False)
    np.testing.assert_array_equal(open_ends, [0.0, 0.5, 1.0, 2.0, 3.0])

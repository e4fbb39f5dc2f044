"""q(s) split at stops: one cubic spline per piece, joined."""

import numpy as np
from scipy.interpolate import CubicSpline

from feedopt.robot.stage import joint_spline


def _corner_path():
    # a joint path with a kink at s = 0.5 (the path reverses there): |s - 0.5| per joint
    s = np.linspace(0.0, 1.0, 21)
    q = np.stack([np.abs(s - 0.5), 2.0 * np.abs(s - 0.5) + s ** 2], axis=1)
    return s, q


def test_pieces_are_the_splines_of_each_side():
    s, q = _corner_path()
    pp = joint_spline(s, q, np.array([10]))
    left, right = CubicSpline(s[:11], q[:11], axis=0), CubicSpline(s[10:], q[10:], axis=0)
    x = np.linspace(0.0, 0.5, 101)[:-1]
    assert np.allclose(pp(x), left(x), atol=1e-14)
    x = np.linspace(0.5, 1.0, 101)
    assert np.allclose(pp(x), right(x), atol=1e-14)
    assert np.allclose(pp(x, 1), right(x, 1), atol=1e-12)


def test_a_kink_is_kept_exactly_no_overshoot():
    s, q = _corner_path()
    x = np.linspace(0.0, 1.0, 2001)
    exact = np.stack([np.abs(x - 0.5), 2.0 * np.abs(x - 0.5) + x ** 2], axis=1)
    split = joint_spline(s, q, np.array([10]))(x)
    assert np.max(np.abs(split - exact)) < 1e-12  # piecewise linear/quadratic: exact
    smooth = CubicSpline(s, q, axis=0)(x)
    assert np.max(np.abs(smooth - exact)) > 1e-3  # one spline rounds the kink


def test_without_breaks_it_is_one_spline():
    s, q = _corner_path()
    assert isinstance(joint_spline(s, q, None), CubicSpline)
    assert np.allclose(joint_spline(s, q, np.array([], dtype=int))(s), q)


def test_right_sided_derivative_at_the_break_and_continuity():
    s, q = _corner_path()
    pp = joint_spline(s, q, np.array([10]))
    assert np.allclose(pp(s), q, atol=1e-14)
    assert np.allclose(pp(0.5, 1), [1.0, 3.0])  # the right side's slope (1, 2 + 2 s)
    assert np.allclose(pp(0.5 - 1e-9, 1), [-1.0, -1.0], atol=1e-6)

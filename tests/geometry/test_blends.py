"""Blend geometry against independent computations (appendix B.1, Eq. 3.1-3.17)."""

import numpy as np
import pytest
from scipy.integrate import quad

from feedopt.geometry import blends, waves
from feedopt.geometry.path import build_lipb_path


def _corner(turn: float, l1: float = 0.1, l2: float = 0.08) -> np.ndarray:
    """Three XY waypoints: along +x, then turning left by ``turn``."""
    return np.array([[0, 0, 0], [l1, 0, 0], [l1 + l2 * np.cos(turn), l2 * np.sin(turn), 0]])


@pytest.mark.parametrize("turn", [0.3, np.pi / 2, 1.9655, 2.8])
def test_circle_tangent_points_follow_appendix_b1(turn):
    w = _corner(turn, 0.4, 0.35)
    r = 0.0127
    path = build_lipb_path(w, "circle", r)
    # appendix B.1 with interior angle alpha from v1 = Pc->P1, v2 = Pc->P2
    v1, v2 = w[0] - w[1], w[2] - w[1]
    alpha = np.arccos(v1 @ v2 / np.linalg.norm(v1) / np.linalg.norm(v2))
    ls = r / abs(np.tan(alpha / 2))
    pt1 = w[1] + ls * v1 / np.linalg.norm(v1)
    pt2 = w[1] + ls * v2 / np.linalg.norm(v2)
    arc = path.segments[1]
    assert arc.kind == "circle"
    p = path.evaluate([arc.s_start, arc.s_end]).position
    np.testing.assert_allclose(p[0], pt1, atol=1e-15)
    np.testing.assert_allclose(p[1], pt2, atol=1e-15)
    # centre: distance r from both lines, on the inside (B.1: P_cc = P_t1 + r u_perp)
    centre = arc.params["centre"]
    assert np.linalg.norm(centre - pt1) == pytest.approx(r, rel=1e-12)
    assert np.linalg.norm(centre - pt2) == pytest.approx(r, rel=1e-12)
    assert (centre - pt1) @ v1 == pytest.approx(0, abs=1e-15)
    assert centre[1] > 0  # a left turn from +x: centre on the +y side
    assert arc.length == pytest.approx(r * (np.pi - alpha), rel=1e-12)


def _bezier(ctrl: np.ndarray, u: float, der: int = 0) -> np.ndarray:
    """Independent de Casteljau / hodograph evaluation."""
    pts = np.asarray(ctrl, dtype=float)
    for _ in range(der):
        pts = (len(pts) - 1) * np.diff(pts, axis=0)
    while len(pts) > 1:
        pts = (1 - u) * pts[:-1] + u * pts[1:]
    return pts[0]


@pytest.mark.parametrize("order", [4, 5])
@pytest.mark.parametrize("turn", [0.2, 1.9655, 3.0])
def test_bezier_control_points_and_alpha(order, turn):
    w = _corner(turn)
    delta = 0.01
    path = build_lipb_path(w, f"bezier{order}", delta)
    seg = path.segments[1]
    ctrl, alpha = seg.params["control"], seg.params["alpha"]
    q = w[1]
    t0 = (w[1] - w[0]) / np.linalg.norm(w[1] - w[0])
    t1 = (w[2] - w[1]) / np.linalg.norm(w[2] - w[1])
    qa, qb = q - delta * t0, q + delta * t1
    np.testing.assert_allclose(ctrl[0], qa, atol=1e-16)
    np.testing.assert_allclose(ctrl[-1], qb, atol=1e-16)
    if order == 4:  # Eq. 3.4
        np.testing.assert_allclose(ctrl[1], qa + alpha / 4 * t0, atol=1e-16)
        np.testing.assert_allclose(ctrl[2], q, atol=1e-16)
        np.testing.assert_allclose(ctrl[3], qb - alpha / 4 * t1, atol=1e-16)
        a, b, c = 4 - abs(t0 + t1) @ abs(t0 + t1) / 4, 3 * (qb - qa) @ (t0 + t1), \
            -9 * (qb - qa) @ (qb - qa)
    else:  # Eq. 3.8
        np.testing.assert_allclose(ctrl[1], qa + alpha / 5 * t0, atol=1e-16)
        np.testing.assert_allclose(ctrl[2], 2 * ctrl[1] - ctrl[0], atol=1e-16)
        np.testing.assert_allclose(ctrl[4], qb - alpha / 5 * t1, atol=1e-16)
        np.testing.assert_allclose(ctrl[3], 2 * ctrl[4] - ctrl[5], atol=1e-16)
        a, b, c = 256 - 49 * (t0 + t1) @ (t0 + t1), 420 * (qb - qa) @ (t0 + t1), \
            -900 * (qb - qa) @ (qb - qa)
    roots = np.roots([a, b, c])
    assert alpha == pytest.approx(roots.real.max(), rel=1e-10)  # largest root (Eq. 3.3/3.7)
    # the quadratic makes the speed at mid-curve equal to alpha
    assert np.linalg.norm(_bezier(ctrl, 0.5, 1)) == pytest.approx(alpha, rel=1e-10)
    # end tangents along the lines, second derivatives along the tangents (G2 with lines)
    for u, t in ((0.0, t0), (1.0, t1)):
        d1, d2 = _bezier(ctrl, u, 1), _bezier(ctrl, u, 2)
        np.testing.assert_allclose(d1 / np.linalg.norm(d1), t, atol=1e-14)
        assert np.linalg.norm(np.cross(d2, t)) <= 1e-12 * max(np.linalg.norm(d2), 1)


@pytest.mark.parametrize("order", [4, 5])
def test_bezier_evaluated_by_arc_length_matches_independent_inverse(order):
    """p(s) of the path equals the Bezier curve at u(s) found by quad + root finding."""
    from scipy.optimize import brentq

    w = _corner(1.9655)
    path = build_lipb_path(w, f"bezier{order}", 0.015)
    seg = path.segments[1]
    ctrl = seg.params["control"]

    def s_of(u):
        return quad(lambda x: np.linalg.norm(_bezier(ctrl, x, 1)), 0, u, epsabs=1e-15,
                    epsrel=1e-13)[0]

    total = s_of(1.0)
    assert seg.length == pytest.approx(total, rel=1e-11)
    for frac in np.linspace(0.03, 0.97, 9):
        s_loc = frac * total
        u = brentq(lambda x, s_loc=s_loc: s_of(x) - s_loc, 0, 1, xtol=1e-15)
        p = path.evaluate(seg.s_start + s_loc).position[0]
        # 1e-9 of the blend length in s maps to at most that distance in position
        assert np.linalg.norm(p - _bezier(ctrl, u)) <= 1e-9 * total


def test_varying_radius_end_conditions():
    """r(0) = r(tf) = r0, r' = 0 and radial acceleration r'' - r = 0 at both ends (Eq. 3.12),
    checked with finite differences of Eq. 3.17 as written in the thesis."""
    r0, tf = 0.0127, 1.9655

    def r_thesis(th):
        return r0 / (2 * tf**2) * th**2 * (th - tf) ** 2 + r0

    r, dr, d2r, d3r = blends.varying_radius(np.array([0.0, tf]), r0, tf)
    np.testing.assert_allclose(r, r0, rtol=1e-15)
    np.testing.assert_allclose(dr, 0.0, atol=1e-18)
    np.testing.assert_allclose(d2r - r, 0.0, atol=1e-17)
    # derivatives against finite differences of the thesis formula in the interior
    th = np.linspace(0.1, tf - 0.1, 7)
    h = 1e-4
    r1, dr1, d2r1, d3r1 = blends.varying_radius(th, r0, tf)
    np.testing.assert_allclose(r1, r_thesis(th), rtol=1e-14)
    np.testing.assert_allclose(dr1, (r_thesis(th + h) - r_thesis(th - h)) / (2 * h), atol=1e-10)
    fd2 = (r_thesis(th + h) - 2 * r_thesis(th) + r_thesis(th - h)) / h**2
    np.testing.assert_allclose(d2r1, fd2, atol=1e-7)
    fd3 = (r_thesis(th + 2 * h) - 2 * r_thesis(th + h) + 2 * r_thesis(th - h)
           - r_thesis(th - 2 * h)) / (2 * h**3)
    np.testing.assert_allclose(d3r1, fd3, atol=1e-4)
    # radial acceleration for an arbitrary timing theta(t) vanishes at the ends
    for th_dot, th_ddot in ((1.3, 0.0), (0.4, 2.5), (2.0, -7.0)):
        for t_end in (0.0, tf):
            r_, dr_, d2r_, _ = blends.varying_radius(np.array(t_end), r0, tf)
            r_ddot = d2r_ * th_dot**2 + dr_ * th_ddot
            assert abs(r_ddot - r_ * th_dot**2) <= 1e-17


@pytest.mark.parametrize("mirror", [False, True])
def test_varying_radius_is_the_thesis_polar_curve_about_the_circle_centre(mirror):
    """Path points lie on r(theta) about the B.1 centre, theta from the B.1 start angle."""
    w = waves.triangle_wave()[:3]
    if mirror:
        w = w * np.array([1, -1, 1])
    v1, v2 = w[1] - w[0], w[2] - w[1]
    clockwise = v1[0] * v2[1] - v1[1] * v2[0] < 0
    assert clockwise != mirror  # the first triangle-wave peak turns right
    r0 = 0.0127
    path = build_lipb_path(w, "varying_radius", r0)
    circle = build_lipb_path(w, "circle", r0).segments[1]
    seg = path.segments[1]
    centre = circle.params["centre"]
    pts = path.evaluate(np.linspace(seg.s_start, seg.s_end, 41)).position
    rel = pts - centre
    ang = np.arctan2(rel[:, 1], rel[:, 0])
    start = circle.params["e1"]
    theta1 = np.arctan2(start[1], start[0])
    theta = np.unwrap(ang - theta1)
    theta = -theta if clockwise else theta
    tf = seg.params["angle"]
    assert theta[0] == pytest.approx(0, abs=1e-12)
    assert theta[-1] == pytest.approx(tf, abs=1e-12)
    expect = r0 / (2 * tf**2) * theta**2 * (theta - tf) ** 2 + r0
    np.testing.assert_allclose(np.linalg.norm(rel[:, :2], axis=1), expect, rtol=1e-13)
    # the blend length is the integral of Eq. 3.23
    ref = quad(lambda t: np.hypot(r0 / (2 * tf**2) * t**2 * (t - tf) ** 2 + r0,
                                  r0 / tf**2 * t * (t - tf) * (2 * t - tf)), 0, tf,
               epsabs=1e-15, epsrel=1e-13)[0]
    assert seg.length == pytest.approx(ref, rel=1e-12)


def test_varying_radius_arc_length_inverse_within_1e9_of_length():
    """theta(s) from the table + Newton agrees with an independent s(theta) to 1e-9 L."""
    from feedopt.geometry.arclength import arc_length, invert

    w = _corner(2.7)
    path = build_lipb_path(w, "varying_radius", 0.005)
    ev = path._eval[path._code[1]]
    seg = path.segments[1]
    r0, tf = seg.params["radius"], seg.params["angle"]

    def sig(t):
        r, dr, _, _ = blends.varying_radius(t, r0, tf)
        return np.hypot(r, dr)

    s_targets = np.linspace(0, seg.length, 23)
    th = invert(ev.speed, ev.table, np.zeros(23, dtype=int), s_targets)
    s_back = np.array([quad(sig, 0, t, epsabs=1e-16, epsrel=1e-13)[0] for t in th])
    assert np.max(np.abs(s_back - s_targets)) <= 1e-9 * seg.length
    np.testing.assert_allclose(arc_length(ev.speed, np.zeros(23, dtype=int), th, ev.table),
                               s_back, atol=1e-12 * seg.length)


def test_varying_radius_peak_curvature_is_about_1_5_over_r0():
    """Noticed while checking Eq. 3.17: kappa(tf/2) = 1/r_mid + r0/(2 r_mid^2)."""
    r0, turn = 0.0127, 1.9655
    path = build_lipb_path(_corner(turn), "varying_radius", r0)
    seg = path.segments[1]
    k = np.linalg.norm(path.evaluate(seg.s_start + seg.length / 2).curvature[0])
    r_mid = r0 * (1 + turn**2 / 32)
    assert k == pytest.approx(1 / r_mid + r0 / (2 * r_mid**2), rel=1e-10)


@pytest.mark.parametrize(("order", "margin"), [(4, 0.1001), (5, 0.0011), (5, 0.3)])
def test_bezier_sharp_corners_arc_length_inverse(order, margin):
    """Near-reversal corners (speed dips): s(u(s)) still within 1e-9 of the length."""
    from feedopt.geometry.arclength import invert

    w = _corner(np.pi - margin, 0.05, 0.05)
    path = build_lipb_path(w, f"bezier{order}", 0.01)
    seg = path.segments[1]
    ctrl = seg.params["control"]
    ev = path._eval[path._code[1]]

    def speed(x):
        return np.linalg.norm(_bezier(ctrl, x, 1))

    length = quad(speed, 0, 1, points=[0.5], epsabs=1e-16, epsrel=1e-12, limit=500)[0]
    s_t = np.linspace(0, seg.length, 41)
    u = invert(ev.speed, ev.table, np.zeros(41, dtype=int), s_t)
    back = [quad(speed, 0, x, points=[0.5] if x > 0.5 else None, epsabs=1e-16, epsrel=1e-12,
                 limit=500)[0] for x in u]
    assert np.max(np.abs(np.array(back) - s_t)) <= 1e-9 * length


def test_bezier4_refuses_near_reversal():
    from feedopt.errors import InputError

    with pytest.raises(InputError, match="bezier4 blend degenerates at the corner at waypoint 1"):
        build_lipb_path(_corner(np.pi - 0.09, 0.05, 0.05), "bezier4", 0.01)
    build_lipb_path(_corner(np.pi - 0.09, 0.05, 0.05), "bezier5", 0.01)

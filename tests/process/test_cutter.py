"""Property tests of the cutter profile (:mod:`feedopt.process.cutter`) on random tools of every
shape, each against an independent computation: finite differences of ``at_length``, the
inverse of ``length_to_height``, a brute-force polyline of the profile built by angle, the
midpoint rule's bound for a monotone integrand, and the ball-nose closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from feedopt.process.cutter import CutterShape, profile_slices
from feedopt.process.tool import Tool
from feedopt.units import MM

SETTINGS = settings(max_examples=80, deadline=None)
FRACTIONS = st.lists(st.floats(0.0, 1.0), min_size=1, max_size=8)
# depths below 1e-6 of the flute length (down to subnormals) lose z = rc (1 - cos kappa) to
# rounding near the tip: z == 0 at depth 3e-26 m on a 1 mm ball (see the report)
DEPTHS = st.lists(st.just(0.0) | st.floats(1e-6, 1.0), min_size=1, max_size=8)


@st.composite
def tools(draw, shapes=tuple(CutterShape), sharp: bool = True) -> Tool:
    """A random valid Tool: D 0.5..60 mm, rc and taper within the shape's rules."""
    shape = draw(st.sampled_from(shapes))
    d = draw(st.floats(0.5, 60.0)) * MM
    r = d / 2.0
    corner = (st.just(0.0) | st.floats(1e-3, 0.999)) if sharp else st.floats(1e-3, 0.999)
    rc, taper = 0.0, 0.0
    if shape is CutterShape.BALL:
        rc = r
    elif shape is CutterShape.BULL:
        rc = r * draw(st.floats(1e-3, 0.999))
    elif shape is CutterShape.TAPERED:
        taper = math.radians(draw(st.floats(0.1, 80.0)))
        rc = r * draw(corner | st.just(1.0))
    elif shape is CutterShape.FACE:
        taper = math.radians(90.0 - draw(st.floats(10.0, 90.0)))  # lead angle 10..90 deg
        rc = r * draw(corner)
    flute = draw(st.floats(0.1, 150.0)) * MM
    return Tool("t", d, 2, math.radians(30.0), flute, shape=shape, corner_radius=rc, taper=taper)


def _kappa1(tool: Tool) -> float:
    return math.pi / 2 - tool.taper


def _span(tool: Tool) -> float:
    """Profile length up to the flute length."""
    return float(tool.profile.length_to_height(tool.flute_length))


def _points(tool: Tool, s: np.ndarray) -> np.ndarray:
    r, z, _, _ = tool.profile.at_length(s)
    return np.stack([r, z])


@given(tools(), FRACTIONS)
@SETTINGS
def test_at_length_is_unit_speed_along_the_tangent(tool: Tool, fractions: list[float]) -> None:
    """(dr/ds, dz/ds) by central differences == (cos kappa, sin kappa); kappa nondecreasing in
    [0, pi/2] and sin^2 + cos^2 = 1."""
    p, total = tool.profile, _span(tool)
    a, rc = p.arc_length, p.corner
    s = np.concatenate([np.linspace(0.0, total, 301), np.asarray(fractions) * total])
    h = np.where(s < a, 1e-4 * rc, 1e-4 * total)
    ok = (s > h) & (np.abs(s - a) > 2 * h)
    s, h = s[ok], h[ok]
    deriv = (_points(tool, s + h) - _points(tool, s - h)) / (2 * h)
    _, _, sk, ck = p.at_length(s)
    np.testing.assert_allclose(deriv[0], ck, atol=1e-7)
    np.testing.assert_allclose(deriv[1], sk, atol=1e-7)
    grid = np.sort(np.concatenate([np.linspace(0.0, total, 501), [a], s]))
    _, _, sk, ck = p.at_length(grid)
    np.testing.assert_allclose(sk**2 + ck**2, 1.0, rtol=0, atol=1e-14)
    kappa = np.arctan2(sk, ck)
    assert np.all(kappa >= 0.0) and np.all(kappa <= math.pi / 2)
    assert np.all(np.diff(kappa) >= -1e-12)


@given(tools(), FRACTIONS)
@SETTINGS
def test_length_to_height_inverts_the_height(tool: Tool, fractions: list[float]) -> None:
    """z(length_to_height(z)) == z, z in [0, flute length] and at the arc top z_e. Near the tip
    arccos(1 - z/rc) is ill-conditioned: an absolute eps * rc is allowed."""
    p = tool.profile
    z_e = p.arc_top[1]
    z = np.concatenate([[0.0, z_e, tool.flute_length], np.asarray(fractions) * tool.flute_length])
    _, back, _, _ = p.at_length(p.length_to_height(z))
    np.testing.assert_allclose(back, z, rtol=1e-9, atol=1e-14 * tool.diameter)
    assert float(p.length_to_height(z_e)) == pytest.approx(p.arc_length, rel=1e-12, abs=1e-18)
    assert float(p.length_to_height(0.0)) == 0.0


@given(tools(shapes=tuple(CutterShape)[1:], sharp=False))
@SETTINGS
def test_arc_meets_the_line_with_the_same_tangent(tool: Tool) -> None:
    """At s = rc kappa1: r, z continuous (the arc's end from the Tool's own numbers), same
    (sin, cos) kappa on both sides, and one-sided differences agree with that tangent."""
    p, k1, rc = tool.profile, _kappa1(tool), tool.corner_radius
    a = p.arc_length
    top = (tool.diameter / 2 - rc + rc * math.sin(k1), rc - rc * math.cos(k1))
    below, at = p.at_length(np.nextafter(a, 0.0)), p.at_length(a)
    for side in (below, at):
        np.testing.assert_allclose(side[:2], top, rtol=1e-12, atol=1e-15 * tool.diameter)
        np.testing.assert_allclose(side[2:], (math.sin(k1), math.cos(k1)), atol=1e-12)
    h = 1e-5 * rc
    left = (_points(tool, a) - _points(tool, a - h)) / h
    right = (_points(tool, a + h) - _points(tool, a)) / h
    np.testing.assert_allclose(left, right, atol=2e-5)
    np.testing.assert_allclose(right, (math.cos(k1), math.sin(k1)), atol=1e-8)


@given(tools(), FRACTIONS)
@SETTINGS
def test_height_at_radius_is_the_lower_surface(tool: Tool, fractions: list[float]) -> None:
    """height_at_radius(r(s)) == z(s) where dr/ds = cos kappa > 0 (tolerance: the
    conditioning tan kappa of z(r)); 0 for rho <= r0."""
    p, total, big = tool.profile, _span(tool), tool.diameter / 2
    s = np.concatenate([np.linspace(0.0, total, 401), np.asarray(fractions) * total])
    r, z, _, ck = p.at_length(s)
    rising = ck > 1e-3
    assert rising[0] == (ck[0] > 0)  # kappa(0) = 0 on a corner arc
    got = p.height_at_radius(r[rising])
    tol = 1e-12 * (big + r[rising]) / ck[rising] + 1e-9 * z[rising]
    assert np.all(np.abs(got - z[rising]) <= tol), np.max(np.abs(got - z[rising]) / tol)
    rho = p.r0 * np.asarray(fractions + [1.0])
    np.testing.assert_array_equal(p.height_at_radius(rho), 0.0)


@given(st.floats(0.5, 60.0), FRACTIONS)
@SETTINGS
def test_height_at_radius_closed_forms(d_mm: float, fractions: list[float]) -> None:
    """Ball: R - sqrt(R^2 - rho^2) for rho <= R; flat end mill: 0 for rho <= R, inf beyond."""
    d = d_mm * MM
    big = d / 2
    rho = big * np.asarray(fractions + [0.0, 1.0])
    ball = Tool("b", d, 2, 0.0, d, shape=CutterShape.BALL, corner_radius=big).profile
    expect = big - np.sqrt(big**2 - rho**2)
    np.testing.assert_allclose(ball.height_at_radius(rho), expect, rtol=1e-9, atol=1e-15 * d)
    flat = Tool("f", d, 2, 0.0, d).profile
    np.testing.assert_array_equal(flat.height_at_radius(rho), 0.0)
    assert np.all(np.isinf(flat.height_at_radius(big * (1 + np.asarray(fractions) + 1e-9))))


def _polyline_length(tool: Tool, depth: float, n: int = 20001) -> tuple[float, float]:
    """Profile length up to ``depth`` by chords of the arc built by angle, then the line by
    hypot; and its error bound (one chord: the partial chord is left out)."""
    rc, k1 = tool.corner_radius, _kappa1(tool)
    k = np.linspace(0.0, k1, n)
    r, z = tool.diameter / 2 - rc + rc * np.sin(k), rc * (1.0 - np.cos(k))
    keep = z <= depth
    length = float(np.sum(np.hypot(np.diff(r[keep]), np.diff(z[keep]))))
    if keep.all():
        rise = depth - z[-1]
        length += math.hypot(rise * math.cos(k1) / math.sin(k1), rise)
    return length, rc * k1 / (n - 1)


def _radius_at_height(tool: Tool, z: float) -> float:
    rc, k1 = tool.corner_radius, _kappa1(tool)
    r0, z_e = tool.diameter / 2 - rc, rc * (1 - math.cos(k1))
    if z <= z_e:
        return r0 + math.sqrt(max(rc**2 - (rc - z) ** 2, 0.0))
    return r0 + rc * math.sin(k1) + (z - z_e) * math.cos(k1) / math.sin(k1)


@given(tools(), DEPTHS, st.sampled_from([1, 7, 200, 800]))
@SETTINGS
def test_profile_slices(tool: Tool, fractions: list[float], count: int) -> None:
    """L * width == the profile length up to the depth (brute force); heights increase inside
    (0, depth); sum(width sin kappa) = depth and sum(width cos kappa) = r(depth) - r0 within
    one width (midpoint rule of a monotone integrand in [0, 1])."""
    depths = np.concatenate([[0.0, tool.flute_length], np.asarray(fractions) * tool.flute_length])
    sl = profile_slices(tool.profile, depths, count)
    assert sl.width.shape == depths.shape and sl.height.shape == (depths.size, count)
    p = tool.profile
    for i, depth in enumerate(depths):
        w, z = sl.width[i], sl.height[i]
        assert count * w == pytest.approx(float(p.length_to_height(depth)), rel=1e-12, abs=0)
        brute, err = _polyline_length(tool, depth)
        assert abs(count * w - brute) <= err + 1e-9 * brute + 1e-15
        if depth == 0.0:
            assert w == 0.0 and np.all(z == 0.0)
            continue
        assert np.all(np.diff(z) > 0)
        assert np.all(z > 0) and np.all(z < depth)
        slack = 1e-9 * (depth + count * w)
        assert abs(np.sum(w * sl.sin_kappa[i]) - depth) <= w + slack
        spread = _radius_at_height(tool, depth) - p.r0
        assert abs(np.sum(w * sl.cos_kappa[i]) - spread) <= w + slack + 1e-9 * spread


@given(st.floats(0.5, 60.0), FRACTIONS, st.integers(1, 300))
@SETTINGS
def test_flat_end_mill_slices_are_algorithm_1(d_mm: float, fractions: list[float],
                                              count: int) -> None:
    """Flat end mill: slices exactly at (j + 1/2) a / L, radius D/2, kappa = 90 deg."""
    d = d_mm * MM
    tool = Tool("f", d, 2, 0.0, 3 * d)
    depths = np.asarray(fractions) * tool.flute_length
    sl = profile_slices(tool.profile, depths, count)
    expect = (np.arange(count) + 0.5)[None, :] * (depths / count)[:, None]
    np.testing.assert_array_equal(sl.height, expect)
    np.testing.assert_array_equal(sl.radius, d / 2)
    np.testing.assert_array_equal(sl.width, depths / count)
    np.testing.assert_array_equal(sl.sin_kappa, 1.0)
    np.testing.assert_array_equal(sl.cos_kappa, 0.0)


@given(st.floats(0.5, 60.0), FRACTIONS)
@SETTINGS
def test_ball_at_length_closed_form(d_mm: float, fractions: list[float]) -> None:
    """Ball: (R sin(s/R), R (1 - cos(s/R))) on the arc, then the cylinder r = R."""
    d = d_mm * MM
    big = d / 2
    p = Tool("b", d, 2, 0.0, 2 * d, shape=CutterShape.BALL, corner_radius=big).profile
    assert p.r0 == 0.0 and p.corner == big and p.kappa1 == math.pi / 2
    assume(not p.is_cylinder)
    s = np.asarray(fractions + [1.0]) * (math.pi / 2 * big)
    r, z, sk, ck = p.at_length(s)
    np.testing.assert_allclose(r, big * np.sin(s / big), rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(z, big * (1 - np.cos(s / big)), rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(np.arctan2(sk, ck), s / big, rtol=1e-12, atol=1e-15)
    r, z, _, _ = p.at_length(s + math.pi / 2 * big)
    np.testing.assert_allclose(r, big, rtol=1e-12)
    np.testing.assert_allclose(z, big + s, rtol=1e-12)

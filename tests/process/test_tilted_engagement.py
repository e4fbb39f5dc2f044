"""Tilted-tool engagement (feedopt.process.tilted_engagement) against closed forms.

Every closed form below is a union of sets ``{phi : A sin(phi) + B cos(phi) > C}`` (the edge
point and the normal are linear in sin(phi), cos(phi) per slice), built by :func:`sinusoid`
and intersected exactly; the model's intervals (sampled at 1 deg, refined by bisection) must
match them to 1e-5 rad (measured: below 1e-8 rad).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.process.cutter import CutterShape, Profile
from feedopt.process.dexel import TriDexel
from feedopt.process.engagement import Engagement
from feedopt.process.general_forces import slice_engagement
from feedopt.process.tilted_engagement import tilted_slice_engagement
from feedopt.process.tool import Tool

MM = 1e-3
R = 5 * MM
TWO_PI = 2 * math.pi
TOL = 1e-5  # rad
FLAT = Profile(R, 0.0, math.pi / 2)
BALL = Profile(0.0, R, math.pi / 2)
BULL = Profile(R - 1.5 * MM, 1.5 * MM, math.pi / 2)


# ---------------------------------------------------------------------------- interval sets
def sinusoid(a: float, b: float, c: float) -> list[tuple[float, float]]:
    """``{phi in [0, 2 pi) : a sin(phi) + b cos(phi) > c}`` as sorted intervals:
    ``rho sin(phi + delta) > c`` with rho = hypot(a, b), delta = atan2(b, a)."""
    rho = math.hypot(a, b)
    if rho == 0.0 or abs(c) >= rho:
        return [(0.0, TWO_PI)] if c < -rho or (rho == 0.0 and c < 0) else []
    alpha, delta = math.asin(c / rho), math.atan2(b, a)
    start = (alpha - delta) % TWO_PI  # sin(phi + delta) > sin(alpha) on (alpha, pi - alpha)
    stop = start + math.pi - 2 * alpha
    if stop <= TWO_PI:
        return [(start, stop)]
    return [(0.0, stop - TWO_PI), (start, TWO_PI)]


def intersect(p: list, q: list) -> list[tuple[float, float]]:
    """The intersection of two sorted interval lists."""
    out = [(max(a, c), min(b, d)) for a, b in p for c, d in q]
    return sorted((a, b) for a, b in out if b - a > 1e-9)


def model_intervals(lo: np.ndarray, hi: np.ndarray) -> list[tuple[float, float]]:
    """The non-empty intervals of one slice, merged across 2 pi (to compare with
    :func:`intersect` of sets that wrap)."""
    return sorted((float(a), float(b)) for a, b in zip(lo, hi, strict=True) if b > a)


def assert_same(model: list, exact: list, where: str) -> None:
    assert len(model) == len(exact), f"{where}: {model} vs {exact}"
    for (a, b), (c, d) in zip(model, exact, strict=True):
        assert abs(a - c) < TOL and abs(b - d) < TOL, f"{where}: {model} vs {exact}"


def lead_axis(lead: float, tilt: float = 0.0) -> np.ndarray:
    """The tool axis leaning by ``lead`` towards +x (the feed) and ``tilt`` towards -y."""
    return np.array([math.sin(lead) * math.cos(tilt), -math.sin(tilt),
                     math.cos(lead) * math.cos(tilt)])


# ------------------------------------------------------------------- flat end mill, lead
@pytest.mark.parametrize("lead_deg", [15.0, -10.0, 0.0])
def test_flat_end_mill_with_lead_on_a_plane(lead_deg):
    """Stock z < 0, tip at depth d, axis k = (sin psi, 0, cos psi), feed +x. Tool frame
    x = (cos psi, 0, -sin psi), y = (0, 1, 0), fx = cos psi, fz = sin psi. A side slice
    (kappa = 90 deg) at height z is at world height ``-d + z cos psi - R sin(phi) sin psi``:
    below the plane iff ``R sin(psi) sin(phi) > z cos(psi) - d``; in front iff
    ``cos(psi) sin(phi) > 0``. psi > 0: phi in (asin s, pi - asin s) with
    s = max(0, (z cos psi - d) / (R sin psi)); psi < 0: two intervals (0, asin s') and
    (pi - asin s', pi) with s' = (d - z cos psi) / (R |sin psi|)."""
    psi, d = math.radians(lead_deg), 2.0 * MM
    te = tilted_slice_engagement(lambda p: p[:, 2] < 0.0, [[0.0, 0.0, -d]], lead_axis(psi),
                                 [1.0, 0.0, 0.0], FLAT, 6 * MM, 30, 360)
    assert np.allclose([te.feed_x[0], te.feed_z[0]], [math.cos(psi), math.sin(psi)])
    se = te.slices
    engaged = 0
    for j in range(30):
        z = se.sliced.height[0, j]
        exact = intersect(sinusoid(R * math.sin(psi), 0.0, z * math.cos(psi) - d),
                          sinusoid(math.cos(psi), 0.0, 0.0))
        assert_same(model_intervals(se.lo[0, j], se.hi[0, j]), exact, f"slice {j}")
        engaged += bool(exact)
    assert 5 < engaged < 30  # the test crosses the plane
    if lead_deg < 0:
        assert se.lo.shape[2] == 2  # the two flanks of a backwards lean


# --------------------------------------------------------------------- ball-nose, lead
def ball_sets(kappa: float, lead: float, centre_height: float, x_step: float | None):
    """The closed form on a ball slice: ``P = C + R n`` with
    ``n = (sin k sin(phi) cos psi - cos k sin psi, sin k cos(phi),
    -sin k sin(phi) sin psi - cos k cos psi)``. Front: n_x > 0. Below z = 0:
    ``R sin k sin psi sin(phi) > C_z - R cos k cos psi``. Ahead of a step at x = x_s (C_x = 0):
    ``R sin k cos psi sin(phi) > x_s + R cos k sin psi``."""
    sk, ck, sp, cp = math.sin(kappa), math.cos(kappa), math.sin(lead), math.cos(lead)
    out = intersect(sinusoid(sk * cp, 0.0, ck * sp),
                    sinusoid(R * sk * sp, 0.0, centre_height - R * ck * cp))
    if x_step is not None:
        out = intersect(out, sinusoid(R * sk * cp, 0.0, x_step + R * ck * sp))
    return out


@pytest.mark.parametrize(("lead_deg", "depth_mm", "step_mm"),
                         [(15.0, 2.0, None), (30.0, 1.0, None), (-20.0, 1.5, None),
                          (15.0, 2.0, 1.0), (0.0, 2.0, -1.5)])
def test_ball_nose_with_lead_on_a_plane(lead_deg, depth_mm, step_mm):
    """A ball of radius R whose lowest point is ``depth`` below the plane z = 0 (centre at
    C = (0, 0, R - depth)), leaning by ``lead``: a groove, or with ``step`` a step whose
    material starts at x = step (the wall of the previous cut); closed form in
    :func:`ball_sets`."""
    psi, a = math.radians(lead_deg), depth_mm * MM
    k = lead_axis(psi)
    centre = np.array([0.0, 0.0, R - a])
    x_s = None if step_mm is None else step_mm * MM

    def stock(p):
        below = p[:, 2] < 0.0
        return below if x_s is None else below & (p[:, 0] > x_s)

    te = tilted_slice_engagement(stock, centre - R * k, k, [1.0, 0.0, 0.0], BALL, R, 30, 360)
    se = te.slices
    kappa = np.arctan2(se.sliced.sin_kappa[0], se.sliced.cos_kappa[0])
    engaged = 0
    for j in range(30):
        exact = ball_sets(kappa[j], psi, R - a, x_s)
        assert_same(model_intervals(se.lo[0, j], se.hi[0, j]), exact, f"slice {j}")
        engaged += bool(exact)
    assert engaged > 3


def test_ball_nose_with_lead_and_tilt_on_a_plane():
    """Lead 20 deg and tilt 25 deg: the general sinusoid. With the tool frame (x, y, k) and
    C = tip + R k, a ball point is below z = 0 iff ``-R sin k (x_z sin(phi) + y_z cos(phi))
    > C_z - R cos k k_z`` and in front iff ``sin k fx sin(phi) > cos k fz``."""
    psi, beta, a = math.radians(20), math.radians(25), 1.8 * MM
    k = lead_axis(psi, beta)
    f = np.array([1.0, 0.0, 0.0])
    centre = np.array([0.3 * MM, -0.2 * MM, R - a])
    te = tilted_slice_engagement(lambda p: p[:, 2] < 0.0, centre - R * k, k, f, BALL, R, 30,
                                 360)
    fz = float(f @ k)
    x = (f - fz * k) / np.linalg.norm(f - fz * k)
    y = np.cross(k, x)
    fx = float(f @ x)
    sliced = te.slices.sliced
    for j in range(30):
        sk, ck = sliced.sin_kappa[0, j], sliced.cos_kappa[0, j]
        exact = intersect(sinusoid(sk * fx, 0.0, ck * fz),
                          sinusoid(-R * sk * x[2], -R * sk * y[2], centre[2] - R * ck * k[2]))
        assert_same(model_intervals(te.slices.lo[0, j], te.slices.hi[0, j]), exact, f"{j}")


# ------------------------------------------------------------- the un-tilted cutter
def _cases():
    a, ae, rr = 3 * MM, 2 * MM, 5 * MM
    up = math.acos(1 - ae / rr)
    return [
        ("slot", (0.0, math.pi), lambda p: p[:, 2] < a),
        ("up", (0.0, up), lambda p: (p[:, 2] < a) & (p[:, 1] >= rr - ae)),
        ("down", (math.pi - up, math.pi), lambda p: (p[:, 2] < a) & (p[:, 1] <= ae - rr)),
    ]


@pytest.mark.parametrize("shape", [CutterShape.FLAT, CutterShape.BALL])
@pytest.mark.parametrize("case", _cases(), ids=lambda c: c[0])
def test_untilted_reproduces_slice_engagement(shape, case):
    """Axis +z, feed +x: the half-space/box form of an Engagement (material below the axial
    depth, between the lateral positions of its entry and exit) gives the intervals of
    general_forces.slice_engagement (measured: within 5e-9 rad)."""
    _, (entry, exit_), stock = case
    a = 3 * MM
    tool = Tool("t", 2 * R, 2, math.radians(30), 20 * MM, shape=shape,
                corner_radius=R if shape is CutterShape.BALL else 0.0)
    ref = slice_engagement(tool, Engagement(np.array([entry]), np.array([exit_]),
                                            np.array([a])), 30)
    te = tilted_slice_engagement(stock, np.zeros((1, 3)), [0, 0, 1], [1, 0, 0], tool.profile,
                                 a, 30, 360)
    assert te.slices.lo.shape == (1, 30, 1)
    assert np.allclose(te.slices.sliced.radius, ref.sliced.radius)
    assert np.max(np.abs(te.slices.lo - ref.lo)) < TOL
    assert np.max(np.abs(te.slices.hi - ref.hi)) < TOL


def test_plunge_along_the_axis_engages_the_whole_bottom():
    """Feed along -k (a plunge): fx = 0, every slice with cos(kappa) > 0 is in front all
    around; a ball in a half-space engages [0, 2 pi) on each slice below the surface."""
    te = tilted_slice_engagement(lambda p: p[:, 2] < 0.0, [[0, 0, -2 * MM]], [0, 0, 1],
                                 [0, 0, -1], BALL, R, 10, 90)
    assert te.feed_x[0] == 0.0 and te.feed_z[0] == -1.0
    below = te.slices.sliced.height[0] < 2 * MM
    assert np.all(te.slices.lo[0, below, 0] == 0.0)
    assert np.all(te.slices.hi[0, below, 0] == TWO_PI)
    assert np.all(te.slices.hi[0, ~below] == 0.0)


def test_dexel_stock_matches_the_half_space_within_its_resolution():
    """The same tilted ball in a tri-dexel box (top at z = 0, h = 0.1 mm) and in the
    half-space: boundaries agree to the dexel resolution (h over the rate the edge point
    crosses the surface; here within 0.08 rad); the intervals' counts agree."""
    psi, a = math.radians(15), 2 * MM
    k = lead_axis(psi)
    tip = np.array([0.0, 0.0, R - a]) - R * k
    box = TriDexel.box([-10 * MM, -10 * MM, -10 * MM], [10 * MM, 10 * MM, 0.0], 0.1 * MM)
    exact = tilted_slice_engagement(lambda p: p[:, 2] < 0.0, tip, k, [1, 0, 0], BALL, R, 20,
                                    360).slices
    dex = tilted_slice_engagement(box.contains, tip, k, [1, 0, 0], BALL, R, 20, 360).slices
    cut = exact.hi > exact.lo
    assert np.array_equal(cut, dex.hi > dex.lo)
    assert np.max(np.abs(exact.lo - dex.lo)[cut]) < 0.08
    assert np.max(np.abs(exact.hi - dex.hi)[cut]) < 0.08


# ------------------------------------------------------------------------- hypothesis
def _engaged(stock, tip, k, f, sliced, j, phi):
    """Independent in-cut test (world frame): material and f . n > 0 at angles ``phi``."""
    x = f - (f @ k) * k
    x /= np.linalg.norm(x)
    y = np.cross(k, x)
    r, z = sliced.radius[0, j], sliced.height[0, j]
    sk, ck = sliced.sin_kappa[0, j], sliced.cos_kappa[0, j]
    radial = np.sin(phi)[:, None] * x + np.cos(phi)[:, None] * y
    pts = tip + z * k + r * radial
    normal = sk * radial - ck * k
    return stock(pts) & (normal @ f > 0.0)


@settings(max_examples=40, deadline=None)
@given(lead=st.floats(-35, 35), tilt=st.floats(-35, 35), ramp=st.floats(-10, 10),
       depth=st.floats(0.2, 8.0), shape=st.sampled_from(["flat", "ball", "bull"]),
       wall=st.one_of(st.none(), st.floats(-4.0, 4.0)))
def test_engaged_points_are_in_material_and_in_front(lead, tilt, ramp, depth, shape, wall):
    """Random tilts, ramps and depths, a plane with an optional wall (material at y > wall):
    interior points of every interval cut, points 1e-5 rad outside do not (unless the next
    interval starts there, across 2 pi), and every sampled angle (but those within 1e-6 rad of
    an end, where the conditions are 0 to rounding) is in an interval iff it cuts."""
    profile = {"flat": FLAT, "ball": BALL, "bull": BULL}[shape]
    k = lead_axis(math.radians(lead), math.radians(tilt))
    f = np.array([math.cos(math.radians(ramp)), 0.0, math.sin(math.radians(ramp))])
    tip = np.array([0.0, 0.0, -depth * MM])

    def stock(p):
        return (p[:, 2] < 0.0) & (True if wall is None else p[:, 1] > wall * MM)

    se = tilted_slice_engagement(stock, tip, k, f, profile, 10 * MM, 8, 180).slices
    grid = np.arange(180) * TWO_PI / 180
    for j in range(8):
        ivs = model_intervals(se.lo[0, j], se.hi[0, j])
        for lo, hi in ivs:
            if hi - lo > 1e-4:
                inner = np.array([lo + 1e-6, 0.5 * (lo + hi), hi - 1e-6])
                assert np.all(_engaged(stock, tip, k, f, se.sliced, j, inner))
            outer = [a for a in (lo - 1e-5, hi + 1e-5)
                     if not any(c <= a % TWO_PI < d for c, d in ivs)]
            if outer:
                assert not np.any(_engaged(stock, tip, k, f, se.sliced, j,
                                           np.array(outer) % TWO_PI))
        ends = np.array([e for iv in ivs for e in iv] + [0.0, TWO_PI])
        clear = np.min(np.abs(grid[:, None] - ends[None, :]), axis=1) > 1e-6  # not on an end
        inside = np.array([any(c <= g < d for c, d in ivs) for g in grid])
        assert np.array_equal(inside[clear],
                              _engaged(stock, tip, k, f, se.sliced, j, grid)[clear])

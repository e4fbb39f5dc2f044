"""The stock sweep with ball-nose and bull-nose cutters against closed forms.

The engaged area of a straight cut (the cross-section of the material the cutter meets,
normal to the feed) is, from the engagement by height of :mod:`feedopt.process.general_forces`,
``A = int w(z) dz`` with ``w = r(z) (cos entry_z - cos exit_z)`` the lateral width of the
engaged arc at height z; in steady state it is also the volume the sweep removes per unit of
path. Closed forms:

* ball-nose of radius R in a slot of depth a <= R into flat stock: a circular segment,
  ``A = R^2 acos((R - a) / R) - (R - a) sqrt(2 R a - a^2)``;
* bull-nose of radius R, corner rc, at a step of radial depth ae >= rc and axial depth
  ap >= rc: the rectangle less the fillet the corner leaves, ``A = ae ap - (1 - pi / 4) rc^2``;
* two parallel ball-nose passes a step-over b apart leave a scallop of height
  ``R - sqrt(R^2 - b^2 / 4)`` midway.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.process.cutter import CutterShape, profile_slices
from feedopt.process.general_forces import slice_intervals
from feedopt.process.stock import FlatEndMill, ZMap, sweep
from feedopt.process.tool import Tool

MM = 1e-3
R = 5 * MM
CELL = 0.05 * MM


def _ball(radius=R):
    return Tool("ball", 2 * radius, 2, 0.5, 20 * MM, shape=CutterShape.BALL,
                corner_radius=radius)


def _line(depth, y=0.0, n=351, length=35 * MM):
    x = np.linspace(0.0, length, n)
    return (np.column_stack([x, np.full(n, y), np.full(n, -depth)]),
            np.tile([1.0, 0.0, 0.0], (n, 1)))


def _engaged_area(tool, engagement, i, slices=400):
    """int w(z) dz over the sample's pieces (or its one interval)."""
    e = engagement
    if e.pieces is not None and np.any(e.pieces.sample == i):
        m = e.pieces.sample == i
        parts = zip(e.pieces.entry[m], e.pieces.exit[m], e.pieces.axial_depth[m], strict=True)
    else:
        parts = [(e.entry[i], e.exit[i], e.axial_depth[i])]
    area = 0.0
    for entry, exit_, depth in parts:
        sl = profile_slices(tool.profile, np.array([depth]), slices)
        lo, hi = slice_intervals(tool.diameter / 2, sl, np.array([entry]), np.array([exit_]))
        width = sl.radius * (np.cos(lo) - np.cos(hi))
        area += float(np.sum(width * sl.width[:, None] * sl.sin_kappa))
    return area


def _cut(tool, stock, depth):
    p, t = _line(depth)
    found = sweep(stock, FlatEndMill.from_tool(tool), p, t)
    removed_per_m = found.removed[150:300].sum() / (p[300, 0] - p[150, 0])
    return found, removed_per_m


@pytest.mark.parametrize("depth_mm", [0.5, 1.0, 2.5, 4.0, 5.0])
def test_ball_nose_slot_engaged_area_is_the_circular_segment(depth_mm):
    a = depth_mm * MM
    stock = ZMap.box(-5 * MM, 40 * MM, -15 * MM, 15 * MM, -10 * MM, 0.0, cell=CELL)
    found, removed = _cut(_ball(), stock, a)
    exact = R * R * math.acos((R - a) / R) - (R - a) * math.sqrt(2 * R * a - a * a)
    # the material above the ball's surface spans |y| < sqrt(2 R a - a^2) at the rim
    half = math.sqrt(2 * R * a - a * a)
    e = found.engagement
    assert R * math.cos(e.entry[200]) == pytest.approx(half, abs=2 * CELL)
    assert R * math.cos(e.exit[200]) == pytest.approx(-half, abs=2 * CELL)
    assert _engaged_area(_ball(), found.engagement, 200) == pytest.approx(exact, rel=2e-4)
    # the swept ball's own shape removed: a cell-resolution quadrature of the same segment
    assert removed == pytest.approx(exact, rel=5e-3)


def test_bull_nose_step_engaged_area_is_the_rectangle_less_the_fillet():
    rc, ae, ap = 2 * MM, 3 * MM, 4 * MM
    bull = Tool("bull", 2 * R, 4, 0.5, 20 * MM, shape=CutterShape.BULL, corner_radius=rc)
    # material on the -y side up to y = -R + ae (down milling: exit at pi)
    stock = ZMap.box(-5 * MM, 40 * MM, -15 * MM, -R + ae, -10 * MM, 0.0, cell=CELL)
    found, removed = _cut(bull, stock, ap)
    exact = ae * ap - (1 - math.pi / 4) * rc * rc
    e = found.engagement
    assert e.exit[200] == math.pi
    assert e.entry[200] == pytest.approx(math.acos((-R + ae) / R), abs=0.03)
    assert _engaged_area(bull, e, 200) == pytest.approx(exact, rel=2e-3)
    assert removed == pytest.approx(exact, rel=5e-3)


def test_flat_end_mill_removal_is_unchanged_by_the_profile_code():
    flat = Tool("flat", 2 * R, 2, 0.5, 20 * MM)
    stock = ZMap.box(-5 * MM, 40 * MM, -15 * MM, 15 * MM, -10 * MM, 0.0, cell=CELL)
    _, removed = _cut(flat, stock, 1 * MM)
    assert removed == pytest.approx(2 * R * 1 * MM, rel=5e-3)


@settings(max_examples=6, deadline=None)
@given(st.floats(0.6, 2.4))
def test_two_ball_passes_leave_the_scallop_of_their_step_over(step_mm):
    b, radius = step_mm * MM, 1.5 * MM
    ball = _ball(radius)
    stock = ZMap.box(-3 * MM, 13 * MM, -4 * MM, 4 * MM + b, -5 * MM, 0.0, cell=0.02 * MM)
    tool = FlatEndMill.from_tool(ball)
    for y in (0.0, b):
        sweep(stock, tool, *_line(1.0 * MM, y=y, n=101, length=10 * MM))
    j = int(round((0.5 * b - stock.origin[1]) / stock.cell - 0.5))
    col = stock.heights[stock.shape[0] // 2]
    scallop = float(col[j]) + 1.0 * MM
    exact = radius - math.sqrt(radius**2 - 0.25 * b * b)
    y_cell = stock.origin[1] + (j + 0.5) * stock.cell  # the cell centre, within h/2 of b/2
    at_cell = radius - math.sqrt(radius**2 - min(abs(y_cell), abs(y_cell - b)) ** 2)
    assert scallop == pytest.approx(at_cell, abs=2e-7)
    # the cell centre is within h / 2 of b / 2: the slope there is (b / 2) / sqrt(R^2 - b^2 / 4)
    slope = 0.5 * b / math.sqrt(radius**2 - 0.25 * b * b)
    assert abs(at_cell - exact) <= 0.5 * 0.02 * MM * slope * 1.01
    # under each pass the ball's tip reaches the programmed depth
    j0 = int(round((0.0 - stock.origin[1]) / stock.cell - 0.5))
    assert float(col[j0]) + 1.0 * MM == pytest.approx(
        radius - math.sqrt(radius**2 - (stock.origin[1] + (j0 + 0.5) * stock.cell) ** 2),
        abs=2e-7)


def test_a_cutter_wider_above_its_tip_is_noted_with_its_width():
    from feedopt.process.tool import wider_above_tip

    tapered = Tool("taper", 6 * MM, 2, 0.5, 10 * MM, shape=CutterShape.TAPERED,
                   taper=math.radians(5))
    # 6 mm tip + 2 * 10 mm * tan 5 deg at the top of the flutes
    assert f"{6 + 20 * math.tan(math.radians(5)):.4g} mm across" in wider_above_tip(tapered)
    assert wider_above_tip(_ball()) is None


@pytest.mark.parametrize("step_mm", [0.5, 1.5, 3.0])
def test_a_ball_pass_beside_the_last_one_cuts_the_crescent_between_them(step_mm):
    """A second ball pass b beside a first at the same depth a: the material it meets is what
    the first left above the second's surface. Its cross-section, integrated over y by a fine
    quadrature of the two balls' lower surfaces, is the engaged area and the removed volume
    per length."""
    a, b = 2.0 * MM, step_mm * MM
    ball = _ball()
    stock = ZMap.box(-5 * MM, 40 * MM, -15 * MM, 15 * MM, -10 * MM, 0.0, cell=CELL)
    tool = FlatEndMill.from_tool(ball)
    sweep(stock, tool, *_line(a, y=0.0))
    p, t = _line(a, y=b)
    # pieces split where the depth changes by 5 um (each at its largest depth: the engaged
    # area is over by at most that depth times the width; 0.1 mm, the default, is coarse
    # for a crescent this thin)
    found = sweep(stock, tool, p, t, depth_step=0.005 * MM)
    y = np.linspace(b - R, b + R, 400_001)

    def lower(y0):  # the ball's lower surface, inf outside its reach
        d = np.abs(y - y0)
        return np.where(d <= R, -a + R - np.sqrt(np.maximum(R * R - d * d, 0.0)), np.inf)

    left = np.minimum(0.0, lower(0.0))  # the top after the first pass
    exact = float(np.sum(np.maximum(left - lower(b), 0.0)) * (y[1] - y[0]))
    removed = found.removed[150:300].sum() / (p[300, 0] - p[150, 0])
    # the force frame's y is to the left of the feed (+x): the first pass is at -y there
    assert removed == pytest.approx(exact, rel=0.01)
    # (measured: 1.0000 of it at 5 um; 1.007 / 1.15 at 20 / 100 um for b = 0.5 mm, always over)
    assert _engaged_area(ball, found.engagement, 200) == pytest.approx(exact, rel=2e-3)

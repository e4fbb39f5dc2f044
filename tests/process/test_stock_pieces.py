"""Several engaged intervals and an angle-dependent axial depth from the stock, and what they
do to the deflection bound, against analytic engagement (never the sweep itself)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.process.coefficients import CuttingCoefficients
from feedopt.process.engagement import Engagement
from feedopt.process.forces import milling_forces
from feedopt.process.stock import DEPTH_STEP, ZMap, lookahead_reach, sweep
from feedopt.process.tool import Tool
from feedopt.schedule.bounds import deflection_feed_bound
from feedopt.schedule.deflection import DeflectionModel, feed_frames

from .test_stock import (
    CORNERS,
    TOOL,
    D,
    R,
    _arc_bound,
    angle_error_bound,
    circle_engagement_cos,
    inside_corner_cut,
    line,
    outside_corner_cut,
)

MM = 1e-3
HSS = Tool("hss", D, 2, math.radians(30), 25 * MM)
K_2500 = CuttingCoefficients(9.19e8, 4.02e8, -1.19e8, 8.80e3, 6.73e3, -1.05e3)  # Table 3.3


def pieces_of(res, i):
    iv = res.intervals
    m = iv.sample == i
    return iv.entry[m], iv.exit[m], iv.axial_depth[m]


@pytest.mark.parametrize("ae_mm", [0.5, 1.0, 2.0])
def test_sharp_inside_corner_at_small_radial_depth_is_two_intervals(ae_mm):
    """Finishing a pocket wall (radial depth ae < R (1 - cos 45 deg)) into a sharp 90 deg
    inside corner: at the corner point the cutter meets the wall beside it on
    [0, theta_e] and the wall ahead, a distance R - ae in front of its centre, where
    R sin(phi) >= R - ae, i.e. on [pi/2 - theta_e, pi/2 + theta_e], theta_e =
    arccos(1 - ae/R): two intervals, with no material between them."""
    ae, h, z_floor = ae_mm * MM, 0.1 * MM, 10 * MM
    xp, yp = 60 * MM, 40 * MM
    stock = ZMap.box(0, 100 * MM, 0, 80 * MM, 0, 20 * MM, cell=h)
    xs, ys = stock.x_centres, stock.y_centres
    stock.heights[np.ix_(xs < xp, ys < yp)] = z_floor
    corner = np.array([xp - R + ae, yp - R + ae, z_floor])
    leg1 = line([5 * MM, corner[1], z_floor], corner, 0.1 * MM)
    leg2 = line(corner, [corner[0], 5 * MM, z_floor], 0.1 * MM)
    pos = np.concatenate([leg1[0], leg2[0][1:]])
    tan = np.concatenate([leg1[1], leg2[1][1:]])
    res = sweep(stock, TOOL, pos, tan)
    i_corner = len(leg1[0]) - 1
    theta_e = math.acos(1 - ae / R)
    entry, exit_, depth = pieces_of(res, i_corner)
    assert entry.size == 2
    # the wall beside: a wall along the feed (angle_error_bound); the wall ahead, across the
    # feed, is seen up to the lookahead reach early and a cell late: an error dx along the
    # feed moves its rim crossing at phi by dx / (R |cos phi|)
    beside = angle_error_bound(theta_e, h, R)
    assert entry[0] == 0.0 and abs(exit_[0] - theta_e) <= beside
    for got, phi in ((entry[1], math.pi / 2 - theta_e), (exit_[1], math.pi / 2 + theta_e)):
        dx = float(lookahead_reach(phi, h, R, 0.1 * MM)) + h
        assert abs(got - phi) <= dx / (R * abs(math.cos(phi))), (got, phi)
    np.testing.assert_allclose(depth, 10 * MM)
    # the hull summarises it; the force model gets the pieces
    assert res.engagement.exit[i_corner] == exit_[1]
    assert res.engagement.pieced[i_corner]
    # away from the corner one interval, the straight cut, and no pieces
    straight = pos[:, 0] < corner[0] - R - 2 * MM
    assert not res.engagement.pieced[straight].any()
    # less material than the hull: a smaller mean force over the revolution (the mean
    # deflection), and a bound never below the hull's (the peak may sit where both agree)
    one = res.engagement.take(slice(i_corner, i_corner + 1))
    hull = Engagement(one.entry, one.exit, one.axial_depth)
    angles = np.linspace(0.0, 2 * math.pi, 720, endpoint=False)
    mean = [np.linalg.norm(milling_forces(HSS, K_2500, e, angles, 10).forces(1e-4)[0].mean(0))
            for e in (one, hull)]
    assert mean[0] < 0.9 * mean[1]
    assert _bound(one, tan[:1])[0] >= _bound(hull, tan[:1])[0] * (1 - 1e-12)


def _slot_across_a_step(top_left, top_right, cell=0.25 * MM):
    """A slot (feed +x along y = yc, tip at 15 mm) through a block whose top is top_left
    for y > yc (the up-milling side, phi < 90 deg) and top_right below."""
    yc = 40.013 * MM
    stock = ZMap.box(0, 100 * MM, 0, 80 * MM, 0, top_left, cell=cell)
    stock.heights[:, stock.y_centres < yc] = top_right
    pos, tan = line([-15 * MM, yc, 15 * MM], [115 * MM, yc, 15 * MM], 0.2 * MM)
    res = sweep(stock, TOOL, pos, tan)
    middle = (pos[:, 0] > 20 * MM) & (pos[:, 0] < 80 * MM)
    return res, middle


def test_a_step_across_the_cutter_gives_each_side_its_depth():
    """Material 5 mm above the tip on the left, 3 mm on the right: the pieces are
    [0, 90] deg at 5 mm and [90, 180] deg at 3 mm, the split within a cell of the step
    (arccos of +-h / R around 90 deg)."""
    h = 0.25 * MM
    res, middle = _slot_across_a_step(20 * MM, 18 * MM, h)
    tol = math.asin(2 * h / R)
    for i in np.flatnonzero(middle):
        entry, exit_, depth = pieces_of(res, i)
        assert entry.size == 2
        assert entry[0] == 0.0 and exit_[1] == math.pi
        assert exit_[0] == entry[1] and abs(exit_[0] - math.pi / 2) <= tol
        np.testing.assert_allclose(depth, [5 * MM, 3 * MM], atol=1e-6)
    assert res.engagement.pieced[middle].all()
    np.testing.assert_allclose(res.engagement.axial_depth[middle], 5 * MM, atol=1e-6)


def test_a_step_below_the_depth_step_is_one_piece():
    res, middle = _slot_across_a_step(20 * MM, 20 * MM - 0.4 * DEPTH_STEP)
    assert not res.engagement.pieced[middle].any()
    assert np.all(np.bincount(res.intervals.sample)[np.flatnonzero(middle)] == 1)


def test_a_sloping_top_gets_conservative_pieces_within_the_depth_step():
    """Material whose top rises linearly across the feed (1 mm over the cutter diameter):
    every piece's depth is at least the true depth everywhere in it and exceeds it by at
    most the depth step plus the rise over one bin."""
    h = 0.25 * MM
    yc, slope, tip = 40.013 * MM, 1.0 / 19.05, 15 * MM
    stock = ZMap.box(0, 100 * MM, 0, 80 * MM, 0, 20 * MM, cell=h)
    stock.heights[:] = (18 * MM + slope * (stock.y_centres - yc))[None, :]
    pos, tan = line([-15 * MM, yc, tip], [115 * MM, yc, tip], 0.2 * MM)
    res = sweep(stock, TOOL, pos, tan)
    i = int(np.argmin(np.abs(pos[:, 0] - 50 * MM)))
    entry, exit_, depth = pieces_of(res, i)
    assert entry.size >= int(1 * MM / DEPTH_STEP) - 2
    # contiguous, covering the slot
    assert entry[0] == 0.0 and exit_[-1] == math.pi
    np.testing.assert_array_equal(exit_[:-1], entry[1:])
    for e, x, a in zip(entry, exit_, depth, strict=True):
        phi = np.linspace(e, x, 50)
        true = 18 * MM + slope * R * np.cos(phi) - tip  # top at lateral R cos(phi)
        assert a >= true.max() - slope * h
        assert a <= true.min() + DEPTH_STEP + 2 * slope * h


def _bound(engagement, tangents, limit=0.2 * MM):
    """v_max [m/s] with an isotropic compliance (1 um/N): the bound depends on the
    engagement only, whatever the feed direction."""
    n = engagement.n
    model = DeflectionModel(
        tool=HSS, coefficients=K_2500, engagement=engagement,
        angles=np.linspace(0.0, math.pi, 181, endpoint=False),
        frames=feed_frames(np.asarray(tangents, dtype=float), np.tile([0.0, 0, 1], (n, 1))),
        compliance=np.tile(np.eye(3) * 1e-6, (n, 1, 1)), rpm=2500.0, axial_slices=10)
    return deflection_feed_bound(model, limit)[0]


@pytest.mark.parametrize(("b_mm", "r_mm"), CORNERS[:2])
@pytest.mark.parametrize("kind", ["inside", "outside"])
def test_deflection_bound_follows_the_corner_engagement(kind, b_mm, r_mm):
    """Around a rounded corner the bound from the stock drops (inside) or rises (outside)
    against the straight wall, and lies between the bounds of the hand-written up-milling
    engagement at the analytic exit angle arccos(+-kappa) (two circles) plus and minus its
    resolution error."""
    step = 0.1 * MM
    cut = inside_corner_cut if kind == "inside" else outside_corner_cut
    pos, tan, res, middle, r_c, r_m = cut(b_mm, r_mm, step)
    kappa = circle_engagement_cos(r_c, r_m)
    expected = math.acos(kappa if kind == "inside" else -kappa)
    straight = np.zeros(len(pos), dtype=bool)
    straight[40:140] = True  # 4-14 mm along the first leg: the straight wall
    sel = middle | straight
    v = np.full(len(pos), np.nan)
    v[sel] = _bound(res.engagement.take(np.flatnonzero(sel)), tan[sel])
    theta = math.acos(1 - b_mm * MM / R)

    def up_milling(exit_angle):
        e = Engagement(np.zeros(1), np.array([min(exit_angle, math.pi)]), np.array([10 * MM]))
        return _bound(e, tan[:1])[0]

    def between(values, exit_angle, err):
        """Within the bounds of the exit angle +- its resolution error (more engagement,
        lower bound)."""
        return np.all((values >= up_milling(exit_angle + err) * (1 - 1e-9))
                      & (values <= up_milling(exit_angle - err) * (1 + 1e-9)))

    assert between(v[straight], theta, float(angle_error_bound(theta, 0.25 * MM, R)))
    err = float(_arc_bound(expected, r_m, r_c, step))  # what the engagement tests allow
    assert between(v[middle], expected, err)
    v_straight = up_milling(theta)
    if kind == "inside":
        assert np.nanmax(v[middle]) < 0.97 * v_straight
    else:
        assert np.nanmin(v[middle]) > 1.03 * v_straight

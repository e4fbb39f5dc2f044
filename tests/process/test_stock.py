"""Engagement from a Z-map stock against the analytic engagement of straight cuts and a corner."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process.engagement import peripheral_engagement, slot_engagement
from feedopt.process.stock import (
    FlatEndMill,
    ZMap,
    angle_error_bound,
    snap_angle,
    sweep,
)
from feedopt.process.tool import Tool

MM = 1e-3
D = 19.05 * MM
R = D / 2
H = 0.25 * MM
TOOL = FlatEndMill.from_tool(Tool("hss", D, 2, math.radians(30), 25 * MM))


def line(a, b, step=0.2 * MM):
    """Samples every ``step`` from a to b (tool tip positions) and their tangents."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = int(round(np.linalg.norm(b - a) / step)) + 1
    pos = a + (b - a) * np.linspace(0.0, 1.0, n)[:, None]
    return pos, np.broadcast_to(b - a, pos.shape).copy()


def assert_angles(measured, expected):
    bound = angle_error_bound(expected, H, R)
    err = np.abs(measured - expected)
    assert np.all(err <= bound + 1e-12), float(np.max(err - bound))


@pytest.mark.parametrize("angle_deg", [0.0, 30.0, 45.0, 72.0])
@pytest.mark.parametrize("step_mm", [0.1, 0.5])
def test_slot_through_box(angle_deg, step_mm):
    stock = ZMap.box(0, 80 * MM, 0, 80 * MM, 0, 20 * MM)
    u = np.array([math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg)), 0.0])
    c = np.array([40.03 * MM, 40.07 * MM, 17 * MM])
    pos, tan = line(c - 60 * MM * u, c + 60 * MM * u, step_mm * MM)
    res = sweep(stock, TOOL, pos, tan)
    inside = np.linalg.norm(pos[:, :2] - c[:2], axis=1) < 25 * MM
    ref = slot_engagement(int(inside.sum()), 3 * MM)
    assert not res.in_air[inside].any()
    assert_angles(res.engagement.entry[inside], ref.entry)
    assert_angles(res.engagement.exit[inside], ref.exit)
    np.testing.assert_allclose(res.axial_depth[inside], ref.axial_depth, atol=1e-8)
    np.testing.assert_allclose(res.engagement.axial_depth[inside], 3 * MM, atol=1e-8)
    # beyond the box by more than R + the longest lookahead (1.5 mm at the rim sides)
    far = (np.abs(pos[:, 0] - 40 * MM) > 51.1 * MM) | (np.abs(pos[:, 1] - 40 * MM) > 51.1 * MM)
    assert res.in_air[far].all()
    # (3) a second pass over the same line finds air
    again = sweep(stock, TOOL, pos, tan)
    assert again.in_air.all()
    np.testing.assert_array_equal(again.engagement.entry, again.engagement.exit)
    np.testing.assert_array_equal(again.axial_depth, 0.0)


@pytest.mark.parametrize("ae_mm", [0.5, 2.0, 6.0, 15.0])
def test_peripheral_up_and_down_on_the_box_edge(ae_mm):
    """Feed +x with the box on the left is up milling; the same line fed -x is down milling."""
    ae = ae_mm * MM
    y_c = 0.0 - R + ae  # box edge at y = 0, a cell boundary
    for direction, milling in ((1.0, "up"), (-1.0, "down")):
        stock = ZMap.box(0, 100 * MM, 0, 50 * MM, -10 * MM, 0)
        a, b = np.array([-20 * MM, y_c, -2 * MM]), np.array([120 * MM, y_c, -2 * MM])
        pos, tan = line(a, b) if direction > 0 else line(b, a)
        res = sweep(stock, TOOL, pos, tan)
        inside = (pos[:, 0] > 15 * MM) & (pos[:, 0] < 85 * MM)
        k = int(inside.sum())
        ref = peripheral_engagement(np.full(k, ae), D, 2 * MM, milling)
        assert not res.in_air[inside].any()
        assert_angles(res.engagement.entry[inside], ref.entry)
        assert_angles(res.engagement.exit[inside], ref.exit)
        np.testing.assert_allclose(res.axial_depth[inside], 2 * MM, atol=1e-8)
        # axis-aligned edge on a cell boundary: the radial depth is exact
        sweep_angle = res.engagement.exit - res.engagement.entry
        np.testing.assert_allclose(
            sweep_angle[inside], math.acos(1 - ae / R), atol=1e-9 if ae < D / 2 else 0.25
        )


@pytest.mark.parametrize("angle_deg", [30.0, 60.0])
def test_peripheral_widening_a_slot_at_an_angle(angle_deg):
    """Pass 2, offset s to the left of a slot, cuts ae = s from its left wall (up milling);
    the wall comes from the Z-map's own pass 1, at an angle to the grid."""
    ae = 1.3 * MM
    stock = ZMap.box(0, 100 * MM, 0, 100 * MM, 0, 20 * MM)
    u = np.array([math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg)), 0.0])
    left = np.array([-u[1], u[0], 0.0])
    c = np.array([50 * MM, 50 * MM, 15 * MM])
    sweep(stock, TOOL, *line(c - 70 * MM * u, c + 70 * MM * u))
    pos, tan = line(c + ae * left - 70 * MM * u, c + ae * left + 70 * MM * u)
    res = sweep(stock, TOOL, pos, tan)
    inside = np.linalg.norm(pos[:, :2] - c[:2], axis=1) < 30 * MM
    ref = peripheral_engagement(np.full(int(inside.sum()), ae), D, 5 * MM, "up")
    assert not res.in_air[inside].any()
    assert_angles(res.engagement.entry[inside], ref.entry)
    assert_angles(res.engagement.exit[inside], ref.exit)
    np.testing.assert_allclose(res.axial_depth[inside], 5 * MM, atol=1e-8)


def test_inside_corner_engagement_spike():
    """Finishing a pocket wall with radial depth ae around a 90 deg inside corner.

    The pocket (x < Xp, y < Yp) is cleared; the tool runs +x along the wall y = Yp (on its
    left: up milling, [0, theta_e] with theta_e = arccos(1 - ae / R)), then turns right to run
    -y along the wall x = Xp. At the corner point of the tool path the cutter touches the
    stock of the wall ahead from phi = pi/2 - theta_e to pi/2 + theta_e besides the stock of
    the wall beside it, so the hull is [0, pi/2 + theta_e] (engagement angle = nominal + 90
    deg, the classic inside-corner value).
    """
    ae = 2.0 * MM
    xp, yp, z_floor = 60 * MM, 40 * MM, 10 * MM
    stock = ZMap.box(0, 100 * MM, 0, 80 * MM, 0, 20 * MM)
    xs, ys = stock.x_centres, stock.y_centres
    stock.heights[np.ix_(xs < xp, ys < yp)] = z_floor
    corner = np.array([xp - R + ae, yp - R + ae, z_floor])
    leg1 = line([5 * MM, corner[1], z_floor], corner, 0.5 * MM)
    leg2 = line(corner, [corner[0], 5 * MM, z_floor], 0.5 * MM)
    pos = np.concatenate([leg1[0], leg2[0][1:]])
    tan = np.concatenate([leg1[1], leg2[1][1:]])
    res = sweep(stock, TOOL, pos, tan)
    eng = res.engagement
    theta_e = math.acos(1 - ae / R)
    i_corner = leg1[0].shape[0] - 1
    straight1 = (
        (pos[:, 0] > 20 * MM) & (pos[:, 0] < corner[0] - 12 * MM) & (np.arange(len(pos)) < i_corner)
    )
    straight2 = (np.arange(len(pos)) > i_corner) & (pos[:, 1] < corner[1] - 12 * MM)
    straight2 &= pos[:, 1] > 15 * MM
    for sel in (straight1, straight2):
        assert not res.in_air[sel].any()
        assert_angles(eng.entry[sel], 0.0)
        assert_angles(eng.exit[sel], theta_e)
    # the spike: at the corner point the hull reaches pi/2 + theta_e
    expected = math.pi / 2 + theta_e
    assert eng.entry[i_corner] == 0.0
    assert abs(eng.exit[i_corner] - expected) <= 2 * angle_error_bound(expected, H, R)
    # it rises above the straight-cut value over the last ae before the corner
    approach = (np.arange(len(pos)) < i_corner) & (pos[:, 0] > corner[0] - ae + 0.3 * MM)
    assert np.all(eng.exit[approach] > math.pi / 2 - 0.05)
    assert eng.exit[: i_corner + 1].max() == pytest.approx(expected, abs=0.05)
    assert np.all(eng.exit[straight1] < theta_e + 0.05)


def test_plunge_tangent_refused_and_air_outside():
    stock = ZMap.box(0, 10 * MM, 0, 10 * MM, 0, 5 * MM)
    with pytest.raises(InputError, match="sample 1 runs along the tool axis"):
        sweep(stock, TOOL, np.zeros((2, 3)), np.array([[1.0, 0, 0], [0, 0, -1.0]]))
    res = sweep(stock, TOOL, *line([50 * MM, 0, 0], [60 * MM, 0, 0]))
    assert res.in_air.all() and np.isnan(res.lateral).all()


def test_error_bound_numbers():
    assert snap_angle(H, R) == pytest.approx(math.acos(1 - math.sqrt(2) * H / R))
    # where the boundary crosses the rim at 90 deg: (h / sqrt 2) / R
    assert angle_error_bound(math.pi / 2, H, R) == pytest.approx(H / math.sqrt(2) / R, rel=1e-3)


def test_memory_and_timing_of_a_200_by_100_box(capsys):
    """Not a timed test: measures a 200 x 100 mm box at 0.25 mm and a 2000-sample path."""
    stock = ZMap.box(0, 200 * MM, 0, 100 * MM, 0, 30 * MM)
    assert stock.shape == (800, 400)
    assert stock.nbytes == 800 * 400 * 4
    s = np.linspace(0, 1, 2000)
    pos = np.stack(
        [
            10 * MM + 180 * MM * s,
            50 * MM + 30 * MM * np.sin(2 * math.pi * s),
            np.full_like(s, 27 * MM),
        ],
        axis=1,
    )
    tan = np.gradient(pos, axis=0)
    start = time.perf_counter()
    res = sweep(stock, TOOL, pos, tan)
    elapsed = time.perf_counter() - start
    assert not res.in_air[10:-10].any()
    with capsys.disabled():
        print(
            f"\nZ-map 800 x 400 cells, {stock.nbytes / 1e6:.2f} MB; 2000 samples "
            f"(step {np.linalg.norm(np.diff(pos, axis=0), axis=1).mean() / MM:.3f} mm) "
            f"in {elapsed:.2f} s"
        )

"""Engagement from a Z-map stock against analytic engagement (straight cuts, offset passes, the
chapter-4 ramp, corner arcs, entering and leaving), removed volumes, stocks from meshes, and the
blocked sweep against the along-path definition written out sample by sample."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.process.engagement import peripheral_engagement, slot_engagement
from feedopt.process.stock import (
    FlatEndMill,
    ZMap,
    angle_error_bound,
    lookahead_reach,
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


def arc(centre, radius, t0, t1, z, step=0.1 * MM):
    """Samples every ~step on the arc of ``radius`` about ``centre`` from angle t0 to t1."""
    n = int(round(abs(t1 - t0) * radius / step)) + 1
    t = np.linspace(t0, t1, n)
    pos = np.column_stack(
        [centre[0] + radius * np.cos(t), centre[1] + radius * np.sin(t), np.full(n, z)]
    )
    sense = math.copysign(1.0, t1 - t0)
    tan = np.column_stack([-np.sin(t) * sense, np.cos(t) * sense, np.zeros(n)])
    return pos, tan


def chain(*pieces):
    """Concatenate (pos, tan) pieces that share their end points."""
    pos = np.concatenate([pieces[0][0]] + [p[0][1:] for p in pieces[1:]])
    tan = np.concatenate([pieces[0][1]] + [p[1][1:] for p in pieces[1:]])
    return pos, tan


def pocket_path(step=0.1 * MM):
    """A small pocket-like path: a 20 mm ramp, then inside-out rounded rectangles, 2 levels."""
    cx, cy = 40 * MM, 30 * MM
    pieces = []
    z_prev = 20 * MM
    for z in (18 * MM, 16 * MM):
        pieces.append(line([cx - 20 * MM, cy, z_prev], [cx, cy, z], step))
        last = np.array([cx, cy, z])
        for hx, hy in ((8 * MM, 2 * MM), (16 * MM, 10 * MM)):
            start = np.array([cx + hx, cy, z])
            pieces.append(line(last, start, step))
            rho = 2 * MM
            legs = [
                arc((cx + hx - rho, cy + hy - rho), rho, 0, math.pi / 2, z, step),
                arc((cx - hx + rho, cy + hy - rho), rho, math.pi / 2, math.pi, z, step),
                arc((cx - hx + rho, cy - hy + rho), rho, math.pi, 1.5 * math.pi, z, step),
                arc((cx + hx - rho, cy - hy + rho), rho, 1.5 * math.pi, 2 * math.pi, z, step),
            ]
            seq = [line(start, legs[0][0][0], step)]
            for k in range(4):
                seq.append(legs[k])
                nxt = legs[(k + 1) % 4][0][0] if k < 3 else start
                seq.append(line(legs[k][0][-1], nxt, step))
            pieces.extend(seq)
            last = start
        pieces.append(line(last, [cx - 20 * MM, cy, z], step))
        z_prev = z
    pos = np.concatenate([p[0] for p in pieces])
    keep = np.concatenate([[True], np.linalg.norm(np.diff(pos, axis=0), axis=1) > 0])
    pos = pos[keep]
    return pos, np.gradient(pos, axis=0)


def _compare_with_reference(stock, pos, tan, lookahead=None):
    ref_stock = stock.copy()
    ref = _reference_sweep(ref_stock, TOOL, pos, tan, lookahead)
    res = sweep(stock, TOOL, pos, tan, lookahead)
    names = ("entry", "exit", "axial_depth", "in_air", "beyond_flutes", "lateral", "removed",
             "swept_depth", "bottom_depth")
    got = (
        res.engagement.entry, res.engagement.exit, res.axial_depth, res.in_air,
        res.beyond_flutes, res.lateral, res.removed, res.swept_depth, res.bottom_depth,
    )
    for name, a, b in zip(names, ref, got, strict=True):
        if name in ("removed", "entry", "exit", "lateral"):  # sums, acos: to rounding
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-15, err_msg=name)
        else:
            np.testing.assert_array_equal(b, a, err_msg=name)
    np.testing.assert_array_equal(stock.heights, ref_stock.heights)
    return res


def _fixed_paths():
    s = np.linspace(0, 1, 1500)
    wavy = np.stack(
        [
            5 * MM + 70 * MM * s,
            30 * MM + 18 * MM * np.sin(3 * math.pi * s),
            np.full_like(s, 17 * MM),
        ],
        axis=1,
    )
    ramp = wavy.copy()
    ramp[:, 2] = np.where(s < 0.3, 19 * MM - 6 * MM * s / 0.3, 13 * MM)
    t = np.linspace(0, 4 * math.pi, 1200)
    helix = np.stack(
        [40 * MM + 8 * MM * np.cos(t), 30 * MM + 8 * MM * np.sin(t), 20 * MM - MM * t / math.pi],
        axis=1,
    )
    rng = np.random.default_rng(3)
    coarse = np.cumsum(rng.uniform(-3, 3, (200, 3)) * MM * [1, 1, 0.05], axis=0)
    coarse += [40 * MM, 30 * MM, 15 * MM]
    x_line = line([-10 * MM, 30.02 * MM, 16 * MM], [90 * MM, 30.02 * MM, 16 * MM], 0.1 * MM)
    y_line = line([40.01 * MM, -5 * MM, 16 * MM], [40.01 * MM, 70 * MM, 16 * MM], 0.3 * MM)
    return {
        "wavy level": (wavy, np.gradient(wavy, axis=0), None),
        "ramp then level": (ramp, np.gradient(ramp, axis=0), None),
        "helix": (helix, np.gradient(helix, axis=0), None),
        "coarse random": (coarse, np.gradient(coarse, axis=0) + [1e-9, 0, 0], None),
        "along x, no lookahead": (*x_line, 0.0),
        "along y, long lookahead": (*y_line, 1.0 * MM),
        "pocket": (*pocket_path(), None),
    }


@pytest.mark.parametrize("name", list(_fixed_paths()))
def test_fast_sweep_equals_reference_sweep(name):
    """The fast sweep finds exactly the engagement and heights of the window sweep."""
    pos, tan, look = _fixed_paths()[name]
    stock = ZMap.box(0, 80 * MM, 0, 60 * MM, 0, 20 * MM)
    stock.heights[100:180, 60:120] = 12 * MM  # a step in the stock
    _compare_with_reference(stock, pos, tan, look)


@settings(max_examples=15, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    step_mm=st.sampled_from([0.05, 0.1, 0.3, 2.0]),
    cell_mm=st.sampled_from([0.13, 0.25, 0.5]),
    z_kind=st.sampled_from(["level", "descending", "steps"]),
)
def test_fast_sweep_equals_reference_on_random_paths(seed, step_mm, cell_mm, z_kind):
    rng = np.random.default_rng(seed)
    stock = ZMap.box(0, 60 * MM, 0, 50 * MM, 0, 20 * MM, cell=cell_mm * MM)
    stock.heights[rng.integers(0, stock.shape[0], 30), rng.integers(0, stock.shape[1], 30)] = 5 * MM
    n = 250
    heading = np.cumsum(rng.normal(0, 0.1, n)) + rng.uniform(0, 2 * math.pi)
    xy = np.cumsum(np.stack([np.cos(heading), np.sin(heading)], 1) * step_mm * MM, axis=0)
    xy += [30 * MM, 25 * MM]
    z = {
        "level": np.full(n, 15 * MM),
        "descending": 18 * MM - np.cumsum(rng.uniform(0, 0.02, n)) * MM,
        "steps": np.where(rng.random(n) < 0.1, 12 * MM, 14 * MM),
    }[z_kind]
    pos = np.column_stack([xy, z])
    _compare_with_reference(stock, pos, np.gradient(pos, axis=0) + [1e-12, 0, 0])


# ---------------------------------------------------------------------------------- removed


def test_removed_adds_up_to_the_volume_cut_by_a_pocket():
    stock = ZMap.box(0, 80 * MM, 0, 60 * MM, 0, 20 * MM)
    before = stock.volume()
    res = sweep(stock, TOOL, *pocket_path())
    assert np.all(res.removed >= 0)
    assert res.removed.sum() == pytest.approx(before - stock.volume(), rel=1e-6)
    assert res.removed.sum() > 0.5 * (32 * 20 + 16 * 4) * 4 * MM**3  # it did clear the pocket
    # a second run over the cleared pocket removes nothing (it may still see the walls
    # through the lookahead)
    again = sweep(stock, TOOL, *pocket_path())
    assert again.removed.sum() == 0.0


@pytest.mark.parametrize("angle_deg", [0.0, 27.0])
def test_removed_by_a_straight_slot_is_the_capsule_volume(angle_deg):
    """A slot plunged at A (sample 0 removes its disc) and cut to B removes the capsule
    ``(L D + pi R^2) depth``. The cells removed are those whose centre is inside the capsule,
    so their area is within that of the capsule dilated and eroded by h / sqrt 2: the error is
    at most ``depth (P h / sqrt 2 + pi h^2 / 2)`` with P = 2 L + 2 pi R (2.2 % here; the
    actual error is far smaller as cells cancel along the boundary)."""
    u = np.array([math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg)), 0.0])
    a = np.array([20.03 * MM, 25.07 * MM, 16 * MM])
    length = 60 * MM
    stock = ZMap.box(0, 100 * MM, 0, 80 * MM, 0, 20 * MM)
    before = stock.volume()
    res = sweep(stock, TOOL, *line(a, a + length * u, 0.1 * MM))
    depth = 4 * MM
    capsule = (length * D + math.pi * R**2) * depth
    bound = depth * ((2 * length + 2 * math.pi * R) * H / math.sqrt(2) + math.pi * H**2 / 2)
    assert res.removed.sum() == pytest.approx(before - stock.volume(), rel=1e-6)
    assert abs(res.removed.sum() - capsule) <= bound
    # per step in the steady part: D ds depth on average (same boundary argument over 40 mm)
    steady = slice(100, 500)
    seg = 40 * MM
    assert abs(res.removed[steady].sum() - D * seg * depth) <= depth * 2 * (seg + D) * H


# --------------------------------------------------------------------------- offset passes


def _offset_pass(radius, b, angle, side, reverse, step=0.25 * MM):
    """Slot 1 along u, then pass 2 offset b to the left (side +1) or right (-1) of u, fed
    along u or -u. Returns pass 2's result, the samples well inside, and the milling mode."""
    tool = FlatEndMill(radius, 30 * MM)
    stock = ZMap.box(0, 140 * MM, 0, 140 * MM, 0, 20 * MM)
    u = np.array([math.cos(angle), math.sin(angle), 0.0])
    left = np.array([-u[1], u[0], 0.0])
    c = np.array([70.011 * MM, 70.023 * MM, 16 * MM])
    sweep(stock, tool, *line(c - 60 * MM * u, c + 60 * MM * u, step))
    a, e = c + side * b * left - 60 * MM * u, c + side * b * left + 60 * MM * u
    pos, tan = line(e, a, step) if reverse else line(a, e, step)
    res = sweep(stock, tool, pos, tan)
    inside = np.abs((pos - c) @ u) < 30 * MM
    milling = "up" if (side > 0) != reverse else "down"
    return res, inside, milling, tool


@pytest.mark.parametrize("side", [1, -1])
@pytest.mark.parametrize("reverse", [False, True])
def test_offset_pass_gives_arccos_of_the_step_over_on_the_right_side(side, reverse):
    """Pass 2 offset b from slot 1: the material left is b wide on the offset side, so the
    engagement is [0, arccos(1 - 2b/D)] with it on the left of the feed (up milling) and
    [pi - arccos(1 - 2b/D), pi] with it on the right (down milling)."""
    b = 3.7 * MM
    res, inside, milling, _ = _offset_pass(R, b, math.radians(23.0), side, reverse)
    sweep_angle = math.acos(1 - 2 * b / D)
    if milling == "up":
        entry, exit_ = 0.0, sweep_angle
    else:
        entry, exit_ = math.pi - sweep_angle, math.pi
    assert not res.in_air[inside].any()
    assert_angles(res.engagement.entry[inside], entry)
    assert_angles(res.engagement.exit[inside], exit_)
    np.testing.assert_allclose(res.axial_depth[inside], 4 * MM, atol=1e-8)


@settings(max_examples=25, deadline=None)
@given(
    radius_mm=st.floats(3.0, 12.0),
    b_frac=st.floats(0.0, 1.0),
    angle=st.floats(0.0, 2 * math.pi),
    side=st.sampled_from([1, -1]),
    reverse=st.booleans(),
)
def test_offset_pass_angles_hypothesis(radius_mm, b_frac, angle, side, reverse):
    radius = radius_mm * MM
    b = 0.5 * MM + b_frac * (2 * radius - 1.0 * MM)  # step-over in [0.5 mm, D - 0.5 mm]
    res, inside, milling, tool = _offset_pass(radius, b, angle, side, reverse)
    sweep_angle = math.acos(1 - b / radius)
    entry, exit_ = (0.0, sweep_angle) if milling == "up" else (math.pi - sweep_angle, math.pi)
    assert not res.in_air[inside].any()
    for got, want in ((res.engagement.entry[inside], entry), (res.engagement.exit[inside], exit_)):
        bound = angle_error_bound(want, H, radius)
        assert np.all(np.abs(got - want) <= bound + 1e-12)


# ------------------------------------------------------------------------ chapter-4 ramp


def test_chapter4_inclined_line_radial_depth_grows_from_0_to_9525():
    """Thesis chapter 4: a 203.2 x 50.8 x 25.4 mm block, the tool (2.54 mm deep) along x over
    203.2 mm, drifting 9.525 mm to -y into the block on its right (down milling), starting
    tangent to the block's edge y = Y. The block is placed with that edge on a cell boundary
    (ZMap.box rounds the far sides up to whole cells: 50.8 mm would end at 51.0 mm).

    Analytic engagement: with d = y_c - Y, the rim meets the (uncut) edge ahead of the centre
    at dx = sqrt(R^2 - d^2) in W, whose lateral coordinate in the force frame is
    ``y* = sqrt(R^2 - d^2) sin(a) - d cos(a)`` (a = atan(9.525 / 203.2), the angle between
    the feed and the edge), so the radial depth seen by the teeth is ``ae = R + y*``. It grows
    from R (1 - cos a) = 0.01 mm to R (1 + sin a) = 9.97 mm, not exactly linearly, and is
    above the nominal ramp ae_n = R - d (0 -> 9.525 mm, linear) by up to R sin a = 0.45 mm:
    the inclined edge is met ahead of the centre. Resolution: h / sqrt 2 plus the view ahead
    and behind the rim times the edge's slope tan(a) (:func:`angle_error_bound`).
    """
    length, width, thick, drift = 203.2 * MM, 50.8 * MM, 25.4 * MM, 9.525 * MM
    y_edge = width
    stock = ZMap.box(0, length, y_edge - 204 * H, y_edge, 0, thick)
    assert stock.origin[1] + stock.shape[1] * H == pytest.approx(y_edge, abs=1e-12)
    ztip = thick - 2.54 * MM
    step = 0.1 * MM
    a = np.array([0.0, y_edge + R, ztip])
    b = np.array([length, y_edge + R - drift, ztip])
    pos, tan = line(a, b, step)
    res = sweep(stock, TOOL, pos, tan)
    alpha = math.atan2(drift, length)
    d = pos[:, 1] - y_edge
    ahead = np.sqrt(np.maximum(R**2 - d**2, 0.0))
    ae_true = R - d * math.cos(alpha) + ahead * math.sin(alpha)
    ae_nominal = R - d
    along = pos[:, 0] + ahead < length - 2 * MM  # the crossing well before the block's end
    entry_true = np.arccos(np.clip(ae_true / R - 1.0, -1.0, 1.0))
    reach = lookahead_reach(entry_true, H, R, step)
    slack = math.tan(alpha) * (reach + step)
    engaged = ~res.in_air
    # ae below about one cell is not resolved; beyond it every sample cuts
    assert engaged[along & (ae_true > math.sqrt(2) * H)].all()
    sel = along & engaged
    ae_meas = res.lateral[:, 1] + R  # down milling: material from -R up to y_hi
    err = np.abs(ae_meas - ae_true)
    assert np.all(err[sel] <= H / math.sqrt(2) + slack[sel]), float(np.max(err[sel]) / MM)
    assert_angles(res.engagement.exit[sel], math.pi)
    bound = angle_error_bound(entry_true[sel], H, R, lateral=slack[sel])
    assert np.all(np.abs(res.engagement.entry[sel] - entry_true[sel]) <= bound)
    np.testing.assert_allclose(res.axial_depth[sel], 2.54 * MM, atol=1e-8)
    # against the nominal linear ramp: within the resolution, plus up to R sin(a) above it
    over = ae_meas[sel] - ae_nominal[sel]
    assert np.all(over >= -H / math.sqrt(2))
    assert np.all(over <= R * math.sin(alpha) + H / math.sqrt(2) + slack[sel])
    # and it does grow linearly to first order: slope of the fit 9.525 mm / 203.2 mm +- 5 %
    fit = np.polyfit(pos[sel, 0], ae_meas[sel], 1)[0]
    assert fit == pytest.approx(drift / length, rel=0.05)
    assert ae_meas[sel][-1] > 9.0 * MM


# ------------------------------------------------------------------------------ corner arcs


def circle_engagement_cos(r_c, r_m):
    """cos of the engaged half-angle for a cutter of radius R centred on a circle of radius
    r_c, concentric with a material boundary circle of radius r_m.

    A rim point c + R v is at distance ``sqrt(r_c^2 + R^2 + 2 r_c R (u.v))`` from the common
    centre O (u = unit vector from O to c), so it is on the boundary where
    ``u.v = kappa = (r_m^2 - r_c^2 - R^2) / (2 r_c R)`` (intersection of two circles; cf.
    Altintas, Manufacturing Automation, 2nd ed., ch. 2 on radial immersion, and the
    circular-path engagement of Kramer 1992 / Wang & Zheng 2002). The feed is tangent,
    perpendicular to u, and a tooth at phi is at v = sin(phi) f + cos(phi) y:

    * inside corner (material outside the circle r_m, on the outer side u = +y: the cutter
      turns towards the material): engaged where u.v = cos(phi) >= kappa, phi in
      [0, arccos(kappa)] (up milling);
    * outside corner (material inside r_m, on the inner side -u = +y): engaged where
      u.v = -cos(phi) <= kappa, phi in [0, arccos(-kappa)].

    With r_m = r_c + R - b (inside) or r_c - R + b (outside), kappa -> 1 - b/R as r_c -> oo,
    the straight cut; inside corners raise, outside corners lower the engagement.
    """
    return (r_m**2 - r_c**2 - R**2) / (2 * r_c * R)


def _arc_bound(phi, r_m, r_c, step):
    """angle_error_bound with the slope of the boundary circle r_m at the rim crossing."""
    dx = R * np.sin(phi)
    slope = dx / np.sqrt(r_m**2 - dx**2)
    return angle_error_bound(phi, H, R, lateral=slope * (lookahead_reach(phi, H, R, step)
                                                         + step * (1 + R / r_c)))


CORNERS = [(2.0, 12.0), (1.0, 15.0), (4.0, 20.0), (6.0, 11.0)]


def _on_arc_middle(pos, legs, o):
    polar = np.arctan2(pos[:, 1] - o[1], pos[:, 0] - o[0])
    on_arc = np.zeros(len(pos), dtype=bool)
    n1, n2 = len(legs[0][0]), len(legs[1][0])
    on_arc[n1 : n1 + n2 - 2] = True
    return on_arc & (polar > math.radians(30)) & (polar < math.radians(60))


def inside_corner_cut(b_mm, r_mm, step=0.1 * MM):
    """A pocket wall y = Yw, x = Xw (material beyond them) with a corner rounded to r_m about
    O, cut at radial depth b: the tool runs +x along the wall (on its left), around O on an
    arc of radius r_c = r_m - R + b (clockwise, 90 deg) and down -y along the other wall.
    Returns (pos, tan, sweep result, middle third of the arc, r_c, r_m)."""
    b, z_floor = b_mm * MM, 10 * MM
    r_c = r_mm * MM
    r_m = r_c + R - b
    xw, yw = 70.03 * MM, 60.07 * MM
    o = (xw - r_m, yw - r_m)
    stock = ZMap.box(0, 100 * MM, 0, 80 * MM, 0, 20 * MM)
    x, y = np.meshgrid(stock.x_centres, stock.y_centres, indexing="ij")
    pocket = ((x < o[0]) & (y < yw)) | ((x < xw) & (y < o[1]))
    pocket |= (x - o[0]) ** 2 + (y - o[1]) ** 2 < r_m**2
    stock.heights[pocket] = z_floor
    legs = (
        line([5 * MM, o[1] + r_c, z_floor], [o[0], o[1] + r_c, z_floor], step),
        arc(o, r_c, math.pi / 2, 0.0, z_floor, step),
        line([o[0] + r_c, o[1], z_floor], [o[0] + r_c, 5 * MM, z_floor], step),
    )
    pos, tan = chain(*legs)
    res = sweep(stock, TOOL, pos, tan)
    return pos, tan, res, _on_arc_middle(pos, legs, o), r_c, r_m


def outside_corner_cut(b_mm, r_mm, step=0.1 * MM):
    """An island x < Xi, y < Yi with its corner rounded to r_m about O, cut at radial depth
    b: the tool runs +y along its side (on its left), around O counter-clockwise on an arc
    of radius r_c = r_m + R - b and -x along its top. Returns as :func:`inside_corner_cut`."""
    b, z_floor = b_mm * MM, 10 * MM
    r_m = r_mm * MM
    r_c = r_m + R - b
    xi, yi = 60.03 * MM, 50.07 * MM
    o = (xi - r_m, yi - r_m)
    stock = ZMap.box(0, 100 * MM, 0, 80 * MM, 0, 20 * MM)
    x, y = np.meshgrid(stock.x_centres, stock.y_centres, indexing="ij")
    island = ((x < o[0]) & (y < yi)) | ((x < xi) & (y < o[1]))
    island |= (x - o[0]) ** 2 + (y - o[1]) ** 2 < r_m**2
    stock.heights[~island] = z_floor
    legs = (
        line([o[0] + r_c, 2 * MM, z_floor], [o[0] + r_c, o[1], z_floor], step),
        arc(o, r_c, 0.0, math.pi / 2, z_floor, step),
        line([o[0], o[1] + r_c, z_floor], [2 * MM, o[1] + r_c, z_floor], step),
    )
    pos, tan = chain(*legs)
    res = sweep(stock, TOOL, pos, tan)
    return pos, tan, res, _on_arc_middle(pos, legs, o), r_c, r_m


@pytest.mark.parametrize(("b_mm", "r_mm"), CORNERS)
def test_inside_corner_arc_raises_engagement_as_two_circles_give(b_mm, r_mm):
    """Inside corner (:func:`inside_corner_cut`): in the middle third of the arc the exit
    angle is arccos(kappa), entry 0."""
    step = 0.1 * MM
    _, _, res, middle, r_c, r_m = inside_corner_cut(b_mm, r_mm, step)
    expected = math.acos(circle_engagement_cos(r_c, r_m))
    assert not res.in_air[middle].any()
    assert_angles(res.engagement.entry[middle], 0.0)
    err = np.abs(res.engagement.exit[middle] - expected)
    assert np.all(err <= _arc_bound(expected, r_m, r_c, step)), float(err.max())
    straight = math.acos(1 - b_mm * MM / R)
    assert expected > straight and res.engagement.exit[middle].mean() > straight  # a rise


@pytest.mark.parametrize(("b_mm", "r_mm"), CORNERS)
def test_outside_corner_arc_lowers_engagement_as_two_circles_give(b_mm, r_mm):
    """Outside corner (:func:`outside_corner_cut`): middle third of the arc: exit
    arccos(-kappa) < arccos(1 - b/R), entry 0."""
    step = 0.1 * MM
    _, _, res, middle, r_c, r_m = outside_corner_cut(b_mm, r_mm, step)
    expected = math.acos(-circle_engagement_cos(r_c, r_m))
    assert not res.in_air[middle].any()
    assert_angles(res.engagement.entry[middle], 0.0)
    err = np.abs(res.engagement.exit[middle] - expected)
    assert np.all(err <= _arc_bound(expected, r_m, r_c, step)), float(err.max())
    straight = math.acos(1 - b_mm * MM / R)
    assert expected < straight and res.engagement.exit[middle].mean() < straight  # a drop


# ------------------------------------------------------------------- entering and leaving


def _hull(x_c, band, x0, x1, reach, phi):
    """Hull [entry, exit] of the tooth angles phi whose rim point (x_c + R sin phi, lateral
    R cos phi) lies in material x in [x0 - reach(phi), x1], lateral in ``band``; (nan, nan)
    for none."""
    xr = x_c + R * np.sin(phi)
    lat = R * np.cos(phi)
    hit = (xr >= x0 - reach) & (xr <= x1) & (lat >= band[0]) & (lat <= band[1])
    if not hit.any():
        return math.nan, math.nan
    return float(phi[hit].min()), float(phi[hit].max())


@pytest.mark.parametrize(("mode", "ae_mm"), [("slot", None), ("up", 3.0), ("down", 3.0),
                                             ("up", 8.0)])
@pytest.mark.parametrize("step_mm", [0.1, 0.37])
def test_entering_and_leaving_the_stock(mode, ae_mm, step_mm):
    """Feed +x through a block x in [X0, X1] (a slot, or a side cut of radial depth ae with
    the block on the left or the right), from air to air.

    The disc first meets the block at x_c = X0 - sqrt(R^2 - y_e^2) (y_e: lateral offset of
    the block's edge, 0 for a slot): the first engaged sample is within one cell plus one
    step of it (the lookahead sees the face ahead up to sqrt(2) h - ds early, a face on a
    cell boundary is seen h/2 late). While entering, the engaged angles are those whose rim
    point is inside the block (x >= X0); the Z-map sees the face between ``lookahead_reach``
    early and a cell late. The last contact is where the rim passes X1 at phi = 0 or pi, a
    tangent contact: material a cell wide is not resolved there (the snap zone), so the
    engagement drops to zero within R sin(snap angle) + h + ds before x_c = X1; until then
    the angles are those of the rim points with x <= X1 (hull of both sides for a slot),
    with the face seen up to a step plus a cell late.
    """
    step = step_mm * MM
    x0, x1 = 20 * MM, 70 * MM
    yc = 40.013 * MM
    stock = ZMap.box(0, 100 * MM, 0, 80 * MM, 0, 20 * MM)
    x, y = np.meshgrid(stock.x_centres, stock.y_centres, indexing="ij")
    if mode == "slot":
        y0, y1 = 10 * MM, 70 * MM
    elif mode == "up":
        y0, y1 = yc + R - ae_mm * MM, 70 * MM
    else:
        y0, y1 = 10 * MM, yc - R + ae_mm * MM
    stock.heights[~((x > x0) & (x < x1) & (y > y0) & (y < y1))] = 0.0
    n = int(round(100 * MM / step)) + 1
    pos = np.column_stack(
        [-5 * MM + 0.0031 * MM + step * np.arange(n), np.full(n, yc), np.full(n, 17 * MM)]
    )
    res = sweep(stock, TOOL, pos, np.tile([1.0, 0.0, 0.0], (n, 1)))
    band = (max(y0 - yc, -R), min(y1 - yc, R))
    y_e = 0.0 if mode == "slot" else (band[0] if mode == "up" else band[1])
    contact = x0 - math.sqrt(R**2 - y_e**2)
    engaged = ~res.in_air
    first = pos[np.argmax(engaged), 0]
    last = pos[n - 1 - np.argmax(engaged[::-1]), 0]
    assert abs(first - contact) <= H + step
    r_snap = R * math.sin(snap_angle(H, R))
    assert x1 - r_snap - H - step <= last <= x1
    # the angles, sample by sample, between the early and the late view of both faces; the
    # late view leaves out the teeth in the snap zone (a sliver there may not show)
    phi = np.linspace(0.0, math.pi, 4001)
    reach = lookahead_reach(phi, H, R, step)
    snap = snap_angle(H, R)
    resolved = np.where((phi >= snap) & (phi <= math.pi - snap), 0.0, np.inf)
    for i in range(n):
        xc = pos[i, 0]
        late = _hull(xc, band, x0 + H + resolved, x1 - H - resolved, 0.0, phi)
        early = _hull(xc, band, x0 - H, x1 + step + H, reach, phi)
        ent, ex = res.engagement.entry[i], res.engagement.exit[i]
        if not math.isnan(late[0]):
            assert engaged[i], xc / MM
            assert ent <= late[0] + float(angle_error_bound(late[0], H, R)), (xc / MM, late)
            assert ex >= late[1] - float(angle_error_bound(late[1], H, R)), (xc / MM, late)
        if engaged[i]:
            assert not math.isnan(early[0]), xc / MM
            assert early[0] - float(angle_error_bound(early[0], H, R)) <= ent, (xc / MM, early)
            assert ex <= early[1] + float(angle_error_bound(early[1], H, R)), (xc / MM, early)
    # in between, the nominal engagement
    mid = (pos[:, 0] > x0 + R + 1 * MM) & (pos[:, 0] < x1 - R - 1 * MM)
    if mode == "slot":
        entry, exit_ = 0.0, math.pi
    else:
        sweep_angle = math.acos(1 - ae_mm * MM / R)
        entry, exit_ = (0.0, sweep_angle) if mode == "up" else (math.pi - sweep_angle, math.pi)
    assert_angles(res.engagement.entry[mid], entry)
    assert_angles(res.engagement.exit[mid], exit_)


# --------------------------------------------------------------------------- from a mesh


def _block_mesh(xs, ys, tops):
    """A closed mesh of blocks on a coarse grid: block (i, j) spans xs[i]..xs[i+1] by
    ys[j]..ys[j+1] from z = 0 to tops[i][j] (0: no block). Faces: the tops, the bottoms and a
    vertical wall wherever neighbouring heights differ (outside counts as 0)."""
    trimesh = pytest.importorskip("trimesh")
    tops = np.asarray(tops, dtype=float)
    nx, ny = tops.shape
    quads = []  # (4 corners, outward normal)

    def top(i, j):
        return tops[i, j] if 0 <= i < nx and 0 <= j < ny else 0.0

    for i in range(nx):
        for j in range(ny):
            t = tops[i, j]
            if t <= 0:
                continue
            x0, x1, y0, y1 = xs[i], xs[i + 1], ys[j], ys[j + 1]
            quads.append(([(x0, y0, t), (x1, y0, t), (x1, y1, t), (x0, y1, t)], (0, 0, 1)))
            quads.append(([(x0, y0, 0), (x0, y1, 0), (x1, y1, 0), (x1, y0, 0)], (0, 0, -1)))
    for i in range(nx + 1):  # walls at x = xs[i] between block i-1 and i
        for j in range(ny):
            lo_h, hi_h = top(i - 1, j), top(i, j)
            if lo_h == hi_h:
                continue
            z0, z1 = min(lo_h, hi_h), max(lo_h, hi_h)
            x = xs[i]
            normal = (1, 0, 0) if lo_h > hi_h else (-1, 0, 0)
            quads.append(([(x, ys[j], z0), (x, ys[j + 1], z0), (x, ys[j + 1], z1),
                           (x, ys[j], z1)], normal))
    for j in range(ny + 1):
        for i in range(nx):
            lo_h, hi_h = top(i, j - 1), top(i, j)
            if lo_h == hi_h:
                continue
            z0, z1 = min(lo_h, hi_h), max(lo_h, hi_h)
            y = ys[j]
            normal = (0, 1, 0) if lo_h > hi_h else (0, -1, 0)
            quads.append(([(xs[i], y, z0), (xs[i + 1], y, z0), (xs[i + 1], y, z1),
                           (xs[i], y, z1)], normal))
    verts, faces = [], []
    for corners, normal in quads:
        c = np.array(corners, dtype=float)
        if np.dot(np.cross(c[1] - c[0], c[2] - c[0]), normal) < 0:
            c = c[::-1]
        base = len(verts)
        verts.extend(c)
        faces.extend([(base, base + 1, base + 2), (base, base + 2, base + 3)])
    mesh = trimesh.Trimesh(np.array(verts), np.array(faces), process=True)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    return mesh


def test_from_mesh_box_equals_zmap_box(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    box = trimesh.creation.box(extents=[100.0, 50.0, 20.0])
    box.apply_translation([60.0, 35.0, 10.0])  # [10, 110] x [10, 60] x [0, 20] mm
    path = tmp_path / "box.stl"
    box.export(path)
    got = ZMap.from_mesh(path, H, scale=MM)
    want = ZMap.box(10 * MM, 110 * MM, 10 * MM, 60 * MM, 0, 20 * MM, H)
    assert got.shape == want.shape and got.origin == pytest.approx(want.origin, abs=1e-12)
    assert got.bottom == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(got.heights, want.heights, atol=1e-9)
    assert got.volume() == pytest.approx(100 * 50 * 20 * MM**3, rel=1e-6)


def test_from_mesh_box_with_pocket_and_hole(tmp_path):
    """A 100 x 60 x 20 mm block with a 40 x 20 mm pocket 8 mm deep and a 10 x 10 mm through
    hole (STL in mm; coarse grid breaks at the pocket and hole edges)."""
    xs = [0.0, 10.0, 20.0, 30.0, 70.0, 100.0]
    ys = [0.0, 20.0, 30.0, 40.0, 60.0]
    tops = np.full((5, 4), 20.0)
    tops[3, 1:3] = 12.0  # pocket x 30..70, y 20..40
    tops[1, 1] = 0.0  # hole x 10..20, y 20..30
    mesh = _block_mesh(xs, ys, tops)
    path = tmp_path / "pocket.stl"
    mesh.export(path)
    cell = 0.5 * MM
    got = ZMap.from_mesh(path, cell, scale=MM)
    assert got.shape == (200, 120) and got.bottom == pytest.approx(0.0, abs=1e-12)
    xc, yc = got.x_centres / MM, got.y_centres / MM
    want = np.full(got.shape, 20.0)
    want[np.ix_((xc > 30) & (xc < 70), (yc > 20) & (yc < 40))] = 12.0
    want[np.ix_((xc > 10) & (xc < 20), (yc > 20) & (yc < 30))] = 0.0
    np.testing.assert_allclose(got.heights / MM, want, atol=1e-6)
    assert got.volume() == pytest.approx((100 * 60 * 20 - 40 * 20 * 8 - 10 * 10 * 20) * MM**3,
                                         rel=1e-6)


def test_from_mesh_refuses_what_a_zmap_cannot_hold(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    with pytest.raises(InputError, match="no such file"):
        ZMap.from_mesh(tmp_path / "missing.stl")
    junk = tmp_path / "junk.stl"
    junk.write_text("this is not a mesh\n")
    with pytest.raises(InputError, match="not an STL"):
        ZMap.from_mesh(junk)
    other = tmp_path / "numbers.txt"
    other.write_text("1 2 3\n")
    with pytest.raises(InputError, match="must be an STL file"):
        ZMap.from_mesh(other)
    # the meshes below are in metres
    box = trimesh.creation.box(extents=[0.1, 0.05, 0.02])
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-1], process=False)
    path = tmp_path / "open.stl"
    open_box.export(path)
    with pytest.raises(InputError, match="not closed"):
        ZMap.from_mesh(path, scale=1.0)
    # a block floating above another: material, air, material in one column
    lower = trimesh.creation.box(extents=[0.1, 0.05, 0.01])
    lower.apply_translation([0.05, 0.025, 0.005])
    upper = trimesh.creation.box(extents=[0.02, 0.02, 0.01])
    upper.apply_translation([0.05, 0.025, 0.03])
    path = tmp_path / "overhang.stl"
    trimesh.util.concatenate([lower, upper]).export(path)
    with pytest.raises(InputError, match="overhang"):
        ZMap.from_mesh(path, scale=1.0)
    # a block standing beside, not on, the bottom
    side = trimesh.creation.box(extents=[0.02, 0.02, 0.01])
    side.apply_translation([0.15, 0.025, 0.012])
    path = tmp_path / "floating.stl"
    trimesh.util.concatenate([lower, side]).export(path)
    with pytest.raises(InputError, match="flat bottom"):
        ZMap.from_mesh(path, scale=1.0)


# --------------------------------------------------------------------------------------------
# The along-path sweep (issue 28) written out sample by sample on a window of cells, as plainly
# as possible, to check that the blocked sweep gives the same engagement and heights, cell by
# cell. Definitions: feedopt.process.stock_sweep's module docstring.
# --------------------------------------------------------------------------------------------


def _ref_curvature(t, chord, ahead):
    """kappa of the arc tangent to t through the chord's other end; None past 90 deg."""
    cross = t[0] * chord[1] - t[1] * chord[0]
    cross = cross if ahead else -cross
    dot = t[0] * chord[0] + t[1] * chord[1]
    length2 = chord[0] ** 2 + chord[1] ** 2
    if length2 <= 1e-18 or dot < abs(cross):
        return None
    return 2.0 * cross / length2


def _ref_arc(x, y, k):
    return x if k == 0.0 else np.arctan2(k * x, 1.0 - k * y) / k


def _ref_front(dx, dy, kb, ka, ds, lam_max, radius, look):
    """In front (before leaving out the previous disc) and y' of cells at (dx, dy)."""
    excess = radius**2 - dx**2 - dy**2
    inside = excess >= 0
    dyc = dy + 0.5 * np.where(inside, kb, ka) * excess
    half = np.sqrt(np.maximum(radius**2 - dyc**2, 0.0))
    sigma = _ref_arc(dx, dy, ka) - _ref_arc(half, dyc, ka)
    lam = np.clip(look * radius / np.maximum(half, 1e-300) - ds, 0.0, lam_max)
    ahead = ~inside & (np.abs(dyc) <= radius) & (sigma > 0) & (sigma <= lam)
    return (inside | ahead) & (dx >= 0), np.clip(dyc, -radius, radius)


def _ref_cut_height(ux, uy, seg, z_prev, z_tip, radius):
    """Swept by the step (centre within R of it) and the lowest tip height over the cell:
    the covered parameters are the roots of |u - s seg|^2 = R^2."""
    len2 = float(seg @ seg)
    if len2 == 0.0:
        return ux**2 + uy**2 <= radius**2, np.full(ux.shape, min(z_prev, z_tip))
    b = ux * seg[0] + uy * seg[1]
    s = np.clip(b / len2, 0.0, 1.0)
    swept = (ux - s * seg[0]) ** 2 + (uy - s * seg[1]) ** 2 <= radius**2
    root = np.sqrt(np.maximum(b * b - len2 * (ux**2 + uy**2 - radius**2), 0.0))
    if z_tip < z_prev:
        s_last = np.clip((b + root) / len2, 0.0, 1.0)
        return swept, z_tip + (z_prev - z_tip) * (1.0 - s_last)
    s_first = np.clip((b - root) / len2, 0.0, 1.0)
    return swept, z_prev + (z_tip - z_prev) * s_first


def _ref_arc_cut_height(wx, wy, f, kb, chord, z_prev, z_tip, radius):
    """As :func:`_ref_cut_height` along the arc of the step (curvature kb, ending at the
    sample with tangent f; (wx, wy) relative to the sample): with the arc's centre O, a disc
    at polar angle t about O covers the cell iff the angle to the cell's is at most
    acos((rho^2 + d^2 - R^2) / (2 rho d))."""
    rho = 1.0 / abs(kb)
    sense = math.copysign(1.0, kb)
    ox, oy = -f[1] * sense * rho, f[0] * sense * rho  # O from the sample
    d = np.hypot(wx - ox, wy - oy)
    t_c = math.atan2(-oy, -ox)
    t_q = np.arctan2(wy - oy, wx - ox)
    u = sense * rho * np.angle(np.exp(1j * (t_q - t_c)))  # arc length from the sample
    with np.errstate(divide="ignore", invalid="ignore"):  # 1 - cos b, without cancelling
        sin2 = (radius**2 - (rho - d) ** 2) / (4.0 * rho * d)
    full = sin2 >= 1.0
    half = 2.0 * rho * np.arcsin(np.sqrt(np.clip(sin2, 0.0, 1.0)))
    cos_b = 1.0 - 2.0 * sin2
    length = 2.0 * rho * math.asin(min(1.0, 0.5 * chord / rho))
    first, last = np.full(u.shape, np.inf), np.full(u.shape, -np.inf)
    for m in (-1, 0, 1):
        lo = np.maximum(u + m * 2 * math.pi * rho - half, -length)
        hi = np.minimum(u + m * 2 * math.pi * rho + half, 0.0)
        ok = (lo <= hi) & (cos_b <= 1.0)
        first = np.where(ok, np.minimum(first, lo), first)
        last = np.where(ok, np.maximum(last, hi), last)
    first, last = np.where(full, -length, first), np.where(full, 0.0, last)
    swept = first <= last
    s_first = np.clip(1.0 + first / length, 0.0, 1.0)
    s_last = np.clip(1.0 + last / length, 0.0, 1.0)
    if z_tip < z_prev:
        return swept, z_tip + (z_prev - z_tip) * (1.0 - s_last)
    return swept, z_prev + (z_tip - z_prev) * s_first


def _reference_sweep(stock, tool, positions, tangents, lookahead=None):
    """(entry, exit, axial depth, in_air, beyond_flutes, lateral, removed, swept, bottom)."""
    p = np.asarray(positions, dtype=float)
    n = p.shape[0]
    t = np.asarray(tangents, dtype=float)[:, :2]
    feed = t / np.linalg.norm(t, axis=1)[:, None]
    h, radius, z0 = stock.cell, tool.radius, stock.bottom
    look = math.sqrt(2.0) * h if lookahead is None else float(lookahead)
    snap = math.sqrt(2.0) * h
    look_cap = look / max(math.sin(snap_angle(h, radius)), 1e-12)
    steps = np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1)
    s_xy = np.concatenate([[0.0], np.cumsum(steps)])
    xc_all, yc_all = stock.x_centres, stock.y_centres
    heights = stock.heights
    out = {k: np.zeros(n) for k in ("entry", "exit", "depth", "removed", "swept", "bottom")}
    in_air, beyond = np.ones(n, dtype=bool), np.zeros(n, dtype=bool)
    lateral = np.full((n, 2), np.nan)
    flat = 0.5 * (radius + look_cap) ** 2
    for i in range(n):
        c, z, f = p[i, :2], p[i, 2], feed[i]
        prev = p[i - 1] if i else p[i]
        ds = float(steps[i - 1]) if i else 0.0
        lam_max = min(max(0.0, look_cap - ds), s_xy[-1] - s_xy[i])
        j = i + 1  # the next sample at least min(lam_max, h / 2) on
        while j < n - 1 and s_xy[j] < s_xy[i] + max(min(lam_max, 0.5 * h), 1e-9):
            j += 1
        ka = _ref_curvature(f, p[min(j, n - 1), :2] - c, True)
        lam_max, ka = (0.0, 0.0) if ka is None else (lam_max, ka)
        lam_max = min(lam_max, 0.5 * math.pi / abs(ka)) if ka else lam_max
        kb = _ref_curvature(f, c - prev[:2], False) or 0.0
        ka, kb = (k if abs(k) * flat > 1e-12 else 0.0 for k in (ka, kb))
        reach = radius + look_cap + 2.0 * ds + 1e-3
        wi = (np.abs(xc_all - c[0]) <= reach).nonzero()[0]
        wj = (np.abs(yc_all - c[1]) <= reach).nonzero()[0]
        if wi.size == 0 or wj.size == 0:
            continue
        wi, wj = slice(wi[0], wi[-1] + 1), slice(wj[0], wj[-1] + 1)
        win = heights[wi, wj]
        wx, wy = xc_all[wi, None] - c[0], yc_all[None, wj] - c[1]
        dx, dy = wx * f[0] + wy * f[1], wy * f[0] - wx * f[1]
        front, dyc = _ref_front(dx, dy, kb, ka, ds, lam_max, radius, look)
        to_prev2 = (xc_all[wi, None] - prev[0]) ** 2 + (yc_all[None, wj] - prev[1]) ** 2
        if i:
            front &= to_prev2 > (radius - 1e-9) ** 2
        floor = max(z, z0)
        material = front & (win > floor + 1e-6)
        if material.any():
            w_half = 0.5 * h * (abs(f[0]) + abs(f[1]))
            y_hi, y_lo = float(dyc[material].max()), float(dyc[material].min())
            y_hi = radius if y_hi >= radius - snap else min(radius, y_hi + w_half)
            y_lo = -radius if y_lo <= -radius + snap else max(-radius, y_lo - w_half)
            top = float(win[material].max())
            in_air[i] = False
            out["entry"][i], out["exit"][i] = math.acos(y_hi / radius), math.acos(y_lo / radius)
            out["depth"][i] = min(top - floor, tool.flute_length)
            beyond[i] = top - floor > tool.flute_length
            lateral[i] = (y_lo, y_hi)
        ux, uy = xc_all[wi, None] - prev[0], yc_all[None, wj] - prev[1]
        if abs(kb) * ds**2 > 8e-12:  # the arc bulges from the chord by more than 1e-12 m
            swept, z_cut = _ref_arc_cut_height(wx + 0 * wy, wy + 0 * wx, f, kb, ds, prev[2], z,
                                               radius)
        else:
            swept, z_cut = _ref_cut_height(ux + 0 * uy, uy + 0 * ux, c - prev[:2], prev[2], z,
                                           radius)
        old = win[swept]
        new = np.minimum(old, np.maximum(z_cut[swept], z0)).astype(np.float32)
        win[swept] = new
        cut = np.subtract(old, new, dtype=float)
        if cut.size:
            out["removed"][i], out["swept"][i] = cut.sum() * h**2, cut.max()
            layer = max(max(prev[2], z0) - floor, 0.0) if i else 0.0  # down from the last tip
            out["bottom"][i] = np.minimum(cut, layer).max()
    return (out["entry"], out["exit"], out["depth"], in_air, beyond, lateral, out["removed"],
            out["swept"], out["bottom"])

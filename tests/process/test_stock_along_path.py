"""Engagement along the path (issue 28) against closed forms: a helical bore (the cutter's
side on the helical ramp the previous turn left, the floor cut by the bottom at the pitch per
turn), a ring cut at constant radial depth on a convex and a concave arc, a ramp rising out of
a hole, an inside corner arc, and the crash check of rapids by their swept volume.

Tolerances, and why
-------------------
* Angles: a material boundary circle of radius r_m concentric with the path (radius rho) is
  represented by cell centres within h / sqrt 2 of it (h the Z-map cell); the rim meets a cell
  at ``y' = (R^2 + rho^2 - d^2) / (2 rho)``, so a cell d off the boundary is ``(r_m / rho) d``
  off laterally, and the reported end is widened by at most h / sqrt 2 more:
  ``angle_error_bound(phi, h, R, lateral=(r_m / rho) h / sqrt 2)`` (whose base term is the
  other h / sqrt 2; within the snap angle of 0 or pi, the snap angle).
* Depths on a helix: each cell's height is exact (the swept volume along the arc: checked to
  float32 rounding, 5e-9 m); a cell is met up to the step ds before the sample or up to the
  lookahead after it, while the tip descends ``tan(alpha) = p / (2 pi rho)`` per unit of path,
  so its depth above the current tip is the closed form +- ``(ds + lookahead) tan(alpha)``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process.stock import (
    FlatEndMill,
    ZMap,
    angle_error_bound,
    lookahead_reach,
    snap_angle,
    sweep,
)
from feedopt.runner import prepare_front
from feedopt.scenario import load_scenario

from .test_stock import CORNERS, H, R, circle_engagement_cos, inside_corner_cut

MM = 1e-3
STEP = 0.1 * MM
TOP = 20 * MM
O = (40.013 * MM, 40.029 * MM)  # off the cell grid


def helix(rho, pitch, turns, z_top=TOP, step=STEP, sense=1.0, start=0.0):
    """Samples every ~step (in xy) of a helix about O (counter-clockwise for sense = 1),
    descending ``pitch`` per turn from z_top (rising for pitch < 0); exact tangents."""
    n = int(round(abs(turns) * 2 * math.pi * rho / step)) + 1
    t = start + sense * np.linspace(0.0, 2 * math.pi * turns, n)
    pos = np.column_stack([O[0] + rho * np.cos(t), O[1] + rho * np.sin(t),
                           z_top - pitch * np.abs(t - start) / (2 * math.pi)])
    tan = np.column_stack([-sense * np.sin(t), sense * np.cos(t),
                           np.full(n, -pitch / (2 * math.pi * rho))])
    return pos, tan, t


def beta(d, rho, r):
    """Half the angle about O over which a disc of radius r centred on the circle rho covers
    a point at distance d from O (law of cosines; pi where it always covers it)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        c = (rho**2 + d**2 - r**2) / (2 * rho * d)
    return np.where(c <= -1.0, math.pi, np.arccos(np.clip(c, -1.0, 1.0)))


def ramp_depth(phi, rho, r, pitch):
    """Closed form of the material above the tip where the tooth at phi meets it on a helix
    in steady state: the rim point at phi is at ``d^2 = R^2 + rho^2 - 2 rho R cos(phi)`` from
    O; the disc starts to cover it now (polar angle theta_q - beta) and last covered it one
    turn before the other end of its cover, theta_q + beta - 2 pi: it is
    ``pitch (1 - beta / pi)`` above the tip."""
    d = np.sqrt(r**2 + rho**2 - 2 * rho * r * np.cos(phi))
    return pitch * (1.0 - beta(d, rho, r) / math.pi)


def floor_heights(stock, rho, r, pitch, t_end, z_top=TOP):
    """Closed form of the Z-map after a helix from polar angle 0 to t_end: a cell at distance d
    and polar angle theta from O was last covered at the last polar angle within beta(d) of
    it (the end itself when the final disc covers it, t_end - (delta - beta) when it lies
    delta behind, one turn earlier when ahead), and left at the tip height there. Returns
    the heights and a mask of the cells away from the ends of their cover (1e-6 rad)."""
    x, y = np.meshgrid(stock.x_centres - O[0], stock.y_centres - O[1], indexing="ij")
    d, theta = np.hypot(x, y), np.arctan2(y, x)
    b = beta(d, rho, r)
    delta = np.angle(np.exp(1j * (t_end - theta)))  # (-pi, pi]
    last = np.where(np.abs(delta) <= b, t_end,
                    np.where(delta > b, t_end - (delta - b), t_end - (delta + 2 * math.pi - b)))
    covered = (d <= rho + r) & (d >= rho - r) & (last >= 0.0)  # rho > R: a core stays
    z = np.where(covered, np.minimum(z_top, z_top - pitch * last / (2 * math.pi)), z_top)
    clear = ((np.abs(np.abs(delta) - b) > 1e-6) & (np.abs(d - rho - r) > 1e-9)
             & (np.abs(d - rho + r) > 1e-9) & (np.abs(last) > 1e-6))
    return z, clear


# ------------------------------------------------------------------------- (1) helical bore


@pytest.mark.parametrize(("rho_mm", "r_mm"), [(8.0, 5.0), (3.0, 5.0), (0.95, 1.0)])
def test_helical_bore_side_meets_the_ramp_and_bottom_cuts_the_pitch(rho_mm, r_mm):
    """A flat end mill of radius R on a helix of radius rho (a ring when rho > R, a full hole
    when rho < R: its core d < R - rho is only ever under the cutter) with pitch p into a
    20 mm block. In steady state (after the first turn):

    * the side edges meet only the helical ramp the previous turn left, ``p (1 - beta / pi)``
      at each tooth angle (:func:`ramp_depth`): no piece deeper than p (+ tolerance), where a
      straight view ahead sees the bore's full depth;
    * the bottom cuts the floor the previous sample left, one step's descent at every sample,
      p per turn; the floor left behind is the closed form :func:`floor_heights` to float32
      rounding.
    """
    rho, r, p = rho_mm * MM, r_mm * MM, 0.5 * MM
    stock = ZMap.box(0, 80 * MM, 0, 80 * MM, 0, TOP)
    pos, tan, t = helix(rho, p, 3.0)
    res = sweep(stock, FlatEndMill(r, 30 * MM), pos, tan, depth_step=0.01 * MM)
    tan_alpha = p / (2 * math.pi * rho)
    tol = (STEP + float(lookahead_reach(snap_angle(H, r), H, r, STEP))) * tan_alpha
    steady = t > 2 * math.pi + 0.5
    assert not res.in_air[steady].any()
    iv = res.intervals
    mine = steady[iv.sample]
    assert iv.axial_depth[mine].max() <= p + tol  # the block is 20 mm deep: no sliver of it
    for k in np.flatnonzero(mine):
        phi = np.linspace(iv.entry[k], iv.exit[k], 200)
        assert iv.axial_depth[k] <= ramp_depth(phi, rho, r, p).max() + tol + 1e-9
    # the front of the rim (90 +- 5 deg) always shows its ramp
    front = ramp_depth(np.radians(np.linspace(85.0, 95.0, 50)), rho, r, p).min()
    deepest = np.zeros(t.size)
    np.maximum.at(deepest, iv.sample, iv.axial_depth)
    assert np.all(deepest[steady] >= front - tol)
    # the bottom: one step's descent a sample, p a turn; a level tip would cut none
    descent = np.r_[0.0, -np.diff(pos[:, 2])]
    np.testing.assert_allclose(res.bottom_depth[steady], descent[steady], atol=5e-9)
    one_turn = (t > 2 * math.pi) & (t <= 4 * math.pi)
    assert abs(res.bottom_depth[one_turn].sum() - p) <= descent.max() + 1e-8
    want, clear = floor_heights(stock, rho, r, p, t[-1])
    np.testing.assert_allclose(stock.heights[clear], want[clear], atol=5e-9)


def test_helical_bore_entry_is_the_full_slot_then_the_pitch():
    """The first turn enters the block from its top: the ramp in front grows from 0 to the
    pitch; the deepest piece of any sample never exceeds the material above its tip."""
    rho, r, p = 3 * MM, 5 * MM, 0.5 * MM
    stock = ZMap.box(0, 80 * MM, 0, 80 * MM, 0, TOP)
    pos, tan, _ = helix(rho, p, 2.0)
    res = sweep(stock, FlatEndMill(r, 30 * MM), pos, tan)
    below = TOP - pos[:, 2]
    assert np.all(res.axial_depth <= np.minimum(below, p) + 1e-6 + 0.1 * MM)


# ------------------------------------------------------------- (2) ring on convex/concave arcs


def ring_cut(kind, rho, a, r=R):
    """A full circle of radius rho about O at constant radial depth a: round a boss of radius
    rho - R + a (convex: material on the inner, left side of the counter-clockwise path) or
    inside a hole of radius rho + R - a (concave: material outside, on the right). Returns
    the sweep, the polar angles and the boundary radius."""
    stock = ZMap.box(0, 80 * MM, 0, 80 * MM, 0, TOP)
    x, y = np.meshgrid(stock.x_centres - O[0], stock.y_centres - O[1], indexing="ij")
    d = np.hypot(x, y)
    r_m = rho - r + a if kind == "convex" else rho + r - a
    stock.heights[(d > r_m) if kind == "convex" else (d < r_m)] = 10 * MM
    pos, tan, t = helix(rho, 0.0, 1.0, z_top=12 * MM)
    return sweep(stock, FlatEndMill(r, 30 * MM), pos, tan), t, r_m


RINGS = [("convex", 15.0, 3.0), ("convex", 25.0, 6.0), ("concave", 15.0, 3.0),
         ("concave", 6.0, 2.0), ("concave", 2.0, 2.0)]


@pytest.mark.parametrize(("kind", "rho_mm", "a_mm"), RINGS)
def test_ring_on_an_arc_engages_as_two_circles_give(kind, rho_mm, a_mm):
    """Radial depth a on an arc of radius rho (Kardes & Altintas, J. Manuf. Sci. Eng. 129,
    2007, circular milling; the triangle of the arc's centre O, the cutter's centre and the
    boundary point where the rim crosses the material circle r_m):
    ``R cos(phi_b) = (R^2 + rho^2 - r_m^2) / (2 rho)``. Convex (boss r_m = rho - R + a, up
    milling): [0, phi_b], less than a straight cut's arccos(1 - a/R); concave (hole
    r_m = rho + R - a, down milling): [phi_b, pi], more than pi - arccos(1 - a/R). One
    interval, also on an arc tighter than the cutter (rho = 2 mm), where the cells met along
    the path spread unevenly over the teeth."""
    rho, a = rho_mm * MM, a_mm * MM
    res, t, r_m = ring_cut(kind, rho, a)
    phi_b = math.acos((R**2 + rho**2 - r_m**2) / (2 * rho * R))
    straight = math.acos(1 - a / R)
    steady = (t > 0.5) & (t < math.pi)  # clear of the disc the start cut
    e = res.engagement
    bound = float(angle_error_bound(phi_b, H, R, lateral=r_m / rho * H / math.sqrt(2)))
    if kind == "convex":
        got, other, want_other, straight_end = e.exit, e.entry, 0.0, straight
    else:
        got, other, want_other, straight_end = e.entry, e.exit, math.pi, math.pi - straight
    assert not res.in_air[steady].any()
    assert np.all(np.abs(got[steady] - phi_b) <= bound)
    assert np.all(other[steady] == want_other)
    assert abs(straight_end - phi_b) > 2 * bound  # the arc's engagement, not a line's
    assert np.all(res.interval_summary()[0][steady] == 1)
    np.testing.assert_allclose(res.axial_depth[steady], TOP - 12 * MM, atol=1e-6)


# ----------------------------------------------------------------- (3) rising out of a hole


def _bored_hole(rho, r, p, turns):
    """A hole from a helix down ``turns`` turns and one flat turn at the bottom."""
    stock = ZMap.box(0, 80 * MM, 0, 80 * MM, 0, TOP)
    down, tan_d, _ = helix(rho, p, turns)
    flat, tan_f, _ = helix(rho, 0.0, 1.0, z_top=down[-1, 2])
    pos, tan = np.concatenate([down, flat[1:]]), np.concatenate([tan_d, tan_f[1:]])
    sweep(stock, FlatEndMill(r, 30 * MM), pos, tan)
    return stock, pos[-1]


@pytest.mark.parametrize(("rho_mm", "r_mm"), [(3.0, 5.0), (8.0, 5.0)])
def test_a_helix_rising_out_of_its_hole_takes_no_material(rho_mm, r_mm):
    """Back up the helix that bored the hole (a ring when rho > R, a full hole when rho < R):
    the cutter stays where it has cut; its bottom rises, so it takes no material with it, and
    its side meets none (a straight view ahead would see the bore's wall, its full depth)."""
    rho, r, p = rho_mm * MM, r_mm * MM, 0.5 * MM
    stock, end = _bored_hole(rho, r, p, 3.0)
    before = stock.heights.copy()
    up, tan, _ = helix(rho, -p, 3.0, z_top=end[2])  # rising
    res = sweep(stock, FlatEndMill(r, 30 * MM), up, tan)
    assert res.in_air.all() and not res.bottom_depth.any() and not res.swept_depth.any()
    np.testing.assert_array_equal(stock.heights, before)


def test_a_straight_ramp_rising_out_of_a_hole_takes_no_material():
    """From the bottom of a full hole (rho < R) up a straight ramp towards its axis and out
    above the top: no engagement, no bottom; the same ramp out through the wall cuts it (a
    ring, rho > R, would keep its core: a ramp towards the axis would cut that)."""
    rho, r, p = 3 * MM, 5 * MM, 0.5 * MM
    tool = FlatEndMill(r, 30 * MM)
    stock, end = _bored_hole(rho, r, p, 3.0)
    n = 200
    s = np.linspace(0.0, 1.0, n)[:, None]
    centre = np.array([O[0], O[1], TOP + 2 * MM])
    res = sweep(stock, tool, end + (centre - end) * s, np.tile(centre - end, (n, 1)))
    assert res.in_air.all() and not res.bottom_depth.any() and not res.swept_depth.any()
    wall = np.array([O[0] + 3 * (rho + r), O[1], TOP + 2 * MM])
    hit = sweep(stock.copy(), tool, end + (wall - end) * s, np.tile(wall - end, (n, 1)))
    assert (~hit.in_air).any() and hit.swept_depth.max() > 1 * MM
    assert not hit.bottom_depth.any()  # rising: the bottom takes nothing


# ------------------------------------------------------------------- (4) inside corner arc


@pytest.mark.parametrize(("b_mm", "r_mm"), CORNERS)
def test_inside_corner_arc_within_the_cell_bound(b_mm, r_mm):
    """An inside corner arc (pocket wall rounded to r_m, tool on r_c = r_m - R + b, cutting
    clockwise with the wall on its left): in the middle third of the arc the exit angle is
    arccos(kappa) of two circles (:func:`tests.process.test_stock.circle_engagement_cos`),
    within the cell bound alone: the lookahead follows the arc, so it adds no error (a
    straight view ahead drifts into the wall ahead of the turn)."""
    _, _, res, middle, r_c, r_m = inside_corner_cut(b_mm, r_mm)
    expected = math.acos(circle_engagement_cos(r_c, r_m))
    bound = float(angle_error_bound(expected, H, R, lateral=r_m / r_c * H / math.sqrt(2)))
    assert not res.in_air[middle].any()
    assert np.all(res.engagement.entry[middle] == 0.0)
    assert np.all(np.abs(res.engagement.exit[middle] - expected) <= bound)
    assert expected - math.acos(1 - b_mm * MM / R) > bound  # the corner's rise is resolved


# ------------------------------------------------------------------ (5) rapids and crashes


def test_swept_volume_of_a_retract_and_of_a_sideways_move_in_a_bore():
    """In a bored hole a move straight up sweeps nothing; a move sideways at depth cuts the
    wall (its swept volume meets material: what a rapid must not do)."""
    rho, r, p = 3 * MM, 5 * MM, 0.5 * MM
    stock, end = _bored_hole(rho, r, p, 3.0)
    tool = FlatEndMill(r, 30 * MM)
    n = 100
    up = end + np.linspace(0.0, 1.0, n)[:, None] * [0.0, 0.0, 25 * MM]
    res = sweep(stock.copy(), tool, up, np.tile([1.0, 0.0, 1.0], (n, 1)))
    assert not res.swept_depth.any() and not res.bottom_depth.any()
    side = end + np.linspace(0.0, 1.0, n)[:, None] * [10 * MM, 0.0, 0.0]
    res = sweep(stock.copy(), tool, side, np.tile([1.0, 0.0, 0.0], (n, 1)))
    assert res.swept_depth.max() == pytest.approx(TOP - end[2], abs=1e-6)


BORE = """G21 G17 G90 G94
T1 M6
S2500 M3
G0 X53. Y40. Z5.
G0 Z1.
G1 Z0. F300.
G3 X47. Y40. Z-0.5 I-3. J0. F254.
G3 X53. Y40. Z-1. I3. J0.
G3 X47. Y40. Z-1.5 I-3. J0.
G3 X53. Y40. Z-2. I3. J0.
G3 X47. Y40. I-3. J0.
G3 X53. Y40. I3. J0.
{retract}
M30
"""


def _bore_front(quick_scenario, tmp_path, retract: str):
    prog = tmp_path / "bore.nc"
    prog.write_text(BORE.format(retract=retract))
    path = quick_scenario("profile", path__file=str(prog), path__spacing_mm=0.25,
                          stock__box_mm=[20.0, 10.0, -20.0, 80.0, 70.0, 0.0])
    sc, base = load_scenario(path)
    return prepare_front(sc, base, progress=lambda _m: None)


def test_a_retract_straight_up_out_of_a_bore_is_no_crash(quick_scenario, tmp_path):
    """A helical bore (R = 9.525 mm on a 3 mm helix, 0.5 mm a half turn) then ``G0 Z25.``:
    the rapid's swept volume is the bore it leaves, so it is planned; the helix engages
    at most its pitch, 1 mm a turn, with its side, and the rapid carries no engagement."""
    front = _bore_front(quick_scenario, tmp_path, "G0 Z25.")
    moves, s = front.path.moves, front.samples.s
    cat = moves.category[moves.index_at(s)]
    found = front.process.material.found
    assert found.axial_depth[cat == "cut"].max() <= 1.0 * MM + 0.05 * MM
    assert found.axial_depth[cat == "cut"].max() > 0.5 * MM
    assert found.in_air[cat == "rapid"].all()
    assert not found.swept_depth[(cat == "rapid") & (front.samples.position[:, 2] > -1.9 * MM)
                                 & (front.samples.position[:, 2] < 0.0)].any()


def test_a_rapid_sideways_through_the_bore_wall_is_still_a_crash(quick_scenario, tmp_path):
    """The same bore left by ``G0 X80.`` at its bottom: the rapid sweeps through the wall, 2 mm
    of material above its tip, and is refused naming the line."""
    with pytest.raises(InputError, match=r"bore.nc line 13: a rapid \(G0\) meets material.*"
                                         r"its swept volume cuts 2 mm of material"):
        _bore_front(quick_scenario, tmp_path, "G0 X80.")

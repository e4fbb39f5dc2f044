"""Surface location errors (walls and floor) against closed forms and brute force (issue 33).

Every reference here is computed in the test from the force model's formulas (a slice of
height da at immersion theta: h = c sin theta, dFt = da (Ktc h + Kte), ...,
dFx = -dFt cos - dFr sin, dFy = dFt sin - dFr cos, dFz = dFa), not from feedopt's force code.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.process.forces import CuttingCoefficients, Engagement, Tool
from feedopt.schedule.deflection import DeflectionModel, feed_frames
from feedopt.schedule.surface import (
    floor_feed_per_tooth,
    surface_errors,
    surface_feed_bound,
    wall_feed_per_tooth,
)

D = 19.05e-3
R = D / 2
RPM = 2500.0
COEFFS = CuttingCoefficients(ktc=700e6, krc=250e6, kac=-120e6, kte=25e3, kre=30e3, kae=-5e3)
# Full, symmetric positive definite compliance (eigenvalues 1.2e-7 .. 3.2e-7 m/N).
C_FULL = np.array([[2.0, 0.5, 0.3], [0.5, 3.0, -0.4], [0.3, -0.4, 1.5]]) * 1e-7
DOWN_HALF = math.pi - math.acos(1 - 0.5)  # down milling, ae = R / 2: entry 2 pi / 3
DOWN_DEEP = math.pi - math.acos(1 - 1.8)  # down milling, ae = 0.9 D: entry 0.6435
UP_HALF = math.acos(1 - 0.5)  # up milling, ae = R / 2: exit pi / 3
UP_DEEP = math.acos(1 - 1.8)  # up milling, ae = 0.9 D: exit 2.4981


def _tool(teeth: int = 2, helix_deg: float = 0.0) -> Tool:
    return Tool("test", D, teeth, math.radians(helix_deg), 30e-3)


def _model(tool: Tool, entry, exit_, depth, frames=None, compliance=None, slices: int = 20,
           angles=None) -> DeflectionModel:
    entry, exit_ = np.atleast_1d(np.asarray(entry, float)), np.atleast_1d(np.asarray(exit_, float))
    n = entry.size
    return DeflectionModel(
        tool=tool, coefficients=COEFFS,
        engagement=Engagement(entry, exit_, np.broadcast_to(np.asarray(depth, float), (n,))),
        angles=(np.deg2rad(np.arange(0, 180, 1.0)) if angles is None else angles),
        frames=np.broadcast_to(np.eye(3), (n, 3, 3)).copy() if frames is None else frames,
        compliance=(np.broadcast_to(C_FULL, (n, 3, 3)).copy() if compliance is None
                    else compliance),
        rpm=RPM, axial_slices=slices)


def _feed(c: float, tool: Tool) -> float:
    """Path feed [m/s] of feed per tooth c [m]: v = c N rpm / 60."""
    return c * tool.teeth * RPM / 60.0


def _slice_force(theta: float, c: float, da: float) -> np.ndarray:
    """Force on the tool of one slice at immersion theta (force-model frame), closed form."""
    h = c * math.sin(theta)
    ft = da * (COEFFS.ktc * h + COEFFS.kte)
    fr = da * (COEFFS.krc * h + COEFFS.kre)
    fa = da * (COEFFS.kac * h + COEFFS.kae)
    return np.array([-ft * math.cos(theta) - fr * math.sin(theta),
                     ft * math.sin(theta) - fr * math.cos(theta), fa])


def _brute_force(tool: Tool, entry: float, exit_: float, a: float, slices: int, phi: float,
                 c: float) -> np.ndarray:
    """Algorithm 1 by loops: every tooth k and slice i with entry <= theta < exit."""
    rate = 2.0 * math.tan(tool.helix) / tool.diameter
    da = a / slices
    f = np.zeros(3)
    for k in range(tool.teeth):
        for i in range(slices):
            theta = (phi + k * 2.0 * math.pi / tool.teeth - rate * (i + 0.5) * da) % (2 * math.pi)
            if entry <= theta < exit_:
                f += _slice_force(theta, c, da)
    return f


# --- 1, 2: straight teeth, closed form at the wall instants -----------------------------------
# Each case: teeth, entry, exit, immersion angles of the teeth in the cut when tooth 1 is at the
# left wall (phi = 0+) and at the right wall (phi = pi-), None where that wall is not generated.
# Tooth k (k = 0 .. N-1) is at phi + k 2 pi / N. Assumption (module and critical_angles
# docstrings, half-open test [entry, exit), one-sided limits): at the left wall the forces are
# the limit phi -> 0+, so in a slot the tooth opposite (at pi, h = 0) has just left and does NOT
# count; at the right wall (phi -> pi-) the tooth opposite (at 2 pi-) has not yet entered.
WALL_CASES = {
    # down milling, ae = R/2, 2 teeth: tooth 2 (at 0- / 2 pi-) is outside [2 pi/3, pi)
    "down_half_2": (2, DOWN_HALF, math.pi, None, [math.pi]),
    # down milling, ae = 0.9 D, 4 teeth: at phi = pi- tooth 4 is at pi/2, in the cut
    "down_deep_4": (4, DOWN_DEEP, math.pi, None, [math.pi, math.pi / 2]),
    # up milling, ae = R/2, 2 teeth: only tooth 1 (at 0) in [0, pi/3)
    "up_half_2": (2, 0.0, UP_HALF, [0.0], None),
    # up milling, ae = 0.9 D, 4 teeth: tooth 2 at pi/2 is in [0, 2.498)
    "up_deep_4": (4, 0.0, UP_DEEP, [0.0, math.pi / 2], None),
    # slot, 2 teeth: one tooth at a time (the opposite one is exactly at the other boundary)
    "slot_2": (2, 0.0, math.pi, [0.0], [math.pi]),
    # slot, 3 teeth: tooth 2 at 2 pi/3 at the left wall, tooth 3 at pi/3 at the right wall
    "slot_3": (3, 0.0, math.pi, [0.0, 2 * math.pi / 3], [math.pi, math.pi / 3]),
}


def _closed_form_wall(thetas, c: float, a: float, sign: float) -> float:
    """sign * e_y . C F with F the sum of the straight teeth at immersions ``thetas``."""
    f = sum(_slice_force(t, c, a) for t in thetas)
    return sign * (C_FULL @ f)[1]


@pytest.mark.parametrize("case", list(WALL_CASES))
def test_straight_tooth_walls_equal_closed_form(case: str) -> None:
    teeth, entry, exit_, left, right = WALL_CASES[case]
    tool, a = _tool(teeth), 4e-3
    model = _model(tool, [entry, entry], [exit_, exit_], a)
    cs = np.array([0.05e-3, 0.2e-3])  # two feeds: slope and intercept
    err = surface_errors(model, _feed(cs, tool))[0]
    assert err.wall.shape == (2, 2, 1)
    np.testing.assert_allclose(err.heights, a / 2)  # straight teeth: one point, mid-height
    for side, thetas, sign in ((0, left, -1.0), (1, right, 1.0)):
        got = err.wall[:, side, 0]
        if thetas is None:
            assert np.all(np.isnan(got))
        else:
            want = [_closed_form_wall(thetas, c, a, sign) for c in cs]
            # the module evaluates the exit at pi - 1e-9 rad: ~1e-9 relative from the limit
            np.testing.assert_allclose(got, want, rtol=1e-7, atol=0)


def test_down_milling_half_immersion_right_wall_is_edge_force_only() -> None:
    """The closed form spelled out: at pi only the exiting tooth, with h = 0, so the right
    wall is e_y . C a (Kte, Kre, Kae) at every feed."""
    tool, a = _tool(2), 4e-3
    model = _model(tool, [DOWN_HALF] * 2, [math.pi] * 2, a)
    err = surface_errors(model, _feed(np.array([0.05e-3, 0.3e-3]), tool))[0]
    want = (C_FULL @ (a * np.array([COEFFS.kte, COEFFS.kre, COEFFS.kae])))[1]
    np.testing.assert_allclose(err.wall[:, 1, 0], want, rtol=1e-7)


# --- 3: helix, brute force per wall height -----------------------------------------------------
@pytest.mark.parametrize(("entry", "exit_"), [(0.0, math.pi), (DOWN_HALF, math.pi),
                                              (0.0, UP_HALF)], ids=["slot", "down", "up"])
def test_helix_walls_equal_brute_force_per_height(entry: float, exit_: float) -> None:
    tool, a, slices, c = _tool(2, 30.0), 10e-3, 20, 0.12e-3
    frames = feed_frames(np.array([[0.6, 0.8, 0.1]]), np.array([[0.1, -0.2, 1.0]]))
    model = _model(tool, entry, exit_, a, frames=frames, slices=slices)
    err = surface_errors(model, np.array([_feed(c, tool)]))[0]
    np.testing.assert_allclose(err.heights[0], (np.arange(slices) + 0.5) * a / slices,
                               rtol=1e-14)
    cr, y = C_FULL @ frames[0], frames[0][:, 1]  # wall normal: the frame's y in the base frame
    rate = 2.0 * math.tan(tool.helix) / D
    for j in range(slices):
        lag = rate * (j + 0.5) * a / slices
        # left wall: limit from the right (1e-12 rad into the cut), right wall: pi - 1e-9
        for side, phi_w, sign, present in ((0, 1e-12, -1.0, entry == 0.0),
                                           (1, math.pi - 1e-9, 1.0, exit_ == math.pi)):
            got = err.wall[0, side, j]
            if not present:
                assert np.isnan(got)
                continue
            f = _brute_force(tool, entry, exit_, a, slices, phi_w + lag, c)
            assert got == pytest.approx(sign * y @ (cr @ f), rel=1e-9, abs=1e-15)


# --- 4: floor -----------------------------------------------------------------------------------
def _floor_brute_force(tool, entry, exit_, a, slices, c, grid, compliance):
    """min over ``grid`` and both one-sided limits of every slice entry / exit of e_z . C F."""
    rate = 2.0 * math.tan(tool.helix) / D
    lags = rate * (np.arange(slices) + 0.5) * a / slices
    eps = 1e-10  # at jumps: just inside and just outside the cut
    jumps = np.concatenate([entry + lags + eps, entry + lags - eps,
                            exit_ + lags - eps, exit_ + lags + eps])
    phis = np.concatenate([grid, np.mod(jumps, tool.pitch)])
    return min((compliance @ _brute_force(tool, entry, exit_, a, slices, p, c))[2] for p in phis)


FLOOR_CASES = [(2, 0.0, 0.0, math.pi), (2, 0.0, DOWN_HALF, math.pi), (2, 0.0, 0.0, UP_HALF),
               (3, 0.0, 0.0, math.pi), (4, 0.0, DOWN_DEEP, math.pi),
               (2, 30.0, 0.0, math.pi), (2, 30.0, DOWN_HALF, math.pi),
               (4, 30.0, DOWN_DEEP, math.pi)]


@pytest.mark.parametrize(("teeth", "helix", "entry", "exit_"), FLOOR_CASES)
def test_floor_equals_brute_force_min_on_the_same_grid(teeth, helix, entry, exit_) -> None:
    """Model grid = 3600 angles per pitch; the brute force takes the same grid plus both sides
    of every jump: equal to 1e-9 (the deepest point here is never on the out-of-cut side)."""
    tool, a, c = _tool(teeth, helix), 8e-3, 0.1e-3
    slices = 10 if helix else 1
    grid = np.arange(3600) * (tool.pitch / 3600)
    model = _model(tool, entry, exit_, a, slices=slices, angles=grid)
    got = surface_errors(model, np.array([_feed(c, tool)]))[0].floor[0]
    want = _floor_brute_force(tool, entry, exit_, a, slices, c, grid, C_FULL)
    assert got == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize(("teeth", "helix", "entry", "exit_"), FLOOR_CASES)
def test_floor_on_a_coarse_grid_is_close_to_the_fine_minimum(teeth, helix, entry, exit_) -> None:
    """Model grid 1 deg: never deeper than the fine (3600 per pitch + jumps) minimum, and
    within 1e-4 relative of it (the interior minima are missed by O(step^2))."""
    tool, a, c = _tool(teeth, helix), 8e-3, 0.1e-3
    slices = 10 if helix else 1
    model = _model(tool, entry, exit_, a, slices=slices)
    got = surface_errors(model, np.array([_feed(c, tool)]))[0].floor[0]
    fine = _floor_brute_force(tool, entry, exit_, a, slices, c,
                              np.arange(3600) * (tool.pitch / 3600), C_FULL)
    assert got >= fine - 1e-7 * abs(fine)
    assert got == pytest.approx(fine, rel=1e-4)


# The axial coupling of this compliance makes the entering tooth (thick chip at 0.6435 rad in
# down milling) push the tool up: the deepest floor pass is just BEFORE a tooth enters, the
# out-of-cut side of the jump, which the module never evaluates (its critical angles are on the
# in-cut side only), so it reports a shallower floor by ~ one grid step of force change.
C_COUPLED = np.array([[7.3, -3.3, -2.0], [-3.3, 2.3, 0.45], [-2.0, 0.45, 1.7]]) * 1e-7


def test_floor_includes_the_out_of_cut_side_of_a_jump() -> None:
    tool, a, c = _tool(3), 8e-3, 0.1e-3
    comp = C_COUPLED[None]
    model = _model(tool, DOWN_DEEP, math.pi, a, compliance=comp.copy(), slices=1)
    got = surface_errors(model, np.array([_feed(c, tool)]))[0].floor[0]
    want = _floor_brute_force(tool, DOWN_DEEP, math.pi, a, 1, c,
                              np.arange(3600) * (tool.pitch / 3600), C_COUPLED)
    assert got == pytest.approx(want, rel=1e-5)


# --- 5: the closed-form feed bounds of the lines, against brute force ---------------------------
def _random_lines(seed: int, shape: tuple[int, ...]):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=shape) * rng.choice([0.0, 1.0], size=shape, p=[0.15, 0.85])
    b = rng.normal(size=shape) * 0.5
    return a, b, float(rng.uniform(0.2, 1.5)), rng


def _check_bound(c_star: float, ok, rows_nan: bool) -> None:
    """``ok(c)`` is the brute-force feasibility of one sample at feed per tooth c."""
    if rows_nan:  # no cut / no wall: no bound
        assert c_star == np.inf
        return
    if c_star == np.inf:
        assert all(ok(c) for c in np.linspace(0.0, 50.0, 2001))
        return
    if c_star == -1.0:
        assert not ok(0.0)
        return
    assert c_star >= 0.0
    assert all(ok(c) for c in np.linspace(0.0, c_star, 2001))
    assert not ok(c_star * (1 + 1e-6) + 1e-12)


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 4), m=st.integers(1, 8))
def test_floor_feed_per_tooth_is_the_brute_force_bound(seed: int, k: int, m: int) -> None:
    a, b, limit, rng = _random_lines(seed, (k, m))
    idle = rng.random(k) < 0.2
    a[idle], b[idle] = np.nan, np.nan
    got = floor_feed_per_tooth(a, b, limit)
    assert got.shape == (k,)
    tol = limit * (1 + 1e-12)
    for i in range(k):
        def ok(c, i=i):
            return abs(np.min(c * a[i] + b[i])) <= tol
        _check_bound(got[i], ok, idle[i])


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 4), h=st.integers(1, 5))
def test_wall_feed_per_tooth_is_the_brute_force_bound(seed: int, k: int, h: int) -> None:
    a, b, limit, rng = _random_lines(seed, (k, 2, h))
    missing = rng.random((k, 2, 1)) < 0.4  # a side not generated: all its heights NaN
    missing = np.broadcast_to(missing, a.shape)
    a, b = np.where(missing, np.nan, a), np.where(missing, np.nan, b)
    got = wall_feed_per_tooth(a, b, limit)
    assert got.shape == (k,)
    tol = limit * (1 + 1e-12)
    for i in range(k):
        keep = ~np.isnan(a[i])
        def ok(c, i=i, keep=keep):
            return bool(np.all(np.abs(c * a[i][keep] + b[i][keep]) <= tol))
        _check_bound(got[i], ok, bool(np.all(np.isnan(a[i]))))


def test_floor_feed_per_tooth_zero_when_limit_reached_exactly_at_zero_feed() -> None:
    """Lines 1 + c and 2 - c, limit 1: min = 1 at c = 0 (allowed), 1 + c > 1 just after, so
    the largest feasible feed is 0, not 'already broken' (-1)."""
    got = floor_feed_per_tooth(np.array([[1.0, -1.0]]), np.array([[1.0, 2.0]]), 1.0)
    assert got[0] == 0.0


# --- 6: end to end -------------------------------------------------------------------------------
def test_surface_feed_bound_is_tight_under_replay() -> None:
    rng = np.random.default_rng(7)
    tool = _tool(3, 30.0)
    entry = np.array([0.0, DOWN_HALF, 0.0, DOWN_DEEP, 0.0, 0.3])
    exit_ = np.array([math.pi, math.pi, UP_HALF, math.pi, UP_DEEP, 0.3])  # last: not cutting
    depth = np.array([6e-3, 10e-3, 8e-3, 4e-3, 12e-3, 5e-3])
    n = entry.size
    m = rng.normal(size=(n, 3, 3))
    comp = (m @ np.swapaxes(m, 1, 2) + 0.5 * np.eye(3)) * 1e-7
    frames = feed_frames(rng.normal(size=(n, 3)), np.array([0.0, 0.0, 1.0]) + 0.2 * rng.normal(
        size=(n, 3)))
    model = _model(tool, entry, exit_, depth, frames=frames, compliance=comp, slices=10)
    zero = surface_feed_bound(model, np.inf, np.inf)
    assert np.all(np.isinf(zero.v_wall)) and np.all(np.isinf(zero.v_floor))
    wall_limit = 2.0 * np.nanmax(zero.zero_feed_wall)
    floor_limit = 2.0 * np.nanmax(np.abs(zero.zero_feed_floor))
    bound = surface_feed_bound(model, wall_limit, floor_limit)
    assert np.isinf(bound.v_wall[-1]) and np.isinf(bound.v_floor[-1])
    assert np.all(np.isfinite(bound.v_wall[:-1])) and np.all(bound.v_wall[:-1] > 0)
    v = np.minimum(bound.v_wall, bound.v_floor)
    v[~np.isfinite(v)] = 0.0
    at_v, at_wall, at_floor = surface_errors(
        model, np.stack([v, np.where(np.isfinite(bound.v_wall), bound.v_wall, 0.0),
                         np.where(np.isfinite(bound.v_floor), bound.v_floor, 0.0)]))
    worst = at_v.worst_wall()
    assert np.all(worst[:-1] <= wall_limit * (1 + 1e-9))
    assert np.all(np.abs(at_v.floor[:-1]) <= floor_limit * (1 + 1e-9))
    assert np.isnan(worst[-1]) and np.isnan(at_v.floor[-1])
    # each bound is reached exactly at its own feed, and the tighter one at the combined feed
    np.testing.assert_allclose(at_wall.worst_wall()[:-1], wall_limit, rtol=1e-9)
    finite_floor = np.isfinite(bound.v_floor)
    assert finite_floor.any()
    np.testing.assert_allclose(np.abs(at_floor.floor[finite_floor]), floor_limit, rtol=1e-9)
    active = np.where(bound.v_wall[:-1] <= bound.v_floor[:-1], worst[:-1] / wall_limit,
                      np.abs(at_v.floor[:-1]) / floor_limit)
    np.testing.assert_allclose(active, 1.0, rtol=1e-9)


def test_no_sample_measured_gives_empty_errors_not_a_crash():
    """An air cut has no sample where the part is measured (issue 33, found by the stock
    scenarios' air-cut test)."""
    from feedopt.schedule.surface import SurfaceErrors

    empty = SurfaceErrors(np.zeros(0, dtype=np.intp), np.zeros((0, 2, 20)), np.zeros((0, 20)),
                          np.zeros(0))
    assert empty.worst_wall().shape == (0,) and empty.describe() == "no surface cut"

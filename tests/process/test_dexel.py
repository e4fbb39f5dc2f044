"""Tri-dexel stock (feedopt.process.dexel) against closed-form volumes and point sets.

Removal volumes are within ~2 % x (h / 1 mm) of the analytic ones and the error falls as h
halves (measured at h = 1, 0.5, 0.25 mm: vertical flat 1.3, 0.42, 0.28 %; tilted flat 0.68,
0.23, 0.08 %; tilted ball 0.54, 0.14, 0.085 %).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.process.cutter import Profile
from feedopt.process.dexel import TriDexel, ray_tool_intervals, tool_solid

MM = 1e-3
R = 5 * MM
FLAT = Profile(R, 0.0, math.pi / 2)
BALL = Profile(0.0, R, math.pi / 2)
RC = 2 * MM
BULL = Profile(R - RC, RC, math.pi / 2)
LO, HI = np.array([0.0, 0.0, 0.0]), np.array([40 * MM, 40 * MM, 20 * MM])
TOP = HI[2]


def axis_about_y(angle: float) -> np.ndarray:
    return np.array([math.sin(angle), 0.0, math.cos(angle)])


def in_tool(points, tip, k, profile, height):
    """Independent point-in-cutter test: 0 <= w <= H, rho <= R(H), w >= height_at_radius."""
    d = points - tip
    w = np.sum(d * k, axis=-1)
    rho = np.linalg.norm(d - w[:, None] * k, axis=1)
    r_top = float(profile.at_length(profile.length_to_height(height))[0])
    return (w >= 0) & (w <= height) & (rho <= r_top) & (w >= profile.height_at_radius(rho))


# ---------------------------------------------------------------------------- the box
def test_box_volume_and_contains():
    """A box whose sides are whole numbers of cells: every grid's volume is exact; points
    more than 0.62 h from the faces are classified right, points outside the grid are not
    material."""
    h = 0.5 * MM
    box = TriDexel.box(LO, HI, h)
    exact = float(np.prod(HI - LO))
    assert np.allclose(box.volumes(), exact, rtol=1e-12)
    rng = np.random.default_rng(3)
    pts = rng.uniform(LO - 5 * MM, HI + 5 * MM, (20000, 3))
    inside = np.all((pts > LO) & (pts < HI), axis=1)
    gap = np.min(np.minimum(np.abs(pts - LO), np.abs(pts - HI)), axis=1)
    far = gap > 0.62 * h
    for rule in ("majority", "any", "z"):
        assert np.array_equal(box.contains(pts, rule)[far], inside[far])


def test_box_not_a_whole_number_of_cells():
    """Sides of 10.3 and 7.7 cells: the volume is the cells whose rays fall inside (the
    midpoint rule), within a cell layer of the exact one."""
    h = 1.0 * MM
    box = TriDexel.box([0, 0, 0], [10.3 * MM, 7.7 * MM, 5 * MM], h)
    exact = 10.3 * 7.7 * 5 * MM**3
    assert abs(box.volume() - exact) < h * (10.3 * 7.7 + 10.3 * 5 + 7.7 * 5) * MM**2


def test_spacing_and_size_checks():
    with pytest.raises(InputError):
        TriDexel.box(LO, HI, 0.0)
    with pytest.raises(InputError):
        TriDexel.box(HI, LO, MM)
    with pytest.raises(InputError):
        TriDexel.box([0, 0, 0], [10.0, 10.0, 10.0], 1e-4)


# ------------------------------------------------------------------- one-pose removals
def _removed(profile, tip, k, h):
    box = TriDexel.box(LO, HI, h)
    before = box.volume()
    box.remove_tool(tip, k, profile, 30 * MM)
    return before - box.volume(), box


def _cases():
    psi = math.radians(20)
    k = axis_about_y(psi)
    tip_t = np.array([20 * MM, 20 * MM, 10 * MM])
    centre = tip_t + R * k
    vertical_tip = np.array([20 * MM, 20 * MM, 12 * MM])
    return {
        # pi R^2 times the length below the top face
        "flat vertical": (FLAT, vertical_tip, np.array([0, 0, 1.0]),
                          math.pi * R**2 * (TOP - vertical_tip[2])),
        # a cylinder cut by an oblique plane: pi R^2 times its axis' length below the plane
        "flat tilted": (FLAT, tip_t, k, math.pi * R**2 * (TOP - tip_t[2]) / math.cos(psi)),
        # half ball plus the cylinder from its centre to the plane
        "ball tilted": (BALL, tip_t, k, 2 / 3 * math.pi * R**3
                        + math.pi * R**2 * (TOP - centre[2]) / math.cos(psi)),
        # Pappus on the corner: pi (r0^2 rc + pi r0 rc^2 / 2 + 2 rc^3 / 3), then a cylinder
        "bull vertical": (BULL, vertical_tip, np.array([0, 0, 1.0]),
                          math.pi * ((R - RC) ** 2 * RC + math.pi * (R - RC) * RC**2 / 2
                                     + 2 * RC**3 / 3) + math.pi * R**2 * (TOP - 12 * MM - RC)),
    }


@pytest.mark.parametrize("name", list(_cases()))
def test_removal_volume_converges(name):
    """The volume one pose removes from the box, against its closed form, at h = 1, 0.5 and
    0.25 mm: within 2 % x (h / mm) and falling as h shrinks."""
    profile, tip, k, exact = _cases()[name]
    errors = []
    for h in (1.0 * MM, 0.5 * MM, 0.25 * MM):
        removed, _ = _removed(profile, tip, k, h)
        errors.append(abs(removed / exact - 1))
        assert errors[-1] < 0.02 * h / MM, (h, errors)
    assert errors[2] < 0.5 * errors[0], errors


def test_removal_leaves_points_right():
    """After the tilted ball, beyond the 0.62 h band of contains() about the tool's surface:
    points inside the tool are not material, points of the box outside it are."""
    profile, tip, k, _ = _cases()["ball tilted"]
    h = 0.5 * MM
    _, box = _removed(profile, tip, k, h)
    pts = np.random.default_rng(5).uniform(LO + h, HI - h, (30000, 3))
    hole = in_tool(pts, tip, k, profile, 30 * MM)
    deep, grown = hole.copy(), hole.copy()  # the tool shrunk and grown by 0.62 h (sampled)
    for shift in np.random.default_rng(6).normal(size=(40, 3)):
        moved = in_tool(pts + 0.62 * h * shift / np.linalg.norm(shift), tip, k, profile,
                        30 * MM)
        deep &= moved
        grown |= moved
    assert deep.sum() > 400 and (~grown).sum() > 10000
    material = box.contains(pts)
    assert not np.any(material[deep])
    assert np.all(material[~grown])


def test_through_hole_splits_rays():
    """A flat end mill lying along y through the box: x- and z-rays get two intervals, the
    volume drops by pi R^2 times the box's depth in y."""
    h = 0.5 * MM
    box = TriDexel.box(LO, HI, h)
    before = box.volume()
    box.remove_tool([20 * MM, -1 * MM, 10 * MM], [0, 1, 0], FLAT, 60 * MM)
    assert box.grids[0].intervals.shape[1] == 2 and box.grids[2].intervals.shape[1] == 2
    assert abs((before - box.volume()) / (math.pi * R**2 * 40 * MM) - 1) < 0.01
    assert box.contains([[20 * MM, 20 * MM, 10 * MM]]).tolist() == [False]
    assert box.contains([[20 * MM, 20 * MM, 17 * MM], [20 * MM, 20 * MM, 3 * MM]]).all()


# ----------------------------------------------------------------------- swept removals
@pytest.mark.parametrize(("profile", "tilt_deg"), [(FLAT, 0.0), (FLAT, 25.0), (BALL, 0.0),
                                                   (BALL, 25.0)])
def test_swept_removal_along_a_line(profile, tilt_deg):
    """A tool tilted by beta about x, swept 20 mm along x: the sweep of a convex body along a
    segment is the body plus the segment times its projection along it (both clipped to the
    box top, which the horizontal motion commutes with). Projection: 2 R times the axis
    length below the top (flat), plus the half disc pi R^2 / 2 (ball)."""
    beta, h = math.radians(tilt_deg), 0.25 * MM
    k = np.array([0.0, -math.sin(beta), math.cos(beta)])
    tip0 = np.array([10 * MM, 20 * MM, 12 * MM])
    ball = profile is BALL
    below = (TOP - tip0[2] - (R * math.cos(beta) if ball else 0.0)) / math.cos(beta)
    body = math.pi * R**2 * below + (2 / 3 * math.pi * R**3 if ball else 0.0)
    shadow = 2 * R * below + (math.pi * R**2 / 2 if ball else 0.0)
    box = TriDexel.box(LO, HI, h)
    before = box.volume()
    poses = box.sweep_tool([tip0, tip0 + [20 * MM, 0, 0]], [k, k], profile, 30 * MM)
    assert poses == 1 + math.ceil(20 * MM / (h / 2))
    exact = body + 20 * MM * shadow
    assert abs((before - box.volume()) / exact - 1) < 0.005


def test_five_axis_sweep_covers_every_pose_between():
    """Tip moving and axis turning by 40 deg: every point of the cutter at poses between the
    given ones (slerped) is gone after the sweep, except within the 0.62 h band of the
    contains() look-up."""
    h = 0.5 * MM
    box = TriDexel.box(LO, HI, h)
    tips = np.array([[12 * MM, 20 * MM, 8 * MM], [28 * MM, 22 * MM, 10 * MM]])
    axes = np.array([axis_about_y(-0.35), axis_about_y(0.35)])
    box.sweep_tool(tips, axes, BALL, 30 * MM)
    rng = np.random.default_rng(8)
    for s in np.linspace(0, 1, 13):
        tip = tips[0] + s * (tips[1] - tips[0])
        k = axis_about_y(-0.35 + 0.7 * s)
        pts = tip + rng.uniform(-R, R, (4000, 3)) + rng.uniform(0, 12 * MM, (4000, 1)) * k
        inner = in_tool(pts, tip, k, BALL, 30 * MM)
        shrunk = inner.copy()  # points at least 0.62 h inside the cutter
        for shift in rng.normal(size=(30, 3)):
            shrunk &= in_tool(pts + 0.62 * h * shift / np.linalg.norm(shift), tip, k, BALL,
                              30 * MM)
        assert not np.any(box.contains(pts)[shrunk])


# ------------------------------------------------------------------- ray intersections
@settings(max_examples=60, deadline=None)
@given(profile=st.sampled_from(["flat", "ball", "bull"]), axis=st.integers(0, 2),
       seed=st.integers(0, 2**31 - 1))
def test_ray_interval_ends_lie_on_the_cutter(profile, axis, seed):
    """For random rays and poses: just inside each end of the interval is in the cutter
    (independent point test), just outside is not; a ray that misses has no point in it
    (sampled). Flat and ball also agree with the bisection of the general profile."""
    prof = {"flat": FLAT, "ball": BALL, "bull": BULL}[profile]
    rng = np.random.default_rng(seed)
    n, height = 400, 12 * MM
    pts = rng.uniform(-8 * MM, 8 * MM, (n, 3))
    pts[:, axis] = 0.0
    k = rng.normal(size=(n, 3))
    k /= np.linalg.norm(k, axis=1, keepdims=True)
    tips = rng.uniform(-2 * MM, 2 * MM, (n, 3))
    t0, t1 = ray_tool_intervals(tool_solid(prof, height), pts, axis, tips, k)
    hit = t0 < t1
    e = np.eye(3)[axis]
    for t, sign in ((t0, 1.0), (t1, -1.0)):
        inside = pts[hit] + (t[hit] + sign * 1e-9)[:, None] * e
        outside = pts[hit] + (t[hit] - sign * 1e-9)[:, None] * e
        short = (t1 - t0)[hit] < 3e-9
        assert np.all(in_tool(inside, tips[hit], k[hit], prof, height) | short)
        assert not np.any(in_tool(outside, tips[hit], k[hit], prof, height))
    miss = ~hit
    for t in np.linspace(-30 * MM, 30 * MM, 241):
        assert not np.any(in_tool(pts[miss] + t * e, tips[miss], k[miss], prof, height))
    if profile != "bull":
        g0, g1 = ray_tool_intervals(tool_solid(prof, height, exact=False), pts, axis, tips, k)
        assert np.array_equal(hit, g0 < g1)
        assert np.allclose(t0[hit], g0[hit], atol=1e-9)
        assert np.allclose(t1[hit], g1[hit], atol=1e-9)


# ---------------------------------------------------------------------------- meshes
def test_from_mesh_volume_and_contains():
    """A sphere (icosphere, 2562 vertices) and a box: volumes within 0.5 % of the mesh's at
    h = 0.5 mm, points beyond the 0.62 h band classified right."""
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=10 * MM)
    sphere.apply_translation([3 * MM, 2 * MM, 1 * MM])
    h = 0.5 * MM
    dex = TriDexel.from_mesh(sphere, h)
    assert abs(dex.volume() / sphere.volume - 1) < 0.005
    box = trimesh.creation.box(extents=[30 * MM, 20 * MM, 10 * MM])
    assert abs(TriDexel.from_mesh(box, h).volume() / box.volume - 1) < 1e-9
    pts = np.random.default_rng(2).uniform(-12 * MM, 14 * MM, (20000, 3))
    d = np.linalg.norm(pts - [3 * MM, 2 * MM, 1 * MM], axis=1)
    far = np.abs(d - 10 * MM) > 0.62 * h + 0.05 * MM  # + the facets' sag
    assert np.array_equal(dex.contains(pts)[far], d[far] < 10 * MM)


def test_from_mesh_refuses_an_open_mesh():
    box = trimesh.creation.box(extents=[3 * MM, 2 * MM, 1 * MM])
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-1], process=False)
    with pytest.raises(InputError):
        TriDexel.from_mesh(open_box, 0.25 * MM)


def test_contains_is_the_vote_of_the_three_grids():
    """The majority (and 'any') of the three grids' own lookups, on points in and around a
    box with a tilted cutter's groove removed (the third grid is consulted only where the
    first two leave it open: the same answer)."""
    box = TriDexel.box([-10 * MM, -10 * MM, -10 * MM], [10 * MM, 10 * MM, 0.0], 0.5 * MM)
    k = np.array([0.3, 0.1, 1.0]) / np.linalg.norm([0.3, 0.1, 1.0])
    box.sweep_tool([[-12 * MM, 0, -2 * MM], [12 * MM, 3 * MM, -3 * MM]], [k, k], BALL, 30 * MM)
    pts = np.random.default_rng(3).uniform(-11 * MM, 11 * MM, (20000, 3))
    votes = sum(g.contains(pts).astype(int) for g in box.grids)
    assert np.array_equal(box.contains(pts), votes >= 2)
    assert np.array_equal(box.contains(pts, rule="any"), votes >= 1)
    assert 0 < np.mean(votes >= 2) < 1 and np.any(votes == 1)

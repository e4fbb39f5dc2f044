"""The five-axis stock walk (feedopt.process.dexel_material) and the engagement by slice in the
force model, against closed forms and the flat end mill's own force code."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process.averages import side_average
from feedopt.process.coefficients import CuttingCoefficients
from feedopt.process.cutter import CutterShape, SliceEngagement
from feedopt.process.dexel import TriDexel
from feedopt.process.dexel_material import (
    BLOCK_TURN_DEG,
    axis_reach,
    blocks,
    engagement_from_dexel,
    lag,
    sweep_dexel,
)
from feedopt.process.engagement import Engagement, slot_engagement
from feedopt.process.forces import critical_angles, milling_forces, milling_forces_at
from feedopt.process.general_forces import slice_engagement
from feedopt.process.tilted_engagement import lateral_hull
from feedopt.process.tool import Tool

MM = 1e-3
R = 5 * MM
COEFFS = CuttingCoefficients(ktc=700e6, krc=250e6, kac=150e6, kte=20e3, kre=30e3, kae=5e3)


def ball(helix_deg: float = 30.0) -> Tool:
    return Tool("ball", 2 * R, 2, math.radians(helix_deg), 20 * MM, shape=CutterShape.BALL,
                corner_radius=R)


def flat() -> Tool:
    return Tool("flat", 2 * R, 3, math.radians(30), 20 * MM)


def straight(start, stop, axis, step=0.2 * MM) -> SimpleNamespace:
    """Samples of a straight pass from ``start`` to ``stop`` [m] with a fixed tool axis."""
    start, stop = np.asarray(start, float), np.asarray(stop, float)
    length = float(np.linalg.norm(stop - start))
    s = np.linspace(0.0, length, int(round(length / step)) + 1)
    t = (stop - start) / length
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    return SimpleNamespace(position=start + s[:, None] * t, s=s,
                           tangent=np.tile(t, (s.size, 1)), axis=np.tile(k, (s.size, 1)))


def segment_area(radius: float, depth: float) -> float:
    """Area of the circular segment of ``depth`` cut off a circle of ``radius``."""
    return (radius**2 * math.acos((radius - depth) / radius)
            - (radius - depth) * math.sqrt(2 * radius * depth - depth**2))


# ------------------------------------------------------------------ ball at lead, a groove
LEAD = math.radians(20.0)
DEPTH = 1.0 * MM  # the box top above the tip


@pytest.fixture(scope="module")
def groove():
    """A ball at 20 deg lead grooving a 20 mm box 1 mm below its top, from air to air."""
    box = TriDexel.box([-10 * MM, -8 * MM, -6 * MM], [10 * MM, 8 * MM, DEPTH], 0.05 * MM)
    before = box.volume()
    k = [math.sin(LEAD), 0.0, math.cos(LEAD)]
    samples = straight([-18 * MM, 0, 0], [18 * MM, 0, 0], k)
    found = sweep_dexel(box, ball(), samples)
    return SimpleNamespace(box=box, before=before, samples=samples, found=found)


def test_groove_removes_the_balls_cross_section(groove):
    """Through the box, the ball removes its circular cross-section below the top: a segment
    of depth a + R (1 - cos(lead)) (the tilted ball's lowest point is below its tip), times
    the box length; the per-sample removals sum to the volume removed."""
    depth = DEPTH + R * (1 - math.cos(LEAD))
    exact = segment_area(R, depth) * 20 * MM
    removed = groove.before - groove.box.volume()
    assert removed == pytest.approx(exact, rel=0.01)
    assert groove.found.removed.sum() == pytest.approx(removed, rel=1e-9)


def test_groove_engagement_is_the_closed_form(groove):
    """Inside the box each slice (r, z, kappa) of the ball cuts where the edge point is below
    the top, ``z0 - r sin(phi) sin(lead) + z cos(lead) < z0 + a``, and on the front,
    ``cos(lead) sin(kappa) sin(phi) > sin(lead) cos(kappa)`` (nothing earlier in the pass
    removed material there): sin(phi) > m, the interval [arcsin m, pi - arcsin m]."""
    x = groove.samples.position[:, 0]
    mid = np.flatnonzero((x > -4 * MM) & (x < 4 * MM))
    table = groove.found.engagement.by_slice.rows(mid)
    sl = table.sliced
    m = np.maximum(math.tan(LEAD) * sl.cos_kappa / sl.sin_kappa,
                   (sl.height * math.cos(LEAD) - DEPTH) / (sl.radius * math.sin(LEAD)))
    cuts = m < 1.0
    lo_exact = np.where(cuts, np.arcsin(np.clip(m, -1, 1)), 0.0)
    hi_exact = np.where(cuts, math.pi - lo_exact, 0.0)
    # never engaged outside the exact set (the front's boundary is exact to bisection)
    on = table.lo < table.hi
    assert np.all(np.where(on, lo_exact[..., None] - table.lo, 0.0) < 1e-6)
    assert np.all(np.where(on, table.hi - hi_exact[..., None], 0.0) < 1e-6)
    # the engaged measure: short only where an earlier pose's surface passes within the
    # dexel resolution (0.6 h) of the edge, where the front's chip c (f . n) is thin
    # (measured: 0.998 over all, 0.960 at the worst sample)
    measure = np.sum(table.hi - table.lo, axis=2)
    exact_measure = hi_exact - lo_exact
    assert measure.sum() / exact_measure.sum() > 0.99
    assert np.min(measure.sum(axis=1) / exact_measure.sum(axis=1)) > 0.95
    mean_walk = side_average(ball(), COEFFS, groove.found.engagement.take(mid))[0]
    exact = Engagement(np.zeros(mid.size), np.full(mid.size, math.pi), np.full(mid.size, R),
                       feed_axial=np.full(mid.size, math.sin(LEAD)),
                       by_slice=SliceEngagement(sl, lo_exact[..., None], hi_exact[..., None],
                                                table.feed_x, table.feed_z))
    mean_exact = side_average(ball(), COEFFS, exact)[0]
    assert np.max(np.abs(mean_walk - mean_exact)) < 0.01 * np.abs(mean_exact).max()


def test_groove_summary_columns(groove):
    """Air before and after the box; the hull of a full-width groove is [0, pi] folded; the
    lean is sin(lead); the depth reaches the top; no plunge for a ball."""
    f, x = groove.found, groove.samples.position[:, 0]
    assert np.all(f.in_air[x < -10 * MM - R - 0.1 * MM])
    assert np.all(f.in_air[x > 10 * MM + R])
    inside = (x > -4 * MM) & (x < 4 * MM)
    assert not f.in_air[inside].any()
    e = f.engagement
    assert e.plunge is None
    assert np.allclose(e.feed_axial[inside], math.sin(LEAD))
    assert np.all(e.entry[inside] < 0.6) and np.all(e.exit[inside] > math.pi - 0.6)
    top = DEPTH / math.cos(LEAD)  # the top along the axis, over the tip: the highest edge
    assert np.all(f.axial_depth[inside] > 0.9 * top)
    assert np.all(f.axial_depth[inside] < top + R * math.tan(LEAD) + 0.5 * MM)


def test_blocks_of_one_sample_agree_on_a_straight_pass(groove):
    """Module docstring: on a straight feed a block sees what sample-by-sample would, but
    for the dexel's resolution: one sample at a time, the pose just before lies within 0.6 h
    of the front's thin-chip edge and misreads a little more of it as cut (the walk's
    blocks are the better of the two there)."""
    box = TriDexel.box([-10 * MM, -8 * MM, -6 * MM], [10 * MM, 8 * MM, DEPTH], 0.05 * MM)
    x = groove.samples.position[:, 0]
    part = np.flatnonzero((x > -3 * MM) & (x < 3 * MM))
    sub = SimpleNamespace(**{k: getattr(groove.samples, k)[part] for k in
                             ("position", "s", "tangent", "axis")})
    box.sweep_tool(groove.samples.position[:part[0]], groove.samples.axis[:part[0]],
                   ball().profile, ball().flute_length)
    one = sweep_dexel(box, ball(), sub, block=1).engagement
    blocked = groove.found.engagement.take(part)

    def measure(e):
        return np.sum(e.by_slice.hi - e.by_slice.lo, axis=(1, 2))

    assert np.all(measure(blocked) >= measure(one) - 1e-6)
    assert np.all(measure(one) > 0.95 * measure(blocked))
    a, b = side_average(ball(), COEFFS, one)[0], side_average(ball(), COEFFS, blocked)[0]
    assert np.max(np.abs(a - b)) < 0.02 * np.abs(b).max()


# ----------------------------------------------------------- flat end mills, plunges, air
def test_flat_end_mill_plunge_is_flagged_and_a_ball_plunge_is_in_its_slices():
    """Straight down into a box: a flat bottom's plunge is Engagement.plunge (its end edges
    have their own model); a ball's bottom is on the front of every slice below the top."""
    box_lo, box_hi = [-10 * MM] * 3, [10 * MM, 10 * MM, 0.0]
    samples = straight([0, 0, 3 * MM], [0, 0, -2 * MM], [0, 0, 1])
    deep = samples.position[:, 2] < -0.2 * MM
    found = sweep_dexel(TriDexel.box(box_lo, box_hi, 0.1 * MM), flat(), samples)
    assert found.engagement.plunge is not None
    assert np.all(found.engagement.plunging[deep])
    assert not found.engagement.plunging[samples.position[:, 2] > 0.2 * MM].any()
    found = sweep_dexel(TriDexel.box(box_lo, box_hi, 0.1 * MM), ball(), samples)
    assert found.engagement.plunge is None
    assert np.all(~found.in_air[deep])
    hi = found.engagement.by_slice.hi
    assert np.allclose(hi[deep][..., 0].max(axis=1), 2 * math.pi)


def _section(**kw) -> SimpleNamespace:
    base = dict(box_mm=None, mesh=None, units=None, from_program=False, air_cut=False,
                cell_mm=0.25)
    base.update(kw)
    return SimpleNamespace(**base)


def test_a_path_that_meets_no_material_is_refused_or_warned():
    samples = straight([0, 0, 30 * MM], [20 * MM, 0, 30 * MM], [0.2, 0, 1])
    section = _section(box_mm=[-10, -10, -10, 10, 10, 0])
    with pytest.raises(InputError, match=r"meets no material .* z 30\.\.30 mm.*air_cut"):
        engagement_from_dexel(section, None, ball(), samples)
    out = engagement_from_dexel(_section(box_mm=[-10, -10, -10, 10, 10, 0], air_cut=True),
                                None, ball(), samples)
    assert "planned as an air cut" in out.warnings[0]
    with pytest.raises(InputError, match="stock.from_program"):
        engagement_from_dexel(_section(from_program=True), None, ball(), samples)


# ------------------------------------------------- the force model on a table by slice
def _stated_table(tool: Tool, engagement: Engagement, slices: int) -> Engagement:
    return Engagement(engagement.entry, engagement.exit, engagement.axial_depth,
                      by_slice=slice_engagement(tool, engagement, slices))


@pytest.mark.parametrize("entry,exit_", [(0.0, math.pi), (0.0, 1.2), (2.0, math.pi)])
def test_flat_end_mill_by_slice_equals_algorithm_1(entry, exit_):
    """A flat end mill's engagement given by slice takes the general cutter's direct sums;
    at kappa = 90 deg they are thesis Algorithm 1, computed by the flat code's prefix sums."""
    tool, n = flat(), 3
    eng = Engagement(np.full(n, entry), np.full(n, exit_), np.array([1.0, 2.5, 4.0]) * MM)
    table = _stated_table(tool, eng, 20)
    phi = np.linspace(0.0, tool.pitch, 37)
    ref, got = (milling_forces(tool, COEFFS, e, phi, 20) for e in (eng, table))
    scale = np.abs(ref.cutting).max()
    assert np.allclose(got.cutting, ref.cutting, atol=1e-9 * scale)
    assert np.allclose(got.edge, ref.edge, atol=1e-9 * np.abs(ref.edge).max())
    crit = critical_angles(tool, eng, 20)
    ref, got = (milling_forces_at(tool, COEFFS, e, crit, 20) for e in (eng, table))
    assert np.allclose(got.cutting, ref.cutting, atol=1e-9 * scale)
    for a, b in zip(side_average(tool, COEFFS, eng), side_average(tool, COEFFS, table),
                    strict=True):
        assert np.allclose(a, b, rtol=1e-9, atol=1e-12)


def test_engagement_by_slice_follows_take_and_without():
    tool = ball()
    eng = slot_engagement(4, np.array([1.0, 2.0, 3.0, 4.0]) * MM)
    table = _stated_table(tool, eng, 10)
    part = table.take(np.array([1, 3]))
    assert part.by_slice.n == 2
    assert np.array_equal(part.by_slice.lo, table.by_slice.lo[[1, 3]])
    dropped = table.without(np.array([False, True, False, False]))
    assert not dropped.cutting[1] and dropped.cutting[[0, 2, 3]].all()
    with pytest.raises(InputError, match="by_slice has 4 samples, expected 2"):
        Engagement(np.zeros(2), np.ones(2), np.ones(2) * MM, by_slice=table.by_slice)


def test_lateral_hull_folds_the_back_onto_the_front():
    sliced = slice_engagement(ball(), slot_engagement(3, 2 * MM), 2).sliced
    lo = np.array([[[0.5, 0.0], [0.0, 0.0]], [[4.0, 0.0], [3.5, 0.0]], [[0.0, 0.0]] * 2])
    hi = np.array([[[1.0, 0.0], [0.0, 0.0]], [[5.0, 0.0], [3.7, 0.0]], [[0.0, 0.0]] * 2])
    entry, exit_ = lateral_hull(SliceEngagement(sliced, lo, hi))
    assert entry[0] == pytest.approx(0.5) and exit_[0] == pytest.approx(1.0)
    # [4, 5) behind: lateral 2 pi - 5 .. 2 pi - 4; [3.5, 3.7): 2 pi - 3.7 .. 2 pi - 3.5
    assert entry[1] == pytest.approx(2 * math.pi - 5.0)
    assert exit_[1] == pytest.approx(2 * math.pi - 3.5)
    assert entry[2] == exit_[2] == 0.0


# ------------------------------------------------- review: plunges, blocks, lag, reach
class _Moves:
    """A program's move table for the samples: one move per sample, its category given."""

    def __init__(self, category: list[str]) -> None:
        self.category = np.array(category)

    def index_at(self, s):
        return np.arange(np.asarray(s).size)

    def label(self, k: int) -> str:
        return f"line {k + 1}"


def test_a_plunge_deeper_than_the_flutes_is_found_and_refused():
    """Straight down 25 mm into a box with 10 mm flutes: the material above the flutes is
    found (nothing is in front of the cutter on a plunge), and a program is refused."""
    short = Tool("short", 2 * R, 3, math.radians(30), 10 * MM)
    samples = straight([0, 0, 2 * MM], [0, 0, -25 * MM], [0, 0, 1])
    box = [[-10 * MM, -10 * MM, -40 * MM], [10 * MM, 10 * MM, 0.0]]
    found = sweep_dexel(TriDexel.box(*box, 0.2 * MM), short, samples)
    tip = samples.position[:, 2]
    assert np.all(found.beyond_flutes[tip < -10.5 * MM])
    assert not found.beyond_flutes[tip > -9.5 * MM].any()
    with pytest.raises(InputError, match="line .*plunge reaches more than the flute length"):
        engagement_from_dexel(_section(box_mm=[-10, -10, -40, 10, 10, 0]), None, short,
                              samples, _Moves(["plunge"] * samples.s.size), "p.cls")


def test_a_rapid_into_the_stock_is_refused_naming_its_line():
    samples = straight([-20 * MM, 0, -1 * MM], [20 * MM, 0, -1 * MM], [0, 0, 1])
    category = ["rapid"] * samples.s.size
    # its sweep cuts the 1 mm deep groove of the 10 mm end mill through the 20 mm box
    with pytest.raises(InputError, match=r"p\.cls line \d+: a rapid meets material.*cuts 19\d "
                                         r"mm\^3"):
        engagement_from_dexel(_section(box_mm=[-10, -10, -10, 10, 10, 0]), None, flat(),
                              samples, _Moves(category), "p.cls")


def test_blocks_end_where_the_feed_turns_and_the_lag_is_six_ray_spacings():
    a = np.radians(np.r_[np.zeros(40), np.linspace(0, 90, 31), np.full(40, 90.0)])
    t = np.column_stack([np.cos(a), np.sin(a), np.zeros(a.size)])
    samples = SimpleNamespace(tangent=t, axis=np.tile([0.0, 0.0, 1.0], (a.size, 1)))
    out = blocks(samples, 16)
    assert out[0] == (0, 16) and out[-1][1] == a.size
    assert all(b == c for (_, b), (c, _) in zip(out[:-1], out[1:], strict=True))
    for start, stop in out:  # no block turns by more than BLOCK_TURN_DEG
        assert np.ptp(np.degrees(a[start:stop])) <= BLOCK_TURN_DEG + 1e-9
    assert lag(0.2 * MM, np.arange(0, 10) * 0.1 * MM) == 12  # six ray spacings
    assert lag(0.1 * MM, np.arange(0, 10) * 1.0 * MM) == 1
    assert lag(0.5 * MM, np.arange(0, 10) * 0.01 * MM) == 64


def test_axis_reach_is_where_the_axis_leaves_the_widened_box():
    box = TriDexel.box([-10 * MM] * 3, [10 * MM, 10 * MM, 0.0], 1 * MM)
    tips = np.array([[0.0, 0.0, -2 * MM], [0.0, 0.0, 30 * MM], [0.0, 0.0, -2 * MM]])
    axes = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    reach = axis_reach(box, tips, axes, flat())
    # up from 2 mm below the top: the box widened by R = 5 mm ends 7 mm up; above it: 0;
    # pointing down: 8 + 5 mm to the widened bottom
    assert reach == pytest.approx([7 * MM, 0.0, 13 * MM])


def test_a_level_ball_finishing_pass_reads_its_closed_form_at_every_sample():
    """Lead 0, 0.5 mm deep: every slice below the top is engaged on [0, pi] (the front);
    no sample of a block (its first included, where the pose before it was just removed)
    reads more than 5 % short of that (with the removal two ray spacings behind, the first
    reads 23 % short; with six, none)."""
    box = TriDexel.box([-10 * MM, -8 * MM, -6 * MM], [10 * MM, 8 * MM, 0.5 * MM], 0.1 * MM)
    samples = straight([-16 * MM, 0, 0], [16 * MM, 0, 0], [0, 0, 1], step=0.1 * MM)
    found = sweep_dexel(box, ball(), samples)
    x = samples.position[:, 0]
    mid = np.flatnonzero((x > -4 * MM) & (x < 4 * MM))
    table = found.engagement.by_slice.rows(mid)
    below = table.sliced.height < 0.5 * MM
    exact = np.where(below, math.pi, 0.0).sum(axis=1)
    got = np.sum(table.hi - table.lo, axis=(1, 2))
    assert np.all(got >= 0.95 * exact) and np.all(got <= exact * (1 + 1e-6) + 0.2)


@pytest.mark.parametrize("tool", [flat(), ball()], ids=["flat", "ball"])
def test_a_rapid_retract_along_the_axis_out_of_its_own_hole_is_no_crash(tool):
    """A plunge 8 mm into a box, then a rapid straight back up the tool axis: the rapid's
    sweep stays in the hole the plunge cut (a retract is no crash, as for the Z-map), and
    the rapid's samples carry no engagement (the tool's side lies on the wall it cut)."""
    down = straight([0, 0, 3 * MM], [0, 0, -8 * MM], [0, 0, 1])
    up = straight([0, 0, -8 * MM], [0, 0, 10 * MM], [0, 0, 1])
    samples = SimpleNamespace(**{k: np.concatenate([getattr(down, k), getattr(up, k)[1:]])
                                 for k in ("position", "tangent", "axis")})
    samples.s = np.concatenate([down.s, down.s[-1] + up.s[1:]])
    category = ["plunge"] * down.s.size + ["rapid"] * (up.s.size - 1)
    out = engagement_from_dexel(_section(box_mm=[-10, -10, -20, 10, 10, 0]), None, tool,
                                samples, _Moves(category), "p.cls")
    rapid = np.array(category) == "rapid"
    assert not out.found.rapid_hits.any()
    assert out.found.in_air[rapid].all()
    assert not out.found.in_air[:down.s.size][down.position[:, 2] < -1 * MM].any()


def test_meshes_thinner_than_a_ray_spacing_and_coarse_rays_are_named(tmp_path):
    """A mesh thinner than stock.cell_mm (or in metres read as mm) is refused naming the
    field (it crashed with an IndexError); rays coarse against the depth of cut warn."""
    from feedopt.process.dexel_material import build_dexel_stock

    tri = np.array([[[0, 0, 0], [40, 0, 0], [0, 20, 0]], [[0, 0, 0.08], [40, 0, 0.08],
                                                           [0, 20, 0.08]]], dtype="<f4")
    rec = np.zeros(2, dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = tri
    (tmp_path / "thin.stl").write_bytes(b"x" * 80 + np.uint32(2).tobytes() + rec.tobytes())
    with pytest.raises(InputError, match=r"stock.mesh .*thin.stl .*0\.08 mm: thinner than "
                                         r"stock.cell_mm 0.2"):
        build_dexel_stock(_section(mesh="thin.stl", cell_mm=0.2),
                          lambda rel, _what: tmp_path / rel)
    samples = straight([-16 * MM, 0, 0], [16 * MM, 0, 0], [0, 0, 1], step=0.5 * MM)
    out = engagement_from_dexel(_section(box_mm=[-10, -10, -10, 10, 10, 1], cell_mm=1.0),
                                None, ball(), samples)
    assert any("stock.cell_mm 1 mm is coarse" in w for w in out.warnings)


def _stl(path, tri: np.ndarray) -> None:
    rec = np.zeros(tri.shape[0], dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = tri
    path.write_bytes(b"x" * 80 + np.uint32(tri.shape[0]).tobytes() + rec.tobytes())


def test_overlapping_shells_are_refused_and_one_closed_box_is_read(tmp_path):
    """Two closed boxes overlapping (a union not merged): the rays pair crossings even-odd
    and would read the overlap hollow; refused by the enclosed volume. One box reads its
    volume."""
    import trimesh

    a = trimesh.creation.box(extents=[20, 10, 5]).triangles
    b = trimesh.creation.box(extents=[10, 10, 5]).triangles + [8.0, 0.0, 1.0]
    _stl(tmp_path / "two.stl", np.concatenate([a, b]))
    _stl(tmp_path / "one.stl", a)
    resolve = lambda rel, _what: tmp_path / rel  # noqa: E731
    from feedopt.process.dexel_material import build_dexel_stock

    with pytest.raises(InputError, match="overlapping shells"):
        build_dexel_stock(_section(mesh="two.stl"), resolve)
    one = build_dexel_stock(_section(mesh="one.stl"), resolve)
    assert one.volume() == pytest.approx(20 * 10 * 5 * MM**3, rel=0.01)

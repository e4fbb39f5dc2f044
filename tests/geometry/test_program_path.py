"""A G-code program as one G2 path: distances to the program computed here in closed form
(lines, circles), G2 by the continuity report and by finite differences of sampled
positions, provenance of every sample, and the refusals (line numbers)."""

import math

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.gcode import parse_gcode
from feedopt.geometry.continuity import continuity_report
from feedopt.geometry.program_path import ProgramPathOptions, Treatment, program_path
from feedopt.units import MM

HEAD = "%\nO100\nG21 G17 G90 G94\nT1 M6\nS2500 M3\nG0 X0 Y0 Z5.\n"
TOL = 0.01 * MM
OPTS = {"stock_top": None, "tolerance": TOL}  # the test programs plunge below Z0

# Line along +x into a tangent quarter circle (r 10, centre (50, -10)) down to (60, -10),
# a line down to (60, -40), a tangent CCW quarter (r 10, centre (70, -40)) to (70, -50), a
# tangent line on to (100, -50): curvature jumps 0 -> 1/10 mm -> 0 at every junction.
TANGENT = HEAD + """G1 Z-1. F300.
G1 X50. F254.
G2 X60. Y-10. I0 J-10.
G1 Y-40.
G3 X70. Y-50. I10. J0
G1 X100.
G0 Z5.
M30
%
"""


def _dist_segment(p, a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
    return np.linalg.norm(p - (a + t[:, None] * (b - a)), axis=1)


def _dist_arc(p, centre, r, a0, a1):
    """Distance to the flat arc of radius r about centre (z = centre z) from angle a0 to a1
    (counter-clockwise, radians)."""
    c = np.asarray(centre, float)
    d = p - c
    ang = np.arctan2(d[:, 1], d[:, 0])
    inside = ((ang - a0) % (2 * np.pi)) <= ((a1 - a0) % (2 * np.pi))
    rho = np.hypot(d[:, 0], d[:, 1])
    on = np.hypot(rho - r, d[:, 2])
    ends = [c + r * np.array([np.cos(a), np.sin(a), 0.0]) for a in (a0, a1)]
    off = np.minimum(*(np.linalg.norm(p - e, axis=1) for e in ends))
    return np.where(inside, on, off)


def _tangent_program_distance(p):
    """Distance [mm] of points p (mm) to the programmed TANGENT geometry."""
    z = -1.0
    parts = [
        _dist_segment(p, (0, 0, 5), (0, 0, z)),
        _dist_segment(p, (0, 0, z), (50, 0, z)),
        _dist_arc(p, (50, -10, z), 10, 0.0, np.pi / 2),
        _dist_segment(p, (60, -10, z), (60, -40, z)),
        _dist_arc(p, (70, -40, z), 10, np.pi, 1.5 * np.pi),
        _dist_segment(p, (70, -50, z), (100, -50, z)),
        _dist_segment(p, (100, -50, z), (100, -50, 5)),
    ]
    return np.min(parts, axis=0)


@pytest.fixture(scope="module")
def tangent():
    return program_path(parse_gcode(TANGENT, "tangent.nc"), ProgramPathOptions(**OPTS))


def test_smoothed_path_stays_within_tolerance_of_every_programmed_move(tangent):
    path = tangent.path
    pts = path.sample(0.02 * MM).position / MM
    dist = _tangent_program_distance(pts)
    assert dist.max() <= TOL / MM * (1 + 1e-6)
    # and the report says the same, junction by junction
    assert np.all(tangent.junctions.deviation <= tangent.junctions.tolerance * (1 + 1e-9))
    assert dist.max() <= tangent.junctions.deviation.max() / MM * (1 + 1e-3)


def test_every_junction_is_g2_by_the_continuity_report(tangent):
    rep = continuity_report(tangent.path)
    g0, g1, g2 = rep.max()
    assert g0 < 1e-9 and g1 < 1e-7 and g2 * MM < 1e-6  # G2 jump below 1e-6 1/mm
    treat = tangent.junctions.treatment
    # the three line-arc / arc-line curvature jumps get transitions, the corners blends
    assert treat.count(Treatment.TRANSITION.value) == 4
    assert set(treat) <= {Treatment.BLEND.value, Treatment.TRANSITION.value}


def _fd_curvature(pos, h):
    """|curvature| from positions at uniform arc-length spacing h by central differences."""
    d2 = (pos[2:] - 2 * pos[1:-1] + pos[:-2]) / (h * h)
    return np.linalg.norm(d2, axis=1)


def test_g2_by_finite_differences_at_two_spacings(tangent):
    """Away from G2 jumps, the largest change of curvature between samples halves when the
    spacing halves (continuous curvature); at a curvature jump it would not shrink."""
    path = tangent.path
    lo, hi = tangent.moves.s_start[1] + 1 * MM, tangent.moves.s_start[6] - 1 * MM  # the cut
    steps = []
    for h in (0.02 * MM, 0.01 * MM):
        s = np.arange(lo, hi, h)
        k = _fd_curvature(path.evaluate(s).position, h)
        steps.append(np.abs(np.diff(k)).max())
    assert steps[1] < 0.65 * steps[0]
    # the same finite differences on the programmed geometry (no transitions) keep the jump
    prog = program_path(parse_gcode(TANGENT), ProgramPathOptions(**OPTS))
    assert prog.path.length > 0
    jump = 1 / (10 * MM)  # 0 -> 1/r
    for h in (0.02 * MM, 0.01 * MM):
        # a sampled jump from 0 to 1/r gives a difference of about 1/r at any spacing
        s = np.arange(0.0, 50 * MM, h)
        x = np.where(s[:, None] < 40 * MM, np.c_[s, 0 * s, 0 * s],
                     np.c_[40 * MM + 10 * MM * np.sin((s - 40 * MM) / (10 * MM)),
                           -10 * MM * (1 - np.cos((s - 40 * MM) / (10 * MM))), 0 * s])
        assert np.abs(np.diff(_fd_curvature(x, h))).max() > 0.3 * jump


def test_every_sample_knows_its_line_and_move(tangent):
    moves = tangent.moves
    assert list(moves.line) == [7, 8, 9, 10, 11, 12, 13]
    assert list(moves.category) == ["plunge", "cut", "cut", "cut", "cut", "cut", "rapid"]
    path = tangent.path
    s_mid = 0.5 * (moves.s_start + np.append(moves.s_start[1:], path.length))
    pts = path.evaluate(s_mid).position / MM
    # mid-move samples lie on their own programmed move
    assert abs(pts[2, 0] - (50 + 10 * math.sin(math.pi / 4))) < 0.05  # the G2 arc
    assert np.allclose(pts[3, 0], 60, atol=1e-6)  # the G1 along -y
    assert list(moves.index_at(s_mid)) == list(range(7))
    assert np.allclose(moves.feed[1:6], 254 / 60 * MM)


def test_path_passes_through_move_ends_where_no_blend_is_needed():
    """Collinear G1 moves with different feeds and two half circles of one circle: no
    treatment, and the path passes exactly through the programmed end points."""
    text = HEAD + ("G1 Z-1. F300.\nG1 X10. F200.\nG1 X20. F254.\nG2 X40. I10. J0\n"
                   "G2 X20. I-10. J0\nG1 Z5.\nM30\n")
    out = program_path(parse_gcode(text), ProgramPathOptions(**OPTS))
    treat = out.junctions.treatment
    assert treat[1] == treat[3] == Treatment.NONE.value  # G1-G1 collinear, arc-arc same circle
    at = out.path.evaluate(out.moves.s_start[[2, 4]]).position / MM
    assert np.allclose(at, [[10, 0, -1], [40, 0, -1]], atol=1e-9)


def test_helical_arc_matches_its_closed_form_and_finite_differences():
    text = HEAD + "G1 Z0.5 F300.\nG3 X10. Y0. Z-0.5 I5. J0 F200.\nG1 X20.\nM30\n"
    out = program_path(parse_gcode(text), ProgramPathOptions(**OPTS))
    seg = next(g for g in out.path.segments if g.kind == "arc")
    s = seg.s_start + np.linspace(0.1, 0.9, 9) * seg.length
    pts = out.path.evaluate(s)
    # on the cylinder of radius 5 about (5, 0)
    rho = np.hypot(pts.position[:, 0] / MM - 5, pts.position[:, 1] / MM)
    assert np.allclose(rho, 5.0, atol=1e-9)
    # descending linearly in the swept angle: 1 mm over half a turn
    h = 1e-6
    fd_t = (out.path.evaluate(s + h).position - out.path.evaluate(s - h).position) / (2 * h)
    assert np.allclose(fd_t, pts.tangent, atol=1e-6)
    fd_k = (out.path.evaluate(s + h).tangent - out.path.evaluate(s - h).tangent) / (2 * h)
    assert np.allclose(fd_k, pts.curvature, atol=1e-3)
    lam = math.hypot(5 * MM, 1 * MM / math.pi)
    assert np.linalg.norm(pts.curvature, axis=1) == pytest.approx(5 * MM / lam**2, rel=1e-9)


def test_arc_with_radius_mismatch_still_passes_through_both_end_points():
    text = HEAD + "G1 Z-1. F300.\nG2 X20. Y0. I10. J0.0008 F254.\nG1 Z5.\nM30\n"
    out = program_path(parse_gcode(text), ProgramPathOptions(**OPTS))
    arc = next(g for g in out.path.segments if g.kind == "arc")
    assert arc.params["radius"] == pytest.approx(10 * MM, abs=1e-6)
    end = out.path.evaluate([out.path.length]).position[0] / MM
    assert np.allclose(end, [20, 0, 5], atol=1e-9)


def test_short_g1_chain_is_one_smooth_spline_without_curvature_spikes():
    r = 30.0
    ang = np.linspace(0, np.pi / 2, 301)  # 300 chords of 0.157 mm
    pts = "\n".join(f"X{r * math.sin(a):.4f} Y{r * (1 - math.cos(a)):.4f}" for a in ang[1:])
    text = HEAD + f"G1 Z-1. F300.\nG1 X0 Y0 F254.\n{pts}\nG1 Z5.\nM30\n"
    out = program_path(parse_gcode(text), ProgramPathOptions(**OPTS))
    assert len(out.chains) == 1 and out.chains[0].moves == 300
    assert out.chains[0].deviation <= TOL
    spline = next(g for g in out.path.segments if g.kind == "spline")
    s = spline.s_start + np.linspace(0.1, 0.9, 400) * spline.length
    kappa = np.linalg.norm(out.path.evaluate(s).curvature, axis=1) * MM
    assert np.allclose(kappa, 1 / r, rtol=0.05)  # no spikes: the circle's curvature
    line_of = out.moves.line[out.moves.index_at(s)]
    assert np.all(np.diff(line_of) >= 0) and line_of.min() >= 9


# plunges and reversals are no longer refused and gaps are linked through the air
# (tests/geometry/test_program_stops.py); a link starting in the material is
@pytest.mark.parametrize(("text", "match"), [
    (HEAD + "G1 Z0.5 F300.\nG0 Z5.\nM30\n", r"no cutting move"),
    (HEAD + "G1 Z-1. F300.\nG1 X10.\nG28 G91 Z0\nG90\nG0 X20. Y0 Z-0.4\nG1 X30.\nM30\n",
     r"line 8: the tool is at Z-1 mm, below the stock top \(Z-0.5 mm\), when the program "
     r"loses its position after this move"),
])
def test_programs_that_cannot_become_one_path_are_refused_with_the_line(text, match):
    with pytest.raises(InputError, match=match):
        program_path(parse_gcode(text), ProgramPathOptions(stock_top=-0.5 * MM, tolerance=TOL))


def test_blend_none_is_refused_for_programs():
    with pytest.raises(InputError, match="choose a blend kind"):
        program_path(parse_gcode(TANGENT), ProgramPathOptions(blend="none", stock_top=None))


@pytest.mark.parametrize("blend", ["circle", "bezier4", "bezier5", "varying_radius"])
def test_every_blend_kind_gives_g2_corners_within_tolerance(blend):
    text = HEAD + "G1 Z-1. F300.\nG1 X30. F254.\nG1 X30. Y30.\nG1 X0. Y40.\nG1 Z5.\nM30\n"
    opts = ProgramPathOptions(**OPTS, blend=blend, blend_size=5 * MM)
    out = program_path(parse_gcode(text), opts)
    rep = continuity_report(out.path)
    assert rep.g2.max() * MM < 1e-6 and rep.g1.max() < 1e-7
    assert np.all(out.junctions.deviation <= out.junctions.tolerance * (1 + 1e-9))
    # the 90 degree corner at (30, 0): the blend stays inside tolerance of the two lines
    pts = out.path.sample(0.01 * MM).position / MM
    d = np.minimum.reduce([_dist_segment(pts, (0, 0, -1), (30, 0, -1)),
                           _dist_segment(pts, (30, 0, -1), (30, 30, -1)),
                           _dist_segment(pts, (30, 30, -1), (0, 40, -1)),
                           _dist_segment(pts, (0, 0, 5), (0, 0, -1)),
                           _dist_segment(pts, (0, 40, -1), (0, 40, 5))])
    assert d.max() <= TOL / MM * (1 + 1e-6)
    expect = (Treatment.BLEND_TRANSITIONS if blend == "circle" else Treatment.BLEND).value
    assert out.junctions.treatment[1] == expect

"""Deviation both ways at sharp junctions (issue 28): programs with 150-179 deg junctions
(line-line, line-arc, arc-arc), the path -> program and program -> path distances checked by
brute force (both curves densely sampled near the junction, nearest distances by numpy
broadcasting), the size-1 blend deviations against the circle's closed form, and the report
naming the junction its largest deviation belongs to."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.cli import main
from feedopt.gcode import parse_gcode
from feedopt.geometry.junctions import _segments_of, unit_deviation
from feedopt.geometry.program_path import ProgramPathOptions, Treatment, program_path
from feedopt.geometry.program_tables import JunctionReport
from feedopt.geometry.registry import get_blend
from feedopt.units import MM

HEAD = "G21 G17 G90 G94\nS2500 M3\n"
CORNER = np.array([20.0, 0.0, -1.0])  # mm, where moves A and B meet
W = 0.5  # mm: the brute force looks this far (and twice this far) around the junction


def _program(kind: str, turn_deg: float, radius: float, sweep_deg: float = 60.0) -> str:
    """Move A arrives at CORNER heading +x, move B leaves it heading ``turn_deg`` from +x:
    a line or an arc (B: counter-clockwise, A: clockwise) of ``radius`` [mm]."""
    th, sw = math.radians(turn_deg), math.radians(sweep_deg)
    if kind == "arc-arc":  # clockwise about (20, -r), ending at its top heading +x
        cx, cy = 20.0, -radius
        sx, sy = cx + radius * math.cos(math.pi / 2 + sw), cy + radius * math.sin(math.pi / 2 + sw)
        a = f"G2 X20. Y0. I{cx - sx:.9f} J{cy - sy:.9f} F254."
    else:
        sx, sy = 0.0, 0.0
        a = "G1 X20. Y0. F254."
    if kind == "line-line":
        b = f"G1 X{20 + 20 * math.cos(th):.9f} Y{20 * math.sin(th):.9f}"
    else:  # counter-clockwise, centre to the left of the heading
        cx, cy = 20 - radius * math.sin(th), radius * math.cos(th)
        a0 = math.atan2(-cy, 20 - cx)
        ex, ey = cx + radius * math.cos(a0 + sw), cy + radius * math.sin(a0 + sw)
        b = f"G3 X{ex:.9f} Y{ey:.9f} I{cx - 20:.9f} J{cy:.9f}"
    return (HEAD + f"G0 X{sx:.9f} Y{sy:.9f} Z5.\nG1 Z-1. F300.\n{a}\n{b}\nG0 Z5.\nM30\n")


def _near_corner(move, reaches: tuple[float, ...], at_end: bool, n: int = 2001
                 ) -> np.ndarray:
    """Points [mm] of a programmed move within each of ``reaches`` (along it) of its end or
    start, ``n`` per reach, merged in order along the move."""
    f = np.minimum(np.array(reaches) / move.length_mm, 1.0)
    t = np.unique(np.concatenate([np.linspace(1.0 - x, 1.0, n) if at_end else
                                  np.linspace(0.0, x, n) for x in f]))
    return move.point_at(t)


def _directed(x: np.ndarray, poly: np.ndarray) -> float:
    """max over the points x of the distance to the polyline ``poly`` (brute force: the
    nearest vertex of every point by numpy broadcasting, |x - y|^2 = |x|^2 + |y|^2 - 2 x.y,
    then the nearer of the two segments at it)."""
    c = poly.mean(axis=0)
    x, y = x - c, poly - c
    yy = np.einsum("ij,ij->i", y, y)
    k = np.empty(len(x), dtype=np.intp)
    for lo in range(0, len(x), 1000):
        xs = x[lo:lo + 1000]
        k[lo:lo + 1000] = np.argmin(yy[None, :] - 2.0 * xs @ y.T, axis=1)
    best = np.full(len(x), np.inf)
    for a in (np.maximum(k - 1, 0), k):
        b = np.minimum(a + 1, len(y) - 1)
        ab = y[b] - y[a]
        t = np.clip(np.einsum("ij,ij->i", x - y[a], ab)
                    / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(x - y[a] - t[:, None] * ab, axis=1))
    return float(best.max())


def _brute_force(out, program, region: float) -> tuple[float, float]:
    """(path -> program, program -> path) [mm] near CORNER: path points within W (in arc
    length) of the point nearest the corner against the programmed moves within 2 W of it,
    and the programmed moves within W against the path within 2 W; both curves sampled 6000
    times over those lengths and again over 3 ``region`` [mm] around the corner (where the
    path turns sharply: the length of the modified stretch or of the programmed corner it cuts
    short, whichever is longer)."""
    b = int(np.flatnonzero(out.moves.line == out.moves.line[2])[0])  # move B
    a_move, b_move = program.moves[b - 1], program.moves[b]
    s_c = out.moves.s_start[b]

    def path_pts(reach: float) -> np.ndarray:
        s = np.unique(np.concatenate([np.linspace(s_c - r * MM, s_c + r * MM, 6001)
                                      for r in (reach, 3 * region)]))
        return out.path.evaluate(np.clip(s, 0.0, out.path.length)).position / MM

    def prog_pts(reach: float) -> np.ndarray:
        return np.vstack([_near_corner(a_move, (reach, 3 * region), True),
                          _near_corner(b_move, (reach, 3 * region), False)])

    return _directed(path_pts(W), prog_pts(2 * W)), _directed(prog_pts(W), path_pts(2 * W))


def _check(kind: str, turn_deg: float, radius: float, tol_mm: float) -> None:
    program = parse_gcode(_program(kind, turn_deg, radius), "sharp.nc")
    out = program_path(program, ProgramPathOptions(tolerance=tol_mm * MM, stock_top=None))
    rep = out.junctions
    j = 1  # plunge->A, A->B, B->retract
    assert np.all(rep.deviation <= rep.tolerance * (1 + 1e-9))
    if rep.treatment[j] == Treatment.STOP.value:  # a hairpin transition (a near-reversal)
        _check_hairpin_stop(out, program, tol_mm)
        return
    region = np.nansum([rep.transition_length[j], 2 * np.nan_to_num(rep.size[j])]) / MM
    assert region < 0.25 * W  # the modified stretch lies well inside the brute-force window
    path_dev, prog_dev = _brute_force(out, program, max(region, 2 * rep.deviation[j] / MM))
    # both ways within the tolerance (sampling errors below 1e-4 of it here)
    assert path_dev <= tol_mm * (1 + 1e-3) and prog_dev <= tol_mm * (1 + 1e-3)
    # the report bounds them and is not far above (its own maxima are zoomed, not sampled)
    assert rep.path_deviation[j] / MM >= path_dev - 1e-3 * tol_mm
    assert rep.program_deviation[j] / MM >= prog_dev - 1e-3 * tol_mm
    assert rep.program_deviation[j] / MM <= prog_dev + 0.03 * tol_mm
    assert rep.deviation[j] == max(rep.path_deviation[j], rep.program_deviation[j])
    if rep.treatment[j] != Treatment.STOP.value:
        # at a sharp corner it is the program that is farther from the path
        assert rep.program_deviation[j] > rep.path_deviation[j]


def _check_hairpin_stop(out, program, tol_mm: float) -> None:
    """A junction turning back so far that its transition would be a hairpin of a fraction
    of a micrometre (too short to be built G2): the tool stops at the programmed corner, the
    path keeps it."""
    corner = np.array(program.moves[int(np.flatnonzero(out.moves.line == out.moves.line[2])[0])
                                    ].start)
    assert out.stops.kind == ("corner",)
    assert np.allclose(out.path.evaluate(out.stops.s).position[0] / MM, corner, atol=1e-9)
    # the cut points tol back along both moves lie 2 tol sin((pi - turn) / 2) apart: < 1 um
    turn = np.arccos(np.clip(np.dot(*_unit_tangents(out, out.stops.s[0])), -1.0, 1.0))
    assert 2 * tol_mm * MM * np.sin(0.5 * (np.pi - turn)) < 1e-6
    assert any("cannot be built G2" in w for w in out.warnings)


def _unit_tangents(out, s: float) -> tuple[np.ndarray, np.ndarray]:
    """The path's unit tangents just before and after ``s``."""
    return (out.path.evaluate(np.array([s - 1e-9])).tangent[0],
            out.path.evaluate(np.array([s + 1e-9])).tangent[0])


@settings(max_examples=20, deadline=None)
@given(kind=st.sampled_from(["line-line", "line-arc", "arc-arc"]),
       turn_deg=st.floats(150.0, 179.0), radius=st.floats(2.0, 20.0),
       tol_mm=st.sampled_from([0.005, 0.01, 0.02]))
def test_sharp_junctions_are_within_tolerance_both_ways(kind, turn_deg, radius, tol_mm):
    _check(kind, turn_deg, radius, tol_mm)


@pytest.mark.parametrize("kind", ["line-line", "line-arc", "arc-arc"])
@pytest.mark.parametrize("turn_deg", [150.0, 170.0, 179.0])
def test_sharp_junctions_at_fixed_angles(kind, turn_deg):
    _check(kind, turn_deg, 10.0, 0.01)


@pytest.mark.parametrize("blend", ["circle", "bezier4", "bezier5", "varying_radius"])
def test_every_blend_kind_at_a_150_deg_corner(blend):
    """Each kind sized to the tolerance both ways (bezier4 refuses turns above 174 deg)."""
    program = parse_gcode(_program("line-line", 150.0, 10.0), "sharp.nc")
    out = program_path(program, ProgramPathOptions(tolerance=0.01 * MM, stock_top=None,
                                                   blend=blend, blend_size=5 * MM))
    rep = out.junctions
    region = np.nansum([rep.transition_length[1], 2 * np.nan_to_num(rep.size[1])]) / MM
    path_dev, prog_dev = _brute_force(out, program, max(region, 2 * rep.deviation[1] / MM))
    assert max(path_dev, prog_dev) <= 0.01 * (1 + 1e-3)
    assert prog_dev > 0.9 * 0.01  # the size is limited by the corner cut short, not the lines
    assert out.junctions.program_deviation[1] / MM >= prog_dev - 1e-5


def test_unit_circle_deviation_matches_the_closed_form():
    """A circle of radius 1 tangent to both lines of a corner turning by g stays 1 - cos(g/2)
    from them and passes 1/cos(g/2) - 1 from the corner, at arc length g/2 from its start."""
    turn = np.radians(np.array([1.0, 30.0, 90.0, 150.0, 170.0, 179.0]))
    got = unit_deviation(get_blend("circle"), turn)
    np.testing.assert_allclose(got.path, 1 - np.cos(turn / 2), rtol=1e-6)
    np.testing.assert_allclose(got.program, 1 / np.cos(turn / 2) - 1, rtol=1e-6)
    np.testing.assert_allclose(got.near, turn / 2, rtol=1e-6)


def test_unit_deviation_of_parametric_blends_by_brute_force():
    """varying_radius and bezier5 by their own parameter: dense samples of the size-1 blend
    against the two rays and the corner."""
    from feedopt.geometry.blends import Corners

    turn = np.radians(np.array([60.0, 150.0, 175.0]))
    m = turn.size
    d_out = np.column_stack([np.cos(turn), np.sin(turn), np.zeros(m)])
    c = Corners(np.zeros((m, 3)), np.tile([1.0, 0, 0], (m, 1)), d_out, turn,
                np.tile([0, 1.0, 0], (m, 1)), np.full(m, 1e9), np.full(m, 1e9))
    for name in ("varying_radius", "bezier5"):
        kind = get_blend(name)
        built = kind.build(c, 1.0)
        got = unit_deviation(kind, turn)
        ev = kind.evaluator(_segments_of(name, built.params, np.asarray(built.length)))
        for i in range(m):
            sl = np.linspace(0.0, built.length[i], 20001)
            p = ev.eval(np.full(sl.size, i), sl)[0]
            ts = float(kind.tangent_distance(turn[i:i + 1], 1.0)[0])
            lines = np.vstack([-np.linspace(ts, 0, 4001)[:, None] * [1.0, 0, 0],
                               np.linspace(0, ts, 4001)[1:, None] * d_out[i]])
            assert got.path[i] == pytest.approx(_directed(p, lines), rel=1e-4)
            assert got.program[i] == pytest.approx(_directed(lines, p), rel=1e-4)


def test_the_largest_deviation_is_named_with_its_own_junction():
    """The summary names the junction closest to its tolerance with its own deviation, both
    directions and tolerance, and the largest in mm separately (an air junction)."""
    n = 3
    rep = JunctionReport(
        before=np.arange(n), s=np.zeros(n), turn=np.zeros(n), curvature_jump=np.zeros(n),
        treatment=("blend",) * n, size=np.zeros(n), transition_length=np.zeros(n),
        deviation=np.array([0.3, 0.0098, 0.004]) * MM,
        tolerance=np.array([0.5, 0.01, 0.01]) * MM, g0=np.zeros(n), g1=np.zeros(n),
        g2=np.zeros(n), labels=("line 3->4", "line 7->8", "line 9->10"),
        path_deviation=np.array([0.3, 0.002, 0.004]) * MM,
        program_deviation=np.array([0.1, 0.0098, 0.001]) * MM)
    text = rep.summary()
    assert text.startswith("3 junctions: largest deviation 0.0098 mm of 0.01 mm at line 7->8 "
                           "(path -> program 0.002 mm, program -> path 0.0098 mm)")
    assert ", in mm 0.3 mm of 0.5 mm at line 3->4" in text
    assert rep.worst() == 1


def test_a_150_deg_line_arc_junction_is_cut_short_no_more_than_the_tolerance(capsys, tmp_path):
    """The case of LinuxCNC cds.ngc: a line into an arc at 150 deg. Reported both ways by
    ``feedopt path`` with the worst junction's own label."""
    f = tmp_path / "cds_like.ngc"
    f.write_text(_program("line-arc", 150.0, 5.0))
    assert main(["path", str(f)]) == 0
    text = capsys.readouterr().out
    assert "path_mm" in text and "prog_mm" in text
    summary = text.strip().splitlines()[-1]
    out = program_path(parse_gcode(f.read_text(), str(f)),
                       ProgramPathOptions(blend_size=12.7 * MM))
    rep = out.junctions
    w = rep.worst()
    assert f"at {rep.labels[w]} " in summary
    assert f"largest deviation {rep.deviation[w] / MM:.3g} mm" in summary
    assert rep.program_deviation[1] <= 0.01 * MM * (1 + 1e-9)

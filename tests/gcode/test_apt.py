"""The APT CL reader: positions, tool vectors, units, feeds, arcs, stops and refusals.

Expected values are computed here independently of the reader (hand formulas, distances from
the circle's centre and axis, cross products), not with its helpers.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.gcode import (
    MoveCategory,
    MoveKind,
    Plane,
    StopKind,
    ToolShape,
    parse_apt,
    read_apt,
)

DATA = Path(__file__).resolve().parents[1] / "data" / "apt"
HEAD = "UNITS/MM\nFROM/0,0,10\nFEDRAT/600,MMPM\n"  # the statement tested is on line 4


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _radial(p, centre, axis) -> tuple[float, float]:
    """Distance of ``p`` from the axis through ``centre`` and its height along the axis."""
    v = np.asarray(p, dtype=float) - np.asarray(centre, dtype=float)
    a = _unit(axis)
    h = float(v @ a)
    return float(np.linalg.norm(v - h * a)), h


def _turn_sign(start, mid, centre, axis) -> float:
    """+1 if going from ``start`` to ``mid`` turns counter-clockwise about ``axis``."""
    a = _unit(axis)
    u = np.asarray(start, float) - centre
    w = np.asarray(mid, float) - centre
    return float(np.sign(np.cross(u, w) @ a))


# ---------------------------------------------------------------- lines, vectors, units
def test_three_axis_lines_feeds_categories_and_resolution():
    p = parse_apt(HEAD + "GOTO/0,0,0\nGOTO/10.5,0,0\nGOTO/10.5,0,5.25\nRAPID\nGOTO/0,0,20\n"
                  "GOTO/0,0,30\nFINI\n")
    kinds = [(m.kind, m.category) for m in p.moves]
    assert kinds == [(MoveKind.LINE, MoveCategory.PLUNGE), (MoveKind.LINE, MoveCategory.CUT),
                     (MoveKind.LINE, MoveCategory.RETRACT),
                     (MoveKind.RAPID, MoveCategory.RAPID),  # RAPID: the next motion only
                     (MoveKind.LINE, MoveCategory.RETRACT)]
    assert p.moves[0].start == (0.0, 0.0, 10.0) and p.moves[1].end == (10.5, 0.0, 0.0)
    assert p.moves[1].feed_mm_s == pytest.approx(600 / 60) and p.moves[3].feed_mm_s is None
    assert [m.line for m in p.moves] == [4, 5, 6, 8, 9]
    assert p.moves[1].text == "GOTO/10.5,0,0"
    assert not p.five_axis and all(m.axis_start is None for m in p.moves)
    assert p.units == "mm" and p.resolution_mm == pytest.approx(0.01)


def test_tool_vectors_are_normalised_and_chained():
    p = parse_apt("MULTAX/ON\nFEDRAT/300\nFROM/0,0,50\nGOTO/0,0,10,0,0,2\nGOTO/10,0,10,1,0,1\n"
                  "GOTO/10,0,10,0,3,4\nGOTO/20,0,10,0,3,4\n")
    m0, m1, m2 = p.moves
    assert p.five_axis
    # the first move has no vector before it: it starts with its own
    assert m0.axis_start == pytest.approx((0, 0, 1)) and m0.axis_end == pytest.approx((0, 0, 1))
    s = 1 / math.sqrt(2)
    assert m1.axis_start == pytest.approx((0, 0, 1)) and m1.axis_end == pytest.approx((s, 0, s))
    # the zero-length GOTO turned the tool: the next move starts from the turned vector
    assert m2.axis_start == pytest.approx((0, 0.6, 0.8)) and m2.axis_end == pytest.approx(
        (0, 0.6, 0.8))
    assert any("turned in place" in w and "line" in w for w in p.warnings)
    # a plunge is along the tool axis, whatever its direction
    q = parse_apt("FEDRAT/300\nFROM/0,0,0,1,0,1\nGOTO/-1,0,-1,1,0,1\nGOTO/0,0,0\n")
    assert [m.category for m in q.moves] == [MoveCategory.PLUNGE, MoveCategory.RETRACT]
    assert q.moves[1].axis_end == pytest.approx((s, 0, s))  # 3 values keep the last vector


def test_inches_scale_coordinates_feeds_and_resolution():
    p = parse_apt("UNITS/INCHES\nFROM/0,0,1\nFEDRAT/10\nGOTO/1.2500,0,1\nFEDRAT/254,MMPM\n"
                  "GOTO/1.25,2,1\nFEDRAT/IPM,5\nGOTO/0,2,1\n")
    assert p.units == "inch"
    assert p.moves[0].end == pytest.approx((1.25 * 25.4, 0, 25.4))
    assert [m.feed_mm_s for m in p.moves] == pytest.approx([10 * 25.4 / 60, 254 / 60,
                                                           5 * 25.4 / 60])
    assert p.resolution_mm == pytest.approx(1e-4 * 25.4)
    same = parse_apt("FROM/0,0,1\nFEDRAT/10\nGOTO/1.2500,0,1\n", units="inch")
    assert same.moves[0].end == p.moves[0].end


def test_file_without_units_and_inch_feeds_is_read_in_inches():
    p = parse_apt("FROM/0,0,1\nFEDRAT/IPM,10\nGOTO/1,0,1\n")
    assert p.units == "inch" and p.moves[0].end == pytest.approx((25.4, 0, 25.4))
    assert any("no UNITS statement" in w for w in p.warnings)
    assert parse_apt("FROM/0,0,1\nFEDRAT/IPM,10\nGOTO/1,0,1\n", units="mm").units == "mm"


def test_feed_per_revolution_uses_the_spindle_speed_of_the_move():
    p = parse_apt("FROM/0,0,0\nSPINDL/1000,CLW\nFEDRAT/0.1,MMPR\nGOTO/5,0,0\n"
                  "SPINDL/RPM,2000,CCLW\nGOTO/10,0,0\nFEDRAT/0.002,IPR\nGOTO/15,0,0\n")
    assert [m.feed_mm_s for m in p.moves] == pytest.approx(
        [0.1 * 1000 / 60, 0.1 * 2000 / 60, 0.002 * 25.4 * 2000 / 60])
    assert [m.spindle_direction for m in p.moves] == [1, -1, -1]
    assert [m.spindle_rpm for m in p.moves] == [1000, 2000, 2000]


def test_syntax_continuations_comments_case_and_numbers():
    text = ("$$ a comment line\nunits/mm ; trailing comment\n\nfedrat/ 100 , mmpm\n"
            "from/0,0,0\ngoto/1.,-.5,$\n   1E-3 $$ continued\nGoTo / 2 , 0 , 0\n"
            "PPRINT/'OP 1 $$ kept'\n")
    p = parse_apt(text)
    assert p.moves[0].end == pytest.approx((1.0, -0.5, 0.001))
    assert p.moves[0].line == 6 and "1E-3" in p.moves[0].text
    assert p.moves[1].end == (2.0, 0.0, 0.0) and p.moves[1].line == 8
    assert any("2 comment(s)" in w for w in p.warnings)


def test_statements_without_effect_are_noted_once_with_their_first_line():
    p = parse_apt("PARTNO/BRACKET\nCOOLNT/ON\nFROM/0,0,0\nFEDRAT/100\nCOOLNT/OFF\n"
                  "CUTCOM/LEFT\nGOTO/1,0,0\nPAINT/COLOR,3\n")
    coolnt = [w for w in p.warnings if w.startswith("COOLNT")]
    assert coolnt == ["COOLNT (coolant): 2 statement(s) (first at line 2)"]
    assert any(w.startswith("CUTCOM") and "line 6" in w for w in p.warnings)
    assert any(w.startswith("PARTNO") for w in p.warnings)
    assert len(p.moves) == 1


def test_stops_tools_and_headers():
    p = parse_apt("CUTTER/10,5\nLOADTL/3\nFROM/0,0,0\nFEDRAT/100\nGOTO/1,0,0\nDELAY/2.5\n"
                  "STOP\nOPSTOP\nCUTTER/8,1\nLOAD/TOOL,7,ADJUST,7\nFROM/0,0,0\nGOTO/2,0,0\n"
                  "CUTTER/6\n")
    assert [(s.kind, s.after_move, s.line) for s in p.stops] == [
        (StopKind.TOOL_CHANGE, -1, 2), (StopKind.DWELL, 0, 6), (StopKind.PROGRAM_STOP, 0, 7),
        (StopKind.OPTIONAL_STOP, 0, 8), (StopKind.TOOL_CHANGE, 0, 10)]
    assert p.stops[1].hold_s == 2.5
    assert p.tools == (3, 7) and [m.tool for m in p.moves] == [3, 7]
    heads = [(h.number, h.diameter_mm, h.corner_radius_mm, h.shape, h.line)
             for h in p.tool_headers]
    assert heads == [(3, 10, 5, ToolShape.BALL, 1), (7, 8, 1, ToolShape.BULL, 9),
                     (7, 6, 0, ToolShape.FLAT, 13)]


def test_position_unknown_after_tool_change_and_gohome():
    p = parse_apt("FEDRAT/100\nLOADTL/1\nRAPID\nGOTO/0,0,50\nGOTO/0,0,10\nGOHOME\n"
                  "RAPID\nGOTO/5,5,50\nGOHOME/0,0,100\n")
    assert [(m.kind, m.start, m.end) for m in p.moves] == [
        (MoveKind.LINE, (0, 0, 50), (0, 0, 10)), (MoveKind.RAPID, (5, 5, 50), (0, 0, 100))]
    assert any("rapid(s) from a position the reader does not know" in w and "4, 8" in w
               for w in p.warnings)
    q = parse_apt("FEDRAT/100\nGOTO/0,0,5\nGOTO/0,1,5\n")  # a feed move from nowhere
    assert len(q.moves) == 1 and q.moves[0].approach


def test_godlta_relative_and_along_the_tool_axis():
    p = parse_apt("FEDRAT/100\nFROM/1,2,3,0,1,0\nGODLTA/1,1,1\nGODLTA/-2\n")
    assert p.moves[0].end == (2, 3, 4)
    assert p.moves[1].end == pytest.approx((2, 1, 4))
    assert p.moves[1].category is MoveCategory.PLUNGE


def test_fini_ends_the_program():
    p = parse_apt("FROM/0,0,0\nFEDRAT/100\nGOTO/1,0,0\nFINI\nGOTO/9,9,9\nNONSENSE/1\n")
    assert len(p.moves) == 1
    assert any("2 statement(s) after FINI (line 4)" in w for w in p.warnings)


# ------------------------------------------------------------------------------ arcs
@pytest.mark.parametrize(("axis", "nx_fields", "turn"), [
    ((0, 0, 1), "", +1),  # ISO 4343 style: counter-clockwise about the axis
    ((0, 0, -1), "", -1),
    ((0, 0, 1), ",0.01,0.5,10,0", -1),  # NX CLSF (tolerance and tool fields): clockwise
    ((0, 0, -1), ",0.01,0.5,10,0", +1),
])
def test_circle_about_z_is_an_arc_in_its_direction(axis, nx_fields, turn):
    i, j, k = axis
    p = parse_apt(f"FROM/10,0,-1\nFEDRAT/100\nCIRCLE/0,0,-1,{i},{j},{k},10{nx_fields}\n"
                  "GOTO/0,10,-1\n")
    (m,) = p.moves
    assert m.kind is MoveKind.ARC and m.plane is Plane.XY and m.radius_mm == pytest.approx(10)
    assert m.centre == pytest.approx((0, 0, -1))
    # quarter turn counter-clockwise about +Z, or three quarters clockwise
    assert m.sweep_rad == pytest.approx(math.pi / 2 if turn > 0 else 1.5 * math.pi)
    mid = m.point_at(0.5)[0]
    assert _radial(mid, (0, 0, -1), (0, 0, 1))[0] == pytest.approx(10)
    assert _turn_sign((10, 0, -1), mid, np.array([0, 0, -1.0]), (0, 0, 1)) == turn


@pytest.mark.parametrize(("axis", "plane"), [((1, 0, 0), Plane.YZ), ((0, -1, 0), Plane.ZX)])
def test_circles_about_x_and_y_map_to_their_planes(axis, plane):
    i, j, k = axis
    start = (0, 5, 0) if plane is Plane.YZ else (5, 0, 0)
    p = parse_apt(f"FROM/{start[0]},{start[1]},{start[2]}\nFEDRAT/100\n"
                  f"CIRCLE/0,0,0,{i},{j},{k},5\nGOTO/{start[0]},{start[1]},{start[2]}\n")
    (m,) = p.moves
    assert m.plane is plane and m.sweep_rad == pytest.approx(2 * math.pi)  # a full circle
    pts = m.point_at(np.linspace(0, 1, 9))
    assert [_radial(q, (0, 0, 0), axis)[0] for q in pts] == pytest.approx([5] * 9)
    assert _turn_sign(start, pts[2], np.zeros(3), axis) == 1  # counter-clockwise about axis


def test_autodesk_movarc_turns_counter_clockwise_about_its_normal():
    # Autodesk's APT post negates the circular normal of a clockwise arc: -Z here is a G2
    p = parse_apt("TLDATA/MILL,6,0,20,0,0\nFROM/10,0,0\nFEDRAT/100\n"
                  "MOVARC/0,0,0,0,0,-1,10,ANGLE,90\nGOTO/0,-10,0\n")
    (m,) = p.moves
    assert m.direction == -1 and m.sweep_rad == pytest.approx(math.pi / 2)


def test_circle_about_a_skew_axis_is_cut_into_lines_within_the_tolerance():
    axis = _unit((1, 1, 1))
    centre = np.array([1.0, 2.0, 3.0])
    e0 = _unit((1, -1, 0))
    e1 = np.cross(axis, e0)
    r = 20.0
    start = centre + r * e0
    end = centre + r * (math.cos(2.0) * e0 + math.sin(2.0) * e1)  # 2 rad counter-clockwise
    text = (f"FROM/{start[0]:.9f},{start[1]:.9f},{start[2]:.9f}\nFEDRAT/100\n"
            f"CIRCLE/1,2,3,1,1,1,20\nGOTO/{end[0]:.9f},{end[1]:.9f},{end[2]:.9f}\n")
    tol = 0.005
    p = parse_apt(text, arc_tolerance_mm=tol)
    assert all(m.kind is MoveKind.LINE and m.category is MoveCategory.CUT for m in p.moves)
    assert p.moves[-1].end == pytest.approx(tuple(end))
    sagitta = r * (1 - math.cos(2.0 / len(p.moves) / 2))
    assert sagitta <= tol and r * (1 - math.cos(2.0 / (len(p.moves) - 1) / 2)) > tol
    for m in p.moves:
        for q in (m.start, m.end):
            rr, h = _radial(q, centre, axis)
            assert rr == pytest.approx(r, abs=1e-9) and h == pytest.approx(0, abs=1e-9)
        mid = 0.5 * (np.array(m.start) + np.array(m.end))
        assert r - _radial(mid, centre, axis)[0] <= tol + 1e-12
        assert _turn_sign(m.start, m.end, centre, axis) == 1
    assert any("cut into lines" in w for w in p.warnings)


def test_points_listed_after_a_circle_give_its_direction():
    # clockwise about +Z, though an ISO file's end-only arc would turn counter-clockwise
    angles = [0, -10, -20, -30, -40]
    pts = [(10 * math.cos(math.radians(a)), 10 * math.sin(math.radians(a)), 0) for a in angles]
    gotos = "".join(f"GOTO/{x:.6f},{y:.6f},{z}\n" for x, y, z in pts[1:])
    p = parse_apt(f"FROM/10,0,0\nFEDRAT/100\nCIRCLE/0,0,0,0,0,1,10\n{gotos}GOTO/20,0,0\n")
    arcs = [m for m in p.moves if m.kind is MoveKind.ARC]
    assert len(arcs) == 4 and all(m.direction == -1 for m in arcs)
    assert sum(m.sweep_rad for m in arcs) == pytest.approx(math.radians(40), abs=1e-6)
    assert p.moves[-1].kind is MoveKind.LINE and p.moves[-1].line == 8  # off the circle
    assert any("order of the points listed" in w for w in p.warnings)


def test_nx_end_point_arc_followed_by_a_line_off_the_circle():
    p = parse_apt("TOOL PATH/OP,TOOL,MILL\nFROM/0,-5,0\nFEDRAT/MMPM,100\n"
                  "CIRCLE/0,0,0,0,0,1,5,0.01,0.5,10,0\nGOTO/-5,0,0\nGOTO/-5,0.01,0\n"
                  "GOTO/-5,20,0\n")
    arc, *lines = p.moves
    # clockwise about +Z from -90 deg to 180 deg: a quarter turn through (-3.5, -3.5)
    assert arc.direction == -1 and arc.sweep_rad == pytest.approx(math.pi / 2)
    assert [m.kind for m in lines] == [MoveKind.LINE, MoveKind.LINE]


def test_circle_times_adds_full_turns():
    p = parse_apt("FROM/5,0,0\nFEDRAT/100\nCIRCLE/0,0,0,0,0,1,5,0.01,0.5,10,0,TIMES,2\n"
                  "GOTO/0,-5,-3\n")
    # NX clockwise about +Z from 0 deg to -90 deg: a quarter, plus one full turn
    assert sum(m.sweep_rad for m in p.moves) == pytest.approx(2.5 * math.pi)
    assert all(m.sweep_rad <= 2 * math.pi + 1e-12 for m in p.moves)
    assert p.moves[-1].end == (0, -5, -3)
    rise = [m.end[2] - m.start[2] for m in p.moves]  # in proportion to the angle
    assert np.allclose(np.array(rise) / [m.sweep_rad for m in p.moves], -3 / (2.5 * math.pi))


def test_nx_sample_file_reads_tangent_lead_arcs():
    p = read_apt(DATA / "nx_simple_mill_plane.cls")
    assert p.units == "mm" and p.tools == (1,) and p.stops[0].kind is StopKind.TOOL_CHANGE
    (head,) = p.tool_headers
    assert (head.diameter_mm, head.corner_radius_mm, head.shape) == (30, 0, ToolShape.FLAT)
    assert p.moves[0].category is MoveCategory.PLUNGE
    assert p.moves[-1].category is MoveCategory.RETRACT
    arcs = [k for k, m in enumerate(p.moves) if m.kind is MoveKind.ARC]
    assert len(arcs) == 2
    for k in arcs:
        arc = p.moves[k]
        assert arc.sweep_rad == pytest.approx(math.pi / 2) and arc.radius_mm == 7.5
        assert arc.end_radius_mm == pytest.approx(7.5, abs=1e-4)
        # the lead-in ends along the next cut, the lead-out starts along the last one
        before = arc.point_at(0.999)[0] if k == arcs[0] else arc.point_at(0.001)[0]
        tangent = _unit(np.array(arc.end) - before if k == arcs[0] else
                        before - np.array(arc.start))
        cut = p.moves[k + 1] if k == arcs[0] else p.moves[k - 1]
        assert tangent @ _unit(np.array(cut.end) - cut.start) > 0.999
    assert any("information-window listing" in w for w in p.warnings)
    assert p.resolution_mm == pytest.approx(1e-4)


# -------------------------------------------------------------------------- refusals
@pytest.mark.parametrize(("statement", "pattern"), [
    ("GOTO/1,2", r"GOTO: expected GOTO/x,y,z or GOTO/x,y,z,i,j,k, got 2 value"),
    ("GOTO/1,2,3,0,0,0", r"GOTO: the tool vector \(0, 0, 0\) has no direction"),
    ("GOTO/1,2,3,nan,0,1", r"GOTO: cannot read 'nan' as a number"),
    ("GOTO/1,2,1E999", r"GOTO: 1E999: out of range"),
    ("GOTO/1,2,x", r"GOTO: cannot read 'x' as a number"),
    ("MULTAX/ON\nGOTO/1,2,3", r"line 5: GOTO: x,y,z only while MULTAX/ON \(line 4\)"),
    ("MULTAX/SOMETIMES", r"MULTAX: expected MULTAX/ON or MULTAX/OFF"),
    ("CYCLE/DRILL,5,MMPM,100", r"CYCLE: canned cycles"),
    ("NURBS/", r"NURBS: spline motion is not read"),
    ("GOFWD/PS1,TANTO,DS1", r"GOFWD: APT part-program motion"),
    ("ROTABL/90", r"ROTABL: rotary-axis motion"),
    ("FOO/1,2", r"FOO: unknown APT statement"),
    ("hello world, 3", r"cannot read 'hello world, 3': not an APT statement"),
    ("CIRCLE/0,0,0,0,0,1,10", r"CIRCLE: the file ends before the GOTO"),
    ("CIRCLE/0,0,0,0,0,1,10\nFROM/0,0,0", r"line 5: FROM: the CIRCLE at line 4 must be"),
    ("CIRCLE/-10,0,10,0,0,1,10\nGOTO/20,0,10", r"line 5: GOTO: the arc ends 30.0000 mm from "
                                               r"the axis of the CIRCLE at line 4, whose radius"),
    ("CIRCLE/3.000,0,10,0,0,1,5.000\nGOTO/3.000,5.000,10",
     r"line 5: GOTO: the arc starts 3.0000 mm from .* \(tolerance 0.002828 mm\)"),
    ("CIRCLE/0,0,10,0,0,1,3\nGOTO/3,0,10", r"line 5: GOTO: the arc starts on the axis"),
    ("CIRCLE/0,0,0,0,0,0,10", r"CIRCLE: the circle axis \(0, 0, 0\) has no direction"),
    ("CIRCLE/0,0,0,0,0,1,0", r"CIRCLE: 0: the radius must be > 0"),
    ("CIRCLE/0,0,0,0,0,1,5,TIMES,0", r"CIRCLE: TIMES,0: the number of turns"),
    ("CIRCLE/0,0,0,0,0,1,5,ABOUT,0", r"CIRCLE: cannot read"),
    ("RAPID\nCIRCLE/0,0,10,0,0,1,5", r"line 5: CIRCLE: RAPID \(line 4\) before an arc"),
    ("RAPID/GOTO", r"RAPID: expected RAPID alone"),
    ("FEDRAT/0", r"FEDRAT: 0: the feed must be > 0"),
    ("FEDRAT/100,FURLONGS", r"FEDRAT: FURLONGS: unknown feed unit"),
    ("FEDRAT/100,INVERS", r"FEDRAT: inverse-time feeds"),
    ("FEDRAT/1,2", r"FEDRAT: cannot read 'FEDRAT/1,2'"),
    ("FEDRAT/0.1,MMPR\nGOTO/1,0,0", r"line 5: GOTO: feed per revolution \(FEDRAT at line 4\)"),
    ("DELAY/2,REV", r"DELAY: a dwell in spindle revolutions without a spindle speed"),
    ("DELAY/-1", r"DELAY: -1: the dwell time must be >= 0"),
    ("SPINDL/200,SFM", r"SPINDL: SFM: constant surface speed"),
    ("SPINDL/-5", r"SPINDL: -5: the spindle speed must be >= 0"),
    ("UNITS/FEET", r"UNITS: expected UNITS/MM or UNITS/INCHES"),
    ("GOTO/1,0,0\nUNITS/INCHES", r"line 5: UNITS: switching units after the first motion"),
    ("LOADTL/1.5", r"LOADTL: 1.5: the tool number must be a whole number"),
    ("LOAD/PART,3", r"LOAD: only LOAD/TOOL,n"),
    ("TLAXIS/NORMPS", r"TLAXIS: only TLAXIS/i,j,k"),
    ("CSYS/1,0,0,0,0,1,0,0,0,0,0,0", r"CSYS: the matrix has no Z axis"),
    ("GOTO/1,2,$", r"line 4: the statement is continued"),
])
def test_refusals_name_the_line_and_the_statement(statement, pattern):
    with pytest.raises(InputError, match=pattern) as info:
        parse_apt(HEAD + statement + "\n")
    assert re.match(r"<APT> line [45]: ", str(info.value)), str(info.value)


def test_feed_move_without_fedrat_names_the_line():
    with pytest.raises(InputError, match=r"<APT> line 2: GOTO: feed move without a feed rate"):
        parse_apt("FROM/0,0,0\nGOTO/1,0,0\n")


def test_read_apt_refuses_a_missing_file_and_reads_latin1(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_apt(tmp_path / "missing.cls")
    f = tmp_path / "latin.apt"
    f.write_bytes("PPRINT/'Fr\xe4ser 6 mm'\nFROM/0,0,0\nFEDRAT/100\nGOTO/1,0,0\n".encode("latin-1"))
    p = read_apt(f)
    assert len(p.moves) == 1 and p.source == str(f)
    assert p.warnings[0].startswith("not UTF-8 text")


def test_options_are_checked():
    with pytest.raises(ValueError, match="arc_tolerance_mm"):
        parse_apt("", arc_tolerance_mm=0)
    with pytest.raises(ValueError, match="circle_direction"):
        parse_apt("", circle_direction="left")  # type: ignore[arg-type]
    p = parse_apt("FROM/10,0,0\nFEDRAT/100\nCIRCLE/0,0,0,0,0,1,10\nGOTO/0,10,0\n",
                  circle_direction="cw")
    assert p.moves[0].direction == -1 and p.moves[0].sweep_rad == pytest.approx(1.5 * math.pi)


# ------------------------------------------------------------------------ properties
_WORDS = ["GOTO", "FROM", "GODLTA", "GOHOME", "RAPID", "CIRCLE", "MOVARC", "TLAXIS", "MULTAX",
          "UNITS", "FEDRAT", "SPINDL", "LOADTL", "LOAD", "CUTTER", "TLDATA", "DELAY", "STOP",
          "OPSTOP", "FINI", "END", "COOLNT", "PPRINT", "CYCLE", "CSYS", "PAINT", "FOO"]
_ARGS = ["0", "1", "-1", "2.5", "-.5", "1.", "10", "1E-3", "100", "0.0000001", "ON", "OFF",
         "MM", "INCHES", "MMPM", "IPM", "MMPR", "IPR", "CLW", "CCLW", "RPM", "TOOL", "REV",
         "TIMES", "ANGLE", "x", ""]


@st.composite
def statements(draw) -> str:
    """A statement of a known (or unknown) major word with arguments from a small pool."""
    word = draw(st.sampled_from(_WORDS))
    sizes = {"GOTO": (3, 6), "FROM": (3, 6), "CIRCLE": (6, 7), "GODLTA": (1, 3)}
    if word in sizes and draw(st.booleans()):
        n = draw(st.sampled_from(sizes[word]))
        nums = draw(st.lists(st.integers(-20, 20), min_size=n, max_size=n))
        return f"{word}/{','.join(map(str, nums))}"
    args = draw(st.lists(st.sampled_from(_ARGS), max_size=8))
    tail = draw(st.sampled_from(["", " $$ note", " ;x", "$"]))
    return f"{word.lower() if draw(st.booleans()) else word}/{','.join(args)}{tail}"


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.booleans(), st.lists(statements(), max_size=25))
def test_random_statement_soups_parse_or_raise_input_error(started, soup):
    try:
        p = parse_apt(("FROM/0,0,0\nFEDRAT/100\n" if started else "") + "\n".join(soup))
    except InputError as exc:
        assert " line " in str(exc)
        return
    for m in p.moves:
        assert all(math.isfinite(x) for x in (*m.start, *m.end))
        if m.axis_end is not None:
            assert math.isclose(float(np.linalg.norm(m.axis_end)), 1.0, rel_tol=1e-9)
        if m.kind is MoveKind.ARC:
            assert m.radius_mm > 0 and 0 < m.sweep_rad <= 2 * math.pi + 1e-9

"""Whole programs written the way CAM posts write them (Fusion Fanuc/Haas, Mastercam, LinuxCNC):
they read, with their stops, tool comments, approaches and resolution."""

import pytest

from feedopt.gcode import MoveCategory, StopKind, ToolShape, parse_gcode


def line_of(text: str, start: str) -> int:
    """1-based line of ``text`` that starts with ``start``."""
    return next(i for i, t in enumerate(text.splitlines(), 1) if t.startswith(start))

FUSION_FANUC = """%
O1001 (POCKET)
(T1 D=6. CR=0. - ZMIN=-3. - flat end mill)
(T2 D=3. CR=1.5 - ZMIN=-3.5 - ball end mill)
N10 G90 G94 G17 G91.1
N15 G21
N20 G28 G91 Z0.
N25 G90

(2D POCKET1)
N30 T1 M6
N35 S8000 M3
N40 G54
N45 M8
N50 G0 X10. Y5.
N55 G43 Z15. H1
N60 G0 Z5.
N65 G1 Z-3. F300.
N70 X30.
N75 G3 X35. Y10. I0. J5.
N80 G1 Y20.
N85 G0 Z15.
N90 M9
N95 M5
N100 G28 G91 Z0.
N105 G90
N110 M01

(FINISH)
N115 T2 M6
N120 S12000 M3
N125 G54
N130 G0 X12. Y8.
N135 G43 Z15. H2
N140 G1 Z-3.5 F200.
N145 G04 P500
N150 X28.
N155 G0 Z15.
N160 M5
N165 G28 G91 Z0.
N170 G28 G91 X0. Y0.
N175 G90
N180 M30
%
"""


def test_fusion_fanuc():
    prog = parse_gcode(FUSION_FANUC, source="p.nc", dwell_p_units="ms")
    assert prog.program_number == 1001 and prog.units == "mm"
    assert [(h.number, h.diameter_mm, h.shape) for h in prog.tool_headers] == [
        (1, 6.0, ToolShape.FLAT), (2, 3.0, ToolShape.BALL)]
    at = [line_of(FUSION_FANUC, n) for n in ("N30 ", "N110 ", "N115 ", "N145 ")]
    assert [(s.kind, s.line) for s in prog.stops] == list(zip(
        [StopKind.TOOL_CHANGE, StopKind.OPTIONAL_STOP, StopKind.TOOL_CHANGE, StopKind.DWELL],
        at, strict=True))
    assert prog.stops[-1].hold_s == pytest.approx(0.5)
    assert prog.tools == (1, 2) and prog.resolution_mm == pytest.approx(0.1)  # Z-3.5
    listed = ["N60 ", "N65 ", "N70 ", "N75 ", "N80 ", "N85 ", "N140 ", "N150 ", "N155 "]
    assert [m.line for m in prog.moves] == [line_of(FUSION_FANUC, n) for n in listed]
    assert not any(m.approach for m in prog.moves)


FUSION_HAAS = """%
O01002 (PROFILE)
(T3 D=0.25 CR=0.03 - ZMIN=-0.25 - bullnose end mill)
G90 G94 G17
G20
G53 G0 Z0.

(2D CONTOUR1)
T3 M6
S9000 M3
G54
M8
G0 X1.2 Y0.35
G43 Z0.6 H3
G0 Z0.2
G1 Z-0.25 F20.
G1 X2.4375 F60.
G2 X2.6875 Y0.6 I0. J0.25
G1 Y1.
G0 Z0.6
M9
G53 G0 Z0.
G53 G0 X0. Y0.
M5
M30
%
"""


def test_fusion_haas_inch_with_g53_retracts():
    prog = parse_gcode(FUSION_HAAS)
    assert prog.units == "inch" and prog.resolution_mm == pytest.approx(1e-4 * 25.4)
    (h,) = prog.tool_headers
    assert h.shape is ToolShape.BULL and h.diameter_mm == pytest.approx(6.35)
    assert h.corner_radius_mm == pytest.approx(0.762) and h.z_min_mm == pytest.approx(-6.35)
    assert [m.category for m in prog.moves] == [
        MoveCategory.RAPID, MoveCategory.PLUNGE, MoveCategory.CUT, MoveCategory.CUT,
        MoveCategory.CUT, MoveCategory.RAPID]
    assert prog.moves[3].radius_mm == pytest.approx(6.35)
    (g53,) = [w for w in prog.warnings if "G53" in w]
    assert g53.startswith("3 G53 rapid(s)") and "(lines 6, 22, 23)" in g53


MASTERCAM = """%
O0000(BRACKET)
(DATE=DD-MM-YY - 03-11-19 TIME=HH:MM - 16:16)
(MATERIAL - ALUMINUM MM)
( T1 | 10. FLAT ENDMILL | H1 | D1 | WEAR COMP | TOOL DIA. - 10. )
( T2 | 6. BALL ENDMILL | H2 )
N100 G21
N102 G0 G17 G40 G49 G80 G90
( 10. FLAT ENDMILL TOOL - 1 DIA. OFF. - 1 LEN. - 1 DIA. - 10. )
N104 T1 M6
N106 G0 G90 G54 X-5.5 Y-12.25 S3000 M3
N108 G43 H1 Z25. M8
N110 Z5.
N112 G1 Z-2. F100.
N114 X40.125 F400.
N116 G3 X45.125 Y-7.25 R5.
N118 G1 Y20.
N120 G0 Z25.
N122 M5
N124 G91 G28 Z0. M9
N126 G28 X0. Y0.
N128 M01
N130 G90
N132 M30
%
"""


def test_mastercam():
    prog = parse_gcode(MASTERCAM)
    assert [(h.number, h.diameter_mm, h.shape, h.line) for h in prog.tool_headers] == [
        (1, 10.0, ToolShape.FLAT, 5), (2, 6.0, ToolShape.BALL, 6), (1, 10.0, ToolShape.FLAT, 9)]
    assert [s.kind for s in prog.stops] == [StopKind.TOOL_CHANGE, StopKind.OPTIONAL_STOP]
    assert prog.resolution_mm == pytest.approx(1e-3)
    assert [m.line for m in prog.moves] == [13, 14, 15, 16, 17, 18]


LINUXCNC = """(T1 D0.125 ;1/8 ball end mill)
G17 G20 G40 G49 G54 G80 G90 G94
G64 P0.001
T1 M6 G43
S12000 M3
G0 X0 Y0 Z0.1
G1 Z-0.05 F10
G61
G1 X1.0 F30
G9 G1 Y0.5
G64 P0.002
G2 X0.5 Y1.0 R0.5
G4 P0.5
M0
G0 Z0.5
M2
"""


def test_linuxcnc_blending_and_exact_stops():
    prog = parse_gcode(LINUXCNC)
    (h,) = prog.tool_headers
    assert h.diameter_mm == pytest.approx(3.175) and h.shape is ToolShape.BALL
    tol = [m.blend_tolerance_mm for m in prog.moves]
    assert tol == [pytest.approx(0.0254), None, None, pytest.approx(0.0508),
                   pytest.approx(0.0508)]
    assert [(s.kind, s.after_move) for s in prog.stops] == [
        (StopKind.TOOL_CHANGE, -1), (StopKind.EXACT, 1), (StopKind.EXACT, 2),
        (StopKind.DWELL, 3), (StopKind.PROGRAM_STOP, 3)]
    assert prog.moves[0].length_offset == 1


CAMOTICS = """G21
(File: 'logo.tpl')
G0 Z3
F1600
M3 S10000
M6 T2
G0 X144 Y13.98
G1 Z-1.5
G1 X146.24 Y14.25
G1 X148.45 Y14.69
G0 Z3
M2
"""


def test_camotics_plunge_after_the_tool_change_is_an_approach():
    prog = parse_gcode(CAMOTICS)
    first = prog.moves[0]
    assert first.approach and first.start == (144, 13.98, -1.5) and first.line == 9
    assert [m.approach for m in prog.moves] == [True, False, False]
    assert any("(lines 8)" in w and "approach" in w for w in prog.warnings)

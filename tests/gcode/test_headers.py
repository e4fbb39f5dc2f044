"""Tool comments as CAM posts write them -> Program.tool_headers."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.gcode import ToolShape, parse_gcode
from feedopt.gcode.headers import size_in_name, tool_header

INCH = 25.4


@pytest.mark.parametrize(("comment", "number", "d", "cr", "shape", "zmin"), [
    # Fusion 360 / HSM (fanuc, haas, grbl, linuxcnc posts)
    ("T1 D=3.175 CR=0. - ZMIN=-5. - flat end mill", 1, 3.175, 0.0, ToolShape.FLAT, -5.0),
    ("T2  D=6. CR=0.5 TAPER=30deg - bull nose end mill", 2, 6.0, 0.5, ToolShape.BULL, None),
    ("T3 D=2. CR=1. - ball end mill", 3, 2.0, 1.0, ToolShape.BALL, None),
    ("T4 ID=B77 D=12.7 CR=0.76 - ZMIN=-12.1 - BULLNOSE END MILL", 4, 12.7, 0.76,
     ToolShape.BULL, -12.1),
    ("T16 D=6.35 CR=0. TAPER=45deg - ZMIN=-1.1 - chamfer mill", 16, 6.35, 0.0,
     ToolShape.CHAMFER, -1.1),
    ("T2 D=7.036 CR=0. TAPER=140deg - ZMIN=-3.82 - drill", 2, 7.036, 0.0, ToolShape.DRILL,
     -3.82),
    ("T1  D=40 CR=0 - ZMIN=0 - face mill", 1, 40.0, 0.0, ToolShape.OTHER, 0.0),
    ("T6  Spiral O Metal 3.175*12mm  Makera    D=3.175 CR=0. - ZMIN=-26. - flat end mill", 6,
     3.175, 0.0, ToolShape.FLAT, -26.0),
    ("T3 D=8. CR=0. - ZMIN=2. - right hand tap", 3, 8.0, 0.0, ToolShape.OTHER, 2.0),
    # Mastercam, table style: D1 is the compensation register, not the diameter
    (" T1 | 1/4 FLAT ENDMILL | H1 | D1 | TOOL DIA. - .25 ", 1, 0.25, None, ToolShape.FLAT,
     None),
    (" T212 |    3. FLAT ENDMILL | H0 ", 212, 3.0, None, ToolShape.FLAT, None),
    ("T2 | 6. BALL ENDMILL | H2 | D2 | WEAR COMP", 2, 6.0, None, ToolShape.BALL, None),
    (" T5 | 1/2 FLAT ENDMILL | H5 ", 5, 12.7, None, ToolShape.FLAT, None),  # a fraction: in
    # Mastercam, line style
    ("TOOL - 1 DIA. OFF. - 1 LEN. - 1 DIA. - .25", 1, 0.25, None, ToolShape.OTHER, None),
    (" 1/16 FLAT ENDMILL TOOL - 1 DIA. OFF. - 1 LEN. - 1 DIA. - .0625", 1, 0.0625, None,
     ToolShape.FLAT, None),
    (" TOOL - 6 2\"  MITSUBISIHI FACE MILL    DIA. OFF. - 6  LEN. - 6  DIA. - 2. ", 6, 2.0,
     None, ToolShape.OTHER, None),
    (" 1/8 X 900 CHAMFER MILL TOOL - 14 DIA. OFF. - 14 LEN. - 14 TOOL DIA. - .125 ", 14, 0.125,
     None, ToolShape.CHAMFER, None),
    # CAMotics / LinuxCNC tool-table style and hand-written
    ("T1 P1 D0.125 Z+0.511 ;1/8 end mill", 1, 0.125, None, ToolShape.OTHER, None),
    ("T3 6mm ball end mill", 3, 6.0, None, ToolShape.BALL, None),
    ("T7 1/8 flat endmill", 7, 3.175, None, ToolShape.FLAT, None),
    ("T1 D2 CR=0.3 ;2mm bull nose end mill", 1, 2.0, 0.3, ToolShape.BULL, None),
    ("TC: 5mm Endmill", None, 5.0, None, ToolShape.OTHER, None),  # FreeCAD
])
def test_tool_comment_forms(comment, number, d, cr, shape, zmin):
    h = tool_header(comment, 7, 1.0)
    assert h is not None and h.line == 7 and h.text == comment.strip()
    assert (h.number, h.shape) == (number, shape)
    assert h.diameter_mm == pytest.approx(d) if d is not None else h.diameter_mm is None
    assert h.corner_radius_mm == (pytest.approx(cr) if cr is not None else None)
    assert h.z_min_mm == (pytest.approx(zmin) if zmin is not None else None)


@pytest.mark.parametrize("comment", [
    "t1 is for facing and left turning, t4 is threading tool, t9 parting",
    "T4 3 flute end mill", "TC: Default Tool", "Tiger", "TOOL CHANGE", "T", "T1", "",
    "T1 D=abc - flat end mill", "T1 D=" + "9" * 400, "T1 | | |", "T1 0/0 flat",
    "(T1 D=-3 - flat end mill", "TOOL - 1 LEN. - 1", "2D Contour1", "T99999999999999 D=1",
])
def test_unreadable_comments_are_not_tools(comment):
    h = tool_header(comment, 1, 1.0)
    assert h is None or h.diameter_mm is None or 0 < h.diameter_mm < 1e5


def test_sizes_in_names():
    assert size_in_name("1/4 FLAT", 1.0) == pytest.approx(6.35)
    assert size_in_name("1/4 FLAT", INCH) == pytest.approx(6.35)  # a fraction is inches
    assert size_in_name("0.25in ball", 1.0) == pytest.approx(6.35)
    assert size_in_name('.5" bull', 1.0) == pytest.approx(12.7)
    assert size_in_name("3. FLAT", INCH) == pytest.approx(3 * INCH)  # program units
    assert size_in_name("6MM FLAT", INCH) == pytest.approx(6.0)
    assert size_in_name("2FL FLAT", 1.0) is None and size_in_name("FLAT 6", 1.0) is None


FUSION_INCH = """%
O1001
(T1 D=0.25 CR=0. - ZMIN=-0.5 - flat end mill)
(T2 D=0.125 CR=0.0625 - ZMIN=-0.25 - ball end mill)
N10 G90 G94 G17 G91.1
N15 G20
N20 G53 G0 Z0.
N25 T1 M6
N30 S8000 M3
N35 G54
N40 G0 X1. Y1.
N45 G43 Z0.6 H1
N50 G1 Z-0.1 F20.
N55 X2.
N60 M30
%
"""


def test_headers_of_an_inch_program_are_scaled_by_the_program_units():
    """Fusion writes the tool list before G20: its numbers are in the program's units."""
    prog = parse_gcode(FUSION_INCH)
    t1, t2 = prog.tool_headers
    assert (t1.number, t1.line, t1.shape) == (1, 3, ToolShape.FLAT)
    assert t1.diameter_mm == pytest.approx(6.35) and t1.z_min_mm == pytest.approx(-12.7)
    assert t2.corner_radius_mm == pytest.approx(1.5875) and t2.shape is ToolShape.BALL
    mm = parse_gcode(FUSION_INCH.replace("G20", "G21"))
    assert mm.tool_headers[0].diameter_mm == pytest.approx(0.25)


def test_headers_from_semicolon_comments_and_every_comment_of_a_line():
    prog = parse_gcode("(T1 D=6 - flat end mill) (T2 D=3 - drill)\n; T3 6mm ball end mill\n"
                       "G0 X0 Y0 Z0 (T4 D=1 - flat end mill)\nM30\n(T9 D=9 - drill)\n")
    assert [(h.number, h.line) for h in prog.tool_headers] == [(1, 1), (2, 1), (3, 2), (4, 3)]


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=80))
def test_any_comment_text_is_never_an_error(text):
    text = text.replace("(", "[").replace(")", "]").replace("\n", " ").replace("\r", " ")
    for t in (text, "T1 " + text, "T1 D=3 " + text, "T2 |" + text, "TOOL - 3 " + text,
              "TC:" + text):
        h = tool_header(t, 1, 1.0)
        assert h is None or h.diameter_mm is None or 0 < h.diameter_mm <= 1e5
    prog = parse_gcode(f"({text.replace(chr(0x85), ' ').replace(chr(0x2028), ' ')})\nM30\n")
    assert prog.moves == ()


size = st.decimals(min_value="0.001", max_value="100", places=3)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 999), size, st.decimals(min_value=0, max_value=10, places=3),
       st.decimals(min_value=-50, max_value=50, places=3),
       st.sampled_from([("flat end mill", ToolShape.FLAT), ("ball end mill", ToolShape.BALL),
                        ("bull nose end mill", ToolShape.BULL), ("drill", ToolShape.DRILL),
                        ("chamfer mill", ToolShape.CHAMFER), ("slot mill", ToolShape.OTHER)]),
       st.booleans())
def test_fusion_comments_read_back(number, d, cr, zmin, kind, inch):
    """What a Fusion post writes from the tool's numbers gives those numbers back (in mm)."""
    comment = f"T{number} D={d} CR={cr} - ZMIN={zmin} - {kind[0]}"
    h = tool_header(comment, 1, INCH if inch else 1.0)
    scale = INCH if inch else 1.0
    assert h.number == number and h.shape is kind[1]
    assert h.diameter_mm == pytest.approx(float(d) * scale)
    assert h.corner_radius_mm == pytest.approx(float(cr) * scale)
    assert h.z_min_mm == pytest.approx(float(zmin) * scale)

"""The HEIDENHAIN Klartext reader (feedopt.gcode.heidenhain): five-axis LN blocks, arcs about a
pole, the modal state, refusals naming the line; the ball saddle's CL file written as LN blocks
here reads to the same moves as the APT reader gives."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.gcode import MoveCategory, MoveKind, Plane, StopKind, parse_apt, parse_heidenhain
from tests.conftest import ROOT

FIVE = """\
0 BEGIN PGM FIVE MM
1 BLK FORM 0.1 Z X-50 Y-50 Z-20
2 BLK FORM 0.2 X+50 Y+50 Z+0
3 ; a comment
4 TOOL CALL 5 Z S2500 F400
5 L Z+100 R0 FMAX M91
6 M128
7 L X-30 Y+0 R0 FMAX M3
8 L Z+10 R0 FMAX
9 LN X-30 Y+0 Z+2 TX+0 TY+0 TZ+1 R0 FMAX
10 LN X-30 Y+0 Z+0 F200
11 LN X-20 Y+0 Z+0 TX+0.0868 TY+0 TZ+0.9962 F AUTO
12 LN X-10 Y+0 Z+0 TX+0.2 TY+0 TZ+1.2
13 LN X+0 Y+0 Z+0 NX+0 NY+0 NZ+1
14 L Z+50 R0 FMAX
15 M5 M9
16 END PGM FIVE MM
17 L X+999 F100
"""


def test_five_axis_ln_blocks_read_with_their_tool_vectors():
    prog = parse_heidenhain(FIVE, "five.h")
    kinds = [(m.kind, m.category, m.line) for m in prog.moves]
    # physical lines (block n is line n + 1); blocks 7 and 8 start where the reader does not
    # know (after M91): not in the move list
    assert kinds == [(MoveKind.RAPID, MoveCategory.RAPID, 10),
                     (MoveKind.LINE, MoveCategory.PLUNGE, 11),
                     (MoveKind.LINE, MoveCategory.CUT, 12),
                     (MoveKind.LINE, MoveCategory.CUT, 13),
                     (MoveKind.LINE, MoveCategory.CUT, 14),
                     (MoveKind.RAPID, MoveCategory.RAPID, 15)]
    plunge, first, second, third = prog.moves[1:5]
    assert plunge.feed_mm_s == pytest.approx(200 / 60)
    assert first.feed_mm_s == pytest.approx(400 / 60)  # F AUTO: the TOOL CALL's F
    assert third.feed_mm_s == pytest.approx(400 / 60)  # modal
    assert first.axis_start == (0.0, 0.0, 1.0)
    n = math.hypot(0.0868, 0.9962)
    assert first.axis_end == pytest.approx((0.0868 / n, 0.0, 0.9962 / n))
    n2 = math.hypot(0.2, 1.2)
    assert second.axis_end == pytest.approx((0.2 / n2, 0.0, 1.2 / n2))
    assert third.axis_end == second.axis_end  # LN without TX TY TZ keeps the vector
    assert third.end == (0.0, 0.0, 0.0)
    assert {m.tool for m in prog.moves} == {5} and prog.tools == (5,)
    assert {m.spindle_rpm for m in prog.moves} == {2500.0}
    assert prog.stops[0].kind is StopKind.TOOL_CHANGE
    text = " ".join(prog.warnings)
    assert "machine coordinates (M91/M92)" in text and "NX NY NZ" in text
    assert "BLK" in text and "M-words" in text
    assert all(m.line < 17 for m in prog.moves)  # nothing after END PGM


def test_arcs_about_a_pole_in_closed_form():
    prog = parse_heidenhain("""\
BEGIN PGM ARC MM
TOOL CALL 1 Z S1000
L X+10 Y+0 Z-1 R0 FMAX M3
CC X+0 Y+0
C X+0 Y+10 DR+ F300
C X+10 Y+0 DR- Z-2
C X+10 Y+0 DR+
CC
L X+10 Y+5 F300
END PGM ARC MM
""")
    quarter, back, full = prog.moves[:3]
    assert quarter.kind is MoveKind.ARC and quarter.plane is Plane.XY
    assert quarter.direction == 1 and quarter.sweep_rad == pytest.approx(math.pi / 2)
    assert quarter.centre == (0.0, 0.0, -1.0) and quarter.radius_mm == 10.0
    assert back.direction == -1 and back.sweep_rad == pytest.approx(math.pi / 2)
    assert back.end == (10.0, 0.0, -2.0)  # a helix down 1 mm
    assert full.sweep_rad == pytest.approx(2 * math.pi)
    mid = quarter.point_at(0.5)[0]
    assert mid == pytest.approx([10 / math.sqrt(2), 10 / math.sqrt(2), -1.0])
    # written to 3 decimals: the radii may differ by 2 sqrt(2) units of the last (0.0028 mm)
    with pytest.raises(InputError, match=r"line 4 .*10 and 10.01 mm from the pole"):
        parse_heidenhain("L X+10.000 Y+0.000 Z+0.000 FMAX\nCC X+0.000 Y+0.000\nL F100\n"
                         "C X+0.000 Y+10.010 DR+\n")
    parse_heidenhain("L X+10.000 Y+0.000 Z+0.000 FMAX\nCC X+0.000 Y+0.000\nL F100\n"
                     "C X+0.000 Y+10.002 DR+\n")


@pytest.mark.parametrize(("block", "says"), [
    ("L X+1 RL F100", "radius compensation"),
    ("L X+1 A+10 F100", "rotary axis words"),
    ("CYCL DEF 7.0 DATUM SHIFT", "CYCL DEF 7.0"),
    ("PLANE SPATIAL SPA+0 SPB+45 SPC+0 TURN FMAX", "tilted working plane"),
    ("L Z+Q22", "Q parameters"),
    ("FN 0: Q1=5", "Q-parameter"),
    ("CR X+5 Y+5 R+10 DR+", "arcs by radius"),
    ("L X+1 FU0.1", "per revolution"),
    ("L Z+50 R0 FMAX M140 MB MAX", "M140"),
    ("CALL LBL 1", "subprograms"),
    ("LN X+1 Y+0 Z+0 TX+0 TY+0 TZ+0 F100", "zero tool vector"),
    ("TOOL CALL 3 X S1000", "spindle along X"),
    ("FOO BAR", "unknown block"),
    ("L X+1 X+2 F100", "X given twice"),
    ("L X+nan F100", "not an address word"),
])
def test_what_could_move_the_tool_is_refused_naming_the_line(block, says):
    text = f"BEGIN PGM R MM\nL X+0 Y+0 Z+0 R0 FMAX\nL F100\n{block}\nEND PGM R MM\n"
    with pytest.raises(InputError, match=rf"line 4 .*{re.escape(says)}"):
        parse_heidenhain(text, "r.h")


def test_inch_programs_and_empty_files_are_refused():
    with pytest.raises(InputError, match="INCH program"):
        parse_heidenhain("0 BEGIN PGM A INCH\n1 L X+1 F10\n")
    with pytest.raises(InputError, match="no blocks"):
        parse_heidenhain("; only a comment\n* structure\n")
    with pytest.raises(InputError, match="without a feed rate"):
        parse_heidenhain("L X+0 Y+0 Z+0 FMAX\nL X+5\n")


def test_continued_cycle_blocks_and_block_delete():
    prog = parse_heidenhain("""\
0 BEGIN PGM C MM
1 CYCL DEF 32.0 TOLERANCE~
   T0.01 ;TOLERANCE
/2 L X+500 Y+500 R0 FMAX
3 L X+0 Y+0 Z+0 R0 FMAX M3
4 CYCL DEF 9.0 DWELL TIME
5 CYCL DEF 9.1 DWELL 1.5
6 L X+10 F100
7 STOP M0
8 L X+20
9 END PGM C MM
""")
    assert [m.line for m in prog.moves] == [8, 10]  # physical lines
    dwell, stop, stop0 = prog.stops
    assert dwell.kind is StopKind.DWELL and dwell.hold_s == 1.5 and dwell.after_move == -1
    assert stop.kind is StopKind.PROGRAM_STOP and stop0.kind is StopKind.PROGRAM_STOP
    text = " ".join(prog.warnings)
    assert "CYCL DEF 32" in text and "'/'" in text


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-500, 500), st.floats(-500, 500), st.floats(-100, 100),
                          st.floats(-1, 1), st.floats(-1, 1), st.floats(0.2, 1)),
                min_size=2, max_size=12))
def test_ln_blocks_read_to_their_written_points_and_unit_vectors(points):
    lines = ["BEGIN PGM H MM", "TOOL CALL 1 Z S1000", "M3"]
    for k, (x, y, z, i, j, kk) in enumerate(points):
        feed = " FMAX" if k == 0 else " F500"
        lines.append(f"LN X{x:+.4f} Y{y:+.4f} Z{z:+.4f} TX{i:+.5f} TY{j:+.5f} TZ{kk:+.5f}"
                     f" R0{feed}")
    prog = parse_heidenhain("\n".join(lines) + "\nEND PGM H MM\n")
    rounded = [tuple(round(v, 4) for v in p[:3]) for p in points]
    # a move to where the tool already is (to the written 4 decimals) is dropped
    want = [p for k, p in enumerate(rounded[1:], start=1) if p != rounded[k - 1]]
    assert len(prog.moves) == len(want)
    for m, p in zip(prog.moves, want, strict=True):
        assert m.end == pytest.approx(p, abs=1e-9)
        assert np.linalg.norm(m.axis_end) == pytest.approx(1.0, abs=1e-12)
        assert m.kind is MoveKind.LINE and m.feed_mm_s == pytest.approx(500 / 60)


def apt_as_klartext(apt_text: str) -> str:
    """An APT CL file's GOTOs, RAPIDs and FEDRATs written as LN blocks (by a regex, not
    feedopt's reader): RAPID -> FMAX, FEDRAT/f -> F f, GOTO/x,y,z,i,j,k -> LN X Y Z TX TY TZ."""
    out, rapid, feed = ["0 BEGIN PGM SADDLE MM", "1 TOOL CALL 1 Z S2500", "2 M3"], False, None
    for line in apt_text.splitlines():
        if line.startswith("RAPID"):
            rapid = True
        elif m := re.match(r"FEDRAT/([\d.]+)", line):
            feed = float(m.group(1))
        elif line.startswith("GOTO/"):
            x, y, z, i, j, k = (float(v) for v in line[5:].split(","))
            f = " FMAX" if rapid else f" F{feed:g}"
            out.append(f"{len(out)} LN X{x:+.6f} Y{y:+.6f} Z{z:+.6f} TX{i:+.6f} TY{j:+.6f} "
                       f"TZ{k:+.6f} R0{f}")
            rapid = False
    out.append(f"{len(out)} END PGM SADDLE MM")
    return "\n".join(out) + "\n"


def test_the_ball_saddle_as_ln_blocks_reads_like_its_apt_file():
    """The bundled CL file as LN blocks: the same moves, end points and tool vectors as the
    APT reader's."""
    apt_text = (ROOT / "scenarios" / "five_axis" / "ball_saddle.cls").read_text()
    hh = parse_heidenhain(apt_as_klartext(apt_text), "saddle.h")
    apt = parse_apt(apt_text, "ball_saddle.cls")
    assert len(hh.moves) == len(apt.moves) > 2000
    for a, b in zip(apt.moves, hh.moves, strict=True):
        assert a.kind is b.kind and a.category is b.category
        assert a.end == pytest.approx(b.end, abs=1e-9)
        assert a.axis_end == pytest.approx(b.axis_end, abs=1e-12)
        assert (a.feed_mm_s is None) == (b.feed_mm_s is None)
        if a.feed_mm_s is not None:
            assert a.feed_mm_s == pytest.approx(b.feed_mm_s)


def test_a_latin_1_file_is_read_and_noted(tmp_path):
    from feedopt.gcode import read_heidenhain

    p = tmp_path / "a.h"
    p.write_bytes(b"BEGIN PGM A MM\n; K\xf6rper\nL X+0 Y+0 Z+0 FMAX\nL X+5 F100 M3\n"
                  b"END PGM A MM\n")
    prog = read_heidenhain(p)
    assert len(prog.moves) == 1 and "read as Latin-1" in prog.warnings[0]

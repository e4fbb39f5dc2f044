"""Everything outside the subset is an InputError naming the line, the N number and the word."""

import pytest

from feedopt.errors import InputError
from feedopt.gcode import parse_gcode

HEAD = "G21 G90 G17\nG0 X0 Y0 Z0\nF600\n"  # the refused block is always line 4


@pytest.mark.parametrize(("block", "pattern"), [
    ("N40 G41 D1 X5", r"line 4 \(N40\): G41: cutter radius compensation"),
    ("G42 X5", r"line 4: G42: cutter radius"),
    ("M98 P100", r"line 4: M98: subprograms"),
    ("N40 M99", r"line 4 \(N40\): M99: subprograms"),
    ("#1=5", r"line 4: cannot read '#1=5': macro variables"),
    ("G1 X#1", r"line 4: cannot read 'X#1': macro"),
    ("G1 X[1+2]", r"line 4: cannot read .*expressions"),
    ("IF [1 EQ 1] GOTO 5", r"line 4: cannot read 'IF.*keywords"),
    ("O<pocket> call", r"line 4: cannot read 'O<POCKET>.*O-word subroutines"),
    ("o100 sub", r"line 4: cannot read 'SUB': keywords \(O-word SUB"),
    ("G81 X1 Y1 Z-2 R1", r"line 4: G81: canned cycles"),
    ("N40 G83 Z-5 Q1", r"line 4 \(N40\): G83: canned cycles"),
    ("G1 X1 A90", r"line 4: A90: rotary and extra axes"),
    ("G1 X1 B9", r"line 4: B9: rotary"),
    ("G1 C1", r"line 4: C1: rotary"),
    ("G1 U1", r"line 4: U1: rotary"),
    ("G1 V1", r"line 4: V1: rotary"),
    ("G1 W1", r"line 4: W1: rotary"),
    ("G2 X10 Y0", r"line 4: G2 without a centre \(I, J, K\) or a radius \(R\)"),
    ("G3 R5", r"line 4: G3 R5: start and end are the same point .*full circle needs I/J/K"),
    ("G2 X10 R0", r"line 4: G2 R0: radius must not be 0"),
    ("G2 X30 R10", r"line 4: G2 R10: radius 10.0000 mm is too small for the chord 30.0000"),
    ("G2 X10.000 Y10.000 I10.000 J0.010", r"line 4: G2: start and end are not on one circle: "
                                          r"start radius 10.0000 mm, end radius 9.9900 mm"),
    ("G2 X10 I0 J0", r"line 4: G2: the centre is at the start point"),
    ("G17 G2 X10 I5 K1", r"line 4: K1: K is not a centre offset in the G17 plane"),
    ("G2 X10 I5 R5", r"line 4: G2 with both R and I/J/K"),
    ("G1 X1 I5", r"line 4: I5: I, J, K and R are only read with G2/G3"),
    ("G20 G1 X1", r"line 4: G20: switching units after the first move"),
    ("G93 G1 X1", r"line 4: G93: inverse-time feed"),
    ("G95 G1 X1", r"line 4: G95: feed per revolution"),
    ("G28", r"line 4: G28 without axis words"),
    ("G28 G1 X0", r"line 4: G28 with a motion code"),
    ("G1 X1 F0", r"line 4: F0: feed must be > 0"),
    ("G1 X1 F-5", r"line 4: F-5: feed must be > 0"),
    ("G4", r"line 4: G4 without P: give the dwell time"),
    ("N40 G04 P-1", r"line 4 \(N40\): G4 P-1: the dwell time must be >= 0"),
    ("G4 X-1", r"line 4: G4 X-1: the dwell time must be >= 0"),
    ("G4 X1 Y2", r"line 4: G4 X1 \(dwell seconds\) with Y2"),
    ("G4 P1 G64 P0.1", r"line 4: P1 and P0.1: two P words"),
    ("G4 G64 P1", r"line 4: P1 with both G4 and G64"),
    ("G4 G28 Z0", r"line 4: G4 and G28: two G codes of the same modal group"),
    ("G64 P-0.01", r"line 4: G64 P-0.01: the path tolerance must be >= 0"),
    ("G1 X1 Q1", r"line 4: Q1: Q words are only read with G64"),
    ("G61 G64", r"line 4: G61 and G64: two G codes of the same modal group \(path control\)"),
    ("G5 X1 Y1 I1 J1 P1 Q1", r"line 4: G5: splines and NURBS \(G5\) are not supported"),
    ("G5.1 X1 I1 J1", r"line 4: G5.1: splines and NURBS \(G5.1\)"),
    ("N40 G5.2 X1 Y1 P1 L3", r"line 4 \(N40\): G5.2: splines and NURBS \(G5.2\)"),
    ("G5.3", r"line 4: G5.3: splines and NURBS"),
    ("G6.2 P3 K0. X1 Y1 R1", r"line 4: G6.2: splines and NURBS \(G6.2\)"),
    ("G41.1 D2", r"line 4: G41.1: cutter radius compensation"),
    ("G10 L2 P1 X0 Y0 Z0", r"line 4: G10: G10 \(setting offsets"),
    ("G92.3", r"line 4: G92.3: G92.3 \(restoring G92 offsets\)"),
    ("G30", r"line 4: G30: G30 \(return to second home\)"),
    ("M70", r"line 4: M70: M code not supported"),
    ("G2 X10 Y10 I10 P2", r"line 4: P2: P words are only read with G4 .* arc turns"),
    ("G92 X0", r"line 4: G92"),
    ("G1.5 X1", r"line 4: G1.5: G code not supported"),
    ("M50", r"line 4: M50: M code not supported"),
    ("G1 X1 E5", r"line 4: E5: E words"),
    ("G1 X1 P2", r"line 4: P2: P words"),
    ("G1 X1 Y2 X3", r"line 4: X1 and X3: two X words"),
    ("G0 G1 X1", r"line 4: G0 and G1: two G codes of the same modal group \(motion\)"),
    ("M3 M4", r"line 4: M3 and M4: two M codes of the same group \(spindle\)"),
    ("G1 X1 (open", r"line 4: comment '\(' is not closed"),
    ("G1 X1 )", r"line 4: '\)' without an opening"),
    ("G1 X1 (a (b) c)", r"line 4: nested comment"),
    ("G1 X1 $", r"line 4: cannot read '\$': unexpected character"),
    ("G1 X1 Ä", r"line 4: cannot read 'Ä'.*U\+00C4"),
    ("G1 X1 G", r"line 4: cannot read 'G': letter G is not followed by a number"),
    ("G1 X1 / Y2", r"line 4: .*block delete '/' is only allowed at the start"),
    ("N4.5 G1 X1", r"line 4 \(N4\): N number N4.5 must be a whole number"),
    ("G80 X1", r"line 4: G80 with axis words \(X1\)"),
    ("G53 G1 Z0", r"line 4: G53 \(machine coordinates\) is only read with G0"),
    ("H1", r"line 4: H1: H is only read with G43"),
    ("M6", r"line 4: M6 without a tool selected"),
    ("O200", r"line 4: O200: an O word is only read as the program number"),
    ("T1.5", r"line 4: T1.5: tool number must be a whole number"),
    ("G1 X" + "9" * 400, r"line 4: X9+: number too large"),
    ("S-100", r"line 4: S-100: spindle speed must be >= 0"),
])
def test_refused_with_line_and_word(block, pattern):
    with pytest.raises(InputError, match=pattern) as exc:
        parse_gcode(HEAD + block + "\nM30\n", source="job.nc")
    assert str(exc.value).startswith("job.nc line 4")


def test_missing_feed_before_first_feed_move():
    with pytest.raises(InputError, match=r"line 3 \(N30\): feed move without a feed rate"):
        parse_gcode("G21 G90\nG0 X0 Y0 Z0\nN30 G1 X5\n")
    with pytest.raises(InputError, match=r"line 2: feed move without a feed rate"):
        parse_gcode("G0 X0 Y0 Z0\nG2 X10 I5\n")


def test_feed_move_from_unknown_start_refused_where_it_cannot_be_an_approach():
    # an arc needs its start for its centre
    with pytest.raises(InputError, match=r"line 2: G2 .*Z unknown since the program start.*"
                                         r"an arc's centre needs its start"):
        parse_gcode("G0 X0 Y0\nG2 X10 I5 F100\n")
    # the unknown axes must be given on the line (in absolute coordinates)
    with pytest.raises(InputError, match=r"line 4: G1 .*Y, Z unknown since the tool change at "
                                         r"line 3.*does not give Y, Z"):
        parse_gcode("G0 X0 Y0 Z0\nT2\nM6\nG1 X1 F100\n")
    with pytest.raises(InputError, match=r"line 2: G1 .*does not give Z in absolute"):
        parse_gcode("G0 X0 Y0\nG91 G1 X1 Y1 Z-1 F100\n")


def test_start_position_option_and_units_before_first_move():
    prog = parse_gcode("G1 X1 F60\nM30\n", start_position=(0.0, 0.0, 0.0))
    assert prog.moves[0].start == (0, 0, 0)
    assert parse_gcode("G21\nG20\nG0 X0 Y0 Z0\nG20 G0 X1\nM30").units == "inch"


def test_axis_words_without_motion_mode():
    with pytest.raises(InputError, match=r"line 1: axis words \(X1\) without an active motion"):
        parse_gcode("X1\n")
    with pytest.raises(InputError, match=r"line 2: axis words \(Y2\) .*give one"):
        parse_gcode("G80\nY2\n")


def test_arc_tolerance_is_a_parameter():
    # four decimals: the rounding allowance (2.8e-4 mm) is below both tolerances
    text = HEAD + "G2 X10.0000 Y10.0000 I10.0000 J0.0100\nM30\n"
    prog = parse_gcode(text, arc_tolerance_mm=0.02)
    assert prog.moves[-1].end_radius_mm == pytest.approx(9.99)
    assert not any("arc radii checked" in w for w in prog.warnings)
    with pytest.raises(InputError, match=r"end radius 9.9900 mm .*tolerance 0.005 mm: "
                                         r"path.arc_tolerance_mm"):
        parse_gcode(text, arc_tolerance_mm=0.005)


def test_inch_arc_tolerance_in_mm():
    # 0.001 in = 0.0254 mm radius mismatch: over 2 sqrt(2) x 0.0001 in = 0.0072 mm, under
    # an arc_tolerance_mm of 0.03 (millimetres, not inches)
    text = "G20\nG0 X0 Y0 Z0\nG2 X1.0000 Y1.0000 I1.0000 J0.0010 F10\n"
    with pytest.raises(InputError, match="not on one circle.*tolerance 0.007184 mm: 2\\*sqrt"):
        parse_gcode(text)
    assert parse_gcode(text, arc_tolerance_mm=0.03).moves[-1].radius_mm == pytest.approx(
        25.4, abs=1e-3)


def test_g80_keeps_the_motion_mode_as_on_fanuc():
    """Fanuc/Haas posts write G80 in the safety line and continue with bare coordinates; G80
    cancels canned cycles only (group 09 there), so G1 stays modal."""
    prog = parse_gcode("G0 X0 Y0 Z0\nG1 X1 F100\nG80\nY2\nM30\n")
    assert [m.end for m in prog.moves] == [(1, 0, 0), (1, 2, 0)]
    assert prog.moves[1].kind.value == "line"


def test_home_return_without_intermediate_move_is_not_a_zero_length_note():
    prog = parse_gcode("G0 X0 Y0 Z0\nG1 X1 F100\nG28 G91 Z0\nG90\nM30\n")
    assert not any("zero-length" in w for w in prog.warnings)
    assert any("G28" in w for w in prog.warnings)

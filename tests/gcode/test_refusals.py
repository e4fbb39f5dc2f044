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
    ("G2 X10 Y10 I10 J0.01", r"line 4: G2: start and end are not on one circle: start radius "
                             r"10.0000 mm, end radius 9.9900 mm"),
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
    ("G4 P1", r"line 4: G4: dwell"),
    ("G92 X0", r"line 4: G92"),
    ("G64 P0.01", r"line 4: G64: G code not supported"),
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
    ("G43 Z1", r"line 4: G43 without an H word"),
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


def test_feed_move_from_unknown_start():
    with pytest.raises(InputError, match=r"line 1: G1 from a position .*X, Y, Z unknown since "
                                         r"the program start"):
        parse_gcode("G1 X1 Y1 Z1 F100\n")
    with pytest.raises(InputError, match=r"line 2: G2 .*Z unknown"):
        parse_gcode("G0 X0 Y0\nG2 X10 I5 F100\n")
    with pytest.raises(InputError, match=r"line 4: G1 .*tool change at line 3"):
        parse_gcode("G0 X0 Y0 Z0\nT2\nM6\nG1 X1 F100\n")


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
    text = HEAD + "G2 X10 Y10 I10 J0.01\nM30\n"
    prog = parse_gcode(text, arc_tolerance_mm=0.02)
    assert prog.moves[-1].end_radius_mm == pytest.approx(9.99)
    with pytest.raises(InputError, match=r"end radius 9.9900 mm .*tolerance 0.005 mm"):
        parse_gcode(text, arc_tolerance_mm=0.005)


def test_inch_arc_tolerance_in_mm():
    # 0.0001 in = 0.00254 mm radius mismatch: over the 0.002 mm default
    with pytest.raises(InputError, match="not on one circle"):
        parse_gcode("G20\nG0 X0 Y0 Z0\nG2 X1 Y1 I1 J0.0001 F10\n")


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

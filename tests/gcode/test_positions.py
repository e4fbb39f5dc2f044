"""Unknown positions: feed lines as approaches (start from the end), G53 and G28 retracts."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.gcode import MoveCategory, MoveKind, parse_gcode


def test_first_feed_move_of_a_program_is_an_approach():
    prog = parse_gcode("G21 G90\nS1000 M3\nG1 X1 Y2 Z-1 F100\nG1 X5\nM30\n")
    # start fully unknown: taken from the end, no length; the next move carries the approach
    (m,) = prog.moves
    assert m.start == (1, 2, -1) and m.end == (5, 2, -1) and m.approach
    (note,) = [w for w in prog.warnings if "approach" in w]
    assert note.startswith("1 feed move(s) from a position the reader does not know")
    assert note.endswith("(lines 3)")


def test_after_m6_only_the_unknown_axes_come_from_the_end():
    """CAMotics' buildbotics: ``M6``, ``G0 X144 Y13.98``, ``G1 Z-1.5``: Z from the end."""
    text = ("G21\nG0 X0 Y0 Z3\nG1 X1 F100\nM3 S10000\nT2 M6\nG0 X144 Y13.98\n"
            "G1 X146 Z-1.5\nG1 X148\nM30\n")
    prog = parse_gcode(text, source="b.nc")
    ramp = prog.moves[-2]
    assert ramp.line == 7 and ramp.approach
    assert ramp.start == (144, 13.98, -1.5) and ramp.end == (146, 13.98, -1.5)
    assert ramp.category is MoveCategory.CUT
    assert not prog.moves[-1].approach and not prog.moves[0].approach
    assert prog.moves[-1].start == ramp.end


def test_approach_plunge_without_length_hands_the_flag_on():
    prog = parse_gcode("G0 Z3\nT1 M6\nM3\nG0 X10 Y5\nG1 Z-1.5 F100\nG1 X12\nG1 X14\nM30\n")
    first, second = prog.moves
    assert first.line == 6 and first.approach and first.start == (10, 5, -1.5)
    assert not second.approach
    assert not any("zero-length" in w for w in prog.warnings)


def test_rapids_from_unknown_positions_stay_omitted():
    prog = parse_gcode("G0 X1 Y1\nG0 Z5\nG0 X2\nM30\n")
    assert [m.line for m in prog.moves] == [3]
    assert any("2 rapid(s) from a position" in w and "(lines 1, 2)" in w
               for w in prog.warnings)


def test_arc_from_unknown_start_still_refused():
    with pytest.raises(InputError, match=r"line 5 \(N130\): G3 from a position .*Z unknown since "
                                         r"the tool change at line 3.*centre needs its start"):
        parse_gcode("G21 G90\nG0 X0 Y0 Z0\nM06 T1 F5840\nN0100 G00 X164.08 Y167.1\n"
                    "N130 G03 X163.1598 Y168.0227 I-0.9220 J0.0000\n")


@pytest.mark.parametrize("g53", ["G53 G0 Z0.", "G0 G53 Z0.", "G53 G00 X0 Y0 Z0"])
def test_g53_retract_note_says_what_is_assumed(g53):
    text = f"G0 X0 Y0 Z5\nG1 X1 F100\n{g53}\nG0 X3 Y3\nG0 Z5\nG1 X4\nM30\n"
    prog = parse_gcode(text)
    (note,) = [w for w in prog.warnings if "G53" in w]
    assert ("treated as a retract to a safe height the reader does not know; the path links "
            "through the air at the program's clearance height") in note
    assert "(lines 3)" in note
    assert [m.line for m in prog.moves] == [2, 6]  # line 1 and 4, 5: rapids from unknown


def test_g53_refusals_stay():
    with pytest.raises(InputError, match=r"line 2: G53 in incremental mode \(G91\)"):
        parse_gcode("G0 X0 Y0 Z0\nG91 G53 G0 Z0\n")
    with pytest.raises(InputError, match=r"line 2: G53 \(machine coordinates\) is only read "
                                         r"with G0"):
        parse_gcode("G0 X0 Y0 Z0\nG53 G1 Z0 F100\n")
    with pytest.raises(InputError, match=r"line 3: G53 \(machine coordinates\) is only read "
                                         r"with G0: write G53 G0"):
        parse_gcode("G0 X0 Y0 Z0\nG1 X1 F100\nG53 Z0\n")


def test_feed_after_g53_with_z_unknown_is_an_approach_in_xy():
    prog = parse_gcode("G0 X0 Y0 Z5\nG1 X1 F100\nG53 G0 Z0.\nG1 X2 Y2 Z-1\nM30\n")
    m = prog.moves[-1]
    assert m.approach and m.start == (1, 0, -1) and m.end == (2, 2, -1)


coord = st.integers(-5000, 5000).map(lambda i: i / 100)


@settings(max_examples=100, deadline=None)
@given(st.tuples(coord, coord, coord), st.tuples(coord, coord, coord),
       st.sets(st.sampled_from("XYZ"), min_size=1, max_size=3))
def test_approach_start_is_the_known_axes_of_before_and_the_rest_of_the_end(before, end, lost):
    """Independent: the start is the previous position on the known axes, the end on the
    others; everything else about the move is as for a known start."""
    lost_text = " ".join(f"{a}0" for a in sorted(lost))
    text = (f"G0 X{before[0]} Y{before[1]} Z{before[2]}\nG28 G91 {lost_text}\nG90\n"
            f"M3 S1000\nG1 X{end[0]} Y{end[1]} Z{end[2]} F100\nG1 X{end[0] + 1}\nM30\n")
    prog = parse_gcode(text)
    expected = tuple(e if a in lost else b for a, b, e in zip("XYZ", before, end, strict=True))
    feeds = [m for m in prog.moves if m.kind is MoveKind.LINE]
    assert feeds[0].start == expected
    has_length = math.dist(expected, end) > 1e-6
    assert feeds[0].approach
    assert feeds[0].end == (end if has_length else (end[0] + 1, end[1], end[2]))
    assert len(feeds) == 1 + has_length

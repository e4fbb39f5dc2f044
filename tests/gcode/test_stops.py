"""Safety lines, exact stops (G61, G61.1, G9), blending (G64 P), dwells (G4), M0/M1/M6 stops."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.gcode import MoveKind, StopKind, parse_gcode

# the tool change stop is on line 2; the rapid from the unknown position is not a move
START = "G21 G90 G17\nT1 M6\nS9000 M3\nG0 X0 Y0 Z0\nF600\n"


def body_stops(body: str, **kw):
    """Program = START + body + M30; its stops after the tool change, and its moves."""
    prog = parse_gcode(START + body + "\nM30\n", source="s.nc", **kw)
    assert prog.stops[0].kind is StopKind.TOOL_CHANGE and prog.stops[0].line == 2
    return prog, prog.stops[1:]


@pytest.mark.parametrize("line", [
    "N1 G00 G17 G21 G40 G49 G80 G90",  # Fanuc / Haas safety line
    "G0 G17 G40 G49 G80 G90 G94",  # Mastercam
    "G90 G94 G17 G91.1", "G90.1", "G91.1", "G40", "G49", "M7", "M8", "M9",
    "G43 H1", "G0 G43 Z15. H1", "G80 G01", "G01 G80", "G98", "G99", "G92.1", "G92.2", "G53",
])
def test_safety_lines_read(line):
    prog = parse_gcode(f"{line}\nG0 X0 Y0 Z5\nG1 X1 F100\nM30\n")
    assert prog.moves[-1].end == (1, 0, 5)


def test_g80_with_a_motion_code_is_a_no_op_cancel():
    """The motion code of the block wins whichever order they are written in."""
    prog = parse_gcode("G0 X0 Y0 Z0\nG1 G80 X1 F100\nG80 G0 X2\nY1\nM30\n")
    assert [m.kind for m in prog.moves] == [MoveKind.LINE, MoveKind.RAPID, MoveKind.RAPID]
    with pytest.raises(InputError, match=r"line 1: G80 and G80: two G codes"):
        parse_gcode("G80 G80\n")


def test_g43_without_h_takes_the_tool_in_the_spindle():
    """LinuxCNC reads G43 alone as the offset of the loaded tool."""
    prog = parse_gcode("T3 M6\nG43\nG0 X0 Y0 Z0\nG1 X1 F100\nM30\n")
    assert prog.moves[-1].length_offset == 3


def test_g61_every_move_ending_while_active_stops():
    prog, stops = body_stops("G1 X1\nG61 X2\nG0 Z5\nG61.1 G1 Z4\nG64\nX5\nG61 X6\n")
    # moves: X1 (0), X2 (1), Z5 rapid (2), Z4 (3), X5 (4), X6 (5)
    assert len(prog.moves) == 6
    assert [(s.kind, s.after_move, s.line) for s in stops] == [
        (StopKind.EXACT, 1, 7), (StopKind.EXACT, 2, 8), (StopKind.EXACT, 3, 9),
        (StopKind.EXACT, 5, 12)]
    assert stops[0].text == "G61 X2" and stops[0].hold_s == 0


def test_g9_stops_its_block_only_and_nothing_without_a_move():
    prog, stops = body_stops("G1 X1\nG9 X2\nX3\nG9\nG9 X3\n")
    assert [(s.kind, s.after_move) for s in stops] == [(StopKind.EXACT, 1)]
    assert len(prog.moves) == 3  # the last G9 X3 has no length: no move, no stop


def test_g64_p_sets_the_tolerance_of_later_moves_in_mm():
    prog, _ = body_stops("G1 X1\nG64 P0.05 X2\nX3\nG64 P0.01 Q0.005\nX4\nG64\nX5\nG64 P0.2\n"
                         "G61 X6\nG64 P0\nX7")
    tol = [m.blend_tolerance_mm for m in prog.moves]
    assert tol == [None, 0.05, 0.05, 0.01, None, None, None]  # G61 and G64 P0 reset it
    assert any("G64 Q" in w and "not used" in w and "(lines 9)" in w for w in prog.warnings)
    inch = parse_gcode("G20\nG0 X0 Y0 Z0\nG64 P0.001\nG1 X1 F10\nM30\n")
    assert inch.moves[-1].blend_tolerance_mm == pytest.approx(0.0254)


@pytest.mark.parametrize(("block", "units", "hold"), [
    ("G4 P1.5", "s", 1.5), ("G04 P2", "s", 2.0), ("G4 P0", "s", 0.0),
    ("G4 P1000", "ms", 1.0), ("G4 P250", "ms", 0.25),
    ("G4 X1.5", "s", 1.5), ("G4 X1.5", "ms", 1.5),  # Fanuc X is seconds
])
def test_dwell_hold_in_seconds(block, units, hold):
    _, stops = body_stops(f"G1 X1\n{block}\nX2", dwell_p_units=units)
    assert [(s.kind, s.after_move, s.line) for s in stops] == [(StopKind.DWELL, 0, 7)]
    assert stops[0].hold_s == pytest.approx(hold)


def test_dwell_large_whole_p_in_seconds_is_noted_with_the_field():
    prog, _ = body_stops("G4 P1000\nG4 P100.\nG4 P99\nG4 P150.5")
    (note,) = [w for w in prog.warnings if "G4 P" in w]
    assert "path.dwell_p_units" in note and "lines 6, 7)" in note
    prog, _ = body_stops("G4 P1000", dwell_p_units="ms")
    assert not any("dwell_p_units" in w for w in prog.warnings)
    with pytest.raises(ValueError, match="dwell_p_units"):
        parse_gcode("G4 P1\n", dwell_p_units="min")


def test_dwell_then_motion_in_one_block_as_rs274():
    """LinuxCNC's skeleton program: ``G04 P.001 G0 X1.0 Y1.0``: dwell first, then the move."""
    prog, stops = body_stops("G1 X1\nG04 P.001 G0 X5 Y1")
    assert stops[0].kind is StopKind.DWELL and stops[0].after_move == 0
    assert prog.moves[-1].end == (5, 1, 0) and prog.moves[-1].kind is MoveKind.RAPID


def test_program_stops_after_the_motion_and_tool_change_before():
    prog, stops = body_stops("G1 X1\nX2 M0\nM01\nG0 Z5\nT2 M6\nG0 X0 Y0 Z5\nG1 Z0")
    assert [(s.kind, s.after_move, s.line) for s in stops] == [
        (StopKind.PROGRAM_STOP, 1, 7), (StopKind.OPTIONAL_STOP, 1, 8),
        (StopKind.TOOL_CHANGE, 2, 10)]  # moves: X1, X2, Z5, (rapid omitted), Z0
    assert not any("program stop" in w for w in prog.warnings)
    first = parse_gcode("T1 M6\nM0\nM30\n").stops
    assert [(s.kind, s.after_move) for s in first] == [
        (StopKind.TOOL_CHANGE, -1), (StopKind.PROGRAM_STOP, -1)]


def test_order_within_one_block():
    """M6, then G4, then the move (its exact stop), then M0, as RS-274/NGC orders them."""
    _, stops = body_stops("G1 X1\nG4 P1 G9 G1 X2 M0\nT2 M6 G4 P2 M1")
    assert [(s.kind, s.after_move, s.line) for s in stops] == [
        (StopKind.DWELL, 0, 7), (StopKind.EXACT, 1, 7), (StopKind.PROGRAM_STOP, 1, 7),
        (StopKind.TOOL_CHANGE, 1, 8), (StopKind.DWELL, 1, 8), (StopKind.OPTIONAL_STOP, 1, 8)]


_OPS = st.sampled_from(["line", "line", "line", "G61", "G61.1", "G64", "G9", "G4", "M0", "M1",
                        "rapid"])


@settings(max_examples=120, deadline=None)
@given(st.lists(_OPS, max_size=25))
def test_stops_match_an_independent_model(ops):
    """Stops against a plain model of the rules: index of the last move, kind, order."""
    lines, expected = [], []
    n_moves, exact, x = 0, False, 0
    for op in ops:
        if op in ("line", "rapid", "G9"):
            x += 1
            lines.append(f"{'G0' if op == 'rapid' else 'G1'}{' G9' if op == 'G9' else ''} X{x}")
            n_moves += 1
            if exact or op == "G9":
                expected.append((StopKind.EXACT, n_moves - 1))
        elif op in ("G61", "G61.1", "G64"):
            exact = op != "G64"
            lines.append(op)
        elif op == "G4":
            lines.append("G4 P0.5")
            expected.append((StopKind.DWELL, n_moves - 1))
        else:
            lines.append(op)
            expected.append((StopKind.PROGRAM_STOP if op == "M0" else StopKind.OPTIONAL_STOP,
                             n_moves - 1))
    prog, stops = body_stops("\n".join(lines))
    assert len(prog.moves) == n_moves
    assert [(s.kind, s.after_move) for s in stops] == expected
    assert all(s.hold_s == (0.5 if s.kind is StopKind.DWELL else 0) for s in stops)

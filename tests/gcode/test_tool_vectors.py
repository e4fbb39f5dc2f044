"""Five-axis G-code with tool vectors: Fanuc G43.5 I J K and Sinumerik TRAORI A3= B3= C3=.

Expected values are computed here independently (numpy normalisation, the lateral distance
of a line from its tool axis by a cross product), not with the reader's helpers.

Semantics and sources (see feedopt/gcode/interpreter.py):
- Fanuc Series 15i connection manual B-63323EN-1/03, 10.4 (G43.5 I_ J_ K_ H_ Q_): when I, J
  and K are all omitted the previous vector is used; an omitted one of them is 0.
- Fanuc Series 30i tool centre point control manual A-79348E: I J K is the tool direction at
  the block end in the programming frame; G2/G3 under G43.5 take R only (not read here).
- Mitsubishi M700V 13.24: a block with only I J K turns the tool about its tip.
- Siemens 840D programming manual 6FC5398-2BP10, TRAORI: A3 B3 C3 point towards the tool
  adapter, their length is meaningless, components not programmed are 0.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.gcode import MoveCategory, MoveKind, parse_gcode
from feedopt.gcode.lexer import lex_line

Z = (0.0, 0.0, 1.0)


def unit(*v):
    a = np.asarray(v, dtype=float)
    return a / np.linalg.norm(a)


def category(d, axis):
    """Independent PLUNGE/RETRACT/CUT of a feed line ``d`` with tool vector ``axis``."""
    d, axis = np.asarray(d, float), np.asarray(axis, float)
    if np.linalg.norm(np.cross(d, axis)) <= 1e-6:
        return MoveCategory.PLUNGE if d @ axis < 0 else MoveCategory.RETRACT
    return MoveCategory.CUT


# Imitates a LinuxCNC RTCP-fork MDI test found in the public code index (linuxcncrsh script:
# "G43.5 H10", "G1 F2000 X0 Y0 Z0 I0.5 J0 K0.866025"; its rotary "A0 C0" words are left out,
# feedopt refuses them) and the igesio NC-interpreter test program ("G90 G54 / T1 M06 /
# G43.5 H1 / G01 X1. Y2. Z3. I0. J0. K1. F100 / M30").
FANUC = """%
O2001 (G43.5 TOOL VECTORS)
N10 G90 G21 G17 G40 G49 G80
N20 T10 M06
N30 S12000 M03
N40 G54
N50 G43.5 H10
N60 G00 X0. Y0. Z50. I0. J0. K1.
N70 G01 Z0. F2000.
N80 X20. I0.5 J0. K0.866025
N90 X40.
N100 Y10. I-0.2 J0.3 K2.
N110 I0. J0.5 K0.866025
N120 X40. Y10. Z0. I0.1 J0. K1.
N130 X60. Y10. Z0.
N140 Z-5. I0. J0. K1.
N150 Z20.
N160 G49
N170 G00 Z60.
N180 M30
%
"""


def _fanuc():
    """The program and its moves by N number."""
    p = parse_gcode(FANUC, "g435.nc")
    return p, {m.n_number: m for m in p.moves}


def test_fanuc_program_vectors_are_normalised_and_modal():
    p, n = _fanuc()
    assert p.five_axis
    tilt = unit(0.5, 0.0, 0.866025)
    assert np.allclose(n[80].axis_end, tilt, atol=1e-15)
    assert np.allclose(n[80].axis_start, Z)
    # N90 writes no vector: it keeps N80's (modal)
    assert n[90].axis_start == n[90].axis_end == n[80].axis_end
    # N100: a non-unit vector is normalised
    assert np.allclose(n[100].axis_end, unit(-0.2, 0.3, 2.0), atol=1e-15)
    for m in p.moves:
        for a in (m.axis_start, m.axis_end):
            assert math.isclose(math.hypot(*a), 1.0, abs_tol=1e-15)


def test_a_block_that_only_turns_the_tool_carries_into_the_next_move():
    p, n = _fanuc()
    # N110 (vector only) and N120 (zero length, another vector) are not moves; N130 starts
    # from N120's vector and keeps it
    assert 110 not in n and 120 not in n
    assert np.allclose(n[130].axis_start, unit(0.1, 0.0, 1.0))
    assert n[130].axis_end == n[130].axis_start
    assert any("turned in place" in w and "(lines 13, 14)" in w for w in p.warnings)


def test_categories_follow_the_tool_vector():
    p, n = _fanuc()
    for m in p.moves:
        if m.kind is MoveKind.LINE:
            d = np.subtract(m.end, m.start)
            assert m.category is category(d, m.axis_end), m.line
    assert n[70].category is MoveCategory.PLUNGE  # along -Z, tool along +Z
    assert n[80].category is MoveCategory.CUT
    # N140: straight down while the tool turns from (0.1, 0, 1) to +Z: a plunge along its end
    assert n[140].category is MoveCategory.PLUNGE
    assert n[150].category is MoveCategory.RETRACT


def test_tilted_plunge_and_retract_along_the_vector():
    a = unit(1.0, -2.0, 2.0)
    text = ("G21 G90\nG0 X0 Y0 Z50\nS1000 M3\nG43.5 H1\n"
            f"G1 X10 Y10 Z10 I{a[0]:.9f} J{a[1]:.9f} K{a[2]:.9f} F500\n"
            f"G1 X{10 - 5 * a[0]:.9f} Y{10 - 5 * a[1]:.9f} Z{10 - 5 * a[2]:.9f}\n"
            f"G1 X{10 + 3 * a[0]:.9f} Y{10 + 3 * a[1]:.9f} Z{10 + 3 * a[2]:.9f}\n"
            "G1 Z0\nM30\n")
    cats = [m.category for m in parse_gcode(text).moves]
    assert cats == [MoveCategory.CUT, MoveCategory.PLUNGE, MoveCategory.RETRACT,
                    category((0, 0, -10 - 3 * a[2]), a)]
    assert cats[3] is MoveCategory.CUT  # straight down is not along this tilted tool


def test_first_vector_and_plus_z_before_any():
    p = parse_gcode("G21 G90\nG0 X0 Y0 Z10\nG0 X1\nG43.5 H1\nG0 X5\nG0 X6 J1\nM30\n")
    a, b, c = p.moves
    assert a.axis_start == a.axis_end == Z  # outside G43.5, in a five-axis program
    assert b.axis_start == b.axis_end == Z  # under G43.5 before any vector: +Z, noted
    assert c.axis_start == Z and c.axis_end == (0.0, 1.0, 0.0)  # omitted I and K are 0
    assert any("before any tool vector" in w and "(lines 5)" in w for w in p.warnings)
    # the first move of a program starts with its own vector
    q = parse_gcode("G21 G90\nG43.5 H1\nG0 X5 I1 K1\nM30\n", start_position=(0, 0, 10))
    assert q.moves[0].axis_start == q.moves[0].axis_end
    assert np.allclose(q.moves[0].axis_start, unit(1, 0, 1))
    # a rapid from an unknown position is not listed, but its vector is where the next starts
    r = parse_gcode("G21 G90\nG43.5 H1\nG0 X0 Y0 Z10 I1 K1\nG0 X5 I0 K1\nM30\n")
    assert np.allclose(r.moves[0].axis_start, unit(1, 0, 1)) and r.moves[0].axis_end == Z


def test_inch_scales_positions_not_vectors():
    mm = parse_gcode("G21 G90\nG0 X0 Y0 Z1\nG43.5 H1\nG1 X1 Y2 Z3 I1 J2 K2 F10\nM30\n")
    inch = parse_gcode("G20 G90\nG0 X0 Y0 Z1\nG43.5 H1\nG1 X1 Y2 Z3 I1 J2 K2 F10\nM30\n")
    (m,), (n,) = mm.moves, inch.moves
    assert np.allclose(np.array(m.end) * 25.4, n.end)
    assert n.axis_end == m.axis_end
    assert np.allclose(n.axis_end, np.array([1, 2, 2]) / 3.0)
    assert math.isclose(n.feed_mm_s, 10 * 25.4 / 60)


def test_g91_moves_incrementally_but_the_vector_is_a_direction():
    # the LinuxCNC RTCP fork's test: "a direction is not incremental" (G91 G1 X0 I J K)
    p = parse_gcode("G21 G90\nG0 X0 Y0 Z0\nG43.5 H1\nG1 X1 I0 J0 K1 F100\n"
                    "G91 G1 X1 I0 J0.6 K0.8\nG1 X1 I0 J0.6 K0.8\nM30\n")
    assert [m.end[0] for m in p.moves] == [1.0, 2.0, 3.0]
    assert p.moves[1].axis_end == p.moves[2].axis_end == (0.0, 0.6, 0.8)


def test_vector_decimals_do_not_set_the_resolution():
    p = parse_gcode("G21 G90\nG0 X0 Y0 Z0\nG43.5 H1\nG1 X1.25 I0.1234567 K0.9876543 F100\n"
                    "M30\n")
    assert math.isclose(p.resolution_mm, 0.01)


def test_g49_ends_vectors_and_three_axis_programs_have_none():
    p, n = _fanuc()
    last = p.moves[-1]
    assert last.n_number == 170 and last.axis_start == last.axis_end == Z
    assert any("five-axis program" in w for w in p.warnings)
    three = parse_gcode("G21 G90\nG0 X0 Y0 Z5\nG43 H1\nG1 Z0 F100\nG1 X5\nG49\nM30\n")
    assert not three.five_axis
    assert all(m.axis_start is None and m.axis_end is None for m in three.moves)
    tilted = parse_gcode("G21 G90\nG0 X0 Y0 Z5\nG43.5 H1\nG1 X5 I1 K1 F9\nG49\nG0 Z9\nM30\n")
    assert tilted.moves[-1].axis_start == Z
    assert any("line 5: G49 ends G43.5 with the tool vector (0.7071, 0, 0.7071)" in w
               for w in tilted.warnings)


# Imitates the output of Autodesk's Siemens SINUMERIK 840D post (public .cps in the code
# index: A3=/B3=/C3= with 6 decimals on "G94 G1 X Y Z A3= B3= C3= F" lines after TRAORI) and
# the 840D manual's ORIVECT example ("N50 A3=0 B3=0 C3=1", "N60 A3=0 B3=1 C3=1"); its T=,
# D1 and CYCLE832 lines are left out (feedopt refuses them).
SIEMENS = """N10 G90 G17 G21
N20 T1 M6
N30 S9000 M3
N40 G0 X0 Y0 Z50
N50 TRAORI(1)
N60 ORIWKS
N70 ORIVECT
N80 G0 X10. Y0. Z20. A3=0. B3=0. C3=1.
N90 G94 G1 Z0. F1200.
N100 G1 X20. A3=0. B3=0.447214 C3=0.894427
N110 A3=0 B3=1 C3=1
N120 G2 X30. Y0. I5. J0.
N130 G1 X40. C3=1.
N140 TRAFOOF
N150 G0 Z50.
N160 M30
"""


def test_sinumerik_traori_vectors():
    p = parse_gcode(SIEMENS, "traori.mpf")
    by_line = {m.line: m for m in p.moves}
    assert np.allclose(by_line[10].axis_end, unit(0, 0.447214, 0.894427), atol=1e-15)
    # N110 turns in place; the arc (read under TRAORI) starts and ends with it
    arc = by_line[12]
    assert arc.kind is MoveKind.ARC and arc.category is MoveCategory.CUT
    assert np.allclose(arc.axis_start, unit(0, 1, 1)) and arc.axis_end == arc.axis_start
    assert by_line[13].axis_end == Z  # A3 and B3 not written: 0
    assert by_line[15].axis_start == by_line[15].axis_end == Z


def test_lexer_reads_sinumerik_words_only_where_plain_words_fail():
    b = lex_line("N100 G1 X20. A3=0. B3 = -.5 C3=+1 ; comment", 3)
    assert [(w.letter, w.value, w.text) for w in b.words[3:]] == [
        ("A3", 0.0, "A3=0."), ("B3", -0.5, "B3=-.5"), ("C3", 1.0, "C3=+1")]
    assert [w.letter for w in lex_line("TRAORI(1)", 1).words] == ["TRAORI"]
    assert [w.text for w in lex_line("G1 X1 A3", 1).words] == ["G1", "X1", "A3"]


HEAD = "G21 G90 G17\nG0 X0 Y0 Z0\nF600\nG43.5 H1\n"  # the refused block is always line 5


@pytest.mark.parametrize(("block", "pattern"), [
    ("G1 X1 I0 J0 K0", r"line 5: I0 J0 K0: the tool vector has no direction"),
    ("N50 I0. K0.", r"line 5 \(N50\): I0. K0.: the tool vector has no direction"),
    ("G2 X10 I5 J0", r"line 5: G2 under G43.5 \(line 4\): I, J, K are the tool vector"),
    ("G3 X10 R5", r"line 5: G3 under G43.5"),
    ("G1 X1 A30", r"line 5: A30: rotary .*need the machine's kinematics.*G43.5 with I J K"),
    ("G1 X1 B3=1", r"line 5: B3=1: A3=, B3=, C3= .*only read after TRAORI"),
    ("TRAORI", r"line 5: TRAORI while G43.5 \(line 4\) is in force: end it with G49"),
    ("G28 Z0 K1", r"line 5: a tool vector with G28"),
    ("G53 G0 Z0 K1", r"line 5: a tool vector with G53"),
    ("G43.5 H1 Q2", r"line 5: Q2 with G43.5: the tool inclination angle"),
    ("G49 G43.4 H1", r"line 5: G43.4: tool centre point control type 1"),
    ("G1 X1 R2", r"line 5: R2: I, J, K and R are only read with G2/G3"),
])
def test_refusals_name_the_line(block, pattern):
    with pytest.raises(InputError, match=pattern):
        parse_gcode(HEAD + block + "\nM30\n")


def test_refusals_without_g435():
    with pytest.raises(InputError, match=r"line 2: A3=1: A3=, B3=, C3="):
        parse_gcode("G21\nG1 X1 A3=1 F10\n")
    with pytest.raises(InputError, match=r"line 3: G43.5 while TRAORI \(line 2\)"):
        parse_gcode("G21\nTRAORI\nG43.5 H1\n")
    with pytest.raises(InputError, match=r"line 3: A3=0 B3=0 C3=0: the tool vector has no"):
        parse_gcode("G21\nTRAORI\nG1 X1 A3=0 B3=0 C3=0 F10\n")


# --- property: random G43.5 programs parse or raise InputError only ------------------------

num = st.one_of(st.integers(-20, 20).map(str),
                st.floats(-50, 50, allow_nan=False).map(lambda x: f"{x:.6f}"),
                st.sampled_from(["0", "0.", "-0", ".5", "-.25"]))
vec_word = st.builds(lambda ls, vs: " ".join(f"{a}{b}" for a, b in zip(ls, vs, strict=False)),
                     st.lists(st.sampled_from("IJK"), min_size=1, max_size=3, unique=True),
                     st.lists(num, min_size=3, max_size=3))
pos_words = st.builds(lambda ls, vs: " ".join(f"{a}{b}" for a, b in zip(ls, vs, strict=False)),
                      st.lists(st.sampled_from("XYZ"), max_size=3, unique=True),
                      st.lists(num, min_size=3, max_size=3))
move = st.builds(lambda g, p, v: " ".join([g, p, v]),
                 st.sampled_from(["G0", "G1", "G1", "", "G91 G1", "G90 G1", "G28", "G53 G0"]),
                 pos_words, st.one_of(st.just(""), vec_word, vec_word))
rare = st.sampled_from(["G43.5 H1", "G49", "G43 H2", "TRAORI", "TRAFOOF", "A3=1 C3=1",
                        "M6 T2", "G2 X1 Y0 I0.5", "G3 X1 R2", "F100", "G20", "M30", "Q1", "A5",
                        "G1 X0 Y0 Z0"])
block = st.one_of(move, move, move, move, move, move, move, move, rare)


@settings(max_examples=300, deadline=None)
@given(st.lists(block, max_size=20))
def test_random_g435_programs_parse_or_raise_input_error(blocks):
    text = "G21 G90\nG0 X0 Y0 Z0\nF300 S1000 M3\nG43.5 H1\n" + "\n".join(blocks)
    try:
        p = parse_gcode(text)
    except InputError as exc:
        assert " line " in str(exc)
        return
    assert p.five_axis or not p.moves
    prev = None
    for m in p.moves:
        for a in (m.axis_start, m.axis_end):
            assert math.isclose(math.hypot(*a), 1.0, abs_tol=1e-12)
        if m.kind is MoveKind.LINE:
            assert m.category is category(np.subtract(m.end, m.start), m.axis_end)
        if prev is not None and m.axis_start != prev.axis_end:  # a turn or G49: noted
            assert any("turned in place" in w or " ends " in w for w in p.warnings)
        prev = m

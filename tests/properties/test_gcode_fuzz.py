"""Property (mutation-based; tests/gcode/test_properties.py has the generated ones): a
CAM-style program mutated line by line is parsed or refused with one InputError."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.gcode import parse_gcode

from ._support import budget, text_mutations

CAM_PROGRAM = """%
O1001 (SLOT TRIANGLE - CAM POST)
(TOOL 1: 19.05 MM FLAT END MILL)
N10 G21 G90 G94 G17 G40 G49 G80
N20 T1 M6
N30 S2500 M3
N40 G54
N50 G0 X0. Y0. Z25.
N60 G43 H1 Z5.
N70 G1 Z-1.5 F120.
N80 G1 X50.8 Y76.2 F253.8
N90 G2 X63.5 Y76.2 I6.35 J0.
N100 G1 X101.6 Y0.
N110 G3 X114.3 Y0. R6.35
N120 G1 X152.4 Y76.2 ; last line
N130 G91 G1 X10. Y-5. Z0.
N140 G90 G18 G2 X172.4 Z-1.5 I5. K0.
N150 G17 G0 Z25.
/N160 G1 X0 Y0
N170 M5
N180 G28 G91 Z0.
N190 G90
N200 M30
%
"""

ALPHABET = list("GXYZIJKRFNMSTHPOgxyz0123456789.-+ ()%;/\t\n") + ["G2", "G3", "R", "I-"]


def check(text):
    try:
        prog = parse_gcode(text, "fuzz.nc")
    except InputError as exc:
        assert str(exc).strip()
        return None
    assert prog is not None
    return prog


def test_unmutated_program_parses():
    assert check(CAM_PROGRAM).moves


@budget(300)
@given(data=st.data())
def test_mutated_program(data):
    check(data.draw(text_mutations(CAM_PROGRAM, alphabet=ALPHABET, max_mutations=6)))


@budget(100)
@given(data=st.data(), line=st.integers(0, CAM_PROGRAM.count("\n") - 1),
       word=st.sampled_from(["G2", "G3", "G91", "G90.1", "G91.1", "G18", "G19", "G20", "R0",
                             "R-1e9", "I0 J0", "F0", "F-1", "X1e308", "Z-inf", "Xnan",
                             "G1", "G0", "G28", "G43 H1", "M30", "G81", "X", "(", ")", ";",
                             "N", "G", "G999", "X1.2.3", "X--1", "F1e-300"]))
def test_word_inserted(data, line, word):
    lines = CAM_PROGRAM.splitlines(keepends=True)
    text = lines[line]
    at = data.draw(st.integers(0, len(text)))
    lines[line] = text[:at] + " " + word + " " + text[at:]
    check("".join(lines))

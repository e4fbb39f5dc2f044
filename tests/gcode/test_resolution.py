"""The program's number resolution and the arc radius tolerance it allows; the spindle rule."""

import math

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.gcode import parse_gcode


@pytest.mark.parametrize(("text", "res"), [
    ("G0 X1 Y2 Z3\n", 1.0),
    ("G0 X1.5 Y2.25 Z3.\n", 0.01),
    ("G0 X1.5 Y2.25 Z3.\nG1 X1.2500 F100.123456\n", 1e-4),  # F is not a coordinate
    ("G20\nG0 X.1234 Y0 Z0\n", 1e-4 * 25.4),
    ("G0 X0 Y0 Z0\nG2 X2 I1.000001 F1\n", 1e-6),  # I, J, K, R count
    ("G0 X0 Y0 Z0\nG4 X1.5555\nG4 P1.55555\nG64 P0.00001\nS1000.5\n", 1.0),  # dwells, P, S
    ("G21 G90\nM30\n", None),
    ("G0 X0." + "0" * 30 + "1\n", 1e-12),  # capped: beyond float noise
])
def test_resolution_is_one_unit_of_the_last_decimal(text, res):
    prog = parse_gcode(text)
    if res is None:
        assert prog.resolution_mm is None
    else:
        assert prog.resolution_mm == pytest.approx(res, rel=1e-12)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(-10**6, 10**6), st.integers(0, 6)), min_size=1,
                max_size=10), st.booleans())
def test_resolution_against_the_written_decimals(values, inch):
    """Independent: the largest count of digits after the point, as the numbers were written."""
    words = [f"X{v / 10 ** d:.{d}f}" if d else f"X{v}" for v, d in values]
    prog = parse_gcode(("G20\n" if inch else "") + "G0 " + "\nG0 ".join(words) + "\n")
    decimals = max(len(w) - w.index(".") - 1 if "." in w else 0 for w in words)
    assert prog.resolution_mm == pytest.approx(10.0 ** -decimals * (25.4 if inch else 1.0),
                                               rel=1e-12)


ARC = "G21 G90 G17\nG0 X0 Y0 Z0\nM3 S1000\nG2 X10.00 Y10.00 I10.00 J{j} F100\nM30\n"


def test_rounding_allowance_accepts_post_rounding_and_says_so_once():
    # two decimals: radii may differ by 2 sqrt(2) x 0.01 = 0.0283 mm; J0.02 moves the end
    # radius by 0.02 mm
    prog = parse_gcode(ARC.format(j="0.02") + "G2 X20.00 Y0.00 I0.00 J-10.00\n")
    (note,) = [w for w in prog.warnings if "arc radii checked" in w]
    assert "0.02828 mm, not path.arc_tolerance_mm (0.002 mm)" in note and "2 decimal" in note
    with pytest.raises(InputError, match=r"line 4: G2: start and end are not on one circle.*"
                                         r"differ by 0.0300 mm, tolerance 0.02828 mm: 2\*sqrt"
                                         r"\(2\) x the program's resolution 0.01 mm, larger "
                                         r"than path.arc_tolerance_mm 0.002 mm"):
        parse_gcode(ARC.format(j="0.03"))


def test_no_note_when_the_option_is_larger_or_there_is_no_arc():
    prog = parse_gcode(ARC.format(j="0.02"), arc_tolerance_mm=0.05)
    assert not any("arc radii checked" in w for w in prog.warnings)
    prog = parse_gcode("G0 X0.1 Y0 Z0\nG1 X1 F100\nM30\n")
    assert not any("arc radii checked" in w for w in prog.warnings)


def test_a_later_finer_coordinate_tightens_an_earlier_arc():
    """The resolution is the whole program's: an arc accepted on two decimals read so far is
    refused once a four-decimal coordinate shows the program is finer."""
    text = ARC.format(j="0.02").replace("M30\n", "G1 X10.0001\nM30\n")
    with pytest.raises(InputError, match=r"line 4: G2: start and end are not on one circle.*"
                                         r"tolerance 0.002 mm: path.arc_tolerance_mm"):
        parse_gcode(text)


def test_r_form_chord_check_uses_the_same_tolerance():
    # chord 20.04, radius 10.00: short by 0.02 mm; allowed with two decimals (0.0283 mm)
    prog = parse_gcode("G0 X0 Y0 Z0\nM3\nG2 X20.04 R10.00 F100\nM30\n")
    assert prog.moves[-1].radius_mm == pytest.approx(10.02)
    with pytest.raises(InputError, match=r"line 3: G2 R10.0000: radius 10.0000 mm is too small "
                                         r"for the chord 20.0400 mm \(end not reachable; "
                                         r"tolerance 0.002 mm: path.arc_tolerance_mm"):
        parse_gcode("G0 X0 Y0 Z0\nM3\nG2 X20.0400 R10.0000 F100\nM30\n")


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 4), st.integers(1000, 20000), st.integers(-60, 60))
def test_arc_accepted_exactly_within_the_allowance(decimals, radius_units, dj_units):
    """Independent: the radii from the written numbers; accepted iff they differ by at most
    max(0.002, 2 sqrt(2) x 10^-decimals) mm."""
    unit = 10.0 ** -decimals
    r = radius_units * unit
    j = dj_units * unit
    fmt = f".{decimals}f"
    text = (f"G0 X0 Y0 Z0\nM3\nG2 X{r:{fmt}} Y{-r:{fmt}} I{r:{fmt}} J{j:{fmt}} F100\n"
            f"M30\n")
    r0 = math.hypot(float(f"{r:{fmt}}"), float(f"{j:{fmt}}"))
    r1 = abs(float(f"{-r:{fmt}}") - float(f"{j:{fmt}}"))
    tol = max(0.002, 2 * math.sqrt(2) * unit)
    assume(abs(abs(r0 - r1) - tol) > 1e-9)
    if abs(r0 - r1) <= tol:
        assert parse_gcode(text).moves[-1].radius_mm == pytest.approx(r0)
    else:
        with pytest.raises(InputError, match="not on one circle.*path.arc_tolerance_mm"):
            parse_gcode(text)


# ------------------------------------------------------------------------------ spindle
def test_cut_after_m5_is_refused_with_the_m5_line():
    text = "G0 X0 Y0 Z0\nM3 S1000\nG1 X1 F100\nN40 M5\nG1 X2\n"
    with pytest.raises(InputError, match=r"line 5: cut with the spindle stopped \(M5 at line "
                                         r"4\)"):
        parse_gcode(text)
    with pytest.raises(InputError, match=r"line 5: cut with the spindle stopped \(M5 at line "
                                         r"4\)"):
        parse_gcode(text.replace("G1 X2", "G3 X2 R0.5"))


def test_plunge_and_retract_after_m5_and_cuts_before_any_m3_are_warnings():
    prog = parse_gcode("G0 X0 Y0 Z0\nG1 X1 F100\nM3\nG1 X2\nM5\nG1 Z1\nG1 Z0\nM4\nG1 X3\nM30\n")
    (note,) = [w for w in prog.warnings if "spindle" in w]
    assert note.startswith("3 feed move(s) with the spindle never started") and "(lines 2, 6, 7)" \
        in note
    # an M5 before the spindle ever ran is not "stopping" it: still a warning
    prog = parse_gcode("M5\nG0 X0 Y0 Z0\nG1 X1 F100\nM30\n")
    assert any("spindle never started" in w for w in prog.warnings)


def test_m3_after_m5_allows_cutting_again_and_m6_keeps_the_stop():
    parse_gcode("G0 X0 Y0 Z0\nM3\nG1 X1 F100\nM5\nM3\nG1 X2\nM30\n")
    with pytest.raises(InputError, match=r"line 6: cut with the spindle stopped \(M5 at line 3"):
        parse_gcode("G0 X0 Y0 Z0\nM3\nM5\nT2 M6\nG0 X0 Y0 Z0\nG1 X1 F100\nG1 X2\n")

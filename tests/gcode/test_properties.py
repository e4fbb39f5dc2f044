"""Properties: G91 equals G90, G20 equals G21 x 25.4, random programs raise only InputError."""

import math
from decimal import Decimal

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.gcode import MoveKind, parse_gcode, sample_move

coord = st.decimals(min_value=-200, max_value=200, places=3, allow_nan=False,
                    allow_infinity=False)
point = st.tuples(coord, coord, coord)


def _moves_equal(a, b, scale=1.0):
    assert len(a.moves) == len(b.moves)
    for m, n in zip(a.moves, b.moves, strict=True):
        assert m.kind is n.kind and m.category is n.category
        assert np.allclose(np.array(m.start) * scale, n.start, atol=1e-9)
        assert np.allclose(np.array(m.end) * scale, n.end, atol=1e-9)
        if m.kind is MoveKind.ARC:
            assert np.allclose(np.array(m.centre) * scale, n.centre, atol=1e-9)
            assert math.isclose(m.sweep_rad, n.sweep_rad, abs_tol=1e-9)


@st.composite
def paths(draw):
    """Absolute points with, per segment, a line or a quarter-circle-ish IJK arc."""
    start = draw(point)
    steps = draw(st.lists(st.tuples(point, st.sampled_from(["G1", "G2", "G3"])),
                          min_size=1, max_size=12))
    return start, steps


def _programs(start, steps):
    """The same geometry written in G90 and in G91 (arcs: centre = midpoint of the chord)."""
    absolute = [f"G21 G90 G17\nG0 X{start[0]} Y{start[1]} Z{start[2]}\nF500"]
    incremental = list(absolute)
    incremental.append("G91")
    prev = start
    for p, code in steps:
        d = tuple(b - a for a, b in zip(prev, p, strict=True))
        arc = ""
        if code != "G1":
            arc = f" I{d[0] / 2} J{d[1] / 2}"  # semicircle in XY (helical by the Z change)
        absolute.append(f"{code} X{p[0]} Y{p[1]} Z{p[2]}{arc}")
        incremental.append(f"{code} X{d[0]} Y{d[1]} Z{d[2]}{arc}")
        prev = p
    return "\n".join(absolute) + "\nM30\n", "\n".join(incremental) + "\nM30\n"


@settings(max_examples=150, deadline=None)
@given(paths())
def test_incremental_equals_absolute(path):
    a_text, i_text = _programs(*path)
    try:
        a = parse_gcode(a_text)
    except InputError as exc:  # degenerate arcs (chord 0 with centre at the start) only
        assert "centre is at the start" in str(exc)
        return
    _moves_equal(a, parse_gcode(i_text))


@settings(max_examples=150, deadline=None)
@given(paths())
def test_inch_equals_mm_times_25_4(path):
    text, _ = _programs(*path)
    inch = Decimal("25.4")

    def scaled(line: str) -> str:
        out = []
        for tok in line.split():
            if tok[0] in "XYZIJ":
                out.append(tok[0] + str(Decimal(tok[1:]) * inch))
            elif tok[0] == "F":
                out.append(tok[0] + str(Decimal(tok[1:]) * inch))
            else:
                out.append(tok)
        return " ".join(out)

    mm_text = "\n".join(scaled(line) for line in text.splitlines())
    inch_text = text.replace("G21", "G20")
    try:
        i = parse_gcode(inch_text)
    except InputError as exc:
        assert "centre is at the start" in str(exc)
        return
    m = parse_gcode(mm_text)
    assert i.units == "inch" and m.units == "mm"
    _moves_equal(i, m)
    feeds_i = np.nan_to_num(i.feeds_mm_s)
    assert np.allclose(feeds_i, np.nan_to_num(m.feeds_mm_s))


number = st.one_of(
    st.integers(-50, 50).map(str),
    st.floats(-100, 100, allow_nan=False).map(lambda x: f"{x:.4f}"),
    st.sampled_from(["0", ".5", "-.5", "5.", "+1", "1e3", "", "-", "0.0001"]),
)
letter = st.sampled_from(list("XYZIJKRFSTHGMNOPABD"))
gword = st.sampled_from(["G0", "G1", "G2", "G3", "G00", "G01", "G02", "G03", "G17", "G18",
                         "G19", "G20", "G21", "G90", "G91", "G90.1", "G91.1", "G94", "G40",
                         "G49", "G80", "G54", "G59", "G28", "G53", "G43 H1", "G41", "G81",
                         "G93", "M3", "M4", "M5", "T1 M6", "M6", "M0", "M1", "M30", "M8", "M9"])
word = st.one_of(gword, st.builds(lambda a, b: a + b, letter, number))
line = st.one_of(
    st.lists(word, max_size=6).map(" ".join),
    st.lists(word, max_size=4).map(lambda ws: "(c) " + " ".join(ws) + " ; x"),
    st.sampled_from(["%", "/G1 X1", "(open", ")", "#1=2", "", "   ", "G1 X[1]"]),
    st.text(max_size=15),
)


@settings(max_examples=400, deadline=None)
@given(st.lists(line, max_size=25), st.booleans())
def test_random_programs_raise_only_input_error(lines, prefix):
    head = "G21 G90\nG0 X0 Y0 Z0\nF300 S1000 M3\n" if prefix else ""
    try:
        prog = parse_gcode(head + "\n".join(lines))
    except InputError as exc:
        assert " line " in str(exc)
        return
    for m in prog.moves:
        assert all(math.isfinite(c) for c in m.start + m.end)
        assert m.line >= 1 and (m.feed_mm_s is None) == (m.kind is MoveKind.RAPID)
        if m.kind is MoveKind.ARC:
            assert abs(m.radius_mm - m.end_radius_mm) <= 0.002 + 1e-9
            assert 0 < m.sweep_rad <= 2 * math.pi + 1e-12
            pts = sample_move(m, 30)
            assert np.allclose(pts[0], m.start) and np.allclose(pts[-1], m.end)

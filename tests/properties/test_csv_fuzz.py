"""Property: a waypoint CSV is either an (n, 3) array of finite metres, n >= 2, or one
InputError; and what it returns builds a path or raises InputError."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.geometry.path import build_lipb_path
from feedopt.geometry.registry import blend_names
from feedopt.geometry.waypoints import COLUMNS, read_waypoints_csv
from feedopt.units import MM

from ._support import SCENARIOS, budget, text_mutations

EXAMPLE = (SCENARIOS / "waypoints" / "example.csv").read_text()

number_text = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(-1e6, 1e6).map(lambda v: f"{v:.4f}"),
    st.integers(-(10**30), 10**30).map(str),
    st.sampled_from(["nan", "NaN", "inf", "-inf", "+inf", "Infinity", "1e999", "-1e999",
                     "1e308", "-1e308", "5e-324", "1e-320", "0", "-0", "", " ", "abc", "1,5",
                     "0x1A", "1_000", "1e", "--1", "\u0661\u0662", "\u00bd", "1.5 mm",
                     "\U0001d7e3", "1e-3", "99999999999"]),
)


@st.composite
def tables(draw):
    cols = list(COLUMNS) + draw(st.lists(st.sampled_from(["id", "note", "x_mm", "F"]),
                                         max_size=2))
    cols = draw(st.permutations(cols))
    if draw(st.booleans()):
        cols = draw(st.lists(st.sampled_from(list(COLUMNS) + ["X", "x", "x_m", ""]),
                             max_size=4))  # wrong, missing or repeated header
    sep = draw(st.sampled_from([",", ",", ";", "\t", ", ", " ,"]))
    nl = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    n = draw(st.integers(0, 8))
    ncell = len(cols) + draw(st.sampled_from([0, 0, 0, -1, 1]))
    rows = [sep.join(draw(number_text) for _ in range(max(ncell, 0))) for _ in range(n)]
    lines = ([] if draw(st.integers(0, 9)) == 0 else [sep.join(cols)]) + rows
    if draw(st.booleans()):
        lines.insert(draw(st.integers(0, len(lines))), draw(st.sampled_from(
            ["# comment", "", "   ", "#x_mm,y_mm,z_mm"])))
    bom = draw(st.sampled_from(["", "", "\ufeff"]))
    return bom + nl.join(lines) + draw(st.sampled_from(["", nl]))


def check(path):
    try:
        w = read_waypoints_csv(path)
    except InputError as exc:
        assert str(exc).strip()
        return None
    assert isinstance(w, np.ndarray) and w.ndim == 2 and w.shape[1] == 3 and len(w) >= 2
    assert np.all(np.isfinite(w))
    return w


def build(w, blend, size_mm, drop):
    try:
        path = build_lipb_path(w, blend, size_mm * MM, drop_repeated=drop)
    except InputError as exc:
        assert str(exc).strip()
        return
    assert path is not None


sizes = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                  st.sampled_from([12.7, 1.0, 0.001, 1e-9, 1e9, 0.0, -1.0]))


@budget(150)
@given(text=tables())
def test_random_tables(tmp_path, text):
    p = tmp_path / "w.csv"
    p.write_text(text, encoding="utf-8")
    check(p)


@budget(100)
@given(raw=st.binary(max_size=300))
def test_random_bytes(tmp_path, raw):
    p = tmp_path / "w.csv"
    for content in (raw, EXAMPLE.encode() + raw, b"\xef\xbb\xbf" + raw):
        p.write_bytes(content)
        check(p)


@budget(100)
@given(data=st.data())
def test_mutated_example(tmp_path, data):
    text = data.draw(text_mutations(EXAMPLE, alphabet=list("0123456789.,-+eE#\n\r ;")))
    p = tmp_path / "w.csv"
    p.write_text(text, encoding="utf-8", errors="surrogatepass")
    check(p)


coordinate = st.one_of(st.floats(-1e5, 1e5), st.sampled_from(
    [0.0, 1e-9, -1e-9, 1e-300, 1e4, 99_999.0, 100_000.0, 1e5 + 1, 1e12, 1e300]))


@budget(100)
@given(points=st.lists(st.tuples(coordinate, coordinate, coordinate), min_size=2, max_size=8),
       repeat=st.booleans(), blend=st.sampled_from(blend_names()), size=sizes,
       drop=st.booleans())
def test_tables_build_a_path_or_input_error(tmp_path, points, repeat, blend, size, drop):
    if repeat:
        points = points[:1] + points
    p = tmp_path / "w.csv"
    p.write_text("x_mm,y_mm,z_mm\n" + "\n".join(",".join(map(repr, r)) for r in points) + "\n")
    w = check(p)
    if w is not None:
        assert np.allclose(w / MM, np.array(points), rtol=1e-12, atol=0)
        build(w, blend, size, drop)


@budget(40)
@given(text=tables(), blend=st.sampled_from(blend_names()), size=sizes)
def test_random_tables_build(tmp_path, text, blend, size):
    p = tmp_path / "w.csv"
    p.write_text(text, encoding="utf-8")
    w = check(p)
    if w is not None:
        build(w, blend, size, True)

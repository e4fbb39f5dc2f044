"""RSI CSV: bit-exact round trip, SI conversion, and the reader's refusals."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from feedopt.errors import InputError
from feedopt.export.job import ControllerSamples
from feedopt.export.rsi import COLUMNS, RsiTable, read_rsi_csv, rsi_table_from_si, write_rsi_csv
from feedopt.robot.kuka import rotation_from_abc
from feedopt.schedule.trajectory import Motion

finite = st.floats(allow_nan=False, allow_infinity=False, allow_subnormal=True, width=64)


@st.composite
def tables(draw):
    times = draw(st.lists(finite, min_size=1, max_size=25, unique=True))
    t = np.sort(np.array(times, dtype=float))
    n = t.shape[0]
    rest = draw(hnp.arrays(np.float64, (n, len(COLUMNS) - 1), elements=finite))
    return RsiTable.from_matrix(np.column_stack([t, rest]))


def test_columns_match_design_order():
    expected = (
        "t_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,"
        "s_mm,feed_mm_s,accel_mm_s2,jerk_mm_s3,deflection_mm"
    )
    assert ",".join(COLUMNS) == expected


@settings(max_examples=60, deadline=None)
@given(table=tables(), comments=st.lists(st.text(), max_size=3))
def test_round_trip_is_bit_exact(tmp_path_factory, table, comments):
    path = tmp_path_factory.mktemp("rsi") / "law.csv"
    write_rsi_csv(path, table, comments)
    back = read_rsi_csv(path)
    assert back.equals(table)
    # bit-exact includes the sign of zero and subnormals
    assert np.array_equal(back.as_matrix().view(np.uint64), table.as_matrix().view(np.uint64))


def test_header_documents_units_and_cycle(tmp_path):
    t = np.arange(5) * 0.004
    z = np.zeros(5)
    table = RsiTable(t, z, z, z, z, z, z, np.zeros((5, 6)), z, z, z, z, z)
    path = write_rsi_csv(tmp_path / "a.csv", table, ["scenario: triangle_slot", "law: thesis"])
    text = path.read_text()
    head = [ln for ln in text.splitlines() if ln.startswith("#")]
    joined = "\n".join(head)
    for word in ("robot base frame", "Z-Y'-X''", "[mm]", "[deg]", "cycle_s: 0.004",
                 "law: thesis"):
        assert word in joined
    assert text.splitlines()[len(head)] == ",".join(COLUMNS)


def test_from_si_converts_units_and_keeps_the_rotation():
    rng = np.random.default_rng(3)
    n = 50
    # Tool pointing down with C wandering across +-180 deg: the raw angles would jump by 360.
    abc = np.column_stack([np.linspace(-170, 190, n), rng.uniform(-30, 30, n),
                           180 + rng.uniform(-5, 5, n)])
    rot = rotation_from_abc(abc)
    p = rng.normal(size=(n, 3))
    q = rng.normal(size=(n, 6))
    s = np.linspace(0, 0.1, n)
    t = np.linspace(0, 1, n)
    samples = ControllerSamples(motion=Motion(t=t, s=s, sdot=s * 2, sddot=s * 3,
                                              sdddot=np.zeros(n)),
                                jerk=s * 4, joint_velocity=np.zeros((n, 6)))
    tab = rsi_table_from_si(samples, p, rot, q, s * 5)
    np.testing.assert_allclose(tab.x_mm, p[:, 0] * 1e3)
    np.testing.assert_allclose(tab.q_deg, np.degrees(q))
    np.testing.assert_allclose(tab.deflection_mm, s * 5e3)
    np.testing.assert_allclose(tab.jerk_mm_s3, s * 4e3)  # the samples' jerk, not motion.sdddot
    abc_out = np.column_stack([tab.a_deg, tab.b_deg, tab.c_deg])
    np.testing.assert_allclose(rotation_from_abc(abc_out), rot, atol=1e-12)
    assert np.max(np.abs(np.diff(tab.a_deg))) < 20 and np.max(np.abs(np.diff(tab.c_deg))) < 20


def test_table_arrays_are_read_only_copies():
    a = np.zeros(3)
    tab = RsiTable(a, a, a, a, a, a, a, np.zeros((3, 6)), a, a, a, a, a)
    a[0] = 1.0
    assert tab.t_s[0] == 0.0
    with pytest.raises(ValueError):
        tab.x_mm[0] = 2.0
    with pytest.raises(ValueError, match="q_deg"):  # more joints than any robot read
        RsiTable(a, a, a, a, a, a, a, np.zeros((3, 13)), a, a, a, a, a)
    with pytest.raises(ValueError, match="q_deg"):
        RsiTable(a, a, a, a, a, a, a, np.zeros(3), a, a, a, a, a)
    seven = RsiTable(a, a, a, a, a, a, a, np.zeros((3, 7)), a, a, a, a, a)  # a 7-axis arm
    assert RsiTable.from_matrix(seven.as_matrix()).equals(seven)


def test_writer_refuses_an_empty_table(tmp_path):
    e = np.zeros(0)
    with pytest.raises(ValueError, match="empty"):
        write_rsi_csv(tmp_path / "e.csv", RsiTable(e, e, e, e, e, e, e, np.zeros((0, 6)), e, e,
                                                    e, e, e))


def test_writer_refuses_non_finite(tmp_path):
    a = np.zeros(3)
    bad = a.copy()
    bad[1] = np.nan
    tab = RsiTable(a + np.arange(3), a, a, a, a, a, a, np.zeros((3, 6)), a, bad, a, a, a)
    with pytest.raises(ValueError, match="feed_mm_s.*row 1"):
        write_rsi_csv(tmp_path / "x.csv", tab)
    assert not (tmp_path / "x.csv").exists()


def _good_lines():
    return ["# comment", ",".join(COLUMNS),
            ",".join(["0.0"] + ["1.5"] * (len(COLUMNS) - 1)),
            ",".join(["0.004"] + ["2.5"] * (len(COLUMNS) - 1))]


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda ls: ls.__setitem__(1, ls[1].replace("y_mm", "Y")), r":2: header column 3 is 'Y'"),
        (lambda ls: ls.__setitem__(1, ls[1] + ",extra"), r":2: header has 19 columns"),
        (lambda ls: ls.__setitem__(3, ls[3] + ",1"), r":4: row has 19 fields"),
        (lambda ls: ls.__setitem__(3, ls[3].replace("2.5", "abc", 1)),
         r":4: column 'x_mm' \(field 2\) is 'abc'"),
        (lambda ls: ls.__setitem__(2, ls[2][:-3] + "nan"),
         r":3: column 'deflection_mm' .* must be finite"),
        (lambda ls: ls.__setitem__(3, "0.0" + ls[3][5:]), r":4: column 't_s' is 0.0"),
        (lambda ls: ls.__delitem__(slice(1, 4)), r"no header row"),
        (lambda ls: ls.__delitem__(slice(2, 4)), r"no data rows"),
    ],
)
def test_reader_errors_name_line_and_column(tmp_path, edit, message):
    lines = _good_lines()
    edit(lines)
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=message):
        read_rsi_csv(path)


def test_reader_accepts_the_good_file_and_crlf(tmp_path):
    path = tmp_path / "ok.csv"
    path.write_bytes(("\r\n".join(_good_lines()) + "\r\n").encode())
    tab = read_rsi_csv(path)
    assert len(tab) == 2 and tab.t_s[1] == 0.004 and tab.q_deg.shape == (2, 6)


def test_reader_missing_file_is_input_error(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_rsi_csv(tmp_path / "nope.csv")

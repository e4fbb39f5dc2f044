"""Calibration (thesis Eq. 3.24-3.25): Table 3.2 -> Table 3.3, and a simulated round trip."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process import (
    CuttingCoefficients,
    SlotForceRow,
    average_forces,
    calibrate,
    feed_from_feed_per_tooth,
    feed_per_tooth,
    milling_forces,
    read_slot_forces,
    rotation_angles,
    slot_engagement,
)

from .conftest import TABLE_3_3, make_tool


def test_table_3_2_gives_table_3_3_within_2_percent(table_3_2):
    cals = calibrate(read_slot_forces(table_3_2), teeth=2, axial_depth=1.27e-3)
    assert [c.rpm for c in cals] == [1000, 2000, 2500]
    for cal in cals:
        got, want = cal.coeffs.as_array(), TABLE_3_3[int(cal.rpm)].as_array()
        np.testing.assert_allclose(got, want, rtol=0.02, err_msg=f"{cal.rpm} rpm")
        assert np.all(cal.r2 > 0.9) and np.all(cal.r2 <= 1)


def test_table_3_3_reproduces_table_3_2_averages_and_signs(table_3_2):
    """Eq. 3.25 sign convention: the closed-form slot average with Table 3.3 gives the
    measured signs (Fx < 0, Fy > 0, Fz < 0) and magnitudes within the fit scatter."""
    tool = make_tool()
    for row in read_slot_forces(table_3_2):
        c = feed_per_tooth(row.feed, row.rpm, 2)
        f = average_forces(tool, TABLE_3_3[int(row.rpm)], 0.0, np.pi, 1.27e-3, c)
        measured = np.array([row.fx, row.fy, row.fz])
        assert np.all(np.sign(f) == np.sign(measured))
        assert np.all(np.abs(f - measured) < 2.0), (row, f)
    # the worked example of the brief: 2500 rpm, 4.23 mm/s
    c = feed_per_tooth(4.23e-3, 2500, 2)
    f = average_forces(tool, TABLE_3_3[2500], 0.0, np.pi, 1.27e-3, c)
    np.testing.assert_allclose(f, [-18.65, 37.03, -6.45], rtol=0.04)


def test_round_trip_simulated_slots_recover_coefficients():
    """Average the *simulated* (numeric, helical) slot forces at four feeds, calibrate, and
    recover the coefficients within 0.5 %."""
    tool = make_tool(helix_deg=30)
    true = CuttingCoefficients(7.0e8, 2.6e8, -0.9e8, 9.0e3, 11.0e3, -2.5e3)
    rpm, a = 3000.0, 2.0e-3
    c = np.array([0.02, 0.05, 0.08, 0.11]) * 1e-3
    split = milling_forces(tool, true, slot_engagement(1, a), rotation_angles(720, midpoint=True))
    rows = []
    for ci in c:
        fx, fy, fz = split.forces(ci)[0].mean(axis=0)
        rows.append(SlotForceRow(rpm, feed_from_feed_per_tooth(ci, rpm, 2), fx, fy, fz))
    (cal,) = calibrate(rows, teeth=2, axial_depth=a)
    np.testing.assert_allclose(cal.coeffs.as_array(), true.as_array(), rtol=0.005)
    np.testing.assert_allclose(cal.r2, 1.0, atol=1e-9)


def test_calibration_refuses_single_feed_and_bad_depth(tmp_path):
    rows = [SlotForceRow(1000, 1e-3, -10, 20, -5), SlotForceRow(1000, 1e-3, -11, 21, -5)]
    with pytest.raises(InputError, match="1000 rpm.*two or more different feeds"):
        calibrate(rows, 2, 1e-3)
    with pytest.raises(InputError, match="axial depth"):
        calibrate(rows, 2, 0.0)
    with pytest.raises(InputError, match="teeth"):
        calibrate(rows, 0, 1e-3)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("spindle_rpm,feed_mm_s,fx_n,fy_n\n1000,1,2,3\n", "missing column.*fz_n"),
        ("spindle_rpm,feed_mm_s,fx_n,fy_n,fz_n\n1000,abc,2,3,4\n", "row 1: feed_mm_s"),
        ("spindle_rpm,feed_mm_s,fx_n,fy_n,fz_n\n0,1,2,3,4\n", "must be > 0"),
        ("# only a comment\n", "no header"),
        ("spindle_rpm,feed_mm_s,fx_n,fy_n,fz_n\n", "no data rows"),
        ("spindle_rpm,feed_mm_s,fx_n,fy_n,fz_n\n1000,1,2,3,4\n1000,2,3,4,5,6\n", "row 2: 6 fields"),
    ],
)
def test_bad_forces_csv(tmp_path, text, match):
    p = tmp_path / "f.csv"
    p.write_text(text)
    with pytest.raises(InputError, match=match):
        read_slot_forces(p)


def test_shipped_table_3_2_is_the_shared_data() -> None:
    from tests.process.conftest import SHARED_TABLE_3_2, TABLE_3_2

    if not SHARED_TABLE_3_2.is_file():
        pytest.skip(f"no shared/ beside the repository ({SHARED_TABLE_3_2}); the tests use "
                    f"their own copy {TABLE_3_2}")
    assert TABLE_3_2.read_bytes() == SHARED_TABLE_3_2.read_bytes()

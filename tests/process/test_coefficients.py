"""Coefficient files: sign rules (thesis 3.6.1), the optional calibrated feed-per-tooth range
and :func:`feed_per_tooth_warning`."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from feedopt.errors import InputError
from feedopt.process import feed_per_tooth, load_coefficients
from feedopt.process.calibration import read_slot_forces
from feedopt.process.coefficients import (
    CoefficientTable,
    CuttingCoefficients,
    feed_per_tooth_warning,
    save_coefficients,
    sign_problems,
)

from .conftest import MATERIAL_YAML, TABLE_3_3

ROW = {"ktc_n_m2": 8.57e8, "krc_n_m2": 3.19e8, "kac_n_m2": -1.05e8, "kte_n_m": 7.42e3,
       "kre_n_m": 8.45e3, "kae_n_m": -2.13e3}  # fmt: skip


def _write(tmp_path, second: dict, extra: dict | None = None):
    doc = {"material": "test", **(extra or {}),
           "speeds": [{"rpm": 1000, **ROW}, {"rpm": 2000, **ROW, **second}]}  # fmt: skip
    p = tmp_path / "coeffs.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return p


@pytest.mark.parametrize(
    ("field", "value", "rule"),
    [
        ("ktc_n_m2", -8.57e8, "must be > 0"),
        ("ktc_n_m2", 0.0, "must be > 0"),
        ("krc_n_m2", -1.0, "must be > 0"),
        ("krc_n_m2", 0.0, "must be > 0"),
        ("kte_n_m", -7.42e3, "must be >= 0"),
        ("kre_n_m", -1e-3, "must be >= 0"),
    ],
)
def test_unphysical_sign_refused_naming_file_entry_and_field(tmp_path, field, value, rule):
    p = _write(tmp_path, {field: value})
    with pytest.raises(InputError) as exc:
        load_coefficients(p)
    msg = str(exc.value)
    assert f"coefficients file {str(p)!r}: speeds[1] (rpm 2000): {field} = {value:.6g}" in msg
    assert rule in msg
    assert "Kac and Kae may have either sign" in msg and "Eq. 3.25" in msg


def test_all_sign_problems_listed_at_once(tmp_path):
    p = _write(tmp_path, {"ktc_n_m2": -1e8, "kre_n_m": -5.0})
    with pytest.raises(InputError, match=r"ktc_n_m2 = -1e\+08 N/m\^2 .*; kre_n_m = -5 N/m"):
        load_coefficients(p)


def test_zero_edge_and_any_axial_sign_allowed(tmp_path):
    p = _write(tmp_path, {"kte_n_m": 0.0, "kre_n_m": 0.0, "kac_n_m2": 2e8, "kae_n_m": 3e3})
    table = load_coefficients(p)
    k = table.at(2000)
    assert (k.kte, k.kre, k.kac, k.kae) == (0.0, 0.0, 2e8, 3e3)
    assert table.at(1000).kac == -1.05e8


def test_sign_problems_helper():
    assert sign_problems(TABLE_3_3[2000]) == []
    bad = CuttingCoefficients(-1.0, 0.0, 5.0, -2.0, 0.0, 7.0)
    names = [p.split(" = ")[0] for p in sign_problems(bad)]
    assert names == ["ktc_n_m2", "krc_n_m2", "kte_n_m"]


def test_range_is_optional_and_in_si(tmp_path):
    assert load_coefficients(_write(tmp_path, {})).feed_per_tooth_range is None
    p = _write(tmp_path, {}, {"feed_per_tooth_range_mm": [0.02, 0.125]})
    lo, hi = load_coefficients(p).feed_per_tooth_range
    assert lo == pytest.approx(0.02e-3) and hi == pytest.approx(0.125e-3)


@pytest.mark.parametrize("bad", [[0.1, 0.02], [0, 0.1], [-0.01, 0.1], [0.1], "0.02..0.1",
                                 [0.02, "x"], [0.02, float("inf")]])  # fmt: skip
def test_bad_range_refused(tmp_path, bad):
    p = _write(tmp_path, {}, {"feed_per_tooth_range_mm": bad})
    with pytest.raises(InputError, match=r"feed_per_tooth_range_mm"):
        load_coefficients(p)


def test_material_file_range_covers_the_thesis_cuts(table_3_2):
    lo, hi = load_coefficients(MATERIAL_YAML).feed_per_tooth_range
    rows = read_slot_forces(table_3_2)
    c = np.array([feed_per_tooth(r.feed, r.rpm, 2) for r in rows])
    # the file's numbers are the extreme cuts (2000 rpm, 1.27 and 8.47 mm/s), to 1e-6 mm
    assert lo == pytest.approx(c.min(), abs=1e-9) and hi == pytest.approx(c.max(), abs=1e-9)
    assert c.min() == pytest.approx(1.27e-3 * 60 / 4000)


def test_feed_per_tooth_warning():
    table = CoefficientTable.from_speeds(
        {2000: TABLE_3_3[2000]}, material="6061", feed_per_tooth_range=(0.019e-3, 0.127e-3)
    )
    assert feed_per_tooth_warning(table, 0.0635e-3) is None
    assert feed_per_tooth_warning(table, 0.019e-3) is None  # the ends are inside
    assert feed_per_tooth_warning(table, 0.127e-3 * (1 + 1e-7)) is None  # file rounding
    above = feed_per_tooth_warning(table, 0.6e-3)
    assert above == (
        "feed per tooth 0.6 mm is above the range the cutting coefficients of '6061' were "
        "calibrated for (0.019..0.127 mm per tooth); the linear force model (thesis Eq. 3.24) "
        "is extrapolated there and the forces may be wrong"
    )
    below = feed_per_tooth_warning(table, 0.0075e-3)
    assert below.startswith("feed per tooth 0.0075 mm is below the range")
    unknown = CoefficientTable.from_speeds({2000: TABLE_3_3[2000]})
    assert unknown.feed_per_tooth_range is None
    assert feed_per_tooth_warning(unknown, 1.0) is None


def test_table_refuses_bad_range():
    with pytest.raises(InputError, match=r"0 < min <= max, got \[0.2, 0.1\] mm"):
        CoefficientTable.from_speeds({2000: TABLE_3_3[2000]},
                                     feed_per_tooth_range=(0.2e-3, 0.1e-3))  # fmt: skip


def test_save_load_round_trip_keeps_range(tmp_path):
    rng = (1.905126456e-5, 1.270512345e-4)  # lo rounds up, hi rounds down in the file
    table = CoefficientTable.from_speeds({2000: TABLE_3_3[2000]}, feed_per_tooth_range=rng)
    p = tmp_path / "c.yaml"
    save_coefficients(table, p)
    text = p.read_text()
    assert text.startswith("# feed_per_tooth_range_mm: smallest and largest feed per tooth")
    assert "feed_per_tooth_range_mm:\n- 0.0190513\n- 0.127051\n" in text
    back = load_coefficients(p)
    lo, hi = back.feed_per_tooth_range
    assert lo == pytest.approx(rng[0], rel=5e-6) and hi == pytest.approx(rng[1], rel=5e-6)
    # the rounding never turns the extreme cuts into warnings
    assert feed_per_tooth_warning(back, rng[0]) is None
    assert feed_per_tooth_warning(back, rng[1]) is None
    assert feed_per_tooth_warning(back, rng[1] * 1.001) is not None
    save_coefficients(CoefficientTable.from_speeds({2000: TABLE_3_3[2000]}), p)
    assert "feed_per_tooth_range" not in p.read_text()
    assert load_coefficients(p).feed_per_tooth_range is None

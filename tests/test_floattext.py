"""Float rows as CSV text: every field reads back to the same bits, with repr's digit count."""

from __future__ import annotations

import io
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt import floattext
from feedopt.floattext import format_float_rows, write_float_rows

_NUMBER = re.compile(r"^-?(\d+)(?:\.(\d+))?(?:e[+-]?\d+)?$")


def significant_digits(text: str) -> str:
    """The significant digits of a decimal spelling (no sign, point, exponent or padding)."""
    m = _NUMBER.match(text)
    assert m, f"{text!r} is not a plain decimal number"
    digits = (m.group(1) + (m.group(2) or "")).strip("0")
    return digits or "0"


def check_field(field: str, value: float) -> None:
    """``field`` reads back to exactly ``value`` and is as short as Python's repr (shortest)."""
    back = float(field)
    assert np.float64(back).tobytes() == np.float64(value).tobytes(), (field, value)
    assert len(significant_digits(field)) == len(significant_digits(repr(value))), (field, value)


SPECIAL = [0.0, -0.0, 1e16, 1e-5, 123456789.0, 5e-324, 1.7976931348623157e308, 0.1, 1 / 3, -2.5,
           1e22, 1e-7, 4.23, 0.29, 9.999999999999999e-5, 1e15, 2.0, 2.2250738585072014e-308,
           0.004 * 36499, 1e23, 9007199254740993.0]


def test_special_values_read_back_and_are_shortest():
    m = np.array(SPECIAL).reshape(3, 7)
    lines = format_float_rows(m).split("\n")
    assert lines[-1] == "" and len(lines) == 4
    for row, line in zip(m, lines[:-1], strict=True):
        fields = line.split(",")
        assert len(fields) == 7
        for field, value in zip(fields, row, strict=True):
            check_field(field, float(value))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.integers(0, 2**64 - 1), min_size=1, max_size=40), st.integers(1, 5))
def test_any_finite_bit_pattern_reads_back(bits, ncol):
    values = np.array(bits, dtype=np.uint64).view(np.float64)
    values = values[np.isfinite(values)]
    values = values[: values.size // ncol * ncol].reshape(-1, ncol)
    text = format_float_rows(values)
    assert text.count("\n") == values.shape[0]
    for row, line in zip(values, text.splitlines(), strict=True):
        for field, value in zip(line.split(","), row, strict=True):
            check_field(field, float(value))


@pytest.mark.parametrize("block", [7, 1 << 14])
def test_blocks_give_the_same_text(monkeypatch, block):
    monkeypatch.setattr(floattext, "ROWS_PER_BLOCK", block)
    m = np.random.default_rng(3).normal(size=(50, 4)) * 1e3
    f = io.StringIO()
    write_float_rows(f, m)
    expected = "".join(",".join(repr(float(v)) for v in row) + "\n" for row in m)
    # normal-sized values have one spelling: the bytes equal repr's
    assert f.getvalue() == expected


def test_non_finite_and_wrong_shape_are_refused():
    with pytest.raises(ValueError, match="non-finite"):
        format_float_rows(np.array([[1.0, np.nan]]))
    with pytest.raises(ValueError, match="non-finite"):
        format_float_rows(np.array([[np.inf]]))
    with pytest.raises(ValueError, match="2-D"):
        format_float_rows(np.array([1.0, 2.0]))
    assert format_float_rows(np.zeros((0, 3))) == ""


def test_non_contiguous_and_integer_input():
    m = np.arange(12, dtype=np.int64).reshape(3, 4)
    assert format_float_rows(m[:, ::2]) == "0.0,2.0\n4.0,6.0\n8.0,10.0\n"


def test_refuse_non_finite_names_the_first_bad_value() -> None:
    from feedopt.floattext import refuse_non_finite

    m = np.zeros((4, 3))
    refuse_non_finite(m, ("a", "b", "c"), "table", "x.csv")  # finite: nothing
    m[2, 1], m[3, 0] = np.inf, np.nan
    with pytest.raises(ValueError, match=r"table has a non-finite value inf in column 'b', row 2; "
                                         r"refusing to write x.csv"):
        refuse_non_finite(m, ("a", "b", "c"), "table", "x.csv")

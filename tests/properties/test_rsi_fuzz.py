"""Property: an RSI CSV is either a table of finite values with strictly increasing time, or
one InputError; a file write_rsi_csv wrote reads back equal."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.export.rsi import COLUMNS, RsiTable, read_rsi_csv, write_rsi_csv

from ._support import budget, text_mutations


def _table(n: int = 5) -> RsiTable:
    m = np.linspace(0.0, 1.0, n * len(COLUMNS)).reshape(n, len(COLUMNS)) * 100.0 - 3.0
    m[:, 0] = np.arange(n) * 0.004
    return RsiTable.from_matrix(m)


def _valid_text(tmp_path) -> str:
    p = write_rsi_csv(tmp_path / "valid.csv", _table(), comments=["law jerk", "\u00e9t\u00e9"])
    return p.read_text()


def check(path):
    try:
        table = read_rsi_csv(path)
    except InputError as exc:
        assert str(exc).strip()
        return None
    assert isinstance(table, RsiTable) and len(table) >= 1
    m = table.as_matrix()
    assert m.shape[1] == len(COLUMNS) and np.all(np.isfinite(m))
    assert np.all(np.diff(m[:, 0]) > 0)
    return table


def test_round_trip(tmp_path):
    p = tmp_path / "valid.csv"
    p.write_text(_valid_text(tmp_path))
    assert read_rsi_csv(p).equals(_table())


field = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                  st.sampled_from(["", "nan", "inf", "-inf", "1e999", "x", "0x10", "1_0",
                                   "\u0663", " 1 ", "1e", "1.0.0", "--0"]))


@budget(120)
@given(data=st.data())
def test_mutated_valid_file(tmp_path, data):
    text = data.draw(text_mutations(_valid_text(tmp_path),
                                    alphabet=list("0123456789.,-+eE#\n\r nai")))
    p = tmp_path / "m.csv"
    p.write_text(text, encoding="utf-8", errors="surrogatepass")
    check(p)


@budget(80)
@given(data=st.data(), row=st.integers(0, 4), col=st.integers(0, len(COLUMNS) - 1),
       value=field)
def test_one_field_replaced(tmp_path, data, row, col, value):
    lines = _valid_text(tmp_path).splitlines()
    first = next(i for i, ln in enumerate(lines) if not ln.startswith("#")) + 1
    parts = lines[first + row].split(",")
    parts[col] = value
    lines[first + row] = ",".join(parts)
    p = tmp_path / "m.csv"
    p.write_text("\n".join(lines) + "\n")
    check(p)


@budget(60)
@given(raw=st.binary(max_size=300), where=st.floats(0, 1))
def test_random_bytes(tmp_path, raw, where):
    valid = _valid_text(tmp_path).encode()
    k = int(where * len(valid))
    p = tmp_path / "m.csv"
    for content in (raw, valid[:k] + raw + valid[k:]):
        p.write_bytes(content)
        check(p)

"""The RSI CSV writer's bytes: # lines, header, one shortest round-trip decimal per value."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt import floattext
from feedopt.export import rsi
from feedopt.export.rsi import COLUMNS, RsiTable, read_rsi_csv, write_rsi_csv
from tests.test_floattext import check_field


def _reference_head(table: RsiTable, comments) -> list[str]:
    """The lines before the data as the writer is specified (module docstring)."""
    lines = [f"# {c}" for c in rsi._HEADER_DOC]
    lines.append(f"# {rsi._cycle_comment(table.t_s)}")
    lines += [f"# {c}" for c in comments]
    lines.append(",".join(COLUMNS))
    return lines


@pytest.mark.parametrize("block", [7, 1 << 14])
def test_written_bytes_are_the_shortest_decimal_of_every_value(tmp_path, monkeypatch, block):
    monkeypatch.setattr(floattext, "ROWS_PER_BLOCK", block)
    rng = np.random.default_rng(5)
    n = 50
    m = rng.normal(size=(n, len(COLUMNS))) * 10.0 ** rng.integers(-20, 20, (n, len(COLUMNS)))
    m[:, 0] = np.cumsum(rng.uniform(0.001, 0.01, n))  # increasing times
    m[3, 1:] = [-0.0, 0.0, 1e16, 1e-5, 123456789.0, 5e-324, 1.7976931348623157e308, 0.1,
                1 / 3, -2.5, 1e22, 1e-7, 4.23, 0.29, 9.999999999999999e-5, 1e15, 2.0]
    table = RsiTable.from_matrix(m)
    path = write_rsi_csv(tmp_path / "t.csv", table, comments=["law jerk", "two words"])
    raw = path.read_bytes()
    assert raw.endswith(b"\n") and b"\r" not in raw
    lines = raw.decode("ascii").split("\n")[:-1]
    head = _reference_head(table, ["law jerk", "two words"])
    assert lines[:len(head)] == head
    data = lines[len(head):]
    assert len(data) == n
    for row, line in zip(table.as_matrix(), data, strict=True):
        fields = line.split(",")
        assert len(fields) == len(COLUMNS)
        for field, value in zip(fields, row, strict=True):
            check_field(field, float(value))
    assert read_rsi_csv(path).equals(table)  # and it reads back bit for bit

"""Rows of floats as CSV text that reads back bit for bit, fast enough for a controller file.

A controller file of a 3-hour job at the 4 ms RSI cycle has about 2.7 M rows x 18 columns.
Python's ``repr`` of each value costs 0.4-0.7 us, most of the export time of a run; orjson
(https://github.com/ijl/orjson) serialises a float64 array with the shortest round-trip decimal
of every value (Ryu-style) in C, about 17x faster. So every value is the shortest decimal that
``float()`` turns back into the same bits, as with ``repr``; only the spelling of exponents may
differ from ``repr`` (``1e-05`` from ``repr`` is ``0.00001`` here) and between orjson
releases, never the value.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TextIO

import numpy as np
import orjson

#: Rows formatted at a time: the text of a long job's file is never held in memory at once.
ROWS_PER_BLOCK = 1 << 14


def refuse_non_finite(m: np.ndarray, columns: Sequence[str], what: str, path: object) -> None:
    """``ValueError`` naming the first non-finite value of ``m`` (rows x ``columns``): its
    column and row, and the file ``path`` not written (a controller file must not hold
    NaN or inf). Call it before opening the file, so nothing is half written."""
    bad = ~np.isfinite(m)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise ValueError(
            f"{what} has a non-finite value {float(m[row, col])!r} in column "
            f"{columns[col]!r}, row {row}; refusing to write {path}")


def format_float_rows(m: np.ndarray) -> str:
    """CSV text of the rows of the 2-D array ``m``, one line each, ending with a newline.

    Every value is the shortest decimal that reads back (``float``) to the same float64.
    Raises ``ValueError`` for a non-finite value (JSON has no spelling for it) or a non-2-D
    array; the writers call :func:`refuse_non_finite` first, which names the column and row.
    """
    m = np.ascontiguousarray(m, dtype=np.float64)
    if m.ndim != 2:
        raise ValueError(f"rows of floats must be a 2-D array, got shape {m.shape}")
    if m.shape[0] == 0:
        return ""
    if m.shape[1] == 0:
        return "\n" * m.shape[0]
    if not np.isfinite(m).all():
        raise ValueError("rows of floats contain a non-finite value")
    # orjson writes [[a,b],[c,d]]: drop the outer brackets and turn "],[" into line ends.
    text = orjson.dumps(m, option=orjson.OPT_SERIALIZE_NUMPY)[2:-2].replace(b"],[", b"\n")
    return text.decode("ascii") + "\n"


def write_float_rows(f: TextIO, m: np.ndarray) -> None:
    """Write the rows of ``m`` to the open text file ``f`` block by block (see
    :func:`format_float_rows`)."""
    for start in range(0, m.shape[0], ROWS_PER_BLOCK):
        f.write(format_float_rows(m[start:start + ROWS_PER_BLOCK]))

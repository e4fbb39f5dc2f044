"""Waypoints from a CSV file with a header naming the columns x_mm, y_mm, z_mm."""

from __future__ import annotations

import csv
import math
from pathlib import Path as FilePath

import numpy as np

from feedopt.errors import InputError
from feedopt.textio import read_user_text
from feedopt.units import MM

COLUMNS = ("x_mm", "y_mm", "z_mm")
#: Largest waypoint coordinate accepted [mm]: 100 m, beyond the reach of any robot cell (the
#: largest arms reach about 4 m, linear tracks tens of metres). Larger values are typos or unit
#: mistakes, and near 1e308 they overflow the geometry.
MAX_COORDINATE_MM = 1e5


def read_waypoints_csv(path: str | FilePath) -> np.ndarray:
    """Read waypoints [mm] and return them in metres, shape (n, 3).

    The header must contain ``x_mm``, ``y_mm`` and ``z_mm`` (any order; other columns are
    ignored). Blank lines and lines starting with ``#`` are skipped. Every value must be a
    finite number; errors name the file line and column.
    """
    p = FilePath(path)
    text = read_user_text(p, "waypoint file", encoding="utf-8-sig")
    lines = [(no, ln) for no, ln in enumerate(text.splitlines(), start=1)
             if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError(f"waypoint file {p} is empty; expected a header {','.join(COLUMNS)}")
    rows = list(csv.reader([ln for _, ln in lines]))
    header = [h.strip() for h in rows[0]]
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise InputError(
            f"{p}: header {header} lacks column(s) {', '.join(missing)}; expected "
            f"{','.join(COLUMNS)} (millimetres)")
    cols = [header.index(c) for c in COLUMNS]
    out = np.empty((len(rows) - 1, 3))
    for r, (row, (no, _)) in enumerate(zip(rows[1:], lines[1:], strict=True)):
        if len(row) != len(header):
            raise InputError(f"{p} line {no}: {len(row)} values, the header has {len(header)}")
        for k, c in enumerate(cols):
            try:
                v = float(row[c])
            except ValueError:
                raise InputError(
                    f"{p} line {no}, column {COLUMNS[k]}: {row[c].strip()!r} is not a number"
                ) from None
            if not math.isfinite(v):
                raise InputError(f"{p} line {no}, column {COLUMNS[k]}: value {v} is not finite")
            if abs(v) > MAX_COORDINATE_MM:
                raise InputError(
                    f"{p} line {no}, column {COLUMNS[k]}: {v:g} mm is beyond any robot's reach "
                    f"(|value| <= {MAX_COORDINATE_MM:g} mm); are the units millimetres?")
            out[r, k] = v
    if len(out) < 2:
        raise InputError(f"{p}: a path needs at least two waypoints, found {len(out)}")
    return out * MM

"""Waypoints from a CSV file with a header naming the columns x_mm, y_mm, z_mm."""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path as FilePath

import numpy as np

from feedopt.errors import InputError
from feedopt.textio import read_user_text
from feedopt.units import MM

COLUMNS = ("x_mm", "y_mm", "z_mm")
#: the tool-vector columns of a five-axis waypoint file
TOOL_VECTOR_COLUMNS = ("i", "j", "k")
#: Largest waypoint coordinate accepted [mm]: 100 m, beyond the reach of any robot cell (the
#: largest arms reach about 4 m, linear tracks tens of metres). Larger values are typos or unit
#: mistakes, and near 1e308 they overflow the geometry.
MAX_COORDINATE_MM = 1e5


def _table(p: FilePath) -> tuple[list[str], list[list[str]], list[int]]:
    """(header, value rows, their file line numbers) of the CSV ``p``."""
    text = read_user_text(p, "waypoint file", encoding="utf-8-sig")
    lines = [(no, ln) for no, ln in enumerate(text.splitlines(), start=1)
             if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError(f"waypoint file {p} is empty; expected a header {','.join(COLUMNS)}")
    rows = list(csv.reader([ln for _, ln in lines]))
    header = [h.strip() for h in rows[0]]
    for row, (no, _) in zip(rows[1:], lines[1:], strict=True):
        if len(row) != len(header):
            raise InputError(f"{p} line {no}: {len(row)} values, the header has {len(header)}")
    return header, rows[1:], [no for no, _ in lines[1:]]


def _column(p: FilePath, header: list[str], rows: list[list[str]], numbers: list[int],
            name: str, limit: float, coordinate: bool = True) -> np.ndarray:
    """The finite values of column ``name`` (|value| <= ``limit``), errors naming the line
    (a ``coordinate`` in mm, else a tool-vector component)."""
    c = header.index(name)
    out = np.empty(len(rows))
    for r, (row, no) in enumerate(zip(rows, numbers, strict=True)):
        try:
            v = float(row[c])
        except ValueError:
            raise InputError(
                f"{p} line {no}, column {name}: {row[c].strip()!r} is not a number") from None
        if not math.isfinite(v):
            raise InputError(f"{p} line {no}, column {name}: value {v} is not finite")
        if abs(v) > limit and not coordinate:
            raise InputError(
                f"{p} line {no}, column {name}: {v:g} is no plausible tool-vector component "
                f"(|value| <= {limit:g}; the vector is normalised, so any length up to that "
                "gives the same direction)")
        if abs(v) > limit:
            raise InputError(
                f"{p} line {no}, column {name}: {v:g} mm is beyond any robot's reach "
                f"(|value| <= {limit:g} mm); are the units millimetres?")
        out[r] = v
    return out


def read_waypoints_csv(path: str | FilePath) -> np.ndarray:
    """Read waypoints [mm] and return them in metres, shape (n, 3).

    The header must contain ``x_mm``, ``y_mm`` and ``z_mm`` (any order; other columns are
    ignored, except that tool vectors ``i, j, k`` are read by :func:`read_tool_vectors_csv`).
    Blank lines and lines starting with ``#`` are skipped. Every value must be a finite
    number; errors name the file line and column.
    """
    p = FilePath(path)
    header, rows, numbers = _table(p)
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise InputError(
            f"{p}: header {header} lacks column(s) {', '.join(missing)}; expected "
            f"{','.join(COLUMNS)} (millimetres)")
    out = np.column_stack([_column(p, header, rows, numbers, c, MAX_COORDINATE_MM)
                           for c in COLUMNS]) if rows else np.empty((0, 3))
    if len(out) < 2:
        raise InputError(f"{p}: a path needs at least two waypoints, found {len(out)}")
    return out * MM


def read_tool_vectors_csv(path: str | FilePath) -> np.ndarray | None:
    """The tool vectors of a five-axis waypoint file: columns ``i, j, k`` (from the tool tip
    into the spindle, in the workpiece frame; normalised), shape (n, 3); None when the file
    has none of them. InputError for only some of the three or a vector of length zero."""
    p = FilePath(path)
    header, rows, numbers = _table(p)
    present = [c for c in TOOL_VECTOR_COLUMNS if c in header]
    near = [h for h in header if h not in TOOL_VECTOR_COLUMNS
            and re.fullmatch(r"(tool_?)?[ijk](_[a-z0-9]*)?", h.lower())]
    if near:
        raise InputError(f"{p}: column(s) {', '.join(near)} look like a tool vector, which is "
                         "read from columns named exactly i, j, k (lower case, no unit: the "
                         "vector is normalised); rename them, or remove them for a three-axis "
                         "path")
    if not present:
        return None
    if len(present) < 3:
        raise InputError(f"{p}: a tool vector needs the three columns i, j, k; the header has "
                         f"only {', '.join(present)}")
    v = np.column_stack([_column(p, header, rows, numbers, c, 1e6, coordinate=False)
                         for c in TOOL_VECTOR_COLUMNS])
    norm = np.linalg.norm(v, axis=1)
    if np.any(norm < 1e-9):
        k = int(np.argmin(norm))
        raise InputError(f"{p} line {numbers[k]}: the tool vector (i, j, k) = "
                         f"({', '.join(f'{x:g}' for x in v[k])}) has no direction")
    return v / norm[:, None]

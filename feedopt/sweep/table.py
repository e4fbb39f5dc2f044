"""The sweep table: one CSV row per grid point, appended as points finish.

Columns: the swept values (one per axis, named ``field`` or ``field.component``), ``status``
(ok / refused / error), ``feasible``, ``reason``, ``t_star_s``, ``max_deflection_nominal_mm``,
``mean_deflection_nominal_mm`` (over the cutting samples), ``max_condition_number``,
``min_bound_mm_s``, ``samples``, per law ``<law>.cycle_time_s``, ``<law>.verdict``,
``<law>.max_deflection_mm``, the extra metrics, and ``seconds`` (evaluation time).
Numbers are written with :func:`repr`, so they read back bit-exact.

Each row is written with one ``write`` and flushed to disk before the next point is
counted, so an interrupted sweep (Ctrl-C, a killed process, a power loss) leaves a table
whose complete rows are valid; a torn last line is dropped when the sweep resumes. At the
end the table is rewritten whole (one row per point, grid order) with an atomic replace.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Iterable, Sequence
from pathlib import Path

from feedopt.errors import InputError
from feedopt.outfile import write_atomically
from feedopt.sweep.grid import Axis, point_key
from feedopt.sweep.point import PointResult, Status
from feedopt.sweep.rowcheck import checked_row

LAW_FIELDS = ("cycle_time_s", "verdict", "max_deflection_mm")
POINT_FIELDS = ("status", "feasible", "reason", "t_star_s", "max_deflection_nominal_mm",
                "mean_deflection_nominal_mm", "max_condition_number", "min_bound_mm_s",
                "samples")
#: A table row: column name -> cell text.
Row = dict[str, str]


def columns(axes: Sequence[Axis], laws: Sequence[str], extra: Sequence[str]) -> list[str]:
    """The header of a sweep's table."""
    return ([a.name for a in axes] + list(POINT_FIELDS)
            + [f"{law}.{f}" for law in laws for f in LAW_FIELDS] + list(extra) + ["seconds"])


def _cell(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def to_row(result: PointResult, axes: Sequence[Axis], laws: Sequence[str],
           extra: Sequence[str]) -> Row:
    """The table row of one point."""
    row = {a.name: _cell(v) for a, v in zip(axes, result.values, strict=True)}
    row |= {"status": result.status.value, "feasible": _cell(result.feasible),
            "reason": result.reason}
    for name in POINT_FIELDS[3:]:
        row[name] = _cell(getattr(result, name))
    for law in laws:
        outcome = result.laws.get(law)
        for f in LAW_FIELDS:
            row[f"{law}.{f}"] = _cell(getattr(outcome, f) if outcome is not None else None)
    row |= {name: _cell(result.extra.get(name)) for name in extra}
    row["seconds"] = _cell(result.seconds)
    return row


def _line(header: Sequence[str], row: Row) -> str:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow([row.get(c, "") for c in header])
    return buf.getvalue()


def row_key(row: Row, axes: Sequence[Axis]) -> tuple[float, ...]:
    """The point a row belongs to."""
    return point_key([row[a.name] for a in axes])


def _cut_torn_line(path: Path) -> None:
    """Cut ``path`` back to its last line end (a killed sweep may have torn its last row)."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return
    if data and not data.endswith(b"\n"):
        with open(path, "r+b") as fh:
            fh.truncate(data.rfind(b"\n") + 1)


class Appender:
    """Appends rows to the table, each flushed and synced before :meth:`append` returns."""

    def __init__(self, path: Path, header: Sequence[str]) -> None:
        self.header = list(header)
        _cut_torn_line(path)
        new = not path.exists() or path.stat().st_size == 0
        self._file = open(path, "a", encoding="utf-8", newline="")  # noqa: SIM115
        if new:
            self._write(_line(self.header, dict(zip(self.header, self.header, strict=True))))

    def _write(self, text: str) -> None:
        self._file.write(text)
        self._file.flush()
        os.fsync(self._file.fileno())

    def append(self, row: Row) -> None:
        self._write(_line(self.header, row))

    def close(self) -> None:
        self._file.close()


def read_table(path: Path, header: Sequence[str], axes: Sequence[Axis],
               laws: Sequence[str] = (), extra: Sequence[str] = ()
               ) -> dict[tuple[float, ...], Row]:
    """The rows of an earlier (possibly interrupted) sweep, the last row of each point.

    A torn last line (no line end: the sweep was killed while writing it) is ignored; the
    :class:`Appender` cuts it off before appending. Every other row is checked as feedopt
    writes it (:mod:`feedopt.sweep.rowcheck`).

    Raises
    ------
    InputError
        The table has other columns than this sweep's, or a row feedopt could not have
        written (named by its line number).
    """
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return {}
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the sweep table ({exc}); remove it or start "
                         "over with --restart") from None
    text = text[: text.rfind("\n") + 1]  # a torn last line (no line end) is not a row
    lines = list(csv.reader(io.StringIO(text)))
    if not lines:
        return {}
    if lines[0] != list(header):
        raise InputError(f"{path}: its columns are not this sweep's ({', '.join(lines[0][:6])} "
                         "...): it belongs to a different sweep; choose another --out or start "
                         "over with --restart")
    out: dict[tuple[float, ...], Row] = {}
    for number, cells in enumerate(lines[1:], start=2):
        if len(cells) != len(header):
            raise InputError(f"{path}: row {number} has {len(cells)} cells, not "
                             f"{len(header)}; remove that row or start over with --restart")
        row = checked_row(path, number, dict(zip(header, cells, strict=True)), axes, laws,
                          extra)
        out[row_key(row, axes)] = row
    return out


def done(rows: dict[tuple[float, ...], Row]) -> set[tuple[float, ...]]:
    """Points that need no new evaluation (errors are retried)."""
    return {k for k, r in rows.items() if r.get("status") != Status.ERROR.value}


def write_table(path: Path, header: Sequence[str], rows: Iterable[Row]) -> None:
    """Write the whole table at once (atomic replace)."""
    text = _line(header, dict(zip(header, header, strict=True)))
    text += "".join(_line(header, r) for r in rows)
    write_atomically(path, text, "--out")

"""Rows read back from a sweep's table are checked as strictly as any other input.

A resumed sweep takes the finished rows of ``sweep.csv`` as they are, and names the best point
from them, so a row that feedopt could not have written (an edited T* of ``-inf``, a status
``maybe``, a feasible point whose law failed) would otherwise become a result, or a best.json
that is not JSON. Such a row is refused with its line number (:class:`InputError`, exit 2),
not quietly evaluated again: the table is feedopt's own output, so a row it could not have
written means someone or something else changed it, and the plausible-looking edits of the same
hand cannot be detected; the user is asked to look, remove the row (its point is then evaluated
again) or start over with ``--restart``.

What is checked: every swept value is a finite number; ``status`` is ok / refused / error;
``feasible`` is yes / no, and yes exactly for an ``ok`` row where no law failed; each number is
empty or a finite number in its range (T* and cycle times > 0, deflections >= 0, condition
numbers >= 1, samples a whole number >= 2, seconds >= 0); an ``ok`` row has T*, the
deflections, condition number, lowest bound and samples; a ``refused`` or ``error`` row has no
results but ``seconds``; each law's verdict is a verdict feedopt writes. Extra metrics (API
only) are any number or empty. Of an ``error`` row only the swept values and the status are
checked: it is evaluated again, none of its other cells is used.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from feedopt.errors import InputError
from feedopt.sweep.grid import Axis
from feedopt.sweep.point import DECLINED, VERDICT_TOKENS, Status

#: Column -> (smallest value, whether the smallest is allowed) of the point's numbers.
_POINT_RANGES = {
    "t_star_s": (0.0, False),
    "max_deflection_nominal_mm": (0.0, True),
    "mean_deflection_nominal_mm": (0.0, True),
    "max_condition_number": (1.0, True),
    "min_bound_mm_s": (0.0, True),
    "samples": (2.0, True),
}
_LAW_RANGES = {"cycle_time_s": (0.0, False), "max_deflection_mm": (0.0, True)}
_VERDICTS = {*VERDICT_TOKENS.values(), DECLINED, ""}
_FAILED = "failed"


class BadRow(Exception):
    """A cell that feedopt could not have written (column, what is wrong)."""


def _number(row: dict[str, str], column: str, low: float | None = None,
            inclusive: bool = True) -> float | None:
    """The cell as a finite float (None if empty); BadRow if it is not one in range."""
    text = row[column].strip()
    if not text:
        return None
    try:
        value = float(text)
    except ValueError:
        raise BadRow(f"{column} is {text!r}, not a number") from None
    if not math.isfinite(value):
        raise BadRow(f"{column} is {text!r}; a sweep writes only finite numbers")
    if low is not None and (value < low or (value == low and not inclusive)):
        bound = ">=" if inclusive else ">"
        raise BadRow(f"{column} is {text}; it is always {bound} {low:g}")
    return value


def _check_point_numbers(row: dict[str, str], status: str) -> None:
    values = {c: _number(row, c, *rng) for c, rng in _POINT_RANGES.items()}
    samples = values["samples"]
    if samples is not None and samples != int(samples):
        raise BadRow(f"samples is {row['samples']!r}, not a whole number")
    missing = [c for c, v in values.items() if v is None]
    if status == Status.OK.value and missing:
        raise BadRow(f"an ok row has no {missing[0]}")
    present = [c for c, v in values.items() if v is not None]
    if status != Status.OK.value and present:
        raise BadRow(f"a {status} row has a {present[0]}; only ok rows have results")
    if _number(row, "seconds", 0.0) is None:
        raise BadRow("seconds is empty")


def _check_laws(row: dict[str, str], status: str, laws: Sequence[str]) -> bool:
    """Check each law's cells; True if a law failed its verification."""
    failed = False
    for law in laws:
        verdict = row[f"{law}.verdict"]
        if verdict not in _VERDICTS:
            raise BadRow(f"{law}.verdict is {verdict!r}; feedopt writes one of "
                       f"{', '.join(sorted(v for v in _VERDICTS if v))} (or nothing)")
        numbers = [_number(row, f"{law}.{f}", *rng) for f, rng in _LAW_RANGES.items()]
        planned = verdict in VERDICT_TOKENS.values()
        if status != Status.OK.value and (verdict or any(n is not None for n in numbers)):
            raise BadRow(f"a {status} row has results of {law}; only ok rows have them")
        if planned and any(n is None for n in numbers):
            raise BadRow(f"{law} is {verdict} but has no cycle time or deflection")
        if not planned and any(n is not None for n in numbers):
            raise BadRow(f"{law} has a cycle time or deflection but was not planned "
                       f"(verdict {verdict!r})")
        failed |= verdict == _FAILED
    return failed


def check_row(row: dict[str, str], axes: Sequence[Axis], laws: Sequence[str],
              extra: Sequence[str]) -> None:
    """Raise BadRow if ``row`` is not one feedopt writes (see the module docstring)."""
    for axis in axes:
        if _number(row, axis.name) is None:
            raise BadRow(f"{axis.name} (a swept value) is empty")
    status = row["status"]
    if status not in {s.value for s in Status}:
        raise BadRow(f"status is {status!r}; feedopt writes ok, refused or error")
    if status == Status.ERROR.value:
        return  # evaluated again when the sweep resumes: none of its cells is used
    _check_point_numbers(row, status)
    failed = _check_laws(row, status, laws)
    for name in extra:
        try:
            float(row[name]) if row[name].strip() else None
        except ValueError:
            raise BadRow(f"{name} is {row[name]!r}, not a number") from None
    feasible = row["feasible"]
    if feasible not in ("yes", "no"):
        raise BadRow(f"feasible is {feasible!r}; feedopt writes yes or no")
    should = "yes" if status == Status.OK.value and not failed else "no"
    if feasible != should:
        raise BadRow(f"feasible is {feasible} for a {status} row"
                   + (" where a law failed its verification" if failed else ""))


def checked_row(path: object, number: int, row: dict[str, str], axes: Sequence[Axis],
                laws: Sequence[str], extra: Sequence[str]) -> dict[str, str]:
    """``row`` (line ``number`` of ``path``) if feedopt could have written it; InputError
    naming the line, the cell and what to do otherwise."""
    try:
        check_row(row, axes, laws, extra)
    except BadRow as exc:
        raise InputError(f"{path}: row {number}: {exc}. This table is feedopt's own output and "
                         "this row was changed after it was written; a resumed sweep trusts its "
                         "rows, so it stops here: remove that row (its point is then evaluated "
                         "again) or start over with --restart") from None
    return row
